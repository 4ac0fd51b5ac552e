//! Tests of the risk stage: synthetic trips with known injected signatures.

use super::evidence::{spd_inverse, unpack, HEAT_INPUT_SPAN_S};
use super::*;
use crate::features::Phase;
use crate::model::HybridModel;
use crate::residual::tests::{row, test_model};
use crate::residual::Residuals;
use crate::rng::Rng;
use crate::sample::{DAY_S, HOUR_S};

/// A fault or drift as a voltage residual added to each moving sample.
pub(crate) type Injection<'a> = &'a dyn Fn(f64, &[f64; N_MODES]) -> f64;

/// Synthetic trips: S-shaped speed profile, random load and direction, white noise of
/// σ_U on the voltage, a daily ±3 % swing of Kd (thermal), plus `fault(t, signature)`, the
/// signatures at the Kd of that moment (the swing included).
pub(crate) fn synthetic_trips(
    model: &HybridModel,
    seed: u64,
    days: f64,
    t0: f64,
    fault: Injection,
) -> Vec<TripEvidence> {
    heated_trips(model, seed, days, t0, fault, 0.0, DEFAULT_WINDING_TAU_S)
}

/// [`synthetic_trips`] of a healthy machine whose load cell reads `offset(t)` (share of the
/// rated load) above the load the car carries.
pub(crate) fn offset_load_trips(
    model: &HybridModel,
    seed: u64,
    days: f64,
    offset: &dyn Fn(f64) -> f64,
) -> Vec<TripEvidence> {
    trips_of(
        model,
        seed,
        days,
        0.0,
        &|_, _| 0.0,
        offset,
        0.0,
        DEFAULT_WINDING_TAU_S,
    )
}

/// [`synthetic_trips`] on a winding that heats: Kd·(1 + β·H) with H a first-order lag of
/// 45 min of (F/F_ref)² and a daily swing of ±3 %, the evidence carrying the monitor's
/// [`Heating`] basis with a lag of `basis_tau_s`.
pub(crate) fn heated_trips(
    model: &HybridModel,
    seed: u64,
    days: f64,
    t0: f64,
    fault: Injection,
    beta: f64,
    basis_tau_s: f64,
) -> Vec<TripEvidence> {
    trips_of(model, seed, days, t0, fault, &|_| 0.0, beta, basis_tau_s)
}

/// The one generator behind the helpers above: `load_offset(t)` is added to the load reading
/// after the voltage was made from the load the car carries.
#[allow(clippy::too_many_arguments)]
fn trips_of(
    model: &HybridModel,
    seed: u64,
    days: f64,
    t0: f64,
    fault: Injection,
    load_offset: &dyn Fn(f64) -> f64,
    beta: f64,
    basis_tau_s: f64,
) -> Vec<TripEvidence> {
    let mut heating = Heating::default();
    let mut winding = (0.0f64, f64::NAN);
    let f_ref = heating_reference(model);
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();
    let mut t = t0;
    let sigma = model.scales.sigma_u_v;
    let friction = friction_reference(model);
    // The car stands between trips: a row each second, as an aligned log has them.
    let mut idle_from = t0;
    while t < t0 + days * DAY_S {
        t += rng.uniform(60.0, 400.0);
        let mut idle = idle_from;
        while idle < t {
            heating.advance(basis_tau_s, idle, HeatInput::Rest);
            idle += 1.0;
        }
        let s = if rng.uniform(0.0, 1.0) < 0.5 {
            1.0
        } else {
            -1.0
        };
        let lambda = rng.uniform(0.0, 0.9);
        let cruise = (rng.uniform(1.0, 14.0)) as usize;
        let mut acc = TripAccumulator::default();
        let profile: Vec<(f64, f64, Phase)> = [
            (0.6, 0.8, Phase::Accelerating),
            (1.4, 0.6, Phase::Accelerating),
        ]
        .into_iter()
        .chain(std::iter::repeat((1.75, 0.0, Phase::Cruising)).take(cruise))
        .chain([
            (1.3, -0.6, Phase::Decelerating),
            (0.5, -0.8, Phase::Decelerating),
        ])
        .collect();
        let profile_len = profile.len();
        for (i, (speed, acc_mag, phase)) in profile.into_iter().enumerate() {
            let time = t + i as f64;
            let mut x = row(model, time, s * speed, lambda, s * acc_mag, 0.0);
            x.phase = phase;
            let p = model.predict(&x);
            let sig = signature(model, friction, &x, p.f_pred);
            let h = heating.advance_row((f_ref, basis_tau_s), &x, Some(&p));
            // The true winding cools while the car stands, and takes each sample's load
            // over the second before it.
            let gap = time - winding.1;
            if gap > 1.0 {
                winding.0 *= (-(gap - 1.0) / 2700.0).exp();
            }
            let keep = (-gap.min(1.0) / 2700.0).exp();
            let keep = if keep.is_finite() { keep } else { 0.0 };
            winding = (
                keep * winding.0 + (1.0 - keep) * (p.f_pred / f_ref).powi(2),
                time,
            );
            let daily = 0.03 * (2.0 * std::f64::consts::PI * time / DAY_S).sin();
            let warm = daily + beta * winding.0;
            // A fault's voltage passes through the Kd the winding has now, as the healthy
            // force's does.
            let present = sig.map(|x| (1.0 + warm) * x);
            x.voltage += warm * sig[MOTOR] + fault(time, &present) + sigma * rng.normal();
            x.lambda += load_offset(time);
            let p = model.predict(&x);
            let r = Residuals::from_prediction(model, &x, &p);
            acc.push(model, friction, &x, (&p, &r), h);
        }
        out.extend(acc.finish(true));
        idle_from = t + profile_len as f64;
        t += 20.0;
    }
    out
}

