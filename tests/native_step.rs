//! The native step (`sim::native`) equals the CPU twins (`sim::cpu`) bit for bit: random
//! fields on an awkward 41 x 13 grid, a random body field or three moving members, two control
//! steps, every advection variant, and the parallel split into single environments. No
//! adapter needed.

mod common;

use common::{Noise, random_body, small_config, swarm_config};
use fluxswarm_gpu::gpu::params::GpuMember;
use fluxswarm_gpu::sim::Grid;
use fluxswarm_gpu::sim::cpu::CpuBatch;
use fluxswarm_gpu::sim::fluid::batch_params;
use fluxswarm_gpu::sim::native::{NativeBatch, Scratch, step};
use fluxswarm_gpu::sim::poisson::PoissonTables;
use fluxswarm_gpu::waveform::Waveform;

/// A batch of `envs` environments on an awkward 41 x 13 grid with random velocities of
/// about 0.2 m/s (departures up to about a cell away), a random body field and, with
/// `members`, three moving members (the body field is then painted from them).
fn random_batch(scheme: &str, trace: &str, envs: usize, members: bool) -> (CpuBatch, Vec<f32>) {
    let extra = [
        &format!("solver.advection={scheme}") as &str,
        &format!("solver.backtrace={trace}"),
        "time.substeps=4",
        "time.control_dt_s=0.001",
    ];
    let resolved = if members {
        swarm_config(41, 13, &[[1.5, 0.5], [2.1, 0.8], [2.9, 0.6]], &extra)
    } else {
        small_config(41, 13, &extra)
    };
    let params = batch_params(&resolved, envs);
    let grid = Grid::from_config(&resolved.config);
    let mut n = Noise::new(7);
    let u = (0..envs * grid.n_u())
        .map(|_| 0.15 + 0.2 * n.next())
        .collect();
    let v = (0..envs * grid.n_v()).map(|_| 0.1 * n.next()).collect();
    let body = random_body(&mut n, envs * grid.n_cells());
    let n_m = params.n_members as usize;
    let start = resolved.config.swarm.initial_positions(grid.height_m);
    let members: Vec<GpuMember> = (0..envs * n_m)
        .map(|k| GpuMember {
            pos: [start[k % n_m][0] as f32, start[k % n_m][1] as f32],
            vel: [0.01 * n.next(), 0.01 * n.next()],
            pinned: 0.0,
            pad: [0.0; 3],
        })
        .collect();
    let boxes = (0..envs)
        .map(|e| {
            let m = &members[e * n_m..(e + 1) * n_m];
            m.iter()
                .fold([f32::MAX, f32::MIN, f32::MAX, f32::MIN], |b, m| {
                    [
                        b[0].min(m.pos[0]),
                        b[1].max(m.pos[0]),
                        b[2].min(m.pos[1]),
                        b[3].max(m.pos[1]),
                    ]
                })
        })
        .collect();
    let actions = (0..envs * n_m)
        .map(|_| [2.0 * n.next(), 2.0 * n.next()])
        .collect();
    let inlet = (0..envs * params.substeps as usize)
        .map(|_| 0.3 * n.next())
        .collect();
    let batch = CpuBatch {
        params,
        scheme: resolved.config.solver.advection,
        poisson: PoissonTables::new(&grid).to_gpu(),
        u,
        v,
        p: vec![0.0; envs * grid.n_cells()],
        body,
        divstar: vec![0.0; envs * grid.nx],
        members,
        actions,
        boxes,
    };
    (batch, inlet)
}

fn bits(x: &[f32]) -> Vec<u32> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// Two control steps of the native step and of the twins give identical bits: velocity,
/// pressure, members and health.
fn equals_twins(scheme: &str, trace: &str, members: bool) {
    let (mut twin, inlet) = random_batch(scheme, trace, 2, members);
    let mut fast = twin.clone();
    let mut scratch = Scratch::default();
    for _ in 0..2 {
        let h_twin = twin.step(&inlet);
        let h_fast = step(&mut fast, &inlet, &mut scratch);
        assert_eq!(format!("{h_twin:?}"), format!("{h_fast:?}"), "health");
    }
    assert_eq!(bits(&twin.u), bits(&fast.u), "u");
    assert_eq!(bits(&twin.v), bits(&fast.v), "v");
    assert_eq!(bits(&twin.p), bits(&fast.p), "p");
    assert_eq!(bits(&twin.divstar), bits(&fast.divstar), "divstar");
    let flat = |b: &CpuBatch| -> Vec<f32> {
        b.members
            .iter()
            .flat_map(|m| [m.pos[0], m.pos[1], m.vel[0], m.vel[1]])
            .collect()
    };
    assert_eq!(bits(&flat(&twin)), bits(&flat(&fast)), "members");
    // The state moved: the comparison is not of two untouched copies.
    let (start, _) = random_batch(scheme, trace, 2, members);
    assert_ne!(bits(&start.u), bits(&fast.u));
    if members {
        assert_ne!(bits(&flat(&start)), bits(&flat(&fast)));
    }
}

/// The parallel batch, split into single environments, steps as the whole batch does.
#[test]
fn native_batch_equals_the_twins_per_environment() {
    let (mut twin, _) = random_batch("maccormack", "euler", 3, true);
    let waveform = Waveform::new(vec![(0.0, 0.1), (0.001, 0.3), (1.0, 0.1)], 1.0).unwrap();
    let mut batch = NativeBatch::new(&twin, waveform.clone(), 0.001);
    let dt_sub = 0.001 / 4.0;
    for step_index in 0..2 {
        let t0 = step_index as f64 * 0.001;
        let inlet: Vec<f32> = (0..3)
            .flat_map(|_| (0..4).map(|s| waveform.at(t0 + (s as f64 + 1.0) * dt_sub) as f32))
            .collect();
        let h_twin = twin.step(&inlet);
        let h_fast = batch.step();
        assert_eq!(format!("{h_twin:?}"), format!("{h_fast:?}"));
    }
    let (nx, ny, n) = (41, 13, 3);
    let nu = ny * (nx + 1);
    for e in 0..3 {
        assert_eq!(
            bits(&twin.u[e * nu..(e + 1) * nu]),
            bits(&batch.env(e).u),
            "u of {e}"
        );
        let m = &twin.members[e * n..(e + 1) * n];
        assert_eq!(format!("{m:?}"), format!("{:?}", batch.env(e).members));
    }
}

#[test]
fn maccormack_euler_with_a_swarm_equals_the_twins() {
    equals_twins("maccormack", "euler", true);
}

#[test]
fn maccormack_rk2_with_a_body_field_equals_the_twins() {
    equals_twins("maccormack", "rk2", false);
}

#[test]
fn semi_lagrangian_euler_with_a_swarm_equals_the_twins() {
    equals_twins("semi_lagrangian", "euler", true);
}

#[test]
fn semi_lagrangian_rk2_with_a_body_field_equals_the_twins() {
    equals_twins("semi_lagrangian", "rk2", false);
}
