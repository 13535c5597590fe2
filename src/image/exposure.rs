//! Automatic exposure for previews: the exposure that maps the image's log-average luminance
//! ("key", Reinhard et al. 2002) to middle grey, so that a scene lit a thousand times brighter than
//! a render's usual range (a sun of 50 000 lux) still previews as a picture rather than as white.

/// Middle grey: the value the image's key is mapped to.
pub const MIDDLE_GREY: f32 = 0.18;
/// The luminance added inside the logarithm, so that black pixels do not send the key to 0.
const DELTA: f64 = 1e-4;

/// What [`auto_exposure`] chose: the exposure in stops and the key it read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoExposure {
    /// Stops (the preview multiplies by `2^stops`).
    pub stops: f32,
    /// The log-average Rec.709 luminance of the image, `exp(mean(ln(δ + L)))`.
    pub key: f32,
}

/// The exposure (stops) that maps the log-average luminance of an RGB buffer (`3 · n` linear
/// floats) to [`MIDDLE_GREY`]. Non-finite and negative pixels are left out; an image without a
/// finite pixel brighter than black gets 0 stops. Clamped to ±64 stops (the CLI's `--exposure`
/// range).
pub fn auto_exposure(rgb: &[f32]) -> AutoExposure {
    let (mut sum, mut n, mut lit) = (0.0f64, 0u64, false);
    for px in rgb.chunks_exact(3) {
        let l = 0.2126 * px[0] as f64 + 0.7152 * px[1] as f64 + 0.0722 * px[2] as f64;
        if l.is_finite() && l >= 0.0 {
            sum += (DELTA + l).ln();
            n += 1;
            lit |= l > 0.0;
        }
    }
    if n == 0 || !lit {
        return AutoExposure { stops: 0.0, key: 0.0 };
    }
    let key = (sum / n as f64).exp();
    let stops = ((MIDDLE_GREY as f64 / key).log2()).clamp(-64.0, 64.0) as f32;
    AutoExposure { stops, key: key as f32 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform image of luminance L gets log2(0.18 / L) stops (up to δ); an image 1 000 times
    /// brighter gets log2(1000) ≈ 9.97 stops less; black and non-finite pixels do not break it.
    #[test]
    fn the_key_goes_to_middle_grey() {
        let grey = |l: f32| vec![l; 300];
        let a = auto_exposure(&grey(0.5));
        assert!((a.key - 0.5).abs() < 2e-4 && (a.stops - (0.18f32 / 0.5).log2()).abs() < 1e-3, "{a:?}");
        let b = auto_exposure(&grey(500.0));
        assert!((a.stops - b.stops - 1000f32.log2()).abs() < 1e-3, "{a:?} {b:?}");
        assert_eq!(auto_exposure(&grey(0.0)), AutoExposure { stops: 0.0, key: 0.0 });
        assert_eq!(auto_exposure(&[]), AutoExposure { stops: 0.0, key: 0.0 });
        let mut img = grey(2.0);
        img[0] = f32::NAN;
        img[4] = f32::INFINITY;
        let c = auto_exposure(&img);
        assert!((c.key - 2.0).abs() < 1e-3, "{c:?}");
        // the log average: half the pixels at 4, half at 1/4 → key 1
        let mixed: Vec<f32> = (0..600).map(|i| if i / 3 % 2 == 0 { 4.0 } else { 0.25 }).collect();
        assert!((auto_exposure(&mixed).key - 1.0).abs() < 1e-3);
    }
}
