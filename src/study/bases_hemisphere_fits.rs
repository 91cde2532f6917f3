//! The rows of `shvis study bases`' hemisphere table: which bases, how each is fitted from a
//! floor texel's radiance samples, and how it reconstructs irradiance (and radiance, where it
//! stores it) at a tangent-space normal. The measurement, its equations and the texel's frame
//! are [`super::bases_hemisphere`]'s module doc; the numbers (3) below refer to it.
//!
//! SH of orders 2…5 (L1…L4) are the samples' world-space projection (3); the engine bases
//! of `sh::bases` encode its order-3 part (their L1 linear and L2 are the rows L1 and L2);
//! the H-basis, Ambient Dice, the ambient cube and the spherical Gaussians (every lobe count
//! of `sh::sg::LOBE_COUNTS`, every solver) are [`SampleFit::fit`] of the samples.

use std::sync::Arc;

use glam::DVec3;

use crate::sh::Order;
use crate::sh::ambient_cube::{self, CubeFit, FACES};
use crate::sh::bases::ShBasis;
use crate::sh::dice::{self, DiceVariant};
use crate::sh::hbasis::{self, HBasisSize};
use crate::sh::samples::{Sample, SampleFit, project_sh};
use crate::sh::sg::{self, LOBE_COUNTS, SgBasis, Solver};
use crate::sh::zonal;
use crate::technique::hemisphere::sg_irradiance;

/// The floor texel's tangent frame in world space: tangent +X, bitangent −Z, normal +Y.
pub const FRAME: [DVec3; 3] = [DVec3::X, DVec3::NEG_Z, DVec3::Y];

/// Highest SH order fitted: L4.
pub const MAX_SH_ORDER: u32 = 5;

/// The engine bases of the table; `ShBasis::L1` and `ShBasis::L2` are the rows L1 and L2.
pub const ENGINE_BASES: [ShBasis; 5] = [
    ShBasis::L1Geomerics,
    ShBasis::L1Zh3Hallucinated,
    ShBasis::Zh3,
    ShBasis::L1Luminance,
    ShBasis::L2Deringed,
];

/// The families of bases, in table order: a row's `family` in
/// [`super::bases_hemisphere::HemisphereRow`].
pub const FAMILIES: [&str; 6] = [
    "SH",
    "SH engine",
    "H-basis",
    "Ambient Dice",
    "ambient cube",
    "SG",
];

/// Tangent-space `m` in world space.
pub fn to_world(m: DVec3) -> DVec3 {
    FRAME[0] * m.x + FRAME[1] * m.y + FRAME[2] * m.z
}

/// World `d` in the floor's tangent space (T is orthonormal: Tᵀ d).
pub fn to_tangent(d: DVec3) -> DVec3 {
    DVec3::new(d.dot(FRAME[0]), d.dot(FRAME[1]), d.dot(FRAME[2]))
}

/// A row of the table: which basis, fitted how.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Spec {
    /// SH of this order (3).
    Sh(u32),
    /// An engine basis from the order-3 SH of (3).
    Engine(ShBasis),
    /// A fit of the samples.
    Fit(SampleFit),
}

/// Every row, in table order.
pub(crate) fn specs() -> Vec<Spec> {
    let mut specs: Vec<Spec> = (2..=MAX_SH_ORDER).map(Spec::Sh).collect();
    specs.extend(ENGINE_BASES.map(Spec::Engine));
    specs.extend([HBasisSize::H4, HBasisSize::H6].map(|s| Spec::Fit(SampleFit::HBasis(s))));
    specs.extend(DiceVariant::ALL.map(|v| Spec::Fit(SampleFit::Dice(v))));
    specs.extend(CubeFit::ALL.map(|f| Spec::Fit(SampleFit::AmbientCube(f))));
    for lobes in LOBE_COUNTS {
        for solver in Solver::ALL {
            specs.push(Spec::Fit(SampleFit::Sg {
                lobes: lobes as u32,
                solver,
            }));
        }
    }
    specs
}

