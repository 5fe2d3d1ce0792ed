//! What the two command-line binaries, `host-sim` and `thermorph-desk`, share: the build's
//! identity (`--version`, `host-sim version`), shell completions, Ctrl-C and the exit status.
//!
//! The exit status is one of:
//!
//! | status | meaning |
//! |---|---|
//! | 0 | done |
//! | 1 | a runtime failure (`error: …` on standard error) |
//! | 2 | a usage error: an unknown command or option, a bad value (clap's message and usage) |
//! | 130 | interrupted by Ctrl-C (SIGINT), after the command tidied up |
//!
//! A command that has something to tidy up on Ctrl-C calls [`catch_interrupt`] and stops
//! when the flag it returns is set (`host-sim run`, the desk's `connect`, `record` and `run`);
//! [`exit`] then gives 130 whatever the command returned. A second Ctrl-C leaves at once, with
//! 130 too. The others end at once, by the signal itself, which a shell reports as 130 as well
//! (`host-sim console`, whose usual end Ctrl-C is, ends with 0).

use std::io::Write;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// Exit status of a runtime failure.
pub const EXIT_FAILURE: u8 = 1;
/// Exit status of a usage error (clap's: an unknown command or option, a bad value).
pub const EXIT_USAGE: u8 = 2;
/// Exit status after Ctrl-C (128 + SIGINT, as a shell reports a command the signal ended).
pub const EXIT_INTERRUPTED: u8 = 130;

/// The crate's version.
pub const CRATE_VERSION: &str = env!("CARGO_PKG_VERSION");
/// The git commit the binaries were built from: its short hash, with `-dirty` when tracked
/// files differed from it; `unknown` outside a git checkout (build.rs).
pub const GIT_COMMIT: &str = env!("THERMORPH_GIT_COMMIT");
/// The date of [`GIT_COMMIT`] (`YYYY-MM-DD`), or `unknown`.
pub const GIT_DATE: &str = env!("THERMORPH_GIT_DATE");
/// `--version`'s text after the binary's name: `0.1.0 (f162b2a 2025-06-14)`, or
/// `0.1.0 (git commit unknown)`.
pub const VERSION: &str = env!("THERMORPH_VERSION");
/// Whether this build has the emulated STM32F446 (`--features pil`: `run`/`paper --board`).
pub const PIL: bool = cfg!(feature = "pil");

/// `host-sim version`'s report on the build: `binary`'s `--version` line, then the crate
/// version, commit, commit date and features one per line.
pub fn version_report(binary: &str) -> String {
    let features = if PIL {
        "pil (the emulated STM32F446: `run`/`paper --board ELF`)"
    } else {
        "none (`run`/`paper --board ELF` need a build with `--features pil`)"
    };
    let dirty = if GIT_COMMIT.ends_with("-dirty") {
        " (tracked files differed from it)"
    } else {
        ""
    };
    format!(
        "{binary} {VERSION}\n\
         version   {CRATE_VERSION}\n\
         commit    {GIT_COMMIT}{dirty}\n\
         date      {GIT_DATE}\n\
         features  {features}\n"
    )
}

/// Arguments of `completions`: the shell to write a completion script for.
#[derive(clap::Args, Debug, Clone)]
pub struct CompletionsArgs {
    /// The shell.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

/// Write the completion script of the binary `command` describes (named `name`) for `shell`.
/// A reader that stops early (`| head`) is no error.
pub fn completions(
    command: &mut clap::Command,
    name: &str,
    shell: clap_complete::Shell,
    out: &mut dyn Write,
) -> std::io::Result<()> {
    // Into memory first: clap_complete panics when its writer fails.
    let mut script = Vec::new();
    clap_complete::generate(shell, command, name, &mut script);
    match out.write_all(&script).and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r,
    }
}

/// Set by Ctrl-C once [`catch_interrupt`] has been called.
static INTERRUPT: AtomicBool = AtomicBool::new(false);

/// Make Ctrl-C (SIGINT; also SIGTERM and SIGHUP) set the returned flag instead of ending the
/// process: the command checks it, stops and tidies up, and [`exit`] gives 130. A second
/// Ctrl-C ends the process at once, without tidying, with 130. Call it once per process.
pub fn catch_interrupt() -> anyhow::Result<&'static AtomicBool> {
    ctrlc::set_handler(|| {
        if INTERRUPT.swap(true, Ordering::SeqCst) {
            eprintln!("interrupted again: leaving without tidying up");
            std::process::exit(EXIT_INTERRUPTED.into());
        }
    })
    .map_err(|e| anyhow::anyhow!("cannot catch Ctrl-C: {e}"))?;
    Ok(&INTERRUPT)
}

/// Whether Ctrl-C was pressed (after [`catch_interrupt`]) or a command said it was
/// interrupted through the flag.
pub fn interrupted() -> bool {
    INTERRUPT.load(Ordering::SeqCst)
}

/// The exit of a command-line binary: the error, if any, on standard error as `error: …`
/// (`{:#}`: the error and its context, `a: b`; the typed errors carry their causes' text
/// themselves, so nothing shows twice), then 130 if the command was interrupted (Ctrl-C),
/// else 1 for an error and 0 for success. (Usage errors never get here: clap exits with 2.)
pub fn exit(result: anyhow::Result<()>) -> ExitCode {
    if let Err(e) = &result {
        eprintln!("error: {e:#}");
    }
    if interrupted() {
        ExitCode::from(EXIT_INTERRUPTED)
    } else if result.is_err() {
        ExitCode::from(EXIT_FAILURE)
    } else {
        ExitCode::SUCCESS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_version_names_the_crate_and_the_commit() {
        assert!(VERSION.starts_with(&format!("{CRATE_VERSION} (")));
        let r = version_report("host-sim");
        assert!(r.starts_with(&format!("host-sim {VERSION}\n")), "{r}");
        assert!(r.contains(&format!("commit    {GIT_COMMIT}")), "{r}");
        assert!(r.contains(&format!("date      {GIT_DATE}")), "{r}");
    }

    #[test]
    fn usage_errors_are_clap_s_status_2() {
        let e = clap::Command::new("x")
            .try_get_matches_from(["x", "--bogus"])
            .unwrap_err();
        assert_eq!(e.exit_code(), i32::from(EXIT_USAGE));
    }
}
