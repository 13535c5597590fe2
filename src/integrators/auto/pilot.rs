//! The path tracer's part of `auto`'s pilot under `--time`: its first samples of the whole image
//! ([`PtSamples`]), which measure its variance per sample and its time per sample (or, at short
//! budgets, its first sample and a probe on a subset of the pixels) and are kept in the image
//! whichever method is chosen — the path tracer's render continues after them, and a
//! photon method's passes are blended with them by their predicted errors.

use crate::error::Result;
use crate::image::Film;
use crate::integrators::allocation::lum;
use crate::integrators::{pt, MethodSettings, Passes, RenderSettings, SilentProgress, Stats};
use crate::prepare::PreparedScene;
use std::time::Instant;

/// Sample indices a continued path tracer may reach ([`Passes::total`] of its sample range).
const MAX_SAMPLES: u32 = 1 << 20;

/// Path-traced samples of the whole image: their mean, how many, and the seed they continue with.
#[derive(Clone, Debug)]
pub struct PtSamples {
    pub film: Film,
    pub spp: u32,
    pub seed: u64,
    /// Per pixel, half the squared difference of the pilot's two samples' direct and indirect
    /// luminance (each an unbiased estimate of one path's variance there); `None` unless the pilot
    /// traced two samples of the whole image.
    pub pair: Option<Vec<[f32; 2]>>,
    /// Two independent groups of these samples ([`Groups`]); `None` unless the pilot traced two
    /// samples of the whole image.
    pub groups: Option<Groups>,
    /// The pilot's second sample, of another seed, while the path tracer's own sample 1 may
    /// still replace it ([`PtSamples::restore_sequence`]); `None` once replaced or dropped.
    pub second: Option<SecondSample>,
}

/// The pilot's second sample of the whole image and the seconds it took.
#[derive(Clone, Debug)]
pub struct SecondSample {
    pub film: Film,
    pub seconds: f64,
}

/// Per pixel, the indirect luminance of two independent groups of the path tracer's samples —
/// the pilot's first sample with the samples continued from its seed for a bias check, and its
/// second sample (another seed) with those continued from that seed — and their counts. A bias
/// measured against the two groups needs no model of their noise: samples of one scrambled
/// sequence are stratified, and their mean's variance is well below a path's over their count.
#[derive(Clone, Debug)]
pub struct Groups {
    pub indirect: Vec<[f32; 2]>,
    pub spp: [u32; 2],
}

/// What the pilot's path-traced samples measured (`None` fields: one sample only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PtFigures {
    /// Seconds of one sample per pixel of the image (the second sample's, less a render's fixed
    /// cost: the first fills the BSDF tables of the materials the paths meet).
    pub seconds_per_spp: f64,
    /// Variance of one path's luminance, mean over pixels, of its direct and indirect parts: half
    /// the squared difference of each pixel's two samples.
    pub variance: Option<[f64; 2]>,
    /// The same relative to each pixel's value ([`pt::pair_variances`]).
    pub relative_variance: Option<[f64; 2]>,
}

/// The settings of path-traced samples `first .. end` of the image, as a timed path tracer draws
/// them (`budget`: the wall-clock seconds it may run).
fn sample_range(base: &RenderSettings, seed: u64, first: u32, end: u32, budget: f64) -> RenderSettings {
    RenderSettings {
        method: MethodSettings::Pt,
        spp: 1,
        seed,
        time_budget: Some(budget.max(1e-3)),
        passes: Some(Passes { total: MAX_SAMPLES, first, end, fixed_bandwidth: false }),
        rival: None,
        crop: None,
        ..base.clone()
    }
}


/// The second sample of the whole image is traced when the first took at most this share of the
/// time budget; else the variance comes from [`pt::probe`]'s pairs of paths on a subset of the
/// pixels (about 0.3 samples per pixel at 200², 0.08 at 400², not kept). The pair of the whole
/// image is kept and measures every pixel: on Crytek Sponza at 400² the probe's 4096 pixels gave
/// the indirect light a variance of 2.05e-3 per sample against the whole image's 4.6e-3 (its
/// rare bright paths missed), which made a single photon pass's indirect error, measured against
/// the path tracer's samples less that variance, look larger than it was.
const SECOND_SAMPLE_SHARE: f64 = 0.3;

/// The least share of the second sample's time counted as its paths' (the rest being the render's
/// fixed cost), so that a noisy measurement of that cost never makes the path tracer look free.
const MIN_PATH_SHARE: f64 = 0.25;

/// Stream of the seed of the pilot's second sample.
const SECOND_STREAM: u64 = 0x7032_6e64; // "p2nd"

