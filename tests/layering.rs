//! Dependencies point one way (STYLE item 11): CLI -> (runner, learn, env, report, output) ->
//! sim -> gpu. A source file under `src/<layer>/` may not name a module its layer must not know:
//! the learner knows no environment, simulation or GPU; the simulation knows nothing above it;
//! the GPU plumbing knows nothing of simulation, environments or learning; nothing in the
//! library names the CLI. Checked on the source text (`crate::<module>` paths), so a forbidden
//! import fails here before review.

use std::path::{Path, PathBuf};

/// (directory under src/, modules it must not name).
const RULES: &[(&str, &[&str])] = &[
    (
        "learn",
        &["env", "sim", "gpu", "report", "output", "rollout", "cli"],
    ),
    (
        "sim",
        &[
            "env", "learn", "report", "output", "rollout", "cli", "testing",
        ],
    ),
    (
        "gpu",
        &[
            "sim", "env", "learn", "report", "output", "rollout", "cli", "testing",
        ],
    ),
    ("env", &["report", "output", "rollout", "cli"]),
    ("output", &["cli", "report", "rollout"]),
    ("rollout", &["cli", "report", "sweep", "testing"]),
    ("report", &["cli", "sim", "gpu"]),
    (
        "sweep",
        &["cli", "sim", "gpu", "env", "learn", "report", "testing"],
    ),
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Every `file: line` of `src` that names a module its layer may not know.
fn violations(src: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for (layer, forbidden) in RULES {
        let mut files = Vec::new();
        rust_files(&src.join(layer), &mut files);
        for file in files {
            let text = std::fs::read_to_string(&file).unwrap();
            for (n, line) in text.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                for module in *forbidden {
                    if code.contains(&format!("crate::{module}::"))
                        || code.contains(&format!("crate::{module};"))
                        || code.contains(&format!("crate::{module}::{{"))
                    {
                        found.push(format!(
                            "{}:{}: {layer} names {module}",
                            file.display(),
                            n + 1
                        ));
                    }
                }
            }
        }
    }
    found
}

#[test]
fn dependencies_point_one_way() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let found = violations(&src);
    assert!(found.is_empty(), "forbidden imports:\n{}", found.join("\n"));
}

#[test]
fn a_forbidden_import_is_found() {
    let dir = tempfile::tempdir().unwrap();
    let learn = dir.path().join("learn");
    std::fs::create_dir_all(&learn).unwrap();
    std::fs::write(
        learn.join("bad.rs"),
        "// crate::env::x in a comment is fine\nuse crate::env::SwarmEnv;\n",
    )
    .unwrap();
    let found = violations(dir.path());
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].ends_with("bad.rs:2: learn names env"), "{found:?}");
}

/// `anyhow` belongs to the binary (`main.rs`, `cli/`): the library's modules return their own
/// typed errors (issue 17, STYLE).
#[test]
fn the_library_uses_typed_errors_not_anyhow() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let found: Vec<String> = files
        .iter()
        .filter(|f| !f.starts_with(src.join("cli")) && !f.ends_with("main.rs"))
        .filter(|f| {
            std::fs::read_to_string(f)
                .unwrap()
                .lines()
                .any(|l| l.split("//").next().unwrap_or("").contains("anyhow"))
        })
        .map(|f| f.display().to_string())
        .collect();
    assert!(
        found.is_empty(),
        "anyhow in library code:\n{}",
        found.join("\n")
    );
}
