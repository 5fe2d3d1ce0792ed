//! The power controller (PWR, RM0390 §5) at 0x4000_7000: the regulator's voltage scale
//! (VOS), the over-drive handshake embassy runs for 180 MHz (ODEN → ODRDY, ODSWEN →
//! ODSWRDY), the backup domain's write protection (DBP, which the chip forwards to the RCC
//! with [`Pwr::backup_access`]) and the backup regulator.
//!
//! Timing (chosen, of the order of DS10693's over-drive switching and regulator times):
//! ODRDY comes [`OVER_DRIVE_READY`] after ODEN, ODSWRDY [`OVER_DRIVE_SWITCH`] after ODSWEN
//! (once ODRDY is set); VOSRDY comes [`VOS_READY`] after the main PLL is on (RM0390 §5.1.4:
//! the VOS value takes effect only with the PLL on; the chip reports the PLL with
//! [`Pwr::set_pll_on`]); BRR follows BRE after [`BACKUP_REGULATOR_READY`]. Clearing ODEN
//! clears ODSWEN, ODRDY and ODSWRDY at once.
//!
//! Not modelled: the low-power modes (LPDS, PDDS, FPDS, LPUDS, MRUDS, UDEN: stored, no
//! effect; the chip never enters Stop or Standby, so WUF and SBF stay 0 and CWUF/CSBF only
//! clear them), the PVD (PVDE/PLS stored, PVDO reads 0: VDD above the threshold), the wake-up
//! pins (EWUP1/2 stored), ADCDC1, FMSSR/FISSR (stored).

use super::{Clocks, Peripheral, Size, TIME_HZ, Time, lanes, merge};

const MICROSECOND: Time = TIME_HZ / 1_000_000;
/// From ODEN set to ODRDY.
pub const OVER_DRIVE_READY: Time = 50 * MICROSECOND;
/// From ODSWEN set (with ODRDY) to ODSWRDY.
pub const OVER_DRIVE_SWITCH: Time = 20 * MICROSECOND;
/// From the main PLL on to VOSRDY.
pub const VOS_READY: Time = 10 * MICROSECOND;
/// From BRE set to BRR.
pub const BACKUP_REGULATOR_READY: Time = 10 * MICROSECOND;

/// Register offsets (RM0390 §5.4).
pub mod reg {
    /// Power control.
    pub const CR: u32 = 0x00;
    /// Power control/status.
    pub const CSR: u32 = 0x04;
}

/// PWR_CR bits.
pub mod cr {
    /// Clear the wake-up flag (write 1; reads 0).
    pub const CWUF: u32 = 1 << 2;
    /// Clear the standby flag (write 1; reads 0).
    pub const CSBF: u32 = 1 << 3;
    /// Disable backup domain write protection.
    pub const DBP: u32 = 1 << 8;
    /// Regulator voltage scaling output selection (2 bits: 01 scale 3, 10 scale 2, 11 scale 1).
    pub const VOS_SHIFT: u32 = 14;
    /// Over-drive enable.
    pub const ODEN: u32 = 1 << 16;
    /// Over-drive switching enable.
    pub const ODSWEN: u32 = 1 << 17;
    /// The writable bits.
    pub const MASK: u32 = 0x003F_EFF3;
}

/// PWR_CSR bits.
pub mod csr {
    /// Backup regulator ready.
    pub const BRR: u32 = 1 << 3;
    /// Backup regulator enable.
    pub const BRE: u32 = 1 << 9;
    /// Voltage scaling output ready.
    pub const VOSRDY: u32 = 1 << 14;
    /// Over-drive ready.
    pub const ODRDY: u32 = 1 << 16;
    /// Over-drive switching ready.
    pub const ODSWRDY: u32 = 1 << 17;
    /// The writable bits (EWUP2, EWUP1, BRE).
    pub const MASK: u32 = (1 << 7) | (1 << 8) | BRE;
}

/// CR's reset value: VOS = 11 (scale 1).
const CR_RESET: u32 = 0x0000_C000;

/// The PWR's registers and its ready handshakes.
#[derive(Clone, Debug)]
pub struct Pwr {
    now: Time,
    cr: u32,
    /// CSR's writable bits (EWUP1/2, BRE).
    csr: u32,
    pll_on: bool,
    od_ready_at: Option<Time>,
    od_ready: bool,
    odsw_ready_at: Option<Time>,
    odsw_ready: bool,
    vos_ready_at: Option<Time>,
    vos_ready: bool,
    br_ready_at: Option<Time>,
    br_ready: bool,
}

