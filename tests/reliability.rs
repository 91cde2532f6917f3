//! One test per class of the failures a hostile user found: a value that would make a loop
//! run without end, a run left with no row, an output over an input, a rerun into a folder
//! of an earlier (or killed) run, an option that does nothing in its combination. Each
//! case exits non-zero with the reason, or does what it says — never hangs, never writes
//! over what it reads, never reports an empty or stale result as a success.

mod cli_run;
mod scratch;

use cli_run::{assert_one_error_line, shvis};
use std::path::Path;

use scratch::Scratch;

/// A 16×16 8-bit height map with one bump.
fn height_map(path: &Path) {
    let img = image::GrayImage::from_fn(16, 16, |x, y| {
        let d = (x as f32 - 8.0).hypot(y as f32 - 8.0);
        image::Luma([(255.0 * (1.0 - d / 8.0).max(0.0)) as u8])
    });
    img.save(path).expect("the height map is written");
}

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// `shvis render --technique preconv --env ENV --out OUT`.
fn render_preconv(env: &str, out: &str) -> std::process::Output {
    shvis(
        &[
            "render",
            "--technique",
            "preconv",
            "--env",
            env,
            "--out",
            out,
        ],
        &[],
    )
}

/// `shvis ssbump` of `height` at `scale` with 16 rays into `out`.
fn ssbump(height: &Path, scale: &str, out: &Path) -> std::process::Output {
    shvis(
        &[
            "ssbump",
            "--height-map",
            s(height),
            "--height-scale",
            scale,
            "--rays",
            "16",
            "--out",
            s(out),
        ],
        &[],
    )
}

/// Heights that once stalled the SSBump march (1e25: t + step == t) are refused at parse
/// time, and the largest accepted height finishes.
#[test]
fn every_ray_march_is_bounded() {
    let dir = Scratch::new("reliability", "march");
    let h = dir.join("h.png");
    height_map(&h);
    let out = dir.join("ss.png");
    for scale in ["1e25", "1e30", "101"] {
        let run = ssbump(&h, scale, &out);
        assert_one_error_line(&run, &["--height-scale", scale, "(0, 100]"]);
    }
    let run = ssbump(&h, "100", &out);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(out.is_file());
}

/// A bench or relight whose every row breaks the path's rules fails, naming them; one that
/// names some such rows fails unless --skip-unsupported, which names them on stderr.
#[test]
fn a_run_without_rows_fails_with_the_reason() {
    let dir = Scratch::new("reliability", "rows");
    let out = dir.join("out");
    for cmd in ["bench", "relight"] {
        let run = shvis(
            &[
                cmd,
                "--techniques",
                "nmprtsvd4p",
                "--paths",
                "dx9",
                "--out",
                s(&out),
            ],
            &[],
        );
        assert_one_error_line(
            &run,
            &["no row to measure", "nmprtsvd4p.dx9", "--paths dx10"],
        );
        let run = shvis(
            &[
                cmd,
                "--techniques",
                "nmprtsvd4p,preconv",
                "--paths",
                "dx9",
                "--out",
                s(&out),
            ],
            &[],
        );
        assert_one_error_line(&run, &["nmprtsvd4p.dx9", "--skip-unsupported"]);
    }
    // A mesh whose lightmap UVs cover no texel centre bakes nothing: an error, not 0 texels.
    let tiny = dir.join("tiny.gltf");
    std::fs::write(&tiny, TINY_UV_TRIANGLE).unwrap();
    let run = shvis(
        &[
            "bake",
            "--scene",
            s(&tiny),
            "--vis-res",
            "64",
            "--rays",
            "36",
            "--out",
            s(&dir.join("bk")),
        ],
        &[],
    );
    assert_one_error_line(&run, &["no triangle covers a lightmap texel centre"]);
    // Named twice: an error, not two identical rows.
    let run = shvis(
        &[
            "bench",
            "--techniques",
            "preconv",
            "--paths",
            "dx10,dx10",
            "--out",
            s(&out),
        ],
        &[],
    );
    assert_one_error_line(&run, &["dx10 is named twice"]);
    assert!(!out.exists(), "a refused run wrote its folder");
}

