//! Rust-side tests of the bridge functions (the C++ side is tested by cpp/tests/test_api.cpp).

use super::api::{guard, FfiError};
use super::bridge::ffi;
use super::functions::*;
use crate::scene::{
    Camera, Cone, Instance, Light, Material, Mesh, PreviewSurface, SceneDesc, TextureDesc, TexturedColor,
    TexturedScalar,
};
use glam::{Mat4, Quat, Vec2, Vec3};

fn sample_scene() -> SceneDesc {
    let xf = Mat4::from_scale_rotation_translation(
        Vec3::new(1.0, 2.0, 0.5),
        Quat::from_rotation_y(0.3),
        Vec3::new(0.1, -0.2, 3.0),
    );
    let quad = Mesh {
        name: "/World/Quad".into(),
        positions: vec![Vec3::new(-1., 0., -1.), Vec3::new(1., 0., -1.), Vec3::new(1., 0., 1.), Vec3::new(-1., 0., 1.)],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        normals: Some(vec![Vec3::Y; 4]),
        uvs: Some(vec![Vec2::new(0., 0.), Vec2::new(1., 0.), Vec2::new(1., 1.), Vec2::new(0., 1.)]),
        colors: None,
        material_ids: vec![0, 1],
        double_sided: true,
        subdivision: None,
    };
    let tri = Mesh {
        name: "/World/Tri".into(),
        positions: vec![Vec3::new(0.3, 0.1, 0.7), Vec3::new(1.1, 0.2, -0.4), Vec3::new(-0.9, 1.3, 0.25)],
        indices: vec![[0, 1, 2]],
        normals: None,
        uvs: None,
        colors: Some(vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.5, 0.0), Vec3::new(0.0, 0.0, 0.25)]),
        material_ids: vec![1],
        double_sided: false,
        subdivision: None,
    };
    let textured = PreviewSurface {
        name: "/Looks/Textured".into(),
        diffuse_color: TexturedColor { value: [0.2, 0.3, 0.4], texture: Some(0), vertex: false },
        roughness: TexturedScalar { value: 0.25, texture: Some(1) },
        normal_map: Some(1),
        emissive_color: TexturedColor::constant([0.5, 0.25, 0.125]),
        ..Default::default()
    };
    let m4 = xf.to_cols_array_2d();
    SceneDesc {
        meshes: vec![quad, tri],
        instances: vec![
            Instance { mesh: 0, transform: Mat4::IDENTITY, name: "/World/Quad".into() },
            Instance { mesh: 1, transform: xf, name: "/World/Tri".into() },
            Instance { mesh: 0, transform: xf.inverse(), name: "/World/Quad2".into() },
        ],
        materials: vec![
            Material::PreviewSurface(textured),
            Material::Error { name: "/Looks/Mdl".into() },
            Material::Lambert {
                name: "/Looks/Painted".into(),
                diffuse_color: TexturedColor { value: [0.5; 3], texture: None, vertex: true },
                emissive_color: TexturedColor::constant([0.0; 3]),
            },
        ],
        textures: vec![
            TextureDesc { path: "/tmp/a.png".into(), color_space: "sRGB".into(), ..Default::default() },
            TextureDesc {
                path: "/tmp/b.exr".into(),
                wrap_s: "clamp".into(),
                output: "r".into(),
                scale: [2.0; 4],
                ..Default::default()
            },
        ],
        lights: vec![
            Light::Rect {
                name: "/L/Rect".into(),
                transform: m4,
                width: 0.5,
                height: 0.25,
                radiance: [10., 9., 8.],
                texture: Some(0),
            },
            Light::Disk { name: "/L/Disk".into(), transform: m4, radius: 0.1, radiance: [1., 2., 3.] },
            Light::Sphere {
                name: "/L/Spot".into(),
                transform: m4,
                radius: 0.05,
                radiance: [4., 4., 4.],
                cone: Some(Cone { angle_deg: 30.0, softness: 0.2, focus: 1.5 }),
            },
            Light::Sphere { name: "/L/Sphere".into(), transform: m4, radius: 0.05, radiance: [4., 4., 4.], cone: None },
            Light::Distant {
                name: "/L/Sun".into(),
                direction: [0.0, -1.0, 0.0],
                angle_deg: 0.53,
                irradiance: [3., 3., 3.],
            },
            Light::Dome { name: "/L/Dome".into(), transform: m4, radiance: [0.1, 0.2, 0.3], texture: Some(1) },
        ],
        camera: Camera {
            name: "/Cam".into(),
            transform: Mat4::from_translation(Vec3::new(0., 1., 5.)).to_cols_array_2d(),
            ..Default::default()
        },
        resolution: Some([32, 24]),
        warnings: vec![],
        source: "sample.rss".into(),
        subdivision: Default::default(),
    }
}

