//! Scene files: what a simulator run does, read from TOML and checked before anything runs.
//!
//! This module owns the scene-file format and its bundled scenes (`host-sim/scenes/*.toml`,
//! built into the binary). (The camera renderer of one image is [`crate::imaging::view`]; a scene
//! *file* here is a whole run.) A file gives:
//!
//! ```toml
//! name = "cycle"                 # optional; the file's stem otherwise
//! description = "…"              # optional
//! duration = "240 s"             # required: "90 s", "250 ms", "1.5 min", "1:30", "0:01:30"
//! ambient = "298.15 K"           # required: "298.15 K" or "25 °C" (or "25 C")
//! initial = "298.15 K"           # optional (default: the ambient), every node starts here
//! period = "0.5 s"               # optional (default 0.5 s): sample period (rows; camera-off frames)
//!
//! [fidelity]                     # optional; every key optional (defaults: the full model)
//! thermal = "full"               # full | lumped
//! sma = "hysteretic"             # hysteretic | switch
//! smp = "viscoelastic"           # viscoelastic | elastic
//! mechanics = true
//! camera = false                 # true: rendered → virtual MLX90640 → driver → MTTS
//! integrator = "zoh"             # zoh | backward-euler | tr-bdf2
//! max_step = "0.5 s"             # largest internal plant step
//!
//! [camera]                       # optional
//! noise = "0.1 K"                # sensor noise rms (NETD)
//! seed = 1                       # noise and sensor-calibration seed
//! azimuth = "0 deg"              # the camera's mount: its rows from spring A (-180…180);
//!                                # tell the firmware with `set cam_azimuth_deg`
//!
//! [plant]                        # optional; every key optional (default "100 %": the fitted
//!                                # block); each 50–200 % of the fitted value (`PlantScale`)
//! heater_power = "120 %"         # the heater's electrical power at every duty
//! wall_capacity = "80 %"         # the SMP wall's heat capacity (both layers)
//! spring_cooling = "80 %"        # each spring's loss to the still ambient air
//! spring_supply = "120 %"        # the spring channels' supply voltage (the 15 A limit stays)
//!
//! [[action]]                     # any number, in any order; each sets only what it names
//! at = "0 s"
//! heater = "100 %"               # heater PWM duty, 0–100 %
//! fan = "0 %"                    # fan PWM duty, 0–100 %
//! springs = "AB"                 # the springs switched on: any of A, B, C, or "none"
//!
//! [[action]]                     # the e-stop button (closed-loop scenes only), alone in
//! at = "30 s"                    # its action
//! button = "pressed"             # pressed | released: the button's level from `at` on
//!
//! [[command]]                    # console lines (the scene then runs closed loop)
//! at = "0 s"
//! line = "mode standby"          # as typed on the board's console
//!
//! [[fault]]                      # injected faults, active from `at` until `until` (or the end)
//! at = "60 s"
//! until = "80 s"                 # optional
//! kind = "heater-open"           # heater-open | stuck-spring | mosfet-short | open-wire |
//!                                # wire-short | sensor | camera
//! spring = "B"                   # stuck-spring, mosfet-short, open-wire, wire-short: which
//! stuck = "on"                   # stuck-spring: on | off (mosfet-short is stuck on)
//! sensor = "nack"                # sensor: nack | stuck | corrupt | frozen
//! camera = "elsewhere"           # camera: elsewhere | burning-film
//! ```
//!
//! An open-loop scene (no `[[command]]`) drives the plant's inputs with `heater`, `fan` and
//! `springs` actions. A closed-loop scene runs the firmware's supervisor, which sets those
//! itself: its only actions are the e-stop button's (B1 on PC13, active low), pressed or
//! released at `at` as a hand on the board would. A press is the button's falling edge: the
//! board's control loop runs a period at once with the button reported pressed, which latches
//! `estop`; from then on every period reads its level, and `reset` is refused until it is
//! released. Pressing a pressed button, or releasing a released one, changes nothing. A
//! `button` in an action with `heater`, `fan` or `springs` is an error (the two kinds never
//! play in the same scene), as are a duty action in a closed-loop scene and a button action in
//! an open-loop one (no firmware is in that loop to read the button).
//!
//! A `camera` fault changes what the camera sees, not the plant; it needs `fidelity.camera =
//! true` ([`CameraFault`] says what each shows). `[plant]` changes the simulated block only:
//! the firmware's observer and controller keep their own (fitted) parameters, so a scaled
//! plant is a model mismatch for them.
//!
//! Quantities carry their unit in the string, so `ambient = 298` or `duration = "90"` is an
//! error, as is an unknown key, a value out of range, a malformed time or an action after the
//! end. Every error names the file, the line and the key.
//!
//! This module owns the error type of scene files, [`ScenarioError`].

use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::plant::{
    Fidelity, Integrator, ModelOptions, PLANT_SCALE_RANGE, PlantScale, SmaFidelity, SmpFidelity,
    ThermalFidelity,
};
use crate::sensor::virtual_mlx::SensorFault;

pub use crate::rig::faults::{
    BURNING_FILM_K, CameraFault, CameraSettings, ELSEWHERE_K, FaultSpec, Injection,
};

/// The bundled scenes: (name, TOML text). The first is the default of `host-sim run`.
pub const BUNDLED: [(&str, &str); 4] = [
    ("cycle", include_str!("../../scenes/cycle.toml")),
    ("open-loop", include_str!("../../scenes/open-loop.toml")),
    ("faults", include_str!("../../scenes/faults.toml")),
    ("two-cycles", include_str!("../../scenes/two-cycles.toml")),
];

/// Longest sample period a scene may ask for, s (the board steps every 50 ms whatever it is).
pub const MAX_PERIOD_S: f64 = 0.5;
/// Longest scene, s (a simulated week).
pub const MAX_DURATION_S: f64 = 7.0 * 86_400.0;
/// Ambient range a scene may ask for, K.
pub const AMBIENT_RANGE_K: (f64, f64) = (233.15, 353.15);
/// Initial-temperature range, K.
pub const INITIAL_RANGE_K: (f64, f64) = (233.15, 423.15);

/// One timed change: of the actuators (open-loop scenes) or of the e-stop button (closed-loop
/// scenes); `None` leaves that input as it was. An action sets the actuators or the button,
/// never both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Action {
    /// When, s from the start.
    pub at_s: f64,
    /// Heater duty, 0…1.
    pub heater_duty: Option<f64>,
    /// Fan duty, 0…1.
    pub fan_duty: Option<f64>,
    /// Spring MOSFETs A, B, C on.
    pub springs_on: Option<[bool; 3]>,
    /// The e-stop button's level from `at_s` on: `true` pressed, `false` released.
    pub button: Option<bool>,
}

impl Action {
    /// Whether the action sets an actuator (heater, fan or springs).
    pub fn sets_actuators(&self) -> bool {
        self.heater_duty.is_some() || self.fan_duty.is_some() || self.springs_on.is_some()
    }
}

