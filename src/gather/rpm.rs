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
//!   descended once for the batch's bounding box and every query starts from there.
//! - **Adaptive radius** (§6.1): `R_j` from the photon's leaf in the photon tree, `count` photons in
//!   a cell of diagonal `d`: on a surface the cell covers about `d²/2`, so `k` photons lie within
//!   `R = d·sqrt(k / (2π·count))`, clamped to the maximum radius.
//! - **Completion** (§5.2): `A_w` is returned in `A_r` order and summed to pixels sequentially.

use super::reverse::ReversePhoton;
use super::Kernel;
use crate::kdtree::{BuildParams, KdTree};
use crate::photon::PhotonMap;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::time::Instant;

/// Reverse photons per block of the reverse photon map.
pub const BLOCK: usize = 1 << 16;

/// What reverse density estimation measured.
#[derive(Default, Clone, Debug)]
pub struct ReverseStats {
    /// Seconds to order `A_r` and build the block kd-trees (summed over blocks: CPU seconds).
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
    lo: Vec3,
    hi: Vec3,
}

/// The photon queries in photon-tree leaf order: (position, radius), photon index, `ΔΦ/(πR²)`.
pub struct Queries {
    balls: Vec<(Vec3, f32)>,
    photon: Vec<u32>,
    scaled_flux: Vec<Vec3>,
    batches: Vec<Batch>,
}

impl Queries {
    pub fn new(map: &PhotonMap, kernel: Kernel) -> Queries {
        let tree = &map.tree;
        let mut q = Queries { balls: Vec::with_capacity(map.len()), photon: Vec::new(), scaled_flux: Vec::new(), batches: Vec::new() };
        for (first, count, diag) in leaf_cells(tree) {
            let r = match kernel {
                Kernel::Fixed(r) => r,
                Kernel::Adaptive { k, max_radius } | Kernel::Knn { k, max_radius } => adaptive_radius(diag, count, k, max_radius),
            };
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for e in &tree.entries()[first..first + count] {
                q.balls.push((e.p, r));
                q.photon.push(e.index);
                q.scaled_flux.push(map.flux[e.index as usize] * (1.0 / (PI * r * r)));
                lo = lo.min(e.p - r);
                hi = hi.max(e.p + r);
            }
            if count > 0 {
                q.batches.push(Batch { first: q.balls.len() - count, count, lo, hi });
            }
        }
        q
    }

    pub fn len(&self) -> usize {
        self.balls.len()
    }

