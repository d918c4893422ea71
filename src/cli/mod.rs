//! Command-line interface: clap subcommands, each calling its module's `run`; `common`,
//! `progress` and `signals` are shared by them.

mod bench;
mod bench_cpu;
mod common;
mod eval;
mod info;
mod map;
mod progress;
mod report;
mod rollout;
mod signals;
mod simulate;
mod sweep;
mod train;
mod train_logs;

use clap::{Parser, Subcommand};

pub use common::error_chain;
pub use signals::Stopped;

#[derive(Debug, Parser)]
#[command(
    name = "fluxswarm-gpu",
    version,
    about = "Batched GPU Navier-Stokes channel flow for micro-robot swarms in pulsatile blood flow"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// List adapters, the chosen one, its limits, the driver self-check and the largest batch.
    Info(info::InfoArgs),
    /// Run the flow and write frames, fields and summary.csv.
    Simulate(simulate::SimulateArgs),
    /// Measure environment steps per second per batch size at the configured grid.
    Bench(bench::BenchArgs),
    /// Run a baseline or trained policy for K episodes and write episodes, swarm and trajectory CSVs.
    Rollout(rollout::RolloutArgs),
    /// Train the swarm with MOMAPPO + PCGrad: logs, TensorBoard events, checkpoints, --resume.
    Train(train::TrainArgs),
    /// Run a trained checkpoint for K episodes and write the same files as rollout.
    Eval(eval::EvalArgs),
    /// Figures and report.md from train runs, baselines and before/after rollouts.
    Report(report::ReportArgs),
    /// The controllability map (map.csv, points.csv, heatmaps) from a directory of rollouts.
    Map(map::MapArgs),
    /// Many runs of train, rollout or eval over a grid of overrides and seeds: a local pool or
    /// a Slurm job array, resumable (SPEC section 8).
    Sweep(sweep::SweepArgs),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info(a) => info::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Rollout(a) => rollout::run(a),
        Command::Train(a) => train::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Report(a) => report::run(a),
        Command::Map(a) => map::run(a),
        Command::Sweep(a) => sweep::run(a),
    }
}
