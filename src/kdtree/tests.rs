//! Every query against brute force, on random and degenerate point sets, for several `max_leaf`
//! (in the manner of Mitsuba's PointKDTree test), plus the structure invariants of the tree.

use glam::Vec3;
use proptest::prelude::*;

use super::*;

/// SplitMix64: a small seeded generator so the tests are reproducible without extra crates.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = self.vec(-1.0, 1.0);
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// Point sets, including the degenerate ones, each with a name for failure messages.
fn datasets(seed: u64) -> Vec<(&'static str, Vec<Vec3>)> {
    let mut r = Rng(seed);
    let mut sets = vec![("empty", vec![]), ("single", vec![Vec3::new(0.3, -0.2, 0.7)])];
    sets.push(("two", vec![Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)]));
    sets.push(("uniform", (0..1500).map(|_| r.vec(-1.0, 1.0)).collect()));
    sets.push(("plane z=0.5", (0..1200).map(|_| Vec3::new(r.f(), r.f(), 0.5)).collect()));
    let (u, v) = (Vec3::new(1.0, 0.3, -0.4), Vec3::new(-0.2, 1.0, 0.6));
    sets.push(("tilted plane", (0..1200).map(|_| u * r.f() + v * r.f()).collect()));
    sets.push(("line x", (0..600).map(|_| Vec3::new(r.f(), 0.3, 0.3)).collect()));
    sets.push(("diagonal line", (0..600).map(|_| Vec3::splat(r.range(-2.0, 2.0))).collect()));
    let bases: Vec<Vec3> = (0..40).map(|_| r.vec(0.0, 1.0)).collect();
    sets.push(("duplicates", (0..1600).map(|_| bases[r.below(bases.len())]).collect()));
    sets.push(("identical 700", vec![Vec3::new(0.1, 0.2, 0.3); 700]));
    sets.push(("grid", (0..1000).map(|i| Vec3::new((i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32) * 0.25).collect()));
    let mut clustered: Vec<Vec3> = (0..200).map(|_| r.vec(-5.0, 5.0)).collect();
    for c in 0..3 {
        let centre = r.vec(-4.0, 4.0);
        let size = [1e-3, 1e-2, 1e-4][c];
        clustered.extend((0..400).map(|_| centre + r.vec(-size, size)));
    }
    sets.push(("clustered + sparse", clustered));
    let mut deep: Vec<Vec3> = (0..130).map(|i| Vec3::new(0.5f32.powi(i), 0.0, 0.0)).collect();
    deep.extend((0..130).map(|i| Vec3::new(0.0, 1.0 - 0.5f32.powi(i), 1.0)));
    sets.push(("exponential spacing", deep));
    sets.push(("far from origin", (0..1000).map(|_| Vec3::new(1e4, -3e3, 5e3) + r.vec(0.0, 1.0)).collect()));
    let mut with_nan: Vec<Vec3> = (0..500).map(|_| r.vec(0.0, 1.0)).collect();
    for i in (0..500).step_by(37) {
        with_nan[i] = [Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::new(0.0, f32::NEG_INFINITY, f32::NAN)][i % 3];
    }
    sets.push(("non-finite mixed in", with_nan));
    sets
}

/// Test parameters; leaf sizes 3 and 16 also cut off empty space (`empty_cut`), 1 and 64 do not.
fn params(max_leaf: usize) -> BuildParams {
    let empty_cut = if matches!(max_leaf, 3 | 16) { 0.25 } else { f32::INFINITY };
    BuildParams { max_leaf, parallel_threshold: 256, empty_cut, ..Default::default() }
}

const LEAF_SIZES: [usize; 4] = [1, 3, 16, 64];

/// A query centre: near a point of the set, or anywhere around its bounds.
fn query_point(r: &mut Rng, points: &[Vec3]) -> Vec3 {
    let finite: Vec<&Vec3> = points.iter().filter(|p| p.is_finite()).take(1).collect();
    if points.is_empty() || finite.is_empty() || r.f() < 0.2 {
        return r.vec(-2.0, 2.0);
    }
    let p = points[r.below(points.len())];
    let p = if p.is_finite() { p } else { *finite[0] };
    match r.below(3) {
        0 => p,
        1 => p + r.vec(-1e-3, 1e-3),
        _ => p + r.vec(-0.3, 0.3),
    }
}

/// The coordinate magnitude that boundary tolerances are relative to (at least 1).
fn scale_of(points: &[Vec3]) -> f64 {
    points.iter().filter(|p| p.is_finite()).fold(1.0f64, |m, p| m.max(p.abs().max_element() as f64))
}

