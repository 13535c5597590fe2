//! The 8-byte kd-tree node and its bit encoding (see the diagram in the [module doc](super)).
//!
//! A node is two `u32` words, `a` and `b`. The two low bits of `b` are the split axis of an interior
//! node (0, 1, 2); the value 3 marks a non-interior node whose kind is in bits 2..4 of `b`.
//! All quantised values are rounded *up* (conservatively) when encoded.

use glam::{Vec2, Vec3};

/// Mask of the two low bits of word `b`: the axis of an interior node, or [`TAG_OTHER`].
const TAG_MASK: u32 = 0b11;
/// Value of the low two bits of `b` for a non-interior node.
const TAG_OTHER: u32 = 0b11;
/// Kind bits (bits 2..4 of `b`) of a non-interior node.
const KIND_LEAF: u32 = 0;
const KIND_EMPTY: u32 = 1;
const KIND_CULL: u32 = 2;

/// Largest right-child offset an interior node can store (30 bits).
pub const MAX_RIGHT_OFFSET: u32 = (1 << 30) - 1;
/// Largest number of points a leaf can reference (8 bits), whatever `max_leaf` says.
pub const MAX_LEAF_COUNT: usize = 255;
/// Safety margin added to the stored `cmax` of a backface-culling node, covering the rounding of
/// the normals, the ray direction and the dot products (all about 1e-7).
pub const CULL_MARGIN: f32 = 1e-5;

/// One kd-tree node: 8 bytes, stored in preorder (the left child of an interior node, and the
/// subtree below a backface-culling node, start at the next index).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
#[repr(C)]
pub struct Node {
    a: u32,
    b: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 8);

/// A decoded [`Node`], for inspection, statistics and tests (the queries read the bits directly).
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum NodeKind {
    /// Points with coordinate `< split` on `axis` are in the left child (next node), points with
    /// coordinate `> split` in the right child (`self + right_offset`); points *equal* to `split`
    /// may be on either side (closed half-spaces), which lets median splits divide duplicates.
    Interior {
        /// Split axis, 0 = x, 1 = y, 2 = z.
        axis: usize,
        /// Position of the splitting plane.
        split: f32,
        /// Index of the right child minus the index of this node (≥ 2).
        right_offset: u32,
    },
    /// A contiguous range `first .. first + count` of [`KdTree::entries`](super::KdTree::entries).
    Leaf {
        /// First position in the tree's entries.
        first: u32,
        /// Number of points (1 ..= 255).
        count: u32,
        /// Diagonal of the leaf's cell (not of its points' bounding box), rounded up to 12
        /// mantissa bits (relative error < 2.5e-4). Used for the adaptive radius of reverse
        /// photon mapping (count / cell size).
        diag: f32,
    },
    /// A subtree without points: the empty side of a slid splitting plane (or the root of a tree
    /// over zero points).
    Empty,
    /// Backface-culling node: every normal `n` in the subtree that starts at the next index
    /// satisfies `angle(n, normal) ≤ δ` with `cmax ≥ sin δ + CULL_MARGIN`, so a ray with unit
    /// direction `d` and `dot(d, normal) > cmax` sees every point of the subtree from behind
    /// (`dot(n, d) > 0`) and skips the subtree.
    Cull {
        /// Reference normal (unit; octahedral, 2 × 16 bits).
        normal: Vec3,
        /// Culling threshold on `dot(dir, normal)`, in (0, 1).
        cmax: f32,
    },
}

impl Node {
    /// The empty node.
    pub const EMPTY: Node = Node { a: 0, b: TAG_OTHER | (KIND_EMPTY << 2) };

    /// An interior node. `axis < 3`, `2 ≤ right_offset ≤ MAX_RIGHT_OFFSET`.
    #[inline]
    pub fn interior(axis: usize, split: f32, right_offset: u32) -> Node {
        debug_assert!(axis < 3 && right_offset <= MAX_RIGHT_OFFSET);
        Node { a: split.to_bits(), b: (right_offset << 2) | axis as u32 }
    }

    /// A leaf over `first .. first + count` (`count ≤ 255`) whose cell diagonal is `diag` (≥ 0).
    #[inline]
    pub fn leaf(first: u32, count: usize, diag: f32) -> Node {
        debug_assert!(count <= MAX_LEAF_COUNT);
        Node { a: first, b: TAG_OTHER | (KIND_LEAF << 2) | ((count as u32) << 4) | (quantize_up(diag, 11) << 12) }
    }

