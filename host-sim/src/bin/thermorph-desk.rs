//! `thermorph-desk`: the researcher's desk — drive, record and plot the Thermorph block (the
//! NUCLEO board's ST-LINK virtual COM port, or `host-sim console --pty`).
//!
//! - `thermorph-desk connect PORT [--baud B]`: interactive console (history, Tab completion).
//! - `thermorph-desk record PORT --out FILE.csv [--duration S] [--hz HZ] [--force]`: telemetry to
//!   CSV until the duration or Ctrl-C; `stream off` and the row count however it ends.
//! - `thermorph-desk run PORT SCRIPT [--record FILE.csv] [--leave-running]`: an experiment
//!   script (recording its telemetry); exits 1 at the first failure, 130 on Ctrl-C, after
//!   sending `stop` unless `--leave-running`.
//! - `thermorph-desk plot FILE.csv --out FILE.png`: plot a recording or host-sim's CSV.
//! - `thermorph-desk ports`: serial ports with their USB identities (ST-LINK marked).
//! - `thermorph-desk completions bash|zsh|fish|elvish|powershell`: the shell's completion script.
//!
//! Exit status ([`host_sim::cli`]): 0 done, 1 a runtime failure (a failed script included), 2 a
//! usage error, 130 interrupted by Ctrl-C — `connect`, `record` and `run` after tidying up as
//! they always do (`record` and `run` send `stream off`, `run` sends `stop` unless
//! `--leave-running`, `connect` waits for the replies still due and saves its history).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};
use host_sim::console::desk::{connect, link::DEFAULT_BAUD, ports, record, script};

#[derive(Parser)]
#[command(
    name = "thermorph-desk",
    version = host_sim::cli::VERSION,
    about = "Drive, record and plot the Thermorph block over its serial console"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Interactive console: line editing, history, Tab completion; telemetry as a status line.
    /// `.quit` or Ctrl-D leave (exit status 0), Ctrl-C too (130); nothing is sent on leaving.
    Connect {
        /// Serial port (e.g. /dev/ttyACM0, or the path `host-sim console --pty` prints).
        port: String,
        /// Baud rate.
        #[arg(long, default_value_t = DEFAULT_BAUD)]
        baud: u32,
        /// Print the telemetry status line at most every S seconds (0: never).
        #[arg(long, default_value = "5", value_parser = script::seconds)]
        status_every: Duration,
        /// History file (default: ~/.thermorph-desk-history).
        #[arg(long)]
        history: Option<PathBuf>,
        /// Say that a command got no reply after S seconds.
        #[arg(long, default_value = "2", value_parser = script::seconds)]
        reply_timeout: Duration,
    },
    /// Turn the telemetry stream on and write every line as CSV (reconnects, marks gaps) until
    /// the duration (exit status 0) or Ctrl-C (130); `stream off` and the row count however it
    /// ends.
    Record {
        /// Serial port.
        port: String,
        /// Output CSV (created once the port answers; an existing one only with --force).
        #[arg(long)]
        out: PathBuf,
        /// Overwrite the output CSV if it exists.
        #[arg(long)]
        force: bool,
        /// Stop after S seconds (default: until Ctrl-C or the port is lost for good).
        #[arg(long, value_parser = script::seconds)]
        duration: Option<Duration>,
        /// Telemetry rate, Hz (default: the board's).
        #[arg(long)]
        hz: Option<f32>,
        /// Baud rate.
        #[arg(long, default_value_t = DEFAULT_BAUD)]
        baud: u32,
        /// Keep trying to reopen a lost port for S seconds.
        #[arg(long, default_value = "30", value_parser = script::seconds)]
        reconnect: Duration,
        /// No telemetry for S seconds: ask for the stream again (a reset board starts silent).
        #[arg(long, default_value = "3", value_parser = script::seconds)]
        silence: Duration,
    },
    /// Run an experiment script (its format: docs/desk.md), every line checked first;
    /// exit 1 at the first failure, 130 on Ctrl-C, after sending `stop`.
    Run {
        /// Serial port (it comes first).
        port: String,
        /// Script file.
        script: PathBuf,
        /// Baud rate.
        #[arg(long, default_value_t = DEFAULT_BAUD)]
        baud: u32,
        /// How long a command may wait for its reply, s.
        #[arg(long, default_value = "2", value_parser = script::seconds)]
        reply_timeout: Duration,
        /// Also record the telemetry received during the run to this CSV.
        #[arg(long)]
        record: Option<PathBuf>,
        /// Overwrite the --record CSV if it exists.
        #[arg(long)]
        force: bool,
        /// On a failure or Ctrl-C, do not send `stop`: leave the block as the script left it.
        #[arg(long)]
        leave_running: bool,
    },
    /// Plot a recording (or host-sim's timeseries.csv) as a PNG.
    Plot {
        /// Input CSV.
        csv: PathBuf,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
        /// Title (default: the CSV's file name).
        #[arg(long)]
        title: Option<String>,
    },
    /// List serial ports with their USB identities; ST-LINK (VID 0483) ones are marked.
    Ports,
    /// Print the shell's completion script (e.g. `thermorph-desk completions bash >
    /// ~/.local/share/bash-completion/completions/thermorph-desk`).
    Completions(host_sim::cli::CompletionsArgs),
}

