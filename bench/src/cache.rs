//! `raysplat-bench cache`: the splatting paper's Table 2 rows PM / RS / RC (§8.3, radiance
//! caching) on our scenes: eye pass, light pass, splatting (for pm: the density estimation) and total
//! seconds (T_S: every phase after the light pass), and the relative MSE against a path-traced
//! reference rendered as two halves with its own noise subtracted ([`raysplat_cli::reference`]): of the
//! `indirect` layer with the direct light sampled (our default), of the whole image with the direct
//! light from photons (`--cache-direct photons`, the paper's Table 2 setting: budgets 0.3 / 0.6 /
//! 0.1 of direct / indirect / caustic photons). Times and errors are means over
//! `--cache-seeds` photon seeds; each render's times are its fastest of `--cache-repeat` renders,
//! the methods alternating (every render of one setting gives the same image, so the same error).
//! It shows whether `rs-rc` is ≥ 4× faster than `rs` with no higher error (the paper's 3.9×).

use raysplat_cli::reference::Reference;
use raysplat::integrators::{self, Method, RenderRequest, RenderSettings, SilentProgress};
use raysplat::usd;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct CacheTableArgs {
    /// Scenes (comma separated).
    #[arg(required = true, num_args = 1.., value_delimiter = ',', value_name = "SCENES")]
    pub scenes: Vec<PathBuf>,
    /// Cache table: the longer image side in pixels (the scene's aspect ratio is kept).
    #[arg(long, default_value_t = 500)]
    pub cache_size: u32,
    /// Cache table: eye samples per pixel.
    #[arg(long, default_value_t = 4)]
    pub cache_spp: u32,
    /// Cache table: stored photons.
    #[arg(long, default_value_t = 200_000)]
    pub cache_photons: usize,
    /// Cache table: samples per pixel of the path-traced reference (two halves).
    #[arg(long, default_value_t = 256)]
    pub cache_reference_spp: u32,
    /// Cache table: photon seeds each row's time and error are averaged over.
    #[arg(long, default_value_t = 2)]
    pub cache_seeds: u64,
    /// Cache table: emission guiding settings to render every method with (comma separated, `on`
    /// and/or `off`; each method's rows follow each other, against the same reference).
    #[arg(long, value_delimiter = ',', default_value = "on", value_parser = ["on", "off"])]
    pub cache_guiding: Vec<String>,
    /// Cache table: where every method's direct light comes from (comma separated): `sampled`
    /// (explicit light sampling in the eye pass, the default; the error is the `indirect`
    /// layer's) and/or `photons` (direct photons, the paper's Table 2 setting with budgets
    /// 0.3 / 0.6 / 0.1 of direct / indirect / caustic photons; the error is the whole image's,
    /// since the photons' estimate then holds the direct light too).
    #[arg(long, value_delimiter = ',', default_value = "sampled", value_parser = ["sampled", "photons"])]
    pub cache_direct: Vec<String>,
    /// Cache table: `--glossy` settings to render rs-rc with (comma separated; the first is the
    /// rs-rc row the ratios use, the others follow as rows `rs-rc/MODE`). pm and rs keep auto.
    #[arg(long, value_delimiter = ',', default_value = "auto", value_parser = ["auto", "exact", "sh", "histogram"])]
    pub cache_glossy: Vec<String>,
    /// Cache table: renders per method and seed, the methods alternating; each keeps its fastest
    /// (a shared machine's load then reaches every method alike).
    #[arg(long, default_value_t = 3)]
    pub cache_repeat: usize,
}

struct Row {
    eye: f64,
    light: f64,
    splat: f64,
    total: f64,
    error: f64,
    /// The error of each photon seed's image (`error` is their mean).
    seed_errors: Vec<f64>,
    paths_per_photon: f64,
}

