//! Building the tree: sliding midpoint with median fallback, backface-culling nodes, statistics.

use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;

use super::node::{quantize_normal, Node, CULL_MARGIN, MAX_LEAF_COUNT, MAX_RIGHT_OFFSET};
use super::{BuildParams, Entry, Entry as Item, KdStats, KdTree, SLIDING_DEPTH_LIMIT};
use crate::{Error, Result};

/// A cell: the region of space a node covers.
#[derive(Clone, Copy, Debug)]
struct Cell {
    min: Vec3,
    max: Vec3,
}

impl Cell {
    fn diag(&self) -> f32 {
        (self.max - self.min).length()
    }
}

/// Build settings shared by all recursion levels (and threads).
struct Ctx<'a> {
    max_leaf: usize,
    min_diag: f32,
    parallel_threshold: usize,
    normals: Option<&'a [Vec3]>,
    cull_sin_max: f32,
    cull_min_points: usize,
    empty_cut: f32,
    overflow: AtomicBool,
}

impl KdTree {
    /// Builds a tree over `points` (any number up to `u32::MAX`; non-finite points are not indexed).
    ///
    /// Errors: `max_leaf` outside 1..=255, a negative or NaN `min_diag_fraction`, too many points or
    /// (for more than ~2.7·10⁸ points) too many nodes for the 30-bit child offsets.
    pub fn build(points: &[Vec3], params: &BuildParams) -> Result<KdTree> {
        build(points, None, params)
    }

    /// Builds a tree over `points` with backface-culling nodes derived from `normals` (one per
    /// point; they need not be unit length; zero or non-finite normals only prevent culling above
    /// them). Errors as [`build`](Self::build), plus a length mismatch.
    pub fn build_with_normals(points: &[Vec3], normals: &[Vec3], params: &BuildParams) -> Result<KdTree> {
        if normals.len() != points.len() {
            return Err(Error::param(
                "kdtree normals",
                format!("{} normals for {} points", normals.len(), points.len()),
            ));
        }
        build(points, Some(normals), params)
    }
}

fn build(points: &[Vec3], normals: Option<&[Vec3]>, params: &BuildParams) -> Result<KdTree> {
    if params.max_leaf == 0 || params.max_leaf > MAX_LEAF_COUNT {
        return Err(Error::param("kdtree max_leaf", format!("{} is not in 1..={MAX_LEAF_COUNT}", params.max_leaf)));
    }
    if !(params.min_diag_fraction >= 0.0) {
        return Err(Error::param("kdtree min_diag_fraction", format!("{} is negative or NaN", params.min_diag_fraction)));
    }
    if points.len() > u32::MAX as usize {
        return Err(Error::param("kdtree points", format!("{} points exceed u32 indices", points.len())));
    }

    let (mut items, excluded): (Vec<Item>, Vec<u32>) = {
        let mut items = crate::memory::try_vec_with_capacity(points.len(), || format!("a kd-tree over {} points", points.len()))?;
        let mut excluded = Vec::new();
        for (i, p) in points.iter().enumerate() {
            if p.is_finite() {
                items.push(Item { p: *p, index: i as u32 });
            } else {
                excluded.push(i as u32);
            }
        }
        (items, excluded)
    };
    let (bmin, bmax) = bounds(&items);
    let root = Cell { min: bmin, max: bmax };
    let min_diag = if items.is_empty() { 0.0 } else { params.min_diag_fraction * root.diag() };
    let ctx = Ctx {
        max_leaf: params.max_leaf,
        min_diag,
        parallel_threshold: params.parallel_threshold.max(2),
        normals,
        cull_sin_max: if params.cull_max_angle >= std::f32::consts::FRAC_PI_2 { 1.0 } else { params.cull_max_angle.max(0.0).sin() },
        cull_min_points: params.cull_min_points.max(2),
        empty_cut: params.empty_cut,
        overflow: AtomicBool::new(false),
    };

    let mut nodes = crate::memory::try_vec_with_capacity(2 * items.len() / params.max_leaf + 2, || format!("the nodes of a kd-tree over {} points", points.len()))?;
    if items.is_empty() {
        nodes.push(Node::EMPTY);
    } else {
        build_rec(&mut items, root, 0, 0, None, true, &ctx, &mut nodes);
    }
    if ctx.overflow.load(Ordering::Relaxed) {
        return Err(Error::param("kdtree points", format!("{} points need more nodes than 30-bit offsets address", points.len())));
    }

    let stats = compute_stats(&nodes, items.len(), excluded.len());
    let lanes = super::Lanes::of(&items);
    Ok(KdTree { nodes, entries: items, excluded, bounds: (bmin, bmax), min_diag, stats, lanes })
}

/// Tight bounds of the items (`(+∞, −∞)` when empty).
fn bounds(items: &[Item]) -> (Vec3, Vec3) {
    items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), it| (lo.min(it.p), hi.max(it.p)))
}

