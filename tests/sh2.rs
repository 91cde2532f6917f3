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