/// Checks a radius query result against brute force (`d² ≤ r²` in f32); the two may differ only on
/// points within 1e-5 (relative to `scale`) of the sphere, where f32 rounding or the underflow of
/// d² decides.
fn assert_same_ball(points: &[Vec3], c: Vec3, radius: f32, got: Vec<u32>, scale: f64, what: &str) {
    let expected: Vec<u32> = (0..points.len() as u32).filter(|&i| (points[i as usize] - c).length_squared() <= radius * radius).collect();
    let got = sorted(got);
    for i in symmetric_difference(&got, &expected) {
        let d = (points[i as usize].as_dvec3() - c.as_dvec3()).length();
        assert!((d - radius as f64).abs() <= 1e-5 * (scale + radius as f64), "{what}: centre {c}, radius {radius}: point {i} at {d}");
    }
}

/// Elements of exactly one of two sorted lists.
fn symmetric_difference(a: &[u32], b: &[u32]) -> Vec<u32> {
    let mut out: Vec<u32> = a.iter().filter(|i| b.binary_search(i).is_err()).copied().collect();
    out.extend(b.iter().filter(|i| a.binary_search(i).is_err()));
    out
}

fn sorted(mut v: Vec<u32>) -> Vec<u32> {
    v.sort_unstable();
    v
}

/// Walks the tree with its cells and checks every structural invariant; returns the leaf count.
fn check_structure(name: &str, tree: &KdTree, points: &[Vec3], normals: Option<&[Vec3]>, max_leaf: usize) {
    let n = points.len();
    let mut perm: Vec<u32> = tree.permutation().collect();
    perm.sort_unstable();
    assert_eq!(perm, (0..n as u32).collect::<Vec<_>>(), "{name}: not a permutation");
    let finite = points.iter().filter(|p| p.is_finite()).count();
    assert_eq!(tree.len(), finite, "{name}: indexed count");
    for (j, i) in tree.permutation().enumerate() {
        if j < tree.len() {
            assert_eq!(tree.entries()[j].p, points[i as usize], "{name}: permuted copy");
        } else {
            assert!(!points[i as usize].is_finite(), "{name}: a finite point was excluded");
        }
    }
    if tree.is_empty() {
        assert_eq!(tree.nodes(), &[Node::EMPTY]);
        return;
    }
    let (lo, hi) = tree.bounds();
    let mut next_first = 0u32;
    let mut leaves = 0;
    // (node, cell min, cell max, interior depth)
    let mut stack = vec![(0usize, lo, hi, 0usize)];
    let mut order = vec![];
    while let Some((i, cmin, cmax, depth)) = stack.pop() {
        order.push(i);
        assert!(depth < MAX_DEPTH, "{name}: too deep");
        match tree.nodes()[i].kind() {
            NodeKind::Interior { axis, split, right_offset } => {
                assert!(split >= cmin[axis] && split <= cmax[axis], "{name}: split outside its cell");
                assert!(right_offset >= 2);
                let (mut lmax, mut rmin) = (cmax, cmin);
                lmax[axis] = split;
                rmin[axis] = split;
                stack.push((i + right_offset as usize, rmin, cmax, depth + 1));
                stack.push((i + 1, cmin, lmax, depth + 1));
            }
            NodeKind::Leaf { first, count, diag } => {
                leaves += 1;
                assert_eq!(first, next_first, "{name}: leaves must tile the permutation in preorder");
                next_first += count;
                assert!(count >= 1 && count as usize <= MAX_LEAF_COUNT);
                let pts: Vec<Vec3> = tree.entries()[first as usize..(first + count) as usize].iter().map(|e| e.p).collect();
                let cell_diag = (cmax - cmin).length();
                let flat = pts.iter().all(|p| *p == pts[0]);
                assert!(
                    count as usize <= max_leaf || cell_diag < tree.min_diag() || flat,
                    "{name}: leaf of {count} > {max_leaf} points, diag {cell_diag}"
                );
                for p in pts {
                    assert!(p.cmpge(cmin).all() && p.cmple(cmax).all(), "{name}: point {p} outside its leaf cell");
                }
                assert!(diag >= cell_diag && diag <= cell_diag * (1.0 + 2.5e-4) + 1e-30, "{name}: diag {diag} vs {cell_diag}");
            }
            NodeKind::Cull { normal, cmax: c } => {
                let normals = normals.expect("cull node without normals");
                // The subtree's point range: from its first leaf to the end of the subtree.
                let range = subtree_range(tree, i + 1);
                for j in range {
                    let m = normals[tree.entries()[j].index as usize].normalize();
                    assert!(m.dot(normal) > 0.0 && m.cross(normal).length() + CULL_MARGIN <= c * 1.000001, "{name}: cull cone");
                }
                stack.push((i + 1, cmin, cmax, depth));
            }
            NodeKind::Empty => assert!(i > 0, "{name}: empty root of a non-empty tree"),
        }
    }
    assert_eq!(next_first as usize, tree.len(), "{name}: leaves cover all points");
    // Preorder: visiting with a stack (left first) must see nodes in array order.
    assert_eq!(order, (0..tree.nodes().len()).collect::<Vec<_>>(), "{name}: not preorder");
    let s = tree.stats();
    assert_eq!((s.leaves, s.nodes, s.points), (leaves, tree.nodes().len(), tree.len()), "{name}: stats");
    assert_eq!(s.leaves + s.interior_nodes + s.cull_nodes + s.empty_nodes, s.nodes);
    assert!(s.memory_bytes >= s.nodes * 8 + n * 4);
}

