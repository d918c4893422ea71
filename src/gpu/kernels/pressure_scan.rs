//! `shaders/pressure_scan.wgsl`: the per-mode tridiagonal solve along x as two parallel scans
//! of affine maps (the GPU variant of [`super::PressureSolve`], same factors and equations),
//! in place on the modes buffer. Grid: (ny, E, 1) workgroups of 256 threads, one per mode.

use super::{Dims, FieldLayout, Pipeline, fluid_module};

pub struct PressureScan {
    pipeline: Pipeline,
}

impl PressureScan {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(device, "pressure_scan", crate::gpu::shaders::PRESSURE_SCAN);
        Self {
            pipeline: Pipeline::new(device, layout, &module, "pressure_scan"),
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
            .dispatch(pass, bind, offset, [d.ny, d.n_env, 1]);
    }
}