/// Seed of the pilot's second sample (its index 1 in that seed's sequence): independent of the
/// first's, so that the pair's difference measures a path's variance without stratification.
pub fn second_seed(seed: u64) -> u64 {
    crate::sampling::hash(&[seed, SECOND_STREAM])
}

/// Seconds of a path-traced render of no samples: what a render costs besides its samples (the
/// image's sums and films), paid once by the path tracer's continuation but in full by the pilot's
/// one-sample render.
fn fixed_seconds(scene: &PreparedScene, base: &RenderSettings) -> Result<f64> {
    let none = sample_range(base, base.seed, 1, 1, f64::MAX);
    let t = Instant::now();
    pt::render(scene, &none, &SilentProgress, &mut Stats::default())?;
    Ok(t.elapsed().as_secs_f64())
}

/// Trace the path tracer's sample 0 of the whole image and measure its variance (from sample 1 of
/// the whole image, or the probe's pairs on a subset: [`SECOND_SAMPLE_SHARE`]), unless the time
/// left after the first (`left` seconds from now, of a budget of `budget`) does not hold another
/// sample: kept as [`PtSamples`], measured as [`PtFigures`].
pub fn trace(scene: &PreparedScene, base: &RenderSettings, left: f64, budget: f64) -> Result<(PtSamples, PtFigures)> {
    let t = Instant::now();
    let mut stats = Stats::default();
    let a = pt::render(scene, &sample_range(base, base.seed, 0, 1, f64::MAX), &SilentProgress, &mut stats)?;
    let first = t.elapsed().as_secs_f64();
    let mut samples = PtSamples { film: a, spp: 1, seed: base.seed, pair: None, groups: None, second: None };
    if left - first < first {
        return Ok((samples, PtFigures { seconds_per_spp: first, variance: None, relative_variance: None }));
    }
    if first > SECOND_SAMPLE_SHARE * budget {
        // the probed pixels weigh by the first sample's block means, independent of the probe's paths
        let sample0 = parts(&samples.film);
        let values = block_means(&sample0.iter().map(|p| p[0] + p[1]).collect::<Vec<_>>(), samples.film.width as usize, samples.film.height as usize);
        let p = pt::probe(scene, base.seed, base.max_depth, Some(&values));
        return Ok((samples, PtFigures { seconds_per_spp: p.seconds_per_spp, variance: Some(p.variance), relative_variance: Some(p.relative_variance) }));
    }
    let t = Instant::now();
    // the second sample comes from another seed: two samples of one scrambled sequence are a
    // stratified pair, whose difference overstates a path's variance (1.7× on the Cornell box), and
    // the pair's variance is subtracted from the passes' measured error
    let b = pt::render(scene, &sample_range(base, second_seed(base.seed), 1, 2, f64::MAX), &SilentProgress, &mut stats)?;
    let second = t.elapsed().as_secs_f64();
    // the continuation pays the render's fixed cost once and the tiles' seeds once per chunk of
    // many samples, the one-sample render both in full
    let fixed = fixed_seconds(scene, base)? + pt::seeds_seconds(scene, base.seed);
    let seconds_per_spp = (second - fixed).max(MIN_PATH_SHARE * second);
    let (x, y) = (parts(&samples.film), parts(&b));
    let (w, h) = (samples.film.width as usize, samples.film.height as usize);
    let values = block_means(&x.iter().zip(&y).map(|(p, q)| 0.5 * (p[0] + p[1] + q[0] + q[1])).collect::<Vec<_>>(), w, h);
    let (variance, relative_variance) = pt::pair_variances(&x, &y, &values);
    samples.pair = Some(x.iter().zip(&y).map(|(p, q)| [(0.5 * (p[0] - q[0]).powi(2)) as f32, (0.5 * (p[1] - q[1]).powi(2)) as f32]).collect());
    samples.groups = Some(Groups { indirect: x.iter().zip(&y).map(|(p, q)| [p[1] as f32, q[1] as f32]).collect(), spp: [1, 1] });
    samples.add(&b, 1);
    samples.second = Some(SecondSample { film: b, seconds: second });
    Ok((samples, PtFigures { seconds_per_spp, variance: Some(variance), relative_variance: Some(relative_variance) }))
}

/// Each pixel's `[direct, indirect]` luminance of a film (zeros for a missing layer).
pub fn parts(film: &Film) -> Vec<[f64; 2]> {
    let n = film.width as usize * film.height as usize;
    let layer = |name: &str| film.layer(name).map(|l| l.data.chunks_exact(3).map(lum).collect::<Vec<_>>()).unwrap_or_else(|| vec![0.0; n]);
    let (d, i) = (layer("direct"), layer("indirect"));
    d.into_iter().zip(i).map(|(d, i)| [d, i]).collect()
}

