//! Subdivision surfaces at render time: which go to Embree as cages (tessellated at edge rates
//! that follow the camera) and which become triangles here (`crate::subdiv`), and the shading
//! data of a hit on one from Embree's limit surface.
//!
//! - Catmull–Clark surfaces go to Embree, unless they emit (light sampling needs their
//!   triangles), have cut-out materials (the hit filter reads triangles), a face of more than 15
//!   points (Embree's limit), or `interpolateBoundary = edgeOnly` with a boundary point of a
//!   single face (where Embree's surface is up to 1 % of the edge length off).
//! - The rest, and Loop and bilinear surfaces (Embree evaluates only Catmull–Clark), are refined
//!   uniformly: `--subdivision N` times, or (`auto`) as many times as halves their longest edge's
//!   rate below, 1 to 3 times; `--subdivision cage` renders every cage as it is.
//! - Edge rates (`auto`): each cage edge gets ⌈length / ([`TARGET_PIXELS`] · pixel footprint at its
//!   nearer end)⌉ segments in [`MIN_RATE`, `MAX_RATE`] (the largest over the mesh's instances),
//!   a function of the edge's two end points only, so both faces of an edge agree and the
//!   tessellation has no cracks; `--subdivision N` gives every edge 2^N.

use glam::{Mat3, Mat4, Vec2, Vec3};

use super::cone::{self, RayCone, TextureFilter};
use super::{normal_map, CameraModel, PreparedScene, SurfaceHit};
use crate::image::Footprint;
use crate::embree::{Hit, Ray, SubdivAttribute, SubdivBoundary, SubdivisionMesh};
use crate::scene::subdiv::{Boundary, FaceVaryingRule, PrimvarMode, Scheme, Subdivision, SubdivisionMode};
use crate::scene::{Material, Mesh, SceneDesc, Warning};
use crate::subdiv::mesh::{cage_reason, fitting_levels, refine_mesh};

/// The length on screen, in pixels, of a tessellated edge (`auto`). At 2 px the images of
/// `scripts/make_heavy_subdiv.py --features` are within noise of a uniform refinement 3 levels deep
/// (relative MSE 1.18e-4 against the images' own 1.10e-4, 512 spp); at 4 px silhouettes of thin
/// tubes show their segments (2.31e-4).
pub const TARGET_PIXELS: f32 = 2.0;
/// The fewest and most segments per cage edge (`auto`).
pub const MIN_RATE: f32 = 1.0;
pub const MAX_RATE: f32 = 64.0;
/// The most quads the tessellation may make (`auto`); rates are lowered evenly beyond it.
pub const MAX_QUADS: f64 = 8e6;
/// The most refinements `auto` applies to a surface refined here.
const MAX_AUTO_LEVELS: u32 = 3;

/// What became of the scene's subdivision surfaces.
#[derive(Clone, Debug, Default)]
pub struct Tessellation {
    /// Per mesh of the scene: the surface handed to Embree, if it is one.
    pub embree: Vec<Option<SubdivisionMesh>>,
    /// Cage faces and (estimated) tessellated quads of the surfaces Embree tessellates, counted
    /// once per instance.
    pub faces: usize,
    pub quads: f64,
}

