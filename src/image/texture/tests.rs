//! Texture lookups against plain references: the interior fast path, the one-division wrapping,
//! the blocked layout against a row-major array, MIP-filtered lookups against bilinear ones and
//! box averages, and the constant `st`.

use super::*;
use super::load;
use crate::image::srgb_decode;

/// Bilinear filtering with every texel wrapped (the general path of `eval`).
fn reference(t: &Texture, uv: Vec2) -> Vec4 {
    let x = uv.x * t.width as f32 - 0.5;
    let y = (1.0 - uv.y) * t.height as f32 - 0.5;
    let (fx, fy) = (x.floor(), y.floor());
    let (tx, ty) = (x - fx, y - fy);
    let (x0, y0) = (fx as i64, fy as i64);
    let top = t.fetch(x0, y0).lerp(t.fetch(x0 + 1, y0), tx);
    let bottom = t.fetch(x0, y0 + 1).lerp(t.fetch(x0 + 1, y0 + 1), tx);
    top.lerp(bottom, ty) * t.scale + t.bias
}

#[test]
fn interior_fast_path_equals_wrapped_lookup() {
    let (w, h) = (5u32, 3u32);
    let data: Vec<Vec4> = (0..w * h).map(|i| Vec4::new(i as f32, (i * i) as f32 * 0.1, 1.0 / (i + 1) as f32, (i % 4) as f32)).collect();
    let mut rng = crate::sampling::Rng::new(3, 0);
    for mode in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp, Wrap::Black] {
        let texels = Texels::Hdr(data.clone());
        let t = Texture { width: w, height: h, texels, levels: Vec::new(), wrap: [mode; 2], scale: Vec4::splat(2.0), bias: Vec4::splat(0.25), output: Output::Rgb, st: None };
        for _ in 0..20_000 {
            let uv = Vec2::new(rng.next_f32() * 3.0 - 1.0, rng.next_f32() * 3.0 - 1.0);
            assert_eq!(t.eval(uv), reference(&t, uv), "{mode:?} at {uv}");
        }
    }
}

#[test]
fn wrap_pair_equals_two_wraps() {
    for n in 1..8u32 {
        for mode in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp, Wrap::Black] {
            let far = (1i64 << 40) - 1;
            let ends = [i64::MIN, i64::MIN + 1, -far - 2, -far - 1, -far, far - 1, far, far + 1, i64::MAX - 1, i64::MAX];
            for i in (-5 * n as i64..5 * n as i64).chain(ends) {
                let want = [wrap(i, n, mode), wrap(i.saturating_add(1), n, mode)];
                assert_eq!(wrap_pair(i, n, mode), want, "{i} of {n}, {mode:?}");
            }
        }
    }
}

/// A texture of `w`×`h` texels given row-major (8-bit, or float if `lut` is `None`).
fn texture(w: u32, h: u32, rows: &[[u8; 4]], lut: Option<&[f32; 256]>, wrap: [Wrap; 2]) -> Texture {
    let texels = match lut {
        Some(lut) => Texels::Ldr { data: Blocked::from_rows(w, h, rows), lut: Box::new(*lut) },
        None => Texels::Hdr(rows.iter().map(|t| decode(*t, &std::array::from_fn(|i| i as f32 * 0.5))).collect()),
    };
    Texture { width: w, height: h, texels, levels: Vec::new(), wrap, scale: Vec4::new(1.0, 0.5, 2.0, 1.0), bias: Vec4::splat(0.125), output: Output::Rgb, st: None }
}

proptest::proptest! {
    /// The blocked layout returns exactly the texel a plain row-major array returns, for every
    /// `(x, y)` in and around odd-sized images under every pair of wrap modes, and `eval`
    /// filters exactly those texels.
    #[test]
    fn blocked_texels_equal_row_major(size in proptest::sample::select(vec![(1u32, 1u32), (5, 3), (17, 9), (3, 17), (4, 4), (8, 5)]), seed in 0u64..1000) {
        let (w, h) = size;
        let mut rng = crate::sampling::Rng::new(seed, 1);
        let rows: Vec<[u8; 4]> = (0..w * h).map(|_| rng.next_u32().to_le_bytes()).collect();
        let lut: [f32; 256] = std::array::from_fn(|i| srgb_decode(i as f32 / 255.0));
        let modes = [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp, Wrap::Black];
        for (ws, wt) in modes.iter().flat_map(|s| modes.iter().map(move |t| (*s, *t))) {
            for l in [Some(&lut), None] {
                let t = texture(w, h, &rows, l, [ws, wt]);
                let plain = |x: i64, y: i64| -> Vec4 {
                    let (Some(x), Some(y)) = (wrap(x, w, ws), wrap(y, h, wt)) else { return Vec4::ZERO };
                    let texel = rows[(y * w + x) as usize];
                    match l {
                        Some(lut) => decode(texel, lut),
                        None => decode(texel, &std::array::from_fn(|i| i as f32 * 0.5)),
                    }
                };
                for y in -2 * h as i64..3 * h as i64 {
                    for x in -2 * w as i64..3 * w as i64 {
                        proptest::prop_assert_eq!(t.fetch(x, y), plain(x, y), "({}, {}) {:?} {:?}", x, y, ws, wt);
                    }
                }
                for _ in 0..200 {
                    let uv = Vec2::new(rng.next_f32() * 3.0 - 1.0, rng.next_f32() * 3.0 - 1.0);
                    let x = uv.x * w as f32 - 0.5;
                    let y = (1.0 - uv.y) * h as f32 - 0.5;
                    let (fx, fy) = (x.floor(), y.floor());
                    let (x0, y0) = (fx as i64, fy as i64);
                    let top = plain(x0, y0).lerp(plain(x0 + 1, y0), x - fx);
                    let bottom = plain(x0, y0 + 1).lerp(plain(x0 + 1, y0 + 1), x - fx);
                    proptest::prop_assert_eq!(t.eval(uv), top.lerp(bottom, y - fy) * t.scale + t.bias);
                }
            }
        }
    }
}

