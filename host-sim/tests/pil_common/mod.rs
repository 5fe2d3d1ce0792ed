//! What the tests of the board's ELF on the emulated STM32F446 share: where the ELF is.

use std::path::PathBuf;

/// The board's release ELF (`CARGO_TARGET_DIR`, else the workspace's `target/`); a missing one
/// fails with the command that builds it.
pub fn elf() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"),
        PathBuf::from,
    );
    let p = target.join("thumbv7em-none-eabihf/release/thermorph-board");
    assert!(
        p.exists(),
        "{} is missing: build it with `cargo build --release -p thermorph-firmware --target \
         thumbv7em-none-eabihf --bin thermorph-board`",
        p.display()
    );
    p
}
