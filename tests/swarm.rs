//! Swarm members: the member kernels against their CPU twins on an awkward batch, the force
//! laws against closed forms (pressure force = -V grad p, each Schiller-Naumann branch, thrust
//! clipping, contact push and reaction), and the coupled physics (a held member throttles the
//! flow, a passive member drifts downstream slower than the fluid, members never overlap).

mod common;

use common::{Noise, max_diff, small_config};
use fluxswarm_gpu::gpu::GpuContext;
use fluxswarm_gpu::gpu::kernels::FieldBinding;
use fluxswarm_gpu::gpu::params::{GpuMember, GpuMemberDiag};
use fluxswarm_gpu::sim::FlowBatch;
use fluxswarm_gpu::sim::{GpuBatch, Stage, cpu};

const R: f64 = 250e-6;
const F_MAX: f64 = 850e-9;

/// A channel of nx x ny cells with members at explicit positions (mm).
fn swarm_batch(
    ctx: &GpuContext,
    nx: u32,
    ny: u32,
    envs: usize,
    pos_mm: &[[f64; 2]],
    extra: &[&str],
) -> GpuBatch {
    GpuBatch::new(ctx, &common::swarm_config(nx, ny, pos_mm, extra), envs).unwrap()
}

fn read_members(b: &GpuBatch) -> (Vec<GpuMember>, Vec<GpuMemberDiag>) {
    let m = b.read_all(FieldBinding::Members).unwrap();
    let d = b.read_all(FieldBinding::MemberDiag).unwrap();
    (
        bytemuck::cast_slice(&m).to_vec(),
        bytemuck::cast_slice(&d).to_vec(),
    )
}

fn member(x_mm: f64, y_mm: f64, vx: f32, vy: f32, pinned: bool) -> GpuMember {
    GpuMember {
        pos: [(x_mm * 1e-3) as f32, (y_mm * 1e-3) as f32],
        vel: [vx, vy],
        pinned: pinned as u32 as f32,
        pad: [0.0; 3],
    }
}

/// The current swarm box of each environment ([E][2] vec4 on the device: current, painted).
fn current_boxes(raw: &[f32]) -> Vec<[f32; 4]> {
    raw.chunks(8).map(|c| [c[0], c[1], c[2], c[3]]).collect()
}

fn close(name: &str, gpu: &[f32], cpu: &[f32], rel: f32) {
    let (d, m) = max_diff(gpu, cpu);
    assert!(
        d <= rel * m.max(1e-30),
        "{name}: max |gpu - cpu| = {d:e} vs max |cpu| = {m:e}"
    );
}

