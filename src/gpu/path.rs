//! The hardware paths (DESIGN §2): what a technique's GPU data may be on each — `dx9`
//! packed 2D textures, `dx10` arrays and seamless cube maps, `dx11` dx10's layout with the
//! per-texel data block-compressed (`technique::block`). Techniques (`technique`), the
//! scene's specular term (`render`) and the reports name them.

use std::fmt;
use std::str::FromStr;

/// The hardware paths of DESIGN §2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HwPath {
    /// DX9-class: 2D textures only, ≤ 16 textures per draw, 4 values per RGBA texel.
    Dx9,
    /// DX10-class: texture arrays for per-texel data, seamless cube (array) tables.
    Dx10,
    /// DX11-class: dx10's layout with the per-texel data block-compressed (BC7 ratios to a
    /// BC6H per-texel norm, or BC4; `technique::block`); tables stay as on dx10.
    Dx11,
}

impl HwPath {
    pub const ALL: &'static [HwPath] = &[HwPath::Dx9, HwPath::Dx10, HwPath::Dx11];

    pub fn name(self) -> &'static str {
        match self {
            HwPath::Dx9 => "dx9",
            HwPath::Dx10 => "dx10",
            HwPath::Dx11 => "dx11",
        }
    }

    /// The shader macros `SHVIS_PATH_DX9` and `SHVIS_PATH_DX11` (dx10 is neither).
    pub fn shader_defines(self) -> [(&'static str, u32); 2] {
        [
            ("PATH_DX9", (self == HwPath::Dx9) as u32),
            ("PATH_DX11", (self == HwPath::Dx11) as u32),
        ]
    }

    /// Whether the path binds arrays and cube maps (dx10 and dx11), not dx9's 2D textures.
    pub fn has_arrays(self) -> bool {
        match self {
            HwPath::Dx9 => false,
            HwPath::Dx10 | HwPath::Dx11 => true,
        }
    }
}

impl fmt::Display for HwPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for HwPath {
    type Err = UnknownPath;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        HwPath::ALL
            .iter()
            .copied()
            .find(|p| p.name() == s)
            .ok_or_else(|| UnknownPath {
                name: s.to_string(),
                known: HwPath::ALL
                    .iter()
                    .map(|p| p.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }
}

impl serde::Serialize for HwPath {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// A path name that does not parse.
#[derive(Debug, thiserror::Error)]
#[error("unknown path '{name}'; known: {known}")]
pub struct UnknownPath {
    pub name: String,
    pub known: String,
}
