//! `shaders/pressure_solve.wgsl`: per-mode tridiagonal (Thomas) solve along x, in place on the
//! modes buffer. Grid: (ceil(ny/16), E, 1).

use super::{Builder, Dims, Entry, FieldBinding::*, Pipeline, Shape, Side, groups};

/// `pressure_solve`: Thomas sweeps of each mode's tridiagonal system along x.
pub const PRESSURE_SOLVE: Entry = Entry {
    name: "pressure_solve",
    file: "pressure_solve.wgsl",
    source: crate::gpu::shaders::PRESSURE_SOLVE,
    shape: Shape::Fixed {
        workgroup: [16, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[Poisson],
    writes: &[Modes],
};

/// The sequential (Thomas) variant of the per-mode tridiagonal solve.
pub struct PressureSolve {
    pipeline: Pipeline,
}

impl PressureSolve {
    /// Builds the pipeline.
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            pipeline: Pipeline::new(b, &PRESSURE_SOLVE),
        }
    }

    /// Records the dispatch, one thread per (mode, environment).
    pub fn record(&self, pass: &mut super::Recorder<'_>, bind: Side<'_>, offset: u32, d: Dims) {
        self.pipeline
            .dispatch(pass, bind, offset, [groups(d.ny, 16), d.n_env, 1]);
    }
}