impl PtSamples {
    /// A copy whose direct and indirect layers are scaled per pixel by `scale` (and the pair's
    /// variances by its square): the plain errors measured against it are weighted errors.
    pub fn weighted(&self, scale: &[f32]) -> PtSamples {
        let mut film = self.film.clone();
        for name in ["direct", "indirect"] {
            if let Some(l) = film.layer_mut(name) {
                for (c, &k) in l.data.chunks_exact_mut(3).zip(scale) {
                    c.iter_mut().for_each(|v| *v *= k);
                }
            }
        }
        let pair = self.pair.as_ref().map(|p| p.iter().zip(scale).map(|(v, &k)| [v[0] * k * k, v[1] * k * k]).collect());
        let groups = self.groups.as_ref().map(|g| Groups { indirect: g.indirect.iter().zip(scale).map(|(v, &k)| [v[0] * k, v[1] * k]).collect(), spp: g.spp });
        PtSamples { film, spp: self.spp, seed: self.seed, pair, groups, second: None }
    }

    /// Add `per_group` samples per pixel to each of the two [`Groups`] (from the seed each
    /// continues, at indices no other sample of these takes), for a finer bias check; returns the
    /// samples added (0 without the groups).
    pub fn add_to_groups(&mut self, scene: &PreparedScene, base: &RenderSettings, per_group: u32, stats: &mut Stats) -> Result<u32> {
        let Some(g) = self.groups.clone() else { return Ok(0) };
        // the first seed's samples continue at this render's count, which only grows; the second
        // seed's after its own (its sample 0 is never drawn: the pilot's is its sample 1)
        let first = sample_range(base, self.seed, self.spp, self.spp + per_group, f64::MAX);
        let second = sample_range(base, second_seed(self.seed), g.spp[1] + 1, g.spp[1] + 1 + per_group, f64::MAX);
        let t = Instant::now();
        let (a, b) = (pt::render(scene, &first, &SilentProgress, &mut Stats::default())?, pt::render(scene, &second, &SilentProgress, &mut Stats::default())?);
        stats.phase("path tracer", t.elapsed().as_secs_f64());
        let (x, y) = (parts(&a), parts(&b));
        let n = per_group as f32;
        let (w0, w1) = (g.spp[0] as f32, g.spp[1] as f32);
        let indirect = g.indirect.iter().zip(x.iter().zip(&y)).map(|(v, (p, q))| [(v[0] * w0 + p[1] as f32 * n) / (w0 + n), (v[1] * w1 + q[1] as f32 * n) / (w1 + n)]).collect();
        self.groups = Some(Groups { indirect, spp: [g.spp[0] + per_group, g.spp[1] + per_group] });
        self.add(&a, per_group);
        self.add(&b, per_group);
        Ok(2 * per_group)
    }

    /// One path's variance of the direct and indirect light, mean over pixels, from the pilot's
    /// pair (`None` without it).
    pub fn pair_variance(&self) -> Option<[f64; 2]> {
        let p = self.pair.as_ref()?;
        let n = p.len().max(1) as f64;
        Some(p.iter().fold([0.0; 2], |a, v| [a[0] + v[0] as f64 / n, a[1] + v[1] as f64 / n]))
    }

    /// Add `n` samples per pixel whose mean is `film` (the mean of all, weighted by counts; the
    /// depth keeps the nearest non-zero depth).
    pub fn add(&mut self, film: &Film, n: u32) {
        let (w0, w1) = (self.spp as f32, n as f32);
        let inv = 1.0 / (w0 + w1).max(1.0);
        for (a, b) in self.film.layers.iter_mut().zip(&film.layers) {
            if a.name == "depth" {
                for (x, &y) in a.data.iter_mut().zip(&b.data) {
                    if y > 0.0 && (*x == 0.0 || y < *x) {
                        *x = y;
                    }
                }
            } else {
                for (x, &y) in a.data.iter_mut().zip(&b.data) {
                    *x = (*x * w0 + y * w1) * inv;
                }
            }
        }
        self.spp += n;
    }

