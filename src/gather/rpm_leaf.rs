//! The leaves of one block of the reverse photon map and the pair work of one photon query against
//! one leaf (`reverse-photon-mapping.md` §3.4–3.5, §6.3): the innermost loops of reverse density
//! estimation, used by [`super::rpm::process_block`].
//!
//! - **Slots**: every leaf's reverse photons are copied to a run of *slots* starting at a multiple
//!   of four and padded to a multiple of four (padding: position +∞, normal 0, which no ball
//!   reaches and no photon filter accepts). Positions are stored four at a time, component by
//!   component ([`Pos4`]): one ball is tested against four reverse photons with 4-wide operations
//!   (the same per-component operations and the same `(x² + y²) + z²` order as a `Vec3A`
//!   `length_squared`: the same decisions as the per-pair test and as the forward search).
//! - **Whole leaves, lazily**: a query whose ball contains the leaf's tight box and whose photon
//!   filter passes for every normal of the leaf reaches all its reverse photons. Its `ΔΦ/(πR²)` is
//!   added once, to the leaf's accumulator, instead of to each of the leaf's `A_w` entries; the
//!   accumulators are added to the entries at the end ([`Leaves::write_back`]). The pairs are the
//!   same; only the summation order changes.
//! - **Photon filter from boxes**: a leaf's box of normals decides the filter for all its reverse
//!   photons when its interval bound is [`FILTER_MARGIN`] away from the threshold; otherwise it is
//!   tested per pair, in the operation order of `ReversePhoton::accepts`.

use super::reverse::ReversePhoton;
use crate::kdtree::KdTree;
use glam::{BVec3A, BVec4A, Vec3, Vec3A, Vec4, Vec4Swizzles};

/// One leaf: the tight box of its reverse photons, the box of their normals (per component), its
/// first slot (a multiple of 4) and its number of reverse photons.
#[derive(Clone, Copy)]
pub(super) struct LeafBox {
    pub lo: Vec3A,
    pub hi: Vec3A,
    pub n_lo: Vec3A,
    pub n_hi: Vec3A,
    pub first: u32,
    pub count: u32,
}

/// Four slots' positions, component by component.
#[derive(Clone, Copy)]
pub(super) struct Pos4 {
    x: Vec4,
    y: Vec4,
    z: Vec4,
}

const _: () = assert!(std::mem::size_of::<Pos4>() == 48);

/// The leaves of one block's kd-tree with their reverse photons in slots.
pub(super) struct Leaves {
    pub boxes: Vec<LeafBox>,
    /// Leaf index (into `boxes`) of every node of the tree (`u32::MAX`: not a non-empty leaf).
    pub node_leaf: Vec<u32>,
    pos: Vec<Pos4>,
    /// Four slots' normals, component by component (padding: 0).
    normals: Vec<Pos4>,
    /// Index into the block of every slot's reverse photon (`u32::MAX`: padding).
    slot_photon: Vec<u32>,
}

