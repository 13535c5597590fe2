//! `raysplat-bench load`: how long USD stages take to convert (usd-core, no cache) and their scene
//! files to load, with their size: the figures `docs/scene-format.md` quotes for Crytek Sponza.

use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct LoadArgs {
    /// USD stages (comma separated).
    #[arg(required = true, num_args = 1.., value_delimiter = ',', value_name = "STAGES")]
    pub stages: Vec<PathBuf>,
}

pub fn run(a: &LoadArgs) -> anyhow::Result<()> {
    let dir = tempfile_dir()?;
    println!("conversion (usd-core, no cache) and loading of the scene file, seconds");
    for (k, stage) in a.stages.iter().enumerate() {
        let rss = dir.join(format!("{k}.rss"));
        let t0 = Instant::now();
        raysplat::usd::convert(stage, &rss, &Default::default())?;
        let convert = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let scene = raysplat::usd::load_scene(&rss)?;
        let load = t1.elapsed().as_secs_f64();
        let triangles: usize = scene.instances.iter().filter_map(|i| scene.meshes.get(i.mesh as usize)).map(|m| m.indices.len()).sum();
        let bytes = std::fs::metadata(&rss).map_or(0, |m| m.len());
        println!(
            "  {}: convert {convert:.2} s, load {load:.2} s; {triangles} triangles, {} meshes, {:.1} MiB",
            stage.display(),
            scene.meshes.len(),
            bytes as f64 / (1u64 << 20) as f64
        );
        std::fs::remove_file(&rss).ok();
    }
    std::fs::remove_dir(&dir).ok();
    Ok(())
}

/// A new folder in the temporary directory for the converted files.
fn tempfile_dir() -> anyhow::Result<PathBuf> {
    let dir = std::env::temp_dir().join(format!("raysplat-bench-load-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| raysplat::Error::io(&dir, e))?;
    Ok(dir)
}
