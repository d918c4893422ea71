//! This machine's own peaks, measured, for `bench`'s roofline of the CPU step: arithmetic from
//! an FMA loop, bandwidth from a triad a = b + s c, each run on every rayon thread at once
//! (started together behind a barrier; the rate is the sum of the threads' rates).
//!
//! - FMA: 12 independent accumulators (enough to cover the FMA latency on two ports) of the
//!   widest vectors the CPU has, chosen at run time: AVX-512 (`zmm`, inline assembly, as the
//!   crate's minimum Rust has no stable AVX-512 target feature), AVX2 + FMA (`ymm`, inline
//!   assembly), and the portable loop in plain Rust (a multiply and an add per element,
//!   vectorised for the build target: SSE2 on the default x86-64 target), which is also the
//!   ceiling of code compiled for the baseline target. 2 flops per lane per FMA.
//! - triad: 12 bytes an element (b and c read, a written, the STREAM convention; a write
//!   that misses the cache also reads its line first, which the count leaves out), over
//!   arrays small enough to stay in a core's L2 (in cache) and large enough to miss every
//!   cache level (out of cache), AVX2 code where the CPU has it.
//!
//! Nothing here is assumed: every figure is timed, and the loops' results go through
//! `std::hint::black_box` (the assembly loops have side effects the compiler keeps).

use std::hint::black_box;
use std::sync::Barrier;
use std::time::Instant;

/// The FMA loops, widest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmaKernel {
    /// 512-bit FMA (`vfmadd231ps zmm`).
    Avx512,
    /// 256-bit FMA (`vfmadd231ps ymm`).
    Avx2,
    /// Plain Rust multiply-adds, as the build target vectorises them.
    Portable,
}

impl FmaKernel {
    /// Every FMA loop, widest first.
    pub const ALL: [FmaKernel; 3] = [FmaKernel::Avx512, FmaKernel::Avx2, FmaKernel::Portable];

    /// Human-readable name of the loop.
    pub fn name(self) -> &'static str {
        match self {
            FmaKernel::Avx512 => "avx512 fma",
            FmaKernel::Avx2 => "avx2 fma",
            FmaKernel::Portable => "portable mul+add (build target)",
        }
    }

    /// Whether this CPU runs it.
    pub fn available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            FmaKernel::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(target_arch = "x86_64")]
            FmaKernel::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            FmaKernel::Portable => true,
            #[allow(unreachable_patterns)] // other architectures
            _ => false,
        }
    }

    /// Flops of one iteration of the loop.
    fn flops_per_iter(self) -> u64 {
        let lanes = match self {
            FmaKernel::Avx512 => 16,
            FmaKernel::Avx2 => 8,
            FmaKernel::Portable => 4,
        };
        ACCUMULATORS * lanes * 2
    }

    /// `iters` iterations; returns a value that depends on all of them.
    fn run(self, iters: u64) -> f32 {
        match self {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the CPU has the instructions (`available`, checked by the caller).
            FmaKernel::Avx512 => unsafe { x86::fma_zmm(iters) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            FmaKernel::Avx2 => unsafe { x86::fma_ymm(iters) },
            _ => portable_fma(iters),
        }
    }
}

const ACCUMULATORS: u64 = 12;

