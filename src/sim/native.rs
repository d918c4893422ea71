//! The native yardstick: the control step of [`cpu::CpuBatch`] written for speed on the CPU,
//! to measure how far the software adapter is from what these cores can do (issue 6).
//!
//! Same algorithm, same f32 arithmetic in the same order, on the same layouts as the twins
//! (per environment: u [ny][nx+1], v [ny+1][nx], cells [ny][nx], modes [ny][nx]), so its
//! results equal [`cpu::CpuBatch::step`] bit for bit (tested). What differs is only how the
//! work is organised:
//! - w = u + dt nu lap u is computed once per face into scratch (the twins recompute it at
//!   every stencil point they sample);
//! - the MacCormack predictor keeps its stencil's extrema, so the correction does not trace
//!   and sample the forward stencil again;
//! - interior stencils index directly, ghosts are mapped only on the boundary rows/columns;
//! - buffers are reused between substeps instead of allocated per pass.
//!
//! The members (paint, forces, move) use the twins themselves: they are under 1 % of a step.
//! One call advances every environment of the batch in turn; run one batch per thread (rayon)
//! for parallelism, as `benches/substep.rs` does.

use crate::config::Advection;
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams};
use crate::waveform::Waveform;

use rayon::prelude::*;

use super::EnvHealth;
use super::cpu::{self, CpuBatch};

/// Reusable per-environment scratch of [`step`].
#[derive(Debug, Default, Clone)]
pub struct Scratch {
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
    u_out: Vec<f32>,
    v_out: Vec<f32>,
    modes: Vec<f32>,
    divstar: Vec<f32>,
    p: Vec<f32>,
    /// Forces and pressure samples of every member in the last substep, [E][N].
    diags: Vec<GpuMemberDiag>,
    row: RowScratch,
}

/// One row of faces being advected: departure points, stencil corners and weights, and the
/// sampled values.
#[derive(Debug, Default, Clone)]
struct RowScratch {
    x: Vec<f32>,
    y: Vec<f32>,
    corner: Vec<[i32; 2]>,
    t: Vec<[f32; 2]>,
    vals: Vec<[f32; 4]>,
    out: Vec<f32>,
}

impl RowScratch {
    fn resize(&mut self, n: usize) {
        self.x.resize(n, 0.0);
        self.y.resize(n, 0.0);
        self.corner.resize(n, [0; 2]);
        self.t.resize(n, [0.0; 2]);
        self.vals.resize(n, [0.0; 4]);
        self.out.resize(n, 0.0);
    }
}

/// The sizes and constants of one environment's grid.
#[derive(Clone, Copy)]
struct Dim {
    nx: usize,
    ny: usize,
    p: GpuParams,
}

impl Dim {
    fn n_u(&self) -> usize {
        self.ny * (self.nx + 1)
    }
    fn n_v(&self) -> usize {
        (self.ny + 1) * self.nx
    }
    fn n_c(&self) -> usize {
        self.ny * self.nx
    }

    /// Ghost-mapped u-like value (i clamped to [0, nx]; rows -1 and ny mirror, odd).
    #[inline(always)]
    fn fetch_u(&self, a: &[f32], i: i32, j: i32) -> f32 {
        let row = self.nx + 1;
        let ic = i.clamp(0, self.nx as i32) as usize;
        if j < 0 {
            -a[ic]
        } else if j >= self.ny as i32 {
            -a[(self.ny - 1) * row + ic]
        } else {
            a[j as usize * row + ic]
        }
    }

    /// Ghost-mapped v-like value (column -1 mirrors, odd; column nx repeats nx-1; j clamped).
    #[inline(always)]
    fn fetch_v(&self, a: &[f32], i: i32, j: i32) -> f32 {
        let jc = j.clamp(0, self.ny as i32) as usize;
        if i < 0 {
            -a[jc * self.nx]
        } else {
            a[jc * self.nx + (i as usize).min(self.nx - 1)]
        }
    }

