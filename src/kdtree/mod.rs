//! The point kd-tree shared by photon mapping, photon-ray splatting and reverse photon mapping.
//!
//! One tree, three query families:
//! - fixed radius ([`KdTree::for_each_in_radius`]) and its batched form
//!   ([`KdTree::for_each_in_radius_batched`], reverse photon mapping §6.3);
//! - k nearest neighbours ([`KdTree::knn`]) with a reusable max-heap ([`KnnHeap`]);
//! - the photon-ray splatting cone-frustum ([`KdTree::for_each_in_cone`], Algorithm 1 of the
//!   splatting paper §7.2) with the hemisphere cap beyond the photon hit (§5) and backface culling.
//!
//! No query allocates: results go to a closure, the traversal stack is a fixed array of
//! [`MAX_DEPTH`] entries (the build guarantees the depth).
//!
//! # Build ([`KdTree::build`], `construct.rs`)
//! Sliding midpoint (splatting §7.1, reverse photon mapping §3.3): split the longest side of the
//! node's *cell* at its middle; if all points fall on one side, slide the plane onto the nearest
//! point. As in the splatting paper, the slid plane cuts the empty part of the cell off as an
//! *empty node* (the points on the plane stay with the others), so cells hug the surfaces that eye
//! samples and photons lie on and a cone crossing empty space skips it. With
//! [`BuildParams::empty_cut`] (the splat's trees), a node with more than `max_leaf` points first cuts
//! off the widest empty slab between its cell and its points' bounds when that slab is wider than
//! the given fraction of the cell on its axis, also as an empty node. A node becomes a leaf when
//! it holds `≤ max_leaf` points (16) or its cell diagonal is below `min_diag_fraction` (0.1 %) of
//! the root diagonal. Robustness:
//! - every split either strictly shrinks the cell (a cut) or strictly shrinks both point counts,
//!   so planes, lines and duplicates cannot recurse forever;
//! - a leaf holds at most 255 points (8-bit count): a node that would be a larger leaf (a heap of
//!   duplicates, a dense cluster inside `min_diag`) is split at the median point instead, and so is
//!   every node at depth [`SLIDING_DEPTH_LIMIT`] or more, which keeps the depth below [`MAX_DEPTH`];
//!   points equal to a split value may then be on either side (closed half-spaces, which the
//!   queries honour);
//! - points with a non-finite coordinate are not indexed (never found); they end the permutation.
//!
//! The build is deterministic, and large subtrees are built in parallel (rayon) into the identical
//! node array: nodes store *relative* right-child offsets, so subtrees are position independent.
//! The tree keeps its own copy of the points in leaf order, each with its original index
//! ([`Entry`], 16 bytes), so a leaf is one contiguous run of memory. It keeps the coordinates a
//! second time as three *lanes* (one `f32` array per axis in leaf order, 12 bytes per point): every
//! query scans a leaf four points at a time over them (glam's `Vec4`, SSE), with the operations of
//! the scalar tests in their order, so distances and memberships are the same bits as
//! [`Cone::test`] and `(p − c).length_squared()` (the brute-force tests compare them exactly). The
//! lanes avoid transposing the entries on the fly, which cost more than the four-wide scan saves
//! (docs/architecture.md, "Performance").
//!
//! # Node encoding (`node.rs`)
//! Every node is 8 bytes, nodes are stored in preorder: the left child of an interior node, and the
//! subtree guarded by a backface-culling node, are at `index + 1`.
//! ```text
//!            word a (32 bits)                      word b (32 bits)
//!          ┌──────────────────────────────┐ ┌──────────────────────────────┬────┐
//! interior │ split position (f32)         │ │ right-child offset (30 bits) │axis│ axis ∈ {0,1,2}
//!          ├──────────────────────────────┤ ├──────────────────┬───────────┼────┼────┐
//! leaf     │ first point (u32)            │ │ cell diag (20 b) │ count (8) │ 00 │ 11 │
//!          ├──────────────────────────────┤ ├──────────────────┴───────────┼────┼────┤
//! empty    │ 0                            │ │ 0                            │ 01 │ 11 │
//!          ├──────────────┬───────────────┤ ├──────────────────────────────┼────┼────┤
//! culling  │ oct v (16 b) │ oct u (16 b)  │ │ cmax (28 bits)               │ 10 │ 11 │
//!          └──────────────┴───────────────┘ └──────────────────────────────┴────┴────┘
//!                                             bit 31                        3..2  1..0
//! ```
//! - *interior*: the split plane, the axis in the two low bits (value 3 means "not interior") and
//!   the offset from this node to its right child.
//! - *leaf*: the range `first .. first + count` of [`KdTree::entries`], and the diagonal of the
//!   leaf's cell (the top 20 bits of its `f32`, rounded up: relative error < 2.5e-4) — the reverse
//!   photon paper's cell diagonal for the adaptive radius (§6.1), read with [`KdTree::leaves`] and
//!   [`KdTree::locate_leaf`]. The diagonal lives in the node; there is no parallel array.
//! - *empty*: a subtree without points: the empty side of a slid plane, or the root of an empty tree.
//! - *backface culling* (splatting §7.1, only when the tree is built with normals): a reference
//!   normal (octahedral 2 × 16 bits) and `cmax` (top 28 bits of an `f32`, rounded up) derived from
//!   the maximum angular deviation `δ` of the subtree's normals from the reference:
//!   `cmax = sin δ + ε`. A ray with `dot(dir, normal) > cmax` sees the whole subtree from behind.
//!   Such a node is inserted above a subtree of at least `cull_min_points` points whose deviation is
//!   at most `cull_max_angle`, and again further down wherever the deviation halves.
//!
//! # Example
//! ```
//! use glam::Vec3;
//! use raysplat::kdtree::{BuildParams, Cone, KdTree, KnnHeap};
//! let points: Vec<Vec3> = (0..1000).map(|i| Vec3::new((i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32)).collect();
//! let tree = KdTree::build(&points, &BuildParams::default()).unwrap();
//! let mut n = 0;
//! tree.for_each_in_radius(Vec3::splat(4.0), 1.0, |_index, _dist2| n += 1);
//! assert_eq!(n, 7);
//! let mut heap = KnnHeap::new();
//! let r2 = tree.knn(Vec3::splat(4.2), 4, f32::INFINITY, &mut heap);
//! assert_eq!(heap.len(), 4);
//! let cone = Cone::new(Vec3::new(-1.0, 4.0, 4.0), Vec3::X, 20.0, 0.1, 0.0);
//! let mut hits = 0;
//! tree.for_each_in_cone(&cone, |_index, _t, _dist2_perp| hits += 1);
//! assert_eq!(hits, 10);
//! # let _ = r2;
//! ```

