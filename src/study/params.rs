//! Iwanicki–Sloan App. A, "Choice of Spherical Parameterization" (Figure 8): the mean
//! squared error of storing SH basis functions in each of the four parameterizations of
//! [`crate::sphere`] and reconstructing them with hardware bilinear filtering, as a function
//! of the total number of texels ("samples").
//!
//! # Experiment
//!
//! For each [`Parameterization`], each resolution of [`resolutions`] and SH order
//! n ∈ {3, 6} (DESIGN §1: bands l < n):
//!
//! 1. store every basis function y_i, i < n², at the texel centres
//!    ([`SphereMap::texel_center_dir`]) — one single-channel texture per function;
//! 2. reconstruct each at the same N directions ω_k, uniform on the sphere (fixed seed;
//!    [`study_directions`]), with the map's bilinear filter ([`SphereMap::bilinear_taps`]);
//! 3. MSE(kind, res, n) = 1/(n²·N) · Σ_{i<n²} Σ_k (ŷ_i(ω_k) − y_i(ω_k))² — the squared error
//!    averaged over the directions *and* over the n² basis functions of the order, with
//!    equal weight per function. Each y_i has unit L² norm on the sphere (mean square
//!    1/4π), so MSE·4π is the error relative to the signal.
//!
//! Resolutions ([`CUBE_RES`], [`DUAL_RES`]) are chosen so that the x axis overlaps: a dual
//! map of res round(√3·r) has 2·res² ≈ 6·r² samples, the cube's count at res r (within 8%).
//! The comparison "at equal sample count" in [`summary_markdown`] interpolates each curve
//! linearly in log–log at common sample counts rather than relying on that match.
//!
//! # Cost
//!
//! One pass over the directions in chunks ([`CHUNK`], rayon-parallel): per chunk the order-6
//! basis is evaluated once (order 3 is its first 9 functions, so one evaluation and one
//! table per map serve both orders), and per map and direction the four taps are computed
//! once and applied to all 36 functions of a texel-major table (36 contiguous f64 per
//! texel). Per-chunk sums are reduced in chunk order, so the result does not depend on the
//! thread count. Memory: ~2 MB of basis values per chunk and ≲ 40 MB of tables.
//!
//! Expected shape (bilinear interpolation of a smooth function): error O(h²), MSE ∝ h⁴ ∝
//! samples⁻²; a seam (per-face `cube-dx9`) adds O(h) errors in an O(h)-wide band,
//! MSE ∝ h³ ∝ samples⁻¹·⁵, so it loses more ground as resolution grows. Tests:
//! `study_is_deterministic_and_orders_kinds` below; the full run is `shvis study params`.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::DVec3;
use rayon::prelude::*;

use super::report::{StudyReport, StudyReportError};
use crate::sh::Order;
use crate::sh::basis::eval_basis;
use crate::sphere::{Parameterization, SphereMap};

/// The SH orders of Figure 8.
pub const ORDERS: [Order; 2] = [Order::THREE, Order::SIX];
/// Cube resolutions (texels per face side); 6·r² samples, 96 … 24 576.
pub const CUBE_RES: [u32; 13] = [4, 5, 6, 8, 10, 12, 16, 20, 24, 32, 40, 48, 64];
/// Dual-map resolutions (per hemisphere side): round(√3·r) for r in [`CUBE_RES`], so
/// 2·res² matches the cubes' 6·r² within 8% (98 … 24 642).
pub const DUAL_RES: [u32; 13] = [7, 9, 10, 14, 17, 21, 28, 35, 42, 55, 69, 83, 111];
/// Directions of the paper's experiment ("one million points over the sphere").
pub const DEFAULT_DIRECTIONS: usize = 1_000_000;
/// Seed used by `shvis study params` unless `--seed` is given.
pub const DEFAULT_SEED: u64 = 0x5ee0_a00a;
/// Directions per parallel work item: 2048 × 36 f64 basis values = 576 KiB.
pub const CHUNK: usize = 2048;

