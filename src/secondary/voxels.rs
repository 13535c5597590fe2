//! The voxel grid with a photon counter per voxel and the split of the global photons into the low-
//! and high-energy maps (§3 of the paper).
//!
//! Photon order. The paper counts photons "as they are traced". Our photon set stores each class
//! (direct, indirect, caustic) in path order; the split walks the three classes merged by their
//! relative position `i / n_k` in their class (ties: class order), which approximates the order in
//! which the paths were traced and never depends on the thread count.
//!
//! Unequal photon powers. Eq. (1) caps the *count* at `c_max = E_max·A/ΔΦ`, which assumes one photon
//! power ΔΦ. Our classes carry different powers (each is divided by its own number of emitted paths),
//! so the counter accumulates photon power (luminance) and caps it at `Φ_max = E_max·A`: with equal
//! powers this is exactly `c_max` photons. `c_max` is reported with the mean photon power.
//!
//! Pilot (Eq. 2). `E_avg = nΔΦ / A_total` over the first `p = 10 %` of the photons: their power
//! divided by `p` (photon powers are per emitted path of the whole light pass) over the total surface
//! area of the scene (one side of every triangle). `E_max = multiplier · E_avg` (default 10, see
//! [`DEFAULT_MULTIPLIER`]) unless the user gives `E_max`.
//!
//! Voxel resolution (automatic). Cubic voxels of edge `2r` with `πr² = T · A_total / N` (N photons
//! to split, T = [`TARGET_PER_DISC`] = 8): a surface at the average irradiance puts about T photons
//! into the disc `A = πr²` of a voxel, so the cap `c_max ≈ multiplier · T = 80` photons at the
//! default is large enough for the count to be meaningful, and the voxels are as small as that
//! allows. The number of voxels along the longest side is clamped to `[4, 128]`.

use crate::photon::PhotonSet;
use crate::prepare::PreparedScene;
use glam::Vec3;

/// Default `E_max / E_avg`. A voxel in a corner of a uniformly lit box holds up to three faces
/// (`12 r²`, 3.8 × the paper's `A = πr²`) plus Poisson noise, so the multiplier must be well above
/// 4 for uniformly lit scenes to have no high-energy voxels; 10 keeps a margin.
pub const DEFAULT_MULTIPLIER: f32 = 10.0;
/// Mean photons in a voxel's disc `πr²` at the average irradiance (sets the automatic resolution).
pub const TARGET_PER_DISC: f32 = 8.0;
/// Share of the photons forming the pilot (the paper's p %).
pub const PILOT_FRACTION: f64 = 0.1;
const MIN_RES: f32 = 4.0;
const MAX_RES: f32 = 128.0;

/// User settings of the split.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitSettings {
    /// `E_max / E_avg` (ignored when `e_max` is given).
    pub multiplier: f32,
    /// Threshold irradiance `E_max` (W/m², luminance), overriding the automatic value.
    pub e_max: Option<f32>,
    /// Voxels along the longest side of the scene bounds (automatic when `None`).
    pub resolution: Option<u32>,
}

impl Default for SplitSettings {
    fn default() -> Self {
        SplitSettings { multiplier: DEFAULT_MULTIPLIER, e_max: None, resolution: None }
    }
}

impl SplitSettings {
    pub fn validate(&self) -> crate::Result<()> {
        use crate::Error;
        if !(self.multiplier.is_finite() && self.multiplier > 0.0) {
            return Err(Error::param("emax-multiplier", format!("{} must be a positive number", self.multiplier)));
        }
        if let Some(e) = self.e_max {
            if !(e.is_finite() && e > 0.0) {
                return Err(Error::param("emax", format!("{e} must be a positive irradiance")));
            }
        }
        if let Some(r) = self.resolution {
            if !(1..=512).contains(&r) {
                return Err(Error::param("voxel-resolution", format!("{r} is out of range (1..=512)")));
            }
        }
        Ok(())
    }
}

/// A regular grid of cubic voxels over a box.
#[derive(Clone, Copy, Debug)]
pub struct VoxelGrid {
    pub lo: Vec3,
    /// Voxel edge `2r`.
    pub edge: f32,
    pub dims: [u32; 3],
}

