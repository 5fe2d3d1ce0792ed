//! `host-sim run SCENE --board ELF` (`--features pil`): a scene played with the board's own ELF
//! on the emulated STM32F446 in place of the library's controller — the same plant, the same
//! camera view shown to the virtual MLX90640 on the chip's I2C1, the same injected faults, the
//! scene's console lines typed into the chip's USART2, and its e-stop button actions on PC13
//! (low pressed, high released, at the action's time to the µs: an edge to EXTI13).
//!
//! What the ELF drives is read off its pins every millisecond (TIM3 CH1's and TIM4 CH1's duty,
//! the spring gates PA8/PB5/PB10 and the spring power enable PA9; every change is kept,
//! [`ElfRun::outputs`]) and drives the plant from then; the spring channels' ADC inputs are the
//! plant's currents and supplies through the simulated front end (`rig::channels`). Its state
//! for the time series comes from its own telemetry, which the harness turns on at power-up
//! (`stream on 4`: its reply is not a scene's line and is not recorded); a latched fault shows
//! there as a change of `fault=`, and is dated by the board's own event log
//! ([`run_elf_traced`]). [`run_elf_with`] lets a script type lines as that state changes (`host-sim paper --board`,
//! [`crate::runs::elf_paper`]).
//!
//! [`ElfConsole`] and [`replay_lines`] serve the ELF's console as `host-sim console` serves the
//! library's: lines typed one at a time, each reply read back (`tests/pil_console.rs` replays
//! `docs/console.md`'s session with them). They are a function and not a `host-sim console
//! --board` mode: the console paces simulated time by the wall clock, which an emulation at
//! ≈ 10× real time cannot promise, while a replay in simulated time is the same every run.
//!
//! The board's defmt log is read as a probe reads it: RTT up channel 0 (`f446::rtt`) after
//! every millisecond of the chip's time and just before each chip reset (the start-up code
//! clears the channel), decoded with the ELF's `.defmt` table (`runs::defmt_log`) into the
//! run's `log` (written as `defmt.log`).

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::path::Path;
use std::rc::Rc;
use std::sync::Mutex;
use std::time::Instant;

use thermorph::channels::FRONT_END;
use thermorph::observer::Observer;
use thermorph::posture::Bend;
use thermorph::settings::Settings;
use thermorph::supervisor::SpringMemory;

use crate::f446::Peripheral;
use crate::f446::cpu::Core;
use crate::f446::gpio::Drive;
use crate::f446::rcc::ResetCause;
use crate::f446::rtt::{RttError, RttUp};
use crate::f446::soc::Soc;
use crate::f446::{FLASH_BASE, TIME_HZ};
use crate::imaging::view::Layout;
use crate::plant::{Inputs, Plant};
use crate::rig::camera::{CameraFaults, camera_temps, render_field};
use crate::rig::{FaultRecord, RigError, apply_faults, channels};
use crate::runs::defmt_log::DefmtLog;
use crate::runs::run::{LogRecord, ReplyRecord, RunError, RunResult, WarningRecord, summarise};
use crate::runs::scenario::Scenario;
use crate::runs::series::{ControlRow, Row};
use crate::sensor::eeprom;
use crate::sensor::sim_time::SimClock;
use crate::sensor::virtual_mlx::VirtualMlx90640;

/// The board's control tick, µs: the harness reads the pins and steps the plant at it.
const TICK_US: u64 = 50_000;

/// The harness looks at the chip's pins this often within a tick, µs.
const SUB_US: u64 = 1_000;

/// Lines typed before this (the board's clocks, USART2 and tasks are up after ≈ 10 ms) wait
/// for it, µs: bytes sent to a receiver not yet enabled would be lost, as on the board.
const CONSOLE_UP_US: u64 = 100_000;

/// Why the ELF cannot play a scene.
#[derive(Debug, thiserror::Error)]
pub enum ElfRunError {
    /// The ELF is refused.
    #[error(transparent)]
    Elf(#[from] crate::f446::elf::ElfError),
    /// The emulated core stopped.
    #[error(transparent)]
    Core(#[from] crate::f446::cpu::CpuError),
    /// The scene, the plant or the camera could not be built.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The emulated board could not be built.
    #[error("the emulated board: {0}")]
    Board(String),
    /// A line typed on the console got no reply in [`REPLY_WITHIN_S`] of simulated time.
    #[error("the board did not answer `{line}` within {after_s} s")]
    NoReply {
        /// The line typed (non-printable bytes escaped).
        line: String,
        /// How long it waited, s of simulated time.
        after_s: f64,
    },
    /// The scene has no console line: the board only plays closed-loop scenes.
    #[error(
        "scene {0}: the board's ELF plays closed-loop scenes only (an open-loop scene drives the \
         plant's inputs itself; give it `[[command]]` lines)"
    )]
    OpenLoop(String),
}

