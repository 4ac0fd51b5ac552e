//! The paper's own training size through the real binary (paper, Sec. 5: 3 h at 1 Hz, about
//! 80 trips and 950 moving samples): `fit` accepts it, says which limits it had to
//! extrapolate, `monitor` watches the following day with both methods, and `status` reads
//! the saved state: normal, with the short training among its caveats.

use liftwatch::sample::HOUR_S;
use std::path::Path;
use std::process::Command;

/// Seconds of training at the start of the simulated log: the paper's 3 hours.
const TRAIN_S: f64 = 3.0 * HOUR_S;

mod common;
use common::Dir;

/// Runs the binary to success and returns its stdout and stderr together.
fn run(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_liftwatch"))
        .args(args)
        .output()
        .expect("the binary runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "liftwatch {args:?} failed:\n{text}");
    text
}

fn s(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

/// Splits a raw `time,signal,value` log at `start + TRAIN_S` into two raw logs.
fn split(raw: &Path, train: &Path, watch: &Path) {
    let text = std::fs::read_to_string(raw).expect("simulated log is readable");
    let mut lines = text.lines();
    let header = lines.next().expect("a header");
    let (mut a, mut b) = (format!("{header}\n"), format!("{header}\n"));
    let mut start = None;
    for line in lines {
        let t: f64 = line
            .split(',')
            .next()
            .and_then(|t| t.parse().ok())
            .expect("a time");
        let t0 = *start.get_or_insert(t);
        let out = if t < t0 + TRAIN_S { &mut a } else { &mut b };
        out.push_str(line);
        out.push('\n');
    }
    std::fs::write(train, a).expect("writable");
    std::fs::write(watch, b).expect("writable");
}

/// The number after "in" in the fit's "N moving samples in M trips" line.
fn fit_counts(text: &str) -> (u32, u32) {
    let line = text
        .lines()
        .find(|l| l.contains("moving samples in"))
        .expect("the fit reports its data");
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = |w: &str| {
        let k = words.iter().position(|x| *x == w).expect("word present");
        words[k - 1].parse().expect("a count")
    };
    (at("moving"), at("trips,"))
}

#[test]
fn three_hours_and_eighty_trips_fit_and_monitor() {
    let dir = Dir::new("paper-setting");
    let sim = dir.0.join("sim");
    // A small, light-traffic car in the morning: about 80 trips of 12 moving seconds in 3 h.
    run(&[
        "simulate",
        "--out",
        s(&sim),
        "--days",
        "1.125",
        "--start-hour",
        "8",
        "--seed",
        "5",
        "--traffic",
        "0.36",
        "--floors",
        "8",
        "--rated-speed",
        "1.6",
        "--rated-load",
        "630",
    ]);
    let (train, watch) = (dir.0.join("train.csv"), dir.0.join("watch.csv"));
    split(&sim.join("raw.csv"), &train, &watch);
    let model = dir.0.join("model.json");
    let fit = run(&[
        "fit",
        "--input",
        s(&train),
        "--elevator",
        s(&sim.join("elevator.toml")),
        "--out",
        s(&model),
    ]);
    let (moving, trips) = fit_counts(&fit);
    assert!(
        (600..1000).contains(&moving) && (60..100).contains(&trips),
        "not the paper's size: {moving} moving samples in {trips} trips"
    );
    assert!(
        fit.contains("extrapolated from the 98."),
        "the fit must say its baseline limits are extrapolated:\n{fit}"
    );
    // Two draws of the network, the one that ended lower kept; the model file lists both.
    assert!(
        fit.contains("network: the lowest loss of 2 draws kept"),
        "the fit says which draw it kept:\n{fit}"
    );
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&model).expect("model written")).expect("JSON");
    let draws = m["fit"]["draws"].as_array().expect("fit.draws");
    let kept: Vec<&serde_json::Value> = draws.iter().filter(|d| d["kept"] == true).collect();
    let loss = |v: &serde_json::Value| -> f64 {
        v.as_str()
            .map_or_else(|| v.as_f64(), |t| t.parse().ok())
            .expect("a loss")
    };
    assert!(draws.len() == 2 && kept.len() == 1, "{draws:?}");
    assert!(
        draws
            .iter()
            .all(|d| loss(&d["loss"]) >= loss(&kept[0]["loss"]))
            && loss(&kept[0]["loss"]) == loss(&m["fit"]["loss_final"]),
        "{draws:?}"
    );
    let state = dir.0.join("state.json");
    for method in ["pinn", "threshold"] {
        let (rows, events) = (
            dir.0.join(format!("{method}.csv")),
            dir.0.join(format!("{method}.jsonl")),
        );
        let mut args = vec![
            "monitor",
            "--model",
            s(&model),
            "--input",
            s(&watch),
            "--out",
            s(&rows),
            "--events",
            s(&events),
            "--method",
            method,
        ];
        if method == "pinn" {
            args.extend(["--state", s(&state)]);
        }
        let text = run(&args);
        let n = std::fs::read_to_string(&rows)
            .expect("rows written")
            .lines()
            .count();
        assert!(n > 80_000, "{method}: only {n} rows for a day:\n{text}");
        if method == "pinn" {
            // A healthy day after a 3-hour training: no advisory.
            let ev = std::fs::read_to_string(&events).expect("events written");
            assert!(
                ev.trim().is_empty(),
                "false advisory on a healthy day:\n{ev}"
            );
        }
    }
    // The verdict of the saved state: normal, and the model's own caveat of its 3 hours.
    let text = run(&["status", "--model", s(&model), "--state", s(&state)]);
    let first = text.lines().next().unwrap_or_default();
    assert!(first.starts_with("NORMAL (as of "), "{text}");
    assert!(
        text.contains("Forecast: ") && text.contains("Evidence: "),
        "{text}"
    );
    assert!(
        text.contains("learnt from 3 h of healthy data"),
        "the short training is a caveat:\n{text}"
    );
    let json = run(&[
        "status",
        "--model",
        s(&model),
        "--state",
        s(&state),
        "--json",
    ]);
    assert_eq!(json.trim().lines().count(), 1, "one JSON object: {json}");
    let v: serde_json::Value = serde_json::from_str(json.trim()).expect("status --json is JSON");
    assert_eq!(v["level"], "normal");
    assert_eq!(v["forecast"]["modes"].as_array().map(Vec::len), Some(3));
    assert!(v["caveats"].as_array().is_some_and(|c| !c.is_empty()));
    // A state of another model is refused in one line, naming both.
    let mut foreign: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&state).expect("state written")).expect("JSON");
    foreign["model_id"] = "0123456789abcdef".into();
    let other = dir.0.join("other-state.json");
    std::fs::write(&other, foreign.to_string()).expect("writable");
    let out = Command::new(env!("CARGO_BIN_EXE_liftwatch"))
        .args(["status", "--model", s(&model), "--state", s(&other)])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.lines().count() == 1, "{err}");
    assert!(err.contains("belongs to model 0123456789abcdef"), "{err}");
}
