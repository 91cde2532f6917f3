//! The ladder recipe of `cpcaK_M`, `cpcaK_Ms`, `…n`: the clustered techniques' rungs
//! ([`RowLadder::clustered`]).

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::technique::cpca::Cpca;

impl LadderRecipe for Cpca {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.clustered(rungs, self.cluster_need(), self.seams)
    }
}