/// Intern a telemetry word as a `&'static str` (the time series' fields are static names).
fn intern(word: &str) -> &'static str {
    static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(&n) = names.get(word) {
        return n;
    }
    let leaked: &'static str = Box::leak(word.to_string().into_boxed_str());
    names.insert(leaked);
    leaked
}

/// A telemetry line's `name=value` fields.
fn field<'a>(line: &'a str, name: &str) -> Option<&'a str> {
    line.split(' ')
        .find_map(|w| w.strip_prefix(name).and_then(|r| r.strip_prefix('=')))
}

fn number(line: &str, name: &str) -> f64 {
    field(line, name)
        .and_then(|v| v.parse().ok())
        .unwrap_or(f64::NAN)
}

/// The supervisor's state as the ELF's telemetry line gives it (the estimate's fields it
/// carries; the others NaN).
fn control_of(line: &str) -> ControlRow {
    let mut e = Observer::new(&Settings::DEFAULT.observer_params(), f32::NAN).estimate();
    let f = |n: &str| number(line, n) as f32;
    e.frozen = f("frozen_pct") / 100.0;
    e.frozen_std = f("frozen_std_pct") / 100.0;
    e.layers_k[0] = f("inner_k");
    e.layers_std_k[0] = f("inner_std_k");
    e.ambient_k = f("ambient_est_k");
    e.ambient_std_k = f("ambient_std_k");
    for (i, s) in ["a", "b", "c"].iter().enumerate() {
        e.springs_k[i] = f(&format!("spring_{s}_k"));
        e.springs_std_k[i] = f(&format!("spring_{s}_std_k"));
        e.austenite[i] = f(&format!("aus_{s}_pct")) / 100.0;
        e.austenite_std[i] = f(&format!("aus_{s}_std_pct")) / 100.0;
        e.springs_wire_k[i] = f32::NAN;
    }
    let fault = field(line, "fault").filter(|&f| f != "none").map(intern);
    ControlRow {
        estimate: e,
        bend: Bend {
            deg: f("bend_deg"),
            sd_deg: f("bend_sd_deg"),
        },
        model_bend_deg: f64::NAN,
        mode: intern(field(line, "mode").unwrap_or("-")),
        phase: intern(field(line, "phase").unwrap_or("-")),
        target_k: number(line, "target_k"),
        tc_k: number(line, "tc_k"),
        fault,
        spring_a: [f64::NAN; 3],
    }
}

/// What a probe takes off the chip's RTT up channel 0: shared with the core's reset hook, which
/// reads it once more before a reset clears it.
struct Probe {
    rtt: RttUp,
    /// Bytes taken, not yet decoded.
    bytes: Vec<u8>,
    /// Why the last read found no usable channel (None: it read, or found none set up yet).
    refused: Option<RttError>,
}

impl Probe {
    /// Take what the board logged since the last read.
    fn read(&mut self, mem: &mut dyn crate::f446::Memory) {
        self.refused = match self.rtt.drain(mem, &mut self.bytes) {
            Ok(_) | Err(RttError::NoControlBlock(_)) => None,
            Err(e) => Some(e),
        };
    }
}

/// The board's defmt log as the run reads it.
struct BoardLog {
    probe: Rc<RefCell<Probe>>,
    log: DefmtLog,
    /// The refusal last noted in the log (noted again only when it changes).
    noted: Option<RttError>,
    /// Each record on standard error too (`THERMORPH_PIL_CONSOLE`).
    echo: bool,
}

/// The emulated board and the block it drives.
struct ElfBoard {
    plant: Plant,
    core: Core,
    faults: Vec<crate::rig::faults::FaultSpec>,
    sensing: channels::Sensing,
    /// The camera's sensor (None: the scene's camera is off, the board sees nothing).
    device: Option<Rc<RefCell<VirtualMlx90640>>>,
    azimuth_deg: f64,
    layout: Option<Layout>,
    view_k: Box<[f64; thermorph::mtts::IMG_PIXELS]>,
    time_us: u64,
    /// What the ELF drove at the last tick, before faults.
    commanded: Inputs,
    /// Bytes the ELF wrote that do not make a whole line yet.
    partial: String,
    /// Bytes typed before the console is up ([`CONSOLE_UP_US`]).
    typed: Vec<u8>,
    /// The defmt log (None: the ELF has no RTT control block).
    log: Option<BoardLog>,
    /// The scene's e-stop button from its actions: (µs, pressed), in time order, not yet
    /// driven on PC13.
    buttons: std::collections::VecDeque<(u64, bool)>,
    /// Every change of what the ELF drives, as the harness saw it at its looks ([`SUB_US`]).
    trace: Vec<OutputChange>,
}

