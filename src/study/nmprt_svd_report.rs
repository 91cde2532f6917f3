//! `shvis study nmprt-svd` as one call: the energy captured by the normal basis, clamped
//! and over the whole sphere, uniform and cosine-weighted, beside the course's.

use super::nmprt_svd::{
    NormalWeighting, energy_captured, hl2_energy, normal_matrix_over, to_markdown,
};

/// The study's markdown for a `side`² disk grid of normals and `quadrature`² hemisphere
/// cells.
pub fn report(side: usize, quadrature: usize) -> String {
    let mut svd = Vec::new();
    let mut hl2 = [0.0; 4];
    for (k, (clamped, w)) in [
        (true, NormalWeighting::Uniform),
        (true, NormalWeighting::Cosine),
        (false, NormalWeighting::Uniform),
        (false, NormalWeighting::Cosine),
    ]
    .into_iter()
    .enumerate()
    {
        let a = normal_matrix_over(side, quadrature, w, clamped);
        svd.push(energy_captured(&a));
        hl2[k] = hl2_energy(side, &a, w);
    }
    to_markdown(side, [&svd[0], &svd[1]], [&svd[2], &svd[3]], hl2)
}
