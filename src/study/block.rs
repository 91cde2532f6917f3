//! `shvis study block`: the SH lightmap (`shlmap`'s order-3 RGB radiance per texel) block-
//! compressed as DX11-class hardware would store it — 9 layers of 1 byte per texel instead
//! of 56 bytes of RGBA16F — under each packing of its signed coefficients, and the
//! encoder's quality settings against time.
//!
//! # Packings (coefficient k of band l, RGB, per texel)
//!
//! ```text
//! half         every L_k in f16 (shlmap's storage, the baseline)
//! bc6h-raw     each L_k as a BC6H image; BC6H is unsigned, so negative terms clamp to 0
//! bc6h-offset  each L_k − m_k in BC6H, m_k ≤ 0 the map's least value of L_k, added back
//! bc6h-ratio   L_0 in BC6H; for k ≥ 1 the ratio r = L_k / L_0 remapped to
//!              u = ½ + r / (2 R_k) ∈ [0, 1] in BC6H; decoded L_k = L̂_0 (2u − 1) R_k
//! bc7-ratio    the same, u in BC7 (8 bits per channel)
//! bc7-norm     the dx11 path's (technique::block): the texel's norm per colour
//!              n_c = max_k |L_k,c| in BC6H, every L_k,c / n_c in BC7 (shlmap's RGBA
//!              groups), at each BC7 quality
//! ```
//!
//! For a non-negative radiance |L_lm| ≤ √(2l+1) L_0 (|y_lm| ≤ √((2l+1)/4π), y_00 = 1/√(4π)),
//! but a bake's radiance is not always non-negative: the environment's SH and the bounced
//! SH irradiance ring below zero where a sun is, and there the ratios of dark texels run
//! far past it. So R_k is the smaller of that bound and the map's own range, the 99.9th
//! percentile of |r| over its texels with L_0 > 0 (a number per coefficient, for the
//! manifest): the bound keeps a sunlit map's few wild ratios from costing every texel its
//! precision, the percentile tightens an overcast map's; what lies beyond is clamped and
//! counted. A texel with L_0 ≤ 0 (per channel)
//! stores ratio 0 — and L_0 = 0, BC6H being unsigned. The ratio packings are Frostbite's and
//! Godot's for L1, carried to band 2.
//!
//! # Error
//!
//! Over the covered texels, on irradiance (E_lm = A_l L_lm, `sh::zonal`):
//!
//! ```text
//! sphere   √(Σ_t ‖ΔE_t‖²) / √(Σ_t ‖E_t‖²), ‖·‖ the L2 norm over all normals (RGB)
//! p99      the 99th percentile over texels of ‖ΔE_t‖ / ‖E_t‖
//! normal   √(Σ_t |ΔE_t(n_t)|²) / √(Σ_t |E_t(n_t)|²) at each texel's geometric normal
//! ```

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::bake::block::{self, Bc6hQuality, Bc7Quality, Clamped};
use crate::bake::shlmap::ShLightmap;
use crate::sh::Order;
use crate::sh::zonal::clamped_cosine_convolution;

/// The packings (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Packing {
    Half,
    Bc6hRaw,
    Bc6hOffset,
    Bc6hRatio,
    Bc7Ratio,
    /// The `dx11` path's packing (`technique::block`): BC7 ratios to a BC6H norm per colour.
    Bc7Norm,
}

impl Packing {
    pub const ALL: [Packing; 6] = [
        Packing::Half,
        Packing::Bc6hRaw,
        Packing::Bc6hOffset,
        Packing::Bc6hRatio,
        Packing::Bc7Ratio,
        Packing::Bc7Norm,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Packing::Half => "half",
            Packing::Bc6hRaw => "bc6h-raw",
            Packing::Bc6hOffset => "bc6h-offset",
            Packing::Bc6hRatio => "bc6h-ratio",
            Packing::Bc7Ratio => "bc7-ratio",
            Packing::Bc7Norm => "bc7-norm",
        }
    }

    /// Bytes per texel on the GPU: RGBA16F groups for `half` (`shlmap`'s 7), one byte per
    /// coefficient layer for the ratio and offset packings, one per RGBA group and one for
    /// the norms for `bc7-norm`.
    pub fn bytes_per_texel(self) -> u32 {
        match self {
            Packing::Half => 56,
            Packing::Bc7Norm => 8,
            Packing::Bc6hRaw | Packing::Bc6hOffset | Packing::Bc6hRatio | Packing::Bc7Ratio => {
                COEFFS as u32
            }
        }
    }
}

