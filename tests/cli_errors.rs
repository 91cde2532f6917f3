//! Bad input at the command line: each case exits non-zero with one `error:` line that
//! names the input, and never panics (DESIGN §4).

mod cli_run;
mod scratch;

use cli_run::{assert_one_error_line, shvis};
use scratch::Scratch;
use std::process::Command;

fn scratch(name: &str) -> Scratch {
    Scratch::new("cli", name)
}

/// A render command that would be quick if its input were good.
fn render_args<'a>(env: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "render",
        "--technique",
        "preconv",
        "--vis-res",
        "64",
        "--rays",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "--env",
        env,
        "--out",
        out,
    ]
}

#[test]
fn missing_env_file() {
    let dir = scratch("missing");
    let out_png = dir.join("x.png");
    let out = shvis(
        &render_args("/no/such/probe.exr", out_png.to_str().unwrap()),
        &[],
    );
    assert_one_error_line(&out, &["/no/such/probe.exr", "cannot read"]);
}

#[test]
fn env_file_of_the_wrong_format() {
    let dir = scratch("format");
    let bogus = dir.join("notes.exr");
    std::fs::write(&bogus, "these are not texels\n").unwrap();
    let out_png = dir.join("x.png");
    let out = shvis(
        &render_args(bogus.to_str().unwrap(), out_png.to_str().unwrap()),
        &[],
    );
    assert_one_error_line(&out, &["notes.exr"]);
}

#[test]
fn unknown_technique_lists_the_names() {
    let out = shvis(&["render", "--technique", "unc7", "--out", "x.png"], &[]);
    assert_one_error_line(&out, &["unc7", "preconv"]);
}

#[test]
fn unknown_path_lists_the_names() {
    let out = shvis(
        &[
            "render",
            "--technique",
            "preconv",
            "--path",
            "dx12",
            "--out",
            "x.png",
        ],
        &[],
    );
    assert_one_error_line(&out, &["dx12", "dx9", "dx10", "dx11"]);
}

#[test]
fn zero_width() {
    let out = shvis(
        &[
            "render",
            "--technique",
            "preconv",
            "--width",
            "0",
            "--out",
            "x.png",
        ],
        &[],
    );
    assert_one_error_line(&out, &["--width"]);
}

#[test]
fn absurd_lightmap_resolution() {
    let dir = scratch("visres");
    let out = shvis(
        &[
            "bake",
            "--vis-res",
            "100000",
            "--out",
            dir.to_str().unwrap(),
        ],
        &[],
    );
    assert_one_error_line(&out, &["100000"]);
}

#[test]
fn no_vulkan_device_at_all() {
    let dir = scratch("noicd");
    let out_png = dir.join("x.png");
    let missing_icd = dir.join("no-such-icd.json");
    let icd = missing_icd.to_str().unwrap();
    let out = shvis(
        &render_args("sky", out_png.to_str().unwrap()),
        &[("VK_ICD_FILENAMES", icd), ("VK_DRIVER_FILES", icd)],
    );
    assert_one_error_line(&out, &["no Vulkan device"]);
}

#[test]
fn unsupported_output_extension() {
    let out = shvis(&["render", "--technique", "preconv", "--out", "x.bmp"], &[]);
    assert_one_error_line(&out, &["x.bmp", ".png or .exr"]);
}

/// `shvis study bases --envs ENV --out OUT`.
fn study_bases(env: &str, out: &std::path::Path) -> std::process::Output {
    shvis(
        &[
            "study",
            "bases",
            "--envs",
            env,
            "--out",
            out.to_str().unwrap(),
        ],
        &[],
    )
}

#[test]
fn sh_coefficient_environments_missing_or_malformed() {
    let dir = scratch("sh_env");
    let out_png = dir.join("x.png");
    let out = shvis(
        &render_args("sh:/no/such/coeffs.txt", out_png.to_str().unwrap()),
        &[],
    );
    assert_one_error_line(&out, &["/no/such/coeffs.txt", "cannot read"]);
    let five = dir.join("five.txt");
    std::fs::write(&five, "1 1 1\n0 0 0\n0 0 0\n0 0 0\n0 0 0\n").unwrap();
    let env = format!("sh:{}", five.display());
    let out = shvis(&render_args(&env, out_png.to_str().unwrap()), &[]);
    assert_one_error_line(&out, &["five.txt", "5 coefficients"]);
    let study_out = dir.join("bases");
    let out = study_bases(&env, &study_out);
    assert_one_error_line(&out, &["five.txt", "5 coefficients"]);
    let out = shvis(&render_args("sh:", out_png.to_str().unwrap()), &[]);
    assert_one_error_line(&out, &["sh:FILE needs the path"]);
}

