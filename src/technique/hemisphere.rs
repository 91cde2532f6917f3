//! The hemisphere lightmap bases, from `shlmap`'s bake, over each texel's tangent-frame
//! hemisphere and read at the normal map's tangent-space normal m (no frame, no SH per
//! pixel); the lighting is baked in. Each is fitted from the texel's radiance samples — the
//! bake's rays, `crate::sh::samples`, the default — or, with `--basis-fit l2`, from the
//! texel's order-3 SH read through its frame at the fit's nodes. Values per texel (RGB, value 3i + c) are range-scaled
//! into f16 as `shlmap`'s are and packed 4 per RGBA16F texel.
//!
//! - `hb4`, `hb6`: the H-basis (Habel & Wimmer 2010; `crate::sh::hbasis`, whose module doc
//!   has the functions and the projection): the H coefficients of the irradiance over the
//!   hemisphere, 12 values in 3 groups (24 bytes) / 18 in 5 (40 bytes); the shader
//!   (`glsl/technique/hbasis.frag`, `glsl/include/hbasis.glsl`) evaluates Σ h_i H_i(m).
//! - `sgN`: N spherical Gaussians (`crate::sh::sg`): per texel the RGB amplitudes fitted to
//!   the texel's incident radiance over its hemisphere by the run's solver, 3N values in ⌈3N/4⌉ groups (sg9: 27
//!   values, 7 groups, 56 bytes); the lobes' axes and sharpness go in the uniform block and
//!   the shader (`glsl/technique/sg.frag`, `glsl/include/sg.glsl`) sums Hill's fitted
//!   SG–cosine integral of each lobe at m.
//! - `dice`, `dicey`: Ambient Dice (`crate::sh::dice`): the least-squares fit of the
//!   texel's irradiance over its hemisphere at the ten vertices that cover it — RGB value
//!   and two derivatives per vertex (90 values, 23 groups, 184 bytes) or Y, its derivatives,
//!   Co and Cg (50 values, 13 groups, 104 bytes). The shader (`glsl/technique/dice.frag`,
//!   `glsl/include/dice.glsl`) finds m's face from the face table in the uniform block
//!   ([`dice_face_table`]) and reads only that face's three vertices — 9 or 6 group reads
//!   at computed indices: array layers on dx10, atlas tiles on dx9
//!   (`texels::TexelGroups::with_dx9_atlas`).

use rayon::prelude::*;

use super::lighting::Recipe;
use std::sync::Arc;

use super::block::{BlockCodec, NormColours};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::spec::{BakeNeeds, HwPath, ReferenceModel};
use super::texels::{TexelGroups, VALUES_PER_TEXEL};
use super::{Inputs, ShaderVariant, TechniqueError};
use super::{PerTexelTaps, ShaderReads, Technique};
use crate::bake::shlmap::ShLightmap;
use crate::gpu::Context;
use crate::sh::dice::{self, DiceVariant};
use crate::sh::hbasis::{self, HBasisSize};
use crate::sh::samples::{BasisFit, SampleFit};
use crate::sh::sg::{FitStats, SgBasis, Solver};

/// Largest lobe count (the uniform block's array).
pub const SG_MAX_LOBES: usize = 12;

/// Uniforms of glsl/technique/sg.frag, block `SgParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SgParams {
    /// x: factor undoing the f16 range scaling.
    pub unscale: [f32; 4],
    /// Lobe axes (tangent space) in .xyz, sharpness in .w.
    pub lobes: [[f32; 4]; SG_MAX_LOBES],
}
crate::gpu::layout::glsl_block!(SgParams = "SgParams" { unscale, lobes });

/// vec4s per face in [`dice_face_table`].
pub const DICE_FACE_VEC4S: usize = 7;

/// Largest face count of the table (the uniform block's array; `dice` uses 12).
pub const DICE_MAX_FACES: usize = 12;

/// Uniforms of glsl/technique/dice.frag, block `DiceParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DiceParams {
    /// x: factor undoing the f16 range scaling.
    pub unscale: [f32; 4],
    /// x, y: the dx9 atlas' columns and rows of tiles.
    pub atlas: [f32; 4],
    /// [`dice_face_table`], a face per entry.
    pub faces: [[[f32; 4]; DICE_FACE_VEC4S]; DICE_MAX_FACES],
}
crate::gpu::layout::glsl_block!(DiceParams = "DiceParams" { unscale, atlas, faces });

