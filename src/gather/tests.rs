//! Reverse density estimation against brute force, and normal against reverse (fixed radius).

use super::reverse::oct16_encode;
use super::*;
use crate::photon::{PhotonMap, PhotonRay};
use proptest::prelude::*;
use std::f32::consts::PI;

/// Photons ending on random points of a few planes (arriving from random directions above them).
fn photon_map(pts: &[(u8, f32, f32, f32)]) -> PhotonMap {
    let normals = [Vec3::Y, Vec3::X, -Vec3::Z, Vec3::new(1.0, 1.0, 0.0).normalize()];
    let rays: Vec<PhotonRay> = pts
        .iter()
        .map(|&(plane, u, v, f)| {
            let n = normals[plane as usize % 4];
            let t = n.any_orthonormal_vector();
            let b = n.cross(t);
            let end = t * u + b * v;
            let dir = -(n + t * (u - 0.5) + b * (v * 0.3)).normalize();
            PhotonRay::new(end - dir * 2.0, dir, 2.0, Vec3::new(f, 0.5 * f, 0.25), n, -n)
        })
        .collect();
    let ends = vec![true; rays.len()];
    PhotonMap::build(&[&rays], &[&ends]).unwrap()
}

/// Reverse photons on the same planes (some facing the other way).
fn reverse_photons(pts: &[(u8, f32, f32, bool)]) -> Vec<ReversePhoton> {
    let normals = [Vec3::Y, Vec3::X, -Vec3::Z, Vec3::new(1.0, 1.0, 0.0).normalize()];
    pts.iter()
        .enumerate()
        .map(|(i, &(plane, u, v, flip))| {
            let n = normals[plane as usize % 4];
            let t = n.any_orthonormal_vector();
            let b = n.cross(t);
            let p = t * u + b * v;
            let nn = if flip { -n } else { n };
            ReversePhoton { p: p.to_array(), weight: [1.0, 2.0, 3.0], n: oct16_encode(nn), wi: oct16_encode(nn), pixel: i as u32 % 7 }
        })
        .collect()
}

/// `A_w` by brute force over all (photon, reverse photon) pairs, with the radius each photon uses.
fn brute(map: &PhotonMap, a_r: &[ReversePhoton], radius_of: impl Fn(usize) -> f32) -> (Vec<Vec3>, u64) {
    let mut pairs = 0;
    let pos: Vec<Vec3> = map.tree.entries().iter().map(|e| (e.index as usize, e.p)).fold(vec![Vec3::ZERO; map.len()], |mut v, (i, p)| {
        v[i] = p;
        v
    });
    let aw = a_r
        .iter()
        .map(|rp| {
            let mut s = Vec3::ZERO;
            for j in 0..map.len() {
                let r = radius_of(j);
                if (pos[j] - rp.pos()).length_squared() <= r * r && ReversePhoton::accepts(rp.normal(), map.wi[j], map.n[j]) {
                    s += map.flux[j] / (PI * r * r);
                    pairs += 1;
                }
            }
            s
        })
        .collect();
    (aw, pairs)
}

