//! Which rows a bench over the whole technique list keeps on a given scene.

use crate::prepare::Prepared;
use crate::technique::Technique;

/// Removes from `techniques` the rows that need a height map when `prepared`'s scene has
/// none (named on their own they fail with the reason instead); returns those removed.
pub fn drop_rows_without_height_map(
    techniques: &mut Vec<Technique>,
    prepared: &Prepared,
) -> Vec<Technique> {
    if prepared.ssbump.is_some() {
        return Vec::new();
    }
    let (kept, dropped): (Vec<Technique>, Vec<Technique>) =
        techniques.iter().partition(|t| !t.needs().ssbump);
    *techniques = kept;
    dropped
}
