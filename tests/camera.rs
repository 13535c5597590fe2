//! The camera's lens: depth of field against the thin-lens circle of confusion, for the path
//! tracer and for the eye pass every photon method starts with; the film's aperture offset.

mod common;
#[path = "common/extreme_scenes.rs"]
mod extreme_scenes;

use common::*;
use extreme_scenes::sphere_light;
use glam::{Vec2, Vec3};
use raysplat::eye::{eye_pass, EyeSettings};
use raysplat::integrators::{render, RenderSettings, SilentProgress};
use raysplat::prepare::PreparedScene;
use raysplat::scene::{Camera, SceneDesc};

const SIZE: u32 = 96;
/// Vertical (and horizontal) field of view of the test camera, degrees.
const FOV: f32 = 10.0;
const LENS: f32 = 0.05;
const FOCUS: f32 = 2.0;
const RADIUS: f32 = 0.02;

/// A small emitting sphere at distance `d` straight ahead of a camera at the origin looking down
/// −Z, nothing else in view (a black floor far below, out of the frame).
fn point_scene(d: f32, lens_radius: f32, offset: [f32; 2]) -> SceneDesc {
    let camera = Camera {
        lens_radius,
        focus_distance: FOCUS,
        aperture_offset: offset,
        ..camera_looking(Vec3::ZERO, Vec3::NEG_Z, FOV)
    };
    SceneDesc {
        meshes: vec![floor("/Floor", 1.0, 0)],
        instances: vec![raysplat::scene::Instance {
            mesh: 0,
            transform: glam::Mat4::from_translation(Vec3::new(0.0, -100.0, 0.0)),
            name: "/Floor".into(),
        }],
        materials: vec![diffuse("/Black", 0.0, 0.0)],
        lights: vec![sphere_light("/Ball", Vec3::new(0.0, 0.0, -d), RADIUS, 1.0)],
        camera,
        resolution: Some([SIZE, SIZE]),
        ..Default::default()
    }
}

/// Luminance-weighted centroid, second central moment (pixels²) and sum of an image.
fn moments(lum: &[f32]) -> (Vec2, f32, f32) {
    let (mut sum, mut c) = (0.0f64, [0.0f64; 2]);
    for (i, &l) in lum.iter().enumerate() {
        let (x, y) = ((i as u32 % SIZE) as f64 + 0.5, (i as u32 / SIZE) as f64 + 0.5);
        sum += l as f64;
        c[0] += l as f64 * x;
        c[1] += l as f64 * y;
    }
    let c = [c[0] / sum, c[1] / sum];
    let m2 = lum
        .iter()
        .enumerate()
        .map(|(i, &l)| {
            let (x, y) = ((i as u32 % SIZE) as f64 + 0.5, (i as u32 / SIZE) as f64 + 0.5);
            l as f64 * ((x - c[0]).powi(2) + (y - c[1]).powi(2))
        })
        .sum::<f64>()
        / sum;
    (Vec2::new(c[0] as f32, c[1] as f32), m2 as f32, sum as f32)
}

fn pt_image(scene: SceneDesc) -> Vec<f32> {
    let s = RenderSettings { spp: 256, seed: 3, ..Default::default() };
    let film = render(scene, &s, &SilentProgress).expect("render").film;
    assert_eq!(film.nan_count(), 0);
    film.rgb("").unwrap().chunks(3).map(|c| c[0]).collect()
}

/// The emission the eye pass sees per pixel (what every photon method's image starts from).
fn eye_image(scene: SceneDesc) -> Vec<f32> {
    let prepared = PreparedScene::new(scene, SIZE, SIZE, 0).expect("prepare");
    let s = EyeSettings { spp: 4, aa_spp: 256, seed: 3, light_samples: 0 };
    eye_pass(&prepared, &s).unwrap().emitted.iter().map(|e| e.x).collect()
}

/// Radius in pixels of the blur disk a lens of radius `lens` gives a point at distance `d` with
/// the plane at `FOCUS` in focus: `lens·|d − F| / (d·F)` on the image plane at distance 1.
fn circle_of_confusion_px(lens: f32, d: f32) -> f32 {
    let half = (0.5 * FOV).to_radians().tan();
    lens * (d - FOCUS).abs() / (d * FOCUS) / (2.0 * half / SIZE as f32)
}

