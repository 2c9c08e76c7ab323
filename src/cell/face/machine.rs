//! The face's command side: the command words as the line last wrote them, the edges a write
//! makes, and what they ask of the daemon. What needs the robot (is there a program with this
//! number, may a cycle start now) the daemon decides, and tells the face ([`Face::select`],
//! [`Face::refuse`]).

use super::{COMMAND_WORDS, bit, check_of, command};
use crate::cell::Mode;

/// What a write asks the daemon to do, in the order given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Action {
    /// Move-enable dropped (remote): stop the robot now and pause the cycle.
    Hold,
    /// Stop the robot now and end the cycle.
    StopNow,
    /// Stop the cycle at the end of its current step.
    Stop,
    /// Clear the robot's fault.
    Reset,
    /// Pause the cycle at the end of its current step.
    Pause,
    /// Select the program numbered `number` (its check word matched): the daemon looks it up
    /// and answers [`Face::select`] or [`Face::refuse`].
    Select {
        /// The program's number.
        number: u8,
    },
    /// Run the selected program `count` times (`None`: until stopped), or resume a paused or
    /// faulted cycle.
    Start {
        /// Cycles to run.
        count: Option<u64>,
    },
    /// Move to the home position.
    Home,
    /// The shown pallet's interrupted slot was not placed: place at it again.
    PalletRedo,
    /// The shown pallet's interrupted slot was placed: count it, go on at the next.
    PalletGoOn,
}

impl Action {
    /// Its name, in a word (metrics, logs).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Hold => "hold",
            Self::StopNow => "stop-now",
            Self::Stop => "stop",
            Self::Reset => "reset",
            Self::Pause => "pause",
            Self::Select { .. } => "strobe",
            Self::Start { .. } => "start",
            Self::Home => "home",
            Self::PalletRedo => "pallet-redo",
            Self::PalletGoOn => "pallet-go-on",
        }
    }
}

/// Why a command was refused: the status block's refusal word (+12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u16)]
pub enum Refusal {
    /// The robot is in local mode: the CLI and the API drive it.
    Local = 1,
    /// Move-enable is off.
    NotEnabled = 2,
    /// A strobe with program number 0 or one over 255.
    NoProgram = 3,
    /// The check word is not the program number XOR 0xFFFF.
    BadCheck = 4,
    /// The program number or its check changed while the strobe was on.
    ChangedDuringStrobe = 5,
    /// No program has that number (or the programs could not be read).
    UnknownProgram = 6,
    /// A start with no program selected (or the number changed since its strobe).
    NotSelected = 7,
    /// A cycle is under way, or the robot is moving.
    Busy = 8,
    /// The robot cannot move now (no link, not homed, a PLC fault, stalled).
    NotReady = 9,
    /// A faulted cycle resumes only after a reset.
    FaultNotCleared = 10,
    /// The command does not fit the cycle's state (pause with none running, reset with no
    /// fault).
    NotNow = 11,
    /// The program fails its check (the daemon's log names the step and the value).
    ProgramRefused = 12,
    /// No `home` position is taught.
    NoHome = 13,
    /// A pallet redo or go-on with no pallet shown (`[robots.NAME.cell.face] pallet`).
    NoPallet = 14,
    /// A pallet redo or go-on with no interrupted slot to choose for.
    NothingToChoose = 15,
    /// Pallet redo and go-on raised together: raise one.
    RedoAndGoOn = 16,
    /// The pallet's count could not be written (the daemon's log says why): nothing changed.
    PalletNotWritten = 17,
}

impl Refusal {
    /// Every refusal, by code.
    pub const ALL: [Self; 17] = [
        Self::Local,
        Self::NotEnabled,
        Self::NoProgram,
        Self::BadCheck,
        Self::ChangedDuringStrobe,
        Self::UnknownProgram,
        Self::NotSelected,
        Self::Busy,
        Self::NotReady,
        Self::FaultNotCleared,
        Self::NotNow,
        Self::ProgramRefused,
        Self::NoHome,
        Self::NoPallet,
        Self::NothingToChoose,
        Self::RedoAndGoOn,
        Self::PalletNotWritten,
    ];

    /// Its code in the refusal word.
    #[must_use]
    pub fn code(self) -> u16 {
        self as u16
    }

