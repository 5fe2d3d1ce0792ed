//! The emulated STM32F446's wiring: the address map (RM0390 table 1) from addresses to the
//! peripheral models, the DMA streams' requests (RM0390 tables 28–29), the GPIO pins to EXTI
//! through SYSCFG, the PLL to the PWR's voltage scaling, the flash array to the core's memory,
//! and every interrupt line to the NVIC — the one place that knows how the models connect
//! ([`Soc`], the core's [`Bus`]).
//!
//! Peripherals the board touches without depending on them (the DBGMCU's freeze bits, the
//! RTC and backup registers, the CRC unit) are kept as plain registers that read back what
//! was written, and listed in [`PLAIN`]; an address outside every window is a bus fault.

use std::cell::RefCell;
use std::rc::Rc;

use super::adc::{ADC1_BASE, Adc};
use super::dma::{BusFault, Controller, Dma, DmaBus, Serviced};
use super::exti::Exti;
use super::flash::Flash;
use super::gpio::{Drive, Gpio};
use super::i2c::{I2C1_BASE, I2c};
use super::iwdg::Iwdg;
use super::mlx_target::MlxTarget;
use super::pwr::Pwr;
use super::rcc::{Rcc, ResetCause};
use super::syscfg::Syscfg;
use super::tim::{TIM2, TIM3, TIM4, TIM5, TIM12, Tim};
use super::usart::{USART2, Usart};
use crate::sensor::sim_time::SimClock;
use crate::sensor::virtual_mlx::VirtualMlx90640;

use super::{
    Bus, Clocks, FLASH_BASE, FLASH_BYTES, IrqLines, Memory, Peripheral, SRAM_BASE, SRAM_BYTES,
    Size, Time,
};

/// The NUCLEO-F446RE's HSE: the ST-LINK's 8 MHz MCO, bypass.
pub const NUCLEO_HSE_HZ: u32 = 8_000_000;

/// Windows kept as plain registers: `(base, length, name)`.
pub const PLAIN: [(u32, u32, &str); 5] = [
    (0x4000_2800, 0x400, "RTC and backup registers"),
    (0x4000_2C00, 0x400, "WWDG"),
    (0x4002_3000, 0x400, "CRC"),
    (0x4002_4000, 0x1000, "backup SRAM"),
    (0xE004_2000, 0x400, "DBGMCU"),
];

/// The timers' instances in [`Soc::tims`]: TIM2, TIM3, TIM4, TIM5, TIM12.
pub const TIMERS: [u32; 5] = [
    0x4000_0000,
    0x4000_0400,
    0x4000_0800,
    0x4000_0C00,
    0x4000_1800,
];

/// The chip's peripherals.
pub struct Soc {
    /// Reset and clock control.
    pub rcc: Rcc,
    /// Power control.
    pub pwr: Pwr,
    /// The flash interface and its array.
    pub flash: Flash,
    /// GPIOA–GPIOH.
    pub gpio: [Gpio; 8],
    /// SYSCFG (the EXTI port selection).
    pub syscfg: Syscfg,
    /// EXTI.
    pub exti: Exti,
    /// The independent watchdog.
    pub iwdg: Iwdg,
    /// TIM2, TIM3, TIM4, TIM5 and TIM12 ([`TIMERS`]).
    pub tims: [Tim; 5],
    /// USART2 (the console).
    pub usart2: Usart,
    /// I2C1 (the camera).
    pub i2c1: I2c,
    /// DMA1 and DMA2.
    pub dma: [Dma; 2],
    /// ADC1 (the spring channels).
    pub adc1: Adc,
    /// The plain windows' registers: `(address, value)`.
    plain: Vec<(u32, u32)>,
    /// The flash's busy state at the last advance (its end rewrites the core's copy).
    flash_busy: bool,
    /// A reset the chip asks for (the watchdog).
    reset: Option<ResetCause>,
    /// The clock of the sensor on I2C1, kept at the chip's time.
    sensor_clock: Option<SimClock>,
    /// The spring channels' analog inputs for each state of the spring gates and the power
    /// enable ([`Soc::set_spring_analog`]).
    spring_analog: Option<Box<[[f64; 6]; 16]>>,
    /// The instant the models were last advanced to.
    advanced: Option<Time>,
    /// The ADC's last conversion end, and the shortest time between two seen.
    adc_last: Option<Time>,
    adc_period: Option<Time>,
    /// Interrupt lines held low whatever their peripheral says (a stall made in the
    /// emulator: [`Soc::suppress_irq`]); cleared by a chip reset.
    suppressed: Vec<u16>,
    /// The RCC's clocks, found again after every advance and write (asked for at every
    /// slice and sleep of the core).
    clocks: std::cell::Cell<Option<Clocks>>,
}

