//! ADC1, the STM32F446's first 12-bit ADC (RM0390 §13), with the ADCs' common registers: the
//! register window at 0x4001_2000 (ADC1's registers at 0x000–0x04C, the common CSR, CCR and
//! CDR at 0x300–0x308), the regular and injected conversions from the input voltages the
//! harness sets, their timing in ADCCLK cycles, the flags, the interrupt line (IRQ 18, shared
//! by the three ADCs) and the DMA request.
//!
//! What this model owns: conversions. A conversion of channel `x` takes its sampling time
//! (SMPx: 3, 15, 28, 56, 84, 112, 144 or 480 cycles) plus the resolution's cycles (12, 10, 8, 6
//! for 12-, 10-, 8-, 6-bit) of ADCCLK = PCLK2 / (2, 4, 6, 8 by the common CCR's ADCPRE); the
//! board's six channels at 480 cycles and 11.25 MHz take 492 cycles, 43.7 µs each. The code is
//! the input voltage at the conversion's end over VREF+ (3.3 V unless the harness sets it):
//! `floor(v / vref · 4096)` clamped to 0…4095, then the resolution's top bits; the internal
//! channels (16/18 temperature and VBAT, 17 VREFINT) are inputs the harness sets like the
//! others. Regular conversions run from SWSTART (or an external trigger the chip reports with
//! [`Adc::regular_trigger`]) through SQ1…SQ(L+1) with SCAN (SQ1 alone without), again and again
//! with CONT; injected ones from JSWSTART (or [`Adc::injected_trigger`], or JAUTO after the
//! regular sequence) through the last JL+1 of JSQ1…JSQ4, interrupting a regular conversion,
//! which starts again once the injected group is done (§13.3.9). EOC is set after each regular
//! conversion with EOCS=1, after the sequence with EOCS=0; reading DR clears it. With DMA=1 a
//! request is held from each regular conversion's end until DR is read; with DDS=0 requests end
//! after the DMA's last transfer ([`Adc::dma_eot`]) until DMA is written 0 then 1. Overrun
//! (§13.8.1): with DMA=1 or EOCS=1, a regular conversion that ends while the previous one's DR
//! is unread sets OVR, loses the new data, stops the regular conversions, ignores regular
//! triggers while OVR is set, and (DMA=1) stops DMA requests until DMA is written 0 then 1.
//! The analog watchdog (AWDEN/JAWDEN, AWDSGL/AWDCH, HTR/LTR) compares each code scaled to 12
//! bits and sets AWD outside the window.
//!
//! Not modelled (the board never uses them): discontinuous modes (DISCEN, DISCNUM, JDISCEN are
//! stored, conversions run as with 0), the dual and triple modes (common CCR MULTI, DELAY, DMA
//! and DDS are stored; CDR reads ADC1's DR in its low half), the stabilisation time after ADON
//! (a conversion may start at once), and the edge detection of external triggers (the chip
//! calls [`Adc::regular_trigger`] on the selected edge).

use super::{Clocks, DmaRequests, IrqLines, Peripheral, Size, Time};

/// The base address of ADC1's window (the common registers at +0x300).
pub const ADC1_BASE: u32 = 0x4001_2000;
/// The ADCs' global interrupt (NVIC position).
pub const ADC_IRQ: u16 = 18;
/// The channels (0–15 external, 16–18 internal).
pub const CHANNELS: usize = 19;

/// SR's bits (RM0390 §13.13.1), all rc_w0.
pub mod sr {
    /// Analog watchdog.
    pub const AWD: u32 = 1 << 0;
    /// Regular end of conversion.
    pub const EOC: u32 = 1 << 1;
    /// Injected end of conversion (of the group).
    pub const JEOC: u32 = 1 << 2;
    /// Injected conversion started.
    pub const JSTRT: u32 = 1 << 3;
    /// Regular conversion started.
    pub const STRT: u32 = 1 << 4;
    /// Overrun.
    pub const OVR: u32 = 1 << 5;
    /// All of them.
    pub const ALL: u32 = 0x3F;
}

/// CR1's bits (RM0390 §13.13.2).
pub mod cr1 {
    /// Analog watchdog channel (5 bits).
    pub const AWDCH: u32 = 0x1F;
    /// EOC interrupt enable.
    pub const EOCIE: u32 = 1 << 5;
    /// Analog watchdog interrupt enable.
    pub const AWDIE: u32 = 1 << 6;
    /// JEOC interrupt enable.
    pub const JEOCIE: u32 = 1 << 7;
    /// Scan mode.
    pub const SCAN: u32 = 1 << 8;
    /// Watchdog on a single channel (AWDCH).
    pub const AWDSGL: u32 = 1 << 9;
    /// Automatic injected group conversion after the regular group.
    pub const JAUTO: u32 = 1 << 10;
    /// Regular discontinuous mode (stored, not modelled).
    pub const DISCEN: u32 = 1 << 11;
    /// Injected discontinuous mode (stored, not modelled).
    pub const JDISCEN: u32 = 1 << 12;
    /// Watchdog on injected channels.
    pub const JAWDEN: u32 = 1 << 22;
    /// Watchdog on regular channels.
    pub const AWDEN: u32 = 1 << 23;
    /// Resolution's shift (2 bits: 12, 10, 8, 6 bits).
    pub const RES_SHIFT: u32 = 24;
    /// Overrun interrupt enable.
    pub const OVRIE: u32 = 1 << 26;
    /// The bits that exist.
    pub const MASK: u32 = 0x07C0_FFFF;
}

