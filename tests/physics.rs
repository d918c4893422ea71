//! The solver against independent truths: the steady Poiseuille parabola and its pressure
//! gradient, mass conservation through every cross-section under the triphasic inlet, a
//! divergence-free field after projection (also around a solid body), batch independence and
//! per-environment NaN reports.

mod common;

use common::small_config;
use fluxswarm_gpu::config::Config;
use fluxswarm_gpu::gpu::GpuContext;
use fluxswarm_gpu::gpu::kernels::FieldBinding;
use fluxswarm_gpu::sim::FlowBatch;
use fluxswarm_gpu::sim::health::DIV_TOLERANCE;
use fluxswarm_gpu::sim::{CpuBatch, GpuBatch, Grid};

/// Discrete flux per unit depth of the parabolic inlet with centreline velocity U.
fn inlet_flux(g: &Grid, centre: f64) -> f64 {
    (0..g.ny).map(|j| g.inlet_profile(centre, j) * g.dy()).sum()
}

/// A solid disc (chi = 1 in cells whose centre lies inside), at rest.
fn disc(g: &Grid, cx: f64, cy: f64, r: f64) -> Vec<[f32; 4]> {
    (0..g.n_cells())
        .map(|c| {
            let x = ((c % g.nx) as f64 + 0.5) * g.dx();
            let y = ((c / g.nx) as f64 + 0.5) * g.dy();
            let inside = (x - cx).powi(2) + (y - cy).powi(2) <= r * r;
            [if inside { 1.0 } else { 0.0 }, 0.0, 0.0, 0.0]
        })
        .collect()
}

fn steady_poiseuille(scheme: &str) {
    let (_lock, ctx) = common::gpu();
    let u0 = 0.05;
    let r = small_config(
        100,
        20, // the paper's resolution across the height
        &[
            "inlet.points=[[0.0, 0.05], [0.5, 0.05]]",
            "time.substeps=10",
            &format!("solver.advection={scheme}"),
        ],
    );
    let mut b = GpuBatch::new(&ctx, &r, 1).unwrap();
    let g = *b.grid();
    // Start far from the answer: a plug flow of the same flux (inlet face keeps the parabola).
    let mean = inlet_flux(&g, u0) / g.height_m;
    let mut u = vec![mean as f32; g.n_u()];
    for j in 0..g.ny {
        u[g.u_idx(0, j)] = g.inlet_profile(u0, j) as f32;
    }
    b.write_env(FieldBinding::UIn, 0, &u).unwrap();
    let error_at = |b: &GpuBatch| {
        let f = b.fields(0).unwrap();
        let ux = f.ux_cells();
        let i = g.nx / 2;
        let (mut num, mut den) = (0.0, 0.0);
        for j in 0..g.ny {
            let exact = g.inlet_profile(u0, j);
            num += (ux[j * g.nx + i] as f64 - exact).powi(2);
            den += exact * exact;
        }
        ((num / den).sqrt(), f)
    };
    let (initial_error, _) = error_at(&b);
    for _ in 0..200 {
        let h = b.step().unwrap();
        assert!(h[0].is_finite());
    }
    let (error, f) = error_at(&b);
    // Pressure gradient of Poiseuille flow: dp/dx = -8 mu U / H^2.
    let p_col = |i: usize| (0..g.ny).map(|j| f.p[j * g.nx + i] as f64).sum::<f64>() / g.ny as f64;
    let grad = (p_col(25) - p_col(75)) / (50.0 * g.dx());
    let exact_grad = 8.0 * 3e-3 * u0 / (g.height_m * g.height_m);
    println!(
        "{scheme}: L2 error at mid-channel {initial_error:.3e} -> {error:.3e}; -dp/dx = {grad:.2} Pa/m (exact {exact_grad:.2})"
    );
    assert!(
        initial_error > 0.1,
        "the start must be far from the parabola"
    );
    assert!(error <= 0.01, "L2 error {error} above 1 %");
    assert!(
        (grad / exact_grad - 1.0).abs() <= 0.02,
        "pressure gradient {grad} vs {exact_grad}"
    );
}

#[test]
fn steady_poiseuille_maccormack() {
    steady_poiseuille("maccormack");
}

#[test]
fn steady_poiseuille_semi_lagrangian() {
    steady_poiseuille("semi_lagrangian");
}

