//! Availability and doors, what an owner asks first (DATA.md §4 `door` and `outage`): from
//! the same aligned samples and the trips of [`crate::features`], door cycles, out-of-service
//! periods, a daily availability and a door-health check with its own advisory.
//!
//! ```text
//! door cycle   door 0 → 1 … 1 → 0: duration d = t_close − t_open; a reopening when it opened
//!              within REOPEN_WINDOW_S of the previous close with no motion in between
//! outage       at rest since t0 (the last moving sample): Λ = Σ rate(hour of week)·Δt;
//!              out of service when Λ ≥ Λ_max and t − t0 ≥ OUTAGE_MIN_S; it began at t0, it
//!              ends at the next moving sample
//! stuck        a trip that ended more than LEVEL_TOLERANCE_M from every learnt landing, the
//!              car still at rest with the door closed STUCK_LIMIT_S later: an outage from
//!              the trip's end, whatever the hour
//! availability per day (UTC days of the data clock): 1 − outage s / observed s
//! door health  per scored cycle (d ≤ DOOR_CYCLE_MAX_S), two scores of healthy mean 0, sd 1:
//!                x = (L_before − L_min) + (L_after − L_min)   load exchanged at the landing
//!                e = d − b·x                 b: seconds per unit of load passing the door
//!                z_d = clip((clip((e − med)/σ̂, ±3) − m_d)/s_d, ±3)          σ̂ = 1.4826·MAD
//!                z_r = clip((clip((x − p0)/√(p0(1 − p0)), ±3) − m_r)/s_r, ±3)   x = 1: reopening
//!              w = the healthy day-to-day wander of the daily mean z beyond its noise
//!              one CUSUM per score and size ν (risk::sequential's sizes and increment):
//!                G ← min(2h, max(0, G + ν·(z − 2w) − ν²/2));   advisory at G ≥ h,
//!                released when every G < h/2
//! ```
//!
//! Learnt by [`OperationReference::learn`] on the training history (`fit`): the trip rate per
//! hour of the week (168 bins of the data clock; hours the training never saw take the
//! quietest rate it did see until the monitor has watched them), Λ_max from the quietest spans the healthy car itself had,
//! the landings from the trips' distances, and the doors' median, MAD, reopening rate and
//! CUSUM thresholds (a moving-block bootstrap of day-long blocks of the training's cycles over
//! ten years per false advisory, floored by Lorden's bound, as `crate::calibrate` does for
//! the machine).
//!
//! Why a whole day: a training that did not see every hour of the day (the paper's three
//! morning hours) judges no silence at all, and only a car stuck between landings is an
//! outage. Its hours say nothing of another day's same hours (a Saturday morning, a quiet
//! Tuesday), and its quietest span, the measure of how long a healthy car stands idle, is a
//! few minutes of a busy morning. Three morning hours of training had the simulated
//! evaluation report 1,416 outages in 3.94 elevator-years of healthy cars (1,337 on the
//! 40-floor tower), every one a car standing idle; and an outage's backlog of trips is not
//! machine evidence, so they also took trips from the risk.
//!
//! Why the quietest rate for an hour the training never saw: a training of three weekdays
//! cannot tell a Saturday afternoon's quiet from a car out of service. With the weekday's
//! rate for it, a simulated office car trained Monday to Wednesday reported 4-12 outages on
//! its first weekend, every one a car standing idle as an office's cars do. With the
//! quietest rate (at night often none) the silence of an unseen hour counts for little or
//! nothing: the car stuck between landings is still found at any hour, the car standing at a
//! landing is found in the hours the training saw. A week's training sees every hour.
//!
//! Why the monitor learns the hours its training never saw: with the quietest rate alone, a
//! car trained Monday to Wednesday was never found standing at a landing from Thursday to
//! Sunday, however long it watched (`evaluate`'s outage cases: a 4-hour outage on the second
//! Thursday went unreported on all three cars). The monitor counts the hours of speed data
//! and the trips started in each hour of the week the training never saw, and judges its
//! silences at that rate, at most its hour of the day's over the training (as a seen hour's
//! is), once it has watched the hour for [`LEARNT_MIN_H`]: from the second week on, every
//! hour is judged as a week's training would judge it. An hour is added when it ends, so a
//! silence is never judged at a rate it is lowering itself, and an hour in which an outage
//! was under way is left out. Λ_max stays the training's. An outage the monitor could not
//! see in an unseen hour's first week teaches it that hour as quiet, until later weeks
//! outweigh it. Nor is it reported; but a silence that Λ at the hours' pooled rates of the
//! day would have called an outage is followed by the backlog an outage is (its door cycles
//! not scored, its trips not machine evidence): on the field bench of `evaluate --seed 2`
//! a 630 kg car trained Monday to Wednesday stood out of service 4 h on its first Thursday,
//! door closed, and the calls that had waited raised a door advisory after it. It costs the
//! evidence of three hours after a quiet spell of a weekend in the first week.
//!
//! Why an hour's rate is at most its hour of the day's over the training: one week shows each
//! hour of the week once, and one hour's count of a Poisson stream of calls is noisy. A
//! 40-floor car's training week started 16 trips in one Wednesday's 01:00 hour and 13 in the
//! next (its nights average about 5), and its monitored Wednesdays reported an outage after
//! two and a half silent hours of most nights: 18 outages in 3.94 elevator-years of healthy
//! cars in `evaluate`. The lower of the two keeps a quiet weekend's hours quiet and takes a
//! busy fluke down to the level of its hour; a weekday's peak loses a fifth (the weekend's
//! share of the pool), so an outage in it is concluded a little later.
//!
//! Why the duration less b·x: a door stands open while people pass through it, about a second
//! each, so its cycles are long in the peaks and on busy days and short at night. That is
//! traffic, not the door. The load cell sees it: the riders stepping out lower the reading,
//! those stepping in raise it again, and x, the fall to the lowest reading plus the rise
//! after it, is the load that passed (riders leave before others board; a net change alone
//! would miss a full car emptying and filling again). b is fitted by least squares on the
//! training's cycles (one pass leaving out residuals beyond 3 σ̂). On a simulated 40-floor
//! office car it took σ̂ from 3.0 s to 1.3 s, so a door 1 s slower stands out twice as
//! clearly, and the wander between the hours of a day from 0.21 to 0.08 of a score's sd: the
//! evening down-peak no longer looks like a slow door. Without load readings (a log without
//! a load cell, or one that reads a constant) b is not fitted and the plain duration is
//! scored; with b fitted, a cycle without a load reading before, during and after it is
//! counted, not scored.
//!
//! Why a rate per hour of the week and Λ instead of a fixed "no trip for an hour": a car
//! standing still at 03:00 or on a Sunday is not out of service; one standing through a
//! Tuesday's lunch peak is. Λ is the number of trips the training says should have started
//! by now: at the lunch peak it is reached in minutes, at night never. Λ_max is twice the
//! largest Λ a healthy quiet span of the training reached (and at least
//! [`OUTAGE_MIN_EXPECTED_TRIPS`]): calls come in groups, so silences are longer than a
//! Poisson process of trips would give, and the training's own quietest span measures that;
//! or the tail's limit ([`tail_limit`]) when that is higher.
//!
//! Why the tail of the silences: twice the longest is a margin, not a rate. Over a year a
//! car stands through many more silences than a training shows, and how far the longest of
//! them goes depends on how many there are: once the monitor judged every hour of the week
//! (the hours a 3-day training never saw, learnt as above), `evaluate`'s 3-day trainings
//! reported 5 outages in 11.8 elevator-years of cars that served throughout, each a silence
//! of 45 min to 1.4 h that a Poisson stream of calls leaves now and then (a Thursday's
//! 18:24, a Sunday's 09:07), where the hours of the training itself had shown none. A
//! silence's Λ beyond a high threshold u is exponential for Poisson calls (memoryless, in
//! expected trips whatever the hour's rate), its scale κ widened by calls in groups, so the
//! training's longest silences measure κ and how often u is passed, and Λ_max is where a
//! year's silences pass once per the alarm budget, with κ at its 95 % bound. Measured on the
//! suites' trainings it lies near twice the longest (3 days: 24.0 → 28.6, 31.8 → 39.7,
//! 42.1 → 44.1 expected trips; a week: 29.4 → 25.5, 30.5 → 36.3), which is the same rule
//! read as a rate; the higher of the two is taken.
//!
//! Why the training's own outages are left out of it: a training log is rarely free of
//! them (a maintenance visit, a car switched off for an afternoon), and one 4-hour outage
//! in a simulated week of a 1000 kg office car took the largest Λ from 17 to 205 and Λ_max
//! to 411 expected trips: an outage on a weekday would have been concluded after about ten
//! hours instead of one. The training judges its silences by the rule the monitor will:
//! from the longest down, each that reached the Λ_max the shorter ones set
//! (`training_outages`) was an outage, and is left out; `fit` names them. A healthy week's
//! silences rise in small steps to their longest, so none is left out unless it is longer
//! than the monitor would have let it be.
//!
//! Why the other days' rates: a training day's silences are measured with the rates learnt
//! from the other days of like traffic (their trip rate within [`SIMILAR_DAY_FACTOR`] of its
//! own; an hour of the week they never saw takes its hour of the day's rate over them), not
//! with rates that day helped set. An hour's rate comes from the very trips its silences
//! lack: a silent hour of the training has its own rate near 0 and its silence counts for
//! nothing, while the same silence on a later day is measured at the rate the training gave
//! that hour. On a 40-floor car a group of riders to several floors starts four or five
//! trips, so a Sunday morning without one call for an hour (e^−4.5 at its 4.5 calls an hour)
//! reads as 20-30 expected trips. With the training's own rates `evaluate`'s suite reported
//! 9 outages in 3.94 elevator-years of healthy cars with week-long trainings (11 with
//! `--seed 2`), 6 with 3-day ones (12 with `--seed 2`), 2 on the field bench, each a car
//! standing idle on a quiet evening or weekend; with the other days' rates none, every other
//! figure the same. The days of like traffic: with all the other days an office's Saturday
//! is measured at its weekdays' rates, four times its own, and the default simulated week's
//! largest quiet Λ went from 10 to 62, so a 4 h outage on a Tuesday morning was concluded
//! after 2.9 h instead of 1 h (a shorter one not at all); with the days like it, 13 and
//! 1.2 h. A day with no other like it takes the
//! nearest in trip rate; a training of one day has no other and keeps its own rates.
//!
//! The door's check never touches the machine's risk: an outage or a slow door raises no
//! machine event, and the machine's evidence is as before.

use std::collections::{BTreeMap, VecDeque};

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::exact;
use crate::features::Trip;
use crate::mode::FaultMode;
use crate::risk::sequential::{gaussian_llr, CLIP, N_SIZES, SIZES};
use crate::rng::{moving_blocks, BlockStart, Rng};
use crate::sample::{pass, History, Sample, DAY_S, HOUR_S, YEAR_DAYS};
use crate::stats::{chi_square_quantile, median, robust_sigma, sorted_quantile};

/// A door that opens again within this long (s) of closing, the car not having moved, is
/// reopening: a lock that failed to make, a safety edge touched, a late passenger. A new call
/// at the same landing opens it too, but rarely so soon (the door closes after 3-6 s of dwell).
pub const REOPEN_WINDOW_S: f64 = 5.0;

/// A door open longer than this (s) is held open (a hold button, a move, a car out of
/// service), not a cycle of the door operator: it is counted but not scored.
pub const DOOR_CYCLE_MAX_S: f64 = 120.0;

/// Shortest out-of-service period reported (s): a pause shorter than a quarter of an hour is
/// not what an availability figure counts (and a busy car's silences are minutes long).
pub const OUTAGE_MIN_S: f64 = 900.0;

/// Λ_max is never below this many expected trips: with trips as a Poisson process the chance
/// of a silence this long is e^−15 ≈ 3·10⁻⁷.
pub const OUTAGE_MIN_EXPECTED_TRIPS: f64 = 15.0;

/// Λ_max is this many times the largest Λ of a healthy quiet span of the training: the
/// training's week shows only its own quietest span, a year more of them.
pub const OUTAGE_MARGIN: f64 = 2.0;

/// A car standing still with its door closed this long (s) after a trip that ended between
/// landings is stuck: a controller that recovers from a transient fault re-levels within a
/// minute or two, and five minutes is when trapped passengers press the alarm.
pub const STUCK_LIMIT_S: f64 = 300.0;

/// A trip ending farther than this (m) from every learnt landing ended between floors: the
/// doors cannot open there (EN 81-20 levels to ±10 mm; storeys are 3 m or more). The least
/// tolerance: trips whose 1 Hz distances scatter about the landings, or landings placed from
/// few trips, widen it ([`LEVEL_MARGIN`]).
pub const LEVEL_TOLERANCE_M: f64 = 0.5;

/// The tolerance is at least this many times the 99th percentile of how far the training's
/// trips ended from the landings it placed: a trip's distance, integrated from 1 Hz speed
/// readings, errs by up to a second's travel at the crawl into a landing, and which second a
/// reading falls in decides it, so the errors are not Gaussian and no standard deviation
/// bounds them. Half as much again covers the 1 % beyond.
pub const LEVEL_MARGIN: f64 = 1.5;

/// Least door cycles of a training that calibrate the door check: about a quiet day's.
pub const DOOR_MIN_CYCLES: usize = 200;

/// Least days of training that calibrate the door check: a door's cycles follow the day's
/// traffic (the evening's full cars, the night's empty ones), and the check's thresholds are
/// a bootstrap of day-long blocks. Three morning hours of a 40-floor tower calibrated a check
/// that raised an advisory on every one of its 19 simulated runs (`evaluate --train-days
/// 0.125`), each door healthy.
pub const DOOR_MIN_DAYS: f64 = 1.0;

/// The reference reopening rate is at least this: a training without reopenings would make
/// every reopening of the field a change.
pub const REOPEN_RATE_FLOOR: f64 = 0.01;

/// A door score's shift within this many healthy day-to-day standard deviations (the
/// wander w of the daily mean score beyond its noise) is no change: each cycle's score enters
/// the CUSUMs as z − 2·w. Busier days have fuller cars and longer cycles; without the
/// allowance a simulated healthy month raised two door advisories, each on a busy day.
pub const DOOR_WANDER_K: f64 = 2.0;

/// A cycle whose duration is off the first least-squares line of the transfer law by more
/// than this many σ̂ is left out of the second: a hold button or a passenger with a trolley
/// is not how the door's time grows with the load that passes it.
pub const TRANSFER_TRIM: f64 = 3.0;

/// The wander w is at least this (score units): a week shows only its own days.
pub const DOOR_WANDER_FLOOR: f64 = 0.1;

/// Years of bootstrapped healthy door cycles per false advisory a year, as for the machine.
pub const DOOR_BOOTSTRAP_YEARS: f64 = 10.0;

