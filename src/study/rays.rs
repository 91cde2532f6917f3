//! `shvis study rays`: each lightmap basis' error against the rays a texel's bake traces
//! and against the bytes it stores — where each basis stops improving.
//!
//! # What is measured
//!
//! For each ray count N (the bake's shared direction set, `bake::directions`), the scene
//! is prepared with N rays per texel — the SH lightmap baked with inter-reflection and
//! every tangent-frame basis fitted from each texel's N samples (`--basis-fit samples`,
//! `sh::samples`) or from its order-3 SH (`l2`) — and each row is rendered on each path.
//! Its error is the bench's: the relative RMSE of the row's image against the
//! inter-reflected footprint reference (`crate::reference`), the same truth for every N
//! and every row,
//!
//! ```text
//! e(row, N) = √(Σ_p |I_row,N(p) − I_ref(p)|²) / √(Σ_p |I_ref(p)|²)                 (1)
//! ```
//!
//! over the covered pixels (`crate::bench`). Bytes per texel are the row's lightmap bytes
//! over the lightmap's texels (on dx11, after block compression). The error ladder is left
//! out (its per-pixel gather would trace N rays from every pixel); the bench gives it at
//! one N.
//!
//! A row "stops improving" at the smallest N whose error is within [`PLATEAU`] of its
//! error at the largest N: past it the error is the basis' (and the lightmap's), not the
//! samples'.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use crate::bench::{BenchError, BenchSettings};
use crate::gpu::Context;
use crate::prepare::{PrepareError, PrepareSettings, prepare, sample_fits_for};

/// Ray counts the study bakes by default.
pub const DEFAULT_RAY_COUNTS: &[u32] = &[64, 256, 1024, 4096];

/// One row at one ray count.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RaysRow {
    pub technique: String,
    pub path: String,
    pub rays: u32,
    /// (1), against the inter-reflected footprint reference.
    pub rel_rmse: f64,
    pub bytes_per_texel: f64,
}

/// One bake of the study.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RaysBake {
    pub rays: u32,
    /// Every bake of the preparation (visibility, SH lightmap and its fits), seconds.
    pub seconds: f64,
}

/// The study's results.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RaysStudy {
    pub scene: String,
    pub env: String,
    pub vis_res: u32,
    pub basis_fit: String,
    /// What the bake's escaped rays read of the environment (`--bake-env`).
    pub bake_env: String,
    pub bounces: u32,
    pub rows: Vec<RaysRow>,
    pub bakes: Vec<RaysBake>,
}

