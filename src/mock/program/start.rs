//! A start (`command = 1`) as the program acts on it: a faulted state or a repeated `seq` drops
//! it; while running it waits; otherwise it is checked in the contract's order (bounds, homed,
//! busy, `from`, then F174's own check of every segment 1) and either starts every masked channel
//! in the same scan or latches the fault. Every start acted on, refused or ignored is recorded.

use thiserror::Error;

use super::{ChannelRun, Program, ScanIo, read_block};
use crate::contract::{CHANNELS, Command, CommandBlock, Fault, Layout, State};
use crate::mock::engine::{Engine, PulseError};
use crate::mock::memory::Memory;
use crate::table::{self, DecodeError, MAX_SEGMENTS, Segment};

/// Why a command block is a bad table header (fault 1).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum HeaderError {
    /// `mask` names no channel or a channel above 3.
    #[error("mask {mask:#06b} must name at least one of channels 0-3 and nothing else")]
    BadMask {
        /// The mask word.
        mask: u16,
    },
    /// `bank` is not 0 or 1.
    #[error("bank {bank} is not 0 or 1")]
    BadBank {
        /// The bank word.
        bank: u16,
    },
    /// A masked channel announces 0 or more than 8 segments.
    #[error("channel {channel} announces {segments} segments; a start needs 1..={MAX_SEGMENTS}")]
    BadSegmentCount {
        /// Pulse channel.
        channel: usize,
        /// The segments word.
        segments: u16,
    },
    /// A masked channel's area does not decode.
    #[error("bank {bank} channel {channel} table area: {source}")]
    Area {
        /// Table bank.
        bank: u16,
        /// Pulse channel.
        channel: usize,
        /// What is wrong with it.
        #[source]
        source: DecodeError,
    },
}

/// What became of one start command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StartOutcome {
    /// Every masked channel started.
    Started,
    /// Refused with this fault (or, for an open e-stop input, stopped with fault 3).
    Refused(Fault),
    /// Dropped unchecked: its `seq` was the last accepted one, or the state was fault or homing.
    Dropped,
}

/// One start command as the program acted on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartRecord {
    /// When, s since the mock started.
    pub at_s: f64,
    /// The scan the program first saw it, s since the mock started: before `at_s` when it
    /// waited behind the running move.
    pub seen_s: f64,
    /// The command block as read.
    pub block: CommandBlock,
    /// Every channel's count at that scan.
    pub counts: [i64; CHANNELS],
    /// The cell's input words at that scan.
    pub inputs: [u16; crate::contract::INPUT_WORDS],
    /// What the program did.
    pub outcome: StartOutcome,
}

impl StartRecord {
    /// Whether the counts differed from the block's `from` on some channel.
    #[must_use]
    pub fn from_mismatch(&self) -> bool {
        (0..CHANNELS).any(|c| self.counts[c] != i64::from(self.block.from[c]))
    }
}

type Tables = [Option<Vec<Segment>>; CHANNELS];

impl Program {
    pub(super) fn on_start(&mut self, at_s: f64, scan: u64, layout: &Layout, io: &mut ScanIo<'_>) {
        let block = read_block(io.memory, layout);
        let outcome = match self.state {
            State::Fault | State::Homing => Some(StartOutcome::Dropped),
            _ if block.seq == self.seq => Some(StartOutcome::Dropped),
            State::Running => None,
            State::Idle | State::Done | State::Stopped => {
                Some(self.act(at_s, scan, layout, block, io))
            }
        };
        let waited = self
            .waiting_since
            .take()
            .filter(|(seq, _)| *seq == block.seq);
        let Some(outcome) = outcome else {
            // Waits behind the running move.
            self.waiting_since = Some(waited.unwrap_or((block.seq, at_s)));
            return;
        };
        self.starts.push(StartRecord {
            at_s,
            seen_s: waited.map_or(at_s, |(_, seen_s)| seen_s),
            block,
            counts: std::array::from_fn(|c| io.engines[c].count()),
            inputs: io.cell,
            outcome,
        });
        match outcome {
            StartOutcome::Started | StartOutcome::Dropped => {
                Self::set_command(io.memory, layout, Command::None);
            }
            StartOutcome::Refused(Fault::StoppedFromOutside) => {
                self.state = State::Stopped;
                self.fault = Fault::StoppedFromOutside;
                Self::set_command(io.memory, layout, Command::None);
            }
            StartOutcome::Refused(fault) => {
                let why = self.last_fault.take().unwrap_or_default();
                self.latch(fault, why, io, layout);
            }
        }
    }

