//! Runs the real `liftwatch` binary against the ways an output can be lost or clobbered
//! (issue "Nothing lost, nothing clobbered, nothing unbounded"):
//!
//! ```text
//! devices, FIFOs, symlinks   written in place, followed; /dev/null stays a device
//! same path twice            an output naming an input or another output is refused
//! full disk                  a failed write leaves no partial and no temporary file
//! overlapping state          input the state covers is refused, or skipped on request
//! absurd models              refused with one short line naming the field
//! kill -9 at any instant     the retry gives the same bytes as one clean run
//! ```
//!
//! A refusal is always: a non-zero exit, one `liftwatch: ...` stderr line of at most
//! [`MAX_LINE_CHARS`] characters (the case directory counted as `DIR`), no `panicked`, no file
//! changed and no temporary file (`.*.tmp*`) left.
//!
//! `-` for standard input and output is covered by `tests/scripts.rs`.

use std::collections::BTreeMap;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Longest stderr line a refusal may print, the case directory written as `DIR`.
const MAX_LINE_CHARS: usize = 300;

/// A run that takes longer is hung: killed, and the test fails (a guard, not a timing test).
const HANG_LIMIT: Duration = Duration::from_secs(60);

/// Chunks the kill test's log is cut into (each run of `monitor` watches one).
const N_CHUNKS: usize = 6;

mod common;
use common::Dir;

/// Every entry under `dir` with its content (a link's target, `None` for a FIFO or device),
/// to prove a refused run changed nothing.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    let mut all = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).expect("dir is readable") {
            let path = e.expect("entry").path();
            let meta = std::fs::symlink_metadata(&path).expect("entry has metadata");
            let content = if meta.is_dir() {
                todo.push(path.clone());
                None
            } else if meta.file_type().is_symlink() {
                let target = std::fs::read_link(&path).expect("link is readable");
                Some(target.into_os_string().into_encoded_bytes())
            } else if meta.is_file() {
                Some(std::fs::read(&path).expect("file is readable"))
            } else {
                None
            };
            all.insert(path, content);
        }
    }
    all
}

/// Temporary files left under `dir`: `.name.<pid>.<n>.tmp` and `.name.<pid>.<n>.tmpdir`.
fn temps(dir: &Path) -> Vec<PathBuf> {
    snapshot(dir)
        .into_keys()
        .filter(|p| {
            let name = p.file_name().unwrap_or_default().to_string_lossy();
            name.starts_with('.') && name.contains(".tmp")
        })
        .collect()
}

fn s(p: &Path) -> &str {
    p.to_str().expect("test paths are UTF-8")
}

/// The end of one run of the binary.
struct Run {
    status: ExitStatus,
    stderr: String,
}

fn command<S: AsRef<str>>(args: &[S], env: &[(&str, &str)]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_liftwatch"));
    cmd.args(args.iter().map(AsRef::as_ref))
        .env_remove("LIFTWATCH_FAULT")
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    cmd
}

/// The arguments as one line, for messages.
fn describe<S: AsRef<str>>(args: &[S]) -> String {
    args.iter().map(AsRef::as_ref).collect::<Vec<_>>().join(" ")
}

