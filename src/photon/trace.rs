//! Tracing photon paths: emission by power, BSDF importance sampling in importance mode, Russian
//! roulette, classification of segments, and the pilot phase of the bandwidth model.

use super::guide::{EmissionGuide, PathStart};
use super::{Bandwidth, PhotonClass, PhotonRay, PhotonSet, PhotonSettings};
use crate::bsdf::TransportMode;
use crate::embree::{self, Ray};
use crate::prepare::PreparedScene;
use crate::{Error, Result};
use crate::sampling::{hash, oct_encode, Frame, Rng};
use glam::Vec3;
use rayon::prelude::*;

const PHOTON_STREAM: u64 = 0x5048_4f54; // "PHOT"
const PILOT_STREAM: u64 = 0x5049_4c54; // "PILT"
/// Paths per parallel work item (fixed: the result never depends on the thread count).
const CHUNK: usize = 256;

/// One traced segment before bandwidths are assigned.
#[derive(Clone, Copy)]
struct Segment {
    origin: Vec3,
    dir: Vec3,
    length: f32,
    flux: Vec3,
    class: PhotonClass,
    ends_diffuse: bool,
    /// Whether the ray splats: it ends on a diffuse or glossy surface, on one that scatters nothing,
    /// or (with [`PhotonSettings::reach`]) it leaves the scene.
    splats: bool,
    /// The ray left the scene (its length reaches the scene's bounding sphere, not a surface).
    escapes: bool,
    n_hit: Vec3,
    n_origin: Vec3,
    /// ln p̃ at the start vertex (`None` at the light: h = 0) and at the end vertex.
    ln_p_start: Option<f64>,
    ln_p_end: f64,
}

fn lum(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// What the paths of a batch share besides the scene and the settings.
#[derive(Clone, Copy)]
struct Tracing<'a> {
    stream: u64,
    /// Length unit of the path densities (the scene radius).
    unit: f64,
    bw: &'a Bandwidth,
    guide: Option<&'a EmissionGuide>,
    /// The indirect class already holds its budget: a path ends at its first vertex that cannot
    /// continue it specularly (a non-specular BSDF, or a non-specular sample). Every later segment
    /// would be indirect, so none of them could be stored: a path stores what the whole path
    /// would. The guide keeps the indirect yield it learned until the class filled (these paths
    /// end before any indirect segment), so where a guide is in use its later paths may start
    /// elsewhere than with a guide that went on learning it.
    indirect_full: bool,
}

/// Distance along the unit direction `d` from `o` to where the ray leaves the bounding sphere of
/// the box `b` (0 if it never is inside). The sphere, not the box: a ray that passes the edge of a
/// flat scene leaves its box at once, before it passes the eye samples beside that edge.
fn exit_distance(b: (Vec3, Vec3), o: Vec3, d: Vec3) -> f32 {
    let (c, r) = (0.5 * (b.0 + b.1), 0.5 * (b.1 - b.0).length());
    let oc = o - c;
    let half_b = oc.dot(d);
    let disc = half_b * half_b - (oc.length_squared() - r * r);
    let t = -half_b + disc.max(0.0).sqrt();
    if disc > 0.0 && t.is_finite() { t.max(0.0) } else { 0.0 }
}

