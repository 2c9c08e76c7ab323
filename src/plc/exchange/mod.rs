//! The register contract's exchanges on top of any [`Plc`] (docs/CONTRACT.md, "What the host does
//! for one move"): read the status block, write a bank and the command block and read them back,
//! write the command word (a start once, never blindly again), stop, clear a fault, home, the
//! host word; read a bank back to describe a start found running. What the status blocks mean is
//! the pure [`Machine`]'s business, and driving a start with it is the daemon's worker's: the
//! one sequence of exchanges shared with it here is [`Contract::proof_read`], the reads after an
//! upload that must see the heartbeat move before the start is written.
//!
//! A start can only be given a [`VerifiedBank`], which only [`Contract::upload`] makes, after
//! every word of the bank and the command block is written and (unless switched off) read back
//! equal: no start can point at a partly written or unverified bank. Every start carries the
//! counts it was planned from (`from`), and the PLC refuses it (fault 5) from any others.

mod describe;
// The tests' driver, shared by the unit tests and tests/common/: not product code, so not in the
// docs. Its functions are generic over the PLC, so no binary holds code of it unless it calls
// it. (It was behind a `testing` feature turned on by the crate's own dev-dependency; that made
// cargo build the library before its unit tests instead of beside them: 80 s of a cold
// `cargo test` on 2 cores.)
#[doc(hidden)]
pub mod driver;

/// The command block `start` begins, no channel placed yet: its bank and permit checked.
fn block_of(start: &StartBlock) -> Result<CommandBlock, ContractError> {
    let bank = start.bank;
    if bank >= crate::contract::BANKS {
        return Err(ContractError::BadBank { bank });
    }
    if !start.permit.is_well_formed() {
        return Err(ContractError::BadPermit {
            permit: start.permit,
        });
    }
    Ok(CommandBlock {
        command: Command::None.word(),
        seq: start.seq,
        bank,
        from: start.from,
        permit: start.permit,
        ..CommandBlock::default()
    })
}

#[cfg(test)]
mod tests;
mod upload;

pub use describe::planned_bounds;
pub use upload::Upload;

/// What a start's command block says besides its tables: its bank, sequence number, the counts
/// its tables were planned from, and its permit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StartBlock {
    /// Table bank (0 or 1).
    pub bank: u16,
    /// Sequence number.
    pub seq: u16,
    /// The counts the tables were planned from.
    pub from: [i32; CHANNELS],
    /// The permit over the cell's inputs.
    pub permit: Permit,
}

impl StartBlock {
    /// A start with no permit.
    #[must_use]
    pub fn unpermitted(bank: u16, seq: u16, from: [i32; CHANNELS]) -> Self {
        Self {
            bank,
            seq,
            from,
            permit: Permit::NONE,
        }
    }
}

impl From<&crate::contract::machine::Planned> for StartBlock {
    fn from(p: &crate::contract::machine::Planned) -> Self {
        Self {
            bank: p.bank,
            seq: p.seq,
            from: p.from,
            permit: p.permit,
        }
    }
}

/// Words of a start's permit (+17..+24), written after its block's first words.
pub const PERMIT_WRITE_WORDS: usize =
    crate::contract::COMMAND_WORDS - COMMAND_PERMIT_OFFSET as usize;

/// Words of a start's command block written before its start (+1..+15: all before `host`).
pub const BLOCK_WRITE_WORDS: usize = COMMAND_HOST_OFFSET as usize - 1;

use crate::contract::Permit;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use thiserror::Error;

use super::{Plc, PlcError};
use crate::contract::machine::{Blocker, Machine, Outcome, Status, WatchSettings};
use crate::contract::{
    CHANNELS, COMMAND_HOST_OFFSET, COMMAND_PERMIT_OFFSET, COMMAND_WORDS, Command, CommandBlock,
    Fault, Layout, MAGIC, STATUS_HEARTBEAT_OFFSET, STATUS_WORDS, State, StatusBlock, UnknownValue,
    VERSION,
};
use crate::table::{DIRECTORY_WORDS, ValidTable, encode_at};

