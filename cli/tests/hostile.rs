//! The hostile-input battery: `render`, `convert` and `compare` against malformed, truncated and
//! fuzzed `.rss`, EXR, USD text, crate (`.usdc`) and package (`.usdz`) files, absurd flags, output
//! paths that must not be written, unwritable and shared caches, and signals. Every case runs the
//! binary in a directory of its own and checks: the exit status expected (2 for bad input), no panic,
//! abort, signal death or Python traceback, no hang (a 30 s guard, not a speed assertion), and the
//! directory unchanged but for the outputs it may write (digests before and after; no temporary
//! left anywhere, the cache included). The figures — cases, panics, aborts, hangs, wrong successes,
//! files left or changed, and the peak memory of the worst input (`/usr/bin/time`) — are printed
//! (`cargo test --release --test hostile -- --nocapture`, or `make fuzz` for the long run).
//!
//! `RAYSPLAT_HOSTILE_SCALE=N` multiplies the number of fuzzed inputs (flips, truncations, crafted
//! counts); `make fuzz` runs N = 8 and 20 000 property cases. The property tests below run the
//! `.rss` reader and the EXR reader in-process on mutated files.

#[path = "../../tests/common/mod.rs"]
mod common;
#[path = "../../tests/common/extreme_scenes.rs"]
mod extreme_scenes;
#[path = "../../tests/common/guarded.rs"]
mod guarded;

use guarded::{changes, digest, Outcome};
use proptest::prelude::*;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::time::Duration;

/// Hang guard of one case: longer is a hang (the slowest case, a USD conversion, takes ~3 s).
const LIMIT: Duration = Duration::from_secs(30);

/// What a case must end with.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Expect {
    /// Exit status 2 (bad input), nothing written.
    Refused,
    /// Exit status 0.
    Success,
    /// 0 or 2 (a fuzzed file may still be valid).
    Either,
    /// Ended by the signal the case sends: exit status 128 + it.
    Signal(i32),
}

/// One command against one prepared directory.
struct Case {
    name: String,
    dir: PathBuf,
    args: Vec<OsString>,
    env: Vec<(&'static str, OsString)>,
    expect: Expect,
    /// Files the command may write or change (relative to `dir`).
    outputs: Vec<PathBuf>,
    /// Stdout must contain this.
    stdout_has: Option<&'static str>,
    /// Send this signal once this file (relative to `dir`, a prefix of a name in it) appears.
    signal: Option<(&'static str, &'static str)>,
}

fn scale() -> usize {
    std::env::var("RAYSPLAT_HOSTILE_SCALE").ok().and_then(|s| s.parse().ok()).unwrap_or(1).max(1)
}

/// The inputs every case may use, written once.
struct Inputs {
    rss: Vec<u8>,
    exr: Vec<u8>,
    usdc: Vec<u8>,
    root: tempfile::TempDir,
}

impl Inputs {
    fn new() -> Inputs {
        let root = tempfile::tempdir().unwrap();
        let rss_path = root.path().join("room.rss");
        raysplat::scene::format::save(&extreme_scenes::room(0.6, 10.0), &rss_path).unwrap();
        let rss = std::fs::read(&rss_path).unwrap();
        let exr_path = root.path().join("room.exr");
        let o = Command::new(guarded::bin_path())
            .args(["render", rss_path.to_str().unwrap(), "--method", "pt", "--spp", "2", "--resolution", "12x10", "-o", exr_path.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let exr = std::fs::read(&exr_path).unwrap();
        let usdc = tri_usdc(root.path());
        Inputs { rss, exr, usdc, root }
    }
}

/// A small crate file (a triangle and a light) written by usd-core.
fn tri_usdc(dir: &Path) -> Vec<u8> {
    let p = dir.join("tri.usdc");
    let script = format!(
        "from pxr import Usd, UsdGeom, UsdLux\ns = Usd.Stage.CreateNew({:?})\nUsdGeom.SetStageMetersPerUnit(s, 1)\n\
         m = UsdGeom.Mesh.Define(s, '/World/Tri')\nm.CreatePointsAttr([(0,0,0),(1,0,0),(0,1,0)])\n\
         m.CreateFaceVertexCountsAttr([3])\nm.CreateFaceVertexIndicesAttr([0,1,2])\nUsdLux.DistantLight.Define(s, '/Sun')\ns.GetRootLayer().Save()\n",
        p.to_str().unwrap()
    );
    let python = raysplat::usd::find_python(None).expect("a Python with usd-core (make setup)");
    let o = Command::new(python).arg("-c").arg(script).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read(p).unwrap()
}

/// `.rss` bytes with the JSON header edited by `f` and the checksum made right again (so the
/// parser behind the checksum is what meets the damage).
fn craft(rss: &[u8], f: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let hl = u64::from_le_bytes(rss[16..24].try_into().unwrap()) as usize;
    let mut header: serde_json::Value = serde_json::from_slice(&rss[24..24 + hl]).unwrap();
    let blob = &rss[(24 + hl).div_ceil(16) * 16..];
    f(&mut header);
    let json = serde_json::to_vec(&header).unwrap();
    with_checksum(assemble(&rss[..12], &json, blob))
}

fn assemble(head: &[u8], json: &[u8], blob: &[u8]) -> Vec<u8> {
    let mut out = head.to_vec();
    out.extend_from_slice(&[0; 4]);
    out.extend_from_slice(&(json.len() as u64).to_le_bytes());
    out.extend_from_slice(json);
    out.resize(out.len().div_ceil(16) * 16, 0);
    out.extend_from_slice(blob);
    out
}

fn with_checksum(mut b: Vec<u8>) -> Vec<u8> {
    if b.len() >= 16 {
        let crc = crc32fast::hash(&b[16..]);
        b[12..16].copy_from_slice(&crc.to_le_bytes());
    }
    b
}

/// A builder of cases, each in a fresh directory under the battery's root.
struct Cases<'a> {
    inputs: &'a Inputs,
    list: Vec<Case>,
}

impl Cases<'_> {
    /// A new case directory holding `files` (name, bytes).
    fn dir(&self, files: &[(&str, &[u8])]) -> PathBuf {
        let d = self.inputs.root.path().join(format!("case{}", self.list.len()));
        std::fs::create_dir_all(d.join("tmp")).unwrap();
        for (name, bytes) in files {
            std::fs::write(d.join(name), bytes).unwrap();
        }
        d
    }

