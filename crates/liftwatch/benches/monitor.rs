//! Hot path of stages 3 and 5-7: the whole per-sample monitor step ([`Monitor::push`]:
//! features, residuals with one network pass per moving sample, per-trip risk, levels,
//! sensor checks) on aligned samples held in memory. Prints samples/s (median of 3 runs)
//! for both methods (the paper's with an uncalibrated model and with one fitted and
//! calibrated on three other simulated days), the cost of the residual stage alone for moving and standstill
//! samples, the output rows' CSV formatting alone, and the size of a saved monitor state.
//!
//! Run with `cargo bench -p liftwatch --bench monitor` (release profile). The telemetry is
//! two simulated days of a 1000 kg, 1.75 m/s, 26-floor elevator (seed 1).
//!
//! With `MONITOR_BENCH_MODEL=model.json MONITOR_BENCH_INPUT=aligned.csv` it times the step of
//! that model on that file instead (read into memory first) and prints two lines: the step on
//! the whole file (what `bench/compare.py --infer` sets beside PyTorch's batched inference on
//! the same samples), then the step on the file's samples at rest alone.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use liftwatch::align::{read_series, AlignConfig};
use liftwatch::features::{FeatureConfig, FeatureTracker};
use liftwatch::fit::FittedModel;
use liftwatch::model::{HybridModel, PhysParams, ResidualNet, ResidualScales, TrainConfig};
use liftwatch::monitor::{Method, Monitor, MonitorRow, RowWriter};
use liftwatch::residual::PredictionCache;
use liftwatch::rng::Rng;
use liftwatch::sim::{simulate, SimConfig};
use liftwatch::{Elevator, Sample};

/// A model with prior-centre physics and random network weights: the cost of a step does
/// not depend on how well the model fits.
fn model(elevator: &Elevator) -> FittedModel {
    let mut net = ResidualNet::new(1, [elevator.rated_speed_mps, 1.0, 1.0], [5.0, 500.0]);
    let mut rng = Rng::new(2);
    for w in &mut net.weights {
        *w = rng.uniform(-0.5, 0.5);
    }
    let hybrid = HybridModel {
        parameters: PhysParams::prior_centre(elevator),
        net,
        scales: ResidualScales {
            sigma_u_v: 2.5,
            sigma_f_n: 400.0,
        },
        elevator: elevator.clone(),
    };
    FittedModel::uncalibrated(hybrid, FeatureConfig::for_elevator(elevator))
}

/// Median of three timed runs of `f`, in seconds.
fn median3(mut f: impl FnMut() -> f64) -> f64 {
    let mut t: Vec<f64> = (0..3).map(|_| f()).collect();
    t.sort_by(f64::total_cmp);
    t[1]
}

/// Seconds of the whole monitor step of `method` over `samples` (median of three runs), as
/// a fresh monitor runs it: every sample pushed into one reused row (the streaming path,
/// [`Monitor::push_into`]), the held rows finished.
fn step_secs(model: &FittedModel, method: Method, samples: &[Sample]) -> f64 {
    median3(|| {
        let start = Instant::now();
        let mut m = Monitor::new(model, method);
        let mut acc = 0.0;
        let mut row = MonitorRow::EMPTY;
        for x in samples {
            if m.push_into(x, &mut row) {
                acc += row.risk;
            }
        }
        black_box(acc);
        black_box(m.finish());
        start.elapsed().as_secs_f64()
    })
}

/// The step of a model file on an aligned file, for `bench/compare.py --infer`.
fn step_on_files(model: &str, input: &str) {
    let model = liftwatch::file::load(Path::new(model)).expect("MONITOR_BENCH_MODEL loads");
    // Aligned at the model's step, as `liftwatch monitor` aligns.
    let align = AlignConfig {
        step_s: model.step_s.unwrap_or(AlignConfig::default().step_s),
        ..AlignConfig::default()
    };
    let (series, _) = read_series(Path::new(input), &align).expect("MONITOR_BENCH_INPUT reads");
    let samples = series.samples;
    let secs = step_secs(&model, Method::Pinn, &samples);
    let n = samples.len() as f64;
    let moving = samples
        .iter()
        .filter(|x| x.speed.abs() > model.features.moving_threshold_mps)
        .count() as f64;
    println!(
        "monitor step on file: {:.2} M samples/s, {:.0} ns/sample ({} samples, {:.1} % moving)",
        n / secs / 1e6,
        secs / n * 1e9,
        samples.len(),
        100.0 * moving / n
    );
    // What a sample at rest costs of the step: the file's samples at rest alone, renumbered
    // onto one unbroken grid, so that the car stands through the whole run (door cycles, load
    // changes and the rest of a stop's life kept, the trips taken out).
    let step = align.step_s;
    let t0 = samples.first().map_or(0.0, |x| x.time);
    let rest: Vec<Sample> = samples
        .iter()
        .filter(|x| x.speed.abs() <= model.features.moving_threshold_mps)
        .enumerate()
        .map(|(i, x)| Sample {
            time: t0 + i as f64 * step,
            ..*x
        })
        .collect();
    let rest_ns = step_secs(&model, Method::Pinn, &rest) / rest.len().max(1) as f64 * 1e9;
    println!(
        "monitor step at rest alone: {rest_ns:.0} ns/sample ({} samples, {:.2} of the whole file's)",
        rest.len(),
        rest_ns / (secs / n * 1e9)
    );
}

