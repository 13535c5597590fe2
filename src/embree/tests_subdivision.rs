//! Subdivision surfaces in Embree against the limit masks of `crate::subdiv` (positions and the
//! tangent masks' normals), and their hits, instances and attributes.

use glam::{DVec3, Mat4, Vec3};

use super::*;
use crate::scene::subdiv::{Boundary, Scheme};
use crate::subdiv::tests::{bumpy_grid, flat, CUBE_IDX, CUBE_PTS};
use crate::subdiv::{Corners, Creases, Refinement};

fn device() -> Device {
    Device::new(1).unwrap()
}

/// The cage as an Embree subdivision mesh, every edge at `level` segments.
fn cage(pts: &[[f64; 3]], fvc: &[u32], fvi: &[u32], boundary: SubdivBoundary, cr: &Creases, co: &Corners, level: f32) -> SubdivisionMesh {
    let (creases, crease_weights) = cr.iter().map(|(&(a, b), &s)| ([a, b], s as f32)).unzip();
    let (corners, corner_weights) = co.iter().map(|(&v, &s)| (v, s as f32)).unzip();
    SubdivisionMesh {
        positions: pts.iter().map(|p| DVec3::from_array(*p).as_vec3()).collect(),
        face_counts: fvc.to_vec(),
        face_indices: fvi.to_vec(),
        holes: Vec::new(),
        creases,
        crease_weights,
        corners,
        corner_weights,
        boundary,
        edge_levels: vec![level; fvi.len()],
        attributes: Vec::new(),
    }
}

fn scene_of(mesh: SubdivisionMesh, placements: &[Mat4]) -> Scene {
    let mut b = SceneBuilder::new(&device()).unwrap();
    let m = b.add_subdivision_mesh(mesh).unwrap();
    for xf in placements {
        b.add_instance(m, *xf).unwrap();
    }
    b.commit().unwrap()
}

/// Embree's parameters (u, v) of the points of face `f` (of `n` points) that a refinement `levels`
/// deep has: quads on a grid of 2^levels, other faces on each sub-patch's grid of 2^(levels-1)
/// (encoded as Embree encodes sub-patches: U = 2l + u + 0.5, V = 2h + v + 0.5 for sub-patch
/// 4h + l).
fn params(n: u32, levels: u32) -> Vec<(f32, f32)> {
    if n == 4 {
        let k = 1 << levels;
        return (0..=k).flat_map(|i| (0..=k).map(move |j| (i as f32 / k as f32, j as f32 / k as f32))).collect();
    }
    let k = 1 << (levels - 1);
    (0..n)
        .flat_map(|s| {
            let (l, h) = ((s % 4) as f32, (s / 4) as f32);
            (0..=k).flat_map(move |i| (0..=k).map(move |j| (2.0 * l + i as f32 / k as f32 + 0.5, 2.0 * h + j as f32 / k as f32 + 0.5)))
        })
        .collect()
}