    /// Replace the pilot's second sample, of another seed, by the path tracer's own sample 1, when
    /// `left` seconds hold it and another sample: the samples are then the path tracer's `0 ..
    /// spp` of one scrambled sequence, as a path tracer alone draws them, and a render that ends as
    /// the path tracer is its image. Returns whether it replaced it; the second sample is dropped
    /// either way, and with it the pair and the groups it made.
    pub fn restore_sequence(&mut self, scene: &PreparedScene, base: &RenderSettings, left: f64, stats: &mut Stats) -> Result<bool> {
        let Some(second) = self.second.take() else { return Ok(false) };
        (self.pair, self.groups) = (None, None);
        if left < 2.0 * second.seconds || self.spp < 2 {
            return Ok(false);
        }
        let t = Instant::now();
        let own = pt::render(scene, &sample_range(base, self.seed, 1, 2, f64::MAX), &SilentProgress, &mut Stats::default())?;
        stats.phase("path tracer", t.elapsed().as_secs_f64());
        let inv = 1.0 / self.spp as f32;
        for ((a, b), c) in self.film.layers.iter_mut().zip(&own.layers).zip(&second.film.layers) {
            if a.name != "depth" {
                for ((x, &y), &z) in a.data.iter_mut().zip(&b.data).zip(&c.data) {
                    *x += (y - z) * inv;
                }
            }
        }
        Ok(true)
    }

    /// Continue the path tracer after these samples until `budget` seconds have passed (at least
    /// one more sample); returns the samples added.
    pub fn continue_for(&mut self, scene: &PreparedScene, base: &RenderSettings, budget: f64, stats: &mut Stats) -> Result<u32> {
        let s = sample_range(base, self.seed, self.spp, MAX_SAMPLES, budget);
        let mut more = Stats::default();
        let film = pt::render(scene, &s, &SilentProgress, &mut more)?;
        let n = more.counter("spp").unwrap_or(0) as u32;
        stats.phase("path tracer", more.phase_seconds("trace").unwrap_or(0.0));
        if n > 0 {
            self.add(&film, n);
        }
        Ok(n)
    }

    /// MSE (luminance, mean over pixels) of `rgb` (a layer's RGB triples) against these samples'
    /// `layer` (`None` without it): `E[(x − pt)²]`, whose expectation is `x`'s own MSE (bias and
    /// variance) plus the path tracer's variance over its samples, `x` being independent of them.
    pub fn difference(&self, rgb: &[f32], layer: &str) -> Option<f64> {
        let y = self.film.layer(layer)?;
        let n = (rgb.len() / 3).max(1) as f64;
        Some(rgb.chunks_exact(3).zip(y.data.chunks_exact(3)).map(|(p, q)| (lum(p) - lum(q)).powi(2)).sum::<f64>() / n)
    }

    /// Squared bias (luminance, mean over pixels) of two independent passes `first` and `second`
    /// (a layer's RGB triples over the whole image) against these samples' `layer`, from the
    /// differences of their means over blocks of [`BIAS_SIDE`]² pixels, with its standard error
    /// (from the spread of the blocks' terms). A density estimate's bias stays in a block's mean
    /// while the noise falls. With the two [`Groups`] (indirect light only), each block's term is
    /// the product of the first pass's difference to the first group and the second's to the
    /// second: all four independent, its expectation is the block's squared bias, with no noise to
    /// subtract. Else it is the squared difference of the passes' mean to the samples, less the
    /// passes' noise in it (a quarter of the squared difference of their own block means: a
    /// photon's kernel spans several pixels, so their noise is correlated) and the path tracer's
    /// (`noise`: its per-pixel variance of its mean over the block's size). `None` without the
    /// layer or when the sizes differ.
    pub fn smooth_bias2(&self, first: &[f32], second: &[f32], layer: &str, noise: f64) -> Option<BiasEstimate> {
        let y = self.film.layer(layer)?;
        let (w, h) = (self.film.width as usize, self.film.height as usize);
        if first.len() != w * h * 3 || second.len() != first.len() || y.data.len() != first.len() || w == 0 || h == 0 {
            return None;
        }
        let (a, b): (Vec<f64>, Vec<f64>) = (first.chunks_exact(3).map(lum).collect(), second.chunks_exact(3).map(lum).collect());
        let side = BIAS_SIDE.min(w).min(h);
        let blocks = |v: Vec<f64>| block_means_of(&v, w, h, side);
        let (terms, subtract): (Vec<f64>, f64) = match self.groups.as_ref().filter(|g| layer == "indirect" && g.indirect.len() == a.len()) {
            Some(g) => {
                let d1 = blocks(a.iter().zip(&g.indirect).map(|(p, q)| p - q[0] as f64).collect());
                let d2 = blocks(b.iter().zip(&g.indirect).map(|(p, q)| p - q[1] as f64).collect());
                (d1.iter().zip(&d2).map(|(x, y)| x * y).collect(), 0.0)
            }
            None => {
                let d = blocks(a.iter().zip(&b).zip(y.data.chunks_exact(3)).map(|((p, q), r)| 0.5 * (p + q) - lum(r)).collect());
                let q = blocks(a.iter().zip(&b).map(|(p, q)| p - q).collect());
                (d.iter().zip(&q).map(|(d, q)| d * d - q * q / 4.0).collect(), noise / (side * side) as f64)
            }
        };
        let n = terms.len().max(1) as f64;
        let mean = terms.iter().sum::<f64>() / n;
        let spread2 = terms.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
        Some(BiasEstimate { bias2: (mean - subtract).max(0.0), standard_error: (spread2 / n).sqrt() })
    }
}

