//! The contract's PLC program (CONTRACT.md, "What the PLC program does, every scan"), one scan
//! at a time, over the mock's memory and pulse engines.
//!
//! Where the contract leaves a choice, the mock makes it like this:
//! - a start with no channel in `mask`, a bit above channel 3 or a `bank` above 1 is a bad table
//!   header (fault 1), as is a masked channel announcing 0 or more than 8 segments or an area that
//!   does not decode;
//! - the first frequency of every masked channel's segment 1 is checked before any channel starts,
//!   so a fault 4 at start outputs nothing anywhere; a fault 4 when chaining a later segment leaves
//!   the other channels running (as F174 on other channels would): stop them with `command = 2`;
//! - a stop in the fault state stops every channel and keeps the fault; the e-stop input is a
//!   level: while it is open every scan stops every channel, with fault 3;
//! - clear fault while running clears the fault word only (the move keeps running);
//! - `segment[c]` holds the 1-based index of the segment channel c runs or last ran (0 before any
//!   start).

use thiserror::Error;

use super::engine::{Engine, PulseError};
use super::memory::Memory;
use super::trace::Recorder;
use crate::contract::{
    CHANNELS, COMMAND_WORDS, Command, CommandBlock, Fault, Layout, MAGIC, State, StatusBlock,
    VERSION,
};
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

/// What the program reads besides memory: inputs wired from outside.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Inputs {
    /// The `ready` word's bits as wired (bit 2 also drops while the e-stop is open).
    pub ready: u16,
    /// Whether the e-stop input is open.
    pub estop_open: bool,
    /// Whether the heartbeat is frozen (fault injection).
    pub freeze_heartbeat: bool,
}

/// Everything a scan touches.
pub(super) struct ScanIo<'a> {
    /// Device memory.
    pub memory: &'a mut Memory,
    /// The pulse channels.
    pub engines: &'a mut [Engine; CHANNELS],
    /// Pulse and anomaly record.
    pub rec: &'a mut Recorder,
    /// Wired inputs.
    pub inputs: Inputs,
}

/// What one channel of the running start still has to play.
#[derive(Debug, Clone, PartialEq)]
struct ChannelRun {
    segments: Vec<Segment>,
    /// 0-based index of the next segment to start.
    next: usize,
    started_scan: u64,
}

/// The PLC program's own state between scans.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Program {
    state: State,
    fault: Fault,
    seq: u16,
    heartbeat: u16,
    segment: [u16; CHANNELS],
    runs: [Option<ChannelRun>; CHANNELS],
    last_fault: Option<String>,
}

impl Default for Program {
    fn default() -> Self {
        Self {
            state: State::Idle,
            fault: Fault::None,
            seq: 0,
            heartbeat: 0,
            segment: [0; CHANNELS],
            runs: Default::default(),
            last_fault: None,
        }
    }
}

impl Program {
    /// The program's state.
    #[must_use]
    pub(super) fn state(&self) -> State {
        self.state
    }

    fn fault(&self) -> Fault {
        self.fault
    }

    /// Why the last fault was latched, for logs and the demo.
    #[must_use]
    pub(super) fn last_fault(&self) -> Option<&str> {
        self.last_fault.as_deref()
    }

    /// One scan at `at_s`, scan number `scan`.
    pub(super) fn scan(&mut self, at_s: f64, scan: u64, layout: &Layout, io: &mut ScanIo<'_>) {
        if !io.inputs.freeze_heartbeat {
            self.heartbeat = self.heartbeat.wrapping_add(1);
        }
        let command = io.memory.dt(u32::from(layout.command_base)).unwrap_or(0);
        if command == Command::Start.word() {
            self.on_start(at_s, scan, layout, io);
        }
        if self.state() == State::Running {
            self.chain(at_s, scan, io);
            self.finish_if_done(io.engines);
        }
        let from_input = io.inputs.estop_open;
        if from_input || command == Command::Stop.word() {
            self.stop(io, layout, from_input);
        }
        if command == Command::ClearFault.word() {
            self.clear_fault(io.memory, layout);
        }
        self.write_status(io, layout);
    }

    fn set_command(memory: &mut Memory, layout: &Layout, command: Command) {
        // The layout was checked against DT memory when the mock was built.
        let _ = memory.write_dt(u32::from(layout.command_base), &[command.word()]);
    }

    fn latch(&mut self, fault: Fault, why: String, io: &mut ScanIo<'_>, layout: &Layout) {
        tracing::warn!(fault = fault.meaning(), "PLC program fault: {why}");
        self.state = State::Fault;
        self.fault = fault;
        self.last_fault = Some(why);
        Self::set_command(io.memory, layout, Command::None);
    }

