//! The ladder recipe of `nmprt*`: the technique's own model per pixel, exact (f32 texel
//! values, f64 evaluation, the SVD basis evaluated rather than looked up); what remains to
//! the GPU image is f16 storage and the basis texture. No rungs before it yet (the
//! transfer's lighting order, the order-3 transferred radiance, the bounces).

use super::{
    AttributionKind, LadderRecipe, NmprtVariant, RowLadder, Rung, Vec3, lightmap_bilinear,
    lightmap_taps,
};
use crate::technique::TechniqueError;
use crate::technique::nmprt::Nmprt;

impl<'a> RowLadder<'a> {
    /// `nmprt*`'s one rung: the technique's own model at each pixel (none without a
    /// transfer bake).
    fn nmprt(&self, rungs: &mut Vec<Rung>, variant: NmprtVariant) {
        let (px, prepared, technique) = (self.px, self.prepared, self.technique);
        let Some(transfer) = prepared.transfer.as_ref() else {
            return;
        };
        let recipe = crate::technique::nmprt::NmprtRecipe::new(variant, transfer.clone());
        let radiance = &prepared.radiance_sh;
        let irradiance = &prepared.irradiance_sh;
        self.push(
            rungs,
            AttributionKind::Technique,
            format!("{technique}.model"),
            &|| {
                let values = recipe.texel_values_all(radiance, irradiance);
                let v = recipe.values_per_texel();
                px.image(|k| {
                    let x = lightmap_bilinear::<36>(transfer.res, px.uv[k], v, |t, j| {
                        f64::from(values[t * v + j])
                    });
                    // The frame of the nearest covered tap.
                    let (taps, weights) = lightmap_taps(transfer.res, px.uv[k]);
                    let frame = taps
                        .iter()
                        .zip(weights)
                        .filter(|(t, _)| transfer.covered[**t])
                        .max_by(|a, b| a.1.total_cmp(&b.1))
                        .map_or([Vec3::ZERO; 3], |(t, _)| transfer.frames[*t]);
                    recipe.eval(&x[..v], px.normal[k], &frame, irradiance)
                })
            },
        );
    }
}

impl LadderRecipe for Nmprt {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.nmprt(rungs, self.variant);
        Ok(())
    }
}
