//! Fitting the hybrid model: physics first, then physics and network together.
//!
//! ```text
//! stage 1  θ̂₁ = argmin Σ w_i·(U_i − U_phys(x_i; θ))²/σ_U² + Σ_k ((θ_k − μ_k)/τ_k)²   Gauss-Newton (LM)
//! stage 2  (θ̂, ŵ) = argmin L(θ, w)  of [`loss`](crate::model::loss), from (θ̂₁, δ ≡ 0)     L-BFGS
//! ```
//!
//! Deviation from the paper: the paper trains θ and the network together with Adam for about
//! 20,000 full-batch epochs from scratch. The model is algebraic, so the fit is a nonlinear
//! least-squares problem: stage 1 solves the physical part exactly in a few Gauss-Newton steps,
//! stage 2 lets the network correct what the physics cannot represent (rope imbalance, drive
//! nonlinearity) with a quasi-Newton method. The paper's schedule stays available as
//! [`Optimizer::Adam`] for comparison; it starts from the prior centre as the paper does.
//!
//! Identifiability without a current signal: moving data alone alias U0 with Kd·F_c and Ke
//! with Kd·c. Standstill samples fix U0, the known rated load fixes Kd through the load slope,
//! and the up/down asymmetry separates F_c from Δm; Ke and c separate only through α_down ≠ 1,
//! weakly. [`ParamReport`] says, per parameter, whether the data or the prior decided it.

use serde::{Deserialize, Serialize};

use crate::elevator::Elevator;
use crate::error::{Error, Result};
use crate::features::FeatureRow;
use crate::linalg::SquareMatrix;
use crate::model::loss::{LossStats, LossWeights, Objective, Obs, ParamMap, Prior, N_UNKNOWNS};
use crate::model::net::ResidualNet;
use crate::model::physics::{PhysParams, N_PHYS};
use crate::model::ResidualScales;

/// The optimiser of stage 2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Optimizer {
    /// Gauss-Newton on the physics, then L-BFGS on everything (default).
    Lbfgs,
    /// The paper's schedule: Adam on everything from the prior centre, full batch.
    Adam,
}

/// Settings of the fit; saved in the model file beside θ and the network weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// Stage-2 optimiser.
    pub optimizer: Optimizer,
    /// Iterations of stage 2 (L-BFGS iterations or Adam epochs).
    pub epochs: usize,
    /// Adam's learning rate.
    pub learning_rate: f64,
    /// Seed of the network's initial weights.
    pub seed: u64,
    /// w_U: weight of the electrical residual.
    pub w_u: f64,
    /// w_F: weight of the mechanical residual.
    pub w_f: f64,
    /// w_P: weight of the prior.
    pub w_p: f64,
    /// w_N: price of the network's corrections.
    pub w_n: f64,
    /// Total weight of all standstill samples relative to all moving samples.
    pub standstill_share: f64,
    /// Log a progress line every this many iterations (0: never).
    pub log_every: usize,
    /// Most moving samples the hybrid stage uses: a longer log is thinned evenly, each kept
    /// sample weighing for the ones it stands for. Stage 1, the standard errors and the risk
    /// calibration always use every sample.
    #[serde(default = "default_stage2_max_moving")]
    pub stage2_max_moving: usize,
}

fn default_stage2_max_moving() -> usize {
    6000
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            optimizer: Optimizer::Lbfgs,
            epochs: 1500,
            learning_rate: 1e-3,
            seed: 1,
            w_u: 1.0,
            w_f: 1.0,
            w_p: 1.0,
            w_n: 0.2,
            standstill_share: 0.1,
            log_every: 100,
            stage2_max_moving: default_stage2_max_moving(),
        }
    }
}

impl TrainConfig {
    /// Checks every setting.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the first setting out of range.
    pub fn validate(&self) -> Result<()> {
        let pos = |field: &'static str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::InvalidConfig {
                    field,
                    why: format!("{v} must be a finite number >= 0"),
                })
            }
        };
        pos("w_u", self.w_u)?;
        pos("w_f", self.w_f)?;
        pos("w_p", self.w_p)?;
        pos("w_n", self.w_n)?;
        pos("standstill_share", self.standstill_share)?;
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return Err(Error::InvalidConfig {
                field: "learning_rate",
                why: format!("{} must be > 0", self.learning_rate),
            });
        }
        if self.w_u + self.w_f == 0.0 {
            return Err(Error::InvalidConfig {
                field: "w_u",
                why: "w_u and w_f cannot both be 0".into(),
            });
        }
        Ok(())
    }
}

/// One point of the training history (what the report plots).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainPoint {
    /// Stage: 1 physics (Gauss-Newton), 2 hybrid.
    pub stage: u8,
    /// Iteration within the whole fit.
    pub iteration: usize,
    /// Loss L.
    pub loss: f64,
    /// RMS of r_U over moving samples (V).
    pub rms_u_v: f64,
    /// RMS of r_F over moving samples (N).
    pub rms_f_n: f64,
    /// θ at this point, in the order of [`PhysParams::NAMES`].
    pub theta: [f64; N_PHYS],
}

