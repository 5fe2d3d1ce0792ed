//! `thermorph-board`: the firmware binary for the NUCLEO-F446RE.
//!
//! Wiring only: the pin map (`board/pins.rs`) gives embassy's peripherals to the library's
//! logic; tasks move data between them. On the host this binary only says where it runs.
//!
//! The board: clocks, tasks and shared state.
//!
//! - `main` (the control loop): wakes on every new measurement, every console line (while a
//!   reply slot is free), every e-stop press and at least every 50 ms (`TICK`, the library's
//!   `app::CONTROL_PERIOD_MS`), and each time runs one control period of the library's
//!   `app::Controller` (which orders it: the e-stop button's level — a press seen since the
//!   last period counts as pressed —, the spring channels' reading, the newest measurement,
//!   then the line), and applies the period's `Outputs` through `pins::Gates::apply` (the only
//!   path that drives a load: heater, fan, spring gates and the spring power enable PA9). A
//!   `save` or `load` applies that decision's outputs (heater and springs off) *before* the
//!   flash operation and holds them through it; `reset`'s probe applies its outputs (spring
//!   power on, every gate off), reads the spring channels once settled (≈ 2 ms, awaited) and
//!   gives the reply, and the outputs without the probe go to the pins. It writes the springs'
//!   memory to RAM kept across a reset (`board/retained.rs`), queues the reply, a `# …` line
//!   for a decision's notice (a warning, an autotune's outcome, after a reset the reset's
//!   cause) and any telemetry line, signals the sensing hint, and blinks LD2 (a 50 ms flash a
//!   second, 10 Hz while a fault is latched).
//! - The spring channels (`board/sense.rs`): ADC1 scans the three spring currents (PA0, PA1,
//!   PA4) and the three supplies (PB0, PC1, PC0) without pause into a circular DMA buffer
//!   (embassy's `RingBufferedAdc`, DMA2 stream 0, 262 µs a scan); each period the control loop
//!   copies out the scans since the last one, without waiting, and hands the library the means
//!   of their first and second half (`channels::SpringSense`; `None` with fewer than two
//!   scans). Scans within `channels::SETTLE_US` of a switch of a spring gate or the spring power
//!   are dropped, so a period's reading is of the outputs the last period applied.
//! - The watchdog (independent, 500 ms, started before any task) is fed after every completed
//!   control step whose decision is `alive`: a measurement at most `sensor_timeout_s` old was
//!   used, or a fault holds the outputs safe. A sensor that stops delivering latches sensor
//!   loss (and keeps the console usable) rather than a reset, so what the watchdog catches is
//!   a stalled executor or control loop. A flash write or erase stretches its period to about
//!   32 s for the operation.
//! - `sensor_task`: the library's sensing pipeline (`thermorph::sensing::Sensor`) on I2C1 —
//!   setup, bus recovery after I2C errors (nine SCL clocks, STOP, I2C1 rebuilt), subpage
//!   pairing, MTTS — publishing each `Measurement` for the control loop (errors go to the log)
//!   and applying the sensing hint the loop signals.
//! - `console_rx_task`: USART2 bytes → `LineReader` → a queue of at most four commands; it
//!   only ever waits for input, refuses lines beyond the queue (`err busy`) and lines that
//!   lost bytes or received damaged ones (`err lost-bytes`, see `board/serial.rs`).
//! - `console_tx_task`: one reply per queued line, in order, and the `#` lines; a long reply
//!   never holds up input.
//! - `estop_task`: wakes the control loop on every press of the user button (PC13) and
//!   remembers it until the loop looks; the loop reads the level itself, and the supervisor
//!   owns the latch.
//!
//! At boot, with every output off: the reset flags give the reset's cause and decide whether
//! the springs' memory kept in RAM is used (a reset) or the springs are assumed hot (a
//! power-up): see `board/retained.rs`. The settings come from the flash, and 32 scans of the
//! spring channels give the current amplifiers' offsets (a refused calibration prints
//! `# warning: spring channel X amplifier offset N counts; channels uncalibrated` and the
//! channels run on nominal offsets). `Supervisor::boot` then starts `stopped` — in standby
//! only after a power-up whose saved `boot_mode` asks for it — and after any other reset its
//! first period prints `# warning: reset by …`.
//!
//! Every panic, hard fault (a stack overflow is one: flip-link is the linker) and unexpected
//! interrupt first drives the heater, fan and spring gates and the spring power enable low,
//! then prints over RTT, then stops at a breakpoint under a debugger or resets the chip — never
//! a hang. From reset until `pins::Board::new` runs every gate pin and the spring power enable
//! is a floating input, so the hardware must have (≤ 10 kΩ) pull-down resistors on the MOSFET
//! gates and the enable.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;

// The console's loss bookkeeping, the spring channels' scans and the reset flags are pure:
// their tests run on the host.
#[cfg(all(test, not(target_os = "none")))]
#[path = "loss.rs"]
mod loss;
#[cfg(all(test, not(target_os = "none")))]
#[path = "reset.rs"]
mod reset;
#[cfg(all(test, not(target_os = "none")))]
#[path = "scans.rs"]
mod scans;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "thermorph-board runs on the NUCLEO-F446RE: `cd firmware && cargo run --release` \
         flashes it with probe-rs. On a computer, run `cargo run --release -p host-sim`."
    );
    std::process::exit(2);
}