/// CR2's bits (RM0390 §13.13.3).
pub mod cr2 {
    /// A/D converter on.
    pub const ADON: u32 = 1 << 0;
    /// Continuous conversion.
    pub const CONT: u32 = 1 << 1;
    /// DMA mode.
    pub const DMA: u32 = 1 << 8;
    /// DMA requests after the last transfer (1: continue).
    pub const DDS: u32 = 1 << 9;
    /// EOC after each regular conversion (0: after the sequence).
    pub const EOCS: u32 = 1 << 10;
    /// Left alignment.
    pub const ALIGN: u32 = 1 << 11;
    /// Injected external trigger's shift (4 bits).
    pub const JEXTSEL_SHIFT: u32 = 16;
    /// Injected external trigger enable's shift (2 bits).
    pub const JEXTEN_SHIFT: u32 = 20;
    /// Start the injected group.
    pub const JSWSTART: u32 = 1 << 22;
    /// Regular external trigger's shift (4 bits).
    pub const EXTSEL_SHIFT: u32 = 24;
    /// Regular external trigger enable's shift (2 bits).
    pub const EXTEN_SHIFT: u32 = 28;
    /// Start the regular group.
    pub const SWSTART: u32 = 1 << 30;
    /// The bits that exist.
    pub const MASK: u32 = 0x7F7F_0F03;
}

/// The sampling times SMP 0–7 selects, ADCCLK cycles.
pub const SAMPLE_CYCLES: [u64; 8] = [3, 15, 28, 56, 84, 112, 144, 480];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Group {
    Regular,
    Injected,
}

/// The conversion in progress.
#[derive(Clone, Copy, Debug)]
struct Conversion {
    end: Time,
    group: Group,
    /// The position in the group's sequence (0-based).
    rank: usize,
}

/// ADC1 and the common registers.
#[derive(Clone, Debug)]
pub struct Adc {
    sr: u32,
    cr1: u32,
    cr2: u32,
    smpr: [u32; 2],
    jofr: [u32; 4],
    htr: u32,
    ltr: u32,
    sqr: [u32; 3],
    jsqr: u32,
    jdr: [u32; 4],
    dr: u32,
    common_ccr: u32,
    /// The conversion in progress.
    conv: Option<Conversion>,
    /// The regular rank to convert next (or interrupted by the injected group).
    regular_next: usize,
    /// A regular sequence is in progress (SWSTART given, not yet ended).
    regular_running: bool,
    /// The regular conversion in progress when the injected group came (restart it after).
    regular_interrupted: bool,
    /// The last regular conversion's data not read yet.
    dr_unread: bool,
    /// DMA requests stopped (overrun, or DDS=0 after the last transfer) until DMA is cleared.
    dma_blocked: bool,
    inputs_v: [f64; CHANNELS],
    vref_v: f64,
    now: Time,
    clocks: Clocks,
}

impl Default for Adc {
    fn default() -> Self {
        Self::new()
    }
}

impl Adc {
    /// ADC1 after reset (HTR 0xFFF, everything else 0), inputs at 0 V, VREF+ 3.3 V.
    pub fn new() -> Self {
        Adc {
            sr: 0,
            cr1: 0,
            cr2: 0,
            smpr: [0; 2],
            jofr: [0; 4],
            htr: 0xFFF,
            ltr: 0,
            sqr: [0; 3],
            jsqr: 0,
            jdr: [0; 4],
            dr: 0,
            common_ccr: 0,
            conv: None,
            regular_next: 0,
            regular_running: false,
            regular_interrupted: false,
            dr_unread: false,
            dma_blocked: false,
            inputs_v: [0.0; CHANNELS],
            vref_v: 3.3,
            now: 0,
            clocks: Clocks::RESET,
        }
    }

    /// The RCC's reset of the ADCs (APB2RSTR ADCRST): every register to its reset value;
    /// the inputs, VREF+ and the time stay.
    pub fn rcc_reset(&mut self) {
        let (inputs_v, vref_v, now, clocks) = (self.inputs_v, self.vref_v, self.now, self.clocks);
        *self = Adc::new();
        self.inputs_v = inputs_v;
        self.vref_v = vref_v;
        self.now = now;
        self.clocks = clocks;
    }

    /// Harness: the voltage on channel `channel` (0–18), V.
    pub fn set_input_v(&mut self, channel: usize, volts: f64) {
        self.inputs_v[channel] = volts;
    }

    /// Harness: VREF+, V (3.3 V on the NUCLEO board).
    pub fn set_vref_v(&mut self, volts: f64) {
        self.vref_v = volts;
    }

    /// The 12-bit code of `volts` (before the resolution's truncation).
    pub fn code_12bit(&self, volts: f64) -> u32 {
        let x = (volts / self.vref_v * 4096.0).floor();
        x.clamp(0.0, 4095.0) as u32
    }

