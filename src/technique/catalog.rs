//! Every technique family as `shvis techniques` lists it: the name grammar, what it is, its
//! paper, the paths it runs on and what it bakes. One entry per family, found by an
//! exhaustive match, so a new family does not compile until it is described here.

use super::spec::{
    BakeNeeds, EngineShBasis, HwPath, LocalBasis, NdfBase, NmprtVariant, RnmVariant, Technique,
};

/// One family's line.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Family {
    /// The names it takes: "uncO", "pcaM / pcaMw", …
    pub names: &'static str,
    /// Its members, as names (the valid parameters).
    pub members: Vec<String>,
    /// What it is, in one line.
    pub what: &'static str,
    /// Where it comes from.
    pub paper: &'static str,
    /// The hardware paths some member runs on.
    pub paths: Vec<HwPath>,
    /// What it bakes, in words.
    pub bakes: String,
}

/// One representative technique per family, in the cost table's order.
const REPRESENTATIVES: &[Technique] = &[
    Technique::Unc {
        order: crate::sh::Order::SIX,
    },
    Technique::Pca {
        m: 8,
        weights_only: false,
    },
    Technique::Shlmap,
    Technique::Preconv,
    Technique::Sh2,
    Technique::Vq {
        k: 256,
        seams: super::spec::SeamMode::Blended,
    },
    Technique::Cpca {
        k: 8,
        m: 11,
        iterative: true,
        seams: super::spec::SeamMode::Blended,
    },
    Technique::PcaVertex {
        m: 12,
        max_edge_cm: None,
    },
    Technique::Rnm {
        variant: RnmVariant::NormalMap,
    },
    Technique::Ndf {
        base: NdfBase::Preconv,
    },
    Technique::Nmprt {
        variant: NmprtVariant::Full,
    },
    Technique::EngineSh {
        basis: EngineShBasis::L1,
    },
    Technique::Local {
        basis: LocalBasis::HBasis(crate::sh::hbasis::HBasisSize::H4),
    },
];

/// The paper's cost table (Iwanicki & Sloan, Table 1): unc3/4/6, pca4–24, pca4w–24w,
/// shlmap, preconv, sh2 — the first rows of [`Technique::ALL`].
pub fn paper_table() -> Vec<Technique> {
    Technique::ALL
        .iter()
        .copied()
        .take_while(|t| PAPER_FAMILIES.contains(&family_of(*t)))
        .collect()
}

/// The families of the paper's table (their names as [`family_of`] gives them).
const PAPER_FAMILIES: &[&str] = &["uncO", "pcaM, pcaMw", "shlmap", "preconv", "sh2"];

/// The rows of each family after the paper's that stand for it in the headline set: one
/// (the cheapest bake that shows what the family does), two for the engine bases (the
/// plain L1 engines ship and the stored ZH3 that improves on it), three for the local
/// bases (the H-basis, nine spherical Gaussians and Ambient Dice).
const LATER_HEADLINES: &[Technique] = &[
    Technique::Vq {
        k: 64,
        seams: super::spec::SeamMode::Blended,
    },
    Technique::Cpca {
        k: 8,
        m: 11,
        iterative: true,
        seams: super::spec::SeamMode::Blended,
    },
    Technique::PcaVertex {
        m: 12,
        max_edge_cm: Some(25),
    },
    Technique::Rnm {
        variant: RnmVariant::NormalMap,
    },
    Technique::Ndf {
        base: NdfBase::Unc {
            order: crate::sh::Order::SIX,
        },
    },
    Technique::Nmprt {
        variant: NmprtVariant::Svd { m: 4 },
    },
    Technique::EngineSh {
        basis: EngineShBasis::L1,
    },
    Technique::EngineSh {
        basis: EngineShBasis::Zh3,
    },
    Technique::Local {
        basis: LocalBasis::HBasis(crate::sh::hbasis::HBasisSize::H4),
    },
    Technique::Local {
        basis: LocalBasis::Sg { lobes: 9 },
    },
    Technique::Local {
        basis: LocalBasis::Dice(crate::sh::dice::DiceVariant::Rgb),
    },
];

