//! `pcaMv` / `pcaMvE`: per-vertex PCA weights (`bake::vertex_pca`). The weights
//! ride in the vertex buffer after the scene's attributes — ⌈M/4⌉ RGBA8 UNORM groups at
//! locations 6… (glsl/scene/mesh.vert) — and the rasterizer interpolates them; the fragment
//! shader is `pcaMw`'s (glsl/technique/pcaw.frag with SHVIS_VERTEX_WEIGHTS) over the same
//! uniform block, so `pcaMv` against `pcaMw` is vertices against lightmap texels and
//! nothing else. The technique draws its own (possibly subdivided) mesh of the same
//! surface. Vertex streams and uniforms exist on dx9 and dx10 (dx11 refuses it:
//! `Refusal::VertexStream`); no texture is bound beyond the material's.

use std::sync::Arc;

use ash::vk;

use super::ShaderReads;
use super::family::{Description, Family, Form, Refusal, Storage};
use super::finish::TextureSlot;
use super::lighting::{LightingData, LightingSet, Recipe};
use super::spec::{BakeNeeds, ReferenceModel};
use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups};
use super::{
    HwPath, Inputs, ShaderVariant, Technique, TechniqueError, TechniqueGpu, TechniqueStats,
};
use crate::bake::vertex_pca::VertexPca;
use crate::gpu::{
    self, Context, MeshBuffers, MeshPipeline, MeshPipelineDesc, VertexLayout, layout,
};
use crate::render::SceneGpu;
use crate::scene::Vertex;

/// Vertex location of the first weight group (after the scene's attributes 0–5).
pub const FIRST_WEIGHT_LOCATION: u32 = 6;

/// The fragment shader of `pcaMv`.
pub fn fragment_shader(m: u32) -> ShaderVariant {
    ShaderVariant {
        path: "technique/pcaw.frag",
        defines: vec![
            ("PCA_GROUPS", m.div_ceil(VALUES_PER_TEXEL as u32)),
            ("VERTEX_WEIGHTS", 1),
        ],
    }
}

/// The longest edge in metres of a `pcaMvE` name's E cm.
pub fn max_edge_m(max_edge_cm: Option<u32>) -> Option<f32> {
    max_edge_cm.map(|cm| cm as f32 / 100.0)
}

/// Whether `bake` is the vertex bake of `pcaMv` with `m` weights and `max_edge_cm`.
pub fn is_bake_of(bake: &VertexPca, m: u32, max_edge_cm: Option<u32>) -> bool {
    bake.m == m as usize && bake.max_edge == max_edge_m(max_edge_cm)
}

/// The vertex bake `max_edge_cm` names among `inputs.vertex_pca`.
pub fn find<'a>(
    inputs: &Inputs<'a>,
    m: u32,
    max_edge_cm: Option<u32>,
    label: &str,
) -> Result<&'a VertexPca, TechniqueError> {
    inputs
        .vertex_pca
        .iter()
        .find(|v| is_bake_of(v, m, max_edge_cm))
        .ok_or_else(|| TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "needs the visibility baked at the mesh's vertices for {m} weights{} \
                 (Prepared::bake_vertex_pca)",
                max_edge_cm.map_or(String::new(), |cm| format!(", edges ≤ {cm} cm"))
            ),
        })
}

/// No per-texel data; the recipe is `pcaMw`'s over the lightmap's quantized basis.
pub(crate) fn prepare(
    m: u32,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let model = inputs.pca.ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: "needs the PCA of the visibility bake".into(),
    })?;
    let q = super::pca::quantized_prefix(model, m as usize);
    let none = TexelGroups::new::<u8>(vk::Format::R8G8B8A8_UNORM, 0, &[], format!("{label}.none"));
    Ok((
        none,
        Recipe::Pca {
            order: model.order,
            table: None,
            basis: q.basis,
            mean: q.mean,
        },
    ))
}

/// The scene's vertex layout with the weight groups appended.
fn weighted_layout(base: &VertexLayout, groups: u32) -> VertexLayout {
    let mut attributes = base.attributes.clone();
    let offset = std::mem::size_of::<Vertex>() as u32;
    attributes.extend((0..groups).map(|g| {
        (
            FIRST_WEIGHT_LOCATION + g,
            vk::Format::R8G8B8A8_UNORM,
            offset + 4 * g,
        )
    }));
    VertexLayout {
        stride: offset + 4 * groups,
        attributes,
    }
}

