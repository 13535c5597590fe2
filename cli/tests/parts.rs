//! Parts of a render (`--tile`, `--crop`, `--passes`/`--pass-range`) and `raysplat merge`: merged
//! parts against the one-machine render, the parts' headers, and the parts merge refuses.
//! Cost: about 40 renders of the Cornell box at 32×32 (a few seconds).

use raysplat::image::{read_exr, read_exr_string_attribute, Film};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_raysplat"));
    c.env("RAYSPLAT_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("convert-cache"));
    c
}

fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box.usda").to_str().unwrap().to_string()
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("run raysplat")
}

fn ok(args: &[&str]) {
    let o = run(args);
    assert!(o.status.success(), "raysplat {args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// Render the Cornell box at 32×32 with `method` and `extra` flags to `out`.
fn render(method: &str, extra: &[&str], out: &Path) {
    let s = scene();
    let mut args = vec!["render", &s, "--method", method, "--resolution", "32x32", "--photons", "5000", "-o", out.to_str().unwrap()];
    // --spp 2 --seed 3 unless `extra` gives them
    for (flag, value) in [("--spp", "2"), ("--seed", "3")] {
        if !extra.contains(&flag) {
            args.extend([flag, value]);
        }
    }
    args.extend_from_slice(extra);
    ok(&args);
}

fn merge(parts: &[PathBuf], out: &Path) -> Output {
    let mut args: Vec<&str> = vec!["merge"];
    args.extend(parts.iter().map(|p| p.to_str().unwrap()));
    args.extend(["-o", out.to_str().unwrap()]);
    run(&args)
}

/// Largest difference between two films over every layer, relative to the value (0: identical bits).
fn max_rel_diff(a: &Film, b: &Film) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let names = |f: &Film| f.layers.iter().map(|l| (l.name.clone(), l.channels.clone())).collect::<Vec<_>>();
    assert_eq!(names(a), names(b));
    let mut worst = 0.0f32;
    for (la, lb) in a.layers.iter().zip(&b.layers) {
        for (x, y) in la.data.iter().zip(&lb.data) {
            if x.to_bits() != y.to_bits() {
                worst = worst.max((x - y).abs() / x.abs().max(y.abs()).max(1e-3));
            }
        }
    }
    worst
}

/// `method` rendered as three tiles (`DIR/METHOD-I.exr`) merged into `DIR/METHOD-merged.exr`.
fn render_tiles_and_merge(method: &str, d: &Path) -> PathBuf {
    let tiles: Vec<PathBuf> = (0..3).map(|i| d.join(format!("{method}-{i}.exr"))).collect();
    for (i, t) in tiles.iter().enumerate() {
        render(method, &["--tile", &format!("{i}/3")], t);
    }
    let merged = d.join(format!("{method}-merged.exr"));
    let o = merge(&tiles, &merged);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    merged
}

#[test]
fn tiles_merge_into_the_one_machine_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for method in ["pt", "pm", "rs"] {
        let whole = d.join(format!("{method}.exr"));
        render(method, &[], &whole);
        let merged = render_tiles_and_merge(method, d);
        let diff = max_rel_diff(&read_exr(&merged).unwrap(), &read_exr(&whole).unwrap());
        // pt and pm: every pixel's numbers come from (seed, pixel) and the shared photons alone;
        // rs sums a photon's splats on the samples of one pixel in the order of its per-tile
        // kd-tree, which a crop changes: float rounding, far below the noise
        let bound = if method == "rs" { 1e-5 } else { 0.0 };
        assert!(diff <= bound, "{method}: merged tiles differ from the whole render by {diff}");
    }
    // a crop window is the same pixels as the tile of that window
    let crop = d.join("crop.exr");
    render("pt", &["--crop", "0,10,32,21"], &crop);
    assert_eq!(max_rel_diff(&read_exr(&crop).unwrap(), &read_exr(&d.join("pt-1.exr")).unwrap()), 0.0);
    let attr = |p: &Path, n: &str| read_exr_string_attribute(p, n).unwrap().unwrap_or_else(|| panic!("{} has no {n}", p.display()));
    assert_eq!(attr(&crop, "raysplat:crop"), "0,10,32,21");
    assert_eq!(attr(&crop, "raysplat:full_resolution"), "32x32");
    assert_eq!(attr(&crop, "raysplat:scene_sha256").len(), 64);
    assert!(attr(&crop, "raysplat:part_settings").contains("\"raysplat:seed\",\"3\""));
}