/// Trace path `j` of `t.stream`, appending its segments to `out`; with a guide, the position
/// sample is drawn from it (flux divided by, path density multiplied by its density) and the start
/// is returned for learning.
fn trace_path(scene: &PreparedScene, s: &PhotonSettings, t: &Tracing, j: u64, out: &mut Vec<Segment>) -> Option<PathStart> {
    let (stream, unit, bw, guide) = (t.stream, t.unit, t.bw, t.guide);
    let lights = &scene.lights;
    let mut rng = Rng::new(hash(&[s.seed, stream, j]), 0);
    let (li, pmf) = lights.choose(rng.next_f32())?;
    let (u1, u2) = (rng.next_2d(), rng.next_2d());
    let start = guide.map(|g| g.warp(li, u1, u2));
    let (u1, q) = start.map_or((u1, 1.0), |st| (st.u, st.q));
    let es = lights.emitters[li].sample_le(u1, u2, &lights.scene_box, &scene.textures)?;
    let mut flux = es.weight / (pmf * q);
    if !(flux.is_finite() && flux.max_element() > 0.0) {
        return None;
    }
    let mut ln_p = ((pmf as f64) * (es.pdf_pos as f64) * (q as f64) * unit * unit * (es.pdf_dir as f64)).max(1e-300).ln();
    let mut ln_p_start: Option<f64> = None;
    let mut ray = Ray::new(es.pos, es.dir);
    // Lights are not surfaces: any point ahead of the emission point is "in front".
    let mut n_origin = es.dir;
    let mut specular_only = true;
    let mut specular_last = false;
    for depth in 0..s.max_depth {
        let class = if depth == 0 {
            PhotonClass::Direct
        } else if specular_only {
            PhotonClass::Caustic
        } else {
            PhotonClass::Indirect
        };
        let Some(hit) = scene.intersect(&ray) else {
            // A ray leaving the scene still passes the eye samples along its way: stored as far
            // as the scene's bounding sphere (as if a surface facing it were there), it splats
            // on them.
            let length = if s.reach.is_some() && !specular_last { exit_distance(scene.bounds, ray.org, ray.dir) } else { 0.0 };
            if length > 0.0 {
                out.push(Segment {
                    origin: ray.org,
                    dir: ray.dir,
                    length,
                    flux,
                    class,
                    ends_diffuse: false,
                    splats: true,
                    escapes: true,
                    n_hit: -ray.dir,
                    n_origin,
                    ln_p_start,
                    ln_p_end: ln_p - bw.ln_d(length),
                });
            }
            break;
        };
        if !specular_last {
            ln_p -= bw.ln_d(hit.t);
        }
        let bsdf = scene.bsdf(&hit);
        let flags = bsdf.flags();
        let ends_diffuse = flags.is_diffuse() || flags.is_glossy();
        // A surface that scatters nothing (black) ends the path; the ray splats on its way there
        // like one that ends on a white wall (the eye samples it passes near a silhouette would
        // miss its light). A ray that ends on a specular surface does not: its light goes on along
        // the next segment (see `photon_ray`).
        let absorbed = flags == crate::bsdf::BsdfFlags::EMPTY;
        out.push(Segment {
            origin: ray.org,
            dir: ray.dir,
            length: hit.t,
            flux,
            class,
            ends_diffuse,
            splats: ends_diffuse || (absorbed && !specular_last),
            escapes: false,
            n_hit: hit.ng,
            n_origin,
            ln_p_start,
            ln_p_end: ln_p,
        });
        // With the indirect class full, only a caustic segment can still be stored, and only a
        // specular bounce continues a caustic path: a path ends at a vertex that cannot scatter
        // specularly (every later segment would be indirect; so no indirect segment is traced).
        if t.indirect_full && !flags.is_specular() {
            break;
        }
        // Scatter (importance transport).
        let frame = Frame::from_normal(hit.ns);
        let wo = -ray.dir;
        let wo_l = frame.to_local(wo);
        let Some(bs) = bsdf.sample(wo_l, rng.next_f32(), rng.next_2d(), TransportMode::Importance) else { break };
        if bs.pdf <= 0.0 || bs.f == Vec3::ZERO {
            break;
        }
        let wi = frame.to_world(bs.wi);
        // A direction on the wrong side of the geometric surface (possible with shading normals)
        // would leak through it: end the photon there.
        let (wo_ng, wi_ng) = (wo.dot(hit.ng), wi.dot(hit.ng));
        let transmitted = bs.flags.contains(crate::bsdf::BsdfFlags::TRANSMISSION) && wo_ng * wi_ng < 0.0;
        if !transmitted && wo_ng * wi_ng <= 0.0 {
            break;
        }
        // Adjoint BSDF with shading normals (Veach 1997, §5.3; pbrt's CorrectShadingNormal): the
        // photon weight is f·|wi·ns|/pdf · |wo·ns||wi·ng| / (|wo·ng||wi·ns|).
        let denom = wo_ng.abs() * bs.wi.z.abs();
        let corr = if denom > 0.0 { wo_l.z.abs() * wi_ng.abs() / denom } else { 0.0 };
        let new_flux = flux * bs.f * (bs.wi.z.abs() / bs.pdf) * corr;
        specular_last = bs.flags.is_specular();
        if t.indirect_full && !specular_last {
            break; // (a non-specular bounce of a BSDF with a specular lobe: as above)
        }
        if !specular_last {
            ln_p += (bs.pdf as f64).max(1e-300).ln();
            specular_only = false;
        }
        // Russian roulette keeps the photon power roughly constant.
        let q = (lum(new_flux) / lum(flux).max(1e-30)).min(1.0);
        if !(q > 0.0) || rng.next_f32() >= q {
            break;
        }
        flux = new_flux / q;
        if !flux.is_finite() {
            break;
        }
        ln_p_start = Some(ln_p);
        n_origin = if wi_ng >= 0.0 { hit.ng } else { -hit.ng };
        ray = scene.spawn(hit.p, hit.ng, wi);
    }
    start
}

