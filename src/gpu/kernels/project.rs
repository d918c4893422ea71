//! `shaders/project.wgsl`: pressure from the solved modes (one thread per column, grid
//! (ceil(nx/LANES), E, 1), LANES and the column scratch from the batch's ny: [`Columns`]), then
//! the velocity correction (grid (ceil((nx+1)/64), ny+1, E)).

use super::{Builder, Columns, Dims, Entry, FieldBinding::*, Pipeline, Shape, Side, groups};

/// `pressure_back`: cell pressure (Pa) from the solved y-modes.
pub const PRESSURE_BACK: Entry = Entry {
    name: "pressure_back",
    file: "project.wgsl",
    source: crate::gpu::shaders::PROJECT,
    shape: Shape::Columns,
    reads: &[Modes, Poisson],
    writes: &[Pressure],
};

/// `project`: subtracts dt / rho times the pressure gradient from the predicted velocity.
pub const PROJECT: Entry = Entry {
    name: "project",
    file: "project.wgsl",
    source: crate::gpu::shaders::PROJECT,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[Pressure],
    writes: &[UOut, VOut],
};

/// The projection pipelines of `project.wgsl`, built for the batch's [`Columns`].
pub struct Project {
    back: Pipeline,
    correct: Pipeline,
    columns: Columns,
}

impl Project {
    /// Builds both pipelines for the builder's column layout.
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            back: Pipeline::new(b, &PRESSURE_BACK),
            correct: Pipeline::new(b, &PROJECT),
            columns: b.columns(),
        }
    }

    /// Records the pressure back-transform, then the velocity correction.
    pub fn record(&self, pass: &mut super::Recorder<'_>, bind: Side<'_>, offset: u32, d: Dims) {
        debug_assert!(
            d.ny <= self.columns.max_ny,
            "built for ny <= {}",
            self.columns.max_ny
        );
        self.back.dispatch(
            pass,
            bind,
            offset,
            [groups(d.nx, self.columns.lanes), d.n_env, 1],
        );
        self.correct.dispatch(
            pass,
            bind,
            offset,
            [groups(d.nx + 1, 64), d.ny + 1, d.n_env],
        );
    }
}
