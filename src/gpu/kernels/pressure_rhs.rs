//! `shaders/pressure_rhs.wgsl`: divergence of the predicted velocity, transformed to the
//! y-cosine modes. Grid: (ceil(nx/64), E, 1), one thread per column.

use super::{Dims, FieldLayout, Pipeline, fluid_module, groups};

pub struct PressureRhs {
    pipeline: Pipeline,
}

impl PressureRhs {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(device, "pressure_rhs", crate::gpu::shaders::PRESSURE_RHS);
        Self {
            pipeline: Pipeline::new(device, layout, &module, "pressure_rhs"),
        }
    }

    pub fn record(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: &wgpu::BindGroup,
        offset: u32,
        d: Dims,
    ) {
        self.pipeline
            .dispatch(pass, bind, offset, [groups(d.nx, 64), d.n_env, 1]);
    }
}
