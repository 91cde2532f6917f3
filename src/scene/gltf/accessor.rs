//! Accessor decoding: an accessor's elements found in its buffer view (offsets, stride and
//! length checked), each component converted to f32 (normalized integers per glTF §3.11),
//! sparse substitutions applied, and index buffers read as u32; and a triangle-list
//! primitive's attributes and indices read and checked against each other
//! ([`read_primitive`]). Everything is read with checked arithmetic: an accessor or view
//! that runs past its buffer is an error, never a panic (the `gltf` crate's own readers
//! assume valid offsets).

use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Semantic;

/// A triangle-list primitive's attributes (flat f32 values, `count` elements each) and
/// indices, as [`read_primitive`] checked them.
pub(super) struct PrimitiveData {
    pub(super) positions: Vec<f32>,
    pub(super) count: usize,
    pub(super) normals: Option<Vec<f32>>,
    pub(super) tangents: Option<Vec<f32>>,
    pub(super) uv0: Option<Vec<f32>>,
    pub(super) uv1: Option<Vec<f32>>,
    /// COLOR_0 as RGB (alpha dropped), `count` × 3.
    pub(super) colors: Option<Vec<f32>>,
    pub(super) indices: Vec<u32>,
}

/// Reads a primitive's attributes and indices (all of its vertices in order where it has
/// none), checked: finite values, as many elements as POSITION, whole triangles, indices in
/// range. Errors are messages for the primitive's name to prefix.
pub(super) fn read_primitive(
    prim: &gltf::Primitive,
    buffers: &[Vec<u8>],
) -> Result<PrimitiveData, String> {
    let attr = |semantic: Semantic, dims: usize| -> Result<Option<Vec<f32>>, String> {
        let Some(acc) = prim.get(&semantic) else {
            return Ok(None);
        };
        let name = format!("{} (accessor {})", semantic_name(&semantic), acc.index());
        let values = read_floats(&acc, buffers, dims).map_err(|m| format!("{name}: {m}"))?;
        if let Some(bad) = values.iter().position(|x| !x.is_finite()) {
            return Err(format!("{name}: element {} is not finite", bad / dims));
        }
        Ok(Some(values))
    };
    let positions = attr(Semantic::Positions, 3)?.ok_or_else(|| "no POSITION".to_string())?;
    let count = positions.len() / 3;
    let normals = attr(Semantic::Normals, 3)?;
    let tangents = attr(Semantic::Tangents, 4)?;
    let uv0 = attr(Semantic::TexCoords(0), 2)?;
    let uv1 = attr(Semantic::TexCoords(1), 2)?;
    let colors = match prim.get(&Semantic::Colors(0)).map(|acc| acc.dimensions()) {
        None => None,
        Some(Dimensions::Vec3) => attr(Semantic::Colors(0), 3)?,
        Some(Dimensions::Vec4) => attr(Semantic::Colors(0), 4)?.map(|rgba| {
            rgba.chunks_exact(4)
                .flat_map(|c| [c[0], c[1], c[2]])
                .collect()
        }),
        Some(other) => return Err(format!("COLOR_0 is {other:?}, not VEC3 or VEC4")),
    };
    // glTF's COLOR_0 multiplies the base colour: a fraction in [0, 1] (glTF 2.0 §3.7.2.1).
    if let Some(bad) = colors
        .as_ref()
        .and_then(|c| c.iter().position(|x| !(0.0..=1.0).contains(x)))
    {
        return Err(format!(
            "COLOR_0: element {} has a value outside [0, 1]",
            bad / 3
        ));
    }
    for (name, values, dims) in [
        ("NORMAL", &normals, 3),
        ("TANGENT", &tangents, 4),
        ("TEXCOORD_0", &uv0, 2),
        ("TEXCOORD_1", &uv1, 2),
        ("COLOR_0", &colors, 3),
    ] {
        if let Some(v) = values.as_ref().filter(|v| v.len() / dims != count) {
            return Err(format!(
                "{name} has {} elements but POSITION has {count}",
                v.len() / dims
            ));
        }
    }
    let indices: Vec<u32> = match prim.indices() {
        Some(acc) => read_indices(&acc, buffers)
            .map_err(|m| format!("indices (accessor {}): {m}", acc.index()))?,
        None => (0..count as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(format!(
            "{} indices is not a whole number of triangles",
            indices.len()
        ));
    }
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= count) {
        return Err(format!(
            "index {bad} is out of range (the primitive has {count} vertices)"
        ));
    }
    Ok(PrimitiveData {
        positions,
        count,
        normals,
        tangents,
        uv0,
        uv1,
        colors,
        indices,
    })
}

