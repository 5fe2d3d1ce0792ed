//! The emulated Cortex-M4 core (`--features pil`) on hand-assembled Thumb code: sleep at `wfe`
//! skips to the next peripheral event, an interrupt is entered and left by the ARMv7-M rules
//! (basic and extended frames), and an access to nothing is recorded.
#![cfg(feature = "pil")]

use host_sim::f446::cpu::{BusFault, Core, FLASH_BASE, SRAM_BASE, SRAM_BYTES};
use host_sim::f446::{Bus, Clocks, Memory, Size, TIME_HZ, Time};
use unicorn_engine::RegisterARM;

/// A peripheral at 0x4000_0000 whose interrupt line (IRQ 0) rises at `at` and falls when
/// software writes its register; the writes are kept. It asks for a chip reset (as a watchdog
/// does) once, at `reset_at`.
struct TestBus {
    at: Time,
    raised: bool,
    cleared: bool,
    writes: Vec<(u32, u32, Time)>,
    reset_at: Time,
    reset_due: bool,
}

impl Bus for TestBus {
    fn read(&mut self, addr: u32, _: Size, _: Time, _: &mut dyn Memory) -> Option<u32> {
        (addr == 0x4000_0000).then_some(0x5A)
    }

    fn write(&mut self, addr: u32, _: Size, value: u32, now: Time, _: &mut dyn Memory) -> bool {
        if addr != 0x4000_0000 {
            return false;
        }
        self.writes.push((addr, value, now));
        self.cleared = true;
        true
    }

    fn advance(&mut self, now: Time, _: &mut dyn Memory) {
        if now >= self.at {
            self.raised = true;
        }
        if now >= self.reset_at {
            self.reset_due = true;
            self.reset_at = Time::MAX;
        }
    }

    fn next_event(&self, now: Time) -> Option<Time> {
        [self.at, self.reset_at]
            .into_iter()
            .filter(|&t| now < t)
            .min()
    }

    fn clocks(&self) -> Clocks {
        Clocks {
            sysclk_hz: 180_000_000,
            hclk_hz: 180_000_000,
            ..Clocks::RESET
        }
    }

    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        line(0, self.raised && !self.cleared);
    }

    fn take_reset(&mut self) -> bool {
        std::mem::take(&mut self.reset_due)
    }

    fn software_reset(&mut self) {}
}

/// What software wrote to the test peripheral.
fn written(c: &Core) -> Vec<u32> {
    let bus = c.bus_as::<TestBus>().expect("built on a TestBus");
    bus.writes.iter().map(|w| w.1).collect()
}

/// Halfwords as little-endian bytes.
fn code(hw: &[u16]) -> Vec<u8> {
    hw.iter().flat_map(|h| h.to_le_bytes()).collect()
}

/// An image: the vector table (SP at the top of SRAM, reset at 0x100, IRQ 0's handler at
/// 0x200) and the two routines.
fn image(main: &[u16], handler: &[u16]) -> Vec<(u32, Vec<u8>)> {
    let mut table = vec![0u8; 0x100];
    let mut put = |i: usize, v: u32| table[4 * i..4 * i + 4].copy_from_slice(&v.to_le_bytes());
    put(0, SRAM_BASE + SRAM_BYTES);
    put(1, (FLASH_BASE + 0x100) | 1);
    put(16, (FLASH_BASE + 0x200) | 1);
    vec![
        (FLASH_BASE, table),
        (FLASH_BASE + 0x100, code(main)),
        (FLASH_BASE + 0x200, code(handler)),
    ]
}

fn core(main: &[u16], handler: &[u16], at: Time) -> Core {
    let img = image(main, handler);
    let code: Vec<(u32, Vec<u8>)> = img[1..].to_vec();
    let bus = TestBus {
        at,
        raised: false,
        cleared: false,
        writes: Vec::new(),
        reset_at: Time::MAX,
        reset_due: false,
    };
    let mut c = Core::new(Box::new(bus), &img, &code).unwrap();
    c.reset().unwrap();
    c
}

/// Enable IRQ 0 (NVIC ISER0 = 1) with r4/r5: movs r4, #0xE0; lsls r4, #24 (0xE000_0000);
/// add r4 with 0xE100 by movw; simpler: ldr from a literal is avoided by building it.
const ENABLE_IRQ0: [u16; 7] = [
    0x24E0, // movs r4, #0xE0
    0x0624, // lsls r4, r4, #24      → 0xE000_0000
    0xF504, 0x4461, // add.w r4, r4, #0xE100 → 0xE000_E100 (ISER0)
    0x2501, // movs r5, #1
    0x6025, // str r5, [r4]
    0xBF00, // nop
];

