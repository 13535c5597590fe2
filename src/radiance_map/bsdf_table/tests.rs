//! Tests of the BSDF tables: exact integration of band-limited light, tables shared over diffuse
//! factors and across runs of materials, the residual that ranks lobes, and the six coefficients an
//! isotropic lobe holds.

use super::*;
use crate::bsdf::{Bsdf, SurfaceParams};
use crate::eye::{GlossySample, GlossyTable};
use crate::sampling::Frame;
use crate::sh::{project_rgb, reconstruct_rgb, ShRotation};
use glam::{Mat3, Vec3};

fn glossy(roughness: f32, wo: Vec3, n: Vec3) -> GlossySample {
    let b = Bsdf::from_preview_surface(&SurfaceParams::coat(Vec3::new(0.5, 0.3, 0.2), Vec3::ONE, false, roughness));
    GlossySample { bsdf: b.at(wo.normalize()), frame: Frame::from_normal(n) }
}

#[test]
fn lambert_needs_one_coefficient_and_integrates_exactly() {
    // a Lambertian BSDF against the cosine-encoded radiance of a uniform sky: ∫ ρ/π · cos = ρ
    let g = GlossySample { bsdf: Bsdf::lambert(Vec3::new(0.8, 0.5, 0.2)).at(Vec3::new(0.3, 0.1, 0.9).normalize()), frame: Frame::from_normal(Vec3::Z) };
    let t = BsdfShTable::new(g.bsdf.bsdf());
    for c in &t.coeffs {
        for v in &c[1..] {
            assert!(v.abs().max_element() < 5e-4, "higher coefficients of Lambert: {v}");
        }
    }
    let n = Vec3::new(0.2, -0.4, 0.9).normalize();
    let g = GlossySample { frame: Frame::from_normal(n), ..g };
    let cosine = project_rgb(|d| Vec3::splat(d.dot(n).max(0.0)), 400, 800);
    let l = t.integrate(&g.lobe(), &cosine);
    assert!((l - Vec3::new(0.8, 0.5, 0.2)).abs().max_element() < 3e-3, "{l}");
}

#[test]
fn glossy_table_matches_the_exact_integral_of_band_limited_light() {
    // light = an SH-band-limited cosine-weighted radiance; exact ∫ f·C by fine numerical
    // integration of the BSDF must match the table's integral in any frame and azimuth
    let c: [Vec3; N] = std::array::from_fn(|k| Vec3::new(0.5, 0.4, 0.3) * ((k as f32 * 0.9).cos() * 0.5 + if k == 0 { 2.0 } else { 0.0 }));
    for (wo, n) in [(Vec3::new(0.4, 0.2, 0.9), Vec3::Z), (Vec3::new(-0.7, 0.5, 0.3), Vec3::new(0.3, 0.3, 0.9).normalize()), (Vec3::new(0.0, 0.0, 1.0), Vec3::new(-1.0, 0.0, 0.1).normalize())] {
        let g = glossy(0.6, wo, n);
        let t = BsdfShTable::new(g.bsdf.bsdf());
        // exact: ∫ f_even(local) C(world) over the sphere with a fine grid (only bands 0–3 of f matter)
        let exact = project_rgb(|d| g.bsdf.eval(Vec3::new(d.x, d.y, d.z.abs())) * reconstruct_rgb(&c, g.frame.to_world(d)), 256, 512)[0] / crate::sh::eval(Vec3::Z)[0];
        let got = t.integrate(&g.lobe(), &c);
        let rel = ((got - exact).abs() / exact.abs().max(Vec3::splat(1e-3))).max_element();
        // differences: the band-limiting of f (exact includes its higher bands against C's
        // bands 0–3 — zero by orthogonality) and the cos θo bin interpolation
        assert!(rel < 0.03, "wo {wo}: table {got} vs exact {exact}");
    }
}


#[test]
fn the_quarter_projection_of_an_even_function_equals_the_full_one() {
    // even in y and z, not in x, with every band present
    let f = |d: Vec3| Vec3::new(1.0 + d.x + d.y * d.y, (d.x * d.z).abs() + d.z * d.z * d.x, (3.0 * d.x).exp() * (1.0 + d.y.abs()));
    let full = project_rgb(f, 48, 96);
    let quarter = crate::sh::project_rgb_even_yz(f, 48, 96);
    for (a, b) in full.iter().zip(&quarter) {
        assert!((*a - *b).abs().max_element() < 1e-5 * (1.0 + a.abs().max_element()), "{a} vs {b}");
    }
    // and the odd coefficients in y or z vanish
    assert!(quarter[1].abs().max_element() < 1e-6 && quarter[2].abs().max_element() < 1e-6);
}

