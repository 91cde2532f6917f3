//! What the probe measures, and in which order: the points (every kind at the counts of
//! [`probe_counts`], the empty shader over the screen, its half, without the depth test and
//! over the triangle grids, the varyings over [`VARYING_GRIDS`], the reads in an untaken
//! branch), each compiled, counted and built into a pipeline ([`PointPlanner`]); their
//! frames in interleaved rounds with a monitor frame after each point's ([`Batches`]); and
//! the points timed again in more batches on fresh builds where a fit misses them
//! ([`missed_points`], [`retime`]).

use std::sync::Arc;

use super::fit::predict_point;
use super::resources::ProbeResources;
use super::shaders::{MAX_PROBE_VARYINGS, probe_source};
use super::states::BUILD_AGREEMENT;
use super::{DeviceStates, ProbePoint, ProbeSettings, Segmented};
use crate::cost::spirv::{self, OpCounts};
use crate::cost::{CostCounts, CostModel, Kind};
use crate::gpu::TimingStats;
use crate::gpu::{Context, GpuError, MeshBuffers, Resource, Sampler, ShaderStage, layout};
use crate::render::{SceneGpu, ShadingLoad};
use crate::scene::Mesh;

/// Grid sides of the per-triangle points: small triangles (125, 55, 31 and 8 pixels at
/// 1280×800), as a scene's many small ones (pca12v25's 115k triangles are ≈ 7 pixels).
pub(super) const TRIANGLE_GRIDS: [u32; 4] = [64, 96, 128, 256];

/// Grid sides (of [`TRIANGLE_GRIDS`]) over which the shader that reads every varying is
/// drawn too: the per-triangle cost of a varying.
pub const VARYING_GRIDS: [u32; 2] = [96, 256];

/// The counts `kind`'s probe points are generated with (the lookups' from 1, as the rows
/// use 1–3 of many kinds).
pub fn probe_counts(kind: Kind) -> &'static [u32] {
    match kind {
        Kind::FloatOp => &[64, 128, 256, 512],
        Kind::Varying => &[2, 5, 9, MAX_PROBE_VARYINGS],
        Kind::UniformRead => &[32, 64, 128, 256],
        Kind::IndexedUniformRead => &[18, 36, 72, 144],
        Kind::TexelFetch => &[4, 8, 12, 16],
        Kind::TrilinearWide | Kind::TrilinearSrgb => &[1, 2, 4, 8],
        Kind::Transcendental => &[32, 64, 128, 256],
        Kind::IndexedPrivateRead => &[9, 18, 27, 36],
        Kind::IntegerDivide => &[8, 16, 32, 64],
        // BC6H and BC7 are decoded in software on lavapipe (0.1–0.2 s a lookup over the
        // screen): two points each, over half the screen (`point_specs`).
        Kind::Bc6hArray | Kind::Bc7Array | Kind::Bc4Array => &[1, 2],
        // No points of its own: the indexed reads' points enter one loop each.
        Kind::Loop => &[],
        _ => &[1, 2, 4, 8, 12, 16],
    }
}

/// Points faster than this get proportionally more frames (up to 20×) after the first round.
const CHEAP_POINT_MS: f64 = 40.0;

/// Interleaved rounds the timed frames are split into.
const PROBE_ROUNDS: u32 = 10;

/// A point a fit misses by more than this (relative) is timed again.
pub(super) const RETIME_ERROR: f64 = 0.08;

/// Most batches a missed point is timed again in (one at a time, while it is missed).
pub(super) const RETIME_BATCHES: usize = 2;

/// A state needs this share of the monitor frames to be sought: the points with fewer than
/// [`MIN_STATE_FRAMES`] in the fastest such state ([`sought_state`]) are timed again. Only
/// that one is sought, the state the main model and the bench's comparisons come from: a
/// slower or rarer state gets a model where every point happened to run in it, and a
/// bench's rows timed in a state without one are timed again in a modelled state. Seeing
/// every point 5 times in a second state that holds 12–26 % of the monitor frames takes two
/// more batches of nearly every point (85 of them; the probe 91–97 s instead of 36–47 s),
/// as a point of 40 ms or more has one frame a round.
pub(super) const STATE_MODEL_SHARE: f64 = 0.2;