#[test]
fn the_winding_heats_and_cools_with_its_time_constant() {
    let tau = 2400.0;
    let mut h = Heating::default();
    h.advance(tau, 0.0, HeatInput::Moving(1.0));
    assert_eq!(
        h.h, 1.0,
        "the first sample finds a winding long at its load"
    );
    // A car running at the reference force: after τ the lag holds 1 − 1/e of it.
    let mut cold = Heating::default();
    cold.advance(tau, 0.0, HeatInput::Rest);
    for s in 1..=tau as u32 {
        cold.advance(tau, f64::from(s), HeatInput::Moving(1.0));
    }
    assert!((cold.h - (1.0 - (-1.0f64).exp())).abs() < 1e-3, "{cold:?}");
    // Standing still it cools by e in τ.
    let warm = cold.h;
    for s in tau as u32 + 1..=2 * tau as u32 {
        cold.advance(tau, f64::from(s), HeatInput::Rest);
    }
    assert!((cold.h - warm / std::f64::consts::E).abs() < 1e-9);
    // The daily harmonic is the phase of the day: at 06:00 the sine's peak.
    let b = cold.advance(tau, 10.0 * DAY_S + 6.0 * HOUR_S, HeatInput::Rest);
    assert!(
        b[HEAT_LAG + 1].abs() < 1e-9 && (b[HEAT_LAG + 2] - 1.0).abs() < 1e-9,
        "{b:?}"
    );
    // Time that runs backwards or is not finite changes nothing.
    let before = cold;
    cold.advance(tau, 0.0, HeatInput::Moving(5.0));
    cold.advance(tau, f64::NAN, HeatInput::Moving(5.0));
    assert_eq!(cold, before);
}

#[test]
fn a_dropout_in_a_busy_hour_does_not_cool_the_winding() {
    // A busy hour: 40 s trips at (F/F_ref)² = 0.5 with 20 s stops, for an hour and a half.
    // Minutes 40-53 lose the load cell (the force of the moving seconds is unknown), minutes
    // 60-70 every channel (whether the car moves is unknown).
    let tau = 2100.0;
    let busy = |s: u32| s % 60 < 40;
    let (mut known, mut blind, mut as_rest) =
        (Heating::default(), Heating::default(), Heating::default());
    let (mut worst, mut worst_rest) = (0.0f64, 0.0f64);
    for s in 0..5400u32 {
        let t = f64::from(s);
        let truth = if busy(s) {
            HeatInput::Moving(0.5)
        } else {
            HeatInput::Rest
        };
        let seen = match s {
            2400..=3180 if busy(s) => HeatInput::MovingUnknown,
            3600..=4200 => HeatInput::Unknown,
            _ => truth,
        };
        known.advance(tau, t, truth);
        blind.advance(tau, t, seen);
        // What the lag did before: an unknown sample as a car at rest.
        let old = match seen {
            HeatInput::MovingUnknown | HeatInput::Unknown => HeatInput::Rest,
            i => i,
        };
        as_rest.advance(tau, t, old);
        worst = worst.max((blind.h - known.h).abs() / known.h);
        worst_rest = worst_rest.max((as_rest.h - known.h).abs() / known.h);
    }
    assert!(worst < 0.05, "H off by {:.1} % at worst", 100.0 * worst);
    assert!(
        worst_rest > 0.2,
        "the old lag should cool by a fifth or more: {:.1} %",
        100.0 * worst_rest
    );
    // A log with three hours missing altogether holds H across them: the row after them
    // speaks for its last minute only.
    let h = known.h;
    known.advance(tau, 5400.0 + 3.0 * HOUR_S, HeatInput::Moving(0.5));
    let minute = (1.0 - (-HEAT_INPUT_SPAN_S / tau).exp()) * (0.5 - h);
    assert!(
        (known.h - h - minute).abs() < 1e-12,
        "{} against {h} + {minute}",
        known.h
    );
}

