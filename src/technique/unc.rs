//! `unc3`, `unc4`, `unc6`: uncompressed SH visibility per texel and an L×H table indexed
//! by the normal (Iwanicki–Sloan §3, eq. (4); DESIGN §2).
//!
//! Per texel: the first O² coefficients of the baked visibility, 4 per RGBA16F texel
//! (G = ⌈O²/4⌉ groups; unc3's last group is padded with zeros). Per lighting: the L×H table
//! of `bake::lxh` for order O, 4 coefficients per RGBA16F texel per colour. Layouts and the
//! shader are shared with `pca*` (`technique::grouped`); dx9 binds G + 3 + 2 textures
//! (unc6: 14 ≤ 16) and `check_path_rules` refuses more.

use std::sync::Arc;

use ash::vk;
use half::f16;

use super::grouped::{self, upload_normal_tables, upload_texel_groups};
use super::{HwPath, Inputs, TechniqueError, TechniqueGpu, TechniqueId, TechniqueStats};
use crate::bake::lxh::{LxhMatrices, build_table};
use crate::gpu::{Context, layout};
use crate::render::SceneGpu;
use crate::sh::Order;
use crate::sphere::{Parameterization, SphereMap};

/// The visibility order of an `unc*` technique.
pub fn order_of(id: TechniqueId) -> Order {
    match id {
        TechniqueId::Unc3 => Order::THREE,
        TechniqueId::Unc4 => Order::FOUR,
        _ => Order::SIX,
    }
}

/// The L×H table's parameterization on each path.
pub fn table_map(path: HwPath, table_res: u32, label: &str) -> Result<SphereMap, TechniqueError> {
    let kind = match path {
        HwPath::Dx9 => Parameterization::DualParaboloid,
        HwPath::Dx10 => Parameterization::CubeDx10,
    };
    SphereMap::new(kind, table_res).map_err(|e| TechniqueError::Input {
        label: label.into(),
        detail: e.to_string(),
    })
}

pub fn build(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    id: TechniqueId,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<TechniqueGpu, TechniqueError> {
    let label = format!("{id}.{path}");
    let order = order_of(id);
    let n = order.coeff_count();
    let groups = n.div_ceil(4);
    let vis = inputs.visibility.ok_or_else(|| TechniqueError::Input {
        label: label.clone(),
        detail: "needs the SH visibility bake".into(),
    })?;
    if vis.order < order {
        return Err(TechniqueError::Input {
            label,
            detail: format!(
                "needs visibility of order {order}, the bake has {}",
                vis.order
            ),
        });
    }
    let res = vis.res;
    let texels = (res * res) as usize;
    let stride = vis.order.coeff_count();

    // Per-texel visibility, 4 coefficients per RGBA16F texel, group-major.
    let mut vis_groups: Vec<Vec<f16>> = vec![vec![f16::ZERO; texels * 4]; groups];
    for t in 0..texels {
        for j in 0..n {
            vis_groups[j / 4][t * 4 + j % 4] = f16::from_f32(vis.coeffs[t * stride + j]);
        }
    }
    let vis_bytes: Vec<&[u8]> = vis_groups.iter().map(|g| bytemuck::cast_slice(g)).collect();
    let texel_images = upload_texel_groups(
        ctx,
        path,
        res,
        vk::Format::R16G16B16A16_SFLOAT,
        &vis_bytes,
        &format!("{label}.visibility"),
    )?;

    // The L×H table for this lighting.
    let matrices = LxhMatrices::new(inputs.radiance_sh, order, inputs.h_order);
    let map = table_map(path, inputs.table_res, &label)?;
    let table = build_table(&matrices, map);
    let (table_images, unscale) = upload_normal_tables(
        ctx,
        path,
        map,
        groups,
        |t, g, c| {
            std::array::from_fn(|k| {
                let j = 4 * g + k;
                if j < n {
                    table.values[t * n + j][c]
                } else {
                    0.0
                }
            })
        },
        None,
        &format!("{label}.lxh"),
    )?;
    grouped::finish(
        ctx,
        scene,
        id,
        path,
        "technique/unc.frag",
        &[("UNC_GROUPS", groups as u32)],
        texel_images,
        table_images,
        false,
        unscale,
        inputs.table_res,
        TechniqueStats {
            texel_bytes: (groups * texels * 8) as u64,
            table_bytes: (map.sample_count() * groups * 3 * 8) as u64,
            textures_bound: 0, // filled in by `finish`
            lookups_per_pixel: layout::MATERIAL_TEXTURES + (4 * groups) as u32,
        },
    )
}
