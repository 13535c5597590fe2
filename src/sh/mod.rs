//! Real spherical harmonics, bands 0–3 (16 coefficients), for the glossy radiance map of
//! `photon-ray-splatting.md` §8.1: evaluation of the orthonormal basis, numerical projection,
//! rotation, the analytic zonal coefficients of the clamped cosine, and an exact quadrature for
//! products of two band-limited functions (degree ≤ 6) that the final integration uses.
//!
//! Ordering is `(l, m)` with `m = -l..=l`, index `l(l+1)+m`; the normalisation is
//! `∫ Y_i Y_j dω = δ_ij` over the sphere.

mod rotation;
mod rotation_unrolled;
#[cfg(test)]
mod tests;

pub use rotation::{rotate_even_yz, ShRotation, EVEN_YZ};

use glam::Vec3;
use std::f32::consts::PI;

/// Coefficients of bands 0–3.
pub const N: usize = 16;
/// Highest band.
pub const BANDS: usize = 4;

/// The 16 basis functions at the unit direction `d`.
#[inline]
pub fn eval(d: Vec3) -> [f32; N] {
    let (x, y, z) = (d.x, d.y, d.z);
    let (x2, y2, z2) = (x * x, y * y, z * z);
    [
        0.282_094_79,
        -0.488_602_51 * y,
        0.488_602_51 * z,
        -0.488_602_51 * x,
        1.092_548_4 * x * y,
        -1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z2 - 1.0),
        -1.092_548_4 * x * z,
        0.546_274_2 * (x2 - y2),
        -0.590_043_6 * y * (3.0 * x2 - y2),
        2.890_611_4 * x * y * z,
        -0.457_045_8 * y * (5.0 * z2 - 1.0),
        0.373_176_33 * z * (5.0 * z2 - 3.0),
        -0.457_045_8 * x * (5.0 * z2 - 1.0),
        1.445_305_7 * z * (x2 - y2),
        -0.590_043_6 * x * (x2 - 3.0 * y2),
    ]
}

/// Reconstruction `Σ c_i Y_i(d)`.
#[inline]
pub fn reconstruct(c: &[f32; N], d: Vec3) -> f32 {
    let y = eval(d);
    c.iter().zip(&y).map(|(a, b)| a * b).sum()
}

/// Reconstruction of RGB coefficients.
#[inline]
pub fn reconstruct_rgb(c: &[Vec3; N], d: Vec3) -> Vec3 {
    let y = eval(d);
    c.iter().zip(&y).fold(Vec3::ZERO, |a, (c, y)| a + *c * *y)
}

/// Index of the zonal coefficient of band `l` (`m = 0`).
pub const fn zonal_index(l: usize) -> usize {
    l * (l + 1)
}

/// Zonal coefficients of the clamped cosine `max(cos θ, 0)` around +z:
/// `√π/2, √(π/3), √(5π)/8, 0` (bands 0–3).
pub fn clamped_cosine_zonal() -> [f32; BANDS] {
    [PI.sqrt() / 2.0, (PI / 3.0).sqrt(), (5.0 * PI).sqrt() / 8.0, 0.0]
}