fn main() {
    if let (Ok(model), Ok(input)) = (
        std::env::var("MONITOR_BENCH_MODEL"),
        std::env::var("MONITOR_BENCH_INPUT"),
    ) {
        step_on_files(&model, &input);
        return;
    }
    let elevator = Elevator::new(1000.0, 1.75, 26);
    let samples: Vec<Sample> = simulate(&SimConfig::new(elevator.clone(), 2.0, 1))
        .expect("a valid simulation")
        .aligned()
        .samples;
    let model = model(&elevator);
    let n = samples.len() as f64;

    // A fitted, calibrated model besides: its risk stage runs the sequential decision, the
    // isolation and the parked zero witness, which an uncalibrated model never reaches.
    let train = simulate(&SimConfig::new(elevator.clone(), 3.0, 7))
        .expect("a valid simulation")
        .aligned();
    let fitted = liftwatch::fit::fit(&train, &elevator, &TrainConfig::default(), &mut |_| {})
        .expect("three simulated days fit")
        .model;
    for (method, model, name) in [
        (Method::Pinn, &model, "Pinn"),
        (Method::Pinn, &fitted, "Pinn, fitted and calibrated model"),
        (Method::Threshold, &model, "Threshold"),
    ] {
        let secs = step_secs(model, method, &samples);
        println!(
            "monitor step ({name}): {:.1} M samples/s, {:.0} ns/sample ({} samples)",
            n / secs / 1e6,
            secs / n * 1e9,
            samples.len()
        );
    }

    // The feature stage alone, to tell its share from the residual and risk stages.
    let secs = median3(|| {
        let start = Instant::now();
        let mut t = FeatureTracker::new(model.features.clone());
        let mut acc = 0.0;
        for x in &samples {
            if let Some(r) = t.push(x) {
                acc += r.a;
            }
        }
        black_box(acc);
        start.elapsed().as_secs_f64()
    });
    println!(
        "feature tracker alone: {:.1} M samples/s, {:.0} ns/sample",
        n / secs / 1e6,
        secs / n * 1e9
    );

    // The residual stage alone, split by motion.
    let mut tracker = FeatureTracker::new(model.features.clone());
    let mut rows: Vec<_> = samples.iter().filter_map(|x| tracker.push(x)).collect();
    rows.extend(tracker.finish());
    let (moving, still): (Vec<_>, Vec<_>) = rows.into_iter().partition(|r| r.s != 0);
    for (name, rows) in [("moving", &moving), ("standstill", &still)] {
        let secs = median3(|| {
            let start = Instant::now();
            let mut cache = PredictionCache::default();
            let mut acc = 0.0;
            for r in rows.iter() {
                let e = cache.residuals(&model.hybrid, r).r_u;
                if e.is_finite() {
                    acc += e;
                }
            }
            black_box(acc);
            start.elapsed().as_secs_f64()
        });
        let k = rows.len() as f64;
        println!(
            "residuals, {name} samples ({:.1} %): {:.0} ns/sample",
            100.0 * k / n,
            secs / k * 1e9
        );
    }

    // The output rows as CSV (DATA.md §4), written into memory: the formatting alone.
    let mut m = Monitor::new(&model, Method::Pinn);
    let mut out_rows: Vec<_> = samples.iter().filter_map(|x| m.push(x)).collect();
    out_rows.extend(m.finish());
    let mut bytes = 0;
    let secs = median3(|| {
        let start = Instant::now();
        let mut w = RowWriter::new(Vec::with_capacity(200 << 20)).expect("a Vec takes a header");
        for r in &out_rows {
            w.write(r).expect("a Vec takes every row");
        }
        bytes = black_box(w.into_inner().expect("a Vec flushes")).len();
        start.elapsed().as_secs_f64()
    });
    let k = out_rows.len() as f64;
    println!(
        "rows written as CSV: {:.1} M rows/s, {:.0} ns/row, {:.0} bytes/row",
        k / secs / 1e6,
        secs / k * 1e9,
        bytes as f64 / k
    );

    let mut m = Monitor::new(&model, Method::Pinn);
    for x in &samples {
        black_box(m.push(x));
    }
    let state = serde_json::to_vec(&m.state()).expect("a state serialises");
    println!("monitor state: {} bytes as JSON", state.len());
}
