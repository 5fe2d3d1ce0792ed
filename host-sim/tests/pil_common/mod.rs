//! What the tests of the board's ELF on the emulated STM32F446 share: where the ELF is, and
//! what its `version` must say.

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

#[path = "../../../firmware/build/git_version.rs"]
#[allow(dead_code)]
mod git_version;

/// `reply` is the ELF's answer to `version`: `ok thermorph VERSION (HASH DATE)`, the build
/// [`assert_this_build`] checks. (Not every test crate that shares this module asks.)
#[allow(dead_code)]
pub fn assert_names_its_build(reply: &str) {
    let prefix = format!("ok thermorph {} (", env!("CARGO_PKG_VERSION"));
    let build = reply
        .strip_prefix(prefix.as_str())
        .and_then(|r| r.strip_suffix(')'))
        .unwrap_or_else(|| panic!("`version` answers {reply:?}, not {prefix}HASH DATE)"));
    assert_this_build(build);
}

/// `build` is `HASH DATE` of this checkout's commit (its `-dirty` mark aside: an edit of the
/// docs alone rebuilds nothing), the date `YYYY-MM-DD`.
#[allow(dead_code)]
pub fn assert_this_build(build: &str) {
    let firmware = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../firmware");
    let (hash, date) = build
        .split_once(' ')
        .unwrap_or_else(|| panic!("{build:?}: not HASH DATE"));
    let d: Vec<&str> = date.split('-').collect();
    assert!(
        d.len() == 3 && d.iter().all(|p| p.bytes().all(|b| b.is_ascii_digit())),
        "{build:?}: the date"
    );
    let here = git_version::describe(&firmware).expect("the tests run in a git checkout");
    assert_eq!(
        hash.trim_end_matches("-dirty"),
        here.commit.trim_end_matches("-dirty"),
        "{build:?}: the ELF was built from another commit; rebuild it"
    );
    assert_eq!(date, here.date, "{build:?}");
}
