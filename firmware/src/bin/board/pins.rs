//! The pin map of the NUCLEO-F446RE (SPEC section 2) — the one file that names pins.
//!
//! | signal | pin | peripheral |
//! |---|---|---|
//! | MLX90640 SCL / SDA | PB8 / PB9 | I2C1, 400 kHz, DMA1 stream 6 (TX) / 0 (RX) |
//! | PI heater gate | PA6 (D12) | TIM3 CH1 PWM, 1 kHz |
//! | fan gate | PB6 (D10) | TIM4 CH1 PWM, 25 kHz |
//! | SMA spring A / B / C | PA8 / PB5 / PB10 (D7 / D4 / D6) | GPIO, active high |
//! | spring power enable | PA9 (D8) | GPIO, active high (low: all three spring channels unpowered) |
//! | spring current A / B / C | PA0 / PA1 / PA4 (A0 / A1 / A2) | ADC1 IN0 / IN1 / IN4 |
//! | spring supply A / B / C | PB0 / PC1 / PC0 (A3 / A4 / A5) | ADC1 IN8 / IN11 / IN10, 20 kΩ / 10 kΩ dividers |
//! | console | PA2 / PA3 | USART2, 115200 8N1 (ST-LINK virtual COM port) |
//! | emergency stop | PC13 | user button B1, EXTI13, active low (level: [`estop_pressed`]) |
//! | status LED | PA5 | LD2 |
//!
//! Every MOSFET gate, and the spring power enable, needs a pull-down of at most 10 kΩ to
//! ground: from reset until [`Board::new`] drives them, these pins are floating inputs, and only
//! the pull-downs keep the loads off. Spring A is not on PB4: that is JTAG NJTRST, pulled *up*
//! inside the chip during and after reset, which would switch the spring on before the firmware
//! runs.
//!
//! The gate pins and the spring power enable are listed once, in [`gate_pins!`]; [`Board::new`]
//! and [`OUTPUTS_OFF`] (the fault handlers' outputs-off program) both expand it, so every fault
//! path drives the spring power enable low with the gates.
//!
//! The spring channels' six analog inputs are listed once, in [`sense_pins!`], in the ADC's scan
//! order (currents A, B, C, then supplies A, B, C: the order of `thermorph::channels::Counts`).
//! ADC1 scans them continuously into a circular DMA buffer ([`SpringInputs`], DMA2 stream 0):
//! 480 sampling cycles an input at 11.25 MHz (PCLK2 / 8), [`SCAN_NS`] a scan. The board's
//! `sense` module drains it every control period.
//!
//! Clocks: HSE 8 MHz bypass (the ST-LINK's MCO), PLL M 4 · N 180 · P 2 → SYSCLK 180 MHz,
//! AHB 180 MHz, APB1 45 MHz, APB2 90 MHz; ADC 11.25 MHz (APB2 / 8).

use embassy_stm32::adc::{self, Adc, AdcChannel, RingBufferedAdc, SampleTime};
use embassy_stm32::exti::{self, ExtiInput};
use embassy_stm32::gpio::{Level, Output, OutputOpenDrain, OutputType, Pull, Speed};
use embassy_stm32::i2c::{self, I2c, Master};
use embassy_stm32::mode::Async;
use embassy_stm32::peripherals;
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::low_level::CountingMode;
use embassy_stm32::timer::simple_pwm::{PwmPin, SimplePwm};
use embassy_stm32::usart::{self, BufferedUart};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{Config, Peri, Peripherals, bind_interrupts, dma, interrupt};
use embassy_time::Timer;
use embedded_hal::i2c::{ErrorType, Operation};
use static_cell::ConstStaticCell;
use thermorph::outputs::{Duty, Outputs, SPRINGS, SpringMask};
use thermorph::sensing::{BusStuck, RecoverBus};

use super::fault::OffProgram;
use super::serial;

/// The gate pins, the one table: `(heater, fan, [spring A, spring B, spring C, spring power
/// enable])` — every pin that switches a load, each off when low. Expands to `$then!(…)` so
/// every place that needs them reads this list.
macro_rules! gate_pins {
    ($then:ident) => {
        $then!(PA6, PB6, [PA8, PB5, PB10, PA9])
    };
}

/// The spring channels' analog inputs, the one table: `([current A, B, C], [supply A, B, C])`,
/// all ADC1 inputs, in scan order. Expands to `$then!(…)`.
macro_rules! sense_pins {
    ($then:ident) => {
        $then!([PA0, PA1, PA4], [PB0, PC1, PC0])
    };
}

