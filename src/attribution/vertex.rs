//! The ladder recipe of `pcaMv`: none — the CPU ladder walks lightmap texels, and
//! per-vertex weights have none.

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::technique::vertex::PcaVertex;

impl LadderRecipe for PcaVertex {
    fn rungs(self, _: &RowLadder<'_>, _: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        Ok(())
    }
}