impl Default for Soc {
    fn default() -> Self {
        Self::new()
    }
}

impl Soc {
    /// The chip at power-up on the NUCLEO (HSE 8 MHz bypass), the flash erased.
    pub fn new() -> Soc {
        Soc {
            rcc: Rcc::new(NUCLEO_HSE_HZ),
            pwr: Pwr::new(),
            flash: Flash::new(),
            gpio: core::array::from_fn(Gpio::new),
            syscfg: Syscfg::new(),
            exti: Exti::new(),
            iwdg: Iwdg::new(),
            tims: [TIM2, TIM3, TIM4, TIM5, TIM12].map(Tim::new),
            usart2: Usart::new(USART2),
            i2c1: I2c::new(),
            dma: [Dma::new(Controller::Dma1), Dma::new(Controller::Dma2)],
            adc1: Adc::new(),
            plain: Vec::new(),
            flash_busy: false,
            reset: None,
            sensor_clock: None,
            spring_analog: None,
            advanced: None,
            adc_last: None,
            adc_period: None,
            suppressed: Vec::new(),
            clocks: std::cell::Cell::new(None),
        }
    }

    /// The spring channels' analog inputs (volts at PA0, PA1, PA4, PB0, PC1, PC0: ADC1 IN0,
    /// IN1, IN4, IN8, IN11, IN10) for each state of the gates PA8, PB5, PB10 (bits 0–2) and
    /// the power enable PA9 (bit 3): the ADC converts the row of the pins' state at each
    /// conversion, so a gate's switch reaches the channels at once, as the circuit's does.
    pub fn set_spring_analog(&mut self, table: Box<[[f64; 6]; 16]>) {
        self.spring_analog = Some(table);
    }

    /// The spring gates' and the power enable's state as [`Soc::set_spring_analog`] indexes
    /// it.
    pub fn spring_pins(&self) -> usize {
        let out = |port: usize, pin: usize| usize::from(self.gpio[port].output(pin) == Some(true));
        out(0, 8) | out(1, 5) << 1 | out(1, 10) << 2 | out(0, 9) << 3
    }

    /// Hold interrupt line `irq` low until the next chip reset: what a stalled interrupt
    /// source does to the firmware (TIM12's, 43, stops embassy's time: every timer wait, the
    /// control loop's tick among them), made in the emulator, not in the firmware.
    pub fn suppress_irq(&mut self, irq: u16) {
        self.suppressed.push(irq);
    }

    /// Put the virtual MLX90640 `device` (built on `clock`) on I2C1, at the chip's time, with
    /// the bus's pull-ups: SCL (PB8) and SDA (PB9) read high wherever no one drives them low,
    /// as the sensor's board pulls them up (a bus recovery clocks SCL and reads SDA through
    /// GPIO: without them a released line would read low, and every recovery "bus stuck").
    pub fn attach_sensor(&mut self, device: Rc<RefCell<VirtualMlx90640>>, clock: SimClock) {
        self.i2c1
            .attach(Box::new(MlxTarget::new(device, clock.clone())));
        self.sensor_clock = Some(clock);
        for pin in [8, 9] {
            self.gpio[1].set_input(pin, Drive::High);
        }
    }

