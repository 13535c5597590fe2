//! Uniform refinement of subdivision surfaces (Catmull–Clark, Loop, bilinear) into polygon meshes
//! whose points lie on the limit surface: the path for the surfaces Embree does not evaluate
//! (Loop, bilinear) and for those that must be triangles (emitters, cut-outs, `--subdivision
//! cage`); Catmull–Clark surfaces otherwise go to Embree as cages (`prepare`).
//!
//! Each level splits every face (Catmull–Clark and bilinear: an n-gon into n quads; Loop: a
//! triangle into four) and places the new points by the scheme's rules:
//! - Catmull–Clark: face points at the face centroid, edge points (v0 + v1 + f0 + f1) / 4, vertex
//!   points (Q + 2R + (n − 3) v) / n [Catmull & Clark 1978];
//! - Loop: edge points 3/8 (v0 + v1) + 1/8 (opposite vertices), vertex points (1 − nβ) v + β Σ
//!   neighbours with Loop's β [Loop 1987];
//! - bilinear: centroids and midpoints, vertices unchanged.
//!
//! Sharp features follow DeRose, Kass & Truong 1998 (the rules OpenSubdiv applies): an edge of
//! sharpness s ≥ 1 is split at its midpoint, 0 < s < 1 blends the smooth and sharp rules by s,
//! and the two children of an edge have sharpness s − 1; a vertex on two sharp edges takes the
//! crease rule (6 v + a + b) / 8, on more (or a corner) stays put. Boundary edges are infinitely
//! sharp (`edgeAndCorner` and `edgeOnly`; with `edgeAndCorner` a boundary vertex of a single face
//! is a corner); non-manifold edges too. Holes keep their place in the topology (they shape their
//! neighbours) and are dropped by [`mesh`].
//!
//! After the last level [`Refinement::project`] moves each point onto the limit surface by its
//! limit mask ([`limit`]); smooth points also get the limit surface's normal from its tangent
//! masks ([`Refinement::limit_normals`]). Face-varying data follows the scheme over its own
//! topology (seams are boundaries), as `faceVaryingLinearInterpolation` says.

mod limit;
pub mod mesh;
mod normals;
mod stencil;
mod topology;
#[cfg(test)]
pub(crate) mod tests;
#[cfg(test)]
mod tests_mesh;

use std::collections::{HashMap, HashSet};

use crate::scene::subdiv::{Boundary, FaceVaryingRule, Scheme};
use stencil::{blend, Stencils};
use topology::{edge_key, other, Topology, INFINITE};
pub use normals::newell;
pub use topology::{Corners, Creases};

/// One level: stencils of its points (over the points before and then, for Catmull–Clark and
/// bilinear, the faces' centroids: index `npts + f`), of its face-vertices (over the face-vertices
/// before), the faces whose centroids the point stencils read, and the point count before.
struct Level {
    points: Stencils,
    face_vertices: Stencils,
    centroid_faces: Option<(Vec<u32>, Vec<u32>, Vec<u32>)>,
    /// The level's input edges (its edge points, in order), for linear refinement.
    edges: Vec<[u32; 2]>,
    npts: usize,
}

/// What the limit masks read: the last level's input topology and tags.
struct LastLevel {
    npts: usize,
    fvc: Vec<u32>,
    fvi: Vec<u32>,
    topo: Topology,
    corner: Corners,
    edge_and_corner: bool,
}

/// A mesh refined `levels` times. `fvc`, `fvi` are the refined faces (every face a quad, or a
/// triangle for Loop), `parent_face` the face of the cage each comes from; the cage's per-point
/// data is refined by [`Refinement::points`], its per-face-vertex data by
/// [`Refinement::face_varying`].
pub struct Refinement {
    pub scheme: Scheme,
    pub level_count: usize,
    pub npts: usize,
    pub fvc: Vec<u32>,
    pub fvi: Vec<u32>,
    pub parent_face: Vec<u32>,
    cage_fvc: Vec<u32>,
    cage_fvi: Vec<u32>,
    levels: Vec<Level>,
    last: Option<LastLevel>,
    limit_stencils: std::sync::OnceLock<Stencils>,
    /// The refined mesh's edges still sharp (s ≥ 1 at the last level: creases that stay hard).
    pub hard_edges: HashSet<(u32, u32)>,
    /// The refined mesh's creases and corners.
    sharp: Creases,
    corner: Corners,
}

