//! Bake cache files (DESIGN §5: "bake (cached, versioned files)") and EXR dumps of a bake
//! for inspection.
//!
//! # Cache file layout (little-endian)
//!
//! ```text
//! offset  size  field
//!      0     8  magic "SHVISBC\0"
//!      8     4  format version (CACHE_FORMAT_VERSION)
//!     12     4  kind (1 = SH visibility)
//!     16     8  key: hash of the scene content and the settings (below)
//!     24     8  payload length, bytes
//!     32     8  payload checksum (hash64 of the payload)
//!     40     …  payload: res u32, order u32, rays_traced u64, seconds f64,
//!               res²·order² coefficients f32, res² covered u8 (0/1), res² AO f32
//! ```
//!
//! The key is [`hash64`](crate::files::hash64) of the format version, the kind, the bake's
//! own sources (`SHVIS_BAKE_SOURCE_HASH` from build.rs: every file under src/bake, src/sh and
//! src/env, so a file baked by other bake code is never read), the vertex and index bytes
//! of the mesh (every attribute, as laid out in [`Vertex`]) and the settings (order, rays,
//! seed, res); the file is `visibility-{key:016x}.bin` in the cache directory. A file is
//! used only when magic, version, kind, key, length and checksum all match and the
//! payload parses to the requested resolution and order; anything else is logged with
//! `log::warn!` (one line: the file and what is wrong) and rebuilt, never trusted.
//! Files are written atomically: a temporary file in the same directory, fsync, rename
//! (then a best-effort fsync of the directory), so a crash leaves the old file or none.
//!
//! Kind 2 holds a VQ / CPCA fit of a visibility map ([`load_or_fit_clusters`], key over the
//! bake's sources, the map's content, the fit's parameters and `cluster::FIT_VERSION`).
//!
//! Kind 4 holds an SH lightmap bake with the bases fitted from its samples
//! ([`load_or_bake_sh_lightmap`]; key over the bake's own sources — `SHVIS_BAKE_SOURCE_HASH`
//! from build.rs, so other bake code never reads it —, the mesh, the albedo texture, the
//! lighting by content — its SH coefficients or its map's texels —, the lightmap
//! resolution, rays, seed, bounces and the fits; payload in [`encode_sh_lightmap`]).
//!
//! Bump [`CACHE_FORMAT_VERSION`] whenever the layout *or the bake's results* change.
//!

use std::fs;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::BakeError;
use super::cluster::{self, ClusteredModel, Clustering};
use super::shlmap::{BakeEnv, BakeLighting, FittedBases, ShLightmap, ShLightmapSettings};
use super::visibility::{VisibilityMap, VisibilitySettings};
use crate::files::{self, Hasher64, hash64};
use crate::scene::{Mesh, Scene, Vertex};
use crate::sh::Order;
use crate::sh::samples::SampleFit;

/// Version of the cache layout and of the bake results it stores (2: rays with −0.0
/// direction components are canonicalized, `bake::trace::canonical_direction`).
pub const CACHE_FORMAT_VERSION: u32 = 2;
/// First 8 bytes of every cache file.
pub const CACHE_MAGIC: [u8; 8] = *b"SHVISBC\0";
/// Header bytes before the payload.
pub const HEADER_BYTES: usize = 40;
/// Largest cache file read (a 8192² order-8 bake is 17 GB; anything larger is not ours).
pub const MAX_CACHE_FILE_BYTES: u64 = 64 << 30;
/// Environment variable naming the cache directory.
pub const CACHE_DIR_ENV: &str = "SHVIS_CACHE_DIR";
/// Kind tag of SH visibility caches.
const KIND_VISIBILITY: u32 = 1;
/// Kind tag of VQ / CPCA fit caches.
const KIND_CLUSTERS: u32 = 2;
/// Kind tag of a derived product's bytes ([`load_or_build_blob`]).
const KIND_BLOB: u32 = 3;
/// Kind tag of SH lightmap bakes.
const KIND_SH_LIGHTMAP: u32 = 4;

/// The cache directory: `$SHVIS_CACHE_DIR` when set and not empty, else `.shvis-cache`
/// in the current directory.
pub fn default_cache_dir() -> PathBuf {
    match std::env::var_os(CACHE_DIR_ENV) {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => PathBuf::from(".shvis-cache"),
    }
}

/// Cache key of a visibility bake of `mesh` at `res`² texels with `settings` (module
/// doc; `settings.progress` does not enter).
pub fn visibility_key(mesh: &Mesh, res: u32, settings: &VisibilitySettings) -> u64 {
    let mut h = Hasher64::default();
    h.write(b"shvis bake cache");
    h.write_u64(u64::from(CACHE_FORMAT_VERSION));
    h.write(b"visibility");
    h.write(env!("SHVIS_BAKE_SOURCE_HASH").as_bytes());
    h.write_u64(u64::from(settings.order.get()));
    h.write_u64(u64::from(settings.rays));
    h.write_u64(settings.seed);
    h.write_u64(u64::from(res));
    h.write_u64(mesh.vertices.len() as u64);
    h.write(bytemuck::cast_slice::<Vertex, u8>(&mesh.vertices));
    h.write_u64(mesh.indices.len() as u64);
    h.write(bytemuck::cast_slice::<u32, u8>(&mesh.indices));
    h.finish()
}

/// Path of the visibility cache file with `key` in `cache_dir`.
pub fn visibility_cache_path(cache_dir: &Path, key: u64) -> PathBuf {
    cache_dir.join(format!("visibility-{key:016x}.bin"))
}

/// The visibility map of `mesh` at `res`² texels with `settings` from the cache in
/// `cache_dir` when a valid file is there, else from `bake()`, which is then written to
/// the cache (module doc). A missing file is silent; a damaged or mismatching one is
/// logged with `log::warn!` and rebuilt.
///
/// # Errors
/// [`BakeError::Io`] when the cache directory or file cannot be written (the baked map
/// is lost then: point `SHVIS_CACHE_DIR` somewhere writable).
pub fn load_or_bake_visibility(
    cache_dir: &Path,
    mesh: &Mesh,
    res: u32,
    settings: &VisibilitySettings,
    bake: impl FnOnce() -> VisibilityMap,
) -> Result<VisibilityMap, BakeError> {
    let key = visibility_key(mesh, res, settings);
    let path = visibility_cache_path(cache_dir, key);
    load_or_build(
        &path,
        "visibility",
        |bytes| decode_visibility(bytes, key, res, settings.order),
        || Ok(bake()),
        |map| encode_visibility(map, key),
    )
}

