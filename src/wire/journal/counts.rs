//! Production counts from the journal: per shift, the cycles run to their end, the parts placed
//! on pallets, the pallets filled, the faults. Shifts are windows of a fixed length laid from
//! midnight UTC plus an offset (8 h from 06:00: 06-14, 14-22, 22-06).

use serde::{Deserialize, Serialize};

use super::{CycleOutcome, Entry, Kind, format_rfc3339};

/// One shift's counts.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShiftCounts {
    /// When it began (RFC 3339, UTC).
    pub from: String,
    /// When it ends.
    pub to: String,
    /// Cycles run to their end.
    pub cycles: u64,
    /// Cycles stopped before their end.
    pub stopped: u64,
    /// Parts placed on pallets.
    pub parts: u64,
    /// Pallets filled.
    pub pallets: u64,
    /// Faults (the PLC's and the cycles').
    pub faults: u64,
}

/// The counts of `entries` per shift of `shift_ms`, shifts starting `offset_ms` after midnight
/// UTC: every shift from the first entry's to the last's, empty ones too, oldest first.
#[must_use]
pub fn per_shift(entries: &[Entry], shift_ms: u64, offset_ms: u64) -> Vec<ShiftCounts> {
    let shift_ms = shift_ms.max(1);
    let start_of = |at: u64| {
        let from_offset = at.saturating_sub(offset_ms % shift_ms);
        from_offset - from_offset % shift_ms + offset_ms % shift_ms
    };
    let (Some(first), Some(last)) = (
        entries.iter().map(|e| e.at_ms).min(),
        entries.iter().map(|e| e.at_ms).max(),
    ) else {
        return Vec::new();
    };
    let mut shifts = Vec::new();
    let mut from = start_of(first);
    while from <= last {
        let to = from + shift_ms;
        let mut counts = ShiftCounts {
            from: format_rfc3339(from),
            to: format_rfc3339(to),
            cycles: 0,
            stopped: 0,
            parts: 0,
            pallets: 0,
            faults: 0,
        };
        for entry in entries.iter().filter(|e| (from..to).contains(&e.at_ms)) {
            count(&mut counts, &entry.kind);
        }
        shifts.push(counts);
        from = to;
    }
    shifts
}

fn count(counts: &mut ShiftCounts, kind: &Kind) {
    match kind {
        Kind::CycleEnded { outcome, .. } => match outcome {
            CycleOutcome::Done => counts.cycles += 1,
            CycleOutcome::Stopped => counts.stopped += 1,
        },
        Kind::PalletPlaced { .. } => counts.parts += 1,
        Kind::PalletFull { .. } => counts.pallets += 1,
        Kind::Fault { .. } => counts.faults += 1,
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOUR: u64 = 3_600_000;

    fn at(ms: u64, kind: Kind) -> Entry {
        Entry {
            seq: ms,
            at_ms: ms,
            robot: Some("r".into()),
            kind,
        }
    }

    fn ended(outcome: CycleOutcome) -> Kind {
        Kind::CycleEnded {
            program: "main".into(),
            cycle: 1,
            outcome,
            cycle_s: None,
        }
    }

    #[test]
    fn shifts_from_six_count_cycles_parts_and_pallets_in_their_window() {
        // 2026-11-29T00:00Z is day 20786.
        let day = 20_786 * 24 * HOUR;
        let placed = |slot| Kind::PalletPlaced {
            pallet: "out".into(),
            slot,
            layer: 1,
        };
        let entries = vec![
            at(day + 5 * HOUR, ended(CycleOutcome::Done)), // night shift 22-06
            at(day + 7 * HOUR, ended(CycleOutcome::Done)),
            at(day + 7 * HOUR + 1, placed(1)),
            at(day + 13 * HOUR, placed(2)),
            at(
                day + 13 * HOUR + 5,
                Kind::PalletFull {
                    pallet: "out".into(),
                    parts: 2,
                },
            ),
            at(day + 13 * HOUR + 9, ended(CycleOutcome::Stopped)),
            // 14-22 has nothing; 22-06 one fault.
            at(
                day + 23 * HOUR,
                Kind::Fault {
                    code: Some(3),
                    reason: "e-stop".into(),
                },
            ),
        ];
        let shifts = per_shift(&entries, 8 * HOUR, 6 * HOUR);
        let got: Vec<(String, u64, u64, u64, u64, u64)> = shifts
            .iter()
            .map(|s| {
                (
                    s.from.clone(),
                    s.cycles,
                    s.stopped,
                    s.parts,
                    s.pallets,
                    s.faults,
                )
            })
            .collect();
        assert_eq!(
            got,
            vec![
                ("2026-11-28T22:00:00.000Z".into(), 1, 0, 0, 0, 0),
                ("2026-11-29T06:00:00.000Z".into(), 1, 1, 2, 1, 0),
                ("2026-11-29T14:00:00.000Z".into(), 0, 0, 0, 0, 0),
                ("2026-11-29T22:00:00.000Z".into(), 0, 0, 0, 0, 1),
            ]
        );
        assert_eq!(shifts[1].to, "2026-11-29T14:00:00.000Z");
        assert!(per_shift(&[], 8 * HOUR, 0).is_empty());
    }
}
