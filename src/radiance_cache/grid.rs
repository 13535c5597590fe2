//! Records on an image grid for photon rays with wide kernels (rs-rc's wide caustic photons): such a
//! ray is splatted onto one record per grid node (the node pixel's first eye sample) instead of
//! every eye sample, and a pixel between nodes takes the bilinear interpolation of its nodes'
//! coefficients. The light of a kernel `R` pixels wide varies on the scale of `R` pixels, so nodes
//! `R/4` pixels apart resolve it; spacing 1 is a record at every pixel.
//!
//! Interpolation never crosses a discontinuity: a pixel whose nodes are not all on its surface
//! (another segment of [`crate::radiance_filter::segment`], a normal beyond
//! [`SAME_SURFACE_COS`], or a first eye sample farther than [`NODE_REACH`] pixel widths per pixel
//! of image distance: a grazing view, or a view through a lens) gets a record of its own. The eye
//! samples off their pixel's surface (`own`) get records at their own position, as with the cache.

use crate::eye::EyePass;
use crate::photon::PhotonRay;
use crate::radiance_map::{Encoder, SAME_SURFACE_COS};
use crate::sh;
use crate::splat::records::splat_records_grouped;
use glam::Vec3;
use rayon::prelude::*;

/// Records are splatted in image blocks of this many pixels square (one tree per block).
const BLOCK: usize = 64;
/// A node's first eye sample may lie at most this many pixel widths (at the pixel's first sample,
/// seen directly) per pixel of image distance plus one from the pixel's (jitter puts a pixel's first
/// sample anywhere in the pixel). 8 accepts the pairs on one smooth surface (ratio 0.5–4 on
/// cornell-glossy) and rejects views through a lens and grazing views, which lie beyond it.
const NODE_REACH: f32 = 8.0;

/// What the cache knows of the image: per pixel its first eye sample (`u32::MAX`: none), its
/// segment label (`u32::MAX`: none) and that sample's normal (zero where none).
pub(super) struct ImageSurface<'a> {
    pub eye: &'a EyePass,
    pub first: &'a [u32],
    pub label: &'a [u32],
    pub normal: &'a [Vec3],
    pub pixel_size: &'a (dyn Fn(Vec3) -> f32 + Sync),
}

impl ImageSurface<'_> {
    /// Pixel `q`'s grid nodes at `spacing` with their bilinear weights (zero weights left out),
    /// or `None` when `q` must be a record itself (a node, or a pixel its nodes do not share).
    ///
    /// Pixel `q` may take node `n`'s coefficients when `n`'s first eye sample is on `q`'s segment,
    /// its normal within [`SAME_SURFACE_COS`] of `q`'s first sample's, and it lies within
    /// [`NODE_REACH`] pixel widths per pixel of image distance plus one of it.
    fn nodes(&self, q: usize, spacing: usize) -> Option<[(usize, f32); 4]> {
        let (w, h) = (self.eye.width as usize, self.eye.height as usize);
        if self.first[q] == u32::MAX || self.label[q] == u32::MAX {
            return None;
        }
        let (x, y) = (q % w, q / w);
        let (x0, y0) = (x / spacing * spacing, y / spacing * spacing);
        if (x0, y0) == (x, y) {
            return None;
        }
        // q's first sample's position, decoded once for its four nodes (the normals are decoded
        // once per pixel, in `normal`)
        let a = &self.eye.samples[self.first[q] as usize];
        let (pa, na) = (a.pos(), self.normal[q]);
        let px = (self.pixel_size)(pa);
        let (fx, fy) = ((x - x0) as f32 / spacing as f32, (y - y0) as f32 / spacing as f32);
        let mut out = [(0usize, 0.0f32); 4];
        for (k, (dx, dy)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
            let wt = (if dx == 0 { 1.0 - fx } else { fx }) * (if dy == 0 { 1.0 - fy } else { fy });
            if wt == 0.0 {
                continue;
            }
            let (nx, ny) = (x0 + dx * spacing, y0 + dy * spacing);
            if nx >= w || ny >= h {
                return None;
            }
            let n = ny * w + nx;
            let fn_ = self.first[n];
            if fn_ == u32::MAX || self.label[n] != self.label[q] {
                return None;
            }
            let b = &self.eye.samples[fn_ as usize];
            let reach = NODE_REACH * ((nx.abs_diff(x)).max(ny.abs_diff(y)) + 1) as f32 * px;
            if na.dot(self.normal[n]) < SAME_SURFACE_COS || (pa - b.pos()).length() > reach {
                return None;
            }
            out[k] = (n, wt);
        }
        Some(out)
    }
}

