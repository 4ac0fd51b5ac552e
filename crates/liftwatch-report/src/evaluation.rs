//! The evaluation's figure, `evaluation.svg` and `.png` beside `evaluation.json`: every
//! machine fault's detection delay against the two references the table reads, the oracle
//! floor and the threshold method.
//!
//! ```text
//! left:  x = oracle floor (days after onset), y = liftwatch's delay     on the diagonal: as
//!                                                                       early as the data allow
//! right: x = threshold method's delay,        y = liftwatch's delay     below the lower line:
//!                                                                       within a third of it
//! ```
//!
//! Both axes are logarithmic, since delays run from minutes (steps) to days (slow ramps); a
//! delay below the axis (a floor of a few seconds) sits on its lower edge. Colours name the
//! true mode; on the right, cases of an elevator whose threshold method raised false signals
//! when healthy are grey, as their "detection" may be its own flicker.

use std::path::{Path, PathBuf};

use liftwatch::evaluate::{CaseResult, Evaluation};
use liftwatch::mode::FaultMode;
use plotters::style::RGBColor;

use crate::plot::{colors::*, emit, Axis, Figure, Legend, Mark, Panel};
use crate::Error;

/// The shortest delay the axes show (days): 1.4 minutes, less than one trip of a busy car.
const MIN_DELAY_DAYS: f64 = 1e-3;
/// Radius of a case's dot (px).
const DOT_PX: u32 = 6;

/// Writes the evaluation's figure into `dir`; `None` (nothing written) when no machine fault
/// was detected with a floor.
///
/// # Errors
/// [`Error::Draw`] when a file cannot be written.
pub fn write_evaluation_figure(dir: &Path, ev: &Evaluation) -> Result<Option<[PathBuf; 2]>, Error> {
    figure(ev).map(|f| emit(dir, &f)).transpose()
}

/// liftwatch's delay and the other's per detected machine fault, with its true mode and
/// whether the other's elevator stands out (grey).
type Pair = (f64, f64, FaultMode, bool);

/// The figure; `None` when no machine fault was detected with a floor.
fn figure(ev: &Evaluation) -> Option<Figure> {
    let delay = |c: &CaseResult, i: usize| c.methods.get(i).and_then(|m| m.delay_days);
    let machine = || {
        ev.cases.iter().filter_map(|c| {
            let m = c.case.truth.filter(|m| m.is_machine())?;
            Some((c, m))
        })
    };
    let noisy = |e: usize| {
        ev.cases
            .iter()
            .filter(|c| c.case.elevator == e)
            .any(|c| c.methods.get(1).is_some_and(|m| m.false_signals > 0))
    };
    let floor: Vec<Pair> = machine()
        .filter_map(|(c, m)| Some((delay(c, 0)?, c.floor_delay_days?, m, false)))
        .collect();
    if floor.is_empty() {
        return None;
    }
    let threshold: Vec<Pair> = machine()
        .filter_map(|(c, m)| Some((delay(c, 0)?, delay(c, 1)?, m, noisy(c.case.elevator))))
        .collect();
    let all = floor.iter().chain(&threshold);
    let hi = all
        .clone()
        .flat_map(|p| [p.0, p.1])
        .fold(MIN_DELAY_DAYS, f64::max);
    let lo = all
        .flat_map(|p| [p.0, p.1])
        .filter(|&d| d >= MIN_DELAY_DAYS)
        .fold(hi, f64::min);
    let axis = |what: &str| Axis::log(lo, hi, format!("{what} (days after onset)"));
    let mut left = Panel::new(
        format!(
            "liftwatch against the oracle floor: {} machine faults",
            floor.len()
        ),
        axis("oracle floor"),
        axis("liftwatch's first rise"),
    );
    let (a, b) = (left.x.min, left.x.max);
    left.marks
        .push(diagonal(a, b, 1.0, GREY, "as early as the data allow"));
    left.marks.extend(dots(&floor));
    left.legend = Legend::UpperLeft;
    let mut panels = vec![left];
    if !threshold.is_empty() {
        let mut right = Panel::new(
            format!(
                "liftwatch against the threshold method: {} both detected",
                threshold.len()
            ),
            axis("threshold method's first alarm"),
            axis("liftwatch's first rise"),
        );
        right
            .marks
            .push(diagonal(a, b, 1.0, GREY, "as early as the threshold"));
        right
            .marks
            .push(diagonal(3.0 * a, b, 1.0 / 3.0, INK, "a third of its delay"));
        right.marks.extend(dots(&threshold));
        right.legend = Legend::UpperLeft;
        panels.push(right);
    }
    Some(Figure {
        name: "evaluation".into(),
        width: 600 * panels.len() as u32,
        height: 600,
        grid: (1, panels.len()),
        panels,
    })
}

/// The line y = k·x across `a..b`.
fn diagonal(a: f64, b: f64, k: f64, color: RGBColor, label: &str) -> Mark {
    Mark::Line {
        pts: vec![(a, k * a), (b, k * b)],
        color,
        width: 2,
        label: Some(label.into()),
    }
}