/// A squared bias measured against path-traced samples ([`PtSamples::smooth_bias2`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasEstimate {
    /// The squared bias, mean over pixels (at least 0).
    pub bias2: f64,
    /// Its standard error (from the spread of the blocks' terms): while the path tracer's noise
    /// makes most of it, it falls as 1 / its samples per pixel.
    pub standard_error: f64,
}

/// The means of the whole blocks of `side`² pixels of `values` (`w` × `h`, row by row).
fn block_means_of(values: &[f64], w: usize, h: usize, side: usize) -> Vec<f64> {
    let (bw, bh) = (w / side, h / side);
    let mut out = Vec::with_capacity(bw * bh);
    for by in 0..bh {
        for bx in 0..bw {
            out.push((0..side).flat_map(|j| (0..side).map(move |i| (by * side + j) * w + bx * side + i)).map(|k| values[k]).sum::<f64>() / (side * side) as f64);
        }
    }
    out
}

/// Side in pixels of the blocks whose mean luminance sets a pixel's relative weight
/// ([`block_means`]).
pub const BIAS_BLOCK: usize = 8;

/// Side in pixels of the blocks [`PtSamples::smooth_bias2`] averages over: small, since much of
/// a density estimate's bias changes sign within a few pixels (light blurred across a silhouette
/// or a corner, too dark on one side and too bright on the other), and a wide block's mean cancels
/// it. On the shader ball at 200×200 after two passes the estimate is 2.9e-3 over 16×16 blocks,
/// 4.6e-3 over 8×8, 6.4e-3 over 4×4 and 7.7e-3 over 2×2.
pub const BIAS_SIDE: usize = 2;

