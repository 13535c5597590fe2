//! Bandwidth selection of photon ray splatting (§6, Eq. 7–8):
//!
//! `h(x_i) = C / M^(1/6) · w / sqrt(p̃(x_i|x_{i-1})^S)`, `h(x_0) = 0`, with the clamped path density
//! `p̃(x_{i+1}|x_i) = p̃(x_i|x_{i-1}) · p_s⊥ / D(x_i, x_{i+1})`, `D(x, y) = max(D̃², ‖x − y‖²)`.
//!
//! `w = m0 · μ_C / ⟨r⟩` with `r = 1/sqrt(p̃^S)`, `μ_C = a·⟨ℓ⟩` (⟨ℓ⟩ the mean segment length),
//! `a = 0.2`, `m0 = 10^(5/6)`, all estimated by a pilot shooting phase.
//!
//! Scale invariance: lengths enter `p̃` in units of the scene radius, so the same scene at any size
//! gets the same bandwidths relative to its size. `D̃` is 10 % of the mean (normalised) segment length.
//! The bandwidth is clamped to `[h_max / 100, h_max]` with `h_max = R · ⟨ℓ⟩` (R = 0.2 by default).
//! Per ray: `h0 = min(h_i, h_{i+1})`, `dh = max(0, h_{i+1} − h_i) / ‖x_{i+1} − x_i‖`.

/// User parameters (the paper's C, S, R).
///
/// Defaults: C = 0.3, S = 0.1, R = 0.2. The paper's scenes use C = 0.6–1.1 and S = 0.2–0.5, but its
/// scale `μ_C = a·⟨D⟩` mixes squared lengths in scene units; with our dimensionally consistent
/// `μ_C = a·⟨ℓ⟩`, C = 1 gives splats of about 0.18 mean segment lengths (6.5 cm in the 0.56 m
/// Cornell box, three times the photon map's k-NN radius). C = 0.3 brings the mean bandwidth to the
/// photon map's at equal photons (the paper's protocol), and S = 0.1 had a third of S = 0.4's
/// indirect error against the path tracer on `scenes/cornell-box.usda` at 200k photons.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandwidthParams {
    /// Smoothness C: scales every bandwidth.
    pub smoothness: f32,
    /// Sensitivity S ∈ (0, 1]: how strongly the bandwidth follows the path density.
    pub sensitivity: f32,
    /// Maximum bandwidth R, in mean photon-segment lengths.
    pub max_bandwidth: f32,
    /// Per photon class (direct, indirect, caustic): a factor on C for that class's bandwidths (1
    /// by default; rs-rc narrows its kernels by class, `integrators::rs_rc::SMOOTHNESS`).
    pub class_smoothness: [f32; 3],
    /// A factor on the kernel radii that C and R do not set — the caustic photons' radius at their
    /// hit, from their neighbours ([`adapt_caustic_bandwidths`]): progressive passes shrink it
    /// with C and R (`integrators::passes::shrink`); 1 otherwise.
    pub radius_scale: f32,
}

impl Default for BandwidthParams {
    fn default() -> Self {
        BandwidthParams { smoothness: 0.3, sensitivity: 0.1, max_bandwidth: 0.2, class_smoothness: [1.0; 3], radius_scale: 1.0 }
    }
}

impl BandwidthParams {
    pub fn validate(&self) -> crate::Result<()> {
        use crate::Error;
        if !(self.smoothness.is_finite() && self.smoothness > 0.0 && self.smoothness <= 1e3) {
            return Err(Error::param("smoothness", format!("{} must be in (0, 1000]", self.smoothness)));
        }
        if !(self.sensitivity.is_finite() && self.sensitivity > 0.0 && self.sensitivity <= 1.0) {
            return Err(Error::param("sensitivity", format!("{} must be in (0, 1]", self.sensitivity)));
        }
        if !(self.max_bandwidth.is_finite() && self.max_bandwidth > 0.0 && self.max_bandwidth <= 1e3) {
            return Err(Error::param("max-bandwidth", format!("{} must be in (0, 1000]", self.max_bandwidth)));
        }
        if let Some(f) = self.class_smoothness.iter().find(|f| !(f.is_finite() && **f > 0.0 && **f <= 1e3)) {
            return Err(Error::param("smoothness", format!("a photon class's factor {f} must be in (0, 1000]")));
        }
        if !(self.radius_scale.is_finite() && self.radius_scale > 0.0 && self.radius_scale <= 1.0) {
            return Err(Error::param("smoothness", format!("the kernel radius factor {} must be in (0, 1]", self.radius_scale)));
        }
        Ok(())
    }
}

pub const A: f64 = 0.2;
pub fn m0() -> f64 {
    10f64.powf(5.0 / 6.0)
}

/// The bandwidth model after the pilot phase.
#[derive(Clone, Copy, Debug, Default)]
pub struct Bandwidth {
    /// Scene radius (the length unit of p̃).
    pub unit: f64,
    /// Mean segment length (metres).
    pub mean_length: f64,
    /// D̃² in normalised units.
    pub d2_min: f64,
    /// ⟨r⟩ from the pilot.
    pub mean_r: f64,
    pub sensitivity: f64,
    pub smoothness: f64,
    pub h_min: f64,
    pub h_max: f64,
    /// [`BandwidthParams::radius_scale`].
    pub radius_scale: f64,
}

