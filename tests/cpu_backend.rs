//! The CPU backend (`sim::cpu`, `solver.backend = "native"`): results independent of the
//! number of threads (bit for bit), the same trajectory as the WGSL kernels through resets
//! and writes, checkpoints that resume on the other backend, and the `auto` self-check that
//! falls back to the CPU when the kernels disagree with it.

mod common;

use common::{Noise, max_diff, random_body, small_config, swarm_config};
use fluxswarm_gpu::checkpoint::Archive;
use fluxswarm_gpu::env::SwarmEnv;
use fluxswarm_gpu::gpu::params::GpuMember;
use fluxswarm_gpu::sim::cpu::BatchState;
use fluxswarm_gpu::sim::fluid::batch_params;
use fluxswarm_gpu::sim::poisson::PoissonTables;
use fluxswarm_gpu::sim::{CpuBatch, FlowBatch, GpuBatch, Grid, open};

/// A batch of `envs` environments on an awkward 41 x 13 grid with random velocities of
/// about 0.2 m/s (departures up to about a cell away), a random body field and, with
/// `members`, three moving members (the body field is then painted from them).
fn random_batch(scheme: &str, trace: &str, envs: usize, members: bool) -> (BatchState, Vec<f32>) {
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
    let batch = BatchState {
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

fn flat(m: &[GpuMember]) -> Vec<f32> {
    m.iter()
        .flat_map(|m| [m.pos[0], m.pos[1], m.vel[0], m.vel[1]])
        .collect()
}

/// Two control steps of a random batch on a pool of `threads` threads.
fn stepped_on(threads: usize, scheme: &str, trace: &str, members: bool) -> BatchState {
    let (mut batch, inlet) = random_batch(scheme, trace, 5, members);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        for _ in 0..2 {
            batch.step(&inlet);
        }
    });
    batch
}

/// Sweeps run with different thread counts: the result must not depend on them.
#[test]
fn cpu_step_is_bit_identical_on_1_2_and_4_threads() {
    for (scheme, trace, members) in [
        ("maccormack", "euler", true),
        ("semi_lagrangian", "rk2", false),
    ] {
        let one = stepped_on(1, scheme, trace, members);
        for threads in [2, 4] {
            let many = stepped_on(threads, scheme, trace, members);
            assert_eq!(
                bits(&one.u),
                bits(&many.u),
                "{scheme}: u on {threads} threads"
            );
            assert_eq!(
                bits(&one.v),
                bits(&many.v),
                "{scheme}: v on {threads} threads"
            );
            assert_eq!(
                bits(&one.p),
                bits(&many.p),
                "{scheme}: p on {threads} threads"
            );
            assert_eq!(
                bits(&flat(&one.members)),
                bits(&flat(&many.members)),
                "{scheme}: members on {threads} threads"
            );
        }
        // The state moved: the comparison is not of two untouched copies.
        let (start, _) = random_batch(scheme, trace, 5, members);
        assert_ne!(bits(&start.u), bits(&one.u));
    }
}

/// The AVX2 path (taken where the processor has it) and the plain-Rust path give the same
/// bits, for both schemes and traces, with and without members.
#[test]
fn the_vector_path_equals_the_plain_path_bit_for_bit() {
    use fluxswarm_gpu::gpu::params::GpuMemberDiag;
    use fluxswarm_gpu::sim::cpu::Scratch;
    for (scheme, trace, members) in [
        ("maccormack", "euler", true),
        ("maccormack", "rk2", false),
        ("semi_lagrangian", "euler", false),
        ("semi_lagrangian", "rk2", true),
    ] {
        let (mut fast, inlet) = random_batch(scheme, trace, 3, members);
        let mut plain = fast.clone();
        let n = 3 * fast.params.n_members as usize;
        let (mut sf, mut sp) = (vec![Scratch::default(); 3], vec![Scratch::portable(); 3]);
        let (mut df, mut dp) = (
            vec![GpuMemberDiag::default(); n],
            vec![GpuMemberDiag::default(); n],
        );
        for _ in 0..3 {
            fast.step_with(&inlet, &mut sf, &mut df);
            plain.step_with(&inlet, &mut sp, &mut dp);
        }
        let what = format!("{scheme}/{trace}, members {members}");
        assert_eq!(bits(&fast.u), bits(&plain.u), "u, {what}");
        assert_eq!(bits(&fast.v), bits(&plain.v), "v, {what}");
        assert_eq!(bits(&fast.p), bits(&plain.p), "p, {what}");
        assert_eq!(bits(&fast.divstar), bits(&plain.divstar), "divstar, {what}");
        assert_eq!(
            bits(&flat(&fast.members)),
            bits(&flat(&plain.members)),
            "members, {what}"
        );
    }
    eprintln!(
        "vector path on this machine: {}",
        fluxswarm_gpu::sim::cpu::simd::path_name()
    );
}

