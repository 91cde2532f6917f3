//! The ladder recipe of the NDF-filtered variants: none — their rungs would be their base
//! technique's, and their own step (the normal map's filtering) is measured by `shvis study
//! ndf`.

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::technique::ndf_diffuse::Ndf;

impl LadderRecipe for Ndf {
    fn rungs(self, _: &RowLadder<'_>, _: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        Ok(())
    }
}
