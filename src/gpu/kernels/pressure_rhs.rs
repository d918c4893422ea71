//! `shaders/pressure_rhs.wgsl`: divergence of the predicted velocity, transformed to the
//! y-cosine modes. Grid: (ceil(nx/LANES), E, 1), one thread per column; LANES and the column
//! scratch follow the batch's ny ([`Columns`]).

use super::{Builder, Columns, Dims, Entry, FieldBinding::*, Pipeline, Shape, Side, groups};

/// `pressure_rhs`: y-cosine modes of rho/dt div u* per column, and each column's divstar.
pub const PRESSURE_RHS: Entry = Entry {
    name: "pressure_rhs",
    file: "pressure_rhs.wgsl",
    source: crate::gpu::shaders::PRESSURE_RHS,
    shape: Shape::Columns,
    reads: &[UOut, VOut, Poisson],
    writes: &[Modes, DivStar],
};

/// The Poisson right-hand-side pipeline, built for the batch's [`Columns`].
pub struct PressureRhs {
    pipeline: Pipeline,
    columns: Columns,
}

impl PressureRhs {
    /// Builds the pipeline for the builder's column layout.
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            pipeline: Pipeline::new(b, &PRESSURE_RHS),
            columns: b.columns(),
        }
    }

    /// Records the dispatch, one thread per column (ny must fit the column layout).
    pub fn record(&self, pass: &mut super::Recorder<'_>, bind: Side<'_>, offset: u32, d: Dims) {
        debug_assert!(
            d.ny <= self.columns.max_ny,
            "built for ny <= {}",
            self.columns.max_ny
        );
        self.pipeline.dispatch(
            pass,
            bind,
            offset,
            [groups(d.nx, self.columns.lanes), d.n_env, 1],
        );
    }
}
