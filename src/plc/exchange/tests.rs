use super::driver::{until_it_may_start, until_ready};
use super::*;
use crate::contract::machine::{Planned, WatchSettings};
use crate::plc::PlcMode;
use crate::table::{ChannelLimits, Segment, validate};

/// DT memory whose status block a test sets; every read of the status block ticks the
/// heartbeat unless frozen; a write log; an optional corruption of one address on read.
#[derive(Debug, Default)]
struct FakePlc {
    dt: std::collections::HashMap<u16, u16>,
    frozen: bool,
    prog: bool,
    corrupt: Option<u16>,
    /// Writes of one word that land but whose reply is lost (a timeout), by address.
    lose_reply_at: Option<u16>,
    /// Writes the PLC refuses (an error reply), by address.
    refuse_at: Option<u16>,
    writes: Vec<(u16, usize)>,
    /// Every read, as (start, count).
    reads: Vec<(u16, usize)>,
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
        self.reads.push((start, usize::from(count)));
        if start == 1_000 && !self.frozen {
            let hb = self.dt.get(&1_002).copied().unwrap_or(0);
            self.dt.insert(1_002, hb.wrapping_add(1));
            // The program copies the command block's host word every scan.
            let host = self.dt.get(&1_048).copied().unwrap_or(0);
            self.dt.insert(1_020, host);
        }
        Ok((start..start + count)
            .map(|a| {
                let w = self.dt.get(&a).copied().unwrap_or(0);
                if self.corrupt == Some(a) { w ^ 1 } else { w }
            })
            .collect())
    }
    async fn write_words(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        if self.refuse_at == Some(start) {
            return Err(PlcError::Refused {
                operation: format!("write DT{start}"),
                refusal: crate::plc::Refusal::Mewtocol {
                    code: 61,
                    meaning: "data error",
                },
            });
        }
        self.writes.push((start, words.len()));
        self.put(start, words);
        if self.lose_reply_at == Some(start) {
            return Err(PlcError::Timeout {
                operation: format!("write DT{start}"),
                timeout_ms: 300,
            });
        }
        Ok(())
    }
    async fn write_words_once(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        self.write_words(start, words).await
    }
    async fn read_bits(
        &mut self,
        _area: crate::gateway::Area,
        _start: u32,
        count: u16,
    ) -> Result<Vec<bool>, PlcError> {
        Ok(vec![false; usize::from(count)])
    }
    async fn write_bit(
        &mut self,
        _area: crate::gateway::Area,
        _bit: u32,
        _on: bool,
    ) -> Result<(), PlcError> {
        Ok(())
    }
    fn exchange_sizes(&self) -> crate::plc::ExchangeSizes {
        crate::plc::ExchangeSizes {
            read_words: 27,
            write_words: 24,
            read_bits: 432,
        }
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
    crate::table::rising(channel, &[500])
}

const FROM: [i32; CHANNELS] = [0, 0, 0, 0];

#[tokio::test(start_paused = true)]
async fn upload_writes_tables_then_the_command_block_with_from_but_not_command_or_host() {
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    let from = [0, 7, 0, -9];
    let bank = c.upload(1, 7, from, &[table(0), table(2)]).await.unwrap();
    assert_eq!(bank.block.mask, 0b101);
    assert_eq!(bank.block.segments, [1, 0, 1, 0]);
    assert_eq!(bank.block.from, from);
    let plc = c.plc();
    assert_eq!(plc.writes[0], (10_000, 16));
    assert_eq!(plc.writes[1], (14_000, 16));
    assert_eq!(plc.writes[2], (1_033, 15), "seq..from, not the host word");
    assert!(
        !plc.writes.iter().any(|(a, _)| *a == 1_032 || *a == 1_048),
        "command or host word written by upload"
    );
    assert_eq!(plc.dt[&1_033], 7);
    assert_eq!(plc.dt[&1_035], 1);
    assert_eq!((plc.dt[&1_042], plc.dt[&1_043]), (7, 0), "from[1]");
    assert_eq!(
        (plc.dt[&1_046], plc.dt[&1_047]),
        (0xFFF7, 0xFFFF),
        "from[3]"
    );
}

