//! The pin map of the NUCLEO-F446RE (SPEC section 2) — the one file that names pins.
//!
//! | signal | pin | peripheral |
//! |---|---|---|
//! | MLX90640 SCL / SDA | PB8 / PB9 | I2C1, 400 kHz, DMA1 stream 6 (TX) / 0 (RX) |
//! | PI heater gate | PA6 | TIM3 CH1 PWM, 1 kHz |
//! | fan gate | PB6 | TIM4 CH1 PWM, 25 kHz |
//! | SMA spring A / B / C | PB4 / PB5 / PB10 | GPIO, active high |
//! | console | PA2 / PA3 | USART2, 115200 8N1 (ST-LINK virtual COM port) |
//! | emergency stop | PC13 | user button B1, EXTI13, active low |
//! | status LED | PA5 | LD2 |
//!
//! Clocks: HSE 8 MHz bypass (the ST-LINK's MCO), PLL M 4 · N 180 · P 2 → SYSCLK 180 MHz,
//! AHB 180 MHz, APB1 45 MHz, APB2 90 MHz.

use embassy_stm32::exti::{self, ExtiInput};
use embassy_stm32::gpio::{Level, Output, OutputType, Pin, Pull, Speed};
use embassy_stm32::i2c::{self, I2c, Master};
use embassy_stm32::mode::Async;
use embassy_stm32::peripherals;
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::low_level::CountingMode;
use embassy_stm32::timer::simple_pwm::{PwmPin, SimplePwm};
use embassy_stm32::usart::{self, BufferedUart};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{Config, Peri, Peripherals, bind_interrupts, dma, interrupt};
use static_cell::ConstStaticCell;

bind_interrupts!(struct Irqs {
    I2C1_EV => i2c::EventInterruptHandler<peripherals::I2C1>;
    I2C1_ER => i2c::ErrorInterruptHandler<peripherals::I2C1>;
    DMA1_STREAM6 => dma::InterruptHandler<peripherals::DMA1_CH6>;
    DMA1_STREAM0 => dma::InterruptHandler<peripherals::DMA1_CH0>;
    USART2 => usart::BufferedInterruptHandler<peripherals::USART2>;
    EXTI15_10 => exti::InterruptHandler<interrupt::typelevel::EXTI15_10>;
});

/// I2C clock for the MLX90640 (the F446's I2C1 is a Fast-mode peripheral: 400 kHz at most).
pub const I2C_HZ: u32 = 400_000;
/// Console baud rate.
pub const CONSOLE_BAUD: u32 = 115_200;
/// Heater PWM frequency.
pub const HEATER_PWM_HZ: u32 = 1_000;
/// Fan PWM frequency.
pub const FAN_PWM_HZ: u32 = 25_000;
/// Independent watchdog timeout, µs.
pub const WATCHDOG_TIMEOUT_US: u32 = 500_000;

// The ST-LINK's virtual COM port has no flow control, and the buffered UART drops what does not
// fit: these hold about 90 ms of input and of replies, so a host may send a burst of commands
// without waiting for each reply.
static CONSOLE_TX: ConstStaticCell<[u8; 1024]> = ConstStaticCell::new([0; 1024]);
static CONSOLE_RX: ConstStaticCell<[u8; 1024]> = ConstStaticCell::new([0; 1024]);

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

/// The heater, fan and spring outputs.
pub struct Outputs {
    heater: SimplePwm<'static, peripherals::TIM3>,
    fan: SimplePwm<'static, peripherals::TIM4>,
    springs: [Output<'static>; 3],
}

impl Outputs {
    /// Turn every output off: heater and fan at 0 % duty, spring gates low.
    pub fn all_off(&mut self) {
        self.heater.ch1().set_duty_cycle_fully_off();
        self.fan.ch1().set_duty_cycle_fully_off();
        for s in &mut self.springs {
            s.set_low();
        }
    }
}

/// Drive the heater, fan and spring gates low, whoever holds them.
///
/// For the hard-fault handler, where every panic ends (panic-probe's `udf`): the pins are taken
/// back from their drivers and made plain low outputs, so a panic or a fault turns the outputs
/// off at once instead of leaving them as they were until the watchdog resets the chip. Keep
/// the pins in step with [`Board::new`].
///
/// # Safety
///
/// Steals the pins from their owners: call it only where no other code runs afterwards.
pub unsafe fn force_outputs_off() {
    fn low(pin: Peri<'static, impl Pin>) {
        // Dropping the driver would disconnect (float) the pin: keep it driven low.
        core::mem::forget(Output::new(pin, Level::Low, Speed::Low));
    }
    // SAFETY: the caller guarantees that nothing uses these pins any more.
    unsafe {
        low(peripherals::PA6::steal());
        low(peripherals::PB6::steal());
        low(peripherals::PB4::steal());
        low(peripherals::PB5::steal());
        low(peripherals::PB10::steal());
    }
}

/// Every peripheral the firmware uses, configured.
pub struct Board {
    /// I2C1 to the MLX90640.
    pub i2c: I2c<'static, Async, Master>,
    /// USART2, the console.
    pub console: BufferedUart<'static>,
    /// Heater, fan and springs.
    pub outputs: Outputs,
    /// The user button.
    pub estop: ExtiInput<'static, Async>,
    /// LD2.
    pub led: Output<'static>,
    /// The independent watchdog (not yet started).
    pub watchdog: IndependentWatchdog<'static, peripherals::IWDG>,
}

impl Board {
    /// Take the peripherals and configure them; every output starts off.
    pub fn new(p: Peripherals) -> Self {
        // Gates first, low, before anything else can run.
        let springs = [
            Output::new(p.PB4, Level::Low, Speed::Low),
            Output::new(p.PB5, Level::Low, Speed::Low),
            Output::new(p.PB10, Level::Low, Speed::Low),
        ];
        let mut heater = SimplePwm::new(
            p.TIM3,
            Some(PwmPin::new(p.PA6, OutputType::PushPull)),
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
            Some(PwmPin::new(p.PB6, OutputType::PushPull)),
            None,
            None,
            None,
            Hertz(FAN_PWM_HZ),
            CountingMode::EdgeAlignedUp,
        );
        fan.ch1().set_duty_cycle_fully_off();
        fan.ch1().enable();

        let mut i2c_config = i2c::Config::default();
        i2c_config.frequency = Hertz(I2C_HZ);
        let i2c = I2c::new(
            p.I2C1, p.PB8, p.PB9, p.DMA1_CH6, p.DMA1_CH0, Irqs, i2c_config,
        );

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
            outputs: Outputs {
                heater,
                fan,
                springs,
            },
            estop: ExtiInput::new(p.PC13, p.EXTI13, Pull::None, Irqs),
            led: Output::new(p.PA5, Level::Low, Speed::Low),
            watchdog: IndependentWatchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US),
        }
    }
}
