//! Photon methods in independent passes — new eye samples and new photons, each pass seeded by
//! `hash(seed, pass)` — averaged: under a wall-clock budget (`--time`, [`render`]), with direct-only
//! camera samples (more direct light and anti-aliasing, no photons) blended into their direct light,
//! later passes' bandwidth, and (when `auto` gave the path tracer's figures) the path tracer for the
//! time left, blended, in the split of the time the first passes' figures predict to have the lowest
//! error ([`super::allocation`]; at least one pass; another starts only if the pass time says it
//! will end within the budget), or a given run of progressive passes (`--passes`, [`progressive`]).
//!
//! Averaging passes lowers the noise of everything a pass estimates (anti-aliasing, the direct light
//! of the eye pass, the photon noise of the density estimates) as 1/passes; it does not lower the
//! bias of the density estimation, which is set by the bandwidth (`--photons`, `--knn`, `-C`, …) of
//! each pass. The image depends on the number of passes, which depends on the machine: for a
//! reproducible image give `--spp`/`--photons` instead of `--time`.

//! Progressive passes follow probabilistic progressive photon mapping (Knaus & Zwicker 2011): pass
//! `k` (from 0) is an independent render whose kernel's squared radius is the first pass's times
//! `∏_{j=1..k} (j + α) / (j + 1)` ([`radius2_ratio`]), which falls as `k^(α−1)`; with α = 2/3 the
//! average of the passes converges to the unbiased image as both its variance and bias vanish.
//! The radius shrinks through the splat bandwidth (smoothness C, maximum bandwidth R and the
//! caustic photons' neighbour radius, times the ratio's square root) and, for photon maps, the neighbour count (times the ratio, at least 1:
//! a kNN radius² goes as k over the photon density). Each pass depends only on (seed, k).

use super::allocation::{self, next_step, Done, Figures, Step};
use super::blend;
use super::regression;
use super::auto::{block_means, parts, BiasEstimate, PtSamples, BIAS_SIDE};
use super::{compose, pt, MethodSettings, Passes, Progress, RenderSettings, Stats};
use crate::error::{Error, Result};
use crate::image::Film;
use crate::prepare::PreparedScene;
use crate::sampling::hash;
use std::time::Instant;

/// Stream tag of the per-pass seeds.
const PASS_STREAM: u64 = 0x7061_7373; // "pass"

/// Seed of pass `k` (pass 0 keeps the user's seed: a one-pass render equals the untimed render).
pub fn pass_seed(seed: u64, k: u32) -> u64 {
    if k == 0 {
        seed
    } else {
        hash(&[seed, PASS_STREAM, k as u64])
    }
}

type PassFn<'a> = dyn Fn(&PreparedScene, &RenderSettings, &dyn Progress, &mut Stats) -> Result<Film> + 'a;

/// Stream tag of the direct-only samples' seeds.
const DIRECT_STREAM: u64 = 0x6472_6374; // "drct"
/// Stream tag of the seed of the path tracer a timed render hands its time left to.
const RIVAL_STREAM: u64 = 0x7276_6c70; // "rvlp"

