//! The momentum predictor u* = A(w) of one environment: semi-Lagrangian advection of the
//! diffused velocity w (bilinear, Euler or midpoint backtrace in the input velocity u^n), or
//! MacCormack (forward predictor, backward corrector, clamped to the predictor stencil's
//! extrema), then the inlet profile u(0, y) = 4 U y (H - y) / H^2, v = 0 on the walls, and
//! the Brinkman blend with the body velocity, (1 - chi) w + chi w_body, on each face.
//! Mirrors `shaders/advect.wgsl`. Shapes: u, u_out [ny][nx+1]; v, v_out [ny+1][nx];
//! body [ny][nx] (chi, u_body, v_body, 0). Works a row of faces at a time: face velocities
//! and departure points (vectorised), corners and weights, gathers, blend.

use super::diffuse::diffuse;
use super::stencil::{Dim, RowScratch};
use crate::config::Advection;

/// Reusable buffers of [`advect`], sized for one environment.
#[derive(Debug, Default, Clone)]
pub(crate) struct AdvectScratch {
    /// The diffused input velocity w.
    w_u: Vec<f32>,
    w_v: Vec<f32>,
    /// MacCormack predictor and its stencil's (min, max), per face.
    hat_u: Vec<f32>,
    hat_v: Vec<f32>,
    ext_u: Vec<[f32; 2]>,
    ext_v: Vec<[f32; 2]>,
    /// The input velocity at each face (the predictor's, reused by the correction).
    vel_u: Vec<[f32; 2]>,
    vel_v: Vec<[f32; 2]>,
    row: RowScratch,
}

impl AdvectScratch {
    fn resize(&mut self, d: &Dim) {
        let (nu, nv) = (d.n_u(), d.n_v());
        self.w_u.resize(nu, 0.0);
        self.hat_u.resize(nu, 0.0);
        self.w_v.resize(nv, 0.0);
        self.hat_v.resize(nv, 0.0);
        self.ext_u.resize(nu, [0.0; 2]);
        self.ext_v.resize(nv, [0.0; 2]);
        self.vel_u.resize(nu, [0.0; 2]);
        self.vel_v.resize(nv, [0.0; 2]);
    }
}

/// The MacCormack value clamped to the predictor's stencil extrema; a non-finite value passes
/// unclamped, as in `advect.wgsl`, so a blow-up reaches the health check (`f32::clamp` would
/// panic on it; for finite values the two are the same).
#[inline(always)]
fn limited(raw: f32, [lo, hi]: [f32; 2]) -> f32 {
    if !raw.is_finite() {
        return raw;
    }
    raw.clamp(lo, hi)
}

/// Brinkman blend of a face between cells a and b (solid fractions chi, body velocities w).
#[inline(always)]
pub(crate) fn brinkman(w: f32, chi_a: f32, w_a: f32, chi_b: f32, w_b: f32) -> f32 {
    if chi_a == 0.0 && chi_b == 0.0 {
        return w;
    }
    let chi = 0.5 * (chi_a + chi_b);
    (1.0 - chi) * w + 0.5 * (chi_a * w_a + chi_b * w_b)
}

