//! The hardware pages against the firmware's pin map, the one file that names the board's pins
//! (`firmware/src/bin/board/pins.rs`), and against the firmware's front-end constants:
//!
//! - the wiring diagram's source (`docs/hardware/wiring.yml`, drawn by `scripts/wiring`): every
//!   pin of its NUCLEO connector is the firmware's pin for the signal it names, under the
//!   NUCLEO-F446RE's Arduino header name it gives; every pin the firmware uses is there;
//! - its harness takes each signal to the right pin of the camera and of the power stage;
//! - the pin tables of the README, of `docs/hardware.md` and of `pins.rs`'s own docs name the
//!   same pins (and header names) in the same order;
//! - `docs/hardware.md`'s table of the firmware's figures (shunt, gain, divider, PWM and bus
//!   frequencies, …) is today's.
//!
//! The pin map is read from `pins.rs`'s source (the binary's modules cannot be linked into a
//! host test): its `gate_pins!` and `sense_pins!` tables, the sensor bus's, console's, button's
//! and LED's pins where `Board::new` takes them, and every other pin name in its code, which
//! must be one of those.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use host_sim::plant::params as p;
use thermorph::channels::{FRONT_END, SETTLE_US};
use thermorph::settings::{PARAMS, Settings};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(rel: &str) -> String {
    let path = root().join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

const PINS_RS: &str = "firmware/src/bin/board/pins.rs";
const WIRING_YML: &str = "docs/hardware/wiring.yml";
const HARDWARE_MD: &str = "docs/hardware.md";

/// What a pin of the board does, as the firmware's pin map assigns it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Signal {
    SensorScl,
    SensorSda,
    HeaterGate,
    FanGate,
    /// Spring 0 = A.
    SpringGate(usize),
    SpringPower,
    SpringCurrent(usize),
    SpringSupply(usize),
    ConsoleTx,
    ConsoleRx,
    EStop,
    StatusLed,
}

use Signal::*;

const LETTERS: [&str; 3] = ["A", "B", "C"];

impl Signal {
    fn all() -> Vec<Signal> {
        let mut v = vec![SensorScl, SensorSda, HeaterGate, FanGate];
        v.extend((0..3).map(SpringGate));
        v.push(SpringPower);
        v.extend((0..3).map(SpringCurrent));
        v.extend((0..3).map(SpringSupply));
        v.extend([ConsoleTx, ConsoleRx, EStop, StatusLed]);
        v
    }

    /// The signal's name in the wiring diagram and in `docs/hardware.md`'s wiring table.
    fn name(self) -> String {
        match self {
            SensorScl => "sensor SCL".into(),
            SensorSda => "sensor SDA".into(),
            HeaterGate => "heater gate".into(),
            FanGate => "fan gate".into(),
            SpringGate(i) => format!("spring {} gate", LETTERS[i]),
            SpringPower => "spring power enable".into(),
            SpringCurrent(i) => format!("spring {} current", LETTERS[i]),
            SpringSupply(i) => format!("spring {} supply", LETTERS[i]),
            ConsoleTx => "console TX".into(),
            ConsoleRx => "console RX".into(),
            EStop => "emergency stop".into(),
            StatusLed => "status LED".into(),
        }
    }

    fn named(name: &str) -> Option<Signal> {
        Signal::all().into_iter().find(|s| s.name() == name)
    }

    /// Whether the signal is wired on the NUCLEO itself (the ST-LINK, B1, LD2).
    fn on_board(self) -> bool {
        matches!(self, ConsoleTx | ConsoleRx | EStop | StatusLed)
    }

    /// The connector and pin of the harness this signal must reach (`docs/hardware/wiring.yml`).
    fn far_end(self) -> Option<(&'static str, String)> {
        let j1 = |p: &str| Some(("J1", p.to_string()));
        match self {
            SensorScl => Some(("CAM", "SCL".into())),
            SensorSda => Some(("CAM", "SDA".into())),
            HeaterGate => j1("HTR"),
            FanGate => j1("FAN"),
            SpringGate(i) => j1(&format!("G{}", LETTERS[i])),
            SpringPower => j1("EN"),
            SpringCurrent(i) => j1(&format!("I{}", LETTERS[i])),
            SpringSupply(i) => j1(&format!("V{}", LETTERS[i])),
            ConsoleTx | ConsoleRx | EStop | StatusLed => None,
        }
    }
}

