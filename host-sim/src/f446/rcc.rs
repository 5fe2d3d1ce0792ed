//! The reset and clock control (RCC, RM0390 §6) at 0x4002_3800: the oscillators' and PLLs'
//! enables and ready flags, the system clock switch, the bus prescalers, the peripherals'
//! reset and clock-enable registers, the backup domain control and the reset flags.
//!
//! It owns the chip's clock tree: [`Rcc::clocks`] gives the frequencies its configuration
//! yields, from the source the switch has actually selected (SWS). It also keeps the reset
//! flags across a reset ([`Rcc::reset`]) until software writes RMVF (RM0390 §6.3.21).
//!
//! Ready flags come true after a modelled start-up delay from the moment an oscillator is on
//! (and, for a PLL, its input is ready): [`HSI_STARTUP`], [`HSE_BYPASS_STARTUP`],
//! [`HSE_CRYSTAL_STARTUP`], [`PLL_LOCK`], [`LSI_STARTUP`], [`LSE_STARTUP`] — round values of
//! the order of DS10693's start-up and lock times (chosen, not measured). A ready flag
//! clears at once when its oscillator is turned off. The switch (SW → SWS) happens when the
//! selected source is ready, at once if it already is.
//!
//! PLLCFGR (and the I2S/SAI PLLs' registers) are taken as written even while the PLL runs
//! (RM0390 asks software to write them only with the PLL off); [`Rcc::clocks`] follows them.
//! The chip forwards PWR_CR's DBP with [`Rcc::set_backup_access`] after each PWR write:
//! BDCR ignores writes without it.
//!
//! Not modelled (registers hold and read back what is written, with no further effect): the
//! clock security system (CSSON is stored; the HSE never fails, CSSF never sets), the MCO
//! outputs (CFGR's MCO fields), RTCPRE, spread spectrum (SSCGR), the I2S/SAI/SPDIF/48 MHz
//! kernel clock selections (DCKCFGR except TIMPRE, CKGATENR, DCKCFGR2), HSI trimming, and the
//! RSTR registers' effect on the peripherals (the chip reads them with [`Rcc::peek`]).

use super::{Clocks, IrqLines, Peripheral, Size, TIME_HZ, Time, lanes, merge};

/// One microsecond in time-base ticks.
const MICROSECOND: Time = TIME_HZ / 1_000_000;
/// The HSI's start-up time once HSION is set.
pub const HSI_STARTUP: Time = 2 * MICROSECOND;
/// The HSE's start-up time in bypass (an external clock: no oscillator to start).
pub const HSE_BYPASS_STARTUP: Time = MICROSECOND;
/// The HSE's start-up time with a crystal.
pub const HSE_CRYSTAL_STARTUP: Time = 2_000 * MICROSECOND;
/// A PLL's lock time once it is on and its input is ready.
pub const PLL_LOCK: Time = 100 * MICROSECOND;
/// The LSI's start-up time.
pub const LSI_STARTUP: Time = 40 * MICROSECOND;
/// The LSE crystal's start-up time (2 s).
pub const LSE_STARTUP: Time = 2_000_000 * MICROSECOND;

/// The HSI's frequency, Hz.
pub const HSI_HZ: u32 = 16_000_000;
/// The LSI's frequency, Hz (nominal; DS10693 gives 17–47 kHz).
pub const LSI_HZ: u32 = 32_000;
/// The LSE crystal's frequency, Hz.
pub const LSE_HZ: u32 = 32_768;
/// The RCC's global interrupt (RM0390 table 38).
pub const RCC_IRQ: u16 = 5;

/// Register offsets (RM0390 §6.3.25).
pub mod reg {
    /// Clock control.
    pub const CR: u32 = 0x00;
    /// Main PLL configuration.
    pub const PLLCFGR: u32 = 0x04;
    /// Clock configuration.
    pub const CFGR: u32 = 0x08;
    /// Clock interrupt.
    pub const CIR: u32 = 0x0C;
    /// AHB1 peripheral reset.
    pub const AHB1RSTR: u32 = 0x10;
    /// AHB2 peripheral reset.
    pub const AHB2RSTR: u32 = 0x14;
    /// AHB3 peripheral reset.
    pub const AHB3RSTR: u32 = 0x18;
    /// APB1 peripheral reset.
    pub const APB1RSTR: u32 = 0x20;
    /// APB2 peripheral reset.
    pub const APB2RSTR: u32 = 0x24;
    /// AHB1 peripheral clock enable.
    pub const AHB1ENR: u32 = 0x30;
    /// AHB2 peripheral clock enable.
    pub const AHB2ENR: u32 = 0x34;
    /// AHB3 peripheral clock enable.
    pub const AHB3ENR: u32 = 0x38;
    /// APB1 peripheral clock enable.
    pub const APB1ENR: u32 = 0x40;
    /// APB2 peripheral clock enable.
    pub const APB2ENR: u32 = 0x44;
    /// AHB1 clock enable in low-power mode.
    pub const AHB1LPENR: u32 = 0x50;
    /// AHB2 clock enable in low-power mode.
    pub const AHB2LPENR: u32 = 0x54;
    /// AHB3 clock enable in low-power mode.
    pub const AHB3LPENR: u32 = 0x58;
    /// APB1 clock enable in low-power mode.
    pub const APB1LPENR: u32 = 0x60;
    /// APB2 clock enable in low-power mode.
    pub const APB2LPENR: u32 = 0x64;
    /// Backup domain control.
    pub const BDCR: u32 = 0x70;
    /// Control and status (LSI, reset flags).
    pub const CSR: u32 = 0x74;
    /// Spread spectrum clock generation.
    pub const SSCGR: u32 = 0x80;
    /// PLLI2S configuration.
    pub const PLLI2SCFGR: u32 = 0x84;
    /// PLLSAI configuration.
    pub const PLLSAICFGR: u32 = 0x88;
    /// Dedicated clocks configuration.
    pub const DCKCFGR: u32 = 0x8C;
    /// Clocks gated enable.
    pub const CKGATENR: u32 = 0x90;
    /// Dedicated clocks configuration 2.
    pub const DCKCFGR2: u32 = 0x94;
}

