//! The board's tasks, the data they share, and the fault handlers (see the crate docs).

#[path = "fault.rs"]
mod fault;
#[path = "pins.rs"]
pub mod pins;
#[path = "retained.rs"]
pub mod retained;
#[path = "sense.rs"]
pub mod sense;
#[path = "serial.rs"]
pub mod serial;

use core::cell::Cell;
use core::sync::atomic::{AtomicBool, Ordering};

use defmt::{error, info, unwrap, warn};
use embassy_embedded_hal::adapter::BlockingAsync;
use embassy_executor::Spawner;
use embassy_futures::select::{Either, Either3, select, select3};
use embassy_stm32::exti::ExtiInput;
use embassy_stm32::mode::Async;
use embassy_stm32::usart::{BufferedUartRx, BufferedUartTx};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_time::{Delay, Duration, Instant, Ticker, Timer};
use embedded_io_async::{Read as _, Write as _};
use static_cell::ConstStaticCell;
use thermorph::app::{Controller, Line};
use thermorph::channels::Channels;
use thermorph::command::ParseError;
use thermorph::console::{ConsoleError, LineReader, MAX_LINE};
use thermorph::measurement::{Measurement, SensingHint};
use thermorph::mlx90640::{Calibration, Image, SubpageFrame};
use thermorph::mtts;
use thermorph::outputs::Outputs;
use thermorph::sensing::{Clock, Outcome, Parts, Pipeline, PipelineConfig, Sensor, Storage};
use thermorph::settings::Settings;
use thermorph::storage::FlashStore;
use thermorph::supervisor::Supervisor;
use thermorph::supervisor::report::{Reply, SETTING_LINES, write_setting};
use thermorph::units::Millis;

use defmt_rtt as _;

/// The sensor task's newest measurement, until the control task takes it. (Sensing errors
/// only go to the log: the supervisor sees a missing sensor as measurements that stop coming.)
static MEASUREMENT: Mutex<CriticalSectionRawMutex, Cell<Option<Measurement>>> =
    Mutex::new(Cell::new(None));
/// Wakes the control task early: a measurement arrived or the e-stop button was pressed.
static WAKE: Signal<CriticalSectionRawMutex, ()> = Signal::new();
/// The supervisor's sensing hint for the frames to come (the control task signals it).
static HINT: Signal<CriticalSectionRawMutex, SensingHint> = Signal::new();
/// The e-stop button went down since the control task last looked: set by the e-stop task on
/// every falling edge, taken by the control task, which reports the button pressed for that
/// period even if its level already reads released (a tap shorter than a period). Never a
/// release: that is only ever the level read ([`pins::estop_pressed`]).
static ESTOP_TAPPED: AtomicBool = AtomicBool::new(false);

/// A console line waiting for its reply.
enum Item {
    /// A line to run.
    Line(heapless::String<MAX_LINE>),
    /// A line refused by the reader.
    Refused(ConsoleError),
    /// This many lines refused because the queue was full.
    Busy(u16),
}

/// Commands waiting for their replies, at most this many (the bound on outstanding commands).
const OUTSTANDING: usize = 4;
static LINES: Channel<CriticalSectionRawMutex, Item, OUTSTANDING> = Channel::new();

/// A line for the console's transmitter.
// Every slot of the channel holds a whole reply anyway (no heap to box it in).
#[allow(clippy::large_enum_variant)]
enum Out {
    /// The reply to one line.
    Reply(Reply),
    /// `n` lines refused because the queue was full: `n` times `err busy`.
    Busy(u16),
    /// A `#` line: telemetry, a warning (with its `#` and CR LF).
    Text(heapless::String<TELEMETRY_CAP>),
    /// `settings`' listing of these settings, one `#` line a parameter (its reply follows).
    Settings(Settings),
}

/// Longest `#` line (telemetry with the observer's fields ≈ 560 bytes, a warning), bytes.
const TELEMETRY_CAP: usize = 640;
/// Replies and `#` lines waiting to be written. The control loop takes a line only when a
/// reply slot is free, so a reply always fits; `#` lines are dropped when the port is behind.
static OUT: Channel<CriticalSectionRawMutex, Out, { OUTSTANDING + 2 }> = Channel::new();

// The pipeline's working memory, one static per part: the zero ones stay in .bss.
static CALIBRATION: ConstStaticCell<Calibration> = ConstStaticCell::new(Calibration::new());
static FRAME: ConstStaticCell<SubpageFrame> = ConstStaticCell::new(SubpageFrame::new());
static IMAGE: ConstStaticCell<Image> = ConstStaticCell::new(Image::new());
static MTTS_SCRATCH: ConstStaticCell<mtts::Scratch> = ConstStaticCell::new(mtts::Scratch::new());

