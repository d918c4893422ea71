//! The driver self-check: a driver that truncates long shader loops (Debian 12's Mesa 22.3
//! lavapipe) is detected and named. CI installs Mesa 25, where this passes.

mod common;

use fluxswarm_gpu::gpu::probe;

#[test]
fn driver_runs_long_loops_in_full() {
    let (_lock, ctx) = common::gpu();
    let trips = probe::loop_trips(&ctx).unwrap();
    if let Some(message) = probe::check_loop_cap(&ctx).unwrap() {
        panic!("{message}");
    }
    assert_eq!(trips, probe::PROBE_TRIPS);
}
