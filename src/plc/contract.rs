//! The register contract's flow on top of any [`Plc`] (CONTRACT.md, "What linterpd does for one
//! move"): read and check the status block, write a bank and the command block, read back and
//! compare, start, stop, clear a fault, follow a start to its end.
//!
//! A start can only be given a [`VerifiedBank`], which only [`Contract::upload`] makes, after
//! every word of the bank and the command block is written and (unless switched off) read back
//! equal: no start can point at a partly written or unverified bank.

use std::time::Duration;

use thiserror::Error;
use tokio::time::Instant;

use super::{Plc, PlcError, PlcMode};
use crate::contract::{
    CHANNELS, COMMAND_WORDS, Command, CommandBlock, Fault, Layout, MAGIC, STATUS_WORDS, State,
    StatusBlock, UnknownValue, VERSION,
};
use crate::table::{DIRECTORY_WORDS, ValidTable, encode};

/// How the flow behaves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContractSettings {
    /// Where the blocks and areas are.
    pub layout: Layout,
    /// Read back every written word and compare (CONTRACT.md: on by default).
    pub verify: bool,
    /// A heartbeat that does not change for this long means the PLC is stalled or in PROG.
    pub heartbeat_timeout: Duration,
    /// Ready bits that must be set before a start (bit 0 homed, 1 drives ready, 2 e-stop clear).
    pub required_ready: u16,
    /// Time between status polls while following a start.
    pub poll_interval: Duration,
}

impl Default for ContractSettings {
    fn default() -> Self {
        Self {
            layout: Layout::default(),
            verify: true,
            heartbeat_timeout: Duration::from_millis(500),
            required_ready: 0b111,
            poll_interval: Duration::from_millis(20),
        }
    }
}

/// Why the contract refuses to go on.
#[derive(Debug, Error)]
pub enum ContractError {
    /// The exchange with the PLC failed.
    #[error(transparent)]
    Plc(#[from] PlcError),
    /// The program is not there (or not ours).
    #[error(
        "status block magic is {found:#06x}, expected {MAGIC:#06x}: the linterpd PLC program is not running at DT{base}"
    )]
    BadMagic {
        /// What was read.
        found: u16,
        /// Status block address.
        base: u16,
    },
    /// The program speaks another contract version.
    #[error("the PLC program speaks contract version {found}; this linterpd speaks {VERSION}")]
    WrongVersion {
        /// What was read.
        found: u16,
    },
    /// The heartbeat stopped.
    #[error(
        "the PLC heartbeat stayed at {value} for {waited_ms} ms (limit {timeout_ms} ms): the PLC is stalled{mode}"
    )]
    StaleHeartbeat {
        /// The frozen value.
        value: u16,
        /// How long it was watched.
        waited_ms: u64,
        /// The limit.
        timeout_ms: u64,
        /// ", and in PROG mode" when the PLC says so.
        mode: &'static str,
    },
    /// A fault is latched on the PLC.
    #[error("the PLC program reports fault {code} ({meaning}); clear it first")]
    Faulted {
        /// Fault word.
        code: u16,
        /// Its meaning.
        meaning: &'static str,
    },
    /// The integrator's ready bits are not all set.
    #[error(
        "the PLC is not ready: ready bits {ready:#05b}, need {required:#05b} (bit 0 homed, 1 drives ready, 2 e-stop clear)"
    )]
    NotReady {
        /// What was read.
        ready: u16,
        /// What is required.
        required: u16,
    },
    /// A word the contract does not define.
    #[error("status block: {0}")]
    Unknown(#[from] UnknownValue),
    /// Read-back differs from what was written.
    #[error(
        "read-back of DT{address} gave {read:#06x}, wrote {wrote:#06x}: the bank is not verified and will not be started"
    )]
    CompareFailed {
        /// DT address.
        address: u16,
        /// Written.
        wrote: u16,
        /// Read.
        read: u16,
    },
    /// A table does not fit its channel's area.
    #[error("channel {channel} table is {words} words; its area holds {area_words}")]
    TooLarge {
        /// Channel.
        channel: u8,
        /// Words.
        words: usize,
        /// Area size.
        area_words: u16,
    },
    /// Two tables for one channel, or a channel beyond 3.
    #[error("channel {channel} appears twice or is not 0-3")]
    BadChannel {
        /// Channel.
        channel: u8,
    },
    /// A bank number other than 0 or 1.
    #[error("bank {bank} does not exist; banks are 0 and 1")]
    BadBank {
        /// Bank.
        bank: u16,
    },
    /// The upload was abandoned between two exchanges (a stop overtook it); nothing was started.
    #[error("upload abandoned before it was complete; nothing was started")]
    Aborted,
    /// The start ended in a fault or a stop instead of done.
    #[error("start {seq} ended {state}{}", if *fault != 0 { format!(" with fault {fault}") } else { String::new() })]
    Ended {
        /// Sequence number.
        seq: u16,
        /// Final state name.
        state: &'static str,
        /// Fault word.
        fault: u16,
    },
}