/// The pipeline's working memory in its statics.
struct BoardStorage {
    cal: &'static mut Calibration,
    frame: &'static mut SubpageFrame,
    image: &'static mut Image,
    scratch: &'static mut mtts::Scratch,
}

impl Storage for BoardStorage {
    fn parts(&mut self) -> Parts<'_> {
        Parts {
            cal: self.cal,
            frame: self.frame,
            image: self.image,
            scratch: self.scratch,
        }
    }

    fn image(&self) -> &Image {
        self.image
    }
}

/// Control loop tick (besides every measurement and console line): the library's control
/// period.
const TICK: Duration = Duration::from_millis(thermorph::app::CONTROL_PERIOD_MS);

/// Where the settings live in the flash region of sectors 5-7 (`pins::Board::flash`):
/// sectors 6 and 7, which memory.x keeps out of the program.
const SETTINGS_RANGE: core::ops::Range<u32> = 0x2_0000..0x6_0000;

/// Give the independent watchdog its longest period (≈ 32 s) while the flash is written or
/// erased — an erase of a 128 KiB sector stalls the core for up to 2 s, longer than the
/// 500 ms period — or restore `period`, then reload it. The watchdog keeps running throughout.
fn watchdog_period(prescaler: embassy_stm32::pac::iwdg::vals::Pr, reload: u16) {
    use embassy_stm32::pac::IWDG;
    use embassy_stm32::pac::iwdg::vals::Key;
    IWDG.kr().write(|w| w.set_key(Key::ENABLE));
    IWDG.pr().write(|w| w.set_pr(prescaler));
    IWDG.rlr().write(|w| w.set_rl(reload));
    // The new values reach the watchdog's clock domain within a few 32 kHz cycles.
    while IWDG.sr().read().0 != 0 {}
    IWDG.kr().write(|w| w.set_key(Key::RESET));
}

/// Run a flash operation with the watchdog's period stretched, then restore it.
async fn with_long_watchdog<R>(
    watchdog: &mut embassy_stm32::wdg::IndependentWatchdog<
        'static,
        embassy_stm32::peripherals::IWDG,
    >,
    op: impl core::future::Future<Output = R>,
) -> R {
    use embassy_stm32::pac::IWDG;
    let (pr, rl) = (IWDG.pr().read().pr(), IWDG.rlr().read().rl());
    watchdog.pet();
    watchdog_period(embassy_stm32::pac::iwdg::vals::Pr::DIVIDE_BY256, 0x0FFF);
    let r = op.await;
    watchdog_period(pr, rl);
    watchdog.pet();
    r
}

/// Drive the pins as `state` says ([`pins::Gates::apply`]); when a spring gate or the spring
/// power switched, the spring channels' scans start settling again ([`sense::Springs::switched`]).
fn apply(gates: &mut pins::Gates, springs: &mut sense::Springs, state: &Outputs) {
    if gates.apply(state) {
        springs.switched();
    }
}

/// The settings' flash store on sectors 6 and 7.
type BoardStore = FlashStore<
    BlockingAsync<embassy_stm32::flash::Bank1Region3<'static, embassy_stm32::flash::Blocking>>,
>;

/// What the control loop drives besides the library, for a period's work before its reply.
struct Hardware<'a> {
    gates: &'a mut pins::Gates,
    springs: &'a mut sense::Springs,
    store: &'a mut BoardStore,
    watchdog:
        &'a mut embassy_stm32::wdg::IndependentWatchdog<'static, embassy_stm32::peripherals::IWDG>,
}

impl Hardware<'_> {
    /// Carry out `period`'s flash operation or probe and put its reply in it.
    ///
    /// - `save` and `load`: the outputs (heater and springs off) go to the pins first and hold
    ///   through the flash operation, which stalls the core; then the flash gives the reply.
    /// - `reset`'s probe: the spring power on with every gate off, a reading once settled
    ///   (≈ 2 ms), then the reply and the outputs without the probe (the power off again).
    async fn before_reply(
        &mut self,
        period: &mut thermorph::app::Period,
        control: &mut Controller,
    ) {
        apply(self.gates, self.springs, &period.outputs);
        if let Some(req) = period.store.take() {
            let reply = with_long_watchdog(
                self.watchdog,
                self.store.carry_out(&req, control.supervisor_mut(), now),
            )
            .await;
            period.reply = Some(reply);
        } else if period.probe {
            let sense = self.springs.probe().await;
            let (reply, after) = control.finish_probe(now(), &sense);
            period.reply = Some(reply);
            period.outputs = after;
        }
    }
}

