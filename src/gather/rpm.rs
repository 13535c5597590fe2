//! Reverse density estimation (`reverse-photon-mapping.md` §3–6): the same sum as Eq. 2, computed
//! from the photons' side (Eq. 3). Every photon `y_j` finds the reverse photons within its radius
//! `R_j` and adds `ΔΦ_j / (π R_j²)` to their entry of the write-back array `A_w`.
//!
//! - **Reverse photon map** (§3.3–3.4): `A_r` is put in Morton order and cut into blocks of
//!   [`BLOCK`] reverse photons; each block gets the shared sliding-midpoint kd-tree (8-byte nodes,
//!   leaves referencing contiguous ranges, the leaf cell diagonal and count in the leaf). Blocks are
//!   compact regions of space, processed in parallel, each owning its slice of `A_w`: no locks, and
//!   every `A_w` entry receives its photons in the same (photon) order for any thread count.
//! - **Coherent queries** (§3.5): photons are visited in the leaf order of the kd-tree over photons
//!   (the global map's tree), so consecutive queries are close in space.
//! - **Batched search** (§6.3): the photons of one photon-tree leaf are one batch; the reverse map is
//!   descended once for the batch's bounding box, then leaf by leaf every query of the batch is
//!   tested against the leaf (loop interchange: the leaf's data stays in L1), four balls at a time
//!   against the leaf's box, with the photon filter decided for whole leaves from their boxes of
//!   normals where it can be (see [`process_block`]; the leaves' slots and the pair loops are in
//!   [`super::rpm_leaf`]).
//! - **Adaptive radius** (§6.1): `R_j` from the photon's leaf in the photon tree, `count` photons in
//!   a cell of diagonal `d`: on a surface the cell covers about `d²/2`, so `k` photons lie within
//!   `R = d·sqrt(k / (2π·count))`, clamped to the maximum radius.
//! - **Completion** (§5.2): `A_w` is returned in `A_r` order and summed to pixels sequentially.

use super::reverse::ReversePhoton;
use super::rpm_leaf::{filter_boxes, leaf_pairs, met_leaf_pairs, near_pairs, Filter, Lanes, Leaves, Query};
use super::Kernel;
use crate::kdtree::{BuildParams, KdTree};
use crate::photon::PhotonMap;
use glam::{Vec3, Vec3A, Vec4};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::time::Instant;

/// Reverse photons per block of the reverse photon map.
pub const BLOCK: usize = 1 << 16;

/// What reverse density estimation measured.
#[derive(Default, Clone, Debug)]
pub struct ReverseStats {
    /// Wall seconds to put `A_r` in Morton order ([`sort_morton`]).
    pub order_s: f64,
    /// Wall seconds of the parallel blocks (each block's kd-tree build and search).
    pub blocks_s: f64,
    /// Seconds to build the block kd-trees and their leaves (summed over blocks: CPU seconds).
    pub build_cpu: f64,
    /// Seconds of search + density estimation (summed over blocks: CPU seconds).
    pub process_cpu: f64,
    /// Photon–reverse-photon pairs accepted.
    pub pairs: u64,
    /// Memory of the largest block kd-tree (bytes).
    pub tree_bytes: u64,
    pub blocks: usize,
}

/// One batch of photon queries: the photons of one leaf of the photon tree.
struct Batch {
    /// Index of the first query in the flat query arrays.
    first: usize,
    count: usize,
    /// Index of the batch's first four-query [`Lanes`].
    first_lane: usize,
    lo: Vec3,
    hi: Vec3,
    /// Boxes (per component) of the batch's incoming directions and photon normals.
    wi_box: (Vec3A, Vec3A),
    np_box: (Vec3A, Vec3A),
}

/// The photon queries in photon-tree leaf order, ready for the pair loops: each with its ball,
/// incoming direction, photon normal and `ΔΦ/(πR²)` ([`Query`]), and per batch its queries four at
/// a time ([`Lanes`]) and the boxes of its directions and normals. Built once per render, not per
/// block: a batch meets about two blocks.
pub struct Queries {
    queries: Vec<Query>,
    /// (position, radius) of every query (the unbatched search's descent).
    balls: Vec<(Vec3, f32)>,
    lanes: Vec<Lanes>,
    batches: Vec<Batch>,
}

