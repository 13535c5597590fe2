//! A subdivision mesh of the scene ([`Mesh::subdivision`]) as a triangle mesh: its cage refined
//! uniformly, points on the limit surface, with normals, texture coordinates, vertex colours and
//! materials; or the cage itself (level 0).

use std::collections::HashMap;

use glam::{DVec3, Vec2, Vec3};

use super::normals::smooth_normals;
use super::topology::{edge_key, Corners, Creases};
use super::{check_cage, RefineError, Refinement};
use crate::scene::subdiv::{Boundary, FaceVaryingRule, PrimvarMode, Scheme, Subdivision};
use crate::scene::Mesh;

/// The most faces a refinement makes; a mesh is refined fewer times rather than beyond it.
pub const MAX_REFINED_FACES: usize = 2_000_000;

/// How many of `want` levels fit in [`MAX_REFINED_FACES`].
pub fn fitting_levels(sd: &Subdivision, want: u32) -> u32 {
    // faces after the first level (Catmull–Clark and bilinear: a quad per face-vertex)
    let first = if sd.scheme == Scheme::Loop { 4 * sd.face_counts.len() } else { sd.face_indices.len() };
    let mut fits = 0;
    while fits < want && first.saturating_mul(4usize.saturating_pow(fits)) <= MAX_REFINED_FACES {
        fits += 1;
    }
    fits
}

/// The triangles [`refine_mesh`] makes of `sd` at `levels` (holes and faces of fewer than three
/// points left out).
pub fn triangle_count(sd: &Subdivision, levels: u32) -> usize {
    let mut hole = vec![false; sd.face_counts.len()];
    sd.holes.iter().for_each(|&f| hole[f as usize] = true);
    let per_face = |c: usize| match (levels, sd.scheme) {
        (0, _) => c.saturating_sub(2),
        (l, Scheme::Loop) => 4usize.pow(l),
        (l, _) => 2 * c * 4usize.pow(l - 1),
    };
    sd.face_counts.iter().zip(&hole).filter(|(&c, &h)| !h && c >= 3).map(|(&c, _)| per_face(c as usize)).sum()
}

/// Why a cage is rendered as it is (`None`: the rules cover it).
pub fn cage_reason(sd: &Subdivision) -> Option<RefineError> {
    check_cage(sd.scheme, &sd.face_counts, &sd.face_indices)
}

/// How an attribute maps onto the refined polygons: one value per point (through an index, or
/// the point's own), or one per face-vertex (through an index, or its own).
enum Plan {
    Vertex(Option<Vec<u32>>),
    Corner(Option<Vec<u32>>),
}

struct Attr {
    values: Vec<f32>,
    width: usize,
    plan: Plan,
}