    /// Checks the start and, if it passes, starts segment 1 of every masked channel.
    fn act(
        &mut self,
        at_s: f64,
        scan: u64,
        layout: &Layout,
        block: CommandBlock,
        io: &mut ScanIo<'_>,
    ) -> StartOutcome {
        let tables = match prepare(&block, layout, self.homed, io) {
            Ok(tables) => tables,
            Err((fault, why)) => {
                tracing::warn!(
                    seq = block.seq,
                    fault = fault.meaning(),
                    "start refused: {why}"
                );
                self.last_fault = Some(why);
                return StartOutcome::Refused(fault);
            }
        };
        for (c, segments) in tables.into_iter().enumerate() {
            let Some(segments) = segments else { continue };
            // `prepare` checked segment 1: starting it cannot fail.
            let _ = io.engines[c].start(&segments[0], 1, at_s, io.rec);
            self.segment[c] = 1;
            self.runs[c] = Some(ChannelRun {
                segments,
                next: 1,
                started_scan: scan,
            });
        }
        self.seq = block.seq;
        self.permit = block.permit;
        self.state = State::Running;
        tracing::info!(
            seq = block.seq,
            mask = block.mask,
            bank = block.bank,
            at_s,
            "start"
        );
        StartOutcome::Started
    }
}

/// Every check a start needs, in the contract's order: the e-stop input (the mock's choice),
/// bounds (fault 1), homed (6), busy channels (2), every channel at `from` (5), the permit on
/// this scan's inputs (8), then F174's own check of every segment 1 (4).
fn prepare(
    block: &CommandBlock,
    layout: &Layout,
    homed: bool,
    io: &ScanIo<'_>,
) -> Result<Tables, (Fault, String)> {
    if io.inputs.estop_open {
        let why = "the e-stop input is open".to_owned();
        return Err((Fault::StoppedFromOutside, why));
    }
    let tables =
        load(block, layout, io.memory).map_err(|e| (Fault::BadTableHeader, e.to_string()))?;
    if !homed {
        return Err((Fault::NotHomed, "the homed bit is clear".to_owned()));
    }
    let flag = |c: usize| io.engines[c].busy() && io.inputs.variant.busy_flags_work();
    if let Some(c) = (0..CHANNELS).find(|&c| tables[c].is_some() && flag(c)) {
        return Err((Fault::ChannelBusy, format!("channel {c} is busy at start")));
    }
    if let Some(c) = (0..CHANNELS).find(|&c| io.engines[c].count() != i64::from(block.from[c])) {
        let why = format!(
            "channel {c} is at {}; the start's from is {}",
            io.engines[c].count(),
            block.from[c]
        );
        return Err((Fault::NotAtStart, why));
    }
    if io.inputs.variant.checks_permit() && !block.permit.holds(&io.cell) {
        let why = format!(
            "the permit (mask {:04X?}, value {:04X?}) does not hold on inputs {:04X?}",
            block.permit.mask, block.permit.value, io.cell
        );
        return Err((Fault::PermitNotMet, why));
    }
    check_first_segments(&tables, io.engines)
        .map_err(|e| (Fault::PulseInstruction, e.to_string()))?;
    Ok(tables)
}

/// Checks the command block's bounds and decodes every masked channel's segments.
fn load(block: &CommandBlock, layout: &Layout, memory: &Memory) -> Result<Tables, HeaderError> {
    if block.mask == 0 || block.mask >> CHANNELS != 0 {
        return Err(HeaderError::BadMask { mask: block.mask });
    }
    if block.bank > 1 {
        return Err(HeaderError::BadBank { bank: block.bank });
    }
    let mut tables: Tables = Default::default();
    for (c, table) in tables.iter_mut().enumerate() {
        if block.mask & (1 << c) == 0 {
            continue;
        }
        let segments = block.segments[c];
        if segments == 0 || usize::from(segments) > MAX_SEGMENTS {
            return Err(HeaderError::BadSegmentCount {
                channel: c,
                segments,
            });
        }
        let start = u32::from(layout.area(block.bank, c));
        let words = memory
            .read_dt(start, usize::from(layout.area_words))
            .unwrap_or(&[]);
        let area_error = |source| HeaderError::Area {
            bank: block.bank,
            channel: c,
            source,
        };
        *table = Some(table::decode(words, usize::from(segments)).map_err(area_error)?);
    }
    Ok(tables)
}

fn check_first_segments(tables: &Tables, engines: &[Engine; CHANNELS]) -> Result<(), PulseError> {
    for (segments, engine) in tables.iter().zip(engines) {
        if let Some(segments) = segments {
            engine.check(&segments[0], 1)?;
        }
    }
    Ok(())
}