/// RCC_CR bits.
pub mod cr {
    /// HSI on.
    pub const HSION: u32 = 1 << 0;
    /// HSI ready.
    pub const HSIRDY: u32 = 1 << 1;
    /// HSE on.
    pub const HSEON: u32 = 1 << 16;
    /// HSE ready.
    pub const HSERDY: u32 = 1 << 17;
    /// HSE bypass (an external clock on OSC_IN).
    pub const HSEBYP: u32 = 1 << 18;
    /// Clock security system on.
    pub const CSSON: u32 = 1 << 19;
    /// Main PLL on.
    pub const PLLON: u32 = 1 << 24;
    /// Main PLL locked.
    pub const PLLRDY: u32 = 1 << 25;
    /// PLLI2S on.
    pub const PLLI2SON: u32 = 1 << 26;
    /// PLLI2S locked.
    pub const PLLI2SRDY: u32 = 1 << 27;
    /// PLLSAI on.
    pub const PLLSAION: u32 = 1 << 28;
    /// PLLSAI locked.
    pub const PLLSAIRDY: u32 = 1 << 29;
}

/// RCC_CSR bits.
pub mod csr {
    /// LSI on.
    pub const LSION: u32 = 1 << 0;
    /// LSI ready.
    pub const LSIRDY: u32 = 1 << 1;
    /// Remove reset flags (write 1).
    pub const RMVF: u32 = 1 << 24;
    /// Brown-out reset flag.
    pub const BORRSTF: u32 = 1 << 25;
    /// NRST pin reset flag.
    pub const PINRSTF: u32 = 1 << 26;
    /// Power-on/power-down reset flag.
    pub const PORRSTF: u32 = 1 << 27;
    /// Software reset flag.
    pub const SFTRSTF: u32 = 1 << 28;
    /// Independent watchdog reset flag.
    pub const IWDGRSTF: u32 = 1 << 29;
    /// Window watchdog reset flag.
    pub const WWDGRSTF: u32 = 1 << 30;
    /// Low-power reset flag.
    pub const LPWRRSTF: u32 = 1 << 31;
    /// Every reset flag.
    pub const FLAGS: u32 = 0xFE00_0000;
}

/// Why the chip reset: which flags of RCC_CSR the reset sets (RM0390 §6.1, §6.3.21).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// Power-on: PORRSTF, BORRSTF and PINRSTF (CSR's reset value 0x0E00_0000); every
    /// register is reset, the backup domain and the flags too.
    PowerUp,
    /// A brown-out: BORRSTF and PINRSTF.
    BrownOut,
    /// The NRST pin (the reset button, a probe): PINRSTF.
    Pin,
    /// SYSRESETREQ: SFTRSTF and PINRSTF (an internal reset drives NRST low).
    Software,
    /// The independent watchdog: IWDGRSTF and PINRSTF.
    IndependentWatchdog,
    /// The window watchdog: WWDGRSTF and PINRSTF.
    WindowWatchdog,
    /// Entering Stop or Standby with the option bytes' reset: LPWRRSTF and PINRSTF.
    LowPower,
}

impl ResetCause {
    /// The CSR flags this reset sets.
    pub const fn flags(self) -> u32 {
        match self {
            ResetCause::PowerUp => csr::PORRSTF | csr::BORRSTF | csr::PINRSTF,
            ResetCause::BrownOut => csr::BORRSTF | csr::PINRSTF,
            ResetCause::Pin => csr::PINRSTF,
            ResetCause::Software => csr::SFTRSTF | csr::PINRSTF,
            ResetCause::IndependentWatchdog => csr::IWDGRSTF | csr::PINRSTF,
            ResetCause::WindowWatchdog => csr::WWDGRSTF | csr::PINRSTF,
            ResetCause::LowPower => csr::LPWRRSTF | csr::PINRSTF,
        }
    }
}

