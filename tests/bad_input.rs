//! Bad input, limits and interruptions, as a hostile user meets them — through the
//! `shvis` binary, one process per case. Every case states what must happen:
//!
//! - [`Expect::Error`]: the exit code (2: the argument parser, 1: everything else), stderr's
//!   first line starts with `error` and names the input (the needles), and no output is
//!   left (the output path is absent, or an empty directory; no temporaries beside it);
//! - [`Expect::Warn`]: exit 0, a warning line with the needles, the output written;
//! - [`Expect::Ok`]: exit 0, the output written (hard cases that must simply work).
//!
//! Always: the process exits by itself within [`CASE_TIMEOUT`] (no hang), with an exit
//! code (no abort or signal), and nothing on stderr reads like a panic or a failed
//! allocation. Files are generated here; nothing large is checked in.
//!
//! Each class of cases ([`Kind`]) is one test in a folder of its own (`arguments`, `budget`,
//! `values`, `env_files`, `scene_files`, `output_locations`, `bake_caches`,
//! `design_hard_cases`, `new_surfaces`), so a failure names its class and `cargo test --test bad_input
//! values` runs one class alone; `every_class_has_cases` counts the whole suite. To count
//! what another build gets wrong, `SHVIS_BAD_INPUT_BIN=<its binary>
//! SHVIS_BAD_INPUT_TALLY=1 cargo test --test bad_input <class> -- --nocapture` runs the
//! class against it and prints each failure and the totals by kind (panic, hang, silently
//! wrong, unclear) instead of failing. The kill-9
//! test (`killed_bakes_rerun_to_identical_outputs`, feature `test-hooks`) interrupts a bake
//! at its five writes.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use shvis::env::EnvMap;

/// Longest a case may run before it counts as a hang.
const CASE_TIMEOUT: Duration = Duration::from_secs(180);

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    /// Options out of range, not numbers, not finite; loop counts without bound.
    Arguments,
    /// Sizes that would allocate more than the budget (headers, vis-res × order², memory).
    Budget,
    /// Values that overflow what a path can represent, silently wrong results.
    Values,
    /// Environment files: missing, special, truncated, malformed.
    EnvFiles,
    /// Scene files: malformed glTF, URIs outside the asset, bad textures.
    SceneFiles,
    /// Output and cache locations: unwritable, wrong kind, full.
    Outputs,
    /// Bake caches: damaged, foreign, special files, stale temporaries.
    Cache,
    /// DESIGN §6 hard cases at the command line.
    HardCases,
    /// The surfaces added since the classes above: export of every technique on dx10 and
    /// dx11, `report` and its tables, `sh:` files in `study bases` and `render`, named sets
    /// and list options, `SHVIS_*` variables, full standard output, links to devices,
    /// binary glTF and EXR channels, `--sg-solve`, the dx11 path's refusals.
    Surfaces,
}

#[derive(Clone, Debug)]
enum Expect {
    Error { code: i32, needles: Vec<String> },
    Warn { needles: Vec<String> },
    Ok,
}

/// A further check after a run: (stdout, stderr) → what is wrong.
type Check = Box<dyn Fn(&str, &str) -> Result<(), String>>;
/// (name, command line, memory limit, needles).
type BudgetCase<'a> = (&'a str, Vec<String>, Option<&'a str>, Vec<&'a str>);
/// (name, command line, needles, output).
type OutputCase<'a> = (&'a str, Vec<String>, Vec<&'a str>, Option<PathBuf>);

struct Case {
    kind: Kind,
    name: String,
    args: Vec<String>,
    env: Vec<(String, String)>,
    /// A shell prefix (`ulimit …;`) the command runs under, if any.
    shell: Option<String>,
    /// The output the command would write.
    out: Option<PathBuf>,
    expect: Expect,
    /// A further check after the run (stdout, stderr) → problem.
    check: Option<Check>,
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn error(code: i32, needles: &[&str]) -> Expect {
    Expect::Error {
        code,
        needles: strings(needles),
    }
}

fn warn(needles: &[&str]) -> Expect {
    Expect::Warn {
        needles: strings(needles),
    }
}

struct Suite {
    dir: PathBuf,
    cases: Vec<Case>,
}

impl Suite {
    fn new(name: &str) -> Suite {
        let dir = std::env::temp_dir().join(format!("shvis-bad-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Suite {
            dir,
            cases: Vec::new(),
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// A fresh cache directory for case `name` (cases do not share caches unless they ask).
    fn cache(&self, name: &str) -> String {
        self.path(&format!("cache-{name}")).display().to_string()
    }

    fn add(&mut self, kind: Kind, name: &str, args: &[&str], out: Option<PathBuf>, expect: Expect) {
        let cache = self.cache(name);
        self.cases.push(Case {
            kind,
            name: name.to_string(),
            args: strings(args),
            env: vec![("SHVIS_CACHE_DIR".into(), cache)],
            shell: None,
            out,
            expect,
            check: None,
        });
    }

    fn last(&mut self) -> &mut Case {
        self.cases.last_mut().unwrap()
    }

    /// Runs every case; panics listing every failure. With `SHVIS_BAD_INPUT_TALLY` set it
    /// prints each failure and the totals by [`classify`] instead, and passes.
    fn run(self) {
        let mut totals: BTreeMap<&str, usize> = BTreeMap::new();
        let failures: Vec<String> = self
            .cases
            .iter()
            .filter_map(|case| {
                let problem = run_case(case).err()?;
                *totals.entry(classify(&problem)).or_default() += 1;
                Some(format!("[{:?}] {}: {problem}", case.kind, case.name))
            })
            .collect();
        if std::env::var_os("SHVIS_BAD_INPUT_TALLY").is_some() {
            for f in &failures {
                println!("{f}");
            }
            println!(
                "tally of {} ({} cases): {totals:?}, {} passed",
                suite_binary(),
                self.cases.len(),
                self.cases.len() - failures.len()
            );
            let _ = std::fs::remove_dir_all(&self.dir);
            return;
        }
        assert!(
            failures.is_empty(),
            "{} of {} cases failed:\n{}",
            failures.len(),
            self.cases.len(),
            failures.join("\n")
        );
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The binary the suite runs: this build's, or the one `SHVIS_BAD_INPUT_BIN` names (to
/// count what an earlier build got wrong: `SHVIS_BAD_INPUT_TALLY`).
fn suite_binary() -> String {
    std::env::var("SHVIS_BAD_INPUT_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_shvis").into())
}

/// What a failed case's problem is, for the tally: a panic (or abort), a hang, a silently
/// wrong result (a case that must fail or warn exited 0 without a word, an output left, a
/// check of what was written failed), or an unclear one (a refusal with the wrong code, not
/// an `error:` line, or not naming the input).
fn classify(problem: &str) -> &'static str {
    if problem.contains("on stderr") || problem.contains("killed by a signal") {
        "panic"
    } else if problem.starts_with("hang") {
        "hang"
    } else if problem.starts_with("exit 0,")
        || problem.starts_with("no warning")
        || problem.contains("was written")
        || problem.contains("output directory holds")
        || problem.contains("temporary")
        || problem.starts_with("check: ")
    {
        "silently wrong"
    } else {
        "unclear"
    }
}

/// Runs the binary with `args` (under `shell` when given), killing it after the timeout.
fn spawn(case: &Case) -> Result<(Option<i32>, String, String), String> {
    let bin = suite_binary();
    let rust_log = match case.expect {
        Expect::Error { .. } => "off",
        _ => "warn",
    };
    let mut cmd = match &case.shell {
        Some(prefix) => {
            let quoted: Vec<String> = case.args.iter().map(|a| format!("'{a}'")).collect();
            let mut c = Command::new("sh");
            c.arg("-c")
                .arg(format!("{prefix} exec '{bin}' {}", quoted.join(" ")));
            c
        }
        None => {
            let mut c = Command::new(bin);
            c.args(&case.args);
            c
        }
    };
    cmd.env("RUST_LOG", rust_log)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in &case.env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().map_err(|e| format!("cannot start: {e}"))?;
    let (mut out_pipe, mut err_pipe) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let out_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out_pipe.read_to_string(&mut s);
        s
    });
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err_pipe.read_to_string(&mut s);
        s
    });
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if started.elapsed() > CASE_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("hang: still running after {CASE_TIMEOUT:?}"));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let stdout = out_thread.join().unwrap_or_default();
    let stderr = err_thread.join().unwrap_or_default();
    Ok((status.code(), stdout, stderr))
}

/// No output at `out`: absent, or an empty directory; no temporaries beside it.
fn no_output(out: &Path) -> Result<(), String> {
    if out.is_dir() {
        let left: Vec<_> = std::fs::read_dir(out)
            .map_err(|e| e.to_string())?
            .flatten()
            .map(|e| e.file_name())
            .collect();
        if !left.is_empty() {
            return Err(format!("output directory holds {left:?}"));
        }
    } else if out.exists() {
        return Err(format!("{} was written", out.display()));
    }
    if let Some(parent) = out.parent()
        && let Ok(entries) = std::fs::read_dir(parent)
    {
        let name = out.file_name().unwrap_or_default().to_string_lossy();
        for e in entries.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if n.starts_with(&format!(".{name}.tmp-")) {
                return Err(format!("temporary {n} left"));
            }
        }
    }
    Ok(())
}

fn run_case(case: &Case) -> Result<(), String> {
    let (code, stdout, stderr) = spawn(case)?;
    for bad in [
        "panicked",
        "internal error",
        "memory allocation of",
        "RUST_BACKTRACE",
    ] {
        if stderr.contains(bad) {
            return Err(format!("'{bad}' on stderr: {stderr}"));
        }
    }
    let Some(code) = code else {
        return Err(format!("killed by a signal (abort?); stderr: {stderr}"));
    };
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    match &case.expect {
        Expect::Error {
            code: want,
            needles,
        } => {
            if code != *want {
                return Err(format!("exit {code}, expected {want}; stderr: {stderr}"));
            }
            let first = lines.first().copied().unwrap_or("");
            if !first.starts_with("error") {
                return Err(format!("first stderr line is not an error: {stderr}"));
            }
            for n in needles {
                if !first.contains(n.as_str()) {
                    return Err(format!("'{n}' missing from: {first}"));
                }
            }
            if let Some(out) = &case.out {
                no_output(out)?;
            }
        }
        Expect::Warn { needles } => {
            if code != 0 {
                return Err(format!("exit {code}; stderr: {stderr}"));
            }
            let found = lines
                .iter()
                .any(|l| l.contains("WARN") && needles.iter().all(|n| l.contains(n.as_str())));
            if !found {
                return Err(format!("no warning with {needles:?}: {stderr}"));
            }
            if let Some(out) = &case.out
                && !out.exists()
            {
                return Err(format!("{} not written", out.display()));
            }
        }
        Expect::Ok => {
            if code != 0 {
                return Err(format!("exit {code}; stderr: {stderr}"));
            }
            if let Some(out) = &case.out
                && !out.exists()
            {
                return Err(format!("{} not written", out.display()));
            }
        }
    }
    if let Some(check) = &case.check {
        check(&stdout, &stderr).map_err(|e| format!("check: {e}"))?;
    }
    Ok(())
}

// ---- Generated input files --------------------------------------------------------------

fn write(path: &Path, bytes: &[u8]) {
    if let Err(e) = std::fs::write(path, bytes) {
        panic!("{}: {e}", path.display());
    }
}

/// A `w × h` f32 RGB EXR with texels `f(x, y)`.
fn exr(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> PathBuf {
    let map = EnvMap {
        width: w,
        height: h,
        texels: (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect(),
    };
    map.save_exr(path).unwrap();
    path.to_path_buf()
}

/// An EXR whose header claims `w × h` (a valid 8 × 4 file with its windows patched).
fn exr_claiming(path: &Path, w: i32, h: i32) -> PathBuf {
    let tmp = path.with_extension("small.exr");
    exr(&tmp, 8, 4, |_, _| [1.0; 3]);
    let mut bytes = std::fs::read(&tmp).unwrap();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = bytes
            .windows(name.len())
            .position(|w| w == name)
            .expect("window attribute")
            + name.len()
            + 4;
        bytes[at + 8..at + 12].copy_from_slice(&(w - 1).to_le_bytes());
        bytes[at + 12..at + 16].copy_from_slice(&(h - 1).to_le_bytes());
    }
    write(path, &bytes);
    path.to_path_buf()
}

/// A Radiance `.hdr` of flat (not run-length) RGBE pixels.
fn hdr(path: &Path, w: u32, h: u32, rgbe: [u8; 4]) -> PathBuf {
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for _ in 0..w * h {
        bytes.extend_from_slice(&rgbe);
    }
    write(path, &bytes);
    path.to_path_buf()
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// PNG bytes whose header claims `w × h` RGBA8, with a token IDAT (never decoded).
fn png_claiming(w: u32, h: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00]);
    chunk(b"IEND", &[]);
    out
}

fn png(w: u32, h: u32) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::RgbaImage::from_pixel(w, h, image::Rgba([128, 128, 255, 255]))
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .unwrap();
    bytes
}

/// A glTF scene: a ground quad and a box-like fold (two quads), positions, normals,
/// TEXCOORD_0 (and TEXCOORD_1 when `uv1` is given), written as `.gltf` + `.bin`; `edit`
/// changes the JSON before it is written.
struct SceneFile {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl SceneFile {
    fn push(&mut self, bytes: &[u8], accessor: Value) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        let mut a = accessor;
        a["bufferView"] = json!(self.views.len() - 1);
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn floats(&mut self, data: &[f32], ty: &str, dims: usize) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let mut a = json!({"componentType": 5126, "count": data.len() / dims, "type": ty});
        if ty == "VEC3" && data.iter().all(|v| v.is_finite()) {
            let lo: Vec<f32> = (0..3)
                .map(|k| {
                    data.iter()
                        .skip(k)
                        .step_by(3)
                        .copied()
                        .fold(f32::MAX, f32::min)
                })
                .collect();
            let hi: Vec<f32> = (0..3)
                .map(|k| {
                    data.iter()
                        .skip(k)
                        .step_by(3)
                        .copied()
                        .fold(f32::MIN, f32::max)
                })
                .collect();
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        if ty == "VEC3" && !data.iter().all(|v| v.is_finite()) {
            a["min"] = json!([0, 0, 0]);
            a["max"] = json!([1, 1, 1]);
        }
        self.push(&bytes, a)
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        self.push(
            &bytes,
            json!({"componentType": 5125, "count": data.len(), "type": "SCALAR"}),
        )
    }
}

/// Ground (4 m, y = 0) and a 1 m wall standing on it: 4 triangles.
fn scene_json(uv1: Option<&[f32]>, positions: Option<&[f32]>) -> (Value, Vec<u8>) {
    let mut s = SceneFile {
        bin: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let p: Vec<f32> = positions.map(<[f32]>::to_vec).unwrap_or_else(|| {
        vec![
            -2., 0., -2., 2., 0., -2., 2., 0., 2., -2., 0., 2., // ground
            -1., 0., 0., 1., 0., 0., 1., 1., 0., -1., 1., 0., // wall facing +Z
        ]
    });
    let n = [
        0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0.,
        1.,
    ];
    let uv = [
        0., 0., 1., 0., 1., 1., 0., 1., 0., 0., 1., 0., 1., 1., 0., 1.,
    ];
    let mut attributes = json!({
        "POSITION": s.floats(&p, "VEC3", 3),
        "NORMAL": s.floats(&n, "VEC3", 3),
        "TEXCOORD_0": s.floats(&uv, "VEC2", 2),
    });
    if let Some(uv1) = uv1 {
        attributes["TEXCOORD_1"] = json!(s.floats(uv1, "VEC2", 2));
    }
    let indices = s.indices(&[0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7]);
    let json = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": indices}]}],
        "buffers": [{"byteLength": s.bin.len(), "uri": "BIN"}],
        "bufferViews": s.views,
        "accessors": s.accessors,
    });
    (json, s.bin)
}

