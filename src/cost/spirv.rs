//! What a compiled fragment shader does per invocation, read off its SPIR-V: the
//! cost model's operation counts are derived from the shader itself, not typed beside it.
//!
//! One pass over the instruction stream (`crate::gpu::reflect::instructions`) records the
//! types, the pointers' storage classes and, per value instruction, what it costs:
//! - **float ops**: arithmetic on floats, counted in scalar operations of the result's
//!   width (a `vec4` add or fused multiply-add is 4, a dot of two `vec3`s 3, a 3×3 matrix
//!   times a vector 9, a normalize 3 per component); comparisons, conversions and selects
//!   are not counted;
//! - **uniform reads**: loads from `Uniform` / `StorageBuffer` / `PushConstant` memory, in
//!   16-byte units (one `vec4` is 1, a `float` is 1), split by how they are addressed:
//!   *indexed* when an access chain on the way to them has an index that is not a constant
//!   (computed per invocation, e.g. a cluster's block from a texel's cluster id), constant
//!   otherwise;
//! - **varying reads**: float components loaded from `Input` variables (interpolants);
//! - **transcendentals**: `exp`, `exp2`, `log`, `log2`, `pow` and the trigonometric and
//!   hyperbolic functions, per component (`sqrt` and `inversesqrt` are float ops);
//! - **indexed private reads**: float components loaded from a `Function` or `Private`
//!   variable through an access chain with a non-constant index (a local array read at an
//!   index computed per invocation, which no compiler can keep in named registers);
//! - **integer divides**: integer division, remainder and modulo by a divisor that is not a
//!   constant, per component;
//! - **samples**: image sample / fetch / gather instructions;
//! - **loops**: loops left in the code (`OpLoopMerge`): where there are any, the other counts
//!   are of the code as written, not as executed; of them **kept loops**, those marked
//!   `DontUnroll` (`[[dont_unroll]]`), which a driver keeps a loop where it may unroll others
//!   (Mesa's NIR unrolls short ones in full).
//!
//! The counts are static: with every loop unrolled (shaderc's performance recipe unrolls
//! loops marked `[[unroll]]`; most shaders here are unrolled by macros) they are what each
//! invocation executes, except inside branches, which are counted as if both sides ran.

use std::collections::{HashMap, HashSet};

use crate::gpu::reflect::{
    OP_CONSTANT, OP_TYPE_ARRAY, OP_TYPE_FLOAT, OP_TYPE_MATRIX, OP_TYPE_POINTER, OP_TYPE_STRUCT,
    OP_TYPE_VECTOR, OP_VARIABLE, STORAGE_PUSH_CONSTANT, STORAGE_UNIFORM,
};

/// Per-invocation operation counts of a shader ([`count`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct OpCounts {
    pub float_ops: u32,
    pub uniform_reads: u32,
    pub indexed_uniform_reads: u32,
    pub varying_reads: u32,
    pub samples: u32,
    pub loops: u32,
    pub kept_loops: u32,
    pub transcendentals: u32,
    pub indexed_private_reads: u32,
    pub integer_divides: u32,
}

/// Loop Control mask bit (SPIR-V unified specification, §3.23).
const LOOP_CONTROL_DONT_UNROLL: u32 = 0x2;
// Opcodes (SPIR-V unified specification, §3.52) the reflection does not read.
const OP_EXT_INST: u32 = 12;
const OP_LOAD: u32 = 61;
const OP_ACCESS_CHAIN: u32 = 65;
const OP_IN_BOUNDS_ACCESS_CHAIN: u32 = 66;
const OP_LOOP_MERGE: u32 = 246;
/// OpImageSampleImplicitLod … OpImageSparseDrefGather and OpImageFetch/Gather.
const SAMPLE_OPS: [u32; 10] = [87, 88, 89, 90, 91, 92, 93, 94, 95, 96];
/// OpFNegate, OpFAdd, OpFSub, OpFMul, OpFDiv, OpFRem, OpFMod.
const FLOAT_ELEMENTWISE_OPS: [u32; 7] = [127, 129, 131, 133, 136, 140, 141];
/// OpUDiv, OpSDiv, OpUMod, OpSRem, OpSMod.
const INTEGER_DIVIDE_OPS: [u32; 5] = [134, 135, 137, 138, 139];
const OP_VECTOR_TIMES_SCALAR: u32 = 142;
const OP_MATRIX_TIMES_SCALAR: u32 = 143;
const OP_VECTOR_TIMES_MATRIX: u32 = 144;
const OP_MATRIX_TIMES_VECTOR: u32 = 145;
const OP_MATRIX_TIMES_MATRIX: u32 = 146;
const OP_OUTER_PRODUCT: u32 = 147;
const OP_DOT: u32 = 148;

