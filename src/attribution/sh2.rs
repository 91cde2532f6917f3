//! The ladder recipe of `sh2`: visibility to order 2, lighting to order 3, then the product
//! and cosine to order 3 (its shader's maths).

use super::{
    AttributionKind, LadderRecipe, LxhMatrices, Order, RowLadder, Rung, exact_cosine, shade,
};
use crate::technique::TechniqueError;
use crate::technique::sh2::Sh2;

impl<'a> RowLadder<'a> {
    /// `sh2`'s rungs: V truncated to order 2, lighting to order 3, then the product and
    /// the cosine to order 3, then the lightmap texels.
    fn sh2(&self, rungs: &mut Vec<Rung>) {
        let px = self.px;
        let radiance = &self.prepared.radiance_sh;
        let order = Order::TWO;
        let n2 = order.coeff_count();
        self.push_visibility(rungs, order);
        let lighting = exact_cosine(radiance, 3, order);
        self.push(
            rungs,
            AttributionKind::LightingOrder,
            "sh2.lighting_order".into(),
            &|| px.image(|k| shade(&lighting, px.normal[k], &px.visibility(k, n2))),
        );
        let product = LxhMatrices::with_lighting_order(radiance, Order::THREE, order, Order::THREE);
        self.push(
            rungs,
            AttributionKind::ProductOrder,
            "sh2.product_order".into(),
            &|| px.image(|k| shade(&product, px.normal[k], &px.visibility(k, n2))),
        );
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            "sh2.lightmap".into(),
            &|| px.image(|k| shade(&product, px.normal[k], &self.lightmap_v(k, n2))),
        );
        self.push_block_compression(rungs, n2, 1.0, &|v, k| shade(&product, px.normal[k], v));
    }
}

impl LadderRecipe for Sh2 {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.sh2(rungs);
        Ok(())
    }
}
