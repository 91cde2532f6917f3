//! The bench's `index.html` in a real browser. A small bench (3 techniques × 2
//! paths at 96×60) writes its folder; headless Chromium (Debian's `chromium`, installed by
//! `make deps`) loads the page from disk and must report no console message, no fetched
//! `<img>` that failed to decode (naturalWidth 0, read back from the attributes the page
//! sets on load; images are lazy, so those far below are not fetched), no script error,
//! and one cost-table row per technique × path; every `src` and `href` of the page names a
//! file in the folder, and every PNG among them decodes. A screenshot goes to
//! `target/tmp/report_html/index.png`.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The Chromium binary, or a failure saying how to install it (never a silent skip).
fn chromium() -> PathBuf {
    for name in [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ] {
        let found = std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| d.join(name))
                .find(|p| p.is_file())
        });
        if let Some(p) = found {
            return p;
        }
    }
    panic!(
        "headless Chromium not found: `make deps` installs it (as root: apt-get install chromium)"
    );
}

/// Chromium's common flags: headless, no sandbox (tests may run as root), no GPU, no
/// first-run work, console messages logged to stderr.
fn browser(args: &[&str], page: &Path, profile: &Path) -> std::process::Output {
    let url = format!("file://{}", page.display());
    Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--no-first-run",
            "--hide-scrollbars",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .output()
        .expect("chromium runs")
}

/// The value of `data-NAME="…"` on the dumped `<html>` element.
fn html_attribute(dom: &str, name: &str) -> Option<String> {
    let html = &dom[dom.find("<html")?..];
    let html = &html[..html.find('>')?];
    let key = format!("data-{name}=\"");
    let start = html.find(&key)? + key.len();
    Some(html[start..start + html[start..].find('"')?].to_string())
}

#[test]
fn bench_report_loads_in_headless_chromium() {
    let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("report_html");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let out = root.join("bench");
    // An earlier run's images (of a row this run does not measure) and a note of the user's.
    std::fs::create_dir_all(out.join("ladder")).unwrap();
    for earlier in ["sh2.dx9.png", "sh2.dx9.exr", "ladder/sh2.dx9.sheet.png"] {
        std::fs::write(out.join(earlier), b"an earlier run").unwrap();
    }
    std::fs::write(out.join("notes.txt"), b"kept").unwrap();
    let techniques = ["unc3", "pca4", "preconv"];
    let paths = ["dx9", "dx10"];
    let bench = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args([
            "bench",
            "--techniques",
            &techniques.join(","),
            "--paths",
            &paths.join(","),
            "--width",
            "96",
            "--height",
            "60",
            "--frames",
            "2",
            "--warmup",
            "0",
            "--ref-spp",
            "4",
            "--vis-res",
            "64",
            "--rays",
            "64",
            "--no-probe",
            "--validate",
            "--out",
        ])
        .arg(&out)
        .env(
            "SHVIS_CACHE_DIR",
            concat!(env!("CARGO_TARGET_TMPDIR"), "/bake-cache"),
        )
        .env("RUST_LOG", "warn")
        .output()
        .expect("shvis runs");
    assert!(
        bench.status.success(),
        "bench failed: {}",
        String::from_utf8_lossy(&bench.stderr)
    );
    let page = out.join("index.html");
    assert!(page.is_file(), "no index.html in {}", out.display());
    for earlier in ["sh2.dx9.png", "sh2.dx9.exr", "ladder/sh2.dx9.sheet.png"] {
        assert!(
            !out.join(earlier).exists(),
            "the earlier run's {earlier} is still there"
        );
    }
    assert!(
        out.join("notes.txt").is_file(),
        "a file that is not an image was removed"
    );

    let profile = root.join("profile");
    let dump = browser(
        &["--virtual-time-budget=20000", "--dump-dom"],
        &page,
        &profile,
    );
    let dom = String::from_utf8_lossy(&dump.stdout);
    let log = String::from_utf8_lossy(&dump.stderr);
    assert!(dump.status.success(), "chromium failed: {log}");
    let console: Vec<&str> = log.lines().filter(|l| l.contains("CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:#?}");
    let images: usize = html_attribute(&dom, "images")
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| {
            panic!(
                "the page's load handler did not run: {}",
                &dom[..dom.len().min(400)]
            )
        });
    let broken = html_attribute(&dom, "broken-images");
    let script_errors = html_attribute(&dom, "script-errors");
    // Per path: the reference and 3 rows × (image + difference); 2 plots, the PCA plot per
    // path, and the paper's figures where the rows fill them.
    assert!(
        images >= 2 * (1 + 2 * techniques.len()) + 2,
        "only {images} images"
    );
    assert_eq!(broken.as_deref(), Some("0"), "images that did not decode");
    assert_eq!(script_errors.as_deref(), Some("0"), "script errors");
    let linked = check_links(
        &out,
        &std::fs::read_to_string(&page).expect("index.html reads"),
    );
    let rows = dom.matches("<tr class=\"row").count();
    assert_eq!(rows, techniques.len() * paths.len(), "cost-table rows");
    for t in techniques {
        for p in paths {
            assert!(
                dom.contains(&format!("id=\"row-{t}.{p}\"")),
                "no row {t}.{p}"
            );
        }
    }

    let shot = root.join("index.png");
    let screenshot = browser(
        &[
            "--virtual-time-budget=20000",
            "--window-size=1280,2400",
            &format!("--screenshot={}", shot.display()),
        ],
        &page,
        &profile,
    );
    assert!(
        screenshot.status.success(),
        "{}",
        String::from_utf8_lossy(&screenshot.stderr)
    );
    let img = image::open(&shot)
        .expect("the screenshot decodes")
        .to_rgb8();
    let distinct: std::collections::HashSet<[u8; 3]> =
        img.pixels().step_by(97).map(|p| p.0).collect();
    assert!(
        distinct.len() > 20,
        "the screenshot is nearly blank ({} colours)",
        distinct.len()
    );
    println!(
        "{images} images, none broken; {linked} links resolve; {rows} rows; screenshot {}",
        shot.display()
    );
}

/// Every `src="…"` and `href="…"` of `html` that is not a fragment or a URL names a file
/// under `dir`, and every PNG among them decodes. Returns how many were checked.
fn check_links(dir: &Path, html: &str) -> usize {
    let mut checked = 0;
    for attribute in ["src=\"", "href=\""] {
        for (at, _) in html.match_indices(attribute) {
            let rest = &html[at + attribute.len()..];
            let target = &rest[..rest.find('"').expect("a closed attribute")];
            if target.starts_with('#') || target.contains("://") || target.starts_with("data:") {
                continue;
            }
            let target = target.replace("&amp;", "&");
            let file = dir.join(&target);
            assert!(
                file.is_file(),
                "the page links {target}, which is not in {}",
                dir.display()
            );
            if target.ends_with(".png") {
                image::open(&file).unwrap_or_else(|e| panic!("{target} does not decode: {e}"));
            }
            checked += 1;
        }
    }
    assert!(checked > 0, "the page links nothing");
    checked
}
