//! The build's git revision, for the records' `computed_by` (which code wrote them):
//! `PRESTON_GIT_REVISION`, the commit's first 12 hex digits (or the revision given in that
//! environment variable, as the container build does), or `unknown` outside a git checkout. Uncommitted changes are not marked: watching the work tree
//! would rebuild the crate on every `git status`.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    // A build without the repository (a container image's) is told the revision instead.
    println!("cargo:rerun-if-env-changed=PRESTON_GIT_REVISION");
    let revision = std::env::var("PRESTON_GIT_REVISION")
        .ok()
        .filter(|r| !r.is_empty())
        .or_else(|| git(&["rev-parse", "--short=12", "HEAD"]))
        .unwrap_or_else(|| "unknown".to_string());
    println!("cargo:rustc-env=PRESTON_GIT_REVISION={revision}");
    // A new commit or checkout moves HEAD or the branch it names.
    for path in [".git/HEAD", ".git/packed-refs"] {
        println!("cargo:rerun-if-changed={path}");
    }
    if let Some(reference) = git(&["symbolic-ref", "-q", "HEAD"]) {
        println!("cargo:rerun-if-changed=.git/{reference}");
    }
}
