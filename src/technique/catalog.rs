//! Every technique family as `shvis techniques` lists it (the name grammar, what it is, its
//! paper, the paths it runs on and what it bakes), and the named sets (`all`, `paper`,
//! `headline`) — all read from the families' own answers ([`super::Family`]).

use super::spec::{BakeNeeds, HwPath, Technique};

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

/// The paper's cost table (Iwanicki & Sloan, Table 1): unc3/4/6, pca4–24, pca4w–24w,
/// shlmap, preconv, sh2 — the rows of the families in it.
pub fn paper_table() -> Vec<Technique> {
    Technique::all()
        .iter()
        .copied()
        .filter(|t| t.description().in_paper_table)
        .collect()
}

/// The headline set (`--techniques headline`, what `make bench` measures) on `path`: on
/// dx9 and dx10 the paper's table and the rows that stand for each later family (one, the
/// cheapest bake that shows what the family does; two for the engine SH variants, the
/// plain L1 engines ship and the stored ZH3 that improves on it; three for the hemisphere
/// bases); on dx11, where lavapipe samples BC textures in software (its BC6H/BC7 rows
/// 6.5–30× slower than dx10 in docs/results/lavapipe-dx11.md), the two rows the dx11
/// path is about: the SH lightmap and the paper's uncompressed visibility.
pub fn headline_on(path: HwPath) -> Vec<Technique> {
    Technique::headline(path)
}

/// The headline set on dx9 and dx10.
pub fn headline() -> Vec<Technique> {
    headline_on(HwPath::Dx10)
}

/// A named set of techniques (`all`, `paper`, `headline`), if `name` is one.
pub fn named_set(name: &str) -> Option<Vec<Technique>> {
    match name {
        "all" => Some(Technique::all().to_vec()),
        "paper" => Some(paper_table()),
        "headline" => Some(headline()),
        _ => None,
    }
}

/// The names [`named_set`] knows.
pub const SET_NAMES: &[&str] = &["all", "paper", "headline"];

/// Every family, in the registry's order.
pub fn families() -> Vec<Family> {
    Technique::families()
        .into_iter()
        .map(|(description, members, example)| {
            let paths = HwPath::ALL
                .iter()
                .copied()
                .filter(|&p| members.iter().any(|m| m.runs_on(p)))
                .collect();
            Family {
                names: description.names,
                members: members.iter().map(|m| m.name()).collect(),
                what: description.what,
                paper: description.paper,
                paths,
                bakes: bakes(&example.needs()),
            }
        })
        .collect()
}

/// The names of `t`'s family ("pcaM, pcaMw"): its group on the report page.
pub fn family_of(t: Technique) -> &'static str {
    t.description().names
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
        assert_eq!(headline[..paper.len()], paper[..]);
        let dx11: Vec<String> = headline_on(HwPath::Dx11).iter().map(|t| t.name()).collect();
        assert_eq!(dx11.join(","), "unc6,shlmap");
        let mut later: Vec<&str> = headline[paper.len()..]
            .iter()
            .map(|&t| family_of(t))
            .collect();
        later.dedup();
        let expected: Vec<&str> = families()
            .iter()
            .map(|f| f.names)
            .filter(|n| !paper.iter().any(|&t| family_of(t) == *n))
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
        for t in Technique::all() {
            assert!(listed.contains(&t.name()), "{t}");
        }
    }
}
