//! `shaders/pressure_rhs.wgsl`: divergence of the predicted velocity, transformed to the
//! y-cosine modes. Grid: (ceil(nx/64), E, 1), one thread per column.

use super::{Builder, Dims, Entry, FieldBinding::*, Pipeline, Side, groups};

pub const PRESSURE_RHS: Entry = Entry {
    name: "pressure_rhs",
    file: "pressure_rhs.wgsl",
    source: crate::gpu::shaders::PRESSURE_RHS,
    workgroup: [64, 1, 1],
    workgroup_bytes: 16384,
    reads: &[UOut, VOut, Poisson],
    writes: &[Modes, DivStar],
};

pub struct PressureRhs {
    pipeline: Pipeline,
}

impl PressureRhs {
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            pipeline: Pipeline::new(b, &PRESSURE_RHS),
        }
    }

    pub fn record(&self, pass: &mut super::Recorder<'_>, bind: Side<'_>, offset: u32, d: Dims) {
        self.pipeline
            .dispatch(pass, bind, offset, [groups(d.nx, 64), d.n_env, 1]);
    }
}