#[test]
fn an_sh_environment_is_studied_and_printed_back() {
    // `sh project` of an sh: environment returns its coefficients (the map is rasterised
    // finely enough), and `study bases` measures it: L2 of an order-3 radiance is exact.
    let dir = scratch("sh_env_ok");
    let file = dir.join("probe.txt");
    let coeffs = "2 2 2\n0.3 0.2 0.1\n1.0 0.9 0.8\n0.1 0.1 0.1\n0.2 0.1 0.1\n0 0.1 0\n0.3 0.3 0.3\n0 0 0.1\n0.1 0 0\n";
    std::fs::write(&file, coeffs).unwrap();
    let env = format!("sh:{}", file.display());
    let out = shvis(&["sh", "project", "--env", &env, "--order", "3"], &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let back: Vec<f64> = String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    let want: Vec<f64> = coeffs
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(back.len(), 27);
    for (b, w) in back.iter().zip(&want) {
        assert!((b - w).abs() < 1e-3, "{back:?}");
    }
    let study_out = dir.join("bases");
    let out = study_bases(&env, &study_out);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(study_out.join("bases.json")).unwrap())
            .unwrap();
    let l2 = json["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["basis"] == "L2")
        .unwrap();
    assert!(l2["rms_rel"].as_f64().unwrap() < 1e-9, "{l2}");
    for f in ["bases.md", "bases_error.svg", "bases_error.png"] {
        assert!(study_out.join(f).is_file(), "{f}");
    }
}

#[test]
fn sh_order_out_of_range() {
    for order in ["0", "31"] {
        let out = shvis(&["sh", "eval", "--order", order], &[]);
        assert_one_error_line(&out, &["order", order]);
    }
}

#[test]
fn sh_zero_and_nan_directions() {
    for dir in ["0 0 0", "nan 0 1", "1 2"] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_shvis"))
            .args(["sh", "eval", "--order", "3"])
            .env("RUST_LOG", "off")
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        use std::io::Write;
        writeln!(child.stdin.take().unwrap(), "{dir}").unwrap();
        let out = child.wait_with_output().unwrap();
        assert_one_error_line(&out, &["stdin line 1"]);
    }
    let out = shvis(&["sh", "irradiance", "--normal", "0,0,0"], &[]);
    assert_one_error_line(&out, &["--normal", "zero-length"]);
}

#[test]
fn absurd_bounce_count() {
    let out = shvis(&["reference", "--bounces", "99", "--out", "x.exr"], &[]);
    assert_one_error_line(&out, &["--bounces", "99"]);
    let out = shvis(
        &[
            "render",
            "--technique",
            "shlmap",
            "--bounces",
            "two",
            "--out",
            "x.png",
        ],
        &[],
    );
    assert_one_error_line(&out, &["--bounces", "two"]);
}

#[test]
fn clustered_names_out_of_range_and_seams_of_an_unclustered_technique() {
    // 32 clusters × 16 values overflow the 64 KiB uniform block: not a nameable technique.
    let out = shvis(
        &["render", "--technique", "cpca32_15", "--out", "x.png"],
        &[],
    );
    assert_one_error_line(&out, &["cpca32_15", "cpcaK_M"]);
    let out = shvis(&["study", "seams", "--techniques", "unc6"], &[]);
    assert_one_error_line(&out, &["unc6", "not a clustered technique"]);
}

#[test]
fn ssbump_bad_height_map_and_scale() {
    let out = shvis(
        &[
            "ssbump",
            "--height-map",
            "/no/such/h.png",
            "--height-scale",
            "2",
            "--out",
            "x.png",
        ],
        &[],
    );
    assert_one_error_line(&out, &["/no/such/h.png", "cannot read"]);
    let out = shvis(
        &[
            "ssbump",
            "--height-map",
            "h.png",
            "--height-scale",
            "0",
            "--out",
            "x.png",
        ],
        &[],
    );
    assert_one_error_line(&out, &["--height-scale"]);
}

#[test]
fn height_maps_displacement_and_sun_elevation() {
    let dir = scratch("height");
    let out_png = dir.join("x.png");
    let out_png = out_png.to_str().unwrap();
    let mut args = render_args("sky", out_png);
    args[2] = "ssbump";
    args.extend(["--height-map", "/no/such/height.png", "--height-scale", "4"]);
    let out = shvis(&args, &[]);
    assert_one_error_line(&out, &["/no/such/height.png", "cannot read the height map"]);
    // A scale without a map is a usage error; a map with a zero scale is refused.
    let mut args = render_args("sky", out_png);
    args.extend(["--height-scale", "4"]);
    let out = shvis(&args, &[]);
    assert!(!out.status.success());
    let mut args = render_args("sky", out_png);
    args.extend(["--height-map", "/no/such/height.png", "--height-scale", "0"]);
    assert_one_error_line(&shvis(&args, &[]), &["height scale 0"]);
    // The house is far too large to displace at one vertex per height texel.
    let out = shvis(
        &[
            "reference",
            "--scene",
            "house",
            "--displaced",
            "--width",
            "8",
            "--height",
            "8",
            "--out",
            out_png,
        ],
        &[],
    );
    assert_one_error_line(&out, &["house", "triangles", "patio"]);
    for env in ["sky:0", "sky:high"] {
        let out = shvis(&render_args(env, out_png), &[]);
        assert_one_error_line(&out, &[env, "sun elevation"]);
    }
}

