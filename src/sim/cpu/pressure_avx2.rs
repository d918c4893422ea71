//! Two stages of the pressure solve in AVX2, each with the same IEEE operations in the same
//! order as its plain code (no fused multiply-add), so the same bits:
//! - [`sweep`]: [`super::pressure::solve`]'s Thomas sweeps, eight modes to a register. The modes
//!   and factor tables are stored `[k][i]` (a mode's row along x), and the sweep runs along x,
//!   so a tile of 8 modes x 8 columns is loaded as eight rows, transposed in registers to
//!   eight columns of 8 modes, swept column by column, and transposed back. The groups of eight
//!   modes are swept side by side, so that their recurrences' latencies overlap. Forward
//!   y_i = (r_i dx^2 - y_(i-1)) / m_i with the stored 1/m_i, back y_i = y_i - c'_i y_(i+1).
//! - [`back_block`]: [`super::pressure::back`]'s p = Q p_k for eight columns at a time, four
//!   output rows' even and odd mode sums (eight registers) side by side.
//!
//! Shapes: modes `[ny][nx]`; the factor tables of the solver's table
//! ([`crate::sim::poisson::PoissonTables::to_gpu`], c' and 1/m `[ny][nx]` each) are
//! interleaved once per control step into `[ny / 8][nx][8]` each ([`interleave`]), so a
//! column's eight factors are one load; Q `[ny][ny]` and p `[ny][nx]`.

use std::arch::x86_64::*;

/// Modes to a register.
pub(super) const LANES: usize = 8;

/// The 8 x 8 transpose of `r` (row l of the result holds element l of every input row).
///
/// # Safety
/// The processor must have AVX2 (inlined into [`sweep`], which needs it).
#[inline(always)]
unsafe fn transpose(r: [__m256; LANES]) -> [__m256; LANES] {
    // SAFETY: the caller guarantees AVX2.
    unsafe {
        let t0 = _mm256_unpacklo_ps(r[0], r[1]);
        let t1 = _mm256_unpackhi_ps(r[0], r[1]);
        let t2 = _mm256_unpacklo_ps(r[2], r[3]);
        let t3 = _mm256_unpackhi_ps(r[2], r[3]);
        let t4 = _mm256_unpacklo_ps(r[4], r[5]);
        let t5 = _mm256_unpackhi_ps(r[4], r[5]);
        let t6 = _mm256_unpacklo_ps(r[6], r[7]);
        let t7 = _mm256_unpackhi_ps(r[6], r[7]);
        let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
        let s1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
        let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
        let s3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
        let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
        let s5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
        let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
        let s7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
        [
            _mm256_permute2f128_ps::<0x20>(s0, s4),
            _mm256_permute2f128_ps::<0x20>(s1, s5),
            _mm256_permute2f128_ps::<0x20>(s2, s6),
            _mm256_permute2f128_ps::<0x20>(s3, s7),
            _mm256_permute2f128_ps::<0x31>(s0, s4),
            _mm256_permute2f128_ps::<0x31>(s1, s5),
            _mm256_permute2f128_ps::<0x31>(s2, s6),
            _mm256_permute2f128_ps::<0x31>(s3, s7),
        ]
    }
}

/// The tile of rows k0 .. k0 + 8 and columns i .. i + 8 of the `[ny][nx]` array `a`, as 8
/// columns of 8 modes.
///
/// # Safety
/// The processor must have AVX2 (inlined into [`sweep`], which needs it).
#[inline(always)]
unsafe fn load_tile(a: &[f32], nx: usize, k0: usize, i: usize) -> [__m256; LANES] {
    let row = |l: usize| {
        let v: &[f32; LANES] = a[(k0 + l) * nx + i..][..LANES].try_into().expect("a row");
        // SAFETY: eight readable values, unaligned load.
        unsafe { _mm256_loadu_ps(v.as_ptr()) }
    };
    // SAFETY: the caller guarantees AVX2.
    unsafe {
        transpose([
            row(0),
            row(1),
            row(2),
            row(3),
            row(4),
            row(5),
            row(6),
            row(7),
        ])
    }
}

