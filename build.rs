//! Link fix for Debian's shaderc (see README "Set-up").
//!
//! Debian's `libshaderc.so` is under-linked and its `libshaderc_combined.a` does not contain
//! glslang or SPIRV-Tools, so shaderc-sys (feature `prefer-static-linking`, with
//! `SHADERC_LIB_DIR` from `.cargo/config.toml`) links the archive and this script adds
//! glslang's static libraries in one link group so their mutual references resolve.

fn main() {
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
