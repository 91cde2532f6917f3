//! The rungs the clustered techniques share (`vqK`, `cpcaK_M`; their recipes are
//! `vq.rs` and `cpca.rs`): visibility order, the cluster compression and the shared
//! compression rungs, then the stored lightmap as the shader reads it.

use super::{
    AttributionKind, RowLadder, Rung, SeamMode, lightmap_bilinear, lightmap_taps, shade,
    texel_index_of,
};
use crate::technique::{ClusterNeed, TechniqueError};

impl<'a> RowLadder<'a> {
    /// `vq*` and `cpca*`'s rungs: visibility order, the cluster compression and the rungs
    /// of [`compression_rungs`], then the stored lightmap as the shader reads it.
    pub(super) fn clustered(
        &self,
        rungs: &mut Vec<Rung>,
        need: ClusterNeed,
        seams: SeamMode,
    ) -> Result<(), TechniqueError> {
        let (px, technique, label) = (self.px, self.technique, &self.label);
        let model = crate::technique::cluster::find(&self.prepared.inputs(), need, label)?;
        let order = model.order;
        let n2 = order.coeff_count();
        self.push_visibility(rungs, order);
        let compressed = |k: usize| {
            let mut out = [0.0; 36];
            out[..n2].copy_from_slice(&model.compress(&px.visibility(k, n2)[..n2]));
            out
        };
        let base = technique.name();
        let lxh = self.push_compression(
            rungs,
            order,
            (
                AttributionKind::ClusterCompression,
                format!("{base}.compression"),
            ),
            &base,
            &compressed,
        );
        // The stored lightmap as the shader reads it (glsl/technique/cluster.frag).
        let q = model.quantize();
        let blended = seams == SeamMode::Blended;
        let stored = |k: usize| -> [f64; 36] {
            let mut out = [0.0; 36];
            if blended {
                let (index, weight) = lightmap_taps(q.res, px.uv[k]);
                for (&t, &w) in index.iter().zip(&weight) {
                    for (o, v) in out.iter_mut().zip(q.reconstruct(t)) {
                        *o += w * v;
                    }
                }
            } else {
                let c = q.cluster_of[texel_index_of(q.res, px.uv[k])] as usize;
                let u: [f64; 36] = lightmap_bilinear(q.res, px.uv[k], q.m, |t, i| {
                    f64::from(q.weights_unorm[t * q.m + i]) / 255.0
                });
                out[..n2].copy_from_slice(&q.means[c][..n2]);
                for (b, ub) in q.bases[c].iter().zip(&u) {
                    for (o, bj) in out.iter_mut().zip(b) {
                        *o += ub * bj;
                    }
                }
            }
            out
        };
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{label}.lightmap"),
            &|| px.image(|k| shade(&lxh, px.normal[k], &stored(k))),
        );
        Ok(())
    }
}
