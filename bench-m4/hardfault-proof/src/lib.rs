//! Proof, under QEMU, that the board's `HardFault` entry turns the outputs off with no stack
//! (`scripts/hardfault-proof`, project issue 17 point 7).
//!
//! The machine is QEMU's `netduinoplus2`, an STM32F405: a Cortex-M4F with the STM32F4's
//! memory map, where TIM2–TIM5 are modelled (their registers read back) and the GPIO ports are
//! logged writes (`-d unimp`). The binaries link the board's `memory.x` through flip-link, as
//! the board does: the stack sits at the bottom of RAM and an overflow runs off 0x2000_0000
//! into a bus fault, whose exception frame cannot be pushed either.
//!
//! [`run`] switches every channel of TIM2–TIM5 on (PWM at half duty), uses the FPU (so the fault
//! leaves a lazy FPU save pending, on the dead stack), and recurses until the stack overflows.
//!
//! - `hardfault-proof` takes the hard fault with the board's own entry
//!   (`firmware/src/bin/board/fault.rs`, `stack_free_hardfault!`) and the board's own
//!   outputs-off program (`PROGRAM`, copied from the board's ELF); the entry continues in
//!   [`after_fault`], which reads the state back, prints it and `hardfault-proof: ok`, and exits
//!   0 — or prints `hardfault-proof: error: …` and exits 1.
//! - `hardfault-control` takes it with a conventional Rust handler (the board's before): its
//!   first push faults at hard fault priority, the core locks up, and nothing is printed.
#![no_std]

use core::hint::black_box;
use core::ptr::{read_volatile, write_volatile};

use cortex_m_semihosting::{debug, hprintln};

/// The board's fault path (only its portable half: `feature = "board"` is off here).
#[path = "../../../firmware/src/bin/board/fault.rs"]
#[allow(unused)]
pub mod fault;

/// The board's outputs-off program (`pins::OUTPUTS_OFF`), from its ELF.
pub static PROGRAM: fault::OffProgram = include!(concat!(env!("OUT_DIR"), "/program.rs"));

/// The timers QEMU models on the STM32F405, with their bases.
const TIMERS: [(&str, u32); 4] = [
    ("TIM2", 0x4000_0000),
    ("TIM3", 0x4000_0400),
    ("TIM4", 0x4000_0800),
    ("TIM5", 0x4000_0C00),
];
const CR1: u32 = 0x00;
const CCMR1: u32 = 0x18;
const CCMR2: u32 = 0x1C;
const CCER: u32 = 0x20;
const ARR: u32 = 0x2C;
const CCR1: u32 = 0x34;
/// Both channels of a CCMRx in PWM mode 1 (OCxM = 0b110) with preload (OCxPE).
const CCMR_PWM1: u32 = 0x6868;
/// CFSR (BusFault status: STKERR, LSPERR), HFSR, FPCCR (LSPACT: bit 0).
const CFSR: u32 = 0xE000_ED28;
const HFSR: u32 = 0xE000_ED2C;
const FPCCR: u32 = 0xE000_EF34;
const STKERR: u32 = 1 << 12;
const LSPERR: u32 = 1 << 13;

fn read(addr: u32) -> u32 {
    // SAFETY: a register of the STM32F405 or of the Cortex-M4 that QEMU models.
    unsafe { read_volatile(addr as *const u32) }
}

fn write(addr: u32, value: u32) {
    // SAFETY: as in `read`; these timers drive nothing in QEMU.
    unsafe { write_volatile(addr as *mut u32, value) }
}

unsafe extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// The top of the stack (the reset value of MSP) and its end, the start of RAM.
fn stack() -> (u32, u32) {
    // Linker symbols, of which only the addresses are used.
    (
        core::ptr::addr_of!(_stack_start) as u32,
        core::ptr::addr_of!(_stack_end) as u32,
    )
}