    /// Bilinear stencil of a u-like field around (x, y), as `G::stencil_u`: the values at
    /// its four corners and the weights.
    #[inline(always)]
    fn stencil_u(&self, a: &[f32], x: f32, y: f32) -> ([f32; 4], [f32; 2]) {
        let (corner, t) = self.corner_u(x, y);
        (self.gather_u(a, corner), t)
    }

    /// As [`Self::stencil_u`] for a v-like field (`G::stencil_v`).
    #[inline(always)]
    fn stencil_v(&self, a: &[f32], x: f32, y: f32) -> ([f32; 4], [f32; 2]) {
        let (corner, t) = self.corner_v(x, y);
        (self.gather_v(a, corner), t)
    }

    /// Lower-left stored u face (i0, j0) of the stencil around (x, y) (clamped into the
    /// channel) and the fractional position inside it.
    #[inline(always)]
    fn corner_u(&self, x: f32, y: f32) -> ([i32; 2], [f32; 2]) {
        let p = &self.p;
        let fx = (x * p.inv_dx).clamp(0.0, p.nx as f32);
        let fy = (y * p.inv_dy).clamp(0.0, p.ny as f32) - 0.5;
        let i0 = floor_i32(fx).min(self.nx as i32 - 1);
        let j0 = floor_i32(fy);
        ([i0, j0], [fx - i0 as f32, fy - j0 as f32])
    }

    /// As [`Self::corner_u`] for v faces.
    #[inline(always)]
    fn corner_v(&self, x: f32, y: f32) -> ([i32; 2], [f32; 2]) {
        let p = &self.p;
        let fx = (x * p.inv_dx).clamp(0.0, p.nx as f32) - 0.5;
        let fy = (y * p.inv_dy).clamp(0.0, p.ny as f32);
        let i0 = floor_i32(fx);
        let j0 = floor_i32(fy).min(self.ny as i32 - 1);
        ([i0, j0], [fx - i0 as f32, fy - j0 as f32])
    }

    /// The four values of a u-like stencil from its corner (ghosts mapped off the interior).
    #[inline(always)]
    fn gather_u(&self, a: &[f32], [i0, j0]: [i32; 2]) -> [f32; 4] {
        if j0 >= 0 && j0 + 1 < self.ny as i32 {
            let row = self.nx + 1;
            let k = j0 as usize * row + i0 as usize;
            [a[k], a[k + 1], a[k + row], a[k + row + 1]]
        } else {
            [
                self.fetch_u(a, i0, j0),
                self.fetch_u(a, i0 + 1, j0),
                self.fetch_u(a, i0, j0 + 1),
                self.fetch_u(a, i0 + 1, j0 + 1),
            ]
        }
    }

    /// As [`Self::gather_u`] for a v-like field.
    #[inline(always)]
    fn gather_v(&self, a: &[f32], [i0, j0]: [i32; 2]) -> [f32; 4] {
        let nx = self.nx;
        if i0 >= 0 && i0 + 1 < nx as i32 {
            let k = j0 as usize * nx + i0 as usize;
            [a[k], a[k + 1], a[k + nx], a[k + nx + 1]]
        } else {
            [
                self.fetch_v(a, i0, j0),
                self.fetch_v(a, i0 + 1, j0),
                self.fetch_v(a, i0, j0 + 1),
                self.fetch_v(a, i0 + 1, j0 + 1),
            ]
        }
    }

    /// Bilinear samples of the u-like field `a` at the points (r.x[n], r.y[n]), n < len, into
    /// r.out (and their stencil extrema into `ext`), exactly as `stencil_u` + `bilerp` per
    /// point, in three passes: corners and weights (vectorised), the gathers, the blend.
    #[inline(always)]
    fn sample_u_row(
        &self,
        a: &[f32],
        r: &mut RowScratch,
        len: usize,
        ext: Option<&mut [[f32; 2]]>,
    ) {
        for n in 0..len {
            (r.corner[n], r.t[n]) = self.corner_u(r.x[n], r.y[n]);
        }
        for n in 0..len {
            r.vals[n] = self.gather_u(a, r.corner[n]);
        }
        Self::blend(r, len, ext);
    }

