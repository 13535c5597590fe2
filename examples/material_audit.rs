//! The renderer's half of the material-binding audit (`scripts/material_audit.py` drives it and
//! compares with what the USD stage's materials say):
//!
//!     material_audit pixels SCENE.rss WIDTHxHEIGHT   # per placed prim and material: the albedo AOV
//!     material_audit average FILE COLOR_SPACE ...     # the mean linear RGB of image files
//!
//! `pixels` traces 4 camera rays per pixel (with their cones, as renders do) and prints, as one JSON
//! object per line, each prim–material pair the rays hit first: its pixel count and the mean of the
//! albedo AOV (`Bsdf::albedo` at the hit, what every method writes to the `albedo` layer) there.
//! `average` prints `{"file", "color_space", "rgb"}` per file: the texture as the renderer reads it
//! (`raw`, `sRGB`, `auto` or `ACEScg`), averaged over its texels.

use std::collections::BTreeMap;

use raysplat::prepare::PreparedScene;
use raysplat::scene::TextureDesc;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("pixels") if args.len() == 3 => pixels(&args[1], &args[2]),
        Some("average") if args.len() >= 3 && args.len() % 2 == 1 => average(&args[1..]),
        _ => Err("usage: material_audit pixels SCENE.rss WIDTHxHEIGHT | average FILE COLOR_SPACE ...".into()),
    };
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

fn pixels(scene: &str, size: &str) -> Result<(), String> {
    let (w, h) = size.split_once('x').and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?))).ok_or("size must be WIDTHxHEIGHT")?;
    let desc = raysplat::usd::load_scene(std::path::Path::new(scene)).map_err(|e| e.to_string())?;
    let prims: Vec<String> = desc.instances.iter().map(|i| i.name.clone()).collect();
    let materials: Vec<String> = desc.materials.iter().map(|m| m.name().to_string()).collect();
    let prepared = PreparedScene::new(desc, w, h, 0).map_err(|e| e.to_string())?;
    let cone = prepared.camera.cone();
    let mut sums: BTreeMap<(u32, u32), (u64, glam::Vec3)> = BTreeMap::new();
    for y in 0..h {
        for x in 0..w {
            for (dx, dy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let ray = prepared.camera.ray(x as f32 + dx, y as f32 + dy);
                if let Some(hit) = prepared.intersect_cone(&ray, Some(cone)) {
                    let e = sums.entry((hit.instance, hit.material)).or_insert((0, glam::Vec3::ZERO));
                    e.0 += 1;
                    e.1 += prepared.bsdf(&hit).albedo();
                }
            }
        }
    }
    for ((inst, mat), (n, sum)) in sums {
        let row = serde_json::json!({
            "prim": prims[inst as usize],
            "material": materials[mat as usize],
            "pixels": n as f64 / 4.0,
            "albedo": (sum / n as f32).to_array(),
        });
        println!("{row}");
    }
    Ok(())
}

fn average(pairs: &[String]) -> Result<(), String> {
    for pair in pairs.chunks(2) {
        let desc = TextureDesc { path: pair[0].clone(), color_space: pair[1].clone(), ..TextureDesc::default() };
        let (tex, warning) = raysplat::image::Texture::load(&desc);
        let rgb = if warning.is_some() { None } else { Some(tex.average_rgb().to_array()) };
        println!("{}", serde_json::json!({"file": pair[0], "color_space": pair[1], "rgb": rgb}));
    }
    Ok(())
}
