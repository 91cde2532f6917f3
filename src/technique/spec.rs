//! What a technique *is*, without a GPU: a family with its parameters ([`Technique`]) and
//! the hardware path it runs on ([`HwPath`]) (DESIGN §2).
//!
//! Every question the rest of the tool asks about a technique — its CLI name, the family's
//! valid parameters (which is what a name such as `unc6` or `pca12w` parses into), the paper's ms/frame, what it needs from the bake, which
//! reference its error is measured against, whether it can follow changing lighting — is
//! answered here by an exhaustive `match` on the family. There is deliberately no wildcard
//! arm over families: adding one is a compile error in each of these matches (and in
//! [`super::build`] and [`super::fragment_shader`]) until every question is answered.

use std::fmt;
use std::str::FromStr;

use crate::sh::Order;

/// A technique of the cost table: a family and its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Technique {
    /// `uncO`: uncompressed SH visibility of order O per texel and an L×H table indexed by
    /// the normal (Iwanicki–Sloan §3, eq. (4)).
    Unc { order: Order },
    /// `pcaM`: M PCA weights of the order-6 visibility per texel and per-basis tables
    /// T_k(n) (eq. (6)); `pcaMw` (`weights_only`): the basis' SH(V_k·L) in uniforms instead
    /// of tables (§4, footnote 2).
    Pca { m: u32, weights_only: bool },
    /// `shlmap`: order-3 SH of incident radiance with inter-reflection per texel (§5).
    Shlmap,
    /// `preconv`: ambient occlusion × pre-convolved irradiance (§5).
    Preconv,
    /// `sh2`: order-2 visibility per texel, the SH product in the shader (§5).
    Sh2,
}

/// Visibility orders a `uncO` name may ask for: the shader packs at most 9 RGBA groups
/// (order 6), and order 1 has no directional information to shadow with.
pub const UNC_ORDERS: std::ops::RangeInclusive<u32> = 2..=6;
/// Largest PCA basis (`pca24`): the fit in `prepare` computes this many vectors.
pub const PCA_MAX_VECTORS: u32 = 24;
/// PCA weights are packed 4 per RGBA8 texel, so M is a multiple of this.
pub const PCA_VECTORS_PER_TEXEL: u32 = 4;

/// The paper's cost table (GeForce GTX 295, 1280×800, 512² visibility; DESIGN §3), by
/// parameter where the family has one.
const PAPER_UNC_MS: &[(u32, f64)] = &[(6, 8.19), (4, 3.33), (3, 2.75)];
const PAPER_PCA_MS: &[(u32, f64)] = &[(4, 1.40), (8, 2.08), (16, 3.61), (24, 5.56)];
const PAPER_SHLMAP_MS: f64 = 0.846;
const PAPER_PRECONV_MS: f64 = 0.648;
const PAPER_SH2_MS: f64 = 0.607;

/// What a technique reads from the bake (`prepare`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BakeNeeds {
    /// SH visibility per texel, at least this order.
    pub visibility: Option<Order>,
    /// A PCA of the order-6 visibility with at least this many vectors.
    pub pca_vectors: Option<u32>,
    /// The SH lightmap (incident radiance with inter-reflection).
    pub sh_lightmap: bool,
    /// Scalar ambient occlusion per texel.
    pub ao: bool,
}

/// Which ground truth a technique's error is measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceModel {
    /// Direct light only: the model of every technique with precomputed visibility.
    Direct,
    /// With inter-reflection (N bounces, as baked): what an SH lightmap models.
    InterReflected,
}