fn main() -> ExitCode {
    // Usage errors: clap's message and usage, exit status 2 (`Cli::parse`).
    host_sim::cli::exit(run(Cli::parse()))
}

/// Run the command.
fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Connect {
            port,
            baud,
            status_every,
            history,
            reply_timeout,
        } => connect::connect(
            &port,
            &connect::ConnectOptions {
                baud,
                status_every: (!status_every.is_zero()).then_some(status_every),
                history: history.or_else(|| {
                    std::env::var_os("HOME")
                        .map(|h| PathBuf::from(h).join(".thermorph-desk-history"))
                }),
                reply_timeout,
            },
            // Ctrl-C at the prompt, or SIGINT between prompts: leave as `.quit` does, with 130.
            host_sim::cli::catch_interrupt()?,
        )?,
        Command::Record {
            port,
            out,
            force,
            duration,
            hz,
            baud,
            reconnect,
            silence,
        } => {
            let interrupt = host_sim::cli::catch_interrupt()?;
            let o = record::RecordOptions {
                baud,
                hz,
                duration,
                reconnect,
                silence,
                force,
                ..Default::default()
            };
            // A bar over the duration, or a spinner; each shows rows and the latest line.
            let bar = match duration {
                Some(d) => indicatif::ProgressBar::new(d.as_secs().max(1)).with_style(
                    indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {msg}")
                        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                        .progress_chars("=> "),
                ),
                None => indicatif::ProgressBar::new_spinner(),
            };
            bar.enable_steady_tick(Duration::from_millis(250));
            let started = std::time::Instant::now();
            let result = record::record(&port, &out, &o, interrupt, &mut |t, s| {
                bar.set_position(started.elapsed().as_secs());
                bar.set_message(format!("{} rows  {}", s.rows, t.summary()));
            });
            bar.finish_and_clear();
            let s = result?;
            eprintln!(
                "wrote {} rows to {} ({} gaps, {} garbage lines){}",
                s.rows,
                out.display(),
                s.gaps,
                s.garbage,
                if s.interrupted {
                    "; stopped by Ctrl-C, `stream off` sent"
                } else {
                    "; `stream off` sent"
                }
            );
        }
        Command::Run {
            port,
            script,
            baud,
            reply_timeout,
            record,
            force,
            leave_running,
        } => {
            let interrupt = host_sim::cli::catch_interrupt()?;
            script::run_file(
                &port,
                &script,
                &script::RunOptions {
                    baud,
                    reply_timeout,
                    record,
                    force,
                    leave_running,
                },
                interrupt,
                &mut |l| println!("{l}"),
            )?;
            println!("script passed");
        }
        Command::Plot { csv, out, title } => {
            let i = host_sim::runs::plot::plot_csv(&csv, &out, title.as_deref())?;
            println!(
                "wrote {} ({}x{} px: {})",
                out.display(),
                i.size_px.0,
                i.size_px.1,
                i.panels.join(", ")
            );
        }
        Command::Ports => {
            let l = ports::list()?;
            if l.is_empty() {
                println!("no serial ports found");
            }
            for p in l {
                println!("{p}");
            }
        }
        Command::Completions(args) => host_sim::cli::completions(
            &mut <Cli as clap::CommandFactory>::command(),
            "thermorph-desk",
            args.shell,
            &mut std::io::stdout().lock(),
        )?,
    }
    Ok(())
}