const COEFFS: usize = 9;

/// One packing at one quality.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BlockRow {
    pub packing: Packing,
    /// BC6H quality (none for `half`).
    pub quality: Option<Bc6hQuality>,
    /// BC7 quality of the BC7 packings.
    pub bc7_quality: Option<Bc7Quality>,
    pub bytes_per_texel: u32,
    pub encode_seconds: f64,
    pub rms_sphere: f64,
    pub p99_sphere: f64,
    pub rms_normal: f64,
    /// Values the encoding clamped (BC6H's range, or a ratio outside [0, 1]).
    pub clamped: Clamped,
}

/// The study of one lightmap.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BlockStudy {
    pub res: u32,
    pub covered_texels: usize,
    /// Covered texels with L_0 ≤ 0 in some channel.
    pub nonpositive_l0_texels: usize,
    /// R_k, k = 1…8, of the ratio packings.
    pub ratio_ranges: Vec<f32>,
    pub rows: Vec<BlockRow>,
    /// The quality the ratio packing defaults to: the fastest within 5 % of the best error.
    pub default_quality: Bc6hQuality,
    /// The same for `bc7-norm`'s BC7 quality.
    pub default_bc7_quality: Bc7Quality,
}

fn band(k: usize) -> u32 {
    match k {
        0 => 0,
        1..=3 => 1,
        _ => 2,
    }
}

/// R_k of the module doc: the smaller of √(2l+1) and the 99.9th percentile of |L_k / L_0|
/// over the channels of `map`'s texels with L_0 > 0.
pub fn ratio_range(map: &ShLightmap, k: usize) -> f32 {
    let bound = ((2 * band(k) + 1) as f32).sqrt();
    let mut ratios: Vec<f32> = (0..(map.res * map.res) as usize)
        .flat_map(|t| {
            let (lk, base) = (map.texel(t)[k], map.texel(t)[0]);
            (0..3)
                .filter(move |&c| base[c] > 0.0)
                .map(move |c| (lk[c] / base[c]).abs())
        })
        .filter(|r| r.is_finite())
        .collect();
    if ratios.is_empty() {
        return bound;
    }
    let at = ((ratios.len() as f64 * 0.999) as usize).min(ratios.len() - 1);
    let (_, &mut range, _) = ratios.select_nth_unstable_by(at, f32::total_cmp);
    if range > 0.0 { range.min(bound) } else { bound }
}

/// Texels whose L_0 is ≤ 0 in some channel (stored as black by the ratio packings).
pub fn nonpositive_l0(map: &ShLightmap) -> usize {
    (0..(map.res * map.res) as usize)
        .filter(|&t| map.covered[t] && map.texel(t)[0].iter().any(|&v| v <= 0.0))
        .count()
}