/// Each pixel's value replaced by the mean of its block of [`BIAS_BLOCK`]² pixels (`w` × `h`
/// values, row by row): a smooth estimate of a noisy image's values, for weights.
pub fn block_means(values: &[f64], w: usize, h: usize) -> Vec<f64> {
    let mut out = values.to_vec();
    if values.len() != w * h {
        return out;
    }
    for by in (0..h).step_by(BIAS_BLOCK) {
        for bx in (0..w).step_by(BIAS_BLOCK) {
            let (ys, xs) = (by..(by + BIAS_BLOCK).min(h), bx..(bx + BIAS_BLOCK).min(w));
            let count = (ys.len() * xs.len()) as f64;
            let mean = ys.clone().flat_map(|j| xs.clone().map(move |i| j * w + i)).map(|k| values[k]).sum::<f64>() / count;
            for k in ys.flat_map(|j| xs.clone().map(move |i| j * w + i)) {
                out[k] = mean;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Layer;

    fn film(v: f32, depth: f32) -> Film {
        let mut f = Film::new(1, 1);
        f.layers.push(Layer { name: "direct".into(), channels: vec!["R".into(), "G".into(), "B".into()], data: vec![v; 3] });
        f.layers.push(Layer { name: "depth".into(), channels: vec!["Z".into()], data: vec![depth] });
        f
    }

    /// Samples added are weighted by their counts: the mean of 3 samples of 1 and 1 sample of 5
    /// is 2; the depth keeps the nearest.
    #[test]
    fn added_samples_weigh_by_their_count() {
        let mut s = PtSamples { film: film(1.0, 4.0), spp: 3, seed: 0, pair: None, groups: None, second: None };
        s.add(&film(5.0, 2.0), 1);
        assert_eq!(s.spp, 4);
        assert_eq!(s.film.layer("direct").unwrap().data, vec![2.0; 3]);
        assert_eq!(s.film.layer("depth").unwrap().data, vec![2.0]);
        assert!((s.difference(&[4.0; 3], "direct").unwrap() - 4.0).abs() < 1e-5);
    }

    /// Two paths per pixel: a light's edge (direct 0 and 100) and 99 dim pixels of indirect light
    /// (0.1 ± 0.05). The plain variance is the edge's, the relative one the dim pixels': each
    /// pixel's divided by its value squared plus 0.01, as a relative MSE weighs it.
    #[test]
    fn relative_pair_variance_weighs_pixels_by_their_value() {
        let mut a = vec![[0.0, 0.0]];
        let mut b = vec![[100.0, 0.0]];
        for _ in 0..99 {
            a.push([0.0, 0.05]);
            b.push([0.0, 0.15]);
        }
        let values: Vec<f64> = a.iter().zip(&b).map(|(x, y)| 0.5 * (x[0] + x[1] + y[0] + y[1])).collect();
        let (plain, relative) = pt::pair_variances(&a, &b, &values);
        assert!((plain[0] - 5000.0 / 100.0).abs() < 1e-9 && (plain[1] - 0.99 * 0.005).abs() < 1e-9, "{plain:?}");
        let want = [5000.0 / (2500.0 + 0.01) / 100.0, 0.99 * 0.005 / (0.01 + 0.01)];
        assert!((relative[0] / want[0] - 1.0).abs() < 1e-9 && (relative[1] / want[1] - 1.0).abs() < 1e-9, "{relative:?} against {want:?}");
        assert!(plain[0] > 1000.0 * plain[1] && relative[1] > 10.0 * relative[0]);
    }

    /// Two passes with `bias(i, j)` and noise of variance `v_pass` shared by each 2×2 block (a
    /// kernel's footprint: correlated from pixel to pixel), and path-traced samples in two groups
    /// with noise of variance `v_pt` per pixel each, over `w` × `w` pixels of a varying truth: the
    /// squared bias estimated against them, through the groups or, without them, by subtracting
    /// the noise of their mean.
    fn estimate(w: usize, seed: u64, v_pass: f64, v_pt: f64, groups: bool, bias: impl Fn(usize, usize) -> f32) -> BiasEstimate {
        use crate::sampling::Rng;
        let mut rng = Rng::new(seed, 0);
        let mut uniform = |var: f64| ((rng.next_f32() as f64 - 0.5) * (12.0 * var).sqrt()) as f32;
        let shared: Vec<[f32; 2]> = (0..(w / 2) * (w / 2)).map(|_| [uniform(v_pass), uniform(v_pass)]).collect();
        let (mut first, mut second, mut pt, mut two) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for j in 0..w {
            for i in 0..w {
                let truth = 0.5 + 0.1 * ((i * 3 + j) % 5) as f32;
                let [a, b] = shared[(j / 2) * (w / 2) + i / 2];
                first.extend([truth + bias(i, j) + a; 3]);
                second.extend([truth + bias(i, j) + b; 3]);
                let g = [truth + uniform(v_pt), truth + uniform(v_pt)];
                pt.extend([0.5 * (g[0] + g[1]); 3]);
                two.push(g);
            }
        }
        let mut f = Film::new(w as u32, w as u32);
        f.layers.push(Layer { name: "indirect".into(), channels: vec!["R".into(), "G".into(), "B".into()], data: pt });
        let groups = groups.then(|| Groups { indirect: two, spp: [1, 1] });
        let s = PtSamples { film: f, spp: 2, seed: 0, pair: None, groups, second: None };
        s.smooth_bias2(&first, &second, "indirect", v_pt / 2.0).unwrap()
    }

    /// A smooth bias under the path tracer's noise 33 times its square and the passes' noise,
    /// correlated over each 2×2 block, 13 times it: recovered from the block means less both
    /// noises (the passes' a pixel's variance over the block's size would count a quarter of it);
    /// without bias the estimate stays within its standard errors of zero.
    #[test]
    fn block_means_recover_a_smooth_bias_under_heavy_noise() {
        let (w, v_pt, v_pass) = (256usize, 0.01, 0.002);
        let smooth = |i: usize, _: usize| 0.01 * (1.0 + (i as f32 / w as f32 * 6.0).sin());
        let bias2 = (0..w).map(|i| (smooth(i, 0) as f64).powi(2)).sum::<f64>() / w as f64;
        for groups in [false, true] {
            let got = estimate(w, 5, v_pass, v_pt, groups, smooth);
            assert!((got.bias2 - bias2).abs() < 3.0 * got.standard_error && got.standard_error < 0.35 * bias2, "groups {groups}: bias² {bias2}, estimated {got:?}");
            let none = estimate(w, 6, v_pass, v_pt, groups, |_, _| 0.0);
            assert!(none.bias2 < 3.0 * none.standard_error && none.standard_error < 0.3 * bias2, "groups {groups}: no bias, estimated {none:?}");
        }
    }

    /// A bias that changes sign every 4 pixels (light blurred across edges: too bright on one side,
    /// too dark on the other) under the path tracer's noise 6 times its square: the small blocks
    /// keep it, where blocks of 8×8 pixels would average it to nothing.
    #[test]
    fn a_bias_that_changes_sign_within_a_few_pixels_is_measured() {
        let amplitude = 0.03f32;
        let bias2 = (amplitude * amplitude) as f64;
        for groups in [false, true] {
            let got = estimate(256, 9, 0.001, 0.01, groups, |i, _| if (i / 4) % 2 == 0 { amplitude } else { -amplitude });
            assert!((got.bias2 / bias2 - 1.0).abs() < 0.15, "groups {groups}: bias² {bias2}, estimated {got:?}");
        }
    }

    /// The estimate's standard error is its spread: over 40 independent images of a uniform bias
    /// the estimates' standard deviation is within 30 % of the mean standard error, and it falls
    /// as the path tracer's variance does (the measure the path tracer is continued by before the
    /// bias decides).
    #[test]
    fn the_bias_estimates_standard_error_is_its_spread() {
        let amplitude = 0.03f32;
        let run = |v_pt: f64, groups: bool| {
            let e: Vec<BiasEstimate> = (0..40).map(|k| estimate(128, 100 + k, 0.0005, v_pt, groups, |_, _| amplitude)).collect();
            let mean = e.iter().map(|x| x.bias2).sum::<f64>() / e.len() as f64;
            let sd = (e.iter().map(|x| (x.bias2 - mean).powi(2)).sum::<f64>() / (e.len() - 1) as f64).sqrt();
            let se = e.iter().map(|x| x.standard_error).sum::<f64>() / e.len() as f64;
            (mean, sd, se)
        };
        for groups in [false, true] {
            let (noisy, quiet) = (run(0.02, groups), run(0.002, groups));
            for (mean, sd, se) in [noisy, quiet] {
                assert!((sd / se - 1.0).abs() < 0.3, "groups {groups}: spread {sd} against standard error {se} (mean {mean})");
            }
            // (as 1 / spp while the noise squared dominates it, more slowly where the bias times
            // the noise does: here it is bias² = 9e-4 against a block noise of 2.5e-3 and 2.5e-4)
            assert!(noisy.2 > 3.0 * quiet.2, "groups {groups}: standard errors {} and {} for ten times the noise", noisy.2, quiet.2);
        }
    }

    /// A pass of known bias (varying over the image) and variance against path-traced samples of
    /// known variance: their mean squared difference less the path tracer's variance recovers the
    /// pass's MSE, its squared bias included.
    #[test]
    fn the_difference_to_the_path_tracer_measures_a_pass_error_bias_included() {
        use crate::sampling::Rng;
        let mut rng = Rng::new(13, 0);
        let mut noise = |var: f64| ((rng.next_f32() as f64 - 0.5) * (12.0 * var).sqrt()) as f32;
        let (n, v_pass, v_pt, spp) = (300_000, 0.01, 0.2, 4u32);
        let (mut pass, mut pt, mut bias2) = (Vec::new(), Vec::new(), 0.0);
        for i in 0..n {
            let truth = 1.0 + (i % 29) as f32 * 0.05;
            let bias = 0.2 * ((i % 7) as f32 / 6.0 - 0.3);
            bias2 += (bias as f64).powi(2);
            pass.extend([truth + bias + noise(v_pass); 3]);
            pt.extend([truth + noise(v_pt / spp as f64); 3]);
        }
        let mut film = Film::new(n as u32, 1);
        film.layers.push(Layer { name: "indirect".into(), channels: vec!["R".into(), "G".into(), "B".into()], data: pt });
        let samples = PtSamples { film, spp, seed: 0, pair: None, groups: None, second: None };
        let measured = samples.difference(&pass, "indirect").unwrap() - v_pt / spp as f64;
        let want = bias2 / n as f64 + v_pass;
        assert!((measured / want - 1.0).abs() < 0.05, "measured {measured}, want {want}");
    }

    /// The repository's Cornell box at 16×16 pixels.
    fn cornell_box() -> PreparedScene {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.usda"));
        PreparedScene::new(crate::usd::load_scene(path).expect("scene"), 16, 16, 1).expect("prepare")
    }

    /// The path tracer's samples `first .. end` of `seed`, untimed.
    fn rendered(scene: &PreparedScene, base: &RenderSettings, seed: u64, first: u32, end: u32) -> Film {
        pt::render(scene, &sample_range(base, seed, first, end, f64::MAX), &SilentProgress, &mut Stats::default()).unwrap()
    }

    /// The pilot's two samples and the samples continued after them are the path tracer's
    /// samples 0, 2, 3, … with sample 1 from the second seed: their mean is the untimed path
    /// tracer's image of as many samples with its sample 1 swapped for the second seed's.
    #[test]
    fn continued_samples_are_the_path_tracers() {
        let scene = cornell_box();
        let base = RenderSettings { seed: 5, threads: 1, ..Default::default() };
        let (mut samples, figures) = trace(&scene, &base, 1e9, 1e9).unwrap();
        assert_eq!(samples.spp, 2);
        let [vd, vi] = figures.variance.expect("two samples");
        assert!(vd > 0.0 && vi > 0.0, "{vd} {vi}");
        // one more sample at least; then the same count untimed
        let mut stats = Stats::default();
        samples.continue_for(&scene, &base, 1e-3, &mut stats).unwrap();
        let n = samples.spp;
        assert!(n >= 3);
        let range = |seed: u64, first: u32, end: u32| rendered(&scene, &base, seed, first, end).layer("").unwrap().data.clone();
        let (whole, own1, second1) = (range(base.seed, 0, n), range(base.seed, 1, 2), range(second_seed(base.seed), 1, 2));
        let expected: Vec<f32> = whole.iter().zip(&own1).zip(&second1).map(|((w, a), b)| (w * n as f32 - a + b) / n as f32).collect();
        let got = &samples.film.layer("").unwrap().data;
        let worst = got.iter().zip(&expected).map(|(x, y)| (x - y).abs() / y.abs().max(1e-3)).fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "largest relative difference {worst}");
    }

    /// A render that ends as the path tracer replaces the pilot's second sample by its own sample
    /// 1: its image is then the untimed path tracer's of as many samples, to rounding.
    #[test]
    fn a_restored_sequence_is_the_path_tracers_image() {
        let scene = cornell_box();
        let base = RenderSettings { seed: 3, threads: 1, ..Default::default() };
        let (mut samples, _) = trace(&scene, &base, 1e9, 1e9).unwrap();
        let mut stats = Stats::default();
        assert!(samples.restore_sequence(&scene, &base, 1e9, &mut stats).unwrap());
        assert!(samples.second.is_none() && samples.pair.is_none() && samples.groups.is_none());
        samples.continue_for(&scene, &base, 1e-3, &mut stats).unwrap();
        let n = samples.spp;
        let whole = rendered(&scene, &base, base.seed, 0, n);
        for name in ["", "direct", "indirect", "albedo"] {
            let (got, want) = (&samples.film.layer(name).unwrap().data, &whole.layer(name).unwrap().data);
            let worst = got.iter().zip(want).map(|(x, y)| (x - y).abs() / y.abs().max(1e-3)).fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "layer {name:?}: largest relative difference {worst} over {n} samples");
        }
        // with too little time left for the sample and another, the pilot's samples stay as they are
        let (mut short, _) = trace(&scene, &base, 1e9, 1e9).unwrap();
        let before = short.film.layer("").unwrap().data.clone();
        assert!(!short.restore_sequence(&scene, &base, 0.0, &mut stats).unwrap());
        assert!(short.second.is_none() && short.film.layer("").unwrap().data == before);
    }

    /// The two groups of a bias check are the first seed's samples 0, 2, 3 and the second seed's
    /// 1, 2, 3 (no sample drawn twice, the groups independent), and the samples' mean is theirs.
    #[test]
    fn a_bias_checks_groups_are_the_two_seeds_samples() {
        let scene = cornell_box();
        let base = RenderSettings { seed: 7, threads: 1, ..Default::default() };
        let (mut samples, _) = trace(&scene, &base, 1e9, 1e9).unwrap();
        assert_eq!(samples.add_to_groups(&scene, &base, 2, &mut Stats::default()).unwrap(), 4);
        let groups = samples.groups.clone().expect("groups");
        assert_eq!((samples.spp, groups.spp), (6, [3, 3]));
        let range = |seed: u64, first: u32, end: u32| rendered(&scene, &base, seed, first, end);
        let indirect = |f: &Film| parts(f).iter().map(|p| p[1]).collect::<Vec<f64>>();
        let (a0, a1, b0, b1) = (indirect(&range(7, 0, 1)), indirect(&range(7, 2, 4)), indirect(&range(second_seed(7), 1, 2)), indirect(&range(second_seed(7), 2, 4)));
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-4 * y.abs().max(1e-3);
        for k in 0..a0.len() {
            let (want0, want1) = ((a0[k] + 2.0 * a1[k]) / 3.0, (b0[k] + 2.0 * b1[k]) / 3.0);
            assert!(close(groups.indirect[k][0] as f64, want0) && close(groups.indirect[k][1] as f64, want1), "pixel {k}: {:?} against {want0}, {want1}", groups.indirect[k]);
        }
        let mean = indirect(&samples.film);
        assert!(mean.iter().zip(&groups.indirect).all(|(m, g)| close(*m, 0.5 * (g[0] + g[1]) as f64)), "the mean is the groups'");
    }
}
