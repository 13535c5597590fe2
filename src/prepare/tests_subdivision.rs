//! Which subdivision surfaces Embree tessellates and which become triangles, their edge rates, and
//! the shading data of a hit on one.

use glam::{Mat4, Vec2, Vec3};

use super::subdivision::edge_rates;
use super::{CameraModel, PreparedScene};
use crate::embree::Ray;
use crate::scene::subdiv::{Boundary, FaceVaryingRule, Primvar, PrimvarMode, Scheme, Subdivision, SubdivisionMode};
use crate::scene::{Camera, Instance, Material, Mesh, SceneDesc, TexturedColor};

/// An n × n grid of unit quads in the z = 0 plane, facing +z, its texture coordinates its x, y.
fn grid(n: u32, scheme: Scheme) -> Mesh {
    let m = n + 1;
    let positions: Vec<Vec3> = (0..m).flat_map(|y| (0..m).map(move |x| Vec3::new(x as f32, y as f32, 0.0))).collect();
    let idx: Vec<u32> = (0..n).flat_map(|y| (0..n).flat_map(move |x| [y * m + x, y * m + x + 1, (y + 1) * m + x + 1, (y + 1) * m + x])).collect();
    let uvs = Primvar { mode: PrimvarMode::Vertex, values: positions.iter().map(|p| p.truncate()).collect(), indices: vec![] };
    let (counts, idx) = if scheme == Scheme::Loop {
        (vec![3; 2 * (n * n) as usize], idx.chunks_exact(4).flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]]).collect())
    } else {
        (vec![4; (n * n) as usize], idx)
    };
    Mesh {
        name: "/Grid".into(),
        positions,
        material_ids: vec![0],
        subdivision: Some(Box::new(Subdivision {
            scheme,
            face_counts: counts,
            face_indices: idx,
            holes: vec![],
            creases: vec![],
            crease_sharpness: vec![],
            corners: vec![],
            corner_sharpness: vec![],
            boundary: Boundary::EdgeAndCorner,
            face_varying: FaceVaryingRule::CornersPlus1,
            uvs: Some(uvs),
            colors: None,
        })),
        ..Default::default()
    }
}

fn lambert(emission: f32) -> Material {
    Material::Lambert { name: "/M".into(), diffuse_color: TexturedColor::constant([0.5; 3]), emissive_color: TexturedColor::constant([emission; 3]) }
}

/// The camera at (2, 2, d) looking down −z at the grid.
fn scene(mesh: Mesh, material: Material, mode: SubdivisionMode, d: f32) -> SceneDesc {
    SceneDesc {
        meshes: vec![mesh],
        instances: vec![Instance { mesh: 0, transform: Mat4::IDENTITY, name: "/Grid".into() }],
        materials: vec![material],
        camera: Camera { transform: Mat4::from_translation(Vec3::new(2.0, 2.0, d)).to_cols_array_2d(), ..Default::default() },
        subdivision: mode,
        source: "grid".into(),
        ..Default::default()
    }
}

fn prepare(desc: SceneDesc) -> PreparedScene {
    PreparedScene::new(desc, 64, 64, 1).unwrap()
}

#[test]
fn catmull_clark_goes_to_embree_and_the_rest_becomes_triangles() {
    let p = prepare(scene(grid(4, Scheme::CatmullClark), lambert(0.0), SubdivisionMode::Auto, 5.0));
    assert_eq!((p.requirements.subdivision_faces, p.requirements.triangles), (16, 0));
    assert!(p.meshes[0].subdivision.is_some() && p.embree.is_subdivision(0));
    // an emitter, a Loop surface, a bilinear one, and everything under `cage`: triangles
    for (mesh, mat, mode, tris) in [
        (grid(4, Scheme::CatmullClark), lambert(1.0), SubdivisionMode::Level(1), 16 * 4 * 2),
        (grid(4, Scheme::Loop), lambert(0.0), SubdivisionMode::Level(1), 32 * 4),
        (grid(4, Scheme::Bilinear), lambert(0.0), SubdivisionMode::Level(2), 16 * 16 * 2),
        (grid(4, Scheme::CatmullClark), lambert(0.0), SubdivisionMode::Cage, 32),
    ] {
        let p = prepare(scene(mesh, mat, mode, 5.0));
        assert_eq!((p.requirements.subdivision_faces, p.requirements.triangles), (0, tris), "{mode}");
        assert!(p.meshes[0].subdivision.is_none() && !p.embree.is_subdivision(0));
    }
    let p = prepare(scene(grid(4, Scheme::CatmullClark), lambert(0.0), SubdivisionMode::Cage, 5.0));
    assert!(p.warnings.iter().any(|w| w.message.contains("rendered as its control cage (--subdivision cage)")), "{:?}", p.warnings);
    // a cut-out material (the hit filter reads triangles): refined here
    let cutout = Material::PreviewSurface(crate::scene::PreviewSurface { opacity_threshold: 0.5, ..Default::default() });
    assert_eq!(prepare(scene(grid(4, Scheme::CatmullClark), cutout, SubdivisionMode::Auto, 5.0)).requirements.subdivision_faces, 0);
    // edgeOnly with a boundary point of a single face (the grid's corners): refined here
    let mut m = grid(4, Scheme::CatmullClark);
    m.subdivision.as_mut().unwrap().boundary = Boundary::EdgeOnly;
    assert_eq!(prepare(scene(m, lambert(0.0), SubdivisionMode::Auto, 5.0)).requirements.subdivision_faces, 0);
}