/// Waits for `child`, killing it when it hangs.
fn finish(mut child: Child, what: &str) -> Run {
    let start = Instant::now();
    while child.try_wait().expect("wait works").is_none() {
        if start.elapsed() > HANG_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("liftwatch {what} hung");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let out = child.wait_with_output().expect("output is readable");
    Run {
        status: out.status,
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Runs the binary to its end with `env` set.
fn liftwatch_env<S: AsRef<str>>(args: &[S], env: &[(&str, &str)]) -> Run {
    let child = command(args, env).spawn().expect("the binary runs");
    finish(child, &describe(args))
}

fn liftwatch<S: AsRef<str>>(args: &[S]) -> Run {
    liftwatch_env(args, &[])
}

/// Runs the binary and demands success.
fn ok<S: AsRef<str>>(args: &[S]) -> Run {
    let run = liftwatch(args);
    assert!(
        run.status.success(),
        "{} failed: {}",
        describe(args),
        run.stderr
    );
    assert!(!run.stderr.contains("panicked"), "{}", run.stderr);
    run
}

/// The refusal contract: non-zero exit, one error line naming `expect`, short, no panic, nothing
/// under `dir` changed, no temporary file. `report` may print its progress line first.
fn assert_refused<S: AsRef<str>>(args: &[S], dir: &Path, expect: &str) {
    let before = snapshot(dir);
    let run = liftwatch(args);
    let args = describe(args);
    assert!(!run.status.success(), "{args} must fail: {}", run.stderr);
    assert!(!run.stderr.contains("panicked"), "{}", run.stderr);
    let lines: Vec<&str> = run.stderr.lines().collect();
    let (progress, error) = lines.split_at(lines.len().saturating_sub(1));
    assert!(
        error.len() == 1 && progress.iter().all(|l| l.starts_with("report: ")),
        "one error line expected from {args}, got: {}",
        run.stderr
    );
    let line = error[0];
    assert!(line.starts_with("liftwatch: "), "{line}");
    let short = line.replace(s(dir), "DIR");
    assert!(
        short.chars().count() <= MAX_LINE_CHARS,
        "{} characters: {short}",
        short.chars().count()
    );
    assert!(line.contains(expect), "`{expect}` expected in: {line}");
    assert!(
        snapshot(dir) == before,
        "{args} changed files under {dir:?}"
    );
    assert_eq!(temps(dir), Vec::<PathBuf>::new(), "temporary files left");
}

/// The shared inputs: a short healthy log, aligned and cut into chunks, and a model fitted on
/// it. Built once per test run.
struct Fixture {
    aligned: PathBuf,
    elevator: PathBuf,
    chunks: Vec<PathBuf>,
    model: PathBuf,
}

fn fixture() -> &'static Fixture {
    static FIXTURE: OnceLock<Fixture> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("safety-fixture");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("the target's tmp dir is writable");
        let sim = dir.join("sim");
        ok(&["simulate", "--out", s(&sim), "--days", "0.6", "--seed", "3"]);
        let aligned = dir.join("aligned.csv");
        let raw = sim.join("raw.csv");
        ok(&["align", "--input", s(&raw), "--out", s(&aligned)]);
        let text = std::fs::read_to_string(&aligned).expect("aligned file is readable");
        let (header, body) = text.split_once('\n').expect("a header line");
        let rows: Vec<&str> = body.lines().collect();
        let chunks = rows
            .chunks(rows.len().div_ceil(N_CHUNKS))
            .enumerate()
            .map(|(i, part)| {
                let path = dir.join(format!("chunk_{i}.csv"));
                std::fs::write(&path, format!("{header}\n{}\n", part.join("\n")))
                    .expect("fixture dir is writable");
                path
            })
            .collect();
        let elevator = sim.join("elevator.toml");
        let model = dir.join("model.json");
        // The night at the start has too few trips to fit on: fit on the whole short log.
        ok(&[
            "fit",
            "--input",
            s(&aligned),
            "--elevator",
            s(&elevator),
            "--out",
            s(&model),
            "--epochs",
            "60",
            "--quiet",
        ]);
        Fixture {
            aligned,
            elevator,
            chunks,
            model,
        }
    })
}

/// The fixture's model as JSON, for cases that change a field.
fn model_json() -> serde_json::Value {
    let text = std::fs::read_to_string(&fixture().model).expect("model is readable");
    serde_json::from_str(&text).expect("the fitted model is JSON")
}

fn write_json(path: &Path, v: &serde_json::Value) {
    std::fs::write(
        path,
        serde_json::to_string_pretty(v).expect("JSON serialises"),
    )
    .expect("case dir is writable");
}

