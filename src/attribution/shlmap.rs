//! The ladder recipe of `shlmap`: the pixel's gathered order-3 radiance, then the lightmap
//! texels (and, on dx11, the blocks). [`RowLadder::lightmap_sh`] serves the SH variants
//! too.

use super::{
    AttributionKind, DVec3, LadderRecipe, RowLadder, Rung, ShBasis, f16_round, lightmap_bilinear,
};
use crate::technique::TechniqueError;
use crate::technique::shlmap::Shlmap;

impl<'a> RowLadder<'a> {
    /// `shlmap`'s rungs (`basis` `None`) and the engine bases' (module doc): the pixel's
    /// gathered order-3 radiance, then for a basis what it stores evaluated by
    /// [`ShBasis::linear`] and, where that differs, by its own reconstruction; then the
    /// lightmap texels. None without an SH lightmap bake.
    pub(super) fn lightmap_sh(&self, rungs: &mut Vec<Rung>, basis: Option<ShBasis>) {
        let px = self.px;
        let Some((map, gathered)) = self.push_radiance_order(rungs) else {
            return;
        };
        let l2 = |c: &[[f64; 3]], n: DVec3| ShBasis::L2.irradiance(&ShBasis::L2.encode(c, None), n);
        let Some(basis) = basis else {
            // As the technique stores it (finite: the bench built it first).
            let scale = crate::technique::shlmap::stored_scale(map).unwrap_or(1.0);
            let unscale = f64::from(1.0 / scale);
            self.push(
                rungs,
                AttributionKind::LightmapTexels,
                "shlmap.lightmap".into(),
                &|| {
                    px.image(|k| {
                        let v = lightmap_bilinear::<27>(map.res, px.uv[k], 27, |t, j| {
                            f16_round(map.texel(t)[j / 3][j % 3] * scale)
                        });
                        let c: Vec<[f64; 3]> = (0..9)
                            .map(|i| std::array::from_fn(|ch| v[3 * i + ch] * unscale))
                            .collect();
                        l2(&c, px.normal[k])
                    })
                },
            );
            self.push_block_compression(rungs, 27, unscale, &|v, k| {
                let c: Vec<[f64; 3]> = (0..9)
                    .map(|i| std::array::from_fn(|ch| v[3 * i + ch]))
                    .collect();
                l2(&c, px.normal[k])
            });
            return;
        };
        let technique = self.technique;
        let linear = basis.linear();
        // The pixel's own hemisphere, as a texel's (the deringing's shaded normals).
        let shaded = |k: usize| Some(px.normal_g[k].as_dvec3());
        self.push(
            rungs,
            AttributionKind::Basis,
            format!("{}.basis", linear.label().replace(' ', "_").to_lowercase()),
            &|| {
                px.image(|k| {
                    linear.irradiance(&basis.encode(&gathered.sh[k], shaded(k)), px.normal[k])
                })
            },
        );
        if linear != basis {
            self.push(
                rungs,
                AttributionKind::Reconstruction,
                format!("{technique}.reconstruction"),
                &|| {
                    px.image(|k| {
                        basis.irradiance(&basis.encode(&gathered.sh[k], shaded(k)), px.normal[k])
                    })
                },
            );
        }
        self.push_lightmap_values(
            rungs,
            map,
            basis.stored_values(),
            &|| crate::technique::sh_variant::stored_texels(map, basis),
            &|v, k| basis.irradiance(v, px.normal[k]),
        );
    }
}

impl LadderRecipe for Shlmap {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.lightmap_sh(rungs, None);
        Ok(())
    }
}
