//! Scene building: [`SceneBuilder`] collects meshes, placements and filters, and `commit` hands
//! them to Embree.
//!
//! Layout of the Embree scene: the top-level scene holds one geometry per instance, attached with
//! geometry ID = instance index. A mesh placed once is flattened (its world-space triangles are
//! that geometry); a mesh placed several times is committed once as a child scene and each
//! placement is an Embree instance geometry. A hit's instance index is therefore `instID[0]` if
//! set, else `geomID`, both in [`Scene`] and in the filter callback.

use std::ffi::c_void;
use std::mem::size_of;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

use glam::{Mat3, Mat4, Vec3, Vec4};

use super::scene::{RawScene, TopGeom};
use super::subdivision::{subdivision_geometry, SubdivHandle, SubdivisionMesh};
use super::sys::{self, RTC_INVALID_GEOMETRY_ID as INVALID_ID};
use super::{Device, MeshId, Scene};
use crate::{Error, Result};

/// An alpha / cut-out test: `(instance, prim, u, v) -> keep the hit`.
pub type FilterFn = Arc<dyn Fn(u32, u32, f32, f32) -> bool + Send + Sync>;

struct MeshData {
    shape: Shape,
    filter: Option<FilterFn>,
}

enum Shape {
    Triangles { positions: Vec<Vec3>, indices: Vec<[u32; 3]> },
    Subdivision(Box<SubdivisionMesh>),
}

impl MeshData {
    /// The mesh's filter, and for a subdivision surface with holes the test that leaves them out:
    /// a hole stays in the topology (it shapes its neighbours, as in OpenSubdiv and USD), its
    /// tessellation is only never hit. (Embree's own hole buffer removes the face from the
    /// topology, which makes its border a boundary and rounds the hole.)
    fn effective_filter(&self) -> Option<FilterFn> {
        let holes = match &self.shape {
            Shape::Subdivision(s) if !s.holes.is_empty() => {
                let mut h = vec![false; s.face_counts.len()];
                s.holes.iter().for_each(|&f| h[f as usize] = true);
                h
            }
            _ => return self.filter.clone(),
        };
        let user = self.filter.clone();
        Some(Arc::new(move |inst, prim, u, v| !holes.get(prim as usize).copied().unwrap_or(false) && user.as_ref().is_none_or(|f| f(inst, prim, u, v))))
    }

    fn is_empty(&self) -> bool {
        match &self.shape {
            Shape::Triangles { indices, .. } => indices.is_empty(),
            Shape::Subdivision(s) => s.face_counts.len() <= s.holes.len(),
        }
    }

    /// The committed geometry of the mesh (in world space with `xf`).
    fn geometry(&self, dev: &Device, xf: Option<&Mat4>, filter: Option<*const FilterFn>) -> Result<RawGeometry> {
        let geom = match &self.shape {
            Shape::Triangles { positions, indices } => triangle_geometry(dev, positions, indices, xf)?,
            Shape::Subdivision(s) => subdivision_geometry(dev, s, xf)?,
        };
        if let Some(f) = filter {
            // SAFETY: the geometry is live; `f` points into a Box that the Scene keeps until after
            // all Embree scenes are released; the callback matches Embree's filter signature.
            unsafe {
                sys::rtcSetGeometryUserData(geom.0, f as *mut c_void);
                sys::rtcSetGeometryIntersectFilterFunction(geom.0, Some(filter_callback));
                sys::rtcSetGeometryOccludedFilterFunction(geom.0, Some(filter_callback));
                sys::rtcCommitGeometry(geom.0);
            }
            dev.check("rtcCommitGeometry (filter)")?;
        }
        Ok(geom)
    }
}

/// Collects meshes, instances and filters; [`SceneBuilder::commit`] turns them into a [`Scene`].
///
/// Nothing is handed to Embree before `commit`, because only then is it known which meshes are
/// placed once (flattened) and which several times (instanced).
pub struct SceneBuilder {
    device: Device,
    meshes: Vec<MeshData>,
    instances: Vec<(u32, Mat4)>,
}