/// Switch the outputs on, then overflow the stack.
pub fn run() -> ! {
    for (_, tim) in TIMERS {
        write(tim + ARR, 999);
        write(tim + CCMR1, CCMR_PWM1);
        write(tim + CCMR2, CCMR_PWM1);
        for ch in 0..4 {
            write(tim + CCR1 + 4 * ch, 500);
        }
        write(tim + CCER, 0x1111);
        write(tim + CR1, 1);
    }
    let (top, end) = stack();
    hprintln!(
        "outputs on (TIM2-TIM5 PWM, every channel at 500/1000); stack {:#010x}..{:#010x}; overflowing it",
        end,
        top
    );
    black_box(recurse(black_box(1.0)));
    fail("the recursion returned")
}

/// A frame of stack a call, until there is none: the result is used after the call, so the
/// calls cannot become a loop. Floating-point, so the FPU is in use at the fault.
#[inline(never)]
fn recurse(x: f32) -> f32 {
    let mut frame = [x; 8];
    black_box(&mut frame);
    if black_box(true) {
        recurse(frame[1] + 1.0) + frame[7]
    } else {
        frame[0]
    }
}

/// Where the stack-free `HardFault` entry continues (`stack_free_hardfault!`'s
/// `continuation`): `msp` is MSP when the handler started.
pub extern "C" fn after_fault(msp: u32, exc_return: u32) -> ! {
    let (top, end) = stack();
    let now: u32;
    // SAFETY: reads the stack pointer.
    unsafe { core::arch::asm!("mrs {}, msp", out(reg) now, options(nomem, nostack)) };
    // A floating-point instruction, before CFSR is read: had the entry left the lazy FPU
    // save pending, it would try to save onto the dead stack here, and fault (LSPERR).
    let half = black_box(black_box(msp as f32) * 0.5);
    let (cfsr, hfsr, fpccr) = (read(CFSR), read(HFSR), read(FPCCR));
    hprintln!(
        "fault: msp={:#010x} exc_return={:#010x} cfsr={:#010x} hfsr={:#010x} fpccr={:#010x}",
        msp,
        exc_return,
        cfsr,
        hfsr,
        fpccr
    );
    hprintln!(
        "continued: msp={:#010x} (stack top {:#010x}, end {:#010x}), fpu {}",
        now,
        top,
        end,
        half as u32
    );
    for (name, tim) in TIMERS {
        let ccr: [u32; 4] = core::array::from_fn(|i| read(tim + CCR1 + 4 * i as u32));
        hprintln!(
            "{} ccmr1={:#06x} ccmr2={:#06x} ccer={:#06x} ccr={:?}",
            name,
            read(tim + CCMR1),
            read(tim + CCMR2),
            read(tim + CCER),
            ccr
        );
    }
    let mut timer_writes = 0;
    for w in &PROGRAM.writes[..PROGRAM.len as usize] {
        if TIMERS
            .iter()
            .any(|&(_, t)| (t..t + 0x400).contains(&w.addr))
        {
            timer_writes += 1;
            if read(w.addr) & w.clear != w.set & w.clear {
                hprintln!("register {:#010x} = {:#010x}", w.addr, read(w.addr));
                fail("a timer register of the program does not hold its value");
            }
        }
    }
    if msp >= end {
        fail("the fault did not find the stack overflowed (MSP within RAM)");
    }
    if cfsr & STKERR == 0 {
        fail("the exception frame was pushed (no CFSR.STKERR): not a dead stack");
    }
    // `now` is below the top by this function's frame only.
    if now >= top || top - now > 1024 {
        fail("MSP was not reset to the top of the stack");
    }
    if exc_return & 0x10 != 0 {
        fail("the FPU was not in use at the fault: no lazy FPU save to cancel");
    }
    if fpccr & 1 != 0 || cfsr & LSPERR != 0 {
        fail("the lazy FPU save was left pending (FPCCR.LSPACT, CFSR.LSPERR)");
    }
    if timer_writes == 0 {
        fail("the program writes no timer register");
    }
    hprintln!("hardfault-proof: ok");
    finish(debug::EXIT_SUCCESS)
}

/// Report a failure and stop QEMU with a failing status.
pub fn fail(what: &str) -> ! {
    hprintln!("hardfault-proof: error: {}", what);
    finish(debug::EXIT_FAILURE)
}

fn finish(code: debug::ExitStatus) -> ! {
    debug::exit(code);
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("hardfault-proof: error: panic: {}", info);
    finish(debug::EXIT_FAILURE)
}