/// What the ELF drove from a time on, as the harness read its pins (before injected faults).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputChange {
    /// When the harness saw it, s: the pins changed within the [`SUB_US`] before.
    pub at_s: f64,
    /// The heater's and fan's duties, the spring gates and the spring power as driven.
    pub outputs: Inputs,
}

impl OutputChange {
    /// The heater off, every spring gate off and the spring power off.
    pub fn heater_and_springs_off(&self) -> bool {
        let o = &self.outputs;
        o.heater_duty == 0.0 && !o.springs_on.iter().any(|s| *s) && o.spring_power_off
    }
}

/// A scene played by the ELF: the run as `host-sim run` reports it, and what the ELF drove at
/// the harness's resolution.
#[derive(Clone, Debug)]
pub struct ElfRun {
    /// The time series and summary.
    pub result: RunResult,
    /// Every change of the ELF's outputs, with the first (at 0 s) what it drove from the start.
    pub outputs: Vec<OutputChange>,
}

/// How the emulated board starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// A reset by its pin, its RAM holding the springs' memory of springs at rest: as the
    /// library's board starts in every run ([`run_elf`]).
    PinRested,
    /// A power-up (nothing kept in RAM: the ELF assumes the springs hot), as `host-sim
    /// console` boots its block ([`ElfConsole`]).
    PowerUp,
}

impl ElfBoard {
    fn new(scenario: &Scenario, elf: &Path, start: Start) -> Result<ElfBoard, ElfRunError> {
        let block = scenario.block();
        let data = crate::f446::elf::read(elf)?;
        let img = crate::f446::elf::parse(&data, &elf.display().to_string())?;
        let plant = Plant::with_options(&block.plant, block.options)
            .map_err(|e| RunError::from(RigError::from(e)))?;
        let mut soc = Soc::new();
        for (a, b) in &img.flash {
            soc.flash.load(*a, b).map_err(ElfRunError::Board)?;
        }
        // The e-stop button released (B1 pulls PC13 high).
        soc.gpio[2].set_input(13, Drive::High);
        let device = if block.camera.enabled {
            let clock = SimClock::new();
            let words = eeprom::realistic(block.camera.seed)
                .encode()
                .map_err(|e| ElfRunError::Board(e.to_string()))?;
            let mut dev = VirtualMlx90640::new(words, clock.clone(), block.camera.seed)
                .map_err(|e| ElfRunError::Board(format!("{e:?}")))?;
            dev.noise_k = block.camera.noise_k;
            let dev = Rc::new(RefCell::new(dev));
            soc.attach_sensor(dev.clone(), clock);
            Some(dev)
        } else {
            None
        };
        if start == Start::PinRested {
            // As the library's board in every run: springs at rest that the board knows of (a
            // reset by its pin long after they were last driven, the memory kept in RAM), not
            // a power-up's assumption of hot springs.
            soc.rcc.write(0x74, crate::f446::Size::Word, 1 << 24);
            soc.rcc.reset(ResetCause::Pin);
        }
        let flash = vec![(FLASH_BASE, soc.flash.array().to_vec())];
        let mut core = Core::new(Box::new(soc), &flash, &img.code)?;
        if let (Start::PinRested, Some(at)) = (start, img.spring_memory) {
            let words = SpringMemory::RESTED.to_words();
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            core.write_bytes(at, &bytes)?;
        }
        core.reset()?;
        let log = img.rtt.map(|at| {
            let probe = Rc::new(RefCell::new(Probe {
                rtt: RttUp::new(at),
                bytes: Vec::new(),
                refused: None,
            }));
            let before_reset = probe.clone();
            core.on_reset(Box::new(move |mem| before_reset.borrow_mut().read(mem)));
            BoardLog {
                probe,
                log: DefmtLog::new(&data),
                noted: None,
                echo: std::env::var_os("THERMORPH_PIL_CONSOLE").is_some(),
            }
        });
        let seed = block.camera.seed;
        let mut board = ElfBoard {
            plant,
            core,
            faults: block.faults.clone(),
            sensing: channels::Sensing::new(channels::SenseErrors::drawn(seed), seed),
            device,
            azimuth_deg: block.camera.azimuth_deg,
            layout: None,
            view_k: Box::new([0.0; thermorph::mtts::IMG_PIXELS]),
            time_us: 0,
            commanded: Inputs::default(),
            partial: String::new(),
            typed: Vec::new(),
            log,
            buttons: scenario
                .actions
                .iter()
                .filter_map(|a| Some(((a.at_s * 1e6).round() as u64, a.button?)))
                .collect(),
            trace: Vec::new(),
        };
        board.show(CameraFaults::default());
        board.analog(&Inputs::default());
        Ok(board)
    }

