//! The command line as scripts use it, through the real binary: `-` for standard input and
//! output, `.gz` in and out, exit statuses under `monitor --fail-on`, `--json` and `--quiet`,
//! no `\r` progress into a pipe, checked choices, the step guard, a short fit's caveats, the
//! alarm budget, the elevator's name and time zone, and one row per trip.

use liftwatch::sample::DAY_S;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

mod common;
use common::Dir;

/// What one run of the binary gave.
struct Out {
    code: i32,
    stdout: Vec<u8>,
    stderr: String,
}

impl Out {
    fn stdout_text(&self) -> String {
        String::from_utf8(self.stdout.clone()).expect("stdout is UTF-8")
    }

    /// The one JSON object `--json` prints.
    fn json(&self) -> serde_json::Value {
        let text = self.stdout_text();
        assert_eq!(text.lines().count(), 1, "one line of JSON: {text}");
        serde_json::from_str(&text).expect("stdout is a JSON object")
    }
}

/// Runs the binary with `stdin` piped in (empty when `None`).
fn run_with(args: &[&str], stdin: Option<&[u8]>) -> Out {
    let mut child = Command::new(env!("CARGO_BIN_EXE_liftwatch"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let input = stdin.map(<[u8]>::to_vec).unwrap_or_default();
    let mut pipe = child.stdin.take().expect("stdin is piped");
    let writer = std::thread::spawn(move || {
        // A command that does not read stdin closes it early: a broken pipe is no failure.
        let _ = pipe.write_all(&input);
    });
    let out = child.wait_with_output().expect("the binary finishes");
    writer.join().expect("the stdin writer ends");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!stderr.contains("panicked"), "liftwatch {args:?}: {stderr}");
    Out {
        code: out.status.code().expect("an exit status, not a signal"),
        stdout: out.stdout,
        stderr,
    }
}

fn run(args: &[&str]) -> Out {
    run_with(args, None)
}

/// Runs to success.
fn ok(args: &[&str]) -> Out {
    let out = run(args);
    assert_eq!(out.code, 0, "liftwatch {args:?}: {}", out.stderr);
    out
}

/// Runs to an error: status 1 and exactly one stderr line naming `expect`.
fn fails(args: &[&str], expect: &str) {
    let out = run(args);
    assert_eq!(out.code, 1, "liftwatch {args:?} must fail: {}", out.stderr);
    assert_eq!(out.stderr.lines().count(), 1, "one line: {}", out.stderr);
    assert!(
        out.stderr.starts_with("liftwatch: ") && out.stderr.contains(expect),
        "`{expect}` expected in: {}",
        out.stderr
    );
}

fn s(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(bytes).expect("memory is writable");
    enc.finish().expect("memory is writable")
}

fn gunzip(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(bytes)
        .read_to_end(&mut out)
        .expect("a gzip stream");
    out
}

/// A healthy half day, a model of it (named "Lift A", at +01:00, an alarm budget of 2 a year)
/// and a day with a motor fault, shared by the cases.
struct Fixture {
    raw: PathBuf,
    model: PathBuf,
    fault: PathBuf,
    fit_stderr: String,
    fit_json: serde_json::Value,
}

fn fixture() -> &'static Fixture {
    static FIXTURE: OnceLock<Fixture> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scripts-fixture");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("the target's tmp dir is writable");
        let (healthy, worn) = (dir.join("healthy"), dir.join("worn"));
        let days = ["--days", "0.5", "--seed", "5", "--quiet"];
        let first = ["simulate", "--out", s(&healthy), "--start-hour", "7"];
        ok(&[&first[..], &days[..]].concat());
        let fault = [
            "--scenario",
            "motor",
            "--ramp",
            "step",
            "--onset-days",
            "0.05",
            "--severity",
            "3",
            "--start-hour",
            "31",
        ];
        let second = ["simulate", "--out", s(&worn)];
        ok(&[&second[..], &days[..], &fault[..]].concat());
        let toml = std::fs::read_to_string(healthy.join("elevator.toml")).expect("elevator");
        let elevator = dir.join("elevator.toml");
        std::fs::write(
            &elevator,
            format!("name = \"Lift A\"\nid = \"B-7\"\ntimezone = \"+01:00\"\n{toml}"),
        )
        .expect("fixture dir is writable");
        let model = dir.join("model.json");
        let raw = healthy.join("raw.csv");
        let fit = ok(&[
            "fit",
            "--input",
            s(&raw),
            "--elevator",
            s(&elevator),
            "--out",
            s(&model),
            "--epochs",
            "60",
            "--false-advisories-per-year",
            "2",
        ]);
        // The same fit again with --json: the same model, and its summary as JSON.
        let model_json = dir.join("model-json.json");
        let json_fit = ok(&[
            "fit",
            "--input",
            s(&raw),
            "--elevator",
            s(&elevator),
            "--out",
            s(&model_json),
            "--epochs",
            "60",
            "--false-advisories-per-year",
            "2",
            "--json",
        ]);
        Fixture {
            raw,
            model,
            fault: worn.join("raw.csv"),
            fit_stderr: fit.stderr,
            fit_json: json_fit.json(),
        }
    })
}