/// `table(channel)` ending on `target` instead.
fn table_to(channel: u8, target: i64) -> ValidTable {
    let mut t = table(channel).table().clone();
    t.segments[0].rows[0].target = target;
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
async fn a_preloaded_bank_is_started_on_its_block_alone_only_when_its_tables_are_the_ones_preloaded()
 {
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    let preload = c
        .preload(1, [DIRECTORY_WORDS; CHANNELS], &[table(0), table(2)])
        .await
        .unwrap();
    assert_eq!(preload.words(), 32);
    // The same tables: the command block alone (the first start of a connection writes its
    // permit words too, all 0 here).
    let before = c.plc().writes.len();
    let bank = c
        .upload_preloaded(1, 7, FROM, &[table(0), table(2)], &preload)
        .await
        .unwrap();
    assert_eq!(c.plc().writes[before..], [(1_033, 15), (1_049, 8)]);
    assert_eq!(bank.block.mask, 0b101);
    // Other tables: written whole, and the area holds them (the target word of row 1).
    let before = c.plc().writes.len();
    let whole = c
        .upload_preloaded(1, 8, FROM, &[table(0), table_to(2, 900)], &preload)
        .await
        .unwrap();
    // The PLC's permit words are known to be 0 now: a start with no permit leaves them.
    assert_eq!(whole.words, 47);
    assert_eq!(
        c.plc().writes[before..],
        [(10_000, 16), (14_000, 16), (1_033, 15)]
    );
    assert_eq!(c.plc().dt[&(14_000 + 8 + 4)], 900);
    // Another bank: written whole into it.
    let before = c.plc().writes.len();
    let other = c
        .upload_preloaded(0, 9, FROM, &[table(0), table(2)], &preload)
        .await
        .unwrap();
    assert_eq!(other.block.bank, 0);
    assert_eq!(
        c.plc().writes[before..],
        [(2_000, 16), (6_000, 16), (1_033, 15)]
    );
}

/// Channel `c`'s area of bank 1, as the PLC holds it, decoded to its first segment.
fn area_of(c: &mut Contract<FakePlc>, channel: u16) -> Vec<Segment> {
    let start = 10_000 + channel * 2_000;
    let words: Vec<u16> = (start..start + 2_000)
        .map(|a| c.plc().dt.get(&a).copied().unwrap_or(0))
        .collect();
    crate::table::decode(&words, 1).unwrap()
}

#[tokio::test(start_paused = true)]
async fn a_table_preloaded_past_another_in_its_bank_is_started_on_its_directories_and_block() {
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    // The first part's tables at the directory's end, a later part's past them (16 words on).
    let first = c
        .preload(1, [DIRECTORY_WORDS; CHANNELS], &[table(0), table(2)])
        .await
        .unwrap();
    let later_tables = [table_to(0, 700), table_to(2, 900)];
    let later = c.preload(1, [16; CHANNELS], &later_tables).await.unwrap();
    assert_eq!(later.words(), 16, "segments alone: the directories wait");
    assert_eq!(c.plc().writes[2..], [(10_016, 8), (14_016, 8)]);
    // The area still plays the first part.
    assert_eq!(area_of(&mut c, 0), table(0).table().segments);
    let bank = c
        .upload_preloaded(1, 7, FROM, &[table(0), table(2)], &first)
        .await
        .unwrap();
    assert!(bank.on_preload);
    // The later part, once the first is done: its directories and its block, read back.
    let before = c.plc().writes.len();
    let bank = c
        .upload_preloaded(1, 8, FROM, &later_tables, &later)
        .await
        .unwrap();
    assert!(bank.on_preload);
    assert_eq!(bank.words, 8 + 8 + 15);
    assert_eq!(
        c.plc().writes[before..],
        [(10_000, 8), (14_000, 8), (1_033, 15)]
    );
    assert_eq!(area_of(&mut c, 0), later_tables[0].table().segments);
    assert_eq!(area_of(&mut c, 2), later_tables[1].table().segments);
    // Placed elsewhere than preloaded, the same tables are not proven: written whole.
    let moved = Preload {
        base: [24; CHANNELS],
        ..later.clone()
    };
    let whole = c
        .upload_preloaded(1, 9, FROM, &later_tables, &moved)
        .await
        .unwrap();
    assert!(!whole.on_preload);
    assert_eq!(whole.words, 16 + 16 + 15);
}

#[tokio::test(start_paused = true)]
async fn a_start_with_a_permit_always_writes_it_and_the_next_without_one_writes_zeros() {
    use crate::contract::{Permit, PermitBit};
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    let permit = Permit::of(&[PermitBit {
        word: 0,
        bit: 5,
        on: true,
    }])
    .unwrap();
    let start = |seq: u16, permit: Permit| StartBlock {
        bank: 1,
        seq,
        from: FROM,
        permit,
    };
    let tables = [table(0), table(2)];
    for (seq, wanted, writes_permit) in [
        (1, Permit::NONE, true),  // the connection's first: not known yet
        (2, Permit::NONE, false), // known all 0: left alone
        (3, permit, true),        // a permit: always written
        (4, permit, true),        // again: never trusted to be there
        (5, Permit::NONE, true),  // back to none: the PLC holds a permit, zeros written
        (6, Permit::NONE, false),
    ] {
        let before = c.plc().writes.len();
        let mut upload = c.begin_upload(&start(seq, wanted), &tables).unwrap();
        while c.upload_step(&mut upload).await.unwrap().is_none() {}
        let wrote = c.plc().writes[before..].iter().any(|(a, _)| *a == 1_049);
        assert_eq!(wrote, writes_permit, "start {seq}");
        let held: Vec<u16> = (1_049..1_057)
            .map(|a| c.plc().dt.get(&a).copied().unwrap_or(0))
            .collect();
        assert_eq!(held, [wanted.mask, wanted.value].concat(), "start {seq}");
    }
}

#[tokio::test(start_paused = true)]
async fn a_preloaded_start_whose_directory_reads_back_wrong_is_not_started() {
    let mut plc = FakePlc::running();
    // The word the later part's directory puts at channel 2's first entry.
    plc.corrupt = Some(14_000);
    let mut c = Contract::new(plc, ContractSettings::default());
    let later = c
        .preload(1, [16; CHANNELS], &[table(0), table(2)])
        .await
        .unwrap();
    let err = c
        .upload_preloaded(1, 8, FROM, &[table(0), table(2)], &later)
        .await
        .unwrap_err();
    assert!(
        matches!(
            err,
            ContractError::CompareFailed {
                address: 14_000,
                wrote: 16,
                ..
            }
        ),
        "{err}"
    );
    assert!(!c.plc().writes.iter().any(|(a, _)| *a == 1_032));
}

#[tokio::test(start_paused = true)]
async fn every_word_written_is_read_back_unless_read_back_is_off() {
    for verify in [true, false] {
        let settings = ContractSettings {
            verify,
            ..ContractSettings::default()
        };
        let mut c = Contract::new(FakePlc::running(), settings);
        let _bank = c.upload(1, 7, FROM, &[table(0), table(2)]).await.unwrap();
        let plc = c.plc();
        assert_eq!(plc.writes.len(), 4, "two tables and the block's two writes");
        let read_back: Vec<_> = plc
            .writes
            .iter()
            .filter(|w| plc.reads.contains(w))
            .collect();
        if verify {
            assert_eq!(read_back.len(), plc.writes.len(), "{:?}", plc.reads);
        } else {
            assert!(read_back.is_empty(), "{:?}", plc.reads);
            let written = |a: u16| {
                plc.writes
                    .iter()
                    .any(|&(s, n)| (s..s + n as u16).contains(&a))
            };
            assert!(
                !plc.reads
                    .iter()
                    .any(|&(s, n)| (s..s + n as u16).any(written)),
                "read_back = false read a written word: {:?}",
                plc.reads
            );
        }
    }
}

#[tokio::test(start_paused = true)]
async fn failed_read_back_yields_no_bank_and_no_start() {
    let mut plc = FakePlc::running();
    plc.corrupt = Some(2_010);
    let mut c = Contract::new(plc, ContractSettings::default());
    let err = c.upload(0, 1, FROM, &[table(0)]).await.unwrap_err();
    assert!(
        matches!(err, ContractError::CompareFailed { address: 2_010, .. }),
        "{err}"
    );
    assert!(!c.plc().writes.iter().any(|(a, _)| *a == 1_032));
}

#[tokio::test(start_paused = true)]
async fn start_writes_exactly_one_command_word() {
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    let bank = c.upload(0, 1, FROM, &[table(1)]).await.unwrap();
    assert!(matches!(
        c.start(&bank).await.unwrap(),
        CommandWrite::Confirmed
    ));
    assert_eq!(c.plc().writes.last(), Some(&(1_032, 1)));
    assert_eq!(c.plc().dt[&1_032], 1);
}

#[tokio::test(start_paused = true)]
async fn a_start_whose_reply_is_lost_is_not_written_again() {
    let mut plc = FakePlc::running();
    plc.lose_reply_at = Some(1_032);
    let mut c = Contract::new(plc, ContractSettings::default());
    let bank = c.upload(0, 1, FROM, &[table(1)]).await.unwrap();
    let written = c.start(&bank).await.unwrap();
    assert!(matches!(
        written,
        CommandWrite::Unconfirmed(PlcError::Timeout { .. })
    ));
    let starts = c.plc().writes.iter().filter(|(a, _)| *a == 1_032).count();
    assert_eq!(starts, 1, "the start was sent once");
}

#[tokio::test(start_paused = true)]
async fn a_start_answered_with_an_error_is_unconfirmed_not_refused() {
    // An error reply does not prove the PLC did not act: what it did is read from its status.
    let mut plc = FakePlc::running();
    plc.refuse_at = Some(1_032);
    let mut c = Contract::new(plc, ContractSettings::default());
    let bank = c.upload(0, 1, FROM, &[table(1)]).await.unwrap();
    let written = c.start(&bank).await.unwrap();
    assert!(
        matches!(written, CommandWrite::Unconfirmed(PlcError::Refused { .. })),
        "{written:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn wrong_magic_and_wrong_version_are_refused_naming_the_values() {
    let mut plc = FakePlc::running();
    plc.dt.insert(1_000, 0x1234);
    let err = Contract::new(plc, ContractSettings::default())
        .status()
        .await
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "status block magic is 0x1234, expected 0x4c49: the linterpd PLC program is not running at DT1000"
    );
    let mut plc = FakePlc::running();
    plc.dt.insert(1_001, 2);
    let err = Contract::new(plc, ContractSettings::default())
        .status()
        .await
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "the PLC program speaks contract version 2; this linterpd speaks 3"
    );
}