/// Largest number of coefficients needed (order 6).
const COEFFS: usize = 36;

/// Errors writing the study's outputs; each message names the file.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// Creating or writing a file failed.
    #[error("{}: cannot write", .path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// Drawing a plot failed (e.g. no usable font for the PNG text).
    #[error("{}: cannot draw plot: {message}", .path.display())]
    Plot {
        /// The plot file.
        path: PathBuf,
        /// What plotters reported.
        message: String,
    },
    /// The GPU half of the study failed.
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
}

/// One point of Figure 8: the MSE of one parameterization at one resolution and order.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StudyPoint {
    /// The parameterization.
    pub parameterization: Parameterization,
    /// SH order n (bands l < n, n² basis functions averaged).
    pub order: u32,
    /// Texels per hemisphere side / cube face side.
    pub res: u32,
    /// Total texels, 2·res² or 6·res² (the x axis).
    pub samples: usize,
    /// Mean squared error over the basis functions and directions (module doc).
    pub mse: f64,
}

/// The study's resolutions for `kind`: [`CUBE_RES`] or [`DUAL_RES`].
pub fn resolutions(kind: Parameterization) -> &'static [u32] {
    if kind.is_cube() { &CUBE_RES } else { &DUAL_RES }
}

/// `n` directions uniform on the unit sphere from SplitMix64 (Steele et al. 2014) seeded
/// with `seed`: z = 1 − 2u, φ = 2πv (Archimedes: z is uniform for uniform area).
pub fn study_directions(n: usize, seed: u64) -> Vec<DVec3> {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut x = state;
        x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        // Top 53 bits → [0, 1).
        ((x ^ (x >> 31)) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    };
    (0..n)
        .map(|_| {
            let z = 1.0 - 2.0 * next();
            let phi = std::f64::consts::TAU * next();
            let s = ((1.0 - z) * (1.0 + z)).max(0.0).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), z)
        })
        .collect()
}

/// Runs the App. A experiment with `directions` random directions (the paper: 10⁶) and
/// `seed`: every parameterization × [`resolutions`] × [`ORDERS`]. Deterministic for a given
/// `(directions, seed)` regardless of the thread count. Points are ordered by order, then
/// parameterization ([`Parameterization::ALL`] order), then resolution.
pub fn run_study(directions: usize, seed: u64) -> Vec<StudyPoint> {
    let maps: Vec<SphereMap> = Parameterization::ALL
        .into_iter()
        .flat_map(|kind| {
            resolutions(kind).iter().map(move |&res| {
                // The constant resolutions are within MIN_RES..=MAX_RES.
                SphereMap::new(kind, res).unwrap_or_else(|e| panic!("study resolution: {e}"))
            })
        })
        .collect();
    let tables: Vec<Vec<f64>> = maps.par_iter().map(basis_table).collect();
    let dirs = study_directions(directions, seed);

    // Per chunk, per map: Σ_k (ŷ_i − y_i)² for each of the 36 functions.
    let chunk_sums: Vec<Vec<[f64; COEFFS]>> = dirs
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut y = vec![0.0; chunk.len() * COEFFS];
            for (d, out) in chunk.iter().zip(y.chunks_exact_mut(COEFFS)) {
                eval_basis(Order::SIX, *d, out);
            }
            maps.iter()
                .zip(&tables)
                .map(|(map, table)| squared_errors(map, table, chunk, &y))
                .collect()
        })
        .collect();

    let mut totals = vec![[0.0; COEFFS]; maps.len()];
    for sums in &chunk_sums {
        for (total, s) in totals.iter_mut().zip(sums) {
            for (t, v) in total.iter_mut().zip(s) {
                *t += v;
            }
        }
    }

    let n_dirs = directions.max(1) as f64;
    let mut points = Vec::with_capacity(ORDERS.len() * maps.len());
    for order in ORDERS {
        let count = order.coeff_count();
        for (map, total) in maps.iter().zip(&totals) {
            let sum: f64 = total[..count].iter().sum();
            points.push(StudyPoint {
                parameterization: map.kind(),
                order: order.get(),
                res: map.res(),
                samples: map.sample_count(),
                mse: sum / (count as f64 * n_dirs),
            });
        }
    }
    points
}

