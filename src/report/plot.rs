//! Plots of the reports (plotters): the font they label with, and the bench's error
//! against PCA basis size (Iwanicki–Sloan Fig. 5 as a curve).

use std::path::{Path, PathBuf};

use super::ReportError;
use super::table::{BenchRow, RowReference};
use crate::sh::Order;
use crate::technique::{HwPath, Technique};

/// The uncompressed row the PCA plot compares with.
const UNC6: Technique = Technique::Unc(crate::technique::Unc { order: Order::SIX });

/// TrueType fonts tried, in order, for plot labels after `$SHVIS_FONT`. plotters is built
/// with `ab_glyph` (no system font lookup), so a font file must be registered by hand.
pub const FONT_CANDIDATES: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/noto/NotoSans-Regular.ttf",
    "/usr/share/fonts/noto/NotoSans-Regular.ttf",
    "/Library/Fonts/Arial.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// The variable naming the plot labels' TrueType font.
pub const FONT_ENV: &str = "SHVIS_FONT";

/// Largest font file read (the usual sans fonts are well under 2 MiB).
const MAX_FONT_BYTES: u64 = 64 << 20;

/// Registers a TrueType font as plotters' "sans-serif" once per process: `$SHVIS_FONT`
/// if set (an error when it is not a font), else the first of [`FONT_CANDIDATES`] that
/// loads. The font bytes are leaked (plotters keeps `&'static` data); a few hundred KiB,
/// once.
pub fn register_plot_font() -> Result<(), String> {
    static FONT: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    FONT.get_or_init(|| {
        let register = |bytes: Vec<u8>| {
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes)
                .is_ok()
        };
        if let Some(path) = std::env::var_os(FONT_ENV).map(PathBuf::from) {
            let bytes = crate::files::read_bounded(&path, MAX_FONT_BYTES, "a font")
                .map_err(|e| format!("{FONT_ENV}: {e}"))?;
            if !register(bytes) {
                return Err(format!(
                    "{FONT_ENV}={}: not a TrueType font",
                    path.display()
                ));
            }
            log::debug!("plot font: {}", path.display());
            return Ok(());
        }
        for path in FONT_CANDIDATES.iter().map(PathBuf::from) {
            if let Ok(bytes) = crate::files::read_bounded(&path, MAX_FONT_BYTES, "a font")
                && register(bytes)
            {
                log::debug!("plot font: {}", path.display());
                return Ok(());
            }
        }
        Err(format!(
            "no TrueType font found for plot labels; set {FONT_ENV} to a .ttf file"
        ))
    })
    .clone()
}

/// Draws into an RGB bitmap and encodes it as PNG with the `image` crate (plotters' own
/// encoder would pull in a second, older `image`).
pub fn write_png_plot<F>(path: &Path, size: (u32, u32), draw: F) -> Result<(), String>
where
    F: for<'a> FnOnce(
        plotters::prelude::DrawingArea<plotters::prelude::BitMapBackend<'a>, plotters::coord::Shift>,
    ) -> Result<(), String>,
{
    use plotters::prelude::{BitMapBackend, IntoDrawingArea};
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    draw(BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area())?;
    let png = super::image::encode_png(&rgb, size.0, size.1, image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    crate::files::write(path, png).map_err(|e| e.to_string())
}

/// Draws an SVG into memory and writes it atomically (`files::write`).
pub fn write_svg_plot<F>(path: &Path, size: (u32, u32), draw: F) -> Result<(), String>
where
    F: for<'a> FnOnce(
        plotters::prelude::DrawingArea<plotters::prelude::SVGBackend<'a>, plotters::coord::Shift>,
    ) -> Result<(), String>,
{
    use plotters::prelude::{IntoDrawingArea, SVGBackend};
    let mut svg = String::new();
    draw(SVGBackend::with_string(&mut svg, size).into_drawing_area())?;
    crate::files::write(path, svg).map_err(|e| e.to_string())
}

