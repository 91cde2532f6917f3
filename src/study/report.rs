//! A study's report: its markdown summary and its data as JSON, side by side as
//! `<stem>.md` and `<stem>.json` in the study's output folder.
//!
//! Every study hands its pair to [`write`] as a [`StudyReport`], and [`write`] puts each
//! file in place with the atomic [`crate::files::write`]. The study makes both texts
//! itself (the JSON as it formats it, e.g. pretty with or without a final newline), so
//! the bytes on disk are exactly the study's; a study whose report is its markdown alone
//! leaves the JSON out. Figures, plots, CSV and the other files a study produces are
//! its own to write.

use std::path::{Path, PathBuf};

use crate::report::ReportError;

/// One study's report files.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StudyReport {
    /// File stem: `"bases"` → `bases.md`, `bases.json`.
    pub stem: &'static str,
    /// The markdown summary, written as `<stem>.md`.
    pub markdown: String,
    /// The data as JSON text, written as `<stem>.json`; `None` when the report is its
    /// markdown alone.
    pub json: Option<String>,
}

/// Writing one file of a report failed.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot write", .path.display())]
pub struct StudyReportError {
    /// The file that could not be written.
    pub path: PathBuf,
    /// The I/O error.
    pub source: std::io::Error,
}

/// Writes `report` into `dir` (which must exist): `<stem>.md`, then `<stem>.json` when it
/// has JSON, each atomically. Returns the paths written, in that order.
///
/// # Errors
/// [`StudyReportError`] naming the first file that could not be written (the ones before
/// it are in place).
pub fn write(dir: &Path, report: &StudyReport) -> Result<Vec<PathBuf>, StudyReportError> {
    let mut files = vec![("md", &report.markdown)];
    if let Some(json) = &report.json {
        files.push(("json", json));
    }
    let mut written = Vec::new();
    for (ext, text) in files {
        let path = dir.join(format!("{}.{ext}", report.stem));
        crate::files::write(&path, text).map_err(|source| StudyReportError {
            path: path.clone(),
            source,
        })?;
        written.push(path);
    }
    Ok(written)
}

/// `value` as pretty JSON (no final newline) for the `<stem>.json` of a report in `dir`;
/// a failure is a [`ReportError`] naming that file.
pub fn pretty_json(
    dir: &Path,
    stem: &str,
    value: &impl serde::Serialize,
) -> Result<String, ReportError> {
    serde_json::to_string_pretty(value).map_err(|e| ReportError::Write {
        path: dir.join(format!("{stem}.json")),
        detail: e.to_string(),
    })
}

/// The reports of the studies whose errors are [`ReportError`]s: the same message a
/// [`crate::report::write_text`] failure gives.
impl From<StudyReportError> for ReportError {
    fn from(e: StudyReportError) -> ReportError {
        ReportError::Write {
            path: e.path,
            detail: e.source.to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_the_markdown_then_the_json_as_given() {
        let dir = std::env::temp_dir().join(format!("shvis-study-report-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp folder");
        let report = StudyReport {
            stem: "demo",
            markdown: "# Demo\n".to_string(),
            json: Some("{\n  \"a\": 1\n}\n".to_string()),
        };
        let written = write(&dir, &report).expect("temp folder is writable");
        assert_eq!(written, [dir.join("demo.md"), dir.join("demo.json")]);
        let read = |name: &str| std::fs::read_to_string(dir.join(name)).expect(name);
        assert_eq!(read("demo.md"), report.markdown);
        assert_eq!(Some(read("demo.json")), report.json);

        let markdown_only = StudyReport {
            stem: "alone",
            markdown: "text".to_string(),
            json: None,
        };
        let written = write(&dir, &markdown_only).expect("temp folder is writable");
        assert_eq!(written, [dir.join("alone.md")]);
        assert!(!dir.join("alone.json").exists());

        let missing = dir.join("missing");
        let err = write(&missing, &report).expect_err("no such folder");
        assert_eq!(err.path, missing.join("demo.md"));
        let detail = err.source.to_string();
        assert_eq!(
            ReportError::from(err).to_string(),
            format!(
                "{}: cannot write: {detail}",
                missing.join("demo.md").display()
            )
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
