//! Building and recording the kernels: a [`Builder`] compiles each entry point's
//! [`Pipeline`] with its own bind group layout, [`Kernels`] holds every pipeline of the fluid
//! batch and builds its [`BindGroups`] once (both sides of the velocity ping-pong), and a
//! [`Recorder`] records dispatches into one compute pass, optionally timed.

use super::layout::{Columns, Entry, FieldBinding};
use super::{
    Advect, Diagnostics, ENTRIES, Members, PressureRhs, PressureScan, PressureSolve, Project,
};
use crate::gpu::{GpuContext, GpuError};

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
    /// Momentum predictor.
    pub advect: Advect,
    /// Poisson right-hand side.
    pub rhs: PressureRhs,
    /// Sequential per-mode tridiagonal solve.
    pub solve: PressureSolve,
    /// Scan per-mode tridiagonal solve.
    pub scan: PressureScan,
    /// Pressure back-transform and velocity correction.
    pub project: Project,
    /// Per-environment health.
    pub diagnostics: Diagnostics,
    /// Body painting and member motion.
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
    /// `buffer(which, g)` is the buffer bound at `which` on side g (side g reads u`[g]`, v`[g]`).
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
    /// Side g: the bind groups that read u`[g]`, v`[g]` and write u`[1-g]`, v`[1-g]`.
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
    /// A recorder without timestamps.
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
    /// Compiles `entry`'s module for the builder's column layout, with its own bind group layout.
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
    /// Cells along x.
    pub nx: u32,
    /// Cells across the height.
    pub ny: u32,
    /// Environments in the batch (E).
    pub n_env: u32,
}

pub(crate) fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}