/// The coefficients of `map` after `packing` at `quality` (texel-major, as `map.coeffs`),
/// and what was clamped.
pub fn round_trip(
    map: &ShLightmap,
    packing: Packing,
    quality: Bc6hQuality,
) -> (Vec<[f32; 3]>, Clamped) {
    let res = map.res;
    let texels = (res * res) as usize;
    let layer = |k: usize| -> Vec<[f32; 3]> { (0..texels).map(|t| map.texel(t)[k]).collect() };
    let mut out = vec![[0.0f32; 3]; texels * COEFFS];
    let mut clamped = Clamped::default();
    let mut put = |k: usize, values: &[[f32; 3]]| {
        for (t, v) in values.iter().enumerate() {
            out[t * COEFFS + k] = *v;
        }
    };
    match packing {
        Packing::Bc7Norm => return norm_round_trip(map, Bc7Quality::Basic),
        Packing::Half => {
            let scale =
                crate::technique::tables::finite_f16_scale(map.coeffs.iter().flatten().copied())
                    .unwrap_or(1.0);
            for k in 0..COEFFS {
                let values: Vec<[f32; 3]> = layer(k)
                    .iter()
                    .map(|v| v.map(|x| half::f16::from_f32(x * scale).to_f32() / scale))
                    .collect();
                put(k, &values);
            }
        }
        Packing::Bc6hRaw | Packing::Bc6hOffset => {
            let coded: Vec<(Vec<[f32; 3]>, Clamped)> = (0..COEFFS)
                .into_par_iter()
                .map(|k| {
                    let values = layer(k);
                    let offset = if packing == Packing::Bc6hOffset {
                        values.iter().flatten().fold(0.0f32, |m, &v| m.min(v))
                    } else {
                        0.0
                    };
                    let shifted: Vec<[f32; 3]> =
                        values.iter().map(|v| v.map(|x| x - offset)).collect();
                    let (blocks, c) = block::encode_bc6h(&shifted, res, quality);
                    let back = block::decode_bc6h(&blocks, res)
                        .into_iter()
                        .map(|v| v.map(|x| x + offset))
                        .collect();
                    (back, c)
                })
                .collect();
            for (k, (values, c)) in coded.iter().enumerate() {
                put(k, values);
                clamped.add(*c);
            }
        }
        Packing::Bc6hRatio | Packing::Bc7Ratio => {
            let (l0_blocks, c0) = block::encode_bc6h(&layer(0), res, quality);
            clamped.add(c0);
            let l0 = block::decode_bc6h(&l0_blocks, res);
            put(0, &l0);
            let coded: Vec<(Vec<[f32; 3]>, Clamped)> = (1..COEFFS)
                .into_par_iter()
                .map(|k| {
                    let bound = ratio_range(map, k);
                    let mut c = Clamped::default();
                    let u: Vec<[f32; 3]> = (0..texels)
                        .map(|t| {
                            let (lk, base) = (map.texel(t)[k], map.texel(t)[0]);
                            std::array::from_fn(|ch| {
                                let r = if base[ch] > 0.0 {
                                    lk[ch] / base[ch]
                                } else {
                                    0.0
                                };
                                let u = 0.5 + r / (2.0 * bound);
                                if u < 0.0 {
                                    c.below += 1;
                                } else if u > 1.0 {
                                    c.above += 1;
                                }
                                u.clamp(0.0, 1.0)
                            })
                        })
                        .collect();
                    let decoded_u: Vec<[f32; 3]> = if packing == Packing::Bc6hRatio {
                        let (blocks, cb) = block::encode_bc6h(&u, res, quality);
                        c.add(cb);
                        block::decode_bc6h(&blocks, res)
                    } else {
                        let rgba: Vec<[u8; 4]> = u
                            .iter()
                            .map(|v| {
                                let q = v.map(|x| (x * 255.0).round() as u8);
                                [q[0], q[1], q[2], 255]
                            })
                            .collect();
                        block::decode_bc7(&block::encode_bc7(&rgba, res, false), res)
                            .iter()
                            .map(|q| [0, 1, 2].map(|ch| f32::from(q[ch]) / 255.0))
                            .collect()
                    };
                    let values = decoded_u
                        .iter()
                        .zip(&l0)
                        .map(|(u, base)| {
                            std::array::from_fn(|ch| base[ch] * (2.0 * u[ch] - 1.0) * bound)
                        })
                        .collect();
                    (values, c)
                })
                .collect();
            for (i, (values, c)) in coded.iter().enumerate() {
                put(i + 1, values);
                clamped.add(*c);
            }
        }
    }
    (out, clamped)
}