#[test]
fn devices_fifos_and_symlinks_are_written_through() {
    let fx = fixture();
    let dir = Dir::new("special");
    let input = s(&fx.chunks[0]);
    let plain = dir.path("plain.csv");
    ok(&["align", "--input", input, "--out", s(&plain)]);
    let expected = std::fs::read(&plain).expect("aligned output");

    ok(&["align", "--input", input, "--out", "/dev/null"]);
    let null = std::fs::symlink_metadata("/dev/null").expect("/dev/null exists");
    assert!(
        null.file_type().is_char_device(),
        "/dev/null must stay a device"
    );
    ok(&[
        "monitor",
        "--model",
        s(&fx.model),
        "--input",
        input,
        "--out",
        "/dev/null",
        "--events",
        "/dev/null",
    ]);
    assert!(std::fs::symlink_metadata("/dev/null")
        .expect("/dev/null exists")
        .file_type()
        .is_char_device());

    let real = dir.file("real.csv", b"old");
    let link = dir.path("link.csv");
    std::os::unix::fs::symlink("real.csv", &link).expect("symlink");
    ok(&["align", "--input", input, "--out", s(&link)]);
    let meta = std::fs::symlink_metadata(&link).expect("link exists");
    assert!(meta.file_type().is_symlink(), "the link must stay a link");
    assert_eq!(std::fs::read(&real).expect("target"), expected);

    let fifo = dir.path("fifo");
    let made = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo runs");
    assert!(made.success(), "mkfifo failed");
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).expect("FIFO is readable"))
    };
    let run = liftwatch(&["align", "--input", input, "--out", s(&fifo)]);
    let start = Instant::now();
    while !reader.is_finished() && start.elapsed() < Duration::from_secs(2) {
        std::thread::sleep(Duration::from_millis(10));
    }
    if !reader.is_finished() {
        // The binary never opened the FIFO: open it once so the reader returns.
        drop(std::fs::OpenOptions::new().write(true).open(&fifo));
    }
    let got = reader.join().expect("reader thread");
    assert!(run.status.success(), "align into a FIFO: {}", run.stderr);
    assert!(got == expected, "the FIFO got {} bytes", got.len());
    assert!(std::fs::symlink_metadata(&fifo)
        .expect("FIFO exists")
        .file_type()
        .is_fifo());
    assert_eq!(temps(&dir.0), Vec::<PathBuf>::new());
}

#[test]
fn an_output_naming_an_input_or_another_output_is_refused() {
    let fx = fixture();
    let dir = Dir::new("same");
    let input = dir.file("in.csv", &std::fs::read(&fx.chunks[0]).expect("chunk"));
    let model = dir.file("model.json", &std::fs::read(&fx.model).expect("model"));
    let state = dir.path("state.json");
    ok(&[
        "monitor",
        "--model",
        s(&model),
        "--input",
        s(&input),
        "--out",
        s(&dir.path("rows.csv")),
        "--state",
        s(&state),
    ]);
    let same = "name the same file";
    assert_refused(
        &["align", "--input", s(&input), "--out", s(&input)],
        &dir.0,
        same,
    );
    let dotted = dir.0.join(".").join("in.csv");
    assert_refused(
        &["align", "--input", s(&input), "--out", s(&dotted)],
        &dir.0,
        same,
    );
    let day2 = dir.file("day2.csv", &std::fs::read(&fx.chunks[1]).expect("chunk"));
    let monitor = |out: &Path, state: &Path| {
        let args = [
            "monitor",
            "--model",
            s(&model),
            "--input",
            s(&day2),
            "--out",
            s(out),
            "--state",
            s(state),
        ];
        args.map(str::to_string)
    };
    assert_refused(&monitor(&model, &state), &dir.0, "--model and --out");
    assert_refused(&monitor(&state, &state), &dir.0, "--out and --state");
    assert_refused(&monitor(&day2, &dir.path("other.json")), &dir.0, same);
    for out in [&input, &model] {
        assert_refused(
            &[
                "report",
                "--model",
                s(&model),
                "--input",
                s(&input),
                "--out",
                s(out),
            ],
            &dir.0,
            same,
        );
    }
}

/// A small tmpfs, unmounted when dropped (also when the test fails).
struct Mount(PathBuf);

impl Mount {
    /// Mounts `size` of tmpfs on `dir`; `None` when skipped by `LIFTWATCH_SKIP_ROOT_TESTS=1`.
    fn tmpfs(dir: &Path, size: &str) -> Option<Mount> {
        std::fs::create_dir_all(dir).expect("mount point");
        let out = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(dir)
            .output();
        match out {
            Ok(o) if o.status.success() => Some(Mount(dir.to_path_buf())),
            failed => {
                let why = match failed {
                    Ok(o) => String::from_utf8_lossy(&o.stderr).into_owned(),
                    Err(e) => e.to_string(),
                };
                if std::env::var("LIFTWATCH_SKIP_ROOT_TESTS").is_ok_and(|v| v == "1") {
                    eprintln!(
                        "skip: cannot mount a tmpfs ({}), LIFTWATCH_SKIP_ROOT_TESTS=1",
                        why.trim()
                    );
                    return None;
                }
                panic!(
                    "cannot mount a tmpfs on {dir:?}: {} (run as root, or set LIFTWATCH_SKIP_ROOT_TESTS=1 to skip)",
                    why.trim()
                );
            }
        }
    }
}

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

