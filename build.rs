//! Records the git commit the binary is built from, for `imunoise --version`.
//!
//! Re-runs only when HEAD or a branch moves, so that editing sources does not re-run it; a build
//! from a source tree without git (a crate tarball) says `unknown`.

use std::path::Path;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
        .filter(|s| !s.is_empty())
}

fn main() {
    let commit = git(&["rev-parse", "--short=12", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let date = git(&["show", "-s", "--format=%cs", "HEAD"]).unwrap_or_default();
    println!("cargo:rustc-env=IMUNOISE_COMMIT={commit}");
    println!("cargo:rustc-env=IMUNOISE_COMMIT_DATE={date}");
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        let dir = Path::new(&dir);
        for watched in ["HEAD", "refs/heads", "packed-refs"] {
            let p = dir.join(watched);
            if p.exists() {
                println!("cargo:rerun-if-changed={}", p.display());
            }
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
}
