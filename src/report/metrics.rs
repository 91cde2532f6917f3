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