/// One timed console line (the scene then runs the supervisor in the loop).
#[derive(Clone, Debug, PartialEq)]
pub struct CommandLine {
    /// When, s from the start.
    pub at_s: f64,
    /// The line as typed (checked by the firmware's parser when the scene is loaded).
    pub line: String,
}

/// A checked scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// Name (also the default output folder's name).
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Length of the run, s.
    pub duration_s: f64,
    /// Ambient temperature, K.
    pub ambient_k: f64,
    /// Initial temperature of every node, K.
    pub initial_k: f64,
    /// Sample period, s: one time-series row each, and with the camera off one true-temperature
    /// measurement each (the simulated board steps every [`crate::rig::TICK_MS`] and on every
    /// frame and line, whatever this is).
    pub period_s: f64,
    /// Plant fidelity.
    pub fidelity: Fidelity,
    /// Plant integrator.
    pub integrator: Integrator,
    /// Largest internal plant step, s.
    pub max_step_s: f64,
    /// Camera settings.
    pub camera: CameraSettings,
    /// Factors on the simulated block's heater power, wall capacity, spring cooling and spring
    /// supply (`[plant]`; default all 1.0).
    pub plant_scale: PlantScale,
    /// Actions sorted by time (ties keep file order): duties in an open-loop scene, the e-stop
    /// button in a closed-loop one.
    pub actions: Vec<Action>,
    /// Console lines sorted by time (ties keep file order). A scene with any runs closed loop:
    /// the firmware's supervisor drives the outputs, and `actions` only press and release the
    /// e-stop button.
    pub commands: Vec<CommandLine>,
    /// Injected faults.
    pub faults: Vec<FaultSpec>,
}

impl Scenario {
    /// The simulated block this scene plays on: plant, camera, injected faults, sample period.
    pub fn block(&self) -> crate::rig::BlockSpec {
        crate::rig::BlockSpec {
            plant: crate::plant::PlantConfig {
                ambient_k: self.ambient_k,
                initial_k: self.initial_k,
                fidelity: self.fidelity,
                integrator: self.integrator,
                max_step_s: self.max_step_s,
            },
            options: ModelOptions {
                scale: self.plant_scale,
                ..ModelOptions::default()
            },
            camera: self.camera,
            faults: self.faults.clone(),
            sample_period_s: self.period_s,
        }
    }
}

/// Why a scene could not be loaded: the file cannot be read, is not TOML, or a key is wrong.
/// `Display` names the file, and for a key its line and name.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// Neither a file nor a bundled scene.
    #[error("no scene `{name}`: not a file, and the bundled scenes are {bundled}")]
    Unknown {
        /// The name given.
        name: String,
        /// The bundled scenes' names, comma separated.
        bundled: String,
    },
    /// The file cannot be read.
    #[error("{}: cannot read: {err}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        err: std::io::Error,
    },
    /// The text is not TOML.
    #[error("{file}:{line}: not valid TOML: {message}")]
    Toml {
        /// The file's name.
        file: String,
        /// The line, 1-based.
        line: usize,
        /// The parser's message, on one line.
        message: String,
    },
    /// A key is unknown, missing, of the wrong type or out of range.
    #[error("{file}:{line}: `{key}`: {message}")]
    Key {
        /// The file's name.
        file: String,
        /// The line, 1-based.
        line: usize,
        /// The key's full name (`action[1].at`).
        key: String,
        /// What is wrong with it.
        message: String,
    },
}

/// Load a scene: a bundled name (`cycle`, …) or a path to a TOML file.
pub fn load(name_or_path: &str) -> Result<Scenario, ScenarioError> {
    let src = source(name_or_path)?;
    parse(&src.text, &src.file, &src.default_name)
}

/// A scene's text before it is checked, with the names its errors and output use.
#[derive(Clone, Debug, PartialEq)]
pub struct Source {
    /// The TOML text.
    pub text: String,
    /// How errors name it (`<bundled cycle>` or the path).
    pub file: String,
    /// The scene's name when the text gives none (the bundled name or the file's stem).
    pub default_name: String,
}

/// The text of a scene: a bundled name (`cycle`, …) or a path to a TOML file.
pub fn source(name_or_path: &str) -> Result<Source, ScenarioError> {
    if let Some((name, text)) = BUNDLED.iter().find(|(n, _)| *n == name_or_path) {
        return Ok(Source {
            text: (*text).to_string(),
            file: format!("<bundled {name}>"),
            default_name: (*name).to_string(),
        });
    }
    let path = Path::new(name_or_path);
    if !path.exists() && !name_or_path.contains(['/', '.']) {
        let names: Vec<&str> = BUNDLED.iter().map(|(n, _)| *n).collect();
        return Err(ScenarioError::Unknown {
            name: name_or_path.to_string(),
            bundled: names.join(", "),
        });
    }
    let text = std::fs::read_to_string(path).map_err(|err| ScenarioError::Read {
        path: path.to_path_buf(),
        err,
    })?;
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene")
        .to_string();
    Ok(Source {
        text,
        file: path.display().to_string(),
        default_name: stem,
    })
}

/// Where a value sits, for error messages.
struct Ctx<'a> {
    file: &'a str,
    text: &'a str,
}

impl Ctx<'_> {
    fn line(&self, span: Option<Range<usize>>) -> usize {
        let at = span.map_or(0, |s| s.start.min(self.text.len()));
        self.text[..at].bytes().filter(|b| *b == b'\n').count() + 1
    }

    fn err(
        &self,
        span: Option<Range<usize>>,
        key: &str,
        msg: impl std::fmt::Display,
    ) -> ScenarioError {
        ScenarioError::Key {
            file: self.file.to_string(),
            line: self.line(span),
            key: key.to_string(),
            message: msg.to_string(),
        }
    }
}