/// Positions covered by the subtree rooted at `node`.
fn subtree_range(tree: &KdTree, node: usize) -> std::ops::Range<usize> {
    let (mut lo, mut hi) = (usize::MAX, 0);
    let mut stack = vec![node];
    while let Some(i) = stack.pop() {
        let n = tree.nodes()[i];
        match n.kind() {
            NodeKind::Interior { right_offset, .. } => stack.extend([i + 1, i + right_offset as usize]),
            NodeKind::Cull { .. } => stack.push(i + 1),
            NodeKind::Leaf { first, count, .. } => {
                lo = lo.min(first as usize);
                hi = hi.max((first + count) as usize);
            }
            NodeKind::Empty => {}
        }
    }
    lo..hi
}

#[test]
fn node_is_8_bytes() {
    assert_eq!(std::mem::size_of::<Node>(), 8);
    assert_eq!(std::mem::align_of::<Node>(), 4);
}

#[test]
fn node_encoding_round_trips_conservatively() {
    let mut r = Rng(7);
    for _ in 0..10_000 {
        let axis = r.below(3);
        let split = r.range(-1e6, 1e6);
        let off = 2 + r.below(MAX_RIGHT_OFFSET as usize - 2) as u32;
        assert_eq!(Node::interior(axis, split, off).kind(), NodeKind::Interior { axis, split, right_offset: off });
        let (first, count) = (r.next_u64() as u32, 1 + r.below(255));
        let diag = r.f() * 10f32.powi(r.below(20) as i32 - 10);
        match Node::leaf(first, count, diag).kind() {
            NodeKind::Leaf { first: f, count: c, diag: d } => {
                assert_eq!((f, c as usize), (first, count));
                assert!(d >= diag && d <= diag * (1.0 + 2.5e-4), "{d} vs {diag}");
            }
            k => panic!("{k:?}"),
        }
        let n = quantize_normal(r.unit());
        let cmax = r.f();
        match Node::cull(n, cmax).kind() {
            NodeKind::Cull { normal, cmax: c } => {
                assert_eq!(normal, n, "a quantised normal must survive re-encoding");
                assert!(c >= cmax && c <= cmax * (1.0 + 1e-6) + 1e-30);
            }
            k => panic!("{k:?}"),
        }
    }
    assert_eq!(Node::EMPTY.kind(), NodeKind::Empty);
    assert!(quantize_normal(Vec3::new(0.0, 0.0, -1.0)).abs_diff_eq(Vec3::NEG_Z, 1e-4));
}

#[test]
fn structure_and_permutation() {
    for (name, points) in datasets(1) {
        for max_leaf in LEAF_SIZES {
            let tree = KdTree::build(&points, &params(max_leaf)).unwrap();
            check_structure(name, &tree, &points, None, max_leaf);
        }
    }
}