#[test]
fn member_kernels_match_cpu() {
    let (_lock, ctx) = common::gpu();
    // 6 x 1.4 mm, 3 environments of 5 members: two touching pairs, one pinned member.
    let pos = [[1.5, 0.5], [2.5, 0.5], [3.0, 0.9], [4.2, 0.7], [4.9, 0.45]];
    let mut b = swarm_batch(&ctx, 60, 14, 3, &pos, &[]);
    let g = *b.grid();
    let mut n = Noise::new(31);
    let mut all = Vec::new();
    for e in 0..3 {
        let mut ms = vec![
            member(1.5, 0.5, 0.01, 0.0, false),
            member(1.5 + 0.49, 0.5, -0.02, 0.001, false), // overlaps member 0
            member(3.0, 0.9, 0.0, 0.0, e == 1),
            member(4.2, 0.7, 0.03, -0.01, false),
            member(4.2 + 0.3, 0.7 + 0.4, 0.0, 0.02, false), // touches member 3
        ];
        for m in &mut ms {
            m.pos[0] += 2e-5 * n.next();
            m.pos[1] += 2e-5 * n.next();
        }
        b.set_members(e, &ms).unwrap();
        all.extend(ms);
    }
    let actions: Vec<[f32; 2]> = (0..15).map(|_| [3.0 * n.next(), 3.0 * n.next()]).collect();
    b.set_all_actions(&actions).unwrap();
    let u: Vec<f32> = n.vec(3 * g.n_u(), 0.05).iter().map(|x| x + 0.1).collect();
    let v = n.vec(3 * g.n_v(), 0.02);
    let p: Vec<f32> = (0..3 * g.n_cells())
        .map(|c| 300.0 - 4.0 * (c % 60) as f32 + 20.0 * n.next())
        .collect();
    b.write_all(FieldBinding::UOut, &u);
    b.write_all(FieldBinding::VOut, &v);
    b.write_all(FieldBinding::Pressure, &p);
    let boxes: Vec<f32> = b.read_all(FieldBinding::SwarmBox).unwrap();
    let boxes: Vec<[f32; 4]> = current_boxes(&boxes);

    b.run_stages(&[Stage::PaintBodies], 0, 1).unwrap();
    let body = b.read_all(FieldBinding::Body).unwrap();
    let want: Vec<[f32; 4]> = cpu::paint_bodies(b.params(), &all, &boxes);
    close("body", &body, bytemuck::cast_slice(&want), 1e-5);
    assert!(
        body.chunks(4).filter(|c| c[0] == 1.0).count() > 3 * 5 * 9,
        "discs are painted"
    );

    b.run_stages(&[Stage::MoveMembers], 0, 1).unwrap();
    let (gm, gd) = read_members(&b);
    let (cm, cd, cb) = cpu::move_members(b.params(), &all, &actions, &p, &u, &v);
    close(
        "positions",
        &gm.iter().flat_map(|m| m.pos).collect::<Vec<_>>(),
        &cm.iter().flat_map(|m| m.pos).collect::<Vec<_>>(),
        1e-6,
    );
    close(
        "velocities",
        &gm.iter().flat_map(|m| m.vel).collect::<Vec<_>>(),
        &cm.iter().flat_map(|m| m.vel).collect::<Vec<_>>(),
        1e-4,
    );
    close(
        "diagnostics",
        bytemuck::cast_slice(&gd),
        bytemuck::cast_slice(&cd),
        1e-4,
    );
    let gb = b.read_all(FieldBinding::SwarmBox).unwrap();
    close(
        "swarm box",
        &current_boxes(&gb).concat(),
        &cb.concat(),
        1e-6,
    );
    // The box the paint used is kept as the one to clear next time.
    let painted: Vec<f32> = gb.chunks(8).flat_map(|c| c[4..8].to_vec()).collect();
    assert_eq!(painted, boxes.concat());
    assert_eq!(gm[7].vel, [0.0, 0.0], "the pinned member stays at rest");
    assert_eq!(gm[7].pos, all[7].pos);
}

/// One member at rest in a 4 x 2 mm box with given uniform velocity and pressure fields;
/// returns the member's forces after one `move_members`.
fn forces_in(
    ctx: &GpuContext,
    u: f32,
    v: f32,
    vel: [f32; 2],
    p: impl Fn(f64, f64) -> f64,
    action: [f32; 2],
    drag: bool,
) -> GpuMemberDiag {
    let mut b = swarm_batch(
        ctx,
        40,
        20,
        1,
        &[[2.0, 1.0]],
        &[&format!("swarm.drag={drag}")],
    );
    let g = *b.grid();
    b.set_members(0, &[member(2.0, 1.0, vel[0], vel[1], false)])
        .unwrap();
    b.set_actions(0, &[action]).unwrap();
    b.write_all(FieldBinding::UOut, &vec![u; g.n_u()]);
    b.write_all(FieldBinding::VOut, &vec![v; g.n_v()]);
    let pres: Vec<f32> = (0..g.n_cells())
        .map(|c| {
            p(
                ((c % g.nx) as f64 + 0.5) * g.dx(),
                ((c / g.nx) as f64 + 0.5) * g.dy(),
            ) as f32
        })
        .collect();
    b.write_all(FieldBinding::Pressure, &pres);
    b.run_stages(&[Stage::MoveMembers], 0, 1).unwrap();
    read_members(&b).1[0]
}