/// Parse and check a scene's TOML text; `file` names it in errors, `default_name` is used
/// when the file has no `name`.
pub fn parse(text: &str, file: &str, default_name: &str) -> Result<Scenario, ScenarioError> {
    let cx = Ctx { file, text };
    let doc = toml_edit::Document::parse(text).map_err(|e| ScenarioError::Toml {
        file: file.to_string(),
        line: cx.line(e.span()),
        message: e.message().trim_end().replace('\n', " "),
    })?;
    let root = doc.as_table();
    check_keys(
        &cx,
        root,
        "",
        &[
            "name",
            "description",
            "duration",
            "ambient",
            "initial",
            "period",
            "fidelity",
            "camera",
            "plant",
            "action",
            "command",
            "fault",
        ],
    )?;
    let name = match root.get_key_value("name") {
        Some((k, v)) => {
            let s = string(&cx, k, v, "name")?;
            if s.is_empty()
                || !s
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            {
                return Err(cx.err(
                    v.span(),
                    "name",
                    format!(
                        "`{s}`: use letters, digits, `-`, `_` or `.` (it names the output folder)"
                    ),
                ));
            }
            s.to_string()
        }
        None => default_name.to_string(),
    };
    let description = match root.get_key_value("description") {
        Some((k, v)) => string(&cx, k, v, "description")?.to_string(),
        None => String::new(),
    };
    let duration_s = match root.get_key_value("duration") {
        Some((k, v)) => time(&cx, k, v, "duration", (1e-3, MAX_DURATION_S))?,
        None => {
            return Err(cx.err(None, "duration", "missing (e.g. `duration = \"110 s\"`)"));
        }
    };
    let ambient_k = match root.get_key_value("ambient") {
        Some((k, v)) => temperature(&cx, k, v, "ambient", AMBIENT_RANGE_K)?,
        None => {
            return Err(cx.err(None, "ambient", "missing (e.g. `ambient = \"298.15 K\"`)"));
        }
    };
    let initial_k = match root.get_key_value("initial") {
        Some((k, v)) => temperature(&cx, k, v, "initial", INITIAL_RANGE_K)?,
        None => ambient_k,
    };
    let period_s = match root.get_key_value("period") {
        Some((k, v)) => time(&cx, k, v, "period", (1e-3, MAX_PERIOD_S))?,
        None => MAX_PERIOD_S,
    };

    let mut fidelity = Fidelity::default();
    let mut integrator = Integrator::default();
    let mut max_step_s = crate::plant::PlantConfig::default().max_step_s;
    let mut camera = CameraSettings {
        enabled: false,
        noise_k: crate::sensor::virtual_mlx::DEFAULT_NOISE_K,
        seed: 1,
        azimuth_deg: 0.0,
    };
    if let Some((k, item)) = root.get_key_value("fidelity") {
        let t = table(&cx, k, item, "fidelity")?;
        check_keys(
            &cx,
            t,
            "fidelity.",
            &[
                "thermal",
                "sma",
                "smp",
                "mechanics",
                "camera",
                "integrator",
                "max_step",
            ],
        )?;
        for (key, val) in t.iter() {
            let k = t.key(key).expect("key of an iterated entry");
            let full = format!("fidelity.{key}");
            match key {
                "thermal" => {
                    fidelity.thermal = choice(
                        &cx,
                        k,
                        val,
                        &full,
                        &[
                            ("full", ThermalFidelity::Full),
                            ("lumped", ThermalFidelity::Lumped),
                        ],
                    )?
                }
                "sma" => {
                    fidelity.sma = choice(
                        &cx,
                        k,
                        val,
                        &full,
                        &[
                            ("hysteretic", SmaFidelity::Hysteretic),
                            ("switch", SmaFidelity::Switch),
                        ],
                    )?
                }
                "smp" => {
                    fidelity.smp = choice(
                        &cx,
                        k,
                        val,
                        &full,
                        &[
                            ("viscoelastic", SmpFidelity::Viscoelastic),
                            ("elastic", SmpFidelity::Elastic),
                        ],
                    )?
                }
                "mechanics" => fidelity.mechanics = boolean(&cx, k, val, &full)?,
                "camera" => camera.enabled = boolean(&cx, k, val, &full)?,
                "integrator" => {
                    integrator = choice(
                        &cx,
                        k,
                        val,
                        &full,
                        &[
                            ("zoh", Integrator::ExponentialZoh),
                            ("backward-euler", Integrator::BackwardEuler),
                            ("tr-bdf2", Integrator::TrBdf2),
                        ],
                    )?
                }
                "max_step" => max_step_s = time(&cx, k, val, &full, (1e-4, MAX_PERIOD_S))?,
                _ => unreachable!("keys were checked"),
            }
        }
    }
    if let Some((k, item)) = root.get_key_value("camera") {
        let t = table(&cx, k, item, "camera")?;
        check_keys(&cx, t, "camera.", &["noise", "seed", "azimuth"])?;
        if let Some((k, v)) = t.get_key_value("noise") {
            camera.noise_k = quantity_in(&cx, k, v, "camera.noise", KELVIN_STEP, (0.0, 5.0))?;
        }
        if let Some((k, v)) = t.get_key_value("azimuth") {
            camera.azimuth_deg =
                quantity_in(&cx, k, v, "camera.azimuth", DEGREES, (-180.0, 180.0))?;
        }
        if let Some((k, v)) = t.get_key_value("seed") {
            let n = integer(&cx, k, v, "camera.seed")?;
            camera.seed =
                u64::try_from(n).map_err(|_| cx.err(v.span(), "camera.seed", "must be ≥ 0"))?;
        }
    }

    let mut plant_scale = PlantScale::default();
    if let Some((k, item)) = root.get_key_value("plant") {
        let t = table(&cx, k, item, "plant")?;
        check_keys(&cx, t, "plant.", &PlantScale::NAMES)?;
        for (key, val) in t.iter() {
            let k = t.key(key).expect("key of an iterated entry");
            let factor = scale_percent(&cx, k, val, &format!("plant.{key}"))?;
            *plant_scale.get_mut(key).expect("keys were checked") = factor;
        }
    }

    let mut actions = Vec::new();
    // The first duty action and the first button action, as the error each is in a scene of
    // the other kind (which kind is known once the commands are read).
    let mut first_duty: Option<ScenarioError> = None;
    let mut first_button: Option<ScenarioError> = None;
    if let Some((k, item)) = root.get_key_value("action") {
        for (i, t) in tables(&cx, k, item, "action")?.into_iter().enumerate() {
            let p = format!("action[{}].", i + 1);
            check_keys(&cx, t, &p, &["at", "heater", "fan", "springs", "button"])?;
            let at_s = match t.get_key_value("at") {
                Some((k, v)) => time(&cx, k, v, &format!("{p}at"), (0.0, duration_s))?,
                None => return Err(cx.err(t.span(), &format!("{p}at"), "missing")),
            };
            let mut a = Action {
                at_s,
                heater_duty: None,
                fan_duty: None,
                springs_on: None,
                button: None,
            };
            let duty_key = ["heater", "fan", "springs"]
                .into_iter()
                .find_map(|key| t.get_key_value(key).map(|(k, _)| (key, k.span())));
            if let Some((bk, bv)) = t.get_key_value("button") {
                let key = format!("{p}button");
                a.button = Some(choice(
                    &cx,
                    bk,
                    bv,
                    &key,
                    &[("pressed", true), ("released", false)],
                )?);
                if let Some((duty, _)) = duty_key {
                    return Err(cx.err(
                        bk.span(),
                        &key,
                        format!(
                            "a button action sets nothing else: give `{duty}` its own \
                             [[action]] (the button is the firmware's input, closed loop; the \
                             duties are an open-loop scene's)"
                        ),
                    ));
                }
                first_button.get_or_insert_with(|| {
                    cx.err(
                        bk.span(),
                        &key,
                        "the e-stop button is the firmware's input, and an open-loop scene has \
                         no firmware in the loop (give the scene [[command]] lines to run the \
                         supervisor)",
                    )
                });
            }
            if let Some((duty, span)) = duty_key {
                first_duty.get_or_insert_with(|| {
                    cx.err(
                        span,
                        &format!("{p}{duty}"),
                        "a scene with console commands runs the supervisor and may not set \
                         duties by hand: only the e-stop `button` may be timed in its \
                         [[action]] tables",
                    )
                });
            }
            if let Some((k, v)) = t.get_key_value("heater") {
                a.heater_duty = Some(percent(&cx, k, v, &format!("{p}heater"))?);
            }
            if let Some((k, v)) = t.get_key_value("fan") {
                a.fan_duty = Some(percent(&cx, k, v, &format!("{p}fan"))?);
            }
            if let Some((k, v)) = t.get_key_value("springs") {
                a.springs_on = Some(springs(&cx, k, v, &format!("{p}springs"))?);
            }
            if !a.sets_actuators() && a.button.is_none() {
                return Err(cx.err(
                    t.span(),
                    &format!("{p}at"),
                    "the action sets nothing (give heater, fan or springs, or the button)",
                ));
            }
            actions.push(a);
        }
    }
    actions.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));

    let mut commands = Vec::new();
    if let Some((k, item)) = root.get_key_value("command") {
        for (i, t) in tables(&cx, k, item, "command")?.into_iter().enumerate() {
            let p = format!("command[{}].", i + 1);
            check_keys(&cx, t, &p, &["at", "line"])?;
            let at_s = match t.get_key_value("at") {
                Some((k, v)) => time(&cx, k, v, &format!("{p}at"), (0.0, duration_s))?,
                None => return Err(cx.err(t.span(), &format!("{p}at"), "missing")),
            };
            let line = match t.get_key_value("line") {
                Some((k, v)) => {
                    let line = string(&cx, k, v, &format!("{p}line"))?;
                    if let Err(e) = thermorph::command::parse(line) {
                        return Err(cx.err(
                            v.span(),
                            &format!("{p}line"),
                            format!("the console would refuse it: {} ({})", e.code(), e),
                        ));
                    }
                    line.to_string()
                }
                None => return Err(cx.err(t.span(), &format!("{p}line"), "missing")),
            };
            commands.push(CommandLine { at_s, line });
        }
    }
    match (commands.is_empty(), first_duty, first_button) {
        (false, Some(e), _) | (true, _, Some(e)) => return Err(e),
        _ => {}
    }
    commands.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));

    let mut faults = Vec::new();
    if let Some((k, item)) = root.get_key_value("fault") {
        for (i, t) in tables(&cx, k, item, "fault")?.into_iter().enumerate() {
            let p = format!("fault[{}].", i + 1);
            check_keys(
                &cx,
                t,
                &p,
                &["at", "until", "kind", "spring", "stuck", "sensor", "camera"],
            )?;
            let at_s = match t.get_key_value("at") {
                Some((k, v)) => time(&cx, k, v, &format!("{p}at"), (0.0, duration_s))?,
                None => return Err(cx.err(t.span(), &format!("{p}at"), "missing")),
            };
            let until_s = match t.get_key_value("until") {
                Some((k, v)) => Some(time(&cx, k, v, &format!("{p}until"), (at_s, f64::MAX))?),
                None => None,
            };
            let Some((kk, kv)) = t.get_key_value("kind") else {
                return Err(cx.err(t.span(), &format!("{p}kind"), "missing"));
            };
            let kind_name = choice(
                &cx,
                kk,
                kv,
                &format!("{p}kind"),
                &[
                    ("heater-open", 0),
                    ("stuck-spring", 1),
                    ("sensor", 2),
                    ("camera", 3),
                    ("mosfet-short", 4),
                    ("open-wire", 5),
                    ("wire-short", 6),
                ],
            )?;
            let allowed: &[&str] = match kind_name {
                0 => &[],
                1 => &["spring", "stuck"],
                2 => &["sensor"],
                4..=6 => &["spring"],
                _ => &["camera"],
            };
            for key in ["spring", "stuck", "sensor", "camera"] {
                if let Some((k, _)) = t.get_key_value(key)
                    && !allowed.contains(&key)
                {
                    return Err(cx.err(
                        k.span(),
                        &format!("{p}{key}"),
                        format!("not used by a `{}` fault", kv.as_str().unwrap_or("")),
                    ));
                }
            }
            let need = |key: &str| {
                t.get_key_value(key).ok_or_else(|| {
                    cx.err(
                        t.span(),
                        &format!("{p}{key}"),
                        format!("missing (a `{}` fault needs it)", kv.as_str().unwrap_or("")),
                    )
                })
            };
            let one_spring = || {
                let (k, v) = need("spring")?;
                let set = springs(&cx, k, v, &format!("{p}spring"))?;
                if set.iter().filter(|s| **s).count() != 1 {
                    return Err(cx.err(
                        v.span(),
                        &format!("{p}spring"),
                        "name one spring: A, B or C",
                    ));
                }
                Ok(set.iter().position(|s| *s).unwrap_or(0))
            };
            let kind = match kind_name {
                0 => Injection::HeaterOpen,
                4 => Injection::StuckSpring {
                    spring: one_spring()?,
                    on: true,
                },
                5 => Injection::OpenWire {
                    spring: one_spring()?,
                },
                6 => Injection::WireShort {
                    spring: one_spring()?,
                },
                1 => {
                    let spring = one_spring()?;
                    let (k, v) = need("stuck")?;
                    let on = choice(
                        &cx,
                        k,
                        v,
                        &format!("{p}stuck"),
                        &[("on", true), ("off", false)],
                    )?;
                    Injection::StuckSpring { spring, on }
                }
                3 => {
                    if !camera.enabled {
                        return Err(cx.err(
                            kv.span(),
                            &format!("{p}kind"),
                            "a `camera` fault needs the camera on (`[fidelity]` `camera = true`)",
                        ));
                    }
                    let (k, v) = need("camera")?;
                    Injection::Camera(choice(
                        &cx,
                        k,
                        v,
                        &format!("{p}camera"),
                        &[
                            ("elsewhere", CameraFault::Elsewhere),
                            ("burning-film", CameraFault::BurningFilm),
                        ],
                    )?)
                }
                _ => {
                    let (k, v) = need("sensor")?;
                    Injection::Sensor(choice(
                        &cx,
                        k,
                        v,
                        &format!("{p}sensor"),
                        &[
                            ("nack", SensorFault::Nack),
                            ("stuck", SensorFault::Stuck),
                            ("corrupt", SensorFault::Corrupt),
                            ("frozen", SensorFault::Frozen),
                        ],
                    )?)
                }
            };
            faults.push(FaultSpec {
                at_s,
                until_s,
                kind,
            });
        }
    }

    Ok(Scenario {
        name,
        description,
        duration_s,
        ambient_k,
        initial_k,
        period_s,
        fidelity,
        integrator,
        max_step_s,
        camera,
        plant_scale,
        actions,
        commands,
        faults,
    })
}

