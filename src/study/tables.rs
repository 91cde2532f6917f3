//! `shvis study compression` and `shvis study seams` as calls: each measures, writes its
//! table as markdown and JSON into an output directory and returns the markdown.

use std::path::Path;
use std::sync::Arc;

use crate::bake::BakeError;
use crate::gpu::Context;
use crate::prepare::Prepared;
use crate::technique::{HwPath, Technique, TechniqueError};

use super::report::{self, StudyReport};
use super::{compression, seams};

/// Errors of the table studies.
#[derive(Debug, thiserror::Error)]
pub enum TableStudyError {
    /// Writing one of the files failed; `name` is its file name.
    #[error("{name}")]
    Write {
        name: String,
        source: std::io::Error,
    },
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    #[error(transparent)]
    Bake(#[from] BakeError),
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    /// A technique the study cannot measure; the message says why.
    #[error("{0}")]
    Invalid(String),
}

/// Writes `markdown` as `dir/{stem}.md` and `rows` as `dir/{stem}.json` (pretty, with a
/// final newline) through [`report::write`].
fn write_md_json(
    dir: &Path,
    stem: &'static str,
    markdown: &str,
    rows: &impl serde::Serialize,
) -> Result<(), TableStudyError> {
    let study_report = StudyReport {
        stem,
        markdown: markdown.to_string(),
        json: Some(serde_json::to_string_pretty(rows)? + "\n"),
    };
    report::write(dir, &study_report).map_err(|e| TableStudyError::Write {
        name: e
            .path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        source: e.source,
    })?;
    Ok(())
}

/// The visibility error against storage of every default configuration fitted to
/// `prepared`'s bake (`table_res`: the L×H tables' side, in the storage), written as
/// compression.md and compression.json.
pub fn compression_tables(
    prepared: &Prepared,
    table_res: u32,
    seed: u64,
    dir: &Path,
) -> Result<String, TableStudyError> {
    let rows = compression::run(
        &prepared.visibility,
        &compression::default_configs(),
        table_res,
        seed,
        Some(&prepared.cache_dir),
    )?;
    let markdown = compression::to_markdown(&rows, prepared.visibility.res, table_res);
    write_md_json(dir, "compression", &markdown, &rows)?;
    Ok(markdown)
}

/// The on-screen errors of `techniques` against unc6 (their data prepared in `prepared`)
/// on each path, written as screen.md and screen.json; `env` names the environment.
pub fn compression_screen(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    techniques: &[Technique],
    paths: &[HwPath],
    env: &str,
    (width, height): (u32, u32),
    dir: &Path,
) -> Result<String, TableStudyError> {
    let screen = compression::screen_errors(ctx, prepared, techniques, paths, width, height)?;
    let markdown = compression::screen_markdown(&screen, env, width, height);
    write_md_json(dir, "screen", &markdown, &screen)?;
    Ok(markdown)
}

/// Refuses techniques without clusters (the seams study measures vqK and cpcaK_M).
pub fn check_clustered(techniques: &[Technique]) -> Result<(), TableStudyError> {
    match techniques.iter().find(|t| t.needs().clusters.is_none()) {
        Some(t) => Err(TableStudyError::Invalid(format!(
            "{t} is not a clustered technique (vqK, cpcaK_M)"
        ))),
        None => Ok(()),
    }
}

/// The seam discontinuity of each clustered technique (prepared in `prepared`) on each
/// path, with and without seam blending, written as seams.md and seams.json.
pub fn seams_table(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    techniques: &[Technique],
    paths: &[HwPath],
    (width, height): (u32, u32),
    dir: &Path,
) -> Result<String, TableStudyError> {
    let mut rows = Vec::new();
    for &technique in techniques {
        for &path in paths {
            rows.extend(seams::measure(
                ctx, prepared, technique, path, width, height,
            )?);
        }
    }
    let markdown = seams::to_markdown(&rows, width, height);
    write_md_json(dir, "seams", &markdown, &rows)?;
    Ok(markdown)
}