#[test]
fn a_textured_diffuse_colour_shares_one_table() {
    // samples of one material with per-texel diffuse colours: one table for all, and each sample's
    // integral equals that of a table of its own BSDF
    let c: [Vec3; N] = std::array::from_fn(|k| Vec3::new(0.5, 0.4, 0.3) * ((k as f32 * 0.7).sin() * 0.4 + if k == 0 { 2.0 } else { 0.0 }));
    let at = |diffuse: Vec3, wo: Vec3| {
        let mut g = glossy(0.4, wo, Vec3::new(0.2, 0.1, 0.95).normalize());
        let p = SurfaceParams {
            diffuse,
            specular: Vec3::ONE,
            use_specular_workflow: false,
            metallic: 0.0,
            roughness: 0.4,
            clearcoat: 0.5,
            clearcoat_roughness: 0.2,
            opacity: 1.0,
            ior: 1.5,
            ..SurfaceParams::default()
        };
        g.bsdf = Bsdf::from_preview_surface(&p).at(wo.normalize());
        g
    };
    let samples: Vec<GlossySample> = [(Vec3::new(0.9, 0.1, 0.1), Vec3::new(0.3, 0.2, 0.9)), (Vec3::new(0.1, 0.8, 0.3), Vec3::new(-0.5, 0.1, 0.6)), (Vec3::new(0.9, 0.1, 0.1), Vec3::new(0.1, 0.7, 0.4))]
        .iter()
        .map(|&(d, wo)| at(d, wo))
        .collect();
    let tables = ShTables::build(&GlossyTable::from_samples(samples.iter().copied()));
    assert_eq!(tables.tables.len(), 1);
    for (i, g) in samples.iter().enumerate() {
        let own = BsdfShTable::new(g.bsdf.bsdf()).integrate(&g.lobe(), &c);
        let shared = tables.integrate(i, &g.lobe(), &c);
        assert!((own - shared).abs().max_element() < 1e-3 * own.abs().max_element(), "{own} vs {shared}");
    }
}

/// The tables of interleaved runs of two materials, one with a per-texel diffuse colour, the
/// other untextured, against a brute-force scan: one table per material, every sample on its
/// material's, the textured one holding the lobe per unit diffuse factor, and each table's
/// residual that of its darkest sample (the first of equally dark ones).
#[test]
fn tables_follow_materials_across_runs_and_take_their_darkest_sample() {
    let textured = |d: f32| {
        let b = Bsdf::from_preview_surface(&SurfaceParams::coat(Vec3::new(d, 0.8 * d, 0.6 * d), Vec3::ONE, false, 0.5));
        GlossySample { bsdf: b.at(Vec3::new(0.2, 0.1, 0.9).normalize()), frame: Frame::from_normal(Vec3::Z) }
    };
    let plain = || glossy(0.7, Vec3::new(0.1, 0.3, 0.9), Vec3::Z);
    // (material, diffuse level): runs of both, the textured one darkest twice (the first counts)
    let layout = [(0, 0.6), (0, 0.6), (1, 0.0), (0, 0.3), (0, 0.9), (1, 0.0), (1, 0.0), (0, 0.1), (0, 0.5), (0, 0.1), (1, 0.0), (0, 0.6)];
    let samples: Vec<GlossySample> = layout.iter().map(|&(m, d)| if m == 0 { textured(d) } else { plain() }).collect();
    let tables = ShTables::build(&GlossyTable::from_samples(samples.iter().copied()));
    assert_eq!(tables.tables.len(), 2);
    for (i, &(m, _)) in layout.iter().enumerate() {
        assert_eq!(tables.table_of[i], m, "sample {i}");
    }
    assert!(!tables.tables[0].kd_coeffs.is_empty() && tables.tables[1].kd_coeffs.is_empty());
    let darkest = (0..layout.len()).filter(|&i| layout[i].0 == 0).fold(0, |a, i| if layout[i].1 < layout[a].1 { i } else { a });
    assert_eq!(darkest, 7);
    // (a darker diffuse layer leaves more of the lobe to the coat, which SH holds worse)
    assert!(sh_residual(textured(0.1).bsdf.bsdf()) > sh_residual(textured(0.3).bsdf.bsdf()));
    assert_eq!(tables.tables[0].residual, sh_residual(samples[darkest].bsdf.bsdf()));
    assert_eq!(tables.tables[1].residual, sh_residual(samples[2].bsdf.bsdf()));
}

