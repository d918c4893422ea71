//! One struct per WGSL kernel (`shaders/<name>.wgsl` <-> `<name>.rs`), each owning its
//! pipeline(s) and knowing its dispatch grid; none owns state. Every entry point has its own
//! bind group layout, from its [`Entry`] table: the two uniforms (bindings 0 and 1) and only the
//! storage buffers it touches, `read` or `read_write`, at the binding numbers of
//! [`FieldBinding`]; its module declares exactly those (`shaders.rs`), so that each kernel fits
//! the 10 storage buffers per stage of the strictest driver we test on (SwiftShader). The bind
//! groups of every pipeline, both sides of the velocity ping-pong, are built once per batch
//! ([`Kernels::bind_groups`]). The two column kernels (`pressure_rhs`, `pressure_back`) are
//! generated for the batch's grid ([`Columns`]): the pipelines are built per batch.

pub mod advect;
pub mod diagnostics;
pub mod members;
pub mod pressure_rhs;
pub mod pressure_scan;
pub mod pressure_solve;
pub mod project;

pub use advect::Advect;
pub use diagnostics::Diagnostics;
pub use members::Members;
pub use pressure_rhs::PressureRhs;
pub use pressure_scan::PressureScan;
pub use pressure_solve::PressureSolve;
pub use project::Project;

use super::{GpuContext, GpuError};

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
        workgroup: [u32; 3],
        workgroup_bytes: u32,
    },
    /// A column kernel: (LANES, 1, 1) and MAX_NY * LANES f32 of scratch, from [`Columns`].
    Columns,
}

/// Storage bindings 2..=21 of the field buffers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum FieldBinding {
    UIn = 2,
    VIn,
    UOut,
    VOut,
    UHat,
    VHat,
    Pressure,
    Modes,
    Body,
    Inlet,
    Poisson,
    DivStar,
    ColStats,
    Health,
    WU,
    WV,
    Members,
    MemberDiag,
    Thrust,
    SwarmBox,
}

impl FieldBinding {
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
    pub name: &'static str,
    /// The kernel's file name and source (`shaders::*`).
    pub file: &'static str,
    pub source: &'static str,
    /// Its workgroup size and `var<workgroup>` memory.
    pub shape: Shape,
    pub reads: &'static [FieldBinding],
    pub writes: &'static [FieldBinding],
}

/// Every entry point the fluid batch builds, in pipeline order.
pub const ENTRIES: [&Entry; 13] = [
    &advect::DIFFUSE,
    &advect::ADVECT_DIFFUSE,
    &advect::ADVECT_PREDICT,
    &advect::MACCORMACK_CORRECT,
    &pressure_rhs::PRESSURE_RHS,
    &pressure_solve::PRESSURE_SOLVE,
    &pressure_scan::PRESSURE_SCAN,
    &project::PRESSURE_BACK,
    &project::PROJECT,
    &diagnostics::DIAG_COLUMNS,
    &diagnostics::DIAG_REDUCE,
    &members::PAINT_BODIES,
    &members::MOVE_MEMBERS,
];

impl Entry {
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

    pub fn invocations(&self, cols: Columns) -> u32 {
        self.workgroup(cols).iter().product()
    }

    fn writes(&self, b: FieldBinding) -> bool {
        self.writes.contains(&b)
    }

    fn binds(&self, b: FieldBinding) -> bool {
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
        super::shaders::entry_module(&header, self.source, self.name)
            .unwrap_or_else(|| panic!("{}: no entry point `{}`", self.file, self.name))
    }

