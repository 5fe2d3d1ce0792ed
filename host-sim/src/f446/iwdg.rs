//! The independent watchdog (IWDG, RM0390 §19) at 0x4000_3000: KR (0xCCCC start, 0xAAAA
//! reload, 0x5555 unlock PR/RLR; any other key locks them again), PR, RLR, SR (PVU, RVU),
//! and its 12-bit down-counter on the LSI (`Clocks::lsi_hz`) over the prescaler (4 << PR,
//! 256 for PR 6 and 7).
//!
//! Started with 0xCCCC the counter begins at 0xFFF (RM0390 §19.3.1: "the counter starts
//! counting down from the reset value of 0xFFF"), not at RLR; each 0xAAAA reloads it with
//! RLR. The chip must reset when it passes 0: from a load of value L, (L + 1) prescaled
//! ticks — RM0390 table 107's timeouts (0.125 ms for RL 0 at /4 at 32 kHz, 512 ms for RL
//! 0xFFF). [`Iwdg::expired`] says so, [`Iwdg::deadline`] and `next_event` give the time.
//! The prescaler's phase restarts at each load (on the chip it runs on; a difference of at
//! most one prescaled tick).
//!
//! A write to PR or RLR (unlocked) reaches the watchdog's LSI domain after
//! [`UPDATE_LSI_CYCLES`] LSI cycles ("up to 5 RC 40 kHz cycles"): PVU or RVU reads 1 until
//! then, and PR/RLR read the value in effect until then. A new prescaler in effect while the
//! counter runs keeps the count and changes its rate. The updates complete whether or not the
//! watchdog runs (the LSI is taken as running: started, the IWDG forces it on).
//!
//! Not modelled: the hardware watchdog option (WDG_SW in the option bytes: the watchdog
//! starts by itself after reset), the debug freeze (DBGMCU), the LSI's spread (17–47 kHz).

use super::{Clocks, Peripheral, Size, Time, lanes, merge};

/// LSI cycles for a PR or RLR write to take effect.
pub const UPDATE_LSI_CYCLES: u64 = 5;
/// KR: start.
pub const KEY_START: u32 = 0xCCCC;
/// KR: reload.
pub const KEY_RELOAD: u32 = 0xAAAA;
/// KR: unlock PR and RLR.
pub const KEY_UNLOCK: u32 = 0x5555;

/// Register offsets (RM0390 §19.4.5).
pub mod reg {
    /// Key.
    pub const KR: u32 = 0x00;
    /// Prescaler.
    pub const PR: u32 = 0x04;
    /// Reload.
    pub const RLR: u32 = 0x08;
    /// Status.
    pub const SR: u32 = 0x0C;
}

/// SR: prescaler update under way.
pub const PVU: u32 = 1 << 0;
/// SR: reload value update under way.
pub const RVU: u32 = 1 << 1;

/// The prescaler's divisor for PR `pr`.
pub fn divisor(pr: u32) -> u64 {
    4 << pr.min(6)
}

/// The IWDG.
#[derive(Clone, Debug)]
pub struct Iwdg {
    now: Time,
    lsi_hz: u32,
    unlocked: bool,
    pr: u32,
    rlr: u32,
    pending_pr: Option<(Time, u32)>,
    pending_rlr: Option<(Time, u32)>,
    /// Running: the time of the last load and the prescaled ticks from it to the reset.
    count: Option<(Time, u64)>,
}

impl Default for Iwdg {
    fn default() -> Self {
        Self::new()
    }
}

impl Iwdg {
    /// The IWDG after reset: stopped, PR 0, RLR 0xFFF.
    pub fn new() -> Iwdg {
        Iwdg {
            now: 0,
            lsi_hz: Clocks::RESET.lsi_hz,
            unlocked: false,
            pr: 0,
            rlr: 0xFFF,
            pending_pr: None,
            pending_rlr: None,
            count: None,
        }
    }

    /// A system reset: stopped, registers to their reset values (the model's time kept).
    pub fn reset(&mut self) {
        let (now, lsi_hz) = (self.now, self.lsi_hz);
        *self = Iwdg::new();
        self.now = now;
        self.lsi_hz = lsi_hz;
    }

