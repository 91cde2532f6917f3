//! What the probe's points draw over and read: its scene (a screen-filling grid of
//! triangle pairs, [`base_grid`] its side for the triangles' asked-for area), the meshes of
//! every grid uploaded with their shading loads, and the textures and uniform block the
//! microbenchmark shaders ([`super::shaders`]) bind.

use std::sync::Arc;

use ash::vk;
use glam::Vec2;

use super::ProbeSettings;
use crate::cost::Kind;
use crate::gpu::{Buffer, Context, GpuError, Image, ImageDesc, MeshBuffers, Sampler, SamplerKind};
use crate::render::{FrameSettings, SceneGpu, ShadingLoad};
use crate::scene::{Mesh, Scene, Vertex};

/// Textures per lookup kind (as dx9 binds separate textures; arrays get as many layers):
/// every lookup of a probe point reads its own texture, as every per-texel group and table
/// of a technique is its own (repeated reads of one texture hit its cache and cost less).
pub(super) const TEXTURES: u32 = 16;

/// Side of the probe's textures.
pub(super) const TEXTURE_SIDE: u32 = 512;

/// Side of the probe's block-compressed arrays (smaller than [`TEXTURE_SIDE`]: encoding
/// takes time, and a lookup's decode costs the same whatever the texture's size).
pub(super) const BLOCK_SIDE: u32 = 256;

/// Uniform vec4s in the probe's block.
pub(super) const UNIFORM_VEC4S: u32 = 256;

/// The probe's scene: a quad filling the screen (or its left half) from a camera at the
/// origin, split into `grid`² quads, lightmap UVs over [0, 1]² across it, material UVs at
/// ≈ 2.7 texels of a 512² map per pixel.
fn probe_scene(width: u32, height: u32, left_half: bool, grid: u32) -> Scene {
    let aspect = width as f32 / height as f32;
    let (x0, x1) = (-1.2 * aspect, if left_half { 0.0 } else { 1.2 * aspect });
    let material_scale = 2.7 * width as f32 / TEXTURE_SIDE as f32;
    let vertex = |x: f32, y: f32| {
        let lightmap = Vec2::new((x / aspect + 1.0) * 0.5, (1.0 - y) * 0.5);
        Vertex {
            position: [x, y, -1.0],
            normal: [0.0, 0.0, 1.0],
            tangent: [1.0, 0.0, 0.0, 1.0],
            uv_material: (lightmap * material_scale).to_array(),
            uv_lightmap: lightmap.to_array(),
            albedo_tint: [1.0; 3],
        }
    };
    // columns × grid quads, two triangles each; the left half keeps the quads' size. Grid 0:
    // one triangle of zero area (a frame that shades nothing).
    let columns = if left_half { grid / 2 } else { grid };
    let mut mesh = Mesh::default();
    if grid == 0 {
        mesh.vertices = vec![vertex(0.0, 0.0); 3];
        mesh.indices = vec![0, 1, 2];
    } else {
        for j in 0..=grid {
            for i in 0..=columns {
                let (fx, fy) = (i as f32 / columns as f32, j as f32 / grid as f32);
                mesh.vertices
                    .push(vertex(x0 + (x1 - x0) * fx, -1.2 + 2.4 * fy));
            }
        }
        for j in 0..grid {
            for i in 0..columns {
                let a = j * (columns + 1) + i;
                let (b, c, d) = (a + 1, a + columns + 2, a + columns + 1);
                mesh.indices.extend([a, b, c, a, c, d]);
            }
        }
    }
    Scene::flat_view("probe", mesh)
}

/// The probe's textures and uniform block.
pub(super) struct ProbeResources {
    pub(super) bilinear: Vec<Image>,
    /// For the dependent lookups: the size of a dx9 table strip (9 spheres of 2 × 32²).
    pub(super) tables: Vec<Image>,
    pub(super) trilinear: Vec<Image>,
    pub(super) trilinear_wide: Vec<Image>,
    pub(super) trilinear_srgb: Vec<Image>,
    pub(super) array: Image,
    /// The same pattern block-compressed, [`BLOCK_SIDE`]², one array per BC format the
    /// device samples (none where it samples none).
    pub(super) block_arrays: Vec<(Kind, Image)>,
    pub(super) cube_array: Image,
    pub(super) uniforms: Buffer,
}