impl Queries {
    /// The queries of the photon map's photons with the radius of `kernel`.
    pub fn new(map: &PhotonMap, kernel: Kernel) -> Queries {
        Queries::of_leaves(map, kernel, &leaf_cells(&map.tree))
    }

    /// The queries of the photon-tree leaves `cells` (first entry, count, cell diagonal).
    fn of_leaves(map: &PhotonMap, kernel: Kernel, cells: &[(usize, usize, f32)]) -> Queries {
        let tree = &map.tree;
        let n = cells.iter().map(|c| c.1).sum();
        let lanes = cells.iter().map(|c| c.1.div_ceil(4)).sum();
        let mut q = Queries { queries: Vec::with_capacity(n), balls: Vec::with_capacity(n), lanes: Vec::with_capacity(lanes), batches: Vec::with_capacity(cells.len()) };
        for &(first, count, diag) in cells {
            let r = match kernel {
                Kernel::Fixed(r) => r,
                Kernel::Adaptive { k, max_radius } | Kernel::Knn { k, max_radius } => adaptive_radius(diag, count, k, max_radius),
            };
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for e in &tree.entries()[first..first + count] {
                let j = e.index as usize;
                q.balls.push((e.p, r));
                q.queries.push(Query { c: e.p.into(), r2: r * r, wi: map.wi[j].into(), np: map.n[j].into(), flux: (map.flux[j] * (1.0 / (PI * r * r))).into() });
                lo = lo.min(e.p - r);
                hi = hi.max(e.p + r);
            }
            if count == 0 {
                continue;
            }
            let batch = &q.queries[q.queries.len() - count..];
            let first_lane = q.lanes.len();
            for g in batch.chunks(4) {
                // Unused lanes: centre 0, radius² −1 (never met).
                let mut lane = Lanes { x: Vec4::ZERO, y: Vec4::ZERO, z: Vec4::ZERO, r2: Vec4::splat(-1.0) };
                for (i, query) in g.iter().enumerate() {
                    (lane.x[i], lane.y[i], lane.z[i], lane.r2[i]) = (query.c.x, query.c.y, query.c.z, query.r2);
                }
                q.lanes.push(lane);
            }
            let (mut wi_box, mut np_box) = ((Vec3A::INFINITY, Vec3A::NEG_INFINITY), (Vec3A::INFINITY, Vec3A::NEG_INFINITY));
            for query in batch {
                wi_box = (wi_box.0.min(query.wi), wi_box.1.max(query.wi));
                np_box = (np_box.0.min(query.np), np_box.1.max(query.np));
            }
            q.batches.push(Batch { first: q.queries.len() - count, count, first_lane, lo, hi, wi_box, np_box });
        }
        q
    }

    pub fn len(&self) -> usize {
        self.queries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.queries.is_empty()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.queries.len() * (size_of::<Query>() + size_of::<(Vec3, f32)>()) + self.lanes.len() * size_of::<Lanes>() + self.batches.len() * size_of::<Batch>()
    }
}

/// The adaptive radius of §6.1 for a photon-tree leaf of `count` photons and cell diagonal `diag`.
pub fn adaptive_radius(diag: f32, count: usize, k: usize, max_radius: f32) -> f32 {
    let r = diag * (k as f32 / (2.0 * PI * count.max(1) as f32)).sqrt();
    r.clamp(max_radius * 1e-3, max_radius)
}

/// The leaves in preorder as (first entry, count, exact cell diagonal). The cells are recomputed
/// from the root bounds and the split planes: the 20-bit diagonal stored in the leaf node is rounded
/// (relative error 2.5e-4), which would make the radius depend on the scene's scale.
pub fn leaf_cells(tree: &KdTree) -> Vec<(usize, usize, f32)> {
    let mut out = Vec::new();
    if tree.is_empty() {
        return out;
    }
    let nodes = tree.nodes();
    let mut stack = vec![(0usize, tree.bounds().0, tree.bounds().1)];
    while let Some((i, lo, hi)) = stack.pop() {
        let n = nodes[i];
        if n.is_interior() {
            let (a, s) = (n.axis(), n.split());
            let (mut lh, mut rl) = (hi, lo);
            lh[a] = s;
            rl[a] = s;
            stack.push((i + n.right_offset() as usize, rl, hi));
            stack.push((i + 1, lo, lh));
        } else if n.is_cull() {
            stack.push((i + 1, lo, hi));
        } else if n.is_leaf() && n.leaf_count() > 0 {
            out.push((n.leaf_first() as usize, n.leaf_count() as usize, (hi - lo).length()));
        }
    }
    out
}