/// A float texture of `w × h` texels given row-major, with its MIP levels.
fn with_levels(w: u32, h: u32, data: Vec<Vec4>, wrap: Wrap) -> Texture {
    let mut levels = load::hdr_levels(w, h, data);
    let base = levels.remove(0);
    Texture { width: w, height: h, texels: base.texels, levels, wrap: [wrap; 2], scale: Vec4::splat(2.0), bias: Vec4::splat(0.5), output: Output::Rgb, st: None }
}

/// A checkerboard of single texels, black and white, 64 × 64.
fn checker() -> Texture {
    let n = 64u32;
    let data = (0..n * n).map(|i| if (i % n + i / n) % 2 == 0 { Vec4::ONE } else { Vec4::new(0.0, 0.0, 0.0, 1.0) }).collect();
    with_levels(n, n, data, Wrap::Repeat)
}

/// Footprints within a texel (magnified textures, close-ups) are the bilinear lookup, bit for
/// bit: close-up texels stay as sharp as without MIP levels.
#[test]
fn small_footprints_are_the_bilinear_lookup() {
    let t = checker();
    assert_eq!(t.level_count(), 7);
    let mut rng = crate::sampling::Rng::new(5, 0);
    for _ in 0..10_000 {
        let uv = Vec2::new(rng.next_f32() * 3.0 - 1.0, rng.next_f32() * 3.0 - 1.0);
        let r = 1.0 / 64.0 * rng.next_f32();
        let (a, b) = (Vec2::new(r, 0.0), Vec2::new(0.0, r * rng.next_f32()));
        for probes in [1, 8] {
            let fp = Footprint { axes: [a, b], max_probes: probes };
            assert_eq!(t.eval_filtered(uv, &fp).to_array().map(f32::to_bits), t.eval(uv).to_array().map(f32::to_bits), "{uv} {r}");
        }
    }
    assert_eq!(t.eval_filtered(Vec2::new(0.3, 0.7), &Footprint::POINT), t.eval(Vec2::new(0.3, 0.7)));
}

/// A footprint of many texels averages them: a checkerboard seen from far away is its mean
/// grey (where the bilinear lookup is black or white), and one covering the image is the
/// image's average.
#[test]
fn large_footprints_average_the_texels() {
    let t = checker();
    let grey = Vec4::new(0.5, 0.5, 0.5, 1.0) * 2.0 + Vec4::splat(0.5);
    let mut rng = crate::sampling::Rng::new(6, 0);
    for _ in 0..2_000 {
        let uv = Vec2::new(rng.next_f32(), rng.next_f32());
        // isotropic: 4 texels wide and more
        let r = (4.0 + 60.0 * rng.next_f32()) / 64.0;
        let v = t.eval_filtered(uv, &Footprint { axes: [Vec2::new(r, 0.0), Vec2::new(0.0, r)], max_probes: 1 });
        assert!((v - grey).abs().max_element() < 1e-4, "{uv} {r}: {v}");
        // anisotropic: 8 texels long, 1 wide (a plane seen at a grazing angle): eight lookups
        // one texel apart, also grey
        let v = t.eval_filtered(uv, &Footprint { axes: [Vec2::new(8.0 / 64.0, 0.0), Vec2::new(0.0, 1.0 / 64.0)], max_probes: 8 });
        assert!((v - grey).abs().max_element() < 1e-4, "{uv}: {v}");
    }
    let big = Footprint { axes: [Vec2::new(4.0, 0.0), Vec2::new(0.0, 4.0)], max_probes: 1 };
    assert!((t.eval_filtered(Vec2::new(0.1, 0.2), &big) - grey).abs().max_element() < 1e-5);
    assert!((t.average_rgb() - grey.truncate()).abs().max_element() < 1e-5);
}

