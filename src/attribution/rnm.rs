//! The ladder recipe of the radiosity-normal-mapping family: none yet — its error is
//! measured against the displaced-geometry reference (`shvis study rnm`), not split into
//! rungs.

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::technique::rnm::Rnm;

impl LadderRecipe for Rnm {
    fn rungs(self, _: &RowLadder<'_>, _: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        Ok(())
    }
}