/// Render passes of `one` until `budget` seconds (counted from `start`) are spent, the time after
/// the first passes split between photon passes (their bandwidth too), direct-only camera samples
/// and, with `s.rival`, the path tracer, by what those passes measured ([`allocation`]).
pub fn render(
    scene: &PreparedScene,
    s: &RenderSettings,
    budget: f64,
    start: Instant,
    progress: &dyn Progress,
    stats: &mut Stats,
    one: &PassFn<'_>,
    pilot: Option<PtSamples>,
) -> Result<Film> {
    let single = RenderSettings { time_budget: None, rival: None, ..s.clone() };
    // the path tracer's samples to blend with the passes: the pilot's, then any continued after them
    let mut pt_samples = pilot.filter(|_| s.rival.is_some());
    let t = Instant::now();
    let mut sum = one(scene, &single, progress, stats)?;
    let first_seconds = t.elapsed().as_secs_f64();
    let pass = s.method.photon_pass();
    let camera_samples = pass.map_or(s.spp, |p| p.aa_spp.max(s.spp)).max(1);
    let light_samples = pass.map_or(0, |p| if p.direct_photons { 0 } else { p.light_samples });
    let eye_seconds = stats.phases.iter().find(|(n, _)| n == "eye").map_or(0.0, |p| p.1);
    // With the pilot's pair of the whole image, every figure weighs a pixel by its value, as a
    // relative error does (a light in view would otherwise make the plain errors): the passes', by
    // scaled copies of their layers, and the path tracer's, by a scaled copy of its samples.
    let scale = match (&pt_samples, &s.rival) {
        (Some(pt), Some(_)) if pt.pair.is_some() => Some(relative_scale(&sum)),
        _ => None,
    };
    let weigh = |rgb: &[f32]| -> Vec<f32> {
        match &scale {
            Some(k) => rgb.chunks_exact(3).zip(k).flat_map(|(c, &k)| [c[0] * k, c[1] * k, c[2] * k]).collect(),
            None => rgb.to_vec(),
        }
    };
    let mut measured_pt = pt_samples.as_ref().map(|pt| scale.as_deref().map_or_else(|| pt.clone(), |k| pt.weighted(k)));
    let rival = s.rival.map(|r| allocation::Rival { variance: measured_pt.as_ref().filter(|_| scale.is_some()).and_then(PtSamples::pair_variance).unwrap_or(r.variance), corrects: scale.is_some(), ..r });
    // one camera sample per pixel has no spread to measure the direct light's variance by: it is
    // measured against the path tracer's samples as a single pass's indirect light is (below)
    let direct_by_pt = match (&measured_pt, &rival, light_samples, camera_samples) {
        // nor can one path-traced sample without a pair (as a single pass's indirect light,
        // below): a camera sample resolves the direct light as a path does
        (Some(pt), Some(rival), 1.., 1) if pt.pair.is_none() => Some(rival.variance[0]),
        (Some(pt), Some(rival), 1.., 1) => {
            sum.layer("direct").and_then(|l| pt.difference(&weigh(&l.data), "direct")).map(|e| (e - rival.variance[0] / pt.spp.max(1) as f64).max(f64::MIN_POSITIVE))
        }
        _ => None,
    };
    let mut figures = Figures {
        pass_fixed: (first_seconds - eye_seconds).max(0.0),
        per_camera_sample: eye_seconds / camera_samples as f64,
        pass_camera_samples: camera_samples,
        per_direct_sample: eye_seconds / camera_samples as f64,
        direct_variance: direct_by_pt.unwrap_or_else(|| direct_variance(&sum, camera_samples, light_samples, scale.as_deref())),
        indirect_variance: None,
        bias2: None,
        bias_of_every_part: false,
    };
    // the indirect layers of the first two passes, which measure the variance and the bias
    let mut firsts: Vec<Vec<f32>> = sum.layer("indirect").map(|l| weigh(&l.data)).into_iter().collect();
    let mut done = Done::at_first_bandwidth(1, 0);
    // what the pilot's path-traced samples measured of the passes, for the summary
    let mut measured_by_pt = String::new();
    // direct-only camera samples' direct light, summed times their count
    let mut extra_direct = Vec::<f32>::new();
    let mut continued = false;
    // whether the indirect figure is one pass's whole error (bias included), measured against the
    // path tracer's samples, rather than a variance
    let mut error_by_pt = false;
    loop {
        let left = budget - start.elapsed().as_secs_f64();
        // After one pass its indirect light's error, bias included, is measured against the path
        // tracer's samples. It is the figure when two more passes do not fit; and when even as pure
        // variance (averaged away by the passes to come) it loses to the path tracer, the time left
        // goes to the path tracer now rather than to a second pass that would only measure the bias.
        if let (None, 1, Some(pt), Some(rival)) = (figures.indirect_variance, done.passes, &measured_pt, &rival) {
            if let Some(e) = firsts.first().and_then(|ind| pt.difference(ind, "indirect")) {
                let optimistic = Figures { indirect_variance: Some((e - rival.variance[1] / pt.spp.max(1) as f64).max(0.0)), bias2: Some(0.0), bias_of_every_part: true, ..figures };
                if left < 2.0 * figures.pass_seconds() && pt.pair.is_none() {
                    // one path-traced sample per pixel, its variance known only from the probe's
                    // few thousand pixels (which miss its rare bright paths), is far noisier than
                    // the pass's indirect light: the difference cannot measure the pass's error
                    figures = Figures { indirect_variance: Some(0.0), bias2: Some(0.0), bias_of_every_part: false, ..figures };
                    measured_by_pt = ", the pass's indirect light taken whole (the pilot's one path-traced sample per pixel, without a pair to measure its variance by, cannot measure its error)".into();
                } else if left < 2.0 * figures.pass_seconds() {
                    figures = Figures { bias_of_every_part: false, ..optimistic };
                    error_by_pt = true;
                    measured_by_pt = ", the pass's indirect error measured against the path tracer's samples".into();
                } else if figures.direct_variance > 0.0 && next_step(&optimistic, Some(rival), &done, left) == Step::PathTracer {
                    figures = optimistic;
                    error_by_pt = true;
                    measured_by_pt = ", the first pass's indirect error measured against the path tracer's samples (bias included): averaged passes would not beat the path tracer even without bias".into();
                }
            }
        }
        let step = if figures.direct_variance > 0.0 {
            next_step(&figures, rival.as_ref(), &done, left)
        } else if left >= figures.pass_seconds() {
            Step::PhotonPass(1.0)
        } else {
            Step::Stop
        };
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        match step {
            Step::Stop => break,
            Step::PhotonPass(ratio) if done.passes < u32::MAX => {
                let mut pass_stats = Stats::default();
                let si = RenderSettings { seed: pass_seed(s.seed, done.passes), method: shrink(&s.method, ratio), ..single.clone() };
                let film = one(scene, &si, progress, &mut pass_stats)?;
                if let Some(l) = film.layer("indirect").map(|l| weigh(&l.data)) {
                    match firsts.len() {
                        1 if ratio == 1.0 => {
                            let v = allocation::variance_of_pair(&firsts[0], &l);
                            figures.indirect_variance = Some(v);
                            error_by_pt = false;
                            // with the pilot's path-traced samples the two passes' mean shows the
                            // bias of every part of the estimate (a radiance cache's too, which a
                            // narrower kernel would not reveal)
                            if let (Some(rival), Some(pt), Some(measured)) = (&rival, pt_samples.as_mut(), measured_pt.as_mut()) {
                                let measure = |pt: &PtSamples| pt.smooth_bias2(&firsts[0], &l, "indirect", rival.variance[1] / pt.spp.max(1) as f64);
                                let room = (BIAS_CHECK_SHARE * (budget - start.elapsed().as_secs_f64()) / rival.seconds_per_spp / 2.0).floor() as u32;
                                let decisive = |bias2: f64| decisive_error(&figures, rival, &done.then(1, 1.0, 0), budget - start.elapsed().as_secs_f64(), bias2);
                                let (estimate, check) = check_bias(scene, &single, pt, measured, scale.as_deref(), measure, decisive, room, stats)?;
                                if let Some(e) = estimate {
                                    figures.bias2 = Some(e.bias2);
                                    figures.bias_of_every_part = true;
                                    measured_by_pt = format!(", the passes' bias measured against the path tracer's samples over {BIAS_SIDE}x{BIAS_SIDE}-pixel blocks{check}");
                                }
                            }
                            firsts.push(l);
                        }
                        2 if figures.bias2.is_none() && ratio < 1.0 => {
                            let (v, b2) = allocation::variance_and_bias(&firsts[0], &firsts[1], &l, ratio);
                            figures.indirect_variance = Some(v);
                            figures.bias2 = Some(b2);
                        }
                        _ => {}
                    }
                }
                accumulate(&mut sum, &film);
                merge(stats, &pass_stats);
                done = done.then(1, ratio, 0);
            }
            Step::PhotonPass(_) => break,
            Step::DirectSamples(n) => {
                let t = Instant::now();
                let d = compose::direct_only(scene, n, hash(&[s.seed, DIRECT_STREAM, done.extra]), light_samples, s.filter)?;
                let seconds = t.elapsed().as_secs_f64();
                merge(stats, &Stats { phases: vec![("direct-only samples".into(), seconds)], ..Default::default() });
                figures.per_direct_sample = seconds / n as f64;
                extra_direct.resize(d.len() * 3, 0.0);
                for (x, v) in extra_direct.chunks_exact_mut(3).zip(&d) {
                    for c in 0..3 {
                        x[c] += v[c] * n as f32;
                    }
                }
                done.extra += n as u64;
            }
            Step::PathTracer => {
                let rival = s.rival.expect("the path tracer is a step only with its figures");
                // the path tracer stops after the sample that crosses its budget
                let budget = (left - 0.5 * rival.seconds_per_spp).max(1e-3);
                match pt_samples.as_mut() {
                    Some(pt) => {
                        pt.continue_for(scene, &single, budget, stats)?;
                    }
                    None => {
                        let pt = RenderSettings { method: MethodSettings::Pt, spp: 1 << 24, time_budget: Some(budget), seed: hash(&[s.seed, RIVAL_STREAM]), ..single.clone() };
                        let mut pt_stats = Stats::default();
                        let film = one(scene, &pt, progress, &mut pt_stats)?;
                        let spp = pt_stats.counters.iter().find(|(n, _)| n == "spp").map_or(0, |c| c.1) as u32;
                        stats.phase("path tracer", pt_stats.phase_seconds("trace").unwrap_or(0.0));
                        pt_samples = Some(PtSamples { film, spp, seed: pt.seed, pair: None, groups: None, second: None });
                    }
                }
                continued = true;
                break;
            }
        }
    }
    let passes = done.passes;
    finish(&mut sum, passes);
    if done.extra > 0 {
        blend_direct(&mut sum, &extra_direct, passes as u64 * camera_samples as u64, done.extra);
    }
    stats.count("passes", passes as u64);
    stats.count("direct_only_camera_samples", done.extra);
    let measured = match (figures.direct_variance > 0.0, figures.indirect_variance) {
        (false, _) => "no direct light sampled by camera samples: photon passes only".to_string(),
        (true, None) => "one photon pass; the time left for another went to direct-only camera samples".to_string(),
        (true, Some(vi)) => format!(
            "measured{} variance of the direct light {:.3e} per camera sample, {}; predicted MSE {:.3e}",
            if scale.is_some() { " (relative to each pixel's value)" } else { "" },
            figures.direct_variance,
            if error_by_pt {
                format!("the indirect light's error {vi:.3e} (bias included)")
            } else {
                format!("of the indirect light {vi:.3e} per pass, its squared bias {}", figures.bias2.map_or("not measured".to_string(), |b| format!("{b:.3e}")))
            },
            figures.predicted_after(&done).unwrap_or(f64::NAN)
        ),
    };
    let narrower = if done.bias_sum < passes as f64 { format!(" (kernels' squared radius {:.2} of the first pass's on average)", done.bias_sum / passes as f64) } else { String::new() };
    let mut line = format!(
        "time allotted: {passes} photon passes of {camera_samples} camera spp ({:.2} s + {:.2} s of camera samples each){narrower}, {} direct-only camera spp ({measured})",
        figures.pass_fixed,
        figures.per_camera_sample * camera_samples as f64,
        done.extra,
    );
    if let (Some(pt), Some(rival)) = (pt_samples, rival) {
        let [d, i] = figures.parts(&done).unwrap_or([f64::INFINITY; 2]);
        let spp = pt.spp;
        let n = spp.max(1) as f64;
        let (pd, pi) = (rival.variance[0] / n, rival.variance[1] / n);
        let direct_weight = allocation::blend_weight(d, pd);
        // one weight for the indirect light from the plan's figures (the fallback, and the figure
        // the summary compares with)
        let wi = allocation::blend_weight(i, pi);
        let (width, height) = (sum.width as usize, sum.height as usize);
        let pixels = width * height;
        let (indirect, indirect_error, how_indirect) = indirect_blend(&mut sum, &pt, scale.as_deref(), (wi, allocation::blended(i, pi)));
        // the direct light per pixel, by the variances of both around it, when the passes' camera
        // samples measured theirs (two or more per pixel, each sampling the lights)
        let passes_variance = sum.layer(compose::DIRECT_VARIANCE_LAYER).filter(|_| light_samples > 0 && camera_samples > 1).map(|l| {
            // the layer holds a pass's variance of its mean of `camera_samples` (mean over the
            // passes); the direct-only samples are the same estimator, one camera sample each
            let per_sample = camera_samples as f32 / (passes as u64 * camera_samples as u64 + done.extra) as f32;
            l.data.iter().map(|&v| v * per_sample).collect::<Vec<f32>>()
        });
        let direct = match (passes_variance, pt.film.layer(pt::DIRECT_MOMENTS_LAYER)) {
            (Some(a), Some(m)) => blend::direct_weights(&a, &m.data, spp, width, height, direct_weight),
            _ => None,
        };
        let how_direct = match &direct {
            Some(w) => format!("the passes' direct light at a weight per pixel from both variances over the {0}x{0} pixels around it (mean {1:.2}; one weight for the image would be {direct_weight:.2})", 2 * blend::DIRECT_WINDOW_RADIUS + 1, w.iter().map(|&x| x as f64).sum::<f64>() / w.len().max(1) as f64),
            None => format!("the passes' direct light at weight {direct_weight:.2}"),
        };
        let direct = direct.unwrap_or_else(|| vec![direct_weight as f32; pixels]);
        blend::blend_rival(&mut sum, &pt.film, &direct, &indirect);
        stats.count("path_tracer_spp", spp as u64);
        let how = if continued { "then the path tracer for the time left, predicted to lower the error more than more passes" } else { "the pilot's path-traced samples" };
        let by_pt = &measured_by_pt;
        line += &format!(
            "; {how} ({spp} spp in all){by_pt}: blended with {how_direct} and {how_indirect} (predicted MSE {:.3e})",
            allocation::blended(d, pd) + indirect_error
        );
    }
    stats.note(line);
    Ok(sum)
}

