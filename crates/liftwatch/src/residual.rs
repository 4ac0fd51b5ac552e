//! Stage 5: dual residuals of one feature row against the hybrid model (paper, Sec. 3.3, 4.2).
//!
//! ```text
//! r_U = U_meas − U_pred                  electrical consistency (V); also at standstill, where
//!                                        U_pred reduces to U0 (+ the network's correction)
//! r_F = F_pred − F_U                     mechanical consistency (N); only while moving (s ≠ 0)
//! e_U = r_U / σ_U,   e_F = r_F / σ_F     dimensionless with the healthy scales of the fit
//! e   = sqrt((e_U² + e_F²) / 2)          combined; one lens alone when the other is missing
//! ```
//!
//! A residual is `NaN` when it is not applicable: r_U needs finite v, a, λ and voltage;
//! r_F needs in addition motion.
//!
//! Caveat, not a deviation: without a current sensor, F_U is derived from the *same*
//! measured voltage through the motor model, F_U = (U − U0 − Ke·|v|)/(φ(s)·Kd·s). Substituting
//! U = U_pred + r_U gives
//!
//! ```text
//! r_F = δF − (δU + r_U)/(φ(s)·Kd·s)  ≈  −r_U/(φ(s)·Kd·s)   up to the network's corrections
//! ```
//!
//! so the two lenses are not independent evidence: they see the same voltage deviation, once
//! in volts and once converted to newtons. The risk stage therefore never counts them as two
//! independent observations (see [`crate::risk`]).

use crate::features::FeatureRow;
use crate::model::{HybridModel, Prediction};

/// The dual residuals of one sample. `NaN` marks a residual that is not applicable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residuals {
    /// r_U = U_meas − U_pred (V).
    pub r_u: f64,
    /// r_F = F_pred − F_U (N); NaN at standstill.
    pub r_f: f64,
    /// e_U = r_U/σ_U (1).
    pub e_u: f64,
    /// e_F = r_F/σ_F (1).
    pub e_f: f64,
    /// e = sqrt((e_U² + e_F²)/2), or the one finite lens alone (1).
    pub e: f64,
}

impl Residuals {
    /// All residuals missing.
    pub const MISSING: Residuals = Residuals {
        r_u: f64::NAN,
        r_f: f64::NAN,
        e_u: f64::NAN,
        e_f: f64::NAN,
        e: f64::NAN,
    };

    /// The residuals of `x` with `model` (one forward pass of the network, inputs as
    /// [`net_inputs`]).
    pub fn compute(model: &HybridModel, x: &FeatureRow) -> Residuals {
        if !applicable(x) {
            return Residuals::MISSING;
        }
        Residuals::from_prediction(model, x, &model.predict(x))
    }

    /// The residuals of `x` from a prediction already made for it.
    pub fn from_prediction(model: &HybridModel, x: &FeatureRow, p: &Prediction) -> Residuals {
        if !applicable(x) {
            return Residuals::MISSING;
        }
        let r_u = x.voltage - p.u_pred;
        let r_f = if x.s != 0 { p.f_pred - p.f_u } else { f64::NAN };
        Residuals::scaled(r_u, r_f, model.scales.sigma_u_v, model.scales.sigma_f_n)
    }

    /// Scales raw residuals by the healthy σ and combines them.
    pub fn scaled(r_u: f64, r_f: f64, sigma_u: f64, sigma_f: f64) -> Residuals {
        let e_u = if r_u.is_finite() && sigma_u > 0.0 {
            r_u / sigma_u
        } else {
            f64::NAN
        };
        let e_f = if r_f.is_finite() && sigma_f > 0.0 {
            r_f / sigma_f
        } else {
            f64::NAN
        };
        let e = match (e_u.is_finite(), e_f.is_finite()) {
            (true, true) => ((e_u * e_u + e_f * e_f) / 2.0).sqrt(),
            (true, false) => e_u.abs(),
            (false, true) => e_f.abs(),
            (false, false) => f64::NAN,
        };
        Residuals {
            r_u,
            r_f,
            e_u,
            e_f,
            e,
        }
    }
}

/// True when the voltage residual can be formed: v, a, λ and voltage are all finite.
pub fn applicable(x: &FeatureRow) -> bool {
    x.v.is_finite() && x.a.is_finite() && x.lambda.is_finite() && x.voltage.is_finite()
}

pub use crate::model::net_inputs;
use crate::model::{rest_lambda, rest_lambda_grid};

