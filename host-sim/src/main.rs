//! `host-sim`: Thermorph's simulator on the command line.
//!
//! - `host-sim [SCENE] [--out DIR] [--quiet]` (or the same after `run`): the main job — a
//!   scene (default: the bundled `cycle`) played against the simulated block, writing a CSV time
//!   series, a summary JSON and a PNG plot, and printing the summary. Without `run`, a first
//!   word that names a command is that command.
//! - `host-sim sweep SCENE --set KEY=V1,V2,… [--set …] [--shard K/N] [--out DIR]` (or
//!   `--merge SHARD.csv … [--out FILE]`): a scene over a grid of overrides, in parallel.
//! - `host-sim console [--speed X] [--pty] [--settings FILE] [SCENE]`: the simulated block
//!   behind the board's console, on stdin/stdout or on a pseudo-terminal (its path printed).
//! - `host-sim sensor`: the virtual MLX90640 on a simulated I2C bus, read and decoded by the
//!   firmware's own driver, with a summary.
//! - `host-sim decode --eeprom FILE --frame FILE [...]`: decode real sensor dumps to CSV.
//! - `host-sim mtts --image FILE [...]`: the five region temperatures of an image.
//! - `host-sim scene [NAME]`: a rendered standard scene as an image file (no name: the list).
//! - `host-sim plant-wp [--out FILE]`: the plant's work-precision table.
//! - `host-sim mtts-wp [--m4 FILE] [--out FILE] [--seeds N]`: the MTTS work-precision table.
//! - `host-sim paper [--json] [--no-camera] [--out DIR] [--board ELF]`: the thesis's figures
//!   (with `--board`, from runs of the board's own ELF on the emulated STM32F446).
//! - `host-sim version`: the build — crate version, git commit (`-dirty` if tracked files
//!   differed from it) and its date, features; `--version` prints its first line.
//! - `host-sim completions bash|zsh|fish|elvish|powershell`: the shell's completion script.
//!
//! Exit status ([`host_sim::cli`]): 0 done, 1 a runtime failure, 2 a usage error (a word that
//! is neither a command nor a scene is one), 130 interrupted by Ctrl-C (`run` stops at the end
//! of its period and writes nothing).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use thermorph::mlx90640::DecodeParams;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version = host_sim::cli::VERSION,
    about = "Thermorph simulator",
    long_about = "Thermorph simulator. Without a command, `host-sim [SCENE] [--out DIR] \
[--quiet]` is `host-sim run …`: the scene (default: cycle) played against the simulated block.",
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// `run`'s arguments, for `host-sim [SCENE] [--out DIR] [--quiet]` without `run`.
    #[command(flatten)]
    run: host_sim::runs::run::RunArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Decode MLX90640 dumps (text: docs/simulator.md) and print `pixel,row,col,value` in °C.
    Decode {
        /// EEPROM dump (832 words).
        #[arg(long)]
        eeprom: PathBuf,
        /// Frame dumps (834 words each), decoded in order into one image.
        #[arg(long = "frame", required = true)]
        frames: Vec<PathBuf>,
        /// Object emissivity, 0 < E ≤ 1.
        #[arg(long, default_value_t = 1.0)]
        emissivity: f32,
        /// Reflected temperature = Ta − S (K or °C, the same step).
        #[arg(
            long = "ta-shift",
            default_value_t = 8.0,
            allow_negative_numbers = true
        )]
        ta_shift: f32,
    },
    /// Play a scene against the simulated block; write timeseries.csv, summary.json, plot.png.
    Run(host_sim::runs::run::RunArgs),
    /// One scene over a grid of overrides (`--set KEY=V1,V2,…`), in parallel across the cores;
    /// one CSV row per case and a PNG of each figure against the first swept key.
    Sweep(host_sim::runs::sweep::SweepArgs),
    /// The simulated block behind the board's console, in real time (or `--speed` times it), on
    /// stdin/stdout or on a pseudo-terminal whose path is printed; Ctrl-C ends it.
    Console(host_sim::console::sim::ConsoleArgs),
    /// Run the virtual MLX90640 through the firmware's driver and print a summary.
    Sensor(host_sim::sensor::demo::SensorArgs),
    /// Find the five region temperatures of a 24×32 image (CSV, K, `nan` = broken pixel; or
    /// `host-sim decode`'s CSV in °C) and print `region,name,temp_k,pixels` and the frame's
    /// quality and bound.
    Mtts {
        /// Image CSV: 24 lines of 32 values in kelvin, or `host-sim decode`'s
        /// `pixel,row,col,value` lines in °C (told apart by that header).
        #[arg(long)]
        image: PathBuf,
        /// Upsampling factor, 1–8.
        #[arg(long, default_value_t = 4)]
        scale: u8,
        /// Number of clusters, 2–8.
        #[arg(long, default_value_t = 5)]
        k: u8,
        /// Clustering method: exact, lloyd or kmeanspp.
        #[arg(long, default_value = "exact")]
        method: String,
        /// Seed of the lloyd and kmeanspp methods.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The mode's prior: unknown, heater-hotter or surface-hotter.
        #[arg(long, default_value = "unknown")]
        prior: String,
        /// The block's design: share of each lattice unit the heater shows through, 15–90 %
        /// (the thesis's lattice: 71).
        #[arg(long, default_value_t = thermorph::mtts::DEFAULT_EXPOSED_PCT)]
        exposed_pct: u8,
    },
    /// Print a standard rendered scene as an image CSV (truth in `#` comment lines); without a
    /// name, list the scenes.
    Scene {
        /// Scene name (none, or an unknown one, lists them).
        name: Option<String>,
        /// Noise seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Write the plant's work-precision table (integrator × step × fidelity) as Markdown.
    PlantWp {
        /// Output file.
        #[arg(long, default_value = "docs/plant-work-precision.md")]
        out: PathBuf,
    },
    /// Measure the MTTS work-precision table (speed against error) and print it as markdown.
    MttsWp(host_sim::imaging::mtts_wp::WpArgs),
    /// Run posture control (`mode pose ANGLE SPRINGS form`) over targets, spring sets and
    /// ambients, camera on, and print the posture and bend-estimate tables (docs/posture.md).
    PoseTable,
    /// Run the thesis's experiments (camera on, the firmware's supervisor) and print the
    /// thesis's figures (docs/product.md) beside the simulated ones, with tolerance and
    /// pass/fail.
    Paper {
        /// Print one JSON object keyed by figure instead of the table.
        #[arg(long)]
        json: bool,
        /// Skip the camera: the supervisor sees the true temperatures (a quick look; the
        /// figures are defined with the camera on).
        #[arg(long)]
        no_camera: bool,
        /// Also write each experiment's time series (CSV) into this folder.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Play the experiments with the board's own ELF on the emulated STM32F446 instead of
        /// the library's supervisor (a host-sim built with `--features pil`; camera on).
        #[arg(long, value_name = "ELF")]
        board: Option<PathBuf>,
    },
    /// Print the build: crate version, git commit (`-dirty` if tracked files differed from
    /// it), the commit's date and the features built in.
    Version,
    /// Print the shell's completion script (e.g. `host-sim completions bash >
    /// ~/.local/share/bash-completion/completions/host-sim`).
    Completions(host_sim::cli::CompletionsArgs),
}

