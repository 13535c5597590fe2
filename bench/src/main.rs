//! `raysplat-bench`: the papers' tables and the measurements behind the documentation's figures,
//! one subcommand per table. Not part of the renderer or of `raysplat`; `make bench` runs them all.
//! Each table measures its rows in one run, so that they compare as ratios on a shared machine.

mod auto;
mod cache;
mod cone_timing;
mod embree;
mod fg;
mod load;
mod photons;
mod pt;
mod pt_errors;
mod real;
mod secondary;
mod splat_timing;
mod target;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "raysplat-bench", version, about = "raysplat's paper tables and measurements")]
struct Cli {
    #[command(subcommand)]
    table: Table,
}

#[derive(Subcommand)]
enum Table {
    /// Embree and path-tracer throughput (as `raysplat bench`), and the share of the path tracer's
    /// time inside Embree, estimated and (built with `--features embree-timing`) measured.
    Embree(embree::EmbreeArgs),
    /// The splatting paper's Table 2: phase times and errors of pm and rs at equal photons, and the
    /// cone-frustum search against a spherical one.
    Photons(photons::PhotonTableArgs),
    /// auto against every method at equal time.
    Auto(auto::AutoTableArgs),
    /// The reverse photon mapping paper's Table 1: pm-fg against rpm-fg.
    Fg(fg::FgTableArgs),
    /// Uniform against explicit final gathering on a scene with strong secondary light.
    Secondary(secondary::SecondaryTableArgs),
    /// The time each method needs to reach a target error against the converged image.
    Target(target::TargetTableArgs),
    /// Path-tracer samples per second on USD stages, and Mitsuba 3's when installed (ratios), with
    /// matching pixel filters; with `--reference-spp` both renderers' errors.
    Pt(pt::PtArgs),
    /// Radiance caching (rs-rc) against pm and rs: time and error (the splatting paper's Table 2).
    Cache(cache::CacheTableArgs),
    /// USD conversion and scene-file loading times.
    Load(load::LoadArgs),
    /// Real scenes: auto and each method at equal times against a path-traced reference.
    Real(real::RealTableArgs),
}

fn main() {
    let cli = Cli::parse();
    let result = match &cli.table {
        Table::Embree(a) => embree::run(a),
        Table::Photons(a) => photons::run(a),
        Table::Auto(a) => auto::run(a),
        Table::Fg(a) => fg::run(a),
        Table::Secondary(a) => secondary::run(a),
        Table::Target(a) => target::run(a),
        Table::Cache(a) => cache::run(a),
        Table::Load(a) => load::run(a),
        Table::Pt(a) => pt::run(a),
        Table::Real(a) => real::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {}", raysplat_cli::message(&e));
        std::process::exit(raysplat_cli::exit_code(&e));
    }
}