/// Turn `desc`'s subdivision meshes into triangle meshes where they must be (see the module
/// docs), and the others into Embree subdivision meshes with their edge rates for `camera`.
pub(super) fn tessellate(desc: &mut SceneDesc, camera: &CameraModel, warnings: &mut Vec<Warning>) -> Tessellation {
    let mode = desc.subdivision;
    let mut out = Tessellation { embree: vec![None; desc.meshes.len()], ..Default::default() };
    let mut placements: Vec<Vec<Mat4>> = vec![Vec::new(); desc.meshes.len()];
    for inst in &desc.instances {
        placements[inst.mesh as usize].push(inst.transform);
    }
    let mut warn = |prim: &str, message: String| warnings.push(Warning { prim: prim.to_string(), message });
    let mut embree_rates: Vec<(usize, Vec<f32>)> = Vec::new();
    for (m, mesh) in desc.meshes.iter_mut().enumerate() {
        let Some(sd) = mesh.subdivision.as_deref() else { continue };
        let name = mesh.name.clone();
        let scheme = scheme_name(sd.scheme);
        let mut level = None;
        if let Some(why) = cage_reason(sd) {
            warn(&name, format!("{why}, which no subdivision rule covers; rendered as its control cage"));
            level = Some(0);
        } else if mode == SubdivisionMode::Cage {
            warn(&name, format!("subdivision surface ({scheme}) rendered as its control cage (--subdivision cage)"));
            level = Some(0);
        } else if let Some(why) = needs_triangles(mesh, sd, &desc.materials) {
            let want = match mode {
                SubdivisionMode::Level(n) => n,
                _ => auto_levels(&edge_rates(&mesh.positions, sd, &placements[m], camera)),
            };
            let fits = fitting_levels(sd, want);
            if fits < want {
                warn(&name, format!("subdivision level {want} would give more than {} faces; refined {fits} times", crate::subdiv::mesh::MAX_REFINED_FACES));
            }
            if why == Why::Scheme && sd.boundary == Boundary::None {
                warn(&name, "interpolateBoundary none is refined as edgeOnly (its boundary faces are kept)".into());
            }
            level = Some(fits);
        }
        match level {
            Some(level) => match refine_mesh(mesh, level) {
                Ok(refined) => *mesh = refined,
                Err(e) => {
                    // (cage_reason caught every cage the rules do not cover)
                    warn(&name, format!("{e}; rendered as its control cage"));
                    *mesh = refine_mesh(mesh, 0).expect("the cage itself needs no rule");
                }
            },
            None => {
                let rates = match mode {
                    SubdivisionMode::Level(n) => vec![(1u32 << n) as f32; sd.face_indices.len()],
                    _ => edge_rates(&mesh.positions, sd, &placements[m], camera),
                };
                embree_rates.push((m, rates));
            }
        }
    }
    // the quads the rates make, counted per instance; beyond MAX_QUADS every rate is scaled down
    let quads = |rates: &[(usize, Vec<f32>)], k: f32| -> f64 {
        rates.iter().map(|(m, r)| estimated_quads(desc.meshes[*m].subdivision.as_deref().unwrap(), r, k) * placements[*m].len() as f64).sum()
    };
    let mut k = 1.0f32;
    if mode == SubdivisionMode::Auto {
        while quads(&embree_rates, k) > MAX_QUADS && k > 1.0 / MAX_RATE {
            k *= 0.8;
        }
    }
    out.quads = quads(&embree_rates, k);
    for (m, rates) in embree_rates {
        let mesh = &desc.meshes[m];
        let sd = mesh.subdivision.as_deref().unwrap();
        out.faces += sd.face_counts.len() * placements[m].len();
        let rates = rates.into_iter().map(|r| (r * k).ceil().clamp(MIN_RATE, 4096.0)).collect();
        out.embree[m] = Some(embree_mesh(mesh, sd, rates));
    }
    if k < 1.0 {
        warnings.push(Warning {
            prim: "/".into(),
            message: format!("subdivision surfaces tessellated at {:.0} % of their edge rates (at most {MAX_QUADS:.0} quads)", 100.0 * k),
        });
    }
    out
}

/// Why a Catmull–Clark surface is refined here rather than by Embree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Why {
    Scheme,
    Emits,
    Cutout,
    BigFace,
    EdgeOnlyCorner,
}

fn needs_triangles(mesh: &Mesh, sd: &Subdivision, materials: &[Material]) -> Option<Why> {
    if sd.scheme != Scheme::CatmullClark {
        return Some(Why::Scheme);
    }
    let mats = || mesh.material_ids.iter().filter_map(|&i| materials.get(i as usize));
    if mats().any(|m| m.emission().is_some_and(|e| e.texture.is_some() || e.value.iter().any(|&c| c > 0.0))) {
        return Some(Why::Emits);
    }
    if mats().any(|m| matches!(m, Material::PreviewSurface(p) if p.opacity_threshold > 0.0)) {
        return Some(Why::Cutout);
    }
    if sd.face_counts.iter().any(|&c| c > 15) {
        return Some(Why::BigFace);
    }
    if sd.boundary == Boundary::EdgeOnly {
        let mut faces = vec![0u32; mesh.positions.len()];
        sd.face_indices.iter().for_each(|&v| faces[v as usize] += 1);
        if faces.contains(&1) {
            return Some(Why::EdgeOnlyCorner);
        }
    }
    None
}

