//! The Cortex-M4's interrupt controller and system control block as the board's code sees them
//! (ARMv7-M Architecture Reference Manual, B3; the Cortex-M4 Devices Generic User Guide, 4):
//! the NVIC's enable, pending, active and priority registers, the SCB's ICSR, VTOR, AIRCR,
//! SCR, CCR, SHPR1–3, SHCSR, the fault status registers, CPACR and the FPU's FPCCR/FPCAR, and
//! SysTick — the System Control Space window at 0xE000_E000 — plus the choice of the next
//! exception to take.
//!
//! This model decides *which* exception the core takes and when (priorities, grouping by
//! PRIGROUP, PRIMASK, BASEPRI, FAULTMASK, the active set); entering and leaving one (the stack
//! frame, EXC_RETURN) is the CPU glue's, which reads the vector from [`Nvic::vtor`].
//!
//! The chip's interrupt lines are level-sensitive ([`Nvic::set_line`]): a line held high pends
//! its interrupt whenever it is not active, and pends it again on return while still high —
//! as RM0390 §10 and the ARMv7-M manual (B3.4.1) say. The STM32F446 implements 4 priority
//! bits (the top nibble of each byte) and 97 interrupts.

use super::{Clocks, Size, Time, lanes, merge};

/// The System Control Space's base address.
pub const SCS_BASE: u32 = 0xE000_E000;
/// The STM32F446's external interrupts (RM0390 table 38: positions 0–96).
pub const IRQS: usize = 97;
/// Exception numbers (ARMv7-M B1.5.2): an external interrupt `n` is exception 16 + n.
pub mod exc {
    /// Reset.
    pub const RESET: u16 = 1;
    /// Non-maskable interrupt.
    pub const NMI: u16 = 2;
    /// Hard fault.
    pub const HARD_FAULT: u16 = 3;
    /// Memory management fault.
    pub const MEM_MANAGE: u16 = 4;
    /// Bus fault.
    pub const BUS_FAULT: u16 = 5;
    /// Usage fault.
    pub const USAGE_FAULT: u16 = 6;
    /// Supervisor call.
    pub const SVCALL: u16 = 11;
    /// Debug monitor.
    pub const DEBUG_MONITOR: u16 = 12;
    /// PendSV.
    pub const PENDSV: u16 = 14;
    /// SysTick.
    pub const SYSTICK: u16 = 15;
    /// The first external interrupt.
    pub const IRQ0: u16 = 16;
}

/// Exceptions in all: 16 system ones and the external interrupts.
const EXCEPTIONS: usize = 16 + IRQS;
/// The implemented priority bits' mask (4 bits, the top nibble).
const PRIO_MASK: u8 = 0xF0;
/// CPUID of a Cortex-M4 r0p1 (the STM32F446's, RM0390 / PM0214).
pub const CPUID: u32 = 0x410F_C241;

/// The interrupt controller, the system control block and SysTick.
#[derive(Clone, Debug)]
pub struct Nvic {
    enabled: [bool; EXCEPTIONS],
    /// [`Nvic::highest_pending`]'s answer until pending, enabled or priority change.
    best: std::cell::Cell<Option<Option<u16>>>,
    pending: [bool; EXCEPTIONS],
    active: [bool; EXCEPTIONS],
    /// Each exception's priority byte (the implemented top nibble).
    priority: [u8; EXCEPTIONS],
    /// Each external interrupt line's level.
    line: [bool; IRQS],
    /// The order exceptions were taken in (the innermost last).
    nesting: Vec<u16>,
    vtor: u32,
    /// AIRCR.PRIGROUP.
    prigroup: u8,
    /// AIRCR.SYSRESETREQ was written with the key.
    reset_requested: bool,
    scr: u32,
    ccr: u32,
    shcsr: u32,
    cfsr: u32,
    hfsr: u32,
    mmfar: u32,
    bfar: u32,
    cpacr: u32,
    fpccr: u32,
    fpcar: u32,
    fpdscr: u32,
    systick: SysTick,
}