    fn soc(&mut self) -> &mut Soc {
        self.core.bus_as_mut::<Soc>().expect("built on the Soc")
    }

    /// Show the camera the plant now.
    fn show(&mut self, faults: CameraFaults) {
        let obs = self.plant.observe();
        if let Some(dev) = &self.device {
            let mut d = dev.borrow_mut();
            d.set_fault(faults.sensor);
            render_field(
                &obs,
                faults,
                self.azimuth_deg,
                &mut self.layout,
                &mut self.view_k,
                &mut d.field_k,
            );
        }
    }

    /// The spring channels' analog inputs for the plant's flows under `inputs`, for every
    /// state of the gates and the power enable the ELF may switch to before the next look
    /// (`Soc::set_spring_analog`): currents on ADC1 IN0/IN1/IN4, supplies on IN8/IN11/IN10
    /// (`pins.rs`), through the simulated front end's counts.
    fn analog(&mut self, inputs: &Inputs) {
        // The pin's volts: the ADC's reference over its 4096 counts.
        let v = f64::from(FRONT_END.adc_ref_v) / 4096.0;
        let mut table = Box::new([[0.0; 6]; 16]);
        for (state, row) in table.iter_mut().enumerate() {
            let i = Inputs {
                springs_on: [state & 1 != 0, state & 2 != 0, state & 4 != 0],
                spring_power_off: state & 8 == 0,
                ..*inputs
            };
            let flows = self.plant.channel_flows(&i);
            let counts = self
                .sensing
                .scan(flows.map(|f| f.current_a), flows.map(|f| f.supply_v));
            for k in 0..3 {
                row[k] = f64::from(counts.current[k]) * v;
                row[3 + k] = f64::from(counts.supply[k]) * v;
            }
        }
        self.soc().set_spring_analog(table);
    }

    /// What the ELF drives now.
    fn outputs(&mut self) -> Inputs {
        let s = self.soc();
        let pin = |port: usize, n: usize| s.gpio[port].output(n).unwrap_or(false);
        Inputs {
            heater_duty: s.tims[1].pwm_duty(1),
            fan_duty: s.tims[2].pwm_duty(1),
            springs_on: [pin(0, 8), pin(1, 5), pin(1, 10)],
            spring_power_off: !pin(0, 9),
            ..Inputs::default()
        }
    }

    /// Read the board's RTT up channel as a probe does and decode what it logged.
    fn read_log(&mut self) {
        let Some(b) = &mut self.log else {
            return;
        };
        let at_s = self.time_us as f64 * 1e-6;
        let mut p = b.probe.borrow_mut();
        p.read(&mut self.core);
        if p.refused != b.noted {
            if let Some(e) = &p.refused {
                b.log.note(at_s, format!("RTT not read: {e}"));
            }
            b.noted = p.refused.clone();
        }
        if p.bytes.is_empty() {
            return;
        }
        let bytes = std::mem::take(&mut p.bytes);
        drop(p);
        let records = b.log.push(&bytes, at_s);
        if b.echo {
            for r in records {
                eprintln!("{at_s:9.3} defmt {r}");
            }
        }
    }

    /// Type `line` on the console (once it is up).
    fn type_line(&mut self, line: &str) {
        self.type_bytes(line.as_bytes());
    }

    /// Type `line`'s bytes and CR LF on the console (once it is up).
    fn type_bytes(&mut self, line: &[u8]) {
        self.typed.extend_from_slice(line);
        self.typed.extend_from_slice(b"\r\n");
        if self.time_us >= CONSOLE_UP_US {
            let bytes: Vec<u8> = self.typed.drain(..).collect();
            self.soc().usart2.receive_bytes(&bytes);
        }
    }

    /// Drive PC13 for the scene's button actions due by now: low pressed (B1 shorts it to
    /// ground), high released (the pull-up); a change is an edge to EXTI13.
    fn press_due(&mut self) {
        while let Some(&(at_us, pressed)) = self.buttons.front() {
            if at_us > self.time_us {
                break;
            }
            self.buttons.pop_front();
            let drive = if pressed { Drive::Low } else { Drive::High };
            self.soc().gpio[2].set_input(13, drive);
        }
    }

    /// Record what the ELF drives now if it changed since the last look.
    fn trace_outputs(&mut self) {
        let outputs = self.outputs();
        if self.trace.last().is_none_or(|c| c.outputs != outputs) {
            self.trace.push(OutputChange {
                at_s: self.time_us as f64 * 1e-6,
                outputs,
            });
        }
    }