// Storage classes (§3.7).
const STORAGE_INPUT: u32 = 1;
const STORAGE_PRIVATE: u32 = 6;
const STORAGE_FUNCTION: u32 = 7;
const STORAGE_STORAGE_BUFFER: u32 = 12;

// GLSL.std.450 instructions that cost more than one operation per component.
const GLSL_NORMALIZE: u32 = 69;
const GLSL_LENGTH: u32 = 66;
const GLSL_DISTANCE: u32 = 67;
const GLSL_CROSS: u32 = 68;
const GLSL_DETERMINANT: u32 = 33;
const GLSL_MATRIX_INVERSE: u32 = 34;
/// GLSL.std.450 Sin … Atan2 (13–25) and Pow, Exp, Log, Exp2, Log2 (26–30): transcendentals.
const GLSL_TRANSCENDENTALS: std::ops::RangeInclusive<u32> = 13..=30;

/// A type's shape: float components (0 for non-float scalars) and bytes-ish size in
/// 16-byte units for memory reads.
#[derive(Clone, Copy, Debug, Default)]
struct Shape {
    floats: u32,
    columns: u32,
    rows: u32,
    units16: u32,
}

/// What the walk over a module has recorded (types, pointers, constants) and counted so
/// far.
#[derive(Default)]
struct Walk {
    counts: OpCounts,
    shapes: HashMap<u32, Shape>,
    /// Pointer type id → (storage class, pointee type id).
    pointer_types: HashMap<u32, (u32, u32)>,
    /// Value id → its type id (variables, access chains, values).
    value_types: HashMap<u32, u32>,
    /// 32-bit constant id → its value (array lengths).
    constants: HashMap<u32, u32>,
    /// Access chains with a non-constant index on their way (module doc).
    indexed_pointers: HashSet<u32>,
}

/// The shape of type `t`, the default one where `t` is unknown.
fn shape_of(shapes: &HashMap<u32, Shape>, t: u32) -> Shape {
    shapes.get(&t).copied().unwrap_or_default()
}

/// Counts the operations of one invocation of `spirv` (module doc). Malformed input ends
/// the walk where it stops making sense; the counts so far are returned.
pub fn count(spirv: &[u32]) -> OpCounts {
    let mut walk = Walk::default();
    for (op, w) in crate::gpu::reflect::instructions(spirv) {
        if !walk.record_declaration(op, w) {
            walk.count_operation(op, w);
        }
        // Every value instruction: remember its result type (word 1 = type, word 2 = id).
        if has_result_type(op) && w.len() >= 2 {
            walk.value_types.entry(w[1]).or_insert(w[0]);
        }
    }
    walk.counts
}