/// How the exchanges behave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContractSettings {
    /// Where the blocks and areas are.
    pub layout: Layout,
    /// Read back every written word and compare (on by default).
    pub verify: bool,
    /// How closely starts are watched.
    pub watch: WatchSettings,
    /// Time between status polls while a start runs.
    pub poll_interval: Duration,
    /// The PLC's longest scan (reads meant to see the heartbeat move are this far apart).
    pub scan_time: Duration,
}

impl Default for ContractSettings {
    fn default() -> Self {
        Self {
            layout: Layout::default(),
            verify: true,
            watch: WatchSettings::default(),
            poll_interval: Duration::from_millis(20),
            scan_time: Duration::from_millis(10),
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
    /// A word the contract does not define.
    #[error("status block: {0}")]
    Unknown(#[from] UnknownValue),
    /// The PLC cannot take a start now.
    #[error("{0}")]
    Blocked(Blocker),
    /// A permit whose value words set bits its mask does not look at.
    #[error(
        "permit value {:04X?} sets bits outside its mask {:04X?}: no start is written with it",
        permit.value, permit.mask
    )]
    BadPermit {
        /// The permit.
        permit: Permit,
    },
    /// The heartbeat stood still while the host waited for the PLC.
    #[error(
        "the PLC heartbeat stood still for {still_ms} ms (limit {limit_ms} ms): the PLC is stalled{mode}"
    )]
    Stalled {
        /// For how long.
        still_ms: u64,
        /// The limit.
        limit_ms: u64,
        /// ", and in PROG mode" when the PLC says so.
        mode: &'static str,
    },
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
    /// A part of a path that begins at speed could not be made ready while the part before it
    /// runs: that part would end at speed with nothing to chain, stopping the robot abruptly.
    #[error(
        "part {part} of {parts} of the path needs about {need_s:.2} s to be written, read back and started over this link (at the pace it showed just now), but the part before it runs only {runs_s:.2} s: the robot would stop at speed where that part ends, so the path is not started; use a faster link (higher baud, `<` frames, Modbus RTU), a lower speed, or a stop at a waypoint"
    )]
    ChainOutrunsLink {
        /// The part, from 1.
        part: usize,
        /// The section's parts.
        parts: usize,
        /// Its estimated time to be ready, s.
        need_s: f64,
        /// How long the part before it runs, s.
        runs_s: f64,
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
    /// The counts are not those the tables were planned from: the start is not written.
    #[error(
        "channel {channel} is at {count}, the tables were planned from {from}: the start is not written"
    )]
    NotAtFrom {
        /// Pulse channel.
        channel: usize,
        /// Its count.
        count: i32,
        /// The plan's `from`.
        from: i32,
    },
    /// A bank read back does not decode.
    #[error("bank {bank} channel {channel} does not decode: {detail}")]
    BadTable {
        /// Bank.
        bank: u16,
        /// Channel.
        channel: usize,
        /// Why.
        detail: String,
    },
    /// The upload was abandoned between two exchanges (a stop overtook it); nothing was started.
    #[error("upload abandoned before it was complete; nothing was started")]
    Aborted,
    /// A start ended without getting done.
    #[error("start {seq} {}", describe_outcome(outcome))]
    Ended {
        /// Sequence number.
        seq: u16,
        /// How it ended.
        outcome: Outcome,
    },
}

impl std::fmt::Display for Blocker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::LinkDown => write!(f, "the PLC link is down"),
            Self::Stalled => write!(
                f,
                "the PLC heartbeat stands still: the PLC is stalled or in PROG mode"
            ),
            Self::NotHomed => write!(
                f,
                "the robot is not homed (the PLC's homed bit is clear): run `linterpd home`"
            ),
            Self::Homing => write!(f, "the robot is homing"),
            Self::Faulted { fault } => write!(
                f,
                "the PLC program reports fault {fault} ({}); clear it first",
                fault_meaning(fault)
            ),
            Self::NotReady { ready, required } => write!(
                f,
                "the PLC is not ready: ready bits {ready:#05b}, need {required:#05b} (bit 0 homed, 1 drives ready, 2 e-stop clear)"
            ),
            Self::HostUnconfirmed => write!(f, "the PLC has not yet echoed this host's word"),
            Self::Stopping => write!(f, "a stop is being carried out"),
            Self::Full => write!(f, "a move runs and another waits behind it"),
            Self::Unproven => write!(
                f,
                "the PLC heartbeat has not been seen moving since the upload"
            ),
            Self::PermitNotMet { permit, inputs } => write!(
                f,
                "the start's permit does not hold on the PLC's inputs {inputs:04X?} (it needs \
                 the bits {:04X?} to be {:04X?}): the start is not written",
                permit.mask, permit.value
            ),
            Self::NotAtFrom {
                channel,
                count,
                from,
            } => write!(
                f,
                "channel {channel} is at {count}, not at {from} where the tables were planned from"
            ),
        }
    }
}