/// Writes `pca_error_{path}.svg` and `.png`: relative RMSE against M for `pcaN` and
/// `pcaNw` on `path`, with `unc6` as a horizontal line. Returns the files written (none when
/// the rows hold no errors).
pub fn write_pca_error_plot(
    rows: &[BenchRow],
    path: HwPath,
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    let series = |weights_only: bool| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.path == path && r.specular.is_none())
            .filter_map(|r| {
                let Technique::Pca(pca) = r.technique else {
                    return None;
                };
                (pca.weights_only == weights_only).then_some((f64::from(pca.m), r.rel_rmse?))
            })
            .collect()
    };
    let (table, weights) = (series(false), series(true));
    let unc6 = rows
        .iter()
        .find(|r| r.path == path && r.technique == UNC6)
        .and_then(|r| r.rel_rmse);
    if table.is_empty() && weights.is_empty() {
        return Ok(vec![]);
    }
    let svg = dir.join(format!("pca_error_{path}.svg"));
    let err = |path: &Path, e: String| ReportError::Write {
        path: path.to_path_buf(),
        detail: e,
    };
    register_plot_font().map_err(|e| err(&svg, e))?;
    let all: Vec<f64> = table
        .iter()
        .chain(&weights)
        .map(|p| p.1)
        .chain(unc6)
        .collect();
    let (lo, hi) = all
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
    let data = PcaPlot {
        path,
        table: &table,
        weights: &weights,
        unc6,
        lo,
        hi,
    };
    write_svg_plot(&svg, (900, 520), |root| draw_pca(root, &data)).map_err(|e| err(&svg, e))?;
    let png = dir.join(format!("pca_error_{path}.png"));
    write_png_plot(&png, (900, 520), |root| draw_pca(root, &data)).map_err(|e| err(&png, e))?;
    Ok(vec![svg, png])
}

struct PcaPlot<'a> {
    path: HwPath,
    table: &'a [(f64, f64)],
    weights: &'a [(f64, f64)],
    unc6: Option<f64>,
    lo: f64,
    hi: f64,
}

fn draw_pca<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    d: &PcaPlot<'_>,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    root.fill(&WHITE).map_err(|e| format!("{e:?}"))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "Relative RMSE against the reference vs PCA basis size ({})",
                d.path
            ),
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..26.0, (d.lo * 0.9)..(d.hi * 1.05))
        .map_err(|e| format!("{e:?}"))?;
    chart
        .configure_mesh()
        .x_desc("M (basis vectors)")
        .y_desc("relative RMSE")
        .draw()
        .map_err(|e| format!("{e:?}"))?;
    let styles = [
        ("a table per basis vector", &BLUE),
        ("weights only (basis in uniforms)", &RED),
    ];
    for ((name, colour), data) in styles.iter().zip([d.table, d.weights]) {
        let c = *colour;
        chart
            .draw_series(LineSeries::new(data.iter().copied(), c.stroke_width(2)))
            .map_err(|e| format!("{e:?}"))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart
            .draw_series(data.iter().map(|&p| Circle::new(p, 4, c.filled())))
            .map_err(|e| format!("{e:?}"))?;
    }
    if let Some(u) = d.unc6 {
        chart
            .draw_series(LineSeries::new(
                [(0.0, u), (26.0, u)],
                BLACK.stroke_width(1),
            ))
            .map_err(|e| format!("{e:?}"))?
            .label(UNC6.name())
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()
        .map_err(|e| format!("{e:?}"))?;
    root.present().map_err(|e| format!("{e:?}"))
}

/// Indices of the points on the Pareto front of (time, error), both minimized: no other
/// point is at least as fast and at least as accurate and better in one. Sorted by time.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best_error = f64::INFINITY;
    for i in order {
        if points[i].1 < best_error {
            best_error = points[i].1;
            front.push(i);
        }
    }
    front
}

/// The x axis of an error plot: what a row costs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CostAxis {
    /// Median ms per frame (`speed_error.*`).
    Time,
    /// GPU bytes of per-texel data plus tables and uniforms (`storage_error.*`).
    Storage,
}

