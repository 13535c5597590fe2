use raysplat::image::{compare, Film};
use raysplat::integrators::{render, Method, RenderOutput, RenderSettings, SilentProgress};
use raysplat::photon::BandwidthParams;
use raysplat::scene::SceneDesc;
use std::path::Path;

fn load(name: &str) -> SceneDesc {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    raysplat::usd::load_scene(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn run(scene: SceneDesc, s: &RenderSettings) -> RenderOutput {
    render(scene, s, &SilentProgress).expect("render")
}

/// Pixels within `dilate` pixels of a discontinuity of the reference's normal or depth AOV.
fn edge_mask(r: &Film, cos_max: f32, rel_depth: f32, dilate: i32) -> Vec<bool> {
    let (w, h) = (r.width as i32, r.height as i32);
    let nl = r.layer("normal").unwrap();
    let dl = r.layer("depth").unwrap();
    let n = |x: i32, y: i32| {
        let p = nl.pixel((y * w + x) as usize);
        glam::Vec3::new(p[0], p[1], p[2]).normalize_or_zero()
    };
    let d = |x: i32, y: i32| dl.pixel((y * w + x) as usize)[0];
    let mut edge = vec![false; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            for (dx, dy) in [(1, 0), (0, 1)] {
                let (x2, y2) = (x + dx, y + dy);
                if x2 >= w || y2 >= h {
                    continue;
                }
                let (da, db) = (d(x, y), d(x2, y2));
                let jump = n(x, y).dot(n(x2, y2)) < cos_max
                    || (da <= 0.0) != (db <= 0.0)
                    || (da - db).abs() > rel_depth * da.min(db).max(1e-30);
                if jump {
                    edge[(y * w + x) as usize] = true;
                    edge[(y2 * w + x2) as usize] = true;
                }
            }
        }
    }
    let mut out = vec![false; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            if !edge[(y * w + x) as usize] {
                continue;
            }
            for yy in (y - dilate).max(0)..=(y + dilate).min(h - 1) {
                for xx in (x - dilate).max(0)..=(x + dilate).min(w - 1) {
                    out[(yy * w + xx) as usize] = true;
                }
            }
        }
    }
    out
}

fn masked(rgb: &[f32], mask: &[bool]) -> Vec<f32> {
    rgb.chunks(3).zip(mask).filter(|(_, &m)| m).flat_map(|(c, _)| c.iter().copied()).collect()
}

fn bias(t: &[f32], r: &[f32]) -> f64 {
    let st: f64 = t.iter().map(|&v| v as f64).sum();
    let sr: f64 = r.iter().map(|&v| v as f64).sum();
    st / sr - 1.0
}

#[test]
#[ignore]
fn explore() {
    let scene_name = std::env::var("SCENE").unwrap_or("cornell-box".into());
    let refp = std::env::var("REF").unwrap();
    let r = raysplat::image::read_exr(Path::new(&refp)).unwrap();
    let rr = r.rgb("indirect").unwrap();
    let mask = edge_mask(&r, 0.8, 0.05, std::env::var("DIL").map(|v| v.parse().unwrap()).unwrap_or(2));
    let nm = mask.iter().filter(|&&m| m).count();
    eprintln!("mask {nm} of {} pixels", mask.len());
    if let Ok(p) = std::env::var("MASKPNG") {
        let img: Vec<f32> = r.rgb("").unwrap().chunks(3).zip(&mask).flat_map(|(c, &m)| if m { vec![1.0, 0.0, 0.0] } else { c.to_vec() }).collect();
        raysplat::image::write_png(Path::new(&p), r.width, r.height, &img, 0.0).unwrap();
    }
    let rm = masked(&rr, &mask);
    let desc = load(&format!("{scene_name}.usda"));
    let res = [r.width, r.height];
    let configs = std::env::var("CONF").unwrap();
    let seeds: Vec<u64> = std::env::var("SEEDS").unwrap_or("1".into()).split(',').map(|s| s.parse().unwrap()).collect();
    for c in configs.split(';') {
        let f: Vec<&str> = c.split(',').collect();
        let method: Method = f[0].parse().unwrap();
        let photons: usize = f[1].parse().unwrap();
        let x: f32 = f[2].parse().unwrap();
        let sens: f32 = f.get(3).map(|v| v.parse().unwrap()).unwrap_or(0.1);
        let spp: u32 = f.get(4).map(|v| v.parse().unwrap()).unwrap_or(4);
        for &seed in &seeds {
            let mut s = RenderSettings { method, photons, seed, spp, resolution: Some(res), ..Default::default() };
            if method == Method::Pm {
                s.knn = x as usize;
            } else {
                s.bandwidth = BandwidthParams { smoothness: x, sensitivity: sens, ..Default::default() };
            }
            let out = run(desc.clone(), &s);
            let t = out.film.rgb("indirect").unwrap();
            let m = compare(&t, &rr);
            let tm = masked(&t, &mask);
            let mm = compare(&tm, &rm);
            let inv = mask.iter().map(|m| !m).collect::<Vec<_>>();
            let mi = compare(&masked(&t, &inv), &masked(&rr, &inv));
            if std::env::var("CLASSES").is_ok() {
                let nl = r.layer("normal").unwrap();
                let names = ["+X", "-X", "+Y", "-Y", "+Z", "-Z", "other"];
                let mut st = [0f64; 7];
                let mut sr = [0f64; 7];
                let mut cnt = [0usize; 7];
                for i in 0..r.pixel_count() {
                    let n = nl.pixel(i);
                    let a = (0..3).max_by(|&a, &b| n[a].abs().partial_cmp(&n[b].abs()).unwrap()).unwrap();
                    let k = if n[a].abs() > 0.97 { 2 * a + (n[a] < 0.0) as usize } else { 6 };
                    st[k] += t[3 * i..3 * i + 3].iter().map(|&v| v as f64).sum::<f64>();
                    sr[k] += rr[3 * i..3 * i + 3].iter().map(|&v| v as f64).sum::<f64>();
                    cnt[k] += 1;
                }
                let parts: Vec<String> = (0..7).filter(|&k| cnt[k] > 0).map(|k| format!("{} {:+.3} ({})", names[k], st[k] / sr[k] - 1.0, cnt[k])).collect();
                eprintln!("   bias by normal: {}", parts.join(", "));
            }
            eprintln!(
                "{c:<22} seed {seed}: rel_mse {:.5} edge {:.5} interior {:.5} | bias all {:+.4} edge {:+.4} | bw {:.2} cm | {:.2}s",
                m.rel_mse,
                mm.rel_mse,
                mi.rel_mse,
                bias(&t, &rr),
                bias(&tm, &rm),
                out.stats.counter("mean_bandwidth_um").unwrap_or(0) as f64 / 1e4,
                out.stats.total_seconds
            );
        }
    }
}

#[test]
#[ignore]
fn means() {
    for f in std::env::var("FILES").unwrap().split(',') {
        let film = raysplat::image::read_exr(Path::new(f)).unwrap();
        let m = |l: &str| {
            let v = film.rgb(l).unwrap();
            v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
        };
        eprintln!("{f}: beauty {:.4} direct {:.4} indirect {:.4}", m(""), m("direct"), m("indirect"));
    }
}