/// Frames in a state below which a point's median there is too few to fit (one run put the
/// 2·128² grid at 1.10× the model on 2 frames), unless they come from [`MIN_STATE_ROUNDS`]
/// rounds.
pub(super) const MIN_STATE_FRAMES: usize = 5;

/// Rounds with frames in a state that are enough whatever their frames: a point of 40 ms
/// or more has one frame a round, so 5 frames of it in a state that holds 84 % of the
/// monitor frames would need every round there, and 67 of 90 points took another batch.
pub(super) const MIN_STATE_ROUNDS: usize = 3;

/// The untaken-branch points: indexed uniform reads (a cluster's block, as the clustered
/// techniques' boundary path reads them) in a branch that no lane takes.
pub const UNTAKEN_BRANCH_READS: &[u32] = &[32, 64, 128];

/// What a probe point is drawn as: its kind (`None`: the empty shader), operation count,
/// whether they sit in an untaken branch, whether the depth test is on, and its mesh.
pub(super) type PointSpec<'m> = (Option<Kind>, u32, bool, bool, &'m MeshBuffers);

/// Every probe point (the probe's module doc), in the order they are built and timed.
pub(super) fn point_specs<'m>(
    ctx: &Arc<Context>,
    nothing_mesh: &'m MeshBuffers,
    full_mesh: &'m MeshBuffers,
    half_mesh: &'m MeshBuffers,
    grids: &'m [(MeshBuffers, Mesh)],
) -> Vec<PointSpec<'m>> {
    let mut specs: Vec<PointSpec<'m>> = vec![
        (None, 0, false, true, nothing_mesh),
        (None, 0, false, true, full_mesh),
        (None, 0, false, true, half_mesh),
        (None, 0, false, false, full_mesh),
    ];
    specs.extend(grids.iter().map(|g| (None, 0, false, true, &g.0)));
    // A device that cannot filter RGBA32F (optional in Vulkan) gets no such points: its
    // cost stays 0 (and the NDF rows, which need it, refuse to build there).
    let wide_filters = ctx.supports_linear_filter(crate::ndf::MOMENT_FORMAT);
    // Likewise a device that cannot sample a BC format gets no points of its kind (the dx11
    // rows refuse to build there).
    for kind in Kind::ALL
        .into_iter()
        .filter(|&k| k != Kind::TrilinearWide || wide_filters)
        .filter(|k| {
            k.block_format()
                .is_none_or(|f| ctx.supports_block_format(f))
        })
    {
        let mesh = if kind.block_format().is_some() {
            half_mesh
        } else {
            full_mesh
        };
        for &count in probe_counts(kind) {
            specs.push((Some(kind), count, false, true, mesh));
        }
    }
    for (g, _) in grids
        .iter()
        .zip(TRIANGLE_GRIDS)
        .filter(|(_, side)| VARYING_GRIDS.contains(side))
    {
        specs.push((Some(Kind::Varying), MAX_PROBE_VARYINGS, false, true, &g.0));
    }
    for &count in UNTAKEN_BRANCH_READS {
        specs.push((Some(Kind::IndexedUniformRead), count, true, true, full_mesh));
    }
    specs
}

/// A probe point with its pipeline, ready to time.
pub(super) struct Planned<'m> {
    pub(super) point: ProbePoint,
    pub(super) pipeline: crate::gpu::MeshPipeline,
    /// How many times `pipeline` was rebuilt (`states`: builds differ).
    pub(super) build: usize,
    pub(super) mesh: &'m MeshBuffers,
}

/// What building a probe point's pipeline needs: the probe scene's GPU state, the textures
/// and samplers the points read, and the shading load of each mesh.
pub(super) struct PointPlanner<'a> {
    pub(super) ctx: &'a Arc<Context>,
    pub(super) gpu: &'a SceneGpu,
    pub(super) res: &'a ProbeResources,
    pub(super) linear: &'a Sampler,
    /// Screen pixels, what a mesh's busy lanes are divided by.
    pub(super) pixels: f64,
    /// Lanes per screen pixel of each mesh: the coverage the model's per-pixel costs
    /// multiply ([`shading_loads`](super::resources::shading_loads)).
    pub(super) loads: Vec<(*const MeshBuffers, ShadingLoad)>,
}