/// The coefficients of `map` through the `dx11` path's packing (`technique::block`, RGB
/// triplets, as `shlmap` stores them on that path) with the ratios at BC7 `quality`.
pub fn norm_round_trip(map: &ShLightmap, quality: Bc7Quality) -> (Vec<[f32; 3]>, Clamped) {
    use crate::technique::block::{BlockCodec, NormColours, compress_at};
    use crate::technique::texels::{TexelGroups, pack_groups};
    let res = map.res;
    let texels = (res * res) as usize;
    let scale = crate::technique::tables::finite_f16_scale(map.coeffs.iter().flatten().copied())
        .unwrap_or(1.0);
    let groups = pack_groups(texels, 3 * COEFFS, |t, j| {
        half::f16::from_f32(map.texel(t)[j / 3][j % 3] * scale)
    });
    let stored = TexelGroups::new(
        ash::vk::Format::R16G16B16A16_SFLOAT,
        res,
        &groups,
        "shlmap".into(),
    );
    let block = compress_at(
        &stored,
        BlockCodec::Ratio(NormColours::Triplets),
        "shlmap",
        quality,
    )
    .expect("range-scaled f16 data compresses");
    let decoded = block.decoded_values();
    let out = (0..texels * COEFFS)
        .map(|i| {
            let (t, k) = (i / COEFFS, i % COEFFS);
            std::array::from_fn(|c| {
                let j = 3 * k + c;
                decoded[j / 4][4 * t + j % 4] / scale
            })
        })
        .collect();
    (out, block.clamped)
}

