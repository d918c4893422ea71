//! One struct per WGSL kernel (`shaders/<name>.wgsl` <-> `<name>.rs`), each owning its
//! pipeline(s) and knowing its dispatch grid; none owns state. All fluid kernels share one bind
//! group layout ([`FieldLayout`], mirrored by `shaders/common.wgsl`) so that two bind groups,
//! built once per batch, serve every pass (the ping-pong of the velocity buffers).

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

/// Bindings of `common.wgsl`: 0 params (uniform), 1 substep (uniform, dynamic offset),
/// 2..=21 storage buffers in the order of [`FieldBinding`].
pub const STORAGE_BINDINGS: u32 = 20;

/// Storage bindings 2..=21 of the field bind group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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
}

/// The bind group layout and pipeline layout shared by every fluid kernel.
pub struct FieldLayout {
    pub bind_group_layout: wgpu::BindGroupLayout,
    pub pipeline_layout: wgpu::PipelineLayout,
}

impl FieldLayout {
    pub fn new(device: &wgpu::Device) -> Self {
        let uniform = |binding, dynamic| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: dynamic,
                min_binding_size: None,
            },
            count: None,
        };
        let mut entries = vec![uniform(0, false), uniform(1, true)];
        entries.extend(
            (2..2 + STORAGE_BINDINGS).map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: false },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }),
        );
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fields"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("fields"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        Self {
            bind_group_layout,
            pipeline_layout,
        }
    }
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

/// A compute pipeline built from `common.wgsl` + a kernel file, for one entry point.
pub struct Pipeline {
    pipeline: wgpu::ComputePipeline,
    label: &'static str,
}

impl Pipeline {
    pub fn new(
        device: &wgpu::Device,
        layout: &FieldLayout,
        module: &wgpu::ShaderModule,
        entry: &'static str,
    ) -> Self {
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&layout.pipeline_layout),
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        Self {
            pipeline,
            label: entry,
        }
    }

    /// Records one dispatch with the field bind group at the given substep slot.
    pub fn dispatch(
        &self,
        rec: &mut Recorder<'_>,
        bind: &wgpu::BindGroup,
        substep_offset: u32,
        groups: [u32; 3],
    ) {
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
        pass.set_bind_group(0, bind, &[substep_offset]);
        pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
        pass.pop_debug_group();
        if let Some((set, k)) = slot {
            pass.write_timestamp(set, k + 1);
        }
    }
}

/// Compiles `common.wgsl` + `kernel` into a module.
pub fn fluid_module(device: &wgpu::Device, label: &str, kernel: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(super::shaders::with_common(kernel).into()),
    })
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
