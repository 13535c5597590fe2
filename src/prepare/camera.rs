//! The render-time camera: a pinhole or thin-lens (or orthographic) projection of a
//! `scene::Camera`.

use crate::embree::Ray;
use crate::scene::{mat4, Camera};
use glam::{Mat3, Vec2, Vec3};

/// Generates primary rays. Pixel (0, 0) is the top-left corner of the image.
#[derive(Clone, Debug)]
pub struct CameraModel {
    pub origin: Vec3,
    /// Camera-to-world rotation (columns: right, up, backward).
    pub rot: Mat3,
    /// Half extents of the image plane at distance 1 (perspective) or in metres (orthographic).
    pub half: Vec2,
    pub orthographic: bool,
    /// Centre of the image window on the plane at distance 1 (perspective) or in metres
    /// (orthographic): the film's aperture offset.
    pub shift: Vec2,
    /// Thin-lens radius in metres (0: a pinhole) and the distance of the plane in focus.
    pub lens_radius: f32,
    pub focus_distance: f32,
    /// Width over height of the image's pixels (the camera's, or what `adjustPixelAspectRatio`
    /// made of it); the EXR file records it.
    pub pixel_aspect: f32,
    pub near: f32,
    pub far: f32,
    /// Size of the image rendered: the whole image's, or its crop window's ([`CameraModel::crop`]).
    pub width: u32,
    pub height: u32,
    /// The whole image's size and the crop window's top-left pixel in it: rays, pixel footprints
    /// and per-pixel seeds ([`CameraModel::pixel_index`]) are those of the whole image, so a crop
    /// renders its pixels as the whole image does.
    pub full: [u32; 2],
    pub offset: [u32; 2],
}

impl CameraModel {
    /// Build from the scene camera for a `width`×`height` image of pixels `cam.pixel_aspect` wide
    /// (over their height). Where the apertures' aspect ratio is not the image's, the camera's
    /// `aspect_conform` (USD `aspectRatioConformPolicy`) decides: `expandAperture` (the default)
    /// grows the aperture that is short, `cropAperture` shrinks the one that is long,
    /// `adjustApertureWidth` / `adjustApertureHeight` change that one, and
    /// `adjustPixelAspectRatio` keeps both and makes the pixels as wide as they then are
    /// ([`CameraModel::pixel_aspect`]).
    pub fn new(cam: &Camera, width: u32, height: u32) -> CameraModel {
        let m = mat4(&cam.transform);
        let m3 = Mat3::from_mat4(m);
        let rot = Mat3::from_cols(m3.x_axis.normalize(), m3.y_axis.normalize(), m3.z_axis.normalize());
        let origin = m.transform_point3(Vec3::ZERO);
        let orthographic = cam.projection == "orthographic";
        let scale = if orthographic { 0.5 } else { 0.5 / cam.focal_length };
        let (mut hx, mut hy) = (cam.horizontal_aperture * scale, cam.vertical_aperture * scale);
        let shift = Vec2::from(cam.aperture_offset) * (2.0 * scale);
        let img_aspect = width as f32 / height as f32 * cam.pixel_aspect;
        let mut pixel_aspect = cam.pixel_aspect;
        match cam.aspect_conform.as_str() {
            "cropAperture" if img_aspect > hx / hy => hy = hx / img_aspect,
            "cropAperture" => hx = hy * img_aspect,
            "adjustApertureWidth" => hx = hy * img_aspect,
            "adjustApertureHeight" => hy = hx / img_aspect,
            "adjustPixelAspectRatio" => pixel_aspect = (hx / hy) / (width as f32 / height as f32),
            // expandAperture
            _ if img_aspect > hx / hy => hx = hy * img_aspect,
            _ => hy = hx / img_aspect,
        }
        CameraModel {
            origin,
            rot,
            half: Vec2::new(hx, hy),
            orthographic,
            shift,
            lens_radius: if orthographic { 0.0 } else { cam.lens_radius },
            focus_distance: cam.focus_distance,
            pixel_aspect,
            near: cam.clipping[0],
            far: cam.clipping[1],
            width,
            height,
            full: [width, height],
            offset: [0, 0],
        }
    }