/// The faces for the shader, 7 vec4s each: the centre (xyz); per vertex i its dual vector
/// (xyz; barycentric λ_i = dual_i · m) with the stored vertex's index in w; per vertex i
/// the edge factors (t_u,i·v_j, t_v,i·v_j) toward its two others j in increasing order
/// (xy, zw) — `sh::dice`'s (1).
pub fn dice_face_table() -> Vec<[f32; 4]> {
    let mut out = Vec::new();
    for face in &dice::dice().faces {
        let c = face.centre.as_vec3();
        out.push([c.x, c.y, c.z, 0.0]);
        for (i, d) in face.dual.iter().enumerate() {
            let d = d.as_vec3();
            out.push([d.x, d.y, d.z, face.vertices[i] as f32]);
        }
        for i in 0..3 {
            let others: Vec<usize> = (0..3).filter(|&j| j != i).collect();
            let (a, b) = (face.edge[i][others[0]], face.edge[i][others[1]]);
            out.push([a[0], a[1], b[0], b[1]].map(|v| v as f32));
        }
    }
    out
}

/// Values per texel of `basis` (RGB counted three times).
pub fn stored_values(basis: HemisphereBasis) -> usize {
    match basis {
        HemisphereBasis::HBasis(size) => 3 * size.count(),
        HemisphereBasis::Sg { lobes } => 3 * lobes as usize,
        HemisphereBasis::Dice(variant) => variant.stored_values(),
    }
}

/// Per-texel group reads per pixel where the shader picks its groups (Ambient Dice: three
/// vertices of 9 or 5 values, each spanning 3 or 2 groups whatever its offset); `None`:
/// every group once.
pub fn group_reads(basis: HemisphereBasis) -> Option<u32> {
    match basis {
        HemisphereBasis::HBasis(_) | HemisphereBasis::Sg { .. } => None,
        HemisphereBasis::Dice(variant) => Some(match variant {
            DiceVariant::Rgb => 9,
            DiceVariant::YCoCg => 6,
        }),
    }
}

/// The fragment shader of `basis`.
pub fn fragment_shader(basis: HemisphereBasis) -> ShaderVariant {
    match basis {
        HemisphereBasis::HBasis(size) => ShaderVariant {
            path: "technique/hbasis.frag",
            defines: vec![
                ("HBASIS_COUNT", size.count() as u32),
                (
                    "HBASIS_GROUPS",
                    stored_values(basis).div_ceil(VALUES_PER_TEXEL) as u32,
                ),
            ],
        },
        HemisphereBasis::Sg { lobes } => ShaderVariant {
            path: "technique/sg.frag",
            defines: vec![
                ("SG_LOBES", lobes),
                (
                    "SG_GROUPS",
                    stored_values(basis).div_ceil(VALUES_PER_TEXEL) as u32,
                ),
            ],
        },
        HemisphereBasis::Dice(variant) => ShaderVariant {
            path: "technique/dice.frag",
            defines: vec![
                ("DICE_YCOCG", u32::from(variant == DiceVariant::YCoCg)),
                ("DICE_FACES", dice::dice().faces.len() as u32),
                (
                    "DICE_GROUPS",
                    stored_values(basis).div_ceil(VALUES_PER_TEXEL) as u32,
                ),
            ],
        },
    }
}

/// The lobes of an `sgN` basis (shared, built once per N).
pub fn sg_basis(lobes: u32) -> std::sync::Arc<SgBasis> {
    crate::sh::sg::shared_basis(lobes as usize)
}

