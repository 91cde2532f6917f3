//! A bench's rows: which it keeps on a given scene, and the first timing round — each
//! technique × path built, timed, drawn, written and measured against its reference.

use std::sync::Arc;

use super::ladder::{Ladder, attribution};
use super::references::{References, reference_for};
use super::timing::timed_segments;
use super::{BenchError, BenchSettings, Clock, Relit};
use crate::gpu::{Context, TimingStats};
use crate::prepare::Prepared;
use crate::probe::states::Segment;
use crate::probe::{Monitor, Segmented};
use crate::render::specular::NormalFilter;
use crate::render::{Frame, SceneGpu};
use crate::report::bench_output::BenchOutput;
use crate::report::figures::FIGURES;
use crate::report::metrics::{image_error, suspect_reason};
use crate::report::table::{BenchRow, RowReference};
use crate::technique::{self, HwPath, Technique, TechniqueError};

/// Removes from `techniques` the rows that need a height map when `prepared`'s scene has
/// none (named on their own they fail with the reason instead); returns those removed.
pub fn drop_rows_without_height_map(
    techniques: &mut Vec<Technique>,
    prepared: &Prepared,
) -> Vec<Technique> {
    if prepared.ssbump.is_some() {
        return Vec::new();
    }
    let (kept, dropped): (Vec<Technique>, Vec<Technique>) =
        techniques.iter().partition(|t| !t.needs().ssbump);
    *techniques = kept;
    dropped
}

/// The first timing round over every technique × path (× specular filtering, each bound to
/// the scene in turn): each row built, timed (`per_round` frames), drawn, written and
/// measured; then the paper's figures from the first filtering's images. Returns the rows
/// and their frame times so far.
#[allow(clippy::too_many_arguments)]
pub(super) fn measure_rows(
    ctx: &Arc<Context>,
    scene: &mut SceneGpu,
    prepared: &Prepared,
    relit: Option<&Relit>,
    references: Option<&References>,
    ladder: &Ladder,
    settings: &BenchSettings,
    per_round: u32,
    monitor: Option<&Monitor>,
    clock: &mut Clock,
    out: &mut BenchOutput,
) -> Result<(Vec<BenchRow>, Vec<Segmented>), BenchError> {
    let filters: Vec<Option<NormalFilter>> = match &settings.specular {
        Some(s) => s.filters.iter().copied().map(Some).collect(),
        None => vec![None],
    };
    let mut rows = Vec::new();
    // Every row's frame times so far, in segments between monitor frames (the later timing
    // rounds add to them).
    let mut samples: Vec<Segmented> = Vec::new();
    // The images the figures need, kept until they are drawn (the first filtering's).
    let mut figure_frames = std::collections::HashMap::new();
    for (k, &filter) in filters.iter().enumerate() {
        if let (Some(filter), Some(s)) = (filter, &settings.specular) {
            scene.add_specular(ctx, &prepared.scene, s.term(filter))?;
        }
        let rows_of = RowTechniques {
            ctx,
            scene,
            prepared,
            relit,
        };
        for &technique in &settings.techniques {
            for &path in &settings.paths {
                if !settings.measures(technique, path) {
                    if let (0, Err(why)) = (k, technique.form_on(path)) {
                        log::info!("{technique}.{path}: left out ({why})");
                    }
                    continue;
                }
                clock
                    .progress
                    .step(&format!("{technique}.{path}: built, timed, measured"));
                let measured = measure_row(
                    &rows_of, technique, path, references, ladder, settings, per_round, monitor,
                    clock, out,
                );
                let (row, frame, segments) = match measured {
                    // The specular term's moment maps can take a dx9 draw past its textures.
                    Err(BenchError::Technique(e @ TechniqueError::Dx9Rule { .. }))
                        if filter.is_some() =>
                    {
                        log::warn!("{e} (with the specular term): row left out");
                        continue;
                    }
                    other => other?,
                };
                rows.push(row);
                samples.push(Segmented(segments));
                if k == 0
                    && FIGURES
                        .iter()
                        .any(|f| f.techniques().any(|t| t == technique))
                {
                    figure_frames.insert((technique, path), frame);
                }
            }
        }
    }
    for &path in &settings.paths {
        out.figures(path, references.map(|r| &r.main.frame), &|t| {
            figure_frames.get(&(t, path))
        });
    }
    Ok((rows, samples))
}