    fn on_start(&mut self, at_s: f64, scan: u64, layout: &Layout, io: &mut ScanIo<'_>) {
        match self.state() {
            State::Running => return,
            State::Fault => return Self::set_command(io.memory, layout, Command::None),
            State::Idle | State::Done | State::Stopped => {}
        }
        let (block, tables) = match prepare(layout, io) {
            Ok(prepared) => prepared,
            Err((fault, why)) => return self.latch(fault, why, io, layout),
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
        self.state = State::Running;
        Self::set_command(io.memory, layout, Command::None);
        tracing::info!(
            seq = block.seq,
            mask = block.mask,
            bank = block.bank,
            at_s,
            "start"
        );
    }

    fn chain(&mut self, at_s: f64, scan: u64, io: &mut ScanIo<'_>) {
        for c in 0..CHANNELS {
            let Some(run) = &mut self.runs[c] else {
                continue;
            };
            if io.engines[c].busy() || run.started_scan >= scan || run.next >= run.segments.len() {
                continue;
            }
            let index = run.next + 1;
            match io.engines[c].start(&run.segments[run.next], index, at_s, io.rec) {
                Ok(()) => {
                    run.next += 1;
                    run.started_scan = scan;
                    self.segment[c] = index as u16;
                }
                Err(e) => {
                    self.runs[c] = None;
                    tracing::warn!("PLC program fault: {e}");
                    self.state = State::Fault;
                    self.fault = Fault::PulseInstruction;
                    self.last_fault = Some(e.to_string());
                    return;
                }
            }
        }
    }

    fn finish_if_done(&mut self, engines: &[Engine; CHANNELS]) {
        let done = self.runs.iter().zip(engines).all(|(run, e)| {
            run.as_ref()
                .is_none_or(|r| !e.busy() && r.next >= r.segments.len())
        });
        if done {
            self.runs = Default::default();
            self.state = State::Done;
            tracing::info!(seq = self.seq, "done");
        }
    }

    fn stop(&mut self, io: &mut ScanIo<'_>, layout: &Layout, from_input: bool) {
        for e in io.engines.iter_mut() {
            e.stop();
        }
        self.runs = Default::default();
        Self::set_command(io.memory, layout, Command::None);
        if self.state() != State::Fault {
            self.state = State::Stopped;
            if from_input {
                self.fault = Fault::StoppedFromOutside;
            }
        }
    }

    fn clear_fault(&mut self, memory: &mut Memory, layout: &Layout) {
        self.fault = Fault::None;
        self.last_fault = None;
        if self.state() != State::Running {
            self.state = State::Idle;
        }
        Self::set_command(memory, layout, Command::None);
    }

    /// Stops everything for PROG mode: a running move ends stopped.
    pub(super) fn enter_prog(&mut self, engines: &mut [Engine; CHANNELS]) {
        for e in engines.iter_mut() {
            e.stop();
        }
        self.runs = Default::default();
        if self.state() == State::Running {
            self.state = State::Stopped;
        }
    }

    fn write_status(&self, io: &mut ScanIo<'_>, layout: &Layout) {
        let mut busy = 0;
        for (c, e) in io.engines.iter().enumerate() {
            busy |= u16::from(e.busy()) << c;
        }
        let mut ready = io.inputs.ready;
        if io.inputs.estop_open {
            ready &= !0b100;
        }
        let status = StatusBlock {
            magic: MAGIC,
            version: VERSION,
            heartbeat: self.heartbeat,
            state: self.state().word(),
            seq: self.seq,
            fault: self.fault().word(),
            busy,
            ready,
            elapsed: std::array::from_fn(|c| io.engines[c].count() as i32),
            segment: self.segment,
        };
        let _ = io
            .memory
            .write_dt(u32::from(layout.status_base), &status.to_words());
    }
}

type Tables = [Option<Vec<Segment>>; CHANNELS];

/// Reads the command block and checks everything a start needs, in the contract's order:
/// bounds (fault 1), busy channels (fault 2), then F174's own check of every segment 1 (fault 4).
fn prepare(layout: &Layout, io: &ScanIo<'_>) -> Result<(CommandBlock, Tables), (Fault, String)> {
    let words = io
        .memory
        .read_dt(u32::from(layout.command_base), COMMAND_WORDS);
    let block = words
        .ok()
        .and_then(CommandBlock::from_words)
        .unwrap_or_default();
    let tables =
        load(&block, layout, io.memory).map_err(|e| (Fault::BadTableHeader, e.to_string()))?;
    if let Some(c) = (0..CHANNELS).find(|&c| tables[c].is_some() && io.engines[c].busy()) {
        return Err((Fault::ChannelBusy, format!("channel {c} is busy at start")));
    }
    check_first_segments(&tables, io.engines)
        .map_err(|e| (Fault::PulseInstruction, e.to_string()))?;
    Ok((block, tables))
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
