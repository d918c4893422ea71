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
//! Shapes: u* `[ny][nx+1]`, v* `[ny+1][nx]`, modes and p `[ny][nx]` (modes`[k][i]`), divstar `[nx]`,
//! poisson [ny*ny | ny*nx | ny*nx]. Columns are handled `BLOCK` at a time so that their sums
//! run side by side in vector registers, each column's in the same order as the kernels; the
//! block's column values live in a scratch of ny x BLOCK. From [`FAST_Y_MIN`] cells across,
//! the dense y-transform (ny^2/2 multiply-adds per column each way) gives way to FFT-based
//! DCT-II / DCT-III (`rustdct`, O(ny log ny)), equal to it within f32 round-off (tested).

use std::sync::Arc;

use rustdct::{Dct2, Dct3, DctPlanner};

use super::stencil::Dim;

/// Columns handled together by the column transforms: four AVX2 registers of independent
/// sums (a block of 8 would wait on one register's add latency at every row), then blocks
/// of 8 and single columns for the rest.
const BLOCK: usize = 32;
const SMALL_BLOCK: usize = 8;
/// Rows of p summed together by the back-transform.
const BACK_ROWS: usize = 4;

/// Divergence of u*, its column maxima into `divstar`, and the y-cosine modes of rho/dt div u*.
/// The y-transforms of tall columns by FFT: DCT-II X_k = sum_j x_j cos(pi k (j + 1/2) / ny)
/// and DCT-III x_j = X_0 / 2 + sum_k>0 X_k cos(pi k (j + 1/2) / ny), scaled by the orthonormal
/// weights c_0 = sqrt(1/ny), c_k = sqrt(2/ny) of Q.
#[derive(Clone)]
pub(crate) struct FastY {
    dct2: Arc<dyn Dct2<f32>>,
    dct3: Arc<dyn Dct3<f32>>,
    weight: Vec<f32>,
    buf: Vec<f32>,
    scratch: Vec<f32>,
}

impl std::fmt::Debug for FastY {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FastY({})", self.weight.len())
    }
}

impl FastY {
    pub(crate) fn new(ny: usize) -> Self {
        let mut planner = DctPlanner::new();
        let (dct2, dct3) = (planner.plan_dct2(ny), planner.plan_dct3(ny));
        let scratch = vec![0.0; dct2.get_scratch_len().max(dct3.get_scratch_len())];
        let weight = (0..ny)
            .map(|k| ((if k == 0 { 1.0 } else { 2.0 }) / ny as f64).sqrt() as f32)
            .collect();
        Self {
            dct2,
            dct3,
            weight,
            buf: vec![0.0; ny],
            scratch,
        }
    }

    fn ny(&self) -> usize {
        self.weight.len()
    }
}

/// Cells across the channel from which the FFT-based y-transforms replace the dense ones
/// (measured: docs/performance.md, "Grid height"; below it the dense sums are as fast or faster).
pub const FAST_Y_MIN: usize = 192;

/// The fast transforms for this grid, if it is tall enough to use them (kept in `slot`).
pub(crate) fn fast_y<'a>(d: &Dim, slot: &'a mut Option<FastY>) -> Option<&'a mut FastY> {
    if d.ny < FAST_Y_MIN {
        return None;
    }
    if slot.as_ref().is_none_or(|f| f.ny() != d.ny) {
        *slot = Some(FastY::new(d.ny));
    }
    slot.as_mut()
}

/// `column` is scratch, resized here to ny x `BLOCK` values; `fast` holds the FFT plans of
/// tall grids.
#[allow(clippy::too_many_arguments)] // inputs, outputs and scratch of the stage
#[inline(always)] // into the step's vector-path instances (`super::simd`)
pub(crate) fn rhs(
    d: &Dim,
    poisson: &[f32],
    u: &[f32],
    v: &[f32],
    modes: &mut [f32],
    divstar: &mut [f32],
    column: &mut Vec<f32>,
    fast: &mut Option<FastY>,
) {
    column.resize(d.ny * BLOCK, 0.0);
    let mut fast = fast_y(d, fast);
    let mut i0 = 0;
    while i0 < d.nx {
        let left = d.nx - i0;
        let (c, m, f) = (&mut *column, poisson, fast.as_deref_mut());
        i0 += if left >= BLOCK {
            rhs_columns::<BLOCK>(d, m, u, v, modes, divstar, c, i0, f);
            BLOCK
        } else if left >= SMALL_BLOCK {
            rhs_columns::<SMALL_BLOCK>(d, m, u, v, modes, divstar, c, i0, f);
            SMALL_BLOCK
        } else {
            rhs_columns::<1>(d, m, u, v, modes, divstar, c, i0, f);
            1
        };
    }
}

