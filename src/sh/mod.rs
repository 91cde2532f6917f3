//! Real spherical harmonics (SH): conventions, band bookkeeping and the math shared by
//! the bake, the lighting prep and the shaders.
//!
//! # Convention (DESIGN §1)
//!
//! Real SH in the graphics convention of Sloan's "Stupid Spherical Harmonics (SH)
//! Tricks" (2008) and DirectXMath (`XMSHEvalDirection`), Condon–Shortley phase
//! included (Iwanicki–Sloan eqs. (1)–(3)):
//!
//! ```text
//! y_l^m = √2 K_l^|m| P_l^|m|(cos θ) cos(mφ)    m > 0
//! y_l^m = √2 K_l^|m| P_l^|m|(cos θ) sin(|m|φ)  m < 0
//! y_l^0 =    K_l^0   P_l^0(cos θ)
//! K_l^m = √((2l+1)(l−m)! / (4π (l+m)!))
//! ```
//!
//! with θ measured from +z and φ from +x towards +y, so that
//! y_0^0 = 1/(2√π), y_1^-1 = −√(3/4π)·y, y_1^0 = √(3/4π)·z, y_1^1 = −√(3/4π)·x.
//! The basis is orthonormal over the unit sphere. Coefficient (l, m) lives at the flat
//! index `i = l(l+1)+m` ([`sh_index`]). "Order n" ([`Order`]) means bands l < n, i.e.
//! n² coefficients (order 3 = 9, order 4 = 16, order 6 = 36).
//!
//! Note that the SH polar axis is +z while the equirectangular env maps of
//! [`crate::env`] use +y as their pole (DESIGN §1); nothing here depends on the map.
//!
//! # Contents
//!
//! - [`bases`]: the lightmap bases engines ship (L1, Geomerics, ZH3, luminance L1,
//!   deringed L2) as encodings of order-3 radiance and their irradiance.
//! - [`sg`]: spherical Gaussian lightmap lobes, their fitting solvers and diffuse evaluation.
//! - [`hbasis`]: the H-basis over a tangent frame's hemisphere (Habel & Wimmer 2010).
//! - [`dice`]: Ambient Dice over a tangent frame's hemisphere (Iwanicki & Sloan 2017).
//! - [`basis`]: evaluation of all y_l^m at a direction, stable to order 30, exact at
//!   the poles.
//! - [`zonal`]: the clamped cosine max(0, cos θ) in SH, its convolution factors and
//!   radiance → irradiance.
//! - [`product`]: the real Gaunt (triple-product) tensor and the product matrix of
//!   Iwanicki–Sloan §3.3.
//! - [`rotate`]: rotation of coefficients of any order (Ivanic–Ruedenberg recurrence).
//! - [`window`]: per-band windowing against ringing (Hanning, Lanczos, deringing).
//! - [`project`]: projection of a function by an exact sphere quadrature, and
//!   reconstruction.
//! - [`gauss_legendre`]: quadrature nodes used by projections and tests.

pub mod ambient_cube;
pub mod bases;
pub mod basis;
pub mod dice;
pub mod hbasis;
pub mod product;
pub mod project;
pub mod rotate;
pub mod samples;
pub mod sg;
pub mod window;
pub mod zonal;

/// Highest SH order accepted by [`Order::new`]: the recurrences of [`basis`] are tested
/// to this order (bands l ≤ 29, 900 coefficients).
pub const MAX_ORDER: u32 = 30;

/// Errors of the SH layer; each message is one line naming the bad input.
#[derive(Debug, thiserror::Error)]
pub enum ShError {
    /// An SH order outside 1..=[`MAX_ORDER`].
    #[error("SH order {0} is out of range (expected 1..={MAX_ORDER})")]
    OrderOutOfRange(u32),
    /// A direction that cannot be normalised.
    #[error("direction ({x}, {y}, {z}) is zero-length or not finite")]
    BadDirection {
        /// x component as given.
        x: f64,
        /// y component as given.
        y: f64,
        /// z component as given.
        z: f64,
    },
}

/// An SH order n: bands l < n, n² coefficients (DESIGN §1). Always in 1..=[`MAX_ORDER`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Order(u32);

impl Order {
    /// Order 1 (1 coefficient): a constant.
    pub const ONE: Order = Order(1);
    /// Order 2 (4 coefficients): `sh2` visibility.
    pub const TWO: Order = Order(2);
    /// Order 3 (9 coefficients): irradiance, `preconv`, `sh2` lighting.
    pub const THREE: Order = Order(3);
    /// Order 4 (16 coefficients).
    pub const FOUR: Order = Order(4);
    /// Order 6 (36 coefficients): the paper's visibility order.
    pub const SIX: Order = Order(6);
    /// Order 8 (64 coefficients): the lighting of order-6 visibility's L×H product.
    pub const EIGHT: Order = Order(8);

