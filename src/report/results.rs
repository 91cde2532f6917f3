//! Results pages (`shvis report`): one or more benches' `table.json`, side by side per
//! technique and path — ms and ×preconv of each, beside the paper's GeForce GTX 295 column
//! (DESIGN §3) — as markdown for `docs/results/`, generated, never typed.
//!
//! A table is read as JSON values, not as [`super::table::BenchTable`]: what a table lacks is
//! left blank. Its `table_version` must be [`TABLE_VERSION`], the layout this build reads
//! (another is refused with what to do: run the bench again). What it holds is checked
//! before it is believed: every time, ratio, error and size the page
//! could copy must be a finite number within physical bounds ([`NUMBER_FIELDS`]), and every
//! text the page copies (labels, device, driver, technique and path names, file names) is
//! escaped, so a table cannot break the page's markdown.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::table::TABLE_VERSION;

/// One bench's table, read from its `table.json`.
#[derive(Clone, Debug)]
pub struct ResultTable {
    /// What the page calls it (a column group's heading).
    pub label: String,
    pub path: PathBuf,
    pub device: String,
    pub driver: String,
    pub width: u64,
    pub height: u64,
    rows: Vec<Value>,
}

/// Errors of reading a table.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    #[error(transparent)]
    Read(#[from] crate::files::FileError),
    #[error("{}: not a bench table.json: {detail}", .path.display())]
    Format { path: PathBuf, detail: String },
    /// A bench table of another layout than [`TABLE_VERSION`].
    #[error(
        "{}: a bench table {found}; this build reads table_version {} only: run `shvis bench` again to write it",
        .path.display(),
        TABLE_VERSION
    )]
    Version { path: PathBuf, found: String },
}

impl ResultTable {
    /// Reads `path` (a bench's `table.json`); `label` defaults to "device W×H".
    pub fn read(path: &Path, label: Option<&str>) -> Result<ResultTable, ResultsError> {
        let text = crate::files::read_bounded(path, MAX_TABLE_BYTES, "bench table")?;
        let format = |detail: &str| ResultsError::Format {
            path: path.to_path_buf(),
            detail: detail.to_string(),
        };
        let json: Value = serde_json::from_slice(&text).map_err(|e| format(&e.to_string()))?;
        let rows = json
            .get("results")
            .and_then(Value::as_array)
            .ok_or_else(|| format("no \"results\" array"))?
            .clone();
        let found = match json.get("table_version") {
            None => Some("without \"table_version\"".to_string()),
            Some(v) => match v.as_u64() {
                Some(n) if n == u64::from(TABLE_VERSION) => None,
                Some(n) => Some(format!("of table_version {n}")),
                None => Some("whose \"table_version\" is not a version number".to_string()),
            },
        };
        if let Some(found) = found {
            return Err(ResultsError::Version {
                path: path.to_path_buf(),
                found,
            });
        }
        let field = |k: &str| {
            json.get(k)
                .and_then(Value::as_str)
                .unwrap_or("")
                .to_string()
        };
        let size = |k: &str| match json.get(k) {
            None | Some(Value::Null) => Ok(0),
            Some(v) => v
                .as_u64()
                .filter(|n| (1..=MAX_FRAME_SIDE).contains(n))
                .ok_or_else(|| {
                    format(&format!(
                        "\"{k}\" is {v}, not a frame size in pixels (1 to {MAX_FRAME_SIDE})"
                    ))
                }),
        };
        let (device, width, height) = (field("device"), size("width")?, size("height")?);
        let mut seen = std::collections::HashSet::new();
        for (i, row) in rows.iter().enumerate() {
            check_row(row).map_err(|detail| {
                let text = |k: &str| row.get(k).and_then(Value::as_str).unwrap_or("?");
                format(&format!(
                    "results[{i}] ({} on {}): {detail}",
                    text("technique"),
                    text("path")
                ))
            })?;
            let key = ["technique", "path", "specular"].map(|k| row.get(k).cloned());
            if !seen.insert(format!("{key:?}")) {
                let text = |k: &str| row.get(k).and_then(Value::as_str).unwrap_or("?");
                return Err(format(&format!(
                    "results[{i}] ({} on {}): the table has this row twice",
                    text("technique"),
                    text("path")
                )));
            }
        }
        // A bench writes all three: a table without them is another file or a fragment.
        for (key, missing) in [
            ("device", device.is_empty()),
            ("width", width == 0),
            ("height", height == 0),
        ] {
            if missing {
                return Err(format(&format!("\"{key}\" is missing")));
            }
        }
        if rows.is_empty() {
            return Err(format("its \"results\" array has no row"));
        }
        Ok(ResultTable {
            label: label.map_or_else(|| format!("{device} {width}×{height}"), str::to_string),
            path: path.to_path_buf(),
            driver: field("driver"),
            device,
            width,
            height,
            rows,
        })
    }

