//! The dense kernels of the learner's hand-written networks ([`super::mlp`]): matrix products on
//! f32 slices and an elementwise tanh.
//!
//! - [`matmul`]: C [m, n] (row-major, contiguous) = (C if `accumulate`, else 0) + A [m, k] B [k, n]
//!   (times a scalar in [`matmul_scaled`]),
//!   where A and B are strided views ([`Mat`]) of row-major buffers, so A^T or B^T cost nothing.
//!   It calls the `gemm` crate (the one candle's CPU backend uses), built with its AVX-512
//!   kernels and dispatched at run time to the best the CPU has. Inside a rayon pool of more than
//!   one thread it splits the output over the pool's threads; the sums over k always run in the
//!   same order, so the result does not depend on the number of threads (tested).
//! - [`tanh_inplace`]: tanh(x) = x + x^3 P(x^2) for |x| < 0.625 and 1 - 2 / (e^(2|x|) + 1) beyond
//!   (Cephes' `tanhf`, with its `expf`: e^y = 2^n P(r), n = round(y / ln 2), r = y - n ln 2),
//!   within 3e-7 relative of the exact value (tested), written so that the compiler vectorises it
//!   and compiled for AVX-512 and AVX2 as well, chosen at run time. No fused multiply-adds, so
//!   all three builds round alike.

use gemm::Parallelism;

/// A strided read-only view of a matrix: element (i, j) is `data[i * rs + j * cs]`.
#[derive(Clone, Copy, Debug)]
pub struct Mat<'a> {
    data: &'a [f32],
    rows: usize,
    cols: usize,
    rs: usize,
    cs: usize,
}

impl<'a> Mat<'a> {
    /// The row-major [rows, cols] matrix at the start of `data`.
    pub fn new(data: &'a [f32], rows: usize, cols: usize) -> Self {
        Self::strided(data, rows, cols, cols, 1)
    }

    /// The [rows, cols] matrix with row stride `rs` and column stride `cs`.
    pub fn strided(data: &'a [f32], rows: usize, cols: usize, rs: usize, cs: usize) -> Self {
        if rows > 0 && cols > 0 {
            let last = (rows - 1) * rs + (cols - 1) * cs;
            assert!(
                last < data.len(),
                "a [{rows}, {cols}] view with strides ({rs}, {cs}) needs {} values, has {}",
                last + 1,
                data.len()
            );
        }
        Self {
            data,
            rows,
            cols,
            rs,
            cs,
        }
    }

    /// The transpose (a view of the same values).
    pub fn t(self) -> Self {
        Self {
            rows: self.cols,
            cols: self.rows,
            rs: self.cs,
            cs: self.rs,
            ..self
        }
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }
}

/// C = (C if `accumulate`) + A B for a row-major C [A.rows, B.cols] (`c.len()` must be exactly
/// that). See the module header.
pub fn matmul(c: &mut [f32], a: Mat, b: Mat, accumulate: bool) {
    matmul_scaled(c, a, b, accumulate, 1.0)
}

/// C = (C if `accumulate`) + `scale` A B, as [`matmul`].
pub fn matmul_scaled(c: &mut [f32], a: Mat, b: Mat, accumulate: bool, scale: f32) {
    let (m, k, n) = (a.rows, a.cols, b.cols);
    assert_eq!(
        b.rows, k,
        "inner dimensions: [{m}, {k}] x [{}, {n}]",
        b.rows
    );
    assert_eq!(c.len(), m * n, "the product is [{m}, {n}]");
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        if !accumulate {
            c.fill(0.0);
        }
        return;
    }
    let par = if rayon::current_num_threads() > 1 {
        Parallelism::Rayon(0)
    } else {
        Parallelism::None
    };
    // SAFETY: the views were bounds-checked on construction (every index i rs + j cs with
    // i < rows, j < cols lies inside their slices), C is an exclusive, contiguous [m, n] buffer
    // that cannot alias the shared inputs, and gemm reads and writes only those elements.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            c.as_mut_ptr(),
            1,
            n as isize,
            accumulate,
            a.data.as_ptr(),
            a.cs as isize,
            a.rs as isize,
            b.data.as_ptr(),
            b.cs as isize,
            b.rs as isize,
            1.0,
            scale,
            false,
            false,
            false,
            par,
        );
    }
}

/// The row-major [rows, bias.len()] matrix whose every row is `bias` (the start of a layer's
/// `x W^T + b`, accumulated onto by [`matmul`]), written once (not zeroed first).
pub fn rows_of(bias: &[f32], rows: usize) -> Vec<f32> {
    let mut c = Vec::with_capacity(rows * bias.len());
    for _ in 0..rows {
        c.extend_from_slice(bias);
    }
    c
}

