//! The contract's PLC program (CONTRACT.md version 3, "What the PLC program does, every scan"),
//! one scan at a time, over the mock's memory and pulse engines.
//!
//! ```text
//! mod.rs    the scan: first-scan clearing, commands (start, stop, clear fault, home), chaining,
//!           done, the status block
//! start.rs  a start's checks, in the contract's order, and the record of every start
//! ```
//!
//! Where the contract leaves a choice, the mock makes it like this:
//! - a start with no channel in `mask`, a bit above channel 3 or a `bank` above 1 is a bad table
//!   header (fault 1), as is a masked channel announcing 0 or more than 8 segments or an area that
//!   does not decode;
//! - a start while the e-stop input is open is refused before anything starts: state stopped,
//!   fault 3, `seq` not latched;
//! - the first frequency of every masked channel's segment 1 is checked before any channel starts,
//!   so a fault 4 at start outputs nothing anywhere; a fault 4 when chaining a later segment leaves
//!   the other channels running (as F174 on other channels would) and drops a waiting start:
//!   stop them with `command = 2`;
//! - a stop in the fault state stops every channel and keeps the fault; the e-stop input is a
//!   level: while it is open every scan stops every channel, with fault 3 (fault 7 while homing);
//! - clear fault while running clears the fault word only (the move keeps running);
//! - a start while homing is dropped (`command = 0`); a stop while homing abandons it (the homed
//!   bit stays clear); the home routine takes [`super::MockConfig::home_s`] and then presets each
//!   masked channel's count to `from[c]`;
//! - a start refused for its permit (fault 8) latches the fault like every refused start; a
//!   running move whose latched permit stops holding is stopped in that scan (state stopped,
//!   fault 9, a waiting start dropped), after the scan's chaining and done checks, so a move
//!   whose last segment ended in the same scan ends done;
//! - the input words are read at the start of the scan: the status block, the start's check and
//!   the running move's check all see the same words;
//! - `segment[c]` holds the 1-based index of the segment channel c runs or last ran (0 before any
//!   start).
//!
//! Variants ([`super::MockVariant`]): with busy relays that never rise, the busy word stays 0,
//! fault 2 never fires and a segment ends when the count shows its last target (the listing's
//! fallback rule); with a stop that only pauses, a stop halts the engines instead of ending their
//! segments ([`Engine::halt`]); with a program that ignores the permit, a start is never refused
//! for it and a running move never held by it.

mod start;

pub use start::{HeaderError, StartOutcome, StartRecord};

use super::engine::Engine;
use super::memory::Memory;
use super::trace::Recorder;
use super::variant::MockVariant;
use crate::contract::{
    CHANNELS, COMMAND_HOST_OFFSET, COMMAND_WORDS, Command, CommandBlock, Fault, INPUT_WORDS,
    InputArea, Layout, MAGIC, Permit, READY_ESTOP_CLEAR, READY_HOMED, State, StatusBlock, VERSION,
};
use crate::gateway::Area;
use crate::table::Segment;

/// What the program reads besides memory: inputs wired from outside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Inputs {
    /// The `ready` word's wired bits (drives ready, e-stop clear; bit 2 also drops while the
    /// e-stop is open). The homed bit is the program's own.
    pub ready: u16,
    /// Whether the e-stop input is open.
    pub estop_open: bool,
    /// Whether the heartbeat is frozen (fault injection).
    pub freeze_heartbeat: bool,
    /// How long the home routine takes, s.
    pub home_s: f64,
    /// The listing, or one defect.
    pub variant: MockVariant,
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
    /// The cell's input words as this scan read them (the status block's `inputs`).
    pub cell: [u16; INPUT_WORDS],
}

/// What one channel of the running start still has to play.
#[derive(Debug, Clone, PartialEq)]
struct ChannelRun {
    segments: Vec<Segment>,
    /// 0-based index of the next segment to start.
    next: usize,
    started_scan: u64,
}

/// A home routine under way.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Homing {
    mask: u16,
    from: [i32; CHANNELS],
    done_at_s: f64,
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
    homed: bool,
    homing: Option<Homing>,
    /// The next scan is the first after power-up or PROG -> RUN (R9013).
    first_scan: bool,
    last_fault: Option<String>,
    starts: Vec<StartRecord>,
    /// The seq of the start waiting behind the running move, and the scan it was first seen.
    waiting_since: Option<(u16, f64)>,
    /// The running move's permit, latched when it started.
    permit: Permit,
}

impl Program {
    /// The program as loaded at power-up, homed or not.
    pub(super) fn new(homed: bool) -> Self {
        Self {
            state: State::Idle,
            fault: Fault::None,
            seq: 0,
            heartbeat: 0,
            segment: [0; CHANNELS],
            runs: Default::default(),
            homed,
            homing: None,
            first_scan: true,
            last_fault: None,
            starts: Vec::new(),
            waiting_since: None,
            permit: Permit::NONE,
        }
    }

    /// The program's state.
    #[must_use]
    pub(super) fn state(&self) -> State {
        self.state
    }

    /// Whether the homed bit is set.
    #[must_use]
    pub(super) fn homed(&self) -> bool {
        self.homed
    }

