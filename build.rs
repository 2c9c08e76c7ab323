//! Build script: the commit `linterpd --version` names, as `LINTERPD_COMMIT`. From
//! `$LINTERPD_COMMIT` if the packager sets it, else `git rev-parse --short HEAD` when the crate's
//! root is a git checkout, else `unknown` (a crate tarball, no git; never the commit of some other
//! repository the sources sit in).

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    if !std::path::Path::new(".git").exists() {
        return None;
    }
    let out = Command::new("git").args(args).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?;
    (out.status.success() && !text.trim().is_empty()).then(|| text.trim().to_owned())
}

fn main() {
    println!("cargo:rerun-if-env-changed=LINTERPD_COMMIT");
    let commit = std::env::var("LINTERPD_COMMIT")
        .ok()
        .filter(|c| !c.is_empty())
        .or_else(|| git(&["rev-parse", "--short", "HEAD"]));
    // Run again when HEAD moves: a commit or a checkout changes HEAD or the ref it names.
    // (Only files that exist: cargo runs the script on every build for a missing one.)
    let head_ref = git(&["symbolic-ref", "-q", "HEAD"]);
    let watched = ["HEAD", "packed-refs"]
        .into_iter()
        .chain(head_ref.as_deref())
        .filter_map(|file| git(&["rev-parse", "--git-path", file]))
        .filter(|path| std::path::Path::new(path).exists());
    for path in watched {
        println!("cargo:rerun-if-changed={path}");
    }
    let commit = commit.unwrap_or_else(|| "unknown".to_owned());
    println!("cargo:rustc-env=LINTERPD_COMMIT={commit}");
}
