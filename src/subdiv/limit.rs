//! Limit masks: each refined point's position on the limit surface, and the limit surface's
//! normal at smooth points.

use std::collections::HashMap;
use std::f64::consts::PI;

use super::stencil::{blend, Stencils};
use super::topology::{edge_key, INFINITE};
use super::{Refinement, Scheme};
use glam::DVec3;

impl Refinement {
    /// Stencils moving each point of the refined mesh to its position on the limit surface, by the
    /// rule its tags give it at the last level:
    /// - smooth (or dart): Catmull–Clark (n² v + 4 Σ eᵢ + Σ dᵢ) / (n (n + 5)) over the edge
    ///   neighbours eᵢ and the quads' diagonal points dᵢ [Halstead, Kass & DeRose 1993]; Loop
    ///   (1 − nχ) v + χ Σ eᵢ with χ = 1 / (3 / (8β) + n);
    /// - crease (two sharp edges to a and b): (a + 4 v + b) / 6, the cubic B-spline's limit; a
    ///   semi-sharp crease (s < 1) blends the smooth and crease rules by s;
    /// - corner (three or more sharp edges, or a corner tag): v; a semi-sharp corner blends.
    ///
    /// Sharpness left at the last level takes the sharp rule, as OpenSubdiv's limit masks do, and a
    /// dart (one sharp edge, where a crease ends inside the surface) the smooth mask (its exact
    /// limit differs by about 3e-4 of the edge length). A point whose faces do not close a fan
    /// around it (non-manifold) keeps its refined position.
    ///
    /// The last level's points are its input's points, edge points and (Catmull–Clark) face
    /// points, so their neighbourhoods follow from the input's topology without building the
    /// refined mesh's.
    pub(super) fn limit(&self) -> Stencils {
        let last = self.last.as_ref().expect("limit masks need a level");
        let (npts, fvc, fvi, t, corner) = (last.npts, &last.fvc, &last.fvi, &last.topo, &last.corner);
        let loop_ = self.scheme == Scheme::Loop;
        let ne = t.edges.len();
        let fbase = (npts + ne) as u32; // face points (Catmull–Clark)
        // the sharpness of each edge's two children (boundary and non-manifold: infinite)
        let child: Vec<f64> = t.edge_sharp.iter().map(|&s| if s >= INFINITE { s } else if s > 1.0 { s - 1.0 } else { 0.0 }).collect();
        let mut weights: HashMap<usize, (f64, f64, f64)> = HashMap::new();
        let mut smooth_mask = |v: u32, ring: &[u32], diagonals: &[u32]| -> Vec<(u32, f64)> {
            let n = ring.len();
            let c = *weights.entry(n).or_insert_with(|| {
                let nn = n as f64;
                if loop_ {
                    let beta = (0.625 - (0.375 + 0.25 * (2.0 * PI / nn).cos()).powi(2)) / nn;
                    let chi = 1.0 / (3.0 / (8.0 * beta) + nn);
                    (1.0 - nn * chi, chi, 0.0)
                } else {
                    let w = 1.0 / (nn * (nn + 5.0));
                    (nn * nn * w, 4.0 * w, w)
                }
            });
            let mut mask = vec![(v, c.0)];
            mask.extend(ring.iter().map(|&x| (x, c.1)));
            if !loop_ {
                mask.extend(diagonals.iter().map(|&x| (x, c.2)));
            }
            mask
        };
        let crease_mask = |v: u32, a: u32, b: u32, s: f64, smooth: &[(u32, f64)]| -> Vec<(u32, f64)> {
            let rule = [(v, 4.0 / 6.0), (a, 1.0 / 6.0), (b, 1.0 / 6.0)];
            if s < 1.0 {
                blend(smooth, &rule, s)
            } else {
                rule.to_vec()
            }
        };
        let mut out = Stencils::with_capacity(npts + ne + fvc.len());
        // Vertex points: the same edges (to their edge points) and faces (their face points the
        // diagonals) as before the level, the edges' sharpness that of their children.
        for v in 0..npts as u32 {
            let (ve, vf) = (t.vert_edges.get(v as usize), t.vert_faces.get(v as usize));
            let n = ve.len();
            // (an edge's children have its faces' count: boundary stays boundary)
            let (creased, vs) = t.vertex_tags(v, &child, corner, last.edge_and_corner);
            let nc = creased.len();
            let mut smooth = vec![(v, 1.0)];
            if n >= 3 && vf.len() == n && nc <= 2 {
                let ring: Vec<u32> = ve.iter().map(|&e| npts as u32 + e).collect();
                let diag: Vec<u32> = vf.iter().map(|&f| fbase + f).collect();
                smooth = smooth_mask(v, &ring, &diag);
            }
            let mut rule = if n == 0 || nc > 2 {
                vec![(v, 1.0)]
            } else if nc < 2 {
                smooth
            } else {
                let (a, b) = (npts as u32 + creased[0], npts as u32 + creased[1]);
                let s = (child[creased[0] as usize].min(1.0) + child[creased[1] as usize].min(1.0)) / 2.0;
                crease_mask(v, a, b, s, &smooth)
            };
            if vs > 0.0 {
                rule = blend(&rule, &[(v, 1.0)], vs.min(1.0));
            }
            out.push(&rule);
        }
        // Edge points: edges to the old edge's ends (its children) and, per face of the edge, to
        // the face point (Catmull–Clark) or to the face's two other edge points (Loop); the
        // diagonals of a Catmull–Clark edge point are the face's neighbouring edge points.
        for (e, &[a, b]) in t.edges.iter().enumerate() {
            let c = child[e];
            let m = npts as u32 + e as u32;
            let mut smooth = vec![(m, 1.0)];
            if t.edge_nf[e] == 2 {
                let (mut ring, mut diag) = (vec![a, b], Vec::new());
                for &f in t.faces_of(e) {
                    let (o, n) = (t.offs[f as usize] as usize, fvc[f as usize] as usize);
                    let k = t.face_edges[o..o + n].iter().position(|&x| x as usize == e).expect("the face has the edge");
                    let before = npts as u32 + t.face_edges[o + (k + n - 1) % n];
                    let after = npts as u32 + t.face_edges[o + (k + 1) % n];
                    if loop_ {
                        ring.extend([before, after]);
                    } else {
                        ring.push(fbase + f);
                        diag.extend([before, after]);
                    }
                }
                smooth = smooth_mask(m, &ring, &diag);
            }
            out.push(&if c > 0.0 { crease_mask(m, a, b, c.min(1.0), &smooth) } else { smooth });
        }
        // Face points (Catmull–Clark): n edges to the face's edge points, the face's corners the
        // diagonals; never sharp.
        if !loop_ {
            for (f, &n) in fvc.iter().enumerate() {
                let o = t.offs[f] as usize;
                let ring: Vec<u32> = (0..n as usize).map(|k| npts as u32 + t.face_edges[o + k]).collect();
                out.push(&if n >= 3 { smooth_mask(fbase + f as u32, &ring, &fvi[o..o + n as usize]) } else { vec![(fbase + f as u32, 1.0)] });
            }
        }
        out
    }

