//! The sRGB transfer functions (IEC 61966-2-1), on single channel values.

/// Linear → sRGB-encoded value (the sRGB OETF). Input is clamped to `[0, 1]` first; NaN maps to 0.
#[inline]
pub fn srgb_encode(linear: f32) -> f32 {
    let v = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB-encoded value → linear (the inverse of [`srgb_encode`]). Values outside `[0, 1]` are
/// extended symmetrically (`-x ↦ -decode(x)`, values above 1 follow the power curve), so decoding
/// never clamps data that was not clamped when encoded.
#[inline]
pub fn srgb_decode(encoded: f32) -> f32 {
    let a = encoded.abs();
    let v = if a <= 0.040_45 { a / 12.92 } else { ((a + 0.055) / 1.055).powf(2.4) };
    v.copysign(encoded)
}