/// Every point Embree evaluates at the refinement's parameters lies on a limit point of the
/// masks and every limit point is one of them, and where the tangent masks give a normal,
/// Embree's dP/du × dP/dv against it. Returns the worst distance, the worst angle at ordinary
/// points and at extraordinary ones.
#[allow(clippy::too_many_arguments)]
fn compare(pts: &[[f64; 3]], fvc: &[u32], fvi: &[u32], boundary: Boundary, mode: SubdivBoundary, cr: &Creases, co: &Corners, what: &str) -> (f64, f64, f64) {
    const LEVELS: usize = 2;
    let r = Refinement::new(pts.len(), fvc, fvi, LEVELS, Scheme::CatmullClark, boundary, cr, co).unwrap();
    let raw = r.points(&flat(pts), 3, false);
    let lim = r.project(&raw, 3);
    let normals = r.limit_normals(&raw);
    let want: Vec<DVec3> = lim.chunks_exact(3).map(DVec3::from_slice).collect();
    let scene = scene_of(cage(pts, fvc, fvi, mode, cr, co, 4.0), &[Mat4::IDENTITY]);
    let mut got = Vec::new();
    for (f, &n) in fvc.iter().enumerate() {
        for (u, v) in params(n, LEVELS as u32) {
            let s = scene.surface_point(0, f as u32, u, v).unwrap();
            got.push((s.p.as_dvec3(), s.dpdu.as_dvec3().cross(s.dpdv.as_dvec3())));
        }
    }
    let nearest = |p: DVec3, set: &mut dyn Iterator<Item = DVec3>| set.map(|q| q.distance(p)).fold(f64::INFINITY, f64::min);
    let mut worst = 0.0f64;
    for (p, _) in &got {
        worst = worst.max(nearest(*p, &mut want.iter().copied()));
    }
    for q in &want {
        worst = worst.max(nearest(*q, &mut got.iter().map(|g| g.0)));
    }
    // near sharp features the masks are not exact (a dart takes the smooth mask): there Embree is
    // held to where the refinement converges, the same points refined 6 levels further (points
    // keep their indices from level to level; the refinement approaches the limit as 4^-levels)
    let far = Refinement::new(pts.len(), fvc, fvi, LEVELS + 6, Scheme::CatmullClark, boundary, cr, co).unwrap();
    let far = far.points(&flat(pts), 3, false);
    let (mut masks_far, mut embree_far) = (0.0f64, 0.0f64);
    for (i, q) in want.iter().enumerate() {
        let f = DVec3::from_slice(&far[3 * i..3 * i + 3]);
        masks_far = masks_far.max(q.distance(f));
        embree_far = embree_far.max(nearest(f, &mut got.iter().map(|g| g.0)));
    }
    // normals: against the tangent masks' (where they hold), and against the area-weighted normals
    // of the same points refined four levels further (they are points of every finer level), as
    // the refinement's own normals are tested
    let deep = Refinement::new(pts.len(), fvc, fvi, LEVELS + 4, Scheme::CatmullClark, boundary, cr, co).unwrap();
    let deep_lim = deep.project(&deep.points(&flat(pts), 3, false), 3);
    let deep_pts: Vec<DVec3> = deep_lim.chunks_exact(3).map(DVec3::from_slice).collect();
    let mut acc = vec![DVec3::ZERO; deep.npts];
    let mut off = 0usize;
    for &n in &deep.fvc {
        let face = &deep.fvi[off..off + n as usize];
        off += n as usize;
        let s = crate::subdiv::newell(&deep_pts, face);
        face.iter().for_each(|&v| acc[v as usize] += s);
    }
    let deg = |a: DVec3, b: DVec3| a.normalize().dot(b.normalize()).clamp(-1.0, 1.0).acos().to_degrees();
    // faces around each refined point: extraordinary points (not 4, nor a boundary's 1 or 2) are
    // where the parametrisation is singular
    let mut faces = vec![0u32; r.npts];
    r.fvi.iter().for_each(|&v| faces[v as usize] += 1);
    let (mut worst_mask, mut worst_deep, mut worst_extra) = (0.0f64, 0.0f64, 0.0f64);
    for (i, q) in want.iter().enumerate() {
        let Some(n) = normals[i] else { continue };
        let Some((_, e)) = got.iter().find(|(p, e)| p.distance(*q) < 1e-4 && e.length() > 0.0) else { continue };
        // (the point keeps its index in the deeper refinement)
        let (m, d) = (deg(*e, n), deg(*e, acc[i]));
        if [1, 2, 4].contains(&faces[i]) {
            worst_mask = worst_mask.max(m);
            worst_deep = worst_deep.max(d);
        } else {
            worst_extra = worst_extra.max(m.max(d));
        }
    }
    eprintln!(
        "{what}: positions within {worst:.2e} of the masks' ({embree_far:.2e} of the refinement 6 levels on, the masks {masks_far:.2e}); \
         normals within {worst_mask:.4}° of the tangent masks', {worst_deep:.4}° of the refinement 4 levels on \
         ({worst_extra:.4}° at extraordinary points)"
    );
    (worst.min(embree_far), worst_mask.max(worst_deep), worst_extra)
}

