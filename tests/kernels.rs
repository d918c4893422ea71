//! Each GPU kernel equals its plain-Rust twin (`sim::cpu`) on an awkward size: 3 environments
//! of 37 x 11 cells (not multiples of any workgroup), random fields and a random solid body.
//! The column kernels (`pressure_rhs`, `pressure_back`) also on tall grids, one per column
//! variant above 64 cells (`gpu::kernels::Columns`), and a whole control step at ny = 128.

mod common;

use common::{Noise, max_diff, random_body, small_config};
use fluxswarm_gpu::config::Advection;
use fluxswarm_gpu::gpu::GpuContext;
use fluxswarm_gpu::gpu::kernels::FieldBinding;
use fluxswarm_gpu::sim::FlowBatch;
use fluxswarm_gpu::sim::cpu;
use fluxswarm_gpu::sim::{GpuBatch, Stage};

const E: usize = 3;
const NX: u32 = 37;
const NY: u32 = 11;

/// Tall grids (nx, ny): the 128 x 32 column variant (100 cells), the 256 x 16 one just past
/// 128 cells and at its top (where the CPU stages take their FFT-based transforms); no nx is a
/// multiple of the 32 or 16 columns of a workgroup.
const TALL: [(u32, u32); 3] = [(41, 100), (37, 129), (23, 256)];
const TALL_ENVS: usize = 2;

fn tall_batch(ctx: &GpuContext, nx: u32, ny: u32) -> GpuBatch {
    GpuBatch::new(ctx, &small_config(nx, ny, &[]), TALL_ENVS).unwrap()
}

fn batch(ctx: &GpuContext, scheme: &str) -> GpuBatch {
    batch_with(ctx, scheme, "euler")
}

fn batch_with(ctx: &GpuContext, scheme: &str, trace: &str) -> GpuBatch {
    let r = small_config(
        NX,
        NY,
        &[
            &format!("solver.advection={scheme}"),
            &format!("solver.backtrace={trace}"),
        ],
    );
    GpuBatch::new(ctx, &r, E).unwrap()
}

/// Random velocities of about 0.2 m/s (departure points up to ~1 cell away), random bodies
/// (a quarter of the cells partly or fully solid, moving) and random inlet values.
fn randomise(batch: &mut GpuBatch, seed: u64) -> (Vec<f32>, Vec<f32>, Vec<[f32; 4]>, Vec<f32>) {
    let g = *batch.grid();
    let n_env = batch.n_env();
    let mut n = Noise::new(seed);
    let u: Vec<f32> = n
        .vec(n_env * g.n_u(), 0.2)
        .iter()
        .map(|x| x + 0.15)
        .collect();
    let v = n.vec(n_env * g.n_v(), 0.1);
    let mut body = Vec::new();
    for e in 0..n_env {
        let cells = random_body(&mut n, g.n_cells());
        batch.set_body(e, &cells).unwrap();
        body.extend(cells);
    }
    let inlet = n.vec(n_env * batch.substeps(), 0.3);
    batch.write_all(FieldBinding::UIn, &u);
    batch.write_all(FieldBinding::VIn, &v);
    batch.write_all(FieldBinding::Inlet, &inlet);
    (u, v, body, inlet)
}

fn assert_close(name: &str, gpu: &[f32], cpu: &[f32], rel: f32) {
    let (d, m) = max_diff(gpu, cpu);
    assert!(
        d <= rel * m.max(1e-30),
        "{name}: max |gpu - cpu| = {d:e} vs max |cpu| = {m:e}"
    );
}

fn advect_matches(scheme: &str, kind: Advection, trace: &str) {
    let (_lock, ctx) = common::gpu();
    let mut b = batch_with(&ctx, scheme, trace);
    assert_eq!(b.params().rk2, (trace == "rk2") as u32);
    let (u, v, body, inlet) = randomise(&mut b, 7);
    let s = 3; // a substep other than 0: reads its own inlet value
    b.run_stages(&[Stage::Advect], s, 1).unwrap();
    let gu = b.read_all(FieldBinding::UOut).unwrap();
    let gv = b.read_all(FieldBinding::VOut).unwrap();
    let (cu, cv) = cpu::advect(
        b.params(),
        kind,
        &cpu::AdvectInputs {
            u: &u,
            v: &v,
            body: &body,
            inlet: &inlet,
            substep: s,
        },
    );
    assert_close("u*", &gu, &cu, 1e-5);
    assert_close("v*", &gv, &cv, 1e-5);
}