#[test]
fn normalmap_bad_meshes_sizes_and_outputs() {
    let dir = scratch("normalmap");
    let out = dir.join("n.png");
    let out = out.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["normalmap", "--map-res", "64"];
        args.extend_from_slice(extra);
        shvis(&args, &[])
    };
    assert_one_error_line(
        &run(&["--high", "sphere:3", "--low", "missing.gltf", "--out", out]),
        &["missing.gltf"],
    );
    assert_one_error_line(
        &run(&["--high", "sphere:12", "--low", "sphere:1", "--out", out]),
        &["sphere:12", "0..=9"],
    );
    assert_one_error_line(
        &run(&["--high", "sphere:3", "--low", "sphere:1", "--out", "n.jpg"]),
        &["n.jpg", ".png or .exr"],
    );
    assert_one_error_line(
        &shvis(
            &[
                "normalmap",
                "--map-res",
                "100000",
                "--high",
                "sphere:3",
                "--low",
                "sphere:1",
                "--out",
                out,
            ],
            &[],
        ),
        &["--map-res 100000"],
    );
    assert_one_error_line(
        &run(&["--high", "sphere:3", "--simplify", "1.5", "--out", out]),
        &["--simplify 1.5"],
    );
    assert_one_error_line(
        &run(&[
            "--high",
            "sphere:3",
            "--low",
            "sphere:1",
            "--distance",
            "-1",
            "--out",
            out,
        ]),
        &["search distance -1"],
    );
    // A low mesh far from the high one: nothing within the search distance.
    assert_one_error_line(
        &run(&[
            "--high",
            "sphere:3",
            "--low",
            "sphere:1",
            "--distance",
            "1e-6",
            "--baker",
            "gpu",
            "--out",
            out,
        ]),
        &["within"],
    );
}

#[test]
fn study_ndf_bad_sigma_and_light() {
    let dir = scratch("ndf");
    let out = dir.to_str().unwrap();
    assert_one_error_line(
        &shvis(&["study", "ndf", "--sigma", "0", "--out", out], &[]),
        &["--sigma 0"],
    );
    assert_one_error_line(
        &shvis(&["study", "ndf", "--light-dir", "0,0,0", "--out", out], &[]),
        &["--light-dir", "not a direction"],
    );
    assert_one_error_line(
        &shvis(&["study", "ndf", "--light-dir", "1,2", "--out", out], &[]),
        &["three numbers"],
    );
    assert_one_error_line(
        &shvis(
            &["study", "ndf", "--light-dir", "0,-1,0", "--out", out],
            &[],
        ),
        &["--light-dir 0,-1,0", "at or below the bumpy plane"],
    );
}

/// A study's list naming an item twice, or two environments that would write one figure,
/// is refused before any work.
#[test]
fn study_lists_name_each_item_once() {
    let dir = scratch("study-lists");
    let out = dir.to_str().unwrap();
    for (args, needles) in [
        (
            vec!["study", "compression", "--techniques", "pca8w,pca8w"],
            vec!["--techniques", "pca8w is named twice"],
        ),
        (
            vec!["study", "seams", "--techniques", "vq64,vq64"],
            vec!["--techniques", "vq64 is named twice"],
        ),
        (
            vec!["study", "rnm", "--envs", "sky:15,sky:15"],
            vec!["--envs", "sky:15 is named twice"],
        ),
        (
            vec!["study", "rnm", "--envs", "a/p.exr,b/p.exr"],
            vec!["a/p.exr and b/p.exr would both write fig1_p.png"],
        ),
        (
            vec!["study", "rnm", "--envs", "a/ndf_bumpy.exr"],
            vec!["fig1_ndf_bumpy.png", "study ndf's figures"],
        ),
        (
            vec!["study", "normalmap", "--ratios", "0.004,0.0040001"],
            vec!["--ratios", "both 0.4 % of the model's triangles"],
        ),
        (
            vec![
                "study",
                "ndf",
                "--diffuse-envs",
                "a/studio.exr,b/studio.hdr",
            ],
            vec!["would both write diffuse_bumpy_studio_*"],
        ),
    ] {
        let mut args = args;
        args.extend(["--out", out]);
        assert_one_error_line(&shvis(&args, &[]), &needles);
    }
}
