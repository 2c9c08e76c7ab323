//! The inputs step (contract version 3): the status block's `inputs[0..3]` read and named by the
//! config's input words, and, when one of them is an R word, one of its relays switched over the
//! link (MEWTOCOL `WCS`, a Modbus coil) and seen in its copy within a few scans, then switched
//! back. X words cannot be switched from the link: with four X words the check needs wiring and
//! is skipped.
//!
//! Which input bits the commission uses (with the default words WX0, WX1, WR10, WR11):
//! ```text
//! COPY_BIT    F of the first R word (R10F)   switched and back here
//! DROP_BIT    E of the first R word (R10E)   a running move's permit needs it, then it is
//!                                            switched: pulses: permit drop holds within one scan
//! REFUSE_BIT  D of inputs[c % 4] (XD, X1D..) only read: pulses: permit refuses fault 8
//! ```

use tokio::time::Instant;

use super::error::Failure;
pub(super) use super::error::on_off;
use super::report::InputsFound;
use super::{Check, Halt, INPUT_CHECKS, LinkTiming, Session, Step};
use crate::contract::{INPUT_WORDS, InputArea, InputWord, StatusBlock, bit_name};
use crate::plc::Plc;
use crate::plc::exchange::Contract;

/// The bit of the first R input word the copy check switches and switches back.
pub(super) const COPY_BIT: u8 = 15;
/// The bit of the first R input word a running move's permit needs and the drop check switches.
pub(super) const DROP_BIT: u8 = 14;
/// The bit of `inputs[c % 4]` the fault-8 check's permit asks for (never written).
pub(super) const REFUSE_BIT: u8 = 13;
/// Scans after a relay write was acknowledged within which its copy must show.
const COPY_SCANS: f64 = 3.0;
/// Status reads made after a relay write, at most.
const COPY_READS: usize = 10;

fn check(name: &'static str, checks: String) -> Check {
    debug_assert!(INPUT_CHECKS.contains(&name));
    Check::new(Step::Inputs, name, checks)
}

/// The index of the first R word among `words`.
pub(super) fn relay_word(words: &[InputWord; INPUT_WORDS]) -> Option<usize> {
    words.iter().position(|w| w.area == InputArea::R)
}

/// The relay number (word * 16 + bit) of bit `bit` of R word `word`.
pub(super) fn relay(word: InputWord, bit: u8) -> u16 {
    word.word * 16 + u16::from(bit)
}

/// Whether bit `bit` of `word` is on.
pub(super) fn is_on(word: u16, bit: u8) -> bool {
    word & (1 << bit) != 0
}

/// `WX0 0x0000 (all off), WR10 0x8001 (R100, R10F on)`.
pub(super) fn describe_inputs(
    values: [u16; INPUT_WORDS],
    words: &[InputWord; INPUT_WORDS],
) -> String {
    let parts: Vec<String> = (0..INPUT_WORDS)
        .map(|i| {
            let on: Vec<String> = (0..16u8)
                .filter(|&b| is_on(values[i], b))
                .map(|b| bit_name(words[i], b))
                .collect();
            let bits = if on.is_empty() {
                "all off".to_owned()
            } else {
                format!("{} on", on.join(", "))
            };
            format!("{} 0x{:04X} ({bits})", words[i], values[i])
        })
        .collect();
    parts.join(", ")
}

/// What a relay write did to the copies.
#[derive(Debug, Clone)]
pub(super) struct Switched {
    /// Status reads made after the write.
    pub reads: usize,
    /// When the read that first showed the new value was sent, s after the write's
    /// acknowledgement (`None`: never shown).
    pub shown_after_s: Option<f64>,
    /// A read sent more than [`COPY_SCANS`] scans after the acknowledgement did not show it.
    pub late: bool,
    /// Another input word in which the bit changed instead.
    pub elsewhere: Option<usize>,
    /// The last read.
    pub last: StatusBlock,
}

impl Switched {
    /// Nothing read yet after a write (the last read `before`).
    fn before(before: &StatusBlock) -> Self {
        Self {
            reads: 0,
            shown_after_s: None,
            late: false,
            elsewhere: None,
            last: *before,
        }
    }