    /// As [`Self::sample_u_row`] for a v-like field.
    #[inline(always)]
    fn sample_v_row(
        &self,
        a: &[f32],
        r: &mut RowScratch,
        len: usize,
        ext: Option<&mut [[f32; 2]]>,
    ) {
        for n in 0..len {
            (r.corner[n], r.t[n]) = self.corner_v(r.x[n], r.y[n]);
        }
        for n in 0..len {
            r.vals[n] = self.gather_v(a, r.corner[n]);
        }
        Self::blend(r, len, ext);
    }

    #[inline(always)]
    fn blend(r: &mut RowScratch, len: usize, ext: Option<&mut [[f32; 2]]>) {
        for n in 0..len {
            r.out[n] = bilerp(r.vals[n], r.t[n]);
        }
        if let Some(ext) = ext {
            for (e, vals) in ext[..len].iter_mut().zip(&r.vals) {
                *e = extrema(*vals);
            }
        }
    }

    /// Input velocity at u face (i, j): its u and the mean of the four v faces around it.
    #[inline(always)]
    fn velocity_at_u_face(&self, u: &[f32], v: &[f32], i: usize, j: usize) -> [f32; 2] {
        let s = if i >= 1 && i < self.nx {
            let k = j * self.nx + i - 1;
            v[k] + v[k + 1] + v[k + self.nx] + v[k + self.nx + 1]
        } else {
            let (a, b) = (i as i32, j as i32);
            self.fetch_v(v, a - 1, b)
                + self.fetch_v(v, a, b)
                + self.fetch_v(v, a - 1, b + 1)
                + self.fetch_v(v, a, b + 1)
        };
        [u[j * (self.nx + 1) + i], 0.25 * s]
    }

    /// Departure point from pos after a step h (Euler, or the midpoint rule in the input
    /// velocity), as `G::trace`.
    #[inline(always)]
    fn trace(&self, u: &[f32], v: &[f32], pos: [f32; 2], v0: [f32; 2], h: f32) -> [f32; 2] {
        if self.p.rk2 == 0 {
            return [pos[0] - h * v0[0], pos[1] - h * v0[1]];
        }
        let mid = [pos[0] - 0.5 * h * v0[0], pos[1] - 0.5 * h * v0[1]];
        let (su, tu) = self.stencil_u(u, mid[0], mid[1]);
        let (sv, tv) = self.stencil_v(v, mid[0], mid[1]);
        let v1 = [bilerp(su, tu), bilerp(sv, tv)];
        [pos[0] - h * v1[0], pos[1] - h * v1[1]]
    }

    fn u_pos(&self, i: usize, j: usize) -> [f32; 2] {
        [i as f32 * self.p.dx, (j as f32 + 0.5) * self.p.dy]
    }

    fn v_pos(&self, i: usize, j: usize) -> [f32; 2] {
        [(i as f32 + 0.5) * self.p.dx, j as f32 * self.p.dy]
    }
}

/// `x.floor() as i32` without a libm call (the baseline x86-64 target has no rounding
/// instruction): the same value for every finite x in i32's range, and 0 for NaN.
#[inline(always)]
fn floor_i32(x: f32) -> i32 {
    let t = x as i32;
    if (t as f32) > x { t - 1 } else { t }
}

