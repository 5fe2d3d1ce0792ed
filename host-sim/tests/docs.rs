//! The README and `docs/*.md` against what they describe (the console's tables are
//! `readme_protocol`'s):
//!
//! - every relative link (and `#anchor`) points at a file (and heading) that exists, and every
//!   page in `docs/` is linked from the README;
//! - the console examples (the README's and the session `scripts/record-session` recorded in
//!   `docs/console.md`) are replayed through `host-sim console`: every reply that does not
//!   depend on the simulated temperatures must be today's (`status` is checked by its fields and
//!   states, `log` with its times masked, telemetry by its fields);
//! - the usage blocks of `host-sim` and `thermorph-desk` list every subcommand and option their
//!   `--help` has, and no other;
//! - the desk's walk-through transcript runs `docs/desk-cycle.txt`'s lines and names the PNG's
//!   real size, and the script `docs/desk.md` quotes under `run` is that file word for word;
//! - every `host_sim::…` and `thermorph::…` path the pages name is a module or an item;
//! - the thesis's figures quoted from `host-sim paper --json` (camera on: the table in
//!   `docs/control-and-safety.md`; `--no-camera`: the table in `docs/PLANT-API.md` and the
//!   figures quoted in `docs/simulator.md` and the autotune's paragraph) are today's, to the
//!   decimals they are written with;
//! - nothing a user reads (the pages, every `--help`) sends them to the specification outside
//!   the repository or says "(this round)", the README links `docs/product.md` and explains the
//!   sensor-dump folder beside the checkout;
//! - `docs/product.md`'s numbers are the code's: its `from` tables, the parameters' defaults,
//!   the constants it cites, the regions, the commands and `host-sim paper`'s figures.

use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

mod transcripts;

use transcripts::{block_after, mask_numbers, read, root, transcript, unescape};

/// The README and every page in `docs/`, as paths relative to the workspace root.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![PathBuf::from("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| Path::new("docs").join(e.unwrap().file_name()))
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

/// The lines of `text` outside fenced code blocks, with inline code spans removed.
fn prose_lines(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Drop `code` spans (a span never holds a link).
        let mut kept = String::new();
        for (i, part) in line.split('`').enumerate() {
            if i % 2 == 0 {
                kept.push_str(part);
            }
        }
        out.push(kept);
    }
    out
}

/// The targets of the markdown links and images in `text` (`[text](target)`).
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in prose_lines(text) {
        let mut rest = line.as_str();
        while let Some(i) = rest.find("](") {
            rest = &rest[i + 2..];
            let end = rest.find(')').expect("a link's closing parenthesis");
            out.push(rest[..end].to_string());
            rest = &rest[end..];
        }
    }
    out
}

/// GitHub's anchors of the headings in `text` (lower case, punctuation dropped, spaces to
/// hyphens; a repeated heading gets `-1`, `-2`, …).
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced || !line.starts_with('#') {
            continue;
        }
        let Some(title) = line.trim_start_matches('#').strip_prefix(' ') else {
            continue;
        };
        let slug: String = title
            .trim()
            .to_lowercase()
            .chars()
            .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        let mut s = slug.clone();
        let mut n = 0;
        while seen.contains(&s) {
            n += 1;
            s = format!("{slug}-{n}");
        }
        seen.insert(s);
    }
    seen
}