    /// A reset of the chip for `cause`: every peripheral to its reset state (the RCC keeps its
    /// reset flags, as RM0390 §6.3.21 says; the flash keeps its array; the outside drives of
    /// the pins stay).
    pub fn chip_reset(&mut self, cause: ResetCause) {
        self.rcc.reset(cause);
        self.pwr.reset();
        self.flash.reset();
        for g in &mut self.gpio {
            g.reset();
        }
        self.syscfg.reset();
        self.exti.reset();
        self.iwdg.reset();
        for t in &mut self.tims {
            t.reset();
        }
        self.usart2.reset();
        self.i2c1.rcc_reset();
        for d in &mut self.dma {
            d.rcc_reset();
        }
        self.adc1.rcc_reset();
        self.plain.clear();
        self.reset = None;
        self.adc_last = None;
        self.adc_period = None;
        self.suppressed.clear();
        self.clocks.set(None);
    }

    /// The reset the chip asks for (the independent watchdog expired), taken.
    pub fn take_reset(&mut self) -> Option<ResetCause> {
        self.reset.take()
    }

    /// The model at `addr`, with the offset into its window.
    fn at(&mut self, addr: u32) -> Option<(&mut dyn Peripheral, u32)> {
        let (base, p): (u32, &mut dyn Peripheral) = match addr {
            0x4000_0000..=0x4000_0FFF => {
                let i = ((addr - 0x4000_0000) / 0x400) as usize;
                (TIMERS[i], &mut self.tims[i])
            }
            0x4000_1800..=0x4000_1BFF => (0x4000_1800, &mut self.tims[4]),
            0x4000_3000..=0x4000_33FF => (0x4000_3000, &mut self.iwdg),
            0x4000_4400..=0x4000_47FF => (0x4000_4400, &mut self.usart2),
            0x4000_5400..=0x4000_57FF => (I2C1_BASE, &mut self.i2c1),
            0x4000_7000..=0x4000_73FF => (0x4000_7000, &mut self.pwr),
            0x4001_2000..=0x4001_23FF => (ADC1_BASE, &mut self.adc1),
            0x4001_3800..=0x4001_3BFF => (0x4001_3800, &mut self.syscfg),
            0x4001_3C00..=0x4001_3FFF => (0x4001_3C00, &mut self.exti),
            0x4002_0000..=0x4002_1FFF => {
                let i = ((addr - 0x4002_0000) / 0x400) as usize;
                (0x4002_0000 + 0x400 * i as u32, &mut self.gpio[i])
            }
            0x4002_3800..=0x4002_3BFF => (0x4002_3800, &mut self.rcc),
            0x4002_3C00..=0x4002_3FFF => (0x4002_3C00, &mut self.flash),
            0x4002_6000..=0x4002_63FF => (0x4002_6000, &mut self.dma[0]),
            0x4002_6400..=0x4002_67FF => (0x4002_6400, &mut self.dma[1]),
            _ => return None,
        };
        Some((p, addr - base))
    }

    fn plain_window(addr: u32) -> bool {
        PLAIN
            .iter()
            .any(|&(b, len, _)| (b..b + len).contains(&addr))
    }

    fn plain_read(&self, addr: u32, size: Size) -> u32 {
        let word = self
            .plain
            .iter()
            .find(|(a, _)| *a == addr & !3)
            .map_or(0, |(_, v)| *v);
        super::lanes(word, addr, size)
    }

    fn plain_write(&mut self, addr: u32, size: Size, value: u32) {
        let old = self.plain_read(addr & !3, Size::Word);
        let v = super::merge(old, addr, size, value);
        match self.plain.iter_mut().find(|(a, _)| *a == addr & !3) {
            Some(e) => e.1 = v,
            None => self.plain.push((addr & !3, v)),
        }
    }

    /// Serve every DMA request now active (RM0390 tables 28–29: DMA1 streams 0/5 and 6/7
    /// channel 1 are I2C1's RX and TX; streams 5 and 6 channel 4 USART2's; DMA2 streams 0/4
    /// channel 0 ADC1's).
    fn serve_dma(&mut self, mem: &mut dyn Memory) {
        self.serve_dma_of(0..2, mem);
    }

