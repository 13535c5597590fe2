//! Guided photon emission (`photon::guide`): the stored photons carry the same flux in expectation,
//! per class and per region of the scene, as unguided ones, and the guided photon set does not
//! depend on the thread count.

mod common;
#[path = "common/extreme_scenes.rs"]
mod extreme_scenes;

use extreme_scenes::{outward_box, rect_light_down};
use common::{diffuse, floor, place, plane_distant};
use glam::Vec3;
use raysplat::photon::{trace_photons, PhotonSet, PhotonSettings};
use raysplat::prepare::PreparedScene;
use raysplat::scene::{Light, SceneDesc};

/// A 8 m × 8 m floor with a 1 m block on it, under a sun at 40°, a constant sky and a small rect
/// light over one corner: indirect photons come from around the block (and under the rect light),
/// so the guide has something to learn, and there is one emitter of each kind.
fn block_on_floor() -> SceneDesc {
    let mut s = plane_distant(0.7, 3.0, 40.0);
    s.meshes = vec![floor("/Floor", 4.0, 0), outward_box("/Block", Vec3::new(0.5, 0.5, -0.3), 0.5, 1)];
    s.instances = vec![place(0, "/Floor"), place(1, "/Block")];
    s.materials = vec![diffuse("/Looks/Floor", 0.7, 0.0), diffuse("/Looks/Block", 0.8, 0.0)];
    s.lights.push(Light::Dome { name: "/Sky".into(), transform: glam::Mat4::IDENTITY.to_cols_array_2d(), radiance: [0.3; 3], texture: None });
    s.lights.push(rect_light_down("/Lamp", Vec3::new(-3.0, 0.6, 3.0), 0.4, 20.0));
    s
}

const BUDGET: [usize; 3] = [4_000, 20_000, 0];

fn trace(scene: &PreparedScene, seed: u64, guiding: bool) -> PhotonSet {
    trace_photons(scene, &PhotonSettings { budget: BUDGET, seed, max_depth: 64, emission_guiding: guiding, ..Default::default() })
}

/// Region of a photon's end point: the block's faces by normal (0-5), else a 4×4 grid of the floor
/// (6-21).
const REGIONS: usize = 22;
fn region(p: Vec3) -> usize {
    let b = p - Vec3::new(0.5, 0.5, -0.3);
    if b.abs().max_element() < 0.51 && p.y > 1e-3 {
        let a = b.abs();
        let axis = if a.x >= a.y && a.x >= a.z { 0 } else if a.y >= a.z { 1 } else { 2 };
        return axis * 2 + (b[axis] > 0.0) as usize;
    }
    let cell = |v: f32| (((v + 4.0) / 2.0) as usize).min(3);
    6 + cell(p.z) * 4 + cell(p.x)
}

/// Flux (luminance, W) per (class, region) of one photon set.
fn fluxes(set: &PhotonSet) -> Vec<f64> {
    let mut out = vec![0.0; 2 * REGIONS];
    for k in 0..2 {
        for r in &set.rays[k] {
            let f = r.flux();
            out[k * REGIONS + region(r.end())] += (0.2126 * f.x + 0.7152 * f.y + 0.0722 * f.z) as f64;
        }
    }
    out
}

fn mean_and_se(samples: &[Vec<f64>], i: usize) -> (f64, f64) {
    let n = samples.len() as f64;
    let m = samples.iter().map(|s| s[i]).sum::<f64>() / n;
    let var = samples.iter().map(|s| (s[i] - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Mean stored flux per class and region over 8 seeds, guided against unguided: they agree within
/// 4 standard errors (of the difference, from the seeds' spread), and so do the totals. Guiding
/// must also have been used and have saved paths (otherwise the test compares nothing).
#[test]
fn guided_photons_carry_the_same_flux_per_region() {
    let scene = PreparedScene::new(block_on_floor(), 16, 16, 0).expect("prepare");
    let (mut guided, mut uniform) = (Vec::new(), Vec::new());
    let (mut paths_g, mut paths_u) = (0u64, 0u64);
    for seed in 0..8 {
        let g = trace(&scene, seed, true);
        let u = trace(&scene, 100 + seed, false);
        let sum = g.guide.expect("guide summary");
        assert!(sum.grids >= 1 && sum.guided_paths > g.paths / 2, "{sum:?} of {} paths", g.paths);
        assert_eq!([g.rays[0].len(), g.rays[1].len()], [BUDGET[0], BUDGET[1]]);
        paths_g += g.paths;
        paths_u += u.paths;
        let mut fg = fluxes(&g);
        let mut fu = fluxes(&u);
        fg.push(fg[REGIONS..].iter().sum());
        fu.push(fu[REGIONS..].iter().sum());
        guided.push(fg);
        uniform.push(fu);
    }
    assert!((paths_g as f64) < 0.8 * paths_u as f64, "guided {paths_g} paths vs uniform {paths_u}");
    let mut checked = 0;
    for i in 0..=2 * REGIONS {
        let ((mg, sg), (mu, su)) = (mean_and_se(&guided, i), mean_and_se(&uniform, i));
        let tol = 4.0 * (sg * sg + su * su).sqrt() + 1e-9 * mu.abs().max(mg.abs());
        assert!((mg - mu).abs() <= tol, "entry {i}: guided {mg:.5} ± {sg:.5}, uniform {mu:.5} ± {su:.5}");
        checked += (mu > 0.0) as usize;
    }
    assert!(checked > REGIONS, "only {checked} non-empty entries");
    // The indirect total is known to within a few percent: a bias of more would show.
    let ((mg, sg), (mu, _)) = (mean_and_se(&guided, 2 * REGIONS), mean_and_se(&uniform, 2 * REGIONS));
    assert!(sg < 0.02 * mg && (mg / mu - 1.0).abs() < 0.05, "indirect total {mg} ± {sg} vs {mu}");
}

/// The guide is learned from the batches in path order: the same photons for 1 and 2 threads.
#[test]
fn guided_photons_do_not_depend_on_the_thread_count() {
    let scene = PreparedScene::new(block_on_floor(), 16, 16, 0).expect("prepare");
    let sets: Vec<PhotonSet> = [1, 2]
        .iter()
        .map(|&threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| trace(&scene, 3, true))
        })
        .collect();
    assert!(sets[0].guide.unwrap().guided_paths > 0);
    assert_eq!(sets[0].paths, sets[1].paths);
    for k in 0..3 {
        assert!(sets[0].rays[k] == sets[1].rays[k], "class {k} differs between 1 and 2 threads");
    }
}