#[inline(always)]
fn mix(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

#[inline(always)]
fn bilerp(vals: [f32; 4], t: [f32; 2]) -> f32 {
    mix(
        mix(vals[0], vals[1], t[0]),
        mix(vals[2], vals[3], t[0]),
        t[1],
    )
}

#[inline(always)]
fn extrema(vals: [f32; 4]) -> [f32; 2] {
    [
        vals.iter().copied().fold(f32::INFINITY, f32::min),
        vals.iter().copied().fold(f32::NEG_INFINITY, f32::max),
    ]
}

/// The MacCormack value clamped to the predictor's stencil extrema; a non-finite value passes
/// unclamped, as in `advect.wgsl`, so a blow-up reaches the health check (the twin's
/// `f32::clamp` would panic on it; for finite values the two are the same).
#[inline(always)]
fn limited(raw: f32, [lo, hi]: [f32; 2]) -> f32 {
    if !raw.is_finite() {
        return raw;
    }
    raw.clamp(lo, hi)
}

#[inline(always)]
fn brinkman(w: f32, chi_a: f32, w_a: f32, chi_b: f32, w_b: f32) -> f32 {
    if chi_a == 0.0 && chi_b == 0.0 {
        return w;
    }
    let chi = 0.5 * (chi_a + chi_b);
    (1.0 - chi) * w + 0.5 * (chi_a * w_a + chi_b * w_b)
}

/// w = u + dt nu lap u on every face (inlet faces and wall v faces keep u, 0). Interior runs
/// of a row go through a branch-free loop (which the compiler vectorises); faces next to a
/// boundary map their ghosts.
fn diffuse(d: &Dim, u: &[f32], v: &[f32], w_u: &mut [f32], w_v: &mut [f32]) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let (ax, ay) = (p.dx * p.dx, p.dy * p.dy);
    let coef = p.dt * p.nu;
    let row = nx + 1;
    let edge_u = |i: usize, j: usize| {
        let (a, b) = (i as i32, j as i32);
        let c = d.fetch_u(u, a, b);
        let lx = d.fetch_u(u, a + 1, b) + d.fetch_u(u, a - 1, b) - 2.0 * c;
        let ly = d.fetch_u(u, a, b + 1) + d.fetch_u(u, a, b - 1) - 2.0 * c;
        u[j * row + i] + coef * (lx / ax + ly / ay)
    };
    for j in 0..ny {
        w_u[j * row] = u[j * row];
        if j >= 1 && j + 1 < ny {
            let (lo, hi) = (j * row + 1, j * row + nx);
            for k in lo..hi {
                let c = u[k];
                let lx = u[k + 1] + u[k - 1] - 2.0 * c;
                let ly = u[k + row] + u[k - row] - 2.0 * c;
                w_u[k] = c + coef * (lx / ax + ly / ay);
            }
            w_u[j * row + nx] = edge_u(nx, j);
        } else {
            for i in 1..=nx {
                w_u[j * row + i] = edge_u(i, j);
            }
        }
    }
    let edge_v = |i: usize, j: usize| {
        let (a, b) = (i as i32, j as i32);
        let c = v[j * nx + i];
        let lx = d.fetch_v(v, a + 1, b) + d.fetch_v(v, a - 1, b) - 2.0 * c;
        let ly = d.fetch_v(v, a, b + 1) + d.fetch_v(v, a, b - 1) - 2.0 * c;
        c + coef * (lx / ax + ly / ay)
    };
    w_v[..nx].fill(0.0);
    w_v[ny * nx..(ny + 1) * nx].fill(0.0);
    for j in 1..ny {
        w_v[j * nx] = edge_v(0, j);
        for k in j * nx + 1..j * nx + nx - 1 {
            let c = v[k];
            let lx = v[k + 1] + v[k - 1] - 2.0 * c;
            let ly = v[k + nx] + v[k - nx] - 2.0 * c;
            w_v[k] = c + coef * (lx / ax + ly / ay);
        }
        w_v[j * nx + nx - 1] = edge_v(nx - 1, j);
    }
}

