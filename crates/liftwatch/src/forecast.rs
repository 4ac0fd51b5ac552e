//! Time to maintenance: the trend of each mode's physical drift, and when it reaches the
//! advisory and alarm levels and a stated physical limit (the paper stops at the risk index;
//! this stage is ours).
//!
//! ```text
//! per block b of 50 usable trips (the monitor feeds every trip it takes as machine evidence):
//!   θ̂_b = (Σ x·xᵀ)⁻¹·Σ x·r_U − θ0            the three signature drifts on the block alone
//!   se_b,m = √(s²·[(Σ x·xᵀ)⁻¹]_mm)            s² the healthy per-trip regression variance
//! per mode m over the window W (the trips the sequential decision holds as changed, at least
//! MIN_TREND_POINTS blocks; else the last TREND_WINDOW_DAYS days):
//!   weighted least squares  y_b = a + b·(t_b − t̄),  w_b = 1/se_b²
//!   per day d: the blocks' weighted means (t_d, y_d) and weight W_d = Σw
//!   weighted least squares  y_d = a + b·(t_d − t̄)
//!   var(a), var(b) = (ΣW)⁻¹, (ΣW·(t − t̄)²)⁻¹ · max(1, χ²/(k − 2))     k days
//!   q = Student-t quantile(0.975, k − 2)
//! crossing of a level T: a + b·τ = T ± q·√(var a + τ²·var b)
//!   the two roots bound the date; b² ≤ q²·var b: no trend distinguishable from zero
//! ```
//!
//! Why blocks and not the drifts of the events: the tracker's drift forgets over 3000 trips
//! (about five busy days), so on a ramp it lags by days, and the sequential decision's drift is
//! the mean over its whole window, which lags a ramp by half the window. A block estimates the
//! drift of its own few hours only. Its noise is mostly the daily thermal swing of the winding
//! (Kd ±3 %), which is autocorrelated from block to block over a day: the residuals, not the
//! nominal standard errors, set the slope's uncertainty, and they are taken per day (batch
//! means), within which the cycle averages out, so the days about the line are close to
//! independent and a Student-t quantile on k − 2 degrees of freedom holds its coverage. Two
//! corrections of the block-level fit were tried first and failed on 6 days of AR(1) blocks
//! (ρ = 0.6): the lag-1 inflation (1 + ρ)/(1 − ρ) saw ρ of 0.2-0.4 and 4 of 29 dated intervals
//! missed the truth; a Newey-West variance over one or two days of lags was smaller still
//! (11 of 38 missed), the known downward bias of both on short series of fitted residuals.
//!
//! The advisory and alarm levels are risks, not drifts; they are translated into the drift
//! that, held steady, brings the mode's risk to the level ([`drift_for_risk`]). They are an
//! approximation both ways: the advisory is also raised by the sequential test, so it may
//! come before its drift; and the risk's lens sees the re-identification's drift, which lags
//! the blocks' by up to its forgetting horizon (3000 trips, about five busy days), so R reaches
//! a level up to that much after the blocks' drift crosses its equivalent (the demo: the
//! block drift passes the alarm's +4.8 % on day 7, the alarm comes on day 9.5).

// Per-mode arrays read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::sample::DAY_S;
use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::alarm::Level;
use crate::elevator::Elevator;
use crate::exact;
use crate::mode::{FaultMode, MACHINE_MODES, N_MODES};
use crate::risk::{mat_vec, spd_inverse, RiskConfig, Rls, TripEvidence};

/// Trips per point of the drift history: the sequential decision's wander block, a few busy
/// hours, short against the daily thermal cycle and long enough to separate the signatures.
pub const BLOCK_TRIPS: u32 = crate::risk::sequential::WANDER_BLOCK_TRIPS as u32;

/// Most points kept: 720 blocks of 50 trips are about 50 busy days, three times the trend
/// window; about 110 KB of the monitor state (capped at 1 MiB).
pub const MAX_POINTS: usize = 720;

/// Without a change held by the sequential decision, the trend is fitted over this many recent
/// days: two weeks hold two weekends and fourteen thermal cycles.
pub const TREND_WINDOW_DAYS: f64 = 14.0;

/// Fewest blocks a trend is fitted on (about 300 trips, half a busy day): fewer cannot tell a
/// slope from the thermal swing.
pub const MIN_TREND_POINTS: usize = 6;