#[test]
fn align_reads_stdin_and_writes_stdout_the_same_bytes_as_files() {
    let fx = fixture();
    let dir = Dir::new("pipe");
    let out = dir.path("aligned.csv");
    ok(&["align", "--input", s(&fx.raw), "--out", s(&out)]);
    let want = std::fs::read(&out).expect("aligned file");
    let raw = std::fs::read(&fx.raw).expect("raw log");
    let piped = run_with(&["align", "--input", "-", "--out", "-"], Some(&raw));
    assert_eq!(piped.code, 0, "{}", piped.stderr);
    assert!(piped.stdout == want, "stdout differs from the file output");
    assert!(
        piped.stderr.starts_with("<stdout>: used"),
        "the summary goes to stderr: {}",
        piped.stderr
    );
    // The last row first: every later row is out of order, and the rows come out sorted.
    let text = String::from_utf8(raw).expect("UTF-8");
    let mut lines: Vec<&str> = text.lines().collect();
    let last = lines.pop().expect("rows");
    lines.insert(1, last);
    let shuffled = format!("{}\n", lines.join("\n"));
    let sorted = run_with(
        &["align", "--input", "-", "--out", "-"],
        Some(shuffled.as_bytes()),
    );
    assert_eq!(sorted.code, 0, "{}", sorted.stderr);
    assert!(
        sorted.stdout == want,
        "an unsorted stdin gives the same rows"
    );
    // Aligned input at another step is read a second time to re-step it: stdin is replayed.
    let (coarse, replayed) = (dir.path("coarse.csv"), dir.path("replayed.csv"));
    ok(&[
        "align",
        "--input",
        s(&out),
        "--out",
        s(&coarse),
        "--step",
        "2",
    ]);
    let again = run_with(
        &[
            "align",
            "--input",
            "-",
            "--out",
            s(&replayed),
            "--step",
            "2",
        ],
        Some(&want),
    );
    assert_eq!(again.code, 0, "{}", again.stderr);
    assert!(
        std::fs::read(&replayed).expect("output") == std::fs::read(&coarse).expect("output"),
        "a replayed stdin gives the rows of the file"
    );
}