/// The meaning of a fault word.
#[must_use]
pub fn fault_meaning(fault: u16) -> &'static str {
    Fault::from_word(fault).map_or("a fault this contract does not define", Fault::meaning)
}

/// Lower-case words for how a start ended, after "start N".
#[must_use]
pub fn describe_outcome(outcome: &Outcome) -> String {
    match *outcome {
        Outcome::Stopped { fault: 0 } => "was stopped".to_owned(),
        Outcome::Stopped { fault } => {
            format!("was stopped: fault {fault} ({})", fault_meaning(fault))
        }
        Outcome::Faulted { fault } => {
            format!("ended in fault {fault} ({})", fault_meaning(fault))
        }
        Outcome::Refused { fault } => format!(
            "was refused by the PLC with fault {fault} ({}); nothing moved",
            fault_meaning(fault)
        ),
        Outcome::Dropped => {
            "was dropped by the PLC: the move before it did not end done; nothing moved".to_owned()
        }
        Outcome::NotTaken { scans } => {
            format!("was not taken by the PLC within {scans} scans; a stop was written")
        }
        Outcome::Stalled { still } => format!(
            "was given up: the PLC heartbeat stood still for {} ms; a stop was written",
            still.as_millis()
        ),
        Outcome::Restarted => {
            "was given up: the PLC restarted (its host word or sequence number changed)".to_owned()
        }
        Outcome::OutsideEnvelope {
            channel,
            count,
            min,
            max,
        } => format!(
            "ran away: channel {channel} reached {count}, outside its planned {min}..={max}; a stop was written"
        ),
        Outcome::Overrun { ran, limit } => format!(
            "ran {:.1} s, past its limit of {:.1} s; a stop was written",
            ran.as_secs_f64(),
            limit.as_secs_f64()
        ),
        Outcome::LinkLost { down } => format!(
            "is unknown: the PLC link was down for {:.1} s, past its planned end",
            down.as_secs_f64()
        ),
        Outcome::WentIdle => "was lost: the PLC went idle without ending it".to_owned(),
    }
}

/// One write of words at a DT address.
type Write = (u16, Vec<u16>);

/// A bank whose every word was written and verified, ready for one start.
#[derive(Debug, Clone, PartialEq, Eq)]
#[must_use = "an uploaded bank does nothing until it is started"]
pub struct VerifiedBank {
    /// The command block as written (command word still 0).
    pub block: CommandBlock,
    /// Words written (tables and command block).
    pub words: usize,
    /// Whether its tables were proven to be the ones preloaded ([`Contract::upload_preloaded`]),
    /// so that only directories and the command block were written now. A bank written whole
    /// may have overwritten tables preloaded past its own.
    pub on_preload: bool,
}

/// Tables written into a bank and read back ahead of their start ([`Contract::preload`]): where
/// they were placed and the words as written, so that the start can prove it plays exactly them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Preload {
    bank: u16,
    base: [usize; CHANNELS],
    writes: Vec<Write>,
}

impl Preload {
    /// The bank they are in.
    #[must_use]
    pub fn bank(&self) -> u16 {
        self.bank
    }

    /// Words written.
    #[must_use]
    pub fn words(&self) -> usize {
        self.writes.iter().map(|(_, w)| w.len()).sum()
    }

    /// A preload of nothing into `bank`, for the dispatcher's tests (no link writes one).
    #[cfg(test)]
    pub(crate) fn empty(bank: u16) -> Self {
        Self {
            bank,
            base: [crate::table::DIRECTORY_WORDS; CHANNELS],
            writes: Vec::new(),
        }
    }
}

