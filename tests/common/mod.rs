//! Fixtures shared by the integration tests: a small prepared house scene, a Vulkan
//! context with validation on that fails the test on any message, and rendering.
#![allow(dead_code)] // each test binary uses a subset

use std::sync::{Arc, OnceLock};

use glam::Vec3;
use shvis::gpu::{Context, ContextDesc};
use shvis::prepare::{PrepareSettings, Prepared, prepare};
use shvis::render::{Frame, FrameSettings, SceneGpu};
use shvis::scene::{Mesh, Texture8, Vertex};
use shvis::technique::{self, HwPath, Technique};

/// Lightmap resolution of test bakes: small, yet a texel is ~10 cm on the house.
pub const TEST_VIS_RES: u32 = 128;
/// Rays per texel of test bakes.
pub const TEST_RAYS: u32 = 128;
/// L×H table texels per side in tests (the paper's lower bound).
pub const TEST_TABLE_RES: u32 = 16;

/// The built-in house and sky, baked once per test binary.
pub fn house() -> &'static Prepared {
    static PREPARED: OnceLock<Prepared> = OnceLock::new();
    PREPARED.get_or_init(|| {
        let mut prepared = prepare(&PrepareSettings {
            vis_res: TEST_VIS_RES,
            rays: TEST_RAYS,
            table_res: TEST_TABLE_RES,
            cache_dir: Some(concat!(env!("CARGO_TARGET_TMPDIR"), "/bake-cache").into()),
            sh_lightmap_bounces: Some(shvis::bake::shlmap::DEFAULT_BOUNCES),
            // Every member of every family (`sg5` and the rest beyond the table's rows).
            sample_fits: shvis::prepare::sample_fits_for(
                &Technique::families()
                    .into_iter()
                    .flat_map(|(_, members, _)| members)
                    .collect::<Vec<_>>(),
                &Default::default(),
            ),
            transfer_bounces: Some(shvis::bake::shlmap::DEFAULT_BOUNCES),
            ..PrepareSettings::default()
        })
        .expect("the built-in scene prepares");
        prepared
            .prepare_techniques(Technique::all())
            .expect("the cost table's cluster fits and vertex bakes");
        prepared
    })
}

/// A context with VK_LAYER_KHRONOS_validation on.
pub fn validated_context() -> Arc<Context> {
    // Validation messages reach the test output through the log.
    let _ = env_logger::builder()
        .is_test(true)
        .filter_level(log::LevelFilter::Warn)
        .try_init();
    Context::new(&ContextDesc {
        validate: true,
        device: None,
        ..ContextDesc::default()
    })
    .expect("a Vulkan device with the validation layer (lavapipe in CI)")
}

/// Fails the test if validation said anything at warning level or above.
pub fn assert_validation_clean(ctx: &Context, what: &str) {
    let (errors, warnings) = ctx.message_counts();
    assert_eq!(
        (errors, warnings),
        (0, 0),
        "{what}: validation errors/warnings (see the log)"
    );
}

/// Renders one technique × path of `prepared` and checks validation stayed clean.
pub fn render(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    id: Technique,
    path: HwPath,
    settings: &FrameSettings,
) -> Frame {
    let scene = SceneGpu::new(ctx, &prepared.scene, settings).expect("scene uploads");
    let tech =
        technique::build(ctx, &scene, id, path, &prepared.inputs()).expect("technique builds");
    let frame = tech.render(&scene, 1, 2).expect("frames render");
    drop(tech);
    drop(scene);
    assert_validation_clean(ctx, &format!("{id}.{path}"));
    frame
}

/// Width and height of the error tests' images (technique and reference alike).
pub const ERROR_TEST_SIZE: (u32, u32) = (320, 200);

/// The reference of the test house at `ERROR_TEST_SIZE` (64 spp; with the 2-bounce image
/// for `shlmap` in `bounced`) and the frame settings to render techniques against it.
///
/// Point-sampled (the techniques' own pixel sampling, MIP-filtered normal map): the error
/// tests compare techniques' visibility, compression and lighting error, which the
/// footprint reference's normal-map filtering error would drown on the minified bricks
/// (`tests/reference_footprint.rs` measures the footprint against a brute force).
pub fn house_reference(ctx: &Arc<Context>) -> (shvis::reference::ReferenceImage, FrameSettings) {
    let (width, height) = ERROR_TEST_SIZE;
    let prepared = house();
    let reference = shvis::reference::render_reference(
        ctx,
        &prepared.scene,
        &prepared.env,
        &shvis::reference::ReferenceSettings {
            width,
            height,
            spp: 64,
            seed: 3,
            bounces: shvis::bake::shlmap::DEFAULT_BOUNCES,
            footprint: false,
        },
    )
    .expect("reference renders");
    let settings = FrameSettings {
        width,
        height,
        ..FrameSettings::default()
    };
    (reference, settings)
}

/// Appends a quad with corners `p` (counter-clockwise seen from the front) and lightmap
/// corners `uv` (all zero for a quad that is not baked: zero UV area, skipped).
pub fn quad(m: &mut Mesh, p: [Vec3; 4], uv: [[f32; 2]; 4]) {
    let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
    let base = m.vertices.len() as u32;
    for k in 0..4 {
        m.vertices.push(Vertex {
            position: p[k].to_array(),
            normal: normal.to_array(),
            uv_lightmap: uv[k],
            ..Vertex::default()
        });
    }
    m.indices
        .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// Lightmap corners covering the whole lightmap.
pub const FULL_UV: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
/// Lightmap corners of a quad that is not baked (zero UV area).
pub const NO_UV: [[f32; 2]; 4] = [[0.0; 2]; 4];

/// A 1×1 RGBA8 texture: a constant albedo or normal map.
pub fn solid_texture(texel: [u8; 4]) -> Texture8 {
    Texture8::solid(texel)
}

/// xorshift64*: deterministic mutations (the stable fuzz stand-ins) without a dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// Uniform in 0..n (n = 0 counts as 1).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}
