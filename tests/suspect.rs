//! A bench row whose image cannot be right is marked suspect with its reason in table.md
//! and table.json, and `bench --strict` exits non-zero on it (`report::metrics::
//! suspect_reason`). The absurd row is planted: `SHVIS_PLANT_ABSURD_ROW=ssbump.dx9` scales
//! that row's image ×100 before it is measured, a hook of the `test-hooks` feature (this
//! file needs it: Cargo.toml's `required-features`).

use std::path::PathBuf;
use std::process::Command;

/// The settings at which the radiosity-normal-mapping rows once came out absurd on their
/// own (a 128² lightmap of 256 rays on the built-in house: `tests/rnm.rs`), with ssbump's
/// image planted ×100: that row is marked, the others are not, and --strict fails on it.
#[test]
fn absurd_rows_are_marked_and_strict_fails() {
    let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("suspect");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let out = root.join("bench");
    let run = |strict: bool| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_shvis"));
        cmd.args([
            "bench",
            "--techniques",
            "rnm,ssbump,preconv",
            "--paths",
            "dx9",
            "--width",
            "320",
            "--height",
            "200",
            "--vis-res",
            "128",
            "--rays",
            "256",
            "--ref-spp",
            "32",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--no-probe",
            "--out",
        ])
        .arg(&out)
        .env("SHVIS_CACHE_DIR", root.join("cache"))
        .env(shvis::bench::rows::PLANT_ABSURD_ROW_ENV, "ssbump.dx9")
        .env("RUST_LOG", "warn");
        if strict {
            cmd.arg("--strict");
        }
        cmd.output().expect("shvis runs")
    };
    let strict = run(true);
    let stderr = String::from_utf8_lossy(&strict.stderr);
    assert!(!strict.status.success(), "--strict passed:\n{stderr}");
    let last = stderr.lines().last().unwrap_or("");
    assert!(
        last.starts_with("error: ") && last.contains("suspect row") && last.contains("ssbump.dx9"),
        "{stderr}"
    );
    let table: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("table.json")).unwrap()).unwrap();
    let suspect = |name: &str| {
        table["results"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["technique"] == name)
            .map(|r| r["suspect"].as_str().unwrap_or("").to_string())
            .unwrap()
    };
    assert!(suspect("ssbump").contains("relative RMSE"), "{table}");
    assert_eq!(suspect("preconv"), "", "a plausible row is not marked");
    assert_eq!(suspect("rnm"), "", "rnm is plausible at these settings");
    let markdown = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(markdown.contains("ssbump (⚠ suspect:"), "{markdown}");
    // Without --strict the same run succeeds, the rows marked all the same.
    assert!(run(false).status.success());
}