/// 10-bit-per-axis Morton code of `p` in the box `(lo, hi)` (`scale`: 1023 / extent).
pub(super) fn morton(p: Vec3, lo: Vec3, scale: Vec3) -> u64 {
    let spread = |x: u64| {
        let mut x = x & 0x3ff;
        x = (x | x << 16) & 0x0300_00ff;
        x = (x | x << 8) & 0x0300_f00f;
        x = (x | x << 4) & 0x030c_30c3;
        x = (x | x << 2) & 0x0924_9249;
        x
    };
    let c = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(1023.0));
    spread(c.x as u64) | spread(c.y as u64) << 1 | spread(c.z as u64) << 2
}

/// Bits of the input index in a sort key (below the 30-bit Morton code).
const INDEX_BITS: u32 = 34;

/// Working memory of one block in flight, per reverse photon: the leaves' slots (position 12,
/// normal 12, write-back entry 16, reverse photon index 4; slots are padded to four per leaf: 13 %
/// more slots than reverse photons measured on the Cornell box, 25 % allowed) and the block kd-tree
/// with its leaf boxes and accumulators (16-byte entries, nodes, boxes, build scratch).
pub const BLOCK_BYTES_PER_REVERSE_PHOTON: u64 = (12 + 12 + 16 + 4) * 5 / 4 + 40;

/// Put `A_r` in Morton order, in place (§3.3: the blocks of the reverse photon map are then compact
/// regions of space). One 8-byte key per reverse photon (a transient 8 bytes per reverse photon,
/// while `A_w` does not exist yet): the 30-bit Morton code above the input index, so ties keep their
/// input order and the order never depends on the thread count. Bounds, keys and the sort are
/// parallel; the keys then apply the permutation in place (following its cycles, sequential).
pub fn sort_morton(a_r: &mut [ReversePhoton]) {
    if a_r.len() < 2 {
        return;
    }
    assert!((a_r.len() as u64) < 1 << INDEX_BITS, "more than 2^34 reverse photons in one task");
    let (lo, hi) = a_r
        .par_chunks(1 << 14)
        .map(|c| c.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), rp| (lo.min(rp.pos()), hi.max(rp.pos()))))
        .reduce(|| (Vec3::INFINITY, Vec3::NEG_INFINITY), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    let scale = Vec3::splat(1023.0) / (hi - lo).max(Vec3::splat(1e-30));
    let mut keys: Vec<u64> = a_r.par_iter().enumerate().map(|(i, rp)| morton(rp.pos(), lo, scale) << INDEX_BITS | i as u64).collect();
    keys.par_sort_unstable();
    // Slot i receives the reverse photon of key i; one that was moved away by an earlier swap is
    // found by following where it went (the keys of slots < i record it).
    let mask = (1u64 << INDEX_BITS) - 1;
    for i in 0..keys.len() {
        let mut j = (keys[i] & mask) as usize;
        while j < i {
            j = (keys[j] & mask) as usize;
        }
        keys[i] = j as u64;
        a_r.swap(i, j);
    }
}

/// Radiance along every gather ray (`A_w`). `A_r` is first put in Morton order (in place) and cut
/// into blocks of `block` reverse photons, searched at most `flight` at a time; `A_w` is returned
/// in that (new) `A_r` order. The result depends on `block`, never on `flight` or the threads.
pub fn estimate(queries: &Queries, a_r: &mut [ReversePhoton], batched: bool, block: usize, flight: usize) -> (Vec<Vec3>, ReverseStats) {
    run(queries, a_r, batched, true, block, flight)
}

/// The search alone (pairs counted, no density estimation), for `raysplat-bench fg`.
pub fn search_only(queries: &Queries, a_r: &mut [ReversePhoton], batched: bool) -> ReverseStats {
    run(queries, a_r, batched, false, BLOCK, usize::MAX).1
}