fn main() -> ExitCode {
    // A usage error (clap's, or a first word that is neither a command nor a scene): clap's
    // message and usage, exit status 2.
    let command = command(Cli::parse()).unwrap_or_else(|e| e.exit());
    host_sim::cli::exit(run(command))
}

/// The command to run: the one named, or `run` with the arguments given without it; a first
/// word that is neither a command nor a scene is a usage error listing both.
fn command(cli: Cli) -> Result<Command, clap::Error> {
    match cli.command {
        Some(c) => Ok(c),
        None => {
            // `host-sim WORD`: a scene; a word that is neither gets both lists.
            if let Err(host_sim::runs::scenario::ScenarioError::Unknown { name, bundled }) =
                host_sim::runs::scenario::source(&cli.run.scene)
            {
                let mut cmd = <Cli as clap::CommandFactory>::command();
                let commands: Vec<String> = cmd
                    .get_subcommands()
                    .map(|c| c.get_name().to_string())
                    .collect();
                return Err(cmd.error(
                    clap::error::ErrorKind::InvalidSubcommand,
                    format!(
                        "`{name}` is neither a command ({}) nor a scene (a file, or bundled: \
                         {bundled})",
                        commands.join(", ")
                    ),
                ));
            }
            Ok(Command::Run(cli.run))
        }
    }
}

