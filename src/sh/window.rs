//! Windowing of SH coefficients against ringing (off by default: [`Window::None`]).
//!
//! # Math
//!
//! A window scales every coefficient of band l by one factor σ_l (σ_0 = 1, so the mean
//! is kept); by the Funk–Hecke theorem this is a convolution with a zonal kernel, so it
//! commutes with rotation. Truncating a function with a discontinuity (a visibility
//! step, a sun) rings — Gibbs oscillations that make light or visibility negative;
//! tapering the high bands trades that for blur (Sloan 2008, "Stupid SH Tricks",
//! §Windowing).
//!
//! ```text
//! Hanning:  σ_l = (1 + cos(π l / w)) / 2   for l < w, else 0
//! Lanczos:  σ_l = sinc(π l / w) = sin(π l / w) / (π l / w)   for l < w, else 0
//! ```
//!
//! (both are 0 at l = w; the Lanczos window is cut there, its main lobe, since the
//! negative side lobes of sinc would flip bands). Larger w means a gentler window.
//!
//! # Deringing ([`Window::Deringing`])
//!
//! In the spirit of P.-P. Sloan, "Deringing Spherical Harmonics" (SIGGRAPH Asia 2017
//! Technical Briefs), which optimises per-band factors so that the reconstruction is
//! non-negative while staying close to the unwindowed one, we use a one-parameter
//! family: the taper's width w is chosen as the *largest* (gentlest) value for which
//! min_ω Σ_l σ_l(w) f_l(ω) ≥ 0. Procedure ([`deringing_width`]):
//!
//! 1. Reconstruct each band's contribution f_l(ω) = Σ_m c_l^m y_l^m(ω) once on a grid:
//!    the directions of [`sphere_quadrature`]`(2·order + 16)` plus the six axis
//!    directions.
//! 2. The minimum for given σ is the grid minimum, refined from the four lowest grid
//!    points by a pattern search on the sphere (steps halved down to 1e-9 rad), so that
//!    minima between grid points are found to ~1e-16 of the function's scale.
//! 3. If the unwindowed function is already non-negative, nothing is done. Otherwise w
//!    lies between 1 (σ_l = 0 for l ≥ 1: only the mean, non-negative when c_0 ≥ 0) and
//!    a width w_hi where the minimum is negative (starting at w = order, doubling).
//!    The minimum need not be monotonic in w, so 32 widths evenly spaced in [1, w_hi]
//!    are tried from the gentle end; the largest non-negative one and its negative
//!    neighbour are then bisected to a relative width of 1e-6, keeping the
//!    non-negative end.
//!
//! If the mean c_0 is negative no window can help; the strongest one (mean only) is
//! used. In practice the family is blunt: a hemisphere step at order 8 needs
//! w ≈ 2.55 (Hanning), keeping bands 0–2 — the price of one parameter, where Sloan's
//! per-band optimisation keeps more detail. For
//! RGB the smallest width over the channels is applied to all three, so hue is
//! filtered consistently.
//!
//! Tests: here (None is the identity, band factors, Hanning zeroes bands ≥ w, the mean
//! is kept) and `tests/sh_oracle.rs` (deringing a step function that rings negative).

use glam::DVec3;

use super::basis::eval_basis;
use super::project::{eval, sphere_quadrature};
use super::{Order, sh_index};

/// The shape of a window's band factors σ_l(w).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Taper {
    /// σ_l = (1 + cos(πl/w))/2 for l < w, else 0.
    Hanning,
    /// σ_l = sinc(πl/w) for l < w, else 0.
    Lanczos,
}

impl Taper {
    /// The factor σ_l for band `l` and width `w` (bands); σ_0 = 1 for every w. A width
    /// that is not positive (or NaN) keeps only band 0.
    pub fn sigma(self, l: u32, w: f64) -> f64 {
        if l == 0 {
            return 1.0;
        }
        let lf = l as f64;
        if w.is_nan() || lf >= w {
            return 0.0;
        }
        let x = std::f64::consts::PI * lf / w;
        match self {
            Taper::Hanning => 0.5 * (1.0 + x.cos()),
            Taper::Lanczos => x.sin() / x,
        }
    }
}

