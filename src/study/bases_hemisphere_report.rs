//! The hemisphere table of `shvis study bases` as markdown and as a plot: the method, the
//! irradiance error of every basis per environment, per environment its table with the best
//! basis at each byte budget, what the order-8 SH source hides from each basis, and Ambient
//! Dice against L2, L3 and L4 (Iwanicki & Sloan, "Ambient Dice", EGSR 2017, §1: quality
//! comparable to 3rd–5th order SH). The measurement and its equations are
//! [`super::bases_hemisphere`].

use std::path::{Path, PathBuf};

use super::bases_hemisphere::{HemisphereEnv, HemisphereRow, HemisphereStudy, LATLONG, SH_RULE_N};
use super::bases_hemisphere_fits::FAMILIES;

/// Byte budgets per texel at which the best basis is named.
pub const BUDGETS: [usize; 5] = [24, 40, 56, 104, 184];

/// The SH orders Ambient Dice's claim is read against.
const DICE_RIVALS: [&str; 3] = ["L2", "L3", "L4"];

/// The Dice rows.
const DICE_ROWS: [&str; 2] = ["Dice", "Dice YCoCg"];

fn pct(v: f64) -> String {
    format!("{:.2} %", 100.0 * v)
}

fn sci(v: f64) -> String {
    format!("{v:.2e}")
}

/// The rows of environment `env`, in table order.
fn rows_of<'a>(study: &'a HemisphereStudy, env: &str) -> Vec<&'a HemisphereRow> {
    study.rows.iter().filter(|r| r.env == env).collect()
}

/// The section of bases.md: method, summary, one part per environment, Ambient Dice.
pub fn markdown(study: &HemisphereStudy) -> String {
    let mut s = method(study);
    s += &summary(study);
    for info in &study.envs {
        s += &environment(info, &rows_of(study, &info.env));
    }
    s += &dice_section(study);
    s
}

fn method(study: &HemisphereStudy) -> String {
    format!(
        "\n## A floor under each environment: every basis from the same samples\n\n\
         A lightmap texel faces up (+Y; tangent +X, bitangent −Z) and sees only the light \
         above its plane. Every basis is fitted from the same radiance samples of that \
         texel, taken from two sources: **pixels**, the environment's own pixels above the \
         plane at full resolution, each with its exact solid angle (an `sh:` environment has \
         no pixels: its SH on a {n} × {n2} hemisphere rule stands for them), and **sh8**, the \
         environment's order-8 SH on that rule — what the lightmap bake's escaped rays read. \
         SH L1–L4 are projected from the samples; the engine bases encode their order-3 \
         projection (L1 linear and L2 are the rows L1 and L2); the H-basis, Ambient Dice, the \
         ambient cube and the spherical Gaussians (every lobe count and solver) are fitted \
         from the samples (`sh::samples`). One truth serves both sources, the pixels': \
         irradiance E(n) = Σ w L max(0, n·ω) over them by brute force, radiance the pixels \
         themselves (read bilinearly at the lat-long pixels).\n\n\
         Errors are on luminance, each reconstruction clamped at 0 as its shader clamps it:\n\n\
         - **(a)** the solid-angle-weighted relative RMS, √(Σ w (Ê − E)²) / √(Σ w E²): for \
         irradiance over the {normals} normals of a hemisphere rule, for radiance over the \
         pixels;\n\
         - **(b)** the per-pixel MSE over a {w} × {h} lat-long image of the upper hemisphere, \
         every pixel weighted alike as Probulator-style published comparisons weigh them: \
         relative, MSE / mean(E²) (a squared measure: (a)² where error and truth are both \
         constant), and absolute, in luminance² of the environment's units.\n\n\
         Radiance is measured for the bases that store it, SH and SG. The H-basis, Ambient \
         Dice and the ambient cube store irradiance only, and the engine bases reconstruct \
         irradiance only, so their radiance columns read \"—\". Bytes per texel are those of \
         the lightmap on dx10, RGBA16F texels of four values: 8 ⌈values / 4⌉. For SG, \"< 0\" \
         is the share of amplitudes the solver made negative.\n",
        n = SH_RULE_N,
        n2 = 2 * SH_RULE_N,
        normals = study.normals,
        w = LATLONG[0],
        h = LATLONG[1],
    )
}

