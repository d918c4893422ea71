//! Records the commit the binary was built from (`FLUXSWARM_COMMIT`, shown by `info` and kept in
//! every sweep record): `git rev-parse --short=12 HEAD`, with `-dirty` when tracked files differ,
//! "unknown" outside a git checkout, or the value of FLUXSWARM_COMMIT given to the build.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    println!("cargo:rerun-if-env-changed=FLUXSWARM_COMMIT");
    println!("cargo:rerun-if-changed=build.rs");
    let commit = match std::env::var("FLUXSWARM_COMMIT") {
        Ok(c) if !c.is_empty() => c,
        _ => match git(&["rev-parse", "--short=12", "HEAD"]) {
            Some(c) => {
                let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                    .is_some_and(|s| !s.is_empty());
                if dirty { format!("{c}-dirty") } else { c }
            }
            None => "unknown".into(),
        },
    };
    println!("cargo:rustc-env=FLUXSWARM_COMMIT={commit}");
    // Rerun when the sources change (they rebuild the crate anyway, and may make it dirty), HEAD
    // moves (a commit, a checkout) or the index changes.
    for dir in ["src", "shaders", "configs", "Cargo.toml"] {
        println!("cargo:rerun-if-changed={dir}");
    }
    let (Some(git_dir), Some(common)) = (
        git(&["rev-parse", "--git-dir"]),
        git(&["rev-parse", "--git-common-dir"]),
    ) else {
        return;
    };
    let mut watch = vec![format!("{git_dir}/HEAD"), format!("{git_dir}/index")];
    if let Some(r) = git(&["symbolic-ref", "-q", "HEAD"]) {
        watch.push(format!("{common}/{r}"));
    }
    watch.push(format!("{common}/packed-refs"));
    for path in watch {
        if std::path::Path::new(&path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    }
}
