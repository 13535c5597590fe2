//! `raysplat info`: what a scene holds (geometry, materials by kind, lights, textures), what it
//! requires, which method `auto` picks and why, whether it has strong secondary lights, which
//! glossy representation `rs` would use and its memory, and the conversion's warnings.

use raysplat::integrators::{self, RenderRequest};
use raysplat::usd;
use std::path::Path;

pub(super) fn info(path: &Path, opts: &usd::StageOptions) -> anyhow::Result<()> {
    let (scene, file_info) = usd::load_scene_info(path, opts)?;
    let scene_camera = scene.camera.name.clone();
    let [w, h] = scene.resolution.unwrap_or([512, 512]);
    let n_lights = scene.lights.len();
    let materials: Vec<String> = scene.materials.iter().map(|m| m.name().to_string()).collect();
    let (_, auto) = integrators::auto::choose(&scene, &RenderRequest::default())?;
    let prepared = raysplat::prepare::PreparedScene::new(scene, w, h, 0)?;
    let r = &prepared.requirements;
    println!("scene: {}", path.display());
    let cam = if file_info.camera_missing { "none (a default camera framing the scene)".to_string() } else { scene_camera };
    match file_info.time {
        Some(t) => println!("camera: {cam}, at time code {t}"),
        None => println!("camera: {cam}"),
    }
    if file_info.cameras.len() > 1 {
        println!("  the stage's cameras (--camera): {}", file_info.cameras.join(", "));
    }
    if let Some([a, b]) = file_info.time_range.filter(|[a, b]| b > a) {
        let whole = a.fract() == 0.0 && b.fract() == 0.0;
        println!("  the stage's time codes: {a} to {b} (--frame{})", if whole { format!(", --frames {a}:{b}") } else { String::new() });
    }
    println!("geometry: {} meshes, {} instances, {} triangles", prepared.meshes.len(), r.instances, r.triangles);
    if r.subdivision_faces > 0 {
        println!("  subdivision surfaces: {} cage faces, tessellated by Embree into about {:.0} quads", r.subdivision_faces, r.subdivision_quads);
    }
    println!(
        "bounds: {:?} .. {:?} (metres), resolution {}x{}",
        prepared.bounds.0.to_array(),
        prepared.bounds.1.to_array(),
        w,
        h
    );
    println!("materials: {}", materials.len());
    for (name, mat) in materials.iter().zip(&prepared.materials) {
        println!("  {name}: {}", describe_flags(raysplat::prepare::material_flags(mat)));
    }
    println!("lights: {} UsdLux lights, {} emissive triangles", n_lights, r.emissive_triangles);
    for (e, name) in prepared.lights.emitters.iter().zip(&prepared.lights.names).take(n_lights) {
        println!("  {name}: {}", emitter_kind(e));
    }
    println!("textures: {}", r.textures);
    println!(
        "requires: diffuse {}, glossy {}, specular {}, cut-outs {}",
        yes(r.has_diffuse()),
        yes(r.has_glossy()),
        yes(r.has_specular()),
        yes(r.cutouts)
    );
    println!("{auto}");
    if !prepared.lights.is_empty() {
        // The he-fg light pass at 100k photons, split by the automatic E_max (docs/secondary-lights.md).
        let sp = integrators::he_fg::survey(&prepared, 100_000, 0).split;
        println!("strong secondary lights: {} ({})", yes(!sp.high_voxels.is_empty()), sp.summary());
    }
    if r.has_glossy() {
        // which pixels need a radiance map (§8.1), from one eye sample per pixel
        let eye = raysplat::eye::eye_pass(&prepared, &raysplat::eye::EyeSettings { spp: 1, aa_spp: 0, seed: 0, light_samples: 1 })?;
        let map = |m| raysplat::radiance_map::RadianceMap::new(m, &eye);
        let (sh, hist) = (map(raysplat::radiance_map::GlossyMode::Sh), map(raysplat::radiance_map::GlossyMode::Histogram));
        let auto = match raysplat::radiance_map::RadianceMap::auto(&eye) {
            Ok(m) => format!("SH map on {} pixels ({:.2} MiB), exact BSDF for {} glossy eye samples", m.slots() - m.extra_slots(), m.bytes() as f64 / 1048576.0, m.exact_samples),
            Err(why) => format!("exact BSDF everywhere ({why})"),
        };
        println!(
            "glossy transport (rs --glossy): {} of {} pixels glossy at 1 spp; auto (default): {auto}; radiance map sh {} (16 coefficients × RGB), histogram {} (20 strata × RGB); exact: none; diffuse pixels keep one RGB value",
            sh.slots(),
            w * h,
            format!("{:.2} MiB", sh.bytes() as f64 / 1048576.0),
            format!("{:.2} MiB", hist.bytes() as f64 / 1048576.0)
        );
    } else {
        println!("glossy transport: none needed (no glossy surface; every pixel keeps one RGB value)");
    }
    println!("warnings: {}", prepared.warnings.len());
    for wn in &prepared.warnings {
        println!("  {}: {}", wn.prim, wn.message);
    }
    Ok(())
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

fn describe_flags(f: raysplat::bsdf::BsdfFlags) -> String {
    use raysplat::bsdf::BsdfFlags as F;
    let mut v = Vec::new();
    for (flag, name) in [(F::DIFFUSE, "diffuse"), (F::GLOSSY, "glossy"), (F::SPECULAR, "specular"), (F::TRANSMISSION, "transmissive")] {
        if f.contains(flag) {
            v.push(name);
        }
    }
    v.join(" + ")
}

fn emitter_kind(e: &raysplat::light::Emitter) -> &'static str {
    use raysplat::light::Emitter::*;
    match e {
        Rect { .. } => "rect",
        Disk { .. } => "disk",
        Sphere { spot: Some(_), .. } => "spot (sphere + cone)",
        Sphere { .. } => "sphere",
        Distant { .. } => "distant",
        Dome { .. } => "dome",
        Triangle { .. } => "emissive triangle",
    }
}