/// Crossings later than this are "not within the horizon": a year, the span over which the
/// thresholds' false-alarm rate is stated.
pub const HORIZON_DAYS: f64 = 365.0;

/// Fewest days a trend is fitted on: the line runs through daily means, and with three the
/// scatter about it has one degree of freedom (a Student-t quantile of 12.7 at 95 %).
pub const MIN_TREND_DAYS: usize = 3;

/// Physical limit of the motor drift: Kd +20 %. Kd = R/Kt; copper resistance rises 0.39 %/K,
/// so +20 % is a winding running 51 K hotter at the same load, or a torque constant down by a
/// sixth (demagnetisation). Either is twice the 25 K between insulation classes B and F, and
/// twice the simulator's full-severity fault (+10 %): the drive is due for repair, not watch.
pub const KD_LIMIT: f64 = 0.20;

/// Physical limit of the friction drift: +100 %, friction doubled. Dry steel guide shoes
/// slide with about twice the friction of lubricated ones at least (the simulator's fault,
/// +25 %, is lubrication thinning); doubled means the lubrication has failed and the shoes and
/// rails wear.
pub const FRICTION_LIMIT: f64 = 1.00;

/// Physical limit of the brake drag, as a share of the weight of car and rated load: 1 %.
/// A drag of that size (the order of the whole guide friction) dissipates about 0.4 kW at
/// 1.75 m/s in a 1000 kg car, which overheats a lining within weeks (the simulator's fault,
/// 0.6·F_c, is 0.6-1.2 % of that weight).
pub const BRAKE_DRAG_LIMIT_SHARE: f64 = 0.01;

/// Standard gravity (m/s²).
const G: f64 = 9.81;

/// Two-sided coverage of every interval: 95 %.
pub const COVERAGE: f64 = 0.95;

/// One point of the drift history: the drifts of one block of trips.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DriftPoint {
    /// Mean end time of the block's trips (s).
    #[serde(with = "exact")]
    pub time: f64,
    /// Usable trips seen up to the end of the block.
    pub trips: u64,
    /// Drift per mode (motor, brake, friction; relative units as in the risk stage).
    #[serde(with = "exact::array")]
    pub drift: [f64; N_MODES],
    /// Standard errors of the drifts.
    #[serde(with = "exact::array")]
    pub se: [f64; N_MODES],
}

/// The bounded drift history a monitor keeps: the block being filled and the last
/// [`MAX_POINTS`] blocks.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DriftHistory {
    #[serde(with = "exact::array")]
    xtx: [f64; 6],
    #[serde(with = "exact::array")]
    xtr: [f64; N_MODES],
    #[serde(with = "exact")]
    t_sum: f64,
    n: u32,
    /// Usable trips seen.
    pub trips: u64,
    /// The completed blocks, oldest first.
    pub points: VecDeque<DriftPoint>,
}

impl DriftHistory {
    /// Takes one trip of machine evidence ending at `time`; a block of [`BLOCK_TRIPS`] usable
    /// trips becomes a point (none when the block does not separate the signatures).
    pub fn push(&mut self, cfg: &RiskConfig, t: &TripEvidence, time: f64) {
        if !t.usable(cfg) {
            return;
        }
        for k in 0..6 {
            self.xtx[k] += t.xtx[k];
        }
        for m in 0..N_MODES {
            self.xtr[m] += t.xtr[m];
        }
        self.t_sum += time;
        self.n += 1;
        self.trips = self.trips.saturating_add(1);
        if self.n < BLOCK_TRIPS {
            return;
        }
        if let Some(inv) = spd_inverse(&self.xtx) {
            let mut p = DriftPoint {
                time: self.t_sum / f64::from(self.n),
                trips: self.trips,
                drift: [0.0; N_MODES],
                se: [0.0; N_MODES],
            };
            let theta = mat_vec(&inv, &self.xtr);
            for m in 0..N_MODES {
                p.drift[m] = theta[m] - cfg.healthy_coef[m];
                p.se[m] = (cfg.prior_s2 * inv[m][m]).sqrt();
            }
            if p.drift.iter().chain(&p.se).all(|v| v.is_finite()) {
                self.points.push_back(p);
            }
            while self.points.len() > MAX_POINTS {
                self.points.pop_front();
            }
        }
        *self = DriftHistory {
            trips: self.trips,
            points: std::mem::take(&mut self.points),
            ..DriftHistory::default()
        };
    }

