//! The general-purpose timers TIM2–TIM5 (RM0390 §17) and TIM12 (RM0390 §18, the 2-channel
//! TIM9/12 layout): one model, parameterised by the instance ([`TimInstance`]).
//!
//! This file owns the timers' register windows, their counters (prescaler, auto-reload, compare
//! matches, update events and the preload/shadow registers), their status flags and interrupt
//! lines, and, for the harness, each channel's PWM output ([`Tim::pwm_duty`]).
//!
//! What the board uses: TIM12 is embassy's time driver (`time-driver-any` picks it on the
//! F446: 1 MHz tick, PSC = 89 at 90 MHz, ARR = 0xFFFF, CC1 at 0x8000 for the half-period count,
//! CC2 the alarm, UIE/CC1IE/CC2IE on IRQ 43), TIM3 CH1 the heater's 1 kHz PWM (PSC 1, ARR 44 999)
//! and TIM4 CH1 the fan's 25 kHz PWM (PSC 0, ARR 3 599), both PWM mode 1, OC1PE and ARPE set.
//!
//! Modelled as RM0390 says:
//! - the counter on the internal clock (the APB1 timer clock, [`Clocks::tim_apb1_hz`]): the
//!   prescaler (PSC preloaded, taking effect at the next update event), edge-aligned up- and
//!   downcounting (DIR), center-aligned counting (CMS: 0 up to ARR, an overflow, down to 0, an
//!   underflow; DIR read-only, showing the direction; compare flags only counting down, only
//!   up or both as CMS says), the auto-reload (ARR, preloaded when ARPE), a null ARR blocking the
//!   counter, one-pulse mode (OPM clears CEN at the update event), UDIS and URS;
//! - update events: overflow/underflow and EGR.UG (UG reinitialises the counter and the
//!   prescaler counter; it loads PSC, ARR and CCRx into their shadows and sets UIF unless
//!   UDIS = 1; with URS = 1 it sets no UIF — §17.4.1, §17.4.5, §17.4.6);
//! - output compare: CCxIF when the counter reaches CCRx (counting into it, so a CCRx of 0
//!   matches as the counter wraps to 0 — every output channel left at CCR 0 flags each period,
//!   as TIM12's CC2 does before the first alarm; a CCRx above ARR is never reached while the
//!   counter is within ARR; writing CNT or UG is no match), CCRx preloaded when OCxPE, OCxREF
//!   in the modes frozen / active / inactive / toggle on match / forced / PWM 1 and 2;
//! - SR's flags rc_w0 (writing 0 clears, 1 leaves), EGR's UG, CCxG (input channels capture the
//!   counter, CCxOF when CCxIF was already set) and TG (sets TIF);
//! - DIER's interrupt enables and the IRQ line (UIF·UIE, CCxIF·CCxIE, TIF·TIE: one line per
//!   timer; TIM12's is TIM8_BRK_TIM12, IRQ 43);
//! - CCxS writable only while CCxE = 0, CCRx read-only for a channel configured as input;
//! - DMAR: an access reaches the register DCR.DBA + the burst index (advanced on each access,
//!   wrapping after DBL + 1 transfers, reset by a DCR write) — TIM2–5 only.
//!
//! Not modelled (the board never uses them; the registers read back what was written):
//! - the slave mode controller (SMCR: external clocks, trigger, gated and reset modes), the
//!   master mode output (CR2.MMS), the TI1 XOR (CR2.TI1S), OCxREF clear (OCxCE), OCxFE, the
//!   input filters and prescalers, the option registers (OR);
//! - input capture from pins (no pin drives a timer input here): only CCxG captures;
//! - the timers' DMA requests (UDE, CCxDE, TDE, CCDS are stored, nothing is requested);
//! - a counter written above ARR, counting up, counts to its top (0xFFFF or 0xFFFF_FFFF) and
//!   wraps to 0 without an update event (RM0390 does not say; a compare match above ARR is
//!   reached then); counting down it underflows at 0 as usual;
//! - center-aligned, the details RM0390 leaves open: UG restarts the counter from 0 counting
//!   up; a match at ARR counts as counting up, at 0 as counting down; the on-match OCxREF
//!   modes act in both directions.
//!
//! Time: [`Peripheral::advance`] counts whole timer clock ticks at the clock it is given (a
//! change of the timer clock is exact to one tick); [`Peripheral::next_event`] is the next
//! instant a flag not yet set is set (or OPM stops the counter), None when no period will ever
//! set one (a PWM timer whose flags software leaves set wakes nobody).
//!
//! A stopped timer's output (CEN = 0) holds a static level: its OCxREF at the present counter
//! value (in PWM mode 1 upcounting: high while CNT < CCRx), through CCxP; [`Tim::pwm_duty`]
//! reports it as 0 or 1. A disabled output (CCxE = 0) is not driven: its duty is 0 (the board's
//! gates have pull-downs).

use super::{Clocks, IrqLines, Peripheral, Size, Time, lanes, merge};

/// One general-purpose timer instance: where it is, how wide its counter is, how many
/// channels and which interrupt line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimInstance {
    /// RM0390's name (`"TIM3"`).
    pub name: &'static str,
    /// The register window's base address.
    pub base: u32,
    /// The NVIC position of its interrupt line (RM0390 table 38).
    pub irq: u16,
    /// Whether CNT, ARR and CCRx are 32 bits wide (TIM2, TIM5) rather than 16.
    pub counter_32bit: bool,
    /// Capture/compare channels: 4 (TIM2–5) or 2 (TIM12, with the TIM9/12 register layout:
    /// no CR2, DCR, DMAR, no DMA enables).
    pub channels: usize,
    /// The writable bits of its option register (OR, offset 0x50; 0: none).
    pub or_mask: u32,
}

/// TIM2: 32-bit, 4 channels, IRQ 28.
pub const TIM2: TimInstance = TimInstance {
    name: "TIM2",
    base: 0x4000_0000,
    irq: 28,
    counter_32bit: true,
    channels: 4,
    or_mask: 0x0C00,
};
/// TIM3: 16-bit, 4 channels, IRQ 29 (the heater's PWM on CH1).
pub const TIM3: TimInstance = TimInstance {
    name: "TIM3",
    base: 0x4000_0400,
    irq: 29,
    counter_32bit: false,
    channels: 4,
    or_mask: 0,
};
/// TIM4: 16-bit, 4 channels, IRQ 30 (the fan's PWM on CH1).
pub const TIM4: TimInstance = TimInstance {
    name: "TIM4",
    base: 0x4000_0800,
    irq: 30,
    counter_32bit: false,
    channels: 4,
    or_mask: 0,
};
/// TIM5: 32-bit, 4 channels, IRQ 50.
pub const TIM5: TimInstance = TimInstance {
    name: "TIM5",
    base: 0x4000_0C00,
    irq: 50,
    counter_32bit: true,
    channels: 4,
    or_mask: 0x00C0,
};
/// TIM12: 16-bit, 2 channels, IRQ 43 (TIM8_BRK_TIM12; embassy's time driver).
pub const TIM12: TimInstance = TimInstance {
    name: "TIM12",
    base: 0x4000_1800,
    irq: 43,
    counter_32bit: false,
    channels: 2,
    or_mask: 0,
};

