//! Which vector instructions the CPU step uses: AVX2 where the processor has it (detected at
//! run time, so one binary runs everywhere), plain Rust otherwise. Both give the same bits:
//! the vector code does the same IEEE operations in the same order (no fused multiply-add),
//! and the tests compare them. `FLUXSWARM_SIMD=portable` forces the plain path (read once).

use std::sync::OnceLock;

/// Whether the step takes its AVX2 path.
pub fn avx2() -> bool {
    static AVX2: OnceLock<bool> = OnceLock::new();
    *AVX2.get_or_init(|| {
        let forced_off = std::env::var("FLUXSWARM_SIMD").is_ok_and(|v| v == "portable");
        !forced_off && detected()
    })
}

/// The name of the path [`avx2`] chose, for run headers and benchmarks.
pub fn path_name() -> &'static str {
    if avx2() { "avx2" } else { "portable" }
}

#[cfg(target_arch = "x86_64")]
fn detected() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

#[cfg(not(target_arch = "x86_64"))]
fn detected() -> bool {
    false
}
