//! What a compiled shader declares, read off its SPIR-V: its uniform and push-constant
//! blocks, each with its type name, set and binding, and its members' names, offsets and
//! sizes ([`blocks`]); and how they compare with the `#[repr(C)]` structs that fill them
//! ([`layout_mismatches`] against a [`BlockLayout`], `layout::GlslBlock`). Tests hold every
//! mirrored block to its shader this way (tests/contract.rs).
//!
//! It also owns the walk over the instruction stream ([`instructions`]; SPIR-V 1.x §2.3:
//! after a five-word header, each instruction is a word with its length in the high half
//! and its opcode in the low half, then its operands), which the cost model's counting
//! (`crate::cost::spirv`) shares.
//!
//! Names come from the debug names (`OpName`, `OpMemberName`) that [`super::compile_source`]
//! keeps. Sizes are what a member occupies in its block: scalars and vectors their
//! components, a matrix its columns (rows when row-major) times its `MatrixStride`, an
//! array its length times its `ArrayStride`, a nested struct up to the end of its last
//! member — enough for the blocks of `glsl/`.

use std::collections::HashMap;

use super::layout::BlockLayout;

// Opcodes (SPIR-V unified specification, §3.52).
const OP_NAME: u32 = 5;
const OP_MEMBER_NAME: u32 = 6;
const OP_TYPE_INT: u32 = 21;
pub(crate) const OP_TYPE_FLOAT: u32 = 22;
pub(crate) const OP_TYPE_VECTOR: u32 = 23;
pub(crate) const OP_TYPE_MATRIX: u32 = 24;
pub(crate) const OP_TYPE_ARRAY: u32 = 28;
pub(crate) const OP_TYPE_STRUCT: u32 = 30;
pub(crate) const OP_TYPE_POINTER: u32 = 32;
pub(crate) const OP_CONSTANT: u32 = 43;
pub(crate) const OP_VARIABLE: u32 = 59;
const OP_DECORATE: u32 = 71;
const OP_MEMBER_DECORATE: u32 = 72;

// Decorations (§3.20).
const DECORATION_BLOCK: u32 = 2;
const DECORATION_ROW_MAJOR: u32 = 4;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_MATRIX_STRIDE: u32 = 7;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const DECORATION_OFFSET: u32 = 35;

// Storage classes (§3.7).
pub(crate) const STORAGE_UNIFORM: u32 = 2;
pub(crate) const STORAGE_PUSH_CONSTANT: u32 = 9;

/// The instructions of `spirv` after its header, as (opcode, operands). The walk ends
/// where the stream stops making sense (a zero length, or one past the end).
pub fn instructions(spirv: &[u32]) -> impl Iterator<Item = (u32, &[u32])> {
    let mut i = 5;
    std::iter::from_fn(move || {
        let word = *spirv.get(i)?;
        let (len, op) = ((word >> 16) as usize, word & 0xffff);
        if len == 0 || i + len > spirv.len() {
            return None;
        }
        let operands = &spirv[i + 1..i + len];
        i += len;
        Some((op, operands))
    })
}

/// Where a block's data comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockKind {
    /// A uniform buffer (`layout(std140, set, binding) uniform`).
    Uniform,
    /// Push constants (`layout(push_constant) uniform`).
    PushConstant,
}

/// One member of a [`Block`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Member {
    pub name: String,
    /// Bytes from the block's start (the `Offset` decoration).
    pub offset: usize,
    /// Bytes it occupies (module doc).
    pub size: usize,
}

/// A uniform or push-constant block of a shader.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Block {
    /// The block's type name (`SgParams`; empty without debug names).
    pub name: String,
    pub kind: BlockKind,
    /// The `DescriptorSet` and `Binding` decorations (none for push constants).
    pub set: Option<u32>,
    pub binding: Option<u32>,
    pub members: Vec<Member>,
}

impl Block {
    /// Bytes up to the end of its last member.
    pub fn extent(&self) -> usize {
        self.members
            .iter()
            .map(|m| m.offset + m.size)
            .max()
            .unwrap_or(0)
    }
}

/// A type's shape, as far as sizes need it.
#[derive(Clone, Debug)]
enum Type {
    /// Bytes of a scalar.
    Scalar(usize),
    Vector {
        component: u32,
        count: usize,
    },
    Matrix {
        column: u32,
        columns: usize,
    },
    Array {
        element: u32,
        length: u32,
    },
    Struct(Vec<u32>),
}

/// What [`blocks`] gathers in one pass.
#[derive(Default)]
struct Module {
    names: HashMap<u32, String>,
    member_names: HashMap<(u32, u32), String>,
    types: HashMap<u32, Type>,
    constants: HashMap<u32, u32>,
    /// Decorations of an id: decoration → its first operand (0 where it has none).
    decorations: HashMap<u32, HashMap<u32, u32>>,
    member_decorations: HashMap<(u32, u32), HashMap<u32, u32>>,
    /// Pointer type → (storage class, pointee).
    pointers: HashMap<u32, (u32, u32)>,
    /// (variable, pointer type), in the module's order.
    variables: Vec<(u32, u32)>,
}