/// The headline set (`--techniques headline`, what `make bench` measures): the paper's
/// table and the rows that stand for each later family.
pub fn headline() -> Vec<Technique> {
    let mut set = paper_table();
    set.extend_from_slice(LATER_HEADLINES);
    set
}

/// The `headline` set's rows on `dx11` (lavapipe samples BC textures in software, 20–40×
/// slower than dx10, so the headline bench measures the two the dx11 path is about: the
/// SH lightmap, and the paper's uncompressed visibility).
pub const HEADLINE_DX11: &[Technique] = &[
    Technique::Shlmap,
    Technique::Unc {
        order: crate::sh::Order::SIX,
    },
];

/// A named set of techniques (`all`, `paper`, `headline`), if `name` is one.
pub fn named_set(name: &str) -> Option<Vec<Technique>> {
    match name {
        "all" => Some(Technique::ALL.to_vec()),
        "paper" => Some(paper_table()),
        "headline" => Some(headline()),
        _ => None,
    }
}

/// The names [`named_set`] knows.
pub const SET_NAMES: &[&str] = &["all", "paper", "headline"];

/// Every family, in the cost table's order.
pub fn families() -> Vec<Family> {
    REPRESENTATIVES.iter().map(|&t| family(t)).collect()
}

fn family(t: Technique) -> Family {
    let (names, what, paper) = describe(t);
    let members = t.family_members();
    let paths = HwPath::ALL
        .iter()
        .copied()
        .filter(|&p| members.iter().any(|m| m.runs_on(p)))
        .collect();
    Family {
        names,
        members: members.iter().map(|m| m.name()).collect(),
        what,
        paper,
        paths,
        bakes: bakes(&t.needs()),
    }
}

/// The names of `t`'s family ("pcaM, pcaMw"): its group on the report page.
pub fn family_of(t: Technique) -> &'static str {
    describe(t).0
}

/// (names, what, paper) of `t`'s family.
fn describe(t: Technique) -> (&'static str, &'static str, &'static str) {
    match t {
        Technique::Unc { .. } => (
            "uncO",
            "SH visibility of order O per texel, an L×H table looked up by the normal",
            "Iwanicki & Sloan §3",
        ),
        Technique::Pca { .. } => (
            "pcaM, pcaMw",
            "M PCA weights of the visibility per texel; per-vector tables (w: SH of V_k·L in uniforms)",
            "Iwanicki & Sloan §3–4",
        ),
        Technique::Shlmap => (
            "shlmap",
            "order-3 SH of incident radiance with inter-reflection per texel (static light)",
            "Iwanicki & Sloan §5",
        ),
        Technique::Preconv => (
            "preconv",
            "ambient occlusion × pre-convolved irradiance at the normal",
            "Iwanicki & Sloan §5",
        ),
        Technique::Sh2 => (
            "sh2",
            "order-2 visibility per texel, the SH product with the lighting in the shader",
            "Iwanicki & Sloan §5",
        ),
        Technique::Vq { .. } => (
            "vqK, vqKn",
            "k-means cluster of the visibility per texel, per-cluster lighting in uniforms (n: naive seams)",
            "Sloan et al., PRT course (CPCA)",
        ),
        Technique::Cpca { .. } => (
            "cpcaK_M, cpcaK_Ms, …n",
            "clustered PCA: a cluster and M weights per texel (s: static clusters; n: naive seams)",
            "Sloan et al., CPCA for PRT (SIGGRAPH 2003)",
        ),
        Technique::PcaVertex { .. } => (
            "pcaMv, pcaMvE",
            "PCA weights baked at mesh vertices (edges ≤ E cm), interpolated, shaded as pcaMw",
            "Iwanicki & Sloan §4 (per-vertex)",
        ),
        Technique::Rnm { .. } => (
            "rnm, rnmao, ssbump",
            "radiosity normal mapping: three lightmaps in the HL2 basis; ao: × height-field AO; ssbump: self-shadowed bump map",
            "Green, Valve (SIGGRAPH 2007 course)",
        ),
        Technique::Ndf { .. } => (
            "uncOndf, preconvndf",
            "the base technique with its normal map filtered as a distribution (moment maps)",
            "Olano & North, Normal Distribution Mapping",
        ),
        Technique::Nmprt { .. } => (
            "nmprt, nmprtsvdM, nmprtsvdMp, nmprthl2, nmprtratio",
            "normal mapping for PRT: transfer matrices per texel, evaluated at the normal",
            "Sloan, PRT course (normal mapping)",
        ),
        Technique::EngineSh { .. } => (
            "l1, l1geo, l1zh3, zh3, l1lum, shlmapw",
            "the SH lightmaps engines ship, from shlmap's bake: L1 (linear, Geomerics, hallucinated ZH3), stored ZH3, luminance L1, deringed L2",
            "Frostbite, Enlighten, Roughton et al. ZH3 (i3D 2024), Unreal, Sloan (deringing)",
        ),
        Technique::Local { .. } => (
            "hb4, hb6, sgN, dice, dicey",
            "bases over the tangent-frame hemisphere, read at the tangent-space normal: the H-basis; N spherical Gaussians fitted by --sg-solve; Ambient Dice (icosahedron vertices, hybrid Bézier; YCoCg)",
            "Habel & Wimmer (I3D 2010); Neubelt & Pettineo (The Order: 1886), MJP's SG series; Iwanicki & Sloan (EGSR 2017)",
        ),
    }
}

