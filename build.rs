//! Four jobs: the link fix for Debian's shaderc (see README "Set-up"), the registry of
//! embedded GLSL sources (`embed_glsl_sources`), the commit `shvis --version` names, and a
//! hash of the bake's sources that the SH lightmap cache keys on (`embed_bake_source_hash`).
//!
//! Debian's `libshaderc.so` is under-linked and its `libshaderc_combined.a` does not contain
//! glslang or SPIRV-Tools, so shaderc-sys (feature `prefer-static-linking`, with
//! `SHADERC_LIB_DIR` from `.cargo/config.toml`) links the archive and this script adds
//! glslang's static libraries in one link group so their mutual references resolve.

fn main() {
    link_shaderc();
    embed_glsl_sources();
    embed_git_commit();
    embed_bake_source_hash();
}

/// Sets `SHVIS_BAKE_SOURCE_HASH`: FNV-1a (64-bit) over the paths and contents of every file
/// under `src/bake`, `src/sh` and `src/env`, so a cached bake from other bake code is never
/// believed (the keys of `bake::cache`).
fn embed_bake_source_hash() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    let mut dirs: Vec<_> = ["bake", "sh", "env"].iter().map(|d| root.join(d)).collect();
    while let Some(dir) = dirs.pop() {
        println!("cargo:rerun-if-changed={}", dir.display());
        for entry in std::fs::read_dir(&dir).expect("src/ is readable") {
            let path = entry.expect("src/ entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else {
                files.push(path);
            }
        }
    }
    files.sort();
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for path in &files {
        println!("cargo:rerun-if-changed={}", path.display());
        let rel = path
            .strip_prefix(&root)
            .expect("under src/")
            .to_string_lossy()
            .into_owned();
        let bytes = std::fs::read(path).expect("a source file");
        for &b in rel.as_bytes().iter().chain(&[0]).chain(&bytes) {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    println!("cargo:rustc-env=SHVIS_BAKE_SOURCE_HASH={hash:016x}");
}

/// Sets `SHVIS_GIT_COMMIT` (the checkout's commit; "unknown" outside git) for
/// `shvis --version`.
fn embed_git_commit() {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let commit = git(&["rev-parse", "--short=12", "HEAD"]).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=SHVIS_GIT_COMMIT={commit}");
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        println!("cargo:rerun-if-changed={dir}/HEAD");
        if let Some(head) = git(&["symbolic-ref", "-q", "HEAD"]) {
            println!("cargo:rerun-if-changed={dir}/{head}");
        }
    }
}

/// Writes `$OUT_DIR/glsl_sources.rs`: every file under `glsl/` as `(path under glsl/,
/// include_str!(…))`, sorted, so `gpu::shader` embeds the shaders without naming any (each
/// technique names its own, `technique::fragment_shader`).
fn embed_glsl_sources() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("glsl");
    println!("cargo:rerun-if-changed={}", root.display());
    let mut files = Vec::new();
    let mut dirs = vec![root.clone()];
    while let Some(dir) = dirs.pop() {
        println!("cargo:rerun-if-changed={}", dir.display());
        for entry in std::fs::read_dir(&dir).expect("glsl/ is readable") {
            let path = entry.expect("glsl/ entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if matches!(
                path.extension().and_then(|e| e.to_str()),
                Some("glsl" | "vert" | "frag" | "comp")
            ) {
                files.push(path);
            }
        }
    }
    files.sort();
    let mut out = String::from("&[\n");
    for path in &files {
        let rel = path.strip_prefix(&root).expect("under glsl/");
        let rel = rel.to_str().expect("UTF-8 shader path").replace('\\', "/");
        out += &format!(
            "    ({rel:?}, include_str!({:?})),\n",
            path.display().to_string()
        );
    }
    out += "]\n";
    let dest =
        std::path::Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("glsl_sources.rs");
    std::fs::write(dest, out).expect("OUT_DIR is writable");
}

fn link_shaderc() {
    let dir = std::env::var("SHADERC_LIB_DIR")
        .unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu".to_string());
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-search=native={dir}");
    let libs = [
        "shaderc_combined",
        "glslang",
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "SPIRV",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
    ];
    let mut group = vec!["-Wl,--start-group".to_string()];
    group.extend(libs.iter().map(|l| format!("-l:lib{l}.a")));
    group.push("-Wl,--end-group".to_string());
    group.push("-lstdc++".to_string());
    group.push("-lpthread".to_string());
    for arg in group {
        println!("cargo:rustc-link-arg={arg}");
    }
}