/// Export a scene through the bridge accessors and rebuild it through the builder.
fn rebuild(scene: &super::Scene) -> Box<super::Scene> {
    let mut b = new_scene_builder(&scene.source().unwrap()).unwrap();
    for t in scene.textures().unwrap() {
        b.add_texture(&t).unwrap();
    }
    for m in scene.materials().unwrap() {
        b.add_material(&m).unwrap();
    }
    for i in 0..scene.mesh_count().unwrap() {
        let m = scene.mesh(i).unwrap();
        let k = b.add_mesh(&m.name, &m.positions, &m.indices, &m.normals, &m.uvs, &m.material_ids, m.double_sided).unwrap();
        b.set_mesh_colors(k, &m.colors).unwrap();
    }
    for i in 0..scene.instance_count().unwrap() {
        b.add_instance(&scene.instance(i).unwrap()).unwrap();
    }
    for l in scene.lights().unwrap() {
        b.add_light(&l).unwrap();
    }
    b.set_camera(&scene.camera().unwrap()).unwrap();
    let [w, h] = scene.resolution().unwrap();
    b.set_resolution(w, h).unwrap();
    b.build().unwrap()
}

fn built(desc: SceneDesc) -> Box<super::Scene> {
    let b = super::SceneBuilder::from_desc(desc);
    b.build().unwrap()
}

#[test]
fn export_and_rebuild_is_exact() {
    let a = built(sample_scene());
    let b = rebuild(&a);
    // Debug output prints floats exactly (shortest round-trip representation).
    let (da, db) = (a.desc(), b.desc());
    assert_eq!(format!("{:?}", da.meshes), format!("{:?}", db.meshes));
    assert_eq!(format!("{:?}", da.instances), format!("{:?}", db.instances));
    assert_eq!(da.materials, db.materials);
    assert_eq!(da.textures, db.textures);
    assert_eq!(da.lights, db.lights);
    assert_eq!(da.camera, db.camera);
    assert_eq!(da.resolution, db.resolution);
    assert_eq!(da.source, db.source);
    for (x, y) in da.instances.iter().zip(&db.instances) {
        assert_eq!(x.transform.to_cols_array().map(f32::to_bits), y.transform.to_cols_array().map(f32::to_bits));
    }
    assert_eq!(a.triangle_count().unwrap(), 2 + 1 + 2);
}