/// Cache key of the SH lightmap bake of `scene` at `res`² texels under `lighting` with
/// `settings`, fitting `fits` (module doc; `settings.progress` does not enter).
pub fn sh_lightmap_key(
    scene: &Scene,
    res: u32,
    lighting: &BakeLighting<'_>,
    settings: &ShLightmapSettings,
    fits: &[SampleFit],
) -> u64 {
    let mut h = Hasher64::default();
    h.write(b"shvis bake cache");
    h.write_u64(u64::from(CACHE_FORMAT_VERSION));
    h.write(b"sh lightmap");
    h.write(env!("SHVIS_BAKE_SOURCE_HASH").as_bytes());
    for v in [res, settings.rays, settings.bounces] {
        h.write_u64(u64::from(v));
    }
    h.write_u64(settings.seed);
    let mesh = &scene.mesh;
    h.write_u64(mesh.vertices.len() as u64);
    h.write(bytemuck::cast_slice::<Vertex, u8>(&mesh.vertices));
    h.write_u64(mesh.indices.len() as u64);
    h.write(bytemuck::cast_slice::<u32, u8>(&mesh.indices));
    let albedo = &scene.material.albedo;
    h.write_u64(u64::from(albedo.width));
    h.write_u64(u64::from(albedo.height));
    h.write(bytemuck::cast_slice::<[u8; 4], u8>(&albedo.texels));
    match lighting {
        BakeLighting::Sh(coeffs) => {
            h.write(b"sh");
            h.write_u64(coeffs.len() as u64);
            for c in coeffs.iter().flatten() {
                h.write(&c.to_le_bytes());
            }
        }
        BakeLighting::Pixels(map) => {
            h.write(b"pixels");
            h.write_u64(u64::from(map.width));
            h.write_u64(u64::from(map.height));
            h.write(bytemuck::cast_slice::<[f32; 3], u8>(&map.texels));
        }
    }
    h.write_u64(fits.len() as u64);
    for fit in fits {
        h.write(format!("{fit:?};").as_bytes());
    }
    h.finish()
}

/// The SH lightmap under `key` (its `res`² texels, fitting `fits`) from the cache in
/// `cache_dir` when a valid file is there, else from `bake()`, which is then written to the
/// cache (module doc: a missing file is silent, a damaged or mismatching one a warning and
/// a rebake).
///
/// # Errors
/// The cache file cannot be written.
pub fn load_or_bake_sh_lightmap(
    cache_dir: &Path,
    key: u64,
    res: u32,
    fits: &[SampleFit],
    bake: impl FnOnce() -> ShLightmap,
) -> Result<ShLightmap, BakeError> {
    let path = cache_dir.join(format!("shlmap-{key:016x}.bin"));
    load_or_build(
        &path,
        "SH lightmap",
        |bytes| decode_sh_lightmap(bytes, key, res, fits),
        || Ok(bake()),
        |map| encode_sh_lightmap(map, key),
    )
}

/// The bytes of a cache file holding `map` under `key`. Payload, little-endian: res,
/// bounces, environment (0 sh, 1 pixels) as u32; rays traced u64, seconds f64; then
/// res² × 27 coefficients, res² covered (u8), res² × 3 normal, res² × 9 frame (columns),
/// the bounce source (u64 count, × 3), the RNM lobes (u64 count, × 9), all f32; the fits'
/// negative counts (u64 count, u64 each), values (u64 count, f16 bits) and scales (u64
/// count, f32).
pub fn encode_sh_lightmap(map: &ShLightmap, key: u64) -> Vec<u8> {
    // The file is built in one buffer of its exact size: the bake's largest allocation
    // after the map itself, so it must not double while it grows.
    let fitted = &map.fitted;
    let float_count = map.coeffs.iter().map(|c| c.len()).sum::<usize>()
        + 3 * map.normal.len()
        + 9 * map.frame.len()
        + 3 * map.bounce_source.len()
        + map
            .basis_irradiance
            .iter()
            .map(|b| 3 * b.len())
            .sum::<usize>()
        + fitted.scales.len();
    let payload_bytes = 12
        + 16
        + 4 * float_count
        + map.covered.len()
        + 5 * 8
        + 8 * fitted.negative.len()
        + 2 * fitted.values.len();
    let mut p = header_first(payload_bytes);
    let env = match map.env {
        BakeEnv::Sh => 0u32,
        BakeEnv::Pixels => 1,
    };
    for v in [map.res, map.bounces, env] {
        p.extend_from_slice(&v.to_le_bytes());
    }
    p.extend_from_slice(&map.stats.rays_traced.to_le_bytes());
    p.extend_from_slice(&map.stats.seconds.to_le_bytes());
    let floats = |p: &mut Vec<u8>, values: &mut dyn Iterator<Item = f32>| {
        for v in values {
            p.extend_from_slice(&v.to_le_bytes());
        }
    };
    floats(&mut p, &mut map.coeffs.iter().flatten().copied());
    p.extend(map.covered.iter().map(|&c| u8::from(c)));
    floats(&mut p, &mut map.normal.iter().flat_map(|n| n.to_array()));
    floats(
        &mut p,
        &mut map.frame.iter().flat_map(|f| f.to_cols_array()),
    );
    p.extend_from_slice(&(map.bounce_source.len() as u64).to_le_bytes());
    floats(
        &mut p,
        &mut map.bounce_source.iter().flat_map(|e| e.to_array()),
    );
    p.extend_from_slice(&(map.basis_irradiance.len() as u64).to_le_bytes());
    floats(
        &mut p,
        &mut map
            .basis_irradiance
            .iter()
            .flat_map(|b| b.iter().flat_map(|e| e.to_array())),
    );
    p.extend_from_slice(&(fitted.negative.len() as u64).to_le_bytes());
    for n in &fitted.negative {
        p.extend_from_slice(&n.to_le_bytes());
    }
    p.extend_from_slice(&(fitted.values.len() as u64).to_le_bytes());
    for v in &fitted.values {
        p.extend_from_slice(&v.to_bits().to_le_bytes());
    }
    p.extend_from_slice(&(fitted.scales.len() as u64).to_le_bytes());
    floats(&mut p, &mut fitted.scales.iter().copied());
    debug_assert_eq!(p.len(), HEADER_BYTES + payload_bytes);
    finish_header(KIND_SH_LIGHTMAP, key, p)
}

