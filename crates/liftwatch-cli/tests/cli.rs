//! Runs the real `liftwatch` binary on bad and partly bad inputs (DATA.md §6): a bad input
//! gives a non-zero exit, exactly one stderr line `liftwatch: ...`, no panic and no output
//! file; a partly bad input succeeds with exactly one `warning:` line.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::Dir;

struct Run {
    ok: bool,
    stderr: String,
}

/// Runs the binary; a run that hangs is killed after a minute (a guard, not a timing test).
fn liftwatch(args: &[&str]) -> Run {
    let mut child = Command::new(env!("CARGO_BIN_EXE_liftwatch"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let start = Instant::now();
    while child.try_wait().expect("wait works").is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("liftwatch {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = child.wait_with_output().expect("output is readable");
    Run {
        ok: out.status.success(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn s(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

/// Aligns `input` into `dir/out.csv` and checks the failure contract.
fn assert_align_fails(dir: &Dir, input: &Path, expect_in_message: &str) {
    let out = dir.0.join("out.csv");
    let before = dir.names();
    let run = liftwatch(&["align", "--input", s(input), "--out", s(&out)]);
    assert!(!run.ok, "{input:?} must fail; stderr: {}", run.stderr);
    let lines: Vec<&str> = run.stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "one stderr line expected, got: {}",
        run.stderr
    );
    assert!(lines[0].starts_with("liftwatch: "), "{}", lines[0]);
    assert!(!run.stderr.contains("panicked"), "{}", run.stderr);
    assert!(
        lines[0].contains(expect_in_message),
        "`{expect_in_message}` expected in: {}",
        lines[0]
    );
    assert_eq!(
        dir.names(),
        before,
        "no output or temporary file may be left behind"
    );
}

#[test]
fn missing_file_fails_with_one_line() {
    let dir = Dir::new("missing");
    assert_align_fails(&dir, &dir.0.join("nope.csv"), "nope.csv");
}

#[test]
fn empty_file_fails_with_one_line() {
    let dir = Dir::new("empty");
    let input = dir.file("in.csv", b"");
    assert_align_fails(&dir, &input, "empty");
}

#[test]
fn header_only_fails_with_one_line() {
    let dir = Dir::new("header");
    let input = dir.file("in.csv", b"time,signal,value\n");
    assert_align_fails(&dir, &input, "no data rows");
}

#[test]
fn wrong_header_fails_with_one_line() {
    let dir = Dir::new("layout");
    let input = dir.file("in.csv", b"timestamp,name,reading\n1,speed,2\n");
    assert_align_fails(&dir, &input, "unknown layout");
}

#[test]
fn every_value_garbage_or_nan_fails_with_one_line() {
    let dir = Dir::new("garbage");
    let input = dir.file(
        "in.csv",
        b"time,signal,value\n1,speed,abc\n2,speed,NaN\n3,load,\n4,door,1.2.3\n",
    );
    assert_align_fails(&dir, &input, "none of the 4 rows");
}

#[test]
fn absurd_timestamps_fail_with_one_line() {
    let dir = Dir::new("absurd");
    let input = dir.file(
        "in.csv",
        b"time,signal,value\n1e300,speed,1\ninf,speed,1\n-inf,load,3\nNaN,door,0\n",
    );
    assert_align_fails(&dir, &input, "outside the accepted range");
}

#[test]
fn time_span_beyond_the_limit_fails_before_writing() {
    let dir = Dir::new("span");
    let input = dir.file(
        "in.csv",
        b"time,signal,value\n0,speed,1\n1,speed,1\n9000000000,speed,1\n",
    );
    assert_align_fails(&dir, &input, "10 years");
}

#[test]
fn invalid_step_fails_with_one_line() {
    let dir = Dir::new("step");
    let input = dir.file("in.csv", b"time,signal,value\n0,speed,1\n");
    let out = dir.0.join("out.csv");
    let run = liftwatch(&[
        "align",
        "--input",
        s(&input),
        "--out",
        s(&out),
        "--step",
        "0",
    ]);
    assert!(!run.ok);
    assert_eq!(run.stderr.lines().count(), 1, "{}", run.stderr);
    assert!(
        run.stderr
            .starts_with("liftwatch: invalid setting `step_s`"),
        "{}",
        run.stderr
    );
    assert!(!out.exists());
}

/// Aligns `input` and returns (stderr lines, output text).
fn align_ok(dir: &Dir, input: &Path) -> (Vec<String>, String) {
    let out = dir.0.join("out.csv");
    let run = liftwatch(&["align", "--input", s(input), "--out", s(&out)]);
    assert!(run.ok, "must succeed: {}", run.stderr);
    assert!(!run.stderr.contains("panicked"), "{}", run.stderr);
    let text = std::fs::read_to_string(&out).expect("output written");
    (run.stderr.lines().map(str::to_owned).collect(), text)
}

#[test]
fn messy_fixture_succeeds_with_one_warning_line() {
    // BOM, CRLF, shuffled rows, a garbage value, an unreadable and an absurd time, an
    // unknown signal, missing values, a duplicate row and a truncated last line.
    let dir = Dir::new("messy");
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../liftwatch/tests/data/raw_messy.csv");
    let (lines, text) = align_ok(&dir, &fixture);
    let warnings: Vec<&String> = lines.iter().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{lines:?}");
    assert!(warnings[0].contains("bad row"), "{}", warnings[0]);
    assert!(warnings[0].contains("`temperature`"), "{}", warnings[0]);
    assert_eq!(lines.len(), 2, "a warning and a summary: {lines:?}");
    assert!(text.starts_with("time,speed,direction,voltage,load,door,floor\n"));
    assert!(text.lines().count() > 10);
    assert_eq!(dir.names(), vec!["out.csv"]);
}

#[test]
fn garbage_rows_among_good_ones_and_truncated_last_line_succeed() {
    let dir = Dir::new("partly");
    let input = dir.file(
        "in.csv",
        b"time,signal,value\r\n0,speed,0\r\n1,speed,x\r\n2,speed,2\r\n2,humidity,40\r\n3,speed,3\r\n4,spe",
    );
    let (lines, text) = align_ok(&dir, &input);
    assert_eq!(
        lines.iter().filter(|l| l.starts_with("warning:")).count(),
        1,
        "{lines:?}"
    );
    assert!(lines[0].contains("lines 3, 7"), "{}", lines[0]);
    assert!(lines[0].contains("`humidity`"), "{}", lines[0]);
    let speeds: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap_or("?"))
        .collect();
    assert_eq!(speeds, vec!["0", "1", "2", "3"]);
}

#[test]
fn clean_input_gives_no_warning() {
    let dir = Dir::new("clean");
    let input = dir.file("in.csv", b"time,signal,value\n0,speed,0\n1,speed,1\n");
    let (lines, _) = align_ok(&dir, &input);
    assert!(
        lines.iter().all(|l| !l.starts_with("warning:")),
        "{lines:?}"
    );
}

#[test]
fn status_refuses_a_missing_or_foreign_state_in_one_line() {
    let dir = Dir::new("status");
    let model = dir.file("model.json", b"{}");
    let state = dir.path("absent.json");
    let run = liftwatch(&["status", "--model", s(&model), "--state", s(&state)]);
    assert!(
        !run.ok && !run.stderr.contains("panicked"),
        "{}",
        run.stderr
    );
    assert_eq!(run.stderr.lines().count(), 1, "{}", run.stderr);
    assert!(
        run.stderr.starts_with("liftwatch: cannot use the model"),
        "{}",
        run.stderr
    );
    let garbage = dir.file("state.json", b"{\"format_version\": 1}");
    let run = liftwatch(&["status", "--model", s(&garbage), "--state", s(&garbage)]);
    assert!(!run.ok && run.stderr.lines().count() == 1, "{}", run.stderr);
}

#[test]
fn simulate_can_switch_the_drive_off_at_rest_use_the_papers_load_cell_and_a_lossy_transmission() {
    let dir = Dir::new("drive-off");
    let out = dir.0.join("sim");
    let run = liftwatch(&[
        "simulate",
        "--out",
        s(&out),
        "--days",
        "0.2",
        "--seed",
        "3",
        "--drive-at-rest",
        "off",
        "--load-cell",
        "constant-k",
        "--efficiency",
        "0.9",
        "--quiet",
    ]);
    assert!(run.ok, "{}", run.stderr);
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["plant"]["drive_at_rest"]["kind"], "off");
    assert_eq!(truth["plant"]["load_cell_load_gain"], 0.0);
    assert_eq!(truth["plant"]["efficiency"], 0.9);
    // Between trips the voltage reads the sensor's offset, not U0 (1-3 % of rated voltage).
    let rest: Vec<f64> = std::fs::read_to_string(out.join("aligned.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect();
            (f[1] == 0.0 && f[2] == 0.0 && f[3].is_finite()).then_some(f[3])
        })
        .collect();
    assert!(rest.len() > 100, "{} standstill rows", rest.len());
    let mut sorted = rest.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!(median < 2.0, "median standstill voltage {median} V");
    let bad = liftwatch(&["simulate", "--out", s(&out), "--drive-at-rest", "sometimes"]);
    assert!(
        !bad.ok && bad.stderr.contains("sometimes"),
        "{}",
        bad.stderr
    );
    let lossy = liftwatch(&["simulate", "--out", s(&out), "--efficiency", "0.4"]);
    assert!(
        !lossy.ok
            && lossy.stderr.trim() == "liftwatch: --efficiency 0.4 must lie between 0.5 and 1",
        "{}",
        lossy.stderr
    );
}