/// A per-band window applied to SH coefficients (module doc). The default is `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Window {
    /// No windowing: coefficients unchanged.
    #[default]
    None,
    /// Hanning window of width `w` bands.
    Hanning {
        /// Width in bands: bands l ≥ w are zeroed.
        w: f64,
    },
    /// Lanczos (sinc) window of width `w` bands.
    Lanczos {
        /// Width in bands: bands l ≥ w are zeroed.
        w: f64,
    },
    /// The gentlest `taper` window whose reconstruction is non-negative over the sphere,
    /// chosen per coefficient vector (module doc, [`deringing_width`]).
    Deringing {
        /// The family whose width is searched.
        taper: Taper,
    },
}

/// The band factors σ_0 … σ_{order−1} that [`apply`] uses for `coeffs` (the data
/// matter only for [`Window::Deringing`]; fixed windows accept an empty slice).
///
/// # Panics
/// For [`Window::Deringing`], if `coeffs` holds fewer than `order.coeff_count()` values.
pub fn band_factors(window: Window, coeffs: &[f64], order: Order) -> Vec<f64> {
    let n = order.get();
    match window {
        Window::None => vec![1.0; n as usize],
        Window::Hanning { w } => (0..n).map(|l| Taper::Hanning.sigma(l, w)).collect(),
        Window::Lanczos { w } => (0..n).map(|l| Taper::Lanczos.sigma(l, w)).collect(),
        Window::Deringing { taper } => match deringing_width(taper, coeffs, order) {
            Some(w) => (0..n).map(|l| taper.sigma(l, w)).collect(),
            None => vec![1.0; n as usize],
        },
    }
}

/// Applies `window` to `coeffs` (bands l < `order`) in place: c_l^m ← σ_l c_l^m.
///
/// # Panics
/// If `coeffs` holds fewer than `order.coeff_count()` values.
pub fn apply(window: Window, coeffs: &mut [f64], order: Order) {
    check_len(coeffs.len(), order);
    if window == Window::None {
        return;
    }
    let sigma = band_factors(window, coeffs, order);
    scale_bands(&sigma, coeffs);
}

/// RGB variant of [`apply`]; [`Window::Deringing`] uses the smallest width over the
/// three channels for all of them.
///
/// # Panics
/// If `coeffs` holds fewer than `order.coeff_count()` values.
pub fn apply_rgb(window: Window, coeffs: &mut [[f64; 3]], order: Order) {
    check_len(coeffs.len(), order);
    let sigma = match window {
        Window::None => return,
        Window::Deringing { taper } => {
            let w = (0..3)
                .filter_map(|ch| {
                    let channel: Vec<f64> = coeffs.iter().map(|c| c[ch]).collect();
                    deringing_width(taper, &channel, order)
                })
                .reduce(f64::min);
            match w {
                Some(w) => (0..order.get()).map(|l| taper.sigma(l, w)).collect(),
                None => return,
            }
        }
        fixed => band_factors(fixed, &[], order),
    };
    for l in 0..order.get() as i32 {
        for m in -l..=l {
            for c in &mut coeffs[sh_index(l, m)] {
                *c *= sigma[l as usize];
            }
        }
    }
}

fn check_len(len: usize, order: Order) {
    assert!(
        len >= order.coeff_count(),
        "{len} coefficients given, order {order} needs {}",
        order.coeff_count()
    );
}

fn scale_bands(sigma: &[f64], coeffs: &mut [f64]) {
    for (l, s) in sigma.iter().enumerate() {
        let l = l as i32;
        for c in &mut coeffs[sh_index(l, -l)..=sh_index(l, l)] {
            *c *= s;
        }
    }
}

/// Relative width at which the bisection of [`deringing_width`] stops.
const BISECTION_REL: f64 = 1e-6;
/// Smallest pattern-search step (radians) when refining a grid minimum.
const REFINE_MIN_STEP: f64 = 1e-9;
/// Grid minima refined per evaluation.
const REFINE_STARTS: usize = 4;
/// Widths sampled before the bisection (step 3 of the module doc).
const DERINGING_SCAN: usize = 32;