    /// [`Soc::serve_dma`] for the controllers in `controllers` (0 DMA1, 1 DMA2).
    fn serve_dma_of(&mut self, controllers: std::ops::Range<usize>, mem: &mut dyn Memory) {
        for c in controllers {
            for s in 0..8 {
                // At most a buffer's worth a call (a request that stays up is served again at
                // the next advance).
                for _ in 0..64 {
                    if !self.dma[c].enabled(s) {
                        break;
                    }
                    let ch = self.dma[c].channel(s);
                    let wanted = match (c, s, ch) {
                        (0, 0 | 5, 1) => self.i2c1.requests().rx,
                        (0, 6 | 7, 1) => self.i2c1.requests().tx,
                        (0, 5, 4) => self.usart2.dma_requests().rx,
                        (0, 6, 4) => self.usart2.dma_requests().tx,
                        (1, 0 | 4, 0) => self.adc1.requests().rx,
                        _ => self.dma[c].memory_to_memory_pending(s),
                    };
                    if !wanted {
                        break;
                    }
                    let mut bus = ChipBus {
                        i2c1: &mut self.i2c1,
                        adc1: &mut self.adc1,
                        usart2: &mut self.usart2,
                        mem,
                    };
                    match self.dma[c].service(s, &mut bus) {
                        Serviced::Moved { remaining } => {
                            if (c, ch) == (0, 1) && remaining == 1 {
                                self.i2c1.dma_eot_1();
                            }
                            if (c, ch) == (1, 0) && remaining == 0 {
                                self.adc1.dma_eot();
                            }
                        }
                        Serviced::Idle | Serviced::Error => break,
                    }
                }
            }
        }
    }

    /// When the core must next look at the ADC: its next conversion's end, or — while DMA2
    /// stream 0 or 4 takes its conversions — no later than halfway to the stream's end (its
    /// half-transfer or transfer-complete flag, which may interrupt), by the shortest
    /// conversion seen.
    fn adc_wake(&self, now: Time, c: &Clocks) -> Option<Time> {
        let next = self.adc1.next_event(now, c)?;
        let fed = [0, 4]
            .into_iter()
            .find(|&st| self.dma[1].enabled(st) && self.dma[1].channel(st) == 0);
        match (fed, self.adc_period) {
            (Some(st), Some(p)) => {
                let left = u64::from(self.dma[1].remaining(st)).max(1);
                Some(next + (left / 2).saturating_sub(1) * p)
            }
            _ => Some(next),
        }
    }

    /// Advance what an access at `addr` sees: a timer or USART2 alone (the most frequent
    /// accesses: embassy's clock, the console's interrupt), I2C1 with DMA1 and the camera
    /// (its transfers), anything else the whole chip. A model left behind keeps its time and
    /// catches up at its next advance (none has an event before the core next looks: the
    /// core's slices end at every event).
    fn advance_for(&mut self, addr: u32, now: Time, mem: &mut dyn Memory) {
        let c = self.clocks();
        match addr {
            0x4000_0000..=0x4000_0FFF => {
                self.tims[((addr - 0x4000_0000) / 0x400) as usize].advance(now, &c)
            }
            0x4000_1800..=0x4000_1BFF => self.tims[4].advance(now, &c),
            0x4000_4400..=0x4000_47FF => self.usart2.advance(now, &c),
            0x4000_5400..=0x4000_57FF | 0x4002_6000..=0x4002_63FF => {
                self.advance_sensor_clock(now);
                self.i2c1.advance(now, &c);
                self.dma[0].advance(now, &c);
                self.serve_dma(mem);
            }
            _ => self.advance(now, mem),
        }
    }

    /// The camera's clock to the chip's time `now`.
    fn advance_sensor_clock(&mut self, now: Time) {
        if let Some(c) = &self.sensor_clock {
            let us = (u128::from(now) * 1_000_000 / u128::from(super::TIME_HZ)) as u64;
            if us > c.now_us() {
                c.advance_us(us - c.now_us());
            }
        }
    }

    /// GPIO edges to EXTI, through SYSCFG's port selection.
    fn route_edges(&mut self) {
        let (mut rising, mut falling) = (0u32, 0u32);
        for port in 0..8 {
            let e = self.gpio[port].take_edges();
            if e.rising | e.falling == 0 {
                continue;
            }
            for line in 0..16 {
                if self.syscfg.exti_port(line) == port {
                    rising |= u32::from(e.rising >> line & 1) << line;
                    falling |= u32::from(e.falling >> line & 1) << line;
                }
            }
        }
        if rising | falling != 0 {
            self.exti.edges(rising, falling);
        }
    }
}

