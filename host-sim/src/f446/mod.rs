//! The emulated STM32F446: what the board's unmodified ELF (`thermorph-board`) runs on in
//! `host-sim run SCENE --board ELF` (issue 42).
//!
//! This folder owns the chip's peripherals as register-level models written from RM0390 (the
//! STM32F446 reference manual), one file each, each with unit tests against the manual's
//! register behaviour. They are plain Rust, MIT OR Apache-2.0 like the rest of the project,
//! and build (and test) in the default build. The CPU core that runs the ELF's instructions is
//! not here: it is unicorn (GPL-2.0), linked only with `--features pil`, out of the default
//! build and of the firmware.
//!
//! The models share one shape ([`Peripheral`]): a register window read and written at the
//! present time, advanced in the chip's time ([`Time`]) with the bus clocks the RCC's
//! configuration gives ([`Clocks`]), the time of its next change of its own accord (so the
//! emulator can skip time while the core sleeps at `wfe`), the levels of its interrupt lines
//! ([`IrqLines`]) and its DMA requests ([`DmaRequests`]). What connects them — the address
//! map, the DMA streams' requests, the button's pin to EXTI, the watchdog's reset — is the
//! chip's own wiring, in one place (the chip, `f446::soc`), not in the models.

pub mod adc;
#[cfg(feature = "pil")]
pub mod cpu;
pub mod dma;
pub mod elf;
pub mod exti;
pub mod flash;
pub mod gpio;
pub mod i2c;
pub mod iwdg;
pub mod mlx_target;
pub mod nvic;
pub mod pwr;
pub mod rcc;
pub mod rtt;
pub mod soc;
pub mod syscfg;
pub mod tim;
pub mod usart;

/// The flash's base address.
pub const FLASH_BASE: u32 = 0x0800_0000;
/// The flash's size, bytes.
pub const FLASH_BYTES: u32 = 512 * 1024;
/// SRAM's base address.
pub const SRAM_BASE: u32 = 0x2000_0000;
/// SRAM's size (SRAM1 112 KiB and SRAM2 16 KiB, contiguous), bytes.
pub const SRAM_BYTES: u32 = 128 * 1024;

/// Time on the emulated chip since power-up, in ticks of [`TIME_HZ`]: every clock the board
/// uses (16 and 180 MHz, the buses' 45 and 90 MHz, the time driver's 1 MHz, I2C's 400 kHz,
/// 115 200 baud, the LSI's 32 kHz) is a whole number of them, so no conversion drifts.
pub type Time = u64;

/// The time base, Hz (720 MHz: a u64 of it lasts 800 years).
pub const TIME_HZ: u64 = 720_000_000;

/// An access's width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// 8 bits.
    Byte,
    /// 16 bits.
    Half,
    /// 32 bits.
    Word,
}

impl Size {
    /// The width in bytes.
    pub const fn bytes(self) -> u32 {
        match self {
            Size::Byte => 1,
            Size::Half => 2,
            Size::Word => 4,
        }
    }

    /// The width of a `bytes`-byte access (None: not 1, 2 or 4).
    pub const fn of(bytes: u32) -> Option<Size> {
        match bytes {
            1 => Some(Size::Byte),
            2 => Some(Size::Half),
            4 => Some(Size::Word),
            _ => None,
        }
    }
}

/// The clocks the RCC's configuration gives, Hz: what the timers, the USART, the I2C and the
/// watchdog count with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clocks {
    /// The system clock (the core's), Hz.
    pub sysclk_hz: u32,
    /// AHB (HCLK), Hz.
    pub hclk_hz: u32,
    /// APB1 (PCLK1: USART2, I2C1), Hz.
    pub pclk1_hz: u32,
    /// APB2 (PCLK2: ADC1, SYSCFG), Hz.
    pub pclk2_hz: u32,
    /// The APB1 timers' clock (TIM2–7, 12–14), Hz: PCLK1, doubled when APB1 is divided.
    pub tim_apb1_hz: u32,
    /// The APB2 timers' clock (TIM1, 8–11), Hz.
    pub tim_apb2_hz: u32,
    /// The LSI (the independent watchdog's), Hz.
    pub lsi_hz: u32,
}