impl Spec {
    /// Its name in the tables.
    pub(crate) fn label(self) -> String {
        match self {
            Spec::Sh(order) => format!("L{}", order - 1),
            Spec::Engine(basis) => basis.label().to_string(),
            Spec::Fit(fit) => match fit {
                SampleFit::HBasis(HBasisSize::H4) => "H4".to_string(),
                SampleFit::HBasis(HBasisSize::H6) => "H6".to_string(),
                SampleFit::Dice(DiceVariant::Rgb) => "Dice".to_string(),
                SampleFit::Dice(DiceVariant::YCoCg) => "Dice YCoCg".to_string(),
                SampleFit::AmbientCube(CubeFit::Projection) => "cube projection".to_string(),
                SampleFit::AmbientCube(CubeFit::LeastSquares) => "cube least squares".to_string(),
                SampleFit::Sg { lobes, solver } => format!("SG{lobes} {solver}"),
            },
        }
    }

    /// Its entry of [`FAMILIES`].
    pub(crate) fn family(self) -> &'static str {
        FAMILIES[match self {
            Spec::Sh(_) => 0,
            Spec::Engine(_) => 1,
            Spec::Fit(SampleFit::HBasis(_)) => 2,
            Spec::Fit(SampleFit::Dice(_)) => 3,
            Spec::Fit(SampleFit::AmbientCube(_)) => 4,
            Spec::Fit(SampleFit::Sg { .. }) => 5,
        }]
    }

    /// Values stored per texel (RGB counted three times).
    pub(crate) fn values(self) -> usize {
        match self {
            Spec::Sh(order) => 3 * (order * order) as usize,
            Spec::Engine(basis) => basis.stored_values(),
            Spec::Fit(fit) => fit.stored_values(),
        }
    }
}

/// A basis fitted from one source, ready to reconstruct at tangent-space normals.
pub(crate) enum Fitted {
    /// (3): radiance and irradiance coefficients, world space.
    Sh {
        order: Order,
        radiance: Vec<[f64; 3]>,
        irradiance: Vec<[f64; 3]>,
    },
    Engine {
        basis: ShBasis,
        stored: Vec<f64>,
    },
    HBasis(Vec<[f64; 3]>),
    Dice {
        variant: DiceVariant,
        stored: Vec<f64>,
    },
    Cube([[f64; 3]; FACES]),
    Sg {
        basis: Arc<SgBasis>,
        amplitudes: Vec<[f64; 3]>,
    },
}

impl Fitted {
    /// Irradiance (RGB, not clamped) at tangent-space `m`.
    pub(crate) fn irradiance(&self, m: DVec3) -> [f64; 3] {
        match self {
            Fitted::Sh {
                order, irradiance, ..
            } => zonal::eval_rgb(irradiance, *order, to_world(m)),
            Fitted::Engine { basis, stored } => basis.irradiance(stored, to_world(m)),
            Fitted::HBasis(h) => hbasis::irradiance(h, m),
            Fitted::Dice { variant, stored } => dice::dice().irradiance(*variant, stored, m),
            Fitted::Cube(c) => ambient_cube::irradiance(c, m),
            Fitted::Sg { basis, amplitudes } => sg_irradiance(basis, amplitudes, m),
        }
    }

    /// Radiance (RGB, not clamped) at tangent-space `m`, for the bases that store it.
    pub(crate) fn radiance(&self, m: DVec3) -> Option<[f64; 3]> {
        match self {
            Fitted::Sh {
                order, radiance, ..
            } => Some(zonal::eval_rgb(radiance, *order, to_world(m))),
            Fitted::Sg { basis, amplitudes } => {
                let mut l = [0.0; 3];
                for (&mu, a) in basis.axes.iter().zip(amplitudes) {
                    let g = sg::lobe(mu, basis.sharpness, m);
                    for c in 0..3 {
                        l[c] += a[c] * g;
                    }
                }
                Some(l)
            }
            Fitted::Engine { .. } | Fitted::HBasis(_) | Fitted::Dice { .. } | Fitted::Cube(_) => {
                None
            }
        }
    }
}