pub fn run(a: &CacheTableArgs) -> anyhow::Result<()> {
    let scenes = &a.scenes;
    if a.cache_reference_spp < 2 {
        anyhow::bail!(raysplat::Error::param("cache-reference-spp", "must be at least 2 (two halves)"));
    }
    let seeds = a.cache_seeds.max(1);
    let repeat = a.cache_repeat.max(1);
    println!(
        "radiance caching (splatting paper, Table 2): {} eye spp, {} photons, relative MSE (direct light sampled: of the indirect layer; from photons: of the whole image) against two path-traced halves of {} spp (noise subtracted), mean of {seeds} photon seeds, each render the fastest of {repeat} (methods alternating), {} threads",
        a.cache_spp,
        a.cache_photons,
        a.cache_reference_spp / 2,
        rayon::current_num_threads()
    );
    for path in scenes {
        let desc = usd::load_scene(path)?;
        let [sw, sh] = desc.resolution.unwrap_or([512, 512]);
        let scale = a.cache_size as f64 / sw.max(sh) as f64;
        let res = [((sw as f64 * scale).round() as u32).max(1), ((sh as f64 * scale).round() as u32).max(1)];
        let request = RenderRequest { resolution: Some(res), spp: Some(a.cache_spp), photons: Some(a.cache_photons), ..Default::default() };
        let base = RenderSettings { resolution: Some(res), ..Default::default() };
        let reference = Reference::render(&desc, &base, a.cache_reference_spp, [1000, 1001], &["indirect", ""])?;
        println!(
            "\n{} ({}x{}): reference {} spp in {:.1} s, its noise {:.5} (indirect layer), {:.5} (whole image)",
            path.display(),
            res[0],
            res[1],
            reference.spp,
            reference.seconds,
            reference.noise("indirect"),
            reference.noise("")
        );
        println!(
            "  {:<15} {:>5} {:>7} {:>7} {:>7} {:>8} {:>8} {:>12} {:>8} {:>11} {:>10}",
            "method", "guide", "direct", "T_E", "T_L", "T_S", "ΣT", "rMSE", "records", "splat pairs", "paths/ph."
        );
        let auto = "auto".to_string();
        let first_glossy = a.cache_glossy.first().unwrap_or(&auto);
        // every method runs in every (guiding, direct light) variant; a method's rows follow each other
        let variants: Vec<(&String, &String)> = a.cache_guiding.iter().flat_map(|g| a.cache_direct.iter().map(move |d| (g, d))).collect();
        let runs: Vec<(Method, &String, &String, &String)> = [(Method::Pm, &auto), (Method::Rs, &auto), (Method::RsRc, first_glossy)]
            .into_iter()
            .chain(a.cache_glossy.iter().skip(1).map(|g| (Method::RsRc, g)))
            .flat_map(|(m, glossy)| variants.iter().map(move |&(g, d)| (m, glossy, g, d)))
            .collect();
        // per run and seed: the error of its image and the stats of its fastest render
        let mut best: Vec<Vec<Option<(f64, integrators::Stats)>>> = vec![vec![None; seeds as usize]; runs.len()];
        // per run and round: the mean total over the seeds (how far the ratios move from round to round)
        let mut round_totals: Vec<Vec<f64>> = vec![Vec::with_capacity(repeat); runs.len()];
        for _ in 0..repeat {
            for (i, &(m, glossy, guiding, direct)) in runs.iter().enumerate() {
                let glossy_mode: raysplat::radiance_map::GlossyMode = glossy.parse()?;
                let direct_photons = direct == "photons";
                // with direct photons the photon estimate holds the direct light: judge the whole image
                let layer = if direct_photons { "" } else { "indirect" };
                let mut round_total = 0.0;
                for seed in 1..=seeds {
                    let s = RenderRequest { method: Some(m), seed, emission_guiding: guiding == "on", glossy: glossy_mode, direct_photons, ..request.clone() }.settings()?;
                    let out = integrators::render(desc.clone(), &s, &SilentProgress)?;
                    round_total += out.stats.total_seconds / seeds as f64;
                    let slot = &mut best[i][(seed - 1) as usize];
                    match slot {
                        Some((_, stats)) if stats.total_seconds <= out.stats.total_seconds => {}
                        Some((_, stats)) => *stats = out.stats,
                        None => *slot = Some((reference.error(layer, &out.film.rgb(layer).expect("the film's layer")), out.stats)),
                    }
                }
                round_totals[i].push(round_total);
            }
        }
        let mut rows = Vec::new();
        for (&(m, glossy, guiding, direct), renders) in runs.iter().zip(&best) {
            let label = if m == Method::RsRc && glossy != first_glossy { format!("{}/{glossy}", m.name()) } else { m.name().to_string() };
            let mut r = Row { eye: 0.0, light: 0.0, splat: 0.0, total: 0.0, error: 0.0, seed_errors: Vec::new(), paths_per_photon: 0.0 };
            let (mut records, mut pairs) = (0, 0);
            for (error, stats) in renders.iter().flatten() {
                let f = 1.0 / seeds as f64;
                let phase = |p: &str| stats.phase_seconds(p).unwrap_or(0.0) * f;
                r.eye += phase("eye");
                r.light += phase("light");
                // T_S: everything after the light pass (pm: photon map build and density estimation)
                r.splat += ["splat", "uncached glossy splat", "caustic splat", "filter", "glossy", "build", "estimate"].iter().map(|p| phase(p)).sum::<f64>();
                r.total += stats.total_seconds * f;
                r.error += error * f;
                r.seed_errors.push(*error);
                let stored: u64 = ["direct_photons", "indirect_photons", "caustic_photons"].iter().filter_map(|c| stats.counter(c)).sum();
                r.paths_per_photon += stats.counter("photon_paths").unwrap_or(0) as f64 / stored.max(1) as f64 * f;
                records = stats.counter("cache_records").unwrap_or(0);
                pairs = stats.counter("splat_pairs").unwrap_or(0);
            }
            let show = |v: u64| if v == 0 { "-".to_string() } else { v.to_string() };
            println!(
                "  {:<15} {:>5} {:>7} {:>7.2} {:>7.2} {:>8.2} {:>8.2} {:>12.5} {:>8} {:>11} {:>10.2}",
                label,
                guiding,
                direct,
                r.eye,
                r.light,
                r.splat,
                r.total,
                r.error,
                show(records),
                show(pairs),
                r.paths_per_photon
            );
            rows.push(r);
        }
        let g = variants.len();
        for (i, (guiding, direct)) in variants.iter().enumerate() {
            let (rs, rc) = (&rows[g + i], &rows[2 * g + i]);
            // the same photon seed's images side by side: how far the mean's ratio moves with the seeds
            let per_seed: Vec<String> = rc.seed_errors.iter().zip(&rs.seed_errors).map(|(c, s)| format!("{:.2}x", c / s)).collect();
            // each round's renders ran minutes apart at most: their ratio shows the machine's noise
            let mut per_round: Vec<f64> = round_totals[g + i].iter().zip(&round_totals[2 * g + i]).map(|(s, c)| s / c).collect();
            per_round.sort_by(f64::total_cmp);
            let spread = match (per_round.first(), per_round.last()) {
                (Some(lo), Some(hi)) if per_round.len() > 1 => format!("; round by round {lo:.1}x to {hi:.1}x over {} rounds", per_round.len()),
                _ => String::new(),
            };
            println!(
                "  rs-rc ({first_glossy}) vs rs (guiding {guiding}, direct light {direct}): {:.1}x faster in total (fastest renders{spread}), {:.1}x in splatting; error {:.2}x rs's (per seed: {}) (goal: ≥ 4x faster, error ≤ 1x)",
                rs.total / rc.total,
                rs.splat / rc.splat,
                rc.error / rs.error,
                per_seed.join(", ")
            );
        }
        if a.cache_guiding.len() == 2 && a.cache_direct.len() == 1 {
            for (k, m) in ["pm", "rs", "rs-rc"].iter().enumerate() {
                let (on, off) = (&rows[k * g], &rows[k * g + 1]);
                println!(
                    "  {m}: guiding {} vs {}: light pass {:.2}x, total {:.2}x, error {:.2}x",
                    a.cache_guiding[0],
                    a.cache_guiding[1],
                    on.light / off.light,
                    on.total / off.total,
                    on.error / off.error
                );
            }
        }
    }
    Ok(())
}