/// A bank whose every word was written and verified, ready for one start.
#[derive(Debug, Clone, PartialEq, Eq)]
#[must_use = "an uploaded bank does nothing until it is started"]
pub struct VerifiedBank {
    /// The command block as written (command word still 0).
    pub block: CommandBlock,
    /// Words written (tables and command block).
    pub words: usize,
}

/// The status block with its words decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// The raw block.
    pub block: StatusBlock,
    /// Its state.
    pub state: State,
    /// Its fault.
    pub fault: Fault,
}

/// The contract flow over one PLC link.
#[derive(Debug)]
pub struct Contract<P> {
    plc: P,
    settings: ContractSettings,
    heartbeat: Option<(u16, Instant)>,
    abort: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

impl<P: Plc> Contract<P> {
    /// The flow over `plc`.
    pub fn new(plc: P, settings: ContractSettings) -> Self {
        Self {
            plc,
            settings,
            heartbeat: None,
            abort: None,
        }
    }

    /// A flag that, once set, makes [`Self::upload`] give up between two exchanges.
    pub fn set_abort(&mut self, flag: std::sync::Arc<std::sync::atomic::AtomicBool>) {
        self.abort = Some(flag);
    }

    fn aborted(&self) -> Result<(), ContractError> {
        match &self.abort {
            Some(flag) if flag.load(std::sync::atomic::Ordering::SeqCst) => {
                Err(ContractError::Aborted)
            }
            _ => Ok(()),
        }
    }

    /// The heartbeat value last seen and when it last changed.
    #[must_use]
    pub fn heartbeat(&self) -> Option<(u16, Instant)> {
        self.heartbeat
    }

