//! The mock PLC: an FP-X running the contract's PLC program (`CONTRACT.md`), synchronous and
//! deterministic. No sockets and no clock: time is an argument (`now_s`, seconds since the mock
//! started). Servers (MEWTOCOL-COM, Modbus) wrap a [`MockPlc`] in `Arc<Mutex<_>>`, advance it to
//! their clock's time before each command, and consult [`MockPlc::on_command`] for link faults;
//! [`InProcess`] does the same without any protocol, for contract-flow tests.
//!
//! ```text
//! memory.rs      DT0..=DT32764, R0..=R255F, range errors
//! program.rs     the contract's PLC program, one scan at a time
//! engine.rs      one F174 pulse channel on the shared execution model (crate::sim)
//! trace.rs       pulse trace (CSV) and anomalies (clamped rows, run-ons)
//! faults.rs      seeded, scriptable fault injection
//! cell/          PURE  a simulated cell (press, stack, sensors) driving the inputs every scan
//! control.rs     the control socket: force and release the cell's inputs, by hand
//! clock.rs       virtual and real clocks for drivers
//! in_process.rs  a crate::plc::Plc handle on a shared mock
//! shared.rs      SharedMock: the mock behind Arc<Mutex<_>> with its clock and scan driver
//! wire.rs        WireStream: serial line timing (11-bit characters at a baud rate)
//! variant.rs     MockVariant: the listing, or one defect a real unit might have
//! answer.rs      MEWTOCOL-COM commands executed on the mock; station rules
//! mewtocol_server.rs  MEWTOCOL-COM server over any byte stream or a TCP listener
//! modbus_server.rs    Modbus TCP / RTU servers through tokio-modbus
//! ```
//!
//! Time: scans run at `k * scan_s` while in RUN; between scans the pulse engines run on their
//! own, so every pulse lands at its model time, not at a scan.

mod answer;
pub mod cell;
mod clock;
pub mod control;
mod engine;
mod faults;
mod in_process;
mod memory;
mod mewtocol_server;
mod modbus_server;
mod program;
mod shared;
mod trace;
mod variant;
mod wire;

use thiserror::Error;

pub use answer::{Route, StationFilter, execute as execute_mewtocol, plc_status};
pub use clock::{Clock, RealClock, VirtualClock};
pub use engine::PulseError;
pub use faults::{
    Action, CoreFault, FaultInjector, FaultItem, FaultScript, Fired, ItemFault, LinkFault,
    ScriptError, Trigger,
};
pub use in_process::InProcess;
pub use memory::{IO_WORDS, Memory, MemoryError, RELAY_HOLD_WORD, RELAY_LAST, RELAY_WORDS};
pub use mewtocol_server::{MewtocolServer, MewtocolServerOptions, ServerError};
pub use modbus_server::{ModbusServer, ModbusServerOptions};
pub use program::{HeaderError, StartOutcome, StartRecord};
pub use shared::SharedMock;
pub use trace::{
    Anomaly, HostWrite, PowerCut, PulsePoint, Recorder, RestartSeen, TableWrite, write_csv,
};
pub use variant::{MockVariant, SMALL_MEWTOCOL_WORDS, SMALL_MODBUS_REGISTERS};
pub use wire::{BITS_PER_CHAR, WireStream, wire_time};

use crate::contract::{CHANNELS, Layout, LayoutError, State, StatusBlock};
use crate::plc::PlcMode;
use crate::table::FrequencyModel;
use engine::Engine;
use program::{Inputs, Program, ScanIo};

/// Default scan time, s.
pub const DEFAULT_SCAN_S: f64 = 0.002;
/// Top frequency per channel of an FP-X C60T (PLC.md §3, "Channels"): 100 kHz on 0-1, 20 kHz on
/// 2-3.
pub const FPX_C60T_MAX_HZ: [u32; CHANNELS] = [100_000, 100_000, 20_000, 20_000];
/// Default time the mock's home routine takes, s.
pub const DEFAULT_HOME_S: f64 = 0.1;
/// A scan due within this much of `now_s` runs (so clocks stepped by sums of floats do not skip
/// a scan).
const SCAN_SLACK_S: f64 = 1e-9;