/// What became of a command word written once.
#[derive(Debug)]
pub enum CommandWrite {
    /// The PLC acknowledged the write.
    Confirmed,
    /// No acknowledgement: the reply was lost or garbled, the link failed, or the PLC answered
    /// with an error. Whether it acted on the command is learnt from the status block, never
    /// assumed (a reply can be an error for a command that was carried out).
    Unconfirmed(PlcError),
}

/// When an owner of a link last saw it make progress (an exchange done, a loop gone round): what
/// a watchdog reads.
/// On tokio's clock (paused in tests).
#[derive(Debug)]
pub struct Beat {
    epoch: tokio::time::Instant,
    ms: std::sync::atomic::AtomicU64,
}

impl Default for Beat {
    fn default() -> Self {
        Self {
            epoch: tokio::time::Instant::now(),
            ms: std::sync::atomic::AtomicU64::new(0),
        }
    }
}

impl Beat {
    /// Progress, now.
    pub fn mark(&self) {
        let ms = self.epoch.elapsed().as_millis() as u64;
        self.ms.store(ms.max(1), Ordering::Relaxed);
    }

    /// How long ago the last progress was (`None` before any).
    #[must_use]
    pub fn since(&self) -> Option<Duration> {
        let ms = self.ms.load(Ordering::Relaxed);
        let now = self.epoch.elapsed().as_millis() as u64;
        (ms > 0).then(|| Duration::from_millis(now.saturating_sub(ms)))
    }
}

/// The contract's exchanges over one PLC link.
#[derive(Debug)]
pub struct Contract<P> {
    plc: P,
    settings: ContractSettings,
    abort: Option<Arc<AtomicBool>>,
    beat: Option<Arc<Beat>>,
    /// Whether this connection wrote the PLC's permit words all 0 and saw the write through
    /// (read back, or acknowledged with read-back off): a start with no permit then leaves them
    /// alone. Only a start with no permit is ever spared the write: whatever the PLC's words
    /// hold, a start with a permit writes its own.
    no_permit_in_plc: bool,
}

impl<P: Plc> Contract<P> {
    /// The exchanges over `plc`.
    pub fn new(plc: P, settings: ContractSettings) -> Self {
        Self {
            plc,
            settings,
            abort: None,
            beat: None,
            no_permit_in_plc: false,
        }
    }

    /// A flag that, once set, makes [`Self::upload`] give up between two exchanges.
    pub fn set_abort(&mut self, flag: Arc<AtomicBool>) {
        self.abort = Some(flag);
    }

    /// A beat marked between the exchanges of a long upload.
    pub fn set_beat(&mut self, beat: Arc<Beat>) {
        self.beat = Some(beat);
    }

    /// Between two exchanges of an upload: progress is marked, and a stop asked for ends it.
    fn aborted(&self) -> Result<(), ContractError> {
        if let Some(beat) = &self.beat {
            beat.mark();
        }
        match &self.abort {
            Some(flag) if flag.load(Ordering::SeqCst) => Err(ContractError::Aborted),
            _ => Ok(()),
        }
    }

    /// How long the shortest exchange takes on this link just now: the command word read once
    /// (reading it changes nothing). With a status read, it paces a chain of starts at speed.
    pub async fn one_word_exchange(&mut self) -> Result<Duration, ContractError> {
        let asked = tokio::time::Instant::now();
        self.plc
            .read_words(self.settings.layout.command_base, 1)
            .await?;
        Ok(asked.elapsed())
    }

    /// The status block's heartbeat word, read alone (nothing else of the block is checked:
    /// a status read after it does that).
    async fn heartbeat(&mut self) -> Result<u16, ContractError> {
        let at = self.settings.layout.status_base + STATUS_HEARTBEAT_OFFSET;
        let words = self.plc.read_words(at, 1).await?;
        words.first().copied().ok_or_else(|| {
            ContractError::Plc(PlcError::BadReply {
                operation: "read the heartbeat word".into(),
                detail: "no word".into(),
            })
        })
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

    /// Reads and decodes the status block; refuses a wrong magic or version.
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
        Ok(Status {
            block,
            state: State::from_word(block.state)?,
            fault: Fault::from_word(block.fault)?,
        })
    }

