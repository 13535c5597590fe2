//! Ray cones (Akenine-Möller et al., "Texture Level of Detail Strategies for Real-Time Ray
//! Tracing", Ray Tracing Gems 2019): a camera ray stands for its pixel, a cone that starts
//! `width` wide and opens by `spread` radians per unit of distance. Where it meets a surface it
//! covers an ellipse; mapped into the triangle's texture coordinates, that ellipse is the
//! [`Footprint`] a texture lookup filters over (MIP levels, anisotropic probes). Two floats carried
//! beside the ray, nothing allocated.

use crate::image::Footprint;
use glam::{Vec2, Vec3};

/// A ray's cone: its width at the ray's origin and how fast it opens (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayCone {
    pub width: f32,
    pub spread: f32,
}

impl RayCone {
    /// The cone's width at distance `t` along its ray.
    #[inline]
    pub fn width_at(&self, t: f32) -> f32 {
        self.width + self.spread * t
    }

    /// The cone of one of `n` stratified camera samples of a pixel, each of which covers `1 / n`
    /// of the pixel's area: `1 / √n` as wide. The first samples of an image then already average
    /// the texels their pixel sees, and as samples grow the footprints shrink, so the image
    /// converges to the one of unfiltered (bilinear) lookups.
    #[inline]
    pub fn per_sample(&self, n: u32) -> RayCone {
        let k = 1.0 / (n.max(1) as f32).sqrt();
        RayCone { width: self.width * k, spread: self.spread * k }
    }

    /// The cone that leaves a surface at distance `t` after a reflection or refraction: as wide
    /// as it arrived, opening by `extra` more (the lobe's own spread; 0 for a mirror).
    #[inline]
    pub fn bounce(&self, t: f32, extra: f32) -> RayCone {
        RayCone { width: self.width_at(t), spread: (self.spread + extra).min(std::f32::consts::FRAC_PI_2) }
    }
}

/// The spread a glossy lobe adds to a cone that leaves in a direction it sampled with density
/// `pdf` (solid angle): the angular radius of a cone of solid angle `1 / pdf`, `√(1 / (π pdf))`
/// (a GGX lobe of roughness `α` has a density of about `1 / (4π α²)` at its peak, where this is
/// `2α`).
#[inline]
pub fn glossy_spread(pdf: f32) -> f32 {
    if pdf > 0.0 {
        (1.0 / (std::f32::consts::PI * pdf)).sqrt().min(std::f32::consts::FRAC_PI_2)
    } else {
        std::f32::consts::FRAC_PI_2
    }
}

/// How textures are filtered: bilinear in the image only (the cone is ignored), trilinear in the
/// MIP level the cone's footprint asks for, or anisotropic (up to [`MAX_PROBES`] trilinear lookups
/// along the footprint's long axis, the default).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TextureFilter {
    Bilinear,
    Trilinear,
    #[default]
    Anisotropic,
}

/// The most lookups of an anisotropic footprint (a surface seen at 83° from its normal and
/// beyond is filtered as at 83° across its long axis).
pub const MAX_PROBES: u32 = 8;

impl TextureFilter {
    /// `"bilinear"`, `"trilinear"` or `"anisotropic"`.
    pub fn parse(s: &str) -> Option<TextureFilter> {
        match s {
            "bilinear" => Some(TextureFilter::Bilinear),
            "trilinear" => Some(TextureFilter::Trilinear),
            "anisotropic" => Some(TextureFilter::Anisotropic),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            TextureFilter::Bilinear => "bilinear",
            TextureFilter::Trilinear => "trilinear",
            TextureFilter::Anisotropic => "anisotropic",
        }
    }

    /// The footprint's most lookups along its long axis; 0: no footprint at all.
    pub fn max_probes(self) -> u32 {
        match self {
            TextureFilter::Bilinear => 0,
            TextureFilter::Trilinear => 1,
            TextureFilter::Anisotropic => MAX_PROBES,
        }
    }
}

/// The footprint of a cone `width` wide arriving along unit direction `dir` at a triangle of
/// world-space edges `e1`, `e2` (from its first corner), unit normal `n` and texture-coordinate
/// edges `d1`, `d2`: the ellipse's axes — `width` across the ray, `width / |cos θ|` along it —
/// mapped into texture coordinates by the triangle's affine map. `Footprint::POINT` where the
/// triangle has no area in either space.
pub fn footprint(width: f32, dir: Vec3, n: Vec3, e: [Vec3; 2], d: [Vec2; 2], max_probes: u32) -> Footprint {
    let [e1, e2] = e;
    let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let det = g11 * g22 - g12 * g12;
    if !(det > 0.0) || !(width > 0.0) || !det.is_finite() {
        return Footprint::POINT;
    }
    // (cos θ at most 20× stretched: beyond, the probes' cap decides anyway)
    let cos = n.dot(dir).abs().max(0.05);
    let along = dir - n * n.dot(dir);
    let major = along.try_normalize().unwrap_or_else(|| e1 / g11.sqrt());
    let minor = n.cross(major);
    // a world direction in the triangle's plane as a texture-coordinate direction
    let to_uv = |x: Vec3| {
        let (r1, r2) = (e1.dot(x), e2.dot(x));
        let (a, b) = ((g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det);
        d[0] * a + d[1] * b
    };
    let fp = Footprint { axes: [to_uv(major * (width / cos)), to_uv(minor * width)], max_probes };
    if fp.axes[0].is_finite() && fp.axes[1].is_finite() {
        fp
    } else {
        Footprint::POINT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plane with texture coordinates = world (x, z) seen straight down is a circle of the
    /// cone's width; seen at 60° from its normal the axis along the view is twice as long.
    #[test]
    fn footprints_on_a_plane() {
        let e = [Vec3::X, Vec3::Z];
        let d = [Vec2::X, Vec2::Y];
        let fp = footprint(0.1, -Vec3::Y, Vec3::Y, e, d, 8);
        let lens = [fp.axes[0].length(), fp.axes[1].length()];
        assert!((lens[0] - 0.1).abs() < 1e-6 && (lens[1] - 0.1).abs() < 1e-6, "{lens:?}");
        let t = 60f32.to_radians();
        let dir = Vec3::new(t.sin(), -t.cos(), 0.0);
        let fp = footprint(0.1, dir, Vec3::Y, e, d, 8);
        assert!((fp.axes[0] - Vec2::new(0.2, 0.0)).length() < 1e-5, "{:?}", fp.axes);
        assert!((fp.axes[1].length() - 0.1).abs() < 1e-5 && fp.axes[1].x.abs() < 1e-6, "{:?}", fp.axes);
        // texture coordinates twice as dense along x: the axis along x doubles
        let fp = footprint(0.1, dir, Vec3::Y, e, [Vec2::X * 2.0, Vec2::Y], 8);
        assert!((fp.axes[0] - Vec2::new(0.4, 0.0)).length() < 1e-5, "{:?}", fp.axes);
        // one of 4 samples per pixel covers a quarter of it: half as wide
        assert_eq!(RayCone { width: 0.2, spread: 0.01 }.per_sample(4), RayCone { width: 0.1, spread: 0.005 });
        // no area: no footprint
        assert_eq!(footprint(0.1, dir, Vec3::Y, [Vec3::X, Vec3::X], d, 8), Footprint::POINT);
        assert_eq!(footprint(0.0, dir, Vec3::Y, e, d, 8), Footprint::POINT);
    }
}
