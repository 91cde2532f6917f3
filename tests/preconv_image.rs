//! Measurable facts of a `preconv` image of the built-in house ("look at it", made
//! checkable): the ground under the porch roof is darker than open ground by a stated
//! margin, and the normal map gives the brick wall local contrast that a flat-normal
//! render lacks.

mod common;

use glam::Vec3;
use shvis::render::{Frame, FrameSettings};
use shvis::scene::house;
use shvis::technique::{HwPath, Technique};

const WIDTH: u32 = 640;
const HEIGHT: u32 = 400;

/// Under the overhang only AO differs from the open ground (same tint, normal map and
/// irradiance); a roof 3 m deep over a 3 m high porch hides well over a third of the
/// cosine-weighted sky, so the porch floor must be at most this fraction of the open one.
const OVERHANG_MAX_RATIO: f64 = 0.7;
/// The normal map must raise the wall's pixel-to-pixel luminance variation clearly above
/// what the brick albedo texture alone gives (measured 1.3× at 640×400).
const NORMAL_MAP_MIN_CONTRAST_GAIN: f64 = 1.15;
/// Albedo and AO cancel in mapped/flat at the same pixel, leaving E(n_mapped)/E(n_flat):
/// the relief's own shading, whose relative spread over the window must exceed this.
const NORMAL_MAP_MIN_SHADING_SPREAD: f64 = 0.05;
/// Half-size of the pixel windows measured around each landmark.
const WINDOW: i32 = 6;

fn render(flat_normals: bool) -> Frame {
    let ctx = common::validated_context();
    common::render(
        &ctx,
        common::house(),
        Technique::Preconv(shvis::technique::Preconv),
        HwPath::Dx10,
        &FrameSettings {
            width: WIDTH,
            height: HEIGHT,
            flat_normals,
            ..FrameSettings::default()
        },
    )
}

fn pixel_of(p: Vec3) -> (i32, i32) {
    let (x, y) = common::house()
        .scene
        .camera
        .project_to_pixel(p, WIDTH, HEIGHT)
        .expect("landmark in front of the camera");
    assert!(
        x >= WINDOW as f32 && y >= WINDOW as f32,
        "landmark {p} off screen at ({x}, {y})"
    );
    assert!(
        x < (WIDTH as i32 - WINDOW) as f32 && y < (HEIGHT as i32 - WINDOW) as f32,
        "landmark {p} off screen at ({x}, {y})"
    );
    (x as i32, y as i32)
}

fn window(frame: &Frame, (cx, cy): (i32, i32)) -> impl Iterator<Item = (u32, u32)> + '_ {
    (cy - WINDOW..=cy + WINDOW)
        .flat_map(move |y| (cx - WINDOW..=cx + WINDOW).map(move |x| (x as u32, y as u32)))
        .inspect(|&(x, y)| assert!(frame.covered(x, y), "background at ({x}, {y})"))
}

fn mean_luminance(frame: &Frame, c: (i32, i32)) -> f64 {
    let n = ((2 * WINDOW + 1) * (2 * WINDOW + 1)) as f64;
    window(frame, c)
        .map(|(x, y)| frame.luminance(x, y) as f64)
        .sum::<f64>()
        / n
}

/// Mean absolute difference of luminance to the right and lower neighbours, relative to
/// the mean luminance.
fn local_contrast(frame: &Frame, c: (i32, i32)) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for (x, y) in window(frame, c) {
        let l = frame.luminance(x, y) as f64;
        sum += (frame.luminance(x + 1, y) as f64 - l).abs();
        sum += (frame.luminance(x, y + 1) as f64 - l).abs();
        n += 2.0;
    }
    sum / n / mean_luminance(frame, c)
}

#[test]
fn porch_floor_is_darker_than_open_ground() {
    let frame = render(false);
    let marks = house::landmarks();
    let under = mean_luminance(&frame, pixel_of(marks.under_overhang));
    let open = mean_luminance(&frame, pixel_of(marks.open_ground));
    println!(
        "luminance under the overhang {under:.4}, open ground {open:.4}, ratio {:.3}",
        under / open
    );
    assert!(
        under < OVERHANG_MAX_RATIO * open,
        "under the overhang {under} vs open {open}"
    );
}

#[test]
fn normal_map_adds_local_contrast() {
    let mapped = render(false);
    let flat = render(true);
    let at = pixel_of(house::landmarks().brick_wall);
    let c_mapped = local_contrast(&mapped, at);
    let c_flat = local_contrast(&flat, at);
    let ratios: Vec<f64> = window(&mapped, at)
        .map(|(x, y)| mapped.luminance(x, y) as f64 / flat.luminance(x, y) as f64)
        .collect();
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let spread = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / ratios.len() as f64)
        .sqrt()
        / mean;
    println!(
        "wall local contrast: normal-mapped {c_mapped:.4}, flat {c_flat:.4}, gain {:.2}; shading spread {spread:.4}",
        c_mapped / c_flat
    );
    assert!(
        c_mapped > NORMAL_MAP_MIN_CONTRAST_GAIN * c_flat,
        "normal-mapped {c_mapped} vs flat {c_flat}"
    );
    assert!(
        spread > NORMAL_MAP_MIN_SHADING_SPREAD,
        "shading spread {spread}"
    );
}