    fn layout_entries(&self) -> Vec<wgpu::BindGroupLayoutEntry> {
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

/// Creates pipelines (the column kernels for `columns`) and hands out their indices into a
/// batch's [`BindGroups`].
pub struct Builder<'a> {
    device: &'a wgpu::Device,
    columns: Columns,
    layouts: Vec<(wgpu::BindGroupLayout, &'static Entry)>,
}

impl Builder<'_> {
    /// The column layout the pipelines are built for.
    pub fn columns(&self) -> Columns {
        self.columns
    }
}

/// Every fluid pipeline (compiled per batch: the column kernels follow its ny) and their bind
/// group layouts.
pub struct Kernels {
    pub advect: Advect,
    pub rhs: PressureRhs,
    pub solve: PressureSolve,
    pub scan: PressureScan,
    pub project: Project,
    pub diagnostics: Diagnostics,
    pub members: Members,
    layouts: Vec<(wgpu::BindGroupLayout, &'static Entry)>,
}

impl Kernels {
    /// Checks every entry point, its column kernels built for `ny` cells across the channel,
    /// against the device's limits (a typed error naming the kernel and the limit, instead of a
    /// wgpu validation error), then builds the pipelines.
    pub fn new(ctx: &GpuContext, ny: u32) -> Result<Self, GpuError> {
        let columns = Columns::for_ny(ny);
        for entry in ENTRIES {
            entry.check(&ctx.limits, &ctx.describe(), columns)?;
        }
        let mut b = Builder {
            device: &ctx.device,
            columns,
            layouts: Vec::new(),
        };
        Ok(Self {
            advect: Advect::new(&mut b),
            rhs: PressureRhs::new(&mut b),
            solve: PressureSolve::new(&mut b),
            scan: PressureScan::new(&mut b),
            project: Project::new(&mut b),
            diagnostics: Diagnostics::new(&mut b),
            members: Members::new(&mut b),
            layouts: b.layouts,
        })
    }

    /// The bind groups of every pipeline for one batch, both sides of the ping-pong:
    /// `buffer(which, g)` is the buffer bound at `which` on side g (side g reads u[g], v[g]).
    pub fn bind_groups<'b>(
        &self,
        device: &wgpu::Device,
        params: &wgpu::Buffer,
        substep: &wgpu::Buffer,
        buffer: impl Fn(FieldBinding, usize) -> &'b wgpu::Buffer,
    ) -> BindGroups {
        let sided = [
            FieldBinding::UIn,
            FieldBinding::VIn,
            FieldBinding::UOut,
            FieldBinding::VOut,
        ];
        let groups = self
            .layouts
            .iter()
            .map(|(layout, entry)| {
                let group = |g: usize| {
                    let mut entries = vec![
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: params.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: substep,
                                offset: 0,
                                size: wgpu::BufferSize::new(16),
                            }),
                        },
                    ];
                    entries.extend(
                        FieldBinding::ALL
                            .into_iter()
                            .filter(|b| entry.binds(*b))
                            .map(|b| wgpu::BindGroupEntry {
                                binding: b as u32,
                                resource: buffer(b, g).as_entire_binding(),
                            }),
                    );
                    device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some(entry.name),
                        layout,
                        entries: &entries,
                    })
                };
                let first = group(0);
                if sided.iter().any(|b| entry.binds(*b)) {
                    [first, group(1)]
                } else {
                    [first.clone(), first]
                }
            })
            .collect();
        BindGroups { groups }
    }
}

/// The bind groups of every pipeline of [`Kernels`] for one batch, built once.
pub struct BindGroups {
    groups: Vec<[wgpu::BindGroup; 2]>,
}

impl BindGroups {
    /// Side g: the bind groups that read u[g], v[g] and write u[1-g], v[1-g].
    pub fn side(&self, g: usize) -> Side<'_> {
        Side { groups: self, g }
    }
}

/// One side of the ping-pong of a batch's bind groups, as the kernels' `record` takes it.
#[derive(Clone, Copy)]
pub struct Side<'a> {
    groups: &'a BindGroups,
    g: usize,
}

/// A compute pass being recorded, optionally with a timestamp query before and after every
/// dispatch (per-kernel GPU times in `bench`; needs the adapter's timestamp-inside-pass feature).
pub struct Recorder<'a> {
    pass: wgpu::ComputePass<'a>,
    timer: Option<Timer<'a>>,
}

struct Timer<'a> {
    set: &'a wgpu::QuerySet,
    capacity: u32,
    labels: Vec<&'static str>,
}

impl<'a> Recorder<'a> {
    pub fn new(pass: wgpu::ComputePass<'a>) -> Self {
        Self { pass, timer: None }
    }

