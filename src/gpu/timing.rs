//! Frame-time statistics (median, min, max) of timestamp-query frame times.

/// Median, min and max of a set of frame times, ms.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TimingStats {
    pub ms_median: f64,
    pub ms_min: f64,
    pub ms_max: f64,
    pub frames: usize,
}

impl TimingStats {
    /// `None` for an empty set (no timestamp support).
    pub fn from_ms(ms: &[f64]) -> Option<Self> {
        if ms.is_empty() {
            return None;
        }
        let mut sorted = ms.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let median = if n % 2 == 1 {
            sorted[n / 2]
        } else {
            0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
        };
        Some(TimingStats {
            ms_median: median,
            ms_min: sorted[0],
            ms_max: sorted[n - 1],
            frames: n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        let s = TimingStats::from_ms(&[3.0, 1.0, 2.0]).unwrap();
        assert_eq!(
            (s.ms_median, s.ms_min, s.ms_max, s.frames),
            (2.0, 1.0, 3.0, 3)
        );
        let s = TimingStats::from_ms(&[4.0, 1.0, 2.0, 3.0]).unwrap();
        assert_eq!(s.ms_median, 2.5);
        assert!(TimingStats::from_ms(&[]).is_none());
    }
}