/// A long, thin footprint across stripes that run along it keeps the stripes with anisotropic
/// lookups (as sharp as the bilinear lookup) where one isotropic lookup blurs them away.
#[test]
fn anisotropic_footprints_stay_sharp_across() {
    // rows alternate in blocks of 4: 0, 0, 0, 0, 1, 1, 1, 1, ... (constant along u)
    let n = 64u32;
    let data = (0..n * n).map(|i| if (i / n / 4) % 2 == 0 { Vec4::new(0.0, 0.0, 0.0, 1.0) } else { Vec4::ONE }).collect();
    let t = with_levels(n, n, data, Wrap::Repeat);
    let grey = Vec4::new(0.5, 0.5, 0.5, 1.0) * 2.0 + Vec4::splat(0.5);
    let along = Vec2::new(16.0 / 64.0, 0.0);
    let across = Vec2::new(0.0, 1.0 / 64.0);
    for row in [1u32, 6, 9, 14] {
        let uv = Vec2::new(0.3, 1.0 - (row as f32 + 0.5) / n as f32);
        let aniso = t.eval_filtered(uv, &Footprint { axes: [along, across], max_probes: 16 });
        let iso = t.eval_filtered(uv, &Footprint { axes: [along, across], max_probes: 1 });
        assert!((aniso - t.eval(uv)).abs().max_element() < 1e-5, "row {row}: {aniso} vs {}", t.eval(uv));
        assert!((iso - grey).abs().max_element() < 1e-4, "row {row}: {iso}");
    }
}

/// Between two levels, a lookup blends them linearly in the level of detail.
#[test]
fn trilinear_blends_neighbouring_levels() {
    let (w, h) = (16u32, 16u32);
    let mut rng = crate::sampling::Rng::new(7, 0);
    let data: Vec<Vec4> = (0..w * h).map(|_| Vec4::new(rng.next_f32(), rng.next_f32(), rng.next_f32(), 1.0)).collect();
    let t = with_levels(w, h, data, Wrap::Clamp);
    let uv = Vec2::new(0.37, 0.61);
    for lod in [1.0f32, 1.25, 2.5, 3.75] {
        let texels = lod.exp2() / w as f32;
        let got = t.eval_filtered(uv, &Footprint { axes: [Vec2::new(texels, 0.0), Vec2::new(0.0, texels)], max_probes: 1 });
        let level = |k: usize| {
            let l = &t.levels[k - 1];
            t.bilinear(&l.texels, l.width, l.height, uv)
        };
        let (k, f) = (lod.floor() as usize, lod.fract());
        let want = level(k).lerp(level(k + 1), f) * t.scale + t.bias;
        assert!((got - want).abs().max_element() < 1e-5, "lod {lod}: {got} vs {want}");
    }
}

/// A texture whose `st` map sends everything to one point is the texel under it, unfiltered:
/// `(0, 0)` is the lower-left texel (where a bilinear lookup with a `black` wrap would be a
/// quarter of it), an authored point the texel it falls in, outside the image the wrap's texel.
#[test]
fn a_constant_st_is_the_texel_under_it() {
    let (w, h) = (4u32, 2u32);
    let data: Vec<Vec4> = (0..w * h).map(|i| Vec4::new(i as f32, 1.0, 0.5, 1.0)).collect();
    let at = |st: [f32; 2], wrap: Wrap| {
        let texels = Texels::Hdr(data.clone());
        let t = Texture { width: w, height: h, texels, levels: Vec::new(), wrap: [wrap; 2], scale: Vec4::splat(2.0), bias: Vec4::splat(0.25), output: Output::Rgb, st: Some([Vec3::new(0.0, 0.0, st[0]), Vec3::new(0.0, 0.0, st[1])]) };
        let t = t.fixed_st();
        assert_eq!((t.width, t.height), (1, 1));
        (t.eval(Vec2::new(0.9, 0.1)), t.eval(Vec2::new(-5.0, 3.0)))
    };
    let texel = |i: u32| Vec4::new(i as f32, 1.0, 0.5, 1.0) * 2.0 + Vec4::splat(0.25);
    // row 0 of the file is the top (v = 1): the lower-left texel is index w · (h − 1)
    for wrap in [Wrap::Black, Wrap::Clamp, Wrap::Repeat] {
        assert_eq!(at([0.0, 0.0], wrap), (texel(4), texel(4)), "{wrap:?}");
        assert_eq!(at([1.0, 1.0], wrap), (texel(3), texel(3)), "{wrap:?}");
        assert_eq!(at([0.6, 0.9], wrap).0, texel(2), "{wrap:?}");
    }
    assert_eq!(at([1.3, 0.2], Wrap::Black).0, Vec4::splat(0.25));
    assert_eq!(at([1.3, 0.2], Wrap::Clamp).0, texel(7));
    assert_eq!(at([1.3, 0.2], Wrap::Repeat).0, texel(5));
}