/// Irradiance error (a) from the pixels, a column per environment.
fn summary(study: &HemisphereStudy) -> String {
    let Some(first) = study.envs.first() else {
        return String::new();
    };
    let mut s =
        String::from("\n### Irradiance error (a) from the pixels\n\n| basis | values | bytes |");
    for info in &study.envs {
        s += &format!(" `{}` |", info.env);
    }
    s += "\n|---|---:|---:|";
    s += &"---:|".repeat(study.envs.len());
    s += "\n";
    for r in rows_of(study, &first.env) {
        s += &format!("| {} | {} | {} |", r.basis, r.values, r.bytes);
        for info in &study.envs {
            let cell = study
                .rows
                .iter()
                .find(|o| o.env == info.env && o.basis == r.basis)
                .map_or_else(|| "—".to_string(), |o| pct(o.full.irradiance.rms_rel));
            s += &format!(" {cell} |");
        }
        s += "\n";
    }
    s
}

/// One environment: its samples, its table and its three sentences.
fn environment(info: &HemisphereEnv, rows: &[&HemisphereRow]) -> String {
    let filtered = if info.pixel_step > 1 {
        format!(
            ", box-filtered {0} × {0} to stay within the study's sample budget",
            info.pixel_step
        )
    } else {
        String::new()
    };
    let mut s = format!(
        "\n### `{}`\n\n\
         Samples: {} from the {}{filtered}; sh8: the order-{} SH on {} nodes.\n\n\
         | basis | values | bytes | E (a) | E (a) sh8 | E (b) rel | E (b) | L (a) | L (a) sh8 \
         | L (b) rel | L (b) | < 0 |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        info.env, info.full_samples, info.full_kind, info.sh8_order, info.sh8_samples
    );
    let dash = || "—".to_string();
    for r in rows {
        let (e, e8) = (&r.full.irradiance, &r.sh8.irradiance);
        let (l, l8) = (r.full.radiance, r.sh8.radiance);
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.basis,
            r.values,
            r.bytes,
            pct(e.rms_rel),
            pct(e8.rms_rel),
            sci(e.mse_rel),
            sci(e.mse),
            l.map_or_else(dash, |v| pct(v.rms_rel)),
            l8.map_or_else(dash, |v| pct(v.rms_rel)),
            l.map_or_else(dash, |v| sci(v.mse_rel)),
            l.map_or_else(dash, |v| sci(v.mse)),
            r.full
                .negative_amplitudes
                .map_or_else(dash, |v| format!("{:.1} %", 100.0 * v)),
        );
    }
    s += &format!("\n{}\n", budget_sentence(rows));
    if let Some(dice) = dice_sentence(&info.env, rows) {
        s += &format!("\n{dice}\n");
    }
    s += &format!("\n{}\n", source_sentence(rows));
    s
}

/// The lowest irradiance error (a) from the pixels among the rows of at most each budget.
fn budget_sentence(rows: &[&HemisphereRow]) -> String {
    let parts: Vec<String> = BUDGETS
        .iter()
        .map(|&budget| {
            let best = rows.iter().filter(|r| r.bytes <= budget).min_by(|a, b| {
                a.full
                    .irradiance
                    .rms_rel
                    .total_cmp(&b.full.irradiance.rms_rel)
            });
            match best {
                Some(r) => format!(
                    "{budget} B: {} ({}, {} B)",
                    r.basis,
                    pct(r.full.irradiance.rms_rel),
                    r.bytes
                ),
                None => format!("{budget} B: none fits"),
            }
        })
        .collect();
    format!(
        "Best irradiance (a, from the pixels) within each budget of bytes per texel — {}.",
        parts.join("; ")
    )
}

/// Irradiance error (a) from the pixels of the row `basis`.
fn irradiance_error(rows: &[&HemisphereRow], basis: &str) -> Option<f64> {
    rows.iter()
        .find(|r| r.basis == basis)
        .map(|r| r.full.irradiance.rms_rel)
}

