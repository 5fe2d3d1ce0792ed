//! The control: the same overflow with a conventional Rust `HardFault` handler, as the board
//! had before. Its first push faults at hard fault priority and the core locks up: it must
//! print nothing after the overflow, and write no output register.
#![no_std]
#![no_main]

use core::ptr::{read_volatile, write_volatile};

use cortex_m_rt::{ExceptionFrame, entry, exception};
use thermorph_hardfault_proof::{PROGRAM, after_fault, fault::RegWrite, run};

#[entry]
fn main() -> ! {
    run()
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    outputs_off();
    after_fault(frame as *const ExceptionFrame as u32, 0)
}

/// The outputs-off program in Rust, as a handler would run it.
#[inline(never)]
fn outputs_off() {
    for w in &PROGRAM.writes[..PROGRAM.len as usize] {
        update(w);
    }
}

#[inline(never)]
fn update(w: &RegWrite) {
    // SAFETY: a register of the program.
    unsafe {
        let r = w.addr as *mut u32;
        write_volatile(r, (read_volatile(r) & !w.clear) | w.set);
    }
}
