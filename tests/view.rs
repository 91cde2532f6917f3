//! `shvis view` through a real swapchain under Xvfb (installed by `make deps`):
//! N frames presented, one technique switch, the sun animating with lighting rebuilds
//! swapped in, validation on; the last frame read back from the swapchain must not be
//! blank and must equal `shvis render` of the same technique and view outside the
//! overlay's box (the viewer encodes exactly as the PNG writer; f16 noise allowed: ≤ 1
//! level in 8 bits).

use std::path::{Path, PathBuf};
use std::process::Command;

fn xvfb_run() -> PathBuf {
    std::env::var_os("PATH")
        .and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| d.join("xvfb-run"))
                .find(|p| p.is_file())
        })
        .unwrap_or_else(|| {
            panic!(
                "xvfb-run not found: `make deps` installs it (as root: apt-get install xvfb xauth)"
            )
        })
}

/// `shvis view ARGS` under Xvfb, with the shared bake cache and warnings only.
fn run_view(args: &[&str], cache: &str) -> std::process::Output {
    Command::new(xvfb_run())
        .args([
            "-a",
            "-s",
            "-screen 0 1024x768x24",
            env!("CARGO_BIN_EXE_shvis"),
            "view",
        ])
        .args(args)
        .env("SHVIS_CACHE_DIR", cache)
        .env("RUST_LOG", "warn")
        .output()
        .expect("xvfb-run runs")
}

fn rgb(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

#[test]
fn viewer_presents_switches_and_matches_render() {
    let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("view");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let cache = concat!(env!("CARGO_TARGET_TMPDIR"), "/bake-cache");
    let (w, h) = (480u32, 300u32);
    let common = [
        "--vis-res",
        "64",
        "--rays",
        "64",
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
        "--validate",
    ]
    .map(String::from);
    let shot = root.join("view.png");
    let shot_arg = shot.display().to_string();
    let mut args = vec![
        "--techniques",
        "preconv,unc6",
        "--path",
        "dx10",
        "--frames",
        "12",
        "--switch-at",
        "4",
        "--screenshot",
        &shot_arg,
    ];
    args.extend(common.iter().map(String::as_str));
    let view = run_view(&args, cache);
    let stdout = String::from_utf8_lossy(&view.stdout);
    let stderr = String::from_utf8_lossy(&view.stderr);
    assert!(view.status.success(), "view failed:\n{stdout}\n{stderr}");
    assert!(
        stdout.contains("preconv.dx10: 3 frames") && stdout.contains("unc6.dx10: 8 frames"),
        "frames per technique (the first frame is not timed): {stdout}"
    );
    println!("{stdout}");

    let render_png = root.join("render.png");
    let render = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(["render", "--technique", "unc6", "--path", "dx10"])
        .args(&common)
        .arg("--out")
        .arg(&render_png)
        .env("SHVIS_CACHE_DIR", cache)
        .env("RUST_LOG", "warn")
        .output()
        .expect("shvis runs");
    assert!(
        render.status.success(),
        "{}",
        String::from_utf8_lossy(&render.stderr)
    );
    let (a, b) = (rgb(&shot), rgb(&render_png));
    assert_eq!(a.dimensions(), (w, h));
    assert_eq!(b.dimensions(), (w, h));
    let (bw, bh) = shvis::view::OVERLAY_BOX;
    let mut worst = 0u8;
    let mut compared = 0usize;
    let mut distinct = std::collections::HashSet::new();
    for (x, y, p) in a.enumerate_pixels() {
        distinct.insert(p.0);
        if x < bw && y < bh {
            continue; // the overlay
        }
        let q = b.get_pixel(x, y);
        for c in 0..3 {
            worst = worst.max(p.0[c].abs_diff(q.0[c]));
        }
        compared += 1;
    }
    assert!(
        distinct.len() > 50,
        "the screenshot is nearly blank ({} colours)",
        distinct.len()
    );
    assert!(compared > (w * h / 2) as usize);
    assert!(
        worst <= 1,
        "the swapchain frame differs from render by up to {worst} levels"
    );

    // The sun animating: lighting rebuilt on the worker and swapped in, validation clean.
    let spin = run_view(
        &[
            "--techniques",
            "unc6",
            "--path",
            "dx9",
            "--frames",
            "60",
            "--animate",
            "3",
            "--every",
            "2",
            "--no-overlay",
            "--vis-res",
            "64",
            "--rays",
            "64",
            "--width",
            "160",
            "--height",
            "100",
            "--validate",
        ],
        cache,
    );
    let stdout = String::from_utf8_lossy(&spin.stdout);
    assert!(
        spin.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&spin.stderr)
    );
    let rebuilds: usize = stdout
        .split("lighting rebuilds swapped in: ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|t| t.parse().ok())
        .unwrap_or(0);
    assert!(
        rebuilds >= 2,
        "only {rebuilds} lighting rebuilds swapped in: {stdout}"
    );
    println!("{stdout}");
}