impl Walk {
    /// Records a type, constant, pointer type, variable or access chain (operands `w`);
    /// false where `op` (with these operands) is none of them.
    fn record_declaration(&mut self, op: u32, w: &[u32]) -> bool {
        let Walk {
            shapes,
            pointer_types,
            value_types,
            constants,
            indexed_pointers,
            ..
        } = self;
        match op {
            OP_TYPE_FLOAT if !w.is_empty() => {
                shapes.insert(
                    w[0],
                    Shape {
                        floats: 1,
                        columns: 1,
                        rows: 1,
                        units16: 1,
                    },
                );
                true
            }
            OP_TYPE_VECTOR if w.len() >= 3 => {
                let c = shape_of(shapes, w[1]);
                shapes.insert(
                    w[0],
                    Shape {
                        floats: c.floats * w[2],
                        columns: 1,
                        rows: w[2],
                        units16: 1,
                    },
                );
                true
            }
            OP_TYPE_MATRIX if w.len() >= 3 => {
                let c = shape_of(shapes, w[1]);
                shapes.insert(
                    w[0],
                    Shape {
                        floats: c.floats * w[2],
                        columns: w[2],
                        rows: c.rows,
                        units16: w[2],
                    },
                );
                true
            }
            OP_CONSTANT if w.len() >= 3 => {
                constants.insert(w[1], w[2]);
                true
            }
            // A whole array or struct loaded at once (the optimizer loads a uniform array
            // with one OpLoad and extracts from it): its size is the sum of its parts.
            OP_TYPE_ARRAY if w.len() >= 3 => {
                let (e, n) = (
                    shape_of(shapes, w[1]),
                    constants.get(&w[2]).copied().unwrap_or(1),
                );
                shapes.insert(
                    w[0],
                    Shape {
                        floats: e.floats * n,
                        columns: 1,
                        rows: 1,
                        units16: e.units16.max(1) * n,
                    },
                );
                true
            }
            OP_TYPE_STRUCT if !w.is_empty() => {
                let members = w[1..].iter().map(|&m| shape_of(shapes, m));
                let (floats, units16) =
                    members.fold((0, 0), |(f, u), m| (f + m.floats, u + m.units16.max(1)));
                shapes.insert(
                    w[0],
                    Shape {
                        floats,
                        columns: 1,
                        rows: 1,
                        units16,
                    },
                );
                true
            }
            OP_TYPE_POINTER if w.len() >= 3 => {
                pointer_types.insert(w[0], (w[1], w[2]));
                true
            }
            OP_VARIABLE | OP_ACCESS_CHAIN | OP_IN_BOUNDS_ACCESS_CHAIN if w.len() >= 2 => {
                value_types.insert(w[1], w[0]);
                if op != OP_VARIABLE
                    && w.len() >= 3
                    && (indexed_pointers.contains(&w[2])
                        || w[3..].iter().any(|index| !constants.contains_key(index)))
                {
                    indexed_pointers.insert(w[1]);
                }
                true
            }
            _ => false,
        }
    }