/// What every row's technique is built from: the device, the scene on it, the bake, and
/// the turned light when the bench relights.
pub(super) struct RowTechniques<'a> {
    pub ctx: &'a Arc<Context>,
    pub scene: &'a SceneGpu,
    pub prepared: &'a Prepared,
    pub relit: Option<&'a Relit>,
}

impl RowTechniques<'_> {
    /// One row's technique, built for the bench's lighting (relit through
    /// `update_lighting` when the bench turns the light and the technique can follow).
    pub(super) fn build(
        &self,
        technique: Technique,
        path: HwPath,
    ) -> Result<technique::TechniqueGpu, BenchError> {
        let (ctx, scene, inputs) = (self.ctx, self.scene, self.prepared.inputs());
        Ok(match self.relit {
            Some(relit) if technique.dynamic_lighting() => {
                let (mut tech, recipe) =
                    technique::build_dynamic(ctx, scene, technique, path, &inputs)?;
                let data = recipe.build(&relit.radiance_sh, &relit.irradiance_sh)?;
                tech.update_lighting(&data)?;
                tech.wait_for_upload()?;
                tech
            }
            _ => technique::build(ctx, scene, technique, path, &inputs)?,
        })
    }
}

/// Builds, times (the first of the timing rounds: `frames`), writes and measures one
/// technique × path; returns its row, image and timed segments.
#[allow(clippy::too_many_arguments)]
fn measure_row(
    rows_of: &RowTechniques<'_>,
    technique: Technique,
    path: HwPath,
    references: Option<&References>,
    ladder: &Ladder,
    settings: &BenchSettings,
    frames: u32,
    monitor: Option<&Monitor>,
    clock: &mut Clock,
    out: &mut BenchOutput,
) -> Result<(BenchRow, Frame, Vec<Segment>), BenchError> {
    let (scene, prepared) = (rows_of.scene, rows_of.prepared);
    let tech = rows_of.build(technique, path)?;
    let costs = technique::cost::counts(rows_of.ctx, scene, &tech)?;
    clock.split(|p| &mut p.build);
    let segments = timed_segments(monitor, 0, settings.warmup, frames, |w, n| {
        tech.time(scene, w, n)
    })?;
    // The image: one more frame, read back (its time is not kept).
    let frame = tech.render(scene, 0, 1)?;
    #[cfg(feature = "test-hooks")]
    let frame = plant_absurd_row(&tech.label(), frame);
    let frame_ms: Vec<f64> = segments.iter().flat_map(|s| s.ms.iter().copied()).collect();
    clock.split(|p| &mut p.render);
    let specular = scene.specular().map(|s| s.term.filter);
    let label = match specular {
        Some(f) => format!("{}.spec{}", tech.label(), f.name()),
        None => tech.label(),
    };
    let timing = TimingStats::from_ms(&frame_ms);
    let (reference_frame, reference_kind) = match references {
        Some(r) => {
            let (f, kind) = reference_for(technique, &r.main);
            (Some(f), kind)
        }
        None => (None, RowReference::None),
    };
    let error = reference_frame.and_then(|r| image_error(&frame, r));
    if let (RowReference::Bounced(_), Some(r)) = (reference_kind, references)
        && let Some(e) = image_error(&frame, &r.main.frame)
    {
        log::info!(
            "{label}: relative RMSE against the direct-only reference {:.4}",
            e.rel_rmse
        );
    }
    // Every row against the inter-reflected reference too, where there is one: the
    // comparison of techniques with and without inter-reflection on one ground truth.
    let rel_rmse_bounced = match (reference_kind, references) {
        (RowReference::Bounced(_), _) => error.map(|e| e.rel_rmse),
        (_, Some(r)) => r
            .main
            .bounced
            .as_ref()
            .and_then(|b| image_error(&frame, &b.frame))
            .map(|e| e.rel_rmse),
        (_, None) => None,
    };
    out.row(&label, &frame, reference_frame)?;
    // The share of the screen covered; the model uses the scene's shaded fragments (`run`).
    let covered = frame.rgba.iter().filter(|p| p[3] > 0.5).count();
    clock.split(|p| &mut p.row_images);
    let attribution = attribution(
        prepared, technique, path, &frame, references, ladder, settings, out,
    )?;
    clock.split(|p| &mut p.ladder);
    let row = BenchRow {
        technique,
        path,
        specular,
        cost: costs.done,
        untaken_cost: costs.untaken,
        coverage: covered as f64 / frame.rgba.len().max(1) as f64,
        own_mesh_load: if settings.probe {
            technique::vertex::own_mesh_load(rows_of.ctx, scene, technique, &prepared.inputs())?
        } else {
            None
        },
        triangles: tech.triangle_count(scene),
        edge_pixels: 0.0,
        model_ms: None,
        x_model: None,
        model_state: None,
        model_state_frames: None,
        ms_median: timing.map(|s| s.ms_median),
        ms_min: timing.map(|s| s.ms_min),
        ms_max: timing.map(|s| s.ms_max),
        frames: frame_ms.len(),
        rel_rmse: error.map(|e| e.rel_rmse),
        rel_rmse_bounced,
        psnr: error.map(|e| e.psnr),
        texel_bytes: tech.stats.texel_bytes,
        table_bytes: tech.stats.table_bytes,
        textures_bound: tech.stats.textures_bound,
        lookups_per_pixel: tech.stats.lookups_per_pixel,
        ratio_to_preconv: None,
        // The paper measured its techniques uncompressed (DX9- and DX10-class cards).
        paper_ms: (path != HwPath::Dx11)
            .then(|| technique.paper_ms())
            .flatten(),
        paper_ratio_to_preconv: (path != HwPath::Dx11)
            .then(|| technique.paper_ratio_to_preconv())
            .flatten(),
        reference: reference_kind,
        attribution,
        clipped_pixels: frame.clipped_pixels(),
        suspect: suspect_reason(&frame, reference_frame, error.map(|e| e.rel_rmse)),
    };
    if let Some(why) = &row.suspect {
        log::warn!("{label}: suspect row: {why}");
    }
    if row.clipped_pixels > 0 {
        log::warn!(
            "{label}: {} pixels clipped at the f16 target's 65504 (or not finite); the row is marked",
            row.clipped_pixels
        );
    }
    Ok((row, frame, segments))
}

/// Test hook of the `test-hooks` feature, not a user setting: the environment variable that
/// plants an absurd row, for the tests of the suspect marker and `--strict`
/// (`tests/suspect.rs`): `technique.path`, whose image is scaled ×100.
#[cfg(feature = "test-hooks")]
pub const PLANT_ABSURD_ROW_ENV: &str = "SHVIS_PLANT_ABSURD_ROW";

/// `frame`, its image scaled ×100 when [`PLANT_ABSURD_ROW_ENV`] names `label` (feature
/// `test-hooks`).
#[cfg(feature = "test-hooks")]
fn plant_absurd_row(label: &str, mut frame: Frame) -> Frame {
    if std::env::var(PLANT_ABSURD_ROW_ENV).is_ok_and(|v| v == label) {
        log::warn!("{label}: image scaled ×100 ({PLANT_ABSURD_ROW_ENV})");
        for p in &mut frame.rgba {
            for c in &mut p[..3] {
                *c *= 100.0;
            }
        }
    }
    frame
}
