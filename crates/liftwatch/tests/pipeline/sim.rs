//! The simulator against physics and against its own declarations.

use liftwatch::align::{read_series, AlignConfig};
use liftwatch::elevator::G;
use liftwatch::mode::FaultMode;
use liftwatch::sample::{DAY_S, HOUR_S};
use liftwatch::sim::{
    self, Ramp, RawRow, Scenario, SensorFault, Signal, SimConfig, SimSink, TruthRow,
};
use liftwatch::{Elevator, Result, Sample};

use crate::Dir;

/// A short run starting at 07:00 on a Monday, so that it holds the morning traffic.
fn morning(days: f64, seed: u64) -> SimConfig {
    SimConfig {
        start_s: 7.0 * HOUR_S,
        ..SimConfig::new(elevator(), days, seed)
    }
}

fn elevator() -> Elevator {
    Elevator::new(1000.0, 1.6, 14)
}

/// A sink that keeps only counts and a few statistics, for multi-day runs.
#[derive(Default)]
struct Stats {
    raw: u64,
    rows: u64,
    max_speed: f64,
    max_accel: f64,
}

impl SimSink for Stats {
    fn raw(&mut self, _row: RawRow) -> Result<()> {
        self.raw += 1;
        Ok(())
    }
    fn truth(&mut self, r: &TruthRow) -> Result<()> {
        self.rows += 1;
        self.max_speed = self.max_speed.max(r.v_true.abs());
        self.max_accel = self.max_accel.max(r.accel_true.abs());
        Ok(())
    }
}

#[test]
fn motion_respects_rated_limits_and_stops_level_with_a_landing() {
    let out = sim::simulate(&morning(0.4, 11)).unwrap();
    let p = &out.truth.plant;
    assert!(
        out.truth.summary.trips > 50,
        "{} trips",
        out.truth.summary.trips
    );
    let mut peaks = Vec::new();
    let (mut peak, mut last_rest, mut moving) = (0.0f64, out.rows[0].pos_true, false);
    for r in &out.rows {
        assert!(r.v_true.abs() <= p.rated.rated_speed_mps + 1e-9);
        assert!(r.accel_true.abs() <= p.accel_mps2 + 1e-9);
        if r.v_true == 0.0 {
            let at_landing = p
                .floor_positions_m
                .iter()
                .any(|&h| (h - r.pos_true).abs() < 1e-6);
            assert!(
                at_landing,
                "car at rest between landings at {} m",
                r.pos_true
            );
            if moving {
                peaks.push(((r.pos_true - last_rest).abs(), peak));
            }
            (peak, last_rest, moving) = (0.0, r.pos_true, false);
        } else {
            peak = peak.max(r.v_true.abs());
            moving = true;
        }
    }
    // A trip shorter than v·T(v), T(v) = v/a + a/j, never reaches rated speed v; the longest do.
    let v = p.rated.rated_speed_mps;
    let reach = v * (v / p.accel_mps2 + p.accel_mps2 / p.jerk_mps3);
    let short: Vec<_> = peaks.iter().filter(|(d, _)| *d < 0.95 * reach).collect();
    assert!(!short.is_empty(), "no trip shorter than {reach} m");
    assert!(short.iter().all(|(_, pk)| *pk < v), "{short:?}");
    assert!(peaks
        .iter()
        .any(|(d, pk)| *d > 2.0 * reach && *pk > 0.99 * v));
}

#[test]
fn an_empty_car_cruising_up_regenerates() {
    let out = sim::simulate(&morning(0.5, 12)).unwrap();
    let th = &out.truth.parameters;
    let cruise_up_empty: Vec<&TruthRow> = out
        .rows
        .iter()
        .filter(|r| r.v_true > 1.0 && r.accel_true == 0.0 && r.load_true == 0.0)
        .collect();
    assert!(cruise_up_empty.len() > 20);
    for r in cruise_up_empty {
        assert!(
            r.force_true < 0.0,
            "counterweight pulls an empty car up: F = {}",
            r.force_true
        );
        assert!(
            r.voltage_true < th.u0 + th.ke * r.v_true.abs(),
            "regenerating lowers U below the back-EMF line"
        );
    }
}

