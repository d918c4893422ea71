//! `fluxswarm-gpu map DIR`: the controllability map from the rollout directories below DIR
//! (`experiments/controllability_map.sh` writes them): `controllability_map.csv`, `controllability_points.csv` and the
//! heatmaps of `fluxswarm_gpu::report::map_output`. Needs no adapter.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use fluxswarm_gpu::report::{map, map_output};

#[derive(Debug, Args)]
pub struct MapArgs {
    /// A directory holding rollout directories (any depth) written with starts.csv, and
    /// optionally wall-drag probes under DIR/wall_drag/.
    pub dir: PathBuf,
    /// Output directory (default: DIR).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Start phases in [0, S) count as systole starts (the paper waveform's systole ends at
    /// 0.15 s).
    #[arg(long, default_value_t = 0.15, value_name = "S")]
    pub systole_end_s: f64,
}

pub fn run(args: MapArgs) -> anyhow::Result<()> {
    let (runs, probes) = map::load(&args.dir)?;
    let cells: Vec<map::Cell> = runs.iter().map(|r| r.cell(args.systole_end_s)).collect();
    let out = args.out.unwrap_or_else(|| args.dir.clone());
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let write = |name: &str, text: String| {
        std::fs::write(out.join(name), text).with_context(|| format!("writing {name}"))
    };
    write(
        "controllability_map.csv",
        map_output::map_csv(&cells, &probes),
    )?;
    write(
        "controllability_points.csv",
        map_output::points_csv(&map_output::points(&cells)),
    )?;
    let figures = map_output::figures(&cells, &probes, &out)?;
    log::info!(
        "{} runs, {} wall-drag probes: controllability_map.csv, controllability_points.csv, {}",
        runs.len(),
        probes.len(),
        figures.join(", ")
    );
    println!("{}", out.display());
    Ok(())
}