    /// Time of the block holding usable trip number `trip` (counted as [`DriftHistory::trips`]),
    /// or of the oldest point when it is older than the history.
    pub fn time_of_trip(&self, trip: u64) -> Option<f64> {
        self.points
            .iter()
            .find(|p| p.trips >= trip)
            .or(self.points.back())
            .map(|p| p.time)
    }
}

/// A straight line fitted to one mode's drift over a window, in relative units per day.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Trend {
    /// Time of the first block in the window (s).
    pub since: f64,
    /// Blocks in the window (the line runs through their daily means).
    pub points: usize,
    /// Fitted drift at `now` (relative units).
    pub level: f64,
    /// Its standard error.
    pub level_se: f64,
    /// Slope (relative units per day).
    pub slope_per_day: f64,
    /// Its standard error.
    pub slope_se: f64,
    /// Lag-1 autocorrelation of the daily residuals (a diagnostic of what a line misses).
    pub rho: f64,
    /// Weighted mean time of the window (s): where the line's two errors are independent.
    #[serde(skip)]
    t_mean: f64,
    /// Drift at `t_mean` and its variance, slope variance (per s²).
    #[serde(skip)]
    fit: (f64, f64, f64, f64),
    /// The interval's quantile (Student t at the effective degrees of freedom).
    #[serde(skip)]
    q: f64,
}

/// Weighted least squares of mode `m`'s daily drift on time, its errors from the scatter of
/// the days about the line; `None` for fewer than [`MIN_TREND_POINTS`] blocks or
/// [`MIN_TREND_DAYS`] days.
pub fn trend(points: &[DriftPoint], m: usize, now: f64) -> Option<Trend> {
    let n = points.len();
    if n < MIN_TREND_POINTS {
        return None;
    }
    // Daily means (t, y, Σw): the thermal cycle averages out within a day.
    let t0 = points[0].time;
    let mut days: Vec<(f64, f64, f64)> = Vec::new();
    let mut bin = f64::NAN;
    for p in points {
        let w = 1.0 / p.se[m].max(1e-12).powi(2);
        let b = ((p.time - t0) / DAY_S).floor();
        if b != bin {
            days.push((0.0, 0.0, 0.0));
            bin = b;
        }
        let d = days.last_mut().expect("a bin was just pushed");
        *d = (d.0 + w * p.time, d.1 + w * p.drift[m], d.2 + w);
    }
    let days: Vec<(f64, f64, f64)> = days.iter().map(|d| (d.0 / d.2, d.1 / d.2, d.2)).collect();
    let k = days.len();
    if k < MIN_TREND_DAYS {
        return None;
    }
    let sw: f64 = days.iter().map(|d| d.2).sum();
    let t_mean = days.iter().map(|d| d.2 * d.0).sum::<f64>() / sw;
    let y_mean = days.iter().map(|d| d.2 * d.1).sum::<f64>() / sw;
    let stt: f64 = days.iter().map(|d| d.2 * (d.0 - t_mean).powi(2)).sum();
    if stt.is_nan() || stt <= 0.0 {
        return None;
    }
    let b = days
        .iter()
        .map(|d| d.2 * (d.0 - t_mean) * (d.1 - y_mean))
        .sum::<f64>()
        / stt;
    let res: Vec<f64> = days
        .iter()
        .map(|d| d.1 - y_mean - b * (d.0 - t_mean))
        .collect();
    let chi2: f64 = res.iter().zip(&days).map(|(r, d)| d.2 * r * r).sum();
    let scatter = (chi2 / (k - 2) as f64).max(1.0);
    let r0: f64 = res.iter().map(|r| r * r).sum();
    let r1: f64 = res.windows(2).map(|p| p[0] * p[1]).sum();
    let rho = if r0 > 0.0 { r1 / r0 } else { 0.0 };
    let (var_a, var_b) = (scatter / sw, scatter / stt);
    let q = crate::stats::t_quantile(0.5 + COVERAGE / 2.0, (k - 2) as f64);
    let dt = now - t_mean;
    Some(Trend {
        since: points[0].time,
        points: n,
        level: y_mean + b * dt,
        level_se: (var_a + dt * dt * var_b).sqrt(),
        slope_per_day: b * DAY_S,
        slope_se: var_b.sqrt() * DAY_S,
        rho,
        t_mean,
        fit: (y_mean, var_a, b, var_b),
        q,
    })
}