#[test]
fn deep_trees_stay_within_the_stack() {
    // Without the diagonal limit, exponentially spaced points slide one point off per level.
    let mut points: Vec<Vec3> = (0..150).map(|i| Vec3::new(0.5f32.powi(i), 0.0, 0.0)).collect();
    points.extend((0..150).map(|i| Vec3::new(0.0, 0.75f32.powi(i), 2.0)));
    points.extend(vec![Vec3::new(0.0, 0.0, 1.0); 1000]);
    let p = BuildParams { max_leaf: 1, min_diag_fraction: 0.0, ..Default::default() };
    let tree = KdTree::build(&points, &p).unwrap();
    check_structure("deep", &tree, &points, None, 1);
    let depth = tree.stats().depth;
    assert!(depth >= SLIDING_DEPTH_LIMIT as usize && depth < MAX_DEPTH, "depth {depth}");
    let mut r = Rng(29);
    let mut heap = KnnHeap::new();
    for q in 0..300 {
        let c = query_point(&mut r, &points);
        let radius = [0.0, 1e-30, 1e-6, 0.1, 1.0][q % 5];
        let mut got = vec![];
        tree.for_each_in_radius(c, radius, |i, _| got.push(i));
        assert_same_ball(&points, c, radius, got, 1.0, "deep");
        let cone = random_cone(&mut r, &points, q);
        let mut got = vec![];
        tree.for_each_in_cone(&cone, |i, _, _| got.push(i));
        let expected: Vec<u32> = (0..points.len() as u32).filter(|&i| cone.test(points[i as usize]).is_some()).collect();
        assert_eq!(sorted(got), expected);
        tree.knn(c, 1 + q % 7, f32::INFINITY, &mut heap);
        let mut all: Vec<f32> = points.iter().map(|p| (*p - c).length_squared()).collect();
        all.sort_by(f32::total_cmp);
        all.truncate(1 + q % 7);
        assert_eq!(heap.sort().iter().map(|n| n.dist2).collect::<Vec<_>>(), all);
    }
}

#[test]
fn bad_parameters_are_errors() {
    let pts = [Vec3::ZERO];
    assert!(KdTree::build(&pts, &BuildParams { max_leaf: 0, ..Default::default() }).is_err());
    assert!(KdTree::build(&pts, &BuildParams { max_leaf: 256, ..Default::default() }).is_err());
    assert!(KdTree::build(&pts, &BuildParams { min_diag_fraction: f32::NAN, ..Default::default() }).is_err());
    assert!(KdTree::build_with_normals(&pts, &[], &BuildParams::default()).is_err());
}

#[test]
fn build_is_deterministic_and_independent_of_parallelism() {
    let mut r = Rng(3);
    let mut points: Vec<Vec3> = (0..60_000).map(|_| r.vec(-1.0, 1.0)).collect();
    points.extend(vec![Vec3::splat(0.25); 3000]);
    let normals: Vec<Vec3> = points.iter().map(|p| p.normalize_or_zero()).collect();
    let reference = KdTree::build_with_normals(&points, &normals, &BuildParams { parallel_threshold: usize::MAX, ..Default::default() }).unwrap();
    for threshold in [64, 4096, BuildParams::default().parallel_threshold] {
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let tree = pool.install(|| KdTree::build_with_normals(&points, &normals, &BuildParams { parallel_threshold: threshold, ..Default::default() })).unwrap();
            assert_eq!(tree.nodes(), reference.nodes());
            assert_eq!(tree.entries(), reference.entries());
        }
    }
    assert!(reference.stats().depth <= (SLIDING_DEPTH_LIMIT as usize) + 33);
}

#[test]
fn radius_query_matches_brute_force() {
    let mut r = Rng(11);
    for (name, points) in datasets(2) {
        let scale = scale_of(&points);
        for max_leaf in LEAF_SIZES {
            let tree = KdTree::build(&points, &params(max_leaf)).unwrap();
            for q in 0..150 {
                let c = query_point(&mut r, &points);
                let radius = [0.0, 1e-3, 0.05, 0.3, 3.0][q % 5] * r.f() * 2.0;
                let mut got = vec![];
                tree.for_each_in_radius(c, radius, |i, d2| {
                    assert_eq!(d2, (points[i as usize] - c).length_squared());
                    got.push(i)
                });
                assert_same_ball(&points, c, radius, got, scale, &format!("{name}, max_leaf {max_leaf}"));
            }
            // Points exactly on the sphere, offset along an axis (ties with the split planes).
            for q in 0..points.len().min(300) {
                let p = points[(q * 7919) % points.len()];
                let radius = [0.25f32, 0.5, 0.0][q % 3];
                let mut c = p;
                c[q % 3] += if q % 2 == 0 { radius } else { -radius };
                if !c.is_finite() || (c - p).length() != radius {
                    continue;
                }
                let mut found = false;
                tree.for_each_in_radius(c, radius, |i, _| found |= points[i as usize] == p);
                assert!(found, "{name}, max_leaf {max_leaf}: {p} at exactly {radius} from {c} not found");
            }
            let mut all = 0;
            tree.for_each_in_radius(Vec3::ZERO, f32::INFINITY, |_, _| all += 1);
            assert_eq!(all, tree.len(), "{name}: infinite radius");
        }
    }
}