/// Which of [`DICE_RIVALS`] the row `dice` beats on irradiance (a) from the pixels.
fn dice_beats(rows: &[&HemisphereRow], dice: &str) -> Option<(f64, [bool; 3])> {
    let error = irradiance_error(rows, dice)?;
    let mut beats = [false; 3];
    for (b, rival) in beats.iter_mut().zip(DICE_RIVALS) {
        *b = error < irradiance_error(rows, rival)?;
    }
    Some((error, beats))
}

/// "beats L2 and L3 but not L4".
fn beats_phrase(beats: [bool; 3]) -> String {
    let (yes, no): (Vec<&str>, Vec<&str>) = {
        let yes = DICE_RIVALS
            .iter()
            .zip(beats)
            .filter(|(_, b)| *b)
            .map(|(r, _)| *r);
        let no = DICE_RIVALS
            .iter()
            .zip(beats)
            .filter(|(_, b)| !*b)
            .map(|(r, _)| *r);
        (yes.collect(), no.collect())
    };
    match (yes.is_empty(), no.is_empty()) {
        (true, _) => format!("beats none of {}", DICE_RIVALS.join(", ")),
        (false, true) => format!("beats all of {}", DICE_RIVALS.join(", ")),
        (false, false) => format!("beats {} but not {}", yes.join(" and "), no.join(" or ")),
    }
}

/// One environment's verdict on the Ambient Dice claim.
fn dice_sentence(env: &str, rows: &[&HemisphereRow]) -> Option<String> {
    let rivals: Vec<String> = DICE_RIVALS
        .iter()
        .map(|r| Some(format!("{r} {}", pct(irradiance_error(rows, r)?))))
        .collect::<Option<_>>()?;
    let verdicts: Vec<String> = DICE_ROWS
        .iter()
        .map(|d| {
            let (error, beats) = dice_beats(rows, d)?;
            Some(format!("{d} ({}) {}", pct(error), beats_phrase(beats)))
        })
        .collect::<Option<_>>()?;
    Some(format!(
        "Ambient Dice on `{env}` (irradiance (a) from the pixels; {}): {}.",
        rivals.join(", "),
        verdicts.join("; ")
    ))
}

/// What fitting from the order-8 SH instead of the pixels does to each basis' errors.
fn source_sentence(rows: &[&HemisphereRow]) -> String {
    let irradiance: Vec<(f64, f64, &str)> = rows
        .iter()
        .map(|r| {
            (
                r.full.irradiance.rms_rel,
                r.sh8.irradiance.rms_rel,
                r.basis.as_str(),
            )
        })
        .collect();
    let radiance: Vec<(f64, f64, &str)> = rows
        .iter()
        .filter_map(|r| {
            Some((
                r.full.radiance?.rms_rel,
                r.sh8.radiance?.rms_rel,
                r.basis.as_str(),
            ))
        })
        .collect();
    let mut s = String::from("Fitted from the order-8 SH instead of the pixels,");
    match change_phrase(&irradiance) {
        Some(p) => s += &format!(" the irradiance error (a) of the bases changes by {p}"),
        None => return String::new(),
    }
    if let Some(p) = change_phrase(&radiance) {
        s += &format!("; the radiance error (a) of those that store radiance by {p}");
    }
    s + "."
}

/// "−0.10 to +2.31 points (median +0.05); most for SG9 ls (8.90 % → 11.21 %)" of
/// (from the pixels, from the SH, basis) triples.
fn change_phrase(errors: &[(f64, f64, &str)]) -> Option<String> {
    let mut deltas: Vec<(f64, usize)> = errors
        .iter()
        .enumerate()
        .map(|(i, (full, sh8, _))| (100.0 * (sh8 - full), i))
        .collect();
    deltas.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (lowest, highest) = (deltas.first()?.0, deltas.last()?.0);
    let median = deltas[deltas.len() / 2].0;
    let &(_, most) = deltas
        .iter()
        .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))?;
    let (full, sh8, basis) = errors[most];
    Some(format!(
        "{lowest:+.2} to {highest:+.2} points (median {median:+.2}); most for {basis} ({} → {})",
        pct(full),
        pct(sh8)
    ))
}