fn machine() -> Machine {
    Machine::new(WatchSettings::default(), 0xBEEF)
}

/// The start of `table(0)` from [`FROM`] in bank 0 with sequence number 1.
fn start_of_table_0() -> Planned {
    Planned {
        tag: 1,
        seq: 1,
        bank: 0,
        from: FROM,
        targets: Some([500, 0, 0, 0]),
        envelope: [(0, 500), (0, 0), (0, 0), (0, 0)],
        duration: Duration::from_millis(500),
        curve: None,
        permit: crate::contract::Permit::NONE,
    }
}

#[tokio::test(start_paused = true)]
async fn the_host_word_is_written_and_its_echo_waited_for_before_a_start() {
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    let mut m = machine();
    let status = until_ready(&mut c, &mut m).await.unwrap();
    assert_eq!(c.plc().dt[&1_048], 0xBEEF);
    assert_eq!(status.block.host, 0xBEEF);
    assert_eq!(m.blocker(tokio::time::Instant::now().into_std()), None);
}

#[tokio::test(start_paused = true)]
async fn frozen_heartbeat_in_prog_mode_is_refused_after_the_timeout() {
    let mut plc = FakePlc::running();
    plc.frozen = true;
    plc.prog = true;
    let mut c = Contract::new(plc, ContractSettings::default());
    let err = until_ready(&mut c, &mut machine()).await.unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("limit 500 ms") && msg.ends_with("stalled, and in PROG mode"),
        "{msg}"
    );
}

