//! The swarm members of one environment (SPEC section 2), mirroring `shaders/members.wgsl`:
//! - `paint_bodies`: the body field, chi = clamp(1/2 + (r - d)/dx, 0, 1) of the nearest
//!   member with its velocity, `[ny][nx]` (chi, u_body, v_body, 0); only cells near the swarm's
//!   box are visited, every other cell is fluid;
//! - `move_members`: the pressure force from four samples at R_s (-pi r/2 depth dp), the
//!   Schiller-Naumann drag (implicit in v), the propulsion F_max a / max(1, |a|) and contact
//!   forces, a semi-implicit Euler step, then four passes of overlap and wall constraints.
//!   Shapes: members, actions, diags `[N]`; u, v, p of the environment; box `[4]`
//!   (x_min, x_max, y_min, y_max of the centres).

use std::f32::consts::PI;
use std::ops::Range;

use super::advect::CellRect;
use super::stencil::{Dim, bilerp, floor_i32, mix};
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams};

/// The body field [ny][nx] of one environment from its members and swarm box; returns the
/// rectangle of cells it may have painted (every cell outside it is fluid). `cleared`: a
/// rectangle outside which `body` is already fluid (the last call's), so that only it is
/// cleared; None clears the whole field.
pub(crate) fn paint_bodies(
    d: &Dim,
    members: &[GpuMember],
    bx: [f32; 4],
    body: &mut [[f32; 4]],
    cleared: Option<&CellRect>,
) -> CellRect {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let reach = p.radius + p.dx;
    match cleared {
        Some(r) => {
            for j in r.j.clone() {
                body[j * nx + r.i.start..j * nx + r.i.end].fill([0.0; 4]);
            }
        }
        None => body.fill([0.0; 4]),
    }
    // Cell centres (i + 1/2) dx inside [lo, hi] lie in this index range (one cell of margin
    // either side for rounding); the exact test below decides.
    let range = |lo: f32, hi: f32, h: f32, n: usize| {
        let a = floor_i32(lo / h - 0.5) - 1;
        let b = floor_i32(hi / h - 0.5) + 2;
        a.clamp(0, n as i32) as usize..b.clamp(0, n as i32) as usize
    };
    let boxed = CellRect {
        i: range(bx[0] - reach, bx[1] + reach, p.dx, nx),
        j: range(bx[2] - reach, bx[3] + reach, p.dy, ny),
    };
    let in_box = |c: [f32; 2]| {
        c[0] >= bx[0] - reach
            && c[0] <= bx[1] + reach
            && c[1] >= bx[2] - reach
            && c[1] <= bx[3] + reach
    };
    // Each member paints the cells within `reach` of its centre where it is the most solid
    // so far: in member order, as a per-cell loop over all members (cells farther away have
    // chi = 0 for it, and the first member with the largest chi wins either way).
    let clip = |a: Range<usize>, b: &Range<usize>| a.start.max(b.start)..a.end.min(b.end);
    for mem in members {
        let (x, y) = (mem.pos[0], mem.pos[1]);
        let cols = clip(range(x - reach, x + reach, p.dx, nx), &boxed.i);
        for j in clip(range(y - reach, y + reach, p.dy, ny), &boxed.j) {
            for i in cols.clone() {
                let c = [(i as f32 + 0.5) * p.dx, (j as f32 + 0.5) * p.dy];
                if !in_box(c) {
                    continue;
                }
                let dist = (c[0] - x).hypot(c[1] - y);
                let chi = (0.5 + (p.radius - dist) * p.inv_dx).clamp(0.0, 1.0);
                let cell = &mut body[j * nx + i];
                if chi > cell[0] {
                    *cell = [chi, mem.vel[0], mem.vel[1], 0.0];
                }
            }
        }
    }
    boxed
}

/// F_prop = F_max a / max(1, |a|) (N).
pub fn propulsion(p: &GpuParams, a: [f32; 2]) -> [f32; 2] {
    let s = p.max_thrust / a[0].hypot(a[1]).max(1.0);
    [s * a[0], s * a[1]]
}

/// C_d |v_rel| of the Schiller-Naumann law (m/s), as `members.wgsl` evaluates it.
pub fn cd_times_speed(p: &GpuParams, speed: f32) -> f32 {
    let re = p.rho * speed * 2.0 * p.radius / p.mu;
    let stokes = 24.0 * p.mu / (p.rho * 2.0 * p.radius);
    if re < 0.1 {
        stokes
    } else if re < 1000.0 {
        stokes * (1.0 + 0.15 * re.powf(0.687))
    } else {
        0.44 * speed
    }
}

/// Pressure at (x, y), bilinear in the cell centres (clamped to the outermost centres).
fn sample_p(d: &Dim, pres: &[f32], x: f32, y: f32) -> f32 {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let fx = (x * p.inv_dx - 0.5).clamp(0.0, (nx - 1) as f32);
    let fy = (y * p.inv_dy - 0.5).clamp(0.0, (ny - 1) as f32);
    let i0 = (fx as usize).min(nx - 2);
    let j0 = (fy as usize).min(ny - 2);
    let (tx, ty) = (fx - i0 as f32, fy - j0 as f32);
    let at = |i, j| pres[j * nx + i];
    let bottom = mix(at(i0, j0), at(i0 + 1, j0), tx);
    let top = mix(at(i0, j0 + 1), at(i0 + 1, j0 + 1), tx);
    mix(bottom, top, ty)
}

