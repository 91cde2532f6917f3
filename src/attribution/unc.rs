//! The ladder recipe of `uncO`: visibility, lighting and cosine orders, the normal table,
//! the lightmap texels.

use super::{
    AttributionKind, LadderRecipe, LxhMatrices, Order, RowLadder, Rung, StoredTable, build_table,
    cosine_order_name, dot_rgb, exact_cosine, lighting_order_name, table_map,
};
use crate::technique::TechniqueError;
use crate::technique::unc::Unc;

impl<'a> RowLadder<'a> {
    /// `unc`'s rungs: visibility, lighting and cosine orders, the normal table, the
    /// lightmap texels.
    fn unc(&self, rungs: &mut Vec<Rung>, order: Order) -> Result<(), TechniqueError> {
        let (px, prepared, technique, label) =
            (self.px, self.prepared, self.technique, &self.label);
        let radiance = &prepared.radiance_sh;
        let n2 = order.coeff_count();
        self.push_visibility(rungs, order);
        let lighting = exact_cosine(radiance, order.get() + 2, order);
        self.push(
            rungs,
            AttributionKind::LightingOrder,
            format!("{technique}.lighting_order"),
            &|| {
                let products = px.products(&lighting_order_name(order), &lighting);
                px.image(|k| products.shade(k, &px.visibility(k, n2)))
            },
        );
        let lxh = LxhMatrices::new(radiance, order, prepared.h_order);
        self.push(
            rungs,
            AttributionKind::CosineOrder,
            format!("{technique}.cosine_order"),
            &|| {
                let products = px.products(&cosine_order_name(order), &lxh);
                px.image(|k| products.shade(k, &px.visibility(k, n2)))
            },
        );
        let map = table_map(self.path, prepared.table_res, label)?;
        let table = build_table(&lxh, map);
        let stored = StoredTable::new(map, n2, |t, j| table.values[t * n2 + j]);
        let table_dot = |v: &[f64], k: usize| {
            dot_rgb(v, &stored.eval(px.normal[k]), n2).map(|x| x * stored.unscale)
        };
        self.push(
            rungs,
            AttributionKind::NormalTable,
            format!("{label}.normal_table"),
            &|| px.image(|k| table_dot(&px.visibility(k, n2), k)),
        );
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{label}.lightmap"),
            &|| px.image(|k| table_dot(&self.lightmap_v(k, n2), k)),
        );
        self.push_block_compression(rungs, n2, 1.0, &table_dot);
        Ok(())
    }
}

impl LadderRecipe for Unc {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.unc(rungs, self.order)
    }
}