/// Why a cage cannot be refined.
#[derive(Clone, Debug, PartialEq)]
pub enum RefineError {
    LoopNeedsTriangles,
    SmallFace { face: usize, count: u32 },
    RepeatedVertex { face: usize, vertices: String },
}

impl std::fmt::Display for RefineError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RefineError::LoopNeedsTriangles => write!(f, "the loop scheme needs triangles and this mesh has other faces"),
            RefineError::SmallFace { face, count } => write!(f, "face {face} has {count} vertices"),
            RefineError::RepeatedVertex { face, vertices } => write!(f, "face {face} names a vertex twice ({vertices})"),
        }
    }
}

/// Whether the rules cover the cage: `None`, or why not.
pub fn check_cage(scheme: Scheme, fvc: &[u32], fvi: &[u32]) -> Option<RefineError> {
    if scheme == Scheme::Loop && fvc.iter().any(|&c| c != 3) {
        return Some(RefineError::LoopNeedsTriangles);
    }
    if let Some(face) = fvc.iter().position(|&c| c < 3) {
        return Some(RefineError::SmallFace { face, count: fvc[face] });
    }
    let mut off = 0usize;
    for (face, &n) in fvc.iter().enumerate() {
        let vs = &fvi[off..off + n as usize];
        if (1..vs.len()).any(|i| vs[..i].contains(&vs[i])) {
            let vertices = vs.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(" ");
            return Some(RefineError::RepeatedVertex { face, vertices });
        }
        off += n as usize;
    }
    None
}

impl Refinement {
    /// Refine the cage (`npts` points, faces `fvc`/`fvi`) `levels` times.
    pub fn new(
        npts: usize,
        fvc: &[u32],
        fvi: &[u32],
        levels: usize,
        scheme: Scheme,
        boundary: Boundary,
        creases: &Creases,
        corners: &Corners,
    ) -> Result<Refinement, RefineError> {
        if let Some(e) = check_cage(scheme, fvc, fvi) {
            return Err(e);
        }
        let mut r = Refinement {
            scheme,
            level_count: levels,
            npts,
            fvc: fvc.to_vec(),
            fvi: fvi.to_vec(),
            parent_face: (0..fvc.len() as u32).collect(),
            cage_fvc: fvc.to_vec(),
            cage_fvi: fvi.to_vec(),
            levels: Vec::new(),
            last: None,
            limit_stencils: std::sync::OnceLock::new(),
            hard_edges: HashSet::new(),
            sharp: HashMap::new(),
            corner: HashMap::new(),
        };
        let (mut sharp, mut corner) = (creases.clone(), corners.clone());
        // `none` is refined as `edgeOnly` (its boundary faces kept); the caller says so
        let edge_and_corner = boundary == Boundary::EdgeAndCorner;
        for _ in 0..levels {
            (sharp, corner) = r.level(&sharp, &corner, edge_and_corner);
        }
        r.hard_edges = sharp.iter().filter(|(_, &s)| s >= 1.0).map(|(&e, _)| e).collect();
        r.sharp = sharp;
        r.corner = corner;
        Ok(r)
    }

    /// Per-point `data` (`width` values per point) of the cage, refined; with `limit`, then moved
    /// to the limit surface.
    pub fn points(&self, data: &[f64], width: usize, limit: bool) -> Vec<f64> {
        let mut data = data.to_vec();
        for l in &self.levels {
            if let Some(faces) = &l.centroid_faces {
                data.extend(centroids(faces, &data, width));
            }
            data = l.points.apply(&data, width);
        }
        if limit {
            self.project(&data, width)
        } else {
            data
        }
    }

