//! `shaders/diagnostics.wgsl`: per-cross-section statistics, then a per-environment reduction
//! into the health buffer. Grids: (ceil((nx+1)/64), E, 1) and (E, 1, 1).

use super::{Builder, Dims, Entry, FieldBinding::*, Pipeline, Shape, Side, groups};

/// `diag_columns`: flux, divergence, speed and non-finite count of each cross-section.
pub const DIAG_COLUMNS: Entry = Entry {
    name: "diag_columns",
    file: "diagnostics.wgsl",
    source: crate::gpu::shaders::DIAGNOSTICS,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[UOut, VOut, Pressure],
    writes: &[ColStats],
};

/// `diag_reduce`: reduces the cross-section statistics into each environment's health.
pub const DIAG_REDUCE: Entry = Entry {
    name: "diag_reduce",
    file: "diagnostics.wgsl",
    source: crate::gpu::shaders::DIAGNOSTICS,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 2048,
    },
    reads: &[DivStar, ColStats],
    writes: &[Health],
};

/// The health pipelines of `diagnostics.wgsl`.
pub struct Diagnostics {
    columns: Pipeline,
    reduce: Pipeline,
}

impl Diagnostics {
    /// Builds both pipelines.
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            columns: Pipeline::new(b, &DIAG_COLUMNS),
            reduce: Pipeline::new(b, &DIAG_REDUCE),
        }
    }

    /// Records the column statistics and the per-environment reduction.
    pub fn record(&self, pass: &mut super::Recorder<'_>, bind: Side<'_>, offset: u32, d: Dims) {
        self.columns
            .dispatch(pass, bind, offset, [groups(d.nx + 1, 64), d.n_env, 1]);
        self.reduce.dispatch(pass, bind, offset, [d.n_env, 1, 1]);
    }
}
