//! `--env sh:FILE`: an environment given by its SH radiance coefficients, so probes exported
//! from an engine and published coefficient sets can be lit and studied.
//!
//! The file is what `shvis sh project` prints: one coefficient per line, "r g b" (RGB
//! radiance, DESIGN §1's convention and flat index l(l+1)+m), n² lines for order n; blank
//! lines and lines starting with `#` are skipped. A coefficient beyond the radiance limit
//! every environment has (`equirect::MAX_ENV_RADIANCE`) is refused at load, for every
//! command alike: past it the bakes' sums and the f16 data overflow. As a map ([`environment`]) the radiance
//! L(ω) = Σ c_i y_i(ω) is rasterised into an equirectangular image fine enough that
//! projecting it back returns the coefficients (texel solid angles are exact; the error of
//! the midpoint rule in θ is ~1/H² of the signal). A truncated SH may be negative somewhere:
//! that is kept, not clamped, and reported (share of the sphere, lowest value) — note that
//! the reference renderer importance-samples only positive radiance, so there the
//! technique and the reference see different light.

use std::path::Path;

use glam::DVec3;

use super::{EnvError, EnvMap};
use crate::sh::Order;
use crate::sh::basis::eval_basis;

/// Largest file read: far above order 30's 900 lines.
const MAX_SH_FILE_BYTES: u64 = 1 << 20;

/// The coefficients of `path` (module doc).
///
/// # Errors
/// [`EnvError::Io`] when it cannot be read; [`EnvError::Format`] for a line that is not
/// three finite numbers within the radiance limit every environment has
/// (`equirect::MAX_ENV_RADIANCE`), no coefficients, or a count that is not a square n² ≤ 30².
pub fn load(path: &Path) -> Result<Vec<[f64; 3]>, EnvError> {
    let bytes = super::equirect::read_env_file(path, MAX_SH_FILE_BYTES, "an SH coefficient file")?;
    let format = |detail: String| EnvError::Format {
        path: path.to_owned(),
        detail,
    };
    let text = String::from_utf8(bytes)
        .map_err(|_| format("not UTF-8 text (expected lines of \"r g b\")".into()))?;
    let mut coeffs = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let values: Vec<f64> = line
            .split_whitespace()
            .map(str::parse::<f64>)
            .collect::<Result<_, _>>()
            .map_err(|_| format(format!("line {}: not numbers: {line:?}", number + 1)))?;
        let [r, g, b] = values[..] else {
            return Err(format(format!(
                "line {}: {} values, expected three (r g b)",
                number + 1,
                values.len()
            )));
        };
        if !(r.is_finite() && g.is_finite() && b.is_finite()) {
            return Err(format(format!("line {}: not finite: {line:?}", number + 1)));
        }
        let limit = super::equirect::MAX_ENV_RADIANCE;
        if let Some(v) = [r, g, b].into_iter().find(|v| v.abs() > f64::from(limit)) {
            return Err(format(format!(
                "line {}: {v:e} is beyond the radiance limit {limit:e} every environment has (the bakes' f32 sums and the f16 data would overflow); scale the coefficients down",
                number + 1
            )));
        }
        coeffs.push([r, g, b]);
    }
    let order = (coeffs.len() as f64).sqrt().round() as u32;
    if coeffs.is_empty() || (order * order) as usize != coeffs.len() || order > crate::sh::MAX_ORDER
    {
        return Err(format(format!(
            "{} coefficients; an order-n SH has n² (1, 4, 9, 16, …, at most {})",
            coeffs.len(),
            crate::sh::MAX_ORDER * crate::sh::MAX_ORDER
        )));
    }
    Ok(coeffs)
}

/// The order of `coeffs` (n² of them).
pub fn order_of(coeffs: &[[f64; 3]]) -> Order {
    let n = (coeffs.len() as f64).sqrt().round() as u32;
    Order::new(n.max(1)).expect("load checked the count")
}

/// The environment of `path` as a map (module doc), with a warning when the radiance is
/// negative somewhere.
///
/// # Errors
/// As [`load`].
pub fn environment(path: &Path) -> Result<EnvMap, EnvError> {
    let coeffs = load(path)?;
    let order = order_of(&coeffs);
    // 16 texels per band across the height, at least 256 × 128.
    let height = (16 * order.get()).clamp(128, 1024);
    let map = EnvMap::from_fn(2 * height, height, |d| {
        radiance(&coeffs, order, d).map(|v| v as f32)
    });
    let (negative, lowest) = negative_share(&map);
    if negative > 0.0 {
        log::warn!(
            "{}: the SH radiance is negative over {:.1} % of the sphere (lowest {:.3e}); kept \
             as given (the reference renderer samples only its positive part)",
            path.display(),
            100.0 * negative,
            lowest
        );
    }
    Ok(map)
}

/// L(d) = Σ c_i y_i(d), RGB.
pub fn radiance(coeffs: &[[f64; 3]], order: Order, d: DVec3) -> [f64; 3] {
    let mut y = vec![0.0; order.coeff_count()];
    eval_basis(order, d, &mut y);
    std::array::from_fn(|c| coeffs.iter().zip(&y).map(|(k, y)| k[c] * y).sum())
}

/// Share of the sphere (by solid angle) where some channel of `map` is negative, and the
/// lowest value.
fn negative_share(map: &EnvMap) -> (f64, f32) {
    let (mut negative, mut total, mut lowest) = (0.0, 0.0, 0.0f32);
    for y in 0..map.height {
        let omega = map.texel_solid_angle(y);
        for x in 0..map.width {
            let t = map.texel(x, y);
            let min = t[0].min(t[1]).min(t[2]);
            total += omega;
            if min < 0.0 {
                negative += omega;
                lowest = lowest.min(min);
            }
        }
    }
    (negative / total, lowest)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("shvis-sh-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn a_projected_file_round_trips_through_the_map() {
        // Order 3 with a strong linear term: negative on part of the sphere.
        let text = "# order 3\n1.0 0.9 0.8\n0.2 0.1 0.0\n0.9 0.8 0.7\n-0.3 -0.2 -0.1\n\
                    0.05 0 0\n0 0.05 0\n0.1 0.1 0.1\n0 0 0.05\n-0.05 0 0\n";
        let path = write("ok.txt", text);
        let coeffs = load(&path).unwrap();
        assert_eq!(coeffs.len(), 9);
        let map = environment(&path).unwrap();
        let (negative, lowest) = negative_share(&map);
        assert!(negative > 0.01 && lowest < 0.0, "{negative} {lowest}");
        let back = crate::env::project::project_sh(&map, Order::THREE);
        for (a, b) in coeffs.iter().zip(&back) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() < 2e-4, "{a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn bad_files_are_one_clear_error() {
        for (name, text, want) in [
            (
                "five.txt",
                "1 1 1\n0 0 0\n0 0 0\n0 0 0\n0 0 0\n",
                "5 coefficients",
            ),
            ("two.txt", "1 1\n", "2 values"),
            ("word.txt", "1 one 1\n", "not numbers"),
            ("nan.txt", "NaN 1 1\n", "not finite"),
            (
                "huge.txt",
                "1 1 1\n3e38 0 0\n0 0 0\n0 0 0\n",
                "line 2: 3e38 is beyond the radiance limit",
            ),
            ("negative.txt", "-2e12 1 1\n", "line 1: -2e12 is beyond"),
            ("empty.txt", "# nothing\n\n", "0 coefficients"),
        ] {
            let e = load(&write(name, text)).unwrap_err().to_string();
            assert!(e.contains(want), "{name}: {e}");
        }
    }
}
