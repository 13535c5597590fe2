//! `raysplat merge PARTS... -o out.exr`: the parts of a render made on several machines, one
//! image. Tiles (crop windows) are stitched into the whole image (parts of one window only: that
//! window); parts of the same window holding different passes
//! are averaged, each weighted by the passes it holds (`raysplat:pass_range` in its header), and
//! the average is taken as a sum over the parts in pass order times 1 / passes, as a one-machine
//! `--passes` render takes it. Every layer (the AOVs) is merged; the depth layer keeps the
//! nearest depth. Parts of different scenes, settings, seeds, frames or image sizes are refused,
//! naming the file and what differs.

use super::part::{parse_crop, parse_pass_range};
use raysplat::integrators::parse_size;
use raysplat::image::{self, Film};
use raysplat::Error;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct MergeArgs {
    /// EXR files written by `raysplat render` with --tile, --crop or --passes/--pass-range.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The merged EXR (written atomically; never one of the parts).
    #[arg(short, long)]
    output: PathBuf,
}

/// Header attributes that say what a part is, beside its settings.
pub const SETTINGS: &str = "raysplat:part_settings";
const NAMES: [&str; 6] = ["raysplat:scene_sha256", "raysplat:full_resolution", "raysplat:crop", "raysplat:frame", SETTINGS, "raysplat:pass_range"];

/// One part: its image, window and passes, and what must match across parts.
struct Part {
    path: PathBuf,
    film: Film,
    crop: [u32; 4],
    /// Passes `first .. end` (a render without `--passes` is the one pass `0 .. 1`).
    passes: (u32, u32),
    /// Scene hash, whole image size and frame (in that order): what must match, with the settings.
    identity: [(String, String); 3],
    settings: Vec<(String, String)>,
}

fn read_part(path: &Path) -> Result<Part, Error> {
    let bad = |m: String| Error::image(path.display().to_string(), m);
    let attrs = image::read_exr_string_attributes(path, &NAMES)?;
    let get = |n: &str| attrs.iter().find(|(k, _)| k == n).map(|(_, v)| v.clone());
    let need = |n: &str| get(n).ok_or_else(|| bad(format!("no {n} attribute: not a part written by `raysplat render` (a render that records its scene hash and window)")));
    let settings: Vec<(String, String)> = serde_json::from_str(&need(SETTINGS)?).map_err(|e| bad(format!("{SETTINGS}: {e}")))?;
    if settings.iter().any(|(k, v)| k == "raysplat:denoise" && v != "off") {
        return Err(bad("a denoised part: merge the raw parts, then denoise the merged image (raysplat denoise)".into()));
    }
    let crop = parse_crop(&need("raysplat:crop")?).map_err(|e| bad(e.to_string()))?;
    let passes = match get("raysplat:pass_range") {
        Some(r) => parse_pass_range(&r).map_err(|e| bad(e.to_string()))?,
        None => (0, 1),
    };
    let film = image::read_exr(path)?;
    if (film.width, film.height) != (crop[2] - crop[0], crop[3] - crop[1]) {
        return Err(bad(format!("its {}x{} pixels are not its window {crop:?}", film.width, film.height)));
    }
    let identity = [
        ("scene (SHA-256 of the scene file)".to_string(), need("raysplat:scene_sha256")?),
        ("image size".to_string(), need("raysplat:full_resolution")?),
        ("frame".to_string(), get("raysplat:frame").unwrap_or_else(|| "none".into())),
    ];
    Ok(Part { path: path.to_path_buf(), film, crop, passes, identity, settings })
}

/// Why `b` cannot be merged with `a`, if it cannot.
fn mismatch(a: &Part, b: &Part) -> Option<String> {
    for ((what, x), (_, y)) in a.identity.iter().zip(&b.identity) {
        if x != y {
            return Some(format!("its {what} differs from {}'s: {y} vs {x}", a.path.display()));
        }
    }
    for (k, v) in &a.settings {
        let other = b.settings.iter().find(|(kb, _)| kb == k).map(|(_, v)| v.as_str());
        if other != Some(v.as_str()) {
            return Some(format!("its setting {} differs from {}'s: {} vs {v}", k.trim_start_matches("raysplat:"), a.path.display(), other.unwrap_or("(none)")));
        }
    }
    if a.settings.len() != b.settings.len() {
        return Some(format!("its settings differ from {}'s", a.path.display()));
    }
    if a.film.layers.iter().map(|l| (&l.name, &l.channels)).ne(b.film.layers.iter().map(|l| (&l.name, &l.channels))) {
        return Some(format!("its layers differ from {}'s", a.path.display()));
    }
    None
}

pub fn run(a: &MergeArgs) -> anyhow::Result<()> {
    // the output rule: a new path or a regular file, never one of the parts
    let inputs: Vec<&Path> = a.parts.iter().map(PathBuf::as_path).collect();
    raysplat::io::check_outputs(&[(a.output.as_path(), raysplat::io::Format::Exr)], &inputs)?;
    let mut parts: Vec<Part> = a.parts.iter().map(|p| read_part(p)).collect::<Result<_, _>>()?;
    for b in &parts[1..] {
        if let Some(why) = mismatch(&parts[0], b) {
            return Err(Error::image(b.path.display().to_string(), format!("cannot be merged: {why}")).into());
        }
    }
    parts.sort_by_key(|p| (p.crop[1], p.crop[0], p.passes.0));
    let (film, window, passes) = merge(&parts)?;
    let mut attrs = parts[0].settings.clone();
    attrs.retain(|(k, _)| k != "raysplat:pass_range");
    if parts[0].settings.iter().any(|(k, _)| k == "raysplat:passes") {
        attrs.push(("raysplat:pass_range".into(), format!("{}:{}", passes.0, passes.1)));
    }
    attrs.push((SETTINGS.into(), serde_json::to_string(&parts[0].settings)?));
    attrs.push(("raysplat:scene_sha256".into(), parts[0].identity[0].1.clone()));
    attrs.push(("raysplat:full_resolution".into(), parts[0].identity[1].1.clone()));
    if parts[0].identity[2].1 != "none" {
        attrs.push(("raysplat:frame".into(), parts[0].identity[2].1.clone()));
    }
    attrs.push(("raysplat:crop".into(), window.map(|v| v.to_string()).join(",")));
    attrs.push(("raysplat:merged_parts".into(), parts.len().to_string()));
    image::write_exr(&a.output, &film, &attrs)?;
    eprintln!(
        "merged {} parts → {} ({}x{}, window {}, passes {}:{})",
        parts.len(),
        a.output.display(),
        film.width,
        film.height,
        window.map(|v| v.to_string()).join(","),
        passes.0,
        passes.1
    );
    Ok(())
}