/// No output may be one of the run's inputs, side files and links included.
#[test]
fn no_output_overwrites_an_input() {
    let dir = Scratch::new("reliability", "over");
    let h = dir.join("x.png");
    height_map(&h);
    let before = std::fs::read(&h).unwrap();
    let run = ssbump(&h, "2", &h);
    assert_one_error_line(
        &run,
        &["x.png", "--out would overwrite the --height-map input"],
    );
    // The input is a side file (`*_d.png`) of --out.
    let d = dir.join("y_d.png");
    height_map(&d);
    let run = ssbump(&d, "2", &dir.join("y.png"));
    assert_one_error_line(
        &run,
        &["y_d.png", "_d file would overwrite the --height-map input"],
    );
    // Through a symbolic link.
    let link = dir.join("link.png");
    std::os::unix::fs::symlink(&h, &link).unwrap();
    let run = ssbump(&h, "2", &link);
    assert_one_error_line(
        &run,
        &["link.png", "would overwrite the --height-map input"],
    );
    // render's environment, normalmap's low mesh.
    let env = dir.join("e.exr");
    std::fs::write(&env, b"not read").unwrap();
    let run = render_preconv(s(&env), s(&env));
    assert_one_error_line(&run, &["e.exr", "--out would overwrite the --env input"]);
    let low = dir.join("low.gltf");
    std::fs::write(&low, b"{}").unwrap();
    let run = shvis(
        &[
            "normalmap",
            "--high",
            "sphere:2",
            "--low",
            s(&low),
            "--gltf",
            s(&low),
            "--out",
            s(&dir.join("n.png")),
        ],
        &[],
    );
    assert_one_error_line(
        &run,
        &["low.gltf", "--gltf would overwrite the --low input"],
    );
    assert_eq!(std::fs::read(&h).unwrap(), before, "the input was written");
    // A file the scene's glTF references (its texture): render's, reference's and
    // normalmap's outputs spare it.
    let model = dir.join("m");
    std::fs::create_dir_all(&model).unwrap();
    let gltf = model.join("m.gltf");
    std::fs::write(
        &gltf,
        br#"{"asset": {"version": "2.0"}, "images": [{"uri": "tex%20a.png"}], "buffers": [{"uri": "m.bin", "byteLength": 4}]}"#,
    )
    .unwrap();
    let texture = model.join("tex a.png");
    std::fs::write(&texture, b"texture").unwrap();
    for (command, option) in [("render", "--scene"), ("reference", "--scene")] {
        let mut args = vec![command, option, s(&gltf), "--out", s(&texture)];
        if command == "render" {
            args.extend(["--technique", "preconv"]);
        }
        let run = shvis(&args, &[]);
        assert_one_error_line(
            &run,
            &["tex a.png", "--out would overwrite the --scene input"],
        );
    }
    let run = shvis(
        &[
            "normalmap",
            "--high",
            s(&gltf),
            "--low",
            "sphere:1",
            "--out",
            s(&texture),
        ],
        &[],
    );
    assert_one_error_line(
        &run,
        &["tex a.png", "--out would overwrite the --high input"],
    );
    assert_eq!(std::fs::read(&texture).unwrap(), b"texture");
    // An input inside the folder a bench, relight or study writes into.
    let folder = dir.join("folder");
    std::fs::create_dir_all(&folder).unwrap();
    let sh = folder.join("table.md");
    std::fs::write(&sh, b"1 1 1\n").unwrap();
    let env = format!("sh:{}", s(&sh));
    for command in [
        vec!["bench"],
        vec!["relight"],
        vec!["study", "block"],
        vec!["study", "seams"],
    ] {
        let mut args = command.clone();
        args.extend(["--env", env.as_str(), "--out", s(&folder)]);
        let run = shvis(&args, &[]);
        assert_one_error_line(
            &run,
            &[
                "table.md",
                "the --env input lies inside --out (the folder the run writes into)",
            ],
        );
    }
    assert_eq!(std::fs::read(&sh).unwrap(), b"1 1 1\n");
}

