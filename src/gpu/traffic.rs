//! Which bound buffers each kernel reads and writes, taken from the shaders themselves: naga's
//! validator records, per entry point, the use of every global (READ, WRITE). `bench` multiplies
//! these by the buffers' sizes to give the bytes a control step moves at least once (compulsory
//! traffic: stencil neighbours are assumed to hit the cache).
//! Every entry point's module binds only what the entry point touches (the samplers are
//! instantiated per velocity source), so naga's sets are exact; [`READ_OVERRIDES`] only drops
//! reads too small to count.

use naga::valid::{Capabilities, GlobalUse, ValidationFlags, Validator};

use super::kernels::FieldBinding;
use super::shaders;

/// Reads left out of the traffic model: `move_members` samples a few cells of u, v and p per
/// member, negligible beside its member buffers.
pub const READ_OVERRIDES: [(&str, &[FieldBinding]); 1] = {
    use FieldBinding::*;
    [("move_members", &[Members, Thrust])]
};

/// The bindings (group 0) an entry point reads and writes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KernelAccess {
    /// Entry point name.
    pub entry: String,
    /// Storage bindings it reads (uniforms 0 and 1 left out).
    pub reads: Vec<u32>,
    /// Storage bindings it writes.
    pub writes: Vec<u32>,
}

/// Accesses of every entry point of every fluid shader module.
pub fn kernel_accesses() -> Vec<KernelAccess> {
    let mut out = Vec::new();
    for (name, source) in shaders::all_modules() {
        if matches!(name, "common.wgsl" | "sample.wgsl" | "loop_probe.wgsl") {
            continue;
        }
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{name} parses (tested in shader_validation): {e}"));
        let info = Validator::new(ValidationFlags::all(), Capabilities::all())
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name} validates: {e:?}"));
        for (index, ep) in module.entry_points.iter().enumerate() {
            let uses = info.get_entry_point(index);
            let mut access = KernelAccess {
                entry: ep.name.clone(),
                reads: Vec::new(),
                writes: Vec::new(),
            };
            for (handle, var) in module.global_variables.iter() {
                let Some(binding) = &var.binding else {
                    continue;
                };
                let u = uses[handle];
                if u.contains(GlobalUse::READ) {
                    access.reads.push(binding.binding);
                }
                if u.contains(GlobalUse::WRITE) {
                    access.writes.push(binding.binding);
                }
            }
            if let Some((_, reads)) = READ_OVERRIDES.iter().find(|o| o.0 == ep.name) {
                let reads: Vec<u32> = reads.iter().map(|b| *b as u32).collect();
                assert!(
                    reads.iter().all(|b| access.reads.contains(b)),
                    "{}: override reads {reads:?} outside the shader's {:?}",
                    ep.name,
                    access.reads
                );
                access.reads = reads;
            }
            access.reads.retain(|b| *b > 1); // the uniforms are a few bytes
            out.push(access);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accesses_come_from_the_shaders() {
        let all = kernel_accesses();
        let find = |e: &str| all.iter().find(|k| k.entry == e).unwrap().clone();
        // diffuse: reads u_in (2), v_in (3) and, to paint, members (18) and the swarm box (21);
        // writes w_u (16), w_v (17) and the body field (10).
        let d = find("diffuse");
        assert_eq!(d.reads, [2, 3, 18, 21]);
        assert_eq!(d.writes, [10, 16, 17]);
        // From naga directly: the projection reads u_out, v_out (4, 5) and p (8).
        assert_eq!(find("project").reads, [4, 5, 8]);
        assert_eq!(find("pressure_back").writes, [8]);
        // The correction writes the output velocity (4, 5).
        let c = find("maccormack_correct");
        assert_eq!(c.writes, [4, 5]);
        assert!(c.reads.contains(&6), "reads u_hat: {c:?}");
    }
}
