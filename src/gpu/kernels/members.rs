//! `shaders/members.wgsl`: members painted into the body field before the momentum predictor
//! (grid (ceil(nx/64), ny, E)) and moved after the projection (one workgroup per environment,
//! grid (E, 1, 1)). Recorded only when the batch has members.

use super::{Builder, Dims, Entry, FieldBinding::*, Pipeline, Shape, Side, groups};

/// `paint_bodies`: writes the body field from the members.
pub const PAINT_BODIES: Entry = Entry {
    name: "paint_bodies",
    file: "members.wgsl",
    source: crate::gpu::shaders::MEMBERS,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 0,
    },
    reads: &[Members, SwarmBox],
    writes: &[Body],
};

/// `move_members`: forces on each member and one substep of its motion.
pub const MOVE_MEMBERS: Entry = Entry {
    name: "move_members",
    file: "members.wgsl",
    source: crate::gpu::shaders::MEMBERS,
    shape: Shape::Fixed {
        workgroup: [64, 1, 1],
        workgroup_bytes: 1792,
    },
    reads: &[UOut, VOut, Pressure, Thrust],
    writes: &[Members, MemberDiag, SwarmBox],
};

/// The swarm pipelines of `members.wgsl`.
pub struct Members {
    paint: Pipeline,
    step: Pipeline,
}

impl Members {
    /// Builds both pipelines.
    pub fn new(b: &mut Builder<'_>) -> Self {
        Self {
            paint: Pipeline::new(b, &PAINT_BODIES),
            step: Pipeline::new(b, &MOVE_MEMBERS),
        }
    }

    /// Writes the body field from the members' current positions and velocities.
    pub fn record_paint(
        &self,
        pass: &mut super::Recorder<'_>,
        bind: Side<'_>,
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
        bind: Side<'_>,
        offset: u32,
        d: Dims,
    ) {
        self.step.dispatch(pass, bind, offset, [d.n_env, 1, 1]);
    }
}