#[test]
fn pressure_force_in_a_uniform_gradient_is_minus_volume_times_gradient() {
    let (_lock, ctx) = common::gpu();
    let volume = 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    for (gx, gy) in [(2400.0, 0.0), (0.0, -1.5e4), (-3000.0, 800.0)] {
        let d = forces_in(
            &ctx,
            0.0,
            0.0,
            [0.0; 2],
            |x, y| 100.0 + gx * x + gy * y,
            [0.0; 2],
            true,
        );
        let want = [-volume * gx, -volume * gy];
        for k in 0..2 {
            let err = (d.hydro[k] as f64 - want[k]).abs();
            assert!(
                err <= 0.01 * want[0].hypot(want[1]),
                "G = ({gx}, {gy}): {:?} vs {want:?}",
                d.hydro
            );
        }
        assert_eq!(d.drag, [0.0, 0.0], "no relative velocity, no drag");
    }
}

#[test]
fn drag_follows_each_schiller_naumann_branch() {
    let (_lock, ctx) = common::gpu();
    let (rho, mu) = (1060.0f64, 3e-3f64);
    let area = std::f64::consts::PI * R * R;
    for re in [0.05, 0.099, 0.101, 0.5, 30.0, 999.0, 1001.0, 4000.0] {
        let speed = re * mu / (rho * 2.0 * R);
        let cd = if re < 0.1 {
            24.0 / re
        } else if re < 1000.0 {
            24.0 / re * (1.0 + 0.15 * re.powf(0.687))
        } else {
            0.44
        };
        let want = 0.5 * rho * area * cd * speed * speed;
        // Flow at 30 degrees: the force must point along the relative velocity.
        let (ux, uy) = (speed * 0.8660254, speed * 0.5);
        let d = forces_in(
            &ctx,
            ux as f32,
            uy as f32,
            [0.0; 2],
            |_, _| 0.0,
            [0.0; 2],
            true,
        );
        let mag = (d.drag[0] as f64).hypot(d.drag[1] as f64);
        assert!(
            (mag / want - 1.0).abs() < 2e-3,
            "Re {re}: |F| = {mag:e}, want {want:e}"
        );
        let cross = d.drag[0] as f64 * uy - d.drag[1] as f64 * ux;
        assert!(
            cross.abs() < 1e-4 * mag * speed && d.drag[0] > 0.0,
            "Re {re}: {:?} not along v_rel",
            d.drag
        );
    }
    // Zero relative velocity: zero drag, no NaN.
    let d = forces_in(&ctx, 0.1, 0.02, [0.1, 0.02], |_, _| 0.0, [0.0; 2], true);
    assert_eq!(d.drag, [0.0, 0.0]);
    // Switched off in the config.
    let d = forces_in(&ctx, 0.1, 0.0, [0.0; 2], |_, _| 0.0, [0.0; 2], false);
    assert_eq!(d.drag, [0.0, 0.0]);
}

#[test]
fn propulsion_is_clipped_to_the_thrust_bound() {
    let (_lock, ctx) = common::gpu();
    for a in [
        [0.0f32, 0.0],
        [0.3, -0.4],
        [1.0, 0.0],
        [-3.0, 4.0],
        [100.0, 100.0],
        [-0.6, 0.8],
    ] {
        let d = forces_in(&ctx, 0.0, 0.0, [0.0; 2], |_, _| 0.0, a, true);
        let norm = (a[0] as f64).hypot(a[1] as f64);
        let scale = F_MAX / norm.max(1.0);
        for k in 0..2 {
            assert!(
                (d.prop[k] as f64 - scale * a[k] as f64).abs() <= 1e-6 * F_MAX,
                "a = {a:?}: {:?}",
                d.prop
            );
        }
        assert!((d.prop[0] as f64).hypot(d.prop[1] as f64) <= F_MAX * (1.0 + 1e-6));
    }
}