/// The width w of the gentlest `taper` window whose reconstruction of `coeffs` is
/// non-negative over the sphere (module doc), or `None` when the unwindowed
/// reconstruction already is. Returns 1.0 (mean only) when c_0 < 0.
///
/// # Panics
/// If `coeffs` holds fewer than `order.coeff_count()` values.
pub fn deringing_width(taper: Taper, coeffs: &[f64], order: Order) -> Option<f64> {
    check_len(coeffs.len(), order);
    let coeffs = &coeffs[..order.coeff_count()];
    let grid = band_grid(coeffs, order, &deringing_grid(order));
    let windowed_min = |sigma: &[f64]| -> f64 {
        let mut lowest: Vec<(f64, DVec3)> = grid
            .iter()
            .map(|(d, bands)| (bands.iter().zip(sigma).map(|(b, s)| b * s).sum(), *d))
            .collect();
        let k = REFINE_STARTS.min(lowest.len());
        lowest.select_nth_unstable_by(k.saturating_sub(1), |a, b| a.0.total_cmp(&b.0));
        let mut windowed = coeffs.to_vec();
        scale_bands(sigma, &mut windowed);
        lowest[..k]
            .iter()
            .map(|&(v, d)| refine_minimum(&windowed, order, d, v))
            .fold(f64::INFINITY, f64::min)
    };
    let width = search_width(taper, order, windowed_min, BISECTION_REL);
    if width == Some(1.0) && coeffs[0] < 0.0 {
        log::warn!("SH deringing: negative mean, no window makes the function non-negative");
    }
    width
}

/// [`deringing_width`] with the minimum taken over `dirs` only (no refinement between
/// them) and the bisection stopped at relative width `rel`: for many small vectors (a
/// lightmap's texels), where a dense fixed grid is accurate enough and the exact search
/// too slow. Dips between grid points may stay slightly negative. Silent where no window
/// helps (a negative mean: the strongest window, 1.0, is returned).
///
/// # Panics
/// If `coeffs` holds fewer than `order.coeff_count()` values.
pub fn deringing_width_on_grid(
    taper: Taper,
    coeffs: &[f64],
    order: Order,
    dirs: &[DVec3],
    rel: f64,
) -> Option<f64> {
    check_len(coeffs.len(), order);
    let grid = band_grid(&coeffs[..order.coeff_count()], order, dirs);
    let windowed_min = |sigma: &[f64]| -> f64 {
        grid.iter()
            .map(|(_, bands)| bands.iter().zip(sigma).map(|(b, s)| b * s).sum::<f64>())
            .fold(f64::INFINITY, f64::min)
    };
    search_width(taper, order, windowed_min, rel)
}