fn check_keys(
    cx: &Ctx,
    t: &toml_edit::Table,
    prefix: &str,
    known: &[&str],
) -> Result<(), ScenarioError> {
    for (key, _) in t.iter() {
        if !known.contains(&key) {
            let span = t.key(key).and_then(|k| k.span());
            return Err(cx.err(
                span,
                &format!("{prefix}{key}"),
                format!("unknown key (known here: {})", known.join(", ")),
            ));
        }
    }
    Ok(())
}

fn span_of(k: &toml_edit::Key, v: &toml_edit::Item) -> Option<Range<usize>> {
    v.span().or_else(|| k.span())
}

fn table<'a>(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &'a toml_edit::Item,
    key: &str,
) -> Result<&'a toml_edit::Table, ScenarioError> {
    v.as_table()
        .ok_or_else(|| cx.err(span_of(k, v), key, format!("must be a table (`[{key}]`)")))
}

fn tables<'a>(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &'a toml_edit::Item,
    key: &str,
) -> Result<Vec<&'a toml_edit::Table>, ScenarioError> {
    v.as_array_of_tables()
        .map(|a| a.iter().collect())
        .ok_or_else(|| {
            cx.err(
                span_of(k, v),
                key,
                format!("must be an array of tables (`[[{key}]]`)"),
            )
        })
}

