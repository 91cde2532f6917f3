//! Numbers and structs shared with GLSL: one source of truth. `shader.rs` hands every
//! constant here to shaderc as a macro `SHVIS_<NAME>`, so no shader repeats a binding or
//! a limit; `#[repr(C)]` structs mirror std140 blocks.
//!
//! It owns the Rust half of the contract with the shaders' blocks: [`GlslBlock`], the
//! layout a struct writes its block with (implemented by [`glsl_block!`] from the struct's
//! fields, each named as the GLSL member it fills), and [`BlockLayout`], that layout as a
//! value, which `reflect::layout_mismatches` holds to the block compiled shaders declare
//! (tests/contract.rs). And it owns the form of a shader id ([`ShaderIds`]): a macro that
//! selects one of a set of named values, each value given to the shaders as its own macro,
//! so that the numbers exist in Rust alone.

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

/// One member of a block as the Rust side writes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemberLayout {
    /// The GLSL member's name (the Rust field's, where a struct writes it).
    pub name: &'static str,
    /// Bytes from the block's start.
    pub offset: usize,
    /// Bytes it takes, or `None` for an array of vec4s whose length the shader's defines
    /// set (written from a slice): then only its offset is held to the shader's.
    pub size: Option<usize>,
}

/// A uniform or push-constant block as the Rust side writes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BlockLayout {
    /// The GLSL block's type name (`SgParams`).
    pub name: &'static str,
    /// Bytes written: the struct's size, or `None` where a member's length follows the
    /// shader's defines.
    pub bytes: Option<usize>,
    /// The members that hold data; padding fields are left out.
    pub members: Vec<MemberLayout>,
}

impl BlockLayout {
    /// A block written as one slice of vec4s: its one member, `member`, at offset 0
    /// (the clustered and weights-only PCA blocks).
    pub fn vec4s(name: &'static str, member: &'static str) -> Self {
        BlockLayout {
            name,
            bytes: None,
            members: vec![MemberLayout {
                name: member,
                offset: 0,
                size: None,
            }],
        }
    }

    /// The same layout under another GLSL block name (a struct that fills blocks of
    /// several shaders).
    pub fn named(self, name: &'static str) -> Self {
        BlockLayout { name, ..self }
    }

    /// With a slice of vec4s, `member`, written after the struct (the NDF filtering's
    /// ambient block after a table technique's).
    pub fn with_vec4s(mut self, member: &'static str) -> Self {
        let offset = self.bytes.unwrap_or_else(|| {
            self.members
                .iter()
                .map(|m| m.offset + m.size.unwrap_or(0))
                .max()
                .unwrap_or(0)
        });
        self.members.push(MemberLayout {
            name: member,
            offset,
            size: None,
        });
        self.bytes = None;
        self
    }
}

/// A `#[repr(C)]` struct that fills a GLSL block: its name there and the members its
/// fields fill ([`glsl_block!`] implements it).
pub trait GlslBlock: Sized {
    /// The GLSL block's type name.
    const GLSL_NAME: &'static str;

    /// The fields that fill the block's members, named as the members, with their
    /// offsets and sizes.
    fn members() -> Vec<MemberLayout>;

    /// The whole layout: the members and the struct's size.
    fn layout() -> BlockLayout {
        BlockLayout {
            name: Self::GLSL_NAME,
            bytes: Some(std::mem::size_of::<Self>()),
            members: Self::members(),
        }
    }
}

/// Implements [`GlslBlock`] for a `#[repr(C)]`, `bytemuck::Zeroable` struct:
/// `glsl_block!(SgParams = "SgParams" { unscale, lobes });` lists the fields that fill the
/// block, each named as its GLSL member (padding fields are left out); offsets and sizes
/// are the compiler's (`offset_of!`, the field's size).
macro_rules! glsl_block {
    ($ty:ty = $glsl:literal { $($field:ident),* $(,)? }) => {
        impl $crate::gpu::layout::GlslBlock for $ty {
            const GLSL_NAME: &'static str = $glsl;

            fn members() -> Vec<$crate::gpu::layout::MemberLayout> {
                vec![$($crate::gpu::layout::MemberLayout {
                    name: stringify!($field),
                    offset: std::mem::offset_of!($ty, $field),
                    size: Some(std::mem::size_of_val(
                        &<$ty as ::bytemuck::Zeroable>::zeroed().$field,
                    )),
                }),*]
            }
        }
    };
}
pub(crate) use glsl_block;

glsl_block!(FrameParams = "FrameParams" {
    clip_from_world,
    camera_position,
    normal_scale,
});

/// A shader macro that selects one of a set of named ids, e.g. `SHVIS_PER_TEXEL_CODEC`.
/// Every compile that may set it gets each id as a macro of its own (`SHVIS_CODEC_BC4 1`)
/// and the GLSL compares the selector with those names only, never with a number: the
/// numbers exist in Rust alone.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShaderIds {
    /// The selecting macro, without `SHVIS_`.
    pub selector: &'static str,
    /// Each id's macro name, without `SHVIS_`, and its value.
    pub ids: Vec<(&'static str, u32)>,
}
