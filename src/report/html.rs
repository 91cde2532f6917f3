//! `index.html` of a bench folder: one self-contained page — relative links to
//! the images and plots beside it, no network, a few lines of inline script and no
//! framework — with what a reader compares techniques by: the device and settings, the
//! cost table (click a header to sort), the speed/error, storage/error and PCA plots, the
//! paper's figures, and per hardware path a grid of the reference, every technique and
//! its ×4 difference image, PNG for looking with the EXR linked for data.
//!
//! Images load lazily (grouped by family in collapsible sections). On load the page records
//! in its `<html>` element how many images it has, how many of those fetched failed to
//! decode and how many are not fetched yet (`data-images`, `data-broken-images`,
//! `data-deferred-images`) and any script error
//! (`data-script-errors`): what `tests/report_html.rs` reads back from headless Chromium.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::ReportError;
use super::table::{BenchRow, BenchTable, RowReference};
use crate::technique::HwPath;

/// File name of the page.
pub const INDEX_NAME: &str = "index.html";

/// Text with `&`, `<`, `>`, `"` escaped for HTML.
fn esc(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A table cell: the text shown and, for numbers, the value it sorts by.
fn num(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("<td data-v=\"{v}\">{v:.digits$}</td>"),
        _ => "<td data-v=\"\">—</td>".to_string(),
    }
}

fn int(v: u64) -> String {
    format!("<td data-v=\"{v}\">{v}</td>")
}

