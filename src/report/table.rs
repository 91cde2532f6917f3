//! The cost table of `shvis bench`: printed, `table.md` and `table.json` (DESIGN §4, whose
//! field names the JSON keeps). Error columns are `null` until a reference exists.

use std::path::Path;

use serde::Serialize;

use super::ReportError;
use crate::technique::{HwPath, Technique};

/// What a row's error is measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowReference {
    /// No reference was rendered.
    None,
    /// The direct-light reference.
    Direct,
    /// The reference with this many bounces of inter-reflection.
    Bounced(u32),
}

impl std::fmt::Display for RowReference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RowReference::None => f.write_str("none"),
            RowReference::Direct => f.write_str("direct"),
            RowReference::Bounced(n) => write!(f, "{n} bounces"),
        }
    }
}

impl Serialize for RowReference {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A rung of the error attribution ladder (`crate::attribution`): what the step from the
/// previous image to this one stops idealising.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttributionKind {
    /// Footprint reference → point-sampled reference: the error of sampling the pixel at
    /// its centre with MIP-filtered material textures.
    PixelFootprint,
    /// Exact visibility → its SH projection (order O, the bake's rays) at the pixel.
    VisibilityOrder,
    /// Exact visibility → the pixel's ambient occlusion (`preconv`).
    AmbientOcclusion,
    /// Order-O visibility → mean + M principal vectors (`pca*`).
    PcaCompression,
    /// Order-O visibility → its best cluster's mean + M vectors (`vqK`, `cpcaK_M`).
    ClusterCompression,
    /// Exact lighting → its SH to the technique's order (O + 2; 3 for `sh2`).
    LightingOrder,
    /// Exact clamped cosine → its SH to the H order (the paper's 3).
    CosineOrder,
    /// `sh2`: the L·V product and the clamped cosine truncated to order 3 (its shader's
    /// math).
    ProductOrder,
    /// `preconv`: irradiance truncated to order 3.
    IrradianceOrder,
    /// `shlmap`: incident radiance with inter-reflection → its order-3 SH at the pixel,
    /// gathered as the bake gathers a texel (the bake's rays, the environment's SH,
    /// bounced light from the lightmap).
    RadianceOrder,
    /// The engine bases: order-3 radiance → what the basis stores, evaluated linearly
    /// (L1 for the L1 family; ZH3, luminance L1, deringed L2 as themselves); the H-basis:
    /// the pixel's irradiance projected through its own frame, at its tangent-space normal.
    Basis,
    /// The tangent-frame bases fitted from samples (`--basis-fit samples`): incident
    /// radiance with inter-reflection → the basis fitted from the pixel's radiance samples
    /// (the bake's rays traced from the pixel), at its tangent-space normal.
    SampledBasis,
    /// The non-linear L1 reconstructions (Geomerics, hallucinated ZH3) against the linear
    /// one of the same data.
    Reconstruction,
    /// Exact L×H (or PCA T_k) → the table: parameterization, resolution, bilinear, f16.
    NormalTable,
    /// Per-pixel data → the lightmap's texels: resolution, bilinear filtering (clustered:
    /// the 4-tap blend or the filtered weights), storage (f16, or 8-bit weights).
    LightmapTexels,
    /// `dx11`: the lightmap's values → what its blocks decode to (BC7 ratios to a BC6H
    /// norm, or BC4; `technique::block`), decoded on the CPU by an independent decoder.
    BlockCompression,
    /// The last CPU rung → the technique's GPU image (f32 arithmetic, filter weights,
    /// the f16 target).
    Gpu,
    /// Point-sampled reference → the technique's GPU image in one step, for a technique
    /// without CPU rungs (`shlmap` when its lightmap was not baked).
    Technique,
}

