//! `--baker gpu` reaches `render` and `bench` — the visibility the
//! techniques read is baked by the GPU simulator on the device that renders, validation
//! on, and the image stays close to the CPU-baked one (the two bakes differ by about the
//! quadrature noise).

mod scratch;

use scratch::Scratch;
use std::path::PathBuf;
use std::process::{Command, Output};

fn shvis(args: &[&str], cache: &PathBuf) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(args)
        .env("RUST_LOG", "info")
        .env("SHVIS_CACHE_DIR", cache)
        .output()
        .expect("shvis runs")
}

#[test]
fn render_bakes_visibility_on_the_gpu_when_asked() {
    let dir = Scratch::new("baker", "gpu");
    let render = |baker: &str| {
        let out = dir.join(format!("{baker}.png"));
        let args = [
            "render",
            "--technique",
            "unc4",
            "--path",
            "dx10",
            "--vis-res",
            "64",
            "--rays",
            "64",
            "--width",
            "96",
            "--height",
            "60",
            "--validate",
            "--baker",
            baker,
            "--out",
            out.to_str().unwrap(),
        ];
        let output = shvis(&args, &dir.join("cache"));
        let stderr = String::from_utf8_lossy(&output.stderr).to_string();
        assert!(output.status.success(), "--baker {baker}: {stderr}");
        (image::open(&out).expect("the PNG").to_rgb8(), stderr)
    };
    let (cpu, cpu_log) = render("cpu");
    let (gpu, gpu_log) = render("gpu");
    assert!(
        gpu_log.contains("visibility on the GPU simulator"),
        "{gpu_log}"
    );
    assert!(!cpu_log.contains("GPU simulator"), "{cpu_log}");
    let (sum, n) = cpu
        .pixels()
        .zip(gpu.pixels())
        .flat_map(|(a, b)| (0..3).map(move |c| (f64::from(a[c]) - f64::from(b[c])).abs()))
        .fold((0.0, 0usize), |(s, n), d| (s + d, n + 1));
    let mean = sum / n as f64;
    println!("mean |cpu − gpu| = {mean:.3} of 255");
    assert!(
        mean < 3.0,
        "the GPU-baked image is far from the CPU-baked one: {mean}"
    );
}
