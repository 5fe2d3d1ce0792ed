//! The external interrupt/event controller (EXTI, RM0390 §10.2) at 0x4001_3C00: IMR, EMR,
//! RTSR, FTSR, SWIER, PR (write 1 to clear) for lines 0–22 (line 19 is not implemented on
//! the F446: its bits read 0).
//!
//! An edge on a line ([`Exti::edges`]: the chip passes the GPIO pins' edges routed by
//! SYSCFG's EXTICR, and the PVD/RTC/USB lines' if it has them) whose direction RTSR or FTSR
//! selects sets the line's PR bit when IMR unmasks it, and raises an event (a `wfe` wake-up,
//! [`Exti::take_event`]) when EMR does — RM0390 figure 24: the pending register follows
//! the interrupt mask. Writing 1 to a SWIER bit that is 0 does the same as an edge; clearing
//! the PR bit clears it. A PR bit holds its NVIC line high until cleared (RM0390 table 38):
//! EXTI0–4 → IRQ 6–10, EXTI9_5 → 23, EXTI15_10 → 40, PVD (16) → 1, RTC alarm (17) → 41,
//! OTG FS wake-up (18) → 42, OTG HS wake-up (20) → 76, tamper/time stamp (21) → 2, RTC
//! wake-up (22) → 3.

use super::{IrqLines, Peripheral, Size, lanes, merge};

/// The implemented lines (0–18, 20–22).
pub const LINES: u32 = 0x0077_FFFF;

/// Register offsets (RM0390 §10.3.7).
pub mod reg {
    /// Interrupt mask.
    pub const IMR: u32 = 0x00;
    /// Event mask.
    pub const EMR: u32 = 0x04;
    /// Rising trigger selection.
    pub const RTSR: u32 = 0x08;
    /// Falling trigger selection.
    pub const FTSR: u32 = 0x0C;
    /// Software interrupt event.
    pub const SWIER: u32 = 0x10;
    /// Pending.
    pub const PR: u32 = 0x14;
}

/// The NVIC line of EXTI line `line`, None for line 19.
pub fn irq_of(line: u32) -> Option<u16> {
    match line {
        0..=4 => Some(6 + line as u16),
        5..=9 => Some(23),
        10..=15 => Some(40),
        16 => Some(1),
        17 => Some(41),
        18 => Some(42),
        20 => Some(76),
        21 => Some(2),
        22 => Some(3),
        _ => None,
    }
}

/// The EXTI's registers.
#[derive(Clone, Debug, Default)]
pub struct Exti {
    imr: u32,
    emr: u32,
    rtsr: u32,
    ftsr: u32,
    swier: u32,
    pr: u32,
    event: bool,
}

impl Exti {
    /// The EXTI after reset (all 0).
    pub fn new() -> Exti {
        Exti::default()
    }

    /// A system reset.
    pub fn reset(&mut self) {
        *self = Exti::new();
    }

    /// Edges on the lines (bit per line): `rising` went 0 → 1, `falling` 1 → 0.
    pub fn edges(&mut self, rising: u32, falling: u32) {
        let hit = ((rising & self.rtsr) | (falling & self.ftsr)) & LINES;
        self.trigger(hit);
    }

    fn trigger(&mut self, lines: u32) {
        self.pr |= lines & self.imr;
        if lines & self.emr != 0 {
            self.event = true;
        }
    }

    /// Whether an event (EMR) was raised since the last call: the core's `wfe` wakes.
    pub fn take_event(&mut self) -> bool {
        std::mem::take(&mut self.event)
    }

    /// The pending lines (PR).
    pub fn pending(&self) -> u32 {
        self.pr
    }

    /// A register's present value (reads have no side effects).
    pub fn peek(&self, offset: u32) -> u32 {
        match offset & !3 {
            reg::IMR => self.imr,
            reg::EMR => self.emr,
            reg::RTSR => self.rtsr,
            reg::FTSR => self.ftsr,
            reg::SWIER => self.swier,
            reg::PR => self.pr,
            _ => 0,
        }
    }
}

impl Peripheral for Exti {
    fn name(&self) -> &'static str {
        "EXTI"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        lanes(self.peek(offset), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        match word {
            reg::PR => {
                // Write 1 to clear; the lanes not written write 0 (no effect).
                let clear = merge(0, offset, size, value) & LINES;
                self.pr &= !clear;
                self.swier &= !clear;
            }
            reg::SWIER => {
                let v = merge(self.swier, offset, size, value) & LINES;
                let new = v & !self.swier;
                self.swier |= v;
                self.trigger(new);
            }
            _ => {
                let v = merge(self.peek(word), offset, size, value) & LINES;
                match word {
                    reg::IMR => self.imr = v,
                    reg::EMR => self.emr = v,
                    reg::RTSR => self.rtsr = v,
                    reg::FTSR => self.ftsr = v,
                    _ => {}
                }
            }
        }
    }
}