/// An oscillator or PLL, as the model tracks its start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Osc {
    Hsi,
    Hse,
    Pll,
    PllI2s,
    PllSai,
    Lsi,
    Lse,
}

const OSCS: [Osc; 7] = [
    Osc::Hsi,
    Osc::Hse,
    Osc::Pll,
    Osc::PllI2s,
    Osc::PllSai,
    Osc::Lsi,
    Osc::Lse,
];

impl Osc {
    fn index(self) -> usize {
        self as usize
    }

    /// CIR's ready flag (bit 0..6; its interrupt enable is 8 higher, its clear 16).
    fn cir_flag(self) -> u32 {
        match self {
            Osc::Lsi => 1 << 0,
            Osc::Lse => 1 << 1,
            Osc::Hsi => 1 << 2,
            Osc::Hse => 1 << 3,
            Osc::Pll => 1 << 4,
            Osc::PllI2s => 1 << 5,
            Osc::PllSai => 1 << 6,
        }
    }
}

/// The reset values (RM0390 §6.3).
const CR_RESET: u32 = 0x0000_0083;
const PLLCFGR_RESET: u32 = 0x2400_3010;
const AHB1ENR_RESET: u32 = 0x0010_0000;
const PLLI2SCFGR_RESET: u32 = 0x2400_3010;
const PLLSAICFGR_RESET: u32 = 0x0400_3010;

/// The writable bits and reset values of the plain registers (offset, mask, reset).
const PLAIN: [(u32, u32, u32); 22] = [
    (reg::AHB1RSTR, 0x2060_10FF, 0),
    (reg::AHB2RSTR, 0x0000_0081, 0),
    (reg::AHB3RSTR, 0x0000_0003, 0),
    (reg::APB1RSTR, 0x3FFF_C9FF, 0),
    (reg::APB2RSTR, 0x00C7_7933, 0),
    (reg::AHB1ENR, 0x6074_10FF, AHB1ENR_RESET),
    (reg::AHB2ENR, 0x0000_0081, 0),
    (reg::AHB3ENR, 0x0000_0003, 0),
    (reg::APB1ENR, 0x3FFF_C9FF, 0),
    (reg::APB2ENR, 0x00C7_7F33, 0),
    (reg::AHB1LPENR, 0x6067_90FF, 0x6067_90FF),
    (reg::AHB2LPENR, 0x0000_0081, 0x0000_0081),
    (reg::AHB3LPENR, 0x0000_0003, 0x0000_0003),
    (reg::APB1LPENR, 0x3FFF_C9FF, 0x3FFF_C9FF),
    (reg::APB2LPENR, 0x00C7_7F33, 0x00C7_7F33),
    (reg::SSCGR, 0xCFFF_FFFF, 0),
    (reg::PLLI2SCFGR, 0x7F03_7FFF, PLLI2SCFGR_RESET),
    (reg::PLLSAICFGR, 0x0F03_7FFF, PLLSAICFGR_RESET),
    (reg::DCKCFGR, 0x1FF0_1F1F, 0),
    (reg::CKGATENR, 0x0000_007F, 0),
    (reg::DCKCFGR2, 0x3CC0_0000, 0),
    (reg::PLLCFGR, 0x7F43_7FFF, PLLCFGR_RESET),
];

/// CFGR's writable bits: all but SWS (3:2), bits 9:8 and bit 23.
const CFGR_MASK: u32 = 0xFF7F_FCF3;
/// CR's writable bits: the enables, HSEBYP, CSSON and HSITRIM.
const CR_MASK: u32 = cr::HSION
    | (0x1F << 3)
    | cr::HSEON
    | cr::HSEBYP
    | cr::CSSON
    | cr::PLLON
    | cr::PLLI2SON
    | cr::PLLSAION;
/// BDCR's writable bits: LSEON, LSEBYP, LSEMOD, RTCSEL, RTCEN, BDRST.
const BDCR_MASK: u32 = 0x0001_830D;
/// DCKCFGR's TIMPRE bit.
const TIMPRE: u32 = 1 << 24;

/// The RCC: its registers and the oscillators' start-up.
#[derive(Clone, Debug)]
pub struct Rcc {
    /// The HSE's frequency (8 MHz from the ST-LINK's MCO on the NUCLEO), Hz.
    hse_hz: u32,
    now: Time,
    cr: u32,
    cfgr: u32,
    cir: u32,
    bdcr: u32,
    csr: u32,
    plain: [u32; PLAIN.len()],
    /// Each oscillator's on state and, while starting, when it is ready.
    on: [bool; 7],
    ready: [bool; 7],
    ready_at: [Option<Time>; 7],
    /// Whether PWR's DBP allows writes to the backup domain (BDCR).
    backup_access: bool,
}