/// The amplitudes (RGB, lobe-major) fitting order-3 RGB radiance `radiance` over the
/// hemisphere of `frame` = [tangent, bitangent, normal] (its values at the fitting nodes).
pub fn fit_sg(
    basis: &SgBasis,
    radiance: &[[f64; 3]],
    frame: [glam::DVec3; 3],
    solver: Solver,
    stats: &mut FitStats,
) -> Vec<[f64; 3]> {
    let mut y = [0.0; 9];
    let samples: Vec<[f64; 3]> = basis
        .nodes()
        .iter()
        .map(|&(m, _)| {
            let world = frame[0] * m.x + frame[1] * m.y + frame[2] * m.z;
            let Some(d) = world.try_normalize() else {
                return [0.0; 3];
            };
            crate::sh::basis::eval_basis(crate::sh::Order::THREE, d, &mut y);
            std::array::from_fn(|c| (0..9).map(|k| radiance[k][c] * y[k]).sum())
        })
        .collect();
    let per_colour: [Vec<f64>; 3] = std::array::from_fn(|c| {
        let channel: Vec<f64> = samples.iter().map(|s| s[c]).collect();
        basis.fit(&channel, solver, stats)
    });
    (0..basis.len())
        .map(|k| std::array::from_fn(|c| per_colour[c][k]))
        .collect()
}

/// Every texel's SG amplitudes (texel-major, 3N each) before the f16 range scale, and how
/// many the solver made negative.
pub fn sg_stored_texels(map: &ShLightmap, lobes: u32, solver: Solver) -> (Vec<f32>, FitStats) {
    let basis = sg_basis(lobes);
    let texels = (map.res * map.res) as usize;
    let fits: Vec<(Vec<f32>, FitStats)> = (0..texels)
        .into_par_iter()
        .map(|t| {
            let frame = map.frame[t];
            let mut stats = FitStats::default();
            if frame == glam::Mat3::ZERO {
                return (vec![0.0; 3 * basis.len()], stats);
            }
            let radiance: Vec<[f64; 3]> = map.texel(t).iter().map(|c| c.map(f64::from)).collect();
            let columns = [frame.x_axis, frame.y_axis, frame.z_axis].map(|c| c.as_dvec3());
            let a = fit_sg(&basis, &radiance, columns, solver, &mut stats);
            (a.into_iter().flatten().map(|v| v as f32).collect(), stats)
        })
        .collect();
    let mut total = FitStats::default();
    let mut stored = Vec::with_capacity(texels * 3 * basis.len());
    for (values, stats) in fits {
        stored.extend(values);
        total.amplitudes += stats.amplitudes;
        total.negative += stats.negative;
    }
    (stored, total)
}

/// Every texel's Ambient Dice data (texel-major, [`DiceVariant::stored_values`] each) before
/// the f16 range scale; zeros where the lightmap has no frame.
pub fn dice_stored_texels(map: &ShLightmap, variant: DiceVariant) -> Vec<f32> {
    let basis = dice::dice();
    per_texel_values(map, |radiance, frame| {
        basis.project_irradiance(variant, radiance, frame)
    })
}

/// `project`(the texel's order-3 RGB radiance, its frame columns) for every texel of `map`,
/// concatenated in f32.
pub(crate) fn per_texel_values(
    map: &ShLightmap,
    project: impl Fn(&[[f64; 3]], [glam::DVec3; 3]) -> Vec<f64> + Sync,
) -> Vec<f32> {
    let texels = (map.res * map.res) as usize;
    (0..texels)
        .into_par_iter()
        .flat_map_iter(|t| {
            let frame = map.frame[t];
            let radiance: Vec<[f64; 3]> = map.texel(t).iter().map(|c| c.map(f64::from)).collect();
            let columns = [frame.x_axis, frame.y_axis, frame.z_axis].map(|c| c.as_dvec3());
            project(&radiance, columns).into_iter().map(|v| v as f32)
        })
        .collect()
}

/// Every texel's stored values (texel-major, [`stored_values`] each) before the f16 range
/// scale; zeros where the lightmap has no frame.
pub fn stored_texels(map: &ShLightmap, size: HBasisSize) -> Vec<f32> {
    per_texel_values(map, |radiance, frame| {
        hbasis::project_irradiance(radiance, frame, size)
            .into_iter()
            .flatten()
            .collect()
    })
}

/// The fit of `basis` the bake makes from each texel's samples.
pub fn sample_fit(basis: HemisphereBasis, solver: Solver) -> SampleFit {
    match basis {
        HemisphereBasis::HBasis(size) => SampleFit::HBasis(size),
        HemisphereBasis::Sg { lobes } => SampleFit::Sg { lobes, solver },
        HemisphereBasis::Dice(variant) => SampleFit::Dice(variant),
    }
}

