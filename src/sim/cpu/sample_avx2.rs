//! [`super::sample::sample_row`] in AVX2: eight faces at a time, the corners and weights
//! computed in vector registers exactly as the plain code does (the same clamps, the same
//! floor, the same `mix` products and sums, no fused multiply-add), so the samples and extrema
//! have the same bits. Chunks that are not on the fast path are noted and left to the plain
//! chunk after the loop, which thus makes no call and keeps its constants in registers.

use std::arch::x86_64::*;

use super::sample::{Departures, Face, LANES, Padded, Sink, fast_end, sample_chunk, sample_one};
use super::stencil::Dim;

/// `floor_i32` of every lane (in range and finite; a NaN lane gives i32::MIN, which no fast
/// path accepts).
#[target_feature(enable = "avx2")]
#[inline]
fn floor_epi32(f: __m256) -> __m256i {
    let t = _mm256_cvttps_epi32(f);
    let above = _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(t), f);
    _mm256_add_epi32(t, _mm256_castps_si256(above))
}

/// WGSL's `mix`, a (1 - t) + b t, as [`super::stencil::mix`].
#[target_feature(enable = "avx2")]
#[inline]
fn mix(a: __m256, b: __m256, t: __m256) -> __m256 {
    let one = _mm256_set1_ps(1.0);
    _mm256_add_ps(_mm256_mul_ps(a, _mm256_sub_ps(one, t)), _mm256_mul_ps(b, t))
}

/// Eight values from the start of `v`.
#[target_feature(enable = "avx2")]
#[inline]
fn load(v: &[f32]) -> __m256 {
    let v: &[f32; LANES] = v[..LANES].try_into().expect("LANES values");
    // SAFETY: eight readable values, unaligned load.
    unsafe { _mm256_loadu_ps(v.as_ptr()) }
}

/// Eight values to the start of `v`.
#[target_feature(enable = "avx2")]
#[inline]
fn store(v: &mut [f32], x: __m256) {
    let v: &mut [f32; LANES] = (&mut v[..LANES]).try_into().expect("LANES values");
    // SAFETY: eight writable values, unaligned store.
    unsafe { _mm256_storeu_ps(v.as_mut_ptr(), x) }
}

/// As [`super::sample::sample_row`] (callable where AVX2 is known to be present:
/// [`super::simd::avx2`]).
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) fn sample_row(
    d: &Dim,
    a: &Padded,
    face: Face,
    j: usize,
    first: usize,
    len: usize,
    r: &mut Departures,
    mut sink: Sink,
) {
    let p = &d.p;
    let want_extrema = sink.extrema();
    let last_fast = fast_end(d, face);
    let (sx, sy) = (_mm256_set1_ps(p.inv_dx), _mm256_set1_ps(p.inv_dy));
    let (nxf, nyf) = (_mm256_set1_ps(d.nx as f32), _mm256_set1_ps(d.ny as f32));
    let (zero, half) = (_mm256_setzero_ps(), _mm256_set1_ps(0.5));
    let (x_last, y_last) = (
        _mm256_set1_epi32(d.nx as i32 - 1),
        _mm256_set1_epi32(d.ny as i32 - 1),
    );
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let (minus1, izero) = (_mm256_set1_epi32(-1), _mm256_setzero_si256());
    let row_j = _mm256_set1_epi32(j as i32);
    let s = a.stride;
    let mut far = 0;
    let mut n = 0;
    while n + LANES <= len && first + n + LANES <= last_fast {
        let i = first + n;
        let x = load(&r.x[n..]);
        let y = load(&r.y[n..]);
        // f32::clamp(v, 0, hi) for every non-NaN v: max_ps(0, v) keeps v unless 0 > v, and
        // min_ps(hi, .) keeps it unless hi < it (a NaN passes through both).
        let mut fx = _mm256_min_ps(nxf, _mm256_max_ps(zero, _mm256_mul_ps(x, sx)));
        let mut fy = _mm256_min_ps(nyf, _mm256_max_ps(zero, _mm256_mul_ps(y, sy)));
        match face {
            Face::U => fy = _mm256_sub_ps(fy, half),
            Face::V => fx = _mm256_sub_ps(fx, half),
        }
        let (mut ix, mut iy) = (floor_epi32(fx), floor_epi32(fy));
        match face {
            Face::U => ix = _mm256_min_epi32(ix, x_last),
            Face::V => iy = _mm256_min_epi32(iy, y_last),
        }
        let tx = _mm256_sub_ps(fx, _mm256_cvtepi32_ps(ix));
        let ty = _mm256_sub_ps(fy, _mm256_cvtepi32_ps(iy));
        let ox = _mm256_sub_epi32(ix, _mm256_add_epi32(_mm256_set1_epi32(i as i32), lane));
        let oy = _mm256_sub_epi32(iy, row_j);
        let (left, below) = (
            _mm256_cmpeq_epi32(ox, minus1),
            _mm256_cmpeq_epi32(oy, minus1),
        );
        let near = _mm256_and_si256(
            _mm256_or_si256(left, _mm256_cmpeq_epi32(ox, izero)),
            _mm256_or_si256(below, _mm256_cmpeq_epi32(oy, izero)),
        );
        if _mm256_movemask_ps(_mm256_castsi256_ps(near)) != 0xFF {
            r.far[far] = n;
            far += 1;
            n += LANES;
            continue;
        }
        let (left, below) = (_mm256_castsi256_ps(left), _mm256_castsi256_ps(below));
        let base = match face {
            Face::U => a.at_u(i - 1, j as isize - 1),
            Face::V => a.at_v(i as isize - 1, j - 1),
        };
        // Per row q of j - 1, j, j + 1: the stencil's left and right values.
        let pick = |q: usize| {
            let k = base + q * s;
            let c = &a.data[k..];
            let (c0, c1, c2) = (load(c), load(&c[1..]), load(&c[2..]));
            (
                _mm256_blendv_ps(c1, c0, left),
                _mm256_blendv_ps(c2, c1, left),
            )
        };
        let (r0, r1, r2) = (pick(0), pick(1), pick(2));
        let v00 = _mm256_blendv_ps(r1.0, r0.0, below);
        let v10 = _mm256_blendv_ps(r1.1, r0.1, below);
        let v01 = _mm256_blendv_ps(r2.0, r1.0, below);
        let v11 = _mm256_blendv_ps(r2.1, r1.1, below);
        let out = mix(mix(v00, v10, tx), mix(v01, v11, tx), ty);
        store(&mut sink.out[n..], out);
        if want_extrema {
            let (mut lo, mut hi) = (
                _mm256_set1_ps(f32::INFINITY),
                _mm256_set1_ps(f32::NEG_INFINITY),
            );
            for v in [v00, v10, v01, v11] {
                lo = _mm256_min_ps(v, lo);
                hi = _mm256_max_ps(v, hi);
            }
            store(&mut sink.lo[n..], lo);
            store(&mut sink.hi[n..], hi);
        }
        n += LANES;
    }
    for &m in &r.far[..far] {
        sample_chunk(d, a, face, j, first + m, m, r, &mut sink);
    }
    for m in n..len {
        sample_one(d, a, face, m, r, &mut sink);
    }
}