/// Each environment of a batch steps exactly as it does alone (environments are independent
/// tasks).
#[test]
fn an_environment_steps_alone_as_in_its_batch() {
    let (mut batch, inlet) = random_batch("maccormack", "euler", 3, true);
    let g =
        Grid::from_config(&swarm_config(41, 13, &[[1.5, 0.5], [2.1, 0.8], [2.9, 0.6]], &[]).config);
    let (nu, n) = (g.n_u(), 3);
    let mut alone = BatchState {
        params: fluxswarm_gpu::gpu::params::GpuParams {
            n_env: 1,
            ..batch.params
        },
        u: batch.u[2 * nu..3 * nu].to_vec(),
        v: batch.v[2 * g.n_v()..3 * g.n_v()].to_vec(),
        p: batch.p[2 * g.n_cells()..3 * g.n_cells()].to_vec(),
        body: batch.body[2 * g.n_cells()..3 * g.n_cells()].to_vec(),
        divstar: batch.divstar[2 * g.nx..3 * g.nx].to_vec(),
        members: batch.members[2 * n..3 * n].to_vec(),
        actions: batch.actions[2 * n..3 * n].to_vec(),
        boxes: batch.boxes[2..3].to_vec(),
        ..batch.clone()
    };
    let subs = batch.params.substeps as usize;
    batch.step(&inlet);
    alone.step(&inlet[2 * subs..3 * subs]);
    assert_eq!(bits(&batch.u[2 * nu..3 * nu]), bits(&alone.u));
    assert_eq!(
        bits(&flat(&batch.members[2 * n..])),
        bits(&flat(&alone.members))
    );
}

const POS_MM: [[f64; 2]; 3] = [[2.0, 0.5], [2.6, 0.9], [3.3, 0.6]];

fn swarm_77x13() -> fluxswarm_gpu::config::Resolved {
    swarm_config(
        77,
        13,
        &POS_MM,
        &["time.substeps=4", "time.control_dt_s=0.001"],
    )
}

fn close(name: &str, a: &[f32], b: &[f32], rel: f32) {
    assert_eq!(a.len(), b.len(), "{name}: lengths");
    let (d, m) = max_diff(a, b);
    assert!(
        d <= rel * m.max(1e-30),
        "{name}: max |gpu - cpu| = {d:e} vs max |cpu| = {m:e}"
    );
}

fn forces(x: &dyn FlowBatch) -> Vec<f32> {
    x.member_forces()
        .iter()
        .flat_map(|d| [d.hydro, d.drag, d.contact, d.prop].concat())
        .collect()
}

/// Compares the states of two batches to the kernel tests' tolerance (1e-4 of the largest
/// value of each array).
fn same_state(a: &dyn FlowBatch, b: &dyn FlowBatch) {
    let (sa, sb) = (a.state().unwrap(), b.state().unwrap());
    close("u", &sa.u, &sb.u, 1e-4);
    close("v", &sa.v, &sb.v, 1e-4);
    close("p", &sa.p, &sb.p, 1e-4);
    close(
        "body",
        bytemuck::cast_slice(&sa.body),
        bytemuck::cast_slice(&sb.body),
        1e-4,
    );
    close("members", &flat(&sa.members), &flat(&sb.members), 1e-4);
    close("forces", &forces(a), &forces(b), 1e-4);
    for e in 0..a.n_env() {
        assert_eq!(a.time_s(e), b.time_s(e), "clock of environment {e}");
    }
}