impl Default for Pwr {
    fn default() -> Self {
        Self::new()
    }
}

impl Pwr {
    /// The PWR after reset (CR 0x0000_C000, CSR 0).
    pub fn new() -> Pwr {
        Pwr {
            now: 0,
            cr: CR_RESET,
            csr: 0,
            pll_on: false,
            od_ready_at: None,
            od_ready: false,
            odsw_ready_at: None,
            odsw_ready: false,
            vos_ready_at: None,
            vos_ready: false,
            br_ready_at: None,
            br_ready: false,
        }
    }

    /// A system reset: the registers to their reset values (the backup regulator's BRE is in
    /// the backup domain, RM0390 §5.4.2, and is kept). The model's time is kept.
    pub fn reset(&mut self) {
        let (now, bre, br_ready) = (self.now, self.csr & csr::BRE, self.br_ready);
        *self = Pwr::new();
        self.now = now;
        self.csr = bre;
        self.br_ready = br_ready && bre != 0;
    }

    /// Whether DBP allows writes to the backup domain (RCC_BDCR, the RTC, backup SRAM).
    pub fn backup_access(&self) -> bool {
        self.cr & cr::DBP != 0
    }

    /// Whether the over-drive is on and switched (ODRDY and ODSWRDY): what 180 MHz needs.
    pub fn over_drive(&self) -> bool {
        self.od_ready && self.odsw_ready
    }

    /// Report whether the main PLL is on (from RCC_CR; the chip forwards it).
    pub fn set_pll_on(&mut self, on: bool) {
        if on != self.pll_on {
            self.pll_on = on;
            self.vos_ready = false;
            self.vos_ready_at = on.then_some(self.now + VOS_READY);
        }
    }

    /// A register's present value (reads have no side effects).
    pub fn peek(&self, offset: u32) -> u32 {
        match offset & !3 {
            reg::CR => self.cr,
            reg::CSR => {
                let mut v = self.csr;
                for (on, bit) in [
                    (self.br_ready, csr::BRR),
                    (self.vos_ready, csr::VOSRDY),
                    (self.od_ready, csr::ODRDY),
                    (self.odsw_ready, csr::ODSWRDY),
                ] {
                    if on {
                        v |= bit;
                    }
                }
                v
            }
            _ => 0,
        }
    }

    fn pending(&self) -> Option<Time> {
        [
            self.od_ready_at,
            self.odsw_ready_at,
            self.vos_ready_at,
            self.br_ready_at,
        ]
        .into_iter()
        .flatten()
        .min()
    }
}

impl Peripheral for Pwr {
    fn name(&self) -> &'static str {
        "PWR"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        lanes(self.peek(offset), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        let v = merge(self.peek(word), offset, size, value);
        match word {
            reg::CR => {
                let old = self.cr;
                // CWUF/CSBF clear WUF/SBF (never set here) and read 0.
                let mut new = v & cr::MASK & !(cr::CWUF | cr::CSBF);
                // ODSWEN needs ODEN (RM0390 §5.1.4).
                if new & cr::ODEN == 0 {
                    new &= !cr::ODSWEN;
                }
                self.cr = new;
                if new & cr::ODEN == 0 {
                    self.od_ready = false;
                    self.od_ready_at = None;
                } else if old & cr::ODEN == 0 {
                    self.od_ready_at = Some(self.now + OVER_DRIVE_READY);
                }
                if new & cr::ODSWEN == 0 {
                    self.odsw_ready = false;
                    self.odsw_ready_at = None;
                } else if old & cr::ODSWEN == 0 && self.od_ready {
                    self.odsw_ready_at = Some(self.now + OVER_DRIVE_SWITCH);
                }
                if ((new ^ old) >> cr::VOS_SHIFT) & 3 != 0 && self.pll_on {
                    self.vos_ready = false;
                    self.vos_ready_at = Some(self.now + VOS_READY);
                }
            }
            reg::CSR => {
                let old = self.csr;
                self.csr = v & csr::MASK;
                if self.csr & csr::BRE == 0 {
                    self.br_ready = false;
                    self.br_ready_at = None;
                } else if old & csr::BRE == 0 {
                    self.br_ready_at = Some(self.now + BACKUP_REGULATOR_READY);
                }
            }
            _ => {}
        }
    }