fn string<'a>(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &'a toml_edit::Item,
    key: &str,
) -> Result<&'a str, ScenarioError> {
    v.as_str()
        .ok_or_else(|| cx.err(span_of(k, v), key, "must be a string"))
}

fn boolean(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
) -> Result<bool, ScenarioError> {
    v.as_bool()
        .ok_or_else(|| cx.err(span_of(k, v), key, "must be true or false"))
}

fn integer(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
) -> Result<i64, ScenarioError> {
    v.as_integer()
        .ok_or_else(|| cx.err(span_of(k, v), key, "must be an integer"))
}

fn choice<T: Copy>(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
    options: &[(&str, T)],
) -> Result<T, ScenarioError> {
    let names: Vec<&str> = options.iter().map(|(n, _)| *n).collect();
    let s = v.as_str().ok_or_else(|| {
        cx.err(
            span_of(k, v),
            key,
            format!("must be a string, one of {}", names.join(", ")),
        )
    })?;
    options
        .iter()
        .find(|(n, _)| *n == s)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            cx.err(
                span_of(k, v),
                key,
                format!("`{s}` is not one of {}", names.join(", ")),
            )
        })
}

/// Split `"<number> <unit>"` (space optional) into its number and unit.
fn split_quantity(s: &str) -> Option<(f64, &str)> {
    let s = s.trim();
    let end = s
        .char_indices()
        .find(|(_, c)| !(c.is_ascii_digit() || "+-.eE".contains(*c)))
        .map_or(s.len(), |(i, _)| i);
    // An exponent's `e` must be followed by a digit or sign; otherwise it starts the unit.
    let (mut num, mut unit) = s.split_at(end);
    while num.ends_with(['e', 'E']) {
        num = &s[..num.len() - 1];
        unit = &s[num.len()..];
    }
    let v: f64 = num.parse().ok()?;
    v.is_finite().then_some((v, unit.trim()))
}

fn quantity_str<'a>(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &'a toml_edit::Item,
    key: &str,
    example: &str,
) -> Result<&'a str, ScenarioError> {
    if v.is_integer() || v.is_float() {
        return Err(cx.err(
            span_of(k, v),
            key,
            format!("a bare number has no unit; write it as a string with one, e.g. `{key} = \"{example}\"`"),
        ));
    }
    v.as_str().ok_or_else(|| {
        cx.err(
            span_of(k, v),
            key,
            format!("must be a string with a unit, e.g. \"{example}\""),
        )
    })
}

/// `v` as a person wrote it: at most 6 decimals, trailing zeros dropped (`233.15`, not the
/// `233.14999999999998` that −40 °C + 273.15 is in binary).
pub fn rounded(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.to_string() }
}

/// Check `v` against `range` (inclusive) and return it: a bound is met within 1e-9 of its size
/// (so a bound written in °C, −40 °C, converted to kelvin with round-off, is in range, and is
/// returned as the bound); the error prints the rounded values.
fn in_range(
    cx: &Ctx,
    span: Option<Range<usize>>,
    key: &str,
    v: f64,
    range: (f64, f64),
    unit: &str,
) -> Result<f64, ScenarioError> {
    let slack = |bound: f64| 1e-9 * bound.abs().max(1.0);
    if v < range.0 - slack(range.0) || v > range.1 + slack(range.1) || v.is_nan() {
        let hi = if range.1 == f64::MAX {
            "…".to_string()
        } else {
            rounded(range.1)
        };
        return Err(cx.err(
            span,
            key,
            format!(
                "{} {unit} is out of range [{}, {hi}] {unit}",
                rounded(v),
                rounded(range.0)
            ),
        ));
    }
    Ok(v.clamp(range.0, range.1))
}

/// Parse a time: `"90 s"`, `"250 ms"`, `"1.5 min"`, `"2 h"`, `"1:30"` or `"0:01:30.5"`.
pub fn parse_time_s(s: &str) -> Option<f64> {
    let s = s.trim();
    if s.contains(':') {
        let parts: Vec<&str> = s.split(':').collect();
        if parts.len() > 3 {
            return None;
        }
        let mut total = 0.0;
        for (i, p) in parts.iter().enumerate() {
            let last = i + 1 == parts.len();
            let ok = !p.is_empty()
                && p.chars().all(|c| c.is_ascii_digit() || (last && c == '.'))
                && (i == 0 || p.split('.').next().is_some_and(|w| w.len() == 2));
            if !ok {
                return None;
            }
            let v: f64 = p.parse().ok()?;
            if i > 0 && v >= 60.0 {
                return None;
            }
            total = total * 60.0 + v;
        }
        return Some(total);
    }
    let (v, unit) = split_quantity(s)?;
    let scale = match unit {
        "s" => 1.0,
        "ms" => 1e-3,
        "min" => 60.0,
        "h" => 3600.0,
        _ => return None,
    };
    (v >= 0.0).then_some(v * scale)
}

fn time(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
    range: (f64, f64),
) -> Result<f64, ScenarioError> {
    let s = quantity_str(cx, k, v, key, "90 s")?;
    let t = parse_time_s(s).ok_or_else(|| {
        cx.err(
            span_of(k, v),
            key,
            format!(
                "malformed time `{s}` (write e.g. \"90 s\", \"250 ms\", \"1.5 min\" or \"1:30\")"
            ),
        )
    })?;
    in_range(cx, span_of(k, v), key, t, range, "s")
}

/// Parse a temperature: `"298.15 K"`, `"25 °C"` or `"25 C"`; return kelvin.
pub fn parse_temperature_k(s: &str) -> Option<f64> {
    let (v, unit) = split_quantity(s)?;
    match unit {
        "K" => Some(v),
        "°C" | "C" | "degC" => Some(v + 273.15),
        _ => None,
    }
}

