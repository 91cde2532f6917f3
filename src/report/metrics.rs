//! Error metrics of an image against the reference (frame-time statistics are
//! `gpu::TimingStats`).

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

/// A row's error above which it is suspect: more error than the reference has signal.
pub const SUSPECT_ERROR: f64 = 1.0;
/// A row's mean (over pixels covered in both) further than this from its reference's,
/// relative, makes it suspect.
pub const SUSPECT_MEAN_CHANGE: f64 = 0.25;

/// Why a row's image cannot be right, if it cannot: non-finite pixels, an error above
/// [`SUSPECT_ERROR`], or a mean more than [`SUSPECT_MEAN_CHANGE`] from its reference's.
/// `None` for a plausible image (a wrong one can still pass).
pub fn suspect_reason(
    test: &crate::render::Frame,
    reference: Option<&crate::render::Frame>,
    rel_rmse: Option<f64>,
) -> Option<String> {
    let mut reasons = Vec::new();
    let non_finite = test
        .rgba
        .iter()
        .filter(|p| p[3] > 0.5 && p[..3].iter().any(|c| !c.is_finite()))
        .count();
    if non_finite > 0 {
        reasons.push(format!("{non_finite} non-finite pixels"));
    }
    if let Some(e) = rel_rmse.filter(|&e| e > SUSPECT_ERROR) {
        reasons.push(format!("relative RMSE {e:.2} > {SUSPECT_ERROR}"));
    }
    if let Some(r) = reference.filter(|r| r.width == test.width && r.height == test.height) {
        let (mut sum_t, mut sum_r) = (0.0f64, 0.0f64);
        for (t, r) in test.rgba.iter().zip(&r.rgba) {
            if t[3] > 0.5 && r[3] > 0.5 && t[..3].iter().all(|c| c.is_finite()) {
                sum_t += t[..3].iter().map(|&c| f64::from(c)).sum::<f64>();
                sum_r += r[..3].iter().map(|&c| f64::from(c)).sum::<f64>();
            }
        }
        if sum_r > 0.0 && (sum_t / sum_r - 1.0).abs() > SUSPECT_MEAN_CHANGE {
            reasons.push(format!("mean {:.2}× the reference's", sum_t / sum_r));
        }
    }
    (!reasons.is_empty()).then(|| reasons.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Frame;

    fn frame(value: f32) -> Frame {
        Frame {
            width: 4,
            height: 2,
            rgba: (0..8)
                .map(|i| [value * (1.0 + i as f32 * 0.1), value, value, 1.0])
                .collect(),
            ms: Vec::new(),
        }
    }

    #[test]
    fn a_plausible_row_passes_and_absurd_ones_say_why() {
        let reference = frame(1.0);
        let close = frame(1.1);
        let e = image_error(&close, &reference).map(|e| e.rel_rmse);
        assert_eq!(suspect_reason(&close, Some(&reference), e), None);
        // A technique scaled ×100: its error and its mean both give it away.
        let scaled = frame(100.0);
        let e = image_error(&scaled, &reference).map(|e| e.rel_rmse);
        let reason = suspect_reason(&scaled, Some(&reference), e).unwrap();
        assert!(
            reason.contains("relative RMSE") && reason.contains("mean 100.00×"),
            "{reason}"
        );
        // Non-finite pixels, with or without a reference.
        let mut broken = frame(1.0);
        broken.rgba[3][1] = f32::NAN;
        let reason = suspect_reason(&broken, None, None).unwrap();
        assert_eq!(reason, "1 non-finite pixels");
        // Half as bright: within the error bound, not within the mean's.
        let dim = frame(0.5);
        let e = image_error(&dim, &reference).map(|e| e.rel_rmse);
        assert_eq!(
            suspect_reason(&dim, Some(&reference), e).as_deref(),
            Some("mean 0.50× the reference's")
        );
    }
}
