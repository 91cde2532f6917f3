//! `shvis study bases`: Probulator's experiment with this tool's truth — per environment, the
//! irradiance over all normals reconstructed by each lightmap basis (`sh::bases`: L1 linear,
//! Geomerics, hallucinated and stored ZH3, luminance L1, L2 and deringed L2) against exact
//! irradiance.
//!
//! # What is measured
//!
//! Normals n_j are the nodes of an exact sphere quadrature (weights w_j, Σ w_j = 4π). Exact
//! irradiance E(n) = ∫ L(ω) max(0, n·ω) dω is a quadrature over the map's texels
//! (`env::project::irradiance_brute_force`, `shvis sh irradiance --exact`); for an
//! environment given by SH coefficients (`sh:FILE`) it is the coefficients convolved with the
//! clamped cosine at their own order (exact for that radiance; clamped at 0 like the
//! reconstructions, so a truncated SH that dips negative is compared as displayed). Each
//! basis encodes the
//! environment's order-3 radiance SH and reconstructs Ê(n), clamped at 0 as its shader
//! does. On luminance, with E_max = max_j E(n_j) the peak irradiance:
//!
//! ```text
//! RMS      √(Σ w (Ê − E)²) / √(Σ w E²)
//! mean     Σ w |Ê − E| / (Σ w · E_max)
//! max      max_j |Ê − E| / E_max
//! vs L2    √(Σ w (Ê − Ê_L2)²) / √(Σ w Ê_L2²)   (the published figures' measure)
//! ```
//!
//! "mean" and "max" are Ramamoorthi & Hanrahan's average and maximum error, relative to the
//! peak irradiance as their bound is: a single direction's order-3 irradiance
//! 1/4 + t/2 + (5/16)P_2(t) misses max(0, t) by 0.094 at t = 0, 9.4 % of its peak of 1 —
//! the 9 % bound.
//!
//! Also reported: the share of normals where the basis' unclamped reconstruction is
//! negative. Lightmap
//! texels see a hemisphere; a probe here is lit from the whole sphere, as in Probulator.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::env::{self, EnvError};
use crate::sh::Order;
use crate::sh::bases::{ShBasis, luminance};
use crate::sh::project::sphere_quadrature;
use crate::sh::zonal;

/// Default environments: the built-in sky with its sun at three heights.
pub const DEFAULT_ENVS: &[&str] = &["sky", "sky:15", "sky:60"];

/// One basis under one environment.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BasisRow {
    pub env: String,
    pub basis: &'static str,
    /// Values stored (RGB counted three times).
    pub coefficients: usize,
    pub rms_rel: f64,
    pub mean_abs_rel: f64,
    pub max_rel: f64,
    pub rms_rel_to_l2: f64,
    /// Share of the normals (by solid angle) where the unclamped reconstruction is negative.
    pub negative_share: f64,
}

/// One basis of the floor table: a texel facing up under the environment.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FloorRow {
    pub env: String,
    /// "L2", "H6", "SG9 nnls"…
    pub basis: String,
    /// Values stored (RGB counted three times).
    pub coefficients: usize,
    /// RMS of irradiance over the upper hemisphere of normals, relative to the reference.
    pub rms_rel: f64,
    /// For SG: the share of amplitudes the solver made negative.
    pub negative_amplitudes: Option<f64>,
}

/// The study's results.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BasesStudy {
    /// Normals over the sphere.
    pub normals: usize,
    pub rows: Vec<BasisRow>,
    /// Normals over the floor's hemisphere.
    pub floor_normals: usize,
    pub floor: Vec<FloorRow>,
}

/// Runs the study on `envs` (`env::resolve` names, `sh:FILE` included) with
/// `quadrature`² · 2 normals; `progress` prints a line per environment.
///
/// # Errors
/// An environment that does not load.
pub fn run(envs: &[String], quadrature: usize, progress: bool) -> Result<BasesStudy, EnvError> {
    let nodes = sphere_quadrature(quadrature);
    let floor_nodes = crate::sh::hbasis::hemisphere_quadrature(quadrature / 2);
    let mut rows = Vec::new();
    let mut floor = Vec::new();
    for (i, name) in envs.iter().enumerate() {
        let started = Instant::now();
        let (radiance, exact) = environment(name, &nodes)?;
        rows.extend(measure(name, &radiance, &exact, &nodes));
        floor.extend(measure_floor(
            name,
            &high_order_radiance(name)?,
            &floor_nodes,
        ));
        if progress {
            eprintln!(
                "study bases: [{}/{}] {name} in {:.1} s",
                i + 1,
                envs.len(),
                started.elapsed().as_secs_f64()
            );
        }
    }
    Ok(BasesStudy {
        normals: nodes.len(),
        rows,
        floor_normals: floor_nodes.len(),
        floor,
    })
}

