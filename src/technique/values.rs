//! What a technique's per-texel values are, as data an engine reads instead of the shader
//! (`shvis export`'s `per_texel.values`): for each value j of a texel, which coefficient of
//! which basis and which colour; what the coefficients hold; the basis' functions, frame and
//! parameters; the range scale; and the operations that turn a texel into irradiance and
//! radiance, in order. The layouts are the families' own (each family's [`Family::values`]);
//! value j is channel j mod 4 of group j div 4 (`super::texels`), the values past
//! [`ValueMap::values`] in the last group are padding (zero).
//!
//! [`Family::values`]: super::family::Family::values

use serde_json::json;

/// The colour a value belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colour {
    /// One channel of linear RGB (0 red, 1 green, 2 blue).
    Channel(u8),
    /// A value every colour shares (visibility, a luminance coefficient).
    Shared,
    /// A component of another colour space (YCoCg's "Y", "Co", "Cg").
    Component(&'static str),
}

/// One per-texel value: coefficient `index` of the basis (named `coefficient`) in `colour`.
#[derive(Clone, Debug, PartialEq)]
pub struct Value {
    pub coefficient: String,
    pub index: usize,
    pub colour: Colour,
}

/// A step of the shading, in order: `op` and its arguments as JSON.
#[derive(Clone, Debug, PartialEq)]
pub struct Step(pub serde_json::Value);

/// What a technique's per-texel values are.
#[derive(Clone, Debug, PartialEq)]
pub struct ValueMap {
    /// What the coefficients hold ("incident radiance", "irradiance", "visibility").
    pub stored: &'static str,
    /// The basis: its name, where it lives, its functions and parameters (JSON object).
    pub basis: serde_json::Value,
    /// Value j of the texel; `None`: a padding channel (zero) inside the data, as the alpha of
    /// `rnm`'s RGB groups. Channels past the list are padding too.
    pub values: Vec<Option<Value>>,
    pub steps: Vec<Step>,
}

/// The SH coefficient names of order `order` (bands l < order), flat index l(l+1)+m.
pub fn sh_coefficient_names(order: usize) -> Vec<String> {
    (0..order)
        .flat_map(|l| {
            let l = l as i64;
            (-l..=l).map(move |m| format!("y_{l},{m}"))
        })
        .collect()
}

/// RGB triplets: value 3k + c is colour c of coefficient k (`names[k]`).
pub fn triplets(names: &[String]) -> Vec<Option<Value>> {
    names
        .iter()
        .enumerate()
        .flat_map(|(k, name)| {
            (0..3).map(move |c| {
                Some(Value {
                    coefficient: name.clone(),
                    index: k,
                    colour: Colour::Channel(c),
                })
            })
        })
        .collect()
}

/// One value per coefficient that every colour shares: value k is `names[k]`.
pub fn shared(names: &[String]) -> Vec<Option<Value>> {
    names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            Some(Value {
                coefficient: name.clone(),
                index: k,
                colour: Colour::Shared,
            })
        })
        .collect()
}

/// The step that undoes the per-texel data's f16 range scaling: multiply by
/// `uniform_block.unscale.x`.
pub fn unscale() -> Step {
    Step(json!({"op": "multiply", "by": "uniform_block.unscale.x"}))
}

/// The ending every diffuse technique shares: irradiance clamped at 0, radiance =
/// albedo/π · irradiance (glsl/include/diffuse_out.glsl).
pub fn diffuse_ending() -> [Step; 2] {
    [
        Step(json!({"op": "max", "with": 0.0, "gives": "irradiance E"})),
        Step(
            json!({"op": "multiply", "by": "albedo / pi", "gives": "outgoing radiance (linear RGB)"}),
        ),
    ]
}

/// The steps of a basis evaluated at the normal `at` (giving `gives`), then unscaled
/// ([`unscale`]) and ended as every diffuse technique ends ([`diffuse_ending`]).
pub fn evaluated_and_unscaled(at: &str, gives: &str) -> Vec<Step> {
    [
        Step(json!({"op": "evaluate", "at": at, "gives": gives})),
        unscale(),
    ]
    .into_iter()
    .chain(diffuse_ending())
    .collect()
}

/// The normal every tangent-frame basis is evaluated at.
pub const TANGENT_NORMAL: &str = "the normal map's tangent-space normal m (x along +u, y image up, z out; x and y scaled by the glTF normalTexture.scale, then normalised)";

/// The normal every world-frame basis is evaluated at.
pub const WORLD_NORMAL: &str = "the shading normal n in world space: m carried by the tangent frame (glTF tangent t, bitangent w · cross(n_v, t), vertex normal n_v), normalised";

impl ValueMap {
    /// The manifest's `per_texel.values` object for data of `total` values per texel
    /// (the groups' channels).
    pub fn to_json(&self, total: usize) -> serde_json::Value {
        let values: Vec<_> = self
            .values
            .iter()
            .enumerate()
            .filter_map(|(j, v)| Some((j, v.as_ref()?)))
            .map(|(j, v)| {
                json!({
                    "j": j,
                    "coefficient": v.coefficient,
                    "index": v.index,
                    "colour": match v.colour {
                        Colour::Channel(0) => "r",
                        Colour::Channel(1) => "g",
                        Colour::Channel(_) => "b",
                        Colour::Shared => "shared",
                        Colour::Component(name) => name,
                    },
                })
            })
            .collect();
        json!({
            "stored": self.stored,
            "basis": self.basis,
            "count": values.len(),
            "padding": (0..total)
                .filter(|&j| self.values.get(j).is_none_or(|v| v.is_none()))
                .collect::<Vec<_>>(),
            "layout": "value j is channel j mod 4 (r, g, b, a) of layer j div 4; padding values are 0",
            "map": values,
            "shading": self.steps.iter().map(|s| s.0.clone()).collect::<Vec<_>>(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sh_names_follow_the_flat_index() {
        let names = sh_coefficient_names(3);
        assert_eq!(names.len(), 9);
        assert_eq!(names[0], "y_0,0");
        assert_eq!(names[1], "y_1,-1");
        assert_eq!(names[6], "y_2,0");
    }

    #[test]
    fn triplets_put_colour_c_of_coefficient_k_at_3k_plus_c() {
        let mut values = triplets(&sh_coefficient_names(2));
        assert_eq!(values.len(), 12);
        let seventh = values[7].clone().unwrap();
        assert_eq!(seventh.index, 2);
        assert_eq!(seventh.colour, Colour::Channel(1));
        values.insert(3, None);
        let map = ValueMap {
            stored: "x",
            basis: json!({}),
            values,
            steps: vec![unscale()],
        };
        let j = map.to_json(16);
        assert_eq!(j["count"], 12);
        assert_eq!(j["padding"], json!([3, 13, 14, 15]));
        assert_eq!(j["map"][7]["j"], 8);
        assert_eq!(j["map"][7]["colour"], "g");
    }
}
