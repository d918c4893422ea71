//! The pressure solve of the projection, exact for the channel's matrix (SPEC section 1):
//! - `rhs`: div u* per cell, its column maxima, and the y-cosine modes of rho/dt div u*,
//!   phat = Q^T (rho/dt div u*) per column (Q the orthonormal DCT-II of the wall-Neumann
//!   y-Laplacian, applied through its even/odd symmetry: ny^2/2 multiply-adds per column);
//! - `solve`: per mode k, (L_x + lambda_k) p_k = phat_k by the Thomas sweeps with the
//!   precomputed factors c' and 1/m of [`crate::sim::poisson`] (Neumann inlet, p = 0 on the
//!   outlet face);
//! - `back`: p = Q p_k per column (even and odd mode sums give a row and its mirror).
//!
//! Mirrors `pressure_rhs.wgsl`, `pressure_solve.wgsl` and `pressure_back` in `project.wgsl`.
//! Shapes: u* [ny][nx+1], v* [ny+1][nx], modes and p [ny][nx] (modes[k][i]), divstar [nx],
//! poisson [ny*ny | ny*nx | ny*nx]. Columns are handled `BLOCK` at a time so that their sums
//! run side by side in vector registers, each column's in the same order as the kernels.

use super::stencil::Dim;

/// Columns handled together by the column transforms.
const BLOCK: usize = 8;

/// Largest ny the fixed-size column buffers hold (`domain.ny` is validated against it).
const MAX_NY: usize = crate::config::MAX_NY as usize;

/// Divergence of u*, its column maxima into `divstar`, and the y-cosine modes of rho/dt div u*.
pub(crate) fn rhs(
    d: &Dim,
    poisson: &[f32],
    u: &[f32],
    v: &[f32],
    modes: &mut [f32],
    divstar: &mut [f32],
) {
    let full = d.nx / BLOCK * BLOCK;
    for i0 in (0..full).step_by(BLOCK) {
        rhs_columns::<BLOCK>(d, poisson, u, v, modes, divstar, i0);
    }
    for i0 in full..d.nx {
        rhs_columns::<1>(d, poisson, u, v, modes, divstar, i0);
    }
}

/// [`rhs`] for columns i0 .. i0 + N.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // rows and lanes of parallel arrays, indexed together
fn rhs_columns<const N: usize>(
    d: &Dim,
    poisson: &[f32],
    u: &[f32],
    v: &[f32],
    modes: &mut [f32],
    divstar: &mut [f32],
    i0: usize,
) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let row = nx + 1;
    let half = ny / 2;
    let scale = p.rho / p.dt;
    let mut column = [[0.0f32; N]; MAX_NY];
    let mut dmax = [0.0f32; N];
    for j in 0..ny {
        let (ua, va, vb) = (j * row + i0, j * nx + i0, (j + 1) * nx + i0);
        for b in 0..N {
            let c = (u[ua + b + 1] - u[ua + b]) / p.dx + (v[vb + b] - v[va + b]) / p.dy;
            column[j][b] = c;
            dmax[b] = dmax[b].max(c.abs());
        }
    }
    divstar[i0..i0 + N].copy_from_slice(&dmax);
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
            modes[k * nx + i0 + b] = acc[b] * scale;
        }
    }
}

/// The Thomas sweeps of every mode, in place on `modes`, four modes at a time so that their
/// independent recurrences overlap instead of waiting on each other's latency.
pub(crate) fn solve(d: &Dim, poisson: &[f32], modes: &mut [f32]) {
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

/// The pressure p [ny][nx] from its modes.
pub(crate) fn back(d: &Dim, poisson: &[f32], modes: &[f32], pres: &mut [f32]) {
    let full = d.nx / BLOCK * BLOCK;
    for i0 in (0..full).step_by(BLOCK) {
        back_columns::<BLOCK>(d, poisson, modes, pres, i0);
    }
    for i0 in full..d.nx {
        back_columns::<1>(d, poisson, modes, pres, i0);
    }
}

/// [`back`] for columns i0 .. i0 + N.
#[inline(always)]
fn back_columns<const N: usize>(
    d: &Dim,
    poisson: &[f32],
    modes: &[f32],
    pres: &mut [f32],
    i0: usize,
) {
    let (nx, ny) = (d.nx, d.ny);
    let mut mode = [[0.0f32; N]; MAX_NY];
    for (k, m) in mode[..ny].iter_mut().enumerate() {
        m.copy_from_slice(&modes[k * nx + i0..k * nx + i0 + N]);
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
                pres[j * nx + i0 + b] = even[b];
            } else {
                pres[j * nx + i0 + b] = even[b] + odd[b];
                pres[mirror * nx + i0 + b] = even[b] - odd[b];
            }
        }
    }
}