/// Runs `steps` control steps and checks flux balance and divergence at every one.
fn check_conservation(b: &mut dyn FlowBatch, steps: usize, label: &str) {
    let g = *b.grid();
    let peak = b.waveform().peak_abs();
    let peak_flux = inlet_flux(&g, peak);
    let div_limit = DIV_TOLERANCE * peak / g.dx();
    let (mut worst_flux, mut worst_div) = (0.0f64, 0.0f64);
    for step in 1..=steps {
        let h = b.step().unwrap()[0];
        assert!(h.is_finite(), "{label}: step {step} not finite");
        let expected = inlet_flux(&g, b.inlet_u(0));
        let imbalance = (h.flux_max as f64 - h.flux_min as f64)
            .max((h.flux_max as f64 - expected).abs())
            .max((h.flux_min as f64 - expected).abs());
        worst_flux = worst_flux.max(imbalance / peak_flux);
        worst_div = worst_div.max(h.max_div as f64);
        assert!(
            imbalance <= 0.005 * peak_flux,
            "{label}: step {step} (U = {:.4} m/s): cross-section fluxes {}..{} vs inlet {expected}, \
             imbalance {imbalance:e} above 0.5 % of the peak flux {peak_flux:e}",
            b.inlet_u(0),
            h.flux_min,
            h.flux_max
        );
        assert!(
            (h.max_div as f64) <= div_limit,
            "{label}: step {step}: max |div u| = {} above {div_limit}",
            h.max_div
        );
    }
    println!(
        "{label}: worst flux imbalance {worst_flux:.2e} of the peak flux; worst max |div u| {worst_div:.3e} 1/s \
         (tolerance {div_limit:.3e} = {DIV_TOLERANCE:e} U_peak/dx)"
    );
}

#[test]
fn triphasic_inlet_conserves_mass_through_every_cross_section() {
    triphasic_conservation("sequential");
}

/// The same with the GPU's tridiagonal kernel (`pressure_scan`, four rows per thread here).
#[test]
fn triphasic_inlet_conserves_mass_with_the_scan_sweep() {
    triphasic_conservation("scan");
}

fn triphasic_conservation(sweep: &str) {
    let (_lock, ctx) = common::gpu();
    // The paper's grid and waveform: 0.3 s covers the systolic ramps, the plateau, the
    // deceleration, the reversal and the return to forward flow.
    let r = Config::load(
        None,
        &[
            "swarm.count=0".into(),
            format!("solver.pressure_sweep={sweep}"),
        ],
    )
    .unwrap();
    let mut b = GpuBatch::new(&ctx, &r, 1).unwrap();
    assert_eq!(b.pressure_sweep(), sweep);
    check_conservation(&mut b, 60, &format!("paper grid, {sweep} sweep"));
}

#[test]
fn divergence_free_and_conservative_around_a_solid_body() {
    let (_lock, ctx) = common::gpu();
    let r = small_config(200, 20, &[]);
    let mut b = GpuBatch::new(&ctx, &r, 1).unwrap();
    let g = *b.grid();
    b.set_body(0, &disc(&g, 0.01, 0.001, 250e-6)).unwrap();
    check_conservation(&mut b, 36, "disc in a 20 mm channel");
    // The body is felt: the flow inside it is much slower than the flow beside it.
    let f = b.fields(0).unwrap();
    let ux = f.ux_cells();
    let at = |x: f64, y: f64| ux[(y / g.dy()) as usize * g.nx + (x / g.dx()) as usize].abs();
    assert!(at(0.01, 0.001) < 0.2 * at(0.01, 0.0004).max(at(0.01, 0.0016)));
}

/// A vessel of `ny` cells of 0.1 mm across (ny x 0.1 mm high), `nx` long, no swarm: on the
/// CPU stages, then, given a device, on the WGSL kernels (their column variants for ny > 64,
/// `gpu::kernels::Columns`).
fn tall(kernels: Option<&GpuContext>, nx: u32, ny: u32, extra: &[&str]) -> Vec<Box<dyn FlowBatch>> {
    let r = small_config(nx, ny, extra);
    let mut batches: Vec<Box<dyn FlowBatch>> = vec![Box::new(CpuBatch::new(&r, 1).unwrap())];
    if let Some(ctx) = kernels {
        batches.push(Box::new(GpuBatch::new(ctx, &r, 1).unwrap()));
    }
    batches
}

