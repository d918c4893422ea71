//! WGSL sources. WGSL has no includes, so a fluid kernel's module is assembled here, one module
//! per entry point: the entry point's storage declarations (generated from its table,
//! [`super::kernels::Entry::module_source`]), `common.wgsl`, the samplers (`sample.wgsl`, once
//! per velocity source) and the kernel's file without its other entry points.

use super::kernels::{Columns, ENTRIES};

/// `common.wgsl`: parameters, index and ghost helpers shared by every fluid kernel.
pub const COMMON: &str = include_str!("../../shaders/common.wgsl");
/// `sample.wgsl`: the samplers of one velocity source (`SRC`), instantiated per source.
pub const SAMPLE: &str = include_str!("../../shaders/sample.wgsl");
/// `advect.wgsl`: the momentum predictor.
pub const ADVECT: &str = include_str!("../../shaders/advect.wgsl");
/// `pressure_rhs.wgsl`: the Poisson right-hand side in y-modes.
pub const PRESSURE_RHS: &str = include_str!("../../shaders/pressure_rhs.wgsl");
/// `pressure_solve.wgsl`: the per-mode Thomas solve.
pub const PRESSURE_SOLVE: &str = include_str!("../../shaders/pressure_solve.wgsl");
/// `pressure_scan.wgsl`: the per-mode solve as parallel scans.
pub const PRESSURE_SCAN: &str = include_str!("../../shaders/pressure_scan.wgsl");
/// `project.wgsl`: pressure back-transform and velocity correction.
pub const PROJECT: &str = include_str!("../../shaders/project.wgsl");
/// `diagnostics.wgsl`: per-environment health.
pub const DIAGNOSTICS: &str = include_str!("../../shaders/diagnostics.wgsl");
/// `members.wgsl`: body painting and member motion.
pub const MEMBERS: &str = include_str!("../../shaders/members.wgsl");
/// `loop_probe.wgsl`: driver self-check counting the trips of a long loop.
pub const LOOP_PROBE: &str = include_str!("../../shaders/loop_probe.wgsl");

/// The velocity sources `sample.wgsl` is instantiated for (its `SRC`), as `load_u_<source>`
/// in `common.wgsl` reads them.
pub const SOURCES: [&str; 4] = ["in", "diffused", "hat", "out"];

/// (file name, full module source) of every shader module the program builds: one per fluid
/// entry point (the column kernels in their first variant; `kernels` tests every variant),
/// plus the preludes alone (all storage declared `read`) and the loop probe.
pub fn all_modules() -> Vec<(&'static str, String)> {
    let prelude = format!("{}\n{COMMON}\n{}", read_only_header(), samplers());
    let mut out = vec![
        ("common.wgsl", format!("{}\n{COMMON}", read_only_header())),
        ("sample.wgsl", prelude),
    ];
    out.extend(
        ENTRIES
            .iter()
            .map(|e| (e.file, e.module_source(Columns::ALL[0]))),
    );
    out.push(("loop_probe.wgsl", LOOP_PROBE.to_string()));
    out
}

/// Every storage binding declared `read` (for validating the preludes on their own).
fn read_only_header() -> String {
    super::kernels::FieldBinding::ALL
        .iter()
        .map(|b| {
            let (name, ty) = b.wgsl();
            format!(
                "@group(0) @binding({}) var<storage, read> {name}: array<{ty}>;\n",
                *b as u32
            )
        })
        .collect()
}

/// `sample.wgsl` once per velocity source.
pub fn samplers() -> String {
    SOURCES
        .iter()
        .map(|s| SAMPLE.replace("SRC", s))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The module of entry point `entry` of a kernel file: `header` (its storage declarations),
/// the preludes, then the kernel without its other entry points; `None` if it has no `entry`.
pub fn entry_module(header: &str, kernel: &str, entry: &str) -> Option<String> {
    let own = only_entry(kernel, entry)?;
    Some(format!("{header}\n{COMMON}\n{}\n{own}", samplers()))
}

/// The names of a kernel file's entry points (`@compute` functions).
pub fn entry_points(kernel: &str) -> Vec<&str> {
    let mut names = Vec::new();
    let mut lines = kernel.lines();
    while let Some(line) = lines.next() {
        if line.starts_with("@compute")
            && let Some(name) = fn_name(line).or_else(|| lines.next().and_then(fn_name))
        {
            names.push(name);
        }
    }
    names
}

/// `kernel` without its entry points other than `entry`: each runs from its `@compute` line to
/// the first line that is a lone `}` (the house style of every kernel file).
fn only_entry(kernel: &str, entry: &str) -> Option<String> {
    let lines: Vec<&str> = kernel.lines().collect();
    let mut out = String::with_capacity(kernel.len());
    let mut found = false;
    let mut k = 0;
    while k < lines.len() {
        let line = lines[k];
        if line.starts_with("@compute") {
            let name = fn_name(line).or_else(|| lines.get(k + 1).and_then(|l| fn_name(l)));
            if name == Some(entry) {
                found = true;
            } else {
                while k < lines.len() && lines[k] != "}" {
                    k += 1;
                }
                k += 1;
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
        k += 1;
    }
    found.then_some(out)
}

/// The function a line declares (`fn name(` anywhere in it).
fn fn_name(line: &str) -> Option<&str> {
    let rest = &line[line.find("fn ")? + 3..];
    Some(rest[..rest.find('(')?].trim())
}