/// Time since boot for the pipeline's timestamps.
#[derive(Clone, Copy)]
struct BoardClock;

impl Clock for BoardClock {
    fn now(&self) -> Millis {
        Millis(Instant::now().as_millis())
    }
}

fn now() -> Millis {
    BoardClock.now()
}

#[embassy_executor::task]
async fn sensor_task(bus: pins::SensorBus) {
    let pipeline = match Pipeline::new(PipelineConfig::default()) {
        Ok(p) => p,
        Err(e) => {
            // Unreachable with the default settings; without reports the watchdog resets.
            error!("sensing pipeline refused its settings: {}", e);
            return;
        }
    };
    let mut sensor = Sensor::new(
        bus,
        Delay,
        BoardClock,
        thermorph::mlx90640::ADDRESS,
        pipeline,
        BoardStorage {
            cal: CALIBRATION.take(),
            frame: FRAME.take(),
            image: IMAGE.take(),
            scratch: MTTS_SCRATCH.take(),
        },
    );
    loop {
        if let Some(h) = HINT.try_take() {
            sensor.set_hint(h);
        }
        match sensor.step().await {
            Outcome::Frame(m) => {
                MEASUREMENT.lock(|c| c.set(Some(m)));
                WAKE.signal(());
            }
            Outcome::Error(e) => warn!("sensor: {}", e),
            Outcome::Ready => info!("MLX90640 calibrated and configured"),
            Outcome::Recovered => info!("I2C bus recovered"),
            Outcome::Paused | Outcome::Half | Outcome::Discarded(_) => {}
        }
    }
}

/// Queue `item`, or count it as refused if the queue is full or lines refused before it still
/// wait to be queued (replies keep the order of the lines).
fn queue(item: Item, busy: &mut u16) {
    flush_busy(busy);
    if *busy > 0 || LINES.try_send(item).is_err() {
        *busy = busy.saturating_add(1);
    }
}

fn flush_busy(busy: &mut u16) {
    if *busy > 0 && LINES.try_send(Item::Busy(*busy)).is_ok() {
        *busy = 0;
    }
}

/// Console input: bytes → lines → the reply queue. It waits only for input (never for a
/// reply to be written), so the receive ring drains as fast as bytes come; lines beyond
/// [`OUTSTANDING`] waiting commands are refused `err busy`, lines that lost bytes `err
/// lost-bytes` (see [`serial`]).
#[embassy_executor::task]
async fn console_rx_task(mut rx: BufferedUartRx<'static>) {
    let mut reader: LineReader<MAX_LINE> = LineReader::new();
    let mut losses = serial::LossTracker::new();
    let mut busy: u16 = 0;
    let mut buf = [0u8; 64];
    loop {
        let read = if busy > 0 {
            // Refused lines wait for room in the queue: look again soon even without input.
            match select(rx.read(&mut buf), Timer::after_millis(10)).await {
                Either::First(r) => r,
                Either::Second(()) => {
                    flush_busy(&mut busy);
                    continue;
                }
            }
        } else {
            rx.read(&mut buf).await
        };
        let n = match read {
            Ok(n) => n,
            Err(e) => {
                // embassy-stm32 0.6's buffered reader never returns an error (`serial` watches
                // the hardware's); should one come, the bytes may be gone: the line they
                // belonged to is refused.
                warn!("console: {}", e);
                reader.mark_lost();
                continue;
            }
        };
        losses.add(serial::took(n));
        for &b in &buf[..n] {
            if losses.next_byte_lost() {
                reader.mark_lost();
            }
            let item = match reader.push(b) {
                None => continue,
                Some(Ok(line)) => match heapless::String::try_from(line) {
                    Ok(s) => Item::Line(s),
                    // The reader caps lines at MAX_LINE bytes, as the string does.
                    Err(_) => Item::Refused(ConsoleError::LineTooLong),
                },
                Some(Err(e)) => Item::Refused(e),
            };
            queue(item, &mut busy);
        }
    }
}

