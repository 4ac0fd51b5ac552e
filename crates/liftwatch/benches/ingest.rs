//! Hot path of stages 1-2: raw `time,signal,value` rows streamed through ingest and
//! alignment into a sink that only counts. Prints raw rows/s (median of 3 runs) and the
//! peak resident memory, for a file and for one twice as long: alignment streams, so the
//! peak must not grow with the file.
//!
//! Run with `cargo bench -p liftwatch --bench ingest` (release profile). The logs are
//! written to a temporary directory and removed at the end.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use liftwatch::align::{align_file, AlignConfig, SampleSink};
use liftwatch::rng::Rng;
use liftwatch::{Result, Sample};

/// Counts samples and folds a value so the work cannot be optimised away.
#[derive(Default)]
struct Count {
    samples: u64,
    checksum: f64,
}

impl SampleSink for Count {
    type Error = liftwatch::Error;

    fn start(&mut self, _has_current: bool) -> Result<()> {
        *self = Count::default();
        Ok(())
    }

    fn push(&mut self, s: &Sample) -> Result<()> {
        self.samples += 1;
        if s.speed.is_finite() {
            self.checksum += s.speed;
        }
        Ok(())
    }
}

/// Writes a raw log of `rows` rows: six signals at ~1 Hz, each with its own phase and
/// ±50 ms jitter, trips every 40 s; mild disorder: in each block of 60 rows (10 s) two
/// random pairs of rows are swapped. `rfc3339` writes times as `...T..:..:..mmmZ`;
/// `late` moves the first 10 s to the end of the file, which forces the in-memory sort.
fn write_log(path: &Path, rows: u64, rfc3339: bool, late: bool, seed: u64) {
    let mut rng = Rng::new(seed);
    let mut out =
        BufWriter::with_capacity(1 << 20, File::create(path).expect("temp dir is writable"));
    writeln!(out, "time,signal,value").expect("write");
    let signals = ["speed", "direction", "voltage", "load", "door", "floor"];
    let t0 = 1_772_352_000.0; // 2026-03-01T08:00:00Z
    let mut write_row = |t: f64, i: usize, v: f64| {
        if rfc3339 {
            let ms = ((t - t0) * 1000.0).round() as u64;
            let (s, ms) = (8 * 3600 + ms / 1000, ms % 1000);
            let (d, s) = (s / 86_400, s % 86_400);
            let (h, m, s) = (s / 3600, (s / 60) % 60, s % 60);
            write!(out, "2026-03-{:02}T{h:02}:{m:02}:{s:02}.{ms:03}Z", 1 + d).expect("write");
        } else {
            write!(out, "{t:.3}").expect("write");
        }
        writeln!(out, ",{},{v:.3}", signals[i]).expect("write");
    };
    let mut block: Vec<(f64, usize, f64)> = Vec::with_capacity(60);
    let mut held_back = Vec::new();
    let mut written = 0u64;
    let mut second = 0u64;
    while written + (held_back.len() as u64) < rows {
        block.clear();
        for _ in 0..10 {
            for i in 0..signals.len() {
                let t = t0 + second as f64 + 0.15 * i as f64 + rng.uniform(-0.05, 0.05);
                let cycle = (second % 40) as f64;
                let moving = (10.0..30.0).contains(&cycle);
                let v = match i {
                    0 if moving => 1.6 * ((cycle - 10.0) / 20.0 * std::f64::consts::PI).sin(),
                    0 => 0.0,
                    1 => f64::from(u8::from(moving)),
                    2 => 20.0 + 180.0 * f64::from(u8::from(moving)) + rng.uniform(-2.0, 2.0),
                    3 => 35.0 + rng.uniform(-0.5, 0.5),
                    4 => f64::from(u8::from(cycle < 5.0)),
                    _ => (1 + (second / 40) % 20) as f64,
                };
                block.push((t, i, v));
            }
            second += 1;
        }
        for _ in 0..2 {
            let a = rng.below(block.len() as u64) as usize;
            let b = rng.below(block.len() as u64) as usize;
            block.swap(a, b);
        }
        if late && second == 10 {
            held_back = block.clone();
            continue;
        }
        for &(t, i, v) in &block {
            if written + (held_back.len() as u64) == rows {
                break;
            }
            write_row(t, i, v);
            written += 1;
        }
    }
    for &(t, i, v) in &held_back {
        write_row(t, i, v);
    }
    out.flush().expect("flush");
}

/// Peak resident set size of this process (kB), from /proc/self/status.
fn peak_rss_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Aligns `path` three times; returns (median rows/s, samples, peak RSS kB of this process).
fn measure(path: &Path, rows: u64, late: bool) -> (f64, u64, Option<u64>) {
    let cfg = AlignConfig::default();
    let mut rates = Vec::new();
    let mut samples = 0;
    for _ in 0..3 {
        let mut sink = Count::default();
        let start = Instant::now();
        let report = align_file(path, &cfg, &mut sink).expect("the generated log aligns");
        let secs = start.elapsed().as_secs_f64();
        assert_eq!(
            report.rows_used,
            rows,
            "every generated row is used: {:?}",
            report.warning()
        );
        assert_eq!(
            report.full_sort, late,
            "only the late tail forces the full sort"
        );
        assert!(sink.checksum > 0.0);
        samples = sink.samples;
        rates.push(rows as f64 / secs);
    }
    rates.sort_by(f64::total_cmp);
    (rates[1], samples, peak_rss_kb())
}

/// Measures in a fresh child process (this binary with `--measure FILE ROWS`), so that the
/// peak RSS is that of ingest and alignment alone, not of writing the log.
fn measure_in_child(path: &Path, rows: u64, late: bool) -> String {
    let exe = std::env::current_exe().expect("the bench knows its binary");
    let out = std::process::Command::new(exe)
        .arg("--measure")
        .arg(path)
        .arg(rows.to_string())
        .arg(if late { "late" } else { "streamed" })
        .output()
        .expect("the bench can run itself");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let [_, flag, path, rows, mode] = args.as_slice() {
        if flag == "--measure" {
            let rows: u64 = rows.parse().expect("rows is a number");
            let (rate, samples, peak) = measure(Path::new(path), rows, mode == "late");
            let peak = peak.map_or("n/a".to_string(), |kb| {
                format!("{:.1} MB", kb as f64 / 1024.0)
            });
            println!(
                "{samples} samples: {:.2} M rows/s (median of 3), peak RSS {peak}",
                rate / 1e6
            );
            return;
        }
    }
    let dir: PathBuf =
        std::env::temp_dir().join(format!("liftwatch-bench-ingest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir is writable");
    let rows: u64 = std::env::var("LIFTWATCH_BENCH_ROWS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    println!("ingest+align, default AlignConfig (step 1 s, gap 5 s, reorder window 600 s), 1 core");
    for (label, n, rfc, late) in [
        ("numeric", rows, false, false),
        ("numeric x2", 2 * rows, false, false),
        ("rfc3339", rows / 10, true, false),
        ("late tail", rows / 10, false, true),
        ("late tail x2", rows / 5, false, true),
    ] {
        let path = dir.join(format!("raw-{n}-{rfc}-{late}.csv"));
        write_log(&path, n, rfc, late, 1);
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        let result = measure_in_child(&path, n, late);
        println!(
            "{label:>12}: {n:>9} rows ({:.0} MB), {result}",
            bytes as f64 / 1e6
        );
        let _ = std::fs::remove_file(&path);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