impl Rcc {
    /// An RCC after power-up (flags PORRSTF, BORRSTF, PINRSTF), the HSI on and ready, with
    /// an HSE of `hse_hz` (8 MHz bypass on the NUCLEO).
    pub fn new(hse_hz: u32) -> Rcc {
        let mut rcc = Rcc {
            hse_hz,
            now: 0,
            cr: 0,
            cfgr: 0,
            cir: 0,
            bdcr: 0,
            csr: 0,
            plain: [0; PLAIN.len()],
            on: [false; 7],
            ready: [false; 7],
            ready_at: [None; 7],
            backup_access: false,
        };
        rcc.reset(ResetCause::PowerUp);
        rcc
    }

    /// Reset the chip's RCC for `cause`: every register to its reset value (the HSI on and
    /// ready, the system clock on it), except the reset flags, which gain `cause`'s flags
    /// and keep the earlier ones until RMVF, and the backup domain (BDCR, the LSE), which
    /// only a power-up resets (RM0390 §6.1.3, §6.3.21). The model's time is kept.
    pub fn reset(&mut self, cause: ResetCause) {
        let power = cause == ResetCause::PowerUp;
        self.cr = CR_RESET;
        self.cfgr = 0;
        self.cir = 0;
        for (i, (_, _, reset)) in PLAIN.iter().enumerate() {
            self.plain[i] = *reset;
        }
        let flags = if power {
            cause.flags()
        } else {
            (self.csr & csr::FLAGS) | cause.flags()
        };
        self.csr = flags;
        let lse = (self.on[Osc::Lse.index()], self.ready[Osc::Lse.index()]);
        let lse_at = self.ready_at[Osc::Lse.index()];
        self.on = [false; 7];
        self.ready = [false; 7];
        self.ready_at = [None; 7];
        self.on[Osc::Hsi.index()] = true;
        self.ready[Osc::Hsi.index()] = true;
        if power {
            self.bdcr = 0;
            self.backup_access = false;
        } else {
            self.on[Osc::Lse.index()] = lse.0;
            self.ready[Osc::Lse.index()] = lse.1;
            self.ready_at[Osc::Lse.index()] = lse_at;
        }
    }

    /// Tell the RCC whether PWR_CR's DBP allows writes to BDCR (the chip forwards it).
    pub fn set_backup_access(&mut self, allowed: bool) {
        self.backup_access = allowed;
    }

    /// A register's present value without a read's side effects (none here), for the chip
    /// (the enables and resets of the peripherals) and the log.
    pub fn peek(&self, offset: u32) -> u32 {
        let offset = offset & !3;
        match offset {
            reg::CR => self.cr_value(),
            reg::CFGR => self.cfgr,
            reg::CIR => self.cir,
            reg::BDCR => self.bdcr_value(),
            reg::CSR => self.csr_value(),
            _ => PLAIN
                .iter()
                .position(|(o, _, _)| *o == offset)
                .map_or(0, |i| self.plain[i]),
        }
    }

    /// The reset flags (CSR 31:25) as they read now.
    pub fn reset_flags(&self) -> u32 {
        self.csr & csr::FLAGS
    }

    /// The clocks the present configuration gives: the system clock from the source the
    /// switch has selected (SWS), divided by HPRE, PPRE1 and PPRE2; the timers' clocks per
    /// RM0390 §6.2 (×2 when their APB is divided; with DCKCFGR's TIMPRE, HCLK when the APB
    /// divides by 1, 2 or 4, else ×4).
    pub fn clocks(&self) -> Clocks {
        let sysclk_hz = match (self.cfgr >> 2) & 3 {
            0 => HSI_HZ,
            1 => self.hse_hz,
            2 => self.pll_output_hz(self.pll_p_div()),
            _ => self.pll_output_hz(self.pll_r_div()),
        };
        let hpre = (self.cfgr >> 4) & 0xF;
        let ahb_div = if hpre < 8 {
            1
        } else {
            [2, 4, 8, 16, 64, 128, 256, 512][(hpre - 8) as usize]
        };
        let hclk_hz = sysclk_hz / ahb_div;
        let apb_div = |ppre: u32| if ppre < 4 { 1 } else { 2 << (ppre - 4) };
        let timpre = self.peek(reg::DCKCFGR) & TIMPRE != 0;
        let tim = |div: u32| -> u32 {
            if timpre {
                if div <= 4 {
                    hclk_hz
                } else {
                    4 * (hclk_hz / div)
                }
            } else if div == 1 {
                hclk_hz
            } else {
                2 * (hclk_hz / div)
            }
        };
        let div1 = apb_div((self.cfgr >> 10) & 7);
        let div2 = apb_div((self.cfgr >> 13) & 7);
        Clocks {
            sysclk_hz,
            hclk_hz,
            pclk1_hz: hclk_hz / div1,
            pclk2_hz: hclk_hz / div2,
            tim_apb1_hz: tim(div1),
            tim_apb2_hz: tim(div2),
            lsi_hz: LSI_HZ,
        }
    }