// NaN-aware comparisons (`!(x <= y)`) are deliberate throughout: a NaN input must take the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod cone;
mod construct;
mod node;
mod query;
#[cfg(test)]
mod tests;

use glam::{Vec3, Vec4};

pub use cone::{is_front_facing, is_in_front_of_surface, Cone};
pub use node::{quantize_normal, Node, NodeKind, CULL_MARGIN, MAX_LEAF_COUNT, MAX_RIGHT_OFFSET};
pub use query::{KnnHeap, LeafInfo, Neighbor};

/// Capacity of the fixed traversal stacks; the build keeps every root-to-leaf path shorter.
pub const MAX_DEPTH: usize = 80;
/// From this depth on the build stops sliding midpoint and splits at the median point, so that the
/// depth stays below `SLIDING_DEPTH_LIMIT + 33 < MAX_DEPTH` for up to 2³² points.
pub const SLIDING_DEPTH_LIMIT: u32 = 40;

/// Build parameters. `Default` gives the papers' values.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildParams {
    /// A node with at most this many points becomes a leaf (1 ..= 255; the papers use 16).
    pub max_leaf: usize,
    /// A node whose cell diagonal is below this fraction of the root cell diagonal becomes a leaf
    /// (if it holds at most 255 points). Default 1e-3 (0.1 %).
    pub min_diag_fraction: f32,
    /// Subtrees with at least this many points are built in parallel (rayon). The result does not
    /// depend on it. Default 32 768; `usize::MAX` builds sequentially.
    pub parallel_threshold: usize,
    /// Largest angular deviation (radians) of the normals below a backface-culling node. Default 60°.
    /// Only used by [`KdTree::build_with_normals`].
    pub cull_max_angle: f32,
    /// Smallest subtree (in points) that gets a backface-culling node. Default 32.
    pub cull_min_points: usize,
    /// Empty-space cut-off: an interior node whose points leave an empty slab wider than this
    /// fraction of its cell on some axis first splits that slab off as an empty child, so that cells
    /// hug the surfaces and cone traversals crossing empty space beside a surface skip them (the
    /// splat trees use 0.25: their cone queries ~8 % faster on the Cornell box). It makes leaf cells
    /// smaller, which changes what [`NodeKind::Leaf`]'s `diag` means for reverse photon mapping, so
    /// it is off by default (`f32::INFINITY`; any value ≥ 1 disables it).
    pub empty_cut: f32,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            max_leaf: 16,
            min_diag_fraction: 1e-3,
            parallel_threshold: 32 * 1024,
            cull_max_angle: 60f32.to_radians(),
            cull_min_points: 32,
            empty_cut: f32::INFINITY,
        }
    }
}

