//! The face's status side: the status words (+8..+22) from the command side and what the robot
//! does.

use super::machine::Face;
use super::{STATUS_WORDS, fault, pallet_bit, status_bit, status_word};
use crate::cell::Mode;

/// Where the robot's cycle stands, as the face shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CyclePhase {
    /// Running a step.
    Running,
    /// Waiting on the cell's inputs.
    Waiting,
    /// Paused (by request, a hold, move-enable).
    Paused,
    /// Faulted.
    Faulted,
    /// Ended (stopped or done): a start may run another.
    Ended,
}

/// The robot's cycle, as the face shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleView {
    /// Where it stands.
    pub phase: CyclePhase,
    /// The step's number, from 1 (0: none).
    pub step: u16,
    /// Cycles done.
    pub done: u64,
}

/// The PLC link, as the face shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Link {
    /// No link (or no status block yet).
    #[default]
    Down,
    /// Linked, but the PLC's heartbeat stands still (stalled, or in PROG mode).
    Stalled,
    /// Linked and running.
    Up,
}

/// The pallet the face shows, as the status words need it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PalletView {
    /// Its count is known (not lost with the pallets file).
    pub known: bool,
    /// The slot to fill next, from 0.
    pub index: usize,
    /// Its slots.
    pub slots: usize,
    /// The next slot's layer, from 0.
    pub layer: usize,
    /// Every slot is filled.
    pub full: bool,
    /// The interrupted slot waiting for redo or go on.
    pub unsure: Option<usize>,
}

/// What the robot does, as the status words need it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct View {
    /// Who drives it.
    pub mode: Mode,
    /// The PLC link.
    pub link: Link,
    /// Whether a move would be taken now (homed, no fault, the PLC in RUN).
    pub accepts_moves: bool,
    /// The PLC's fault word, when not 0.
    pub plc_fault: Option<u16>,
    /// Whether a move is queued or running.
    pub moving: bool,
    /// The cycle, if one ran.
    pub cycle: Option<CycleView>,
    /// Status reads of the PLC so far.
    pub heartbeat: u64,
    /// The taught position the robot stands at: its place in the face's `positions`, from 1.
    pub position: Option<u16>,
    /// Whether it stands at the home position.
    pub in_home: bool,
    /// The pallet the face shows, if it shows one.
    pub pallet: Option<PalletView>,
}

/// The status words.
#[must_use]
pub fn status_words(face: &Face, view: &View) -> [u16; STATUS_WORDS] {
    let phase = view.cycle.map(|c| c.phase);
    let cycle_live = phase.is_some_and(|p| p != CyclePhase::Ended);
    let fault = fault_code(view, phase);
    let bits = status_bits(face, view, fault);
    let done = view.cycle.map_or(0, |c| c.done);
    let mut words = [0; STATUS_WORDS];
    words[status_word::BITS] = bits;
    words[status_word::PROGRAM] = face.selected().map_or(0, |(n, _)| u16::from(n));
    words[status_word::STEP] = view.cycle.filter(|_| cycle_live).map_or(0, |c| c.step);
    words[status_word::FAULT] = fault;
    words[status_word::REFUSED] = face.refused().map_or(0, super::Refusal::code);
    words[status_word::HEARTBEAT] = (view.heartbeat & 0xFFFF) as u16;
    words[status_word::DONE_LOW] = (done & 0xFFFF) as u16;
    words[status_word::DONE_HIGH] = ((done >> 16) & 0xFFFF) as u16;
    words[status_word::POSITION] = view.position.unwrap_or(0);
    words[status_word::COMMANDS] = face.words()[super::command::BITS];
    if let Some(p) = &view.pallet {
        pallet_words(p, &mut words);
    }
    words
}

/// The fault word: the link's, the PLC's, the cycle's (0: none).
fn fault_code(view: &View, phase: Option<CyclePhase>) -> u16 {
    match (view.link, view.plc_fault, phase) {
        (Link::Down, ..) => fault::LINK_DOWN,
        (Link::Stalled, ..) => fault::STALLED,
        (Link::Up, Some(code), _) => code.min(99),
        (Link::Up, None, Some(CyclePhase::Faulted)) => fault::CYCLE,
        (Link::Up, ..) => 0,
    }
}