#[test]
fn a_full_disk_leaves_no_partial_and_no_temporary_file() {
    let fx = fixture();
    let dir = Dir::new("full");
    let fit_into = |out: &Path| {
        vec![
            "fit".to_string(),
            "--input".into(),
            s(&fx.aligned).into(),
            "--elevator".into(),
            s(&fx.elevator).into(),
            "--out".into(),
            s(out).into(),
        ]
    };
    // fit keeps its aligned samples beside the model: a directory that is not there is named,
    // with the flag that names it, before anything is fitted.
    let missing = dir.path("missing");
    assert_refused(
        &fit_into(&missing.join("m.json")),
        &dir.0,
        &format!("the directory {} does not exist", s(&missing)),
    );
    let Some(mount) = Mount::tmpfs(&dir.path("small"), "64k") else {
        return;
    };
    let small = mount.0.clone();
    // Outputs far larger than 64 KiB: the whole aligned log, and a report's figures.
    let aligned = s(&fx.aligned);
    assert!(std::fs::metadata(&fx.aligned).expect("aligned").len() > 4 * 65536);
    let space = "No space left on device";
    assert_refused(
        &[
            "align",
            "--input",
            aligned,
            "--out",
            s(&small.join("a.csv")),
        ],
        &small,
        space,
    );
    let existing = small.join("a.csv");
    std::fs::write(&existing, "old content\n").expect("small file fits");
    assert_refused(
        &["align", "--input", aligned, "--out", s(&existing)],
        &small,
        space,
    );
    // The fit's samples on disk (64 bytes each) do not fit either; nothing of them is left.
    assert_refused(&fit_into(&small.join("m.json")), &small, space);
    let model = s(&fx.model);
    let input = s(&fx.chunks[3]);
    assert_refused(
        &[
            "report",
            "--model",
            model,
            "--input",
            input,
            "--out",
            s(&small.join("rep")),
        ],
        &small,
        space,
    );
    std::fs::create_dir(small.join("old")).expect("dir fits");
    std::fs::write(small.join("old/index.html"), "old").expect("file fits");
    assert_refused(
        &[
            "report",
            "--model",
            model,
            "--input",
            input,
            "--out",
            s(&small.join("old")),
        ],
        &small,
        space,
    );
    // Rows that do not fit leave the state as it was: nothing is lost for the next run.
    let state = dir.file("state.json", b"");
    std::fs::remove_file(&state).expect("state path");
    ok(&[
        "monitor",
        "--model",
        model,
        "--input",
        s(&fx.chunks[0]),
        "--out",
        "/dev/null",
        "--state",
        s(&state),
    ]);
    let saved = std::fs::read(&state).expect("state written");
    assert_refused(
        &[
            "monitor",
            "--model",
            model,
            "--input",
            s(&fx.chunks[1]),
            "--out",
            s(&small.join("rows.csv")),
            "--state",
            s(&state),
        ],
        &small,
        space,
    );
    assert_eq!(
        std::fs::read(&state).expect("state"),
        saved,
        "state changed"
    );
    drop(mount);
}

/// `report --days` draws the input's last days and holds only those; the verdict is the whole
/// input's. A number of days that is not positive is refused.
#[test]
fn a_report_draws_its_last_days() {
    let fx = fixture();
    let dir = Dir::new("days");
    let (model, aligned) = (s(&fx.model), s(&fx.aligned));
    let whole = dir.path("whole");
    let last = dir.path("last");
    let args = |out: &Path, days: &str| {
        let (out, days) = (s(out).to_string(), format!("--days={days}"));
        ["report", "--model", model, "--input", aligned, "--out"]
            .map(String::from)
            .into_iter()
            .chain([out, days])
            .collect::<Vec<String>>()
    };
    let report = |out: &Path, days: &str| {
        let run = ok(&args(out, days));
        let index = std::fs::read_to_string(out.join("index.html")).expect("index.html");
        (run.stderr, index)
    };
    let (all, all_page) = report(&whole, "31");
    let (part, part_page) = report(&last, "0.25");
    // 0.25 days at 1 s, the first of them included, out of the 0.6 days' samples.
    let n = |text: &str| text.split_whitespace().nth(1).map(str::to_string);
    assert!(!all.contains("figures of its last"), "{all}");
    assert_eq!(n(&part), n(&all));
    assert!(
        part.contains("; figures of its last 0.25 days (21601 samples)"),
        "{part}"
    );
    assert!(!all_page.contains("its last"));
    assert!(part_page.contains("aligned.csv, its last 0.25 of 0.6 days"));
    let verdict = |page: &str| {
        let at = page.find("id=\"verdict\"").expect("a verdict");
        page[at..at + 400].to_string()
    };
    assert_eq!(verdict(&part_page), verdict(&all_page));
    for bad in ["0", "-1", "NaN", "inf"] {
        assert_refused(
            &args(&dir.path("bad"), bad),
            &dir.0,
            "--days must be a positive number of days",
        );
    }
}