/// How the mock is built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MockConfig {
    /// Where the contract's blocks and areas sit.
    pub layout: Layout,
    /// Scan time, s.
    pub scan_s: f64,
    /// What the channels really output (unless the variant imposes a model).
    pub model: FrequencyModel,
    /// Top frequency per channel, Hz.
    pub channel_max_hz: [u32; CHANNELS],
    /// Whether the channels are homed at power-up (a machine homed before linterpd came; the
    /// contract's power-up state is `false`: `linterpd mock-plc --unhomed`).
    pub homed: bool,
    /// How long the home routine takes, s.
    pub home_s: f64,
    /// The listing, or one defect (`linterpd mock-plc --variant`).
    pub variant: MockVariant,
}

impl Default for MockConfig {
    fn default() -> Self {
        Self {
            layout: Layout::default(),
            scan_s: DEFAULT_SCAN_S,
            model: FrequencyModel::default(),
            channel_max_hz: FPX_C60T_MAX_HZ,
            homed: true,
            home_s: DEFAULT_HOME_S,
            variant: MockVariant::Listing,
        }
    }
}

/// Why a mock cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MockError {
    /// The layout does not fit DT memory.
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// The scan time is not a positive number of seconds.
    #[error("scan time {scan_s} s must be above 0")]
    ScanTime {
        /// The scan time given.
        scan_s: f64,
    },
}

/// The most host writes a mock keeps ([`MockPlc::host_writes`]); older ones go, half at a time.
pub const HOST_WRITES_KEPT: usize = 10_000;

/// An FP-X running the contract's PLC program.
#[derive(Debug, Clone)]
pub struct MockPlc {
    config: MockConfig,
    memory: Memory,
    engines: [Engine; CHANNELS],
    program: Program,
    mode: PlcMode,
    now_s: f64,
    next_scan: u64,
    ready: u16,
    estop_open: bool,
    heartbeat_frozen: bool,
    recorder: Recorder,
    faults: FaultInjector,
    commands: u64,
    /// Replies of several frames left unanswered (the `one-frame-replies` variant).
    unanswered_multi_frame: u64,
    /// The simulated cell driving the inputs (none by default).
    cell: cell::Cell,
}