fn probe_resources(ctx: &Arc<Context>) -> Result<ProbeResources, GpuError> {
    let side = TEXTURE_SIDE;
    // A smooth pseudo-random pattern (RGBA16F halves, RGBA8 bytes).
    let value = |i: u32, x: u32, y: u32| -> f32 {
        let h = crate::bake::directions::splitmix64(
            u64::from(i) << 40 | u64::from(y) << 20 | u64::from(x),
        );
        crate::bake::directions::unit_f64(h) as f32
    };
    let halves = |i: u32, s: u32| -> Vec<u8> {
        (0..s * s * 4)
            .flat_map(|j| half::f16::from_f32(value(i, j % (s * 4), j / (s * 4))).to_le_bytes())
            .collect()
    };
    let f16 = vk::Format::R16G16B16A16_SFLOAT;
    let bilinear = (0..TEXTURES)
        .map(|i| {
            let data = halves(i, side);
            Image::with_data(
                ctx,
                &ImageDesc::texture_2d(f16, side, side),
                &[vec![data.as_slice()]],
                &format!("probe.bilinear{i}"),
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (table_w, table_h) = (9 * 2 * 32, 32);
    let tables = (0..TEXTURES)
        .map(|i| {
            let data: Vec<u8> = (0..table_w * table_h * 4)
                .flat_map(|j| {
                    half::f16::from_f32(value(i, j % (table_w * 4), j / (table_w * 4)))
                        .to_le_bytes()
                })
                .collect();
            Image::with_data(
                ctx,
                &ImageDesc::texture_2d(f16, table_w, table_h),
                &[vec![data.as_slice()]],
                &format!("probe.table{i}"),
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    // The same texels, as RGBA8 (material textures: the normal map's UNORM, the albedo's
    // sRGB) and as RGBA32F (NDF moment maps).
    let mip_chains = |format: vk::Format, name: &str| {
        let wide = format == crate::ndf::MOMENT_FORMAT;
        (0..TEXTURES)
            .map(|i| {
                let texels: Vec<[f32; 4]> = (0..side * side)
                    .map(|j| std::array::from_fn(|c| value(i, (j % side) * 4 + c as u32, j / side)))
                    .collect();
                let levels = crate::scene::mip::box_mip_levels(side, side, texels);
                let bytes: Vec<Vec<u8>> = levels
                    .iter()
                    .map(|(_, _, t)| {
                        if wide {
                            bytemuck::cast_slice(t).to_vec()
                        } else {
                            t.iter()
                                .flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
                                .collect()
                        }
                    })
                    .collect();
                let data: Vec<Vec<&[u8]>> = bytes.iter().map(|b| vec![b.as_slice()]).collect();
                Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(format, side, side).mip_levels(levels.len() as u32),
                    &data,
                    &format!("probe.{name}{i}"),
                )
            })
            .collect::<Result<Vec<_>, _>>()
    };
    let trilinear = mip_chains(vk::Format::R8G8B8A8_UNORM, "trilinear")?;
    let trilinear_wide = mip_chains(crate::ndf::MOMENT_FORMAT, "trilinear_wide")?;
    let trilinear_srgb = mip_chains(vk::Format::R8G8B8A8_SRGB, "trilinear_srgb")?;
    let layers: Vec<Vec<u8>> = (0..TEXTURES).map(|i| halves(i, side)).collect();
    let array = Image::with_data(
        ctx,
        &ImageDesc::texture_2d_array(f16, side, side, TEXTURES),
        &[layers.iter().map(Vec::as_slice).collect()],
        "probe.array",
    )?;
    let block_arrays = block_arrays(ctx, &value)?;
    let cube_side = 32;
    let faces: Vec<Vec<u8>> = (0..6 * TEXTURES).map(|i| halves(i, cube_side)).collect();
    let cube_array = Image::with_data(
        ctx,
        &ImageDesc::texture_cube_array(f16, cube_side, TEXTURES),
        &[faces.iter().map(Vec::as_slice).collect()],
        "probe.cube_array",
    )?;
    let block: Vec<f32> = (0..UNIFORM_VEC4S * 4)
        .map(|i| if i < 4 { 0.999 } else { 1e-3 * (i % 7) as f32 })
        .collect();
    let uniforms = Buffer::with_data(
        ctx,
        bytemuck::cast_slice(&block),
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        "probe.uniforms",
    )?;
    Ok(ProbeResources {
        bilinear,
        tables,
        trilinear,
        trilinear_wide,
        trilinear_srgb,
        array,
        block_arrays,
        cube_array,
        uniforms,
    })
}

impl ProbeResources {
    /// The block-compressed array of BC kind `kind`, where the device samples its format.
    pub(super) fn block_array(&self, kind: Kind) -> Option<&Image> {
        self.block_arrays
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, image)| image)
    }
}

/// [`TEXTURES`] layers of each BC format the device samples, at the dx11 path's qualities
/// (`technique::block`), of a smooth pattern with a little of `value`'s noise: the encoders
/// pick a block's mode by its content, the decode's cost follows the mode, and lightmaps are
/// smooth within their charts (on lavapipe a white-noise pattern's blocks cost 10–25 % more
/// to decode than a lightmap's).
fn block_arrays(
    ctx: &Arc<Context>,
    value: &dyn Fn(u32, u32, u32) -> f32,
) -> Result<Vec<(Kind, Image)>, GpuError> {
    use crate::bake::block;
    let side = BLOCK_SIDE;
    let texel = |i: u32, j: u32, c: u32| {
        let (x, y) = (j % side, j / side);
        let phase = i as f32 * 0.7 + c as f32 * 1.3;
        let wave = (x as f32 / 37.0 + phase).sin() * (y as f32 / 29.0 - phase).cos();
        0.5 + 0.4 * wave + 0.05 * (value(i, x * 4 + c, y) - 0.5)
    };
    let mut arrays = Vec::new();
    let sampled = Kind::ALL
        .into_iter()
        .filter_map(|k| k.block_format().map(|f| (k, f)))
        .filter(|&(_, f)| ctx.supports_block_format(f));
    for (kind, format) in sampled {
        let layers: Vec<Vec<u8>> = (0..TEXTURES)
            .map(|i| {
                let texels = 0..side * side;
                let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                match kind {
                    Kind::Bc6hArray => {
                        let rgb: Vec<[f32; 3]> = texels
                            .map(|j| std::array::from_fn(|c| texel(i, j, c as u32)))
                            .collect();
                        block::encode_bc6h(&rgb, side, crate::technique::block::NORM_QUALITY).0
                    }
                    Kind::Bc7Array => {
                        let rgba: Vec<[u8; 4]> = texels
                            .map(|j| std::array::from_fn(|c| byte(texel(i, j, c as u32))))
                            .collect();
                        block::encode_bc7_at(
                            &rgba,
                            side,
                            true,
                            crate::technique::block::RATIO_QUALITY,
                        )
                    }
                    _ => {
                        let r: Vec<u8> = texels.map(|j| byte(texel(i, j, 0))).collect();
                        block::encode_bc4(&r, side)
                    }
                }
            })
            .collect();
        let image = Image::with_data(
            ctx,
            &ImageDesc::texture_2d_array(format, side, side, TEXTURES),
            &[layers.iter().map(Vec::as_slice).collect()],
            &format!("probe.{}", format!("{kind:?}").to_lowercase()),
        )?;
        arrays.push((kind, image));
    }
    Ok(arrays)
}

/// The probe's scene on the GPU at `s`'s size, over a `base`² grid of triangle pairs.
pub(super) fn probe_target(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
    base: u32,
) -> Result<SceneGpu, GpuError> {
    SceneGpu::new(
        ctx,
        &probe_scene(s.width, s.height, false, base),
        &FrameSettings {
            width: s.width,
            height: s.height,
            ..FrameSettings::default()
        },
    )
}

/// The textures and uniforms every probe point binds, and the lightmap-like sampler.
pub(super) fn point_resources(ctx: &Arc<Context>) -> Result<(ProbeResources, Sampler), GpuError> {
    Ok((
        probe_resources(ctx)?,
        Sampler::new(ctx, SamplerKind::LinearClamp, "probe.linear")?,
    ))
}

/// Uploads the probe's mesh over the screen (or its left half) with a `grid`² grid of
/// triangle pairs (0: the mesh that shades nothing).
pub(super) fn upload_probe_mesh(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
    left_half: bool,
    grid: u32,
) -> Result<(MeshBuffers, Mesh), GpuError> {
    let m = probe_scene(s.width, s.height, left_half, grid).mesh;
    let buffers = MeshBuffers::new(
        ctx,
        bytemuck::cast_slice(&m.vertices),
        &m.indices,
        &format!("probe.mesh{}{grid}", if left_half { ".half" } else { "" }),
    )?;
    Ok((buffers, m))
}

/// The shading load of each of `meshes`, keyed by its buffers' address.
pub(super) fn shading_loads<'m>(
    ctx: &Arc<Context>,
    gpu: &SceneGpu,
    meshes: impl Iterator<Item = &'m (MeshBuffers, Mesh)>,
) -> Result<Vec<(*const MeshBuffers, ShadingLoad)>, GpuError> {
    let mut loads = Vec::new();
    for (buffers, m) in meshes {
        let load = gpu.shading_load(ctx, Some((buffers, m)))?;
        loads.push((buffers as *const MeshBuffers, load));
    }
    Ok(loads)
}

/// Side of the grid whose triangles cover `triangle_pixels` each on a `width` × `height`
/// screen (the grid spans 1.2 × the view each way), even so that the half screen halves it.
pub(super) fn base_grid(width: u32, height: u32, triangle_pixels: f64) -> u32 {
    let cells = 0.5 * 1.44 * f64::from(width) * f64::from(height) / triangle_pixels.max(1.0);
    let half = (0.5 * cells.sqrt()).round().clamp(1.0, 128.0) as u32;
    2 * half
}
