//! Studies: CPU experiments that reproduce the paper's measurements outside the renderer
//! and write their data, a markdown summary and plots (DESIGN §4, `shvis study …`).
//!
//! - [`params`]: Iwanicki–Sloan App. A, Figure 8 — how well each sphere parameterization
//!   of [`crate::sphere`] reconstructs SH basis functions under hardware bilinear
//!   filtering, as MSE against total texel count (`shvis study params`).

//! - [`compression`]: issue 16 — visibility error against storage for PCA, VQ and CPCA
//!   (`shvis study compression`).
//! - [`seams`]: issue 16 — the screen-space discontinuity at cluster boundaries of the
//!   clustered techniques, with and without the seam mitigation (`shvis study seams`).
//! - [`rnm`]: issue 17 — radiosity normal mapping and SSBump against the displaced-geometry
//!   reference under a low sun and an overcast probe (`shvis study rnm`).
//! - [`normalmap`]: issue 18 — GPU normal-map generation timed against triangle counts and
//!   resolution beside the CPU baker, checked on a real model, rendered through `unc6`
//!   (`shvis study normalmap`).
//! - [`ndf`]: issue 19 — the specular term under naive MIP and normal-distribution filtering
//!   on the receding bumpy plane against its footprint reference (`shvis study ndf`).

pub mod compression;
pub mod ndf;
pub mod normalmap;
pub mod params;
pub mod params_gpu;
pub mod rnm;
pub mod seams;