/// What the data say about one parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamReport {
    /// Name as in [`PhysParams::NAMES`], or a combination such as `ke + kd*c_visc`.
    pub name: String,
    /// Unit.
    pub unit: String,
    /// Identified value.
    pub value: f64,
    /// Standard error from the Gauss-Newton covariance (samples taken as independent, so a
    /// lower bound where residuals within a trip are correlated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std_error: Option<f64>,
    /// Prior width τ; none for combinations of parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_sd: Option<f64>,
    /// True when the data narrowed the prior at least threefold: the value is the data's.
    pub determined: bool,
}

/// Everything the fit found besides the model itself.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// Moving samples used.
    pub moving_samples: usize,
    /// Standstill samples used.
    pub standstill_samples: usize,
    /// Per parameter and identifiable combination: value, standard error, determined or not.
    pub parameters: Vec<ParamReport>,
    /// Training history, thinned to at most a few hundred points.
    pub history: Vec<TrainPoint>,
    /// Final RMS of r_U over moving samples (V).
    pub rms_u_v: f64,
    /// Final RMS of r_F over moving samples (N).
    pub rms_f_n: f64,
    /// Loss after stage 1 and at the end.
    pub loss_stage1: f64,
    /// Final loss.
    pub loss_final: f64,
    /// Stage-2 iterations run.
    pub iterations: usize,
    /// Warnings about what the data could not determine.
    pub warnings: Vec<String>,
}

/// The trained hybrid model, before risk calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct Trained {
    /// Identified θ.
    pub parameters: PhysParams,
    /// The correcting network.
    pub net: ResidualNet,
    /// Healthy residual scales.
    pub scales: ResidualScales,
    /// Standard errors, history, warnings.
    pub summary: FitSummary,
}

/// Minimum moving time (s) and trips the fit needs.
pub const MIN_MOVING_S: f64 = 120.0;
/// Minimum number of trips the fit needs.
pub const MIN_TRIPS: usize = 6;

/// Turns feature rows into observations: moving rows one by one, standstill rows averaged per
/// load bin (0.5 % of rated load), which leaves a quadratic loss unchanged up to a constant
/// while cutting the standstill work of a long log to a few hundred terms.
///
/// Moving rows are weighted by how well their instant is known. Each signal is logged on its
/// own ≈1 Hz clock, so the speed at a voltage instant is interpolated, and between samples
/// that interpolation errs by up to |Δ²v|/8 (the curvature of v over one step). Through the
/// back-EMF term that is an extra voltage error of about Ke·|Δ²v|/8, tens of volts in a jerk
/// phase against a volt of sensor noise. Weights w = σ²/(σ² + (Ke·Δ²v/8)²), with σ and Ke
/// from the prior (`sigma_v`, `ke_v_s_per_m`), give those rows the little trust they deserve.
/// Deviation from the paper, which weighs all moving samples alike.
///
/// # Errors
/// [`Error::TooLittleMotion`] and [`Error::Unidentifiable`] when the rows cannot determine θ.
pub fn observations(
    rows: &[FeatureRow],
    floors: u32,
    standstill_share: f64,
) -> Result<(Vec<Obs>, usize, usize)> {
    observations_weighted(rows, floors, standstill_share, 0.0, 1.0)
}

/// [`observations`] with interpolation weights for a back-EMF slope `ke_v_s_per_m` (V·s/m) and
/// a voltage noise `sigma_v` (V); `ke_v_s_per_m` = 0 gives every moving row weight 1.
///
/// # Errors
/// As [`observations`].
pub fn observations_weighted(
    rows: &[FeatureRow],
    floors: u32,
    standstill_share: f64,
    ke_v_s_per_m: f64,
    sigma_v: f64,
) -> Result<(Vec<Obs>, usize, usize)> {
    let ok = |r: &FeatureRow| {
        r.v.is_finite() && r.lambda.is_finite() && r.a.is_finite() && r.voltage.is_finite()
    };
    let mut moving: Vec<Obs> = Vec::new();
    let mut trips = std::collections::BTreeSet::new();
    let (mut up, mut down) = (0usize, 0usize);
    let mut bins: std::collections::BTreeMap<i64, (f64, f64, f64)> =
        std::collections::BTreeMap::new();
    let mut n_rest = 0usize;
    for (i, r) in rows.iter().enumerate().filter(|(_, r)| ok(r)) {
        if r.s != 0 {
            let w = interpolation_weight(rows, i, ke_v_s_per_m, sigma_v);
            let q = PhysParams::relative_height(r.floor, floors);
            moving.push(Obs {
                s: r.s,
                v: r.v,
                lambda: r.lambda,
                a: r.a,
                q,
                u: r.voltage,
                w,
            });
            if let Some(t) = r.trip {
                trips.insert(t);
            }
            if r.s > 0 {
                up += 1;
            } else {
                down += 1;
            }
        } else {
            let b = bins
                .entry((r.lambda * 200.0).round() as i64)
                .or_insert((0.0, 0.0, 0.0));
            b.0 += 1.0;
            b.1 += r.lambda;
            b.2 += r.voltage;
            n_rest += 1;
        }
    }
    let moving_s = moving.len() as f64;
    let moving_w: f64 = moving.iter().map(|o| o.w).sum();
    if moving_s < MIN_MOVING_S || trips.len() < MIN_TRIPS {
        return Err(Error::TooLittleMotion {
            moving_s,
            trips: trips.len(),
            need_s: MIN_MOVING_S,
            need_trips: MIN_TRIPS,
        });
    }
    if up < 30 || down < 30 {
        return Err(Error::Unidentifiable(format!(
            "travel in one direction only ({up} s up, {down} s down): the up/down asymmetry that separates friction from imbalance is missing"
        )));
    }
    if n_rest < 30 {
        return Err(Error::Unidentifiable(format!(
            "only {n_rest} standstill samples with voltage: the base voltage U0 cannot be separated from friction"
        )));
    }
    let rest_w = standstill_share * moving_w / n_rest as f64;
    let n_moving = moving.len();
    for (n, lam, u) in bins.into_values() {
        moving.push(Obs {
            s: 0,
            v: 0.0,
            lambda: lam / n,
            a: 0.0,
            q: 0.0,
            u: u / n,
            w: n * rest_w,
        });
    }
    Ok((moving, n_moving, n_rest))
}