impl MockPlc {
    /// A mock in RUN at t = 0, memory zero, counts 0, drives ready, e-stop closed, homed as the
    /// config says; its first scan has run (at t = 0).
    pub fn new(config: MockConfig) -> Result<Self, MockError> {
        config.layout.check()?;
        if !(config.scan_s.is_finite() && config.scan_s > 0.0) {
            return Err(MockError::ScanTime {
                scan_s: config.scan_s,
            });
        }
        let model = config.variant.model().unwrap_or(config.model);
        let engines =
            std::array::from_fn(|c| Engine::new(c as u8, config.channel_max_hz[c], model));
        let mut mock = Self {
            config,
            memory: Memory::new(),
            engines,
            program: Program::new(config.homed),
            mode: PlcMode::Run,
            now_s: 0.0,
            next_scan: 0,
            ready: 0b111,
            estop_open: false,
            heartbeat_frozen: false,
            recorder: Recorder::default(),
            faults: FaultInjector::default(),
            commands: 0,
            unanswered_multi_frame: 0,
            cell: cell::Cell::default(),
        };
        // The first scan (R9013) runs at power-up, before anybody can write to the PLC.
        mock.advance_to(0.0);
        Ok(mock)
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &MockConfig {
        &self.config
    }

    /// How far the mock has run, s.
    #[must_use]
    pub fn now_s(&self) -> f64 {
        self.now_s
    }

    /// Scans run or skipped (PROG) so far.
    #[must_use]
    pub fn scans(&self) -> u64 {
        self.next_scan
    }

    /// Runs every scan due up to `now_s`, in order, with the pulse engines advanced exactly to
    /// each scan, then the engines to `now_s`. A time before the mock's own is ignored.
    pub fn advance_to(&mut self, now_s: f64) {
        if now_s.is_nan() || now_s < self.now_s {
            return;
        }
        loop {
            let at_s = self.next_scan as f64 * self.config.scan_s;
            if at_s > now_s + SCAN_SLACK_S {
                break;
            }
            self.advance_engines(at_s);
            self.apply_due_faults(at_s);
            self.step_cell(at_s);
            if self.mode == PlcMode::Run {
                self.scan(at_s);
            }
            self.next_scan += 1;
        }
        self.advance_engines(now_s);
        self.apply_due_faults(now_s);
        self.now_s = now_s;
    }

    fn advance_engines(&mut self, to_s: f64) {
        for e in &mut self.engines {
            e.advance(to_s, &mut self.recorder);
        }
    }

    /// The cell's models stepped at `at_s` on what the PLC shows, their inputs written (the
    /// outside world runs in PROG mode too).
    fn step_cell(&mut self, at_s: f64) {
        if self.cell.is_idle() {
            return;
        }
        let memory = &self.memory;
        let bit = |a: crate::gateway::Address| memory.bit(a.area, a.index).unwrap_or(false);
        let seen = cell::Seen {
            bit: &bit,
            counts: std::array::from_fn(|c| self.engines[c].count()),
        };
        for (a, on) in self.cell.step(at_s, &seen) {
            // Checked against the mock's memory when the description was read.
            let _ = self.memory.set_bit(a.area, a.index, on);
        }
    }

    /// The simulated cell.
    #[must_use]
    pub fn cell(&self) -> &cell::Cell {
        &self.cell
    }

    /// The simulated cell, to force an input.
    pub fn cell_mut(&mut self) -> &mut cell::Cell {
        &mut self.cell
    }

    /// Runs `cell` from now on (its inputs are written from the next scan).
    pub fn set_cell(&mut self, cell: cell::Cell) {
        self.cell = cell;
    }

    fn scan(&mut self, at_s: f64) {
        let cell = program::cell_inputs(&self.memory, &self.config.layout);
        let mut io = ScanIo {
            memory: &mut self.memory,
            engines: &mut self.engines,
            rec: &mut self.recorder,
            inputs: Inputs {
                ready: self.ready,
                estop_open: self.estop_open,
                freeze_heartbeat: self.heartbeat_frozen,
                home_s: self.config.home_s,
                variant: self.config.variant,
            },
            cell,
        };
        self.program
            .scan(at_s, self.next_scan, &self.config.layout, &mut io);
        if self.recorder.restart == RestartSeen::NotScanned {
            self.recorder.restart = RestartSeen::Unseen;
        }
        for (c, e) in self.engines.iter().enumerate() {
            if e.running_on() && self.next_scan.is_multiple_of(self.scans_per_second()) {
                tracing::error!(
                    channel = c,
                    count = e.count(),
                    at_s,
                    "channel still running on without end"
                );
            }
        }
    }

    fn scans_per_second(&self) -> u64 {
        ((1.0 / self.config.scan_s).round() as u64).max(1)
    }

    /// RUN or PROG.
    #[must_use]
    pub fn mode(&self) -> PlcMode {
        self.mode
    }

    /// Switches mode. Entering PROG stops every channel and the program (a running move ends
    /// stopped); the status block then holds still, heartbeat included. Back in RUN the program
    /// begins with a first scan (CONTRACT.md: state idle, seq 0, host 0, homed bit clear).
    pub fn set_mode(&mut self, mode: PlcMode) {
        if mode == PlcMode::Prog && self.mode == PlcMode::Run {
            self.program.enter_prog(&mut self.engines);
            tracing::warn!(at_s = self.now_s, "mock PLC switched to PROG");
        }
        self.mode = mode;
    }

    /// The program's state.
    #[must_use]
    pub fn state(&self) -> State {
        self.program.state()
    }

    /// Why the last fault was latched.
    #[must_use]
    pub fn last_fault(&self) -> Option<&str> {
        self.program.last_fault()
    }

    /// The status block as it stands in memory.
    #[must_use]
    pub fn status(&self) -> StatusBlock {
        let words = self.memory.read_dt(
            u32::from(self.config.layout.status_base),
            crate::contract::STATUS_WORDS,
        );
        words
            .ok()
            .and_then(StatusBlock::from_words)
            .unwrap_or_default()
    }

    /// Device memory (DT and R).
    #[must_use]
    pub fn memory(&self) -> &Memory {
        &self.memory
    }

    /// Device memory, for writes from a server or a test.
    pub fn memory_mut(&mut self) -> &mut Memory {
        &mut self.memory
    }

    /// Reads `count` DT words from `start`.
    pub fn read_words(&self, start: u32, count: usize) -> Result<Vec<u16>, MemoryError> {
        self.memory.read_dt(start, count).map(<[u16]>::to_vec)
    }

    /// Writes DT words from `start`.
    pub fn write_words(&mut self, start: u32, words: &[u16]) -> Result<(), MemoryError> {
        self.memory.write_dt(start, words)
    }

    /// A client's read of DT words: [`Self::read_words`], noting a read of the status block's
    /// `host` word (the host learns of a power cycle from it).
    pub fn host_read_words(&mut self, start: u32, count: usize) -> Result<Vec<u16>, MemoryError> {
        let words = self.read_words(start, count)?;
        let host = u32::from(self.config.layout.status_base) + 20;
        if (start..start + count as u32).contains(&host)
            && self.recorder.restart == RestartSeen::Unseen
        {
            self.recorder.restart = RestartSeen::Seen;
        }
        Ok(words)
    }

    /// A client's write of DT words: [`Self::write_words`], recorded ([`Self::host_writes`]).
    pub fn host_write_words(&mut self, start: u32, words: &[u16]) -> Result<(), MemoryError> {
        self.write_words(start, words)?;
        self.note_host_write(crate::gateway::Area::Dt, start, words.to_vec());
        Ok(())
    }

    /// A client's write of a Y or R bit: [`Self::write_bit`], recorded ([`Self::host_writes`]).
    pub fn host_write_bit(
        &mut self,
        area: crate::gateway::Area,
        bit: u32,
        on: bool,
    ) -> Result<(), MemoryError> {
        self.write_bit(area, bit, on)?;
        self.note_host_write(area, bit, vec![u16::from(on)]);
        Ok(())
    }

    fn note_host_write(&mut self, area: crate::gateway::Area, start: u32, values: Vec<u16>) {
        if area == crate::gateway::Area::Dt && self.config.layout.holds(start) {
            // The contract's own words: its starts are recorded as such, its uploads here.
            if let Some((bank, channel)) = self.config.layout.table_area_of(start) {
                self.note_table_write(bank, channel, start, values.len());
            }
            return;
        }
        let kept = &mut self.recorder.host_writes;
        if kept.len() == HOST_WRITES_KEPT {
            kept.drain(..HOST_WRITES_KEPT / 2);
        }
        let write = HostWrite {
            command: self.commands,
            area,
            start,
            values,
            after_restart_seen: self.recorder.restart == RestartSeen::Seen,
            counts: std::array::from_fn(|c| self.engines[c].count()),
        };
        self.recorder.host_writes.push(write);
    }

    fn note_table_write(&mut self, bank: u16, channel: usize, start: u32, words: usize) {
        let kept = &mut self.recorder.table_writes;
        if kept.len() == HOST_WRITES_KEPT {
            kept.drain(..HOST_WRITES_KEPT / 2);
        }
        kept.push(TableWrite {
            command: self.commands,
            at_s: self.now_s,
            bank,
            channel,
            start,
            words,
        });
    }

    /// The writes a client made (over MEWTOCOL, Modbus or in process) into the table areas (the
    /// uploads and preloads), in order, each with when it landed; the last
    /// [`HOST_WRITES_KEPT`] at most.
    #[must_use]
    pub fn table_writes(&self) -> &[TableWrite] {
        &self.recorder.table_writes
    }

    /// The writes a client made (over MEWTOCOL, Modbus or in process) outside the contract's
    /// blocks and table areas (the cell's outputs), in order, each with whether the host could
    /// have known of the last power cycle before it; the last [`HOST_WRITES_KEPT`] at most.
    #[must_use]
    pub fn host_writes(&self) -> &[HostWrite] {
        &self.recorder.host_writes
    }

    /// Every power cut so far, in order, with what it lost.
    #[must_use]
    pub fn power_cuts(&self) -> &[PowerCut] {
        &self.recorder.power_cuts
    }

    /// Reads relay R`relay` (word * 16 + bit).
    pub fn read_relay(&self, relay: u32) -> Result<bool, MemoryError> {
        self.memory.relay(relay)
    }

    /// Writes relay R`relay`.
    pub fn write_relay(&mut self, relay: u32, on: bool) -> Result<(), MemoryError> {
        self.memory.set_relay(relay, on)
    }

    /// Reads bit `bit` (word * 16 + bit) of X, Y or R; R9020 reads whether the mock runs.
    pub fn read_bit(&self, area: crate::gateway::Area, bit: u32) -> Result<bool, MemoryError> {
        if area == crate::gateway::Area::R && bit == u32::from(crate::plc::R9020) {
            return Ok(self.mode == PlcMode::Run);
        }
        self.memory.bit(area, bit)
    }

    /// Writes bit `bit` of Y or R (an X input is the outside world's: [`Self::set_input`]).
    pub fn write_bit(
        &mut self,
        area: crate::gateway::Area,
        bit: u32,
        on: bool,
    ) -> Result<(), MemoryError> {
        if area == crate::gateway::Area::X {
            return Err(MemoryError::BitOutOfRange {
                area: "X",
                bit,
                last: 0,
            });
        }
        self.memory.set_bit(area, bit, on)
    }

    /// Sets input X`bit` (word * 16 + bit), as the wiring would (a bit the cell drives is set
    /// again by the cell at the next scan: force it through [`Self::cell_mut`] instead).
    pub fn set_input(&mut self, bit: u32, on: bool) -> Result<(), MemoryError> {
        self.memory.set_bit(crate::gateway::Area::X, bit, on)
    }

    /// Sets the `ready` word's wired bits (bit 1 drives ready, bit 2 e-stop clear); bit 0,
    /// homed, is the program's own and is ignored here.
    pub fn set_ready(&mut self, bits: u16) {
        self.ready = bits & !crate::contract::READY_HOMED;
    }

    /// Whether the program's homed bit is set.
    #[must_use]
    pub fn homed(&self) -> bool {
        self.program.homed()
    }

    /// Every start command the program acted on, refused or dropped, in order (a start that
    /// waited is recorded when it is acted on).
    #[must_use]
    pub fn starts(&self) -> &[StartRecord] {
        self.program.starts()
    }

    /// A power cycle: every channel stops and its count is lost (0), every Y output and every
    /// non-hold R relay (below WR248) goes off, the program starts over with a first scan and the
    /// homed bit clear. DT memory is kept (the table areas and the command block's words are
    /// hold registers); the first scan clears the contract's words. Recorded
    /// ([`Self::power_cuts`]).
    pub fn power_cycle(&mut self) {
        let (outputs, relays) = self.memory.power_cut();
        self.recorder.power_cuts.push(PowerCut {
            command: self.commands,
            counts: std::array::from_fn(|c| self.engines[c].count()),
            outputs,
            relays,
        });
        for e in &mut self.engines {
            e.stop();
            e.set_count(0);
        }
        self.program.power_cycle();
        self.recorder.restart = RestartSeen::NotScanned;
        tracing::warn!(at_s = self.now_s, "mock PLC power-cycled");
    }

    /// Opens (true) or closes the e-stop input. While it is open every scan stops every channel
    /// (fault 3) and `ready` bit 2 reads 0.
    pub fn set_estop_open(&mut self, open: bool) {
        self.estop_open = open;
    }

    /// A channel's elapsed count (the engine's, not the status block's copy).
    #[must_use]
    pub fn count(&self, channel: usize) -> i64 {
        self.engines[channel].count()
    }

    /// Presets a channel's count (as homing or writing the elapsed-value register does).
    pub fn set_count(&mut self, channel: usize, count: i64) {
        self.engines[channel].set_count(count);
    }

    /// Whether a channel is outputting pulses.
    #[must_use]
    pub fn busy(&self, channel: usize) -> bool {
        self.engines[channel].busy()
    }

    /// Whether a channel is running on without end (a target against its direction).
    #[must_use]
    pub fn running_on(&self, channel: usize) -> bool {
        self.engines[channel].running_on()
    }

    /// Starts or stops recording every pulse (it can be large). Stopping drops the record.
    pub fn record_pulses(&mut self, on: bool) {
        self.recorder.pulses = on.then(|| self.recorder.pulses.take().unwrap_or_default());
    }

    /// The pulses recorded so far, emptying the record (recording goes on).
    pub fn take_pulses(&mut self) -> Vec<PulsePoint> {
        self.recorder
            .pulses
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Every anomaly since the mock started (clamped rows, run-ons).
    #[must_use]
    pub fn anomalies(&self) -> &[Anomaly] {
        &self.recorder.anomalies
    }

    /// Installs a fault script, starting it from the beginning.
    pub fn set_faults(&mut self, script: FaultScript) {
        self.faults = FaultInjector::new(script);
    }

    /// Whether the heartbeat is frozen.
    #[must_use]
    pub fn heartbeat_frozen(&self) -> bool {
        self.heartbeat_frozen
    }

    /// Freezes or thaws the heartbeat (scans go on).
    pub fn freeze_heartbeat(&mut self, frozen: bool) {
        self.heartbeat_frozen = frozen;
    }

    /// Replies of several frames a server left unanswered so far (`one-frame-replies`).
    #[must_use]
    pub fn unanswered_multi_frame(&self) -> u64 {
        self.unanswered_multi_frame
    }

    /// A server left a reply of several frames unanswered.
    pub fn note_unanswered_multi_frame(&mut self) {
        self.unanswered_multi_frame += 1;
    }

    /// Commands counted by [`Self::on_command`] so far.
    #[must_use]
    pub fn commands(&self) -> u64 {
        self.commands
    }

    /// A server calls this once per command it receives, after advancing the mock: it counts the
    /// command (the first is number 1), applies the core faults due at it and returns the link
    /// faults the server must apply to its reply.
    pub fn on_command(&mut self) -> Vec<LinkFault> {
        self.commands += 1;
        let fired = self.faults.on_command(self.commands);
        for f in fired.core {
            self.apply_core_fault(f);
        }
        fired.link
    }

    fn apply_due_faults(&mut self, at_s: f64) {
        for f in self.faults.due_at(at_s) {
            self.apply_core_fault(f);
        }
    }

    fn apply_core_fault(&mut self, fault: CoreFault) {
        tracing::warn!(%fault, at_s = self.now_s, "injected fault");
        match fault {
            CoreFault::FreezeHeartbeat => self.heartbeat_frozen = true,
            CoreFault::ThawHeartbeat => self.heartbeat_frozen = false,
            CoreFault::Prog => self.set_mode(PlcMode::Prog),
            CoreFault::Run => self.set_mode(PlcMode::Run),
            CoreFault::PowerCycle => self.power_cycle(),
        }
    }
}

#[cfg(test)]
mod server_tests;
#[cfg(test)]
mod tests;
