//! `thermorph-desk`: the researcher's desk — drive, record and plot the Thermorph block (the
//! NUCLEO board's ST-LINK virtual COM port, or `host-sim console --pty`).
//!
//! - `thermorph-desk connect PORT [--baud B]`: interactive console (history, Tab completion).
//! - `thermorph-desk record PORT --out FILE.csv [--duration S] [--hz HZ]`: telemetry to CSV.
//! - `thermorph-desk run PORT SCRIPT [--record FILE.csv]`: an experiment script (recording its
//!   telemetry); exits 1 at the first failure.
//! - `thermorph-desk plot FILE.csv --out FILE.png`: plot a recording or host-sim's CSV.
//! - `thermorph-desk ports`: serial ports with their USB identities (ST-LINK marked).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};
use host_sim::console::desk::{connect, link::DEFAULT_BAUD, ports, record, script};

#[derive(Parser)]
#[command(
    name = "thermorph-desk",
    version,
    about = "Drive, record and plot the Thermorph block over its serial console"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Interactive console: line editing, history, Tab completion; telemetry as a status line.
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
    },
    /// Turn the telemetry stream on and write every line as CSV (reconnects, marks gaps).
    Record {
        /// Serial port.
        port: String,
        /// Output CSV.
        #[arg(long)]
        out: PathBuf,
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
    /// Run an experiment script (see `host_sim::console::desk::script`); exit 1 at the first failure.
    Run {
        /// Serial port.
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
}

fn main() -> ExitCode {
    host_sim::exit(run(Cli::parse()))
}

/// Run the command.
fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Connect {
            port,
            baud,
            status_every,
            history,
        } => connect::connect(
            &port,
            &connect::ConnectOptions {
                baud,
                status_every: (!status_every.is_zero()).then_some(status_every),
                history: history.or_else(|| {
                    std::env::var_os("HOME")
                        .map(|h| PathBuf::from(h).join(".thermorph-desk-history"))
                }),
                drain: Duration::from_secs(2),
            },
        )?,
        Command::Record {
            port,
            out,
            duration,
            hz,
            baud,
            reconnect,
            silence,
        } => {
            let o = record::RecordOptions {
                baud,
                hz,
                duration,
                reconnect,
                silence,
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
            let result = record::record(&port, &out, &o, &mut |t, s| {
                bar.set_position(started.elapsed().as_secs());
                bar.set_message(format!("{} rows  {}", s.rows, t.summary()));
            });
            bar.finish_and_clear();
            let s = result?;
            eprintln!(
                "wrote {} rows to {} ({} gaps, {} garbage lines)",
                s.rows,
                out.display(),
                s.gaps,
                s.garbage
            );
        }
        Command::Run {
            port,
            script,
            baud,
            reply_timeout,
            record,
        } => {
            script::run_file(
                &port,
                baud,
                &script,
                reply_timeout,
                record.as_deref(),
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
    }
    Ok(())
}