/// Memo of the network's outputs, keyed by the exact network inputs: the last call's, and
/// every input at rest seen so far.
///
/// At standstill the inputs are (0, λ, 0) with λ held from door close and rounded to 0.001
/// ([`net_inputs`]), so a car at rest shows under a thousand distinct inputs in a month: the
/// memo turns their forward pass into a lookup (on 30 simulated days, 17,000 passes for
/// 2.2 M standstill samples, where the last call's output alone left 284,000). Moving samples miss
/// it and pay the one 370-weight pass. A hit returns the bits a pass would: the network is a
/// pure function of its inputs, and an entry is only taken when its key's bits are the
/// inputs' bits. One cache serves one model, as the last call's output always did.
#[derive(Clone, Debug, Default)]
pub struct PredictionCache {
    key: Option<Key>,
    du: f64,
    df: f64,
    /// Outputs at rest, inputs (0, λ, 0): slot [`rest_slot`] of λ holds λ's bits and the
    /// output; empty until the first standstill sample (a cache that never sees one, as in
    /// the fit's per-trip sums, allocates nothing).
    rest: Vec<Option<(u64, [f64; 2])>>,
    /// The bits of the last floor reading and the elevator's floors, with the reading's
    /// relative height ([`crate::model::PhysParams::relative_height`]).
    height: Option<((u64, u32), f64)>,
}

/// What [`PredictionCache`] keys its last output by: the bits of λ's grid steps at rest,
/// of (v, λ, a) while moving.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Key {
    Rest(u64),
    Moving([u64; 3]),
}

/// Slots of [`PredictionCache`]'s table of outputs at rest, 8 KiB, held by every monitor
/// (a server keeps one per elevator): λ·1000 and λ·1000 + 256 share a slot and are told
/// apart by their bits. On the 30 days above 256 slots left 17,000 passes at rest, 2,048
/// (one per λ up to [`crate::features::LAMBDA_MAX`], 64 KiB) 928: a saving of 5 % of the
/// passes for eight times the memory.
const REST_SLOTS: usize = 256;

/// The slot of λ's grid steps ([`rest_lambda_grid`]) in the table of outputs at rest,
/// wrapped into the table. Only where an entry is looked for; whether it is λ's is decided
/// by its bits.
fn rest_slot(steps: f64) -> usize {
    // `as` saturates (NaN to 0); the wrap keeps any λ inside the table.
    (steps as i64 as usize) % REST_SLOTS
}

impl PredictionCache {
    /// The prediction for `x`, reusing the network output when its inputs equal the last
    /// call's or an input at rest seen before.
    pub fn predict(&mut self, model: &HybridModel, x: &FeatureRow) -> Prediction {
        // At rest the key is λ's grid steps ([`net_inputs`]' λ before its division, one to
        // one with it), so that a hit costs no division.
        let key = if x.s == 0 {
            Key::Rest(rest_lambda_grid(x.lambda).to_bits())
        } else {
            Key::Moving([x.v.to_bits(), x.lambda.to_bits(), x.a.to_bits()])
        };
        if self.key != Some(key) {
            let [du, df] = match key {
                Key::Rest(steps) => self.at_rest(model, f64::from_bits(steps)),
                Key::Moving(_) => model.net.forward(x.v, x.lambda, x.a),
            };
            (self.key, self.du, self.df) = (Some(key), du, df);
        }
        // The floor's relative height, kept while the floor reading holds (a division a row).
        let key = (x.floor.to_bits(), model.elevator.floors);
        let q = match self.height {
            Some((k, q)) if k == key => q,
            _ => {
                let q = crate::model::PhysParams::relative_height(x.floor, key.1);
                self.height = Some((key, q));
                q
            }
        };
        model.predict_at(x, q, [self.du, self.df])
    }

    /// The network's output at (+0, λ, +0) for λ of `steps` grid steps, from the table or by
    /// one pass stored there.
    fn at_rest(&mut self, model: &HybridModel, steps: f64) -> [f64; 2] {
        if self.rest.is_empty() {
            self.rest = vec![None; REST_SLOTS];
        }
        let bits = steps.to_bits();
        let slot = &mut self.rest[rest_slot(steps)];
        match *slot {
            Some((k, y)) if k == bits => y,
            _ => {
                let y = model.net.forward(0.0, rest_lambda(steps), 0.0);
                *slot = Some((bits, y));
                y
            }
        }
    }

