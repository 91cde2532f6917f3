//! `sh2` (order-2 visibility, order-3 lighting, product and convolution in the shader):
//! the generated product include matches the Gaunt tensor; error ordering on the house.

mod common;

use shvis::technique::sh2::product_glsl;

/// `glsl/include/sh_product.glsl` is `product_glsl()`'s output. Run with
/// `SHVIS_REGENERATE=1` to rewrite it after changing the generator.
#[test]
fn generated_product_include_is_current() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/glsl/include/sh_product.glsl");
    let generated = product_glsl();
    if std::env::var_os("SHVIS_REGENERATE").is_some() {
        std::fs::write(path, &generated).unwrap();
    }
    let on_disk = std::fs::read_to_string(path).unwrap();
    assert_eq!(
        on_disk, generated,
        "{path} is stale: rerun with SHVIS_REGENERATE=1"
    );
}

/// On the house, sh2 captures some of the shadowing preconv misses (the paper's Fig. 4
/// reading): its error against the reference is below preconv's, and the paths agree.
#[test]
fn sh2_error_is_below_preconv_and_paths_agree() {
    use shvis::report::metrics::image_error;
    use shvis::technique::{HwPath, Technique};
    let ctx = common::validated_context();
    let (reference, settings) = common::house_reference(&ctx);
    let prepared = common::house();
    let mut sh2 = vec![];
    for &path in HwPath::ALL {
        let e = |t| {
            let frame = common::render(&ctx, prepared, t, path, &settings);
            image_error(&frame, &reference.frame).unwrap().rel_rmse
        };
        let (e_sh2, e_preconv) = (
            e(Technique::Sh2(shvis::technique::Sh2)),
            e(Technique::Preconv(shvis::technique::Preconv)),
        );
        println!(
            "{path}: relative RMSE sh2 {e_sh2:.4}, preconv {e_preconv:.4} (reference noise {:.4})",
            reference.rel_noise
        );
        assert!(e_sh2 < e_preconv, "{e_sh2} vs {e_preconv}");
        sh2.push(e_sh2);
    }
    assert!((sh2[0] - sh2[1]).abs() < 0.01, "dx9 vs dx10: {sh2:?}");
}
