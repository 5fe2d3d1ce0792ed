//! What the two command-line binaries, `host-sim` and `thermorph-desk`, share: the build's
//! identity (`--version`, `host-sim version`) and shell completions.

use std::io::Write;

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
}
