//! CPU bake: everything computed once per scene and stored per lightmap texel (DESIGN §5).
//!
//! - [`raster`]: which lightmap texels a mesh covers, with their world position and
//!   geometric normal (texel centres at (i+½)/res, DESIGN §1), and gutter dilation.
//! - [`trace`]: occlusion rays against the mesh (obvhs compressed-wide BVH).
//! - [`ao`]: scalar ambient occlusion per texel, the `preconv` technique's data (DESIGN §2).
//! - [`directions`]: the shared stratified ray directions of the visibility bake and the
//!   SH projection of a texel's visible set.
//! - [`visibility`]: SH visibility per texel (Iwanicki–Sloan §3.1), the `unc*`/`pca*` data.
//! - [`gpu_visibility`]: the same bake by depth maps on the GPU (PRT course's simulator).
//! - [`surface`]: attributes of ray hit points (oriented normal, albedo, lightmap texel).
//! - [`shlmap`]: order-3 SH of incident radiance with inter-reflection, the `shlmap` data.
//! - [`transfer`]: per-texel transfer matrices M (lighting → order-3 transferred incident
//!   radiance, inter-reflection included) of normal mapping for PRT.
//! - [`outer`]: sums of nine-row outer products in a fixed order, the transfer bake's
//!   inner loop.
//! - [`cache`]: versioned, checksummed bake cache files, and EXR dumps for inspection.
//! - [`block`]: BC6H / BC7 block compression (Intel's ISPC encoder) and decoding (`bcdec_rs`).
//!
//! Inputs a user controls (ray counts, resolutions) are validated here once, by
//! [`validate_rays`] and [`validate_res`], so the bake math itself returns no errors.

pub mod ao;
pub mod block;
pub mod cache;
pub mod cluster;
pub mod directions;
pub mod gpu_check;
pub mod gpu_visibility;
pub mod lxh;
pub mod outer;
pub mod pca;
pub mod raster;
pub mod shlmap;
pub mod ssbump;
pub mod surface;
pub mod trace;
pub mod transfer;
pub mod vertex_pca;
pub mod visibility;

/// A bake's progress bar on stderr, `label` first, with the elapsed time, the share done
/// and a message slot (rays/s); hidden unless `show`.
pub fn progress_bar(show: bool, len: usize, label: &str) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len as u64);
    let style = indicatif::ProgressStyle::with_template(&format!(
        "{label} {{elapsed_precise}} [{{bar:40.cyan/blue}}] {{percent:>3}}% {{msg}}"
    ))
    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
    .progress_chars("=> ");
    bar.set_style(style);
    bar
}

/// Work and time of one bake, shared by every bake that traces rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BakeStats {
    /// Rays traced in total (directions below a texel's horizon are not traced).
    pub rays_traced: u64,
    /// Wall-clock time of the bake, seconds.
    pub seconds: f64,
}

impl BakeStats {
    /// Throughput, traced rays per second (0 when nothing was timed).
    pub fn rays_per_second(&self) -> f64 {
        if self.seconds > 0.0 {
            self.rays_traced as f64 / self.seconds
        } else {
            0.0
        }
    }
}

impl std::fmt::Display for BakeStats {
    /// "1.59 s, 49.00 Mrays/s"
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.2} s, {:.2} Mrays/s",
            self.seconds,
            self.rays_per_second() * 1e-6
        )
    }
}

/// Fewest rays per texel.
pub const MIN_RAYS: u32 = 1;
/// Most rays per texel.
pub const MAX_RAYS: u32 = 65536;
/// Smallest lightmap resolution (texels per side).
pub const MIN_RES: u32 = 16;
/// Largest lightmap resolution (texels per side).
pub const MAX_RES: u32 = 8192;

/// Errors of the bake layer; each message is one line naming the input.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("--rays {rays} is out of range {min}..={max}")]
    RaysOutOfRange { rays: u32, min: u32, max: u32 },
    #[error("lightmap resolution {res} is out of range {min}..={max}")]
    ResOutOfRange { res: u32, min: u32, max: u32 },
    #[error("no triangle covers a lightmap texel centre: the mesh has no usable lightmap UVs")]
    EmptyLightmap,
    #[error("PCA basis size {m} is out of range 1..={n}")]
    PcaBasisOutOfRange { m: usize, n: usize },
    #[error("cluster count {k} is out of range 1..=65536")]
    ClusterCountOutOfRange { k: usize },
    #[error("{}: cannot {action}: {source}", .path.display())]
    Io {
        path: std::path::PathBuf,
        action: &'static str,
        source: std::io::Error,
    },
    #[error("{}: cannot write EXR: {detail}", .path.display())]
    Exr {
        path: std::path::PathBuf,
        detail: String,
    },
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// Data derived from a bake and cached with it (the dx11 blocks) could not be made.
    #[error("{0}")]
    Derived(String),
}

/// Checks a rays-per-texel count against [`MIN_RAYS`]..=[`MAX_RAYS`].
///
/// # Errors
/// [`BakeError::RaysOutOfRange`] outside that range.
pub fn validate_rays(rays: u32) -> Result<u32, BakeError> {
    if (MIN_RAYS..=MAX_RAYS).contains(&rays) {
        Ok(rays)
    } else {
        Err(BakeError::RaysOutOfRange {
            rays,
            min: MIN_RAYS,
            max: MAX_RAYS,
        })
    }
}

/// Checks a lightmap resolution against [`MIN_RES`]..=[`MAX_RES`].
///
/// # Errors
/// [`BakeError::ResOutOfRange`] outside that range.
pub fn validate_res(res: u32) -> Result<u32, BakeError> {
    if (MIN_RES..=MAX_RES).contains(&res) {
        Ok(res)
    } else {
        Err(BakeError::ResOutOfRange {
            res,
            min: MIN_RES,
            max: MAX_RES,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_are_inclusive() {
        assert!(validate_rays(1).is_ok() && validate_rays(65536).is_ok());
        assert!(validate_rays(0).is_err() && validate_rays(65537).is_err());
        assert!(validate_res(16).is_ok() && validate_res(8192).is_ok());
        assert!(validate_res(15).is_err() && validate_res(8193).is_err());
        let msg = validate_rays(0).map_err(|e| e.to_string());
        assert_eq!(msg, Err("--rays 0 is out of range 1..=65536".to_string()));
    }
}