impl CostAxis {
    fn stem(self) -> &'static str {
        match self {
            CostAxis::Time => "speed_error",
            CostAxis::Storage => "storage_error",
        }
    }

    fn of(self, row: &super::table::BenchRow) -> Option<f64> {
        match self {
            CostAxis::Time => row.ms_median.filter(|&m| m > 0.0),
            CostAxis::Storage => {
                Some((row.texel_bytes + row.table_bytes) as f64).filter(|&b| b > 0.0)
            }
        }
    }

    fn label(self, x: f64) -> String {
        match self {
            CostAxis::Time if x >= 10.0 => format!("{x:.0}"),
            CostAxis::Time => format!("{x:.2}"),
            CostAxis::Storage => {
                let kib = x / 1024.0;
                if kib >= 1024.0 {
                    format!("{:.1} Mi", kib / 1024.0)
                } else {
                    format!("{kib:.0} Ki")
                }
            }
        }
    }

    fn description(self) -> &'static str {
        match self {
            CostAxis::Time => "ms per frame, median (log scale)",
            CostAxis::Storage => "bytes on the GPU: per-texel data + tables + uniforms (log scale)",
        }
    }

    fn title(self) -> &'static str {
        match self {
            CostAxis::Time => "Speed against error",
            CostAxis::Storage => "Storage against error",
        }
    }
}

/// Writes `{speed,storage}_error.svg` and `.png`: relative RMSE against the row's cost
/// (`axis`, log scale) for every row with both, one colour and marker per path, the Pareto
/// front of each path drawn as a staircase through its points (filled markers; dominated
/// points hollow). Returns the files written (none when no row has both figures).
pub fn write_error_plot(
    table: &super::table::BenchTable,
    dir: &Path,
    axis: CostAxis,
) -> Result<Vec<PathBuf>, ReportError> {
    let points: Vec<SpeedErrorPoint> = table
        .results
        .iter()
        .filter_map(|r| {
            let starred = r.reference != RowReference::Direct;
            Some(SpeedErrorPoint {
                label: format!(
                    "{}{}{}",
                    r.name(),
                    if starred { "*" } else { "" },
                    if r.suspect.is_some() {
                        " (suspect)"
                    } else {
                        ""
                    }
                ),
                path: r.path.to_string(),
                ms: axis.of(r)?,
                error: r.rel_rmse?,
                on_front: false,
            })
        })
        .collect();
    if points.is_empty() {
        return Ok(vec![]);
    }
    let mut points = points;
    let mut paths: Vec<String> = points.iter().map(|p| p.path.clone()).collect();
    paths.sort();
    paths.dedup();
    for path in &paths {
        let idx: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].path == *path)
            .collect();
        let xy: Vec<(f64, f64)> = idx
            .iter()
            .map(|&i| (points[i].ms, points[i].error))
            .collect();
        for k in pareto_front(&xy) {
            points[idx[k]].on_front = true;
        }
    }
    let svg = dir.join(format!("{}.svg", axis.stem()));
    let err = |path: &Path, e: String| ReportError::Write {
        path: path.to_path_buf(),
        detail: e,
    };
    register_plot_font().map_err(|e| err(&svg, e))?;
    let starred = table
        .results
        .iter()
        .find(|r| matches!(r.reference, RowReference::Bounced(_)))
        .map(|r| {
            format!(
                "{}* against the reference with {}",
                r.technique, r.reference
            )
        });
    let title = format!(
        "{} · {} · {}×{}",
        axis.title(),
        table.device,
        table.width,
        table.height
    );
    let data = SpeedErrorPlot {
        title: &title,
        note: starred.as_deref(),
        points: &points,
        paths: &paths,
        axis,
    };
    let size = (1100, 700);
    write_svg_plot(&svg, size, |root| draw_speed_error(root, &data)).map_err(|e| err(&svg, e))?;
    let png = dir.join(format!("{}.png", axis.stem()));
    write_png_plot(&png, size, |root| draw_speed_error(root, &data)).map_err(|e| err(&png, e))?;
    Ok(vec![svg, png])
}