#[test]
fn load_cell_at_rest_reads_the_load_and_feels_acceleration_in_motion() {
    let out = sim::simulate(&morning(0.5, 13)).unwrap();
    let (mut err, mut n) = (0.0, 0.0);
    let (mut accel_sum, mut reading_sum, mut m) = (0.0, 0.0, 0.0);
    let p_ratio = out.truth.load_cell_platform_ratio;
    for r in &out.rows {
        let l = r.sample.load;
        if !l.is_finite() {
            continue;
        }
        if r.v_true == 0.0 && r.sample.door == 0.0 {
            assert!(
                (l - 100.0 * r.load_true).abs() < 4.0,
                "{l} vs {}",
                100.0 * r.load_true
            );
            err += l - 100.0 * r.load_true;
            n += 1.0;
        } else if r.accel_true.abs() > 0.5 {
            // Inertial part of the reading: (λ + p)·a/g·100.
            // Signed by a, so that starts and stops add up instead of cancelling.
            let s = r.accel_true.signum();
            accel_sum += s * (r.load_true + p_ratio) * r.accel_true / G * 100.0;
            reading_sum += s * (l - 100.0 * r.load_true);
            m += 1.0;
        }
    }
    assert!(n > 1000.0);
    assert!((err / n).abs() < 0.3, "mean error at rest {}", err / n);
    assert!(m > 50.0);
    // Latency and noise blur single samples; on average the inertial part shows.
    let ratio = reading_sum / accel_sum;
    assert!((0.7..1.3).contains(&ratio), "{ratio}");
}

#[test]
fn traffic_mean_load_is_within_iso_25745_range_and_thermal_drift_is_a_healthy_machines() {
    for (load, speed, floors) in [(630.0, 1.0, 8), (1000.0, 1.75, 20), (1600.0, 2.5, 36)] {
        let cfg = SimConfig::new(Elevator::new(load, speed, floors), 7.0, 14);
        let mut stats = Stats::default();
        let truth = sim::run(&cfg, &mut stats, &mut |_| {}).unwrap();
        let s = &truth.summary;
        assert!(
            (0.045..=0.11).contains(&s.mean_load_ratio_moving),
            "{load} kg: {}",
            s.mean_load_ratio_moving
        );
        assert_eq!(stats.rows, 7 * 86_400);
        assert_eq!(stats.raw, s.raw_rows);
        assert!(stats.max_speed <= speed + 1e-9);
        // The winding's heating and the machine room's day move Kd by 5-20 % from a quiet
        // night to a busy hour (MODEL.md: 10-20 %), never by a fault's size.
        let (low, high) = s.kd_thermal_range;
        assert!(low > 0.90 && high < 1.12, "{:?}", s.kd_thermal_range);
        assert!(
            (0.05..0.20).contains(&(high - low)),
            "a healthy machine's swing: {:?}",
            s.kd_thermal_range
        );
        assert_eq!(s.dropped_calls, 0);
    }
}

#[test]
fn the_same_seed_gives_the_same_telemetry() {
    let cfg = morning(0.1, 15);
    let a = sim::simulate(&cfg).unwrap();
    let b = sim::simulate(&cfg).unwrap();
    // Debug text compares NaN fields (missing values) as equal, `==` would not.
    assert!(a.raw == b.raw, "raw rows differ");
    assert!(
        format!("{:?}", a.rows) == format!("{:?}", b.rows),
        "aligned rows differ"
    );
    let c = sim::simulate(&SimConfig { seed: 16, ..cfg }).unwrap();
    assert!(a.raw != c.raw, "another seed, other telemetry");
}

#[test]
fn a_given_plant_is_kept_across_seeds_for_train_and_test_runs() {
    let train = sim::simulate(&morning(0.05, 22)).unwrap();
    let test = SimConfig {
        seed: 23,
        plant: Some(train.truth.plant.clone()),
        ..morning(0.05, 23)
    };
    let test = sim::simulate(&test).unwrap();
    assert_eq!(train.truth.parameters, test.truth.parameters);
    assert!(train.raw != test.raw, "other seed, other traffic and noise");
}