impl SceneBuilder {
    /// Start an empty scene on `device`.
    pub fn new(device: &Device) -> Result<SceneBuilder> {
        Ok(SceneBuilder {
            device: device.clone(),
            meshes: Vec::new(),
            instances: Vec::new(),
        })
    }

    /// Adds a prototype triangle mesh (object space). Positions/indices are copied.
    ///
    /// Fails if an index is out of range. Triangles with non-finite or coincident vertices are
    /// allowed (Embree never reports hits on them).
    pub fn add_mesh(&mut self, positions: &[Vec3], indices: &[[u32; 3]]) -> Result<MeshId> {
        let id = self.meshes.len();
        if positions.len() > u32::MAX as usize || indices.len() >= u32::MAX as usize {
            return Err(Error::param(
                "mesh",
                format!("mesh {id}: too many vertices or triangles"),
            ));
        }
        if let Some((t, tri)) = indices
            .iter()
            .enumerate()
            .find(|(_, tri)| tri.iter().any(|&i| i as usize >= positions.len()))
        {
            return Err(Error::param(
                "indices",
                format!(
                    "mesh {id}: triangle {t} {tri:?} references a vertex >= the vertex count {}",
                    positions.len()
                ),
            ));
        }
        self.meshes.push(MeshData {
            shape: Shape::Triangles { positions: positions.to_vec(), indices: indices.to_vec() },
            filter: None,
        });
        Ok(MeshId(id as u32))
    }

    /// Adds a prototype Catmull–Clark subdivision surface (object space; taken by value). Hits on
    /// it report a face of the cage as `prim` and the face's parameters as `u`, `v` (quads: along
    /// p1 − p0 and p3 − p0; other faces: Embree's sub-patch encoding), which
    /// [`Scene::surface_point`] and [`Scene::attribute`] evaluate. Fails on sizes or indices that
    /// do not fit together.
    pub fn add_subdivision_mesh(&mut self, mesh: SubdivisionMesh) -> Result<MeshId> {
        let id = self.meshes.len();
        mesh.check(id)?;
        self.meshes.push(MeshData { shape: Shape::Subdivision(Box::new(mesh)), filter: None });
        Ok(MeshId(id as u32))
    }

    /// Places a mesh in the world; returns the instance index (0,1,2,... in call order) reported
    /// in hits. `object_to_world` must be affine and finite.
    pub fn add_instance(&mut self, mesh: MeshId, object_to_world: Mat4) -> Result<u32> {
        self.mesh_index(mesh)?;
        let index = self.instances.len();
        if index >= INVALID_ID as usize {
            return Err(Error::param("instances", "too many instances"));
        }
        if !object_to_world.is_finite() || object_to_world.row(3) != Vec4::W {
            return Err(Error::param(
                "transform",
                format!("instance {index}: object_to_world must be finite and affine, got {object_to_world}"),
            ));
        }
        self.instances.push((mesh.0, object_to_world));
        Ok(index as u32)
    }

    /// Optional alpha/cut-out test for a mesh: called for candidate hits; return false to ignore
    /// the hit (args: instance index, primitive id, barycentric u, v; a subdivision surface's face
    /// and face parameters). Runs inside an Embree filter
    /// callback, possibly on several threads at once; a panic in it counts as "keep the hit".
    ///
    /// # Panics
    /// If `mesh` was not returned by this builder's [`SceneBuilder::add_mesh`].
    pub fn set_filter(&mut self, mesh: MeshId, f: FilterFn) {
        let m = self.mesh_index(mesh).expect("set_filter: unknown MeshId");
        self.meshes[m].filter = Some(f);
    }