    /// Why the last fault was latched, for logs and the demo.
    #[must_use]
    pub(super) fn last_fault(&self) -> Option<&str> {
        self.last_fault.as_deref()
    }

    /// Every start the program acted on, refused or ignored, in order.
    #[must_use]
    pub(super) fn starts(&self) -> &[StartRecord] {
        &self.starts
    }

    /// Power lost and back: the next scan is a first scan, and the homed bit is gone.
    pub(super) fn power_cycle(&mut self) {
        self.runs = Default::default();
        self.homing = None;
        self.homed = false;
        self.first_scan = true;
    }

    /// One scan at `at_s`, scan number `scan`.
    pub(super) fn scan(&mut self, at_s: f64, scan: u64, layout: &Layout, io: &mut ScanIo<'_>) {
        if std::mem::take(&mut self.first_scan) {
            self.clear_on_first_scan(io.memory, layout);
        }
        if !io.inputs.freeze_heartbeat {
            self.heartbeat = self.heartbeat.wrapping_add(1);
        }
        let command = io.memory.dt(u32::from(layout.command_base)).unwrap_or(0);
        if command == Command::Start.word() {
            self.on_start(at_s, scan, layout, io);
        }
        if self.state == State::Running {
            self.chain(at_s, scan, io, layout);
        }
        if self.state == State::Running {
            self.finish_if_done(io.engines, io.inputs.variant);
        }
        if self.state == State::Homing {
            self.home_progress(at_s, io, layout);
        }
        let checks_permit = io.inputs.variant.checks_permit();
        if self.state == State::Running && checks_permit && !self.permit.holds(&io.cell) {
            self.hold(at_s, io, layout);
        }
        let from_input = io.inputs.estop_open;
        if from_input || command == Command::Stop.word() {
            self.stop(at_s, io, layout, from_input);
        }
        if command == Command::ClearFault.word() {
            self.clear_fault(io.memory, layout);
        }
        if command == Command::Home.word() {
            self.on_home(at_s, layout, io);
        }
        self.write_status(io, layout);
    }

    /// R9013: state idle, seq 0, waiting 0, command 0, both host words 0 (the homed bit was
    /// cleared when the program stopped: a mock homed at power-up stands for a machine homed
    /// before linterpd came).
    fn clear_on_first_scan(&mut self, memory: &mut Memory, layout: &Layout) {
        self.state = State::Idle;
        self.fault = Fault::None;
        self.seq = 0;
        self.runs = Default::default();
        self.homing = None;
        let base = u32::from(layout.command_base);
        let _ = memory.write_dt(base, &[Command::None.word()]);
        let _ = memory.write_dt(base + u32::from(COMMAND_HOST_OFFSET), &[0]);
        tracing::info!(homed = self.homed, "PLC program first scan");
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

    fn chain(&mut self, at_s: f64, scan: u64, io: &mut ScanIo<'_>, layout: &Layout) {
        for c in 0..CHANNELS {
            let Some(run) = &mut self.runs[c] else {
                continue;
            };
            let running = still_running(run, &io.engines[c], io.inputs.variant);
            if running || run.started_scan >= scan || run.next >= run.segments.len() {
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
                    // A move that ends in a fault drops the start waiting behind it.
                    return self.latch(Fault::PulseInstruction, e.to_string(), io, layout);
                }
            }
        }
    }

    fn finish_if_done(&mut self, engines: &[Engine; CHANNELS], variant: MockVariant) {
        let done = self.runs.iter().zip(engines).all(|(run, e)| {
            run.as_ref()
                .is_none_or(|r| !still_running(r, e, variant) && r.next >= r.segments.len())
        });
        if done {
            self.runs = Default::default();
            self.state = State::Done;
            tracing::info!(seq = self.seq, "done");
        }
    }

    fn stop(&mut self, at_s: f64, io: &mut ScanIo<'_>, layout: &Layout, from_input: bool) {
        let aborts = io.inputs.variant.stop_aborts();
        for e in io.engines.iter_mut() {
            e.halt(at_s, aborts);
        }
        self.runs = Default::default();
        // Dropping the command word drops a waiting start with it.
        Self::set_command(io.memory, layout, Command::None);
        if self.state == State::Homing {
            self.homing = None;
            if from_input {
                let why = "the e-stop input opened while homing".to_owned();
                return self.latch(Fault::HomingFailed, why, io, layout);
            }
        }
        if self.state != State::Fault {
            self.state = State::Stopped;
            if from_input {
                self.fault = Fault::StoppedFromOutside;
            }
        }
    }

    /// The running move's permit stopped holding: every channel stops in this scan.
    fn hold(&mut self, at_s: f64, io: &mut ScanIo<'_>, layout: &Layout) {
        tracing::warn!(seq = self.seq, inputs = ?io.cell, "permit dropped: stopping");
        self.stop(at_s, io, layout, false);
        self.fault = Fault::PermitDropped;
        self.last_fault = Some(format!(
            "the permit of start {} stopped holding on inputs {:04X?}",
            self.seq, io.cell
        ));
    }