/// The momentum predictor u* of one environment into `u_out` / `v_out`, a row of faces at a
/// time: face velocities and departure points, then the row's samples, then the update.
#[allow(clippy::too_many_arguments)] // the stage's inputs and outputs, named as in SPEC 1
pub(crate) fn advect(
    d: &Dim,
    scheme: Advection,
    u: &[f32],
    v: &[f32],
    body: &[[f32; 4]],
    centre: f32,
    s: &mut AdvectScratch,
    u_out: &mut [f32],
    v_out: &mut [f32],
) {
    s.resize(d);
    let (nx, ny, p) = (d.nx, d.ny, d.p);
    let row = nx + 1;
    diffuse(d, u, v, &mut s.w_u, &mut s.w_v);
    s.row.resize(nx);
    let mac = scheme == Advection::Maccormack;
    // Face velocities (the predictor's, reused by the correction).
    for j in 0..ny {
        let base = j * row;
        for i in 1..nx {
            let k = j * nx + i - 1;
            let sum = v[k] + v[k + 1] + v[k + nx] + v[k + nx + 1];
            s.vel_u[base + i] = [u[base + i], 0.25 * sum];
        }
        s.vel_u[base + nx] = d.velocity_at_u_face(u, v, nx, j);
    }
    for j in 1..ny {
        for i in 0..nx {
            let k = (j - 1) * row + i;
            let sum = u[k] + u[k + 1] + u[k + row] + u[k + row + 1];
            s.vel_v[j * nx + i] = [0.25 * sum, v[j * nx + i]];
        }
    }
    let h_forward = p.dt;
    if mac {
        for j in 0..ny {
            let faces = j * row + 1..j * row + row;
            s.hat_u[j * row] = u[j * row];
            departures_u(d, u, v, j, &s.vel_u[faces.clone()], h_forward, &mut s.row);
            d.sample_u_row(&s.w_u, &mut s.row, nx, Some(&mut s.ext_u[faces.clone()]));
            s.hat_u[faces].copy_from_slice(&s.row.out[..nx]);
        }
        s.hat_v[..nx].fill(0.0);
        s.hat_v[ny * nx..].fill(0.0);
        for j in 1..ny {
            let faces = j * nx..(j + 1) * nx;
            departures_v(d, u, v, j, &s.vel_v[faces.clone()], h_forward, &mut s.row);
            d.sample_v_row(&s.w_v, &mut s.row, nx, Some(&mut s.ext_v[faces.clone()]));
            s.hat_v[faces].copy_from_slice(&s.row.out[..nx]);
        }
    }
    for j in 0..ny {
        let y = (j as f32 + 0.5) * p.dy;
        u_out[j * row] = 4.0 * centre * y * (p.height - y) / (p.height * p.height);
        let faces = j * row + 1..j * row + row;
        if mac {
            departures_u(d, u, v, j, &s.vel_u[faces.clone()], -p.dt, &mut s.row);
            d.sample_u_row(&s.hat_u, &mut s.row, nx, None);
        } else {
            departures_u(d, u, v, j, &s.vel_u[faces.clone()], h_forward, &mut s.row);
            d.sample_u_row(&s.w_u, &mut s.row, nx, None);
        }
        for i in 1..=nx {
            let k = j * row + i;
            let sampled = s.row.out[i - 1];
            let w = if mac {
                limited(s.hat_u[k] + 0.5 * (s.w_u[k] - sampled), s.ext_u[k])
            } else {
                sampled
            };
            let a = body[j * nx + i.max(1) - 1];
            let b = body[j * nx + i.min(nx - 1)];
            u_out[k] = brinkman(w, a[0], a[1], b[0], b[1]);
        }
    }
    v_out[..nx].fill(0.0);
    v_out[ny * nx..].fill(0.0);
    for j in 1..ny {
        let faces = j * nx..(j + 1) * nx;
        if mac {
            departures_v(d, u, v, j, &s.vel_v[faces.clone()], -p.dt, &mut s.row);
            d.sample_v_row(&s.hat_v, &mut s.row, nx, None);
        } else {
            departures_v(d, u, v, j, &s.vel_v[faces.clone()], h_forward, &mut s.row);
            d.sample_v_row(&s.w_v, &mut s.row, nx, None);
        }
        for i in 0..nx {
            let k = j * nx + i;
            let sampled = s.row.out[i];
            let w = if mac {
                limited(s.hat_v[k] + 0.5 * (s.w_v[k] - sampled), s.ext_v[k])
            } else {
                sampled
            };
            let a = body[(j - 1) * nx + i];
            let b = body[j * nx + i];
            v_out[k] = brinkman(w, a[0], a[2], b[0], b[2]);
        }
    }
}

/// Departure points (into r.x, r.y) of u faces 1..=nx of row j after a step h, from their
/// velocities `vel`, as `trace` per face (the Euler loop vectorises).
#[inline(always)]
fn departures_u(
    d: &Dim,
    u: &[f32],
    v: &[f32],
    j: usize,
    vel: &[[f32; 2]],
    h: f32,
    r: &mut RowScratch,
) {
    let y = (j as f32 + 0.5) * d.p.dy;
    if d.p.rk2 == 0 {
        for (n, vel) in vel.iter().enumerate() {
            r.x[n] = (n + 1) as f32 * d.p.dx - h * vel[0];
            r.y[n] = y - h * vel[1];
        }
    } else {
        for (n, vel) in vel.iter().enumerate() {
            let dep = d.trace(u, v, d.u_pos(n + 1, j), *vel, h);
            (r.x[n], r.y[n]) = (dep[0], dep[1]);
        }
    }
}

/// Departure points of v faces 0..nx of row j (as [`departures_u`]).
#[inline(always)]
fn departures_v(
    d: &Dim,
    u: &[f32],
    v: &[f32],
    j: usize,
    vel: &[[f32; 2]],
    h: f32,
    r: &mut RowScratch,
) {
    let y = j as f32 * d.p.dy;
    if d.p.rk2 == 0 {
        for (n, vel) in vel.iter().enumerate() {
            r.x[n] = (n as f32 + 0.5) * d.p.dx - h * vel[0];
            r.y[n] = y - h * vel[1];
        }
    } else {
        for (n, vel) in vel.iter().enumerate() {
            let dep = d.trace(u, v, d.v_pos(n, j), *vel, h);
            (r.x[n], r.y[n]) = (dep[0], dep[1]);
        }
    }
}