impl Leaves {
    pub fn new(tree: &KdTree, block: &[ReversePhoton]) -> Leaves {
        let entries = tree.entries();
        let nodes = tree.nodes();
        let mut l = Leaves { boxes: Vec::new(), node_leaf: vec![u32::MAX; nodes.len()], pos: Vec::new(), normals: Vec::new(), slot_photon: Vec::new() };
        let pad = Vec4::splat(f32::INFINITY);
        for (i, n) in nodes.iter().enumerate() {
            if !(n.is_leaf() && n.leaf_count() > 0) {
                continue;
            }
            let run = &entries[n.leaf_first() as usize..(n.leaf_first() + n.leaf_count()) as usize];
            let first = l.slot_photon.len() as u32;
            let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
            let (mut n_lo, mut n_hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
            for four in run.chunks(4) {
                let mut p4 = Pos4 { x: pad, y: pad, z: pad };
                let mut n4 = Pos4 { x: Vec4::ZERO, y: Vec4::ZERO, z: Vec4::ZERO };
                for (k, e) in four.iter().enumerate() {
                    let (p, nrm) = (Vec3A::from(e.p), Vec3A::from(block[e.index as usize].normal()));
                    (p4.x[k], p4.y[k], p4.z[k]) = (p.x, p.y, p.z);
                    (lo, hi) = (lo.min(p), hi.max(p));
                    (n_lo, n_hi) = (n_lo.min(nrm), n_hi.max(nrm));
                    (n4.x[k], n4.y[k], n4.z[k]) = (nrm.x, nrm.y, nrm.z);
                    l.slot_photon.push(e.index);
                }
                for _ in four.len()..4 {
                    l.slot_photon.push(u32::MAX);
                }
                l.pos.push(p4);
                l.normals.push(n4);
            }
            l.node_leaf[i] = l.boxes.len() as u32;
            l.boxes.push(LeafBox { lo, hi, n_lo, n_hi, first, count: run.len() as u32 });
        }
        l
    }

    /// Number of slots (reverse photons and padding).
    pub fn slots(&self) -> usize {
        self.slot_photon.len()
    }

    /// Bytes held (boxes, node map, slots).
    pub fn bytes(&self) -> usize {
        self.boxes.len() * std::mem::size_of::<LeafBox>() + self.node_leaf.len() * 4 + self.pos.len() * 48 + self.normals.len() * 48 + self.slot_photon.len() * 4
    }

    /// `A_w` of the block (in block order) from the per-slot sums `w` and the per-leaf
    /// accumulators of whole leaves `acc`.
    pub fn write_back(&self, w: &[Vec3A], acc: &[Vec3A], a_w: &mut [Vec3]) {
        for (lb, a) in self.boxes.iter().zip(acc) {
            let s = lb.first as usize..(lb.first + lb.count) as usize;
            for (&j, l) in self.slot_photon[s.clone()].iter().zip(&w[s]) {
                a_w[j as usize] = Vec3::from(*l + *a);
            }
        }
    }
}

/// Margin of the whole-leaf photon filter: a leaf's normal box decides the filter for all its
/// reverse photons only when its bound is this far from the threshold. The per-pair test is an f32
/// dot product of near-unit vectors (error below 1e-6), so a decision taken for the whole leaf is
/// the one every per-pair test would take; closer to the threshold the pairs are tested one by one.
const FILTER_MARGIN: f32 = 1e-5;

/// `(min, max)` of `n · v` over the box `(lo, hi)` of normals `n`.
#[inline(always)]
fn dot_range(lo: Vec3A, hi: Vec3A, v: Vec3A) -> (f32, f32) {
    let (a, b) = (lo * v, hi * v);
    (a.min(b).element_sum(), a.max(b).element_sum())
}

/// What the normal boxes decide for every pair of a leaf and a set of queries.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Filter {
    /// No pair passes the photon filter.
    Fail,
    /// Every pair passes it.
    Pass,
    /// Test per query (or per pair).
    Undecided,
}

/// The photon filter for all pairs of the normals in `(n_lo, n_hi)` and the queries whose `wi` and
/// photon normals lie in the boxes `wi` and `np` (interval bounds of the dot products, with the
/// margin of [`FILTER_MARGIN`]).
#[inline(always)]
pub(super) fn filter_boxes(n_lo: Vec3A, n_hi: Vec3A, wi: (Vec3A, Vec3A), np: (Vec3A, Vec3A)) -> Filter {
    let range = |(lo, hi): (Vec3A, Vec3A)| {
        let (a, b, c, d) = (n_lo * lo, n_lo * hi, n_hi * lo, n_hi * hi);
        (a.min(b).min(c.min(d)).element_sum(), a.max(b).max(c.max(d)).element_sum())
    };
    let ((lo_wi, hi_wi), (lo_np, hi_np)) = (range(wi), range(np));
    if hi_wi < -FILTER_MARGIN || hi_np < 1e-3 - FILTER_MARGIN {
        Filter::Fail
    } else if lo_wi > FILTER_MARGIN && lo_np > 1e-3 + FILTER_MARGIN {
        Filter::Pass
    } else {
        Filter::Undecided
    }
}

/// Four queries of a batch, component by component, for the ball–box tests of one leaf against
/// four queries at once: centres' x, y, z and squared radii (−1 in unused lanes: never met).
#[derive(Clone, Copy)]
pub(super) struct Lanes {
    pub x: Vec4,
    pub y: Vec4,
    pub z: Vec4,
    pub r2: Vec4,
}

