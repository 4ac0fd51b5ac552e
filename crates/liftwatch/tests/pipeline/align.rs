//! Stages 1-2 end to end: a raw log built in code, then shuffled, duplicated and corrupted,
//! must align to exactly the series of the clean log, with every good row used and every
//! bad row counted.

use std::path::Path;

use liftwatch::align::{read_series, write_aligned_file, AlignConfig};
use liftwatch::rng::Rng;
use liftwatch::Sample;

use crate::Dir;

/// One raw row: time, signal, value (already formatted, so duplicates are byte-equal).
type Row = (f64, &'static str, String);

/// A clean raw log: six signals at ~1 Hz, each with its own phase and jitter, a voltage
/// dropout of a minute, trips every 40 s.
fn clean_log(seconds: u32, rng: &mut Rng) -> Vec<Row> {
    let signals = ["speed", "direction", "voltage", "load", "door", "floor"];
    let mut rows = Vec::new();
    for (i, sig) in signals.into_iter().enumerate() {
        let phase = 0.13 * i as f64;
        for k in 0..seconds {
            let t = 1_000.0 + f64::from(k) + phase + rng.uniform(-0.04, 0.04);
            if sig == "voltage" && (300.0..360.0).contains(&(t - 1_000.0)) {
                continue;
            }
            let cycle = (t - 1_000.0) % 40.0;
            let moving = (10.0..30.0).contains(&cycle);
            let v = match sig {
                "speed" if moving => 1.5 * ((cycle - 10.0) / 20.0 * std::f64::consts::PI).sin(),
                "speed" => 0.0,
                "direction" => f64::from(u8::from(moving)),
                "voltage" => 20.0 + 200.0 * f64::from(u8::from(moving)) + rng.uniform(-1.0, 1.0),
                "load" => 30.0 + rng.uniform(-0.5, 0.5),
                "door" => f64::from(u8::from(cycle < 5.0)),
                _ => (1.0 + ((t - 1_000.0) / 40.0).floor()) % 7.0,
            };
            rows.push((t, sig, format!("{v:.4}")));
        }
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    rows
}

fn write_rows(path: &Path, rows: &[Row], garbage: &[String]) {
    let mut text = String::from("time,signal,value\n");
    for (t, sig, v) in rows {
        text.push_str(&format!("{t:.6},{sig},{v}\n"));
    }
    for g in garbage {
        text.push_str(g);
        text.push('\n');
    }
    std::fs::write(path, text).expect("temp dir is writable");
}

/// Inserts `garbage` lines at random places of a written log, returning the new text.
fn scatter(text: &str, garbage: &[String], rng: &mut Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    for g in garbage {
        // After the first data row, which fixes the time form of the file.
        let at = 2 + rng.below(lines.len() as u64 - 2) as usize;
        lines.insert(at, g.clone());
    }
    lines.join("\n") + "\n"
}

/// Equal, or both missing; a value repeated three times averages to itself within rounding.
fn same(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-12 * (1.0 + a.abs())
}

fn assert_same_series(a: &[Sample], b: &[Sample]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        let fields = |s: &Sample| {
            [
                s.time,
                s.speed,
                s.direction,
                s.voltage,
                s.load,
                s.door,
                s.floor,
                s.current,
            ]
        };
        for (u, v) in fields(x).into_iter().zip(fields(y)) {
            assert!(same(u, v), "{x:?}\n!=\n{y:?}");
        }
    }
}

/// Runs the messy-log check with a given reorder window and disorder.
fn messy_log_aligns_like_clean(window_s: f64, late_rows: usize, name: &str) {
    let dir = Dir::new(name);
    let mut rng = Rng::new(42);
    let clean = clean_log(900, &mut rng);
    let clean_path = dir.0.join("clean.csv");
    write_rows(&clean_path, &clean, &[]);
    let cfg = AlignConfig::default()
        .with_reorder_window(window_s)
        .expect("valid window");
    let (expected, clean_report) = read_series(&clean_path, &cfg).expect("clean log aligns");
    assert_eq!(clean_report.rows_used, clean.len() as u64);
    assert!(expected.len() >= 899);
    // The dropout shows as a gap, not as bridged values.
    assert!(expected
        .samples
        .iter()
        .any(|s| s.voltage.is_nan() && s.speed.is_finite()));

    // Mild disorder: every row moved by up to 20 s; `late_rows` rows moved to the end.
    let mut messy: Vec<(f64, Row)> = clean
        .iter()
        .map(|r| (r.0 + rng.uniform(-20.0, 20.0), r.clone()))
        .collect();
    messy.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut rows: Vec<Row> = messy.into_iter().map(|(_, r)| r).collect();
    for _ in 0..late_rows {
        let i = rng.below(rows.len() as u64 / 2) as usize;
        let r = rows.remove(i);
        rows.push(r);
    }
    // Exact duplicates of 50 rows: averaged (continuous) or last kept (discrete), same value.
    for _ in 0..50 {
        let i = rng.below(rows.len() as u64) as usize;
        let r = rows[i].clone();
        rows.insert(i + 1, r);
    }
    let garbage: Vec<String> = vec![
        "1002.5,speed,abc".into(),
        "not-a-time,load,3".into(),
        "1003.5,voltage".into(),
        "1e300,speed,1".into(),
        "inf,door,0".into(),
        "1004.5,floor,2,extra".into(),
        "2026-03-01T00:00:00Z,speed,1".into(),
        "1005.5,speed,1.0.0".into(),
    ];
    let unknown = [
        "1001.1,temperature,21",
        "1001.2,temperature,22",
        "1001.3,humidity,40",
    ];
    let missing = ["1006.5,speed,", "1007.5,load,NaN", "1008.5,door,nan"];
    let messy_path = dir.0.join("messy.csv");
    write_rows(&messy_path, &rows, &[]);
    let extra: Vec<String> = garbage
        .iter()
        .cloned()
        .chain(unknown.into_iter().chain(missing).map(String::from))
        .collect();
    let text = std::fs::read_to_string(&messy_path).expect("just written");
    std::fs::write(&messy_path, scatter(&text, &extra, &mut rng)).expect("temp dir is writable");

    let (got, report) = read_series(&messy_path, &cfg).expect("messy log aligns");
    assert_eq!(
        report.rows_used,
        rows.len() as u64,
        "every good row is used"
    );
    assert_eq!(
        report.bad_rows,
        garbage.len() as u64,
        "every bad row is counted"
    );
    assert_eq!(report.missing_values, missing.len() as u64);
    assert_eq!(report.unknown_signals.get("temperature"), Some(&2));
    assert_eq!(report.unknown_signals.get("humidity"), Some(&1));
    assert_eq!(report.rows_read, (rows.len() + extra.len()) as u64);
    assert!(report.duplicate_timestamps >= 50);
    assert!(report.rows_reordered > 0);
    assert_eq!(report.full_sort, late_rows > 0);
    assert!(report.warning().is_some());
    assert_same_series(&got.samples, &expected.samples);
}

#[test]
fn shuffled_duplicated_corrupted_log_aligns_like_the_clean_one() {
    messy_log_aligns_like_clean(600.0, 0, "window");
}

#[test]
fn rows_later_than_the_window_are_sorted_in_and_still_used() {
    messy_log_aligns_like_clean(30.0, 5, "late");
}

#[test]
fn aligned_file_reads_back_as_written() {
    let dir = Dir::new("roundtrip");
    let mut rng = Rng::new(7);
    let clean = clean_log(200, &mut rng);
    let raw = dir.0.join("raw.csv");
    write_rows(&raw, &clean, &[]);
    let (series, _) = read_series(&raw, &AlignConfig::default()).expect("aligns");
    let aligned = dir.0.join("aligned.csv");
    write_aligned_file(&aligned, &series.samples).expect("writes");
    let (back, report) = read_series(&aligned, &AlignConfig::default()).expect("reads back");
    assert_eq!(
        report.passes, 1,
        "an aligned file at the step passes through"
    );
    assert_eq!(back.len(), series.len());
    for (a, b) in back.samples.iter().zip(&series.samples) {
        let fields = |s: &Sample| [s.speed, s.direction, s.voltage, s.load, s.door, s.floor];
        assert_eq!(a.time, b.time);
        for (u, v) in fields(a).into_iter().zip(fields(b)) {
            // Written rounded to 1e-6.
            assert!(
                (u.is_nan() && v.is_nan()) || (u - v).abs() <= 5e-7,
                "{a:?} vs {b:?}"
            );
        }
    }
}

#[test]
fn messy_fixture_matches_its_golden_file() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let (series, report) =
        read_series(&data.join("raw_messy.csv"), &AlignConfig::default()).expect("fixture aligns");
    assert_eq!(
        report.bad_rows, 4,
        "garbage value, unreadable time, absurd time, truncated last line"
    );
    assert_eq!(report.unknown_rows(), 1);
    let mut actual = Vec::new();
    liftwatch::align::write_aligned(&mut actual, &series.samples).expect("writes to memory");
    let actual = String::from_utf8(actual).expect("CSV is UTF-8");
    let golden = data.join("aligned.expected.csv");
    if std::env::var_os("LIFTWATCH_BLESS").is_some() {
        std::fs::write(&golden, &actual).expect("fixture dir is writable");
    }
    let expected =
        std::fs::read_to_string(&golden).expect("golden file exists (LIFTWATCH_BLESS=1 writes it)");
    assert!(
        actual == expected,
        "aligned output differs from {}\nexpected:\n{expected}\nactual:\n{actual}",
        golden.display()
    );
}