fn run(queries: &Queries, a_r: &mut [ReversePhoton], batched: bool, density: bool, block: usize, flight: usize) -> (Vec<Vec3>, ReverseStats) {
    let mut stats = ReverseStats::default();
    if a_r.is_empty() {
        return (Vec::new(), stats);
    }
    let block = block.max(1);
    let t = Instant::now();
    sort_morton(a_r);
    stats.order_s = t.elapsed().as_secs_f64();
    let a_r: &[ReversePhoton] = a_r;
    let mut a_w = vec![Vec3::ZERO; if density { a_r.len() } else { 0 }];
    let t = Instant::now();
    // waves of `flight` blocks (a whole number of blocks each: the same blocks as in one wave)
    let wave = block.saturating_mul(flight.max(1));
    let mut per_block: Vec<ReverseStats> = Vec::new();
    for (k, r) in a_r.chunks(wave).enumerate() {
        if density {
            let w = &mut a_w[k * wave..k * wave + r.len()];
            per_block.par_extend(r.par_chunks(block).zip(w.par_chunks_mut(block)).map(|(b, w)| process_block(queries, b, w, batched)));
        } else {
            per_block.par_extend(r.par_chunks(block).map(|b| process_block(queries, b, &mut [], batched)));
        }
    }
    stats.blocks_s = t.elapsed().as_secs_f64();
    for st in per_block {
        stats.add(&st);
    }
    (a_w, stats)
}

impl ReverseStats {
    /// Accumulate another block's (or task's) figures.
    pub fn add(&mut self, st: &ReverseStats) {
        self.order_s += st.order_s;
        self.blocks_s += st.blocks_s;
        self.build_cpu += st.build_cpu;
        self.process_cpu += st.process_cpu;
        self.pairs += st.pairs;
        self.tree_bytes = self.tree_bytes.max(st.tree_bytes);
        self.blocks += st.blocks;
    }

    /// Wall seconds of the search (search + density estimation), the rest being the build: the
    /// parallel blocks' wall time split by their CPU time, the Morton order counted as build. (The
    /// order is not split by CPU time: it would count its wall time partly as search, more so the
    /// more threads share the blocks.)
    pub fn search_wall(&self) -> f64 {
        self.blocks_s * self.process_cpu / (self.process_cpu + self.build_cpu).max(1e-12)
    }
}

/// The leaves whose cell meets the box `(lo, hi)`, appended to `out` (indices into `boxes`).
fn leaves_in_box(tree: &KdTree, node_leaf: &[u32], lo: Vec3, hi: Vec3, stack: &mut Vec<u32>, out: &mut Vec<u32>) {
    let nodes = tree.nodes();
    stack.clear();
    stack.push(0);
    while let Some(i) = stack.pop() {
        let mut i = i as usize;
        loop {
            let n = nodes[i];
            if n.is_interior() {
                let (a, sp) = (n.axis(), n.split());
                let (l, r) = (lo[a] <= sp, hi[a] >= sp);
                let far = i + n.right_offset() as usize;
                if l && r {
                    stack.push(far as u32);
                    i += 1;
                } else if l {
                    i += 1;
                } else {
                    i = far;
                }
            } else if n.is_cull() {
                i += 1;
            } else {
                if n.is_leaf() && n.leaf_count() > 0 {
                    out.push(node_leaf[i]);
                }
                break;
            }
        }
    }
}