impl AttributionKind {
    pub fn name(self) -> &'static str {
        match self {
            AttributionKind::PixelFootprint => "pixel footprint → point sampling",
            AttributionKind::VisibilityOrder => "visibility → SH order",
            AttributionKind::AmbientOcclusion => "visibility → AO",
            AttributionKind::PcaCompression => "PCA compression",
            AttributionKind::ClusterCompression => "VQ/CPCA compression",
            AttributionKind::LightingOrder => "lighting → SH order",
            AttributionKind::CosineOrder => "clamped cosine → H order",
            AttributionKind::ProductOrder => "L·V product → order 3",
            AttributionKind::IrradianceOrder => "irradiance → order 3",
            AttributionKind::RadianceOrder => "incident radiance → order-3 SH",
            AttributionKind::Basis => "order-3 SH → stored basis",
            AttributionKind::SampledBasis => "incident radiance → stored basis",
            AttributionKind::Reconstruction => "linear → non-linear reconstruction",
            AttributionKind::NormalTable => "normal table",
            AttributionKind::LightmapTexels => "lightmap texels",
            AttributionKind::BlockCompression => "block compression",
            AttributionKind::Gpu => "CPU → GPU",
            AttributionKind::Technique => "point sampling → technique",
        }
    }
}

impl Serialize for AttributionKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// One rung: the relative RMSE between its two images.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AttributionStep {
    pub step: AttributionKind,
    pub rel_rmse: Option<f64>,
    /// The image this step arrives at, relative to the bench's output folder (the ladder
    /// starts at `reference.exr`, or `reference_bounces{N}.exr` for `shlmap`).
    pub image: String,
}

/// One technique × path row.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchRow {
    pub technique: Technique,
    pub path: HwPath,
    /// The specular term's normal-map filtering, for a row with one (`--specular`).
    pub specular: Option<crate::render::specular::NormalFilter>,
    /// Per-pixel operation counts by kind (`crate::probe`), and the share of the screen
    /// shaded: with the probe, the device lanes kept busy per screen pixel (fragments,
    /// overdraw included, and the idle lanes of partly covered SIMD batches;
    /// `SceneGpu::shading_load` over the row's mesh); else the covered pixels' share.
    pub cost: crate::cost::CostCounts,
    /// The straight-line work of its branches where no lane takes them
    /// (`technique::cost::ShaderCosts::untaken`).
    pub untaken_cost: crate::cost::CostCounts,
    pub coverage: f64,
    /// What a frame of the row's own mesh shades (`pcaMv`), for the probe's columns.
    #[serde(skip)]
    pub own_mesh_load: Option<crate::render::ShadingLoad>,
    /// Triangles one frame draws.
    pub triangles: u32,
    /// Their edges on the screen, pixels (with the probe; `render::ShadingLoad`).
    pub edge_pixels: f64,
    /// The device cost model's frame time for the row (`shvis bench` runs the probe first),
    /// and the measured median over it.
    pub model_ms: Option<f64>,
    /// Measured over model: the median of its frames in `model_state` (`probe::states`: the
    /// fastest state it ran in that the probe has a model of), of its fastest build there,
    /// over that state's model time; where fewer than 3 frames ran in such a state
    /// (`model_state` `None`), the median of its fastest build's frames over the main
    /// model's.
    pub x_model: Option<f64>,
    pub model_state: Option<usize>,
    /// Frames of the row in `model_state`.
    pub model_state_frames: Option<usize>,
    pub ms_median: Option<f64>,
    pub ms_min: Option<f64>,
    pub ms_max: Option<f64>,
    pub frames: usize,
    pub rel_rmse: Option<f64>,
    /// Its relative RMSE against the inter-reflected reference, when the bench rendered
    /// one (for the inter-reflected rows, `rel_rmse` itself).
    pub rel_rmse_bounced: Option<f64>,
    pub psnr: Option<f64>,
    pub texel_bytes: u64,
    pub table_bytes: u64,
    pub textures_bound: u32,
    pub lookups_per_pixel: u32,
    /// `ms_median` over `preconv`'s on the same path.
    pub ratio_to_preconv: Option<f64>,
    /// The paper's ms/frame on its GTX 295 (DESIGN §3), where it measured the technique.
    pub paper_ms: Option<f64>,
    /// The paper's ratio to its `preconv`.
    pub paper_ratio_to_preconv: Option<f64>,
    /// What `rel_rmse` is measured against (JSON: "direct", "N bounces" or "none").
    pub reference: RowReference,
    /// Where `rel_rmse` comes from, rung by rung (empty without a footprint reference).
    pub attribution: Vec<AttributionStep>,
    /// Covered pixels whose value the f16 target could not hold (`Frame::clipped_pixels`);
    /// a row with any is marked in `table.md`.
    pub clipped_pixels: u64,
    /// Why the row's image cannot be right, if it cannot (`metrics::suspect_reason`):
    /// marked in every output, and `bench --strict` fails on it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub suspect: Option<String>,
}