/// The buses as a DMA stream reaches them: the peripherals' data registers and SRAM.
struct ChipBus<'a> {
    i2c1: &'a mut I2c,
    adc1: &'a mut Adc,
    usart2: &'a mut Usart,
    mem: &'a mut dyn Memory,
}

impl ChipBus<'_> {
    fn peripheral(&mut self, address: u32) -> Option<(&mut dyn Peripheral, u32)> {
        match address {
            0x4000_5400..=0x4000_57FF => Some((self.i2c1, address - I2C1_BASE)),
            0x4001_2000..=0x4001_23FF => Some((self.adc1, address - ADC1_BASE)),
            0x4000_4400..=0x4000_47FF => Some((self.usart2, address - 0x4000_4400)),
            _ => None,
        }
    }
}

impl DmaBus for ChipBus<'_> {
    fn read(&mut self, address: u32, size: Size) -> Result<u32, BusFault> {
        if let Some((p, off)) = self.peripheral(address) {
            return Ok(p.read(off, size));
        }
        let mut b = [0u8; 4];
        let n = size.bytes() as usize;
        if in_memory(address) && self.mem.read(address, &mut b[..n]) {
            return Ok(u32::from_le_bytes(b));
        }
        Err(BusFault)
    }

    fn write(&mut self, address: u32, size: Size, value: u32) -> Result<(), BusFault> {
        if let Some((p, off)) = self.peripheral(address) {
            p.write(off, size, value);
            return Ok(());
        }
        let n = size.bytes() as usize;
        if (SRAM_BASE..SRAM_BASE + SRAM_BYTES).contains(&address)
            && self.mem.write(address, &value.to_le_bytes()[..n])
        {
            return Ok(());
        }
        Err(BusFault)
    }
}

fn in_memory(a: u32) -> bool {
    (SRAM_BASE..SRAM_BASE + SRAM_BYTES).contains(&a)
        || (FLASH_BASE..FLASH_BASE + FLASH_BYTES).contains(&a)
}

impl Bus for Soc {
    fn read(&mut self, addr: u32, size: Size, now: Time, mem: &mut dyn Memory) -> Option<u32> {
        self.advance_for(addr, now, mem);
        if let Some((p, off)) = self.at(addr) {
            return Some(p.read(off, size));
        }
        Self::plain_window(addr).then(|| self.plain_read(addr, size))
    }

    fn write(
        &mut self,
        addr: u32,
        size: Size,
        value: u32,
        now: Time,
        mem: &mut dyn Memory,
    ) -> bool {
        self.advance_for(addr, now, mem);
        if (FLASH_BASE..FLASH_BASE + FLASH_BYTES).contains(&addr) {
            self.flash.program(addr, size, value, now);
            let word = addr & !3;
            if let Some(v) = self.flash.read_array(word, Size::Word) {
                mem.write(word, &v.to_le_bytes());
            }
            return self.flash.take_bus_error().is_none();
        }
        if let Some((p, off)) = self.at(addr) {
            p.write(off, size, value);
        } else if Self::plain_window(addr) {
            self.plain_write(addr, size, value);
        } else {
            return false;
        }
        // A write may start a transfer a request already asks for, and changes what the next
        // advance at this instant must see.
        self.serve_dma(mem);
        self.advanced = None;
        if (0x4002_3800..=0x4002_3BFF).contains(&addr) {
            self.clocks.set(None);
        }
        true
    }

