//! MIP pyramids: every level below the image is half the one above it (rounded up), down to
//! 1 × 1, each texel the average of the 2 × 2 texels above it in linear values (the last row or
//! column of an odd size is averaged with itself). 8-bit levels are encoded back to 8 bits with
//! the image's own table (sRGB or linear), each made from the exact averages of the level above.

use glam::Vec4;

use crate::image::srgb_encode;

/// A level's size and its linear texels, row-major.
pub(super) type LinearLevel = (u32, u32, Vec<Vec4>);

/// The sizes of the levels below a `w × h` image, largest first.
pub(super) fn sizes(w: u32, h: u32) -> Vec<(u32, u32)> {
    let (mut w, mut h) = (w, h);
    let mut out = Vec::new();
    while w > 1 || h > 1 {
        (w, h) = (w.div_ceil(2), h.div_ceil(2));
        out.push((w, h));
    }
    out
}

/// One level down from a `w × h` level whose texel `(x, y)` is `get(x, y)`.
fn half(w: u32, h: u32, get: impl Fn(usize, usize) -> Vec4) -> LinearLevel {
    let (hw, hh) = (w.div_ceil(2), h.div_ceil(2));
    let (last_x, last_y) = (w as usize - 1, h as usize - 1);
    let mut out = Vec::with_capacity(hw as usize * hh as usize);
    for y in 0..hh as usize {
        let (y0, y1) = (2 * y, (2 * y + 1).min(last_y));
        for x in 0..hw as usize {
            let (x0, x1) = (2 * x, (2 * x + 1).min(last_x));
            out.push((get(x0, y0) + get(x1, y0) + get(x0, y1) + get(x1, y1)) * 0.25);
        }
    }
    (hw, hh, out)
}

/// The levels below a `w × h` image of linear texels `get(x, y)`, largest first.
pub(super) fn pyramid(w: u32, h: u32, get: impl Fn(usize, usize) -> Vec4) -> Vec<LinearLevel> {
    let mut levels: Vec<LinearLevel> = Vec::new();
    if w > 1 || h > 1 {
        levels.push(half(w, h, get));
    }
    while let Some((lw, lh, data)) = levels.last().filter(|l| l.0 > 1 || l.1 > 1) {
        let lw_usize = *lw as usize;
        let next = half(*lw, *lh, |x, y| data[y * lw_usize + x]);
        levels.push(next);
    }
    levels
}

/// A linear level as 8-bit texels for the table of [`super::load`]: colour channels sRGB-encoded
/// when `srgb`, alpha linear; rounded to the nearest code.
pub(super) fn encode_ldr(texels: &[Vec4], srgb: bool) -> Vec<[u8; 4]> {
    let code = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    let colour = |v: f32| if srgb { code(srgb_encode(v)) } else { code(v) };
    texels.iter().map(|t| [colour(t.x), colour(t.y), colour(t.z), code(t.w)]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every level is the box average of the image over the texels it covers (for sizes that
    /// halve exactly), and the sizes go down to 1 × 1.
    #[test]
    fn levels_are_box_averages() {
        let (w, h) = (8u32, 4u32);
        let img: Vec<Vec4> = (0..w * h).map(|i| Vec4::new(i as f32, (i * 7 % 5) as f32, 1.0, 0.5)).collect();
        let levels = pyramid(w, h, |x, y| img[y * w as usize + x]);
        assert_eq!(levels.iter().map(|l| (l.0, l.1)).collect::<Vec<_>>(), sizes(w, h));
        assert_eq!(sizes(w, h), vec![(4, 2), (2, 1), (1, 1)]);
        for (k, (lw, lh, data)) in levels.iter().enumerate() {
            let s = 1usize << (k + 1);
            for y in 0..*lh as usize {
                for x in 0..*lw as usize {
                    // the texels of the image under this one (a level one texel high covers
                    // every row)
                    let (mut sum, mut n) = (Vec4::ZERO, 0);
                    for yy in y * s..((y + 1) * s).min(h as usize) {
                        for xx in x * s..((x + 1) * s).min(w as usize) {
                            sum += img[yy * w as usize + xx];
                            n += 1;
                        }
                    }
                    let want = sum / n as f32;
                    assert!((data[y * *lw as usize + x] - want).abs().max_element() < 1e-4, "level {} ({x}, {y})", k + 1);
                }
            }
        }
        // odd sizes round up; a 1 × 1 image has no levels
        assert_eq!(sizes(5, 3), vec![(3, 2), (2, 1), (1, 1)]);
        assert!(pyramid(1, 1, |_, _| Vec4::ONE).is_empty());
    }
}