/// Parses an SH lightmap cache file of `res`² texels fitting `fits`; `Err` says what is
/// wrong, in a few words.
pub fn decode_sh_lightmap(
    bytes: &[u8],
    key: u64,
    res: u32,
    fits: &[SampleFit],
) -> Result<ShLightmap, String> {
    let mut r = Reader {
        bytes: payload_of(bytes, KIND_SH_LIGHTMAP, "SH lightmap", key)?,
    };
    let (stored_res, bounces, env) = (r.u32()?, r.u32()?, r.u32()?);
    if stored_res != res {
        return Err(format!("resolution {stored_res}, expected {res}"));
    }
    let env = match env {
        0 => BakeEnv::Sh,
        1 => BakeEnv::Pixels,
        other => return Err(format!("environment tag {other}")),
    };
    let rays_traced = r.u64()?;
    let seconds = f64::from_bits(r.u64()?);
    let texels = (res as usize).pow(2);
    let coeffs = r.f32s(texels * 27)?;
    let covered = r.coverage(texels)?;
    let covered_count = covered.iter().filter(|&&c| c).count();
    let normal = r.f32s(texels * 3)?;
    let frame = r.f32s(texels * 9)?;
    let count = |r: &mut Reader<'_>, limit: usize| -> Result<usize, String> {
        let n = r.u64()?;
        usize::try_from(n)
            .ok()
            .filter(|&n| n <= limit)
            .ok_or_else(|| format!("count {n} is more than {limit}"))
    };
    let n = count(&mut r, texels)?;
    let bounce_source = r.f32s(n * 3)?;
    let n = count(&mut r, texels)?;
    let basis_irradiance = r.f32s(n * 9)?;
    let n = count(&mut r, fits.len())?;
    if n != fits.len() {
        return Err(format!("{n} fits, expected {}", fits.len()));
    }
    let negative = (0..n).map(|_| r.u64()).collect::<Result<Vec<_>, _>>()?;
    let per_texel: usize = fits.iter().map(|f| f.stored_values()).sum();
    let n = count(&mut r, texels * per_texel)?;
    let values: Vec<half::f16> = r
        .take(n * 2)?
        .chunks_exact(2)
        .map(|b| half::f16::from_bits(u16::from_le_bytes([b[0], b[1]])))
        .collect();
    let n = count(&mut r, texels * fits.len())?;
    let scales = r.f32s(n)?;
    if !r.bytes.is_empty() {
        return Err(format!("{} bytes after the payload", r.bytes.len()));
    }
    // What a bake of these settings writes: every count follows from the coverage, and
    // every value is finite.
    let expected = [
        (
            "bounce sources",
            bounce_source.len() / 3,
            if bounces > 0 { texels } else { 0 },
        ),
        ("basis irradiances", basis_irradiance.len() / 9, texels),
        ("fitted values", values.len(), covered_count * per_texel),
        (
            "block scales",
            scales.len(),
            if per_texel > 0 {
                covered_count * fits.len()
            } else {
                0
            },
        ),
    ];
    for (what, count, expected) in expected {
        if count != expected {
            return Err(format!("{count} {what}, expected {expected}"));
        }
    }
    let floats = [
        ("coefficient", &coeffs),
        ("normal", &normal),
        ("frame", &frame),
        ("bounce source", &bounce_source),
        ("basis irradiance", &basis_irradiance),
        ("block scale", &scales),
    ];
    for (what, values) in floats {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!("{what} value {i} is {}, not finite", values[i]));
        }
    }
    if let Some(i) = values.iter().position(|v: &half::f16| !v.is_finite()) {
        return Err(format!("fitted value {i} is {}, not finite", values[i]));
    }
    Ok(ShLightmap {
        res,
        bounces,
        coeffs: coeffs.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        covered,
        normal: normal.chunks_exact(3).map(glam::Vec3::from_slice).collect(),
        frame: frame
            .chunks_exact(9)
            .map(glam::Mat3::from_cols_slice)
            .collect(),
        bounce_source: bounce_source
            .chunks_exact(3)
            .map(glam::Vec3::from_slice)
            .collect(),
        basis_irradiance: basis_irradiance
            .chunks_exact(9)
            .map(|b| [0, 1, 2].map(|k| glam::Vec3::from_slice(&b[3 * k..3 * k + 3])))
            .collect(),
        fitted: FittedBases {
            fits: fits.to_vec(),
            negative,
            values,
            scales,
        },
        env,
        stats: super::BakeStats {
            rays_traced,
            seconds,
        },
    })
}

/// A derived product (`what`: "dx11 blocks") cached under `key` in `cache_dir` as
/// `{prefix}-{key:016x}.bin`, `encode`'s bytes with the header and checks of every cache
/// file; `decode` reads them back and checks what they claim. `build` makes the product
/// when the file is missing or either check fails (a warning), and the file is rewritten.
///
/// # Errors
/// `build`'s, or the cache file cannot be written.
pub fn load_or_build_blob<T>(
    cache_dir: &Path,
    prefix: &str,
    what: &str,
    key: u64,
    decode: impl FnOnce(&[u8]) -> Result<T, String>,
    build: impl FnOnce() -> Result<T, BakeError>,
    encode: impl FnOnce(&T) -> Vec<u8>,
) -> Result<T, BakeError> {
    let path = cache_dir.join(format!("{prefix}-{key:016x}.bin"));
    load_or_build(
        &path,
        what,
        |bytes| payload_of(bytes, KIND_BLOB, what, key).and_then(decode),
        build,
        |value| with_header(KIND_BLOB, key, &encode(value)),
    )
}

