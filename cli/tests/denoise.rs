//! Denoising through the command line (`render --denoise`, `raysplat denoise`): the raw layer
//! survives the EXR round trip bit for bit, the two ways agree, and a build without Open Image
//! Denoise refuses with exit status 2 and writes nothing. The library's side: `tests/denoise.rs`.

#[path = "../../tests/common/mod.rs"]
mod common;

use common::*;
use raysplat::denoise::{self, RAW_LAYER};
use std::path::Path;
use std::process::{Command, Output};

fn raysplat(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raysplat")).args(args).output().expect("run raysplat")
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Through the command line: `render --denoise on` keeps the plain render as `raw` (after the EXR
/// round trip, bit for bit), and `raysplat denoise` of the plain render gives the same image.
#[test]
fn render_and_the_denoise_command_agree() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    raysplat::scene::format::save(&furnace(0.5, 1.0), Path::new(&p("furnace.rss"))).unwrap();
    let common = ["--method", "pt", "--spp", "2", "--resolution", "40x32", "--threads", "2"];
    let plain = raysplat(&[&["render", &p("furnace.rss"), "-o", &p("plain.exr")][..], &common].concat());
    assert!(plain.status.success(), "{}", text(&plain));
    let on = raysplat(&[&["render", &p("furnace.rss"), "-o", &p("on.exr"), "--denoise", "on"][..], &common].concat());
    let cmd = raysplat(&["denoise", &p("plain.exr"), "-o", &p("later.exr")]);
    if !denoise::available() {
        for o in [&on, &cmd] {
            assert_eq!(o.status.code(), Some(2), "{}", text(o));
            assert!(text(o).contains("the denoiser is unavailable") && text(o).contains("make setup"), "{}", text(o));
        }
        assert!(!Path::new(&p("on.exr")).exists() && !Path::new(&p("later.exr")).exists(), "nothing written");
        eprintln!("no denoiser in this build: checked the messages and exit status 2");
        return;
    }
    assert!(on.status.success(), "{}", text(&on));
    assert!(text(&on).contains("denoised with Open Image Denoise") && text(&on).contains("denoise "), "summary:\n{}", text(&on));
    assert!(cmd.status.success(), "{}", text(&cmd));
    let read = |n: &str| raysplat::image::read_exr(Path::new(&p(n))).unwrap();
    let (plain, on, later) = (read("plain.exr"), read("on.exr"), read("later.exr"));
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&on.layer(RAW_LAYER).unwrap().data), bits(&plain.layer("").unwrap().data));
    assert_eq!(bits(&later.layer("").unwrap().data), bits(&on.layer("").unwrap().data), "denoise command = render --denoise on");
    assert_eq!(bits(&later.layer(RAW_LAYER).unwrap().data), bits(&plain.layer("").unwrap().data));
    let attr = |n: &str, k: &str| raysplat::image::read_exr_string_attribute(Path::new(&p(n)), k).unwrap();
    assert_eq!(attr("later.exr", "raysplat:method").as_deref(), Some("pt"), "the render's attributes are kept");
    assert_eq!(attr("later.exr", "raysplat:denoise").as_deref(), Some("on"));
    assert_eq!(attr("on.exr", "raysplat:denoise").as_deref(), Some("on"));
    // an image without a beauty is a clean error naming the file, and nothing is written
    let mut f = raysplat::image::Film::new(4, 4);
    f.add_layer("depth", &["Z"]);
    raysplat::image::write_exr(Path::new(&p("depth.exr")), &f, &[]).unwrap();
    let bad = raysplat(&["denoise", &p("depth.exr"), "-o", &p("bad.exr")]);
    assert_eq!(bad.status.code(), Some(2), "{}", text(&bad));
    assert!(text(&bad).contains("depth.exr") && !text(&bad).contains("panicked"), "{}", text(&bad));
    assert!(!Path::new(&p("bad.exr")).exists());
}
