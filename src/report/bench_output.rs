//! The files of a bench run (`shvis bench --out DIR`): the probe's page, the references, a
//! PNG + EXR per row with its difference image, the error ladder's rungs and sheets, the
//! paper's figures, the plots, `table.md`, `table.json` and `index.html`.
//!
//! The bench hands each product here as it is made — a row's image as soon as it is drawn,
//! so a run at 1280×800 never holds more than one row's frames — and this module writes it,
//! once (a rung shared by rows is written by the first). Figures and plots that cannot be
//! drawn (no font) are warnings, not a failed bench; images and the table are errors.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::figures::{DIFFERENCE_SCALE, difference, write_figures, write_ladder_sheet};
use super::image::{write_exr, write_exr_half, write_png};
use super::plot::{CostAxis, write_error_plot, write_pca_error_plot};
use super::table::BenchTable;
use super::{LADDER_DIR, ReportError};
use crate::probe::Probe;
use crate::render::Frame;
use crate::technique::{HwPath, Technique};

/// Whether `name` is a file a bench writes beside its tables: an image (`.exr`, `.png`) or
/// a plot (`.svg`). A run removes the earlier run's, with its [`LADDER_DIR`], before it
/// writes its own, so the folder's page shows one run.
pub fn is_bench_image(name: &str) -> bool {
    [".exr", ".png", ".svg"]
        .iter()
        .any(|ext| name.ends_with(ext))
}

/// Where a bench's files go, and which ladder rungs are written already.
pub struct BenchOutput {
    dir: PathBuf,
    /// Exposure in EV of the PNG images.
    exposure: f32,
    rungs_written: HashSet<String>,
}

impl BenchOutput {
    /// Files into `dir` (which exists), PNGs at `exposure` EV.
    pub fn new(dir: &Path, exposure: f32) -> BenchOutput {
        BenchOutput {
            dir: dir.to_path_buf(),
            exposure,
            rungs_written: HashSet::new(),
        }
    }

    /// `probe.md` and `probe.json`.
    pub fn probe(&self, probe: &Probe) -> Result<(), ReportError> {
        super::write_probe(probe, &self.dir).map(drop)
    }

    /// `{name}.png` and `{name}.exr`.
    pub fn images(&self, name: &str, frame: &Frame) -> Result<(), ReportError> {
        write_exr(&self.dir.join(format!("{name}.exr")), frame)?;
        write_png(&self.dir.join(format!("{name}.png")), frame, self.exposure)
    }

    /// A row's image `{label}.{png,exr}` and, against its reference, the difference image
    /// `{label}.diff{DIFFERENCE_SCALE}.png`.
    pub fn row(
        &self,
        label: &str,
        frame: &Frame,
        reference: Option<&Frame>,
    ) -> Result<(), ReportError> {
        self.images(label, frame)?;
        if let Some(r) = reference {
            let diff = difference(frame, r, DIFFERENCE_SCALE);
            let name = format!("{label}.diff{DIFFERENCE_SCALE}.png");
            write_png(&self.dir.join(name), &diff, self.exposure)?;
        }
        Ok(())
    }

    /// Creates the ladder's folder, before its first rung.
    pub fn ladder_folder(&self) -> Result<(), ReportError> {
        let dir = self.dir.join(LADDER_DIR);
        std::fs::create_dir_all(&dir).map_err(|e| ReportError::Write {
            path: dir,
            detail: e.to_string(),
        })
    }

    /// A ladder rung `ladder/{stem}.{exr,png}` (EXR in half floats), unless written already;
    /// returns its path relative to the output folder.
    pub fn rung(&mut self, stem: &str, frame: &Frame) -> Result<String, ReportError> {
        if self.rungs_written.insert(stem.to_string()) {
            let dir = self.dir.join(LADDER_DIR);
            write_exr_half(&dir.join(format!("{stem}.exr")), frame)?;
            write_png(&dir.join(format!("{stem}.png")), frame, self.exposure)?;
        }
        Ok(format!("{LADDER_DIR}/{stem}.exr"))
    }

    /// A row's ladder sheet `ladder/{technique}.{path}.sheet.png`: its images side by side,
    /// each named.
    pub fn ladder_sheet(&self, technique: Technique, path: HwPath, sheet: &[(String, &Frame)]) {
        let dir = self.dir.join(LADDER_DIR);
        let file = dir.join(format!("{technique}.{path}.sheet.png"));
        let written = std::fs::create_dir_all(&dir)
            .map_err(|e| format!("{}: cannot create: {e}", dir.display()))
            .and_then(|()| {
                write_ladder_sheet(&file, sheet, self.exposure).map_err(|e| e.to_string())
            });
        match written {
            Ok(()) => log::info!("wrote {}", file.display()),
            Err(e) => log::warn!("{e}"),
        }
    }

    /// The paper's figures on `path` from the rows' images (`image`) and the reference.
    pub fn figures<'a>(
        &self,
        path: HwPath,
        reference: Option<&Frame>,
        image: &dyn Fn(Technique) -> Option<&'a Frame>,
    ) {
        log_written(write_figures(
            &self.dir,
            path,
            reference,
            image,
            self.exposure,
        ));
    }

    /// The PCA plot per path and the speed/error and storage/error plots.
    pub fn plots(&self, table: &BenchTable, paths: &[HwPath]) {
        for &path in paths {
            log_written(write_pca_error_plot(&table.results, path, &self.dir));
        }
        log_written(write_error_plot(table, &self.dir, CostAxis::Time));
        log_written(write_error_plot(table, &self.dir, CostAxis::Storage));
    }

    /// `table.md`, `table.json` and `index.html`; returns the page's path.
    pub fn table(&self, table: &BenchTable) -> Result<PathBuf, ReportError> {
        table.write(&self.dir)?;
        super::html::write_index(table, &self.dir)
    }
}

/// Logs the files written, or the reason none were as a warning.
fn log_written(result: Result<Vec<PathBuf>, ReportError>) {
    match result {
        Ok(files) => files
            .iter()
            .for_each(|f| log::info!("wrote {}", f.display())),
        Err(e) => log::warn!("{e}"),
    }
}