/// One grid's splatted records: per pixel its grid nodes (`None`: a record itself, or no
/// sample), per pixel its record slot (`u32::MAX`: none), and `sh::N` coefficients per record.
struct GridSplat {
    nodes: Vec<Option<[(usize, f32); 4]>>,
    slot: Vec<u32>,
    coeffs: Vec<Vec3>,
    /// Per record: whether any ray reached it (away from the caustic a grid stays dark, and its
    /// zero coefficients need not be added to the pixels there).
    lit: Vec<bool>,
}

/// Every grid's records, splatted ([`splat_grids`]); [`Grids::add_row`] adds them to one image
/// row's coefficients.
pub(super) struct Grids {
    grids: Vec<GridSplat>,
    width: usize,
    pub pairs: u64,
    /// Records splatted onto (pixels and off-surface samples), over all grids.
    pub records: usize,
}

impl Grids {
    /// Adds every grid's light to the coefficients `row` of image row `y` (records directly, the
    /// other pixels interpolated between their nodes), grid after grid.
    pub(super) fn add_row(&self, y: usize, row: &mut [[Vec3; sh::N]]) {
        for (x, acc) in row.iter_mut().enumerate() {
            self.add_pixel(y * self.width + x, acc);
        }
    }

    /// Adds every grid's light to pixel `q`'s coefficients `acc`.
    #[inline]
    pub(super) fn add_pixel(&self, q: usize, acc: &mut [Vec3; sh::N]) {
        for g in &self.grids {
            // record `j`'s coefficients × `wt`, if any ray reached it
            let add = |acc: &mut [Vec3; sh::N], j: usize, wt: f32| {
                if g.lit[j] {
                    super::add_scaled(acc, &g.coeffs[j * sh::N..(j + 1) * sh::N], wt);
                }
            };
            match (g.slot[q], g.nodes[q]) {
                (j, _) if j != u32::MAX => add(acc, j as usize, 1.0),
                (_, Some(ns)) => {
                    for (nd, wt) in ns.into_iter().filter(|&(_, wt)| wt > 0.0) {
                        add(acc, g.slot[nd] as usize, wt);
                    }
                }
                _ => {}
            }
        }
    }
}