    fn add(&mut self, name: String, dir: PathBuf, args: &[&str], expect: Expect, outputs: &[&str]) -> &mut Case {
        let args = args.iter().map(|a| if a.starts_with('@') { dir.join(&a[1..]).into_os_string() } else { OsString::from(a) }).collect();
        self.list.push(Case {
            name,
            args,
            env: Vec::new(),
            expect,
            outputs: outputs.iter().map(PathBuf::from).collect(),
            stdout_has: None,
            signal: None,
            dir,
        });
        self.list.last_mut().unwrap()
    }

    /// `render` of `scene` (a file of the case directory) to `@out.exr` with `extra` flags, and
    /// `--method pt --spp 1 --resolution 6x4` where `extra` does not say otherwise.
    fn render(&mut self, name: String, files: &[(&str, &[u8])], scene: &str, extra: &[&str], expect: Expect) {
        let dir = self.dir(files);
        let scene = format!("@{scene}");
        let mut args: Vec<&str> = vec!["render", scene.as_str()];
        for (flag, value) in [("-o", "@out.exr"), ("--method", "pt"), ("--spp", "1"), ("--resolution", "6x4")] {
            if !extra.iter().any(|a| *a == flag || a.starts_with(&format!("{flag}="))) {
                args.extend([flag, value]);
            }
        }
        args.extend_from_slice(extra);
        self.add(name, dir, &args, expect, &["out.exr"]);
    }
}

/// Evenly spread positions in `0..len`, `n` of them.
fn spread(len: usize, n: usize) -> Vec<usize> {
    (0..n).map(|k| k * len / n).collect()
}

fn rss_cases(c: &mut Cases) {
    let rss = c.inputs.rss.clone();
    let s = scale();
    // truncated anywhere: refused
    let mut cuts: Vec<usize> = vec![0, 1, 7, 8, 11, 12, 15, 16, 23, 24, 25];
    cuts.extend(spread(rss.len(), 20 * s));
    cuts.sort_unstable();
    cuts.dedup();
    for n in cuts.into_iter().filter(|&n| n < rss.len()) {
        c.render(format!("rss truncated to {n} bytes"), &[("s.rss", &rss[..n])], "s.rss", &[], Expect::Refused);
    }
    // one bit flipped anywhere: refused by the checksum, never loaded with changed values
    for (k, at) in spread(rss.len(), 90 * s).into_iter().enumerate() {
        let mut b = rss.clone();
        b[at] ^= 1 << (k % 8);
        c.render(format!("rss bit {} of byte {at} flipped", k % 8), &[("s.rss", &b)], "s.rss", &[], Expect::Refused);
    }
    // crafted headers with a right checksum: absurd counts, offsets, types, references
    let huge = [1u64 << 32, 1 << 40, 1 << 62, u64::MAX];
    let mut crafted: Vec<(String, Vec<u8>, Expect)> = Vec::new();
    for array in ["positions", "indices", "material_ids"] {
        for &n in &huge {
            crafted.push((format!("{array} count {n}"), craft(&rss, |h| h["meshes"][0][array]["count"] = n.into()), Expect::Refused));
            crafted.push((format!("{array} offset {n}"), craft(&rss, |h| h["meshes"][0][array]["offset"] = n.into()), Expect::Refused));
        }
        crafted.push((format!("{array} of type f32x9"), craft(&rss, |h| h["meshes"][0][array]["type"] = "f32x9".into()), Expect::Refused));
    }
    for (what, v) in [
        ("normals", serde_json::json!({"type": "f32x3", "offset": 0, "count": 1u64 << 40})),
        ("uvs", serde_json::json!({"type": "f32x2", "offset": 1u64 << 50, "count": 4})),
        ("colors", serde_json::json!({"type": "f32x3", "offset": 0, "count": 1})),
    ] {
        crafted.push((format!("{what} absurd"), craft(&rss, |h| h["meshes"][0][what] = v), Expect::Refused));
    }
    let edits: Vec<(&str, Box<dyn Fn(&mut serde_json::Value)>, Expect)> = vec![
        ("no meshes", Box::new(|h| h["meshes"] = serde_json::json!([])), Expect::Refused),
        ("instance of mesh 10^9", Box::new(|h| h["instances"][0]["mesh"] = 1_000_000_000u64.into()), Expect::Refused),
        ("NaN-free but infinite transform", Box::new(|h| h["instances"][0]["transform"][0][0] = 1e39.into()), Expect::Refused),
        ("material index 10^9", Box::new(|h| h["meshes"][0]["material_ids"]["count"] = 0.into()), Expect::Refused),
        ("light radiance -1", Box::new(|h| h["lights"][0]["radiance"] = serde_json::json!([-1.0, 1.0, 1.0])), Expect::Refused),
        ("light of unknown type", Box::new(|h| h["lights"][0]["type"] = "laser".into()), Expect::Refused),
        ("camera focal length 0", Box::new(|h| h["camera"]["focal_length"] = 0.0.into()), Expect::Refused),
        ("format tag wrong", Box::new(|h| h["format"] = "something".into()), Expect::Refused),
        ("a texture on /dev/zero", Box::new(|h| h["textures"] = serde_json::json!([{"path": "/dev/zero"}])), Expect::Success),
        ("a texture on a directory", Box::new(|h| h["textures"] = serde_json::json!([{"path": "/"}])), Expect::Success),
        ("a dependency on /dev/zero", Box::new(|h| h["dependencies"] = serde_json::json!([{"path": "/dev/zero", "sha256": "00"}])), Expect::Success),
        ("stage resolution 10^6", Box::new(|h| h["resolution"] = serde_json::json!([1000000, 1])), Expect::Success),
        ("a 10^6-character name", Box::new(|h| h["meshes"][0]["name"] = "x".repeat(1_000_000).into()), Expect::Success),
        ("header not an object", Box::new(|h| *h = serde_json::json!([1, 2, 3])), Expect::Refused),
    ];
    for (name, f, expect) in edits {
        crafted.push((name.to_string(), craft(&rss, f), expect));
    }
    // a header length beyond the file, a deeply nested header, an older version
    let mut b = rss.clone();
    b[16..24].copy_from_slice(&(u64::MAX - 8).to_le_bytes());
    crafted.push(("header length 2^64 - 9".into(), with_checksum(b), Expect::Refused));
    let nested = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
    crafted.push(("a header nested 100 000 deep".into(), with_checksum(assemble(&rss[..12], nested.as_bytes(), &[])), Expect::Refused));
    let mut b = rss.clone();
    b[8..12].copy_from_slice(&1u32.to_le_bytes());
    crafted.push(("version 1".into(), with_checksum(b), Expect::Refused));
    crafted.push(("random bytes".into(), (0..5000u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect(), Expect::Refused));
    for (name, bytes, expect) in crafted {
        c.render(format!("rss crafted: {name}"), &[("s.rss", &bytes)], "s.rss", &[], expect);
    }
    // render without --resolution: the crafted stage resolution is an error naming it
    let b = craft(&rss, |h| h["resolution"] = serde_json::json!([0, 7]));
    let dir = c.dir(&[("s.rss", &b)]);
    c.add("rss crafted: stage resolution 0x7, no --resolution".into(), dir, &["render", "@s.rss", "-o", "@out.exr"], Expect::Refused, &[]);
}

fn flag_cases(c: &mut Cases) {
    let rss = c.inputs.rss.clone();
    let refused: &[&[&str]] = &[
        &["--spp", "0"], &["--spp", "4294967295"], &["--resolution", "0x0"], &["--resolution", "65537x1"],
        &["--resolution", "99999999999x1"], &["--resolution=-1x5"], &["--resolution", "banana"], &["--time", "nan"],
        &["--time", "inf"], &["--time", "1e300"], &["--time=-1"], &["--time", "0"], &["--method", "pm", "--photons", "1000000000000"],
        &["--threads", "100000"], &["--max-depth", "0"], &["--method", "rpm-fg", "--memory", "0"], &["--method", "rpm-fg", "--memory", "-5"],
        &["--method", "rpm-fg", "--memory", "lots"], &["--method", "rpm-fg", "--memory", "512"], &["--method", "pm-fg", "--fg-rays", "1000000000"],
        &["--method", "pm-fg", "--fg-rays", "0"], &["--method", "pm", "--knn", "0"], &["--method", "pm", "--knn", "100000000"],
        &["--method", "rs", "--smoothness", "nan"], &["--method", "rs", "--smoothness", "1e30"], &["--method", "rs", "--max-bandwidth", "0"],
        &["--method", "rs", "--sensitivity", "-1"], &["--light-samples", "0"], &["--light-samples", "100000000"], &["--aa-spp", "100000000"],
        &["--method", "rs", "--filter-radius", "100000000"], &["--method", "he-fg", "--emax", "nan"], &["--method", "he-fg", "--voxel-resolution", "0"],
        &["--method", "he-fg", "--voxel-resolution", "100000000"], &["--method", "he-fg", "--explicit-rays", "100000000"],
        &["--method", "he-fg", "--explicit-allocation", "all"], &["--method", "rs-rc", "--cache-error", "0"], &["--method", "rs-rc", "--cache-error", "1e30"],
        &["--method", "rpm-fg", "--gather-radius", "-1"], &["--method", "pm-fg", "--density-limit", "0"], &["--method", "nope"],
        &["--glossy", "mirror"], &["--emission-guiding", "maybe"], &["--quality", "final"], &["--method", "auto", "--quality", "best"],
        &["--exposure", "1e9"], &["--exposure", "nan"], &["--camera", "/Cam"], &["--frame", "3"], &["--subdivision-level", "99"],
        &["--frames", "1:3", "-o", "@plain.exr"], &["--no-spill", "--spill-dir", "@tmp"], &["--method", "rpm-fg", "--spill-dir", "@missing"],
        &["--method", "pt", "--spp", "1000000000"], &["--method", "rs", "--resolution", "16384x16384", "--spp", "4096"],
    ];
    for f in refused {
        c.render(format!("flags {}", f.join(" ")), &[("s.rss", &rss)], "s.rss", f, Expect::Refused);
    }
    let accepted: &[&[&str]] = &[
        &["--threads", "3"], &["--seed", "18446744073709551615"], &["--method", "rs", "--photons", "0"], &["--method", "pm", "--photons", "1"],
        &["--method", "rpm-fg", "--memory", "1e30G"], &["--aa-spp", "0"], &["--method", "pm-fg", "--gather-radius", "1e-30"],
        &["--exposure=-64"], &["--method", "rpm-fg", "--memory", "1M", "--fg-rays", "16"],
        &["--method", "rpm-fg", "--memory", "1M", "--spill-dir", "@tmp"],
    ];
    for f in accepted {
        c.render(format!("flags {}", f.join(" ")), &[("s.rss", &rss)], "s.rss", f, Expect::Success);
    }
    // commands and arguments clap refuses
    for args in [&["render"][..], &["render", "@s.rss"], &["nonsense"], &["convert", "@s.rss"], &["compare", "@s.rss"], &["render", "@s.rss", "-o"]] {
        let dir = c.dir(&[("s.rss", &rss)]);
        c.add(format!("arguments {}", args.join(" ")), dir, args, Expect::Refused, &[]);
    }
}

fn output_cases(c: &mut Cases) {
    let rss = c.inputs.rss.clone();
    let exr = c.inputs.exr.clone();
    let render = |c: &mut Cases, name: &str, prepare: &dyn Fn(&Path), args: &[&str], expect: Expect, outputs: &[&str]| {
        let dir = c.dir(&[("s.rss", &rss), ("old.exr", &exr)]);
        prepare(&dir);
        let args: Vec<&str> = [&["render", "@s.rss", "--method", "pt", "--spp", "1", "--resolution", "6x4"][..], args].concat();
        c.add(format!("output: {name}"), dir, &args, expect, outputs);
    };
    let none = |_: &Path| {};
    let fifo = |d: &Path| {
        Command::new("mkfifo").arg(d.join("pipe.exr")).status().unwrap();
    };
    let socket = |d: &Path| {
        let l = std::os::unix::net::UnixListener::bind(d.join("sock.exr")).unwrap();
        std::mem::forget(l); // the socket file stays for the case
    };
    let device = |d: &Path| {
        let _ = Command::new("mknod").arg(d.join("null.exr")).args(["c", "1", "3"]).status();
    };
    let links = |d: &Path| {
        std::os::unix::fs::symlink("s.rss", d.join("to-input.exr")).unwrap();
        std::os::unix::fs::symlink("nowhere.exr", d.join("dangling.exr")).unwrap();
        std::os::unix::fs::symlink("old.exr", d.join("to-old.exr")).unwrap();
        std::os::unix::fs::symlink("old.exr", d.join("to-old.png")).unwrap();
        std::fs::hard_link(d.join("s.rss"), d.join("hard")).unwrap();
        std::fs::write(d.join("file"), b"a file").unwrap();
    };
    render(c, "a FIFO", &fifo, &["-o", "@pipe.exr"], Expect::Refused, &[]);
    render(c, "a socket", &socket, &["-o", "@sock.exr"], Expect::Refused, &[]);
    let dev = c.inputs.root.path().join("probe-device");
    if Command::new("mknod").arg(&dev).args(["c", "1", "3"]).status().is_ok_and(|s| s.success()) {
        render(c, "a device", &device, &["-o", "@null.exr"], Expect::Refused, &[]);
    } else {
        eprintln!("skipped the device-node output case: mknod failed (not root?)");
    }
    let _ = std::fs::remove_file(&dev);
    for (name, args) in [
        ("the input", vec!["-o", "@s.rss"]),
        ("a hard link to the input", vec!["-o", "@hard"]),
        ("a symbolic link to the input", vec!["-o", "@to-input.exr"]),
        ("a dangling symbolic link", vec!["-o", "@dangling.exr"]),
        ("the directory", vec!["-o", "@."]),
        ("a missing directory", vec!["-o", "@missing/x.exr"]),
        ("below a regular file", vec!["-o", "@file/x.exr"]),
        ("an empty name", vec!["-o", ""]),
        ("/", vec!["-o", "/"]),
        ("named .png", vec!["-o", "@x.png"]),
        ("named .jpg", vec!["-o", "@x.JPG"]),
        ("named .usda", vec!["-o", "@x.usda"]),
        ("named .rss", vec!["-o", "@x.rss"]),
        ("a preview named .exr", vec!["-o", "@x.exr", "--preview", "@p.exr"]),
        ("a preview over the output", vec!["-o", "@x", "--preview", "@x"]),
        ("a preview over the input", vec!["-o", "@x.exr", "--preview", "@s.rss"]),
        ("a preview through a link to the output", vec!["-o", "@old.exr", "--preview", "@to-old.png"]),
    ] {
        render(c, name, &links, &args, Expect::Refused, &[]);
    }
    render(c, "through a symbolic link to a regular file", &links, &["-o", "@to-old.exr"], Expect::Success, &["old.exr"]);
    render(c, "over an existing image, with a preview", &none, &["-o", "@old.exr", "--preview", "@p.png"], Expect::Success, &["old.exr", "p.png"]);
}

fn compare_cases(c: &mut Cases) {
    let exr = c.inputs.exr.clone();
    let s = scale();
    let mut cuts = spread(exr.len(), 16 * s);
    cuts.dedup();
    for n in cuts {
        let dir = c.dir(&[("t.exr", &exr[..n]), ("r.exr", &exr)]);
        c.add(format!("compare: test truncated to {n} bytes"), dir, &["compare", "@t.exr", "@r.exr"], Expect::Refused, &[]);
    }
    for (k, at) in spread(exr.len(), 30 * s).into_iter().enumerate() {
        let mut b = exr.clone();
        b[at] ^= 1 << (k % 8);
        let dir = c.dir(&[("t.exr", &b), ("r.exr", &exr)]);
        c.add(format!("compare: bit {} of byte {at} flipped", k % 8), dir, &["compare", "@t.exr", "@r.exr", "--json"], Expect::Either, &[]);
    }
    let rss = c.inputs.rss.clone();
    let fifo = |d: &Path| {
        Command::new("mkfifo").arg(d.join("pipe.exr")).status().unwrap();
    };
    for (name, t, prepare) in [
        ("/dev/zero", "/dev/zero", None),
        ("a directory", "@.", None),
        ("a FIFO", "@pipe.exr", Some(&fifo as &dyn Fn(&Path))),
        ("an empty file", "@empty.exr", None),
        ("a scene file", "@s.rss", None),
        ("a missing file", "@missing.exr", None),
    ] {
        let dir = c.dir(&[("r.exr", &exr), ("empty.exr", b""), ("s.rss", &rss)]);
        if let Some(p) = prepare {
            p(&dir);
        }
        c.add(format!("compare: test is {name}"), dir, &["compare", t, "@r.exr"], Expect::Refused, &[]);
    }
    for (name, args, expect, outputs) in [
        ("a missing layer", &["compare", "@r.exr", "@r.exr", "--layer", "nope"][..], Expect::Refused, &[][..]),
        ("the error image over the input", &["compare", "@r.exr", "@r.exr", "--error-image", "@r.exr"], Expect::Refused, &[]),
        ("the error image named .exr", &["compare", "@r.exr", "@r.exr", "--error-image", "@e.exr"], Expect::Refused, &[]),
        ("the error image", &["compare", "@r.exr", "@r.exr", "--error-image", "@e.png"], Expect::Success, &["e.png"]),
    ] {
        let dir = c.dir(&[("r.exr", &exr)]);
        c.add(format!("compare: {name}"), dir, args, expect, outputs);
    }
    // a test image with NaN and infinite pixels: the error is infinite
    let film = raysplat::image::read_exr(&c.inputs.root.path().join("room.exr")).unwrap();
    let mut spoiled = film.clone();
    spoiled.layers[0].data[0] = f32::NAN;
    spoiled.layers[0].data[8] = f32::INFINITY;
    let p = c.inputs.root.path().join("nan.exr");
    raysplat::image::write_exr(&p, &spoiled, &[]).unwrap();
    let nan = std::fs::read(&p).unwrap();
    let dir = c.dir(&[("t.exr", &nan), ("r.exr", &exr)]);
    c.add("compare: NaN and Inf in the test".into(), dir, &["compare", "@t.exr", "@r.exr", "--json"], Expect::Success, &[]).stdout_has = Some("\"rmse\":\"inf\"");
    let dir = c.dir(&[("t.exr", &nan), ("r.exr", &exr)]);
    c.add("compare: NaN and Inf in the reference".into(), dir, &["compare", "@r.exr", "@t.exr"], Expect::Success, &[]).stdout_has = Some("nan             0 (test), 2 (reference)");
    // another size
    let mut small = film.clone();
    small.width = 1;
    small.height = 1;
    for l in &mut small.layers {
        let n = l.channels.len();
        l.data.truncate(n);
    }
    let p = c.inputs.root.path().join("small.exr");
    raysplat::image::write_exr(&p, &small, &[]).unwrap();
    let small = std::fs::read(&p).unwrap();
    let dir = c.dir(&[("t.exr", &small), ("r.exr", &exr)]);
    c.add("compare: another size".into(), dir, &["compare", "@t.exr", "@r.exr"], Expect::Refused, &[]);
}

const USD_HEAD: &str = "#usda 1.0\n(\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n";
const SUN: &str = "def DistantLight \"Sun\" {\n    float inputs:intensity = 3\n}\n";

fn mesh(points: &str, counts: &str, indices: &str) -> String {
    format!("{USD_HEAD}def Mesh \"M\" {{\n    int[] faceVertexCounts = [{counts}]\n    int[] faceVertexIndices = [{indices}]\n    point3f[] points = [{points}]\n}}\n{SUN}")
}

fn usd_cases(c: &mut Cases) {
    let s = scale();
    let quad = "(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)";
    let texts: Vec<(&str, String, Expect)> = vec![
        ("a good quad", mesh(quad, "4", "0, 1, 2, 3"), Expect::Success),
        ("a syntax error", format!("{USD_HEAD}def Mesh \"M\" {{\n    point3f[] points = [(0, 0\n}}\n"), Expect::Refused),
        ("not USD at all", "hello, world\n".into(), Expect::Refused),
        ("an empty file", String::new(), Expect::Refused),
        ("NaN points", mesh("(0, 0, 0), (nan, 0, 0), (1, 1, 0), (0, 1, 0)", "4", "0, 1, 2, 3"), Expect::Refused),
        ("infinite points", mesh("(0, 0, 0), (inf, 0, 0), (1, 1, 0), (0, 1, 0)", "4", "0, 1, 2, 3"), Expect::Refused),
        ("an index out of range", mesh(quad, "4", "0, 1, 2, 99"), Expect::Refused),
        ("a negative index", mesh(quad, "4", "0, 1, 2, -1"), Expect::Refused),
        ("counts summing past the indices", mesh(quad, "400000000", "0, 1, 2, 3"), Expect::Refused),
        ("a negative count", mesh(quad, "-4", "0, 1, 2, 3"), Expect::Refused),
        ("no geometry", format!("{USD_HEAD}{SUN}"), Expect::Refused),
        ("a sublayer of itself", format!("#usda 1.0\n(\n    subLayers = [@./stage.usda@]\n)\n{SUN}"), Expect::Refused),
        ("a missing reference", format!("{USD_HEAD}def \"R\" (references = @missing.usda@) {{}}\n{SUN}"), Expect::Refused),
        ("a reference to /dev/zero", format!("{USD_HEAD}def \"R\" (references = @/dev/zero@) {{}}\n{}", mesh(quad, "4", "0, 1, 2, 3").replace(USD_HEAD, "")), Expect::Either),
        ("a texture on /dev/zero", format!("{}def Material \"T\" {{\n token outputs:surface.connect = </T/S.outputs:surface>\n def Shader \"S\" {{\n  uniform token info:id = \"UsdPreviewSurface\"\n  color3f inputs:diffuseColor.connect = </T/X.outputs:rgb>\n  token outputs:surface\n }}\n def Shader \"X\" {{\n  uniform token info:id = \"UsdUVTexture\"\n  asset inputs:file = @/dev/zero@\n  float3 outputs:rgb\n }}\n}}\n", mesh(quad, "4", "0, 1, 2, 3").replace("}\ndef Distant", " rel material:binding = </T>\n}\ndef Distant")), Expect::Success),
        ("a stage resolution of 10^6", format!("{}def RenderSettings \"RS\" {{\n uniform int2 resolution = (1000000, 3)\n}}\n", mesh(quad, "4", "0, 1, 2, 3")), Expect::Success),
        ("a camera with focal length 0", format!("{}def Camera \"C\" {{\n float focalLength = 0\n}}\n", mesh(quad, "4", "0, 1, 2, 3")), Expect::Either),
        ("metersPerUnit 0", mesh(quad, "4", "0, 1, 2, 3").replace("metersPerUnit = 1", "metersPerUnit = 0"), Expect::Refused),
    ];
    for (name, text, expect) in &texts {
        c.render(format!("usda: {name}"), &[("stage.usda", text.as_bytes())], "stage.usda", &[], *expect);
    }
    // truncated text
    let good = texts[0].1.as_bytes().to_vec();
    for n in spread(good.len(), 4 * s).into_iter().skip(1) {
        c.render(format!("usda truncated to {n} bytes"), &[("stage.usda", &good[..n])], "stage.usda", &[], Expect::Either);
    }
    // crate files: truncated, and counts patched to 2^30 (the check must refuse before usd-core
    // allocates: a 849-byte file claiming 2^30 tokens took 8.5 GB)
    let usdc = c.inputs.usdc.clone();
    for n in spread(usdc.len(), 5 * s).into_iter().skip(1) {
        c.render(format!("usdc truncated to {n} bytes"), &[("stage.usdc", &usdc[..n])], "stage.usdc", &[], Expect::Refused);
    }
    let words = usdc.len() / 4;
    for at in spread(words, 10 * s).into_iter().map(|w| 4 * w) {
        let mut b = usdc.clone();
        b[at..at + 4].copy_from_slice(&(1u32 << 30).to_le_bytes());
        c.render(format!("usdc word at byte {at} set to 2^30"), &[("stage.usdc", &b)], "stage.usdc", &[], Expect::Either);
    }
    // packages: the crate file zipped, truncated, or with a member declaring 2^31 bytes
    let zip = store_zip(&[("stage.usdc", &usdc)]);
    c.render("usdz: a crate file".into(), &[("stage.usdz", &zip)], "stage.usdz", &[], Expect::Success);
    c.render("usdz truncated".into(), &[("stage.usdz", &zip[..zip.len() / 2])], "stage.usdz", &[], Expect::Refused);
    let mut bomb = zip.clone();
    declare_size(&mut bomb, 1 << 31);
    c.render("usdz: a member declaring 2^31 bytes".into(), &[("stage.usdz", &bomb)], "stage.usdz", &[], Expect::Refused);
    let mut crafted = usdc.clone();
    crafted[212..216].copy_from_slice(&(1u32 << 30).to_le_bytes());
    c.render("usdz: a crate file claiming 2^30 tokens".into(), &[("stage.usdz", &store_zip(&[("stage.usdc", &crafted)]))], "stage.usdz", &[], Expect::Refused);
    // a reference to a FIFO (usd-core would wait for a writer for ever) and to a device
    let fifo_ref = format!("{USD_HEAD}def \"R\" (references = @./ref.usda@) {{}}\n{SUN}");
    let dir = c.dir(&[("stage.usda", fifo_ref.as_bytes())]);
    Command::new("mkfifo").arg(dir.join("ref.usda")).status().unwrap();
    c.add("usda: a reference to a FIFO".into(), dir, &["render", "@stage.usda", "-o", "@out.exr"], Expect::Refused, &[]);
    let dir = c.dir(&[("stage.usda", fifo_ref.as_bytes())]);
    std::os::unix::fs::symlink("/dev/zero", dir.join("ref.usda")).unwrap();
    c.add("usda: a reference to /dev/zero".into(), dir, &["render", "@stage.usda", "-o", "@out.exr"], Expect::Refused, &[]);
    // stage options a stage cannot honour
    let text = texts[0].1.as_bytes();
    for (name, f) in [
        ("a camera it lacks", &["--camera", "/Nope"][..]),
        ("--frame nan", &["--frame", "nan"]),
        ("--subdivision-level 7", &["--subdivision-level", "7"]),
        ("frames without #", &["--frames", "1:2"]),
    ] {
        c.render(format!("usda: {name}"), &[("stage.usda", text)], "stage.usda", f, Expect::Refused);
    }
    // convert: over its input, to another format's name, atomically on failure
    let files: [(&str, &[u8]); 3] = [("stage.usda", text), ("nan.usda", texts[4].1.as_bytes()), ("old.rss", b"previous")];
    for (name, args, expect, outputs) in [
        ("onto the input", &["convert", "@stage.usda", "@stage.usda"][..], Expect::Refused, &[][..]),
        ("to a name of another format", &["convert", "@stage.usda", "@x.exr"], Expect::Refused, &[]),
        ("a stage with NaN points over an old file", &["convert", "@nan.usda", "@old.rss"], Expect::Refused, &[]),
        ("a good stage", &["convert", "@stage.usda", "@new.rss"], Expect::Success, &["new.rss"]),
    ] {
        let dir = c.dir(&files);
        c.add(format!("convert: {name}"), dir, args, expect, outputs);
    }
}

/// A zip archive of stored (uncompressed) members, as a .usdz is.
fn store_zip(members: &[(&str, &[u8])]) -> Vec<u8> {
    let (mut out, mut central) = (Vec::new(), Vec::new());
    for (name, data) in members {
        let offset = out.len() as u32;
        let crc = crc32fast::hash(data);
        let mut local = Vec::new();
        local.extend_from_slice(&0x04034b50u32.to_le_bytes());
        local.extend_from_slice(&[20, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
        local.extend_from_slice(&crc.to_le_bytes());
        local.extend_from_slice(&(data.len() as u32).to_le_bytes());
        local.extend_from_slice(&(data.len() as u32).to_le_bytes());
        local.extend_from_slice(&(name.len() as u16).to_le_bytes());
        // usdz aligns member data to 64 bytes with an extra field
        let pad = (64 - (out.len() + local.len() + 2 + name.len() + 4) % 64) % 64;
        local.extend_from_slice(&((pad + 4) as u16).to_le_bytes());
        local.extend_from_slice(name.as_bytes());
        local.extend_from_slice(&0x1986u16.to_le_bytes());
        local.extend_from_slice(&(pad as u16).to_le_bytes());
        local.extend(std::iter::repeat_n(0u8, pad));
        out.extend_from_slice(&local);
        out.extend_from_slice(data);
        central.extend_from_slice(&0x02014b50u32.to_le_bytes());
        central.extend_from_slice(&[20, 0, 20, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
        central.extend_from_slice(&crc.to_le_bytes());
        central.extend_from_slice(&(data.len() as u32).to_le_bytes());
        central.extend_from_slice(&(data.len() as u32).to_le_bytes());
        central.extend_from_slice(&(name.len() as u16).to_le_bytes());
        central.extend_from_slice(&[0; 12]);
        central.extend_from_slice(&offset.to_le_bytes());
        central.extend_from_slice(name.as_bytes());
    }
    let start = out.len() as u32;
    out.extend_from_slice(&central);
    out.extend_from_slice(&0x06054b50u32.to_le_bytes());
    out.extend_from_slice(&[0, 0, 0, 0]);
    out.extend_from_slice(&(members.len() as u16).to_le_bytes());
    out.extend_from_slice(&(members.len() as u16).to_le_bytes());
    out.extend_from_slice(&(central.len() as u32).to_le_bytes());
    out.extend_from_slice(&start.to_le_bytes());
    out.extend_from_slice(&[0, 0]);
    out
}

/// Make the first member of a zip archive declare `size` uncompressed bytes (central directory).
fn declare_size(zip: &mut [u8], size: u32) {
    let at = zip.windows(4).position(|w| w == 0x02014b50u32.to_le_bytes()).unwrap();
    zip[at + 24..at + 28].copy_from_slice(&size.to_le_bytes());
}

fn cache_cases(c: &mut Cases) {
    let text = mesh("(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)", "4", "0, 1, 2, 3");
    // the cache directory below a regular file (root may write anywhere else): a warning and a
    // temporary cache
    let files: [(&str, &[u8]); 2] = [("stage.usda", text.as_bytes()), ("file", b"x")];
    let dir = c.dir(&files);
    let blocked = dir.join("file/cache").into_os_string();
    let case = c.add("cache: below a regular file".into(), dir, &["render", "@stage.usda", "-o", "@out.exr", "--spp", "1", "--resolution", "4x4"], Expect::Success, &["out.exr", "tmp/raysplat-cache-"]);
    case.env.push(("RAYSPLAT_CACHE_DIR", blocked));
    let dir = c.dir(&files);
    let case = c.add("cache: an unreadable limit".into(), dir, &["render", "@stage.usda", "-o", "@out.exr"], Expect::Refused, &[]);
    case.env.push(("RAYSPLAT_CACHE_LIMIT", "lots".into()));
    let dir = c.dir(&files);
    let case = c.add("cache: a limit of 1K".into(), dir, &["render", "@stage.usda", "-o", "@out.exr", "--spp", "1", "--resolution", "4x4"], Expect::Success, &["out.exr"]);
    case.env.push(("RAYSPLAT_CACHE_LIMIT", "1K".into()));
}

fn signal_cases(c: &mut Cases) {
    let rss = c.inputs.rss.clone();
    for (sig, n) in [("TERM", 15), ("INT", 2), ("HUP", 1)] {
        let dir = c.dir(&[("s.rss", &rss)]);
        let case = c.add(
            format!("signal: SIG{sig} while rpm-fg spills"),
            dir,
            &["render", "@s.rss", "-o", "@out.exr", "--method", "rpm-fg", "--memory", "1M", "--fg-rays", "64", "--spp", "1", "--resolution", "160x160"],
            Expect::Signal(n),
            &[],
        );
        case.signal = Some(("tmp", sig));
    }
}

/// What the battery found.
#[derive(Default, Debug)]
struct Tally {
    cases: usize,
    panics: usize,
    aborts: usize,
    hangs: usize,
    tracebacks: usize,
    wrong_status: usize,
    wrong_successes: usize,
    files: usize,
    worst: Option<(u64, String)>,
    failures: Vec<String>,
}

/// Whether a digest entry is one the case may write: an output (or below one), or a conversion
/// or decoded texture in the case's cache.
fn allowed(case: &Case, p: &Path) -> bool {
    let temporary = p.to_string_lossy().ends_with(".tmp") || p.to_string_lossy().contains("raysplat-spill-");
    !temporary && (case.outputs.iter().any(|o| p.to_string_lossy().starts_with(&*o.to_string_lossy())) || p.starts_with("cache"))
}

fn run_case(case: &Case) -> (Outcome, Vec<String>) {
    let before = digest(&case.dir);
    let mut cmd = Command::new(guarded::bin_path());
    cmd.args(&case.args).current_dir(&case.dir).env("TMPDIR", case.dir.join("tmp")).env("RAYSPLAT_CACHE_DIR", case.dir.join("cache"));
    for (k, v) in &case.env {
        cmd.env(k, v);
    }
    let outcome = match case.signal {
        None => guarded::run(cmd, LIMIT, true),
        Some((watch, sig)) => {
            let watched = case.dir.join(watch);
            let dir = case.dir.clone();
            // the signal goes once the watched directory has an entry (the spill directory)
            let sender = std::thread::spawn(move || {
                let seen = guarded::wait_for(LIMIT, || std::fs::read_dir(&watched).map(|d| d.count() > 0).unwrap_or(false));
                if seen {
                    let pids: Vec<u32> = std::fs::read_dir("/proc")
                        .unwrap()
                        .flatten()
                        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
                        .filter(|p| std::fs::read_link(format!("/proc/{p}/cwd")).is_ok_and(|c| c == dir))
                        .filter(|p| std::fs::read_to_string(format!("/proc/{p}/comm")).is_ok_and(|c| c.trim() == "raysplat"))
                        .collect();
                    for p in pids {
                        guarded::kill(p, sig);
                    }
                }
            });
            let o = guarded::run(cmd, LIMIT, true);
            sender.join().unwrap();
            o
        }
    };
    let keep = |d: guarded::Listing| d.into_iter().filter(|(p, _)| !allowed(case, p)).collect::<guarded::Listing>();
    let problems = changes(&keep(before), &keep(digest(&case.dir)));
    (outcome, problems)
}

fn tally(case: &Case, o: &Outcome, problems: &[String], t: &mut Tally) {
    t.cases += 1;
    let fail = |t: &mut Tally, why: String| t.failures.push(format!("{}: {why}\n  stderr: {}", case.name, o.stderr.trim().lines().take(4).collect::<Vec<_>>().join("\n          ")));
    if o.stderr.contains("panicked") {
        t.panics += 1;
        fail(t, "panic".into());
    }
    if o.timed_out {
        t.hangs += 1;
        fail(t, "hang".into());
    } else if let Some(sig) = o.signal {
        t.aborts += 1;
        fail(t, format!("died of signal {sig}"));
    }
    if o.stderr.contains("Traceback") {
        t.tracebacks += 1;
        fail(t, "Python traceback".into());
    }
    if let Some(m) = o.misbehaviour().filter(|_| !o.timed_out && o.signal.is_none() && !o.stderr.contains("panicked") && !o.stderr.contains("Traceback")) {
        t.aborts += 1;
        fail(t, m);
    }
    let ok = match case.expect {
        Expect::Refused => o.code == Some(2),
        Expect::Success => o.code == Some(0),
        Expect::Either => matches!(o.code, Some(0) | Some(2)),
        Expect::Signal(n) => o.code == Some(128 + n) || o.code == Some(0),
    };
    if !ok && !o.timed_out && o.signal.is_none() {
        if case.expect == Expect::Refused && o.code == Some(0) {
            t.wrong_successes += 1;
        } else {
            t.wrong_status += 1;
        }
        fail(t, format!("exit status {:?}, expected {:?}", o.code, case.expect));
    }
    if let Some(needle) = case.stdout_has {
        if !o.stdout.contains(needle) {
            t.wrong_status += 1;
            fail(t, format!("stdout lacks {needle:?}: {}", o.stdout));
        }
    }
    if !problems.is_empty() {
        t.files += problems.len();
        fail(t, problems.join("; "));
    }
    if let Some(k) = o.max_rss_kib {
        if t.worst.as_ref().is_none_or(|w| k > w.0) {
            t.worst = Some((k, case.name.clone()));
        }
    }
}

#[test]
fn hostile_inputs_end_in_clear_errors_and_leave_nothing_behind() {
    let inputs = Inputs::new();
    let mut c = Cases { inputs: &inputs, list: Vec::new() };
    rss_cases(&mut c);
    flag_cases(&mut c);
    output_cases(&mut c);
    compare_cases(&mut c);
    usd_cases(&mut c);
    cache_cases(&mut c);
    signal_cases(&mut c);
    let cases = c.list;
    let t0 = std::time::Instant::now();
    let tally_all = Mutex::new(Tally::default());
    let next = Mutex::new(0usize);
    // two workers (the machine's cores are shared); each case has its own directory
    std::thread::scope(|scope| {
        for _ in 0..2 {
            scope.spawn(|| loop {
                let k = {
                    let mut n = next.lock().unwrap();
                    *n += 1;
                    *n - 1
                };
                let Some(case) = cases.get(k) else { break };
                let (o, problems) = run_case(case);
                tally(case, &o, &problems, &mut tally_all.lock().unwrap());
            });
        }
    });
    let t = tally_all.into_inner().unwrap();
    let worst = t.worst.as_ref().map_or("not measured (/usr/bin/time is missing)".to_string(), |(k, n)| format!("{:.0} MiB ({n})", *k as f64 / 1024.0));
    eprintln!(
        "hostile battery: {} cases in {:.0} s: {} panics, {} aborts or signal deaths, {} hangs (> {} s), {} Python tracebacks, \
         {} wrong successes, {} other wrong exit statuses, {} files left or changed; peak memory of the worst input {worst}",
        t.cases,
        t0.elapsed().as_secs_f64(),
        t.panics,
        t.aborts,
        t.hangs,
        LIMIT.as_secs(),
        t.tracebacks,
        t.wrong_successes,
        t.wrong_status,
        t.files
    );
    assert!(t.cases >= 300, "only {} cases", t.cases);
    assert!(t.failures.is_empty(), "{} failures:\n{}", t.failures.len(), t.failures.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// Property tests: the readers in-process, on mutated files.

fn room_rss() -> &'static [u8] {
    static RSS: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    RSS.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("room.rss");
        raysplat::scene::format::save(&extreme_scenes::room(0.6, 10.0), &p).unwrap();
        std::fs::read(p).unwrap()
    })
}

fn room_exr() -> &'static [u8] {
    static EXR: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    EXR.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("room.exr");
        let mut film = raysplat::image::Film::new(7, 5);
        film.add_layer("", &["R", "G", "B", "A"]);
        film.add_layer("depth", &["Z"]);
        for (i, v) in film.layers[0].data.iter_mut().enumerate() {
            *v = i as f32 * 0.25;
        }
        raysplat::image::write_exr(&p, &film, &[("k".into(), "v".into())]).unwrap();
        std::fs::read(p).unwrap()
    })
}

/// A mutation of `base`: bytes overwritten, a cut, or bytes spliced in.
fn mutate(base: &[u8], edits: &[(usize, u8)], cut: Option<usize>, splice: Option<(usize, Vec<u8>)>) -> Vec<u8> {
    let mut b = base.to_vec();
    for &(at, v) in edits {
        let n = b.len();
        if n > 0 {
            b[at % n] = v;
        }
    }
    if let Some((at, bytes)) = splice {
        let at = at % (b.len() + 1);
        b.splice(at..at, bytes);
    }
    if let Some(n) = cut {
        b.truncate(n % (b.len() + 1));
    }
    b
}

fn mutation() -> impl Strategy<Value = (Vec<(usize, u8)>, Option<usize>, Option<(usize, Vec<u8>)>)> {
    (prop::collection::vec((any::<usize>(), any::<u8>()), 0..6), prop::option::of(any::<usize>()), prop::option::of((any::<usize>(), prop::collection::vec(any::<u8>(), 1..64))))
}

/// Property cases per test: 256, or `PROPTEST_CASES` (`make fuzz`).
fn property_cases() -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(256)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: property_cases(), failure_persistence: None, ..ProptestConfig::default() })]

    /// The `.rss` reader on mutated files: never a panic; a file that differs from the one written
    /// never loads (the checksum); with the checksum made right again (so the parser itself meets the
    /// damage), never a panic either, and the arrays it loads are never larger than the file.
    #[test]
    fn the_rss_reader_refuses_every_change((edits, cut, splice) in mutation(), fix in any::<bool>()) {
        let base = room_rss();
        let mut b = mutate(base, &edits, cut, splice);
        if fix {
            b = with_checksum(b);
        }
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("m.rss");
        std::fs::write(&p, &b).unwrap();
        match raysplat::scene::format::load(&p) {
            Ok((mut scene, _)) => {
                prop_assert!(fix || b == base, "a changed file loaded");
                let floats: usize = scene.meshes.iter().map(|m| m.positions.len() * 12 + m.indices.len() * 12).sum();
                prop_assert!(floats <= b.len());
                let _ = scene.validate();
            }
            Err(e) => {
                let m = e.to_string();
                prop_assert!(m.contains("m.rss"), "{}", m);
            }
        }
    }

    /// The EXR reader of `compare` on mutated files: an image or an error naming the file, never a
    /// panic or a crash.
    #[test]
    fn the_exr_reader_never_panics((edits, cut, splice) in mutation()) {
        let b = mutate(room_exr(), &edits, cut, splice);
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("m.exr");
        std::fs::write(&p, &b).unwrap();
        match raysplat::image::read_exr(&p) {
            Ok(f) => prop_assert!(f.width > 0 && f.height > 0),
            Err(e) => prop_assert!(e.to_string().contains("m.exr"), "{}", e),
        }
    }
}