/// RMSE between the indirect layers of two films.
fn rmse_indirect(a: &Film, b: &Film) -> f64 {
    let (x, y) = (a.rgb("indirect").unwrap(), b.rgb("indirect").unwrap());
    (x.iter().zip(&y).map(|(p, q)| ((p - q) as f64).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
}

/// The radiance cache of rs-rc and the final-gathering methods' caches place their records over
/// the image rendered, so a tile's records are others than the whole image's: merged tiles are
/// another draw of the same estimate (the same photons), not the same bits. Their indirect light
/// (all that differs: the eye pass is the same) differs from the one-machine render's by less than
/// two seeds' do (which also draw new photons and eye samples): measured 0.3–0.5 times.
#[test]
fn cached_methods_tiles_differ_by_less_than_their_noise() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for method in ["rs-rc", "pm-fg", "rpm-fg", "rs-fg", "he-fg"] {
        let (whole, other) = (d.join(format!("{method}.exr")), d.join(format!("{method}-seed4.exr")));
        render(method, &[], &whole);
        render(method, &["--seed", "4"], &other);
        let merged = render_tiles_and_merge(method, d);
        let w = read_exr(&whole).unwrap();
        let (tiles_err, seed_err) = (rmse_indirect(&read_exr(&merged).unwrap(), &w), rmse_indirect(&read_exr(&other).unwrap(), &w));
        eprintln!("{method}: merged tiles' indirect light differs from the whole render's by an RMSE of {tiles_err:.5}, another seed's by {seed_err:.5}");
        assert!(tiles_err < seed_err, "{method}: merged tiles differ from the whole render by {tiles_err}, more than another seed ({seed_err})");
    }
}

#[test]
fn passes_merge_into_the_one_machine_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for method in ["pt", "rs", "pm"] {
        let parts: Vec<PathBuf> = [(0, 1), (1, 3), (3, 4)].iter().map(|(a, b)| d.join(format!("{method}-{a}-{b}.exr"))).collect();
        for (p, (a, b)) in parts.iter().zip([(0, 1), (1, 3), (3, 4)]) {
            render(method, &["--passes", "4", "--pass-range", &format!("{a}:{b}")], p);
        }
        assert_eq!(read_exr_string_attribute(&parts[1], "raysplat:pass_range").unwrap().as_deref(), Some("1:3"));
        let merged = d.join(format!("{method}-merged.exr"));
        let o = merge(&parts, &merged);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let whole = d.join(format!("{method}-whole.exr"));
        // the path tracer's 4 passes of 2 samples are its 8 samples per pixel
        if method == "pt" {
            render(method, &["--spp", "8"], &whole);
        } else {
            render(method, &["--passes", "4"], &whole);
        }
        let (mut m, mut w) = (read_exr(&merged).unwrap(), read_exr(&whole).unwrap());
        if method == "pt" {
            // the path tracer's normal is its samples' summed normal, normalised: merged passes
            // average the passes' unit normals instead (the photon methods' passes do so too)
            m.layers.retain(|l| l.name != "normal");
            w.layers.retain(|l| l.name != "normal");
        }
        let diff = max_rel_diff(&m, &w);
        // the passes' sums are taken in another grouping: float rounding
        assert!(diff <= 1e-5, "{method}: merged passes differ from the whole render by {diff}");
        assert_eq!(read_exr_string_attribute(&merged, "raysplat:pass_range").unwrap().as_deref(), Some("0:4"));
    }
    // progressive pass 0 is the render without passes (its seed, its bandwidth)
    let (one, plain) = (d.join("one.exr"), d.join("plain.exr"));
    render("rs", &["--passes", "8", "--pass-range", "0:1"], &one);
    render("rs", &[], &plain);
    assert_eq!(max_rel_diff(&read_exr(&one).unwrap(), &read_exr(&plain).unwrap()), 0.0);
    // later passes shrink the bandwidth: pass 7 alone is another image
    let seventh = d.join("seventh.exr");
    render("rs", &["--passes", "8", "--pass-range", "7:8"], &seventh);
    assert!(max_rel_diff(&read_exr(&seventh).unwrap(), &read_exr(&plain).unwrap()) > 1e-3);
}

#[test]
fn merge_refuses_parts_that_do_not_belong_together() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |n: &str| d.join(n);
    render("pt", &["--passes", "4", "--pass-range", "0:1"], &p("a.exr"));
    render("pt", &["--passes", "4", "--pass-range", "1:2", "--seed", "4"], &p("seed.exr"));
    render("pt", &["--passes", "4", "--pass-range", "2:3"], &p("gap.exr"));
    render("pt", &["--tile", "0/3"], &p("t0.exr"));
    render("pt", &["--tile", "2/3"], &p("t2.exr"));
    let refused = |parts: &[&str], needles: &[&str]| {
        let o = merge(&parts.iter().map(|n| p(n)).collect::<Vec<_>>(), &p("out.exr"));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{parts:?}: {err}");
        for n in needles {
            assert!(err.contains(n), "{parts:?}: {n:?} not in {err}");
        }
        assert!(!p("out.exr").exists());
    };
    refused(&["a.exr", "seed.exr"], &["seed.exr", "setting seed differs", "4 vs 3"]);
    refused(&["a.exr", "gap.exr"], &["gap.exr", "gap"]);
    refused(&["a.exr", "t0.exr"], &["t0.exr", "differs"]);
    refused(&["t0.exr", "t2.exr"], &["(0, 10)", "tile missing"]);
    // never over an input: the part is left as it was
    let before = std::fs::read(p("a.exr")).unwrap();
    let o = run(&["merge", p("a.exr").to_str().unwrap(), "-o", p("a.exr").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("is the same file as the input"));
    assert_eq!(std::fs::read(p("a.exr")).unwrap(), before);
    // a render that is no part (an EXR without the header) is named
    std::fs::write(p("junk.exr"), b"not an exr").unwrap();
    refused(&["a.exr", "junk.exr"], &["junk.exr"]);
}
