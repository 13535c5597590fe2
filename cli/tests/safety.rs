//! No user file is ever lost, nothing is left behind, no input exhausts the machine: one test per
//! promise, each through the binary as a user meets it (the hostile-input battery, many inputs per
//! promise, is `tests/hostile.rs`).

#[path = "../../tests/common/mod.rs"]
mod common;
#[path = "../../tests/common/extreme_scenes.rs"]
mod extreme_scenes;
#[path = "../../tests/common/guarded.rs"]
mod guarded;

use guarded::{changes, digest, Outcome};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// Hang guard of one command (a guard, not a speed assertion).
const LIMIT: Duration = Duration::from_secs(120);

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(p)
}

/// The binary with a cache directory of the test's own.
fn bin(cache: &Path) -> Command {
    let mut c = Command::new(guarded::bin_path());
    c.env("RAYSPLAT_CACHE_DIR", cache);
    c
}

fn run_in<A: AsRef<std::ffi::OsStr>>(cache: &Path, args: &[A]) -> Outcome {
    let mut c = bin(cache);
    c.args(args);
    guarded::run(c, LIMIT, false)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Exit status 2, a message naming each of `needles`, and no panic, signal, hang or traceback.
fn assert_refused(o: &Outcome, needles: &[&str]) {
    assert_eq!(o.misbehaviour(), None, "{}", o.stderr);
    assert_eq!(o.code, Some(2), "exit status {:?}, stderr:\n{}", o.code, o.stderr);
    for n in needles {
        assert!(o.stderr.contains(n), "stderr lacks {n:?}:\n{}", o.stderr);
    }
}

fn assert_success(o: &Outcome) {
    assert_eq!(o.misbehaviour(), None, "{}", o.stderr);
    assert_eq!(o.code, Some(0), "stderr:\n{}", o.stderr);
}

/// A small room (no Python needed) saved as a `.rss` file in `dir`.
fn room_rss(dir: &Path) -> PathBuf {
    let p = dir.join("room.rss");
    raysplat::scene::format::save(&extreme_scenes::room(0.6, 10.0), &p).unwrap();
    p
}

const FAST: [&str; 6] = ["--method", "pt", "--spp", "1", "--resolution", "8x8"];

fn render_args<'a>(scene: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [&["render", scene][..], &FAST[..], extra].concat()
}