/// For this long (s) after an outage ends the car serves the calls that waited through it:
/// fuller cars, longer door cycles, a winding warming from cold, and a machine a technician
/// may just have adjusted. Those door cycles are counted, not scored, and those trips are not
/// machine evidence. Three hours: a winding cold after a long outage takes about three of its
/// 30-60 min time constants to come back within 5 % of its working temperature, and that
/// early rise is where the heating model is least sure (on a simulated 4 h outage the door
/// advisory came 30 min, a machine `friction` advisory 70 min, and, once the evidence took
/// the fit's interpolation weights, a motor advisory 2.5 h after service resumed). Outages
/// are rare, so the evidence this leaves out costs little.
pub const OUTAGE_BACKLOG_S: f64 = 3.0 * HOUR_S;

/// Days of usage kept in the monitor state (trips, door cycles, availability per day).
pub const USAGE_DAYS: usize = 60;

/// Door cycles kept for the figures an event and the verdict quote (median, reopening rate):
/// a few busy hours' worth, about 5 KB of state.
pub const RECENT_CYCLES: usize = 100;

/// The two door scores: cycle duration and reopening.
pub const DOOR_SCORES: [&str; 2] = ["duration", "reopening"];

/// Seed of the door calibration's bootstrap (fixed: a model reproduces from its data).
const DOOR_BOOTSTRAP_SEED: u64 = 0x646f_6f72;

/// Hours in a week: the bins of the trip rate.
const HOURS_PER_WEEK: usize = 168;

/// Hours of speed data in an hour of the week for the training to have seen it, and to give
/// it a rate of its own: a quarter of it, as a training that starts at 10:45 sees its 10:00.
const SEEN_MIN_H: f64 = 0.25;

/// Hours of speed data the monitor needs in an hour of the week its training never saw before
/// it judges silences there at what it counted: nine tenths of the hour, so that a rate is
/// never taken from the first minutes of the hour it then applies to, while the sensors'
/// dropouts of a few minutes do not put it off for a week.
pub const LEARNT_MIN_H: f64 = 0.9;

/// The door check's reference, learnt on healthy cycles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DoorReference {
    /// Median healthy cycle duration (s), as displayed (the scores use `transfer`'s when
    /// there is one).
    pub median_s: f64,
    /// σ̂ = 1.4826·MAD of the healthy durations (s), at least one step.
    pub sigma_s: f64,
    /// Healthy reopenings per cycle p0, at least [`REOPEN_RATE_FLOOR`].
    pub reopen_rate: f64,
    /// Healthy mean m of the clipped scores (duration, reopening).
    pub score_mean: [f64; 2],
    /// Healthy standard deviation s of the clipped scores (duration, reopening).
    pub score_sd: [f64; 2],
    /// w: healthy day-to-day wander of the daily mean score beyond its noise, per score, at
    /// least [`DOOR_WANDER_FLOOR`].
    pub wander: [f64; 2],
    /// h per score and size (log-likelihood ratio units).
    pub h: [[f64; N_SIZES]; 2],
    /// Healthy door cycles scored.
    pub cycles: u64,
    /// Healthy door cycles per day of training.
    pub cycles_per_day: f64,
    /// The duration's dependence on the load passing the door; `None` when the training's
    /// load readings could not measure it (and in models written before it existed): the
    /// plain duration is scored then.
    #[serde(default)]
    pub transfer: Option<DoorTransfer>,
}

/// How long a door cycle lasts beyond its passengers: e = d − b·x (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DoorTransfer {
    /// b: seconds per unit of load exchanged (the load cell's units).
    pub s_per_load: f64,
    /// Median healthy e (s): a cycle's length with nobody passing.
    pub median_s: f64,
    /// σ̂ = 1.4826·MAD of the healthy e (s), at least one step.
    pub sigma_s: f64,
}

impl DoorReference {
    /// Whether cycle `c` is scored against this reference ([`scored_with`]).
    fn scores_cycle(&self, c: &DoorCycle) -> bool {
        scored_with(self.transfer.as_ref(), c)
    }
}

/// Whether cycle `c` is scored with the transfer law `transfer`: a door cycle, not a door
/// held open, and, with a law, one whose exchanged load was read. The training's cycles and
/// the monitor's are chosen by this one test.
fn scored_with(transfer: Option<&DoorTransfer>, c: &DoorCycle) -> bool {
    c.duration_s <= DOOR_CYCLE_MAX_S && (transfer.is_none() || c.exchange.is_finite())
}

/// Everything [`OperationTracker`] compares with, learnt in `fit`; models written before it
/// existed have none, and get usage counts without outages or a door check.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OperationReference {
    /// Trips started per hour of each of the 168 hours of the week (bin ⌊t/3600⌋ mod 168 of
    /// the data clock), from the training.
    pub trips_per_hour: Vec<f64>,
    /// Λ_max: expected trips of a silence that makes an outage.
    pub outage_expected_trips: f64,
    /// The largest Λ of a quiet span of the training.
    pub quiet_max_expected_trips: f64,
    /// Landing heights above the first (m), from the trips' distances; empty when the
    /// training could not place them (then no stuck check).
    pub landings_m: Vec<f64>,
    /// How far (m) a trip may end from a landing and still be level: at least
    /// [`LEVEL_TOLERANCE_M`], wider when the training's trips scattered about the landings
    /// ([`level_tolerance`]); [`LEVEL_TOLERANCE_M`] in models written before it.
    #[serde(default = "default_level_tolerance")]
    pub level_tolerance_m: f64,
    /// The door check; `None` when the training had too few cycles.
    pub door: Option<DoorReference>,
    /// The hours of the week the training never saw (bins, ascending), whose rates the
    /// monitor learns as it watches them ([`OperationTracker`]; module docs, "Why the monitor
    /// learns the hours its training never saw"); empty after a training of a whole week,
    /// after one that did not see every hour of the day, and in models written before.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unseen_hours: Vec<u8>,
    /// Trips started per hour of each hour of the day, pooled over the training's days: the
    /// most a learnt hour's rate may be, as a seen hour's is (module docs, "Why an hour's rate
    /// is at most its hour of the day's"); empty where `unseen_hours` is.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub hour_of_day_rates: Vec<f64>,
}

/// One completed door cycle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DoorCycle {
    /// When the door started to open (s).
    pub start: f64,
    /// Open (signal 1) for this long (s).
    pub duration_s: f64,
    /// It opened within [`REOPEN_WINDOW_S`] of the previous close, no motion between.
    pub reopening: bool,
    /// x: load exchanged at the landing, (L_before − L_min) + (L_after − L_min) in the load
    /// cell's units; NaN when a reading before, during or after the cycle was missing.
    #[serde(with = "exact", default = "crate::exact::nan")]
    pub exchange: f64,
}

/// Why a car is out of service.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutageKind {
    /// Still at a landing through hours it normally travels.
    OutOfService,
    /// Stopped between two landings with the door closed.
    StuckBetweenFloors,
}

/// An out-of-service period, open or closed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outage {
    /// Which kind.
    pub kind: OutageKind,
    /// When the car last moved (s): the period's start.
    #[serde(with = "exact")]
    pub start: f64,
    /// When the car moved again (s), NaN while open.
    #[serde(with = "exact")]
    pub end: f64,
    /// When the monitor concluded it (s).
    #[serde(with = "exact")]
    pub detected_at: f64,
    /// Floor indicator where it stood (NaN unknown).
    #[serde(with = "exact")]
    pub floor: f64,
    /// The door was open when it was concluded.
    pub door_open: bool,
    /// Λ at detection: trips the training expected in that time.
    #[serde(with = "exact")]
    pub expected_trips: f64,
}

impl Outage {
    /// For people: "stopped at floor 3, door open", "stuck between floors 7 and 8".
    pub fn reason(&self) -> String {
        let floor = if self.floor.is_finite() {
            format!("floor {:.0}", self.floor)
        } else {
            "an unknown floor".into()
        };
        match self.kind {
            OutageKind::OutOfService => format!(
                "stopped at {floor}, door {}",
                if self.door_open { "open" } else { "closed" }
            ),
            OutageKind::StuckBetweenFloors => {
                format!("stuck between floors near {floor}, door closed")
            }
        }
    }
}

/// What the tracker reports, one JSON line each in the events file (DATA.md §4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum OperationEvent {
    /// An outage was concluded (its start lies before).
    OutageStart(Outage),
    /// The car moved again.
    OutageEnd(Outage),
    /// The door check changed level: `true` raised the door advisory, `false` released it.
    Door {
        /// When (s).
        #[serde(with = "exact")]
        time: f64,
        /// Raised or released.
        raised: bool,
        /// max G/h over the door CUSUMs.
        #[serde(with = "exact")]
        ratio: f64,
        /// The score whose CUSUM leads ([`DOOR_SCORES`]).
        lead: usize,
        /// Median duration of the recent cycles ([`RECENT_CYCLES`]) (s).
        #[serde(with = "exact")]
        recent_median_s: f64,
        /// Reopenings per cycle of the recent cycles.
        #[serde(with = "exact")]
        recent_reopen_rate: f64,
        /// The reference's median (s).
        #[serde(with = "exact")]
        reference_median_s: f64,
        /// The reference's reopening rate.
        #[serde(with = "exact")]
        reference_reopen_rate: f64,
    },
}

impl OperationEvent {
    /// The time of its line's `time` field: the outage's start (in both of its lines), the
    /// door check's change.
    pub fn time(&self) -> f64 {
        match self {
            OperationEvent::OutageStart(o) | OperationEvent::OutageEnd(o) => o.start,
            OperationEvent::Door { time, .. } => *time,
        }
    }

    /// One JSON object on one line (DATA.md §4): an outage line (`"kind": "outage"`, `time`
    /// its start, `end` null while open) or a door level line (`"kind": "level"`, mode `door`).
    pub fn to_json_line(&self) -> String {
        let num = |x: f64| {
            if x.is_finite() {
                serde_json::json!(x)
            } else {
                serde_json::Value::Null
            }
        };
        let fields: Vec<(&str, serde_json::Value)> = match self {
            OperationEvent::OutageStart(o) | OperationEvent::OutageEnd(o) => vec![
                ("time", num(o.start)),
                ("kind", "outage".into()),
                (
                    "state",
                    if matches!(self, OperationEvent::OutageStart(_)) {
                        "start"
                    } else {
                        "end"
                    }
                    .into(),
                ),
                ("end", num(o.end)),
                ("duration_s", num(o.end - o.start)),
                ("detected_at", num(o.detected_at)),
                (
                    "outage",
                    serde_json::to_value(o.kind).expect("a name always serialises"),
                ),
                ("reason", o.reason().into()),
                ("expected_trips", num(o.expected_trips)),
            ],
            OperationEvent::Door {
                time,
                raised,
                ratio,
                lead,
                recent_median_s,
                recent_reopen_rate,
                reference_median_s,
                reference_reopen_rate,
            } => vec![
                ("time", num(*time)),
                ("kind", "level".into()),
                ("subsystem", "door".into()),
                ("level", if *raised { "advisory" } else { "normal" }.into()),
                ("mode", FaultMode::Door.as_str().into()),
                ("cusum_ratio", num(*ratio)),
                ("cusum_signature", DOOR_SCORES[*lead].into()),
                ("door_cycle_median_s", num(*recent_median_s)),
                ("door_reopen_rate", num(*recent_reopen_rate)),
                ("reference_cycle_median_s", num(*reference_median_s)),
                ("reference_reopen_rate", num(*reference_reopen_rate)),
            ],
        };
        // Written in this order (a serde_json map would sort the keys): `time` first, as in
        // every event line.
        let body: Vec<String> = fields.iter().map(|(k, v)| format!("\"{k}\":{v}")).collect();
        format!("{{{}}}", body.join(","))
    }
}

/// Usage of one day (UTC day of the data clock: ⌊t/86400⌋).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DayUsage {
    /// ⌊t/86400⌋.
    pub day: i64,
    /// Seconds of data seen.
    #[serde(with = "exact")]
    pub observed_s: f64,
    /// Seconds out of service.
    #[serde(with = "exact")]
    pub outage_s: f64,
    /// Trips completed.
    pub trips: u64,
    /// Door cycles completed.
    pub door_cycles: u64,
    /// Of which reopenings.
    pub reopenings: u64,
    /// Sum of the scored cycles' durations (s) and their number, for the day's mean.
    #[serde(with = "exact")]
    pub door_s: f64,
    /// Scored cycles.
    pub scored_cycles: u64,
}

impl DayUsage {
    /// 1 − outage/observed; NaN for a day without data.
    pub fn availability(&self) -> f64 {
        if self.observed_s > 0.0 {
            (1.0 - self.outage_s / self.observed_s).clamp(0.0, 1.0)
        } else {
            f64::NAN
        }
    }

    /// Mean duration of the scored door cycles (s), NaN without any.
    pub fn mean_door_cycle_s(&self) -> f64 {
        if self.scored_cycles > 0 {
            self.door_s / self.scored_cycles as f64
        } else {
            f64::NAN
        }
    }
}

/// The door check's CUSUMs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DoorCheck {
    /// G per score and size.
    #[serde(with = "exact::array")]
    pub g: [f64; 2 * N_SIZES],
    /// The door advisory is raised.
    pub raised: bool,
}

impl DoorCheck {
    /// max G/h and the leading score.
    pub fn ratio(&self, r: &DoorReference) -> (f64, usize) {
        let mut best = (0.0, 0);
        for k in 0..2 {
            for j in 0..N_SIZES {
                let q = self.g[k * N_SIZES + j] / r.h[k][j];
                if q > best.0 {
                    best = (q, k);
                }
            }
        }
        best
    }

    /// Takes one scored cycle's standardised scores; returns the new raised state when it
    /// changed.
    fn push(&mut self, r: &DoorReference, z: [f64; 2]) -> Option<bool> {
        for (k, zk) in z.iter().enumerate() {
            for (j, nu) in SIZES.iter().enumerate() {
                let h = r.h[k][j];
                let g = &mut self.g[k * N_SIZES + j];
                *g = (*g + gaussian_llr(*nu, *zk)).clamp(0.0, 2.0 * h);
            }
        }
        let (ratio, _) = self.ratio(r);
        let was = self.raised;
        if !self.raised && ratio >= 1.0 {
            self.raised = true;
        } else if self.raised && ratio < 0.5 {
            self.raised = false;
        }
        (self.raised != was).then_some(self.raised)
    }
}

/// The clipped raw scores of a cycle (duration, reopening) against `r`.
fn raw_scores(r: &DoorReference, c: &DoorCycle) -> [f64; 2] {
    let p = r.reopen_rate;
    let x = if c.reopening { 1.0 } else { 0.0 };
    let duration = match &r.transfer {
        Some(t) => (c.duration_s - t.s_per_load * c.exchange - t.median_s) / t.sigma_s,
        None => (c.duration_s - r.median_s) / r.sigma_s,
    };
    [
        duration.clamp(-CLIP, CLIP),
        ((x - p) / (p * (1.0 - p)).sqrt()).clamp(-CLIP, CLIP),
    ]
}

