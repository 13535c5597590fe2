//! The refinement's rules at one level, and the limit masks against refinement carried much
//! further.

use std::collections::HashMap;
use std::f64::consts::PI;

use super::topology::{Corners, Creases, Topology};
use super::*;
use glam::DVec3;

/// A cube of side 2 about the origin, faces outward.
pub const CUBE_PTS: [[f64; 3]; 8] =
    [[-1., -1., -1.], [1., -1., -1.], [1., 1., -1.], [-1., 1., -1.], [-1., -1., 1.], [1., -1., 1.], [1., 1., 1.], [-1., 1., 1.]];
pub const CUBE_IDX: [u32; 24] = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3];
/// A regular tetrahedron about the origin.
const TET_PTS: [[f64; 3]; 4] = [[1., 1., 1.], [1., -1., -1.], [-1., 1., -1.], [-1., -1., 1.]];
const TET_IDX: [u32; 12] = [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2];

const CC: Scheme = Scheme::CatmullClark;
const EC: Boundary = Boundary::EdgeAndCorner;

pub fn flat(points: &[[f64; 3]]) -> Vec<f64> {
    points.iter().flatten().copied().collect()
}

pub fn point(data: &[f64], i: usize) -> DVec3 {
    DVec3::from_slice(&data[3 * i..3 * i + 3])
}

fn refine(npts: usize, fvc: &[u32], fvi: &[u32], levels: usize, scheme: Scheme, boundary: Boundary, cr: &Creases, co: &Corners) -> Refinement {
    Refinement::new(npts, fvc, fvi, levels, scheme, boundary, cr, co).unwrap()
}

fn plain(npts: usize, fvc: &[u32], fvi: &[u32], levels: usize, scheme: Scheme) -> Refinement {
    refine(npts, fvc, fvi, levels, scheme, EC, &HashMap::new(), &HashMap::new())
}

/// An n × n grid of quads over [0, n]², its heights bumpy: (points, counts, indices).
pub fn bumpy_grid(n: u32) -> (Vec<[f64; 3]>, Vec<u32>, Vec<u32>) {
    let m = n + 1;
    let mut pts = Vec::new();
    for y in 0..m {
        for x in 0..m {
            let (xf, yf) = (x as f64, y as f64);
            pts.push([xf, yf, 0.3 * (1.7 * xf + 0.9 * yf).sin() + 0.05 * xf * yf]);
        }
    }
    let mut idx = Vec::new();
    for y in 0..n {
        for x in 0..n {
            idx.extend([y * m + x, y * m + x + 1, (y + 1) * m + x + 1, (y + 1) * m + x]);
        }
    }
    (pts, vec![4; (n * n) as usize], idx)
}

/// The grid's quads split into triangles.
fn triangles(idx: &[u32]) -> Vec<u32> {
    idx.chunks_exact(4).flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]]).collect()
}

/// Subdivision tags of `bumpy_grid(n)`: an infinitely sharp crease along x = 2 (which ends on the
/// boundary) and an infinitely sharp interior corner.
fn tags(n: u32) -> (Creases, Corners) {
    let m = n + 1;
    ((0..n).map(|y| ((y * m + 2, (y + 1) * m + 2), 100.0)).collect(), [(m + 1, 100.0)].into())
}

