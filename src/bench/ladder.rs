//! The error ladder of a bench's rows (`crate::attribution`): footprint → point reference,
//! the technique's CPU rungs, then the GPU image, each step's relative RMSE a column of the
//! row and each rung an image under `ladder/`.

use std::sync::Arc;

use super::references::{References, reference_for, reference_stem};
use super::{BenchError, BenchSettings};
use crate::attribution::{LadderPixels, cpu_rungs};
use crate::gpu::Context;
use crate::prepare::Prepared;
use crate::render::Frame;
use crate::report::bench_output::BenchOutput;
use crate::report::metrics::image_error;
use crate::report::table::{AttributionKind, AttributionStep, ladder_grid_words};
use crate::technique::{HwPath, Technique};

/// The error ladder's per-pixel data of the CPU rungs, where the bench has a ladder.
pub(super) struct Ladder {
    pixels: Option<LadderPixels>,
}

impl Ladder {
    /// The ladder of a bench where it runs ([`BenchSettings::ladder_runs`]) and has its
    /// point reference; the reason logged where it is left out.
    pub(super) fn new(
        ctx: &Arc<Context>,
        prepared: &Prepared,
        settings: &BenchSettings,
        references: Option<&References>,
        out: &BenchOutput,
    ) -> Result<Ladder, BenchError> {
        let specular = settings.specular.is_some();
        let pixels = match references.and_then(|r| r.point.as_ref()) {
            Some(_) if settings.ladder_runs(specular) => {
                Some(ladder_pixels(ctx, prepared, settings, out)?)
            }
            Some(_) if settings.relight_degrees.is_some() => {
                log::info!(
                    "error ladder: left out when relit (its CPU rungs use the bake's lighting)"
                );
                None
            }
            Some(_) if specular => {
                log::info!("error ladder: left out with --specular (its CPU rungs are diffuse)");
                None
            }
            _ => None,
        };
        Ok(Ladder { pixels })
    }

    /// Every how many pixels in each direction the ladder evaluates one; `None` without
    /// a ladder.
    pub(super) fn stride(&self) -> Option<u32> {
        self.pixels.as_ref().map(LadderPixels::stride)
    }
}

/// Renders the point G-buffer and traces the per-pixel visibility of the ladder.
fn ladder_pixels(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    settings: &BenchSettings,
    out: &BenchOutput,
) -> Result<LadderPixels, BenchError> {
    let pixels = LadderPixels::new(
        ctx,
        prepared,
        settings.width,
        settings.height,
        settings.ladder_stride,
    )?;
    log::info!(
        "error ladder: {} pixels ({}), visibility traced per pixel ({} rays) and exact lighting tabulated in {:.1} s",
        pixels.len(),
        ladder_grid_words(pixels.stride()),
        pixels.rays_traced(),
        pixels.seconds
    );
    out.ladder_folder()?;
    Ok(pixels)
}

/// The attribution ladder of a row (`crate::attribution`): footprint → point reference,
/// the technique's CPU rungs (written to `ladder/`), then the GPU image `frame`; without
/// CPU rungs it steps from the point reference to the image.
#[allow(clippy::too_many_arguments)]
pub(super) fn attribution(
    prepared: &Prepared,
    technique: Technique,
    path: HwPath,
    frame: &Frame,
    references: Option<&References>,
    ladder: &Ladder,
    settings: &BenchSettings,
    out: &mut BenchOutput,
) -> Result<Vec<AttributionStep>, BenchError> {
    let Some((r, Some(point))) = references.map(|r| (r, r.point.as_ref())) else {
        return Ok(vec![]);
    };
    if settings.specular.is_some() {
        return Ok(vec![]);
    }
    let (footprint, _) = reference_for(technique, &r.main);
    let (point, kind) = reference_for(technique, point);
    // With CPU rungs, every step is measured at the ladder's grid of pixels.
    let grid = ladder.pixels.as_ref();
    let at_grid = |f: &Frame| grid.map(|px| px.pick(f));
    let (footprint_grid, point_grid, frame_grid) =
        (at_grid(footprint), at_grid(point), at_grid(frame));
    let footprint = footprint_grid.as_ref().unwrap_or(footprint);
    let point = point_grid.as_ref().unwrap_or(point);
    let frame = frame_grid.as_ref().unwrap_or(frame);
    let rel = |a: &Frame, b: &Frame| image_error(a, b).map(|e| e.rel_rmse);
    let mut steps = vec![AttributionStep {
        step: AttributionKind::PixelFootprint,
        rel_rmse: rel(point, footprint),
        image: format!("{}.exr", reference_stem("reference_point", kind)),
    }];
    let rungs = match &ladder.pixels {
        Some(pixels) => {
            let start = std::time::Instant::now();
            let rungs = cpu_rungs(pixels, prepared, technique, path)?;
            log::info!(
                "error ladder of {technique}.{path}: {} CPU rungs in {:.1} s",
                rungs.len(),
                start.elapsed().as_secs_f64()
            );
            rungs
        }
        None => vec![],
    };
    let mut previous = point;
    for rung in &rungs {
        let image = out.rung(&rung.stem, &rung.frame)?;
        steps.push(AttributionStep {
            step: rung.step,
            rel_rmse: rel(&rung.frame, previous),
            image,
        });
        previous = &rung.frame;
    }
    let mut sheet: Vec<(String, &Frame)> = vec![
        ("reference".into(), footprint),
        ("point reference".into(), point),
    ];
    sheet.extend(rungs.iter().map(|r| (r.step.name().to_string(), &r.frame)));
    sheet.push(("GPU".into(), frame));
    out.ladder_sheet(technique, path, &sheet);
    steps.push(AttributionStep {
        step: if rungs.is_empty() {
            AttributionKind::Technique
        } else {
            AttributionKind::Gpu
        },
        rel_rmse: rel(frame, previous),
        image: format!("{technique}.{path}.exr"),
    });
    Ok(steps)
}