/// The standardised scores z of a cycle, clipped to ±[`CLIP`] once more (a reopening
/// standardised by a small p0's spread would otherwise count as ten cycles' evidence).
fn standardised(r: &DoorReference, c: &DoorCycle) -> [f64; 2] {
    let u = raw_scores(r, c);
    [0, 1].map(|k| ((u[k] - r.score_mean[k]) / r.score_sd[k]).clamp(-CLIP, CLIP))
}

/// What a cycle adds to the CUSUMs: z less the day-to-day allowance [`DOOR_WANDER_K`]·w.
fn scores(r: &DoorReference, c: &DoorCycle) -> [f64; 2] {
    let z = standardised(r, c);
    [0, 1].map(|k| z[k] - DOOR_WANDER_K * r.wander[k])
}

/// The smaller of `a` and `b`, NaN when either is (`f64::min` ignores a NaN).
fn nan_min(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.min(b)
    }
}

/// The hour of the week of time `t` (s), 0..[`HOURS_PER_WEEK`]: the bin of
/// [`OperationReference::trips_per_hour`]. Below [`EXACT_INTEGERS`] hours in integers
/// ([`floor_to_i64`]: every sample asks, and `floor` and a float remainder are calls on the
/// baseline x86-64 target), beyond them as floats; both give the bin the floats give.
fn hour_bin(t: f64) -> usize {
    let hours = t / HOUR_S;
    if hours.abs() < EXACT_INTEGERS {
        // Same value: the float floor of such an hour is an integer the float remainder
        // divides exactly.
        floor_to_i64(hours).rem_euclid(HOURS_PER_WEEK as i64) as usize
    } else {
        (hours.floor().rem_euclid(HOURS_PER_WEEK as f64)) as usize % HOURS_PER_WEEK
    }
}

/// The day of time `t` (s): ⌊t / 86,400⌋.
fn day_of(t: f64) -> i64 {
    floor_to_i64(t / DAY_S)
}

/// 2⁵³: below it in magnitude every integer is a float, and the float remainder of one by
/// a small integer is exact.
const EXACT_INTEGERS: f64 = 9_007_199_254_740_992.0;

/// `q.floor() as i64` for every `q` (NaN 0, saturating beyond the range) without the call
/// `floor` is on the baseline x86-64 target: the truncation toward zero, one less when it
/// lies above `q` (a negative `q` with a fraction). Where the truncation is beyond 2⁵³ in
/// magnitude `q` is an integer already and nothing is taken off.
fn floor_to_i64(q: f64) -> i64 {
    let i = q as i64;
    if i as f64 > q {
        i.saturating_sub(1)
    } else {
        i
    }
}

/// Bins a [`BinMemo`] remembers: 0 to 2³⁰, where b·w is exact for the day's 86,400 s
/// (below 2⁵³) and every clock of DATA.md lies (relative from 0, Unix time from 1970).
const MEMO_BINS: i64 = 1 << 30;

/// ⌊t/w⌋ of the last time asked, with the span of times certain to give the same bin: the
/// operation tracker asks each sample for its hour and its day, and a division and a floor
/// per question were a third of the tracker's time in `perf` (a 30-day `monitor` run). A
/// time in the span returns what [`floor_to_i64`]`(t / w)` returns: t/w rounded is monotone
/// in t, the span starts at b·w (exact, so t/w ≥ b there) and ends 2⁻⁵⁰ of its end below
/// (b+1)·w (so t/w, rounded to 2⁻⁵³, stays below b+1). Not state: never saved, equal to any
/// other memo.
#[derive(Clone, Copy, Debug)]
struct BinMemo {
    lo: f64,
    hi: f64,
    bin: i64,
}

impl Default for BinMemo {
    fn default() -> Self {
        BinMemo {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            bin: 0,
        }
    }
}

impl PartialEq for BinMemo {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl BinMemo {
    /// ⌊t/w⌋ (`w` positive) when it lies in 0..[`MEMO_BINS`], remembered; `None` otherwise.
    fn floor_div(&mut self, t: f64, w: f64) -> Option<i64> {
        if t >= self.lo && t <= self.hi {
            return Some(self.bin);
        }
        let b = floor_to_i64(t / w);
        if !(0..MEMO_BINS).contains(&b) {
            return None;
        }
        *self = BinMemo {
            lo: b as f64 * w,
            hi: (b + 1) as f64 * w * (1.0 - 4.0 * f64::EPSILON),
            bin: b,
        };
        Some(b)
    }
}

/// What the monitor counted in one hour of the week its training never saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HourCount {
    /// Hours of speed data watched in it, over every week so far.
    pub hours: f64,
    /// Trips started in those hours.
    pub starts: f64,
}

/// The hour of the week under way, when the training never saw it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct HourWatch {
    /// Its bin.
    bin: u8,
    /// What it counted so far.
    count: HourCount,
    /// An outage was under way in it: it is left out.
    outage: bool,
}

/// The streaming tracker: door cycles, outages, daily usage and the door check. Saved and
/// resumed inside the monitor's state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OperationTracker {
    #[serde(with = "exact")]
    door_prev: f64,
    #[serde(with = "exact")]
    open_since: f64,
    #[serde(with = "exact")]
    last_close: f64,
    moved_since_close: bool,
    /// The last load reading while the door was closed (NaN: none yet, or missing).
    #[serde(with = "exact", default = "crate::exact::nan")]
    load_closed: f64,
    /// The lowest load reading of the open door so far, its readings before included (NaN
    /// once one was missing).
    #[serde(with = "exact", default = "crate::exact::nan")]
    load_min: f64,
    /// The last floor reading (NaN: none yet).
    #[serde(with = "exact", default = "crate::exact::nan")]
    floor_prev: f64,
    /// Time of the last moving sample, or of the first sample (s).
    #[serde(with = "exact")]
    rest_since: f64,
    /// Λ since `rest_since`.
    #[serde(with = "exact")]
    expected: f64,
    /// Λ since `rest_since` with the hours the training never saw and the monitor has not
    /// yet learnt at their hour of the day's pooled rate (Λ itself takes their quietest
    /// rate): a silence it would have called an outage was, perhaps, one, and the calls that
    /// waited follow as after an outage (`out_of_use_end`). 0 while every hour has a rate.
    #[serde(with = "exact", default)]
    expected_pooled: f64,
    /// Seconds at rest since `rest_since`, per day, until an outage claims them.
    pending: Vec<(i64, f64)>,
    /// A trip that ended between landings: its end time (s).
    #[serde(with = "exact")]
    between_since: f64,
    /// The outage under way.
    pub open: Option<Outage>,
    /// The last outage that ended.
    pub last_outage: Option<Outage>,
    /// When the car last came back into use after standing out of it unjudged (NaN: never):
    /// a door held open for [`OUTAGE_MIN_S`] or more closed, an outage or not, or a silence
    /// ended that Λ at the pooled rates (`expected_pooled`) called an outage in hours the
    /// monitor had not yet learnt. The calls that waited follow as after an outage.
    #[serde(with = "exact", default = "crate::exact::nan", alias = "held_open_end")]
    out_of_use_end: f64,
    /// Outages concluded.
    pub outages: u64,
    /// The door check.
    pub door: DoorCheck,
    /// The last [`RECENT_CYCLES`] scored cycles, for the figures an event quotes.
    recent: VecDeque<DoorCycle>,
    /// Usage per day, the last [`USAGE_DAYS`].
    pub days: VecDeque<DayUsage>,
    /// Events not yet handed out (at most one leaves per sample).
    queue: VecDeque<OperationEvent>,
    /// Per hour of the week, for the hours the training never saw: hours of speed data
    /// watched and trips started in them over the hours gone by, outages left out (`None` for
    /// the hours it saw; empty until a reference with unseen hours is first given, and in
    /// older states, which then start counting).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    learnt: Vec<Option<HourCount>>,
    /// The hour under way, counted apart until it ends: a silence is never judged at a rate
    /// it is lowering itself.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    watching: Option<HourWatch>,
    /// The hour and the day of the last sample ([`BinMemo`]).
    #[serde(skip)]
    hour_memo: BinMemo,
    #[serde(skip)]
    day_memo: BinMemo,
}

impl Default for OperationTracker {
    fn default() -> Self {
        OperationTracker::new()
    }
}

impl OperationTracker {
    /// Nothing seen yet.
    pub fn new() -> Self {
        OperationTracker {
            door_prev: f64::NAN,
            open_since: f64::NAN,
            last_close: f64::NAN,
            moved_since_close: false,
            load_closed: f64::NAN,
            load_min: f64::NAN,
            floor_prev: f64::NAN,
            rest_since: f64::NAN,
            expected: 0.0,
            expected_pooled: 0.0,
            pending: Vec::new(),
            between_since: f64::NAN,
            open: None,
            last_outage: None,
            out_of_use_end: f64::NAN,
            outages: 0,
            door: DoorCheck::default(),
            recent: VecDeque::new(),
            days: VecDeque::new(),
            queue: VecDeque::new(),
            learnt: Vec::new(),
            watching: None,
            hour_memo: BinMemo::default(),
            day_memo: BinMemo::default(),
        }
    }

    /// The trip rates of hour of the week `h`: the one its silence is judged at (Λ), and the
    /// one of `expected_pooled`. Λ's is the reference's or, for an hour the training never saw
    /// and the monitor since watched for [`LEARNT_MIN_H`], the rate it counted there, at most
    /// its hour of the day's over the training. The pooled one is that hour of the day's
    /// while the hour is unseen and not yet learnt, else Λ's.
    fn rates(&self, h: usize, r: &OperationReference) -> (f64, f64) {
        let of_day = r.hour_of_day_rates.get(h % 24).copied();
        let seen = r.trips_per_hour.get(h).copied().unwrap_or(0.0);
        match self.learnt.get(h) {
            Some(Some(c)) if c.hours >= LEARNT_MIN_H => {
                let own = own_rate(c.starts, c.hours, of_day.unwrap_or(0.0));
                (own, own)
            }
            Some(Some(c)) if c.hours < LEARNT_MIN_H => (seen, of_day.unwrap_or(seen)),
            _ => (seen, seen),
        }
    }

    /// Counts the sample at `t` into its hour of the week when the training never saw that
    /// hour: its hours of speed data (the trips it starts are counted by [`Self::trip`], from
    /// the trips the features stage found, as the training counts them). An hour is added to
    /// what was learnt when it ends, unless an outage was under way in it: a car out of
    /// service says nothing of the building's traffic.
    fn learn_hour(&mut self, t: f64, step_s: f64, r: &OperationReference) {
        if r.unseen_hours.is_empty() {
            return;
        }
        if self.learnt.len() != HOURS_PER_WEEK {
            self.learnt = vec![None; HOURS_PER_WEEK];
            for &h in &r.unseen_hours {
                if let Some(c) = self.learnt.get_mut(usize::from(h)) {
                    *c = Some(HourCount::default());
                }
            }
        }
        let h = self.hour_bin(t);
        let w = match self.watching.as_mut() {
            Some(w) if usize::from(w.bin) == h => w,
            _ => {
                if let Some(w) = self.watching.take().filter(|w| !w.outage) {
                    if let Some(Some(c)) = self.learnt.get_mut(usize::from(w.bin)) {
                        c.hours += w.count.hours;
                        c.starts += w.count.starts;
                    }
                }
                let Some(Some(_)) = self.learnt.get(h) else {
                    return;
                };
                self.watching.insert(HourWatch {
                    bin: u8::try_from(h).unwrap_or(u8::MAX),
                    count: HourCount::default(),
                    outage: false,
                })
            }
        };
        if self.open.is_some() {
            w.outage = true;
        } else {
            w.count.hours += step_s / HOUR_S;
        }
    }

    /// Counts a trip that started at `start` into its hour of the week, when the monitor
    /// learns that hour: into the hour under way, or into the hour before when the trip
    /// crossed into this one (that hour's hours were added when it ended). Not in an hour an
    /// outage was under way in, whose hours were left out.
    fn learn_start(&mut self, start: f64) {
        if self.learnt.is_empty() || !start.is_finite() {
            return;
        }
        let h = hour_bin(start);
        match self.watching.as_mut() {
            Some(w) if usize::from(w.bin) == h => {
                if !w.outage {
                    w.count.starts += 1.0;
                }
            }
            _ => {
                let hour_start = (start / HOUR_S).floor() * HOUR_S;
                let outage_in_it = self.last_outage.is_some_and(|o| o.end >= hour_start);
                if let Some(Some(c)) = self.learnt.get_mut(h).filter(|_| !outage_in_it) {
                    c.starts += 1.0;
                }
            }
        }
    }

    /// [`hour_bin`] of `t`, through the memo.
    fn hour_bin(&mut self, t: f64) -> usize {
        match self.hour_memo.floor_div(t, HOUR_S) {
            Some(h) => h.rem_euclid(HOURS_PER_WEEK as i64) as usize,
            None => hour_bin(t),
        }
    }

    /// [`day_of`] `t`, through the memo.
    fn day_of(&mut self, t: f64) -> i64 {
        self.day_memo
            .floor_div(t, DAY_S)
            .unwrap_or_else(|| day_of(t))
    }

    fn day_mut(&mut self, t: f64) -> &mut DayUsage {
        let d = self.day_of(t);
        // The last sample's day, on all but the first sample of a day.
        let n = self.days.len();
        if n > 0 && self.days[n - 1].day == d {
            return &mut self.days[n - 1];
        }
        if self.days.back().map_or(true, |u| u.day < d) {
            self.days.push_back(DayUsage {
                day: d,
                ..DayUsage::default()
            });
            while self.days.len() > USAGE_DAYS {
                self.days.pop_front();
            }
        }
        // A day before the last one kept (input never goes back; the guard keeps it safe).
        let i = self.days.iter().rposition(|u| u.day <= d).unwrap_or(0);
        &mut self.days[i]
    }

