use std::path::PathBuf;

use super::*;
use crate::wire::journal::Source;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linterpd-journal-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn command(n: u64) -> Kind {
    Kind::Command {
        source: Source::Api,
        who: Some(format!("uid {n}")),
        action: "POST stop".into(),
        status: Some(200),
        refused: None,
    }
}

fn all(journal: &Journal) -> Vec<Entry> {
    journal
        .read(&Query {
            limit: usize::MAX,
            ..Query::default()
        })
        .unwrap()
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
}

#[test]
fn entries_survive_a_restart_and_their_numbers_go_on() {
    let dir = temp("restart");
    let settings = JournalSettings::default();
    let rt = runtime();
    let first = Journal::open(&dir, &settings).unwrap();
    for n in 0..3 {
        first.record(Some("r"), command(n));
    }
    rt.block_on(first.flush());
    drop(first);
    let second = Journal::open(&dir, &settings).unwrap();
    second.record(None, Kind::DaemonStopping);
    rt.block_on(second.flush());
    let entries = all(&second);
    let seqs: Vec<u64> = entries.iter().map(|e| e.seq).collect();
    assert_eq!(seqs, vec![1, 2, 3, 4]);
    assert_eq!(entries[0].kind, command(0));
    assert_eq!(entries[3].kind, Kind::DaemonStopping);
    assert_eq!(second.counts().written, 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn rotation_keeps_the_files_and_bytes_within_the_caps() {
    let dir = temp("rotate");
    let settings = JournalSettings {
        file_bytes: 4096,
        files: 3,
        queue: 10_000,
    };
    let rt = runtime();
    let journal = Journal::open(&dir, &settings).unwrap();
    for n in 0..2000 {
        journal.record(Some("r"), command(n));
    }
    rt.block_on(journal.flush());
    let files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap())
        .collect();
    let bytes: u64 = files.iter().map(|f| f.metadata().unwrap().len()).sum();
    assert_eq!(files.len(), 3, "{files:?}");
    assert!(files.iter().all(|f| f.metadata().unwrap().len() <= 4096));
    assert!(bytes <= 3 * 4096, "{bytes}");
    // The newest entries are kept, numbered on without a gap.
    let entries = all(&journal);
    let last = entries.last().unwrap();
    assert_eq!(last.seq, 2000);
    assert!(entries.windows(2).all(|w| w[1].seq == w[0].seq + 1));
    assert!(
        entries.len() > 40 && entries.len() < 2000,
        "{}",
        entries.len()
    );
    assert_eq!(journal.counts().dropped, 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_torn_last_line_is_cut_off_journaled_and_the_numbers_go_on() {
    let dir = temp("torn");
    let settings = JournalSettings::default();
    let rt = runtime();
    let journal = Journal::open(&dir, &settings).unwrap();
    journal.record(Some("r"), command(1));
    journal.record(Some("r"), command(2));
    rt.block_on(journal.flush());
    drop(journal);
    // A power cut in the middle of the third line, and a block of zeros after it.
    let file = segments::segment_path(&dir, 1);
    let mut text = std::fs::read(&file).unwrap();
    let torn: Vec<u8> = [&b"{\"seq\":3,\"at\":\"2026-11-29T08:"[..], &[0; 40]].concat();
    text.extend_from_slice(&torn);
    std::fs::write(&file, &text).unwrap();
    let reopened = Journal::open(&dir, &settings).unwrap();
    reopened.record(Some("r"), command(3));
    rt.block_on(reopened.flush());
    let entries = all(&reopened);
    let kinds: Vec<&str> = entries.iter().map(|e| e.kind.name()).collect();
    assert_eq!(kinds, vec!["command", "command", "torn-line", "command"]);
    assert_eq!(
        entries[2].kind,
        Kind::TornLine {
            file: "00000000000000000001.jsonl".into(),
            bytes: torn.len() as u64
        }
    );
    assert_eq!(
        entries.iter().map(|e| e.seq).collect::<Vec<_>>(),
        vec![1, 2, 3, 4]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_whole_last_entry_missing_its_line_break_is_kept() {
    let dir = temp("no-break");
    let settings = JournalSettings::default();
    let rt = runtime();
    let journal = Journal::open(&dir, &settings).unwrap();
    journal.record(Some("r"), command(1));
    rt.block_on(journal.flush());
    drop(journal);
    let file = segments::segment_path(&dir, 1);
    let text = std::fs::read_to_string(&file).unwrap();
    std::fs::write(&file, text.trim_end()).unwrap();
    let reopened = Journal::open(&dir, &settings).unwrap();
    reopened.record(Some("r"), command(2));
    rt.block_on(reopened.flush());
    let seqs: Vec<u64> = all(&reopened).iter().map(|e| e.seq).collect();
    assert_eq!(seqs, vec![1, 2]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_full_queue_drops_and_counts_and_the_drop_is_journaled() {
    let dir = temp("full");
    let settings = JournalSettings {
        queue: 16,
        ..JournalSettings::default()
    };
    let rt = runtime();
    let journal = Journal::open(&dir, &settings).unwrap();
    // Far more than the queue takes while the writer is busy with its first batch.
    for n in 0..100_000 {
        journal.record(Some("r"), command(n));
    }
    rt.block_on(journal.flush());
    journal.record(Some("r"), command(0));
    rt.block_on(journal.flush());
    let counts = journal.counts();
    assert!(counts.dropped > 0, "{counts:?}");
    let told: u64 = all(&journal)
        .iter()
        .filter_map(|e| match e.kind {
            Kind::Dropped { entries } => Some(entries),
            _ => None,
        })
        .sum();
    assert_eq!(told, counts.dropped);
    assert_eq!(
        counts.written + counts.dropped,
        100_001 + told_entries(&journal)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The `dropped` entries themselves (written, not recorded).
fn told_entries(journal: &Journal) -> u64 {
    all(journal)
        .iter()
        .filter(|e| matches!(e.kind, Kind::Dropped { .. }))
        .count() as u64
}

#[test]
fn a_query_takes_after_since_robot_and_the_newest() {
    let dir = temp("query");
    let settings = JournalSettings {
        file_bytes: 65_536,
        ..JournalSettings::default()
    };
    let rt = runtime();
    let journal = Journal::open(&dir, &settings).unwrap();
    for n in 0..1000 {
        let robot = if n % 2 == 0 { "a" } else { "b" };
        journal.record(Some(robot), command(n));
    }
    journal.record(None, Kind::DaemonStopping);
    rt.block_on(journal.flush());
    let q = |query: Query| journal.read(&query).unwrap();
    let after = q(Query {
        after: Some(990),
        limit: 5,
        ..Query::default()
    });
    assert_eq!(
        after.iter().map(|e| e.seq).collect::<Vec<_>>(),
        vec![991, 992, 993, 994, 995]
    );
    let newest = q(Query {
        limit: 3,
        newest: true,
        robot: Some("a".into()),
        ..Query::default()
    });
    assert_eq!(
        newest.iter().map(|e| e.seq).collect::<Vec<_>>(),
        vec![997, 999, 1001]
    );
    let since = q(Query {
        since_ms: Some(now_ms() + 60_000),
        limit: 10,
        ..Query::default()
    });
    assert!(since.is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}