/// Console output: the control loop's replies (one per line, in line order), telemetry lines
/// and `settings`' listing, each written whole, so they never break each other. Every item is
/// written as pieces through the one `write` below (a smaller task).
///
/// embassy-stm32 0.6's buffered writer takes a buffer whole or not at all: one longer than its
/// ring is refused (`get`'s 1.5 KB reply came out as an empty line), and one the ring has no
/// room for returns `Pending` without registering the task's waker, so the task was never
/// woken again (`settings`' listing stalled the console for good once the ring filled). So a
/// piece is cut to the ring's size, and one that might not fit waits for the ring to empty
/// (`flush`, whose waker is registered; a timer in case its wake-up is missed) — the bytes
/// queued since are counted.
#[embassy_executor::task]
async fn console_tx_task(mut tx: BufferedUartTx<'static>) {
    const RING: usize = pins::CONSOLE_TX_BYTES;
    let busy = Reply::parse_error(ParseError::Busy);
    let mut queued = 0;
    loop {
        let item = OUT.receive().await;
        let pieces = match &item {
            Out::Reply(_) => 2,
            Out::Busy(n) => 2 * usize::from(*n),
            Out::Text(_) => 1,
            Out::Settings(_) => SETTING_LINES,
        };
        for k in 0..pieces {
            // A listing's line, in the telemetry's line type (its writer is in flash already).
            let mut line = heapless::String::<TELEMETRY_CAP>::new();
            let piece: &[u8] = match &item {
                // A reply (or `err busy`), then its line end.
                Out::Reply(_) | Out::Busy(_) if k % 2 == 1 => b"\r\n",
                Out::Reply(r) => r.as_str().as_bytes(),
                Out::Busy(_) => busy.as_str().as_bytes(),
                Out::Text(t) => t.as_bytes(),
                Out::Settings(s) => {
                    let _ = write_setting(&mut line, s, k);
                    line.as_bytes()
                }
            };
            for chunk in piece.chunks(RING) {
                if queued + chunk.len() > RING {
                    while let Either::Second(()) = select(tx.flush(), Timer::after_millis(2)).await
                    {
                    }
                    queued = 0;
                }
                if tx.write_all(chunk).await.is_err() {
                    warn!("console: write failed");
                }
                queued += chunk.len();
            }
        }
    }
}

/// The emergency stop's edges: every press wakes the control loop at once and is remembered
/// until it looks ([`ESTOP_TAPPED`]). The loop reads the button's level itself every period;
/// this task only makes a press quicker to act on and a short tap impossible to miss.
#[embassy_executor::task]
async fn estop_task(mut button: ExtiInput<'static, Async>) {
    loop {
        button.wait_for_falling_edge().await;
        ESTOP_TAPPED.store(true, Ordering::Release);
        WAKE.signal(());
    }
}

