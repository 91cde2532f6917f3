//! Diffuse techniques under NDF filtering (`unc{O}ndf`, `preconvndf`;
//! shaders `glsl/include/ndf_diffuse.glsl` with `grouped.glsl` / `preconv.frag`).
//!
//! A minified pixel covers many normal-map texels; what it should shade with is the mean of
//! the shading f(n) over their normals, ∫ p(n) f(n) dn with p the normals' distribution
//! (the NDF), not f at their renormalised mean. The NDF maps' moments (`crate::ndf`; built
//! here with σ = 0, `crate::ndf::moment_maps`) give that integral at lookup time:
//!
//! **preconv — exact, anisotropic.** f(n) = AO · Σ_{l<3,m} E_lm y_lm(n), and every
//! y_lm with l ≤ 2 is a polynomial of degree ≤ 2 in the components of unit n (1; x, y, z;
//! xy, yz, xz, 2z² − x² − y², x² − y²). So
//!
//! ```text
//! E_p[f] = AO · Σ E_lm ŷ_lm(u, M),   ŷ: x → u = E[n], xxᵀ → M = E[nnᵀ]
//! ```
//!
//! exactly, for any p: the nine moments are what order-3 irradiance needs
//! ([`expected_sh_order3`]; three extra fetches).
//!
//! **unc — isotropic, from the mean length.** f(n) = Σ_j V_j T_j(n) with the L×H table
//! T_j(n) = Σ_k M_kj A_l y_k(n) over the clamped cosine's bands l < h_order (3: bands 0–2;
//! `crate::bake::lxh`). For p rotationally symmetric about μ, Funk–Hecke gives
//! ∫ p(n) y_lm(n) dn = a_l y_lm(μ), a_l = E[P_l(n·μ)]: band l is attenuated by a_l, with
//! a_0 = 1, a_1 = E[n·μ] = r the mean length. Bands are separated without per-band
//! tables by parity: T(μ) − T(−μ) is twice the odd part, which is band 1 alone (the clamped
//! cosine's odd bands above 1 vanish, A_3 = A_5 = 0), T(μ) + T(−μ) twice the even part,
//! and band 0 is the constant T0_j = L_j / 4 (M_0j = L_j y_00, A_0 = π; [`ambient_block`]):
//!
//! ```text
//! T̄(μ) = T0 + a_1 (T(μ) − T(−μ))/2 + a_2 ((T(μ) + T(−μ))/2 − T0)
//!      = (1 − a_2) T0 + (a_2 + a_1)/2 · T(μ) + (a_2 − a_1)/2 · T(−μ)
//! ```
//!
//! exact for h_order ≤ 4; beyond it band 4 is attenuated by a_2 instead of a_4. The mean
//! length r is the one moment read (one fetch); a_2 comes from the von Mises–Fisher
//! distribution of that mean length ([`zonal_attenuation`]): a_1 = coth κ − 1/κ = r, the
//! Bessel recurrence a_2 = 1 − 3a_1/κ, and Banerjee et al.'s κ ≈ r(3 − r²)/(1 − r²) give
//! a_2 = 2r²/(3 − r²) (1 for one normal, 0 for a uniform spread). Cost: every table
//! fetched twice (at ±μ) plus one moment fetch; Σ_j V_j T0_j from uniforms. μ is the
//! shading normal the unfiltered technique uses, so a_1 = a_2 = 1 gives its image exactly.
//!
//! **Magnification.** Bilinear magnification blends neighbouring texels' moments, which
//! would read as a spread although the pixel sees one interpolated normal. The filter's
//! weight is w = clamp(λ, 0, 1), λ the normal map's level of detail (`textureQueryLod`),
//! and each a_l becomes 1 + w (a_l − 1) (preconv: the filtered and unfiltered irradiance
//! blended by w): where the map is magnified the image is the unfiltered technique's, from
//! one level of minification on the filter is whole.

use std::sync::Arc;

use glam::DVec3;

use super::family::{Description, Family, Form, Refusal};
use super::finish::{SlotKind, TextureSlot};
use super::lighting::Recipe;
use super::spec::{BakeNeeds, ReferenceModel};
use super::texels::TexelGroups;
use super::{
    HwPath, Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError, texels::VALUES_PER_TEXEL,
};
use crate::gpu::{Context, GpuError, Image, ImageDesc};
use crate::ndf::{Moments, NdfMaps};
use crate::sh::Order;