#[test]
fn advect_semi_lagrangian_euler_matches_cpu() {
    advect_matches("semi_lagrangian", Advection::SemiLagrangian, "euler");
}

#[test]
fn advect_semi_lagrangian_rk2_matches_cpu() {
    advect_matches("semi_lagrangian", Advection::SemiLagrangian, "rk2");
}

#[test]
fn advect_maccormack_euler_matches_cpu() {
    advect_matches("maccormack", Advection::Maccormack, "euler");
}

#[test]
fn advect_maccormack_rk2_matches_cpu() {
    advect_matches("maccormack", Advection::Maccormack, "rk2");
}

#[test]
fn pressure_rhs_matches_cpu() {
    let (_lock, ctx) = common::gpu();
    rhs_matches(&batch(&ctx, "maccormack"), "37 x 11");
}

/// The kernel's modes and column maxima of |div u*| against the CPU stage's on random fields.
fn rhs_matches(b: &GpuBatch, size: &str) {
    let g = *b.grid();
    let n_env = b.n_env();
    let mut n = Noise::new(11);
    let u = n.vec(n_env * g.n_u(), 0.3);
    let v = n.vec(n_env * g.n_v(), 0.1);
    b.write_all(FieldBinding::UOut, &u);
    b.write_all(FieldBinding::VOut, &v);
    b.run_stages(&[Stage::PressureRhs], 0, 1).unwrap();
    let poisson = b.read_all(FieldBinding::Poisson).unwrap();
    let (modes, divstar) = cpu::pressure_rhs(b.params(), &poisson, &u, &v);
    assert_close(
        &format!("modes at {size}"),
        &b.read_all(FieldBinding::Modes).unwrap(),
        &modes,
        1e-5,
    );
    assert_close(
        &format!("divstar at {size}"),
        &b.read_all(FieldBinding::DivStar).unwrap(),
        &divstar,
        1e-6,
    );
}

/// Runs the batch's tridiagonal kernel on random right-hand sides and compares it with the
/// CPU twin's Thomas sweeps.
fn solve_matches_thomas(b: &GpuBatch, n_env: usize, seed: u64, label: &str) {
    let rhs = Noise::new(seed).vec(n_env * b.grid().n_cells(), 1e5);
    b.write_all(FieldBinding::Modes, &rhs);
    b.run_stages(&[Stage::PressureSolve], 0, 1).unwrap();
    let poisson = b.read_all(FieldBinding::Poisson).unwrap();
    let mut modes = rhs.clone();
    cpu::pressure_solve(b.params(), &poisson, &mut modes);
    assert_close(
        label,
        &b.read_all(FieldBinding::Modes).unwrap(),
        &modes,
        1e-5,
    );
}

#[test]
fn pressure_solve_matches_cpu() {
    let (_lock, ctx) = common::gpu();
    let r = small_config(NX, NY, &["solver.pressure_sweep=sequential"]);
    let b = GpuBatch::new(&ctx, &r, E).unwrap();
    assert_eq!(b.pressure_sweep(), "sequential");
    solve_matches_thomas(&b, E, 13, "solved modes");
}

/// The scan kernel (`solver.pressure_sweep = "scan"`) solves the same systems as the CPU
/// twin's Thomas sweeps: fewer rows than threads (37: one row per thread, most threads empty),
/// three rows per thread with a partial last chunk (601 = 200 x 3 + 1), and the paper's size.
#[test]
fn pressure_scan_matches_cpu_thomas() {
    let (_lock, ctx) = common::gpu();
    for (nx, ny, n_env) in [(NX, NY, E), (601, 5, 2), (1000, 20, 1)] {
        let r = small_config(nx, ny, &["solver.pressure_sweep=scan"]);
        let b = GpuBatch::new(&ctx, &r, n_env).unwrap();
        assert_eq!(b.pressure_sweep(), "scan");
        solve_matches_thomas(&b, n_env, 17, &format!("scan-solved modes at {nx} x {ny}"));
    }
}