impl VoxelGrid {
    /// Cubic voxels, `res` of them along the longest side of `bounds` (slightly padded).
    pub fn new(bounds: (Vec3, Vec3), res: u32) -> VoxelGrid {
        let ext = (bounds.1 - bounds.0).max(Vec3::splat(1e-20));
        let pad = ext.max_element() * 1e-4;
        let (lo, ext) = (bounds.0 - Vec3::splat(pad), ext + Vec3::splat(2.0 * pad));
        let edge = ext.max_element() / res.max(1) as f32;
        let d = |e: f32| ((e / edge).ceil() as u32).clamp(1, res.max(1));
        VoxelGrid { lo, edge, dims: [d(ext.x), d(ext.y), d(ext.z)] }
    }

    pub fn len(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The paper's `A = πr²` for a voxel of edge `2r`.
    pub fn disc_area(&self) -> f32 {
        std::f32::consts::PI * (0.5 * self.edge).powi(2)
    }

    pub fn volume(&self) -> f32 {
        self.edge.powi(3)
    }

    /// Voxel containing `p` (points outside the grid are clamped to it).
    pub fn index(&self, p: Vec3) -> u32 {
        let c = (p - self.lo) / self.edge;
        let f = |x: f32, d: u32| (x.max(0.0) as u32).min(d - 1);
        let (x, y, z) = (f(c.x, self.dims[0]), f(c.y, self.dims[1]), f(c.z, self.dims[2]));
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    /// The box of voxel `v`.
    pub fn bounds(&self, v: u32) -> (Vec3, Vec3) {
        let (dx, dy) = (self.dims[0], self.dims[1]);
        let (x, y, z) = (v % dx, (v / dx) % dy, v / (dx * dy));
        let lo = self.lo + Vec3::new(x as f32, y as f32, z as f32) * self.edge;
        (lo, lo + Vec3::splat(self.edge))
    }
}

/// The voxels holding high-energy photons, with their photon counts.
#[derive(Clone, Debug, Default)]
pub struct HighVoxels {
    pub voxels: Vec<u32>,
    pub counts: Vec<u32>,
}

impl HighVoxels {
    pub fn len(&self) -> usize {
        self.voxels.len()
    }
    pub fn is_empty(&self) -> bool {
        self.voxels.is_empty()
    }
}

/// The result of the split: per class, which photons go to which map.
pub struct Split {
    pub grid: VoxelGrid,
    /// Photons (ending on non-specular surfaces) in the low- and high-energy maps, per class.
    pub low: [Vec<bool>; 3],
    pub high: [Vec<bool>; 3],
    pub high_voxels: HighVoxels,
    pub e_avg: f32,
    pub e_max: f32,
    /// Voxel power cap `E_max·A` and the equivalent count `c_max` at the mean photon power.
    pub flux_cap: f32,
    pub c_max: f32,
    pub pilot_photons: usize,
    pub high_photons: usize,
    pub low_photons: usize,
}

impl Split {
    pub fn bytes(&self) -> u64 {
        (self.grid.len() * 4 + self.high_voxels.len() * 8) as u64
    }

    /// One line on the split, for `raysplat info` and `raysplat-bench secondary`: the
    /// high-energy voxels and photons, the threshold and the voxel cap.
    pub fn summary(&self) -> String {
        let [x, y, z] = self.grid.dims;
        format!(
            "{} high-energy voxels of a {x}x{y}x{z} grid, {} of {} photons high-energy; E_avg {:.4e}, E_max {:.4e} W/m^2 ({:.3} x E_avg), c_max {:.0}",
            self.high_voxels.len(),
            self.high_photons,
            self.high_photons + self.low_photons,
            self.e_avg,
            self.e_max,
            self.e_max / self.e_avg.max(1e-30),
            self.c_max
        )
    }
}

/// Total surface area of the scene (one side of every triangle of every instance), A_total of Eq. 2.
pub fn scene_area(scene: &PreparedScene) -> f64 {
    let mut a = 0.0f64;
    for inst in &scene.instances {
        a += crate::prepare::surface_area(&scene.meshes[inst.mesh as usize], &inst.to_world);
    }
    a
}

#[inline]
fn lum(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Split the photons of `classes` (indices into `photons.rays`) that end on non-specular surfaces.
pub fn split(scene: &PreparedScene, photons: &PhotonSet, classes: &[usize], s: &SplitSettings) -> Split {
    // Merge the classes by relative position (path order, approximately).
    let mut order: Vec<(f64, u8, u32)> = Vec::new();
    for &k in classes {
        let n = photons.rays[k].len();
        for i in 0..n {
            if photons.ends_diffuse[k][i] {
                order.push((i as f64 / n as f64, k as u8, i as u32));
            }
        }
    }
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let n = order.len();
    let area = scene_area(scene).max(1e-30);
    // Pilot: the first p % of the photons (Eq. 2).
    let pilot = ((n as f64 * PILOT_FRACTION).ceil() as usize).min(n);
    let pilot_flux: f64 = order[..pilot].iter().map(|&(_, k, i)| lum(photons.rays[k as usize][i as usize].flux) as f64).sum();
    let e_avg = if pilot > 0 { (pilot_flux / (PILOT_FRACTION * area)) as f32 } else { 0.0 };
    let e_max = s.e_max.unwrap_or(s.multiplier * e_avg);
    let res = s.resolution.map(|r| r as f32).unwrap_or_else(|| {
        let r = (TARGET_PER_DISC as f64 * area / (std::f64::consts::PI * n.max(1) as f64)).sqrt() as f32;
        let ext = (scene.bounds.1 - scene.bounds.0).max_element();
        (ext / (2.0 * r)).clamp(MIN_RES, MAX_RES)
    });
    let grid = VoxelGrid::new(scene.bounds, res.round().max(1.0) as u32);
    let flux_cap = e_max * grid.disc_area();
    let mean_power = if n > 0 {
        order.iter().map(|&(_, k, i)| lum(photons.rays[k as usize][i as usize].flux) as f64).sum::<f64>() / n as f64
    } else {
        0.0
    };
    let c_max = if mean_power > 0.0 { (flux_cap as f64 / mean_power) as f32 } else { 0.0 };
    let mut acc = vec![0.0f32; grid.len()];
    let mut low: [Vec<bool>; 3] = std::array::from_fn(|k| vec![false; photons.rays[k].len()]);
    let mut high: [Vec<bool>; 3] = std::array::from_fn(|k| vec![false; photons.rays[k].len()]);
    let (mut n_low, mut n_high) = (0, 0);
    let mut high_of: std::collections::BTreeMap<u32, u32> = Default::default();
    for &(_, k, i) in &order {
        let r = &photons.rays[k as usize][i as usize];
        let v = grid.index(r.end());
        let a = &mut acc[v as usize];
        if *a < flux_cap {
            *a += lum(r.flux);
            low[k as usize][i as usize] = true;
            n_low += 1;
        } else {
            high[k as usize][i as usize] = true;
            *high_of.entry(v).or_default() += 1;
            n_high += 1;
        }
    }
    let high_voxels = HighVoxels { voxels: high_of.keys().copied().collect(), counts: high_of.values().copied().collect() };
    Split {
        grid,
        low,
        high,
        high_voxels,
        e_avg,
        e_max,
        flux_cap,
        c_max,
        pilot_photons: pilot,
        high_photons: n_high,
        low_photons: n_low,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voxel_index_and_bounds_agree() {
        let g = VoxelGrid::new((Vec3::new(-1.0, 0.0, -2.0), Vec3::new(3.0, 1.0, 2.0)), 8);
        assert_eq!((g.dims[0], g.dims[2]), (8, 8));
        assert!(g.dims[1] as f32 * g.edge >= 1.0 && g.dims[1] <= 3);
        for v in [0u32, 5, 17, 63, (g.len() - 1) as u32] {
            let (lo, hi) = g.bounds(v);
            assert_eq!(g.index(0.5 * (lo + hi)), v);
        }
        assert!((g.disc_area() - std::f32::consts::PI * (0.5 * g.edge).powi(2)).abs() < 1e-6);
    }
}
