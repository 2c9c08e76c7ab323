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
    #[error("status block magic is {found:#06x}, expected {MAGIC:#06x}: the linterpd PLC program is not running at DT{base}")]
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
    #[error("the PLC heartbeat stayed at {value} for {waited_ms} ms (limit {timeout_ms} ms): the PLC is stalled{mode}")]
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
    #[error("the PLC is not ready: ready bits {ready:#05b}, need {required:#05b} (bit 0 homed, 1 drives ready, 2 e-stop clear)")]
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
    #[error("read-back of DT{address} gave {read:#06x}, wrote {wrote:#06x}: the bank is not verified and will not be started")]
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
}

impl<P: Plc> Contract<P> {
    /// The flow over `plc`.
    pub fn new(plc: P, settings: ContractSettings) -> Self {
        Self { plc, settings, heartbeat: None }
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
        let words = self.plc.read_words(self.settings.layout.status_base, STATUS_WORDS as u16).await?;
        let block = StatusBlock::from_words(&words).ok_or_else(|| PlcError::BadReply {
            operation: "read status block".into(),
            detail: format!("{} words, expected {STATUS_WORDS}", words.len()),
        })?;
        if block.magic != MAGIC {
            return Err(ContractError::BadMagic { found: block.magic, base: self.settings.layout.status_base });
        }
        if block.version != VERSION {
            return Err(ContractError::WrongVersion { found: block.version });
        }
        self.note_heartbeat(block.heartbeat);
        Ok(Status { block, state: State::from_word(block.state)?, fault: Fault::from_word(block.fault)? })
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
            tokio::time::sleep(self.settings.poll_interval.min(self.settings.heartbeat_timeout - waited)).await;
            status = self.status().await?;
        }
        if status.state == State::Fault {
            return Err(ContractError::Faulted { code: status.block.fault, meaning: status.fault.meaning() });
        }
        let required = self.settings.required_ready;
        if status.block.ready & required != required {
            return Err(ContractError::NotReady { ready: status.block.ready, required });
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
    pub async fn upload(&mut self, bank: u16, seq: u16, tables: &[ValidTable]) -> Result<VerifiedBank, ContractError> {
        if bank >= crate::contract::BANKS {
            return Err(ContractError::BadBank { bank });
        }
        let mut block = CommandBlock { command: Command::None.word(), seq, mask: 0, bank, segments: [0; CHANNELS] };
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
                return Err(ContractError::TooLarge { channel, words: words.len(), area_words });
            }
            block.mask |= 1 << c;
            block.segments[c] = t.table().segments.len() as u16;
            writes.push((self.settings.layout.area(bank, c), words));
        }
        // Everything but the command word (offset 0), which only `start` writes.
        writes.push((self.settings.layout.command_base + 1, block.to_words()[1..COMMAND_WORDS].to_vec()));
        for (address, words) in &writes {
            self.plc.write_words(*address, words).await?;
        }
        if self.settings.verify {
            for (address, words) in &writes {
                self.compare(*address, words).await?;
            }
        }
        Ok(VerifiedBank { block, words: writes.iter().map(|(_, w)| w.len()).sum() })
    }

    async fn compare(&mut self, address: u16, wrote: &[u16]) -> Result<(), ContractError> {
        let read = self.plc.read_words(address, wrote.len() as u16).await?;
        for (i, (w, r)) in wrote.iter().zip(read.iter().chain(std::iter::repeat(&0))).enumerate() {
            if w != r {
                return Err(ContractError::CompareFailed { address: address + i as u16, wrote: *w, read: *r });
            }
        }
        Ok(())
    }

    /// Starts a verified bank: writes `command = 1` as a single word. Accepted while idle, done
    /// or stopped; while running, the PLC program holds it and starts it when the move ends.
    pub async fn start(&mut self, bank: VerifiedBank) -> Result<CommandBlock, ContractError> {
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
        self.plc.write_words(self.settings.layout.command_base, &[command.word()]).await?;
        Ok(())
    }

    /// Polls the status block until start `seq` has been accepted and is done, calling
    /// `progress` with every status read; a stop or fault ends it with an error.
    pub async fn follow(&mut self, seq: u16, mut progress: impl FnMut(&Status)) -> Result<Status, ContractError> {
        loop {
            let status = self.status().await?;
            progress(&status);
            if status.block.seq == seq {
                match status.state {
                    State::Done => return Ok(status),
                    State::Stopped | State::Fault => {
                        return Err(ContractError::Ended { seq, state: status.state.name(), fault: status.block.fault });
                    }
                    State::Idle | State::Running => {}
                }
            } else if status.state == State::Fault {
                return Err(ContractError::Ended { seq, state: status.state.name(), fault: status.block.fault });
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
