//! The README's console section is checked against the tables it documents: every command of
//! `COMMANDS` with its arguments, every parameter of `PARAMS` with unit, range and default, every
//! parse error code, and the telemetry fields in `TELEMETRY_FIELDS`' order — so the code's
//! tables stay the source and the README cannot drift from them.

use thermorph::command::{COMMANDS, ParseError};
use thermorph::settings::{PARAMS, Settings};

use thermorph::supervisor::report::TELEMETRY_FIELDS;

fn readme() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).unwrap()
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
    // As the README writes them: whole numbers bare, others to six significant digits.
    let r = (v * 1e4).round() / 1e4;
    format!("{r}")
}

#[test]
fn readme_lists_every_command_with_its_arguments() {
    let rows = table(&readme(), "### Commands", "| command |");
    let names: Vec<String> = COMMANDS.iter().map(|c| format!("`{}`", c.name)).collect();
    let listed: Vec<String> = rows.iter().map(|r| r[0].clone()).collect();
    assert_eq!(listed, names, "the README's commands, in table order");
    for (c, r) in COMMANDS.iter().zip(&rows) {
        let args = if c.args.is_empty() {
            String::new()
        } else {
            format!("`{}`", c.args)
        };
        assert_eq!(r[1], args, "arguments of {}", c.name);
    }
}

/// The README's parameter rows as they must read (printed when they do not, to paste).
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
fn readme_lists_every_parameter_with_unit_range_and_default() {
    let text = readme();
    let want = parameter_rows();
    let rows = table(&text, "### Commands", "| name | unit |");
    let got: Vec<String> = rows
        .iter()
        .map(|r| format!("| {} |", r.join(" | ")))
        .collect();
    assert!(
        got == want,
        "the README's parameter table differs from PARAMS; its rows should be:\n{}",
        want.join("\n")
    );
    let size = format!(
        "{} bytes with today's {} parameters",
        thermorph::settings::RECORD_LEN,
        PARAMS.len()
    );
    assert!(
        text.split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
            .contains(&size),
        "the record's size should read: {size:?}"
    );
}

#[test]
fn readme_lists_every_parse_error_code() {
    let rows = table(&readme(), "### Commands", "| code | when |");
    let codes: Vec<&str> = rows.iter().map(|r| r[0].trim_matches('`')).collect();
    for e in [
        ParseError::LineTooLong,
        ParseError::BinaryInput,
        ParseError::LostBytes,
        ParseError::UnknownCommand,
        ParseError::BadArguments,
        ParseError::UnknownName,
    ] {
        assert!(codes.contains(&e.code()), "{}", e.code());
    }
}

#[test]
fn readme_telemetry_table_is_the_field_list() {
    let text = readme();
    let rows = table(&text, "### Telemetry", "| field |");
    let fields: Vec<String> = rows.iter().map(|r| r[0].trim_matches('`').into()).collect();
    assert_eq!(fields, TELEMETRY_FIELDS);
    // The format line shows them in the same order.
    let line = TELEMETRY_FIELDS
        .iter()
        .map(|f| format!("{f}=…"))
        .collect::<Vec<_>>()
        .join(" ");
    assert!(text.contains(&format!("`# {line}`")), "{line}");
}
