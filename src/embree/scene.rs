//! The committed [`Scene`] and its ray queries (single and batched).

use glam::{Mat3, Vec3};

use super::builder::{FilterFn, RawGeometry};
use super::query::{Query, RayHit};
use super::subdivision::SubdivHandle;
use super::sys::{self, RTC_INVALID_GEOMETRY_ID as INVALID_ID};
use super::{Device, Hit, Ray};
use crate::{Error, Result};

/// Rays per `Query::intersect_many` / `Query::occluded_many` call in the batched queries.
const BATCH: usize = 64;

/// What a top-level geometry ID (= instance index) is.
pub(super) enum TopGeom {
    /// The instance's mesh has no triangles; nothing was attached.
    Empty,
    /// The world-space triangles are in the top-level scene; Embree's Ng is already world space.
    Flat,
    /// An Embree instance of a child scene; Embree's Ng is in object space.
    Instanced {
        /// Cofactor matrix of the linear part: maps object-space `e1 × e2` to world-space `e1 × e2`
        /// (= det · inverse transpose, so it keeps the winding even for mirroring transforms).
        normal_to_world: Mat3,
    },
}

/// A committed scene, ready for ray queries from any number of threads (`Send + Sync`).
///
/// Owns the Embree scenes, the filter closures and a device reference; dropping it releases all.
pub struct Scene {
    // Field order is drop order: the top-level scene (and its instances) before the child scenes,
    // the scenes before the filter closures their geometries point to, the device last.
    pub(super) top: RawScene,
    pub(super) children: Vec<RawScene>,
    /// Indexed by top-level geometry ID = instance index.
    pub(super) geoms: Vec<TopGeom>,
    pub(super) bounds: (Vec3, Vec3),
    /// Per instance: how to evaluate it, if it is a subdivision surface.
    pub(super) subdivisions: Vec<Option<SubdivHandle>>,
    /// References to the subdivision geometries `subdivisions` points to.
    pub(super) _held: Vec<RawGeometry>,
    /// Boxed: Embree geometries hold raw pointers to these `FilterFn`s, so they must not move.
    #[allow(clippy::vec_box)]
    pub(super) filters: Vec<Box<FilterFn>>,
    pub(super) _device: Device,
}

// SAFETY: after commit the Embree scenes are only used through rtcIntersect*/rtcOccluded* and the
// geometries through rtcInterpolate, which Embree allows concurrently from any thread; the filter
// closures are `Send + Sync`; the rest is plain data. Dropping (releasing the handles) needs exclusive ownership, which Rust guarantees.
unsafe impl Send for Scene {}
// SAFETY: see `Send`; `&Scene` only permits concurrent ray queries.
unsafe impl Sync for Scene {}

/// The Embree call `f`, its cycles counted by `embree::timing` when built with `embree-timing`.
#[inline(always)]
fn timed<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(feature = "embree-timing")]
    return super::timing::timed(f);
    #[cfg(not(feature = "embree-timing"))]
    f()
}