/// A blob cache file of `payload` under `key`, as [`load_or_build_blob`] writes it (tests
/// that forge a file whose header checks but whose content lies).
#[cfg(test)]
pub(crate) fn blob_file(key: u64, payload: &[u8]) -> Vec<u8> {
    with_header(KIND_BLOB, key, payload)
}

/// The value in the cache file at `path` when it decodes, else `build()`'s, written there
/// (module doc: a missing file is silent, a bad one a warning and a rebuild).
fn load_or_build<T>(
    path: &Path,
    what: &str,
    decode: impl FnOnce(&[u8]) -> Result<T, String>,
    build: impl FnOnce() -> Result<T, BakeError>,
    encode: impl FnOnce(&T) -> Vec<u8>,
) -> Result<T, BakeError> {
    if let Some(dir) = path.parent() {
        files::remove_stale_temps(dir);
    }
    // A file larger than the memory left is not read: ours fit when they were written.
    let too_large = fs::metadata(path).ok().and_then(|m| {
        crate::limits::available_memory()
            .filter(|&available| m.len() > available)
            .map(|available| (m.len(), available))
    });
    // Ok(None): no file yet. Errors name the file.
    let read = match too_large {
        Some((size, available)) => Err(format!(
            "{}: {size} bytes, more than the {available} bytes of memory available",
            path.display()
        )),
        None => match files::read_bounded(path, MAX_CACHE_FILE_BYTES, "a bake cache file") {
            Ok(bytes) => Ok(Some(bytes)),
            Err(files::FileError::Io { cause, .. })
                if cause.kind() == std::io::ErrorKind::NotFound =>
            {
                Ok(None)
            }
            Err(e) => Err(e.to_string()),
        },
    };
    match read {
        Ok(Some(bytes)) => match decode(&bytes) {
            Ok(value) => {
                log::info!("{what}: using cache {}", path.display());
                return Ok(value);
            }
            Err(e) => log::warn!("bake cache {}: {e}; rebuilding", path.display()),
        },
        Ok(None) => log::debug!("bake cache {}: not there yet", path.display()),
        Err(e) => log::warn!("bake cache {e}; rebuilding"),
    }
    let value = build()?;
    write_atomically(path, &encode(&value))?;
    Ok(value)
}

/// Cache key of a VQ / CPCA fit (`bake::cluster::fit`) of `vis` with `k` clusters of `m`
/// vectors, `clustering` and `seed`: the fit's inputs, the visibility by content.
pub fn clusters_key(
    vis: &VisibilityMap,
    k: usize,
    m: usize,
    clustering: Clustering,
    seed: u64,
) -> u64 {
    let mut h = Hasher64::default();
    h.write(b"shvis bake cache");
    h.write_u64(u64::from(CACHE_FORMAT_VERSION));
    h.write(b"clusters");
    h.write(env!("SHVIS_BAKE_SOURCE_HASH").as_bytes());
    h.write_u64(u64::from(cluster::FIT_VERSION));
    h.write_u64(k as u64);
    h.write_u64(m as u64);
    h.write_u64(clustering_tag(clustering).into());
    h.write_u64(seed);
    h.write_u64(u64::from(vis.res));
    h.write_u64(u64::from(vis.order.get()));
    h.write(bytemuck::cast_slice::<f32, u8>(&vis.coeffs));
    h.write(
        &vis.covered
            .iter()
            .map(|&c| u8::from(c))
            .collect::<Vec<u8>>(),
    );
    h.finish()
}

fn clustering_tag(c: Clustering) -> u32 {
    match c {
        Clustering::KMeans => 0,
        Clustering::Iterative => 1,
    }
}

/// A VQ / CPCA fit of `vis` from the cache in `cache_dir`, else from `fit()`, then cached
/// (`clusters-{key:016x}.bin`; as [`load_or_bake_visibility`]).
///
/// # Errors
/// `fit()`'s, or [`BakeError::Io`] when the file cannot be written.
pub fn load_or_fit_clusters(
    cache_dir: &Path,
    vis: &VisibilityMap,
    k: usize,
    m: usize,
    clustering: Clustering,
    seed: u64,
    fit: impl FnOnce() -> Result<ClusteredModel, BakeError>,
) -> Result<ClusteredModel, BakeError> {
    let key = clusters_key(vis, k, m, clustering, seed);
    let path = cache_dir.join(format!("clusters-{key:016x}.bin"));
    load_or_build(
        &path,
        "clusters",
        |bytes| decode_clusters(bytes, key, vis, k, m, clustering),
        fit,
        |model| encode_clusters(model, key),
    )
}

/// The bytes of a cache file holding `model` under `key`. Payload: k, m, n, res,
/// clustering, iterations (u32 each); per cluster its members (u64), mean (n f64) and
/// basis (m·n f64); res² cluster indices (u32); res²·m weights (f32).
pub fn encode_clusters(model: &ClusteredModel, key: u64) -> Vec<u8> {
    let n = model.order.coeff_count();
    let mut p = Vec::new();
    for v in [
        model.clusters.len() as u32,
        model.m as u32,
        n as u32,
        model.res,
        clustering_tag(model.clustering),
        model.iterations,
    ] {
        p.extend_from_slice(&v.to_le_bytes());
    }
    for c in &model.clusters {
        p.extend_from_slice(&(c.members as u64).to_le_bytes());
        for x in c.mean.iter().chain(c.basis.iter().flatten()) {
            p.extend_from_slice(&x.to_le_bytes());
        }
    }
    for c in &model.cluster_of {
        p.extend_from_slice(&c.to_le_bytes());
    }
    for w in &model.weights {
        p.extend_from_slice(&w.to_le_bytes());
    }
    with_header(KIND_CLUSTERS, key, &p)
}