/// Register offsets.
const CR1: u32 = 0x00;
const CR2: u32 = 0x04;
const SMCR: u32 = 0x08;
const DIER: u32 = 0x0C;
const SR: u32 = 0x10;
const EGR: u32 = 0x14;
const CCMR1: u32 = 0x18;
const CCMR2: u32 = 0x1C;
const CCER: u32 = 0x20;
const CNT: u32 = 0x24;
const PSC: u32 = 0x28;
const ARR: u32 = 0x2C;
const CCR1: u32 = 0x34;
const CCR4: u32 = 0x40;
const DCR: u32 = 0x48;
const DMAR: u32 = 0x4C;
const OR: u32 = 0x50;

/// CR1 bits.
const CEN: u32 = 1 << 0;
const UDIS: u32 = 1 << 1;
const URS: u32 = 1 << 2;
const OPM: u32 = 1 << 3;
const DIR: u32 = 1 << 4;
const ARPE: u32 = 1 << 7;

/// SR / DIER / EGR bits shared by position: update (UIF, UIE, UG) and trigger (TIF, TIE, TG).
const UIF: u32 = 1 << 0;
const TIF: u32 = 1 << 6;

/// CCxIF (SR), CCxIE (DIER), CCxG (EGR) of channel index `ch` (0-based).
const fn cc_bit(ch: usize) -> u32 {
    1 << (1 + ch)
}

/// CCxOF (SR) of channel index `ch`.
const fn ccof_bit(ch: usize) -> u32 {
    1 << (9 + ch)
}

/// OCxM values (RM0390 §17.4.7).
const OCM_ACTIVE_ON_MATCH: u32 = 0b001;
const OCM_INACTIVE_ON_MATCH: u32 = 0b010;
const OCM_TOGGLE: u32 = 0b011;
const OCM_FORCE_INACTIVE: u32 = 0b100;
const OCM_FORCE_ACTIVE: u32 = 0b101;
const OCM_PWM1: u32 = 0b110;
const OCM_PWM2: u32 = 0b111;

/// The writable bits of each register, by layout.
struct Masks {
    cr1: u32,
    cr2: u32,
    smcr: u32,
    dier: u32,
    sr: u32,
    egr: u32,
    ccmr: [u32; 2],
    ccer: u32,
    dcr: u32,
}

/// TIM2–5 (RM0390 §17.4).
const MASKS_4CH: Masks = Masks {
    cr1: 0x03FF,
    cr2: 0x00F8,
    smcr: 0xFFF7,
    dier: 0x5F5F,
    sr: 0x1E5F,
    egr: 0x005F,
    ccmr: [0xFFFF, 0xFFFF],
    ccer: 0xBBBB,
    dcr: 0x1F1F,
};

/// TIM9/12 (RM0390 §18.4): no DIR/CMS, no CR2, no ETR, no DMA, no OCxCE, two channels.
const MASKS_2CH: Masks = Masks {
    cr1: 0x038F,
    cr2: 0,
    smcr: 0x00F7,
    dier: 0x0047,
    sr: 0x0647,
    egr: 0x0047,
    ccmr: [0x7F7F, 0],
    ccer: 0x00BB,
    dcr: 0,
};

/// How a run of the counter ended.
enum Run {
    /// It ran all the clock ticks asked.
    Done,
    /// An event after this many clock ticks set a new flag or stopped the counter.
    Changed(u64),
    /// Nothing will change any more of its own accord (stopped, blocked, or every period
    /// repeats the last).
    Steady,
}

/// A general-purpose timer (TIM2–5, TIM12).
#[derive(Clone, Debug)]
pub struct Tim {
    inst: TimInstance,
    cr1: u32,
    cr2: u32,
    smcr: u32,
    dier: u32,
    sr: u32,
    ccmr: [u32; 2],
    ccer: u32,
    cnt: u32,
    /// PSC as written (the preload register).
    psc: u32,
    /// The prescaler in use (loaded from `psc` at an update event).
    psc_active: u32,
    /// ARR as written.
    arr: u32,
    /// The auto-reload in use (`arr` at once without ARPE, at an update event with it).
    arr_active: u32,
    /// CCRx as written (or captured).
    ccr: [u32; 4],
    /// The compare values in use.
    ccr_active: [u32; 4],
    dcr: u32,
    or: u32,
    /// DMAR's burst index.
    burst_index: u32,
    /// Timer clock ticks counted towards the next counter tick (0..=psc_active).
    prescaler_count: u64,
    /// OCxREF where it is state (frozen, on-match and forced modes).
    oc_ref: [bool; 4],
    /// The time the model stands at.
    now: Time,
    /// The last [`Peripheral::next_event`]'s answer: (asked at, the timer clock then, the
    /// event). Between register writes the event found from one time holds from any later
    /// time before it (nothing changes until then), so it is not looked for again.
    next: std::cell::Cell<Option<(Time, u32, Option<Time>)>>,
}

impl Tim {
    /// The timer `inst` at reset (RM0390: every register 0 but ARR, all ones).
    pub fn new(inst: TimInstance) -> Tim {
        let top = if inst.counter_32bit { u32::MAX } else { 0xFFFF };
        Tim {
            inst,
            cr1: 0,
            cr2: 0,
            smcr: 0,
            dier: 0,
            sr: 0,
            ccmr: [0; 2],
            ccer: 0,
            cnt: 0,
            psc: 0,
            psc_active: 0,
            arr: top,
            arr_active: top,
            ccr: [0; 4],
            ccr_active: [0; 4],
            dcr: 0,
            or: 0,
            burst_index: 0,
            prescaler_count: 0,
            oc_ref: [false; 4],
            now: 0,
            next: std::cell::Cell::new(None),
        }
    }

    /// A reset from the RCC (APB1RSTR's bit pulsed): every register back to its reset value, the
    /// counter stopped, at the present time.
    pub fn reset(&mut self) {
        let now = self.now;
        *self = Tim::new(self.inst);
        self.now = now;
    }

    /// The instance this models.
    pub fn instance(&self) -> TimInstance {
        self.inst
    }

    /// The counter's present value (CNT, without side effects).
    pub fn counter(&self) -> u32 {
        self.cnt
    }

    /// The update (PWM) frequency in use, Hz, at the timer clock of `clocks`: the timer clock
    /// / (PSC + 1) / (ARR + 1) with the shadow (active) PSC and ARR; None while ARR is 0.
    pub fn update_hz(&self, clocks: &Clocks) -> Option<f64> {
        if self.arr_active == 0 {
            return None;
        }
        Some(
            f64::from(clocks.tim_apb1_hz)
                / (f64::from(self.psc_active) + 1.0)
                / (f64::from(self.arr_active) + 1.0),
        )
    }

