//! The momentum predictor u* = A(w) of one environment: semi-Lagrangian advection of the
//! diffused velocity w (bilinear, Euler or midpoint backtrace in the input velocity u^n), or
//! MacCormack (forward predictor, backward corrector, clamped to the predictor stencil's
//! extrema), then the inlet profile u(0, y) = 4 U y (H - y) / H^2, v = 0 on the walls, and
//! the Brinkman blend with the body velocity, (1 - chi) w + chi w_body, on each face.
//! Mirrors `shaders/advect.wgsl`. Shapes: u, u_out `[ny][nx+1]`; v, v_out `[ny+1][nx]`;
//! body `[ny][nx]` (chi, u_body, v_body, 0); w and the predictor padded with their ghosts
//! (`sample`). Works a row of faces at a time: departure points from the face
//! velocities, then the row's samples (`sample_row`) straight into the output row (or the
//! predictor and its extrema), then the MacCormack update in place. The Brinkman blend
//! visits only the cells of `solid` (every other cell has chi = 0, where it is the identity).

use std::ops::Range;

use super::diffuse::diffuse;
use super::sample::{Departures, Face, Padded, Sink, sample_row};
use super::stencil::Dim;
use crate::config::Advection;

/// A rectangle of cells, [j][i], outside which every cell is fluid (chi = 0).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct CellRect {
    pub i: Range<usize>,
    pub j: Range<usize>,
}

/// The smallest rectangle holding every cell of `body` with chi != 0 (None: all fluid).
pub(crate) fn solid_extent(d: &Dim, body: &[[f32; 4]]) -> Option<CellRect> {
    let mut rect: Option<CellRect> = None;
    for (cj, cells) in body.chunks_exact(d.nx).enumerate() {
        let solid = |c: &[f32; 4]| c[0] != 0.0;
        let (Some(lo), Some(hi)) = (cells.iter().position(solid), cells.iter().rposition(solid))
        else {
            continue;
        };
        let r = rect.get_or_insert(CellRect {
            i: lo..hi + 1,
            j: cj..cj + 1,
        });
        (r.i.start, r.i.end) = (r.i.start.min(lo), r.i.end.max(hi + 1));
        r.j.end = cj + 1;
    }
    rect
}

/// Reusable buffers of [`advect`], sized for one environment.
#[derive(Debug, Default, Clone)]
pub(crate) struct AdvectScratch {
    /// The diffused input velocity w.
    w_u: Padded,
    w_v: Padded,
    /// MacCormack predictor and its stencil's min and max, per face.
    hat_u: Padded,
    hat_v: Padded,
    lo_u: Vec<f32>,
    hi_u: Vec<f32>,
    lo_v: Vec<f32>,
    hi_v: Vec<f32>,
    row: Departures,
}