bind_interrupts!(struct Irqs {
    I2C1_EV => i2c::EventInterruptHandler<peripherals::I2C1>;
    I2C1_ER => i2c::ErrorInterruptHandler<peripherals::I2C1>;
    DMA1_STREAM6 => dma::InterruptHandler<peripherals::DMA1_CH6>;
    DMA1_STREAM0 => dma::InterruptHandler<peripherals::DMA1_CH0>;
    DMA2_STREAM0 => dma::InterruptHandler<peripherals::DMA2_CH0>;
    // The loss watch runs first, before embassy's handler takes the byte.
    USART2 => serial::RxLossWatch, usart::BufferedInterruptHandler<peripherals::USART2>;
    EXTI15_10 => exti::InterruptHandler<interrupt::typelevel::EXTI15_10>;
});

/// I2C clock for the MLX90640 (the F446's I2C1 is a Fast-mode peripheral: 400 kHz at most).
pub const I2C_HZ: u32 = 400_000;
/// Half a clock period of the bus recovery's bit-banged SCL, µs (100 kHz).
pub const RECOVERY_HALF_PERIOD_US: u64 = 5;
/// Console baud rate.
pub const CONSOLE_BAUD: u32 = 115_200;
/// Heater PWM frequency.
pub const HEATER_PWM_HZ: u32 = 1_000;
/// Fan PWM frequency.
pub const FAN_PWM_HZ: u32 = 25_000;
/// Independent watchdog timeout, µs.
pub const WATCHDOG_TIMEOUT_US: u32 = 500_000;

/// Inputs in one ADC scan: three currents, three supplies.
pub const SENSE_INPUTS: usize = 6;
/// ADC clock, Hz: PCLK2 (90 MHz, [`clocks`]) / 8, the slowest prescaler (the datasheet's range
/// is 0.6-36 MHz).
pub const ADC_HZ: u32 = 11_250_000;
/// Sampling time of every input. The supply dividers' source impedance is 6.7 kΩ (20 k ∥ 10 k);
/// 480 cycles allow over 250 kΩ at 12 bits, so an RC filter at an input costs no accuracy.
const SAMPLE_TIME: SampleTime = SampleTime::CYCLES480;
/// ADC clock cycles of one conversion: 480 sampling, 12 converting.
const CONVERSION_CYCLES: u32 = 480 + 12;
/// One scan of the six inputs, ns (262.4 µs: about 3 800 scans a second, 190 a control period).
pub const SCAN_NS: u32 =
    (SENSE_INPUTS as u64 * CONVERSION_CYCLES as u64 * 1_000_000_000 / ADC_HZ as u64) as u32;
/// Scans the circular DMA buffer holds (67 ms: a control period and a late wake-up). The control
/// loop must drain it within that, or the scans since are lost (`RingBufferedAdc::read_latest`
/// restarts from the newest).
pub const RING_SCANS: usize = 256;

// The ST-LINK's virtual COM port has no flow control: these hold about 90 ms of input and of
// replies. The console reader never waits for anything but input, so the receive buffer only
// fills if the executor stalls; `serial` detects it (and hardware overruns) and the affected
// line is refused.
static CONSOLE_TX: ConstStaticCell<[u8; CONSOLE_TX_BYTES]> =
    ConstStaticCell::new([0; CONSOLE_TX_BYTES]);
/// The console's transmit ring, bytes (the most one write may hand it: `board`'s transmitter
/// cuts longer pieces).
pub const CONSOLE_TX_BYTES: usize = 1024;
static CONSOLE_RX: ConstStaticCell<[u8; serial::RX_BUF]> =
    ConstStaticCell::new([0; serial::RX_BUF]);
/// ADC1's circular DMA buffer: [`RING_SCANS`] scans of [`SENSE_INPUTS`] counts.
static ADC_RING: ConstStaticCell<[u16; RING_SCANS * SENSE_INPUTS]> =
    ConstStaticCell::new([0; RING_SCANS * SENSE_INPUTS]);

/// The clock tree: 180 MHz from the 8 MHz HSE bypass.
pub fn clocks() -> Config {
    use embassy_stm32::rcc::{
        AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllSource,
        Sysclk,
    };
    let mut config = Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Bypass,
    });
    config.rcc.pll_src = PllSource::HSE;
    config.rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL180,
        divp: Some(PllPDiv::DIV2),
        divq: None,
        divr: None,
    });
    config.rcc.sys = Sysclk::PLL1_P;
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV4;
    config.rcc.apb2_pre = APBPrescaler::DIV2;
    config
}

