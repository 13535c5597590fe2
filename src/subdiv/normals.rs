//! Shading normals of a refined (or cage) polygon mesh: area-weighted per point, or per smooth fan
//! of faces where hard edges split a point's faces.

use std::collections::HashMap;

use super::topology::edge_key;
use super::Refinement;
use glam::DVec3;

/// Newell's normal of a polygon (area-weighted, any polygon).
pub fn newell(points: &[DVec3], face: &[u32]) -> DVec3 {
    let n = face.len();
    let mut s = DVec3::ZERO;
    for k in 0..n {
        let (a, b) = (points[face[k] as usize], points[face[(k + 1) % n] as usize]);
        s += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    s
}

/// `v` normalised, or zero where it has no length.
pub fn unit_or_zero(v: DVec3) -> DVec3 {
    let ln = v.length();
    if ln > 0.0 && ln.is_finite() {
        v / ln
    } else {
        DVec3::ZERO
    }
}

/// Area-weighted point normals over `triangles` (point indices), each replaced by `exact` where
/// that has one, turned to the side of the one it replaces.
pub fn smooth_normals(points: &[DVec3], triangles: &[[u32; 3]], exact: &[Option<DVec3>]) -> Vec<DVec3> {
    let mut acc = vec![DVec3::ZERO; points.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| points[i as usize]);
        let n = (b - a).cross(c - a);
        for &v in t {
            acc[v as usize] += n;
        }
    }
    acc.iter()
        .enumerate()
        .map(|(v, &s)| {
            let n = unit_or_zero(s);
            match exact.get(v).copied().flatten() {
                Some(e) if e.dot(n) < 0.0 => -e,
                Some(e) => e,
                None => n,
            }
        })
        .collect()
}

impl Refinement {
    /// Normals of the refined mesh per face-vertex, as (normals, index per face-vertex):
    /// area-weighted over the faces around each point (not `holes`, refined faces that are not
    /// rendered), but not across [`hard_edges`](Self::hard_edges) (a sharp crease stays a hard edge
    /// in the shading as in the surface); a point's `exact` normal where it has one (such a point
    /// has no sharp edge: one fan).
    pub fn corner_normals(&self, points: &[DVec3], holes: &[bool], exact: &[Option<DVec3>]) -> (Vec<DVec3>, Vec<u32>) {
        let (fvc, fvi) = (&self.fvc, &self.fvi);
        let mut offs = Vec::with_capacity(fvc.len());
        let mut off = 0usize;
        for &n in fvc {
            offs.push(off);
            off += n as usize;
        }
        let fnrm: Vec<DVec3> = fvc.iter().zip(&offs).map(|(&n, &o)| newell(points, &fvi[o..o + n as usize])).collect();
        // corners joined across every edge that is not hard: one group per smooth fan of a point
        let mut parent: Vec<u32> = (0..fvi.len() as u32).collect();
        fn find(parent: &mut [u32], mut i: u32) -> u32 {
            while parent[i as usize] != i {
                parent[i as usize] = parent[parent[i as usize] as usize];
                i = parent[i as usize];
            }
            i
        }
        let mut first: HashMap<(u32, u32), (u32, u32, u32)> = HashMap::new();
        for (f, &n) in fvc.iter().enumerate() {
            let (o, n) = (offs[f], n as usize);
            for k in 0..n {
                let (a, b) = (fvi[o + k], fvi[o + (k + 1) % n]);
                let key = edge_key(a, b);
                if self.hard_edges.contains(&key) {
                    continue;
                }
                let (ca, cb) = ((o + k) as u32, (o + (k + 1) % n) as u32); // this face's corners at a and b
                let other = *first.entry(key).or_insert((ca, cb, a));
                if other.0 == ca {
                    continue;
                }
                let (oa, ob) = if other.2 == a { (other.0, other.1) } else { (other.1, other.0) };
                for (c, d) in [(ca, oa), (cb, ob)] {
                    let (rc, rd) = (find(&mut parent, c), find(&mut parent, d));
                    if rc != rd {
                        parent[rc as usize] = rd;
                    }
                }
            }
        }
        let mut groups: HashMap<u32, u32> = HashMap::new();
        let (mut idx, mut sums, mut point_of) = (Vec::with_capacity(fvi.len()), Vec::new(), Vec::new());
        for (f, &n) in fvc.iter().enumerate() {
            for k in 0..n as usize {
                let c = (offs[f] + k) as u32;
                let root = find(&mut parent, c);
                let g = *groups.entry(root).or_insert_with(|| {
                    sums.push(DVec3::ZERO);
                    point_of.push(fvi[c as usize]);
                    sums.len() as u32 - 1
                });
                idx.push(g);
                if !holes[f] {
                    sums[g as usize] += fnrm[f];
                }
            }
        }
        let normals = sums
            .iter()
            .zip(&point_of)
            .map(|(&s, &v)| match exact.get(v as usize).copied().flatten() {
                Some(e) => unit_or_zero(if e.dot(s) < 0.0 { -e } else { e }),
                None => unit_or_zero(s),
            })
            .collect();
        (normals, idx)
    }
}