const STYLE: &str = "
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; background: #fafafa; }
h1 { margin: 0 0 .3em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ccc; }
dl.settings { display: grid; grid-template-columns: max-content auto; gap: .2em 1em; }
dl.settings dt { font-weight: 600; }
table.cost { border-collapse: collapse; font-variant-numeric: tabular-nums; }
table.cost th, table.cost td { border: 1px solid #ccc; padding: .2em .5em; text-align: right; }
table.cost th { background: #eee; cursor: pointer; position: sticky; top: 0; }
table.cost td:first-child, table.cost td:nth-child(2) { text-align: left; }
tr.clipped td:first-child::after, tr.suspect td:first-child::after { content: ' ⚠'; color: #b00; }
tr.suspect td { background: #fee; }
.scroll { overflow-x: auto; }
.plots { display: grid; grid-template-columns: repeat(auto-fill, minmax(480px, 1fr)); gap: 1em; }
.plots figure, .figures figure { margin: 0; }
.plots img, .figures img { max-width: 100%; border: 1px solid #ddd; background: #fff; }
.grid { display: grid; grid-template-columns: repeat(auto-fill, minmax(320px, 1fr)); gap: 1em; }
.grid figure { margin: 0; background: #fff; border: 1px solid #ddd; padding: .4em; }
.grid .pair { display: grid; grid-template-columns: 1fr 1fr; gap: .3em; }
.grid img { width: 100%; display: block; image-rendering: auto; }
figcaption { font-size: 12px; margin-top: .3em; }
figcaption a { margin-right: .6em; }
details.family summary, details.glossary summary { cursor: pointer; font-weight: bold; margin: .6em 0; }
ul.headline li.warn { color: #b00; }
";

/// What each column of the cost table means.
const GLOSSARY: &str = "<details class=\"glossary\"><summary>Columns</summary><dl>
<dt>ms median, min, max</dt><dd>GPU time of a frame from timestamp queries, over the timed frames (several frames per query on a fast GPU, after the clocks settle).</dd>
<dt>frames</dt><dd>Timed frames, over three rounds on fresh builds.</dd>
<dt>×preconv, paper ×preconv</dt><dd>The row's median over preconv's on the same path; the paper's ratio on a GeForce GTX 295.</dd>
<dt>model ms, ×model</dt><dd>The device cost model's time for the row (lookups, float ops, reads priced by the probe) and measured over modelled.</dd>
<dt>rel. RMSE, against, PSNR dB</dt><dd>Error of the image against the reference (direct light, or the inter-reflected one for techniques that bake inter-reflection).</dd>
<dt>texel bytes, table bytes</dt><dd>GPU memory of the per-texel data and of the lighting tables and uniforms.</dd>
<dt>textures, lookups/px</dt><dd>Textures bound for the draw and fetches per pixel, albedo and normal map included.</dd>
<dt>clipped px</dt><dd>Pixels the f16 target could not hold; ⚠ marks them, and suspect rows (non-finite pixels, an error above 1, or a mean 25 % off the reference's).</dd>
</dl></details>
";

/// Sorts the cost table by the clicked column (numbers by `data-v`, text otherwise) and
/// records image decoding and script errors on `<html>` once the page has loaded.
const SCRIPT: &str = "
window.addEventListener('error', () => {
  const e = document.documentElement;
  e.dataset.scriptErrors = String(Number(e.dataset.scriptErrors || 0) + 1);
});
document.querySelectorAll('table.cost th').forEach((th, col) => {
  th.addEventListener('click', () => {
    const body = th.closest('table').tBodies[0];
    const up = th.dataset.dir !== 'up';
    th.dataset.dir = up ? 'up' : 'down';
    const key = tr => {
      const td = tr.children[col];
      const v = td.dataset.v;
      return v === undefined ? td.textContent : (v === '' ? Infinity : Number(v));
    };
    const rows = Array.from(body.rows);
    rows.sort((a, b) => {
      const x = key(a), y = key(b);
      const c = typeof x === 'number' && typeof y === 'number' ? x - y : String(x).localeCompare(String(y));
      return up ? c : -c;
    });
    rows.forEach(r => body.appendChild(r));
  });
});
window.addEventListener('load', () => {
  const images = Array.from(document.images);
  const e = document.documentElement;
  e.dataset.images = String(images.length);
  // Lazy images far from the viewport are not fetched yet: deferred, not broken.
  const fetched = images.filter(i => i.complete);
  e.dataset.brokenImages = String(fetched.filter(i => i.naturalWidth === 0).length);
  e.dataset.deferredImages = String(images.length - fetched.length);
  e.dataset.scriptErrors = e.dataset.scriptErrors || '0';
});
";

/// The image stem of `row` (its PNG/EXR/difference files are `{stem}.png` …), as the
/// bench writes them.
fn stem(row: &BenchRow) -> String {
    match row.specular {
        Some(f) => format!("{}.{}.spec{}", row.technique, row.path, f.name()),
        None => format!("{}.{}", row.technique, row.path),
    }
}

/// `<img>` of `file` in `dir` when it exists, loaded when it nears the viewport.
fn picture(dir: &Path, file: &str, alt: &str) -> Option<String> {
    dir.join(file).is_file().then(|| {
        format!(
            "<img src=\"{}\" alt=\"{}\" loading=\"lazy\">",
            esc(file),
            esc(alt)
        )
    })
}

fn links(dir: &Path, files: &[(&str, String)]) -> String {
    files
        .iter()
        .filter(|(_, f)| dir.join(f).is_file())
        .map(|(label, f)| format!("<a href=\"{}\">{label}</a>", esc(f)))
        .collect::<Vec<_>>()
        .join("")
}

/// Writes `dir/index.html` for `table`, whose images the bench wrote into `dir`; returns
/// its path.
///
/// # Errors
/// [`ReportError::Write`] when the page cannot be written.
pub fn write_index(table: &BenchTable, dir: &Path) -> Result<PathBuf, ReportError> {
    let path = dir.join(INDEX_NAME);
    super::image::write_file(&path, to_html(table, dir).as_bytes())?;
    Ok(path)
}

/// The page (module doc); `dir` is where the files it links to are looked for.
pub fn to_html(table: &BenchTable, dir: &Path) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>shvis bench — {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        esc(&table.device)
    );
    let _ = write!(
        h,
        "<h1>shvis bench</h1>\n<p>Normal mapping with low-frequency precomputed visibility (Iwanicki &amp; Sloan) and the techniques around it: every technique × hardware path, its GPU time and its error against the ray-traced reference.</p>\n"
    );
    h += &headline(table);
    h += &more_links(dir);
    h += &settings_list(table);
    h += &cost_table(table);
    h += GLOSSARY;
    h += &plots(dir);
    h += &figures(table, dir);
    let paths: Vec<HwPath> = HwPath::ALL
        .iter()
        .copied()
        .filter(|p| table.results.iter().any(|r| r.path == *p))
        .collect();
    for path in paths {
        h += &image_grid(table, dir, path);
    }
    let _ = write!(h, "<script>{SCRIPT}</script>\n</body>\n</html>\n");
    h
}

/// The rows of `path` on the speed/error front: timed and measured, and no other row both
/// faster and more accurate (ties count as neither), fastest first.
pub fn front(rows: &[BenchRow], path: HwPath) -> Vec<&BenchRow> {
    let measured: Vec<(&BenchRow, f64, f64)> = rows
        .iter()
        .filter(|r| r.path == path && r.suspect.is_none() && r.specular.is_none())
        .filter_map(|r| Some((r, r.ms_median?, r.rel_rmse?)))
        .collect();
    let mut front: Vec<(&BenchRow, f64, f64)> = measured
        .iter()
        .copied()
        .filter(|&(_, ms, e)| {
            !measured
                .iter()
                .any(|&(_, ms2, e2)| ms2 <= ms && e2 <= e && (ms2 < ms || e2 < e))
        })
        .collect();
    front.sort_by(|a, b| a.1.total_cmp(&b.1));
    front.into_iter().map(|(r, _, _)| r).collect()
}

/// The best error on `path` and the fastest row within [`NEAR_BEST_ERROR`] of it.
fn near_best(rows: &[BenchRow], path: HwPath) -> Option<(&BenchRow, f64)> {
    let on_path = || {
        rows.iter()
            .filter(|r| r.path == path && r.suspect.is_none())
    };
    let best = on_path()
        .filter_map(|r| r.rel_rmse)
        .min_by(f64::total_cmp)?;
    on_path()
        .filter(|r| {
            r.rel_rmse
                .is_some_and(|e| e <= best * (1.0 + NEAR_BEST_ERROR))
        })
        .filter(|r| r.ms_median.is_some())
        .min_by(|a, b| {
            a.ms_median
                .unwrap_or(f64::MAX)
                .total_cmp(&b.ms_median.unwrap_or(f64::MAX))
        })
        .map(|r| (r, best))
}

/// How close to the best error a row counts as "as good" in the headline.
const NEAR_BEST_ERROR: f64 = 0.05;

/// The headline: where the page's numbers come from, and per path the speed/error front in
/// words; links to the probe's page and the studies' outputs beside the bench.
fn headline(t: &BenchTable) -> String {
    let mut s = String::from("<h2 id=\"headline\">Headline</h2>\n<ul class=\"headline\">\n");
    let _ = writeln!(
        s,
        "<li>{} rows on <b>{}</b>{}, {}×{} frames, a {}² lightmap; errors against a {}-sample reference.</li>",
        t.results.len(),
        esc(&t.device),
        if t.driver.is_empty() {
            String::new()
        } else {
            format!(" ({})", esc(&t.driver))
        },
        t.width,
        t.height,
        t.vis_res,
        t.reference_spp
    );
    for path in HwPath::ALL {
        let names: Vec<String> = front(&t.results, *path)
            .iter()
            .map(|r| {
                format!(
                    "{} ({:.3} ms, {:.4})",
                    r.name(),
                    r.ms_median.unwrap_or(0.0),
                    r.rel_rmse.unwrap_or(0.0)
                )
            })
            .collect();
        if names.is_empty() {
            continue;
        }
        let _ = write!(
            s,
            "<li><b>{path}</b>: the speed/error front, fastest first — {}.",
            esc(&names.join(", "))
        );
        if let Some((r, best)) = near_best(&t.results, *path) {
            let _ = write!(
                s,
                " Fastest within {:.0} % of the best error ({best:.4}): <b>{}</b>.",
                100.0 * NEAR_BEST_ERROR,
                esc(&r.name())
            );
        }
        s += "</li>\n";
    }
    let suspect = t.results.iter().filter(|r| r.suspect.is_some()).count();
    if suspect > 0 {
        let _ = writeln!(
            s,
            "<li class=\"warn\">{suspect} suspect row(s), marked ⚠ in the table: their images cannot be right (hover the row for why).</li>"
        );
    }
    s += "</ul>\n";
    s
}

fn settings_list(t: &BenchTable) -> String {
    let opt = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.4}"));
    let mut s =
        String::from("<h2 id=\"settings\">Device and settings</h2>\n<dl class=\"settings\">\n");
    let mut item = |k: &str, v: String| {
        let _ = writeln!(s, "<dt>{}</dt><dd>{}</dd>", esc(k), esc(&v));
    };
    item("device", t.device.clone());
    item("frame", format!("{}×{}", t.width, t.height));
    item("lightmap", format!("{}² texels", t.vis_res));
    item(
        "reference",
        format!(
            "{} spp, relative noise {} (the floor under every error)",
            t.reference_spp,
            opt(t.reference_rel_noise)
        ),
    );
    if let Some(stride) = t.ladder_stride {
        item(
            "error ladder",
            format!(
                "measured at {}",
                crate::report::table::ladder_grid_words(stride)
            ),
        );
    }
    if t.reference_bounces > 0 {
        item(
            "inter-reflected reference",
            format!(
                "{} bounces (shlmap's), relative noise {}",
                t.reference_bounces,
                opt(t.reference_bounced_rel_noise)
            ),
        );
    }
    if let Some(spec) = &t.specular {
        item("specular term", spec.clone());
    }
    if let Some(relit) = &t.relit {
        item("relit", relit.clone());
    }
    if let Some(measured) = &t.probe_measured {
        item("device probe", format!("measured {measured}"));
    }
    item(
        "bench wall time",
        format!("{:.1} s: {}", t.seconds, t.phases.summary()),
    );
    item("rows", format!("{}", t.results.len()));
    s +=
        "</dl>\n<p>Data: <a href=\"table.json\">table.json</a> · <a href=\"table.md\">table.md</a>";
    s += "</p>\n";
    s
}

/// Links to what else the bench's folder holds: the probe's page, the studies of
/// `make bench-full` (each in a subfolder), where they exist.
fn more_links(dir: &Path) -> String {
    let candidates = [
        ("device probe", "probe.md"),
        ("rnm study", "rnm/rnm.md"),
        ("normal-map generation study", "normalmap/normalmap.md"),
        ("NDF study", "ndf/ndf.md"),
        ("nmprt SVD study", "nmprt/nmprt_svd.md"),
        ("relit bench", "relit90/index.html"),
        ("specular bench", "specular/index.html"),
    ];
    let found: Vec<String> = candidates
        .iter()
        .filter(|(_, f)| dir.join(f).is_file())
        .map(|(label, f)| format!("<a href=\"{}\">{label}</a>", esc(f)))
        .collect();
    if found.is_empty() {
        return String::new();
    }
    format!("<p class=\"more\">Also here: {}</p>\n", found.join(" · "))
}

fn cost_table(t: &BenchTable) -> String {
    let mut s = String::from(
        "<h2 id=\"cost\">Cost table</h2>\n<p>GPU ms from timestamp queries (median, min, max of the timed frames); relative RMSE and PSNR against the reference; bytes of per-texel data and tables. Click a header to sort.</p>\n<div class=\"scroll\"><table class=\"cost\">\n<thead><tr>",
    );
    for head in [
        "technique",
        "path",
        "ms median",
        "ms min",
        "ms max",
        "frames",
        "×preconv",
        "paper ×preconv",
        "model ms",
        "×model",
        "rel. RMSE",
        "against",
        "PSNR dB",
        "texel bytes",
        "table bytes",
        "textures",
        "lookups/px",
        "clipped px",
    ] {
        let _ = write!(s, "<th>{}</th>", esc(head));
    }
    s += "</tr></thead>\n<tbody>\n";
    for r in &t.results {
        let class = match (r.suspect.is_some(), r.clipped_pixels > 0) {
            (true, _) => "row suspect",
            (false, true) => "row clipped",
            (false, false) => "row",
        };
        let title = r.suspect.as_ref().map_or(String::new(), |why| {
            format!(" title=\"suspect: {}\"", esc(why))
        });
        let against = match r.reference {
            RowReference::None => "—".to_string(),
            other => other.to_string(),
        };
        let _ = writeln!(
            s,
            "<tr class=\"{class}\" id=\"row-{}\"{title}><td><a href=\"#img-{}\">{}</a></td><td>{}</td>{}{}{}{}{}{}{}{}{}<td>{}</td>{}{}{}{}{}{}</tr>",
            esc(&stem(r)),
            esc(&stem(r)),
            esc(&r.name()),
            r.path,
            num(r.ms_median, 3),
            num(r.ms_min, 3),
            num(r.ms_max, 3),
            int(r.frames as u64),
            num(r.ratio_to_preconv, 2),
            num(r.paper_ratio_to_preconv, 2),
            num(r.model_ms, 3),
            num(r.x_model, 2),
            num(r.rel_rmse, 4),
            esc(&against),
            num(r.psnr, 2),
            int(r.texel_bytes),
            int(r.table_bytes),
            int(u64::from(r.textures_bound)),
            int(u64::from(r.lookups_per_pixel)),
            int(r.clipped_pixels),
        );
    }
    s += "</tbody>\n</table></div>\n";
    s
}

/// The plots the bench wrote, in reading order, those that exist.
fn plots(dir: &Path) -> String {
    let mut s = String::from("<h2 id=\"plots\">Plots</h2>\n<div class=\"plots\">\n");
    let mut any = false;
    let mut names: Vec<(String, &str)> = vec![
        ("speed_error".into(), "GPU time against error"),
        ("storage_error".into(), "storage against error"),
    ];
    for path in HwPath::ALL {
        names.push((format!("pca_error_{path}"), "PCA: error against basis size"));
    }
    for (stem, what) in &names {
        if let Some(img) = picture(dir, &format!("{stem}.png"), what) {
            any = true;
            let _ = writeln!(
                s,
                "<figure>{img}<figcaption>{} · {}</figcaption></figure>",
                esc(&format!("{what} ({stem})")),
                links(dir, &[("SVG", format!("{stem}.svg"))])
            );
        }
    }
    if !any {
        s += "<p>No plots (the bench had no reference, or no font to label them).</p>\n";
    }
    s += "</div>\n";
    s
}

/// The paper's figures (`fig4_dx9.png` …) and the error ladders' sheets.
fn figures(t: &BenchTable, dir: &Path) -> String {
    let mut s = String::from("<h2 id=\"figures\">Figures</h2>\n<div class=\"figures\">\n");
    let mut any = false;
    for fig in crate::report::figures::FIGURES {
        for path in HwPath::ALL {
            let file = format!("{}_{path}.png", fig.name);
            if let Some(img) = picture(dir, &file, &file) {
                any = true;
                let _ = writeln!(
                    s,
                    "<figure>{img}<figcaption>{}</figcaption></figure>",
                    esc(&file)
                );
            }
        }
    }
    let sheets: Vec<String> = t
        .results
        .iter()
        .map(|r| format!("{}/{}.{}.sheet.png", super::LADDER_DIR, r.technique, r.path))
        .filter(|f| dir.join(f).is_file())
        .collect();
    if !sheets.is_empty() {
        any = true;
        s += "<p>Error ladders (reference → each approximation in turn → the GPU image): ";
        s += &sheets
            .iter()
            .map(|f| format!("<a href=\"{}\">{}</a>", esc(f), esc(f)))
            .collect::<Vec<_>>()
            .join(" · ");
        s += "</p>\n";
    }
    if !any {
        s += "<p>No figures for these rows.</p>\n";
    }
    s += "</div>\n";
    s
}

/// The reference and every row of `path`: image and ×4 difference side by side.
fn image_grid(t: &BenchTable, dir: &Path, path: HwPath) -> String {
    let mut s = format!("<h2 id=\"images-{path}\">Images: {path}</h2>\n<div class=\"grid\">\n");
    for (stem, label) in [
        ("reference", "reference (direct light)".to_string()),
        (
            &*format!("reference_bounces{}", t.reference_bounces),
            format!("reference ({} bounces)", t.reference_bounces),
        ),
    ] {
        if let Some(img) = picture(dir, &format!("{stem}.png"), &label) {
            let _ = writeln!(
                s,
                "<figure>{img}<figcaption>{} {}</figcaption></figure>",
                esc(&label),
                links(dir, &[("EXR", format!("{stem}.exr"))])
            );
        }
    }
    // Rows grouped by family (`technique::catalog`), each group collapsible.
    let mut families: Vec<&str> = Vec::new();
    for r in t.results.iter().filter(|r| r.path == path) {
        let family = crate::technique::catalog::family_of(r.technique);
        if !families.contains(&family) {
            families.push(family);
        }
    }
    for family in families {
        let _ = writeln!(
            s,
            "</div>\n<details open class=\"family\"><summary>{}</summary>\n<div class=\"grid\">",
            esc(family)
        );
        let rows = t.results.iter().filter(|r| {
            r.path == path && crate::technique::catalog::family_of(r.technique) == family
        });
        s += &row_figures(rows, dir);
        s += "</div>\n</details>\n<div class=\"grid\">\n";
    }
    s += "</div>\n";
    s
}

/// Each row's image and ×4 difference side by side, with its caption.
fn row_figures<'a>(rows: impl Iterator<Item = &'a BenchRow>, dir: &Path) -> String {
    let mut s = String::new();
    for r in rows {
        let stem = stem(r);
        let image = picture(dir, &format!("{stem}.png"), &stem).unwrap_or_default();
        let diff_file = format!(
            "{stem}.diff{}.png",
            crate::report::figures::DIFFERENCE_SCALE
        );
        let diff = picture(dir, &diff_file, &format!("{stem} ×4 difference")).unwrap_or_default();
        let error = r
            .rel_rmse
            .map_or(String::new(), |e| format!(" · rel. RMSE {e:.4}"));
        let ms = r
            .ms_median
            .map_or(String::new(), |m| format!(" · {m:.3} ms"));
        let _ = writeln!(
            s,
            "<figure id=\"img-{}\"><div class=\"pair\">{image}{diff}</div><figcaption><b>{}</b>{}{} · {}</figcaption></figure>",
            esc(&stem),
            esc(&r.name()),
            ms,
            error,
            links(
                dir,
                &[
                    ("EXR", format!("{stem}.exr")),
                    ("×4 difference", diff_file.clone()),
                ]
            ) + &format!("<a href=\"#row-{}\">cost row</a>", esc(&stem))
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_rows_no_other_beats_on_both_and_names_the_near_best() {
        use crate::report::table::tests::row;
        let t = |name: &str| name.parse().unwrap();
        let with = |name: &str, ms: f64, e: f64| {
            let mut r = row(t(name), ms, vec![]);
            r.rel_rmse = Some(e);
            r
        };
        let mut absurd = with("ssbump", 0.1, 0.001);
        absurd.suspect = Some("relative RMSE 99 > 1".into());
        let rows = vec![
            with("preconv", 1.0, 0.30),
            with("sh2", 1.2, 0.35), // slower and worse than preconv: off the front
            with("pca8", 2.0, 0.20),
            with("unc6", 8.0, 0.10),
            with("pca16", 3.0, 0.104), // within 5 % of unc6's error, far faster
            absurd,                    // suspect rows are never on the front
        ];
        let names: Vec<String> = front(&rows, HwPath::Dx10)
            .iter()
            .map(|r| r.name())
            .collect();
        assert_eq!(names, ["preconv", "pca8", "pca16", "unc6"]);
        let (near, best) = near_best(&rows, HwPath::Dx10).unwrap();
        assert_eq!((near.name(), best), ("pca16".to_string(), 0.10));
        assert!(front(&rows, HwPath::Dx9).is_empty());
    }

    #[test]
    fn escapes_markup() {
        assert_eq!(esc("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
        assert_eq!(num(Some(1.23456), 2), "<td data-v=\"1.23456\">1.23</td>");
        assert_eq!(num(None, 2), "<td data-v=\"\">—</td>");
    }
}