/// Moves the members of one environment through one substep in the projected velocity u, v
/// and pressure: their forces and samples into `diags`, the new swarm box into `bx`.
#[allow(clippy::too_many_arguments)] // the stage's inputs and outputs, named as in SPEC 2
pub(crate) fn move_members(
    d: &Dim,
    members: &mut [GpuMember],
    actions: &[[f32; 2]],
    pres: &[f32],
    u: &[f32],
    v: &[f32],
    diags: &mut [GpuMemberDiag],
    bx: &mut [f32; 4],
) {
    let p = &d.p;
    let n = members.len();
    let swarm: &[GpuMember] = members;
    let force: Vec<[f32; 2]> = actions.iter().map(|&a| propulsion(p, a)).collect();
    let mut pos = Vec::with_capacity(n);
    let mut vel = Vec::with_capacity(n);
    for (m, me) in swarm.iter().enumerate() {
        let clampq = |q: [f32; 2]| [q[0].clamp(0.0, p.length), q[1].clamp(0.0, p.height)];
        let rs = p.sample_radius;
        let q = [
            clampq([me.pos[0] + rs, me.pos[1]]),
            clampq([me.pos[0], me.pos[1] + rs]),
            clampq([me.pos[0] - rs, me.pos[1]]),
            clampq([me.pos[0], me.pos[1] - rs]),
        ];
        let ps = q.map(|q| sample_p(d, pres, q[0], q[1]));
        let mut uf = [0.0f32; 2];
        for q in &q {
            let (su, tu) = d.stencil_u(u, q[0], q[1]);
            let (sv, tv) = d.stencil_v(v, q[0], q[1]);
            uf[0] += bilerp(su, tu);
            uf[1] += bilerp(sv, tv);
        }
        uf = [uf[0] * 0.25, uf[1] * 0.25];
        let c = -(PI * p.radius / 2.0) * p.depth;
        let hydro = [c * (ps[0] - ps[2]), c * (ps[1] - ps[3])];
        let rel = [uf[0] - me.vel[0], uf[1] - me.vel[1]];
        let kd = if p.drag != 0 {
            0.5 * p.rho * PI * p.radius * p.radius * cd_times_speed(p, rel[0].hypot(rel[1]))
        } else {
            0.0
        };
        let mut contact = [0.0f32; 2];
        for (j, other) in swarm.iter().enumerate() {
            let dv = [me.pos[0] - other.pos[0], me.pos[1] - other.pos[1]];
            let dist = dv[0].hypot(dv[1]);
            if j != m && dist > 0.0 && dist <= 2.0 * p.radius {
                let nij = [dv[0] / dist, dv[1] / dist];
                let push = (force[j][0] * nij[0] + force[j][1] * nij[1]).max(0.0)
                    + (-(force[m][0] * nij[0] + force[m][1] * nij[1])).max(0.0);
                contact = [contact[0] + push * nij[0], contact[1] + push * nij[1]];
            }
        }
        diags[m] = GpuMemberDiag {
            hydro,
            drag: [kd * rel[0], kd * rel[1]],
            contact,
            prop: force[m],
            p: ps,
        };
        if me.pinned == 0.0 {
            let h = p.dt / p.mass;
            let nv = |k: usize| {
                (me.vel[k] + h * (hydro[k] + force[m][k] + contact[k] + kd * uf[k]))
                    / (1.0 + h * kd)
            };
            let nvel = [nv(0), nv(1)];
            vel.push(nvel);
            pos.push([me.pos[0] + p.dt * nvel[0], me.pos[1] + p.dt * nvel[1]]);
        } else {
            vel.push([0.0, 0.0]);
            pos.push(me.pos);
        }
    }
    for _ in 0..4 {
        let (snap_p, snap_v) = (pos.clone(), vel.clone());
        for (m, me) in swarm.iter().enumerate() {
            if me.pinned != 0.0 {
                continue;
            }
            let (mut dp, mut dv) = ([0.0f32; 2], [0.0f32; 2]);
            for j in 0..n {
                let dd = [snap_p[m][0] - snap_p[j][0], snap_p[m][1] - snap_p[j][1]];
                let dist = dd[0].hypot(dd[1]);
                if j != m && dist > 0.0 && dist < 2.0 * p.radius {
                    let nij = [dd[0] / dist, dd[1] / dist];
                    let share = if swarm[j].pinned != 0.0 { 1.0 } else { 0.5 };
                    let over = share * (2.0 * p.radius - dist);
                    dp = [dp[0] + over * nij[0], dp[1] + over * nij[1]];
                    let approach = (snap_v[m][0] - snap_v[j][0]) * nij[0]
                        + (snap_v[m][1] - snap_v[j][1]) * nij[1];
                    if approach < 0.0 {
                        dv = [
                            dv[0] - share * approach * nij[0],
                            dv[1] - share * approach * nij[1],
                        ];
                    }
                }
            }
            let mut q = [snap_p[m][0] + dp[0], snap_p[m][1] + dp[1]];
            let mut w = [snap_v[m][0] + dv[0], snap_v[m][1] + dv[1]];
            let (lo, hi) = (
                [p.radius, p.radius],
                [p.length - p.radius, p.height - p.radius],
            );
            for k in 0..2 {
                if q[k] < lo[k] {
                    q[k] = lo[k];
                    w[k] = w[k].max(0.0);
                }
                if q[k] > hi[k] {
                    q[k] = hi[k];
                    w[k] = w[k].min(0.0);
                }
            }
            pos[m] = q;
            vel[m] = w;
        }
    }
    for (m, me) in members.iter_mut().enumerate() {
        me.pos = pos[m];
        me.vel = vel[m];
    }
    if n > 0 {
        let mut b = [pos[0][0], pos[0][0], pos[0][1], pos[0][1]];
        for q in &pos[1..] {
            b = [
                b[0].min(q[0]),
                b[1].max(q[0]),
                b[2].min(q[1]),
                b[3].max(q[1]),
            ];
        }
        *bx = b;
    }
}