    /// Unit normals of the limit surface at the refined points, from `points` (the refined points
    /// as [`points`](Self::points) gives them without `limit`, 3 per point), where the tangent
    /// masks hold: at smooth points (no sharp edge, no corner tag) whose faces close a fan around
    /// them (Catmull–Clark: quads; Loop: triangles). Over the ring e₀ … eₙ₋₁ and the quads'
    /// diagonal points dᵢ (between eᵢ and eᵢ₊₁): Catmull–Clark t₁ = Σ Aₙ cos(2πi/n) eᵢ +
    /// (cos(2πi/n) + cos(2π(i+1)/n)) dᵢ and t₂ the same turned by one, Aₙ = 1 + cos(2π/n) +
    /// cos(π/n) √(2 (9 + cos(2π/n))) [Halstead, Kass & DeRose 1993]; Loop t₁ = Σ cos(2πi/n) eᵢ,
    /// t₂ = Σ sin(2πi/n) eᵢ; the normal their cross product, on the faces' front side. `None`
    /// elsewhere (creases, corners, darts, boundaries, and the cage and bilinear refinements).
    pub fn limit_normals(&self, points: &[f64]) -> Vec<Option<DVec3>> {
        let mut out = vec![None; self.npts];
        if self.levels.is_empty() || self.scheme == Scheme::Bilinear {
            return out;
        }
        let loop_ = self.scheme == Scheme::Loop;
        let side = if loop_ { 3 } else { 4 };
        // per point, its corners as (previous point, next point, diagonal point) around each face
        let mut around: Vec<Vec<(u32, u32, u32)>> = vec![Vec::new(); self.npts];
        let mut off = 0usize;
        for &n in &self.fvc {
            let n = n as usize;
            if n == side {
                let f = &self.fvi[off..off + n];
                for k in 0..n {
                    around[f[k] as usize].push((f[(k + n - 1) % n], f[(k + 1) % n], f[(k + 2) % n]));
                }
            }
            off += n;
        }
        let p = |i: u32| DVec3::new(points[3 * i as usize], points[3 * i as usize + 1], points[3 * i as usize + 2]);
        type Masks = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);
        let mut masks: HashMap<usize, Masks> = HashMap::new();
        for (v, cs) in around.iter().enumerate() {
            let n = cs.len();
            if n < 3 || self.corner.get(&(v as u32)).copied().unwrap_or(0.0) > 0.0 {
                continue;
            }
            // the fan in order: the face after a face (across the edge to its next point b) has b
            // as its previous point; the ring e₀ = the first face's previous point, dᵢ the
            // diagonal between eᵢ and eᵢ₊₁
            let mut by_prev: HashMap<u32, (u32, u32)> = HashMap::with_capacity(n);
            for &(a, b, d) in cs {
                by_prev.entry(a).or_insert((b, d));
            }
            if by_prev.len() != n {
                continue; // two faces leave v by the same edge: not a fan
            }
            let mut order = Vec::with_capacity(n);
            let mut e = cs[0].0;
            for _ in 0..n {
                let Some(&(b, d)) = by_prev.get(&e) else { break };
                order.push((e, d));
                e = b;
            }
            if order.len() != n || e != cs[0].0 {
                continue; // the fan does not close (a boundary) or visits v twice
            }
            if order.iter().any(|&(e, _)| self.sharp.get(&edge_key(v as u32, e)).copied().unwrap_or(0.0) > 0.0) {
                continue;
            }
            let (w1, w2, u1, u2) = masks.entry(n).or_insert_with(|| {
                let nn = n as f64;
                let cos: Vec<f64> = (0..n).map(|i| (2.0 * PI * i as f64 / nn).cos()).collect();
                let sin: Vec<f64> = (0..n).map(|i| (2.0 * PI * i as f64 / nn).sin()).collect();
                if loop_ {
                    (cos, sin, Vec::new(), Vec::new())
                } else {
                    let an = 1.0 + (2.0 * PI / nn).cos() + (PI / nn).cos() * (2.0 * (9.0 + (2.0 * PI / nn).cos())).sqrt();
                    let prev = |i: usize| cos[(i + n - 1) % n];
                    (
                        cos.iter().map(|x| an * x).collect(),
                        (0..n).map(|i| an * prev(i)).collect(),
                        (0..n).map(|i| cos[i] + cos[(i + 1) % n]).collect(),
                        (0..n).map(|i| prev(i) + cos[i]).collect(),
                    )
                }
            });
            let (mut a, mut b) = (DVec3::ZERO, DVec3::ZERO);
            for (i, &(e, dg)) in order.iter().enumerate() {
                a += w1[i] * p(e);
                b += w2[i] * p(e);
                if !u1.is_empty() {
                    a += u1[i] * p(dg);
                    b += u2[i] * p(dg);
                }
            }
            // t₂ × t₁: the ring is walked from each face's previous point to its next one, against
            // the faces' winding seen from their front
            let nrm = b.cross(a);
            let ln = nrm.length();
            if ln > 0.0 && ln.is_finite() {
                out[v] = Some(nrm / ln);
            }
        }
        out
    }
}