/// (a_1, a_2): the attenuation of SH bands 1 and 2 by the von Mises–Fisher distribution of
/// mean length `r` (module doc).
pub fn zonal_attenuation(r: f64) -> [f64; 2] {
    let r = r.clamp(0.0, 1.0);
    [r, 2.0 * r * r / (3.0 - r * r)]
}

/// E_p[y_i(n)], i < 9, for a distribution of unit normals with moments `m`: the order-3
/// basis with x → E[n], xxᵀ → E[nnᵀ] (module doc; mirrors `sh_expect_order3` of
/// `glsl/include/sh.glsl`).
pub fn expected_sh_order3(m: &Moments) -> [f64; 9] {
    use std::f64::consts::PI;
    let k00 = 0.5 * (1.0 / PI).sqrt();
    let k1 = (3.0 / (4.0 * PI)).sqrt();
    let k2 = 0.5 * (15.0 / PI).sqrt();
    let k20 = 0.25 * (5.0 / PI).sqrt();
    let k22 = 0.25 * (15.0 / PI).sqrt();
    let (u, s) = (m.mean, m.second);
    let (xx, yy, zz) = (s.x_axis.x, s.y_axis.y, s.z_axis.z);
    let (xy, xz, yz) = (s.y_axis.x, s.z_axis.x, s.z_axis.y);
    [
        k00,
        -k1 * u.y,
        k1 * u.z,
        -k1 * u.x,
        k2 * xy,
        -k2 * yz,
        k20 * (2.0 * zz - xx - yy),
        -k2 * xz,
        k22 * (xx - yy),
    ]
}

/// The L×H table filtered by an isotropic NDF (module doc): from T(μ), T(−μ), the band-0
/// constant T0 and (a_1, a_2).
pub fn filtered_table_value(t_mu: f64, t_minus_mu: f64, t0: f64, a: [f64; 2]) -> f64 {
    (1.0 - a[1]) * t0 + 0.5 * (a[1] + a[0]) * t_mu + 0.5 * (a[1] - a[0]) * t_minus_mu
}

/// The band-0 constant T0_j = L_j / 4 of the L×H table of order `order` per colour, as the
/// shader reads it: vec4 `c·G + g` holds coefficients 4g..4g+3 of colour c (G groups).
pub fn ambient_block(radiance_sh: &[[f64; 3]], order: Order) -> Vec<[f32; 4]> {
    let n = order.coeff_count();
    let groups = n.div_ceil(VALUES_PER_TEXEL);
    (0..3)
        .flat_map(|c| {
            (0..groups).map(move |g| {
                std::array::from_fn(|k| {
                    let j = VALUES_PER_TEXEL * g + k;
                    if j < n {
                        (radiance_sh[j][c] / 4.0) as f32
                    } else {
                        0.0
                    }
                })
            })
        })
        .collect()
}

/// The moment images a technique on `base` binds: `unc` the first moments only (one 2D
/// texture), `preconv` all three (dx9: three 2D textures; dx10, dx11: a 3-layer array); each
/// with the full MIP chain.
pub fn upload(
    ctx: &Arc<Context>,
    maps: &NdfMaps,
    base: NdfBase,
    path: HwPath,
    label: &str,
) -> Result<Vec<Image>, GpuError> {
    match base {
        NdfBase::Preconv => crate::render::specular::upload_maps(ctx, maps, path),
        NdfBase::Unc { .. } => {
            let format = crate::render::specular::check_moment_filtering(ctx)?;
            let (w, h) = (maps.levels[0].width, maps.levels[0].height);
            let data: Vec<Vec<&[u8]>> = maps
                .levels
                .iter()
                .map(|l| vec![bytemuck::cast_slice(&l.textures[0][..])])
                .collect();
            Ok(vec![Image::with_data(
                ctx,
                &ImageDesc::texture_2d(format, w, h).mip_levels(maps.levels.len() as u32),
                &data,
                &format!("{label}.ndf_mean"),
            )?])
        }
    }
}

