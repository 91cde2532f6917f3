//! The ladder recipe of `vqK`, `vqKn`: the clustered techniques' rungs
//! ([`RowLadder::clustered`]).

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::technique::vq::Vq;

impl LadderRecipe for Vq {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.clustered(rungs, self.cluster_need(), self.seams)
    }
}
