//! The fault path: every panic, hard fault and unexpected interrupt first drives the heater,
//! fan and spring gates and the spring power enable low, then prints over RTT (once), then
//! stops at a breakpoint under a debugger or resets the chip.
//!
//! # A hard fault may find no stack
//!
//! flip-link puts the stack at the bottom of RAM, below the statics, so a stack overflow runs
//! off the start of RAM (`_stack_end`, 0x2000_0000) into a bus fault. The exception entry's own
//! push of its frame then fails too (CFSR.STKERR), and the hard fault handler starts
//! with MSP below RAM: its first `push` — the prologue of any Rust function — faults again, at
//! hard fault priority, and the core locks up with the gates as they were (a PWM keeps
//! switching the heater) until the independent watchdog resets it, or for ever before the
//! watchdog is started.
//!
//! So the `HardFault` vector is the assembly of [`stack_free_hardfault!`], which touches no
//! memory but the registers it updates (the program's and FPCCR) and its own code and data in
//! flash:
//!
//! 1. it runs the board's [`OffProgram`] (`pins::OUTPUTS_OFF`: the GPIO registers of the gate
//!    pins and the spring power enable, and the PWM timers' compare registers) through
//!    `thermorph_outputs_off`, a leaf routine that uses r0–r3 and r12 only;
//! 2. it cancels a pending lazy save of the FPU registers (FPCCR.LSPACT): its address, FPCAR,
//!    lies on the dead stack, and the first floating-point instruction in Rust would fault on it;
//! 3. it points MSP back at the top of the stack (`_stack_start`, where the reset vector starts
//!    it), and only then
//! 4. calls the Rust continuation with the fault's MSP and EXC_RETURN.
//!
//! The panic and default handlers run the same program through the same routine before
//! anything else. `scripts/hardfault-proof` runs this entry under QEMU on an overflowed stack
//! (`bench-m4/hardfault-proof`), with the board's own program, and checks that the board's
//! `HardFault` machine code is the one it ran.
//!
//! This file is also compiled by that proof: its board half (the handlers and the continuation,
//! which use defmt, cortex-m and `pins`) is under `feature = "board"`, which the
//! `thermorph-board` binary always has (`required-features`) and the proof never has.

/// The most register writes an [`OffProgram`] holds.
pub const MAX_WRITES: usize = 12;

/// One register update of an [`OffProgram`]: `*addr = (*addr & !clear) | set`.
#[derive(Clone, Copy)]
#[repr(C)]
pub struct RegWrite {
    /// The register's address.
    pub addr: u32,
    /// Bits cleared (all of them for a plain write).
    pub clear: u32,
    /// Bits set after the clear.
    pub set: u32,
}

/// What turns the outputs off, as data in flash: `len` register updates, in order. The
/// stack-free `HardFault` entry and [`outputs_off`] run it with the same code
/// (`thermorph_outputs_off`); the layout is that code's.
#[repr(C)]
pub struct OffProgram {
    /// How many of `writes` run.
    pub len: u32,
    /// The updates, `len` of them first.
    pub writes: [RegWrite; MAX_WRITES],
}

/// STM32F4 register addresses (RM0390, the STM32F446's reference manual).
mod stm32f4 {
    /// GPIOA; port n (A = 0) is 0x400 · n above.
    pub const GPIO_BASE: u32 = 0x4002_0000;
    /// Ports A to H.
    pub const GPIO_PORTS: usize = 8;
    /// GPIOx_MODER: two bits a pin, 0b01 general-purpose output.
    pub const MODER: u32 = 0x00;
    /// GPIOx_BSRR: bit 16 + n clears pin n's output (write only).
    pub const BSRR: u32 = 0x18;
    /// TIMx_CCMR1 (channels 1, 2); CCMR2 (3, 4) follows.
    pub const CCMR1: u32 = 0x18;
    /// TIMx_CCR1; CCR2–CCR4 follow.
    pub const CCR1: u32 = 0x34;
    /// OCxM = 0b100: the channel's reference is forced to its inactive level, at once (OCxM is
    /// not preloaded, unlike CCRx).
    pub const OCM_FORCE_INACTIVE: u32 = 0b100;

    /// A timer with four capture/compare channels, by name.
    pub const fn timer(name: &str) -> u32 {
        match name.as_bytes() {
            b"TIM1" => 0x4001_0000,
            b"TIM2" => 0x4000_0000,
            b"TIM3" => 0x4000_0400,
            b"TIM4" => 0x4000_0800,
            b"TIM5" => 0x4000_0C00,
            b"TIM8" => 0x4001_0400,
            _ => panic!("not a four-channel STM32F4 timer"),
        }
    }

    /// `"Ch1"` … `"Ch4"` → 1 … 4.
    pub const fn channel(name: &str) -> u32 {
        match name.as_bytes() {
            [b'C', b'h', n @ b'1'..=b'4'] => (*n - b'0') as u32,
            _ => panic!("not a timer channel (Ch1 to Ch4)"),
        }
    }