/// The stored photon ray of a segment: the bandwidths at its ends (`h0`, `dh`; `h_scale` per class,
/// [`Bandwidth::h_scale`]), its direction and normals encoded. A segment that ends on a purely
/// specular surface gets bandwidth 0, so it splats nothing: its light is not reflected there but
/// goes on along the next segment, which is splatted where it lands; its footprint would light the
/// surfaces near the specular one a second time (the floor under a glass sphere would receive the
/// light inside the sphere too: twice the caustic; docs/architecture.md, "Photon rays that end on
/// specular surfaces").
fn photon_ray(seg: &Segment, bw: &Bandwidth, h_scale: &[f64; 3]) -> PhotonRay {
    let scale = h_scale[seg.class as usize];
    let splats = seg.splats;
    let h_start = seg.ln_p_start.filter(|_| splats).map_or(0.0, |l| bw.h_scaled(l, scale));
    let h_end = if splats { bw.h_scaled(seg.ln_p_end, scale) } else { 0.0 };
    let mut r = PhotonRay {
        origin: seg.origin.to_array(),
        dir: oct_encode(seg.dir),
        length: seg.length,
        h0: h_start.min(h_end),
        dh: if seg.length > 0.0 { (h_end - h_start).max(0.0) / seg.length } else { 0.0 },
        flux: seg.flux.to_array(),
        n_hit: oct_encode(seg.n_hit),
        n_origin: oct_encode(seg.n_origin),
    };
    if !r.flux.iter().all(|f| f.is_finite()) {
        r.flux = [0.0; 3];
    }
    r
}

/// Segments of consecutive paths: `segments[ends[k-1]..ends[k]]` belong to path `first + k`, which
/// started at `starts[k]` of the guide (if any).
struct Batch {
    first: u64,
    segments: Vec<Segment>,
    ends: Vec<usize>,
    starts: Vec<Option<PathStart>>,
}

impl Batch {
    fn paths(&self) -> impl Iterator<Item = (u64, &[Segment])> {
        let mut start = 0;
        self.ends.iter().enumerate().map(move |(k, &end)| {
            let p = &self.segments[start..end];
            start = end;
            (self.first + k as u64, p)
        })
    }
}

/// Trace paths `[first, first + n)` in parallel chunks of fixed size, in path order.
fn trace_batch(scene: &PreparedScene, s: &PhotonSettings, t: &Tracing, first: u64, n: usize) -> Vec<Batch> {
    let chunks: Vec<u64> = (0..n.div_ceil(CHUNK)).map(|c| first + (c * CHUNK) as u64).collect();
    chunks
        .par_iter()
        .map(|&c0| {
            embree::set_flush_denormals();
            let end = (c0 + CHUNK as u64).min(first + n as u64);
            let mut b = Batch { first: c0, segments: Vec::with_capacity(CHUNK * 4), ends: Vec::with_capacity(CHUNK), starts: Vec::with_capacity(CHUNK) };
            for j in c0..end {
                let start = trace_path(scene, s, t, j, &mut b.segments);
                b.ends.push(b.segments.len());
                b.starts.push(start);
            }
            b
        })
        .collect()
}

/// Emitted paths per budgeted photon after which a class that stored nothing is given up.
const EMPTY_CLASS_PATHS: usize = 8;

/// The light pass: a pilot phase fits the bandwidth model, then paths are traced until every
/// class with a budget holds that many photons (or the path limit is reached).
pub fn trace_photons(scene: &PreparedScene, s: &PhotonSettings) -> PhotonSet {
    trace_photons_cancellable(scene, s, &|| false).unwrap_or_else(|e| panic!("the light pass: {e}"))
}