/// The NUCLEO-F446RE's Arduino Uno header names of its STM32 pins (ST's Nucleo-64 user manual,
/// UM1724, and the board's variant in stm32duino).
const ARDUINO: [(&str, &str); 22] = [
    ("D0", "PA3"),
    ("D1", "PA2"),
    ("D2", "PA10"),
    ("D3", "PB3"),
    ("D4", "PB5"),
    ("D5", "PB4"),
    ("D6", "PB10"),
    ("D7", "PA8"),
    ("D8", "PA9"),
    ("D9", "PC7"),
    ("D10", "PB6"),
    ("D11", "PA7"),
    ("D12", "PA6"),
    ("D13", "PA5"),
    ("D14", "PB9"),
    ("D15", "PB8"),
    ("A0", "PA0"),
    ("A1", "PA1"),
    ("A2", "PA4"),
    ("A3", "PB0"),
    ("A4", "PC1"),
    ("A5", "PC0"),
];

/// The Arduino header name of `pin`, if it has one.
fn header_of(pin: &str) -> Option<&'static str> {
    ARDUINO.iter().find(|(_, p)| *p == pin).map(|(h, _)| *h)
}

/// Whether `t` is an STM32 pin name (`PA0` … `PK15`).
fn is_pin(t: &str) -> bool {
    let b = t.as_bytes();
    (3..=4).contains(&b.len())
        && b[0] == b'P'
        && (b'A'..=b'K').contains(&b[1])
        && b[2..].iter().all(u8::is_ascii_digit)
}

/// Whether `t` is an Arduino header name (`D0` … `D15`, `A0` … `A5`).
fn is_header(t: &str) -> bool {
    ARDUINO.iter().any(|(h, _)| *h == t)
}

/// The words of `s` (runs of letters and digits), in order.
fn words(s: &str) -> Vec<&str> {
    s.split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .collect()
}

/// `source` without its `//` comments (`pins.rs` has no `//` inside a string).
fn code_of(source: &str) -> String {
    source
        .lines()
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The text from the opening parenthesis that ends `needle`'s first match after `from` to its
/// closing one.
fn call_args<'a>(code: &'a str, from: &str, needle: &str) -> &'a str {
    let at = code
        .find(from)
        .unwrap_or_else(|| panic!("{PINS_RS}: no {from:?}"));
    let start = at
        + code[at..]
            .find(needle)
            .unwrap_or_else(|| panic!("{PINS_RS}: no {needle:?} after {from:?}"))
        + needle.len();
    let mut depth = 1;
    for (i, c) in code[start..].char_indices() {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    return &code[start..start + i];
                }
            }
            _ => {}
        }
    }
    panic!("{PINS_RS}: unbalanced parentheses after {needle:?}")
}

/// The pin named right after `needle` in `code`.
fn pin_after(code: &str, needle: &str) -> String {
    let at = code
        .find(needle)
        .unwrap_or_else(|| panic!("{PINS_RS}: no {needle:?}"))
        + needle.len();
    let pin = words(&code[at..])[0];
    assert!(
        is_pin(pin),
        "{PINS_RS}: {needle:?} is followed by {pin:?}, not a pin"
    );
    pin.to_string()
}

