//! Shading normals from tangent-space normal maps, and the bend that keeps a shading normal from
//! reflecting the view below the surface. Every path (camera paths, the eye pass, photons, final
//! gathering) gets its shading normal from `PreparedScene::surface_hit`, which calls these.

use glam::Vec3;

/// The normal a tangent-space normal map's value `m` (`x` along the tangent, `y` along the
/// bitangent, `z` along the normal, in [−1, 1]) gives in the frame of the interpolated normal `n`
/// and tangent `t` (world space, not necessarily unit or orthogonal) whose bitangent is
/// `sign · n × t` (MikkTSpace's per-pixel reconstruction). `n` itself where the frame or the
/// value is degenerate.
#[inline]
pub fn perturbed(n: Vec3, t: Vec3, sign: f32, m: Vec3) -> Vec3 {
    let n = n.normalize_or_zero();
    let t = (t - n * n.dot(t)).normalize_or_zero();
    if n == Vec3::ZERO || t == Vec3::ZERO || !m.is_finite() {
        return n;
    }
    let b = sign * n.cross(t);
    (t * m.x + b * m.y + n * m.z).try_normalize().unwrap_or(n)
}

/// Shading normal `n` bent toward the geometric normal `ng` (both unit, on the side of `wo`, the
/// unit direction toward the viewer) just enough that the mirror direction of `wo` about it lies
/// above the surface (by `min(0.9 ng·wo, 0.01)` in cosine): a normal map or interpolated normals
/// can tilt `n` so far that the view reflects into the surface, where a path finds nothing
/// but black (the black fringes of normal-mapped silhouettes). `n` unchanged where it does not.
/// The bend is found by bisection along the arc from `n` to `ng` (`ng` itself always qualifies).
pub fn keep_reflection_above(n: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    let cos_g = ng.dot(wo);
    if !(cos_g > 0.0) {
        return n;
    }
    let margin = (0.9 * cos_g).min(0.01);
    let above = |n: Vec3| (2.0 * n.dot(wo) * n - wo).dot(ng);
    if above(n) >= margin {
        return n;
    }
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..20 {
        let mid = 0.5 * (lo + hi);
        if above(n.lerp(ng, mid).normalize()) >= margin {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    n.lerp(ng, hi).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The map's value is read in the tangent frame: (0, 0, 1) is the normal, (1, 0, 0) the
    /// tangent, (0, 1, 0) the bitangent, whose sign follows `sign`.
    #[test]
    fn values_are_read_in_the_tangent_frame() {
        let (n, t) = (Vec3::Z, Vec3::X + 0.3 * Vec3::Z);
        assert!((perturbed(n, t, 1.0, Vec3::Z) - Vec3::Z).length() < 1e-6);
        assert!((perturbed(n, t, 1.0, Vec3::X) - Vec3::X).length() < 1e-6);
        assert!((perturbed(n, t, 1.0, Vec3::Y) - Vec3::Y).length() < 1e-6);
        assert!((perturbed(n, t, -1.0, Vec3::Y) + Vec3::Y).length() < 1e-6);
        let m = Vec3::new(0.5, 0.0, 0.8);
        let p = perturbed(n, t, 1.0, m);
        assert!((p.length() - 1.0).abs() < 1e-6 && p.y.abs() < 1e-6 && p.x > 0.0);
        assert_eq!(perturbed(n, Vec3::ZERO, 1.0, Vec3::X), n);
    }

    /// A normal that reflects the view below the surface is bent just enough (the reflection
    /// then grazes the surface by the margin); one that does not is left as it is.
    #[test]
    fn reflections_are_kept_above_the_surface() {
        let ng = Vec3::Z;
        let wo = Vec3::new(0.9, 0.0, 0.2).normalize();
        let fine = Vec3::new(0.1, 0.0, 1.0).normalize();
        assert_eq!(keep_reflection_above(fine, ng, wo), fine);
        // tilted away from the viewer by 60°: the view reflects into the surface
        let tilted = Vec3::new(-(60f32.to_radians().sin()), 0.0, 60f32.to_radians().cos());
        assert!((2.0 * tilted.dot(wo) * tilted - wo).dot(ng) < 0.0);
        let bent = keep_reflection_above(tilted, ng, wo);
        let r = 2.0 * bent.dot(wo) * bent - wo;
        let margin = (0.9 * ng.dot(wo)).min(0.01);
        assert!(r.dot(ng) >= margin && r.dot(ng) < margin + 1e-3, "{}", r.dot(ng));
        // between the two, in their plane
        assert!(bent.y.abs() < 1e-6 && bent.x > tilted.x && (bent.length() - 1.0).abs() < 1e-5);
    }
}