/// Builds the subtree over `items` (which start at `base` in the final order) and appends it to `out`.
/// `cull_above` is the threshold of the nearest culling node above; `new_set` is false when the
/// parent cut off empty space only (same points: no new culling node to consider).
#[allow(clippy::too_many_arguments)]
fn build_rec(items: &mut [Item], cell: Cell, base: u32, depth: u32, mut cull_above: Option<f32>, new_set: bool, ctx: &Ctx, out: &mut Vec<Node>) {
    let n = items.len();
    debug_assert!(n > 0);

    if let Some(normals) = ctx.normals {
        // Worth a new culling node only if it can be markedly tighter than the one above.
        let could_tighten = !matches!(cull_above, Some(c) if c <= 4.0 * CULL_MARGIN);
        if new_set && n >= ctx.cull_min_points && could_tighten {
            let limit = cull_above.map_or(ctx.cull_sin_max, |c| ctx.cull_sin_max.min(0.5 * c));
            if let Some((normal, cmax)) = normal_cone(items, normals, limit) {
                let node = Node::cull(normal, cmax);
                out.push(node);
                cull_above = Some(node.cull_cmax());
            }
        }
    }

    let diag = cell.diag();
    let (pmin, pmax) = bounds(items);
    let spread = pmax - pmin;
    let flat = spread.cmple(Vec3::ZERO).all();
    // Empty space beside the points is cut off first (not around a leaf: that would only add nodes
    // above the leaf's points, which the leaf test checks one by one anyway).
    let cut = if depth < SLIDING_DEPTH_LIMIT && n > ctx.max_leaf { empty_space_cut(cell, pmin, pmax, ctx.empty_cut) } else { None };
    if cut.is_none() && (n <= ctx.max_leaf || (n <= MAX_LEAF_COUNT && (flat || diag < ctx.min_diag))) {
        out.push(Node::leaf(base, n, diag));
        return;
    }

    // Sliding midpoint on the longest cell side; the median point when that cannot progress.
    let ext = cell.max - cell.min;
    let longest = |eligible: &dyn Fn(usize) -> bool| {
        (0..3).filter(|&a| eligible(a)).fold(usize::MAX, |best, a| if best == usize::MAX || ext[a] > ext[best] { a } else { best })
    };
    let sliding = if let Some((axis, split, all_left)) = cut {
        Some((axis, split, if all_left { n } else { 0 }))
    } else if flat || diag < ctx.min_diag || depth >= SLIDING_DEPTH_LIMIT {
        None
    } else {
        let axis = longest(&|_| true);
        sliding_midpoint_split(items, axis, cell, pmin, pmax).map(|(split, k)| (axis, split, k))
    };
    let (axis, split, k) = sliding.unwrap_or_else(|| {
        let axis = longest(&|a| flat || spread[a] > 0.0);
        let (split, k) = median_split(items, axis);
        (axis, split, k)
    });

    let (left, right) = items.split_at_mut(k);
    let mut lcell = cell;
    lcell.max[axis] = split;
    let mut rcell = cell;
    rcell.min[axis] = split;
    let rbase = base + k as u32;

    let me = out.len();
    out.push(Node::EMPTY); // patched below
    let split_set = k > 0 && k < n;
    let offset = if n >= ctx.parallel_threshold && split_set {
        let (lnodes, rnodes) = rayon::join(
            || {
                let mut v = Vec::new();
                build_child(left, lcell, base, depth + 1, cull_above, split_set, ctx, &mut v);
                v
            },
            || {
                let mut v = Vec::new();
                build_child(right, rcell, rbase, depth + 1, cull_above, split_set, ctx, &mut v);
                v
            },
        );
        out.extend_from_slice(&lnodes);
        out.extend_from_slice(&rnodes);
        1 + lnodes.len()
    } else {
        build_child(left, lcell, base, depth + 1, cull_above, split_set, ctx, out);
        let offset = out.len() - me;
        build_child(right, rcell, rbase, depth + 1, cull_above, split_set, ctx, out);
        offset
    };
    if offset > MAX_RIGHT_OFFSET as usize {
        ctx.overflow.store(true, Ordering::Relaxed);
    }
    out[me] = Node::interior(axis, split, offset.min(MAX_RIGHT_OFFSET as usize) as u32);
}

/// A child: an empty node for no points, else the subtree.
#[allow(clippy::too_many_arguments)]
fn build_child(items: &mut [Item], cell: Cell, base: u32, depth: u32, cull_above: Option<f32>, new_set: bool, ctx: &Ctx, out: &mut Vec<Node>) {
    if items.is_empty() {
        out.push(Node::EMPTY);
    } else {
        build_rec(items, cell, base, depth, cull_above, new_set, ctx, out);
    }
}