    fn clear_fault(&mut self, memory: &mut Memory, layout: &Layout) {
        self.fault = Fault::None;
        self.last_fault = None;
        if !matches!(self.state, State::Running | State::Homing) {
            self.state = State::Idle;
        }
        Self::set_command(memory, layout, Command::None);
    }

    /// `command = 4` in idle, done or stopped: the home routine starts for the channels in
    /// `mask`; in any other state the command is dropped.
    fn on_home(&mut self, at_s: f64, layout: &Layout, io: &mut ScanIo<'_>) {
        if !matches!(self.state, State::Idle | State::Done | State::Stopped) {
            return Self::set_command(io.memory, layout, Command::None);
        }
        let block = read_block(io.memory, layout);
        if block.mask == 0 || block.mask >> CHANNELS != 0 {
            let why = format!("home mask {:#06b} names no channel 0-3", block.mask);
            return self.latch(Fault::BadTableHeader, why, io, layout);
        }
        self.homed = false;
        self.homing = Some(Homing {
            mask: block.mask,
            from: block.from,
            done_at_s: at_s + io.inputs.home_s,
        });
        self.state = State::Homing;
        Self::set_command(io.memory, layout, Command::None);
        tracing::info!(mask = block.mask, at_s, "homing");
    }

    fn home_progress(&mut self, at_s: f64, io: &mut ScanIo<'_>, layout: &Layout) {
        let Some(homing) = self.homing else {
            let why = "homing state without a home routine".to_owned();
            return self.latch(Fault::HomingFailed, why, io, layout);
        };
        if at_s + 1e-12 < homing.done_at_s {
            return;
        }
        for c in (0..CHANNELS).filter(|c| homing.mask & (1 << c) != 0) {
            io.engines[c].set_count(i64::from(homing.from[c]));
        }
        self.homing = None;
        self.homed = true;
        self.state = State::Done;
        tracing::info!(mask = homing.mask, from = %homing.from.map(|c| c.to_string()).join(","), "homed");
    }

    /// Stops everything for PROG mode: a running move ends stopped. Back in RUN the program
    /// starts with a first scan.
    pub(super) fn enter_prog(&mut self, engines: &mut [Engine; CHANNELS]) {
        for e in engines.iter_mut() {
            e.stop();
        }
        self.runs = Default::default();
        self.homing = None;
        if matches!(self.state, State::Running | State::Homing) {
            self.state = State::Stopped;
        }
        self.homed = false;
        self.first_scan = true;
    }

    fn write_status(&self, io: &mut ScanIo<'_>, layout: &Layout) {
        let mut busy = 0;
        for (c, e) in io.engines.iter().enumerate() {
            busy |= u16::from(e.busy() && io.inputs.variant.busy_flags_work()) << c;
        }
        let mut ready = io.inputs.ready & !READY_HOMED;
        if io.inputs.estop_open {
            ready &= !READY_ESTOP_CLEAR;
        }
        if self.homed {
            ready |= READY_HOMED;
        }
        let block = read_block(io.memory, layout);
        let pending = io.memory.dt(u32::from(layout.command_base)).unwrap_or(0);
        let waiting = if pending == Command::Start.word() && block.seq != self.seq {
            block.seq
        } else {
            0
        };
        let status = StatusBlock {
            magic: MAGIC,
            version: VERSION,
            heartbeat: self.heartbeat,
            state: self.state.word(),
            seq: self.seq,
            fault: self.fault.word(),
            busy,
            ready,
            elapsed: std::array::from_fn(|c| io.engines[c].count() as i32),
            segment: self.segment,
            host: block.host,
            waiting,
            inputs: io.cell,
        };
        let _ = io
            .memory
            .write_dt(u32::from(layout.status_base), &status.to_words());
    }
}

/// Whether the program sees the segment a channel runs as still running: its busy flag, or,
/// with busy relays that never rise, the count short of the segment's last target (the listing
/// ends a segment when its flag is OFF and was seen ON, or when the count shows that target).
fn still_running(run: &ChannelRun, engine: &Engine, variant: MockVariant) -> bool {
    if variant.busy_flags_work() {
        return engine.busy();
    }
    let current = run.next.checked_sub(1).and_then(|i| run.segments.get(i));
    current
        .and_then(|s| s.rows.last())
        .is_some_and(|row| engine.count() != row.target)
}

/// The cell's input words as they stand in memory, in the layout's order (a word the memory
/// does not hold reads 0: the config checks the words against the FP-X's areas).
pub(super) fn cell_inputs(memory: &Memory, layout: &Layout) -> [u16; INPUT_WORDS] {
    std::array::from_fn(|i| {
        let word = layout.inputs[i];
        let area = match word.area {
            InputArea::X => Area::X,
            InputArea::R => Area::R,
        };
        memory
            .read_bit_words(area, u32::from(word.word), 1)
            .map_or(0, |w| w[0])
    })
}

/// The command block as it stands in memory.
fn read_block(memory: &Memory, layout: &Layout) -> CommandBlock {
    memory
        .read_dt(u32::from(layout.command_base), COMMAND_WORDS)
        .ok()
        .and_then(CommandBlock::from_words)
        .unwrap_or_default()
}