/// The momentum predictor u* of one environment into s.u_out / s.v_out, a row of faces at a
/// time: face velocities and departure points, then the row's samples, then the update.
#[inline(always)]
fn advect(
    d: &Dim,
    scheme: Advection,
    u: &[f32],
    v: &[f32],
    body: &[[f32; 4]],
    centre: f32,
    s: &mut Scratch,
) {
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
        s.u_out[j * row] = 4.0 * centre * y * (p.height - y) / (p.height * p.height);
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
            s.u_out[k] = brinkman(w, a[0], a[1], b[0], b[1]);
        }
    }
    s.v_out[..nx].fill(0.0);
    s.v_out[ny * nx..].fill(0.0);
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
            s.v_out[k] = brinkman(w, a[0], a[2], b[0], b[2]);
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

/// Columns handled together by the column transforms: their sums run side by side in vector
/// registers, each column's in the twin's order.
const BLOCK: usize = 8;

/// Divergence, its column maxima and the y-cosine modes of rho/dt div u* (as the twin).
fn pressure_rhs(d: &Dim, poisson: &[f32], s: &mut Scratch) {
    let full = d.nx / BLOCK * BLOCK;
    for i0 in (0..full).step_by(BLOCK) {
        rhs_columns::<BLOCK>(d, poisson, s, i0);
    }
    for i0 in full..d.nx {
        rhs_columns::<1>(d, poisson, s, i0);
    }
}

/// [`pressure_rhs`] for columns i0 .. i0 + N.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // rows and lanes of parallel arrays, indexed together
fn rhs_columns<const N: usize>(d: &Dim, poisson: &[f32], s: &mut Scratch, i0: usize) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let (u, v) = (&s.u_out, &s.v_out);
    let row = nx + 1;
    let half = ny / 2;
    let scale = p.rho / p.dt;
    let mut column = [[0.0f32; N]; 64];
    let mut dmax = [0.0f32; N];
    for j in 0..ny {
        let (ua, va, vb) = (j * row + i0, j * nx + i0, (j + 1) * nx + i0);
        for b in 0..N {
            let c = (u[ua + b + 1] - u[ua + b]) / p.dx + (v[vb + b] - v[va + b]) / p.dy;
            column[j][b] = c;
            dmax[b] = dmax[b].max(c.abs());
        }
    }
    s.divstar[i0..i0 + N].copy_from_slice(&dmax);
    for j in 0..half {
        for b in 0..N {
            let (lo, hi) = (column[j][b], column[ny - 1 - j][b]);
            column[j][b] = lo + hi;
            column[ny - 1 - j][b] = lo - hi;
        }
    }
    for k in 0..ny {
        let mut acc = [0.0f32; N];
        let mut add = |q: f32, c: &[f32; N]| {
            for b in 0..N {
                acc[b] += q * c[b];
            }
        };
        if k % 2 == 0 {
            for j in 0..half {
                add(poisson[j * ny + k], &column[j]);
            }
            if ny % 2 == 1 {
                add(poisson[half * ny + k], &column[half]);
            }
        } else {
            for j in 0..half {
                add(poisson[j * ny + k], &column[ny - 1 - j]);
            }
        }
        for b in 0..N {
            s.modes[k * nx + i0 + b] = acc[b] * scale;
        }
    }
}

/// The Thomas sweeps of every mode (as the twin), four modes at a time so that their
/// independent recurrences overlap instead of waiting on each other's latency.
fn pressure_solve(d: &Dim, poisson: &[f32], modes: &mut [f32]) {
    let (nx, ny) = (d.nx, d.ny);
    let dx2 = d.p.dx * d.p.dx;
    let (c_at, m_at) = (ny * ny, ny * ny + ny * nx);
    let mut k0 = 0;
    while k0 < ny {
        let lanes = (ny - k0).min(4);
        let mut prev = [0.0f32; 4];
        for i in 0..nx {
            for (l, prev) in prev[..lanes].iter_mut().enumerate() {
                let k = k0 + l;
                let y = (modes[k * nx + i] * dx2 - *prev) * poisson[m_at + k * nx + i];
                modes[k * nx + i] = y;
                *prev = y;
            }
        }
        let mut next = [0.0f32; 4];
        for i in (0..nx).rev() {
            for (l, next) in next[..lanes].iter_mut().enumerate() {
                let k = k0 + l;
                let y = modes[k * nx + i] - poisson[c_at + k * nx + i] * *next;
                modes[k * nx + i] = y;
                *next = y;
            }
        }
        k0 += lanes;
    }
}