/// How the passes' indirect light in `sum` meets the path tracer's samples `pt`: with the pilot's
/// pair (a variance per pixel) and enough samples, corrected by a regression on them (`sum`'s
/// layer replaced, the passes' weight 1 everywhere); with fewer, a weight per pixel from the errors
/// measured around it; else `one`, the plan's weight for the image and its predicted error. The
/// passes' weights per pixel, the predicted error and the summary's words.
fn indirect_blend(sum: &mut Film, pt: &PtSamples, scale: Option<&[f32]>, one: (f64, f64)) -> (Vec<f32>, f64, String) {
    let (width, height) = (sum.width as usize, sum.height as usize);
    let one_weight = || (vec![one.0 as f32; width * height], one.1, format!("indirect light at {:.2}", one.0));
    let (ours, theirs) = (sum.layer("indirect"), pt.film.layer("indirect"));
    let (Some(pair), Some(k), Some(ours), Some(theirs)) = (&pt.pair, scale, ours, theirs) else {
        return one_weight();
    };
    let variance: Vec<f32> = pair.iter().map(|p| p[1]).collect();
    if let Some((light, error)) = regression::correct(&ours.data, &theirs.data, &variance, pt.spp, k, width, height) {
        let how = format!("indirect light from the passes', corrected by a local linear regression of the path-traced samples on them over {0}x{0}-pixel windows", 2 * regression::RADIUS + 1);
        // what the correction leaves of the passes' bias, measured against the samples
        let check = pt.film.layer(pt::INDIRECT_MOMENTS_LAYER).and_then(|m| regression::against_samples(&light, &theirs.data, &m.data, pt.spp, k, width, height));
        if let Some(layer) = sum.layer_mut("indirect") {
            layer.data = light;
        }
        return match check {
            Some(c) => {
                let against = if pt.spp >= regression::OUTLIER_MIN_SPP {
                    let mean = c.weights.iter().map(|&x| x as f64).sum::<f64>() / c.weights.len().max(1) as f64;
                    format!("at a weight per pixel from both errors over the {0}x{0} pixels around it (mean {mean:.2}; one weight for the image would be {1:.2})", 2 * regression::WEIGHT_RADIUS + 1, c.weight())
                } else {
                    format!("at weight {:.2}", c.weight())
                };
                let how = format!(
                    "{how}, {against} against the samples themselves (its error measured against them {:.3e}, theirs {:.3e}) and a weight of their own at the {} pixels where it stands over {} standard errors from them",
                    c.corrected,
                    c.samples,
                    c.flagged.len(),
                    regression::OUTLIER_SIGMAS
                );
                (c.weights, c.blended, how)
            }
            None => (vec![1.0; width * height], error, how),
        };
    }
    match blend::indirect_weights(&ours.data, &theirs.data, pair, pt.spp, k, width, height) {
        Some((w, error)) => {
            let mean = w.iter().map(|&x| x as f64).sum::<f64>() / w.len().max(1) as f64;
            let how = format!("indirect light at a weight per pixel from the errors measured over {0}x{0}-pixel windows (mean {mean:.2}; one weight for the image would be {1:.2})", 2 * blend::WINDOW_RADIUS + 1, one.0);
            (w, error, how)
        }
        None => one_weight(),
    }
}