/// The weight σ²/(σ² + (Ke·Δ²v/8)²) of row `i`: see [`observations`].
pub fn interpolation_weight(rows: &[FeatureRow], i: usize, ke: f64, sigma: f64) -> f64 {
    if ke == 0.0 || i == 0 || i + 1 >= rows.len() {
        return 1.0;
    }
    let (a, b, c) = (rows[i - 1].v, rows[i].v, rows[i + 1].v);
    let d2 = a - 2.0 * b + c;
    if !d2.is_finite() {
        return 1.0;
    }
    let e = ke * d2 / 8.0;
    sigma * sigma / (sigma * sigma + e * e)
}

/// Fits θ and the network to training observations.
///
/// `observer` sees every logged [`TrainPoint`] as it happens (progress on screen, plots).
///
/// # Errors
/// [`Error::InvalidConfig`] for bad settings, [`Error::Unidentifiable`] when the normal
/// equations are singular even with the prior.
pub fn train(
    data: &[Obs],
    elevator: &Elevator,
    cfg: &TrainConfig,
    observer: &mut dyn FnMut(&TrainPoint),
) -> Result<Trained> {
    cfg.validate()?;
    let m_r = elevator.rated_load_kg;
    let prior = Prior::for_elevator(elevator);
    let map = ParamMap::new(&prior, m_r);
    let mut history = Vec::new();
    let mut log = |p: TrainPoint, history: &mut Vec<TrainPoint>| {
        observer(&p);
        history.push(p);
    };

    // Stage 1: physics alone, Gauss-Newton with Levenberg damping, σ_U re-estimated twice.
    let mut sigma_u = 0.01 * elevator.rated_voltage();
    let mut z = [0.0; N_PHYS];
    let mut iteration = 0;
    let mut curvature = [1.0; N_PHYS];
    for _round in 0..3 {
        (z, curvature) =
            gauss_newton(data, &prior, &map, m_r, sigma_u, cfg.w_p, z, &mut iteration)?;
        let p = map.theta(&z);
        sigma_u = robust_sigma(
            data.iter()
                .filter(|o| o.s != 0)
                .map(|o| o.u - phys_u(&p, o, m_r)),
        )
        .max(1e-3);
    }
    let p1 = map.theta(&z);
    let sigma_f = robust_sigma(data.iter().filter(|o| o.s != 0).map(|o| {
        p1.force(o.s, o.v, o.lambda, o.a, o.q, m_r) - p1.force_from_voltage(o.s, o.v, o.u)
    }))
    .max(1e-3);
    let weights = LossWeights {
        w_u: cfg.w_u,
        w_f: cfg.w_f,
        w_p: cfg.w_p,
        w_n: cfg.w_n,
        sigma_u,
        sigma_f,
    };
    let net0 = ResidualNet::new(
        cfg.seed,
        [elevator.rated_speed_mps, 1.0, 1.0],
        [3.0 * sigma_u, 3.0 * sigma_f],
    );
    let thinned = thin_moving(data, cfg.stage2_max_moving);
    let obj = Objective {
        data: &thinned,
        rated_load_kg: m_r,
        prior,
        map,
        weights,
        input_scale: net0.input_scale,
        output_scale: net0.output_scale,
        motor_ref: p1,
    };
    let mut x = vec![0.0; N_UNKNOWNS];
    x[..N_PHYS].copy_from_slice(&z);
    x[N_PHYS..].copy_from_slice(&net0.weights);
    let (loss1, st1) = obj.eval(&x, None);
    log(point(1, iteration, loss1, st1, &map, &x), &mut history);

    // Stage 2.
    if cfg.optimizer == Optimizer::Adam {
        x[..N_PHYS].iter_mut().for_each(|v| *v = 0.0); // the paper starts from the prior
    }
    let every = if cfg.log_every == 0 {
        usize::MAX
    } else {
        cfg.log_every
    };
    let mut on_iter = |it: usize, loss: f64, st: LossStats, x: &[f64]| {
        if it % every == 0 || it == cfg.epochs {
            log(point(2, iteration + it, loss, st, &map, x), &mut history);
        }
    };
    // Precondition θ by its Gauss-Newton curvature (per unit of the normalised loss): the data
    // pin Kd or U0 thousands of times harder than any single network weight, and an unscaled
    // quasi-Newton method would crawl along that valley.
    let wsum: f64 = thinned.iter().map(|o| o.w).sum();
    let mut precond = vec![1.0; N_UNKNOWNS];
    for k in 0..N_PHYS {
        precond[k] = (2.0 * cfg.w_u.max(1e-3) * curvature[k] / wsum)
            .sqrt()
            .max(1e-6);
    }
    let iters = match cfg.optimizer {
        Optimizer::Lbfgs => {
            let (it, xf) = lbfgs(&obj, &mut x, &precond, cfg.epochs, &mut on_iter);
            x = xf;
            it
        }
        Optimizer::Adam => adam(&obj, &mut x, cfg.epochs, cfg.learning_rate, &mut on_iter),
    };
    let (loss_final, st) = obj.eval(&x, None);
    if history.last().map(|p| p.iteration) != Some(iteration + iters) {
        log(
            point(2, iteration + iters, loss_final, st, &map, &x),
            &mut history,
        );
    }

    let parameters = map.theta(&x[..N_PHYS]);
    let mut net = net0;
    net.weights.copy_from_slice(&x[N_PHYS..]);
    let (reports, warnings) = param_reports(data, &parameters, &net, &prior, m_r, cfg.w_p);
    // Healthy scales from the final residuals of moving samples.
    let model_u = |o: &Obs| {
        let [du, _] = net.forward(o.v, o.lambda, o.a);
        o.u - parameters.voltage(
            o.s,
            o.v,
            parameters.force(o.s, o.v, o.lambda, o.a, o.q, m_r),
        ) - du
    };
    let model_f = |o: &Obs| {
        let [_, df] = net.forward(o.v, o.lambda, o.a);
        parameters.force(o.s, o.v, o.lambda, o.a, o.q, m_r) + df
            - parameters.force_from_voltage(o.s, o.v, o.u)
    };
    let scales = ResidualScales {
        sigma_u_v: robust_sigma(data.iter().filter(|o| o.s != 0).map(model_u)).max(1e-3),
        sigma_f_n: robust_sigma(data.iter().filter(|o| o.s != 0).map(model_f)).max(1e-3),
    };
    let n_moving = data.iter().filter(|o| o.s != 0).count();
    let summary = FitSummary {
        moving_samples: n_moving,
        standstill_samples: 0,
        parameters: reports,
        history: thin(history, 400),
        rms_u_v: st.rms_u,
        rms_f_n: st.rms_f,
        loss_stage1: loss1,
        loss_final,
        iterations: iters,
        warnings,
    };
    Ok(Trained {
        parameters,
        net,
        scales,
        summary,
    })
}