/// Run the command.
fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Decode {
            eeprom,
            frames,
            emissivity,
            ta_shift,
        } => {
            let params = DecodeParams {
                emissivity,
                reflected: None,
                ta_shift_k: ta_shift,
            };
            let img = host_sim::imaging::decode::decode_files(&eeprom, &frames, &params)?;
            let stdout = std::io::stdout();
            let mut out = std::io::BufWriter::new(stdout.lock());
            host_sim::imaging::decode::write_csv(&img, &mut out)?;
            Ok(())
        }
        Command::Run(args) => match &args.board {
            // Ctrl-C stops the run at the end of its period: exit status 130.
            None => host_sim::runs::run::cli(&args, host_sim::cli::catch_interrupt()?),
            Some(elf) => run_board(&args, elf),
        },
        Command::Sweep(args) => host_sim::runs::sweep::cli(&args),
        Command::Console(args) => host_sim::console::sim::cli(&args),
        Command::Sensor(args) => host_sim::sensor::demo::run(&args),
        Command::Mtts {
            image,
            scale,
            k,
            method,
            seed,
            prior,
            exposed_pct,
        } => {
            let method = host_sim::imaging::mtts_cli::parse_method(&method)?;
            let config = thermorph::mtts::Config {
                scale,
                k,
                method,
                seed,
                exposed_pct,
                ..Default::default()
            };
            let prior = host_sim::imaging::mtts_cli::parse_prior(&prior)?;
            host_sim::imaging::mtts_cli::run(
                &image,
                config,
                prior,
                &mut std::io::stdout().lock(),
                &mut std::io::stderr().lock(),
            )
        }
        Command::Scene { name, seed } => {
            host_sim::imaging::mtts_cli::scene(name.as_deref(), seed, &mut std::io::stdout().lock())
        }
        Command::PlantWp { out } => host_sim::plant::wp::run(&out, 20),
        Command::MttsWp(args) => host_sim::imaging::mtts_wp::run(&args),
        Command::PoseTable => host_sim::runs::pose::cli(),
        Command::Paper {
            json,
            no_camera,
            out,
            board,
        } => match &board {
            None => host_sim::runs::paper::cli(json, !no_camera, out.as_deref()),
            Some(elf) => paper_board(json, !no_camera, out.as_deref(), elf),
        },
        Command::Version => {
            print!("{}", host_sim::cli::version_report("host-sim"));
            Ok(())
        }
        Command::Completions(args) => {
            host_sim::cli::completions(
                &mut <Cli as clap::CommandFactory>::command(),
                "host-sim",
                args.shell,
                &mut std::io::stdout().lock(),
            )?;
            Ok(())
        }
    }
}

/// `run --board ELF`: the scene with the board's own ELF on the emulated STM32F446.
#[cfg(feature = "pil")]
fn run_board(args: &host_sim::runs::run::RunArgs, elf: &std::path::Path) -> anyhow::Result<()> {
    host_sim::runs::elf_run::cli(args, elf)
}

/// Without `--features pil` there is no emulated chip to run the ELF on.
#[cfg(not(feature = "pil"))]
fn run_board(_: &host_sim::runs::run::RunArgs, elf: &std::path::Path) -> anyhow::Result<()> {
    anyhow::bail!(
        "--board {}: this host-sim was built without the emulated STM32F446; build it with \
         `cargo run --release -p host-sim --features pil -- run SCENE --board ELF` (docs/pil.md)",
        elf.display()
    )
}

/// `paper --board ELF`: the thesis's experiments played by the board's own ELF.
#[cfg(feature = "pil")]
fn paper_board(
    json: bool,
    camera: bool,
    out: Option<&std::path::Path>,
    elf: &std::path::Path,
) -> anyhow::Result<()> {
    host_sim::runs::elf_paper::cli(json, camera, out, elf)
}

/// Without `--features pil` there is no emulated chip to run the ELF on.
#[cfg(not(feature = "pil"))]
fn paper_board(
    _: bool,
    _: bool,
    _: Option<&std::path::Path>,
    elf: &std::path::Path,
) -> anyhow::Result<()> {
    anyhow::bail!(
        "--board {}: this host-sim was built without the emulated STM32F446; build it with \
         `cargo run --release -p host-sim --features pil -- paper --board ELF` (docs/pil.md)",
        elf.display()
    )
}
