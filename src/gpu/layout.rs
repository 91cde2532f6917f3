//! Numbers and structs shared with GLSL: one source of truth. `shader.rs` hands every
//! constant here to shaderc as a macro `SHVIS_<NAME>`, so no shader repeats a binding or
//! a limit; `#[repr(C)]` structs mirror std140 blocks with their offsets asserted.

/// At most 16 textures per draw on `dx9`, albedo and normal map included (DESIGN §2).
pub const DX9_MAX_TEXTURES: u32 = 16;

/// Set 0 bindings, the same for every technique.
pub const BINDING_FRAME: u32 = 0;
pub const BINDING_ALBEDO: u32 = 1;
pub const BINDING_NORMAL_MAP: u32 = 2;
/// The technique's own uniform block.
pub const BINDING_TECHNIQUE_PARAMS: u32 = 3;
/// The technique's first texture; further ones follow consecutively.
pub const BINDING_TECHNIQUE_TEXTURE0: u32 = 4;

/// The scene's specular material term (`--specular`, glsl/include/specular.glsl): its
/// uniform block and, for the NDF filterings, the moment maps. Above every technique's own
/// bindings (`technique::finish` checks).
pub const BINDING_SPECULAR_PARAMS: u32 = 16;
pub const BINDING_SPECULAR_MOMENTS: u32 = 17;

/// Textures every technique binds besides its own (albedo, normal map).
pub const MATERIAL_TEXTURES: u32 = 2;

/// Macros given to every shader compile.
pub const SHADER_MACROS: &[(&str, u32)] = &[
    ("DX9_MAX_TEXTURES", DX9_MAX_TEXTURES),
    ("BINDING_FRAME", BINDING_FRAME),
    ("BINDING_ALBEDO", BINDING_ALBEDO),
    ("BINDING_NORMAL_MAP", BINDING_NORMAL_MAP),
    ("BINDING_TECHNIQUE_PARAMS", BINDING_TECHNIQUE_PARAMS),
    ("BINDING_TECHNIQUE_TEXTURE0", BINDING_TECHNIQUE_TEXTURE0),
    ("BINDING_SPECULAR_PARAMS", BINDING_SPECULAR_PARAMS),
    ("BINDING_SPECULAR_MOMENTS", BINDING_SPECULAR_MOMENTS),
];

/// Uniform block `FrameParams` of glsl/include/common.glsl (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FrameParams {
    /// offset 0: clip ← world (Vulkan clip space, y down).
    pub clip_from_world: [[f32; 4]; 4],
    /// offset 64: camera position in world space (w unused).
    pub camera_position: [f32; 4],
    /// offset 80: material normal-map scale (glTF normalTexture.scale); 0 = flat normals.
    pub normal_scale: f32,
    pub _pad: [f32; 3],
}
const _: () = assert!(std::mem::offset_of!(FrameParams, camera_position) == 64);
const _: () = assert!(std::mem::offset_of!(FrameParams, normal_scale) == 80);
const _: () = assert!(std::mem::size_of::<FrameParams>() == 96);
