//! The ladder recipe of The hemisphere bases (`hb*`, `sg*`, `dice*`): the pixel's gathered
//! radiance, the basis fitted through the pixel's own frame, then the lightmap's f16
//! values.

use super::{LadderRecipe, RowLadder, Rung};
use crate::technique::TechniqueError;
use crate::technique::hemisphere::{Hemisphere, HemisphereBasis};

impl<'a> RowLadder<'a> {
    /// The H-basis rungs ([`RowLadder::tangent_basis`]).
    fn hbasis(&self, rungs: &mut Vec<Rung>, size: crate::sh::hbasis::HBasisSize) {
        use crate::sh::hbasis;
        let rgb = |v: &[f64]| -> Vec<[f64; 3]> {
            (0..size.count())
                .map(|i| [v[3 * i], v[3 * i + 1], v[3 * i + 2]])
                .collect()
        };
        self.tangent_basis(
            rungs,
            self.technique.to_string(),
            &|radiance, frame, m| {
                hbasis::irradiance(&hbasis::project_irradiance(radiance, frame, size), m)
            },
            3 * size.count(),
            &|map| crate::technique::hemisphere::stored_texels(map, size),
            &|v, m| hbasis::irradiance(&rgb(v), m),
        );
    }

    /// The Ambient Dice rungs ([`RowLadder::tangent_basis`]): the fit at the ten vertices
    /// and its hybrid (or YCoCg) interpolation.
    fn dice(&self, rungs: &mut Vec<Rung>, variant: crate::sh::dice::DiceVariant) {
        let basis = crate::sh::dice::dice();
        self.tangent_basis(
            rungs,
            self.technique.to_string(),
            &|radiance, frame, m| {
                basis.irradiance(
                    variant,
                    &basis.project_irradiance(variant, radiance, frame),
                    m,
                )
            },
            variant.stored_values(),
            &|map| crate::technique::hemisphere::dice_stored_texels(map, variant),
            &|v, m| basis.irradiance(variant, v, m),
        );
    }

    /// The SG rungs ([`RowLadder::tangent_basis`]): the lobes fitted by the run's solver.
    fn sg(&self, rungs: &mut Vec<Rung>, lobes: u32) {
        use crate::technique::hemisphere::{fit_sg, sg_basis, sg_irradiance, sg_stored_texels};
        let basis = sg_basis(lobes);
        let solver = self.prepared.options.Hemisphere.solver;
        let rgb = |v: &[f64]| -> Vec<[f64; 3]> {
            (0..lobes as usize)
                .map(|i| [v[3 * i], v[3 * i + 1], v[3 * i + 2]])
                .collect()
        };
        self.tangent_basis(
            rungs,
            format!("{}.{solver}", self.technique),
            &|radiance, frame, m| {
                let mut stats = crate::sh::sg::FitStats::default();
                sg_irradiance(
                    &basis,
                    &fit_sg(&basis, radiance, frame, solver, &mut stats),
                    m,
                )
            },
            3 * lobes as usize,
            &|map| sg_stored_texels(map, lobes, solver).0,
            &|v, m| sg_irradiance(&basis, &rgb(v), m),
        );
    }
}

impl LadderRecipe for Hemisphere {
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        match self.basis {
            HemisphereBasis::HBasis(size) => row.hbasis(rungs, size),
            HemisphereBasis::Sg { lobes } => row.sg(rungs, lobes),
            HemisphereBasis::Dice(variant) => row.dice(rungs, variant),
        }
        Ok(())
    }
}