/// Splats each set of photon rays `sets` (`(rays, spacing)`) onto its grid's records and the
/// off-surface samples `own`, adding the latter's light to `own_coeffs` (`sh::N` per sample of
/// `own`); the pixels' share is added row by row with [`Grids::add_row`].
pub(super) fn splat_grids(
    img: &ImageSurface,
    own: &[u32],
    sets: &[(&[PhotonRay], usize)],
    own_coeffs: &mut [Vec3],
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Option<Grids> {
    let eye = img.eye;
    let (w, n) = (eye.width as usize, (eye.width * eye.height) as usize);
    let block = |q: usize| (((q / w) / BLOCK) * w.div_ceil(BLOCK) + (q % w) / BLOCK) as u32;
    let mut out = Grids { grids: Vec::new(), width: w, pairs: 0, records: 0 };
    for &(rays, spacing) in sets.iter().filter(|(r, _)| !r.is_empty()) {
        let spacing = spacing.max(1);
        let nodes: Vec<Option<[(usize, f32); 4]>> = (0..n).into_par_iter().map(|q| img.nodes(q, spacing)).collect();
        // record pixels: pixels with a sample that interpolate nothing
        let px: Vec<usize> = (0..n).filter(|&q| img.first[q] != u32::MAX && nodes[q].is_none()).collect();
        let mut slot = vec![u32::MAX; n];
        for (j, &q) in px.iter().enumerate() {
            slot[q] = j as u32;
        }
        let at = px.iter().map(|&q| img.first[q] as usize).chain(own.iter().map(|&i| i as usize));
        let (pts, nrm): (Vec<Vec3>, Vec<Vec3>) = at.map(|i| (eye.samples[i].pos(), eye.samples[i].normal())).unzip();
        let group: Vec<u32> = px.iter().map(|&q| block(q)).chain(own.iter().map(|&i| block(eye.samples[i as usize].pixel as usize))).collect();
        let mut res = splat_records_grouped(&pts, &nrm, &group, &[rays], Encoder::Sh, cancelled)?;
        out.pairs += res.pairs;
        out.records += pts.len();
        for (a, c) in own_coeffs.iter_mut().zip(&res.coeffs[px.len() * sh::N..]) {
            *a += *c;
        }
        res.coeffs.truncate(px.len() * sh::N);
        let lit = res.coeffs.par_chunks(sh::N).map(|c| c.iter().any(|v| *v != Vec3::ZERO)).collect();
        out.grids.push(GridSplat { nodes, slot, coeffs: res.coeffs, lit });
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::super::{render, CacheParams, Integrated, View};
    use crate::eye::{EyePass, EyeSample, NO_GLOSSY};
    use crate::photon::PhotonRay;
    use crate::sampling::{hash, oct_encode, Rng};
    use glam::Vec3;

    const PITCH: f32 = 0.05;

    const W: usize = 41;

    /// A 41 × 25 image of one Lambertian eye sample per pixel on the plane z = 0, except the left
    /// `far_cols` columns, which see a plane 1.5 further away (a depth discontinuity).
    fn image(far_cols: u32) -> EyePass {
        let (w, h) = (W as u32, 25u32);
        let z = |p: u32| if p % w < far_cols { -1.5 } else { 0.0 };
        let samples = (0..w * h).map(|p| EyeSample { p: [(p % w) as f32 * PITCH, (p / w) as f32 * PITCH, z(p)], n: oct_encode(Vec3::Z), weight: [1.0; 3], pixel: p, glossy: NO_GLOSSY }).collect();
        let mut eye = EyePass::of_samples(w, h, samples, Default::default());
        eye.depth = (0..w * h).map(|p| 1.0 - z(p)).collect();
        eye.normal = vec![Vec3::Z; (w * h) as usize];
        eye
    }

    /// Photon rays falling onto z = 0 with kernels 8–12 pixels wide, landing right of `x_min`.
    fn rays(x_min: f32) -> Vec<PhotonRay> {
        (0..4000)
            .map(|i| {
                let mut r = Rng::new(hash(&[41, i as u64]), 0);
                let target = Vec3::new(x_min + r.next_f32() * (2.0 - x_min), r.next_f32() * 1.2, 0.0);
                let d = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, -1.0).normalize();
                let len = 0.5 + r.next_f32();
                let mut ray = PhotonRay::new(target - d * len, d, len, Vec3::new(1.0, 0.5, 0.2) * (0.5 + r.next_f32()), -Vec3::Z, Vec3::Z);
                (ray.h0, ray.dh) = (PITCH * (8.0 + 4.0 * r.next_f32()), 0.0);
                ray
            })
            .collect()
    }

    fn radiance(eye: &EyePass, rays: &[PhotonRay], spacing: usize) -> (Vec<Vec3>, usize) {
        let tables = crate::radiance_map::ShTables::build(&eye.glossy);
        let out = render(eye, &[], &[(rays, spacing)], &View { pixel_size: &|_| PITCH, raster: &|_| None }, &CacheParams::default(), &Integrated { tables: &tables, cached: &[] }, &|| false).unwrap();
        (out.radiance, out.grid_records)
    }

    /// On one surface, records 2 pixels apart (a quarter of the kernels' smallest radius) give what
    /// a record at every pixel gives: exactly at the nodes, within interpolation error between them.
    #[test]
    fn grid_interpolates_what_every_pixel_receives() {
        let eye = image(0);
        let rays = rays(0.0);
        let ((fine, n1), (coarse, n2)) = (radiance(&eye, &rays, 1), radiance(&eye, &rays, 2));
        assert_eq!(n1, 41 * 25);
        assert_eq!(n2, 21 * 13, "one record per node, none for the other pixels");
        let (mut worst, mut sum) = (0.0f32, 0.0f32);
        for (q, (a, b)) in coarse.iter().zip(&fine).enumerate() {
            assert!(b.x > 0.0, "pixel {q} unlit");
            let rel = ((*a - *b).abs() / *b).max_element();
            if (q % W) % 2 == 0 && (q / W) % 2 == 0 {
                assert!(rel < 1e-5, "node {q}: {a} vs {b}");
            }
            worst = worst.max(rel);
            sum += rel;
        }
        let mean = sum / coarse.len() as f32;
        assert!(mean < 0.01 && worst < 0.05, "interpolation error: mean {mean}, worst {worst}");
    }

    /// Pixels never interpolate across a depth discontinuity: the far plane, which no photon
    /// reaches, stays dark next to the lit near plane, and the near plane's pixels at the edge get
    /// records of their own (they equal a record at every pixel there).
    #[test]
    fn grid_does_not_interpolate_across_discontinuities() {
        let eye = image(13); // the edge between columns 12 and 13, between grid nodes
        let rays = rays(0.9);
        let ((fine, _), (coarse, n2)) = (radiance(&eye, &rays, 1), radiance(&eye, &rays, 4));
        assert!(n2 > 11 * 7 && n2 < 41 * 25 / 2, "nodes plus the edge's pixels: {n2}");
        for (q, (a, b)) in coarse.iter().zip(&fine).enumerate() {
            let x = q % W;
            if x < 13 {
                assert_eq!(*a, Vec3::ZERO, "far pixel {q} received light");
                assert_eq!(*b, Vec3::ZERO);
            } else if x < 16 {
                assert!(b.x > 0.0 && ((*a - *b).abs() / *b).max_element() < 1e-5, "edge pixel {q}: {a} vs {b}");
            }
        }
    }
}
