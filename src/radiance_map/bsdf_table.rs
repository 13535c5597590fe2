//! BSDFs projected to spherical harmonics in a precomputed table over discrete outgoing directions
//! (§8.1). An isotropic BSDF's lobe for outgoing direction `wo = (sin θo, 0, cos θo)` (local frame)
//! is projected once per `cos θo` bin; any other `wo` is the same lobe turned by its azimuth φo.
//!
//! The radiance coefficients carry the cosine (§8.1: "we encode cos θ in the radiance SH
//! coefficients rather than in the BRDF coefficients"), and they vanish below the surface, so the
//! BSDF may take any value there: we project its *even extension* `f(x, y, |z|)`, which removes the
//! step at the horizon (the Lambert part becomes the single coefficient of a constant, exactly).
//!
//! The final integral is `Σ_k F_k C'_k` of the BSDF coefficients `F` (local frame, interpolated
//! linearly between bins) and the radiance coefficients turned into the local frame: `C'` holds
//! the coefficients of `d ↦ C(R d)`, `R` = shading frame ∘ azimuth rotation, from the band matrices
//! of [`crate::sh::ShRotation`]. (It was `Σ_q w_q F(d_q) C(R d_q)` with the exact product quadrature of
//! [`crate::sh::quadrature`]: the same value, several times the arithmetic.)

use crate::sh::{eval, rotate_even_yz, EvenGrid, EVEN_YZ, N};
use crate::bsdf::{AbMemo, Bsdf};
use crate::eye::{GlossyLobe, GlossyTable};
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// `cos θo` bins of a table.
pub const BINS: usize = 32;
/// Projection grid per bin (cos θ × φ over the sphere).
const GRID: (usize, usize) = (96, 192);

/// One BSDF's table: per `cos θo` bin, the lobe's coefficients (RGB). A table shared by BSDFs that
/// differ only in their diffuse factor `kd` (a textured diffuse colour, see
/// [`Bsdf::diffuse_split`]) holds the lobe of `kd = 0` and, separately, the lobe per unit `kd`.
pub struct BsdfShTable {
    /// `BINS` coefficient sets (with `kd_coeffs`: those of `kd = 0`).
    pub coeffs: Vec<[Vec3; N]>,
    /// `BINS` coefficient sets of the lobe per unit `kd` (`f₁ − f₀`), or empty.
    pub(super) kd_coeffs: Vec<[Vec3; N]>,
    /// How much of the lobe bands 0–3 misplace ([`sh_residual`]) for the table's sample with the
    /// darkest diffuse factor (set by [`ShTables::build`]; 0 for a table built alone).
    pub residual: f32,
}

/// A projected lobe: its coefficients per bin.
struct Projection {
    coeffs: Vec<[Vec3; N]>,
}

/// The share of a BSDF's reflected light that its SH projection (bands 0–3) misplaces:
/// `Σ ∫ |f − f_SH| cos θi dωi / Σ ∫ f cos θi dωi` over the upper hemisphere, summed over 8
/// outgoing directions (`cos θo` bins) and RGB. It bounds the relative error of the SH integration
/// for incoming light that is uniform up to a factor `k` by about `k` times itself: 0 for
/// Lambert, small for rough lobes, near 1 for sharp ones.
pub fn sh_residual(bsdf: &Bsdf) -> f32 {
    const BINS_R: usize = 8;
    let grid = EvenGrid::new(48, 96);
    let (mut miss, mut total) = (0.0f64, 0.0f64);
    for i in 0..BINS_R {
        let cz = (i as f32 + 0.5) / BINS_R as f32;
        let wo = Vec3::new((1.0 - cz * cz).sqrt(), 0.0, cz);
        let at = bsdf.at(wo);
        let mut memo = AbMemo::default();
        let mut f_at = Vec::with_capacity(grid.len());
        let c = grid.project_rgb(|d| {
            let f = at.eval_memo(Vec3::new(d.x, d.y, d.z.abs()), &mut memo);
            f_at.push(f);
            f
        });
        // the quarter grid's directions lie in the upper hemisphere (z > 0); both f and its
        // projection are even in y, so each stands for two directions of equal cos θi
        for (d, f) in grid.dirs().iter().zip(&f_at) {
            let y = eval(*d);
            let f_sh = c.iter().zip(&y).fold(Vec3::ZERO, |a, (c, y)| a + *c * *y);
            miss += ((*f - f_sh).abs().element_sum() * d.z) as f64;
            total += (f.element_sum() * d.z) as f64;
        }
    }
    if total > 0.0 {
        (miss / total) as f32
    } else {
        0.0
    }
}

/// The coefficients of `bsdf`'s lobe per bin.
fn project_lobes(bsdf: &Bsdf) -> Projection {
    let grid = EvenGrid::new(GRID.0, GRID.1);
    // the bins in parallel (a scene with one glossy material has one table to build)
    let coeffs = (0..BINS)
        .into_par_iter()
        .map(|i| {
            let cz = (i as f32 + 0.5) / BINS as f32;
            let wo = Vec3::new((1.0 - cz * cz).sqrt(), 0.0, cz);
            // isotropic, with wo in the xz plane: the even extension is even in y and in z. The
            // per-`wo` work once per bin, the albedo-table lookup at `cos θi` once per grid row
            // (the same values as `bsdf.eval(wo, wi)`, bit for bit).
            let at = bsdf.at(wo);
            let mut memo = AbMemo::default();
            grid.project_rgb(|d| at.eval_memo(Vec3::new(d.x, d.y, d.z.abs()), &mut memo))
        })
        .collect();
    Projection { coeffs }
}