    fn advance(&mut self, now: Time, _clocks: &Clocks) {
        for (at, ready) in [
            (&mut self.od_ready_at, &mut self.od_ready),
            (&mut self.vos_ready_at, &mut self.vos_ready),
            (&mut self.br_ready_at, &mut self.br_ready),
            (&mut self.odsw_ready_at, &mut self.odsw_ready),
        ] {
            if at.is_some_and(|t| t <= now) {
                *at = None;
                *ready = true;
            }
        }
        self.now = self.now.max(now);
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        self.pending().map(|t| t.max(now))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(p: &mut Pwr, t: Time) {
        p.advance(t, &Clocks::RESET);
    }

    fn modify(p: &mut Pwr, f: impl Fn(u32) -> u32) {
        let v = p.read(reg::CR, Size::Word);
        p.write(reg::CR, Size::Word, f(v));
    }

    #[test]
    fn reset_values() {
        let mut p = Pwr::new();
        assert_eq!(p.read(reg::CR, Size::Word), 0x0000_C000);
        assert_eq!(p.read(reg::CSR, Size::Word), 0);
        assert!(!p.backup_access());
    }

    /// Embassy's F446 sequence: VOS scale 1, ODEN, wait ODRDY, ODSWEN, wait ODSWRDY.
    #[test]
    fn over_drive_handshake_in_order_and_with_its_delays() {
        let mut p = Pwr::new();
        at(&mut p, 100);
        modify(&mut p, |v| v | (3 << cr::VOS_SHIFT));
        // ODSWEN before ODEN is refused.
        modify(&mut p, |v| v | cr::ODSWEN);
        assert_eq!(p.read(reg::CR, Size::Word) & cr::ODSWEN, 0);
        modify(&mut p, |v| v | cr::ODEN);
        assert_eq!(p.read(reg::CSR, Size::Word) & csr::ODRDY, 0);
        assert_eq!(
            p.next_event(100, &Clocks::RESET),
            Some(100 + OVER_DRIVE_READY)
        );
        at(&mut p, 100 + OVER_DRIVE_READY - 1);
        assert_eq!(p.read(reg::CSR, Size::Word) & csr::ODRDY, 0);
        at(&mut p, 100 + OVER_DRIVE_READY);
        assert_ne!(p.read(reg::CSR, Size::Word) & csr::ODRDY, 0);
        let t = 100 + OVER_DRIVE_READY;
        modify(&mut p, |v| v | cr::ODSWEN);
        at(&mut p, t + OVER_DRIVE_SWITCH);
        assert_eq!(
            p.read(reg::CSR, Size::Word) & (csr::ODRDY | csr::ODSWRDY),
            csr::ODRDY | csr::ODSWRDY
        );
        assert!(p.over_drive());
        // ODEN off drops everything.
        modify(&mut p, |v| v & !cr::ODEN);
        assert_eq!(p.read(reg::CR, Size::Word) & cr::ODSWEN, 0);
        assert_eq!(p.read(reg::CSR, Size::Word), 0);
        assert_eq!(p.next_event(t, &Clocks::RESET), None);
    }

    #[test]
    fn vosrdy_follows_the_pll_and_brr_follows_bre() {
        let mut p = Pwr::new();
        p.set_pll_on(true);
        at(&mut p, VOS_READY);
        assert_ne!(p.read(reg::CSR, Size::Word) & csr::VOSRDY, 0);
        p.set_pll_on(false);
        assert_eq!(p.read(reg::CSR, Size::Word) & csr::VOSRDY, 0);
        p.write(reg::CSR, Size::Word, csr::BRE | csr::ODRDY);
        assert_eq!(
            p.read(reg::CSR, Size::Word),
            csr::BRE,
            "ready bits read-only"
        );
        at(&mut p, VOS_READY + BACKUP_REGULATOR_READY);
        assert_eq!(p.read(reg::CSR, Size::Word), csr::BRE | csr::BRR);
        modify(&mut p, |v| v | cr::DBP | cr::CWUF);
        assert!(p.backup_access());
        assert_eq!(p.read(reg::CR, Size::Word) & cr::CWUF, 0);
        p.reset();
        assert!(!p.backup_access());
        assert_eq!(p.read(reg::CSR, Size::Word), csr::BRE | csr::BRR);
    }
}