#[test]
fn options_follow_the_cli() {
    use crate::integrators::{Method, MethodSettings, Quality, RenderRequest};
    let d = default_options().unwrap();
    // the defaults are the CLI's (`raysplat_cli`'s tests check the command line's side): auto
    let request = |o: &ffi::RenderOptions| super::convert::request_in(o);
    assert_eq!(request(&d).unwrap(), RenderRequest::DEFAULT);
    assert_eq!((d.method.as_str(), d.quality.as_str(), d.spp, d.photons), ("auto", "", 0, 0));
    assert_eq!(methods().unwrap(), std::iter::once("auto").chain(Method::ALL.iter().map(|m| m.name())).map(String::from).collect::<Vec<_>>());
    // a request and its options stand for each other
    let asked = RenderRequest {
        method: Some(Method::RsRc),
        spp: Some(3),
        time: Some(2.5),
        seed: 9,
        threads: 2,
        resolution: Some([64, 32]),
        photons: Some(5000),
        aa_spp: 8,
        glossy: crate::radiance_map::GlossyMode::Sh,
        fg_rays: Some(12),
        gather_radius: Some(0.05),
        memory: Some(1 << 21),
        spill_dir: Some("/tmp".into()),
        density_limit: Some(4e4),
        cache_error: Some(0.3),
        ..RenderRequest::DEFAULT
    };
    assert_eq!(request(&super::convert::options_out(&asked)).unwrap(), asked);
    let auto_final = RenderRequest { quality: Some(Quality::Final), ..RenderRequest::DEFAULT };
    assert_eq!(request(&super::convert::options_out(&auto_final)).unwrap(), auto_final);
    // the same checks and messages as the CLI
    let settings = |o: ffi::RenderOptions| request(&o).and_then(|r| r.settings());
    // (as C++ sees them: fields where the CLI names flags)
    let err = |o: ffi::RenderOptions| super::names::api_message(&request(&o).and_then(|r| r.settings()).unwrap_err());
    let pt = ffi::RenderOptions { method: "pt".into(), ..d.clone() };
    assert_eq!(err(ffi::RenderOptions { method: "nope".into(), ..d.clone() }), crate::integrators::parse_method("nope").unwrap_err().to_string());
    assert!(err(ffi::RenderOptions { method: "nope".into(), ..d.clone() }).contains("(available: auto, pt, "));
    let rs = ffi::RenderOptions { method: "rs".into(), ..d.clone() };
    assert!(err(ffi::RenderOptions { photons: 1 << 40, ..rs.clone() }).contains("invalid parameter photons"));
    assert!(err(ffi::RenderOptions { method: "pm".into(), knn: 0, ..d.clone() }).contains("invalid parameter knn"));
    assert!(err(ffi::RenderOptions { sensitivity: 2.0, ..rs.clone() }).contains("invalid parameter sensitivity"));
    assert!(err(ffi::RenderOptions { method: "pm-fg".into(), gather_rays: 1 << 20, ..d.clone() }).contains("invalid parameter gather_rays"));
    assert!(err(ffi::RenderOptions { quality: "final".into(), ..pt.clone() }).contains("invalid parameter quality: quality applies to method auto only"));
    // --fg-rays is one setting of each gathering method: pm-fg's gather rays, he-fg's stratified rays
    let rpm = settings(ffi::RenderOptions { method: "rpm-fg".into(), gather_rays: 5, memory_budget: 1 << 20, ..d.clone() }).unwrap();
    let MethodSettings::RpmFg(fg) = &rpm.method else { panic!("{rpm:?}") };
    assert_eq!((fg.fg.rays, fg.fg.memory, fg.fg.gather_radius, fg.fg.density_limit), (5, Some(1 << 20), None, None));
    let he = settings(ffi::RenderOptions { method: "he-fg".into(), gather_rays: 5, ..d.clone() }).unwrap();
    let MethodSettings::HeFg(he) = &he.method else { panic!("{he:?}") };
    assert_eq!((he.stratified_rays, he.explicit_rays), (5, 230));
    let he_default = settings(ffi::RenderOptions { method: "he-fg".into(), ..d.clone() }).unwrap();
    let MethodSettings::HeFg(he) = &he_default.method else { panic!("{he_default:?}") };
    assert_eq!(he.stratified_rays, 48);
    let fixed = settings(ffi::RenderOptions { method: "pm-fg".into(), gather_radius: 0.05, spill_dir: "/tmp".into(), density_limit: 4e4, ..d.clone() }).unwrap();
    let MethodSettings::PmFg(fg) = &fixed.method else { panic!("{fixed:?}") };
    assert_eq!((fg.fg.rays, fg.fg.gather_radius, fg.fg.spill_dir.clone(), fg.fg.density_limit), (64, Some(0.05), Some("/tmp".into()), Some(4e4)));
    assert!(err(ffi::RenderOptions { method: "pm-fg".into(), gather_radius: -1.0, ..d.clone() }).contains("invalid parameter gather_radius"));
    assert!(err(ffi::RenderOptions { method: "rpm-fg".into(), density_limit: f32::NAN, ..d.clone() }).contains("density"));
    assert!(err(ffi::RenderOptions { method: "rpm-fg".into(), no_spill: true, spill_dir: "/tmp".into(), ..d.clone() }).contains("invalid parameter no_spill: contradicts spill_dir"));
    let rc = |e| settings(ffi::RenderOptions { method: "rs-rc".into(), cache_error: e, ..d.clone() }).map(|s| match s.method {
        MethodSettings::RsRc(m) => m.cache_error,
        _ => unreachable!(),
    });
    assert_eq!((rc(0.0).unwrap(), rc(0.3).unwrap()), (0.5, 0.3));
    assert!(err(ffi::RenderOptions { method: "rs-rc".into(), cache_error: -1.0, ..d.clone() }).contains("invalid parameter cache_error"));
    assert!(err(ffi::RenderOptions { width: 64, ..pt.clone() }).contains("invalid parameter width/height: 64x0"));
    assert!(err(ffi::RenderOptions { time_budget: -1.0, ..pt.clone() }).contains("invalid parameter time_budget:"));
    // 0 samples: the method's default, as a flag left out (with a time budget, pt renders until it is spent)
    assert_eq!(settings(pt.clone()).unwrap().spp, 16);
    assert_eq!(settings(rs.clone()).unwrap().spp, 4);
    let timed = settings(ffi::RenderOptions { time_budget: 2.5, ..pt.clone() }).unwrap();
    assert_eq!((timed.spp, timed.time_budget), (1 << 24, Some(2.5)));
    let sized = settings(ffi::RenderOptions { width: 64, height: 32, threads: 3, ..pt }).unwrap();
    assert_eq!((sized.resolution, sized.threads), (Some([64, 32]), 3));
}