impl Clocks {
    /// After reset: everything on the 16 MHz HSI, no prescaler; the LSI at its 32 kHz.
    pub const RESET: Clocks = Clocks {
        sysclk_hz: 16_000_000,
        hclk_hz: 16_000_000,
        pclk1_hz: 16_000_000,
        pclk2_hz: 16_000_000,
        tim_apb1_hz: 16_000_000,
        tim_apb2_hz: 16_000_000,
        lsi_hz: 32_000,
    };

    /// The whole ticks of a clock at `hz` in `time` (rounded down).
    pub fn ticks(time: Time, hz: u32) -> u64 {
        (u128::from(time) * u128::from(hz) / u128::from(TIME_HZ)) as u64
    }

    /// The time of `ticks` of a clock at `hz` (rounded up: the first instant at or after).
    pub fn time_of(ticks: u64, hz: u32) -> Time {
        let hz = u128::from(hz.max(1));
        ((u128::from(ticks) * u128::from(TIME_HZ)).div_ceil(hz)) as Time
    }

    /// The time `cycles` of the core take at the present system clock.
    pub fn core_time(&self, cycles: u64) -> Time {
        Self::time_of(cycles, self.sysclk_hz)
    }
}

/// A peripheral's interrupt lines and their levels (an NVIC input is pending while its line
/// is high, as on the chip: a peripheral's flags hold its line until software clears them).
pub trait IrqLines {
    /// Report each line this peripheral drives with its level: `line(irq, high)`, `irq` the
    /// NVIC's position (RM0390 table 38).
    fn irqs(&self, line: &mut dyn FnMut(u16, bool));
}

/// What a peripheral asks of its DMA streams now (RM0390 §9.3.3): a request held while its
/// flag and its DMA enable are set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DmaRequests {
    /// A byte (or word) to read from its data register.
    pub rx: bool,
    /// Room for one in its data register.
    pub tx: bool,
}

/// A memory-mapped peripheral: its register window, read and written at the present time.
///
/// The caller advances it ([`Peripheral::advance`]) to the present before each access and
/// each time the core runs on; a register read may have side effects (a status flag cleared
/// by the read, a data register emptied), as on the chip.
pub trait Peripheral {
    /// The peripheral's name as RM0390 gives it (`"RCC"`, `"I2C1"`), for the log.
    fn name(&self) -> &'static str;

    /// A read of `size` at `offset` from the window's base.
    fn read(&mut self, offset: u32, size: Size) -> u32;

    /// A write of `value` (`size` wide, in its low bits) at `offset` from the window's base.
    fn write(&mut self, offset: u32, size: Size, value: u32);

    /// Advance to `now` with `clocks` (the default: nothing moves by itself).
    fn advance(&mut self, now: Time, clocks: &Clocks) {
        let _ = (now, clocks);
    }

    /// The next time after `now` it changes of its own accord (a counter's update, a byte
    /// shifted out), or None: nothing until software acts.
    fn next_event(&self, now: Time, clocks: &Clocks) -> Option<Time> {
        let _ = (now, clocks);
        None
    }
}

/// The emulated chip's memories as its bus masters (the core, the DMA streams) reach them:
/// SRAM, and the flash's array for reading.
pub trait Memory {
    /// Read `buf.len()` bytes at `addr` (false: nothing there).
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> bool;
    /// Write `bytes` at `addr` (false: nothing writable there).
    fn write(&mut self, addr: u32, bytes: &[u8]) -> bool;
}