#[test]
fn gz_and_zst_input_and_output_are_chosen_by_the_name() {
    let fx = fixture();
    let dir = Dir::new("gz");
    let plain = dir.path("aligned.csv");
    ok(&["align", "--input", s(&fx.raw), "--out", s(&plain)]);
    let raw_gz = dir.file("raw.csv.gz", &gzip(&std::fs::read(&fx.raw).expect("raw")));
    let out_gz = dir.path("aligned.csv.gz");
    ok(&["align", "--input", s(&raw_gz), "--out", s(&out_gz)]);
    let want = std::fs::read(&plain).expect("aligned");
    let got = std::fs::read(&out_gz).expect("gz output");
    assert_eq!(&got[..2], b"\x1f\x8b", "the .gz output is gzip");
    assert!(
        got.len() * 2 < want.len(),
        "{} vs {} bytes",
        got.len(),
        want.len()
    );
    assert!(gunzip(&got) == want, "gzip in and out gives the plain rows");
    // Monitor reads the compressed aligned series and writes compressed rows and events.
    let (rows, events) = (dir.path("risk.csv.gz"), dir.path("events.jsonl.gz"));
    let args = ["monitor", "--model", s(&fx.model), "--input"];
    ok(&[
        &args[..],
        &[s(&out_gz), "--out", s(&rows), "--events", s(&events)],
    ]
    .concat());
    let plain_rows = dir.path("risk.csv");
    ok(&[&args[..], &[s(&plain), "--out", s(&plain_rows)]].concat());
    let rows = gunzip(&std::fs::read(&rows).expect("rows"));
    assert!(rows == std::fs::read(&plain_rows).expect("plain rows"));
    // The same with zstd, in and out.
    let zst = dir.path("aligned.csv.zst");
    ok(&["align", "--input", s(&fx.raw), "--out", s(&zst)]);
    let got = std::fs::read(&zst).expect("zst output");
    assert_eq!(&got[..4], b"\x28\xb5\x2f\xfd", "the .zst output is zstd");
    assert!(zstd::decode_all(&got[..]).expect("zstd") == want);
    let zst_rows = dir.path("risk.csv.zst");
    ok(&[&args[..], &[s(&zst), "--out", s(&zst_rows)]].concat());
    let rows = zstd::decode_all(&std::fs::read(&zst_rows).expect("rows")[..]).expect("zstd");
    assert!(rows == std::fs::read(&plain_rows).expect("plain rows"));
}

#[test]
fn only_one_dash_per_direction() {
    let fx = fixture();
    fails(
        &[
            "monitor",
            "--model",
            s(&fx.model),
            "--input",
            "-",
            "--out",
            "-",
            "--events",
            "-",
        ],
        "--out and --events are both `-`",
    );
    fails(
        &[
            "monitor",
            "--model",
            s(&fx.model),
            "--input",
            s(&fx.raw),
            "--out",
            "-",
            "--json",
        ],
        "--json and `--out -` both write standard output",
    );
    fails(&["simulate", "--out", "-"], "--out cannot be `-`");
    fails(
        &[
            "report",
            "--model",
            s(&fx.model),
            "--input",
            "-",
            "--out",
            "-",
        ],
        "--out cannot be `-`",
    );
    let state = ["--out", "r.csv", "--state", "-"];
    fails(
        &[
            &["monitor", "--model", s(&fx.model), "--input", s(&fx.raw)],
            &state[..],
        ]
        .concat(),
        "--state cannot be `-`",
    );
}

#[test]
fn fail_on_turns_the_highest_level_into_the_exit_status() {
    let fx = fixture();
    let dir = Dir::new("fail-on");
    let out = dir.path("risk.csv");
    let base = [
        "monitor",
        "--model",
        s(&fx.model),
        "--input",
        s(&fx.fault),
        "--out",
        s(&out),
    ];
    let plain = run(&[&base[..], &["--json"]].concat());
    assert_eq!(plain.code, 0, "without --fail-on a level is no failure");
    let summary = plain.json();
    let highest = summary["highest_level"]
        .as_str()
        .expect("highest_level")
        .to_string();
    assert_ne!(
        highest, "normal",
        "the fault must raise the level for the test to mean anything"
    );
    let advisory = run(&[&base[..], &["--fail-on", "advisory", "--quiet"]].concat());
    assert_eq!(
        advisory.code,
        if highest == "alarm" { 4 } else { 3 },
        "{highest}"
    );
    assert_eq!(advisory.stderr, "", "--quiet prints nothing on success");
    let alarm = run(&[&base[..], &["--fail-on", "alarm", "--quiet"]].concat());
    assert_eq!(
        alarm.code,
        if highest == "alarm" { 4 } else { 0 },
        "{highest}"
    );
    assert!(out.exists(), "the outputs are written whatever the status");
    let bad = run(&[&base[..], &["--fail-on", "warning"]].concat());
    assert_eq!(bad.code, 2, "a choice not offered is a usage error");
    assert!(
        bad.stderr.contains("possible values: advisory, alarm"),
        "{}",
        bad.stderr
    );
}