/// Output paths: only a new path or an existing regular file is written (through a symbolic link,
/// its target); an input, another output of the same command, a directory, a device, a FIFO or a
/// socket, and a name that says another format, are refused with exit status 2 before anything on
/// disk changes.
#[test]
fn outputs_never_replace_inputs_devices_or_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let work = dir.path().join("work");
    std::fs::create_dir(&work).unwrap();
    let scene = room_rss(&work);
    let w = |n: &str| work.join(n);
    std::fs::hard_link(&scene, w("scene-link")).unwrap();
    Command::new("mkfifo").arg(w("pipe.exr")).arg(w("pipe.png")).status().unwrap();
    let device = Command::new("mknod").arg(w("null.exr")).args(["c", "1", "3"]).status().is_ok_and(|s| s.success());
    if !device {
        eprintln!("skipped the device node case: mknod failed (not root?)");
    }
    let _socket = std::os::unix::net::UnixListener::bind(w("sock.exr")).unwrap();
    std::fs::write(w("old.exr"), b"not yet an image").unwrap();
    std::os::unix::fs::symlink("old.exr", w("link.exr")).unwrap();
    let sc = s(&scene);
    let before = digest(&work);
    let ws = |n: &str| w(n).to_str().unwrap().to_string();
    let (link, o_exr, x_exr, x, pipe, sock, x_png, p_exr) =
        (ws("scene-link"), ws("o.exr"), ws("x.exr"), ws("x"), ws("pipe.exr"), ws("sock.exr"), ws("x.png"), ws("p.exr"));
    let wd = s(&work);
    let refused: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (render_args(sc, &["-o", sc]), vec!["room.rss"]),
        (render_args(sc, &["-o", &link]), vec!["scene-link", "same file as the input"]),
        (render_args(sc, &["-o", &o_exr, "--preview", sc]), vec!["room.rss"]),
        (render_args(sc, &["-o", &x_exr, "--preview", &x_exr]), vec!["x.exr", "OpenEXR"]),
        (render_args(sc, &["-o", &x, "--preview", &x]), vec!["same file as the other output"]),
        (render_args(sc, &["-o", &pipe]), vec!["pipe.exr", "FIFO"]),
        (render_args(sc, &["-o", &sock]), vec!["sock.exr", "socket"]),
        (render_args(sc, &["-o", wd]), vec!["is a directory"]),
        (render_args(sc, &["-o", &x_png]), vec!["x.png", "OpenEXR"]),
        (render_args(sc, &["-o", &x_exr, "--preview", &p_exr]), vec!["p.exr", "PNG"]),
    ];
    for (args, needles) in &refused {
        let o = run_in(&cache, args);
        assert_refused(&o, needles);
        assert!(!o.stderr.contains("wrote"), "{args:?} rendered first:\n{}", o.stderr);
        assert_eq!(changes(&before, &digest(&work)), Vec::<String>::new(), "{args:?}");
    }
    if device {
        assert_refused(&run_in(&cache, &render_args(sc, &["-o", s(&w("null.exr"))])), &["null.exr", "a device"]);
        assert_eq!(changes(&before, &digest(&work)), Vec::<String>::new());
    }
    // compare's error image: not over an input, and only as PNG
    let img = w("img.exr");
    assert_success(&run_in(&cache, &render_args(sc, &["-o", s(&img)])));
    let before = digest(&work);
    for (ei, needle) in [(s(&img), "img.exr"), (s(&w("err.exr")), "err.exr"), (s(&w("pipe.png")), "FIFO")] {
        let o = run_in(&cache, &["compare", s(&img), s(&img), "--error-image", ei]);
        assert_refused(&o, &[needle]);
        assert_eq!(changes(&before, &digest(&work)), Vec::<String>::new());
    }
    // convert: never over its input (the converter does not even start)
    let usda = w("box.usda");
    std::fs::copy(repo("scenes/cornell-box.usda"), &usda).unwrap();
    let before = digest(&work);
    assert_refused(&run_in(&cache, &["convert", s(&usda), s(&usda)]), &["box.usda"]);
    assert_refused(&run_in(&cache, &["convert", s(&usda), s(&w("box.exr"))]), &["box.exr", "OpenEXR"]);
    assert_eq!(changes(&before, &digest(&work)), Vec::<String>::new());
    // through a symbolic link: the target is written, the link stays
    assert_success(&run_in(&cache, &render_args(sc, &["-o", s(&w("link.exr"))])));
    assert!(std::fs::symlink_metadata(w("link.exr")).unwrap().file_type().is_symlink());
    assert_eq!(raysplat::image::read_exr(&w("old.exr")).unwrap().width, 8);
    // the library's writer keeps the same rule (the C++ API's write_exr goes through it)
    let film = raysplat::image::read_exr(&img).unwrap();
    let e = raysplat::image::write_exr(&w("lib.png"), &film, &[]).unwrap_err().to_string();
    assert!(e.contains("lib.png") && e.contains("OpenEXR"), "{e}");
    assert!(!w("lib.png").exists());
}

