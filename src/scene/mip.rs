//! MIP chains built on the CPU: the material textures' (sRGB or UNORM RGBA8, averaged in
//! linear light) and box chains of float texels (the SSBump's, the NDF moments').

use super::Texture8;

/// Level 0 = `tex`; each next level halves each side (at least 1) with a 2×2 box filter
/// ([`box_mip_levels`]) in linear light (`srgb`: the colour channels are sRGB-encoded).
pub fn mip_chain(tex: &Texture8, srgb: bool) -> Vec<Texture8> {
    let to_linear = |c: u8| {
        let c = c as f32 / 255.0;
        if !srgb {
            c
        } else if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let from_linear = |c: f32| {
        let c = if !srgb {
            c
        } else if c <= 0.0031308 {
            c * 12.92
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        };
        (c * 255.0).round().clamp(0.0, 255.0) as u8
    };
    let linear = tex
        .texels
        .iter()
        .map(|t| {
            [
                to_linear(t[0]),
                to_linear(t[1]),
                to_linear(t[2]),
                f32::from(t[3]) / 255.0,
            ]
        })
        .collect();
    let levels = box_mip_levels(tex.width, tex.height, linear);
    std::iter::once(tex.clone())
        .chain(levels.into_iter().skip(1).map(|(width, height, texels)| {
            Texture8 {
                width,
                height,
                texels: texels
                    .iter()
                    .map(|t| {
                        [
                            from_linear(t[0]),
                            from_linear(t[1]),
                            from_linear(t[2]),
                            (t[3] * 255.0).round().clamp(0.0, 255.0) as u8,
                        ]
                    })
                    .collect(),
            }
        }))
        .collect()
}

/// MIP levels (width, height, texels) of `width` × `height` RGBA texels (row-major): level
/// 0 = `texels`, each next halves each side (at least 1) with a 2×2 box filter, clamped at
/// odd edges. The material textures' chains ([`mip_chain`]) and the SSBump's.
pub fn box_mip_levels(
    width: u32,
    height: u32,
    texels: Vec<[f32; 4]>,
) -> Vec<(u32, u32, Vec<[f32; 4]>)> {
    let mut levels = vec![(width, height, texels)];
    while let Some((pw, ph, prev)) = levels.last().filter(|(w, h, _)| *w > 1 || *h > 1) {
        let (pw, ph) = (*pw, *ph);
        let (w, h) = ((pw / 2).max(1), (ph / 2).max(1));
        let mut next = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0.0f32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(pw - 1);
                    let sy = (2 * y + dy).min(ph - 1);
                    let t = prev[(sy * pw + sx) as usize];
                    for c in 0..4 {
                        sum[c] += t[c];
                    }
                }
                next.push(sum.map(|v| v / 4.0));
            }
        }
        levels.push((w, h, next));
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(width: u32, height: u32, texel: impl Fn(u32, u32) -> [u8; 4]) -> Texture8 {
        Texture8 {
            width,
            height,
            texels: (0..height)
                .flat_map(|y| (0..width).map(move |x| (x, y)))
                .map(|(x, y)| texel(x, y))
                .collect(),
        }
    }

    #[test]
    fn mip_chain_halves_to_one_texel_with_box_averages() {
        let tex = texture(8, 2, |x, y| [(x * 30) as u8, (y * 200) as u8, 17, 255]);
        let levels = mip_chain(&tex, false);
        let sizes: Vec<(u32, u32)> = levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(8, 2), (4, 1), (2, 1), (1, 1)]);
        assert_eq!(levels[0].texels, tex.texels);
        // Level 1 texel x averages level-0 texels 2x, 2x + 1 in rows 0 and 1.
        for x in 0..4u32 {
            let t = levels[1].texels[x as usize];
            assert_eq!(
                t[0],
                ((2 * x * 30 + (2 * x + 1) * 30) as f32 / 2.0).round() as u8
            );
            assert_eq!(t[1], 100);
            assert_eq!(t[2], 17);
        }
        // 1×1: the whole texture's mean.
        let mean_r = (0..8).map(|x| x * 30).sum::<u32>() as f32 / 8.0;
        assert!((levels[3].texels[0][0] as f32 - mean_r).abs() <= 1.0);
    }

    #[test]
    fn box_mip_levels_halve_to_one_texel_and_keep_the_mean() {
        let levels = box_mip_levels(8, 4, (0..32).map(|i| [i as f32, 1.0, 0.0, 0.5]).collect());
        let sizes: Vec<(u32, u32)> = levels.iter().map(|(w, h, _)| (*w, *h)).collect();
        assert_eq!(sizes, vec![(8, 4), (4, 2), (2, 1), (1, 1)]);
        let last = levels.last().unwrap().2[0];
        assert!(
            (last[0] - 15.5).abs() < 1e-5 && last[1] == 1.0 && last[3] == 0.5,
            "{last:?}"
        );
    }

    #[test]
    fn srgb_mip_chain_averages_in_linear_light() {
        // Black and white stripes: the linear mean is 0.5, which sRGB encodes as 188, not 128.
        let tex = texture(2, 2, |x, _| {
            if x == 0 {
                [0, 0, 0, 255]
            } else {
                [255, 255, 255, 0]
            }
        });
        let srgb = mip_chain(&tex, true);
        let linear = mip_chain(&tex, false);
        assert_eq!(srgb[1].texels[0][0], 188);
        assert_eq!(linear[1].texels[0][0], 128);
        // Alpha is linear either way.
        assert_eq!(srgb[1].texels[0][3], 128);
    }
}
