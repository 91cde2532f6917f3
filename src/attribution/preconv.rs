//! The ladder recipe of `preconv`: the pixel's AO in place of its visibility, then
//! irradiance truncated to order 3.

use super::{AttributionKind, LadderRecipe, Order, RowLadder, Rung, f16_round, lightmap_bilinear};
use crate::technique::TechniqueError;
use crate::technique::preconv::Preconv;

impl<'a> RowLadder<'a> {
    /// `preconv`'s rungs: V replaced by the pixel's AO, irradiance truncated to order 3,
    /// the AO lightmap's texels.
    fn preconv(&self, rungs: &mut Vec<Rung>) {
        let (px, prepared) = (self.px, self.prepared);
        let y00 = 0.5 / std::f64::consts::PI.sqrt();
        let ao = |k: usize| f64::from(px.vis.ao[k]);
        self.push(
            rungs,
            AttributionKind::AmbientOcclusion,
            "preconv.ambient_occlusion".into(),
            // ∫ L H_n = G_0 / y_00.
            &|| px.image(|k| self.exact(k)[0].map(|g| ao(k) * g / y00)),
        );
        let e3 = |k: usize| {
            crate::sh::zonal::eval_rgb(&prepared.irradiance_sh, Order::THREE, px.normal[k])
                .map(|e| e.max(0.0))
        };
        self.push(
            rungs,
            AttributionKind::IrradianceOrder,
            "preconv.irradiance_order".into(),
            &|| px.image(|k| e3(k).map(|e| ao(k) * e)),
        );
        let ao_map = &prepared.ao;
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            "preconv.lightmap".into(),
            &|| {
                px.image(|k| {
                    let a = lightmap_bilinear::<1>(ao_map.res, px.uv[k], 1, |t, _| {
                        f16_round(ao_map.values[t])
                    })[0];
                    e3(k).map(|e| a * e)
                })
            },
        );
        self.push_block_compression(rungs, 1, 1.0, &|v, k| e3(k).map(|e| v[0] * e));
    }
}

impl LadderRecipe for Preconv {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.preconv(rungs);
        Ok(())
    }
}