/// `spec` fitted from `samples` (tangent space) whose world-space SH (3) of order
/// [`MAX_SH_ORDER`] is `sh`; for SG the share of negative amplitudes.
pub(crate) fn fit(spec: Spec, samples: &[Sample], sh: &[[f64; 3]]) -> (Fitted, Option<f64>) {
    let triples =
        |v: &[f64]| -> Vec<[f64; 3]> { v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect() };
    match spec {
        Spec::Sh(n) => {
            let order = Order::new(n).expect("SH orders 2 to 5 are valid");
            // A projection's coefficients do not depend on where it is truncated.
            let radiance = sh[..order.coeff_count()].to_vec();
            let irradiance = zonal::irradiance_from_radiance(&radiance, order);
            let fitted = Fitted::Sh {
                order,
                radiance,
                irradiance,
            };
            (fitted, None)
        }
        Spec::Engine(basis) => {
            let stored = basis.encode(&sh[..Order::THREE.coeff_count()], Some(FRAME[2]));
            (Fitted::Engine { basis, stored }, None)
        }
        Spec::Fit(fit) => {
            let (values, stats) = fit.fit(samples);
            let fitted = match fit {
                SampleFit::HBasis(_) => Fitted::HBasis(triples(&values)),
                SampleFit::Dice(variant) => Fitted::Dice {
                    variant,
                    stored: values,
                },
                SampleFit::AmbientCube(_) => {
                    let faces = triples(&values);
                    Fitted::Cube(std::array::from_fn(|f| faces[f]))
                }
                SampleFit::Sg { lobes, .. } => Fitted::Sg {
                    basis: sg::shared_basis(lobes as usize),
                    amplitudes: triples(&values),
                },
            };
            let negative = matches!(fit, SampleFit::Sg { .. })
                .then(|| stats.negative as f64 / stats.amplitudes.max(1) as f64);
            (fitted, negative)
        }
    }
}

/// Builds what the fits share (the kernel tables of `sh::samples`, the lobe bases) before a
/// parallel loop asks for it, so that no fit in the loop waits on a build.
pub(crate) fn warm_up() {
    for spec in specs() {
        if let Spec::Fit(fit) = spec {
            let _ = fit.fit(&[]);
        }
    }
}

/// The world-space SH (3) of order [`MAX_SH_ORDER`] of tangent-space `samples`; every lower
/// order is its leading part.
pub(crate) fn world_sh(samples: &[Sample]) -> Vec<[f64; 3]> {
    let world: Vec<Sample> = samples
        .iter()
        .map(|s| Sample {
            dir: to_world(s.dir),
            ..*s
        })
        .collect();
    project_sh(
        &world,
        Order::new(MAX_SH_ORDER).expect("L4's order is valid"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_store_what_their_bases_store() {
        let values = |label: &str| {
            specs()
                .into_iter()
                .find(|s| s.label() == label)
                .map(Spec::values)
        };
        assert_eq!(values("L1"), Some(12));
        assert_eq!(values("L4"), Some(75));
        assert_eq!(values("ZH3 stored"), Some(15));
        assert_eq!(values("Dice YCoCg"), Some(50));
        assert_eq!(values("cube least squares"), Some(18));
        assert_eq!(values("SG9 ls"), Some(27));
        let labels: Vec<String> = specs().into_iter().map(Spec::label).collect();
        for (i, label) in labels.iter().enumerate() {
            assert!(!labels[..i].contains(label), "{label} twice");
        }
    }

    #[test]
    fn the_frame_maps_tangent_space_to_world_and_back() {
        for d in [DVec3::new(0.3, 0.5, -0.2).normalize(), DVec3::Y, DVec3::X] {
            assert!((to_world(to_tangent(d)) - d).length() < 1e-15, "{d}");
        }
        assert_eq!(to_world(DVec3::Z), DVec3::Y);
        assert_eq!(to_world(DVec3::X), DVec3::X);
        assert_eq!(to_world(DVec3::Y), DVec3::NEG_Z);
    }
}