    /// `"PB10"` → (1, 10).
    pub const fn pin(name: &str) -> (usize, u32) {
        let b = name.as_bytes();
        assert!(
            b.len() >= 3 && b.len() <= 4 && b[0] == b'P',
            "not a pin name"
        );
        assert!(
            b[1] >= b'A' && b[1] < b'A' + GPIO_PORTS as u8,
            "no such port"
        );
        let mut n = 0;
        let mut i = 2;
        while i < b.len() {
            assert!(b[i].is_ascii_digit(), "not a pin name");
            n = n * 10 + (b[i] - b'0') as u32;
            i += 1;
        }
        assert!(n < 16, "no such pin");
        ((b[1] - b'A') as usize, n)
    }
}

impl OffProgram {
    const EMPTY: Self = OffProgram {
        len: 0,
        writes: [RegWrite {
            addr: 0,
            clear: 0,
            set: 0,
        }; MAX_WRITES],
    };

    const fn then(mut self, addr: u32, clear: u32, set: u32) -> Self {
        assert!(
            (self.len as usize) < MAX_WRITES,
            "OffProgram: too many writes"
        );
        self.writes[self.len as usize] = RegWrite { addr, clear, set };
        self.len += 1;
        self
    }

    /// The STM32F4 program that turns off `gates` (pin names, `"PA6"`) and the timer channels
    /// `pwm` (`("TIM3", "Ch1")`) driving some of them:
    ///
    /// 1. every gate pin's output low (one BSRR write a port) — the springs are off;
    /// 2. every PWM channel forced inactive (OCxM) and its compare value 0 — the heater and fan
    ///    are off while their pins are still the timers';
    /// 3. every gate pin a general-purpose output (MODER), so it holds the low of step 1
    ///    whatever its timer does next.
    ///
    /// A port whose clock is off ignores the writes; its pins are then still the floating inputs
    /// of reset, held low by the gates' pull-downs.
    pub const fn stm32f4(gates: &[&str], pwm: &[(&str, &str)]) -> Self {
        use stm32f4::*;
        let mut low = [0u32; GPIO_PORTS];
        let mut i = 0;
        while i < gates.len() {
            let (port, pin) = pin(gates[i]);
            low[port] |= 1 << pin;
            i += 1;
        }
        let mut p = Self::EMPTY;
        let mut port = 0;
        while port < GPIO_PORTS {
            if low[port] != 0 {
                p = p.then(
                    GPIO_BASE + 0x400 * port as u32 + BSRR,
                    u32::MAX,
                    low[port] << 16,
                );
            }
            port += 1;
        }
        let mut i = 0;
        while i < pwm.len() {
            let (base, ch) = (timer(pwm[i].0), channel(pwm[i].1));
            let ccmr = base + CCMR1 + 4 * ((ch - 1) / 2);
            let shift = 4 + 8 * ((ch - 1) % 2);
            p = p.then(ccmr, 0b111 << shift, OCM_FORCE_INACTIVE << shift);
            p = p.then(base + CCR1 + 4 * (ch - 1), u32::MAX, 0);
            i += 1;
        }
        let mut port = 0;
        while port < GPIO_PORTS {
            if low[port] != 0 {
                let (mut clear, mut set, mut pin) = (0u32, 0u32, 0);
                while pin < 16 {
                    if low[port] & (1 << pin) != 0 {
                        clear |= 0b11 << (2 * pin);
                        set |= 0b01 << (2 * pin);
                    }
                    pin += 1;
                }
                p = p.then(GPIO_BASE + 0x400 * port as u32 + MODER, clear, set);
            }
            port += 1;
        }
        p
    }
}