#[test]
fn batched_radius_query_matches_single_queries() {
    let mut r = Rng(12);
    for (name, points) in datasets(3) {
        for max_leaf in [1, 16] {
            let tree = KdTree::build(&points, &params(max_leaf)).unwrap();
            for _ in 0..100 {
                let centre = query_point(&mut r, &points);
                let spread = [1e-3, 0.02, 0.5][r.below(3)];
                let radius = [2e-3, 0.02, 0.2][r.below(3)];
                let queries: Vec<(Vec3, f32)> = (0..1 + r.below(20)).map(|_| (centre + r.vec(-spread, spread), r.f() * radius)).collect();
                let mut got = vec![vec![]; queries.len()];
                tree.for_each_in_radius_batched(&queries, |q, i, _| got[q].push(i));
                for (q, &(c, rad)) in queries.iter().enumerate() {
                    let mut single = vec![];
                    tree.for_each_in_radius(c, rad, |i, _| single.push(i));
                    assert_eq!(sorted(got[q].clone()), sorted(single), "{name}: batched query {q}");
                }
            }
        }
    }
}

#[test]
fn knn_matches_sorting() {
    let mut r = Rng(13);
    let mut heap = KnnHeap::new();
    for (name, points) in datasets(4) {
        for max_leaf in LEAF_SIZES {
            let tree = KdTree::build(&points, &params(max_leaf)).unwrap();
            for q in 0..150 {
                let c = query_point(&mut r, &points);
                let k = [1, 2, 5, 16, 50, 2000][q % 6];
                let max_r = if q % 3 == 0 { f32::INFINITY } else { r.f() * 0.5 };
                let max_r2 = if max_r.is_finite() { max_r * max_r } else { f32::INFINITY };
                let mut all: Vec<f32> = points.iter().map(|p| (*p - c).length_squared()).filter(|d2| *d2 <= max_r2).collect();
                all.sort_by(f32::total_cmp);
                all.truncate(k);
                let r2 = tree.knn(c, k, max_r, &mut heap);
                let got: Vec<f32> = heap.sort().iter().map(|n| n.dist2).collect();
                assert_eq!(got, all, "{name}, max_leaf {max_leaf}, k {k}, centre {c}");
                for n in heap.as_slice() {
                    assert_eq!(n.dist2, (points[n.index as usize] - c).length_squared());
                }
                let expected_r2 = if all.len() == k { all[k - 1] } else { max_r2 };
                assert_eq!(r2, expected_r2);
            }
        }
    }
    let tree = KdTree::build(&[Vec3::ZERO], &BuildParams::default()).unwrap();
    assert_eq!(tree.knn(Vec3::ONE, 0, 1.0, &mut heap), 0.0);
    assert!(heap.is_empty());
}

/// A random cone near the points: through a point, along an axis, degenerate radii, with or
/// without the cap.
fn random_cone(r: &mut Rng, points: &[Vec3], q: usize) -> Cone {
    let target = query_point(r, points);
    let dir = match q % 5 {
        0 => [Vec3::X, Vec3::NEG_Y, Vec3::Z][r.below(3)],
        1 => Vec3::new(1.0, 1.0, 0.0).normalize(),
        _ => r.unit(),
    };
    let t_max = [0.0, 0.05, 0.5, 2.0, 6.0][r.below(5)] * r.f();
    let before = r.range(-0.2, 1.2) * t_max;
    let h0 = [0.0, 1e-3, 0.02, 0.2][r.below(4)] * r.f();
    let dh = [0.0, 0.0, 0.05, 0.5, -0.01][r.below(5)] * r.f();
    let dh = if h0 + dh * t_max < 0.0 { 0.0 } else { dh };
    Cone::new(target - dir * before, dir, t_max, h0, dh).with_hemisphere_cap(q & 1 == 0)
}

/// Exact (f64) membership and whether the point is within 1e-5 (relative) of the region's boundary.
fn cone_reference(c: &Cone, p: Vec3, scale: f64) -> (bool, bool) {
    let (o, d, p) = (c.origin.as_dvec3(), c.dir.as_dvec3(), p.as_dvec3());
    let (t_max, h0, dh) = (c.t_max as f64, c.h0 as f64, c.dh as f64);
    let v = p - o;
    let t = v.dot(d);
    let dist = (v - d * t).length();
    let tol = 1e-5 * (scale + h0.abs() + (dh * t_max).abs());
    let h = h0 + dh * t.clamp(0.0, t_max);
    let hit = o + d * t_max;
    let cap_h = h0 + dh * t_max;
    let in_frustum = t >= 0.0 && t <= t_max && dist < h;
    let in_cap = c.hemisphere_cap && t > t_max && (p - hit).length() < cap_h;
    let near = t.abs() < tol || (t - t_max).abs() < tol || (dist - h).abs() < tol || (c.hemisphere_cap && ((p - hit).length() - cap_h).abs() < tol);
    (in_frustum || in_cap, near)
}