#[test]
fn input_the_state_covers_is_refused_or_skipped() {
    let fx = fixture();
    let dir = Dir::new("covered");
    let model = s(&fx.model);
    let state = dir.path("state.json");
    let monitor = |input: &Path, out: &str, extra: Option<&str>| {
        let mut args = vec![
            "monitor".to_string(),
            "--model".into(),
            model.into(),
            "--input".into(),
            s(input).into(),
            "--out".into(),
            s(&dir.path(out)).into(),
            "--state".into(),
            s(&state).into(),
        ];
        args.extend(extra.map(str::to_string));
        args
    };
    ok(&monitor(&fx.chunks[0], "day1.csv", None));
    let saved = std::fs::read(&state).expect("state written");
    assert_refused(
        &monitor(&fx.chunks[0], "again.csv", None),
        &dir.0,
        "--skip-covered",
    );
    let run = ok(&monitor(&fx.chunks[0], "again.csv", Some("--skip-covered")));
    let n_rows = std::fs::read_to_string(&fx.chunks[0])
        .expect("chunk")
        .lines()
        .count()
        - 1;
    assert!(
        run.stderr
            .contains(&format!("0 samples, {n_rows} already covered skipped")),
        "{}",
        run.stderr
    );
    assert_eq!(std::fs::read(&state).expect("state"), saved, "state moved");

    // Half of day 1 again, then day 2: the covered half is skipped, day 2 is watched as if
    // it came alone.
    let day1 = std::fs::read_to_string(&fx.chunks[0]).expect("chunk");
    let day2 = std::fs::read_to_string(&fx.chunks[1]).expect("chunk");
    let (header, rows1) = day1.split_once('\n').expect("header");
    let rows1: Vec<&str> = rows1.lines().collect();
    let tail = rows1[rows1.len() / 2..].join("\n");
    let body2 = day2.split_once('\n').expect("header").1;
    let overlap = dir.file(
        "overlap.csv",
        format!("{header}\n{tail}\n{body2}").as_bytes(),
    );
    let run = ok(&monitor(&overlap, "day2.csv", Some("--skip-covered")));
    let skipped = rows1.len() - rows1.len() / 2;
    assert!(
        run.stderr
            .contains(&format!("{skipped} already covered skipped")),
        "{}",
        run.stderr
    );
    let alone_state = dir.path("alone.json");
    for (i, chunk) in fx.chunks[..2].iter().enumerate() {
        ok(&[
            "monitor",
            "--model",
            model,
            "--input",
            s(chunk),
            "--out",
            s(&dir.path(&format!("alone_{i}.csv"))),
            "--state",
            s(&alone_state),
        ]);
    }
    let read = |name: &str| std::fs::read(dir.path(name)).expect("output");
    assert!(read("day2.csv") == read("alone_1.csv"), "day 2 rows differ");
    assert!(
        read("state.json") == read("alone.json"),
        "final states differ"
    );
}