/// SysTick (ARMv7-M B3.3): a 24-bit down-counter on the processor clock (CLKSOURCE = 1) or
/// HCLK / 8.
#[derive(Clone, Copy, Debug, Default)]
struct SysTick {
    csr: u32,
    rvr: u32,
    /// The counter's value at `since`.
    cvr: u32,
    since: Time,
    countflag: bool,
}

/// The core's masks as the exception choice needs them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Masks {
    /// PRIMASK: every exception of configurable priority masked.
    pub primask: bool,
    /// FAULTMASK: everything but NMI masked.
    pub faultmask: bool,
    /// BASEPRI (0: none).
    pub basepri: u8,
}

impl Default for Nvic {
    fn default() -> Self {
        Self::new()
    }
}

impl Nvic {
    /// At reset: every interrupt disabled, nothing pending, every priority 0, VTOR 0, the FPU
    /// off (CPACR 0) with automatic and lazy state preservation on (FPCCR 0xC000_0000).
    pub fn new() -> Nvic {
        let mut enabled = [false; EXCEPTIONS];
        // Reset, NMI and hard fault are always enabled.
        for e in [exc::RESET, exc::NMI, exc::HARD_FAULT] {
            enabled[e as usize] = true;
        }
        // SVCall, PendSV, SysTick and the debug monitor have no enable bit.
        for e in [exc::SVCALL, exc::DEBUG_MONITOR, exc::PENDSV, exc::SYSTICK] {
            enabled[e as usize] = true;
        }
        Nvic {
            enabled,
            best: std::cell::Cell::new(None),
            pending: [false; EXCEPTIONS],
            active: [false; EXCEPTIONS],
            priority: [0; EXCEPTIONS],
            line: [false; IRQS],
            nesting: Vec::new(),
            vtor: 0,
            prigroup: 0,
            reset_requested: false,
            scr: 0,
            ccr: 0x0000_0200,
            shcsr: 0,
            cfsr: 0,
            hfsr: 0,
            mmfar: 0,
            bfar: 0,
            cpacr: 0,
            fpccr: 0xC000_0000,
            fpcar: 0,
            fpdscr: 0,
            systick: SysTick::default(),
        }
    }

    /// The vector table's base (VTOR).
    pub fn vtor(&self) -> u32 {
        self.vtor
    }

    /// FPCCR (ASPEN bit 31, LSPEN bit 30, LSPACT bit 0).
    pub fn fpccr(&self) -> u32 {
        self.fpccr
    }

    /// Record FPCAR (the extended frame's FP area, written by the CPU glue on entry).
    pub fn set_fpcar(&mut self, addr: u32) {
        self.fpcar = addr & !7;
    }

    /// SCR.SEVONPEND: a newly pending interrupt wakes a WFE even when it cannot be taken.
    pub fn sev_on_pend(&self) -> bool {
        self.scr & (1 << 4) != 0
    }

    /// AIRCR.SYSRESETREQ was written (with its key) and not yet taken.
    pub fn reset_requested(&self) -> bool {
        self.reset_requested
    }

    /// AIRCR.SYSRESETREQ was written (with its key) since the last call.
    pub fn take_reset_request(&mut self) -> bool {
        core::mem::take(&mut self.reset_requested)
    }

    /// Set external interrupt `irq`'s line level: high pends it unless it is active (it pends
    /// again on its return while still high). Returns whether this made it newly pending.
    pub fn set_line(&mut self, irq: u16, high: bool) -> bool {
        let Some(l) = self.line.get_mut(irq as usize) else {
            return false;
        };
        *l = high;
        let e = (exc::IRQ0 + irq) as usize;
        if high && !self.active[e] && !self.pending[e] {
            self.pending[e] = true;
            self.best.set(None);
            return true;
        }
        false
    }

    /// Pend exception `e` (a system exception, or `IRQ0 + n`).
    pub fn pend(&mut self, e: u16) {
        self.best.set(None);
        if let Some(p) = self.pending.get_mut(e as usize) {
            *p = true;
        }
    }

    /// Whether exception `e` is pending.
    pub fn is_pending(&self, e: u16) -> bool {
        self.pending.get(e as usize).copied().unwrap_or(false)
    }

    /// Whether exception `e` is active.
    pub fn is_active(&self, e: u16) -> bool {
        self.active.get(e as usize).copied().unwrap_or(false)
    }