    fn pllcfgr(&self) -> u32 {
        self.peek(reg::PLLCFGR)
    }

    fn pll_p_div(&self) -> u32 {
        2 * (((self.pllcfgr() >> 16) & 3) + 1)
    }

    fn pll_r_div(&self) -> u32 {
        ((self.pllcfgr() >> 28) & 7).max(1)
    }

    /// The main PLL's VCO divided by `div`, Hz (its input: HSI or HSE by PLLSRC, over M).
    fn pll_output_hz(&self, div: u32) -> u32 {
        let c = self.pllcfgr();
        let src_hz = if c & (1 << 22) != 0 {
            self.hse_hz
        } else {
            HSI_HZ
        };
        let m = u64::from((c & 0x3F).max(1));
        let n = u64::from((c >> 6) & 0x1FF);
        (u64::from(src_hz) * n / m / u64::from(div)) as u32
    }

    fn cr_value(&self) -> u32 {
        let mut v = (self.cr & CR_MASK) | (self.cr & 0xFF00);
        for (osc, on_bit, rdy_bit) in [
            (Osc::Hsi, cr::HSION, cr::HSIRDY),
            (Osc::Hse, cr::HSEON, cr::HSERDY),
            (Osc::Pll, cr::PLLON, cr::PLLRDY),
            (Osc::PllI2s, cr::PLLI2SON, cr::PLLI2SRDY),
            (Osc::PllSai, cr::PLLSAION, cr::PLLSAIRDY),
        ] {
            v &= !(on_bit | rdy_bit);
            if self.on[osc.index()] {
                v |= on_bit;
            }
            if self.ready[osc.index()] {
                v |= rdy_bit;
            }
        }
        v
    }

    fn bdcr_value(&self) -> u32 {
        let mut v = self.bdcr & !3;
        if self.on[Osc::Lse.index()] {
            v |= 1;
        }
        if self.ready[Osc::Lse.index()] {
            v |= 2;
        }
        v
    }

    fn csr_value(&self) -> u32 {
        let mut v = self.csr & csr::FLAGS;
        if self.on[Osc::Lsi.index()] {
            v |= csr::LSION;
        }
        if self.ready[Osc::Lsi.index()] {
            v |= csr::LSIRDY;
        }
        v
    }

    /// The present system clock's source (SWS) and what it depends on.
    fn in_use(&self, osc: Osc) -> bool {
        let sws = (self.cfgr >> 2) & 3;
        let pll_src_hse = self.pllcfgr() & (1 << 22) != 0;
        let pll_in_use = sws >= 2;
        match osc {
            Osc::Hsi => sws == 0 || (pll_in_use && !pll_src_hse),
            Osc::Hse => sws == 1 || (pll_in_use && pll_src_hse),
            Osc::Pll => pll_in_use,
            _ => false,
        }
    }

    /// Turn an oscillator on or off (off refused while it feeds the system clock, RM0390
    /// §6.3.1).
    fn set_on(&mut self, osc: Osc, on: bool) {
        let i = osc.index();
        if on == self.on[i] || (!on && self.in_use(osc)) {
            return;
        }
        self.on[i] = on;
        if !on {
            self.ready[i] = false;
            self.ready_at[i] = None;
        }
    }

    /// Whether a PLL's input (HSI or HSE by PLLSRC; the I2S and SAI PLLs share it) is ready.
    fn pll_input_ready(&self) -> bool {
        let src = if self.pllcfgr() & (1 << 22) != 0 {
            Osc::Hse
        } else {
            Osc::Hsi
        };
        self.ready[src.index()]
    }

    fn startup(&self, osc: Osc) -> Time {
        match osc {
            Osc::Hsi => HSI_STARTUP,
            Osc::Hse if self.cr & cr::HSEBYP != 0 => HSE_BYPASS_STARTUP,
            Osc::Hse => HSE_CRYSTAL_STARTUP,
            Osc::Pll | Osc::PllI2s | Osc::PllSai => PLL_LOCK,
            Osc::Lsi => LSI_STARTUP,
            Osc::Lse => LSE_STARTUP,
        }
    }

    /// At `t`: start the oscillators that are on and not yet starting (a PLL once its input
    /// is ready), and switch the system clock if its selected source is ready.
    fn settle(&mut self, t: Time) {
        for osc in OSCS {
            let i = osc.index();
            let is_pll = matches!(osc, Osc::Pll | Osc::PllI2s | Osc::PllSai);
            if self.on[i]
                && !self.ready[i]
                && self.ready_at[i].is_none()
                && (!is_pll || self.pll_input_ready())
            {
                self.ready_at[i] = Some(t + self.startup(osc));
            }
            // A PLL loses lock when its input stops.
            if is_pll && self.ready[i] && !self.pll_input_ready() {
                self.ready[i] = false;
                self.ready_at[i] = None;
            }
        }
        let sw = self.cfgr & 3;
        let target = match sw {
            0 => Osc::Hsi,
            1 => Osc::Hse,
            _ => Osc::Pll,
        };
        if self.ready[target.index()] {
            self.cfgr = (self.cfgr & !0xC) | (sw << 2);
        }
    }