/// A rerun into the folder of an earlier run removes a killed run's temporaries before it
/// does anything else; refused for its inputs, it leaves the earlier run's report as it was
/// (the report is removed only once the run is about to write images).
#[test]
fn a_rerun_clears_stale_temporaries_and_a_refused_one_keeps_the_earlier_report() {
    let dir = Scratch::new("reliability", "rerun");
    let out = dir.join("bench");
    std::fs::create_dir_all(&out).unwrap();
    for f in ["index.html", "table.md", "table.json", "probe.md"] {
        std::fs::write(out.join(f), b"an earlier run").unwrap();
    }
    // PID 4194304 is above Linux's largest: no process owns it.
    let stale = out.join(".unc6.dx9.png.tmp-4194304-0");
    std::fs::write(&stale, b"half a PNG").unwrap();
    let run = shvis(
        &["bench", "--env", "/no/such/env.exr", "--out", s(&out)],
        &[],
    );
    assert_one_error_line(&run, &["/no/such/env.exr"]);
    for f in ["index.html", "table.md", "table.json", "probe.md"] {
        assert_eq!(
            std::fs::read(out.join(f)).ok().as_deref(),
            Some(&b"an earlier run"[..]),
            "{f} of the earlier run was not kept"
        );
    }
    assert!(!stale.exists(), "the killed run's temporary is still there");
}

/// Options that would do nothing in the combination given are errors naming both.
#[test]
fn an_option_that_does_nothing_is_an_error() {
    let dir = Scratch::new("reliability", "ignored");
    let png = dir.join("x.png");
    // clap's own messages, on one line with the arguments' names.
    let run = shvis(
        &[
            "render",
            "--technique",
            "preconv",
            "--light-dir",
            "0,1,0",
            "--out",
            s(&png),
        ],
        &[],
    );
    assert_eq!(run.status.code(), Some(2));
    assert_one_error_line(&run, &["not provided", "--specular"]);
    for option in ["--specular-sigma", "--specular-ks"] {
        let run = shvis(
            &[
                "render",
                "--technique",
                "preconv",
                option,
                "0.2",
                "--out",
                s(&png),
            ],
            &[],
        );
        assert_one_error_line(&run, &["not provided", "--specular"]);
    }
    // The GPU baker's depth-map settings without it.
    for (option, value) in [
        ("--depth-res", "64"),
        ("--depth-bias", "0.2"),
        ("--slope-bias", "1"),
    ] {
        let run = shvis(
            &[
                "render",
                "--technique",
                "preconv",
                option,
                value,
                "--out",
                s(&png),
            ],
            &[],
        );
        assert_one_error_line(&run, &[option, "--baker gpu"]);
    }
    let bench_out = dir.join("b");
    for extra in [["--probe", "fresh"], ["--probe-frames", "5"]] {
        let mut args = vec!["bench", "--no-probe", "--out", s(&bench_out)];
        args.extend(extra);
        assert_one_error_line(&shvis(&args, &[]), &["--no-probe", "cannot be used with"]);
    }
    // Without a reference there are no errors to measure and no ladder.
    for extra in [&["--ladder-stride", "1"][..], &["--point-reference"][..]] {
        let mut args = vec!["bench", "--ref-spp", "0", "--out", s(&bench_out)];
        args.extend_from_slice(extra);
        assert_one_error_line(&shvis(&args, &[]), &[extra[0], "--ref-spp 0"]);
    }
    assert_one_error_line(
        &shvis(
            &[
                "bench",
                "--point-reference",
                "--ladder-stride",
                "1",
                "--out",
                s(&bench_out),
            ],
            &[],
        ),
        &["--ladder-stride", "no ladder with --point-reference"],
    );
    assert!(!bench_out.exists(), "a refused bench wrote its folder");
    assert_one_error_line(
        &shvis(&["render", "--out", s(&png)], &[]),
        &["not provided", "--technique"],
    );
    assert_one_error_line(
        &shvis(
            &["bake", "--compare-cpu", "--out", s(&dir.join("bake"))],
            &[],
        ),
        &["--compare-cpu", "--baker gpu"],
    );
    assert_one_error_line(
        &shvis(
            &[
                "normalmap",
                "--high",
                "sphere:2",
                "--low",
                "sphere:1",
                "--cpu-face-rays",
                "--out",
                s(&png),
            ],
            &[],
        ),
        &["--cpu-face-rays", "--baker cpu"],
    );
    // The GPU baker's options with the CPU baker.
    for option in ["--no-mirror", "--no-cull", "--direct-draws", "--validate"] {
        let run = shvis(
            &[
                "normalmap",
                "--high",
                "sphere:2",
                "--low",
                "sphere:1",
                "--baker",
                "cpu",
                option,
                "--out",
                s(&png),
            ],
            &[],
        );
        assert_one_error_line(&run, &[option, "not with --baker cpu"]);
    }
    assert_one_error_line(
        &shvis(
            &[
                "view",
                "--frames",
                "2",
                "--screenshot",
                s(&dir.join("x.exr")),
            ],
            &[],
        ),
        &["x.exr", "--screenshot writes PNG"],
    );
    assert_one_error_line(
        &shvis(
            &["relight", "--turns", "1e30", "--out", s(&dir.join("r"))],
            &[],
        ),
        &["--turns 1e30"],
    );
    assert_one_error_line(
        &shvis(
            &[
                "probe",
                "--triangle-pixels",
                "1e12",
                "--out",
                s(&dir.join("p")),
            ],
            &[],
        ),
        &["--triangle-pixels 1000000000000", "at most 512000"],
    );
}