/// Sliding midpoint (the splatting paper's variant): split at the middle of the cell side; when all
/// points fall on one side, put the plane on the nearest point instead, which cuts the empty part of
/// the cell off as an empty child (so cells hug surfaces and cone traversals skip empty space).
/// Returns the split and the number of points that go left (0 or all of them for a cut), or `None`
/// when neither makes progress (a cell side one ulp wide).
fn sliding_midpoint_split(items: &mut [Item], axis: usize, cell: Cell, pmin: Vec3, pmax: Vec3) -> Option<(f32, usize)> {
    let mid = 0.5 * cell.min[axis] + 0.5 * cell.max[axis];
    let (lo, hi) = (pmin[axis], pmax[axis]);
    if lo < mid && mid <= hi {
        Some((mid, partition(items, |p| p[axis] < mid)))
    } else if mid > hi {
        // All points left of the middle: the cell above `hi` is empty (hi < mid ≤ cell.max).
        Some((hi, items.len()))
    } else if lo > cell.min[axis] {
        // All points right of the middle: the cell below `lo` is empty.
        Some((lo, 0))
    } else if hi > lo {
        // mid == lo == cell.min (a cell side of an ulp): slide and move the lowest points left.
        Some((lo, partition(items, |p| p[axis] <= lo)))
    } else {
        None
    }
}

/// The widest empty slab between the cell and the points' bounds, as `(axis, split, all points
/// left)`, if it is wider than `fraction` of the cell on its axis.
fn empty_space_cut(cell: Cell, pmin: Vec3, pmax: Vec3, fraction: f32) -> Option<(usize, f32, bool)> {
    let mut best: Option<(usize, f32, bool)> = None;
    let mut best_frac = fraction;
    for a in 0..3 {
        let ext = cell.max[a] - cell.min[a];
        if !(ext > 0.0) {
            continue;
        }
        let (low, high) = ((pmin[a] - cell.min[a]) / ext, (cell.max[a] - pmax[a]) / ext);
        if low > best_frac {
            (best, best_frac) = (Some((a, pmin[a], false)), low);
        }
        if high > best_frac {
            (best, best_frac) = (Some((a, pmax[a], true)), high);
        }
    }
    best
}

/// Median split: the lower half (by coordinate, then original index) goes left.
fn median_split(items: &mut [Item], axis: usize) -> (f32, usize) {
    let m = items.len() / 2;
    items.select_nth_unstable_by(m, |x, y| x.p[axis].total_cmp(&y.p[axis]).then(x.index.cmp(&y.index)));
    (items[m].p[axis], m)
}

/// Moves the items whose position satisfies `left` to the front; returns their number.
fn partition(items: &mut [Item], left: impl Fn(Vec3) -> bool) -> usize {
    let mut k = 0;
    for j in 0..items.len() {
        if left(items[j].p) {
            items.swap(k, j);
            k += 1;
        }
    }
    k
}

/// The reference normal and culling threshold of the items, if every normal is within an angle
/// whose sine is at most `limit` of the (quantised) mean normal.
fn normal_cone(items: &[Item], normals: &[Vec3], limit: f32) -> Option<(Vec3, f32)> {
    // Two normals within δ of a reference are within 2δ of each other: a cheap early rejection
    // (against the first normal) while summing for the mean.
    let first = normals[items[0].index as usize].normalize_or_zero();
    let min_cos_pair = 1.0 - 2.0 * limit * limit;
    let mut sum = Vec3::ZERO;
    for it in items {
        let n = normals[it.index as usize].normalize_or_zero();
        if !(n.dot(first) >= min_cos_pair - 1e-6) {
            return None;
        }
        sum += n;
    }
    let mean = sum.normalize_or_zero();
    if mean == Vec3::ZERO {
        return None;
    }
    let reference = quantize_normal(mean);
    let mut max_sin = 0.0f32;
    for it in items {
        let n = normals[it.index as usize].normalize_or_zero();
        // sin of the angle from the cross product: accurate for small angles, unlike 1 - cos².
        let sin = n.cross(reference).length();
        if !(n.dot(reference) > 0.0) || !(sin + CULL_MARGIN <= limit) {
            return None;
        }
        max_sin = max_sin.max(sin);
    }
    Some((reference, max_sin + CULL_MARGIN))
}

/// Walks the node array and counts.
fn compute_stats(nodes: &[Node], points: usize, excluded: usize) -> KdStats {
    let mut s = KdStats { points, excluded_points: excluded, nodes: nodes.len(), ..Default::default() };
    // (node, interior depth) pairs; cull nodes do not add depth.
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, d)) = stack.pop() {
        let node = nodes[i];
        if node.is_interior() {
            s.interior_nodes += 1;
            stack.push((i + node.right_offset() as usize, d + 1));
            stack.push((i + 1, d + 1));
        } else if node.is_leaf() {
            s.leaves += 1;
            s.depth = s.depth.max(d);
            s.max_leaf_points = s.max_leaf_points.max(node.leaf_count() as usize);
        } else if node.is_cull() {
            s.cull_nodes += 1;
            stack.push((i + 1, d));
        } else {
            s.empty_nodes += 1;
        }
    }
    s.memory_bytes = std::mem::size_of_val(nodes)
        + points * std::mem::size_of::<Entry>()
        + 3 * (points + 3) * std::mem::size_of::<f32>() // the coordinate lanes
        + excluded * std::mem::size_of::<u32>();
    s
}
