//! `shaders/pressure_scan.wgsl`: the per-mode tridiagonal solve along x as two parallel scans
//! of affine maps (the GPU variant of [`super::PressureSolve`], same factors and equations),
//! in place on the modes buffer. Grid: (ny, E, 1) workgroups of 256 threads, one per mode.

use super::{Builder, Dims, Entry, FieldBinding::*, Pipeline, Shape, Side};

/// `pressure_scan`: the tridiagonal solve of each mode as two parallel scans.
pub const PRESSURE_SCAN: Entry = Entry {
    name: "pressure_scan",
    file: "pressure_scan.wgsl",
    source: crate::gpu::shaders::PRESSURE_SCAN,
    shape: Shape::Fixed {
        workgroup: [256, 1, 1],
        workgroup_bytes: 2048,
    },
    reads: &[Poisson],
    writes: &[Modes],
};

/// The scan variant of the per-mode tridiagonal solve.
pub struct PressureScan {
    pipeline: Pipeline,
}

impl PressureScan {
    /// Builds the pipeline.
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            pipeline: Pipeline::new(b, &PRESSURE_SCAN),
        }
    }

    /// Records the dispatch, one workgroup per (mode, environment).
    pub fn record(&self, pass: &mut super::Recorder<'_>, bind: Side<'_>, offset: u32, d: Dims) {
        self.pipeline
            .dispatch(pass, bind, offset, [d.ny, d.n_env, 1]);
    }
}