#[test]
fn fault_ramps_have_the_declared_onset_and_severity() {
    let base = SimConfig::new(elevator(), 1.0, 17);
    let healthy = sim::simulate(&base).unwrap();
    let motor = sim::simulate(&base.clone().with_mode(FaultMode::Motor)).unwrap();
    let (onset, full) = (0.4 * DAY_S, DAY_S);
    for (h, m) in healthy.rows.iter().zip(&motor.rows) {
        let t = h.sample.time;
        let want = if t < onset {
            0.0
        } else {
            (t - onset) / (full - onset)
        };
        assert!(
            (m.severity - want).abs() < 1e-9,
            "severity at {t}: {} vs {want}",
            m.severity
        );
        // Same traffic, same heat: only the degradation separates the two Kd.
        assert!((m.kd_true / h.kd_true - (1.0 + 0.10 * want)).abs() < 1e-9);
        assert_eq!(h.force_true, m.force_true);
    }
    let last = motor.rows.last().unwrap();
    assert!(last.severity > 0.999);

    let friction = sim::simulate(&base.clone().with_mode(FaultMode::Friction)).unwrap();
    let brake = sim::simulate(&base.clone().with_mode(FaultMode::Brake)).unwrap();
    let f_c = healthy.truth.parameters.f_c;
    let (mut fr_up, mut fr_down, mut br_up, mut br_down) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for ((h, f), b) in healthy.rows.iter().zip(&friction.rows).zip(&brake.rows) {
        if h.sample.time < 0.9 * DAY_S || h.v_true.abs() < 0.5 || h.accel_true != 0.0 {
            continue;
        }
        let s = h.v_true.signum();
        let (df, db) = (
            (f.force_true - h.force_true) * s,
            (b.force_true - h.force_true) * s,
        );
        if s > 0.0 {
            fr_up.push(df);
            br_up.push(db);
        } else {
            fr_down.push(df);
            br_down.push(db);
        }
    }
    let mean = |v: &Vec<f64>| v.iter().sum::<f64>() / v.len().max(1) as f64;
    assert!(!fr_up.is_empty() && !fr_down.is_empty());
    // Friction: ≈ +25 % of F_c (plus viscous) opposing motion, both ways.
    for d in [mean(&fr_up), mean(&fr_down)] {
        assert!(
            d > 0.2 * 0.9 * f_c && d < 0.5 * f_c,
            "friction extra {d} N for F_c {f_c} N"
        );
    }
    // Brake: drags ~0.6·F_c going down, much less cruising up.
    let (up, down) = (mean(&br_up), mean(&br_down));
    assert!(
        down > 0.5 * f_c && down < 0.7 * f_c,
        "brake drag down {down} N"
    );
    assert!(up < 0.5 * down, "brake drag up {up} N vs down {down} N");
}

#[test]
fn step_and_exponential_ramps_follow_their_shape() {
    let mut cfg = SimConfig::new(elevator(), 0.2, 18);
    cfg.scenario = Scenario::new(FaultMode::Friction, HOUR_S, Ramp::Step, HOUR_S, 0.5).unwrap();
    let out = sim::simulate(&cfg).unwrap();
    assert!(out
        .rows
        .iter()
        .all(|r| r.severity == if r.sample.time < HOUR_S { 0.0 } else { 0.5 }));
    cfg.scenario = Scenario::new(
        FaultMode::Friction,
        HOUR_S,
        Ramp::Exponential,
        10_000.0,
        1.0,
    )
    .unwrap();
    let out = sim::simulate(&cfg).unwrap();
    let mid = out.rows.iter().find(|r| r.sample.time == 6800.0).unwrap();
    assert!(
        mid.severity > 0.0 && mid.severity < 0.5 * 0.9,
        "{}",
        mid.severity
    );
}