/// The handler: r1 = 7, write it to the peripheral (which lowers its line), return.
const HANDLER: [u16; 5] = [
    0x2107, // movs r1, #7
    0x2240, // movs r2, #0x40
    0x0612, // lsls r2, r2, #24   → 0x4000_0000
    0x6011, // str r1, [r2]
    0x4770, // bx lr
];

#[test]
fn wfe_sleeps_to_the_interrupt_which_returns_to_the_thread() {
    let at = TIME_HZ / 1000; // 1 ms
    let mut main = ENABLE_IRQ0.to_vec();
    main.extend([
        0x202A, // movs r0, #42
        0xBF20, // wfe
        0x2305, // movs r3, #5
        0xE7FE, // b .
    ]);
    let mut c = core(&main, &HANDLER, at);
    let sp0 = c.reg(RegisterARM::SP);
    // Before the event it sleeps at wfe, having run a few instructions only.
    c.run_until(at / 2).unwrap();
    assert!(c.sleeping());
    assert!(c.instructions() < 20, "{}", c.instructions());
    assert_eq!(c.reg(RegisterARM::R1), 0);
    c.run_until(at + TIME_HZ / 100_000).unwrap();
    assert_eq!(
        c.reg(RegisterARM::R0),
        42,
        "the thread's registers are restored"
    );
    assert_eq!(
        c.reg(RegisterARM::R1),
        0,
        "r1 is in the frame: the handler's 7 is gone"
    );
    assert_eq!(written(&c), vec![7], "the handler ran once");
    assert_eq!(c.reg(RegisterARM::R3), 5, "the thread went on past wfe");
    assert_eq!(c.reg(RegisterARM::SP), sp0, "the frame was popped");
    assert!(!c.nvic().is_active(16) && !c.nvic().is_pending(16));
    assert!(c.bus_faults().is_empty(), "{:?}", c.bus_faults());
}

#[test]
fn an_fpu_context_is_stacked_in_the_extended_frame() {
    let at = TIME_HZ / 1000;
    let mut main = ENABLE_IRQ0.to_vec();
    main.extend([
        // CPACR (0xE000_ED88) |= 0xF << 20: r4 = 0xE000_E100 + 0xC88.
        0xF604, 0x4488, // addw r4, r4, #0xC88
        0xF44F, 0x0570, // mov.w r5, #0x00F0_0000
        0x6025, // str r5, [r4]
        0xF3BF, 0x8F6F, // isb
        0x2063, // movs r0, #99
        0xEE00, 0x0A10, // vmov s0, r0   (the FP context becomes active: CONTROL.FPCA)
        0xBF20, // wfe
        0xEE10, 0x3A10, // vmov r3, s0
        0xE7FE, // b .
    ]);
    let handler = [
        0x2107, // movs r1, #7
        0xEE00, 0x1A10, // vmov s0, r1  (the handler clobbers s0)
        0x2240, 0x0612, 0x6011, // write the peripheral
        0x4770, // bx lr
    ];
    let mut c = core(&main, &handler, at);
    let sp0 = c.reg(RegisterARM::SP);
    c.run_until(at / 2).unwrap();
    assert_eq!(
        c.reg(RegisterARM::CONTROL) & 0b100,
        0b100,
        "FPCA after vmov"
    );
    c.run_until(at + TIME_HZ / 100_000).unwrap();
    assert_eq!(written(&c), vec![7], "the handler ran once");
    assert_eq!(
        c.reg(RegisterARM::R3),
        99,
        "s0 restored from the extended frame"
    );
    assert_eq!(c.reg(RegisterARM::SP), sp0);
    assert_eq!(c.reg(RegisterARM::CONTROL) & 0b100, 0b100, "FPCA restored");
}

#[test]
fn an_access_to_nothing_is_a_recorded_bus_fault_or_an_error() {
    // 0x4000_0004: inside the peripheral window, no register: recorded, read as 0.
    let main = [
        0x2240, // movs r2, #0x40
        0x0612, // lsls r2, r2, #24   → 0x4000_0000
        0x6850, // ldr r0, [r2, #4]
        0x2307, // movs r3, #7
        0xE7FE, // b .
    ];
    let mut c = core(&main, &HANDLER, Time::MAX);
    c.run_until(TIME_HZ / 1000).unwrap();
    assert_eq!(
        c.bus_faults(),
        &[BusFault {
            addr: 0x4000_0004,
            write: false
        }]
    );
    assert_eq!((c.reg(RegisterARM::R0), c.reg(RegisterARM::R3)), (0, 7));
    // 0x4100_0000: outside every window: the run stops with the address.
    let main = [0x2241, 0x0612, 0x6810, 0xE7FE];
    let mut c = core(&main, &HANDLER, Time::MAX);
    let err = c.run_until(TIME_HZ / 1000).unwrap_err();
    assert!(err.to_string().contains("stopped at pc"), "{err}");
}