/// The firmware's pin of every signal, read from `pins.rs`.
fn firmware_map() -> BTreeMap<Signal, String> {
    let code = code_of(&read(PINS_RS));
    let pins_of = |s: &str| -> Vec<String> {
        words(s)
            .into_iter()
            .filter(|w| is_pin(w))
            .map(String::from)
            .collect()
    };
    let mut map = BTreeMap::new();

    let gates = pins_of(call_args(&code, "macro_rules! gate_pins", "$then!("));
    assert_eq!(
        gates.len(),
        6,
        "gate_pins!: (heater, fan, [A, B, C, power]): {gates:?}"
    );
    let order = [
        HeaterGate,
        FanGate,
        SpringGate(0),
        SpringGate(1),
        SpringGate(2),
        SpringPower,
    ];
    map.extend(order.into_iter().zip(gates));

    let sense = pins_of(call_args(&code, "macro_rules! sense_pins", "$then!("));
    assert_eq!(
        sense.len(),
        6,
        "sense_pins!: ([currents], [supplies]): {sense:?}"
    );
    let order = (0..3).map(SpringCurrent).chain((0..3).map(SpringSupply));
    map.extend(order.zip(sense));

    map.insert(
        SensorScl,
        pin_after(&code, "scl: Peri<'static, peripherals::"),
    );
    map.insert(
        SensorSda,
        pin_after(&code, "sda: Peri<'static, peripherals::"),
    );
    // embassy's `BufferedUart::new(peripheral, rx, tx, …)`.
    let uart = pins_of(call_args(
        &code,
        "fn new(p: Peripherals)",
        "BufferedUart::new(",
    ));
    assert_eq!(uart.len(), 2, "BufferedUart::new's pins: {uart:?}");
    map.insert(ConsoleRx, uart[0].clone());
    map.insert(ConsoleTx, uart[1].clone());
    map.insert(EStop, pin_after(&code, "ExtiInput::new(p."));
    map.insert(StatusLed, pin_after(&code, "led: Output::new(p."));

    // No pin of the code is left out of the map, and no pin serves two signals.
    let named: BTreeSet<String> = pins_of(&code).into_iter().collect();
    let mapped: BTreeSet<String> = map.values().cloned().collect();
    assert_eq!(
        named, mapped,
        "{PINS_RS} uses pins the test does not know of"
    );
    assert_eq!(mapped.len(), map.len(), "a pin serves two signals: {map:?}");
    map
}

#[test]
fn the_pin_map_is_read_from_the_firmware() {
    let map = firmware_map();
    assert_eq!(map.len(), Signal::all().len());
    // The SPEC's pins the firmware was built with (a parse that went wrong fails here first).
    assert_eq!(map[&HeaterGate], "PA6");
    assert_eq!(map[&SpringGate(2)], "PB10");
    assert_eq!(map[&SpringSupply(2)], "PC0");
    assert_eq!(map[&ConsoleRx], "PA3");
    assert_eq!(map[&EStop], "PC13");
}

// ------------------------------------------------------------------- the diagram's source

/// `s` without surrounding quotes.
fn unquote(s: &str) -> String {
    s.trim().trim_matches('"').trim_matches('\'').to_string()
}

/// The items of a YAML flow list `[a, b, "c"]`.
fn flow_list(s: &str) -> Vec<String> {
    let s = s.trim();
    let inner = s
        .strip_prefix('[')
        .and_then(|s| s.strip_suffix(']'))
        .unwrap_or_else(|| panic!("{WIRING_YML}: not a flow list: {s:?}"));
    inner.split(',').map(unquote).collect()
}

/// The lines of `connectors:`'s entry `name` (indented by two), up to the next entry.
fn connector_lines<'a>(yml: &'a str, name: &str) -> Vec<&'a str> {
    let head = format!("  {name}:");
    let mut lines = yml.lines().skip_while(|l| l.trim_end() != head);
    assert!(lines.next().is_some(), "{WIRING_YML}: no connector {name}");
    lines
        .take_while(|l| l.trim().is_empty() || l.starts_with("   "))
        .collect()
}

/// A list field (`pins`, `pinlabels`) of connector `name`, written as a flow or a block list.
fn connector_list(yml: &str, name: &str, field: &str) -> Vec<String> {
    let lines = connector_lines(yml, name);
    let key = format!("    {field}:");
    let at = lines
        .iter()
        .position(|l| l.starts_with(&key))
        .unwrap_or_else(|| panic!("{WIRING_YML}: {name} has no {field}"));
    let rest = lines[at][key.len()..].trim();
    if !rest.is_empty() {
        return flow_list(rest);
    }
    lines[at + 1..]
        .iter()
        .map_while(|l| l.strip_prefix("      - "))
        .map(unquote)
        .collect()
}

/// The harness's connection sets: each a list of (connector or cable, its pins or wires).
fn connections(yml: &str) -> Vec<Vec<(String, Vec<String>)>> {
    let mut sets: Vec<Vec<(String, Vec<String>)>> = Vec::new();
    let body = yml
        .split_once("\nconnections:\n")
        .unwrap_or_else(|| panic!("{WIRING_YML}: no connections"))
        .1;
    for line in body.lines() {
        let item = if let Some(i) = line.strip_prefix("  - - ") {
            sets.push(Vec::new());
            i
        } else if let Some(i) = line.strip_prefix("    - ") {
            i
        } else {
            assert!(line.trim().is_empty(), "{WIRING_YML}: unexpected {line:?}");
            continue;
        };
        let (name, list) = item
            .split_once(':')
            .unwrap_or_else(|| panic!("{WIRING_YML}: {item:?}"));
        sets.last_mut()
            .unwrap()
            .push((name.trim().to_string(), flow_list(list)));
    }
    sets
}