/// Size and shape of a built tree, for render summaries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KdStats {
    /// Points indexed by the tree.
    pub points: usize,
    /// Points not indexed because a coordinate is not finite.
    pub excluded_points: usize,
    /// All nodes.
    pub nodes: usize,
    /// Interior nodes.
    pub interior_nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Empty nodes.
    pub empty_nodes: usize,
    /// Backface-culling nodes.
    pub cull_nodes: usize,
    /// Largest number of interior nodes on a root-to-leaf path (0 for a single leaf).
    pub depth: usize,
    /// Largest number of points in a leaf.
    pub max_leaf_points: usize,
    /// Memory of the tree in bytes: nodes and entries (points with their indices).
    pub memory_bytes: usize,
}

/// A point of the tree, in leaf order: position and original index (16 bytes, so a leaf of 16
/// points is four cache lines and needs no second array for the indices).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Entry {
    /// Position.
    pub p: Vec3,
    /// Index of the point in the slice given to the build.
    pub index: u32,
}

/// A kd-tree over 3D points: the nodes, and the points reordered so that every leaf references a
/// contiguous range of them (each with its original index).
///
/// Queries report *original* point indices (positions in the slice given to the build).
#[derive(Clone, Debug)]
pub struct KdTree {
    nodes: Vec<Node>,
    entries: Vec<Entry>,
    excluded: Vec<u32>,
    bounds: (Vec3, Vec3),
    min_diag: f32,
    stats: KdStats,
    lanes: Lanes,
}

/// The entries' coordinates in leaf order, one array per axis, padded with 3 NaNs so that four
/// lanes can be read from any entry.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lanes {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Lanes {
    pub(crate) fn of(entries: &[Entry]) -> Lanes {
        let pad = |f: fn(&Entry) -> f32| entries.iter().map(f).chain([f32::NAN; 3]).collect::<Vec<f32>>();
        Lanes { x: pad(|e| e.p.x), y: pad(|e| e.p.y), z: pad(|e| e.p.z) }
    }

    /// A point in every lane.
    #[inline(always)]
    pub(crate) fn splat(c: Vec3) -> [Vec4; 3] {
        [Vec4::splat(c.x), Vec4::splat(c.y), Vec4::splat(c.z)]
    }

    /// The coordinates of entries `j .. j + 4`.
    #[inline(always)]
    pub(crate) fn at(&self, j: usize) -> [Vec4; 3] {
        [Vec4::from_slice(&self.x[j..j + 4]), Vec4::from_slice(&self.y[j..j + 4]), Vec4::from_slice(&self.z[j..j + 4])]
    }

    /// Squared distances of entries `j .. j + 4` to `c` (a [`splat`](Self::splat) point), with the
    /// operations of `(p − c).length_squared()`: the same bits.
    #[inline(always)]
    pub(crate) fn dist2(&self, j: usize, c: [Vec4; 3]) -> Vec4 {
        let [x, y, z] = self.at(j);
        let (dx, dy, dz) = (x - c[0], y - c[1], z - c[2]);
        dx * dx + dy * dy + dz * dz
    }
}

/// The lane mask of a group of four entries of which `left` (≥ 1) belong to the leaf.
#[inline(always)]
pub(crate) fn lanes_left(left: usize) -> u32 {
    if left >= 4 {
        0b1111
    } else {
        (1u32 << left) - 1
    }
}

impl KdTree {
    /// The nodes in preorder (the root is at index 0; a tree always has at least one node).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The indexed points in leaf order; a leaf covers `entries()[first .. first + count]`.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The permutation of all point indices the build produced: the indexed points in leaf order,
    /// then the excluded ones (non-finite coordinates). Callers may reorder their per-point data
    /// with it for coherent access.
    pub fn permutation(&self) -> impl Iterator<Item = u32> + '_ {
        self.entries.iter().map(|e| e.index).chain(self.excluded.iter().copied())
    }

    /// Indices of the points that were not indexed because a coordinate is not finite.
    pub fn excluded(&self) -> &[u32] {
        &self.excluded
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The root cell: the tight bounding box `(min, max)` of the indexed points
    /// (`(+∞, −∞)` for an empty tree).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// The absolute leaf-diagonal threshold the build used (`min_diag_fraction` × root diagonal).
    pub fn min_diag(&self) -> f32 {
        self.min_diag
    }

    /// Statistics (node counts, depth, memory).
    pub fn stats(&self) -> &KdStats {
        &self.stats
    }

    /// True when the tree holds backface-culling nodes (built with normals that were coherent
    /// enough somewhere).
    pub fn has_cull_nodes(&self) -> bool {
        self.stats.cull_nodes > 0
    }
}