/// The values the bake fitted from the samples for `fit`, or the error of a technique
/// (`label`) whose bake did not fit it.
pub(crate) fn fitted_values<'a>(
    map: &'a ShLightmap,
    fit: SampleFit,
    label: &str,
) -> Result<crate::bake::shlmap::FittedBasis<'a>, TechniqueError> {
    map.fitted(fit).ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: format!("the SH lightmap bake did not fit {fit:?} from its samples"),
    })
}

/// The stored values, range-scaled into f16, and the recipe of their baked-in lighting.
pub(crate) fn prepare(
    basis: HemisphereBasis,
    inputs: &Inputs<'_>,
    options: HemisphereOptions,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let map = super::shlmap::baked_map(inputs, label)?;
    let solver = options.solver;
    let stored = match (basis, options.fit) {
        (_, BasisFit::Samples) => {
            let fitted = fitted_values(map, sample_fit(basis, solver), label)?;
            if let HemisphereBasis::Sg { .. } = basis {
                let stats = fitted.stats();
                log::info!(
                    "{label}: {solver} fit from samples, {} of {} amplitudes negative ({:.2} %)",
                    stats.negative,
                    stats.amplitudes,
                    100.0 * stats.negative as f64 / stats.amplitudes.max(1) as f64
                );
            }
            fitted.texel_values()
        }
        (HemisphereBasis::HBasis(size), BasisFit::L2) => stored_texels(map, size),
        (HemisphereBasis::Sg { lobes }, BasisFit::L2) => {
            let (stored, stats) = sg_stored_texels(map, lobes, solver);
            log::info!(
                "{label}: {} fit, {} of {} amplitudes negative ({:.2} %)",
                solver,
                stats.negative,
                stats.amplitudes,
                100.0 * stats.negative as f64 / stats.amplitudes.max(1) as f64
            );
            stored
        }
        (HemisphereBasis::Dice(variant), BasisFit::L2) => dice_stored_texels(map, variant),
    };
    let name = format!("{label}.{}", Hemisphere { basis }.name());
    let (texel_groups, recipe, scale) =
        super::shlmap::baked_values(&stored, stored_values(basis), map.res, name, label)?;
    let (texel_groups, recipe) = match basis {
        HemisphereBasis::HBasis(_) | HemisphereBasis::Sg { .. } => (texel_groups, recipe),
        HemisphereBasis::Dice(_) => {
            let texel_groups = texel_groups.with_dx9_atlas();
            let atlas = texel_groups
                .dx9_atlas
                .as_ref()
                .map_or([1.0, 1.0], |a| [a.columns as f32, a.rows as f32]);
            let mut params = DiceParams {
                unscale: [1.0 / scale, 0.0, 0.0, 0.0],
                atlas: [atlas[0], atlas[1], 0.0, 0.0],
                faces: [[[0.0; 4]; DICE_FACE_VEC4S]; DICE_MAX_FACES],
            };
            for (dst, src) in params.faces.iter_mut().flatten().zip(dice_face_table()) {
                *dst = src;
            }
            let recipe = Recipe::Baked(super::lighting::LightingData::params(
                bytemuck::bytes_of(&params).to_vec(),
            ));
            (texel_groups, recipe)
        }
    };
    let recipe = match basis {
        HemisphereBasis::HBasis(_) | HemisphereBasis::Dice(_) => recipe,
        HemisphereBasis::Sg { lobes } => {
            let sg = sg_basis(lobes);
            let mut params = SgParams {
                unscale: [1.0 / scale, 0.0, 0.0, 0.0],
                lobes: [[0.0; 4]; SG_MAX_LOBES],
            };
            for (dst, mu) in params.lobes.iter_mut().zip(&sg.axes) {
                *dst = [mu.x as f32, mu.y as f32, mu.z as f32, sg.sharpness as f32];
            }
            Recipe::Baked(super::lighting::LightingData::params(
                bytemuck::bytes_of(&params).to_vec(),
            ))
        }
    };
    Ok((texel_groups, recipe))
}

/// What a [`Hemisphere`] technique stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HemisphereBasis {
    /// `hb4`, `hb6`: the H-basis of the irradiance over the hemisphere.
    HBasis(HBasisSize),
    /// `sgN`: N spherical Gaussian lobes over the hemisphere, RGB amplitudes fitted by the
    /// run's `--sg-solve` (`crate::sh::sg`).
    Sg { lobes: u32 },
    /// `dice`, `dicey`: Ambient Dice, RGB or YCoCg (`crate::sh::dice`).
    Dice(DiceVariant),
}