fn scheme_name(s: Scheme) -> &'static str {
    match s {
        Scheme::CatmullClark => "catmullClark",
        Scheme::Loop => "loop",
        Scheme::Bilinear => "bilinear",
    }
}

/// The segments each face-vertex's edge needs for `camera` (the largest over the placements).
pub fn edge_rates(positions: &[Vec3], sd: &Subdivision, placements: &[Mat4], camera: &CameraModel) -> Vec<f32> {
    // the size of a pixel at distance d: d · per_metre (perspective) or `flat` (orthographic)
    let (per_metre, flat) = if camera.orthographic {
        (0.0, 2.0 * camera.half.y / camera.height as f32)
    } else {
        (2.0 * camera.half.y / camera.height as f32, 0.0)
    };
    let footprint = |d: f32| (d * per_metre + flat).max(1e-30);
    let mut rates = vec![MIN_RATE; sd.face_indices.len()];
    let mut rate_of = |world: &dyn Fn(Vec3) -> Vec3, scale: f32, near: Option<f32>| {
        let mut off = 0usize;
        for &n in &sd.face_counts {
            let n = n as usize;
            for k in 0..n {
                let (a, b) = (sd.face_indices[off + k], sd.face_indices[off + (k + 1) % n]);
                // (ordered by index: both faces of an edge compute exactly the same rate)
                let (a, b) = (world(positions[a.min(b) as usize]), world(positions[a.max(b) as usize]));
                let d = near.unwrap_or_else(|| (a - camera.origin).length().min((b - camera.origin).length()));
                let r = scale * (a - b).length() / (TARGET_PIXELS * footprint(d));
                let slot = &mut rates[off + k];
                *slot = slot.max(if r.is_finite() { r.min(MAX_RATE) } else { MAX_RATE });
            }
            off += n;
        }
    };
    if placements.len() <= 4 {
        for xf in placements {
            rate_of(&|p| xf.transform_point3(p), 1.0, None);
        }
    } else {
        // many placements: edges measured in object space, scaled by the placement that is
        // largest on screen (its greatest stretch over the distance of its nearest point)
        let (lo, hi) = positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let mut best = 0.0f32;
        for xf in placements {
            let stretch = [xf.x_axis, xf.y_axis, xf.z_axis].iter().map(|c| c.truncate().length()).fold(0.0, f32::max);
            let local = xf.inverse().transform_point3(camera.origin).clamp(lo, hi);
            let d = (xf.transform_point3(local) - camera.origin).length();
            best = best.max(stretch / footprint(d));
        }
        let fp1 = footprint(1.0);
        rate_of(&|p| p, best * fp1, Some(1.0));
    }
    rates.iter().map(|r| r.clamp(MIN_RATE, MAX_RATE)).collect()
}

/// Refinement levels (`auto`) for a surface refined here: enough to bring its longest edge's rate
/// down to one segment, 1 to [`MAX_AUTO_LEVELS`].
fn auto_levels(rates: &[f32]) -> u32 {
    let worst = rates.iter().copied().fold(1.0f32, f32::max);
    (worst.log2().ceil() as u32).clamp(1, MAX_AUTO_LEVELS)
}

/// Quads of the tessellation at rates scaled by `k`: per face, the mean rate of its edges
/// squared (quads; other faces are n quads of half the rate).
fn estimated_quads(sd: &Subdivision, rates: &[f32], k: f32) -> f64 {
    let mut off = 0usize;
    let mut q = 0.0f64;
    for &n in &sd.face_counts {
        let n = n as usize;
        let mean = rates[off..off + n].iter().map(|&r| (r * k).ceil().max(1.0) as f64).sum::<f64>() / n as f64;
        q += if n == 4 { mean * mean } else { n as f64 * (mean * 0.5).max(1.0).powi(2) };
        off += n;
    }
    q
}

fn face_varying_mode(rule: FaceVaryingRule) -> SubdivBoundary {
    match rule {
        FaceVaryingRule::None => SubdivBoundary::Smooth,
        // (Embree cannot also pin the points where three or more values meet)
        FaceVaryingRule::CornersOnly | FaceVaryingRule::CornersPlus1 | FaceVaryingRule::CornersPlus2 => SubdivBoundary::PinCorners,
        FaceVaryingRule::Boundaries => SubdivBoundary::PinBoundary,
        FaceVaryingRule::All => SubdivBoundary::PinAll,
    }
}