/// What `needs` bakes, in words.
fn bakes(needs: &BakeNeeds) -> String {
    let mut parts = Vec::new();
    if let Some(order) = needs.visibility {
        parts.push(format!("SH visibility (order {})", order.get()));
    }
    if needs.pca_vectors.is_some() {
        parts.push("PCA of the visibility".into());
    }
    if needs.clusters.is_some() {
        parts.push("clusters of the visibility".into());
    }
    if needs.sh_lightmap {
        parts.push("SH lightmap with inter-reflection".into());
    }
    if needs.transfer {
        parts.push("transfer matrices".into());
    }
    if needs.ao {
        parts.push("ambient occlusion".into());
    }
    if needs.ssbump {
        parts.push("SSBump from the height field".into());
    }
    if needs.ndf_moments {
        parts.push("normal-map moments".into());
    }
    if parts.is_empty() {
        "nothing".into()
    } else {
        parts.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_headline_set_is_the_paper_table_and_rows_of_every_later_family() {
        let paper = paper_table();
        let names: Vec<String> = paper.iter().map(|t| t.name()).collect();
        assert_eq!(
            names.join(","),
            "unc3,unc4,unc6,pca4,pca8,pca12,pca16,pca24,pca4w,pca8w,pca12w,pca16w,pca24w,shlmap,preconv,sh2"
        );
        let headline = headline();
        let mut later: Vec<&str> = headline[paper.len()..]
            .iter()
            .map(|&t| family_of(t))
            .collect();
        later.dedup();
        let expected: Vec<&str> = families()
            .iter()
            .map(|f| f.names)
            .filter(|n| !PAPER_FAMILIES.contains(n))
            .collect();
        assert_eq!(later, expected);
        for set in SET_NAMES {
            assert!(named_set(set).is_some_and(|s| !s.is_empty()), "{set}");
        }
    }

    #[test]
    fn every_technique_belongs_to_a_listed_family() {
        let listed: Vec<String> = families().into_iter().flat_map(|f| f.members).collect();
        for t in Technique::nameable() {
            assert!(
                listed.contains(&t.name()),
                "{t} is in no family of the catalog"
            );
        }
        for t in Technique::ALL {
            assert!(listed.contains(&t.name()), "{t}");
        }
    }
}