/// Order of the radiance SH the floor table starts from (the bake's lighting order).
const FLOOR_LIGHTING_ORDER: u32 = 8;

/// The environment's radiance SH at [`FLOOR_LIGHTING_ORDER`] (an `sh:FILE` as given).
fn high_order_radiance(name: &str) -> Result<Vec<[f64; 3]>, EnvError> {
    if let Some(path) = name.strip_prefix(env::SH_PREFIX) {
        return env::sh_file::load(Path::new(path));
    }
    let map = env::resolve(name)?;
    let order = Order::new(FLOOR_LIGHTING_ORDER).expect("a valid order");
    Ok(env::project::project_sh(&map, order))
}

/// The floor table of one environment (module doc): a texel facing +Y sees the radiance
/// above its plane; each basis stores what its technique stores for that texel and is
/// compared, over the hemisphere of normals, with the irradiance of that radiance.
fn measure_floor(env: &str, radiance: &[[f64; 3]], normals: &[(DVec3, f64)]) -> Vec<FloorRow> {
    use crate::sh::dice::DiceVariant;
    use crate::sh::hbasis::{self, HBasisSize};
    use crate::sh::sg::{FitStats, LOBE_COUNTS, Solver};
    use crate::technique::hemisphere::{fit_sg, sg_basis, sg_irradiance};
    let order = Order::new((radiance.len() as f64).sqrt().round() as u32).expect("n² coefficients");
    // Tangent frame of the floor: tangent +X, bitangent −Z, normal +Y (t × b = n).
    let frame = [DVec3::X, DVec3::NEG_Z, DVec3::Y];
    let to_world = |m: DVec3| frame[0] * m.x + frame[1] * m.y + frame[2] * m.z;
    // The radiance above the plane on a fine hemisphere rule: the reference irradiance and
    // the texel's order-3 SH (what the bake stores) both come from it.
    let fine = hbasis::hemisphere_quadrature(48);
    let mut y = vec![0.0; order.coeff_count()];
    let above: Vec<(DVec3, f64, [f64; 3])> = fine
        .iter()
        .map(|&(m, w)| {
            let d = to_world(m);
            crate::sh::basis::eval_basis(order, d, &mut y);
            let l = std::array::from_fn(|c| radiance.iter().zip(&y).map(|(k, y)| k[c] * y).sum());
            (d, w, l)
        })
        .collect();
    let mut sh3 = vec![[0.0; 3]; 9];
    let mut y3 = [0.0; 9];
    for &(d, w, l) in &above {
        crate::sh::basis::eval_basis(Order::THREE, d, &mut y3);
        for k in 0..9 {
            for c in 0..3 {
                sh3[k][c] += w * l[c] * y3[k];
            }
        }
    }
    let reference: Vec<f64> = normals
        .iter()
        .map(|&(m, _)| {
            let n = to_world(m);
            luminance(std::array::from_fn(|c| {
                above
                    .iter()
                    .map(|&(d, w, l)| w * l[c] * n.dot(d).max(0.0))
                    .sum()
            }))
        })
        .collect();
    let ref_sq: f64 = normals
        .iter()
        .zip(&reference)
        .map(|(&(_, w), e)| w * e * e)
        .sum();
    let rms = |e: &dyn Fn(DVec3) -> [f64; 3]| -> f64 {
        let se: f64 = normals
            .iter()
            .zip(&reference)
            .map(|(&(m, w), r)| w * (luminance(e(m).map(|v| v.max(0.0))) - r).powi(2))
            .sum();
        if ref_sq > 0.0 {
            (se / ref_sq).sqrt()
        } else {
            0.0
        }
    };
    let row = |basis: String, coefficients: usize, rms_rel: f64, negative: Option<f64>| FloorRow {
        env: env.to_string(),
        basis,
        coefficients,
        rms_rel,
        negative_amplitudes: negative,
    };
    let mut rows = Vec::new();
    for basis in [ShBasis::L1, ShBasis::Zh3, ShBasis::L2] {
        let stored = basis.encode(&sh3, Some(DVec3::Y));
        let e = |m: DVec3| basis.irradiance(&stored, to_world(m));
        rows.push(row(
            basis.label().into(),
            basis.stored_values(),
            rms(&e),
            None,
        ));
    }
    for (size, label) in [(HBasisSize::H4, "H4"), (HBasisSize::H6, "H6")] {
        let h = hbasis::project_irradiance(&sh3, frame, size);
        let e = |m: DVec3| hbasis::irradiance(&h, m);
        rows.push(row(label.into(), 3 * size.count(), rms(&e), None));
    }
    for (variant, label) in [
        (DiceVariant::Rgb, "Dice"),
        (DiceVariant::YCoCg, "Dice YCoCg"),
    ] {
        let basis = crate::sh::dice::dice();
        let x = basis.project_irradiance(variant, &sh3, frame);
        let e = |m: DVec3| basis.irradiance(variant, &x, m);
        rows.push(row(label.into(), variant.stored_values(), rms(&e), None));
    }
    for n in LOBE_COUNTS {
        let basis = sg_basis(n as u32);
        for solver in Solver::ALL {
            let mut stats = FitStats::default();
            let a = fit_sg(&basis, &sh3, frame, solver, &mut stats);
            let e = |m: DVec3| sg_irradiance(&basis, &a, m);
            let negative = stats.negative as f64 / stats.amplitudes.max(1) as f64;
            rows.push(row(
                format!("SG{n} {solver}"),
                3 * n,
                rms(&e),
                Some(negative),
            ));
        }
    }
    rows
}