#[test]
fn inverse_of_a_spd_matrix_is_exact() {
    let p = [4.0, 1.0, 0.5, 3.0, 0.2, 2.0];
    let inv = spd_inverse(&p).unwrap();
    let a = unpack(&p);
    for i in 0..3 {
        for j in 0..3 {
            let v: f64 = (0..3).map(|k| a[i][k] * inv[k][j]).sum();
            assert!((v - f64::from(u8::from(i == j))).abs() < 1e-12);
        }
    }
    assert!(
        spd_inverse(&[1.0, 1.0, 0.0, 1.0, 0.0, 1.0]).is_none(),
        "singular"
    );
}

#[test]
fn regression_recovers_injected_coefficients() {
    let m = test_model();
    let trips = synthetic_trips(&m, 3, 2.0, 0.0, &|_, x| {
        0.10 * x[MOTOR] + 0.25 * x[FRICTION] + 0.5 * x[BRAKE]
    });
    let mut rls = Rls::default();
    for t in &trips {
        rls.update(t, 1.0);
    }
    let (theta, _) = rls.estimate(1.0).unwrap();
    // The thermal swing averages out over two whole days.
    assert!((theta[MOTOR] - 0.10).abs() < 0.01, "{theta:?}");
    assert!((theta[FRICTION] - 0.25).abs() < 0.05, "{theta:?}");
    assert!((theta[BRAKE] - 0.5).abs() < 0.1, "{theta:?}");
}

#[test]
fn each_signature_alone_reads_its_projection_of_an_offset() {
    // An offset along friction alone: friction's lens reads it whole; the others read only
    // its projection on them (Σ x_m·x_f/Σ x_m² of it), never the large opposite drifts a
    // joint fit of near-collinear signatures can split it into, and nothing when θ0 already
    // holds it.
    let m = test_model();
    let offset = 0.2;
    let trips = synthetic_trips(&m, 5, 2.0, 0.0, &|_, x| offset * x[FRICTION]);
    let mut rls = Rls::default();
    let (mut xx, mut xf) = ([0.0; N_MODES], [0.0; N_MODES]);
    for t in &trips {
        rls.update(t, 1.0);
        let w = unpack(&t.xtx);
        for k in 0..N_MODES {
            xx[k] += w[k][k];
            xf[k] += w[k][FRICTION];
        }
    }
    let lens = rls.alone(&[0.0; N_MODES], 1.0);
    let (d, se) = lens[FRICTION].expect("friction has information");
    assert!((d - offset).abs() < 0.05, "friction alone {d} ± {se}");
    for k in [MOTOR, BRAKE] {
        let (d, _) = lens[k].expect("information");
        let projection = offset * xf[k] / xx[k];
        assert!(
            (d - projection).abs() < 0.05 * offset.max(projection.abs()) + 0.02,
            "mode {k}: {d} against the projection {projection}"
        );
    }
    let mut theta0 = [0.0; N_MODES];
    theta0[FRICTION] = offset;
    for (k, lens) in rls.alone(&theta0, 1.0).into_iter().enumerate() {
        let (d, _) = lens.expect("information");
        assert!(
            d.abs() < 0.05 * offset + 0.02,
            "mode {k} reads {d} with θ0 holding it"
        );
    }
}

#[test]
fn a_model_files_winding_levels_are_checked() {
    let mut cfg = RiskConfig::default();
    cfg.validate().expect("the default settings are valid");
    cfg.winding.levels = Some([-0.09, 0.02, 0.0]);
    cfg.validate().expect("a fitted level is valid");
    for bad in [f64::NAN, f64::INFINITY, 1e4] {
        cfg.winding.levels = Some([0.0, bad, 0.0]);
        let err = cfg.validate().expect_err("a level out of range is refused");
        assert!(err.to_string().contains("risk.winding.levels"), "{err}");
    }
}