/// `sh_residual` ranks lobes by how well bands 0–3 hold them: Lambert exactly, the rough coated
/// walls of `cornell-box.usda` (roughness 1, specular colour 0, the darkest wall's diffuse colour)
/// within `GlossyMode::Auto`'s bound, a roughness-0.3 coat and Crytek Sponza's 0.41 far outside it,
/// and rougher lobes no worse than sharper ones.
#[test]
fn sh_residual_separates_rough_lobes_from_sharp_ones() {
    use crate::radiance_map::SH_RESIDUAL_MAX;
    let lambert = sh_residual(&Bsdf::lambert(Vec3::splat(0.7)));
    assert!(lambert < 1e-3, "Lambert misplaces {lambert}");
    let green = sh_residual(&Bsdf::from_preview_surface(&SurfaceParams::coat(Vec3::new(0.12, 0.45, 0.15), Vec3::ZERO, true, 1.0)));
    assert!(green < SH_RESIDUAL_MAX, "rough wall misplaces {green}");
    let sharp = sh_residual(glossy(0.3, Vec3::Z, Vec3::Z).bsdf.bsdf());
    let sponza = sh_residual(glossy(0.408, Vec3::Z, Vec3::Z).bsdf.bsdf());
    assert!(sharp > 3.0 * SH_RESIDUAL_MAX && sponza > 3.0 * SH_RESIDUAL_MAX, "sharp coats misplace {sharp}, {sponza}");
    let by_roughness: Vec<f32> = [0.3, 0.5, 0.7, 1.0].iter().map(|&r| sh_residual(glossy(r, Vec3::Z, Vec3::Z).bsdf.bsdf())).collect();
    assert!(by_roughness.windows(2).all(|w| w[1] <= w[0] * 1.05), "not decreasing with roughness: {by_roughness:?}");
}

/// An isotropic lobe's table holds coefficients only at the basis functions even in `y` and `z`
/// (`EVEN_YZ`): the others are 0 exactly, so the final integration may skip them. Checked on a
/// rough and a sharp coat and on a table shared over diffuse factors (`kd_coeffs`); and the
/// integral over those six equals the sum over all sixteen with the full rotation, bit for bit.
#[test]
fn lobe_tables_are_even_in_y_and_z_and_integrate_over_those_coefficients() {
    use crate::sh::EVEN_YZ;
    let c: [Vec3; N] = std::array::from_fn(|k| Vec3::new(0.5, 0.4, 0.3) * ((k as f32 * 0.9).cos() * 0.5 + if k == 0 { 2.0 } else { 0.0 }));
    for roughness in [1.0, 0.3] {
        let g = glossy(roughness, Vec3::new(-0.7, 0.5, 0.3), Vec3::new(0.3, 0.3, 0.9).normalize());
        for t in [BsdfShTable::new(g.bsdf.bsdf()), BsdfShTable::any_diffuse(g.bsdf.bsdf())] {
            assert!(!t.kd_coeffs.is_empty() || t.coeffs.len() == BINS);
            for bin in t.coeffs.iter().chain(&t.kd_coeffs) {
                for k in (0..N).filter(|k| !EVEN_YZ.contains(k)) {
                    assert!(bin[k] == Vec3::ZERO, "roughness {roughness}: coefficient {k} = {}", bin[k]);
                }
                assert!(EVEN_YZ[1..].iter().any(|&k| bin[k] != Vec3::ZERO), "roughness {roughness}: a lobe with no shape");
            }
            // the same sum over all 16 coefficients, with the full rotation
            let wo = g.bsdf.wo();
            let x = (wo.z.abs() * BINS as f32 - 0.5).clamp(0.0, (BINS - 1) as f32);
            let (i0, tt) = ((x as usize).min(BINS - 2), x - (x as usize).min(BINS - 2) as f32);
            let r = (wo.x * wo.x + wo.y * wo.y).sqrt();
            let rz = Mat3::from_cols(Vec3::new(wo.x / r, wo.y / r, 0.0), Vec3::new(-wo.y / r, wo.x / r, 0.0), Vec3::Z);
            let local = ShRotation::new(Mat3::from_cols(g.frame.s, g.frame.t, g.frame.n) * rz).apply(&c);
            let kd = g.bsdf.bsdf().diffuse_factor().filter(|_| !t.kd_coeffs.is_empty());
            let mut want = Vec3::ZERO;
            for k in 0..N {
                let lobe = |cs: &[[Vec3; N]]| cs[i0][k] * (1.0 - tt) + cs[i0 + 1][k] * tt;
                let f = match kd {
                    Some(kd) => lobe(&t.coeffs) + kd * lobe(&t.kd_coeffs),
                    None => lobe(&t.coeffs),
                };
                want += f * local[k];
            }
            assert_eq!(t.integrate(&g.lobe(), &c), want, "roughness {roughness}");
        }
    }
}