/// The mean length of the unit normals `normals` (the r of [`zonal_attenuation`]).
pub fn mean_length(normals: &[DVec3]) -> f64 {
    (normals.iter().sum::<DVec3>() / normals.len().max(1) as f64).length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::lxh::LxhMatrices;
    use crate::sh::basis::eval_basis_vec;

    fn lighting(order: Order) -> Vec<[f64; 3]> {
        (0..order.coeff_count())
            .map(|j| {
                let x = (j as f64 * 0.71).sin();
                [1.0 + x, 0.5 - 0.3 * x, 0.2 * x]
            })
            .collect()
    }

    /// Normals at angle θ about μ, evenly spread in azimuth: a zonal distribution with
    /// a_1 = cos θ, a_2 = P_2(cos θ) exactly (band-2 functions need ≥ 5 azimuths).
    fn ring(mu: DVec3, theta: f64, count: usize) -> Vec<DVec3> {
        let (e1, e2) = mu.any_orthonormal_pair();
        (0..count)
            .map(|k| {
                let phi = std::f64::consts::TAU * (k as f64 + 0.3) / count as f64;
                mu * theta.cos() + (e1 * phi.cos() + e2 * phi.sin()) * theta.sin()
            })
            .collect()
    }

    #[test]
    fn the_parity_split_filters_the_lxh_table_exactly_for_a_zonal_ndf() {
        let order = Order::SIX;
        let radiance = lighting(Order::new(8).unwrap());
        let lxh = LxhMatrices::new(&radiance, order, Order::THREE);
        let t0 = ambient_block(&radiance, order);
        let mu = DVec3::new(0.3, -0.5, 0.8).normalize();
        for theta in [0.2f64, 0.7, 1.3] {
            let normals = ring(mu, theta, 7);
            let (c, p2) = (theta.cos(), 0.5 * (3.0 * theta.cos().powi(2) - 1.0));
            let (plus, minus) = (lxh.eval(mu), lxh.eval(-mu));
            for j in 0..order.coeff_count() {
                for ch in 0..3 {
                    let truth = normals.iter().map(|&n| lxh.eval(n)[j][ch]).sum::<f64>()
                        / normals.len() as f64;
                    let band0 = f64::from(t0[ch * 9 + j / 4][j % 4]);
                    let got = filtered_table_value(plus[j][ch], minus[j][ch], band0, [c, p2]);
                    assert!(
                        (got - truth).abs() < 1e-5 * (1.0 + truth.abs()),
                        "θ {theta} j {j} c {ch}: {got} vs {truth}"
                    );
                }
            }
        }
    }

    #[test]
    fn band_zero_of_the_lxh_table_is_a_quarter_of_the_lighting() {
        let order = Order::FOUR;
        let radiance = lighting(Order::SIX);
        let lxh = LxhMatrices::new(&radiance, order, Order::THREE);
        let quadrature = crate::sh::project::sphere_quadrature(24);
        let t0 = ambient_block(&radiance, order);
        for j in 0..order.coeff_count() {
            let mean: f64 = quadrature
                .iter()
                .map(|&(d, w)| lxh.eval(d)[j][1] * w)
                .sum::<f64>()
                / (4.0 * std::f64::consts::PI);
            let stored = f64::from(t0[4 + j / 4][j % 4]);
            assert!((mean - stored).abs() < 1e-5, "j {j}: {mean} vs {stored}");
        }
    }

    #[test]
    fn order_three_expectation_is_exact_for_any_mixture() {
        let normals: Vec<DVec3> = (0..11)
            .map(|i| {
                let a = i as f64 * 0.9;
                DVec3::new(a.sin() * 0.8, (1.7 * a).cos() * 0.5, 0.6 + 0.3 * a.cos()).normalize()
            })
            .collect();
        let parts: Vec<Moments> = normals
            .iter()
            .map(|&n| Moments::of_normal(n, 0.0))
            .collect();
        let mixture = Moments::mixture(&parts);
        let expected = expected_sh_order3(&mixture);
        for (i, &e) in expected.iter().enumerate() {
            let truth = normals
                .iter()
                .map(|&n| eval_basis_vec(Order::THREE, n)[i])
                .sum::<f64>()
                / normals.len() as f64;
            assert!((e - truth).abs() < 1e-12, "y{i}: {e} vs {truth}");
        }
        // One normal: the expectation is the basis itself.
        let n = normals[3];
        let one = expected_sh_order3(&Moments::of_normal(n, 0.0));
        let basis = eval_basis_vec(Order::THREE, n);
        assert!(one.iter().zip(&basis).all(|(a, b)| (a - b).abs() < 1e-12));
    }

    #[test]
    fn vmf_band_two_from_the_mean_length_tracks_the_true_vmf() {
        // The vMF of concentration κ: r = coth κ − 1/κ, a_2 = 1 − 3r/κ exactly.
        for kappa in [0.5f64, 2.0, 8.0, 50.0, 400.0] {
            let r = 1.0 / kappa.tanh() - 1.0 / kappa;
            let a2_true = 1.0 - 3.0 * r / kappa;
            let [a1, a2] = zonal_attenuation(r);
            assert_eq!(a1, r);
            assert!((a2 - a2_true).abs() < 0.03, "κ {kappa}: {a2} vs {a2_true}");
        }
        assert_eq!(zonal_attenuation(1.0), [1.0, 1.0]);
        assert_eq!(zonal_attenuation(0.0), [0.0, 0.0]);
        assert_eq!(mean_length(&[DVec3::Z, -DVec3::Z]), 0.0);
    }
}