    /// The command block as it stands in the PLC.
    pub async fn command_block(&mut self) -> Result<CommandBlock, ContractError> {
        let words = self
            .plc
            .read_words(self.settings.layout.command_base, COMMAND_WORDS as u16)
            .await?;
        CommandBlock::from_words(&words).ok_or_else(|| {
            ContractError::Plc(PlcError::BadReply {
                operation: "read command block".into(),
                detail: format!("{} words, expected {COMMAND_WORDS}", words.len()),
            })
        })
    }

    /// Writes every table into `bank`, then the command block except its command and host words
    /// (`from` = the counts the tables were planned from, no permit), then reads all of it back
    /// and compares. Only a complete, verified upload yields the bank.
    pub async fn upload(
        &mut self,
        bank: u16,
        seq: u16,
        from: [i32; CHANNELS],
        tables: &[ValidTable],
    ) -> Result<VerifiedBank, ContractError> {
        let start = StartBlock::unpermitted(bank, seq, from);
        let mut upload = self.begin_upload(&start, tables)?;
        self.finish_upload(&mut upload).await
    }

    /// [`Self::upload`] for `start` (its permit too), cut into exchanges, none made yet:
    /// [`Self::upload_step`] makes them.
    pub fn begin_upload(
        &self,
        start: &StartBlock,
        tables: &[ValidTable],
    ) -> Result<Upload, ContractError> {
        let (block, mut writes, _) = self.placed(start, tables, [DIRECTORY_WORDS; CHANNELS])?;
        writes.extend(self.block_writes(&block));
        Ok(Upload::new(block, writes, false, self.settings.verify))
    }

    /// Makes the next exchange of `upload` (a write, or a read-back compared): the bank once
    /// the last is done, `None` before. A stop asked for ends it between two exchanges.
    pub async fn upload_step(
        &mut self,
        upload: &mut Upload,
    ) -> Result<Option<VerifiedBank>, ContractError> {
        self.aborted()?;
        match upload.next(self.plc.exchange_sizes()) {
            Some(upload::Exchange::Write { address, words }) => {
                if address == self.permit_address() {
                    // Unknown until the write is seen through.
                    self.no_permit_in_plc = false;
                }
                self.plc.write_words(address, &words).await?;
            }
            Some(upload::Exchange::ReadBack { address, words }) => {
                self.compare(address, &words).await?;
            }
            None => {}
        }
        let bank = upload.bank();
        if let Some(bank) = &bank
            && upload.writes_at(self.permit_address())
        {
            self.no_permit_in_plc = bank.block.permit.is_none();
        }
        Ok(bank)
    }

    /// Makes every exchange of `upload` left.
    async fn exchanges(&mut self, upload: &mut Upload) -> Result<(), ContractError> {
        while !upload.is_done() {
            self.upload_step(upload).await?;
        }
        Ok(())
    }

    async fn finish_upload(&mut self, upload: &mut Upload) -> Result<VerifiedBank, ContractError> {
        self.exchanges(upload).await?;
        Ok(upload.bank().expect("every exchange made"))
    }

    /// Writes every table into `bank` and reads them back, without the command block: a part
    /// of a path that will start at speed later, uploaded while nothing runs from `bank` (see
    /// [`Self::upload_preloaded`]). Channel `c`'s segments are placed from word `base[c]` of
    /// its area: the directory's end ([`DIRECTORY_WORDS`]), where the directory is written
    /// with them, or past tables kept before them in the same area (a part that starts after
    /// another from the same bank), where the directory is left for the start to write, when
    /// the tables before are done.
    pub async fn preload(
        &mut self,
        bank: u16,
        base: [usize; CHANNELS],
        tables: &[ValidTable],
    ) -> Result<Preload, ContractError> {
        let (mut upload, preload) = self.begin_preload(bank, base, tables)?;
        self.exchanges(&mut upload).await?;
        Ok(preload)
    }

    /// [`Self::preload`] cut into exchanges, none made yet ([`Self::upload_step`] makes them,
    /// so that a running move is watched between two of them): the upload, and what is
    /// preloaded once its last exchange is made (not before).
    pub fn begin_preload(
        &self,
        bank: u16,
        base: [usize; CHANNELS],
        tables: &[ValidTable],
    ) -> Result<(Upload, Preload), ContractError> {
        let unstarted = StartBlock::unpermitted(bank, 0, [0; CHANNELS]);
        let (block, writes, _) = self.placed(&unstarted, tables, base)?;
        // The tables alone: no command block is written (the start's upload writes it).
        let upload = Upload::new(block, writes.clone(), false, self.settings.verify);
        Ok((upload, Preload { bank, base, writes }))
    }

