//! The general-purpose I/O ports (GPIOA..H, RM0390 §7) at 0x4002_0000 + 0x400 × port: one
//! [`Gpio`] per port, with MODER, OTYPER, OSPEEDR, PUPDR, IDR, ODR, BSRR, LCKR, AFRL, AFRH
//! and their reset values (GPIOA and GPIOB differ: the debug pins, RM0390 §7.4).
//!
//! The harness drives each pin from outside ([`Gpio::set_input`]: high, low or floating) and
//! reads what the port drives ([`Gpio::output`]). A pin's level — what IDR reads and EXTI
//! sees — is, in order: the port's own driver (output mode: push-pull drives ODR, open-drain
//! drives low when ODR is 0), else the external drive, else the pull (up 1, down 0), else 0
//! (a floating input reads 0 here; on the chip it is undefined). When both the port and the
//! outside drive a pin, the port's level is taken (a short on the chip). Analog mode reads 0
//! (the Schmitt trigger is off). In alternate-function mode the peripheral's output is not
//! modelled here: the pin's level is the outside's or the pull's. Each change of a pin's
//! level is kept as an edge until [`Gpio::take_edges`] (for EXTI).
//!
//! BSRR: a write sets the ODR bits of its low half and resets those of its high half; set
//! has priority when both name a bit (RM0390 §7.4.7); it reads 0. LCKR: the lock sequence
//! (write LCKK=1, write LCKK=0, write LCKK=1 with the same `LCK[15:0]`, then read) freezes the
//! locked pins' MODER, OTYPER, OSPEEDR, PUPDR and AFR bits and LCKR itself until reset; any
//! other order aborts it (RM0390 §7.4.8). OSPEEDR is stored only (no slew-rate model).

use super::{Peripheral, Size, lanes, merge};

/// Register offsets (RM0390 §7.4.11).
pub mod reg {
    /// Port mode.
    pub const MODER: u32 = 0x00;
    /// Output type.
    pub const OTYPER: u32 = 0x04;
    /// Output speed.
    pub const OSPEEDR: u32 = 0x08;
    /// Pull-up/pull-down.
    pub const PUPDR: u32 = 0x0C;
    /// Input data.
    pub const IDR: u32 = 0x10;
    /// Output data.
    pub const ODR: u32 = 0x14;
    /// Bit set/reset.
    pub const BSRR: u32 = 0x18;
    /// Configuration lock.
    pub const LCKR: u32 = 0x1C;
    /// Alternate function low (pins 0–7).
    pub const AFRL: u32 = 0x20;
    /// Alternate function high (pins 8–15).
    pub const AFRH: u32 = 0x24;
}

/// The lock key bit of LCKR.
pub const LCKK: u32 = 1 << 16;

/// How the outside drives a pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Drive {
    /// Driven high.
    High,
    /// Driven low.
    Low,
    /// Not driven (the pull, if any, decides).
    #[default]
    Floating,
}

/// A pin's mode (MODER).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Input (00).
    Input,
    /// General-purpose output (01).
    Output,
    /// Alternate function (10).
    Alternate,
    /// Analog (11).
    Analog,
}

/// The level changes since the last [`Gpio::take_edges`], one bit per pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Edges {
    /// Pins that went from 0 to 1.
    pub rising: u16,
    /// Pins that went from 1 to 0.
    pub falling: u16,
}

const NAMES: [&str; 8] = [
    "GPIOA", "GPIOB", "GPIOC", "GPIOD", "GPIOE", "GPIOF", "GPIOG", "GPIOH",
];

/// One GPIO port.
#[derive(Clone, Debug)]
pub struct Gpio {
    port: usize,
    moder: u32,
    otyper: u32,
    ospeedr: u32,
    pupdr: u32,
    odr: u32,
    afr: [u32; 2],
    lckr: u32,
    /// The lock sequence's progress (0: none, 1..3 writes done).
    lock_step: u8,
    external: [Drive; 16],
    levels: u16,
    edges: Edges,
}

impl Gpio {
    /// Port `port` (0 = A .. 7 = H) after reset, nothing driving its pins from outside.
    pub fn new(port: usize) -> Gpio {
        assert!(port < NAMES.len(), "no GPIO port {port}");
        let mut g = Gpio {
            port,
            moder: 0,
            otyper: 0,
            ospeedr: 0,
            pupdr: 0,
            odr: 0,
            afr: [0; 2],
            lckr: 0,
            lock_step: 0,
            external: [Drive::Floating; 16],
            levels: 0,
            edges: Edges::default(),
        };
        g.reset();
        g.edges = Edges::default();
        g
    }

