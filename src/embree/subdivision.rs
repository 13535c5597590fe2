//! Catmull–Clark subdivision surfaces: the geometry Embree tessellates at build time (edge rates
//! set by the caller) and evaluates on the limit surface on request (`rtcInterpolate`).

use glam::{Mat4, Vec3};

use super::builder::RawGeometry;
use super::sys;
use super::{Device, Scene};
use crate::{Error, Result};

/// How a topology treats its boundary and corners (the rules Embree's subdivision modes name).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubdivBoundary {
    /// Faces on the boundary are not part of the surface (they shape their neighbours).
    NoBoundary,
    /// The boundary is a smooth B-spline curve of the boundary points.
    Smooth,
    /// As `Smooth`, and a corner point (of a single face) stays put.
    PinCorners,
    /// The boundary is interpolated linearly (every boundary point stays put).
    PinBoundary,
    /// Everything is interpolated linearly within each face.
    PinAll,
}

impl SubdivBoundary {
    fn raw(self) -> sys::RTCSubdivisionMode {
        match self {
            SubdivBoundary::NoBoundary => sys::RTC_SUBDIVISION_MODE_NO_BOUNDARY,
            SubdivBoundary::Smooth => sys::RTC_SUBDIVISION_MODE_SMOOTH_BOUNDARY,
            SubdivBoundary::PinCorners => sys::RTC_SUBDIVISION_MODE_PIN_CORNERS,
            SubdivBoundary::PinBoundary => sys::RTC_SUBDIVISION_MODE_PIN_BOUNDARY,
            SubdivBoundary::PinAll => sys::RTC_SUBDIVISION_MODE_PIN_ALL,
        }
    }
}

/// Data interpolated over a subdivision surface ([`Scene::attribute`]): `width` floats per value
/// (1 to 4), over the surface's own points and rules (`topology: None`) or over a topology of its
/// own (an index per face-vertex of the cage into `values`, and its boundary rule).
#[derive(Clone, Debug, Default)]
pub struct SubdivAttribute {
    pub width: u32,
    pub values: Vec<f32>,
    pub topology: Option<(Vec<u32>, SubdivBoundary)>,
}

/// A Catmull–Clark subdivision surface for [`super::SceneBuilder::add_subdivision_mesh`]: its
/// control cage (faces of 3 to 15 points), tags, per-edge tessellation rates and attributes.
#[derive(Clone, Debug)]
pub struct SubdivisionMesh {
    pub positions: Vec<Vec3>,
    /// Points of each face (3 to 15).
    pub face_counts: Vec<u32>,
    /// The faces' points, face after face.
    pub face_indices: Vec<u32>,
    /// Faces left out of the surface: they keep their place in the topology and shape their
    /// neighbours (as in OpenSubdiv and USD); rays pass through them.
    pub holes: Vec<u32>,
    /// Creased edges and their sharpness (`f32::INFINITY`: infinitely sharp).
    pub creases: Vec<[u32; 2]>,
    pub crease_weights: Vec<f32>,
    /// Sharp points and their sharpness.
    pub corners: Vec<u32>,
    pub corner_weights: Vec<f32>,
    pub boundary: SubdivBoundary,
    /// Segments along the edge from each face-vertex to the next (≥ 1, at most 4096). An edge
    /// shared by two faces must get the same rate from both, or the tessellation cracks.
    pub edge_levels: Vec<f32>,
    /// Interpolated data; [`Scene::attribute`]'s `slot` is the index in this list.
    pub attributes: Vec<SubdivAttribute>,
}

impl SubdivisionMesh {
    /// Check sizes and indices (Embree does not, and reads out of bounds otherwise).
    pub(super) fn check(&self, id: usize) -> Result<()> {
        let bad = |msg: String| Err(Error::param("subdivision", format!("mesh {id}: {msg}")));
        let nfv: u64 = self.face_counts.iter().map(|&c| c as u64).sum();
        if nfv != self.face_indices.len() as u64 {
            return bad(format!("face counts sum to {nfv} for {} indices", self.face_indices.len()));
        }
        if let Some(c) = self.face_counts.iter().find(|&&c| !(3..=15).contains(&c)) {
            return bad(format!("a face has {c} points (3 to 15 are supported)"));
        }
        let np = self.positions.len();
        if self.face_indices.iter().chain(self.creases.iter().flatten()).chain(&self.corners).any(|&i| i as usize >= np) {
            return bad(format!("an index reaches beyond the {np} points"));
        }
        if self.holes.iter().any(|&f| f as usize >= self.face_counts.len()) {
            return bad("a hole names a face out of range".into());
        }
        if self.creases.len() != self.crease_weights.len() || self.corners.len() != self.corner_weights.len() {
            return bad("creases and corners need one weight each".into());
        }
        if self.edge_levels.len() != self.face_indices.len() || !self.edge_levels.iter().all(|l| *l >= 1.0 && *l <= 4096.0) {
            return bad("one edge level in [1, 4096] per face-vertex is needed".into());
        }
        for (k, a) in self.attributes.iter().enumerate() {
            let w = a.width as usize;
            if !(1..=4).contains(&w) || a.values.len() % w != 0 {
                return bad(format!("attribute {k}: width {w} for {} values", a.values.len()));
            }
            let n = a.values.len() / w;
            match &a.topology {
                None if n != np => return bad(format!("attribute {k}: {n} values for {np} points")),
                Some((idx, _)) if idx.len() != self.face_indices.len() || idx.iter().any(|&i| i as usize >= n) => {
                    return bad(format!("attribute {k}: indices do not fit the faces or the values"));
                }
                _ => {}
            }
        }
        Ok(())
    }
}