    /// A recorder writing timestamps 2k and 2k + 1 around the k-th dispatch into `set`.
    pub fn timed(pass: wgpu::ComputePass<'a>, set: &'a wgpu::QuerySet, capacity: u32) -> Self {
        Self {
            pass,
            timer: Some(Timer {
                set,
                capacity,
                labels: Vec::new(),
            }),
        }
    }

    /// The entry point of each timed dispatch, in order.
    pub fn labels(&self) -> &[&'static str] {
        self.timer.as_ref().map_or(&[], |t| &t.labels)
    }
}

/// The compute pipeline of one entry point, with its own bind group layout.
pub struct Pipeline {
    pipeline: wgpu::ComputePipeline,
    label: &'static str,
    /// Index of its bind groups in a batch's [`BindGroups`].
    id: usize,
}

impl Pipeline {
    pub fn new(b: &mut Builder<'_>, entry: &'static Entry) -> Self {
        let device = b.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(entry.name),
            source: wgpu::ShaderSource::Wgsl(entry.module_source(b.columns).into()),
        });
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(entry.name),
            entries: &entry.layout_entries(),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(entry.name),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry.name),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(entry.name),
            compilation_options: Default::default(),
            cache: None,
        });
        b.layouts.push((bind_group_layout, entry));
        Self {
            pipeline,
            label: entry.name,
            id: b.layouts.len() - 1,
        }
    }

    /// Records one dispatch with its bind group of the given side at the given substep slot.
    pub fn dispatch(
        &self,
        rec: &mut Recorder<'_>,
        bind: Side<'_>,
        substep_offset: u32,
        groups: [u32; 3],
    ) {
        let group = &bind.groups.groups[self.id][bind.g];
        let pass = &mut rec.pass;
        let slot = rec.timer.as_mut().map(|t| {
            let k = 2 * t.labels.len() as u32;
            assert!(k + 1 < t.capacity, "timestamp query set too small");
            t.labels.push(self.label);
            (t.set, k)
        });
        if let Some((set, k)) = slot {
            pass.write_timestamp(set, k);
        }
        pass.push_debug_group(self.label);
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, group, &[substep_offset]);
        pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
        pass.pop_debug_group();
        if let Some((set, k)) = slot {
            pass.write_timestamp(set, k + 1);
        }
    }
}

/// Grid sizes the dispatch shapes need.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dims {
    pub nx: u32,
    pub ny: u32,
    pub n_env: u32,
}

pub(crate) fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}

/// Copies `bytes` bytes at `offset` of a buffer to the CPU (blocking). `buffer` needs COPY_SRC.
pub fn read_buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    offset: u64,
    bytes: u64,
) -> Result<Vec<T>, GpuError> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(buffer, offset, &staging, 0, bytes);
    ctx.queue.submit([enc.finish()]);
    map_and_read(ctx, &staging, bytes)
}

