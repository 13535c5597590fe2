//! Which photon rays can splat onto an eye pass: the boxes of its eye samples per image tile,
//! grouped in blocks of tiles, tested against a ray's footprint exactly as the splat rejects a
//! tile. The light pass keeps a ray that leaves the scene only where it passes the eye samples
//! (most such rays go to the sky, far from any).

use super::{misses_box, Footprint, TILE};
use crate::eye::EyePass;
use crate::photon::PhotonRay;
use glam::Vec3;

/// Tiles per side of a block (a block's box is tested before its tiles').
const BLOCK: u32 = 8;

/// The eye samples' boxes: all of them, per block of tiles and per tile.
#[derive(Debug)]
pub struct Reach {
    all: (Vec3, Vec3),
    /// Per block: its box and its tiles' range in `tiles`.
    blocks: Vec<(Vec3, Vec3, std::ops::Range<usize>)>,
    tiles: Vec<(Vec3, Vec3)>,
}

fn empty() -> (Vec3, Vec3) {
    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY))
}

fn grow(b: &mut (Vec3, Vec3), lo: Vec3, hi: Vec3) {
    b.0 = b.0.min(lo);
    b.1 = b.1.max(hi);
}

impl Reach {
    /// The boxes of `eye`'s samples.
    pub fn of(eye: &EyePass) -> Reach {
        let tx = eye.width.div_ceil(TILE).max(1);
        let ty = eye.height.div_ceil(TILE).max(1);
        let mut per_tile = vec![empty(); (tx * ty) as usize];
        for s in &eye.samples {
            let (x, y) = (s.pixel % eye.width.max(1), s.pixel / eye.width.max(1));
            let t = ((y / TILE).min(ty - 1) * tx + (x / TILE).min(tx - 1)) as usize;
            let p = s.pos();
            grow(&mut per_tile[t], p, p);
        }
        let (bx, by) = (tx.div_ceil(BLOCK), ty.div_ceil(BLOCK));
        let (mut all, mut blocks, mut tiles) = (empty(), Vec::new(), Vec::new());
        for j in 0..by {
            for i in 0..bx {
                let (first, mut b) = (tiles.len(), empty());
                for y in j * BLOCK..((j + 1) * BLOCK).min(ty) {
                    for x in i * BLOCK..((i + 1) * BLOCK).min(tx) {
                        let t = per_tile[(y * tx + x) as usize];
                        if t.0.cmple(t.1).all() {
                            grow(&mut b, t.0, t.1);
                            tiles.push(t);
                        }
                    }
                }
                if tiles.len() > first {
                    grow(&mut all, b.0, b.1);
                    blocks.push((b.0, b.1, first..tiles.len()));
                }
            }
        }
        Reach { all, blocks, tiles }
    }

    /// Whether `r` can splat onto any of the eye samples: its footprint meets a tile's box.
    pub fn reaches(&self, r: &PhotonRay) -> bool {
        let Some(fp) = Footprint::of(r) else { return false };
        let misses = |b: &(Vec3, Vec3)| misses_box(&fp.cone, fp.rmax, b.0, b.1);
        if self.blocks.is_empty() || misses(&self.all) {
            return false;
        }
        self.blocks.iter().any(|(lo, hi, range)| !misses(&(*lo, *hi)) && self.tiles[range.clone()].iter().any(|t| !misses(t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eye::{EyeSample, GlossyTable, NO_GLOSSY};
    use crate::kdtree::{BuildParams, KdTree};
    use crate::sampling::{hash, oct_encode, Rng};

    /// Against brute force: eye samples on three walls of a unit box, spread over the tiles of a
    /// 100×80 image, and random photon rays (many passing outside the box, some grazing, some long
    /// beyond their hit): every ray that splats onto at least one sample (the splat's own query over
    /// all samples) is one that `reaches` says can; most that miss are told so.
    #[test]
    fn every_ray_that_splats_onto_a_sample_reaches_it() {
        let mut r = Rng::new(hash(&[77]), 0);
        let (w, h) = (100u32, 80u32);
        let mut samples = Vec::new();
        for i in 0..3000u32 {
            let (a, b) = (r.next_f32(), r.next_f32());
            let (p, n) = match i % 3 {
                0 => (Vec3::new(a, b, 0.0), Vec3::Z),
                1 => (Vec3::new(0.0, a, b), Vec3::X),
                _ => (Vec3::new(a, 0.0, b), Vec3::Y),
            };
            // a sample's pixel follows its place on its wall, as an image's would
            let pixel = ((b * h as f32) as u32).min(h - 1) * w + ((a * w as f32) as u32).min(w - 1);
            samples.push(EyeSample { p: p.to_array(), n: oct_encode(n), weight: [1.0; 3], pixel, glossy: NO_GLOSSY });
        }
        let pts: Vec<Vec3> = samples.iter().map(|s| s.pos()).collect();
        let nrm: Vec<Vec3> = samples.iter().map(|s| s.normal()).collect();
        let tree = KdTree::build(&pts, &BuildParams::default()).expect("tree");
        let reach = Reach::of(&EyePass::of_samples(w, h, samples, GlossyTable::default()));
        let (mut splatting, mut missing, mut told) = (0, 0, 0);
        for _ in 0..20_000 {
            let o = Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 3.0 - Vec3::splat(1.0);
            let target = Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 1.6 - Vec3::splat(0.3);
            let dir = (target - o).normalize();
            let length = (target - o).length() * (0.5 + r.next_f32());
            let n_hit = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5).normalize();
            let mut ray = PhotonRay::new(o, dir, length, Vec3::ONE, dir, -n_hit * n_hit.dot(dir).signum());
            (ray.h0, ray.dh) = (0.02 * r.next_f32(), 0.1 * r.next_f32() / length);
            let mut splats = false;
            super::super::for_each_splat(&ray, &tree, &pts, &nrm, |_, _, _, _, _, _| splats = true);
            if splats {
                splatting += 1;
                assert!(reach.reaches(&ray), "a ray that splats is not reached: {ray:?}");
            } else {
                missing += 1;
                told += !reach.reaches(&ray) as usize;
            }
        }
        assert!(splatting > 2000 && missing > 2000, "{splatting} rays splat, {missing} do not");
        assert!(told > missing / 4, "{told} of {missing} rays that splat nothing are told they cannot");
    }
}