/// Errors say what is wrong in the user's terms, and inputs the help promises are read.
#[test]
fn errors_name_the_input_and_what_is_wrong() {
    let dir = Scratch::new("reliability", "wording");
    let png = dir.join("x.png");
    assert_one_error_line(
        &render_preconv("angular:", s(&png)),
        &["angular:", "needs the path of a 1:1 angular probe"],
    );
    // A 2:1 map forced to be an angular probe.
    let wide = dir.join("wide.exr");
    exr::prelude::write_rgb_file(&wide, 8, 4, |_, _| (1.0f32, 1.0f32, 1.0f32)).unwrap();
    assert_one_error_line(
        &render_preconv(&format!("angular:{}", s(&wide)), s(&png)),
        &["wide.exr", "1:1 angular probe", "8×4"],
    );
    // A 1:1 map whose light lies only in the corners, outside the probe's disk.
    let corners = dir.join("corners.exr");
    exr::prelude::write_rgb_file(&corners, 16, 16, |x, y| {
        let (dx, dy) = (x as f32 - 7.5, y as f32 - 7.5);
        let v = if dx.hypot(dy) > 8.8 { 1.0f32 } else { 0.0 };
        (v, v, v)
    })
    .unwrap();
    let forced = format!("angular:{}", s(&corners));
    assert_one_error_line(
        &render_preconv(&forced, s(&png)),
        &["corners.exr", "it is black", "outside the probe's disk"],
    );
    assert_one_error_line(
        &shvis(
            &[
                "study",
                "normalmap",
                "--ratios",
                "0,1.5",
                "--out",
                s(&dir.join("st")),
            ],
            &[],
        ),
        &["--ratios", "(0, 1]"],
    );
    // A low mesh without material UVs (one triangle, POSITION and NORMAL only).
    let nouv = dir.join("nouv.gltf");
    std::fs::write(&nouv, NO_UV_TRIANGLE).unwrap();
    assert_one_error_line(
        &shvis(
            &[
                "normalmap",
                "--high",
                "sphere:2",
                "--low",
                s(&nouv),
                "--map-res",
                "64",
                "--out",
                s(&png),
            ],
            &[],
        ),
        &["no material UVs (TEXCOORD_0)", "--simplify"],
    );
    // A cause is said once, not again after its error's message.
    let run = shvis(
        &["sh", "irradiance", "--env", "sky", "--normal", "0,0,0"],
        &[],
    );
    assert_one_error_line(&run, &["--normal", "zero-length"]);
    assert_eq!(
        String::from_utf8_lossy(&run.stderr)
            .matches("zero-length")
            .count(),
        1
    );
    // A truncated environment map: the decoder's words, and what they mean.
    let cut = dir.join("cut.exr");
    exr::prelude::write_rgb_file(&cut, 64, 32, |x, _| (x as f32, 1.0f32, 1.0f32)).unwrap();
    let bytes = std::fs::read(&cut).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    assert_one_error_line(
        &render_preconv(s(&cut), s(&png)),
        &["cut.exr", "invalid OpenEXR file", "truncated?"],
    );
    // An EXR height map, as the help says.
    let h = dir.join("h.exr");
    exr::prelude::write_rgb_file(&h, 16, 16, |x, y| {
        let v = if (x / 4 + y / 4) % 2 == 0 {
            1.0f32
        } else {
            0.0
        };
        (v, v, v)
    })
    .unwrap();
    let run = ssbump(&h, "2", &dir.join("ss.png"));
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

/// `shvis ssbump` of a height map into `dir/ss.png` with the test hook `hook` on `file`,
/// which interrupts it: asserts the exit status 130, returns the names left in `dir`
/// (sorted; the height map `h.png` among them).
#[cfg(feature = "test-hooks")]
fn interrupted_ssbump(dir: &Path, hook: &str, file: &str) -> Vec<String> {
    let h = dir.join("h.png");
    height_map(&h);
    let out = dir.join("ss.png");
    let run = shvis(
        &[
            "ssbump",
            "--height-map",
            s(&h),
            "--height-scale",
            "2",
            "--rays",
            "8",
            "--out",
            s(&out),
        ],
        &[(hook, file)],
    );
    assert_eq!(
        run.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let mut left: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    left
}

/// SIGINT while a file is being written: the temporary is removed and the process exits
/// with 130, leaving no output and no `.NAME.tmp-*` behind. The interruption is a hook of
/// the `test-hooks` feature (`files::INTERRUPT_WHILE_WRITING_ENV`).
#[cfg(feature = "test-hooks")]
#[test]
fn an_interrupted_write_leaves_no_temporary() {
    let dir = Scratch::new("reliability", "sigint");
    let left = interrupted_ssbump(&dir, shvis::files::INTERRUPT_WHILE_WRITING_ENV, "ss.png");
    assert_eq!(left, ["h.png"], "left behind");
}

/// SIGINT while a set of files is being put in place waits for the set: the run exits with
/// 130 with every file of the set new (none left from the earlier run beside new ones) and
/// no temporary behind (`files::INTERRUPT_WHILE_COMMITTING_ENV`).
#[cfg(feature = "test-hooks")]
#[test]
fn an_interrupt_during_a_commit_waits_for_the_whole_set() {
    let dir = Scratch::new("reliability", "sigint-commit");
    let set = [
        "ss.png",
        "ss.exr",
        "ss_d.png",
        "ss_d.exr",
        "ss_ao.png",
        "ss_ao.exr",
    ];
    for f in set {
        std::fs::write(dir.join(f), b"an earlier run").unwrap();
    }
    let left = interrupted_ssbump(&dir, shvis::files::INTERRUPT_WHILE_COMMITTING_ENV, "ss.png");
    for f in set {
        assert_ne!(
            std::fs::read(dir.join(f)).unwrap(),
            b"an earlier run",
            "{f} is the earlier run's beside new files"
        );
    }
    let mut expected: Vec<String> = set
        .iter()
        .chain(&["h.png"])
        .map(|f| f.to_string())
        .collect();
    expected.sort();
    assert_eq!(left, expected);
}

/// A glTF triangle with positions and normals and no TEXCOORD_0.
const NO_UV_TRIANGLE: &str = "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 72, \"uri\": \"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/\"}], \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 36}, {\"buffer\": 0, \"byteOffset\": 36, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 0]}, {\"bufferView\": 1, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"}], \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"NORMAL\": 1}}]}], \"nodes\": [{\"mesh\": 0}], \"scenes\": [{\"nodes\": [0]}], \"scene\": 0}";