/// The `HardFault` entry that needs no stack, and `thermorph_outputs_off`, as one block of
/// assembly: `stack_free_hardfault!(PROGRAM, continuation)`, where `PROGRAM` is a `static`
/// [`OffProgram`] and `continuation` an `extern "C" fn(msp: u32, exc_return: u32) -> !`
/// (`msp`: MSP when the handler started, the exception frame's address if it could be
/// pushed). Expand it once per binary.
///
/// The code is the same in every binary (`scripts/hardfault-proof` compares it byte for byte);
/// only the last three words, the literal pool (`PROGRAM`, `_stack_start`, `continuation`),
/// differ.
macro_rules! stack_free_hardfault {
    ($program:path, $continuation:path) => {
        core::arch::global_asm!(
            ".pushsection .HardFault.stack_free, \"ax\", %progbits",
            ".syntax unified",
            ".thumb",
            ".p2align 2",
            ".global HardFault",
            ".type HardFault, %function",
            ".thumb_func",
            "HardFault:",
            // Registers only, from here to the `msr msp`: MSP may lie below RAM.
            "  mrs r4, msp",
            "  mov r5, lr",
            "  ldr r0, 3f",
            "  bl thermorph_outputs_off",
            // FPCCR.LSPACT: no lazy FPU save onto the dead stack.
            "  ldr r0, 2f",
            "  ldr r1, [r0]",
            "  bic r1, r1, #1",
            "  str r1, [r0]",
            "  ldr r0, 4f",
            "  msr msp, r0",
            "  mov r0, r4",
            "  mov r1, r5",
            "  ldr r2, 5f",
            "  blx r2",
            "  udf #0",
            ".p2align 2",
            "2: .word 0xE000EF34",
            "3: .word {program}",
            "4: .word _stack_start",
            "5: .word {continuation}",
            ".size HardFault, . - HardFault",
            "",
            // r0: &OffProgram. Clobbers r0-r3, r12; no stack.
            ".global thermorph_outputs_off",
            ".type thermorph_outputs_off, %function",
            ".thumb_func",
            "thermorph_outputs_off:",
            "  ldr r1, [r0], #4",
            "1: subs r1, r1, #1",
            "  bmi 6f",
            "  ldr r2, [r0], #4",
            "  ldr r3, [r2]",
            "  ldr r12, [r0], #4",
            "  bic r3, r3, r12",
            "  ldr r12, [r0], #4",
            "  orr r3, r3, r12",
            "  str r3, [r2]",
            "  b 1b",
            "6: dsb sy",
            "  bx lr",
            ".size thermorph_outputs_off, . - thermorph_outputs_off",
            ".popsection",
            program = sym $program,
            continuation = sym $continuation,
        );
    };
}
pub(crate) use stack_free_hardfault;

unsafe extern "C" {
    /// Run an [`OffProgram`] (defined by [`stack_free_hardfault!`]).
    fn thermorph_outputs_off(program: &OffProgram);
}

/// Run `program` now: the panic and default handlers' first step, with the code the
/// `HardFault` entry runs.
///
/// # Safety
///
/// Takes the outputs from their drivers: call it only where no other code drives them
/// afterwards.
pub unsafe fn outputs_off(program: &'static OffProgram) {
    // SAFETY: the routine writes only the program's registers and uses no stack; the caller
    // guarantees that nothing else drives those outputs any more.
    unsafe { thermorph_outputs_off(program) }
}

#[cfg(feature = "board")]
mod handlers {
    use core::sync::atomic::{AtomicBool, Ordering};

    use defmt::error;

    use super::super::pins::OUTPUTS_OFF;
    use super::outputs_off;

    super::stack_free_hardfault!(OUTPUTS_OFF, after_hard_fault);

    /// Set by the first panic or fault: a second one (say, a panic inside the logger while it
    /// prints the first) skips the printing.
    static FAILING: AtomicBool = AtomicBool::new(false);

    /// Turn the outputs off first, then report (once), then halt for the debugger or reset the
    /// chip.
    fn fail_safe(report: impl FnOnce()) -> ! {
        // SAFETY: called only from the panic and fault handlers, after which no task runs.
        unsafe { outputs_off(&OUTPUTS_OFF) };
        if !FAILING.swap(true, Ordering::AcqRel) {
            report();
        }
        halt_or_reset()
    }

    fn halt_or_reset() -> ! {
        if cortex_m::peripheral::DCB::is_debugger_attached() {
            // probe-rs stops here and prints the backtrace.
            cortex_m::asm::bkpt();
        }
        // No debugger (or it resumed): reset at once rather than wait for a watchdog that may
        // not be running yet. The gate pull-downs hold the loads off through the reset.
        cortex_m::peripheral::SCB::sys_reset()
    }

    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        // The outputs go off before the message is formatted.
        fail_safe(|| error!("panic, outputs off: {}", defmt::Display2Format(info)))
    }

    /// Where the stack-free `HardFault` entry continues (any fault, a stack overflow
    /// included), on a fresh stack and with the outputs off: `msp` is where the fault left the
    /// stack — below `_stack_end`, the start of RAM, after an overflow.
    unsafe extern "C" fn after_hard_fault(msp: u32, exc_return: u32) -> ! {
        unsafe extern "C" {
            static _stack_end: u32;
        }
        let stack_end = core::ptr::addr_of!(_stack_end) as u32;
        // SAFETY: CFSR, a read-only use of a System Control Block register.
        let cfsr = unsafe { core::ptr::read_volatile(0xE000_ED28 as *const u32) };
        fail_safe(|| {
            error!(
                "hard fault{}: MSP {=u32:#010x}, EXC_RETURN {=u32:#010x}, CFSR {=u32:#010x}; outputs off",
                if msp < stack_end {
                    " (stack overflow)"
                } else {
                    ""
                },
                msp,
                exc_return,
                cfsr
            )
        })
    }

    /// An interrupt or exception without a handler.
    #[cortex_m_rt::exception]
    unsafe fn DefaultHandler(irqn: i16) -> ! {
        fail_safe(|| error!("unexpected interrupt or exception {}, outputs off", irqn))
    }
}