/// `mesh` (which has a [`Subdivision`]) refined `levels` times into triangles (0: its cage,
/// triangulated, with area-weighted normals). Holes are dropped, faces of fewer than three
/// vertices too (only the cage can have them). Errors when the rules do not cover the cage
/// ([`cage_reason`]) and `levels > 0`.
pub fn refine_mesh(mesh: &Mesh, levels: u32) -> Result<Mesh, RefineError> {
    let sd = mesh.subdivision.as_deref().expect("refine_mesh needs a subdivision mesh");
    let cage: Vec<f64> = mesh.positions.iter().flat_map(|p| p.to_array()).map(f64::from).collect();
    let npts = mesh.positions.len();
    let is_hole = {
        let mut h = vec![false; sd.face_counts.len()];
        for &f in &sd.holes {
            if let Some(x) = h.get_mut(f as usize) {
                *x = true;
            }
        }
        h
    };
    let refinement = if levels > 0 {
        let mut creases = Creases::new();
        for (e, &s) in sd.creases.iter().zip(&sd.crease_sharpness) {
            let k = edge_key(e[0], e[1]);
            let old = creases.get(&k).copied().unwrap_or(0.0);
            creases.insert(k, old.max(s as f64));
        }
        let corners: Corners = sd.corners.iter().zip(&sd.corner_sharpness).map(|(&v, &s)| (v, s as f64)).collect();
        // `none` is refined as `edgeOnly`: its boundary faces are kept
        let boundary = if sd.boundary == Boundary::None { Boundary::EdgeOnly } else { sd.boundary };
        Some(Refinement::new(npts, &sd.face_counts, &sd.face_indices, levels as usize, sd.scheme, boundary, &creases, &corners)?)
    } else {
        None
    };
    let (fvc, fvi, parent): (&[u32], &[u32], Vec<u32>) = match &refinement {
        Some(r) => (&r.fvc, &r.fvi, r.parent_face.clone()),
        None => (&sd.face_counts, &sd.face_indices, (0..sd.face_counts.len() as u32).collect()),
    };
    let (points, exact) = match &refinement {
        Some(r) => {
            let raw = r.points(&cage, 3, false);
            let exact = r.limit_normals(&raw);
            (r.project(&raw, 3), exact)
        }
        None => (cage.clone(), vec![None; npts]),
    };
    let pts: Vec<DVec3> = points.chunks_exact(3).map(DVec3::from_slice).collect();
    let holes: Vec<bool> = parent.iter().map(|&p| is_hole[p as usize]).collect();
    // fan triangles as face-vertex corners, and the cage face of each
    let (mut tri_corners, mut tri_face) = (Vec::new(), Vec::new());
    let mut off = 0u32;
    for (f, &c) in fvc.iter().enumerate() {
        if c >= 3 && !holes[f] {
            for k in 1..c - 1 {
                tri_corners.push([off, off + k, off + k + 1]);
                tri_face.push(parent[f]);
            }
        }
        off += c;
    }
    let mut attrs: Vec<(&str, Attr)> = Vec::new();
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    match &refinement {
        Some(r) if !r.hard_edges.is_empty() => {
            // sharp creases stay hard edges in the shading: normals per smooth fan of each point
            let (n, idx) = r.corner_normals(&pts, &holes, &exact);
            let values = n.iter().flat_map(|v| v.as_vec3().to_array()).collect();
            attrs.push(("normals", Attr { values, width: 3, plan: Plan::Corner(Some(idx)) }));
        }
        _ => {
            let tris: Vec<[u32; 3]> = tri_corners.iter().map(|t| t.map(|c| fvi[c as usize])).collect();
            let n = smooth_normals(&pts, &tris, &exact);
            let values = n.iter().flat_map(|v| v.as_vec3().to_array()).collect();
            attrs.push(("normals", Attr { values, width: 3, plan: Plan::Vertex(None) }));
        }
    }
    let mut primvar = |name: &'static str, mode: PrimvarMode, values: Vec<f64>, indices: &[u32], width: usize| {
        let attr = match (mode, &refinement) {
            (PrimvarMode::Vertex, None) => Attr { values: f32s(&values), width, plan: Plan::Vertex(None) },
            (PrimvarMode::Vertex, Some(r)) => Attr { values: f32s(&r.points(&values, width, true)), width, plan: Plan::Vertex(None) },
            (_, None) => Attr { values: f32s(&values), width, plan: Plan::Corner(Some(indices.to_vec())) },
            (PrimvarMode::Linear, Some(r)) if indices == sd.face_indices.as_slice() => {
                // one value per point (USD `varying`): refined linearly, per point
                let per_point = per_point_values(&values, npts, width);
                Attr { values: f32s(&r.varying(&per_point, width)), width, plan: Plan::Vertex(None) }
            }
            (mode, Some(r)) => {
                let data: Vec<f64> = indices.iter().flat_map(|&i| values[i as usize * width..(i as usize + 1) * width].iter().copied()).collect();
                let rule = if mode == PrimvarMode::Linear { FaceVaryingRule::All } else { sd.face_varying };
                let (v, idx) = r.face_varying(&data, width, rule, true);
                let (v, idx) = match idx {
                    Some(idx) => (f32s(&v), idx),
                    None => dedup(&f32s(&v), width),
                };
                Attr { values: v, width, plan: Plan::Corner(Some(idx)) }
            }
        };
        attrs.push((name, attr));
    };
    if let Some(uv) = &sd.uvs {
        let values = uv.values.iter().flat_map(|v| v.to_array()).map(f64::from).collect();
        primvar("uvs", uv.mode, values, &uv.indices, 2);
    }
    if let Some(c) = &sd.colors {
        let values = c.values.iter().flat_map(|v| v.to_array()).map(f64::from).collect();
        primvar("colors", c.mode, values, &c.indices, 3);
    }
    let material_ids = if mesh.material_ids.len() <= 1 {
        mesh.material_ids.clone()
    } else {
        let ids: Vec<u32> = tri_face.iter().map(|&f| mesh.material_ids[f as usize]).collect();
        if ids.iter().all(|&i| i == ids[0]) {
            vec![ids.first().copied().unwrap_or(mesh.material_ids[0])]
        } else {
            ids
        }
    };
    let p32: Vec<f32> = f32s(&points);
    let mut out = Mesh {
        name: mesh.name.clone(),
        material_ids,
        double_sided: mesh.double_sided,
        ..Default::default()
    };
    let gather = |values: &[f32], width: usize, sel: &mut dyn Iterator<Item = u32>| -> Vec<f32> {
        sel.flat_map(|i| values[i as usize * width..(i as usize + 1) * width].iter().copied()).collect()
    };
    let all_vertex = attrs.iter().all(|(_, a)| matches!(a.plan, Plan::Vertex(_)));
    let (pos, cols): (Vec<f32>, Vec<(&str, Vec<f32>)>) = if all_vertex {
        out.indices = tri_corners.iter().map(|t| t.map(|c| fvi[c as usize])).collect();
        let cols = attrs
            .iter()
            .map(|(name, a)| {
                let v = match &a.plan {
                    Plan::Vertex(Some(idx)) => gather(&a.values, a.width, &mut idx.iter().copied()),
                    _ => a.values.clone(),
                };
                (*name, v)
            })
            .collect();
        (p32, cols)
    } else {
        // one vertex per distinct (point, face-vertex attribute indices)
        let corner_idx = |a: &Attr, c: usize| -> u32 {
            match &a.plan {
                Plan::Corner(Some(idx)) => idx[c],
                _ => c as u32,
            }
        };
        let mut uniq: HashMap<Vec<u32>, u32> = HashMap::new();
        let mut keys: Vec<Vec<u32>> = Vec::new();
        let remap: Vec<u32> = (0..fvi.len())
            .map(|c| {
                let mut key = vec![fvi[c]];
                key.extend(attrs.iter().filter(|(_, a)| matches!(a.plan, Plan::Corner(_))).map(|(_, a)| corner_idx(a, c)));
                let n = uniq.len() as u32;
                *uniq.entry(key.clone()).or_insert_with(|| {
                    keys.push(key);
                    n
                })
            })
            .collect();
        out.indices = tri_corners.iter().map(|t| t.map(|c| remap[c as usize])).collect();
        let pos = gather(&p32, 3, &mut keys.iter().map(|k| k[0]));
        let mut ci = 0;
        let cols = attrs
            .iter()
            .map(|(name, a)| {
                let v = match &a.plan {
                    Plan::Vertex(idx) => gather(&a.values, a.width, &mut keys.iter().map(|k| idx.as_ref().map_or(k[0], |i| i[k[0] as usize]))),
                    Plan::Corner(_) => {
                        ci += 1;
                        gather(&a.values, a.width, &mut keys.iter().map(|k| k[ci]))
                    }
                };
                (*name, v)
            })
            .collect();
        (pos, cols)
    };
    out.positions = pos.chunks_exact(3).map(Vec3::from_slice).collect();
    for (name, v) in cols {
        match name {
            "normals" => out.normals = Some(v.chunks_exact(3).map(Vec3::from_slice).collect()),
            "uvs" => out.uvs = Some(v.chunks_exact(2).map(Vec2::from_slice).collect()),
            _ => out.colors = Some(v.chunks_exact(3).map(Vec3::from_slice).collect()),
        }
    }
    Ok(out)
}

/// Values of linear data whose index per face-vertex is the face-vertex's point (USD `varying`):
/// value `i` is point `i`'s (points no face names take zeros).
fn per_point_values(values: &[f64], npts: usize, width: usize) -> Vec<f64> {
    let mut out = vec![0.0; npts * width];
    let n = values.len().min(npts * width);
    out[..n].copy_from_slice(&values[..n]);
    out
}

/// Per-face-vertex values as distinct values and an index per face-vertex.
fn dedup(values: &[f32], width: usize) -> (Vec<f32>, Vec<u32>) {
    let mut ids: HashMap<Vec<u32>, u32> = HashMap::new();
    let mut out = Vec::new();
    let idx = values
        .chunks_exact(width)
        .map(|v| {
            let key: Vec<u32> = v.iter().map(|x| (x + 0.0).to_bits()).collect();
            let n = ids.len() as u32;
            *ids.entry(key).or_insert_with(|| {
                out.extend_from_slice(v);
                n
            })
        })
        .collect();
    (out, idx)
}
