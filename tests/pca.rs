//! PCA-compressed visibility: error against the reference falls as the basis
//! grows, and the weights-only variant matches the table variant.

mod common;

use shvis::report::metrics::image_error;
use shvis::sh::Order;
use shvis::technique::{HwPath, Technique};

/// pcaNw and pcaN compute the same ∫ L V H₃ from the same 8-bit weights; they differ by the
/// table's bilinear reconstruction over normals (32² per face) and its f16 storage —
/// measured ≈ 1e-3 relative; this leaves an order of magnitude.
const WEIGHTS_ONLY_AGREEMENT: f64 = 0.01;

#[test]
fn error_falls_with_basis_size_and_weights_only_matches() {
    let ctx = common::validated_context();
    let prepared = common::house();
    let (reference, settings) = common::house_reference(&ctx);
    let pairs = [4, 8, 12, 16, 24].map(|m| {
        (
            Technique::Pca(shvis::technique::Pca {
                m,
                weights_only: false,
            }),
            Technique::Pca(shvis::technique::Pca {
                m,
                weights_only: true,
            }),
        )
    });
    let mut errors = Vec::new();
    for (table, weights_only) in pairs {
        let a = common::render(&ctx, prepared, table, HwPath::Dx10, &settings);
        let b = common::render(&ctx, prepared, weights_only, HwPath::Dx10, &settings);
        let e = image_error(&a, &reference.frame).expect("overlap").rel_rmse;
        let between = image_error(&b, &a).expect("overlap").rel_rmse;
        println!("{table}: rel RMSE {e:.4}; {weights_only} vs {table}: {between:.2e}");
        assert!(
            between < WEIGHTS_ONLY_AGREEMENT,
            "{weights_only} vs {table}: {between}"
        );
        errors.push(e);
    }
    let unc6 = common::render(
        &ctx,
        prepared,
        Technique::Unc(shvis::technique::Unc { order: Order::SIX }),
        HwPath::Dx10,
        &settings,
    );
    let e_unc6 = image_error(&unc6, &reference.frame)
        .expect("overlap")
        .rel_rmse;
    println!(
        "unc6: rel RMSE {e_unc6:.4} (reference noise {:.4})",
        reference.rel_noise
    );
    for w in errors.windows(2) {
        assert!(w[1] < w[0], "error must fall with M: {errors:?}");
    }
}