/// The heater, fan and spring gates and the spring power enable: driven only by
/// [`Gates::apply`] with the library's [`Outputs`].
pub struct Gates {
    heater: SimplePwm<'static, peripherals::TIM3>,
    fan: SimplePwm<'static, peripherals::TIM4>,
    springs: [Output<'static>; SPRINGS],
    spring_power: Output<'static>,
    /// The spring gates and power as last applied (all off from [`Board::new`]).
    channels: (SpringMask, bool),
}

impl Gates {
    /// Drive every output as `state` says: heater and fan duty, spring gates, spring power. The
    /// only function that switches a load on. Return whether a spring gate or the spring power
    /// switched (the spring channels' readings then need [`thermorph::channels::SETTLE_US`]).
    ///
    /// When the spring power switches, it goes off before the gates change and on after them:
    /// it is never switched on over the previous state's gates.
    pub fn apply(&mut self, state: &Outputs) -> bool {
        fn duty(
            ch: &mut embassy_stm32::timer::simple_pwm::SimplePwmChannel<
                '_,
                impl embassy_stm32::timer::GeneralInstance4Channel,
            >,
            d: Duty,
        ) {
            if d.fraction() <= 0.0 {
                ch.set_duty_cycle_fully_off();
            } else {
                let max = ch.max_duty_cycle();
                // Duty is within [0, 1]: the product is within [0, max].
                ch.set_duty_cycle((d.fraction() * max as f32) as u32);
            }
        }
        duty(&mut self.heater.ch1(), state.heater);
        duty(&mut self.fan.ch1(), state.fan);
        if !state.spring_power {
            self.spring_power.set_low();
        }
        for (i, s) in self.springs.iter_mut().enumerate() {
            if state.springs.contains(i) {
                s.set_high();
            } else {
                s.set_low();
            }
        }
        if state.spring_power {
            self.spring_power.set_high();
        }
        let channels = (state.springs, state.spring_power);
        core::mem::replace(&mut self.channels, channels) != channels
    }
}

/// [`OUTPUTS_OFF`] from the gate pins.
macro_rules! outputs_off {
    ($h:ident, $f:ident, [$($s:ident),*]) => {
        OffProgram::stm32f4(
            &[$(stringify!($s),)* stringify!($h), stringify!($f)],
            &[pwm_channel!(TIM3, Ch1, $h), pwm_channel!(TIM4, Ch1, $f)],
        )
    };
}

/// `(timer, channel)` names of a PWM output; fails to compile unless `$pin` is that channel's
/// pin.
macro_rules! pwm_channel {
    ($tim:ident, $ch:ident, $pin:ident) => {{
        const _: () = pwm_pin::<peripherals::$tim, embassy_stm32::timer::$ch, peripherals::$pin>();
        (stringify!($tim), stringify!($ch))
    }};
}

const fn pwm_pin<T, C, P>()
where
    T: embassy_stm32::timer::GeneralInstance4Channel,
    C: embassy_stm32::timer::TimerChannel,
    P: embassy_stm32::timer::TimerPin<T, C>,
{
}

/// The register program every fault handler runs before anything else (`fault.rs`): the pins
/// of [`gate_pins!`] (the spring power enable with the gates) driven low as GPIO outputs,
/// whoever holds them, and the heater's and fan's PWM channels — as [`Board::new`] sets them
/// up — forced inactive with a compare value of 0. The hard fault handler runs it without a
/// stack.
pub static OUTPUTS_OFF: OffProgram = gate_pins!(outputs_off);

/// I2C1 on PB8 / PB9 with its DMA streams, at [`I2C_HZ`].
fn sensor_i2c(
    i2c: Peri<'static, peripherals::I2C1>,
    scl: Peri<'static, peripherals::PB8>,
    sda: Peri<'static, peripherals::PB9>,
    tx_dma: Peri<'static, peripherals::DMA1_CH6>,
    rx_dma: Peri<'static, peripherals::DMA1_CH0>,
) -> I2c<'static, Async, Master> {
    let mut config = i2c::Config::default();
    config.frequency = Hertz(I2C_HZ);
    I2c::new(i2c, scl, sda, tx_dma, rx_dma, Irqs, config)
}

/// The sensor's bus: I2C1, rebuilt by a recovery ([`RecoverBus`]).
pub struct SensorBus {
    i2c: Option<I2c<'static, Async, Master>>,
}

impl ErrorType for SensorBus {
    type Error = i2c::Error;
}

impl embedded_hal_async::i2c::I2c for SensorBus {
    async fn read(&mut self, address: u8, read: &mut [u8]) -> Result<(), i2c::Error> {
        match self.i2c.as_mut() {
            Some(b) => b.read(address, read).await,
            None => Err(i2c::Error::Bus),
        }
    }