    /// Exception `e`'s priority: negative for reset (−3), NMI (−2) and hard fault (−1), else
    /// its byte's implemented bits.
    pub fn priority(&self, e: u16) -> i16 {
        match e {
            exc::RESET => -3,
            exc::NMI => -2,
            exc::HARD_FAULT => -1,
            _ => i16::from(self.priority[e as usize] & PRIO_MASK),
        }
    }

    /// The group priority of priority `p` (the bits above PRIGROUP's subpriority field).
    fn group(&self, p: i16) -> i16 {
        if p < 0 {
            return p;
        }
        let sub_bits = u32::from(self.prigroup) + 1;
        let mask = (0xFFu32 << sub_bits) as u8;
        i16::from(p as u8 & mask)
    }

    /// The execution priority: the highest (lowest value) group priority of the active
    /// exceptions and of the masks (ARMv7-M B1.5.4); 256 with none.
    pub fn execution_priority(&self, m: Masks) -> i16 {
        let mut p = 256i16;
        for &e in &self.nesting {
            p = p.min(self.group(self.priority(e)));
        }
        if m.basepri & PRIO_MASK != 0 {
            p = p.min(self.group(i16::from(m.basepri & PRIO_MASK)));
        }
        if m.primask {
            p = p.min(0);
        }
        if m.faultmask {
            p = p.min(-1);
        }
        p
    }

    /// The pending, enabled exception of the highest priority (the lowest exception number
    /// among equals), whatever the masks.
    pub fn highest_pending(&self) -> Option<u16> {
        if let Some(b) = self.best.get() {
            return b;
        }
        let b = self.find_highest_pending();
        self.best.set(Some(b));
        b
    }

    fn find_highest_pending(&self) -> Option<u16> {
        let mut best: Option<(i16, u16)> = None;
        for e in 1..EXCEPTIONS as u16 {
            if self.pending[e as usize] && self.enabled[e as usize] {
                let p = self.priority(e);
                if best.is_none_or(|(bp, _)| p < bp) {
                    best = Some((p, e));
                }
            }
        }
        best.map(|(_, e)| e)
    }

    /// The exception the core takes now, if any: the highest pending one whose group priority
    /// is above (numerically below) the execution priority.
    pub fn to_take(&self, m: Masks) -> Option<u16> {
        let e = self.highest_pending()?;
        (self.group(self.priority(e)) < self.execution_priority(m)).then_some(e)
    }

    /// The core takes exception `e`: pending → active, innermost.
    pub fn acknowledge(&mut self, e: u16) {
        self.best.set(None);
        self.pending[e as usize] = false;
        self.active[e as usize] = true;
        self.nesting.push(e);
    }

    /// Exception `e` returns: no longer active; an interrupt whose line is still high pends
    /// again. Returns false if `e` was not active (an illegal return).
    pub fn complete(&mut self, e: u16) -> bool {
        self.best.set(None);
        if !self.active.get(e as usize).copied().unwrap_or(false) {
            return false;
        }
        self.active[e as usize] = false;
        if let Some(i) = self.nesting.iter().rposition(|&x| x == e) {
            self.nesting.remove(i);
        }
        if e >= exc::IRQ0 && self.line[(e - exc::IRQ0) as usize] {
            self.pending[e as usize] = true;
        }
        true
    }

    /// The innermost active exception (0: thread mode).
    pub fn current(&self) -> u16 {
        self.nesting.last().copied().unwrap_or(0)
    }

    /// Whether only one exception is active (a return goes to thread mode).
    pub fn returns_to_base(&self) -> bool {
        self.nesting.len() <= 1
    }