/// The mesh as Embree's subdivision mesh: attribute 0 its texture coordinates (if any), then its
/// vertex colours (if any).
fn embree_mesh(mesh: &Mesh, sd: &Subdivision, edge_levels: Vec<f32>) -> SubdivisionMesh {
    let boundary = match sd.boundary {
        Boundary::None => SubdivBoundary::NoBoundary,
        Boundary::EdgeOnly => SubdivBoundary::Smooth,
        Boundary::EdgeAndCorner => SubdivBoundary::PinCorners,
    };
    let topology = |mode: PrimvarMode, indices: &[u32]| match mode {
        PrimvarMode::Vertex => None,
        PrimvarMode::Linear => Some((indices.to_vec(), SubdivBoundary::PinAll)),
        PrimvarMode::FaceVarying => Some((indices.to_vec(), face_varying_mode(sd.face_varying))),
    };
    let mut attributes = Vec::new();
    if let Some(uv) = &sd.uvs {
        let values = uv.values.iter().flat_map(|v| v.to_array()).collect();
        attributes.push(SubdivAttribute { width: 2, values, topology: topology(uv.mode, &uv.indices) });
    }
    if let Some(c) = &sd.colors {
        let values = c.values.iter().flat_map(|v| v.to_array()).collect();
        attributes.push(SubdivAttribute { width: 3, values, topology: topology(c.mode, &c.indices) });
    }
    // sharpness 10 and more is infinitely sharp, as OpenSubdiv reads it
    let sharp = |s: f32| if s >= 10.0 { f32::INFINITY } else { s };
    let (creases, crease_weights) = sd.creases.iter().zip(&sd.crease_sharpness).filter(|(_, &s)| s > 0.0).map(|(&e, &s)| (e, sharp(s))).unzip();
    let (corners, corner_weights) = sd.corners.iter().zip(&sd.corner_sharpness).filter(|(_, &s)| s > 0.0).map(|(&v, &s)| (v, sharp(s))).unzip();
    SubdivisionMesh {
        positions: mesh.positions.clone(),
        face_counts: sd.face_counts.clone(),
        face_indices: sd.face_indices.clone(),
        holes: sd.holes.clone(),
        creases,
        crease_weights,
        corners,
        corner_weights,
        boundary,
        edge_levels,
        attributes,
    }
}

/// Surface area of a placed mesh: its triangles, or a subdivision surface's cage faces (not its
/// holes; for dense cages close to the limit surface's area, for coarse ones larger).
pub fn surface_area(mesh: &Mesh, to_world: &Mat4) -> f64 {
    let p = |i: u32| mesh.positions.get(i as usize).map_or(glam::DVec3::ZERO, |&q| to_world.transform_point3(q).as_dvec3());
    match mesh.subdivision.as_deref() {
        None => mesh.indices.iter().map(|t| 0.5 * (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).length()).filter(|a| a.is_finite()).sum(),
        Some(sd) => {
            let mut hole = vec![false; sd.face_counts.len()];
            sd.holes.iter().for_each(|&f| hole[f as usize] = true);
            let mut off = 0usize;
            let mut area = 0.0;
            for (f, &n) in sd.face_counts.iter().enumerate() {
                let face = &sd.face_indices[off..off + n as usize];
                off += n as usize;
                if !hole[f] {
                    let pts: Vec<glam::DVec3> = face.iter().map(|&i| p(i)).collect();
                    let idx: Vec<u32> = (0..face.len() as u32).collect();
                    area += 0.5 * crate::subdiv::newell(&pts, &idx).length();
                }
            }
            area
        }
    }
}

