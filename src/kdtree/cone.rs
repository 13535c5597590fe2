//! The photon-ray splatting query: all points inside a cone frustum around a segment (Algorithm 1 of
//! the splatting paper §7.2), with the hemisphere cap beyond the photon hit (§5) and backface culling.

use glam::{Vec3, Vec4};

use super::{lanes_left, KdTree, Lanes, MAX_DEPTH};

/// Relative padding of the virtual-plane tests, covering the rounding of the interval arithmetic.
const PAD: f32 = 8.0 * f32::EPSILON;

/// A photon ray with its splat footprint: the segment `origin + t·dir`, `t ∈ [0, t_max]`, whose
/// radius grows linearly, `h(t) = h0 + dh·t`.
///
/// A point `p` with projection `t = dot(p − origin, dir)` and perpendicular squared distance
/// `dist2 = |p − origin − t·dir|²` is inside when
/// - `0 ≤ t ≤ t_max` and `dist2 < h(t)²` (the cone frustum), or
/// - with `hemisphere_cap`, `t > t_max` and `|p − hit|² < h(t_max)²` where `hit = origin + t_max·dir`:
///   beyond the photon hit the footprint is a half ball (splatting §5, Fig. 4).
///
/// The radius must not be negative where it matters: points where `h(t) ≤ 0` are outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Start of the photon ray (the previous path vertex).
    pub origin: Vec3,
    /// Direction; must be unit length (the constructors normalise it) or zero (which makes the
    /// query a ball of radius `h0` around `origin`).
    pub dir: Vec3,
    /// Length of the segment, ≥ 0 (the photon hit is at `t_max`; a negative or NaN length makes
    /// the region empty).
    pub t_max: f32,
    /// Radius at `t = 0`.
    pub h0: f32,
    /// Radius growth per unit length (the paper's `dh ≥ 0`; negative values are allowed).
    pub dh: f32,
    /// Extend the footprint past the hit by a half ball of radius `h(t_max)`.
    pub hemisphere_cap: bool,
    /// Skip subtrees behind backface-culling nodes that face away from the ray (no effect on a tree
    /// built without normals). The leaf callback still has to test each point itself.
    pub backface_cull: bool,
}

impl Cone {
    /// A cone frustum with the given start radius and growth, without cap, with backface culling.
    pub fn new(origin: Vec3, dir: Vec3, t_max: f32, h0: f32, dh: f32) -> Cone {
        Cone { origin, dir: dir.normalize_or_zero(), t_max, h0, dh, hemisphere_cap: false, backface_cull: true }
    }

    /// The frustum of a photon ray from `from` (bandwidth `h_from`) to its hit `to` (bandwidth
    /// `h_to`), as splatting §6 defines it: `h0 = min(h_from, h_to)`,
    /// `dh = max(0, h_to − h_from) / |to − from|`, with the hemisphere cap.
    pub fn photon_ray(from: Vec3, to: Vec3, h_from: f32, h_to: f32) -> Cone {
        let len = (to - from).length();
        let dh = if len > 0.0 { (h_to - h_from).max(0.0) / len } else { 0.0 };
        Cone::new(from, to - from, len, h_from.min(h_to), dh).with_hemisphere_cap(true)
    }

    /// Sets [`hemisphere_cap`](Self::hemisphere_cap).
    pub fn with_hemisphere_cap(mut self, cap: bool) -> Cone {
        self.hemisphere_cap = cap;
        self
    }

    /// Sets [`backface_cull`](Self::backface_cull).
    pub fn with_backface_cull(mut self, cull: bool) -> Cone {
        self.backface_cull = cull;
        self
    }

    /// The radius `h(t)`.
    #[inline]
    pub fn radius_at(&self, t: f32) -> f32 {
        self.h0 + self.dh * t
    }

    /// The photon hit `origin + t_max·dir`.
    #[inline]
    pub fn hit_point(&self) -> Vec3 {
        self.origin + self.dir * self.t_max
    }