/// Interleaves each vertex with its weight groups.
fn interleave(bake: &VertexPca, groups: usize) -> Vec<u8> {
    let n = bake.mesh.vertices.len();
    let packed = pack_groups(n, bake.m, |v, k| bake.weights_unorm[v * bake.m + k]);
    let mut bytes = Vec::with_capacity(n * (std::mem::size_of::<Vertex>() + 4 * groups));
    for (v, vertex) in bake.mesh.vertices.iter().enumerate() {
        bytes.extend_from_slice(bytemuck::bytes_of(vertex));
        for group in &packed {
            bytes.extend_from_slice(&group[4 * v..4 * v + 4]);
        }
    }
    bytes
}

/// Builds `pcaMv` with `sets` copies of its uniform block (`super::finish`'s job for the
/// texel techniques, here over the technique's own mesh and vertex stream).
pub(crate) fn finish(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
    lighting: &LightingData,
    sets: usize,
) -> Result<TechniqueGpu, TechniqueError> {
    let Technique::PcaVertex(PcaVertex { m, max_edge_cm }) = technique else {
        unreachable!("vertex::finish builds pcaMv only");
    };
    let label = format!("{technique}.{path}");
    super::finish::check_uniform_size(ctx, lighting.params.len(), &label)?;
    let bake = find(inputs, m, max_edge_cm, &label)?;
    let groups = m.div_ceil(VALUES_PER_TEXEL as u32);
    let mesh = MeshBuffers::new(
        ctx,
        &interleave(bake, groups as usize),
        &bake.mesh.indices,
        &format!("{label}.mesh"),
    )?;
    let vertex_layout = weighted_layout(scene.vertex_layout(), groups);
    let vertex = gpu::compile_glsl(
        "scene/mesh.vert",
        gpu::ShaderStage::Vertex,
        &[
            ("GBUFFER", scene.specular().is_some() as u32),
            ("VERTEX_WEIGHT_GROUPS", groups),
        ],
    )?;
    let fragment = super::finish::compile_fragment(technique, path, scene, &lighting.defines)?;
    let mut built = Vec::with_capacity(sets);
    for set in 0..sets.max(1) {
        let suffix = super::finish::set_suffix(set);
        let params = super::finish::params_buffer(ctx, &lighting.params, &label, &suffix)?;
        let resources = super::finish::base_resources(scene, &params, path);
        let pipeline = MeshPipeline::new(
            ctx,
            scene.target(),
            &MeshPipelineDesc {
                name: &format!("{label}{suffix}"),
                vertex_spirv: &vertex,
                fragment_spirv: &fragment,
                vertex_layout: &vertex_layout,
                resources: &resources,
                depth_test: true,
                additive: false,
            },
        )?;
        drop(resources);
        built.push(LightingSet {
            pipeline,
            params,
            tables: Vec::new(),
            own_per_texel: None,
            defines: lighting.defines.clone(),
        });
    }
    let mut stats = TechniqueStats {
        texel_bytes: (bake.mesh.vertices.len() * 4 * groups as usize) as u64,
        table_bytes: lighting.params.len() as u64,
        textures_bound: layout::MATERIAL_TEXTURES,
        lookups_per_pixel: layout::MATERIAL_TEXTURES,
    };
    super::finish::add_specular_stats(scene, path, &mut stats);
    let mut gpu = TechniqueGpu::new(
        ctx,
        technique,
        path,
        stats,
        super::finish::TextureSlot::per_texel(Vec::new()),
        None,
        fragment,
        built,
    );
    gpu.mesh = Some(mesh);
    Ok(gpu)
}

