use super::*;
use crate::sampling::Rng;

fn every_filter() -> Vec<PixelFilter> {
    let mut out = Vec::new();
    for kind in FilterKind::ALL {
        for radius in [None, Some(0.5), Some(1.3), Some(3.0)] {
            out.push(PixelFilter::new(kind, radius).unwrap());
        }
    }
    out
}

/// ∫∫ f = 1 by the midpoint rule over the support (independent of the closed forms the filter
/// normalises with).
#[test]
fn each_filter_integrates_to_one() {
    for f in every_filter() {
        const N: usize = 600;
        let h = 2.0 * f.radius as f64 / N as f64;
        let mut sum = 0.0f64;
        for i in 0..N {
            let dx = -f.radius as f64 + (i as f64 + 0.5) * h;
            for j in 0..N {
                let dy = -f.radius as f64 + (j as f64 + 0.5) * h;
                sum += f.eval(dx as f32, dy as f32) as f64;
            }
        }
        let integral = sum * h * h;
        assert!((integral - 1.0).abs() < 2e-3, "{}: ∫∫f = {integral}", f.describe());
        assert_eq!(f.eval_1d(f.radius * 1.01), 0.0, "{}: zero beyond the radius", f.describe());
        assert!(f.eval(0.0, 0.0) > 0.0, "{}: positive at the centre", f.describe());
    }
}

#[test]
fn names_and_radii_are_checked() {
    for k in FilterKind::ALL {
        assert_eq!(FilterKind::parse(k.name()).unwrap(), k);
    }
    assert!(FilterKind::parse("lanczos").unwrap_err().to_string().contains("box, gaussian, blackman-harris, mitchell"));
    assert!(PixelFilter::new(FilterKind::Gaussian, Some(0.4)).is_err());
    assert!(PixelFilter::new(FilterKind::Gaussian, Some(f32::NAN)).is_err());
    assert!(PixelFilter::new(FilterKind::Gaussian, Some(8.5)).is_err());
    assert!(PixelFilter::default().is_pixel_box());
    assert!(!PixelFilter::new(FilterKind::Box, Some(1.0)).unwrap().is_pixel_box());
    assert_eq!(PixelFilter::new(FilterKind::Box, Some(0.5)).unwrap(), PixelFilter::BOX);
    assert_eq!(PixelFilter::new(FilterKind::Gaussian, None).unwrap().margin(), 2);
    assert_eq!(PixelFilter::new(FilterKind::BlackmanHarris, None).unwrap().margin(), 1);
    assert_eq!(PixelFilter::BOX.margin(), 0);
}