    /// A backface-culling node with unit reference `normal` and threshold `cmax ∈ [0, 1)`.
    /// The stored normal is quantised: build it from [`quantize_normal`]`(normal)` and compute
    /// `cmax` against that, as the builder does.
    #[inline]
    pub fn cull(normal: Vec3, cmax: f32) -> Node {
        let (u, v) = oct_encode(normal);
        Node { a: (u as u32) | ((v as u32) << 16), b: TAG_OTHER | (KIND_CULL << 2) | (quantize_up(cmax, 3) << 4) }
    }

    /// Decodes the node.
    pub fn kind(&self) -> NodeKind {
        if self.is_interior() {
            return NodeKind::Interior { axis: self.axis(), split: self.split(), right_offset: self.right_offset() };
        }
        match (self.b >> 2) & 3 {
            KIND_LEAF => NodeKind::Leaf { first: self.leaf_first(), count: self.leaf_count(), diag: self.leaf_diag() },
            KIND_CULL => NodeKind::Cull { normal: self.cull_normal(), cmax: self.cull_cmax() },
            _ => NodeKind::Empty,
        }
    }

    /// True for an interior node.
    #[inline(always)]
    pub fn is_interior(&self) -> bool {
        self.b & TAG_MASK != TAG_OTHER
    }
    /// True for a leaf.
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.b & 0b1111 == TAG_OTHER | (KIND_LEAF << 2)
    }
    /// True for a backface-culling node.
    #[inline(always)]
    pub fn is_cull(&self) -> bool {
        self.b & 0b1111 == TAG_OTHER | (KIND_CULL << 2)
    }
    /// True for an empty node.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.b & 0b1111 == TAG_OTHER | (KIND_EMPTY << 2)
    }
    /// Split axis of an interior node.
    #[inline(always)]
    pub fn axis(&self) -> usize {
        (self.b & TAG_MASK) as usize
    }
    /// Split position of an interior node.
    #[inline(always)]
    pub fn split(&self) -> f32 {
        f32::from_bits(self.a)
    }
    /// Right-child offset of an interior node.
    #[inline(always)]
    pub fn right_offset(&self) -> u32 {
        self.b >> 2
    }
    /// First point of a leaf.
    #[inline(always)]
    pub fn leaf_first(&self) -> u32 {
        self.a
    }
    /// Point count of a leaf.
    #[inline(always)]
    pub fn leaf_count(&self) -> u32 {
        (self.b >> 4) & 0xff
    }
    /// Cell diagonal of a leaf (rounded up).
    #[inline(always)]
    pub fn leaf_diag(&self) -> f32 {
        f32::from_bits((self.b >> 12) << 11)
    }
    /// Reference normal of a culling node (unit).
    #[inline]
    pub fn cull_normal(&self) -> Vec3 {
        oct_decode(self.a as u16, (self.a >> 16) as u16)
    }
    /// Threshold of a culling node.
    #[inline(always)]
    pub fn cull_cmax(&self) -> f32 {
        f32::from_bits((self.b >> 4) << 3)
    }
    /// The two raw words `(a, b)` (for hashing and debugging).
    pub fn raw(&self) -> (u32, u32) {
        (self.a, self.b)
    }
}

/// Keeps the top `31 - shift` bits of a non-negative finite-or-infinite `f32`, rounding up, so that
/// `f32::from_bits(q << shift) >= x`. Negative and NaN inputs encode 0.
#[inline]
fn quantize_up(x: f32, shift: u32) -> u32 {
    if !(x > 0.0) {
        return 0;
    }
    let bits = x.to_bits() as u64; // sign bit is 0
    let q = (bits + (1u64 << shift) - 1) >> shift;
    q.min((0x7f80_0000u64) >> shift) as u32 // at most +inf
}

/// The unit normal a culling node actually stores for `n` (octahedral, 2 × 16 bits), normalised.
pub fn quantize_normal(n: Vec3) -> Vec3 {
    let (u, v) = oct_encode(n);
    oct_decode(u, v)
}

fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(if v.x >= 0.0 { 1.0 } else { -1.0 }, if v.y >= 0.0 { 1.0 } else { -1.0 })
}

fn oct_encode(n: Vec3) -> (u16, u16) {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    let mut p = if l1 > 0.0 { Vec2::new(n.x, n.y) / l1 } else { Vec2::ZERO };
    if n.z < 0.0 {
        p = (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p);
    }
    let q = |x: f32| ((x.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0).round() as u16;
    (q(p.x), q(p.y))
}

fn oct_decode(u: u16, v: u16) -> Vec3 {
    let p = Vec2::new(u as f32, v as f32) / 65535.0 * 2.0 - Vec2::ONE;
    let z = 1.0 - p.x.abs() - p.y.abs();
    let xy = if z < 0.0 { (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p) } else { p };
    Vec3::new(xy.x, xy.y, z).normalize()
}