/// A glTF triangle whose lightmap UVs (TEXCOORD_1) span a ten-thousandth of the map.
const TINY_UV_TRIANGLE: &str = "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 120, \"uri\": \"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/zczMPc3MzD07Ac09zczMPc3MzD07Ac09\"}], \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 36}, {\"buffer\": 0, \"byteOffset\": 36, \"byteLength\": 36}, {\"buffer\": 0, \"byteOffset\": 72, \"byteLength\": 24}, {\"buffer\": 0, \"byteOffset\": 96, \"byteLength\": 24}], \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 0]}, {\"bufferView\": 1, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"}, {\"bufferView\": 2, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"}, {\"bufferView\": 3, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"}], \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"NORMAL\": 1, \"TEXCOORD_0\": 2, \"TEXCOORD_1\": 3}}]}], \"nodes\": [{\"mesh\": 0}], \"scenes\": [{\"nodes\": [0]}], \"scene\": 0}";

/// A bake writes its folder as one run: a rebake at a lower order leaves no layer of the
/// earlier bake, a folder that is not an earlier bake is refused before the bake, and
/// `bake --check` passes only a folder that holds exactly the layers of its order.
#[test]
fn a_bake_replaces_its_folder_whole() {
    let dir = Scratch::new("reliability", "bake-folder");
    let out = dir.join("bake");
    let cache = dir.join("cache");
    let bake = |order: &str, out: &Path| {
        shvis(
            &[
                "bake",
                "--vis-res",
                "64",
                "--rays",
                "36",
                "--order",
                order,
                "--out",
                s(out),
            ],
            &[("SHVIS_CACHE_DIR", s(&cache))],
        )
    };
    let names = |d: &Path| {
        let mut n: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        n.sort();
        n
    };
    assert!(bake("6", &out).status.success());
    assert_eq!(names(&out).len(), 11, "9 layers, ao.exr, manifest.json");
    assert!(bake("3", &out).status.success());
    assert_eq!(
        names(&out),
        [
            "ao.exr",
            "manifest.json",
            "visibility_0.exr",
            "visibility_1.exr",
            "visibility_2.exr"
        ]
    );
    let check = |d: &Path| shvis(&["bake", "--check", "--out", s(d)], &[]);
    assert!(check(&out).status.success());
    // A stray file, then a manifest that lists a file outside the folder.
    std::fs::write(out.join("visibility_8.exr"), b"stale").unwrap();
    assert_one_error_line(&check(&out), &["an order-3 bake has", "visibility_8.exr"]);
    std::fs::remove_file(out.join("visibility_8.exr")).unwrap();
    let manifest = out.join("manifest.json");
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(&manifest, text.replace("\"ao.exr\"", "\"../ao.exr\"")).unwrap();
    assert_one_error_line(&check(&out), &["../ao.exr", "not a file of the folder"]);
    // A folder of other files is refused before the bake, and left as it was.
    let notes = dir.join("notes");
    std::fs::create_dir_all(&notes).unwrap();
    std::fs::write(notes.join("notes.txt"), b"mine").unwrap();
    assert_one_error_line(&bake("3", &notes), &["notes", "not an earlier run's"]);
    assert_eq!(names(&notes), ["notes.txt"]);
    // The current folder, even an earlier bake, cannot be replaced.
    let here = std::process::Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(["bake", "--vis-res", "64", "--rays", "36", "--out", "."])
        .current_dir(&out)
        .env("SHVIS_CACHE_DIR", &cache)
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    assert_one_error_line(&here, &["the current folder or holds it"]);
}