/// Parses a clusters cache file for a fit of `vis` with `k` × `m` and `clustering`.
pub fn decode_clusters(
    bytes: &[u8],
    key: u64,
    vis: &VisibilityMap,
    k: usize,
    m: usize,
    clustering: Clustering,
) -> Result<ClusteredModel, String> {
    let payload = payload_of(bytes, KIND_CLUSTERS, "clusters", key)?;
    let mut r = Reader { bytes: payload };
    let n = vis.order.coeff_count();
    let head: Vec<u32> = (0..6).map(|_| r.u32()).collect::<Result<_, _>>()?;
    let want = [
        k as u32,
        m as u32,
        n as u32,
        vis.res,
        clustering_tag(clustering),
    ];
    if head[..5] != want {
        return Err(format!(
            "holds k, m, n, res, clustering {:?}, expected {want:?}",
            &head[..5]
        ));
    }
    let mut clusters = Vec::with_capacity(k);
    for _ in 0..k {
        let members = r.u64()? as usize;
        let mean = r.f64s(n)?;
        let basis = (0..m).map(|_| r.f64s(n)).collect::<Result<_, _>>()?;
        clusters.push(cluster::Cluster {
            mean,
            basis,
            members,
        });
    }
    let texels = (vis.res as usize).pow(2);
    let cluster_of: Vec<u32> = (0..texels).map(|_| r.u32()).collect::<Result<_, _>>()?;
    if cluster_of.iter().any(|&c| c as usize >= k) {
        return Err("a cluster index is out of range".into());
    }
    let weights = r.f32s(texels * m)?;
    let finite = clusters
        .iter()
        .flat_map(|c| c.mean.iter().chain(c.basis.iter().flatten()))
        .all(|x| x.is_finite())
        && weights.iter().all(|w| w.is_finite());
    if !finite {
        return Err("a mean, basis vector or weight is not finite".into());
    }
    if !r.bytes.is_empty() {
        return Err(format!(
            "{} unexpected bytes after the payload",
            r.bytes.len()
        ));
    }
    Ok(ClusteredModel {
        order: vis.order,
        res: vis.res,
        clustering,
        m,
        clusters,
        cluster_of,
        weights,
        iterations: head[5],
    })
}

/// The bytes of a cache file holding `map` under `key`.
pub fn encode_visibility(map: &VisibilityMap, key: u64) -> Vec<u8> {
    let texels = map.covered.len();
    let mut payload = Vec::with_capacity(24 + 4 * map.coeffs.len() + 5 * texels);
    payload.extend_from_slice(&map.res.to_le_bytes());
    payload.extend_from_slice(&map.order.get().to_le_bytes());
    payload.extend_from_slice(&map.stats.rays_traced.to_le_bytes());
    payload.extend_from_slice(&map.stats.seconds.to_le_bytes());
    for c in &map.coeffs {
        payload.extend_from_slice(&c.to_le_bytes());
    }
    payload.extend(map.covered.iter().map(|&c| u8::from(c)));
    for a in &map.ao {
        payload.extend_from_slice(&a.to_le_bytes());
    }
    with_header(KIND_VISIBILITY, key, &payload)
}

/// A cache file: the header (module doc) of `kind` and `key`, then `payload`.
fn with_header(kind: u32, key: u64, payload: &[u8]) -> Vec<u8> {
    let mut file = header_first(payload.len());
    file.extend_from_slice(payload);
    finish_header(kind, key, file)
}

/// A cache file's buffer before its payload is appended: room for the header, then
/// capacity for `payload_bytes`.
fn header_first(payload_bytes: usize) -> Vec<u8> {
    let mut file = Vec::with_capacity(HEADER_BYTES + payload_bytes);
    file.resize(HEADER_BYTES, 0);
    file
}

/// Fills in the header (module doc) of `file`, whose payload follows [`header_first`]'s room.
fn finish_header(kind: u32, key: u64, mut file: Vec<u8>) -> Vec<u8> {
    let payload = &file[HEADER_BYTES..];
    let (length, hash) = (payload.len() as u64, hash64(payload));
    let mut header = Vec::with_capacity(HEADER_BYTES);
    header.extend_from_slice(&CACHE_MAGIC);
    header.extend_from_slice(&CACHE_FORMAT_VERSION.to_le_bytes());
    header.extend_from_slice(&kind.to_le_bytes());
    header.extend_from_slice(&key.to_le_bytes());
    header.extend_from_slice(&length.to_le_bytes());
    header.extend_from_slice(&hash.to_le_bytes());
    file[..HEADER_BYTES].copy_from_slice(&header);
    file
}

/// Little-endian reader over a byte slice that reports short reads.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if self.bytes.len() < n {
            return Err(format!(
                "payload ends early ({} bytes short)",
                n - self.bytes.len()
            ));
        }
        let (head, tail) = self.bytes.split_at(n);
        self.bytes = tail;
        Ok(head)
    }
    fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self) -> Result<u64, String> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes([
            b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7],
        ]))
    }
    fn f64s(&mut self, n: usize) -> Result<Vec<f64>, String> {
        let bytes = self.take(n.checked_mul(8).ok_or("size overflows")?)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
            .collect())
    }
    /// `texels` coverage flags, one byte each, 0 or 1.
    fn coverage(&mut self, texels: usize) -> Result<Vec<bool>, String> {
        let flags = self.take(texels)?;
        if let Some(i) = flags.iter().position(|&b| b > 1) {
            return Err(format!(
                "coverage flag {} at texel {i} is not 0 or 1",
                flags[i]
            ));
        }
        Ok(flags.iter().map(|&b| b != 0).collect())
    }

    fn f32s(&mut self, n: usize) -> Result<Vec<f32>, String> {
        let bytes = self.take(n.checked_mul(4).ok_or("size overflows")?)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}