/// The order-3 radiance SH of `name` and its exact irradiance (luminance) at `nodes`.
fn environment(name: &str, nodes: &[(DVec3, f64)]) -> Result<(Vec<[f64; 3]>, Vec<f64>), EnvError> {
    if let Some(path) = name.strip_prefix(env::SH_PREFIX) {
        let coeffs = env::sh_file::load(Path::new(path))?;
        let order = env::sh_file::order_of(&coeffs);
        let irradiance = zonal::irradiance_from_radiance(&coeffs, order);
        let exact = nodes
            .iter()
            .map(|&(n, _)| luminance(zonal::eval_rgb(&irradiance, order, n).map(|v| v.max(0.0))))
            .collect();
        let mut radiance = coeffs;
        radiance.resize(Order::THREE.coeff_count().max(radiance.len()), [0.0; 3]);
        return Ok((radiance, exact));
    }
    let map = env::resolve(name)?;
    let radiance = env::project::project_sh(&map, Order::THREE);
    let exact = nodes
        .iter()
        .map(|&(n, _)| luminance(env::project::irradiance_brute_force(&map, n)))
        .collect();
    Ok((radiance, exact))
}

/// Every basis' row for one environment.
fn measure(
    env: &str,
    radiance: &[[f64; 3]],
    exact: &[f64],
    nodes: &[(DVec3, f64)],
) -> Vec<BasisRow> {
    let reconstruct = |basis: ShBasis| -> (Vec<f64>, f64) {
        let stored = basis.encode(radiance, None);
        let mut negative = 0.0;
        let values = nodes
            .iter()
            .map(|&(n, w)| {
                let e = basis.irradiance(&stored, n);
                if e.iter().any(|&v| v < 0.0) {
                    negative += w;
                }
                luminance(e.map(|v| v.max(0.0)))
            })
            .collect();
        (values, negative / (4.0 * std::f64::consts::PI))
    };
    let (l2, _) = reconstruct(ShBasis::L2);
    let weighted = |f: &dyn Fn(usize) -> f64| -> f64 {
        nodes.iter().enumerate().map(|(j, &(_, w))| w * f(j)).sum()
    };
    let total_w: f64 = nodes.iter().map(|&(_, w)| w).sum();
    let exact_sq = weighted(&|j| exact[j] * exact[j]);
    let peak = exact.iter().copied().fold(0.0, f64::max);
    let l2_sq = weighted(&|j| l2[j] * l2[j]);
    ShBasis::ALL
        .par_iter()
        .map(|&basis| {
            let (e, negative_share) = reconstruct(basis);
            let rel = |num: f64, den: f64| if den > 0.0 { num / den } else { 0.0 };
            BasisRow {
                env: env.to_string(),
                basis: basis.label(),
                coefficients: basis.stored_values(),
                rms_rel: rel(
                    weighted(&|j| (e[j] - exact[j]).powi(2)).sqrt(),
                    exact_sq.sqrt(),
                ),
                mean_abs_rel: rel(weighted(&|j| (e[j] - exact[j]).abs()), total_w * peak),
                max_rel: rel(
                    e.iter()
                        .zip(exact)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f64::max),
                    peak,
                ),
                rms_rel_to_l2: rel(weighted(&|j| (e[j] - l2[j]).powi(2)).sqrt(), l2_sq.sqrt()),
                negative_share,
            }
        })
        .collect()
}