    /// Whether the watchdog runs.
    pub fn running(&self) -> bool {
        self.count.is_some()
    }

    /// When the counter passes 0 (the chip's reset), if it runs.
    pub fn deadline(&self) -> Option<Time> {
        self.count
            .map(|(base, ticks)| base + Clocks::time_of(ticks * divisor(self.pr), self.lsi_hz))
    }

    /// Whether the watchdog has run out by `now`: the chip resets (IWDGRSTF).
    pub fn expired(&self, now: Time) -> bool {
        self.deadline().is_some_and(|t| t <= now)
    }

    /// The counter's value at the model's present time, if it runs.
    pub fn counter(&self) -> Option<u32> {
        self.count.map(|(base, ticks)| {
            let cycles = Clocks::ticks(self.now.saturating_sub(base), self.lsi_hz);
            let done = cycles / divisor(self.pr);
            ticks.saturating_sub(done + 1) as u32
        })
    }

    fn load(&mut self, value: u32) {
        self.count = Some((self.now, u64::from(value) + 1));
    }

    fn update_time(&self) -> Time {
        self.now + Clocks::time_of(UPDATE_LSI_CYCLES, self.lsi_hz)
    }

    /// A register's present value (reads have no side effects).
    pub fn peek(&self, offset: u32) -> u32 {
        match offset & !3 {
            reg::PR => self.pr,
            reg::RLR => self.rlr,
            reg::SR => {
                (if self.pending_pr.is_some() { PVU } else { 0 })
                    | (if self.pending_rlr.is_some() { RVU } else { 0 })
            }
            _ => 0,
        }
    }

    /// Apply the pending updates due by `t`.
    fn settle(&mut self, t: Time) {
        if let Some((at, pr)) = self.pending_pr.filter(|(at, _)| *at <= t) {
            self.pending_pr = None;
            // Keep the count: rebase at the change with the ticks still to go.
            if let Some((base, ticks)) = self.count {
                let cycles = Clocks::ticks(at.saturating_sub(base), self.lsi_hz);
                let left = ticks.saturating_sub(cycles / divisor(self.pr)).max(1);
                self.count = Some((at, left));
            }
            self.pr = pr;
        }
        if let Some((_, rlr)) = self.pending_rlr.filter(|(at, _)| *at <= t) {
            self.pending_rlr = None;
            self.rlr = rlr;
        }
    }
}

impl Peripheral for Iwdg {
    fn name(&self) -> &'static str {
        "IWDG"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        lanes(self.peek(offset), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        // The registers are 16 bits wide; a narrower write is taken at its lanes, the
        // others written as 0.
        let v = merge(0, offset, size, value);
        match offset & !3 {
            reg::KR => {
                let key = v & 0xFFFF;
                self.unlocked = key == KEY_UNLOCK;
                match key {
                    KEY_START if self.count.is_none() => self.load(0xFFF),
                    KEY_RELOAD if self.count.is_some() => self.load(self.rlr),
                    _ => {}
                }
            }
            reg::PR if self.unlocked => {
                self.pending_pr = Some((self.update_time(), v & 7));
            }
            reg::RLR if self.unlocked => {
                self.pending_rlr = Some((self.update_time(), v & 0xFFF));
            }
            _ => {}
        }
    }