    async fn write(&mut self, address: u8, write: &[u8]) -> Result<(), i2c::Error> {
        match self.i2c.as_mut() {
            Some(b) => b.write(address, write).await,
            None => Err(i2c::Error::Bus),
        }
    }

    async fn write_read(
        &mut self,
        address: u8,
        write: &[u8],
        read: &mut [u8],
    ) -> Result<(), i2c::Error> {
        match self.i2c.as_mut() {
            Some(b) => b.write_read(address, write, read).await,
            None => Err(i2c::Error::Bus),
        }
    }

    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), i2c::Error> {
        match self.i2c.as_mut() {
            Some(b) => b.transaction(address, operations).await,
            None => Err(i2c::Error::Bus),
        }
    }
}

impl RecoverBus for SensorBus {
    /// Drop the peripheral (its pins disconnect, its clock stops), clock SCL as an open-drain
    /// GPIO until the sensor lets SDA go (at most nine clocks: one byte and its ACK), send a
    /// STOP, and build I2C1 again (enabled and reset).
    async fn recover(&mut self) -> Result<(), BusStuck> {
        self.i2c = None;
        // SAFETY: the I2C driver that owned these pins was just dropped; nothing else uses
        // them, and the GPIO drivers are dropped before the peripheral is built again.
        let (mut scl, mut sda) = unsafe {
            (
                OutputOpenDrain::new(peripherals::PB8::steal(), Level::High, Speed::Low),
                OutputOpenDrain::new(peripherals::PB9::steal(), Level::High, Speed::Low),
            )
        };
        Timer::after_micros(RECOVERY_HALF_PERIOD_US).await;
        for _ in 0..9 {
            if sda.is_high() {
                break;
            }
            scl.set_low();
            Timer::after_micros(RECOVERY_HALF_PERIOD_US).await;
            scl.set_high();
            Timer::after_micros(RECOVERY_HALF_PERIOD_US).await;
        }
        // STOP: SDA rises while SCL is high.
        scl.set_low();
        Timer::after_micros(RECOVERY_HALF_PERIOD_US).await;
        sda.set_low();
        Timer::after_micros(RECOVERY_HALF_PERIOD_US).await;
        scl.set_high();
        Timer::after_micros(RECOVERY_HALF_PERIOD_US).await;
        sda.set_high();
        Timer::after_micros(RECOVERY_HALF_PERIOD_US).await;
        let free = sda.is_high() && scl.is_high();
        drop((scl, sda));
        // SAFETY: as above; the previous driver is gone, so this is the only I2C1 driver.
        self.i2c = Some(unsafe {
            sensor_i2c(
                peripherals::I2C1::steal(),
                peripherals::PB8::steal(),
                peripherals::PB9::steal(),
                peripherals::DMA1_CH6::steal(),
                peripherals::DMA1_CH0::steal(),
            )
        });
        if free { Ok(()) } else { Err(BusStuck) }
    }
}

/// ADC1 scanning the spring channels' inputs ([`sense_pins!`]) into its circular DMA buffer;
/// not started.
pub type SpringInputs = RingBufferedAdc<'static, peripherals::ADC1>;