/// One set of dots per true mode, and one grey set for the cases marked to stand out.
fn dots(pairs: &[Pair]) -> Vec<Mark> {
    let mut out = Vec::new();
    for (mode, color) in [
        (FaultMode::Motor, BLUE),
        (FaultMode::Brake, ORANGE),
        (FaultMode::Friction, GREEN),
    ] {
        let pts: Vec<(f64, f64)> = pairs
            .iter()
            .filter(|p| p.2 == mode && !p.3)
            .map(|p| (p.1, p.0))
            .collect();
        if !pts.is_empty() {
            out.push(Mark::Dots {
                pts,
                color,
                radius: DOT_PX,
                label: Some(mode.as_str().into()),
            });
        }
    }
    let grey: Vec<(f64, f64)> = pairs.iter().filter(|p| p.3).map(|p| (p.1, p.0)).collect();
    if !grey.is_empty() {
        out.push(Mark::Dots {
            pts: grey,
            color: GREY,
            radius: DOT_PX,
            label: Some("threshold not quiet when healthy".into()),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use liftwatch::evaluate::{compare_delays, Case, ChartSettings, MethodResult, SuiteConfig};
    use liftwatch::sim::Scenario;

    fn method(name: &'static str, delay: Option<f64>, false_signals: usize) -> MethodResult {
        MethodResult {
            method: name,
            delay_days: delay,
            severity_at_detection: delay.map(|_| 1.0),
            false_signals,
            exposure_days: 3.0,
            false_per_year: 0.0,
            mode: None,
            mode_correct: None,
            flicker: None,
            persistent_delay_days: None,
            drift_z: None,
            drift_z_alarm: None,
            leak_z: None,
            door_advisories: None,
            outages: None,
            events: Vec::new(),
        }
    }

    /// A case of `elevator`: liftwatch's, the threshold's and the floor's delays, and the
    /// threshold's false signals.
    fn case(
        elevator: usize,
        truth: Option<FaultMode>,
        [ours, theirs, floor]: [Option<f64>; 3],
        noisy: usize,
    ) -> CaseResult {
        CaseResult {
            case: Case {
                name: format!("E{elevator} {truth:?}"),
                elevator,
                truth,
                scenario: Scenario::healthy(),
                sensor_fault: None,
                days: 7.0,
                onset_days: truth.map(|_| 3.0),
            },
            trips: 1000,
            late_mean_z: 0.0,
            methods: vec![
                method("liftwatch", ours, 0),
                method("threshold", theirs, noisy),
            ],
            floor_delay_days: floor,
            seconds: 0.0,
        }
    }

    fn evaluation(cases: Vec<CaseResult>) -> Evaluation {
        Evaluation {
            config: SuiteConfig::new(1, true),
            chart_settings: ChartSettings {
                cusum_k: 0.5,
                ewma_lambda: 0.1,
                target_false_per_year: 1.0,
                block_trips: 50,
                calibration_years: 10.0,
                persistent_trips: 20,
            },
            elevators: Vec::new(),
            aggregates: Vec::new(),
            delays: compare_delays(&cases),
            cases,
            seconds: 0.0,
        }
    }

    /// The points of every dot mark of `p`, by colour.
    fn dots_of(p: &Panel, color: RGBColor) -> Vec<(f64, f64)> {
        p.marks
            .iter()
            .filter_map(|m| match m {
                Mark::Dots { pts, color: c, .. } if *c == color => Some(pts.clone()),
                _ => None,
            })
            .flatten()
            .collect()
    }

    /// Each detected machine fault is a dot (x the reference, y liftwatch) in its mode's
    /// colour; sensor faults, misses and healthy runs are not; the threshold's cases on an
    /// elevator where it was noisy when healthy are grey; the files are written.
    #[test]
    fn every_detected_machine_fault_is_a_dot_against_its_references() {
        let motor = Some(FaultMode::Motor);
        let ev = evaluation(vec![
            case(0, motor, [Some(0.5), Some(2.0), Some(0.25)], 0),
            case(
                0,
                Some(FaultMode::Sensor),
                [Some(0.01), Some(0.001), None],
                0,
            ),
            case(1, None, [None, None, None], 3),
            case(
                1,
                Some(FaultMode::Friction),
                [Some(0.6), Some(0.3), Some(0.4)],
                0,
            ),
            case(1, motor, [None, Some(0.2), Some(0.1)], 0),
        ]);
        let f = figure(&ev).expect("two machine faults were detected with a floor");
        assert_eq!((f.grid, f.panels.len()), ((1, 2), 2));
        let (left, right) = (&f.panels[0], &f.panels[1]);
        assert_eq!(dots_of(left, BLUE), [(0.25, 0.5)]);
        assert_eq!(dots_of(left, GREEN), [(0.4, 0.6)]);
        assert_eq!(dots_of(right, BLUE), [(2.0, 0.5)]);
        assert_eq!(dots_of(right, GREEN), []);
        assert_eq!(dots_of(right, GREY), [(0.3, 0.6)]);
        // Whole decades around every delay.
        assert_eq!((left.x.min, left.x.max), (0.1, 10.0));
        let dir = std::env::temp_dir().join(format!("liftwatch-eval-fig-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let [svg, png] = write_evaluation_figure(&dir, &ev).unwrap().unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.contains("oracle floor") && text.contains("a third of its delay"));
        assert!(std::fs::metadata(&png).unwrap().len() > 1000);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Nothing detected with a floor draws nothing; no threshold detection, one panel.
    #[test]
    fn a_suite_without_detections_draws_nothing() {
        let motor = Some(FaultMode::Motor);
        assert!(figure(&evaluation(vec![case(
            0,
            motor,
            [None, None, Some(0.1)],
            0
        )]))
        .is_none());
        let one = figure(&evaluation(vec![case(
            0,
            motor,
            [Some(0.2), None, Some(0.1)],
            0,
        )]));
        assert_eq!(one.map(|f| f.panels.len()), Some(1));
    }
}