/// Temporaries go on SIGINT, SIGTERM and SIGHUP: the EXR being written and the spill directory of
/// `rpm-fg --memory 1M`. A process killed outright (SIGKILL) leaves its spill directory, which the
/// next render spilling into the same directory removes.
#[test]
fn signals_leave_no_temporaries_and_the_next_start_removes_a_dead_processs() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene = room_rss(dir.path());
    let tmp = dir.path().join("tmp");
    let out = dir.path().join("out");
    std::fs::create_dir_all(&tmp).unwrap();
    std::fs::create_dir_all(&out).unwrap();
    let spill_dirs = || std::fs::read_dir(&tmp).unwrap().flatten().filter(|e| e.file_name().to_string_lossy().starts_with("raysplat-spill-")).count();
    let spill = |resolution: &str, rays: &str| {
        let mut c = bin(&cache);
        c.env("TMPDIR", &tmp).args(["render", s(&scene), "--method", "rpm-fg", "--memory", "1M", "--fg-rays", rays, "--spp", "1", "--photons", "20000"]);
        c.args(["--resolution", resolution, "--threads", "2", "-o", s(&out.join("fg.exr"))]);
        c
    };
    for signal in ["TERM", "INT", "HUP", "KILL"] {
        let mut c = spill("160x160", "64");
        c.stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null());
        let mut child = c.spawn().unwrap();
        assert!(guarded::wait_for(LIMIT, || spill_dirs() > 0), "SIG{signal}: no spill directory appeared");
        guarded::kill(child.id(), signal);
        let status = child.wait().unwrap();
        assert!(!status.success(), "SIG{signal}: the render finished first");
        if signal == "KILL" {
            assert_eq!(spill_dirs(), 1, "SIGKILL cannot be handled: its spill directory stays");
        } else {
            assert_eq!(spill_dirs(), 0, "SIG{signal} left a spill directory");
            assert_eq!(status.code(), Some(128 + [("TERM", 15), ("INT", 2), ("HUP", 1)].iter().find(|x| x.0 == signal).unwrap().1));
        }
    }
    // the next render spilling there removes the dead process's directory (and its own)
    let c = spill("24x24", "16");
    assert_success(&guarded::run(c, LIMIT, false));
    assert_eq!(spill_dirs(), 0);
    assert_eq!(std::fs::read_dir(&tmp).unwrap().count(), 0);
    // SIGINT while the EXR is being written: no `.NAME.….tmp` stays
    let exr = out.join("big.exr");
    let mut c = bin(&cache);
    c.args(["render", s(&scene), "--method", "pt", "--spp", "1", "--max-depth", "1", "--resolution", "2000x2000", "-o", s(&exr)]);
    c.stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null());
    let mut child = c.spawn().unwrap();
    let temporaries = || std::fs::read_dir(&out).unwrap().flatten().filter(|e| e.file_name().to_string_lossy().ends_with(".tmp")).count();
    assert!(guarded::wait_for(LIMIT, || temporaries() > 0), "no temporary appeared");
    guarded::kill(child.id(), "INT");
    let status = child.wait().unwrap();
    if status.success() {
        eprintln!("the write finished before SIGINT arrived; the temporary went with the rename");
    } else {
        assert_eq!(status.code(), Some(130));
    }
    assert_eq!(temporaries(), 0, "SIGINT left the EXR's temporary");
}

/// A stage whose conversion takes seconds: 20 000 one-triangle meshes, each a prim the converter
/// visits in Python (about 5 s on 2 cores; the converter is quick on few large meshes).
fn slow_stage(dir: &Path) -> PathBuf {
    let mut text = String::from("#usda 1.0\n(\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n");
    for k in 0..20_000 {
        text += &format!("def Mesh \"M{k}\" {{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n    point3f[] points = [({k}, 0, 0), ({k}, 1, 0), ({k}, 0, 1)]\n}}\n");
    }
    text += "def DistantLight \"Sun\" {\n    float inputs:intensity = 3\n}\n";
    let p = dir.join("slow.usda");
    std::fs::write(&p, text).unwrap();
    p
}

