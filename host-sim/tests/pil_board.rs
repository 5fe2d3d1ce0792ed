//! The board's own release ELF (`thermorph-board`) on the emulated STM32F446 (`--features
//! pil`): it boots through embassy's clock setup to 180 MHz with no access to an unmodelled
//! register, sleeps in its executor, answers the console over the emulated USART2, and reads
//! the virtual MLX90640 over I2C1 with DMA into regions through its own MTTS.
//!
//! Needs the ELF: `cargo build --release -p thermorph-firmware --target thumbv7em-none-eabihf
//! --bin thermorph-board` (`.ci/run` builds it before this test).
#![cfg(feature = "pil")]

mod pil_common;

use std::cell::RefCell;
use std::rc::Rc;

use host_sim::f446::cpu::Core;
use host_sim::f446::gpio::Drive;
use host_sim::f446::soc::Soc;
use host_sim::f446::{FLASH_BASE, TIME_HZ, Time};
use host_sim::sensor::eeprom;
use host_sim::sensor::sim_time::SimClock;
use host_sim::sensor::virtual_mlx::VirtualMlx90640;
use pil_common::elf;

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
    start(soc, &img)
}

/// The core on `soc`, its flash as the chip's array holds it (the ELF and any record).
fn start(soc: Soc, img: &host_sim::f446::elf::Image) -> Core {
    let flash = vec![(FLASH_BASE, soc.flash.array().to_vec())];
    let mut core = Core::new(Box::new(soc), &flash, &img.code).unwrap();
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
    assert!(version.ends_with("\r\n"), "{version:?}");
    pil_common::assert_names_its_build(version.trim_end());
    // A power-up with default settings starts stopped, every output off.
    let status = exchange(&mut core, "status", 0.2);
    assert!(status.starts_with("ok mode=stopped "), "{status:?}");
    let s = soc(&mut core);
    assert_eq!(s.tims[1].pwm_duty(1), 0.0, "the heater (TIM3 CH1) off");
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

/// The chip's flash region 3 (sectors 5–7, 0x0802_0000, 384 KiB) as embassy's blocking flash
/// gives it to the board's store: 4-byte writes over erased bytes only, 128 KiB erases.
struct Region3(Vec<u8>);

#[derive(Debug)]
struct NorError;

impl embedded_storage_async::nor_flash::NorFlashError for NorError {
    fn kind(&self) -> embedded_storage_async::nor_flash::NorFlashErrorKind {
        embedded_storage_async::nor_flash::NorFlashErrorKind::Other
    }
}

impl embedded_storage_async::nor_flash::ErrorType for Region3 {
    type Error = NorError;
}

impl embedded_storage_async::nor_flash::ReadNorFlash for Region3 {
    const READ_SIZE: usize = 1;
    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), NorError> {
        let at = offset as usize;
        bytes.copy_from_slice(self.0.get(at..at + bytes.len()).ok_or(NorError)?);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.0.len()
    }
}

impl embedded_storage_async::nor_flash::NorFlash for Region3 {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 128 * 1024;
    async fn erase(&mut self, from: u32, to: u32) -> Result<(), NorError> {
        self.0[from as usize..to as usize].fill(0xFF);
        Ok(())
    }
    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), NorError> {
        let at = offset as usize;
        let dst = &mut self.0[at..at + bytes.len()];
        if dst.iter().any(|&b| b != 0xFF) {
            return Err(NorError);
        }
        dst.copy_from_slice(bytes);
        Ok(())
    }
}

/// Region 3's offset in the flash array, and the board's settings range within it
/// (`SETTINGS_RANGE` in the board's code: sectors 6 and 7).
const REGION3: std::ops::Range<usize> = 0x2_0000..0x8_0000;
const SETTINGS: std::ops::Range<u32> = 0x2_0000..0x6_0000;

/// `save` on the ELF writes a record the library's store reads back (the settings changed
/// before it), and a record the library writes is what the ELF boots with.
#[test]
fn the_elfs_flash_record_and_the_librarys_are_the_same() {
    use embassy_futures::block_on;
    use thermorph::settings::Settings;
    use thermorph::storage::FlashStore;

    let mut core = board();
    core.run_until(TIME_HZ).unwrap();
    let set = exchange(&mut core, "set hot_k 361", 0.1);
    assert!(set.starts_with("ok hot_k=361"), "{set:?}");
    // A save writes (and may erase: 2 s a 128 KiB sector at the x8 parallelism embassy uses).
    let saved = exchange(&mut core, "save", 6.0);
    assert!(saved.starts_with("ok"), "{saved:?}");
    let region = soc(&mut core).flash.array()[REGION3].to_vec();
    let mut store = FlashStore::new(Region3(region), SETTINGS.clone()).unwrap();
    let mut said = String::new();
    let s = block_on(store.boot_settings(&mut said));
    assert!(said.is_empty(), "{said}");
    assert_eq!(s.hot_k, 361.0, "the library reads the ELF's record");
    // And back: the library's record of other settings, placed in a fresh board's flash.
    let mut mine = Settings::DEFAULT;
    mine.hot_k = 362.0;
    let mut store = FlashStore::new(Region3(vec![0xFF; REGION3.len()]), SETTINGS.clone()).unwrap();
    block_on(store.write(&mine.encode())).unwrap();
    let bytes = store.release().0;
    let range = SETTINGS.start as usize..SETTINGS.end as usize;
    let img = host_sim::f446::elf::load(&elf()).unwrap();
    let mut soc_ = Soc::new();
    for (a, b) in &img.flash {
        soc_.flash.load(*a, b).unwrap();
    }
    // Sectors 6 and 7 only: sector 5 holds the program's end.
    let at = FLASH_BASE + (REGION3.start + range.start) as u32;
    soc_.flash.load(at, &bytes[range]).unwrap();
    soc_.gpio[2].set_input(13, Drive::High);
    let mut core = start(soc_, &img);
    core.run_until(TIME_HZ).unwrap();
    let got = exchange(&mut core, "get hot_k", 0.1);
    assert!(
        got.starts_with("ok hot_k=362"),
        "the ELF boots with the library's: {got:?}"
    );
}

