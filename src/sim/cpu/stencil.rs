//! The staggered grid of one environment as the CPU stages see it: sizes, the boundary
//! ghosts, bilinear stencils and the scalar helpers every stage shares.
//!
//! Per environment (x fastest): u [ny][nx+1] at (i dx, (j + 1/2) dy), v [ny+1][nx] at
//! ((i + 1/2) dx, j dy), cells and modes [ny][nx]. Ghosts (as `shaders/common.wgsl`): rows -1
//! and ny mirror u with a sign flip (no-slip walls), u's column index is clamped to [0, nx];
//! column -1 mirrors v with a sign flip (inlet v = 0), column nx repeats nx - 1 (outlet zero
//! gradient), v's row index is clamped to [0, ny].

use crate::gpu::params::GpuParams;

/// The sizes and constants of one environment's grid.
#[derive(Clone, Copy)]
pub(crate) struct Dim {
    pub nx: usize,
    pub ny: usize,
    pub p: GpuParams,
}

impl Dim {
    pub fn new(p: &GpuParams) -> Self {
        Self {
            nx: p.nx as usize,
            ny: p.ny as usize,
            p: *p,
        }
    }

    pub fn n_u(&self) -> usize {
        self.ny * (self.nx + 1)
    }
    pub fn n_v(&self) -> usize {
        (self.ny + 1) * self.nx
    }
    pub fn n_c(&self) -> usize {
        self.ny * self.nx
    }

    /// Ghost-mapped u-like value (i clamped to [0, nx]; rows -1 and ny mirror, odd).
    #[inline(always)]
    pub fn fetch_u(&self, a: &[f32], i: i32, j: i32) -> f32 {
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
    pub fn fetch_v(&self, a: &[f32], i: i32, j: i32) -> f32 {
        let jc = j.clamp(0, self.ny as i32) as usize;
        if i < 0 {
            -a[jc * self.nx]
        } else {
            a[jc * self.nx + (i as usize).min(self.nx - 1)]
        }
    }

    /// Bilinear stencil of a u-like field around (x, y): the values at its four corners and
    /// the weights.
    #[inline(always)]
    pub fn stencil_u(&self, a: &[f32], x: f32, y: f32) -> ([f32; 4], [f32; 2]) {
        let (corner, t) = self.corner_u(x, y);
        (self.gather_u(a, corner), t)
    }

    /// As [`Self::stencil_u`] for a v-like field.
    #[inline(always)]
    pub fn stencil_v(&self, a: &[f32], x: f32, y: f32) -> ([f32; 4], [f32; 2]) {
        let (corner, t) = self.corner_v(x, y);
        (self.gather_v(a, corner), t)
    }

    /// Lower-left stored u face (i0, j0) of the stencil around (x, y) (clamped into the
    /// channel) and the fractional position inside it.
    #[inline(always)]
    pub fn corner_u(&self, x: f32, y: f32) -> ([i32; 2], [f32; 2]) {
        let p = &self.p;
        let fx = (x * p.inv_dx).clamp(0.0, p.nx as f32);
        let fy = (y * p.inv_dy).clamp(0.0, p.ny as f32) - 0.5;
        let i0 = floor_i32(fx).min(self.nx as i32 - 1);
        let j0 = floor_i32(fy);
        ([i0, j0], [fx - i0 as f32, fy - j0 as f32])
    }

    /// As [`Self::corner_u`] for v faces.
    #[inline(always)]
    pub fn corner_v(&self, x: f32, y: f32) -> ([i32; 2], [f32; 2]) {
        let p = &self.p;
        let fx = (x * p.inv_dx).clamp(0.0, p.nx as f32) - 0.5;
        let fy = (y * p.inv_dy).clamp(0.0, p.ny as f32);
        let i0 = floor_i32(fx);
        let j0 = floor_i32(fy).min(self.ny as i32 - 1);
        ([i0, j0], [fx - i0 as f32, fy - j0 as f32])
    }

    /// The four values of a u-like stencil from its corner (ghosts mapped off the interior).
    #[inline(always)]
    pub fn gather_u(&self, a: &[f32], [i0, j0]: [i32; 2]) -> [f32; 4] {
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
    pub fn gather_v(&self, a: &[f32], [i0, j0]: [i32; 2]) -> [f32; 4] {
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

    /// Input velocity at u face (i, j): its u and the mean of the four v faces around it.
    #[inline(always)]
    pub fn velocity_at_u_face(&self, u: &[f32], v: &[f32], i: usize, j: usize) -> [f32; 2] {
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
    /// velocity).
    #[inline(always)]
    pub fn trace(&self, u: &[f32], v: &[f32], pos: [f32; 2], v0: [f32; 2], h: f32) -> [f32; 2] {
        if self.p.rk2 == 0 {
            return [pos[0] - h * v0[0], pos[1] - h * v0[1]];
        }
        let mid = [pos[0] - 0.5 * h * v0[0], pos[1] - 0.5 * h * v0[1]];
        let (su, tu) = self.stencil_u(u, mid[0], mid[1]);
        let (sv, tv) = self.stencil_v(v, mid[0], mid[1]);
        let v1 = [bilerp(su, tu), bilerp(sv, tv)];
        [pos[0] - h * v1[0], pos[1] - h * v1[1]]
    }

    pub fn u_pos(&self, i: usize, j: usize) -> [f32; 2] {
        [i as f32 * self.p.dx, (j as f32 + 0.5) * self.p.dy]
    }

    pub fn v_pos(&self, i: usize, j: usize) -> [f32; 2] {
        [(i as f32 + 0.5) * self.p.dx, j as f32 * self.p.dy]
    }
}

/// `x.floor() as i32` without a libm call (the baseline x86-64 target has no rounding
/// instruction): the same value for every finite x in i32's range, and 0 for NaN.
#[inline(always)]
pub(crate) fn floor_i32(x: f32) -> i32 {
    let t = x as i32;
    if (t as f32) > x { t - 1 } else { t }
}

/// WGSL's `mix`: a (1 - t) + b t.
#[inline(always)]
pub(crate) fn mix(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

/// Bilinear blend of the corners [(0,0), (1,0), (0,1), (1,1)] at weights t.
#[inline(always)]
pub(crate) fn bilerp(vals: [f32; 4], t: [f32; 2]) -> f32 {
    mix(
        mix(vals[0], vals[1], t[0]),
        mix(vals[2], vals[3], t[0]),
        t[1],
    )
}

/// (min, max) of a stencil's four values, folded from (+inf, -inf) with `v < m` / `v > m`
/// (NaN values are skipped, as by `f32::min`; the vector path's `min_ps` / `max_ps` take the
/// same choices, so both give the same bits).
#[inline(always)]
pub(crate) fn extrema(vals: [f32; 4]) -> [f32; 2] {
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for v in vals {
        lo = if v < lo { v } else { lo };
        hi = if v > hi { v } else { hi };
    }
    [lo, hi]
}