impl<'a> PointPlanner<'a> {
    /// The shading load of `mesh` (one of those the planner was given).
    pub(super) fn load_of(&self, mesh: &MeshBuffers) -> Option<ShadingLoad> {
        self.loads
            .iter()
            .find(|(m, _)| std::ptr::eq(*m, mesh))
            .map(|(_, l)| *l)
    }

    /// Compiles a probe point's shader, counts its operations and builds its pipeline
    /// over `mesh`; the point's timings are still to be taken.
    pub(super) fn plan(
        &self,
        kind: Option<Kind>,
        count: u32,
        untaken: bool,
        depth_test: bool,
        mesh: &MeshBuffers,
    ) -> Result<(ProbePoint, crate::gpu::MeshPipeline), GpuError> {
        let name = format!(
            "probe.{}{count}{}",
            kind.map_or("empty".to_string(), |k| format!("{k:?}").to_lowercase()),
            if untaken { ".untaken" } else { "" }
        );
        let compile = |count, counted| {
            crate::gpu::shader::compile_source(
                &format!("{name}.frag"),
                &probe_source(kind, count, untaken, counted),
                ShaderStage::Fragment,
                &[],
            )
        };
        let spirv = compile(count, false)?;
        // Operations per pixel from the build with every loop unrolled (the drawn one where
        // it has no loop to unroll), loops entered from the drawn one.
        let drawn = spirv::count(&spirv);
        let unrolled = if probe_source(kind, count, untaken, true)
            == probe_source(kind, count, untaken, false)
        {
            drawn
        } else {
            spirv::count(&compile(count, true)?)
        };
        let ops = OpCounts {
            kept_loops: drawn.kept_loops,
            ..unrolled
        };
        let resources = self.point_resources(kind);
        let pipeline = self
            .gpu
            .mesh_pipeline_with_depth(self.ctx, &name, &spirv, &resources, depth_test)?;
        // SPIR-V counts both sides of a branch: the untaken work is what the point counts
        // beyond the same shader with none of the operations.
        let all = CostCounts::new(&lookups_of(kind, count), &ops);
        let untaken_counts = if untaken {
            all.less(&CostCounts::new(&[], &spirv::count(&compile(0, true)?)))
        } else {
            CostCounts::default()
        };
        let point = ProbePoint {
            kind,
            count,
            coverage: self.load_of(mesh).map_or(0.0, |l| l.lanes / self.pixels),
            triangles: mesh.triangle_count(),
            edge_pixels: self.load_of(mesh).map_or(0.0, |l| l.edge_pixels),
            depth_test,
            in_untaken_branch: untaken,
            counts: all.less(&untaken_counts),
            untaken: untaken_counts,
            ms_median: f64::NAN,
            batches: 1,
            frames: 0,
            state_frames: 0,
            model_ms: f64::NAN,
        };
        Ok((point, pipeline))
    }

    /// What a point of `kind` binds: the scene's common resources, the uniform block and
    /// the textures its lookups read.
    fn point_resources(&self, kind: Option<Kind>) -> Vec<(u32, Resource<'a>)> {
        let (res, linear, material) = (self.res, self.linear, self.gpu.material_sampler());
        let mut resources = self.gpu.common_resources();
        resources.push((
            layout::BINDING_TECHNIQUE_PARAMS,
            Resource::Uniform(&res.uniforms),
        ));
        let t0 = layout::BINDING_TECHNIQUE_TEXTURE0;
        match kind {
            Some(Kind::Bilinear2d | Kind::TexelFetch) => resources.push((
                t0,
                Resource::TextureArray(res.bilinear.iter().map(|i| (i, linear)).collect()),
            )),
            Some(Kind::Dependent2d) => resources.push((
                t0,
                Resource::TextureArray(res.tables.iter().map(|i| (i, linear)).collect()),
            )),
            Some(Kind::Trilinear2d) => resources.push((
                t0,
                Resource::TextureArray(res.trilinear.iter().map(|i| (i, material)).collect()),
            )),
            Some(Kind::TrilinearWide) => resources.push((
                t0,
                Resource::TextureArray(res.trilinear_wide.iter().map(|i| (i, material)).collect()),
            )),
            Some(Kind::TrilinearSrgb) => resources.push((
                t0,
                Resource::TextureArray(res.trilinear_srgb.iter().map(|i| (i, material)).collect()),
            )),
            Some(Kind::Array2d) => resources.push((t0, Resource::Texture(&res.array, linear))),
            Some(k) if k.block_format().is_some() => {
                if let Some(image) = res.block_array(k) {
                    resources.push((t0, Resource::Texture(image, linear)));
                }
            }
            Some(Kind::CubeArray) => {
                resources.push((t0, Resource::Texture(&res.cube_array, linear)));
            }
            _ => {}
        }
        resources
    }
}