/// When a drift reaches a level.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum When {
    /// Already there: the monitor's level is, or the fitted drift now is beyond it by its
    /// interval.
    Reached,
    /// A date (s) with its interval; `late` is `None` when the interval's end lies beyond
    /// the horizon.
    At {
        /// Most likely time (s).
        time: f64,
        /// Early end of the interval (s).
        early: f64,
        /// Late end of the interval (s), `None` beyond [`HORIZON_DAYS`].
        late: Option<f64>,
    },
    /// A rising trend, but the level lies beyond [`HORIZON_DAYS`].
    NotWithinHorizon,
    /// No rising trend distinguishable from zero (or too few blocks to fit one).
    NoTrend,
}

impl When {
    /// Solves the crossing of level `target` by `trend` after `now`.
    pub fn solve(tr: &Trend, target: f64, now: f64) -> When {
        let (a, var_a, b, var_b) = tr.fit;
        let z = tr.q;
        // Reached only when the fitted drift now is beyond the level by its own interval: a
        // level inside the healthy scatter is not a crossing.
        if tr.level - z * tr.level_se >= target {
            return When::Reached;
        }
        // (a + bτ − T)² = z²(var_a + τ²·var_b), τ = t − t̄.
        let d = a - target;
        let qa = b * b - z * z * var_b;
        if b <= 0.0 || qa <= 0.0 {
            return When::NoTrend;
        }
        let qb = 2.0 * b * d;
        let qc = d * d - z * z * var_a;
        let disc = (qb * qb - 4.0 * qa * qc).max(0.0).sqrt();
        let (r1, r2) = ((-qb - disc) / (2.0 * qa), (-qb + disc) / (2.0 * qa));
        let horizon = now + HORIZON_DAYS * DAY_S;
        let time = tr.t_mean - d / b;
        if time > horizon {
            return When::NotWithinHorizon;
        }
        let late = tr.t_mean + r2;
        When::At {
            time,
            early: (tr.t_mean + r1).max(now),
            late: (late <= horizon).then_some(late),
        }
    }
}

/// One level a drift is forecast to reach.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Crossing {
    /// What the level is: `advisory level`, `alarm level`, `physical limit`.
    pub name: &'static str,
    /// The level in the mode's physical unit.
    pub threshold: f64,
    /// When the trend reaches it.
    pub when: When,
}

/// The forecast of one machine mode, in its physical unit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModeForecast {
    /// The mode.
    pub mode: FaultMode,
    /// What drifts: `Kd`, `friction`, `brake drag`.
    pub quantity: &'static str,
    /// Its unit: `%` or `N`.
    pub unit: &'static str,
    /// The line through the window, in the physical unit; `None` with too few blocks.
    pub trend: Option<Trend>,
    /// Advisory level, alarm level and physical limit.
    pub crossings: Vec<Crossing>,
}

/// The forecast of all three machine modes at `now`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Forecast {
    /// Time of the forecast (s): the last sample the monitor saw.
    pub now: f64,
    /// Motor, brake, friction.
    pub modes: Vec<ModeForecast>,
}

/// The drift of mode `m` that, held on every trip, brings the mode's risk to `risk`: the
/// per-mode lens c = ln(1 + d/scale) in excess of τ_m, scale = max(σ_m, k_m·SE_m) and, where
/// the lens also reads the level alone, its healthy RMS and error; accumulated to its steady state
/// x·exp(κ·D_max)/(1 − γ) (relative units).
pub fn drift_for_risk(cfg: &RiskConfig, m: usize, risk: f64) -> f64 {
    let x = risk / cfg.steady_state(1.0);
    // The lens divides by max(σ_m, k_m·SE_m); SE_m of the re-identification at its healthy
    // information (the prior information the tracker starts from).
    let se = spd_inverse(&cfg.prior_info).map_or(0.0, |inv| (cfg.prior_s2 * inv[m][m]).sqrt());
    let joint = cfg.joint_scale(m, se);
    // A drift of mode m alone reads the same jointly and alone; the lens takes the smaller z,
    // i.e. the larger scale (the level alone against its healthy RMS, `lens_sd`).
    let scale = if cfg.lens_sd.is_some() {
        let alone = Rls::with_prior(cfg).alone(&cfg.healthy_coef, cfg.prior_s2)[m];
        joint.max(cfg.alone_scale(m, alone.map_or(0.0, |(_, se)| se)))
    } else {
        joint
    };
    scale * ((cfg.tau_modes[m] + x).exp() - 1.0)
}