    /// The duty of channel `channel` (1-based: 1 is CH1) at its output pin, 0–1: the fraction
    /// of each period the output (OCxREF through the polarity CCxP) is high.
    ///
    /// PWM mode 1 upcounting: min(CCRx, ARR + 1) / (ARR + 1) (downcounting: min(CCRx + 1,
    /// ARR + 1) / (ARR + 1); center-aligned: min(CCRx, ARR) / ARR); PWM mode 2 its complement; forced active 1, forced inactive 0;
    /// toggle on match 0.5 while a match is reached each period; frozen and active/inactive on
    /// match their present level. 0 when CCxE = 0 (the output is not driven), and for a
    /// channel configured as input or beyond the timer's channels. A stopped counter (CEN = 0)
    /// holds a static level: 0 or 1.
    pub fn pwm_duty(&self, channel: usize) -> f64 {
        if channel == 0 || channel > self.inst.channels {
            return 0.0;
        }
        let ch = channel - 1;
        if self.ccer & (1 << (4 * ch)) == 0 || self.ccs(ch) != 0 {
            return 0.0;
        }
        let running = self.cr1 & CEN != 0 && self.arr_active != 0;
        let arr = u64::from(self.arr_active);
        let v = u64::from(self.ccr_active[ch]);
        let down = self.down();
        let pwm1 = if self.center() {
            v.min(arr) as f64 / arr.max(1) as f64
        } else if down {
            (v + 1).min(arr + 1) as f64 / (arr + 1) as f64
        } else {
            v.min(arr + 1) as f64 / (arr + 1) as f64
        };
        let duty = match self.ocm(ch) {
            OCM_PWM1 if running => pwm1,
            OCM_PWM2 if running => 1.0 - pwm1,
            OCM_TOGGLE if running && v <= arr => 0.5,
            _ => {
                if self.ref_level(ch) {
                    1.0
                } else {
                    0.0
                }
            }
        };
        // CCxP: the output is active low.
        if self.ccer & (2 << (4 * ch)) != 0 {
            1.0 - duty
        } else {
            duty
        }
    }

