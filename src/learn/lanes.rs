//! The learner's passes over whole gradient vectors, summed in f64 in eight lanes: lane l takes
//! the products of the elements 8 q + l in order, the lanes are added 0 to 7, then the
//! remainder (the last `len % 8` elements) in order. [`dot`] is a . b; [`gram3`] the six dot
//! products of three gradients in one pass; [`combine3`] the weighted sum of three gradients
//! (in f64, rounded to f32) plus an f32 term, written out, with its squared norm.
//!
//! Each has a plain version (the definition) and an AVX2 version written with the intrinsics of
//! the same operations: exact f32 -> f64 conversions, one rounding per product and per sum (no
//! fused multiply-add), in the plain version's order, so both give the same bits (tested). The
//! AVX2 one runs where the CPU has it (detected at run time). (An AVX-512 version was no faster
//! on the 2-core Xeon VM: these passes are bound by the cache, not the arithmetic.)

/// Which build runs: the best the CPU has, or one named (the tests compare them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Path {
    Plain,
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Path {
    /// The best build this CPU runs.
    pub(crate) fn best() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Path::Avx2;
        }
        Path::Plain
    }

    /// Every build this CPU runs, the plain one first.
    #[cfg(test)]
    pub(crate) fn available() -> Vec<Self> {
        let mut all = vec![Path::Plain];
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            all.push(Path::Avx2);
        }
        all
    }
}

/// a . b (see the module header), on the best build.
pub(crate) fn dot(a: &[f32], b: &[f32]) -> f64 {
    dot_on(Path::best(), a, b)
}

pub(crate) fn dot_on(path: Path, a: &[f32], b: &[f32]) -> f64 {
    let len = a.len().min(b.len());
    let (a, b) = (&a[..len], &b[..len]);
    match path {
        Path::Plain => dot_plain(a, b),
        // SAFETY: `path` is one the CPU runs (`Path::best` or `available` chose it).
        #[cfg(target_arch = "x86_64")]
        Path::Avx2 => unsafe { x86::dot_avx2(a, b) },
    }
}