/// A literal string operand: UTF-8, NUL-terminated, packed little-endian into words.
fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take_while(|&b| b != 0)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

impl Module {
    fn read(spirv: &[u32]) -> Module {
        let mut m = Module::default();
        for (op, w) in instructions(spirv) {
            match op {
                OP_NAME if !w.is_empty() => {
                    m.names.insert(w[0], literal_string(&w[1..]));
                }
                OP_MEMBER_NAME if w.len() >= 2 => {
                    m.member_names.insert((w[0], w[1]), literal_string(&w[2..]));
                }
                OP_TYPE_INT | OP_TYPE_FLOAT if w.len() >= 2 => {
                    m.types.insert(w[0], Type::Scalar(w[1] as usize / 8));
                }
                OP_TYPE_VECTOR if w.len() >= 3 => {
                    let count = w[2] as usize;
                    m.types.insert(
                        w[0],
                        Type::Vector {
                            component: w[1],
                            count,
                        },
                    );
                }
                OP_TYPE_MATRIX if w.len() >= 3 => {
                    let columns = w[2] as usize;
                    m.types.insert(
                        w[0],
                        Type::Matrix {
                            column: w[1],
                            columns,
                        },
                    );
                }
                OP_TYPE_ARRAY if w.len() >= 3 => {
                    m.types.insert(
                        w[0],
                        Type::Array {
                            element: w[1],
                            length: w[2],
                        },
                    );
                }
                OP_TYPE_STRUCT if !w.is_empty() => {
                    m.types.insert(w[0], Type::Struct(w[1..].to_vec()));
                }
                OP_TYPE_POINTER if w.len() >= 3 => {
                    m.pointers.insert(w[0], (w[1], w[2]));
                }
                OP_CONSTANT if w.len() >= 3 => {
                    m.constants.insert(w[1], w[2]);
                }
                OP_VARIABLE if w.len() >= 3 => m.variables.push((w[1], w[0])),
                OP_DECORATE if w.len() >= 2 => {
                    m.decorations
                        .entry(w[0])
                        .or_default()
                        .insert(w[1], w.get(2).copied().unwrap_or(0));
                }
                OP_MEMBER_DECORATE if w.len() >= 3 => {
                    m.member_decorations
                        .entry((w[0], w[1]))
                        .or_default()
                        .insert(w[2], w.get(3).copied().unwrap_or(0));
                }
                _ => {}
            }
        }
        m
    }

    fn decoration(&self, id: u32, decoration: u32) -> Option<u32> {
        self.decorations.get(&id)?.get(&decoration).copied()
    }

    fn member_decoration(&self, ty: u32, member: u32, decoration: u32) -> Option<u32> {
        self.member_decorations
            .get(&(ty, member))?
            .get(&decoration)
            .copied()
    }

    /// Bytes type `ty` occupies in a block; `matrix` is its member's (MatrixStride,
    /// row-major) for matrices and arrays of them.
    fn size(&self, ty: u32, matrix: (Option<u32>, bool)) -> Result<usize, String> {
        let unknown = || format!("type %{ty} is not one the reflection sizes");
        match self.types.get(&ty).ok_or_else(unknown)? {
            Type::Scalar(bytes) => Ok(*bytes),
            Type::Vector { component, count } => Ok(self.size(*component, matrix)? * count),
            Type::Matrix { column, columns } => {
                let (stride, row_major) = matrix;
                let stride = stride.ok_or_else(|| format!("matrix %{ty} has no MatrixStride"))?;
                let lines = if row_major {
                    match self.types.get(column) {
                        Some(Type::Vector { count, .. }) => *count,
                        _ => return Err(unknown()),
                    }
                } else {
                    *columns
                };
                Ok(stride as usize * lines)
            }
            Type::Array { element, length } => {
                let length = self
                    .constants
                    .get(length)
                    .copied()
                    .ok_or_else(|| format!("array %{ty}'s length is not a constant"))?
                    as usize;
                let stride = match self.decoration(ty, DECORATION_ARRAY_STRIDE) {
                    Some(stride) => stride as usize,
                    None => self.size(*element, matrix)?,
                };
                Ok(stride * length)
            }
            Type::Struct(_) => Ok(self
                .members(ty)?
                .iter()
                .map(|m| m.offset + m.size)
                .max()
                .unwrap_or(0)),
        }
    }