/// The published figures the study is read beside (RMS of irradiance relative to L2,
/// computed from the published L2 coefficients of four well-known probes, as the ZH3
/// paper's comparison does): (basis, low, high).
pub const PUBLISHED_VS_L2: &[(&str, f64, f64)] = &[
    ("L1 linear", 0.09, 0.45),
    ("L1 + hallucinated ZH3", 0.06, 0.12),
    ("ZH3 stored", 0.04, 0.16),
];

/// Ramamoorthi & Hanrahan's figures for order-3 irradiance: average error under 1 % in
/// practice, maximum under about 5 %, 9 % the theoretical bound.
pub const RH_AVERAGE: f64 = 0.01;
pub const RH_MAX_PRACTICE: f64 = 0.05;
pub const RH_MAX_BOUND: f64 = 0.09;

/// bases.md: the table per environment, L2 against Ramamoorthi & Hanrahan, the L1 family
/// against the published figures.
pub fn markdown(study: &BasesStudy) -> String {
    let mut s = format!(
        "# Lightmap bases: irradiance error against exact irradiance\n\n\
         {} normals over the sphere (an exact quadrature); irradiance on luminance; each basis \
         encodes the environment's order-3 radiance SH and is clamped at 0 as its shader is. \
         RMS is relative to exact irradiance; mean and max (absolute error) to its peak, as \
         Ramamoorthi & Hanrahan's are; \"vs L2\" is the RMS \
         relative to L2's reconstruction; \"< 0\" the share of normals where the unclamped \
         reconstruction is negative.\n\n\
         | environment | basis | values | RMS | mean | max | vs L2 | < 0 |\n\
         |---|---|---:|---:|---:|---:|---:|---:|\n",
        study.normals
    );
    for r in &study.rows {
        s += &format!(
            "| {} | {} | {} | {:.2} % | {:.2} % | {:.2} % | {:.2} % | {:.1} % |\n",
            r.env,
            r.basis,
            r.coefficients,
            100.0 * r.rms_rel,
            100.0 * r.mean_abs_rel,
            100.0 * r.max_rel,
            100.0 * r.rms_rel_to_l2,
            100.0 * r.negative_share
        );
    }
    s += &format!(
        "\n## L2 against Ramamoorthi & Hanrahan\n\n\
         Their bound for order-3 irradiance: average error under {:.0} % in practice, maximum \
         under about {:.0} %, {:.0} % in theory.\n\n\
         | environment | mean | max | mean < 1 % | max < 5 % | max < 9 % |\n\
         |---|---:|---:|---|---|---|\n",
        100.0 * RH_AVERAGE,
        100.0 * RH_MAX_PRACTICE,
        100.0 * RH_MAX_BOUND
    );
    for r in study.rows.iter().filter(|r| r.basis == ShBasis::L2.label()) {
        let yes = |ok: bool| if ok { "yes" } else { "no" };
        s += &format!(
            "| {} | {:.3} % | {:.2} % | {} | {} | {} |\n",
            r.env,
            100.0 * r.mean_abs_rel,
            100.0 * r.max_rel,
            yes(r.mean_abs_rel < RH_AVERAGE),
            yes(r.max_rel < RH_MAX_PRACTICE),
            yes(r.max_rel < RH_MAX_BOUND)
        );
    }
    s += &format!(
        "\n## A floor under each environment: the local bases and the SG solvers\n\n\
         A texel facing up (+Y) sees the radiance above its plane (the environment's order-8 \
         SH there); each basis stores what its technique stores for that texel — from the \
         texel's order-3 SH, as the bake gives it — and is compared over the {} normals of \
         the upper hemisphere with the irradiance of that radiance. RMS relative to it; for SG, \
         the share of amplitudes the solver made negative.\n\n\
         | environment | basis | values | RMS | negative amplitudes |\n|---|---|---:|---:|---:|\n",
        study.floor_normals
    );
    for r in &study.floor {
        s += &format!(
            "| {} | {} | {} | {:.2} % | {} |\n",
            r.env,
            r.basis,
            r.coefficients,
            100.0 * r.rms_rel,
            r.negative_amplitudes
                .map_or_else(|| "—".to_string(), |v| format!("{:.1} %", 100.0 * v))
        );
    }
    s += "\n## The L1 family beside the published figures\n\n\
          RMS relative to L2, here per environment and as published (four well-known probes).\n\n\
          | basis | here (min – max) | published |\n|---|---|---|\n";
    for &(basis, lo, hi) in PUBLISHED_VS_L2 {
        let here: Vec<f64> = study
            .rows
            .iter()
            .filter(|r| r.basis == basis)
            .map(|r| r.rms_rel_to_l2)
            .collect();
        let (min, max) = here
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        s += &format!(
            "| {basis} | {:.1} – {:.1} % | {:.0} – {:.0} % |\n",
            100.0 * min,
            100.0 * max,
            100.0 * lo,
            100.0 * hi
        );
    }
    s
}