    /// What it means, in a few words.
    #[must_use]
    pub fn meaning(self) -> &'static str {
        match self {
            Self::Local => "the robot is in local mode",
            Self::NotEnabled => "move-enable is off",
            Self::NoProgram => "the strobe came with no program number (0, or over 255)",
            Self::BadCheck => "the check word is not the program number XOR 0xFFFF",
            Self::ChangedDuringStrobe => "the program number changed while the strobe was on",
            Self::UnknownProgram => "no program has that number",
            Self::NotSelected => "no program is selected",
            Self::Busy => "a cycle is under way or the robot is moving",
            Self::NotReady => "the robot cannot move now",
            Self::FaultNotCleared => "the cycle faulted: reset first",
            Self::NotNow => "the command does not fit the cycle's state",
            Self::ProgramRefused => "the program fails its check",
            Self::NoHome => "no home position is taught",
            Self::NoPallet => "the face shows no pallet",
            Self::NothingToChoose => "the pallet has no interrupted slot to redo or go on from",
            Self::RedoAndGoOn => "pallet redo and go-on came together",
            Self::PalletNotWritten => "the pallet's count could not be written",
        }
    }
}

/// The command side of the face.
#[derive(Debug, Clone, Default)]
pub struct Face {
    words: [u16; COMMAND_WORDS],
    /// Whether the baseline is set (the first write after start or a mode change sets it).
    primed: bool,
    selected: Option<(u8, String)>,
    refused: Option<Refusal>,
    /// Commands refused so far.
    refusals: u64,
}

impl Face {
    /// A face no one has written.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The command words as last written.
    #[must_use]
    pub fn words(&self) -> [u16; COMMAND_WORDS] {
        self.words
    }

    /// The selected program: its number and name.
    #[must_use]
    pub fn selected(&self) -> Option<(u8, &str)> {
        self.selected.as_ref().map(|(n, name)| (*n, name.as_str()))
    }

    /// Why the last command was refused.
    #[must_use]
    pub fn refused(&self) -> Option<Refusal> {
        self.refused
    }

    /// Commands refused so far (each refusal counts, the same one again too).
    #[must_use]
    pub fn refusals(&self) -> u64 {
        self.refusals
    }

    /// Whether move-enable is on.
    #[must_use]
    pub fn enabled(&self) -> bool {
        self.words[command::BITS] & bit::ENABLE != 0
    }

    /// The mode changed: the selection goes, and the next write sets the baseline again.
    pub fn mode_changed(&mut self) {
        self.primed = false;
        self.selected = None;
        self.refused = None;
    }

    /// The daemon found program `number`: it is selected.
    pub fn select(&mut self, number: u8, name: &str) {
        self.selected = Some((number, name.to_owned()));
    }

    /// The daemon refused the last command.
    pub fn refuse(&mut self, why: Refusal) {
        self.refused = Some(why);
        self.refusals += 1;
    }

    /// The line wrote `values` from command word `at` (the caller keeps them within the
    /// command words) in `mode`: the actions its edges ask for, in order.
    ///
    /// # Panics
    /// When the write goes past the command words.
    pub fn write(&mut self, at: usize, values: &[u16], mode: Mode) -> Vec<Action> {
        let old = self.words;
        self.words[at..at + values.len()].copy_from_slice(values);
        let new = self.words;
        if !self.primed {
            self.primed = true;
            return Vec::new();
        }
        let (was, now) = (old[command::BITS], new[command::BITS]);
        let rose = now & !was;
        let fell = was & !now;
        let remote = mode == Mode::Remote;
        if rose & bit::EDGES != 0 {
            self.refused = None;
        }
        let mut actions = stops(rose, fell, remote);
        let renumbered = new[command::PROGRAM] != old[command::PROGRAM]
            || new[command::CHECK] != old[command::CHECK];
        if renumbered {
            self.selected = None;
            if was & now & bit::STROBE != 0 {
                self.refuse(Refusal::ChangedDuringStrobe);
            }
        }
        let rose = self.one_choice(rose, remote);
        self.commands(rose, remote, &mut actions);
        actions
    }

    /// The commands whose bits `rose` (but the stops), in order: each action, or its refusal.
    fn commands(&mut self, rose: u16, remote: bool, actions: &mut Vec<Action>) {
        for edge in [
            bit::RESET,
            bit::PAUSE,
            bit::STROBE,
            bit::START,
            bit::HOME,
            bit::PALLET_REDO,
            bit::PALLET_GO_ON,
        ] {
            if rose & edge == 0 {
                continue;
            }
            match self.command(edge, remote) {
                Ok(action) => actions.push(action),
                Err(why) => self.refuse(why),
            }
        }
    }

    /// `rose` without the pallet's choices when both rose at once (refused: neither is taken).
    fn one_choice(&mut self, rose: u16, remote: bool) -> u16 {
        let both = bit::PALLET_REDO | bit::PALLET_GO_ON;
        if rose & both != both {
            return rose;
        }
        self.refuse(if remote {
            Refusal::RedoAndGoOn
        } else {
            Refusal::Local
        });
        rose & !both
    }

