//! Build script of the hard-fault proof: the board's memory map (the workspace's `memory.x`,
//! which flip-link turns around as for the board) and the board's outputs-off program, as
//! `scripts/hardfault-proof` took it from the board's ELF (`HARDFAULT_PROOF_PROGRAM`: a file of
//! hexadecimal words, `len` then `addr clear set` triples).

use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let root = manifest
        .ancestors()
        .nth(2)
        .expect("bench-m4/hardfault-proof sits in the workspace");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        // A search path of its own (`-L dir`, two arguments): flip-link looks there for the
        // script that has the RAM region.
        println!("cargo:rustc-link-search={}", root.display());
    }
    println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=HARDFAULT_PROOF_PROGRAM");

    let path = std::env::var("HARDFAULT_PROOF_PROGRAM").expect(
        "HARDFAULT_PROOF_PROGRAM: the board's outputs-off program; run scripts/hardfault-proof",
    );
    println!("cargo:rerun-if-changed={path}");
    let text = std::fs::read_to_string(&path).unwrap();
    let words: Vec<u32> = text
        .split_whitespace()
        .map(|w| u32::from_str_radix(w.trim_start_matches("0x"), 16).expect("a hex word"))
        .collect();
    let (len, rest) = words.split_first().expect("the program's length");
    assert_eq!(rest.len() % 3, 0, "addr clear set triples");
    let mut src = String::from("crate::fault::OffProgram {\n    len: ");
    write!(src, "{len},\n    writes: [\n").unwrap();
    for w in rest.chunks(3) {
        writeln!(
            src,
            "        crate::fault::RegWrite {{ addr: {:#010x}, clear: {:#010x}, set: {:#010x} }},",
            w[0], w[1], w[2]
        )
        .unwrap();
    }
    src.push_str("    ],\n}\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    std::fs::write(out.join("program.rs"), src).unwrap();
}