/// `v_d`: the variance of one camera sample's direct light, mean over pixels, from a pass's film
/// of `camera_samples` camera samples per pixel (its direct-variance layer holds the variance of
/// their mean); 0 when the eye pass samples no direct light (`light_samples` 0: it comes from
/// photons).
fn direct_variance(film: &Film, camera_samples: u32, light_samples: u32, scale: Option<&[f32]>) -> f64 {
    let pixels = (film.width as usize * film.height as usize).max(1);
    let weight = |k: usize| scale.map_or(1.0, |s| (s[k] as f64).powi(2));
    match (light_samples, film.layer(compose::DIRECT_VARIANCE_LAYER)) {
        (1.., Some(l)) => l.data.iter().enumerate().map(|(k, &v)| v as f64 * weight(k)).sum::<f64>() / pixels as f64 * camera_samples as f64,
        _ => 0.0,
    }
}

/// The standard error of the passes' squared bias measured against the path tracer's samples, at
/// most this share of the predicted error of the plan it decides ([`decisive_error`]): a bias that
/// large changes which plan wins, and a measurement noisier than it cannot see it. On Crytek Sponza
/// (200², 16 s, passes of 200k photons, eight seeds) the bias measured 2.8e-4 to 7.4e-4 with it, and every seed took the
/// path tracer for most of the time (relative MSE 5.7e-4 to 6.5e-4); with half of it, one seed
/// measured 1.4e-4 and took more passes and direct-only samples (9.0e-4).
const BIAS_CHECK_ERROR: f64 = 0.25;
/// The most of the time left the path tracer takes before the bias is measured against it.
const BIAS_CHECK_SHARE: f64 = 0.25;

/// Samples per pixel the path tracer needs in all (`None`: its `spp` are enough) for a squared bias
/// measured against it to have a standard error of at most [`BIAS_CHECK_ERROR`] of `decisive`,
/// the error measured with `spp` samples being `standard_error`: where the path tracer's noise
/// squared makes most of it (a bias too small to see), it falls as 1 / spp.
fn samples_for_bias_check(standard_error: f64, spp: u32, decisive: f64) -> Option<u32> {
    let goal = BIAS_CHECK_ERROR * decisive;
    (spp > 0 && standard_error > goal && goal > 0.0).then(|| (spp as f64 * standard_error / goal).ceil().min(u32::MAX as f64) as u32)
}