/// The payload of a cache file of `kind` (`kind_name` for the message) under `key`, once
/// magic, version, kind, key, length and checksum all match.
fn payload_of<'a>(
    bytes: &'a [u8],
    kind_tag: u32,
    kind_name: &str,
    key: u64,
) -> Result<&'a [u8], String> {
    if bytes.len() < HEADER_BYTES {
        return Err(format!(
            "truncated header ({} of {HEADER_BYTES} bytes)",
            bytes.len()
        ));
    }
    let mut header = Reader {
        bytes: &bytes[..HEADER_BYTES],
    };
    if header.take(8)? != CACHE_MAGIC {
        return Err("wrong magic (not a shvis bake cache)".into());
    }
    let version = header.u32()?;
    if version != CACHE_FORMAT_VERSION {
        return Err(format!(
            "format version {version}, expected {CACHE_FORMAT_VERSION}"
        ));
    }
    let kind = header.u32()?;
    if kind != kind_tag {
        return Err(format!("kind {kind}, expected {kind_tag} ({kind_name})"));
    }
    let stored_key = header.u64()?;
    if stored_key != key {
        return Err(format!("key {stored_key:016x}, expected {key:016x}"));
    }
    let length = header.u64()?;
    let payload = &bytes[HEADER_BYTES..];
    if length != payload.len() as u64 {
        return Err(format!(
            "payload length {} bytes, header says {length}",
            payload.len()
        ));
    }
    let checksum = header.u64()?;
    let actual = hash64(payload);
    if checksum != actual {
        return Err(format!(
            "payload checksum {actual:016x}, header says {checksum:016x}"
        ));
    }
    Ok(payload)
}

/// Parses a cache file; `Err` says what is wrong, in a few words.
pub fn decode_visibility(
    bytes: &[u8],
    key: u64,
    res: u32,
    order: Order,
) -> Result<VisibilityMap, String> {
    let payload = payload_of(bytes, KIND_VISIBILITY, "visibility", key)?;
    let mut r = Reader { bytes: payload };
    let (file_res, file_order) = (r.u32()?, r.u32()?);
    if file_res != res || file_order != order.get() {
        return Err(format!(
            "holds res {file_res} order {file_order}, expected res {res} order {}",
            order.get()
        ));
    }
    let rays_traced = r.u64()?;
    let seconds = f64::from_bits(r.u64()?);
    let texels = (res as usize) * (res as usize);
    let coeffs = r.f32s(texels * order.coeff_count())?;
    let covered = r.coverage(texels)?;
    let ao = r.f32s(texels)?;
    if !r.bytes.is_empty() {
        return Err(format!(
            "{} unexpected bytes after the payload",
            r.bytes.len()
        ));
    }
    // Values a bake can produce: the projection of a visibility function (|c| ≤ √(4π)·‖y‖,
    // far below 1e3) and AO in [0, 1].
    if let Some(i) = coeffs.iter().position(|c| !c.is_finite() || c.abs() > 1e3) {
        return Err(format!(
            "coefficient {i} is {}, not what a bake produces",
            coeffs[i]
        ));
    }
    if let Some(i) = ao.iter().position(|a| !(0.0..=1.0).contains(a)) {
        return Err(format!("AO of texel {i} is {}, outside [0, 1]", ao[i]));
    }
    Ok(VisibilityMap {
        res,
        order,
        coeffs,
        covered,
        ao,
        stats: super::BakeStats {
            rays_traced,
            seconds,
        },
    })
}

/// Writes a cache file atomically ([`files::write_atomic`]), creating the directory.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), BakeError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    fs::create_dir_all(dir).map_err(|source| BakeError::Io {
        path: dir.to_path_buf(),
        action: "create the cache directory",
        source,
    })?;
    // A cache entry is the cache's own file: a link there to anything but a regular file
    // (a device, a dangling name) is damage, replaced by the entry rather than written
    // through as an output would be.
    if fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
        && !fs::metadata(path).is_ok_and(|m| m.is_file())
    {
        fs::remove_file(path).map_err(|source| BakeError::Io {
            path: path.to_path_buf(),
            action: "replace the damaged cache link",
            source,
        })?;
    }
    files::write_atomic(path, bytes).map_err(BakeError::File)
}

/// Writes `map` into `dir` as f32 OpenEXR images for inspection: `visibility_{k}.exr`
/// holds coefficients 4k, 4k+1, 4k+2, 4k+3 (flat index l(l+1)+m) in channels R, G, B, A
/// (zero past order²), `ao.exr` the AO in channel Y. Image row y is lightmap row y
/// (v = 0 at the top, DESIGN §1).
///
/// The folder is written as one run ([`files::replace_dir`]), `manifest.json` (`settings`,
/// each file's size and hash; [`files::Manifest`]) last: a killed or failed bake leaves the
/// earlier bake whole or none, and no layer of an earlier bake of a higher order survives
/// beside a new one. An existing `dir` must be empty or an earlier bake ([`is_bake_dir`]).
///
/// # Errors
/// [`BakeError::Exr`] when an image cannot be encoded, [`BakeError::File`] when `dir` is
/// not an earlier bake's or a file cannot be written.
pub fn write_exr_layers(
    dir: &Path,
    map: &VisibilityMap,
    settings: serde_json::Value,
) -> Result<(), BakeError> {
    use crate::files::EXR_ENCODING;
    use exr::prelude::{Image, SpecificChannels, WritableImage};
    let res = map.res as usize;
    let n2 = map.order.coeff_count();
    let exr_err = |name: &str, e: exr::error::Error| BakeError::Exr {
        path: dir.join(name),
        detail: e.to_string(),
    };
    // One file per job on rayon's pool (each encoded single-threaded): exr's own
    // per-file parallelism starts threads for every file and leaves most of them idle.
    let encode_layer = |k: usize| -> Result<(String, Vec<u8>), BakeError> {
        let name = format!("visibility_{k}.exr");
        let c = |x: usize, y: usize, j: usize| {
            let i = 4 * k + j;
            if i < n2 {
                map.coeffs[(y * res + x) * n2 + i]
            } else {
                0.0
            }
        };
        let channels = SpecificChannels::rgba(|p: exr::math::Vec2<usize>| {
            let (x, y) = (p.0, p.1);
            (c(x, y, 0), c(x, y, 1), c(x, y, 2), c(x, y, 3))
        });
        let mut bytes = std::io::Cursor::new(Vec::new());
        Image::from_encoded_channels((res, res), EXR_ENCODING, channels)
            .write()
            .non_parallel()
            .to_buffered(&mut bytes)
            .map_err(|e| exr_err(&name, e))?;
        Ok((name, bytes.into_inner()))
    };
    let encode_ao = || -> Result<(String, Vec<u8>), BakeError> {
        let name = "ao.exr".to_string();
        let channels = SpecificChannels::build()
            .with_channel("Y")
            .with_pixel_fn(|p: exr::math::Vec2<usize>| (map.ao[p.1 * res + p.0],));
        let mut bytes = std::io::Cursor::new(Vec::new());
        Image::from_encoded_channels((res, res), EXR_ENCODING, channels)
            .write()
            .non_parallel()
            .to_buffered(&mut bytes)
            .map_err(|e| exr_err(&name, e))?;
        Ok((name, bytes.into_inner()))
    };
    let layers = n2.div_ceil(4);
    let encoded: Vec<(String, Vec<u8>)> = (0..=layers)
        .into_par_iter()
        .map(|k| {
            if k < layers {
                encode_layer(k)
            } else {
                encode_ao()
            }
        })
        .collect::<Result<_, _>>()?;
    files::replace_dir(dir, "--out", is_bake_dir, |tmp| {
        for (name, bytes) in &encoded {
            files::write_atomic(&tmp.join(name), bytes)?;
        }
        files::Manifest::new(
            settings,
            encoded.iter().map(|(n, b)| (n.clone(), b.as_slice())),
        )
        .write(tmp)
    })?;
    Ok(())
}