#[test]
fn a_raw_log_resumed_with_an_overlap_gives_the_rows_of_one_run() {
    let fx = fixture();
    let dir = Dir::new("raw-resume");
    let model = s(&fx.model);
    let raw_path = fx
        .aligned
        .parent()
        .expect("fixture dir")
        .join("sim/raw.csv");
    let raw = std::fs::read_to_string(&raw_path).expect("raw log");
    let (header, body) = raw.split_once('\n').expect("header");
    // Split at 240 s, mid-trip in this log (seed 3): rows by their time, as a logger that
    // starts a new file at a given instant writes them.
    let split = 240.0;
    let time = |line: &str| line.split(',').next().and_then(|t| t.parse::<f64>().ok());
    let (before, after): (Vec<&str>, Vec<&str>) = body
        .lines()
        .partition(|l| time(l).is_some_and(|t| t < split));
    let part1 = dir.file(
        "part1.csv",
        format!("{header}\n{}\n", before.join("\n")).as_bytes(),
    );
    let part2 = dir.file(
        "part2.csv",
        format!("{header}\n{}\n", after.join("\n")).as_bytes(),
    );
    // The last 200 rows of the first part again in front of the second.
    let tail = &before[before.len().saturating_sub(200)..];
    let overlap = dir.file(
        "overlap.csv",
        format!("{header}\n{}\n{}\n", tail.join("\n"), after.join("\n")).as_bytes(),
    );
    let monitor = |input: &Path, out: &str, state: &str, extra: &[&str]| {
        let mut args: Vec<String> = ["monitor", "--model", model, "--input", s(input)]
            .iter()
            .map(|a| a.to_string())
            .collect();
        args.extend(["--out".into(), s(&dir.path(out)).into()]);
        if !state.is_empty() {
            args.extend(["--state".into(), s(&dir.path(state)).into()]);
        }
        args.extend(extra.iter().map(|a| a.to_string()));
        ok(&args)
    };
    monitor(&raw_path, "whole.csv", "", &[]);
    monitor(&part1, "p1.csv", "a.json", &[]);
    std::fs::copy(dir.path("a.json"), dir.path("b.json")).expect("copy");
    let gap = monitor(&part2, "p2.csv", "a.json", &[]);
    assert!(
        gap.stderr.contains("the samples between are missing"),
        "a resume without overlap says what it loses: {}",
        gap.stderr
    );
    monitor(&overlap, "p2o.csv", "b.json", &["--skip-covered"]);
    let rows = |name: &str| -> Vec<String> {
        let text = std::fs::read_to_string(dir.path(name)).expect("rows");
        text.lines().skip(1).map(str::to_string).collect()
    };
    let mut whole = rows("whole.csv");
    whole.pop(); // a --state run holds its last sample back for the central difference
    let joined = [rows("p1.csv"), rows("p2o.csv")].concat();
    assert!(
        joined == whole,
        "the overlapped resume differs from one run"
    );
    let gapped = [rows("p1.csv"), rows("p2.csv")].concat();
    assert!(
        gapped != whole,
        "without the overlap a sample is lost (the test's premise)"
    );
}

#[test]
fn absurd_models_are_refused_with_one_line_naming_the_field() {
    let fx = fixture();
    let dir = Dir::new("absurd");
    let input = s(&fx.chunks[0]);
    let long = "x".repeat(100_000);
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(&str, &str, Edit)> = vec![
        (
            "kd",
            "kd",
            Box::new(|m| m["parameters"]["kd"] = 1e308.into()),
        ),
        (
            "m0",
            "m0",
            Box::new(|m| m["parameters"]["m0"] = 1e308.into()),
        ),
        (
            "sigma",
            "sigma_u_v",
            Box::new(|m| m["scales"]["sigma_u_v"] = 1e-308.into()),
        ),
        (
            "tau",
            "tau",
            Box::new(|m| m["risk"]["tau"] = (-1e308).into()),
        ),
        (
            "spread",
            "trip_spread",
            Box::new(|m| m["risk"]["trip_spread_u"][0] = (-0.5).into()),
        ),
        ("optimizer", "optimizer", {
            let long = long.clone();
            Box::new(move |m| m["train"]["optimizer"] = long.clone().into())
        }),
        ("kd-string", "kd", {
            let long = long.clone();
            Box::new(move |m| m["parameters"]["kd"] = long.clone().into())
        }),
        ("name", "name", {
            let long = long.clone();
            Box::new(move |m| m["fit"]["parameters"][0]["name"] = long.clone().into())
        }),
        ("key", "has a key of 100000 characters", {
            let long = long.clone();
            Box::new(move |m| m["risk"][long.as_str()] = 1.0.into())
        }),
    ];
    for (name, field, edit) in cases {
        let mut m = model_json();
        edit(&mut m);
        let model = dir.path(&format!("{name}.json"));
        write_json(&model, &m);
        let model = s(&model);
        let (out, events, state) = (
            dir.path("rows.csv"),
            dir.path("events.jsonl"),
            dir.path("state.json"),
        );
        let (out, events, state) = (s(&out), s(&events), s(&state));
        assert_refused(
            &[
                "monitor", "--model", model, "--input", input, "--out", out, "--events", events,
                "--state", state,
            ],
            &dir.0,
            field,
        );
        let rep = dir.path("report");
        let rep = s(&rep);
        assert_refused(
            &["report", "--model", model, "--input", input, "--out", rep],
            &dir.0,
            field,
        );
    }
    // The unchanged model passes, so the refusals above are the edits' doing.
    write_json(&dir.path("good.json"), &model_json());
    ok(&[
        "monitor",
        "--model",
        s(&dir.path("good.json")),
        "--input",
        input,
        "--out",
        "/dev/null",
    ]);
}

#[path = "safety/kill.rs"]
mod kill;
