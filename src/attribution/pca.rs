//! The ladder recipe of `pcaM` and `pcaMw`: the visibility rung, PCA compression, then the
//! tables or the weights-only block and the lightmap.

use super::{
    AttributionKind, LadderRecipe, LxhMatrices, Order, QuantizedPca, RowLadder, Rung, StoredTable,
    build_table, eval_basis, lightmap_bilinear, quantized_prefix, table_map, weights_only_block,
};
use crate::technique::TechniqueError;
use crate::technique::pca::Pca;

impl<'a> RowLadder<'a> {
    /// `pcaM` and `pcaMw`'s rungs: visibility order, the PCA compression and the rungs of
    /// [`compression_rungs`], then the stored form (tables, or the weights-only block).
    fn pca(&self, rungs: &mut Vec<Rung>, m: u32, weights_only: bool) -> Result<(), TechniqueError> {
        let (px, label) = (self.px, &self.label);
        let model = &self.prepared.pca;
        let order = model.order;
        let n2 = order.coeff_count();
        if n2 > 36 {
            log::warn!(
                "{label}: the error ladder handles PCA of visibility up to order 6, the bake has order {order}; no CPU rungs"
            );
            return Ok(());
        }
        let m = (m as usize).min(model.basis.len());
        self.push_visibility(rungs, order);
        // V_e + Σ_k (V_k·(V − V_e)) V_k over the first m (orthonormal) vectors.
        let compressed = |k: usize| {
            let v = px.visibility(k, n2);
            let mut out = [0.0; 36];
            out[..n2].copy_from_slice(&model.mean[..n2]);
            for b in &model.basis[..m] {
                let w: f64 = (0..n2).map(|j| b[j] * (v[j] - model.mean[j])).sum();
                for j in 0..n2 {
                    out[j] += w * b[j];
                }
            }
            out
        };
        let base = format!("pca{m}");
        let lxh = self.push_compression(
            rungs,
            order,
            (
                AttributionKind::PcaCompression,
                format!("{base}.pca_compression"),
            ),
            &base,
            &compressed,
        );
        let q = quantized_prefix(model, m);
        // The stored weights, bilinear: UNORM8 reads as q / 255.
        let unorm = f64::from((1u32 << q.bits) - 1);
        let lightmap_u = |k: usize| {
            lightmap_bilinear(q.res, px.uv[k], q.m, |t, i| {
                f64::from(q.weights_unorm[t * q.m + i]) / unorm
            })
        };
        if weights_only {
            self.push_pca_weights_only_lightmap(rungs, order, &q, &lightmap_u);
        } else {
            self.push_pca_table_rungs(rungs, &lxh, &q, &compressed, &lightmap_u)?;
        }
        Ok(())
    }

    /// `pcaMw`'s lightmap rung: the stored weights `lightmap_u` applied to the uniform
    /// block of order-3 SH (`weights_only_block`), evaluated at the shading normal.
    fn push_pca_weights_only_lightmap(
        &self,
        rungs: &mut Vec<Rung>,
        order: Order,
        q: &QuantizedPca,
        lightmap_u: &(dyn Fn(usize) -> [f64; 36] + Sync),
    ) {
        let (px, technique) = (self.px, self.technique);
        let block = weights_only_block(&q.basis, &q.mean, order, &self.prepared.radiance_sh);
        let shade_weights = |u: &[f64], k: usize| {
            let mut y = [0.0; 9];
            eval_basis(Order::THREE, px.normal[k], &mut y);
            let mut e = [0.0; 3];
            for (i, yi) in y.iter().enumerate() {
                for c in 0..3 {
                    let mut coeff = f64::from(block[9 * q.m + i][c]);
                    for (b, ub) in u[..q.m].iter().enumerate() {
                        coeff += ub * f64::from(block[9 * b + i][c]);
                    }
                    e[c] += coeff * yi;
                }
            }
            e
        };
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{technique}.lightmap"),
            &|| px.image(|k| shade_weights(&lightmap_u(k), k)),
        );
        // The blocks decode to the weights' unorm values, as the RGBA8 lightmap reads.
        self.push_block_compression(rungs, q.m, 1.0, &shade_weights);
    }

    /// `pcaM`'s last rungs: the quantized basis's and mean's normal tables read with the
    /// compressed V's continuous weights (normal table), then with the stored weights
    /// `lightmap_u` (lightmap texels).
    fn push_pca_table_rungs(
        &self,
        rungs: &mut Vec<Rung>,
        lxh: &LxhMatrices,
        q: &QuantizedPca,
        compressed: &(dyn Fn(usize) -> [f64; 36] + Sync),
        lightmap_u: &(dyn Fn(usize) -> [f64; 36] + Sync),
    ) -> Result<(), TechniqueError> {
        let (px, label) = (self.px, &self.label);
        let n2 = self.prepared.pca.order.coeff_count();
        // Basis tables T_k = Σ_j V_kj (L×H)_j and the mean's, as pca.rs builds them.
        let map = table_map(self.path, self.prepared.table_res, label)?;
        let table = build_table(lxh, map);
        let project = |t: usize, v: &[f64]| table.project(t, v);
        let stored = StoredTable::new(map, q.m + 1, |t, i| {
            project(t, if i < q.m { &q.basis[i] } else { &q.mean })
        });
        let tables_dot = |u: &[f64], k: usize| {
            let t = stored.eval(px.normal[k]);
            let mut s = t[q.m];
            for (ui, ti) in u[..q.m].iter().zip(&t) {
                for c in 0..3 {
                    s[c] += ui * ti[c];
                }
            }
            s.map(|x| x * stored.unscale)
        };
        // The compressed V in the quantized basis's coordinates, unrounded.
        let continuous_u = |k: usize| {
            let v = compressed(k);
            let mut u = [0.0; 36];
            for (ui, b) in u.iter_mut().zip(&q.basis) {
                let norm2: f64 = b.iter().map(|x| x * x).sum();
                if norm2 > 0.0 {
                    *ui = (0..n2).map(|j| b[j] * (v[j] - q.mean[j])).sum::<f64>() / norm2;
                }
            }
            u
        };
        self.push(
            rungs,
            AttributionKind::NormalTable,
            format!("{label}.normal_table"),
            &|| px.image(|k| tables_dot(&continuous_u(k), k)),
        );
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{label}.lightmap"),
            &|| px.image(|k| tables_dot(&lightmap_u(k), k)),
        );
        self.push_block_compression(rungs, q.m, 1.0, &tables_dot);
        Ok(())
    }
}

impl LadderRecipe for Pca {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.pca(rungs, self.m, self.weights_only)
    }
}
