//! The crash test: `monitor` killed with SIGKILL at random instants, and aborted at each commit
//! instant, over a log cut in chunks; each chunk retried until a run finishes. The outputs and
//! the final state must equal, byte for byte, those of runs never interrupted.

use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::{command, finish, fixture, model_json, s, temps, write_json, Dir, N_CHUNKS};

/// Kills that must hit a running `monitor` across the kill test.
const MIN_KILLS: usize = 200;

/// The values of `LIFTWATCH_FAULT`: the process aborts at that commit instant.
const FAULTS: [&str; 3] = ["after-rows", "after-events", "before-state"];

/// Signal numbers on Linux (no libc here): SIGKILL from `Child::kill`, SIGABRT from `abort`.
const SIGKILL: i32 = 9;
/// See [`SIGKILL`].
const SIGABRT: i32 = 6;

/// splitmix64: the seeded stream of kill delays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// How one run of `monitor` ended.
#[derive(Debug, PartialEq)]
enum Outcome {
    /// Exit 0: everything committed.
    Done,
    /// Refused because the state covers the input: an earlier, killed run had committed it all.
    Covered,
    /// Killed by SIGKILL while running.
    Killed,
    /// Aborted at a fault point.
    Aborted,
}

/// The outputs of chunk `i` in `dir`, and the arguments that watch it.
fn monitor_args(model: &Path, chunk: &Path, dir: &Path, i: usize) -> Vec<String> {
    let out = dir.join(format!("out_{i}.csv"));
    let events = dir.join(format!("ev_{i}.jsonl"));
    let state = dir.join("state.json");
    [
        "monitor",
        "--model",
        s(model),
        "--input",
        s(chunk),
        "--out",
        s(&out),
        "--events",
        s(&events),
        "--state",
        s(&state),
    ]
    .map(str::to_string)
    .to_vec()
}

/// Runs `monitor` once, killed after `kill_after` if given.
fn attempt(args: &[String], env: &[(&str, &str)], kill_after: Option<Duration>) -> Outcome {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let mut child = command(&args, env).spawn().expect("the binary runs");
    if let Some(delay) = kill_after {
        std::thread::sleep(delay);
        // An already exited child is not reaped yet: the kill then changes nothing.
        let _ = child.kill();
    }
    let run = finish(child, &format!("{args:?}"));
    assert!(!run.stderr.contains("panicked"), "{}", run.stderr);
    match run.status.signal() {
        Some(SIGKILL) => Outcome::Killed,
        Some(SIGABRT) => Outcome::Aborted,
        Some(other) => panic!("monitor died of signal {other}: {}", run.stderr),
        None if run.status.success() => Outcome::Done,
        None if run.stderr.contains("--skip-covered") => Outcome::Covered,
        None => panic!("monitor failed: {}", run.stderr),
    }
}

/// Asserts that `dir` holds exactly the reference's bytes and no temporary file.
fn assert_same_as_reference(dir: &Path, reference: &Path, what: &str) {
    for i in 0..N_CHUNKS {
        for name in [format!("out_{i}.csv"), format!("ev_{i}.jsonl")] {
            let got = std::fs::read(dir.join(&name)).expect("output written");
            let want = std::fs::read(reference.join(&name)).expect("reference written");
            assert!(got == want, "{what}: {name} differs from the reference");
        }
    }
    let got = std::fs::read(dir.join("state.json")).expect("state written");
    let want = std::fs::read(reference.join("state.json")).expect("reference state");
    assert!(
        got == want,
        "{what}: final state differs from the reference"
    );
    assert_eq!(
        temps(dir),
        Vec::<PathBuf>::new(),
        "{what}: temporary files left"
    );
}

/// Most attempts on one chunk before the test stops killing (the delays are random, a long
/// unlucky streak only costs time).
const MAX_KILLS_PER_CHUNK: usize = 40;

/// Kills counted by what they found committed.
#[derive(Debug, Default)]
struct Kills {
    /// Kills that hit a running process.
    total: usize,
    /// Of these, kills after which the chunk's rows were in place but not yet the state.
    rows_not_state: usize,
    /// Kills after which the state had moved: the run had committed everything.
    everything: usize,
}

/// Watches every chunk into `dir`, each run killed at a random instant of `durations[i]`
/// (a quarter beyond it, so some runs finish) and retried until one finishes.
fn kill_round(
    model: &Path,
    chunks: &[PathBuf],
    dir: &Path,
    durations: &[Duration],
    rng: &mut Rng,
    kills: &mut Kills,
) {
    for (i, chunk) in chunks.iter().enumerate() {
        let args = monitor_args(model, chunk, dir, i);
        let state_before = std::fs::read(dir.join("state.json")).ok();
        let mut killed = false;
        let mut done = false;
        for _ in 0..MAX_KILLS_PER_CHUNK {
            let delay = durations[i].mul_f64(1.25 * rng.unit());
            match attempt(&args, &[], Some(delay)) {
                Outcome::Killed => {
                    kills.total += 1;
                    killed = true;
                    if std::fs::read(dir.join("state.json")).ok() != state_before {
                        kills.everything += 1;
                    } else if dir.join(format!("out_{i}.csv")).exists() {
                        kills.rows_not_state += 1;
                    }
                }
                Outcome::Done => {
                    done = true;
                    break;
                }
                Outcome::Covered if killed => {
                    done = true;
                    break;
                }
                other => panic!("chunk {i}: unexpected {other:?} before any kill"),
            }
        }
        if !done {
            let last = attempt(&args, &[], None);
            assert!(
                last == Outcome::Done || (killed && last == Outcome::Covered),
                "chunk {i}: {last:?}"
            );
        }
    }
}