/// Writes `name.gltf` (+ `name.bin` unless the edit changed the buffer URI) into `dir`.
fn gltf(dir: &Path, name: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
    gltf_with(dir, name, None, None, edit)
}

fn gltf_with(
    dir: &Path,
    name: &str,
    uv1: Option<&[f32]>,
    positions: Option<&[f32]>,
    edit: impl FnOnce(&mut Value),
) -> PathBuf {
    let (mut json, bin) = scene_json(uv1, positions);
    let bin_name = format!("{name}.bin");
    json["buffers"][0]["uri"] = json!(bin_name);
    write(&dir.join(&bin_name), &bin);
    edit(&mut json);
    let path = dir.join(format!("{name}.gltf"));
    write(&path, json.to_string().as_bytes());
    path
}

/// Adds a base-colour texture whose image is `uri`.
fn with_texture(json: &mut Value, uri: &str) {
    json["images"] = json!([{"uri": uri}]);
    json["textures"] = json!([{"source": 0}]);
    json["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    json["meshes"][0]["primitives"][0]["material"] = json!(0);
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// `shvis export` of `technique` on `path` at a small lightmap (64², 16 rays) with `seed`
/// into `out`, baking through `cache`, quiet.
fn small_export(technique: &str, path: &str, seed: &str, out: &Path, cache: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_shvis"));
    cmd.args([
        "export",
        "--technique",
        technique,
        "--path",
        path,
        "--vis-res",
        "64",
        "--rays",
        "16",
        "--seed",
        seed,
        "--out",
        &s(out),
    ])
    .env("SHVIS_CACHE_DIR", cache)
    .env("RUST_LOG", "off");
    cmd
}

/// An empty folder `NAME-PID` in the system's temporary directory.
fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Every file of folder `d` by name, with its bytes.
fn files_of(d: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}

// ---- The cases --------------------------------------------------------------------------

/// Options of every command: each bound, non-numbers, non-finite floats. All refused by
/// the parser (exit 2) or the first check (exit 1) before any work.
fn argument_cases(suite: &mut Suite) {
    let out = s(&suite.path("arg-out"));
    let png = s(&suite.path("arg.png"));
    let exr_out = s(&suite.path("arg.exr"));
    // (command line, exit code, needles)
    let mut table: Vec<(Vec<&str>, i32, Vec<&str>)> = Vec::new();
    for (flag, values) in [
        ("--rays", &["0", "65537", "-5", "many", "1e3"][..]),
        ("--order", &["0", "29", "31", "-1", "6.5"][..]),
        ("--table-res", &["3", "257"][..]),
        ("--h-order", &["0", "31"][..]),
        ("--seed", &["-1", "x"][..]),
        ("--height-scale", &["nan", "inf"][..]),
    ] {
        for v in values {
            table.push((vec!["bake", flag, v, "--out", &out], 2, vec![flag]));
        }
    }
    for v in ["0", "15", "63", "8193", "4294967295"] {
        let code = if v == "4294967295" || v.parse::<u64>().is_ok() {
            1
        } else {
            2
        };
        table.push((
            vec!["bake", "--vis-res", v, "--out", &out],
            code,
            vec!["--vis-res", "64..=8192", "house"],
        ));
    }
    table.push((
        vec!["bake", "--vis-res", "abc", "--out", &out],
        2,
        vec!["--vis-res"],
    ));
    let render = |extra: &[&'static str]| -> Vec<&'static str> {
        let mut v = vec!["render", "--technique", "preconv"];
        v.extend_from_slice(extra);
        v
    };
    for (flag, values) in [
        ("--width", &["0", "16385", "-1"][..]),
        ("--height", &["0", "99999"][..]),
        ("--exposure", &["nan", "inf", "-inf", "1e39", "bright"][..]),
        ("--bounces", &["17"][..]),
        ("--specular-sigma", &["nan"][..]),
        ("--specular-ks", &["-inf"][..]),
        ("--light-dir", &["nan,0,1", "0,inf,1"][..]),
    ] {
        for v in values {
            let mut args = render(&[]);
            args.extend([flag, v, "--out", &png]);
            table.push((args, 2, vec![flag]));
        }
    }
    table.push((
        vec!["render", "--technique", "unc99", "--out", &png],
        2,
        vec!["unc99"],
    ));
    table.push((
        vec![
            "render",
            "--technique",
            "preconv",
            "--path",
            "dx12",
            "--out",
            &png,
        ],
        2,
        vec!["dx12"],
    ));
    for (flag, v) in [
        ("--ref-spp", "0"),
        ("--ref-spp", "1000001"),
        ("--width", "0"),
        ("--bounces", "17"),
        ("--exposure", "nan"),
    ] {
        table.push((vec!["reference", flag, v, "--out", &exr_out], 2, vec![flag]));
    }
    table.push((
        vec!["reference", "--vis-res", "3", "--out", &exr_out],
        1,
        vec!["--vis-res 3", "64..=8192"],
    ));
    for (flag, v) in [
        ("--frames", "0"),
        ("--frames", "100001"),
        ("--warmup", "10001"),
        ("--warmup", "4000000000"),
        ("--ref-spp", "2000000"),
        ("--ref-spp", "-1"),
        ("--width", "0"),
        ("--exposure", "-inf"),
    ] {
        table.push((vec!["bench", flag, v, "--out", &out], 2, vec![flag]));
    }
    table.push((
        vec!["bench", "--techniques", "unc3,nope", "--out", &out],
        1,
        vec!["nope"],
    ));
    table.push((
        vec!["bench", "--paths", "dx12", "--out", &out],
        1,
        vec!["dx12"],
    ));
    table.push((
        vec!["export", "--technique", "vq16", "--out", &out],
        1,
        vec!["vq16.dx11", "cluster indices"],
    ));
    table.push((
        vec![
            "export",
            "--technique",
            "unc6",
            "--path",
            "dx9",
            "--out",
            &out,
        ],
        1,
        vec!["unc6.dx9", "--path dx10 or dx11"],
    ));
    table.push((
        vec!["export", "--technique", "rnmao", "--out", &out],
        1,
        vec!["rnmao", "material-space"],
    ));
    for (flag, v) in [
        ("--frames", "0"),
        ("--every", "0"),
        ("--error-frames", "65"),
        ("--turns", "nan"),
        ("--ref-spp", "0"),
    ] {
        table.push((vec!["relight", flag, v, "--out", &out], 2, vec![flag]));
    }
    for (flag, v) in [("--frames", "0"), ("--warmup", "10001"), ("--width", "0")] {
        table.push((vec!["probe", flag, v, "--out", &out], 2, vec![flag]));
    }
    for (args, flag) in [
        (vec!["study", "normalmap", "--rays", "0"], "--rays"),
        (vec!["study", "normalmap", "--map-res", "9000"], "--map-res"),
        (vec!["study", "rnm", "--vis-res", "9000"], "--vis-res"),
        (
            vec![
                "normalmap",
                "--high",
                "sphere:1",
                "--low",
                "sphere:0",
                "--expand",
                "5000",
            ],
            "--expand",
        ),
        (
            vec!["bake", "--baker", "gpu", "--depth-res", "8"],
            "--depth-res",
        ),
    ] {
        let mut args = args;
        args.extend(["--out", &out]);
        table.push((args, 2, vec![flag]));
    }
    table.push((
        vec!["study", "params", "--gpu-directions", "0", "--out", &out],
        1,
        vec!["--gpu-directions 0", "1..=10000000"],
    ));
    table.push((vec!["sh", "eval", "--order", "0"], 1, vec!["order"]));
    table.push((vec!["sh", "eval", "--order", "31"], 1, vec!["order"]));
    table.push((vec!["sh", "project", "--order", "31"], 1, vec!["order"]));
    table.push((
        vec!["sh", "irradiance", "--normal", "0,0,0"],
        1,
        vec!["normal"],
    ));
    table.push((
        vec!["sh", "irradiance", "--normal", "nan,0,1"],
        1,
        vec!["normal"],
    ));
    for (i, (args, code, needles)) in table.into_iter().enumerate() {
        let name = format!("args-{i}-{}", args.join(" "));
        let out_path = args
            .iter()
            .position(|a| *a == "--out")
            .map(|k| PathBuf::from(args[k + 1]));
        suite.add(
            Kind::Arguments,
            &name,
            &args,
            out_path,
            error(code, &needles),
        );
    }
}

/// Sizes checked against the budget before anything is allocated.
fn budget_cases(suite: &mut Suite) {
    let d = suite.dir.clone();
    let out = suite.path("budget-out");
    let huge_exr = exr_claiming(&d.join("huge.exr"), 200_000, 100_000);
    let big_exr = exr_claiming(&d.join("big.exr"), 16384, 8192);
    let huge_hdr = hdr(&d.join("huge_header.hdr"), 8, 4, [128, 128, 128, 129]);
    {
        let text = std::fs::read(&huge_hdr).unwrap();
        let patched = String::from_utf8_lossy(&text).replace("-Y 4 +X 8", "-Y 100000 +X 200000");
        write(&huge_hdr, patched.as_bytes());
    }
    let big_hdr = d.join("big_header.hdr");
    write(
        &big_hdr,
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8192 +X 16384\n\x02\x02\x40\x00",
    );
    let project = |env: &Path| {
        vec![
            "sh".to_string(),
            "project".into(),
            "--order".into(),
            "2".into(),
            "--env".into(),
            s(env),
        ]
    };
    let cases: Vec<BudgetCase> = vec![
        (
            "exr header 200000×100000",
            project(&huge_exr),
            None,
            vec!["huge.exr", "200000", "16384"],
        ),
        (
            "exr header 16384×8192 over a 64 MiB budget",
            project(&big_exr),
            Some("64M"),
            vec!["big.exr", "needs", "available"],
        ),
        (
            "hdr header 200000×100000",
            project(&huge_hdr),
            None,
            vec!["huge_header.hdr", "200000", "16384"],
        ),
        (
            "hdr header 16384×8192 over a 64 MiB budget",
            project(&big_hdr),
            Some("64M"),
            vec!["big_header.hdr", "needs"],
        ),
        (
            "render with the huge exr",
            strings(&[
                "render",
                "--technique",
                "preconv",
                "--vis-res",
                "64",
                "--rays",
                "4",
                "--width",
                "8",
                "--height",
                "8",
                "--env",
                &s(&huge_exr),
                "--out",
                &s(&d.join("huge.png")),
            ]),
            None,
            vec!["huge.exr", "200000"],
        ),
    ];
    for (name, args, limit, needles) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        suite.add(Kind::Budget, name, &args, None, error(1, &needles));
        if let Some(l) = limit {
            suite
                .last()
                .env
                .push(("SHVIS_MEMORY_LIMIT".into(), l.into()));
        }
    }
    for (cmd, width, height, limit) in [
        ("render", "16384", "16384", "4G"),
        ("reference", "16384", "16384", "16G"),
        ("bench", "16384", "8192", "16G"),
        ("probe", "8192", "8192", "1G"),
        ("relight", "16384", "16384", "16G"),
    ] {
        let mut args = vec![cmd, "--width", width, "--height", height];
        let out = d.join(format!("frames-{cmd}.exr"));
        let out_s = s(&out);
        match cmd {
            "render" => args.extend(["--technique", "preconv", "--out", &out_s]),
            "reference" => args.extend(["--out", &out_s]),
            _ => args.extend(["--out", &out_s]),
        }
        suite.add(
            Kind::Budget,
            &format!("{cmd} frames of {width}×{height}"),
            &args,
            Some(out),
            error(
                1,
                &[&format!("--width {width} × --height {height}"), "needs"],
            ),
        );
        // A stated budget, so that the case does not depend on the machine's memory.
        suite
            .last()
            .env
            .push(("SHVIS_MEMORY_LIMIT".into(), limit.into()));
    }
    for (name, vis_res, order, limit) in [
        ("vis-res 8192 × order 28", "8192", "28", None),
        ("vis-res 8192 × order 6", "8192", "6", Some("16G")),
        ("vis-res 2048 × order 6 over 1 GiB", "2048", "6", Some("1G")),
        ("vis-res 64 × order 6 over 1 MiB", "64", "6", Some("1M")),
        ("vis-res 512 × order 20 over 1 GiB", "512", "20", Some("1G")),
    ] {
        suite.add(
            Kind::Budget,
            name,
            &[
                "bake",
                "--vis-res",
                vis_res,
                "--order",
                order,
                "--out",
                &s(&out),
            ],
            Some(out.clone()),
            error(
                1,
                &[
                    &format!("--vis-res {vis_res} × --order {order}"),
                    "needs",
                    "lower --vis-res or --order",
                ],
            ),
        );
        if let Some(l) = limit {
            suite
                .last()
                .env
                .push(("SHVIS_MEMORY_LIMIT".into(), l.into()));
        }
    }
    // Textures: sized from their header before decoding.
    let tex = |name: &str, bytes: &[u8]| -> PathBuf {
        write(&d.join(format!("{name}.png")), bytes);
        gltf(&d, name, |j| with_texture(j, &format!("{name}.png")))
    };
    let huge_tex = tex("tex_huge", &png_claiming(100_000, 100_000));
    let wide_tex = tex("tex_wide", &png_claiming(16385, 1));
    let big_tex = tex("tex_big", &png_claiming(16384, 16384));
    let bake = |scene: &Path, out: &Path| {
        strings(&[
            "bake",
            "--scene",
            &s(scene),
            "--vis-res",
            "16",
            "--rays",
            "4",
            "--order",
            "2",
            "--out",
            &s(out),
        ])
    };
    for (name, scene, limit, needles) in [
        (
            "texture header 100000²",
            &huge_tex,
            None,
            vec!["tex_huge.gltf", "100000", "16384"],
        ),
        (
            "texture header 16385×1",
            &wide_tex,
            None,
            vec!["tex_wide.gltf", "16385"],
        ),
        (
            "texture header 16384² over 256 MiB",
            &big_tex,
            Some("256M"),
            vec!["tex_big.gltf", "needs"],
        ),
    ] {
        let o = d.join(format!(
            "out-{}",
            scene.file_stem().unwrap().to_string_lossy()
        ));
        let args = bake(scene, &o);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        suite.add(Kind::Budget, name, &args, None, error(1, &needles));
        if let Some(l) = limit {
            suite
                .last()
                .env
                .push(("SHVIS_MEMORY_LIMIT".into(), l.into()));
        }
    }
    // The documented maximum side loads (a 16384 × 4 texture).
    write(&d.join("tex_max.png"), &png(16384, 4));
    let max_tex = gltf(&d, "tex_max", |j| with_texture(j, "tex_max.png"));
    let o = d.join("out-tex-max");
    let args = bake(&max_tex, &o);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    suite.add(
        Kind::Budget,
        "texture 16384 wide loads",
        &args,
        Some(o),
        Expect::Ok,
    );
}

/// Values beyond what a path represents: refused or flagged, the same for every technique.
fn value_cases(suite: &mut Suite) {
    let d = suite.dir.clone();
    let env_1e30 = exr(&d.join("v1e30.exr"), 16, 8, |x, y| {
        if (x, y) == (3, 2) {
            [1e30; 3]
        } else {
            [1.0; 3]
        }
    });
    let env_rgbe255 = hdr(&d.join("rgbe255.hdr"), 8, 4, [200, 200, 200, 255]);
    let env_bright = exr(&d.join("bright.exr"), 64, 32, |_, _| [1e9; 3]);
    let env_negative = exr(&d.join("negative.exr"), 16, 8, |x, _| {
        if x == 0 { [-0.5; 3] } else { [1.0; 3] }
    });
    for (name, env, needles) in [
        (
            "texel 1e30",
            &env_1e30,
            vec!["v1e30.exr", "radiance limit", "x=3, y=2"],
        ),
        (
            "rgbe exponent 255",
            &env_rgbe255,
            vec!["rgbe255.hdr", "radiance limit"],
        ),
    ] {
        suite.add(
            Kind::Values,
            &format!("sh project: {name}"),
            &["sh", "project", "--order", "2", "--env", &s(env)],
            None,
            error(1, &needles),
        );
        for technique in ["preconv", "unc3", "sh2", "shlmap"] {
            let out = d.join(format!(
                "v-{technique}-{}.png",
                env.file_stem().unwrap().to_string_lossy()
            ));
            suite.add(
                Kind::Values,
                &format!("render {technique}: {name}"),
                &[
                    "render",
                    "--technique",
                    technique,
                    "--vis-res",
                    "64",
                    "--rays",
                    "16",
                    "--order",
                    "3",
                    "--width",
                    "8",
                    "--height",
                    "8",
                    "--env",
                    &s(env),
                    "--out",
                    &s(&out),
                ],
                Some(out.clone()),
                error(1, &needles),
            );
        }
    }
    suite.add(
        Kind::Values,
        "negative texels clamped with a warning",
        &["sh", "project", "--order", "2", "--env", &s(&env_negative)],
        None,
        warn(&["negative.exr", "negative radiance", "clamped"]),
    );
    for technique in ["preconv", "unc3"] {
        let out = d.join(format!("bright-{technique}.exr"));
        suite.add(
            Kind::Values,
            &format!("f16 target clips under a 1e9 sky: {technique}"),
            &[
                "render",
                "--technique",
                technique,
                "--vis-res",
                "64",
                "--rays",
                "16",
                "--order",
                "3",
                "--width",
                "16",
                "--height",
                "16",
                "--env",
                &s(&env_bright),
                "--out",
                &s(&out),
            ],
            Some(out),
            warn(&["pixels clipped", "65504"]),
        );
    }
    let bench_out = d.join("bench-bright");
    suite.add(
        Kind::Values,
        "bench marks the clipped row",
        &[
            "bench",
            "--techniques",
            "preconv",
            "--paths",
            "dx9",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--ref-spp",
            "0",
            "--no-probe",
            "--width",
            "16",
            "--height",
            "16",
            "--vis-res",
            "64",
            "--rays",
            "16",
            "--order",
            "3",
            "--env",
            &s(&env_bright),
            "--out",
            &s(&bench_out),
        ],
        Some(bench_out.join("table.json")),
        warn(&["pixels clipped"]),
    );
    let table = bench_out.join("table.json");
    let md = bench_out.join("table.md");
    suite.last().check = Some(Box::new(move |_, _| {
        let json: Value =
            serde_json::from_slice(&std::fs::read(&table).map_err(|e| e.to_string())?)
                .map_err(|e| e.to_string())?;
        let clipped = json["results"][0]["clipped_pixels"].as_u64().unwrap_or(0);
        let text = std::fs::read_to_string(&md).map_err(|e| e.to_string())?;
        if clipped == 0 || !text.contains("px clipped") {
            return Err(format!(
                "row not marked: clipped_pixels {clipped}; table.md: {text}"
            ));
        }
        Ok(())
    }));
    let out = d.join("rays1");
    suite.add(
        Kind::Values,
        "fewer rays than coefficients",
        &[
            "bake",
            "--vis-res",
            "64",
            "--rays",
            "1",
            "--order",
            "6",
            "--out",
            &s(&out),
        ],
        Some(out),
        warn(&["--rays 1", "36 SH coefficients"]),
    );
    for (name, camera) in [
        (
            "camera yfov 0",
            json!({"type": "perspective", "perspective": {"yfov": 0.0, "znear": 0.1}}),
        ),
        (
            "camera znear 0",
            json!({"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.0}}),
        ),
        (
            "camera yfov 4",
            json!({"type": "perspective", "perspective": {"yfov": 4.0, "znear": 0.1}}),
        ),
    ] {
        let file = name.replace(' ', "_");
        let scene = gltf(&d, &file, |j| {
            j["cameras"] = json!([camera]);
            j["nodes"] = json!([{"mesh": 0}, {"camera": 0, "translation": [0, 1, 5]}]);
            j["scenes"] = json!([{"nodes": [0, 1]}]);
        });
        let out = d.join(format!("{file}.png"));
        suite.add(
            Kind::Values,
            name,
            &[
                "render",
                "--technique",
                "preconv",
                "--scene",
                &s(&scene),
                "--vis-res",
                "32",
                "--rays",
                "4",
                "--order",
                "2",
                "--width",
                "8",
                "--height",
                "8",
                "--out",
                &s(&out),
            ],
            Some(out),
            warn(&[
                &format!("{file}.gltf"),
                "camera 0 is unusable",
                "frames the scene",
            ]),
        );
    }
    // Both quads mapped onto the same lightmap square.
    let same = [0.1f32, 0.1, 0.9, 0.1, 0.9, 0.9, 0.1, 0.9];
    let uv1: Vec<f32> = same.iter().chain(same.iter()).copied().collect();
    let overlap = gltf_with(&d, "overlap", Some(&uv1), None, |_| {});
    let out = d.join("overlap-out");
    suite.add(
        Kind::Values,
        "overlapping TEXCOORD_1 charts",
        &[
            "bake",
            "--scene",
            &s(&overlap),
            "--vis-res",
            "32",
            "--rays",
            "4",
            "--order",
            "2",
            "--out",
            &s(&out),
        ],
        Some(out),
        warn(&["lightmap UVs overlap", "TEXCOORD_1"]),
    );
    // The reference's sums stay finite under the brightest accepted sky: the noise it
    // prints is a finite positive number.
    let out = d.join("bright-reference.exr");
    suite.add(
        Kind::Values,
        "reference under a 1e9 sky",
        &[
            "reference",
            "--width",
            "16",
            "--height",
            "16",
            "--ref-spp",
            "16",
            "--vis-res",
            "64",
            "--env",
            &s(&env_bright),
            "--out",
            &s(&out),
        ],
        Some(out),
        Expect::Ok,
    );
    suite.last().check = Some(Box::new(|stdout, _| {
        let noise: Option<f64> = stdout
            .split("image) ")
            .nth(1)
            .and_then(|t| t.split_whitespace().next())
            .and_then(|t| t.parse().ok());
        match noise {
            Some(n) if n.is_finite() && n > 0.0 => Ok(()),
            _ => Err(format!("noise not a finite positive number: {stdout}")),
        }
    }));
    let out = d.join("exposure.png");
    suite.add(
        Kind::Values,
        "exposure 1e39 overflows f32",
        &[
            "render",
            "--technique",
            "preconv",
            "--exposure",
            "1e39",
            "--out",
            &s(&out),
        ],
        Some(out),
        error(2, &["--exposure"]),
    );
}

/// Environment files (through `sh project`: no device needed).
fn env_file_cases(suite: &mut Suite) {
    let d = suite.dir.clone();
    let good = exr(&d.join("good.exr"), 16, 8, |_, _| [1.0; 3]);
    let bytes = std::fs::read(&good).unwrap();
    let truncated = d.join("truncated.exr");
    write(&truncated, &bytes[..bytes.len() / 2]);
    let header_only = d.join("header_only.exr");
    write(&header_only, &bytes[..40]);
    let text = d.join("text.exr");
    write(&text, b"these are not texels\n");
    let empty = d.join("empty.exr");
    write(&empty, b"");
    let zero = d.join("zero.exr");
    let _ = std::os::unix::fs::symlink("/dev/zero", &zero);
    let fifo = d.join("fifo.exr");
    let _ = Command::new("mkfifo").arg(&fifo).status();
    let dir = d.join("a_directory.exr");
    std::fs::create_dir_all(&dir).unwrap();
    let wide = exr(&d.join("three_to_one.exr"), 24, 8, |_, _| [1.0; 3]);
    let tall = exr(&d.join("tall.exr"), 8, 16, |_, _| [1.0; 3]);
    let nan = exr(&d.join("nan.exr"), 16, 8, |x, y| {
        if (x, y) == (5, 1) {
            [f32::NAN, 0.0, 0.0]
        } else {
            [1.0; 3]
        }
    });
    let inf = exr(&d.join("inf.exr"), 16, 8, |x, _| {
        if x == 2 {
            [0.0, f32::INFINITY, 0.0]
        } else {
            [1.0; 3]
        }
    });
    let neg_inf = exr(&d.join("neg_inf.exr"), 16, 8, |x, _| {
        if x == 2 {
            [0.0, 0.0, f32::NEG_INFINITY]
        } else {
            [1.0; 3]
        }
    });
    let square = exr(&d.join("square.exr"), 16, 16, |_, _| [1.0; 3]);
    let one_row = exr(&d.join("one_row.exr"), 2, 1, |_, _| [1.0; 3]);
    let hdr_garbage = d.join("garbage.hdr");
    write(
        &hdr_garbage,
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n\x01",
    );
    let hdr_no_size = d.join("no_size.hdr");
    write(&hdr_no_size, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n");
    let png_env = d.join("photo.exr");
    write(&png_env, &png(8, 4));
    let exr_named_hdr = d.join("misnamed.hdr");
    std::fs::copy(&good, &exr_named_hdr).unwrap();
    let mut flipped = bytes.clone();
    let n = flipped.len();
    for i in (n / 2..n).step_by(7) {
        flipped[i] ^= 0x5a;
    }
    let corrupt = d.join("corrupt_tiles.exr");
    write(&corrupt, &flipped);
    let cases: Vec<(&str, String, Expect)> = vec![
        (
            "missing",
            s(&d.join("absent.exr")),
            error(1, &["absent.exr", "cannot read"]),
        ),
        ("truncated", s(&truncated), error(1, &["truncated.exr"])),
        (
            "header only",
            s(&header_only),
            error(1, &["header_only.exr"]),
        ),
        (
            "text",
            s(&text),
            error(1, &["text.exr", "not an OpenEXR or Radiance HDR file"]),
        ),
        (
            "empty",
            s(&empty),
            error(1, &["empty.exr", "not an OpenEXR"]),
        ),
        (
            "link to /dev/zero",
            s(&zero),
            error(1, &["zero.exr", "not a regular file"]),
        ),
        (
            "FIFO",
            s(&fifo),
            error(1, &["fifo.exr", "not a regular file (a FIFO)"]),
        ),
        (
            "directory",
            s(&dir),
            error(1, &["a_directory.exr", "directory"]),
        ),
        ("3:1", s(&wide), error(1, &["three_to_one.exr", "24×8"])),
        ("1:2", s(&tall), error(1, &["tall.exr", "8×16"])),
        (
            "one row",
            s(&one_row),
            error(1, &["one_row.exr", "2×1", "too small"]),
        ),
        (
            "NaN texel",
            s(&nan),
            error(1, &["nan.exr", "NaN or infinite", "x=5, y=1"]),
        ),
        (
            "Inf texel",
            s(&inf),
            error(1, &["inf.exr", "NaN or infinite"]),
        ),
        (
            "-Inf texel",
            s(&neg_inf),
            error(1, &["neg_inf.exr", "NaN or infinite"]),
        ),
        (
            "square without a disk",
            s(&square),
            error(1, &["square.exr", "angular"]),
        ),
        (
            "hdr garbage",
            s(&hdr_garbage),
            error(1, &["garbage.hdr", "Radiance"]),
        ),
        (
            "hdr without size",
            s(&hdr_no_size),
            error(1, &["no_size.hdr", "Radiance"]),
        ),
        (
            "png named exr",
            s(&png_env),
            error(1, &["photo.exr", "89 50 4e 47"]),
        ),
        (
            "corrupt tiles",
            s(&corrupt),
            error(1, &["corrupt_tiles.exr"]),
        ),
        (
            "angular: missing",
            format!("angular:{}", s(&d.join("nope.exr"))),
            error(1, &["nope.exr"]),
        ),
        ("exr named .hdr loads", s(&exr_named_hdr), Expect::Ok),
    ];
    for (name, env, expect) in cases {
        suite.add(
            Kind::EnvFiles,
            name,
            &["sh", "project", "--order", "2", "--env", &env],
            None,
            expect,
        );
    }
    let out = d.join("fifo-height.png");
    suite.add(
        Kind::EnvFiles,
        "height map is a FIFO",
        &[
            "render",
            "--technique",
            "preconv",
            "--height-map",
            &s(&fifo),
            "--out",
            &s(&out),
        ],
        Some(out),
        error(1, &["fifo.exr", "not a regular file (a FIFO)"]),
    );
    let out = d.join("env-render.png");
    suite.add(
        Kind::EnvFiles,
        "render with a FIFO env fails before the bake",
        &[
            "render",
            "--technique",
            "preconv",
            "--env",
            &s(&fifo),
            "--out",
            &s(&out),
        ],
        Some(out),
        error(1, &["fifo.exr", "not a regular file"]),
    );
}

/// glTF files: structure, URIs and textures (through `bake`: no device needed).
fn scene_file_cases(suite: &mut Suite) {
    let d = suite.dir.join("scenes");
    std::fs::create_dir_all(&d).unwrap();
    let outside = suite.dir.join("outside.bin");
    write(&outside, &[0u8; 256]);
    let malformed = d.join("malformed.gltf");
    write(
        &malformed,
        b"{ \"asset\": {\"version\": \"2.0\"}, \"meshes\": [ ",
    );
    let glb_bad = d.join("bad_magic.glb");
    write(
        &glb_bad,
        b"glTX\x02\0\0\0\x20\0\0\0garbage-garbage-garbage!",
    );
    let glb_short = d.join("short.glb");
    write(&glb_short, b"glTF\x02\0\0\0\x04\0\0\0");
    let not_json = d.join("binary.gltf");
    write(&not_json, &[0xff, 0xfe, 0x00, 0x01, 0x02]);
    let nan_positions: Vec<f32> = {
        let mut p = vec![
            -2., 0., -2., 2., 0., -2., 2., 0., 2., -2., 0., 2., -1., 0., 0., 1., 0., 0., 1., 1.,
            0., -1., 1., 0.,
        ];
        p[4] = f32::NAN;
        p
    };
    let degenerate: Vec<f32> = vec![0.0; 24];
    let mut cases: Vec<(&str, PathBuf, Vec<&str>)> = vec![
        (
            "malformed json",
            malformed,
            vec!["malformed.gltf", "invalid glTF"],
        ),
        ("bad glb magic", glb_bad, vec!["bad_magic.glb"]),
        ("short glb", glb_short, vec!["short.glb"]),
        ("binary .gltf", not_json, vec!["binary.gltf"]),
        ("missing file", d.join("absent.gltf"), vec!["absent.gltf"]),
        (
            "missing file, capital extension",
            d.join("absent.GLB"),
            vec!["absent.GLB", "cannot read"],
        ),
        (
            "absolute buffer path",
            gltf(&d, "abs_buffer", |j| {
                j["buffers"][0]["uri"] = json!(s(&outside))
            }),
            vec!["abs_buffer.gltf", "refused", "absolute"],
        ),
        (
            "file: URI to /etc/passwd",
            gltf(&d, "passwd", |j| {
                j["buffers"][0]["uri"] = json!("file:///etc/passwd")
            }),
            vec!["passwd.gltf", "refused", "file:"],
        ),
        (
            "http URI",
            gltf(&d, "remote", |j| {
                j["buffers"][0]["uri"] = json!("http://example.com/x.bin")
            }),
            vec!["remote.gltf", "refused", "no network"],
        ),
        (
            "../ escape",
            gltf(&d, "escape", |j| {
                j["buffers"][0]["uri"] = json!("../outside.bin")
            }),
            vec!["escape.gltf", "refused", "leaves the glTF file's folder"],
        ),
        (
            "percent-encoded ../ escape",
            gltf(&d, "escape_pct", |j| {
                j["buffers"][0]["uri"] = json!("sub/%2E%2E/%2E%2E/outside.bin")
            }),
            vec!["escape_pct.gltf", "leaves the glTF file's folder"],
        ),
        (
            "image file: URI",
            gltf(&d, "image_passwd", |j| {
                with_texture(j, "file:///etc/passwd")
            }),
            vec!["image_passwd.gltf", "refused"],
        ),
        (
            "image absolute path",
            gltf(&d, "image_abs", |j| with_texture(j, "/etc/hostname")),
            vec!["image_abs.gltf", "refused"],
        ),
        (
            "bad data URI",
            gltf(&d, "bad_data", |j| {
                j["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@")
            }),
            vec!["bad_data.gltf", "data URI"],
        ),
        (
            "missing buffer file",
            gltf(&d, "lost_bin", |j| {
                j["buffers"][0]["uri"] = json!("lost.bin")
            }),
            vec!["lost_bin.gltf", "not found"],
        ),
        (
            "buffer is /dev/zero link",
            {
                let p = gltf(&d, "zero_bin", |j| {
                    j["buffers"][0]["uri"] = json!("zero.bin")
                });
                let _ = std::os::unix::fs::symlink("/dev/zero", d.join("zero.bin"));
                p
            },
            vec!["zero_bin.gltf", "not a regular file"],
        ),
        (
            "buffer file shorter than its byteLength",
            gltf(&d, "short_buffer", |j| {
                j["buffers"][0]["byteLength"] = json!(100000)
            }),
            vec!["short_buffer.gltf", "byteLength is 100000"],
        ),
        (
            "NaN positions",
            gltf_with(&d, "nan_pos", None, Some(&nan_positions), |_| {}),
            vec!["nan_pos.gltf", "not finite"],
        ),
        (
            "all triangles degenerate",
            gltf_with(&d, "degenerate", None, Some(&degenerate), |_| {}),
            vec!["degenerate.gltf", "no usable triangles"],
        ),
        (
            "index out of range",
            gltf(&d, "bad_index", |j| j["accessors"][3]["count"] = json!(13)),
            vec!["bad_index.gltf"],
        ),
        (
            "no meshes in the scene",
            gltf(&d, "no_mesh", |j| j["scenes"] = json!([{"nodes": []}])),
            vec!["no_mesh.gltf", "no meshes"],
        ),
        (
            "node cycle",
            gltf(&d, "cycle", |j| {
                j["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}])
            }),
            vec!["cycle.gltf"],
        ),
        (
            "corrupt texture",
            {
                write(&d.join("corrupt.png"), &png(4, 4)[..30]);
                gltf(&d, "corrupt_tex", |j| with_texture(j, "corrupt.png"))
            },
            vec!["corrupt_tex.gltf", "image 0"],
        ),
        (
            "texture not an image",
            {
                write(&d.join("notes.png"), b"hello");
                gltf(&d, "text_tex", |j| with_texture(j, "notes.png"))
            },
            vec!["text_tex.gltf", "image 0"],
        ),
    ];
    let unknown = PathBuf::from("castle");
    cases.push(("unknown built-in", unknown, vec!["castle", "unknown scene"]));
    let dir_scene = d.join("folder.gltf");
    std::fs::create_dir_all(&dir_scene).unwrap();
    cases.push(("scene is a directory", dir_scene, vec!["folder.gltf"]));
    for (i, (name, scene, needles)) in cases.into_iter().enumerate() {
        let out = d.join(format!("out-{i}"));
        suite.add(
            Kind::SceneFiles,
            name,
            &[
                "bake",
                "--scene",
                &s(&scene),
                "--vis-res",
                "16",
                "--rays",
                "4",
                "--order",
                "2",
                "--out",
                &s(&out),
            ],
            Some(out),
            error(1, &needles),
        );
    }
    let caps = gltf(&d, "capitals", |_| {});
    let caps_upper = d.join("CAPITALS.GLTF");
    std::fs::rename(&caps, &caps_upper).unwrap();
    let out = d.join("out-capitals");
    suite.add(
        Kind::SceneFiles,
        ".GLTF in capitals loads",
        &[
            "bake",
            "--scene",
            &s(&caps_upper),
            "--vis-res",
            "16",
            "--rays",
            "4",
            "--order",
            "2",
            "--out",
            &s(&out),
        ],
        Some(out.join("manifest.json")),
        Expect::Ok,
    );
    let sub = d.join("sub");
    std::fs::create_dir_all(&sub).unwrap();
    let (json, bin) = scene_json(None, None);
    write(&sub.join("mesh.bin"), &bin);
    let mut json = json;
    json["buffers"][0]["uri"] = json!("sub/mesh.bin");
    let nested = d.join("nested.gltf");
    write(&nested, json.to_string().as_bytes());
    let out = d.join("out-nested");
    suite.add(
        Kind::SceneFiles,
        "relative path into a subfolder loads",
        &[
            "bake",
            "--scene",
            &s(&nested),
            "--vis-res",
            "16",
            "--rays",
            "4",
            "--order",
            "2",
            "--out",
            &s(&out),
        ],
        Some(out.join("manifest.json")),
        Expect::Ok,
    );
}

/// Output and cache locations, checked before any bake; a full disk.
fn output_cases(suite: &mut Suite) {
    let d = suite.dir.clone();
    let file = d.join("a_file");
    write(&file, b"x");
    let as_dir = d.join("dir.png");
    std::fs::create_dir_all(&as_dir).unwrap();
    let quick = [
        "--vis-res",
        "64",
        "--rays",
        "4",
        "--order",
        "2",
        "--width",
        "8",
        "--height",
        "8",
    ];
    let render = |out: &str| {
        let mut v = strings(&["render", "--technique", "preconv"]);
        v.extend(strings(&quick));
        v.extend(strings(&["--out", out]));
        v
    };
    let cases: Vec<OutputCase> = vec![
        (
            "render into /proc",
            render("/proc/shvis/x.png"),
            vec!["/proc/shvis", "--out is not writable"],
            None,
        ),
        (
            "render over a directory",
            render(&s(&as_dir)),
            vec!["dir.png", "is a directory"],
            None,
        ),
        (
            "render under a file",
            render(&s(&file.join("x.png"))),
            vec!["a_file"],
            None,
        ),
        (
            "render to .jpg",
            render(&s(&d.join("x.jpg"))),
            vec!["x.jpg", "extension"],
            Some(d.join("x.jpg")),
        ),
        (
            "reference into /proc",
            strings(&[
                "reference",
                "--width",
                "8",
                "--height",
                "8",
                "--out",
                "/proc/shvis/r.exr",
            ]),
            vec!["/proc/shvis"],
            None,
        ),
        (
            "reference to .tiff",
            strings(&["reference", "--out", &s(&d.join("r.tiff"))]),
            vec!["r.tiff"],
            Some(d.join("r.tiff")),
        ),
        (
            "bake into /proc",
            strings(&[
                "bake",
                "--vis-res",
                "64",
                "--rays",
                "4",
                "--out",
                "/proc/shvis/bake",
            ]),
            vec!["/proc/shvis/bake", "--out is not writable"],
            None,
        ),
        (
            "bake into a file",
            strings(&["bake", "--vis-res", "64", "--rays", "4", "--out", &s(&file)]),
            vec!["a_file", "not a directory"],
            None,
        ),
        (
            "bench into /proc",
            strings(&["bench", "--out", "/proc/shvis/bench"]),
            vec!["/proc/shvis/bench"],
            None,
        ),
        (
            "probe into a file",
            strings(&["probe", "--out", &s(&file)]),
            vec!["a_file"],
            None,
        ),
        (
            "relight into /proc",
            strings(&["relight", "--out", "/proc/shvis/relight"]),
            vec!["/proc/shvis/relight"],
            None,
        ),
    ];
    for (name, args, needles, out) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let cache = PathBuf::from(suite.cache(name));
        suite.add(Kind::Outputs, name, &args, out, error(1, &needles));
        // Checked before any bake: the cache stays empty.
        suite.last().check = Some(Box::new(move |_, _| {
            let baked = std::fs::read_dir(&cache).is_ok_and(|mut e| e.next().is_some());
            if baked {
                return Err("a bake ran before the output was checked".into());
            }
            Ok(())
        }));
    }
    let out = d.join("view-shot.png");
    suite.add(
        Kind::Outputs,
        "view without a display",
        &["view", "--frames", "2", "--screenshot", &s(&out)],
        Some(out.clone()),
        error(1, &["no display", "xvfb-run"]),
    );
    suite.last().env.push(("DISPLAY".into(), String::new()));
    suite
        .last()
        .env
        .push(("WAYLAND_DISPLAY".into(), String::new()));
    suite.add(
        Kind::Outputs,
        "view screenshot into /proc",
        &[
            "view",
            "--frames",
            "2",
            "--screenshot",
            "/proc/shvis/shot.png",
        ],
        None,
        error(1, &["/proc/shvis", "--screenshot is not writable"]),
    );
    for (name, cache, needles) in [
        (
            "cache in /proc",
            "/proc/shvis-cache",
            vec!["/proc/shvis-cache", "bake cache"],
        ),
        ("cache is a file", &*s(&file), vec!["a_file", "bake cache"]),
    ] {
        let out = d.join(format!("{}.png", name.replace(' ', "_")));
        let args = render(&s(&out));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        suite.add(Kind::Outputs, name, &args, Some(out), error(1, &needles));
        suite.last().env = vec![("SHVIS_CACHE_DIR".into(), cache.to_string())];
        let out = d.join(format!("{}-bake", name.replace(' ', "_")));
        suite.add(
            Kind::Outputs,
            &format!("bake with {name}"),
            &["bake", "--vis-res", "64", "--rays", "4", "--out", &s(&out)],
            None,
            error(1, &needles),
        );
        suite.last().env = vec![("SHVIS_CACHE_DIR".into(), cache.to_string())];
    }
    // A full disk: files limited to 64 KiB (SIGXFSZ ignored, so writes fail with EFBIG).
    // The bake cache is filled first without the limit, so the frame is what fails.
    let warm = d.join("full-warm.exr");
    let cache = suite.cache("full disk");
    let mut warm_args = strings(&[
        "render",
        "--technique",
        "preconv",
        "--vis-res",
        "64",
        "--rays",
        "4",
        "--order",
        "2",
        "--width",
        "8",
        "--height",
        "8",
        "--out",
        &s(&warm),
    ]);
    let warm_run = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(&warm_args)
        .env("SHVIS_CACHE_DIR", &cache)
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    assert!(
        warm_run.status.success(),
        "{}",
        String::from_utf8_lossy(&warm_run.stderr)
    );
    let out = d.join("full.exr");
    warm_args.truncate(warm_args.len() - 6);
    warm_args.extend(strings(&[
        "--width",
        "256",
        "--height",
        "256",
        "--out",
        &s(&out),
    ]));
    let args: Vec<&str> = warm_args.iter().map(String::as_str).collect();
    suite.add(
        Kind::Outputs,
        "disk full while writing the frame",
        &args,
        Some(out),
        error(1, &["full.exr", "cannot write"]),
    );
    suite.last().env = vec![("SHVIS_CACHE_DIR".into(), cache)];
    suite.last().shell = Some("ulimit -f 64; trap '' XFSZ;".into());
}

/// Bake caches: every damaged or foreign file is rebuilt with a warning, never trusted.
fn cache_cases(suite: &mut Suite) {
    let d = suite.dir.clone();
    let bake = |out: &Path| {
        strings(&[
            "bake",
            "--vis-res",
            "64",
            "--rays",
            "8",
            "--order",
            "3",
            "--out",
            &s(out),
        ])
    };
    // One clean run whose cache file and outputs every case is compared with.
    let clean_cache = PathBuf::from(suite.cache("clean"));
    let clean_out = d.join("cache-clean-out");
    let run = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(bake(&clean_out))
        .env("SHVIS_CACHE_DIR", &clean_cache)
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let cache_file = std::fs::read_dir(&clean_cache)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "bin"))
        .expect("a cache file");
    let name = cache_file.file_name().unwrap().to_owned();
    let good = std::fs::read(&cache_file).unwrap();
    const HEADER: usize = 40;
    // Payload: res u32, order u32, rays u64, seconds f64, then coefficients (f32) …
    let resealed = |mut bytes: Vec<u8>| {
        let h = shvis::files::hash64(&bytes[HEADER..]);
        bytes[32..40].copy_from_slice(&h.to_le_bytes());
        bytes
    };
    let texels = 64 * 64;
    let coeff0 = HEADER + 24;
    let flags0 = coeff0 + 4 * texels * 9;
    let ao0 = flags0 + texels;
    let mut variants: Vec<(&str, Option<Vec<u8>>, &str)> = Vec::new();
    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 0x10;
    variants.push(("flipped payload byte", Some(flipped), "checksum"));
    variants.push((
        "truncated",
        Some(good[..good.len() - 100].to_vec()),
        "payload length",
    ));
    variants.push(("header only", Some(good[..20].to_vec()), "truncated header"));
    variants.push(("empty", Some(Vec::new()), "truncated header"));
    let mut version = good.clone();
    version[8] = 99;
    variants.push(("other version", Some(version), "format version 99"));
    let mut key = good.clone();
    key[16] ^= 1;
    variants.push(("foreign key", Some(key), "key"));
    let mut magic = good.clone();
    magic[0] = b'X';
    variants.push(("wrong magic", Some(magic), "magic"));
    let mut nan = good.clone();
    nan[coeff0 + 40..coeff0 + 44].copy_from_slice(&f32::NAN.to_le_bytes());
    variants.push((
        "NaN coefficient, valid checksum",
        Some(resealed(nan)),
        "coefficient 10 is NaN",
    ));
    let mut huge = good.clone();
    huge[coeff0..coeff0 + 4].copy_from_slice(&1e30f32.to_le_bytes());
    variants.push((
        "1e30 coefficient, valid checksum",
        Some(resealed(huge)),
        "not what a bake produces",
    ));
    let mut ao = good.clone();
    ao[ao0 + 8..ao0 + 12].copy_from_slice(&2.0f32.to_le_bytes());
    variants.push(("AO 2, valid checksum", Some(resealed(ao)), "outside [0, 1]"));
    let mut flag = good.clone();
    flag[flags0 + 3] = 7;
    variants.push((
        "coverage flag 7, valid checksum",
        Some(resealed(flag)),
        "coverage flag 7",
    ));
    let mut res = good.clone();
    res[HEADER..HEADER + 4].copy_from_slice(&32u32.to_le_bytes());
    variants.push((
        "other resolution, valid checksum",
        Some(resealed(res)),
        "holds res 32",
    ));
    variants.push(("link to /dev/zero", None, "not a regular file"));
    let clean_layers: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(&clean_out)
        .unwrap()
        .flatten()
        .map(|e| (e.path(), std::fs::read(e.path()).unwrap()))
        .collect();
    for (i, (what, bytes, needle)) in variants.into_iter().enumerate() {
        let case_name = format!("cache {what}");
        let cache = PathBuf::from(suite.cache(&case_name));
        std::fs::create_dir_all(&cache).unwrap();
        match bytes {
            Some(b) => write(&cache.join(&name), &b),
            None => std::os::unix::fs::symlink("/dev/zero", cache.join(&name)).unwrap(),
        }
        let out = d.join(format!("cache-out-{i}"));
        let args = bake(&out);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        suite.add(
            Kind::Cache,
            &case_name,
            &args,
            Some(out.join("manifest.json")),
            warn(&["bake cache", needle, "rebuilding"]),
        );
        let layers = clean_layers.clone();
        let (cache_path, good) = (cache.join(&name), good.clone());
        suite.last().check = Some(Box::new(move |_, _| {
            for (p, want) in &layers {
                let got =
                    std::fs::read(out.join(p.file_name().unwrap())).map_err(|e| e.to_string())?;
                if &got != want {
                    return Err(format!("{} differs from the clean run's", p.display()));
                }
            }
            // The rebuilt cache equals the clean one except for the timing field.
            let rebuilt = std::fs::read(&cache_path).map_err(|e| e.to_string())?;
            if rebuilt.len() != good.len() || rebuilt[HEADER + 24..] != good[HEADER + 24..] {
                return Err("the rebuilt cache differs from a clean bake's".into());
            }
            Ok(())
        }));
    }
    // A directory where the cache file goes: cannot be rebuilt, so an error naming it.
    let cache = PathBuf::from(suite.cache("cache path is a directory"));
    std::fs::create_dir_all(cache.join(&name)).unwrap();
    let out = d.join("cache-dir-out");
    let args = bake(&out);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    suite.add(
        Kind::Cache,
        "cache path is a directory",
        &args,
        None,
        error(1, &[&name.to_string_lossy(), "cannot write"]),
    );
    // Temporaries of a killed run are removed; those of live processes are kept.
    let cache = PathBuf::from(suite.cache("stale temporaries"));
    std::fs::create_dir_all(&cache).unwrap();
    let dead = cache.join(format!(".{}.tmp-2147483600-0", name.to_string_lossy()));
    let live = cache.join(format!(".{}.tmp-1-0", name.to_string_lossy()));
    write(&dead, b"half a file");
    write(&live, b"pid 1 is alive");
    let out = d.join("cache-stale-out");
    let args = bake(&out);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    suite.add(
        Kind::Cache,
        "stale temporaries",
        &args,
        Some(out),
        Expect::Ok,
    );
    suite.last().check = Some(Box::new(move |_, _| {
        if dead.exists() || !live.exists() {
            return Err(format!(
                "dead temp exists {}, live temp exists {}",
                dead.exists(),
                live.exists()
            ));
        }
        Ok(())
    }));
}

/// DESIGN §6 at the command line.
fn hard_cases(suite: &mut Suite) {
    let d = suite.dir.clone();
    // An HDR sun of 1e5 (a 2×2-texel disc in a 1 sky): finite, unclipped, on both paths.
    let sun = exr(&d.join("sun1e5.exr"), 128, 64, |x, y| {
        if (60..62).contains(&x) && (20..22).contains(&y) {
            [1e5; 3]
        } else {
            [0.5; 3]
        }
    });
    for technique in ["unc6", "preconv", "pca8", "sh2"] {
        for path in ["dx9", "dx10"] {
            let out = d.join(format!("sun-{technique}-{path}.exr"));
            suite.add(
                Kind::HardCases,
                &format!("1e5 sun: {technique} {path}"),
                &[
                    "render",
                    "--technique",
                    technique,
                    "--path",
                    path,
                    "--vis-res",
                    "64",
                    "--rays",
                    "64",
                    "--width",
                    "32",
                    "--height",
                    "20",
                    "--env",
                    &s(&sun),
                    "--out",
                    &s(&out),
                ],
                Some(out.clone()),
                Expect::Ok,
            );
            suite.last().check = Some(Box::new(move |_, stderr| {
                if stderr.contains("clipped") {
                    return Err(format!("clipped: {stderr}"));
                }
                let img = exr::prelude::read_first_rgba_layer_from_file(
                    &out,
                    |r, _| vec![[0.0f32; 4]; r.width() * r.height()],
                    |px: &mut Vec<[f32; 4]>, p, (r, g, b, a): (f32, f32, f32, f32)| {
                        px[p.y() * 32 + p.x()] = [r, g, b, a]
                    },
                )
                .map_err(|e| e.to_string())?;
                let px = img.layer_data.channel_data.pixels;
                let lit = px.iter().filter(|p| p[3] > 0.5 && p[0] > 0.0).count();
                if !px.iter().flatten().all(|c| c.is_finite()) || lit == 0 {
                    return Err(format!(
                        "{lit} lit pixels, finite: {}",
                        px.iter().flatten().all(|c| c.is_finite())
                    ));
                }
                Ok(())
            }));
        }
    }
    // Degenerate and zero-UV-area triangles beside good ones: skipped with a warning.
    let mut p = vec![
        -2., 0., -2., 2., 0., -2., 2., 0., 2., -2., 0., 2., -1., 0., 0., 1., 0., 0., 1., 1., 0.,
        -1., 1., 0.,
    ];
    p[18..24].copy_from_slice(&[1., 0., 0., 1., 0., 0.]); // wall corners 6, 7 collapse onto 5
    let degenerate = gltf_with(&d, "some_degenerate", None, Some(&p), |_| {});
    let out = d.join("degenerate-out");
    suite.add(
        Kind::HardCases,
        "degenerate triangles skipped",
        &[
            "bake",
            "--scene",
            &s(&degenerate),
            "--vis-res",
            "32",
            "--rays",
            "4",
            "--order",
            "2",
            "--out",
            &s(&out),
        ],
        Some(out),
        warn(&["degenerate"]),
    );
    // Zero-length normals from a normal map of (128, 128, 128) texels.
    let mut grey = Vec::new();
    image::RgbaImage::from_pixel(4, 4, image::Rgba([128, 128, 128, 255]))
        .write_to(
            &mut std::io::Cursor::new(&mut grey),
            image::ImageFormat::Png,
        )
        .unwrap();
    write(&d.join("grey.png"), &grey);
    let zero_normals = gltf(&d, "zero_normals", |j| {
        j["images"] = json!([{"uri": "grey.png"}]);
        j["textures"] = json!([{"source": 0}]);
        j["materials"] = json!([{"normalTexture": {"index": 0}}]);
        j["meshes"][0]["primitives"][0]["material"] = json!(0);
    });
    for technique in ["unc6", "preconv"] {
        let out = d.join(format!("zero-normals-{technique}.exr"));
        suite.add(
            Kind::HardCases,
            &format!("zero-length normal-map normals: {technique}"),
            &[
                "render",
                "--technique",
                technique,
                "--scene",
                &s(&zero_normals),
                "--vis-res",
                "32",
                "--rays",
                "64",
                "--width",
                "16",
                "--height",
                "16",
                "--out",
                &s(&out),
            ],
            Some(out),
            Expect::Ok,
        );
    }
}

// ---- One test per class -----------------------------------------------------------------

impl Kind {
    /// Every class, in the order of the enum.
    const ALL: [Kind; 9] = [
        Kind::Arguments,
        Kind::Budget,
        Kind::Values,
        Kind::EnvFiles,
        Kind::SceneFiles,
        Kind::Outputs,
        Kind::Cache,
        Kind::HardCases,
        Kind::Surfaces,
    ];

    /// The generator of this class's cases.
    fn cases(self) -> fn(&mut Suite) {
        match self {
            Kind::Arguments => argument_cases,
            Kind::Budget => budget_cases,
            Kind::Values => value_cases,
            Kind::EnvFiles => env_file_cases,
            Kind::SceneFiles => scene_file_cases,
            Kind::Outputs => output_cases,
            Kind::Cache => cache_cases,
            Kind::HardCases => hard_cases,
            Kind::Surfaces => surface_cases,
        }
    }
}

/// The surfaces added since the other classes (see [`Kind::Surfaces`]): each refusal is one
/// `error:` line naming what is wrong, before any work.
fn surface_cases(suite: &mut Suite) {
    use shvis::technique::{HwPath, Technique};
    let d = suite.path("surfaces");
    std::fs::create_dir_all(&d).unwrap();
    let out = |name: &str| d.join(format!("out-{name}"));
    let k = Kind::Surfaces;

    // sh: files, malformed, in study bases and render (36 × 2).
    let mut order31 = String::new();
    for _ in 0..31 * 31 {
        order31.push_str("1 0 0\n");
    }
    let mut sixteen = "1 1 1\n".repeat(15);
    sixteen.push_str("x y z\n");
    let sh_files: Vec<(&str, Vec<u8>)> = vec![
        ("empty", vec![]),
        ("comment", b"# only a comment\n".to_vec()),
        ("blank", b"\n\n\n".to_vec()),
        ("spaces", b"   \n\t\n".to_vec()),
        ("two", b"1 2\n".to_vec()),
        ("four", b"1 2 3 4\n".to_vec()),
        ("text", b"a b c\n".to_vec()),
        ("nan", b"nan 0 0\n".to_vec()),
        ("inf", b"inf 0 0\n".to_vec()),
        ("neginf", b"-inf 0 0\n".to_vec()),
        ("plusinf", b"+inf 0 0\n".to_vec()),
        ("e13", b"1e13 0 0\n".to_vec()),
        ("nege13", b"-1e13 0 0\n".to_vec()),
        ("e38", b"3e38 0 0\n".to_vec()),
        ("e400", b"1e400 0 0\n".to_vec()),
        ("e30green", b"0 1e30 0\n".to_vec()),
        ("justover", b"1.000001e12 0 0\n".to_vec()),
        ("lines2", b"1 1 1\n0 0 0\n".to_vec()),
        ("lines3", b"1 1 1\n0 0 0\n0 0 0\n".to_vec()),
        ("lines5", "1 1 1\n".repeat(5).into_bytes()),
        ("order31", order31.into_bytes()),
        ("binary", vec![0, 0xff, 1, 2, b'\n']),
        ("latin1", b"1 1 \xff\n".to_vec()),
        ("commas", b"1,1,1\n".to_vec()),
        ("hex", b"0x1 0 0\n".to_vec()),
        ("minus", "\u{2212}1 0 0\n".as_bytes().to_vec()),
        ("junk", b"1 1 1 x\n".to_vec()),
        ("semicolon", b"1 1 1;\n".to_vec()),
        ("line16", sixteen.into_bytes()),
        ("nanmid", b"-0 nan 1\n".to_vec()),
        ("bigfile", "# padding\n".repeat(120_000).into_bytes()),
        ("inf4", b"1 1 1\n0 0 0\n0 inf 0\n0 0 0\n".to_vec()),
    ];
    let mut sh_paths: Vec<(String, PathBuf)> = sh_files
        .into_iter()
        .map(|(name, bytes)| {
            let path = d.join(format!("{name}.sh"));
            write(&path, &bytes);
            (name.to_string(), path)
        })
        .collect();
    let dir_sh = d.join("folder.sh");
    std::fs::create_dir_all(&dir_sh).unwrap();
    sh_paths.push(("folder".into(), dir_sh));
    sh_paths.push(("missing".into(), d.join("missing.sh")));
    let zero_sh = d.join("zero.sh");
    std::os::unix::fs::symlink("/dev/zero", &zero_sh).unwrap();
    sh_paths.push(("zero".into(), zero_sh));
    let fifo_sh = d.join("fifo.sh");
    let _ = Command::new("mkfifo").arg(&fifo_sh).status();
    sh_paths.push(("fifo".into(), fifo_sh));
    for (name, path) in &sh_paths {
        let env = format!("sh:{}", path.display());
        let file = path.file_name().unwrap().to_string_lossy().into_owned();
        let o = out(&format!("study-{name}"));
        suite.add(
            k,
            &format!("study bases sh:{name}"),
            &["study", "bases", "--envs", &env, "--out", &s(&o)],
            Some(o),
            error(1, &[&file]),
        );
        let png = d.join(format!("render-{name}.png"));
        suite.add(
            k,
            &format!("render sh:{name}"),
            &[
                "render",
                "--technique",
                "preconv",
                "--env",
                &env,
                "--out",
                &s(&png),
            ],
            Some(png),
            error(1, &[&file]),
        );
    }

    // export of every technique on dx10 and dx11 with an environment that is not there:
    // a technique with no export there says why in its terms, any other names the file.
    let missing_env = s(&d.join("no-such-sky.exr"));
    for &t in Technique::all() {
        for path in [HwPath::Dx10, HwPath::Dx11] {
            let name = format!("{t}.{path}");
            let o = out(&format!("export-{name}"));
            let expect = match shvis::export::refusal(t, path) {
                None => error(1, &["no-such-sky.exr"]),
                Some(why) => error(1, &[&why.to_string()]),
            };
            suite.add(
                k,
                &format!("export {name}, missing --env"),
                &[
                    "export",
                    "--technique",
                    &t.to_string(),
                    "--path",
                    &path.to_string(),
                    "--env",
                    &missing_env,
                    "--out",
                    &s(&o),
                ],
                Some(o),
                expect,
            );
        }
    }

    // report: tables that cannot be believed, outputs that would be wrong.
    let version = shvis::report::table::TABLE_VERSION;
    let row = |extra: &str| {
        format!(
            r#"{{"table_version":{version},"device":"d","width":64,"height":32,"results":[{{"technique":"unc6","path":"dx10"{extra}}}]}}"#
        )
    };
    let tables: Vec<(&str, String, &str)> = vec![
        ("empty", String::new(), "not a bench table.json"),
        ("not-json", "table".into(), "not a bench table.json"),
        ("array", "[]".into(), "no \"results\" array"),
        (
            "no-results",
            r#"{"device":"d"}"#.into(),
            "no \"results\" array",
        ),
        (
            "results-object",
            r#"{"results":{}}"#.into(),
            "no \"results\" array",
        ),
        (
            "unversioned",
            r#"{"device":"d","width":64,"height":32,"results":[{"technique":"unc6","path":"dx10","ms_median":1}]}"#.into(),
            "without \"table_version\"",
        ),
        (
            "other-version",
            row(r#","ms_median":1"#).replacen(
                &format!(r#""table_version":{version}"#),
                &format!(r#""table_version":{}"#, version + 1),
                1,
            ),
            "run `shvis bench` again",
        ),
        (
            "row-number",
            format!(r#"{{"table_version":{version},"results":[7]}}"#),
            "is not a row",
        ),
        (
            "row-nameless",
            format!(r#"{{"table_version":{version},"results":[{{"ms_median":1}}]}}"#),
            "\"technique\" is missing",
        ),
        (
            "negative-ms",
            row(r#","ms_median":-1"#),
            "cannot be negative",
        ),
        (
            "absurd-ms",
            row(r#","ms_median":1e9"#),
            "beyond any time in ms",
        ),
        ("text-ms", row(r#","ms_median":"fast""#), "not a number"),
        (
            "negative-ratio",
            row(r#","ratio_to_preconv":-2"#),
            "cannot be negative",
        ),
        (
            "negative-error",
            row(r#","rel_rmse":-0.5"#),
            "cannot be negative",
        ),
        (
            "absurd-error",
            row(r#","rel_rmse":1e30"#),
            "beyond any relative error",
        ),
        (
            "fraction-bytes",
            row(r#","texel_bytes":0.5"#),
            "whole number",
        ),
        (
            "negative-bytes",
            row(r#","table_bytes":-8"#),
            "cannot be negative",
        ),
        (
            "overflow",
            row(r#","ms_median":1e999"#),
            "not a bench table.json",
        ),
        (
            "width",
            format!(r#"{{"table_version":{version},"width":-3,"results":[]}}"#),
            "not a frame size",
        ),
        (
            "height",
            format!(r#"{{"table_version":{version},"height":1e7,"results":[]}}"#),
            "not a frame size",
        ),
        ("paper-ms", row(r#","paper_ms":-0.1"#), "cannot be negative"),
    ];
    for (name, text, needle) in tables {
        let table = d.join(format!("{name}.json"));
        write(&table, text.as_bytes());
        let page = out(&format!("report-{name}.md"));
        suite.add(
            k,
            &format!("report {name}"),
            &["report", &s(&table), "--out", &s(&page)],
            Some(page),
            error(1, &[&format!("{name}.json"), needle]),
        );
    }
    let good = d.join("good.json");
    write(&good, row(r#","ms_median":1.5"#).as_bytes());
    let zero_table = d.join("zero.json");
    std::os::unix::fs::symlink("/dev/zero", &zero_table).unwrap();
    // The cases that aim --out at a table get tables of their own: a build that writes
    // over its input must not spoil the cases after it.
    let victims: Vec<PathBuf> = (0..2)
        .map(|i| {
            let v = d.join(format!("victim-{i}.json"));
            write(&v, row(r#","ms_median":1.5"#).as_bytes());
            v
        })
        .collect();
    let table_link = d.join("page-link.md");
    std::os::unix::fs::symlink(&victims[1], &table_link).unwrap();
    let full_page = d.join("full-page.md");
    std::os::unix::fs::symlink("/dev/full", &full_page).unwrap();
    let page = out("report-page.md");
    let refusals: Vec<(&str, Vec<String>, Vec<&str>)> = vec![
        (
            "missing table",
            vec![s(&d.join("absent.json"))],
            vec!["absent.json"],
        ),
        ("table is a folder", vec![s(&d)], vec!["surfaces"]),
        (
            "table links to /dev/zero",
            vec![s(&zero_table)],
            vec!["zero.json", "not a regular file"],
        ),
        (
            "--out is the table",
            vec![s(&victims[0]), "--out".into(), s(&victims[0])],
            vec!["--out would overwrite"],
        ),
        (
            "--out links to the table",
            vec![s(&victims[1]), "--out".into(), s(&table_link)],
            vec!["--out would overwrite"],
        ),
        (
            "--out links to /dev/full",
            vec![s(&good), "--out".into(), s(&full_page)],
            vec!["full-page.md", "No space left"],
        ),
        (
            "--out in a missing folder",
            vec![s(&good), "--out".into(), s(&d.join("no/such/page.md"))],
            vec!["page.md"],
        ),
        (
            "labels for two tables, one given",
            vec![
                s(&good),
                "--labels".into(),
                "a,b".into(),
                "--out".into(),
                s(&page),
            ],
            vec!["--labels"],
        ),
    ];
    for (name, mut args, needles) in refusals {
        if !args.iter().any(|a| a == "--out") {
            args.extend(["--out".into(), s(&page)]);
        }
        let mut all = vec!["report".to_string()];
        all.extend(args);
        let all: Vec<&str> = all.iter().map(String::as_str).collect();
        suite.add(k, &format!("report {name}"), &all, None, error(1, &needles));
    }
    // Markup in a table's texts stays text: the page keeps its columns.
    let markup = d.join("markup.json");
    write(
        &markup,
        format!(r#"{{"table_version":{version},"device":"GPU | <b>x</b>\n# y","driver":"`d`","width":8,"height":8,"results":[{{"technique":"unc6|x","path":"dx10","ms_median":1}}]}}"#).as_bytes(),
    );
    let markup_page = out("report-markup.md");
    suite.add(
        k,
        "report escapes markup",
        &[
            "report",
            &s(&markup),
            "--labels",
            "a|b",
            "--out",
            &s(&markup_page),
        ],
        Some(markup_page.clone()),
        Expect::Ok,
    );
    suite.last().check = Some(Box::new(move |_, _| {
        let md = std::fs::read_to_string(&markup_page).map_err(|e| e.to_string())?;
        for line in md.lines().filter(|l| l.starts_with('|')) {
            let cells = line.replace("\\|", "").matches('|').count();
            if cells != 7 && cells != 11 {
                return Err(format!("a table line lost its columns: {line}"));
            }
        }
        if md.contains("<b>") {
            return Err("markup copied unescaped".into());
        }
        Ok(())
    }));

    // A full standard output: one error line, exit 1 (not a panic, not 0).
    let report_page = out("report-full-stdout.md");
    let full: Vec<(&str, Vec<String>)> = vec![
        ("techniques", vec!["techniques".into()]),
        (
            "techniques --json",
            vec!["techniques".into(), "--json".into()],
        ),
        ("devices", vec!["devices".into()]),
        ("--help", vec!["--help".into()]),
        ("--version", vec!["--version".into()]),
        ("export --help", vec!["export".into(), "--help".into()]),
        ("report --help", vec!["report".into(), "--help".into()]),
        ("study --help", vec!["study".into(), "--help".into()]),
        (
            "report",
            vec!["report".into(), s(&good), "--out".into(), s(&report_page)],
        ),
    ];
    for (name, args) in full {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        suite.add(
            k,
            &format!("full stdout: {name}"),
            &args,
            None,
            error(1, &["standard output"]),
        );
        suite.last().shell = Some("exec >/dev/full;".into());
    }

    // Named sets and list options.
    let bench_out = out("bench");
    let lists: Vec<(&str, Vec<&str>, Vec<&str>)> = vec![
        (
            "set with a name",
            vec!["bench", "--techniques", "headline,l1"],
            vec!["headline is a set"],
        ),
        (
            "two sets",
            vec!["bench", "--techniques", "all,paper"],
            vec!["is a set"],
        ),
        (
            "leading comma",
            vec!["bench", "--techniques", ",shlmap"],
            vec!["entry 1 is empty"],
        ),
        (
            "double comma",
            vec!["bench", "--techniques", "shlmap,,l1"],
            vec!["entry 2 is empty"],
        ),
        (
            "trailing comma",
            vec!["bench", "--techniques", "shlmap,"],
            vec!["entry 2 is empty"],
        ),
        (
            "empty list",
            vec!["bench", "--techniques", ""],
            vec!["empty"],
        ),
        (
            "paths double comma",
            vec!["bench", "--paths", "dx10,,dx11"],
            vec!["entry 2 is empty"],
        ),
        (
            "relight set with a name",
            vec!["relight", "--techniques", "paper,unc6"],
            vec!["paper is a set"],
        ),
        (
            "unknown name",
            vec!["bench", "--techniques", "unc7x"],
            vec!["unc7x", "headline"],
        ),
    ];
    for (name, args, needles) in lists {
        let mut args = args;
        let o = s(&bench_out);
        args.extend(["--out", &o]);
        suite.add(
            k,
            &format!("list: {name}"),
            &args,
            Some(bench_out.clone()),
            error(1, &needles),
        );
    }

    for command in ["export", "render"] {
        let o = s(&bench_out);
        suite.add(
            k,
            &format!("list: {command} --technique a set"),
            &[command, "--technique", "headline", "--out", &o],
            Some(bench_out.clone()),
            error(2, &["'headline' is a set of techniques"]),
        );
    }

    // SHVIS_* variables that do not parse stop every command before any work.
    let vars: Vec<(&str, &str)> = vec![
        ("SHVIS_MEMORY_LIMIT", "abc"),
        ("SHVIS_MEMORY_LIMIT", "-1"),
        ("SHVIS_MEMORY_LIMIT", ""),
        ("SHVIS_MEMORY_LIMIT", "1e999"),
        ("SHVIS_MEMORY_LIMIT", "12 parsecs"),
        ("SHVIS_TRACE_LANES", "3"),
        ("SHVIS_TRACE_LANES", "abc"),
        ("SHVIS_TRACE_LANES", ""),
        ("SHVIS_TRACE_LANES", "32"),
    ];
    for (var, value) in vars {
        let png = d.join(format!("var-{var}-{}.png", value.len()));
        suite.add(
            k,
            &format!("{var}={value:?}"),
            &["render", "--technique", "preconv", "--out", &s(&png)],
            Some(png),
            error(1, &[var]),
        );
        suite.last().env.push((var.into(), value.into()));
    }

    // Binary glTF and EXR channels.
    let (json, bin) = scene_json(None, None);
    let mut glb = b"glTF".to_vec();
    glb.extend_from_slice(&2u32.to_le_bytes());
    let json_bytes = {
        let mut j = serde_json::to_vec(&json).unwrap();
        while j.len() % 4 != 0 {
            j.push(b' ');
        }
        j
    };
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json_bytes);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let mut magic = glb.clone();
    magic[..4].copy_from_slice(b"XXXX");
    let glbs: Vec<(&str, Vec<u8>, &str)> = vec![
        ("magic", magic, "not a binary glTF"),
        ("header", glb[..10].to_vec(), "glb"),
        ("cut", glb[..glb.len() / 2].to_vec(), "truncated .glb"),
        ("json-cut", glb[..30].to_vec(), "truncated .glb"),
    ];
    for (name, bytes, needle) in glbs {
        let path = d.join(format!("{name}.glb"));
        write(&path, &bytes);
        let png = d.join(format!("glb-{name}.png"));
        suite.add(
            k,
            &format!("glb {name}"),
            &[
                "render",
                "--technique",
                "preconv",
                "--scene",
                &s(&path),
                "--out",
                &s(&png),
            ],
            Some(png),
            error(1, &[&format!("{name}.glb"), needle]),
        );
    }
    let luminance = d.join("luminance.exr");
    {
        use exr::prelude::*;
        let channel = AnyChannel::new("Y", FlatSamples::F32(vec![1.0; 8 * 4]));
        let layer = Layer::new(
            (8, 4),
            LayerAttributes::named("lum"),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(vec![channel])),
        );
        Image::from_layer(layer)
            .write()
            .to_file(&luminance)
            .unwrap();
    }
    let lum_png = d.join("lum-env.png");
    suite.add(
        k,
        "exr without RGB as --env",
        &[
            "render",
            "--technique",
            "preconv",
            "--env",
            &s(&luminance),
            "--out",
            &s(&lum_png),
        ],
        Some(lum_png),
        error(1, &["luminance.exr", "no R, G and B"]),
    );
    let lum_png = d.join("lum-height.png");
    suite.add(
        k,
        "exr without RGB as --height-map",
        &[
            "render",
            "--technique",
            "rnmao",
            "--height-map",
            &s(&luminance),
            "--out",
            &s(&lum_png),
        ],
        Some(lum_png),
        error(1, &["luminance.exr", "no R, G and B"]),
    );

    // Export over its own inputs, directly and through a link.
    let sky = exr(&d.join("sky.exr"), 16, 8, |_, _| [1.0; 3]);
    let sky_link = d.join("sky-link");
    std::os::unix::fs::symlink(&sky, &sky_link).unwrap();
    let sh_good = d.join("good.sh");
    write(&sh_good, b"1 1 1\n");
    let height = d.join("height.png");
    write(&height, &png(8, 8));
    let scene = gltf(&d, "scene", |_| {});
    let overs: Vec<(&str, Vec<String>, PathBuf)> = vec![
        ("the env", vec!["--env".into(), s(&sky)], sky.clone()),
        (
            "a link to the env",
            vec!["--env".into(), s(&sky)],
            sky_link.clone(),
        ),
        (
            "the sh: file",
            vec!["--env".into(), format!("sh:{}", sh_good.display())],
            sh_good.clone(),
        ),
        (
            "the height map",
            vec!["--height-map".into(), s(&height)],
            height.clone(),
        ),
        (
            "the scene",
            vec!["--scene".into(), s(&scene)],
            scene.clone(),
        ),
    ];
    for (name, args, over) in overs {
        let mut all: Vec<String> = ["export", "--technique", "preconv", "--path", "dx10"]
            .map(String::from)
            .to_vec();
        all.extend(args);
        all.extend(["--out".into(), s(&over)]);
        let all: Vec<&str> = all.iter().map(String::as_str).collect();
        suite.add(
            k,
            &format!("export --out over {name}"),
            &all,
            None,
            error(1, &["--out"]),
        );
    }

    // Outputs linked to devices.
    let full_png = d.join("full.png");
    std::os::unix::fs::symlink("/dev/full", &full_png).unwrap();
    suite.add(
        k,
        "render --out links to /dev/full",
        &[
            "render",
            "--technique",
            "preconv",
            "--width",
            "32",
            "--height",
            "20",
            "--vis-res",
            "64",
            "--rays",
            "16",
            "--out",
            &s(&full_png),
        ],
        None,
        error(1, &["full.png", "No space left"]),
    );
    let full_dir = d.join("full-dir");
    std::os::unix::fs::symlink("/dev/full", &full_dir).unwrap();
    suite.add(
        k,
        "export --out links to /dev/full",
        &[
            "export",
            "--technique",
            "preconv",
            "--path",
            "dx10",
            "--out",
            &s(&full_dir),
        ],
        None,
        error(1, &["/dev/full", "--out"]),
    );

    // --sg-solve and the dx11 path's refusals.
    for value in ["", "fast", "ls,ls"] {
        let png = d.join(format!("sg-{}.png", value.len()));
        suite.add(
            k,
            &format!("--sg-solve {value:?}"),
            &[
                "render",
                "--technique",
                "sg9",
                "--sg-solve",
                value,
                "--out",
                &s(&png),
            ],
            Some(png),
            error(2, &["--sg-solve"]),
        );
    }
    let png = d.join("nmprt-dx11.png");
    suite.add(
        k,
        "render nmprt on dx11",
        &[
            "render",
            "--technique",
            "nmprt",
            "--path",
            "dx11",
            "--out",
            &s(&png),
        ],
        Some(png),
        error(1, &["nmprt", "dx11"]),
    );
    let o = out("bench-nmprt-dx11");
    suite.add(
        k,
        "bench nmprt on dx11",
        &[
            "bench",
            "--techniques",
            "nmprt",
            "--paths",
            "dx11",
            "--out",
            &s(&o),
        ],
        Some(o),
        error(1, &["nmprt", "dx11"]),
    );
    suite.add(
        k,
        "view without a display",
        &["view"],
        None,
        error(1, &["display"]),
    );
    suite.last().env.push(("DISPLAY".into(), String::new()));
    suite
        .last()
        .env
        .push(("WAYLAND_DISPLAY".into(), String::new()));
}

/// Generates the cases of `kind` in a suite of its own (its own folder) and runs them: each
/// meets its expectation (module doc), or the test fails listing every case that did not.
fn run_class(kind: Kind) {
    let started = Instant::now();
    let mut suite = Suite::new(&format!("{kind:?}"));
    kind.cases()(&mut suite);
    let total = suite.cases.len();
    assert!(total > 0, "{kind:?}: no cases");
    let strays: Vec<&str> = suite
        .cases
        .iter()
        .filter(|c| c.kind != kind)
        .map(|c| c.name.as_str())
        .collect();
    assert!(
        strays.is_empty(),
        "{kind:?} generates cases of another class: {strays:?}"
    );
    suite.run();
    println!(
        "{kind:?}: {total} cases in {:.1} s",
        started.elapsed().as_secs_f64()
    );
}

#[test]
fn arguments() {
    run_class(Kind::Arguments);
}

#[test]
fn budget() {
    run_class(Kind::Budget);
}

#[test]
fn values() {
    run_class(Kind::Values);
}

#[test]
fn env_files() {
    run_class(Kind::EnvFiles);
}

#[test]
fn scene_files() {
    run_class(Kind::SceneFiles);
}

#[test]
fn output_locations() {
    run_class(Kind::Outputs);
}

#[test]
fn bake_caches() {
    run_class(Kind::Cache);
}

#[test]
fn design_hard_cases() {
    run_class(Kind::HardCases);
}

#[test]
fn new_surfaces() {
    run_class(Kind::Surfaces);
}

/// The suite as a whole, generated and not run (the class tests run it): some two hundred
/// cases, every class with some.
#[test]
fn every_class_has_cases() {
    let mut suite = Suite::new("count");
    for kind in Kind::ALL {
        kind.cases()(&mut suite);
    }
    let mut per_class = BTreeMap::new();
    for case in &suite.cases {
        *per_class.entry(case.kind).or_insert(0usize) += 1;
    }
    let total = suite.cases.len();
    println!("{total} cases: {per_class:?}");
    let _ = std::fs::remove_dir_all(&suite.dir);
    assert!(total >= 150, "only {total} cases");
    assert_eq!(
        per_class.len(),
        Kind::ALL.len(),
        "every class has cases: {per_class:?}"
    );
}

/// `kill -9` at each of a bake's five writes (three visibility layers, AO, the cache file),
/// then a rerun: its outputs are byte-identical to an uninterrupted run's, the killed run
/// left the earlier bake in its folder whole (`bake --check` passes it), and no temporary
/// is left. The kill is a hook of the
/// `test-hooks` feature (`files::KILL_WHILE_WRITING_ENV`).
#[cfg(feature = "test-hooks")]
#[test]
fn killed_bakes_rerun_to_identical_outputs() {
    let dir = scratch_dir("shvis-kill9");
    let bake = |out: &Path, cache: &Path, kill_at: Option<&str>| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_shvis"));
        cmd.args([
            "bake",
            "--vis-res",
            "64",
            "--rays",
            "16",
            "--order",
            "3",
            "--out",
            &s(out),
        ])
        .env("SHVIS_CACHE_DIR", cache)
        .env("RUST_LOG", "off");
        if let Some(file) = kill_at {
            cmd.env(shvis::files::KILL_WHILE_WRITING_ENV, file);
        }
        cmd.output().unwrap()
    };
    let clean_out = dir.join("clean");
    let clean_cache = dir.join("clean-cache");
    let run = bake(&clean_out, &clean_cache, None);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let clean = files_of(&clean_out);
    assert_eq!(
        clean.keys().cloned().collect::<Vec<_>>(),
        [
            "ao.exr",
            "manifest.json",
            "visibility_0.exr",
            "visibility_1.exr",
            "visibility_2.exr"
        ]
    );
    let cache_name = files_of(&clean_cache).into_keys().next().unwrap();
    // An earlier, complete output of other settings (seed 1) that each killed run writes
    // over: the hard case, where new, truncated and old layers would mix.
    let old_out = dir.join("old");
    let old = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args([
            "bake",
            "--vis-res",
            "64",
            "--rays",
            "16",
            "--order",
            "3",
            "--seed",
            "1",
            "--out",
            &s(&old_out),
        ])
        .env("SHVIS_CACHE_DIR", dir.join("old-cache"))
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    assert!(
        old.status.success(),
        "{}",
        String::from_utf8_lossy(&old.stderr)
    );
    assert_ne!(
        files_of(&old_out)["visibility_0.exr"],
        clean["visibility_0.exr"]
    );
    for point in [
        "visibility_0.exr",
        "visibility_1.exr",
        "visibility_2.exr",
        "ao.exr",
        cache_name.as_str(),
    ] {
        // The killed run writes over an earlier, complete output (the hard case: old and
        // new files mixed) with its own cache.
        let out = dir.join(format!("out-{point}"));
        let cache = dir.join(format!("cache-{point}"));
        copy_dir(&old_out, &out);
        let killed = bake(&out, &cache, Some(point));
        assert_eq!(
            killed.status.code(),
            None,
            "{point}: the bake was not killed: {}",
            String::from_utf8_lossy(&killed.stderr)
        );
        // Killed at a layer or at the cache write, the folder holds the earlier complete
        // output, intact: the new one was being written beside it.
        let check = Command::new(env!("CARGO_BIN_EXE_shvis"))
            .args(["bake", "--check", "--out", &s(&out)])
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&check.stderr).into_owned()
            + &String::from_utf8_lossy(&check.stdout);
        assert!(
            check.status.success() && said.contains("\"seed\":1"),
            "{point}: {said}"
        );
        assert_eq!(
            files_of(&out),
            files_of(&old_out),
            "{point}: the earlier bake"
        );
        let rerun = bake(&out, &cache, None);
        assert!(
            rerun.status.success(),
            "{point}: {}",
            String::from_utf8_lossy(&rerun.stderr)
        );
        let got = files_of(&out);
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            clean.keys().collect::<Vec<_>>(),
            "{point}: files (temporaries left?)"
        );
        let temporaries: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp-"))
            .collect();
        assert!(
            temporaries.is_empty(),
            "{point}: the killed run's temporary folder is left: {temporaries:?}"
        );
        for (name, bytes) in &clean {
            assert!(
                &got[name] == bytes,
                "{point}: {name} differs from the uninterrupted run's"
            );
        }
        let cache_files: Vec<String> = files_of(&cache).into_keys().collect();
        assert_eq!(
            cache_files,
            std::slice::from_ref(&cache_name),
            "{point}: cache holds {cache_files:?}"
        );
        shvis::files::Manifest::verify(&out).unwrap();
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Copies the files of `from` into `to` (created), for the kill-9 test.
#[cfg(feature = "test-hooks")]
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

/// `shvis export` writes its folder as one run (`files::replace_dir`): an export killed
/// halfway through a file (`files::KILL_WHILE_WRITING_ENV`) leaves the earlier export
/// whole, file for file; the next export replaces it whole (a file only the earlier folder
/// had is gone) and removes the killed run's temporary; a folder that is not an export, or
/// one holding an input of the run, is refused.
#[cfg(feature = "test-hooks")]
#[test]
fn an_export_replaces_the_earlier_one_whole_or_not_at_all() {
    let dir = scratch_dir("shvis-export-run");
    let out = dir.join("export");
    let export = |seed: &str, env: &str, out: &Path, kill_at: Option<&str>| {
        let mut cmd = small_export("shlmap", "dx10", seed, out, &dir.join("cache"));
        cmd.args(["--env", env]);
        if let Some(file) = kill_at {
            cmd.env(shvis::files::KILL_WHILE_WRITING_ENV, file);
        }
        cmd.output().unwrap()
    };
    let first = export("0", "sky", &out, None);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    std::fs::write(out.join("only-in-the-earlier-export.txt"), "old").unwrap();
    let earlier = files_of(&out);
    let killed = export("1", "sky", &out, Some("per_texel.ktx2"));
    assert!(!killed.status.success(), "the hook kills the export");
    assert_eq!(files_of(&out), earlier, "the earlier export is left whole");
    let temporaries = |d: &Path| {
        std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
            .count()
    };
    assert_eq!(temporaries(&dir), 1, "the killed run's temporary folder");
    let next = export("1", "sky", &out, None);
    assert!(
        next.status.success(),
        "{}",
        String::from_utf8_lossy(&next.stderr)
    );
    let replaced = files_of(&out);
    assert!(!replaced.contains_key("only-in-the-earlier-export.txt"));
    assert_ne!(replaced["per_texel.ktx2"], earlier["per_texel.ktx2"]);
    assert_eq!(temporaries(&dir), 0, "the stale temporary is removed");

    let other = dir.join("notes");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "mine").unwrap();
    let refused = export("0", "sky", &other, None);
    assert_eq!(refused.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("not an earlier run's"));
    assert_eq!(std::fs::read(other.join("notes.txt")).unwrap(), b"mine");

    let env = out.join("probe.exr");
    let mut probe = shvis::env::EnvMap::from_fn(8, 4, |_| [1.0; 3]);
    probe.texels[0] = [2.0; 3];
    probe.save_exr(&env).unwrap();
    let refused = export("0", &s(&env), &out, None);
    assert_eq!(refused.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--env input"));
    assert!(env.exists(), "the input survives");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Twenty exports killed with SIGKILL at random points over an export's run, each over an
/// earlier export of other settings: every time the folder holds one whole export, the
/// earlier one or the new one, file for file, and its manifest names every file beside it.
#[cfg(feature = "test-hooks")]
#[test]
fn exports_killed_at_any_point_leave_one_whole_export() {
    let dir = scratch_dir("shvis-export-kill");
    let command = |seed: &str, out: &Path| {
        let mut cmd = small_export("zh3", "dx11", seed, out, &dir.join("cache"));
        cmd.stdout(Stdio::null()).stderr(Stdio::null());
        cmd
    };
    let run = |seed: &str, out: &Path| {
        assert!(command(seed, out).status().unwrap().success());
        files_of(out)
    };
    // Both settings baked once (and cached), so every export below is the same work.
    let earlier = run("0", &dir.join("earlier"));
    let new = run("1", &dir.join("new"));
    assert_ne!(earlier, new);
    // How long an export takes once its bake is cached: the kills spread over it.
    let started = Instant::now();
    assert_eq!(
        run("1", &dir.join("new")),
        new,
        "a second export is identical"
    );
    let span = started.elapsed();
    let out = dir.join("export");
    let mut outcomes = BTreeMap::new();
    // Kill points drawn at random over the export's run (and a little past it), from a seed
    // printed on failure; SHVIS_KILL_SEED repeats a run.
    let seed: u64 = std::env::var("SHVIS_KILL_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_nanos() as u64
        });
    let mut state = seed | 1;
    let mut uniform = move || {
        // xorshift64*: a uniform number in [0, 1).
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    };
    for k in 0..20u32 {
        if !out.exists() || files_of(&out) != earlier {
            let _ = std::fs::remove_dir_all(&out);
            run("0", &out);
        }
        let mut child = command("1", &out).spawn().unwrap();
        let at = span.mul_f64(1.1 * uniform());
        std::thread::sleep(at);
        let _ = child.kill();
        let _ = child.wait();
        let found = files_of(&out);
        let which = if found == earlier {
            "earlier"
        } else if found == new {
            "new"
        } else {
            panic!(
                "kill {k} at {at:?} (SHVIS_KILL_SEED={seed}): the folder mixes exports: {:?}",
                found.keys().collect::<Vec<_>>()
            )
        };
        *outcomes.entry(which).or_insert(0) += 1;
        let manifest: Value = serde_json::from_slice(&found["manifest.json"]).unwrap();
        for name in found.keys().filter(|n| *n != "manifest.json") {
            assert!(
                manifest.to_string().contains(name.as_str()),
                "kill {k} at {at:?} (SHVIS_KILL_SEED={seed}): {name}"
            );
        }
    }
    assert_eq!(outcomes.values().sum::<u32>(), 20, "{outcomes:?}");
    eprintln!("20 kills over a {span:?} export (SHVIS_KILL_SEED={seed}): {outcomes:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A full standard output never panics: each command whose stdout is `/dev/full` exits
/// non-zero with one `error:` line on stderr that names standard output (`--help` and
/// `--version` too, which are not a success there); with stderr full as well it still exits
/// 1, not with a panic's or an abort's status. An export's files, written before its lines,
/// stay whole.
#[test]
fn a_full_standard_output_is_an_error_not_a_panic() {
    let dir = scratch_dir("shvis-full-stdout");
    let export_out = dir.join("export");
    let cache = dir.join("cache");
    let export_args: Vec<String> = small_export("hb4", "dx10", "0", &export_out, &cache)
        .get_args()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    let commands: Vec<Vec<String>> = vec![
        strings(&["techniques"]),
        strings(&["techniques", "--json"]),
        strings(&["devices"]),
        strings(&["--help"]),
        strings(&["--version"]),
        strings(&["export", "--help"]),
        strings(&["report", "--help"]),
        export_args,
    ];
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    for args in &commands {
        let run = Command::new(env!("CARGO_BIN_EXE_shvis"))
            .args(args)
            .stdout(full())
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        let errors: Vec<&str> = stderr.lines().filter(|l| l.contains("error")).collect();
        assert_eq!(run.status.code(), Some(1), "{args:?}: {stderr}");
        assert_eq!(errors.len(), 1, "{args:?}: {stderr}");
        assert!(
            errors[0].starts_with("error:") && errors[0].contains("standard output"),
            "{args:?}: {stderr}"
        );
        assert!(!stderr.contains("internal error"), "{args:?}: {stderr}");

        let silent = Command::new(env!("CARGO_BIN_EXE_shvis"))
            .args(args)
            .stdout(full())
            .stderr(full())
            .status()
            .unwrap();
        assert_eq!(silent.code(), Some(1), "{args:?} with stderr full too");
    }
    let manifest: Value =
        serde_json::from_slice(&std::fs::read(export_out.join("manifest.json")).unwrap()).unwrap();
    for (name, _) in files_of(&export_out) {
        assert!(
            name == "manifest.json" || manifest.to_string().contains(&name),
            "{name}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `cmd`, which must fail with status 1, and returns its `error:` line and its stdout
/// (`what` labels the failures).
fn error_line(cmd: &mut Command, what: &str) -> (String, String) {
    let run = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{what}: {stderr}");
    let line = stderr
        .lines()
        .find(|l| l.starts_with("error:"))
        .unwrap_or_else(|| panic!("{what}: no error line in {stderr}"));
    (
        line.to_string(),
        String::from_utf8_lossy(&run.stdout).into_owned(),
    )
}

/// Errors that name the cause: a named set mixed with names is explained (a set is given
/// alone), an empty entry of a list option is named by its place, an unknown technique's
/// error lists the sets beside the names, and a `SHVIS_*` variable that does not parse stops
/// the command instead of being ignored.
#[test]
fn sets_empty_entries_and_unparsable_variables_say_why() {
    let out = scratch_dir("shvis-lists").join("out");
    let out = out.to_string_lossy().into_owned();
    let cases: Vec<(Vec<&str>, Vec<(&str, &str)>, Vec<&str>)> = vec![
        (
            vec!["bench", "--techniques", "headline,l1", "--out", &out],
            vec![],
            vec!["headline is a set", "given alone"],
        ),
        (
            vec!["bench", "--techniques", "shlmap,,l1", "--out", &out],
            vec![],
            vec!["entry 2 is empty"],
        ),
        (
            vec!["bench", "--techniques", "shlmap,", "--out", &out],
            vec![],
            vec!["entry 2 is empty"],
        ),
        (
            vec!["bench", "--paths", "dx10,,dx11", "--out", &out],
            vec![],
            vec!["'dx10,,dx11'", "entry 2 is empty"],
        ),
        (
            vec!["bench", "--techniques", "shlmapx", "--out", &out],
            vec![],
            vec![
                "unknown technique 'shlmapx'",
                "or a set, given alone: all, paper, headline",
            ],
        ),
        (
            vec!["techniques"],
            vec![("SHVIS_TRACE_LANES", "abc")],
            vec!["SHVIS_TRACE_LANES=\"abc\"", "4, 8, 16"],
        ),
        (
            vec!["techniques"],
            vec![("SHVIS_MEMORY_LIMIT", "lots")],
            vec!["SHVIS_MEMORY_LIMIT=\"lots\"", "512M"],
        ),
    ];
    for (args, env, needles) in cases {
        let (line, _) = error_line(
            Command::new(env!("CARGO_BIN_EXE_shvis"))
                .args(&args)
                .envs(env.iter().copied()),
            &format!("{args:?} {env:?}"),
        );
        for needle in needles {
            assert!(line.contains(needle), "{args:?} {env:?}: {line}");
        }
        assert!(
            !std::path::Path::new(&out).exists(),
            "{args:?}: no work before the error"
        );
    }
    let fine = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .arg("techniques")
        .envs([("SHVIS_TRACE_LANES", "16"), ("SHVIS_MEMORY_LIMIT", "8G")])
        .output()
        .unwrap();
    assert!(fine.status.success());
}

/// An OpenEXR file without R, G and B channels (a luminance-only `Y` image) says so, as an
/// environment and as a height map, naming the channels it has.
#[test]
fn an_exr_without_rgb_says_so() {
    use exr::prelude::*;
    let dir = scratch_dir("shvis-exr-no-rgb");
    let path = dir.join("luminance.exr");
    let channel = AnyChannel::new("Y", FlatSamples::F32(vec![0.5f32; 8 * 4]));
    let layer = Layer::new(
        (8, 4),
        LayerAttributes::named("luminance"),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![channel])),
    );
    Image::from_layer(layer).write().to_file(&path).unwrap();
    let out = dir.join("out.png");
    for args in [
        vec![
            "render",
            "--technique",
            "preconv",
            "--env",
            s(&path).as_str(),
            "--out",
            s(&out).as_str(),
        ],
        vec![
            "render",
            "--technique",
            "rnmao",
            "--height-map",
            s(&path).as_str(),
            "--out",
            s(&out).as_str(),
        ],
    ] {
        let (line, _) = error_line(
            Command::new(env!("CARGO_BIN_EXE_shvis")).args(&args),
            &format!("{args:?}"),
        );
        assert!(
            line.contains("luminance.exr")
                && line.contains("no R, G and B channels")
                && line.contains("Y"),
            "{args:?}: {line}"
        );
        assert!(!out.exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `study normalmap --model` reads the model before its timings: a missing or broken model
/// fails at once, naming `--model`, with no output folder made.
#[test]
fn study_normalmap_checks_its_model_first() {
    let dir = scratch_dir("shvis-normalmap-model");
    let broken = dir.join("broken.gltf");
    write(&broken, b"{ not json");
    for model in [dir.join("missing.gltf"), broken] {
        let out = dir.join("out");
        let (line, stdout) = error_line(
            Command::new(env!("CARGO_BIN_EXE_shvis"))
                .args(["study", "normalmap", "--model"])
                .arg(&model)
                .arg("--out")
                .arg(&out),
            &format!("{model:?}"),
        );
        assert!(
            line.contains("--model") && line.contains(&*model.to_string_lossy()),
            "{line}"
        );
        assert!(
            !out.exists(),
            "{model:?}: no output folder before the model is read"
        );
        assert!(
            !stdout.contains("timings on"),
            "no timing before the model is read: {stdout}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `report` never writes its page over one of its tables: `--out` naming a table, or a
/// link to one, is refused before anything is read or written, and the table is unchanged.
#[test]
fn report_never_writes_over_its_tables() {
    let dir = scratch_dir("shvis-report-over-input");
    let table = dir.join("table.json");
    write(&table, b"{\"stands for\": \"a bench table\"}");
    let link = dir.join("page.md");
    std::os::unix::fs::symlink(&table, &link).unwrap();
    for out in [&table, &link] {
        let (line, _) = error_line(
            Command::new(env!("CARGO_BIN_EXE_shvis"))
                .arg("report")
                .arg(&table)
                .arg("--out")
                .arg(out),
            &format!("{out:?}"),
        );
        assert!(
            line.contains("--out would overwrite the table input"),
            "{line}"
        );
        assert_eq!(
            std::fs::read(&table).unwrap(),
            b"{\"stands for\": \"a bench table\"}",
            "{out:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An output that is a link to a character device is written into as `cp` would (an error
/// on `/dev/full`, the bytes gone into `/dev/null`), never replaced by a file; a link to a
/// regular file is written through and stays a link (before: the link was replaced by the
/// page, exit 0).
#[test]
fn outputs_linked_to_devices_are_written_through_as_cp_does() {
    let dir = scratch_dir("shvis-output-links");
    let table = dir.join("table.json");
    write(
        &table,
        format!(
            r#"{{"table_version":{},"device":"d","width":8,"height":8,"results":[{{"technique":"preconv","path":"dx10","ms_median":1.0}}]}}"#,
            shvis::report::table::TABLE_VERSION
        )
        .as_bytes(),
    );
    let page = dir.join("page.md");
    write(&page, b"earlier");
    let links = [
        ("full.md", Path::new("/dev/full")),
        ("null.md", Path::new("/dev/null")),
        ("file.md", page.as_path()),
    ];
    for (name, target) in links {
        std::os::unix::fs::symlink(target, dir.join(name)).unwrap();
    }
    let report = |out: &Path| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_shvis"));
        cmd.arg("report").arg(&table).arg("--out").arg(out);
        cmd
    };
    let (line, _) = error_line(&mut report(&dir.join("full.md")), "full.md");
    assert!(
        line.contains("full.md: cannot write: No space left on device"),
        "{line}"
    );
    for name in ["null.md", "file.md"] {
        let out = report(&dir.join(name)).output().unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    for (name, _) in links {
        let m = std::fs::symlink_metadata(dir.join(name)).unwrap();
        assert!(m.file_type().is_symlink(), "{name} was replaced");
    }
    let written = std::fs::read_to_string(&page).unwrap();
    assert!(written.starts_with("# Cost table"), "{written}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An `sh:` file whose coefficients overflow the arithmetic is one clear error naming the
/// file and the line, whichever command reads it (before: render and export said "the SH
/// lightmap is not finite (non-finite lighting?)" or clipped most of the frame with a
/// warning, and export wrote the files).
#[test]
fn sh_files_beyond_the_radiance_limit_are_refused_by_every_command() {
    let dir = scratch_dir("shvis-sh-overflow");
    let file = dir.join("overflow.sh");
    write(&file, b"3e38 3e38 3e38\n1e30 0 0\n0 0 0\n0 0 0\n");
    let env = format!("sh:{}", file.display());
    let out = dir.join("out");
    let o = s(&out);
    let commands: Vec<Vec<&str>> = vec![
        vec![
            "render",
            "--technique",
            "shlmap",
            "--env",
            &env,
            "--out",
            "PNG",
        ],
        vec![
            "export",
            "--technique",
            "shlmap",
            "--path",
            "dx10",
            "--env",
            &env,
            "--out",
            &o,
        ],
        vec![
            "bench",
            "--techniques",
            "shlmap",
            "--paths",
            "dx10",
            "--env",
            &env,
            "--out",
            &o,
        ],
        vec!["study", "bases", "--envs", &env, "--out", &o],
        vec![
            "relight",
            "--techniques",
            "unc6",
            "--fade-to",
            &env,
            "--out",
            &o,
        ],
    ];
    let png = s(&dir.join("r.png"));
    for args in commands {
        let args: Vec<&str> = args
            .iter()
            .map(|a| if *a == "PNG" { png.as_str() } else { a })
            .collect();
        let (line, _) = error_line(
            Command::new(env!("CARGO_BIN_EXE_shvis")).args(&args),
            &format!("{args:?}"),
        );
        assert!(
            line.contains("overflow.sh")
                && line.contains("line 1: 3e38 is beyond the radiance limit"),
            "{args:?}: {line}"
        );
        // bench and study check that --out takes files before any work: empty is allowed.
        let written: Vec<_> = std::fs::read_dir(&out)
            .map(|d| d.map(|e| e.unwrap().file_name()).collect())
            .unwrap_or_default();
        assert!(written.is_empty(), "{args:?}: wrote {written:?}");
        assert!(!dir.join("r.png").exists(), "{args:?}: wrote r.png");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A probe forced to be read as angular (`angular:`) whose light lies partly outside the
/// disk warns, naming the file and the share dropped, as the unforced read refuses it.
#[test]
fn a_forced_angular_probe_with_light_outside_its_disk_warns() {
    let dir = scratch_dir("shvis-angular-outside");
    // A 16 × 16 map: dim inside the disk, bright in the corners outside it.
    let probe = exr(&dir.join("corners.exr"), 16, 16, |x, y| {
        let (u, v) = ((x as f32 + 0.5) / 8.0 - 1.0, (y as f32 + 0.5) / 8.0 - 1.0);
        if u * u + v * v > 1.0 {
            [5.0; 3]
        } else {
            [0.5; 3]
        }
    });
    let env = format!("angular:{}", probe.display());
    let run = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(["sh", "project", "--order", "2", "--env", &env])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.lines().any(|l| l.contains("WARN")
            && l.contains("corners.exr")
            && l.contains("outside the probe's disk and is dropped")),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Lighting too bright for the f16 target says so in relight as render and bench do: a
/// cross-fade to an `sh:` file of 1e10 warns with the clipped pixels, which relight.json
/// records (before: errors of 1.0 in the table and no word).
#[test]
fn a_relight_too_bright_for_its_target_warns() {
    let dir = scratch_dir("shvis-relight-bright");
    let file = dir.join("bright.sh");
    write(&file, b"1e10 1e10 1e10\n5e9 0 0\n0 0 0\n0 0 0\n");
    let out = dir.join("out");
    let run = Command::new(env!("CARGO_BIN_EXE_shvis"))
        .args(["relight", "--techniques", "preconv", "--paths", "dx10"])
        .args([
            "--frames",
            "4",
            "--every",
            "2",
            "--error-frames",
            "1",
            "--ref-spp",
            "2",
        ])
        .args([
            "--width",
            "64",
            "--height",
            "40",
            "--vis-res",
            "64",
            "--rays",
            "32",
        ])
        .arg("--fade-to")
        .arg(format!("sh:{}", file.display()))
        .arg("--out")
        .arg(&out)
        .env("SHVIS_CACHE_DIR", dir.join("cache"))
        .env("RUST_LOG", "warn")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.lines().any(|l| l.contains("WARN")
            && l.contains("preconv.dx10")
            && l.contains("pixels clipped at the f16 target's 65504")),
        "{stderr}"
    );
    let table: Value =
        serde_json::from_slice(&std::fs::read(out.join("relight.json")).unwrap()).unwrap();
    assert!(
        table["results"][0]["clipped_pixels"].as_u64().unwrap() > 0,
        "{table}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `study rnm` checks its scene before any environment's bake and blames `--scene` (before:
/// "--env sky:15: scene 'house' would need ≈ … triangles", after the bake).
#[test]
fn study_rnm_blames_the_scene_not_the_environment() {
    let dir = scratch_dir("shvis-study-rnm-scene");
    let missing = s(&dir.join("missing.gltf"));
    for (scene, says) in [
        ("house", "--scene house: scene 'house' would need"),
        ("cornell", "--scene cornell: unknown scene 'cornell'"),
        (missing.as_str(), "missing.gltf: cannot read"),
    ] {
        let (line, _) = error_line(
            Command::new(env!("CARGO_BIN_EXE_shvis"))
                .args(["study", "rnm", "--scene", scene, "--out"])
                .arg(dir.join("out"))
                .env("SHVIS_CACHE_DIR", dir.join("cache")),
            scene,
        );
        assert!(
            line.contains(says) && !line.contains("--env"),
            "{scene}: {line}"
        );
        assert!(
            !dir.join("cache").exists(),
            "{scene}: baked before the check"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
