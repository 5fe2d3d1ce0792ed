//! The board's own release ELF (`thermorph-board`) on the emulated STM32F446 (`--features
//! pil`): it boots through embassy's clock setup to 180 MHz with no access to an unmodelled
//! register, sleeps in its executor, answers the console over the emulated USART2, and reads
//! the virtual MLX90640 over I2C1 with DMA into regions through its own MTTS.
//!
//! Needs the ELF: `cargo build --release -p thermorph-firmware --target thumbv7em-none-eabihf
//! --bin thermorph-board` (`.ci/run` builds it before this test).
#![cfg(feature = "pil")]

use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;

use host_sim::f446::cpu::Core;
use host_sim::f446::gpio::Drive;
use host_sim::f446::soc::Soc;
use host_sim::f446::{TIME_HZ, Time};
use host_sim::sensor::eeprom;
use host_sim::sensor::sim_time::SimClock;
use host_sim::sensor::virtual_mlx::VirtualMlx90640;

fn elf() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"),
        PathBuf::from,
    );
    let p = target.join("thumbv7em-none-eabihf/release/thermorph-board");
    assert!(
        p.exists(),
        "{} is missing: build it with `cargo build --release -p thermorph-firmware --target \
         thumbv7em-none-eabihf --bin thermorph-board`",
        p.display()
    );
    p
}

/// The board powered up with the e-stop button released (PC13 high) and the camera on I2C1
/// (a realistic sensor looking at a uniform 303 K field).
fn board() -> Core {
    let img = host_sim::f446::elf::load(&elf()).unwrap();
    let mut soc = Soc::new();
    let clock = SimClock::new();
    let words = eeprom::realistic(1).encode().unwrap();
    let device = VirtualMlx90640::new(words, clock.clone(), 1).unwrap();
    soc.attach_sensor(Rc::new(RefCell::new(device)), clock);
    for (a, b) in &img.flash {
        soc.flash.load(*a, b).unwrap();
    }
    soc.gpio[2].set_input(13, Drive::High);
    let mut core = Core::new(Box::new(soc), &img.flash, &img.code).unwrap();
    core.reset().unwrap();
    core
}

fn soc(core: &mut Core) -> &mut Soc {
    core.bus_as_mut::<Soc>().expect("built on the Soc")
}

/// Send `line` and run `for_s` more: the bytes the board wrote meanwhile.
fn exchange(core: &mut Core, line: &str, for_s: f64) -> String {
    soc(core)
        .usart2
        .receive_bytes(format!("{line}\r\n").as_bytes());
    let until = core.now() + (for_s * TIME_HZ as f64) as Time;
    core.run_until(until).unwrap();
    soc(core)
        .usart2
        .take_transmitted()
        .iter()
        .map(|b| char::from(b.byte))
        .collect()
}

#[test]
fn the_elf_boots_to_180_mhz_and_answers_its_console() {
    let mut core = board();
    core.run_until(TIME_HZ / 2).unwrap();
    assert!(core.bus_faults().is_empty(), "{:?}", core.bus_faults());
    assert_eq!(core.bus().clocks().sysclk_hz, 180_000_000);
    assert_eq!(core.bus().clocks().pclk1_hz, 45_000_000);
    assert!(core.sleeping(), "the executor sleeps at wfe between tasks");
    let version = exchange(&mut core, "version", 0.2);
    assert!(
        version.starts_with("ok thermorph ") && version.ends_with("\r\n"),
        "{version:?}"
    );
    // A power-up with default settings starts stopped, every output off.
    let status = exchange(&mut core, "status", 0.2);
    assert!(status.starts_with("ok mode=stopped "), "{status:?}");
    let s = soc(&mut core);
    assert_eq!(s.tims[1].pwm_duty(0), 0.0, "the heater (TIM3 CH1) off");
    // The camera's frames come through I2C1 and DMA: the regions read the field.
    core.run_until(core.now() + 3 * TIME_HZ).unwrap();
    let status = exchange(&mut core, "status", 0.2);
    let field = |name: &str| -> f64 {
        let at = status.find(&format!(" {name}=")).expect(name) + name.len() + 2;
        status[at..].split(' ').next().unwrap().parse().unwrap()
    };
    for r in ["t1_k", "t2_k", "t5_k"] {
        assert!((field(r) - 303.15).abs() < 0.5, "{r}: {status}");
    }
    // 8 Hz subpages, two a frame, for 3 s.
    assert!(field("frame") >= 10.0, "{status}");
    assert!(core.bus_faults().is_empty(), "{:?}", core.bus_faults());
    assert!(core.bus_faults().is_empty(), "{:?}", core.bus_faults());
}

/// A control loop stalled in the emulator (TIM12's interrupt, embassy's time, held low: the
/// loop's tick never comes and nothing feeds the watchdog) is reset by the IWDG 0.5–1 s later;
/// the board comes up saying why, and its springs' estimate continues from the memory kept in
/// RAM instead of the power-up's hot assumption.
#[test]
fn a_stalled_loop_is_reset_by_the_watchdog_with_the_springs_memory_kept() {
    let mut core = board();
    core.run_until(8 * TIME_HZ).unwrap();
    let spring_k = |status: &str| -> f64 {
        let at = status.find(" spring_a_k=").expect("spring_a_k") + " spring_a_k=".len();
        status[at..].split(' ').next().unwrap().parse().unwrap()
    };
    let before = spring_k(&exchange(&mut core, "status", 0.1));
    let booted = 372.39;
    assert!(
        before < booted - 1.0,
        "the estimate cooled since power-up: {before}"
    );
    let stall = core.now();
    soc(&mut core).suppress_irq(43);
    core.run_until(stall + TIME_HZ * 3 / 2).unwrap();
    let resets = core.resets().to_vec();
    assert_eq!(resets.len(), 1, "{resets:?}");
    let after_s = (resets[0] - stall) as f64 / TIME_HZ as f64;
    println!("the watchdog reset the stalled board {after_s:.3} s after the stall");
    assert!(
        (0.5..=1.0).contains(&after_s),
        "reset {after_s} s after the stall"
    );
    let said: String = soc(&mut core)
        .usart2
        .take_transmitted()
        .iter()
        .map(|b| char::from(b.byte))
        .collect();
    assert!(said.contains("# warning: reset by watchdog"), "{said:?}");
    let status = exchange(&mut core, "status", 0.1);
    assert!(status.starts_with("ok mode=stopped "), "{status}");
    let kept = spring_k(&status);
    assert!(
        (kept - before).abs() < 1.5 && kept < booted - 0.5,
        "the springs' memory: {kept} K after the reset, {before} K before it"
    );
}