    /// One tick: the chip to the next tick in steps of [`SUB_US`] (and to each button action's
    /// time, when PC13 changes), its pins read after each (the spring channels' analog inputs
    /// follow a gate at once, as the circuit does), the plant run with what they drove; the
    /// lines the ELF wrote, each with the time its last byte left the port, s.
    #[allow(clippy::type_complexity)]
    fn tick(&mut self) -> Result<(Inputs, u32, CameraFaults, Vec<(f64, String)>), ElfRunError> {
        let t_s = self.time_us as f64 * 1e-6;
        if self.time_us >= CONSOLE_UP_US && !self.typed.is_empty() {
            let bytes: Vec<u8> = self.typed.drain(..).collect();
            self.soc().usart2.receive_bytes(&bytes);
        }
        self.press_due();
        self.commanded = self.outputs();
        self.trace_outputs();
        let mut inputs = self.commanded;
        let (mask, cam) = apply_faults(&self.faults, t_s, &mut inputs);
        let first = inputs;
        self.show(cam);
        let next = self.time_us + TICK_US;
        let mut held_from = self.time_us;
        // The channels' inputs for every state of the pins (the pins' state picks the row at
        // each conversion), with the front end's noise drawn anew at each tick and wherever the
        // plant runs (as the library's board draws it once a tick).
        self.analog(&inputs);
        while self.time_us < next {
            let mut to = (self.time_us + SUB_US).min(next);
            if let Some(&(at_us, _)) = self.buttons.front() {
                to = to.min(at_us.max(self.time_us + 1));
            }
            self.core.run_until(to * (TIME_HZ / 1_000_000))?;
            self.time_us = to;
            self.read_log();
            self.press_due();
            self.trace_outputs();
            let mut now = self.outputs();
            apply_faults(&self.faults, t_s, &mut now);
            if now != inputs || to == next {
                self.plant.step(&inputs, (to - held_from) as f64 * 1e-6);
                held_from = to;
                inputs = now;
                if to < next {
                    self.analog(&inputs);
                }
            }
        }
        let inputs = first;
        let bytes = self.soc().usart2.take_transmitted();
        let mut lines = Vec::new();
        for b in bytes {
            self.partial.push(char::from(b.byte));
            if let Some(line) = self.partial.strip_suffix("\r\n") {
                lines.push((b.end as f64 / TIME_HZ as f64, line.to_string()));
                self.partial.clear();
            }
        }
        Ok((inputs, mask, cam, lines))
    }
}

/// A line typed on the ELF's console, waiting for its reply (the board replies in line order).
enum Awaiting {
    /// A scene's line: when it was due, s, and the line.
    Scene(f64, String),
    /// The harness's `stream on 4` (its reply is not recorded).
    Stream,
    /// The harness's `log` after a change of the latched fault (its reply dates it).
    Log,
}

/// The fault events of a `log` reply (`ok events=N | 12.35 fault estop (emergency stop) | …`)
/// with their place among all the board's events: (index, board time s, code, reason). `None`
/// for a reply that is not a log.
fn log_faults(reply: &str) -> Option<Vec<(u32, f64, String, String)>> {
    let mut parts = reply.split(" | ");
    let total: u32 = parts.next()?.strip_prefix("ok events=")?.parse().ok()?;
    let events: Vec<&str> = parts.collect();
    let first = total.checked_sub(events.len() as u32)?;
    let mut faults = Vec::new();
    for (i, e) in events.iter().enumerate() {
        let (t, what) = e.split_once(' ')?;
        let Some(fault) = what.strip_prefix("fault ") else {
            continue;
        };
        let (code, reason) = fault.split_once(' ').unwrap_or((fault, ""));
        let reason = reason
            .strip_prefix('(')
            .and_then(|r| r.strip_suffix(')'))
            .unwrap_or(reason);
        faults.push((
            first + i as u32,
            t.parse().ok()?,
            code.to_string(),
            reason.to_string(),
        ));
    }
    Some(faults)
}

/// Play `scenario` with the ELF at `elf`.
pub fn run_elf(
    scenario: &Scenario,
    elf: &Path,
    progress: &mut dyn FnMut(f64),
) -> Result<RunResult, ElfRunError> {
    run_elf_with(scenario, elf, progress, &mut |_, _| None)
}

/// Decides console lines from the board's state at a scene period's start (time s, its state
/// from its latest telemetry line): [`run_elf_with`]'s counterpart of
/// [`crate::runs::run::Reactor`].
pub type ElfReactor<'a> = dyn FnMut(f64, &ControlRow) -> Option<String> + 'a;