/// The limit stencils of `r`'s refined mesh built from that mesh's own topology: the oracle for
/// `Refinement::limit`, which derives them from the last level's input.
fn brute_force_limit(r: &Refinement, boundary: Boundary) -> Vec<Vec<(u32, f64)>> {
    let t = Topology::new(r.npts, &r.fvc, &r.fvi, &r.sharp);
    let loop_ = r.scheme == Scheme::Loop;
    let fvi = &r.fvi;
    let mut out = Vec::new();
    for v in 0..r.npts as u32 {
        let (ve, vf) = (t.vert_edges.get(v as usize), t.vert_faces.get(v as usize));
        let n = ve.len();
        let (creased, vs) = t.vertex_tags(v, &t.edge_sharp, &r.corner, boundary == EC);
        let nc = creased.len();
        let ring: Vec<u32> = ve.iter().map(|&e| topology::other(t.edges[e as usize], v)).collect();
        let mut smooth = vec![(v, 1.0)];
        if n >= 3 && vf.len() == n && nc <= 2 {
            let nn = n as f64;
            if loop_ {
                let beta = (0.625 - (0.375 + 0.25 * (2.0 * PI / nn).cos()).powi(2)) / nn;
                let chi = 1.0 / (3.0 / (8.0 * beta) + nn);
                smooth = std::iter::once((v, 1.0 - nn * chi)).chain(ring.iter().map(|&x| (x, chi))).collect();
            } else {
                let w = 1.0 / (nn * (nn + 5.0));
                let diag = vf.iter().map(|&f| {
                    let o = t.offs[f as usize] as usize;
                    let k = fvi[o..o + 4].iter().position(|&x| x == v).unwrap();
                    fvi[o + (k + 2) % 4]
                });
                smooth = std::iter::once((v, nn * nn * w)).chain(ring.iter().map(|&x| (x, 4.0 * w))).chain(diag.map(|x| (x, w))).collect();
            }
        }
        let mut rule = if n == 0 || nc > 2 {
            vec![(v, 1.0)]
        } else if nc < 2 {
            smooth
        } else {
            let ends: Vec<u32> = ve.iter().zip(&ring).filter(|(e, _)| creased.contains(e)).map(|(_, &x)| x).collect();
            let mut r = vec![(v, 4.0 / 6.0), (ends[0], 1.0 / 6.0), (ends[1], 1.0 / 6.0)];
            let s = (t.edge_sharp[creased[0] as usize].min(1.0) + t.edge_sharp[creased[1] as usize].min(1.0)) / 2.0;
            if s < 1.0 {
                r = stencil::blend(&smooth, &r, s);
            }
            r
        };
        if vs > 0.0 {
            rule = stencil::blend(&rule, &[(v, 1.0)], vs.min(1.0));
        }
        out.push(rule);
    }
    out
}

/// Area-weighted (Newell) vertex normals of `r`'s refined mesh at `points`.
fn area_normals(r: &Refinement, points: &[f64]) -> Vec<DVec3> {
    let pts: Vec<DVec3> = points.chunks_exact(3).map(DVec3::from_slice).collect();
    let mut acc = vec![DVec3::ZERO; r.npts];
    let mut off = 0usize;
    for &n in &r.fvc {
        let face = &r.fvi[off..off + n as usize];
        off += n as usize;
        let s = normals::newell(&pts, face);
        for &v in face {
            acc[v as usize] += s;
        }
    }
    acc.iter().map(|a| a.normalize()).collect()
}

/// Degrees between unit vectors.
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
}

/// A stencil as {index: summed weight} (the order and the splitting of terms aside).
fn as_weights(st: &[(u32, f64)]) -> HashMap<u32, f64> {
    let mut out: HashMap<u32, f64> = HashMap::new();
    for &(i, w) in st {
        *out.entry(i).or_insert(0.0) += w;
    }
    out.retain(|_, w| w.abs() > 1e-15);
    out
}

fn close(a: f64, b: f64, places: i32) -> bool {
    (a - b).abs() < 0.5 * 10f64.powi(-places)
}

#[test]
fn catmull_clark_rules_at_one_level() {
    // face points at the face centres, edge points (v0 + v1 + f0 + f1)/4, a corner of valence 3 at
    // (Q + 2R)/3 = 5/9 of it
    let r = plain(8, &[4; 6], &CUBE_IDX, 1, CC);
    let p = r.points(&flat(&CUBE_PTS), 3, false);
    let round = |x: f64| (x * 1e9).round() as i64;
    let pts: std::collections::HashSet<[i64; 3]> = (0..r.npts).map(|i| point(&p, i).to_array().map(round)).collect();
    assert_eq!(pts.len(), 8 + 12 + 6);
    assert!(pts.contains(&[1.0, 0.0, 0.0].map(round)));
    assert!(pts.contains(&[0.75, 0.75, 0.0].map(round)));
    assert!(pts.contains(&[5.0 / 9.0; 3].map(round)));
}

#[test]
fn loop_rule_at_one_level() {
    // Loop's vertex rule at valence 3 (beta = 3/16): a tip moves to (1 - 9/16) v + 3/16 (sum of the
    // others) = v / 4
    let r = plain(4, &[3; 4], &TET_IDX, 1, Scheme::Loop);
    for c in point(&r.points(&flat(&TET_PTS), 3, false), 0).to_array() {
        assert!(close(c, 0.25, 12), "{c}");
    }
}