/// The developed Poiseuille flow of a tall grid (ny = 128, 256, including the CPU's FFT-based
/// y-transforms from 192 cells), on both backends, stays developed: after 40 control steps
/// (0.2 s) the mid-channel profile is within 0.1 % of the parabola and -dp/dx within 2 % of 8 mu U / H^2.
/// Without the balance of diffusion and the projection's pressure gradient the centreline
/// would lose nu |u''| t = 2.8 % (ny = 128) or 0.7 % (ny = 256) of U in that time.
#[test]
fn developed_poiseuille_holds_on_tall_grids() {
    let (_lock, ctx) = common::gpu();
    for ny in [128u32, 256] {
        let u0 = 0.05;
        for mut b in tall(
            Some(&ctx),
            24,
            ny,
            &["inlet.points=[[0.0, 0.05], [0.5, 0.05]]"],
        ) {
            let name = b.backend_name();
            let g = *b.grid();
            for _ in 0..40 {
                assert!(b.step().unwrap()[0].is_finite());
            }
            let f = b.fields(0).unwrap();
            let ux = f.ux_cells();
            let i = g.nx / 2;
            let (mut num, mut den) = (0.0, 0.0);
            for j in 0..g.ny {
                let exact = g.inlet_profile(u0, j);
                num += (ux[j * g.nx + i] as f64 - exact).powi(2);
                den += exact * exact;
            }
            let error = (num / den).sqrt();
            let p_col =
                |i: usize| (0..g.ny).map(|j| f.p[j * g.nx + i] as f64).sum::<f64>() / g.ny as f64;
            let grad = (p_col(4) - p_col(19)) / (15.0 * g.dx());
            let exact_grad = 8.0 * 3e-3 * u0 / (g.height_m * g.height_m);
            println!(
                "ny = {ny}, {name}: L2 error {error:.3e}; -dp/dx = {grad:.4} Pa/m (exact {exact_grad:.4})"
            );
            assert!(error <= 1e-3, "ny = {ny}, {name}: L2 error {error}");
            assert!(
                (grad / exact_grad - 1.0).abs() <= 0.02,
                "ny = {ny}, {name}: {grad} vs {exact_grad}"
            );
        }
    }
}

/// Mass conservation under the triphasic inlet through the systole on tall grids: the CPU
/// backend at ny = 128 and 256, the kernels at 256 (their widest column variant, where the CPU
/// takes its FFT path). The kernels' 128-cell variant is checked by the Poiseuille test above
/// and `whole_control_step_on_a_tall_grid_matches_cpu` (tests/kernels.rs); its conservation run
/// here would add 25 s to the SwiftShader pass (the 256 one takes 34 s there, 6 s on lavapipe).
#[test]
fn triphasic_inlet_conserves_mass_on_tall_grids() {
    let (_lock, ctx) = common::gpu();
    for ny in [128u32, 256] {
        let kernels = (ny == 256).then_some(&ctx);
        for mut b in tall(kernels, 100, ny, &[]) {
            let label = format!("100 x {ny} on the {} backend", b.backend_name());
            check_conservation(b.as_mut(), 30, &label);
        }
    }
}

/// Sets up environment `e` of a batch as scenario `s` (0, 1, 2): different phases and bodies.
fn scenario(b: &mut GpuBatch, e: usize, s: usize) {
    let g = *b.grid();
    b.reset_env_with_phase(e, [0.0, 0.3, 0.02][s]).unwrap();
    if s == 2 {
        b.set_body(e, &disc(&g, 0.004, 0.0007, 250e-6)).unwrap();
    }
}

#[test]
fn environments_are_independent_and_nan_is_reported_per_environment() {
    let (_lock, ctx) = common::gpu();
    let r = small_config(80, 12, &[]);
    let steps = 8;
    let nan_step = 3;
    let mut batch = GpuBatch::new(&ctx, &r, 3).unwrap();
    for s in 0..3 {
        scenario(&mut batch, s, s);
    }
    let mut health = Vec::new();
    for step in 1..=steps {
        if step == nan_step + 1 {
            // Poison one face of environment 1 after step 3.
            let mut u = batch.read_env(FieldBinding::UIn, 1).unwrap();
            u[batch.grid().u_idx(40, 6)] = f32::NAN;
            batch.write_env(FieldBinding::UIn, 1, &u).unwrap();
        }
        health.push(batch.step().unwrap());
    }
    for (k, h) in health.iter().enumerate() {
        let step = k + 1;
        assert!(
            h[0].is_finite() && h[2].is_finite(),
            "step {step}: a healthy environment reported bad"
        );
        assert_eq!(
            h[1].diverged(),
            step > nan_step,
            "step {step}: environment 1 report"
        );
    }
    for s in [0, 2] {
        let mut alone = GpuBatch::new(&ctx, &r, 1).unwrap();
        scenario(&mut alone, 0, s);
        for _ in 0..steps {
            alone.step().unwrap();
        }
        let a = alone.fields(0).unwrap();
        let b = batch.fields(s).unwrap();
        assert!(a.u_faces.iter().all(|x| x.is_finite()));
        assert_eq!(
            a.u_faces, b.u_faces,
            "environment {s}: u differs from the same run alone"
        );
        assert_eq!(
            a.v_faces, b.v_faces,
            "environment {s}: v differs from the same run alone"
        );
        assert_eq!(
            a.p, b.p,
            "environment {s}: p differs from the same run alone"
        );
    }
}
