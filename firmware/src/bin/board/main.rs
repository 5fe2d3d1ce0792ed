//! `thermorph-board`: the firmware binary for the NUCLEO-F446RE.
//!
//! Wiring only: the pin map (`board/pins.rs`) gives embassy's peripherals to the library's
//! logic; tasks move data between them. On the host this binary only says where it runs.
//!
//! The board: clocks, tasks and shared state.
//!
//! - `main` (the control loop): a 100 ms ticker that feeds the independent watchdog (timeout
//!   500 ms) only while it runs, keeps every output off (this stage of the firmware drives no
//!   heater, fan or spring) and blinks LD2 — 1 Hz heartbeat, 5 Hz while the sensor reports an
//!   error or the emergency stop is latched.
//! - `sensor_task`: calibrates and configures the MLX90640 on I2C1, then reads subpages,
//!   decodes them into the image and runs MTTS on every whole frame; any error is recorded for
//!   the console and retried after a pause (re-calibrating if the calibration was lost). A
//!   missing sensor is therefore a visible error, never a reset loop.
//! - `console_task`: USART2 bytes → `thermorph::console` → one reply line per command.
//! - `estop_task`: the user button (PC13) latches the emergency stop.
//!
//! A panic leaves every output off: panic-probe prints it and executes `udf`, the hard-fault
//! handler drives the heater, fan and spring gates low and spins until the watchdog resets the
//! chip. From reset until `pins::Board::new` runs every gate pin is a floating input, so the
//! hardware must have (and the block has) pull-down resistors on the low-side MOSFET gates.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "thermorph-board runs on the NUCLEO-F446RE: `cd firmware && cargo run --release` \
         flashes it with probe-rs. On a computer, run `cargo run --release -p host-sim`."
    );
    std::process::exit(2);
}
