//! The board's stack-free `HardFault` entry, on an overflowed stack (see the library).
#![no_std]
#![no_main]

use thermorph_hardfault_proof::{PROGRAM, after_fault, run};

/// The board's fault module again, for its `stack_free_hardfault!` (a macro of this crate's
/// own); the library's copy has the types.
#[path = "../../../../firmware/src/bin/board/fault.rs"]
#[allow(unused)]
mod fault;

fault::stack_free_hardfault!(PROGRAM, after_fault);

#[cortex_m_rt::entry]
fn main() -> ! {
    run()
}