#[test]
fn project_matches_cpu() {
    let (_lock, ctx) = common::gpu();
    project_matches(&batch(&ctx, "maccormack"), "37 x 11");
}

/// Both column kernels on each tall grid, one batch per grid (building a batch's pipelines
/// takes seconds on SwiftShader).
#[test]
fn pressure_rhs_and_project_match_cpu_on_tall_grids() {
    let (_lock, ctx) = common::gpu();
    for (nx, ny) in TALL {
        let b = tall_batch(&ctx, nx, ny);
        let size = format!("{nx} x {ny}");
        rhs_matches(&b, &size);
        project_matches(&b, &size);
    }
}

/// `pressure_back` and `project` against the CPU stage on random modes and velocities.
fn project_matches(b: &GpuBatch, size: &str) {
    let g = *b.grid();
    let n_env = b.n_env();
    let mut n = Noise::new(17);
    let modes = n.vec(n_env * g.n_cells(), 50.0);
    let mut u = n.vec(n_env * g.n_u(), 0.3);
    let mut v = n.vec(n_env * g.n_v(), 0.1);
    b.write_all(FieldBinding::Modes, &modes);
    b.write_all(FieldBinding::UOut, &u);
    b.write_all(FieldBinding::VOut, &v);
    b.run_stages(&[Stage::Project], 0, 1).unwrap();
    let poisson = b.read_all(FieldBinding::Poisson).unwrap();
    let p = cpu::project(b.params(), &poisson, &modes, &mut u, &mut v);
    let gpu_p = b.read_all(FieldBinding::Pressure).unwrap();
    assert_close(&format!("p at {size}"), &gpu_p, &p, 1e-5);
    let gpu_u = b.read_all(FieldBinding::UOut).unwrap();
    assert_close(&format!("u at {size}"), &gpu_u, &u, 1e-5);
    let gpu_v = b.read_all(FieldBinding::VOut).unwrap();
    assert_close(&format!("v at {size}"), &gpu_v, &v, 1e-5);
}

#[test]
fn diagnostics_match_cpu_and_count_non_finite_values() {
    let (_lock, ctx) = common::gpu();
    let mut b = batch(&ctx, "maccormack");
    let g = *b.grid();
    let mut n = Noise::new(19);
    let mut u = n.vec(E * g.n_u(), 0.3);
    let v = n.vec(E * g.n_v(), 0.1);
    let p = n.vec(E * g.n_cells(), 100.0);
    let divstar = n
        .vec(E * g.nx, 10.0)
        .iter()
        .map(|x| x.abs())
        .collect::<Vec<_>>();
    u[g.n_u() + g.u_idx(5, 3)] = f32::NAN; // environment 1 only
    b.write_all(FieldBinding::UIn, &u);
    b.write_all(FieldBinding::VIn, &v);
    b.write_all(FieldBinding::Pressure, &p);
    b.write_all(FieldBinding::DivStar, &divstar);
    let gpu = b.health().unwrap();
    let cpu = cpu::diagnostics(b.params(), &u, &v, &p, &divstar);
    for e in [0, 2] {
        let (h, c) = (gpu[e], cpu[e]);
        assert!(h.is_finite() && c.is_finite());
        for (name, a, b) in [
            ("flux_min", h.flux_min, c.flux_min),
            ("flux_max", h.flux_max, c.flux_max),
            ("inlet_flux", h.inlet_flux, c.inlet_flux),
        ] {
            assert!(
                (a - b).abs() <= 1e-5 * b.abs().max(1e-6),
                "env {e} {name}: {a} vs {b}"
            );
        }
        let bound = max_div_bound(&g, b.params().dx, b.params().dy, &u, &v, e);
        assert!(
            (h.max_div - c.max_div).abs() <= bound,
            "env {e} max_div: {} vs {} (bound {bound})",
            h.max_div,
            c.max_div
        );
        assert_eq!(h.max_speed, c.max_speed, "env {e} max_speed");
        assert_eq!(h.div_before, c.div_before, "env {e} div_before");
    }
    // The NaN face touches its own flux, two cell divergences and itself: counted, env 1 only.
    assert!(gpu[1].nonfinite > 0 && gpu[1].diverged());
    assert_eq!(gpu[1].nonfinite, cpu[1].nonfinite);
}