/// Render an image of `w × h` by tiles of `tile` pixels: `spp` random samples per pixel, each of
/// value `value(x, y)`, merged tile by tile.
fn splat_image(f: PixelFilter, [w, h]: [u32; 2], tile: u32, spp: u32, value: impl Fn(f32, f32) -> f32) -> Vec<f32> {
    let mut image = FilteredImage::new(w, h, 2);
    for ty in (0..h).step_by(tile as usize) {
        for tx in (0..w).step_by(tile as usize) {
            let (tw, th) = (tile.min(w - tx), tile.min(h - ty));
            let mut t = SplatTile::new(f, [tx, ty, tw, th], [w, h], 2);
            for y in ty..ty + th {
                for x in tx..tx + tw {
                    let mut rng = Rng::new((y * w + x) as u64, 7);
                    for _ in 0..spp {
                        let (sx, sy) = (x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                        let v = value(sx, sy);
                        t.add(sx, sy, &[v, 2.0 * v]);
                    }
                }
            }
            image.merge(&t);
        }
    }
    image.resolve()
}

/// A constant image stays constant everywhere, across tile borders and at the image's edges.
#[test]
fn constant_image_stays_constant_at_tile_borders() {
    for f in every_filter() {
        let img = splat_image(f, [37, 21], 8, 3, |_, _| 0.7);
        for (i, px) in img.chunks_exact(2).enumerate() {
            assert!((px[0] - 0.7).abs() < 1e-5 && (px[1] - 1.4).abs() < 2e-5, "{} pixel {i}: {px:?}", f.describe());
        }
    }
}

/// Tiling does not change the image beyond summation order: 8-pixel tiles against one tile.
#[test]
fn tiles_match_one_tile() {
    let edge = |x: f32, y: f32| if x + 0.3 * y < 14.2 { 1.0 } else { 0.1 };
    for f in every_filter() {
        let tiled = splat_image(f, [31, 17], 8, 2, edge);
        let whole = splat_image(f, [31, 17], 64, 2, edge);
        for (i, (a, b)) in tiled.iter().zip(&whole).enumerate() {
            assert!((a - b).abs() < 1e-5, "{} value {i}: {a} vs {b}", f.describe());
        }
    }
}

/// A vertical step edge, densely sampled, comes out as the filter's cumulative profile across it:
/// pixel value = ∫ f over the bright side.
#[test]
fn step_edge_is_the_filters_cumulative_profile() {
    const EDGE: f32 = 10.0;
    for kind in [FilterKind::Box, FilterKind::Gaussian, FilterKind::BlackmanHarris] {
        let f = PixelFilter::new(kind, Some(1.7)).unwrap();
        let img = splat_image(f, [20, 3], 8, 4000, |x, _| if x < EDGE { 1.0 } else { 0.0 });
        for x in 6..14u32 {
            let c = x as f32 + 0.5;
            // ∫_{-r}^{EDGE - c} f, by the midpoint rule
            let n = 4000;
            let hi = (EDGE - c).clamp(-f.radius, f.radius);
            let step = (hi + f.radius) / n as f32;
            let expected: f32 = (0..n).map(|i| f.eval_1d(-f.radius + (i as f32 + 0.5) * step) * step).sum();
            let got = img[((1 * 20 + x) * 2) as usize];
            assert!((got - expected).abs() < 0.02, "{} pixel {x}: {got} vs {expected}", f.describe());
        }
    }
}

/// Filter importance sampling: the mean weight is ∫f = 1 and the weighted second moment of the
/// offset is ∫f·d², over stratified u (a sample's weight f/pdf stands for f under the pdf).
#[test]
fn sampled_offsets_reproduce_the_filter() {
    for f in every_filter() {
        let sampler = FilterSampler::new(f);
        const N: usize = 4000;
        let (mut w_sum, mut m2, mut max_d) = (0.0f64, 0.0f64, 0.0f32);
        for i in 0..N {
            let u = (i as f32 + 0.5) / N as f32;
            let (dx, w) = sampler.sample_1d(u);
            let w = w as f64;
            w_sum += w;
            m2 += w * (dx * dx) as f64;
            max_d = max_d.max(dx.abs());
        }
        let (mean, second) = (w_sum / N as f64, m2 / N as f64);
        let k = 20_000;
        let h = 2.0 * f.radius as f64 / k as f64;
        let exact: f64 = (0..k).map(|i| {
            let d = -f.radius as f64 + (i as f64 + 0.5) * h;
            f.eval_1d(d as f32) as f64 * d * d * h
        }).sum();
        assert!((mean - 1.0).abs() < 2e-3, "{}: mean weight {mean}", f.describe());
        assert!((second - exact).abs() < 2e-3 * (1.0 + exact), "{}: ∫f·d² {second} vs {exact}", f.describe());
        assert!(max_d <= f.radius, "{}: offset {max_d} beyond the radius", f.describe());
    }
    // the box's and the Gaussian's weights are one but for the table's rounding
    for kind in [FilterKind::Box, FilterKind::Gaussian] {
        let b = FilterSampler::new(PixelFilter::new(kind, Some(1.5)).unwrap());
        for u in [0.0, 0.1, 0.37, 0.5, 0.99] {
            let w = b.sample([u, 0.3]).1;
            assert!((w - 1.0).abs() < 0.02, "{kind:?}: weight {w} at u {u}");
        }
    }
}
