//! Texture lookups against plain references: the interior fast path, the one-division wrapping,
//! and the blocked layout against a row-major array.

use super::*;

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
        let t = Texture { width: w, height: h, texels, wrap: [mode; 2], scale: Vec4::splat(2.0), bias: Vec4::splat(0.25), output: Output::Rgb, st: None };
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
    Texture { width: w, height: h, texels, wrap, scale: Vec4::new(1.0, 0.5, 2.0, 1.0), bias: Vec4::splat(0.125), output: Output::Rgb, st: None }
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