/// Steps 3 of the module doc: the gentlest width whose `windowed_min` is non-negative.
fn search_width(
    taper: Taper,
    order: Order,
    windowed_min: impl Fn(&[f64]) -> f64,
    rel: f64,
) -> Option<f64> {
    let n = order.get() as usize;
    let sigma_at = |w: f64| -> Vec<f64> { (0..n as u32).map(|l| taper.sigma(l, w)).collect() };
    if windowed_min(&vec![1.0; n]) >= 0.0 {
        return None;
    }
    let mut lo = 1.0; // mean only
    if windowed_min(&sigma_at(lo)) < 0.0 {
        return Some(lo);
    }
    // A width whose reconstruction is negative: σ → 1 as w → ∞, so doubling finds one.
    let mut hi = (n as f64).max(2.0);
    let mut doublings = 0;
    while windowed_min(&sigma_at(hi)) >= 0.0 {
        doublings += 1;
        if doublings > 64 {
            return Some(hi);
        }
        hi *= 2.0;
    }
    // Coarse scan from the gentle end: the largest non-negative sample and its negative
    // neighbour bracket the gentlest crossing even if the minimum is not monotonic in w.
    let span = hi - lo;
    let mut upper = hi;
    for k in (0..DERINGING_SCAN).rev() {
        let w = lo + span * k as f64 / DERINGING_SCAN as f64;
        if windowed_min(&sigma_at(w)) >= 0.0 {
            (lo, hi) = (w, upper);
            break;
        }
        upper = w;
    }
    while hi - lo > rel * hi {
        let mid = 0.5 * (lo + hi);
        if windowed_min(&sigma_at(mid)) >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

/// The directions of the exact search's grid (module doc, step 1).
fn deringing_grid(order: Order) -> Vec<DVec3> {
    let n = order.get() as usize;
    let mut dirs: Vec<DVec3> = sphere_quadrature(2 * n + 16)
        .into_iter()
        .map(|(d, _)| d)
        .collect();
    dirs.extend([
        DVec3::X,
        DVec3::NEG_X,
        DVec3::Y,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ]);
    dirs
}

/// Per-band reconstructions f_l(ω) on the deringing grid (module doc, step 1).
fn band_grid(coeffs: &[f64], order: Order, dirs: &[DVec3]) -> Vec<(DVec3, Vec<f64>)> {
    let n = order.get() as usize;
    let mut y = vec![0.0; order.coeff_count()];
    dirs.iter()
        .map(|&d| {
            eval_basis(order, d, &mut y);
            let bands = (0..n as i32)
                .map(|l| {
                    let r = sh_index(l, -l)..=sh_index(l, l);
                    coeffs[r.clone()]
                        .iter()
                        .zip(&y[r])
                        .map(|(c, y)| c * y)
                        .sum()
                })
                .collect();
            (d, bands)
        })
        .collect()
}

/// Pattern search for a local minimum of Σ c_i y_i(ω) near `start` (module doc, step 2).
fn refine_minimum(coeffs: &[f64], order: Order, start: DVec3, start_value: f64) -> f64 {
    let (mut d, mut best) = (start, start_value);
    let mut step = std::f64::consts::PI / (2 * order.get() as usize + 16) as f64;
    while step > REFINE_MIN_STEP {
        let (t1, t2) = d.any_orthonormal_pair();
        let mut moved = false;
        for t in [t1, -t1, t2, -t2, t1 + t2, -t1 - t2, t1 - t2, t2 - t1] {
            let cand = (d + step * t).normalize();
            let v = eval(coeffs, order, cand);
            if v < best {
                (d, best, moved) = (cand, v, true);
                break;
            }
        }
        if !moved {
            step *= 0.5;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Products of a factor with a coefficient: one rounding.
    const ONE_ROUNDING: f64 = 1e-15;

    fn sample(order: Order) -> Vec<f64> {
        (0..order.coeff_count())
            .map(|i| ((i * 7 + 3) as f64).sin())
            .collect()
    }

    #[test]
    fn none_is_identity_and_default() {
        let order = Order::SIX;
        let c = sample(order);
        let mut w = c.clone();
        apply(Window::default(), &mut w, order);
        assert_eq!(w, c);
        let mut rgb: Vec<[f64; 3]> = c.iter().map(|v| [*v, 2.0 * v, -v]).collect();
        let before = rgb.clone();
        apply_rgb(Window::None, &mut rgb, order);
        assert_eq!(rgb, before);
    }

    #[test]
    fn hanning_and_lanczos_factors() {
        let h = band_factors(
            Window::Hanning { w: 4.0 },
            &[],
            Order::new(1).expect("valid"),
        );
        assert_eq!(h, vec![1.0]);
        let order = Order::SIX;
        let h = band_factors(Window::Hanning { w: 4.0 }, &sample(order), order);
        let want = [1.0, (1.0 + (std::f64::consts::PI / 4.0).cos()) / 2.0, 0.5];
        for (a, b) in h.iter().zip(&want) {
            assert!((a - b).abs() < ONE_ROUNDING, "{h:?}");
        }
        assert_eq!(&h[4..], &[0.0, 0.0]);
        let lz = band_factors(Window::Lanczos { w: 6.0 }, &sample(order), order);
        let x = std::f64::consts::PI / 2.0; // l = 3
        assert!(
            (lz[3] - x.sin() / x).abs() < ONE_ROUNDING && lz[0] == 1.0,
            "{lz:?}"
        );
        assert!(Taper::Hanning.sigma(2, f64::NAN) == 0.0 && Taper::Lanczos.sigma(0, -1.0) == 1.0);
    }

    #[test]
    fn hanning_zeroes_high_bands_and_keeps_mean_rgb() {
        let order = Order::SIX;
        let mut rgb: Vec<[f64; 3]> = sample(order).iter().map(|v| [*v, 2.0 * v, -v]).collect();
        let c0 = rgb[0];
        apply_rgb(Window::Hanning { w: 3.0 }, &mut rgb, order);
        assert_eq!(rgb[0], c0);
        assert!(rgb[sh_index(3, 0)..].iter().all(|c| *c == [0.0; 3]));
    }

    #[test]
    fn deringing_leaves_non_negative_functions_alone() {
        let order = Order::FOUR;
        let mut c = vec![0.0; order.coeff_count()];
        c[0] = 1.0;
        c[sh_index(1, 0)] = 0.1; // 1/(2√π) + 0.1·√(3/4π) z > 0
        assert_eq!(deringing_width(Taper::Hanning, &c, order), None);
        let before = c.clone();
        apply(
            Window::Deringing {
                taper: Taper::Lanczos,
            },
            &mut c,
            order,
        );
        assert_eq!(c, before);
    }
}