/// An open tube of 8 × 3 bumpy quads: every boundary point on two faces.
fn tube() -> (Vec<[f64; 3]>, Vec<u32>, Vec<u32>) {
    let pts = (0..4).flat_map(|j| (0..8).map(move |k| {
        let a = k as f64 * std::f64::consts::TAU / 8.0;
        let r = 1.0 + 0.2 * ((3 * j + k) % 4) as f64;
        [r * a.cos(), r * a.sin(), 0.7 * j as f64]
    }));
    let idx = (0..3u32).flat_map(|j| (0..8u32).flat_map(move |k| [8 * j + k, 8 * j + (k + 1) % 8, 8 * (j + 1) + (k + 1) % 8, 8 * (j + 1) + k]));
    (pts.collect(), vec![4; 24], idx.collect())
}

#[test]
fn limit_surface_is_the_masks() {
    // the cube (valence-3 corners, extraordinary), a bumpy grid with its boundary under
    // edgeAndCorner, an open tube under both rules, an infinitely sharp crease and corner, and
    // n-gons beside it (Embree's sub-patches). (Not edgeOnly at a boundary point of a single face:
    // there Embree's surface is up to 0.8 % of the edge length off the masks', and `prepare`
    // refines such meshes itself.)
    let (none_c, none_k) = (Creases::new(), Corners::new());
    let (g, gc, gi) = bumpy_grid(4);
    let crease: Creases = (0..4u32).map(|y| ((y * 5 + 2, (y + 1) * 5 + 2), f64::INFINITY)).collect();
    let corner: Corners = [(6u32, f64::INFINITY)].into();
    let mut more = g.clone();
    more.extend([[-1.0, 0.5, 0.2], [-1.5, 2.0, 0.0], [-0.8, 3.5, 0.1]]);
    let np = g.len() as u32;
    let ngon_c: Vec<u32> = gc.iter().copied().chain([5, 3]).collect();
    let ngon_i: Vec<u32> = gi.iter().copied().chain([0, 5, 10, np + 2, np + 1, 0, np + 1, np]).collect();
    let (t, tc, ti) = tube();
    let cases: [(&[[f64; 3]], &[u32], &[u32], Boundary, SubdivBoundary, &Creases, &Corners, &str); 6] = [
        (&CUBE_PTS, &[4; 6], &CUBE_IDX, Boundary::EdgeAndCorner, SubdivBoundary::PinCorners, &none_c, &none_k, "cube"),
        (&g, &gc, &gi, Boundary::EdgeAndCorner, SubdivBoundary::PinCorners, &none_c, &none_k, "grid, edgeAndCorner"),
        (&t, &tc, &ti, Boundary::EdgeAndCorner, SubdivBoundary::PinCorners, &none_c, &none_k, "tube, edgeAndCorner"),
        (&t, &tc, &ti, Boundary::EdgeOnly, SubdivBoundary::Smooth, &none_c, &none_k, "tube, edgeOnly"),
        (&g, &gc, &gi, Boundary::EdgeAndCorner, SubdivBoundary::PinCorners, &crease, &corner, "grid, crease and corner"),
        (&more, &ngon_c, &ngon_i, Boundary::EdgeAndCorner, SubdivBoundary::PinCorners, &none_c, &none_k, "grid with n-gons"),
    ];
    for (p, fvc, fvi, boundary, mode, cr, co, what) in cases {
        let (dist, deg, extraordinary) = compare(p, fvc, fvi, boundary, mode, cr, co, what);
        // (beside creases and corners Embree's patches are approximations: 1e-4 of the edge length)
        let tol = if cr.is_empty() { 2e-5 } else { 2e-4 };
        assert!(dist < tol, "{what}: a point {dist} from the limit masks' and the converged refinement");
        assert!(deg < 0.02, "{what}: a normal {deg}° from the tangent masks' or the refinement's");
        // (at an extraordinary point, where the parametrisation is singular, Embree's derivatives
        // are a few hundredths of a degree off)
        assert!(extraordinary < 0.1, "{what}: a normal {extraordinary}° off at an extraordinary point");
    }
}

