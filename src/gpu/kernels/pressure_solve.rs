//! `shaders/pressure_solve.wgsl`: per-mode tridiagonal (Thomas) solve along x, in place on the
//! modes buffer. Grid: (ceil(ny/16), E, 1).

use super::{Dims, FieldLayout, Pipeline, fluid_module, groups};

pub struct PressureSolve {
    pipeline: Pipeline,
}

impl PressureSolve {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(
            device,
            "pressure_solve",
            crate::gpu::shaders::PRESSURE_SOLVE,
        );
        Self {
            pipeline: Pipeline::new(device, layout, &module, "pressure_solve"),
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
            .dispatch(pass, bind, offset, [groups(d.ny, 16), d.n_env, 1]);
    }
}