/// Every k-th moving observation (k = ⌈moving/max⌉) with its weight multiplied by k, and every
/// standstill observation: the same loss in expectation at a fraction of the cost.
fn thin_moving(data: &[Obs], max: usize) -> Vec<Obs> {
    let moving = data.iter().filter(|o| o.s != 0).count();
    if max == 0 || moving <= max {
        return data.to_vec();
    }
    let k = moving.div_ceil(max);
    let mut i = 0usize;
    data.iter()
        .filter_map(|o| {
            if o.s == 0 {
                return Some(*o);
            }
            i += 1;
            ((i - 1) % k == 0).then_some(Obs {
                w: o.w * k as f64,
                ..*o
            })
        })
        .collect()
}

fn point(
    stage: u8,
    iteration: usize,
    loss: f64,
    st: LossStats,
    map: &ParamMap,
    x: &[f64],
) -> TrainPoint {
    TrainPoint {
        stage,
        iteration,
        loss,
        rms_u_v: st.rms_u,
        rms_f_n: st.rms_f,
        theta: map.theta(&x[..N_PHYS]).to_array(),
    }
}

fn thin(h: Vec<TrainPoint>, max: usize) -> Vec<TrainPoint> {
    if h.len() <= max {
        return h;
    }
    let step = h.len().div_ceil(max);
    let last = h.len() - 1;
    h.into_iter()
        .enumerate()
        .filter(|(i, _)| i % step == 0 || *i == last)
        .map(|(_, p)| p)
        .collect()
}

fn phys_u(p: &PhysParams, o: &Obs, m_r: f64) -> f64 {
    p.voltage(o.s, o.v, p.force(o.s, o.v, o.lambda, o.a, o.q, m_r))
}

/// 1.4826·MAD: a standard deviation that a few outliers do not inflate.
pub fn robust_sigma(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    let med = median(&mut v);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - med).abs()).collect();
    1.4826 * median(&mut dev)
}

fn median(v: &mut [f64]) -> f64 {
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, f64::total_cmp);
    v[mid]
}