#[test]
fn faces_no_rule_covers_are_refused() {
    let (cr, co) = (Creases::new(), Corners::new());
    for (scheme, fvc, fvi) in [(Scheme::Loop, vec![3, 3], vec![0, 1, 2, 1, 1, 3]), (CC, vec![4], vec![0, 1, 1, 2])] {
        let e = Refinement::new(4, &fvc, &fvi, 1, scheme, EC, &cr, &co).err().unwrap();
        assert!(e.to_string().contains("names a vertex twice"), "{e}");
    }
    for (fvc, fvi) in [(vec![4, 0], vec![0, 1, 2, 3]), (vec![2], vec![0, 1])] {
        let e = Refinement::new(4, &fvc, &fvi, 1, Scheme::Bilinear, EC, &cr, &co).err().unwrap();
        assert!(matches!(e, RefineError::SmallFace { .. }), "{e}");
    }
    let e = Refinement::new(8, &[4; 6], &CUBE_IDX, 1, Scheme::Loop, EC, &cr, &co).err().unwrap();
    assert_eq!(e, RefineError::LoopNeedsTriangles);
}

#[test]
fn cage_corners_have_their_analytic_limits() {
    // Catmull–Clark, a cube's corner (valence 3): (9 v + 4 Σ e + Σ d) / 24 = v / 2; Loop, a
    // tetrahedron's tip (valence 3, χ = 1/5): (1 - 3/5) v + (Σ e) / 5 = v / 5; the same at every
    // level, and the refined points without the projection are not there
    for levels in 1..=3 {
        let cc = plain(8, &[4; 6], &CUBE_IDX, levels, CC);
        let lp = plain(4, &[3; 4], &TET_IDX, levels, Scheme::Loop);
        for (r, pts, scale) in [(&cc, &CUBE_PTS[..], 0.5), (&lp, &TET_PTS[..], 0.2)] {
            let (lim, raw) = (r.points(&flat(pts), 3, true), r.points(&flat(pts), 3, false));
            for (i, v) in pts.iter().enumerate() {
                let want = DVec3::from_array(*v) * scale;
                assert!((point(&lim, i) - want).abs().max_element() < 1e-12);
                assert!(point(&raw, i).distance(want) > 1e-4);
            }
        }
    }
}

#[test]
fn limit_masks_equal_those_of_the_refined_mesh_itself() {
    // `limit` reads each refined point's neighbourhood off the last level's input; the masks built
    // from the refined mesh's own topology must be the same, for every rule: smooth points of every
    // valence, darts, creases (infinite, semi-sharp left over, blended), corners (tagged,
    // semi-sharp, edgeAndCorner's single-face corners), boundaries, holes' neighbours, n-gons, a
    // non-manifold edge
    let (pts, counts, idx) = bumpy_grid(4);
    let crease: Creases = [((2, 7), 100.0), ((7, 12), 1.5), ((12, 17), 2.4), ((17, 22), 0.6), ((6, 7), 1.2)].into();
    let corner: Corners = [(6, 1.3), (18, 100.0), (16, 0.4)].into();
    let tris = triangles(&idx);
    // a pentagon and a triangle beside the grid, and a fin on the edge (0, 1): non-manifold
    let mut more_pts = pts.clone();
    more_pts.extend([[-1.0, 0.5, 0.2], [-1.5, 2.0, 0.0], [-0.8, 3.5, 0.1], [0.5, -1.0, 0.5]]);
    let (np, fin) = (pts.len() as u32, pts.len() as u32 + 3);
    let ngon_c: Vec<u32> = counts.iter().copied().chain([5, 3, 3]).collect();
    let ngon_i: Vec<u32> = idx.iter().copied().chain([0, 5, 10, np + 2, np + 1, 0, np + 1, np, 0, 1, fin]).collect();
    let tri_c = vec![3u32; tris.len() / 3];
    let tri_c1 = vec![3u32; tris.len() / 3 + 1];
    let tris1: Vec<u32> = tris.iter().copied().chain([0, 1, fin]).collect();
    let cases: [(Scheme, &[[f64; 3]], &[u32], &[u32], Boundary); 5] = [
        (CC, &pts, &counts, &idx, EC),
        (CC, &pts, &counts, &idx, Boundary::EdgeOnly),
        (CC, &more_pts, &ngon_c, &ngon_i, EC),
        (Scheme::Loop, &pts, &tri_c, &tris, EC),
        (Scheme::Loop, &more_pts, &tri_c1, &tris1, Boundary::EdgeOnly),
    ];
    for (scheme, p, fvc, fvi, boundary) in cases {
        for levels in [1, 2] {
            let r = refine(p.len(), fvc, fvi, levels, scheme, boundary, &crease, &corner);
            let got = r.limit();
            let want = brute_force_limit(&r, boundary);
            assert_eq!(got.len(), want.len());
            for (i, w) in want.iter().enumerate() {
                let (gi, gw) = got.get(i);
                let g = as_weights(&gi.iter().copied().zip(gw.iter().copied()).collect::<Vec<_>>());
                let w = as_weights(w);
                let mut gk: Vec<_> = g.keys().collect();
                let mut wk: Vec<_> = w.keys().collect();
                gk.sort();
                wk.sort();
                assert_eq!(gk, wk, "{scheme:?} {boundary:?} {levels} {i}");
                for k in g.keys() {
                    assert!(close(g[k], w[k], 12), "{scheme:?} {boundary:?} {levels} {i}");
                }
            }
        }
    }
}