/// The attribute's glTF spelling (`POSITION`, `TEXCOORD_1`, …) for messages.
fn semantic_name(semantic: &Semantic) -> String {
    match semantic {
        Semantic::Positions => "POSITION".into(),
        Semantic::Normals => "NORMAL".into(),
        Semantic::Tangents => "TANGENT".into(),
        Semantic::TexCoords(n) => format!("TEXCOORD_{n}"),
        Semantic::Colors(n) => format!("COLOR_{n}"),
        other => format!("{other:?}"),
    }
}

/// Accessors without a buffer view are zero-filled; more elements than this are refused
/// (a hostile file could otherwise ask for gigabytes of zeros).
const MAX_ZERO_FILLED: usize = 1 << 20;

/// Where an accessor's elements live: bytes from the first element on, and the stride.
fn element_bytes<'b>(
    acc: &gltf::Accessor,
    buffers: &'b [Vec<u8>],
    elem_size: usize,
) -> Result<Option<(&'b [u8], usize)>, String> {
    let Some(view) = acc.view() else {
        return Ok(None);
    };
    let data = buffers
        .get(view.buffer().index())
        .ok_or("bad buffer index")?;
    let view_bytes = view
        .offset()
        .checked_add(view.length())
        .and_then(|end| data.get(view.offset()..end))
        .ok_or("buffer view runs past its buffer")?;
    let stride = view.stride().unwrap_or(elem_size);
    if stride < elem_size {
        return Err(format!("byteStride {stride} < element size {elem_size}"));
    }
    let count = acc.count();
    let needed = match count {
        0 => 0,
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|b| b.checked_add(elem_size))
            .ok_or("size overflows")?,
    };
    let bytes = acc
        .offset()
        .checked_add(needed)
        .and_then(|end| view_bytes.get(acc.offset()..end))
        .ok_or_else(|| {
            format!(
                "{count} elements at offset {} run past the buffer view ({} bytes)",
                acc.offset(),
                view_bytes.len()
            )
        })?;
    Ok(Some((bytes, stride)))
}

/// One component at `bytes[0..]` as f32, normalized per glTF §3.11 when asked.
fn component(bytes: &[u8], ty: DataType, normalized: bool) -> f32 {
    let b = |k: usize| bytes.get(k).copied().unwrap_or(0);
    match (ty, normalized) {
        (DataType::I8, false) => f32::from(b(0) as i8),
        (DataType::I8, true) => (f32::from(b(0) as i8) / 127.0).max(-1.0),
        (DataType::U8, false) => f32::from(b(0)),
        (DataType::U8, true) => f32::from(b(0)) / 255.0,
        (DataType::I16, n) => {
            let v = f32::from(i16::from_le_bytes([b(0), b(1)]));
            if n { (v / 32767.0).max(-1.0) } else { v }
        }
        (DataType::U16, n) => {
            let v = f32::from(u16::from_le_bytes([b(0), b(1)]));
            if n { v / 65535.0 } else { v }
        }
        (DataType::U32, n) => {
            let v = u32::from_le_bytes([b(0), b(1), b(2), b(3)]) as f32;
            if n { v / u32::MAX as f32 } else { v }
        }
        (DataType::F32, _) => f32::from_le_bytes([b(0), b(1), b(2), b(3)]),
    }
}