/// Maps a MAP_READ buffer (after its copy was submitted) and returns its first `bytes` bytes.
pub fn map_and_read<T: bytemuck::Pod>(
    ctx: &GpuContext,
    staging: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<T>, GpuError> {
    let slice = staging.slice(0..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv()
        .map_err(|e| GpuError::Operation(e.to_string()))?
        .map_err(|e| GpuError::Operation(format!("buffer map failed: {e}")))?;
    let data = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Operation(e.to_string()))?;
        bytemuck::pod_collect_to_vec(&view)
    };
    staging.unmap();
    Ok(data)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use naga::valid::{Capabilities, GlobalUse, ValidationFlags, Validator};
    use naga::{AddressSpace, StorageAccess};

    use super::*;
    use crate::gpu::shaders;

    /// Heights that pick every column variant, at and around its edges.
    const HEIGHTS: [u32; 8] = [1, 20, 64, 65, 128, 129, 200, 256];

    #[test]
    fn the_column_layout_follows_the_grid_within_16_kib() {
        let layouts: Vec<_> = HEIGHTS
            .iter()
            .map(|&ny| {
                let c = Columns::for_ny(ny);
                (c.max_ny, c.lanes)
            })
            .collect();
        assert_eq!(
            layouts,
            [
                (64, 64),
                (64, 64),
                (64, 64),
                (128, 32),
                (128, 32),
                (256, 16),
                (256, 16),
                (256, 16)
            ]
        );
        assert_eq!(Columns::for_ny(crate::config::MAX_NY), Columns::ALL[2]);
        for c in Columns::ALL {
            assert_eq!(c.workgroup_bytes(), MAX_WORKGROUP_BYTES, "{c:?}");
        }
        // Past 4096 cells one column alone is over 16 KiB: the limit check says so.
        let c = Columns::for_ny(5000);
        assert_eq!((c.max_ny, c.lanes), (8192, 1));
        let err = pressure_rhs::PRESSURE_RHS
            .check(&wgpu::Limits::default(), "webgpu", c)
            .unwrap_err();
        assert!(matches!(
            err,
            GpuError::Limit {
                limit: "max_compute_workgroup_storage_size",
                need: 32768,
                have: 16384,
                ..
            }
        ));
    }

    /// Every entry point's module, as naga sees it, in every column variant: it binds exactly
    /// its table's buffers, with `read` exactly where it does not write (so a `read` binding is
    /// never written), within [`MAX_STORAGE_BUFFERS`], [`MAX_INVOCATIONS`] and the table's
    /// workgroup shape and memory.
    #[test]
    fn every_entry_point_binds_its_table_within_the_limits() {
        let mut failures = Vec::new();
        for entry in ENTRIES {
            for ny in HEIGHTS {
                check_entry_module(entry, ny, &mut failures);
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    fn check_entry_module(entry: &Entry, ny: u32, failures: &mut Vec<String>) {
        let cols = Columns::for_ny(ny);
        let source = entry.module_source(cols);
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{}: {}", entry.name, e.emit_to_string(&source)));
        let info = Validator::new(ValidationFlags::all(), Capabilities::all())
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}: {}", entry.name, e.emit_to_string(&source)));
        assert_eq!(module.entry_points.len(), 1, "{}", entry.name);
        let ep = &module.entry_points[0];
        assert_eq!(ep.name, entry.name);
        let uses = info.get_entry_point(0);
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (mut used, mut written) = (BTreeSet::new(), BTreeSet::new());
        let mut workgroup_bytes = 0;
        for (handle, var) in module.global_variables.iter() {
            let u = uses[handle];
            if u.is_empty() {
                continue;
            }
            match (var.space, &var.binding) {
                (AddressSpace::WorkGroup, _) => workgroup_bytes += layouter[var.ty].size,
                (AddressSpace::Uniform, Some(b)) => {
                    assert!(b.group == 0 && b.binding <= 1, "{}: {b:?}", entry.name)
                }
                (AddressSpace::Storage { access }, Some(b)) => {
                    assert_eq!(b.group, 0);
                    let field = FieldBinding::from_index(b.binding).unwrap();
                    used.insert(field);
                    let writes = u.contains(GlobalUse::WRITE);
                    if writes {
                        written.insert(field);
                    }
                    let declared_rw = access.contains(StorageAccess::STORE);
                    if !declared_rw && writes {
                        failures.push(format!("{}: {field:?} is `read` but written", ep.name));
                    }
                    if declared_rw && !writes {
                        failures.push(format!("{}: {field:?} is only read", ep.name));
                    }
                }
                other => panic!("{}: unexpected global {other:?}", entry.name),
            }
        }
        let table: BTreeSet<_> = entry.reads.iter().chain(entry.writes).copied().collect();
        let table_writes: BTreeSet<_> = entry.writes.iter().copied().collect();
        if used != table || written != table_writes {
            failures.push(format!(
                "{}: the shader uses {used:?} and writes {written:?}; its table says {table:?} \
                 and {table_writes:?}",
                ep.name
            ));
        }
        if table.len() != entry.reads.len() + entry.writes.len() {
            failures.push(format!("{}: a buffer is listed twice", ep.name));
        }
        if entry.storage_buffers() > MAX_STORAGE_BUFFERS {
            failures.push(format!(
                "{}: {} storage buffers, above {MAX_STORAGE_BUFFERS}",
                ep.name,
                entry.storage_buffers()
            ));
        }
        let workgroup = entry.workgroup(cols);
        if ep.workgroup_size != workgroup || entry.invocations(cols) > MAX_INVOCATIONS {
            failures.push(format!(
                "{} at ny = {ny}: workgroup {:?} (table {workgroup:?}, at most \
                 {MAX_INVOCATIONS} invocations)",
                ep.name, ep.workgroup_size
            ));
        }
        let table_bytes = entry.workgroup_bytes(cols);
        if workgroup_bytes != table_bytes || workgroup_bytes > MAX_WORKGROUP_BYTES {
            failures.push(format!(
                "{} at ny = {ny}: {workgroup_bytes} B of workgroup memory (table \
                 {table_bytes}, WebGPU allows {MAX_WORKGROUP_BYTES})",
                ep.name
            ));
        }
    }

    /// The table lists every `@compute` function of every kernel file, once.
    #[test]
    fn every_compute_function_has_a_table() {
        let files = [
            ("advect.wgsl", shaders::ADVECT),
            ("pressure_rhs.wgsl", shaders::PRESSURE_RHS),
            ("pressure_solve.wgsl", shaders::PRESSURE_SOLVE),
            ("pressure_scan.wgsl", shaders::PRESSURE_SCAN),
            ("project.wgsl", shaders::PROJECT),
            ("diagnostics.wgsl", shaders::DIAGNOSTICS),
            ("members.wgsl", shaders::MEMBERS),
        ];
        let mut in_files = Vec::new();
        for (file, source) in files {
            for name in shaders::entry_points(source) {
                in_files.push((file, name));
            }
        }
        let mut tables: Vec<_> = ENTRIES.iter().map(|e| (e.file, e.name)).collect();
        in_files.sort();
        tables.sort();
        assert_eq!(in_files, tables);
        assert_eq!(in_files.len(), 13);
    }

    #[test]
    fn a_device_below_a_kernels_needs_is_a_typed_error() {
        // SwiftShader's limits: everything fits.
        let swiftshader = wgpu::Limits {
            max_storage_buffers_per_shader_stage: 10,
            max_compute_invocations_per_workgroup: 256,
            max_compute_workgroup_size_x: 256,
            ..wgpu::Limits::default()
        };
        for entry in ENTRIES {
            for cols in Columns::ALL {
                entry.check(&swiftshader, "swiftshader", cols).unwrap();
            }
        }
        let eight = wgpu::Limits {
            max_storage_buffers_per_shader_stage: 8,
            ..swiftshader.clone()
        };
        let err = advect::MACCORMACK_CORRECT
            .check(&eight, "eight", Columns::ALL[0])
            .unwrap_err();
        let text = err.to_string();
        assert!(
            matches!(
                err,
                GpuError::Limit {
                    kernel: "maccormack_correct",
                    limit: "max_storage_buffers_per_shader_stage",
                    need: 10,
                    have: 8,
                    ..
                }
            ),
            "{text}"
        );
        assert!(
            text.contains("maccormack_correct") && text.contains("eight"),
            "{text}"
        );
        let small = wgpu::Limits {
            max_compute_invocations_per_workgroup: 128,
            ..swiftshader
        };
        let err = pressure_scan::PRESSURE_SCAN
            .check(&small, "small", Columns::ALL[0])
            .unwrap_err();
        assert!(matches!(
            err,
            GpuError::Limit {
                kernel: "pressure_scan",
                limit: "max_compute_invocations_per_workgroup",
                need: 256,
                have: 128,
                ..
            }
        ));
        // Within WebGPU's default 8 storage buffers: all but the two advection passes.
        let over: Vec<_> = ENTRIES
            .iter()
            .filter(|e| e.storage_buffers() > 8)
            .map(|e| e.name)
            .collect();
        assert_eq!(over, ["advect_diffuse", "maccormack_correct"]);
    }
}