    /// Whether `preload` is `tables` placed in `bank` from `base`, word for word: a part
    /// preloaded earlier that a later walk over the same banks would place there again.
    #[must_use]
    pub fn preloaded_as(
        &self,
        preload: &Preload,
        bank: u16,
        base: [usize; CHANNELS],
        tables: &[ValidTable],
    ) -> bool {
        let unstarted = StartBlock::unpermitted(bank, 0, [0; CHANNELS]);
        preload.bank == bank
            && preload.base == base
            && self
                .placed(&unstarted, tables, base)
                .is_ok_and(|(_, writes, _)| writes == preload.writes)
    }

    /// [`Self::upload`] for tables already written into `bank` and read back by
    /// [`Self::preload`]: only the directories left for the start and the command block are
    /// written and compared, when `tables`, placed as preloaded, are word for word those
    /// preloaded there; otherwise (another bank, other tables) everything is written and
    /// compared as by [`Self::upload`]. A start never rests on a preload that is not proven to
    /// be its own.
    pub async fn upload_preloaded(
        &mut self,
        bank: u16,
        seq: u16,
        from: [i32; CHANNELS],
        tables: &[ValidTable],
        preload: &Preload,
    ) -> Result<VerifiedBank, ContractError> {
        let start = StartBlock::unpermitted(bank, seq, from);
        let mut upload = self.begin_upload_preloaded(&start, tables, preload)?;
        self.finish_upload(&mut upload).await
    }

    /// [`Self::upload_preloaded`] for `start` (its permit too), cut into exchanges, none made
    /// yet.
    pub fn begin_upload_preloaded(
        &self,
        start: &StartBlock,
        tables: &[ValidTable],
        preload: &Preload,
    ) -> Result<Upload, ContractError> {
        let bank = start.bank;
        let (block, tables_writes, mut writes) = self.placed(start, tables, preload.base)?;
        if preload.bank != bank || preload.writes != tables_writes {
            tracing::warn!(
                bank,
                preloaded_bank = preload.bank,
                "tables differ from those preloaded: writing them whole"
            );
            return self.begin_upload(start, tables);
        }
        writes.extend(self.block_writes(&block));
        Ok(Upload::new(block, writes, true, self.settings.verify))
    }

    /// The command block for `tables` in `bank`, each channel's segments placed from word
    /// `base[c]` of its area: the writes of the tables, and of the directories not among them
    /// (those of the channels placed past the directory's end).
    fn placed(
        &self,
        start: &StartBlock,
        tables: &[ValidTable],
        base: [usize; CHANNELS],
    ) -> Result<(CommandBlock, Vec<Write>, Vec<Write>), ContractError> {
        let mut block = block_of(start)?;
        let bank = block.bank;
        let mut writes: Vec<Write> = Vec::with_capacity(tables.len() + 1);
        let mut directories: Vec<Write> = Vec::new();
        for t in tables {
            let channel = t.table().channel;
            let c = usize::from(channel);
            if c >= CHANNELS || block.mask & (1 << c) != 0 {
                return Err(ContractError::BadChannel { channel });
            }
            let at = base[c].max(DIRECTORY_WORDS);
            let (directory, words) = encode_at(t, at);
            let area_words = self.settings.layout.area_words;
            let end = at + words.len();
            if end > usize::from(area_words) {
                return Err(ContractError::TooLarge {
                    channel,
                    words: end,
                    area_words,
                });
            }
            block.mask |= 1 << c;
            block.segments[c] = t.table().segments.len() as u16;
            let area = self.settings.layout.area(bank, c);
            if at == DIRECTORY_WORDS {
                writes.push((area, [&directory[..], &words[..]].concat()));
            } else {
                writes.push((area + at as u16, words));
                directories.push((area, directory.to_vec()));
            }
        }
        Ok((block, writes, directories))
    }