    fn advance(&mut self, now: Time, mem: &mut dyn Memory) {
        // Many accesses fall at one instant (a block's are counted at its start): the models
        // stood there already.
        if self.advanced == Some(now) {
            return;
        }
        self.advanced = Some(now);
        let clocks = self.rcc.clocks();
        self.rcc.advance(now, &clocks);
        self.clocks.set(None);
        let pll_on = self.rcc.peek(super::rcc::reg::CR) & (1 << 24) != 0;
        self.pwr.set_pll_on(pll_on);
        self.pwr.advance(now, &clocks);
        self.flash.advance(now, &clocks);
        let busy = self.flash.busy_until().is_some();
        if self.flash_busy && !busy {
            // An erase or a program ended: the core's copy follows the array.
            mem.write(FLASH_BASE, self.flash.array());
        }
        self.flash_busy = busy;
        for g in &mut self.gpio {
            g.advance(now, &clocks);
        }
        self.route_edges();
        self.syscfg.advance(now, &clocks);
        self.exti.advance(now, &clocks);
        self.iwdg.advance(now, &clocks);
        if self.iwdg.expired(now) && self.reset.is_none() {
            self.reset = Some(ResetCause::IndependentWatchdog);
        }
        for t in &mut self.tims {
            t.advance(now, &clocks);
        }
        self.usart2.advance(now, &clocks);
        self.advance_sensor_clock(now);
        self.i2c1.advance(now, &clocks);
        if let Some(table) = &self.spring_analog {
            let row = table[self.spring_pins()];
            for (ch, v) in [0, 1, 4, 8, 11, 10].into_iter().zip(row) {
                self.adc1.set_input_v(ch, v);
            }
        }
        for d in &mut self.dma {
            d.advance(now, &clocks);
        }
        self.serve_dma(mem);
        // The ADC's conversions one by one, each handed to its DMA stream at its end (a scan
        // into a circular buffer needs no core: `next_event` wakes it only near the stream's
        // half and end).
        while let Some(t) = self.adc1.next_event(0, &clocks).filter(|&t| t <= now) {
            self.adc1.advance(t, &clocks);
            self.serve_dma(mem);
            if let Some(last) = self.adc_last.replace(t) {
                let p = t - last;
                self.adc_period = Some(self.adc_period.map_or(p, |q| q.min(p)));
            }
        }
        self.adc1.advance(now, &clocks);
        self.serve_dma(mem);
    }

    fn next_event(&self, now: Time) -> Option<Time> {
        let c = self.clocks();
        let fixed = [
            self.rcc.next_event(now, &c),
            self.pwr.next_event(now, &c),
            self.flash.next_event(now, &c),
            self.syscfg.next_event(now, &c),
            self.iwdg.next_event(now, &c),
            self.usart2.next_event(now, &c),
            self.i2c1.next_event(now, &c),
            self.adc_wake(now, &c),
        ];
        let tims = self.tims.iter().map(|t| t.next_event(now, &c));
        let dma = self.dma.iter().map(|d| d.next_event(now, &c));
        fixed
            .into_iter()
            .chain(tims)
            .chain(dma)
            .flatten()
            .filter(|&t| t > now)
            .min()
    }

    /// The camera's bytes: I2C1's transfer steps and the DMA streams they feed, one after
    /// another, while they raise no interrupt (≈ 13 000 a second of frames that the core,
    /// asleep, need not wake for).
    fn skip(&mut self, now: Time, until: Time, mem: &mut dyn Memory) -> Time {
        let c = self.clocks();
        let others = [
            self.rcc.next_event(now, &c),
            self.pwr.next_event(now, &c),
            self.flash.next_event(now, &c),
            self.syscfg.next_event(now, &c),
            self.iwdg.next_event(now, &c),
            self.usart2.next_event(now, &c),
            self.adc_wake(now, &c),
        ]
        .into_iter()
        .chain(self.tims.iter().map(|t| t.next_event(now, &c)))
        .flatten()
        .filter(|&t| t > now)
        .fold(until, Time::min);
        let lines = |s: &Soc| {
            let mut high = 0u128;
            let mut add = |irq: u16, h: bool| high |= u128::from(h) << (irq % 128);
            s.i2c1.irqs(&mut add);
            s.dma[0].irqs(&mut add);
            high
        };
        let before = lines(self);
        // I2C1's requests go to DMA1 (streams 0/5 and 6/7): DMA2 is not touched here.
        let dma2 = self.dma[1].next_event(now, &c);
        let mut t = now;
        loop {
            let Some(step) = self.i2c1.next_event(t, &c).filter(|&s| s > t) else {
                return t;
            };
            let dma = self.dma[0].next_event(t, &c).into_iter().chain(dma2).min();
            if step >= others || dma.is_some_and(|d| d <= step) {
                return t;
            }
            self.advance_sensor_clock(step);
            self.i2c1.advance(step, &c);
            self.dma[0].advance(step, &c);
            self.serve_dma_of(0..1, mem);
            self.advanced = None;
            t = step;
            if lines(self) != before {
                return t;
            }
        }
    }