#[test]
fn rays_hit_the_tessellated_limit_surface() {
    // the cube's limit surface lies between radii 0.6 and 1 (its corners' limits at v/2, its faces'
    // centres at 68/81); rays toward the centre hit it there, on the outside, and the hit point is
    // the limit point of the reported face and parameters within the tessellation's error, which
    // falls as the square of the edge rate
    let mut errors = Vec::new();
    for level in [8.0, 32.0] {
        let scene = scene_of(cage(&CUBE_PTS, &[4; 6], &CUBE_IDX, SubdivBoundary::PinCorners, &Creases::new(), &Corners::new(), level), &[Mat4::IDENTITY]);
        let mut worst = 0.0f32;
        for k in 0..200 {
            let a = k as f32 * 2.399963; // golden-angle spiral over the sphere
            let z = 1.0 - 2.0 * (k as f32 + 0.5) / 200.0;
            let d = Vec3::new((1.0 - z * z).sqrt() * a.cos(), (1.0 - z * z).sqrt() * a.sin(), z);
            let ray = Ray::new(d * 5.0, -d);
            let h = scene.intersect(&ray).expect("the cube is hit");
            let p = ray.org + ray.dir * h.t;
            assert!((0.6..1.0).contains(&p.length()), "{p}");
            assert!(h.ng.dot(p) > 0.0, "the geometric normal faces out");
            let s = scene.surface_point(h.instance, h.prim, h.u, h.v).unwrap();
            worst = worst.max(s.p.distance(p));
            assert!(s.dpdu.cross(s.dpdv).dot(h.ng) > 0.0, "dP/du × dP/dv follows the winding");
            assert!(scene.occluded(&ray));
        }
        assert!(scene.is_subdivision(0));
        let (lo, hi) = scene.bounds();
        assert!(lo.cmple(Vec3::splat(-0.5)).all() && hi.cmpge(Vec3::splat(0.5)).all());
        errors.push(worst);
    }
    eprintln!("hit point to its limit point: {:.2e} at 8 segments per edge, {:.2e} at 32", errors[0], errors[1]);
    assert!(errors[1] < 1e-3 && errors[1] < errors[0] / 8.0, "{errors:?}");
}

#[test]
fn instances_evaluate_in_world_space() {
    // the same surface placed twice (an Embree instance each), scaled and moved: its points and
    // derivatives come out transformed
    let xf = [Mat4::from_translation(Vec3::new(5.0, 0.0, 0.0)), Mat4::from_scale_rotation_translation(Vec3::new(2.0, 1.0, 1.0), glam::Quat::IDENTITY, Vec3::new(-5.0, 0.0, 0.0))];
    let scene = scene_of(cage(&CUBE_PTS, &[4; 6], &CUBE_IDX, SubdivBoundary::PinCorners, &Creases::new(), &Corners::new(), 4.0), &xf);
    let single = scene_of(cage(&CUBE_PTS, &[4; 6], &CUBE_IDX, SubdivBoundary::PinCorners, &Creases::new(), &Corners::new(), 4.0), &[Mat4::IDENTITY]);
    for (i, m) in xf.iter().enumerate() {
        let (a, b) = (scene.surface_point(i as u32, 2, 0.3, 0.6).unwrap(), single.surface_point(0, 2, 0.3, 0.6).unwrap());
        assert!(a.p.distance(m.transform_point3(b.p)) < 1e-5);
        assert!(a.dpdu.distance(m.transform_vector3(b.dpdu)) < 1e-4);
        let h = scene.intersect(&Ray::new(m.transform_point3(Vec3::new(0.0, 0.0, 5.0)), -Vec3::Z)).unwrap();
        assert_eq!(h.instance, i as u32);
        assert!(h.ng.z > 0.0);
    }
    assert!(scene.surface_point(7, 0, 0.0, 0.0).is_none());
}

