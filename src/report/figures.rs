//! The paper's comparison figures from bench images (Iwanicki–Sloan Figs. 4–6): difference
//! images scaled by 4 (the paper's 400 %) and composite sheets of labelled tiles.
//!
//! ```text
//! Fig. 4  unc6 · pca4 · pca16 / shlmap · preconv · sh2
//! Fig. 5  pca4 · pca12 · pca24 · unc6 / ×4 differences to unc6 (unc6: to the reference)
//! Fig. 6  unc3 · unc4 · unc6 / ×4 differences to unc6 (unc6: to the reference)
//! ```

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use super::ReportError;
use super::image::to_srgb8;
use crate::render::Frame;
use crate::sh::Order;
use crate::technique::{HwPath, Technique};

/// Difference images are scaled by this (the paper's "400 %").
pub const DIFFERENCE_SCALE: f32 = 4.0;
/// Height of a tile's caption band, pixels.
const CAPTION_HEIGHT: u32 = 22;

const fn unc(order: Order) -> Technique {
    Technique::Unc(crate::technique::Unc { order })
}
const fn pca(m: u32) -> Technique {
    Technique::Pca(crate::technique::Pca {
        m,
        weights_only: false,
    })
}

/// A figure: rows of tiles.
pub struct FigureSpec {
    /// File stem: `fig4` → `fig4_{path}.png`.
    pub name: &'static str,
    /// The top row's techniques.
    pub top: &'static [Technique],
    /// The bottom row: techniques (`None`), or differences of each top tile to this one.
    pub differences_to: Option<Technique>,
    /// For Fig. 4, a second row of techniques.
    pub bottom: &'static [Technique],
}

/// Figs. 4–6 of the paper.
pub const FIGURES: &[FigureSpec] = &[
    FigureSpec {
        name: "fig4",
        top: &[unc(Order::SIX), pca(4), pca(16)],
        differences_to: None,
        bottom: &[
            Technique::Shlmap(crate::technique::Shlmap),
            Technique::Preconv(crate::technique::Preconv),
            Technique::Sh2(crate::technique::Sh2),
        ],
    },
    FigureSpec {
        name: "fig5",
        top: &[pca(4), pca(12), pca(24), unc(Order::SIX)],
        differences_to: Some(unc(Order::SIX)),
        bottom: &[],
    },
    FigureSpec {
        name: "fig6",
        top: &[unc(Order::THREE), unc(Order::FOUR), unc(Order::SIX)],
        differences_to: Some(unc(Order::SIX)),
        bottom: &[],
    },
];

impl FigureSpec {
    /// Every technique whose image the figure needs.
    pub fn techniques(&self) -> impl Iterator<Item = Technique> + '_ {
        self.top.iter().chain(self.bottom).copied()
    }
}

/// |a − b| × `scale` per channel, where both are covered (alpha 1), else background.
pub fn difference(a: &Frame, b: &Frame, scale: f32) -> Frame {
    let rgba = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .map(|(p, q)| {
            if p[3] < 0.5 || q[3] < 0.5 {
                [0.0; 4]
            } else {
                [
                    (p[0] - q[0]).abs() * scale,
                    (p[1] - q[1]).abs() * scale,
                    (p[2] - q[2]).abs() * scale,
                    1.0,
                ]
            }
        })
        .collect();
    Frame {
        width: a.width,
        height: a.height,
        rgba,
        ms: vec![],
    }
}

/// Writes `{figure}_{path}.png` for every figure whose images `image` can find (`None`:
/// the technique was not run). Tiles are the frames at `exposure`, captioned. Returns the
/// files written.
pub fn write_figures<'a>(
    dir: &Path,
    path: HwPath,
    reference: Option<&Frame>,
    image: &dyn Fn(Technique) -> Option<&'a Frame>,
    exposure: f32,
) -> Result<Vec<PathBuf>, ReportError> {
    let mut written = Vec::new();
    for fig in FIGURES {
        if fig.techniques().any(|t| image(t).is_none()) {
            continue;
        }
        let find = |t: Technique| image(t).expect("checked above");
        let tile = |t: Technique| (t.name(), Cow::Borrowed(find(t)));
        let top: Vec<(String, Cow<'_, Frame>)> = fig.top.iter().map(|&t| tile(t)).collect();
        let bottom: Vec<(String, Cow<'_, Frame>)> = match fig.differences_to {
            None => fig.bottom.iter().map(|&t| tile(t)).collect(),
            Some(base) => fig
                .top
                .iter()
                .filter_map(|&t| {
                    if t != base {
                        let label = format!("|{t} − {base}| ×{DIFFERENCE_SCALE}");
                        let d = difference(find(t), find(base), DIFFERENCE_SCALE);
                        Some((label, Cow::Owned(d)))
                    } else {
                        let r = reference?;
                        let label = format!("|{t} − reference| ×{DIFFERENCE_SCALE}");
                        Some((label, Cow::Owned(difference(find(t), r, DIFFERENCE_SCALE))))
                    }
                })
                .collect(),
        };
        let file = dir.join(format!("{}_{path}.png", fig.name));
        write_sheet(&file, &[top, bottom], exposure)?;
        written.push(file);
    }
    Ok(written)
}

/// Tiles no wider than this in ladder sheets (frames are box-filtered down to fit).
pub const LADDER_TILE_WIDTH: u32 = 400;

/// An error ladder as one sheet: the rungs' images left to right (captioned), and below
/// each rung after the first its ×4 difference to the previous one. Tiles are box-filtered
/// to at most [`LADDER_TILE_WIDTH`] wide.
pub fn write_ladder_sheet(
    file: &Path,
    rungs: &[(String, &Frame)],
    exposure: f32,
) -> Result<(), ReportError> {
    let factor = rungs
        .first()
        .map_or(1, |(_, f)| f.width.div_ceil(LADDER_TILE_WIDTH).max(1));
    let small: Vec<Frame> = rungs.iter().map(|(_, f)| downsample(f, factor)).collect();
    let top = rungs
        .iter()
        .zip(&small)
        .map(|((label, _), f)| (label.clone(), Cow::Borrowed(f)))
        .collect();
    let bottom = small
        .windows(2)
        .zip(&rungs[1..])
        .map(|(pair, (label, _))| {
            let d = difference(&pair[1], &pair[0], DIFFERENCE_SCALE);
            (format!("Δ {label} ×{DIFFERENCE_SCALE}"), Cow::Owned(d))
        })
        .collect();
    write_sheet(file, &[top, bottom], exposure)
}

/// `frame` box-filtered by `factor` per axis (covered pixels only; alpha = coverage).
fn downsample(frame: &Frame, factor: u32) -> Frame {
    if factor <= 1 {
        return frame.clone();
    }
    let (w, h) = (frame.width / factor, frame.height / factor);
    let mut rgba = vec![[0.0f32; 4]; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let (mut sum, mut covered) = ([0.0f32; 3], 0u32);
            for dy in 0..factor {
                for dx in 0..factor {
                    let p =
                        frame.rgba[((y * factor + dy) * frame.width + x * factor + dx) as usize];
                    if p[3] >= 0.5 {
                        covered += 1;
                        for c in 0..3 {
                            sum[c] += p[c];
                        }
                    }
                }
            }
            if covered > 0 {
                let n = covered as f32;
                rgba[(y * w + x) as usize] = [sum[0] / n, sum[1] / n, sum[2] / n, 1.0];
            }
        }
    }
    Frame {
        width: w,
        height: h,
        rgba,
        ms: vec![],
    }
}