/// The 36 order-6 basis functions at every texel centre, texel-major
/// (`table[t·36 + i] = y_i(texel t)`), so one bilinear tap reads 36 contiguous values.
fn basis_table(map: &SphereMap) -> Vec<f64> {
    let res = map.res();
    let mut table = vec![0.0; map.sample_count() * COEFFS];
    for (t, out) in table.chunks_exact_mut(COEFFS).enumerate() {
        let t = t as u32;
        let (face, k) = (t / (res * res), t % (res * res));
        eval_basis(
            Order::SIX,
            map.texel_center_dir(face, k % res, k / res),
            out,
        );
    }
    table
}

/// Σ over `dirs` of the squared reconstruction error of each basis function; `y` holds the
/// exact values, 36 per direction.
fn squared_errors(map: &SphereMap, table: &[f64], dirs: &[DVec3], y: &[f64]) -> [f64; COEFFS] {
    let mut acc = [0.0; COEFFS];
    for (d, exact) in dirs.iter().zip(y.chunks_exact(COEFFS)) {
        let taps = map.bilinear_taps(*d);
        let row = |k: usize| {
            let t = taps.index[k] as usize * COEFFS;
            &table[t..t + COEFFS]
        };
        let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
        let [w0, w1, w2, w3] = taps.weight;
        for i in 0..COEFFS {
            let e = w0 * r0[i] + w1 * r1[i] + w2 * r2[i] + w3 * r3[i] - exact[i];
            acc[i] += e * e;
        }
    }
    acc
}

/// Writes `parameterization,order,res,samples,mse` rows (MSE with 17 significant digits).
///
/// # Errors
/// Whatever `w` reports.
pub fn write_csv(points: &[StudyPoint], w: &mut impl Write) -> std::io::Result<()> {
    writeln!(w, "parameterization,order,res,samples,mse")?;
    for p in points {
        writeln!(
            w,
            "{},{},{},{},{:.16e}",
            p.parameterization, p.order, p.res, p.samples, p.mse
        )?;
    }
    Ok(())
}

/// The points of one curve (kind, order), by increasing sample count.
fn curve(points: &[StudyPoint], kind: Parameterization, order: u32) -> Vec<StudyPoint> {
    let mut c: Vec<StudyPoint> = points
        .iter()
        .filter(|p| p.parameterization == kind && p.order == order)
        .copied()
        .collect();
    c.sort_by_key(|p| p.samples);
    c
}

/// log–log linear interpolation of a curve at `samples`; `None` outside its range.
fn mse_at(curve: &[StudyPoint], samples: f64) -> Option<f64> {
    let x = samples.ln();
    curve.windows(2).find_map(|w| {
        let (x0, x1) = ((w[0].samples as f64).ln(), (w[1].samples as f64).ln());
        (x0 <= x && x <= x1 && x1 > x0).then(|| {
            let t = (x - x0) / (x1 - x0);
            (w[0].mse.ln() * (1.0 - t) + w[1].mse.ln() * t).exp()
        })
    })
}

