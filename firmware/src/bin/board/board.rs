//! The board's tasks and shared state (see the crate docs).

#[path = "pins.rs"]
pub mod pins;

use core::cell::RefCell;
use core::fmt::Write as _;

use defmt::{info, unwrap, warn};
use embassy_executor::Spawner;
use embassy_stm32::exti::ExtiInput;
use embassy_stm32::i2c::{I2c, Master};
use embassy_stm32::mode::Async;
use embassy_stm32::usart::BufferedUart;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_time::{Delay, Duration, Ticker, Timer};
use embedded_io_async::{Read as _, Write as _};
use static_cell::ConstStaticCell;
use thermorph::console::{self, LineReader, MAX_LINE, SensorError, Status};
use thermorph::mlx90640::{self, Calibration, DecodeParams, Image, Mlx90640, SubpageFrame};
use thermorph::mtts::{self, Mtts};
use {defmt_rtt as _, panic_probe as _};

/// What the console reports, written by the sensor task.
static STATUS: Mutex<CriticalSectionRawMutex, RefCell<Status>> = Mutex::new(RefCell::new(Status {
    ta: None,
    vdd_v: None,
    frames: 0,
    image: None,
    regions: None,
    sensor_error: None,
    sensor_errors: 0,
    estop: false,
}));

static CALIBRATION: ConstStaticCell<Calibration> = ConstStaticCell::new(Calibration::new());
static FRAME: ConstStaticCell<SubpageFrame> = ConstStaticCell::new(SubpageFrame::new());
static IMAGE: ConstStaticCell<Image> = ConstStaticCell::new(Image::new());
static MTTS_SCRATCH: ConstStaticCell<mtts::Scratch> = ConstStaticCell::new(mtts::Scratch::new());

/// Pause after a sensor error before trying again.
const SENSOR_RETRY: Duration = Duration::from_millis(200);
/// Control loop period; the watchdog timeout is five of these.
const TICK: Duration = Duration::from_millis(100);

fn record_error(e: SensorError) {
    warn!("sensor: {}", e);
    STATUS.lock(|s| {
        let mut s = s.borrow_mut();
        s.sensor_error = Some(e);
        s.sensor_errors = s.sensor_errors.wrapping_add(1);
    });
}

#[embassy_executor::task]
async fn sensor_task(i2c: I2c<'static, Async, Master>) {
    let cal = CALIBRATION.take();
    let frame = FRAME.take();
    let image = IMAGE.take();
    let scratch = MTTS_SCRATCH.take();
    let mut mtts = match Mtts::new(mtts::Config::default()) {
        Ok(m) => Some(m),
        Err(e) => {
            record_error(SensorError::Mtts(e));
            None
        }
    };
    let mut driver = Mlx90640::new(i2c, Delay, mlx90640::ADDRESS);
    let params = DecodeParams::default();
    let mut ready = false;
    loop {
        if !ready {
            let setup = async {
                driver.calibrate(cal).await?;
                driver.configure(mlx90640::Config::default()).await
            };
            match setup.await {
                Ok(()) => {
                    info!("MLX90640 calibrated and configured");
                    ready = true;
                }
                Err(e) => {
                    record_error(SensorError::Driver(e));
                    Timer::after(SENSOR_RETRY).await;
                    continue;
                }
            }
        }
        let decoded = match driver.read_subpage(frame).await {
            Ok(()) => image
                .update(frame, cal, &params)
                .map_err(mlx90640::Error::from),
            Err(e) => Err(e),
        };
        match decoded {
            Ok(info) => {
                let stats = image.stats();
                let regions = match mtts.as_mut() {
                    Some(m) if info.subpage == 1 && image.complete() => {
                        match m.process(&image.to_k, scratch) {
                            Ok(out) => Some(out.regions.map(|r| r.temp)),
                            Err(e) => {
                                record_error(SensorError::Mtts(e));
                                None
                            }
                        }
                    }
                    _ => None,
                };
                STATUS.lock(|s| {
                    let mut s = s.borrow_mut();
                    s.ta = Some(info.ta);
                    s.vdd_v = Some(info.vdd_v);
                    s.frames = s.frames.wrapping_add(1);
                    s.image = stats;
                    if regions.is_some() {
                        s.regions = regions;
                        s.sensor_error = None;
                    }
                });
            }
            Err(e) => {
                // A bus error may mean the sensor was unplugged: calibrate again.
                if matches!(
                    e,
                    mlx90640::Error::Bus { .. } | mlx90640::Error::Timeout { .. }
                ) {
                    ready = false;
                }
                record_error(SensorError::Driver(e));
                Timer::after(SENSOR_RETRY).await;
            }
        }
    }
}