/// The module doc's three errors of `decoded` against `map`.
pub fn errors(map: &ShLightmap, decoded: &[[f32; 3]]) -> (f64, f64, f64) {
    let a: Vec<f64> = (0..COEFFS)
        .map(|k| clamped_cosine_convolution(band(k)))
        .collect();
    let per_texel: Vec<(f64, f64, f64, f64)> = (0..(map.res * map.res) as usize)
        .into_par_iter()
        .filter(|&t| map.covered[t])
        .map(|t| {
            let (orig, got) = (map.texel(t), &decoded[t * COEFFS..(t + 1) * COEFFS]);
            let (mut err, mut norm) = (0.0, 0.0);
            for k in 0..COEFFS {
                for c in 0..3 {
                    let (o, g) = (f64::from(orig[k][c]), f64::from(got[k][c]));
                    err += (a[k] * (g - o)).powi(2);
                    norm += (a[k] * o).powi(2);
                }
            }
            let n = map.normal[t].as_dvec3();
            let (mut en_err, mut en) = (0.0, 0.0);
            if n != DVec3::ZERO {
                let mut y = [0.0; COEFFS];
                crate::sh::basis::eval_basis(Order::THREE, n, &mut y);
                for c in 0..3 {
                    let e = |coeffs: &[[f32; 3]]| -> f64 {
                        (0..COEFFS)
                            .map(|k| a[k] * f64::from(coeffs[k][c]) * y[k])
                            .sum()
                    };
                    let (eo, eg) = (e(orig), e(got));
                    en_err += (eg - eo).powi(2);
                    en += eo * eo;
                }
            }
            (err, norm, en_err, en)
        })
        .collect();
    let sum = |f: fn(&(f64, f64, f64, f64)) -> f64| per_texel.iter().map(f).sum::<f64>();
    let ratio = |e: f64, n: f64| if n > 0.0 { (e / n).sqrt() } else { 0.0 };
    let rms_sphere = ratio(sum(|p| p.0), sum(|p| p.1));
    let rms_normal = ratio(sum(|p| p.2), sum(|p| p.3));
    let mut relative: Vec<f64> = per_texel
        .iter()
        .filter(|p| p.1 > 0.0)
        .map(|p| (p.0 / p.1).sqrt())
        .collect();
    relative.sort_by(f64::total_cmp);
    let p99 = relative
        .get(((relative.len() as f64 * 0.99) as usize).min(relative.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    (rms_sphere, p99, rms_normal)
}

/// Every packing at the basic quality, and the ratio packing at every BC6H quality.
pub fn run(map: &ShLightmap) -> BlockStudy {
    let mut rows = Vec::new();
    let mut measure = |packing: Packing, quality: Bc6hQuality, bc7: Option<Bc7Quality>| {
        let started = Instant::now();
        let (decoded, clamped) = match (packing, bc7) {
            (Packing::Bc7Norm, Some(q)) => norm_round_trip(map, q),
            _ => round_trip(map, packing, quality),
        };
        let encode_seconds = started.elapsed().as_secs_f64();
        let (rms_sphere, p99_sphere, rms_normal) = errors(map, &decoded);
        let row = BlockRow {
            packing,
            quality: (packing != Packing::Half).then_some(quality),
            bc7_quality: bc7,
            bytes_per_texel: packing.bytes_per_texel(),
            encode_seconds,
            rms_sphere,
            p99_sphere,
            rms_normal,
            clamped,
        };
        log::info!(
            "{} {}: {:.3} % RMS in {:.2} s",
            packing.name(),
            bc7.map_or(quality.name(), Bc7Quality::name),
            100.0 * rms_sphere,
            encode_seconds
        );
        rows.push(row);
    };
    for packing in Packing::ALL {
        match packing {
            Packing::Bc6hRatio => {
                for quality in Bc6hQuality::ALL {
                    measure(packing, quality, None);
                }
            }
            Packing::Bc7Norm => {
                for q in Bc7Quality::ALL {
                    measure(packing, crate::technique::block::NORM_QUALITY, Some(q));
                }
            }
            Packing::Bc7Ratio => measure(packing, Bc6hQuality::Basic, Some(Bc7Quality::Basic)),
            Packing::Half | Packing::Bc6hRaw | Packing::Bc6hOffset => {
                measure(packing, Bc6hQuality::Basic, None);
            }
        }
    }
    let default_bc7_quality = fastest_within_5_percent(&rows, Packing::Bc7Norm, |r| r.bc7_quality)
        .unwrap_or(Bc7Quality::Basic);
    let default_quality = fastest_within_5_percent(&rows, Packing::Bc6hRatio, |r| r.quality)
        .unwrap_or(Bc6hQuality::Basic);
    BlockStudy {
        res: map.res,
        covered_texels: map.covered.iter().filter(|&&c| c).count(),
        nonpositive_l0_texels: nonpositive_l0(map),
        ratio_ranges: (1..COEFFS).map(|k| ratio_range(map, k)).collect(),
        rows,
        default_quality,
        default_bc7_quality,
    }
}

/// One technique's normal-indexed tables block-compressed as the `dx11` path compresses
/// per-texel data (`technique::block`: BC7 ratios to a BC6H norm, one norm per table texel
/// and cube face), against their RGBA16F storage.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TableRow {
    pub technique: String,
    /// The tables' texels on dx10 (RGBA16F) and as blocks.
    pub bytes_half: u64,
    pub bytes_blocks: u64,
    /// √(Σ Δ²) / √(Σ v²) over every stored table value, and the largest |Δ| over the
    /// largest |v|.
    pub rms: f64,
    pub max: f64,
    /// Encoding time of the tables on this machine: on the path a lighting change takes.
    pub encode_seconds: f64,
}

/// [`TableRow`] of each technique in `techniques` that has tables, on dx10's layout.
///
/// # Errors
/// The technique's own (inputs it lacks).
pub fn tables(
    prepared: &crate::prepare::Prepared,
    techniques: &[crate::technique::Technique],
) -> Result<Vec<TableRow>, crate::technique::TechniqueError> {
    use crate::technique::block::{BlockCodec, NormColours, compress};
    use crate::technique::texels::TexelGroups;
    let inputs = prepared.inputs();
    let mut rows = Vec::new();
    for &t in techniques {
        let recipe =
            crate::technique::LightingRecipe::new(t, crate::technique::HwPath::Dx10, &inputs)?;
        let data = recipe.build(inputs.radiance_sh, inputs.irradiance_sh)?;
        let Some(tables) = data.tables else { continue };
        let started = Instant::now();
        let (mut sum_d2, mut sum_v2, mut max_d, mut max_v) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let (mut bytes_half, mut bytes_blocks) = (0u64, 0u64);
        for image in &tables.images {
            let faces = if image.desc.layers % 6 == 0 { 6 } else { 1 };
            let res = image.desc.width;
            for face in 0..faces {
                let groups: Vec<Vec<half::f16>> = image
                    .layers
                    .iter()
                    .skip(face)
                    .step_by(faces)
                    .map(|l| l.iter().flatten().copied().collect())
                    .collect();
                let texels = TexelGroups::new(
                    ash::vk::Format::R16G16B16A16_SFLOAT,
                    res,
                    &groups,
                    image.name.clone(),
                );
                let block = compress(&texels, BlockCodec::Ratio(NormColours::One), &image.name)?;
                bytes_half += texels.groups.iter().map(|g| g.len() as u64).sum::<u64>();
                bytes_blocks += (block.bytes_per_texel() * f64::from(res * res)) as u64;
                for (g, decoded) in groups.iter().zip(block.decoded_values()) {
                    for (v, d) in g.iter().zip(decoded) {
                        let (v, d) = (f64::from(v.to_f32()), f64::from(d));
                        sum_d2 += (v - d) * (v - d);
                        sum_v2 += v * v;
                        max_d = max_d.max((v - d).abs());
                        max_v = max_v.max(v.abs());
                    }
                }
            }
        }
        rows.push(TableRow {
            technique: t.name(),
            bytes_half,
            bytes_blocks,
            rms: (sum_d2 / sum_v2.max(f64::MIN_POSITIVE)).sqrt(),
            max: max_d / max_v.max(f64::MIN_POSITIVE),
            encode_seconds: started.elapsed().as_secs_f64(),
        });
    }
    Ok(rows)
}

/// The table rows as a Markdown section.
pub fn tables_markdown(rows: &[TableRow]) -> String {
    let mut s = String::from(
        "\n## Lighting tables\n\nEach technique's normal-indexed tables (dx10's cube arrays) in \
         the dx11 path's packing, one norm per table texel and face, against their RGBA16F \
         values:\n\n\
         | technique | RGBA16F bytes | block bytes | RMS | largest error / largest value | encode s |\n\
         |---|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {:.3} % | {:.3} % | {:.2} |\n",
            r.technique,
            r.bytes_half,
            r.bytes_blocks,
            100.0 * r.rms,
            100.0 * r.max,
            r.encode_seconds
        );
    }
    s
}