impl BsdfShTable {
    /// Project `b`'s lobe for every `cos θo` bin.
    pub fn new(b: &Bsdf) -> BsdfShTable {
        let Projection { coeffs } = project_lobes(b);
        BsdfShTable { coeffs, kd_coeffs: Vec::new(), residual: 0.0 }
    }

    /// The table of every BSDF that equals `b` but for its diffuse factor: two projections, of
    /// `kd = 0` and `kd = 1`. Falls back to [`new`](Self::new)'s single projection for BSDFs
    /// without a diffuse factor.
    pub fn any_diffuse(b: &Bsdf) -> BsdfShTable {
        let Some((_, b0, b1)) = b.diffuse_split() else { return Self::new(b) };
        let (p0, p1) = rayon::join(|| project_lobes(&b0), || project_lobes(&b1));
        let kd_coeffs = p1.coeffs.iter().zip(&p0.coeffs).map(|(a, b)| std::array::from_fn(|k| a[k] - b[k])).collect();
        BsdfShTable { coeffs: p0.coeffs, kd_coeffs, residual: 0.0 }
    }

    pub fn bytes(&self) -> u64 {
        ((self.coeffs.len() + self.kd_coeffs.len()) * N * std::mem::size_of::<Vec3>()) as u64
    }

    /// `∫ f(ω, wo) C(ω) dω` for the glossy sample `g` and world-frame radiance coefficients `c`
    /// (cosine included), band-limited to bands 0–3.
    pub fn integrate(&self, g: &GlossyLobe, c: &[Vec3; N]) -> Vec3 {
        let wo = g.wo;
        let cz = wo.z.abs().clamp(0.0, 1.0);
        let x = (cz * BINS as f32 - 0.5).clamp(0.0, (BINS - 1) as f32);
        let i0 = (x as usize).min(BINS - 2);
        let t = x - i0 as f32;
        let (cphi, sphi) = {
            let r = (wo.x * wo.x + wo.y * wo.y).sqrt();
            if r > 1e-7 {
                (wo.x / r, wo.y / r)
            } else {
                (1.0, 0.0)
            }
        };
        // local (lobe at φo = 0) → local (φo) → world
        let rz = Mat3::from_cols(Vec3::new(cphi, sphi, 0.0), Vec3::new(-sphi, cphi, 0.0), Vec3::Z);
        let frame = Mat3::from_cols(g.frame.s, g.frame.t, g.frame.n);
        let r = frame * rz;
        // the incoming light in the lobe's frame, at the coefficients the lobe has (the others
        // are 0 exactly: see `EVEN_YZ`; skipping them leaves the sum as it was, bit for bit)
        let local = rotate_even_yz(r, c);
        let (f0, f1) = (&self.coeffs[i0], &self.coeffs[i0 + 1]);
        let mut sum = Vec3::ZERO;
        match (self.kd_coeffs.is_empty(), g.bsdf.diffuse_factor()) {
            (false, Some(kd)) => {
                let (k0, k1) = (&self.kd_coeffs[i0], &self.kd_coeffs[i0 + 1]);
                for (&k, l) in EVEN_YZ.iter().zip(&local) {
                    let f = f0[k] * (1.0 - t) + f1[k] * t + kd * (k0[k] * (1.0 - t) + k1[k] * t);
                    sum += f * *l;
                }
            }
            _ => {
                for (&k, l) in EVEN_YZ.iter().zip(&local) {
                    sum += (f0[k] * (1.0 - t) + f1[k] * t) * *l;
                }
            }
        }
        sum
    }
}

/// The tables of the distinct BSDFs of a set of glossy eye samples (`Default`: none).
#[derive(Default)]
pub struct ShTables {
    pub tables: Vec<BsdfShTable>,
    /// Table index per glossy sample.
    pub table_of: Vec<u32>,
}

impl ShTables {
    /// One table per distinct BSDF up to its diffuse factor (bit-identical parameters otherwise,
    /// compared through the exact `Debug` form of the BSDF with `kd = 0`): an untextured material
    /// gets one table; a textured diffuse colour still one (holding the lobe per unit `kd`);
    /// textured roughness one per distinct value. Neighbouring glossy samples mostly share a
    /// material, so a sample equal to the previous one takes its table without formatting its key.
    pub fn build(glossy: &GlossyTable) -> ShTables {
        Self::build_where(glossy, usize::MAX, |_| true).expect("no cap")
    }