    fn advance(&mut self, now: Time, clocks: &Clocks) {
        self.lsi_hz = clocks.lsi_hz;
        self.settle(now);
        self.now = self.now.max(now);
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        [
            self.pending_pr.map(|(t, _)| t),
            self.pending_rlr.map(|(t, _)| t),
            self.deadline(),
        ]
        .into_iter()
        .flatten()
        .min()
        .map(|t| t.max(now))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::f446::TIME_HZ;

    const MS: Time = TIME_HZ / 1_000;

    fn at(w: &mut Iwdg, t: Time) {
        w.advance(t, &Clocks::RESET);
    }

    fn wr(w: &mut Iwdg, o: u32, v: u32) {
        w.write(o, Size::Word, v);
    }

    #[test]
    fn reset_values_and_write_protection() {
        let mut w = Iwdg::new();
        assert_eq!(w.read(reg::PR, Size::Word), 0);
        assert_eq!(w.read(reg::RLR, Size::Word), 0xFFF);
        assert_eq!(w.read(reg::SR, Size::Word), 0);
        assert_eq!(w.read(reg::KR, Size::Word), 0);
        wr(&mut w, reg::PR, 3);
        assert_eq!(w.read(reg::SR, Size::Word), 0, "locked: ignored");
        wr(&mut w, reg::KR, KEY_UNLOCK);
        wr(&mut w, reg::KR, 0x1234);
        wr(&mut w, reg::RLR, 3);
        assert_eq!(w.read(reg::SR, Size::Word), 0, "relocked by another key");
        assert!(!w.running());
        assert_eq!(w.next_event(0, &Clocks::RESET), None);
    }

    /// The board's 500 ms: embassy's PR 0 (/4) and RLR 3999 at 32 kHz.
    #[test]
    fn the_boards_500_ms_timeout() {
        let mut w = Iwdg::new();
        at(&mut w, 1_000);
        wr(&mut w, reg::KR, KEY_UNLOCK);
        wr(&mut w, reg::PR, 0);
        wr(&mut w, reg::RLR, 3999);
        assert_eq!(w.read(reg::SR, Size::Word), PVU | RVU);
        assert_eq!(
            w.read(reg::RLR, Size::Word),
            0xFFF,
            "old value until updated"
        );
        let upd = 1_000 + Clocks::time_of(5, 32_000);
        assert_eq!(w.next_event(1_000, &Clocks::RESET), Some(upd));
        at(&mut w, upd - 1);
        assert_eq!(w.read(reg::SR, Size::Word), PVU | RVU);
        at(&mut w, upd);
        assert_eq!(w.read(reg::SR, Size::Word), 0);
        assert_eq!(w.read(reg::RLR, Size::Word), 3999);
        // Start: from 0xFFF, 4096 ticks of /4 = 512 ms.
        wr(&mut w, reg::KR, KEY_START);
        assert_eq!(w.deadline(), Some(upd + 512 * MS));
        assert_eq!(w.counter(), Some(0xFFF));
        // Pet: RLR 3999 → 4000 ticks = 500 ms.
        let t = upd + 100 * MS;
        at(&mut w, t);
        wr(&mut w, reg::KR, KEY_RELOAD);
        assert_eq!(w.deadline(), Some(t + 500 * MS));
        at(&mut w, t + 250 * MS);
        assert_eq!(w.counter(), Some(3999 - 2000));
        assert!(!w.expired(t + 500 * MS - 1));
        assert!(w.expired(t + 500 * MS));
        assert_eq!(w.next_event(t, &Clocks::RESET), Some(t + 500 * MS));
        // A second start does not reload.
        wr(&mut w, reg::KR, KEY_START);
        assert_eq!(w.deadline(), Some(t + 500 * MS));
        w.reset();
        assert!(!w.running());
        assert_eq!(w.read(reg::RLR, Size::Word), 0xFFF);
    }

    /// The board stretches the period for a flash erase: /256 and 0xFFF (≈ 32.8 s).
    #[test]
    fn a_longer_prescaler_in_effect_stretches_the_period() {
        let mut w = Iwdg::new();
        wr(&mut w, reg::KR, KEY_START);
        wr(&mut w, reg::KR, KEY_UNLOCK);
        wr(&mut w, reg::PR, 6);
        wr(&mut w, reg::RLR, 0xFFF);
        let upd = Clocks::time_of(5, 32_000);
        at(&mut w, upd);
        wr(&mut w, reg::KR, KEY_RELOAD);
        assert_eq!(w.deadline(), Some(upd + 4096 * 256 * TIME_HZ / 32_000));
        assert_eq!(divisor(7), 256);
        // Back to /4 mid-count keeps the count (4096 - 10 ticks left) at the new rate.
        at(&mut w, upd + 10 * 256 * TIME_HZ / 32_000);
        wr(&mut w, reg::KR, KEY_UNLOCK);
        wr(&mut w, reg::PR, 0);
        let upd2 = upd + 10 * 256 * TIME_HZ / 32_000 + upd;
        at(&mut w, upd2);
        assert_eq!(w.deadline(), Some(upd2 + 4086 * 4 * TIME_HZ / 32_000));
    }
}