    /// Feeds one aligned sample of step `step_s`; returns the door cycle it completed.
    /// `thr` is the motion threshold (m/s); `r` the reference (None: usage counts only).
    pub fn push(
        &mut self,
        x: &Sample,
        step_s: f64,
        thr: f64,
        r: Option<&OperationReference>,
    ) -> Option<DoorCycle> {
        let t = x.time;
        if !t.is_finite() {
            return None;
        }
        self.day_mut(t).observed_s += step_s;
        if self.rest_since.is_nan() {
            self.rest_since = t;
        }
        let moving = x.speed.is_finite() && x.speed > thr;
        let at_rest = x.speed.is_finite() && !moving;
        if let Some(r) = r.filter(|_| x.speed.is_finite()) {
            self.learn_hour(t, step_s, r);
        }
        // A door that opens or a floor reading that changes is a car in use, whatever the
        // speed reads (a speed sensor stuck at zero on a travelling car is a sensor fault,
        // named as one, not an outage): the silence starts again, an outage under way stays.
        let used = (self.door_prev == 0.0 && x.door.is_finite() && x.door != 0.0)
            || (x.floor.is_finite() && self.floor_prev.is_finite() && x.floor != self.floor_prev);
        if x.floor.is_finite() {
            self.floor_prev = x.floor;
        }
        if used && !moving && self.open.is_none() {
            self.end_silence(t, r);
        }
        if moving {
            self.moved_since_close = true;
            self.between_since = f64::NAN;
            if let Some(mut o) = self.open.take() {
                o.end = t;
                self.queue.push_back(OperationEvent::OutageEnd(o));
                self.last_outage = Some(o);
                self.restart_silence(t);
            } else {
                self.end_silence(t, r);
            }
        } else if self.open.is_some() {
            self.day_mut(t).outage_s += step_s;
        } else if at_rest {
            if let Some(r) = r {
                let h = self.hour_bin(t);
                let (rate, pooled) = self.rates(h, r);
                self.expected += rate * step_s / HOUR_S;
                if !self.learnt.is_empty() {
                    self.expected_pooled += pooled * step_s / HOUR_S;
                }
            }
            let d = self.day_of(t);
            match self.pending.last_mut() {
                Some((day, s)) if *day == d => *s += step_s,
                _ => self.pending.push((d, step_s)),
            }
            if let Some(r) = r {
                self.check_outage(x, r);
            }
        }
        let cycle = self.door_step(x);
        if let (Some(c), Some(dr)) = (cycle, r.and_then(|r| r.door.as_ref())) {
            let backlog = c.start - self.back_in_use() < OUTAGE_BACKLOG_S;
            if dr.scores_cycle(&c) && self.open.is_none() && !backlog {
                self.score_cycle(&c, dr);
            }
        }
        cycle
    }

    /// The car was in use at `t`: the silence, its Λ and its unclaimed rest start again.
    fn restart_silence(&mut self, t: f64) {
        self.rest_since = t;
        self.expected = 0.0;
        self.expected_pooled = 0.0;
        self.pending.clear();
    }

    /// The car, in no outage, was in use at `t`: a silence that the pooled rates of the hours
    /// not yet learnt would have called an outage ended (its calls follow as a backlog), and
    /// the next starts.
    fn end_silence(&mut self, t: f64, r: Option<&OperationReference>) {
        let unjudged = r.is_some_and(|r| {
            self.expected_pooled >= r.outage_expected_trips
                && self.expected < r.outage_expected_trips
                && t - self.rest_since >= OUTAGE_MIN_S
        });
        if unjudged {
            self.out_of_use_end = t;
        }
        self.restart_silence(t);
    }

    /// Opens an outage when the silence is long and unlikely enough, or the car stands
    /// between landings.
    fn check_outage(&mut self, x: &Sample, r: &OperationReference) {
        let t = x.time;
        let door_closed = x.door == 0.0;
        // A door that opened since that trip ended stands at a landing, whatever the trip's
        // distance said: landing doors unlock only within 0.2 m of a landing (0.35 m with
        // manual doors; EN 81-20's unlocking zone). The hop that frees a stuck car starts
        // off its landing, and from the landing its floor reading names, it ends "between".
        let opened_since = self.last_close >= self.between_since;
        let stuck = self.between_since.is_finite()
            && door_closed
            && !opened_since
            && t - self.between_since >= STUCK_LIMIT_S;
        let quiet = self.expected >= r.outage_expected_trips && t - self.rest_since >= OUTAGE_MIN_S;
        if !(stuck || quiet) {
            return;
        }
        let (kind, start) = if stuck {
            (
                OutageKind::StuckBetweenFloors,
                self.between_since.max(self.rest_since),
            )
        } else {
            (OutageKind::OutOfService, self.rest_since)
        };
        let o = Outage {
            kind,
            start,
            end: f64::NAN,
            detected_at: t,
            floor: x.floor,
            door_open: x.door == 1.0,
            expected_trips: self.expected,
        };
        for (day, s) in std::mem::take(&mut self.pending) {
            if let Some(u) = self.days.iter_mut().find(|u| u.day == day) {
                u.outage_s += s;
            }
        }
        self.open = Some(o);
        self.outages = self.outages.saturating_add(1);
        self.queue.push_back(OperationEvent::OutageStart(o));
    }

    /// Door cycle bookkeeping at one sample.
    fn door_step(&mut self, x: &Sample) -> Option<DoorCycle> {
        let t = x.time;
        let d = x.door;
        let mut out = None;
        if d.is_nan() {
            self.open_since = f64::NAN;
        } else if self.door_prev == 0.0 && d != 0.0 {
            self.open_since = t;
            // NaN propagates through min: a missing reading spoils the cycle's exchange.
            self.load_min = nan_min(self.load_closed, x.load);
        } else if d != 0.0 {
            self.load_min = nan_min(self.load_min, x.load);
        } else if self.door_prev != 0.0 && !self.door_prev.is_nan() && d == 0.0 {
            if self.open_since.is_finite() {
                let reopening = self.last_close.is_finite()
                    && self.open_since - self.last_close <= REOPEN_WINDOW_S
                    && !self.moved_since_close;
                let low = nan_min(self.load_min, x.load);
                let c = DoorCycle {
                    start: self.open_since,
                    duration_s: t - self.open_since,
                    reopening,
                    exchange: (self.load_closed - low) + (x.load - low),
                };
                if c.duration_s >= OUTAGE_MIN_S {
                    self.out_of_use_end = t;
                }
                let u = self.day_mut(t);
                u.door_cycles += 1;
                u.reopenings += u64::from(reopening);
                if c.duration_s <= DOOR_CYCLE_MAX_S {
                    u.door_s += c.duration_s;
                    u.scored_cycles += 1;
                    self.recent.push_back(c);
                    while self.recent.len() > RECENT_CYCLES {
                        self.recent.pop_front();
                    }
                }
                out = Some(c);
            }
            self.open_since = f64::NAN;
            self.last_close = t;
            self.moved_since_close = false;
        }
        if d == 0.0 {
            self.load_closed = x.load;
        }
        self.door_prev = d;
        out
    }

    fn score_cycle(&mut self, c: &DoorCycle, r: &DoorReference) {
        let Some(raised) = self.door.push(r, scores(r, c)) else {
            return;
        };
        let (ratio, lead) = self.door.ratio(r);
        let durations: Vec<f64> = self.recent.iter().map(|c| c.duration_s).collect();
        let n = self.recent.len().max(1) as f64;
        let reopen = self.recent.iter().filter(|c| c.reopening).count() as f64 / n;
        self.queue.push_back(OperationEvent::Door {
            time: c.start + c.duration_s,
            raised,
            ratio,
            lead,
            recent_median_s: median(&durations),
            recent_reopen_rate: reopen,
            reference_median_s: r.median_s,
            reference_reopen_rate: r.reopen_rate,
        });
    }

    /// A trip the features stage reported: counted for the day and, in an hour the training
    /// never saw, for its hour; and checked for an end between landings.
    pub fn trip(&mut self, t: &Trip, r: Option<&OperationReference>) {
        self.day_mut(t.end_time).trips += 1;
        self.learn_start(t.start_time);
        self.between_since = f64::NAN;
        let Some(r) = r else { return };
        if let Some(off) = level_offset(&r.landings_m, t) {
            if off > r.level_tolerance_m {
                self.between_since = t.end_time;
            }
        }
    }

    /// True while an outage is under way or its backlog is served: from its start to
    /// [`OUTAGE_BACKLOG_S`] after its end (or after a door held open as long as an outage
    /// lasts at least closed), `t` (s) in it.
    pub fn serving_backlog(&self, t: f64) -> bool {
        self.open.is_some() || t - self.back_in_use() < OUTAGE_BACKLOG_S
    }

    /// When the car last came back into use after standing out of it: the end of the last
    /// outage, or the close of a door held open for [`OUTAGE_MIN_S`], whichever is later
    /// (−∞ when neither happened).
    fn back_in_use(&self) -> f64 {
        // `max` passes over the NaN of a door never held open.
        let outage = self.last_outage.map_or(f64::NEG_INFINITY, |o| o.end);
        self.out_of_use_end.max(outage)
    }

    /// The next event, at most one per call (the monitor takes one per sample).
    pub fn take_event(&mut self) -> Option<OperationEvent> {
        self.queue.pop_front()
    }

    /// Availability over the last `n` days kept (observed-time weighted), NaN without data.
    pub fn availability(&self, n: usize) -> f64 {
        let (mut obs, mut out) = (0.0, 0.0);
        for u in self.days.iter().rev().take(n) {
            obs += u.observed_s;
            out += u.outage_s;
        }
        if obs > 0.0 {
            (1.0 - out / obs).clamp(0.0, 1.0)
        } else {
            f64::NAN
        }
    }

    /// The recent cycles ([`RECENT_CYCLES`]): median duration (s), reopenings per cycle and
    /// their number.
    pub fn recent_doors(&self) -> (f64, f64, usize) {
        let d: Vec<f64> = self.recent.iter().map(|c| c.duration_s).collect();
        let n = self.recent.len();
        let r = self.recent.iter().filter(|c| c.reopening).count() as f64 / n.max(1) as f64;
        (median(&d), if n > 0 { r } else { f64::NAN }, n)
    }
}

/// Distance (m) from where trip `t` ended to the nearest landing, the trip's start taken as
/// level with its `from_floor`; None when the start floor or the landings are unknown, or
/// when the end lies beyond the end landings by more than [`LEVEL_TOLERANCE_M`] (no car stands
/// outside its shaft: that trip is a speed reading's, not the car's).
pub fn level_offset(landings_m: &[f64], t: &Trip) -> Option<f64> {
    if !t.from_floor.is_finite() || t.from_floor < 1.0 || !t.distance_m.is_finite() {
        return None;
    }
    let from = landings_m.get(t.from_floor as usize - 1)?;
    let x = from + f64::from(t.direction) * t.distance_m;
    let (low, high) = landings_m
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    if x < low - LEVEL_TOLERANCE_M || x > high + LEVEL_TOLERANCE_M {
        // No car stands outside its shaft: the speed reading travelled, not the car (a
        // speed sensor stuck at a travelling value makes an hour-long "trip" kilometres long).
        return None;
    }
    landings_m
        .iter()
        .map(|h| (h - x).abs())
        .min_by(f64::total_cmp)
}

fn default_level_tolerance() -> f64 {
    LEVEL_TOLERANCE_M
}

/// The training's trips between two landings as (from, to, signed distance), landings
/// counted from 0.
fn landing_trips(trips: &[Trip], floors: usize) -> Vec<(usize, usize, f64)> {
    let floor_of = |f: f64| {
        (f.is_finite() && f >= 1.0 && f <= floors as f64 && f.fract() == 0.0)
            .then(|| f as usize - 1)
    };
    trips
        .iter()
        .filter_map(|t| {
            let (a, b) = (floor_of(t.from_floor)?, floor_of(t.to_floor)?);
            (a != b && t.distance_m.is_finite())
                .then(|| (a, b, f64::from(t.direction) * t.distance_m))
        })
        .collect()
}

/// How far a healthy trip may end from a landing of `heights` (placed by [`learn_landings`]
/// from the same trips): [`LEVEL_MARGIN`] times the 99th percentile of the trips' misclosures
/// |h\[to\] − h\[from\] − distance|, at least [`LEVEL_TOLERANCE_M`].
pub fn level_tolerance(trips: &[Trip], floors: usize, heights: &[f64]) -> f64 {
    if heights.len() != floors {
        return LEVEL_TOLERANCE_M;
    }
    let mut misclosure: Vec<f64> = landing_trips(trips, floors)
        .iter()
        .map(|&(a, b, d)| (heights[b] - heights[a] - d).abs())
        .collect();
    if misclosure.is_empty() {
        return LEVEL_TOLERANCE_M;
    }
    misclosure.sort_by(f64::total_cmp);
    (LEVEL_MARGIN * sorted_quantile(&misclosure, 0.99)).max(LEVEL_TOLERANCE_M)
}

/// Landing heights above the first from the trips' floors and distances: h\[to\] − h\[from\] =
/// direction·distance, solved by medians in turn (Gauss-Seidel), robust to odd trips. Empty
/// when some landing was never reached.
pub fn learn_landings(trips: &[Trip], floors: usize) -> Vec<f64> {
    let obs = landing_trips(trips, floors);
    let mut seen = vec![false; floors];
    for &(a, b, _) in &obs {
        seen[a] = true;
        seen[b] = true;
    }
    if floors < 2 || seen.iter().any(|s| !s) {
        return Vec::new();
    }
    // Start from the mean storey of the trips, then refine each landing by the median of
    // what every trip touching it says, a few dozen rounds (converges in a handful).
    let storey = {
        let per: Vec<f64> = obs
            .iter()
            .map(|&(a, b, d)| d / (b as f64 - a as f64))
            .collect();
        median(&per)
    };
    let mut h: Vec<f64> = (0..floors).map(|f| f as f64 * storey).collect();
    let mut votes: Vec<Vec<f64>> = vec![Vec::new(); floors];
    for _ in 0..30 {
        for v in &mut votes {
            v.clear();
        }
        for &(a, b, d) in &obs {
            votes[b].push(h[a] + d);
            votes[a].push(h[b] - d);
        }
        for f in 1..floors {
            h[f] = median(&votes[f]);
        }
    }
    h
}

/// The rate [`hourly_rates`] gives an hour of the week the training never saw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Unseen {
    /// The quietest rate the training saw: the monitor's rule (module docs, "Why the
    /// quietest rate").
    Quietest,
    /// Its hour of the day's, pooled over the days seen: the rule of the other days' rates
    /// that measure a training day's silences (module docs, "Why the other days' rates").
    HourOfDay,
}

/// Hours with speed data and trip starts per hour of the week.
#[derive(Clone, Debug)]
struct WeekCounts {
    hours: [f64; HOURS_PER_WEEK],
    starts: [f64; HOURS_PER_WEEK],
}

impl Default for WeekCounts {
    fn default() -> Self {
        WeekCounts {
            hours: [0.0; HOURS_PER_WEEK],
            starts: [0.0; HOURS_PER_WEEK],
        }
    }
}

impl WeekCounts {
    fn add(&mut self, o: &WeekCounts) {
        for b in 0..HOURS_PER_WEEK {
            self.hours[b] += o.hours[b];
            self.starts[b] += o.starts[b];
        }
    }

    /// Trips started per hour over all the hours these counts saw.
    fn rate(&self) -> f64 {
        self.starts.iter().sum::<f64>() / self.hours.iter().sum::<f64>()
    }
}

/// A day's traffic is like another's when their trip rates are within this factor: an
/// office's weekend runs at a quarter of its weekdays, a busy weekday within a third of a
/// quiet one.
pub const SIMILAR_DAY_FACTOR: f64 = 2.0;

/// The training days (each with its trip rate) other than `days[i]` whose trip rate is
/// within [`SIMILAR_DAY_FACTOR`] of its own; the nearest one in ratio when none is.
fn similar_days(days: &[(i64, f64, WeekCounts)], i: usize) -> Vec<&WeekCounts> {
    let rate = days[i].1;
    let others = days
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != i)
        .map(|(_, (_, r, c))| ((r / rate).ln().abs(), c));
    let near: Vec<&WeekCounts> = others
        .clone()
        .filter(|(ratio, _)| *ratio <= SIMILAR_DAY_FACTOR.ln())
        .map(|(_, c)| c)
        .collect();
    if near.is_empty() {
        others
            .filter(|(ratio, _)| ratio.is_finite())
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, c)| c)
            .into_iter()
            .collect()
    } else {
        near
    }
}