/// The lightmap bases over the texel's tangent-frame hemisphere (module doc), from the same
/// bake as `shlmap`, indexed by the tangent-space normal: `hb4`, `hb6` — the H-basis (Habel
/// & Wimmer 2010; `crate::sh::hbasis`); `sg5`, `sg6`, `sg9`, `sg12` — spherical Gaussians
/// (`crate::sh::sg`); `dice`, `dicey` — Ambient Dice (Iwanicki & Sloan 2017;
/// `crate::sh::dice`). Its options are the SG solver (`--sg-solve`) and the fits' source
/// (`--basis-fit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Hemisphere {
    pub basis: HemisphereBasis,
}

/// The hemisphere family's run options.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct HemisphereOptions {
    /// How `sgN` fits its amplitudes (`--sg-solve`).
    pub solver: Solver,
    /// What every basis is fitted from (`--basis-fit`).
    pub fit: BasisFit,
}

impl Family for Hemisphere {
    type Options = HemisphereOptions;
    const DESCRIPTION: Description = Description {
        names: "hb4, hb6, sgN, dice, dicey",
        what: "bases over the tangent-frame hemisphere, read at the tangent-space normal: the H-basis; N spherical Gaussians fitted by --sg-solve; Ambient Dice (icosahedron vertices, hybrid Bézier; YCoCg)",
        paper: "Habel & Wimmer (I3D 2010); Neubelt & Pettineo (The Order: 1886), MJP's SG series; Iwanicki & Sloan (EGSR 2017)",
        in_paper_table: false,
    };
    const EXAMPLE: Hemisphere = Hemisphere {
        basis: HemisphereBasis::HBasis(HBasisSize::H4),
    };

    fn members() -> Vec<Hemisphere> {
        [
            HemisphereBasis::HBasis(HBasisSize::H4),
            HemisphereBasis::HBasis(HBasisSize::H6),
        ]
        .into_iter()
        .chain(
            crate::sh::sg::LOBE_COUNTS
                .iter()
                .map(|&n| HemisphereBasis::Sg { lobes: n as u32 }),
        )
        .chain(DiceVariant::ALL.map(HemisphereBasis::Dice))
        .map(|basis| Hemisphere { basis })
        .collect()
    }

    fn table_rows() -> Vec<Hemisphere> {
        [
            HemisphereBasis::HBasis(HBasisSize::H4),
            HemisphereBasis::HBasis(HBasisSize::H6),
            HemisphereBasis::Sg { lobes: 6 },
            HemisphereBasis::Sg { lobes: 9 },
            HemisphereBasis::Sg { lobes: 12 },
            HemisphereBasis::Dice(DiceVariant::Rgb),
            HemisphereBasis::Dice(DiceVariant::YCoCg),
        ]
        .map(|basis| Hemisphere { basis })
        .to_vec()
    }

