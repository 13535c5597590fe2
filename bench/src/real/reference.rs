//! The real-scene table's path-traced reference: two independent halves (their difference
//! measures the reference's own noise, [`super::metrics::Measure::noise`]), kept on disk so that a
//! second run of the table renders none. A cached reference is keyed by the converted scene's
//! content (the `.rss` file, which records the hashes of the stage's layers and textures) and by
//! both halves' complete render settings; a damaged or unreadable entry is rendered again.

use raysplat::image::{self, Film};
use raysplat::integrators::{self, MethodSettings, RenderSettings, SilentProgress};
use raysplat::scene::SceneDesc;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Bumped when what a cached reference holds changes meaning.
const FORMAT: &str = "raysplat-bench real reference 1";
/// The EXR attribute holding the seconds a half took.
const SECONDS: &str = "raysplat:bench_seconds";

/// The two halves of a reference and their mean.
pub struct Halves {
    pub a: Film,
    pub b: Film,
    /// The mean of the halves.
    pub mean: Film,
    /// Samples per pixel of both halves together.
    pub spp: u32,
    /// Seconds the two halves took to render (when they were rendered).
    pub seconds: f64,
    /// Read from the cache.
    pub cached: bool,
}

impl Halves {
    /// A layer ("" = beauty) of half A, half B and their mean, RGB.
    pub fn layer(&self, name: &str) -> Option<[Vec<f32>; 3]> {
        Some([self.a.rgb(name)?, self.b.rgb(name)?, self.mean.rgb(name)?])
    }
}

/// The settings of the two halves: `spp / 2` path-traced samples each, seeds `seeds`.
pub fn half_settings(base: &RenderSettings, spp: u32, seeds: [u64; 2]) -> [RenderSettings; 2] {
    seeds.map(|seed| RenderSettings { method: MethodSettings::Pt, spp: (spp / 2).max(1), seed, time_budget: None, ..base.clone() })
}

/// The cache key of a reference of the converted scene `rss` rendered with `halves`.
pub fn key(rss: &Path, halves: &[RenderSettings; 2]) -> anyhow::Result<String> {
    let scene = raysplat::usd::sha256_file(rss)?;
    let mut h = Sha256::new();
    h.update(FORMAT.as_bytes());
    h.update(scene.as_bytes());
    for s in halves {
        h.update([0u8]);
        h.update(format!("{s:?}").as_bytes());
    }
    Ok(h.finalize().iter().take(16).map(|b| format!("{b:02x}")).collect())
}

fn paths(dir: &Path, key: &str) -> [PathBuf; 2] {
    [dir.join(format!("{key}.a.exr")), dir.join(format!("{key}.b.exr"))]
}

/// Whether the reference `key` is in `dir` (both halves present; not checked further).
pub fn is_cached(dir: &Path, key: &str) -> bool {
    paths(dir, key).iter().all(|p| p.is_file())
}

/// The reference of `desc` with `halves`: read from `dir` under `key` when there, else rendered
/// and written there (a cache that cannot be written is reported on stderr, and the reference
/// still used).
pub fn load_or_render(dir: &Path, key: &str, desc: &SceneDesc, halves: &[RenderSettings; 2]) -> anyhow::Result<Halves> {
    let [pa, pb] = paths(dir, key);
    if is_cached(dir, key) {
        match read(&pa, &pb, halves) {
            Ok(h) => return Ok(h),
            Err(e) => eprintln!("real: the cached reference {} cannot be used ({e:#}); rendering it again", pa.display()),
        }
    }
    let render = |s: &RenderSettings| integrators::render(desc.clone(), s, &SilentProgress);
    let (a, b) = (render(&halves[0])?, render(&halves[1])?);
    let write = || -> anyhow::Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| raysplat::Error::io(dir, e))?;
        for (path, (out, s)) in [(&pa, (&a, &halves[0])), (&pb, (&b, &halves[1]))] {
            let mut attributes = s.attributes();
            attributes.push((SECONDS.into(), out.stats.total_seconds.to_string()));
            image::write_exr(path, &out.film, &attributes)?;
        }
        Ok(())
    };
    if let Err(e) = write() {
        eprintln!("real: the reference cannot be cached in {} ({e:#})", dir.display());
    }
    let seconds = a.stats.total_seconds + b.stats.total_seconds;
    Ok(halves_of(a.film, b.film, halves, seconds, false))
}

fn read(pa: &Path, pb: &Path, halves: &[RenderSettings; 2]) -> anyhow::Result<Halves> {
    let (a, b) = (image::read_exr(pa)?, image::read_exr(pb)?);
    let size = halves[0].resolution;
    for f in [&a, &b] {
        if size.is_some_and(|[w, h]| [f.width, f.height] != [w, h]) || f.width != b.width || f.height != b.height {
            anyhow::bail!("its size {}x{} is not the reference's", f.width, f.height);
        }
    }
    let seconds = [pa, pb]
        .iter()
        .map(|p| image::read_exr_string_attribute(p, SECONDS).ok().flatten().and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0))
        .sum();
    Ok(halves_of(a, b, halves, seconds, true))
}

fn halves_of(a: Film, b: Film, halves: &[RenderSettings; 2], seconds: f64, cached: bool) -> Halves {
    let mut mean = a.clone();
    for (la, lb) in mean.layers.iter_mut().zip(&b.layers) {
        for (x, y) in la.data.iter_mut().zip(&lb.data) {
            *x = 0.5 * (*x + y);
        }
    }
    Halves { a, b, mean, spp: halves[0].spp + halves[1].spp, seconds, cached }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reference is rendered once: the second call reads the same pixels from the cache, and a
    /// damaged entry is rendered again.
    #[test]
    fn a_reference_is_read_back_from_the_cache() {
        let scene = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.usda"));
        let rss = raysplat::usd::convert_cached(scene, &Default::default()).unwrap();
        let desc = raysplat::usd::load_scene(&rss).unwrap();
        let base = RenderSettings { resolution: Some([12, 8]), ..Default::default() };
        let halves = half_settings(&base, 4, [1, 2]);
        let dir = tempfile::tempdir().unwrap();
        let k = key(&rss, &halves).unwrap();
        assert!(!is_cached(dir.path(), &k));
        let first = load_or_render(dir.path(), &k, &desc, &halves).unwrap();
        assert!(!first.cached && is_cached(dir.path(), &k));
        let second = load_or_render(dir.path(), &k, &desc, &halves).unwrap();
        assert!(second.cached && second.seconds > 0.0);
        for l in ["", "direct", "indirect"] {
            assert_eq!(first.layer(l).unwrap(), second.layer(l).unwrap(), "layer {l:?}");
        }
        // other settings, another key
        let other = half_settings(&base, 8, [1, 2]);
        assert_ne!(key(&rss, &other).unwrap(), k);
        // a damaged entry: rendered again, and the entry repaired
        std::fs::write(dir.path().join(format!("{k}.b.exr")), b"not an EXR").unwrap();
        let third = load_or_render(dir.path(), &k, &desc, &halves).unwrap();
        assert!(!third.cached && third.layer("").unwrap() == first.layer("").unwrap());
        assert!(load_or_render(dir.path(), &k, &desc, &halves).unwrap().cached);
    }
}