    fn mesh_index(&self, mesh: MeshId) -> Result<usize> {
        match mesh.0 as usize {
            m if m < self.meshes.len() => Ok(m),
            m => Err(Error::param(
                "mesh",
                format!("unknown mesh id {m} ({} meshes added)", self.meshes.len()),
            )),
        }
    }

    /// Build the acceleration structures. Embree errors become `Error::Embree`.
    pub fn commit(self) -> Result<Scene> {
        let dev = &self.device;
        let mut uses = vec![0usize; self.meshes.len()];
        for &(m, _) in &self.instances {
            uses[m as usize] += 1;
        }
        // Boxed so that each filter has a thin, stable address to use as Embree user data.
        let filters: Vec<Option<Box<FilterFn>>> = self.meshes.iter().map(|m| m.effective_filter().map(Box::new)).collect();
        let filter_ptr = |m: usize| filters[m].as_deref().map(|f| f as *const FilterFn);

        let top = RawScene::new(dev)?;
        let mut children: Vec<Option<RawScene>> = Vec::with_capacity(self.meshes.len());
        // the instanced meshes' geometries (subdivision surfaces are evaluated through them)
        let mut child_geoms: Vec<Option<RawGeometry>> = Vec::with_capacity(self.meshes.len());
        for (m, mesh) in self.meshes.iter().enumerate() {
            if uses[m] < 2 || mesh.is_empty() {
                children.push(None);
                child_geoms.push(None);
                continue;
            }
            let child = RawScene::new(dev)?;
            let geom = mesh.geometry(dev, None, filter_ptr(m))?;
            child.attach(dev, &geom, 0)?;
            child.commit(dev)?;
            children.push(Some(child));
            child_geoms.push(Some(geom));
        }

        // Object-space bounds of the instanced meshes (flattened ones are bounded in world space).
        let object_bounds: Vec<Aabb> = (self.meshes.iter().zip(&children))
            .map(|(m, c)| {
                if c.is_some() {
                    mesh_bounds(m, None)
                } else {
                    Aabb::EMPTY
                }
            })
            .collect();
        let mut geoms = Vec::with_capacity(self.instances.len());
        let mut subdivisions = Vec::with_capacity(self.instances.len());
        let mut held = Vec::new();
        let mut bounds = Aabb::EMPTY;
        for (i, &(m, xf)) in self.instances.iter().enumerate() {
            let mesh = &self.meshes[m as usize];
            let widths = || match &mesh.shape {
                Shape::Subdivision(s) => Some(s.attributes.iter().map(|a| a.width).collect::<Vec<u32>>()),
                Shape::Triangles { .. } => None,
            };
            if mesh.is_empty() {
                geoms.push(TopGeom::Empty);
                subdivisions.push(None);
                continue;
            }
            if let Some(child) = &children[m as usize] {
                let geom = instance_geometry(dev, child, &xf)?;
                top.attach(dev, &geom, i as u32)?;
                bounds = bounds.union(object_bounds[m as usize].transformed(&xf));
                geoms.push(TopGeom::Instanced {
                    normal_to_world: cofactor(&xf),
                });
                let g = child_geoms[m as usize].as_ref().expect("an instanced mesh has a geometry").0;
                subdivisions.push(widths().map(|widths| SubdivHandle { geom: g, to_world: Some(xf), widths }));
            } else {
                let geom = mesh.geometry(dev, Some(&xf), filter_ptr(m as usize))?;
                top.attach(dev, &geom, i as u32)?;
                bounds = bounds.union(mesh_bounds(mesh, Some(&xf)));
                geoms.push(TopGeom::Flat);
                subdivisions.push(widths().map(|widths| SubdivHandle { geom: geom.0, to_world: None, widths }));
                if matches!(mesh.shape, Shape::Subdivision(_)) {
                    held.push(geom);
                }
            }
        }
        top.commit(dev)?;
        held.extend(child_geoms.into_iter().flatten());

        Ok(Scene {
            top,
            children: children.into_iter().flatten().collect(),
            geoms,
            bounds: if bounds.is_empty() {
                (Vec3::ZERO, Vec3::ZERO)
            } else {
                (bounds.min, bounds.max)
            },
            filters: filters.into_iter().flatten().collect(),
            subdivisions,
            _held: held,
            _device: self.device,
        })
    }
}

