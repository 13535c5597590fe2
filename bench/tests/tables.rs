//! The tables as `make bench` prints them, on tiny settings: their rows, their ratio lines, and the
//! consistency of what they print (the timings themselves are not checked).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raysplat-bench"))
        .env("RAYSPLAT_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("convert-cache"))
        .args(args)
        .output()
        .expect("run raysplat-bench")
}

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(p)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `raysplat-bench cache` prints a row per method and direct-light setting (errors finite and
/// positive, the same for every repeat of a render) and, per setting, the rs-rc/rs ratio line with
/// its per-seed error ratios.
#[test]
fn cache_table_prints_every_method_and_the_ratio() {
    let scene = repo("scenes/cornell-glossy.usda");
    let args = ["cache", scene.to_str().unwrap(), "--cache-size", "24", "--cache-photons", "2000", "--cache-reference-spp", "4", "--cache-seeds", "1", "--cache-direct", "sampled,photons"];
    let (once, twice) = (run(&[&args[..], &["--cache-repeat", "1"]].concat()), run(&[&args[..], &["--cache-repeat", "2"]].concat()));
    let rows = |o: &Output| -> Vec<(String, String, f64)> {
        assert!(o.status.success(), "stderr:\n{}", stderr(o));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        for direct in ["sampled", "photons"] {
            let key = format!("rs-rc (auto) vs rs (guiding on, direct light {direct}):");
            let ratio = out.lines().find(|l| l.contains(&key)).unwrap_or_else(|| panic!("no ratio line `{key}`:\n{out}"));
            // one seed: its own error ratio is the mean's
            let after = |key: &str| ratio.split(key).nth(1).and_then(|r| r.split('x').next()).unwrap_or_else(|| panic!("no `{key}` in {ratio}"));
            assert_eq!(after("; error "), after("(per seed: "), "{ratio}");
        }
        out.lines()
            .filter_map(|l| {
                let f: Vec<&str> = l.split_whitespace().collect();
                (f.len() == 11 && ["pm", "rs", "rs-rc"].contains(&f[0])).then(|| (f[0].to_string(), f[2].to_string(), f[7].parse::<f64>().expect("error column")))
            })
            .collect()
    };
    let (a, b) = (rows(&once), rows(&twice));
    let order: Vec<(&str, &str)> = a.iter().map(|(m, d, _)| (m.as_str(), d.as_str())).collect();
    assert_eq!(order, [("pm", "sampled"), ("pm", "photons"), ("rs", "sampled"), ("rs", "photons"), ("rs-rc", "sampled"), ("rs-rc", "photons")]);
    assert!(a.iter().all(|(_, _, e)| e.is_finite() && *e > 0.0), "{a:?}");
    assert_eq!(a, b, "a render's error must not depend on how often it is repeated");
    // the two settings judge different images (the indirect layer; the whole image with photons' direct light)
    assert_ne!(a[2].2, a[3].2, "{a:?}");
}

/// `raysplat-bench photons` prints the pm and rs rows (finite, positive errors), the rs/pm line, and
/// the search comparison, whose per-point line is the two timings divided by the points found.
#[test]
fn photon_table_prints_both_methods_and_the_search_comparison() {
    let scene = repo("scenes/cornell-box.usda");
    let o = run(&["photons", scene.to_str().unwrap(), "--table-resolution", "32x24", "--table-photons", "3000", "--table-reference-spp", "4", "--table-repeat", "1"]);
    assert!(o.status.success(), "stderr:\n{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.lines().next().is_some_and(|l| l.contains("32x24 x 4 eye spp, M = 3000 stored photons")), "{out}");
    let row = |name: &str| -> Vec<f64> {
        let l = out.lines().find(|l| l.trim_start().starts_with(name)).unwrap_or_else(|| panic!("no {name} row:\n{out}"));
        l.split('|').nth(2).unwrap().split_whitespace().map(|v| v.parse().expect("error column")).collect()
    };
    for name in ["PM (100 k-NN)", "RS (C = "] {
        let e = row(name);
        assert!(e.len() == 2 && e.iter().all(|v| v.is_finite()), "{name}: {e:?}");
    }
    assert!(out.contains("rs / pm: T_S ") && out.contains("(goal: ΣT ≤ 1x at equal photons, with lower error)"), "{out}");
    // `… splat cones … 0.123s, N points …` and `balls of radius h at the photon hit 0.045s, M points`
    let seconds_points = |key: &str| -> (f64, f64) {
        let l = out.lines().find(|l| l.contains(key)).unwrap_or_else(|| panic!("no `{key}`:\n{out}"));
        let rest = l.split(key).nth(1).unwrap();
        let f: Vec<&str> = rest.split_whitespace().collect();
        (f[0].trim_end_matches("s,").parse().unwrap(), f[1].parse().unwrap())
    };
    let (cone_s, cone_n) = seconds_points("splat cones (segment + extension beyond the hit) ");
    let (ball_s, ball_n) = seconds_points("balls of radius h at the photon hit ");
    assert!(cone_n > 0.0 && ball_n > 0.0, "{out}");
    // the paper's footprint is the bare segment plus a half ball inside the splat cone's extension
    let (_, bare_n) = seconds_points("bare segments ");
    let (_, paper_n) = seconds_points("the paper's footprint (segment + hemisphere beyond the hit, §5 Fig. 4) ");
    assert!(bare_n < paper_n && paper_n <= cone_n, "bare {bare_n}, paper {paper_n}, splat {cone_n}:\n{out}");
    let per = out.lines().find(|l| l.contains("per point found:")).unwrap_or_else(|| panic!("no per-point line:\n{out}"));
    let ns: Vec<f64> = per.split_whitespace().filter_map(|w| w.parse().ok()).collect();
    assert_eq!(ns.len(), 2, "{per}");
    // the printed seconds have 3 decimals: compare within their rounding
    for (v, s, n) in [(ns[0], cone_s, cone_n), (ns[1], ball_s, ball_n)] {
        assert!((v - s * 1e9 / n).abs() <= 0.0005 * 1e9 / n + 0.05, "{per}: {v} against {s}s / {n}");
    }
}