/// Fills `ratio_to_preconv` of every row from the `preconv` row of its path.
pub fn fill_ratios_to_preconv(rows: &mut [BenchRow]) {
    let preconv: Vec<(HwPath, _, f64)> = rows
        .iter()
        .filter(|r| r.technique == Technique::Preconv(crate::technique::Preconv))
        .filter_map(|r| Some((r.path, r.specular, r.ms_median?)))
        .collect();
    for row in rows.iter_mut() {
        row.ratio_to_preconv = preconv
            .iter()
            .find(|(p, s, _)| *p == row.path && *s == row.specular)
            .and_then(|(_, _, base)| Some(row.ms_median? / base))
            .filter(|r| r.is_finite());
    }
}

impl BenchRow {
    /// The row's name in tables and plots: the technique's, `+spec{filter}` with the
    /// specular term.
    pub fn name(&self) -> String {
        match self.specular {
            Some(f) => format!("{}+spec{}", self.technique, f.name()),
            None => self.technique.name(),
        }
    }
}

/// Version of `table.json`'s layout (`table_version`; docs/reading-results.md): `shvis
/// report` reads tables of this version only. Bump it whenever a field changes meaning or
/// form, or one `report` reads is added or removed.
pub const TABLE_VERSION: u32 = 1;

/// The whole table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchTable {
    /// [`TABLE_VERSION`].
    pub table_version: u32,
    pub device: String,
    /// The device's driver, name and version (`gpu::DeviceSummary::driver`).
    pub driver: String,
    pub width: u32,
    pub height: u32,
    pub vis_res: u32,
    /// Samples per pixel of the reference the errors are measured against (0: none).
    pub reference_spp: u32,
    /// The reference's own relative noise (compare with `rel_rmse`).
    pub reference_rel_noise: Option<f64>,
    /// The error ladder's grid: every `ladder_stride`-th pixel in each direction, where its
    /// steps are measured (`None`: no ladder).
    pub ladder_stride: Option<u32>,
    /// Bounces of the inter-reflected reference `shlmap` is measured against (0: none).
    pub reference_bounces: u32,
    /// That reference's relative noise.
    pub reference_bounced_rel_noise: Option<f64>,
    /// The specular material term of the rows that have one (`--specular`): its light and
    /// base spread.
    pub specular: Option<String>,
    /// `--relight-rotate`: the lighting the rows and references are under when it is not
    /// the one baked (techniques with dynamic lighting relit to it, baked ones as baked).
    pub relit: Option<String>,
    /// The probe's main cost model (`probe.md`).
    pub cost_model: Option<crate::cost::CostModel>,
    /// When the probe behind `cost_model` was measured, and the cache file a reused one
    /// came from.
    pub probe_measured: Option<String>,
    /// Its model per speed state (`probe::states`), the rows' `model_ms` come from the one
    /// of their `model_state`.
    pub state_cost_models: Vec<crate::probe::StateModel>,
    /// The device's speed states the probe told apart (`probe::states`), and the share of
    /// the bench's monitor frames (read between every few frames of every row) in each.
    pub device_states: Option<crate::probe::DeviceStates>,
    pub bench_state_shares: Option<Vec<f64>>,
    /// The probe's model checked on the scene (`probe::scene_check`): shaders of known
    /// counts over the scene's mesh, each against the model.
    pub scene_checks: Vec<crate::probe::scene_check::SceneCheck>,
    /// Wall time of the bench itself (probe, references, rows, files; the bake before it
    /// is not counted), s.
    pub seconds: f64,
    /// Where `seconds` went.
    pub phases: BenchPhases,
    pub results: Vec<BenchRow>,
}

