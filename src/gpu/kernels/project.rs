//! `shaders/project.wgsl`: pressure from the solved modes and the velocity correction.
//! Grid: (ceil((nx+1)/64), ny+1, E).

use super::{Dims, FieldLayout, Pipeline, fluid_module, groups};

pub struct Project {
    pipeline: Pipeline,
}

impl Project {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(device, "project", crate::gpu::shaders::PROJECT);
        Self {
            pipeline: Pipeline::new(device, layout, &module, "project"),
        }
    }

    pub fn record(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        bind: &wgpu::BindGroup,
        offset: u32,
        d: Dims,
    ) {
        self.pipeline.dispatch(
            pass,
            bind,
            offset,
            [groups(d.nx + 1, 64), d.ny + 1, d.n_env],
        );
    }
}