/// Whether `dir` holds nothing but files [`write_exr_layers`] writes (`visibility_K.exr`,
/// `ao.exr`, `manifest.json`) and temporaries of killed writes: an earlier bake's folder,
/// which a bake may replace whole.
pub fn is_bake_dir(dir: &Path) -> bool {
    fs::read_dir(dir).is_ok_and(|entries| {
        entries.flatten().all(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let is_file = e.file_type().is_ok_and(|t| t.is_file());
            is_file
                && (name == "ao.exr"
                    || name == files::MANIFEST_NAME
                    || (name.starts_with('.') && name.contains(".tmp-"))
                    || name
                        .strip_prefix("visibility_")
                        .and_then(|k| k.strip_suffix(".exr"))
                        .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit())))
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_layers_are_byte_identical_for_any_thread_count() {
        let (res, order) = (70u32, Order::SIX);
        let n = order.coeff_count();
        let texels = (res * res) as usize;
        let map = VisibilityMap {
            res,
            order,
            // Incompressible-looking values, so RLE blocks differ in size.
            coeffs: (0..texels * n)
                .map(|i| (crate::files::splitmix64(i as u64) >> 40) as f32 * 1e-7)
                .collect(),
            covered: vec![true; texels],
            ao: (0..texels).map(|i| (i % 97) as f32 / 97.0).collect(),
            stats: super::super::BakeStats::default(),
        };
        let root = std::env::temp_dir().join(format!("shvis-exr-order-{}", std::process::id()));
        let mut files: Vec<Vec<(String, Vec<u8>)>> = Vec::new();
        for threads in [1, 3] {
            let dir = root.join(threads.to_string());
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| write_exr_layers(&dir, &map, serde_json::json!({})))
                .unwrap();
            let mut entries: Vec<(String, Vec<u8>)> = fs::read_dir(&dir)
                .unwrap()
                .map(|e| {
                    let path = e.unwrap().path();
                    let name = path.file_name().unwrap().to_string_lossy().into_owned();
                    (name, fs::read(&path).unwrap())
                })
                .collect();
            entries.sort();
            files.push(entries);
        }
        let _ = fs::remove_dir_all(&root);
        assert_eq!(
            files[0].len(),
            11,
            "9 coefficient layers, AO and the manifest"
        );
        for (a, b) in files[0].iter().zip(&files[1]) {
            assert_eq!(a.0, b.0);
            assert!(a.1 == b.1, "{} differs between 1 and 3 threads", a.0);
        }
    }

    /// An SH lightmap with every field filled (two fits), 4² texels.
    fn sh_lightmap() -> ShLightmap {
        use crate::sh::hbasis::HBasisSize;
        let texels = 16;
        let fits = vec![
            SampleFit::HBasis(HBasisSize::H4),
            SampleFit::AmbientCube(crate::sh::ambient_cube::CubeFit::Projection),
        ];
        let per_texel: usize = fits.iter().map(|f| f.stored_values()).sum();
        let covered: Vec<bool> = (0..texels).map(|t| t % 3 != 0).collect();
        let covered_count = covered.iter().filter(|&&c| c).count();
        ShLightmap {
            res: 4,
            bounces: 2,
            coeffs: (0..texels * 9).map(|i| [i as f32, -0.5, 1e5]).collect(),
            covered,
            normal: vec![glam::Vec3::Y; texels],
            frame: vec![glam::Mat3::from_cols_array(&[1., 2., 3., 4., 5., 6., 7., 8., 9.]); texels],
            bounce_source: (0..texels).map(|t| glam::Vec3::splat(t as f32)).collect(),
            basis_irradiance: vec![[glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z]; texels],
            fitted: FittedBases {
                fits,
                negative: vec![3, 0],
                values: (0..covered_count * per_texel)
                    .map(|i| half::f16::from_f32(i as f32 / 7.0))
                    .collect(),
                scales: (0..covered_count * 2)
                    .map(|i| (1 << (i % 5)) as f32)
                    .collect(),
            },
            env: BakeEnv::Pixels,
            stats: super::super::BakeStats {
                rays_traced: 12345,
                seconds: 1.5,
            },
        }
    }

    #[test]
    fn sh_lightmaps_round_trip_and_a_damaged_or_foreign_file_is_rejected() {
        let map = sh_lightmap();
        let fits = map.fitted.fits.clone();
        let bytes = encode_sh_lightmap(&map, 42);
        assert_eq!(decode_sh_lightmap(&bytes, 42, 4, &fits), Ok(map.clone()));
        assert!(
            decode_sh_lightmap(&bytes, 43, 4, &fits).is_err(),
            "another key"
        );
        assert!(
            decode_sh_lightmap(&bytes, 42, 8, &fits).is_err(),
            "another resolution"
        );
        assert!(
            decode_sh_lightmap(&bytes, 42, 4, &fits[..1]).is_err(),
            "other fits"
        );
        let mut damaged = bytes.clone();
        let last = damaged.len() - 1;
        damaged[last] ^= 1;
        assert!(
            decode_sh_lightmap(&damaged, 42, 4, &fits).is_err(),
            "checksum"
        );
        assert!(decode_sh_lightmap(&bytes[..bytes.len() - 4], 42, 4, &fits).is_err());
        // A payload that lies about its counts, re-checksummed so only the parse can tell.
        let payload = &bytes[HEADER_BYTES..];
        let mut lying = payload.to_vec();
        // After res, bounces, env (u32), rays (u64), seconds (f64) and the per-texel arrays.
        let at = 28 + 16 * 27 * 4 + 16 + 16 * 12 + 16 * 36;
        lying[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        let forged = with_header(KIND_SH_LIGHTMAP, 42, &lying);
        assert!(
            decode_sh_lightmap(&forged, 42, 4, &fits).is_err(),
            "a count past the texels"
        );
        // Files whose checksum holds but whose content no bake of these settings writes.
        let refused = |map: &ShLightmap, why: &str| {
            let e = decode_sh_lightmap(&encode_sh_lightmap(map, 42), 42, 4, &fits).expect_err(why);
            assert!(e.contains(why), "{why}: {e}");
        };
        let mut fewer = map.clone();
        fewer.fitted.values.truncate(3);
        refused(&fewer, "fitted values");
        let mut no_scales = map.clone();
        no_scales.fitted.scales.clear();
        refused(&no_scales, "block scales");
        let mut no_source = map.clone();
        no_source.bounce_source.clear();
        refused(&no_source, "bounce sources");
        let mut not_finite = map.clone();
        not_finite.coeffs[5][1] = f32::NAN;
        refused(&not_finite, "not finite");
        let mut infinite_value = map.clone();
        infinite_value.fitted.values[0] = half::f16::INFINITY;
        refused(&infinite_value, "not finite");
    }

    /// The key follows what the bake reads: the lighting, the fits, the settings.
    #[test]
    fn the_sh_lightmap_key_changes_with_the_lighting_fits_and_settings() {
        let scene = crate::scene::patio::build(64).unwrap();
        let settings = ShLightmapSettings {
            rays: 64,
            seed: 0,
            bounces: 1,
            progress: false,
        };
        let sh = vec![[1.0f64; 3]; 9];
        let mut other = sh.clone();
        other[4][1] = 1.5;
        let fit = [SampleFit::HBasis(crate::sh::hbasis::HBasisSize::H4)];
        let key = |l: &BakeLighting<'_>, s: &ShLightmapSettings, f: &[SampleFit]| {
            sh_lightmap_key(&scene, 64, l, s, f)
        };
        let base = key(&BakeLighting::Sh(&sh), &settings, &fit);
        assert_eq!(
            base,
            key(
                &BakeLighting::Sh(&sh),
                &ShLightmapSettings {
                    progress: true,
                    ..settings
                },
                &fit
            )
        );
        for changed in [
            key(&BakeLighting::Sh(&other), &settings, &fit),
            key(&BakeLighting::Sh(&sh), &settings, &[]),
            key(
                &BakeLighting::Sh(&sh),
                &ShLightmapSettings {
                    bounces: 2,
                    ..settings
                },
                &fit,
            ),
            key(
                &BakeLighting::Sh(&sh),
                &ShLightmapSettings {
                    seed: 1,
                    ..settings
                },
                &fit,
            ),
            key(
                &BakeLighting::Pixels(&crate::env::EnvMap::from_fn(8, 4, |_| [1.0; 3])),
                &settings,
                &fit,
            ),
        ] {
            assert_ne!(base, changed);
        }
    }

    #[test]
    fn cluster_fits_round_trip_and_a_damaged_or_foreign_file_is_rejected() {
        let (res, order) = (6u32, Order::TWO);
        let texels = (res * res) as usize;
        let vis = VisibilityMap {
            res,
            order,
            coeffs: (0..texels * 4)
                .map(|i| ((i * 37 % 11) as f32).sin())
                .collect(),
            covered: (0..texels).map(|t| t % 7 != 0).collect(),
            ao: vec![1.0; texels],
            stats: Default::default(),
        };
        let model = cluster::fit(&vis, 3, 2, Clustering::Iterative, 5).unwrap();
        let key = clusters_key(&vis, 3, 2, Clustering::Iterative, 5);
        let bytes = encode_clusters(&model, key);
        let back = decode_clusters(&bytes, key, &vis, 3, 2, Clustering::Iterative).unwrap();
        assert_eq!(back, model);
        // A flipped payload byte fails the checksum; other parameters have other keys.
        let mut bad = bytes.clone();
        bad[HEADER_BYTES + 30] ^= 1;
        let e = decode_clusters(&bad, key, &vis, 3, 2, Clustering::Iterative).unwrap_err();
        assert!(e.contains("checksum"), "{e}");
        assert_ne!(key, clusters_key(&vis, 3, 2, Clustering::KMeans, 5));
        assert_ne!(key, clusters_key(&vis, 3, 2, Clustering::Iterative, 6));
        let e = decode_clusters(&bytes, key, &vis, 4, 2, Clustering::Iterative).unwrap_err();
        assert!(e.contains("expected"), "{e}");
        // Through the directory: fitted once, then read back; a corrupt file is refitted.
        let dir = std::env::temp_dir().join(format!("shvis-cluster-cache-{}", std::process::id()));
        let fit = || cluster::fit(&vis, 3, 2, Clustering::Iterative, 5);
        let first = load_or_fit_clusters(&dir, &vis, 3, 2, Clustering::Iterative, 5, fit).unwrap();
        let cached = load_or_fit_clusters(&dir, &vis, 3, 2, Clustering::Iterative, 5, || {
            panic!("a valid cache must not be refitted")
        })
        .unwrap();
        assert_eq!(first, cached);
        let file = dir.join(format!("clusters-{key:016x}.bin"));
        std::fs::write(&file, &bad).unwrap();
        let refit = load_or_fit_clusters(&dir, &vis, 3, 2, Clustering::Iterative, 5, fit).unwrap();
        assert_eq!(refit, model);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