/// The technique an NDF-filtered variant ([`Ndf`]) extends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NdfBase {
    Unc { order: Order },
    Preconv,
}

impl NdfBase {
    /// The unfiltered technique.
    pub fn technique(self) -> Technique {
        match self {
            NdfBase::Unc { order } => super::unc::Unc { order }.into(),
            NdfBase::Preconv => super::preconv::Preconv.into(),
        }
    }
}

/// The `uncOndf`, `preconvndf` family: the base technique with its normal map filtered as a
/// distribution (Olano & North; module doc): the clamped-cosine bands attenuated at lookup
/// time by the zonal coefficients of the pixel's filtered normals — isotropic from the mean
/// length for `unc`, exact from all nine moments for `preconv`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Ndf {
    pub base: NdfBase,
}

impl Family for Ndf {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "uncOndf, preconvndf",
        what: "the base technique with its normal map filtered as a distribution (moment maps)",
        paper: "Olano & North, Normal Distribution Mapping",
        in_paper_table: false,
    };
    const EXAMPLE: Ndf = Ndf {
        base: NdfBase::Preconv,
    };

    fn members() -> Vec<Ndf> {
        super::unc::UNC_ORDERS
            .filter_map(|o| Order::new(o).ok())
            .map(|order| NdfBase::Unc { order })
            .chain([NdfBase::Preconv])
            .map(|base| Ndf { base })
            .collect()
    }

    fn table_rows() -> Vec<Ndf> {
        vec![
            Ndf {
                base: NdfBase::Unc { order: Order::SIX },
            },
            Ndf::EXAMPLE,
        ]
    }

    fn headline(path: HwPath) -> Vec<Ndf> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![Ndf {
                base: NdfBase::Unc { order: Order::SIX },
            }],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        format!("{}ndf", self.base.technique().name())
    }

    fn paper_ms(self) -> Option<f64> {
        None
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds {
            ndf_moments: true,
            ..self.base.technique().needs()
        }
    }

    fn reference(self) -> ReferenceModel {
        ReferenceModel::Direct
    }

    fn dynamic_lighting(self) -> bool {
        true
    }

    fn ndf_variant(self) -> Option<Technique> {
        Some(self.into())
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        Ok(Form {
            material_textures: true,
            ..self.base.technique().form_on(path)?
        })
    }

    fn prepare(
        self,
        path: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        _: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        let base = self.base.technique();
        let (texels, recipe) = base.prepare_data(path, inputs, &format!("{base}.{path}"))?;
        let order = match self.base {
            NdfBase::Unc { order } => Some(order),
            NdfBase::Preconv => None,
        };
        let recipe = Recipe::Ndf {
            base: Box::new(recipe),
            order,
        };
        Ok((texels, recipe))
    }

    fn extra_slot(
        self,
        ctx: &Arc<Context>,
        path: HwPath,
        inputs: &Inputs<'_>,
        label: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError> {
        let maps = inputs.ndf_moments.ok_or_else(|| TechniqueError::Input {
            label: label.into(),
            detail: "needs the moments of the material's normal map (prepare builds them)".into(),
        })?;
        let images = upload(ctx, maps, self.base, path, label)?;
        Ok((!images.is_empty()).then_some(TextureSlot {
            kind: SlotKind::Material,
            images,
        }))
    }

    fn fragment_shader(self) -> ShaderVariant {
        let mut shader = self.base.technique().fragment_shader();
        shader.defines.push(("NDF_DIFFUSE", 1));
        shader
    }

    fn reads(self) -> ShaderReads {
        ShaderReads {
            table_fetches: match self.base {
                NdfBase::Unc { .. } => 2,
                NdfBase::Preconv => 1,
            },
            ..self.base.technique().reads()
        }
    }

    fn options_tag(self, _: &()) -> Option<String> {
        None
    }

    fn sample_fit(self, _: &()) -> Option<crate::sh::samples::SampleFit> {
        None
    }

    fn values(self) -> Option<super::values::ValueMap> {
        None
    }
}
