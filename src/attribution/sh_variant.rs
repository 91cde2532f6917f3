//! The ladder recipe of the SH lightmap variants engines ship (`l1`, `zh3`, …; `sh::bases`):
//! the pixel's gathered order-3 radiance (`shlmap`'s first rung), then "basis" (what the
//! texel stores, evaluated by `ShBasis::linear`) and, for Geomerics and hallucinated ZH3,
//! "reconstruction", then the lightmap texels reconstructed as the shader does.

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::technique::sh_variant::ShVariant;

impl LadderRecipe for ShVariant {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        row.lightmap_sh(rungs, Some(self.basis.sh_basis()));
        Ok(())
    }
}