#[test]
fn faces_no_rule_covers_leave_the_cage_with_a_warning() {
    // a face that names a point twice: the cage's polygons, with a warning naming the face
    let mut m = grid(2, Scheme::CatmullClark);
    m.subdivision.as_mut().unwrap().face_indices[1..4].copy_from_slice(&[0, 4, 3]);
    let p = prepare(scene(m, lambert(0.0), SubdivisionMode::Auto, 5.0));
    assert_eq!((p.requirements.subdivision_faces, p.requirements.triangles), (0, 8));
    assert!(p.warnings.iter().any(|w| w.prim == "/Grid" && w.message.contains("face 0 names a vertex twice (0 0 4 3)")), "{:?}", p.warnings);
}

#[test]
fn edge_rates_follow_the_camera_and_agree_across_each_edge() {
    let mesh = grid(8, Scheme::CatmullClark);
    let sd = mesh.subdivision.as_deref().unwrap();
    let camera = |d: f32| CameraModel::new(&Camera { transform: Mat4::from_translation(Vec3::new(2.0, 2.0, d)).to_cols_array_2d(), ..Default::default() }, 512, 512);
    let near = edge_rates(&mesh.positions, sd, &[Mat4::IDENTITY], &camera(3.0));
    let far = edge_rates(&mesh.positions, sd, &[Mat4::IDENTITY], &camera(30.0));
    // a pixel is 6e-4 of the distance: a unit edge 3 m away spans about 560 px, the cap of 64
    // segments; 30 m away 56 px, 28 segments of 2 px; nothing below 1
    assert!(near.iter().all(|&r| r <= 64.0) && near.iter().any(|&r| r == 64.0), "{near:?}");
    assert!(far.iter().all(|&r| (1.0..40.0).contains(&r)), "{far:?}");
    assert!(near.iter().zip(&far).all(|(n, f)| n >= f));
    // both faces of an edge: the same rate, bit for bit
    let mut seen = std::collections::HashMap::new();
    let mut off = 0usize;
    for &n in &sd.face_counts {
        for k in 0..n as usize {
            let (a, b) = (sd.face_indices[off + k], sd.face_indices[off + (k + 1) % n as usize]);
            if let Some(r) = seen.insert((a.min(b), a.max(b)), far[off + k].to_bits()) {
                assert_eq!(r, far[off + k].to_bits());
            }
        }
        off += n as usize;
    }
    // many placements: measured on the one largest on screen, never below a single one's rates
    let xfs: Vec<Mat4> = (0..6).map(|k| Mat4::from_translation(Vec3::new(20.0 * k as f32, 0.0, 0.0))).collect();
    let many = edge_rates(&mesh.positions, sd, &xfs, &camera(30.0));
    assert!(many.iter().zip(&far).all(|(m, f)| m >= f));
}