/// ∂U_phys/∂θ for one observation.
fn du_dtheta(p: &PhysParams, o: &Obs, m_r: f64) -> [f64; N_PHYS] {
    let s = f64::from(o.s);
    let k = p.phi(o.s) * p.kd * s;
    let f = p.force(o.s, o.v, o.lambda, o.a, o.q, m_r);
    let g = crate::elevator::G;
    [
        k * g,
        k * o.a,
        k * s,
        k * o.v,
        p.phi(o.s) * s * f,
        o.v.abs(),
        1.0,
        if o.s == -1 { p.kd * s * f } else { 0.0 },
        k * g * o.q,
    ]
}

/// Levenberg-Marquardt on the voltage equation with the prior as pseudo-observations, in z.
#[allow(clippy::too_many_arguments)]
fn gauss_newton(
    data: &[Obs],
    prior: &Prior,
    map: &ParamMap,
    m_r: f64,
    sigma_u: f64,
    w_p: f64,
    mut z: [f64; N_PHYS],
    iteration: &mut usize,
) -> Result<([f64; N_PHYS], [f64; N_PHYS])> {
    let cost = |z: &[f64; N_PHYS]| {
        let p = map.theta(z);
        let d: f64 = data
            .iter()
            .map(|o| o.w * ((o.u - phys_u(&p, o, m_r)) / sigma_u).powi(2))
            .sum();
        d + w_p * prior.penalty(&p)
    };
    let mut mu = 1e-3;
    let mut c = cost(&z);
    let mut curvature = [1.0; N_PHYS];
    for _ in 0..100 {
        *iteration += 1;
        let p = map.theta(&z);
        let dz = map.dtheta_dz(&z);
        let mut h = SquareMatrix::zeros(N_PHYS);
        let mut g = [0.0; N_PHYS];
        for o in data {
            let r = (o.u - phys_u(&p, o, m_r)) / sigma_u;
            let mut j = du_dtheta(&p, o, m_r);
            for k in 0..N_PHYS {
                j[k] *= dz[k] / sigma_u;
                g[k] += o.w * r * j[k];
            }
            h.add_outer(&j, o.w);
        }
        let (t, m) = (p.to_array(), prior.centre.to_array());
        for k in 0..N_PHYS {
            let jk = dz[k] / prior.sd[k];
            *h.at(k, k) += w_p * jk * jk;
            g[k] -= w_p * (t[k] - m[k]) / prior.sd[k] * jk;
        }
        for (k, c) in curvature.iter_mut().enumerate() {
            *c = h.get(k, k);
        }
        let mut improved = false;
        for _ in 0..30 {
            let mut hd = h.clone();
            for k in 0..N_PHYS {
                *hd.at(k, k) += mu * h.get(k, k).max(1e-12);
            }
            let Some(l) = hd.cholesky() else {
                mu *= 10.0;
                continue;
            };
            let step = l.cholesky_solve(&g);
            let mut zn = z;
            for k in 0..N_PHYS {
                zn[k] += step[k];
            }
            let cn = cost(&zn);
            if cn.is_finite() && cn <= c {
                let rel = (c - cn) / c.max(1e-300);
                z = zn;
                c = cn;
                mu = (mu * 0.3).max(1e-9);
                improved = true;
                if rel < 1e-12 {
                    return Ok((z, curvature));
                }
                break;
            }
            mu *= 10.0;
        }
        if !improved {
            break;
        }
    }
    if !c.is_finite() {
        return Err(Error::Unidentifiable("the physical fit diverged".into()));
    }
    Ok((z, curvature))
}

/// Called after every stage-2 iteration with (iteration, loss, statistics, unknowns).
type IterObserver<'a> = &'a mut dyn FnMut(usize, f64, LossStats, &[f64]);