/// The MacCormack value clamped to the predictor's stencil extrema; a non-finite value passes
/// unclamped, as in `advect.wgsl`, so a blow-up reaches the health check (for finite values
/// this is `f32::clamp`, which would panic on it).
#[inline(always)]
fn limited(raw: f32, lo: f32, hi: f32) -> f32 {
    if !raw.is_finite() {
        raw
    } else if raw < lo {
        lo
    } else if raw > hi {
        hi
    } else {
        raw
    }
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

/// The momentum predictor u* of one environment into `u_out` / `v_out`; `solid` bounds the
/// cells of `body` with chi != 0 ([`solid_extent`]).
/// `AVX2`: sample with [`super::sample_avx2`] (the caller has checked [`super::simd::avx2`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the stage's inputs and outputs, named as in SPEC 1
pub(crate) fn advect<const AVX2: bool>(
    d: &Dim,
    scheme: Advection,
    u: &[f32],
    v: &[f32],
    body: &[[f32; 4]],
    solid: Option<&CellRect>,
    centre: f32,
    s: &mut AdvectScratch,
    u_out: &mut [f32],
    v_out: &mut [f32],
) {
    let (nx, ny, p) = (d.nx, d.ny, d.p);
    let row = nx + 1;
    diffuse(d, u, v, &mut s.w_u, &mut s.w_v);
    s.row.resize(nx);
    let mac = scheme == Advection::Maccormack;
    if mac {
        predict::<AVX2>(d, u, v, s);
    }
    let r = &mut s.row;
    for j in 0..ny {
        let y = (j as f32 + 0.5) * p.dy;
        u_out[j * row] = 4.0 * centre * y * (p.height - y) / (p.height * p.height);
        let out = &mut u_out[j * row + 1..(j + 1) * row];
        if mac {
            departures_u(d, u, v, j, -p.dt, r);
            sample_row::<AVX2>(d, &s.hat_u, Face::U, j, 1, nx, r, Sink::values(out));
            let at = s.hat_u.at_u(1, j as isize);
            let (hat, w) = (&s.hat_u.data[at..at + nx], &s.w_u.data[at..at + nx]);
            let ext = j * row + 1..(j + 1) * row;
            let (lo, hi) = (&s.lo_u[ext.clone()], &s.hi_u[ext]);
            for n in 0..nx {
                out[n] = limited(hat[n] + 0.5 * (w[n] - out[n]), lo[n], hi[n]);
            }
        } else {
            departures_u(d, u, v, j, p.dt, r);
            sample_row::<AVX2>(d, &s.w_u, Face::U, j, 1, nx, r, Sink::values(out));
        }
    }
    v_out[..nx].fill(0.0);
    v_out[ny * nx..].fill(0.0);
    for j in 1..ny {
        let out = &mut v_out[j * nx..(j + 1) * nx];
        if mac {
            departures_v(d, u, v, j, -p.dt, r);
            sample_row::<AVX2>(d, &s.hat_v, Face::V, j, 0, nx, r, Sink::values(out));
            let at = s.hat_v.at_v(0, j);
            let (hat, w) = (&s.hat_v.data[at..at + nx], &s.w_v.data[at..at + nx]);
            let ext = j * nx..(j + 1) * nx;
            let (lo, hi) = (&s.lo_v[ext.clone()], &s.hi_v[ext]);
            for n in 0..nx {
                out[n] = limited(hat[n] + 0.5 * (w[n] - out[n]), lo[n], hi[n]);
            }
        } else {
            departures_v(d, u, v, j, p.dt, r);
            sample_row::<AVX2>(d, &s.w_v, Face::V, j, 0, nx, r, Sink::values(out));
        }
    }
    if let Some(rect) = solid {
        blend_bodies(d, body, rect, u_out, v_out);
    }
}

/// The MacCormack predictor w^ = A_forward(w) of every face into `s.hat_u` / `s.hat_v` (the
/// inlet faces keep u, the wall faces 0), with its stencil's extrema, and their ghosts.
#[inline(always)]
fn predict<const AVX2: bool>(d: &Dim, u: &[f32], v: &[f32], s: &mut AdvectScratch) {
    let (nx, ny, dt) = (d.nx, d.ny, d.p.dt);
    let row = nx + 1;
    s.hat_u.resize(d, Face::U);
    s.hat_v.resize(d, Face::V);
    for e in [&mut s.lo_u, &mut s.hi_u] {
        e.resize(d.n_u(), 0.0);
    }
    for e in [&mut s.lo_v, &mut s.hi_v] {
        e.resize(d.n_v(), 0.0);
    }
    let r = &mut s.row;
    for j in 0..ny {
        departures_u(d, u, v, j, dt, r);
        let at = s.hat_u.at_u(0, j as isize);
        s.hat_u.data[at] = u[j * row];
        let ext = j * row + 1..(j + 1) * row;
        let sink = Sink::with_extrema(
            &mut s.hat_u.data[at + 1..at + 1 + nx],
            &mut s.lo_u[ext.clone()],
            &mut s.hi_u[ext],
        );
        sample_row::<AVX2>(d, &s.w_u, Face::U, j, 1, nx, r, sink);
    }
    s.hat_u.fill_ghosts_u(d);
    for j in [0, ny] {
        let at = s.hat_v.at_v(0, j);
        s.hat_v.data[at..at + nx].fill(0.0);
    }
    for j in 1..ny {
        departures_v(d, u, v, j, dt, r);
        let at = s.hat_v.at_v(0, j);
        let ext = j * nx..(j + 1) * nx;
        let sink = Sink::with_extrema(
            &mut s.hat_v.data[at..at + nx],
            &mut s.lo_v[ext.clone()],
            &mut s.hi_v[ext],
        );
        sample_row::<AVX2>(d, &s.w_v, Face::V, j, 0, nx, r, sink);
    }
    s.hat_v.fill_ghosts_v(d);
}

/// The Brinkman blend of every face next to a cell of `rect`, in place.
fn blend_bodies(d: &Dim, body: &[[f32; 4]], rect: &CellRect, u_out: &mut [f32], v_out: &mut [f32]) {
    let (nx, ny) = (d.nx, d.ny);
    let row = nx + 1;
    for j in rect.j.clone() {
        for i in rect.i.start.max(1)..=rect.i.end.min(nx) {
            let a = body[j * nx + i - 1];
            let b = body[j * nx + i.min(nx - 1)];
            let k = j * row + i;
            u_out[k] = brinkman(u_out[k], a[0], a[1], b[0], b[1]);
        }
    }
    for j in rect.j.start.max(1)..=rect.j.end.min(ny - 1) {
        for i in rect.i.clone() {
            let a = body[(j - 1) * nx + i];
            let b = body[j * nx + i];
            let k = j * nx + i;
            v_out[k] = brinkman(v_out[k], a[0], a[2], b[0], b[2]);
        }
    }
}

/// Departure points (into r.x, r.y) of u faces 1..=nx of row j after a step h, from their
/// velocities (u, and the mean of the four v faces around), as `trace` per face (the Euler
/// loop runs over whole rows, which the compiler vectorises).
#[inline(always)]
fn departures_u(d: &Dim, u: &[f32], v: &[f32], j: usize, h: f32, r: &mut Departures) {
    let (nx, p) = (d.nx, &d.p);
    let y = (j as f32 + 0.5) * p.dy;
    let base = j * (nx + 1);
    if p.rk2 == 0 {
        let (below, above) = (&v[j * nx..(j + 1) * nx], &v[(j + 1) * nx..(j + 2) * nx]);
        let along = &u[base + 1..base + nx];
        let (xs, ys) = (&mut r.x[..nx - 1], &mut r.y[..nx - 1]);
        for n in 0..nx - 1 {
            let sum = below[n] + below[n + 1] + above[n] + above[n + 1];
            xs[n] = (n as i32 + 1) as f32 * p.dx - h * along[n]; // i32: a vector conversion
            ys[n] = y - h * (0.25 * sum);
        }
    } else {
        for i in 1..nx {
            let k = j * nx + i - 1;
            let sum = v[k] + v[k + 1] + v[k + nx] + v[k + nx + 1];
            let vel = [u[base + i], 0.25 * sum];
            [r.x[i - 1], r.y[i - 1]] = d.trace(u, v, d.u_pos(i, j), vel, h);
        }
    }
    let vel = d.velocity_at_u_face(u, v, nx, j);
    [r.x[nx - 1], r.y[nx - 1]] = d.trace(u, v, d.u_pos(nx, j), vel, h);
}

/// Departure points of v faces 0..nx of row j (as [`departures_u`]).
#[inline(always)]
fn departures_v(d: &Dim, u: &[f32], v: &[f32], j: usize, h: f32, r: &mut Departures) {
    let (nx, p) = (d.nx, &d.p);
    let row = nx + 1;
    let y = j as f32 * p.dy;
    let (below, above) = (&u[(j - 1) * row..j * row], &u[j * row..(j + 1) * row]);
    let along = &v[j * nx..(j + 1) * nx];
    if p.rk2 == 0 {
        let (xs, ys) = (&mut r.x[..nx], &mut r.y[..nx]);
        for n in 0..nx {
            let sum = below[n] + below[n + 1] + above[n] + above[n + 1];
            xs[n] = (n as i32 as f32 + 0.5) * p.dx - h * (0.25 * sum);
            ys[n] = y - h * along[n];
        }
    } else {
        for i in 0..nx {
            let sum = below[i] + below[i + 1] + above[i] + above[i + 1];
            let vel = [0.25 * sum, along[i]];
            [r.x[i], r.y[i]] = d.trace(u, v, d.v_pos(i, j), vel, h);
        }
    }
}