struct SpeedErrorPoint {
    label: String,
    path: String,
    /// The cost (x): ms or bytes.
    ms: f64,
    error: f64,
    on_front: bool,
}

struct SpeedErrorPlot<'a> {
    title: &'a str,
    note: Option<&'a str>,
    points: &'a [SpeedErrorPoint],
    paths: &'a [String],
    axis: CostAxis,
}

fn draw_speed_error<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    d: &SpeedErrorPlot<'_>,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("{e:?}");
    root.fill(&WHITE).map_err(e)?;
    let (ms_lo, ms_hi, err_lo, err_hi) = d.points.iter().fold(
        (f64::MAX, f64::MIN, f64::MAX, f64::MIN),
        |(a, b, c, dd), p| (a.min(p.ms), b.max(p.ms), c.min(p.error), dd.max(p.error)),
    );
    let err_pad = 0.08 * (err_hi - err_lo).max(1e-3);
    let mut chart = ChartBuilder::on(&root)
        .caption(d.title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        // x is ln(ms) on a linear axis labelled in ms: a log axis whose labels plotters
        // cannot drop when the range spans less than a decade.
        .build_cartesian_2d(
            (ms_lo * 0.8).ln()..(ms_hi * 1.25).ln(),
            (err_lo - err_pad).max(0.0)..(err_hi + err_pad),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_labels(12)
        .x_label_formatter(&|x| d.axis.label(x.exp()))
        .x_desc(match d.note {
            Some(n) => format!("{}    [{n}]", d.axis.description()),
            None => d.axis.description().to_string(),
        })
        .y_desc("relative RMSE against the reference")
        .draw()
        .map_err(e)?;
    let palette = [BLUE, RED, GREEN, MAGENTA];
    for (k, path) in d.paths.iter().enumerate() {
        let colour = palette[k % palette.len()];
        let mut front: Vec<&SpeedErrorPoint> = d
            .points
            .iter()
            .filter(|p| p.path == *path && p.on_front)
            .collect();
        front.sort_by(|a, b| a.ms.total_cmp(&b.ms));
        // Staircase: from each front point, right at its error, then down to the next.
        let mut stairs = Vec::new();
        for (i, p) in front.iter().enumerate() {
            stairs.push((p.ms.ln(), p.error));
            if let Some(next) = front.get(i + 1) {
                stairs.push((next.ms.ln(), p.error));
            }
        }
        if let Some(last) = front.last() {
            stairs.push(((ms_hi * 1.25).ln(), last.error));
        }
        chart
            .draw_series(LineSeries::new(stairs, colour.stroke_width(2)))
            .map_err(e)?
            .label(format!(
                "{path}: Pareto front (filled and named: on it; hollow: dominated, see the table)"
            ))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        for p in d.points.iter().filter(|p| p.path == *path) {
            let style = if p.on_front {
                colour.filled()
            } else {
                colour.stroke_width(1)
            };
            // Only the front is labelled (the table names every row): labels above the
            // first path's points and below the second's keep one technique's apart.
            let dy = if k % 2 == 1 { 5 } else { -17 };
            let label = if p.on_front {
                p.label.clone()
            } else {
                String::new()
            };
            let marker = EmptyElement::at((p.ms.ln(), p.error))
                + Circle::new((0, 0), 5, style)
                + Text::new(
                    label,
                    (6, dy),
                    ("sans-serif", 13).into_font().color(&colour),
                );
            chart.draw_series(std::iter::once(marker)).map_err(e)?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()
        .map_err(e)?;
    root.present().map_err(|e| format!("{e:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        // (ms, error): 1 is dominated by 0 (slower and worse), 3 by 2 (same speed,
        // worse); 4 is slowest but best.
        let pts = [
            (1.0, 0.5),
            (2.0, 0.6),
            (3.0, 0.3),
            (3.0, 0.4),
            (9.0, 0.1),
            (f64::NAN, 0.0),
        ];
        assert_eq!(pareto_front(&pts), vec![0, 2, 4]);
        assert!(pareto_front(&[]).is_empty());
    }
}