/// A NUCLEO pin label `signal (header)`, split.
fn split_label(label: &str) -> (&str, &str) {
    let (signal, rest) = label
        .split_once(" (")
        .unwrap_or_else(|| panic!("{WIRING_YML}: NUCLEO label {label:?} is not `signal (pin)`"));
    (signal, rest.strip_suffix(')').unwrap())
}

#[test]
fn the_diagrams_nucleo_pins_are_the_firmwares() {
    let map = firmware_map();
    let yml = read(WIRING_YML);
    let pins = connector_list(&yml, "NUCLEO", "pins");
    let labels = connector_list(&yml, "NUCLEO", "pinlabels");
    assert_eq!(pins.len(), labels.len(), "NUCLEO: a label for every pin");

    let mut seen = BTreeSet::new();
    for (pin, label) in pins.iter().zip(&labels) {
        let (name, header) = split_label(label);
        match Signal::named(name) {
            Some(s) => {
                assert_eq!(
                    &map[&s], pin,
                    "{WIRING_YML}: {name} is on {pin}; the firmware has it on {}",
                    map[&s]
                );
                if s.on_board() {
                    assert_eq!(header, "on board", "{name}: the NUCLEO wires it itself");
                } else {
                    assert_eq!(
                        Some(header),
                        header_of(pin),
                        "{WIRING_YML}: {pin} is not header pin {header}"
                    );
                }
                assert!(seen.insert(s), "{WIRING_YML}: {name} twice");
            }
            None => assert!(
                [("3V3", "3V3"), ("GND", "GND")].contains(&(pin.as_str(), header)),
                "{WIRING_YML}: NUCLEO pin {pin} {label:?}: no such signal"
            ),
        }
    }
    let missing: Vec<_> = Signal::all()
        .into_iter()
        .filter(|s| !seen.contains(s))
        .map(Signal::name)
        .collect();
    assert!(missing.is_empty(), "{WIRING_YML} lacks {missing:?}");
}

#[test]
fn the_harness_takes_every_signal_to_its_pin() {
    let map = firmware_map();
    let yml = read(WIRING_YML);
    // NUCLEO pin → (connector, pin) at the set's far end; wires pair pins by position.
    let mut reaches: BTreeMap<String, Vec<(String, String)>> = BTreeMap::new();
    for set in connections(&yml) {
        let (first, last) = (&set[0], &set[set.len() - 1]);
        if first.0 != "NUCLEO" {
            continue;
        }
        assert_eq!(first.1.len(), last.1.len(), "{WIRING_YML}: {set:?}");
        for (from, to) in first.1.iter().zip(&last.1) {
            reaches
                .entry(from.clone())
                .or_default()
                .push((last.0.clone(), to.clone()));
        }
    }
    for s in Signal::all() {
        let pin = &map[&s];
        let got = reaches.remove(pin).unwrap_or_default();
        let want: Vec<_> = s
            .far_end()
            .map(|(c, p)| (c.to_string(), p))
            .into_iter()
            .collect();
        assert_eq!(got, want, "{WIRING_YML}: {} ({pin})", s.name());
        // The far pin exists on its connector.
        for (c, p) in &want {
            assert!(
                connector_list(&yml, c, "pins").contains(p),
                "{c} has no pin {p}"
            );
        }
    }
    // Power: the camera and the amplifiers from the NUCLEO's 3.3 V, grounds joined.
    let pair = |c: &str, p: &str| (c.to_string(), p.to_string());
    for (pin, want) in [
        ("3V3", [pair("CAM", "VIN"), pair("J1", "3V3")]),
        ("GND", [pair("CAM", "GND"), pair("J1", "GND")]),
    ] {
        assert_eq!(
            reaches.remove(pin).unwrap_or_default(),
            want,
            "{WIRING_YML}: {pin}"
        );
    }
    assert!(
        reaches.is_empty(),
        "{WIRING_YML}: unexpected wires {reaches:?}"
    );
}

