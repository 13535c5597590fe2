//! Histogram radiance map (§8.1): 20 directional strata, the Voronoi cells of the vertices of a
//! regular dodecahedron; a precomputed directional filter [Stü98] spreads each photon over
//! neighbouring strata with weights tabulated for `N_D` discrete photon directions (the cells of a
//! 32×32 octahedral map); glossy eye samples integrate the histogram by BSDF sampling.

use crate::eye::GlossyLobe;
use crate::sampling::{hash, Rng};
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Number of strata.
pub const STRATA: usize = 20;
/// Octahedral map resolution of the discrete photon directions (`N_D = RES²`).
pub const RES: usize = 32;
/// Strata a photon direction spreads to, at most.
pub const SPREAD: usize = 8;
/// Angular standard deviation of the directional filter (radians). Neighbouring strata centres are
/// 41.8° apart; at a stratum's centre each of its three neighbours receives ~11 %.
pub const SIGMA: f32 = 0.35;
/// Directions of the fine set used for the strata's solid angles above a surface.
const FINE: usize = 4096;

/// The strata, the filter table and a fine direction set labelled by stratum.
pub struct Strata {
    pub centres: [Vec3; STRATA],
    /// Per discrete direction: `(stratum, weight)` pairs, weights summing to one.
    pub filter: Vec<[(u8, f32); SPREAD]>,
    /// The fine direction set grouped by stratum (`fine[offsets[s]..offsets[s + 1]]`).
    fine: Vec<Vec3>,
    offsets: [usize; STRATA + 1],
}

/// A stratum lies entirely on one side of a plane through the origin when its centre is farther
/// than this (as a cosine to the plane's normal, `sin 37.38°` plus margin) from the plane: every
/// point of a cell is within 37.38° of its centre (the angle between a dodecahedron vertex and the
/// adjacent face centres).
const CELL_SIN_RADIUS: f32 = 0.62;

/// The 20 vertices of a regular dodecahedron, normalised.
pub fn dodecahedron() -> [Vec3; STRATA] {
    let p = (1.0 + 5.0f32.sqrt()) / 2.0;
    let ip = 1.0 / p;
    let mut v = Vec::with_capacity(STRATA);
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                v.push(Vec3::new(sx, sy, sz));
            }
        }
    }
    for a in [-1.0, 1.0] {
        for b in [-1.0, 1.0] {
            v.push(Vec3::new(0.0, a * ip, b * p));
            v.push(Vec3::new(a * ip, b * p, 0.0));
            v.push(Vec3::new(a * p, 0.0, b * ip));
        }
    }
    std::array::from_fn(|i| v[i].normalize())
}

