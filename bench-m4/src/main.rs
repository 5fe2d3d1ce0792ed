//! Instruction counts of the MTTS pipeline on a Cortex-M4F, under QEMU (`scripts/bench-m4`).
//!
//! Runs on QEMU's `mps2-an386` machine with `-icount shift=10,sleep=off`: every instruction
//! takes 2^10 ns of virtual time, and the FPGAIO counter (0x4002_8018) ticks at 25 MHz, so
//! instructions = ticks · 40 / 1024, exact to a fraction of an instruction. A loop of known
//! length checks that. Output goes through semihosting, one line per stage:
//! `<stage> insns=<N>` (the MTTS stages, the control step, the state observer's calls), plus
//! the work-precision lines `host-sim mtts-wp --m4` reads:
//! `wp_mtts scale=S method=M insns=N` and `wp_roots variant=V to768_insns=N`.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod bench;
#[cfg(target_os = "none")]
mod roots;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("thermorph-bench-m4 runs under QEMU: scripts/bench-m4");
    std::process::exit(2);
}