#[test]
fn cone_query_matches_brute_force() {
    let mut r = Rng(17);
    let mut checked = 0usize;
    for (name, points) in datasets(5) {
        let scale = scale_of(&points);
        for max_leaf in LEAF_SIZES {
            let tree = KdTree::build(&points, &params(max_leaf)).unwrap();
            for q in 0..200 {
                let cone = random_cone(&mut r, &points, q);
                let expected: Vec<u32> = (0..points.len() as u32).filter(|&i| cone.test(points[i as usize]).is_some()).collect();
                let mut got = vec![];
                tree.for_each_in_cone(&cone, |i, t, d2| {
                    assert_eq!(Some((t, d2)), cone.test(points[i as usize]));
                    got.push(i);
                });
                let got = sorted(got);
                assert_eq!(got, expected, "{name}, max_leaf {max_leaf}, {cone:?}");
                // The membership test itself against the exact geometry.
                for (i, p) in points.iter().enumerate().filter(|(_, p)| p.is_finite()) {
                    let (inside, near) = cone_reference(&cone, *p, scale);
                    let found = got.binary_search(&(i as u32)).is_ok();
                    assert!(found == inside || near, "{name}: point {p} inside={inside} found={found} for {cone:?}");
                    checked += inside as usize;
                }
            }
        }
    }
    assert!(checked > 10_000, "queries found too little to be a test ({checked})");
}

/// Point sets with normals: planes, a sphere, a box, noisy and random normals, broken normals.
fn oriented_sets(seed: u64) -> Vec<(&'static str, Vec<Vec3>, Vec<Vec3>)> {
    let mut r = Rng(seed);
    let mut sets = vec![];
    let plane: Vec<Vec3> = (0..2000).map(|_| Vec3::new(r.f(), r.f(), 0.0)).collect();
    sets.push(("plane", plane.clone(), vec![Vec3::Z; plane.len()]));
    let noisy: Vec<Vec3> = plane.iter().map(|_| (Vec3::Z + r.vec(-0.2, 0.2)) * 3.0).collect();
    sets.push(("plane, noisy normals", plane.clone(), noisy));
    let sphere: Vec<Vec3> = (0..3000).map(|_| r.unit()).collect();
    sets.push(("sphere", sphere.clone(), sphere.clone()));
    let mut bx = vec![];
    let mut bn = vec![];
    for _ in 0..3000 {
        let (axis, sign) = (r.below(3), if r.f() < 0.5 { -1.0 } else { 1.0 });
        let mut p = r.vec(-1.0, 1.0);
        p[axis] = sign;
        let mut n = Vec3::ZERO;
        n[axis] = -sign; // inward, like the walls of a room
        bx.push(p);
        bn.push(n);
    }
    sets.push(("room", bx, bn));
    let random: Vec<Vec3> = (0..1500).map(|_| r.vec(0.0, 1.0)).collect();
    let rn = random.iter().map(|_| r.unit()).collect();
    sets.push(("random normals", random, rn));
    let mut broken = vec![Vec3::Z; plane.len()];
    broken[100] = Vec3::ZERO;
    broken[900] = Vec3::NAN;
    sets.push(("broken normals", plane, broken));
    sets
}

/// Empty-space cut-off on the walls of a room: the cells hug the walls (more empty nodes: the cut-off
/// slabs), and every query finds what the tree without cuts finds.
#[test]
fn empty_space_cuts_hug_the_walls_and_change_no_result() {
    let (_, points, normals) = oriented_sets(8).into_iter().find(|s| s.0 == "room").unwrap();
    let plain = KdTree::build_with_normals(&points, &normals, &BuildParams { empty_cut: f32::INFINITY, ..params(16) }).unwrap();
    let cut = KdTree::build_with_normals(&points, &normals, &BuildParams { empty_cut: 0.25, ..params(16) }).unwrap();
    check_structure("room, cut", &cut, &points, Some(&normals), 16);
    let (e0, e1) = (plain.stats().empty_nodes, cut.stats().empty_nodes);
    assert!(e1 > e0 + 10, "empty nodes: {e0} without cuts, {e1} with");
    let mut r = Rng(23);
    for q in 0..400 {
        let cone = random_cone(&mut r, &points, q).with_backface_cull(q % 3 == 0);
        let (mut a, mut b) = (vec![], vec![]);
        plain.for_each_in_cone(&cone, |i, _, _| a.push(i));
        cut.for_each_in_cone(&cone, |i, _, _| b.push(i));
        assert_eq!(sorted(a), sorted(b), "{cone:?}");
        let c = query_point(&mut r, &points);
        let (mut a, mut b) = (vec![], vec![]);
        plain.for_each_in_radius(c, 0.3, |i, _| a.push(i));
        cut.for_each_in_radius(c, 0.3, |i, _| b.push(i));
        assert_eq!(sorted(a), sorted(b));
    }
}