/// Octahedral cell of a unit direction.
#[inline]
pub fn cell(d: Vec3) -> usize {
    let s = d.x.abs() + d.y.abs() + d.z.abs();
    let mut p = Vec2::new(d.x, d.y) / s;
    if d.z < 0.0 {
        p = (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * Vec2::new(p.x.signum(), p.y.signum());
    }
    let u = (((p.x + 1.0) * 0.5 * RES as f32) as usize).min(RES - 1);
    let v = (((p.y + 1.0) * 0.5 * RES as f32) as usize).min(RES - 1);
    v * RES + u
}

/// Centre direction of an octahedral cell.
pub fn cell_centre(c: usize) -> Vec3 {
    let (u, v) = (c % RES, c / RES);
    let p = Vec2::new((u as f32 + 0.5) / RES as f32 * 2.0 - 1.0, (v as f32 + 0.5) / RES as f32 * 2.0 - 1.0);
    let z = 1.0 - p.x.abs() - p.y.abs();
    let (x, y) = if z < 0.0 { ((1.0 - p.y.abs()) * p.x.signum(), (1.0 - p.x.abs()) * p.y.signum()) } else { (p.x, p.y) };
    Vec3::new(x, y, z).normalize()
}

impl Strata {
    pub fn get() -> &'static Strata {
        static S: OnceLock<Strata> = OnceLock::new();
        S.get_or_init(Strata::new)
    }

    fn new() -> Strata {
        let centres = dodecahedron();
        let filter = (0..RES * RES)
            .map(|c| {
                let d = cell_centre(c);
                let mut w: Vec<(u8, f32)> = centres
                    .iter()
                    .enumerate()
                    .map(|(s, v)| {
                        let a = d.dot(*v).clamp(-1.0, 1.0).acos();
                        (s as u8, (-a * a / (2.0 * SIGMA * SIGMA)).exp())
                    })
                    .collect();
                w.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
                w.truncate(SPREAD);
                let sum: f32 = w.iter().map(|x| x.1).sum();
                std::array::from_fn(|i| (w[i].0, w[i].1 / sum))
            })
            .collect();
        // spherical Fibonacci points: equal solid angle 4π/FINE each
        let mut labelled: Vec<(u8, Vec3)> = (0..FINE)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / FINE as f32;
                let phi = i as f32 * 2.399_963_2;
                let r = (1.0 - z * z).sqrt();
                let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                (nearest(&centres, d) as u8, d)
            })
            .collect();
        labelled.sort_by_key(|x| x.0); // stable: keeps the spiral order within a stratum
        let mut offsets = [0usize; STRATA + 1];
        for (s, _) in &labelled {
            offsets[*s as usize + 1] += 1;
        }
        for s in 0..STRATA {
            offsets[s + 1] += offsets[s];
        }
        let fine = labelled.into_iter().map(|x| x.1).collect();
        Strata { centres, filter, fine, offsets }
    }

    /// The stratum of a direction (its nearest dodecahedron vertex).
    #[inline]
    pub fn stratum(&self, d: Vec3) -> usize {
        nearest(&self.centres, d)
    }

    /// Filter weights for a photon arriving from direction `wi` (pointing away from the surface).
    #[inline]
    pub fn weights(&self, wi: Vec3) -> &[(u8, f32); SPREAD] {
        &self.filter[cell(wi)]
    }

    /// Solid angle of each stratum above the plane with normal `n` (fine directions are counted
    /// only for the strata the plane cuts).
    pub fn solid_angles_above(&self, n: Vec3) -> [f32; STRATA] {
        std::array::from_fn(|s| {
            let dirs = &self.fine[self.offsets[s]..self.offsets[s + 1]];
            let c = self.centres[s].dot(n);
            let count = if c > CELL_SIN_RADIUS {
                dirs.len()
            } else if c < -CELL_SIN_RADIUS {
                0
            } else {
                dirs.iter().filter(|d| d.dot(n) > 0.0).count()
            };
            count as f32 * 4.0 * std::f32::consts::PI / FINE as f32
        })
    }

    /// `∫ f(ω) L(ω) cos θ dω` for glossy sample `g` from the strata sums `h` (each the cosine-weighted
    /// radiance integrated over its stratum), taking the cosine-weighted radiance constant over the
    /// part of each stratum above the surface and integrating the BSDF over it by `samples²`
    /// stratified BSDF samples (seeded by `seed`).
    pub fn integrate(&self, g: &GlossyLobe, h: &[Vec3; STRATA], samples: u32, seed: u64) -> Vec3 {
        let omega = self.solid_angles_above(g.frame.n);
        let mut acc = [Vec3::ZERO; STRATA];
        let mut rng = Rng::new(seed, 0);
        let wo = g.wo;
        let inv = 1.0 / (samples * samples) as f32;
        for i in 0..samples {
            for j in 0..samples {
                let u = Vec2::new((i as f32 + rng.next_f32()) / samples as f32, (j as f32 + rng.next_f32()) / samples as f32);
                let Some(bs) = g.bsdf.sample(wo, rng.next_f32(), u, crate::bsdf::TransportMode::Radiance) else { continue };
                if bs.is_specular() || !(bs.pdf > 0.0) || bs.wi.z <= 0.0 {
                    continue;
                }
                let s = self.stratum(g.frame.to_world(bs.wi));
                acc[s] += bs.f / bs.pdf * inv;
            }
        }
        let mut sum = Vec3::ZERO;
        for s in 0..STRATA {
            if omega[s] > 0.0 {
                sum += h[s] / omega[s] * acc[s];
            }
        }
        sum
    }
}

#[inline]
fn nearest(centres: &[Vec3; STRATA], d: Vec3) -> usize {
    let mut best = (0, f32::MIN);
    for (i, c) in centres.iter().enumerate() {
        let v = c.dot(d);
        if v > best.1 {
            best = (i, v);
        }
    }
    best.0
}

/// Seed of a glossy sample's BSDF sampling.
pub fn seed_of(seed: u64, glossy_index: usize) -> u64 {
    hash(&[seed, 0x4849_5354, glossy_index as u64]) // "HIST"
}