/// Stitch and average `parts` (sorted by window, then first pass): the merged film, its window
/// and the passes it holds.
fn merge(parts: &[Part]) -> Result<(Film, [u32; 4], (u32, u32)), Error> {
    let err = |p: &Part, m: String| Error::image(p.path.display().to_string(), m);
    // the windows, each with its parts' pass ranges, which must be the same contiguous run
    let mut windows: Vec<(&[u32; 4], Vec<&Part>)> = Vec::new();
    for p in parts {
        match windows.last_mut() {
            Some((w, list)) if **w == p.crop => list.push(p),
            _ => windows.push((&p.crop, vec![p])),
        }
    }
    let mut run: Option<(u32, u32)> = None;
    for (_, list) in &windows {
        let mut end = list[0].passes.0;
        for p in list {
            if p.passes.0 != end {
                let why = if p.passes.0 < end { "overlaps the passes of another part of its window" } else { "leaves a gap after the passes of the parts before it" };
                return Err(err(p, format!("passes {}:{} {why} (parts of one window must hold a run of passes once each)", p.passes.0, p.passes.1)));
            }
            end = p.passes.1;
        }
        let r = (list[0].passes.0, end);
        if run.is_some_and(|q| q != r) {
            return Err(err(list[0], format!("its window holds passes {}:{}, another window's {}:{}", r.0, r.1, run.unwrap().0, run.unwrap().1)));
        }
        run = Some(r);
    }
    let run = run.expect("at least one part");
    // one window: its passes; several: tiles of the whole image
    let window = match windows[..] {
        [(w, _)] => *w,
        _ => {
            let [fw, fh] = parse_size(&parts[0].identity[1].1).map_err(|e| err(&parts[0], e.to_string()))?;
            [0, 0, fw, fh]
        }
    };
    let [x0, y0, x1, y1] = window;
    let (w, h) = (x1 - x0, y1 - y0);
    let mut covered = vec![false; (w * h) as usize];
    let mut out = Film::new(w, h);
    out.pixel_aspect = parts[0].film.pixel_aspect;
    for l in &parts[0].film.layers {
        out.layers.push(raysplat::image::Layer { name: l.name.clone(), channels: l.channels.clone(), data: vec![0.0; (w * h) as usize * l.channels.len()] });
    }
    for (win, list) in &windows {
        let avg = average(list, run.1 - run.0);
        let [cx0, cy0, cx1, cy1] = **win;
        for y in cy0..cy1 {
            for x in cx0..cx1 {
                let dst = ((y - y0) * w + (x - x0)) as usize;
                if std::mem::replace(&mut covered[dst], true) {
                    return Err(err(list[0], format!("its window {cx0},{cy0},{cx1},{cy1} overlaps another part's at pixel ({x}, {y})")));
                }
                let src = ((y - cy0) * (cx1 - cx0) + (x - cx0)) as usize;
                for (o, l) in out.layers.iter_mut().zip(&avg.layers) {
                    let n = l.channels.len();
                    o.data[dst * n..dst * n + n].copy_from_slice(&l.data[src * n..src * n + n]);
                }
            }
        }
    }
    if let Some(k) = covered.iter().position(|c| !c) {
        return Err(Error::param(
            "parts",
            format!("the tiles do not cover the {w}x{h} image: pixel ({}, {}) is in none of them (a tile missing?)", x0 + k as u32 % w, y0 + k as u32 / w),
        ));
    }
    Ok((out, window, run))
}

/// The average of one window's parts over their `passes` passes: each part's mean times its
/// passes, summed in pass order, times 1 / passes (one part: the part itself, bit for bit). The
/// depth layer keeps the nearest non-zero depth.
fn average(list: &[&Part], passes: u32) -> Film {
    if list.len() == 1 {
        return list[0].film.clone();
    }
    let mut sum = list[0].film.clone();
    let inv = 1.0 / passes as f32;
    for (i, p) in list.iter().enumerate() {
        let k = (p.passes.1 - p.passes.0) as f32;
        for (a, b) in sum.layers.iter_mut().zip(&p.film.layers) {
            if a.name == "depth" {
                if i > 0 {
                    for (x, &y) in a.data.iter_mut().zip(&b.data) {
                        if y > 0.0 && (*x == 0.0 || y < *x) {
                            *x = y;
                        }
                    }
                }
            } else if i == 0 {
                a.data.iter_mut().for_each(|x| *x *= k);
            } else {
                a.data.iter_mut().zip(&b.data).for_each(|(x, &y)| *x += y * k);
            }
        }
    }
    for l in sum.layers.iter_mut().filter(|l| l.name != "depth") {
        l.data.iter_mut().for_each(|x| *x *= inv);
    }
    sum
}
