//! Subdivision meshes of the scene refined into triangle meshes (`refine_mesh`): the limit surface,
//! its normals, sharp features, holes, materials per face and primvars of every mode.

use std::collections::HashSet;

use glam::{DVec3, Vec2, Vec3};

use super::mesh::{refine_mesh, triangle_count};
use super::tests::{flat, CUBE_IDX, CUBE_PTS};
use super::{Corners, Creases, Refinement};
use crate::scene::subdiv::{Boundary, FaceVaryingRule, Primvar, PrimvarMode, Scheme, Subdivision};
use crate::scene::Mesh;

pub fn cage_mesh(pts: &[[f64; 3]], fvc: &[u32], fvi: &[u32], scheme: Scheme) -> Mesh {
    Mesh {
        name: "/Cage".into(),
        positions: pts.iter().map(|p| DVec3::from_array(*p).as_vec3()).collect(),
        material_ids: vec![0],
        subdivision: Some(Box::new(Subdivision {
            scheme,
            face_counts: fvc.to_vec(),
            face_indices: fvi.to_vec(),
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

fn cube() -> Mesh {
    cage_mesh(&CUBE_PTS, &[4; 6], &CUBE_IDX, Scheme::CatmullClark)
}

fn sd(m: &mut Mesh) -> &mut Subdivision {
    m.subdivision.as_deref_mut().unwrap()
}

fn rounded(p: Vec3) -> [i64; 3] {
    p.to_array().map(|c| (c as f64 * 1e5).round() as i64)
}

fn tri_normal(m: &Mesh, t: [u32; 3]) -> Vec3 {
    let [a, b, c] = t.map(|i| m.positions[i as usize]);
    (b - a).cross(c - a).normalize()
}

#[test]
fn catmull_clark_points_lie_on_the_limit_surface() {
    // one level on a cube, its points then moved onto the limit surface: a corner of valence 3 to
    // (9 v + 4 Σ e + Σ d) / 24 = v / 2, a face centre (regular: the bicubic B-spline's mask) to
    // 68/81 of the half side; the points of level 1 are points of level 2 too
    let m = refine_mesh(&cube(), 1).unwrap();
    assert_eq!(m.indices.len(), 6 * 4 * 2);
    assert_eq!(triangle_count(cube().subdivision.as_deref().unwrap(), 1), 48);
    let pts: HashSet<[i64; 3]> = m.positions.iter().map(|&p| rounded(p)).collect();
    assert_eq!(pts.len(), 8 + 12 + 6);
    assert!(pts.contains(&rounded(Vec3::splat(0.5))) && pts.contains(&rounded(Vec3::new(-0.5, 0.5, -0.5))));
    assert!(pts.contains(&rounded(Vec3::new(68.0 / 81.0, 0.0, 0.0))));
    let level2 = refine_mesh(&cube(), 2).unwrap();
    assert_eq!(level2.indices.len(), 6 * 16 * 2);
    let pts2: HashSet<[i64; 3]> = level2.positions.iter().map(|&p| rounded(p)).collect();
    assert!(pts.is_subset(&pts2));
    // winding kept: every triangle faces away from the centre; normals smooth and outward; every
    // point between the limit surface's bounds
    let normals = m.normals.as_ref().unwrap();
    for t in &m.indices {
        let centre = t.iter().map(|&i| m.positions[i as usize]).sum::<Vec3>() / 3.0;
        assert!(tri_normal(&m, *t).dot(centre) > 0.0);
    }
    for (p, n) in m.positions.iter().zip(normals) {
        assert!(p.dot(*n) > 0.5);
    }
    for p in &level2.positions {
        assert!((0.6..1.0).contains(&p.length()));
    }
}

#[test]
fn normals_are_the_limit_surfaces() {
    // against the area-weighted normals of the same points refined four levels further (they are
    // points of every finer level too), within 0.02°
    let m = refine_mesh(&cube(), 2).unwrap();
    let deep = Refinement::new(8, &[4; 6], &CUBE_IDX, 6, Scheme::CatmullClark, Boundary::EdgeAndCorner, &Creases::new(), &Corners::new()).unwrap();
    let dp: Vec<DVec3> = deep.points(&flat(&CUBE_PTS), 3, true).chunks_exact(3).map(DVec3::from_slice).collect();
    let mut acc = vec![DVec3::ZERO; deep.npts];
    for f in deep.fvi.chunks_exact(4) {
        let s = super::newell(&dp, f);
        f.iter().for_each(|&v| acc[v as usize] += s);
    }
    let key = |p: DVec3| (p * 1e4).round().as_i64vec3();
    let want: std::collections::HashMap<_, DVec3> = dp.iter().zip(&acc).map(|(&p, &n)| (key(p), n.normalize())).collect();
    let worst = m
        .positions
        .iter()
        .zip(m.normals.as_ref().unwrap())
        .map(|(p, n)| n.as_dvec3().dot(want[&key(p.as_dvec3())]).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f64::max);
    assert!(worst < 0.02, "{worst}");
}

#[test]
fn boundaries_and_sharp_creases_keep_their_shape() {
    // a flat 2×1 grid: edgeAndCorner keeps the corners and the boundary on its lines
    let grid = cage_mesh(&[[0., 0., 0.], [1., 0., 0.], [2., 0., 0.], [0., 1., 0.], [1., 1., 0.], [2., 1., 0.]], &[4, 4], &[0, 1, 4, 3, 1, 2, 5, 4], Scheme::CatmullClark);
    let g = refine_mesh(&grid, 3).unwrap();
    assert!(g.positions.iter().all(|p| p.z.abs() < 1e-6));
    for c in [[0., 0.], [2., 0.], [0., 1.], [2., 1.]] {
        assert!(g.positions.iter().any(|p| (p.truncate() - Vec2::from_array(c)).abs().max_element() < 1e-6), "{c:?}");
    }
    // a cube whose every edge is infinitely sharp stays a cube, flat in the shading on each face
    let mut sharp = cube();
    let edges = [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]];
    sd(&mut sharp).creases = edges.to_vec();
    sd(&mut sharp).crease_sharpness = vec![10.0; 12];
    let s = refine_mesh(&sharp, 3).unwrap();
    assert!(s.positions.iter().all(|p| (p.abs().max_element() - 1.0).abs() < 1e-5));
    assert!(s.positions.iter().any(|&p| rounded(p) == rounded(Vec3::ONE)));
    let normals = s.normals.as_ref().unwrap();
    for t in &s.indices {
        let face = tri_normal(&s, *t);
        for &i in t {
            assert!((normals[i as usize] - face).abs().max_element() < 1e-4);
        }
    }
    // a cube with one infinitely sharp corner
    let mut corner = cube();
    sd(&mut corner).corners = vec![6];
    sd(&mut corner).corner_sharpness = vec![10.0];
    let c = refine_mesh(&corner, 3).unwrap();
    let pts: HashSet<[i64; 3]> = c.positions.iter().map(|&p| rounded(p)).collect();
    assert!(pts.contains(&rounded(Vec3::ONE)) && !pts.contains(&rounded(-Vec3::ONE)));
}

#[test]
fn holes_materials_and_face_varying_uvs() {
    // three quads in a row, the third a hole; face 1 has its own material; face-varying uvs, one
    // square per face
    let mut m = cage_mesh(
        &[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.], [2., 0., 0.], [2., 1., 0.], [3., 0., 0.], [3., 1., 0.]],
        &[4, 4, 4],
        &[0, 1, 2, 3, 1, 4, 5, 2, 4, 6, 7, 5],
        Scheme::CatmullClark,
    );
    m.material_ids = vec![0, 1, 0];
    sd(&mut m).holes = vec![2];
    let square = [Vec2::new(0., 0.), Vec2::new(1., 0.), Vec2::new(1., 1.), Vec2::new(0., 1.)];
    sd(&mut m).uvs = Some(Primvar { mode: PrimvarMode::FaceVarying, values: square.repeat(3), indices: (0..12).collect() });
    let r = refine_mesh(&m, 1).unwrap();
    assert_eq!(r.indices.len(), 2 * 4 * 2);
    assert_eq!(r.material_ids, [[0u32; 8], [1; 8]].concat());
    let uvs: HashSet<[i64; 2]> = r.uvs.as_ref().unwrap().iter().map(|u| u.to_array().map(|c| (c * 1e5).round() as i64)).collect();
    assert!(uvs.contains(&[50000, 50000]) && uvs.contains(&[50000, 0]));
    // the cage itself (level 0): the hole dropped, the uvs as authored
    let c = refine_mesh(&m, 0).unwrap();
    assert_eq!(c.indices.len(), 4);
    assert_eq!(c.material_ids, vec![0, 0, 1, 1]);
}

/// A 3×3 grid of quads whose texture coordinates are its own x, y (face-varying, one island).
fn island(rule: FaceVaryingRule) -> Mesh {
    let pts: Vec<[f64; 3]> = (0..4)
        .flat_map(|y| (0..4).map(move |x| [x as f64 + 0.3 * ((x == 1 && y == 1) as u8 as f64), y as f64 - 0.2 * ((x == 2) as u8 as f64), 0.1 * ((x * 7 + y * 3) % 4) as f64]))
        .collect();
    let idx: Vec<u32> = (0..3u32).flat_map(|y| (0..3u32).flat_map(move |x| [y * 4 + x, y * 4 + x + 1, (y + 1) * 4 + x + 1, (y + 1) * 4 + x])).collect();
    let mut m = cage_mesh(&pts, &[4; 9], &idx, Scheme::CatmullClark);
    let values: Vec<Vec2> = idx.iter().map(|&i| Vec2::new(pts[i as usize][0] as f32, pts[i as usize][1] as f32)).collect();
    sd(&mut m).uvs = Some(Primvar { mode: PrimvarMode::FaceVarying, values, indices: (0..36).collect() });
    sd(&mut m).face_varying = rule;
    m
}

#[test]
fn face_varying_primvars_follow_the_smooth_rules_inside_their_islands() {
    // refined smoothly (cornersPlus1, USD's default) the coordinates stay the refined points' x, y;
    // refined linearly ("all") they do not
    let smooth = refine_mesh(&island(FaceVaryingRule::CornersPlus1), 2).unwrap();
    for (p, u) in smooth.positions.iter().zip(smooth.uvs.as_ref().unwrap()) {
        assert!((p.truncate() - *u).abs().max_element() < 1e-5, "{p} {u}");
    }
    let linear = refine_mesh(&island(FaceVaryingRule::All), 2).unwrap();
    let worst = linear.positions.iter().zip(linear.uvs.as_ref().unwrap()).map(|(p, u)| (p.truncate() - *u).abs().element_sum()).fold(0.0, f32::max);
    assert!(worst > 0.01);
}

#[test]
fn varying_primvars_are_refined_linearly() {
    // a 4×4 grid with one coordinate 1 at an interior vertex, 0 elsewhere: linear over the point
    // indices (USD varying) its peak stays 1 and every value is a multiple of 1/16 at level 2;
    // per vertex it follows the smooth rules and the limit
    let pts: Vec<[f64; 3]> = (0..5).flat_map(|y| (0..5).map(move |x| [x as f64, y as f64, 0.1 * ((x * 7 + y * 3) % 4) as f64])).collect();
    let idx: Vec<u32> = (0..4u32).flat_map(|y| (0..4u32).flat_map(move |x| [y * 5 + x, y * 5 + x + 1, (y + 1) * 5 + x + 1, (y + 1) * 5 + x])).collect();
    let hat: Vec<Vec2> = (0..25).map(|i| Vec2::new(if i == 13 { 1.0 } else { 0.0 }, 0.0)).collect();
    let mut varying = cage_mesh(&pts, &[4; 16], &idx, Scheme::CatmullClark);
    sd(&mut varying).uvs = Some(Primvar { mode: PrimvarMode::Linear, values: hat.clone(), indices: idx.clone() });
    let mut vertex = cage_mesh(&pts, &[4; 16], &idx, Scheme::CatmullClark);
    sd(&mut vertex).uvs = Some(Primvar { mode: PrimvarMode::Vertex, values: hat, indices: vec![] });
    let v: Vec<f32> = refine_mesh(&varying, 2).unwrap().uvs.unwrap().iter().map(|u| u.x).collect();
    assert_eq!(v.iter().copied().fold(0.0, f32::max), 1.0);
    assert!(v.iter().all(|x| ((x * 16.0) - (x * 16.0).round()).abs() < 1e-4));
    assert!(refine_mesh(&vertex, 2).unwrap().uvs.unwrap().iter().all(|u| u.x < 0.5));
}

#[test]
fn loop_bilinear_and_the_cage() {
    let tet = [[1., 1., 1.], [1., -1., -1.], [-1., 1., -1.], [-1., -1., 1.]];
    let l = refine_mesh(&cage_mesh(&tet, &[3; 4], &[0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2], Scheme::Loop), 1).unwrap();
    assert_eq!(l.indices.len(), 16);
    // a tip's limit (valence 3, χ = 1/5): (1 - 3/5) v + (sum of the others) / 5 = v / 5
    assert!(l.positions.iter().any(|&p| rounded(p) == rounded(Vec3::splat(0.2))));
    let b = refine_mesh(&cage_mesh(&CUBE_PTS, &[4; 6], &CUBE_IDX, Scheme::Bilinear), 1).unwrap();
    assert_eq!(b.indices.len(), 48);
    assert!(b.positions.iter().all(|p| (p.abs().max_element() - 1.0).abs() < 1e-6));
    // the cage: its polygons fan-triangulated, area-weighted normals (over the triangles: a
    // corner on two triangles of a face leans toward it)
    let c = refine_mesh(&cube(), 0).unwrap();
    assert_eq!(c.indices.len(), 12);
    assert_eq!(c.positions.len(), 8);
    for (p, n) in c.positions.iter().zip(c.normals.as_ref().unwrap()) {
        assert!((n.length() - 1.0).abs() < 1e-5 && n.dot(p.normalize()) > 0.9, "{n} at {p}");
    }
    // a flat square's cage: its own normal
    let sq = refine_mesh(&cage_mesh(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]], &[4], &[0, 1, 2, 3], Scheme::CatmullClark), 0).unwrap();
    assert!(sq.normals.unwrap().iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    // a Loop cage of quads is no Loop surface
    assert!(refine_mesh(&cage_mesh(&CUBE_PTS, &[4; 6], &CUBE_IDX, Scheme::Loop), 1).is_err());
}