#[tokio::test(start_paused = true)]
async fn latched_fault_missing_ready_bits_and_no_homing_are_refused() {
    let cases: [(u16, u16, u16, &str); 3] = [
        (
            State::Fault.word(),
            2,
            0b111,
            "fault 2 (channel busy at start)",
        ),
        (State::Idle.word(), 0, 0b011, "ready bits 0b011, need 0b111"),
        (State::Idle.word(), 0, 0b110, "not homed"),
    ];
    for (state, fault, ready, want) in cases {
        let mut plc = FakePlc::running();
        plc.dt.insert(1_003, state);
        plc.dt.insert(1_005, fault);
        plc.dt.insert(1_007, ready);
        let mut c = Contract::new(plc, ContractSettings::default());
        let err = until_ready(&mut c, &mut machine()).await.unwrap_err();
        assert!(err.to_string().contains(want), "{err}");
    }
}

#[tokio::test(start_paused = true)]
async fn a_start_from_other_counts_than_its_from_is_not_written() {
    let mut plc = FakePlc::running();
    plc.put(1_008, &[5, 0]);
    let mut c = Contract::new(plc, ContractSettings::default());
    let mut m = machine();
    until_ready(&mut c, &mut m).await.unwrap();
    m.upload_begun();
    let _bank = c.upload(0, 1, FROM, &[table(0)]).await.unwrap();
    let err = until_it_may_start(&mut c, &mut m, &start_of_table_0())
        .await
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "channel 0 is at 5, the tables were planned from 0: the start is not written"
    );
    assert!(!c.plc().writes.iter().any(|(a, _)| *a == 1_032));
}

