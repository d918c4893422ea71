//! `shaders/members.wgsl`: members painted into the body field before the momentum predictor
//! (grid (ceil(nx/64), ny, E)) and moved after the projection (one workgroup per environment,
//! grid (E, 1, 1)). Recorded only when the batch has members.

use super::{Dims, FieldLayout, Pipeline, fluid_module, groups};

pub struct Members {
    paint: Pipeline,
    step: Pipeline,
}

impl Members {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(device, "members", crate::gpu::shaders::MEMBERS);
        Self {
            paint: Pipeline::new(device, layout, &module, "paint_bodies"),
            step: Pipeline::new(device, layout, &module, "move_members"),
        }
    }

    /// Writes the body field from the members' current positions and velocities.
    pub fn record_paint(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: &wgpu::BindGroup,
        offset: u32,
        d: Dims,
    ) {
        self.paint
            .dispatch(pass, bind, offset, [groups(d.nx, 64), d.ny, d.n_env]);
    }

    /// Samples the projected flow, computes the forces and moves every member one substep.
    pub fn record_move(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: &wgpu::BindGroup,
        offset: u32,
        d: Dims,
    ) {
        self.step.dispatch(pass, bind, offset, [d.n_env, 1, 1]);
    }
}