impl PreparedScene {
    /// Shading data of a hit on a subdivision surface Embree tessellates: the shading normal
    /// from the limit surface's derivatives (dP/du × dP/dv, on the side of the hit triangle's
    /// normal; perturbed by the material's normal map in the frame of the texture coordinates'
    /// derivatives), texture coordinates and colours interpolated over it, and the texture
    /// footprint of the ray's cone from the same derivatives.
    pub(super) fn subdivision_hit(&self, ray: &Ray, h: &Hit, mesh: &Mesh, sd: &Subdivision, cone: Option<RayCone>) -> SurfaceHit {
        let ng = h.ng.normalize_or_zero();
        let surface = self.embree.surface_point(h.instance, h.prim, h.u, h.v);
        let limit = surface.map_or(Vec3::ZERO, |s| s.dpdu.cross(s.dpdv).normalize_or_zero());
        let material = mesh.material_of(h.prim as usize);
        let look = &self.looks[material as usize];
        // (interpolated only for materials that read them: each is an evaluation of the surface)
        let wanted = self.reads_surface_data(material);
        let (mut out, mut du, mut dv) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
        let frame_needed = look.normal_map.is_some() || (cone.is_some() && look.textured && self.texture_filter != TextureFilter::Bilinear);
        let mut uv_derivatives = None;
        let uv = if wanted && sd.uvs.is_some() {
            let ok = if frame_needed {
                self.embree.attribute_derivatives(h.instance, h.prim, h.u, h.v, 0, &mut out, &mut du, &mut dv)
            } else {
                self.embree.attribute(h.instance, h.prim, h.u, h.v, 0, &mut out)
            };
            uv_derivatives = (ok && frame_needed).then(|| [Vec2::new(du[0], du[1]), Vec2::new(dv[0], dv[1])]);
            if ok {
                Vec2::new(out[0], out[1])
            } else {
                Vec2::new(h.u, h.v)
            }
        } else {
            Vec2::new(h.u, h.v)
        };
        let slot = sd.uvs.is_some() as usize;
        let color = (wanted && sd.colors.is_some() && self.embree.attribute(h.instance, h.prim, h.u, h.v, slot, &mut out))
            .then(|| Vec3::new(out[0], out[1], out[2]));
        let footprint = match (cone, surface, uv_derivatives) {
            (Some(c), Some(s), Some(d)) if look.textured && self.texture_filter != TextureFilter::Bilinear => {
                let len = ray.dir.length();
                cone::footprint(c.width_at(h.t * len), ray.dir / len, ng, [s.dpdu, s.dpdv], d, self.texture_filter.max_probes())
            }
            _ => Footprint::POINT,
        };
        let ns = match (look.normal_map, surface, uv_derivatives) {
            (Some(tex), Some(s), Some(d)) if limit != Vec3::ZERO => {
                // the tangent frame of the texture coordinates: dP/ds and dP/dt from the
                // surface's and the coordinates' derivatives (what MikkTSpace approximates per
                // triangle), the bitangent's sign from dP/dt; the normal the placement's normal
                // matrix gives, as for triangles (a mirroring placement turns dP/du × dP/dv)
                let mirrored = Mat3::from_mat4(self.instances[h.instance as usize].to_world).determinant() < 0.0;
                let limit = if mirrored { -limit } else { limit };
                let det = d[0].x * d[1].y - d[1].x * d[0].y;
                let (t, b) = if det != 0.0 && det.is_finite() {
                    ((s.dpdu * d[1].y - s.dpdv * d[0].y) / det, (s.dpdv * d[0].x - s.dpdu * d[1].x) / det)
                } else {
                    (Vec3::ZERO, Vec3::ZERO)
                };
                let sign = if limit.cross(t).dot(b) < 0.0 { -1.0 } else { 1.0 };
                let value = self.textures[tex as usize].eval_rgb_filtered(uv, &footprint);
                let w = normal_map::perturbed(limit, t, sign, value);
                let w = if limit.dot(ng) < 0.0 { -w } else { w };
                // keep the view's reflection above the surface (seen from the ray's side)
                let side = if ng.dot(ray.dir) > 0.0 { -1.0 } else { 1.0 };
                let wo = (-ray.dir).normalize_or_zero();
                side * normal_map::keep_reflection_above(side * w, side * ng, wo)
            }
            _ if limit == Vec3::ZERO => ng,
            _ if limit.dot(ng) < 0.0 => -limit,
            _ => limit,
        };
        SurfaceHit {
            p: ray.org + ray.dir * h.t,
            ng,
            ns,
            uv,
            color,
            t: h.t,
            material,
            instance: h.instance,
            prim: h.prim,
            footprint,
        }
    }
}