/// `evaluate` writes `evaluation.json` with each machine fault's oracle floor, its figure
/// beside it, and the delays against the references in its `--json` summary.
#[test]
fn evaluate_writes_the_floor_the_delays_and_their_figure() {
    let dir = Dir::new("evaluate");
    let out = dir.path("eval");
    let j = ok(&["evaluate", "--quick", "--out", s(&out), "--json"]).json();
    assert_eq!(j["command"], "evaluate");
    let floor = &j["delays"]["floor"];
    assert!(floor["cases"].as_u64().expect("floor cases") >= 1, "{j}");
    assert!(
        floor["other_median_days"].as_f64().expect("floor days") > 0.0,
        "{j}"
    );
    let text = std::fs::read_to_string(out.join("evaluation.json")).expect("evaluation.json");
    let ev: serde_json::Value = serde_json::from_str(&text).expect("evaluation.json is JSON");
    let cases = ev["cases"].as_array().expect("cases");
    for c in cases {
        let machine = matches!(c["truth"].as_str(), Some("motor" | "brake" | "friction"));
        assert_eq!(
            c["floor_delay_days"].is_f64(),
            machine,
            "a floor exactly for the machine faults: {c}"
        );
    }
    // The quick suite's car stuck between floors for an hour is reported as such within
    // minutes of its stop (the stuck check's 5 min and the aligner's lag), and nowhere else.
    let stuck = &j["outages"][0];
    assert_eq!(stuck["case"], "E2 outage stuck", "{j}");
    assert_eq!(stuck["reported"], true, "{j}");
    assert_eq!(stuck["kind_correct"], true, "{j}");
    assert_eq!(stuck["false_reports"], 0, "{j}");
    let after_h = stuck["after_h"].as_f64().expect("hours to the report");
    assert!((0.08..0.2).contains(&after_h), "{after_h} h");
    let svg = std::fs::read_to_string(out.join("evaluation.svg")).expect("evaluation.svg");
    assert!(svg.contains("oracle floor"), "the figure's left panel");
    assert!(std::fs::metadata(out.join("evaluation.png")).is_ok_and(|m| m.len() > 1000));
}

/// `evaluate --keep-runs` keeps a case's model and aligned log, and `monitor` on them raises
/// the events the suite counted, at the same seconds: a case of the table traced alone (the
/// quick suite's motor ramp, after the paper's 3-hour training).
#[test]
fn a_kept_run_monitored_alone_raises_the_events_the_suite_counted() {
    let dir = Dir::new("evaluate-keep");
    let (out, kept) = (dir.path("eval"), dir.path("kept"));
    ok(&[
        "evaluate",
        "--quick",
        "--train-days",
        "0.125",
        "--only",
        "E2 motor",
        "--keep-runs",
        s(&kept),
        "--out",
        s(&out),
        "-q",
    ]);
    let text = std::fs::read_to_string(out.join("evaluation.json")).expect("evaluation.json");
    let ev: serde_json::Value = serde_json::from_str(&text).expect("evaluation.json is JSON");
    let counted: Vec<(f64, String)> = ev["cases"][0]["methods"][0]["events"]
        .as_array()
        .map_or(&[][..], Vec::as_slice)
        .iter()
        .map(|e| (e["time"].as_f64().expect("time"), e["level"].to_string()))
        .collect();
    let events = dir.path("events.jsonl");
    ok(&[
        "monitor",
        "--model",
        s(&kept.join("E2-model.json")),
        "--input",
        s(&kept.join("E2-motor-linear-S1.0.csv.zst")),
        "--out",
        s(&dir.path("trips.csv")),
        "--rows",
        "trip",
        "--events",
        s(&events),
        "-q",
    ]);
    let raised: Vec<(f64, String)> = std::fs::read_to_string(&events)
        .expect("events written")
        .lines()
        .map(|l| {
            let e: serde_json::Value = serde_json::from_str(l).expect("an event is JSON");
            (e["time"].as_f64().expect("time"), e["level"].to_string())
        })
        .collect();
    assert!(!counted.is_empty(), "the motor ramp is detected: {text}");
    assert_eq!(raised, counted);
}

