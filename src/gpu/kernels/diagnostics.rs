//! `shaders/diagnostics.wgsl`: per-cross-section statistics, then a per-environment reduction
//! into the health buffer. Grids: (ceil((nx+1)/64), E, 1) and (E, 1, 1).

use super::{Dims, FieldLayout, Pipeline, fluid_module, groups};

pub struct Diagnostics {
    columns: Pipeline,
    reduce: Pipeline,
}

impl Diagnostics {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(device, "diagnostics", crate::gpu::shaders::DIAGNOSTICS);
        Self {
            columns: Pipeline::new(device, layout, &module, "diag_columns"),
            reduce: Pipeline::new(device, layout, &module, "diag_reduce"),
        }
    }

    pub fn record(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: &wgpu::BindGroup,
        offset: u32,
        d: Dims,
    ) {
        self.columns
            .dispatch(pass, bind, offset, [groups(d.nx + 1, 64), d.n_env, 1]);
        self.reduce.dispatch(pass, bind, offset, [d.n_env, 1, 1]);
    }
}