#[test]
fn attributes_follow_their_own_topology() {
    // texture coordinates of a cube unfolded into six separate squares (a seam at every edge):
    // linear within each face, they are the face's own bilinear coordinates; vertex data follows
    // the surface's rules (a corner's value moves toward its neighbours' as its position does)
    let mut mesh = cage(&CUBE_PTS, &[4; 6], &CUBE_IDX, SubdivBoundary::PinCorners, &Creases::new(), &Corners::new(), 4.0);
    let square = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0];
    mesh.attributes.push(SubdivAttribute { width: 2, values: square.to_vec(), topology: Some(([0, 1, 2, 3].repeat(6), SubdivBoundary::PinAll)) });
    mesh.attributes.push(SubdivAttribute { width: 1, values: (0..8).map(|i| if i == 6 { 1.0 } else { 0.0 }).collect(), topology: None });
    let scene = scene_of(mesh, &[Mat4::IDENTITY]);
    let mut out = [0.0f32; 4];
    for f in 0..6 {
        for (u, v) in [(0.0, 0.0), (0.25, 0.5), (1.0, 1.0), (0.7, 0.1)] {
            assert!(scene.attribute(0, f, u, v, 0, &mut out));
            assert!((out[0] - u).abs() < 1e-5 && (out[1] - v).abs() < 1e-5, "face {f} ({u}, {v}): {out:?}");
        }
    }
    // point 6 = (1, 1, 1) is corner 2 of face 1 (4 5 6 7): its limit value (9·1 + 0 + 0)/24
    assert!(scene.attribute(0, 1, 1.0, 1.0, 1, &mut out));
    assert!((out[0] - 9.0 / 24.0).abs() < 1e-5, "{out:?}");
    assert!(!scene.attribute(0, 1, 1.0, 1.0, 2, &mut out));
}

#[test]
fn bad_subdivision_meshes_are_errors() {
    let mut b = SceneBuilder::new(&device()).unwrap();
    let good = cage(&CUBE_PTS, &[4; 6], &CUBE_IDX, SubdivBoundary::PinCorners, &Creases::new(), &Corners::new(), 1.0);
    let mut short = good.clone();
    short.edge_levels.pop();
    let mut far = good.clone();
    far.face_indices[3] = 8;
    let mut big = good.clone();
    big.face_counts = vec![24];
    let mut zero = good.clone();
    zero.edge_levels[0] = 0.0;
    for m in [short, far, big, zero] {
        assert!(matches!(b.add_subdivision_mesh(m), Err(crate::Error::Param { .. })));
    }
    assert!(b.add_subdivision_mesh(good).is_ok());
}

#[test]
fn holes_keep_their_place_in_the_topology() {
    // a flat 4 × 4 grid with face (1, 1) a hole: the hole shapes its neighbours as if it were
    // there (OpenSubdiv's and USD's holes), so the gap is exactly the square [1, 2]² (the limit of a
    // flat regular grid is the plane, its points' limits where they are); rays pass through it,
    // the neighbours are hit right up to its edges. (A hole left out of the topology makes a
    // boundary there, and its rounded border eats into the neighbours.)
    let (g, gc, gi) = bumpy_grid(4);
    let flat_pts: Vec<[f64; 3]> = g.iter().map(|p| [p[0], p[1], 0.0]).collect();
    let mut mesh = cage(&flat_pts, &gc, &gi, SubdivBoundary::PinCorners, &Creases::new(), &Corners::new(), 8.0);
    mesh.holes = vec![5];
    let scene = scene_of(mesh, &[Mat4::IDENTITY]);
    let down = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z);
    for (x, y) in [(1.5, 1.5), (1.03, 1.03), (1.97, 1.97), (1.03, 1.97)] {
        assert!(scene.intersect(&down(x, y)).is_none(), "({x}, {y}) is in the hole");
        assert!(!scene.occluded(&down(x, y)));
    }
    for (x, y) in [(1.5, 0.97), (0.97, 1.5), (2.03, 1.5), (1.5, 2.03), (0.97, 0.97)] {
        let h = scene.intersect(&down(x, y)).unwrap_or_else(|| panic!("({x}, {y}) misses the hole's neighbours"));
        assert_ne!(h.prim, 5);
    }
}