#[test]
fn json_is_one_object_on_stdout_and_people_read_stderr() {
    let fx = fixture();
    let dir = Dir::new("json");
    let sim = dir.path("sim");
    let out = ok(&["simulate", "--out", s(&sim), "--days", "2.2", "--json"]);
    let j = out.json();
    assert_eq!(j["command"], "simulate");
    assert!(j["trips"].as_u64().expect("trips") > 100);
    assert!(
        !out.stderr.contains('\r'),
        "no progress into a pipe: {:?}",
        out.stderr
    );
    assert_eq!(
        out.stderr, "",
        "--json leaves no human line: {}",
        out.stderr
    );
    let aligned = dir.path("aligned.csv");
    let align = ok(&[
        "align",
        "--input",
        s(&fx.raw),
        "--out",
        s(&aligned),
        "--json",
    ]);
    let j = align.json();
    assert_eq!(j["input"]["layout"], "raw");
    assert!(
        j["input"]["samples"].as_u64().expect("samples") > 43_000,
        "{j}"
    );
    let fit = &fx.fit_json;
    assert_eq!(fit["command"], "fit");
    assert_eq!(fit["step_s"], 1.0);
    assert!(fit["parameters"]["kd"]["value"].as_f64().expect("kd") > 0.0);
    let sim_summary = ok(&["simulate", "--out", s(&sim), "--days", "0.2"]);
    assert!(sim_summary.stdout.is_empty(), "summaries go to stderr");
    assert!(
        sim_summary.stderr.starts_with("simulated 0.2 days"),
        "{}",
        sim_summary.stderr
    );
    assert!(
        !fx.fit_stderr.contains('\r'),
        "fit progress stays off a pipe"
    );
}

#[test]
fn enumerated_flags_are_checked_choices() {
    let dir = Dir::new("choices");
    for (flag, bad, listed) in [
        ("--scenario", "wear", "healthy, motor, brake, friction"),
        ("--ramp", "sudden", "step, linear, exponential"),
        ("--sensor-fault", "stuck", "none, load-drift, stuck-speed"),
        ("--doors", "squeaky", "ideal, field, slowing"),
        ("--outage", "flood", "none, out-of-service, stuck"),
    ] {
        let out = run(&["simulate", "--out", s(&dir.path("x")), flag, bad]);
        assert_eq!(out.code, 2, "{flag} {bad}: {}", out.stderr);
        assert!(out.stderr.contains(listed), "{}", out.stderr);
    }
    assert!(!dir.path("x").exists());
}

#[test]
fn another_step_than_the_models_is_refused_naming_both() {
    let fx = fixture();
    let dir = Dir::new("step");
    let out = dir.path("risk.csv");
    let base = [
        "monitor",
        "--model",
        s(&fx.model),
        "--out",
        s(&out),
        "--input",
    ];
    fails(
        &[&base[..], &[s(&fx.raw), "--step", "2"]].concat(),
        "--step 2 s differs from the model's step of 1 s",
    );
    let coarse = dir.path("aligned2.csv");
    ok(&[
        "align",
        "--input",
        s(&fx.raw),
        "--out",
        s(&coarse),
        "--step",
        "2",
    ]);
    fails(
        &[&base[..], &[s(&coarse)]].concat(),
        "aligned at a step of 2 s, the model's step is 1 s",
    );
    assert!(!out.exists(), "a refused run writes nothing");
    fails(
        &[
            "report",
            "--model",
            s(&fx.model),
            "--input",
            s(&coarse),
            "--out",
            s(&dir.path("r")),
        ],
        "the model's step is 1 s",
    );
    // A model written before the step was kept: accepted, with a note.
    let mut old: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fx.model).expect("model")).expect("JSON");
    old.as_object_mut().expect("an object").remove("step_s");
    let old_model = dir.file("old.json", old.to_string().as_bytes());
    let run = ok(&[
        "monitor",
        "--model",
        s(&old_model),
        "--input",
        s(&fx.raw),
        "--out",
        s(&out),
    ]);
    assert!(
        run.stderr
            .starts_with("note: the model does not record the step"),
        "{}",
        run.stderr
    );
}