    /// The writes of a command block's words but the command and host words: +1..+15 (seq,
    /// mask, bank, segments, from), then the permit +17..+24. Two writes, so that the `host`
    /// word is only ever written when the PLC's copy differs (CONTRACT.md).
    fn block_writes(&self, block: &CommandBlock) -> Vec<(u16, Vec<u16>)> {
        let words = block.to_words();
        let base = self.settings.layout.command_base;
        let permit = usize::from(COMMAND_PERMIT_OFFSET);
        let mut writes = vec![(base + 1, words[1..=BLOCK_WRITE_WORDS].to_vec())];
        if !(block.permit.is_none() && self.no_permit_in_plc) {
            writes.push((base + COMMAND_PERMIT_OFFSET, words[permit..].to_vec()));
        }
        writes
    }

    /// The address of the command block's permit words.
    fn permit_address(&self) -> u16 {
        self.settings.layout.command_base + COMMAND_PERMIT_OFFSET
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

    /// Writes `command = 1` for a verified bank, once. Anything but an acknowledgement (a lost,
    /// garbled or error reply) comes back as [`CommandWrite::Unconfirmed`]: read the status block
    /// to learn whether the start was taken.
    pub async fn start(&mut self, bank: &VerifiedBank) -> Result<CommandWrite, ContractError> {
        let _ = bank;
        self.command_once(Command::Start).await
    }

    async fn command_once(&mut self, command: Command) -> Result<CommandWrite, ContractError> {
        let address = self.settings.layout.command_base;
        match self.plc.write_words_once(address, &[command.word()]).await {
            Ok(()) => Ok(CommandWrite::Confirmed),
            // Never sent.
            Err(e @ PlcError::InvalidRequest { .. }) => Err(ContractError::Plc(e)),
            Err(e) => Ok(CommandWrite::Unconfirmed(e)),
        }
    }

    /// Writes `command = 4` to home the channels in `mask`, each preset to `from[c]` at its home
    /// position (the block's mask and `from` first, read back, then the command word once).
    pub async fn home(
        &mut self,
        mask: u16,
        from: [i32; CHANNELS],
    ) -> Result<CommandWrite, ContractError> {
        let block = CommandBlock {
            mask,
            from,
            ..self.command_block().await?
        };
        let (address, words) = self.block_writes(&block).swap_remove(0);
        self.plc.write_words(address, &words).await?;
        if self.settings.verify {
            self.compare(address, &words).await?;
        }
        self.command_once(Command::Home).await
    }

    /// Stops every channel and drops any waiting start. Safe to write again.
    pub async fn stop(&mut self) -> Result<(), ContractError> {
        self.command(Command::Stop).await
    }

    /// Clears a latched fault.
    pub async fn clear_fault(&mut self) -> Result<(), ContractError> {
        self.command(Command::ClearFault).await
    }

    /// Withdraws a start that waits (`command = 0`): it never runs. Harmless if the PLC has
    /// already acted on it.
    pub async fn withdraw(&mut self) -> Result<(), ContractError> {
        self.command(Command::None).await
    }

    async fn command(&mut self, command: Command) -> Result<(), ContractError> {
        self.plc
            .write_words(self.settings.layout.command_base, &[command.word()])
            .await?;
        Ok(())
    }

    /// Writes the host's word into the command block.
    pub async fn write_host(&mut self, host: u16) -> Result<(), ContractError> {
        let address = self.settings.layout.command_base + COMMAND_HOST_OFFSET;
        self.plc.write_words(address, &[host]).await?;
        Ok(())
    }

    /// The next read toward the proof a start needs after its upload, the one the daemon makes
    /// and the tests' driver (`driver`) makes: while the machine wants two more reads to see the
    /// heartbeat move ([`Machine::proof_wants_two_reads`]), the first is the heartbeat word
    /// alone, given to the machine here; then the status block, which the caller gives the
    /// machine ([`Machine::on_status`], carrying out what it asks for) before it asks
    /// [`Machine::may_start`].
    pub async fn proof_read(&mut self, machine: &mut Machine) -> Result<Status, ContractError> {
        if machine.proof_wants_two_reads(tokio::time::Instant::now().into_std()) {
            let beat = self.heartbeat().await?;
            machine.heartbeat_read(beat, tokio::time::Instant::now().into_std());
        }
        self.status().await
    }
}