    /// Counts what instruction `op` (operands `w`) costs: memory reads, loops, samples and
    /// float operations.
    fn count_operation(&mut self, op: u32, w: &[u32]) {
        let Walk {
            counts,
            shapes,
            pointer_types,
            value_types,
            indexed_pointers,
            ..
        } = self;
        match op {
            OP_LOAD if w.len() >= 3 => {
                value_types.insert(w[1], w[0]);
                let storage = value_types
                    .get(&w[2])
                    .and_then(|t| pointer_types.get(t))
                    .map(|&(s, _)| s);
                let loaded = shape_of(shapes, w[0]);
                match storage {
                    Some(STORAGE_UNIFORM | STORAGE_STORAGE_BUFFER | STORAGE_PUSH_CONSTANT) => {
                        if indexed_pointers.contains(&w[2]) {
                            counts.indexed_uniform_reads += loaded.units16.max(1);
                        } else {
                            counts.uniform_reads += loaded.units16.max(1);
                        }
                    }
                    Some(STORAGE_INPUT) => counts.varying_reads += loaded.floats,
                    Some(STORAGE_FUNCTION | STORAGE_PRIVATE)
                        if indexed_pointers.contains(&w[2]) =>
                    {
                        counts.indexed_private_reads += loaded.floats;
                    }
                    _ => {}
                }
            }
            OP_LOOP_MERGE => {
                counts.loops += 1;
                if w.get(2)
                    .is_some_and(|control| control & LOOP_CONTROL_DONT_UNROLL != 0)
                {
                    counts.kept_loops += 1;
                }
            }
            op if SAMPLE_OPS.contains(&op) => counts.samples += 1,
            op if INTEGER_DIVIDE_OPS.contains(&op) && w.len() >= 4 => {
                if !self.constants.contains_key(&w[3]) {
                    counts.integer_divides += shape_of(shapes, w[0]).rows.max(1);
                }
            }
            op if FLOAT_ELEMENTWISE_OPS.contains(&op)
                || op == OP_VECTOR_TIMES_SCALAR
                || op == OP_MATRIX_TIMES_SCALAR =>
            {
                if let Some(&t) = w.first() {
                    counts.float_ops += shape_of(shapes, t).floats;
                }
            }
            OP_DOT if w.len() >= 3 => {
                let operand = value_types.get(&w[2]).map(|&t| shape_of(shapes, t));
                counts.float_ops += operand.map_or(4, |s| s.floats);
                value_types.insert(w[1], w[0]);
            }
            OP_MATRIX_TIMES_VECTOR
            | OP_VECTOR_TIMES_MATRIX
            | OP_MATRIX_TIMES_MATRIX
            | OP_OUTER_PRODUCT
                if w.len() >= 2 =>
            {
                // One multiply-add per product term: result components × the inner size.
                let result = shape_of(shapes, w[0]);
                let inner = match op {
                    OP_OUTER_PRODUCT => 1,
                    _ => w
                        .get(2)
                        .and_then(|a| value_types.get(a))
                        .map_or(result.rows, |&t| {
                            let s = shape_of(shapes, t);
                            if op == OP_MATRIX_TIMES_VECTOR {
                                s.columns
                            } else {
                                s.rows
                            }
                        }),
                };
                counts.float_ops += result.floats * inner.max(1);
            }
            OP_EXT_INST if w.len() >= 4 => {
                let result = shape_of(shapes, w[0]);
                let operand = w
                    .get(4)
                    .and_then(|a| value_types.get(a))
                    .map_or(result, |&t| shape_of(shapes, t));
                if GLSL_TRANSCENDENTALS.contains(&w[3]) {
                    counts.transcendentals += result.floats;
                    return;
                }
                counts.float_ops += match w[3] {
                    GLSL_NORMALIZE => 3 * operand.floats,
                    GLSL_LENGTH | GLSL_DISTANCE => 2 * operand.floats,
                    GLSL_CROSS => 6,
                    GLSL_DETERMINANT => 3 * operand.floats,
                    GLSL_MATRIX_INVERSE => 6 * operand.floats,
                    _ => result.floats,
                };
            }
            _ => {}
        }
    }
}