    fn clocks(&self) -> Clocks {
        self.clocks.get().unwrap_or_else(|| {
            let c = self.rcc.clocks();
            self.clocks.set(Some(c));
            c
        })
    }

    fn take_reset(&mut self) -> bool {
        match self.reset.take() {
            Some(cause) => {
                self.chip_reset(cause);
                true
            }
            None => false,
        }
    }

    fn software_reset(&mut self) {
        self.chip_reset(ResetCause::Software);
    }

    /// A timer's write changes its own line; USART2's and I2C1's their own and, through the
    /// DMA requests they raise (served at the write), the DMA streams'; anything else may
    /// reach further (GPIO to EXTI, RCC's resets): every line.
    fn irqs_after_write(&self, addr: u32, line: &mut dyn FnMut(u16, bool)) {
        let suppressed = &self.suppressed;
        let line = &mut |irq: u16, high: bool| line(irq, high && !suppressed.contains(&irq));
        match addr {
            0x4000_0000..=0x4000_0FFF => {
                self.tims[((addr - 0x4000_0000) / 0x400) as usize].irqs(line);
            }
            0x4000_1800..=0x4000_1BFF => self.tims[4].irqs(line),
            0x4000_4400..=0x4000_47FF | 0x4000_5400..=0x4000_57FF | 0x4002_6000..=0x4002_67FF => {
                self.usart2.irqs(line);
                self.i2c1.irqs(line);
                for d in &self.dma {
                    d.irqs(line);
                }
            }
            _ => self.irqs(line),
        }
    }

    fn irqs(&self, line: &mut dyn FnMut(u16, bool)) {
        let suppressed = &self.suppressed;
        let line = &mut |irq: u16, high: bool| line(irq, high && !suppressed.contains(&irq));
        self.rcc.irqs(line);
        self.flash.irqs(line);
        self.exti.irqs(line);
        for t in &self.tims {
            t.irqs(line);
        }
        self.usart2.irqs(line);
        self.i2c1.irqs(line);
        for d in &self.dma {
            d.irqs(line);
        }
        self.adc1.irqs(line);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::f446::gpio::reg;

    /// The sensor's bus lines read high when released (its pull-ups), low where the chip drives
    /// them low as open-drain outputs, as a bus recovery sees them.
    #[test]
    fn the_sensor_bus_lines_are_pulled_up() {
        let mut soc = Soc::new();
        let idr = |soc: &mut Soc| (soc.gpio[1].read(reg::IDR, Size::Word) >> 8) & 3;
        // No sensor: floating inputs without a pull read low.
        assert_eq!(idr(&mut soc), 0);
        let words = crate::sensor::eeprom::realistic(1).encode().unwrap();
        let clock = SimClock::new();
        let dev = VirtualMlx90640::new(words, clock.clone(), 1).unwrap();
        soc.attach_sensor(Rc::new(RefCell::new(dev)), clock);
        assert_eq!(idr(&mut soc), 3, "released: both high");
        // PB8 and PB9 open-drain outputs (recovery's GPIO), SDA driven low, SCL released.
        let g = &mut soc.gpio[1];
        g.write(reg::OTYPER, Size::Word, 3 << 8);
        g.write(reg::ODR, Size::Word, 1 << 8);
        g.write(reg::MODER, Size::Word, 0b0101 << 16);
        assert_eq!(idr(&mut soc), 1, "SDA low, SCL high");
        soc.gpio[1].write(reg::ODR, Size::Word, 3 << 8);
        assert_eq!(idr(&mut soc), 3);
        // A chip reset keeps the outside's drives.
        soc.chip_reset(ResetCause::Pin);
        assert_eq!(idr(&mut soc), 3);
    }
}