impl Bandwidth {
    /// Fit from pilot statistics: mean segment length (metres) and the pilot's ln p̃ values.
    pub fn fit(p: &BandwidthParams, unit: f64, mean_length: f64, pilot_ln_p: &[f64]) -> Bandwidth {
        let s = p.sensitivity as f64;
        let mean_r = if pilot_ln_p.is_empty() {
            1.0
        } else {
            pilot_ln_p.iter().map(|&l| (-0.5 * s * l).exp()).sum::<f64>() / pilot_ln_p.len() as f64
        };
        let mean_length = if mean_length > 0.0 { mean_length } else { unit };
        let h_max = p.max_bandwidth as f64 * mean_length;
        Bandwidth {
            unit,
            mean_length,
            d2_min: (0.1 * mean_length / unit).powi(2),
            mean_r: if mean_r.is_finite() && mean_r > 0.0 { mean_r } else { 1.0 },
            sensitivity: s,
            smoothness: p.smoothness as f64,
            h_min: h_max / 100.0,
            h_max,
            radius_scale: p.radius_scale as f64,
        }
    }

    /// `ln D(x, y)` in normalised units for a segment of `length` metres.
    #[inline]
    pub fn ln_d(&self, length: f32) -> f64 {
        let l = length as f64 / self.unit;
        (l * l).max(self.d2_min).ln()
    }

    /// Bandwidth at a vertex with path density `ln_p` for a class of `m` stored photons.
    #[inline]
    pub fn h(&self, ln_p: f64, m: usize) -> f32 {
        self.h_scaled(ln_p, self.h_scale(m))
    }

    /// The factor of [`h`](Self::h) that does not depend on the vertex, `C / M^(1/6) · w`, for a
    /// class of `m` stored photons (once per class, not per vertex: two `powf`s).
    pub fn h_scale(&self, m: usize) -> f64 {
        let mu_c = A * self.mean_length;
        let w = m0() * mu_c / self.mean_r;
        self.smoothness / (m.max(1) as f64).powf(1.0 / 6.0) * w
    }

    /// [`h`](Self::h) given its [`h_scale`](Self::h_scale) (the same value, bit for bit).
    #[inline]
    pub fn h_scaled(&self, ln_p: f64, scale: f64) -> f32 {
        let r = (-0.5 * self.sensitivity * ln_p).exp();
        let h = scale * r;
        let h = if h.is_finite() { h } else { self.h_max };
        h.clamp(self.h_min, self.h_max) as f32
    }
}

/// Neighbours that set a caustic photon's bandwidth at its hit (see [`adapt_caustic_bandwidths`]).
pub const CAUSTIC_NEIGHBOURS: usize = 64;

/// Caustic photons (light → specular surfaces → diffuse hit): the bandwidth at the hit becomes the
/// distance to the [`CAUSTIC_NEIGHBOURS`]-th nearest other caustic hit, clamped to
/// `[h_min, h_max]` — a sample-point adaptive kernel. The path density p̃ of Eq. 7 takes no factor
/// at specular vertices, so it does not see a lens or a curved mirror focusing light: with Eq. 8
/// alone a caustic gets the bandwidth of unfocused light and is smeared over its surroundings
/// (docs/architecture.md, "Caustic bandwidth"). The ray's cone keeps its radius at
/// the origin where that is smaller and reaches the new radius at the hit. The neighbour distance
/// is scaled by [`BandwidthParams::radius_scale`], as C and R scale the other kernels.
pub fn adapt_caustic_bandwidths(set: &mut super::PhotonSet) {
    use crate::kdtree::{BuildParams, KdTree, KnnHeap};
    use rayon::prelude::*;
    let k = super::PhotonClass::Caustic as usize;
    let (bw, rays, ends) = (set.bandwidth, &mut set.rays[k], &set.ends_diffuse[k]);
    let idx: Vec<usize> = (0..rays.len()).filter(|&i| ends[i]).collect();
    if idx.len() <= CAUSTIC_NEIGHBOURS {
        return;
    }
    let pts: Vec<glam::Vec3> = idx.iter().map(|&i| rays[i].end()).collect();
    let Ok(tree) = KdTree::build(&pts, &BuildParams::default()) else { return };
    let (h_min, h_max, scale) = (bw.h_min as f32, bw.h_max as f32, bw.radius_scale as f32);
    let radii: Vec<f32> = pts
        .par_iter()
        .map_init(KnnHeap::new, |heap, p| tree.knn(*p, CAUSTIC_NEIGHBOURS + 1, h_max / scale, heap).sqrt() * scale)
        .collect();
    for (&i, r) in idx.iter().zip(radii) {
        let ray = &mut rays[i];
        let h_end = if r.is_finite() { r.clamp(h_min, h_max) } else { h_max };
        let h0 = ray.h0.min(h_end);
        ray.h0 = h0;
        ray.dh = if ray.length > 0.0 { (h_end - h0) / ray.length } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The light pass computes each class's factor once (`h_scale`) and each vertex's bandwidth
    /// from it (`h_scaled`): the same bits as Eq. 8 evaluated whole (`h`), clamps included.
    #[test]
    fn per_class_factor_gives_the_same_bandwidths() {
        let p = BandwidthParams { smoothness: 0.37, sensitivity: 0.3, max_bandwidth: 0.2, ..BandwidthParams::default() };
        let pilot: Vec<f64> = (0..200).map(|i| -3.0 + 0.07 * i as f64).collect();
        let bw = Bandwidth::fit(&p, 2.5, 0.8, &pilot);
        let mut clamped = [false, false];
        for m in [1usize, 20_000, 180_000, 1 << 24] {
            let scale = bw.h_scale(m);
            for i in 0..400 {
                let ln_p = -60.0 + 0.31 * i as f64;
                let h = bw.h(ln_p, m);
                assert_eq!(h.to_bits(), bw.h_scaled(ln_p, scale).to_bits(), "m {m}, ln p {ln_p}");
                clamped[0] |= h == bw.h_min as f32;
                clamped[1] |= h == bw.h_max as f32;
            }
        }
        assert!(clamped[0] && clamped[1], "the range covers both clamps: {clamped:?}");
    }
}