    /// Validates a user-supplied order.
    ///
    /// # Errors
    /// [`ShError::OrderOutOfRange`] unless 1 ≤ `n` ≤ [`MAX_ORDER`].
    pub fn new(n: u32) -> Result<Order, ShError> {
        if (1..=MAX_ORDER).contains(&n) {
            Ok(Order(n))
        } else {
            Err(ShError::OrderOutOfRange(n))
        }
    }

    /// The order n (number of bands).
    pub const fn get(self) -> u32 {
        self.0
    }

    /// Number of coefficients, n².
    pub const fn coeff_count(self) -> usize {
        (self.0 * self.0) as usize
    }
}

impl std::fmt::Display for Order {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Flat index of coefficient (l, m): `l(l+1)+m`. Requires l ≥ 0 and |m| ≤ l
/// (debug-checked).
pub const fn sh_index(l: i32, m: i32) -> usize {
    debug_assert!(l >= 0 && m >= -l && m <= l);
    (l * (l + 1) + m) as usize
}

/// Normalises a user-supplied direction.
///
/// # Errors
/// [`ShError::BadDirection`] if `dir` is zero-length or has a NaN/infinite component.
pub fn unit_dir(dir: glam::DVec3) -> Result<glam::DVec3, ShError> {
    dir.try_normalize().ok_or(ShError::BadDirection {
        x: dir.x,
        y: dir.y,
        z: dir.z,
    })
}

/// Gauss–Legendre rule with `n` nodes on [−1, 1]: `(nodes, weights)`, nodes ascending.
///
/// Exact for polynomials of degree ≤ 2n−1. Nodes by Newton iteration on Bonnet's
/// recurrence (n+1)P_{n+1} = (2n+1)xP_n − nP_{n−1}, started from the Tricomi
/// approximation; weights 2/((1−x²)P_n'(x)²). Accurate to a few ulps for n ≤ 1000.
/// `n = 0` gives empty vectors.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    use std::f64::consts::PI;
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    let nf = n as f64;
    for i in 0..n.div_ceil(2) {
        // i-th largest root, Tricomi's initial guess.
        let mut x =
            (PI * (i as f64 + 0.75) / (nf + 0.5)).cos() * (1.0 - (nf - 1.0) / (8.0 * nf * nf * nf));
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, x);
        dp = if d.is_finite() { d } else { dp };
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[n - 1 - i] = x;
        nodes[i] = -x;
        weights[n - 1 - i] = w;
        weights[i] = w;
    }
    (nodes, weights)
}

/// P_n(x) and P_n'(x) by Bonnet's recurrence (|x| < 1).
fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sums of a few dozen O(1) terms in f64.
    const QUADRATURE: f64 = 1e-13;

    #[test]
    fn order_bounds_and_counts() {
        assert!(Order::new(0).is_err());
        assert!(Order::new(MAX_ORDER + 1).is_err());
        let o = Order::new(6).expect("6 is valid");
        assert_eq!((o.get(), o.coeff_count()), (6, 36));
        assert_eq!(
            Order::new(MAX_ORDER).map(Order::coeff_count).ok(),
            Some(900)
        );
        assert_eq!(Order::THREE.coeff_count(), 9);
    }

    #[test]
    fn flat_index_is_l_l_plus_1_plus_m() {
        assert_eq!(sh_index(0, 0), 0);
        assert_eq!(sh_index(1, -1), 1);
        assert_eq!(sh_index(1, 1), 3);
        assert_eq!(sh_index(2, -2), 4);
        assert_eq!(sh_index(5, 5), 35);
    }

    #[test]
    fn error_messages_are_one_line() {
        let e = Order::new(31).unwrap_err().to_string();
        assert!(e.contains("31") && !e.contains('\n'), "{e}");
        let e = unit_dir(glam::DVec3::ZERO).unwrap_err().to_string();
        assert!(e.contains("zero-length") && !e.contains('\n'), "{e}");
        assert!(unit_dir(glam::DVec3::new(f64::NAN, 0.0, 1.0)).is_err());
    }

    #[test]
    fn gauss_legendre_integrates_monomials() {
        for n in [1, 2, 3, 8, 17, 64] {
            let (x, w) = gauss_legendre(n);
            for k in 0..2 * n {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                let exact = if k % 2 == 1 {
                    0.0
                } else {
                    2.0 / (k as f64 + 1.0)
                };
                assert!(
                    (q - exact).abs() < QUADRATURE,
                    "n={n} k={k}: {q} vs {exact}"
                );
            }
        }
    }
}