/// Ambient Dice against L2, L3, L4: a table over the environments and the overall verdict.
fn dice_section(study: &HemisphereStudy) -> String {
    let mut s = String::from(
        "\n### Ambient Dice against L2, L3 and L4\n\n\
         Iwanicki & Sloan (\"Ambient Dice\", EGSR 2017) claim quality comparable to 3rd–5th \
         order SH, the rows L2–L4 here. Our Dice covers the upper hemisphere (the 10 of the \
         icosahedron's 12 vertices a normal above the surface reads) and stores irradiance, \
         so it is compared on irradiance over the hemisphere: error (a), from the pixels.\n\n\
         | environment | Dice | Dice YCoCg | L2 | L3 | L4 | Dice vs SH | Dice YCoCg vs SH |\n\
         |---|---:|---:|---:|---:|---:|---|---|\n",
    );
    let mut wins = [[0usize; 3]; 2];
    let mut counted = 0;
    for info in &study.envs {
        let rows = rows_of(study, &info.env);
        let cell = |basis: &str| irradiance_error(&rows, basis).map_or_else(|| "—".into(), pct);
        let verdicts: Vec<Option<(f64, [bool; 3])>> =
            DICE_ROWS.iter().map(|d| dice_beats(&rows, d)).collect();
        let phrase =
            |v: &Option<(f64, [bool; 3])>| v.map_or_else(|| "—".into(), |v| beats_phrase(v.1));
        s += &format!(
            "| `{}` | {} | {} | {} | {} | {} | {} | {} |\n",
            info.env,
            cell("Dice"),
            cell("Dice YCoCg"),
            cell("L2"),
            cell("L3"),
            cell("L4"),
            phrase(&verdicts[0]),
            phrase(&verdicts[1]),
        );
        if let [Some((_, rgb)), Some((_, ycocg))] = verdicts[..] {
            counted += 1;
            for (w, beats) in wins.iter_mut().zip([rgb, ycocg]) {
                for (count, b) in w.iter_mut().zip(beats) {
                    *count += usize::from(b);
                }
            }
        }
    }
    if counted > 0 {
        let on = |k: usize| match k {
            0 => "on none".to_string(),
            k if k == counted => "on every one".to_string(),
            k => format!("on {k} of {counted}"),
        };
        let overall: Vec<String> = DICE_ROWS
            .iter()
            .zip(wins)
            .map(|(d, w)| {
                let parts: Vec<String> = DICE_RIVALS
                    .iter()
                    .zip(w)
                    .map(|(r, k)| format!("{r} {}", on(k)))
                    .collect();
                format!("{d} beats {}", parts.join(", "))
            })
            .collect();
        let environments = if counted == 1 {
            "environment"
        } else {
            "environments"
        };
        s += &format!(
            "\nOverall, over the {counted} {environments}: {}.\n",
            overall.join("; ")
        );
    }
    s
}

/// bases_hemisphere.svg / .png: irradiance error (a) from the pixels against bytes per
/// texel, a panel per environment, a series per family (its best at each size joined).
/// Returns the files written (none without environments).
///
/// # Errors
/// A message when plotters fails or no font is found for the labels.
pub fn write_plot(study: &HemisphereStudy, dir: &Path) -> Result<Vec<PathBuf>, String> {
    use crate::report::plot::{register_plot_font, write_png_plot, write_svg_plot};
    if study.envs.is_empty() {
        return Ok(Vec::new());
    }
    register_plot_font()?;
    let cols = study.envs.len().min(3);
    let grid = (study.envs.len().div_ceil(cols), cols);
    let size = (480 * grid.1 as u32, 400 * grid.0 as u32);
    let svg = dir.join("bases_hemisphere.svg");
    let png = dir.join("bases_hemisphere.png");
    write_svg_plot(&svg, size, |root| draw(root, study, grid))?;
    write_png_plot(&png, size, |root| draw(root, study, grid))?;
    Ok(vec![svg, png])
}

fn draw<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    study: &HemisphereStudy,
    grid: (usize, usize),
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    root.fill(&WHITE).map_err(|e| format!("{e:?}"))?;
    for (panel, info) in root.split_evenly(grid).iter().zip(&study.envs) {
        draw_panel(panel, &info.env, &rows_of(study, &info.env))?;
    }
    root.present().map_err(|e| format!("{e:?}"))
}