/// Pressure from its modes, then the velocity correction of s.u_out / s.v_out (as the twin).
fn project(d: &Dim, poisson: &[f32], s: &mut Scratch) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let scale = p.dt / p.rho;
    let full = nx / BLOCK * BLOCK;
    for i0 in (0..full).step_by(BLOCK) {
        back_columns::<BLOCK>(d, poisson, s, i0);
    }
    for i0 in full..nx {
        back_columns::<1>(d, poisson, s, i0);
    }
    let pres = &s.p;
    let row = nx + 1;
    for j in 0..ny {
        for i in 1..=nx {
            let left = pres[j * nx + i - 1];
            let right = if i == nx { -left } else { pres[j * nx + i] };
            s.u_out[j * row + i] -= scale * (right - left) / p.dx;
        }
    }
    for j in 1..ny {
        for i in 0..nx {
            s.v_out[j * nx + i] -= scale * (pres[j * nx + i] - pres[(j - 1) * nx + i]) / p.dy;
        }
    }
}

/// The pressure of columns i0 .. i0 + N from their modes: even and odd mode sums give a row
/// and its mirror (as the twin's `pressure_back`).
#[inline(always)]
fn back_columns<const N: usize>(d: &Dim, poisson: &[f32], s: &mut Scratch, i0: usize) {
    let (nx, ny) = (d.nx, d.ny);
    let mut mode = [[0.0f32; N]; 64];
    for (k, m) in mode[..ny].iter_mut().enumerate() {
        m.copy_from_slice(&s.modes[k * nx + i0..k * nx + i0 + N]);
    }
    for j in 0..ny.div_ceil(2) {
        let q = &poisson[j * ny..(j + 1) * ny];
        let mut even = [0.0f32; N];
        for k in (0..ny).step_by(2) {
            for b in 0..N {
                even[b] += q[k] * mode[k][b];
            }
        }
        let mut odd = [0.0f32; N];
        for k in (1..ny).step_by(2) {
            for b in 0..N {
                odd[b] += q[k] * mode[k][b];
            }
        }
        let mirror = ny - 1 - j;
        for b in 0..N {
            if mirror == j {
                s.p[j * nx + i0 + b] = even[b];
            } else {
                s.p[j * nx + i0 + b] = even[b] + odd[b];
                s.p[mirror * nx + i0 + b] = even[b] - odd[b];
            }
        }
    }
}

/// The body field from the members, as [`cpu::paint_bodies`], visiting only the cells near
/// each environment's swarm box (the twin tests every cell against the box; the same test
/// decides here, so the result is the same).
fn paint_bodies(d: &Dim, members: &[GpuMember], boxes: &[[f32; 4]], body: &mut Vec<[f32; 4]>) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let n = p.n_members as usize;
    let reach = p.radius + p.dx;
    body.clear();
    body.resize(p.n_env as usize * nx * ny, [0.0; 4]);
    for (e, bx) in boxes.iter().enumerate() {
        // Cell centres (i + 1/2) dx inside [bx0 - reach, bx1 + reach] lie in this index range
        // (one cell of margin either side for rounding).
        let range = |lo: f32, hi: f32, h: f32, n: usize| {
            let a = floor_i32(lo / h - 0.5) - 1;
            let b = floor_i32(hi / h - 0.5) + 2;
            (a.clamp(0, n as i32) as usize, b.clamp(0, n as i32) as usize)
        };
        let (i_lo, i_hi) = range(bx[0] - reach, bx[1] + reach, p.dx, nx);
        let (j_lo, j_hi) = range(bx[2] - reach, bx[3] + reach, p.dy, ny);
        let swarm = &members[e * n..(e + 1) * n];
        for j in j_lo..j_hi {
            for i in i_lo..i_hi {
                let c = [(i as f32 + 0.5) * p.dx, (j as f32 + 0.5) * p.dy];
                if !(c[0] >= bx[0] - reach
                    && c[0] <= bx[1] + reach
                    && c[1] >= bx[2] - reach
                    && c[1] <= bx[3] + reach)
                {
                    continue;
                }
                let mut cell = [0.0f32; 4];
                for mem in swarm {
                    let dist = (c[0] - mem.pos[0]).hypot(c[1] - mem.pos[1]);
                    let chi = (0.5 + (p.radius - dist) * p.inv_dx).clamp(0.0, 1.0);
                    if chi > cell[0] {
                        cell = [chi, mem.vel[0], mem.vel[1], 0.0];
                    }
                }
                body[(e * ny + j) * nx + i] = cell;
            }
        }
    }
}