    /// A system reset: the registers to their reset values (the outside's drive is kept;
    /// level changes it causes are edges).
    pub fn reset(&mut self) {
        let (moder, ospeedr, pupdr) = match self.port {
            0 => (0xA800_0000, 0x0C00_0000, 0x6400_0000),
            1 => (0x0000_0280, 0x0000_00C0, 0x0000_0100),
            _ => (0, 0, 0),
        };
        self.moder = moder;
        self.ospeedr = ospeedr;
        self.pupdr = pupdr;
        self.otyper = 0;
        self.odr = 0;
        self.afr = [0; 2];
        self.lckr = 0;
        self.lock_step = 0;
        self.update();
    }

    /// Drive pin `pin` (0–15) from outside.
    pub fn set_input(&mut self, pin: usize, drive: Drive) {
        self.external[pin] = drive;
        self.update();
    }

    /// Pin `pin`'s mode.
    pub fn mode(&self, pin: usize) -> Mode {
        match (self.moder >> (2 * pin)) & 3 {
            0 => Mode::Input,
            1 => Mode::Output,
            2 => Mode::Alternate,
            _ => Mode::Analog,
        }
    }

    /// Pin `pin`'s alternate function number (AFRL/AFRH).
    pub fn alternate(&self, pin: usize) -> u8 {
        ((self.afr[pin / 8] >> (4 * (pin % 8))) & 0xF) as u8
    }

    /// The level the port drives on `pin`: Some in output mode (push-pull: ODR; open-drain:
    /// low when ODR is 0), None when it does not drive it.
    pub fn output(&self, pin: usize) -> Option<bool> {
        if self.mode(pin) != Mode::Output {
            return None;
        }
        let high = self.odr & (1 << pin) != 0;
        let open_drain = self.otyper & (1 << pin) != 0;
        match (open_drain, high) {
            (true, true) => None,
            _ => Some(high),
        }
    }

    /// The pins' levels as IDR reads them (bit per pin).
    pub fn levels(&self) -> u16 {
        self.levels
    }

    /// The level changes since the last call.
    pub fn take_edges(&mut self) -> Edges {
        std::mem::take(&mut self.edges)
    }

    fn level(&self, pin: usize) -> bool {
        if self.mode(pin) == Mode::Analog {
            return false;
        }
        if let Some(level) = self.output(pin) {
            return level;
        }
        match self.external[pin] {
            Drive::High => true,
            Drive::Low => false,
            Drive::Floating => (self.pupdr >> (2 * pin)) & 3 == 1,
        }
    }

    /// Recompute the levels; record the changes as edges.
    fn update(&mut self) {
        let new = (0..16).fold(0u16, |v, p| v | (u16::from(self.level(p)) << p));
        let changed = new ^ self.levels;
        self.edges.rising |= changed & new;
        self.edges.falling |= changed & !new;
        self.levels = new;
    }

    /// The mask of a 2-bit-per-pin register's bits that locked pins freeze.
    fn locked_mask2(&self) -> u32 {
        (0..16)
            .filter(|p| self.locked(*p))
            .fold(0, |m, p| m | (3 << (2 * p)))
    }

    fn locked(&self, pin: usize) -> bool {
        self.lckr & LCKK != 0 && self.lckr & (1 << pin) != 0
    }

    /// A register's present value (IDR included; no read side effects but LCKR's).
    pub fn peek(&self, offset: u32) -> u32 {
        match offset & !3 {
            reg::MODER => self.moder,
            reg::OTYPER => self.otyper,
            reg::OSPEEDR => self.ospeedr,
            reg::PUPDR => self.pupdr,
            reg::IDR => u32::from(self.levels),
            reg::ODR => self.odr,
            reg::LCKR => self.lckr,
            reg::AFRL => self.afr[0],
            reg::AFRH => self.afr[1],
            _ => 0,
        }
    }

    fn lock_write(&mut self, v: u32) {
        if self.lckr & LCKK != 0 {
            return; // Locked until reset.
        }
        let keys = v & 0xFFFF;
        let same = keys == self.lckr & 0xFFFF;
        let k = v & LCKK != 0;
        self.lock_step = match (self.lock_step, k) {
            (0, true) => 1,
            (1, false) if same => 2,
            (2, true) if same => 3,
            (_, true) => 1,
            _ => 0,
        };
        self.lckr = keys;
    }
}

