//! Texels in cache-line blocks: the image is cut into blocks of `BW × BH` texels that fill one
//! 64-byte cache line each (8-bit RGBA: 4×4 texels), stored in row-major
//! block order, the image padded to whole blocks. A bilinear footprint (2×2 texels) then lies in
//! one line unless it straddles a block edge — for 4×4 blocks in 9 of the 16 positions, where a
//! row-major array always needs two lines (one per row) for a footprint of incoherent rays.

/// One 64-byte block of `1 << SHIFT_X` × `1 << SHIFT_Y` texels, row-major inside the block.
pub(super) trait Block: Copy {
    type Texel: Copy;
    const SHIFT_X: u32;
    const SHIFT_Y: u32;
    const EMPTY: Self;
    fn get(&self, i: usize) -> Self::Texel;
    /// Row `r` of the block.
    fn row_mut(&mut self, r: usize) -> &mut [Self::Texel];
}

/// 4×4 8-bit RGBA texels.
#[derive(Clone, Copy, bytemuck::Zeroable, bytemuck::Pod)]
#[repr(C, align(64))]
pub(super) struct Rgba8x4x4([[u8; 4]; 16]);

const _: () = assert!(std::mem::size_of::<Rgba8x4x4>() == 64);

macro_rules! block {
    ($t:ty, $texel:ty, $sx:expr, $sy:expr, $empty:expr) => {
        impl Block for $t {
            type Texel = $texel;
            const SHIFT_X: u32 = $sx;
            const SHIFT_Y: u32 = $sy;
            const EMPTY: Self = $empty;
            #[inline(always)]
            fn get(&self, i: usize) -> $texel {
                self.0[i]
            }
            fn row_mut(&mut self, r: usize) -> &mut [$texel] {
                &mut self.0[r << $sx..(r + 1) << $sx]
            }
        }
    };
}
block!(Rgba8x4x4, [u8; 4], 2, 2, Rgba8x4x4([[0; 4]; 16]));

/// A `width × height` image in blocks `B` (padding texels are never read).
pub(super) struct Blocked<B> {
    blocks: Vec<B>,
    /// Blocks per block row.
    blocks_x: usize,
}

impl<B: Block> Blocked<B> {
    const W: usize = 1 << B::SHIFT_X;
    const MASK_X: usize = Self::W - 1;
    const MASK_Y: usize = (1 << B::SHIFT_Y) - 1;

    /// The image of `width × height` texels given row-major, row 0 first (`rows.len()` must be
    /// `width · height`).
    pub fn from_rows(width: u32, height: u32, rows: &[B::Texel]) -> Self {
        let (w, h) = (width as usize, height as usize);
        assert_eq!(rows.len(), w * h, "texel count");
        let (blocks_x, blocks_y) = (w.div_ceil(Self::W), h.div_ceil(Self::MASK_Y + 1));
        let mut blocks = Vec::with_capacity(blocks_x * blocks_y);
        for by in 0..blocks_y {
            for bx in 0..blocks_x {
                let mut block = B::EMPTY;
                let x0 = bx * Self::W;
                let run = Self::W.min(w - x0);
                for r in 0..=Self::MASK_Y {
                    let y = (by << B::SHIFT_Y) + r;
                    if y < h {
                        // Element by element: a `copy_from_slice` of 2–4 texels is a `memcpy` call.
                        for (d, s) in block.row_mut(r).iter_mut().zip(&rows[y * w + x0..][..run]) {
                            *d = *s;
                        }
                    }
                }
                blocks.push(block);
            }
        }
        Blocked { blocks, blocks_x }
    }

    /// The blocks, in row-major block order.
    pub fn blocks(&self) -> &[B] {
        &self.blocks
    }

    /// The image of `width × height` texels from its blocks ([`Self::blocks`]); `None` when their
    /// number does not fit the size.
    pub fn from_blocks(width: u32, height: u32, blocks: Vec<B>) -> Option<Self> {
        let blocks_x = (width as usize).div_ceil(Self::W);
        (blocks.len() == blocks_x * (height as usize).div_ceil(Self::MASK_Y + 1)).then_some(Blocked { blocks, blocks_x })
    }

    /// (block, index inside the block) of texel `(x, y)`.
    #[inline(always)]
    fn index(&self, x: usize, y: usize) -> (usize, usize) {
        let k = (y >> B::SHIFT_Y) * self.blocks_x + (x >> B::SHIFT_X);
        (k, ((y & Self::MASK_Y) << B::SHIFT_X) | (x & Self::MASK_X))
    }

    /// Texel `(x, y)`, inside the image.
    #[inline(always)]
    pub fn get(&self, x: usize, y: usize) -> B::Texel {
        let (k, i) = self.index(x, y);
        self.blocks[k].get(i)
    }

    /// Texels `(x, y)`, `(x + 1, y)`, `(x, y + 1)`, `(x + 1, y + 1)`, all inside the image.
    #[inline(always)]
    pub fn quad(&self, x: usize, y: usize) -> [B::Texel; 4] {
        if x & Self::MASK_X != Self::MASK_X && y & Self::MASK_Y != Self::MASK_Y {
            let (k, i) = self.index(x, y);
            let b = &self.blocks[k];
            [b.get(i), b.get(i + 1), b.get(i + Self::W), b.get(i + Self::W + 1)]
        } else {
            [self.get(x, y), self.get(x + 1, y), self.get(x, y + 1), self.get(x + 1, y + 1)]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check<B: Block>(w: u32, h: u32, f: impl Fn(u32, u32) -> B::Texel) -> Result<(), TestCaseError>
    where
        B::Texel: PartialEq + std::fmt::Debug,
    {
        let rows: Vec<B::Texel> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        let b = Blocked::<B>::from_rows(w, h, &rows);
        let at = |x: u32, y: u32| rows[(y * w + x) as usize];
        for y in 0..h {
            for x in 0..w {
                prop_assert_eq!(b.get(x as usize, y as usize), at(x, y), "({}, {}) of {}x{}", x, y, w, h);
                if x + 1 < w && y + 1 < h {
                    let want = [at(x, y), at(x + 1, y), at(x, y + 1), at(x + 1, y + 1)];
                    prop_assert_eq!(b.quad(x as usize, y as usize), want, "quad ({}, {}) of {}x{}", x, y, w, h);
                }
            }
        }
        Ok(())
    }

    proptest! {
        /// Every texel and every interior 2×2 footprint is the one a row-major array holds.
        #[test]
        fn blocked_equals_row_major(w in 1u32..40, h in 1u32..40, seed in any::<u32>()) {
            let hash = |x: u32, y: u32| (x.wrapping_mul(0x9E37_79B9) ^ y.wrapping_mul(0x85EB_CA6B) ^ seed).wrapping_mul(0xC2B2_AE35);
            check::<Rgba8x4x4>(w, h, |x, y| hash(x, y).to_le_bytes())?;
        }
    }
}