#[derive(Debug, thiserror::Error)]
pub enum RaysStudyError {
    #[error(transparent)]
    Prepare(#[from] PrepareError),
    #[error(transparent)]
    Technique(#[from] crate::technique::TechniqueError),
    #[error(transparent)]
    Bench(#[from] BenchError),
    #[error("{0}")]
    Report(String),
}

/// Runs the study: for each of `ray_counts`, `prepare_settings` with that many rays (its
/// sample fits for `bench.techniques`), then the bench of `bench` (probe and ladder off)
/// into `bench.out`/`rays-N`. `say` reports progress, one line per ray count.
///
/// # Errors
/// A bake, a row or a write that fails.
pub fn run(
    ctx: &Arc<Context>,
    prepare_settings: &PrepareSettings,
    bench: &BenchSettings,
    ray_counts: &[u32],
    say: &mut dyn FnMut(&str),
) -> Result<RaysStudy, RaysStudyError> {
    let mut study = RaysStudy {
        scene: prepare_settings.scene.clone(),
        env: prepare_settings.env.clone(),
        vis_res: prepare_settings.vis_res,
        basis_fit: prepare_settings.options.AmbientCube.to_string(),
        bake_env: prepare_settings.bake_env.to_string(),
        bounces: bench.bounces,
        rows: Vec::new(),
        bakes: Vec::new(),
    };
    let texels = f64::from(prepare_settings.vis_res).powi(2);
    for (i, &rays) in ray_counts.iter().enumerate() {
        let started = Instant::now();
        let settings = PrepareSettings {
            rays,
            sample_fits: sample_fits_for(&bench.techniques, &prepare_settings.options),
            ..prepare_settings.clone()
        };
        let mut prepared = prepare(&settings)?;
        prepared.prepare_techniques(&bench.techniques)?;
        study.bakes.push(RaysBake {
            rays,
            seconds: started.elapsed().as_secs_f64(),
        });
        let out = bench.out.join(format!("rays-{rays}"));
        std::fs::create_dir_all(&out)
            .map_err(|e| RaysStudyError::Report(format!("{}: {e}", out.display())))?;
        let table = crate::bench::run(
            ctx,
            &prepared,
            &BenchSettings {
                out,
                probe: false,
                ladder: false,
                ladder_stride: 1,
                ..bench.clone()
            },
        )?;
        for row in &table.results {
            let Some(rel_rmse) = row.rel_rmse_bounced.or(row.rel_rmse) else {
                continue;
            };
            study.rows.push(RaysRow {
                technique: row.technique.name(),
                path: row.path.to_string(),
                rays,
                rel_rmse,
                bytes_per_texel: row.texel_bytes as f64 / texels,
            });
        }
        say(&format!(
            "study rays: [{}/{}] {rays} rays per texel in {:.1} s",
            i + 1,
            ray_counts.len(),
            started.elapsed().as_secs_f64()
        ));
    }
    Ok(study)
}

/// The report: a table of e(row, N) per path, bytes per texel, the bakes' time, and for
/// each row the ray count past which quadrupling the rays changes its error by less than
/// `plateau` (relative).
pub fn markdown(study: &RaysStudy) -> String {
    let mut md = format!(
        "# Error against rays per texel: {} under `{}`\n\n\
         Each row's relative RMSE against the inter-reflected footprint reference ({} \
         bounces), the lightmap baked at {}² texels with N rays per texel; tangent-frame \
         bases fitted from `{}`; escaped rays read the environment's `{}` (`--bake-env`). \
         Bytes per texel: the row's lightmap bytes over its texels.\n\n",
        study.scene, study.env, study.bounces, study.vis_res, study.basis_fit, study.bake_env
    );
    let counts = ray_counts(study);
    for path in paths(study) {
        md.push_str(&format!("## {path}\n\n| row | bytes/texel |"));
        for n in &counts {
            md.push_str(&format!(" N = {n} |"));
        }
        md.push_str(" stops improving at |\n|---|---:|");
        md.push_str(&"---:|".repeat(counts.len() + 1));
        md.push('\n');
        for technique in techniques(study) {
            let rows: Vec<&RaysRow> = study
                .rows
                .iter()
                .filter(|r| r.path == path && r.technique == technique)
                .collect();
            let Some(first) = rows.first() else {
                continue;
            };
            md.push_str(&format!("| {technique} | {:.1} |", first.bytes_per_texel));
            for n in &counts {
                match rows.iter().find(|r| r.rays == *n) {
                    Some(r) => md.push_str(&format!(" {:.4} |", r.rel_rmse)),
                    None => md.push_str(" — |"),
                }
            }
            md.push_str(&format!(" {} |\n", plateau_text(&rows)));
        }
        md.push('\n');
    }
    md.push_str("## Bakes\n\n| rays per texel | seconds (all bakes) |\n|---:|---:|\n");
    for b in &study.bakes {
        md.push_str(&format!("| {} | {:.1} |\n", b.rays, b.seconds));
    }
    md.push_str(&format!(
        "\n\"Stops improving at N\": the smallest N whose error is within {:.0} % of the \
         error at the largest N.\n",
        100.0 * PLATEAU
    ));
    md
}

/// How close to the last error counts as stopped (relative).
pub const PLATEAU: f64 = 0.01;

fn plateau_text(rows: &[&RaysRow]) -> String {
    let Some(last) = rows.iter().max_by_key(|r| r.rays) else {
        return "—".into();
    };
    let mut sorted: Vec<&&RaysRow> = rows.iter().collect();
    sorted.sort_by_key(|r| r.rays);
    sorted
        .iter()
        .find(|r| (r.rel_rmse - last.rel_rmse).abs() <= PLATEAU * last.rel_rmse)
        .map_or_else(|| "—".into(), |r| r.rays.to_string())
}

fn ray_counts(study: &RaysStudy) -> Vec<u32> {
    let mut counts: Vec<u32> = study.rows.iter().map(|r| r.rays).collect();
    counts.sort_unstable();
    counts.dedup();
    counts
}

fn paths(study: &RaysStudy) -> Vec<String> {
    distinct(study.rows.iter().map(|r| &r.path))
}

fn techniques(study: &RaysStudy) -> Vec<String> {
    distinct(study.rows.iter().map(|r| &r.technique))
}

/// The distinct values of `values`, in first-seen order.
fn distinct<'a>(values: impl Iterator<Item = &'a String>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for v in values {
        if !out.contains(v) {
            out.push(v.clone());
        }
    }
    out
}

/// Writes rays.md, rays.json and the plots (rays.svg/.png: error against N per path, and
/// error against bytes per texel) into `dir`.
///
/// # Errors
/// A file that cannot be written.
pub fn write(study: &RaysStudy, dir: &Path) -> Result<Vec<PathBuf>, RaysStudyError> {
    let json = super::report::pretty_json(dir, "rays", study)
        .map_err(|e| RaysStudyError::Report(e.to_string()))?;
    let mut written = super::report::write(
        dir,
        &super::report::StudyReport {
            stem: "rays".into(),
            markdown: markdown(study),
            json: Some(json),
        },
    )
    .map_err(|e| RaysStudyError::Report(e.to_string()))?;
    written.extend(write_plot(study, dir).map_err(RaysStudyError::Report)?);
    Ok(written)
}

fn write_plot(study: &RaysStudy, dir: &Path) -> Result<Vec<PathBuf>, String> {
    use crate::report::plot::{register_plot_font, write_png_plot, write_svg_plot};
    register_plot_font()?;
    let svg = dir.join("rays.svg");
    let png = dir.join("rays.png");
    let size = (1100, 460 * paths(study).len().max(1) as u32);
    write_svg_plot(&svg, size, |root| draw(root, study))?;
    write_png_plot(&png, size, |root| draw(root, study))?;
    Ok(vec![svg, png])
}

/// Per path: error against log₂ N (left) and against bytes per texel (right), a line per
/// row.
fn draw<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    study: &RaysStudy,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let err = |e: &dyn std::fmt::Debug| format!("{e:?}");
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let paths = paths(study);
    let techniques = techniques(study);
    let counts = ray_counts(study);
    let (lo, hi) = (
        counts.first().copied().unwrap_or(1).max(1) as f64,
        counts.last().copied().unwrap_or(1).max(1) as f64,
    );
    let top = study.rows.iter().map(|r| r.rel_rmse).fold(0.0, f64::max) * 1.1;
    let bottom = study.rows.iter().map(|r| r.rel_rmse).fold(top, f64::min) * 0.9;
    let max_bytes = study
        .rows
        .iter()
        .map(|r| r.bytes_per_texel)
        .fold(1.0, f64::max)
        * 1.1;
    let rows_of = root.split_evenly((paths.len().max(1), 2));
    for (p, path) in paths.iter().enumerate() {
        for panel in 0..2 {
            let area = &rows_of[2 * p + panel];
            let mut builder = ChartBuilder::on(area);
            builder
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(56);
            let (caption, x_desc) = if panel == 0 {
                (format!("{path}: error against rays per texel"), "log₂ N")
            } else {
                (
                    format!("{path}: error against bytes per texel"),
                    "bytes per texel",
                )
            };
            builder.caption(caption, ("sans-serif", 16));
            let x_range = if panel == 0 {
                lo.log2() - 0.2..hi.log2() + 0.2
            } else {
                0.0..max_bytes
            };
            let mut chart = builder
                .build_cartesian_2d(x_range, bottom..top)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_desc("rel. RMSE")
                .draw()
                .map_err(|e| err(&e))?;
            for (i, technique) in techniques.iter().enumerate() {
                let colour = Palette99::pick(i).to_rgba();
                let points: Vec<(f64, f64)> = study
                    .rows
                    .iter()
                    .filter(|r| &r.path == path && &r.technique == technique)
                    .map(|r| {
                        let x = if panel == 0 {
                            f64::from(r.rays).log2()
                        } else {
                            r.bytes_per_texel
                        };
                        (x, r.rel_rmse)
                    })
                    .collect();
                if points.is_empty() {
                    continue;
                }
                let series = chart
                    .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                    .map_err(|e| err(&e))?;
                if panel == 0 {
                    series
                        .label(technique.clone())
                        .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
                }
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(|e| err(&e))?;
            }
            if panel == 0 {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .draw()
                    .map_err(|e| err(&e))?;
            }
        }
    }
    root.present().map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(technique: &str, rays: u32, rel_rmse: f64) -> RaysRow {
        RaysRow {
            technique: technique.into(),
            path: "dx10".into(),
            rays,
            rel_rmse,
            bytes_per_texel: 24.0,
        }
    }

    #[test]
    fn the_plateau_is_the_first_count_within_a_percent_of_the_last() {
        let rows = [
            row("hb4", 64, 0.40),
            row("hb4", 256, 0.30),
            row("hb4", 1024, 0.2515),
            row("hb4", 4096, 0.25),
        ];
        let refs: Vec<&RaysRow> = rows.iter().collect();
        assert_eq!(plateau_text(&refs), "1024");
        let falling = [row("sg9", 64, 0.5), row("sg9", 4096, 0.2)];
        let refs: Vec<&RaysRow> = falling.iter().collect();
        assert_eq!(plateau_text(&refs), "4096");
    }

    #[test]
    fn the_report_has_a_column_per_ray_count_and_a_row_per_technique() {
        let study = RaysStudy {
            scene: "house".into(),
            env: "sky".into(),
            vis_res: 128,
            basis_fit: "samples".into(),
            bake_env: "sh".into(),
            bounces: 2,
            rows: vec![
                row("hb4", 64, 0.4),
                row("hb4", 256, 0.3),
                row("dice", 64, 0.35),
            ],
            bakes: vec![],
        };
        let md = markdown(&study);
        assert!(md.contains("| row | bytes/texel | N = 64 | N = 256 | stops improving at |"));
        assert!(
            md.contains("| hb4 | 24.0 | 0.4000 | 0.3000 | 256 |"),
            "{md}"
        );
        assert!(md.contains("| dice | 24.0 | 0.3500 | — | 64 |"), "{md}");
    }
}