#[tokio::test(start_paused = true)]
async fn the_proof_after_an_upload_reads_the_heartbeat_word_alone_then_the_status_block() {
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    let mut m = machine();
    until_ready(&mut c, &mut m).await.unwrap();
    m.upload_begun();
    let _bank = c.upload(0, 1, FROM, &[table(0)]).await.unwrap();
    let before = c.plc().reads.len();
    // The fake ticks its heartbeat at each status read, not at a read of the word alone: the
    // word, then the block, see it move.
    let status = c.proof_read(&mut m).await.unwrap();
    let now = tokio::time::Instant::now().into_std();
    let _ = m.on_status(&status, now);
    assert_eq!(m.may_start(&start_of_table_0(), now), Ok(()));
    assert_eq!(
        c.plc().reads[before..],
        [(1_002, 1), (1_000, STATUS_WORDS)],
        "the heartbeat word alone, then the status block"
    );
    // The proof made, a read more is the status block alone.
    c.proof_read(&mut m).await.unwrap();
    assert_eq!(c.plc().reads[before + 2..], [(1_000, STATUS_WORDS)]);
}

#[tokio::test(start_paused = true)]
async fn a_bank_read_back_describes_a_start_found_running() {
    let mut c = Contract::new(FakePlc::running(), ContractSettings::default());
    let from = [0, 0, 0, 0];
    let bank = c.upload(1, 5, from, &[table(2)]).await.unwrap();
    assert_eq!(bank.block.bank, 1);
    let mut status = c.status().await.unwrap();
    status.block.elapsed[2] = 200;
    status.block.busy = 0b100;
    let planned = c.describe_running(5, 42, &status).await.unwrap();
    assert_eq!(planned.bank, 1);
    assert_eq!(planned.targets, Some([0, 0, 500, 0]));
    assert_eq!(planned.envelope[2], (0, 500));
    assert_eq!(planned.envelope[0], (0, 0));
    assert_eq!(planned.duration, Duration::from_millis(500));
    // A later start written into the other bank: the running one's bank is still found.
    c.plc().put(1_033, &[6, 0, 0]);
    let planned = c.describe_running(5, 42, &status).await.unwrap();
    assert_eq!((planned.bank, planned.targets), (1, None));
    assert_eq!(
        planned.envelope[2],
        (200, 500),
        "from unknown: bounded from where it is"
    );
}
