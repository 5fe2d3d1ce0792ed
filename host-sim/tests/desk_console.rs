//! The researcher's desk against the simulator's console on a real pseudo-terminal, as it runs
//! against the board's ST-LINK port: `host-sim console --pty` (the firmware's supervisor and
//! console behind a pty) driven by `thermorph-desk run` with a script that preheats, steps with
//! two springs, forms and recovers, recording the telemetry, then `thermorph-desk plot`.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SIM: &str = env!("CARGO_BIN_EXE_host-sim");

mod common;

use common::{desk, png_size, scratch};
use host_sim::console::desk::telemetry::csv_header;
use host_sim::runs::plot::Table;

/// `host-sim console --pty` on a scene, stopped with SIGINT when dropped.
struct Console {
    child: Child,
    path: String,
}

impl Console {
    fn start(scene: &str, speed: &str, settings: &std::path::Path) -> Console {
        let mut child = Command::new(SIM)
            .args(["console", "--pty", "--speed", speed, "--settings"])
            .arg(settings)
            .arg(scene)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start host-sim console");
        let mut first = String::new();
        BufReader::new(child.stdout.as_mut().unwrap())
            .read_line(&mut first)
            .unwrap();
        let path = first.trim().to_string();
        assert!(
            path.starts_with("/dev/pts/"),
            "the console printed {first:?}"
        );
        Console { child, path }
    }
}

impl Drop for Console {
    fn drop(&mut self) {
        // SIGINT through kill(1): the console ends cleanly on it (as on Ctrl-C).
        let _ = Command::new("kill")
            .args(["-INT", &self.child.id().to_string()])
            .status();
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn desk_runs_records_and_plots_a_cycle_on_host_sim_console() {
    let dir = scratch("cycle");
    // The open-loop scene's block without its timed duties (the console plays none), camera
    // off to keep the test quick; 10× real time, so a 6 s spring phase (600 ms) cannot fall
    // between two of the script's `status` polls.
    let console = Console::start("open-loop", "10", &dir.join("settings.bin"));
    let script = dir.join("cycle.txt");
    std::fs::write(
        &script,
        "mode standby\n\
         wait tc_k >= 322 within 30\n\
         expect fault == none\n\
         mode step-large AB\n\
         wait phase == spring within 60\n\
         wait springs == AB within 10\n\
         wait phase == hold within 60\n\
         mode form\n\
         wait mode == standby within 60\n\
         mode recover\n\
         wait mode == standby within 60\n\
         expect fault == none\n",
    )
    .unwrap();
    let csv = dir.join("cycle.csv");
    let run = desk(
        &[
            "run",
            &console.path,
            script.to_str().unwrap(),
            "--record",
            csv.to_str().unwrap(),
        ],
        "",
        Duration::from_secs(240),
    );
    assert!(run.ok, "{}\n{}", run.stdout, run.stderr);
    assert!(run.stdout.contains("script passed"), "{}", run.stdout);

    // The recording: the library's telemetry fields, every mode of the cycle, both springs
    // stepping, the recovery's pulse on all three, the film at the stepping temperature.
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().next().unwrap(), csv_header());
    let t = Table::parse(&text).unwrap();
    assert!(t.len() > 100, "{} rows", t.len());
    let (modes, springs) = (t.text("mode").unwrap(), t.text("springs").unwrap());
    for m in ["standby", "step-large", "form", "recover"] {
        assert!(modes.contains(&m), "no {m} recorded");
    }
    assert!(springs.contains(&"AB"));
    assert!(
        modes
            .iter()
            .zip(&springs)
            .any(|(m, s)| *m == "recover" && *s == "ABC")
    );
    let hottest = t.num("t1_k").unwrap().into_iter().fold(f64::MIN, f64::max);
    assert!(hottest > 357.0, "{hottest}");
    assert!(t.text("fault").unwrap().iter().all(|f| *f == "none"));

    let png = dir.join("cycle.png");
    let plot = desk(
        &[
            "plot",
            csv.to_str().unwrap(),
            "--out",
            png.to_str().unwrap(),
        ],
        "",
        Duration::from_secs(30),
    );
    assert!(plot.ok, "{}\n{}", plot.stdout, plot.stderr);
    let bytes = std::fs::read(&png).unwrap();
    let (width, height) = png_size(&png);
    assert_eq!(width, host_sim::runs::plot::WIDTH_PX);
    assert!(
        height > 600 && bytes.len() > 20_000,
        "{width}×{height}, {} bytes",
        bytes.len()
    );
    // The walk-through's picture in docs/desk.md is today's plot of such a recording (issue 44:
    // it had lost a panel): the same size and panels as this one.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    assert_eq!(
        png_size(&root.join("docs/desk-cycle.png")),
        (width, height),
        "docs/desk-cycle.png is stale: redraw it as docs/desk.md says"
    );
    let panels = |s: &str| {
        s.lines()
            .find_map(|l| l.split(" px: ").nth(1))
            .map(|p| p.trim_end_matches(')').to_string())
    };
    let page = std::fs::read_to_string(root.join("docs/desk.md")).unwrap();
    assert_eq!(panels(&page), panels(&plot.stdout), "{}", plot.stdout);
    drop(console);
    std::fs::remove_dir_all(&dir).unwrap();
}
