//! `acube`, `acubels`: the ambient cube (Valve's Source engine: McTaggart, "Half-Life 2 /
//! Valve Source Shading", GDC 2004; Mitchell, McTaggart & Green, "Shading in Valve's Source
//! Engine", SIGGRAPH 2006 course) as a lightmap basis over a texel's tangent frame: six RGB
//! values, one per ±axis of the frame, blended by the squared components of the normal —
//! so the normal map's tangent-space normal indexes the texel directly, as with the
//! hemisphere bases (`super::hemisphere`). From `shlmap`'s bake; the lighting is baked in.
//! The basis, its evaluation and its fits are `crate::sh::ambient_cube`'s.
//!
//! # Storage and shader
//!
//! Per texel the 18 values (value 3·face + c) range-scaled into f16 as `shlmap`'s are, in 5
//! RGBA16F groups (40 bytes; the last two values unused); on dx11 BC7 ratios to a BC6H norm
//! per colour (`super::block`). `glsl/technique/ambient_cube.frag` evaluates (1) at the
//! normal map's tangent-space normal, branch-free (each axis selects its face by its
//! sign), and writes albedo/π · max(0, E). `acube` is fitted by (2), `acubels` by (3).


use std::sync::Arc;

use super::block::{BlockCodec, NormColours};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::Recipe;
use super::spec::{BakeNeeds, HwPath, ReferenceModel};
use super::texels::{TexelGroups, VALUES_PER_TEXEL};
use super::{Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::bake::shlmap::ShLightmap;
use crate::gpu::Context;
pub use crate::sh::ambient_cube::{CubeFit, FACES, STORED_VALUES};
use crate::sh::ambient_cube::project_irradiance;
use crate::sh::samples::{BasisFit, SampleFit};

/// Every texel's cube (texel-major, [`STORED_VALUES`] each, face-major RGB) before the f16
/// range scale; zeros where the lightmap has no frame.
pub fn stored_texels(map: &ShLightmap, fit: CubeFit) -> Vec<f32> {
    super::hemisphere::per_texel_values(map, |radiance, frame| {
        project_irradiance(radiance, frame, fit)
            .into_iter()
            .flatten()
            .collect()
    })
}

/// The ambient-cube family: `acube` (Valve's projection, (2)) and `acubels` (the
/// hemisphere's least squares, (3)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AmbientCube {
    pub fit: CubeFit,
}

impl Family for AmbientCube {
    type Options = BasisFit;
    const DESCRIPTION: Description = Description {
        names: "acube, acubels",
        what: "Valve's ambient cube over the tangent frame: six RGB values per texel blended by the squared normal; fitted at the axes (ls: least squares over the hemisphere)",
        paper: "McTaggart (GDC 2004); Mitchell, McTaggart & Green (SIGGRAPH 2006 course)",
        in_paper_table: false,
    };
    const EXAMPLE: AmbientCube = AmbientCube {
        fit: CubeFit::Projection,
    };

    fn members() -> Vec<AmbientCube> {
        CubeFit::ALL.map(|fit| AmbientCube { fit }).to_vec()
    }

    fn table_rows() -> Vec<AmbientCube> {
        AmbientCube::members()
    }

    fn headline(path: HwPath) -> Vec<AmbientCube> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![AmbientCube::EXAMPLE],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        match self.fit {
            CubeFit::Projection => "acube",
            CubeFit::LeastSquares => "acubels",
        }
        .into()
    }

    fn paper_ms(self) -> Option<f64> {
        None
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds::SH_LIGHTMAP
    }

    fn reference(self) -> ReferenceModel {
        ReferenceModel::InterReflected
    }

    fn dynamic_lighting(self) -> bool {
        false
    }

    fn ndf_variant(self) -> Option<Technique> {
        None
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        Ok(Form::values(path, BlockCodec::Ratio(NormColours::Triplets)))
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        fit: &BasisFit,
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        let map = super::shlmap::baked_map(inputs, label)?;
        let stored = match fit {
            BasisFit::Samples => {
                let fit = SampleFit::AmbientCube(self.fit);
                super::hemisphere::fitted_values(map, fit, label)?.texel_values()
            }
            BasisFit::L2 => stored_texels(map, self.fit),
        };
        let name = format!("{label}.ambient_cube");
        let (texels, recipe, _) =
            super::shlmap::baked_values(&stored, STORED_VALUES, map.res, name, label)?;
        Ok((texels, recipe))
    }

    fn extra_slot(
        self,
        _: &Arc<Context>,
        _: HwPath,
        _: &Inputs<'_>,
        _: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError> {
        Ok(None)
    }

    fn fragment_shader(self) -> ShaderVariant {
        ShaderVariant {
            path: "technique/ambient_cube.frag",
            defines: vec![(
                "AMBIENT_CUBE_GROUPS",
                STORED_VALUES.div_ceil(VALUES_PER_TEXEL) as u32,
            )],
        }
    }

    fn reads(self) -> ShaderReads {
        ShaderReads::PLAIN
    }

    fn options_tag(self, fit: &BasisFit) -> Option<String> {
        Some(fit.to_string())
    }

    fn sample_fit(self, fit: &BasisFit) -> Option<SampleFit> {
        (*fit == BasisFit::Samples).then_some(SampleFit::AmbientCube(self.fit))
    }

    fn values(self) -> Option<super::values::ValueMap> {
        use super::values::{self, ValueMap};
        let names: Vec<String> = ["+x", "-x", "+y", "-y", "+z", "-z"]
            .iter()
            .map(|f| format!("face {f}"))
            .collect();
        Some(ValueMap {
            stored: match self.fit {
                CubeFit::Projection => "irradiance along each axis of the texel's tangent frame (Valve's projection)",
                CubeFit::LeastSquares => "the ambient cube least-squares fitted to the irradiance over the texel's hemisphere",
            },
            basis: serde_json::json!({
                "name": "ambient cube",
                "reference": "McTaggart, Half-Life 2 / Valve Source Shading, GDC 2004",
                "frame": "tangent (x along +u, y image up, z the surface normal)",
            }),
            values: values::triplets(&names),
            steps: values::evaluated_and_unscaled(values::TANGENT_NORMAL, "E(m) = m.x^2 C[+x or -x] + m.y^2 C[+y or -y] + m.z^2 C[+z or -z], each axis' face chosen by the sign of its component, per colour"),
        })
    }
}
