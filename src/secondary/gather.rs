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
//! the ray `x + tω` through the voxel. A ray is aimed at voxel `v` chosen with probability `P(v)`,
//! and `f L_high cos / Σ_v P(v) q_v(ω)` (the mixture density over all high-energy voxels), counted
//! when the first hit lies in any high-energy voxel, is an unbiased estimate of the second integral.
//! (Counting only hits in the chosen voxel with `q_v` alone is also unbiased but wastes the rays that
//! leave its chord before reaching the surface: twice the variance on `scenes/secondary-light.usda`.)
//!
//! Radiance at a gather hit `z` is `albedo(z)/π · E(z)` with `E` from Christensen's precomputed
//! irradiance ([`crate::photon::IrradianceMap`]); hits on purely specular surfaces add nothing (the
//! caustic map covers `L S+ D` at the gather point itself).

use super::{HighVoxels, VoxelGrid};
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
    pub high: Option<(&'a IrradianceMap, &'a HighVoxels, VoxelGrid, Distribution1D, Mixture)>,
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
            let dist = Distribution1D::new(&w);
            let mix = Mixture::new(&g, hv, &dist);
            (m, hv, g, dist, mix)
        });
        GatherMaps { low, high, max_radius }
    }
}

/// The mixture density `Σ_v P(v) q_v(ω)` of the explicit directions, evaluated by a 3D-DDA walk
/// (Amanatides & Woo) through the sub-grid spanning the high-energy voxels, whose cells hold `P(v)`.
pub struct Mixture {
    lo: Vec3,
    edge: f32,
    dims: [i32; 3],
    pmf: Vec<f32>,
    inv_3v: f32,
}

impl Mixture {
    fn new(grid: &VoxelGrid, hv: &HighVoxels, dist: &Distribution1D) -> Mixture {
        let cell = |v: u32| {
            let (dx, dy) = (grid.dims[0], grid.dims[1]);
            [(v % dx) as i32, ((v / dx) % dy) as i32, (v / (dx * dy)) as i32]
        };
        let (mut lo, mut hi) = ([i32::MAX; 3], [i32::MIN; 3]);
        for &v in &hv.voxels {
            let c = cell(v);
            for a in 0..3 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
        let dims = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1];
        let mut pmf = vec![0.0; (dims[0] * dims[1] * dims[2]) as usize];
        for (j, &v) in hv.voxels.iter().enumerate() {
            let c = cell(v);
            pmf[(((c[2] - lo[2]) * dims[1] + c[1] - lo[1]) * dims[0] + c[0] - lo[0]) as usize] = dist.pmf(j);
        }
        let origin = grid.lo + Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32) * grid.edge;
        Mixture { lo: origin, edge: grid.edge, dims, pmf, inv_3v: 1.0 / (3.0 * grid.volume()) }
    }

    /// `Σ_v P(v) (t₁³ − t₀³) / (3V)` over the voxels the ray `x + tω` crosses.
    pub fn pdf(&self, x: Vec3, w: Vec3) -> f32 {
        let hi = self.lo + Vec3::new(self.dims[0] as f32, self.dims[1] as f32, self.dims[2] as f32) * self.edge;
        let Some((t_in, t_out)) = chord(x, w, (self.lo, hi)) else { return 0.0 };
        let start = (x + w * t_in - self.lo) / self.edge;
        let mut c = [0i32; 3];
        let (mut t_max, mut t_delta, mut step) = ([f32::INFINITY; 3], [f32::INFINITY; 3], [0i32; 3]);
        for a in 0..3 {
            c[a] = (start[a].floor() as i32).clamp(0, self.dims[a] - 1);
            if w[a] > 0.0 {
                step[a] = 1;
                t_delta[a] = self.edge / w[a];
                t_max[a] = ((self.lo[a] + (c[a] + 1) as f32 * self.edge) - x[a]) / w[a];
            } else if w[a] < 0.0 {
                step[a] = -1;
                t_delta[a] = -self.edge / w[a];
                t_max[a] = ((self.lo[a] + c[a] as f32 * self.edge) - x[a]) / w[a];
            }
        }
        let (mut t, mut q) = (t_in, 0.0f32);
        loop {
            let a = if t_max[0] <= t_max[1] && t_max[0] <= t_max[2] { 0 } else if t_max[1] <= t_max[2] { 1 } else { 2 };
            let t_next = t_max[a].min(t_out).max(t);
            let pm = self.pmf[((c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]) as usize];
            if pm > 0.0 {
                q += pm * (t_next.powi(3) - t.powi(3)) * self.inv_3v;
            }
            t = t_next;
            c[a] += step[a];
            t_max[a] += t_delta[a];
            if t >= t_out || c[a] < 0 || c[a] >= self.dims[a] {
                break;
            }
        }
        q
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
#[allow(clippy::too_many_arguments)]
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
    let Some((high, hv, grid, dist, mix)) = &maps.high else { return out };
    let m = s.explicit_rays as usize;
    let mut sum = Vec3::ZERO;
    for k in 0..m {
        let Some((vi, _, _)) = dist.sample_discrete((k as f32 + rng.next_f32()) / m as f32) else { break };
        let bx = grid.bounds(hv.voxels[vi]);
        let y = bx.0 + (bx.1 - bx.0) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let Some(w) = (y - x).try_normalize() else { continue };
        let cos = w.dot(n);
        if cos <= 0.0 {
            continue;
        }
        let Some(h) = scene.intersect(&scene.spawn(x, n, w)) else { continue };
        // Counted when the hit lies in any high-energy voxel, with the mixture density of the
        // direction over all voxels (one-sample balance: a ray aimed at one voxel that hits the
        // secondary source in a neighbouring one still counts).
        if hv.voxels.binary_search(&grid.index(h.p)).is_err() {
            continue;
        }
        let q = mix.pdf(x, w);
        if q.is_nan() || q <= 0.0 {
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

    /// The DDA walk gives the same mixture density as summing the chords of every voxel.
    #[test]
    fn mixture_density_matches_brute_force() {
        let grid = VoxelGrid::new((Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.0, 1.0)), 10);
        let mut rng = Rng::new(7, 0);
        let mut voxels: Vec<u32> = (0..40).map(|_| (rng.next_f32() * grid.len() as f32) as u32).collect();
        voxels.sort();
        voxels.dedup();
        let counts: Vec<u32> = voxels.iter().map(|&v| 1 + v % 5).collect();
        let hv = HighVoxels { voxels, counts };
        let dist = Distribution1D::new(&hv.counts.iter().map(|&c| c as f32).collect::<Vec<_>>());
        let mix = Mixture::new(&grid, &hv, &dist);
        let inv = 1.0 / (3.0 * grid.volume());
        let mut nonzero = 0;
        for _ in 0..2000 {
            let x = Vec3::new(rng.next_f32() * 3.0 - 1.5, rng.next_f32() * 1.5 - 0.25, rng.next_f32() * 3.0 - 1.5);
            let w = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let brute: f32 = hv.voxels.iter().enumerate().filter_map(|(j, &v)| chord(x, w, grid.bounds(v)).map(|(t0, t1)| dist.pmf(j) * (t1.powi(3) - t0.powi(3)) * inv)).sum();
            let dda = mix.pdf(x, w);
            assert!((dda - brute).abs() <= 1e-3 * brute.max(1e-3), "{dda} vs {brute} at {x} {w}");
            nonzero += (brute > 0.0) as u32;
        }
        assert!(nonzero > 100, "{nonzero}");
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
