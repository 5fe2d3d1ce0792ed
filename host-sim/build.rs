//! The build's identity for `host-sim --version`, `host-sim version` and
//! `thermorph-desk --version`: the git commit this package was built from (short hash, with
//! `-dirty` when tracked files differed from it) and its date, as the environment variables
//! `THERMORPH_GIT_COMMIT`, `THERMORPH_GIT_DATE` and `THERMORPH_VERSION` (the crate's version
//! with both). Outside a git checkout (a crates tarball, no `git`) both are `unknown`.
//!
//! It reruns when the checkout moves to another commit (`HEAD` and the branch it points to)
//! and when the sources this package compiles change (its own and the firmware library's), so
//! a build from edited sources says `-dirty`; an edit elsewhere (the docs) rebuilds nothing and
//! so leaves the mark as the last build found it.

#[path = "../firmware/build/git_version.rs"]
mod git_version;

fn main() {
    let manifest = std::path::PathBuf::from(
        std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
    );
    let version = std::env::var("CARGO_PKG_VERSION").expect("cargo sets CARGO_PKG_VERSION");
    let (commit, date) = git_version::for_build(&manifest);
    for p in ["build.rs", "src", "../firmware/src", "../firmware/build"] {
        if manifest.join(p).exists() {
            println!("cargo:rerun-if-changed={p}");
        }
    }
    let long = if commit == "unknown" {
        format!("{version} (git commit unknown)")
    } else {
        format!("{version} ({commit} {date})")
    };
    println!("cargo:rustc-env=THERMORPH_GIT_COMMIT={commit}");
    println!("cargo:rustc-env=THERMORPH_GIT_DATE={date}");
    println!("cargo:rustc-env=THERMORPH_VERSION={long}");
}
