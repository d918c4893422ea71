//! Every WGSL module parses and validates with naga (no adapter needed); all failures are
//! reported at once.

use fluxswarm_gpu::gpu::shaders;

#[test]
fn every_wgsl_module_parses_and_validates() {
    let mut failures = Vec::new();
    let modules = shaders::all_modules();
    for (name, source) in &modules {
        let module = match naga::front::wgsl::parse_str(source) {
            Ok(m) => m,
            Err(e) => {
                failures.push(format!(
                    "{name}: parse error:\n{}",
                    e.emit_to_string(source)
                ));
                continue;
            }
        };
        let mut validator = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        );
        if let Err(e) = validator.validate(&module) {
            failures.push(format!(
                "{name}: validation error:\n{}",
                e.emit_to_string(source)
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn every_shader_file_is_built_by_the_program() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let built: Vec<&str> = shaders::all_modules().iter().map(|m| m.0).collect();
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().to_string();
        if name.ends_with(".wgsl") {
            assert!(
                built.contains(&name.as_str()),
                "{name} is not in shaders::all_modules()"
            );
        }
    }
}