    /// The exact membership test the traversal applies to every candidate: `Some((t, dist2_perp))`
    /// when `p` is inside (see the type doc), else `None`.
    #[inline]
    pub fn test(&self, p: Vec3) -> Option<(f32, f32)> {
        let v = p - self.origin;
        let t = v.dot(self.dir);
        if !(t >= 0.0) {
            return None;
        }
        let d2 = (v - self.dir * t).length_squared();
        if t <= self.t_max {
            let h = self.radius_at(t);
            (h > 0.0 && d2 < h * h).then_some((t, d2))
        } else if self.hemisphere_cap && self.t_max >= 0.0 {
            let h = self.radius_at(self.t_max);
            (h > 0.0 && (p - self.hit_point()).length_squared() < h * h).then_some((t, d2))
        } else {
            None
        }
    }

    /// The largest radius over `[t0, t1] ∩ [0, t_max]` (the cap never exceeds `h(t_max)`), ≥ 0.
    #[inline(always)]
    fn radius_bound(&self, t0: f32, t1: f32) -> f32 {
        let t = if self.dh >= 0.0 { t1 } else { t0 };
        self.radius_at(t.clamp(0.0, self.t_max.max(0.0))).max(0.0)
    }
}

/// [`Cone::test`] for four points at a time (over a tree's coordinate lanes), with the same
/// operations in the same order: the same `t`, `dist2` and memberships, bit for bit.
struct ConeLanes {
    o: [Vec4; 3],
    d: [Vec4; 3],
    h0: Vec4,
    dh: Vec4,
    t_max: Vec4,
    /// `Some((hit, h(t_max)²))` when the hemisphere cap is on and not empty.
    cap: Option<([Vec4; 3], Vec4)>,
}

impl ConeLanes {
    fn new(c: &Cone) -> ConeLanes {
        let hc = c.radius_at(c.t_max);
        let cap = (c.hemisphere_cap && c.t_max >= 0.0 && hc > 0.0).then(|| (Lanes::splat(c.hit_point()), Vec4::splat(hc * hc)));
        ConeLanes { o: Lanes::splat(c.origin), d: Lanes::splat(c.dir), h0: Vec4::splat(c.h0), dh: Vec4::splat(c.dh), t_max: Vec4::splat(c.t_max), cap }
    }

    /// The lanes inside the cone (bit `i` for point `i`), and every point's `t` and `dist2`.
    #[inline(always)]
    fn test(&self, [x, y, z]: [Vec4; 3]) -> (u32, Vec4, Vec4) {
        let (o, d) = (self.o, self.d);
        let (px, py, pz) = (x - o[0], y - o[1], z - o[2]);
        let t = px * d[0] + py * d[1] + pz * d[2];
        let (qx, qy, qz) = (px - d[0] * t, py - d[1] * t, pz - d[2] * t);
        let d2 = qx * qx + qy * qy + qz * qz;
        let h = self.h0 + self.dh * t;
        let mut mask = (t.cmpge(Vec4::ZERO) & t.cmple(self.t_max) & h.cmpgt(Vec4::ZERO) & d2.cmplt(h * h)).bitmask();
        if let Some((hit, hc2)) = self.cap {
            let (cx, cy, cz) = (x - hit[0], y - hit[1], z - hit[2]);
            mask |= (t.cmpgt(self.t_max) & (cx * cx + cy * cy + cz * cz).cmplt(hc2)).bitmask();
        }
        (mask, t, d2)
    }
}

/// The splatting paper's front-facing test for an eye sample with normal `normal` and a photon ray
/// with direction `dir`: `dot(normal, dir) < 0`. Backface culling never skips a point for which
/// this holds (nor a grazing one, `dot = 0`).
#[inline]
pub fn is_front_facing(normal: Vec3, dir: Vec3) -> bool {
    normal.dot(dir) < 0.0
}

/// The splatting paper's third feasibility test: `p` lies in front of the surface at the photon
/// ray's origin (`dot(p − origin, origin_normal) > 0`).
#[inline]
pub fn is_in_front_of_surface(p: Vec3, origin: Vec3, origin_normal: Vec3) -> bool {
    (p - origin).dot(origin_normal) > 0.0
}