    /// Render only the window `[x0, y0, x1, y1)` of the image (pixel coordinates, checked by the
    /// caller to lie inside it): pixel (0, 0) becomes the window's top-left pixel.
    pub fn crop(&mut self, [x0, y0, x1, y1]: [u32; 4]) {
        debug_assert!(x0 < x1 && y0 < y1 && x1 <= self.full[0] && y1 <= self.full[1]);
        self.offset = [x0, y0];
        self.width = x1 - x0;
        self.height = y1 - y0;
    }

    /// Index of pixel (`x`, `y`) of the rendered window in the whole image (row-major): what
    /// per-pixel random streams are seeded with.
    #[inline]
    pub fn pixel_index(&self, x: u32, y: u32) -> u64 {
        (y + self.offset[1]) as u64 * self.full[0] as u64 + (x + self.offset[0]) as u64
    }

    /// Whether primary rays need a lens sample ([`ray_lens`](Self::ray_lens)): depth of field.
    #[inline]
    pub fn has_lens(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// Primary ray through position (`x`, `y`) of the whole image in pixels (fractional; y down;
    /// a crop window's pixel `x` is at `x + offset[0]`) from the lens
    /// point that `lens() ∈ [0,1)²` picks (uniform over the lens disk). A pinhole draws no lens
    /// point: `lens` is called only for a camera with depth of field.
    #[inline]
    pub fn ray_lens(&self, x: f32, y: f32, lens: impl FnOnce() -> Vec2) -> Ray {
        if !self.has_lens() {
            return self.ray(x, y);
        }
        let u = lens();
        // the pinhole ray's point on the plane in focus, seen from a point of the lens
        let (sx, sy) = self.window(x, y);
        let focus = Vec3::new(sx, sy, -1.0) * self.focus_distance;
        let lens = (crate::sampling::square_to_uniform_disk_concentric(u) * self.lens_radius).extend(0.0);
        let local = focus - lens;
        let len = local.length();
        // clipping distances are along the view axis: t = distance · |local| / |local.z|
        let along = len / local.z.abs();
        Ray::segment(self.origin + self.rot * lens, self.rot * (local / len), self.near * along, self.far * along)
    }

    /// Image-plane coordinates (at distance 1, or metres for orthographic) of pixel position (x, y).
    #[inline]
    fn window(&self, x: f32, y: f32) -> (f32, f32) {
        let sx = (2.0 * x / self.full[0] as f32 - 1.0) * self.half.x + self.shift.x;
        let sy = (1.0 - 2.0 * y / self.full[1] as f32) * self.half.y + self.shift.y;
        (sx, sy)
    }

    /// Primary ray through position (`x`, `y`) of the whole image in pixels (fractional; y down), through the
    /// centre of the lens.
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let (sx, sy) = self.window(x, y);
        if self.orthographic {
            let org = self.origin + self.rot * Vec3::new(sx, sy, 0.0);
            let dir = self.rot * Vec3::NEG_Z;
            Ray::segment(org, dir, self.near, self.far)
        } else {
            let local = Vec3::new(sx, sy, -1.0);
            let len = local.length();
            let dir = self.rot * (local / len);
            // clipping distances are along the view axis
            Ray::segment(self.origin, dir, self.near * len, self.far * len)
        }
    }

    /// The position in the rendered window (in pixels, fractional; y down) where world point `p` projects, through
    /// the centre of the lens (what [`ray`](Self::ray) inverts); `None` behind the camera.
    pub fn raster(&self, p: Vec3) -> Option<Vec2> {
        let local = self.rot.transpose() * (p - self.origin);
        let (sx, sy) = if self.orthographic {
            (local.x, local.y)
        } else {
            if !(local.z < 0.0) {
                return None;
            }
            (local.x / -local.z, local.y / -local.z)
        };
        let x = ((sx - self.shift.x) / self.half.x + 1.0) * 0.5 * self.full[0] as f32 - self.offset[0] as f32;
        let y = (1.0 - (sy - self.shift.y) / self.half.y) * 0.5 * self.full[1] as f32 - self.offset[1] as f32;
        (x.is_finite() && y.is_finite()).then_some(Vec2::new(x, y))
    }

    /// The cone of a primary ray: as wide as a pixel (the geometric mean of its width and
    /// height, at unit distance), opening from the pinhole (perspective; a thin lens is taken as
    /// its centre, the cone's width then right at the plane in focus) or parallel
    /// (orthographic).
    pub fn cone(&self) -> super::RayCone {
        let pixel = (4.0 * self.half.x * self.half.y / (self.full[0] as f32 * self.full[1] as f32)).sqrt();
        if self.orthographic {
            super::RayCone { width: pixel, spread: 0.0 }
        } else {
            super::RayCone { width: 0.0, spread: pixel }
        }
    }

