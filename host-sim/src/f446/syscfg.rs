//! The system configuration controller (SYSCFG, RM0390 §8) at 0x4001_3800: the memory
//! remap (MEMRMP), the ADC supply configuration (PMC), the EXTI lines' port selection
//! (EXTICR1–4: which port's pin x drives EXTI line x, [`Syscfg::exti_port`]), the I/O
//! compensation cell (CMPCR) and FMPI2C1's fast-mode-plus drive (CFGR).
//!
//! MEMRMP reads MEM_MODE 00 (the BOOT pins select the main flash on the NUCLEO) and is
//! stored only: the remap of 0x0000_0000 is the chip's address map, which does not follow it
//! (the board never remaps). PMC and CFGR are stored only. CMPCR's READY comes
//! [`COMPENSATION_READY`] after CMP_PD is set (chosen, of the order of DS10693's cell
//! start-up) and clears with it.

use super::{Clocks, Peripheral, Size, TIME_HZ, Time, lanes, merge};

/// From CMP_PD set to READY (chosen).
pub const COMPENSATION_READY: Time = 10 * TIME_HZ / 1_000_000;

/// Register offsets (RM0390 §8.2.9).
pub mod reg {
    /// Memory remap.
    pub const MEMRMP: u32 = 0x00;
    /// Peripheral mode configuration.
    pub const PMC: u32 = 0x04;
    /// EXTI lines 0–3's ports.
    pub const EXTICR1: u32 = 0x08;
    /// EXTI lines 4–7's ports.
    pub const EXTICR2: u32 = 0x0C;
    /// EXTI lines 8–11's ports.
    pub const EXTICR3: u32 = 0x10;
    /// EXTI lines 12–15's ports.
    pub const EXTICR4: u32 = 0x14;
    /// Compensation cell control.
    pub const CMPCR: u32 = 0x20;
    /// Configuration (FMPI2C1 SCL/SDA fast-mode plus).
    pub const CFGR: u32 = 0x2C;
}

/// CMPCR's power-down bit (1: the cell on).
pub const CMP_PD: u32 = 1 << 0;
/// CMPCR's ready bit.
pub const CMP_READY: u32 = 1 << 8;

/// SYSCFG's registers.
#[derive(Clone, Debug, Default)]
pub struct Syscfg {
    now: Time,
    memrmp: u32,
    pmc: u32,
    exticr: [u32; 4],
    cmpcr: u32,
    ready_at: Option<Time>,
    ready: bool,
    cfgr: u32,
}

impl Syscfg {
    /// SYSCFG after reset (all 0: flash at 0, every EXTI line on port A).
    pub fn new() -> Syscfg {
        Syscfg::default()
    }

    /// A system reset.
    pub fn reset(&mut self) {
        let now = self.now;
        *self = Syscfg::new();
        self.now = now;
    }

    /// The port (0 = A .. 7 = H) whose pin `line` (0–15) drives EXTI line `line`.
    pub fn exti_port(&self, line: usize) -> usize {
        ((self.exticr[line / 4] >> (4 * (line % 4))) & 0xF) as usize
    }

    /// Port `port`'s pins whose EXTI line selects it (bit per line 0–15).
    pub fn lines_of(&self, port: usize) -> u16 {
        (0..16)
            .filter(|l| self.exti_port(*l) == port)
            .fold(0, |m, l| m | (1 << l))
    }

    /// A register's present value (reads have no side effects).
    pub fn peek(&self, offset: u32) -> u32 {
        match offset & !3 {
            reg::MEMRMP => self.memrmp,
            reg::PMC => self.pmc,
            o @ reg::EXTICR1..=reg::EXTICR4 => self.exticr[((o - reg::EXTICR1) / 4) as usize],
            reg::CMPCR => self.cmpcr | if self.ready { CMP_READY } else { 0 },
            reg::CFGR => self.cfgr,
            _ => 0,
        }
    }
}

impl Peripheral for Syscfg {
    fn name(&self) -> &'static str {
        "SYSCFG"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        lanes(self.peek(offset), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        let v = merge(self.peek(word), offset, size, value);
        match word {
            reg::MEMRMP => self.memrmp = v & 0xC07,
            reg::PMC => self.pmc = v & 0x7_0000,
            o @ reg::EXTICR1..=reg::EXTICR4 => {
                self.exticr[((o - reg::EXTICR1) / 4) as usize] = v & 0xFFFF;
            }
            reg::CMPCR => {
                let on = v & CMP_PD != 0;
                if on && self.cmpcr & CMP_PD == 0 {
                    self.ready_at = Some(self.now + COMPENSATION_READY);
                } else if !on {
                    self.ready = false;
                    self.ready_at = None;
                }
                self.cmpcr = v & CMP_PD;
            }
            reg::CFGR => self.cfgr = v & 3,
            _ => {}
        }
    }

    fn advance(&mut self, now: Time, _clocks: &Clocks) {
        if self.ready_at.is_some_and(|t| t <= now) {
            self.ready_at = None;
            self.ready = true;
        }
        self.now = self.now.max(now);
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        self.ready_at.map(|t| t.max(now))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exticr_selects_a_port_per_line() {
        let mut s = Syscfg::new();
        assert_eq!(s.exti_port(13), 0);
        // PC13: EXTICR4 bits 7:4 = 2 (embassy's modify of exticr(3)).
        s.write(reg::EXTICR4, Size::Word, 2 << 4);
        assert_eq!(s.exti_port(13), 2);
        assert_eq!(s.lines_of(2), 1 << 13);
        assert_eq!(s.lines_of(0), !(1u16 << 13));
        assert_eq!(s.read(reg::EXTICR4, Size::Word), 0x20);
        s.write(reg::EXTICR1, Size::Word, 0xFFFF_FFFF);
        assert_eq!(
            s.read(reg::EXTICR1, Size::Word),
            0xFFFF,
            "high half reserved"
        );
        s.reset();
        assert_eq!(s.exti_port(13), 0);
    }

    #[test]
    fn compensation_cell_becomes_ready() {
        let mut s = Syscfg::new();
        s.write(reg::CMPCR, Size::Word, CMP_PD);
        assert_eq!(s.read(reg::CMPCR, Size::Word), CMP_PD);
        assert_eq!(s.next_event(0, &Clocks::RESET), Some(COMPENSATION_READY));
        s.advance(COMPENSATION_READY, &Clocks::RESET);
        assert_eq!(s.read(reg::CMPCR, Size::Word), CMP_PD | CMP_READY);
        s.write(reg::CMPCR, Size::Word, CMP_READY);
        assert_eq!(
            s.read(reg::CMPCR, Size::Word),
            0,
            "READY read-only, cleared with PD"
        );
        for o in [reg::MEMRMP, reg::PMC, reg::CFGR] {
            assert_eq!(s.read(o, Size::Word), 0);
        }
    }
}