fn draw_panel<DB: plotters::prelude::DrawingBackend>(
    panel: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    env: &str,
    rows: &[&HemisphereRow],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let err = |e: &dyn std::fmt::Debug| format!("{e:?}");
    // A log axis cannot show an exact reconstruction: those points are left out.
    let points: Vec<(f64, f64, &str)> = rows
        .iter()
        .filter(|r| r.full.irradiance.rms_rel > 0.0)
        .map(|r| (r.bytes as f64, 100.0 * r.full.irradiance.rms_rel, r.family))
        .collect();
    if points.is_empty() {
        return Ok(());
    }
    let (lo, hi) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let x_max = 1.1 * points.iter().map(|p| p.0).fold(0.0, f64::max);
    let title = Path::new(env)
        .file_name()
        .map_or_else(|| env.to_string(), |f| f.to_string_lossy().into_owned());
    let mut chart = ChartBuilder::on(panel)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..x_max, (0.7 * lo..1.4 * hi).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("bytes per texel (dx10)")
        .y_desc("irradiance RMS (a), %")
        .y_label_formatter(&|y| format!("{y:.2}"))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, family) in FAMILIES.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let mine: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.2 == *family)
            .map(|p| (p.0, p.1))
            .collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(LineSeries::new(
                best_per_size(&mine),
                colour.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label(*family)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(mine.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .map_err(|e| err(&e))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))
}

/// The lowest error at each size, by size.
fn best_per_size(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted = points.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    sorted.dedup_by(|next, kept| next.0 == kept.0);
    sorted
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::bases_hemisphere::{Errors, SourceErrors};

    fn row(env: &str, basis: &str, bytes: usize, full: f64, sh8: f64) -> HemisphereRow {
        let errors = |e: f64| SourceErrors {
            irradiance: Errors {
                rms_rel: e,
                mse_rel: e * e,
                mse: e * e,
            },
            radiance: None,
            negative_amplitudes: None,
        };
        HemisphereRow {
            env: env.to_string(),
            basis: basis.to_string(),
            family: FAMILIES[0],
            values: bytes / 2,
            bytes,
            full: errors(full),
            sh8: errors(sh8),
        }
    }

    #[test]
    fn sentences_name_the_best_basis_per_budget_and_dice_against_sh() {
        let rows = vec![
            row("e", "L1", 24, 0.20, 0.21),
            row("e", "H6", 40, 0.08, 0.09),
            row("e", "L2", 56, 0.06, 0.07),
            row("e", "L3", 96, 0.03, 0.06),
            row("e", "Dice YCoCg", 104, 0.05, 0.06),
            row("e", "L4", 152, 0.02, 0.04),
            row("e", "Dice", 184, 0.04, 0.05),
        ];
        let refs: Vec<&HemisphereRow> = rows.iter().collect();
        let budget = budget_sentence(&refs);
        assert!(budget.contains("24 B: L1 (20.00 %, 24 B)"), "{budget}");
        assert!(budget.contains("40 B: H6"), "{budget}");
        assert!(budget.contains("104 B: L3"), "{budget}");
        assert!(budget.contains("184 B: L4"), "{budget}");
        let dice = dice_sentence("e", &refs).expect("every row is there");
        assert!(
            dice.contains("Dice (4.00 %) beats L2 but not L3 or L4"),
            "{dice}"
        );
        let source = source_sentence(&refs);
        assert!(source.contains("most for L3 (3.00 % → 6.00 %)"), "{source}");
        let study = HemisphereStudy {
            normals: 128,
            latlong: LATLONG,
            envs: vec![HemisphereEnv {
                env: "e".to_string(),
                full_kind: "pixels",
                full_samples: 10,
                pixel_step: 1,
                sh8_samples: 10,
                sh8_order: 8,
            }],
            rows,
        };
        let md = markdown(&study);
        assert!(
            md.contains("Dice beats L2 on every one, L3 on none, L4 on none"),
            "{md}"
        );
        assert!(md.contains("| L2 | 28 | 56 | 6.00 % |"), "{md}");
    }
}
