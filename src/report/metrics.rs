//! Frame-time statistics (median, min, max). Error metrics against the reference come
//! with the reference renderer.

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

/// Error of an image against the reference over the pixels covered in both.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ImageError {
    /// √(Σ (t − r)²) / √(Σ r²) over covered pixels and RGB channels.
    pub rel_rmse: f64,
    /// 10·log10(peak² / MSE), peak = the reference's largest RGB value over covered pixels.
    pub psnr: f64,
    pub pixels: usize,
}

/// Compares `test` with `reference` (same size). `None` when no pixel is covered in both.
pub fn image_error(
    test: &crate::render::Frame,
    reference: &crate::render::Frame,
) -> Option<ImageError> {
    if test.width != reference.width || test.height != reference.height {
        return None;
    }
    let (mut se, mut ref_sq, mut peak, mut pixels) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for (t, r) in test.rgba.iter().zip(&reference.rgba) {
        if t[3] < 0.5 || r[3] < 0.5 {
            continue;
        }
        pixels += 1;
        for c in 0..3 {
            let (tv, rv) = (t[c] as f64, r[c] as f64);
            se += (tv - rv).powi(2);
            ref_sq += rv * rv;
            peak = peak.max(rv);
        }
    }
    if pixels == 0 || ref_sq == 0.0 {
        return None;
    }
    let mse = se / (3 * pixels) as f64;
    Some(ImageError {
        rel_rmse: (se / ref_sq).sqrt(),
        psnr: 10.0 * (peak * peak / mse).log10(),
        pixels,
    })
}