    fn next_ready(&self) -> Option<Time> {
        self.ready_at.iter().flatten().copied().min()
    }
}

impl Peripheral for Rcc {
    fn name(&self) -> &'static str {
        "RCC"
    }

    fn read(&mut self, offset: u32, size: Size) -> u32 {
        lanes(self.peek(offset), offset, size)
    }

    fn write(&mut self, offset: u32, size: Size, value: u32) {
        let word = offset & !3;
        let old = self.peek(word);
        let v = merge(old, offset, size, value);
        match word {
            reg::CR => {
                self.cr = (self.cr & !CR_MASK) | (v & CR_MASK);
                // HSEBYP is writable only while the HSE is off.
                if self.on[Osc::Hse.index()] {
                    self.cr = (self.cr & !cr::HSEBYP) | (old & cr::HSEBYP);
                }
                self.set_on(Osc::Hsi, v & cr::HSION != 0);
                self.set_on(Osc::Hse, v & cr::HSEON != 0);
                self.set_on(Osc::Pll, v & cr::PLLON != 0);
                self.set_on(Osc::PllI2s, v & cr::PLLI2SON != 0);
                self.set_on(Osc::PllSai, v & cr::PLLSAION != 0);
            }
            reg::CFGR => {
                // SW = 11 (PLL_R) is a valid source on the F446.
                self.cfgr = (self.cfgr & !CFGR_MASK) | (v & CFGR_MASK);
            }
            reg::CIR => {
                // Enables 14:8 kept; clear bits 23:16 clear the flags; flags read-only.
                let clear = (v >> 16) & 0xFF;
                self.cir = (self.cir & 0x7F & !clear) | (v & 0x7F00);
            }
            reg::BDCR => {
                if self.backup_access {
                    if v & (1 << 16) != 0 {
                        // BDRST: the backup domain to its reset state.
                        self.bdcr = 1 << 16;
                        self.set_on(Osc::Lse, false);
                    } else {
                        self.bdcr = v & BDCR_MASK;
                        self.set_on(Osc::Lse, v & 1 != 0);
                    }
                }
            }
            reg::CSR => {
                if v & csr::RMVF != 0 {
                    self.csr &= !csr::FLAGS;
                }
                self.set_on(Osc::Lsi, v & csr::LSION != 0);
            }
            _ => {
                if let Some(i) = PLAIN.iter().position(|(o, _, _)| *o == word) {
                    self.plain[i] = v & PLAIN[i].1;
                }
            }
        }
        let now = self.now;
        self.settle(now);
    }

    fn advance(&mut self, now: Time, _clocks: &Clocks) {
        while let Some(t) = self.next_ready().filter(|t| *t <= now) {
            for osc in OSCS {
                let i = osc.index();
                if self.ready_at[i] == Some(t) {
                    self.ready_at[i] = None;
                    self.ready[i] = true;
                    if self.cir & (osc.cir_flag() << 8) != 0 {
                        self.cir |= osc.cir_flag();
                    }
                }
            }
            self.settle(t);
        }
        self.now = self.now.max(now);
    }

    fn next_event(&self, now: Time, _clocks: &Clocks) -> Option<Time> {
        self.next_ready().map(|t| t.max(now))
    }
}

