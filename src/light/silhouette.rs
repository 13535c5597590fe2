//! Where photons from infinite lights (distant, dome) start: uniformly over the silhouette of the
//! scene's bounding box seen along the travel direction, not over the disc of its bounding sphere.
//!
//! A ray of direction `d` that misses the box's silhouette misses every surface, so emitting only
//! through the silhouette is unbiased, and it wastes no photon on the parts of the disc the box does
//! not cover: that is 1 − A⊥/(πr²), from 26 % (a cube seen along its diagonal, the best case:
//! A⊥ = √3·a², πr² = 3π/4·a²) to almost 100 %
//! (a flat floor under a grazing sun; a long hall seen from its side). Crytek Sponza lost 46 % of its
//! emitted photon paths there.
//!
//! The silhouette of a box is tiled, without overlap, by the projections of the (up to three) faces
//! that face the light; a face of axis `k` projects with area `|d_k|·A_k`. Choosing a face in
//! proportion to that and a point uniformly on it gives a uniform density `1/A⊥` over the silhouette,
//! measured perpendicular to `d`. The point is then moved back along `d` to the plane at distance
//! `r` behind the centre, where pbrt's bounding-sphere disc starts photons: rays start outside
//! the scene, and the first segment's length (which enters the path density of the splatting
//! paper's Eq. 7) is distributed as from that disc.

use glam::{Vec2, Vec3};

/// The scene's bounding box, padded so that no extent is zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneBox {
    lo: Vec3,
    hi: Vec3,
    center: Vec3,
    radius: f32,
}

impl SceneBox {
    /// The box `[lo, hi]`, padded by 1e-4 of its diagonal on every side (a flat scene keeps a thin
    /// silhouette edge-on), by at least a few ulps of its coordinates and by at least 1e-15 (face
    /// areas stay normal floats).
    pub fn new(lo: Vec3, hi: Vec3) -> SceneBox {
        let (lo, hi) = if lo.cmple(hi).all() && lo.is_finite() && hi.is_finite() { (lo, hi) } else { (Vec3::ZERO, Vec3::ZERO) };
        let pad = (1e-4 * (hi - lo).length() + 4.0 * f32::EPSILON * lo.abs().max(hi.abs()).max_element()).max(1e-15);
        let (lo, hi) = (lo - Vec3::splat(pad), hi + Vec3::splat(pad));
        SceneBox { lo, hi, center: 0.5 * (lo + hi), radius: 0.5 * (hi - lo).length() }
    }

    pub fn center(&self) -> Vec3 {
        self.center
    }

    /// Radius of the bounding sphere around [`center`](Self::center).
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Projected areas of the faces of axes x, y, z seen along `d`.
    fn face_areas(&self, d: Vec3) -> [f32; 3] {
        let e = self.hi - self.lo;
        [d.x.abs() * e.y * e.z, d.y.abs() * e.x * e.z, d.z.abs() * e.x * e.y]
    }

    /// Area of the silhouette seen along the unit direction `d`.
    pub fn projected_area(&self, d: Vec3) -> f32 {
        let [a, b, c] = self.face_areas(d);
        a + b + c
    }

