//! Studies: CPU experiments that reproduce the paper's measurements outside the renderer
//! and write their data, a markdown summary and plots (DESIGN §4, `shvis study …`).
//!
//! Each study's report is a [`report::StudyReport`]: its markdown summary and its data as
//! JSON, written as `<stem>.md` and `<stem>.json` by the one writer [`report::write`]
//! (atomically); the study writes its figures, plots and other files beside them itself.
//!
//! - [`params`]: Iwanicki–Sloan App. A, Figure 8 — how well each sphere parameterization
//!   of [`crate::sphere`] reconstructs SH basis functions under hardware bilinear
//!   filtering, as MSE against total texel count (`shvis study params`).

//! - [`compression`]: visibility error against storage for PCA, VQ and CPCA
//!   (`shvis study compression`).
//! - [`seams`]: the screen-space discontinuity at cluster boundaries of the
//!   clustered techniques, with and without the seam mitigation (`shvis study seams`).
//! - [`rnm`]: radiosity normal mapping and SSBump against the displaced-geometry
//!   reference under a low sun and an overcast probe (`shvis study rnm`).
//! - [`normalmap`]: GPU normal-map generation timed against triangle counts and
//!   resolution beside the CPU baker, checked on a real model, rendered through `unc6`
//!   (`shvis study normalmap`).
//! - [`nmprt_svd`]: the energy of normal mapping for PRT's "normal basis" (the
//!   SVD of the hemisphere-clamped quadratic SH over normals), `shvis study nmprt-svd`.
//! - [`bases`]: irradiance error of each engine lightmap basis (L1, Geomerics, ZH3,
//!   luminance L1, L2, deringed L2) against exact irradiance per environment; and
//!   [`bases_hemisphere`] (its rows in [`bases_hemisphere_fits`], its report in
//!   [`bases_hemisphere_report`]): a floor texel under each environment, every lightmap
//!   basis fitted from the same radiance samples — the pixels and the order-8 SH — against
//!   the pixels' irradiance and radiance, with bytes per texel (`shvis study bases`).
//! - [`block`]: the SH lightmap block-compressed (BC6H, BC7) under each packing of its
//!   signed coefficients, and the encoder's settings against time (`shvis study block`).
//! - [`ndf`]: the specular term under naive MIP and normal-distribution filtering
//!   on the receding bumpy plane against its footprint reference (`shvis study ndf`).

pub mod bases;
pub mod bases_hemisphere;
pub mod bases_hemisphere_fits;
pub mod bases_hemisphere_report;
pub mod block;
pub mod compression;
pub mod ndf;
pub mod ndf_diffuse;
pub mod ndf_report;
pub mod nmprt_svd;
pub mod nmprt_svd_report;
pub mod normalmap;
pub mod normalmap_report;
pub mod params;
pub mod params_gpu;
pub mod rays;
pub mod report;
pub mod rnm;
pub mod rnm_report;
pub mod seams;
pub mod tables;

use crate::render::Frame;

/// Frames of one size tiled left to right (the studies' composites).
pub(crate) fn side_by_side(frames: &[&Frame]) -> Frame {
    let (w, h) = (frames[0].width, frames[0].height);
    let total = w * frames.len() as u32;
    let mut rgba = vec![[0.0f32; 4]; (total * h) as usize];
    for (k, f) in frames.iter().enumerate() {
        for y in 0..h {
            for x in 0..w {
                rgba[(y * total + k as u32 * w + x) as usize] = f.rgba[(y * w + x) as usize];
            }
        }
    }
    Frame {
        width: total,
        height: h,
        rgba,
        ms: Vec::new(),
    }
}