fn temperature(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
    range_k: (f64, f64),
) -> Result<f64, ScenarioError> {
    let s = quantity_str(cx, k, v, key, "298.15 K")?;
    let t = parse_temperature_k(s).ok_or_else(|| {
        cx.err(
            span_of(k, v),
            key,
            format!(
                "`{s}` is not a temperature with a unit (write e.g. \"298.15 K\" or \"25 °C\")"
            ),
        )
    })?;
    in_range(cx, span_of(k, v), key, t, range_k, "K")
}

/// A quantity's unit for [`quantity_in`]: the unit errors name, the spellings accepted, what
/// the value is, an example.
type Unit = (
    &'static str,
    &'static [&'static str],
    &'static str,
    &'static str,
);

/// A temperature difference: kelvin only (a Celsius step is the same size; `°C` is accepted).
const KELVIN_STEP: Unit = ("K", &["K", "°C", "C"], "a temperature difference", "0.1 K");

/// An angle in degrees (`"90 deg"`, `"-30°"`).
const DEGREES: Unit = ("deg", &["deg", "°"], "an angle", "90 deg");

/// A number with one of `unit`'s spellings ([`KELVIN_STEP`], [`DEGREES`]) within `range` (in
/// its unit).
fn quantity_in(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
    (name, spellings, what, example): Unit,
    range: (f64, f64),
) -> Result<f64, ScenarioError> {
    let s = quantity_str(cx, k, v, key, example)?;
    let x = split_quantity(s)
        .filter(|(_, u)| spellings.contains(u))
        .map(|(x, _)| x)
        .ok_or_else(|| {
            cx.err(
                span_of(k, v),
                key,
                format!("`{s}` is not {what} with a unit (e.g. \"{example}\")"),
            )
        })?;
    in_range(cx, span_of(k, v), key, x, range, name)
}

/// A value in percent (`"50 %"`, `"80%"`) within `range` (in %), as a fraction: `example`
/// and `what` word the error for a value without the unit.
fn percent_in(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
    example: &str,
    what: &str,
    range: (f64, f64),
) -> Result<f64, ScenarioError> {
    let s = quantity_str(cx, k, v, key, example)?;
    let p = split_quantity(s)
        .filter(|(_, u)| *u == "%")
        .map(|(x, _)| x)
        .ok_or_else(|| {
            cx.err(
                span_of(k, v),
                key,
                format!("`{s}` is not {what} (write e.g. \"{example}\")"),
            )
        })?;
    Ok(in_range(cx, span_of(k, v), key, p, range, "%")? / 100.0)
}

fn percent(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
) -> Result<f64, ScenarioError> {
    percent_in(cx, k, v, key, "50 %", "a duty in percent", (0.0, 100.0))
}

/// A factor on the fitted block as a percentage (`"120 %"`, `"80%"`), within
/// [`PLANT_SCALE_RANGE`]; returns the factor (1.2).
fn scale_percent(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
) -> Result<f64, ScenarioError> {
    let range = (100.0 * PLANT_SCALE_RANGE.0, 100.0 * PLANT_SCALE_RANGE.1);
    percent_in(
        cx,
        k,
        v,
        key,
        "120 %",
        "a percentage of the fitted block",
        range,
    )
}

