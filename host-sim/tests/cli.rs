//! The command-line conventions both binaries share (`host_sim::cli`), run as a person runs
//! them:
//!
//! - `--version` on both and `host-sim version` name the build: crate version, git commit
//!   (`-dirty`) and its date; the build scripts' git query (`firmware/build/git_version.rs`) on scratch
//!   repositories — a plain one, a linked worktree, none at all, one that does not track the
//!   package;
//! - `completions SHELL` on both: a script that names the subcommands, and that bash loads and
//!   completes with (zsh and fish check its syntax where they are installed);
//! - exit statuses: 2 for a usage error (`host-sim bogus` included), 1 for a runtime failure,
//!   130 after Ctrl-C (SIGINT) for `host-sim run` and the desk's `record`, `run` and `connect`
//!   (on a pipe, and Ctrl-C typed on a terminal), each after its usual tidying up.

use std::io::{BufRead, BufReader, Read, Write};
use std::os::fd::OwnedFd;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

mod common;
#[path = "../../firmware/build/git_version.rs"]
mod git_version;

const SIM: &str = env!("CARGO_BIN_EXE_host-sim");
const DESK: &str = env!("CARGO_BIN_EXE_thermorph-desk");

fn run(binary: &str, args: &[&str]) -> Output {
    Command::new(binary)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("{binary}: {e}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `git` in `dir` with a fixed identity and no signing; panics on failure.
fn git(dir: &Path, args: &[&str]) -> String {
    let out = Command::new("git")
        .arg("-C")
        .arg(dir)
        .args([
            "-c",
            "user.name=Test",
            "-c",
            "user.email=test@example.invalid",
            "-c",
            "commit.gpgsign=false",
            "-c",
            "init.defaultBranch=main",
        ])
        .args(args)
        .output()
        .expect("git");
    assert!(out.status.success(), "git {args:?}: {}", text(&out.stderr));
    text(&out.stdout).trim().to_string()
}

/// `(commit, date)` of `--version`'s `NAME 0.1.0 (COMMIT DATE)`, `None` for `(git commit
/// unknown)`.
fn version_line(name: &str, line: &str) -> Option<(String, String)> {
    let rest = line
        .strip_prefix(&format!("{name} {} (", env!("CARGO_PKG_VERSION")))
        .and_then(|r| r.strip_suffix(')'))
        .unwrap_or_else(|| panic!("{name} --version printed {line:?}"));
    if rest == "git commit unknown" {
        return None;
    }
    let (commit, date) = rest.split_once(' ').expect("COMMIT DATE");
    Some((commit.to_string(), date.to_string()))
}

#[test]
fn version_names_the_crate_the_commit_and_its_date() {
    // What git says of this checkout now (the binaries were built from it just before).
    let here = git_version::describe(Path::new(env!("CARGO_MANIFEST_DIR")));
    for (binary, name) in [(SIM, "host-sim"), (DESK, "thermorph-desk")] {
        let out = run(binary, &["--version"]);
        assert!(out.status.success(), "{name} --version: {out:?}");
        let line = text(&out.stdout).trim().to_string();
        let got = version_line(name, &line);
        match (&here, &got) {
            (Some(g), Some((commit, date))) => {
                let hash = commit.trim_end_matches("-dirty");
                assert!(
                    hash.len() >= 7 && hash.chars().all(|c| c.is_ascii_hexdigit()),
                    "{line}"
                );
                assert_eq!(hash, g.commit.trim_end_matches("-dirty"), "{line}");
                assert_eq!(date, &g.date, "{line}");
                assert!(
                    date.len() == 10 && date.as_bytes()[4] == b'-' && date.as_bytes()[7] == b'-',
                    "{line}"
                );
            }
            (None, None) => {}
            _ => panic!("{name}: `{line}`, but git says {here:?}"),
        }
    }
    let out = run(SIM, &["version"]);
    assert_eq!(out.status.code(), Some(0), "host-sim version: {out:?}");
    let report = text(&out.stdout);
    let first = text(&run(SIM, &["--version"]).stdout);
    assert!(report.starts_with(&first), "{report}");
    let commit = got_commit(&first);
    assert!(
        report.contains(&format!("\ncommit    {commit}")),
        "{report}"
    );
    assert!(
        report.contains(&format!("\nversion   {}\n", env!("CARGO_PKG_VERSION"))),
        "{report}"
    );
    assert!(report.contains("\nfeatures  "), "{report}");
}

/// The commit `--version` names (`unknown` outside a checkout).
fn got_commit(line: &str) -> String {
    version_line("host-sim", line.trim()).map_or("unknown".into(), |(c, _)| c)
}

#[test]
fn build_script_git_query_on_scratch_repositories() {
    let dir = scratch("git");
    // No repository at all (a crates tarball): nothing, so build.rs says `unknown`.
    let plain = dir.join("tarball");
    std::fs::create_dir_all(&plain).unwrap();
    std::fs::write(plain.join("Cargo.toml"), "[package]\n").unwrap();
    assert_eq!(git_version::describe(&plain), None);

    // A repository whose package directory holds a tracked Cargo.toml.
    let repo = dir.join("repo");
    let pkg = repo.join("host-sim");
    std::fs::create_dir_all(&pkg).unwrap();
    git(&repo, &["init", "-q"]);
    std::fs::write(pkg.join("Cargo.toml"), "[package]\n").unwrap();
    git(&repo, &["add", "."]);
    git(&repo, &["commit", "-q", "-m", "first"]);
    let hash = git(&repo, &["rev-parse", "--short", "HEAD"]);
    let date = git(&repo, &["log", "-1", "--date=short", "--format=%cd"]);
    let v = git_version::describe(&pkg).expect("a checkout");
    assert_eq!(
        (v.commit.as_str(), v.date.as_str()),
        (hash.as_str(), date.as_str())
    );
    let git_dir = repo.join(".git").canonicalize().unwrap();
    let watch: Vec<PathBuf> = v.watch.iter().map(|p| p.canonicalize().unwrap()).collect();
    assert_eq!(
        watch,
        [git_dir.join("HEAD"), git_dir.join("refs/heads/main")],
        "{v:?}"
    );

    // An untracked file leaves it clean; an edited tracked file makes it dirty.
    std::fs::write(pkg.join("notes.txt"), "x").unwrap();
    assert_eq!(git_version::describe(&pkg).unwrap().commit, hash);
    std::fs::write(pkg.join("Cargo.toml"), "[package]\nname = \"x\"\n").unwrap();
    assert_eq!(
        git_version::describe(&pkg).unwrap().commit,
        format!("{hash}-dirty")
    );
    // Staged counts as well.
    git(&repo, &["add", "host-sim/Cargo.toml"]);
    assert_eq!(
        git_version::describe(&pkg).unwrap().commit,
        format!("{hash}-dirty")
    );
    git(&repo, &["commit", "-q", "-m", "second"]);
    let second = git(&repo, &["rev-parse", "--short", "HEAD"]);
    assert_ne!(second, hash);
    assert_eq!(git_version::describe(&pkg).unwrap().commit, second);

    // A linked worktree (`.git` is a file there): HEAD in its own git directory, the branch in
    // the common one.
    let wt = dir.join("wt");
    git(
        &repo,
        &["worktree", "add", "-q", "-b", "side", wt.to_str().unwrap()],
    );
    let v = git_version::describe(&wt.join("host-sim")).expect("a worktree");
    assert_eq!(v.commit, second);
    let watch: Vec<PathBuf> = v.watch.iter().map(|p| p.canonicalize().unwrap()).collect();
    assert_eq!(
        watch,
        [
            git_dir.join("worktrees/wt/HEAD"),
            git_dir.join("refs/heads/side")
        ],
        "{v:?}"
    );

    // A package unpacked inside a repository that does not track it.
    let foreign = repo.join("vendor/host-sim");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("Cargo.toml"), "[package]\n").unwrap();
    assert_eq!(git_version::describe(&foreign), None);

    // A detached HEAD: only HEAD to watch.
    git(&repo, &["checkout", "-q", "--detach"]);
    let v = git_version::describe(&pkg).unwrap();
    assert_eq!(v.watch.len(), 1, "{v:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The bash completions of `words` (the last one being completed, possibly empty) with
/// `script` loaded, as bash's programmable completion calls the function it registered.
fn bash_complete(script: &Path, binary: &str, words: &[&str]) -> Vec<String> {
    let quoted: Vec<String> = words.iter().map(|w| format!("'{w}'")).collect();
    let program = format!(
        "source '{script}'\n\
         f=$(complete -p {binary} | sed -E 's/.*-F ([^ ]+).*/\\1/')\n\
         COMP_WORDS=({words}); COMP_CWORD={cword}; COMP_LINE='{line}'; COMP_POINT=${{#COMP_LINE}}\n\
         \"$f\" {binary} {cur} {prev}\n\
         printf '%s\\n' \"${{COMPREPLY[@]}}\"\n",
        script = script.display(),
        words = quoted.join(" "),
        cword = words.len() - 1,
        line = words.join(" "),
        cur = quoted[words.len() - 1],
        prev = quoted[words.len() - 2],
    );
    let out = Command::new("bash")
        .args(["--norc", "--noprofile", "-c", &program])
        .output()
        .expect("bash");
    assert!(out.status.success(), "{program}\n{}", text(&out.stderr));
    text(&out.stdout)
        .lines()
        .filter(|l| !l.is_empty())
        .map(String::from)
        .collect()
}

/// Whether `shell` is installed.
fn installed(shell: &str) -> bool {
    Command::new(shell)
        .args(["-c", "exit 0"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn completions_name_the_subcommands_and_bash_completes_with_them() {
    let dir = scratch("completions");
    for (binary, name, commands, prefix, completed) in [
        (
            SIM,
            "host-sim",
            &["run", "paper", "console", "sweep", "version", "completions"][..],
            "pa",
            "paper",
        ),
        (
            DESK,
            "thermorph-desk",
            &["connect", "record", "run", "plot", "ports", "completions"][..],
            "rec",
            "record",
        ),
    ] {
        for shell in ["bash", "zsh", "fish"] {
            let out = run(binary, &["completions", shell]);
            assert_eq!(
                out.status.code(),
                Some(0),
                "{name} completions {shell}: {out:?}"
            );
            let script = text(&out.stdout);
            assert!(!script.trim().is_empty(), "{name} completions {shell}");
            for c in commands {
                assert!(
                    script.contains(c),
                    "{name} completions {shell} does not name `{c}`"
                );
            }
            let file = dir.join(format!("{name}.{shell}"));
            std::fs::write(&file, &script).unwrap();
            match shell {
                "bash" => assert!(script.contains("complete -F "), "{script}"),
                "zsh" => assert!(script.starts_with(&format!("#compdef {name}")), "{script}"),
                _ => assert!(script.contains(&format!("complete -c {name} ")), "{script}"),
            }
            // The shell's own syntax check, where the shell is installed (bash always is).
            if installed(shell) {
                let check = Command::new(shell).arg("-n").arg(&file).output().unwrap();
                assert!(
                    check.status.success(),
                    "{shell} -n {name}'s completions: {}",
                    text(&check.stderr)
                );
            } else {
                eprintln!("{shell} is not installed: its script's syntax is not checked");
            }
        }
        let script = dir.join(format!("{name}.bash"));
        assert_eq!(
            bash_complete(&script, name, &[name, prefix]),
            [completed],
            "`{name} {prefix}<Tab>`"
        );
        // The subcommands are offered from an empty word.
        let all = bash_complete(&script, name, &[name, ""]);
        for c in commands {
            assert!(all.iter().any(|w| w == c), "`{name} <Tab>`: {all:?}");
        }
    }
    // A shell it does not know is a usage error.
    let out = run(SIM, &["completions", "tcsh"]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn usage_errors_exit_2_and_runtime_failures_1() {
    let usage: [(&str, &[&str]); 6] = [
        (SIM, &["bogus"]),
        (SIM, &["run", "--bogus"]),
        (SIM, &["mtts"]),
        (SIM, &["--speed", "2"]),
        (DESK, &["bogus"]),
        (DESK, &["record", "/dev/null"]),
    ];
    for (binary, args) in usage {
        let out = run(binary, args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{binary} {args:?}: {err}");
        assert!(
            err.starts_with("error: ") && err.contains("Usage:"),
            "{err}"
        );
    }
    // `host-sim WORD`: a word neither a command nor a scene says both lists.
    let err = text(&run(SIM, &["bogus"]).stderr);
    assert!(
        err.contains("`bogus` is neither a command (decode, run,") && err.contains("cycle"),
        "{err}"
    );
    let dir = scratch("failures");
    let missing = dir.join("missing.csv");
    let png = dir.join("out.png");
    let failures: [(&str, Vec<&str>); 3] = [
        (SIM, vec!["run", "no-such-scene"]),
        (
            DESK,
            vec![
                "plot",
                missing.to_str().unwrap(),
                "--out",
                png.to_str().unwrap(),
            ],
        ),
        (
            DESK,
            vec![
                "record",
                "/nonexistent/port",
                "--out",
                png.to_str().unwrap(),
            ],
        ),
    ];
    for (binary, args) in failures {
        let out = run(binary, &args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{binary} {args:?}: {err}");
        assert!(
            err.starts_with("error: ") && !err.contains("Usage:"),
            "{err}"
        );
    }
    // Help and version are no errors.
    for (binary, args) in [(SIM, ["--help"]), (SIM, ["-V"]), (DESK, ["--help"])] {
        assert_eq!(run(binary, &args).status.code(), Some(0), "{args:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Whether process `pid` catches SIGINT (`SigCgt` in /proc: its handler is installed).
fn catches_sigint(pid: u32) -> bool {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("SigCgt:"))
        .and_then(|m| u64::from_str_radix(m.trim(), 16).ok())
        .is_some_and(|m| m & (1 << (nix::sys::signal::Signal::SIGINT as i32 - 1)) != 0)
}

/// Send SIGINT to `child` once it catches it (or after 5 s, so a process that never does is
/// ended by it).
fn interrupt(child: &Child) {
    let until = Instant::now() + Duration::from_secs(5);
    while !catches_sigint(child.id()) && Instant::now() < until {
        std::thread::sleep(Duration::from_millis(20));
    }
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGINT,
    )
    .expect("SIGINT");
}

/// Wait for `child`, killing it and failing after `limit`.
fn wait(child: &mut Child, limit: Duration, what: &str) -> ExitStatus {
    let until = Instant::now() + limit;
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        if Instant::now() > until {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// What a process has written so far, read on a thread until its end.
#[derive(Clone, Default)]
struct Captured(Arc<Mutex<String>>);

impl Captured {
    fn start(mut r: impl Read + Send + 'static) -> (Captured, std::thread::JoinHandle<()>) {
        let c = Captured::default();
        let seen = c.clone();
        let t = std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            // A pseudo-terminal's master reads EIO once no one has its slave open.
            while let Ok(n) = r.read(&mut buf) {
                if n == 0 {
                    break;
                }
                seen.0.lock().unwrap().push_str(&text(&buf[..n]));
            }
        });
        (c, t)
    }

    fn get(&self) -> String {
        self.0.lock().unwrap().clone()
    }

    /// Wait (at most 15 s) until `ready` holds for what was written.
    fn until(&self, what: &str, ready: impl Fn(&str) -> bool) {
        let until = Instant::now() + Duration::from_secs(15);
        while !ready(&self.get()) {
            assert!(Instant::now() < until, "{what}: {:?}", self.get());
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

#[test]
fn ctrl_c_stops_a_run_with_130_and_writes_nothing() {
    let dir = scratch("run-int");
    // The default cycle, long enough to be interrupted (several seconds of wall time whole).
    let cycle =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cycle.toml"))
            .unwrap();
    assert!(cycle.contains("\nduration = \"7:30\"\n"));
    let scene = dir.join("long.toml");
    std::fs::write(
        &scene,
        cycle.replace("\nduration = \"7:30\"\n", "\nduration = \"20000 s\"\n"),
    )
    .unwrap();
    let out = dir.join("out");
    let mut child = Command::new(SIM)
        .args([
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (stdout, out_t) = Captured::start(child.stdout.take().unwrap());
    let (stderr, err_t) = Captured::start(child.stderr.take().unwrap());
    interrupt(&child);
    let status = wait(&mut child, Duration::from_secs(20), "host-sim run");
    out_t.join().unwrap();
    err_t.join().unwrap();
    let err = stderr.get();
    assert_eq!(status.code(), Some(130), "{status:?}: {err}");
    assert!(
        err.contains("error: interrupted (Ctrl-C) at ")
            && err.contains(&format!(
                "of the scene's 20000 s; nothing written to {}",
                out.display()
            )),
        "{err}"
    );
    assert!(stdout.get().is_empty());
    assert!(!out.join("timeseries.csv").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `host-sim console --pty`: the block behind a pseudo-terminal, as the desk finds the board.
struct Board {
    child: Child,
    path: String,
}

impl Board {
    fn start(dir: &Path) -> Board {
        let mut child = Command::new(SIM)
            .args(["console", "--pty", "--speed", "5", "--settings"])
            .arg(dir.join("settings.bin"))
            .arg("open-loop")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("host-sim console");
        let mut first = String::new();
        BufReader::new(child.stdout.as_mut().unwrap())
            .read_line(&mut first)
            .unwrap();
        let path = first.trim().to_string();
        assert!(path.starts_with("/dev/pts/"), "{first:?}");
        Board { child, path }
    }
}

impl Drop for Board {
    fn drop(&mut self) {
        let _ = nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(self.child.id() as i32),
            nix::sys::signal::Signal::SIGINT,
        );
        let until = Instant::now() + Duration::from_secs(5);
        while Instant::now() < until {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The desk with `args`, its standard input a pipe kept open (saying nothing), interrupted
/// (SIGINT) once `ready` holds for its standard output: its status, stdout and stderr.
fn desk_interrupted(args: &[&str], ready: impl Fn(&str) -> bool) -> (ExitStatus, String, String) {
    let mut child = common::spawn_desk(args);
    let stdin = child.stdin.take();
    let (stdout, out_t) = Captured::start(child.stdout.take().unwrap());
    let (stderr, err_t) = Captured::start(child.stderr.take().unwrap());
    stdout.until(
        &format!("{args:?} not ready; stderr {:?}", stderr.get()),
        ready,
    );
    interrupt(&child);
    let status = wait(&mut child, Duration::from_secs(20), &format!("{args:?}"));
    drop(stdin);
    out_t.join().unwrap();
    err_t.join().unwrap();
    (status, stdout.get(), stderr.get())
}

#[test]
fn ctrl_c_ends_the_desks_record_with_130_after_stream_off() {
    let dir = scratch("desk-record-int");
    let board = Board::start(&dir);
    let csv = dir.join("rec.csv");
    let (status, _, err) = desk_interrupted(
        &[
            "record",
            &board.path,
            "--out",
            csv.to_str().unwrap(),
            "--hz",
            "10",
        ],
        // A few rows in: the CSV is created once the board has answered.
        |_| std::fs::read_to_string(&csv).is_ok_and(|t| t.lines().count() > 3),
    );
    assert_eq!(status.code(), Some(130), "record: {status:?}: {err}");
    assert!(
        err.contains("; stopped by Ctrl-C, `stream off` sent"),
        "record: {err}"
    );
    assert!(std::fs::read_to_string(&csv).unwrap().lines().count() > 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn ctrl_c_ends_the_desks_run_with_130_after_stop() {
    let dir = scratch("desk-run-int");
    let board = Board::start(&dir);
    let script = dir.join("long.txt");
    std::fs::write(&script, "mode standby\nsleep 60\n").unwrap();
    let (status, out, err) =
        desk_interrupted(&["run", &board.path, script.to_str().unwrap()], |out| {
            out.contains("line 1: mode standby -> ok")
        });
    assert_eq!(status.code(), Some(130), "run: {status:?}: {out}{err}");
    assert!(
        out.contains("the run failed: sent `stop` -> ok stopped"),
        "run: {out}"
    );
    assert!(
        err.contains(&format!(
            "error: {}:2: interrupted (Ctrl-C)",
            script.display()
        )),
        "run: {err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sigint_ends_the_desks_connect_on_a_pipe_with_130() {
    let dir = scratch("desk-connect-int");
    let board = Board::start(&dir);
    // `connect` with its input a pipe that says nothing: SIGINT ends it as `.quit` would.
    let history = dir.join("history");
    let (status, out, err) = desk_interrupted(
        &[
            "connect",
            &board.path,
            "--status-every",
            "0",
            "--history",
            history.to_str().unwrap(),
        ],
        |out| out.contains("connected to"),
    );
    assert_eq!(status.code(), Some(130), "connect: {status:?}: {out}{err}");
    assert!(
        out.contains(&format!("left {}; the block was left as it is", board.path)),
        "connect: {out}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn ctrl_c_typed_at_the_desks_prompt_leaves_with_130() {
    let dir = scratch("desk-tty");
    let board = Board::start(&dir);
    // The desk on a terminal of its own: a pseudo-terminal's slave as its stdin, stdout and
    // stderr; the test types on the master.
    let pty = nix::pty::openpty(None, None).expect("openpty");
    nix::fcntl::fcntl(
        &pty.master,
        nix::fcntl::FcntlArg::F_SETFD(nix::fcntl::FdFlag::FD_CLOEXEC),
    )
    .unwrap();
    let slave: OwnedFd = pty.slave;
    // Neither end may leak into the processes other tests start meanwhile: the master would
    // never read the end of the slave's last holder.
    nix::fcntl::fcntl(
        &slave,
        nix::fcntl::FcntlArg::F_SETFD(nix::fcntl::FdFlag::FD_CLOEXEC),
    )
    .unwrap();
    let io = || Stdio::from(slave.try_clone().unwrap());
    let history = dir.join("history");
    let mut child = Command::new(DESK)
        .args([
            "connect",
            &board.path,
            "--status-every",
            "0",
            "--history",
            history.to_str().unwrap(),
        ])
        .env("HOME", std::env::temp_dir())
        .env("TERM", "xterm")
        .stdin(io())
        .stdout(io())
        .stderr(io())
        .spawn()
        .expect("thermorph-desk connect");
    drop(slave);
    let mut master = std::fs::File::from(pty.master);
    let (seen, reader) = Captured::start(master.try_clone().unwrap());
    // The prompt: the line editor has the terminal in raw mode, where Ctrl-C is a key.
    seen.until("no prompt", |s| s.contains("desk> "));
    master.write_all(b"\x03").unwrap();
    let status = wait(&mut child, Duration::from_secs(20), "connect on a terminal");
    drop(master);
    reader.join().unwrap();
    let seen = seen.get();
    assert_eq!(status.code(), Some(130), "{status:?}: {seen}");
    assert!(
        seen.contains(&format!("left {}; the block was left as it is", board.path)),
        "{seen}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