    fn headline(path: HwPath) -> Vec<Hemisphere> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => [
                HemisphereBasis::HBasis(HBasisSize::H4),
                HemisphereBasis::Sg { lobes: 9 },
                HemisphereBasis::Dice(DiceVariant::Rgb),
            ]
            .map(|basis| Hemisphere { basis })
            .to_vec(),
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        match self.basis {
            HemisphereBasis::HBasis(HBasisSize::H4) => "hb4".into(),
            HemisphereBasis::HBasis(HBasisSize::H6) => "hb6".into(),
            HemisphereBasis::Sg { lobes } => format!("sg{lobes}"),
            HemisphereBasis::Dice(DiceVariant::Rgb) => "dice".into(),
            HemisphereBasis::Dice(DiceVariant::YCoCg) => "dicey".into(),
        }
    }

    fn paper_ms(self) -> Option<f64> {
        None
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds::SH_LIGHTMAP
    }

    fn reference(self) -> ReferenceModel {
        ReferenceModel::InterReflected
    }

    fn dynamic_lighting(self) -> bool {
        false
    }

    fn ndf_variant(self) -> Option<Technique> {
        None
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        let colours = match self.basis {
            HemisphereBasis::HBasis(_)
            | HemisphereBasis::Sg { .. }
            | HemisphereBasis::Dice(DiceVariant::Rgb) => NormColours::Triplets,
            HemisphereBasis::Dice(DiceVariant::YCoCg) => NormColours::One,
        };
        Ok(Form::values(path, BlockCodec::Ratio(colours)))
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        options: &HemisphereOptions,
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        prepare(self.basis, inputs, *options, label)
    }

    fn extra_slot(
        self,
        _: &Arc<Context>,
        _: HwPath,
        _: &Inputs<'_>,
        _: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError> {
        Ok(None)
    }

    fn fragment_shader(self) -> ShaderVariant {
        fragment_shader(self.basis)
    }

    fn reads(self) -> ShaderReads {
        match group_reads(self.basis) {
            Some(lookups) => ShaderReads {
                per_texel_taps: Some(PerTexelTaps {
                    lookups,
                    fetches: 0,
                }),
                ..ShaderReads::PLAIN
            },
            None => ShaderReads::PLAIN,
        }
    }

    fn options_tag(self, options: &HemisphereOptions) -> Option<String> {
        Some(match self.basis {
            HemisphereBasis::Sg { .. } => format!("{}.{}", options.solver, options.fit),
            _ => options.fit.to_string(),
        })
    }

    fn sample_fit(self, options: &HemisphereOptions) -> Option<SampleFit> {
        (options.fit == BasisFit::Samples).then(|| sample_fit(self.basis, options.solver))
    }

    fn values(self) -> Option<super::values::ValueMap> {
        Some(value_map(self.basis))
    }
}

/// The H-basis functions at a tangent-space direction m (`glsl/include/hbasis.glsl`).
const H_BASIS_FUNCTIONS: [&str; 6] = [
                        "H_0 = 1 / sqrt(2 pi)",
                        "H_1 = sqrt(3 / (2 pi)) m.y",
                        "H_2 = sqrt(3 / (2 pi)) (2 m.z - 1)",
                        "H_3 = sqrt(3 / (2 pi)) m.x",
                        "H_4 = sqrt(15 / (2 pi)) m.x m.y",
                        "H_5 = sqrt(15 / (2 pi)) (m.x^2 - m.y^2) / 2",
                    ];