#[test]
fn every_relative_link_points_at_an_existing_file_and_heading() {
    // Code blocks and spans do not count, so the fenced code the pages hold cannot hide a link.
    let text = prose_lines("a [x](y.md) `[no](z)`\n```\n[no](w)\n```\n![i](p.png#a)").join("\n");
    assert_eq!(links(&text), ["y.md", "p.png#a"]);
    assert!(
        anchors("## The `host-sim console`\n## Researcher's desk").contains("the-host-sim-console")
    );

    let mut wrong = Vec::new();
    let mut count = 0;
    for page in pages() {
        let text = read(&root().join(&page));
        let dir = page.parent().unwrap();
        for target in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            count += 1;
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let path = if file.is_empty() {
                page.clone()
            } else {
                dir.join(file)
            };
            if !root().join(&path).exists() {
                wrong.push(format!(
                    "{}: {target}: no {}",
                    page.display(),
                    path.display()
                ));
                continue;
            }
            if let Some(a) = anchor {
                let is_md = path.extension().is_some_and(|e| e == "md");
                if !is_md || !anchors(&read(&root().join(&path))).contains(a) {
                    wrong.push(format!("{}: {target}: no heading #{a}", page.display()));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "broken links:\n{}", wrong.join("\n"));
    assert!(count > 20, "only {count} links found");

    // Every page in docs/ is reachable from the README.
    let readme = links(&read(&root().join("README.md")));
    for page in pages().iter().skip(1) {
        let want = page.to_str().unwrap();
        assert!(
            readme.iter().any(|l| l.split('#').next() == Some(want)),
            "the README does not link {want}"
        );
    }
}

/// `host-sim console` (stdin/stdout, a fresh settings file) answering `lines`: what it wrote.
fn replay(name: &str, lines: &[Vec<u8>]) -> Vec<String> {
    let dir = std::env::temp_dir().join(format!("thermorph-docs-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["console", "--speed", "10", "--settings"])
        .arg(dir.join("settings.bin"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut input = Vec::new();
    for l in lines {
        input.extend_from_slice(l);
        input.extend_from_slice(b"\r\n");
    }
    child.stdin.take().unwrap().write_all(&input).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{out:?}");
    std::fs::remove_dir_all(&dir).unwrap();
    String::from_utf8(out.stdout)
        .unwrap()
        .split_terminator("\r\n")
        .map(String::from)
        .collect()
}

/// Check a transcript against a replay of its lines through `host-sim console`
/// ([`transcripts::differences`]); return how many replies were compared.
fn check_transcript(name: &str, block: &str) -> usize {
    let session = transcript(block);
    let sent: Vec<Vec<u8>> = session.iter().map(|e| e.sent.clone()).collect();
    let wrong = transcripts::differences(name, "today", &session, &replay(name, &sent));
    assert!(
        wrong.is_empty(),
        "{name}: the firmware answers differently today (run `python3 scripts/record-session` \
         for docs/console.md's session, or edit the README's example):\n{}",
        wrong.join("\n")
    );
    session.len()
}

#[test]
fn console_examples_are_what_the_firmware_answers() {
    assert_eq!(
        mask_numbers("ok events=2 | 6.55 mode a -> b"),
        "ok events=N | N mode a -> b"
    );
    assert_eq!(unescape("stat\\x1bus"), b"stat\x1bus");

    let readme = read(&root().join("README.md"));
    let n = check_transcript("readme", block_after(&readme, "<!-- console example", None));
    assert!(n >= 5, "{n}");

    let console = read(&root().join("docs/console.md"));
    let block = transcripts::console_session();
    let block = block.as_str();
    let n = check_transcript("session", block);
    assert!(n >= 15, "{n}");
    let lines: Vec<&str> = block.lines().collect();
    let telemetry = lines.iter().filter(|l| l.starts_with("# t_s=")).count();
    assert!(
        telemetry >= 6,
        "the session streams telemetry: {telemetry} lines"
    );
    // The script that writes it is named beside it, and holds the same lines.
    assert!(console.contains("`python3 scripts/record-session`"));
    let script = read(&root().join("scripts/record-session"));
    for e in transcript(block) {
        let literal = String::from_utf8_lossy(&e.sent).replace('\x1b', "\\x1b");
        assert!(
            script.contains(&format!("b\"{literal}\",")),
            "scripts/record-session does not send {literal:?}"
        );
    }
}

/// `binary`'s subcommands (from `--help`) with the long options of each.
fn cli(binary: &str) -> Vec<(String, BTreeSet<String>)> {
    let help = |args: &[&str]| {
        let out = Command::new(binary).args(args).output().unwrap();
        assert!(out.status.success(), "{binary} {args:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let top = help(&["--help"]);
    let commands: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .map(|l| l.split_whitespace().next().unwrap().to_string())
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 4, "{top}");
    commands
        .into_iter()
        .map(|c| {
            let options = help(&[&c, "--help"])
                .lines()
                .filter(|l| l.trim_start().starts_with('-'))
                .flat_map(|l| {
                    // The flags, up to the description: `-o, --out <OUT>  Output …`.
                    l.split([' ', ','])
                        .filter(|w| !w.is_empty())
                        .take_while(|w| w.starts_with('-') || w.starts_with('<'))
                        .map(String::from)
                        .collect::<Vec<_>>()
                })
                .filter(|w| w.starts_with("--") && w != "--help" && w != "--version")
                .collect();
            (c, options)
        })
        .collect()
}

/// The usage lines of `binary` in the first fenced block after `marker` in `page`: subcommand
/// (the first word after the name, `[run]` as `run`) → the long options the line names.
fn usage(page: &str, marker: &str, binary: &str) -> Vec<(String, BTreeSet<String>)> {
    let text = read(&root().join(page));
    let at = text
        .find(marker)
        .unwrap_or_else(|| panic!("{page}: no {marker:?}"));
    let block = block_after(&text[at..], "", None);
    let mut lines: Vec<String> = Vec::new();
    for l in block.lines() {
        match lines.last_mut() {
            Some(last) if l.starts_with(' ') => last.push_str(l),
            _ => lines.push(l.to_string()),
        }
    }
    lines
        .iter()
        .filter_map(|l| l.strip_prefix(&format!("{binary} ")))
        .map(|l| {
            let l = l.split(" # ").next().unwrap();
            let command = l
                .split_whitespace()
                .next()
                .unwrap()
                .trim_matches(['[', ']']);
            let options = l
                .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
                .filter(|w| w.starts_with("--"))
                .map(String::from)
                .collect();
            (command.to_string(), options)
        })
        .collect()
}

#[test]
fn usage_blocks_list_every_subcommand_and_option() {
    for (page, marker, name, binary) in [
        (
            "docs/simulator.md",
            "## Commands",
            "host-sim",
            env!("CARGO_BIN_EXE_host-sim"),
        ),
        (
            "docs/desk.md",
            "# Researcher's desk",
            "thermorph-desk",
            env!("CARGO_BIN_EXE_thermorph-desk"),
        ),
    ] {
        let mut want = cli(binary);
        let mut got = usage(page, marker, name);
        want.sort();
        got.sort();
        assert_eq!(
            got, want,
            "{page}: the usage block of {name} against its --help (subcommand, long options)"
        );
    }
}

#[test]
fn desk_walk_through_runs_the_script_and_names_the_plot() {
    let desk = read(&root().join("docs/desk.md"));
    let script = read(&root().join("docs/desk-cycle.txt"));
    let script: Vec<&str> = script.lines().collect();
    let at = desk
        .find("[   0.00 s] line")
        .expect("the walk-through's output");
    let block = &desk[at..at + desk[at..].find("```").unwrap()];
    let mut n = 0;
    for l in block.lines().filter(|l| l.starts_with('[')) {
        let rest = l.split_once("] line ").expect("[ t s] line N: …").1;
        let (number, step) = rest.split_once(": ").unwrap();
        let number: usize = number.parse().unwrap();
        let step = match step.split_once(" -> ") {
            Some((command, _)) => command,
            None => step.rsplit_once(": ").unwrap().0,
        };
        // The script's own comments are not part of the step.
        let line = script[number - 1].split('#').next().unwrap().trim_end();
        let line = line.split(" within ").next().unwrap();
        assert_eq!(step, line, "docs/desk-cycle.txt line {number}");
        n += 1;
    }
    assert!(n >= 8, "{n} steps");

    // `wrote docs/desk-cycle.png (WxH px: …)` is the PNG beside it.
    let png = std::fs::read(root().join("docs/desk-cycle.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
    let size = format!("wrote docs/desk-cycle.png ({}x{} px", be(16), be(20));
    assert!(
        block.contains(&size),
        "the walk-through should read {size:?}"
    );
}

/// The script `docs/desk.md` shows under `run` is `docs/desk-cycle.txt`, the one the
/// walk-through runs and the PNG was made with, so the two cannot drift apart.
#[test]
fn desk_quoted_script_is_the_walk_through_script() {
    let desk = read(&root().join("docs/desk.md"));
    let script = read(&root().join("docs/desk-cycle.txt"));
    let run = desk.find("\n- `run`:").expect("docs/desk.md's `run` item");
    let open = "\n  ```text\n";
    let at = run + desk[run..].find(open).expect("a script block under `run`") + open.len();
    let block = &desk[at..at + desk[at..].find("  ```\n").unwrap()];
    let quoted: String = block
        .lines()
        .map(|l| format!("{}\n", l.strip_prefix("  ").unwrap_or(l)))
        .collect();
    assert_eq!(
        quoted, script,
        "docs/desk.md's script under `run` against docs/desk-cycle.txt"
    );
}

/// The `host_sim::…` and `thermorph::…` paths the pages name.
fn rust_paths(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for krate in ["host_sim::", "thermorph::"] {
        for (i, _) in text.match_indices(krate) {
            let before = text[..i].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let path: String = text[i..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                .collect();
            out.push(path.trim_end_matches(':').to_string());
        }
    }
    out
}

/// Whether `text` holds `words` with no identifier character just before or after.
fn has_word(text: &str, words: &str) -> bool {
    let ident = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || c == '_');
    text.match_indices(words).any(|(i, _)| {
        !ident(text[..i].chars().next_back()) && !ident(text[i + words.len()..].chars().next())
    })
}

/// Whether `path` names a module of the workspace's crates, or an item declared in one (then
/// any further segments, as `Type::method`, declared in that module's folder).
fn resolves(path: &str) -> bool {
    let mut segments = path.split("::");
    let (mut dir, mut file) = match segments.next() {
        Some("host_sim") => (
            root().join("host-sim/src"),
            root().join("host-sim/src/lib.rs"),
        ),
        Some("thermorph") => (
            root().join("firmware/src"),
            root().join("firmware/src/lib.rs"),
        ),
        _ => return false,
    };
    let rest: Vec<&str> = segments.collect();
    for (i, seg) in rest.iter().enumerate() {
        if dir.join(format!("{seg}.rs")).exists() {
            file = dir.join(format!("{seg}.rs"));
            dir = dir.join(seg);
        } else if dir.join(seg).join("mod.rs").exists() {
            file = dir.join(seg).join("mod.rs");
            dir = dir.join(seg);
        } else {
            let declares = |text: &str, name: &str| {
                [
                    "fn", "struct", "enum", "trait", "const", "static", "type", "mod",
                ]
                .iter()
                .any(|k| has_word(text, &format!("{k} {name}")))
                    || text
                        .split(';')
                        .map(|s| s.lines().filter(|l| !l.trim_start().starts_with("//")))
                        .map(|s| s.collect::<Vec<_>>().join(" "))
                        .any(|s| s.trim_start().starts_with("pub use") && has_word(&s, name))
            };
            if !declares(&read(&file), seg) {
                return false;
            }
            // Members of the item: declared somewhere beside it.
            let beside: String = std::fs::read_dir(file.parent().unwrap())
                .unwrap()
                .map(|e| e.unwrap().path())
                .filter(|p| p.extension().is_some_and(|e| e == "rs"))
                .map(|p| read(&p))
                .collect();
            return rest[i + 1..].iter().all(|m| declares(&beside, m));
        }
    }
    true
}

#[test]
fn every_rust_path_the_pages_name_exists() {
    assert!(resolves("host_sim::runs::run::run"));
    assert!(!resolves("host_sim::run::run"));
    let mut wrong = Vec::new();
    let mut count = 0;
    for page in pages() {
        for path in rust_paths(&read(&root().join(&page))) {
            count += 1;
            if !resolves(&path) {
                wrong.push(format!("{}: {path}", page.display()));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "no such module or item:\n{}",
        wrong.join("\n")
    );
    assert!(count >= 8, "only {count} paths found");
}

/// `host-sim paper --json` (camera on, or with `--no-camera`): figure → `{thesis, sim, pass}`.
fn paper(camera: bool) -> serde_json::Map<String, serde_json::Value> {
    let mut args = vec!["paper", "--json"];
    if !camera {
        args.push("--no-camera");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(&args)
        .output()
        .unwrap();
    assert!(out.status.success(), "host-sim {args:?}: {out:?}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object().unwrap().clone()
}

/// A figure's simulated values (one, or the pulse drops' three).
fn sims(figure: &serde_json::Value) -> Vec<f64> {
    match &figure["sim"] {
        serde_json::Value::Array(a) => a.iter().map(|x| x.as_f64().unwrap()).collect(),
        x => vec![x.as_f64().unwrap()],
    }
}

/// The numbers written in `text` with their decimals (`−` or `-` before a digit is a sign).
fn numbers(text: &str) -> Vec<(f64, usize)> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let signed = matches!(chars[i], '−' | '-')
            && chars.get(i + 1).is_some_and(|c| c.is_ascii_digit())
            && !(i > 0 && chars[i - 1].is_alphanumeric());
        let starts = chars[i].is_ascii_digit() && !(i > 0 && chars[i - 1].is_alphanumeric());
        if !(signed || starts) {
            i += 1;
            continue;
        }
        let mut s = String::from(if signed { "-" } else { "" });
        i += usize::from(signed);
        let mut decimals = None;
        while i < chars.len() {
            let c = chars[i];
            if c.is_ascii_digit() {
                s.push(c);
                decimals = decimals.map(|d: usize| d + 1);
            } else if c == '.'
                && decimals.is_none()
                && chars.get(i + 1).is_some_and(|c| c.is_ascii_digit())
            {
                s.push(c);
                decimals = Some(0);
            } else {
                break;
            }
            i += 1;
        }
        out.push((s.parse().unwrap(), decimals.unwrap_or(0)));
    }
    out
}

/// Whether a number written with `decimals` decimals is `sim` rounded.
fn rounds_to(written: (f64, usize), sim: f64) -> bool {
    (written.0 - sim).abs() <= 0.5 * 10f64.powi(-(written.1 as i32)) + 1e-9
}

/// The cells (trimmed) of a table row; `\|` is a `|` inside a cell.
fn cells(row: &str) -> Vec<String> {
    row.replace("\\|", "\u{0}")
        .trim()
        .trim_matches('|')
        .split('|')
        .map(|c| c.trim().replace('\u{0}', "|"))
        .collect()
}

/// The rows (cells, trimmed) of the first table after `heading` in `text`.
fn table_after(text: &str, heading: &str) -> Vec<Vec<String>> {
    let at = text
        .find(heading)
        .unwrap_or_else(|| panic!("no {heading:?}"));
    text[at..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(cells)
        .collect()
}

/// Every table in `text`: its header's cells and its rows' cells.
fn tables(text: &str) -> Vec<(Vec<String>, Vec<Vec<String>>)> {
    let mut out: Vec<(Vec<String>, Vec<Vec<String>>)> = Vec::new();
    let mut in_table = false;
    for line in text.lines() {
        if !line.starts_with('|') {
            in_table = false;
        } else if !in_table {
            in_table = true;
            out.push((cells(line), Vec::new()));
        } else if !line.starts_with("|--") && !line.starts_with("| --") {
            out.last_mut().unwrap().1.push(cells(line));
        }
    }
    out
}

/// In `text`, the number right after `before` rounds `sim`.
fn check_after(wrong: &mut Vec<String>, place: &str, text: &str, before: &str, sim: f64) {
    let Some(at) = text.find(before) else {
        wrong.push(format!("{place}: no {before:?}"));
        return;
    };
    match numbers(&text[at + before.len()..]).first() {
        Some(&n)
            if rounds_to(n, sim)
                && text[at + before.len()..]
                    .starts_with(|c: char| c.is_ascii_digit() || c == '−' || c == '-') => {}
        n => wrong.push(format!("{place}: after {before:?}: {n:?}, today {sim}")),
    }
}

#[test]
fn paper_figures_in_the_docs_are_todays() {
    assert_eq!(
        numbers("−0.02, −0.11, 1406; ×4.54 a2"),
        [(-0.02, 2), (-0.11, 2), (1406.0, 0), (4.54, 2)]
    );
    let mut wrong = Vec::new();

    // Camera on: docs/control-and-safety.md's table, one row per figure.
    let on = paper(true);
    let page = read(&root().join("docs/control-and-safety.md"));
    let rows = table_after(&page, "`host-sim paper` (camera on, 298 K):");
    let listed: BTreeSet<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(
        listed,
        on.keys().map(String::as_str).collect(),
        "the table's figures"
    );
    for r in &rows {
        let f = &on[&r[0]];
        let written = numbers(&r[2]);
        let today = sims(f);
        let same = written.len() == today.len()
            && written.iter().zip(&today).all(|(&w, &s)| rounds_to(w, s));
        let pass = f["pass"].as_bool().unwrap();
        if !same || r[4].starts_with("pass") != pass {
            wrong.push(format!(
                "control-and-safety.md: {} | {} | {}: today {today:?}, {}",
                r[0],
                r[2],
                r[4],
                if pass { "pass" } else { "fail" }
            ));
        }
    }

    // Camera off: docs/PLANT-API.md's table (figures grouped by row) and the prose that quotes it.
    let off = paper(false);
    let page = read(&root().join("docs/PLANT-API.md"));
    let rows = table_after(
        &page,
        "## Closed loop (`cargo run --release -p host-sim -- paper --no-camera`)",
    );
    let groups: [&[&str]; 8] = [
        &[
            "preheat_time_s",
            "standby_overshoot_k",
            "standby_hold_band_k",
        ],
        &[
            "large_stepping_time_s",
            "full_loading_one_spring_deg",
            "full_loading_two_springs_deg",
        ],
        &["pulse_drop_deg"],
        &["forming_time_s", "forming_angle_loss_deg"],
        &["formed_k_b", "stiffness_ratio"],
        &["recovery_time_s"],
        &["cycle_time_s"],
        &["stepping_soak_s", "recovery_k_b_25s_ratio", "spring_peak_k"],
    ];
    assert_eq!(rows.len(), groups.len(), "PLANT-API.md's closed-loop rows");
    for (r, keys) in rows.iter().zip(groups) {
        let today: Vec<f64> = keys.iter().flat_map(|k| sims(&off[*k])).collect();
        let written = numbers(&r[2]);
        let same = written.len() == today.len()
            && written.iter().zip(&today).all(|(&w, &s)| rounds_to(w, s));
        let pass = keys.iter().all(|k| off[*k]["pass"].as_bool().unwrap());
        if !same || r[3].starts_with("pass") != pass {
            wrong.push(format!(
                "PLANT-API.md: {} | {} | {}: today {today:?}",
                r[0], r[2], r[3]
            ));
        }
    }
    let sim = |k: &str| sims(&off[k])[0];
    let page = read(&root().join("docs/simulator.md"));
    let at = page
        .find("In the closed loop (")
        .expect("simulator.md's closed-loop figures");
    let para = &page[at..at + page[at..].find("\n\n").unwrap()];
    let para = para.split_whitespace().collect::<Vec<_>>().join(" ");
    for (before, key) in [
        ("forming takes ", "forming_time_s"),
        ("loses ", "forming_angle_loss_deg"),
        ("k_b ", "formed_k_b"),
        ("(×", "stiffness_ratio"),
        ("loading ", "full_loading_one_spring_deg"),
        ("° / ", "full_loading_two_springs_deg"),
        ("recovery ", "recovery_time_s"),
    ] {
        check_after(&mut wrong, "simulator.md", &para, before, sim(key));
    }
    let page = read(&root().join("docs/control-and-safety.md"));
    let at = page
        .find("`host-sim paper --no-camera`) ")
        .expect("the autotune's figures");
    let para = page[at..at + 300]
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    for (before, key) in [
        ("322.5 K in ", "preheat_time_s"),
        ("323 K by ", "standby_overshoot_k"),
        ("holds ±", "standby_hold_band_k"),
    ] {
        check_after(&mut wrong, "control-and-safety.md", &para, before, sim(key));
    }
    assert!(
        wrong.is_empty(),
        "figures that `host-sim paper --json [--no-camera]` gives otherwise today:\n{}",
        wrong.join("\n")
    );
}

/// The README's headline envelope (issue 44: it had drifted from a rerun of the command
/// printed beside it): the default cycle from 263 to 323 K ambient, its two-spring loading's
/// range, how near straight it comes back, no fault, the hottest spring — each the sweep's
/// figure rounded as written.
#[test]
fn the_readme_envelope_is_what_its_sweep_gives() {
    const COMMAND: &str = "host-sim sweep cycle --set ambient=263K,273K,283K,298K,308K,318K,323K --set\nduration=900s";
    let readme = read(&root().join("README.md"));
    assert!(
        readme.contains(&format!("(`{COMMAND}`)")),
        "the README names another sweep"
    );
    let dir =
        std::env::temp_dir().join(format!("thermorph-readme-envelope-{}", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args([
            "sweep",
            "cycle",
            "--set",
            "ambient=263K,273K,283K,298K,308K,318K,323K",
        ])
        .args(["--set", "duration=900s", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let csv = read(&dir.join("sweep.csv"));
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 7);
    let all = |name: &str| rows.iter().map(|r| r[col(name)]).collect::<Vec<f64>>();
    let max = |v: Vec<f64>| v.into_iter().fold(f64::MIN, f64::max);
    let min = |v: Vec<f64>| v.into_iter().fold(f64::MAX, f64::min);
    let mut wrong = Vec::new();
    let load = all("full_loading_two_springs_deg");
    check_after(
        &mut wrong,
        "README",
        &readme,
        "the default cycle loads ",
        min(load.clone()),
    );
    check_after(
        &mut wrong,
        "README",
        &readme,
        &format!("loads {:.1}–", min(load.clone())),
        max(load),
    );
    check_after(
        &mut wrong,
        "README",
        &readme,
        "comes back within ",
        max(all("final_bend_deg")),
    );
    check_after(
        &mut wrong,
        "README",
        &readme,
        "the hottest spring ",
        max(all("spring_peak_k")),
    );
    assert_eq!(max(all("faults")), 0.0, "a fault in the envelope");
    assert!(readme.contains("of straight, no fault,"));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// The `--help` of `binary` and of each of its subcommands ([`cli`]'s): (what was run, text).
fn help_texts(binary: &str) -> Vec<(String, String)> {
    let help = |args: &[&str]| {
        let out = Command::new(binary).args(args).output().unwrap();
        assert!(out.status.success(), "{binary} {args:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let name = Path::new(binary).file_name().unwrap().to_string_lossy();
    let mut texts = vec![(format!("{name} --help"), help(&["--help"]))];
    for (command, _) in cli(binary) {
        texts.push((
            format!("{name} {command} --help"),
            help(&[&command, "--help"]),
        ));
    }
    texts
}

/// What in `text` sends a user outside the repository or speaks the workshop's language: the
/// specification (a maintainers' file beside the checkout, not in a clone) or a section of it,
/// and "(this round)".
fn outside_references(text: &str) -> Vec<&'static str> {
    let mut found: Vec<&'static str> = ["../shared/SPEC.md", "SPEC.md", "SPEC section"]
        .into_iter()
        .filter(|s| text.contains(s))
        .collect();
    if has_word(text, "SPEC") {
        found.push("SPEC");
    }
    if text.to_lowercase().contains("(this round)") {
        found.push("(this round)");
    }
    found
}

/// Issue 44 (a researcher's first hour): the README and `--help` sent readers to
/// `../shared/SPEC.md`, which a clone does not have. No page a user reads (README.md,
/// docs/*.md) and no `--help` of `host-sim`, `thermorph-desk` or any of their subcommands names
/// the specification or a section of it, or says "(this round)"; docs/product.md describes
/// the product and the README links it; the README still explains the sensor-dump folder
/// beside the checkout (where, the override, what a clone without it does, where the dumps
/// come from).
#[test]
fn nothing_a_user_reads_points_outside_the_repository() {
    assert_eq!(
        outside_references("see ../shared/SPEC.md, SPEC section 8 (this round)"),
        [
            "../shared/SPEC.md",
            "SPEC.md",
            "SPEC section",
            "SPEC",
            "(this round)"
        ]
    );
    assert_eq!(outside_references("the SPEC's 50 mm"), ["SPEC"]);
    assert!(outside_references("SPECS, a SPECTRUM, the spec, round 2").is_empty());

    let mut texts: Vec<(String, String)> = pages()
        .into_iter()
        .map(|p| (p.display().to_string(), read(&root().join(&p))))
        .collect();
    let n_pages = texts.len();
    texts.extend(help_texts(env!("CARGO_BIN_EXE_host-sim")));
    texts.extend(help_texts(env!("CARGO_BIN_EXE_thermorph-desk")));
    assert!(texts.len() >= n_pages + 15, "only {} texts", texts.len());
    let wrong: Vec<String> = texts
        .iter()
        .filter_map(|(place, text)| {
            let found = outside_references(text);
            (!found.is_empty()).then(|| format!("{place}: {found:?}"))
        })
        .collect();
    assert!(
        wrong.is_empty(),
        "what a user reads names the specification outside the repository (link \
         docs/product.md's section instead; `--help`: \"the thesis's figures (docs/product.md)\") \
         or says \"(this round)\":\n{}",
        wrong.join("\n")
    );

    assert!(
        root().join("docs/product.md").is_file(),
        "no docs/product.md"
    );
    let readme = read(&root().join("README.md"));
    assert!(
        links(&readme)
            .iter()
            .any(|l| l.split('#').next() == Some("docs/product.md")),
        "the README does not link docs/product.md"
    );
    for said in [
        "../shared/data/mlx90640/",
        "THERMORPH_DATA_DIR",
        "SKIPPED",
        "THERMORPH_REQUIRE_DATA=1",
        "https://github.com/melexis/mlx90640-library",
    ] {
        assert!(
            readme.contains(said),
            "the README no longer explains the sensor-dump folder: no {said:?}"
        );
    }
}

/// A value the code holds, by the name docs/product.md gives it: a console parameter's default
/// (`thermorph::settings::PARAMS`, as `get` shows it) or a constant the page cites by path.
fn code_value(name: &str) -> Option<Vec<f64>> {
    use host_sim::plant::params as plant;
    use thermorph::block;
    use thermorph::settings::{PARAMS, Settings};
    if let Some(p) = PARAMS.iter().find(|p| p.name == name) {
        return Some(vec![f64::from((p.get)(&Settings::DEFAULT))]);
    }
    let f = |x: f32| f64::from(x);
    Some(match name {
        "thermorph::block::CYLINDER_LENGTH_MM" => vec![f(block::CYLINDER_LENGTH_MM)],
        "thermorph::block::CYLINDER_INNER_DIAMETER_MM" => {
            vec![f(block::CYLINDER_INNER_DIAMETER_MM)]
        }
        "thermorph::block::CYLINDER_WALL_MM" => vec![f(block::CYLINDER_WALL_MM)],
        "thermorph::block::LATTICE_UNIT_MM" => vec![f(block::LATTICE_UNIT_MM)],
        "thermorph::block::LATTICE_GAP_MM" => vec![f(block::LATTICE_GAP_MM)],
        "thermorph::block::LATTICE_UPPER_LAYER_MM" => vec![f(block::LATTICE_UPPER_LAYER_MM)],
        "thermorph::block::LATTICE_LOWER_LAYER_MM" => vec![f(block::LATTICE_LOWER_LAYER_MM)],
        "thermorph::block::PLATE_THICKNESS_MM" => vec![f(block::PLATE_THICKNESS_MM)],
        "thermorph::block::PLATE_DIAMETER_MM" => vec![f(block::PLATE_DIAMETER_MM)],
        "thermorph::block::SPRING_RADIUS_MM" => vec![f(block::SPRING_RADIUS_MM)],
        "thermorph::block::SPRING_SPACING_DEG" => vec![f(block::SPRING_SPACING_DEG)],
        "thermorph::block::CAMERA_DISTANCE_MM" => {
            let (near, far) = block::CAMERA_DISTANCE_MM;
            vec![f(near), f(far)]
        }
        "thermorph::mlx90640::COLS" => vec![thermorph::mlx90640::COLS as f64],
        "thermorph::mlx90640::ROWS" => vec![thermorph::mlx90640::ROWS as f64],
        "thermorph::app::CONTROL_PERIOD_MS" => vec![thermorph::app::CONTROL_PERIOD_MS as f64],
        "host_sim::plant::params::SMP_TG_K" => vec![plant::SMP_TG_K],
        "host_sim::plant::params::WIRE_DIAMETER_MM" => vec![plant::WIRE_DIAMETER_MM],
        "host_sim::plant::params::SPRING_SUPPLY_V" => vec![plant::SPRING_SUPPLY_V],
        "host_sim::plant::params::SPRING_SUPPLY_LIMIT_A" => vec![plant::SPRING_SUPPLY_LIMIT_A],
        "host_sim::plant::params::HEATER_SUPPLY_V" => vec![plant::HEATER_SUPPLY_V],
        "host_sim::plant::params::HEATER_SUPPLY_LIMIT_A" => vec![plant::HEATER_SUPPLY_LIMIT_A],
        "host_sim::runs::paper::STEP_AT_S" => vec![host_sim::runs::paper::STEP_AT_S],
        _ => return None,
    })
}

/// The `code spans` of `text`.
fn code_spans(text: &str) -> Vec<&str> {
    text.split('`').skip(1).step_by(2).collect()
}

/// Whether the numbers written in `text` are `values`, rounded as written.
fn written_as(text: &str, values: &[f64]) -> bool {
    let written = numbers(text);
    written.len() == values.len() && written.iter().zip(values).all(|(&w, &v)| rounds_to(w, v))
}

/// docs/product.md's numbers are the code's (issue 44: the product described in the project's
/// own words, every number with the code that holds it): each row of a table whose last column
/// is `from` holds the values of the names it cites; a parameter written `` `name` (N …`` holds
/// its default; a number written `N … (`path`)` is that constant; the region table is MTTS's
/// names; the console section names every command; the figures table is `host-sim paper`'s
/// figures with the references, tolerances and definitions of `cycle_figures::judge`.
#[test]
fn product_page_numbers_are_the_codes() {
    assert_eq!(cells(r"| a \| b | `c` |"), ["a | b", "`c`"]);
    assert_eq!(code_spans("a `b` c `d`"), ["b", "d"]);
    assert!(written_as("32 × 24", &[32.0, 24.0]) && written_as("1.8 mm", &[1.799_999_952]));

    let page = read(&root().join("docs/product.md"));
    let mut wrong = Vec::new();
    let mut checked = 0;

    // Tables with a `from` column.
    for (header, rows) in tables(&page) {
        if header.last().map(String::as_str) != Some("from") {
            continue;
        }
        for row in rows {
            let names = code_spans(row.last().unwrap());
            let values: Option<Vec<f64>> = names
                .iter()
                .map(|n| code_value(n))
                .collect::<Option<Vec<Vec<f64>>>>()
                .map(|v| v.concat());
            match values {
                Some(v) if written_as(&row[row.len() - 2], &v) => checked += 1,
                Some(v) => wrong.push(format!("{row:?}: the code holds {v:?}")),
                None => wrong.push(format!("{row:?}: {names:?} is not a value the test knows")),
            }
        }
    }

    // `name` (N …): a parameter's default; N … (`path`): a constant.
    for (i, _) in page.match_indices("` (") {
        let Some(open) = page[..i].rfind('`') else {
            continue;
        };
        let name = &page[open + 1..i];
        let after = &page[i + 3..];
        if thermorph::settings::PARAMS.iter().any(|p| p.name == name)
            && after.starts_with(|c: char| c.is_ascii_digit())
        {
            let v = code_value(name).unwrap()[0];
            match numbers(after).first() {
                Some(&n) if rounds_to(n, v) => checked += 1,
                n => wrong.push(format!("`{name}` ({n:?}: its default is {v}")),
            }
        }
    }
    for (i, _) in page.match_indices("(`") {
        let path: String = page[i + 2..].chars().take_while(|c| *c != '`').collect();
        if !path.contains("::") || !page[i + 2 + path.len()..].starts_with("`)") {
            continue;
        }
        if let Some(v) = code_value(&path) {
            match numbers(&page[..i]).last() {
                Some(&n) if rounds_to(n, v[0]) => checked += 1,
                n => wrong.push(format!("{n:?} (`{path}`): the code holds {v:?}")),
            }
        }
    }

    // The five regions, named as `status` names them.
    let regions = table_after(&page, "## Region temperatures");
    let names: Vec<&str> = regions.iter().map(|r| r[1].as_str()).collect();
    assert_eq!(names, thermorph::mtts::REGION_NAMES, "the regions' names");
    let labels: Vec<&str> = regions.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(labels, ["T1", "T2", "T3", "T4", "T5"]);

    // The console section names every command.
    let at = page.find("## The console").expect("a console section");
    let section = &page[at..at + page[at + 3..].find("\n## ").unwrap()];
    for c in thermorph::command::COMMANDS {
        if !section.contains(&format!("`{}`", c.name)) {
            wrong.push(format!("the console section does not name `{}`", c.name));
        }
    }

    // The figures: `host-sim paper`'s, as `cycle_figures::judge` defines them.
    let figures = host_sim::runs::cycle_figures::judge(&Default::default(), None);
    let rows = table_after(&page, "## Figures");
    let listed: Vec<String> = rows
        .iter()
        .map(|r| r[0].trim_matches('`').to_string())
        .collect();
    assert_eq!(
        listed,
        host_sim::runs::cycle_figures::KEYS,
        "the figures table's keys, in order"
    );
    for (row, fig) in rows.iter().zip(&figures) {
        let thesis: Vec<f64> = match &fig.thesis {
            serde_json::Value::Array(a) => a.iter().map(|x| x.as_f64().unwrap()).collect(),
            serde_json::Value::Null => Vec::new(),
            x => vec![x.as_f64().unwrap()],
        };
        let reference_ok = if thesis.is_empty() {
            row[1] == "—"
        } else {
            written_as(&row[1], &thesis)
        };
        if !reference_ok || Some(row[2].as_str()) != fig.tolerance.as_deref() || row[3] != fig.how {
            wrong.push(format!(
                "figures: {row:?}: the code has {thesis:?} | {:?} | {:?}",
                fig.tolerance, fig.how
            ));
        }
    }

    assert!(
        wrong.is_empty(),
        "docs/product.md against the code:\n{}",
        wrong.join("\n")
    );
    assert!(checked >= 45, "only {checked} numbers checked");
}