    /// Advance SysTick to `now`: its counter reloads and pends SysTick when it wraps with
    /// TICKINT.
    pub fn advance(&mut self, now: Time, clocks: &Clocks) {
        let st = &mut self.systick;
        if st.csr & 1 == 0 {
            st.since = now;
            return;
        }
        let hz = systick_hz(st.csr, clocks);
        let elapsed = Clocks::ticks(now.saturating_sub(st.since), hz);
        if elapsed == 0 {
            return;
        }
        st.since += Clocks::time_of(elapsed, hz);
        let period = u64::from(st.rvr & 0x00FF_FFFF) + 1;
        let cvr = u64::from(st.cvr);
        if elapsed > cvr {
            // It reached zero at least once: reload and count on.
            st.countflag = true;
            let after = (elapsed - cvr - 1) % period;
            st.cvr = (u64::from(st.rvr & 0x00FF_FFFF) - after.min(period - 1)) as u32;
            if st.csr & 2 != 0 {
                self.pending[exc::SYSTICK as usize] = true;
                self.best.set(None);
            }
        } else {
            st.cvr = (cvr - elapsed) as u32;
        }
    }

    /// When SysTick next wraps, if it is counting with TICKINT.
    pub fn next_event(&self, now: Time, clocks: &Clocks) -> Option<Time> {
        let st = &self.systick;
        if st.csr & 3 != 3 {
            return None;
        }
        let hz = systick_hz(st.csr, clocks);
        Some(now.max(st.since) + Clocks::time_of(u64::from(st.cvr) + 1, hz))
    }

    /// A read of the System Control Space at `offset` from [`SCS_BASE`].
    pub fn read(&mut self, offset: u32, size: Size) -> u32 {
        self.best.set(None);
        let word = self.read_word(offset & !3);
        lanes(word, offset, size)
    }

    /// A write to the System Control Space at `offset` from [`SCS_BASE`]. The priority
    /// registers take byte writes; the others word writes (a narrower one is merged).
    pub fn write(&mut self, offset: u32, size: Size, value: u32) {
        let aligned = offset & !3;
        // Bit-set and bit-clear registers: a narrower write sets or clears only its lanes.
        if matches!(aligned, 0x100..=0x11C | 0x180..=0x19C | 0x200..=0x21C | 0x280..=0x29C) {
            let v = merge(0, offset, size, value);
            self.write_word(aligned, v);
        } else {
            // (Reading ICSR looks at the highest pending exception: forget it after the write.)
            let old = self.read_word(aligned);
            self.write_word(aligned, merge(old, offset, size, value));
        }
        self.best.set(None);
    }

    fn bits(&self, set: &[bool; EXCEPTIONS], word: u32) -> u32 {
        (0..32)
            .filter(|b| {
                let irq = word as usize * 32 + b;
                irq < IRQS && set[16 + irq]
            })
            .fold(0, |v, b| v | 1 << b)
    }

    fn read_word(&self, off: u32) -> u32 {
        match off {
            // ICTR: 97 interrupts → 4 words of 32.
            0x004 => 3,
            0x010 => {
                let st = &self.systick;
                st.csr & 0x7 | u32::from(st.countflag) << 16
            }
            0x014 => self.systick.rvr,
            0x018 => self.systick.cvr,
            // CALIB: no reference clock, TENMS unknown.
            0x01C => 0x8000_0000,
            0x100..=0x11C => self.bits(&self.enabled, (off - 0x100) / 4),
            0x180..=0x19C => self.bits(&self.enabled, (off - 0x180) / 4),
            0x200..=0x21C => self.bits(&self.pending, (off - 0x200) / 4),
            0x280..=0x29C => self.bits(&self.pending, (off - 0x280) / 4),
            0x300..=0x31C => self.bits(&self.active, (off - 0x300) / 4),
            0x400..=0x4EF => {
                let first = (off - 0x400) as usize;
                (0..4).fold(0, |v, k| {
                    let p = self
                        .priority
                        .get(16 + first + k)
                        .filter(|_| first + k < IRQS)
                        .copied()
                        .unwrap_or(0);
                    v | u32::from(p) << (8 * k)
                })
            }
            0xD00 => CPUID,
            0xD04 => self.icsr(),
            0xD08 => self.vtor,
            0xD0C => 0xFA05_0000 | u32::from(self.prigroup) << 8,
            0xD10 => self.scr,
            0xD14 => self.ccr,
            0xD18..=0xD20 => {
                let first = 4 + (off - 0xD18) as usize;
                (0..4).fold(0, |v, k| v | u32::from(self.priority[first + k]) << (8 * k))
            }
            0xD24 => self.shcsr_value(),
            0xD28 => self.cfsr,
            0xD2C => self.hfsr,
            0xD34 => self.mmfar,
            0xD38 => self.bfar,
            0xD88 => self.cpacr,
            0xF34 => self.fpccr,
            0xF38 => self.fpcar,
            0xF3C => self.fpdscr,
            // MVFR0/1: single precision, square root, divide (the M4F's FPU).
            0xF40 => 0x1011_0021,
            0xF44 => 0x1100_0011,
            _ => 0,
        }
    }

