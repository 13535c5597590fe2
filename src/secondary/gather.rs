//! The per-point estimator of reflected indirect light at a gather point `x` (normal `n`):
//!
//! `∫ f(ω) L(z(ω)) cos θ dω  =  ∫ f L_low cos dω  +  ∫ f L_high 1[z ∈ high voxel] cos dω`
//!
//! where `L_low`, `L_high` are the density estimates of the low- and high-energy maps at the first
//! surface `z(ω)` seen from `x`. Every global photon is in exactly one map, so the two integrals add
//! up to the gather of the whole map: nothing is counted twice. The first integral is estimated by
//! `N` stratified cosine-weighted gather rays (`--fg-rays`) which look up only the low-energy map;
//! the second by `M` explicit rays (`--explicit-rays`) toward uniformly random points `y` in the
//! high-energy voxels, which look up only the high-energy map (Eq. 3–5).
//!
//! Eq. (5) converts the voxel sample to a solid angle with `dω' = (ω''·N') A / l²`, `A = πr²` a
//! guess of the surface area in the voxel, which is biased whenever the voxel holds more or less
//! surface than that. We use the exact density instead: a uniform point in voxel `v` (volume `V`)
//! seen from `x` has the solid-angle density `q_v(ω) = (t₁³ − t₀³) / (3V)`, `[t₀, t₁]` the chord of
//! the ray `x + tω` through the voxel, so `f L_high cos / (P(v) q_v(ω))` counted only when the first
//! hit lies in `v` (inside the chord) is an unbiased estimate of the second integral.
//!
//! Radiance at a gather hit `z` is `albedo(z)/π · E(z)` with `E` from Christensen's precomputed
//! irradiance ([`crate::photon::IrradianceMap`]); hits on purely specular surfaces add nothing (the
//! caustic map covers `L S+ D` at the gather point itself).

use super::{HighVoxels, VoxelGrid};
use crate::embree::Ray;
use crate::kdtree::KnnHeap;
use crate::photon::IrradianceMap;
use crate::prepare::{PreparedScene, SurfaceHit};
use crate::sampling::{square_to_cosine_hemisphere, Distribution1D, Frame, Rng};
use glam::{Vec2, Vec3};

/// How the explicit rays are shared between the high-energy voxels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Allocation {
    /// The same number of rays per voxel (the voxel is chosen uniformly, stratified over the rays).
    PerVoxel,
    /// In proportion to the voxel's high-energy photon count.
    Proportional,
}