    /// Its rows without a specular term by (technique, path): the rows of the comparison.
    fn rows_by_key(&self) -> RowIndex<'_> {
        let mut index = RowIndex::default();
        for row in self
            .rows
            .iter()
            .filter(|r| r.get("specular").is_none_or(Value::is_null))
        {
            let text = |k: &str| row.get(k).and_then(Value::as_str).unwrap_or("").to_string();
            index
                .entry((text("technique"), text("path")))
                .or_insert(row);
        }
        index
    }
}

/// A table's rows by (technique, path).
type RowIndex<'a> = std::collections::HashMap<(String, String), &'a Value>;

/// Largest `table.json` read (a bench's is tens of KiB).
const MAX_TABLE_BYTES: u64 = 64 << 20;

/// Largest frame side a table may claim (Vulkan's guaranteed image limits are far below).
const MAX_FRAME_SIDE: u64 = 1 << 16;

/// What a number of a row measures, and so what it may hold.
#[derive(Clone, Copy, Debug)]
enum Measure {
    /// Milliseconds of a frame: under a quarter of an hour.
    Milliseconds,
    /// A ratio of two frame times.
    Ratio,
    /// A relative error (RMSE over the truth's RMS).
    RelativeError,
    /// Bytes of a technique's data: whole, under a tebibyte.
    Bytes,
}

impl Measure {
    fn name(self) -> &'static str {
        match self {
            Measure::Milliseconds => "time in ms",
            Measure::Ratio => "ratio of times",
            Measure::RelativeError => "relative error",
            Measure::Bytes => "size in bytes",
        }
    }

    fn largest(self) -> f64 {
        match self {
            Measure::Milliseconds => 1e6,
            Measure::Ratio => 1e6,
            Measure::RelativeError => 1e3,
            Measure::Bytes => (1u64 << 40) as f64,
        }
    }
}

/// Every row field the page copies or a reader compares, with what it measures.
const NUMBER_FIELDS: [(&str, Measure); 12] = [
    ("ms_median", Measure::Milliseconds),
    ("ms_min", Measure::Milliseconds),
    ("ms_max", Measure::Milliseconds),
    ("paper_ms", Measure::Milliseconds),
    ("model_ms", Measure::Milliseconds),
    ("x_model", Measure::Ratio),
    ("ratio_to_preconv", Measure::Ratio),
    ("paper_ratio_to_preconv", Measure::Ratio),
    ("rel_rmse", Measure::RelativeError),
    ("rel_rmse_bounced", Measure::RelativeError),
    ("texel_bytes", Measure::Bytes),
    ("table_bytes", Measure::Bytes),
];