/// 12 accumulators of 4 lanes, acc = acc m + a (m = 1, a small: no overflow, no denormals).
fn portable_fma(iters: u64) -> f32 {
    let mut acc = [[0.0f32; 4]; ACCUMULATORS as usize];
    let (m, a) = (black_box(1.0f32), black_box(1e-7f32));
    for _ in 0..iters {
        for v in &mut acc {
            for x in v {
                *x = *x * m + a;
            }
        }
    }
    black_box(acc).iter().flatten().sum()
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::asm;

    /// Expands to the FMA loop over registers of the given width: 12 accumulators
    /// (register 0 to 11), the factors in 12 and 13, reduced into register 0 and stored.
    macro_rules! fma_loop {
        ($r:literal, $iters:expr) => {{
            let (m, a) = (1.0f32, 1e-7f32);
            let mut out = [0.0f32; 16];
            // SAFETY: reads m and a, writes 64 bytes of `out` at most; every vector register
            // it touches (0 to 15, their upper halves by vzeroupper) is declared clobbered;
            // the caller checked the instruction set.
            unsafe {
                asm!(
                    concat!("vbroadcastss ", $r, "12, dword ptr [{m}]"),
                    concat!("vbroadcastss ", $r, "13, dword ptr [{a}]"),
                    "vxorps xmm0, xmm0, xmm0",
                    "vxorps xmm1, xmm1, xmm1",
                    "vxorps xmm2, xmm2, xmm2",
                    "vxorps xmm3, xmm3, xmm3",
                    "vxorps xmm4, xmm4, xmm4",
                    "vxorps xmm5, xmm5, xmm5",
                    "vxorps xmm6, xmm6, xmm6",
                    "vxorps xmm7, xmm7, xmm7",
                    "vxorps xmm8, xmm8, xmm8",
                    "vxorps xmm9, xmm9, xmm9",
                    "vxorps xmm10, xmm10, xmm10",
                    "vxorps xmm11, xmm11, xmm11",
                    "2:",
                    concat!("vfmadd231ps ", $r, "0, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "1, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "2, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "3, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "4, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "5, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "6, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "7, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "8, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "9, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "10, ", $r, "12, ", $r, "13"),
                    concat!("vfmadd231ps ", $r, "11, ", $r, "12, ", $r, "13"),
                    "dec {n}",
                    "jnz 2b",
                    concat!("vaddps ", $r, "0, ", $r, "0, ", $r, "11"),
                    concat!("vaddps ", $r, "0, ", $r, "0, ", $r, "6"),
                    concat!("vmovups [{out}], ", $r, "0"),
                    "vzeroupper",
                    m = in(reg) &m as *const f32,
                    a = in(reg) &a as *const f32,
                    out = in(reg) out.as_mut_ptr(),
                    n = inout(reg) $iters.max(1) => _,
                    out("xmm0") _, out("xmm1") _, out("xmm2") _, out("xmm3") _,
                    out("xmm4") _, out("xmm5") _, out("xmm6") _, out("xmm7") _,
                    out("xmm8") _, out("xmm9") _, out("xmm10") _, out("xmm11") _,
                    out("xmm12") _, out("xmm13") _,
                    // vzeroupper clears the upper halves of these two as well
                    out("xmm14") _, out("xmm15") _,
                    options(nostack),
                );
            }
            out.iter().sum::<f32>()
        }};
    }

    /// # Safety
    /// The CPU must have AVX-512F.
    pub unsafe fn fma_zmm(iters: u64) -> f32 {
        fma_loop!("zmm", iters)
    }

    /// # Safety
    /// The CPU must have AVX2 and FMA.
    pub unsafe fn fma_ymm(iters: u64) -> f32 {
        fma_loop!("ymm", iters)
    }

    /// The triad compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn triad_avx2(a: &mut [f32], b: &[f32], c: &[f32], s: f32) {
        super::triad_body(a, b, c, s)
    }
}

/// Runs `work(thread, stop_after_s)` on every rayon thread at once, each returning
/// (units done, seconds taken); the sum of their rates (units per second).
fn on_all_threads(work: impl Fn(usize) -> (f64, f64) + Sync) -> f64 {
    let barrier = Barrier::new(rayon::current_num_threads());
    rayon::broadcast(|ctx| {
        barrier.wait();
        let (units, secs) = work(ctx.index());
        units / secs.max(1e-9)
    })
    .into_iter()
    .sum()
}

/// GFlop/s of the FMA loop on all threads for about `seconds`; `None` where the CPU lacks it.
pub fn fma_gflops(kernel: FmaKernel, seconds: f64) -> Option<f64> {
    if !kernel.available() {
        return None;
    }
    let chunk = 200_000u64;
    kernel.run(chunk); // warm-up (clock ramp, wider units powered up)
    Some(on_all_threads(|_| {
        let start = Instant::now();
        let mut iters = 0u64;
        let mut sink = 0.0f32;
        while iters == 0 || start.elapsed().as_secs_f64() < seconds {
            sink += kernel.run(chunk);
            iters += chunk;
        }
        black_box(sink);
        let secs = start.elapsed().as_secs_f64();
        ((iters * kernel.flops_per_iter()) as f64 / 1e9, secs)
    }))
}

#[inline(always)]
fn triad_body(a: &mut [f32], b: &[f32], c: &[f32], s: f32) {
    for ((x, y), z) in a.iter_mut().zip(b).zip(c) {
        *x = y + s * z;
    }
}

/// The triad code that runs here: AVX2 where the CPU has it, the build target's otherwise.
pub fn triad_kernel() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        return "avx2";
    }
    "build target"
}

fn triad(a: &mut [f32], b: &[f32], c: &[f32], s: f32) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        return unsafe { x86::triad_avx2(a, b, c, s) };
    }
    triad_body(a, b, c, s)
}

/// GB/s of the triad on all threads, each over its own three arrays of `floats` f32, after a
/// first pass that faults the pages in, for about `seconds` (at least two passes each).
pub fn triad_gb_per_s(floats: usize, seconds: f64) -> f64 {
    let floats = floats.max(16);
    on_all_threads(|t| {
        let (mut a, b, c) = (
            vec![0.0f32; floats],
            vec![1.0f32 + t as f32; floats],
            vec![2.0f32; floats],
        );
        let s = black_box(0.5f32);
        triad(&mut a, &b, &c, s);
        let start = Instant::now();
        let mut passes = 0u64;
        while passes < 2 || start.elapsed().as_secs_f64() < seconds {
            triad(black_box(&mut a), black_box(&b), black_box(&c), s);
            passes += 1;
        }
        let secs = start.elapsed().as_secs_f64();
        black_box(&a);
        ((passes * floats as u64 * 12) as f64 / 1e9, secs)
    })
}