fn dot_plain(a: &[f32], b: &[f32]) -> f64 {
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail = tail_dot(ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            acc[l] += x[l] as f64 * y[l] as f64;
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// The remainder's sum of products, in order (from -0.0, as `Iterator::sum` starts).
fn tail_dot(a: &[f32], b: &[f32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| *x as f64 * *y as f64)
        .sum::<f64>()
}

/// [`dot`] of the pairs (0,0), (0,1), (0,2), (1,1), (1,2), (2,2) of three vectors of one
/// length, in one pass.
pub(crate) fn gram3(a: &[f32], b: &[f32], c: &[f32]) -> [f64; 6] {
    gram3_on(Path::best(), a, b, c)
}

pub(crate) fn gram3_on(path: Path, a: &[f32], b: &[f32], c: &[f32]) -> [f64; 6] {
    assert!(
        a.len() == b.len() && a.len() == c.len(),
        "three vectors of one length"
    );
    let mut acc = [[0.0f64; 8]; 6];
    let full = a.len() / 8 * 8;
    match path {
        Path::Plain => gram3_plain(&a[..full], &b[..full], &c[..full], &mut acc),
        // SAFETY: `path` is one the CPU runs.
        #[cfg(target_arch = "x86_64")]
        Path::Avx2 => unsafe { x86::gram3_avx2(&a[..full], &b[..full], &c[..full], &mut acc) },
    }
    let (ra, rb, rc) = (&a[full..], &b[full..], &c[full..]);
    let pairs = [(ra, ra), (ra, rb), (ra, rc), (rb, rb), (rb, rc), (rc, rc)];
    let mut out = [0.0f64; 6];
    for ((o, acc), (p, q)) in out.iter_mut().zip(&acc).zip(pairs) {
        *o = acc.iter().sum::<f64>() + tail_dot(p, q);
    }
    out
}

/// The lanes of [`gram3`] over whole chunks of eight (`a.len()` a multiple of 8).
fn gram3_plain(a: &[f32], b: &[f32], c: &[f32], acc: &mut [[f64; 8]; 6]) {
    for ((x, y), z) in a
        .chunks_exact(8)
        .zip(b.chunks_exact(8))
        .zip(c.chunks_exact(8))
    {
        for l in 0..8 {
            let (x, y, z) = (x[l] as f64, y[l] as f64, z[l] as f64);
            acc[0][l] += x * x;
            acc[1][l] += x * y;
            acc[2][l] += x * z;
            acc[3][l] += y * y;
            acc[4][l] += y * z;
            acc[5][l] += z * z;
        }
    }
}

/// out = (w0 a + w1 b + w2 c, in f64 in that order, rounded to f32) + e per element (where `e`
/// is given), and out . out as [`dot`] sums it.
pub(crate) fn combine3(out: &mut [f32], g: [&[f32]; 3], w: [f64; 3], e: Option<&[f32]>) -> f64 {
    combine3_on(Path::best(), out, g, w, e)
}

pub(crate) fn combine3_on(
    path: Path,
    out: &mut [f32],
    g: [&[f32]; 3],
    w: [f64; 3],
    e: Option<&[f32]>,
) -> f64 {
    let len = out.len();
    assert!(
        g.iter().all(|g| g.len() == len) && e.is_none_or(|e| e.len() == len),
        "inputs of the output's length"
    );
    let full = len / 8 * 8;
    let mut acc = [0.0f64; 8];
    {
        let (o, g) = (&mut out[..full], g.map(|g| &g[..full]));
        let e = e.map(|e| &e[..full]);
        match path {
            Path::Plain => combine3_plain(o, g, w, e, &mut acc),
            // SAFETY: `path` is one the CPU runs.
            #[cfg(target_arch = "x86_64")]
            Path::Avx2 => unsafe { x86::combine3_avx2(o, g, w, e, &mut acc) },
        }
    }
    let mut tail = -0.0f64;
    for (x, o) in out.iter_mut().enumerate().skip(full) {
        let v = one(g, w, e, x);
        *o = v;
        tail += v as f64 * v as f64;
    }
    acc.iter().sum::<f64>() + tail
}

/// Element `x` of [`combine3`].
#[inline(always)]
fn one(g: [&[f32]; 3], w: [f64; 3], e: Option<&[f32]>, x: usize) -> f32 {
    let s = (w[0] * g[0][x] as f64 + w[1] * g[1][x] as f64 + w[2] * g[2][x] as f64) as f32;
    match e {
        Some(e) => s + e[x],
        None => s,
    }
}

fn combine3_plain(
    out: &mut [f32],
    g: [&[f32]; 3],
    w: [f64; 3],
    e: Option<&[f32]>,
    acc: &mut [f64; 8],
) {
    for q in 0..out.len() / 8 {
        for l in 0..8 {
            let v = one(g, w, e, q * 8 + l);
            out[q * 8 + l] = v;
            acc[l] += v as f64 * v as f64;
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The AVX2 build: eight f64 lanes are two 256-bit registers (lanes 0-3 and 4-7). Every
    //! slice here has a length that is a multiple of 8.
    use std::arch::x86_64::*;

    #[target_feature(enable = "avx2")]
    fn load8(p: &[f32]) -> (__m256d, __m256d) {
        let p = &p[..8];
        // SAFETY: `p` has eight elements.
        unsafe {
            (
                _mm256_cvtps_pd(_mm_loadu_ps(p.as_ptr())),
                _mm256_cvtps_pd(_mm_loadu_ps(p[4..].as_ptr())),
            )
        }
    }

    #[target_feature(enable = "avx2")]
    fn lanes(v: (__m256d, __m256d), acc: &mut [f64; 8]) {
        // SAFETY: `acc` holds eight f64.
        unsafe {
            _mm256_storeu_pd(acc.as_mut_ptr(), v.0);
            _mm256_storeu_pd(acc[4..].as_mut_ptr(), v.1);
        }
    }

    #[target_feature(enable = "avx2")]
    fn mul2(a: (__m256d, __m256d), b: (__m256d, __m256d)) -> (__m256d, __m256d) {
        (_mm256_mul_pd(a.0, b.0), _mm256_mul_pd(a.1, b.1))
    }

    #[target_feature(enable = "avx2")]
    fn add2(a: (__m256d, __m256d), b: (__m256d, __m256d)) -> (__m256d, __m256d) {
        (_mm256_add_pd(a.0, b.0), _mm256_add_pd(a.1, b.1))
    }

    #[target_feature(enable = "avx2")]
    fn zero2() -> (__m256d, __m256d) {
        (_mm256_setzero_pd(), _mm256_setzero_pd())
    }

    #[target_feature(enable = "avx2")]
    pub(super) fn dot_avx2(a: &[f32], b: &[f32]) -> f64 {
        let mut s = zero2();
        for (x, y) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
            s = add2(s, mul2(load8(x), load8(y)));
        }
        let mut acc = [0.0f64; 8];
        lanes(s, &mut acc);
        let full = a.len() / 8 * 8;
        acc.iter().sum::<f64>() + super::tail_dot(&a[full..], &b[full..])
    }

    #[target_feature(enable = "avx2")]
    pub(super) fn gram3_avx2(a: &[f32], b: &[f32], c: &[f32], acc: &mut [[f64; 8]; 6]) {
        let mut s = [zero2(); 6];
        for ((x, y), z) in a
            .chunks_exact(8)
            .zip(b.chunks_exact(8))
            .zip(c.chunks_exact(8))
        {
            let (x, y, z) = (load8(x), load8(y), load8(z));
            s[0] = add2(s[0], mul2(x, x));
            s[1] = add2(s[1], mul2(x, y));
            s[2] = add2(s[2], mul2(x, z));
            s[3] = add2(s[3], mul2(y, y));
            s[4] = add2(s[4], mul2(y, z));
            s[5] = add2(s[5], mul2(z, z));
        }
        for (s, acc) in s.into_iter().zip(acc.iter_mut()) {
            lanes(s, acc);
        }
    }

    #[target_feature(enable = "avx2")]
    pub(super) fn combine3_avx2(
        out: &mut [f32],
        g: [&[f32]; 3],
        w: [f64; 3],
        e: Option<&[f32]>,
        acc: &mut [f64; 8],
    ) {
        let ws = w.map(|w| {
            let v = _mm256_set1_pd(w);
            (v, v)
        });
        let mut s = zero2();
        for q in 0..out.len() / 8 {
            let at = q * 8..q * 8 + 8;
            let t = add2(
                add2(
                    mul2(ws[0], load8(&g[0][at.clone()])),
                    mul2(ws[1], load8(&g[1][at.clone()])),
                ),
                mul2(ws[2], load8(&g[2][at.clone()])),
            );
            let (mut lo, mut hi) = (_mm256_cvtpd_ps(t.0), _mm256_cvtpd_ps(t.1));
            if let Some(e) = e {
                let e = &e[at.clone()];
                // SAFETY: eight elements of `e`.
                unsafe {
                    lo = _mm_add_ps(lo, _mm_loadu_ps(e.as_ptr()));
                    hi = _mm_add_ps(hi, _mm_loadu_ps(e[4..].as_ptr()));
                }
            }
            let o = &mut out[at];
            // SAFETY: eight elements of `out`.
            unsafe {
                _mm_storeu_ps(o.as_mut_ptr(), lo);
                _mm_storeu_ps(o[4..].as_mut_ptr(), hi);
            }
            let v = (_mm256_cvtps_pd(lo), _mm256_cvtps_pd(hi));
            s = add2(s, mul2(v, v));
        }
        lanes(s, acc);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vectors over many scales, with zeros, of length `len`.
    fn noise(rng: &mut crate::rng::Rng, len: usize, s: f64) -> Vec<f32> {
        (0..len)
            .map(|i| {
                if i % 53 == 7 {
                    0.0
                } else {
                    (s * rng.normal() * 10f64.powi((i % 7) as i32 - 3)) as f32
                }
            })
            .collect()
    }

    fn bits(x: &[f32]) -> Vec<u32> {
        x.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn every_build_gives_the_definitions_bits() {
        let paths = Path::available();
        println!("builds on this CPU: {paths:?}");
        let mut rng = crate::rng::Rng::new(6);
        for len in [0usize, 3, 8, 13, 1003, 4096 + 5] {
            let g: Vec<Vec<f32>> = (0..3)
                .map(|k| noise(&mut rng, len, 1.0 + k as f64))
                .collect();
            let e = noise(&mut rng, len, 0.01);
            let w = [0.31f64, -0.07, 0.4];
            // The definitions written out: eight lanes, then the lanes in order, then the rest.
            let lanes = |p: &[f32], q: &[f32]| -> f64 {
                let mut acc = [0.0f64; 8];
                let full = len / 8 * 8;
                for x in 0..full {
                    acc[x % 8] += p[x] as f64 * q[x] as f64;
                }
                let mut s = -0.0f64;
                for a in acc {
                    s += a;
                }
                let mut t = -0.0f64;
                for x in full..len {
                    t += p[x] as f64 * q[x] as f64;
                }
                s + t
            };
            let want_out: Vec<f32> = (0..len)
                .map(|x| {
                    let s = (0..3).map(|m| w[m] * g[m][x] as f64).sum::<f64>() as f32;
                    s + e[x]
                })
                .collect();
            let want_bare: Vec<f32> = (0..len)
                .map(|x| (0..3).map(|m| w[m] * g[m][x] as f64).sum::<f64>() as f32)
                .collect();
            for &path in &paths {
                let d = dot_on(path, &g[0], &g[1]);
                assert_eq!(d.to_bits(), lanes(&g[0], &g[1]).to_bits(), "{path:?} {len}");
                let gram = gram3_on(path, &g[0], &g[1], &g[2]);
                let pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
                for (got, (i, j)) in gram.iter().zip(pairs) {
                    let want = lanes(&g[i], &g[j]);
                    assert_eq!(got.to_bits(), want.to_bits(), "{path:?} {len} ({i},{j})");
                }
                let views = [&g[0][..], &g[1][..], &g[2][..]];
                let mut out = vec![f32::NAN; len];
                let sq = combine3_on(path, &mut out, views, w, Some(&e));
                assert_eq!(bits(&out), bits(&want_out), "{path:?} {len}");
                assert_eq!(sq.to_bits(), lanes(&want_out, &want_out).to_bits());
                let sq = combine3_on(path, &mut out, views, w, None);
                assert_eq!(bits(&out), bits(&want_bare), "{path:?} {len}");
                assert_eq!(sq.to_bits(), lanes(&want_bare, &want_bare).to_bits());
            }
        }
    }
}