/// One control step of every environment of `batch` (inlet [E][S]), equal to
/// [`CpuBatch::step`]: paint, advect, pressure, project, move per substep, then the health.
pub fn step(batch: &mut CpuBatch, inlet: &[f32], scratch: &mut Scratch) -> Vec<EnvHealth> {
    let p = batch.params;
    let (nx, ny, ne) = (p.nx as usize, p.ny as usize, p.n_env as usize);
    let d = Dim { nx, ny, p };
    let s = scratch;
    let sized = |b: &mut Vec<f32>, n: usize| b.resize(n, 0.0);
    sized(&mut s.w_u, d.n_u());
    sized(&mut s.hat_u, d.n_u());
    sized(&mut s.u_out, d.n_u());
    sized(&mut s.w_v, d.n_v());
    sized(&mut s.hat_v, d.n_v());
    sized(&mut s.v_out, d.n_v());
    sized(&mut s.modes, d.n_c());
    sized(&mut s.p, d.n_c());
    sized(&mut s.divstar, nx);
    s.ext_u.resize(d.n_u(), [0.0; 2]);
    s.ext_v.resize(d.n_v(), [0.0; 2]);
    s.vel_u.resize(d.n_u(), [0.0; 2]);
    s.vel_v.resize(d.n_v(), [0.0; 2]);
    let (nu, nv, nc) = (d.n_u(), d.n_v(), d.n_c());
    for sub in 0..p.substeps as usize {
        if p.n_members > 0 {
            paint_bodies(&d, &batch.members, &batch.boxes, &mut batch.body);
        }
        for e in 0..ne {
            let centre = inlet[e * p.substeps as usize + sub];
            let u = &batch.u[e * nu..(e + 1) * nu];
            let v = &batch.v[e * nv..(e + 1) * nv];
            let body = &batch.body[e * nc..(e + 1) * nc];
            advect(&d, batch.scheme, u, v, body, centre, s);
            pressure_rhs(&d, &batch.poisson, s);
            pressure_solve(&d, &batch.poisson, &mut s.modes);
            project(&d, &batch.poisson, s);
            batch.u[e * nu..(e + 1) * nu].copy_from_slice(&s.u_out);
            batch.v[e * nv..(e + 1) * nv].copy_from_slice(&s.v_out);
            batch.p[e * nc..(e + 1) * nc].copy_from_slice(&s.p);
            batch.divstar[e * nx..(e + 1) * nx].copy_from_slice(&s.divstar);
        }
        if p.n_members > 0 {
            let (m, diags, boxes) = cpu::move_members(
                &p,
                &batch.members,
                &batch.actions,
                &batch.p,
                &batch.u,
                &batch.v,
            );
            batch.members = m;
            batch.boxes = boxes;
            s.diags = diags;
        }
    }
    cpu::diagnostics(&p, &batch.u, &batch.v, &batch.p, &batch.divstar)
}

/// A batch stepped natively: one single-environment [`CpuBatch`] per environment, advanced in
/// parallel on the rayon pool, with the clock of `FluidBatch` (time since reset and waveform
/// phase per environment; the inlet of each substep comes from the waveform).
pub struct NativeBatch {
    envs: Vec<(CpuBatch, Scratch)>,
    waveform: Waveform,
    control_dt: f64,
    time_s: Vec<f64>,
    phase_s: Vec<f64>,
}