/// A scene file that is a FIFO is refused by the loader: listing the glTF's files for the
/// output checks does not open it (which would wait for a writer).
#[test]
fn a_fifo_scene_is_refused_not_waited_on() {
    let dir = Scratch::new("reliability", "fifo-scene");
    let fifo = dir.join("scene.gltf");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(["render", "--technique", "preconv", "--scene", s(&fifo)])
        .args(["--out", s(&dir.join("x.png"))])
        .env("RUST_LOG", "off")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > std::time::Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("render waited on a FIFO scene");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let run = child.wait_with_output().unwrap();
    assert_one_error_line(&run, &["scene.gltf", "not a regular file"]);
}

/// The SSBump bake's memory is checked against `SHVIS_MEMORY_LIMIT` before it starts, not
/// found out by the allocator.
#[test]
fn an_ssbump_bake_beyond_the_memory_limit_is_refused() {
    let dir = Scratch::new("reliability", "ssbump-memory");
    let h = dir.join("h.png");
    image::GrayImage::from_fn(128, 128, |x, y| image::Luma([((x * y) % 251) as u8]))
        .save(&h)
        .unwrap();
    let run = shvis(
        &[
            "ssbump",
            "--height-map",
            s(&h),
            "--height-scale",
            "1",
            "--rays",
            "1",
            "--out",
            s(&dir.join("b.png")),
        ],
        &[("SHVIS_MEMORY_LIMIT", "1M")],
    );
    assert_one_error_line(&run, &["SSBump bake of 128×128 height texels", "memory"]);
    assert!(!dir.join("b.png").exists());
}
