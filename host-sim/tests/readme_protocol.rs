//! The console reference (`docs/console.md`, once the README's console section) is checked
//! against the tables it documents: every command of `COMMANDS` with its arguments, every
//! parameter of `PARAMS` with unit, range and default, the settings record's size, every `err`
//! code the firmware answers (and none it does not), every fault code (here and in the safety
//! table of `docs/control-and-safety.md`), and the telemetry fields in `TELEMETRY_FIELDS`' order
//! — so the code's tables stay the source and the pages cannot drift from them.

use std::path::{Path, PathBuf};

use thermorph::command::{ArgError, COMMANDS, ParseError, Word};
use thermorph::console::MAX_LINE;
use thermorph::settings::{PARAMS, Settings};
use thermorph::supervisor::mode::ModeId;
use thermorph::supervisor::report::TELEMETRY_FIELDS;
use thermorph::supervisor::safety::FaultKind;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn doc(name: &str) -> String {
    let path = root().join("docs").join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The console reference.
fn console_md() -> String {
    doc("console.md")
}

/// `text` with every run of white space (line ends included) one space.
fn flat(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The rows (cells, trimmed, `\|` unescaped) of the first table after `heading`.
fn table(text: &str, heading: &str, after: &str) -> Vec<Vec<String>> {
    let at = text
        .find(heading)
        .unwrap_or_else(|| panic!("no {heading:?}"));
    let at = at
        + text[at..]
            .find(after)
            .unwrap_or_else(|| panic!("no {after:?}"));
    text[at..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(|l| {
            let l = l.replace("\\|", "\u{1}");
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().replace('\u{1}', "|"))
                .collect()
        })
        .collect()
}

fn num(v: f32) -> String {
    // As the page writes them: whole numbers bare, others to six significant digits.
    let r = (v * 1e4).round() / 1e4;
    format!("{r}")
}

#[test]
fn console_doc_lists_every_command_with_its_arguments() {
    let rows = table(&console_md(), "## Commands", "| command |");
    let names: Vec<String> = COMMANDS.iter().map(|c| format!("`{}`", c.name)).collect();
    let listed: Vec<String> = rows.iter().map(|r| r[0].clone()).collect();
    assert_eq!(listed, names, "docs/console.md's commands, in table order");
    for (c, r) in COMMANDS.iter().zip(&rows) {
        let args = if c.args.is_empty() {
            String::new()
        } else {
            format!("`{}`", c.args)
        };
        assert_eq!(r[1], args, "arguments of {}", c.name);
    }
}

/// The parameter rows as they must read (printed when they do not, to paste).
fn parameter_rows() -> Vec<String> {
    let d = Settings::DEFAULT;
    PARAMS
        .iter()
        .map(|p| {
            let unit = if p.unit.is_empty() {
                "—".to_string()
            } else {
                p.unit.replace('*', "·")
            };
            format!(
                "| `{}` | {unit} | {} – {} | {} | {} |",
                p.name,
                num(p.min),
                num(p.max),
                num((p.get)(&d)),
                p.help
            )
        })
        .collect()
}

#[test]
fn console_doc_lists_every_parameter_with_unit_range_and_default() {
    let text = console_md();
    let want = parameter_rows();
    let rows = table(&text, "## Parameters", "| name | unit |");
    let got: Vec<String> = rows
        .iter()
        .map(|r| format!("| {} |", r.join(" | ")))
        .collect();
    assert!(
        got == want,
        "docs/console.md's parameter table differs from PARAMS; its rows should be:\n{}",
        want.join("\n")
    );
    let size = format!(
        "{} bytes with today's {} parameters",
        thermorph::settings::RECORD_LEN,
        PARAMS.len()
    );
    assert!(
        flat(&text).contains(&size),
        "the record's size should read: {size:?}"
    );
    // On the board each save is a sequential-storage item: 8-byte header, then the 1-byte key
    // and the record padded to whole 4-byte words.
    let item = 8 + (thermorph::settings::RECORD_LEN + 1).div_ceil(4) * 4;
    let flat = flat(&text);
    let want = format!("each save takes {item} bytes");
    assert!(flat.contains(&want), "the flash item should read: {want:?}");
    for (page, label) in [
        (16 * 1024, " saves per 16 KiB"),
        (128 * 1024, " per 128 KiB page"),
    ] {
        let at = flat.find(label).unwrap_or_else(|| panic!("no {label:?}"));
        let n: f64 = flat[..at].rsplit(' ').next().unwrap().parse().unwrap();
        let fits = page as f64 / item as f64;
        assert!((n - fits).abs() <= 0.01 * fits, "{n}{label}: {fits:.0} fit");
    }
}

/// Every `err` code the firmware's sources answer: the parse errors' codes, and the codes
/// written by `Reply::err("…", …)` or in a `"err …:` format string anywhere in
/// `firmware/src/` (the library and the board binary).
fn firmware_error_codes() -> Vec<String> {
    let mut codes: Vec<String> = [
        ParseError::LineTooLong,
        ParseError::BinaryInput,
        ParseError::LostBytes,
        ParseError::UnknownCommand(None),
        ParseError::BadArguments(ArgError::NotANumber),
        ParseError::UnknownName(Word::new("x"), None),
        ParseError::Busy,
    ]
    .iter()
    .map(|e| {
        // Fails to compile when a parse error is added: add it to the list above.
        match e {
            ParseError::LineTooLong
            | ParseError::BinaryInput
            | ParseError::LostBytes
            | ParseError::UnknownCommand(_)
            | ParseError::BadArguments(_)
            | ParseError::UnknownName(..)
            | ParseError::Busy => e.code().to_string(),
        }
    })
    .collect();
    let mut files = vec![root().join("firmware/src")];
    while let Some(p) = files.pop() {
        if p.is_dir() {
            files.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
            continue;
        }
        if p.extension().is_none_or(|e| e != "rs") || p.ends_with("tests.rs") {
            continue;
        }
        let text = flat(&std::fs::read_to_string(&p).unwrap());
        for (pattern, after) in [
            ("Reply::err( \"", '"'),
            ("Reply::err(\"", '"'),
            ("\"err ", ':'),
        ] {
            for (i, _) in text.match_indices(pattern) {
                let rest = &text[i + pattern.len()..];
                let code = &rest[..rest.find(after).unwrap_or(0)];
                let is_code =
                    !code.is_empty() && code.bytes().all(|b| b.is_ascii_lowercase() || b == b'-');
                if is_code && !codes.iter().any(|c| c == code) {
                    codes.push(code.to_string());
                }
            }
        }
    }
    codes
}

#[test]
fn console_doc_lists_every_error_code_the_firmware_answers() {
    let text = console_md();
    let rows = table(&text, "## Error and fault codes", "| code | when |");
    let listed: Vec<&str> = rows.iter().map(|r| r[0].trim_matches('`')).collect();
    let codes = firmware_error_codes();
    for c in [
        "out-of-range",
        "conflict",
        "bad-state",
        "fault-latched",
        "cause-present",
    ] {
        assert!(codes.iter().any(|x| x == c), "the source scan misses {c}");
    }
    for c in &codes {
        assert!(
            listed.contains(&c.as_str()),
            "docs/console.md lacks `err {c}`"
        );
    }
    for c in &listed {
        assert!(
            codes.iter().any(|x| x == c),
            "docs/console.md lists `err {c}`, which the firmware never answers"
        );
    }
    // The limits the protocol's rules and the table name.
    assert!(
        flat(&text).contains(&format!("A line over {MAX_LINE} bytes")),
        "the line limit is {MAX_LINE} bytes"
    );
    let board = std::fs::read_to_string(root().join("firmware/src/bin/board/board.rs")).unwrap();
    let outstanding = board
        .split("const OUTSTANDING: usize = ")
        .nth(1)
        .and_then(|r| r.split(';').next())
        .expect("OUTSTANDING in board.rs");
    assert!(
        flat(&text).contains(&format!("while {outstanding} commands were still waiting")),
        "the board queues {outstanding} commands (`err busy`)"
    );
}

/// Every fault code, from [`FaultKind::code`].
fn fault_codes() -> Vec<&'static str> {
    let kinds = [
        FaultKind::OverTemperature,
        FaultKind::SpringOnTime(0),
        FaultKind::SpringDuty(0),
        FaultKind::SpringOverTemperature(0),
        FaultKind::SensorLoss,
        FaultKind::RunawayHeating,
        FaultKind::RunawayHolding,
        FaultKind::NoResponse,
        FaultKind::EStop,
        FaultKind::SpringStuckOn(0),
        FaultKind::SpringOpen(0),
        FaultKind::SpringShort(0),
        FaultKind::SpringSensing(0),
    ];
    kinds
        .iter()
        .map(|&kind| {
            // Fails to compile when a fault is added: add it to the list above.
            match kind {
                FaultKind::OverTemperature
                | FaultKind::SpringOnTime(_)
                | FaultKind::SpringDuty(_)
                | FaultKind::SpringOverTemperature(_)
                | FaultKind::SensorLoss
                | FaultKind::RunawayHeating
                | FaultKind::RunawayHolding
                | FaultKind::NoResponse
                | FaultKind::EStop
                | FaultKind::SpringStuckOn(_)
                | FaultKind::SpringOpen(_)
                | FaultKind::SpringShort(_)
                | FaultKind::SpringSensing(_) => kind.code(),
            }
        })
        .collect()
}

#[test]
fn docs_list_every_fault_code() {
    let codes = fault_codes();
    // The console reference's list, in order.
    let text = flat(&console_md());
    let at = text.find("Fault codes (").expect("the fault code list");
    let at = at + text[at..].find("):").expect("Fault codes (…): …") + 2;
    let list = &text[at..at + text[at..].find("`.").expect("…, `last`.") + 1];
    let listed: Vec<&str> = list
        .split(',')
        .map(|c| c.trim().trim_matches('`'))
        .collect();
    assert_eq!(listed, codes, "docs/console.md's fault codes");
    // The safety table: one row per fault, in order.
    let rows = table(&doc("control-and-safety.md"), "## Safety", "| fault |");
    let listed: Vec<&str> = rows.iter().map(|r| r[0].trim_matches('`')).collect();
    assert_eq!(listed, codes, "docs/control-and-safety.md's safety table");
}

#[test]
fn console_doc_telemetry_table_is_the_field_list() {
    let text = console_md();
    let rows = table(&text, "## Telemetry", "| field |");
    let fields: Vec<String> = rows.iter().map(|r| r[0].trim_matches('`').into()).collect();
    assert_eq!(fields, TELEMETRY_FIELDS);
    // The `mode` row names every mode, in `ModeId::ALL`'s order.
    let modes = &rows[fields.iter().position(|f| f == "mode").unwrap()][2];
    let listed: Vec<&str> = modes.split(", ").map(|m| m.trim_matches('`')).collect();
    let names: Vec<&str> = ModeId::ALL.iter().map(|m| m.name()).collect();
    assert_eq!(listed, names, "the telemetry table's modes");
    // The format line shows them in the same order.
    let line = TELEMETRY_FIELDS
        .iter()
        .map(|f| format!("{f}=…"))
        .collect::<Vec<_>>()
        .join(" ");
    assert!(text.contains(&format!("`# {line}`")), "{line}");
}

/// Issue 44: the page says what the firmware does about `stream`'s rate: its maximum
/// (`STREAM_MAX_HZ`; the page once said 20 where the console refused above 10) and default.
#[test]
fn console_doc_states_the_streams_maximum_and_default() {
    use thermorph::supervisor::{STREAM_DEFAULT_HZ, STREAM_MAX_HZ};
    let rows = table(&console_md(), "## Commands", "| command |");
    let row = rows
        .iter()
        .find(|r| r[0] == "`stream`")
        .expect("the stream row");
    let said = |before: &str| -> f32 {
        let at = row[2]
            .find(before)
            .unwrap_or_else(|| panic!("the stream row says no {before:?}: {}", row[2]));
        let rest = &row[2][at + before.len()..];
        let end = rest
            .find(|c: char| !c.is_ascii_digit() && c != '.')
            .unwrap_or(rest.len());
        rest[..end].parse().unwrap()
    };
    assert_eq!(
        said("at most "),
        STREAM_MAX_HZ,
        "docs/console.md: {}",
        row[2]
    );
    assert_eq!(
        said("default "),
        STREAM_DEFAULT_HZ,
        "docs/console.md: {}",
        row[2]
    );
    // And `help stream` says the same.
    let help = COMMANDS.iter().find(|c| c.name == "stream").unwrap().help;
    assert!(
        help.contains(&format!(
            "up to {STREAM_MAX_HZ} (default {STREAM_DEFAULT_HZ})"
        )),
        "{help}"
    );
}

/// Issue 44: the page's table of `status`' fields is the reply's, in order (`spring_a` and
/// `supply_v` only where the board senses its springs, `reason` only with a fault).
#[test]
fn console_doc_status_table_is_the_replys_fields() {
    use thermorph::command::Command;
    use thermorph::measurement::{Measurement, Quality};
    use thermorph::supervisor::Supervisor;
    use thermorph::units::{Kelvin, Millis};
    let mut sup = Supervisor::new(Millis(0), Settings::DEFAULT);
    let m = Measurement {
        at: Millis(100),
        seq: 1,
        regions: [300.0, 299.0, 298.0, 298.0, 298.0].map(Kelvin::new),
        hottest: Kelvin::new(300.0),
        filled_pixels: 0,
        quality: Quality::Resolved,
        bound: Kelvin::lit(0.5),
        tilt: None,
        exposure: None,
    };
    sup.step(Millis(100), Some(&m), None);
    let reply = sup
        .step(Millis(150), None, Some(Command::Status { short: false }))
        .reply
        .unwrap();
    let fields: Vec<&str> = reply
        .as_str()
        .strip_prefix("ok ")
        .unwrap()
        .split(' ')
        .map(|f| f.split('=').next().unwrap())
        .collect();
    let rows = table(&console_md(), "## Reading `status`", "| field | meaning |");
    let mut documented: Vec<&str> = Vec::new();
    for r in &rows {
        let names: Vec<&str> = r[0].split(", ").map(|n| n.trim_matches('`')).collect();
        for n in names {
            // `first` … `last`: the reply's fields from one to the other.
            if let Some((first, last)) = n.split_once("` … `") {
                let a = fields.iter().position(|f| *f == first).expect(first);
                let b = fields.iter().position(|f| *f == last).expect(last);
                documented.extend(&fields[a..=b]);
            } else {
                documented.push(n);
            }
        }
    }
    documented.retain(|f| !matches!(*f, "spring_a" | "supply_v"));
    assert_eq!(
        fields, documented,
        "docs/console.md's status table, in order"
    );
}