/// Stores 8 columns of 8 modes as the tile of rows k0 .. k0 + 8, columns i .. i + 8 of `a`.
///
/// # Safety
/// The processor must have AVX2 (inlined into [`sweep`], which needs it).
#[inline(always)]
unsafe fn store_tile(a: &mut [f32], nx: usize, k0: usize, i: usize, cols: [__m256; LANES]) {
    // SAFETY: the caller guarantees AVX2.
    let rows = unsafe { transpose(cols) };
    for (l, r) in rows.into_iter().enumerate() {
        let v: &mut [f32; LANES] = (&mut a[(k0 + l) * nx + i..][..LANES])
            .try_into()
            .expect("a row");
        // SAFETY: eight writable values, unaligned store.
        unsafe { _mm256_storeu_ps(v.as_mut_ptr(), r) }
    }
}

/// Eight values from the start of `v`.
///
/// # Safety
/// The processor must have AVX2 (inlined into [`sweep`], which needs it).
#[inline(always)]
unsafe fn load(v: &[f32]) -> __m256 {
    let v: &[f32; LANES] = v[..LANES].try_into().expect("eight values");
    // SAFETY: eight readable values, unaligned load.
    unsafe { _mm256_loadu_ps(v.as_ptr()) }
}

/// The factor tables of the whole groups of eight modes, interleaved for [`sweep`]: 1/m as
/// `[ny / 8][nx][8]` (element l of column i of group g: mode 8 g + l), then c' alike.
/// `tables` is the solver's table, c' at `c_at` and 1/m at `m_at`, each `[ny][nx]`.
pub(super) fn interleave(
    nx: usize,
    ny: usize,
    tables: &[f32],
    (c_at, m_at): (usize, usize),
    out: &mut Vec<f32>,
) {
    let groups = ny / LANES;
    let half = groups * nx * LANES;
    out.resize(2 * half, 0.0);
    let (m_out, c_out) = out.split_at_mut(half);
    for (at, dst) in [(m_at, m_out), (c_at, c_out)] {
        for (g, dst) in dst.chunks_exact_mut(nx * LANES).enumerate() {
            for (l, row) in tables[at + g * LANES * nx..][..LANES * nx]
                .chunks_exact(nx)
                .enumerate()
            {
                for (i, &x) in row.iter().enumerate() {
                    dst[i * LANES + l] = x;
                }
            }
        }
    }
}

/// Lane l of `x` (a register of 8 modes) as an array.
///
/// # Safety
/// The processor must have AVX2 (inlined into [`sweep`], which needs it).
#[inline(always)]
unsafe fn lanes(x: __m256) -> [f32; LANES] {
    let mut out = [0.0f32; LANES];
    // SAFETY: eight writable values, unaligned store.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), x) };
    out
}

/// The forward and back sweeps of the modes of groups g0 .. g0 + G (mode 8 g + l), in place
/// on `modes` `[ny][nx]` (callable where AVX2 is present: [`super::simd::avx2`]). `sweep` holds
/// the tables of [`interleave`]. Columns past the last whole tile of 8 go one at a time.
#[target_feature(enable = "avx2")]
pub(super) fn sweep<const G: usize>(
    nx: usize,
    ny: usize,
    dx2: f32,
    sweep: &[f32],
    g0: usize,
    modes: &mut [f32],
) {
    // SAFETY: this function runs where AVX2 is present (its target feature), which the
    // helpers need.
    unsafe {
        let half = ny / LANES * nx * LANES;
        let (m_inv, c_prime) = sweep.split_at(half);
        let at = |g: usize, i: usize| ((g0 + g) * nx + i) * LANES;
        let whole = nx / LANES * LANES;
        let h = _mm256_set1_ps(dx2);
        let mut prev = [_mm256_setzero_ps(); G];
        for i in (0..whole).step_by(LANES) {
            for (g, prev) in prev.iter_mut().enumerate() {
                let k0 = (g0 + g) * LANES;
                let mut r = load_tile(modes, nx, k0, i);
                for (c, r) in r.iter_mut().enumerate() {
                    let m = load(&m_inv[at(g, i + c)..]);
                    *prev = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(*r, h), *prev), m);
                    *r = *prev;
                }
                store_tile(modes, nx, k0, i, r);
            }
        }
        let mut next = [_mm256_setzero_ps(); G];
        for (g, (prev, next)) in prev.iter().zip(&mut next).enumerate() {
            let (mut y, mut z) = (lanes(*prev), [0.0f32; LANES]);
            let k0 = (g0 + g) * LANES;
            for i in whole..nx {
                for (l, y) in y.iter_mut().enumerate() {
                    let a = (k0 + l) * nx + i;
                    *y = (modes[a] * dx2 - *y) * m_inv[at(g, i) + l];
                    modes[a] = *y;
                }
            }
            for i in (whole..nx).rev() {
                for (l, z) in z.iter_mut().enumerate() {
                    let a = (k0 + l) * nx + i;
                    *z = modes[a] - c_prime[at(g, i) + l] * *z;
                    modes[a] = *z;
                }
            }
            *next = load(&z);
        }
        for i in (0..whole).step_by(LANES).rev() {
            for (g, next) in next.iter_mut().enumerate() {
                let k0 = (g0 + g) * LANES;
                let mut r = load_tile(modes, nx, k0, i);
                for (c, r) in r.iter_mut().enumerate().rev() {
                    let cp = load(&c_prime[at(g, i + c)..]);
                    *next = _mm256_sub_ps(*r, _mm256_mul_ps(cp, *next));
                    *r = *next;
                }
                store_tile(modes, nx, k0, i, r);
            }
        }
    }
}