/// The texture lookups a point of `kind` makes: `count` of its kind where it is a lookup.
fn lookups_of(kind: Option<Kind>, count: u32) -> Vec<(Kind, u32)> {
    match kind {
        Some(k) if k.is_lookup() => vec![(k, count)],
        _ => vec![],
    }
}

/// How the points' frames are taken: in `rounds` interleaved rounds of `per_round` frames
/// each (the probe's module doc), with a frame of the monitor point after each point's frames.
pub(super) struct Batches<'a> {
    gpu: &'a SceneGpu,
    warmup: u32,
    /// Show a batch's progress bar (`ProbeSettings::progress`).
    progress: bool,
    pub(super) rounds: u32,
    pub(super) per_round: u32,
    /// The planned point that monitors the device: the empty shader over the screen.
    pub(super) monitor_index: usize,
}

impl<'a> Batches<'a> {
    /// The rounds for `s`'s frames, and the monitor among `planned` (its mesh `screen`).
    ///
    /// # Errors
    /// No empty-shader point over the screen among `planned`.
    pub(super) fn new(
        gpu: &'a SceneGpu,
        s: &ProbeSettings,
        planned: &[Planned],
        screen: &MeshBuffers,
    ) -> Result<Self, GpuError> {
        // A slow drift of the device (another tenant, clocks) would otherwise land on
        // whichever points ran during it; in rounds it spreads over all of them and the
        // median drops it. The faster switches between speed states are told apart by the
        // monitor (`states`).
        let rounds = s.frames.clamp(1, PROBE_ROUNDS);
        let per_round = s.frames.div_ceil(rounds);
        let monitor_index = planned
            .iter()
            .position(|p| {
                p.point.kind.is_none() && p.point.depth_test && std::ptr::eq(p.mesh, screen)
            })
            .ok_or_else(|| GpuError::Invalid {
                what: "probe".into(),
                detail: "no empty-shader point over the screen to monitor the device with".into(),
            })?;
        Ok(Batches {
            gpu,
            warmup: s.warmup,
            progress: s.progress,
            rounds,
            per_round,
            monitor_index,
        })
    }

    /// One monitor frame (`monitor_frame`) of the monitor point, ms.
    fn read_monitor(&self, planned: &[Planned]) -> Result<f64, GpuError> {
        let m = &planned[self.monitor_index];
        monitor_frame(self.gpu, &m.pipeline, m.mesh)
    }