    /// [`build`](Self::build), projecting only the lobes whose [`sh_residual`] `project` accepts
    /// (the others get an empty table, which must not be integrated), or `None` (nothing
    /// projected) when the samples need more than `max_tables` tables.
    pub fn build_where(glossy: &GlossyTable, max_tables: usize, project: impl Fn(f32) -> bool + Sync) -> Option<ShTables> {
        let key_bsdf = |b: &Bsdf| b.diffuse_split().map_or(*b, |(_, b0, _)| b0);
        let mut index: HashMap<String, u32> = HashMap::new();
        // per table: its first sample and whether its samples' diffuse factors differ; and its
        // sample with the darkest diffuse factor (the one whose lobe SH holds worst)
        let mut firsts: Vec<(usize, bool)> = Vec::new();
        let mut darkest: Vec<(usize, f32)> = Vec::new();
        let kd_sum = |b: &Bsdf| b.diffuse_factor().map_or(0.0, |k| k.element_sum());
        const KNOWN_KEYS: usize = 8;
        let mut known: Vec<(Bsdf, u32)> = Vec::with_capacity(KNOWN_KEYS);
        // Samples of one material follow each other in pixel order, with the same key (the BSDF
        // up to its diffuse factor, which a textured diffuse colour varies from sample to sample):
        // only the first sample of each run of equal keys is looked up (the runs found in
        // parallel), the others take its table. Each run's darkest sample (the first of equal
        // ones) and whether its diffuse factors differ are found in parallel too.
        let same_key = |a: &Bsdf, b: &Bsdf| match (a, b) {
            (Bsdf::Preview(a), Bsdf::Preview(b)) => a.same_but_diffuse(b),
            _ => a == b,
        };
        let heads: Vec<usize> = (0..glossy.len()).into_par_iter().filter(|&i| i == 0 || !same_key(glossy.bsdf(i), glossy.bsdf(i - 1))).collect();
        let run_end = |k: usize| heads.get(k + 1).copied().unwrap_or(glossy.len());
        // per run: (its darkest sample, its diffuse factor sum, whether its diffuse factors differ)
        let runs: Vec<(usize, f32, bool)> = (0..heads.len())
            .into_par_iter()
            .map(|k| {
                let (i0, kd0) = (heads[k], glossy.bsdf(heads[k]).diffuse_factor());
                let (mut dark, mut dark_sum, mut varies) = (i0, kd_sum(glossy.bsdf(i0)), false);
                for i in i0 + 1..run_end(k) {
                    let kd = glossy.bsdf(i).diffuse_factor();
                    if kd != kd0 {
                        varies = true;
                        let sum = kd_sum(glossy.bsdf(i));
                        if sum < dark_sum {
                            (dark, dark_sum) = (i, sum);
                        }
                    }
                }
                (dark, dark_sum, varies)
            })
            .collect();
        let mut head_table = Vec::with_capacity(heads.len());
        for (&i, &(dark, dark_sum, run_varies)) in heads.iter().zip(&runs) {
            let g = glossy.bsdf(i);
            let key = key_bsdf(g);
            // the tables of the first few keys are found by comparison (formatting a key for the
            // index costs a microsecond, and samples of a few materials alternate in pixel order)
            let t = match known.iter().find(|(b, _)| *b == key) {
                Some(&(_, t)) => t,
                None => {
                    let t = *index.entry(format!("{key:?}")).or_insert_with(|| {
                        firsts.push((i, false));
                        darkest.push((i, kd_sum(g)));
                        (firsts.len() - 1) as u32
                    });
                    if known.len() < KNOWN_KEYS {
                        known.push((key, t));
                    }
                    t
                }
            };
            let (first, varies) = &mut firsts[t as usize];
            *varies |= run_varies || glossy.bsdf(*first).diffuse_factor() != g.diffuse_factor();
            if *varies && dark_sum < darkest[t as usize].1 {
                darkest[t as usize] = (dark, dark_sum);
            }
            head_table.push(t);
            if firsts.len() > max_tables {
                return None;
            }
        }
        let mut table_of = vec![0u32; glossy.len()];
        for (k, (&i, &t)) in heads.iter().zip(&head_table).enumerate() {
            table_of[i..run_end(k)].fill(t);
        }
        let tables = firsts
            .par_iter()
            .zip(&darkest)
            .map(|(&(i, varies), &(dark, _))| {
                let residual = sh_residual(glossy.bsdf(dark));
                let mut t = match (project(residual), varies) {
                    (false, _) => BsdfShTable { coeffs: Vec::new(), kd_coeffs: Vec::new(), residual },
                    (true, true) => BsdfShTable::any_diffuse(glossy.bsdf(i)),
                    (true, false) => BsdfShTable::new(glossy.bsdf(i)),
                };
                t.residual = residual;
                t
            })
            .collect();
        Some(ShTables { tables, table_of })
    }

    /// [`BsdfShTable::integrate`] for glossy sample number `index`.
    pub fn integrate(&self, index: usize, g: &GlossyLobe, c: &[Vec3; N]) -> Vec3 {
        self.tables[self.table_of[index] as usize].integrate(g, c)
    }

    pub fn bytes(&self) -> u64 {
        self.tables.iter().map(|t| t.bytes()).sum::<u64>() + self.table_of.len() as u64 * 4
    }
}

#[cfg(test)]
mod tests;