/// One block of the reverse photon map: build its kd-tree, search it from every photon batch whose
/// box meets the block, and accumulate `ΔΦ/(πR²)` into `a_w` (the block's slice of `A_w`; empty:
/// count the pairs only).
///
/// Batched search (§6.3): one descent per batch collects the leaves whose cells meet the batch's
/// box; then, leaf by leaf, every query of the batch is tested against the leaf (loop interchange:
/// the leaf's slots stay in L1 while the batch's queries pass over them), four queries at a time
/// against the leaf's box ([`Lanes::meeting`]): per (query, leaf) the leaf is skipped, taken whole
/// (one add to the leaf's accumulator) or its slots tested four at a time (see [`super::rpm_leaf`]).
/// The photon filter is decided once per (batch, leaf) from the boxes of the batch's directions and
/// photon normals and the leaf's normals where it can be, else per query or per pair.
pub fn process_block(queries: &Queries, block: &[ReversePhoton], a_w: &mut [Vec3], batched: bool) -> ReverseStats {
    let density = !a_w.is_empty();
    let t = Instant::now();
    let pts: Vec<Vec3> = block.iter().map(|rp| rp.pos()).collect();
    let params = BuildParams { parallel_threshold: usize::MAX, ..BuildParams::default() };
    let tree = KdTree::build(&pts, &params).expect("finite reverse photons");
    drop(pts);
    let leaves = Leaves::new(&tree, block);
    let boxes = &leaves.boxes;
    let mut w = vec![Vec3A::ZERO; if density { leaves.slots() } else { 0 }];
    let mut acc = vec![Vec3A::ZERO; if density { boxes.len() } else { 0 }];
    let mut st = ReverseStats {
        build_cpu: t.elapsed().as_secs_f64(),
        tree_bytes: (tree.stats().memory_bytes + leaves.bytes() + w.len() * 16 + acc.len() * 16) as u64,
        blocks: 1,
        ..Default::default()
    };
    let t = Instant::now();
    let (blo, bhi) = tree.bounds();
    let mut pairs = 0u64;
    let mut whole = Vec3A::ZERO;
    let (mut stack, mut cand) = (Vec::new(), Vec::new());
    for b in &queries.batches {
        if b.hi.cmplt(blo).any() || b.lo.cmpgt(bhi).any() {
            continue;
        }
        let batch = &queries.queries[b.first..b.first + b.count];
        if batched {
            let lanes = &queries.lanes[b.first_lane..b.first_lane + b.count.div_ceil(4)];
            let (wi_box, np_box) = (b.wi_box, b.np_box);
            cand.clear();
            leaves_in_box(&tree, &leaves.node_leaf, b.lo, b.hi, &mut stack, &mut cand);
            let (blo, bhi) = (Vec3A::from(b.lo), Vec3A::from(b.hi));
            for &l in &cand {
                let lb = &boxes[l as usize];
                // The leaf's tight box against the batch's box (its cell met it).
                if lb.lo.cmpgt(bhi).any() || lb.hi.cmplt(blo).any() {
                    continue;
                }
                // The photon filter for the whole batch at once, from the boxes of its directions
                // and photon normals (per query when undecided).
                let filter = filter_boxes(lb.n_lo, lb.n_hi, wi_box, np_box);
                if filter == Filter::Fail {
                    continue;
                }
                // Four queries at a time against the leaf's box, in query order.
                whole = Vec3A::ZERO;
                for (g, lane) in lanes.iter().enumerate() {
                    let (met, inside) = lane.meeting(lb);
                    let qs = &batch[4 * g..];
                    if filter == Filter::Pass {
                        pairs += inside.count_ones() as u64 * lb.count as u64;
                        if density {
                            for_bits(inside, |i| whole += qs[i].flux);
                        }
                        for_bits(met & !inside, |i| pairs += near_pairs(&qs[i], lb, &leaves, &mut w));
                    } else {
                        for_bits(met, |i| pairs += met_leaf_pairs(&qs[i], lb, &leaves, &mut w, &mut whole, false));
                    }
                }
                if density {
                    acc[l as usize] += whole;
                }
            }
        } else {
            for (q, &(c, r)) in batch.iter().zip(&queries.balls[b.first..b.first + b.count]) {
                // One descent per query, for its own ball.
                cand.clear();
                leaves_in_box(&tree, &leaves.node_leaf, c - r, c + r, &mut stack, &mut cand);
                for &l in &cand {
                    pairs += leaf_pairs(q, &boxes[l as usize], &leaves, &mut w, if density { &mut acc[l as usize] } else { &mut whole });
                }
            }
        }
    }
    if density {
        leaves.write_back(&w, &acc, a_w);
    }
    st.pairs = pairs;
    st.process_cpu = t.elapsed().as_secs_f64();
    st
}

/// `f(i)` for every set bit `i` of `m`, lowest first.
#[inline(always)]
fn for_bits(mut m: u32, mut f: impl FnMut(usize)) {
    while m != 0 {
        f(m.trailing_zeros() as usize);
        m &= m - 1;
    }
}