/// The trip rate per hour of the week from the `hours` with speed data and the trip `starts`
/// in each: an hour of the week seen for at least a quarter of an hour has its own rate, or
/// its hour of the day's pooled over the training when that is lower (module docs: one
/// hour's count is noisy); the others take the quietest rate the training saw (a training of
/// three weekdays knows no Saturday). All 0 when the hours do not cover every hour of the day
/// (module docs, "Why a whole day": those hours say nothing of another day's same hours, nor
/// its quietest span of a quiet day).
fn hourly_rates(
    hours: &[f64; HOURS_PER_WEEK],
    starts: &[f64; HOURS_PER_WEEK],
    unseen: Unseen,
) -> Vec<f64> {
    let seen = |b: usize| hours[b] >= SEEN_MIN_H;
    let by_day = hour_of_day_rates(hours, starts);
    let pooled = |b: usize| by_day[b % 24];
    let own = |b: usize| own_rate(starts[b], hours[b], pooled(b));
    let quietest = (0..HOURS_PER_WEEK)
        .filter(|&b| seen(b))
        .map(own)
        .fold(f64::INFINITY, f64::min);
    let whole_day = by_day.iter().all(|r| r.is_finite());
    (0..HOURS_PER_WEEK)
        .map(|b| {
            if !whole_day {
                0.0
            } else if seen(b) {
                own(b)
            } else if unseen == Unseen::HourOfDay {
                pooled(b)
            } else {
                quietest
            }
        })
        .collect()
}

/// An hour of the week's own rate, `starts` trips in `hours` of data, at most `pooled`, its
/// hour of the day's (module docs, "Why an hour's rate is at most its hour of the day's"):
/// the rule of a seen hour in the training and of an unseen one the monitor has watched.
fn own_rate(starts: f64, hours: f64, pooled: f64) -> f64 {
    (starts / hours).min(pooled)
}

/// Each hour of the day's trip rate pooled over the hours of the week seen for
/// [`SEEN_MIN_H`]; NaN for an hour of the day no day saw.
fn hour_of_day_rates(hours: &[f64; HOURS_PER_WEEK], starts: &[f64; HOURS_PER_WEEK]) -> [f64; 24] {
    let mut by_day = [(0.0f64, 0.0f64); 24];
    for b in (0..HOURS_PER_WEEK).filter(|&b| hours[b] >= SEEN_MIN_H) {
        by_day[b % 24].0 += starts[b];
        by_day[b % 24].1 += hours[b];
    }
    by_day.map(|(n, h)| if h > 0.0 { n / h } else { f64::NAN })
}

/// A silence of the training: the car at rest and unused from `start` to `end` (s), the
/// trips its hours' rates expected meanwhile (Λ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Silence {
    /// Its start: the last motion, door opening or floor change before it (s).
    pub start: f64,
    /// Its last sample (s).
    pub end: f64,
    /// Λ at its end.
    pub expected_trips: f64,
}

/// What [`OperationReference::learn`] learns: the reference, and the training's silences
/// that were outages by the monitor's rule (longest first), left out of Λ_max.
#[derive(Clone, Debug)]
pub struct Learnt {
    /// The reference the monitor judges by.
    pub reference: OperationReference,
    /// The training's own outages.
    pub outages: Vec<Silence>,
}

/// Λ_max from the largest Λ of a healthy silence: [`OUTAGE_MARGIN`] times it, at least
/// [`OUTAGE_MIN_EXPECTED_TRIPS`].
fn outage_limit(quiet: f64) -> f64 {
    (OUTAGE_MARGIN * quiet).max(OUTAGE_MIN_EXPECTED_TRIPS)
}

/// The longest silences of the training whose excesses measure the scale of a long silence
/// ([`tail_limit`]): thirty, a scale known within about a fifth.
pub const TAIL_SILENCES: usize = 30;

/// Fewest silences beyond the threshold for [`tail_limit`] to measure a scale at all (a
/// 95 % bound on ten excesses is 1.7 times their mean).
pub const TAIL_MIN_SILENCES: usize = 10;

/// The Λ of a silence that a healthy car reaches once in `1/target` years, from the tail of
/// the training's silences (`sorted` by Λ, longest first, its own outages left out; module
/// docs, "Why the tail of the silences"):
///
/// ```text
/// u = Λ of the (k+1)-th longest,  k = min(TAIL_SILENCES, silences − 1)
/// κ̂ = mean(Λ_i − u) over the k longest        excess beyond u ~ exponential of scale κ
/// κ₉₅ = 2k·κ̂/χ²₀.₀₅(2k)                       upper 95 % bound (2kκ̂/κ ~ χ²(2k))
/// n = k·365.25/span_days                      silences beyond u per year
/// Λ_tail = u + κ₉₅·ln(n/target)
/// ```
///
/// `None` when fewer than [`TAIL_MIN_SILENCES`] silences pass u.
pub fn tail_limit(sorted: &[Silence], span_days: f64, target: f64) -> Option<f64> {
    let k = TAIL_SILENCES.min(sorted.len().checked_sub(1)?);
    if k < TAIL_MIN_SILENCES || !(span_days > 0.0 && target > 0.0) {
        return None;
    }
    let u = sorted[k].expected_trips;
    let excess = sorted[..k]
        .iter()
        .map(|s| s.expected_trips - u)
        .sum::<f64>()
        / k as f64;
    let dof = 2.0 * k as f64;
    let scale = dof * excess / chi_square_quantile(0.05, dof);
    let per_year = k as f64 * YEAR_DAYS / span_days;
    Some(u + scale * (per_year / target).ln().max(0.0))
}

/// How many of the longest silences (`sorted` by Λ, longest first) were outages: the
/// longest is one when it reached the Λ_max the silences after it set, and lasted
/// [`OUTAGE_MIN_S`], as the monitor asks; then the next is judged by the ones after it, and
/// so on. Each is what the monitor, fitted on the rest of the training, would call an
/// outage. Two silences of like length shield each other: a habit of the building (a lunch
/// break on two days) is not told from two outages, and both stay. At least one silence is
/// kept to judge by.
fn training_outages(sorted: &[Silence]) -> usize {
    sorted
        .windows(2)
        .take_while(|w| {
            let (s, rest) = (w[0], w[1].expected_trips);
            s.expected_trips >= outage_limit(rest) && s.end - s.start >= OUTAGE_MIN_S
        })
        .count()
}

impl OperationReference {
    /// Learns the reference on a healthy history: its samples (step `step_s`, motion
    /// threshold `thr`), the trips the features stage found in it, `floors` landings, and
    /// the alarm budget `target` (false door advisories per year). The silences of the
    /// history that were outages by the monitor's own rule come back beside it, left out of
    /// Λ_max (module docs, "Why the training's own outages are left out of it").
    ///
    /// # Errors
    /// As [`History::read`]: the history is read twice.
    pub fn learn(
        history: &dyn History,
        trips: &[Trip],
        thr: f64,
        floors: usize,
        target: f64,
    ) -> Result<Learnt> {
        let step_s = history.step_s();
        // Trip rate per hour of the week, over the hours with speed data; and the same
        // counts per day of the training, for the rates that leave one day out.
        let mut hours = [0.0f64; HOURS_PER_WEEK];
        let mut starts = [0.0f64; HOURS_PER_WEEK];
        let mut per_day: BTreeMap<i64, WeekCounts> = BTreeMap::new();
        let n_samples = pass(history, |samples| {
            let mut n = 0usize;
            for x in samples {
                n += 1;
                if x.time.is_finite() && x.speed.is_finite() {
                    hours[hour_bin(x.time)] += step_s / HOUR_S;
                    per_day.entry(day_of(x.time)).or_default().hours[hour_bin(x.time)] +=
                        step_s / HOUR_S;
                }
            }
            n
        })?;
        for t in trips {
            starts[hour_bin(t.start_time)] += 1.0;
            if t.start_time.is_finite() {
                per_day.entry(day_of(t.start_time)).or_default().starts[hour_bin(t.start_time)] +=
                    1.0;
            }
        }
        let trips_per_hour = hourly_rates(&hours, &starts, Unseen::Quietest);
        // The quietest healthy spans: run the tracker with the rates and no outage threshold.
        let mut probe = OperationReference {
            trips_per_hour,
            outage_expected_trips: f64::INFINITY,
            quiet_max_expected_trips: 0.0,
            landings_m: Vec::new(),
            level_tolerance_m: LEVEL_TOLERANCE_M,
            door: None,
            unseen_hours: Vec::new(),
            hour_of_day_rates: Vec::new(),
        };
        // Each day's silences are measured with the rates of the other days of like traffic
        // (module docs, "Why the other days' rates"); a day whose others do not cover every
        // hour of the day keeps the whole training's.
        let days: Vec<(i64, f64, WeekCounts)> =
            per_day.into_iter().map(|(d, c)| (d, c.rate(), c)).collect();
        let judges: Vec<(i64, OperationReference)> = (0..days.len())
            .map(|i| {
                let mut others = WeekCounts::default();
                for c in similar_days(&days, i) {
                    others.add(c);
                }
                let judge = OperationReference {
                    trips_per_hour: hourly_rates(&others.hours, &others.starts, Unseen::HourOfDay),
                    ..probe.clone()
                };
                (
                    days[i].0,
                    if judge.checks_silence() {
                        judge
                    } else {
                        probe.clone()
                    },
                )
            })
            .collect();
        let mut tr = OperationTracker::new();
        let mut silences: Vec<Silence> = Vec::new();
        let mut cycles = Vec::new();
        pass(history, |samples| {
            for x in samples {
                let judge = judges
                    .binary_search_by_key(&day_of(x.time), |(d, _)| *d)
                    .map_or(&probe, |i| &judges[i].1);
                if let Some(c) = tr.push(&x, step_s, thr, Some(judge)) {
                    cycles.push(c);
                }
                // Λ only grows within a silence; the car in use starts the next one.
                match silences.last_mut() {
                    Some(s) if s.start.to_bits() == tr.rest_since.to_bits() => {
                        s.end = x.time;
                        s.expected_trips = s.expected_trips.max(tr.expected);
                    }
                    _ if tr.expected > 0.0 => silences.push(Silence {
                        start: tr.rest_since,
                        end: x.time,
                        expected_trips: tr.expected,
                    }),
                    _ => {}
                }
            }
        })?;
        silences.sort_by(|a, b| b.expected_trips.total_cmp(&a.expected_trips));
        let outages: Vec<Silence> = silences.drain(..training_outages(&silences)).collect();
        let quiet = silences.first().map_or(0.0, |s| s.expected_trips);
        let span_days = n_samples as f64 * step_s / DAY_S;
        probe.quiet_max_expected_trips = quiet;
        let margin = outage_limit(quiet);
        probe.outage_expected_trips =
            tail_limit(&silences, span_days, target).map_or(margin, |tail| tail.max(margin));
        probe.landings_m = learn_landings(trips, floors);
        probe.level_tolerance_m = level_tolerance(trips, floors, &probe.landings_m);
        probe.door = DoorReference::learn(&cycles, step_s, span_days, target);
        // The monitor learns the hours it never saw only where the training judges silences
        // at all: it saw every hour of the day, so each has a pooled rate.
        if probe.checks_silence() {
            probe.unseen_hours = (0..HOURS_PER_WEEK)
                .filter(|&b| hours[b] < SEEN_MIN_H)
                .filter_map(|b| u8::try_from(b).ok())
                .collect();
            if !probe.unseen_hours.is_empty() {
                probe.hour_of_day_rates = hour_of_day_rates(&hours, &starts).to_vec();
            }
        }
        Ok(Learnt {
            reference: probe,
            outages,
        })
    }

    /// Whether silences are judged: the training saw every hour of the day. Without (a
    /// training of a few hours) only a car stuck between landings is an outage.
    pub fn checks_silence(&self) -> bool {
        self.trips_per_hour.iter().any(|&r| r > 0.0)
    }

    /// Checks a hand-edited model.
    ///
    /// # Errors
    /// A message naming the first field out of range.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let check = crate::error::check_range;
        if self.trips_per_hour.len() != HOURS_PER_WEEK {
            return Err(format!(
                "operation.trips_per_hour has {} values, expected {HOURS_PER_WEEK}",
                self.trips_per_hour.len()
            ));
        }
        for &r in &self.trips_per_hour {
            check("operation.trips_per_hour", r, 0.0, 1e5)?;
        }
        check(
            "operation.outage_expected_trips",
            self.outage_expected_trips,
            1.0,
            1e9,
        )?;
        check(
            "operation.level_tolerance_m",
            self.level_tolerance_m,
            0.0,
            1e3,
        )?;
        for &h in &self.landings_m {
            check("operation.landings_m", h, -1e4, 1e4)?;
        }
        if let Some(&h) = self
            .unseen_hours
            .iter()
            .find(|&&h| usize::from(h) >= HOURS_PER_WEEK)
        {
            return Err(format!(
                "operation.unseen_hours holds {h}, an hour of the week is below {HOURS_PER_WEEK}"
            ));
        }
        if !self.unseen_hours.is_empty() && self.hour_of_day_rates.len() != 24 {
            return Err(format!(
                "operation.hour_of_day_rates has {} values, expected 24 beside unseen_hours",
                self.hour_of_day_rates.len()
            ));
        }
        for &r in &self.hour_of_day_rates {
            check("operation.hour_of_day_rates", r, 0.0, 1e5)?;
        }
        if let Some(d) = &self.door {
            check("operation.door.median_s", d.median_s, 0.0, 1e4)?;
            check("operation.door.sigma_s", d.sigma_s, 1e-6, 1e4)?;
            check(
                "operation.door.reopen_rate",
                d.reopen_rate,
                REOPEN_RATE_FLOOR,
                0.99,
            )?;
            if let Some(t) = &d.transfer {
                check(
                    "operation.door.transfer.s_per_load",
                    t.s_per_load,
                    1e-12,
                    1e4,
                )?;
                check("operation.door.transfer.median_s", t.median_s, -1e4, 1e4)?;
                check("operation.door.transfer.sigma_s", t.sigma_s, 1e-6, 1e4)?;
            }
            for k in 0..2 {
                check("operation.door.wander", d.wander[k], 0.0, CLIP)?;
                check("operation.door.score_mean", d.score_mean[k], -CLIP, CLIP)?;
                check("operation.door.score_sd", d.score_sd[k], 1e-6, 10.0)?;
                for j in 0..N_SIZES {
                    check("operation.door.h", d.h[k][j], 1e-3, 1e9)?;
                }
            }
        }
        Ok(())
    }
}