impl Technique {
    /// The cost table's rows, in DESIGN §2 order.
    pub const ALL: &'static [Technique] = &[
        Technique::Unc {
            order: Order::THREE,
        },
        Technique::Unc { order: Order::FOUR },
        Technique::Unc { order: Order::SIX },
        Technique::Pca {
            m: 4,
            weights_only: false,
        },
        Technique::Pca {
            m: 8,
            weights_only: false,
        },
        Technique::Pca {
            m: 12,
            weights_only: false,
        },
        Technique::Pca {
            m: 16,
            weights_only: false,
        },
        Technique::Pca {
            m: 24,
            weights_only: false,
        },
        Technique::Pca {
            m: 4,
            weights_only: true,
        },
        Technique::Pca {
            m: 8,
            weights_only: true,
        },
        Technique::Pca {
            m: 12,
            weights_only: true,
        },
        Technique::Pca {
            m: 16,
            weights_only: true,
        },
        Technique::Pca {
            m: 24,
            weights_only: true,
        },
        Technique::Shlmap,
        Technique::Preconv,
        Technique::Sh2,
    ];

    /// The CLI name: `unc6`, `pca12`, `pca12w`, `shlmap`, `preconv`, `sh2`.
    pub fn name(self) -> String {
        match self {
            Technique::Unc { order } => format!("unc{order}"),
            Technique::Pca { m, weights_only } => {
                format!("pca{m}{}", if weights_only { "w" } else { "" })
            }
            Technique::Shlmap => "shlmap".into(),
            Technique::Preconv => "preconv".into(),
            Technique::Sh2 => "sh2".into(),
        }
    }

    /// ms/frame of the paper's cost table for the techniques it measured.
    pub fn paper_ms(self) -> Option<f64> {
        let lookup = |table: &[(u32, f64)], key: u32| {
            table.iter().find(|(k, _)| *k == key).map(|&(_, ms)| ms)
        };
        match self {
            Technique::Unc { order } => lookup(PAPER_UNC_MS, order.get()),
            // The paper timed only the table variant.
            Technique::Pca { m, weights_only } => {
                (!weights_only).then(|| lookup(PAPER_PCA_MS, m)).flatten()
            }
            Technique::Shlmap => Some(PAPER_SHLMAP_MS),
            Technique::Preconv => Some(PAPER_PRECONV_MS),
            Technique::Sh2 => Some(PAPER_SH2_MS),
        }
    }

    /// The paper's time relative to its `preconv`.
    pub fn paper_ratio_to_preconv(self) -> Option<f64> {
        Some(self.paper_ms()? / Technique::Preconv.paper_ms()?)
    }

    /// What the technique reads from the bake.
    pub fn needs(self) -> BakeNeeds {
        match self {
            Technique::Unc { order } => BakeNeeds {
                visibility: Some(order),
                ..BakeNeeds::default()
            },
            Technique::Pca { m, .. } => BakeNeeds {
                visibility: Some(Order::SIX),
                pca_vectors: Some(m),
                ..BakeNeeds::default()
            },
            Technique::Shlmap => BakeNeeds {
                sh_lightmap: true,
                ..BakeNeeds::default()
            },
            Technique::Preconv => BakeNeeds {
                ao: true,
                ..BakeNeeds::default()
            },
            Technique::Sh2 => BakeNeeds {
                visibility: Some(Order::TWO),
                ..BakeNeeds::default()
            },
        }
    }

    /// The ground truth its error is measured against.
    pub fn reference(self) -> ReferenceModel {
        match self {
            Technique::Shlmap => ReferenceModel::InterReflected,
            Technique::Unc { .. } | Technique::Pca { .. } | Technique::Preconv | Technique::Sh2 => {
                ReferenceModel::Direct
            }
        }
    }

    /// Whether a change of lighting needs only new per-lighting data (tables, uniforms),
    /// not a new bake.
    pub fn dynamic_lighting(self) -> bool {
        match self {
            Technique::Shlmap => false,
            Technique::Unc { .. } | Technique::Pca { .. } | Technique::Preconv | Technique::Sh2 => {
                true
            }
        }
    }

    /// Every technique of this one's family that a name may denote: each valid parameter.
    pub fn family_members(self) -> Vec<Technique> {
        match self {
            Technique::Unc { .. } => UNC_ORDERS
                .filter_map(|o| Order::new(o).ok())
                .map(|order| Technique::Unc { order })
                .collect(),
            Technique::Pca { .. } => (PCA_VECTORS_PER_TEXEL..=PCA_MAX_VECTORS)
                .step_by(PCA_VECTORS_PER_TEXEL as usize)
                .flat_map(|m| [false, true].map(|weights_only| Technique::Pca { m, weights_only }))
                .collect(),
            Technique::Shlmap | Technique::Preconv | Technique::Sh2 => vec![self],
        }
    }

    /// Every technique a CLI name can denote: the families of [`Technique::ALL`] with all
    /// their parameters. Parsing is the inverse of [`Technique::name`] over this set.
    pub fn nameable() -> Vec<Technique> {
        let mut all: Vec<Technique> = Technique::ALL
            .iter()
            .flat_map(|t| t.family_members())
            .collect();
        let mut seen = std::collections::HashSet::new();
        all.retain(|t| seen.insert(*t));
        all
    }
}