/// L-BFGS with a backtracking Armijo line search; returns the iterations run.
///
/// It works in y = p·x (`pre` = p, a diagonal preconditioner), so the curvature it meets is near one.
fn lbfgs(
    obj: &Objective<'_>,
    x: &mut [f64],
    pre: &[f64],
    max_iter: usize,
    on_iter: IterObserver<'_>,
) -> (usize, Vec<f64>) {
    const M: usize = 10;
    let n = x.len();
    // f(y) = L(y/d); ∇_y f = ∇_x L / d.
    let eval = |y: &[f64], xs: &mut [f64], g: &mut [f64]| {
        for i in 0..n {
            xs[i] = y[i] / pre[i];
        }
        let r = obj.eval(xs, Some(g));
        for i in 0..n {
            g[i] /= pre[i];
        }
        r
    };
    let mut xs = x.to_vec();
    let mut y_cur: Vec<f64> = (0..n).map(|i| x[i] * pre[i]).collect();
    let x = &mut y_cur;
    let mut g = vec![0.0; n];
    let (mut f, _) = eval(x, &mut xs, &mut g);
    let mut s_hist: Vec<Vec<f64>> = Vec::new();
    let mut y_hist: Vec<Vec<f64>> = Vec::new();
    let mut rho: Vec<f64> = Vec::new();
    let mut gn = vec![0.0; n];
    let mut xn = vec![0.0; n];
    const PLATEAU: usize = 50;
    const PLATEAU_GAIN: f64 = 1e-4;
    let mut recent: Vec<f64> = Vec::with_capacity(PLATEAU + 1);
    for it in 1..=max_iter {
        // Two-loop recursion: d = −H·g.
        let mut d: Vec<f64> = g.iter().map(|v| -v).collect();
        let k = s_hist.len();
        let mut alpha = vec![0.0; k];
        for i in (0..k).rev() {
            alpha[i] = rho[i] * dot(&s_hist[i], &d);
            axpy(-alpha[i], &y_hist[i], &mut d);
        }
        let gamma = if k > 0 {
            dot(&s_hist[k - 1], &y_hist[k - 1]) / dot(&y_hist[k - 1], &y_hist[k - 1])
        } else {
            1.0 / norm(&g).max(1e-12)
        };
        d.iter_mut().for_each(|v| *v *= gamma);
        for i in 0..k {
            let beta = rho[i] * dot(&y_hist[i], &d);
            axpy(alpha[i] - beta, &s_hist[i], &mut d);
        }
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction: restart from steepest descent.
            s_hist.clear();
            y_hist.clear();
            rho.clear();
            d = g.iter().map(|v| -v / norm(&g).max(1e-12)).collect();
            slope = dot(&g, &d);
        }
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..40 {
            for i in 0..n {
                xn[i] = x[i] + step * d[i];
            }
            let (fnew, st) = eval(&xn, &mut xs, &mut gn);
            if fnew.is_finite() && fnew <= f + 1e-4 * step * slope {
                accepted = Some((fnew, st));
                break;
            }
            step *= 0.5;
        }
        let Some((fnew, st)) = accepted else {
            finish(x, &mut xs, pre);
            return (it - 1, xs);
        };
        let s: Vec<f64> = (0..n).map(|i| xn[i] - x[i]).collect();
        let y: Vec<f64> = (0..n).map(|i| gn[i] - g[i]).collect();
        let sy = dot(&s, &y);
        if sy > 1e-12 * norm(&s) * norm(&y) {
            if s_hist.len() == M {
                s_hist.remove(0);
                y_hist.remove(0);
                rho.remove(0);
            }
            s_hist.push(s);
            y_hist.push(y);
            rho.push(1.0 / sy);
        }
        x.copy_from_slice(&xn);
        g.copy_from_slice(&gn);
        f = fnew;
        finish(x, &mut xs, pre);
        on_iter(it, f, st, &xs);
        // Converged when 50 iterations gained less than 10⁻⁴ of the loss: past that the
        // network only polishes noise.
        recent.push(f);
        if recent.len() > PLATEAU {
            let old = recent.remove(0);
            if (old - f) < PLATEAU_GAIN * f.abs() {
                return (it, xs);
            }
        }
        if norm(&g) < 1e-9 {
            return (it, xs);
        }
    }
    (max_iter, xs)
}

fn finish(y: &[f64], xs: &mut [f64], d: &[f64]) {
    for i in 0..y.len() {
        xs[i] = y[i] / d[i];
    }
}