/// Factor and unit that turn mode `m`'s relative drift into its physical unit; `f_c` is the
/// risk stage's friction reference (N) that scales the brake signature.
pub fn unit_of(m: usize, f_c: f64) -> (f64, &'static str, &'static str) {
    match MACHINE_MODES[m] {
        FaultMode::Motor => (100.0, "%", "Kd"),
        FaultMode::Friction => (100.0, "%", "friction"),
        _ => (f_c, "N", "brake drag"),
    }
}

/// The physical limit of mode `m` in relative units ([`KD_LIMIT`], [`FRICTION_LIMIT`],
/// [`BRAKE_DRAG_LIMIT_SHARE`] of the weight of car and rated load over `f_c`).
pub fn physical_limit(m: usize, elevator: &Elevator, f_c: f64) -> f64 {
    match MACHINE_MODES[m] {
        FaultMode::Motor => KD_LIMIT,
        FaultMode::Friction => FRICTION_LIMIT,
        _ => {
            BRAKE_DRAG_LIMIT_SHARE * (elevator.car_mass() + elevator.rated_load_kg) * G
                / f_c.max(1e-9)
        }
    }
}

/// The forecast from `history` at `now` with the monitor at `level`; the trend window starts
/// at `changed_since` (the first trip the sequential decision holds as changed) when given,
/// else [`TREND_WINDOW_DAYS`] back, and takes at least [`MIN_TREND_POINTS`] blocks.
pub fn forecast(
    history: &DriftHistory,
    cfg: &RiskConfig,
    elevator: &Elevator,
    f_c: f64,
    level: Level,
    now: f64,
    changed_since: Option<f64>,
) -> Forecast {
    let pts: Vec<DriftPoint> = history.points.iter().copied().collect();
    let from = changed_since.unwrap_or(now - TREND_WINDOW_DAYS * DAY_S);
    let mut first = pts.partition_point(|p| p.time < from);
    first = first.min(pts.len().saturating_sub(MIN_TREND_POINTS));
    let window = &pts[first..];
    let modes = (0..N_MODES)
        .map(|m| {
            let (k, unit, quantity) = unit_of(m, f_c);
            let tr = trend(window, m, now);
            let levels = [
                (
                    "advisory level",
                    drift_for_risk(cfg, m, cfg.advisory),
                    Level::Advisory,
                ),
                (
                    "alarm level",
                    drift_for_risk(cfg, m, cfg.alarm),
                    Level::Alarm,
                ),
                (
                    "physical limit",
                    physical_limit(m, elevator, f_c),
                    Level::Alarm,
                ),
            ];
            let crossings = levels
                .iter()
                .map(|&(name, target, lv)| Crossing {
                    name,
                    threshold: k * target,
                    when: match &tr {
                        _ if name != "physical limit" && level >= lv => When::Reached,
                        Some(t) => When::solve(t, target, now),
                        None => When::NoTrend,
                    },
                })
                .collect();
            ModeForecast {
                mode: MACHINE_MODES[m],
                quantity,
                unit,
                trend: tr.map(|t| scaled(t, k)),
                crossings,
            }
        })
        .collect();
    Forecast { now, modes }
}