    /// The layout's writable bits.
    fn masks(&self) -> &'static Masks {
        if self.inst.channels == 2 {
            &MASKS_2CH
        } else {
            &MASKS_4CH
        }
    }

    /// The counter's top value (all ones at its width).
    fn top(&self) -> u32 {
        if self.inst.counter_32bit {
            u32::MAX
        } else {
            0xFFFF
        }
    }

    /// Whether the counter counts down: DIR; center-aligned, up from 0 and down from ARR
    /// whatever DIR says.
    fn down(&self) -> bool {
        if self.center() {
            self.cnt != 0 && (self.cnt == self.arr_active || self.cr1 & DIR != 0)
        } else {
            self.cr1 & DIR != 0
        }
    }

    /// Center-aligned, DIR set to the direction the counter counts in (up from 0, down from
    /// ARR).
    fn settle_dir(&mut self) {
        if self.center() {
            if self.down() {
                self.cr1 |= DIR;
            } else {
                self.cr1 &= !DIR;
            }
        }
    }

    /// Whether the counter is center-aligned (CMS ≠ 0).
    fn center(&self) -> bool {
        (self.cr1 >> 5) & 3 != 0
    }

    /// Counter ticks of one whole period (an edge-aligned ARR + 1, a center-aligned 2 · ARR).
    fn period_ticks(&self) -> u64 {
        let arr = u64::from(self.arr_active);
        if self.center() { 2 * arr } else { arr + 1 }
    }

    /// CCxS of channel index `ch` (0: output).
    fn ccs(&self, ch: usize) -> u32 {
        (self.ccmr[ch / 2] >> (8 * (ch % 2))) & 3
    }

    /// OCxM of channel index `ch`.
    fn ocm(&self, ch: usize) -> u32 {
        (self.ccmr[ch / 2] >> (8 * (ch % 2) + 4)) & 7
    }

    /// OCxPE of channel index `ch`.
    fn ocpe(&self, ch: usize) -> bool {
        (self.ccmr[ch / 2] >> (8 * (ch % 2) + 3)) & 1 != 0
    }

    /// OCxREF of channel index `ch` at the present counter value.
    fn ref_level(&self, ch: usize) -> bool {
        let c = u64::from(self.cnt);
        let v = u64::from(self.ccr_active[ch]);
        let pwm1 = if u64::from(self.arr_active) < v {
            true
        } else if self.down() && !self.center() {
            c <= v
        } else {
            c < v
        };
        match self.ocm(ch) {
            OCM_PWM1 => pwm1,
            OCM_PWM2 => !pwm1,
            OCM_FORCE_ACTIVE => true,
            OCM_FORCE_INACTIVE => false,
            _ => self.oc_ref[ch],
        }
    }

    /// Counter ticks from now to the counter's wrap (overflow, underflow or its top; center-
    /// aligned, its turn at ARR or 0), or None while the counter is blocked (ARR = 0).
    fn ticks_to_wrap(&self) -> Option<u64> {
        let arr = u64::from(self.arr_active);
        let c = u64::from(self.cnt);
        if arr == 0 {
            None
        } else if self.center() {
            if self.down() {
                Some(c)
            } else if c < arr {
                Some(arr - c)
            } else {
                Some(u64::from(self.top()) - c + 1)
            }
        } else if self.down() {
            Some(c + 1)
        } else if c <= arr {
            Some(arr - c + 1)
        } else {
            Some(u64::from(self.top()) - c + 1)
        }
    }

    /// Counter ticks to the next event (a wrap or a compare match), or None while blocked.
    fn ticks_to_event(&self) -> Option<u64> {
        let mut d = self.ticks_to_wrap()?;
        let c = u64::from(self.cnt);
        let arr = u64::from(self.arr_active);
        for ch in 0..self.inst.channels {
            if self.ccs(ch) != 0 {
                continue;
            }
            let v = u64::from(self.ccr_active[ch]);
            let dist = if self.down() {
                (v < c).then(|| c - v)
            } else {
                (v > c && (v <= arr || c > arr)).then(|| v - c)
            };
            if let Some(dist) = dist {
                d = d.min(dist);
            }
        }
        Some(d)
    }

    /// Move the counter `d` counter ticks on, `d` at most [`Self::ticks_to_event`]; handle
    /// the event if it is reached. Return whether the counter wrapped.
    fn count(&mut self, d: u64) -> bool {
        let Some(to_event) = self.ticks_to_event() else {
            return false;
        };
        debug_assert!(d <= to_event);
        self.settle_dir();
        let wrap = self.ticks_to_wrap() == Some(d);
        let down = self.down();
        // Counting up from above ARR, the counter wraps at its top without an update;
        // counting down it always underflows at 0.
        let in_range = self.cnt <= self.arr_active;
        if self.center() {
            let cycle = wrap && down;
            if wrap && down {
                // The underflow at 0, then up.
                self.cnt = 0;
                self.cr1 &= !DIR;
                self.overflow();
            } else if wrap && in_range {
                // The overflow at ARR, then down.
                self.cnt = self.arr_active;
                self.cr1 |= DIR;
                self.overflow();
            } else if wrap {
                self.cnt = 0;
            } else if down {
                self.cnt -= d as u32;
            } else {
                self.cnt += d as u32;
            }
            if d == to_event || wrap {
                // CMS 01: flags counting down only, 10 up only, 11 both.
                let cms = (self.cr1 >> 5) & 3;
                let flags = if down { cms & 1 != 0 } else { cms & 2 != 0 };
                for ch in 0..self.inst.channels {
                    if self.ccs(ch) == 0 && self.ccr_active[ch] == self.cnt {
                        let sr = self.sr;
                        self.compare_match(ch);
                        if !flags {
                            self.sr = sr;
                        }
                    }
                }
            }
            return cycle;
        }
        if wrap {
            if self.down() {
                self.overflow();
                self.cnt = self.arr_active;
            } else {
                self.cnt = 0;
                if in_range {
                    self.overflow();
                }
            }
        } else if self.down() {
            self.cnt -= d as u32;
        } else {
            self.cnt += d as u32;
        }
        if d == to_event || wrap {
            for ch in 0..self.inst.channels {
                if self.ccs(ch) == 0 && self.ccr_active[ch] == self.cnt {
                    self.compare_match(ch);
                }
            }
        }
        wrap
    }

    /// An overflow or underflow: an update event unless UDIS.
    fn overflow(&mut self) {
        if self.cr1 & UDIS == 0 {
            self.load_shadows();
            self.sr |= UIF;
            if self.cr1 & OPM != 0 {
                self.cr1 &= !CEN;
            }
        }
    }

    /// An update event's transfer of the preload registers into their shadows.
    fn load_shadows(&mut self) {
        self.psc_active = self.psc;
        self.arr_active = self.arr;
        self.ccr_active = self.ccr;
    }

    /// A compare match on channel index `ch` (an output channel).
    fn compare_match(&mut self, ch: usize) {
        self.sr |= cc_bit(ch);
        match self.ocm(ch) {
            OCM_ACTIVE_ON_MATCH => self.oc_ref[ch] = true,
            OCM_INACTIVE_ON_MATCH => self.oc_ref[ch] = false,
            OCM_TOGGLE => self.oc_ref[ch] = !self.oc_ref[ch],
            _ => {}
        }
    }

    /// What a clean period must leave unchanged (flags, shadows, CR1 but the direction a
    /// center-aligned counter shows in DIR).
    fn state_key(&self) -> (u32, u32, u32, u32, [u32; 4]) {
        let dir = if self.center() { DIR } else { 0 };
        (
            self.sr,
            self.cr1 & !dir,
            self.psc_active,
            self.arr_active,
            self.ccr_active,
        )
    }

    /// Run `n` timer clock ticks. With `stop_at_change`, stop at the first event that sets a
    /// flag not set before or stops the counter.
    fn run(&mut self, mut n: u64, stop_at_change: bool) -> Run {
        let start = n;
        let mut seen_wrap = false;
        let mut changed = false;
        let mut events = 0u32;
        while n > 0 && self.cr1 & CEN != 0 {
            events += 1;
            if stop_at_change && events > 100_000 {
                // (Never in the cases tested: a period settles within a few. A wake to look
                // again from here, not a change.)
                return Run::Changed(start - n);
            }
            let div = u64::from(self.psc_active) + 1;
            let pc = self.prescaler_count;
            let Some(d) = self.ticks_to_event() else {
                self.prescaler_count = (pc + n) % div;
                return Run::Steady;
            };
            let need = d * div - pc;
            if n < need {
                let k = (pc + n) / div;
                self.count(k);
                self.prescaler_count = (pc + n) % div;
                return Run::Done;
            }
            n -= need;
            self.prescaler_count = 0;
            let before = self.state_key();
            let wrapped = self.count(d);
            let after = self.state_key();
            if stop_at_change && (after.0 & !before.0 != 0 || after.1 & CEN == 0) {
                return Run::Changed(start - n);
            }
            changed |= before != after;
            if wrapped {
                if seen_wrap && !changed {
                    // Every further period repeats the one just run: skip whole periods (in
                    // pairs, for toggle mode's alternating level).
                    if stop_at_change {
                        return Run::Steady;
                    }
                    let period = 2 * div * self.period_ticks();
                    n %= period;
                }
                seen_wrap = true;
                changed = false;
            }
        }
        if self.cr1 & CEN == 0 {
            Run::Steady
        } else {
            Run::Done
        }
    }

    /// EGR: software event generation.
    fn generate(&mut self, egr: u32) {
        let egr = egr & self.masks().egr;
        if egr & 1 != 0 {
            self.prescaler_count = 0;
            if self.cr1 & UDIS == 0 {
                self.load_shadows();
                if self.cr1 & URS == 0 {
                    self.sr |= UIF;
                }
                if self.cr1 & OPM != 0 {
                    self.cr1 &= !CEN;
                }
            }
            if self.center() {
                self.cr1 &= !DIR;
                self.cnt = 0;
            } else if self.cr1 & DIR != 0 {
                self.cnt = self.arr_active;
            } else {
                self.cnt = 0;
            }
        }
        for ch in 0..self.inst.channels {
            if egr & cc_bit(ch) != 0 {
                if self.ccs(ch) != 0 {
                    if self.sr & cc_bit(ch) != 0 {
                        self.sr |= ccof_bit(ch);
                    }
                    self.ccr[ch] = self.cnt;
                    self.ccr_active[ch] = self.cnt;
                    self.sr |= cc_bit(ch);
                } else {
                    self.compare_match(ch);
                }
            }
        }
        if egr & TIF != 0 {
            self.sr |= TIF;
        }
    }

    /// A CCMRx write (index `i`): CCxS kept while the channel is on; OCxREF kept as state
    /// when leaving a computed mode, set by the forced modes.
    fn write_ccmr(&mut self, i: usize, value: u32) {
        for ch in 0..self.inst.channels {
            self.oc_ref[ch] = self.ref_level(ch);
        }
        let mut v = value & self.masks().ccmr[i];
        for half in 0..2 {
            let ch = 2 * i + half;
            if ch < self.inst.channels && self.ccer & (1 << (4 * ch)) != 0 {
                let ccs = 3 << (8 * half);
                v = (v & !ccs) | (self.ccmr[i] & ccs);
            }
        }
        self.ccmr[i] = v;
        for ch in 0..self.inst.channels {
            match self.ocm(ch) {
                OCM_FORCE_ACTIVE => self.oc_ref[ch] = true,
                OCM_FORCE_INACTIVE => self.oc_ref[ch] = false,
                _ => {}
            }
        }
    }

    /// The 32-bit register at `offset` (word-aligned), without side effects but DMAR's.
    fn read_reg(&mut self, offset: u32) -> u32 {
        let two = self.inst.channels == 2;
        match offset {
            CR1 => self.cr1,
            CR2 => self.cr2,
            SMCR => self.smcr,
            DIER => self.dier,
            SR => self.sr,
            CCMR1 => self.ccmr[0],
            CCMR2 => self.ccmr[1],
            CCER => self.ccer,
            CNT => self.cnt,
            PSC => self.psc,
            ARR => self.arr,
            CCR1..=CCR4 => {
                let ch = ((offset - CCR1) / 4) as usize;
                if ch < self.inst.channels {
                    self.ccr[ch]
                } else {
                    0
                }
            }
            DCR => self.dcr,
            DMAR if !two => {
                let target = self.burst_target();
                if target == DMAR {
                    0
                } else {
                    self.read_reg(target)
                }
            }
            OR => self.or,
            _ => 0,
        }
    }

    /// The register a DMAR access reaches now, and the burst index advanced.
    fn burst_target(&mut self) -> u32 {
        let dba = self.dcr & 0x1F;
        let dbl = (self.dcr >> 8) & 0x1F;
        let target = (dba + self.burst_index) * 4;
        self.burst_index = (self.burst_index + 1) % (dbl + 1);
        target
    }

    /// A write of the whole 32-bit register at `offset` (word-aligned).
    fn write_reg(&mut self, offset: u32, value: u32) {
        self.write_reg_raw(offset, value);
        self.settle_dir();
    }

    /// [`Self::write_reg`] before DIR is settled.
    fn write_reg_raw(&mut self, offset: u32, value: u32) {
        let m = self.masks();
        let top = self.top();
        let two = self.inst.channels == 2;
        match offset {
            CR1 => {
                let old = self.cr1;
                self.cr1 = value & m.cr1;
                // DIR is read-only center-aligned (it shows the direction).
                if self.center() && (old >> 5) & 3 != 0 {
                    self.cr1 = (self.cr1 & !DIR) | (old & DIR);
                }
            }
            CR2 => self.cr2 = value & m.cr2,
            SMCR => self.smcr = value & m.smcr,
            DIER => self.dier = value & m.dier,
            // rc_w0: a 0 clears, a 1 leaves.
            SR => self.sr &= value | !m.sr,
            EGR => self.generate(value),
            CCMR1 => self.write_ccmr(0, value),
            CCMR2 if !two => self.write_ccmr(1, value),
            CCER => self.ccer = value & m.ccer,
            CNT => self.cnt = value & top,
            PSC => self.psc = value & 0xFFFF,
            ARR => {
                self.arr = value & top;
                if self.cr1 & ARPE == 0 {
                    self.arr_active = self.arr;
                }
            }
            CCR1..=CCR4 => {
                let ch = ((offset - CCR1) / 4) as usize;
                if ch < self.inst.channels && self.ccs(ch) == 0 {
                    self.ccr[ch] = value & top;
                    if !self.ocpe(ch) {
                        self.ccr_active[ch] = self.ccr[ch];
                    }
                }
            }
            DCR => {
                self.dcr = value & m.dcr;
                self.burst_index = 0;
            }
            DMAR if !two => {
                let target = self.burst_target();
                if target != DMAR {
                    self.write_reg(target, value);
                }
            }
            OR => self.or = value & self.inst.or_mask,
            _ => {}
        }
    }
}

