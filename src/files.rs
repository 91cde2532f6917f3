//! How shvis writes data files so that equal data gives equal bytes.
//!
//! OpenEXR: the `exr` crate's default encoding writes tiles in whatever order its worker
//! threads finish (`LineOrder::Unspecified`), so two runs with identical pixels give
//! different files. [`EXR_ENCODING`] keeps its compression and tiling but asks for
//! increasing line order, which the writer sorts into, whatever the thread count.

use exr::prelude::{Encoding, LineOrder};

/// RLE, 64×64 tiles (exr's `FAST_LOSSLESS`), in increasing line order.
pub const EXR_ENCODING: Encoding = Encoding {
    line_order: LineOrder::Increasing,
    ..Encoding::FAST_LOSSLESS
};