/// The converter (Python) ends with `raysplat`: killed with it on SIGTERM, and on its parent's
/// death (SIGKILL, which `raysplat` cannot handle); its staging files go too. `convert` is atomic:
/// a stage that fails validation (NaN points) leaves no `.rss`, nor changes an existing one.
#[test]
fn the_converter_ends_with_its_parent_and_convert_is_atomic() {
    let dir = tempfile::tempdir().unwrap();
    let stage = slow_stage(dir.path());
    // the converter itself, not the check that Python imports pxr before it
    let converter = |pid: &u32| std::fs::read(format!("/proc/{pid}/cmdline")).is_ok_and(|c| !String::from_utf8_lossy(&c).contains("import pxr"));
    for signal in ["TERM", "KILL"] {
        // a cache of its own: a conversion that ended in the first run is not one to kill in the next
        let cache = dir.path().join(format!("cache-{signal}"));
        let mut c = bin(&cache);
        c.args(["render", s(&stage), "--resolution", "8x8", "--spp", "1", "-o", s(&dir.path().join("slow.exr"))]);
        c.stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null());
        let mut child = c.spawn().unwrap();
        let mut python = Vec::new();
        assert!(
            guarded::wait_for(LIMIT, || {
                python = guarded::children_of(child.id()).into_iter().filter(converter).collect();
                !python.is_empty()
            }),
            "SIG{signal}: no converter started"
        );
        std::thread::sleep(Duration::from_millis(500));
        guarded::kill(child.id(), signal);
        child.wait().unwrap();
        assert!(guarded::wait_for(Duration::from_secs(10), || python.iter().all(|&p| !guarded::alive(p))), "SIG{signal}: the converter {python:?} outlived raysplat");
        if signal == "TERM" {
            let left: Vec<_> = std::fs::read_dir(&cache).into_iter().flatten().flatten().map(|e| e.file_name()).collect();
            assert!(left.iter().all(|n| !n.to_string_lossy().ends_with(".tmp")), "{left:?}");
        }
    }
    let cache = dir.path().join("cache");
    let nan = dir.path().join("nan.usda");
    std::fs::write(
        &nan,
        "#usda 1.0\n(\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\ndef Mesh \"Bad\" {\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n    point3f[] points = [(0, 0, 0), (nan, 0, 0), (0, 1, 0)]\n}\n",
    )
    .unwrap();
    let rss = dir.path().join("nan.rss");
    let o = run_in(&cache, &["convert", s(&nan), s(&rss)]);
    assert_refused(&o, &["nan.usda", "/Bad"]);
    assert!(!rss.exists(), "a failed conversion wrote {}", rss.display());
    std::fs::write(&rss, b"the previous conversion").unwrap();
    let before = digest(dir.path());
    assert_refused(&run_in(&cache, &["convert", s(&nan), s(&rss)]), &["nan.usda"]);
    assert_eq!(changes(&before, &digest(dir.path())), Vec::<String>::new());
}

/// Inputs that are not regular files are refused (`render /dev/zero` read without end); a render
/// under an address-space limit (`ulimit -v`) too large for it is refused by the memory check, which
/// honours the process's limits, instead of aborting on a failed allocation.
#[test]
fn non_regular_inputs_and_memory_limits_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let out = dir.path().join("x.exr");
    let limited = |limit_kib: u64, args: &[&str]| {
        let mut c = Command::new("bash");
        c.env("RAYSPLAT_CACHE_DIR", &cache).arg("-c").arg(format!("ulimit -v {limit_kib}; exec \"$0\" \"$@\"")).arg(guarded::bin_path()).args(args);
        guarded::run(c, Duration::from_secs(60), false)
    };
    for input in ["/dev/zero", "/dev/urandom"] {
        let o = limited(4_000_000, &["render", input, "-o", s(&out)]);
        assert_refused(&o, &[input, "a device"]);
    }
    let fifo = dir.path().join("scene.rss");
    Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert_refused(&limited(4_000_000, &["render", s(&fifo), "-o", s(&out)]), &["scene.rss", "FIFO"]);
    assert_refused(&limited(4_000_000, &["compare", s(&fifo), s(&fifo)]), &["scene.rss", "FIFO"]);
    assert_refused(&limited(4_000_000, &["render", s(dir.path()), "-o", s(&out)]), &["a directory"]);
    let scene = room_rss(dir.path());
    let o = limited(3_000_000, &["render", s(&scene), "--method", "pt", "--resolution", "12000x12000", "-o", s(&out)]);
    assert_refused(&o, &["12000x12000", "memory", "limit"]);
    assert!(!out.exists());
}

fn flip_byte(path: &Path, at: usize) {
    let mut b = std::fs::read(path).unwrap();
    b[at] ^= 0x01;
    std::fs::write(path, b).unwrap();
}

/// Byte offset of a blob array's first byte in an `.rss` file: the blob starts after the JSON
/// header, 16-byte aligned.
fn blob_start(bytes: &[u8]) -> usize {
    let header_len = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    (24 + header_len).div_ceil(16) * 16
}

