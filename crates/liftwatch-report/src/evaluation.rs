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

use liftwatch::evaluate::{delay_pairs, DelayPair, DelayPairs, Evaluation};
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
    figure_of(&delay_pairs(&ev.cases))
        .map(|f| emit(dir, &f))
        .transpose()
}

/// The figure of the suite's [`DelayPairs`] ([`delay_pairs`]); `None` when no machine fault
/// was detected with a floor.
fn figure_of(pairs: &DelayPairs) -> Option<Figure> {
    let (floor, threshold) = (&pairs.floor, &pairs.threshold);
    if floor.is_empty() {
        return None;
    }
    let all = floor.iter().chain(threshold);
    let hi = all
        .clone()
        .flat_map(|p| [p.liftwatch_days, p.other_days])
        .fold(MIN_DELAY_DAYS, f64::max);
    let lo = all
        .flat_map(|p| [p.liftwatch_days, p.other_days])
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
    left.marks.extend(dots(floor, false));
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
        right.marks.extend(dots(threshold, true));
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

/// One set of dots (x the reference, y liftwatch) per true mode; with `grey_noisy`, the
/// cases of an elevator whose threshold method was not quiet when healthy in grey instead.
fn dots(pairs: &[DelayPair], grey_noisy: bool) -> Vec<Mark> {
    let grey = |p: &DelayPair| grey_noisy && !p.threshold_quiet;
    let set = |keep: &dyn Fn(&DelayPair) -> bool, color, label: &str| {
        let pts: Vec<(f64, f64)> = pairs
            .iter()
            .filter(|p| keep(p))
            .map(|p| (p.other_days, p.liftwatch_days))
            .collect();
        (!pts.is_empty()).then(|| Mark::Dots {
            pts,
            color,
            radius: DOT_PX,
            label: Some(label.into()),
        })
    };
    let mut out: Vec<Mark> = [
        (FaultMode::Motor, BLUE),
        (FaultMode::Brake, ORANGE),
        (FaultMode::Friction, GREEN),
    ]
    .into_iter()
    .filter_map(|(mode, color)| set(&|p| p.mode == mode && !grey(p), color, mode.as_str()))
    .collect();
    out.extend(set(&grey, GREY, "threshold not quiet when healthy"));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(ours: f64, other: f64, mode: FaultMode, quiet: bool) -> DelayPair {
        DelayPair {
            liftwatch_days: ours,
            other_days: other,
            mode,
            threshold_quiet: quiet,
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

    /// Each pair is a dot (x the reference, y liftwatch) in its mode's colour; beside the
    /// threshold, the cases of an elevator where it was noisy when healthy are grey; the
    /// files are written.
    #[test]
    fn every_detected_machine_fault_is_a_dot_against_its_references() {
        let pairs = DelayPairs {
            floor: vec![
                pair(0.5, 0.25, FaultMode::Motor, true),
                pair(0.6, 0.4, FaultMode::Friction, false),
            ],
            threshold: vec![
                pair(0.5, 2.0, FaultMode::Motor, true),
                pair(0.6, 0.3, FaultMode::Friction, false),
            ],
        };
        let f = figure_of(&pairs).expect("two machine faults were detected with a floor");
        assert_eq!((f.grid, f.panels.len()), ((1, 2), 2));
        let (left, right) = (&f.panels[0], &f.panels[1]);
        assert_eq!(dots_of(left, BLUE), [(0.25, 0.5)]);
        assert_eq!(dots_of(left, GREEN), [(0.4, 0.6)]);
        assert_eq!(dots_of(left, GREY), []);
        assert_eq!(dots_of(right, BLUE), [(2.0, 0.5)]);
        assert_eq!(dots_of(right, GREEN), []);
        assert_eq!(dots_of(right, GREY), [(0.3, 0.6)]);
        // Whole decades around every delay.
        assert_eq!((left.x.min, left.x.max), (0.1, 10.0));
        let dir = std::env::temp_dir().join(format!("liftwatch-eval-fig-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fig = emit(&dir, &f).unwrap();
        let text = std::fs::read_to_string(&fig[0]).unwrap();
        assert!(text.contains("oracle floor") && text.contains("a third of its delay"));
        assert!(std::fs::metadata(&fig[1]).unwrap().len() > 1000);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Nothing detected with a floor draws nothing; no threshold detection, one panel.
    #[test]
    fn a_suite_without_detections_draws_nothing() {
        assert!(figure_of(&DelayPairs::default()).is_none());
        let one = DelayPairs {
            floor: vec![pair(0.2, 0.1, FaultMode::Brake, true)],
            threshold: Vec::new(),
        };
        assert_eq!(figure_of(&one).map(|f| f.panels.len()), Some(1));
    }
}