/// The reset hook sees the RAM as the program left it, before the reset and the program's
/// start-up code (which zeroes its counter, as a board's zeroes the RTT block's offsets).
#[test]
fn the_reset_hook_reads_the_ram_before_the_chip_resets() {
    // r0 = 0x2000_0000; [r0] = 0; then [r0] += 1 forever.
    let main = [
        0x2020, // movs r0, #0x20
        0x0600, // lsls r0, r0, #24
        0x2100, // movs r1, #0
        0x6001, // str r1, [r0]
        0x6801, // ldr r1, [r0]
        0x3101, // adds r1, #1
        0x6001, // str r1, [r0]
        0xE7FB, // b (the ldr)
    ];
    let img = image(&main, &HANDLER);
    let code: Vec<(u32, Vec<u8>)> = img[1..].to_vec();
    let reset_at = TIME_HZ / 1000;
    let bus = TestBus {
        at: Time::MAX,
        raised: false,
        cleared: false,
        writes: Vec::new(),
        reset_at,
        reset_due: false,
    };
    let mut c = Core::new(Box::new(bus), &img, &code).unwrap();
    c.reset().unwrap();
    let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let hook_seen = seen.clone();
    c.on_reset(Box::new(move |mem: &mut dyn Memory| {
        let mut b = [0u8; 4];
        assert!(mem.read(SRAM_BASE, &mut b));
        hook_seen.borrow_mut().push(u32::from_le_bytes(b));
    }));
    let counter = |c: &Core| c.read_u32(SRAM_BASE).unwrap();
    c.run_until(reset_at - TIME_HZ / 100_000).unwrap();
    let before = counter(&c);
    assert!(before > 1000, "{before}");
    c.run_until(reset_at + TIME_HZ / 100_000).unwrap();
    assert_eq!(c.resets().len(), 1);
    let seen = seen.borrow().clone();
    assert_eq!(seen.len(), 1, "one reset, one look");
    assert!(
        seen[0] > before,
        "the count at the reset: {seen:?} after {before}"
    );
    let after = counter(&c);
    assert!(
        after < seen[0] / 10,
        "the program started over after the hook: {after} after {seen:?}"
    );
}

/// A load inside an IT block that misses the TLB (the first touch of an SRAM page) leaves no
/// IT state behind: the code after the block, in the next translated block, runs
/// unconditionally. (unicorn's TLB fill restores the missing instruction's IT bits; left
/// there, the next block decoded as if inside the IT block, here skipping `movs r4, #9`.)
#[test]
fn a_tlb_miss_inside_an_it_block_leaves_no_it_state() {
    let main = [
        0x2220, // movs r2, #0x20
        0x0612, // lsls r2, r2, #24   → 0x2000_0000, a page not touched yet
        0x2000, // movs r0, #0
        0x2800, // cmp r0, #0         (Z = 1)
        0xBF04, // itt eq
        0x6811, // ldreq r1, [r2]     (the TLB miss)
        0x3101, // addeq r1, #1
        0x2305, // movs r3, #5        (Z = 0)
        0xE7FF, // b (the next instruction): the translated block ends here
        0x2409, // movs r4, #9
        0x2507, // movs r5, #7
        0xE7FE, // b .
    ];
    let mut c = core(&main, &HANDLER, Time::MAX);
    c.run_until(TIME_HZ / 10_000).unwrap();
    assert_eq!(c.reg(RegisterARM::R1), 1, "the IT block ran");
    assert_eq!(
        (c.reg(RegisterARM::R4), c.reg(RegisterARM::R5)),
        (9, 7),
        "the code after the IT block ran unconditionally"
    );
    assert_eq!(c.reg(RegisterARM::XPSR) & 0x0600_FC00, 0, "no IT bits");
}

/// SRAM holds data, not code: a branch there stops the run with an error naming the address
/// (the ELF's code is in flash; the harness maps SRAM execute-never, which lets unicorn store
/// to it on its fast path).
#[test]
fn a_branch_into_sram_is_an_error() {
    let main = [
        0x2020, // movs r0, #0x20
        0x0600, // lsls r0, r0, #24   → 0x2000_0000
        0x3001, // adds r0, #1        (Thumb)
        0x4700, // bx r0
    ];
    let mut c = core(&main, &HANDLER, Time::MAX);
    let err = c.run_until(TIME_HZ / 10_000).unwrap_err();
    assert!(
        err.to_string().contains("stopped at pc 0x20000000"),
        "{err}"
    );
}
