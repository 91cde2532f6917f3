//! Plots of the reports (plotters): the font they label with, and the bench's error
//! against PCA basis size (Iwanicki–Sloan Fig. 5 as a curve).

use std::path::{Path, PathBuf};

use super::ReportError;
use super::table::BenchRow;

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

/// Registers a TrueType font as plotters' "sans-serif" once per process: `$SHVIS_FONT`
/// if set, else the first of [`FONT_CANDIDATES`] that loads. The font bytes are leaked
/// (plotters keeps `&'static` data); a few hundred KiB, once.
pub fn register_plot_font() -> Result<(), String> {
    static FONT: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    FONT.get_or_init(|| {
        use plotters::style::{FontStyle, register_font};
        let from_env = std::env::var_os("SHVIS_FONT").map(PathBuf::from);
        let candidates = from_env
            .into_iter()
            .chain(FONT_CANDIDATES.iter().map(PathBuf::from));
        for path in candidates {
            if let Ok(bytes) = std::fs::read(&path) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    log::debug!("plot font: {}", path.display());
                    return Ok(());
                }
            }
        }
        Err("no TrueType font found for plot labels; set SHVIS_FONT to a .ttf file".to_owned())
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
    image::save_buffer_with_format(
        path,
        &rgb,
        size.0,
        size.1,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| e.to_string())
}

/// Writes `pca_error_{path}.svg` and `.png`: relative RMSE against M for `pcaN` and
/// `pcaNw` on `path`, with `unc6` as a horizontal line. Returns the files written (none when
/// the rows hold no errors).
pub fn write_pca_error_plot(
    rows: &[BenchRow],
    path: &str,
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    use plotters::prelude::*;
    let series = |weights_only: bool| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| {
                r.path == path
                    && r.technique.starts_with("pca")
                    && r.technique.ends_with('w') == weights_only
            })
            .filter_map(|r| {
                let m: f64 = r
                    .technique
                    .trim_start_matches("pca")
                    .trim_end_matches('w')
                    .parse()
                    .ok()?;
                Some((m, r.rel_rmse?))
            })
            .collect()
    };
    let (table, weights) = (series(false), series(true));
    let unc6 = rows
        .iter()
        .find(|r| r.path == path && r.technique == "unc6")
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
    draw_pca(SVGBackend::new(&svg, (900, 520)).into_drawing_area(), &data)
        .map_err(|e| err(&svg, e))?;
    let png = dir.join(format!("pca_error_{path}.png"));
    write_png_plot(&png, (900, 520), |root| draw_pca(root, &data)).map_err(|e| err(&png, e))?;
    Ok(vec![svg, png])
}

struct PcaPlot<'a> {
    path: &'a str,
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
    let styles = [("pcaN (tables)", &BLUE), ("pcaNw (weights only)", &RED)];
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
            .label("unc6")
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
