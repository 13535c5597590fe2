//! Scenes built in code for the integration tests (no Python needed).
#![allow(dead_code)]

pub mod repo;

use glam::{Mat4, Vec2, Vec3};
use raysplat::scene::{Camera, Instance, Light, Material, Mesh, SceneDesc, TexturedColor};

/// An ideal diffuse (Lambert) material.
pub fn diffuse(name: &str, albedo: f32, emission: f32) -> Material {
    Material::Lambert {
        name: name.into(),
        diffuse_color: TexturedColor::constant([albedo; 3]),
        emissive_color: TexturedColor::constant([emission; 3]),
    }
}

/// Axis-aligned box [-h, h]^3 as 12 triangles facing inward.
pub fn inward_box(name: &str, h: f32, material: u32) -> Mesh {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x * h, y * h, z * h);
    let positions = vec![
        p(-1., -1., -1.), p(1., -1., -1.), p(1., 1., -1.), p(-1., 1., -1.),
        p(-1., -1., 1.), p(1., -1., 1.), p(1., 1., 1.), p(-1., 1., 1.),
    ];
    // Outward-facing quads (counter-clockwise seen from outside), then flipped to face inward.
    let quads = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [0, 4, 7, 3], [1, 2, 6, 5]];
    let mut indices = Vec::new();
    for q in quads {
        indices.push([q[0], q[2], q[1]]);
        indices.push([q[0], q[3], q[2]]);
    }
    Mesh { name: name.into(), positions, indices, normals: None, uvs: None, colors: None, material_ids: vec![material], double_sided: false, subdivision: None }
}

/// Square in the y = 0 plane, side 2h, facing +Y.
pub fn floor(name: &str, h: f32, material: u32) -> Mesh {
    let positions = vec![Vec3::new(-h, 0., -h), Vec3::new(h, 0., -h), Vec3::new(h, 0., h), Vec3::new(-h, 0., h)];
    Mesh {
        name: name.into(),
        positions,
        indices: vec![[0, 2, 1], [0, 3, 2]],
        normals: None,
        uvs: Some(vec![Vec2::new(0., 0.), Vec2::new(1., 0.), Vec2::new(1., 1.), Vec2::new(0., 1.)]),
        colors: None,
        material_ids: vec![material],
        double_sided: false,
        subdivision: None,
    }
}

pub fn place(mesh: u32, name: &str) -> Instance {
    Instance { mesh, transform: Mat4::IDENTITY, name: name.into() }
}

/// Camera at `eye` looking at `target` (+Y up unless looking straight down, then −Z up).
pub fn camera_looking(eye: Vec3, target: Vec3, vertical_fov_deg: f32) -> Camera {
    let f = (target - eye).normalize();
    let up = if f.cross(Vec3::Y).length() < 1e-3 { Vec3::NEG_Z } else { Vec3::Y };
    let r = f.cross(up).normalize();
    let u = r.cross(f);
    let m = Mat4::from_cols(r.extend(0.), u.extend(0.), (-f).extend(0.), eye.extend(1.));
    let ap = 2.0 * 50.0 * (0.5 * vertical_fov_deg.to_radians()).tan();
    Camera {
        name: "/cam".into(),
        transform: m.to_cols_array_2d(),
        projection: "perspective".into(),
        focal_length: 50.0,
        horizontal_aperture: ap,
        vertical_aperture: ap,
        clipping: [1e-3, 1e6],
        ..Default::default()
    }
}

/// White furnace: closed diffuse box with albedo ρ and uniform emission Le, camera inside.
pub fn furnace(albedo: f32, le: f32) -> SceneDesc {
    SceneDesc {
        meshes: vec![inward_box("/Box", 1.0, 0)],
        instances: vec![place(0, "/Box")],
        materials: vec![diffuse("/Looks/Wall", albedo, le)],
        camera: camera_looking(Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.5, 0.1, -1.0), 60.0),
        resolution: Some([24, 24]),
        source: "furnace (built in code)".into(),
        ..Default::default()
    }
}

/// A large diffuse floor under a delta distant light at `theta_deg` from the zenith.
pub fn plane_distant(albedo: f32, irradiance: f32, theta_deg: f32) -> SceneDesc {
    let t = theta_deg.to_radians();
    SceneDesc {
        meshes: vec![floor("/Floor", 100.0, 0)],
        instances: vec![place(0, "/Floor")],
        materials: vec![diffuse("/Looks/Floor", albedo, 0.0)],
        lights: vec![Light::Distant {
            name: "/Sun".into(),
            direction: [t.sin(), -t.cos(), 0.0],
            angle_deg: 0.0,
            irradiance: [irradiance; 3],
        }],
        camera: camera_looking(Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, 40.0),
        resolution: Some([16, 16]),
        source: "plane-distant (built in code)".into(),
        ..Default::default()
    }
}

/// A small floor patch under a parallel square rect light of side `s` at height `d` (facing down).
pub fn plane_rect(albedo: f32, radiance: f32, s: f32, d: f32) -> SceneDesc {
    // Light frame: local −Z must point down (−Y world): −90° about X maps −Z to −Y.
    let xf = Mat4::from_translation(Vec3::new(0.0, d, 0.0)) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    SceneDesc {
        meshes: vec![floor("/Patch", 0.05 * s, 0)],
        instances: vec![place(0, "/Patch")],
        materials: vec![diffuse("/Looks/Patch", albedo, 0.0)],
        lights: vec![Light::Rect {
            name: "/Rect".into(),
            transform: xf.to_cols_array_2d(),
            width: s,
            height: s,
            radiance: [radiance; 3],
            texture: None,
        }],
        camera: camera_looking(Vec3::new(0.0, 2.0 * d, 0.0), Vec3::ZERO, 1.0),
        resolution: Some([8, 8]),
        source: "plane-rect (built in code)".into(),
        ..Default::default()
    }
}

/// Irradiance at a point below the centre of a parallel square light of side `s` at distance `d`
/// with radiance `l`: four corner rectangles of the classic parallel-rectangle form factor.
pub fn square_light_irradiance(l: f32, s: f32, d: f32) -> f32 {
    let (x, y) = ((0.5 * s / d) as f64, (0.5 * s / d) as f64);
    let f = (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
        + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
        / (2.0 * std::f64::consts::PI);
    (std::f64::consts::PI * l as f64 * 4.0 * f) as f32
}

pub fn mean_rgb(film: &raysplat::image::Film) -> Vec3 {
    let rgb = film.rgb("").expect("beauty");
    let n = rgb.len() / 3;
    let mut s = Vec3::ZERO;
    for c in rgb.chunks(3) {
        s += Vec3::new(c[0], c[1], c[2]);
    }
    s / n as f32
}

/// Largest per-pixel relative difference (relative to the larger of the two values).
pub fn max_rel_diff(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            let m = x.abs().max(y.abs()) as f64;
            if m == 0.0 {
                0.0
            } else {
                (x - y).abs() as f64 / m
            }
        })
        .fold(0.0, f64::max)
}