/// [`rhs`] for columns i0 .. i0 + N.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // rows and lanes of parallel arrays, indexed together
#[allow(clippy::too_many_arguments)]
fn rhs_columns<const N: usize>(
    d: &Dim,
    poisson: &[f32],
    u: &[f32],
    v: &[f32],
    modes: &mut [f32],
    divstar: &mut [f32],
    scratch: &mut [f32],
    i0: usize,
    fast: Option<&mut FastY>,
) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let row = nx + 1;
    let half = ny / 2;
    let scale = p.rho / p.dt;
    let (column, _) = scratch[..ny * N].as_chunks_mut::<N>();
    let mut dmax = [0.0f32; N];
    for j in 0..ny {
        // Slices of exactly the lengths used, so that the loop has no bounds checks and
        // vectorises (the same division per lane as the kernel, hence the same bits).
        let ur: &[f32; N] = u[j * row + i0 + 1..][..N].try_into().expect("N faces");
        let ul: &[f32; N] = u[j * row + i0..][..N].try_into().expect("N faces");
        let va: &[f32; N] = v[j * nx + i0..][..N].try_into().expect("N faces");
        let vb: &[f32; N] = v[(j + 1) * nx + i0..][..N].try_into().expect("N faces");
        let col = &mut column[j];
        for b in 0..N {
            let c = (ur[b] - ul[b]) / p.dx + (vb[b] - va[b]) / p.dy;
            col[b] = c;
            dmax[b] = dmax[b].max(c.abs());
        }
    }
    divstar[i0..i0 + N].copy_from_slice(&dmax);
    if let Some(f) = fast {
        for b in 0..N {
            for j in 0..ny {
                f.buf[j] = column[j][b];
            }
            f.dct2.process_dct2_with_scratch(&mut f.buf, &mut f.scratch);
            for k in 0..ny {
                modes[k * nx + i0 + b] = f.buf[k] * f.weight[k] * scale;
            }
        }
        return;
    }
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

/// Modes swept side by side: their recurrences' add and multiply latencies overlap.
const SWEEP_LANES: usize = 8;

/// The Thomas sweeps of every mode, in place on `modes`. With `AVX2` (the caller has checked
/// [`super::simd::avx2`]) the whole groups of eight modes go through
/// [`super::pressure_avx2::sweep`], whose interleaved tables `sweep` holds
/// ([`super::pressure_avx2::interleave`]); the other modes, and every mode without AVX2, go
/// `SWEEP_LANES` at a time so that their independent recurrences overlap instead of waiting
/// on each other's latency. Both give the same bits.
#[inline(always)] // into the step's vector-path instances (`super::simd`)
pub(crate) fn solve<const AVX2: bool>(d: &Dim, poisson: &[f32], sweep: &[f32], modes: &mut [f32]) {
    let (nx, ny) = (d.nx, d.ny);
    let dx2 = d.p.dx * d.p.dx;
    #[allow(unused_mut)] // set on x86-64 only
    let mut k0 = 0;
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        use super::pressure_avx2::{LANES, sweep as avx2};
        let groups = ny / LANES;
        // Up to four groups side by side (more would not fit the registers).
        let size = groups.div_ceil(groups.div_ceil(4).max(1));
        let mut g0 = 0;
        while g0 < groups {
            let n = size.min(groups - g0);
            // SAFETY: the caller has checked that the processor has AVX2.
            unsafe {
                match n {
                    1 => avx2::<1>(nx, ny, dx2, sweep, g0, modes),
                    2 => avx2::<2>(nx, ny, dx2, sweep, g0, modes),
                    3 => avx2::<3>(nx, ny, dx2, sweep, g0, modes),
                    _ => avx2::<4>(nx, ny, dx2, sweep, g0, modes),
                }
            }
            g0 += n;
        }
        k0 = groups * LANES;
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = sweep;
    solve_from(d, poisson, k0, modes, dx2);
}