    /// Whether and when `inputs[w]` showed the switch away from `was`, in words.
    fn seen(&self, w: usize, was: bool) -> String {
        match self.shown_after_s {
            Some(t) => format!(
                "showed in inputs[{w}] after {} read(s), the read sent {:.1} ms after the write's acknowledgement",
                self.reads,
                t * 1e3
            ),
            None => format!(
                "inputs[{w}] read 0x{:04X} over {} reads, never {}",
                self.last.inputs[w],
                self.reads,
                on_off(!was)
            ),
        }
    }

    /// Takes one read after the write: whether `inputs[w]` shows bit `bit` as `on` (sent
    /// `sent_s` after the acknowledgement; later than `late_s` is late).
    fn read(
        &mut self,
        block: StatusBlock,
        (w, bit, on): (usize, u8, bool),
        sent_s: f64,
        late_s: f64,
        before: &StatusBlock,
    ) -> bool {
        self.reads += 1;
        self.last = block;
        if is_on(block.inputs[w], bit) == on {
            self.shown_after_s = Some(sent_s);
            return true;
        }
        if sent_s > late_s {
            self.late = true;
        }
        self.elsewhere = self.elsewhere.or_else(|| {
            (0..INPUT_WORDS).find(|&j| j != w && is_on(block.inputs[j] ^ before.inputs[j], bit))
        });
        false
    }
}

/// Writes relay `bit` of input word `w` to `on` and reads the status block until `inputs[w]`
/// shows it ([`COPY_READS`] reads at most). `Err` when the write or a read failed.
pub(super) async fn switch<P: Plc>(
    contract: &mut Contract<P>,
    pace: LinkTiming,
    (w, bit): (usize, u8),
    on: bool,
    before: &StatusBlock,
) -> Result<Switched, Failure> {
    let word = contract.settings().layout.inputs[w];
    let name = bit_name(word, bit);
    contract
        .plc()
        .write_relay(relay(word, bit), on)
        .await
        .map_err(|source| Failure::RelayWrite {
            name: name.clone(),
            on,
            source,
        })?;
    let acked = Instant::now();
    let mut out = Switched::before(before);
    let late_s = COPY_SCANS * pace.scan_s.max(0.001);
    for _ in 0..COPY_READS {
        tokio::time::sleep(pace.poll()).await;
        let sent_s = acked.elapsed().as_secs_f64();
        let block = contract
            .status()
            .await
            .map_err(|source| Failure::ReadAfterRelay {
                name: name.clone(),
                source,
            })?
            .block;
        if out.read(block, (w, bit, on), sent_s, late_s, before) {
            break;
        }
    }
    Ok(out)
}

/// The inputs step.
pub(super) async fn step<P: Plc>(
    s: &mut Session<'_>,
    contract: &mut Contract<P>,
    pace: LinkTiming,
) -> Result<(), Halt> {
    let words = s.target.link.layout.inputs;
    let named: Vec<String> = words.iter().map(ToString::to_string).collect();
    let w = relay_word(&words);
    let k = copy_check(s.target.link.layout, &named, w);
    let before = match contract.status().await {
        Ok(st) => st.block,
        Err(e) => return s.record(k.fail(format!("{e:#}"), "the link failed")),
    };
    let read = describe_inputs(before.inputs, &words);
    s.findings.inputs = Some(InputsFound {
        words: named,
        values: before.inputs.to_vec(),
        relay_word: w,
        copied: None,
    });
    let Some(w) = w else {
        return s.record(k.skip(format!(
            "read {read}; all four input words are X words, which the link cannot switch: this \
             check needs wiring (switch an input by hand and see its copy change, \
             deploy/plc/README.md, \"by hand\")"
        )));
    };
    let report = copy_and_back(contract, pace, k, (w, &before), &read).await;
    if let Some(found) = &mut s.findings.inputs {
        found.copied = Some(report.verdict == super::Verdict::Pass);
    }
    s.record(report)
}