/// [`trace_photons`] that polls `cancelled` between batches ([`Error::Cancelled`] when
/// cancelled) and allocates the photon arrays fallibly ([`Error::OutOfMemory`]).
pub fn trace_photons_cancellable(scene: &PreparedScene, s: &PhotonSettings, cancelled: &(dyn Fn() -> bool + Sync)) -> Result<PhotonSet> {
    let mut set = PhotonSet::default();
    let total: usize = s.budget.iter().sum();
    if total == 0 || scene.lights.is_empty() {
        return Ok(set);
    }
    let unit = scene.radius as f64;
    // Pilot: a small independent set of paths.
    let pilot_n = (total / 10).clamp(1_000, 20_000);
    let provisional = Bandwidth::fit(&s.bandwidth, unit, unit, &[]);
    let pilot = trace_batch(scene, s, &Tracing { stream: PILOT_STREAM, unit, bw: &provisional, guide: None, indirect_full: false }, 0, pilot_n);
    let (mut len_sum, mut len_n, mut ln_ps) = (0.0f64, 0usize, Vec::new());
    // (the bandwidth model is fitted to the segments between surfaces: a ray leaving the scene
    // is as long as the scene's bounding sphere makes it)
    for seg in pilot.iter().flat_map(|b| b.segments.iter()).filter(|seg| !seg.escapes) {
        len_sum += seg.length as f64;
        len_n += 1;
        ln_ps.push(seg.ln_p_end);
    }
    let mean_len = if len_n > 0 { len_sum / len_n as f64 } else { unit };
    // ln p̃ depends on D̃ (through the mean length): recompute the pilot with the fitted D̃.
    let first_fit = Bandwidth::fit(&s.bandwidth, unit, mean_len, &[]);
    let pilot = trace_batch(scene, s, &Tracing { stream: PILOT_STREAM, unit, bw: &first_fit, guide: None, indirect_full: false }, 0, pilot_n);
    ln_ps.clear();
    pilot.iter().flat_map(|b| b.segments.iter()).filter(|seg| !seg.escapes).for_each(|seg| ln_ps.push(seg.ln_p_end));
    let bw = Bandwidth::fit(&s.bandwidth, unit, mean_len, &ln_ps);
    set.bandwidth = bw;

    // every class's photons in one allocation each (pushing into growing arrays copied them
    // again at each doubling)
    for k in 0..3 {
        crate::memory::try_reserve(&mut set.rays[k], s.budget[k], || format!("{} photon rays", s.budget[k]))?;
        crate::memory::try_reserve(&mut set.ends_diffuse[k], s.budget[k], || format!("{} photons' flags", s.budget[k]))?;
    }
    let max_paths = (total * s.max_paths_per_photon.max(1)) as u64;
    let batch = (total / 4).clamp(4 * CHUNK, 1 << 18);
    let mut next = 0u64;
    // A class is done when it holds its budget, or when it is still empty after
    // `EMPTY_CLASS_PATHS` paths per budgeted photon: its yield is then below 1/EMPTY_CLASS_PATHS of a
    // photon per budgeted photon, so the path limit would bring fewer than
    // max_paths_per_photon/EMPTY_CLASS_PATHS photons. (A lone floor under the sun has no indirect
    // light: its light pass traced 64 paths per photon for nothing.)
    // Segments stored per class against its budget (the rays that leave the scene are stored
    // beside it).
    let mut counted = [0usize; 3];
    let done = |counted: &[usize; 3], next: u64| {
        (0..3).all(|k| counted[k] >= s.budget[k] || (counted[k] == 0 && next >= (total * EMPTY_CLASS_PATHS) as u64))
    };
    // Guided emission learns from every batch's paths (uniform until a key has enough of them).
    let mut guide = s.emission_guiding.then(|| EmissionGuide::new(&scene.lights.emitters, s.budget));
    let mut guided_paths = 0u64;
    let h_scale: [f64; 3] = std::array::from_fn(|k| bw.h_scale(s.budget[k]) * s.bandwidth.class_smoothness[k] as f64);
    while !done(&counted, next) && next < max_paths {
        if cancelled() {
            return Err(Error::Cancelled);
        }
        let indirect = PhotonClass::Indirect as usize;
        let indirect_full = counted[indirect] >= s.budget[indirect];
        let batches = trace_batch(scene, s, &Tracing { stream: PHOTON_STREAM, unit, bw: &bw, guide: guide.as_ref(), indirect_full }, next, batch);
        // which segments are stored (in path order, until each class holds its budget) ...
        let (mut kept, mut leaving): ([Vec<&Segment>; 3], [Vec<&Segment>; 3]) = Default::default();
        for (j, path) in batches.iter().flat_map(Batch::paths) {
            for seg in path {
                let k = seg.class as usize;
                if counted[k] >= s.budget[k] {
                    continue;
                }
                if seg.escapes {
                    leaving[k].push(seg);
                    continue;
                }
                kept[k].push(seg);
                set.ends_diffuse[k].push(seg.ends_diffuse);
                counted[k] += 1;
                if counted[k] == s.budget[k] {
                    set.emitted[k] = j + 1;
                }
            }
            set.paths = j + 1;
        }
        // ... and their photon rays, in parallel; then the leaving rays that pass the eye samples
        for (k, kept) in kept.iter().enumerate() {
            set.rays[k].par_extend(kept.par_iter().map(|seg| photon_ray(seg, &bw, &h_scale)));
        }
        if let Some(reach) = &s.reach {
            for (k, leaving) in leaving.iter().enumerate() {
                let passing: Vec<PhotonRay> = leaving.par_iter().map(|seg| photon_ray(seg, &bw, &h_scale)).filter(|r| reach.reaches(r)).collect();
                crate::memory::try_reserve(&mut set.rays[k], passing.len(), || format!("{} photon rays leaving the scene", passing.len()))?;
                crate::memory::try_reserve(&mut set.ends_diffuse[k], passing.len(), || format!("{} photons' flags", passing.len()))?;
                set.ends_diffuse[k].extend(std::iter::repeat_n(false, passing.len()));
                set.leaving[k] += passing.len();
                set.rays[k].extend(passing);
            }
        }
        if let Some(g) = &mut guide {
            for b in &batches {
                for ((j, path), start) in b.paths().zip(&b.starts) {
                    let Some(start) = start else { continue };
                    guided_paths += (start.guided && j < set.paths) as u64;
                    let mut counts = [0u32; 3];
                    path.iter().filter(|seg| !seg.escapes).for_each(|seg| counts[seg.class as usize] += 1);
                    g.record(start, counts);
                }
            }
            g.rebuild();
        }
        next += batch as u64;
    }
    if let Some(g) = &guide {
        set.guide = Some(g.summary(guided_paths));
    }
    super::bandwidth::adapt_caustic_bandwidths(&mut set);
    for k in 0..3 {
        if set.emitted[k] == 0 {
            set.emitted[k] = set.paths.max(1);
        }
        let inv = 1.0 / set.emitted[k] as f32;
        for r in &mut set.rays[k] {
            r.flux = (Vec3::from(r.flux) * inv).to_array();
        }
    }
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With the indirect class full, a path ends where it can no longer be caustic, and keeps every
    /// segment a whole path has up to there: the same direct and caustic segments (the ones that
    /// can still be stored), bit for bit, path by path, with only indirect segments cut. On
    /// cornell-glossy (a glass sphere, a glossy and a diffuse material) and for many paths, so that
    /// some paths are caustic and some cut.
    #[test]
    fn paths_cut_once_the_indirect_class_is_full_keep_what_can_be_stored() {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-glossy.usda"));
        let scene = PreparedScene::new(crate::usd::load_scene(path).expect("scene"), 32, 32, 0).expect("prepare");
        let s = PhotonSettings { budget: [1000, 1000, 1000], ..PhotonSettings::default() };
        let bw = Bandwidth::fit(&s.bandwidth, scene.radius as f64, scene.radius as f64, &[]);
        let tracing = |indirect_full| Tracing { stream: PHOTON_STREAM, unit: scene.radius as f64, bw: &bw, guide: None, indirect_full };
        let (whole, cut) = (trace_batch(&scene, &s, &tracing(false), 0, 20_000), trace_batch(&scene, &s, &tracing(true), 0, 20_000));
        let (mut caustic, mut shortened, mut cut_indirect) = (0, 0, 0);
        for (w, c) in whole.iter().zip(&cut) {
            for ((_, pw), (_, pc)) in w.paths().zip(c.paths()) {
                let kept = pw.iter().take_while(|seg| seg.class != PhotonClass::Indirect).count();
                assert_eq!(pc.len(), kept, "a cut path keeps its segments up to its first indirect one");
                for (a, b) in pw.iter().zip(pc) {
                    assert!(a.origin == b.origin && a.dir == b.dir && a.length == b.length && a.flux == b.flux && a.ln_p_end == b.ln_p_end);
                }
                caustic += pc.iter().filter(|seg| seg.class == PhotonClass::Caustic).count();
                shortened += (pc.len() < pw.len()) as usize;
                cut_indirect += pw.len() - pc.len();
            }
        }
        assert!(caustic > 100 && shortened > 5_000 && cut_indirect > shortened, "{caustic} caustic segments, {shortened} paths shortened by {cut_indirect} segments");
    }

    /// A 0.1 m patch under a 1 m light: most direct photons miss it and leave the scene. Without
    /// eye samples to pass, none of those is stored; with the eye pass's [`crate::splat::Reach`],
    /// those that pass the patch's eye samples are stored beside the budget (which still counts
    /// the rays that end on the patch, exactly), and every one of them reaches the samples.
    #[test]
    fn rays_leaving_the_scene_are_stored_where_they_pass_the_eye_samples() {
        use crate::eye::{eye_pass, EyeSettings};
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/plane-rect.usda"));
        let scene = PreparedScene::new(crate::usd::load_scene(path).expect("scene"), 8, 8, 0).expect("prepare");
        let eye = eye_pass(&scene, &EyeSettings { spp: 1, aa_spp: 1, seed: 0, light_samples: 1 }).expect("eye pass");
        let reach = std::sync::Arc::new(crate::splat::Reach::of(&eye));
        let budget = [300, 0, 0];
        let without = trace_photons(&scene, &PhotonSettings { budget, max_paths_per_photon: 1000, ..PhotonSettings::default() });
        let with = trace_photons(&scene, &PhotonSettings { budget, max_paths_per_photon: 1000, reach: Some(reach.clone()), ..PhotonSettings::default() });
        assert_eq!(without.rays[0].len(), 300);
        assert!(without.ends_diffuse[0].iter().all(|&d| d), "only rays that end on the patch without a reach");
        assert_eq!(with.ends_diffuse[0].iter().filter(|&&d| d).count(), 300, "the budget counts the rays that end on the patch");
        let leaving: Vec<&PhotonRay> = with.rays[0].iter().zip(&with.ends_diffuse[0]).filter(|(_, &d)| !d).map(|(r, _)| r).collect();
        assert_eq!(with.leaving, [leaving.len(), 0, 0]);
        assert!(leaving.len() > 20, "{} leaving rays stored", leaving.len());
        assert!(leaving.iter().all(|r| reach.reaches(r) && r.radius_at(r.length) > 0.0));
        // the light's photons that pass far from the patch are not stored
        assert!(leaving.len() < (with.emitted[0] as usize - 300) / 4, "{} of {} paths that missed the patch", leaving.len(), with.emitted[0] - 300);
    }

    /// A ray that ends on a surface that scatters nothing splats on its way there (its cone has a
    /// radius), as one that ends on a white wall does: on the Cornell box with its red wall black,
    /// the segments that end there have the bandwidth model's radii.
    #[test]
    fn rays_that_end_on_black_surfaces_splat() {
        use crate::scene::{Material, TexturedColor};
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"));
        let mut desc = crate::usd::load_scene(path).expect("scene");
        let red = desc.materials.iter().position(|m| m.name().ends_with("/Red")).expect("a red material");
        desc.materials[red] = Material::Lambert { name: "/Black".into(), diffuse_color: TexturedColor::constant([0.0; 3]), emissive_color: TexturedColor::constant([0.0; 3]) };
        let scene = PreparedScene::new(desc, 16, 16, 0).expect("prepare");
        let set = trace_photons(&scene, &PhotonSettings { budget: [3000, 3000, 0], ..PhotonSettings::default() });
        let (mut black, mut white) = (0, 0);
        for k in 0..2 {
            for (r, &diffuse) in set.rays[k].iter().zip(&set.ends_diffuse[k]) {
                assert!(r.radius_at(r.length) > 0.0, "class {k}: a ray that ends {} splats nothing", if diffuse { "on a white wall" } else { "on the black wall" });
                if diffuse { white += 1 } else { black += 1 }
            }
        }
        assert!(black > 300 && white > 3000, "{black} rays end on the black wall, {white} elsewhere");
    }
}