/// The passes' squared bias measured against the path tracer's samples `pt` (`measured`: them as
/// the figures weigh them, `scale`), and the summary's words for the samples it added. The pilot's
/// few samples hide a bias that would change which plan wins, so while the estimate's standard
/// error is above [`BIAS_CHECK_ERROR`] of `decisive` (the winning plan's predicted error for a
/// squared bias), the path tracer continues first, in its two independent groups
/// ([`PtSamples::add_to_groups`]; the samples stay in the image), at most `room` samples per group
/// in all, and the bias is measured again.
#[allow(clippy::too_many_arguments)]
fn check_bias(
    scene: &PreparedScene,
    single: &RenderSettings,
    pt: &mut PtSamples,
    measured: &mut PtSamples,
    scale: Option<&[f32]>,
    measure: impl Fn(&PtSamples) -> Option<BiasEstimate>,
    decisive: impl Fn(f64) -> f64,
    mut room: u32,
    stats: &mut Stats,
) -> Result<(Option<BiasEstimate>, String)> {
    let mut estimate = measure(measured);
    let (first_spp, first_error) = (pt.spp, estimate.map_or(0.0, |e| e.standard_error));
    let mut goal = f64::NAN;
    while let Some(e) = estimate {
        goal = decisive(e.bias2);
        let Some(want) = samples_for_bias_check(e.standard_error, pt.spp, goal) else { break };
        let per_group = (want - pt.spp).div_ceil(2).min(room);
        if per_group == 0 {
            break;
        }
        room -= per_group;
        pt.add_to_groups(scene, single, per_group, stats)?;
        *measured = scale.map_or_else(|| pt.clone(), |k| pt.weighted(k));
        estimate = measure(measured);
    }
    let added = pt.spp - first_spp;
    let words = match added {
        0 => String::new(),
        _ => format!(" (after {added} more path-traced spp: with {first_spp} its standard error was {first_error:.1e}, the winning plan's predicted error {goal:.1e})"),
    };
    Ok((estimate, words))
}

/// The predicted error of the plan that wins, for `left` seconds after `done`, if the passes'
/// squared bias is `bias2`: the lower of more passes and direct-only samples
/// ([`allocation::best_plan`]) and the path tracer for the time left ([`allocation::switched`]).
/// The bias decides between plans whose errors are of this size, which the path tracer's error on
/// its own (far above it where the passes lower the error) would not show.
fn decisive_error(figures: &Figures, rival: &allocation::Rival, done: &Done, left: f64, bias2: f64) -> f64 {
    let f = Figures { bias2: Some(bias2), bias_of_every_part: true, ..*figures };
    let passes = allocation::best_plan(&f, done, left).map_or(f64::INFINITY, |p| p.0);
    let pt = allocation::switched(&f, rival, done, left).unwrap_or(f64::INFINITY);
    passes.min(pt)
}

/// Per pixel, the square root of [`pt::relative_weight`] of the pixel's luminance in `film` (its
/// direct and indirect light, a first pass's, whose noise is independent of the path tracer's;
/// averaged over blocks as the pilot's weights are): the factor that turns a plain squared error
/// of a scaled layer into a relative one.
fn relative_scale(film: &Film) -> Vec<f32> {
    let value: Vec<f64> = parts(film).iter().map(|[d, i]| (d + i).max(0.0)).collect();
    block_means(&value, film.width as usize, film.height as usize).iter().map(|&v| pt::relative_weight(v).sqrt() as f32).collect()
}

/// Replace the direct light of the averaged passes (`camera` camera samples per pixel in all) by
/// its mean with `extra` direct-only samples per pixel (`extra_direct`: their RGB sum times
/// their count), each camera sample weighted alike; the beauty follows.
fn blend_direct(sum: &mut Film, extra_direct: &[f32], camera: u64, extra: u64) {
    let total = (camera + extra) as f32;
    let Some(direct) = sum.layer_mut("direct") else { return };
    let old = direct.data.clone();
    for (d, e) in direct.data.iter_mut().zip(extra_direct) {
        *d = (*d * camera as f32 + e) / total;
    }
    let new = direct.data.clone();
    if let Some(beauty) = sum.layer_mut("") {
        for (i, px) in beauty.data.chunks_exact_mut(4).enumerate() {
            for c in 0..3 {
                px[c] += new[3 * i + c] - old[3 * i + c];
            }
        }
    }
}

/// α of progressive photon mapping: the share of the photons a pass's radius keeps.
pub const ALPHA: f64 = 2.0 / 3.0;

/// Squared kernel radius of progressive pass `k` over that of pass 0: `∏_{j=1..k} (j + α) / (j + 1)`.
pub fn radius2_ratio(k: u32) -> f64 {
    (1..=k).map(|j| (j as f64 + ALPHA) / (j as f64 + 1.0)).product()
}

/// `m` with its kernels' squared radius scaled by `ratio` (see the module's documentation).
pub fn shrink(m: &MethodSettings, ratio: f64) -> MethodSettings {
    let mut m = m.clone();
    let r = ratio.sqrt() as f32;
    if let Some(pass) = m.photon_pass_mut() {
        pass.bandwidth.smoothness *= r;
        pass.bandwidth.max_bandwidth *= r;
        pass.bandwidth.radius_scale *= r;
    }
    let knn = |k: &mut usize| *k = ((*k as f64 * ratio).round() as usize).max(1);
    match &mut m {
        MethodSettings::Pm(p) => knn(&mut p.knn),
        MethodSettings::PmFg(p) => {
            knn(&mut p.knn);
            p.fg.gather_radius = p.fg.gather_radius.map(|g| g * r);
        }
        MethodSettings::RpmFg(p) => {
            knn(&mut p.knn);
            p.fg.gather_radius = p.fg.gather_radius.map(|g| g * r);
        }
        MethodSettings::HeFg(p) => knn(&mut p.knn),
        MethodSettings::RsFg(p) => p.fg.gather_radius = p.fg.gather_radius.map(|g| g * r),
        MethodSettings::Pt | MethodSettings::Rs(_) | MethodSettings::RsRc(_) => {}
    }
    m
}

/// Render progressive passes `passes.first .. passes.end` of `one` and average them.
pub fn progressive(scene: &PreparedScene, s: &RenderSettings, passes: Passes, progress: &dyn Progress, stats: &mut Stats, one: &PassFn<'_>) -> Result<Film> {
    let ratio = |k: u32| if passes.fixed_bandwidth { 1.0 } else { radius2_ratio(k) };
    let pass = |k: u32| RenderSettings { seed: pass_seed(s.seed, k), method: shrink(&s.method, ratio(k)), passes: None, ..s.clone() };
    let mut sum = one(scene, &pass(passes.first), progress, stats)?;
    for k in passes.first + 1..passes.end {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let mut pass_stats = Stats::default();
        let film = one(scene, &pass(k), progress, &mut pass_stats)?;
        accumulate(&mut sum, &film);
        merge(stats, &pass_stats);
    }
    finish(&mut sum, passes.count());
    stats.count("passes", passes.count() as u64);
    Ok(sum)
}