/// ADC1 at [`ADC_HZ`] with `inputs` in its regular sequence, scanning continuously into
/// [`ADC_RING`] through DMA2 stream 0 (not yet started).
fn spring_adc(
    adc1: Peri<'static, peripherals::ADC1>,
    dma: Peri<'static, peripherals::DMA2_CH0>,
    inputs: [adc::AnyAdcChannel<'static, peripherals::ADC1>; SENSE_INPUTS],
) -> SpringInputs {
    use embassy_stm32::pac::{ADC1, ADC123_COMMON};
    let adc = Adc::new(adc1);
    // embassy picks the fastest prescaler (PCLK2 / 4); the ADC is off while it changes, and
    // `into_ring_buffered` turns it on again.
    ADC1.cr2().modify(|w| w.set_adon(false));
    ADC123_COMMON
        .ccr()
        .modify(|w| w.set_adcpre(adc::Adcpre::DIV8));
    adc.into_ring_buffered(
        dma,
        ADC_RING.take(),
        Irqs,
        inputs.into_iter().map(|i| (i, SAMPLE_TIME)),
        adc::CONTINUOUS,
        adc::Exten::DISABLED,
    )
}

/// Whether [`SpringInputs`], once started, still converts: ADC1 has no overrun (which stops its
/// DMA requests) and DMA2 stream 0 is enabled (an error disables it).
pub fn spring_inputs_running() -> bool {
    use embassy_stm32::pac::{ADC1, DMA2};
    !ADC1.sr().read().ovr() && DMA2.st(0).cr().read().en()
}

/// Every peripheral the firmware uses, configured.
pub struct Board {
    /// I2C1 to the MLX90640.
    pub i2c: SensorBus,
    /// USART2, the console.
    pub console: BufferedUart<'static>,
    /// Heater, fan, springs and the spring power.
    pub outputs: Gates,
    /// The spring channels' currents and supplies (not started).
    pub springs: SpringInputs,
    /// The user button, for its edges (its level: [`estop_pressed`]).
    pub estop: ExtiInput<'static, Async>,
    /// LD2.
    pub led: Output<'static>,
    /// The independent watchdog (not yet started).
    pub watchdog: IndependentWatchdog<'static, peripherals::IWDG>,
    /// The flash's 128 KiB sectors (5-7); the settings use 6 and 7.
    pub flash: embassy_stm32::flash::Bank1Region3<'static, embassy_stm32::flash::Blocking>,
}

impl Board {
    /// Take the peripherals and configure them; every output starts off.
    pub fn new(p: Peripherals) -> Self {
        // Gates first, low, before anything else can run.
        macro_rules! take_gates {
            ($h:ident, $f:ident, [$a:ident, $b:ident, $c:ident, $power:ident]) => {
                (
                    [
                        Output::new(p.$a, Level::Low, Speed::Low),
                        Output::new(p.$b, Level::Low, Speed::Low),
                        Output::new(p.$c, Level::Low, Speed::Low),
                    ],
                    Output::new(p.$power, Level::Low, Speed::Low),
                    p.$h,
                    p.$f,
                )
            };
        }
        let (springs, spring_power, heater_pin, fan_pin) = gate_pins!(take_gates);
        let mut heater = SimplePwm::new(
            p.TIM3,
            Some(PwmPin::new(heater_pin, OutputType::PushPull)),
            None,
            None,
            None,
            Hertz(HEATER_PWM_HZ),
            CountingMode::EdgeAlignedUp,
        );
        heater.ch1().set_duty_cycle_fully_off();
        heater.ch1().enable();
        let mut fan = SimplePwm::new(
            p.TIM4,
            Some(PwmPin::new(fan_pin, OutputType::PushPull)),
            None,
            None,
            None,
            Hertz(FAN_PWM_HZ),
            CountingMode::EdgeAlignedUp,
        );
        fan.ch1().set_duty_cycle_fully_off();
        fan.ch1().enable();

        // The spring channels' inputs, analog, in scan order (each an ADC1 input, or this fails
        // to compile).
        macro_rules! take_inputs {
            ([$($i:ident),*], [$($v:ident),*]) => {
                [$(p.$i.degrade_adc(),)* $(p.$v.degrade_adc(),)*]
            };
        }
        let spring_inputs = spring_adc(p.ADC1, p.DMA2_CH0, sense_pins!(take_inputs));

        let i2c = SensorBus {
            i2c: Some(sensor_i2c(p.I2C1, p.PB8, p.PB9, p.DMA1_CH6, p.DMA1_CH0)),
        };

        let mut uart_config = usart::Config::default();
        uart_config.baudrate = CONSOLE_BAUD;
        // Wake the reader on every byte, not only on a full buffer or an idle line.
        uart_config.eager_reads = Some(1);
        let console = match BufferedUart::new(
            p.USART2,
            p.PA3,
            p.PA2,
            CONSOLE_TX.take(),
            CONSOLE_RX.take(),
            Irqs,
            uart_config,
        ) {
            Ok(u) => u,
            // 115200 8N1 is always a valid configuration at 45 MHz APB1.
            Err(_) => defmt::panic!("USART2 configuration refused"),
        };

        Board {
            i2c,
            console,
            outputs: Gates {
                heater,
                fan,
                springs,
                spring_power,
                channels: (SpringMask::NONE, false),
            },
            springs: spring_inputs,
            estop: ExtiInput::new(p.PC13, p.EXTI13, Pull::None, Irqs),
            led: Output::new(p.PA5, Level::Low, Speed::Low),
            watchdog: IndependentWatchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US),
            flash: embassy_stm32::flash::Flash::new_blocking(p.FLASH)
                .into_blocking_regions()
                .bank1_region3,
        }
    }
}

/// Whether the emergency-stop button reads pressed now (PC13 low). It reads the port's input
/// register only, so the control loop may call it while the e-stop task waits on the pin's
/// edges through [`Board::estop`].
pub fn estop_pressed() -> bool {
    use embassy_stm32::pac::GPIOC;
    use embassy_stm32::pac::gpio::vals::Idr;
    GPIOC.idr().read().idr(13) == Idr::LOW
}