impl Peripheral for Gpio {
    fn name(&self) -> &'static str {
        NAMES[self.port]
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        if offset & !3 == reg::LCKR && self.lock_step == 3 {
            // The read that completes the sequence: LCKK now reads 1.
            self.lckr |= LCKK;
            self.lock_step = 0;
        }
        lanes(self.peek(offset), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        if word == reg::BSRR {
            let v = merge(0, offset, size, value);
            let set = v & 0xFFFF;
            let reset = (v >> 16) & !set;
            self.odr = (self.odr | set) & !reset;
            self.update();
            return;
        }
        let v = merge(self.peek(word), offset, size, value);
        let frozen2 = self.locked_mask2();
        let keep = |old: u32, new: u32, frozen: u32| (old & frozen) | (new & !frozen);
        match word {
            reg::MODER => self.moder = keep(self.moder, v, frozen2),
            reg::OSPEEDR => self.ospeedr = keep(self.ospeedr, v, frozen2),
            reg::PUPDR => self.pupdr = keep(self.pupdr, v, frozen2),
            reg::OTYPER => {
                let frozen = (0..16)
                    .filter(|p| self.locked(*p))
                    .fold(0, |m, p| m | (1 << p));
                self.otyper = keep(self.otyper, v & 0xFFFF, frozen);
            }
            reg::ODR => self.odr = v & 0xFFFF,
            reg::LCKR => self.lock_write(v),
            reg::AFRL | reg::AFRH => {
                let half = ((word - reg::AFRL) / 4) as usize;
                let frozen = (0..8)
                    .filter(|p| self.locked(half * 8 + p))
                    .fold(0, |m, p| m | (0xF << (4 * p)));
                self.afr[half] = keep(self.afr[half], v, frozen);
            }
            _ => {}
        }
        self.update();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rd(g: &mut Gpio, o: u32) -> u32 {
        g.read(o, Size::Word)
    }

    fn wr(g: &mut Gpio, o: u32, v: u32) {
        g.write(o, Size::Word, v);
    }

    #[test]
    fn reset_values_per_port() {
        let mut a = Gpio::new(0);
        assert_eq!(a.name(), "GPIOA");
        assert_eq!(rd(&mut a, reg::MODER), 0xA800_0000);
        assert_eq!(rd(&mut a, reg::OSPEEDR), 0x0C00_0000);
        assert_eq!(rd(&mut a, reg::PUPDR), 0x6400_0000);
        let mut b = Gpio::new(1);
        assert_eq!(rd(&mut b, reg::MODER), 0x0000_0280);
        assert_eq!(rd(&mut b, reg::OSPEEDR), 0x0000_00C0);
        assert_eq!(rd(&mut b, reg::PUPDR), 0x0000_0100);
        let mut c = Gpio::new(2);
        for o in [
            reg::MODER,
            reg::OSPEEDR,
            reg::PUPDR,
            reg::ODR,
            reg::AFRL,
            reg::AFRH,
        ] {
            assert_eq!(rd(&mut c, o), 0);
        }
        // PA13 and PA15 (SWDIO, JTDI: AF with pull-up) read 1, PA14 (pull-down) 0.
        assert_eq!(rd(&mut a, reg::IDR), (1 << 13) | (1 << 15));
        assert_eq!(rd(&mut b, reg::IDR), 1 << 4, "PB4 (NJTRST) pulled up");
        assert_eq!(Gpio::new(7).name(), "GPIOH");
    }

    #[test]
    fn bsrr_sets_and_resets_with_set_winning_and_reads_zero() {
        let mut g = Gpio::new(2);
        wr(&mut g, reg::MODER, 0x5555_5555);
        wr(&mut g, reg::BSRR, 0x0000_00F0);
        assert_eq!(rd(&mut g, reg::ODR), 0xF0);
        wr(&mut g, reg::BSRR, 0x0030_0011);
        assert_eq!(rd(&mut g, reg::ODR), 0xD1, "bit 4 set and reset: set wins");
        assert_eq!(rd(&mut g, reg::BSRR), 0);
        // A half-word write at +2 is a reset-only write.
        g.write(reg::BSRR + 2, Size::Half, 0x0001);
        assert_eq!(rd(&mut g, reg::ODR), 0xD0);
        assert_eq!(rd(&mut g, reg::IDR), 0xD0, "outputs read back");
        assert_eq!(g.output(4), Some(true));
        assert_eq!(g.output(0), Some(false));
    }

    #[test]
    fn idr_follows_the_outside_the_pull_or_the_driver_by_mode() {
        let mut g = Gpio::new(2);
        // PC13: input with pull-up (the board's e-stop button, active low).
        wr(&mut g, reg::PUPDR, 1 << 26);
        assert_eq!(rd(&mut g, reg::IDR), 1 << 13);
        g.take_edges();
        g.set_input(13, Drive::Low);
        assert_eq!(rd(&mut g, reg::IDR), 0);
        assert_eq!(
            g.take_edges(),
            Edges {
                rising: 0,
                falling: 1 << 13
            }
        );
        g.set_input(13, Drive::Floating);
        assert_eq!(
            g.take_edges(),
            Edges {
                rising: 1 << 13,
                falling: 0
            }
        );
        assert_eq!(g.take_edges(), Edges::default());
        // Pull-down, floating: 0; driven high: 1.
        wr(&mut g, reg::PUPDR, 2 << 26);
        assert_eq!(rd(&mut g, reg::IDR), 0);
        g.set_input(13, Drive::High);
        assert_eq!(rd(&mut g, reg::IDR), 1 << 13);
        // Analog: 0 whatever the outside.
        wr(&mut g, reg::MODER, 3 << 26);
        assert_eq!(rd(&mut g, reg::IDR), 0);
        // Open-drain output with ODR 1: released, the outside decides; ODR 0 pulls low.
        wr(&mut g, reg::MODER, 1 << 26);
        wr(&mut g, reg::OTYPER, 1 << 13);
        wr(&mut g, reg::ODR, 1 << 13);
        assert_eq!(g.output(13), None);
        assert_eq!(rd(&mut g, reg::IDR), 1 << 13);
        g.set_input(13, Drive::Low);
        assert_eq!(rd(&mut g, reg::IDR), 0);
        g.set_input(13, Drive::High);
        wr(&mut g, reg::ODR, 0);
        assert_eq!(g.output(13), Some(false));
        assert_eq!(rd(&mut g, reg::IDR), 0);
        // Alternate function: the outside's level; AFRH holds the function.
        wr(&mut g, reg::MODER, 2 << 26);
        wr(&mut g, reg::AFRH, 7 << 20);
        assert_eq!(g.mode(13), Mode::Alternate);
        assert_eq!(g.alternate(13), 7);
        assert_eq!(g.output(13), None);
        assert_eq!(rd(&mut g, reg::IDR), 1 << 13);
        // IDR is read-only.
        wr(&mut g, reg::IDR, 0);
        assert_eq!(rd(&mut g, reg::IDR), 1 << 13);
    }

    #[test]
    fn the_lock_sequence_freezes_the_locked_pins_configuration() {
        let mut g = Gpio::new(0);
        // An aborted sequence (the second write with LCKK set) locks nothing.
        wr(&mut g, reg::LCKR, LCKK | 0x20);
        wr(&mut g, reg::LCKR, LCKK | 0x20);
        rd(&mut g, reg::LCKR);
        assert_eq!(rd(&mut g, reg::LCKR) & LCKK, 0);
        wr(&mut g, reg::LCKR, LCKK | 0x20);
        wr(&mut g, reg::LCKR, 0x20);
        wr(&mut g, reg::LCKR, LCKK | 0x20);
        assert_eq!(rd(&mut g, reg::LCKR), LCKK | 0x20);
        assert_eq!(rd(&mut g, reg::LCKR), LCKK | 0x20);
        // PA5's mode frozen, PA6's free; ODR is never locked.
        wr(&mut g, reg::MODER, 0xA800_0000 | (1 << 10) | (1 << 12));
        assert_eq!(rd(&mut g, reg::MODER), 0xA800_0000 | (1 << 12));
        wr(&mut g, reg::AFRL, 0xFFFF_FFFF);
        assert_eq!(rd(&mut g, reg::AFRL), 0xFF0F_FFFF);
        wr(&mut g, reg::ODR, 1 << 5);
        assert_eq!(rd(&mut g, reg::ODR), 1 << 5);
        wr(&mut g, reg::LCKR, 0);
        assert_eq!(rd(&mut g, reg::LCKR), LCKK | 0x20, "LCKR frozen too");
        g.reset();
        assert_eq!(rd(&mut g, reg::LCKR), 0);
    }
}