    fn members(&self, ty: u32) -> Result<Vec<Member>, String> {
        let Some(Type::Struct(fields)) = self.types.get(&ty) else {
            return Err(format!("type %{ty} is not a struct"));
        };
        (0u32..)
            .zip(fields)
            .map(|(i, &field)| {
                let name = self.member_names.get(&(ty, i)).cloned().unwrap_or_default();
                let offset = self
                    .member_decoration(ty, i, DECORATION_OFFSET)
                    .ok_or_else(|| format!("member {i} ({name}) of %{ty} has no Offset"))?;
                let matrix = (
                    self.member_decoration(ty, i, DECORATION_MATRIX_STRIDE),
                    self.member_decoration(ty, i, DECORATION_ROW_MAJOR)
                        .is_some(),
                );
                let size = self
                    .size(field, matrix)
                    .map_err(|e| format!("member {i} ({name}) of %{ty}: {e}"))?;
                Ok(Member {
                    name,
                    offset: offset as usize,
                    size,
                })
            })
            .collect()
    }
}

/// Every uniform and push-constant block `spirv` declares, in the module's order (storage
/// buffers are left out). Blocks the optimizer found unused are gone from the module and
/// so from the list.
///
/// # Errors
/// A member whose type or offset the reflection cannot read, named with its block.
pub fn blocks(spirv: &[u32]) -> Result<Vec<Block>, String> {
    let module = Module::read(spirv);
    let mut found = Vec::new();
    for &(variable, pointer) in &module.variables {
        let Some(&(storage, pointee)) = module.pointers.get(&pointer) else {
            continue;
        };
        let mut ty = pointee;
        let kind = match storage {
            STORAGE_UNIFORM => BlockKind::Uniform,
            STORAGE_PUSH_CONSTANT => BlockKind::PushConstant,
            _ => continue,
        };
        // An array of blocks (`uniform B { … } b[2]`) declares the block once.
        if let Some(Type::Array { element, .. }) = module.types.get(&ty) {
            ty = *element;
        }
        if module.decoration(ty, DECORATION_BLOCK).is_none() {
            continue; // a `BufferBlock`: a storage buffer in the older form
        }
        let name = module.names.get(&ty).cloned().unwrap_or_default();
        let members = module
            .members(ty)
            .map_err(|e| format!("block {name}: {e}"))?;
        found.push(Block {
            name,
            kind,
            set: module.decoration(variable, DECORATION_DESCRIPTOR_SET),
            binding: module.decoration(variable, DECORATION_BINDING),
            members,
        });
    }
    Ok(found)
}