#[test]
fn builder_errors_name_the_mesh() {
    let mat = default_material("/Looks/White").unwrap();
    let pos = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let mut b = new_scene_builder("cpp-test").unwrap();
    b.add_material(&mat).unwrap();
    let e = b.add_mesh("/Short", &pos[..8], &[0, 1, 2], &[], &[], &[0], false).unwrap_err().to_string();
    assert_eq!(e, "cpp-test: /Short: positions has 8 values, not a multiple of 3");
    let e = b.add_mesh("/Idx", &pos, &[0, 1], &[], &[], &[0], false).unwrap_err().to_string();
    assert!(e.contains("/Idx") && e.contains("indices"), "{e}");
    let e = b.add_mesh("/NoMat", &pos, &[0, 1, 2], &[], &[], &[], false).unwrap_err().to_string();
    assert!(e.contains("/NoMat"), "{e}");
    b.add_mesh("/Bad", &pos, &[0, 1, 7], &[], &[], &[0], false).unwrap();
    b.add_instance(&ffi::InstanceDesc { mesh: 0, transform: Mat4::IDENTITY.to_cols_array(), name: "/Bad".into() })
        .unwrap();
    let e = b.build().map(|_| ()).unwrap_err().to_string();
    assert!(e.starts_with("cpp-test: /Bad: vertex index 7 out of range"), "{e}");

    let mut nan = pos;
    nan[4] = f32::NAN;
    let mut b = new_scene_builder("cpp-test").unwrap();
    b.add_material(&mat).unwrap();
    b.add_mesh("/NaNMesh", &nan, &[0, 1, 2], &[], &[], &[0], false).unwrap();
    b.add_instance(&ffi::InstanceDesc { mesh: 0, transform: Mat4::IDENTITY.to_cols_array(), name: "/NaNMesh".into() })
        .unwrap();
    let e = b.build().map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("/NaNMesh") && e.contains("NaN"), "{e}");

    let mut l = default_light(ffi::LightKind::Rect, "/L").unwrap();
    l.texture = -3;
    assert!(b.add_light(&l).unwrap_err().to_string().contains("texture index -3"));
    assert!(default_light(ffi::LightKind { repr: 77 }, "/L").is_err());
}

#[test]
fn panics_become_errors() {
    let r: Result<(), FfiError> = guard(|| panic!("boom {}", 7));
    let e = r.unwrap_err().to_string();
    assert!(e.contains("internal error") && e.contains("boom 7"), "{e}");
}

#[test]
fn missing_scene_file_gives_the_cli_message() {
    let path = "/nonexistent/raysplat/scene.usda";
    let e = load_scene(path).map(|_| ()).unwrap_err().to_string();
    assert_eq!(e, crate::usd::load_scene(std::path::Path::new(path)).unwrap_err().to_string());
    assert!(e.contains(path));
}

#[test]
fn cancel_token_flags() {
    let t = new_cancel_token().unwrap();
    assert!(!t.is_cancelled().unwrap());
    t.cancel().unwrap();
    assert!(t.is_cancelled().unwrap());
    t.reset().unwrap();
    assert!(!t.is_cancelled().unwrap());
}