/// [`run_elf`], with `react` able to type console lines as the board's state changes, as
/// [`crate::runs::run::run_with`]'s reactor does for the library: at each scene period's start
/// (after the scene's lines due then) it sees the board's state as its latest telemetry line
/// gave it (telemetry runs at 4 Hz, so up to a quarter second old; not called before the
/// first), and a line it returns is typed at the next period's start, the reaction time of
/// someone polling `status`, one scene period.
pub fn run_elf_with(
    scenario: &Scenario,
    elf: &Path,
    progress: &mut dyn FnMut(f64),
    react: &mut ElfReactor<'_>,
) -> Result<RunResult, ElfRunError> {
    Ok(run_elf_traced_with(scenario, elf, progress, react)?.result)
}

/// [`run_elf`], with every change of what the ELF drove as the harness saw it (every
/// [`SUB_US`]).
///
/// The run's latched faults are the board's own events: when its telemetry's `fault=`
/// changes (a fault latched, or an e-stop over one), the harness types `log` (its reply is not
/// recorded) and takes each new fault's code, reason and time from it — the same event the
/// library's run records, to the log's 10 ms, on the board's clock (which starts when
/// embassy's time driver does, a few ms after the chip's reset: the harness measures the
/// difference from the telemetry lines' `t_s` and the times their bytes left the port, and
/// adds it). Should a `log` reply not come before the scene ends, the fault stays as its
/// telemetry showed it (code only, the line's time).
pub fn run_elf_traced(
    scenario: &Scenario,
    elf: &Path,
    progress: &mut dyn FnMut(f64),
) -> Result<ElfRun, ElfRunError> {
    run_elf_traced_with(scenario, elf, progress, &mut |_, _| None)
}

