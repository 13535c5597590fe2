//! Spherical queries: fixed radius, batched fixed radius, k nearest neighbours; leaf access.

use glam::{Vec3, Vec4};

use super::{lanes_left, KdTree, Lanes, MAX_DEPTH};

/// Relative padding of plane tests, covering the rounding of `center ± radius` (a few ulps).
const PAD: f32 = 8.0 * f32::EPSILON;

/// One neighbour found by [`KdTree::knn`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbor {
    /// Squared distance to the query point.
    pub dist2: f32,
    /// Original point index.
    pub index: u32,
}

/// Reusable scratch space for [`KdTree::knn`]: a binary max-heap on `dist2`. Keep one per thread;
/// after a query it holds the neighbours (in heap order; see [`sort`](Self::sort)).
#[derive(Clone, Debug, Default)]
pub struct KnnHeap {
    items: Vec<Neighbor>,
}

impl KnnHeap {
    /// An empty heap.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty heap with room for `k` neighbours (queries then never allocate).
    pub fn with_capacity(k: usize) -> Self {
        KnnHeap { items: Vec::with_capacity(k) }
    }

    /// The neighbours found by the last query, in heap order (the farthest first).
    pub fn as_slice(&self) -> &[Neighbor] {
        &self.items
    }

    /// Number of neighbours found.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// True when nothing was found.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Sorts the neighbours by increasing distance (then index) and returns them.
    pub fn sort(&mut self) -> &[Neighbor] {
        self.items.sort_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
        &self.items
    }

    fn max_dist2(&self) -> f32 {
        self.items[0].dist2
    }

    fn push(&mut self, n: Neighbor) {
        self.items.push(n);
        let mut i = self.items.len() - 1;
        while i > 0 {
            let parent = (i - 1) / 2;
            if self.items[parent].dist2 >= self.items[i].dist2 {
                break;
            }
            self.items.swap(parent, i);
            i = parent;
        }
    }

    fn replace_max(&mut self, n: Neighbor) {
        self.items[0] = n;
        let len = self.items.len();
        let mut i = 0;
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut big = i;
            if l < len && self.items[l].dist2 > self.items[big].dist2 {
                big = l;
            }
            if r < len && self.items[r].dist2 > self.items[big].dist2 {
                big = r;
            }
            if big == i {
                break;
            }
            self.items.swap(i, big);
            i = big;
        }
    }
}

/// A leaf of the tree: a contiguous range of the permuted points and the diagonal of its cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafInfo {
    /// Index of the leaf node in [`KdTree::nodes`].
    pub node: u32,
    /// First position in [`KdTree::entries`].
    pub first: u32,
    /// Number of points.
    pub count: u32,
    /// Diagonal of the leaf cell (rounded up, relative error < 2.5e-4); with `count` this gives the
    /// adaptive gather radius of reverse photon mapping §6.1.
    pub diag: f32,
}

impl LeafInfo {
    /// The range of [`KdTree::entries`] the leaf covers.
    pub fn range(&self) -> std::ops::Range<usize> {
        self.first as usize..(self.first + self.count) as usize
    }
}

impl KdTree {
    /// Calls `f(index, dist2)` for every point within `radius` of `center` (`dist2 ≤ radius²`,
    /// a closed ball: radius 0 finds the duplicates of `center`).
    pub fn for_each_in_radius(&self, center: Vec3, radius: f32, f: impl FnMut(u32, f32)) {
        let (lo, hi) = self.bounds;
        let r = radius.max(0.0);
        let rp = r + PAD * (center.abs() + r);
        if !(radius >= 0.0) || (center + rp).cmplt(lo).any() || (center - rp).cmpgt(hi).any() {
            return;
        }
        self.radius_from(0, center, r, f);
    }