/// Least-squares slope of log MSE against log samples over the upper half of a curve.
fn tail_slope(curve: &[StudyPoint]) -> Option<f64> {
    let tail = &curve[curve.len() / 2..];
    if tail.len() < 2 {
        return None;
    }
    let pts: Vec<(f64, f64)> = tail
        .iter()
        .map(|p| ((p.samples as f64).ln(), p.mse.ln()))
        .collect();
    let n = pts.len() as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxy: f64 = pts.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = pts.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// A markdown report: per order, the MSE table, the ranking of the four
/// parameterizations at common sample counts (log–log interpolation), fitted slopes, and
/// the paper's claims checked (DX10 cube lowest MSE at equal sample count; DX9 cube worst
/// at low resolution).
pub fn summary_markdown(points: &[StudyPoint]) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Sphere parameterizations for SH signals (Iwanicki–Sloan App. A, Figure 8)\n"
    );
    let _ = writeln!(
        md,
        "MSE = squared error of bilinear reconstruction, averaged over uniform random \
         directions and over the n² SH basis functions of order n (each stored as its own \
         texture, sampled at texel centres). Samples = total texels (2·res² for dual maps, \
         6·res² for cubes).\n"
    );
    let mut orders: Vec<u32> = points.iter().map(|p| p.order).collect();
    orders.sort_unstable();
    orders.dedup();
    for order in orders {
        let curves: Vec<(Parameterization, Vec<StudyPoint>)> = Parameterization::ALL
            .into_iter()
            .map(|k| (k, curve(points, k, order)))
            .filter(|(_, c)| !c.is_empty())
            .collect();
        let _ = writeln!(md, "## Order {order} ({} basis functions)\n", order * order);
        write_mse_table(&mut md, &curves);

        let ranking = write_ranking(&mut md, &curves);

        let _ = writeln!(
            md,
            "\n### Slopes (d log MSE / d log samples, upper half of each curve)\n"
        );
        for (k, c) in &curves {
            if let Some(s) = tail_slope(c) {
                let _ = writeln!(md, "- {k}: {s:.2}");
            }
        }
        let _ = writeln!(
            md,
            "\n(Smooth bilinear reconstruction gives −2; a seam band gives −1.5.)\n"
        );

        write_claims(&mut md, &curves, ranking);
    }
    md
}

/// One order's curves, each with its parameterization.
type Curves = [(Parameterization, Vec<StudyPoint>)];

/// Writes the MSE table of `curves`: one row per resolution step, one column per
/// parameterization.
fn write_mse_table(md: &mut String, curves: &Curves) {
    let _ = write!(md, "| step |");
    for (k, _) in curves {
        let _ = write!(md, " {k}: res · samples · MSE |");
    }
    let _ = write!(md, "\n|---|");
    for _ in curves {
        let _ = write!(md, "---|");
    }
    let _ = writeln!(md);
    let steps = curves.iter().map(|(_, c)| c.len()).max().unwrap_or(0);
    for s in 0..steps {
        let _ = write!(md, "| {s} |");
        for (_, c) in curves {
            match c.get(s) {
                Some(p) => {
                    let _ = write!(md, " {} · {} · {:.3e} |", p.res, p.samples, p.mse);
                }
                None => md.push_str(" |"),
            }
        }
        let _ = writeln!(md);
    }
}

/// The ranking of one order's parameterizations at common sample counts.
struct Ranking {
    /// The common sample counts ranked at.
    targets: Vec<usize>,
    /// At how many of them the DX10 cube ranks first.
    dx10_best: usize,
    /// At how many of them the DX9 cube ranks last.
    dx9_worst: usize,
    /// The first count with the DX9 cube ranked, and its rank there (1 = lowest MSE).
    first_rank_of_dx9: Option<(usize, usize)>,
}

