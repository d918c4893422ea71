//! What every entry point binds and how big it is: the storage bindings ([`FieldBinding`]),
//! each entry point's table ([`Entry`]: kernel file, workgroup [`Shape`], buffers read and
//! written), the column kernels' layout per grid height ([`Columns`]) and the device limits
//! every entry point fits in; [`Entry::check`] turns a limit an adapter lacks into a typed
//! error naming the kernel.

use crate::gpu::GpuError;

/// Storage bindings 2..=21 (0 is the params uniform, 1 the substep uniform, dynamic offset).
pub const STORAGE_BINDINGS: u32 = 20;

/// Storage buffers per shader stage that every entry point fits in: SwiftShader's limit.
/// (WebGPU's default is 8; `advect_diffuse` needs 9 and `maccormack_correct` 10.)
pub const MAX_STORAGE_BUFFERS: u32 = 10;

/// Invocations per workgroup that every entry point fits in (SwiftShader's and WebGPU's limit).
pub const MAX_INVOCATIONS: u32 = 256;

/// Bytes of workgroup memory that every entry point fits in (WebGPU's default limit).
pub const MAX_WORKGROUP_BYTES: u32 = 16384;

/// The layout of the column kernels (`pressure_rhs`, `pressure_back`) for a grid: one thread per
/// column, `lanes` columns per workgroup, each column's `max_ny` values kept in lane-interleaved
/// workgroup memory (`[j * LANES + lane]`). Every variant fills the same 16 KiB of workgroup
/// memory (`max_ny * lanes` = 4096 f32, [`MAX_WORKGROUP_BYTES`]) with `lanes` <= 64 invocations:
/// 64 x 64 up to ny = 64 (the layout the kernels always had), 128 x 32 up to 128, 256 x 16 up
/// to 256 ([`crate::config::MAX_NY`]). The lanes only say which column a thread owns: each
/// column's arithmetic is the same in every variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Columns {
    /// Most cells across the channel a column holds (`MAX_NY` in the WGSL).
    pub max_ny: u32,
    /// Columns per workgroup, one thread each (`LANES`, the workgroup size).
    pub lanes: u32,
}

impl Columns {
    /// The variants the configuration's ny (1 ..= [`crate::config::MAX_NY`]) can take.
    pub const ALL: [Columns; 3] = [
        Columns::for_ny(64),
        Columns::for_ny(128),
        Columns::for_ny(256),
    ];

    /// The variant for ny cells across the channel: `max_ny` the next power of two from 64,
    /// `lanes` what fills 16 KiB. Above ny = 4096 a column alone needs more than 16 KiB
    /// (`lanes` stays 1): [`Entry::check`] then names the workgroup-memory limit.
    pub const fn for_ny(ny: u32) -> Self {
        let max_ny = if ny <= 64 { 64 } else { ny.next_power_of_two() };
        let floats = MAX_WORKGROUP_BYTES / 4;
        let lanes = if max_ny >= floats { 1 } else { floats / max_ny };
        Self { max_ny, lanes }
    }

    /// Bytes of the column scratch.
    pub const fn workgroup_bytes(self) -> u32 {
        4 * self.max_ny * self.lanes
    }
}

/// The workgroup of an entry point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// The same at every grid: size and bytes of `var<workgroup>` memory.
    Fixed {
        /// Workgroup size (x, y, z).
        workgroup: [u32; 3],
        /// Bytes of `var<workgroup>` memory.
        workgroup_bytes: u32,
    },
    /// A column kernel: (LANES, 1, 1) and MAX_NY * LANES f32 of scratch, from [`Columns`].
    Columns,
}