#[test]
fn limit_is_where_further_refinement_converges() {
    // every refined point's limit position against the same point refined five levels more (the
    // refinement converges to the limit as 4^-levels): boundaries (both interpolateBoundary rules),
    // an infinitely sharp crease and corner, Catmull–Clark and Loop
    let (pts, counts, idx) = bumpy_grid(4);
    let tris = triangles(&idx);
    let (crease, corner) = tags(4);
    let none = (Creases::new(), Corners::new());
    let tri_c = vec![3u32; tris.len() / 3];
    let cases: [(Scheme, &[u32], &[u32], Boundary, &Creases, &Corners); 3] = [
        (CC, &counts, &idx, EC, &crease, &corner),
        (CC, &counts, &idx, Boundary::EdgeOnly, &none.0, &none.1),
        (Scheme::Loop, &tri_c, &tris, EC, &crease, &corner),
    ];
    let fp = flat(&pts);
    for (scheme, fvc, fvi, boundary, cr, co) in cases {
        let r = refine(pts.len(), fvc, fvi, 1, scheme, boundary, cr, co);
        let deep = refine(pts.len(), fvc, fvi, 6, scheme, boundary, cr, co);
        let (lim, far, raw) = (r.points(&fp, 3, true), deep.points(&fp, 3, false), r.points(&fp, 3, false));
        let worst = (0..r.npts).map(|i| point(&lim, i).distance(point(&far, i))).fold(0.0, f64::max);
        let before = (0..r.npts).map(|i| point(&raw, i).distance(point(&far, i))).fold(0.0, f64::max);
        assert!(worst < 3e-4, "{scheme:?} {boundary:?}: {worst}");
        assert!(before > 30.0 * worst, "{scheme:?} {boundary:?}");
        // the sharp corner and the crease's ends on the boundary stay put
        if !co.is_empty() {
            assert_eq!(point(&lim, 6), DVec3::from_array(pts[6]));
            assert_eq!(point(&lim, 2), DVec3::from_array(pts[2]));
        }
    }
}

#[test]
fn limit_positions_do_not_depend_on_the_level() {
    // a point's limit is a point of the surface: the cage's points and the level-1 points land on
    // the same place from levels 1, 2 and 3 (a crease across the grid, from boundary to boundary,
    // and a corner; a dart takes the smooth mask and is not exact)
    let (pts, counts, idx) = bumpy_grid(3);
    let crease: Creases = [((1, 5), 100.0), ((5, 9), 100.0), ((9, 13), 100.0)].into();
    let corner: Corners = [(10, 100.0)].into();
    let refs: Vec<Refinement> = (1..=3).map(|k| refine(pts.len(), &counts, &idx, k, CC, EC, &crease, &corner)).collect();
    let lims: Vec<Vec<f64>> = refs.iter().map(|r| r.points(&flat(&pts), 3, true)).collect();
    for lim in &lims[1..] {
        for i in 0..refs[0].npts {
            assert!((point(&lims[0], i) - point(lim, i)).abs().max_element() < 5e-10);
        }
    }
}