#[test]
fn aligned_truth_agrees_with_the_raw_log() {
    let out = sim::simulate(&morning(0.3, 19)).unwrap();
    let rows = &out.rows;
    let t0 = rows[0].sample.time;
    let at = |t: f64| &rows[((t - t0).round().max(0.0) as usize).min(rows.len() - 1)];
    let (mut d_speed, mut n_speed, mut door_same, mut n_door) = (0.0, 0.0, 0, 0);
    let mut last_time = [f64::NEG_INFINITY; 6];
    for r in &out.raw {
        let k = r.signal.index();
        let gap = r.time - last_time[k];
        assert!(
            gap >= 0.0,
            "{} goes backwards at {}",
            r.signal.name(),
            r.time
        );
        if last_time[k].is_finite() && gap > 0.0 {
            // Each signal ticks about once a second, or stays silent for a dropout.
            assert!(
                (0.5..1.5).contains(&gap) || gap > 55.0,
                "{} gap {gap}",
                r.signal.name()
            );
        }
        last_time[k] = r.time;
        let a = at(r.time);
        match r.signal {
            Signal::Speed if a.v_true != 0.0 => {
                // Within the grid's half second the car's speed changes by at most a_max/2.
                d_speed += (r.value - a.v_true.abs()).abs();
                n_speed += 1.0;
            }
            Signal::Door if a.sample.door.is_finite() => {
                n_door += 1;
                door_same += usize::from(r.value == a.sample.door);
            }
            _ => {}
        }
    }
    assert!(n_speed > 500.0);
    assert!(
        d_speed / n_speed < 0.25,
        "mean speed difference {}",
        d_speed / n_speed
    );
    assert!(
        door_same as f64 > 0.97 * n_door as f64,
        "{door_same}/{n_door}"
    );
    // Rows are in logging order: mostly, not entirely, sorted by time.
    let back = out.raw.windows(2).filter(|w| w[1].time < w[0].time).count();
    assert!(back > 0 && back < out.raw.len() / 2);
}

#[test]
fn sensor_faults_show_in_the_readings_only() {
    let mut cfg = morning(0.5, 20);
    cfg.dropouts_per_day = 0.0;
    cfg.sensor_fault = Some(SensorFault::LoadDrift {
        onset_s: 10_000.0,
        pct_per_day: 20.0,
    });
    let out = sim::simulate(&cfg).unwrap();
    let late: Vec<f64> = out
        .rows
        .iter()
        .filter(|r| r.sample.time > 30_000.0 && r.v_true == 0.0 && r.sample.door == 0.0)
        .map(|r| r.sample.load - 100.0 * r.load_true - 20.0 * (r.sample.time - 10_000.0) / DAY_S)
        .collect();
    let bias = late.iter().sum::<f64>() / late.len() as f64;
    assert!(
        bias.abs() < 0.3,
        "the drift is the declared one: residual bias {bias}"
    );

    cfg.sensor_fault = Some(SensorFault::StuckSpeed {
        onset_s: 30_000.0,
        duration_s: HOUR_S,
    });
    let out = sim::simulate(&cfg).unwrap();
    let stuck: Vec<f64> = out
        .raw
        .iter()
        .filter(|r| r.signal == Signal::Speed && (30_001.0..33_599.0).contains(&r.time))
        .map(|r| r.value)
        .collect();
    assert!(stuck.len() > 3000 && stuck.iter().all(|&v| v == stuck[0]));
    let moving = out
        .rows
        .iter()
        .filter(|r| (30_001.0..33_599.0).contains(&r.sample.time) && r.v_true != 0.0)
        .count();
    assert!(
        moving > 0,
        "the car kept moving while the speed reading froze"
    );
}

