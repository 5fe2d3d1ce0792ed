//! Put the workspace root, where `memory.x` lives, on the linker's search path for the board.

fn main() {
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let manifest = std::path::PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
        let root = manifest.parent().expect("firmware/ sits in the workspace");
        // Only this package's binaries: a search path would propagate to every crate that
        // depends on the library (the QEMU bench links its own memory map).
        println!("cargo:rustc-link-arg-bins=-L{}", root.display());
        println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    }
    println!("cargo:rerun-if-changed=build.rs");
}