/// How `block` of `shader` differs from `rust`, the layout the Rust side writes it with,
/// one line per difference naming the shader, the block, the member and both values:
/// a member at another offset or of another size, a member without a Rust field, a Rust
/// field the block lacks (but an array whose length follows the shader's defines, which a
/// variant may leave out), and a Rust struct smaller than the block or larger than its
/// end rounded up to 16 bytes. Empty where they agree.
pub fn layout_mismatches(shader: &str, block: &Block, rust: &BlockLayout) -> Vec<String> {
    let at = format!("{shader}: block {}", block.name);
    let mut problems = Vec::new();
    for member in &block.members {
        let Some(mirror) = rust.members.iter().find(|m| m.name == member.name) else {
            problems.push(format!(
                "{at}: member {} (GLSL offset {}, {} bytes) has no Rust field",
                member.name, member.offset, member.size
            ));
            continue;
        };
        if mirror.offset != member.offset {
            problems.push(format!(
                "{at}: member {}: GLSL offset {}, Rust offset {}",
                member.name, member.offset, mirror.offset
            ));
        }
        if let Some(size) = mirror.size
            && size != member.size
        {
            problems.push(format!(
                "{at}: member {}: GLSL size {} bytes, Rust size {size}",
                member.name, member.size
            ));
        }
    }
    for mirror in &rust.members {
        if mirror.size.is_some() && !block.members.iter().any(|m| m.name == mirror.name) {
            problems.push(format!(
                "{at}: Rust field {} (offset {}) is no member of the block",
                mirror.name, mirror.offset
            ));
        }
    }
    if let Some(bytes) = rust.bytes {
        let extent = block.extent();
        if bytes < extent || bytes > extent.next_multiple_of(16) {
            problems.push(format!(
                "{at}: GLSL block ends at byte {extent}, the Rust struct is {bytes} bytes"
            ));
        }
    }
    problems
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::{GlslBlock, MemberLayout};
    use crate::gpu::{ShaderStage, compile_source};

    const SHADER: &str = "#version 450\n\
        layout(std140, set = 1, binding = 3) uniform Params {\n\
            mat4 m;\n\
            vec4 v[3];\n\
            float f;\n\
            vec3 p;\n\
        } params;\n\
        layout(push_constant) uniform Push { uint count; float scale; } push;\n\
        layout(location = 0) out vec4 o;\n\
        void main() { o = params.m * params.v[2] + params.f * vec4(params.p, 1.0) + float(push.count) * push.scale; }\n";

    /// The blocks of [`SHADER`]: `Params`, then `Push`.
    fn reflected() -> Vec<Block> {
        let spirv = compile_source("test.frag", SHADER, ShaderStage::Fragment, &[]).unwrap();
        let mut found = blocks(&spirv).unwrap();
        found.sort_by(|a, b| a.name.cmp(&b.name));
        found
    }

    fn member(name: &str, offset: usize, size: usize) -> Member {
        Member {
            name: name.into(),
            offset,
            size,
        }
    }

    #[test]
    fn uniform_and_push_constant_blocks_read_with_names_offsets_and_sizes() {
        let found = reflected();
        assert_eq!(found.len(), 2, "{found:?}");
        let params = &found[0];
        assert_eq!(params.name, "Params");
        assert_eq!(params.kind, BlockKind::Uniform);
        assert_eq!((params.set, params.binding), (Some(1), Some(3)));
        assert_eq!(
            params.members,
            [
                member("m", 0, 64),
                member("v", 64, 48),
                member("f", 112, 4),
                member("p", 128, 12),
            ]
        );
        assert_eq!(params.extent(), 140);
        let push = &found[1];
        assert_eq!(
            (push.name.as_str(), push.kind),
            ("Push", BlockKind::PushConstant)
        );
        assert_eq!((push.set, push.binding), (None, None));
        assert_eq!(push.members, [member("count", 0, 4), member("scale", 4, 4)]);
    }

    /// The block above as Rust writes it.
    #[repr(C)]
    #[derive(bytemuck::Zeroable)]
    struct Params {
        m: [[f32; 4]; 4],
        v: [[f32; 4]; 3],
        f: f32,
        _pad: [f32; 3],
        p: [f32; 3],
        _pad2: f32,
    }
    crate::gpu::layout::glsl_block!(Params = "Params" { m, v, f, p });

    /// The same fields with `f` and `p` swapped: a planted mismatch.
    #[repr(C)]
    #[derive(bytemuck::Zeroable)]
    struct Swapped {
        m: [[f32; 4]; 4],
        v: [[f32; 4]; 3],
        p: [f32; 3],
        f: f32,
    }
    crate::gpu::layout::glsl_block!(Swapped = "Params" { m, v, p, f });

    #[test]
    fn a_matching_struct_passes_and_a_swapped_one_is_reported_with_both_offsets() {
        let block = &reflected()[0];
        assert_eq!(
            layout_mismatches("test.frag", block, &Params::layout()),
            Vec::<String>::new()
        );
        let problems = layout_mismatches("test.frag", block, &Swapped::layout());
        assert_eq!(
            problems,
            [
                "test.frag: block Params: member f: GLSL offset 112, Rust offset 124",
                "test.frag: block Params: member p: GLSL offset 128, Rust offset 112",
                "test.frag: block Params: GLSL block ends at byte 140, the Rust struct is 128 bytes",
            ]
        );
    }

    #[test]
    fn a_missing_field_an_extra_field_and_a_wrong_size_are_reported() {
        let block = &reflected()[0];
        let mut layout = Params::layout();
        layout.members.retain(|m| m.name != "f");
        layout.members.push(MemberLayout {
            name: "extra",
            offset: 144,
            size: Some(4),
        });
        layout.members[1].size = Some(32);
        let problems = layout_mismatches("test.frag", block, &layout);
        assert_eq!(problems.len(), 3, "{problems:?}");
        assert!(problems[0].contains("member v: GLSL size 48 bytes, Rust size 32"));
        assert!(problems[1].contains("member f (GLSL offset 112, 4 bytes) has no Rust field"));
        assert!(problems[2].contains("Rust field extra (offset 144)"));
        // An array whose length the shader's defines set (size `None`) is held to its
        // offset only, and may be absent.
        let variable = BlockLayout {
            name: "Params",
            bytes: None,
            members: vec![
                MemberLayout {
                    name: "v",
                    offset: 64,
                    size: None,
                },
                MemberLayout {
                    name: "absent",
                    offset: 256,
                    size: None,
                },
            ],
        };
        let problems = layout_mismatches("test.frag", block, &variable);
        assert_eq!(problems.len(), 3, "m, f and p have no field: {problems:?}");
        assert!(problems.iter().all(|p| p.contains("has no Rust field")));
    }

    #[test]
    fn the_walk_stops_at_a_truncated_instruction() {
        let mut spirv = compile_source("test.frag", SHADER, ShaderStage::Fragment, &[]).unwrap();
        let whole = instructions(&spirv).count();
        assert!(whole > 10);
        spirv.truncate(spirv.len() - 1);
        assert!(instructions(&spirv).count() < whole);
        assert_eq!(instructions(&spirv[..5]).count(), 0);
    }
}