#[test]
fn write_dir_writes_the_four_files_with_the_contract_headers() {
    let dir = std::env::temp_dir().join(format!("liftwatch-sim-test-{}", std::process::id()));
    let cfg = SimConfig::new(elevator(), 0.05, 21).with_mode(FaultMode::Brake);
    let truth = sim::write_dir(&cfg, &dir, &mut |_| {}).unwrap();
    let raw = std::fs::read_to_string(dir.join("raw.csv")).unwrap();
    assert!(raw.starts_with("time,signal,value\n"));
    assert_eq!(raw.lines().count() as u64, truth.summary.raw_rows + 1);
    let aligned = std::fs::read_to_string(dir.join("aligned.csv")).unwrap();
    assert!(aligned.starts_with("time,speed,direction,voltage,load,door,floor,"));
    assert_eq!(
        aligned.lines().count() as u64,
        truth.summary.aligned_rows + 1
    );
    // The raw log's grid: from its first reading to its last, a second or two inside the run.
    assert!(
        (truth.summary.truth_rows - 2..=truth.summary.truth_rows)
            .contains(&truth.summary.aligned_rows),
        "{} aligned rows of {} seconds",
        truth.summary.aligned_rows,
        truth.summary.truth_rows
    );
    let e = Elevator::from_toml_file(&dir.join("elevator.toml")).unwrap();
    assert_eq!(e, elevator());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    for k in liftwatch::model::PhysParams::NAMES {
        assert!(json["parameters"][k].is_f64(), "{k}");
    }
    assert_eq!(json["scenario"]["mode"], "brake");
    assert_eq!(json["scenario"]["ramp"], "linear");
    assert_eq!(json["seed"], 21);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// DATA.md §2: an aligned series is the output of alignment, and every command takes either
/// layout. So the run's `aligned.csv` must hold what aligning its own `raw.csv` gives (what
/// `liftwatch align` writes), and a command fed either file sees the same samples, trips and
/// residuals. It used to hold every sensor read at the grid instant instead, which no aligner
/// can make of a log whose clocks are phase-shifted: the voltage interpolated across a trip's
/// start and end differs by tens of volts, by how far each clock's samples sit from the grid,
/// and on a 30-day run a model fitted on one file raised a brake alarm on the other.
#[test]
fn simulated_aligned_csv_is_the_alignment_of_its_own_raw_log() {
    let dir = Dir::new("sim-aligned-is-raw-aligned");
    // Dropouts often enough that the short run holds gaps longer than the gap limit.
    let cfg = SimConfig {
        dropouts_per_day: 50.0,
        ..morning(0.1, 23)
    };
    sim::write_dir(&cfg, &dir.0, &mut |_| {}).unwrap();
    let align = |name: &str| {
        read_series(&dir.0.join(name), &AlignConfig::default())
            .unwrap()
            .0
    };
    let (from_raw, written) = (align("raw.csv"), align("aligned.csv"));
    let fields = |s: &Sample| [s.speed, s.direction, s.voltage, s.load, s.door, s.floor];
    let by_time: std::collections::HashMap<u64, &Sample> = written
        .samples
        .iter()
        .map(|s| (s.time.to_bits(), s))
        .collect();
    let (mut moving, mut gaps) = (0, 0);
    for r in &from_raw.samples {
        let w = by_time
            .get(&r.time.to_bits())
            .unwrap_or_else(|| panic!("aligned.csv has no row at {} s", r.time));
        for (x, y) in fields(w).into_iter().zip(fields(r)) {
            // Both files are written rounded to 1e-6.
            assert!(
                (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-6,
                "at {} s aligned.csv has {:?}, aligning raw.csv gives {:?}",
                r.time,
                fields(w),
                fields(r)
            );
        }
        moving += usize::from(r.speed > 0.5);
        gaps += usize::from(fields(r).iter().any(|x| x.is_nan()));
    }
    assert_eq!(
        written.len(),
        from_raw.len(),
        "one row per grid point of the raw log"
    );
    assert!(
        moving > 100 && gaps > 10,
        "{moving} moving, {gaps} with gaps"
    );
    // The in-memory alignment of the log (what the evaluation trains on) is the same series.
    let (in_memory, truth) = sim::simulate_aligned(&cfg).unwrap();
    assert_eq!(in_memory.len(), written.len());
    assert_eq!(truth.summary.aligned_rows, written.len() as u64);
    for (m, w) in in_memory.samples.iter().zip(&written.samples) {
        assert_eq!(m.time, w.time);
        for (x, y) in fields(m).into_iter().zip(fields(w)) {
            assert!(
                (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-6,
                "at {} s simulate_aligned has {:?}, aligned.csv {:?}",
                m.time,
                fields(m),
                fields(w)
            );
        }
    }
    // The truth columns stay with their grid instant: the aligned speed follows the true one.
    let text = std::fs::read_to_string(dir.0.join("aligned.csv")).unwrap();
    let (mut d, mut n) = (0.0, 0.0);
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line
            .split(',')
            .map(|x| x.parse().unwrap_or(f64::NAN))
            .collect();
        if f[1].is_finite() && f[7] != 0.0 {
            d += (f[1] - f[7].abs()).abs();
            n += 1.0;
        }
    }
    assert!(
        n > 100.0 && d / n < 0.05,
        "mean |speed - |v_true|| {} over {n}",
        d / n
    );
}