    /// Forward (viewing) direction.
    pub fn forward(&self) -> Vec3 {
        self.rot * Vec3::NEG_Z
    }

    /// Width of one pixel, in metres, at world point `p` seen directly (across the view axis;
    /// points at or before the near plane count as on it).
    pub fn pixel_size_at(&self, p: Vec3) -> f32 {
        let at_unit = 2.0 * self.half.x / self.full[0] as f32;
        if self.orthographic {
            at_unit
        } else {
            at_unit * (p - self.origin).dot(self.forward()).max(self.near)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each `aspectRatioConformPolicy` on 36 × 24 apertures (3:2) and a square image, and
    /// non-square pixels: the half extents of the film at unit distance, and the pixels' aspect.
    #[test]
    fn aspect_conform_policies_shape_the_film() {
        let model = |conform: &str, pixel_aspect: f32, w: u32, h: u32| {
            let cam = Camera { focal_length: 50.0, horizontal_aperture: 36.0, vertical_aperture: 24.0, pixel_aspect, aspect_conform: conform.into(), ..Camera::default() };
            let m = CameraModel::new(&cam, w, h);
            (m.half * 100.0, m.pixel_aspect) // apertures at focal length 50: half = aperture / 100
        };
        let close = |(a, pa): (Vec2, f32), (b, pb): (Vec2, f32)| (a - b).abs().max_element() < 1e-4 && (pa - pb).abs() < 1e-6;
        let cases = [
            ("expandAperture", 1.0, (Vec2::new(36.0, 36.0), 1.0)),
            ("cropAperture", 1.0, (Vec2::new(24.0, 24.0), 1.0)),
            ("adjustApertureWidth", 1.0, (Vec2::new(24.0, 24.0), 1.0)),
            ("adjustApertureHeight", 1.0, (Vec2::new(36.0, 36.0), 1.0)),
            ("adjustPixelAspectRatio", 1.0, (Vec2::new(36.0, 24.0), 1.5)),
            // pixels twice as wide as high: the image is 2:1 on the film, wider than the apertures
            ("expandAperture", 2.0, (Vec2::new(48.0, 24.0), 2.0)),
            ("cropAperture", 2.0, (Vec2::new(36.0, 18.0), 2.0)),
        ];
        for (conform, par, want) in cases {
            let got = model(conform, par, 100, 100);
            assert!(close(got, want), "{conform} at pixel aspect {par}: {got:?}, want {want:?}");
        }
        // square pixels on a 3:2 image: every policy leaves 3:2 apertures alone
        for conform in crate::scene::ASPECT_CONFORM {
            assert!(close(model(conform, 1.0, 150, 100), (Vec2::new(36.0, 24.0), 1.0)), "{conform}");
        }
    }

    /// `raster` inverts `ray`: a point anywhere along the ray through an image position projects
    /// back onto that position, for a rotated, shifted perspective camera and an orthographic one;
    /// a point behind a perspective camera projects nowhere.
    #[test]
    fn raster_finds_the_image_position_of_a_point_seen_directly() {
        let rot = glam::Mat4::from_rotation_translation(glam::Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.1), Vec3::new(1.0, 2.0, -3.0));
        let transform = rot.to_cols_array_2d();
        for projection in ["perspective", "orthographic"] {
            let cam = Camera { projection: projection.into(), transform, focal_length: 35.0, horizontal_aperture: 36.0, vertical_aperture: 24.0, aperture_offset: [2.0, -1.5], clipping: [0.01, 1e4], ..Camera::default() };
            let m = CameraModel::new(&cam, 320, 200);
            for (x, y) in [(0.5, 0.5), (160.0, 100.0), (319.9, 12.25), (3.75, 199.5), (250.5, 77.0)] {
                for t in [0.5f32, 3.0, 40.0] {
                    let r = m.ray(x, y);
                    let got = m.raster(r.org + r.dir * t).expect("a point in front of the camera");
                    assert!((got - Vec2::new(x, y)).abs().max_element() < 2e-3, "{projection} ({x}, {y}) at {t}: {got}");
                }
            }
            if projection == "perspective" {
                assert_eq!(m.raster(m.origin - m.forward()), None);
            }
        }
    }
}