/// Adam (Kingma & Ba), full batch, as the paper trains; returns the epochs run.
fn adam(
    obj: &Objective<'_>,
    x: &mut [f64],
    epochs: usize,
    lr: f64,
    on_iter: IterObserver<'_>,
) -> usize {
    let (b1, b2, eps): (f64, f64, f64) = (0.9, 0.999, 1e-8);
    let n = x.len();
    let (mut m, mut v, mut g) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for t in 1..=epochs {
        let (f, st) = obj.eval(x, Some(&mut g));
        let (c1, c2) = (1.0 - b1.powi(t as i32), 1.0 - b2.powi(t as i32));
        for i in 0..n {
            m[i] = b1 * m[i] + (1.0 - b1) * g[i];
            v[i] = b2 * v[i] + (1.0 - b2) * g[i] * g[i];
            x[i] -= lr * (m[i] / c1) / ((v[i] / c2).sqrt() + eps);
        }
        on_iter(t, f, st, x);
    }
    epochs
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// Standard errors from the Gauss-Newton covariance of the voltage equation at the final θ
/// with the network held fixed, and which parameters the data determined.
fn param_reports(
    data: &[Obs],
    p: &PhysParams,
    net: &ResidualNet,
    prior: &Prior,
    m_r: f64,
    w_p: f64,
) -> (Vec<ParamReport>, Vec<String>) {
    let sigma = robust_sigma(
        data.iter()
            .filter(|o| o.s != 0)
            .map(|o| o.u - phys_u(p, o, m_r) - net.forward(o.v, o.lambda, o.a)[0]),
    )
    .max(1e-6);
    let mut h = SquareMatrix::zeros(N_PHYS);
    for o in data {
        let j = du_dtheta(p, o, m_r).map(|v| v / sigma);
        h.add_outer(&j, o.w);
    }
    for k in 0..N_PHYS {
        *h.at(k, k) += w_p / (prior.sd[k] * prior.sd[k]);
    }
    let mut warnings = Vec::new();
    let Some(l) = h.cholesky() else {
        warnings
            .push("the parameter covariance is singular: standard errors are not available".into());
        let reps = PhysParams::NAMES
            .iter()
            .zip(p.to_array())
            .enumerate()
            .map(|(k, (n, v))| ParamReport {
                name: (*n).into(),
                unit: PhysParams::UNITS[k].into(),
                value: v,
                std_error: None,
                prior_sd: Some(prior.sd[k]),
                determined: false,
            })
            .collect();
        return (reps, warnings);
    };
    let cov = l.cholesky_inverse();
    let t = p.to_array();
    let mut reps: Vec<ParamReport> = (0..N_PHYS)
        .map(|k| {
            let se = cov.get(k, k).max(0.0).sqrt();
            let determined = se < prior.sd[k] / 3.0;
            if !determined {
                warnings.push(format!(
                    "{} is set mostly by its prior (standard error {:.3} {} against prior width {:.3})",
                    PhysParams::NAMES[k],
                    se,
                    PhysParams::UNITS[k],
                    prior.sd[k]
                ));
            }
            ParamReport {
                name: PhysParams::NAMES[k].into(),
                unit: PhysParams::UNITS[k].into(),
                value: t[k],
                std_error: Some(se),
                prior_sd: Some(prior.sd[k]),
                determined,
            }
        })
        .collect();
    // Identifiable combinations: the |v| slope of the voltage up and down.
    let combo = |name: &str, grad: [f64; N_PHYS], value: f64| {
        let mut var = 0.0;
        for i in 0..N_PHYS {
            for j in 0..N_PHYS {
                var += grad[i] * cov.get(i, j) * grad[j];
            }
        }
        let se = var.max(0.0).sqrt();
        ParamReport {
            name: name.into(),
            unit: "V s/m".into(),
            value,
            std_error: Some(se),
            prior_sd: None,
            determined: se < 0.05 * value.abs(),
        }
    };
    reps.push(combo(
        "ke + kd*c_visc",
        [0.0, 0.0, 0.0, p.kd, p.c_visc, 1.0, 0.0, 0.0, 0.0],
        p.ke + p.kd * p.c_visc,
    ));
    reps.push(combo(
        "ke + alpha_down*kd*c_visc",
        [
            0.0,
            0.0,
            0.0,
            p.alpha_down * p.kd,
            p.alpha_down * p.c_visc,
            1.0,
            0.0,
            p.kd * p.c_visc,
            0.0,
        ],
        p.ke + p.alpha_down * p.kd * p.c_visc,
    ));
    // Sensor timing: a relative latency Δτ between the speed and voltage channels adds
    // −Ke·Δτ·s·a to the voltage, the very shape of the inertia term Kd·M0·s·a.
    warnings.push(format!(
        "m0 is an apparent inertia: each 10 ms of latency of the voltage channel behind the speed channel lowers it by {:.0} kg",
        p.ke * 0.01 / p.kd
    ));
    (reps, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Data generated exactly by MODEL.md's equations plus Gaussian voltage noise: trips of
    /// trapezoidal speed, mostly light loads, standstill between trips.
    pub(crate) fn paper_exact(
        truth: &PhysParams,
        e: &Elevator,
        noise_v: f64,
        trips: usize,
        seed: u64,
    ) -> Vec<FeatureRow> {
        let floors = e.floors;
        let mut rng = Rng::new(seed);
        let mut rows = Vec::new();
        let mut t = 0.0;
        let v_r = e.rated_speed_mps;
        for trip in 0..trips {
            let s: i8 = if trip % 2 == 0 { 1 } else { -1 };
            let lambda = (rng.exponential(0.12)).min(1.0);
            let floor = 1.0 + rng.below(u64::from(floors)) as f64;
            let q = PhysParams::relative_height(floor, floors);
            let cruise = rng.below(12) as usize;
            let ramp = (v_r / 0.45).ceil() as usize;
            let mut speeds: Vec<f64> = (1..=ramp).map(|k| v_r * k as f64 / ramp as f64).collect();
            speeds.extend(std::iter::repeat(v_r).take(cruise));
            speeds.extend((0..ramp).rev().map(|k| v_r * k as f64 / ramp as f64));
            let mut prev = 0.0;
            for sp in speeds {
                let v = f64::from(s) * sp;
                let a = v - prev;
                prev = v;
                let st = if sp > 0.05 { s } else { 0 };
                let f = truth.force(st, v, lambda, a, q, e.rated_load_kg);
                let u = truth.voltage(st, v, f) + noise_v * rng.normal();
                rows.push(FeatureRow {
                    time: t,
                    v,
                    s: st,
                    lambda,
                    a_v: a,
                    a_l: f64::NAN,
                    a,
                    voltage: u,
                    floor,
                    phase: crate::features::Phase::Cruising,
                    trip: Some(trip as u32),
                });
                t += 1.0;
            }
            for _ in 0..20 {
                let u = truth.u0 + noise_v * rng.normal();
                rows.push(FeatureRow {
                    time: t,
                    v: 0.0,
                    s: 0,
                    lambda,
                    a_v: 0.0,
                    a_l: f64::NAN,
                    a: 0.0,
                    voltage: u,
                    floor,
                    phase: crate::features::Phase::Standstill,
                    trip: None,
                });
                t += 1.0;
            }
        }
        rows
    }

    fn truth() -> PhysParams {
        PhysParams {
            delta_m: -430.0,
            m0: 3300.0,
            f_c: 260.0,
            c_visc: 110.0,
            kd: 0.0052,
            ke: 175.0,
            u0: 8.0,
            alpha_down: 0.82,
            m_rope: -180.0,
        }
    }

    #[test]
    fn paper_exact_data_give_the_identifiable_parameters_back_within_2_percent() {
        // Six hours of paper-like traffic (the paper's 3 h hold 80 trips) with 2 V voltage noise.
        let e = Elevator::new(1000.0, 1.75, 26);
        let t = truth();
        let rows = paper_exact(&t, &e, 2.0, 480, 5);
        let (obs, _, _) = observations(&rows, e.floors, 0.1).unwrap();
        let cfg = TrainConfig {
            epochs: 200,
            log_every: 0,
            ..TrainConfig::default()
        };
        let fit = train(&obs, &e, &cfg, &mut |_| {}).unwrap();
        let p = fit.parameters;
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
        for (name, got, want) in [
            ("u0", p.u0, t.u0),
            ("kd", p.kd, t.kd),
            ("alpha_down", p.alpha_down, t.alpha_down),
            ("m0", p.m0, t.m0),
            ("delta_m", p.delta_m, t.delta_m),
            (
                "ke + kd c (up)",
                p.ke + p.kd * p.c_visc,
                t.ke + t.kd * t.c_visc,
            ),
            (
                "ke + α kd c (down)",
                p.ke + p.alpha_down * p.kd * p.c_visc,
                t.ke + t.alpha_down * t.kd * t.c_visc,
            ),
            ("m_rope", p.m_rope, t.m_rope),
        ] {
            assert!(
                rel(got, want) < 0.02,
                "{name}: got {got}, want {want} ({:.2} %)",
                100.0 * rel(got, want)
            );
        }
        // F_c is a small difference of two large constants (Δm·g ± F_c): it is tested against
        // its own standard error, which the fit must report honestly.
        let se = |name: &str| {
            fit.summary
                .parameters
                .iter()
                .find(|r| r.name == name)
                .and_then(|r| r.std_error)
                .unwrap()
        };
        assert!(
            (p.f_c - t.f_c).abs() < 3.0 * se("f_c"),
            "f_c {} ± {} vs {}",
            p.f_c,
            se("f_c"),
            t.f_c
        );
        // c separates from Ke only through α_down ≠ 1: the fit must say it could not determine it.
        assert!(
            fit.summary.warnings.iter().any(|w| w.starts_with("c_visc")),
            "{:?}",
            fit.summary.warnings
        );
        assert!(
            (fit.summary.rms_u_v - 2.0).abs() < 0.2,
            "rms {}",
            fit.summary.rms_u_v
        );
    }

    #[test]
    fn the_network_corrects_what_the_physics_cannot_represent() {
        // A drive effect the physics lacks: a 5 V bump in voltage around 0.9 m/s (a modulation
        // change of the inverter, say). The hybrid model must explain it without moving Kd.
        let e = Elevator::new(1000.0, 1.75, 26);
        let t = truth();
        let mut rows = paper_exact(&t, &e, 1.0, 240, 9);
        for r in rows.iter_mut().filter(|r| r.s != 0) {
            r.voltage += 5.0 * (-((r.v.abs() - 0.9) / 0.3).powi(2)).exp();
        }
        let (obs, _, _) = observations(&rows, e.floors, 0.1).unwrap();
        let physics_only = TrainConfig {
            epochs: 0,
            log_every: 0,
            ..TrainConfig::default()
        };
        let hybrid = TrainConfig {
            epochs: 400,
            log_every: 0,
            ..TrainConfig::default()
        };
        let p_fit = train(&obs, &e, &physics_only, &mut |_| {}).unwrap();
        let h_fit = train(&obs, &e, &hybrid, &mut |_| {}).unwrap();
        assert!(
            h_fit.summary.rms_u_v < 0.75 * p_fit.summary.rms_u_v,
            "{} vs {}",
            h_fit.summary.rms_u_v,
            p_fit.summary.rms_u_v
        );
        assert!(
            (h_fit.parameters.kd - t.kd).abs() / t.kd < 0.05,
            "kd {}",
            h_fit.parameters.kd
        );
    }

    #[test]
    fn too_little_motion_is_refused() {
        let e = Elevator::new(1000.0, 1.75, 26);
        let rows = paper_exact(&truth(), &e, 2.0, 3, 5);
        assert!(matches!(
            observations(&rows, e.floors, 0.1),
            Err(Error::TooLittleMotion { .. })
        ));
    }

    #[test]
    fn one_direction_only_is_refused() {
        let e = Elevator::new(1000.0, 1.75, 26);
        let rows: Vec<FeatureRow> = paper_exact(&truth(), &e, 2.0, 60, 5)
            .into_iter()
            .filter(|r| r.s >= 0)
            .collect();
        assert!(matches!(
            observations(&rows, e.floors, 0.1),
            Err(Error::Unidentifiable(_))
        ));
    }
}