fn springs(
    cx: &Ctx,
    k: &toml_edit::Key,
    v: &toml_edit::Item,
    key: &str,
) -> Result<[bool; 3], ScenarioError> {
    let s = v.as_str().ok_or_else(|| {
        cx.err(
            span_of(k, v),
            key,
            "must be a string of spring letters (\"AB\") or \"none\"",
        )
    })?;
    if s.trim() == "none" {
        return Ok([false; 3]);
    }
    // The console's grammar (`SpringMask::parse`: each of A, B, C at most once, any case),
    // with the separators a scene file may write between letters.
    let letters: String = s
        .chars()
        .filter(|c| !matches!(c, ' ' | ',' | '+'))
        .collect();
    let mask = thermorph::outputs::SpringMask::parse(&letters).ok_or_else(|| {
        let unknown = letters.chars().find(|c| {
            !thermorph::outputs::SPRING_NAMES
                .iter()
                .any(|n| n.eq_ignore_ascii_case(c))
        });
        let why = match unknown {
            Some(c) => format!("`{s}`: `{c}` is not a spring (A, B, C, or \"none\")"),
            None if letters.is_empty() => "empty (write \"none\" for all off)".to_string(),
            None => format!("`{s}` names a spring twice"),
        };
        cx.err(span_of(k, v), key, why)
    })?;
    Ok(core::array::from_fn(|i| mask.contains(i)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "duration = \"10 s\"\nambient = \"25 °C\"\n";

    fn err(text: &str) -> String {
        parse(text, "t.toml", "t").unwrap_err().to_string()
    }

    #[test]
    fn bundled_scenes_parse() {
        for (name, text) in BUNDLED {
            let s = parse(text, name, name).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(s.name, name);
            assert!(
                s.actions.is_empty() != s.commands.is_empty(),
                "{name}: timed duties or console lines, exactly one of them"
            );
        }
        assert!(load("cycle").is_ok());
        assert!(
            load("no-such-scene")
                .unwrap_err()
                .to_string()
                .contains("bundled scenes are cycle")
        );
    }

    #[test]
    fn minimal_scene_defaults() {
        let s = parse(MINIMAL, "t.toml", "t").unwrap();
        assert_eq!(s.name, "t");
        assert!((s.ambient_k - 298.15).abs() < 1e-12);
        assert_eq!(s.initial_k, s.ambient_k);
        assert_eq!(s.period_s, 0.5);
        assert_eq!(s.fidelity, Fidelity::default());
        assert!(!s.camera.enabled);
    }

    #[test]
    fn the_camera_mount_is_an_angle_with_its_unit() {
        let s = parse(
            &format!("{MINIMAL}[camera]\nazimuth = \"90 deg\"\n"),
            "t.toml",
            "t",
        )
        .unwrap();
        assert_eq!(s.camera.azimuth_deg, 90.0);
        assert_eq!(
            parse(MINIMAL, "t.toml", "t").unwrap().camera.azimuth_deg,
            0.0
        );
        let e = err(&format!("{MINIMAL}[camera]\nazimuth = \"90\"\n"));
        assert!(e.contains("not an angle with a unit"), "{e}");
        let e = err(&format!("{MINIMAL}[camera]\nazimuth = \"200 deg\"\n"));
        assert!(e.contains("out of range"), "{e}");
    }

    #[test]
    fn times_and_temperatures() {
        assert_eq!(parse_time_s("90 s"), Some(90.0));
        assert_eq!(parse_time_s("250ms"), Some(0.25));
        assert_eq!(parse_time_s("1.5 min"), Some(90.0));
        assert_eq!(parse_time_s("1:30"), Some(90.0));
        assert_eq!(parse_time_s("1:02:03.5"), Some(3723.5));
        for bad in [
            "90",
            "1:3",
            "1:60",
            "-1 s",
            "1:30:00:00",
            "s",
            "1e s",
            "nan s",
            "1:3x",
        ] {
            assert_eq!(parse_time_s(bad), None, "{bad}");
        }
        assert_eq!(parse_temperature_k("300 K"), Some(300.0));
        assert_eq!(parse_temperature_k("1e2 K"), Some(100.0));
        assert!((parse_temperature_k("25 °C").unwrap() - 298.15).abs() < 1e-12);
        assert_eq!(parse_temperature_k("300"), None);
        assert_eq!(parse_temperature_k("300 F"), None);
    }

    #[test]
    fn celsius_at_the_bounds_is_in_range_and_errors_print_rounded_values() {
        // −40 °C + 273.15 is 233.14999999999998 in binary, below the bound 233.15.
        for (text, k) in [("-40 °C", 233.15), ("80 °C", 353.15), ("-40 C", 233.15)] {
            let s = parse(
                &format!("duration = \"10 s\"\nambient = \"{text}\"\n"),
                "t.toml",
                "t",
            )
            .unwrap();
            assert_eq!(s.ambient_k, k, "{text}");
        }
        let e = err("duration = \"10 s\"\nambient = \"-40.5 °C\"\n");
        assert!(
            e.ends_with("`ambient`: 232.65 K is out of range [233.15, 353.15] K"),
            "{e}"
        );
        let e = err("duration = \"10 s\"\nambient = \"80.01 °C\"\n");
        assert!(e.contains("353.16 K is out of range"), "{e}");
        assert_eq!(rounded(233.14999999999998), "233.15");
        assert_eq!(rounded(-0.0000001), "0");
        assert_eq!(rounded(2.5), "2.5");
        assert_eq!(rounded(10.0), "10");
    }

    #[test]
    fn errors_name_file_line_and_key() {
        let e = err(&format!("{MINIMAL}colour = \"red\"\n"));
        assert!(e.starts_with("t.toml:3: `colour`: unknown key"), "{e}");
        let e = err("duration = \"10 s\"\nambient = 298\n");
        assert!(
            e.starts_with("t.toml:2: `ambient`: a bare number has no unit"),
            "{e}"
        );
        let e = err("duration = \"10 s\"\nambient = \"298 F\"\n");
        assert!(
            e.contains("t.toml:2: `ambient`") && e.contains("not a temperature"),
            "{e}"
        );
        let e = err("duration = \"10 s\"\nambient = \"500 K\"\n");
        assert!(
            e.contains("t.toml:2: `ambient`: 500 K is out of range"),
            "{e}"
        );
        let e = err("duration = \"1:7x\"\nambient = \"298 K\"\n");
        assert!(
            e.contains("t.toml:1: `duration`: malformed time `1:7x`"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}\n[[action]]\nat = \"5 s\"\nheater = \"150 %\"\n"
        ));
        assert!(
            e.contains("t.toml:6: `action[1].heater`: 150 % is out of range"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}[[action]]\nat = \"20 s\"\nfan = \"5 %\"\n"
        ));
        assert!(
            e.contains("t.toml:4: `action[1].at`: 20 s is out of range [0, 10]"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}[[action]]\nat = \"2 s\"\nsprings = \"AD\"\n"
        ));
        assert!(
            e.contains("t.toml:5: `action[1].springs`") && e.contains("`D`"),
            "{e}"
        );
        let e = err(&format!("{MINIMAL}[[action]]\nat = \"2 s\"\n"));
        assert!(
            e.contains("`action[1].at`: the action sets nothing (give heater, fan or springs, or the button)"),
            "{e}"
        );
        let e = err(&format!("{MINIMAL}[fidelity]\nthermal = \"medium\"\n"));
        assert!(
            e.contains("t.toml:4: `fidelity.thermal`: `medium` is not one of full, lumped"),
            "{e}"
        );
        let e = err(&format!("{MINIMAL}[fidelity]\ncolour = 1\n"));
        assert!(
            e.contains("t.toml:4: `fidelity.colour`: unknown key"),
            "{e}"
        );
        let e = err(&format!("{MINIMAL}period = \"2 s\"\n"));
        assert!(e.contains("`period`: 2 s is out of range"), "{e}");
        let e = err(&format!(
            "{MINIMAL}[[fault]]\nat = \"1 s\"\nkind = \"stuck-spring\"\nspring = \"A\"\n"
        ));
        assert!(e.contains("`fault[1].stuck`: missing"), "{e}");
        let e = err(&format!(
            "{MINIMAL}[[fault]]\nat = \"1 s\"\nkind = \"heater-open\"\nsensor = \"nack\"\n"
        ));
        assert!(
            e.contains("t.toml:6: `fault[1].sensor`: not used by a `heater-open` fault"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}[[fault]]\nat = \"5 s\"\nuntil = \"2 s\"\nkind = \"heater-open\"\n"
        ));
        assert!(
            e.contains("t.toml:5: `fault[1].until`: 2 s is out of range"),
            "{e}"
        );
        let e = err("duration = \"10 s\"\nambient = \"298 K\n");
        assert!(e.starts_with("t.toml:2: not valid TOML"), "{e}");
        let e = err("ambient = \"298 K\"\n");
        assert!(e.contains("`duration`: missing"), "{e}");
    }

    #[test]
    fn actions_sort_and_faults_parse() {
        let s = parse(
            &format!(
                "{MINIMAL}[[action]]\nat = \"5 s\"\nsprings = \"A, C\"\n[[action]]\nat = \"1 s\"\nheater = \"40 %\"\n\
                 [[fault]]\nat = \"2 s\"\nuntil = \"3 s\"\nkind = \"stuck-spring\"\nspring = \"b\"\nstuck = \"on\"\n\
                 [[fault]]\nat = \"4 s\"\nkind = \"sensor\"\nsensor = \"frozen\"\n"
            ),
            "t.toml",
            "t",
        )
        .unwrap();
        assert_eq!(s.actions[0].at_s, 1.0);
        assert_eq!(s.actions[0].heater_duty, Some(0.4));
        assert_eq!(s.actions[1].springs_on, Some([true, false, true]));
        assert_eq!(
            s.faults[0].kind,
            Injection::StuckSpring {
                spring: 1,
                on: true
            }
        );
        assert!(s.faults[0].active(2.5) && !s.faults[0].active(3.0) && !s.faults[0].active(1.9));
        assert_eq!(s.faults[1].kind, Injection::Sensor(SensorFault::Frozen));
        assert!(s.faults[1].active(1e9));
    }

    #[test]
    fn a_closed_loop_scene_times_the_button() {
        let s = parse(
            &format!(
                "{MINIMAL}[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n\
                 [[action]]\nat = \"6 s\"\nbutton = \"released\"\n\
                 [[action]]\nat = \"5.013 s\"\nbutton = \"pressed\"\n"
            ),
            "t.toml",
            "t",
        )
        .unwrap();
        assert_eq!(s.actions.len(), 2);
        assert_eq!(
            (s.actions[0].at_s, s.actions[0].button),
            (5.013, Some(true))
        );
        assert_eq!((s.actions[1].at_s, s.actions[1].button), (6.0, Some(false)));
        assert!(s.actions.iter().all(|a| !a.sets_actuators()));
        assert_eq!(s.commands.len(), 1);
    }

    #[test]
    fn button_errors_name_file_line_and_key() {
        let cmd = "[[command]]\nat = \"0 s\"\nline = \"mode standby\"\n";
        // A duty in a closed-loop scene: named at its own line and key.
        let e = err(&format!(
            "{MINIMAL}{cmd}[[action]]\nat = \"1 s\"\nbutton = \"pressed\"\n\
             [[action]]\nat = \"2 s\"\nfan = \"50 %\"\n"
        ));
        assert!(
            e.starts_with("t.toml:11: `action[2].fan`: a scene with console commands")
                && e.contains("may not set duties")
                && e.contains("button"),
            "{e}"
        );
        // The button in an open-loop scene.
        let e = err(&format!(
            "{MINIMAL}[[action]]\nat = \"0 s\"\nheater = \"50 %\"\n\
             [[action]]\nat = \"2 s\"\nbutton = \"pressed\"\n"
        ));
        assert!(
            e.starts_with(
                "t.toml:8: `action[2].button`: the e-stop button is the firmware's input"
            ) && e.contains("open-loop"),
            "{e}"
        );
        // The button with a duty in one action, whatever the scene.
        for scene in [MINIMAL.to_string(), format!("{MINIMAL}{cmd}")] {
            let e = err(&format!(
                "{scene}[[action]]\nat = \"2 s\"\nsprings = \"A\"\nbutton = \"pressed\"\n"
            ));
            assert!(
                e.contains("`action[1].button`: a button action sets nothing else: give `springs`"),
                "{e}"
            );
        }
        let e = err(&format!(
            "{MINIMAL}{cmd}[[action]]\nat = \"2 s\"\nbutton = \"down\"\n"
        ));
        assert!(
            e.starts_with("t.toml:8: `action[1].button`: `down` is not one of pressed, released"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}{cmd}[[action]]\nat = \"2 s\"\nbutton = true\n"
        ));
        assert!(
            e.contains("`action[1].button`: must be a string, one of pressed, released"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}{cmd}[[action]]\nat = \"12 s\"\nbutton = \"pressed\"\n"
        ));
        assert!(
            e.contains("t.toml:7: `action[1].at`: 12 s is out of range [0, 10]"),
            "{e}"
        );
    }

    #[test]
    fn plant_scale_parses_and_reaches_the_block() {
        let s = parse(
            &format!(
                "{MINIMAL}[plant]\nheater_power = \"120 %\"\nwall_capacity = \"80%\"\n\
                 spring_cooling = \"50 %\"\nspring_supply = \"200 %\"\n"
            ),
            "t.toml",
            "t",
        )
        .unwrap();
        let want = PlantScale {
            heater_power: 1.2,
            wall_capacity: 0.8,
            spring_cooling: 0.5,
            spring_supply: 2.0,
        };
        assert_eq!(s.plant_scale, want);
        assert_eq!(s.block().options.scale, want);
        assert!(!s.block().options.pmma_plates && !s.block().options.shared_spring_supply);
        // A key left out stays at the fitted block's; no table is the fitted block.
        let s = parse(
            &format!("{MINIMAL}[plant]\nspring_supply = \"80 %\"\n"),
            "t.toml",
            "t",
        )
        .unwrap();
        assert_eq!(
            s.plant_scale,
            PlantScale {
                spring_supply: 0.8,
                ..PlantScale::UNIT
            }
        );
        assert_eq!(
            parse(MINIMAL, "t.toml", "t").unwrap().block().options,
            ModelOptions::default()
        );
        // The bundled cycle spells the fitted block out.
        assert_eq!(load("cycle").unwrap().plant_scale, PlantScale::UNIT);
    }

    #[test]
    fn plant_scale_errors_name_file_line_and_key() {
        let e = err(&format!("{MINIMAL}[plant]\nheater_power = 1.2\n"));
        assert!(
            e.starts_with("t.toml:4: `plant.heater_power`: a bare number has no unit"),
            "{e}"
        );
        assert!(e.contains("\"120 %\""), "{e}");
        let e = err(&format!("{MINIMAL}[plant]\nwall_capacity = \"1.2\"\n"));
        assert!(
            e.contains("t.toml:4: `plant.wall_capacity`: `1.2` is not a percentage"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}[plant]\nheater_power = \"100 %\"\nspring_cooling = \"250 %\"\n"
        ));
        assert!(
            e.contains("t.toml:5: `plant.spring_cooling`: 250 % is out of range [50, 200] %"),
            "{e}"
        );
        let e = err(&format!("{MINIMAL}[plant]\nspring_supply = \"40 %\"\n"));
        assert!(
            e.contains("t.toml:4: `plant.spring_supply`: 40 % is out of range [50, 200] %"),
            "{e}"
        );
        let e = err(&format!("{MINIMAL}[plant]\nfan_power = \"120 %\"\n"));
        assert!(
            e.contains("t.toml:4: `plant.fan_power`: unknown key (known here: heater_power, wall_capacity, spring_cooling, spring_supply)"),
            "{e}"
        );
        let e = err(&format!("{MINIMAL}plant = \"120 %\"\n"));
        assert!(e.contains("t.toml:3: `plant`: must be a table"), "{e}");
    }

    #[test]
    fn camera_faults_parse_and_need_the_camera() {
        let fault = "[[fault]]\nat = \"1 s\"\nkind = \"camera\"\ncamera = \"elsewhere\"\n";
        let s = parse(
            &format!("{MINIMAL}[fidelity]\ncamera = true\n{fault}"),
            "t.toml",
            "t",
        )
        .unwrap();
        assert_eq!(s.faults[0].kind, Injection::Camera(CameraFault::Elsewhere));
        let e = err(&format!("{MINIMAL}{fault}"));
        assert!(
            e.contains("t.toml:5: `fault[1].kind`: a `camera` fault needs the camera on"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}[fidelity]\ncamera = true\n[[fault]]\nat = \"1 s\"\nkind = \"camera\"\ncamera = \"fog\"\n"
        ));
        assert!(
            e.contains("t.toml:8: `fault[1].camera`: `fog` is not one of elsewhere, burning-film"),
            "{e}"
        );
        let e = err(&format!(
            "{MINIMAL}[[fault]]\nat = \"1 s\"\nkind = \"sensor\"\nsensor = \"nack\"\ncamera = \"elsewhere\"\n"
        ));
        assert!(
            e.contains("`fault[1].camera`: not used by a `sensor` fault"),
            "{e}"
        );
    }
}