    /// Fixed-radius search for many queries at once (reverse photon mapping §6.3): calls
    /// `f(query, index, dist2)` for every point within `queries[query].1` of `queries[query].0`.
    ///
    /// The traversal descends once, for the bounding box of all query balls, to the deepest node whose
    /// cell contains them, and starts every individual query there, skipping the upper levels. Give
    /// it queries that are close together (e.g. the points of one leaf of another tree).
    pub fn for_each_in_radius_batched(&self, queries: &[(Vec3, f32)], mut f: impl FnMut(usize, u32, f32)) {
        let mut lo = Vec3::INFINITY;
        let mut hi = Vec3::NEG_INFINITY;
        for &(c, r) in queries {
            if c.is_finite() && r >= 0.0 {
                lo = lo.min(c - r);
                hi = hi.max(c + r);
            }
        }
        if !(lo.cmple(hi).all()) {
            return;
        }
        let mut node = 0usize;
        loop {
            let n = self.nodes[node];
            if n.is_interior() {
                let (a, s) = (n.axis(), n.split());
                let pad = PAD * (s.abs() + lo[a].abs().max(hi[a].abs()));
                if hi[a] + pad < s {
                    node += 1;
                } else if lo[a] - pad > s {
                    node += n.right_offset() as usize;
                } else {
                    break;
                }
            } else if n.is_cull() {
                node += 1;
            } else {
                break;
            }
        }
        for (q, &(c, r)) in queries.iter().enumerate() {
            if r >= 0.0 {
                self.radius_from(node, c, r, |i, d2| f(q, i, d2));
            }
        }
    }

    /// Fixed-radius traversal of the subtree at `start`.
    fn radius_from(&self, start: usize, c: Vec3, r: f32, mut f: impl FnMut(u32, f32)) {
        let r2 = r * r;
        let (c4, r2_4) = (Lanes::splat(c), Vec4::splat(r2));
        let mut stack = [0u32; MAX_DEPTH];
        let mut sp = 0;
        let mut node = start;
        loop {
            let n = self.nodes[node];
            if n.is_interior() {
                let (a, s) = (n.axis(), n.split());
                let ca = c[a];
                let rp = r + PAD * (ca.abs() + r + s.abs());
                let left = ca - rp <= s;
                let right = ca + rp >= s;
                let far = node + n.right_offset() as usize;
                if left {
                    if right {
                        stack[sp] = far as u32;
                        sp += 1;
                    }
                    node += 1;
                    continue;
                } else if right {
                    node = far;
                    continue;
                }
            } else if n.is_leaf() {
                let (first, count) = (n.leaf_first() as usize, n.leaf_count() as usize);
                for j in (first..first + count).step_by(4) {
                    let d2 = self.lanes.dist2(j, c4);
                    let mut mask = d2.cmple(r2_4).bitmask() & lanes_left(first + count - j);
                    while mask != 0 {
                        let b = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        f(self.entries[j + b].index, d2[b]);
                    }
                }
            } else if n.is_cull() {
                node += 1;
                continue;
            }
            if sp == 0 {
                return;
            }
            sp -= 1;
            node = stack[sp] as usize;
        }
    }

    /// The `k` nearest neighbours of `center` within `max_radius` (`dist2 ≤ max_radius²`; pass
    /// `f32::INFINITY` for no limit), left in `heap` (cleared first; see [`KnnHeap::sort`]).
    ///
    /// Returns the squared radius of the ball that was searched exhaustively: the squared distance
    /// of the `k`-th neighbour when `k` were found, otherwise `max_radius²` (what a density
    /// estimate divides by). Returns 0 for `k = 0`. Among equidistant candidates for the last
    /// place, which one is kept depends on the traversal order (deterministically).
    pub fn knn(&self, center: Vec3, k: usize, max_radius: f32, heap: &mut KnnHeap) -> f32 {
        self.knn_filtered(center, k, max_radius, heap, |_| true)
    }