    /// The residuals of `x`, through the memo.
    pub fn residuals(&mut self, model: &HybridModel, x: &FeatureRow) -> Residuals {
        if !applicable(x) {
            return Residuals::MISSING;
        }
        let p = self.predict(model, x);
        Residuals::from_prediction(model, x, &p)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::elevator::Elevator;
    use crate::features::{FeatureConfig, Phase};
    use crate::model::{PhysParams, ResidualNet, ResidualScales};

    /// A model with prior-centre physics and a zero network, for unit tests of later stages.
    pub(crate) fn test_model() -> HybridModel {
        let elevator = Elevator::new(1000.0, 1.75, 26);
        HybridModel {
            parameters: PhysParams::prior_centre(&elevator),
            net: ResidualNet::new(1, [1.75, 1.0, 1.0], [5.0, 500.0]),
            scales: ResidualScales {
                sigma_u_v: 1.5,
                sigma_f_n: 300.0,
            },
            elevator,
        }
    }

    /// Feature settings matching [`test_model`].
    pub(crate) fn test_features() -> FeatureConfig {
        FeatureConfig {
            rated_load_kg: 1000.0,
            moving_threshold_mps: 0.05,
            load_cell_platform_ratio: 0.3,
            load_cell_load_gain: 1.0,
            beta_transient: 0.7,
            beta_cruise: 0.3,
        }
    }

    /// A feature row whose voltage is exactly what the model predicts plus `r_u`.
    pub(crate) fn row(
        model: &HybridModel,
        time: f64,
        v: f64,
        lambda: f64,
        a: f64,
        r_u: f64,
    ) -> FeatureRow {
        let s = if v.abs() > 0.05 { v.signum() as i8 } else { 0 };
        let mut x = FeatureRow {
            time,
            v,
            s,
            lambda,
            a_v: a,
            a_l: f64::NAN,
            a,
            d2v: f64::NAN,
            d2u: f64::NAN,
            voltage: 0.0,
            floor: f64::NAN,
            phase: if s == 0 {
                Phase::Standstill
            } else {
                Phase::Cruising
            },
            trip: None,
        };
        x.voltage = PredictionCache::default().predict(model, &x).u_pred + r_u;
        x
    }

    #[test]
    fn exact_voltage_leaves_no_residual() {
        let m = test_model();
        let r = Residuals::compute(&m, &row(&m, 0.0, 1.5, 0.4, 0.0, 0.0));
        assert!(r.r_u.abs() < 1e-9 && r.r_f.abs() < 1e-6, "{r:?}");
    }

    #[test]
    fn force_residual_mirrors_the_voltage_residual() {
        // Without a current sensor the two lenses see the same deviation: r_F = −r_U/(φ·Kd·s).
        let m = test_model();
        for (v, r_u) in [(1.5, 3.0), (-1.5, 3.0), (1.0, -2.0)] {
            let r = Residuals::compute(&m, &row(&m, 0.0, v, 0.4, 0.0, r_u));
            let s = v.signum();
            let expect = -r_u / (m.parameters.phi(s as i8) * m.parameters.kd * s);
            assert!(
                (r.r_f - expect).abs() < 1e-6 * expect.abs(),
                "{} vs {expect}",
                r.r_f
            );
            assert!((r.e_u - r_u / 1.5).abs() < 1e-9);
        }
    }

    #[test]
    fn standstill_checks_only_the_voltage() {
        let m = test_model();
        let r = Residuals::compute(&m, &row(&m, 0.0, 0.0, 0.4, 0.0, 3.0));
        assert!((r.r_u - 3.0).abs() < 1e-9);
        assert!(r.r_f.is_nan() && r.e_f.is_nan());
        assert!((r.e - 2.0).abs() < 1e-9, "one lens alone: e = |e_U|");
    }

    #[test]
    fn missing_voltage_makes_every_residual_missing() {
        let m = test_model();
        let mut x = row(&m, 0.0, 1.0, 0.4, 0.0, 0.0);
        x.voltage = f64::NAN;
        let r = Residuals::compute(&m, &x);
        assert!(r.r_u.is_nan() && r.r_f.is_nan() && r.e.is_nan());
    }

    #[test]
    fn cached_prediction_equals_a_fresh_one() {
        let mut m = test_model();
        let mut rng = crate::rng::Rng::new(5);
        for w in &mut m.net.weights {
            *w = rng.uniform(-0.5, 0.5);
        }
        assert_eq!(
            rest_slot(rest_lambda_grid(0.952)),
            rest_slot(rest_lambda_grid(3.0)),
            "the test's λ share a slot"
        );
        let mut cache = PredictionCache::default();
        for x in [
            row(&m, 0.0, 0.0, 0.3, 0.0, 1.0),
            row(&m, 1.0, 0.0, 0.3, 0.0, 2.0),
            row(&m, 2.0, 1.2, 0.3, 0.4, 1.0),
            // Back at rest on a λ the table holds, then two λ that share a slot
            // (3000 and 952 both wrap onto slot 184).
            row(&m, 3.0, 0.0, 0.3, 0.0, 1.5),
            row(&m, 4.0, 0.0, 0.952, 0.0, 1.0),
            row(&m, 5.0, 0.0, 3.0, 0.0, 1.0),
            row(&m, 6.0, 0.0, 0.952, 0.0, 1.0),
            row(&m, 7.0, 0.0, 0.3, 0.0, -1.0),
            // λ a hair below zero rounds to −0, a half step away from zero.
            row(&m, 8.0, 0.0, -0.0003, 0.0, 1.0),
            row(&m, 9.0, 0.0, -0.0, 0.0, 1.0),
            row(&m, 10.0, 0.0, 0.0005, 0.0, 1.0),
        ] {
            let (a, b) = (cache.residuals(&m, &x), Residuals::compute(&m, &x));
            let bits = |r: Residuals| [r.r_u, r.r_f, r.e_u, r.e_f, r.e].map(f64::to_bits);
            assert_eq!(bits(a), bits(b), "{a:?} vs {b:?}");
        }
    }
}