#[test]
fn contact_moves_force_between_members_and_creates_none() {
    let (_lock, ctx) = common::gpu();
    // Member 0 pushes towards member 1 (touching, 1.99 r apart); member 1 is passive.
    let mut b = swarm_batch(&ctx, 40, 20, 1, &[[1.5, 1.0], [2.5, 1.0]], &[]);
    b.set_members(
        0,
        &[
            member(1.5, 1.0, 0.0, 0.0, false),
            member(1.5 + 0.4975, 1.0, 0.0, 0.0, false),
        ],
    )
    .unwrap();
    b.set_actions(0, &[[1.0, 0.0], [0.0, 0.0]]).unwrap();
    b.run_stages(&[Stage::MoveMembers], 0, 1).unwrap();
    let (_, d) = read_members(&b);
    let f = F_MAX as f32;
    assert!(
        (d[1].contact[0] - f).abs() < 1e-3 * f && d[1].contact[1].abs() < 1e-6 * f,
        "{:?}",
        d[1].contact
    );
    assert!(
        (d[0].contact[0] + f).abs() < 1e-3 * f,
        "reaction: {:?}",
        d[0].contact
    );
    // A random cluster: contact forces sum to zero over the swarm.
    let spread = [[0.5, 0.5], [1.2, 0.5], [1.9, 0.5], [2.6, 0.5], [3.3, 0.5]];
    let mut b = swarm_batch(&ctx, 40, 20, 1, &spread, &[]);
    let cluster = [
        [1.0, 0.6],
        [1.5, 0.6],
        [1.25, 1.03],
        [2.0, 0.6],
        [1.75, 1.03],
    ];
    let ms: Vec<GpuMember> = cluster
        .iter()
        .map(|p| member(p[0], p[1], 0.0, 0.0, false))
        .collect();
    b.set_members(0, &ms).unwrap();
    // Everyone pushes towards the cluster's centre, with different strengths.
    let centre = [1.5, 0.78];
    let inward: Vec<[f32; 2]> = cluster
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let s = 0.5 + 0.4 * k as f64;
            [
                (s * (centre[0] - p[0])) as f32 * 4.0,
                (s * (centre[1] - p[1])) as f32 * 4.0,
            ]
        })
        .collect();
    b.set_all_actions(&inward).unwrap();
    b.run_stages(&[Stage::MoveMembers], 0, 1).unwrap();
    let (_, d) = read_members(&b);
    let nonzero = d.iter().filter(|d| d.contact != [0.0, 0.0]).count();
    assert_eq!(nonzero, 5, "every member is pushed or pushes: {d:?}");
    for k in 0..2 {
        let sum: f32 = d.iter().map(|d| d.contact[k]).sum();
        assert!(sum.abs() < 1e-5 * f, "sum of contact forces {sum:e}");
    }
}