/// Add `f` into `sum`; the depth layer keeps the nearest non-zero depth (as the path tracer does).
fn accumulate(sum: &mut Film, f: &Film) {
    for (a, b) in sum.layers.iter_mut().zip(&f.layers) {
        debug_assert_eq!(a.name, b.name);
        if a.name == "depth" {
            for (x, &y) in a.data.iter_mut().zip(&b.data) {
                if y > 0.0 && (*x == 0.0 || y < *x) {
                    *x = y;
                }
            }
        } else {
            for (x, &y) in a.data.iter_mut().zip(&b.data) {
                *x += y;
            }
        }
    }
}

fn finish(sum: &mut Film, passes: u32) {
    let inv = 1.0 / passes as f32;
    for l in sum.layers.iter_mut().filter(|l| l.name != "depth") {
        l.data.iter_mut().for_each(|x| *x *= inv);
    }
}

/// Phase times and counters of later passes add to the first pass's (same names).
fn merge(stats: &mut Stats, pass: &Stats) {
    for (name, secs) in &pass.phases {
        match stats.phases.iter_mut().find(|(n, _)| n == name) {
            Some((_, t)) => *t += secs,
            None => stats.phases.push((name.clone(), *secs)),
        }
    }
    for (name, v) in &pass.counters {
        match stats.counters.iter_mut().find(|(n, _)| n == name) {
            Some((_, c)) => *c += v,
            None => stats.counters.push((name.clone(), *v)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Layer;

    fn film(v: f32, depth: f32) -> Film {
        let mut f = Film::new(1, 1);
        f.layers.push(Layer { name: String::new(), channels: vec!["R".into()], data: vec![v] });
        f.layers.push(Layer { name: "depth".into(), channels: vec!["Z".into()], data: vec![depth] });
        f
    }

    #[test]
    fn passes_average_and_keep_the_nearest_depth() {
        let mut sum = film(1.0, 0.0);
        accumulate(&mut sum, &film(2.0, 5.0));
        accumulate(&mut sum, &film(6.0, 3.0));
        finish(&mut sum, 3);
        assert_eq!(sum.layers[0].data, vec![3.0]);
        assert_eq!(sum.layers[1].data, vec![3.0]);
    }

    /// The radius schedule is Knaus & Zwicker's recurrence `r²_{i+1} = r²_i (i + α) / (i + 1)`, and
    /// falls as `k^(α−1)`: the ratio over `k^(α−1)` tends to a constant.
    #[test]
    fn radius_schedule_is_the_recurrence_and_falls_as_a_power() {
        assert_eq!(radius2_ratio(0), 1.0);
        for k in 1..50u32 {
            let want = radius2_ratio(k - 1) * (k as f64 + ALPHA) / (k as f64 + 1.0);
            assert!((radius2_ratio(k) - want).abs() <= 1e-15 * want);
        }
        let c = |k: u32| radius2_ratio(k) / (k as f64).powf(ALPHA - 1.0);
        assert!((c(10_000) / c(20_000) - 1.0).abs() < 1e-4, "{} {}", c(10_000), c(20_000));
    }

    /// Pass 0 keeps the settings; later passes shrink the splat bandwidth by the ratio's square
    /// root and the neighbour count by the ratio.
    #[test]
    fn shrink_scales_bandwidths_and_neighbours() {
        let pm = MethodSettings::of(super::super::Method::Pm);
        let MethodSettings::Pm(p0) = shrink(&pm, 1.0) else { panic!() };
        let MethodSettings::Pm(p) = shrink(&pm, 0.25) else { panic!() };
        assert_eq!((p0.knn, p.knn), (100, 25));
        assert_eq!(p.pass.bandwidth.smoothness, p0.pass.bandwidth.smoothness * 0.5);
        assert_eq!(p.pass.bandwidth.max_bandwidth, p0.pass.bandwidth.max_bandwidth * 0.5);
        let MethodSettings::Pm(tiny) = shrink(&pm, 1e-6) else { panic!() };
        assert_eq!(tiny.knn, 1);
    }

    /// The light pass of a shrunk pass traces the same photons (at one seed) with every splat
    /// radius — at the origin and at the hit, of every class, the caustic photons' neighbour radius
    /// too — the scheduled factor times the first pass's. On cornell-glossy (a glass sphere:
    /// caustic photons), the factor of pass 20.
    #[test]
    fn a_shrunk_pass_scales_every_splat_radius() {
        use crate::photon::{trace_photons, PhotonSettings};
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-glossy.usda"));
        let scene = PreparedScene::new(crate::usd::load_scene(path).expect("scene"), 32, 32, 0).expect("prepare");
        let rs = MethodSettings::of(super::super::Method::Rs);
        let ratio = radius2_ratio(20);
        let trace = |ratio: f64| {
            let m = shrink(&rs, ratio);
            trace_photons(&scene, &PhotonSettings { budget: [0, 3000, 3000], bandwidth: m.photon_pass().unwrap().bandwidth, ..PhotonSettings::default() })
        };
        let (first, later) = (trace(1.0), trace(ratio));
        let f = ratio.sqrt() as f32;
        let near = |a: f32, b: f32| (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + 1e-9;
        for k in 0..3 {
            assert_eq!(first.rays[k].len(), later.rays[k].len(), "class {k}: the same photons");
            for (a, b) in first.rays[k].iter().zip(&later.rays[k]) {
                assert_eq!((a.origin, a.dir, a.length), (b.origin, b.dir, b.length), "class {k}: the same photons");
                let (end_a, end_b) = (a.h0 + a.dh * a.length, b.h0 + b.dh * b.length);
                assert!(near(b.h0, f * a.h0) && near(end_b, f * end_a), "class {k}: radii {} → {}, {end_a} → {end_b}, not × {f}", a.h0, b.h0);
            }
        }
        assert!(first.rays[2].len() > 500, "{} caustic photons", first.rays[2].len());
    }

    /// The allocation's figures measured on two scenes — `plane-rect` (a plane under a rect light:
    /// nothing bounces, so its indirect light is exactly 0 and all its noise is direct) and the
    /// Cornell box (half its light has bounced) — with the same timings: the plane's plan puts more
    /// of the time into direct-only camera samples than the box's, and the box's more into passes.
    #[test]
    fn a_directly_lit_scene_gets_more_camera_samples_than_a_bouncing_one() {
        use super::super::{rs_rc, Method};
        let plan = |name: &str| {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
            let scene = PreparedScene::new(crate::usd::load_scene(&path).expect("scene"), 24, 24, 0).expect("prepare");
            let mut m = MethodSettings::of(Method::RsRc);
            let pass = m.photon_pass_mut().unwrap();
            (pass.photons, pass.aa_spp) = (4000, 4);
            let light_samples = pass.light_samples;
            let MethodSettings::RsRc(rc) = &m else { unreachable!() };
            let s = |k: u32| RenderSettings { spp: 1, seed: pass_seed(3, k), method: m.clone(), ..Default::default() };
            let film = |k: u32| rs_rc::render(&scene, &s(k), rc, &crate::integrators::SilentProgress, &mut Stats::default()).unwrap();
            let (a, b) = (film(0), film(1));
            let vd = direct_variance(&a, 4, light_samples, None);
            let vi = allocation::variance_of_pair(&a.layer("indirect").unwrap().data, &b.layer("indirect").unwrap().data);
            let f = Figures { pass_fixed: 0.2, per_camera_sample: 0.01, pass_camera_samples: 4, per_direct_sample: 0.01, direct_variance: vd, indirect_variance: Some(vi), bias2: Some(0.0), bias_of_every_part: false };
            let (_, passes, _, extra) = allocation::best_plan(&f, &Done::at_first_bandwidth(2, 0), 5.0).unwrap();
            (vd, vi, passes, extra)
        };
        let (plane, cornell) = (plan("plane-rect.usda"), plan("cornell-box.usda"));
        assert!(plane.0 > 0.0 && plane.1 == 0.0, "plane-rect: direct variance {}, indirect {}", plane.0, plane.1);
        assert!(cornell.1 > 0.0, "cornell-box: indirect variance {}", cornell.1);
        assert!(plane.3 > cornell.3 && plane.2 < cornell.2, "plane-rect: {} passes + {} direct spp; cornell-box: {} + {}", plane.2, plane.3, cornell.2, cornell.3);
    }

    /// A first pass whose indirect light is off by far more than the path tracer's noise hands the
    /// time left to the path tracer at once, its error measured against the pilot's samples; an
    /// exact one is followed by a second pass. The passes are stand-ins (the pilot's film with a
    /// chosen indirect layer and direct-light variance, and a given eye time) on `plane-rect`.
    #[test]
    fn a_first_pass_that_loses_even_without_bias_hands_the_time_to_the_path_tracer() {
        use super::super::{allocation::Rival, Method, SilentProgress};
        use std::cell::Cell;
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plane-rect.usda");
        let scene = PreparedScene::new(crate::usd::load_scene(&path).expect("scene"), 16, 16, 0).expect("prepare");
        let base = RenderSettings { spp: 2, seed: 5, ..Default::default() };
        let mut pilot = pt::render(&scene, &base, &SilentProgress, &mut Stats::default()).expect("pilot");
        // the pilot's indirect light: 1 with the noise of two samples of variance 0.02 each
        let noise = |k: usize| 0.1 * (((k as f64 * 0.618_034).fract() - 0.5) * 12f64.sqrt());
        for (k, c) in pilot.layer_mut("indirect").unwrap().data.chunks_exact_mut(3).enumerate() {
            c.fill((1.0 + noise(k)) as f32);
        }
        // the path tracer's direct light is noisier than the passes' camera samples' (0.04 per
        // sample), so that without an indirect error the passes win
        let rival = Rival { seconds_per_spp: 0.004, variance: [0.2, 0.02], corrects: false };
        let mut method = MethodSettings::of(Method::RsRc);
        method.photon_pass_mut().unwrap().aa_spp = 4;
        let run = |indirect: f32| {
            let calls = Cell::new(0u32);
            let mut pass = pilot.clone();
            pass.layer_mut("indirect").unwrap().data.fill(indirect);
            pass.add_layer(compose::DIRECT_VARIANCE_LAYER, &["V"]);
            pass.layer_mut(compose::DIRECT_VARIANCE_LAYER).unwrap().data.fill(0.01);
            let one = |_: &PreparedScene, _: &RenderSettings, _: &dyn Progress, st: &mut Stats| -> Result<Film> {
                calls.set(calls.get() + 1);
                std::thread::sleep(std::time::Duration::from_millis(40));
                st.phase("eye", 0.02);
                Ok(pass.clone())
            };
            let s = RenderSettings { spp: 1, seed: 5, method: method.clone(), rival: Some(rival), ..Default::default() };
            let samples = PtSamples { film: pilot.clone(), spp: 2, seed: 5, pair: None, groups: None, second: None };
            let mut stats = Stats::default();
            render(&scene, &s, 0.6, Instant::now(), &SilentProgress, &mut stats, &one, Some(samples)).expect("timed passes");
            (calls.get(), stats.counter("path_tracer_spp").unwrap_or(0))
        };
        let (biased_passes, biased_spp) = run(1.5);
        assert_eq!(biased_passes, 1, "a pass off by 0.5 (squared error 0.25 against the path tracer's 0.02 per sample)");
        assert!(biased_spp > 2, "the path tracer continued: {biased_spp} spp");
        let (exact_passes, _) = run(1.0);
        assert!(exact_passes >= 2, "an exact pass is followed by another: {exact_passes} passes");
    }

    /// A single pass after a pilot of one path-traced sample per pixel and no pair (the probe's
    /// variances, which understate the sample's indirect noise here, 0.02 against 0.08): the
    /// difference between the two cannot measure the pass's error, so the pass's indirect light is
    /// kept whole, and its one camera sample's direct light blends with the path tracer's at equal
    /// weight (the probe's variance for both).
    #[test]
    fn a_single_pass_after_one_unpaired_sample_keeps_its_indirect_light() {
        use super::super::{allocation::Rival, Method, SilentProgress};
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plane-rect.usda");
        let scene = PreparedScene::new(crate::usd::load_scene(&path).expect("scene"), 16, 16, 0).expect("prepare");
        let mut pilot = pt::render(&scene, &RenderSettings { spp: 1, seed: 5, ..Default::default() }, &SilentProgress, &mut Stats::default()).expect("pilot");
        let noise = |k: usize| 0.2 * (((k as f64 * 0.618_034).fract() - 0.5) * 12f64.sqrt()) * 2f64.sqrt();
        for (k, c) in pilot.layer_mut("indirect").unwrap().data.chunks_exact_mut(3).enumerate() {
            c.fill((1.0 + noise(k)) as f32);
        }
        let mut pass = pilot.clone();
        pass.layer_mut("indirect").unwrap().data.fill(1.0);
        pass.layer_mut("direct").unwrap().data.iter_mut().for_each(|v| *v += 0.2);
        let mut method = MethodSettings::of(Method::RsRc);
        let p = method.photon_pass_mut().unwrap();
        (p.aa_spp, p.light_samples) = (1, 1);
        let one = |_: &PreparedScene, _: &RenderSettings, _: &dyn Progress, st: &mut Stats| -> Result<Film> {
            std::thread::sleep(std::time::Duration::from_millis(40));
            st.phase("eye", 0.02);
            Ok(pass.clone())
        };
        let rival = Rival { seconds_per_spp: 0.05, variance: [0.04, 0.02], corrects: false };
        let s = RenderSettings { spp: 1, seed: 5, method, rival: Some(rival), ..Default::default() };
        let samples = PtSamples { film: pilot.clone(), spp: 1, seed: 5, pair: None, groups: None, second: None };
        let mut stats = Stats::default();
        let film = render(&scene, &s, 0.05, Instant::now(), &SilentProgress, &mut stats, &one, Some(samples)).expect("timed pass");
        assert_eq!(stats.counter("passes"), Some(1));
        assert!(film.layer("indirect").unwrap().data.iter().all(|&v| v == 1.0), "the pass's indirect light, whole");
        for (x, y) in film.layer("direct").unwrap().data.iter().zip(&pilot.layer("direct").unwrap().data) {
            assert!((x - (y + 0.1)).abs() < 1e-5, "{x} against the mean of {y} and {}", y + 0.2);
        }
    }

    /// The passes' indirect light 30 % too bright over a textured truth, against path-traced
    /// samples of it: with 16 spp and the pilot's pair it is corrected to the samples' level
    /// (weight 1, the layer replaced, far closer to the truth than the passes were); with 2 spp it
    /// keeps its layer and takes weights per pixel; without the pair, the plan's one weight.
    #[test]
    fn the_passes_indirect_light_is_corrected_to_the_path_tracers_level() {
        let (w, h) = (32usize, 24usize);
        let n = w * h;
        let truth: Vec<f32> = regression::textured(w, h).into_iter().map(|v| v as f32).collect();
        let film = |values: &dyn Fn(usize) -> f32| {
            let mut f = Film::new(w as u32, h as u32);
            f.add_layer("indirect", &["R", "G", "B"]);
            for (k, c) in f.layer_mut("indirect").unwrap().data.chunks_exact_mut(3).enumerate() {
                c.fill(values(k));
            }
            f
        };
        let passes = film(&|k| 1.3 * truth[k]);
        let mut rng = crate::sampling::Rng::new(11, 0);
        let noise: Vec<f32> = (0..n).map(|_| (rng.next_f32() - 0.5) * 12f32.sqrt()).collect();
        let variance = 0.04f32;
        let samples = |spp: u32, pair: bool| PtSamples {
            film: film(&|k| truth[k] + (variance / spp as f32).sqrt() * noise[k]),
            spp,
            seed: 0,
            pair: pair.then(|| vec![[0.0, variance]; n]),
            groups: None,
            second: None,
        };
        let scale = vec![1.0f32; n];
        let error = |f: &Film| f.layer("indirect").unwrap().data.chunks_exact(3).zip(&truth).map(|(c, t)| ((c[0] - t) as f64).powi(2)).sum::<f64>() / n as f64;
        let before = error(&passes);
        let mut sum = passes.clone();
        let (weights, _, how) = indirect_blend(&mut sum, &samples(16, true), Some(&scale), (0.5, 1.0));
        assert!(weights.iter().all(|&x| x == 1.0) && how.contains("regression"), "{how}");
        let (mean, want) = (sum.layer("indirect").unwrap().data.iter().map(|&x| x as f64).sum::<f64>() / (3 * n) as f64, truth.iter().map(|&x| x as f64).sum::<f64>() / n as f64);
        assert!((mean / want - 1.0).abs() < 0.03, "corrected mean {mean} against {want}");
        assert!(error(&sum) < 0.1 * before, "corrected {:.2e}, passes {before:.2e}", error(&sum));
        let mut sum = passes.clone();
        let (weights, _, how) = indirect_blend(&mut sum, &samples(2, true), Some(&scale), (0.5, 1.0));
        assert!(how.contains("weight per pixel") && weights.len() == n, "{how}");
        assert_eq!(sum.layer("indirect").unwrap().data, passes.layer("indirect").unwrap().data);
        let (weights, error, how) = indirect_blend(&mut sum, &samples(16, false), None, (0.5, 1.0));
        assert!(weights.iter().all(|&x| x == 0.5) && error == 1.0, "{how}");
    }

    /// The path tracer continues before the bias decides only while the bias measured against it
    /// is coarser than the error of the plan it decides: a standard error of 6.3e-4 with the
    /// pilot's 2 spp against plans of error 1.7e-4 (goal 4.25e-5) asks for 30 spp in all, against
    /// 1.7e-2 (goal 4.25e-3) for none, and so does a measurement already fine enough.
    #[test]
    fn the_path_tracer_continues_until_it_can_see_a_bias_that_matters() {
        assert_eq!(samples_for_bias_check(6.3e-4, 2, 1.7e-4), Some(30));
        assert_eq!(samples_for_bias_check(6.3e-4, 2, 1.7e-2), None);
        assert_eq!(samples_for_bias_check(4.0e-5, 30, 1.7e-4), None);
        assert_eq!(samples_for_bias_check(6.3e-4, 0, 1.7e-4), None, "no samples to continue");
    }

    #[test]
    fn pass_seeds_differ_and_pass_zero_is_the_seed() {
        assert_eq!(pass_seed(42, 0), 42);
        let s: std::collections::HashSet<u64> = (0..1000).map(|k| pass_seed(42, k)).collect();
        assert_eq!(s.len(), 1000);
    }
}