impl IrqLines for Rcc {
    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        line(RCC_IRQ, self.cir & (self.cir >> 8) & 0x7F != 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HSE_HZ: u32 = 8_000_000;

    fn at(rcc: &mut Rcc, t: Time) {
        rcc.advance(t, &Clocks::RESET);
    }

    fn rd(rcc: &mut Rcc, o: u32) -> u32 {
        rcc.read(o, Size::Word)
    }

    fn wr(rcc: &mut Rcc, o: u32, v: u32) {
        rcc.write(o, Size::Word, v);
    }

    fn md(p: &mut Rcc, o: u32, f: impl Fn(u32) -> u32) {
        let v = p.read(o, Size::Word);
        p.write(o, Size::Word, f(v));
    }

    #[test]
    fn reset_values_are_rm0390s() {
        let mut r = Rcc::new(HSE_HZ);
        assert_eq!(rd(&mut r, reg::CR), 0x0000_0083);
        assert_eq!(rd(&mut r, reg::PLLCFGR), 0x2400_3010);
        assert_eq!(rd(&mut r, reg::CFGR), 0);
        assert_eq!(rd(&mut r, reg::AHB1ENR), 0x0010_0000);
        assert_eq!(rd(&mut r, reg::AHB1LPENR), 0x6067_90FF);
        assert_eq!(rd(&mut r, reg::AHB2LPENR), 0x81);
        assert_eq!(rd(&mut r, reg::AHB3LPENR), 0x3);
        assert_eq!(rd(&mut r, reg::APB1LPENR), 0x3FFF_C9FF);
        assert_eq!(rd(&mut r, reg::APB2LPENR), 0x00C7_7F33);
        assert_eq!(rd(&mut r, reg::CSR), 0x0E00_0000);
        assert_eq!(rd(&mut r, reg::PLLI2SCFGR), 0x2400_3010);
        assert_eq!(rd(&mut r, reg::PLLSAICFGR), 0x0400_3010);
        for o in [
            reg::BDCR,
            reg::SSCGR,
            reg::DCKCFGR,
            reg::CKGATENR,
            reg::DCKCFGR2,
        ] {
            assert_eq!(rd(&mut r, o), 0, "{o:#x}");
        }
        assert_eq!(r.clocks(), Clocks::RESET);
    }

    /// Embassy's F4 sequence for the board's 180 MHz (pins.rs): HSE bypass on, PLL M4 N180
    /// P2 from the HSE, switch with AHB /1, APB1 /4, APB2 /2.
    #[test]
    fn the_boards_clock_setup_gives_180_mhz_after_the_handshakes() {
        let mut r = Rcc::new(HSE_HZ);
        at(&mut r, 1_000);
        md(&mut r, reg::CR, |v| v | cr::HSEBYP);
        md(&mut r, reg::CR, |v| v | cr::HSEON);
        assert_eq!(rd(&mut r, reg::CR) & cr::HSERDY, 0, "not ready at once");
        assert_eq!(
            r.next_event(1_000, &Clocks::RESET),
            Some(1_000 + HSE_BYPASS_STARTUP)
        );
        at(&mut r, 1_000 + HSE_BYPASS_STARTUP);
        assert_ne!(rd(&mut r, reg::CR) & cr::HSERDY, 0);
        let t = 1_000 + HSE_BYPASS_STARTUP;
        // PLL: M=4, N=180, P=/2 (00), Q=2, source HSE.
        wr(&mut r, reg::PLLCFGR, 4 | (180 << 6) | (1 << 22) | (2 << 24));
        md(&mut r, reg::CR, |v| v | cr::PLLON);
        at(&mut r, t + PLL_LOCK - 1);
        assert_eq!(rd(&mut r, reg::CR) & cr::PLLRDY, 0);
        at(&mut r, t + PLL_LOCK);
        assert_ne!(rd(&mut r, reg::CR) & cr::PLLRDY, 0);
        wr(&mut r, reg::CFGR, 2 | (0b101 << 10) | (0b100 << 13));
        assert_eq!(
            (rd(&mut r, reg::CFGR) >> 2) & 3,
            2,
            "SWS follows a ready source"
        );
        let c = r.clocks();
        assert_eq!(c.sysclk_hz, 180_000_000);
        assert_eq!(c.hclk_hz, 180_000_000);
        assert_eq!(c.pclk1_hz, 45_000_000);
        assert_eq!(c.pclk2_hz, 90_000_000);
        assert_eq!(c.tim_apb1_hz, 90_000_000);
        assert_eq!(c.tim_apb2_hz, 180_000_000);
        // Turning off the HSE (the PLL's input, in use) or the PLL is refused.
        md(&mut r, reg::CR, |v| {
            v & !(cr::PLLON | cr::HSEON | cr::HSION)
        });
        let v = rd(&mut r, reg::CR);
        assert_eq!(v & (cr::PLLRDY | cr::HSERDY), cr::PLLRDY | cr::HSERDY);
        assert_eq!(v & cr::HSION, 0, "the HSI is free to stop");
        // TIMPRE: APB1 /4 → timers at HCLK.
        wr(&mut r, reg::DCKCFGR, TIMPRE);
        assert_eq!(r.clocks().tim_apb1_hz, 180_000_000);
    }

    #[test]
    fn the_switch_waits_for_its_source_and_hsebyp_is_fixed_while_on() {
        let mut r = Rcc::new(HSE_HZ);
        wr(&mut r, reg::CFGR, 1);
        assert_eq!(rd(&mut r, reg::CFGR), 1, "SWS still HSI: HSE off");
        wr(&mut r, reg::CR, cr::HSION | cr::HSEON);
        at(&mut r, HSE_CRYSTAL_STARTUP - 1);
        assert_eq!(rd(&mut r, reg::CFGR), 1);
        at(&mut r, HSE_CRYSTAL_STARTUP);
        assert_eq!(rd(&mut r, reg::CFGR), 1 | (1 << 2));
        assert_eq!(r.clocks().sysclk_hz, HSE_HZ);
        wr(&mut r, reg::CR, cr::HSION | cr::HSEON | cr::HSEBYP);
        assert_eq!(rd(&mut r, reg::CR) & cr::HSEBYP, 0);
        // The PLL off: its ready clears at once.
        wr(&mut r, reg::CR, cr::HSION | cr::HSEON | cr::PLLON);
        at(&mut r, HSE_CRYSTAL_STARTUP + PLL_LOCK);
        assert_ne!(rd(&mut r, reg::CR) & cr::PLLRDY, 0);
        wr(&mut r, reg::CR, cr::HSION | cr::HSEON);
        assert_eq!(rd(&mut r, reg::CR) & (cr::PLLRDY | cr::PLLON), 0);
    }

    #[test]
    fn ready_interrupt_flags_set_only_when_enabled_and_clear_by_their_c_bits() {
        let mut r = Rcc::new(HSE_HZ);
        let mut level = false;
        wr(&mut r, reg::CIR, 1 << (8 + 3)); // HSERDYIE
        wr(
            &mut r,
            reg::CR,
            cr::HSION | cr::HSEON | cr::HSEBYP | cr::PLLON,
        );
        at(&mut r, HSE_BYPASS_STARTUP + PLL_LOCK);
        // The PLL's input is the HSI (PLLSRC 0): it locked, but PLLRDYIE was clear.
        assert_eq!(rd(&mut r, reg::CIR) & 0xFF, 1 << 3);
        r.irqs(&mut |irq, high| {
            assert_eq!(irq, RCC_IRQ);
            level = high;
        });
        assert!(level);
        wr(&mut r, reg::CIR, (1 << (8 + 3)) | (1 << (16 + 3)));
        assert_eq!(rd(&mut r, reg::CIR), 1 << 11);
        r.irqs(&mut |_, high| level = high);
        assert!(!level);
    }

    #[test]
    fn reset_flags_accumulate_over_resets_until_rmvf() {
        let mut r = Rcc::new(HSE_HZ);
        wr(&mut r, reg::CSR, csr::RMVF);
        assert_eq!(rd(&mut r, reg::CSR), 0);
        wr(&mut r, reg::APB1ENR, 1 << 28);
        r.reset(ResetCause::IndependentWatchdog);
        assert_eq!(rd(&mut r, reg::CSR), csr::IWDGRSTF | csr::PINRSTF);
        assert_eq!(rd(&mut r, reg::APB1ENR), 0, "registers reset");
        r.reset(ResetCause::Software);
        assert_eq!(
            rd(&mut r, reg::CSR),
            csr::IWDGRSTF | csr::SFTRSTF | csr::PINRSTF
        );
        r.reset(ResetCause::PowerUp);
        assert_eq!(r.reset_flags(), 0x0E00_0000);
        wr(&mut r, reg::CSR, csr::RMVF);
        r.reset(ResetCause::Pin);
        assert_eq!(r.reset_flags(), csr::PINRSTF);
        // The flags are read-only.
        wr(&mut r, reg::CSR, csr::FLAGS & !csr::RMVF);
        assert_eq!(r.reset_flags(), csr::PINRSTF);
    }

    #[test]
    fn lsi_starts_and_the_backup_domain_needs_dbp_and_survives_a_system_reset() {
        let mut r = Rcc::new(HSE_HZ);
        wr(&mut r, reg::CSR, csr::LSION);
        assert_eq!(rd(&mut r, reg::CSR) & 3, 1);
        at(&mut r, LSI_STARTUP);
        assert_eq!(rd(&mut r, reg::CSR) & 3, 3);
        wr(&mut r, reg::BDCR, (1 << 15) | (2 << 8));
        assert_eq!(rd(&mut r, reg::BDCR), 0, "DBP clear: write-protected");
        r.set_backup_access(true);
        wr(&mut r, reg::BDCR, (1 << 15) | (2 << 8));
        assert_eq!(rd(&mut r, reg::BDCR), (1 << 15) | (2 << 8));
        r.reset(ResetCause::Software);
        assert_eq!(rd(&mut r, reg::BDCR), (1 << 15) | (2 << 8));
        assert_eq!(rd(&mut r, reg::CSR) & 3, 0, "LSION reset by a system reset");
        r.reset(ResetCause::PowerUp);
        assert_eq!(rd(&mut r, reg::BDCR), 0);
    }

    #[test]
    fn byte_writes_and_reads_take_their_lanes() {
        let mut r = Rcc::new(HSE_HZ);
        r.write(reg::APB1ENR + 2, Size::Byte, 0x02); // USART2EN (bit 17)
        assert_eq!(rd(&mut r, reg::APB1ENR), 1 << 17);
        assert_eq!(r.read(reg::PLLCFGR + 3, Size::Byte), 0x24);
        // Unimplemented bits of an enable register stay 0.
        wr(&mut r, reg::APB2ENR, 0xFFFF_FFFF);
        assert_eq!(rd(&mut r, reg::APB2ENR), 0x00C7_7F33);
    }
}