/// An accessor of `dims` components per element as flat f32 values (sparse applied).
fn read_floats(acc: &gltf::Accessor, buffers: &[Vec<u8>], dims: usize) -> Result<Vec<f32>, String> {
    let found = match acc.dimensions() {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        other => return Err(format!("type {other:?} where VEC{dims} was expected")),
    };
    if found != dims {
        return Err(format!("VEC{found} where VEC{dims} was expected"));
    }
    let ty = acc.data_type();
    let size = ty.size();
    let elem = size * dims;
    let count = acc.count();
    let mut out = match element_bytes(acc, buffers, elem)? {
        Some((bytes, stride)) => {
            let mut out = Vec::with_capacity(count * dims);
            for i in 0..count {
                let e = &bytes[i * stride..i * stride + elem];
                out.extend((0..dims).map(|k| component(&e[k * size..], ty, acc.normalized())));
            }
            out
        }
        None if count <= MAX_ZERO_FILLED => vec![0.0; count * dims],
        None => return Err(format!("{count} elements without a buffer view")),
    };
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        let indices = sparse_indices(&sparse, buffers)?;
        let values = sparse.values();
        let data = buffers
            .get(values.view().buffer().index())
            .ok_or("bad buffer index")?;
        let start = values
            .view()
            .offset()
            .checked_add(values.offset())
            .ok_or("sparse offset overflows")?;
        let bytes = n
            .checked_mul(elem)
            .and_then(|len| len.checked_add(start))
            .and_then(|end| data.get(start..end))
            .ok_or("sparse values run past their buffer")?;
        for (k, &i) in indices.iter().enumerate() {
            let slot = out
                .get_mut(i as usize * dims..(i as usize + 1) * dims)
                .ok_or_else(|| format!("sparse index {i} ≥ count {count}"))?;
            for (c, v) in slot.iter_mut().enumerate() {
                *v = component(&bytes[k * elem + c * size..], ty, acc.normalized());
            }
        }
    }
    Ok(out)
}

/// Indices of a sparse accessor.
fn sparse_indices(
    sparse: &gltf::accessor::sparse::Sparse,
    buffers: &[Vec<u8>],
) -> Result<Vec<u32>, String> {
    let idx = sparse.indices();
    let size = idx.index_type().size();
    let data = buffers
        .get(idx.view().buffer().index())
        .ok_or("bad buffer index")?;
    let start = idx
        .view()
        .offset()
        .checked_add(idx.offset())
        .ok_or("sparse offset overflows")?;
    let bytes = sparse
        .count()
        .checked_mul(size)
        .and_then(|len| len.checked_add(start))
        .and_then(|end| data.get(start..end))
        .ok_or("sparse indices run past their buffer")?;
    Ok(bytes
        .chunks_exact(size)
        .map(|c| match c {
            [a] => u32::from(*a),
            [a, b] => u32::from(u16::from_le_bytes([*a, *b])),
            [a, b, c, d] => u32::from_le_bytes([*a, *b, *c, *d]),
            _ => u32::MAX,
        })
        .collect())
}

/// A SCALAR accessor of unsigned integers (the index buffer).
fn read_indices(acc: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    if acc.dimensions() != Dimensions::Scalar {
        return Err(format!(
            "type {:?} where SCALAR was expected",
            acc.dimensions()
        ));
    }
    let ty = acc.data_type();
    if !matches!(ty, DataType::U8 | DataType::U16 | DataType::U32) || acc.normalized() {
        return Err(format!("component type {ty:?} cannot hold indices"));
    }
    // Integers below 2²⁴ survive f32 exactly; larger ones are read directly.
    let size = ty.size();
    match element_bytes(acc, buffers, size)? {
        Some((bytes, stride)) if acc.sparse().is_none() => Ok((0..acc.count())
            .map(|i| {
                let e = &bytes[i * stride..i * stride + size];
                match ty {
                    DataType::U8 => u32::from(e[0]),
                    DataType::U16 => u32::from(u16::from_le_bytes([e[0], e[1]])),
                    _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
                }
            })
            .collect()),
        _ => Ok(read_floats(acc, buffers, 1)?
            .into_iter()
            .map(|v| v as u32)
            .collect()),
    }
}
