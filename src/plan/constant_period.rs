//! The seed's constant time period method, made safe for an FP-X.
//!
//! Each joint's counts at the interpolation points give one row per period with a nonzero count
//! change. A period in which the joint moves no pulse is folded into the next row (the row spans
//! several periods at a lower frequency); periods with no pulse after the joint's last move fold
//! into its last row, so every moving channel ends with the move. No "+1" correction, no
//! zero-length row. Rows become segments in [`super::segments`].

use super::segments::Span;

/// The spans of one joint: `counts[i]` is its count at point i, points `period_s` apart but the
/// last, at `end_s` (a whole number of periods, or a time-optimal profile's own last period).
#[must_use]
pub(super) fn spans(counts: &[i64], period_s: f64, end_s: f64) -> Vec<Span> {
    let last = counts.len().saturating_sub(1);
    let at = |i: usize| {
        if i == last {
            end_s
        } else {
            i as f64 * period_s
        }
    };
    let mut out: Vec<Span> = Vec::new();
    let mut row_start = 0usize;
    for i in 1..counts.len() {
        if counts[i] != counts[i - 1] {
            out.push(Span {
                target: counts[i],
                start_s: at(row_start),
                end_s: at(i),
            });
            row_start = i;
        }
    }
    if let Some(row) = out.last_mut() {
        row.end_s = at(last);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_periods_fold_into_the_next_row_and_trailing_ones_into_the_last() {
        let s = spans(&[0, 0, 0, 2, 2, 5, 5], 0.05, 0.30);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].target, 2);
        assert!((s[0].start_s - 0.0).abs() < 1e-12 && (s[0].end_s - 0.15).abs() < 1e-12);
        assert_eq!(s[1].target, 5);
        assert!((s[1].start_s - 0.15).abs() < 1e-12 && (s[1].end_s - 0.30).abs() < 1e-12);
    }

    #[test]
    fn joint_that_never_moves_has_no_rows() {
        assert!(spans(&[7, 7, 7], 0.05, 0.1).is_empty());
    }
}