impl Lanes {
    /// `(met, inside)`: bit `i` of `met` set when query `i`'s ball meets the box of `lb`, of
    /// `inside` when it also contains it (the tests of [`leaf_pairs`] and [`met_leaf_pairs`], in
    /// the same operation order: the same decisions).
    #[inline(always)]
    pub fn meeting(&self, lb: &LeafBox) -> (u32, u32) {
        let (lo, hi) = ((Vec4::splat(lb.lo.x), Vec4::splat(lb.lo.y), Vec4::splat(lb.lo.z)), (Vec4::splat(lb.hi.x), Vec4::splat(lb.hi.y), Vec4::splat(lb.hi.z)));
        let near = |c: Vec4, lo: Vec4, hi: Vec4| (lo - c).max(c - hi).max(Vec4::ZERO);
        let far = |c: Vec4, lo: Vec4, hi: Vec4| (c - lo).abs().max((c - hi).abs());
        let (nx, ny, nz) = (near(self.x, lo.0, hi.0), near(self.y, lo.1, hi.1), near(self.z, lo.2, hi.2));
        let met = (nx * nx + ny * ny + nz * nz).cmple(self.r2).bitmask();
        let (fx, fy, fz) = (far(self.x, lo.0, hi.0), far(self.y, lo.1, hi.1), far(self.z, lo.2, hi.2));
        (met, met & (fx * fx + fy * fy + fz * fz).cmple(self.r2).bitmask())
    }
}

/// One photon query, as the pair loops read it (SIMD vectors: the same per-component results and
/// the same x + y + z order of the dot products as `Vec3`).
#[derive(Clone, Copy)]
pub(super) struct Query {
    pub c: Vec3A,
    pub wi: Vec3A,
    pub np: Vec3A,
    pub flux: Vec3A,
    pub r2: f32,
}

/// The reverse photons of leaf `lb` that query `q` reaches and whose photon filter it passes:
/// `ΔΦ/(πR²)` added to their `w` entries (if `w` is not empty; to `acc` for a whole leaf); returns
/// how many. The leaf is skipped when the ball misses its box.
#[inline(always)]
pub(super) fn leaf_pairs(q: &Query, lb: &LeafBox, leaves: &Leaves, w: &mut [Vec3A], acc: &mut Vec3A) -> u64 {
    let near = (lb.lo - q.c).max(q.c - lb.hi).max(Vec3A::ZERO);
    if near.length_squared() > q.r2 {
        return 0;
    }
    met_leaf_pairs(q, lb, leaves, w, acc, false)
}

/// [`leaf_pairs`] for a query whose ball meets the leaf's box; `pass`: the photon filter is known to
/// pass for every normal of the leaf (decided for the whole batch). The leaf is skipped when its
/// normal box fails the filter for every normal, taken whole (no distance tests, `acc`) when the
/// box lies inside the ball, and the filter is tested per pair only when the normal box does not
/// decide it for the whole leaf.
#[inline(always)]
pub(super) fn met_leaf_pairs(q: &Query, lb: &LeafBox, leaves: &Leaves, w: &mut [Vec3A], acc: &mut Vec3A, pass: bool) -> u64 {
    let all_pass = pass || {
        let (lo_wi, hi_wi) = dot_range(lb.n_lo, lb.n_hi, q.wi);
        let (lo_np, hi_np) = dot_range(lb.n_lo, lb.n_hi, q.np);
        if hi_wi < -FILTER_MARGIN || hi_np < 1e-3 - FILTER_MARGIN {
            return 0;
        }
        lo_wi > FILTER_MARGIN && lo_np > 1e-3 + FILTER_MARGIN
    };
    let far = (q.c - lb.lo).abs().max((q.c - lb.hi).abs());
    let inside = far.length_squared() <= q.r2;
    match (inside, all_pass) {
        (true, true) => {
            *acc += q.flux;
            lb.count as u64
        }
        (false, true) => near_pairs(q, lb, leaves, w),
        (inside, false) => filtered_pairs(q, lb, leaves, w, inside),
    }
}