/// bases_error.svg / .png: RMS against exact irradiance over stored values, a series per
/// environment. Returns the files written.
pub fn write_plot(study: &BasesStudy, dir: &Path) -> Result<Vec<PathBuf>, String> {
    use crate::report::plot::{register_plot_font, write_png_plot, write_svg_plot};
    register_plot_font()?;
    let svg = dir.join("bases_error.svg");
    let png = dir.join("bases_error.png");
    write_svg_plot(&svg, (900, 560), |root| draw(root, study))?;
    write_png_plot(&png, (900, 560), |root| draw(root, study))?;
    Ok(vec![svg, png])
}

fn draw<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    study: &BasesStudy,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let err = |e: &dyn std::fmt::Debug| format!("{e:?}");
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let top = study
        .rows
        .iter()
        .map(|r| 100.0 * r.rms_rel)
        .fold(1.0, f64::max);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Irradiance RMS against exact, by values stored per texel",
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..30.0, 0.0..top * 1.1)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("values per texel (RGB)")
        .y_desc("RMS, % of exact")
        .draw()
        .map_err(|e| err(&e))?;
    let mut envs: Vec<&str> = study.rows.iter().map(|r| r.env.as_str()).collect();
    envs.dedup();
    for (i, env) in envs.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let points: Vec<(f64, f64, &str)> = study
            .rows
            .iter()
            .filter(|r| r.env == *env)
            .map(|r| (r.coefficients as f64, 100.0 * r.rms_rel, r.basis))
            .collect();
        chart
            .draw_series(
                points
                    .iter()
                    .map(|&(x, y, _)| Circle::new((x, y), 4, colour.filled())),
            )
            .map_err(|e| err(&e))?
            .label(
                Path::new(env)
                    .file_name()
                    .map_or_else(|| env.to_string(), |f| f.to_string_lossy().into_owned()),
            )
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, colour.filled()));
        if i == 0 {
            chart
                .draw_series(points.iter().map(|&(x, y, label)| {
                    Text::new(label.to_string(), (x + 0.3, y), ("sans-serif", 12))
                }))
                .map_err(|e| err(&e))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn l2_of_an_sh_environment_of_order_3_is_exact_and_l1_is_not() {
        let dir = std::env::temp_dir().join(format!("shvis-bases-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("probe.txt");
        std::fs::write(
            &file,
            "2 2 2\n0.3 0.2 0.1\n1.0 0.9 0.8\n0.1 0.1 0.1\n0.2 0.1 0.1\n0 0.1 0\n0.3 0.3 0.3\n0 0 0.1\n0.1 0 0\n",
        )
        .unwrap();
        let study = run(&[format!("sh:{}", file.display())], 12, false).unwrap();
        let row = |b: ShBasis| study.rows.iter().find(|r| r.basis == b.label()).unwrap();
        assert!(row(ShBasis::L2).rms_rel < 1e-12, "{:?}", row(ShBasis::L2));
        assert!(row(ShBasis::L1).rms_rel > 0.01);
        assert!(row(ShBasis::Zh3).rms_rel <= row(ShBasis::L1).rms_rel);
        let md = markdown(&study);
        assert!(md.contains("| L2 |") && md.contains("published"), "{md}");
    }
}