#[test]
fn depth_of_field_blurs_a_point_into_the_thin_lens_circle_of_confusion() {
    for (name, image) in [("pt", pt_image as fn(SceneDesc) -> Vec<f32>), ("eye pass", eye_image)] {
        let d = 4.0;
        let (c0, m0, s0) = moments(&image(point_scene(d, 0.0, [0.0; 2])));
        let (c1, m1, s1) = moments(&image(point_scene(d, LENS, [0.0; 2])));
        // a uniform disk of radius R has E[r²] = R²/2; the pinhole image's own spread adds
        let radius = (2.0 * (m1 - m0)).sqrt();
        let expect = circle_of_confusion_px(LENS, d);
        assert!(expect > 5.0, "the test's blur is too small to measure: {expect} px");
        assert!((radius - expect).abs() < 0.02 * expect, "{name}: blur radius {radius} px, thin lens {expect} px");
        // the blur moves no light: the same centre and the same total
        assert!((c1 - c0).length() < 0.1, "{name}: centre {c0} → {c1}");
        assert!((s1 - s0).abs() < 0.03 * s0, "{name}: image sum {s0} → {s1}");
        // in focus, the lens changes nothing beyond noise
        let (_, m_focus, _) = moments(&image(point_scene(FOCUS, LENS, [0.0; 2])));
        let (_, m_pin, _) = moments(&image(point_scene(FOCUS, 0.0, [0.0; 2])));
        assert!((m_focus - m_pin).abs() < 0.02 * expect * expect, "{name}: in focus {m_focus} vs pinhole {m_pin} px²");
    }
}

#[test]
fn aperture_offset_moves_the_view_right_and_up() {
    // an offset of a quarter aperture moves the image window by a quarter of its width: the point
    // moves a quarter of the image to the left; a negative vertical offset moves it up
    let ap = camera_looking(Vec3::ZERO, Vec3::NEG_Z, FOV).horizontal_aperture;
    let (c0, _, _) = moments(&pt_image(point_scene(4.0, 0.0, [0.0; 2])));
    let (c1, _, _) = moments(&pt_image(point_scene(4.0, 0.0, [0.25 * ap, -0.125 * ap])));
    let shift = c1 - c0;
    assert!((shift.x + 0.25 * SIZE as f32).abs() < 0.2, "horizontal shift {} px", shift.x);
    assert!((shift.y + 0.125 * SIZE as f32).abs() < 0.2, "vertical shift {} px", shift.y);
}

#[test]
fn wide_pixels_squeeze_the_view_and_the_file_records_them() {
    // pixels twice as wide as high on square apertures: the image window is twice as wide
    // (expandAperture), so the same aperture offset moves the point half as many pixels; the EXR
    // header carries the pixels' aspect
    let ap = camera_looking(Vec3::ZERO, Vec3::NEG_Z, FOV).horizontal_aperture;
    let run = |pixel_aspect: f32| {
        let mut scene = point_scene(4.0, 0.0, [0.25 * ap, 0.0]);
        scene.camera.pixel_aspect = pixel_aspect;
        let s = RenderSettings { spp: 64, seed: 3, ..Default::default() };
        let film = render(scene, &s, &SilentProgress).expect("render").film;
        let lum: Vec<f32> = film.rgb("").unwrap().chunks(3).map(|c| c[0]).collect();
        (moments(&lum).0, film)
    };
    let ((square, _), (wide, film)) = (run(1.0), run(2.0));
    let centre = 0.5 * SIZE as f32;
    assert!((square.x - (centre - 0.25 * SIZE as f32)).abs() < 0.2, "square pixels: x {}", square.x);
    assert!((wide.x - (centre - 0.125 * SIZE as f32)).abs() < 0.2, "wide pixels: x {}", wide.x);
    assert!((wide.y - square.y).abs() < 0.1, "the vertical position moved: {} → {}", square.y, wide.y);
    assert_eq!(film.pixel_aspect, 2.0);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wide.exr");
    raysplat::image::write_exr(&path, &film, &[]).unwrap();
    assert_eq!(raysplat::image::read_exr(&path).unwrap().pixel_aspect, 2.0);
}

#[test]
fn lens_renders_are_the_same_for_any_thread_count() {
    let run = |threads| {
        let s = RenderSettings { spp: 4, seed: 9, threads, ..Default::default() };
        render(point_scene(4.0, LENS, [0.0; 2]), &s, &SilentProgress).expect("render").film.rgb("").unwrap()
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn bad_lens_parameters_are_clear_errors() {
    let cases: [(&str, fn(&mut Camera), &str); 7] = [
        ("NaN lens", |c| c.lens_radius = f32::NAN, "lens radius NaN m must be finite"),
        ("negative lens", |c| c.lens_radius = -0.1, "lens radius -0.1 m must be finite"),
        ("no focus", |c| (c.lens_radius, c.focus_distance) = (0.01, 0.0), "focus distance 0 m must be positive"),
        ("orthographic", |c| (c.lens_radius, c.projection) = (0.01, "orthographic".into()), "needs a perspective camera"),
        ("infinite offset", |c| c.aperture_offset = [f32::INFINITY, 0.0], "aperture offset [inf, 0.0] is not finite"),
        ("flat pixels", |c| c.pixel_aspect = 0.0, "pixel aspect ratio 0 must be between"),
        ("unknown policy", |c| c.aspect_conform = "stretch".into(), "unknown aspect ratio conform policy \"stretch\""),
    ];
    for (what, spoil, message) in cases {
        let mut scene = point_scene(4.0, 0.0, [0.0; 2]);
        spoil(&mut scene.camera);
        let e = scene.validate().expect_err(what).to_string();
        assert!(e.contains("/cam: ") && e.contains(message), "{what}: {e}");
    }
}
