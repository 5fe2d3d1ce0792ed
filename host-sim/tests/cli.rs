//! The command-line conventions both binaries share (`host_sim::cli`), run as a person runs
//! them:
//!
//! - `--version` on both and `host-sim version` name the build: crate version, git commit
//!   (`-dirty`) and its date; build.rs's git query (`build/git_version.rs`) on scratch
//!   repositories — a plain one, a linked worktree, none at all, one that does not track the
//!   package;
//! - `completions SHELL` on both: a script that names the subcommands, and that bash loads and
//!   completes with (zsh and fish check its syntax where they are installed).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

#[path = "../build/git_version.rs"]
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
    std::fs::remove_dir_all(&dir).unwrap();
}