/// An owned `RTCGeometry` reference (released once attached: the scene keeps its own).
pub(super) struct RawGeometry(pub(super) sys::RTCGeometry);

impl RawGeometry {
    pub(super) fn new(dev: &Device, kind: sys::RTCGeometryType) -> Result<RawGeometry> {
        // SAFETY: the device handle is live.
        let raw = unsafe { sys::rtcNewGeometry(dev.raw(), kind) };
        dev.check("rtcNewGeometry")?;
        if raw.is_null() {
            return Err(Error::Embree("rtcNewGeometry returned null".into()));
        }
        Ok(RawGeometry(raw))
    }

    /// Give the geometry a new Embree-allocated (and padded) buffer holding `data` in `slot`.
    pub(super) fn set_buffer<T: Copy>(
        &self,
        dev: &Device,
        kind: sys::RTCBufferType,
        slot: u32,
        format: sys::RTCFormat,
        data: impl ExactSizeIterator<Item = T>,
    ) -> Result<()> {
        let count = data.len();
        // SAFETY: the geometry is live; stride and count describe the buffer we then fill.
        let ptr =
            unsafe { sys::rtcSetNewGeometryBuffer(self.0, kind, slot, format, size_of::<T>(), count) };
        dev.check("rtcSetNewGeometryBuffer")?;
        if ptr.is_null() {
            return Err(Error::Embree(
                "rtcSetNewGeometryBuffer returned null".into(),
            ));
        }
        // SAFETY: Embree returned a 16-byte aligned buffer of `count * size_of::<T>()` bytes owned by
        // the geometry; nothing else accesses it before the geometry is committed. T is a scalar
        // or an array of `f32` or `u32` matching `format`.
        let buf = unsafe { std::slice::from_raw_parts_mut(ptr as *mut T, count) };
        for (dst, src) in buf.iter_mut().zip(data) {
            *dst = src;
        }
        Ok(())
    }
}

impl Drop for RawGeometry {
    fn drop(&mut self) {
        // SAFETY: we own one reference to this live geometry.
        unsafe { sys::rtcReleaseGeometry(self.0) };
    }
}

/// A committed triangle geometry with copies of the vertices (transformed by `xf` if given).
fn triangle_geometry(dev: &Device, positions: &[Vec3], indices: &[[u32; 3]], xf: Option<&Mat4>) -> Result<RawGeometry> {
    let geom = RawGeometry::new(dev, sys::RTC_GEOMETRY_TYPE_TRIANGLE)?;
    let verts = positions.iter().map(|&p| xf.map_or(p, |m| m.transform_point3(p)).to_array());
    geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_VERTEX, 0, sys::RTC_FORMAT_FLOAT3, verts)?;
    geom.set_buffer(dev, sys::RTC_BUFFER_TYPE_INDEX, 0, sys::RTC_FORMAT_UINT3, indices.iter().copied())?;
    // SAFETY: the geometry is live and fully specified.
    unsafe { sys::rtcCommitGeometry(geom.0) };
    dev.check("rtcCommitGeometry (triangles)")?;
    Ok(geom)
}

