//! Tight bounding boxes of the leaves' points, kept beside the 8-byte node array (which has no room
//! for them): one [`LeafBox`] per leaf in leaf order (preorder), found from a node index by a rank
//! over a bit per node ([`LeafIndex`]). The cone and fixed-radius traversals test a leaf's box
//! before scanning its points; a leaf *cell* (bounded by split planes only) is often much larger
//! than its points, which lie on a surface.

use glam::Vec3;

use super::node::Node;
use super::Entry;

/// The bounding box of one leaf's points (24 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct LeafBox {
    /// Componentwise minimum of the leaf's points.
    pub lo: Vec3,
    /// Componentwise maximum.
    pub hi: Vec3,
}

const _: () = assert!(std::mem::size_of::<LeafBox>() == 24);

/// One block of 64 nodes: which of them are leaves, and how many leaves precede the block.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
struct RankBlock {
    leaves: u64,
    before: u32,
}

const _: () = assert!(std::mem::size_of::<RankBlock>() == 16);

/// Leaf boxes in leaf order and the node → leaf-ordinal rank (0.25 bytes per node).
#[derive(Clone, Debug, Default)]
pub(super) struct LeafIndex {
    boxes: Vec<LeafBox>,
    rank: Vec<RankBlock>,
}

impl LeafIndex {
    /// The boxes of the leaves of `nodes` (preorder) over `entries`.
    pub(super) fn build(nodes: &[Node], entries: &[Entry]) -> LeafIndex {
        let mut rank = vec![RankBlock::default(); nodes.len().div_ceil(64)];
        let mut boxes = Vec::new();
        for (i, n) in nodes.iter().enumerate() {
            if i % 64 == 0 {
                rank[i / 64].before = boxes.len() as u32;
            }
            if n.is_leaf() {
                rank[i / 64].leaves |= 1u64 << (i % 64);
                let (first, count) = (n.leaf_first() as usize, n.leaf_count() as usize);
                let b = entries[first..first + count]
                    .iter()
                    .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), e| (lo.min(e.p), hi.max(e.p)));
                boxes.push(LeafBox { lo: b.0, hi: b.1 });
            }
        }
        LeafIndex { boxes, rank }
    }

    /// The box of the leaf at node index `node` (which must be a leaf).
    #[inline(always)]
    pub(super) fn of(&self, node: usize) -> &LeafBox {
        let b = self.rank[node / 64];
        let below = b.leaves & ((1u64 << (node % 64)) - 1);
        &self.boxes[b.before as usize + below.count_ones() as usize]
    }

    /// The boxes in leaf order.
    pub(super) fn boxes(&self) -> &[LeafBox] {
        &self.boxes
    }

    /// Memory in bytes.
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(self.boxes.as_slice()) + std::mem::size_of_val(self.rank.as_slice())
    }
}

/// True when no point of `b` can be within `r` of `c` with `|p − c|² ≤ r2` computed in f32
/// (the per-axis gaps are never larger than the point's offsets, rounding is monotone, and the
/// sums are formed in the same order; the margin is a safety factor only).
#[inline(always)]
pub(super) fn ball_misses(b: &LeafBox, c: Vec3, r2: f32) -> bool {
    let gap = (b.lo - c).max(c - b.hi).max(Vec3::ZERO);
    gap.length_squared() > r2 * (1.0 + 32.0 * f32::EPSILON)
}
