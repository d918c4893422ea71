//! The batch's device buffers ([E] outermost; shapes in the module header above): one table
//! of sizes (`words_per_env`), their creation, the two pre-built bind groups per kernel, and the
//! buffer behind each binding.

use super::*;

pub(super) struct Buffers {
    pub(super) params: wgpu::Buffer,
    pub(super) substep: wgpu::Buffer,
    pub(super) u: [wgpu::Buffer; 2],
    pub(super) v: [wgpu::Buffer; 2],
    pub(super) u_hat: wgpu::Buffer,
    pub(super) v_hat: wgpu::Buffer,
    pub(super) p: wgpu::Buffer,
    pub(super) modes: wgpu::Buffer,
    pub(super) body: wgpu::Buffer,
    pub(super) inlet: wgpu::Buffer,
    pub(super) poisson: wgpu::Buffer,
    pub(super) divstar: wgpu::Buffer,
    pub(super) colstats: wgpu::Buffer,
    pub(super) health: wgpu::Buffer,
    pub(super) health_staging: wgpu::Buffer,
    pub(super) w_u: wgpu::Buffer,
    pub(super) w_v: wgpu::Buffer,
    pub(super) members: wgpu::Buffer,
    pub(super) member_diag: wgpu::Buffer,
    pub(super) thrust: wgpu::Buffer,
    pub(super) swarm_box: wgpu::Buffer,
}

impl Buffers {
    /// The buffer behind a binding on side `g` of the ping-pong (side g reads u[g], v[g] and
    /// writes u[1-g], v[1-g]).
    fn get(&self, which: FieldBinding, g: usize) -> &wgpu::Buffer {
        match which {
            FieldBinding::UIn => &self.u[g],
            FieldBinding::VIn => &self.v[g],
            FieldBinding::UOut => &self.u[1 - g],
            FieldBinding::VOut => &self.v[1 - g],
            FieldBinding::UHat => &self.u_hat,
            FieldBinding::VHat => &self.v_hat,
            FieldBinding::Pressure => &self.p,
            FieldBinding::Modes => &self.modes,
            FieldBinding::Body => &self.body,
            FieldBinding::Inlet => &self.inlet,
            FieldBinding::Poisson => &self.poisson,
            FieldBinding::DivStar => &self.divstar,
            FieldBinding::ColStats => &self.colstats,
            FieldBinding::Health => &self.health,
            FieldBinding::WU => &self.w_u,
            FieldBinding::WV => &self.w_v,
            FieldBinding::Members => &self.members,
            FieldBinding::MemberDiag => &self.member_diag,
            FieldBinding::Thrust => &self.thrust,
            FieldBinding::SwarmBox => &self.swarm_box,
        }
    }
}

impl GpuBatch {
    pub(super) fn create_buffers(
        ctx: &GpuContext,
        grid: &Grid,
        params: &GpuParams,
        n_env: usize,
        substeps: usize,
        n_members: usize,
        stride: u32,
    ) -> Buffers {
        let device = &ctx.device;
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let zeros = |label: &str, bytes: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (bytes.max(16) as u64).next_multiple_of(16),
                usage: storage,
                mapped_at_creation: false,
            })
        };
        let f = 4;
        let mut slots = vec![0u8; stride as usize * substeps];
        for s in 0..substeps {
            let u = SubstepUniform {
                index: s as u32,
                pad: [0; 3],
            };
            let at = s * stride as usize;
            slots[at..at + 16].copy_from_slice(bytemuck::bytes_of(&u));
        }
        Buffers {
            params: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(params),
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            substep: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("substep slots"),
                contents: &slots,
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            u: [
                zeros("u0", n_env * grid.n_u() * f),
                zeros("u1", n_env * grid.n_u() * f),
            ],
            v: [
                zeros("v0", n_env * grid.n_v() * f),
                zeros("v1", n_env * grid.n_v() * f),
            ],
            u_hat: zeros("u_hat", n_env * grid.n_u() * 16),
            v_hat: zeros("v_hat", n_env * grid.n_v() * 16),
            p: zeros("p", n_env * grid.n_cells() * f),
            modes: zeros("modes", n_env * grid.n_cells() * f),
            body: zeros("body", n_env * grid.n_cells() * 16),
            inlet: zeros("inlet", n_env * substeps * f),
            poisson: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("poisson"),
                contents: bytemuck::cast_slice(&PoissonTables::new(grid).to_gpu()),
                usage: storage,
            }),
            divstar: zeros("divstar", n_env * grid.nx * f),
            colstats: zeros("colstats", n_env * (grid.nx + 1) * 16),
            health: zeros("health", n_env * 32),
            w_u: zeros("w_u", n_env * grid.n_u() * f),
            w_v: zeros("w_v", n_env * grid.n_v() * f),
            // At least one element each: `diffuse` (which paints) binds them in every batch.
            members: zeros("members", n_env * n_members.max(1) * 32),
            member_diag: zeros("member diag", n_env * n_members.max(1) * 48),
            thrust: zeros("thrust", n_env * n_members.max(1) * 8),
            swarm_box: zeros("swarm box", n_env * 32),
            health_staging: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("health + members staging"),
                size: (n_env * (32 + n_members * (32 + 48))) as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }

    /// Every pipeline's bind groups, both sides (built once per batch).
    pub(super) fn bind_groups(
        device: &wgpu::Device,
        pipelines: &Pipelines,
        b: &Buffers,
    ) -> BindGroups {
        pipelines.bind_groups(device, &b.params, &b.substep, |which, g| b.get(which, g))
    }

    /// The buffer behind a binding now (`UIn`/`VIn` are the current field).
    pub(super) fn buffer(&self, which: FieldBinding) -> &wgpu::Buffer {
        self.buffers.get(which, self.cur)
    }

    /// Elements (of 4 bytes) one environment holds in a buffer.
    pub(super) fn words_per_env(&self, which: FieldBinding) -> usize {
        let g = &self.core.grid;
        match which {
            FieldBinding::UIn | FieldBinding::UOut | FieldBinding::WU => g.n_u(),
            FieldBinding::VIn | FieldBinding::VOut | FieldBinding::WV => g.n_v(),
            FieldBinding::UHat => 4 * g.n_u(),
            FieldBinding::VHat => 4 * g.n_v(),
            FieldBinding::Pressure | FieldBinding::Modes => g.n_cells(),
            FieldBinding::Body => 4 * g.n_cells(),
            FieldBinding::Inlet => self.core.substeps,
            FieldBinding::Poisson => 0,
            FieldBinding::DivStar => g.nx,
            FieldBinding::ColStats => 4 * (g.nx + 1),
            FieldBinding::Health => 8,
            FieldBinding::Members => 8 * self.core.n_members,
            FieldBinding::MemberDiag => 12 * self.core.n_members,
            FieldBinding::Thrust => 2 * self.core.n_members,
            FieldBinding::SwarmBox => 8,
        }
    }
    /// Bytes of a whole buffer (all environments).
    pub(super) fn buffer_bytes(&self, which: FieldBinding) -> u64 {
        let words = if which == FieldBinding::Poisson {
            self.core.grid.ny * self.core.grid.ny + 2 * self.core.grid.n_cells()
        } else {
            self.words_per_env(which) * self.core.n_env
        };
        4 * words as u64
    }
}
