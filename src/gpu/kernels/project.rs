//! `shaders/project.wgsl`: pressure from the solved modes (one thread per column, grid
//! (ceil(nx/64), E, 1)), then the velocity correction (grid (ceil((nx+1)/64), ny+1, E)).

use super::{Dims, FieldLayout, Pipeline, fluid_module, groups};

pub struct Project {
    back: Pipeline,
    correct: Pipeline,
}

impl Project {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(device, "project", crate::gpu::shaders::PROJECT);
        Self {
            back: Pipeline::new(device, layout, &module, "pressure_back"),
            correct: Pipeline::new(device, layout, &module, "project"),
        }
    }

    pub fn record(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: &wgpu::BindGroup,
        offset: u32,
        d: Dims,
    ) {
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