/// Three control steps with actions, a reset of environment 1 and new members in
/// environment 0 between them: the CPU batch tracks the kernels (which equal the CPU stages
/// to 1e-4 per step).
#[test]
fn cpu_backend_tracks_the_kernels_through_resets_and_writes() {
    let (_lock, ctx) = common::gpu();
    let r = swarm_77x13();
    let mut a = GpuBatch::new(&ctx, &r, 2).unwrap();
    let mut b = CpuBatch::new(&r, 2).unwrap();
    assert_eq!((a.backend_name(), b.backend_name()), ("adapter", "native"));
    let n = a.n_members();
    let actions: Vec<[f32; 2]> = (0..2 * n)
        .map(|k| [-1.0 + 0.3 * k as f32, 0.5 - 0.2 * k as f32])
        .collect();
    let start = flat(b.members());
    for step in 0..3 {
        for x in [&mut a as &mut dyn FlowBatch, &mut b] {
            x.set_all_actions(&actions).unwrap();
            if step == 1 {
                x.reset_env(1).unwrap();
                let mut m = x.members()[..n].to_vec();
                m[0].pos[0] += 1e-4;
                m[0].vel = [0.01, -0.005];
                x.set_members(0, &m).unwrap();
                x.set_actions(0, &vec![[0.5, 0.5]; n]).unwrap();
            }
        }
        let ha = a.step().unwrap();
        let hb = b.step().unwrap();
        for (x, y) in ha.iter().zip(&hb) {
            let rel = (x.inlet_flux - y.inlet_flux).abs() / y.inlet_flux.abs().max(1e-30);
            assert!(
                rel <= 1e-4,
                "inlet flux {} vs {}",
                x.inlet_flux,
                y.inlet_flux
            );
        }
        same_state(&a, &b);
    }
    assert_ne!(flat(b.members()), start, "the members moved");
    let (fa, fb) = (a.fields(1).unwrap(), b.fields(1).unwrap());
    close("fields u", &fa.u_faces, &fb.u_faces, 1e-4);
    close("fields p", &fa.p, &fb.p, 1e-4);
}

/// A checkpoint written by one backend resumes on the other: after two steps on the source
/// backend, the state is saved, loaded into a batch of the other backend, and both step on
/// together for two more steps.
#[test]
fn a_checkpoint_resumes_on_the_other_backend() {
    let (_lock, ctx) = common::gpu();
    let r = swarm_77x13();
    let actions = vec![[-0.7f32, 0.4]; 2 * POS_MM.len()];
    for gpu_first in [true, false] {
        let mut src: Box<dyn FlowBatch> = if gpu_first {
            Box::new(GpuBatch::new(&ctx, &r, 2).unwrap())
        } else {
            Box::new(CpuBatch::new(&r, 2).unwrap())
        };
        let mut dst: Box<dyn FlowBatch> = if gpu_first {
            Box::new(CpuBatch::new(&r, 2).unwrap())
        } else {
            Box::new(GpuBatch::new(&ctx, &r, 2).unwrap())
        };
        src.reset_env_with_phase(1, 0.03).unwrap();
        src.set_all_actions(&actions).unwrap();
        src.step().unwrap();
        src.step().unwrap();
        let mut archive = Archive::new();
        src.save_state(&mut archive, "fluid").unwrap();
        let bytes = archive.to_bytes();
        let back = Archive::from_bytes(&bytes, std::path::Path::new("mem")).unwrap();
        dst.load_state(&back, "fluid").unwrap();
        assert_eq!(dst.steps(), 2);
        same_state(src.as_ref(), dst.as_ref());
        for _ in 0..2 {
            src.step().unwrap();
            dst.step().unwrap();
        }
        same_state(src.as_ref(), dst.as_ref());
        assert_eq!(dst.time_s(1), src.time_s(1));
    }
}

/// A short episode of the swarm environment (members swept downstream to the failure line)
/// ends at the same step with the same outcome on both backends.
#[test]
fn a_short_episode_ends_the_same_way_on_both_backends() {
    let (_lock, ctx) = common::gpu();
    let r = swarm_config(77, 13, &POS_MM, &[]);
    let mut on_gpu = common::gpu_env(&ctx, &r, 1, 5);
    let mut on_cpu = SwarmEnv::new(Box::new(CpuBatch::new(&r, 1).unwrap()), &r, 5).unwrap();
    on_gpu.reset().unwrap();
    on_cpu.reset().unwrap();
    let actions = vec![[-1.0f32, 0.2]; POS_MM.len()];
    let mut ended = None;
    for step in 1..=200 {
        let (g, c) = (
            on_gpu.step(&actions).unwrap(),
            on_cpu.step(&actions).unwrap(),
        );
        close("rewards", &g.rewards, &c.rewards, 1e-3);
        assert_eq!(
            g.episodes[0].is_some(),
            c.episodes[0].is_some(),
            "step {step}"
        );
        if let (Some(eg), Some(ec)) = (&g.episodes[0], &c.episodes[0]) {
            assert_eq!((eg.outcome, eg.steps), (ec.outcome, ec.steps));
            ended = Some(eg.steps);
            break;
        }
    }
    assert!(ended.is_some(), "the episode ends within 200 steps");
}