/// The plain sweeps of modes k0 .. ny, `SWEEP_LANES` at a time.
#[inline(always)]
fn solve_from(d: &Dim, poisson: &[f32], mut k0: usize, modes: &mut [f32], dx2: f32) {
    let (nx, ny) = (d.nx, d.ny);
    let (c_at, m_at) = (ny * ny, ny * ny + ny * nx);
    while k0 < ny {
        let lanes = (ny - k0).min(SWEEP_LANES);
        let mut prev = [0.0f32; SWEEP_LANES];
        for i in 0..nx {
            for (l, prev) in prev[..lanes].iter_mut().enumerate() {
                let k = k0 + l;
                let y = (modes[k * nx + i] * dx2 - *prev) * poisson[m_at + k * nx + i];
                modes[k * nx + i] = y;
                *prev = y;
            }
        }
        let mut next = [0.0f32; SWEEP_LANES];
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

/// The pressure p [ny][nx] from its modes (`mode` is scratch, as in [`rhs`]). With `AVX2` (the
/// caller has checked [`super::simd::avx2`]) the whole blocks of eight columns go through
/// [`super::pressure_avx2::back_block`], which gives the same bits.
#[inline(always)] // into the step's vector-path instances (`super::simd`)
pub(crate) fn back<const AVX2: bool>(
    d: &Dim,
    poisson: &[f32],
    modes: &[f32],
    pres: &mut [f32],
    mode: &mut Vec<f32>,
    fast: &mut Option<FastY>,
) {
    if let Some(f) = fast_y(d, fast) {
        return back_fast(d, modes, pres, f);
    }
    mode.resize(d.ny * SMALL_BLOCK, 0.0);
    let full = d.nx / SMALL_BLOCK * SMALL_BLOCK;
    #[allow(unused_mut)] // advanced on x86-64 only
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        for i0 in (0..full).step_by(SMALL_BLOCK) {
            // SAFETY: the caller has checked that the processor has AVX2.
            unsafe { super::pressure_avx2::back_block(d.nx, d.ny, poisson, modes, pres, i0) };
        }
        done = full;
    }
    for i0 in (done..full).step_by(SMALL_BLOCK) {
        back_columns::<SMALL_BLOCK>(d, poisson, modes, pres, mode, i0);
    }
    for i0 in full..d.nx {
        back_columns::<1>(d, poisson, modes, pres, mode, i0);
    }
}

/// [`back`] by the FFT-based DCT-III, column by column.
fn back_fast(d: &Dim, modes: &[f32], pres: &mut [f32], f: &mut FastY) {
    let (nx, ny) = (d.nx, d.ny);
    for i in 0..nx {
        for k in 0..ny {
            let w = if k == 0 {
                2.0 * f.weight[0]
            } else {
                f.weight[k]
            };
            f.buf[k] = modes[k * nx + i] * w;
        }
        f.dct3.process_dct3_with_scratch(&mut f.buf, &mut f.scratch);
        for j in 0..ny {
            pres[j * nx + i] = f.buf[j];
        }
    }
}

/// [`back`] for columns i0 .. i0 + N.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // rows and lanes of parallel arrays, indexed together
fn back_columns<const N: usize>(
    d: &Dim,
    poisson: &[f32],
    modes: &[f32],
    pres: &mut [f32],
    scratch: &mut [f32],
    i0: usize,
) {
    let (nx, ny) = (d.nx, d.ny);
    let (mode, _) = scratch[..ny * N].as_chunks_mut::<N>();
    for (k, m) in mode[..ny].iter_mut().enumerate() {
        m.copy_from_slice(&modes[k * nx + i0..k * nx + i0 + N]);
    }
    // BACK_ROWS output rows at once, so that their sums are independent (the last group
    // repeats its last row where ny / 2 is not a multiple of it).
    let rows = ny.div_ceil(2);
    let mut j0 = 0;
    while j0 < rows {
        let row = |r: usize| (j0 + r).min(rows - 1);
        let mut even = [[0.0f32; N]; BACK_ROWS];
        let mut odd = [[0.0f32; N]; BACK_ROWS];
        for k in (0..ny).step_by(2) {
            for r in 0..BACK_ROWS {
                let q = poisson[row(r) * ny + k];
                for b in 0..N {
                    even[r][b] += q * mode[k][b];
                }
            }
        }
        for k in (1..ny).step_by(2) {
            for r in 0..BACK_ROWS {
                let q = poisson[row(r) * ny + k];
                for b in 0..N {
                    odd[r][b] += q * mode[k][b];
                }
            }
        }
        for r in 0..BACK_ROWS.min(rows - j0) {
            let j = j0 + r;
            let mirror = ny - 1 - j;
            for b in 0..N {
                if mirror == j {
                    pres[j * nx + i0 + b] = even[r][b];
                } else {
                    pres[j * nx + i0 + b] = even[r][b] + odd[r][b];
                    pres[mirror * nx + i0 + b] = even[r][b] - odd[r][b];
                }
            }
        }
        j0 += BACK_ROWS;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::sim::{Grid, batch_params, poisson::PoissonTables};

    /// A grid of 13 x ny cells of 0.1 mm, no swarm.
    fn dim(ny: u32) -> (Dim, Vec<f32>) {
        dim_nx(13, ny)
    }

    /// A grid of nx x ny cells of 0.1 mm (nx at least 11), no swarm.
    fn dim_nx(nx: u32, ny: u32) -> (Dim, Vec<f32>) {
        let sets: Vec<String> = [
            format!("domain.nx={nx}"),
            format!("domain.ny={ny}"),
            format!("domain.length_m={}", nx as f64 * 1e-4),
            format!("domain.height_m={}", ny as f64 * 1e-4),
            "domain.success_x_m=0.0003".into(),
            "domain.failure_x_m=0.001".into(),
            "swarm.count=0".into(),
        ]
        .to_vec();
        let r = Config::load(None, &sets).unwrap();
        let poisson = PoissonTables::new(&Grid::from_config(&r.config)).to_gpu();
        (Dim::new(&batch_params(&r, 1)), poisson)
    }

    fn noise(n: usize, seed: u32) -> Vec<f32> {
        (0..n)
            .map(|k| (((k as u32).wrapping_mul(2654435761) ^ seed) % 2001) as f32 / 1000.0 - 1.0)
            .collect()
    }

    fn max_rel(a: &[f32], b: &[f32]) -> f32 {
        let scale = b.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    /// The FFT transforms equal the dense ones (the WGSL kernels' arithmetic), both ways,
    /// within f32 round-off, from short to the tallest columns; the batch takes them from
    /// `FAST_Y_MIN` cells across.
    #[test]
    fn fast_y_transforms_equal_the_dense_sums() {
        for ny in [20u32, 64, 128, 201, 256] {
            let (d, poisson) = dim(ny);
            let (u, v) = (noise(d.n_u(), 1), noise(d.n_v(), 2));
            let mut column = vec![0.0; d.ny * BLOCK];
            let (mut dense, mut fast) = (vec![0.0; d.n_c()], vec![0.0; d.n_c()]);
            let (mut div_a, mut div_b) = (vec![0.0; d.nx], vec![0.0; d.nx]);
            let mut f = FastY::new(d.ny);
            for i0 in 0..d.nx {
                let (c, m) = (&mut column, &poisson);
                rhs_columns::<1>(&d, m, &u, &v, &mut dense, &mut div_a, c, i0, None);
                rhs_columns::<1>(&d, m, &u, &v, &mut fast, &mut div_b, c, i0, Some(&mut f));
            }
            assert_eq!(div_a, div_b);
            let e = max_rel(&fast, &dense);
            assert!(e < 2e-6, "rhs at ny = {ny}: {e:e}");
            let modes = noise(d.n_c(), 3);
            let (mut pa, mut pb) = (vec![0.0; d.n_c()], vec![0.0; d.n_c()]);
            for i0 in 0..d.nx {
                back_columns::<1>(&d, &poisson, &modes, &mut pa, &mut column, i0);
            }
            back_fast(&d, &modes, &mut pb, &mut f);
            let e = max_rel(&pb, &pa);
            assert!(e < 2e-6, "back at ny = {ny}: {e:e}");
            let taken = fast_y(&d, &mut None).is_some();
            assert_eq!(taken, d.ny >= FAST_Y_MIN, "ny = {ny}");
        }
    }

    /// The AVX2 Thomas sweeps and back-transform give the plain ones' bits, on heights with
    /// whole groups of eight modes, a remainder, or neither (odd and even), and lengths with
    /// and without columns past the last tile or block of eight.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_sweeps_and_back_transform_give_the_plain_bits() {
        if !super::super::simd::avx2() {
            eprintln!("no AVX2 on this processor: only the plain sweeps exist here");
            return;
        }
        let mut sweep = Vec::new();
        for (nx, ny) in [
            (11, 7),
            (16, 8),
            (13, 9),
            (21, 17),
            (40, 32),
            (29, 43),
            (64, 40),
        ] {
            let (d, poisson) = dim_nx(nx, ny);
            let rhs = noise(d.n_c(), nx * ny);
            let (mut plain, mut avx2) = (rhs.clone(), rhs);
            solve::<false>(&d, &poisson, &[], &mut plain);
            let tables = (d.ny * d.ny, d.ny * d.ny + d.ny * d.nx);
            super::super::pressure_avx2::interleave(d.nx, d.ny, &poisson, tables, &mut sweep);
            solve::<true>(&d, &poisson, &sweep, &mut avx2);
            assert!(plain.iter().any(|x| *x != 0.0));
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&avx2), bits(&plain), "sweeps at {nx} x {ny}");
            let (mut p_plain, mut p_avx2) = (vec![0.0; d.n_c()], vec![0.0; d.n_c()]);
            back::<false>(
                &d,
                &poisson,
                &plain,
                &mut p_plain,
                &mut Vec::new(),
                &mut None,
            );
            back::<true>(
                &d,
                &poisson,
                &plain,
                &mut p_avx2,
                &mut Vec::new(),
                &mut None,
            );
            assert!(p_plain.iter().all(|x| x.is_finite() && *x != 0.0));
            assert_eq!(bits(&p_avx2), bits(&p_plain), "back at {nx} x {ny}");
        }
    }
}