/// [`run_elf_traced`] with [`run_elf_with`]'s `react`.
pub fn run_elf_traced_with(
    scenario: &Scenario,
    elf: &Path,
    progress: &mut dyn FnMut(f64),
    react: &mut ElfReactor<'_>,
) -> Result<ElfRun, ElfRunError> {
    if scenario.commands.is_empty() {
        return Err(ElfRunError::OpenLoop(scenario.name.clone()));
    }
    let started = Instant::now();
    let mut b = ElfBoard::new(scenario, elf, Start::PinRested)?;
    let period_us = ((scenario.period_s * 1e6).round() as u64).max(TICK_US);
    let steps = (scenario.duration_s / scenario.period_s).round().max(1.0) as usize;
    let mut rows = Vec::with_capacity(steps);
    let mut replies: Vec<ReplyRecord> = Vec::new();
    let mut waiting: std::collections::VecDeque<Awaiting> = std::collections::VecDeque::new();
    let mut warnings = Vec::new();
    // Faults from the board's log, and those its telemetry showed that no log dated yet.
    let mut faults: Vec<FaultRecord> = Vec::new();
    let mut undated: Vec<FaultRecord> = Vec::new();
    let mut events_seen = 0u32;
    // Harness time less the board's clock, s: at most each telemetry line's last byte's end
    // less its bytes' time on the wire less its `t_s` (the line was written in the period it
    // dates, no later than its first byte left); the least such bound, from a line that did
    // not wait behind another, is within the clock's 1 ms of the truth.
    let mut clock_offset_s = f64::INFINITY;
    let mut control: Option<ControlRow> = None;
    let mut next_command = 0;
    let console = std::env::var_os("THERMORPH_PIL_CONSOLE").is_some();
    // The harness's own line: telemetry at the scene's rate is the time series' control state.
    b.type_line("stream on 4");
    waiting.push_back(Awaiting::Stream);
    let mut inputs = (Inputs::default(), 0, CameraFaults::default());
    // A line `react` decided at a period's start, typed at the next one's.
    let mut reacted: Option<String> = None;
    for k in 0..steps {
        let t1_us = (k as u64 + 1) * period_us;
        let row_start = (inputs.0, inputs.1, b.commanded.springs_on, control);
        let mut period_start = true;
        while b.time_us < t1_us {
            let t_s = b.time_us as f64 * 1e-6;
            while let Some(c) = scenario
                .commands
                .get(next_command)
                .filter(|c| c.at_s <= t_s + 1e-9)
            {
                b.type_line(&c.line);
                waiting.push_back(Awaiting::Scene(c.at_s, c.line.clone()));
                next_command += 1;
            }
            if std::mem::take(&mut period_start) {
                if let Some(line) = reacted.take() {
                    b.type_line(&line);
                    waiting.push_back(Awaiting::Scene(t_s, line));
                }
                reacted = control.as_ref().and_then(|c| react(t_s, c));
            }
            let (i, mask, cam, lines) = b.tick()?;
            inputs = (i, mask, cam);
            for (at_s, line) in lines {
                if console {
                    eprintln!("{at_s:9.4} | {line}");
                }
                if let Some(t) = line.strip_prefix("# t_s=").map(|_| line.as_str()) {
                    let s = b.soc();
                    if let Some(frame) = s.usart2.frame_time(&s.rcc.clocks()) {
                        let wire_s = (line.len() + 2) as f64 * frame as f64 / TIME_HZ as f64;
                        clock_offset_s = clock_offset_s.min(at_s - wire_s - number(t, "t_s"));
                    }
                    let c = control_of(t);
                    let before = control.and_then(|p| p.fault);
                    if let Some(code) = c.fault.filter(|&f| Some(f) != before) {
                        undated.push(FaultRecord {
                            at_s,
                            code: code.to_string(),
                            reason: String::new(),
                        });
                        b.type_line("log");
                        waiting.push_back(Awaiting::Log);
                    }
                    control = Some(c);
                } else if let Some(w) = line.strip_prefix("# warning: ") {
                    warnings.push(WarningRecord {
                        at_s,
                        text: w.to_string(),
                    });
                } else if line.starts_with('#') {
                } else {
                    match waiting.pop_front() {
                        Some(Awaiting::Scene(at_s, l)) => replies.push(ReplyRecord {
                            at_s,
                            line: l,
                            reply: line,
                        }),
                        Some(Awaiting::Log) => {
                            if let Some(events) = log_faults(&line) {
                                for (index, board_s, code, reason) in events {
                                    if index >= events_seen {
                                        faults.push(FaultRecord {
                                            at_s: board_s,
                                            code,
                                            reason,
                                        });
                                    }
                                }
                                events_seen = line
                                    .strip_prefix("ok events=")
                                    .and_then(|r| r.split(' ').next())
                                    .and_then(|n| n.parse().ok())
                                    .unwrap_or(events_seen);
                                // This log dates the change that asked for it.
                                if !undated.is_empty() {
                                    undated.remove(0);
                                }
                            }
                        }
                        Some(Awaiting::Stream) | None => {}
                    }
                }
            }
        }
        let (inputs_at, mask, springs_cmd, control_at) = row_start;
        let obs = b.plant.observe();
        rows.push(Row {
            inputs: inputs_at,
            springs_cmd,
            obs,
            measured_k: None,
            quality: None,
            truth_k: camera_temps(&obs).regions(),
            faults: mask,
            control: control_at,
        });
        progress((k + 1) as f64 / steps as f64);
    }
    let wall_s = started.elapsed().as_secs_f64();
    if console {
        let (slices, sleeps) = b.core.stats();
        eprintln!(
            "{} instructions, {slices} slices, {sleeps} sleeps",
            b.core.instructions()
        );
    }
    let offset_s = if clock_offset_s.is_finite() {
        clock_offset_s
    } else {
        0.0
    };
    if console {
        eprintln!("the board's clock runs {offset_s:.4} s behind the harness's");
    }
    for f in &mut faults {
        f.at_s += offset_s;
    }
    faults.append(&mut undated);
    faults.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    let mut summary = summarise(scenario, &rows, wall_s, None);
    summary.replies = replies;
    summary.faults = faults;
    summary.warnings = warnings;
    let end_s = b.time_us as f64 * 1e-6;
    let log: Vec<LogRecord> = b.log.map_or_else(Vec::new, |l| l.log.finish(end_s));
    Ok(ElfRun {
        result: RunResult { rows, summary, log },
        outputs: b.trace,
    })
}

/// How long [`ElfConsole::line`] waits for a reply, s of simulated time (a `save` that must
/// erase a 128 KiB sector first stalls the board ≈ 2 s).
pub const REPLY_WITHIN_S: f64 = 10.0;

/// How long [`replay_lines`] runs on after the last reply, s of simulated time: a line answered
/// twice would show its second reply here.
pub const SETTLE_S: f64 = 0.5;

/// The ELF's console on the emulated board, as `host-sim console` serves the library's: the
/// scene's block (its plant, camera and injected faults; its timed duties and console lines
/// are not played) behind the board, lines typed into USART2 one at a time.
pub struct ElfConsole {
    board: ElfBoard,
}

impl ElfConsole {
    /// Start the board as `start` says on `scenario`'s block (`host-sim console` boots its own
    /// as a [`Start::PowerUp`]) and run it until its console is up (0.1 s: bytes sent to a
    /// receiver not yet enabled would be lost); returns the console and the lines the board
    /// wrote meanwhile.
    pub fn boot(
        scenario: &Scenario,
        elf: &Path,
        start: Start,
    ) -> Result<(ElfConsole, Vec<String>), ElfRunError> {
        let mut console = ElfConsole {
            board: ElfBoard::new(scenario, elf, start)?,
        };
        let mut said = Vec::new();
        while console.board.time_us < CONSOLE_UP_US {
            said.extend(console.tick()?);
        }
        Ok((console, said))
    }