    fn icsr(&self) -> u32 {
        let active = u32::from(self.current()) & 0x1FF;
        let pending = u32::from(self.highest_pending().unwrap_or(0)) & 0x1FF;
        let rettobase = u32::from(self.returns_to_base() && active != 0);
        let isrpending = u32::from((16..EXCEPTIONS).any(|e| self.pending[e]));
        active
            | rettobase << 11
            | pending << 12
            | isrpending << 22
            | u32::from(self.pending[exc::SYSTICK as usize]) << 26
            | u32::from(self.pending[exc::PENDSV as usize]) << 28
            | u32::from(self.pending[exc::NMI as usize]) << 31
    }

    fn shcsr_value(&self) -> u32 {
        let a = |e: u16| u32::from(self.active[e as usize]);
        let p = |e: u16| u32::from(self.pending[e as usize]);
        (self.shcsr & 0x0007_0000)
            | a(exc::MEM_MANAGE)
            | a(exc::BUS_FAULT) << 1
            | a(exc::USAGE_FAULT) << 3
            | a(exc::SVCALL) << 7
            | a(exc::DEBUG_MONITOR) << 8
            | a(exc::PENDSV) << 10
            | a(exc::SYSTICK) << 11
            | p(exc::USAGE_FAULT) << 12
            | p(exc::MEM_MANAGE) << 13
            | p(exc::BUS_FAULT) << 14
            | p(exc::SVCALL) << 15
    }

    fn write_word(&mut self, off: u32, v: u32) {
        let each = |word: u32, f: &mut dyn FnMut(usize)| {
            for b in 0..32 {
                let irq = (word * 32 + b) as usize;
                if v & 1 << b != 0 && irq < IRQS {
                    f(16 + irq);
                }
            }
        };
        match off {
            0x010 => {
                let st = &mut self.systick;
                st.csr = v & 0x7;
            }
            0x014 => self.systick.rvr = v & 0x00FF_FFFF,
            // Any write clears the counter and COUNTFLAG.
            0x018 => {
                self.systick.cvr = 0;
                self.systick.countflag = false;
            }
            0x100..=0x11C => each((off - 0x100) / 4, &mut |e| self.enabled[e] = true),
            0x180..=0x19C => each((off - 0x180) / 4, &mut |e| self.enabled[e] = false),
            0x200..=0x21C => each((off - 0x200) / 4, &mut |e| self.pending[e] = true),
            0x280..=0x29C => {
                let line = self.line;
                each((off - 0x280) / 4, &mut |e| {
                    // A line still high pends it again at once.
                    self.pending[e] = line[e - 16] && !self.active[e];
                });
            }
            0x400..=0x4EF => {
                let first = (off - 0x400) as usize;
                for k in 0..4 {
                    if first + k < IRQS {
                        self.priority[16 + first + k] = (v >> (8 * k)) as u8 & PRIO_MASK;
                    }
                }
            }
            0xD04 => {
                if v & 1 << 31 != 0 {
                    self.pending[exc::NMI as usize] = true;
                }
                if v & 1 << 28 != 0 {
                    self.pending[exc::PENDSV as usize] = true;
                }
                if v & 1 << 27 != 0 {
                    self.pending[exc::PENDSV as usize] = false;
                }
                if v & 1 << 26 != 0 {
                    self.pending[exc::SYSTICK as usize] = true;
                }
                if v & 1 << 25 != 0 {
                    self.pending[exc::SYSTICK as usize] = false;
                }
            }
            0xD08 => self.vtor = v & 0xFFFF_FF80,
            // Only with its key (VECTKEY 0x05FA).
            0xD0C if v >> 16 == 0x05FA => {
                self.prigroup = ((v >> 8) & 7) as u8;
                if v & 1 << 2 != 0 {
                    self.reset_requested = true;
                }
            }
            0xD10 => self.scr = v & 0x16,
            0xD14 => self.ccr = v & 0x0000_031B,
            0xD18..=0xD20 => {
                let first = 4 + (off - 0xD18) as usize;
                for k in 0..4 {
                    self.priority[first + k] = (v >> (8 * k)) as u8 & PRIO_MASK;
                }
            }
            0xD24 => {
                self.shcsr = v & 0x0007_0000;
                self.enabled[exc::MEM_MANAGE as usize] = v & 1 << 16 != 0;
                self.enabled[exc::BUS_FAULT as usize] = v & 1 << 17 != 0;
                self.enabled[exc::USAGE_FAULT as usize] = v & 1 << 18 != 0;
            }
            // Fault status: write one to clear.
            0xD28 => self.cfsr &= !v,
            0xD2C => self.hfsr &= !v,
            0xD34 => self.mmfar = v,
            0xD38 => self.bfar = v,
            0xD88 => self.cpacr = v & 0x00F0_0000,
            0xF00 => {
                let irq = (v & 0x1FF) as usize;
                if irq < IRQS {
                    self.pending[16 + irq] = true;
                }
            }
            0xF34 => self.fpccr = (self.fpccr & 0x1FF) | (v & 0xC000_0000) | (v & 1),
            0xF38 => self.fpcar = v & !7,
            0xF3C => self.fpdscr = v & 0x07C0_0000,
            _ => {}
        }
    }