/// The midpoint rule's directions on an equal-area (cos θ, φ) grid of `n_theta × n_phi` cells, row
/// by row, and each cell's solid angle.
fn midpoint_grid(n_theta: usize, n_phi: usize) -> (impl Iterator<Item = Vec3>, f64) {
    let dw = 4.0 * PI as f64 / (n_theta * n_phi) as f64;
    let dirs = (0..n_theta).flat_map(move |i| {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / n_theta as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        (0..n_phi).map(move |j| {
            let phi = 2.0 * PI * (j as f32 + 0.5) / n_phi as f32;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
    });
    (dirs, dw)
}

/// Numerical projection of `f` by the midpoint rule on an equal-area (cos θ, φ) grid.
pub fn project(f: impl Fn(Vec3) -> f32, n_theta: usize, n_phi: usize) -> [f32; N] {
    let mut c = [0.0f64; N];
    let (dirs, dw) = midpoint_grid(n_theta, n_phi);
    for d in dirs {
        let v = f(d) as f64;
        for (ck, y) in c.iter_mut().zip(eval(d)) {
            *ck += v * y as f64 * dw;
        }
    }
    c.map(|x| x as f32)
}

/// [`project`] of an RGB function (one evaluation per direction).
pub fn project_rgb(f: impl Fn(Vec3) -> Vec3, n_theta: usize, n_phi: usize) -> [Vec3; N] {
    let mut c = [glam::DVec3::ZERO; N];
    let (dirs, dw) = midpoint_grid(n_theta, n_phi);
    for d in dirs {
        let v = f(d).as_dvec3() * dw;
        for (ck, y) in c.iter_mut().zip(eval(d)) {
            *ck += v * y as f64;
        }
    }
    c.map(|x| x.as_vec3())
}

/// [`project_rgb`] of a function even in `y` and in `z` (`f(x, ±y, ±z)` equal), on the same grid:
/// `f` is evaluated on the quarter `y > 0, z > 0` only, each value standing for its four mirror
/// images. `n_theta` and `n_phi` must be even (the grid is then symmetric in `y` and `z`).
pub fn project_rgb_even_yz(f: impl FnMut(Vec3) -> Vec3, n_theta: usize, n_phi: usize) -> [Vec3; N] {
    EvenGrid::new(n_theta, n_phi).project_rgb(f)
}

/// The quarter grid of [`project_rgb_even_yz`] with each point's basis values summed over its four
/// mirror images, for projecting many functions on one grid (a BSDF table projects one lobe per
/// outgoing-direction bin): the basis is evaluated once per grid, not once per function.
///
/// The sums vanish (exactly: `Y_k(x, −y, z)` is `−Y_k(x, y, z)` bit for bit for a `Y_k` odd in
/// `y`, likewise in `z`) but at the basis functions even in `y` and in `z`,
/// [`EVEN_YZ`](rotation::EVEN_YZ): only those six are kept and accumulated, and a projection's
/// other ten coefficients are 0, as the full sums give them.
pub struct EvenGrid {
    /// Quarter-grid directions, row by row (`cos θ` descending, then φ).
    dirs: Vec<Vec3>,
    /// Per direction, `Y_k(x, y, z) + Y_k(x, −y, z) + Y_k(x, y, −z) + Y_k(x, −y, −z)` for the
    /// `k` of [`EVEN_YZ`](rotation::EVEN_YZ).
    basis: Vec<[f32; rotation::EVEN_YZ.len()]>,
    /// Solid angle of a cell of the full grid.
    dw: f64,
}

impl EvenGrid {
    /// The quarter of the `n_theta × n_phi` equal-area grid (both even).
    pub fn new(n_theta: usize, n_phi: usize) -> EvenGrid {
        debug_assert!(n_theta % 2 == 0 && n_phi % 2 == 0);
        let trig: Vec<(f32, f32)> = (0..n_phi / 2).map(|j| (2.0 * PI * (j as f32 + 0.5) / n_phi as f32).sin_cos()).collect();
        let mut dirs = Vec::with_capacity(n_theta * n_phi / 4);
        let mut basis = Vec::with_capacity(n_theta * n_phi / 4);
        for i in 0..n_theta / 2 {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n_theta as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            for &(sin, cos) in &trig {
                let (x, y) = (r * cos, r * sin);
                let ys = [eval(Vec3::new(x, y, z)), eval(Vec3::new(x, -y, z)), eval(Vec3::new(x, y, -z)), eval(Vec3::new(x, -y, -z))];
                let sum = |k: usize| ys[0][k] + ys[1][k] + ys[2][k] + ys[3][k];
                debug_assert!((0..N).filter(|k| !rotation::EVEN_YZ.contains(k)).all(|k| sum(k) == 0.0), "a basis function odd in y or z summed to nonzero");
                dirs.push(Vec3::new(x, y, z));
                basis.push(rotation::EVEN_YZ.map(sum));
            }
        }
        EvenGrid { dirs, basis, dw: 4.0 * PI as f64 / (n_theta * n_phi) as f64 }
    }

    /// The quarter grid's directions (`y > 0`, `z > 0`), in the order `project_rgb` evaluates them.
    pub fn dirs(&self) -> &[Vec3] {
        &self.dirs
    }

    /// Number of quarter-grid directions.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// Coefficients of `f` (even in `y` and `z`), evaluating it at the quarter grid's directions in
    /// order (consecutive directions of a row share `cos θ`).
    pub fn project_rgb(&self, mut f: impl FnMut(Vec3) -> Vec3) -> [Vec3; N] {
        let mut c = [glam::DVec3::ZERO; rotation::EVEN_YZ.len()];
        for (d, y) in self.dirs.iter().zip(&self.basis) {
            let v = f(*d).as_dvec3() * self.dw;
            for (ck, yk) in c.iter_mut().zip(y) {
                *ck += v * *yk as f64;
            }
        }
        let mut out = [Vec3::ZERO; N];
        for (&k, ck) in rotation::EVEN_YZ.iter().zip(c) {
            out[k] = ck.as_vec3();
        }
        out
    }
}

/// Nodes of a product quadrature on the sphere, exact for polynomials of degree ≤ 7 in `z` times
/// trigonometric polynomials of degree ≤ 7 in φ — so exact for the product of two functions of
/// bands 0–3 (degree 6): 4 Gauss–Legendre nodes in `cos θ` × 8 uniform nodes in φ.
pub struct Quadrature {
    pub dirs: [Vec3; 32],
    pub weights: [f32; 32],
}

/// The product quadrature (see [`Quadrature`]).
pub fn quadrature() -> &'static Quadrature {
    static Q: std::sync::OnceLock<Quadrature> = std::sync::OnceLock::new();
    Q.get_or_init(|| {
        let gl = [
            (-0.861_136_3, 0.347_854_85),
            (-0.339_981_04, 0.652_145_15),
            (0.339_981_04, 0.652_145_15),
            (0.861_136_3, 0.347_854_85),
        ];
        let mut q = Quadrature { dirs: [Vec3::ZERO; 32], weights: [0.0; 32] };
        for (i, &(z, w)) in gl.iter().enumerate() {
            let r = (1.0f32 - z * z).sqrt();
            for j in 0..8 {
                // offset by half a step so no node lies on the x axis (any offset is exact)
                let phi = 2.0 * PI * (j as f32 + 0.5) / 8.0;
                q.dirs[i * 8 + j] = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                q.weights[i * 8 + j] = w * 2.0 * PI / 8.0;
            }
        }
        q
    })
}

/// Coefficients of `d ↦ g(rot⁻¹·d)` where `g` has coefficients `c` (the function rotated by the
/// orthonormal `rot`), by exact re-projection with [`quadrature`].
pub fn rotate(c: &[f32; N], rot: glam::Mat3) -> [f32; N] {
    let q = quadrature();
    let inv = rot.transpose();
    let mut out = [0.0f32; N];
    for (d, w) in q.dirs.iter().zip(q.weights) {
        let v = reconstruct(c, inv * *d) * w;
        for (o, y) in out.iter_mut().zip(eval(*d)) {
            *o += v * y;
        }
    }
    out
}
