//! `shaders/advect.wgsl`: momentum predictor (diffusion, then advection + boundary values +
//! Brinkman). Semi-Lagrangian: diffuse and advect, two dispatches; MacCormack: diffuse,
//! predict and correct, three. Grid: (ceil((nx+1)/64), ny+1, E).

use super::{Builder, Dims, Entry, FieldBinding::*, Pipeline, Shape, Side, groups};
use crate::config::Advection;

/// `diffuse`: one explicit diffusion step of the input velocity into w; with members it also
/// paints the body field.
pub const DIFFUSE: Entry = Entry {
    name: "diffuse",
    file: "advect.wgsl",
    source: crate::gpu::shaders::ADVECT,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[UIn, VIn, Members, SwarmBox],
    writes: &[Body, WU, WV],
};

/// `advect_diffuse`: semi-Lagrangian advection of w with boundary values and Brinkman blending.
pub const ADVECT_DIFFUSE: Entry = Entry {
    name: "advect_diffuse",
    file: "advect.wgsl",
    source: crate::gpu::shaders::ADVECT,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[UIn, VIn, Body, Inlet, WU, WV, SwarmBox],
    writes: &[UOut, VOut],
};

/// `advect_predict`: the MacCormack predictor, u_hat = A(w).
pub const ADVECT_PREDICT: Entry = Entry {
    name: "advect_predict",
    file: "advect.wgsl",
    source: crate::gpu::shaders::ADVECT,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[UIn, VIn, Inlet, WU, WV],
    writes: &[UHat, VHat],
};

/// `maccormack_correct`: the MacCormack correction, clamped to the extrema of A's stencil.
pub const MACCORMACK_CORRECT: Entry = Entry {
    name: "maccormack_correct",
    file: "advect.wgsl",
    source: crate::gpu::shaders::ADVECT,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[UIn, VIn, UHat, VHat, Body, WU, WV, SwarmBox],
    writes: &[UOut, VOut],
};

/// The momentum-predictor pipelines of `advect.wgsl`.
pub struct Advect {
    diffuse: Pipeline,
    semi_lagrangian: Pipeline,
    predict: Pipeline,
    correct: Pipeline,
}

impl Advect {
    /// Builds the four pipelines.
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            diffuse: Pipeline::new(b, &DIFFUSE),
            semi_lagrangian: Pipeline::new(b, &ADVECT_DIFFUSE),
            predict: Pipeline::new(b, &ADVECT_PREDICT),
            correct: Pipeline::new(b, &MACCORMACK_CORRECT),
        }
    }

    /// Dispatch grid (ceil((nx+1)/64), ny+1, E): one thread per u face and v face (i, j).
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

    /// Records the predictor's dispatches for `scheme` on side `bind`, at the substep uniform's
    /// dynamic offset `substep_offset` (bytes).
    pub fn record(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: Side<'_>,
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