/// Constant inlet of `u0` m/s in a 20 x 2 mm channel.
fn steady(extra: &[&str]) -> Vec<String> {
    let mut v = vec![
        "inlet.points=[[0.0, 0.05], [0.5, 0.05]]".to_string(),
        "time.substeps=10".to_string(),
    ];
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

#[test]
fn a_held_member_throttles_the_flow_and_keeps_the_flux() {
    let (_lock, ctx) = common::gpu();
    let run = |with_member: bool| {
        let sets = steady(&[]);
        let refs: Vec<&str> = sets.iter().map(String::as_str).collect();
        let mut b = if with_member {
            let mut s = refs.clone();
            s.push("swarm.pinned=[0]");
            swarm_batch(&ctx, 200, 20, 1, &[[10.0, 1.0]], &s)
        } else {
            GpuBatch::new(&ctx, &small_config(200, 20, &refs), 1).unwrap()
        };
        let g = *b.grid();
        let mut worst = 0.0f32;
        for _ in 0..40 {
            let h = b.step().unwrap()[0];
            worst = worst.max((h.flux_max - h.flux_min) / h.inlet_flux.abs());
        }
        let f = b.fields(0).unwrap();
        let ux = f.ux_cells();
        let i = 100; // the member's column
        let gap = (0..g.ny)
            .filter(|&j| !(7..=12).contains(&j))
            .map(|j| ux[j * g.nx + i])
            .fold(0.0, f32::max);
        let pm = |i: usize| (0..g.ny).map(|j| f.p[j * g.nx + i]).sum::<f32>() / g.ny as f32;
        (gap, pm(80) - pm(120), worst)
    };
    let (gap0, drop0, _) = run(false);
    let (gap1, drop1, worst) = run(true);
    println!(
        "gap velocity {gap0:.4} -> {gap1:.4} m/s; pressure drop over 4 mm {drop0:.3} -> {drop1:.3} Pa; flux imbalance {worst:.2e}"
    );
    assert!(
        gap1 > 1.05 * gap0,
        "the gaps beside a held member carry faster flow"
    );
    assert!(drop1 > 1.2 * drop0, "the member adds resistance");
    assert!(worst < 0.005, "flux balance with a member: {worst}");
}

#[test]
fn a_passive_member_drifts_downstream_slower_than_the_fluid() {
    let (_lock, ctx) = common::gpu();
    let sets = steady(&[]);
    let refs: Vec<&str> = sets.iter().map(String::as_str).collect();
    let mut b = swarm_batch(&ctx, 200, 20, 1, &[[5.0, 1.0]], &refs);
    let mut vx = Vec::new();
    for _ in 0..60 {
        let h = b.step().unwrap()[0];
        assert!(h.is_finite());
        let m = b.members()[0];
        assert!(m.pos[1] >= R as f32 * 0.999 && m.pos[1] <= 0.002 - R as f32 * 0.999);
        vx.push(m.vel[0]);
    }
    let m = b.members()[0];
    let last = *vx.last().unwrap();
    let ratio = last / 0.05; // centreline velocity of the undisturbed flow
    println!(
        "passive member: x = {:.3} mm, vx = {last:.4} m/s = {ratio:.3} of the centreline speed",
        m.pos[0] * 1e3
    );
    assert!(m.pos[0] > 0.0055, "moved downstream");
    assert!(last > 0.0 && ratio < 1.0, "settles below the fluid speed");
    assert!(
        (last - vx[vx.len() - 6]).abs() < 0.05 * last,
        "settled: {:?}",
        &vx[vx.len() - 6..]
    );
}

#[test]
fn members_pushed_together_never_overlap() {
    let (_lock, ctx) = common::gpu();
    let sets = steady(&[]);
    let refs: Vec<&str> = sets.iter().map(String::as_str).collect();
    let mut b = swarm_batch(
        &ctx,
        200,
        20,
        1,
        &[[8.0, 1.0], [8.8, 1.1], [9.6, 0.7]],
        &refs,
    );
    b.set_actions(0, &[[1.0, 0.0], [-1.0, 0.0], [-1.0, 0.5]])
        .unwrap();
    let mut touched = false;
    for _ in 0..60 {
        b.step().unwrap();
        let m = b.members();
        for i in 0..3 {
            for j in 0..i {
                let d = (m[i].pos[0] - m[j].pos[0]).hypot(m[i].pos[1] - m[j].pos[1]);
                assert!(
                    d >= 2.0 * R as f32 * (1.0 - 1e-3),
                    "members {i}, {j} overlap: {d:e}"
                );
                touched |= d <= 2.0 * R as f32 * 1.01;
            }
        }
        let f = b.member_forces();
        for k in 0..2 {
            let sum: f32 = f.iter().map(|d| d.contact[k]).sum();
            assert!(sum.abs() < 1e-5 * F_MAX as f32);
        }
    }
    assert!(touched, "the members were pushed into contact");
}

/// A whole control step with members (paint, advect with the Brinkman blend skipped away from
/// the swarm, pressure, projection, move) against the CPU batch twin, on an awkward grid where
/// the swarm covers only part of the channel.
#[test]
fn whole_control_step_with_a_swarm_matches_cpu() {
    let (_lock, ctx) = common::gpu();
    let pos = [[2.0, 0.5], [2.6, 0.9], [3.3, 0.6]];
    let extra = ["time.substeps=4", "time.control_dt_s=0.001"];
    let mut b = swarm_batch(&ctx, 77, 13, 2, &pos, &extra);
    let n = b.n_members();
    let actions: Vec<[f32; 2]> = (0..2 * n)
        .map(|k| [-1.0 + 0.3 * k as f32, 0.5 - 0.2 * k as f32])
        .collect();
    b.set_all_actions(&actions).unwrap();
    let cpu_start = b.members().to_vec();
    let read = |w| b.read_all(w).unwrap();
    let quads =
        |v: Vec<f32>| -> Vec<[f32; 4]> { v.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect() };
    let mut reference = cpu::BatchState {
        params: *b.params(),
        scheme: fluxswarm_gpu::config::Advection::Maccormack,
        poisson: read(FieldBinding::Poisson),
        u: read(FieldBinding::UIn),
        v: read(FieldBinding::VIn),
        p: read(FieldBinding::Pressure),
        body: quads(read(FieldBinding::Body)),
        divstar: vec![0.0; 2 * 77],
        members: cpu_start.clone(),
        actions: actions.clone(),
        boxes: current_boxes(&read(FieldBinding::SwarmBox)),
    };
    let inlet: Vec<f32> = (0..2)
        .flat_map(|_| (0..4).map(|s| b.waveform().at((s as f64 + 1.0) * 0.001 / 4.0) as f32))
        .collect();
    b.step().unwrap();
    reference.step(&inlet);
    let read = |w| b.read_all(w).unwrap();
    close("u", &read(FieldBinding::UIn), &reference.u, 1e-4);
    close("v", &read(FieldBinding::VIn), &reference.v, 1e-4);
    close("p", &read(FieldBinding::Pressure), &reference.p, 1e-4);
    let body: Vec<f32> = reference.body.concat();
    close("body", &read(FieldBinding::Body), &body, 1e-5);
    let flat = |m: &[GpuMember]| -> Vec<f32> {
        m.iter()
            .flat_map(|m| [m.pos[0], m.pos[1], m.vel[0], m.vel[1]])
            .collect()
    };
    let moved = flat(b.members());
    close("members", &moved, &flat(&reference.members), 1e-5);
    // The members moved, and the solid is where they are.
    assert_ne!(moved, flat(&cpu_start));
    assert!(body.iter().step_by(4).any(|chi| *chi > 0.5));
}

/// The paint writes only inside the current and the previously painted box: after the swarm
/// jumps (as the move kernel records it: current box, painted box), the old discs are cleared
/// and the new ones painted, exactly as a full repaint would; cells outside both boxes are not
/// touched (they are zero by construction in a run).
#[test]
fn paint_clears_where_the_swarm_was_and_nothing_beyond() {
    let (_lock, ctx) = common::gpu();
    let at_a = [[1.5, 0.5], [2.0, 0.8]];
    let b = swarm_batch(&ctx, 60, 14, 1, &at_a, &[]);
    b.run_stages(&[Stage::PaintBodies], 0, 1).unwrap(); // full paint at A
    let raw_box = b.read_all(FieldBinding::SwarmBox).unwrap();
    let box_a = current_boxes(&raw_box)[0];
    // The swarm now at B, 2.5 mm downstream; the box to clear is A's.
    let at_b = [
        member(4.0, 0.5, 0.0, 0.0, false),
        member(4.5, 0.8, 0.0, 0.0, false),
    ];
    b.write_all(
        FieldBinding::Members,
        bytemuck::cast_slice::<GpuMember, f32>(&at_b),
    );
    let box_b = [4.0e-3, 4.5e-3, 0.5e-3, 0.8e-3];
    b.write_all(FieldBinding::SwarmBox, &[box_b, box_a].concat());
    // A marker far from both boxes must survive: the paint does not visit it.
    let mut body = b.read_all(FieldBinding::Body).unwrap();
    let far = 13 * 60 + 58; // cell (58, 13), 5.8 mm
    body[4 * far] = 0.25;
    b.write_all(FieldBinding::Body, &body);
    b.run_stages(&[Stage::PaintBodies], 0, 1).unwrap();
    let got = b.read_all(FieldBinding::Body).unwrap();
    let mut want: Vec<f32> = cpu::paint_bodies(b.params(), &at_b, &[box_b]).concat();
    want[4 * far] = 0.25;
    close("body after the jump", &got, &want, 1e-6);
    let chi_near_a = got[4 * (5 * 60 + 15)]; // cell (15, 5): inside the old disc at (1.5, 0.5)
    assert_eq!(chi_near_a, 0.0, "the old disc is cleared");
    assert!(
        got.chunks(4).filter(|c| c[0] == 1.0).count() >= 2 * 9,
        "new discs painted"
    );
}