    /// The regular group's external trigger `extsel` (0–15) had its selected edge: it starts
    /// the regular group if EXTEN is not 0 and EXTSEL is `extsel`.
    pub fn regular_trigger(&mut self, extsel: u8) {
        let exten = (self.cr2 >> cr2::EXTEN_SHIFT) & 3;
        if exten != 0 && (self.cr2 >> cr2::EXTSEL_SHIFT) & 0xF == u32::from(extsel) {
            self.start_regular();
        }
    }

    /// The injected group's external trigger `jextsel` (0–15) had its selected edge.
    pub fn injected_trigger(&mut self, jextsel: u8) {
        let jexten = (self.cr2 >> cr2::JEXTEN_SHIFT) & 3;
        if jexten != 0 && (self.cr2 >> cr2::JEXTSEL_SHIFT) & 0xF == u32::from(jextsel) {
            self.start_injected();
        }
    }

    /// The DMA stream reading DR has made its last transfer (NDTR reached 0): with DDS=0 no
    /// request follows until DMA is written 0 then 1.
    pub fn dma_eot(&mut self) {
        if self.cr2 & cr2::DDS == 0 {
            self.dma_blocked = true;
        }
    }

    /// The DMA request now: DMA=1 and a regular conversion's data unread.
    pub fn requests(&self) -> DmaRequests {
        DmaRequests {
            rx: self.cr2 & cr2::DMA != 0 && self.dr_unread && !self.dma_blocked,
            tx: false,
        }
    }

    fn resolution_bits(&self) -> u32 {
        [12, 10, 8, 6][((self.cr1 >> cr1::RES_SHIFT) & 3) as usize]
    }

    /// ADCCLK's divider of PCLK2 (ADCPRE).
    fn prescaler(&self) -> u64 {
        2 * (((self.common_ccr >> 16) & 3) as u64 + 1)
    }

    /// ADCCLK cycles of a conversion of `channel`.
    pub fn conversion_cycles(&self, channel: u8) -> u64 {
        let ch = usize::from(channel);
        let smp = if ch < 10 {
            (self.smpr[1] >> (3 * ch)) & 7
        } else {
            (self.smpr[0] >> (3 * (ch - 10))) & 7
        };
        SAMPLE_CYCLES[smp as usize] + u64::from(self.resolution_bits())
    }

    fn regular_len(&self) -> usize {
        if self.cr1 & cr1::SCAN != 0 {
            ((self.sqr[0] >> 20) & 0xF) as usize + 1
        } else {
            1
        }
    }

    fn regular_channel(&self, rank: usize) -> u8 {
        // SQ1–6 in SQR3, SQ7–12 in SQR2, SQ13–16 in SQR1.
        let reg = [2, 1, 0][rank / 6];
        ((self.sqr[reg] >> (5 * (rank % 6))) & 0x1F) as u8
    }

    fn injected_len(&self) -> usize {
        if self.cr1 & cr1::SCAN != 0 {
            ((self.jsqr >> 20) & 3) as usize + 1
        } else {
            1
        }
    }

    fn injected_channel(&self, rank: usize) -> u8 {
        // JL+1 conversions use JSQ(4−JL)…JSQ4 (§13.13.12).
        let jl = ((self.jsqr >> 20) & 3) as usize;
        let field = 3 - jl + rank;
        ((self.jsqr >> (5 * field)) & 0x1F) as u8
    }

    fn channel_of(&self, group: Group, rank: usize) -> u8 {
        match group {
            Group::Regular => self.regular_channel(rank),
            Group::Injected => self.injected_channel(rank),
        }
        .min(CHANNELS as u8 - 1)
    }

    fn begin(&mut self, group: Group, rank: usize) {
        let ch = self.channel_of(group, rank);
        let pclk2_cycles = self.conversion_cycles(ch) * self.prescaler();
        let end = self.now + Clocks::time_of(pclk2_cycles, self.clocks.pclk2_hz);
        self.conv = Some(Conversion { end, group, rank });
        match group {
            Group::Regular => self.sr |= sr::STRT,
            Group::Injected => self.sr |= sr::JSTRT,
        }
    }

    fn start_regular(&mut self) {
        if self.cr2 & cr2::ADON == 0 || self.sr & sr::OVR != 0 {
            return;
        }
        self.cr2 &= !cr2::SWSTART;
        if self.regular_running {
            // A trigger during a sequence is ignored.
            return;
        }
        self.regular_running = true;
        self.regular_next = 0;
        if self.conv.is_none() {
            self.begin(Group::Regular, 0);
        }
    }

    fn start_injected(&mut self) {
        if self.cr2 & cr2::ADON == 0 {
            return;
        }
        self.cr2 &= !cr2::JSWSTART;
        match self.conv {
            Some(c) if c.group == Group::Injected => {}
            Some(c) => {
                // §13.3.9: the regular conversion is reset, the injected group converts, then
                // the regular conversion restarts.
                self.regular_next = c.rank;
                self.regular_interrupted = true;
                self.conv = None;
                self.begin(Group::Injected, 0);
            }
            None => self.begin(Group::Injected, 0),
        }
    }