/// Why `row` cannot be believed, if it cannot: a row is an object naming its technique and
/// path, and each of its [`NUMBER_FIELDS`] is absent, null, or a number its measure allows.
fn check_row(row: &Value) -> Result<(), String> {
    let Some(object) = row.as_object() else {
        return Err(format!("{row} is not a row (a JSON object)"));
    };
    for key in ["technique", "path"] {
        if !object.get(key).is_some_and(Value::is_string) {
            return Err(format!("\"{key}\" is missing or not text"));
        }
    }
    for (key, measure) in NUMBER_FIELDS {
        let value = match object.get(key) {
            None | Some(Value::Null) => continue,
            Some(v) => v,
        };
        let Some(x) = value.as_f64() else {
            return Err(format!("\"{key}\" is {value}, not a number"));
        };
        let largest = measure.largest();
        if x < 0.0 {
            return Err(format!(
                "\"{key}\" is {value}: a {} cannot be negative",
                measure.name()
            ));
        }
        if x > largest {
            return Err(format!(
                "\"{key}\" is {value}: beyond any {} a bench measures (at most {largest:e})",
                measure.name()
            ));
        }
        if matches!(measure, Measure::Bytes) && value.as_u64().is_none() {
            return Err(format!("\"{key}\" is {value}: bytes are a whole number"));
        }
    }
    // What every measured row holds, and holds in order.
    let number = |k: &str| object.get(k).and_then(Value::as_f64);
    let Some(median) = number("ms_median") else {
        return Err("\"ms_median\" is missing: not a measured row".into());
    };
    if let Some(frames) = object.get("frames").filter(|v| !v.is_null())
        && frames.as_u64().is_none_or(|n| n == 0)
    {
        return Err(format!(
            "\"frames\" is {frames}, not a count of frames (1 or more)"
        ));
    }
    if let (Some(min), Some(max)) = (number("ms_min"), number("ms_max"))
        && !(min <= median && median <= max)
    {
        return Err(format!(
            "\"ms_min\" {min}, \"ms_median\" {median} and \"ms_max\" {max} are not in order"
        ));
    }
    Ok(())
}

/// `text` as markdown table text that shows as it is: markup characters are escaped, line
/// breaks and other control characters become spaces, and `|` cannot end a cell.
pub fn markdown_text(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '\\' | '`' | '*' | '_' | '[' | ']' | '|' | '#' | '!' | '~' => {
                out.push('\\');
                out.push(c);
            }
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// The comparison page of `tables` (markdown), made on `date`.
pub fn comparison_page(tables: &[ResultTable], date: &str) -> String {
    let mut md = String::from("# Cost table on real devices\n\n");
    let _ = writeln!(
        md,
        "Generated by `shvis report` on {date} from each bench's `table.json`; the paper's \
         column is Iwanicki & Sloan's GeForce GTX 295 at 1280×800 (DESIGN §3). ms: the median \
         frame's GPU time; ×preconv: the row's median over `preconv`'s on the same path; \
         ×model: measured over the device cost model's time (docs/reading-results.md; — where \
         the bench ran without the probe). rel. RMSE: against the row's own reference (the \
         reference column: the paper's visibility techniques light directly and are measured \
         against the direct-light reference, the lightmap bases store inter-reflected light \
         and are measured against the bounced one); rel. RMSE, bounced: every row against the \
         same inter-reflected reference, the one truth for comparing any two rows.\n"
    );
    md.push_str("| table | device | driver | frame | rows | file |\n|---|---|---|---|---|---|\n");
    for t in tables {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {}×{} | {} | {} |",
            markdown_text(&t.label),
            markdown_text(&t.device),
            if t.driver.is_empty() {
                "—".to_string()
            } else {
                markdown_text(&t.driver)
            },
            t.width,
            t.height,
            t.rows.len(),
            markdown_text(&t.path.display().to_string())
        );
    }
    md.push_str("\n| technique | path | reference | paper ms | paper ×preconv |");
    for t in tables {
        let _ = write!(
            md,
            " {label} ms | {label} ×preconv | {label} ×model | {label} rel. RMSE | {label} rel. RMSE, bounced |",
            label = markdown_text(&t.label)
        );
    }
    md.push_str("\n|---|---|---|---|---|");
    md.push_str(&"---|---|---|---|---|".repeat(tables.len()));
    md.push('\n');
    let indexes: Vec<RowIndex<'_>> = tables.iter().map(ResultTable::rows_by_key).collect();
    for key in row_keys(tables) {
        let rows: Vec<Option<&Value>> = indexes.iter().map(|i| i.get(&key).copied()).collect();
        let (technique, path) = key;
        let first = rows.iter().find_map(|r| *r);
        let number = |row: Option<&Value>, key: &str, digits: usize| {
            row.and_then(|r| r.get(key))
                .and_then(Value::as_f64)
                .map_or_else(|| "—".to_string(), |v| format!("{v:.digits$}"))
        };
        let _ = write!(
            md,
            "| {} | {} | {} | {} | {} |",
            markdown_text(&technique),
            markdown_text(&path),
            reference_of(&rows),
            number(first, "paper_ms", 3),
            number(first, "paper_ratio_to_preconv", 2)
        );
        for &row in &rows {
            let _ = write!(
                md,
                " {} | {} | {} | {} | {} |",
                number(row, "ms_median", 3),
                number(row, "ratio_to_preconv", 2),
                number(row, "x_model", 2),
                number(row, "rel_rmse", 4),
                number(row, "rel_rmse_bounced", 4)
            );
        }
        md.push('\n');
    }
    md
}