/// The status bits word, with `fault` the fault word.
fn status_bits(face: &Face, view: &View, fault: u16) -> u16 {
    let phase = view.cycle.map(|c| c.phase);
    let cycle_live = phase.is_some_and(|p| p != CyclePhase::Ended);
    let remote = view.mode == Mode::Remote;
    let linked = view.link != Link::Down;
    let ready = remote
        && face.enabled()
        && linked
        && view.accepts_moves
        && fault == 0
        && !cycle_live
        && !view.moving;
    [
        (ready, status_bit::READY),
        (phase == Some(CyclePhase::Running), status_bit::RUNNING),
        (phase == Some(CyclePhase::Paused), status_bit::PAUSED),
        (phase == Some(CyclePhase::Waiting), status_bit::WAITING),
        (fault != 0, status_bit::FAULT),
        (view.in_home, status_bit::IN_HOME),
        (remote, status_bit::REMOTE),
        (face.selected().is_some(), status_bit::SELECTED),
        (view.moving, status_bit::MOVING),
        (linked, status_bit::LINKED),
        (face.refused().is_some(), status_bit::REFUSED),
        (face.enabled(), status_bit::ENABLED),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .fold(0, |word, (_, bit)| word | bit)
}

/// The shown pallet's words (+18..+22); a count past a word's range shows as 65535.
fn pallet_words(p: &PalletView, words: &mut [u16; STATUS_WORDS]) {
    let word = |n: usize| u16::try_from(n).unwrap_or(u16::MAX);
    let bits = if p.known {
        pallet_bit::SHOWN
            | if p.full { pallet_bit::FULL } else { 0 }
            | if p.unsure.is_some() {
                pallet_bit::UNSURE
            } else {
                0
            }
    } else {
        pallet_bit::LOST
    };
    words[status_word::PALLET] = bits;
    words[status_word::PALLET_SLOTS] = word(p.slots);
    if p.known {
        words[status_word::PALLET_INDEX] = word(p.index);
        words[status_word::PALLET_LAYER] = word(p.layer);
        words[status_word::PALLET_UNSURE] = word(p.unsure.unwrap_or(0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::face::{bit, check_of};

    fn remote_ready() -> (Face, View) {
        let mut face = Face::new();
        face.write(0, &[0, 0, bit::ENABLE, 0], Mode::Remote);
        let view = View {
            mode: Mode::Remote,
            link: Link::Up,
            accepts_moves: true,
            heartbeat: 0x1_0005,
            ..View::default()
        };
        (face, view)
    }

    fn has(words: &[u16; STATUS_WORDS], b: u16) -> bool {
        words[status_word::BITS] & b != 0
    }

    #[test]
    fn ready_needs_remote_enable_link_no_fault_and_no_cycle() {
        let (face, view) = remote_ready();
        let w = status_words(&face, &view);
        assert!(has(&w, status_bit::READY) && has(&w, status_bit::REMOTE));
        assert_eq!(w[status_word::HEARTBEAT], 5, "wraps at 16 bits");
        let not_ready = [
            View {
                mode: Mode::Local,
                ..view
            },
            View {
                link: Link::Down,
                ..view
            },
            View {
                accepts_moves: false,
                ..view
            },
            View {
                moving: true,
                ..view
            },
            View {
                plc_fault: Some(4),
                ..view
            },
            View {
                cycle: Some(CycleView {
                    phase: CyclePhase::Paused,
                    step: 2,
                    done: 0,
                }),
                ..view
            },
        ];
        for v in not_ready {
            assert!(!has(&status_words(&face, &v), status_bit::READY), "{v:?}");
        }
        let mut off = face.clone();
        off.write(bit_word(), &[0], Mode::Remote);
        assert!(!has(&status_words(&off, &view), status_bit::READY));
    }

    fn bit_word() -> usize {
        crate::cell::face::command::BITS
    }

    #[test]
    fn the_fault_word_names_the_worst_first() {
        let (face, view) = remote_ready();
        let faulted = Some(CycleView {
            phase: CyclePhase::Faulted,
            step: 3,
            done: 70_000,
        });
        let cases = [
            (
                View {
                    link: Link::Down,
                    plc_fault: Some(4),
                    ..view
                },
                fault::LINK_DOWN,
            ),
            (
                View {
                    link: Link::Stalled,
                    ..view
                },
                fault::STALLED,
            ),
            (
                View {
                    plc_fault: Some(4),
                    cycle: faulted,
                    ..view
                },
                4,
            ),
            (
                View {
                    cycle: faulted,
                    ..view
                },
                fault::CYCLE,
            ),
            (view, 0),
        ];
        for (v, code) in cases {
            let w = status_words(&face, &v);
            assert_eq!(w[status_word::FAULT], code, "{v:?}");
            assert_eq!(has(&w, status_bit::FAULT), code != 0);
        }
        let w = status_words(
            &face,
            &View {
                cycle: faulted,
                ..view
            },
        );
        assert_eq!(w[status_word::STEP], 3);
        assert_eq!(
            (w[status_word::DONE_LOW], w[status_word::DONE_HIGH]),
            (4_464, 1)
        );
    }

    #[test]
    fn the_selection_and_the_refusal_are_echoed() {
        let (mut face, view) = remote_ready();
        face.write(
            0,
            &[9, check_of(9), bit::ENABLE | bit::STROBE],
            Mode::Remote,
        );
        face.select(9, "unload");
        let w = status_words(&face, &view);
        assert_eq!(w[status_word::PROGRAM], 9);
        assert!(has(&w, status_bit::SELECTED) && !has(&w, status_bit::REFUSED));
        assert_eq!(w[status_word::COMMANDS], bit::ENABLE | bit::STROBE);
        face.write(0, &[10], Mode::Remote);
        let w = status_words(&face, &view);
        assert_eq!(w[status_word::PROGRAM], 0);
        assert_eq!(w[status_word::REFUSED], 5);
        assert!(has(&w, status_bit::REFUSED));
    }

    #[test]
    fn the_shown_pallet_has_its_index_full_and_unsure_at_the_end_of_the_block() {
        let (face, view) = remote_ready();
        let before = status_words(&face, &view);
        assert_eq!(before[status_word::PALLET..], [0; 5], "no pallet shown");
        let pallet = PalletView {
            known: true,
            index: 7,
            slots: 24,
            layer: 1,
            full: false,
            unsure: Some(7),
        };
        let shown = View {
            pallet: Some(pallet),
            ..view
        };
        let w = status_words(&face, &shown);
        // The first ten status words do not move.
        assert_eq!(w[..status_word::PALLET], before[..status_word::PALLET]);
        assert_eq!(
            w[status_word::PALLET..],
            [pallet_bit::SHOWN | pallet_bit::UNSURE, 7, 24, 1, 7]
        );
        assert_eq!(status_word::PALLET + crate::cell::face::STATUS_AT, 18);
        let full = PalletView {
            index: 24,
            layer: 3,
            full: true,
            unsure: None,
            ..pallet
        };
        let w = status_words(
            &face,
            &View {
                pallet: Some(full),
                ..view
            },
        );
        assert_eq!(
            w[status_word::PALLET..],
            [pallet_bit::SHOWN | pallet_bit::FULL, 24, 24, 3, 0]
        );
        let lost = PalletView {
            known: false,
            ..pallet
        };
        let w = status_words(
            &face,
            &View {
                pallet: Some(lost),
                ..view
            },
        );
        assert_eq!(w[status_word::PALLET..], [pallet_bit::LOST, 0, 24, 0, 0]);
    }

    #[test]
    fn an_ended_cycle_shows_no_step_but_its_count() {
        let (face, view) = remote_ready();
        let v = View {
            cycle: Some(CycleView {
                phase: CyclePhase::Ended,
                step: 4,
                done: 12,
            }),
            position: Some(2),
            in_home: true,
            ..view
        };
        let w = status_words(&face, &v);
        assert_eq!(w[status_word::STEP], 0);
        assert_eq!(w[status_word::DONE_LOW], 12);
        assert_eq!(w[status_word::POSITION], 2);
        assert!(has(&w, status_bit::IN_HOME) && has(&w, status_bit::READY));
    }
}