impl DoorReference {
    /// The door check's reference from healthy `cycles` over `span_days` days at step
    /// `step_s`; `None` with fewer than [`DOOR_MIN_CYCLES`] scored cycles.
    pub fn learn(
        cycles: &[DoorCycle],
        step_s: f64,
        span_days: f64,
        target: f64,
    ) -> Option<DoorReference> {
        let scored: Vec<DoorCycle> = cycles
            .iter()
            .copied()
            .filter(|c| c.duration_s <= DOOR_CYCLE_MAX_S)
            .collect();
        if scored.len() < DOOR_MIN_CYCLES || span_days.is_nan() || span_days < DOOR_MIN_DAYS {
            return None;
        }
        let d: Vec<f64> = scored.iter().map(|c| c.duration_s).collect();
        let (median_s, sigma_s) = (median(&d), robust_sigma(d.iter().copied()).max(step_s));
        let transfer = DoorTransfer::fit(&scored, step_s);
        let scored: Vec<DoorCycle> = scored
            .into_iter()
            .filter(|c| scored_with(transfer.as_ref(), c))
            .collect();
        let reopen = scored.iter().filter(|c| c.reopening).count() as f64 / scored.len() as f64;
        let mut r = DoorReference {
            median_s,
            sigma_s,
            reopen_rate: reopen.max(REOPEN_RATE_FLOOR),
            score_mean: [0.0; 2],
            score_sd: [1.0; 2],
            wander: [DOOR_WANDER_FLOOR; 2],
            h: [[1.0; N_SIZES]; 2],
            cycles: scored.len() as u64,
            cycles_per_day: scored.len() as f64 / span_days,
            transfer,
        };
        let raw: Vec<[f64; 2]> = scored.iter().map(|c| raw_scores(&r, c)).collect();
        for k in 0..2 {
            let n = raw.len() as f64;
            let m = raw.iter().map(|u| u[k]).sum::<f64>() / n;
            let v = raw.iter().map(|u| (u[k] - m) * (u[k] - m)).sum::<f64>() / n;
            r.score_mean[k] = m;
            // A score that never varied (no reopening seen) is scaled by its Bernoulli sd at p0.
            r.score_sd[k] = if v > 1e-12 { v.sqrt() } else { 1.0 };
        }
        if reopen < REOPEN_RATE_FLOOR {
            // At the floor the score's healthy mean and sd are those of a Bernoulli(p0) draw,
            // not the (lower) ones of the training: a conservative reference.
            let p = r.reopen_rate;
            let hi = ((1.0 - p) / (p * (1.0 - p)).sqrt()).min(CLIP);
            let lo = ((-p) / (p * (1.0 - p)).sqrt()).max(-CLIP);
            let m = p * hi + (1.0 - p) * lo;
            r.score_mean[1] = m;
            r.score_sd[1] = (p * (hi - m).powi(2) + (1.0 - p) * (lo - m).powi(2)).sqrt();
        }
        // Wander: the spread of the daily mean z beyond what each day's count explains.
        let mut by_day: Vec<(i64, [f64; 2], f64)> = Vec::new();
        for c in &scored {
            let z = standardised(&r, c);
            let d = day_of(c.start);
            match by_day.last_mut() {
                Some((day, sum, n)) if *day == d => {
                    sum[0] += z[0];
                    sum[1] += z[1];
                    *n += 1.0;
                }
                _ => by_day.push((d, z, 1.0)),
            }
        }
        let full: Vec<&(i64, [f64; 2], f64)> = by_day
            .iter()
            .filter(|d| d.2 >= 0.25 * r.cycles_per_day)
            .collect();
        if full.len() >= 3 {
            let nd = full.len() as f64;
            for k in 0..2 {
                let means: Vec<f64> = full.iter().map(|d| d.1[k] / d.2).collect();
                let m = means.iter().sum::<f64>() / nd;
                let var = means.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (nd - 1.0);
                let noise = full.iter().map(|d| 1.0 / d.2).sum::<f64>() / nd;
                r.wander[k] = (var - noise).max(0.0).sqrt().max(DOOR_WANDER_FLOOR);
            }
        }
        // Thresholds: the highest G over bootstrapped healthy years (day-long blocks of the
        // training's cycles), never below Lorden's bound for four statistics.
        let per_year = r.cycles_per_day * YEAR_DAYS;
        let lorden = (4.0 * per_year / target).ln().max(1.0);
        let total = (DOOR_BOOTSTRAP_YEARS / target).clamp(1.0, 100.0) * per_year;
        let z: Vec<[f64; 2]> = scored.iter().map(|c| scores(&r, c)).collect();
        let mut rng = Rng::new(DOOR_BOOTSTRAP_SEED);
        let mut g = [0.0f64; 2 * N_SIZES];
        let mut max_g = [0.0f64; 2 * N_SIZES];
        let ends = |first: usize, i: usize| scored[i].start - scored[first].start >= DAY_S;
        moving_blocks(
            &mut rng,
            z.len(),
            BlockStart::Anywhere,
            total as usize,
            ends,
            |i| {
                for k in 0..2 {
                    for (j, nu) in SIZES.iter().enumerate() {
                        let gk = &mut g[k * N_SIZES + j];
                        *gk = (*gk + gaussian_llr(*nu, z[i][k])).max(0.0);
                        max_g[k * N_SIZES + j] = max_g[k * N_SIZES + j].max(*gk);
                    }
                }
            },
        );
        for k in 0..2 {
            for j in 0..N_SIZES {
                r.h[k][j] = max_g[k * N_SIZES + j].max(lorden);
            }
        }
        Some(r)
    }
}