#[test]
fn limit_normals_are_those_of_the_limit_surface() {
    // the tangent masks' normals at smooth points against the area-weighted normals of the limit
    // points six levels deeper (within 0.02°; the area-weighted normals of the level's own limit
    // points are off by tenths of a degree to degrees); creases, corners and the boundary get none
    let (pts, counts, idx) = bumpy_grid(3);
    let tris = triangles(&idx);
    let crease: Creases = [((1, 5), 100.0), ((5, 9), 100.0), ((9, 13), 100.0)].into();
    let corner: Corners = [(10, 100.0)].into();
    let none = (Creases::new(), Corners::new());
    let tri_c = vec![3u32; tris.len() / 3];
    let cases: [(Scheme, &[u32], &[u32], &[[f64; 3]], (&Creases, &Corners)); 3] = [
        (CC, &counts, &idx, &pts, (&crease, &corner)),
        (Scheme::Loop, &tri_c, &tris, &pts, (&crease, &corner)),
        (CC, &[4; 6], &CUBE_IDX, &CUBE_PTS, (&none.0, &none.1)),
    ];
    for (scheme, fvc, fvi, p, (cr, co)) in cases {
        let cube = fvc.len() == 6;
        let r = refine(p.len(), fvc, fvi, 1, scheme, EC, cr, co);
        let deep = refine(p.len(), fvc, fvi, 5, scheme, EC, cr, co);
        let want = area_normals(&deep, &deep.points(&flat(p), 3, true));
        let raw = r.points(&flat(p), 3, false);
        let (got, approx) = (r.limit_normals(&raw), area_normals(&r, &r.project(&raw, 3)));
        let smooth: Vec<usize> = (0..r.npts).filter(|&i| got[i].is_some()).collect();
        assert!(smooth.len() > r.npts / 3, "{scheme:?}");
        let worst = smooth.iter().map(|&i| angle(got[i].unwrap(), want[i])).fold(0.0, f64::max);
        let before = smooth.iter().map(|&i| angle(approx[i], want[i])).fold(0.0, f64::max);
        assert!(worst < 0.02, "{scheme:?}: {worst}");
        if !cube {
            // (the cube's level-1 points lie on its symmetry planes)
            assert!(before > 0.5, "{scheme:?}");
            for v in [1, 5, 9, 13, 10, 0, 4] {
                assert!(got[v].is_none(), "{scheme:?} {v}");
            }
        }
    }
}

#[test]
fn face_varying_data_takes_the_limit_over_its_own_topology() {
    // a grid whose texture coordinates are its own x, y: smooth face-varying refinement with the
    // limit gives every refined corner the (x, y) of its limit point
    let (pts, counts, idx) = bumpy_grid(3);
    let r = plain(pts.len(), &counts, &idx, 2, CC);
    let lim = r.points(&flat(&pts), 3, true);
    let uvs: Vec<f64> = idx.iter().flat_map(|&i| [pts[i as usize][0], pts[i as usize][1]]).collect();
    let (uv, uidx) = r.face_varying(&uvs, 2, FaceVaryingRule::CornersPlus1, true);
    let uidx = uidx.unwrap();
    for (c, &v) in r.fvi.iter().enumerate() {
        let u = uidx[c] as usize;
        assert!(close(uv[2 * u], lim[3 * v as usize], 9));
        assert!(close(uv[2 * u + 1], lim[3 * v as usize + 1], 9));
    }
}

#[test]
fn varying_data_is_refined_linearly() {
    // Catmull–Clark with creases and a corner: varying data refines as the bilinear scheme refines
    // the same data (same topology, same point order), at every level, and unlike the smooth rules
    // keeps a lone peak at its vertex
    let (pts, counts, idx) = bumpy_grid(4);
    let (crease, corner) = tags(4);
    let hat: Vec<f64> = (0..pts.len()).map(|i| if i == 13 { 1.0 } else { 0.0 }).collect();
    for levels in 1..=3 {
        let r = refine(pts.len(), &counts, &idx, levels, CC, EC, &crease, &corner);
        let lin = plain(pts.len(), &counts, &idx, levels, Scheme::Bilinear);
        assert_eq!((&r.fvc, &r.fvi), (&lin.fvc, &lin.fvi));
        let got = r.varying(&hat, 1);
        assert_eq!(got, lin.points(&hat, 1, false));
        assert_eq!(got[13], 1.0);
        assert!(r.points(&hat, 1, true)[13] < 0.5);
        // values of a bilinear hat at dyadic points: multiples of 1/4^levels
        let step = 4f64.powi(levels as i32);
        for x in &got {
            assert!(close(x * step, (x * step).round(), 9));
        }
    }
    // Loop: vertex points keep their value, edge points take the edge's midpoint
    let r = plain(4, &[3; 4], &TET_IDX, 1, Scheme::Loop);
    let data = [1.0, 2.0, 4.0, 8.0];
    let got = r.varying(&data, 1);
    assert_eq!(&got[..4], &data);
    let mut mids = got[4..].to_vec();
    mids.sort_by(f64::total_cmp);
    let mut want: Vec<f64> = (0..4).flat_map(|a| (a + 1..4).map(move |b| (data[a] + data[b]) / 2.0)).collect();
    want.sort_by(f64::total_cmp);
    assert_eq!(mids, want);
    // two levels: every value an average of the cage's
    let got = plain(4, &[3; 4], &TET_IDX, 2, Scheme::Loop).varying(&data, 1);
    assert_eq!(got.len(), 4 + 6 + 24);
    assert_eq!(got.iter().copied().fold(f64::INFINITY, f64::min), 1.0);
    assert_eq!(got.iter().copied().fold(0.0, f64::max), 8.0);
}