    pub fn is_empty(&self) -> bool {
        self.balls.is_empty()
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

/// 21-bit-per-axis Morton code of `p` in the box `(lo, hi)`.
fn morton(p: Vec3, lo: Vec3, scale: Vec3) -> u64 {
    let spread = |x: u64| {
        let mut x = x & 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let c = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(2_097_151.0));
    spread(c.x as u64) | spread(c.y as u64) << 1 | spread(c.z as u64) << 2
}

/// Working memory of one block in flight, per reverse photon: positions and normals (12 + 12) and
/// the block kd-tree (16-byte entries, nodes, build scratch).
pub const BLOCK_BYTES_PER_REVERSE_PHOTON: u64 = 12 + 12 + 32;

/// Put `A_r` in Morton order, in place (§3.3: the blocks of the reverse photon map are then compact
/// regions of space). Keys are computed once (a transient 16 bytes per reverse photon, while `A_w`
/// does not exist yet); ties keep their input order, so the order never depends on the thread count.
pub fn sort_morton(a_r: &mut [ReversePhoton]) {
    if a_r.is_empty() {
        return;
    }
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for rp in a_r.iter() {
        lo = lo.min(rp.pos());
        hi = hi.max(rp.pos());
    }
    let scale = Vec3::splat(2_097_151.0) / (hi - lo).max(Vec3::splat(1e-30));
    a_r.par_sort_by_cached_key(|rp| morton(rp.pos(), lo, scale));
}

/// Radiance along every gather ray (`A_w`). `A_r` is first put in Morton order (in place) and cut
/// into blocks of `block` reverse photons; `A_w` is returned in that (new) `A_r` order.
pub fn estimate(map: &PhotonMap, queries: &Queries, a_r: &mut [ReversePhoton], batched: bool, block: usize) -> (Vec<Vec3>, ReverseStats) {
    run(map, queries, a_r, batched, true, block)
}

/// The search alone (pairs counted, no density estimation), for `bench --fg-table`.
pub fn search_only(map: &PhotonMap, queries: &Queries, a_r: &mut [ReversePhoton], batched: bool) -> ReverseStats {
    run(map, queries, a_r, batched, false, BLOCK).1
}

fn run(map: &PhotonMap, queries: &Queries, a_r: &mut [ReversePhoton], batched: bool, density: bool, block: usize) -> (Vec<Vec3>, ReverseStats) {
    let mut stats = ReverseStats::default();
    if a_r.is_empty() {
        return (Vec::new(), stats);
    }
    let block = block.max(1);
    let t = Instant::now();
    sort_morton(a_r);
    stats.build_cpu += t.elapsed().as_secs_f64();
    let a_r: &[ReversePhoton] = a_r;
    let mut a_w = vec![Vec3::ZERO; if density { a_r.len() } else { 0 }];
    let per_block: Vec<ReverseStats> = if density {
        a_r.par_chunks(block).zip(a_w.par_chunks_mut(block)).map(|(b, w)| process_block(map, queries, b, w, batched)).collect()
    } else {
        a_r.par_chunks(block).map(|b| process_block(map, queries, b, &mut [], batched)).collect()
    };
    for st in per_block {
        stats.add(&st);
    }
    (a_w, stats)
}

impl ReverseStats {
    /// Accumulate another block's (or task's) figures.
    pub fn add(&mut self, st: &ReverseStats) {
        self.build_cpu += st.build_cpu;
        self.process_cpu += st.process_cpu;
        self.pairs += st.pairs;
        self.tree_bytes = self.tree_bytes.max(st.tree_bytes);
        self.blocks += st.blocks;
    }
}

/// One block of the reverse photon map: build its kd-tree, search it from every photon batch whose
/// box meets the block, and accumulate `ΔΦ/(πR²)` into `a_w` (the block's slice of `A_w`; empty:
/// count the pairs only).
pub fn process_block(map: &PhotonMap, queries: &Queries, block: &[ReversePhoton], a_w: &mut [Vec3], batched: bool) -> ReverseStats {
    let density = !a_w.is_empty();
    let t = Instant::now();
    let pts: Vec<Vec3> = block.iter().map(|rp| rp.pos()).collect();
    let params = BuildParams { parallel_threshold: usize::MAX, ..BuildParams::default() };
    let tree = KdTree::build(&pts, &params).expect("finite reverse photons");
    drop(pts);
    let normals: Vec<Vec3> = block.iter().map(|rp| rp.normal()).collect();
    let mut st = ReverseStats { build_cpu: t.elapsed().as_secs_f64(), tree_bytes: tree.stats().memory_bytes as u64, blocks: 1, ..Default::default() };
    let t = Instant::now();
    let (blo, bhi) = tree.bounds();
    let mut pairs = 0u64;
    for b in &queries.batches {
        if b.hi.cmplt(blo).any() || b.lo.cmpgt(bhi).any() {
            continue;
        }
        let range = b.first..b.first + b.count;
        let mut visit = |q: usize, i: u32, _d2: f32| {
            let (q, i) = (b.first + q, i as usize);
            let j = queries.photon[q] as usize;
            if ReversePhoton::accepts(normals[i], map.wi[j], map.n[j]) {
                pairs += 1;
                if density {
                    a_w[i] += queries.scaled_flux[q];
                }
            }
        };
        if batched {
            tree.for_each_in_radius_batched(&queries.balls[range], &mut visit);
        } else {
            for (q, &(c, r)) in queries.balls[range].iter().enumerate() {
                tree.for_each_in_radius(c, r, |i, d2| visit(q, i, d2));
            }
        }
    }
    st.pairs = pairs;
    st.process_cpu = t.elapsed().as_secs_f64();
    st
}