/// Writes the ranking table of `curves` at the cube counts inside every curve's range
/// (log–log interpolation) and returns what the claims read off it.
fn write_ranking(md: &mut String, curves: &Curves) -> Ranking {
    // Ranking at common sample counts: the cube counts inside every curve's range.
    let lo = curves
        .iter()
        .filter_map(|(_, c)| c.first().map(|p| p.samples))
        .max()
        .unwrap_or(0);
    let hi = curves
        .iter()
        .filter_map(|(_, c)| c.last().map(|p| p.samples))
        .min()
        .unwrap_or(0);
    let targets: Vec<usize> = CUBE_RES
        .iter()
        .map(|r| 6 * (*r as usize) * (*r as usize))
        .filter(|&s| s >= lo && s <= hi)
        .collect();
    let _ = writeln!(
        md,
        "\n### Ranking at equal sample count (log–log interpolation), lowest MSE first\n"
    );
    let _ = writeln!(
        md,
        "| samples | 1st | 2nd | 3rd | 4th |\n|---|---|---|---|---|"
    );
    let mut dx10_best = 0;
    let mut dx9_worst = 0;
    let mut first_rank_of_dx9 = None;
    for &t in &targets {
        let mut ranked: Vec<(Parameterization, f64)> = curves
            .iter()
            .filter_map(|(k, c)| mse_at(c, t as f64).map(|m| (*k, m)))
            .collect();
        ranked.sort_by(|a, b| a.1.total_cmp(&b.1));
        let _ = write!(md, "| {t} |");
        for (k, m) in &ranked {
            let _ = write!(md, " {k} ({m:.3e}) |");
        }
        let _ = writeln!(md);
        if ranked.first().map(|r| r.0) == Some(Parameterization::CubeDx10) {
            dx10_best += 1;
        }
        if ranked.last().map(|r| r.0) == Some(Parameterization::CubeDx9) {
            dx9_worst += 1;
        }
        if first_rank_of_dx9.is_none() {
            first_rank_of_dx9 = ranked
                .iter()
                .position(|r| r.0 == Parameterization::CubeDx9)
                .map(|p| (t, p + 1));
        }
    }
    Ranking {
        targets,
        dx10_best,
        dx9_worst,
        first_rank_of_dx9,
    }
}

/// Writes the paper's claims checked against `ranking` of `curves`.
fn write_claims(md: &mut String, curves: &Curves, ranking: Ranking) {
    let Ranking {
        targets,
        dx10_best,
        dx9_worst,
        first_rank_of_dx9,
    } = ranking;
    let _ = writeln!(md, "### The paper's claims\n");
    let _ = writeln!(
        md,
        "- *DX10 (seamless) cube has the lowest MSE at equal sample count*: lowest at \
         {dx10_best} of {} common sample counts — {}.",
        targets.len(),
        if dx10_best == targets.len() && !targets.is_empty() {
            "holds"
        } else {
            "does not hold everywhere"
        }
    );
    if let Some((t, rank)) = first_rank_of_dx9 {
        // DX9/DX10 MSE ratio at the smallest and largest common counts.
        let ratio = |t: usize| {
            let at = |k| {
                curves
                    .iter()
                    .find(|(c, _)| *c == k)
                    .and_then(|(_, c)| mse_at(c, t as f64))
            };
            at(Parameterization::CubeDx9)
                .zip(at(Parameterization::CubeDx10))
                .map(|(a, b)| a / b)
        };
        let last = targets.last().copied().unwrap_or(t);
        let verdict = if rank == curves.len() {
            "holds in MSE"
        } else {
            "not in MSE terms: its flaw is the seam (not C0), which a mean hides"
        };
        let _ = writeln!(
            md,
            "- *DX9 (per-face) cube is the worst at low resolution*: {verdict}. At the \
             smallest common count ({t} samples) it ranks {rank} of {}, with {:.2}× the \
             DX10 cube's MSE ({:.2}× at {last}); it is the worst of the four at {dx9_worst} \
             of {} counts.\n",
            curves.len(),
            ratio(t).unwrap_or(f64::NAN),
            ratio(last).unwrap_or(f64::NAN),
            targets.len()
        );
    }
}

/// Line colours per parameterization, in [`Parameterization::ALL`] order.
const COLOURS: [(u8, u8, u8); 4] = [(230, 159, 0), (0, 114, 178), (213, 94, 0), (0, 158, 115)];

