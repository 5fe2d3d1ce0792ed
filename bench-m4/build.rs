//! Build script of the QEMU bench: the mps2-an386 memory map, and the bench's input — the
//! realistic virtual sensor's EEPROM and two raw subpages of a rendered heating scene, made by
//! the simulator's encoder so the bench decodes real raw words.

use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    std::fs::write(
        out.join("memory.x"),
        "/* QEMU mps2-an386: 4 MiB code SRAM at 0, 4 MiB data SRAM at 0x20000000. */\n\
         MEMORY\n{\n  FLASH : ORIGIN = 0x00000000, LENGTH = 4M\n  \
         RAM : ORIGIN = 0x20000000, LENGTH = 4M\n}\n",
    )
    .unwrap();
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        println!("cargo:rustc-link-search={}", out.display());
    }

    let (eeprom, frames) = host_sim::sensor::demo::bench_input("heating-358").unwrap();
    let mut src = String::new();
    let words = |src: &mut String, name: &str, w: &[u16]| {
        write!(
            src,
            "/// Generated.\npub static {name}: [u16; {}] = [",
            w.len()
        )
        .unwrap();
        for x in w {
            write!(src, "{x},").unwrap();
        }
        src.push_str("];\n");
    };
    words(&mut src, "EEPROM", &eeprom);
    words(&mut src, "FRAME0", &frames[0].words);
    words(&mut src, "FRAME1", &frames[1].words);
    std::fs::write(out.join("data.rs"), src).unwrap();
    println!("cargo:rerun-if-changed=build.rs");
}