/// The bench's wall time by phase, seconds (what a `make bench` spends).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct BenchPhases {
    /// `shvis probe`'s microbenchmarks.
    pub probe: f64,
    /// The footprint and point references (and their inter-reflected twins).
    pub references: f64,
    /// The error ladder's per-pixel G-buffer, visibility and exact-lighting table.
    pub ladder_setup: f64,
    /// Building every row's technique (CPU data, uploads, pipelines), the scene's upload.
    pub build: f64,
    /// Warm-up and timed frames of every row, and the image read back.
    pub render: f64,
    /// Every row's error, its PNG/EXR and difference image.
    pub row_images: f64,
    /// Every row's error-ladder rungs (CPU) and their images and sheet.
    pub ladder: f64,
    /// Figures, the fragment count of the cost model and the plots (the table is written
    /// after, with these figures in it).
    pub figures: f64,
}

impl BenchPhases {
    /// One line: each phase and its seconds.
    pub fn summary(&self) -> String {
        format!(
            "probe {:.1} s, references {:.1} s, ladder set-up {:.1} s, technique builds {:.1} s, frames {:.1} s, row images {:.1} s, ladder rungs {:.1} s, figures and plots {:.1} s",
            self.probe,
            self.references,
            self.ladder_setup,
            self.build,
            self.render,
            self.row_images,
            self.ladder,
            self.figures
        )
    }
}

/// The pixels an error ladder of `stride` is measured at, in words.
pub fn ladder_grid_words(stride: u32) -> String {
    match stride {
        1 => "every pixel".into(),
        n => format!("one pixel of each {n}×{n} block"),
    }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "—".to_string(), |v| format!("{v:.digits$}"))
}