#[test]
fn hits_take_normals_and_texture_coordinates_from_the_limit_surface() {
    // a flat grid's limit surface is flat, and its texture coordinates (its x, y per point, vertex
    // interpolation) stay affine: at a hit they are the hit point's x, y; the shading normal is +z
    // (a textured material: texture coordinates are interpolated for the materials that read them)
    let textured = Material::Lambert { name: "/T".into(), diffuse_color: TexturedColor { value: [0.5; 3], texture: Some(0), vertex: false }, emissive_color: TexturedColor::constant([0.0; 3]) };
    let mut g = grid(4, Scheme::CatmullClark);
    // vertex colours (x, y, 1) / 4 per point: affine too, so at a hit the hit point's
    let colors: Vec<Vec3> = g.positions.iter().map(|p| Vec3::new(p.x, p.y, 1.0) / 4.0).collect();
    g.subdivision.as_mut().unwrap().colors = Some(Primvar { mode: PrimvarMode::Vertex, values: colors, indices: vec![] });
    let mut desc = scene(g, textured, SubdivisionMode::Auto, 5.0);
    desc.textures = vec![crate::scene::TextureDesc { path: "/nonexistent/checker.png".into(), ..Default::default() }];
    let p = prepare(desc);
    for (x, y) in [(1.3, 2.2), (0.6, 0.6), (2.0, 3.7)] {
        let ray = Ray::new(Vec3::new(x, y, 3.0), -Vec3::Z);
        let h = p.intersect(&ray).expect("the grid is hit");
        assert!((h.uv - Vec2::new(h.p.x, h.p.y)).abs().max_element() < 1e-4, "{:?} at {}", h.uv, h.p);
        assert!((h.ns - Vec3::Z).length() < 1e-4 && h.ng.z > 0.99, "{} {}", h.ns, h.ng);
        let c = h.color.expect("the grid has colours");
        assert!((c - Vec3::new(h.p.x, h.p.y, 1.0) / 4.0).abs().max_element() < 1e-4, "{c} at {}", h.p);
        assert_eq!(p.uv_at(h.instance, h.prim, Vec2::new(0.5, 0.5)), {
            let mut out = [0.0; 4];
            p.embree.attribute(h.instance, h.prim, 0.5, 0.5, 0, &mut out);
            Vec2::new(out[0], out[1])
        });
    }
}

#[test]
fn shading_normals_are_smooth_across_the_tessellation() {
    // rays swept across a subdivision cube in steps of 1e-3: the shading normal (the limit
    // surface's) turns by about the step over the curvature radius at every step, where the
    // tessellation's facet normal jumps at facet edges
    let cube = {
        let p = [[-1., -1., -1.], [1., -1., -1.], [1., 1., -1.], [-1., 1., -1.], [-1., -1., 1.], [1., -1., 1.], [1., 1., 1.], [-1., 1., 1.]];
        let mut m = grid(1, Scheme::CatmullClark);
        m.positions = p.iter().map(|&c| Vec3::from_array(c)).collect();
        let sd = m.subdivision.as_mut().unwrap();
        sd.face_counts = vec![4; 6];
        sd.face_indices = vec![0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3];
        sd.uvs = None;
        m
    };
    let p = prepare(scene(cube, lambert(0.0), SubdivisionMode::Level(2), 5.0));
    let (mut ns_step, mut ng_step) = (0.0f32, 0.0f32);
    let mut last: Option<(Vec3, Vec3)> = None;
    for k in 0..1000 {
        let x = -0.6 + 1.2 * k as f32 / 1000.0;
        let h = p.intersect(&Ray::new(Vec3::new(x, 0.13, 5.0), -Vec3::Z)).expect("the cube is hit");
        if let Some((ns, ng)) = last {
            ns_step = ns_step.max(ns.dot(h.ns).clamp(-1.0, 1.0).acos().to_degrees());
            ng_step = ng_step.max(ng.dot(h.ng).clamp(-1.0, 1.0).acos().to_degrees());
        }
        last = Some((h.ns, h.ng));
    }
    assert!(ns_step < 0.3, "the shading normal turns by {ns_step}° in one step");
    assert!(ng_step > 3.0, "the facets (4 segments per edge) should show in the geometric normal: {ng_step}°");
}

