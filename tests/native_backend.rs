//! The native backend (`solver.backend = "native"`) inside a `FluidBatch`: it steps as the
//! adapter does, picks up what is written to the device between steps (a reset, new members,
//! new actions), writes its results back where fields and checkpoints read them, and reports
//! the members' forces.

mod common;

use common::{max_diff, swarm_config};
use fluxswarm_gpu::gpu::GpuContext;
use fluxswarm_gpu::gpu::kernels::FieldBinding;
use fluxswarm_gpu::gpu::params::GpuMember;
use fluxswarm_gpu::sim::FluidBatch;

const POS_MM: [[f64; 2]; 3] = [[2.0, 0.5], [2.6, 0.9], [3.3, 0.6]];

fn batch(ctx: &GpuContext, backend: &str) -> FluidBatch {
    let extra = [
        "time.substeps=4",
        "time.control_dt_s=0.001",
        &format!("solver.backend={backend}"),
    ];
    FluidBatch::new(ctx, &swarm_config(77, 13, &POS_MM, &extra), 2).unwrap()
}

fn close(name: &str, adapter: &[f32], native: &[f32], rel: f32) {
    assert_eq!(adapter.len(), native.len(), "{name}: lengths");
    let (d, m) = max_diff(adapter, native);
    assert!(
        d <= rel * m.max(1e-30),
        "{name}: max |adapter - native| = {d:e} vs max |adapter| = {m:e}"
    );
}

fn flat(m: &[GpuMember]) -> Vec<f32> {
    m.iter()
        .flat_map(|m| [m.pos[0], m.pos[1], m.vel[0], m.vel[1]])
        .collect()
}

/// Three control steps with actions, a reset of environment 1 and new members in
/// environment 0 between them: the native batch tracks the adapter's (the kernels equal their
/// twins to 1e-4 per step; the native step equals the twins bit for bit).
#[test]
fn native_backend_tracks_the_adapter_through_resets_and_writes() {
    let (_lock, ctx) = common::gpu();
    let mut a = batch(&ctx, "adapter");
    let mut b = batch(&ctx, "native");
    assert!(!a.is_native() && b.is_native());
    assert!(
        !b.can_profile(),
        "the native step has no dispatches to time"
    );
    let n = a.n_members();
    let actions: Vec<[f32; 2]> = (0..2 * n)
        .map(|k| [-1.0 + 0.3 * k as f32, 0.5 - 0.2 * k as f32])
        .collect();
    let start = flat(b.members());
    for step in 0..3 {
        for x in [&mut a, &mut b] {
            x.set_all_actions(&actions);
            if step == 1 {
                x.reset_env(1).unwrap();
                let mut m = x.members()[..n].to_vec();
                m[0].pos[0] += 1e-4;
                m[0].vel = [0.01, -0.005];
                x.set_members(0, &m).unwrap();
                x.set_actions(0, &vec![[0.5, 0.5]; n]).unwrap();
            }
        }
        let ha = a.step(&ctx).unwrap();
        let hb = b.step(&ctx).unwrap();
        for (x, y) in ha.iter().zip(&hb) {
            let rel = (x.inlet_flux - y.inlet_flux).abs() / x.inlet_flux.abs().max(1e-30);
            assert!(
                rel <= 1e-4,
                "inlet flux {} vs {}",
                x.inlet_flux,
                y.inlet_flux
            );
        }
        close("members", &flat(a.members()), &flat(b.members()), 1e-4);
        let forces = |x: &FluidBatch| -> Vec<f32> {
            x.member_forces()
                .iter()
                .flat_map(|d| [d.hydro, d.drag, d.contact, d.prop].concat())
                .collect()
        };
        close("forces", &forces(&a), &forces(&b), 1e-4);
    }
    for (which, name) in [
        (FieldBinding::UIn, "u"),
        (FieldBinding::VIn, "v"),
        (FieldBinding::Pressure, "p"),
        (FieldBinding::Body, "body"),
        (FieldBinding::Members, "members buffer"),
    ] {
        close(
            name,
            &a.read_all(&ctx, which).unwrap(),
            &b.read_all(&ctx, which).unwrap(),
            1e-4,
        );
    }
    assert_eq!(a.time_s(0), b.time_s(0));
    assert_eq!(a.time_s(1), b.time_s(1));
    assert_ne!(flat(b.members()), start, "the members moved");
    // Fields read back from the native batch are its own state.
    let fa = a.fields(&ctx, 1).unwrap();
    let fb = b.fields(&ctx, 1).unwrap();
    close("fields u", &fa.u_faces, &fb.u_faces, 1e-4);
}