#[test]
fn backface_culling_never_drops_front_facing_points() {
    let mut r = Rng(19);
    for (name, points, normals) in oriented_sets(6) {
        for max_leaf in [1, 4, 16] {
            let p = BuildParams { cull_min_points: 8, ..params(max_leaf) };
            let tree = KdTree::build_with_normals(&points, &normals, &p).unwrap();
            check_structure(name, &tree, &points, Some(&normals), max_leaf);
            if name == "plane" || name == "sphere" || name == "room" {
                assert!(tree.has_cull_nodes(), "{name}: no culling nodes");
            }
            for q in 0..300 {
                let cone = random_cone(&mut r, &points, q).with_backface_cull(true);
                let all: Vec<u32> = (0..points.len() as u32).filter(|&i| cone.test(points[i as usize]).is_some()).collect();
                let mut got = vec![];
                tree.for_each_in_cone(&cone, |i, _, _| got.push(i));
                let got = sorted(got);
                for i in &got {
                    assert!(all.binary_search(i).is_ok(), "{name}: culled query found a point outside the cone");
                }
                for &i in &all {
                    if !(normals[i as usize].dot(cone.dir) > 0.0) {
                        assert!(got.binary_search(&i).is_ok(), "{name}: dropped front-facing or grazing point {i}, {cone:?}");
                    }
                }
                let mut unculled = vec![];
                tree.for_each_in_cone(&cone.with_backface_cull(false), |i, _, _| unculled.push(i));
                assert_eq!(sorted(unculled), all, "{name}: without culling the query is exact");
            }
        }
    }
    // A ray hitting the plane from behind finds nothing: the whole tree is culled.
    let (_, points, normals) = oriented_sets(6).remove(0);
    let tree = KdTree::build_with_normals(&points, &normals, &BuildParams::default()).unwrap();
    assert!(tree.nodes()[0].is_cull());
    let cone = Cone::new(Vec3::new(0.5, 0.5, -1.0), Vec3::Z, 2.0, 0.3, 0.0);
    let mut n = 0;
    tree.for_each_in_cone(&cone, |_, _, _| n += 1);
    assert_eq!(n, 0);
    tree.for_each_in_cone(&cone.with_backface_cull(false), |_, _, _| n += 1);
    assert!(n > 100);
}

#[test]
fn cone_cap_and_photon_ray() {
    // A photon ray ending on the plane z = 0: the cap reaches points beyond the hit point.
    let points = vec![Vec3::new(0.0, 0.0, -0.05), Vec3::new(0.09, 0.0, -0.01), Vec3::new(0.0, 0.0, -0.2), Vec3::new(0.0, 0.05, 0.5)];
    let tree = KdTree::build(&points, &BuildParams::default()).unwrap();
    let cone = Cone::photon_ray(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, 0.1, 0.1);
    assert!(cone.hemisphere_cap && cone.dh == 0.0 && cone.t_max == 1.0);
    let mut got = vec![];
    tree.for_each_in_cone(&cone, |i, _, _| got.push(i));
    assert_eq!(sorted(got), vec![0, 1, 3]);
    let mut got = vec![];
    tree.for_each_in_cone(&cone.with_hemisphere_cap(false), |i, _, _| got.push(i));
    assert_eq!(got, vec![3]);
    let backwards = Cone { t_max: -0.5, ..cone };
    tree.for_each_in_cone(&backwards, |_, _, _| panic!("a negative length makes the region empty"));
    assert!(points.iter().all(|p| backwards.test(*p).is_none()));
    let ball = Cone::new(Vec3::new(0.0, 0.0, -0.06), Vec3::ZERO, 1.0, 0.02, 0.0);
    let mut got = vec![];
    tree.for_each_in_cone(&ball, |i, t, _| got.push((i, t)));
    assert_eq!(got, vec![(0, 0.0)], "a zero direction is a ball around the origin");
    let grow = Cone::photon_ray(Vec3::ZERO, Vec3::X * 2.0, 0.1, 0.3);
    assert!(grow.h0 == 0.1 && (grow.dh - 0.1).abs() < 1e-6);
    assert!(is_front_facing(Vec3::Z, Vec3::NEG_Z) && !is_front_facing(Vec3::Z, Vec3::X));
    assert!(is_in_front_of_surface(Vec3::Z, Vec3::ZERO, Vec3::Z));
}