fn close(a: &[Vec3], b: &[Vec3], rel: f32) -> std::result::Result<(), String> {
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let d = (*x - *y).abs().max_element();
        if d > rel * x.abs().max_element().max(y.abs().max_element()) + 1e-30 {
            return Err(format!("entry {i}: {x} vs {y}"));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Fixed radius: reverse (batched and not) and normal photon mapping find exactly the pairs of a
    /// brute-force search and the same radiance per gather hit.
    #[test]
    fn fixed_radius_search_matches_brute_force(
        photons in prop::collection::vec((0u8..4, -1f32..1.0, -1f32..1.0, 0.1f32..2.0), 1..400),
        hits in prop::collection::vec((0u8..4, -1f32..1.0, -1f32..1.0, any::<bool>()), 1..300),
        r in 0.01f32..0.6,
    ) {
        let map = photon_map(&photons);
        let mut a_r = reverse_photons(&hits);
        rpm::sort_morton(&mut a_r); // estimate returns A_w in Morton order
        let (want, want_pairs) = brute(&map, &a_r, |_| r);
        let q = rpm::Queries::new(&map, Kernel::Fixed(r));
        let mut small_blocks = Vec::new();
        for (batched, block, flight) in [(true, rpm::BLOCK, usize::MAX), (false, rpm::BLOCK, usize::MAX), (true, 7, usize::MAX), (true, 7, 2)] {
            let (aw, st) = rpm::estimate(&q, &mut a_r, batched, block, flight);
            prop_assert_eq!(st.pairs, want_pairs);
            prop_assert_eq!(rpm::search_only(&q, &mut a_r, batched).pairs, want_pairs);
            close(&aw, &want, 1e-5).map_err(TestCaseError::fail)?;
            if block == 7 {
                small_blocks.push(aw);
            }
        }
        // blocks searched in waves: the same sums, bit for bit
        prop_assert!(small_blocks[0] == small_blocks[1]);
        let (fwd, found) = forward::estimate(&map, &a_r, Kernel::Fixed(r));
        prop_assert_eq!(found, want_pairs);
        prop_assert_eq!(forward::search_only(&map, &a_r, Kernel::Fixed(r)), want_pairs);
        close(&fwd, &want, 1e-5).map_err(TestCaseError::fail)?;
    }

    /// Adaptive radius: every photon uses the radius of its photon-tree leaf, and the reverse search
    /// finds the pairs brute force finds with those radii.
    #[test]
    fn adaptive_radius_search_matches_brute_force(
        photons in prop::collection::vec((0u8..4, -1f32..1.0, -1f32..1.0, 0.1f32..2.0), 1..400),
        hits in prop::collection::vec((0u8..4, -1f32..1.0, -1f32..1.0, any::<bool>()), 1..200),
    ) {
        let map = photon_map(&photons);
        let mut a_r = reverse_photons(&hits);
        rpm::sort_morton(&mut a_r);
        let kernel = Kernel::Adaptive { k: 20, max_radius: 0.5 };
        let q = rpm::Queries::new(&map, kernel);
        let mut radius = vec![0.0; map.len()];
        let cells = rpm::leaf_cells(&map.tree);
        prop_assert_eq!(cells.len(), map.tree.leaves().filter(|l| l.count > 0).count());
        for ((first, count, diag), leaf) in cells.into_iter().zip(map.tree.leaves().filter(|l| l.count > 0)) {
            // The exact cell diagonal is what the node stores, before its rounding up.
            prop_assert_eq!((first, count), (leaf.first as usize, leaf.count as usize));
            prop_assert!(diag <= leaf.diag && diag >= leaf.diag * (1.0 - 3e-4), "diag {} stored {}", diag, leaf.diag);
            let r = (diag * (20.0 / (2.0 * PI * count.max(1) as f32)).sqrt()).clamp(0.5e-3, 0.5);
            for e in &map.tree.entries()[first..first + count] {
                radius[e.index as usize] = r;
            }
        }
        let (want, want_pairs) = brute(&map, &a_r, |j| radius[j]);
        let (aw, st) = rpm::estimate(&q, &mut a_r, true, rpm::BLOCK, usize::MAX);
        prop_assert_eq!(st.pairs, want_pairs);
        close(&aw, &want, 1e-5).map_err(TestCaseError::fail)?;
    }
}

#[test]
fn completion_sums_weight_times_radiance_per_pixel() {
    let a_r = reverse_photons(&[(0, 0.0, 0.0, false), (1, 0.5, 0.5, false), (2, 0.1, 0.2, true)]);
    let l = [Vec3::ONE, Vec3::splat(2.0), Vec3::new(1.0, 0.0, 0.0)];
    let mut px = vec![Vec3::ZERO; 3];
    complete(&a_r, &l, &mut px);
    assert_eq!(px[0], Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(px[1], Vec3::new(2.0, 4.0, 6.0));
    assert_eq!(px[2], Vec3::new(1.0, 0.0, 0.0));
}

#[test]
fn settings_are_validated() {
    assert!(FgSettings { rays: 0, ..Default::default() }.validate().is_err());
    assert!(FgSettings { gather_radius: Some(-1.0), ..Default::default() }.validate().is_err());
    assert!(FgSettings { memory: Some(1000), ..Default::default() }.validate().is_err());
    assert!(FgSettings::default().validate().is_ok());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// The Morton order of `A_r`: a permutation of the input (every reverse photon once, bit for
    /// bit) equal to a stable sort by the 10-bit-per-axis Morton code (ties in input order), with
    /// duplicated positions and sizes around the cycle structure of the in-place permutation.
    #[test]
    fn sort_morton_is_the_stable_morton_permutation(pts in prop::collection::vec((0u8..4, -2.0f32..2.0, -2.0f32..2.0, any::<bool>()), 0..600), dup in 0usize..4) {
        let mut input = reverse_photons(&pts);
        for i in 0..input.len() / 5 * dup.min(1) {
            let j = (i * 7 + dup) % input.len();
            input[j].p = input[i].p; // equal positions: equal codes, input order decides
        }
        let mut sorted = input.clone();
        rpm::sort_morton(&mut sorted);
        let (lo, hi) = input.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), rp| (lo.min(rp.pos()), hi.max(rp.pos())));
        let scale = Vec3::splat(1023.0) / (hi - lo).max(Vec3::splat(1e-30));
        let mut want: Vec<(u64, usize)> = input.iter().enumerate().map(|(i, rp)| (rpm::morton(rp.pos(), lo, scale), i)).collect();
        want.sort_by_key(|w| w.0);
        let bits = |rp: &ReversePhoton| (rp.p.map(f32::to_bits), rp.weight.map(f32::to_bits), rp.n, rp.wi, rp.pixel);
        prop_assert_eq!(sorted.len(), input.len());
        for (k, (s, &(_, i))) in sorted.iter().zip(&want).enumerate() {
            prop_assert_eq!(bits(s), bits(&input[i]), "slot {}", k);
        }
    }
}