impl Scene {
    /// The closest hit along `ray` within `[tnear, tfar]`, if any.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut query = Query::new(false);
        let mut rh = RayHit::new(rtc_ray_hit(ray));
        // SAFETY: `top` is a committed scene, never modified after commit.
        timed(|| unsafe { query.intersect(self.top.0, &mut rh) });
        self.to_hit(rh.get())
    }

    /// Whether anything blocks `ray` within `[tnear, tfar]`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut query = Query::new(false);
        let mut r = rtc_ray(ray);
        // SAFETY: `top` is a committed scene, never modified after commit.
        timed(|| unsafe { query.occluded(self.top.0, &mut r) });
        r.tfar == f32::NEG_INFINITY
    }

    /// Batched [`Scene::intersect`]: `hits[i]` is the hit of `rays[i]`. Set `coherent` for rays
    /// with similar origins and directions (camera rays): Embree 3 then traces them as packets
    /// (`rtcIntersect1M`); Embree 4 takes it as a hint.
    ///
    /// # Panics
    /// If `rays` and `hits` differ in length.
    pub fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>], coherent: bool) {
        assert_eq!(
            rays.len(),
            hits.len(),
            "intersect_batch: rays and hits differ in length"
        );
        let mut query = Query::new(coherent);
        let mut buf = [RayHit::new(rtc_ray_hit(&Ray::new(Vec3::ZERO, Vec3::Z))); BATCH];
        for (rays, hits) in rays.chunks(BATCH).zip(hits.chunks_mut(BATCH)) {
            for (b, r) in buf.iter_mut().zip(rays) {
                *b = RayHit::new(rtc_ray_hit(r));
            }
            let buf = &mut buf[..rays.len()];
            // SAFETY: `top` is a committed scene, never modified after commit.
            timed(|| unsafe { query.intersect_many(self.top.0, buf) });
            for (h, b) in hits.iter_mut().zip(buf.iter()) {
                *h = self.to_hit(b.get());
            }
        }
    }

    /// Batched [`Scene::occluded`]: `occluded[i]` tells whether `rays[i]` is blocked (`coherent`
    /// as for [`Scene::intersect_batch`]).
    ///
    /// # Panics
    /// If `rays` and `occluded` differ in length.
    pub fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool], coherent: bool) {
        assert_eq!(
            rays.len(),
            occluded.len(),
            "occluded_batch: rays and occluded differ in length"
        );
        let mut query = Query::new(coherent);
        let mut buf = [sys::RTCRay::default(); BATCH];
        for (rays, occluded) in rays.chunks(BATCH).zip(occluded.chunks_mut(BATCH)) {
            for (b, r) in buf.iter_mut().zip(rays) {
                *b = rtc_ray(r);
            }
            let buf = &mut buf[..rays.len()];
            // SAFETY: `top` is a committed scene, never modified after commit.
            timed(|| unsafe { query.occluded_many(self.top.0, buf) });
            for (o, b) in occluded.iter_mut().zip(buf.iter()) {
                *o = b.tfar == f32::NEG_INFINITY;
            }
        }
    }

    /// World-space bounding box `(min, max)` of all instances; `(0, 0)` for an empty scene.
    /// Flattened meshes are bounded exactly, instanced ones by their transformed object-space box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    fn to_hit(&self, rh: &sys::RTCRayHit) -> Option<Hit> {
        let h = &rh.hit;
        if h.geomID == INVALID_ID {
            return None;
        }
        let instance = if h.instID[0] != INVALID_ID {
            h.instID[0]
        } else {
            h.geomID
        };
        let mut ng = Vec3::new(h.Ng_x, h.Ng_y, h.Ng_z);
        if let Some(TopGeom::Instanced { normal_to_world }) = self.geoms.get(instance as usize) {
            ng = *normal_to_world * ng;
        }
        Some(Hit {
            t: rh.ray.tfar,
            u: h.u,
            v: h.v,
            instance,
            prim: h.primID,
            ng,
        })
    }
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("instances", &self.geoms.len())
            .field("child_scenes", &self.children.len())
            .field("filters", &self.filters.len())
            .field("bounds", &self.bounds)
            .finish_non_exhaustive()
    }
}

/// An owned `RTCScene` reference.
pub(super) struct RawScene(pub(super) sys::RTCScene);

impl RawScene {
    pub(super) fn new(dev: &Device) -> Result<RawScene> {
        // SAFETY: the device handle is live.
        let raw = unsafe { sys::rtcNewScene(dev.raw()) };
        dev.check("rtcNewScene")?;
        if raw.is_null() {
            return Err(Error::Embree("rtcNewScene returned null".into()));
        }
        Ok(RawScene(raw))
    }

    pub(super) fn attach(&self, dev: &Device, geom: &RawGeometry, id: u32) -> Result<()> {
        // SAFETY: both handles are live and belong to `dev`; the scene takes its own reference.
        unsafe { sys::rtcAttachGeometryByID(self.0, geom.0, id) };
        dev.check("rtcAttachGeometryByID")
    }

    pub(super) fn commit(&self, dev: &Device) -> Result<()> {
        // rtcCommitScene rather than rtcJoinCommitScene: with Debian's TBB build Embree recommends
        // it, and the build threads are bounded by the device's `threads=` setting.
        // SAFETY: the scene is live and not being traced or modified by anyone else.
        unsafe { sys::rtcCommitScene(self.0) };
        dev.check("rtcCommitScene")
    }
}

impl Drop for RawScene {
    fn drop(&mut self) {
        // SAFETY: we own one reference to this live scene.
        unsafe { sys::rtcReleaseScene(self.0) };
    }
}

/// A fully initialised Embree ray (mask all ones, time 0, no flags).
fn rtc_ray(r: &Ray) -> sys::RTCRay {
    sys::RTCRay {
        org_x: r.org.x,
        org_y: r.org.y,
        org_z: r.org.z,
        tnear: r.tnear,
        dir_x: r.dir.x,
        dir_y: r.dir.y,
        dir_z: r.dir.z,
        time: 0.0,
        tfar: r.tfar,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// A ray with the "no hit" record Embree expects on input.
fn rtc_ray_hit(r: &Ray) -> sys::RTCRayHit {
    sys::RTCRayHit { ray: rtc_ray(r), hit: no_hit() }
}

/// The "no hit" record Embree expects on input.
fn no_hit() -> sys::RTCHit {
    sys::RTCHit {
        geomID: INVALID_ID,
        primID: INVALID_ID,
        instID: [INVALID_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
        ..Default::default()
    }
}
