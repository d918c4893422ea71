//! `bench`'s measuring tools: a timestamped control step advances the batch exactly like a
//! plain one and names every dispatch, and the traffic model counts each kernel's buffers.

mod common;

use fluxswarm_gpu::gpu::kernels::FieldBinding;
use fluxswarm_gpu::sim::FlowBatch;
use fluxswarm_gpu::sim::GpuBatch;

#[test]
fn a_profiled_step_is_a_plain_step_with_every_dispatch_timed() {
    let (_lock, ctx) = common::gpu();
    let cfg = common::swarm_config(
        90,
        10,
        &[[3.0, 0.5], [4.5, 0.4]],
        // The sweep is pinned: `auto` picks `pressure_scan` on a GPU and `pressure_solve` on a
        // software adapter (the H200 run of 2026-12-04 found the list below driver-dependent).
        &[
            "time.substeps=3",
            "time.control_dt_s=0.00075",
            "solver.pressure_sweep=sequential",
        ],
    );
    let mut plain = GpuBatch::new(&ctx, &cfg, 2).unwrap();
    let mut timed = GpuBatch::new(&ctx, &cfg, 2).unwrap();
    for b in [&mut plain, &mut timed] {
        b.set_all_actions(&[[-1.0, 0.2], [0.5, 0.0], [0.0, -1.0], [1.0, 1.0]])
            .unwrap();
    }
    plain.step().unwrap();
    let Some(kernels) = timed.profile_step().unwrap() else {
        assert!(!timed.can_profile());
        eprintln!("adapter without timestamps inside passes: nothing to check");
        return;
    };
    for which in [FieldBinding::UIn, FieldBinding::VIn, FieldBinding::Pressure] {
        assert_eq!(
            plain.read_all(which).unwrap(),
            timed.read_all(which).unwrap(),
            "{which:?}"
        );
    }
    assert_eq!(plain.members(), timed.members());
    assert_eq!(plain.time_s(0), timed.time_s(0));
    let names: Vec<&str> = kernels.iter().map(|k| k.0).collect();
    assert_eq!(
        names,
        [
            "diffuse",
            "advect_predict",
            "maccormack_correct",
            "pressure_rhs",
            "pressure_solve",
            "pressure_back",
            "project",
            "move_members",
            "diag_columns",
            "diag_reduce"
        ]
    );
    let dispatches: u32 = kernels.iter().map(|k| k.1).sum();
    assert_eq!(dispatches, timed.dispatches_per_control_step());
    assert!(kernels.iter().all(|k| k.2 >= 0.0 && k.2 < 10.0));
    assert!(kernels.iter().map(|k| k.2).sum::<f64>() > 0.0);
}

#[test]
fn traffic_counts_each_buffer_a_kernel_touches() {
    let (_lock, ctx) = common::gpu();
    let (nx, ny, e) = (90usize, 10usize, 3usize);
    let cfg = common::small_config(nx as u32, ny as u32, &[]);
    let batch = GpuBatch::new(&ctx, &cfg, e).unwrap();
    let bytes = batch.bytes_per_dispatch();
    let of = |k: &str| bytes.iter().find(|b| b.0 == k).unwrap().1;
    // diffuse reads u, v and writes w_u, w_v: 2 x (u + v) faces of 4 bytes; with members it
    // also paints (the body field, 16 bytes a cell, and the two swarm boxes, 32 bytes).
    let faces = (nx + 1) * ny + nx * (ny + 1);
    assert_eq!(
        of("diffuse"),
        ((2 * faces * 4 + 16 * nx * ny + 32) * e) as u64
    );
    // project reads p and u_out/v_out, writes u_out/v_out.
    assert_eq!(of("project"), ((nx * ny + 2 * faces) * 4 * e) as u64);
}