impl Peripheral for Tim {
    fn name(&self) -> &'static str {
        self.inst.name
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        lanes(self.read_reg(offset & !3), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let reg = offset & !3;
        let old = match reg {
            // Write-only, and DMAR's target is read only by a whole access.
            EGR | DMAR => 0,
            _ => self.read_reg(reg),
        };
        self.write_reg(reg, merge(old, offset, size, value));
        self.next.set(None);
    }

    fn advance(&mut self, now: Time, clocks: &Clocks) {
        if now <= self.now {
            return;
        }
        let hz = clocks.tim_apb1_hz;
        let n = Clocks::ticks(now, hz) - Clocks::ticks(self.now, hz);
        self.now = now;
        self.run(n, false);
    }

    fn next_event(&self, now: Time, clocks: &Clocks) -> Option<Time> {
        if self.cr1 & CEN == 0 {
            return None;
        }
        let hz = clocks.tim_apb1_hz;
        if let Some((asked, at_hz, event)) = self.next.get() {
            if at_hz == hz && now >= asked && event.is_none_or(|t| now < t) {
                return event;
            }
        }
        let event = self.find_next_event(now, clocks);
        self.next.set(Some((now, hz, event)));
        event
    }
}

impl Tim {
    /// The next time the timer's state changes after `now`, from a copy run ahead.
    fn find_next_event(&self, now: Time, clocks: &Clocks) -> Option<Time> {
        let mut sim = self.clone();
        sim.advance(now, clocks);
        let hz = clocks.tim_apb1_hz;
        let base = Clocks::ticks(sim.now, hz);
        // Far enough for several periods of the slowest setting (a 32-bit ARR at PSC 65 535 is
        // longer: then the event is looked for again from there).
        let horizon = 1u64 << 50;
        match sim.run(horizon, true) {
            Run::Changed(used) => Some(Clocks::time_of(base + used, hz).max(now + 1)),
            Run::Done => Some(Clocks::time_of(base + horizon, hz)),
            Run::Steady => None,
        }
    }
}

