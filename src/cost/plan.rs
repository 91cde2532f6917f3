//! How the cost model counts a shader whose work per pixel depends on its data (the
//! clustered techniques' decodes, `technique::cluster::count_plan`).
//!
//! Counts = Σ (share + share_per_measured · s) · counts(variant): each variant is the plan's
//! count shader (never drawn; it includes the drawn shader's decode, its loops unrolled, and
//! is compiled once more with `COUNT_LOOPS` for the loops the drawn shader enters on that
//! path), s the share of shaded fragments that the measuring build (`measure_defines`, drawn
//! once over the scene, additively: red 1 where the fragment's subgroup — the SIMD batch it
//! runs in — takes the costly path, green 1 per fragment) finds (0 without one). A batch
//! with one fragment on the costly path runs both paths. Variants marked `untaken` count,
//! the same way, the work of a branch in the batches that do not take it — which a device
//! that runs untaken branches masked (lavapipe) pays in part, priced by
//! [`super::CostModel::untaken_share`].

/// A count shader's builds and how their counts combine.
#[derive(Clone, Debug, PartialEq)]
pub struct CountPlan {
    /// The count shader under `glsl/`, compiled with the technique's defines and each
    /// variant's.
    pub shader: &'static str,
    pub measure_defines: Option<Vec<(&'static str, u32)>>,
    pub variants: Vec<CountVariant>,
}

/// One build of a [`CountPlan`].
#[derive(Clone, Debug, PartialEq)]
pub struct CountVariant {
    pub defines: Vec<(&'static str, u32)>,
    pub share: f64,
    pub share_per_measured: f64,
    /// Counted as work of a branch that no lane of a batch takes, not as work done.
    pub untaken: bool,
}