/// Whether instructions of `op` start with (result type, result id): all but the
/// module-level, type, decoration and control-flow instructions.
fn has_result_type(op: u32) -> bool {
    !matches!(op, 0..=11 | 13..=17 | 19..=39 | 56 | 62 | 71..=77 | 246..=255)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::{ShaderStage, shader::compile_source};

    fn counts_of(body: &str) -> OpCounts {
        let text = format!(
            "#version 450\n\
             #extension GL_EXT_control_flow_attributes : require\n\
             layout(location = 0) in vec4 a;\n\
             layout(location = 1) in vec2 uv;\n\
             layout(std140, set = 0, binding = 0) uniform P {{ vec4 c[8]; }} p;\n\
             layout(set = 0, binding = 1) uniform sampler2D t;\n\
             layout(location = 0) out vec4 o;\n\
             void main() {{ {body} }}\n"
        );
        let spirv = compile_source("test.frag", &text, ShaderStage::Fragment, &[]).unwrap();
        count(&spirv)
    }

    #[test]
    fn a_shader_counts_its_float_ops_uniform_and_varying_reads_and_samples() {
        // 4 multiplies + 4 adds on vec4s, a dot of vec4s (4), one uniform vec4, six varying
        // floats (a and uv), two samples.
        let c = counts_of(
            "vec4 x = a * p.c[3] + texture(t, uv) + texture(t, uv * 0.5);\n\
             o = x * dot(x, a);",
        );
        assert_eq!(c.uniform_reads, 1, "{c:?}");
        assert_eq!(c.varying_reads, 6, "{c:?}");
        assert_eq!(c.samples, 2, "{c:?}");
        assert_eq!(c.loops, 0);
        // The optimizer fuses a*c + sample into one vec4 Fma (4), then one add (4), the dot
        // (4), x * scalar (4), uv * 0.5 (2): a fused multiply-add counts once.
        assert_eq!(c.float_ops, 18, "{c:?}");
    }

    #[test]
    fn transcendentals_are_counted_apart_from_float_ops() {
        // exp of a vec4 (4), sin of a float (1), pow of a vec2 (2); sqrt stays a float op.
        let c = counts_of(
            "vec4 e = exp(a);\nfloat s = sin(a.x);\nvec2 q = pow(uv, vec2(2.5));\n\
             o = vec4(e.x + s, q, sqrt(a.w));",
        );
        assert_eq!(c.transcendentals, 7, "{c:?}");
        assert_eq!(c.float_ops, 2, "{c:?}");
    }

    #[test]
    fn integer_divides_by_a_computed_divisor_are_counted() {
        // Two by a divisor from a varying (one a remainder), one by a constant (a shift).
        let c = counts_of(
            "int q = int(uv.x * 100.0);\nint d = 2 + int(uv.y * 4.0);\n\
             o = vec4(float(q / d), float(q % d), float(q / 4), 0.0);",
        );
        assert_eq!(c.integer_divides, 2, "{c:?}");
    }

    #[test]
    fn a_private_array_read_at_a_computed_index_is_counted() {
        // Twelve floats from the varyings at constant indices, three read back at an index
        // computed per invocation, one at a constant index (a register, not counted).
        let c = counts_of(
            "float t[12];\n[[unroll]] for (int i = 0; i < 12; ++i) { t[i] = a[i & 3] * float(i); }\n\
             int k = int(uv.x * 8.0);\n\
             o = vec4(t[k], t[k + 1], t[k + 2], t[3]);",
        );
        assert_eq!(c.indexed_private_reads, 3, "{c:?}");
    }

    #[test]
    fn a_uniform_array_read_whole_counts_every_element() {
        // Passing the block's array to a function copies all eight vec4s.
        let c = counts_of(
            "vec4 s = vec4(0.0);\nvec4 cs[8] = p.c;\n[[unroll]] for (int i = 0; i < 8; ++i) { s += cs[i]; }\no = s;",
        );
        assert_eq!(c.uniform_reads, 8, "{c:?}");
    }

    #[test]
    fn unrolled_loops_count_every_iteration_and_kept_loops_are_flagged() {
        let unrolled = counts_of(
            "vec4 s = vec4(0.0);\n[[unroll]] for (int i = 0; i < 8; ++i) { s += p.c[i]; }\no = s;",
        );
        assert_eq!(unrolled.loops, 0, "{unrolled:?}");
        assert_eq!(unrolled.kept_loops, 0, "{unrolled:?}");
        assert_eq!(unrolled.uniform_reads, 8, "{unrolled:?}");
        assert_eq!(unrolled.indexed_uniform_reads, 0, "{unrolled:?}");
        let kept = counts_of(
            "vec4 s = vec4(0.0);\n[[dont_unroll]] for (int i = 0; i < 8; ++i) { s += p.c[i]; }\no = s;",
        );
        assert_eq!(kept.loops, 1, "{kept:?}");
        assert_eq!(kept.kept_loops, 1, "{kept:?}");
        let plain =
            counts_of("vec4 s = vec4(0.0);\nfor (int i = 0; i < 8; ++i) { s += p.c[i]; }\no = s;");
        assert_eq!((plain.loops, plain.kept_loops), (1, 0), "{plain:?}");
    }

    #[test]
    fn reads_at_an_index_computed_per_invocation_are_counted_apart() {
        // Two reads at a varying-derived index, one at a constant one.
        let c = counts_of("int k = int(uv.x * 4.0) & 3;\no = p.c[k] + p.c[k + 4] + p.c[1];");
        assert_eq!(c.indexed_uniform_reads, 2, "{c:?}");
        assert_eq!(c.uniform_reads, 1, "{c:?}");
    }
}