/// A committed instance geometry placing `child` with the affine transform `xf`.
fn instance_geometry(dev: &Device, child: &RawScene, xf: &Mat4) -> Result<RawGeometry> {
    let geom = RawGeometry::new(dev, sys::RTC_GEOMETRY_TYPE_INSTANCE)?;
    // 3x4 column-major: the first three rows of the four columns.
    let cols: [f32; 12] = [xf.x_axis, xf.y_axis, xf.z_axis, xf.w_axis]
        .map(|c| c.truncate().to_array())
        .concat()
        .try_into()
        .unwrap();
    // SAFETY: both handles are live; `cols` holds the 12 floats the format requires and Embree
    // copies them during the call.
    unsafe {
        sys::rtcSetGeometryInstancedScene(geom.0, child.0);
        sys::rtcSetGeometryTransform(
            geom.0,
            0,
            sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
            cols.as_ptr() as *const c_void,
        );
        sys::rtcCommitGeometry(geom.0);
    }
    dev.check("rtcCommitGeometry (instance)")?;
    Ok(geom)
}

/// Embree filter callback for intersect and occluded queries: runs the mesh's closure on each
/// valid candidate hit of the (possibly N-wide) packet and invalidates rejected ones.
unsafe extern "C" fn filter_callback(args: *const sys::RTCFilterFunctionNArguments) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: Embree passes arguments valid for the duration of the call; the user pointer is
        // the `FilterFn` set in `MeshData::geometry`, kept alive by the Scene.
        let (args, f) = unsafe { (&*args, &*(((*args).geometryUserPtr) as *const FilterFn)) };
        let n = args.N as usize;
        // SAFETY: `valid` has N entries and the hit is an N-wide SoA packet (RTCHitN layout: Ng x/y/z,
        // u, v, primID, geomID, instID[0], each N consecutive 4-byte values).
        let (valid, hit) = unsafe {
            (
                std::slice::from_raw_parts_mut(args.valid, n),
                std::slice::from_raw_parts(args.hit as *const u32, 8 * n),
            )
        };
        for i in 0..n {
            if valid[i] == 0 {
                continue;
            }
            let (u, v) = (
                f32::from_bits(hit[3 * n + i]),
                f32::from_bits(hit[4 * n + i]),
            );
            let (prim, geom, inst) = (hit[5 * n + i], hit[6 * n + i], hit[7 * n + i]);
            let instance = if inst != INVALID_ID { inst } else { geom };
            if !f(instance, prim, u, v) {
                valid[i] = 0;
            }
        }
    }));
}

/// Cofactor matrix of the linear part of `m`: `cof(M) (a × b) = (M a) × (M b)`.
fn cofactor(m: &Mat4) -> Mat3 {
    let (a, b, c) = (
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    );
    Mat3::from_cols(b.cross(c), c.cross(a), a.cross(b))
}

#[derive(Clone, Copy)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    fn grow(self, p: Vec3) -> Aabb {
        if p.is_finite() {
            Aabb {
                min: self.min.min(p),
                max: self.max.max(p),
            }
        } else {
            self
        }
    }

    fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// The box around the 8 transformed corners.
    fn transformed(self, m: &Mat4) -> Aabb {
        if self.is_empty() {
            return self;
        }
        (0..8).fold(Aabb::EMPTY, |b, k| {
            let corner = Vec3::select(
                glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0),
                self.max,
                self.min,
            );
            b.grow(m.transform_point3(corner))
        })
    }
}

/// Bounds of `mesh` (optionally transformed): its triangles, leaving out those with a non-finite
/// vertex as Embree does; a subdivision surface's cage points (the limit surface lies in their
/// convex hull).
fn mesh_bounds(mesh: &MeshData, xf: Option<&Mat4>) -> Aabb {
    let at = |p: Vec3| xf.map_or(p, |m| m.transform_point3(p));
    match &mesh.shape {
        Shape::Triangles { positions, indices } => indices.iter().fold(Aabb::EMPTY, |b, tri| {
            let p = tri.map(|i| at(positions[i as usize]));
            if p.iter().all(|p| p.is_finite()) {
                p.into_iter().fold(b, Aabb::grow)
            } else {
                b
            }
        }),
        Shape::Subdivision(s) => s.face_indices.iter().fold(Aabb::EMPTY, |b, &i| b.grow(at(s.positions[i as usize]))),
    }
}