#[test]
fn a_short_fit_says_what_it_cannot_promise_and_keeps_the_alarm_budget() {
    let fx = fixture();
    let e = &fx.fit_stderr;
    assert!(e.contains("note: short training: "), "{e}");
    assert!(e.contains("of the 7 days the calibration needs"), "{e}");
    assert!(
        e.contains("cannot promise its alarm budget of 2 false advisories"),
        "{e}"
    );
    assert!(
        e.contains("alarm budget: at most 2 false advisories per elevator-year"),
        "{e}"
    );
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fx.model).expect("model")).expect("JSON");
    let cal = &model["risk"]["calibration"];
    assert_eq!(cal["target_false_advisories_per_year"], 2.0);
    assert_eq!(
        cal["years_simulated"], 5.0,
        "the bootstrap keeps its margin on the target"
    );
    assert_eq!(model["step_s"], 1.0);
    assert_eq!(
        fx.fit_json["calibration"]["target_false_advisories_per_year"],
        2.0
    );
    let dir = Dir::new("budget");
    fails(
        &[
            "fit",
            "--input",
            s(&fx.raw),
            "--elevator",
            s(&dir.file(
                "e.toml",
                b"rated_load_kg = 1000.0\nrated_speed_mps = 1.6\nfloors = 16\n",
            )),
            "--out",
            s(&dir.path("m.json")),
            "--false-advisories-per-year",
            "0",
        ],
        "false_advisories_per_year",
    );
}

#[test]
fn the_elevator_name_and_time_zone_reach_the_model_the_events_and_the_rows() {
    let fx = fixture();
    assert_eq!(fx.fit_json["elevator"]["name"], "Lift A");
    let dir = Dir::new("identity");
    let (rows, events) = (dir.path("risk.csv"), dir.path("events.jsonl"));
    ok(&[
        "monitor",
        "--model",
        s(&fx.model),
        "--input",
        s(&fx.fault),
        "--out",
        s(&rows),
        "--events",
        s(&events),
        "--time-format",
        "rfc3339",
    ]);
    let text = std::fs::read_to_string(&events).expect("events");
    let first: serde_json::Value =
        serde_json::from_str(text.lines().next().expect("an event")).expect("a JSON line");
    assert_eq!(first["elevator"], "Lift A");
    assert_eq!(first["elevator_id"], "B-7");
    assert!(first["time"].is_f64(), "the contract's numeric time stays");
    assert!(
        first["time_rfc3339"]
            .as_str()
            .expect("time_rfc3339")
            .ends_with("+01:00"),
        "{first}"
    );
    let rows = std::fs::read_to_string(&rows).expect("rows");
    let second = rows.lines().nth(1).expect("a row");
    // Day 2 from 07:00 at the start of the simulated clock, written at +01:00.
    assert!(second.starts_with("1970-01-02T08:00:01+01:00,"), "{second}");
}

#[test]
fn rows_trip_writes_one_row_per_trip_at_fixed_precision() {
    let fx = fixture();
    let dir = Dir::new("trips");
    let (trips, seconds) = (dir.path("trips.csv"), dir.path("risk.csv"));
    let base = [
        "monitor",
        "--model",
        s(&fx.model),
        "--input",
        s(&fx.fault),
        "--json",
        "--out",
    ];
    let summary = ok(&[&base[..], &[s(&trips), "--rows", "trip"]].concat()).json();
    ok(&[&base[..], &[s(&seconds)]].concat());
    let text = std::fs::read_to_string(&trips).expect("trip rows");
    let mut lines = text.lines();
    let header = lines.next().expect("a header");
    assert!(header.starts_with("start,end,direction,from_floor,to_floor,load_pct,samples,"));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(
        rows.len() as u64,
        summary["trips"].as_u64().expect("trips"),
        "one row per trip"
    );
    let columns = header.split(',').count();
    for row in &rows {
        let f: Vec<&str> = row.split(',').collect();
        assert_eq!(f.len(), columns, "{row}");
        assert!(f[2] == "1" || f[2] == "-1", "direction: {row}");
        assert!(
            f[7].is_empty() || f[7].split('.').nth(1).map(str::len) == Some(3),
            "{row}"
        );
    }
    assert!(
        rows.iter().any(|r| r.contains(",motor,")),
        "the fault's trips name their mode"
    );
    let per_second = std::fs::metadata(&seconds).expect("rows").len();
    assert!(
        text.len() as u64 * 20 < per_second,
        "{} vs {per_second} bytes",
        text.len()
    );
}