/// The fit reads a file's samples in passes from a spill on disk (`fit` on the command line)
/// instead of holding them: the model must be the one the samples held in memory give.
#[test]
fn a_fit_of_a_files_spilled_samples_is_the_fit_of_the_samples_in_memory() {
    use liftwatch::align::read_spilled;
    use liftwatch::fit::fit;
    use liftwatch::model::TrainConfig;
    use liftwatch::sample::{pass, HOUR_S};
    use liftwatch::sim::{simulate, SimConfig};
    use liftwatch::Elevator;

    let dir = Dir::new("spilled-fit");
    let e = Elevator::new(800.0, 1.6, 12);
    let mut sim = SimConfig::new(e.clone(), 0.25, 41);
    sim.start_s = 7.0 * HOUR_S;
    let path = dir.0.join("aligned.csv");
    let samples = simulate(&sim)
        .expect("a valid simulation")
        .aligned()
        .samples;
    write_aligned_file(&path, &samples).unwrap();
    let cfg = AlignConfig::default();
    let (series, _) = read_series(&path, &cfg).unwrap();
    let (spilled, _) = read_spilled(&path, &cfg, &dir.0).unwrap();
    assert_eq!(spilled.len(), series.len() as u64);
    let read_back: Vec<Sample> = pass(&spilled, |s| s.collect()).unwrap();
    assert!(read_back
        .iter()
        .zip(&series.samples)
        .all(|(a, b)| format!("{a:?}") == format!("{b:?}")));
    let train = TrainConfig {
        log_every: 0,
        ..TrainConfig::default()
    };
    let in_memory = fit(&series, &e, &train, &mut |_| {}).expect("six hours fit");
    let from_disk = fit(&spilled, &e, &train, &mut |_| {}).expect("six hours fit");
    assert_eq!(from_disk.model, in_memory.model);
    assert_eq!(from_disk.trips, in_memory.trips);
}