#[test]
fn leaves_and_locate_leaf() {
    let mut r = Rng(23);
    for (name, points) in datasets(8) {
        let tree = KdTree::build(&points, &params(8)).unwrap();
        let leaves: Vec<LeafInfo> = tree.leaves().collect();
        assert_eq!(leaves.len(), tree.stats().leaves);
        assert_eq!(leaves.iter().map(|l| l.count as usize).sum::<usize>(), tree.len(), "{name}");
        for _ in 0..100 {
            let p = query_point(&mut r, &points);
            match tree.locate_leaf(p) {
                None => assert!(tree.is_empty() || tree.stats().empty_nodes > 0),
                Some(leaf) => {
                    assert!(leaves.contains(&leaf));
                    // p lies in the leaf's cell iff it lies in the root cell (clamped otherwise).
                    let (lo, hi) = tree.bounds();
                    if p.cmpge(lo).all() && p.cmple(hi).all() {
                        let cell = leaf_cell(&tree, leaf.node as usize);
                        assert!(p.cmpge(cell.0).all() && p.cmple(cell.1).all(), "{name}: {p} not in the located cell");
                    }
                }
            }
        }
    }
}

/// The cell of the node at `target`, found by descending from the root.
fn leaf_cell(tree: &KdTree, target: usize) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = tree.bounds();
    let mut i = 0;
    while i != target {
        match tree.nodes()[i].kind() {
            NodeKind::Interior { axis, split, right_offset } => {
                let right = i + right_offset as usize;
                if target >= right {
                    lo[axis] = split;
                    i = right;
                } else {
                    hi[axis] = split;
                    i += 1;
                }
            }
            _ => i += 1,
        }
    }
    (lo, hi)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Small sets on a coarse lattice (many ties with split planes, duplicates) and random queries.
    #[test]
    fn prop_queries_match_brute_force(
        raw in prop::collection::vec((0u8..6, 0u8..6, 0u8..3), 0..300),
        max_leaf in 1usize..20,
        queries in prop::collection::vec((0u8..12, 0u8..12, 0u8..6, 0u8..12, 0u8..12, 0u8..6, 0u8..8), 1..30),
    ) {
        let points: Vec<Vec3> = raw.iter().map(|&(x, y, z)| Vec3::new(x as f32, y as f32, z as f32) * 0.5).collect();
        let tree = KdTree::build(&points, &params(max_leaf)).unwrap();
        check_structure("proptest", &tree, &points, None, max_leaf);
        let mut heap = KnnHeap::new();
        for &(ax, ay, az, bx, by, bz, rad) in &queries {
            let a = Vec3::new(ax as f32, ay as f32, az as f32) * 0.25 - 0.25;
            let b = Vec3::new(bx as f32, by as f32, bz as f32) * 0.25 - 0.25;
            let radius = rad as f32 * 0.25;
            let mut got = vec![];
            tree.for_each_in_radius(a, radius, |i, _| got.push(i));
            let expected: Vec<u32> = (0..points.len() as u32).filter(|&i| (points[i as usize] - a).length_squared() <= radius * radius).collect();
            prop_assert_eq!(sorted(got), expected);

            let k = 1 + rad as usize * 3;
            tree.knn(a, k, f32::INFINITY, &mut heap);
            let mut all: Vec<f32> = points.iter().map(|p| (*p - a).length_squared()).collect();
            all.sort_by(f32::total_cmp);
            all.truncate(k);
            prop_assert_eq!(heap.sort().iter().map(|n| n.dist2).collect::<Vec<_>>(), all);

            let cone = Cone::new(a, b - a, (b - a).length(), radius * 0.5, 0.1).with_hemisphere_cap(rad % 2 == 0);
            let mut got = vec![];
            tree.for_each_in_cone(&cone, |i, _, _| got.push(i));
            let expected: Vec<u32> = (0..points.len() as u32).filter(|&i| cone.test(points[i as usize]).is_some()).collect();
            prop_assert_eq!(sorted(got), expected);
        }
    }
}
