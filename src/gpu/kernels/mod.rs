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
mod layout;
pub mod members;
mod pipeline;
pub mod pressure_rhs;
pub mod pressure_scan;
pub mod pressure_solve;
pub mod project;
mod readback;

pub use advect::Advect;
pub use diagnostics::Diagnostics;
pub use layout::{
    Columns, Entry, FieldBinding, MAX_INVOCATIONS, MAX_STORAGE_BUFFERS, MAX_WORKGROUP_BYTES,
    STORAGE_BINDINGS, Shape,
};
pub use members::Members;
pub(crate) use pipeline::groups;
pub use pipeline::{BindGroups, Builder, Dims, Kernels, Pipeline, Recorder, Side};
pub use pressure_rhs::PressureRhs;
pub use pressure_scan::PressureScan;
pub use pressure_solve::PressureSolve;
pub use project::Project;
pub use readback::{map_and_read, read_buffer};

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

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use naga::valid::{Capabilities, GlobalUse, ValidationFlags, Validator};
    use naga::{AddressSpace, StorageAccess};

    use super::*;
    use crate::gpu::{GpuError, shaders};

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
