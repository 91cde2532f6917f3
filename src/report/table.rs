//! The cost table of `shvis bench`: printed, `table.md` and `table.json` (DESIGN §4, whose
//! field names the JSON keeps). Error columns are `null` until a reference exists.

use std::path::Path;

use serde::Serialize;

use super::ReportError;

/// One technique × path row.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchRow {
    pub technique: String,
    pub path: String,
    pub ms_median: Option<f64>,
    pub ms_min: Option<f64>,
    pub ms_max: Option<f64>,
    pub frames: usize,
    pub rel_rmse: Option<f64>,
    pub psnr: Option<f64>,
    pub texel_bytes: u64,
    pub table_bytes: u64,
    pub textures_bound: u32,
    pub lookups_per_pixel: u32,
}

/// The whole table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchTable {
    pub device: String,
    pub width: u32,
    pub height: u32,
    pub vis_res: u32,
    /// Samples per pixel of the reference the errors are measured against (0: none).
    pub reference_spp: u32,
    /// The reference's own relative noise (compare with `rel_rmse`).
    pub reference_rel_noise: Option<f64>,
    pub results: Vec<BenchRow>,
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "—".to_string(), |v| format!("{v:.digits$}"))
}

impl BenchTable {
    /// Markdown table (also what the terminal shows).
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "device: {} · {}×{} · visibility {}² · reference {} spp (relative noise {})\n\n",
            self.device,
            self.width,
            self.height,
            self.vis_res,
            self.reference_spp,
            opt(self.reference_rel_noise, 4)
        );
        s += "| technique | path | ms median | ms min | ms max | frames | rel. RMSE | PSNR dB | texel bytes | table bytes | textures | lookups/px |\n";
        s += "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for r in &self.results {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.technique,
                r.path,
                opt(r.ms_median, 3),
                opt(r.ms_min, 3),
                opt(r.ms_max, 3),
                r.frames,
                opt(r.rel_rmse, 4),
                opt(r.psnr, 2),
                r.texel_bytes,
                r.table_bytes,
                r.textures_bound,
                r.lookups_per_pixel
            );
        }
        s
    }

    /// Writes `table.md` and `table.json` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<(), ReportError> {
        let err = |path: &Path, e: &dyn std::fmt::Display| ReportError::Write {
            path: path.to_path_buf(),
            detail: e.to_string(),
        };
        let md = dir.join("table.md");
        std::fs::write(&md, self.to_markdown()).map_err(|e| err(&md, &e))?;
        let json_path = dir.join("table.json");
        let json = serde_json::to_string_pretty(self).map_err(|e| err(&json_path, &e))?;
        std::fs::write(&json_path, json + "\n").map_err(|e| err(&json_path, &e))?;
        Ok(())
    }
}
