//! A technique's counts for the device cost model (`crate::cost`), asked for by the bench and
//! the probe, never by a build: its lookups by kind from the images it binds and the float
//! ops, uniform and varying reads of its fragment shader's SPIR-V (`cost::spirv`) — or, for
//! a shader whose work depends on its data, of its [`CountPlan`]'s count builds, weighted by
//! the share of fragments each path runs (measured by drawing the plan's measuring build
//! once over the scene).
//!
//! Lookup kinds: material textures trilinear (the albedo's sRGB and the NDF moment maps'
//! RGBA32F each a kind of their own), per-texel data bilinear 2D (dx9) or 2D array (dx10, dx11)
//! or, where a shader reads its taps one by one, texel fetches (priced as 2D fetches on every
//! path: the probe has no array fetch), normal-indexed tables dependent 2D (dx9) or cube
//! array (dx10, dx11), a normal basis dependent 2D (dx9) or 2D array (dx10, dx11), the specular term's
//! moment maps trilinear RGBA32F. On dx11 each per-texel layer is priced by its format: a
//! BC6H, BC7 or BC4 layer as a lookup of that format (which a device without a texture
//! unit's decoder pays for at every fetch), any other as a 2D-array lookup.

use std::sync::Arc;

use super::finish::{self, SlotKind, SlotLayout};
use super::{HwPath, ShaderReads, TechniqueError, TechniqueGpu};
use crate::cost::spirv::{self, OpCounts};
use crate::cost::{CostCounts, CountPlan, Kind};
use crate::gpu::{self, Context, ImageDesc, layout};
use crate::render::SceneGpu;

/// Per-pixel counts of a technique's shader on its path.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShaderCosts {
    /// The work done, by kind.
    pub done: CostCounts,
    /// The straight-line work of its branches where no lane of a batch takes them, which
    /// some devices run masked (`CostModel::untaken_share`).
    pub untaken: CostCounts,
}

/// The cost model's counts of `tech` drawn over `scene` (its front lighting set's bindings).
pub fn counts(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    tech: &TechniqueGpu,
) -> Result<ShaderCosts, TechniqueError> {
    let reads = tech.technique.reads();
    let set = &tech.sets[tech.front];
    let slots = finish::bound_slots(
        &tech.per_texel,
        tech.extra.as_ref(),
        &set.own_per_texel,
        &set.tables,
    );
    let layouts: Vec<SlotLayout> = slots.iter().map(|s| s.layout()).collect();
    let builds = match &reads.count_plan {
        None => vec![(1.0, spirv::count(&tech.fragment), false)],
        Some(plan) => {
            let resources = finish::resources(scene, &set.params, tech.path, &slots);
            plan_counts(ctx, scene, tech, plan, &resources)?
        }
    };
    // The work done, and apart the work of branches no lane takes.
    let counts_of = |untaken: bool| {
        let ops: Vec<_> = builds
            .iter()
            .filter(|&&(_, _, is_untaken)| is_untaken == untaken)
            .map(|&(share, ops, _)| (share, ops))
            .collect();
        lookup_counts(&reads, tech.path, scene, &layouts, &ops)
    };
    Ok(ShaderCosts {
        done: counts_of(false),
        untaken: counts_of(true),
    })
}

