//! `thermorph-board`: the firmware binary for the NUCLEO-F446RE.
//!
//! Wiring only: the pin map (`board/pins.rs`) gives embassy's peripherals to the library's
//! logic; tasks move data between them. On the host this binary only says where it runs.
//!
//! The board: clocks, tasks and shared state.
//!
//! - `main` (the control loop): every 100 ms takes the sensor task's newest measurement and
//!   error and the e-stop event, and applies one `Outputs` through `pins::Outputs::apply` (the
//!   only path that drives a load; until the supervisor is connected it applies
//!   `Outputs::OFF`). It feeds the independent watchdog (500 ms, started before any task) only
//!   while the sensor task has finished a step (each is bounded by the driver's timeouts)
//!   within the last second, and blinks LD2: 1 Hz heartbeat, 5 Hz while the sensor reports an error or the e-stop was
//!   pressed.
//! - `sensor_task`: the library's sensing pipeline (`thermorph::sensing::Sensor`) on I2C1 —
//!   setup, bus recovery after I2C errors (nine SCL clocks, STOP, I2C1 rebuilt), subpage
//!   pairing, MTTS — publishing each `Measurement` or `SensingError` for the control task and
//!   applying the sensing hint the control task signals.
//! - `console_rx_task`: USART2 bytes → `LineReader` → a queue of at most four commands; it
//!   only ever waits for input, refuses lines beyond the queue (`err busy`) and lines that
//!   lost bytes (`err lost-bytes`, see `board/serial.rs`).
//! - `console_tx_task`: one reply per queued line, in order; a long reply never holds up input.
//! - `estop_task`: publishes every press of the user button (PC13), including one held at
//!   start; the supervisor owns the latch.
//!
//! Every panic, hard fault (a stack overflow is one: flip-link is the linker) and unexpected
//! interrupt first drives the heater, fan and spring gates low, then prints over RTT, then
//! stops at a breakpoint under a debugger or resets the chip — never a hang. From reset until
//! `pins::Board::new` runs every gate pin is a floating input, so the hardware must have
//! (≤ 10 kΩ) pull-down resistors on the MOSFET gates.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;

// The console's loss bookkeeping is pure: its tests run on the host.
#[cfg(all(test, not(target_os = "none")))]
#[path = "loss.rs"]
mod loss;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "thermorph-board runs on the NUCLEO-F446RE: `cd firmware && cargo run --release` \
         flashes it with probe-rs. On a computer, run `cargo run --release -p host-sim`."
    );
    std::process::exit(2);
}