/// The e-stop button (PC13, active low, EXTI13 on its falling edge) latches `estop` on the
/// ELF within a tick, heater and fan off; released, `reset` clears it.
#[test]
fn the_button_latches_an_estop_through_exti() {
    let mut core = board();
    core.run_until(TIME_HZ).unwrap();
    let standby = exchange(&mut core, "mode standby", 0.5);
    assert!(standby.starts_with("ok mode standby"), "{standby:?}");
    assert!(soc(&mut core).tims[1].pwm_duty(1) > 0.0, "standby heats");
    let pressed = core.now();
    soc(&mut core).gpio[2].set_input(13, Drive::Low);
    core.run_until(pressed + TIME_HZ / 20).unwrap();
    assert_eq!(
        soc(&mut core).tims[1].pwm_duty(1),
        0.0,
        "heater off within a tick"
    );
    let status = exchange(&mut core, "status", 0.1);
    assert!(status.contains("fault=estop"), "{status}");
    soc(&mut core).gpio[2].set_input(13, Drive::High);
    core.run_until(core.now() + TIME_HZ / 10).unwrap();
    let reset = exchange(&mut core, "reset", 0.2);
    assert!(reset.starts_with("ok"), "{reset:?}");
    assert!(core.bus_faults().is_empty(), "{:?}", core.bus_faults());
}

/// `run SCENE --board ELF` reads the board's defmt frames off RTT up channel 0 and decodes
/// them with the ELF's table into `defmt.log`: the boot's `info!` lines (`board.rs`: the
/// version, the reset cause, the springs' memory kept, the camera configured) and a `warn!` for
/// every notice the board also wrote on its console (`write_notice`), each with the board's
/// uptime as its timestamp; the summary names the file.
#[test]
fn the_boards_defmt_frames_are_decoded_into_the_runs_log() {
    use host_sim::runs::scenario;
    use thermorph::supervisor::ResetCause;

    let dir = std::env::temp_dir().join(format!("thermorph-pil-defmt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("boot.toml");
    std::fs::write(
        &scene,
        "name = \"boot\"\nduration = \"2 s\"\nperiod = \"0.25 s\"\nambient = \"298.15 K\"\n\
         [fidelity]\ncamera = true\n[camera]\nseed = 1\n[[command]]\nat = \"1 s\"\nline = \"status\"\n",
    )
    .unwrap();
    scenario::load(scene.to_str().unwrap()).expect("a scene of the board's");
    let out_dir = dir.join("out");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["run", scene.to_str().unwrap(), "--board"])
        .arg(elf())
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains(&format!("{}/defmt.log", out_dir.display())),
        "{stdout}"
    );
    let log = std::fs::read_to_string(out_dir.join("defmt.log")).unwrap();
    // `   0.004321 INFO  message`: the board's uptime, the level, the message.
    let lines: Vec<(f64, &str, &str)> = log
        .lines()
        .map(|l| {
            let frame = || -> Option<(f64, &str, &str)> {
                let t = l.get(..11)?.trim().parse().ok()?;
                Some((t, l.get(12..17)?.trim(), l.get(18..)?))
            };
            frame().unwrap_or_else(|| panic!("not a frame: {l:?}\n{log}"))
        })
        .collect();
    let has = |level: &str, text: &str| lines.iter().any(|l| l.1 == level && l.2 == text);
    // `thermorph 0.1.0 (b98b8ce 2026-11-29) up`: the version and the build.
    let up = format!("thermorph {} (", thermorph::VERSION);
    let build = lines
        .iter()
        .find_map(|l| l.2.strip_prefix(up.as_str())?.strip_suffix(") up"))
        .unwrap_or_else(|| panic!("no INFO {up}HASH DATE) up in\n{log}"));
    pil_common::assert_this_build(build);
    for text in [
        format!("reset cause: {:?}", ResetCause::Pin),
        "springs: memory kept across the reset".to_string(),
        "MLX90640 calibrated and configured".to_string(),
    ] {
        assert!(has("INFO", &text), "no INFO {text:?} in\n{log}");
    }
    // Every console warning (`# warning: …`) is also a `warn!` of its notice.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    let warnings = summary["warnings"].as_array().unwrap();
    assert!(!warnings.is_empty(), "the reset's notice: {summary}");
    for w in warnings {
        let text = format!("warning: {}", w["text"].as_str().unwrap());
        assert!(has("WARN", &text), "no WARN {text:?} in\n{log}");
    }
    // The uptime is the run's time (less the few ms before embassy's time driver starts), in
    // order.
    assert!(
        lines.windows(2).all(|w| w[0].0 <= w[1].0),
        "timestamps out of order:\n{log}"
    );
    assert!(
        lines.iter().all(|l| (0.0..2.0).contains(&l.0)),
        "uptimes beyond the run:\n{log}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