// ------------------------------------------------------------------- the pages' pin tables

/// The rows (cells, trimmed) of the first table after `heading` in `text`.
fn table(text: &str, heading: &str, path: &str) -> Vec<Vec<String>> {
    let at = text
        .find(heading)
        .unwrap_or_else(|| panic!("{path}: no {heading:?}"));
    text[at..]
        .lines()
        .map(|l| l.trim_start_matches("//!").trim())
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

/// The signals a pin table's row names, in its pins' order: a wiring name (`spring A gate`)
/// or one of the README's and `pins.rs`'s grouped rows.
fn row_signals(name: &str) -> Option<Vec<Signal>> {
    let springs = |f: fn(usize) -> Signal| (0..3).map(f).collect::<Vec<_>>();
    let grouped = match name {
        "MLX90640 SCL / SDA" => vec![SensorScl, SensorSda],
        "PI heater gate" | "PI heater gate (PWM)" => vec![HeaterGate],
        "fan gate" | "fan (PWM)" => vec![FanGate],
        "SMA spring A / B / C" => springs(SpringGate),
        "spring current A / B / C" => springs(SpringCurrent),
        "spring supply A / B / C" => springs(SpringSupply),
        "console" => vec![ConsoleTx, ConsoleRx],
        _ => return Signal::named(name).map(|s| vec![s]),
    };
    Some(grouped)
}

/// Check a pin table: each row's pin cell names its signals' pins in order, and any header
/// names (D7, A0) are those pins'. Returns the signals covered.
fn check_pin_table(path: &str, rows: &[Vec<String>], pin_column: usize) -> BTreeSet<Signal> {
    let map = firmware_map();
    let mut covered = BTreeSet::new();
    for row in rows {
        let name = row[0].trim_matches('`');
        let signals = row_signals(name)
            .unwrap_or_else(|| panic!("{path}: pin table row {name:?}: no such signal"));
        let cell = &row[pin_column];
        let pins: Vec<&str> = words(cell).into_iter().filter(|w| is_pin(w)).collect();
        let want: Vec<&str> = signals.iter().map(|s| map[s].as_str()).collect();
        assert_eq!(
            pins, want,
            "{path}: row {name:?}: the firmware's pins are {want:?}"
        );
        let headers: Vec<&str> = words(cell).into_iter().filter(|w| is_header(w)).collect();
        let want: Vec<&str> = want.iter().filter_map(|p| header_of(p)).collect();
        assert!(
            headers.is_empty() || headers == want,
            "{path}: row {name:?}: header pins {headers:?}, the pins' are {want:?}"
        );
        covered.extend(signals);
    }
    covered
}

#[test]
fn the_readme_pin_table_is_the_firmwares() {
    let rows = table(&read("README.md"), "## Hardware", "README.md");
    let covered = check_pin_table("README.md", &rows, 1);
    assert_eq!(covered.len(), Signal::all().len(), "README.md: every pin");
}

#[test]
fn the_pin_map_docs_are_its_code() {
    let rows = table(&read(PINS_RS), "//! | signal | pin |", PINS_RS);
    let covered = check_pin_table(PINS_RS, &rows, 1);
    assert_eq!(
        covered.len(),
        Signal::all().len(),
        "{PINS_RS}'s table: every pin"
    );
}

#[test]
fn the_hardware_pages_wiring_table_is_the_firmwares_and_the_diagrams() {
    let text = read(HARDWARE_MD);
    let rows = table(&text, "## Wiring", HARDWARE_MD);
    let covered = check_pin_table(HARDWARE_MD, &rows, 1);
    assert_eq!(
        covered.len(),
        Signal::all().len(),
        "{HARDWARE_MD}: every pin"
    );
    // The third column: where the wire goes (`J1 GA`, `camera SCL`, `on board`).
    for row in &rows {
        let s = Signal::named(row[0].trim_matches('`')).unwrap();
        let want = match s.far_end() {
            Some(("CAM", p)) => format!("camera {p}"),
            Some((c, p)) => format!("{c} {p}"),
            None => "on board".to_string(),
        };
        assert_eq!(row[2], want, "{HARDWARE_MD}: {}", s.name());
    }
    // The page shows the drawing of wiring.yml.
    assert!(
        text.contains("(hardware/wiring.svg)"),
        "{HARDWARE_MD}: no drawing"
    );
}

// ------------------------------------------------------------------- the firmware's figures

/// A `pub const NAME: u32 = …;` of `pins.rs`, as a number.
fn pins_const(name: &str) -> f64 {
    let code = code_of(&read(PINS_RS));
    let needle = format!("pub const {name}: u32 = ");
    let at = code
        .find(&needle)
        .unwrap_or_else(|| panic!("{PINS_RS}: no {needle:?}"))
        + needle.len();
    let value = &code[at..at + code[at..].find(';').unwrap()];
    value
        .replace('_', "")
        .parse()
        .unwrap_or_else(|e| panic!("{PINS_RS}: {name} = {value:?}: {e}"))
}

/// `hz` as the pages write it (`1 kHz`, `11.25 MHz`).
fn hz(hz: f64) -> String {
    if hz >= 1e6 {
        format!("{} MHz", hz / 1e6)
    } else {
        format!("{} kHz", hz / 1e3)
    }
}

#[test]
fn the_hardware_pages_figures_are_the_firmwares() {
    let fe = FRONT_END;
    let defaults = Settings::default();
    let param_max = |name: &str| PARAMS.iter().find(|p| p.name == name).unwrap().max;
    let expected: Vec<(&str, String)> = vec![
        ("FRONT_END.shunt_ohm", format!("{} mΩ", fe.shunt_ohm * 1e3)),
        ("FRONT_END.amp_gain", format!("{} V/V", fe.amp_gain)),
        ("FRONT_END.divider_ratio", format!("{}", fe.divider_ratio)),
        ("FRONT_END.adc_ref_v", format!("{} V", fe.adc_ref_v)),
        (
            "FRONT_END.amps_per_count()",
            format!("{:.2} mA", fe.amps_per_count() * 1e3),
        ),
        (
            "FRONT_END.volts_per_count()",
            format!("{:.2} mV", fe.volts_per_count() * 1e3),
        ),
        (
            "FRONT_END.supply_nominal_v",
            format!("{} V", fe.supply_nominal_v),
        ),
        (
            "FRONT_END.supply_limit_a",
            format!("{} A", fe.supply_limit_a),
        ),
        (
            "FRONT_END.series_ohm",
            format!("{} mΩ", fe.series_ohm * 1e3),
        ),
        ("channels::SETTLE_US", format!("{SETTLE_US} µs")),
        ("spring_short_a", format!("{} A", defaults.spring_short_a)),
        ("t_max_k", format!("{} K", defaults.t_max_k)),
        ("t_max_k, largest", format!("{} K", param_max("t_max_k"))),
        ("form_fan_pct", format!("{} %", defaults.form_fan * 100.0)),
        ("HEATER_PWM_HZ", hz(pins_const("HEATER_PWM_HZ"))),
        ("FAN_PWM_HZ", hz(pins_const("FAN_PWM_HZ"))),
        ("I2C_HZ", hz(pins_const("I2C_HZ"))),
        ("ADC_HZ", hz(pins_const("ADC_HZ"))),
        (
            "params::HEATER_SUPPLY_V",
            format!("{} V", p::HEATER_SUPPLY_V),
        ),
        (
            "params::HEATER_RESISTANCE_OHM",
            format!("{} Ω", p::HEATER_RESISTANCE_OHM),
        ),
        (
            "params::HEATER_SUPPLY_V² / params::HEATER_RESISTANCE_OHM",
            format!(
                "{:.1} W",
                p::HEATER_SUPPLY_V * p::HEATER_SUPPLY_V / p::HEATER_RESISTANCE_OHM
            ),
        ),
    ];
    let rows = table(
        &read(HARDWARE_MD),
        "## What the firmware expects",
        HARDWARE_MD,
    );
    let mut left: BTreeMap<&str, String> = expected.into_iter().collect();
    for row in &rows {
        let source = row[2].replace('`', "");
        let want = left
            .remove(source.as_str())
            .unwrap_or_else(|| panic!("{HARDWARE_MD}: figure from {source:?}: not checked here"));
        assert_eq!(row[1], want, "{HARDWARE_MD}: {} ({source})", row[0]);
    }
    assert!(left.is_empty(), "{HARDWARE_MD} lacks {:?}", left.keys());
}