    /// Per-point `data` refined linearly, as USD interpolates `varying` primvars (bilinearly over
    /// each face): a vertex point keeps its value, an edge point takes its edge's midpoint, a face
    /// point its face's centroid. Its own limit.
    pub fn varying(&self, data: &[f64], width: usize) -> Vec<f64> {
        let mut data = data.to_vec();
        for l in &self.levels {
            let mut st = Stencils::with_capacity(l.npts + l.edges.len());
            for v in 0..l.npts as u32 {
                st.push(&[(v, 1.0)]);
            }
            for &[a, b] in &l.edges {
                st.push(&[(a, 0.5), (b, 0.5)]);
            }
            if let Some(faces) = &l.centroid_faces {
                data.extend(centroids(faces, &data, width));
                for f in 0..faces.1.len() {
                    st.push(&[((l.npts + f) as u32, 1.0)]);
                }
            }
            data = st.apply(&data, width);
        }
        data
    }

    /// Refined per-point `data` (from [`points`](Self::points)) moved to the limit surface. The cage
    /// and bilinear refinements lie on their limit surfaces already.
    pub fn project(&self, data: &[f64], width: usize) -> Vec<f64> {
        if self.levels.is_empty() || self.scheme == Scheme::Bilinear {
            return data.to_vec();
        }
        self.limit_stencils.get_or_init(|| self.limit()).apply(data, width)
    }

    /// Per-face-vertex `data` of the cage, refined: the refined values and, per refined
    /// face-vertex, its value's index (`None`: one value per face-vertex). Linearly within each
    /// face for [`FaceVaryingRule::All`] (and the bilinear scheme), else smoothly by the mesh's
    /// scheme over the face-varying topology: corners of equal values are one point, an edge whose
    /// two faces disagree at an end is a seam, and seams are boundaries. Pinned (linear) there:
    /// `None` nothing, `CornersOnly` corners of a single face, `CornersPlus1` and `CornersPlus2`
    /// also points where three or more values meet, `Boundaries` every seam point.
    pub fn face_varying(&self, data: &[f64], width: usize, rule: FaceVaryingRule, limit: bool) -> (Vec<f64>, Option<Vec<u32>>) {
        if rule == FaceVaryingRule::All || self.scheme == Scheme::Bilinear || self.levels.is_empty() {
            let mut data = data.to_vec();
            for l in &self.levels {
                data = l.face_vertices.apply(&data, width);
            }
            return (data, None);
        }
        let (fvc, fvi) = (&self.cage_fvc, &self.cage_fvi);
        let mut ids: HashMap<(u32, Vec<u64>), u32> = HashMap::new();
        let mut values: Vec<f64> = Vec::new();
        let mut keys: Vec<u32> = Vec::new(); // each value's point
        let mut fv_ids = Vec::with_capacity(fvi.len());
        for (k, &v) in fvi.iter().enumerate() {
            let vals = &data[k * width..(k + 1) * width];
            // (+ 0.0: -0 and 0 are one value)
            let key = (v, vals.iter().map(|x| (x + 0.0).to_bits()).collect::<Vec<u64>>());
            let n = ids.len() as u32;
            let i = *ids.entry(key).or_insert_with(|| {
                values.extend_from_slice(vals);
                keys.push(v);
                n
            });
            fv_ids.push(i);
        }
        let mut per_vertex: HashMap<u32, u32> = HashMap::new();
        for &v in &keys {
            *per_vertex.entry(v).or_insert(0) += 1;
        }
        let pinned: Vec<u32> = match rule {
            FaceVaryingRule::CornersPlus1 | FaceVaryingRule::CornersPlus2 => {
                (0..keys.len() as u32).filter(|&i| per_vertex[&keys[i as usize]] >= 3).collect()
            }
            FaceVaryingRule::Boundaries => {
                // every point of a seam (an edge of the face-varying topology with one face)
                let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
                let mut off = 0usize;
                for &n in fvc {
                    let n = n as usize;
                    for k in 0..n {
                        *uses.entry(edge_key(fv_ids[off + k], fv_ids[off + (k + 1) % n])).or_insert(0) += 1;
                    }
                    off += n;
                }
                let mut p: Vec<u32> = uses.iter().filter(|(_, &u)| u == 1).flat_map(|(e, _)| [e.0, e.1]).collect();
                p.sort_unstable();
                p.dedup();
                p
            }
            _ => Vec::new(),
        };
        let boundary = if rule == FaceVaryingRule::None { Boundary::EdgeOnly } else { Boundary::EdgeAndCorner };
        let corners: Corners = pinned.into_iter().map(|i| (i, INFINITE)).collect();
        let fref = Refinement::new(keys.len(), fvc, &fv_ids, self.level_count, self.scheme, boundary, &HashMap::new(), &corners)
            .expect("the face-varying topology has the cage's faces");
        let out = fref.points(&values, width, limit);
        (out, Some(fref.fvi))
    }

