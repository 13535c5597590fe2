//! Embree 3's ray-query calls: `rtcIntersect1`/`rtcOccluded1` with an intersect context, and the
//! stream calls `rtcIntersect1M`/`rtcOccluded1M` for batches (traced as packets when coherent).

use std::mem::size_of;

use super::sys::{self, RTC_INVALID_GEOMETRY_ID as INVALID_ID};

/// A ray and its hit record, as `rtcIntersect*` reads and writes them.
#[repr(transparent)]
#[derive(Clone, Copy)]
pub(super) struct RayHit(sys::RTCRayHit);

impl RayHit {
    pub(super) fn new(rh: sys::RTCRayHit) -> RayHit {
        RayHit(rh)
    }

    pub(super) fn get(&self) -> &sys::RTCRayHit {
        &self.0
    }
}

/// The arguments of a query: the intersect context with its coherence flag.
pub(super) struct Query(sys::RTCIntersectContext);

impl Query {
    /// Reimplementation of the header-only `rtcInitIntersectContext`, with the coherence flag.
    #[allow(clippy::needless_update)]
    pub(super) fn new(coherent: bool) -> Query {
        Query(sys::RTCIntersectContext {
            flags: if coherent {
                sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT
            } else {
                sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
            },
            filter: None,
            instID: [INVALID_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
            ..Default::default() // `instStackSize` in Embree builds with several instance levels
        })
    }

    /// The closest hit of `rh`'s ray, written into `rh`.
    ///
    /// # Safety
    /// `scene` is a committed scene, not modified during the call.
    #[inline]
    pub(super) unsafe fn intersect(&mut self, scene: sys::RTCScene, rh: &mut RayHit) {
        // SAFETY: the caller guarantees the scene; the context and the ray are initialised and
        // live for the call.
        unsafe { sys::rtcIntersect1(scene, &mut self.0, &mut rh.0) }
    }

    /// Whether `ray` is blocked: its `tfar` becomes −∞ if so.
    ///
    /// # Safety
    /// As for [`Query::intersect`].
    #[inline]
    pub(super) unsafe fn occluded(&mut self, scene: sys::RTCScene, ray: &mut sys::RTCRay) {
        // SAFETY: as in `intersect`.
        unsafe { sys::rtcOccluded1(scene, &mut self.0, ray) }
    }

    /// [`Query::intersect`] of every entry of `rhs` (a stream call).
    ///
    /// # Safety
    /// As for [`Query::intersect`].
    pub(super) unsafe fn intersect_many(&mut self, scene: sys::RTCScene, rhs: &mut [RayHit]) {
        // SAFETY: as in `intersect`; `rhs` holds `rhs.len()` initialised entries with the stride given.
        unsafe {
            sys::rtcIntersect1M(scene, &mut self.0, rhs.as_mut_ptr().cast(), rhs.len() as u32, size_of::<RayHit>())
        }
    }

    /// [`Query::occluded`] of every entry of `rays` (a stream call).
    ///
    /// # Safety
    /// As for [`Query::intersect`].
    pub(super) unsafe fn occluded_many(&mut self, scene: sys::RTCScene, rays: &mut [sys::RTCRay]) {
        // SAFETY: as in `intersect_many`, with `RTCRay` entries.
        unsafe {
            sys::rtcOccluded1M(scene, &mut self.0, rays.as_mut_ptr(), rays.len() as u32, size_of::<sys::RTCRay>())
        }
    }
}
