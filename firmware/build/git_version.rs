//! The git commit a package directory was built from, asked of `git` itself: shared by
//! `firmware/build.rs` (the board's console `version`), `host-sim/build.rs` (which hands it to
//! the host binaries as environment variables) and the test that checks it on scratch
//! repositories (`host-sim/tests/cli.rs`).

use std::path::{Path, PathBuf};
use std::process::Command;

/// What `git` says about the checkout that holds a package directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GitVersion {
    /// The commit's short hash, with `-dirty` when a tracked file differed from it.
    pub commit: String,
    /// The commit's date (committer date, `YYYY-MM-DD`).
    pub date: String,
    /// The files that change when the checkout moves to another commit: `HEAD` and the ref it
    /// points to (a branch's file, or `packed-refs` once git has packed it). Only existing
    /// files: cargo reruns a build script on every build while a watched path is missing.
    pub watch: Vec<PathBuf>,
}

/// `git -C dir ARGS`, its standard output trimmed; `None` if git is missing or fails.
fn git(dir: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    Some(String::from_utf8(out.stdout).ok()?.trim().to_string())
}

/// The commit `dir` (a package directory, holding its `Cargo.toml`) was checked out at, or
/// `None` outside a git checkout of that package: no `git`, no repository, or a repository
/// that does not track `dir/Cargo.toml` (a crates tarball unpacked inside some other
/// repository).
pub fn describe(dir: &Path) -> Option<GitVersion> {
    git(dir, &["ls-files", "--error-unmatch", "Cargo.toml"])?;
    let hash = git(dir, &["rev-parse", "--short", "HEAD"]).filter(|h| !h.is_empty())?;
    let date = git(dir, &["log", "-1", "--date=short", "--format=%cd", "HEAD"])
        .filter(|d| !d.is_empty())?;
    // Tracked files only (as `git describe --dirty`); `--no-optional-locks`: never rewrite the
    // index to refresh it, which another process (and cargo's watch on it) would see.
    let status = git(
        dir,
        &[
            "--no-optional-locks",
            "status",
            "--porcelain",
            "--untracked-files=no",
        ],
    )?;
    let commit = if status.is_empty() {
        hash
    } else {
        format!("{hash}-dirty")
    };
    // In a linked worktree `.git` is a file: HEAD is in the worktree's own git directory, the
    // branches in the common one.
    let absolute = |p: String| {
        let p = PathBuf::from(p);
        if p.is_absolute() { p } else { dir.join(p) }
    };
    let git_dir = absolute(git(dir, &["rev-parse", "--git-dir"])?);
    let common_dir = absolute(git(dir, &["rev-parse", "--git-common-dir"])?);
    let mut watch = vec![git_dir.join("HEAD")];
    if let Some(branch) = git(dir, &["symbolic-ref", "-q", "HEAD"]) {
        watch.push(common_dir.join(branch));
        watch.push(common_dir.join("packed-refs"));
    }
    watch.retain(|p| p.exists());
    Some(GitVersion {
        commit,
        date,
        watch,
    })
}

/// [`describe`] as a build script wants it: the commit and its date (`unknown` for both outside
/// a git checkout), with cargo told to rerun the script when the checkout moves
/// ([`GitVersion::watch`]). Shared by `firmware/build.rs` and `host-sim/build.rs`; the tests
/// that include this file ask [`describe`] alone.
#[allow(dead_code)]
pub fn for_build(dir: &Path) -> (String, String) {
    match describe(dir) {
        Some(g) => {
            for p in &g.watch {
                println!("cargo:rerun-if-changed={}", p.display());
            }
            (g.commit, g.date)
        }
        None => ("unknown".to_string(), "unknown".to_string()),
    }
}
