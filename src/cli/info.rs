//! `fluxswarm-gpu info`: which backend `solver.backend` runs and why (SPEC section 8), the
//! adapters, the chosen one, its limits, the driver self-check and the largest batch at the
//! configured grid. Works with no adapter at all (it says so).

use clap::Args;
use fluxswarm_gpu::gpu::{GpuContext, context, probe};
use fluxswarm_gpu::sim::{Grid, fluid};

use super::common::ConfigArgs;

#[derive(Debug, Args)]
pub struct InfoArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let resolved = args.common.load()?;
    let adapters = context::enumerate_adapters();
    println!("adapters found: {}", adapters.len());
    for a in &adapters {
        println!("  - {}", context::describe(&a.get_info()));
    }
    match fluxswarm_gpu::sim::open(&resolved, 1, args.common.adapter) {
        Ok(opened) => {
            println!("{}", opened.header());
            for w in &opened.warnings {
                println!("  warning: {w}");
            }
        }
        Err(e) => println!("control step: cannot open a batch: {e}"),
    }
    let ctx = match GpuContext::new(args.common.adapter) {
        Ok(ctx) => ctx,
        Err(e) => {
            println!("no adapter for the WGSL kernels: {e}");
            return Ok(());
        }
    };
    println!("chosen ({:?}): {}", args.common.adapter, ctx.banner());
    let l = &ctx.limits;
    println!("limits:");
    println!(
        "  max_buffer_size                     {} MiB",
        l.max_buffer_size >> 20
    );
    println!(
        "  max_storage_buffer_binding_size     {} MiB",
        l.max_storage_buffer_binding_size >> 20
    );
    println!(
        "  max_storage_buffers_per_shader_stage {}",
        l.max_storage_buffers_per_shader_stage
    );
    println!(
        "  max_compute_workgroups_per_dimension {}",
        l.max_compute_workgroups_per_dimension
    );
    println!(
        "  max_compute_invocations_per_workgroup {}",
        l.max_compute_invocations_per_workgroup
    );
    println!(
        "  min_uniform_buffer_offset_alignment {}",
        l.min_uniform_buffer_offset_alignment
    );
    match probe::check_loop_cap(&ctx)? {
        None => println!(
            "driver self-check: long shader loops run in full ({} trips)",
            probe::PROBE_TRIPS
        ),
        Some(w) => println!("driver self-check: FAILED: {w}"),
    }
    let c = &resolved.config;
    let grid = Grid::from_config(c);
    let per_env = fluid::bytes_per_env(&grid, c.time.substeps as usize);
    println!(
        "grid {} x {} ({} substeps): {:.2} MiB of buffers per environment",
        grid.nx,
        grid.ny,
        c.time.substeps,
        per_env as f64 / (1 << 20) as f64
    );
    println!(
        "largest batch: {} environments (bounded by the {} MiB storage-binding limit of the \
         {:.2} MiB body buffer per environment; wgpu does not report device memory, so check \
         that E x {:.2} MiB fits it)",
        fluid::max_batch(l, &grid),
        l.max_storage_buffer_binding_size.min(l.max_buffer_size) >> 20,
        fluid::largest_buffer_per_env(&grid) as f64 / (1 << 20) as f64,
        per_env as f64 / (1 << 20) as f64
    );
    Ok(())
}