    /// The silhouette area averaged over all directions: a quarter of the surface area (Cauchy).
    pub fn mean_projected_area(&self) -> f32 {
        let e = self.hi - self.lo;
        0.5 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// A photon origin for travel direction `d` (unit): uniform over the silhouette (density
    /// `1 / projected_area(d)` perpendicular to `d`), on the plane at distance
    /// [`radius`](Self::radius) behind the centre.
    pub fn sample_origin(&self, d: Vec3, u: Vec2) -> Vec3 {
        let a = self.face_areas(d);
        let total = a[0] + a[1] + a[2];
        let mut x = u.x * total;
        let mut k = 2;
        for (i, &ai) in a.iter().enumerate().take(2) {
            if x < ai {
                k = i;
                break;
            }
            x -= ai;
        }
        let s = if a[k] > 0.0 { (x / a[k]).clamp(0.0, 1.0) } else { 0.5 };
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let mut p = self.lo;
        p[i] += s * (self.hi[i] - self.lo[i]);
        p[j] += u.y * (self.hi[j] - self.lo[j]);
        // The face the light enters through.
        p[k] = if d[k] > 0.0 { self.lo[k] } else { self.hi[k] };
        p - d * ((p - self.center).dot(d) + self.radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{square_to_uniform_disk_concentric, square_to_uniform_sphere, Frame, Rng};

    /// Entry `t` of the ray into the box, if it hits it.
    fn enters(b: &SceneBox, o: Vec3, d: Vec3) -> bool {
        let (t0, t1) = ((b.lo - o) / d, (b.hi - o) / d);
        let (near, far) = (t0.min(t1).max_element(), t0.max(t1).min_element());
        near <= far && far >= 0.0
    }

    /// Points from the silhouette sampler all enter the box, and averages over them agree with
    /// averages over the bounding-sphere disc's rays that enter it (pbrt's emission, restricted to
    /// the rays that matter): the density is uniform over the silhouette, and the fraction of disc
    /// rays that enter, times the disc's area, is the projected area.
    #[test]
    fn silhouette_sampling_is_uniform_over_the_rays_that_enter_the_box() {
        let mut rng = Rng::new(11, 0);
        for case in 0..12 {
            let ext = Vec3::new(0.2 + 3.0 * rng.next_f32(), if case % 4 == 0 { 0.0 } else { 0.1 + rng.next_f32() }, 0.3 + 2.0 * rng.next_f32());
            let lo = Vec3::new(rng.next_f32(), -rng.next_f32(), 5.0 * rng.next_f32());
            let b = SceneBox::new(lo, lo + ext);
            let d = square_to_uniform_sphere(rng.next_2d());
            let (c, r) = (b.center(), b.radius());
            let f = Frame::from_normal(d);
            // Test functions of the position across the beam.
            let g = |p: Vec3| {
                let q = p - c;
                [q.dot(f.s), q.dot(f.t), q.dot(f.s) * q.dot(f.t), q.dot(f.s).powi(2)]
            };
            let n = 200_000;
            let (mut new, mut old, mut hits) = ([0.0f64; 4], [0.0f64; 4], 0usize);
            for _ in 0..n {
                let o = b.sample_origin(d, rng.next_2d());
                assert!(enters(&b, o + d * 1e-3 * r, d), "case {case}: {o} misses the box along {d}");
                assert!(((o - c).dot(d) + r).abs() < 1e-4 * r, "case {case}: origin off the start plane");
                for (s, v) in new.iter_mut().zip(g(o)) {
                    *s += v as f64;
                }
                let q = square_to_uniform_disk_concentric(rng.next_2d()) * r;
                let o = c - d * r + f.s * q.x + f.t * q.y;
                if enters(&b, o, d) {
                    hits += 1;
                    for (s, v) in old.iter_mut().zip(g(o)) {
                        *s += v as f64;
                    }
                }
            }
            let area = std::f64::consts::PI * (r * r) as f64 * hits as f64 / n as f64;
            let want = b.projected_area(d) as f64;
            assert!((area / want - 1.0).abs() < 0.02, "case {case}: disc estimate {area} vs projected area {want}");
            for k in 0..4 {
                let (a, o) = (new[k] / n as f64, old[k] / hits as f64);
                let scale = (r * r) as f64;
                assert!((a - o).abs() < 0.02 * scale, "case {case}, moment {k}: {a} vs {o} (r = {r})");
            }
        }
    }

    #[test]
    fn mean_projected_area_is_the_average_over_directions() {
        let b = SceneBox::new(Vec3::ZERO, Vec3::new(1.0, 2.0, 0.5));
        let mut rng = Rng::new(3, 0);
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| b.projected_area(square_to_uniform_sphere(rng.next_2d())) as f64).sum::<f64>() / n as f64;
        assert!((mean / b.mean_projected_area() as f64 - 1.0).abs() < 0.01, "{mean} vs {}", b.mean_projected_area());
    }

    #[test]
    fn degenerate_boxes_stay_finite() {
        for (lo, hi) in [(Vec3::ZERO, Vec3::ZERO), (Vec3::ONE, Vec3::ZERO), (Vec3::splat(f32::NAN), Vec3::ONE), (Vec3::splat(1e4), Vec3::splat(1e4))] {
            let b = SceneBox::new(lo, hi);
            let o = b.sample_origin(Vec3::Y, Vec2::new(0.3, 0.7));
            assert!(o.is_finite() && b.projected_area(Vec3::Y) > 0.0 && b.radius() > 0.0, "{lo} {hi}: {b:?}");
        }
    }
}