/// `auto` on an adapter: the kernels when they pass the start-up self-check, the CPU backend
/// with a warning that says why when they fail it (made to fail on purpose here).
#[test]
fn auto_falls_back_to_the_cpu_when_the_self_check_fails() {
    let (_lock, ctx) = common::gpu();
    let r = swarm_77x13();
    let ok = open::open_auto_on(&ctx, &r, 2, false).unwrap();
    assert_eq!(ok.batch.backend_name(), "adapter", "{}", ok.header());
    assert!(ok.warnings.is_empty(), "{:?}", ok.warnings);
    let failed = open::open_auto_on(&ctx, &r, 2, true).unwrap();
    assert_eq!(failed.batch.backend_name(), "native");
    assert!(failed.why.contains("self-check"), "{}", failed.why);
    let warning = failed.warnings.join(" ");
    assert!(
        warning.contains("u differs from the CPU step") && warning.contains("CPU backend"),
        "{warning}"
    );
    assert_eq!(failed.batch.n_env(), 2);
}

/// `solver.backend = "native"` opens no adapter at all.
#[test]
fn the_native_backend_needs_no_adapter() {
    let mut r = small_config(41, 13, &["solver.backend=native"]);
    r.config.time.substeps = 4;
    let mut opened = open(&r, 2, fluxswarm_gpu::gpu::AdapterChoice::Gpu).unwrap();
    assert_eq!(opened.batch.backend_name(), "native");
    assert!(opened.batch.step().unwrap().iter().all(|h| !h.diverged()));
}

/// Wider vessels: ny up to 256 runs on both backends (the kernels take their 256 x 16 column
/// variant at ny = 130): a control step of the kernels equals the CPU's to the kernel tests'
/// tolerance, and `auto` on an adapter takes the kernels.
#[test]
fn tall_grids_run_on_the_cpu_and_the_kernels_alike() {
    let (_lock, ctx) = common::gpu();
    let r = small_config(24, 130, &["time.substeps=40", "time.control_dt_s=0.001"]);
    let mut cpu = CpuBatch::new(&r, 1).unwrap();
    let mut gpu = GpuBatch::new(&ctx, &r, 1).unwrap();
    for x in [&mut cpu as &mut dyn FlowBatch, &mut gpu] {
        assert!(!x.step().unwrap()[0].diverged(), "{}", x.backend_name());
    }
    same_state(&gpu, &cpu);
    let opened = open::open_auto_on(&ctx, &r, 1, false).unwrap();
    assert_eq!(opened.batch.backend_name(), "adapter", "{}", opened.why);
}

/// The stage timer of `bench` (`CpuBatch::profile_step`) steps exactly as `step` does, bit for
/// bit and clock included, and charges time to every stage that runs (paint and move only with
/// members).
#[test]
fn timed_cpu_steps_equal_untimed_ones_and_time_every_stage() {
    use fluxswarm_gpu::sim::cpu::CpuStage;
    let bits = |x: &[f32]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for (scheme, trace, swarm) in [
        ("maccormack", "euler", true),
        ("semi_lagrangian", "rk2", true),
        ("semi_lagrangian", "euler", false),
    ] {
        let extra = [
            &format!("solver.advection={scheme}") as &str,
            &format!("solver.backtrace={trace}"),
            "time.substeps=4",
            "time.control_dt_s=0.001",
        ];
        let r = if swarm {
            swarm_config(77, 13, &POS_MM, &extra)
        } else {
            small_config(77, 13, &extra)
        };
        let (mut plain, mut timed) = (CpuBatch::new(&r, 2).unwrap(), CpuBatch::new(&r, 2).unwrap());
        let n = plain.n_members();
        let actions: Vec<[f32; 2]> = (0..2 * n).map(|k| [0.4 - 0.1 * k as f32, 0.3]).collect();
        plain.set_all_actions(&actions).unwrap();
        timed.set_all_actions(&actions).unwrap();
        for _ in 0..3 {
            let a = plain.step().unwrap();
            let (b, times) = timed.profile_step().unwrap();
            assert_eq!(a, b, "{scheme}");
            for s in CpuStage::ALL {
                let runs = swarm || !matches!(s, CpuStage::Paint | CpuStage::Move);
                assert_eq!(times[s] > 0, runs, "{scheme} {trace}: {s:?} {times:?}");
            }
        }
        let (x, y) = (plain.state_ref(), timed.state_ref());
        for (name, a, b) in [
            ("u", &x.u, &y.u),
            ("v", &x.v, &y.v),
            ("p", &x.p, &y.p),
            ("divstar", &x.divstar, &y.divstar),
        ] {
            assert_eq!(bits(a), bits(b), "{scheme} {trace}: {name}");
        }
        let flat_body = |s: &[[f32; 4]]| bits(s.as_flattened());
        assert_eq!(flat_body(&x.body), flat_body(&y.body));
        assert_eq!(x.members, y.members);
        assert_eq!(plain.member_forces(), timed.member_forces());
        assert_eq!(plain.core().time_s, timed.core().time_s);
    }
}
