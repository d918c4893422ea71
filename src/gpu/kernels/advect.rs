//! `shaders/advect.wgsl`: momentum predictor (diffusion, then advection + boundary values +
//! Brinkman). Semi-Lagrangian: diffuse and advect, two dispatches; MacCormack: diffuse,
//! predict and correct, three. Grid: (ceil((nx+1)/64), ny+1, E).

use super::{Dims, FieldLayout, Pipeline, fluid_module, groups};
use crate::config::Advection;

pub struct Advect {
    diffuse: Pipeline,
    semi_lagrangian: Pipeline,
    predict: Pipeline,
    correct: Pipeline,
}

impl Advect {
    pub fn new(device: &wgpu::Device, layout: &FieldLayout) -> Self {
        let module = fluid_module(device, "advect", crate::gpu::shaders::ADVECT);
        Self {
            diffuse: Pipeline::new(device, layout, &module, "diffuse"),
            semi_lagrangian: Pipeline::new(device, layout, &module, "advect_diffuse"),
            predict: Pipeline::new(device, layout, &module, "advect_predict"),
            correct: Pipeline::new(device, layout, &module, "maccormack_correct"),
        }
    }

    pub fn grid(d: Dims) -> [u32; 3] {
        [groups(d.nx + 1, 64), d.ny + 1, d.n_env]
    }

    /// Dispatches per substep for a scheme.
    pub fn dispatches(scheme: Advection) -> u32 {
        match scheme {
            Advection::SemiLagrangian => 2,
            Advection::Maccormack => 3,
        }
    }

    pub fn record(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: &wgpu::BindGroup,
        substep_offset: u32,
        dims: Dims,
        scheme: Advection,
    ) {
        let grid = Self::grid(dims);
        self.diffuse.dispatch(pass, bind, substep_offset, grid);
        match scheme {
            Advection::SemiLagrangian => {
                self.semi_lagrangian
                    .dispatch(pass, bind, substep_offset, grid)
            }
            Advection::Maccormack => {
                self.predict.dispatch(pass, bind, substep_offset, grid);
                self.correct.dispatch(pass, bind, substep_offset, grid);
            }
        }
    }
}