    /// The watchdog's check of `code` (at the resolution) on `channel`.
    fn watchdog(&mut self, group: Group, channel: u8, code: u32) {
        let enabled = match group {
            Group::Regular => self.cr1 & cr1::AWDEN != 0,
            Group::Injected => self.cr1 & cr1::JAWDEN != 0,
        };
        let single = self.cr1 & cr1::AWDSGL != 0;
        if !enabled || (single && u32::from(channel) != self.cr1 & cr1::AWDCH) {
            return;
        }
        let code12 = code << (12 - self.resolution_bits());
        if code12 > self.htr || code12 < self.ltr {
            self.sr |= sr::AWD;
        }
    }

    /// The conversion `c` ended (at `self.now`).
    fn finish(&mut self, c: Conversion) {
        let ch = self.channel_of(c.group, c.rank);
        let r = self.resolution_bits();
        let code = self.code_12bit(self.inputs_v[usize::from(ch)]) >> (12 - r);
        self.watchdog(c.group, ch, code);
        let left = self.cr2 & cr2::ALIGN != 0;
        match c.group {
            Group::Regular => {
                let overrun_check = self.cr2 & (cr2::DMA | cr2::EOCS) != 0;
                if overrun_check && self.dr_unread {
                    // §13.8.1: the data are lost, the regular conversions stop.
                    self.sr |= sr::OVR;
                    self.regular_running = false;
                    if self.cr2 & cr2::DMA != 0 {
                        self.dma_blocked = true;
                    }
                    self.after_injected_or_idle();
                    return;
                }
                self.dr = if left {
                    code << if r == 6 { 2 } else { 16 - r }
                } else {
                    code
                };
                self.dr_unread = true;
                let last = c.rank + 1 >= self.regular_len();
                if self.cr2 & cr2::EOCS != 0 || last {
                    self.sr |= sr::EOC;
                }
                if !last {
                    self.begin(Group::Regular, c.rank + 1);
                    return;
                }
                self.regular_running = false;
                if self.cr1 & cr1::JAUTO != 0 {
                    self.begin(Group::Injected, 0);
                    return;
                }
                if self.cr2 & cr2::CONT != 0 {
                    self.regular_running = true;
                    self.begin(Group::Regular, 0);
                }
            }
            Group::Injected => {
                let offset = self.jofr[c.rank.min(3)] as i32;
                let v = code as i32 - offset;
                self.jdr[c.rank] = if left {
                    let shift = if r == 6 { 2 } else { 15 - r };
                    ((v << shift) as u32) & 0xFFFF
                } else {
                    (v as u32) & 0xFFFF
                };
                if c.rank + 1 < self.injected_len() {
                    self.begin(Group::Injected, c.rank + 1);
                    return;
                }
                self.sr |= sr::JEOC;
                if self.cr1 & cr1::JAUTO != 0 && !self.regular_interrupted {
                    // JAUTO: the injected group followed the regular one.
                    if self.cr2 & cr2::CONT != 0 {
                        self.regular_running = true;
                        self.begin(Group::Regular, 0);
                    }
                    return;
                }
                self.after_injected_or_idle();
            }
        }
    }

    /// After the injected group (or an overrun): resume an interrupted regular conversion.
    fn after_injected_or_idle(&mut self) {
        if self.regular_interrupted {
            self.regular_interrupted = false;
            if self.regular_running {
                self.begin(Group::Regular, self.regular_next);
            }
        }
    }

    fn write_cr2(&mut self, value: u32) {
        self.cr2 = value & cr2::MASK;
        if self.cr2 & cr2::DMA == 0 {
            self.dma_blocked = false;
        }
        if self.cr2 & cr2::ADON == 0 {
            // Powered down: conversions stop.
            self.conv = None;
            self.regular_running = false;
            self.regular_interrupted = false;
            self.cr2 &= !(cr2::SWSTART | cr2::JSWSTART);
            return;
        }
        // SWSTART is ignored (and stays as written) while OVR is set.
        if self.cr2 & cr2::SWSTART != 0 {
            self.start_regular();
        }
        if self.cr2 & cr2::JSWSTART != 0 {
            self.start_injected();
        }
    }

    fn read_dr(&mut self) -> u32 {
        self.sr &= !sr::EOC;
        self.dr_unread = false;
        self.dr
    }

    fn peek(&self, offset: u32) -> u32 {
        match offset {
            0x00 => self.sr,
            0x04 => self.cr1,
            0x08 => self.cr2,
            0x0C => self.smpr[0],
            0x10 => self.smpr[1],
            0x14..=0x20 => self.jofr[((offset - 0x14) / 4) as usize],
            0x24 => self.htr,
            0x28 => self.ltr,
            0x2C..=0x34 => self.sqr[((offset - 0x2C) / 4) as usize],
            0x38 => self.jsqr,
            0x3C..=0x48 => self.jdr[((offset - 0x3C) / 4) as usize],
            0x4C => self.dr,
            // Common: CSR mirrors ADC1's flags (ADC2/3 not modelled), CCR, CDR.
            0x300 => self.sr & sr::ALL,
            0x304 => self.common_ccr,
            0x308 => self.dr & 0xFFFF,
            _ => 0,
        }
    }
}