    /// The link, for other requests.
    pub fn plc(&mut self) -> &mut P {
        &mut self.plc
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> &ContractSettings {
        &self.settings
    }

    /// Reads and decodes the status block, and notes the heartbeat.
    pub async fn status(&mut self) -> Result<Status, ContractError> {
        let words = self
            .plc
            .read_words(self.settings.layout.status_base, STATUS_WORDS as u16)
            .await?;
        let block = StatusBlock::from_words(&words).ok_or_else(|| PlcError::BadReply {
            operation: "read status block".into(),
            detail: format!("{} words, expected {STATUS_WORDS}", words.len()),
        })?;
        if block.magic != MAGIC {
            return Err(ContractError::BadMagic {
                found: block.magic,
                base: self.settings.layout.status_base,
            });
        }
        if block.version != VERSION {
            return Err(ContractError::WrongVersion {
                found: block.version,
            });
        }
        self.note_heartbeat(block.heartbeat);
        Ok(Status {
            block,
            state: State::from_word(block.state)?,
            fault: Fault::from_word(block.fault)?,
        })
    }

    fn note_heartbeat(&mut self, value: u16) {
        match self.heartbeat {
            Some((last, _)) if last == value => {}
            _ => self.heartbeat = Some((value, Instant::now())),
        }
    }

    /// Reads the status block until the heartbeat is seen moving: refuses a stalled PLC, one in
    /// PROG mode, a wrong program, a latched fault or missing ready bits.
    pub async fn check_alive(&mut self) -> Result<Status, ContractError> {
        let first = self.status().await?;
        let since = Instant::now();
        let mut status = first;
        while status.block.heartbeat == first.block.heartbeat {
            let waited = since.elapsed();
            if waited >= self.settings.heartbeat_timeout {
                return Err(self.stale(first.block.heartbeat, waited).await);
            }
            tokio::time::sleep(
                self.settings
                    .poll_interval
                    .min(self.settings.heartbeat_timeout.saturating_sub(waited)),
            )
            .await;
            status = self.status().await?;
        }
        if status.state == State::Fault {
            return Err(ContractError::Faulted {
                code: status.block.fault,
                meaning: status.fault.meaning(),
            });
        }
        let required = self.settings.required_ready;
        if status.block.ready & required != required {
            return Err(ContractError::NotReady {
                ready: status.block.ready,
                required,
            });
        }
        Ok(status)
    }

    async fn stale(&mut self, value: u16, waited: Duration) -> ContractError {
        let prog = matches!(self.plc.mode().await, Ok(PlcMode::Prog));
        ContractError::StaleHeartbeat {
            value,
            waited_ms: waited.as_millis() as u64,
            timeout_ms: self.settings.heartbeat_timeout.as_millis() as u64,
            mode: if prog { ", and in PROG mode" } else { "" },
        }
    }

    /// Writes every table into `bank`, then the command block except its command word, then
    /// reads all of it back and compares. Only a complete, verified upload yields the bank.
    pub async fn upload(
        &mut self,
        bank: u16,
        seq: u16,
        tables: &[ValidTable],
    ) -> Result<VerifiedBank, ContractError> {
        if bank >= crate::contract::BANKS {
            return Err(ContractError::BadBank { bank });
        }
        let mut block = CommandBlock {
            command: Command::None.word(),
            seq,
            mask: 0,
            bank,
            segments: [0; CHANNELS],
        };
        let mut writes: Vec<(u16, Vec<u16>)> = Vec::with_capacity(tables.len() + 1);
        for t in tables {
            let channel = t.table().channel;
            let c = usize::from(channel);
            if c >= CHANNELS || block.mask & (1 << c) != 0 {
                return Err(ContractError::BadChannel { channel });
            }
            let words = encode(t);
            let area_words = self.settings.layout.area_words;
            if words.len() > usize::from(area_words) || words.len() < DIRECTORY_WORDS {
                return Err(ContractError::TooLarge {
                    channel,
                    words: words.len(),
                    area_words,
                });
            }
            block.mask |= 1 << c;
            block.segments[c] = t.table().segments.len() as u16;
            writes.push((self.settings.layout.area(bank, c), words));
        }
        // Everything but the command word (offset 0), which only `start` writes.
        writes.push((
            self.settings.layout.command_base + 1,
            block.to_words()[1..COMMAND_WORDS].to_vec(),
        ));
        for (address, words) in &writes {
            self.aborted()?;
            self.plc.write_words(*address, words).await?;
        }
        if self.settings.verify {
            for (address, words) in &writes {
                self.aborted()?;
                self.compare(*address, words).await?;
            }
        }
        Ok(VerifiedBank {
            block,
            words: writes.iter().map(|(_, w)| w.len()).sum(),
        })
    }

    async fn compare(&mut self, address: u16, wrote: &[u16]) -> Result<(), ContractError> {
        let read = self.plc.read_words(address, wrote.len() as u16).await?;
        for (i, (w, r)) in wrote
            .iter()
            .zip(read.iter().chain(std::iter::repeat(&0)))
            .enumerate()
        {
            if w != r {
                return Err(ContractError::CompareFailed {
                    address: address + i as u16,
                    wrote: *w,
                    read: *r,
                });
            }
        }
        Ok(())
    }

    /// Starts a verified bank: checks the PLC is still alive (heartbeat moving, no fault, ready),
    /// then writes `command = 1` as a single word. Accepted while idle, done or stopped; while
    /// running, the PLC program holds it and starts it when the move ends.
    pub async fn start(&mut self, bank: VerifiedBank) -> Result<CommandBlock, ContractError> {
        self.check_alive().await?;
        self.command(Command::Start).await?;
        Ok(bank.block)
    }

    /// Stops every channel (and any waiting start).
    pub async fn stop(&mut self) -> Result<(), ContractError> {
        self.command(Command::Stop).await
    }

    /// Clears a latched fault.
    pub async fn clear_fault(&mut self) -> Result<(), ContractError> {
        self.command(Command::ClearFault).await
    }

    async fn command(&mut self, command: Command) -> Result<(), ContractError> {
        self.plc
            .write_words(self.settings.layout.command_base, &[command.word()])
            .await?;
        Ok(())
    }

    /// Polls the status block until start `seq` has been accepted and is done, calling
    /// `progress` with every status read; a stop or fault ends it with an error.
    pub async fn follow(
        &mut self,
        seq: u16,
        mut progress: impl FnMut(&Status),
    ) -> Result<Status, ContractError> {
        loop {
            let status = self.status().await?;
            progress(&status);
            if status.block.seq == seq {
                match status.state {
                    State::Done => return Ok(status),
                    State::Stopped | State::Fault => {
                        return Err(ContractError::Ended {
                            seq,
                            state: status.state.name(),
                            fault: status.block.fault,
                        });
                    }
                    State::Idle | State::Running => {}
                }
            } else if status.state == State::Fault {
                return Err(ContractError::Ended {
                    seq,
                    state: status.state.name(),
                    fault: status.block.fault,
                });
            }
            if let Some((value, at)) = self.heartbeat
                && at.elapsed() >= self.settings.heartbeat_timeout
            {
                return Err(self.stale(value, at.elapsed()).await);
            }
            tokio::time::sleep(self.settings.poll_interval).await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{
        ChannelLimits, ChannelTable, ControlCode, Direction, Duty, FrequencyRange, OutputMethod,
        Row, Segment, validate,
    };

    /// DT memory whose status block a test sets; every read of the status block ticks the
    /// heartbeat unless frozen; a write log; an optional corruption of one address on read.
    #[derive(Debug, Default)]
    struct FakePlc {
        dt: std::collections::HashMap<u16, u16>,
        frozen: bool,
        prog: bool,
        corrupt: Option<u16>,
        writes: Vec<(u16, usize)>,
    }

    impl FakePlc {
        fn running() -> Self {
            let mut f = Self::default();
            let status = StatusBlock {
                magic: MAGIC,
                version: VERSION,
                ready: 0b111,
                ..StatusBlock::default()
            };
            f.put(1_000, &status.to_words());
            f
        }
        fn put(&mut self, at: u16, words: &[u16]) {
            for (i, w) in words.iter().enumerate() {
                self.dt.insert(at + i as u16, *w);
            }
        }
    }

    impl Plc for FakePlc {
        async fn read_words(&mut self, start: u16, count: u16) -> Result<Vec<u16>, PlcError> {
            if start == 1_000 && !self.frozen {
                let hb = self.dt.get(&1_002).copied().unwrap_or(0);
                self.dt.insert(1_002, hb.wrapping_add(1));
            }
            Ok((start..start + count)
                .map(|a| {
                    let w = self.dt.get(&a).copied().unwrap_or(0);
                    if self.corrupt == Some(a) { w ^ 1 } else { w }
                })
                .collect())
        }
        async fn write_words(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
            self.writes.push((start, words.len()));
            self.put(start, words);
            Ok(())
        }
        async fn read_relay(&mut self, _relay: u16) -> Result<bool, PlcError> {
            Ok(false)
        }
        async fn write_relay(&mut self, _relay: u16, _on: bool) -> Result<(), PlcError> {
            Ok(())
        }
        async fn mode(&mut self) -> Result<PlcMode, PlcError> {
            Ok(if self.prog {
                PlcMode::Prog
            } else {
                PlcMode::Run
            })
        }
    }

    fn table(channel: u8) -> ValidTable {
        let control = ControlCode {
            output: OutputMethod::PulseSign,
            direction: Direction::Up,
            absolute: true,
            range: FrequencyRange::High,
            duty: Duty::Half,
        };
        let t = ChannelTable {
            channel,
            start: 0,
            segments: vec![Segment {
                control,
                rows: vec![Row {
                    freq_hz: 1_000,
                    target: 500,
                }],
            }],
        };
        validate(
            t,
            ChannelLimits {
                max_freq_hz: 20_000,
                area_words: 2_000,
            },
        )
        .unwrap()
    }

    #[tokio::test(start_paused = true)]
    async fn upload_writes_tables_and_command_block_but_not_the_command_word() {
        let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
        let bank = c.upload(1, 7, &[table(0), table(2)]).await.unwrap();
        assert_eq!(bank.block.mask, 0b101);
        assert_eq!(bank.block.segments, [1, 0, 1, 0]);
        let plc = c.plc();
        assert_eq!(plc.writes[0], (10_000, 16));
        assert_eq!(plc.writes[1], (14_000, 16));
        assert_eq!(plc.writes[2], (1_033, 7));
        assert!(
            !plc.writes.iter().any(|(a, _)| *a == 1_032),
            "command word written by upload"
        );
        assert_eq!(plc.dt[&1_033], 7);
        assert_eq!(plc.dt[&1_035], 1);
    }

    #[tokio::test(start_paused = true)]
    async fn failed_read_back_yields_no_bank_and_no_start() {
        let mut plc = FakePlc::running();
        plc.corrupt = Some(2_010);
        let mut c = Contract::new(plc, ContractSettings::default());
        let err = c.upload(0, 1, &[table(0)]).await.unwrap_err();
        assert!(
            matches!(err, ContractError::CompareFailed { address: 2_010, .. }),
            "{err}"
        );
        assert!(!c.plc().writes.iter().any(|(a, _)| *a == 1_032));
    }

    #[tokio::test(start_paused = true)]
    async fn start_writes_exactly_one_command_word() {
        let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
        let bank = c.upload(0, 1, &[table(1)]).await.unwrap();
        c.start(bank).await.unwrap();
        assert_eq!(c.plc().writes.last(), Some(&(1_032, 1)));
        assert_eq!(c.plc().dt[&1_032], 1);
    }

    #[tokio::test(start_paused = true)]
    async fn wrong_magic_is_refused_naming_the_value() {
        let mut plc = FakePlc::running();
        plc.dt.insert(1_000, 0x1234);
        let err = Contract::new(plc, ContractSettings::default())
            .check_alive()
            .await
            .unwrap_err();
        assert_eq!(
            err.to_string(),
            "status block magic is 0x1234, expected 0x4c49: the linterpd PLC program is not running at DT1000"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn frozen_heartbeat_in_prog_mode_is_refused_after_the_timeout() {
        let mut plc = FakePlc::running();
        plc.frozen = true;
        plc.prog = true;
        let err = Contract::new(plc, ContractSettings::default())
            .check_alive()
            .await
            .unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("limit 500 ms") && msg.ends_with("stalled, and in PROG mode"),
            "{msg}"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn latched_fault_and_missing_ready_bits_are_refused() {
        let mut plc = FakePlc::running();
        plc.dt.insert(1_003, State::Fault.word());
        plc.dt.insert(1_005, Fault::ChannelBusy.word());
        let err = Contract::new(plc, ContractSettings::default())
            .check_alive()
            .await
            .unwrap_err();
        assert!(
            err.to_string().contains("fault 2 (channel busy at start)"),
            "{err}"
        );
        let mut plc = FakePlc::running();
        plc.dt.insert(1_007, 0b011);
        let err = Contract::new(plc, ContractSettings::default())
            .check_alive()
            .await
            .unwrap_err();
        assert!(
            matches!(err, ContractError::NotReady { ready: 0b011, .. }),
            "{err}"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn follow_returns_when_the_start_is_done_and_fails_on_stop() {
        let mut plc = FakePlc::running();
        plc.dt.insert(1_003, State::Done.word());
        plc.dt.insert(1_004, 5);
        let mut c = Contract::new(plc, ContractSettings::default());
        let mut seen = 0;
        let status = c.follow(5, |_| seen += 1).await.unwrap();
        assert_eq!((status.state, seen), (State::Done, 1));
        c.plc().dt.insert(1_003, State::Stopped.word());
        let err = c.follow(5, |_| {}).await.unwrap_err();
        assert_eq!(err.to_string(), "start 5 ended stopped");
    }
}