/// What a row's `rel_rmse` is measured against in the tables that measured it ("direct",
/// "2 bounces"), each distinct value once, "—" where none did.
fn reference_of(rows: &[Option<&Value>]) -> String {
    let mut seen: Vec<&str> = Vec::new();
    for row in rows.iter().flatten() {
        if let Some(r) = row.get("reference").and_then(Value::as_str)
            && r != "none"
            && !seen.contains(&r)
        {
            seen.push(r);
        }
    }
    if seen.is_empty() {
        return "—".to_string();
    }
    markdown_text(&seen.join(" / "))
}

/// Every (technique, path) of the tables, in the first table's order, then the others'.
fn row_keys(tables: &[ResultTable]) -> Vec<(String, String)> {
    let mut keys: Vec<(String, String)> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for row in tables.iter().flat_map(|t| &t.rows) {
        if !row.get("specular").is_none_or(Value::is_null) {
            continue;
        }
        let text = |k: &str| row.get(k).and_then(Value::as_str).unwrap_or("").to_string();
        let key = (text("technique"), text("path"));
        if seen.insert(key.clone()) {
            keys.push(key);
        }
    }
    keys
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(label: &str, rows: Value) -> ResultTable {
        ResultTable {
            label: label.into(),
            path: PathBuf::from(format!("{label}/table.json")),
            device: "dev".into(),
            driver: String::new(),
            width: 1280,
            height: 800,
            rows: rows.as_array().unwrap().clone(),
        }
    }

    #[test]
    fn rows_of_every_table_stand_side_by_side_with_the_papers() {
        let a = table(
            "gpu",
            serde_json::json!([
                {"technique": "preconv", "path": "dx9", "ms_median": 0.05, "ratio_to_preconv": 1.0,
                 "paper_ms": 0.648, "paper_ratio_to_preconv": 1.0, "rel_rmse": 0.1,
                 "reference": "direct"},
                {"technique": "unc6", "path": "dx9", "ms_median": 0.6, "ratio_to_preconv": 12.0,
                 "paper_ms": 8.19, "paper_ratio_to_preconv": 12.64, "rel_rmse": 0.02,
                 "x_model": 1.034, "reference": "direct", "rel_rmse_bounced": 0.03},
                {"technique": "unc6", "path": "dx9", "specular": "mip", "ms_median": 9.0}
            ]),
        );
        let b = table(
            "cpu",
            serde_json::json!([
                {"technique": "unc6", "path": "dx9", "ms_median": 40.0, "ratio_to_preconv": 4.5,
                 "reference": "2 bounces"},
                {"technique": "preconv", "path": "dx9", "ms_median": 9.0, "reference": "none"}
            ]),
        );
        let md = comparison_page(&[a, b], "2026-12-04");
        assert!(
            md.contains(
                "| unc6 | dx9 | direct / 2 bounces | 8.190 | 12.64 | 0.600 | 12.00 | 1.03 | 0.0200 | 0.0300 | 40.000 | 4.50 | — | — | — |"
            ),
            "{md}"
        );
        assert!(
            md.contains(
                "| preconv | dx9 | direct | 0.648 | 1.00 | 0.050 | 1.00 | — | 0.1000 | — | 9.000 | — | — | — | — |"
            ),
            "{md}"
        );
        // The specular row is not a row of the comparison.
        assert_eq!(md.matches("| unc6 | dx9 |").count(), 1, "{md}");
    }

    /// Reads `json` as a table file of its own.
    fn read_file(name: &str, json: &str) -> Result<ResultTable, ResultsError> {
        let dir = std::env::temp_dir().join(format!("shvis-results-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, json).unwrap();
        ResultTable::read(&path, None)
    }

    /// [`read_file`] of the object `json` with this build's `table_version` put first.
    fn read_text(name: &str, json: &str) -> Result<ResultTable, ResultsError> {
        let versioned = json.replacen('{', &format!("{{\"table_version\":{TABLE_VERSION},"), 1);
        read_file(name, &versioned)
    }

    #[test]
    fn tables_of_another_version_are_refused_saying_what_to_do() {
        let rest = r#""device":"d","width":64,"height":32,"results":[{"technique":"unc6","path":"dx10","ms_median":1.0}]}"#;
        let next = TABLE_VERSION + 1;
        for (name, head, says) in [
            (
                "unversioned",
                "{".to_string(),
                "without \"table_version\"".to_string(),
            ),
            (
                "next",
                format!("{{\"table_version\":{next},"),
                format!("of table_version {next}"),
            ),
            (
                "text",
                format!("{{\"table_version\":\"{TABLE_VERSION}\","),
                "is not a version number".to_string(),
            ),
        ] {
            let e = read_file(name, &format!("{head}{rest}"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(&format!("{name}.json: a bench table ")), "{e}");
            assert!(e.contains(&says), "{name}: {e}");
            assert!(
                e.contains(&format!("reads table_version {TABLE_VERSION} only"))
                    && e.contains("run `shvis bench` again"),
                "{e}"
            );
        }
        assert!(read_text("current", &format!("{{{rest}")).is_ok());
    }

    /// The tables the results pages in docs/results/ are made from read as this build's.
    #[test]
    fn the_committed_results_tables_read() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/results");
        let mut read = 0;
        for entry in std::fs::read_dir(&dir).expect("docs/results") {
            let path = entry.unwrap().path();
            if path.to_string_lossy().ends_with(".table.json") {
                let table = ResultTable::read(&path, None).unwrap_or_else(|e| panic!("{e}"));
                assert!(!table.rows.is_empty(), "{}", path.display());
                read += 1;
            }
        }
        assert!(read > 0, "no table in {}", dir.display());
    }

    #[test]
    fn tables_with_impossible_numbers_are_refused_naming_the_row_and_field() {
        let row = |extra: &str| {
            format!(
                r#"{{"device":"d","width":64,"height":32,"results":[
                {{"technique":"preconv","path":"dx9","ms_median":0.5}},
                {{"technique":"unc6","path":"dx10",{extra}}}]}}"#
            )
        };
        for (name, extra, says) in [
            (
                "negative",
                r#""ms_median":-1"#,
                "\"ms_median\" is -1: a time in ms cannot be negative",
            ),
            (
                "absurd",
                r#""ms_median":1e9"#,
                "beyond any time in ms a bench measures",
            ),
            (
                "error",
                r#""rel_rmse":-0.1"#,
                "a relative error cannot be negative",
            ),
            (
                "text",
                r#""ratio_to_preconv":"fast""#,
                "\"ratio_to_preconv\" is \"fast\", not a number",
            ),
            ("bytes", r#""texel_bytes":1.5"#, "bytes are a whole number"),
            ("huge", r#""table_bytes":1e300"#, "beyond any size in bytes"),
        ] {
            let e = read_text(name, &row(extra)).unwrap_err().to_string();
            assert!(
                e.contains(&format!(
                    "{name}.json: not a bench table.json: results[1] (unc6 on dx10): "
                )),
                "{e}"
            );
            assert!(e.contains(says), "{name}: {e}");
        }
        let e = read_text("nan", &row(r#""ms_median":1e999"#))
            .unwrap_err()
            .to_string();
        assert!(e.contains("nan.json: not a bench table.json"), "{e}");
        let e = read_text("size", r#"{"width":-3,"results":[]}"#)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("\"width\" is -3, not a frame size in pixels"),
            "{e}"
        );
        let e = read_text("nameless", r#"{"results":[{"ms_median":1}]}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"technique\" is missing or not text"), "{e}");
        assert!(read_text("fine", &row(r#""ms_median":0.7,"rel_rmse":null"#)).is_ok());
    }

    #[test]
    fn tables_that_are_not_a_whole_bench_are_refused() {
        let table = |head: &str, rows: &str| format!(r#"{{{head}"results":[{rows}]}}"#);
        let head = r#""device":"d","width":64,"height":32,"#;
        let row = r#"{"technique":"unc6","path":"dx10","ms_median":1.0}"#;
        for (name, text, says) in [
            (
                "no-device",
                table(r#""width":64,"height":32,"#, row),
                "\"device\" is missing",
            ),
            (
                "no-width",
                table(r#""device":"d","height":32,"#, row),
                "\"width\" is missing",
            ),
            ("no-rows", table(head, ""), "has no row"),
            (
                "unmeasured",
                table(head, r#"{"technique":"unc6","path":"dx10"}"#),
                "\"ms_median\" is missing",
            ),
            (
                "twice",
                table(head, &format!("{row},{row}")),
                "results[1] (unc6 on dx10): the table has this row twice",
            ),
            (
                "no-frames",
                table(
                    head,
                    r#"{"technique":"unc6","path":"dx10","ms_median":1,"frames":0}"#,
                ),
                "\"frames\" is 0",
            ),
            (
                "disorder",
                table(
                    head,
                    r#"{"technique":"unc6","path":"dx10","ms_median":1.6,"ms_min":1000,"ms_max":2000}"#,
                ),
                "are not in order",
            ),
        ] {
            let e = read_text(name, &text).unwrap_err().to_string();
            assert!(e.contains(says), "{name}: {e}");
        }
        assert!(read_text("whole", &table(head, row)).is_ok());
    }

    #[test]
    fn text_copied_from_tables_cannot_break_the_page() {
        let mut t = table(
            "a|b\n# c",
            serde_json::json!([
                {"technique": "unc6<script>", "path": "dx9|x", "ms_median": 1.0}
            ]),
        );
        t.device = "GPU `x` *bold* [link](y)".into();
        let md = comparison_page(&[t], "2026-12-06");
        let header = md.lines().find(|l| l.starts_with("| a")).unwrap();
        assert_eq!(
            header,
            "| a\\|b \\# c | GPU \\`x\\` \\*bold\\* \\[link\\](y) | — | 1280×800 | 1 | a\\|b \\# c/table.json |"
        );
        assert!(md.contains("| unc6&lt;script&gt; | dx9\\|x | — |"), "{md}");
        // Every table line keeps its number of cells.
        for line in md.lines().filter(|l| l.starts_with('|')) {
            let cells = line.replace("\\|", "").matches('|').count();
            assert!(cells == 7 || cells == 11, "{line}");
        }
    }
}