/// Draws Figure 8: MSE against total samples, log–log, one panel per order, one line per
/// parameterization.
fn draw_figure<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    points: &[StudyPoint],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut orders: Vec<u32> = points.iter().map(|p| p.order).collect();
    orders.sort_unstable();
    orders.dedup();
    let panels = root.split_evenly((1, orders.len().max(1)));
    for (panel, order) in panels.iter().zip(orders) {
        let pts: Vec<&StudyPoint> = points
            .iter()
            .filter(|p| p.order == order && p.mse > 0.0)
            .collect();
        let (x0, x1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| {
            (a.min(p.samples as f64), b.max(p.samples as f64))
        });
        let (y0, y1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| {
            (a.min(p.mse), b.max(p.mse))
        });
        if pts.is_empty() {
            continue;
        }
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("MSE, order {order} SH"), ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (x0 * 0.8..x1 * 1.25).log_scale(),
                (y0 * 0.5..y1 * 2.0).log_scale(),
            )
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("total samples")
            .y_desc("MSE")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .map_err(|e| e.to_string())?;
        for (kind, (r, g, b)) in Parameterization::ALL.into_iter().zip(COLOURS) {
            let colour = RGBColor(r, g, b);
            let line: Vec<(f64, f64)> = curve(points, kind, order)
                .iter()
                .filter(|p| p.mse > 0.0)
                .map(|p| (p.samples as f64, p.mse))
                .collect();
            chart
                .draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(kind.name())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(line.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

/// Writes Figure 8 as `params_mse.svg` and `params_mse.png` into `dir`; returns the paths.
///
/// # Errors
/// [`StudyError::Plot`] when plotters fails or no font is available for the labels
/// (`$SHVIS_FONT`, else DejaVu/Liberation/Noto Sans or Arial at their usual paths).
pub fn write_plots(points: &[StudyPoint], dir: &Path) -> Result<Vec<PathBuf>, StudyError> {
    const SIZE: (u32, u32) = (1200, 520);
    let svg = dir.join("params_mse.svg");
    crate::report::plot::register_plot_font().map_err(|message| StudyError::Plot {
        path: svg.clone(),
        message,
    })?;
    crate::report::plot::write_svg_plot(&svg, SIZE, |root| draw_figure(root, points)).map_err(
        |message| StudyError::Plot {
            path: svg.clone(),
            message,
        },
    )?;
    let png = dir.join("params_mse.png");
    crate::report::plot::write_png_plot(&png, SIZE, |root| draw_figure(root, points)).map_err(
        |message| StudyError::Plot {
            path: png.clone(),
            message,
        },
    )?;
    Ok(vec![svg, png])
}

/// Writes everything `shvis study params --out DIR` produces into `dir` (created if
/// missing): `params.csv` ([`write_csv`]), the report `params.md` ([`summary_markdown`])
/// and `params.json` (the points) through [`super::report::write`], and the plots
/// ([`write_plots`]). Returns the paths written: the CSV, the JSON, the markdown, the plots.
///
/// # Errors
/// [`StudyError::Io`] naming the file that could not be written, or [`StudyError::Plot`]
/// (the data files are written before the plots).
pub fn write_report(points: &[StudyPoint], dir: &Path) -> Result<Vec<PathBuf>, StudyError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| StudyError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let csv = dir.join("params.csv");
    let mut buf = Vec::new();
    write_csv(points, &mut buf).map_err(io(&csv))?;
    crate::files::write(&csv, buf).map_err(io(&csv))?;
    let json = serde_json::to_string_pretty(points).map_err(|e| StudyError::Io {
        path: dir.join("params.json"),
        source: e.into(),
    })?;
    let study_report = StudyReport {
        stem: "params",
        markdown: summary_markdown(points),
        json: Some(json),
    };
    let mut written = vec![csv];
    // params.json before params.md: the order the command lists them in.
    written.extend(super::report::write(dir, &study_report)?.into_iter().rev());
    written.extend(write_plots(points, dir)?);
    Ok(written)
}

/// A report file that could not be written, as the study's other files fail.
impl From<StudyReportError> for StudyError {
    fn from(e: StudyReportError) -> StudyError {
        StudyError::Io {
            path: e.path,
            source: e.source,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolutions_match_sample_counts_within_8_percent() {
        for (c, d) in CUBE_RES.iter().zip(DUAL_RES) {
            let (cube, dual) = (6.0 * f64::from(c * c), 2.0 * f64::from(d * d));
            assert!(
                (dual / cube - 1.0).abs() <= 0.08 + 1e-12,
                "cube {c} vs dual {d}"
            );
            assert_eq!(d, (f64::from(*c) * 3f64.sqrt()).round() as u32);
        }
    }

    #[test]
    fn directions_are_unit_and_centred() {
        let dirs = study_directions(100_000, 1);
        assert!(dirs.iter().all(|d| (d.length() - 1.0).abs() < 1e-14));
        let mean = dirs.iter().sum::<DVec3>() / dirs.len() as f64;
        // Mean of N uniform unit vectors: each component has σ = 1/√(3N) ≈ 0.0018.
        assert!(mean.length() < 0.01, "{mean}");
        assert_eq!(study_directions(10, 9), study_directions(10, 9));
    }

    #[test]
    fn study_is_deterministic_and_orders_kinds() {
        let a = run_study(3 * CHUNK + 17, 42);
        assert_eq!(a, run_study(3 * CHUNK + 17, 42));
        assert_eq!(a.len(), 2 * 4 * CUBE_RES.len());
        assert!(a.iter().all(|p| p.mse.is_finite() && p.mse > 0.0));
        // Every curve falls with resolution.
        for order in [3, 6] {
            for kind in Parameterization::ALL {
                let c = curve(&a, kind, order);
                assert!(
                    c.windows(2).all(|w| w[1].mse < w[0].mse),
                    "{kind} {order}: {c:?}"
                );
            }
        }
        let md = summary_markdown(&a);
        assert!(
            md.contains("## Order 3") && md.contains("## Order 6"),
            "{md}"
        );
        let mut csv = Vec::new();
        write_csv(&a, &mut csv).expect("write to memory");
        assert_eq!(String::from_utf8_lossy(&csv).lines().count(), a.len() + 1);
    }

    /// `write_report` writes what `shvis study params --out DIR` promises, in order: the
    /// CSV, the points as JSON, the summary and both plots, each holding what its writer
    /// makes of the points.
    #[test]
    fn write_report_writes_every_output_of_the_points() {
        let points = run_study(CHUNK + 1, 42);
        let dir = std::env::temp_dir().join(format!("shvis-study-params-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let written = write_report(&points, &dir).expect("temp folder is writable");
        let names: Vec<&str> = written
            .iter()
            .map(|p| p.file_name().and_then(|n| n.to_str()).unwrap_or(""))
            .collect();
        assert_eq!(
            names,
            [
                "params.csv",
                "params.json",
                "params.md",
                "params_mse.svg",
                "params_mse.png"
            ]
        );
        assert!(
            written.iter().all(|p| p.parent() == Some(dir.as_path())),
            "{written:?}"
        );
        let read = |name: &str| std::fs::read(dir.join(name)).expect(name);
        let mut csv = Vec::new();
        write_csv(&points, &mut csv).expect("write to memory");
        assert_eq!(read("params.csv"), csv);
        let json: serde_json::Value =
            serde_json::from_slice(&read("params.json")).expect("params.json parses");
        assert_eq!(
            json,
            serde_json::to_value(&points).expect("points serialize")
        );
        assert_eq!(read("params.md"), summary_markdown(&points).into_bytes());
        let svg = String::from_utf8(read("params_mse.svg")).expect("SVG is text");
        assert!(svg.contains("<svg"), "params_mse.svg: {svg:.200}");
        assert!(
            read("params_mse.png").starts_with(b"\x89PNG\r\n\x1a\n"),
            "params_mse.png is not a PNG"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