/// Array sizes and the time of each measurement.
#[derive(Debug, Clone, Copy)]
pub struct PeakSizes {
    /// Each of a thread's three in-cache arrays (bytes).
    pub in_cache_array: usize,
    /// Each of the three out-of-cache arrays, over all threads together (bytes).
    pub out_of_cache_array: usize,
    /// Seconds per measurement (per FMA kernel, per triad).
    pub seconds: f64,
}

impl Default for PeakSizes {
    /// 3 x 64 KiB a thread (beyond a 48 KiB L1, well inside a 1-2 MiB L2), 3 x 256 MiB in all
    /// (three times an L3 of 260 MiB), 0.2 s each.
    fn default() -> Self {
        Self {
            in_cache_array: 64 << 10,
            out_of_cache_array: 256 << 20,
            seconds: 0.2,
        }
    }
}

/// This machine's peaks on all rayon threads.
#[derive(Debug, Clone)]
pub struct Peaks {
    /// Rayon threads the peaks were measured on.
    pub threads: usize,
    /// GFlop/s of every FMA loop this CPU runs, widest first.
    pub fma: Vec<(FmaKernel, f64)>,
    /// Triad GB/s in cache and out of cache, and the code that ran them.
    pub triad_in_cache: f64,
    /// Triad GB/s out of cache.
    pub triad_out_of_cache: f64,
    /// The triad code that ran: `avx2` or `build target`.
    pub triad_kernel: &'static str,
    /// Array sizes and time per measurement used.
    pub sizes: PeakSizes,
}

impl Peaks {
    /// Times the FMA loops and both triads on every rayon thread.
    pub fn measure(sizes: PeakSizes) -> Self {
        let threads = rayon::current_num_threads();
        let fma = FmaKernel::ALL
            .iter()
            .filter_map(|&k| fma_gflops(k, sizes.seconds).map(|g| (k, g)))
            .collect();
        let in_cache = sizes.in_cache_array / 4;
        let out_of_cache = sizes.out_of_cache_array / 4 / threads;
        Self {
            threads,
            fma,
            triad_in_cache: triad_gb_per_s(in_cache, sizes.seconds),
            triad_out_of_cache: triad_gb_per_s(out_of_cache, sizes.seconds),
            triad_kernel: triad_kernel(),
            sizes,
        }
    }

    /// The fastest FMA loop and its GFlop/s.
    pub fn best_fma(&self) -> (FmaKernel, f64) {
        self.fma.iter().copied().fold(
            (FmaKernel::Portable, 0.0),
            |b, k| if k.1 > b.1 { k } else { b },
        )
    }

    /// GFlop/s of the portable loop: the ceiling of code built for the baseline target.
    pub fn portable_fma(&self) -> f64 {
        self.fma
            .iter()
            .find(|k| k.0 == FmaKernel::Portable)
            .map_or(0.0, |k| k.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peaks_are_finite_and_positive() {
        let p = Peaks::measure(PeakSizes {
            in_cache_array: 16 << 10,
            out_of_cache_array: 4 << 20,
            seconds: 0.02,
        });
        assert!(p.threads >= 1);
        assert!(p.fma.iter().any(|k| k.0 == FmaKernel::Portable));
        for (k, g) in &p.fma {
            assert!(g.is_finite() && *g > 0.0, "{k:?}: {g}");
        }
        assert!(p.best_fma().1 >= p.portable_fma() && p.portable_fma() > 0.0);
        for gb in [p.triad_in_cache, p.triad_out_of_cache] {
            assert!(gb.is_finite() && gb > 0.0, "{p:?}");
        }
    }

    #[test]
    fn the_loops_compute_what_they_say() {
        let mut a = vec![0.0f32; 37];
        triad(&mut a, &[1.0; 37], &[2.0; 37], 0.5);
        assert!(a.iter().all(|&x| x == 2.0));
        for k in FmaKernel::ALL.into_iter().filter(|k| k.available()) {
            let lanes = (k.flops_per_iter() / 2 / ACCUMULATORS) as f32;
            let expect = match k {
                FmaKernel::Portable => ACCUMULATORS as f32 * lanes * 3e-7,
                // The reduction adds three of the 12 accumulators into the one stored.
                _ => 3.0 * lanes * 3e-7,
            };
            let got = k.run(3);
            assert!(
                (got - expect).abs() <= 1e-3 * expect,
                "{k:?}: {got} vs {expect}"
            );
        }
    }
}