/// What [`Scene`] keeps of a placed subdivision surface to evaluate it.
pub(super) struct SubdivHandle {
    /// The geometry holding the buffers (a reference is kept in [`Scene`]).
    pub geom: sys::RTCGeometry,
    /// Object to world for an instanced surface (whose buffers are in object space); `None` when
    /// the buffers are in world space already.
    pub to_world: Option<Mat4>,
    pub widths: Vec<u32>,
}

/// A point of a surface with its first derivatives along the face's parameters (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub p: Vec3,
    pub dpdu: Vec3,
    pub dpdv: Vec3,
}

/// 16-byte padded output for `rtcInterpolate`.
#[repr(C, align(16))]
#[derive(Default)]
struct Out4([f32; 4]);

/// A committed subdivision geometry with `mesh`'s buffers (positions transformed by `xf` if given).
pub(super) fn subdivision_geometry(dev: &Device, mesh: &SubdivisionMesh, xf: Option<&Mat4>) -> Result<RawGeometry> {
    let geom = RawGeometry::new(dev, sys::RTC_GEOMETRY_TYPE_SUBDIVISION)?;
    // 16-byte elements with w = 0: Embree's subdivision code loads whole 4-wide vectors and (in
    // Debian's build, with assertions on) aborts on a non-finite w, which the last element of a
    // packed buffer would read from uninitialised padding.
    let verts = mesh.positions.iter().map(|&p| xf.map_or(p, |m| m.transform_point3(p)).extend(0.0).to_array());
    geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_VERTEX, 0, sys::RTC_FORMAT_FLOAT3, verts)?;
    geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_FACE, 0, sys::RTC_FORMAT_UINT, mesh.face_counts.iter().copied())?;
    geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_INDEX, 0, sys::RTC_FORMAT_UINT, mesh.face_indices.iter().copied())?;
    geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_LEVEL, 0, sys::RTC_FORMAT_FLOAT, mesh.edge_levels.iter().copied())?;
    // (holes are left out by a hit filter, `MeshData::effective_filter`: they keep their place in
    // the topology)
    if !mesh.creases.is_empty() {
        geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_EDGE_CREASE_INDEX, 0, sys::RTC_FORMAT_UINT2, mesh.creases.iter().copied())?;
        geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_EDGE_CREASE_WEIGHT, 0, sys::RTC_FORMAT_FLOAT, mesh.crease_weights.iter().copied())?;
    }
    if !mesh.corners.is_empty() {
        geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_VERTEX_CREASE_INDEX, 0, sys::RTC_FORMAT_UINT, mesh.corners.iter().copied())?;
        geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_VERTEX_CREASE_WEIGHT, 0, sys::RTC_FORMAT_FLOAT, mesh.corner_weights.iter().copied())?;
    }
    let topologies = 1 + mesh.attributes.iter().filter(|a| a.topology.is_some()).count();
    // SAFETY: the geometry is live; the counts are set before the buffers that use them.
    unsafe {
        sys::rtcSetGeometryTopologyCount(geom.0, topologies as u32);
        sys::rtcSetGeometrySubdivisionMode(geom.0, 0, mesh.boundary.raw());
        sys::rtcSetGeometryVertexAttributeCount(geom.0, mesh.attributes.len() as u32);
    }
    dev.check("subdivision topologies")?;
    let mut topology = 0u32;
    for (slot, a) in mesh.attributes.iter().enumerate() {
        let format = match a.width {
            1 => sys::RTC_FORMAT_FLOAT,
            2 => sys::RTC_FORMAT_FLOAT2,
            3 => sys::RTC_FORMAT_FLOAT3,
            _ => sys::RTC_FORMAT_FLOAT4,
        };
        // 16-byte elements padded with zeros, as for the vertices
        let w = a.width as usize;
        let values = a.values.chunks_exact(w).map(|c| {
            let mut v = [0.0f32; 4];
            v[..w].copy_from_slice(c);
            v
        });
        geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_VERTEX_ATTRIBUTE, slot as u32, format, values)?;
        let t = match &a.topology {
            None => 0,
            Some((idx, rule)) => {
                topology += 1;
                geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_INDEX, topology, sys::RTC_FORMAT_UINT, idx.iter().copied())?;
                // SAFETY: the geometry is live and has `topologies` topologies.
                unsafe { sys::rtcSetGeometrySubdivisionMode(geom.0, topology, rule.raw()) };
                topology
            }
        };
        // SAFETY: the geometry is live; the slot and topology exist.
        unsafe { sys::rtcSetGeometryVertexAttributeTopology(geom.0, slot as u32, t) };
    }
    // SAFETY: the geometry is live and fully specified.
    unsafe { sys::rtcCommitGeometry(geom.0) };
    dev.check("rtcCommitGeometry (subdivision)")?;
    Ok(geom)
}