impl DoorTransfer {
    /// b by least squares of the durations on the exchanged load, refitted once without the
    /// cycles beyond [`TRANSFER_TRIM`] σ̂; `None` when fewer than half of the cycles (or
    /// fewer than [`DOOR_MIN_CYCLES`]) have a load reading, when the load never varied, or
    /// when b is not positive (a longer exchange never shortens a cycle).
    fn fit(cycles: &[DoorCycle], step_s: f64) -> Option<DoorTransfer> {
        let read: Vec<(f64, f64)> = cycles
            .iter()
            .filter(|c| c.exchange.is_finite())
            .map(|c| (c.exchange, c.duration_s))
            .collect();
        if read.len() < DOOR_MIN_CYCLES || 2 * read.len() < cycles.len() {
            return None;
        }
        let slope = |pts: &mut dyn Iterator<Item = (f64, f64)>| {
            let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for (x, y) in pts {
                n += 1.0;
                sx += x;
                sy += y;
                sxx += x * x;
                sxy += x * y;
            }
            // A load that never varied (a cell reading a constant) leaves no slope: the spread
            // must stand clear of the sums' rounding, about 1e-16 of Σx², by a wide margin
            // (and an empty set gives NaN, which fails the test too).
            let var = sxx - sx * sx / n;
            (var > 1e-9 * sxx.max(f64::MIN_POSITIVE)).then(|| (sxy - sx * sy / n) / var)
        };
        let b0 = slope(&mut read.iter().copied())?;
        let e0: Vec<f64> = read.iter().map(|(x, y)| y - b0 * x).collect();
        let (m0, s0) = (median(&e0), robust_sigma(e0.iter().copied()).max(step_s));
        let b = slope(
            &mut read
                .iter()
                .zip(&e0)
                .filter(|(_, e)| (*e - m0).abs() <= TRANSFER_TRIM * s0)
                .map(|(p, _)| *p),
        )?;
        if !(b.is_finite() && b > 0.0) {
            return None;
        }
        let e: Vec<f64> = read.iter().map(|(x, y)| y - b * x).collect();
        Some(DoorTransfer {
            s_per_load: b,
            median_s: median(&e),
            sigma_s: robust_sigma(e.iter().copied()).max(step_s),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::AlignedSeries;

    fn sample(t: f64, speed: f64, door: f64, floor: f64) -> Sample {
        Sample {
            time: t,
            speed,
            direction: 0.0,
            voltage: 10.0,
            load: 0.0,
            door,
            floor,
            current: f64::NAN,
        }
    }

    #[test]
    fn integer_bins_equal_the_float_ones() {
        let float_hour = |t: f64| {
            ((t / HOUR_S).floor().rem_euclid(HOURS_PER_WEEK as f64)) as usize % HOURS_PER_WEEK
        };
        let float_day = |t: f64| (t / DAY_S).floor() as i64;
        let mut rng = crate::rng::Rng::new(3);
        let edges = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            HOUR_S,
            -HOUR_S,
            DAY_S,
            -86_400.5,
            1e-300,
            -1e-300,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            EXACT_INTEGERS * HOUR_S,
            -EXACT_INTEGERS * HOUR_S,
            9.3e18 * DAY_S,
            -9.3e18 * DAY_S,
        ];
        let random = (0..100_000).map(|i| {
            let t = rng.uniform(-2e9, 2e9);
            if i % 2 == 0 {
                t.round()
            } else {
                t
            }
        });
        let mut memo = OperationTracker::new();
        // Times in order across many bins' edges, and back again: the memo's spans.
        let walk = (0..200_000u32).map(|i| {
            let edge = f64::from(i / 8) * HOUR_S;
            match i % 8 {
                // The float just below a bin's edge, the closest a time comes to the next bin.
                7 if edge > 0.0 => f64::from_bits(edge.to_bits() - 1),
                k => edge + [-1e-9, -1e-6, 0.0, 1e-9, 0.5, -0.5, 1799.0, 0.0][k as usize],
            }
        });
        for t in walk.clone().chain(walk.rev()) {
            assert_eq!(memo.hour_bin(t), hour_bin(t), "{t}");
            assert_eq!(memo.day_of(t), day_of(t), "{t}");
        }
        for t in edges.into_iter().chain(random) {
            assert_eq!(memo.hour_bin(t), hour_bin(t), "{t}");
            assert_eq!(memo.day_of(t), day_of(t), "{t}");
            assert_eq!(hour_bin(t), float_hour(t), "{t}");
            assert_eq!(day_of(t), float_day(t), "{t}");
            assert_eq!(floor_to_i64(t), t.floor() as i64, "{t}");
        }
    }

    #[test]
    fn door_cycles_and_reopenings_are_counted() {
        let mut tr = OperationTracker::new();
        let mut cycles = Vec::new();
        // closed, open 10 s, closed 2 s, open 4 s (a reopening), closed 20 s, move, open 8 s.
        let pattern: Vec<(f64, f64)> = (0..60)
            .map(|i| {
                let door = matches!(i, 5..=14 | 17..=20 | 45..=52) as u8;
                let speed = if (30..=40).contains(&i) { 1.0 } else { 0.0 };
                (speed, f64::from(door))
            })
            .collect();
        for (i, (v, d)) in pattern.iter().enumerate() {
            if let Some(c) = tr.push(&sample(i as f64, *v, *d, 1.0), 1.0, 0.05, None) {
                cycles.push(c);
            }
        }
        assert_eq!(cycles.len(), 3, "{cycles:?}");
        assert_eq!(cycles[0].duration_s, 10.0);
        assert!(!cycles[0].reopening && cycles[1].reopening && !cycles[2].reopening);
        let u = tr.days.back().unwrap();
        assert_eq!((u.door_cycles, u.reopenings), (3, 1));
        assert_eq!(u.availability(), 1.0);
    }

    #[test]
    fn landings_come_back_from_trips() {
        let h = [0.0, 4.2, 7.5, 10.9, 14.0];
        let mut trips = Vec::new();
        for (k, (a, b)) in [
            (0, 1),
            (1, 3),
            (3, 0),
            (0, 4),
            (4, 2),
            (2, 0),
            (0, 3),
            (1, 4),
        ]
        .into_iter()
        .enumerate()
        {
            let d: f64 = h[b] - h[a];
            trips.push(Trip {
                index: k as u32,
                start_time: 0.0,
                end_time: 1.0,
                direction: if d > 0.0 { 1 } else { -1 },
                from_floor: (a + 1) as f64,
                to_floor: (b + 1) as f64,
                load_ratio: 0.0,
                peak_speed: 1.0,
                distance_m: d.abs() + 0.01,
                samples: 5,
            });
        }
        let got = learn_landings(&trips, 5);
        for f in 0..5 {
            assert!((got[f] - h[f]).abs() < 0.05, "{got:?}");
        }
        let mut stuck = trips[1];
        stuck.distance_m = 5.0; // from landing 2 at 4.2 m up 5 m: 9.2 m, 1.7 m from landing 4
        assert!(level_offset(&got, &stuck).unwrap() > LEVEL_TOLERANCE_M);
        assert!(level_offset(&got, &trips[1]).unwrap() < LEVEL_TOLERANCE_M);
        let beyond = Trip {
            distance_m: 5000.0,
            ..trips[1]
        };
        assert_eq!(level_offset(&got, &beyond), None, "outside the shaft");
        assert!(
            learn_landings(&trips[..2], 5).is_empty(),
            "landing 5 never reached"
        );
        assert_eq!(level_tolerance(&trips, 5, &got), LEVEL_TOLERANCE_M);
    }

    /// A tower's morning: every trip from the lobby, a seventh of them a second's crawl longer
    /// than they were (1 Hz readings). The landings come out of the medians, the long trips'
    /// misclosure widens the tolerance past them, and a car stopped mid-storey is still off.
    #[test]
    fn scattered_trip_ends_widen_the_level_tolerance() {
        let storey = 3.5;
        let mut trips = Vec::new();
        for k in 0..200u32 {
            let to = 2 + k % 30;
            let long = if k % 7 == 0 { 0.8 } else { 0.0 };
            trips.push(Trip {
                index: k,
                start_time: 0.0,
                end_time: 1.0,
                direction: 1,
                from_floor: 1.0,
                to_floor: f64::from(to),
                load_ratio: 0.0,
                peak_speed: 2.5,
                distance_m: storey * f64::from(to - 1) + long,
                samples: 10,
            });
        }
        // And down again to the lobby, as long or short.
        let back: Vec<Trip> = trips
            .iter()
            .map(|t| Trip {
                direction: -1,
                from_floor: t.to_floor,
                to_floor: 1.0,
                ..*t
            })
            .collect();
        trips.extend(back);
        let h = learn_landings(&trips, 31);
        let tolerance = level_tolerance(&trips, 31, &h);
        assert!((1.0..1.5).contains(&tolerance), "{tolerance}");
        let long = trips[0];
        assert!(level_offset(&h, &long).unwrap() < tolerance);
        let mid = Trip {
            distance_m: storey * 9.5,
            ..trips[1]
        };
        assert!(level_offset(&h, &mid).unwrap() > tolerance);
    }

    /// A reference of 30 trips an hour at every hour, an outage at 20 expected trips.
    fn busy_reference() -> OperationReference {
        OperationReference {
            trips_per_hour: vec![30.0; HOURS_PER_WEEK],
            outage_expected_trips: 20.0,
            quiet_max_expected_trips: 10.0,
            landings_m: Vec::new(),
            level_tolerance_m: LEVEL_TOLERANCE_M,
            door: None,
            unseen_hours: Vec::new(),
            hour_of_day_rates: Vec::new(),
        }
    }

    /// The outages a fresh tracker with reference `r` starts on `samples` (step 1 s).
    fn outage_starts(r: &OperationReference, samples: impl Iterator<Item = Sample>) -> usize {
        let mut tr = OperationTracker::new();
        let mut n = 0;
        for x in samples {
            tr.push(&x, 1.0, 0.05, Some(r));
            while let Some(e) = tr.take_event() {
                n += usize::from(matches!(e, OperationEvent::OutageStart(_)));
            }
        }
        n
    }

    #[test]
    fn a_silence_through_busy_hours_is_an_outage_and_ends_with_motion() {
        let r = busy_reference();
        let mut tr = OperationTracker::new();
        let mut events = Vec::new();
        for i in 0..7200 {
            let t = f64::from(i);
            let v = if i == 100 || i == 5000 { 1.0 } else { 0.0 };
            tr.push(&sample(t, v, 1.0, 3.0), 1.0, 0.05, Some(&r));
            while let Some(e) = tr.take_event() {
                events.push(e);
            }
        }
        // 20 expected trips at 30/h: 40 min after the car stopped at 100 s.
        let OperationEvent::OutageStart(o) = events[0] else {
            panic!("{events:?}")
        };
        assert_eq!(o.start, 100.0);
        assert!((o.detected_at - 2500.0).abs() <= 1.0, "{o:?}");
        assert_eq!(o.reason(), "stopped at floor 3, door open");
        let OperationEvent::OutageEnd(e) = events[1] else {
            panic!("{events:?}")
        };
        assert_eq!(e.end, 5000.0);
        let u = tr.days.back().unwrap();
        assert!((u.outage_s - 4899.0).abs() <= 1.0, "{u:?}");
        assert!(events[1].to_json_line().contains(r#""kind":"outage""#));
        // Without a reference: usage only, no outage.
        let mut bare = OperationTracker::new();
        for i in 0..7200 {
            bare.push(&sample(f64::from(i), 0.0, 0.0, 1.0), 1.0, 0.05, None);
        }
        assert!(bare.take_event().is_none() && bare.availability(1) == 1.0);
    }

    /// Trips of a Poisson stream leave silences whose Λ, in expected trips, is exponential
    /// of mean 1 whatever the hour's rate. Three days of them at 30 trips an hour (2,160
    /// silences) set a limit near ln(262,980) = 12.5, where a year of the same stream
    /// (262,980 silences) passes it once; the 95 % bound on the scale lifts it above that, so
    /// over five such trainings, each followed by its year, the limits are passed fewer than
    /// five times, as the alarm budget of one a year asks. A budget ten times smaller raises a
    /// limit by ln 10 times the scale's bound. With too few silences there is no tail to read.
    #[test]
    fn the_tail_of_the_silences_sets_how_long_a_car_may_stand_idle() {
        let mut rng = Rng::new(17);
        let mut draw = |n: usize| {
            let mut v: Vec<Silence> = (0..n)
                .map(|_| Silence {
                    start: 0.0,
                    end: 0.0,
                    expected_trips: rng.exponential(1.0),
                })
                .collect();
            v.sort_by(|a, b| b.expected_trips.total_cmp(&a.expected_trips));
            v
        };
        let mut passed = 0;
        for _ in 0..5 {
            let training = draw(3 * 24 * 30);
            let limit = tail_limit(&training, 3.0, 1.0).expect("enough silences");
            assert!((12.5..20.0).contains(&limit), "Λ_max {limit:.2}");
            let year = draw((YEAR_DAYS * 24.0 * 30.0) as usize);
            passed += year.iter().filter(|s| s.expected_trips >= limit).count();
            let tenth = tail_limit(&training, 3.0, 0.1).unwrap();
            assert!(
                tenth > limit + 2.0 && tenth < limit + 5.0,
                "{tenth:.2} against {limit:.2}"
            );
            assert_eq!(tail_limit(&training[..TAIL_MIN_SILENCES], 3.0, 1.0), None);
        }
        assert!(
            passed < 5,
            "{passed} silences of five healthy years past their Λ_max"
        );
    }

    /// The training's silences, longest first, as Λ and minutes: a healthy week's rise in
    /// small steps and none is an outage; one far beyond the rest is, and so is one only just
    /// beyond twice the rest, and the next when it is far beyond the ones after it; two of
    /// like length are not; none shorter than a quarter of an hour or below Λ's floor is.
    #[test]
    fn the_trainings_outages_are_its_silences_the_rest_would_call_outages() {
        let silences = |spans: &[(f64, f64)]| -> Vec<Silence> {
            spans
                .iter()
                .map(|&(l, min)| Silence {
                    start: 0.0,
                    end: 60.0 * min,
                    expected_trips: l,
                })
                .collect()
        };
        let k = |spans: &[(f64, f64)]| training_outages(&silences(spans));
        let healthy = [(17.2, 100.0), (15.0, 90.0), (14.1, 80.0), (3.0, 20.0)];
        assert_eq!(k(&healthy), 0);
        assert_eq!(k(&[(205.0, 240.0), (17.2, 100.0), (15.0, 90.0)]), 1);
        assert_eq!(k(&[(205.0, 240.0), (60.0, 300.0), (17.2, 100.0)]), 2);
        assert_eq!(
            k(&[(205.0, 240.0), (190.0, 300.0), (17.2, 100.0)]),
            0,
            "like lengths"
        );
        assert_eq!(k(&[(34.5, 60.0), (17.2, 100.0)]), 1);
        assert_eq!(k(&[(34.3, 60.0), (17.2, 100.0)]), 0);
        assert_eq!(k(&[(34.5, 60.0)]), 0, "nothing left to judge it by");
        // Below Λ's floor or a quarter of an hour, the monitor calls nothing an outage.
        assert_eq!(k(&[(14.0, 200.0), (3.0, 20.0)]), 0);
        assert_eq!(k(&[(40.0, 10.0), (3.0, 20.0)]), 0);
        assert_eq!(k(&[]), 0);
    }

    /// A trip that ends 1.5 m past a landing, the car then standing still with its door
    /// closed: stuck, from the trip's end. The same trip, the door opening and closing after
    /// it: a car at a landing (its distance was off, as a freed car's hop is, which starts
    /// where it was stuck), no outage however long it then stands.
    #[test]
    fn a_car_that_opens_its_door_stands_at_a_landing_whatever_its_distance_says() {
        let r = OperationReference {
            trips_per_hour: vec![0.0; HOURS_PER_WEEK],
            landings_m: vec![0.0, 3.0, 6.0, 9.0],
            ..busy_reference()
        };
        let hop = Trip {
            index: 0,
            start_time: 90.0,
            end_time: 100.0,
            direction: 1,
            from_floor: 2.0,
            to_floor: 2.0,
            load_ratio: 0.0,
            peak_speed: 1.0,
            distance_m: 1.5,
            samples: 10,
        };
        assert!(level_offset(&r.landings_m, &hop).unwrap() > r.level_tolerance_m);
        let starts = |door_cycle: bool| {
            let mut tr = OperationTracker::new();
            let mut starts = Vec::new();
            for i in 0..3600 {
                let t = f64::from(i);
                let v = if (90..100).contains(&i) { 1.0 } else { 0.0 };
                let door = f64::from(u8::from(door_cycle && (110..130).contains(&i)));
                tr.push(&sample(t, v, door, 2.0), 1.0, 0.05, Some(&r));
                if i == 101 {
                    tr.trip(&hop, Some(&r));
                }
                while let Some(e) = tr.take_event() {
                    if let OperationEvent::OutageStart(o) = e {
                        starts.push(o);
                    }
                }
            }
            starts
        };
        let stuck = starts(false);
        assert_eq!(stuck.len(), 1, "{stuck:?}");
        assert_eq!(stuck[0].kind, OutageKind::StuckBetweenFloors);
        assert_eq!(stuck[0].start, 100.0);
        assert!(starts(true).is_empty());
    }

    /// A speed sensor stuck at zero on a travelling car: the floor reading changes every two
    /// minutes and the door opens at each stop, so the car is in use and no outage is
    /// reported; the same hours with floor and door still are one.
    #[test]
    fn a_car_in_use_is_no_outage_whatever_the_speed_reads() {
        let r = busy_reference();
        let outages = |in_use: bool| {
            let samples = (0..3 * 3600).map(|i| {
                let stop = if in_use { i / 120 } else { 0 };
                let door = if in_use && i % 120 >= 100 { 1.0 } else { 0.0 };
                sample(f64::from(i), 0.0, door, f64::from(1 + stop % 5))
            });
            outage_starts(&r, samples)
        };
        assert_eq!(outages(true), 0);
        assert_eq!(outages(false), 1);
    }

    /// Trained on Monday to Wednesday of an office (a trip every 2 min from 07:00 to 19:00,
    /// none at night): a Saturday with a trip every 3 h is no outage, as the hours the
    /// training never saw take its quietest rate (none at night), while a silence through the
    /// next Monday morning, an hour it saw, still is.
    #[test]
    fn an_hour_the_training_never_saw_takes_its_quietest_rate() {
        let (samples, trips) = office_log(3, |t| {
            (7.0..19.0).contains(&((t / HOUR_S) % 24.0)).then_some(120)
        });
        let r = learn_1s(&samples, &trips).reference;
        assert!((r.trips_per_hour[hour_bin(DAY_S + 9.0 * HOUR_S)] - 30.0).abs() < 1e-9);
        assert_eq!(r.trips_per_hour[hour_bin(5.0 * DAY_S + 9.0 * HOUR_S)], 0.0);
        let outages = |from: f64, to: f64, every: i64| {
            let samples = ((from as i64)..(to as i64)).map(|t| {
                let v = if t % every == 0 { 1.0 } else { 0.0 };
                sample(t as f64, v, 0.0, 1.0)
            });
            outage_starts(&r, samples)
        };
        assert_eq!(
            outages(5.0 * DAY_S, 6.0 * DAY_S, 3 * 3600),
            0,
            "a quiet Saturday"
        );
        assert_eq!(
            outages(7.0 * DAY_S, 7.5 * DAY_S, 6 * 3600),
            1,
            "a silent Monday morning"
        );
        // Three morning hours of training: no hour of any day is judged, theirs included
        // (module docs, "Why a whole day"); the door check needs a day as well.
        let (from, to) = (7 * 3600, 10 * 3600);
        let morning_trips: Vec<Trip> = trips
            .iter()
            .copied()
            .filter(|t| (f64::from(from)..f64::from(to)).contains(&t.start_time))
            .collect();
        let morning = learn_1s(&samples[from as usize..to as usize], &morning_trips).reference;
        assert!(!morning.checks_silence());
        assert!(r.checks_silence());
        let silent_morning = (7 * DAY_S as i64..(7.5 * DAY_S) as i64).map(|t| {
            sample(
                t as f64,
                if t % (6 * 3600) == 0 { 1.0 } else { 0.0 },
                0.0,
                1.0,
            )
        });
        assert_eq!(outage_starts(&morning, silent_morning), 0);
    }

    /// A door held open for an hour at a landing is a car out of use whether or not an outage
    /// was concluded (in an hour the training never saw none is): the three hours after it
    /// closes are the waiting calls' backlog, as after an outage; a door open for a minute
    /// is a door cycle.
    #[test]
    fn a_door_held_open_for_an_hour_is_followed_by_a_backlog() {
        let mut tr = OperationTracker::new();
        let feed = |tr: &mut OperationTracker, from: u32, to: u32, door: f64| {
            for k in from..to {
                tr.push(&sample(f64::from(k), 0.0, door, 3.0), 1.0, 0.05, None);
            }
        };
        feed(&mut tr, 0, 100, 0.0);
        feed(&mut tr, 100, 160, 1.0);
        feed(&mut tr, 160, 200, 0.0);
        assert!(!tr.serving_backlog(200.0), "a minute's door cycle");
        feed(&mut tr, 200, 3800, 1.0);
        feed(&mut tr, 3800, 3900, 0.0);
        assert!(tr.serving_backlog(3900.0) && tr.serving_backlog(3800.0 + OUTAGE_BACKLOG_S - 1.0));
        assert!(!tr.serving_backlog(3800.0 + OUTAGE_BACKLOG_S));
        assert_eq!(tr.outages, 0);
    }

    /// Trained Monday to Wednesday on an office (a trip every 2 min from 07:00 to 19:00),
    /// then watched without a break for two weeks of weekdays like them and quiet weekends
    /// (a trip every 8 min by day). On the first Thursday a car standing from 15:00 to 19:00
    /// stands in hours the training never saw: at their quietest rate, none, no outage. The
    /// monitor has counted Thursday's morning by the second Thursday, and a car standing from
    /// 10:00 to 14:00 is an outage, concluded at the 30 trips an hour it counted (at most its
    /// hour of the day's) once Λ_max is reached; the hours of that outage are left out of what
    /// it counts. The weekends, learnt at their own quarter rate, hold no outage, and the
    /// state carries what was counted.
    #[test]
    fn the_monitor_learns_the_hours_its_training_never_saw() {
        let office = |t: f64| (7.0..19.0).contains(&((t / HOUR_S) % 24.0)).then_some(120);
        let r = learnt(3, office).reference;
        let thursday_10 = hour_bin(3.0 * DAY_S + 10.0 * HOUR_S);
        assert_eq!(r.unseen_hours.len(), 4 * 24);
        assert!(r.unseen_hours.contains(&(thursday_10 as u8)));
        assert_eq!(r.trips_per_hour[thursday_10], 0.0);
        assert!((r.hour_of_day_rates[10] - 30.0).abs() < 1e-9);
        assert!(r.validate().is_ok());
        let mut tr = OperationTracker::new();
        let mut starts = Vec::new();
        for i in 3 * 86_400..17 * 86_400u32 {
            let t = f64::from(i);
            let (day, h) = ((t / DAY_S).floor() as u32 % 7, (t / HOUR_S) % 24.0);
            let week = i / (7 * 86_400);
            let standing = day == 3
                && if week == 0 {
                    (15.0..19.0).contains(&h)
                } else {
                    (10.0..14.0).contains(&h)
                };
            let every = if day >= 5 { 480 } else { 120 };
            let start = (7.0..19.0).contains(&h) && !standing && i % every == 0;
            tr.push(
                &sample(t, if start { 1.0 } else { 0.0 }, 0.0, 1.0),
                1.0,
                0.05,
                Some(&r),
            );
            if start {
                tr.trip(&hop(0, t), Some(&r));
            }
            while let Some(e) = tr.take_event() {
                if let OperationEvent::OutageStart(o) = e {
                    starts.push(o);
                }
            }
        }
        assert_eq!(starts.len(), 1, "{starts:?}");
        let o = starts[0];
        let standing_from = 10.0 * DAY_S + 10.0 * HOUR_S;
        assert!((o.start - standing_from).abs() <= 120.0, "{o:?}");
        let waited_h = (o.detected_at - o.start) / HOUR_S;
        let at_30 = r.outage_expected_trips / 30.0;
        assert!(
            (waited_h - at_30).abs() < 0.05,
            "{waited_h} h, {at_30} h at 30 trips an hour"
        );
        let counted = |h: usize| tr.learnt[h].expect("an unseen hour is counted");
        // The first Thursday's hour; the second's held the outage.
        let thursday = counted(thursday_10);
        assert!(
            (thursday.hours - 1.0).abs() < 1e-6 && thursday.starts == 30.0,
            "{thursday:?}"
        );
        let saturday = counted(hour_bin(5.0 * DAY_S + 10.0 * HOUR_S));
        assert!((saturday.hours - 2.0).abs() < 1e-6, "{saturday:?}");
        assert!(
            (7.0..=8.0).contains(&(saturday.starts / saturday.hours)),
            "{saturday:?}"
        );
        assert!(
            tr.learnt[hour_bin(DAY_S + 10.0 * HOUR_S)].is_none(),
            "a seen hour"
        );
        let state = serde_json::to_string(&tr).unwrap();
        let back: OperationTracker = serde_json::from_str(&state).unwrap();
        assert!(back.learnt == tr.learnt);
        assert_eq!(serde_json::to_string(&back).unwrap(), state);
    }

    /// A trip is counted into the hour it started in, as the training counts it, also when
    /// the features stage reports it after that hour has ended; and not into an hour an
    /// outage was under way in.
    #[test]
    fn a_learnt_hour_counts_the_trips_started_in_it() {
        let office = |t: f64| (7.0..19.0).contains(&((t / HOUR_S) % 24.0)).then_some(120);
        let r = learnt(3, office).reference;
        let thursday_10 = 3.0 * DAY_S + 10.0 * HOUR_S;
        let mut tr = OperationTracker::new();
        let feed = |tr: &mut OperationTracker, from: f64, to: f64| {
            for i in from as u32..to as u32 {
                tr.push(&sample(f64::from(i), 0.0, 0.0, 1.0), 1.0, 0.05, Some(&r));
            }
        };
        feed(&mut tr, thursday_10, thursday_10 + 1800.0);
        tr.trip(&hop(0, thursday_10 + 1000.0), Some(&r));
        feed(&mut tr, thursday_10 + 1800.0, thursday_10 + HOUR_S + 5.0);
        // Started at 10:59:55, reported at 11:00:05, when 10:00's hour was already added.
        tr.trip(&hop(1, thursday_10 + HOUR_S - 5.0), Some(&r));
        feed(
            &mut tr,
            thursday_10 + HOUR_S + 5.0,
            thursday_10 + 2.0 * HOUR_S + 1.0,
        );
        let ten = tr.learnt[hour_bin(thursday_10)].expect("unseen");
        assert!(
            (ten.hours - 1.0).abs() < 1e-9 && ten.starts == 2.0,
            "{ten:?}"
        );
        let eleven = tr.learnt[hour_bin(thursday_10 + HOUR_S)].expect("unseen");
        assert!(
            (eleven.hours - 1.0).abs() < 1e-9 && eleven.starts == 0.0,
            "{eleven:?}"
        );
    }

    /// A car trained Monday to Wednesday stands out of service for 4 h on the first Thursday,
    /// an hour its Λ does not judge yet: no outage is reported, but the calls that waited are
    /// a backlog, as after an outage; a 20-minute pause the same morning is not.
    #[test]
    fn an_unjudged_silence_as_long_as_an_outage_is_followed_by_its_backlog() {
        let office = |t: f64| (7.0..19.0).contains(&((t / HOUR_S) % 24.0)).then_some(120);
        let r = learnt(3, office).reference;
        let at = |h: f64| 3.0 * DAY_S + h * HOUR_S;
        // Λ_max is 15 trips, half an hour at Thursday 10:00's pooled 30 an hour.
        assert!((r.outage_expected_trips - 15.0).abs() < 1e-9, "{r:?}");
        let mut tr = OperationTracker::new();
        let mut backlog = Vec::new();
        for i in at(0.0) as u32..at(24.0) as u32 {
            let t = f64::from(i);
            let h = (t / HOUR_S) % 24.0;
            let silent = (8.0..8.34).contains(&h) || (10.0..14.0).contains(&h);
            let start = (7.0..19.0).contains(&h) && !silent && i % 120 == 0;
            tr.push(
                &sample(t, f64::from(u8::from(start)), 0.0, 1.0),
                1.0,
                0.05,
                Some(&r),
            );
            assert!(tr.take_event().is_none(), "nothing is reported at {h} h");
            if tr.serving_backlog(t) {
                backlog.push(t);
            }
        }
        assert!(
            !backlog.is_empty(),
            "the 4 h silence is followed by its backlog"
        );
        let (first, last) = (backlog[0], backlog[backlog.len() - 1]);
        assert_eq!(backlog.len() as f64, last - first + 1.0, "one span");
        assert!((first - at(14.0)).abs() <= 120.0, "{first}");
        assert!(
            (last - first - (OUTAGE_BACKLOG_S - 1.0)).abs() < 1e-9,
            "{last}"
        );
    }

    /// What `days` of training from Monday 00:00 at step 1 s teach, with a trip started
    /// every `every(t)` s (None: no trip in that second's hour).
    fn learnt(days: u32, every: impl Fn(f64) -> Option<u32>) -> Learnt {
        let (samples, trips) = office_log(days, every);
        learn_1s(&samples, &trips)
    }

    /// What `samples` at step 1 s, with their `trips`, teach a two-landing car (motion
    /// threshold 0.05 m/s, a false door advisory a year).
    fn learn_1s(samples: &[Sample], trips: &[Trip]) -> Learnt {
        let history = AlignedSeries {
            step_s: 1.0,
            samples: samples.to_vec(),
        };
        OperationReference::learn(&history, trips, 0.05, 2, 1.0).expect("held in memory")
    }

    /// The samples and trips of [`learnt`]'s log.
    fn office_log(days: u32, every: impl Fn(f64) -> Option<u32>) -> (Vec<Sample>, Vec<Trip>) {
        let mut samples = Vec::new();
        let mut trips = Vec::new();
        for i in 0..days * 86_400 {
            let t = f64::from(i);
            let start = every(t).is_some_and(|e| i % e == 0);
            samples.push(sample(t, if start { 1.0 } else { 0.0 }, 0.0, 1.0));
            if start {
                trips.push(hop(trips.len() as u32, t));
            }
        }
        (samples, trips)
    }

    /// Trip `index`: one moving second at `t`, a floor up.
    fn hop(index: u32, t: f64) -> Trip {
        Trip {
            index,
            start_time: t,
            end_time: t,
            direction: 1,
            from_floor: 1.0,
            to_floor: 2.0,
            load_ratio: 0.0,
            peak_speed: 1.0,
            distance_m: 1.0,
            samples: 1,
        }
    }

    /// The outages `r` reports on a day from `day` (days from the training's Monday) with
    /// a trip every 2 min from 07:00 to 19:00 outside the hours `silent` says.
    fn office_day(r: &OperationReference, day: u32, silent: &dyn Fn(f64) -> bool) -> usize {
        let samples = (day * 86_400..(day + 1) * 86_400).map(|i| {
            let t = f64::from(i);
            let h = (t / HOUR_S) % 24.0;
            let start = (7.0..19.0).contains(&h) && !silent(h) && i % 120 == 0;
            sample(t, if start { 1.0 } else { 0.0 }, 0.0, 1.0)
        });
        outage_starts(r, samples)
    }

    /// Trained Monday to Wednesday on an office (a trip every 2 min from 07:00 to 19:00)
    /// whose Tuesday had a two-hour lunch break, once, and then on the Wednesday as well: the
    /// break, measured at the other days' 30 trips an hour, is a silence of 60 expected trips
    /// (measured in the training's own rates it counted for nothing: its hours' rate is 0).
    /// Once, alone beside silences of one expected trip, it is what the monitor would call an
    /// outage, so it is the training's outage, left out of Λ_max, and the same break on the
    /// next Monday is one too. Taken twice (31 expected trips each, at the rates of the days
    /// with and without it), the two shield each other as the office's habit: the Monday break
    /// is no outage. A silence through that whole Monday is one either way.
    #[test]
    fn a_silence_the_training_had_is_measured_at_the_other_days_rates() {
        let office = |break_days: f64| {
            learnt(3, move |t| {
                let h = (t / HOUR_S) % 24.0;
                let lunch_break =
                    (DAY_S..(1.0 + break_days) * DAY_S).contains(&t) && (12.0..14.0).contains(&h);
                ((7.0..19.0).contains(&h) && !lunch_break).then_some(120)
            })
        };
        let lunch = |h: f64| (12.0..14.0).contains(&h);
        let once = office(1.0);
        assert_eq!(once.outages.len(), 1, "{:?}", once.outages);
        assert!(
            once.outages[0].expected_trips >= 59.0,
            "the break at the other days' rates: {:?}",
            once.outages
        );
        assert!(once.reference.quiet_max_expected_trips < 2.0);
        assert_eq!(office_day(&once.reference, 7, &lunch), 1);
        let twice = office(2.0);
        assert!(twice.outages.is_empty(), "{:?}", twice.outages);
        assert!(twice.reference.quiet_max_expected_trips >= 30.0);
        assert_eq!(office_day(&twice.reference, 7, &lunch), 0, "a lunch break");
        for r in [&once.reference, &twice.reference] {
            assert_eq!(office_day(r, 7, &|_| true), 1, "a silent Monday");
        }
    }

    /// A week of an office whose weekend runs at a quarter of its weekdays' 30 trips an hour,
    /// with a two-hour silence on Saturday afternoon: Saturday is measured at Sunday's rates
    /// (the day of like traffic), a silence of 15 expected trips, not at the weekdays' 60.
    /// Alone beside silences of about one, it reaches Λ's floor and is the training's outage;
    /// a two-hour silence on a weekday is one either way.
    #[test]
    fn a_training_day_is_measured_at_the_rates_of_days_like_it() {
        let learnt = learnt(7, |t| {
            let h = (t / HOUR_S) % 24.0;
            let day = (t / DAY_S).floor();
            let weekend = day >= 5.0;
            let silence = day == 5.0 && (13.0..15.0).contains(&h);
            let every = if weekend { 480 } else { 120 };
            ((7.0..19.0).contains(&h) && !silence).then_some(every)
        });
        let saturday = learnt.outages.first().map(|s| s.expected_trips);
        assert!(
            saturday.is_some_and(|l| (14.0..30.0).contains(&l)),
            "{:?}",
            learnt.outages
        );
        let r = learnt.reference;
        assert_eq!(
            office_day(&r, 8, &|h| (12.0..14.5).contains(&h)),
            1,
            "a weekday"
        );
    }

    #[test]
    fn door_check_rises_on_slow_cycles_and_not_on_healthy_ones() {
        let mut rng = Rng::new(3);
        let healthy: Vec<DoorCycle> = (0..3000)
            .map(|i| DoorCycle {
                start: f64::from(i) * 120.0,
                duration_s: (10.0 + 2.0 * rng.normal()).round().max(4.0),
                reopening: rng.chance(0.03),
                exchange: f64::NAN,
            })
            .collect();
        let r = DoorReference::learn(&healthy, 1.0, 3000.0 * 120.0 / DAY_S, 1.0).unwrap();
        assert!((r.median_s - 10.0).abs() <= 1.0 && r.h[0][0] > 5.0, "{r:?}");
        let mut check = DoorCheck::default();
        assert!(healthy
            .iter()
            .all(|c| check.push(&r, scores(&r, c)).is_none()));
        let slow = DoorCycle {
            start: 0.0,
            duration_s: 13.0,
            reopening: false,
            exchange: f64::NAN,
        };
        let n = (0..2000)
            .position(|_| check.push(&r, scores(&r, &slow)) == Some(true))
            .expect("a door 3 s slower raises the advisory");
        assert!(n < 500, "{n} cycles");
        assert!(DoorReference::learn(&healthy[..10], 1.0, 1.0, 1.0).is_none());
        // 360 cycles, enough by count, in half a day: not a day's traffic.
        assert!(DoorReference::learn(&healthy[..360], 1.0, 0.5, 1.0).is_none());
        assert!(DoorReference::learn(&healthy[..720], 1.0, 1.0, 1.0).is_some());
    }

    /// Healthy cycles whose length is 8 s plus 0.8 s per 10 units of load passing the door,
    /// with an evening peak of full cars, every day alike: the transfer law is learnt, the
    /// peaks raise nothing (the plain duration raises on the first), and a door 2 s slower is
    /// caught within a day's cycles, sooner than with the plain duration's wider σ̂.
    #[test]
    fn the_load_passing_the_door_is_not_a_slow_door() {
        const PER_LOAD: f64 = 0.08;
        let cycle = |rng: &mut Rng, i: u32, slower: f64| {
            let start = f64::from(i) * 90.0;
            let hour = (start / HOUR_S) % 24.0;
            let peak = (17.0..19.0).contains(&hour);
            let exchange = if peak {
                rng.uniform(100.0, 200.0)
            } else {
                rng.uniform(0.0, 80.0)
            };
            DoorCycle {
                start,
                duration_s: (8.0 + slower + PER_LOAD * exchange + 1.5 * rng.normal()).round(),
                reopening: false,
                exchange,
            }
        };
        let mut rng = Rng::new(5);
        let training: Vec<DoorCycle> = (0..2880).map(|i| cycle(&mut rng, i, 0.0)).collect();
        let r = DoorReference::learn(&training, 1.0, 3.0, 1.0).unwrap();
        let t = r
            .transfer
            .expect("the load readings measure the transfer law");
        assert!((t.s_per_load - PER_LOAD).abs() < 0.005, "{t:?}");
        assert!(
            (t.median_s - 8.0).abs() < 0.5 && t.sigma_s < r.sigma_s,
            "{r:?}"
        );
        let mut plain = r.clone();
        plain.transfer = None;
        let raised = |r: &DoorReference, slower: f64, seed: u64| {
            let mut rng = Rng::new(seed);
            let mut check = DoorCheck::default();
            (2880..2880 + 9600)
                .position(|i| check.push(r, scores(r, &cycle(&mut rng, i, slower))) == Some(true))
        };
        for seed in 0..5 {
            assert_eq!(raised(&r, 0.0, seed), None, "ten healthy days, seed {seed}");
        }
        // The plain duration takes the first evening peak of full cars for a slow door.
        assert!(raised(&plain, 0.0, 0).is_some_and(|n| n < 960));
        let with = raised(&r, 2.0, 9).expect("a door 2 s slower is caught");
        assert!(with < 960, "{with} cycles");
        assert!(raised(&plain, 2.0, 9).map_or(true, |n| n > with));
        let unread: Vec<DoorCycle> = training
            .iter()
            .map(|c| DoorCycle {
                exchange: f64::NAN,
                ..*c
            })
            .collect();
        let r = DoorReference::learn(&unread, 1.0, 3.0, 1.0).unwrap();
        assert!(r.transfer.is_none() && r.scores_cycle(&unread[0]));
    }
}
