//! Allocator settings for the learner's small tensor work on the CPU, applied at the start of
//! `main` (and of `benches/learner.rs`).
//!
//! glibc's allocator hands every block over 128 KiB (the threshold grows to at most 32 MiB
//! after frees) back to the kernel when it is freed, so each minibatch's activations and
//! gradients (0.1–8 MB tensors) were fresh pages that the kernel had to fault in and zero:
//! about 15 % of an update in `perf`, and a learner update at E = 4 took 1.6x as long
//! (`benches/learner.rs`, with and without `UNTUNED=1`). Raising the mmap and trim
//! thresholds keeps such blocks in the heap for reuse. Elsewhere this does nothing.

/// Largest block (bytes) the allocator keeps in its heap rather than mapping it afresh.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MMAP_THRESHOLD: i32 = 256 << 20;
/// Free heap (bytes) the allocator may keep before returning memory to the kernel.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const TRIM_THRESHOLD: i32 = 1 << 30;

/// Applies the settings above (glibc only).
pub fn keep_freed_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes the allocator's parameters, under its own locks.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
        libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
    }
}