const TEXTURED: &str = "#usda 1.0\n(\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n\
    def Mesh \"M\" {\n int[] faceVertexCounts = [4]\n int[] faceVertexIndices = [0, 1, 2, 3]\n\
     point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]\n\
     texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = \"vertex\")\n\
     uniform token subdivisionScheme = \"none\"\n rel material:binding = </Looks/T>\n}\n\
    def Scope \"Looks\" {\n def Material \"T\" {\n  token outputs:surface.connect = </Looks/T/S.outputs:surface>\n\
     def Shader \"S\" {\n   uniform token info:id = \"UsdPreviewSurface\"\n   color3f inputs:diffuseColor.connect = </Looks/T/Tex.outputs:rgb>\n   token outputs:surface\n  }\n\
     def Shader \"Tex\" {\n   uniform token info:id = \"UsdUVTexture\"\n   asset inputs:file = @tex.png@\n   float2 inputs:st.connect = </Looks/T/St.outputs:result>\n   float3 outputs:rgb\n  }\n\
     def Shader \"St\" {\n   uniform token info:id = \"UsdPrimvarReader_float2\"\n   string inputs:varname = \"st\"\n   float2 outputs:result\n  }\n }\n}\n\
    def DistantLight \"Sun\" {\n float inputs:intensity = 3\n}\n\
    def Camera \"Cam\" {\n double3 xformOp:translate = (0, 0, 4)\n uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n";

/// Every `.rss` file and cache entry carries a checksum: a damaged `.rss` given by the user is an
/// error naming it; a damaged cached conversion or decoded texture is rebuilt with a warning (the
/// image is the undamaged one); an unwritable cache falls back to a temporary one with a warning.
#[test]
fn damaged_scenes_and_cache_entries_are_found() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    // a user's .rss with one flipped bit in its vertex positions
    let scene = room_rss(dir.path());
    let at = blob_start(&std::fs::read(&scene).unwrap()) + 2;
    flip_byte(&scene, at);
    let out = dir.path().join("x.exr");
    assert_refused(&run_in(&cache, &render_args(s(&scene), &["-o", s(&out)])), &["room.rss", "damaged"]);
    assert!(!out.exists());
    // a cached conversion and a cached decoded texture, each damaged
    let stage = dir.path().join("textured.usda");
    std::fs::write(&stage, TEXTURED).unwrap();
    image::RgbImage::from_fn(16, 16, |x, y| image::Rgb([(x * 16) as u8, (y * 16) as u8, 200])).save(dir.path().join("tex.png")).unwrap();
    let first = dir.path().join("first.exr");
    let st = s(&stage).to_string();
    let args = |o: &Path| -> Vec<String> {
        ["render", &st, "--method", "pt", "--spp", "4", "--resolution", "16x16", "-o", s(o)].iter().map(|a| a.to_string()).collect()
    };
    assert_success(&run_in(&cache, &args(&first)));
    let image = |p: &Path| raysplat::image::read_exr(p).unwrap().layer("").unwrap().data.clone();
    let entries = |sub: &str, ext: &str| -> Vec<PathBuf> {
        std::fs::read_dir(cache.join(sub)).unwrap().flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == ext)).collect()
    };
    let (rss, rstx) = (entries("", "rss"), entries("textures", "rstx"));
    assert_eq!((rss.len(), rstx.len()), (1, 1), "{rss:?} {rstx:?}");
    let b = std::fs::read(&rss[0]).unwrap();
    flip_byte(&rss[0], blob_start(&b) + 1);
    let mut t = std::fs::read(&rstx[0]).unwrap();
    let n = t.len();
    t[n - 64..].fill(0);
    std::fs::write(&rstx[0], t).unwrap();
    let again = dir.path().join("again.exr");
    let o = run_in(&cache, &args(&again));
    assert_success(&o);
    assert!(o.stderr.contains("warning:") && o.stderr.contains(s(&rss[0])) && o.stderr.contains("damaged"), "{}", o.stderr);
    assert!(o.stderr.contains(s(&rstx[0])), "no warning about the texture:\n{}", o.stderr);
    assert!(image(&again) == image(&first), "the damaged cache entries changed the image");
    // rebuilt: a third render finds both entries whole, silently
    let o = run_in(&cache, &args(&again));
    assert_success(&o);
    assert!(!o.stderr.contains("damaged"), "{}", o.stderr);
    // a cache directory that cannot be made (a file is in the way; root may write anywhere else)
    let blocker = dir.path().join("blocker");
    std::fs::write(&blocker, b"a file").unwrap();
    let unwritable = blocker.join("cache");
    let third = dir.path().join("third.exr");
    let o = run_in(&unwritable, &args(&third));
    assert_success(&o);
    assert!(o.stderr.contains("warning:") && o.stderr.contains(s(&unwritable)) && o.stderr.contains("temporary"), "{}", o.stderr);
    assert!(image(&third) == image(&first));
}