/// e^y for y in [-87, 88] (Cephes `expf`): n = round(y log2 e) by the 1.5 2^23 rounding trick,
/// r = y - n ln 2 in two parts, e^r by a degree-7 polynomial, 2^n from the exponent bits.
#[inline(always)]
fn exp_reduced(y: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    let t = y * std::f32::consts::LOG2_E + MAGIC;
    let n = t - MAGIC;
    let r = y - n * 0.693_359_4 - n * -2.121_944_4e-4;
    let p = (((((1.987_569_1e-4 * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2)
        * r
        + 1.666_666_5e-1)
        * r
        + 0.5)
        * (r * r)
        + r
        + 1.0;
    let n_int = t.to_bits().wrapping_sub(MAGIC.to_bits()) as i32;
    p * f32::from_bits(((n_int + 127) << 23) as u32)
}

#[inline(always)]
fn tanh1(x: f32) -> f32 {
    let ax = x.abs();
    let z = x * x;
    let small =
        ((((-5.704_988_7e-3 * z + 2.063_909e-2) * z - 5.373_971_6e-2) * z + 1.333_144_2e-1) * z
            - 3.333_328e-1)
            * z
            * ax
            + ax;
    // tanh(9) rounds to 1 in f32, so 2|x| is clamped at 18 (NaN passes the clamp).
    let y = if 2.0 * ax > 18.0 { 18.0 } else { 2.0 * ax };
    let large = 1.0 - 2.0 / (exp_reduced(y) + 1.0);
    let t = if ax < 0.625 { small } else { large };
    if x.is_nan() { x } else { t.copysign(x) }
}

#[inline(always)]
fn tanh_slice(xs: &mut [f32]) {
    for x in xs {
        *x = tanh1(*x);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn tanh_avx512(xs: &mut [f32]) {
    tanh_slice(xs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn tanh_avx2(xs: &mut [f32]) {
    tanh_slice(xs)
}

/// x <- tanh(x) elementwise (see the module header).
pub fn tanh_inplace(xs: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F (checked just above).
            return unsafe { tanh_avx512(xs) };
        }
        if is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { tanh_avx2(xs) };
        }
    }
    tanh_slice(xs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(a: Mat, b: Mat) -> Vec<f64> {
        let mut c = vec![0.0f64; a.rows * b.cols];
        for i in 0..a.rows {
            for j in 0..b.cols {
                for p in 0..a.cols {
                    c[i * b.cols + j] +=
                        a.data[i * a.rs + p * a.cs] as f64 * b.data[p * b.rs + j * b.cs] as f64;
                }
            }
        }
        c
    }

    #[test]
    fn products_of_strided_views_match_the_naive_sums() {
        let mut rng = crate::rng::Rng::new(3);
        let mut noise = |n: usize| -> Vec<f32> { (0..n).map(|_| rng.normal() as f32).collect() };
        let (m, k, n) = (37, 19, 23);
        let (a, at, b, bt) = (noise(m * k), noise(k * m), noise(k * n), noise(n * k));
        for (a, b) in [
            (Mat::new(&a, m, k), Mat::new(&b, k, n)),
            (Mat::new(&at, k, m).t(), Mat::new(&bt, n, k).t()),
            (Mat::strided(&a, m, k, k, 1), Mat::new(&bt, n, k).t()),
        ] {
            let want = naive(a, b);
            let mut c = noise(m * n);
            let before = c.clone();
            matmul(&mut c, a, b, false);
            for (x, y) in c.iter().zip(&want) {
                assert!((*x as f64 - y).abs() < 1e-4, "{x} vs {y}");
            }
            let mut acc = before.clone();
            matmul(&mut acc, a, b, true);
            for ((x, y), z) in acc.iter().zip(&want).zip(&before) {
                assert!((*x as f64 - y - *z as f64).abs() < 1e-4);
            }
        }
    }

    #[test]
    fn a_product_does_not_depend_on_the_number_of_threads() {
        let mut rng = crate::rng::Rng::new(4);
        let mut noise = |n: usize| -> Vec<f32> { (0..n).map(|_| rng.normal() as f32).collect() };
        let (m, k, n) = (512, 1024, 256);
        let (a, b) = (noise(m * k), noise(k * n));
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut c = vec![0.0f32; m * n];
                matmul(&mut c, Mat::new(&a, m, k), Mat::new(&b, k, n), false);
                c
            })
        };
        let one = run(1);
        assert_eq!(one, run(2));
        assert_eq!(one, run(4));
    }

    #[test]
    fn tanh_is_within_3e_7_relative_of_the_exact_value() {
        let mut xs: Vec<f32> = (-200_000..=200_000).map(|i| i as f32 * 1e-4).collect();
        xs.extend([
            1e-30,
            -1e-30,
            1e-8,
            0.624_999_9,
            0.625,
            9.0,
            10.0,
            50.0,
            -88.0,
            1e30,
            -1e30,
        ]);
        xs.extend([0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY]);
        let mut got = xs.clone();
        tanh_inplace(&mut got);
        let mut worst = 0.0f64;
        for (x, t) in xs.iter().zip(&got) {
            let want = (*x as f64).tanh();
            let rel = (*t as f64 - want).abs() / want.abs().max(1e-38);
            worst = worst.max(rel);
            assert!(rel <= 3e-7, "tanh({x}) = {t}, exact {want}");
            assert_eq!(
                t.is_sign_negative(),
                x.is_sign_negative(),
                "sign of tanh({x})"
            );
        }
        println!("worst relative error {worst:e}");
        let mut nan = [f32::NAN];
        tanh_inplace(&mut nan);
        assert!(nan[0].is_nan());
        // The vectorised builds round exactly as the plain one.
        let mut plain = xs.clone();
        tanh_slice(&mut plain);
        assert_eq!(
            plain.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            got.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
    }
}