    /// Record a fault for the fault status registers: `cfsr_bits` ORed into CFSR, and HFSR's
    /// FORCED (bit 30) when it escalates to a hard fault.
    pub fn record_fault(&mut self, cfsr_bits: u32, forced: bool) {
        self.best.set(None);
        self.cfsr |= cfsr_bits;
        if forced {
            self.hfsr |= 1 << 30;
        }
    }
}

/// SysTick's clock: the processor clock with CLKSOURCE, else HCLK / 8 (STM32: the external
/// reference).
fn systick_hz(csr: u32, clocks: &Clocks) -> u32 {
    if csr & 4 != 0 {
        clocks.hclk_hz
    } else {
        clocks.hclk_hz / 8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NONE: Masks = Masks {
        primask: false,
        faultmask: false,
        basepri: 0,
    };

    fn enable(n: &mut Nvic, irq: u32) {
        n.write(0x100 + irq / 32 * 4, Size::Word, 1 << (irq % 32));
    }

    #[test]
    fn a_level_line_pends_when_enabled_and_again_after_return() {
        let mut n = Nvic::new();
        // TIM8_BRK_TIM12 (43): pending but disabled is not taken.
        n.set_line(43, true);
        assert!(n.is_pending(16 + 43));
        assert_eq!(n.to_take(NONE), None);
        enable(&mut n, 43);
        assert_eq!(n.read(0x104, Size::Word), 1 << 11, "ISER1 bit 11");
        assert_eq!(n.to_take(NONE), Some(16 + 43));
        n.acknowledge(16 + 43);
        assert!(!n.is_pending(16 + 43) && n.is_active(16 + 43));
        assert_eq!(n.read(0xD04, Size::Word) & 0x1FF, 59, "ICSR.VECTACTIVE");
        // Still high at return: pends again. Low: not.
        assert!(n.complete(16 + 43));
        assert!(n.is_pending(16 + 43));
        n.acknowledge(16 + 43);
        n.set_line(43, false);
        n.complete(16 + 43);
        assert!(!n.is_pending(16 + 43));
        assert!(!n.complete(16 + 43), "not active: an illegal return");
    }

    #[test]
    fn priorities_masks_and_preemption() {
        let mut n = Nvic::new();
        enable(&mut n, 38); // USART2
        enable(&mut n, 31); // I2C1_EV
        // IPR: byte writes, only the top nibble kept.
        n.write(0x400 + 38, Size::Byte, 0x3F);
        n.write(0x400 + 31, Size::Byte, 0x10);
        assert_eq!(n.read(0x400 + 36, Size::Word), 0x0030_0000);
        n.pend(16 + 38);
        n.pend(16 + 31);
        assert_eq!(n.to_take(NONE), Some(16 + 31), "0x10 before 0x30");
        n.acknowledge(16 + 31);
        // USART2 (0x30) cannot preempt I2C1 (0x10).
        assert_eq!(n.to_take(NONE), None);
        n.complete(16 + 31);
        assert_eq!(n.to_take(NONE), Some(16 + 38));
        // PRIMASK holds it; BASEPRI 0x30 too (not above), 0x40 lets it through.
        let primask = Masks {
            primask: true,
            ..NONE
        };
        assert_eq!(n.to_take(primask), None);
        let bp = |b| Masks { basepri: b, ..NONE };
        assert_eq!(n.to_take(bp(0x30)), None);
        assert_eq!(n.to_take(bp(0x40)), Some(16 + 38));
        // ICPR clears it (its line is low).
        n.write(0x284, Size::Word, 1 << 6);
        assert!(!n.is_pending(16 + 38));
    }

    #[test]
    fn prigroup_splits_group_and_subpriority() {
        let mut n = Nvic::new();
        enable(&mut n, 1);
        enable(&mut n, 2);
        // PRIGROUP 5: bits 7:6 group, 5:0 sub. 0x40 and 0x70 are the same group.
        n.write(0xD0C, Size::Word, 0x05FA_0500);
        assert_eq!(n.read(0xD0C, Size::Word) & 0x700, 0x500);
        n.write(0x400, Size::Word, 0x0070_4000);
        n.pend(16 + 1);
        n.acknowledge(16 + 1);
        n.pend(16 + 2);
        assert_eq!(n.to_take(NONE), None, "same group: no preemption");
        // Without the key the write is ignored.
        n.write(0xD0C, Size::Word, 0x0000_0000);
        assert_eq!(n.read(0xD0C, Size::Word) & 0x700, 0x500);
        n.write(0xD0C, Size::Word, 0x05FA_0004);
        assert!(n.take_reset_request());
    }

    #[test]
    fn system_exceptions_pend_by_icsr_and_shpr() {
        let mut n = Nvic::new();
        n.write(0xD20, Size::Word, 0xF0F0_0000); // PendSV, SysTick lowest
        n.write(0xD04, Size::Word, 1 << 28);
        assert_eq!(n.read(0xD04, Size::Word) >> 28 & 1, 1);
        assert_eq!(n.to_take(NONE), Some(exc::PENDSV));
        n.write(0xD04, Size::Word, 1 << 27);
        assert_eq!(n.to_take(NONE), None);
        assert_eq!(n.read(0xD00, Size::Word), CPUID);
        assert_eq!(
            n.read(0xF34, Size::Word),
            0xC000_0000,
            "FPCCR: ASPEN, LSPEN"
        );
    }

    #[test]
    fn systick_wraps_at_its_reload() {
        let mut n = Nvic::new();
        let c = Clocks {
            sysclk_hz: 180_000_000,
            hclk_hz: 180_000_000,
            ..Clocks::RESET
        };
        n.write(0x014, Size::Word, 179_999); // 1 ms at 180 MHz
        n.write(0x018, Size::Word, 0);
        n.write(0x010, Size::Word, 0b111);
        n.advance(0, &c);
        // CVR starts at 0: the first tick reloads and pends.
        let next = n.next_event(0, &c).unwrap();
        assert_eq!(next, Clocks::time_of(1, 180_000_000));
        n.advance(next, &c);
        assert!(n.is_pending(exc::SYSTICK));
        assert_eq!(n.read(0x010, Size::Word) >> 16 & 1, 1, "COUNTFLAG");
        // A whole period (180 000 ticks, 1 ms) later it wraps again.
        let again = n.next_event(next, &c).unwrap();
        assert_eq!(again - next, Clocks::time_of(180_000, 180_000_000));
        n.advance(again - 1, &c);
        n.write(0xD04, Size::Word, 1 << 25);
        n.advance(again - 1, &c);
        assert!(!n.is_pending(exc::SYSTICK), "not yet");
        n.advance(again, &c);
        assert!(n.is_pending(exc::SYSTICK));
    }
}