impl Peripheral for Adc {
    fn name(&self) -> &'static str {
        "ADC1"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        let word = offset & !3;
        let v = if word == 0x4C {
            self.read_dr()
        } else {
            self.peek(word)
        };
        super::lanes(v, offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        let value = super::merge(self.peek(word), offset, size, value);
        match word {
            // rc_w0: 0 clears, 1 leaves.
            0x00 => self.sr &= value | !sr::ALL,
            0x04 => self.cr1 = value & cr1::MASK,
            0x08 => self.write_cr2(value),
            0x0C => self.smpr[0] = value & 0x07FF_FFFF,
            0x10 => self.smpr[1] = value & 0x3FFF_FFFF,
            0x14..=0x20 => self.jofr[((word - 0x14) / 4) as usize] = value & 0xFFF,
            0x24 => self.htr = value & 0xFFF,
            0x28 => self.ltr = value & 0xFFF,
            0x2C => self.sqr[0] = value & 0x00FF_FFFF,
            0x30 | 0x34 => self.sqr[((word - 0x2C) / 4) as usize] = value & 0x3FFF_FFFF,
            0x38 => self.jsqr = value & 0x003F_FFFF,
            0x304 => self.common_ccr = value & 0x00C3_EF1F,
            // JDRx, DR, CSR and CDR are read-only.
            _ => {}
        }
    }

    fn advance(&mut self, now: Time, clocks: &Clocks) {
        self.clocks = *clocks;
        while let Some(c) = self.conv {
            if c.end > now {
                break;
            }
            self.now = c.end;
            self.conv = None;
            self.finish(c);
        }
        self.now = self.now.max(now);
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        self.conv.map(|c| c.end.max(now + 1))
    }
}

impl IrqLines for Adc {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        let (s, c) = (self.sr, self.cr1);
        let high = (s & sr::EOC != 0 && c & cr1::EOCIE != 0)
            || (s & sr::JEOC != 0 && c & cr1::JEOCIE != 0)
            || (s & sr::AWD != 0 && c & cr1::AWDIE != 0)
            || (s & sr::OVR != 0 && c & cr1::OVRIE != 0);
        line(ADC_IRQ, high);
    }
}

#[cfg(test)]
mod tests {
    use super::super::dma::{BusFault, Controller, Dma, DmaBus, Serviced, cr as dcr};
    use super::*;

    const CLOCKS: Clocks = Clocks {
        sysclk_hz: 180_000_000,
        hclk_hz: 180_000_000,
        pclk1_hz: 45_000_000,
        pclk2_hz: 90_000_000,
        tim_apb1_hz: 90_000_000,
        tim_apb2_hz: 180_000_000,
        lsi_hz: 32_000,
    };
    /// The board's scan: IN0, IN1, IN4, IN8, IN11, IN10.
    const SCAN: [u8; 6] = [0, 1, 4, 8, 11, 10];
    /// 492 ADCCLK cycles at 11.25 MHz (64 ticks each).
    const CONV: Time = 492 * 64;

    fn modify(adc: &mut Adc, reg: u32, f: impl FnOnce(u32) -> u32) {
        let v = adc.peek(reg);
        adc.write(reg, Size::Word, f(v));
    }

    /// What embassy-stm32 0.6 does for the board's `into_ring_buffered` (adc/v2.rs), then
    /// `RingBufferedAdc::start` (after the DMA stream is enabled): SWSTART.
    fn board_setup(adc: &mut Adc) {
        adc.advance(0, &CLOCKS);
        // Adc::new: ADCPRE (DIV4 from PCLK2), ADON; the board then sets DIV8.
        modify(adc, 0x304, |v| (v & !(3 << 16)) | 1 << 16);
        modify(adc, 0x08, |v| v | cr2::ADON);
        modify(adc, 0x304, |v| (v & !(3 << 16)) | 3 << 16);
        // stop(): SWSTART, ADON, DMA off; EOCIE, OVRIE off; EOC, OVR cleared.
        modify(adc, 0x08, |v| v & !(cr2::SWSTART | cr2::ADON | cr2::DMA));
        modify(adc, 0x04, |v| v & !(cr1::EOCIE | cr1::OVRIE));
        modify(adc, 0x00, |v| v & !(sr::EOC | sr::OVR));
        // configure_sequence: ADON, L, SQx, SMPx = 480 cycles (7).
        modify(adc, 0x08, |v| v | cr2::ADON);
        modify(adc, 0x2C, |v| (v & !(0xF << 20)) | 5 << 20);
        for (i, &ch) in SCAN.iter().enumerate() {
            modify(adc, 0x34, |v| {
                (v & !(0x1F << (5 * i))) | u32::from(ch) << (5 * i)
            });
            if ch <= 9 {
                modify(adc, 0x10, |v| v | 7 << (3 * ch));
            } else {
                modify(adc, 0x0C, |v| v | 7 << (3 * (ch - 10)));
            }
        }
        // configure_dma: SR cleared; EOCIE, OVRIE, SCAN, DISCEN off; DMA, DDS, EOCS; CONT.
        modify(adc, 0x00, |v| v & !(sr::EOC | sr::OVR | sr::STRT));
        modify(adc, 0x04, |v| {
            (v | cr1::EOCIE | cr1::OVRIE | cr1::SCAN) & !cr1::DISCEN
        });
        modify(adc, 0x08, |v| v | cr2::DMA | cr2::DDS | cr2::EOCS);
        modify(adc, 0x08, |v| v | cr2::CONT);
    }