#[test]
fn placed_twice_a_surface_is_an_instance_evaluated_in_world_space() {
    // the grid placed twice (an Embree instance each; one mirrored): hits on either take the
    // texture coordinates of the object-space point, and a shading normal on the side of the
    // geometric one (the mirrored placement turns the winding, and so the front, to −z, as it does
    // a triangle mesh's)
    let textured = Material::Lambert { name: "/T".into(), diffuse_color: TexturedColor { value: [0.5; 3], texture: Some(0), vertex: false }, emissive_color: TexturedColor::constant([0.0; 3]) };
    let mut desc = scene(grid(4, Scheme::CatmullClark), textured, SubdivisionMode::Auto, 5.0);
    desc.textures = vec![crate::scene::TextureDesc { path: "/nonexistent/checker.png".into(), ..Default::default() }];
    let mirrored = Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0)) * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    desc.instances.push(Instance { mesh: 0, transform: mirrored, name: "/Grid2".into() });
    let p = prepare(desc);
    assert_eq!(p.requirements.subdivision_faces, 32);
    for (instance, x, local_x) in [(0u32, 1.3f32, 1.3f32), (1, 8.7, 1.3)] {
        let h = p.intersect(&Ray::new(Vec3::new(x, 2.2, 3.0), -Vec3::Z)).expect("hit");
        assert_eq!(h.instance, instance);
        assert!((h.uv - Vec2::new(local_x, 2.2)).abs().max_element() < 1e-4, "{instance}: {:?}", h.uv);
        assert!(h.ns.z.abs() > 0.999 && h.ns.dot(h.ng) > 0.999, "{instance}: {} {}", h.ns, h.ng);
        assert_eq!(h.ng.z > 0.0, instance == 0);
    }
}

#[test]
fn normal_maps_and_texture_footprints_on_the_limit_surface_match_the_triangles() {
    // a normal map tilting toward +u and +v, on the flat grid placed plainly and mirrored: a hit
    // on the surface Embree tessellates (tangent frame from the limit surface's derivatives) and
    // on the same surface refined into triangles (MikkTSpace tangents) give the same shading
    // normal; the cone's footprint in texture space is the same too (both maps are affine here)
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("normal.png");
    let m = Vec3::new(0.3, 0.4, 0.866).normalize();
    let code = |c: f32| ((c * 0.5 + 0.5) * 65535.0).round() as u16;
    image::ImageBuffer::from_pixel(4, 4, image::Rgb([code(m.x), code(m.y), code(m.z)])).save(&png).unwrap();
    let map = crate::scene::TextureDesc {
        path: png.display().to_string(),
        color_space: "raw".into(),
        scale: [2.0, 2.0, 2.0, 1.0],
        bias: [-1.0, -1.0, -1.0, 0.0],
        ..Default::default()
    };
    let checker = crate::scene::TextureDesc { path: "/nonexistent/checker.png".into(), ..Default::default() };
    let material = Material::PreviewSurface(crate::scene::PreviewSurface {
        name: "/Mapped".into(),
        diffuse_color: TexturedColor { value: [0.5; 3], texture: Some(1), vertex: false },
        normal_map: Some(0),
        ..Default::default()
    });
    let mirrored = Mat4::from_translation(Vec3::new(20.0, 0.0, 0.0)) * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let build = |mesh| {
        let mut desc = scene(mesh, material.clone(), SubdivisionMode::Auto, 5.0);
        desc.textures = vec![map.clone(), checker.clone()];
        desc.instances.push(Instance { mesh: 0, transform: mirrored, name: "/Grid2".into() });
        prepare(desc)
    };
    let refined = crate::subdiv::mesh::refine_mesh(&grid(8, Scheme::CatmullClark), 3).unwrap();
    let (limit, triangles) = (build(grid(8, Scheme::CatmullClark)), build(refined));
    assert!(limit.embree.is_subdivision(0) && !triangles.embree.is_subdivision(0));
    let cone = super::RayCone { width: 0.02, spread: 0.01 };
    for (x, y) in [(4.3, 3.7), (2.6, 5.1), (15.7, 3.7)] {
        // (obliquely: the footprint is an ellipse)
        let ray = Ray::new(Vec3::new(x - 1.0, y - 0.5, 3.0), Vec3::new(1.0, 0.5, -3.0));
        let (a, b) = (limit.intersect_cone(&ray, Some(cone)).unwrap(), triangles.intersect_cone(&ray, Some(cone)).unwrap());
        assert!((a.ns - b.ns).length() < 1e-3, "({x}, {y}): limit {} triangles {}", a.ns, b.ns);
        // (the map does tilt the normal: by acos 0.866 = 30°)
        assert!((a.ns.dot(a.ng).abs() - m.z).abs() < 1e-3, "({x}, {y}): {} against {}", a.ns, a.ng);
        for k in 0..2 {
            let (u, v) = (a.footprint.axes[k], b.footprint.axes[k]);
            assert!(u.length() > 1e-3 && (u - v).length() < 1e-3 * v.length(), "({x}, {y}) axis {k}: {u} {v}");
        }
    }
}