/// Storage bindings 2..=21 of the field buffers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum FieldBinding {
    /// `u_in`: input u velocity, faces `[E][ny][nx+1]` (m/s).
    UIn = 2,
    /// `v_in`: input v velocity, faces `[E][ny+1][nx]` (m/s).
    VIn,
    /// `u_out`: output u velocity, `[E][ny][nx+1]` (m/s).
    UOut,
    /// `v_out`: output v velocity, `[E][ny+1][nx]` (m/s).
    VOut,
    /// `u_hat`: like u, vec4 (MacCormack predictor, stencil min, max, transverse velocity).
    UHat,
    /// `v_hat`: like v, vec4 (MacCormack predictor, stencil min, max, transverse velocity).
    VHat,
    /// `p`: pressure at cell centres, `[E][ny][nx]` (Pa).
    Pressure,
    /// `phat`: y-cosine modes of the pressure solve, `[E][ny][nx]` (mode k of column i).
    Modes,
    /// `body`: per cell vec4 (solid fraction chi, body u, body v, 0), `[E][ny][nx]`.
    Body,
    /// `inlet`: inlet centreline velocity at the end of each substep, `[E][substeps]` (m/s).
    Inlet,
    /// `poisson`: the fast solver's tables (Q, Thomas c' and 1/m, the packed transform tables),
    /// [`crate::sim::poisson::PoissonTables::to_gpu`].
    Poisson,
    /// `divstar`: max_j abs(div u*) of each column before projection, `[E][nx]` (1/s).
    DivStar,
    /// `colstats`: per cross-section x = i dx, vec4 (flux, max abs(div u), max speed,
    /// non-finite count), `[E][nx+1]`.
    ColStats,
    /// `health`: per-environment health, two vec4 each, `[E][2]`.
    Health,
    /// `w_u`: u after one explicit diffusion step, like u (m/s).
    WU,
    /// `w_v`: v after one explicit diffusion step, like v (m/s).
    WV,
    /// `members`: member position, velocity and pinned flag, `[E][N]`.
    Members,
    /// `member_diag`: forces on each member in the last substep and its pressure samples, `[E][N]`.
    MemberDiag,
    /// `thrust`: raw actions a of each member (vec2), `[E][N]`.
    Thrust,
    /// `swarm_box`: x/y extent of the member centres now and at the last paint, `[E][2]`.
    SwarmBox,
}

impl FieldBinding {
    /// Every storage binding, in binding order.
    pub const ALL: [FieldBinding; 20] = [
        Self::UIn,
        Self::VIn,
        Self::UOut,
        Self::VOut,
        Self::UHat,
        Self::VHat,
        Self::Pressure,
        Self::Modes,
        Self::Body,
        Self::Inlet,
        Self::Poisson,
        Self::DivStar,
        Self::ColStats,
        Self::Health,
        Self::WU,
        Self::WV,
        Self::Members,
        Self::MemberDiag,
        Self::Thrust,
        Self::SwarmBox,
    ];

    /// The storage binding with this index (the uniforms 0 and 1 are not storage).
    pub fn from_index(binding: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|b| *b as u32 == binding)
    }

    /// The WGSL name and element type of the binding (mirrors `shaders/common.wgsl`).
    pub fn wgsl(self) -> (&'static str, &'static str) {
        use FieldBinding::*;
        match self {
            UIn => ("u_in", "f32"),
            VIn => ("v_in", "f32"),
            UOut => ("u_out", "f32"),
            VOut => ("v_out", "f32"),
            UHat => ("u_hat", "vec4<f32>"),
            VHat => ("v_hat", "vec4<f32>"),
            Pressure => ("p", "f32"),
            Modes => ("phat", "f32"),
            Body => ("body", "vec4<f32>"),
            Inlet => ("inlet", "f32"),
            Poisson => ("poisson", "f32"),
            DivStar => ("divstar", "f32"),
            ColStats => ("colstats", "vec4<f32>"),
            Health => ("health", "vec4<f32>"),
            WU => ("w_u", "f32"),
            WV => ("w_v", "f32"),
            Members => ("members", "Member"),
            MemberDiag => ("member_diag", "MemberDiag"),
            Thrust => ("thrust", "vec2<f32>"),
            SwarmBox => ("swarm_box", "vec4<f32>"),
        }
    }
}

/// One compute entry point: its kernel file, its workgroup, and the storage buffers it reads
/// only and those it writes (and may read). A unit test checks every table against naga's
/// analysis of the module built from it.
#[derive(Debug)]
pub struct Entry {
    /// The entry point's name in its kernel file.
    pub name: &'static str,
    /// The kernel's file name and source (`shaders::*`).
    pub file: &'static str,
    /// The kernel file's WGSL source.
    pub source: &'static str,
    /// Its workgroup size and `var<workgroup>` memory.
    pub shape: Shape,
    /// Storage buffers the entry point only reads.
    pub reads: &'static [FieldBinding],
    /// Storage buffers the entry point writes (and may read).
    pub writes: &'static [FieldBinding],
}

impl Entry {
    /// Storage buffers the entry point binds (reads plus writes).
    pub fn storage_buffers(&self) -> u32 {
        (self.reads.len() + self.writes.len()) as u32
    }