    struct Bus<'a>(&'a mut Adc, &'a mut Vec<u16>);

    impl DmaBus for Bus<'_> {
        fn read(&mut self, address: u32, size: Size) -> Result<u32, BusFault> {
            assert_eq!((address, size), (ADC1_BASE + 0x4C, Size::Half));
            Ok(self.0.read(0x4C, size))
        }
        fn write(&mut self, address: u32, size: Size, value: u32) -> Result<(), BusFault> {
            assert_eq!(size, Size::Half);
            let i = ((address - 0x2000_0000) / 2) as usize;
            *self.1.get_mut(i).ok_or(BusFault)? = value as u16;
            Ok(())
        }
    }

    fn dma_stream0(dma: &mut Dma, n: u32) {
        dma.write(0x18, Size::Word, ADC1_BASE + 0x4C);
        dma.write(0x1C, Size::Word, 0x2000_0000);
        dma.write(0x14, Size::Word, n);
        dma.write(0x24, Size::Word, 0);
        let cr = 0b01 << dcr::PSIZE_SHIFT
            | 0b01 << dcr::MSIZE_SHIFT
            | dcr::MINC
            | dcr::CIRC
            | dcr::HTIE
            | dcr::TCIE
            | dcr::TEIE;
        dma.write(0x10, Size::Word, cr);
        dma.write(0x10, Size::Word, cr | dcr::EN);
    }

    fn set_board_inputs(adc: &mut Adc) -> [u32; 6] {
        let volts = [0.0, 0.5, 1.65, 2.0, 3.2999, 4.0];
        for (&ch, &v) in SCAN.iter().zip(&volts) {
            adc.set_input_v(usize::from(ch), v);
        }
        // floor(v / 3.3 · 4096), clamped.
        [0, 620, 2048, 2482, 4095, 4095]
    }

    #[test]
    fn board_scan_of_six_channels_into_a_circular_dma_buffer() {
        let mut adc = Adc::new();
        let mut dma = Dma::new(Controller::Dma2);
        let mut buf = vec![0u16; 12];
        let codes = set_board_inputs(&mut adc);
        board_setup(&mut adc);
        dma_stream0(&mut dma, 12);
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        assert_eq!(
            adc.peek(0x08) & cr2::SWSTART,
            0,
            "cleared as the conversion starts"
        );
        assert_eq!(adc.peek(0x00), sr::STRT);
        let mut ends = Vec::new();
        let mut now = 0;
        for k in 0..15 {
            if k == 12 {
                // New voltages for the second lap's first three conversions.
                adc.set_input_v(0, 1.0);
                adc.set_input_v(1, 2.5);
                adc.set_input_v(4, 0.1);
            }
            now = adc.next_event(now, &CLOCKS).unwrap();
            adc.advance(now, &CLOCKS);
            ends.push(now);
            let mut irq = false;
            adc.irqs(&mut |_, h| irq = h);
            assert!(irq, "EOC with EOCIE until the DMA reads DR");
            assert!(adc.requests().rx);
            let r = dma.service(0, &mut Bus(&mut adc, &mut buf));
            assert!(matches!(r, Serviced::Moved { .. }));
            assert!(!adc.requests().rx);
            assert_eq!(adc.peek(0x00) & sr::EOC, 0, "the DMA's DR read clears EOC");
        }
        // Each conversion 480 + 12 cycles of 90 MHz / 8, back to back.
        let expected: Vec<Time> = (1..=15).map(|k| k * CONV).collect();
        assert_eq!(ends, expected);
        assert_eq!(CONV, 31_488);
        assert_eq!(
            Clocks::ticks(6 * CONV, 1_000_000),
            262,
            "a scan takes 262.4 µs"
        );
        // 15 conversions into 12 slots: the last 3 wrapped to the start.
        let mut want: Vec<u16> = codes.iter().chain(&codes).map(|&c| c as u16).collect();
        want[..3].copy_from_slice(&[1241, 3103, 124]);
        assert_eq!(buf, want);
        assert_eq!(adc.peek(0x00) & sr::OVR, 0);
    }

    #[test]
    fn overrun_when_dr_is_not_read_with_dma_stops_conversions_and_requests() {
        let mut adc = Adc::new();
        set_board_inputs(&mut adc);
        board_setup(&mut adc);
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        adc.advance(CONV, &CLOCKS);
        assert!(adc.requests().rx);
        assert_eq!(adc.peek(0x4C), 0);
        // Nobody reads: the second conversion's end is an overrun.
        adc.advance(2 * CONV, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::OVR, sr::OVR);
        assert_eq!(adc.peek(0x4C), 0, "the new data were lost");
        assert!(!adc.requests().rx, "DMA requests stop");
        assert_eq!(adc.next_event(2 * CONV, &CLOCKS), None, "conversions stop");
        let mut irq = false;
        adc.irqs(&mut |i, h| irq = i == ADC_IRQ && h);
        assert!(irq, "OVRIE");
        // SWSTART is ignored while OVR is set.
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        assert_eq!(adc.next_event(2 * CONV, &CLOCKS), None);
        // Recovery: clear OVR, DMA off and on, read DR, start again.
        modify(&mut adc, 0x00, |v| v & !sr::OVR);
        modify(&mut adc, 0x08, |v| v & !(cr2::DMA | cr2::SWSTART));
        modify(&mut adc, 0x08, |v| v | cr2::DMA);
        adc.read(0x4C, Size::Half);
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        adc.advance(3 * CONV, &CLOCKS);
        assert!(adc.requests().rx);
        assert_eq!(
            adc.read(0x4C, Size::Half),
            0,
            "IN0 again: the sequence restarted"
        );
    }

    #[test]
    fn single_conversion_without_scan_eocs_0_and_no_overrun_detection() {
        let mut adc = Adc::new();
        adc.advance(0, &CLOCKS);
        adc.set_input_v(3, 1.0);
        // PCLK2 / 2 = 45 MHz; channel 3 at 3 cycles; 8-bit: 3 + 8 = 11 cycles.
        modify(&mut adc, 0x04, |_| 2 << cr1::RES_SHIFT);
        modify(&mut adc, 0x34, |_| 3);
        modify(&mut adc, 0x08, |_| cr2::ADON);
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        let t = adc.next_event(0, &CLOCKS).unwrap();
        assert_eq!(t, Clocks::time_of(11 * 2, 90_000_000));
        adc.advance(t, &CLOCKS);
        // floor(1.0 / 3.3 · 4096) = 1241 → 8 bits: 77.
        assert_eq!(adc.peek(0x00), sr::STRT | sr::EOC);
        assert_eq!(adc.peek(0x4C), 1241 >> 4);
        assert_eq!(adc.next_event(t, &CLOCKS), None, "single, not continuous");
        // A second conversion over unread data: no OVR with DMA=0 and EOCS=0.
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        adc.advance(2 * t, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::OVR, 0);
        // Left alignment of an 8-bit code: bits 15:8.
        modify(&mut adc, 0x08, |v| v | cr2::ALIGN | cr2::SWSTART);
        adc.advance(3 * t, &CLOCKS);
        assert_eq!(adc.read(0x4C, Size::Word), 77 << 8);
        assert_eq!(adc.peek(0x00) & sr::EOC, 0, "DR read clears EOC");
        // rc_w0: writing 1 leaves STRT, 0 clears it.
        adc.write(0x00, Size::Word, 0x3F);
        assert_eq!(adc.peek(0x00), sr::STRT);
        adc.write(0x00, Size::Word, 0);
        assert_eq!(adc.peek(0x00), 0);
        assert_eq!(adc.peek(0x300), 0, "CSR mirrors SR");
    }

    #[test]
    fn eoc_at_the_end_of_the_sequence_with_eocs_0() {
        let mut adc = Adc::new();
        adc.advance(0, &CLOCKS);
        modify(&mut adc, 0x04, |_| cr1::SCAN);
        modify(&mut adc, 0x2C, |_| 1 << 20);
        modify(&mut adc, 0x34, |_| 5 | 6 << 5);
        modify(&mut adc, 0x08, |_| cr2::ADON);
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        // (3 + 12) cycles of 45 MHz each (PCLK2 / 2).
        let conv = Clocks::time_of(15 * 2, 90_000_000);
        adc.advance(conv, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::EOC, 0);
        adc.advance(2 * conv, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::EOC, sr::EOC);
    }

    #[test]
    fn injected_group_interrupts_regular_and_applies_offsets() {
        let mut adc = Adc::new();
        adc.advance(0, &CLOCKS);
        adc.set_input_v(0, 1.65);
        adc.set_input_v(2, 0.5);
        adc.set_input_v(7, 3.3);
        modify(&mut adc, 0x04, |_| cr1::SCAN | cr1::JEOCIE);
        modify(&mut adc, 0x34, |_| 7);
        // Two injected conversions (JL=1): JSQ3 = IN0, JSQ4 = IN2; JOFR1 = 48.
        modify(&mut adc, 0x38, |_| 1 << 20 | 2 << 15);
        modify(&mut adc, 0x14, |_| 48);
        modify(&mut adc, 0x08, |_| cr2::ADON | cr2::SWSTART);
        let conv = Clocks::time_of(15 * 2, 90_000_000);
        adc.advance(conv / 2, &CLOCKS);
        modify(&mut adc, 0x08, |v| v | cr2::JSWSTART);
        assert_eq!(adc.peek(0x08) & cr2::JSWSTART, 0);
        assert_eq!(adc.peek(0x00) & sr::JSTRT, sr::JSTRT);
        adc.advance(conv / 2 + 2 * conv, &CLOCKS);
        assert_eq!(adc.peek(0x00) & (sr::JEOC | sr::EOC), sr::JEOC);
        assert_eq!(adc.peek(0x3C), 2048 - 48);
        assert_eq!(adc.peek(0x40), 620);
        let mut irq = false;
        adc.irqs(&mut |_, h| irq = h);
        assert!(irq);
        // The regular conversion restarted after the group: ends a whole conversion later.
        adc.advance(conv / 2 + 3 * conv, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::EOC, sr::EOC);
        assert_eq!(adc.peek(0x4C), 4095);
        // A negative injected result is sign-extended to 16 bits.
        modify(&mut adc, 0x14, |_| 3000);
        adc.set_input_v(0, 0.0);
        modify(&mut adc, 0x08, |v| v | cr2::JSWSTART);
        adc.advance(conv / 2 + 5 * conv, &CLOCKS);
        assert_eq!(adc.peek(0x3C), (-3000i32 as u32) & 0xFFFF);
    }

    #[test]
    fn analog_watchdog_on_a_single_channel() {
        let mut adc = Adc::new();
        adc.advance(0, &CLOCKS);
        adc.set_input_v(4, 3.0);
        modify(&mut adc, 0x24, |_| 3000);
        modify(&mut adc, 0x28, |_| 100);
        modify(&mut adc, 0x04, |_| {
            cr1::AWDEN | cr1::AWDSGL | cr1::AWDIE | 4
        });
        modify(&mut adc, 0x34, |_| 4);
        modify(&mut adc, 0x08, |_| cr2::ADON | cr2::SWSTART);
        adc.advance(1_000_000, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::AWD, sr::AWD, "3723 > HTR 3000");
        modify(&mut adc, 0x00, |v| v & !sr::AWD);
        adc.set_input_v(4, 1.0);
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        adc.advance(2_000_000, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::AWD, 0);
    }

    #[test]
    fn dds_0_stops_requests_after_the_dma_eot_until_dma_is_rewritten() {
        let mut adc = Adc::new();
        adc.advance(0, &CLOCKS);
        modify(&mut adc, 0x08, |_| cr2::ADON | cr2::CONT | cr2::DMA);
        modify(&mut adc, 0x08, |v| v | cr2::SWSTART);
        let conv = Clocks::time_of(15 * 2, 90_000_000);
        adc.advance(conv, &CLOCKS);
        assert!(adc.requests().rx);
        adc.read(0x4C, Size::Half);
        adc.dma_eot();
        adc.advance(2 * conv, &CLOCKS);
        assert!(
            !adc.requests().rx,
            "DDS=0: no request after the last transfer"
        );
        modify(&mut adc, 0x08, |v| v & !cr2::DMA);
        modify(&mut adc, 0x08, |v| v | cr2::DMA);
        assert!(adc.requests().rx);
        // With DDS=1 the EOT changes nothing.
        modify(&mut adc, 0x08, |v| v | cr2::DDS);
        adc.dma_eot();
        assert!(adc.requests().rx);
    }

    #[test]
    fn jauto_converts_the_injected_group_after_the_regular_one() {
        let mut adc = Adc::new();
        adc.advance(0, &CLOCKS);
        adc.set_input_v(1, 3.3);
        adc.set_input_v(2, 1.65);
        modify(&mut adc, 0x04, |_| cr1::JAUTO);
        modify(&mut adc, 0x34, |_| 1);
        // JL=0: the one injected conversion is JSQ4.
        modify(&mut adc, 0x38, |_| 2 << 15);
        modify(&mut adc, 0x08, |_| cr2::ADON | cr2::SWSTART);
        let conv = Clocks::time_of(15 * 2, 90_000_000);
        adc.advance(conv, &CLOCKS);
        assert_eq!(adc.peek(0x00) & (sr::EOC | sr::JEOC), sr::EOC);
        adc.advance(2 * conv, &CLOCKS);
        assert_eq!(adc.peek(0x00) & sr::JEOC, sr::JEOC);
        assert_eq!((adc.peek(0x4C), adc.peek(0x3C)), (4095, 2048));
        assert_eq!(adc.next_event(2 * conv, &CLOCKS), None, "CONT=0: done");
    }

    #[test]
    fn adon_off_stops_and_registers_mask() {
        let mut adc = Adc::new();
        adc.advance(0, &CLOCKS);
        modify(&mut adc, 0x08, |_| cr2::SWSTART);
        assert_eq!(adc.next_event(0, &CLOCKS), None, "SWSTART needs ADON");
        modify(&mut adc, 0x08, |_| cr2::ADON | cr2::CONT | cr2::SWSTART);
        assert!(adc.next_event(0, &CLOCKS).is_some());
        modify(&mut adc, 0x08, |v| v & !cr2::ADON);
        assert_eq!(adc.next_event(0, &CLOCKS), None);
        assert_eq!(adc.peek(0x24), 0xFFF, "HTR reset value");
        adc.write(0x2C, Size::Word, u32::MAX);
        assert_eq!(adc.peek(0x2C), 0x00FF_FFFF);
        adc.write(0x304, Size::Word, u32::MAX);
        assert_eq!(adc.peek(0x304), 0x00C3_EF1F);
        adc.rcc_reset();
        assert_eq!(
            (adc.peek(0x2C), adc.peek(0x304), adc.peek(0x24)),
            (0, 0, 0xFFF)
        );
    }
}