impl NativeBatch {
    /// Splits `batch` into its environments, each at time 0 and phase 0.
    pub fn new(batch: &CpuBatch, waveform: Waveform, control_dt: f64) -> Self {
        let p = batch.params;
        let (ne, n) = (p.n_env as usize, p.n_members as usize);
        let (nx, ny) = (p.nx as usize, p.ny as usize);
        let (nu, nv, nc) = (ny * (nx + 1), (ny + 1) * nx, ny * nx);
        let envs = (0..ne)
            .map(|e| {
                let one = CpuBatch {
                    params: GpuParams { n_env: 1, ..p },
                    scheme: batch.scheme,
                    poisson: batch.poisson.clone(),
                    u: batch.u[e * nu..(e + 1) * nu].to_vec(),
                    v: batch.v[e * nv..(e + 1) * nv].to_vec(),
                    p: batch.p[e * nc..(e + 1) * nc].to_vec(),
                    body: batch.body[e * nc..(e + 1) * nc].to_vec(),
                    divstar: batch.divstar[e * nx..(e + 1) * nx].to_vec(),
                    members: batch.members[e * n..(e + 1) * n].to_vec(),
                    actions: batch.actions[e * n..(e + 1) * n].to_vec(),
                    boxes: batch.boxes[e..e + 1].to_vec(),
                };
                (one, Scratch::default())
            })
            .collect();
        Self {
            envs,
            waveform,
            control_dt,
            time_s: vec![0.0; ne],
            phase_s: vec![0.0; ne],
        }
    }

    pub fn n_env(&self) -> usize {
        self.envs.len()
    }

    /// Environment e's state.
    pub fn env(&self, e: usize) -> &CpuBatch {
        &self.envs[e].0
    }

    /// Advances every environment by one control step (in parallel) and returns their health.
    pub fn step(&mut self) -> Vec<EnvHealth> {
        let (waveform, control_dt) = (&self.waveform, self.control_dt);
        let inlet: Vec<f32> = self
            .envs
            .iter()
            .zip(self.time_s.iter().zip(&self.phase_s))
            .flat_map(|((env, _), (t, phase))| {
                waveform.substep_values(t + phase, control_dt, env.params.substeps as usize)
            })
            .collect();
        let health = self.step_with_inlet(&inlet);
        for t in &mut self.time_s {
            *t += control_dt;
        }
        health
    }

    /// Advances every environment by one control step with the given inlet centreline
    /// velocities, [E][S] (m/s), without touching the clock (for `FluidBatch`, which keeps its
    /// own).
    pub fn step_with_inlet(&mut self, inlet: &[f32]) -> Vec<EnvHealth> {
        let substeps = self
            .envs
            .first()
            .map_or(0, |e| e.0.params.substeps as usize);
        assert_eq!(inlet.len(), self.envs.len() * substeps, "inlet is [E][S]");
        self.envs
            .par_iter_mut()
            .zip(inlet.par_chunks(substeps.max(1)))
            .map(|((env, scratch), inlet)| step(env, inlet, scratch)[0])
            .collect()
    }

    /// Replaces environment e's state with a single-environment batch of the same shape.
    pub fn replace_env(&mut self, e: usize, env: CpuBatch) {
        assert_eq!(env.params, self.envs[e].0.params, "same grid and members");
        self.envs[e].0 = env;
    }

    /// Sets environment e's raw actions, one per member.
    pub fn set_actions(&mut self, e: usize, actions: &[[f32; 2]]) {
        self.envs[e].0.actions.copy_from_slice(actions);
    }

    /// Forces and pressure samples of environment e's members in the last substep.
    pub fn diags(&self, e: usize) -> &[GpuMemberDiag] {
        &self.envs[e].1.diags
    }
}
