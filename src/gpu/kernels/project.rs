//! `shaders/project.wgsl`: pressure from the solved modes (one thread per column, grid
//! (ceil(nx/64), E, 1)), then the velocity correction (grid (ceil((nx+1)/64), ny+1, E)).

use super::{Builder, Dims, Entry, FieldBinding::*, Pipeline, Side, groups};

pub const PRESSURE_BACK: Entry = Entry {
    name: "pressure_back",
    file: "project.wgsl",
    source: crate::gpu::shaders::PROJECT,
    workgroup: [64, 1, 1],
    workgroup_bytes: 16384,
    reads: &[Modes, Poisson],
    writes: &[Pressure],
};

pub const PROJECT: Entry = Entry {
    name: "project",
    file: "project.wgsl",
    source: crate::gpu::shaders::PROJECT,
    workgroup: [64, 1, 1],
    workgroup_bytes: 0,
    reads: &[Pressure],
    writes: &[UOut, VOut],
};

pub struct Project {
    back: Pipeline,
    correct: Pipeline,
}

impl Project {
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            back: Pipeline::new(b, &PRESSURE_BACK),
            correct: Pipeline::new(b, &PROJECT),
        }
    }

    pub fn record(&self, pass: &mut super::Recorder<'_>, bind: Side<'_>, offset: u32, d: Dims) {
        self.back
            .dispatch(pass, bind, offset, [groups(d.nx, 64), d.n_env, 1]);
        self.correct.dispatch(
            pass,
            bind,
            offset,
            [groups(d.nx + 1, 64), d.ny + 1, d.n_env],
        );
    }
}