    /// The workgroup size in the module built for `cols`.
    pub fn workgroup(&self, cols: Columns) -> [u32; 3] {
        match self.shape {
            Shape::Fixed { workgroup, .. } => workgroup,
            Shape::Columns => [cols.lanes, 1, 1],
        }
    }

    /// Bytes of `var<workgroup>` memory the entry point uses in the module built for `cols`.
    pub fn workgroup_bytes(&self, cols: Columns) -> u32 {
        match self.shape {
            Shape::Fixed {
                workgroup_bytes, ..
            } => workgroup_bytes,
            Shape::Columns => cols.workgroup_bytes(),
        }
    }

    /// Invocations per workgroup in the module built for `cols`.
    pub fn invocations(&self, cols: Columns) -> u32 {
        self.workgroup(cols).iter().product()
    }

    fn writes(&self, b: FieldBinding) -> bool {
        self.writes.contains(&b)
    }

    pub(super) fn binds(&self, b: FieldBinding) -> bool {
        self.reads.contains(&b) || self.writes(b)
    }

    /// The module of this entry point alone, for the column layout `cols`: its storage
    /// declarations (every field buffer is declared, so that the kernel file's other helpers
    /// compile; those the entry point does not use are not part of its interface) and `MAX_NY`,
    /// `LANES` (declared in every module, for the kernel file's shared scratch), then
    /// `common.wgsl`, the samplers and the kernel file without its other entry points.
    pub fn module_source(&self, cols: Columns) -> String {
        let mut header = format!(
            "// Module of entry point `{}` ({}): storage bindings from its table in \
             src/gpu/kernels/.\n\
             const MAX_NY: u32 = {}u; // column layout (Columns in src/gpu/kernels/mod.rs)\n\
             const LANES: u32 = {}u;\n",
            self.name, self.file, cols.max_ny, cols.lanes
        );
        for b in FieldBinding::ALL {
            let (name, ty) = b.wgsl();
            let access = if self.writes(b) { "read_write" } else { "read" };
            let note = if self.binds(b) {
                ""
            } else {
                " // not used here"
            };
            header.push_str(&format!(
                "@group(0) @binding({}) var<storage, {access}> {name}: array<{ty}>;{note}\n",
                b as u32
            ));
        }
        crate::gpu::shaders::entry_module(&header, self.source, self.name)
            .unwrap_or_else(|| panic!("{}: no entry point `{}`", self.file, self.name))
    }

    pub(super) fn layout_entries(&self) -> Vec<wgpu::BindGroupLayoutEntry> {
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: binding == 1,
                min_binding_size: None,
            },
            count: None,
        };
        let mut entries = vec![
            entry(0, wgpu::BufferBindingType::Uniform),
            entry(1, wgpu::BufferBindingType::Uniform),
        ];
        for b in FieldBinding::ALL.into_iter().filter(|b| self.binds(*b)) {
            let read_only = !self.writes(b);
            entries.push(entry(
                b as u32,
                wgpu::BufferBindingType::Storage { read_only },
            ));
        }
        entries
    }

    /// Whether the device can run this entry point, built for `cols`; the first limit it
    /// exceeds otherwise.
    pub fn check(
        &self,
        limits: &wgpu::Limits,
        adapter: &str,
        cols: Columns,
    ) -> Result<(), GpuError> {
        let workgroup = self.workgroup(cols);
        let needs = [
            (
                "max_storage_buffers_per_shader_stage",
                self.storage_buffers(),
                limits.max_storage_buffers_per_shader_stage,
            ),
            (
                "max_compute_invocations_per_workgroup",
                self.invocations(cols),
                limits.max_compute_invocations_per_workgroup,
            ),
            (
                "max_compute_workgroup_size_x",
                workgroup[0],
                limits.max_compute_workgroup_size_x,
            ),
            (
                "max_compute_workgroup_size_y",
                workgroup[1],
                limits.max_compute_workgroup_size_y,
            ),
            (
                "max_compute_workgroup_size_z",
                workgroup[2],
                limits.max_compute_workgroup_size_z,
            ),
            (
                "max_compute_workgroup_storage_size",
                self.workgroup_bytes(cols),
                limits.max_compute_workgroup_storage_size,
            ),
        ];
        match needs.into_iter().find(|(_, need, have)| need > have) {
            Some((limit, need, have)) => Err(GpuError::Limit {
                kernel: self.name,
                limit,
                need,
                have,
                adapter: adapter.to_string(),
            }),
            None => Ok(()),
        }
    }
}