/// p = Q p_k for the eight columns i0 .. i0 + 8 (callable where AVX2 is present), as
/// [`super::pressure::back`]'s plain blocks do it: per output row j < ceil(ny / 2), the even
/// and the odd modes' sums, each from zero in mode order, then p_j = even + odd and its mirror
/// p_(ny-1-j) = even - odd (p_j = even for the middle row of an odd height). Four rows at a
/// time, their eight sums side by side. `q` is the solver's table Q `[ny][ny]`.
#[target_feature(enable = "avx2")]
pub(super) fn back_block(
    nx: usize,
    ny: usize,
    q: &[f32],
    modes: &[f32],
    pres: &mut [f32],
    i0: usize,
) {
    const ROWS: usize = 4;
    let rows = ny.div_ceil(2);
    // SAFETY: this function runs where AVX2 is present (its target feature), which the
    // helpers need.
    unsafe {
        let mode = |k: usize| load(&modes[k * nx + i0..]);
        let mut j0 = 0;
        while j0 < rows {
            let at: [usize; ROWS] = std::array::from_fn(|r| (j0 + r).min(rows - 1) * ny);
            let mut even = [_mm256_setzero_ps(); ROWS];
            let mut odd = [_mm256_setzero_ps(); ROWS];
            let mut k = 0;
            while k + 1 < ny {
                let (me, mo) = (mode(k), mode(k + 1));
                for r in 0..ROWS {
                    let (qe, qo) = (q[at[r] + k], q[at[r] + k + 1]);
                    even[r] = _mm256_add_ps(even[r], _mm256_mul_ps(_mm256_set1_ps(qe), me));
                    odd[r] = _mm256_add_ps(odd[r], _mm256_mul_ps(_mm256_set1_ps(qo), mo));
                }
                k += 2;
            }
            if k < ny {
                let me = mode(k);
                for r in 0..ROWS {
                    let qe = _mm256_set1_ps(q[at[r] + k]);
                    even[r] = _mm256_add_ps(even[r], _mm256_mul_ps(qe, me));
                }
            }
            for r in 0..ROWS.min(rows - j0) {
                let j = j0 + r;
                let mirror = ny - 1 - j;
                let mut put = |row: usize, x: __m256| {
                    let v: &mut [f32; LANES] = (&mut pres[row * nx + i0..][..LANES])
                        .try_into()
                        .expect("a row");
                    _mm256_storeu_ps(v.as_mut_ptr(), x)
                };
                if mirror == j {
                    put(j, even[r]);
                } else {
                    put(j, _mm256_add_ps(even[r], odd[r]));
                    put(mirror, _mm256_sub_ps(even[r], odd[r]));
                }
            }
            j0 += ROWS;
        }
    }
}