/// Tiles `rows` (all frames one size) into one PNG with a caption band above each tile.
pub fn write_sheet(
    file: &Path,
    rows: &[Vec<(String, Cow<'_, Frame>)>],
    exposure: f32,
) -> Result<(), ReportError> {
    let err = |detail: String| ReportError::Write {
        path: file.to_path_buf(),
        detail,
    };
    let first = rows
        .iter()
        .flatten()
        .next()
        .ok_or_else(|| err("a sheet needs at least one image".into()))?;
    let (tw, th) = (first.1.width, first.1.height + CAPTION_HEIGHT);
    let columns = rows.iter().map(Vec::len).max().unwrap_or(0) as u32;
    let (width, height) = (tw * columns, th * rows.len() as u32);
    let mut rgb = vec![255u8; (width * height * 3) as usize];
    for (r, row) in rows.iter().enumerate() {
        for (c, (_, frame)) in row.iter().enumerate() {
            if (frame.width, frame.height + CAPTION_HEIGHT) != (tw, th) {
                return Err(err("sheet tiles differ in size".into()));
            }
            let tile = to_srgb8(frame, exposure);
            let (x0, y0) = (c as u32 * tw, r as u32 * th + CAPTION_HEIGHT);
            for y in 0..frame.height {
                let src = (y * frame.width * 3) as usize;
                let dst = (((y0 + y) * width + x0) * 3) as usize;
                rgb[dst..dst + (frame.width * 3) as usize]
                    .copy_from_slice(&tile[src..src + (frame.width * 3) as usize]);
            }
        }
    }
    draw_captions(&mut rgb, (width, height), rows, (tw, th)).map_err(err)?;
    image::save_buffer_with_format(
        file,
        &rgb,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| err(e.to_string()))
}

fn draw_captions(
    rgb: &mut [u8],
    size: (u32, u32),
    rows: &[Vec<(String, Cow<'_, Frame>)>],
    tile: (u32, u32),
) -> Result<(), String> {
    use plotters::prelude::*;
    super::plot::register_plot_font()?;
    let root = BitMapBackend::with_buffer(rgb, size).into_drawing_area();
    let style = ("sans-serif", 16).into_font().color(&BLACK);
    for (r, row) in rows.iter().enumerate() {
        for (c, (label, _)) in row.iter().enumerate() {
            let at = (c as i32 * tile.0 as i32 + 6, r as i32 * tile.1 as i32 + 3);
            root.draw_text(label, &style, at)
                .map_err(|e| format!("{e:?}"))?;
        }
    }
    root.present().map_err(|e| format!("{e:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(width: u32, height: u32, value: f32) -> Frame {
        Frame {
            width,
            height,
            rgba: vec![[value, value, value, 1.0]; (width * height) as usize],
            ms: vec![],
        }
    }

    #[test]
    fn difference_is_scaled_and_skips_background() {
        let mut a = frame(2, 1, 0.5);
        let b = frame(2, 1, 0.25);
        a.rgba[1][3] = 0.0;
        let d = difference(&a, &b, DIFFERENCE_SCALE);
        assert_eq!(d.rgba[0], [1.0, 1.0, 1.0, 1.0]);
        assert_eq!(d.rgba[1], [0.0; 4]);
    }

    #[test]
    fn figures_need_only_techniques_of_the_cost_table() {
        for fig in FIGURES {
            for t in fig.techniques() {
                assert!(Technique::all().contains(&t), "{}: {t}", fig.name);
            }
            if let Some(base) = fig.differences_to {
                assert!(fig.top.contains(&base));
            }
        }
    }
}