    /// Simulated time since power-up, s.
    pub fn time_s(&self) -> f64 {
        self.board.time_us as f64 * 1e-6
    }

    fn tick(&mut self) -> Result<Vec<String>, ElfRunError> {
        let lines = self.board.tick()?.3;
        if std::env::var_os("THERMORPH_PIL_CONSOLE").is_some() {
            for (at_s, l) in &lines {
                eprintln!("{at_s:9.4} | {l}");
            }
        }
        Ok(lines.into_iter().map(|(_, l)| l).collect())
    }

    /// Run `seconds` more (in whole control ticks); the lines the board wrote.
    pub fn run_for(&mut self, seconds: f64) -> Result<Vec<String>, ElfRunError> {
        let until = self.board.time_us + (seconds * 1e6).round() as u64;
        let mut said = Vec::new();
        while self.board.time_us < until {
            said.extend(self.tick()?);
        }
        Ok(said)
    }

    /// Type `line` (its bytes, then CR LF) and run tick by tick until the board writes a line
    /// that is not a `#` line (warnings, telemetry): its reply. Returns every line written
    /// from the typing to the end of the tick the reply came in, the reply among them; no
    /// reply within [`REPLY_WITHIN_S`] is [`ElfRunError::NoReply`].
    pub fn line(&mut self, line: &[u8]) -> Result<Vec<String>, ElfRunError> {
        self.board.type_bytes(line);
        let until = self.board.time_us + (REPLY_WITHIN_S * 1e6) as u64;
        let mut said = Vec::new();
        while self.board.time_us < until {
            let lines = self.tick()?;
            let answered = lines.iter().any(|l| !l.starts_with('#'));
            said.extend(lines);
            if answered {
                return Ok(said);
            }
        }
        Err(ElfRunError::NoReply {
            line: line.escape_ascii().to_string(),
            after_s: REPLY_WITHIN_S,
        })
    }
}

/// A console session against the ELF: the board started as `start` says on `scenario`'s block
/// (a [`Start::PowerUp`] as `host-sim console`'s), the first of `lines` typed once the console
/// is up and each next one once the previous is answered (as a
/// person, or `scripts/record-session`, waits at a terminal; lines typed faster would queue in
/// the board and bytes typed while `save` stalls it could be lost, as on the board), then
/// [`SETTLE_S`] more. Returns every line the board wrote, as `host-sim console` writes its
/// block's on standard output: warnings and telemetry (`#`) and the replies.
pub fn replay_lines(
    scenario: &Scenario,
    elf: &Path,
    start: Start,
    lines: &[Vec<u8>],
) -> Result<Vec<String>, ElfRunError> {
    let (mut console, mut said) = ElfConsole::boot(scenario, elf, start)?;
    for l in lines {
        said.extend(console.line(l)?);
    }
    said.extend(console.run_for(SETTLE_S)?);
    Ok(said)
}

/// `host-sim run SCENE --board ELF`: load the scene, play it with the ELF (a progress bar),
/// write the outputs and print the summary as `host-sim run` does.
pub fn cli(args: &crate::runs::run::RunArgs, elf: &Path) -> anyhow::Result<()> {
    let scenario = crate::runs::scenario::load(&args.scene)?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(&scenario.name));
    let mut bar = crate::runs::run::Progress::new(!args.quiet);
    let result = run_elf(&scenario, elf, &mut |f| bar.update(f));
    bar.finish();
    crate::runs::run::finish(&result?, &dir, args.quiet)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_reply_gives_its_faults_with_their_place_among_all_events() {
        // 18 events, the ring keeps the last 3: indices 15, 16, 17.
        let reply = "ok events=18 | 4.10 fault sensor-loss (no valid measurement for 1.02 s) \
                     | 4.10 mode standby -> fault | 5.01 fault estop (emergency stop)";
        let faults = log_faults(reply).unwrap();
        assert_eq!(
            faults,
            [
                (
                    15,
                    4.1,
                    "sensor-loss".to_string(),
                    "no valid measurement for 1.02 s".to_string()
                ),
                (17, 5.01, "estop".to_string(), "emergency stop".to_string()),
            ]
        );
        assert_eq!(log_faults("ok events=0").unwrap(), []);
        assert!(log_faults("ok mode standby").is_none());
        assert!(log_faults("ok events=1 | x.y fault estop (emergency stop)").is_none());
    }
}