/// The quality of the fastest row of `packing` (rows are measured fastest setting first)
/// whose RMS is within 5 % of the packing's best.
fn fastest_within_5_percent<Q>(
    rows: &[BlockRow],
    packing: Packing,
    quality: impl Fn(&BlockRow) -> Option<Q>,
) -> Option<Q> {
    let of_packing = || rows.iter().filter(move |r| r.packing == packing);
    let best = of_packing()
        .map(|r| r.rms_sphere)
        .fold(f64::INFINITY, f64::min);
    of_packing()
        .find(|r| r.rms_sphere <= 1.05 * best)
        .and_then(quality)
}

/// The study as a Markdown page.
pub fn markdown(study: &BlockStudy) -> String {
    let mut s = format!(
        "# Block compression of the SH lightmap\n\n\
         {}² texels ({} covered, {} of them with L0 ≤ 0 in some channel), 9 RGB coefficients \
         each; ratio ranges R1…R8 {}. Errors on irradiance over the covered texels: over all \
         normals (RMS and 99th percentile per texel) and at each texel's geometric normal; \
         encode time of the 9 layers on this machine.\n\n\
         | packing | BC6H quality | BC7 quality | bytes/texel | RMS | p99 | at the normal | encode s | clamped below / above |\n\
         |---|---|---|---:|---:|---:|---:|---:|---:|\n",
        study.res,
        study.covered_texels,
        study.nonpositive_l0_texels,
        study
            .ratio_ranges
            .iter()
            .map(|r| format!("{r:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for r in &study.rows {
        s += &format!(
            "| {} | {} | {} | {} | {:.3} % | {:.2} % | {:.3} % | {:.2} | {} / {} |\n",
            r.packing.name(),
            r.quality.map_or("—", Bc6hQuality::name),
            r.bc7_quality.map_or("—", Bc7Quality::name),
            r.bytes_per_texel,
            100.0 * r.rms_sphere,
            100.0 * r.p99_sphere,
            100.0 * r.rms_normal,
            r.encode_seconds,
            r.clamped.below,
            r.clamped.above
        );
    }
    s += &format!(
        "\nDefault BC6H quality (the fastest within 5 % of the best ratio-packing error): {}; \
         BC7 quality of `bc7-norm` by the same rule: {}.\n",
        study.default_quality.name(),
        study.default_bc7_quality.name()
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 64² map of sky-like texels with signed band-2 terms, one texel with L_0 = 0 and,
    /// with `ringing`, one whose L1 is far outside the others' range.
    fn map(ringing: bool) -> ShLightmap {
        let res = 64;
        let texels = (res * res) as usize;
        let mut coeffs = Vec::with_capacity(texels * COEFFS);
        for t in 0..texels {
            let x = (t % 16) as f32 / 16.0;
            let mut c = [[0.0f32; 3]; COEFFS];
            c[0] = [1.0 + x, 0.9 + 0.5 * x, 0.8];
            c[2] = [0.5 * x, 0.3, 0.2];
            c[3] = [0.1 * x, 0.08 * x, 0.05 * x];
            c[4] = [-0.2, 0.1 * x, -0.05];
            c[8] = [0.1, -0.15, 0.05 * x];
            if t == 5 {
                c = [[0.0; 3]; COEFFS];
            }
            if ringing && t == 7 {
                c[3] = [5.0, 5.0, 5.0];
            }
            coeffs.extend(c);
        }
        ShLightmap {
            res,
            bounces: 0,
            coeffs,
            covered: vec![true; texels],
            normal: vec![glam::Vec3::Y; texels],
            frame: vec![glam::Mat3::IDENTITY; texels],
            bounce_source: Vec::new(),
            basis_irradiance: Vec::new(),
            fitted: Default::default(),
            env: Default::default(),
            stats: Default::default(),
        }
    }

    #[test]
    fn the_ratio_packings_keep_signed_terms_and_raw_bc6h_loses_them() {
        let plain = map(false);
        let error = |p: Packing| {
            let (decoded, clamped) = round_trip(&plain, p, Bc6hQuality::Basic);
            (errors(&plain, &decoded).0, clamped, decoded)
        };
        let (half, _, _) = error(Packing::Half);
        assert!(half < 1e-3, "{half}");
        let (raw, raw_clamped, _) = error(Packing::Bc6hRaw);
        assert!(raw_clamped.below > 0);
        let (ratio, ratio_clamped, decoded) = error(Packing::Bc6hRatio);
        let (bc7, _, _) = error(Packing::Bc7Ratio);
        assert!(ratio < 0.05 && bc7 < 0.05, "ratio {ratio} bc7 {bc7}");
        // The dx11 path's packing: nothing clamped; the black texel stores ratio 0 under its
        // block's norm, so it decodes to within the block's BC7 error of 0 (its neighbours'
        // L0 is about 1–2).
        let (norm, norm_clamped, norm_decoded) = error(Packing::Bc7Norm);
        assert!(norm < 0.05, "bc7-norm {norm}");
        assert_eq!(norm_clamped, Clamped::default());
        let black = &norm_decoded[5 * COEFFS..6 * COEFFS];
        assert!(black.iter().flatten().all(|v| v.abs() < 0.05), "{black:?}");
        assert!(raw > 2.0 * ratio, "raw {raw} ratio {ratio}");
        assert_eq!(ratio_clamped, Clamped::default());
        // The L0 ratio packings store L0 = 0 as a black texel.
        assert!(
            decoded[5 * COEFFS..6 * COEFFS]
                .iter()
                .flatten()
                .all(|v| v.abs() < 1e-3)
        );
        // A texel whose L1 is far beyond the others' range (a ringing SH) is clamped and
        // counted, per channel.
        let ringing = map(true);
        assert!(ratio_range(&ringing, 3) < 0.1);
        assert!(ratio_range(&ringing, 2) <= 3f32.sqrt());
        let (_, clamped) = round_trip(&ringing, Packing::Bc6hRatio, Bc6hQuality::Basic);
        assert_eq!(clamped.above, 3, "{clamped:?}");
    }
}