#[test]
fn a_reader_that_goes_away_ends_the_run_quietly_with_141() {
    // `liftwatch monitor … --out - | head -1`: the reader closes the pipe after one line; the
    // run stops with 128 + SIGPIPE as a shell reports for coreutils, saying nothing.
    let f = fixture();
    let mut child = Command::new(env!("CARGO_BIN_EXE_liftwatch"))
        .args([
            "monitor",
            "--model",
            s(&f.model),
            "--input",
            s(&f.fault),
            "--out",
            "-",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let mut stdout = child.stdout.take().expect("stdout is piped");
    let mut first = [0u8; 64];
    stdout
        .read_exact(&mut first)
        .expect("the header comes first");
    drop(stdout);
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .expect("stderr is piped")
        .read_to_string(&mut stderr)
        .expect("stderr is UTF-8");
    let status = child.wait().expect("the run ends");
    assert_eq!(status.code(), Some(141), "stderr: {stderr}");
    assert!(!stderr.contains("Broken pipe"), "stderr: {stderr}");
}

#[test]
fn every_machine_event_carries_the_forecast_of_its_mode() {
    let fx = fixture();
    let dir = Dir::new("event-forecast");
    let events = dir.path("events.jsonl");
    let args = ["monitor", "--model", s(&fx.model), "--input", s(&fx.fault)];
    ok(&[&args[..], &["--out", "/dev/null", "--events", s(&events)]].concat());
    let text = std::fs::read_to_string(&events).expect("events");
    let mut machine = 0;
    for line in text.lines() {
        let e: serde_json::Value = serde_json::from_str(line).expect("one JSON object a line");
        let mode = e["mode"].as_str().expect("mode");
        if !["motor", "brake", "friction"].contains(&mode) {
            assert!(e.get("forecast").is_none(), "{line}");
            continue;
        }
        machine += 1;
        let fc = &e["forecast"];
        assert_eq!(fc["mode"], mode, "{line}");
        let names: Vec<&str> = fc["crossings"]
            .as_array()
            .expect("crossings")
            .iter()
            .map(|c| c["name"].as_str().expect("name"))
            .collect();
        assert_eq!(names, ["advisory level", "alarm level", "physical limit"]);
        // An event raised at advisory or above has reached the advisory level.
        if e["level"] != "normal" {
            let first = &fc["crossings"][0]["when"]["status"];
            assert_eq!(first, "reached", "{line}");
        }
    }
    assert!(
        machine > 0,
        "the motor fault raises a machine event: {text}"
    );
}

#[test]
fn simulate_writes_its_outage_and_doors_into_the_truth() {
    let dir = Dir::new("outage-truth");
    let out = dir.path("sim");
    ok(&[
        "simulate",
        "--out",
        s(&out),
        "--days",
        "1",
        "--seed",
        "3",
        "--doors",
        "field",
        "--outage",
        "stuck",
        "--onset-days",
        "0.42",
        "--quiet",
    ]);
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["doors"]["kind"], "field");
    let o = &truth["outages"][0];
    assert_eq!(o["kind"], "stuck_between_floors");
    let (start, end) = (o["start_s"].as_f64().unwrap(), o["end_s"].as_f64().unwrap());
    assert!(
        start >= 0.42 * DAY_S && (end - start - 1800.0).abs() < 1e-6,
        "{o}"
    );
    assert!(o["position"]
        .as_str()
        .unwrap()
        .starts_with("between landings"));
    // The default run keeps its old truth: no doors, no outages.
    let plain = dir.path("plain");
    ok(&["simulate", "--out", s(&plain), "--days", "0.2", "--quiet"]);
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(plain.join("truth.json")).unwrap()).unwrap();
    assert!(truth.get("doors").is_none() && truth.get("outages").is_none());
}