/// The shares and SPIR-V counts of `plan`'s builds, its measuring build drawn once over the
/// scene with the technique's `resources`.
fn plan_counts(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    tech: &TechniqueGpu,
    plan: &CountPlan,
    resources: &[(u32, gpu::Resource<'_>)],
) -> Result<Vec<(f64, OpCounts, bool)>, TechniqueError> {
    let (technique, path) = (tech.technique, tech.path);
    let compile = |defines: &[(&'static str, u32)]| {
        finish::compile_fragment_source(technique, Some(plan.shader), path, scene, defines)
    };
    let measured = match &plan.measure_defines {
        Some(defines) => {
            let mut defines = defines.clone();
            defines.push((
                "SUBGROUP_VOTE",
                u32::from(ctx.supports_fragment_subgroup_vote()),
            ));
            measure_costly_share(ctx, scene, tech, &compile(&defines)?, resources)?
        }
        None => 0.0,
    };
    plan.variants
        .iter()
        .map(|v| {
            let mut counts = spirv::count(&compile(&v.defines)?);
            if counts.loops > 0 {
                log::warn!(
                    "{technique} on {path}: count build {:?} keeps {} loop(s), whose bodies are counted once",
                    v.defines,
                    counts.loops
                );
            }
            // The loops one pixel enters on this path: the build with the drawn shader's
            // loops kept (`COUNT_LOOPS`).
            let mut kept = v.defines.clone();
            kept.push(("COUNT_LOOPS", 1));
            counts.kept_loops = spirv::count(&compile(&kept)?).kept_loops;
            let share = v.share + v.share_per_measured * measured;
            log::debug!(
                "{technique} on {path}: count build {:?}, share {share:.4}: {counts:?}",
                v.defines
            );
            Ok((share, counts, v.untaken))
        })
        .collect()
}

/// The share s of a [`CountPlan`]: its measuring build (`measure`, SPIR-V) drawn once over
/// the scene, additively.
fn measure_costly_share(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    tech: &TechniqueGpu,
    measure: &[u32],
    resources: &[(u32, gpu::Resource<'_>)],
) -> Result<f64, TechniqueError> {
    let label = tech.label();
    let pipeline = gpu::MeshPipeline::new(
        ctx,
        scene.target(),
        &gpu::MeshPipelineDesc {
            name: &format!("{label}.count_paths"),
            vertex_spirv: scene.vertex_spirv(),
            fragment_spirv: measure,
            vertex_layout: scene.vertex_layout(),
            resources,
            depth_test: true,
            additive: true,
        },
    )?;
    let frame = scene.render_pipeline(&pipeline, 0, 1)?;
    let (costly, fragments) = frame.rgba.iter().fold((0.0, 0.0), |(r, g), p| {
        (r + f64::from(p[0]), g + f64::from(p[1]))
    });
    let measured = if fragments > 0.0 {
        costly / fragments
    } else {
        0.0
    };
    log::debug!(
        "{label}: {:.1} % of the shaded fragments run the costly path (subgroup vote: {})",
        100.0 * measured,
        ctx.supports_fragment_subgroup_vote()
    );
    Ok(measured)
}

/// Σ share · counts over `builds`, each with the lookups by kind of the bound `layouts`
/// (module doc) and the scene's specular term.
fn lookup_counts(
    reads: &ShaderReads,
    path: HwPath,
    scene: &SceneGpu,
    layouts: &[SlotLayout],
    builds: &[(f64, OpCounts)],
) -> CostCounts {
    // The albedo (sRGB) and, unless the technique skips it, the normal map (UNORM).
    let normal_map = layout::MATERIAL_TEXTURES - 1 - u32::from(!reads.reads_normal_map);
    let mut lookups = vec![(Kind::TrilinearSrgb, 1), (Kind::Trilinear2d, normal_map)];
    for slot in layouts {
        let n = match (slot.kind, reads.per_texel_taps) {
            (SlotKind::PerTexel, Some(taps)) => {
                lookups.push((Kind::TexelFetch, taps.fetches));
                taps.lookups - taps.fetches
            }
            (SlotKind::NormalTable, _) => slot.lookups() * reads.table_fetches,
            (SlotKind::PerTexel, None) | (SlotKind::Material | SlotKind::NormalBasis, _) => {
                slot.lookups()
            }
        };
        let kind = match (slot.kind, path) {
            (SlotKind::PerTexel, HwPath::Dx11) => {
                // Each image by its format, the block-compressed ones by their own kinds:
                // the groups' layers (the first image) as the shader reads them, the
                // norms' once.
                for (i, d) in slot.images.iter().enumerate() {
                    let kind = Kind::of_block_format(d.format).unwrap_or(Kind::Array2d);
                    let reads = match reads.per_texel_taps {
                        Some(taps) if i == 0 => taps.lookups - taps.fetches,
                        _ => d.layers,
                    };
                    lookups.push((kind, reads));
                }
                continue;
            }
            (SlotKind::Material, _) => {
                // RGBA32F (the NDF moment maps) priced apart from RGBA8 material textures.
                let wide = |d: &&ImageDesc| d.format == crate::ndf::MOMENT_FORMAT;
                let wide_lookups: u32 = slot.images.iter().filter(wide).map(|d| d.layers).sum();
                lookups.push((Kind::TrilinearWide, wide_lookups));
                lookups.push((Kind::Trilinear2d, n - wide_lookups));
                continue;
            }
            (SlotKind::PerTexel, HwPath::Dx9) => Kind::Bilinear2d,
            (SlotKind::PerTexel, HwPath::Dx10) => Kind::Array2d,
            (SlotKind::NormalTable, HwPath::Dx9) => Kind::Dependent2d,
            (SlotKind::NormalTable, HwPath::Dx10 | HwPath::Dx11) => Kind::CubeArray,
            // The disk texture is read at the normal map's coordinates: dependent, a 2D
            // array layer on dx10.
            (SlotKind::NormalBasis, HwPath::Dx9) => Kind::Dependent2d,
            (SlotKind::NormalBasis, HwPath::Dx10 | HwPath::Dx11) => Kind::Array2d,
        };
        lookups.push((kind, n));
    }
    if let Some(specular) = scene.specular() {
        // The NDF moment maps, RGBA32F (`render::specular`).
        lookups.push((Kind::TrilinearWide, specular.term.filter.extra_lookups()));
    }
    CostCounts::shared(
        builds
            .iter()
            .map(|(share, ops)| (*share, CostCounts::new(&lookups, ops))),
    )
}