/// What the values of `basis` are ([`Family::values`]).
fn value_map(basis: HemisphereBasis) -> super::values::ValueMap {
    use super::values::{self, Colour, Value, ValueMap};
    let ending =
        |evaluate: String| values::evaluated_and_unscaled(values::TANGENT_NORMAL, &evaluate);
    let v3 = |v: glam::DVec3| [v.x, v.y, v.z];
    match basis {
        HemisphereBasis::HBasis(size) => {
            let names: Vec<String> = (0..size.count()).map(|i| format!("H_{i}")).collect();
            ValueMap {
                stored: "irradiance over the texel's hemisphere, fitted in the H-basis",
                basis: serde_json::json!({
                    "name": "h-basis",
                    "reference": "Habel & Wimmer 2010",
                    "frame": "tangent (x along +u, y image up, z the surface normal)",
                    "functions": &H_BASIS_FUNCTIONS[..size.count()],
                }),
                values: values::triplets(&names),
                steps: ending("E(m) = sum over i of h_i H_i(m), per colour".into()),
            }
        }
        HemisphereBasis::Sg { lobes } => {
            let sg = sg_basis(lobes);
            let names: Vec<String> = (0..lobes).map(|k| format!("lobe_{k}")).collect();
            ValueMap {
                stored: "amplitudes of spherical Gaussian lobes fitted to the incident radiance over the texel's hemisphere (by --sg-solve)",
                basis: serde_json::json!({
                    "name": "spherical gaussians",
                    "frame": "tangent (x along +u, y image up, z the surface normal)",
                    "lobe": "G_k(w) = exp(lambda (mu_k . w - 1))",
                    "axes": sg.axes.iter().map(|&a| v3(a)).collect::<Vec<_>>(),
                    "sharpness": sg.sharpness,
                    "parameters": "also in the uniform block: lobes[k].xyz = mu_k, lobes[k].w = lambda",
                }),
                values: values::triplets(&names),
                steps: ending(
                    "E(m) = sum over k of a_k I(mu_k . m, lambda), per colour; I(t, lambda) = the lobe's integral against max(0, m . w), Hill's fit: e = exp(-lambda), e2 = e^2, r = 1 / lambda, scale = 1 + 2 e2 - r, bias = (e - e2) r - e2, x = sqrt(max(1 - scale, 0)), x0 = 0.36 t, x1 = x / (4 * 0.36), y = (x0 + x1)^2 / x if |x0| <= x1 else clamp(t, 0, 1), I = (scale y + bias) 2 pi (1 - exp(-2 lambda)) r".into(),
                ),
            }
        }
        HemisphereBasis::Dice(variant) => {
            let d = dice::dice();
            let mut list = Vec::new();
            for v in 0..dice::STORED_VERTICES {
                let parts = ["value", "du", "dv"];
                match variant {
                    DiceVariant::Rgb => {
                        for (k, part) in parts.iter().enumerate() {
                            for c in 0..3 {
                                list.push(Some(Value {
                                    coefficient: format!("vertex_{v}.{part}"),
                                    index: 3 * v + k,
                                    colour: Colour::Channel(c as u8),
                                }));
                            }
                        }
                    }
                    DiceVariant::YCoCg => {
                        for (k, part) in parts.iter().enumerate() {
                            list.push(Some(Value {
                                coefficient: format!("vertex_{v}.{part}"),
                                index: 3 * v + k,
                                colour: Colour::Component("Y"),
                            }));
                        }
                        for chroma in ["Co", "Cg"] {
                            list.push(Some(Value {
                                coefficient: format!("vertex_{v}.value"),
                                index: 3 * v,
                                colour: Colour::Component(chroma),
                            }));
                        }
                    }
                }
            }
            let colour = match variant {
                DiceVariant::Rgb => "each colour by the hybrid patch",
                DiceVariant::YCoCg => {
                    "Y = R/4 + G/2 + B/4 by the hybrid patch; Co = (R - B)/2 and Cg = (2G - R - B)/4 by the linear interpolation sum b_i c_i; RGB = (Y + Co - Cg, Y + Cg, Y - Co - Cg)"
                }
            };
            ValueMap {
                stored: "irradiance over the texel's hemisphere, least-squares fitted as Ambient Dice vertex data (value and directional derivatives)",
                basis: serde_json::json!({
                    "name": "ambient dice",
                    "reference": "Iwanicki & Sloan, Ambient Dice, EGSR 2017",
                    "frame": "tangent (x along +u, y image up, z the surface normal)",
                    "vertices": d.vertices.iter().map(|&v| v3(v)).collect::<Vec<_>>(),
                    "vertex_tangents": d.vertex_tangents.iter().map(|t| [v3(t[0]), v3(t[1])]).collect::<Vec<_>>(),
                    "faces": "uniform_block.faces: per face 7 vec4s: the centre (xyz); per corner i its dual vector (xyz, barycentric lambda_i = dual_i . m) with the stored vertex index in w; per corner i the edge factors (t_u,i . v_j, t_v,i . v_j) toward its two other corners j in increasing order (xy, zw)",
                    "colour": colour,
                }),
                values: list,
                steps: ending(format!(
                    "m' = (m.x, m.y, max(m.z, 0)) normalised; the face whose centre is nearest m'; b = lambda / sum(lambda); the cubic Bezier triangle in b with corners f_i, edge points f_i + (du_i e_u,ij + dv_i e_v,ij) / 3 and Farin's hybrid centre (c111 candidates 1/4 (c021 + c012) + 1/2 (c120 + c102) - 1/4 (c030 + c003) and cyclically, blended by b_j b_k / (b0 b1 + b1 b2 + b2 b0)); {colour}"
                )),
            }
        }
    }
}

/// The shared SG evaluation the ladder and the tests use: E at tangent-space `m` from
/// lobe-major RGB amplitudes.
pub fn sg_irradiance(basis: &SgBasis, amplitudes: &[[f64; 3]], m: glam::DVec3) -> [f64; 3] {
    std::array::from_fn(|c| {
        let a: Vec<f64> = amplitudes.iter().map(|v| v[c]).collect();
        basis.irradiance(&a, m)
    })
}