    /// As [`knn`](Self::knn), among the points whose index `accept` admits (the others are not
    /// candidates at all: the `k`-th accepted point sets the radius).
    #[inline]
    pub fn knn_filtered(&self, center: Vec3, k: usize, max_radius: f32, heap: &mut KnnHeap, accept: impl Fn(u32) -> bool) -> f32 {
        heap.items.clear();
        if k == 0 {
            return 0.0;
        }
        let max_r2 = if max_radius.is_finite() { max_radius * max_radius } else { f32::INFINITY };
        if !(max_radius >= 0.0) || self.is_empty() {
            return max_r2.max(0.0);
        }
        heap.items.reserve(k);
        let mut bound = max_r2;
        let c4 = Lanes::splat(center);
        // (node, squared distance to its cell, per-axis offsets to the cell) — incremental distance
        // (Arya & Mount): replacing one axis offset when crossing a split plane.
        let mut stack = [(0u32, 0f32, Vec3::ZERO); MAX_DEPTH];
        let mut sp = 1;
        stack[0] = (0, 0.0, Vec3::ZERO);
        while sp > 0 {
            sp -= 1;
            let (mut node, d2, off) = stack[sp];
            if d2 > bound {
                continue;
            }
            loop {
                let n = self.nodes[node as usize];
                if n.is_interior() {
                    let (a, s) = (n.axis(), n.split());
                    let diff = center[a] - s;
                    let (near, far) = if diff <= 0.0 { (node + 1, node + n.right_offset()) } else { (node + n.right_offset(), node + 1) };
                    let mut far_off = off;
                    far_off[a] = diff;
                    // Lower bound, recomputed from the offsets (no accumulated rounding) and
                    // padded downwards by a few ulps.
                    let far_d2 = far_off.length_squared() * (1.0 - PAD);
                    if far_d2 <= bound {
                        stack[sp] = (far, far_d2, far_off);
                        sp += 1;
                    }
                    node = near;
                } else if n.is_leaf() {
                    let (first, count) = (n.leaf_first() as usize, n.leaf_count() as usize);
                    for j in (first..first + count).step_by(4) {
                        let d2 = self.lanes.dist2(j, c4);
                        // the bound only shrinks within the leaf: a lane beyond it now stays beyond
                        let mut mask = d2.cmple(Vec4::splat(bound)).bitmask() & lanes_left(first + count - j);
                        while mask != 0 {
                            let b = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            let (pd2, e) = (d2[b], &self.entries[j + b]);
                            if heap.items.len() < k {
                                if pd2 <= bound && accept(e.index) {
                                    heap.push(Neighbor { dist2: pd2, index: e.index });
                                    if heap.items.len() == k {
                                        bound = heap.max_dist2();
                                    }
                                }
                            } else if pd2 < bound && accept(e.index) {
                                heap.replace_max(Neighbor { dist2: pd2, index: e.index });
                                bound = heap.max_dist2();
                            }
                        }
                    }
                    break;
                } else if n.is_cull() {
                    node += 1;
                } else {
                    break;
                }
            }
        }
        if heap.items.len() == k {
            heap.max_dist2()
        } else {
            max_r2
        }
    }

    /// The leaves in preorder, i.e. in the order of their point ranges (which tile `0 .. len()`).
    pub fn leaves(&self) -> impl Iterator<Item = LeafInfo> + '_ {
        self.nodes.iter().enumerate().filter(|(_, n)| n.is_leaf()).map(|(i, n)| LeafInfo {
            node: i as u32,
            first: n.leaf_first(),
            count: n.leaf_count(),
            diag: n.leaf_diag(),
        })
    }

    /// The leaf whose cell contains `p` (on a splitting plane, the left one), or `None` when that
    /// cell is empty (the build cuts empty space off) or the tree is. `p` need not be a point of the
    /// tree; outside the root cell the nearest cell on each split is taken.
    pub fn locate_leaf(&self, p: Vec3) -> Option<LeafInfo> {
        let mut node = 0usize;
        loop {
            let n = self.nodes[node];
            if n.is_interior() {
                node += if p[n.axis()] <= n.split() { 1 } else { n.right_offset() as usize };
            } else if n.is_cull() {
                node += 1;
            } else if n.is_leaf() {
                return Some(LeafInfo { node: node as u32, first: n.leaf_first(), count: n.leaf_count(), diag: n.leaf_diag() });
            } else {
                return None;
            }
        }
    }
}