/// Queue a console line `# {notice}` — `# warning: …`, `# autotune done: …` — (best effort,
/// as telemetry: a port behind by a whole queue loses it; warnings and autotune outcomes are
/// also in the supervisor's `log`).
fn write_notice(notice: thermorph::supervisor::Notice) {
    use core::fmt::Write as _;
    warn!("{}", defmt::Display2Format(&notice));
    let mut line = heapless::String::<TELEMETRY_CAP>::new();
    if write!(line, "# {notice}\r\n").is_err() || OUT.try_send(Out::Text(line)).is_err() {
        warn!("console: notice line dropped");
    }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    // Why the chip started, and the springs' memory if a reset kept it: read before anything
    // else, then the reset flags are cleared.
    let (cause, boot) = retained::take();
    let p = embassy_stm32::init(pins::clocks());
    let pins::Board {
        i2c,
        console,
        mut outputs,
        springs,
        estop,
        mut led,
        mut watchdog,
        flash,
    } = pins::Board::new(p);
    outputs.apply(&Outputs::OFF);
    // Start the watchdog before any task runs: from here a stall resets the chip.
    watchdog.unleash();
    info!(
        "thermorph {} ({}) up",
        thermorph::VERSION,
        thermorph::BUILD.unwrap_or("unknown")
    );
    let (tx, rx) = console.split();
    spawner.spawn(unwrap!(sensor_task(i2c)));
    spawner.spawn(unwrap!(console_rx_task(rx)));
    spawner.spawn(unwrap!(console_tx_task(tx)));
    spawner.spawn(unwrap!(estop_task(estop)));

    // The settings record: the stored one, or the defaults with a warning on the console.
    let mut store = unwrap!(FlashStore::new(BlockingAsync::new(flash), SETTINGS_RANGE).ok());
    // The spring channels: the ADC starts, and the amplifiers' offsets are measured with every
    // gate and the spring power off (as applied above); a refused calibration adds a warning.
    let mut springs = sense::Springs::new(springs);
    // (In a block, so the line's buffer is not kept in the control loop's future.)
    let (settings, calibration) = {
        let mut boot_line = heapless::String::<TELEMETRY_CAP>::new();
        let settings = with_long_watchdog(&mut watchdog, store.boot_settings(&mut boot_line)).await;
        let calibration = springs.calibrate(&mut boot_line).await;
        if !boot_line.is_empty() {
            let _ = OUT.try_send(Out::Text(boot_line));
        }
        (settings, calibration)
    };
    info!("reset cause: {}", cause);
    match boot {
        retained::Boot::Kept(_) => info!("springs: memory kept across the reset"),
        retained::Boot::PowerUp => info!("power-up: springs assumed hot"),
        retained::Boot::Unchecked => {
            warn!("reset without a valid spring memory: springs assumed hot")
        }
    }
    // Stopped (or standby after a power-up whose `boot_mode` asks for it); after any other
    // reset the first period's notice says why.
    let mut control = Controller::new(Supervisor::boot(now(), settings, boot.memory(), cause));
    control
        .supervisor_mut()
        .set_channels(Channels::new(calibration));
    retained::keep(&control.supervisor().spring_memory());
    let mut ticker = Ticker::every(TICK);
    loop {
        // Wake on a measurement or an e-stop press, a console line (only while a reply slot
        // is free, so the reply cannot block this loop) or the tick.
        let item = if OUT.free_capacity() > 1 {
            match select3(WAKE.wait(), LINES.receive(), ticker.next()).await {
                Either3::Second(item) => Some(item),
                _ => None,
            }
        } else {
            match select(WAKE.wait(), ticker.next()).await {
                Either::First(()) | Either::Second(()) => None,
            }
        };
        let measurement = MEASUREMENT.lock(Cell::take);
        // The spring channels' scans since the last period, under the outputs it applied.
        let spring_sense = springs.take();
        let t = now();

        // The control period (the library's Controller orders it): the e-stop button's level
        // (or a press since the last look), the spring channels, the measurement, then the
        // line.
        let tapped = ESTOP_TAPPED.swap(false, Ordering::AcqRel);
        let line = match &item {
            Some(Item::Line(l)) => Some(Line::Text(l.as_str())),
            Some(Item::Refused(e)) => Some(Line::Refused(*e)),
            Some(Item::Busy(_)) | None => None,
        };
        let mut period = control.period(
            t,
            Some(pins::estop_pressed() || tapped),
            spring_sense.as_ref(),
            measurement.as_ref(),
            line,
        );
        if let Some(Item::Busy(n)) = item {
            let _ = OUT.try_send(Out::Busy(n));
        }
        // `save`, `load` and `reset`'s probe give their reply after the hardware's part (one
        // await point in this loop besides its wake-up: the period is kept once).
        if period.store.is_some() || period.probe {
            let mut hw = Hardware {
                gates: &mut outputs,
                springs: &mut springs,
                store: &mut store,
                watchdog: &mut watchdog,
            };
            hw.before_reply(&mut period, &mut control).await;
        }
        if let Some(r) = period.reply.take() {
            // `settings`' listing first: the line was taken with two slots free.
            if r.lists_settings() {
                let _ = OUT.try_send(Out::Settings(*control.supervisor().settings()));
            }
            let _ = OUT.try_send(Out::Reply(r));
        }
        apply(&mut outputs, &mut springs, &period.outputs);
        retained::keep(&control.supervisor().spring_memory());
        HINT.signal(period.sensing);
        // After the reply, whose slot is kept free: a notice, then telemetry.
        for n in period.notices.into_iter().flatten() {
            write_notice(n);
        }
        if period.telemetry {
            let mut line = heapless::String::<TELEMETRY_CAP>::new();
            if control.write_telemetry(t, &mut line).is_ok() {
                // Best effort: a port that is behind loses telemetry, never a reply.
                let _ = OUT.try_send(Out::Text(line));
            }
        }
        let alive = period.alive;

        // The watchdog is fed after every completed control step that was alive: it used a
        // fresh measurement, or a fault holds the outputs safe (a stale measurement latches
        // sensor loss in that same step, and the console stays usable). So what it catches is
        // a stalled executor or control loop.
        if alive {
            watchdog.pet();
        }
        // LD2: a 50 ms flash every second, or 10 Hz while a fault is latched (by the clock:
        // the loop also wakes between ticks).
        let slot = t.0 / TICK.as_millis();
        let on = if control.supervisor().fault().is_some() {
            slot.is_multiple_of(2)
        } else {
            slot.is_multiple_of(20)
        };
        if on {
            led.set_high();
        } else {
            led.set_low();
        }
    }
}