impl IrqLines for Tim {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        // UIE, CCxIE and TIE sit at their flags' positions.
        let enables = self.dier & (UIF | TIF | 0x1E);
        line(self.inst.irq, self.sr & enables != 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The board's clocks: APB1 45 MHz, its timers 90 MHz.
    const BOARD: Clocks = Clocks {
        sysclk_hz: 180_000_000,
        hclk_hz: 180_000_000,
        pclk1_hz: 45_000_000,
        pclk2_hz: 90_000_000,
        tim_apb1_hz: 90_000_000,
        tim_apb2_hz: 180_000_000,
        lsi_hz: 32_000,
    };

    /// `us` microseconds in time units.
    const fn us(us: u64) -> Time {
        us * 720
    }

    fn w(t: &mut Tim, offset: u32, value: u32) {
        t.write(offset, Size::Word, value);
    }

    fn r(t: &mut Tim, offset: u32) -> u32 {
        t.read(offset, Size::Word)
    }

    /// Read-modify-write of the register at `offset`.
    fn rmw(t: &mut Tim, offset: u32, f: impl FnOnce(u32) -> u32) {
        let v = f(r(t, offset));
        w(t, offset, v);
    }

    fn irq(t: &Tim) -> (u16, bool) {
        let mut out = (0, false);
        t.irqs(&mut |n, high| out = (n, high));
        out
    }

    /// embassy-stm32 0.6's time driver's `init` (time_driver/gp16.rs), at `now`.
    fn time_driver(now: Time) -> Tim {
        let mut t = Tim::new(TIM12);
        t.advance(now, &BOARD);
        rmw(&mut t, CR1, |v| v & !CEN);
        w(&mut t, CNT, 0);
        w(&mut t, PSC, 90_000_000 / 1_000_000 - 1);
        w(&mut t, ARR, 0xFFFF);
        rmw(&mut t, CR1, |v| v | URS);
        w(&mut t, EGR, 1);
        rmw(&mut t, CR1, |v| v & !URS);
        w(&mut t, CCR1, 0x8000);
        w(&mut t, DIER, UIF | cc_bit(0));
        rmw(&mut t, CR1, |v| v | CEN);
        t
    }

    #[test]
    fn the_time_driver_counts_microseconds_and_sees_half_and_whole_periods() {
        let t0 = us(100);
        let mut t = time_driver(t0);
        // URS = 1 during UG: no update flag, PSC loaded.
        assert_eq!(r(&mut t, SR), 0);
        assert_eq!(irq(&t), (43, false));
        // The first half period: CC1 at 0x8000 µs, not a tick before.
        assert_eq!(t.next_event(t0, &BOARD), Some(t0 + us(0x8000)));
        t.advance(t0 + us(0x8000) - 1, &BOARD);
        assert_eq!(r(&mut t, CNT), 0x7FFF);
        assert_eq!(r(&mut t, SR), 0);
        t.advance(t0 + us(0x8000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0x8000);
        assert_eq!(r(&mut t, SR), cc_bit(0));
        assert_eq!(irq(&t), (43, true));
        // The handler writes !SR: clears what it saw, leaves the rest.
        let sr = r(&mut t, SR);
        w(&mut t, SR, !sr);
        assert_eq!(irq(&t), (43, false));
        // The overflow: UIF at 0x10000 µs, the counter back at 0.
        assert_eq!(t.next_event(t.now, &BOARD), Some(t0 + us(0x10000)));
        t.advance(t0 + us(0x10000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0);
        // CCR2 (0 until an alarm is set) matches as the counter wraps to 0.
        assert_eq!(r(&mut t, SR), UIF | cc_bit(1));
        assert_eq!(irq(&t), (43, true));
        w(&mut t, SR, !(UIF | cc_bit(1)));
        // An alarm 1234 µs ahead on CC2, its interrupt enabled.
        let at = r(&mut t, CNT) + 1234;
        w(&mut t, CCR1 + 4, at);
        rmw(&mut t, DIER, |v| v | cc_bit(1));
        let due = t0 + us(0x10000 + 1234);
        assert_eq!(t.next_event(t.now, &BOARD), Some(due));
        t.advance(due - 1, &BOARD);
        assert_eq!(irq(&t), (43, false));
        t.advance(due, &BOARD);
        assert_eq!(r(&mut t, SR), cc_bit(1));
        assert_eq!(irq(&t), (43, true));
        // CC2's flag without its enable holds no line.
        rmw(&mut t, DIER, |v| v & !cc_bit(1));
        assert_eq!(irq(&t), (43, false));
    }

    #[test]
    fn a_flag_set_after_the_handler_read_sr_survives_its_write() {
        let mut t = time_driver(0);
        t.advance(us(0x8000), &BOARD);
        let seen = r(&mut t, SR);
        assert_eq!(seen, cc_bit(0));
        // The overflow comes between the handler's read and its write of !SR.
        t.advance(us(0x10000), &BOARD);
        w(&mut t, SR, !seen);
        assert_eq!(r(&mut t, SR), UIF | cc_bit(1));
        assert_eq!(irq(&t), (43, true));
        // An RCC reset: registers back to reset, time kept.
        t.reset();
        assert_eq!(r(&mut t, SR), 0);
        assert_eq!(r(&mut t, ARR), 0xFFFF);
        assert_eq!(t.now, us(0x10000));
        assert_eq!(t.next_event(t.now, &BOARD), None);
    }

    #[test]
    fn a_long_jump_sets_what_small_steps_set() {
        let mut a = time_driver(0);
        let mut b = a.clone();
        let end = us(3_000_017);
        a.advance(end, &BOARD);
        let mut t = 0;
        while t < end {
            t = (t + 7_777_777).min(end);
            b.advance(t, &BOARD);
        }
        assert_eq!(a.cnt, b.cnt);
        assert_eq!(a.sr, b.sr);
        assert_eq!(a.prescaler_count, b.prescaler_count);
        assert_eq!(a.cnt, (3_000_017 % 65_536) as u32);
        // Both flags are set and nothing else will change: no event to wake for.
        assert_eq!(a.sr, UIF | cc_bit(0) | cc_bit(1));
        assert_eq!(a.next_event(end, &BOARD), None);
        // A flag cleared is a flag to wake for again.
        w(&mut a, SR, !UIF);
        assert_eq!(
            a.next_event(end, &BOARD),
            Some(us(3_000_017 - 3_000_017 % 65_536 + 65_536))
        );
    }

    #[test]
    fn jumps_agree_with_single_clock_steps_in_random_settings() {
        // A small linear congruential generator: the same cases every run.
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = |n: u32| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((seed >> 33) % u64::from(n)) as u32
        };
        for case in 0..300 {
            let mut a = Tim::new(if case % 2 == 0 { TIM3 } else { TIM12 });
            for _ in 0..6 {
                // Random writes, the same to both.
                let modes = [0x6, 0x7, 0x1, 0x2, 0x3, 0x0, 0x4, 0x5];
                let ccmr = |m: u32, pe: u32| (m << 4) | (pe << 3);
                let writes = [
                    (PSC, rnd(4)),
                    (ARR, rnd(12)),
                    (CCR1, rnd(14)),
                    (CCR1 + 4, rnd(14)),
                    (CCR1 + 8, rnd(14)),
                    (
                        CCMR1,
                        ccmr(modes[rnd(8) as usize], rnd(2))
                            | (ccmr(modes[rnd(8) as usize], rnd(2)) << 8),
                    ),
                    (
                        CCMR2,
                        ccmr(modes[rnd(8) as usize], rnd(2))
                            | (ccmr(modes[rnd(8) as usize], rnd(2)) << 8),
                    ),
                    (CCER, 0x1111 * rnd(2)),
                    (SR, rnd(0x2000)),
                    (CNT, rnd(14)),
                    (EGR, rnd(2)),
                ];
                for (offset, value) in writes {
                    // ARR always (small: every period within the single steps' reach).
                    if offset == ARR || rnd(3) == 0 {
                        w(&mut a, offset, value);
                    }
                }
                let cr1 = CEN
                    | (u32::from(rnd(3) == 0) * (rnd(4) << 5))
                    | (rnd(2) * ARPE)
                    | (rnd(2) * DIR)
                    | (rnd(2) * URS)
                    | (u32::from(rnd(8) == 0) * UDIS)
                    | (u32::from(rnd(8) == 0) * OPM);
                w(&mut a, CR1, cr1);
                // The next change, as next_event finds it and by single clocks.
                let mut c = a.clone();
                let found = match c.run(1 << 40, true) {
                    Run::Changed(used) => Some(used),
                    Run::Steady => None,
                    Run::Done => panic!("case {case}: no end"),
                };
                let mut d = a.clone();
                // (Single steps as far as the change found, or 5 000 clocks.)
                let reach = found.unwrap_or(0).max(5_000);
                let stepped = (1..=reach).find(|_| {
                    let before = d.sr;
                    d.run(1, false);
                    d.sr & !before != 0 || d.cr1 & CEN == 0
                });
                assert_eq!(found, stepped, "case {case}: next change");
                let mut b = a.clone();
                let n = u64::from(rnd(600));
                a.run(n, false);
                for _ in 0..n {
                    b.run(1, false);
                }
                let key = |t: &Tim| {
                    (
                        t.cnt,
                        t.sr,
                        t.cr1,
                        t.prescaler_count,
                        t.psc_active,
                        t.arr_active,
                        t.ccr_active,
                        t.oc_ref,
                    )
                };
                assert_eq!(key(&a), key(&b), "case {case}, {n} clocks");
                for ch in 1..=4 {
                    assert_eq!(a.pwm_duty(ch), b.pwm_duty(ch));
                }
            }
        }
    }

    #[test]
    fn the_prescaler_takes_effect_only_at_an_update() {
        let mut t = Tim::new(TIM3);
        w(&mut t, ARR, 999);
        w(&mut t, CR1, CEN);
        // PSC written while running: still counting at 90 MHz until the overflow.
        w(&mut t, PSC, 89);
        t.advance(Clocks::time_of(500, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 500);
        assert_eq!(r(&mut t, PSC), 89);
        t.advance(Clocks::time_of(1000, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0);
        assert_eq!(r(&mut t, SR) & UIF, UIF);
        // From the update on: 1 MHz.
        t.advance(Clocks::time_of(1000, 90_000_000) + us(10), &BOARD);
        assert_eq!(r(&mut t, CNT), 10);
        // UG loads it at once (and clears the counter and the prescaler's count).
        w(&mut t, PSC, 8);
        w(&mut t, SR, 0);
        w(&mut t, EGR, 1);
        assert_eq!(r(&mut t, CNT), 0);
        assert_eq!(r(&mut t, SR), UIF, "UG with URS = 0 sets UIF");
        let now = t.now;
        t.advance(now + us(1), &BOARD);
        assert_eq!(r(&mut t, CNT), 10);
    }

    #[test]
    fn update_generation_follows_urs_and_udis() {
        let mut t = Tim::new(TIM4);
        w(&mut t, PSC, 5);
        w(&mut t, CR1, URS);
        w(&mut t, EGR, 1);
        assert_eq!(r(&mut t, SR), 0, "URS = 1: no UIF from UG");
        assert_eq!(t.psc_active, 5);
        // UDIS: no update event at all, shadows kept, the counter still cleared.
        w(&mut t, PSC, 7);
        w(&mut t, CNT, 33);
        w(&mut t, CR1, UDIS);
        w(&mut t, EGR, 1);
        assert_eq!(r(&mut t, SR), 0);
        assert_eq!(t.psc_active, 5);
        assert_eq!(r(&mut t, CNT), 0);
        // UDIS overflow: wraps, no flag, no load.
        w(&mut t, ARR, 9);
        w(&mut t, CR1, UDIS | CEN);
        t.advance(Clocks::time_of(6 * 10, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0);
        // (CCR1–4 = 0 match as the counter wraps to 0: a compare is not an update.)
        assert_eq!(r(&mut t, SR), 0x1E);
        assert_eq!(t.psc_active, 5);
    }

    #[test]
    fn auto_reload_is_preloaded_only_with_arpe() {
        let mut t = Tim::new(TIM3);
        w(&mut t, ARR, 99);
        w(&mut t, CR1, CEN);
        t.advance(Clocks::time_of(50, 90_000_000), &BOARD);
        // No ARPE: a new ARR applies at once: this period ends at 60.
        w(&mut t, ARR, 59);
        t.advance(Clocks::time_of(60, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0);
        assert_eq!(r(&mut t, SR) & UIF, UIF);
        // ARPE: the period in use finishes with the old value.
        w(&mut t, CR1, CEN | ARPE);
        w(&mut t, ARR, 9);
        assert_eq!(r(&mut t, ARR), 9, "reads the preload register");
        t.advance(Clocks::time_of(60 + 30, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 30);
        t.advance(Clocks::time_of(60 + 60, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0);
        t.advance(Clocks::time_of(60 + 60 + 10, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0, "then 10-tick periods");
        assert_eq!(t.update_hz(&BOARD), Some(9_000_000.0));
    }

    #[test]
    fn status_flags_are_rc_w0() {
        let mut t = Tim::new(TIM2);
        w(&mut t, CCMR1, 0x0101); // CC1, CC2 inputs
        w(&mut t, EGR, 0x5F);
        assert_eq!(r(&mut t, SR), 0x5F);
        w(&mut t, EGR, 0x06);
        assert_eq!(r(&mut t, SR), 0x5F | ccof_bit(0) | ccof_bit(1));
        // Writing 1s changes nothing; a 0 clears exactly its bit.
        w(&mut t, SR, 0xFFFF_FFFF);
        assert_eq!(r(&mut t, SR), 0x065F);
        w(&mut t, SR, !cc_bit(2));
        assert_eq!(r(&mut t, SR), 0x065F & !cc_bit(2));
        // A byte write of the low byte leaves the high byte's flags.
        t.write(SR, Size::Byte, 0);
        assert_eq!(r(&mut t, SR), 0x0600);
        // Flags without enables hold no line; with one, they do.
        assert_eq!(irq(&t), (28, false));
        w(&mut t, EGR, TIF);
        w(&mut t, DIER, TIF);
        assert_eq!(irq(&t), (28, true));
    }

    /// SimplePwm::new as embassy-stm32 0.6 runs it, then the board's duty.
    fn simple_pwm(inst: TimInstance, hz: u32, ccr: u32) -> Tim {
        let mut t = Tim::new(inst);
        let clocks = u64::from(BOARD.tim_apb1_hz / hz);
        let psc = (clocks - 1) / 65_536;
        let arr = clocks / (psc + 1) - 1;
        w(&mut t, PSC, psc as u32);
        w(&mut t, ARR, arr as u32);
        for i in 0..2 {
            // OCxM = PWM mode 1, OCxPE for both channels of the register.
            let v = r(&mut t, CCMR1 + 4 * i) | 0x6868;
            w(&mut t, CCMR1 + 4 * i, v);
        }
        rmw(&mut t, CR1, |v| v | ARPE);
        rmw(&mut t, CR1, |v| v | URS);
        w(&mut t, EGR, 1);
        rmw(&mut t, CR1, |v| v & !URS);
        rmw(&mut t, CR1, |v| v | CEN);
        // set_duty_cycle_fully_off, enable.
        w(&mut t, CCR1, 0);
        rmw(&mut t, CCER, |v| v | 1);
        w(&mut t, CCR1, ccr);
        t
    }

    #[test]
    fn heater_and_fan_pwm_duties() {
        let mut heater = simple_pwm(TIM3, 1_000, 45_000 / 4);
        assert_eq!((heater.psc, heater.arr), (1, 44_999));
        assert_eq!(heater.update_hz(&BOARD), Some(1_000.0));
        // CCR1 is preloaded: the old duty (0) until the next update.
        assert_eq!(heater.pwm_duty(1), 0.0);
        heater.advance(us(1_000), &BOARD);
        assert_eq!(heater.pwm_duty(1), 0.25);
        assert_eq!(heater.pwm_duty(2), 0.0, "CH2 not enabled");
        let mut fan = simple_pwm(TIM4, 25_000, 2_160);
        assert_eq!((fan.psc, fan.arr), (0, 3_599));
        assert_eq!(fan.update_hz(&BOARD), Some(25_000.0));
        fan.advance(us(40), &BOARD);
        assert_eq!(fan.pwm_duty(1), 0.6);
        // Full on (CCR = ARR + 1), polarity inverted, PWM mode 2.
        w(&mut fan, CCR1, 3_600);
        fan.advance(us(80), &BOARD);
        assert_eq!(fan.pwm_duty(1), 1.0);
        w(&mut fan, CCER, 0b11);
        assert_eq!(fan.pwm_duty(1), 0.0);
        w(&mut fan, CCER, 1);
        w(&mut fan, CCR1, 900);
        fan.advance(us(120), &BOARD);
        w(&mut fan, CCMR1, 0x7878);
        assert_eq!(fan.pwm_duty(1), 0.75);
        // Stopped: a static level, OCxREF at the counter (PWM 2: high once CNT >= CCR).
        w(&mut fan, CR1, ARPE);
        w(&mut fan, CNT, 899);
        assert_eq!(fan.pwm_duty(1), 0.0);
        w(&mut fan, CNT, 900);
        assert_eq!(fan.pwm_duty(1), 1.0);
        // Output disabled: not driven.
        w(&mut fan, CCER, 0);
        assert_eq!(fan.pwm_duty(1), 0.0);
        // CC1 (11 250) is still to come in this period; once every flag is set (the board
        // leaves them), a PWM timer wakes nobody.
        assert_eq!(
            heater.next_event(heater.now, &BOARD),
            Some(us(1_000) + Clocks::time_of(11_250 * 2, 90_000_000))
        );
        heater.advance(us(3_000), &BOARD);
        assert_eq!(heater.sr, UIF | 0x1E);
        assert_eq!(heater.next_event(heater.now, &BOARD), None);
    }

    #[test]
    fn compare_flags_and_forced_levels() {
        let mut t = Tim::new(TIM5);
        w(&mut t, ARR, 0xFFFF_FFFF);
        w(&mut t, CCR1 + 8, 70_000); // CC3: frozen output
        w(&mut t, CCMR2, 0x0010); // CC3: active on match
        w(&mut t, CCER, 1 << 8);
        w(&mut t, CR1, CEN);
        assert_eq!(t.pwm_duty(3), 0.0);
        t.advance(Clocks::time_of(69_999, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, SR), 0);
        t.advance(Clocks::time_of(70_000, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, SR), cc_bit(2));
        assert_eq!(t.pwm_duty(3), 1.0);
        assert_eq!(r(&mut t, CNT), 70_000, "32 bits");
        // Forced inactive; CC3S cannot change while CC3E is set.
        w(&mut t, CCMR2, 0x0041);
        assert_eq!(r(&mut t, CCMR2), 0x0040);
        assert_eq!(t.pwm_duty(3), 0.0);
    }

    #[test]
    fn downcounting_and_one_pulse() {
        let mut t = Tim::new(TIM3);
        w(&mut t, ARR, 99);
        w(&mut t, CCR1, 40);
        w(&mut t, CR1, DIR | OPM);
        w(&mut t, EGR, 1);
        assert_eq!(r(&mut t, CNT), 99, "UG downcounting loads ARR");
        w(&mut t, SR, 0);
        w(&mut t, CR1, DIR | OPM | CEN);
        t.advance(Clocks::time_of(59, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 40);
        assert_eq!(r(&mut t, SR), cc_bit(0));
        // CC2–4 (CCR 0) match at 0, then the underflow: UIF, the counter back at ARR,
        // stopped (OPM).
        assert_eq!(
            t.next_event(t.now, &BOARD),
            Some(Clocks::time_of(99, 90_000_000))
        );
        t.advance(Clocks::time_of(99, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, SR), 0x1E);
        assert_eq!(
            t.next_event(t.now, &BOARD),
            Some(Clocks::time_of(100, 90_000_000))
        );
        t.advance(Clocks::time_of(100, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, SR), 0x1E | UIF);
        assert_eq!(r(&mut t, CNT), 99);
        assert_eq!(r(&mut t, CR1) & CEN, 0);
        t.advance(Clocks::time_of(500, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 99);
        assert_eq!(t.next_event(t.now, &BOARD), None);
        // Written above ARR: down to 0, then the underflow (an update) and ARR.
        w(&mut t, SR, 0);
        w(&mut t, CNT, 150);
        w(&mut t, CR1, DIR | CEN);
        t.advance(Clocks::time_of(500 + 151, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, SR) & UIF, UIF);
        assert_eq!(r(&mut t, CNT), 99);
        // Counting up from above ARR: to the top and round to 0 without an update.
        w(&mut t, SR, 0);
        w(&mut t, CNT, 0xFFF0);
        w(&mut t, CR1, CEN);
        t.advance(Clocks::time_of(500 + 151 + 16, 90_000_000), &BOARD);
        assert_eq!(r(&mut t, CNT), 0);
        assert_eq!(r(&mut t, SR) & UIF, 0);
    }

    #[test]
    fn center_aligned_counting_turns_at_arr_and_0() {
        let clk = |n: u64| Clocks::time_of(n, 90_000_000);
        for (cms, up_flags, down_flags) in [(1, false, true), (2, true, false), (3, true, true)] {
            let mut t = Tim::new(TIM3);
            w(&mut t, ARR, 6);
            w(&mut t, CCR1, 2);
            w(&mut t, CCR1 + 4, 5);
            w(&mut t, CCMR1, 0x6060); // PWM mode 1 on CH1 and CH2
            w(&mut t, CCER, 0x11);
            w(&mut t, CR1, (cms << 5) | CEN);
            // Up: 2 and 5 pass, then the overflow at ARR (tick 6).
            t.advance(clk(5), &BOARD);
            let up = cc_bit(0) | cc_bit(1);
            assert_eq!(r(&mut t, SR), if up_flags { up } else { 0 }, "CMS {cms}");
            assert_eq!(r(&mut t, CR1) & DIR, 0);
            t.advance(clk(6), &BOARD);
            assert_eq!(r(&mut t, CNT), 6);
            assert_eq!(r(&mut t, SR) & UIF, UIF);
            assert_eq!(r(&mut t, CR1) & DIR, DIR, "DIR shows counting down");
            // DIR is read-only now.
            rmw(&mut t, CR1, |v| v & !DIR);
            assert_eq!(r(&mut t, CR1) & DIR, DIR);
            w(&mut t, SR, 0);
            // Down: 5 at tick 7, 2 at tick 10, the underflow at 0 (tick 12).
            t.advance(clk(10), &BOARD);
            assert_eq!(r(&mut t, CNT), 2);
            assert_eq!(r(&mut t, SR), if down_flags { up } else { 0 }, "CMS {cms}");
            t.advance(clk(12), &BOARD);
            assert_eq!(r(&mut t, CNT), 0);
            assert_eq!(r(&mut t, SR) & UIF, UIF);
            assert_eq!(r(&mut t, CR1) & DIR, 0);
            t.advance(clk(13), &BOARD);
            assert_eq!(r(&mut t, CNT), 1);
            // PWM: high while CNT < CCR, both ways: CCR / ARR; a period of 2 · ARR ticks.
            assert_eq!(t.pwm_duty(1), 2.0 / 6.0);
            assert_eq!(t.pwm_duty(2), 5.0 / 6.0);
        }
    }

    #[test]
    fn the_2_channel_layout_has_no_cr2_ccr3_or_dma() {
        let mut t = Tim::new(TIM12);
        w(&mut t, CR2, 0xFF);
        w(&mut t, CCR1 + 8, 5);
        w(&mut t, DCR, 0x1F1F);
        w(&mut t, CR1, 0xFFFF);
        w(&mut t, DIER, 0xFFFF);
        assert_eq!(r(&mut t, CR2), 0);
        assert_eq!(r(&mut t, CCR1 + 8), 0);
        assert_eq!(r(&mut t, DCR), 0);
        assert_eq!(r(&mut t, CR1), 0x038F, "no DIR, no CMS");
        assert_eq!(r(&mut t, DIER), 0x0047);
        // A half-word write of CNT.
        t.write(CNT + 2, Size::Half, 0x1234);
        assert_eq!(r(&mut t, CNT), 0);
        t.write(CNT, Size::Half, 0x1234);
        assert_eq!(r(&mut t, CNT), 0x1234);
    }

    #[test]
    fn dma_burst_register_walks_the_window() {
        let mut t = Tim::new(TIM3);
        // DBA = CCR1 (13), DBL = 2 (three transfers).
        w(&mut t, DCR, (2 << 8) | 13);
        w(&mut t, DMAR, 11);
        w(&mut t, DMAR, 22);
        w(&mut t, DMAR, 33);
        w(&mut t, DMAR, 44);
        assert_eq!(t.ccr, [44, 22, 33, 0]);
    }
}