impl BenchTable {
    /// Markdown table (also what the terminal shows).
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "device: {} · {}×{} · visibility {}² · reference {} spp (relative noise {})",
            self.device,
            self.width,
            self.height,
            self.vis_res,
            self.reference_spp,
            opt(self.reference_rel_noise, 4)
        );
        if let Some(stride) = self.ladder_stride {
            s += &format!(" · error ladder at {}", ladder_grid_words(stride));
        }
        s += &format!(
            "; bench wall time {:.1} s ({})",
            self.seconds,
            self.phases.summary()
        );
        if let Some(term) = &self.specular {
            s += &format!(
                "; rows `+spec{{filter}}` add the specular term ({term}) with its normal map filtered as named, against references with its footprint reference added"
            );
        }
        if let Some(relit) = &self.relit {
            s += &format!("; relit: {relit}");
        }
        if let Some(measured) = &self.probe_measured {
            s += &format!("; device probe measured {measured}");
        }
        if let (Some(states), Some(shares)) = (&self.device_states, &self.bench_state_shares) {
            s += &format!(
                "; {}; the rows' monitor frames {} in each state; ×model compares a row's frames in the fastest modelled state it ran in (its fastest build's) with that state's model",
                states.describe(),
                crate::probe::DeviceStates::format_shares(shares)
            );
        }
        if !self.scene_checks.is_empty() {
            s += &format!(
                "; the probe's shaders over the scene: {}",
                crate::probe::scene_check::summary(&self.scene_checks)
            );
        }
        if self.reference_bounces > 0 {
            s += &format!(
                "; shlmap against the reference with {} bounces (relative noise {})",
                self.reference_bounces,
                opt(self.reference_bounced_rel_noise, 4)
            );
        }
        s += "\n\n";
        s += "| technique | path | ms median | ms min | ms max | frames | ×preconv | paper ×preconv | model ms | ×model | rel. RMSE | PSNR dB | texel bytes | table bytes | textures | lookups/px |\n";
        s += "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for r in &self.results {
            let rmse = match (r.rel_rmse, r.reference) {
                (Some(e), RowReference::Bounced(_)) => format!("{e:.4} ({})", r.reference),
                (e, RowReference::Direct | RowReference::None | RowReference::Bounced(_)) => {
                    opt(e, 4)
                }
            };
            let mut name = match r.clipped_pixels {
                0 => r.name(),
                n => format!("{} (⚠ {n} px clipped)", r.name()),
            };
            if let Some(why) = &r.suspect {
                name += &format!(" (⚠ suspect: {why})");
            }
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                name,
                r.path,
                opt(r.ms_median, 3),
                opt(r.ms_min, 3),
                opt(r.ms_max, 3),
                r.frames,
                opt(r.ratio_to_preconv, 2),
                opt(r.paper_ratio_to_preconv, 2),
                opt(r.model_ms, 3),
                opt(r.x_model, 2),
                rmse,
                opt(r.psnr, 2),
                r.texel_bytes,
                r.table_bytes,
                r.textures_bound,
                r.lookups_per_pixel
            );
        }
        s += &self.bounced_markdown();
        s += &self.attribution_markdown();
        s
    }

    /// Every row against the inter-reflected reference (empty without one): techniques
    /// that model direct light only and those with inter-reflection on one ground truth.
    fn bounced_markdown(&self) -> String {
        if self.reference_bounces == 0 || self.results.iter().all(|r| r.rel_rmse_bounced.is_none())
        {
            return String::new();
        }
        let mut s = format!(
            "\nEvery row against the reference with {} bounces (relative RMSE):\n\n| technique | path | rel. RMSE, {} bounces |\n|---|---|---:|\n",
            self.reference_bounces, self.reference_bounces
        );
        for r in &self.results {
            s += &format!(
                "| {} | {} | {} |\n",
                r.name(),
                r.path,
                opt(r.rel_rmse_bounced, 4)
            );
        }
        s
    }

    /// The attribution ladders, one line per row (empty when no row has rungs): each
    /// rung's relative RMSE and its share of the rungs' summed squares (errors of
    /// independent steps add in quadrature), then the row's total error.
    fn attribution_markdown(&self) -> String {
        if self.results.iter().all(|r| r.attribution.is_empty()) {
            return String::new();
        }
        let mut s = String::from(
            "\nError attribution: relative RMSE of each rung against the previous image \
             (its share of Σ rung²), from the reference to the GPU image; total = the row's \
             error, √Σ rung² beside it:\n\n| technique | path | rungs | total | √Σ rung² |\n|---|---|---|---:|---:|\n",
        );
        for r in self.results.iter().filter(|r| !r.attribution.is_empty()) {
            let sum_sq: f64 = r
                .attribution
                .iter()
                .filter_map(|a| a.rel_rmse)
                .map(|e| e * e)
                .sum();
            let rungs: Vec<String> = r
                .attribution
                .iter()
                .map(|a| match a.rel_rmse {
                    Some(e) if sum_sq > 0.0 => {
                        format!("{} {e:.4} ({:.0}%)", a.step.name(), 100.0 * e * e / sum_sq)
                    }
                    e => format!("{} {}", a.step.name(), opt(e, 4)),
                })
                .collect();
            s += &format!(
                "| {} | {} | {} | {} | {:.4} |\n",
                r.name(),
                r.path,
                rungs.join(" · "),
                opt(r.rel_rmse, 4),
                sum_sq.sqrt()
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
        crate::files::write(&md, self.to_markdown()).map_err(|e| err(&md, &e))?;
        let json_path = dir.join("table.json");
        let json = serde_json::to_string_pretty(self).map_err(|e| err(&json_path, &e))?;
        crate::files::write(&json_path, json + "\n").map_err(|e| err(&json_path, &e))?;
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A dx10 row of `technique` at `ms` with relative RMSE 0.25 (tests elsewhere use it).
    pub(crate) fn row(
        technique: Technique,
        ms: f64,
        attribution: Vec<AttributionStep>,
    ) -> BenchRow {
        BenchRow {
            technique,
            path: HwPath::Dx10,
            specular: None,
            cost: crate::cost::CostCounts::default(),
            untaken_cost: crate::cost::CostCounts::default(),
            coverage: 1.0,
            own_mesh_load: None,
            triangles: 2,
            edge_pixels: 0.0,
            model_ms: None,
            x_model: None,
            model_state: None,
            model_state_frames: None,
            ms_median: Some(ms),
            ms_min: Some(ms),
            ms_max: Some(ms),
            frames: 1,
            rel_rmse: Some(0.25),
            rel_rmse_bounced: None,
            psnr: Some(30.0),
            texel_bytes: 8,
            table_bytes: 16,
            textures_bound: 3,
            lookups_per_pixel: 3,
            ratio_to_preconv: None,
            paper_ms: technique.paper_ms(),
            paper_ratio_to_preconv: technique.paper_ratio_to_preconv(),
            reference: RowReference::Direct,
            attribution,
            clipped_pixels: 0,
            suspect: None,
        }
    }

    #[test]
    fn ratios_use_the_preconv_row_of_the_same_path() {
        let mut rows = vec![
            row(Technique::Sh2(crate::technique::Sh2), 3.0, vec![]),
            row(Technique::Preconv(crate::technique::Preconv), 2.0, vec![]),
        ];
        rows[0].path = HwPath::Dx9;
        rows.push(row(Technique::Sh2(crate::technique::Sh2), 4.0, vec![]));
        fill_ratios_to_preconv(&mut rows);
        assert_eq!(rows[0].ratio_to_preconv, None, "no dx9 preconv row");
        assert_eq!(rows[2].ratio_to_preconv, Some(2.0));
    }

    #[test]
    fn attribution_rungs_reach_the_markdown_and_the_json() {
        let steps = vec![
            AttributionStep {
                step: AttributionKind::PixelFootprint,
                rel_rmse: Some(0.3),
                image: "reference_point.exr".into(),
            },
            AttributionStep {
                step: AttributionKind::Technique,
                rel_rmse: Some(0.4),
                image: "preconv.dx10.exr".into(),
            },
        ];
        let table = BenchTable {
            table_version: TABLE_VERSION,
            driver: String::new(),
            device: "test".into(),
            width: 4,
            height: 4,
            vis_res: 16,
            reference_spp: 4,
            ladder_stride: None,
            reference_rel_noise: Some(0.1),
            reference_bounces: 0,
            reference_bounced_rel_noise: None,
            specular: None,
            relit: None,
            cost_model: None,
            probe_measured: None,
            device_states: None,
            bench_state_shares: None,
            scene_checks: Vec::new(),
            state_cost_models: Vec::new(),
            seconds: 0.0,
            phases: BenchPhases::default(),
            results: vec![
                row(Technique::Preconv(crate::technique::Preconv), 1.0, steps),
                row(Technique::Sh2(crate::technique::Sh2), 1.0, vec![]),
            ],
        };
        let md = table.to_markdown();
        // 0.3² : 0.4² = 36% : 64% of Σ rung² = 0.25, √ = 0.5.
        assert!(
            md.contains(
                "| preconv | dx10 | pixel footprint → point sampling 0.3000 (36%) · point sampling → technique 0.4000 (64%) | 0.2500 | 0.5000 |"
            ),
            "{md}"
        );
        assert!(
            !md.contains("| sh2 | dx10 | pixel"),
            "a row without rungs has no attribution line"
        );
        let json = serde_json::to_value(&table).unwrap();
        let rung = &json["results"][0]["attribution"][1];
        assert_eq!(rung["step"], "point sampling → technique");
        assert_eq!(rung["rel_rmse"], 0.4);
        assert_eq!(rung["image"], "preconv.dx10.exr");
        assert_eq!(json["results"][0]["technique"], "preconv");
        assert_eq!(json["results"][0]["reference"], "direct");
        assert_eq!(json["table_version"], TABLE_VERSION);
    }
}
