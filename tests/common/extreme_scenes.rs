//! Scenes built in code for `tests/extremes.rs` (numerical stability at the extremes).
#![allow(dead_code)]

use crate::common::{camera_looking, diffuse, inward_box, place};
use glam::{Mat4, Vec3};
use raysplat::scene::{Light, Mesh, SceneDesc};

/// Axis-aligned box `center ± h` as 12 triangles facing outward.
pub fn outward_box(name: &str, center: Vec3, h: f32, material: u32) -> Mesh {
    let mut m = inward_box(name, 1.0, material);
    for p in &mut m.positions {
        *p = center + *p * h;
    }
    for t in &mut m.indices {
        t.swap(1, 2);
    }
    m
}

/// A square rect light of side `s` centred at `c`, facing down (−Y).
pub fn rect_light_down(name: &str, c: Vec3, s: f32, radiance: f32) -> Light {
    let xf = Mat4::from_translation(c) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    Light::Rect { name: name.into(), transform: xf.to_cols_array_2d(), width: s, height: s, radiance: [radiance; 3], texture: None }
}

pub fn sphere_light(name: &str, c: Vec3, r: f32, radiance: f32) -> Light {
    Light::Sphere {
        name: name.into(),
        transform: Mat4::from_translation(c).to_cols_array_2d(),
        radius: r,
        radiance: [radiance; 3],
        cone: None,
    }
}

/// A closed diffuse room [-1, 1]^3 (walls albedo `albedo`) with a 0.5 m rect light of radiance
/// `radiance` just under the ceiling and a block (albedo 0.3) on the floor; camera inside. Direct
/// light, shadows, indirect light, a visible light source: everything the photon methods estimate.
pub fn room(albedo: f32, radiance: f32) -> SceneDesc {
    SceneDesc {
        meshes: vec![inward_box("/Room", 1.0, 0), outward_box("/Block", Vec3::new(0.3, -0.7, -0.3), 0.3, 1)],
        instances: vec![place(0, "/Room"), place(1, "/Block")],
        materials: vec![diffuse("/Looks/Wall", albedo, 0.0), diffuse("/Looks/Block", 0.3, 0.0)],
        lights: vec![rect_light_down("/Light", Vec3::new(0.0, 0.98, 0.0), 0.5, radiance)],
        camera: camera_looking(Vec3::new(0.0, 0.0, 0.95), Vec3::new(0.1, -0.3, -1.0), 70.0),
        resolution: Some([24, 24]),
        source: "room (built in code)".into(),
        ..Default::default()
    }
}

/// The light-tight box: an inward box (albedo 0.7, single-sided, zero thickness) with a light inside
/// (a sphere light if `sphere`, else a rect light), seen by a camera outside (looking at a corner of
/// the box, three faces in view) or inside.
pub fn sealed_box(sphere: bool, camera_inside: bool) -> SceneDesc {
    let light = if sphere {
        sphere_light("/Inside", Vec3::new(0.2, 0.3, -0.1), 0.2, 20.0)
    } else {
        rect_light_down("/Inside", Vec3::new(0.0, 0.9, 0.0), 0.8, 20.0)
    };
    let camera = if camera_inside {
        camera_looking(Vec3::new(-0.5, -0.4, 0.6), Vec3::new(0.5, 0.5, -1.0), 80.0)
    } else {
        camera_looking(Vec3::new(2.2, 1.9, 2.6), Vec3::ZERO, 50.0)
    };
    SceneDesc {
        meshes: vec![inward_box("/Box", 1.0, 0)],
        instances: vec![place(0, "/Box")],
        materials: vec![diffuse("/Looks/Box", 0.7, 0.0)],
        lights: vec![light],
        camera,
        resolution: Some([32, 32]),
        source: "sealed box (built in code)".into(),
        ..Default::default()
    }
}

/// The floor square [-h, h]² (y = 0, facing +Y) as four triangles, one of which is a needle of
/// width `w` along the diagonal from (−h, −h) to (h, h) (aspect w / (2√2 h)). Covers the square exactly.
pub fn needle_floor(name: &str, h: f32, w: f32, material: u32) -> Mesh {
    let a = Vec3::new(-h, 0.0, -h);
    let b = Vec3::new(h, 0.0, -h);
    let c = Vec3::new(h, 0.0, h);
    let d = Vec3::new(-h, 0.0, h);
    // M: just off the middle of the diagonal AC, toward B (perpendicular distance w).
    let m = Vec3::new(w / std::f32::consts::SQRT_2, 0.0, -w / std::f32::consts::SQRT_2);
    Mesh {
        name: name.into(),
        positions: vec![a, b, c, d, m],
        // counter-clockwise seen from above (+Y): normals up
        indices: vec![[0, 4, 1], [1, 4, 2], [0, 2, 4], [0, 3, 2]],
        normals: None,
        uvs: None,
        colors: None,
        material_ids: vec![material],
        double_sided: false,
        subdivision: None,
    }
}

/// A fan of `n` needles (length `len`, width `len·aspect`) standing around the origin at height
/// `y`, each rotated by a generic angle so that its vertices are not exactly representable.
pub fn needle_fan(name: &str, n: usize, len: f32, aspect: f32, y: f32, material: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for k in 0..n {
        let phi = 0.1234 + k as f32 * 2.399_963; // golden angle
        let (s, c) = phi.sin_cos();
        let dir = Vec3::new(c, 0.37, s).normalize();
        let side = dir.cross(Vec3::Y).normalize();
        let p0 = Vec3::new(0.05 * c, y, 0.05 * s);
        let i = positions.len() as u32;
        positions.push(p0);
        positions.push(p0 + dir * len);
        positions.push(p0 + dir * (0.5 * len) + side * (len * aspect));
        indices.push([i, i + 1, i + 2]);
    }
    Mesh { name: name.into(), positions, indices, normals: None, uvs: None, colors: None, material_ids: vec![material], double_sided: false, subdivision: None }
}

/// `plane_distant` (a floor under a delta distant light) with its floor replaced by `meshes`, mesh
/// `i` placed as is and the material list replaced by Lambert materials of the given albedos.
pub fn lit_floor(meshes: Vec<Mesh>, albedos: &[f32], irradiance: f32, theta_deg: f32) -> SceneDesc {
    let mut s = crate::common::plane_distant(albedos[0], irradiance, theta_deg);
    s.instances = (0..meshes.len() as u32).map(|i| place(i, &meshes[i as usize].name.clone())).collect();
    s.meshes = meshes;
    s.materials = albedos.iter().enumerate().map(|(i, &a)| diffuse(&format!("/Looks/M{i}"), a, 0.0)).collect();
    s
}

