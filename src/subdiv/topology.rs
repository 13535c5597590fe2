//! The topology of one level of a refinement: face offsets, edges, what meets at each point, and
//! the sharpness tags as they apply to that level's edges.

use std::collections::HashMap;

/// The sharpness of boundary and non-manifold edges and of pinned points.
pub const INFINITE: f64 = 1e30;

/// Creases `(a, b)` with `a < b` → sharpness.
pub type Creases = HashMap<(u32, u32), f64>;
/// Corners: point → sharpness.
pub type Corners = HashMap<u32, f64>;

/// The unordered key of an edge.
#[inline]
pub fn edge_key(a: u32, b: u32) -> (u32, u32) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// Lists per element (point → its edges, point → its faces), flat.
#[derive(Clone, Debug, Default)]
pub struct Csr {
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Csr {
    /// From `(element, item)` pairs given in the order each element's list should keep.
    fn build(n: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> Csr {
        let mut start = vec![0u32; n + 1];
        for (e, _) in pairs.clone() {
            start[e as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; start[n] as usize];
        for (e, x) in pairs {
            items[fill[e as usize] as usize] = x;
            fill[e as usize] += 1;
        }
        Csr { start, items }
    }

    #[inline]
    pub fn get(&self, i: usize) -> &[u32] {
        &self.items[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// One level's mesh topology.
#[derive(Clone, Debug, Default)]
pub struct Topology {
    /// First face-vertex of each face.
    pub offs: Vec<u32>,
    /// Edges in order of first use (faces in order, each face's corners in order), `a < b`.
    pub edges: Vec<[u32; 2]>,
    /// Edge index of a key.
    pub edge_of: HashMap<(u32, u32), u32>,
    /// Faces of each edge: how many, and the first two.
    pub edge_nf: Vec<u32>,
    pub edge_f: Vec<[u32; 2]>,
    /// Per face-vertex: the edge from that corner to the next.
    pub face_edges: Vec<u32>,
    /// Sharpness of each edge: boundary and non-manifold edges (not two faces) infinite, else the
    /// crease tag's (0 without).
    pub edge_sharp: Vec<f64>,
    pub vert_edges: Csr,
    pub vert_faces: Csr,
}

impl Topology {
    pub fn new(npts: usize, fvc: &[u32], fvi: &[u32], sharp: &Creases) -> Topology {
        let nf = fvc.len();
        let mut offs = Vec::with_capacity(nf);
        let mut off = 0u32;
        for &n in fvc {
            offs.push(off);
            off += n;
        }
        let mut edge_of: HashMap<(u32, u32), u32> = HashMap::with_capacity(fvi.len());
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(fvi.len());
        let mut edge_nf: Vec<u32> = Vec::with_capacity(fvi.len());
        let mut edge_f: Vec<[u32; 2]> = Vec::with_capacity(fvi.len());
        let mut face_edges = Vec::with_capacity(fvi.len());
        for (f, &n) in fvc.iter().enumerate() {
            let o = offs[f] as usize;
            let n = n as usize;
            for k in 0..n {
                let (a, b) = (fvi[o + k], fvi[o + (k + 1) % n]);
                let key = edge_key(a, b);
                let e = *edge_of.entry(key).or_insert_with(|| {
                    edges.push([key.0, key.1]);
                    edge_nf.push(0);
                    edge_f.push([u32::MAX; 2]);
                    edges.len() as u32 - 1
                });
                let c = edge_nf[e as usize] as usize;
                if c < 2 {
                    edge_f[e as usize][c] = f as u32;
                }
                edge_nf[e as usize] += 1;
                face_edges.push(e);
            }
        }
        let edge_sharp = edges
            .iter()
            .zip(&edge_nf)
            .map(|(e, &n)| if n != 2 { INFINITE } else { sharp.get(&(e[0], e[1])).copied().unwrap_or(0.0) })
            .collect();
        let vert_edges = Csr::build(
            npts,
            edges.iter().enumerate().flat_map(|(e, &[a, b])| [(a, e as u32), (b, e as u32)]),
        );
        let vert_faces = Csr::build(
            npts,
            fvc.iter().enumerate().flat_map(|(f, &n)| {
                let o = offs[f] as usize;
                fvi[o..o + n as usize].iter().map(move |&v| (v, f as u32))
            }),
        );
        Topology { offs, edges, edge_of, edge_nf, edge_f, face_edges, edge_sharp, vert_edges, vert_faces }
    }

    /// The faces of edge `e` (all of them when it has at most two).
    #[inline]
    pub fn faces_of(&self, e: usize) -> &[u32] {
        let n = (self.edge_nf[e] as usize).min(2);
        &self.edge_f[e][..n]
    }

    /// A point's sharp edges (sharpness > 0 in `edge_sharp`) and its own sharpness (a corner tag;
    /// with `edge_and_corner` a boundary point of a single face is an infinitely sharp corner).
    pub fn vertex_tags(&self, v: u32, edge_sharp: &[f64], corner: &Corners, edge_and_corner: bool) -> (Vec<u32>, f64) {
        let ve = self.vert_edges.get(v as usize);
        let vf = self.vert_faces.get(v as usize);
        let creased: Vec<u32> = ve.iter().copied().filter(|&e| edge_sharp[e as usize] > 0.0).collect();
        let mut vs = corner.get(&v).copied().unwrap_or(0.0);
        if edge_and_corner
            && vf.len() == 1
            && creased.len() == 2
            && self.edge_nf[creased[0] as usize] == 1
            && self.edge_nf[creased[1] as usize] == 1
        {
            vs = INFINITE;
        }
        (creased, vs)
    }
}

/// The other end of an edge.
#[inline]
pub fn other(edge: [u32; 2], v: u32) -> u32 {
    if edge[0] == v {
        edge[1]
    } else {
        edge[0]
    }
}