impl Scene {
    /// Whether instance `instance` is a subdivision surface (hits on it report a face of its cage
    /// and the face's parameters, which [`Scene::surface_point`] and [`Scene::attribute`] take).
    pub fn is_subdivision(&self, instance: u32) -> bool {
        matches!(self.subdivisions.get(instance as usize), Some(Some(_)))
    }

    /// The limit surface of subdivision instance `instance` at parameters (`u`, `v`) of face
    /// `prim`, in world space; `None` if the instance is not a subdivision surface.
    pub fn surface_point(&self, instance: u32, prim: u32, u: f32, v: f32) -> Option<SurfacePoint> {
        let h = self.subdivisions.get(instance as usize)?.as_ref()?;
        let (mut p, mut du, mut dv) = (Out4::default(), Out4::default(), Out4::default());
        let args = sys::RTCInterpolateArguments {
            geometry: h.geom,
            primID: prim,
            u,
            v,
            bufferType: sys::RTC_BUFFER_TYPE_VERTEX,
            bufferSlot: 0,
            P: p.0.as_mut_ptr(),
            dPdu: du.0.as_mut_ptr(),
            dPdv: dv.0.as_mut_ptr(),
            ddPdudu: std::ptr::null_mut(),
            ddPdvdv: std::ptr::null_mut(),
            ddPdudv: std::ptr::null_mut(),
            valueCount: 3,
        };
        // SAFETY: the geometry is committed and kept alive by the scene; the outputs are 16-byte
        // padded; rtcInterpolate reads only the geometry's buffers and may run on any thread.
        unsafe { sys::rtcInterpolate(&args) };
        let v3 = |o: &Out4| Vec3::new(o.0[0], o.0[1], o.0[2]);
        let (p, dpdu, dpdv) = (v3(&p), v3(&du), v3(&dv));
        Some(match h.to_world {
            Some(m) => SurfacePoint { p: m.transform_point3(p), dpdu: m.transform_vector3(dpdu), dpdv: m.transform_vector3(dpdv) },
            None => SurfacePoint { p, dpdu, dpdv },
        })
    }

    /// Attribute `slot` of subdivision instance `instance` at parameters (`u`, `v`) of face
    /// `prim`, into the first `width` entries of `out`; false if there is no such attribute.
    pub fn attribute(&self, instance: u32, prim: u32, u: f32, v: f32, slot: usize, out: &mut [f32; 4]) -> bool {
        self.interpolate_attribute(instance, prim, u, v, slot, out, None)
    }

    /// [`Scene::attribute`] with its derivatives along the face's parameters (`du`, `dv`: the
    /// first `width` entries), e.g. for a texture footprint or a tangent frame.
    #[allow(clippy::too_many_arguments)]
    pub fn attribute_derivatives(&self, instance: u32, prim: u32, u: f32, v: f32, slot: usize, out: &mut [f32; 4], du: &mut [f32; 4], dv: &mut [f32; 4]) -> bool {
        self.interpolate_attribute(instance, prim, u, v, slot, out, Some((du, dv)))
    }

    #[allow(clippy::too_many_arguments)]
    fn interpolate_attribute(&self, instance: u32, prim: u32, u: f32, v: f32, slot: usize, out: &mut [f32; 4], derivatives: Option<(&mut [f32; 4], &mut [f32; 4])>) -> bool {
        let Some(Some(h)) = self.subdivisions.get(instance as usize) else { return false };
        let Some(&width) = h.widths.get(slot) else { return false };
        let (mut p, mut du, mut dv) = (Out4::default(), Out4::default(), Out4::default());
        let wanted = derivatives.is_some();
        let args = sys::RTCInterpolateArguments {
            geometry: h.geom,
            primID: prim,
            u,
            v,
            bufferType: sys::RTC_BUFFER_TYPE_VERTEX_ATTRIBUTE,
            bufferSlot: slot as u32,
            P: p.0.as_mut_ptr(),
            dPdu: if wanted { du.0.as_mut_ptr() } else { std::ptr::null_mut() },
            dPdv: if wanted { dv.0.as_mut_ptr() } else { std::ptr::null_mut() },
            ddPdudu: std::ptr::null_mut(),
            ddPdvdv: std::ptr::null_mut(),
            ddPdudv: std::ptr::null_mut(),
            valueCount: width,
        };
        // SAFETY: as in `surface_point`; the slot exists and holds `width` floats per value, and
        // every output is 16-byte padded.
        unsafe { sys::rtcInterpolate(&args) };
        *out = p.0;
        if let Some((a, b)) = derivatives {
            *a = du.0;
            *b = dv.0;
        }
        true
    }
}