#[embassy_executor::task]
async fn console_task(uart: BufferedUart<'static>) {
    let (mut tx, mut rx) = uart.split();
    let mut reader: LineReader<MAX_LINE> = LineReader::new();
    let mut buf = [0u8; 64];
    loop {
        let n = match rx.read(&mut buf).await {
            Ok(n) => n,
            Err(e) => {
                // embassy logs framing, noise and overrun errors itself and returns none from
                // a buffered read today; should one come, the bytes are lost and the line
                // reader carries on to the next line end.
                warn!("console: {}", e);
                continue;
            }
        };
        for &b in &buf[..n] {
            let Some(line) = reader.push(b) else {
                continue;
            };
            let mut out: heapless::String<384> = heapless::String::new();
            let status = STATUS.lock(|s| *s.borrow());
            let written = match line.and_then(console::parse) {
                Ok(cmd) => console::respond(cmd, &status, &mut out),
                Err(e) => console::respond_error(e, &mut out),
            };
            if written.is_err() {
                out.clear();
                let _ = out.write_str("err internal: reply too long\r\n");
            }
            if tx.write_all(out.as_bytes()).await.is_err() {
                warn!("console: write failed");
            }
        }
    }
}

#[embassy_executor::task]
async fn estop_task(mut button: ExtiInput<'static, Async>) {
    loop {
        button.wait_for_falling_edge().await;
        warn!("emergency stop");
        STATUS.lock(|s| s.borrow_mut().estop = true);
    }
}

/// Turn every output off, then wait for the watchdog to reset the chip.
///
/// Every panic ends here (panic-probe prints it over RTT, then executes `udf`), as does any
/// fault. Under `probe-rs run` the probe halts the core on entry to print a backtrace; the
/// watchdog, which keeps counting, then resets the chip and the pull-downs hold the gates low.
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    // SAFETY: nothing else runs after a hard fault; the pins are never handed back.
    unsafe { pins::force_outputs_off() };
    loop {
        cortex_m::asm::nop();
    }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(pins::clocks());
    let pins::Board {
        i2c,
        console,
        mut outputs,
        estop,
        mut led,
        mut watchdog,
    } = pins::Board::new(p);
    outputs.all_off();
    info!("thermorph {} up", thermorph::VERSION);
    spawner.spawn(unwrap!(sensor_task(i2c)));
    spawner.spawn(unwrap!(console_task(console)));
    spawner.spawn(unwrap!(estop_task(estop)));

    watchdog.unleash();
    let mut ticker = Ticker::every(TICK);
    let mut tick: u32 = 0;
    loop {
        watchdog.pet();
        // Nothing drives an output at this stage; keep them off every tick.
        outputs.all_off();
        let (fault, estop) = STATUS.lock(|s| {
            let s = s.borrow();
            (s.sensor_error.is_some(), s.estop)
        });
        let on = if fault || estop {
            tick % 2 == 0
        } else {
            tick % 10 == 0
        };
        if on {
            led.set_high();
        } else {
            led.set_low();
        }
        tick = tick.wrapping_add(1);
        ticker.next().await;
    }
}