    /// One level: its stencils, the child faces, and the children's sharpness.
    fn level(&mut self, sharp: &Creases, corner: &Corners, edge_and_corner: bool) -> (Creases, Corners) {
        let (npts, loop_, linear) = (self.npts, self.scheme == Scheme::Loop, self.scheme == Scheme::Bilinear);
        let (fvc, fvi) = (std::mem::take(&mut self.fvc), std::mem::take(&mut self.fvi));
        let nf = fvc.len();
        let t = Topology::new(npts, &fvc, &fvi, sharp);
        let ne = t.edges.len();
        let mut st = Stencils::with_capacity(npts + ne + nf);
        // Vertex points (new index = old index).
        for v in 0..npts as u32 {
            let (ve, vf) = (t.vert_edges.get(v as usize), t.vert_faces.get(v as usize));
            let n = ve.len();
            if n == 0 || linear {
                st.push(&[(v, 1.0)]);
                continue;
            }
            let (creased, vs) = t.vertex_tags(v, &t.edge_sharp, corner, edge_and_corner);
            let nc = creased.len();
            let es = |i: usize| t.edge_sharp[creased[i] as usize];
            let smooth = || -> Vec<(u32, f64)> {
                let nn = n as f64;
                if loop_ {
                    let beta = (0.625 - (0.375 + 0.25 * (2.0 * std::f64::consts::PI / nn).cos()).powi(2)) / nn;
                    std::iter::once((v, 1.0 - nn * beta)).chain(ve.iter().map(|&e| (other(t.edges[e as usize], v), beta))).collect()
                } else {
                    // (Q + 2R + (n − 3) v) / n = (n − 2)/n v + Σ others / n² + Σ centroids / (n |faces|)
                    let wq = 1.0 / (nn * vf.len() as f64);
                    std::iter::once((v, (nn - 2.0) / nn))
                        .chain(ve.iter().map(|&e| (other(t.edges[e as usize], v), 1.0 / (nn * nn))))
                        .chain(vf.iter().map(|&f| (npts as u32 + f, wq)))
                        .collect()
                }
            };
            let mut rule = if nc < 2 {
                smooth() // smooth or dart
            } else if nc == 2 {
                let (a, b) = (other(t.edges[creased[0] as usize], v), other(t.edges[creased[1] as usize], v));
                let r = vec![(v, 0.75), (a, 0.125), (b, 0.125)];
                let s = (es(0).min(1.0) + es(1).min(1.0)) / 2.0;
                if s < 1.0 {
                    blend(&smooth(), &r, s)
                } else {
                    r
                }
            } else {
                vec![(v, 1.0)]
            };
            if vs > 0.0 {
                rule = blend(&rule, &[(v, 1.0)], vs.min(1.0));
            }
            st.push(&rule);
        }
        // Edge points.
        for (e, &[a, b]) in t.edges.iter().enumerate() {
            let s = t.edge_sharp[e];
            if s >= 1.0 || linear {
                st.push(&[(a, 0.5), (b, 0.5)]);
                continue;
            }
            let fs = t.faces_of(e);
            let smooth: Vec<(u32, f64)> = if loop_ {
                let mut r = vec![(a, 0.375), (b, 0.375)];
                r.extend(fs.iter().map(|&f| {
                    let o = t.offs[f as usize] as usize;
                    (*fvi[o..o + 3].iter().find(|&&x| x != a && x != b).expect("a triangle has a third vertex"), 0.125)
                }));
                r
            } else {
                vec![(a, 0.25), (b, 0.25), (npts as u32 + fs[0], 0.25), (npts as u32 + fs[1], 0.25)]
            };
            if s > 0.0 {
                st.push(&blend(&smooth, &[(a, 0.5), (b, 0.5)], s));
            } else {
                st.push(&smooth);
            }
        }
        // Face points: the centroids themselves.
        if !loop_ {
            for f in 0..nf as u32 {
                st.push(&[(npts as u32 + f, 1.0)]);
            }
        }
        // Child faces, their face-vertex stencils, and the children's sharpness.
        let mut new_fvc = Vec::with_capacity(4 * nf);
        let mut new_fvi = Vec::with_capacity(4 * fvi.len());
        let mut new_parent = Vec::with_capacity(4 * nf);
        let mut fv = Stencils::with_capacity(4 * fvi.len());
        for f in 0..nf {
            let (o, n) = (t.offs[f] as usize, fvc[f] as usize);
            let ev = |k: usize| npts as u32 + t.face_edges[o + k]; // edge point after corner k
            let p = self.parent_face[f];
            let oo = o as u32;
            if loop_ {
                let (v0, v1, v2) = (fvi[o], fvi[o + 1], fvi[o + 2]);
                let (e01, e12, e20) = (ev(0), ev(1), ev(2));
                let m01 = [(oo, 0.5), (oo + 1, 0.5)];
                let m12 = [(oo + 1, 0.5), (oo + 2, 0.5)];
                let m20 = [(oo + 2, 0.5), (oo, 0.5)];
                new_fvc.extend([3, 3, 3, 3]);
                new_fvi.extend([v0, e01, e20, v1, e12, e01, v2, e20, e12, e01, e12, e20]);
                for s in [&[(oo, 1.0)][..], &m01, &m20, &[(oo + 1, 1.0)], &m12, &m01, &[(oo + 2, 1.0)], &m20, &m12, &m01, &m12, &m20] {
                    fv.push(s);
                }
                new_parent.extend([p; 4]);
                continue;
            }
            let fp = (npts + ne + f) as u32;
            let centre: Vec<(u32, f64)> = (0..n).map(|k| (oo + k as u32, 1.0 / n as f64)).collect();
            for k in 0..n {
                let km = if k > 0 { k - 1 } else { n - 1 };
                let k1 = if k + 1 < n { k + 1 } else { 0 };
                new_fvi.extend([fvi[o + k], ev(k), fp, ev(km)]);
                fv.push(&[(oo + k as u32, 1.0)]);
                fv.push(&[(oo + k as u32, 0.5), (oo + k1 as u32, 0.5)]);
                fv.push(&centre);
                fv.push(&[(oo + km as u32, 0.5), (oo + k as u32, 0.5)]);
            }
            new_fvc.extend(std::iter::repeat_n(4, n));
            new_parent.extend(std::iter::repeat_n(p, n));
        }
        let mut new_sharp = Creases::new();
        for (&(a, b), &s) in sharp {
            if let Some(&e) = t.edge_of.get(&(a, b)) {
                if s > 1.0 {
                    let m = npts as u32 + e;
                    new_sharp.insert(edge_key(a, m), s - 1.0);
                    new_sharp.insert(edge_key(b, m), s - 1.0);
                }
            }
        }
        let new_corner: Corners = corner.iter().filter(|(_, &s)| s > 1.0).map(|(&v, &s)| (v, s - 1.0)).collect();
        let npts_new = st.len();
        let centroid_faces = if loop_ { None } else { Some((t.offs.clone(), fvc.clone(), fvi.clone())) };
        self.levels.push(Level { points: st, face_vertices: fv, centroid_faces, edges: t.edges.clone(), npts });
        self.last = Some(LastLevel { npts, fvc, fvi, topo: t, corner: new_corner.clone(), edge_and_corner });
        self.npts = npts_new;
        self.fvc = new_fvc;
        self.fvi = new_fvi;
        self.parent_face = new_parent;
        (new_sharp, new_corner)
    }
}

/// Flat centroids of `faces` (offsets, counts, indices) over per-point `data`.
fn centroids(faces: &(Vec<u32>, Vec<u32>, Vec<u32>), data: &[f64], width: usize) -> Vec<f64> {
    let (offs, counts, idx) = faces;
    let mut out = Vec::with_capacity(offs.len() * width);
    for (&o, &n) in offs.iter().zip(counts) {
        let inv = 1.0 / n as f64;
        for c in 0..width {
            let s: f64 = (0..n as usize).map(|k| data[idx[o as usize + k] as usize * width + c]).sum();
            out.push(s * inv);
        }
    }
    out
}