    /// One batch: the timed frames of the points `which`, in interleaved rounds, a monitor
    /// frame after each point's frames; returns their segments and the monitor frames.
    /// Cheap points get more frames (a millisecond of jitter is 10 % of them), scaled by a
    /// known median or, failing that, by the batch's first round. `label` names its
    /// progress bar.
    pub(super) fn time_batch(
        &self,
        planned: &[Planned],
        which: &[usize],
        known_ms: &[f64],
        label: &str,
    ) -> Result<(Vec<Segmented>, Vec<f64>), GpuError> {
        let bar =
            crate::bake::progress_bar(self.progress, self.rounds as usize * which.len(), label);
        let mut timed = vec![Segmented::default(); which.len()];
        let mut before = self.read_monitor(planned)?;
        let mut monitor = vec![before];
        for round in 0..self.rounds {
            for (&i, t) in which.iter().zip(&mut timed) {
                let ms = if known_ms[i].is_finite() {
                    Some(known_ms[i])
                } else if round > 0 {
                    TimingStats::from_ms(&t.all()).map(|first| first.ms_median)
                } else {
                    None
                };
                // After the first round only the cheap points warm up again: on a fast GPU
                // their warm-up frame picks how many frames a timing query spans
                // (`gpu::pass`); an expensive point's pipeline is warm by then and its frame
                // is a query of its own either way (lavapipe: its medians within 1.5 % with
                // and without).
                let warmup = match ms {
                    _ if round == 0 => self.warmup,
                    Some(ms) if ms >= CHEAP_POINT_MS => 0,
                    _ => self.warmup.min(1),
                };
                let frames = match ms {
                    Some(ms) => {
                        let scale = (CHEAP_POINT_MS / ms).clamp(1.0, 20.0);
                        (f64::from(self.per_round) * scale).round() as u32
                    }
                    None => self.per_round,
                };
                let p = &planned[i];
                let got = self
                    .gpu
                    .time_pipeline_on(&p.pipeline, p.mesh, warmup, frames)?;
                let after = self.read_monitor(planned)?;
                t.push(p.build, before, got, after);
                monitor.push(after);
                before = after;
                bar.inc(1);
            }
        }
        bar.finish_and_clear();
        Ok((timed, monitor))
    }
}

/// The points to time again (`run_with_monitor`): those with fewer than
/// [`MIN_STATE_FRAMES`] frames in the [`sought_state`] from fewer than [`MIN_STATE_ROUNDS`]
/// rounds, and those `model` misses by more than [`RETIME_ERROR`] unless two of their
/// builds agree within [`BUILD_AGREEMENT`] — such a miss is the model's, which another
/// build would only repeat (a minimax fit's worst points sit near its largest error, 7–11 %
/// on this project's VM).
pub(super) fn missed_points(
    model: &CostModel,
    points: &[ProbePoint],
    timed: &[Segmented],
    states: &DeviceStates,
) -> Vec<usize> {
    (0..points.len())
        .filter(|&i| {
            let p = &points[i];
            needs_retime(predict_point(model, p), p.ms_median, &timed[i], states)
        })
        .collect()
}

/// Whether a point measured at `measured_ms` (in the main state), modelled at
/// `predicted_ms`, with the frames `timed`, is timed again ([`missed_points`]).
fn needs_retime(
    predicted_ms: f64,
    measured_ms: f64,
    timed: &Segmented,
    states: &DeviceStates,
) -> bool {
    let sought = sought_state(states);
    let (frames, rounds) = timed
        .0
        .iter()
        .filter(|s| states.ran_in(s, sought))
        .fold((0, 0), |(frames, rounds), s| {
            (frames + s.ms.len(), rounds + 1)
        });
    let unseen = frames < MIN_STATE_FRAMES && rounds < MIN_STATE_ROUNDS;
    let missed = (predicted_ms - measured_ms).abs() > RETIME_ERROR * measured_ms;
    let settled = timed.builds_agree_in(states, states.main_state, BUILD_AGREEMENT, 1);
    unseen || (missed && !settled)
}

/// The state whose frames the probe seeks: the fastest holding [`STATE_MODEL_SHARE`] of
/// the monitor frames (the main state where none does).
fn sought_state(states: &DeviceStates) -> usize {
    (0..states.count())
        .find(|&state| states.shares[state] >= STATE_MODEL_SHARE)
        .unwrap_or(states.main_state)
}