/// Watches every chunk into `dir`, each first aborted at every fault point in turn, checking
/// what each abort left, then retried; returns how long each retry ran.
fn fault_round(model: &Path, chunks: &[PathBuf], dir: &Path, reference: &Path) -> Vec<Duration> {
    let mut durations = Vec::new();
    for (i, chunk) in chunks.iter().enumerate() {
        let args = monitor_args(model, chunk, dir, i);
        let state_before = std::fs::read(dir.join("state.json")).ok();
        for fault in FAULTS {
            let outcome = attempt(&args, &[("LIFTWATCH_FAULT", fault)], None);
            assert_eq!(outcome, Outcome::Aborted, "chunk {i}, {fault}");
            let same = |name: &str| {
                std::fs::read(dir.join(name)).ok() == std::fs::read(reference.join(name)).ok()
            };
            assert!(same(&format!("out_{i}.csv")), "chunk {i}, {fault}: rows");
            if fault != "after-rows" {
                assert!(same(&format!("ev_{i}.jsonl")), "chunk {i}, {fault}: events");
            }
            let state = std::fs::read(dir.join("state.json")).ok();
            assert!(state == state_before, "chunk {i}, {fault}: state moved");
        }
        let start = Instant::now();
        assert_eq!(attempt(&args, &[], None), Outcome::Done, "chunk {i}");
        durations.push(start.elapsed());
    }
    durations
}

/// The crash test: `monitor` killed with SIGKILL at random instants (and aborted at each commit
/// instant) over a log cut in chunks, each retried until it finishes, gives byte for byte the
/// outputs and final state of runs that were never interrupted.
#[test]
fn killed_runs_retried_give_the_same_bytes_as_clean_runs() {
    let fx = fixture();
    let dir = Dir::new("kill");
    // Lowered risk thresholds and sequential thresholds (the machine's level follows both),
    // so that the healthy log changes level and the events file has lines to lose whatever
    // the door check makes of this log.
    let mut m = model_json();
    m["risk"]["advisory"] = 1.0.into();
    m["risk"]["alarm"] = 3.0.into();
    m["risk"]["advisory_modes"] = serde_json::json!([1.0, 1.0, 1.0]);
    m["risk"]["sequential"]["h"] = serde_json::json!([[2.0, 2.0], [2.0, 2.0], [2.0, 2.0]]);
    let model = dir.path("model.json");
    write_json(&model, &m);

    let reference = dir.path("ref");
    std::fs::create_dir(&reference).expect("ref dir");
    let mut durations = Vec::new();
    for (i, chunk) in fx.chunks.iter().enumerate() {
        let start = Instant::now();
        assert_eq!(
            attempt(&monitor_args(&model, chunk, &reference, i), &[], None),
            Outcome::Done
        );
        durations.push(start.elapsed());
    }
    let events: usize = (0..N_CHUNKS)
        .map(|i| {
            let text = std::fs::read_to_string(reference.join(format!("ev_{i}.jsonl")));
            text.expect("reference events").lines().count()
        })
        .sum();
    assert!(
        events > 0,
        "the reference has no events: the test would prove less"
    );

    let faults = dir.path("faults");
    std::fs::create_dir(&faults).expect("round dir");
    // The kills aim within the warm runs' durations: the reference runs came first, from
    // cold caches, and ran longer, and kills drawn from them missed the shorter runs they
    // were aimed at often enough to leave the count short on a loaded machine.
    let warm = fault_round(&model, &fx.chunks, &faults, &reference);
    for (d, w) in durations.iter_mut().zip(warm) {
        *d = (*d).min(w);
    }
    assert_same_as_reference(&faults, &reference, "fault points");
    std::fs::remove_dir_all(&faults).expect("round dir");

    let mut rng = Rng(0x5afe_f11e);
    let mut kills = Kills::default();
    let mut rounds = 0;
    let started = Instant::now();
    while kills.total < MIN_KILLS && rounds < 30 {
        let round = dir.path(&format!("round_{rounds}"));
        std::fs::create_dir(&round).expect("round dir");
        kill_round(&model, &fx.chunks, &round, &durations, &mut rng, &mut kills);
        assert_same_as_reference(&round, &reference, &format!("kill round {rounds}"));
        std::fs::remove_dir_all(&round).expect("round dir");
        rounds += 1;
    }
    eprintln!(
        "kill test: {} kills of a running monitor ({} found the chunk's rows in place but not the state, {} found everything committed) in {rounds} rounds, {:.1} s, runs of {durations:?}",
        kills.total,
        kills.rows_not_state,
        kills.everything,
        started.elapsed().as_secs_f64()
    );
    assert!(
        kills.total >= MIN_KILLS,
        "only {kills:?} hit a running process"
    );
}