/// The most WGSL's accuracy rules let the GPU's max |div u| differ from the CPU's in
/// environment `e`. Per cell, div = (u_e - u_w)/dx + (v_n - v_s)/dy: the differences are
/// correctly rounded on both, a quotient is within 2.5 ULP on the GPU (WGSL's f32 division) and
/// 0.5 ULP on the CPU, and the sum is rounded once on each (or contracted into an FMA), so the
/// two differ by at most 3 ULP(q1) + 3 ULP(q2) + ULP(q1 + q2) <= 4 * 2^-23 * (|q1| + |q2|).
/// A max is 1-Lipschitz, so the worst cell's bound holds for max |div u|. (Measured on an H200,
/// 2026-12-04: 1 ULP apart, where lavapipe gives the CPU's value exactly.)
fn max_div_bound(
    g: &fluxswarm_gpu::sim::Grid,
    dx: f32,
    dy: f32,
    u: &[f32],
    v: &[f32],
    e: usize,
) -> f32 {
    let (u, v) = (&u[e * g.n_u()..], &v[e * g.n_v()..]);
    let mut worst = 0.0f32;
    for j in 0..g.ny {
        for i in 0..g.nx {
            let q1 = (u[g.u_idx(i + 1, j)] - u[g.u_idx(i, j)]) / dx;
            let q2 = (v[g.v_idx(i, j + 1)] - v[g.v_idx(i, j)]) / dy;
            worst = worst.max(q1.abs() + q2.abs());
        }
    }
    4.0 * f32::EPSILON * worst
}

#[test]
fn whole_control_step_matches_cpu() {
    whole_control_step_matches_cpu_with(NX, NY, E, "sequential");
}

#[test]
fn whole_control_step_with_the_scan_sweep_matches_cpu() {
    whole_control_step_matches_cpu_with(NX, NY, E, "scan");
}

/// ny = 128: the 128 x 32 column variant in a whole control step.
#[test]
fn whole_control_step_on_a_tall_grid_matches_cpu() {
    whole_control_step_matches_cpu_with(NX, 128, TALL_ENVS, "sequential");
}

fn whole_control_step_matches_cpu_with(nx: u32, ny: u32, n_env: usize, sweep: &str) {
    let (_lock, ctx) = common::gpu();
    let r = small_config(
        nx,
        ny,
        &[
            "time.substeps=5",
            "time.control_dt_s=0.00125",
            &format!("solver.pressure_sweep={sweep}"),
        ],
    );
    let mut b = GpuBatch::new(&ctx, &r, n_env).unwrap();
    assert_eq!(b.pressure_sweep(), sweep);
    let (u, v, body, _) = randomise(&mut b, 23);
    let poisson = b.read_all(FieldBinding::Poisson).unwrap();
    let mut reference = cpu::BatchState {
        params: *b.params(),
        scheme: Advection::Maccormack,
        poisson,
        u,
        v,
        p: vec![0.0; n_env * b.grid().n_cells()],
        body,
        divstar: vec![0.0; n_env * b.grid().nx],
        members: Vec::new(),
        actions: Vec::new(),
        boxes: Vec::new(),
    };
    // The inlet values the batch will use for this step.
    let inlet: Vec<f32> = (0..n_env)
        .flat_map(|_| (0..5).map(|s| b.waveform().at((s as f64 + 1.0) * 0.00125 / 5.0) as f32))
        .collect();
    let health = b.step().unwrap();
    let cpu_health = reference.step(&inlet);
    assert_close(
        "u",
        &b.read_all(FieldBinding::UIn).unwrap(),
        &reference.u,
        1e-4,
    );
    assert_close(
        "v",
        &b.read_all(FieldBinding::VIn).unwrap(),
        &reference.v,
        1e-4,
    );
    assert_close(
        "p",
        &b.read_all(FieldBinding::Pressure).unwrap(),
        &reference.p,
        1e-4,
    );
    for e in 0..n_env {
        let (h, c) = (health[e], cpu_health[e]);
        assert!((h.flux_max - c.flux_max).abs() <= 1e-4 * c.flux_max.abs());
    }
}
