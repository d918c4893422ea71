//! WGSL sources. Fluid kernels are `common.wgsl` (bindings, grid helpers) followed by the
//! kernel's own file; WGSL has no includes, so the two are concatenated here.

pub const COMMON: &str = include_str!("../../shaders/common.wgsl");
pub const ADVECT: &str = include_str!("../../shaders/advect.wgsl");
pub const PRESSURE_RHS: &str = include_str!("../../shaders/pressure_rhs.wgsl");
pub const PRESSURE_SOLVE: &str = include_str!("../../shaders/pressure_solve.wgsl");
pub const PRESSURE_SCAN: &str = include_str!("../../shaders/pressure_scan.wgsl");
pub const PROJECT: &str = include_str!("../../shaders/project.wgsl");
pub const DIAGNOSTICS: &str = include_str!("../../shaders/diagnostics.wgsl");
pub const MEMBERS: &str = include_str!("../../shaders/members.wgsl");
pub const LOOP_PROBE: &str = include_str!("../../shaders/loop_probe.wgsl");

/// (file name, full module source) of every shader module the program builds.
pub fn all_modules() -> Vec<(&'static str, String)> {
    vec![
        ("common.wgsl", COMMON.to_string()),
        ("advect.wgsl", with_common(ADVECT)),
        ("pressure_rhs.wgsl", with_common(PRESSURE_RHS)),
        ("pressure_solve.wgsl", with_common(PRESSURE_SOLVE)),
        ("pressure_scan.wgsl", with_common(PRESSURE_SCAN)),
        ("project.wgsl", with_common(PROJECT)),
        ("diagnostics.wgsl", with_common(DIAGNOSTICS)),
        ("members.wgsl", with_common(MEMBERS)),
        ("loop_probe.wgsl", LOOP_PROBE.to_string()),
    ]
}

/// A fluid kernel's full source: the common prelude, then the kernel.
pub fn with_common(kernel: &str) -> String {
    format!("{COMMON}\n{kernel}")
}