/// The squared distances of query `q`'s centre to four slots.
#[inline(always)]
fn dist2(q: (Vec4, Vec4, Vec4, Vec4), p: &Pos4) -> Vec4 {
    let (dx, dy, dz) = (p.x - q.0, p.y - q.1, p.z - q.2);
    dx * dx + dy * dy + dz * dz
}

/// The distance mask of query `q` against four slots (bit `i`: slot `i` within the ball).
#[inline(always)]
fn within(q: (Vec4, Vec4, Vec4, Vec4), p: &Pos4) -> u32 {
    dist2(q, p).cmple(q.3).bitmask()
}

/// A leaf whose filter passes for every normal and whose box the ball meets but does not contain:
/// one 4-wide distance test per four slots; every slot's entry gets `flux` or +0 (branchless).
#[inline(always)]
pub(super) fn near_pairs(q: &Query, lb: &LeafBox, leaves: &Leaves, w: &mut [Vec3A]) -> u64 {
    let q4 = (Vec4::splat(q.c.x), Vec4::splat(q.c.y), Vec4::splat(q.c.z), Vec4::splat(q.r2));
    let (first, groups) = (lb.first as usize, (lb.count as usize).div_ceil(4));
    let r2 = Vec3A::splat(q.r2);
    let mut n = 0u64;
    if w.is_empty() {
        for p in &leaves.pos[first / 4..first / 4 + groups] {
            n += within(q4, p).count_ones() as u64;
        }
    } else {
        for (p, w4) in leaves.pos[first / 4..first / 4 + groups].iter().zip(w[first..first + 4 * groups].chunks_exact_mut(4)) {
            let d2 = dist2(q4, p);
            n += d2.cmple(q4.3).bitmask().count_ones() as u64;
            // Each lane's distance broadcast and compared again: a full-width mask selecting
            // `flux` or +0 (`w` entries are sums of non-negative fluxes from +0, never −0, so
            // adding +0 leaves them bit for bit).
            for (l, d) in w4.iter_mut().zip([d2.xxxx(), d2.yyyy(), d2.zzzz(), d2.wwww()]) {
                *l += Vec3A::select(Vec3A::from_vec4(d).cmple(r2), q.flux, Vec3A::ZERO);
            }
        }
    }
    n
}

/// A leaf whose filter the normal box does not decide: per pair `ReversePhoton::accepts`, four
/// slots at a time (the same per-component products and `(x + y) + z` order as `Vec3A::dot`: the
/// same decisions; padding slots have normal 0: never accepted).
#[inline(always)]
fn filtered_pairs(q: &Query, lb: &LeafBox, leaves: &Leaves, w: &mut [Vec3A], inside: bool) -> u64 {
    let q4 = (Vec4::splat(q.c.x), Vec4::splat(q.c.y), Vec4::splat(q.c.z), Vec4::splat(q.r2));
    let (wi, np) = ((Vec4::splat(q.wi.x), Vec4::splat(q.wi.y), Vec4::splat(q.wi.z)), (Vec4::splat(q.np.x), Vec4::splat(q.np.y), Vec4::splat(q.np.z)));
    let (first, groups) = (lb.first as usize, (lb.count as usize).div_ceil(4));
    let density = !w.is_empty();
    let mut n = 0u64;
    for (g, (p, nr)) in leaves.pos[first / 4..first / 4 + groups].iter().zip(&leaves.normals[first / 4..first / 4 + groups]).enumerate() {
        let near = if inside { BVec4A::splat(true) } else { dist2(q4, p).cmple(q4.3) };
        let front = (wi.0 * nr.x + wi.1 * nr.y + wi.2 * nr.z).cmpgt(Vec4::ZERO);
        let facing = (np.0 * nr.x + np.1 * nr.y + np.2 * nr.z).cmpgt(Vec4::splat(1e-3));
        let m = (near & front & facing).bitmask();
        n += m.count_ones() as u64;
        if density {
            for (i, l) in w[first + 4 * g..first + 4 * g + 4].iter_mut().enumerate() {
                *l += Vec3A::select(BVec3A::splat(m >> i & 1 != 0), q.flux, Vec3A::ZERO);
            }
        }
    }
    n
}