    fn command(&mut self, edge: u16, remote: bool) -> Result<Action, Refusal> {
        if !remote {
            return Err(Refusal::Local);
        }
        let enabled = self.enabled();
        match edge {
            bit::RESET => Ok(Action::Reset),
            bit::PAUSE => Ok(Action::Pause),
            bit::STROBE => {
                self.selected = None;
                let program = self.words[command::PROGRAM];
                let number = u8::try_from(program)
                    .ok()
                    .filter(|n| *n > 0)
                    .ok_or(Refusal::NoProgram)?;
                if self.words[command::CHECK] != check_of(program) {
                    return Err(Refusal::BadCheck);
                }
                Ok(Action::Select { number })
            }
            bit::START if enabled => {
                let count = self.words[command::COUNT];
                Ok(Action::Start {
                    count: (count > 0).then_some(u64::from(count)),
                })
            }
            bit::HOME if enabled => Ok(Action::Home),
            // A choice moves nothing: move-enable is not needed.
            bit::PALLET_REDO => Ok(Action::PalletRedo),
            bit::PALLET_GO_ON => Ok(Action::PalletGoOn),
            _ => Err(Refusal::NotEnabled),
        }
    }
}

/// What the stop bits ask, taken in any mode, and the hold of `enable` falling in remote.
fn stops(rose: u16, fell: u16, remote: bool) -> Vec<Action> {
    let mut actions = Vec::new();
    if remote && fell & bit::ENABLE != 0 {
        actions.push(Action::Hold);
    }
    if rose & bit::STOP_NOW != 0 {
        actions.push(Action::StopNow);
    }
    if rose & bit::STOP != 0 {
        actions.push(Action::Stop);
    }
    actions
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::Mode::{Local, Remote};

    const ON: u16 = bit::ENABLE;

    /// A primed face with move-enable on and program 3 strobed and selected.
    fn selected() -> Face {
        let mut f = Face::new();
        assert!(
            f.write(0, &[0, 0, ON, 0], Remote).is_empty(),
            "the baseline"
        );
        let acts = f.write(0, &[3, check_of(3), ON | bit::STROBE], Remote);
        assert_eq!(acts, [Action::Select { number: 3 }]);
        f.select(3, "load");
        f
    }

    #[test]
    fn every_command_bit_but_move_enable_acts_on_its_edge() {
        let all = (0..10).fold(0, |all, n| all | 1 << n);
        assert_eq!(bit::EDGES, all & !bit::ENABLE);
        assert_eq!(
            (bit::STROBE, bit::ENABLE, bit::PALLET_GO_ON),
            (1, 1 << 6, 1 << 9)
        );
    }

    #[test]
    fn the_first_write_only_sets_the_baseline() {
        let mut f = Face::new();
        let all = bit::EDGES | ON;
        assert!(f.write(0, &[3, check_of(3), all, 0], Remote).is_empty());
        assert!(f.enabled());
        assert_eq!(f.selected(), None);
        // Dropping and raising start is an edge.
        f.write(command::BITS, &[ON], Remote);
        assert_eq!(
            f.write(command::BITS, &[ON | bit::START], Remote),
            [Action::Start { count: None }]
        );
        // After a mode change the baseline is set again.
        f.mode_changed();
        assert!(f.write(command::BITS, &[ON], Remote).is_empty());
    }

    #[test]
    fn a_strobe_with_its_check_selects_and_a_start_runs() {
        let mut f = selected();
        assert_eq!(f.selected(), Some((3, "load")));
        assert_eq!(f.refused(), None);
        f.write(command::BITS, &[ON], Remote);
        assert_eq!(
            f.write(command::BITS, &[ON | bit::START], Remote),
            [Action::Start { count: None }]
        );
        f.write(command::COUNT, &[5], Remote);
        f.write(command::BITS, &[ON], Remote);
        assert_eq!(
            f.write(command::BITS, &[ON | bit::START], Remote),
            [Action::Start { count: Some(5) }]
        );
        // Writing the same words again is no edge.
        assert!(
            f.write(command::BITS, &[ON | bit::START], Remote)
                .is_empty()
        );
    }

    #[test]
    fn a_bad_strobe_is_refused_with_its_reason() {
        for (program, check, why) in [
            (0, check_of(0), Refusal::NoProgram),
            (256, check_of(256), Refusal::NoProgram),
            (3, 3, Refusal::BadCheck),
            (3, check_of(4), Refusal::BadCheck),
        ] {
            let mut f = Face::new();
            f.write(0, &[0, 0, ON, 0], Remote);
            let acts = f.write(0, &[program, check, ON | bit::STROBE], Remote);
            assert!(acts.is_empty(), "{program} {check}: {acts:?}");
            assert_eq!(f.refused(), Some(why), "{program} {check}");
            assert_eq!(f.selected(), None);
        }
    }

    #[test]
    fn a_number_changed_during_the_strobe_drops_the_selection() {
        let mut f = selected();
        assert!(f.write(command::PROGRAM, &[4], Remote).is_empty());
        assert_eq!(f.refused(), Some(Refusal::ChangedDuringStrobe));
        assert_eq!(f.selected(), None);
        // With the strobe off, a new number only drops the selection (strobe it again).
        let mut f = selected();
        f.write(command::BITS, &[ON], Remote);
        f.write(0, &[4, check_of(4)], Remote);
        assert_eq!(f.selected(), None);
        assert_eq!(f.refused(), None);
    }

    #[test]
    fn local_mode_refuses_all_but_the_stops() {
        let mut f = Face::new();
        f.write(0, &[0, 0, ON, 0], Local);
        for edge in [bit::STROBE, bit::START, bit::PAUSE, bit::RESET, bit::HOME] {
            f.write(command::BITS, &[ON], Local);
            let acts = f.write(0, &[3, check_of(3), ON | edge], Local);
            assert!(acts.is_empty(), "{edge:#x}: {acts:?}");
            assert_eq!(f.refused(), Some(Refusal::Local), "{edge:#x}");
        }
        assert_eq!(
            f.refusals(),
            5,
            "each refusal counts, the same one again too"
        );
        f.write(command::BITS, &[ON], Local);
        assert_eq!(
            f.write(command::BITS, &[ON | bit::STOP | bit::STOP_NOW], Local),
            [Action::StopNow, Action::Stop]
        );
        // Move-enable is the line's only in remote: dropping it in local holds nothing.
        assert!(f.write(command::BITS, &[0], Local).is_empty());
    }

    #[test]
    fn move_enable_dropping_holds_and_gates_start_and_home() {
        let mut f = selected();
        assert_eq!(f.write(command::BITS, &[0], Remote), [Action::Hold]);
        for edge in [bit::START, bit::HOME] {
            f.write(command::BITS, &[0], Remote);
            assert!(f.write(command::BITS, &[edge], Remote).is_empty());
            assert_eq!(f.refused(), Some(Refusal::NotEnabled));
        }
        // A later accepted command clears the refusal.
        f.write(command::BITS, &[ON], Remote);
        assert_eq!(
            f.write(command::BITS, &[ON | bit::HOME], Remote),
            [Action::Home]
        );
        assert_eq!(f.refused(), None);
    }

    #[test]
    fn one_write_acts_in_a_fixed_order() {
        let mut f = Face::new();
        f.write(0, &[0, 0, ON, 0], Remote);
        let all = ON | bit::RESET | bit::STROBE | bit::START | bit::PAUSE;
        assert_eq!(
            f.write(0, &[7, check_of(7), all, 2], Remote),
            [
                Action::Reset,
                Action::Pause,
                Action::Select { number: 7 },
                Action::Start { count: Some(2) },
            ]
        );
    }

    #[test]
    fn pallet_redo_and_go_on_act_on_their_edges_in_remote_without_move_enable() {
        let mut f = Face::new();
        f.write(0, &[0, 0, 0, 0], Remote);
        assert_eq!(
            f.write(command::BITS, &[bit::PALLET_REDO], Remote),
            [Action::PalletRedo]
        );
        // Held on: no second edge.
        assert!(
            f.write(command::BITS, &[bit::PALLET_REDO], Remote)
                .is_empty()
        );
        assert_eq!(
            f.write(command::BITS, &[bit::PALLET_GO_ON], Remote),
            [Action::PalletGoOn]
        );
        assert_eq!(f.refused(), None);
        // Both at once: neither, refused.
        f.write(command::BITS, &[0], Remote);
        let both = bit::PALLET_REDO | bit::PALLET_GO_ON;
        assert!(f.write(command::BITS, &[both], Remote).is_empty());
        assert_eq!(f.refused(), Some(Refusal::RedoAndGoOn));
        // Local mode: refused as the other commands are.
        let mut f = Face::new();
        f.write(0, &[0, 0, 0, 0], Local);
        assert!(
            f.write(command::BITS, &[bit::PALLET_GO_ON], Local)
                .is_empty()
        );
        assert_eq!(f.refused(), Some(Refusal::Local));
        assert_eq!(
            (Action::PalletRedo.name(), Action::PalletGoOn.name()),
            ("pallet-redo", "pallet-go-on")
        );
    }

    #[test]
    fn refusal_codes_are_distinct_and_say_what_they_mean() {
        let codes: std::collections::BTreeSet<u16> =
            Refusal::ALL.iter().map(|r| r.code()).collect();
        assert_eq!(codes.len(), Refusal::ALL.len());
        assert_eq!(codes.first(), Some(&1));
        // Numbered 1 on without a gap: a line PLC's table of meanings is indexed by them.
        assert_eq!(codes.last(), Some(&(Refusal::ALL.len() as u16)));
        assert!(Refusal::ALL.iter().all(|r| !r.meaning().is_empty()));
    }
}
