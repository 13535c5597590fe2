//! Subdivision surfaces through every kind of ray: exact furnaces built from a Catmull–Clark cube,
//! one on the path Embree tessellates (a convex object under a uniform sky) and one refined into
//! triangles here (an emitting room), through the path tracer and a photon method.

mod common;

use common::*;
use glam::Vec3;
use raysplat::integrators::{render, Method, RenderOutput, RenderRequest, RenderSettings, SilentProgress};
use raysplat::scene::subdiv::{Boundary, FaceVaryingRule, Scheme, Subdivision};
use raysplat::scene::{Light, Mesh, SceneDesc};

/// A Catmull–Clark cube cage of side 2 about the origin, faces outward (or inward).
fn cube(name: &str, inward: bool, material: u32) -> Mesh {
    let p = [[-1., -1., -1.], [1., -1., -1.], [1., 1., -1.], [-1., 1., -1.], [-1., -1., 1.], [1., -1., 1.], [1., 1., 1.], [-1., 1., 1.]];
    let mut idx = vec![0u32, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3];
    if inward {
        idx.chunks_exact_mut(4).for_each(|f| f[1..].reverse());
    }
    Mesh {
        name: name.into(),
        positions: p.iter().map(|&c| Vec3::from_array(c)).collect(),
        material_ids: vec![material],
        subdivision: Some(Box::new(Subdivision {
            scheme: Scheme::CatmullClark,
            face_counts: vec![4; 6],
            face_indices: idx,
            holes: vec![],
            creases: vec![],
            crease_sharpness: vec![],
            corners: vec![],
            corner_sharpness: vec![],
            boundary: Boundary::EdgeAndCorner,
            face_varying: FaceVaryingRule::CornersPlus1,
            uvs: None,
            colors: None,
        })),
        ..Default::default()
    }
}

fn run(scene: SceneDesc, s: &RenderSettings) -> RenderOutput {
    let out = render(scene, s, &SilentProgress).expect("render");
    assert_eq!(out.film.nan_count(), 0);
    out
}

/// The closed room of a subdivision cube seen from inside, emitting Le = 1 with albedo 0.5: the
/// radiance is Le / (1 − ρ) = 2 everywhere, whatever the room's shape. An emitting surface is
/// refined into triangles (light sampling needs them), which every ray then sees. The rounded
/// room (no tags) through the path tracer; the room with every edge infinitely sharp (its limit
/// surface the cube itself, flat faces) through the path tracer and two photon methods. (On the
/// rounded room the photon methods' density estimates are low, 1.75 at 100 000 photons, as they
/// were when the converter refined it: their gather disks flatten curved walls.)
#[test]
fn emitting_subdivision_room_is_a_white_furnace() {
    let scene = |sharp: bool| {
        let mut room = cube("/Room", true, 0);
        if sharp {
            let sd = room.subdivision.as_mut().unwrap();
            sd.creases = vec![[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]];
            sd.crease_sharpness = vec![10.0; 12];
        }
        SceneDesc {
            meshes: vec![room],
            instances: vec![place(0, "/Room")],
            materials: vec![diffuse("/Looks/Wall", 0.5, 1.0)],
            camera: camera_looking(Vec3::new(0.05, 0.1, 0.15), Vec3::new(0.5, 0.1, -1.0), 60.0),
            resolution: Some([24, 24]),
            source: "subdivision furnace (built in code)".into(),
            ..Default::default()
        }
    };
    for (sharp, method, spp, tol) in [(false, Method::Pt, 256, 0.01), (true, Method::Pt, 256, 0.01), (true, Method::Pm, 4, 0.02), (true, Method::Rs, 4, 0.02)] {
        let s = RenderRequest { method: Some(method), spp: Some(spp), seed: 5, photons: Some(100_000), ..Default::default() }.settings().unwrap();
        let out = run(scene(sharp), &s);
        let mean = mean_rgb(&out.film).x;
        eprintln!("{method}, {} room: mean {mean:.4} (2 expected); {}", if sharp { "sharp" } else { "rounded" }, out.stats.scene);
        assert!((mean - 2.0).abs() < tol * 2.0, "{method}: mean {mean} vs 2");
        assert!(out.stats.scene.contains(" emissive triangles") && !out.stats.scene.contains("0 emissive triangles"), "{}", out.stats.scene);
        assert!(!out.stats.scene.contains("subdivision faces"), "the emitting room is triangles: {}", out.stats.scene);
    }
}

/// A convex object under a uniform sky of radiance 1 reflects ρ · 1 (its irradiance is π, nothing
/// shadows or lights it otherwise): the subdivision cube (tessellated by Embree, smooth normals
/// from its limit surface) with ρ = 0.5 is 0.5 over the pixels it covers whole, the sky 1. Shadow
/// rays from the surface must not hit the surface itself; with `direct_photons` the photons, traced
/// against the same surface, carry the same light.
#[test]
fn convex_subdivision_object_under_a_uniform_sky() {
    let scene = || SceneDesc {
        meshes: vec![cube("/Ball", false, 0)],
        instances: vec![place(0, "/Ball")],
        materials: vec![diffuse("/Looks/Ball", 0.5, 0.0)],
        lights: vec![Light::Dome { name: "/Sky".into(), transform: glam::Mat4::IDENTITY.to_cols_array_2d(), radiance: [1.0; 3], texture: None }],
        camera: camera_looking(Vec3::new(0.3, 1.2, 3.5), Vec3::ZERO, 40.0),
        resolution: Some([32, 32]),
        source: "subdivision sky furnace (built in code)".into(),
        ..Default::default()
    };
    for (method, spp, direct_photons, tol) in [(Method::Pt, 64, false, 0.01), (Method::Pm, 8, true, 0.03)] {
        let s = RenderRequest { method: Some(method), spp: Some(spp), seed: 3, photons: Some(100_000), direct_photons, ..Default::default() }.settings().unwrap();
        let out = run(scene(), &s);
        assert!(out.stats.scene.contains("6 subdivision faces"), "{}", out.stats.scene);
        let (rgb, albedo) = (out.film.rgb("").unwrap(), out.film.rgb("albedo").unwrap());
        let (mut object, mut sky) = (Vec::new(), Vec::new());
        for (k, c) in rgb.chunks(3).enumerate() {
            match albedo[3 * k] {
                a if (a - 0.5).abs() < 1e-6 => object.push(c[0] as f64),
                0.0 => sky.push(c[0] as f64),
                _ => {} // the silhouette
            }
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        eprintln!("{method}: object {:.4} over {} pixels (0.5 expected), sky {:.4}", mean(&object), object.len(), mean(&sky));
        assert!(object.len() > 150 && !sky.is_empty());
        assert!((mean(&object) - 0.5).abs() < tol * 0.5, "{method}: object mean {} vs 0.5", mean(&object));
        assert!(sky.iter().all(|&v| (v - 1.0).abs() < 1e-4));
    }
}