impl fmt::Display for Technique {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

impl FromStr for Technique {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let found = Technique::nameable().into_iter().find(|t| t.name() == s);
        found.ok_or_else(|| ParseError::UnknownTechnique {
            name: s.to_string(),
            known: format!(
                "{} (and uncO for O in {}..={}, pcaM/pcaMw for M a multiple of {} up to {})",
                join_names(Technique::ALL.iter().map(|t| t.name())),
                UNC_ORDERS.start(),
                UNC_ORDERS.end(),
                PCA_VECTORS_PER_TEXEL,
                PCA_MAX_VECTORS
            ),
        })
    }
}

impl serde::Serialize for Technique {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

/// The hardware paths of DESIGN §2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HwPath {
    /// DX9-class: 2D textures only, ≤ 16 textures per draw, 4 values per RGBA texel.
    Dx9,
    /// DX10-class: texture arrays for per-texel data, seamless cube (array) tables.
    Dx10,
}

impl HwPath {
    pub const ALL: &'static [HwPath] = &[HwPath::Dx9, HwPath::Dx10];

    pub fn name(self) -> &'static str {
        match self {
            HwPath::Dx9 => "dx9",
            HwPath::Dx10 => "dx10",
        }
    }

    /// The value of the shader macro `SHVIS_PATH_DX9`.
    pub fn shader_define(self) -> (&'static str, u32) {
        ("PATH_DX9", (self == HwPath::Dx9) as u32)
    }
}

impl fmt::Display for HwPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for HwPath {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        HwPath::ALL
            .iter()
            .copied()
            .find(|p| p.name() == s)
            .ok_or_else(|| ParseError::UnknownPath {
                name: s.to_string(),
                known: join_names(HwPath::ALL.iter().map(|p| p.name().to_string())),
            })
    }
}

impl serde::Serialize for HwPath {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

fn join_names(names: impl Iterator<Item = String>) -> String {
    names.collect::<Vec<_>>().join(", ")
}

/// A technique or path name that does not parse.
#[derive(Debug, thiserror::Error)]
pub enum ParseError {
    #[error("unknown technique '{name}'; known: {known}")]
    UnknownTechnique { name: String, known: String },
    #[error("unknown path '{name}'; known: {known}")]
    UnknownPath { name: String, known: String },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_lists_known() {
        for &t in Technique::ALL {
            assert_eq!(t.name().parse::<Technique>().unwrap(), t);
        }
        for &p in HwPath::ALL {
            assert_eq!(p.name().parse::<HwPath>().unwrap(), p);
        }
        let e = "unc7".parse::<Technique>().unwrap_err().to_string();
        assert!(e.contains("unc7") && e.contains("preconv"), "{e}");
        let e = "dx11".parse::<HwPath>().unwrap_err().to_string();
        assert!(e.contains("dx9, dx10"), "{e}");
    }

    #[test]
    fn parameterised_names_parse_beyond_the_cost_table() {
        assert_eq!(
            "unc5".parse::<Technique>().unwrap(),
            Technique::Unc {
                order: Order::new(5).unwrap()
            }
        );
        assert_eq!(
            "pca20w".parse::<Technique>().unwrap(),
            Technique::Pca {
                m: 20,
                weights_only: true
            }
        );
        for bad in [
            "unc", "unc1", "unc7", "unc+6", "unc06x", "pca", "pca0", "pca6", "pca28", "pcaw",
            "pca4ww", "pca-4", "sh3", "Preconv", "",
        ] {
            assert!(bad.parse::<Technique>().is_err(), "{bad:?} parsed");
        }
    }

    #[test]
    fn paper_figures_only_where_the_paper_measured() {
        let named = |s: &str| s.parse::<Technique>().unwrap().paper_ms();
        assert_eq!(named("unc6"), Some(8.19));
        assert_eq!(named("pca24"), Some(5.56));
        assert_eq!(named("pca12"), None);
        assert_eq!(named("pca4w"), None);
        assert_eq!(named("unc5"), None);
        let r = named("sh2").unwrap() / named("preconv").unwrap();
        assert_eq!(Technique::Sh2.paper_ratio_to_preconv(), Some(r));
    }

    #[test]
    fn needs_and_references_follow_the_family() {
        let pca = Technique::Pca {
            m: 12,
            weights_only: true,
        };
        assert_eq!(pca.needs().pca_vectors, Some(12));
        assert_eq!(pca.needs().visibility, Some(Order::SIX));
        assert!(Technique::Shlmap.needs().sh_lightmap && !Technique::Shlmap.dynamic_lighting());
        assert!(Technique::Preconv.needs().ao);
        for &t in Technique::ALL {
            let bounced = t.reference() == ReferenceModel::InterReflected;
            assert_eq!(bounced, t == Technique::Shlmap, "{t}");
        }
    }
}