/// Times the `missed` points in one more batch, on pipelines built afresh; their segments
/// join theirs in `timed`, the batch's monitor frames `monitor`.
pub(super) fn retime(
    planner: &PointPlanner,
    batches: &Batches,
    planned: &mut [Planned],
    missed: &[usize],
    points: &[ProbePoint],
    timed: &mut [Segmented],
    monitor: &mut Vec<f64>,
) -> Result<(), GpuError> {
    let known: Vec<f64> = points.iter().map(|p| p.ms_median).collect();
    for &i in missed {
        let p = &planned[i];
        let (_, pipeline) = planner.plan(
            p.point.kind,
            p.point.count,
            p.point.in_untaken_branch,
            p.point.depth_test,
            p.mesh,
        )?;
        planned[i].pipeline = pipeline;
        planned[i].build += 1;
    }
    let (batch, batch_monitor) =
        batches.time_batch(planned, missed, &known, "probe frames (points timed again)")?;
    for (&i, t) in missed.iter().zip(batch) {
        timed[i].0.extend(t.0);
    }
    monitor.extend(batch_monitor);
    Ok(())
}

/// A monitor reading: one untimed frame of `pipeline` over `mesh` (the first frame after
/// heavy work runs slow, `states`), then one timed, ms (NaN without timestamps).
pub(super) fn monitor_frame(
    gpu: &SceneGpu,
    pipeline: &crate::gpu::MeshPipeline,
    mesh: &MeshBuffers,
) -> Result<f64, GpuError> {
    let ms = gpu.time_pipeline_on(pipeline, mesh, 1, 1)?;
    Ok(ms.first().copied().unwrap_or(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A device 74 % of the time in its fast state (3 ms monitor frames), 26 % in its slow one.
    fn two_states() -> DeviceStates {
        let mut monitor = vec![3.0; 74];
        monitor.extend([5.0; 26]);
        DeviceStates::from_monitor(&monitor)
    }

    #[test]
    fn only_the_fastest_common_state_is_sought() {
        let states = two_states();
        assert_eq!((states.count(), sought_state(&states)), (2, 0));
        // Five frames in the fast state, two in the slow one: enough.
        let mut seen = Segmented::default();
        for ms in [10.0, 10.1, 10.2, 10.1, 10.0] {
            seen.push(0, 3.0, vec![ms], 3.0);
        }
        seen.push(0, 5.0, vec![14.0], 5.0);
        seen.push(0, 5.0, vec![14.2], 5.0);
        assert!(!needs_retime(10.1, 10.1, &seen, &states));
        // Two rounds of two frames in the fast state (one beside a slow monitor frame):
        // timed again.
        let mut unseen = Segmented::default();
        unseen.push(0, 3.0, vec![10.0, 10.1], 3.0);
        unseen.push(0, 3.0, vec![10.2, 10.1], 3.0);
        unseen.push(0, 3.0, vec![10.0, 10.2], 5.0);
        assert_eq!(unseen.ran_in(&states, 0).len(), 4);
        assert!(needs_retime(10.1, 10.1, &unseen, &states));
        // Three rounds of one frame: enough.
        let mut three_rounds = Segmented::default();
        for ms in [40.0, 40.5, 40.2] {
            three_rounds.push(0, 3.0, vec![ms], 3.0);
        }
        three_rounds.push(0, 3.0, vec![40.1], 5.0);
        assert!(!needs_retime(40.2, 40.2, &three_rounds, &states));
    }

    #[test]
    fn a_miss_that_two_agreeing_builds_repeat_is_not_timed_again() {
        let states = two_states();
        let mut timed = Segmented::default();
        for ms in [10.0, 10.1, 10.2, 10.1, 10.0] {
            timed.push(0, 3.0, vec![ms], 3.0);
        }
        // Missed by 12 % on one build: timed again.
        assert!(needs_retime(11.3, 10.1, &timed, &states));
        // A second build within 10 % of the first: the miss is the model's.
        let mut agreeing = timed.clone();
        for ms in [10.6, 10.5, 10.7] {
            agreeing.push(1, 3.0, vec![ms], 3.0);
        }
        assert!(!needs_retime(11.3, 10.1, &agreeing, &states));
        // A second build 25 % slower than the first: one of them is odd, timed again.
        let mut odd = timed;
        for ms in [12.6, 12.5, 12.7] {
            odd.push(1, 3.0, vec![ms], 3.0);
        }
        assert!(needs_retime(11.3, 10.1, &odd, &states));
        // Within the error: not timed again whatever the builds.
        assert!(!needs_retime(10.5, 10.1, &odd, &states));
    }
}
