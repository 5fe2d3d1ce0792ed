//! The board's build: put the workspace root, where `memory.x` lives, on the linker's search
//! path, and name the commit it was built from.
//!
//! For the board (target OS `none`) it sets `THERMORPH_BUILD` to the git commit's short hash
//! (`-dirty` when tracked files differed from it) and date, `b98b8ce 2026-11-29`, which the
//! console's `version` reply carries ([`thermorph::BUILD`]); outside a git checkout it says
//! `unknown`. Host builds of the library get none and never rerun this script when the
//! checkout moves: the library is in every host crate, and a commit would rebuild them all.

#[path = "build/git_version.rs"]
mod git_version;

fn main() {
    let manifest = std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let root = manifest.parent().expect("firmware/ sits in the workspace");
        // Only this package's binaries: a search path would propagate to every crate that
        // depends on the library (the QEMU bench links its own memory map).
        println!("cargo:rustc-link-arg-bins=-L{}", root.display());
        println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
        let build = match git_version::for_build(&manifest) {
            (commit, _) if commit == "unknown" => commit,
            (commit, date) => format!("{commit} {date}"),
        };
        // A source edit reruns the script, so the mark says `-dirty`.
        println!("cargo:rerun-if-changed=src");
        println!("cargo:rustc-env=THERMORPH_BUILD={build}");
    }
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=build");
}