impl KdTree {
    /// Calls `f(index, t, dist2_perp)` for every point inside `cone` (see [`Cone`]), in traversal
    /// order, skipping subtrees whose normals all face away from the ray when `cone.backface_cull`.
    ///
    /// The traversal is Algorithm 1: the ray interval `[t0, t1]` is clipped by each splitting plane
    /// moved by the largest splat radius over the interval to either side (the virtual planes).
    pub fn for_each_in_cone(&self, cone: &Cone, mut f: impl FnMut(u32, f32, f32)) {
        if self.is_empty() || !(cone.t_max >= 0.0) {
            return;
        }
        let (o, d) = (cone.origin, cone.dir);
        let cap = if cone.hemisphere_cap { cone.radius_at(cone.t_max).max(0.0) } else { 0.0 };
        let t_end = cone.t_max + cap;
        // Per-axis reciprocal; an axis the ray is (numerically) parallel to is handled apart.
        let parallel = d.abs().cmplt(Vec3::splat(1e-30));
        let inv = Vec3::ONE / d;

        // Clip [0, t_end] by the root cell grown by the largest radius.
        let r = cone.radius_bound(0.0, t_end);
        let (lo, hi) = self.bounds;
        let mut t0 = 0.0f32;
        let mut t1 = t_end;
        for a in 0..3 {
            let pad = r + PAD * (lo[a].abs().max(hi[a].abs()) + o[a].abs() + r);
            let (l, h) = (lo[a] - pad, hi[a] + pad);
            if parallel.test(a) {
                if !(o[a] >= l && o[a] <= h) {
                    return;
                }
            } else {
                let (ta, tb) = ((l - o[a]) * inv[a], (h - o[a]) * inv[a]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if !(t0 <= t1) {
            return;
        }

        let cull_dir = if cone.backface_cull { d } else { Vec3::ZERO };
        // Per-cone constants, as arrays indexed by the split axis (a `Vec3` index is a match):
        // the origin, the reciprocal direction, the sign of the direction, whether the ray is
        // parallel to the axis, and a padding bound that holds for every split plane in the tree
        // (they lie within the root bounds) and every radius of this cone.
        let r_all = cone.radius_bound(0.0, t_end);
        let oa_ = o.to_array();
        let inv_ = inv.to_array();
        let pos_ = [d.x > 0.0, d.y > 0.0, d.z > 0.0];
        let par_ = [parallel.x, parallel.y, parallel.z];
        let pad_ = [0, 1, 2].map(|a| PAD * (lo[a].abs().max(hi[a].abs()) + o[a].abs() + r_all));
        let (h0, dh, t_cap) = (cone.h0, cone.dh, cone.t_max.max(0.0));
        let lanes = ConeLanes::new(cone);
        let mut stack = [(0u32, 0f32, 0f32); MAX_DEPTH];
        let mut sp = 0;
        let mut node = 0usize;
        loop {
            let n = self.nodes[node];
            if n.is_interior() {
                let (a, s) = (n.axis(), n.split());
                // The largest radius over [t0, t1] ∩ [0, t_max] (`Cone::radius_bound`).
                // (t0 ≥ 0 always; `min` rather than `clamp`, which checks its bounds.)
                let r = (h0 + dh * (if dh >= 0.0 { t1 } else { t0 }).min(t_cap)).max(0.0);
                let oa = oa_[a];
                let rp = r + pad_[a];
                let far = node + n.right_offset() as usize;
                // Intervals of the left child (coordinates ≤ s) and the right child (≥ s).
                let (l0, l1, r0, r1);
                if par_[a] {
                    let go_left = oa - rp <= s;
                    let go_right = oa + rp >= s;
                    (l0, l1) = if go_left { (t0, t1) } else { (1.0, 0.0) };
                    (r0, r1) = if go_right { (t0, t1) } else { (1.0, 0.0) };
                } else {
                    // The ray crosses the virtual planes s − r and s + r at t_alpha and t_beta.
                    let t_alpha = (s - rp - oa) * inv_[a];
                    let t_beta = (s + rp - oa) * inv_[a];
                    if pos_[a] {
                        (l0, l1) = (t0, t1.min(t_beta));
                        (r0, r1) = (t0.max(t_alpha), t1);
                    } else {
                        (l0, l1) = (t0.max(t_beta), t1);
                        (r0, r1) = (t0, t1.min(t_alpha));
                    }
                }
                let go_left = l0 <= l1;
                let go_right = r0 <= r1;
                if go_left {
                    if go_right {
                        stack[sp] = (far as u32, r0, r1);
                        sp += 1;
                    }
                    node += 1;
                    (t0, t1) = (l0, l1);
                    continue;
                } else if go_right {
                    node = far;
                    (t0, t1) = (r0, r1);
                    continue;
                }
            } else if n.is_leaf() {
                let (first, count) = (n.leaf_first() as usize, n.leaf_count() as usize);
                for j in (first..first + count).step_by(4) {
                    let (mask, t, d2) = lanes.test(self.lanes.at(j));
                    let mut mask = mask & lanes_left(first + count - j);
                    while mask != 0 {
                        let b = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        f(self.entries[j + b].index, t[b], d2[b]);
                    }
                }
            } else if n.is_cull() && !(cull_dir.dot(n.cull_normal()) > n.cull_cmax()) {
                // Not every normal below faces away from the ray: descend.
                node += 1;
                continue;
            }
            if sp == 0 {
                return;
            }
            sp -= 1;
            let (next, a, b) = stack[sp];
            node = next as usize;
            (t0, t1) = (a, b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The size of the paper's footprint on a plane, against a ball of the same radius at the hit
    /// (the spherical search the splatting paper's §9 compares with): a photon arriving at θ from
    /// the normal finds the half ellipse (h, h/cos θ) before the hit and the cap's half disc after
    /// it, `(1 + 1/cos θ)/2` times the ball's disc. Averaged over cosine-distributed arrivals
    /// (diffuse interreflection: s = sin²θ uniform, E[1/cos θ] = ∫₀¹ (1 − s)^(−1/2) ds = 2) that
    /// is 1.5 — the floor of the cone/sphere cost ratio `raysplat-bench photons` prints,
    /// for a traversal as cheap per point as the spherical one.
    #[test]
    fn paper_footprint_on_a_plane_holds_half_an_ellipse_and_half_a_disc() {
        let (h, step) = (0.1f32, 0.002f32);
        let n = (1.2 / step) as i32;
        let grid: Vec<Vec3> = (-n..=n).flat_map(|i| (-n..=n).map(move |j| Vec3::new(i as f32 * step, j as f32 * step, 0.0))).collect();
        let cell = step * step;
        for deg in [10.0f32, 30.0, 45.0, 60.0, 75.0, 80.0] {
            let th = deg.to_radians();
            // arriving from above, tilted along +x, hitting the origin from 2 units away
            let dir = Vec3::new(th.sin(), 0.0, -th.cos());
            let cone = Cone::new(-2.0 * dir, dir, 2.0, h, 0.0).with_hemisphere_cap(true).with_backface_cull(false);
            let (mut before, mut after, mut ball) = (0usize, 0usize, 0usize);
            for &p in &grid {
                if let Some((t, _)) = cone.test(p) {
                    if t <= cone.t_max { before += 1 } else { after += 1 }
                }
                ball += (p.length_squared() < h * h) as usize;
            }
            let disc = std::f32::consts::PI * h * h;
            let (b, a) = (before as f32 * cell, after as f32 * cell);
            assert!((b / (disc / 2.0 / th.cos()) - 1.0).abs() < 0.02, "θ = {deg}°: before the hit {b}, half ellipse {}", disc / 2.0 / th.cos());
            assert!((a / (disc / 2.0) - 1.0).abs() < 0.02, "θ = {deg}°: beyond the hit {a}, half disc {}", disc / 2.0);
            let ratio = (before + after) as f32 / ball as f32;
            assert!((ratio - (1.0 + 1.0 / th.cos()) / 2.0).abs() < 0.03 * ratio, "θ = {deg}°: footprint/ball {ratio}");
        }
    }
}
