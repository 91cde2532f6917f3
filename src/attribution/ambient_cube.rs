//! The ladder recipe of the ambient cube (`acube`, `acubels`): the pixel's gathered
//! radiance, the cube fitted through the pixel's own frame and evaluated at its
//! tangent-space normal, then the lightmap's f16 values ([`RowLadder::tangent_basis`]).

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::sh::ambient_cube::{FACES, STORED_VALUES, irradiance, project_irradiance};
use crate::technique::ambient_cube::{AmbientCube, stored_texels};

impl LadderRecipe for AmbientCube {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        let fit = self.fit;
        let cube = |v: &[f64]| -> [[f64; 3]; FACES] {
            std::array::from_fn(|f| [v[3 * f], v[3 * f + 1], v[3 * f + 2]])
        };
        row.tangent_basis(
            rungs,
            row.technique.to_string(),
            &|radiance, frame, m| irradiance(&project_irradiance(radiance, frame, fit), m),
            STORED_VALUES,
            &|map| stored_texels(map, fit),
            &|v, m| irradiance(&cube(v), m),
        );
        Ok(())
    }
}