/// The copy check, as its report names what it looks at (`w`: the R word switched, if any).
fn copy_check(layout: crate::contract::Layout, named: &[String], w: Option<usize>) -> Check {
    let words = layout.inputs;
    let at = layout.status_base + crate::contract::STATUS_INPUTS_OFFSET;
    check(
        "copied every scan",
        match w {
            Some(w) => format!(
                "inputs[0..3] (DT{at}..DT{}) copy {} every scan: relay {} switched over the link \
                 shows in inputs[{w}] within {COPY_SCANS} scans, and back",
                at + 3,
                named.join(", "),
                bit_name(words[w], COPY_BIT)
            ),
            None => format!(
                "inputs[0..3] (DT{at}..DT{}) copy {} every scan",
                at + 3,
                named.join(", ")
            ),
        },
    )
}

/// Switches the copy bit of R word `w`, then back; the check's report.
async fn copy_and_back<P: Plc>(
    contract: &mut Contract<P>,
    pace: LinkTiming,
    k: Check,
    (w, before): (usize, &StatusBlock),
    read: &str,
) -> super::CheckReport {
    let name = bit_name(contract.settings().layout.inputs[w], COPY_BIT);
    let was = is_on(before.inputs[w], COPY_BIT);
    let there = switch(contract, pace, (w, COPY_BIT), !was, before).await;
    let back = switch(contract, pace, (w, COPY_BIT), was, before).await;
    let (there, back) = match (there, back) {
        (Ok(t), Ok(b)) => (t, b),
        (Err(e), _) | (_, Err(e)) => {
            return k.fail(
                format!("read {read}; {e}"),
                "relays must be writable over the link (MEWTOCOL WCS, Modbus coil 2048 + relay) \
                 and the status block readable: see the failure",
            );
        }
    };
    let saw = format!(
        "read {read}; {name} switched {}: {}; switched {} again: {}",
        on_off(!was),
        there.seen(w, was),
        on_off(was),
        back.seen(w, was)
    );
    let copy = Copy {
        layout: contract.settings().layout,
        w,
        name,
        was,
    };
    match copy.problem(&there, &back, pace.scan_s) {
        Some((hint, true)) => k.config(saw, hint),
        Some((hint, false)) => k.fail(saw, hint),
        None => k.pass(saw),
    }
}

/// The relay the copy check switched: its word among the inputs, its name and what it was.
struct Copy {
    layout: crate::contract::Layout,
    w: usize,
    name: String,
    was: bool,
}

impl Copy {
    /// What went wrong, and whether only the config must change; `None` when the copy held.
    fn problem(&self, there: &Switched, back: &Switched, scan_s: f64) -> Option<(String, bool)> {
        let Self { w, name, was, .. } = self;
        let words = self.layout.inputs;
        let at = self.layout.status_base + crate::contract::STATUS_INPUTS_OFFSET;
        let word = words[*w];
        if let (None, Some(j)) = (there.shown_after_s, there.elsewhere) {
            let hint = format!(
                "{name} showed in inputs[{j}], which the config names {}: the program copies \
                 {word} into inputs[{j}] (DT{}); set inputs in [robots.NAME.plc.contract] to the \
                 words in the order the listing's copy block copies them",
                words[j],
                at + j as u16
            );
            return Some((hint, true));
        }
        if there.shown_after_s.is_none() || back.shown_after_s.is_none() {
            let left = if back.shown_after_s.is_none() {
                format!(" ({name} may be left {}: switch it back)", on_off(!was))
            } else {
                String::new()
            };
            let hint = format!(
                "the contract says inputs[{w}] (DT{}) is a copy of {word} made every scan: the \
                 program does not copy it (the listing's copy block, F0 MV {word} DT{}), the \
                 config names another word, or the machine's own logic drives {name}{left}",
                at + *w as u16,
                at + *w as u16
            );
            return Some((hint, false));
        }
        (there.late || back.late).then(|| {
            let hint = format!(
                "the copy came later than {COPY_SCANS} scans (mean scan {:.1} ms) after the write: \
                 the contract says inputs are copied first thing every scan",
                scan_s * 1e3
            );
            (hint, false)
        })
    }
}