impl IrqLines for Exti {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        let group = |mask: u32| self.pr & mask != 0;
        for l in 0..5 {
            line(6 + l as u16, group(1 << l));
        }
        line(23, group(0x3E0));
        line(40, group(0xFC00));
        for l in [16, 17, 18, 20, 21, 22] {
            if let Some(irq) = irq_of(l) {
                line(irq, group(1 << l));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn levels(e: &Exti) -> Vec<(u16, bool)> {
        let mut v = Vec::new();
        e.irqs(&mut |irq, high| v.push((irq, high)));
        v
    }

    fn high(e: &Exti, irq: u16) -> bool {
        levels(e).iter().any(|(i, h)| *i == irq && *h)
    }

    /// The board's e-stop: PC13, falling edge, EXTI15_10.
    #[test]
    fn a_falling_edge_on_line_13_pends_irq_40_until_cleared() {
        let mut e = Exti::new();
        e.write(reg::FTSR, Size::Word, 1 << 13);
        e.write(reg::IMR, Size::Word, 1 << 13);
        e.edges(1 << 13, 0);
        assert_eq!(e.read(reg::PR, Size::Word), 0, "rising: not selected");
        e.edges(0, 1 << 13);
        assert_eq!(e.read(reg::PR, Size::Word), 1 << 13);
        assert!(high(&e, 40));
        assert!(!high(&e, 23));
        // Writing 0 changes nothing; writing 1 clears.
        e.write(reg::PR, Size::Word, 0);
        assert!(high(&e, 40));
        e.write(reg::PR, Size::Word, 1 << 13);
        assert_eq!(e.read(reg::PR, Size::Word), 0);
        assert!(!high(&e, 40));
        // Masked: no pending (and no IRQ).
        e.write(reg::IMR, Size::Word, 0);
        e.edges(0, 1 << 13);
        assert_eq!(e.pending(), 0);
    }

    #[test]
    fn each_line_reaches_its_irq() {
        let mut e = Exti::new();
        e.write(reg::IMR, Size::Word, LINES);
        e.write(reg::RTSR, Size::Word, 0xFFFF_FFFF);
        assert_eq!(e.read(reg::RTSR, Size::Word), LINES, "line 19 absent");
        for (line, irq) in [
            (0, 6),
            (4, 10),
            (5, 23),
            (9, 23),
            (10, 40),
            (15, 40),
            (22, 3),
        ] {
            e.edges(1 << line, 0);
            assert!(high(&e, irq), "line {line}");
            e.write(reg::PR, Size::Word, 1 << line);
            assert!(!high(&e, irq), "line {line}");
        }
        assert_eq!(irq_of(19), None);
    }

    /// The chip's wiring for the board's e-stop, end to end: the button (PC13, pulled up,
    /// active low) through SYSCFG's EXTICR4 to EXTI line 13, falling edge, IRQ 40.
    #[test]
    fn the_button_on_pc13_through_syscfg_to_irq_40() {
        use crate::f446::gpio::{Drive, Gpio};
        use crate::f446::syscfg::{self, Syscfg};
        let mut portc = Gpio::new(2);
        let mut sys = Syscfg::new();
        let mut e = Exti::new();
        portc.set_input(13, Drive::High);
        sys.write(syscfg::reg::EXTICR4, Size::Word, 2 << 4);
        e.write(reg::FTSR, Size::Word, 1 << 13);
        e.write(reg::IMR, Size::Word, 1 << 13);
        let route = |g: &mut Gpio, s: &Syscfg, e: &mut Exti| {
            let edges = g.take_edges();
            let mine = u32::from(s.lines_of(2));
            e.edges(
                u32::from(edges.rising) & mine,
                u32::from(edges.falling) & mine,
            );
        };
        route(&mut portc, &sys, &mut e);
        assert_eq!(e.pending(), 0);
        portc.set_input(13, Drive::Low);
        route(&mut portc, &sys, &mut e);
        assert_eq!(e.pending(), 1 << 13);
        assert!(high(&e, 40));
        e.write(reg::PR, Size::Word, 1 << 13);
        portc.set_input(13, Drive::High);
        route(&mut portc, &sys, &mut e);
        assert!(!high(&e, 40), "release: a rising edge, not selected");
    }

    #[test]
    fn swier_and_events() {
        let mut e = Exti::new();
        e.write(reg::SWIER, Size::Word, 1 << 3);
        assert_eq!(e.pending(), 0, "IMR clear: no pending");
        assert_eq!(e.read(reg::SWIER, Size::Word), 1 << 3);
        e.write(reg::PR, Size::Word, 1 << 3);
        assert_eq!(e.read(reg::SWIER, Size::Word), 0, "cleared with PR");
        e.write(reg::IMR, Size::Word, 1 << 3);
        e.write(reg::SWIER, Size::Word, 1 << 3);
        assert_eq!(e.pending(), 1 << 3);
        assert!(high(&e, 9));
        e.write(reg::EMR, Size::Word, 1 << 0);
        e.write(reg::FTSR, Size::Word, 1 << 0);
        assert!(!e.take_event());
        e.edges(0, 1);
        assert!(e.take_event());
        assert!(!e.take_event());
        e.write(reg::PR + 1, Size::Byte, 0xFF);
        assert_eq!(e.pending(), 1 << 3, "byte lane 1 clears lines 8-15 only");
    }
}