/// The chip's peripherals as the core sees them: the address map's registers, time, the
/// clocks and the interrupt lines. The chip (`f446::soc`) implements it over the models; the
/// CPU core (unicorn, `--features pil`) drives it.
pub trait Bus: std::any::Any {
    /// A read of `size` at `addr` at time `now` (None: no peripheral there, a bus fault).
    fn read(&mut self, addr: u32, size: Size, now: Time, mem: &mut dyn Memory) -> Option<u32>;
    /// A write at time `now` (false: no peripheral there, a bus fault). Writes to the flash's
    /// address range come here too (programming it, through its interface).
    fn write(&mut self, addr: u32, size: Size, value: u32, now: Time, mem: &mut dyn Memory)
    -> bool;
    /// Advance every peripheral to `now` (DMA transfers reach `mem`).
    fn advance(&mut self, now: Time, mem: &mut dyn Memory);
    /// The next instant after `now` at which a peripheral changes of its own accord.
    fn next_event(&self, now: Time) -> Option<Time>;
    /// While the core sleeps: run the bus's own events from `now` on, before `until` and
    /// before any other peripheral's event, as long as no interrupt line changes; return the
    /// time reached (`now`: nothing skipped). Only what those events touch is advanced (every
    /// other model stands still until its own next event, after the time returned). A bus
    /// with nothing to skip leaves this as it is.
    fn skip(&mut self, now: Time, until: Time, mem: &mut dyn Memory) -> Time {
        let _ = (until, mem);
        now
    }
    /// The clocks in force.
    fn clocks(&self) -> Clocks;
    /// Each external interrupt line's level: `line(irq, high)`.
    fn irqs(&self, line: &mut dyn FnMut(u16, bool));
    /// The levels of the lines a write at `addr` may have changed (at least those; a bus
    /// that cannot tell gives them all).
    fn irqs_after_write(&self, addr: u32, line: &mut dyn FnMut(u16, bool)) {
        let _ = addr;
        self.irqs(line);
    }
    /// Whether the chip asks for a system reset of its own (a watchdog), taken; its
    /// peripherals have been reset for it.
    fn take_reset(&mut self) -> bool;
    /// A software reset (AIRCR.SYSRESETREQ): reset the peripherals for it.
    fn software_reset(&mut self);
}

/// The bits of `value` (a write of `size` at `offset`) merged into the 32-bit register at
/// `offset & !3`, whose present value is `old`: a byte or half-word write changes only its
/// lanes (the chip's APB peripherals take narrower writes as the lanes written).
pub fn merge(old: u32, offset: u32, size: Size, value: u32) -> u32 {
    let shift = (offset & 3) * 8;
    let mask = match size {
        Size::Byte => 0xFF,
        Size::Half => 0xFFFF,
        Size::Word => 0xFFFF_FFFF,
    } << shift;
    (old & !mask) | ((value << shift) & mask)
}

/// The lanes of the 32-bit register `word` that a read of `size` at `offset` sees.
pub fn lanes(word: u32, offset: u32, size: Size) -> u32 {
    let shift = (offset & 3) * 8;
    let v = word >> shift;
    match size {
        Size::Byte => v & 0xFF,
        Size::Half => v & 0xFFFF,
        Size::Word => v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn narrow_writes_change_their_lanes_only() {
        assert_eq!(merge(0x1122_3344, 1, Size::Byte, 0xAB), 0x1122_AB44);
        assert_eq!(merge(0x1122_3344, 2, Size::Half, 0xBEEF), 0xBEEF_3344);
        assert_eq!(merge(0x1122_3344, 0, Size::Word, 0xCAFE_F00D), 0xCAFE_F00D);
        assert_eq!(lanes(0x1122_3344, 3, Size::Byte), 0x11);
        assert_eq!(lanes(0x1122_3344, 2, Size::Half), 0x1122);
    }

    #[test]
    fn times_and_ticks_convert_both_ways() {
        // 1 MHz (the time driver's tick) is 720 time units; 180 core cycles at 180 MHz.
        assert_eq!(Clocks::ticks(720, 1_000_000), 1);
        assert_eq!(Clocks::ticks(719, 1_000_000), 0);
        assert_eq!(Clocks::time_of(1, 1_000_000), 720);
        let c = Clocks {
            sysclk_hz: 180_000_000,
            ..Clocks::RESET
        };
        assert_eq!(c.core_time(180), 720);
        // Every clock the board uses divides the time base.
        for hz in [
            16_000_000u64,
            180_000_000,
            90_000_000,
            45_000_000,
            400_000,
            115_200,
            32_000,
        ] {
            assert_eq!(TIME_HZ % hz, 0, "{hz}");
        }
    }
}