/// `compare` counts the non-finite pixels of each image and makes the error infinite, in the text
/// and in `--json`, so that a script gating on the error cannot pass.
#[test]
fn compare_reports_non_finite_pixels_of_either_image() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene = room_rss(dir.path());
    let good = dir.path().join("good.exr");
    assert_success(&run_in(&cache, &render_args(s(&scene), &["-o", s(&good)])));
    let film = raysplat::image::read_exr(&good).unwrap();
    let spoil = |name: &str, pixels: &[usize], v: f32| {
        let mut f = film.clone();
        let layer = f.layers.iter_mut().find(|l| l.name.is_empty()).unwrap();
        let n = layer.channels.len();
        for &p in pixels {
            layer.data[p * n] = v;
        }
        let p = dir.path().join(name);
        raysplat::image::write_exr(&p, &f, &[]).unwrap();
        p
    };
    let nan = spoil("nan.exr", &[0, 5, 9], f32::NAN);
    let inf = spoil("inf.exr", &[3, 4], f32::INFINITY);
    for (t, r, nt, nr) in [(&nan, &good, 3, 0), (&good, &nan, 0, 3), (&inf, &good, 2, 0), (&nan, &inf, 3, 2)] {
        let o = run_in(&cache, &["compare", s(t), s(r), "--json"]);
        assert_success(&o);
        let j: serde_json::Value = serde_json::from_str(&o.stdout).unwrap();
        assert_eq!((j["nan"].as_u64(), j["nan_reference"].as_u64()), (Some(nt), Some(nr)), "{j}");
        for k in ["rmse", "rel_mse", "mean_rel_error"] {
            assert_eq!(j[k], "inf", "{k}: {j}");
        }
        let o = run_in(&cache, &["compare", s(t), s(r)]);
        assert!(o.stdout.contains("rmse            inf"), "{}", o.stdout);
        assert!(o.stdout.contains(&format!("nan             {nt} (test), {nr} (reference)")), "{}", o.stdout);
    }
}

/// A bad stage resolution names the render settings prim, and `--resolution` wins over it; errors
/// name files as the user gave them (a relative path stays relative).
#[test]
fn messages_name_the_prim_and_the_path_as_given() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let stage = dir.path().join("huge.usda");
    std::fs::write(
        &stage,
        "#usda 1.0\n(\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\ndef Mesh \"Floor\" {\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    point3f[] points = [(-5, 0, 5), (5, 0, 5), (5, 0, -5), (-5, 0, -5)]\n}\n\
         def DistantLight \"Sun\" {\n    float inputs:intensity = 3\n}\ndef Scope \"Render\" {\n    def RenderSettings \"Settings\" {\n        uniform int2 resolution = (100000, 20)\n    }\n}\n",
    )
    .unwrap();
    let out = dir.path().join("x.exr");
    let o = run_in(&cache, &["render", s(&stage), "--method", "pt", "--spp", "1", "--resolution", "8x8", "-o", s(&out)]);
    assert_success(&o);
    assert!(o.stderr.contains("/Render/Settings") && o.stderr.contains("100000x20"), "{}", o.stderr);
    let o = run_in(&cache, &["info", s(&stage)]);
    assert!(o.stderr.contains("/Render/Settings: resolution 100000x20") || o.stdout.contains("/Render/Settings"), "{}\n{}", o.stdout, o.stderr);
    // relative paths stay as given, from the converter's errors too
    std::fs::write(dir.path().join("broken.usda"), "#usda 1.0\ndef Mesh \"M\" {\n    point3f[] points = [(0, 0\n}\n").unwrap();
    let mut c = bin(&cache);
    c.current_dir(dir.path()).args(["render", "broken.usda", "-o", "x.exr"]);
    let o = guarded::run(c, LIMIT, false);
    assert_refused(&o, &["error: broken.usda: "]);
    assert!(!o.stderr.contains(s(dir.path())), "an absolute path in:\n{}", o.stderr);
    let mut c = bin(&cache);
    c.current_dir(dir.path()).args(["compare", "missing.exr", "x.exr"]);
    let o = guarded::run(c, LIMIT, false);
    assert_refused(&o, &["error: missing.exr: "]);
}