/// What a frame of `pcaMv`'s own mesh shades (`SceneGpu::shading_load`, the cost model's
/// coverage): its finer mesh keeps more of the device's lanes busy per pixel than the
/// scene's. Drawn once in the scene's vertex format; `None` for the other techniques.
pub fn own_mesh_load(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    inputs: &Inputs<'_>,
) -> Result<Option<crate::render::ShadingLoad>, TechniqueError> {
    let Technique::PcaVertex(PcaVertex { m, max_edge_cm }) = technique else {
        return Ok(None);
    };
    let label = format!("{technique}");
    let bake = find(inputs, m, max_edge_cm, &label)?;
    let plain = MeshBuffers::new(
        ctx,
        bytemuck::cast_slice(&bake.mesh.vertices),
        &bake.mesh.indices,
        &format!("{label}.mesh.count"),
    )?;
    Ok(Some(scene.shading_load(ctx, Some((&plain, &bake.mesh)))?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_follow_each_vertex_in_the_stream() {
        let vertex = Vertex::default();
        let bake = VertexPca {
            max_edge: None,
            mesh: crate::scene::Mesh {
                vertices: vec![vertex; 2],
                indices: vec![0, 1, 0],
            },
            m: 5,
            weights_unorm: (1..=10).collect(),
            clamped: 0,
            rms_error: 0.0,
            rays_traced: 0,
        };
        let bytes = interleave(&bake, 2);
        let stride = std::mem::size_of::<Vertex>() + 8;
        assert_eq!(bytes.len(), 2 * stride);
        let w = &bytes[stride + stride - 8..];
        assert_eq!(w, &[6, 7, 8, 9, 10, 0, 0, 0]);
        let base = VertexLayout {
            stride: std::mem::size_of::<Vertex>() as u32,
            attributes: vec![(0, vk::Format::R32G32B32_SFLOAT, 0)],
        };
        let l = weighted_layout(&base, 2);
        assert_eq!(l.stride as usize, stride);
        assert_eq!(l.attributes.last().unwrap().0, FIRST_WEIGHT_LOCATION + 1);
    }
}

/// The `pcaMv` / `pcaMvE` family: the first M weights of the lightmap's PCA basis baked at
/// the vertices of the mesh (subdivided so no edge exceeds E cm; none: as authored), in a
/// vertex stream, interpolated and shaded as `pcaMw`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PcaVertex {
    pub m: u32,
    pub max_edge_cm: Option<u32>,
}

/// Edge lengths (cm) a `pcaMvE` name may subdivide the mesh to.
pub const VERTEX_EDGES_CM: &[u32] = &[100, 50, 25, 10];

impl Family for PcaVertex {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "pcaMv, pcaMvE",
        what: "PCA weights baked at mesh vertices (edges ≤ E cm), interpolated, shaded as pcaMw",
        paper: "Iwanicki & Sloan §4 (per-vertex)",
        in_paper_table: false,
    };
    const EXAMPLE: PcaVertex = PcaVertex {
        m: 12,
        max_edge_cm: None,
    };

    fn members() -> Vec<PcaVertex> {
        super::pca::vector_counts()
            .flat_map(|m| {
                std::iter::once(None)
                    .chain(VERTEX_EDGES_CM.iter().copied().map(Some))
                    .map(move |max_edge_cm| PcaVertex { m, max_edge_cm })
            })
            .collect()
    }

    fn table_rows() -> Vec<PcaVertex> {
        vec![
            PcaVertex::EXAMPLE,
            PcaVertex {
                m: 12,
                max_edge_cm: Some(25),
            },
        ]
    }

    fn headline(path: HwPath) -> Vec<PcaVertex> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![PcaVertex {
                m: 12,
                max_edge_cm: Some(25),
            }],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        match self.max_edge_cm {
            Some(cm) => format!("pca{}v{cm}", self.m),
            None => format!("pca{}v", self.m),
        }
    }

    fn paper_ms(self) -> Option<f64> {
        None
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds {
            visibility: Some(crate::sh::Order::SIX),
            pca_vectors: Some(self.m),
            vertex_pca: Some((self.m, self.max_edge_cm)),
            ..BakeNeeds::default()
        }
    }

    fn reference(self) -> ReferenceModel {
        ReferenceModel::Direct
    }

    fn dynamic_lighting(self) -> bool {
        true
    }

    fn ndf_variant(self) -> Option<Technique> {
        None
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => Ok(Form {
                storage: Storage::VertexStream,
                ..Form::TEXTURES
            }),
            HwPath::Dx11 => Err(Refusal::VertexStream),
        }
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        prepare(self.m, inputs, label)
    }

    fn extra_slot(
        self,
        _: &Arc<Context>,
        _: HwPath,
        _: &Inputs<'_>,
        _: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError> {
        Ok(None)
    }

    fn fragment_shader(self) -> ShaderVariant {
        fragment_shader(self.m)
    }

    fn reads(self) -> ShaderReads {
        ShaderReads::PLAIN
    }

    fn options_tag(self, _: &()) -> Option<String> {
        None
    }

    fn sample_fit(self, _: &()) -> Option<crate::sh::samples::SampleFit> {
        None
    }

    fn values(self) -> Option<super::values::ValueMap> {
        None
    }
}