/// The trend in physical units (factor `k`).
fn scaled(t: Trend, k: f64) -> Trend {
    Trend {
        level: k * t.level,
        level_se: k * t.level_se,
        slope_per_day: k * t.slope_per_day,
        slope_se: k * t.slope_se,
        ..t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use crate::sample::HOUR_S;

    /// Points every 4 h over `days` of a drift a + b·t plus AR(1) noise (ρ = 0.6) of sd `sd`.
    fn ramp(days: f64, b_per_day: f64, sd: f64, seed: u64) -> Vec<DriftPoint> {
        let mut rng = Rng::new(seed);
        let mut e = 0.0;
        (0..(days * 6.0) as usize)
            .map(|k| {
                let t = k as f64 * 4.0 * HOUR_S;
                e = 0.6 * e + 0.8 * sd * rng.normal();
                DriftPoint {
                    time: t,
                    trips: 50 * (k as u64 + 1),
                    drift: [b_per_day * t / DAY_S + e, e, e],
                    se: [0.3 * sd; N_MODES],
                }
            })
            .collect()
    }

    #[test]
    fn a_ramps_crossing_interval_holds_the_truth_in_most_seeds() {
        // Kd rising 1 %/day through a ±2 % autocorrelated wander, watched for 8 days: 0.10 is
        // crossed on day 10.
        // An interval that misses the truth is worse than none: "no trend" is allowed, a
        // confident wrong date is counted against the coverage.
        let (mut dated, mut missed) = (0, 0);
        for seed in 0..40 {
            let pts = ramp(8.0, 0.01, 0.02, seed);
            let now = pts.last().unwrap().time;
            let tr = trend(&pts, 0, now).unwrap();
            match When::solve(&tr, 0.10, now) {
                When::At { early, late, .. } => {
                    dated += 1;
                    if !(early <= 10.0 * DAY_S && late.map_or(true, |l| l >= 10.0 * DAY_S)) {
                        missed += 1;
                    }
                }
                When::NoTrend => {}
                other => panic!("seed {seed}: {other:?}"),
            }
        }
        // At the nominal 95 %, six or more misses in 40 have a probability of 1.4 %.
        assert!(dated >= 36, "only {dated} of 40 ramps dated");
        assert!(missed <= 5, "{missed} of {dated} intervals miss the truth");
    }

    #[test]
    fn no_slope_gives_no_trend() {
        let mut none = 0;
        for seed in 0..40 {
            let pts = ramp(6.0, 0.0, 0.02, seed);
            let now = pts.last().unwrap().time;
            let tr = trend(&pts, 0, now).unwrap();
            if matches!(When::solve(&tr, 0.10, now), When::NoTrend) {
                none += 1;
            }
        }
        assert!(none >= 34, "{none} of 40 flat runs say no trend");
    }

    #[test]
    fn the_history_is_bounded_and_keeps_its_newest_blocks() {
        let cfg = RiskConfig::default();
        let mut h = DriftHistory::default();
        let t = TripEvidence {
            start: 0.0,
            end: 0.0,
            n: 10,
            direction: 1,
            mean_e_u: 0.0,
            mean_e_f: 0.0,
            xtx: [2.0, 0.1, 0.2, 1.5, 0.1, 1.0],
            xtr: [0.2, 0.0, 0.1],
            rr: 1.0,
            plausible: true,
            thermal: Default::default(),
            load: Default::default(),
        };
        let blocks = MAX_POINTS + 30;
        for k in 0..blocks * BLOCK_TRIPS as usize {
            h.push(&cfg, &t, k as f64);
        }
        assert_eq!(h.points.len(), MAX_POINTS);
        assert_eq!(h.trips, (blocks * BLOCK_TRIPS as usize) as u64);
        let newest = h.points.back().unwrap();
        assert_eq!(newest.trips, h.trips);
        assert!(newest.drift[0].is_finite() && newest.se[0] > 0.0);
        let json = serde_json::to_vec(&h).unwrap();
        assert!(json.len() < 200 * 1024, "{} bytes", json.len());
        let back: DriftHistory = serde_json::from_slice(&json).unwrap();
        assert_eq!(back, h);
    }

    #[test]
    fn the_limits_are_in_physical_units() {
        let e = Elevator::new(1000.0, 1.75, 26);
        // 1 % of (1200 + 1000) kg · g over F_c = 300 N.
        let brake = physical_limit(FaultMode::Brake as usize, &e, 300.0);
        assert!((brake * 300.0 - 0.01 * 2200.0 * G).abs() < 1e-9);
        assert_eq!(unit_of(0, 300.0).0 * KD_LIMIT, 20.0);
        // A higher risk level needs a larger held drift.
        let cfg = RiskConfig::default();
        assert!(drift_for_risk(&cfg, 0, cfg.alarm) > drift_for_risk(&cfg, 0, cfg.advisory));
    }
}
