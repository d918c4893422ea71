//! Buffer sizes per environment, the largest batch an adapter allows, and the kernels' batch
//! constants (needed without a GPU too: the CPU backend takes the same struct).

use super::*;

/// Bytes of the largest single buffer of one environment (the body buffer, 16 B per cell).
pub fn largest_buffer_per_env(grid: &Grid) -> u64 {
    (grid.n_cells() * 16)
        .max(grid.n_u() * 4)
        .max(grid.n_v() * 4) as u64
}

/// Bytes of all buffers of one environment.
pub fn bytes_per_env(grid: &Grid, substeps: usize) -> u64 {
    let f = 4u64;
    let vel = (grid.n_u() + grid.n_v()) as u64 * f;
    8 * vel // u, v ping-pong, w_u/w_v, u_hat/v_hat (vec4)
        + 2 * grid.n_cells() as u64 * f // p, modes
        + grid.n_cells() as u64 * 16 // body
        + substeps as u64 * f
        + grid.nx as u64 * f
        + (grid.nx as u64 + 1) * 16
        + 32
}

/// Largest batch the adapter's binding and dispatch limits allow at this grid.
pub fn max_batch(limits: &wgpu::Limits, grid: &Grid) -> usize {
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let by_binding = (binding / largest_buffer_per_env(grid)) as usize;
    by_binding.min(limits.max_compute_workgroups_per_dimension as usize)
}

/// The kernels' batch constants for `n_env` environments of this configuration (no GPU needed:
/// the CPU stages take the same struct).
pub fn batch_params(resolved: &Resolved, n_env: usize) -> GpuParams {
    let config = &resolved.config;
    let grid = Grid::from_config(config);
    let swarm = &config.swarm;
    let substeps = config.time.substeps as usize;
    let n_members = swarm.count as usize;
    // Pressure samples just outside the painted solid: R_s = r + 2 dx (SPEC section 2).
    let sample_radius = swarm.radius_m + 2.0 * grid.dx();
    GpuParams {
        nx: grid.nx as u32,
        ny: grid.ny as u32,
        n_env: n_env as u32,
        substeps: substeps as u32,
        dx: grid.dx() as f32,
        dy: grid.dy() as f32,
        dt: config.dt_sub() as f32,
        nu: config.kinematic_viscosity() as f32,
        rho: config.fluid.density_kg_m3 as f32,
        height: grid.height_m as f32,
        rk2: (config.solver.backtrace == Backtrace::Rk2) as u32,
        pad1: 0.0,
        inv_dx: (1.0 / grid.dx()) as f32,
        inv_dy: (1.0 / grid.dy()) as f32,
        length: grid.length_m as f32,
        mu: config.fluid.viscosity_pa_s as f32,
        n_members: n_members as u32,
        drag: config.swarm.drag as u32,
        radius: swarm.radius_m as f32,
        sample_radius: sample_radius as f32,
        depth: (4.0 * swarm.radius_m * swarm.radius_m / (3.0 * sample_radius)) as f32,
        mass: swarm.mass_kg() as f32,
        max_thrust: swarm.max_thrust_n as f32,
        pad4: 0.0,
        pad5: 0.0,
        pad6: 0.0,
        pad7: 0.0,
        pad8: 0.0,
    }
}
