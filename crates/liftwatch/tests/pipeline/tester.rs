//! The monitor tester: one series through every path the project offers for it, demanding the
//! same rows and events from each (in the spirit of ripgrep's `SearcherTester`).
//!
//! ```text
//! reference   raw log ─ align (in memory) ─ monitor::run                  (the batch driver)
//! resume-k    the same samples, the monitor saved to JSON and resumed every k samples
//! streaming   raw log ─ align (streaming) ─ Monitor::push as each sample is released
//! ```
//!
//! The model is the prior-centre physics of the elevator with an uncalibrated, low threshold,
//! so that the simulated elevator (whose hidden plant differs from the prior) moves risk,
//! levels, events and the sensor check: every part of the monitor state is exercised.

use liftwatch::sample::{DAY_S, HOUR_S};
use std::path::{Path, PathBuf};

use liftwatch::align::{align_file, read_series, AlignConfig, SampleSink};
use liftwatch::features::FeatureConfig;
use liftwatch::fit::FittedModel;
use liftwatch::model::{HybridModel, PhysParams, ResidualNet, ResidualScales};
use liftwatch::monitor::{
    self, Method, Monitor, MonitorRow, MonitorState, RowWriter, TimeFormat, TripRowWriter,
};
use liftwatch::sim::{simulate, RawCsvWriter, SensorFault, SimConfig};
use liftwatch::{Elevator, Sample};

use crate::Dir;

/// One series and the model to watch it with.
struct MonitorTester {
    model: FittedModel,
    raw: PathBuf,
    align: AlignConfig,
}

impl MonitorTester {
    /// Half a simulated day of a 1000 kg car with a stuck speed signal for an hour, written as
    /// a raw log into `dir`.
    fn new(dir: &Path) -> MonitorTester {
        let elevator = Elevator::new(1000.0, 1.75, 26);
        let mut sim = SimConfig::new(elevator.clone(), 0.5, 7);
        sim.sensor_fault = Some(SensorFault::StuckSpeed {
            onset_s: 0.25 * DAY_S,
            duration_s: HOUR_S,
        });
        let out = simulate(&sim).expect("a valid simulation");
        let raw = dir.join("raw.csv");
        let mut w = RawCsvWriter::create(&raw).expect("scratch is writable");
        for r in &out.raw {
            w.write(r).expect("scratch is writable");
        }
        w.finish().expect("scratch is writable");
        let hybrid = HybridModel {
            parameters: PhysParams::prior_centre(&elevator),
            net: ResidualNet::new(1, [elevator.rated_speed_mps, 1.0, 1.0], [5.0, 500.0]),
            scales: ResidualScales {
                sigma_u_v: 1.5,
                sigma_f_n: 300.0,
            },
            elevator: elevator.clone(),
        };
        let mut model = FittedModel::uncalibrated(hybrid, FeatureConfig::for_elevator(&elevator));
        model.risk.advisory = 5.0;
        model.risk.alarm = 50.0;
        MonitorTester {
            model,
            raw,
            align: AlignConfig::default(),
        }
    }

    fn samples(&self) -> Vec<Sample> {
        read_series(&self.raw, &self.align)
            .expect("the simulated log aligns")
            .0
            .samples
    }

    /// Rows of the streaming path: every aligned sample goes into the monitor as the aligner
    /// releases it, nothing is collected in between.
    fn streaming(&self, method: Method) -> Vec<MonitorRow> {
        struct Feed {
            monitor: Monitor,
            fresh: Monitor,
            rows: Vec<MonitorRow>,
        }
        impl SampleSink for Feed {
            type Error = liftwatch::Error;
            fn start(&mut self, _has_current: bool) -> liftwatch::Result<()> {
                self.monitor = self.fresh.clone();
                self.rows.clear();
                Ok(())
            }
            fn push(&mut self, s: &Sample) -> liftwatch::Result<()> {
                self.rows.extend(self.monitor.push(s));
                Ok(())
            }
        }
        let fresh = Monitor::new(&self.model, method);
        let mut feed = Feed {
            monitor: fresh.clone(),
            fresh,
            rows: Vec::new(),
        };
        align_file(&self.raw, &self.align, &mut feed).expect("the simulated log aligns");
        feed.rows.extend(feed.monitor.finish());
        feed.rows
    }

    /// Rows when the monitor is saved as JSON and resumed before every `k`-th sample.
    fn resumed_every(&self, xs: &[Sample], method: Method, k: usize) -> Vec<MonitorRow> {
        let mut m = Monitor::new(&self.model, method);
        let mut rows = Vec::with_capacity(xs.len());
        for chunk in xs.chunks(k) {
            rows.extend(chunk.iter().filter_map(|x| m.push(x)));
            let json = serde_json::to_string(&m.state()).expect("a state serialises");
            let state: MonitorState = serde_json::from_str(&json).expect("a state parses");
            m = Monitor::resume(&self.model, state).expect("its own state resumes");
        }
        rows.extend(m.finish());
        rows
    }

    /// Runs every path for both methods and demands identical rows and events.
    fn check(&self) {
        let xs = self.samples();
        for method in [Method::Pinn, Method::Threshold] {
            let reference = monitor::run(&self.model, &xs, method);
            assert_eq!(reference.len(), xs.len(), "one row per sample");
            if method == Method::Pinn {
                assert!(
                    events(&reference).len() >= 2,
                    "the series must move the level for the test to mean anything"
                );
            }
            let want = (csv(&reference), events(&reference));
            let streaming = self.streaming(method);
            assert!(
                (csv(&streaming), events(&streaming)) == want,
                "{method:?}: streaming raw -> align -> monitor differs from the batch run"
            );
            for k in [1, 7, 997, xs.len() / 2 + 3] {
                let resumed = self.resumed_every(&xs, method, k);
                assert!(
                    (csv(&resumed), events(&resumed)) == want,
                    "{method:?}: resuming every {k} samples differs from one run"
                );
            }
        }
    }
}

/// The per-second rows, then the per-trip rows: a trip cut by a resume must come out whole.
fn csv(rows: &[MonitorRow]) -> String {
    let mut w = RowWriter::new(Vec::new()).expect("memory is writable");
    let mut t = TripRowWriter::new(Vec::new(), TimeFormat::Epoch).expect("memory is writable");
    for r in rows {
        w.write(r).expect("memory is writable");
        t.write(r).expect("memory is writable");
    }
    let trips = t.into_inner().expect("memory is writable");
    assert!(
        trips.iter().filter(|&&b| b == b'\n').count() > 2,
        "the series must hold trips for the per-trip rows to be compared"
    );
    let mut out = w.into_inner().expect("memory is writable");
    out.extend(trips);
    String::from_utf8(out).expect("CSV is UTF-8")
}

fn events(rows: &[MonitorRow]) -> Vec<String> {
    rows.iter()
        .filter_map(|r| r.event.as_deref().copied())
        .map(|e| e.to_json_line())
        .collect()
}

#[test]
fn every_path_through_the_monitor_gives_the_same_rows() {
    let dir = Dir::new("paths");
    MonitorTester::new(&dir.0).check();
}
