//! Embree 4's ray-query calls: `rtcIntersect1`/`rtcOccluded1` with their argument structures
//! (Embree 4 has no intersect context and no stream calls: batches are traced ray by ray, with the
//! coherence flag as a hint).

use super::sys;

/// A ray and its hit record, as `rtcIntersect1` reads and writes them, with room behind the hit:
/// an Embree 4 built with instance arrays (4.3 and later, as the embreex wheel's) writes an
/// `instPrimID` per instance level after `instID`, which the 4.2 headers of `embree4-sys` lack.
#[repr(C)]
#[derive(Clone, Copy)]
pub(super) struct RayHit(sys::RTCRayHit, [u32; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize]);

impl RayHit {
    pub(super) fn new(rh: sys::RTCRayHit) -> RayHit {
        RayHit(rh, [sys::RTC_INVALID_GEOMETRY_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize])
    }

    pub(super) fn get(&self) -> &sys::RTCRayHit {
        &self.0
    }
}

/// An argument structure with room for `minWidthDistanceFactor`, which a library built with
/// `RTC_MIN_WIDTH` reads after the fields the headers declare (0, as `rtcInit*Arguments` sets it).
#[repr(C)]
struct Padded<T>(T, f32);

/// The arguments of the queries (`rtcInitIntersectArguments` and `rtcInitOccludedArguments`, header
/// functions reimplemented, with the coherence flag): every feature on, no context (Embree then
/// uses a fresh one per call), no argument filter.
pub(super) struct Query {
    intersect: Padded<sys::RTCIntersectArguments>,
    occluded: Padded<sys::RTCOccludedArguments>,
}

impl Query {
    pub(super) fn new(coherent: bool) -> Query {
        let flags = if coherent { sys::RTCRayQueryFlags::COHERENT } else { sys::RTCRayQueryFlags::INCOHERENT };
        let feature_mask = sys::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL;
        Query {
            intersect: Padded(
                sys::RTCIntersectArguments {
                    flags,
                    feature_mask,
                    context: std::ptr::null_mut(),
                    filter: None,
                    intersect: None,
                },
                0.0,
            ),
            occluded: Padded(
                sys::RTCOccludedArguments {
                    flags,
                    feature_mask,
                    context: std::ptr::null_mut(),
                    filter: None,
                    occluded: None,
                },
                0.0,
            ),
        }
    }

    /// The closest hit of `rh`'s ray, written into `rh`.
    ///
    /// # Safety
    /// `scene` is a committed scene, not modified during the call.
    #[inline]
    pub(super) unsafe fn intersect(&mut self, scene: sys::RTCScene, rh: &mut RayHit) {
        // SAFETY: the caller guarantees the scene; the ray-hit (with the room the library may
        // write) and the arguments (with the room it may read) are initialised and live for the call.
        unsafe { sys::rtcIntersect1(scene, &mut rh.0, &mut self.intersect.0) }
    }

    /// Whether `ray` is blocked: its `tfar` becomes −∞ if so.
    ///
    /// # Safety
    /// As for [`Query::intersect`].
    #[inline]
    pub(super) unsafe fn occluded(&mut self, scene: sys::RTCScene, ray: &mut sys::RTCRay) {
        // SAFETY: as in `intersect`.
        unsafe { sys::rtcOccluded1(scene, ray, &mut self.occluded.0) }
    }

    /// [`Query::intersect`] of every entry of `rhs`.
    ///
    /// # Safety
    /// As for [`Query::intersect`].
    pub(super) unsafe fn intersect_many(&mut self, scene: sys::RTCScene, rhs: &mut [RayHit]) {
        for rh in rhs {
            // SAFETY: the caller's guarantee, passed on.
            unsafe { self.intersect(scene, rh) }
        }
    }

    /// [`Query::occluded`] of every entry of `rays`.
    ///
    /// # Safety
    /// As for [`Query::intersect`].
    pub(super) unsafe fn occluded_many(&mut self, scene: sys::RTCScene, rays: &mut [sys::RTCRay]) {
        for ray in rays {
            // SAFETY: the caller's guarantee, passed on.
            unsafe { self.occluded(scene, ray) }
        }
    }
}