impl Allocation {
    pub fn name(self) -> &'static str {
        match self {
            Allocation::PerVoxel => "per-voxel",
            Allocation::Proportional => "proportional",
        }
    }
    pub fn parse(s: &str) -> crate::Result<Allocation> {
        match s {
            "per-voxel" => Ok(Allocation::PerVoxel),
            "proportional" => Ok(Allocation::Proportional),
            _ => Err(crate::Error::param("explicit-allocation", format!("{s:?} (available: per-voxel, proportional)"))),
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub struct GatherSettings {
    /// Stratified cosine-weighted rays into the low-energy map.
    pub fg_rays: u32,
    /// Rays toward the high-energy voxels.
    pub explicit_rays: u32,
}

/// What the estimator reads.
pub struct GatherMaps<'a> {
    pub low: &'a IrradianceMap,
    /// The high-energy map with its voxels (absent when the scene has none).
    pub high: Option<(&'a IrradianceMap, &'a HighVoxels, VoxelGrid, Distribution1D)>,
    /// Search radius of the irradiance look-ups.
    pub max_radius: f32,
}

impl<'a> GatherMaps<'a> {
    pub fn new(low: &'a IrradianceMap, high: Option<(&'a IrradianceMap, &'a HighVoxels, VoxelGrid)>, alloc: Allocation, max_radius: f32) -> Self {
        let high = high.filter(|h| !h.1.is_empty()).map(|(m, hv, g)| {
            let w: Vec<f32> = match alloc {
                Allocation::PerVoxel => vec![1.0; hv.len()],
                Allocation::Proportional => hv.counts.iter().map(|&c| c as f32).collect(),
            };
            (m, hv, g, Distribution1D::new(&w))
        });
        GatherMaps { low, high, max_radius }
    }
}

/// Result of one gather.
#[derive(Clone, Copy, Debug, Default)]
pub struct Gathered {
    /// `∫ f L cos dω` (with `f = 1`: the irradiance).
    pub value: Vec3,
    /// Harmonic mean distance of the stratified rays' hits (∞ when none hit).
    pub harmonic: f32,
    pub rays: u32,
}

fn hit_radiance(scene: &PreparedScene, map: &IrradianceMap, h: &SurfaceHit, w: Vec3, max_r: f32, heap: &mut KnnHeap) -> Vec3 {
    let bsdf = scene.bsdf(h);
    let flags = bsdf.flags();
    if !(flags.is_diffuse() || flags.is_glossy()) {
        return Vec3::ZERO;
    }
    // Normal on the side the gather ray arrives from.
    let n = if h.ng.dot(w) > 0.0 { -h.ng } else { h.ng };
    bsdf.albedo() * std::f32::consts::FRAC_1_PI * map.lookup(h.p, n, max_r, heap)
}

/// Chord `[t0, t1]` of the ray `o + t d` (t ≥ 0) through the box.
fn chord(o: Vec3, d: Vec3, (lo, hi): (Vec3, Vec3)) -> Option<(f32, f32)> {
    let inv = d.recip();
    let (a, b) = ((lo - o) * inv, (hi - o) * inv);
    let (t0, t1) = (a.min(b).max_element().max(0.0), a.max(b).min_element());
    (t1 > t0 && t1.is_finite()).then_some((t0, t1))
}

/// Estimate `∫ f(ω) L(z(ω)) cos θ dω` at `x` with normal `n` (toward the viewer); `f(ω)` is the
/// BSDF toward world direction `ω` (1 for the irradiance).
pub fn gather(scene: &PreparedScene, maps: &GatherMaps, s: &GatherSettings, x: Vec3, n: Vec3, f: &dyn Fn(Vec3) -> Vec3, rng: &mut Rng, heap: &mut KnnHeap) -> Gathered {
    let frame = Frame::from_normal(n);
    let mut out = Gathered::default();
    let nf = s.fg_rays as usize;
    let mut sum = Vec3::ZERO;
    let mut inv_d = 0.0f64;
    if nf > 0 {
        // a × b strata, the remainder uniformly.
        let a = (nf as f64).sqrt().floor().max(1.0) as usize;
        let b = nf / a;
        for k in 0..nf {
            let u = if k < a * b {
                let (i, j) = (k % a, k / a);
                Vec2::new((i as f32 + rng.next_f32()) / a as f32, (j as f32 + rng.next_f32()) / b as f32)
            } else {
                rng.next_2d()
            };
            let w = frame.to_world(square_to_cosine_hemisphere(u.min(Vec2::splat(1.0 - f32::EPSILON))));
            let Some(h) = scene.intersect(&scene.spawn(x, n, w)) else { continue };
            inv_d += 1.0 / h.t.max(1e-20) as f64;
            // cos θ / pdf = π.
            sum += f(w) * std::f32::consts::PI * hit_radiance(scene, maps.low, &h, w, maps.max_radius, heap);
        }
        out.value += sum / nf as f32;
        out.rays += nf as u32;
    }
    out.harmonic = if inv_d > 0.0 { (nf as f64 / inv_d) as f32 } else { f32::INFINITY };
    let Some((high, hv, grid, dist)) = &maps.high else { return out };
    let m = s.explicit_rays as usize;
    let mut sum = Vec3::ZERO;
    for k in 0..m {
        let Some((vi, pmf, _)) = dist.sample_discrete((k as f32 + rng.next_f32()) / m as f32) else { break };
        let bx = grid.bounds(hv.voxels[vi]);
        let y = bx.0 + (bx.1 - bx.0) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let d = y - x;
        let Some(w) = d.try_normalize() else { continue };
        let cos = w.dot(n);
        if cos <= 0.0 {
            continue;
        }
        let Some((t0, t1)) = chord(x, w, bx) else { continue };
        let q = pmf * (t1.powi(3) - t0.powi(3)) / (3.0 * grid.volume());
        if !(q > 0.0) {
            continue;
        }
        let mut ray: Ray = scene.spawn(x, n, w);
        ray.tfar = t1;
        let Some(h) = scene.intersect(&ray) else { continue };
        // The hit must lie in the chosen voxel (the ray origin is offset by a tiny epsilon).
        if (h.p - x).dot(w) < t0 {
            continue;
        }
        sum += f(w) * cos * hit_radiance(scene, high, &h, w, maps.max_radius, heap) / q;
    }
    if m > 0 {
        out.value += sum / m as f32;
        out.rays += m as u32;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chord_of_a_box() {
        let b = (Vec3::splat(1.0), Vec3::splat(2.0));
        let (t0, t1) = chord(Vec3::ZERO, Vec3::ONE.normalize(), b).unwrap();
        assert!((t0 - 3f32.sqrt()).abs() < 1e-5 && (t1 - 2.0 * 3f32.sqrt()).abs() < 1e-5);
        assert!(chord(Vec3::ZERO, -Vec3::X, b).is_none());
        let (t0, _) = chord(Vec3::splat(1.5), Vec3::X, b).unwrap();
        assert_eq!(t0, 0.0);
    }

    /// The solid-angle density of a uniform point in a box, `(t1³ − t0³)/(3V)`, integrates to 1
    /// over the sphere of directions (Monte Carlo over uniform directions).
    #[test]
    fn voxel_direction_density_integrates_to_one() {
        let b = (Vec3::new(0.5, -0.2, 0.1), Vec3::new(0.9, 0.2, 0.5));
        let v = 0.4f32.powi(3);
        let mut rng = Rng::new(3, 0);
        let n = 400_000;
        let mut s = 0.0f64;
        for _ in 0..n {
            let w = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            if let Some((t0, t1)) = chord(Vec3::ZERO, w, b) {
                s += ((t1.powi(3) - t0.powi(3)) / (3.0 * v)) as f64;
            }
        }
        let integral = s / n as f64 * 4.0 * std::f64::consts::PI;
        assert!((integral - 1.0).abs() < 0.03, "{integral}");
    }
}
