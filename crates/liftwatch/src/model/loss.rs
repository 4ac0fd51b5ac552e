//! The training objective of the hybrid model and its analytic gradient (MODEL.md, Sec. 3.2-3.3).
//!
//! ```text
//! r_U = U − (U_phys(θ) + δU)                          electrical residual (V)
//! r_F = (F_phys(θ) + δF) − F_U(θ)                     mechanical residual (N)
//! L   = [ Σ w_i·( w_U·(r_U/σ_U)² + w_F·(r_F/σ_F)² + w_N·((δU/σ_U)² + (δF/σ_F)²) )
//!         + w_P·Σ_k ((θ_k − μ_k)/τ_k)² ] / Σ w_i
//! ```
//!
//! Deviations from the paper, each for a reason shown by the round-trip tests:
//! - residuals are divided by fixed noise scales σ_U, σ_F, so that volts and newtons weigh the
//!   same and the weights w_U, w_F mean what they say;
//! - the network's outputs are penalised (w_N): the network can represent any function of
//!   (v, λ, a), physics included, so without a price on δ it absorbs the physics and the
//!   parameters stop meaning what their names say;
//! - F_U in r_F is evaluated with the motor parameters (U0, Ke, Kd, α_down) identified from the
//!   electrical equation alone and held fixed (`motor_ref`). Letting them move inside F_U =
//!   (U − U0 − Ke·|v|)/(φ·Kd·s) rewards a larger Kd simply because it shrinks the voltage noise
//!   mapped into newtons: on paper-exact data that bias alone moved Kd by +14 %, M0 by −13 %;
//! - the prior is a Gaussian MAP term on θ with documented centres and widths, scaled like one
//!   more observation per parameter, so it decides only what the data cannot.
//!
//! Positive parameters (M0, F_c, c, Kd, Ke, U0, α_down) are optimised as z with
//! θ = μ·softplus(z)/ln 2 (z = 0 is the prior centre); Δm and m_rope, which may have either
//! sign, as θ = μ + 0.1·M_r·z.

use crate::elevator::Elevator;
use crate::model::net::{backward_lanes, forward_lanes, NetCache, LANES, N_WEIGHTS};
use crate::model::physics::{PhysParams, EPS_MAX, N_PHYS};

/// Number of optimised unknowns: θ (as z) then the network weights.
pub const N_UNKNOWNS: usize = N_PHYS + N_WEIGHTS;

/// One observation of the training set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obs {
    /// s: direction of motion, 0 at rest.
    pub s: i8,
    /// v: signed velocity (m/s).
    pub v: f64,
    /// λ: static load ratio.
    pub lambda: f64,
    /// a: fused acceleration (m/s²).
    pub a: f64,
    /// q: relative height of the car (−½ bottom … +½ top).
    pub q: f64,
    /// U: measured voltage (V); a mean when the observation aggregates several samples.
    pub u: f64,
    /// Weight w_i (a count of samples times the motion weight).
    pub w: f64,
}

impl Obs {
    /// U_phys(x; θ): the voltage the physics alone predicts for this observation (V).
    pub fn u_phys(&self, p: &PhysParams, rated_load_kg: f64) -> f64 {
        p.voltage(
            self.s,
            self.v,
            p.force(self.s, self.v, self.lambda, self.a, self.q, rated_load_kg),
        )
    }
}

/// Gaussian prior on θ: centres μ and widths τ, derived from the elevator description.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    /// Centres μ.
    pub centre: PhysParams,
    /// Standard deviations τ, in the order of [`PhysParams::NAMES`].
    pub sd: [f64; N_PHYS],
}

impl Prior {
    /// The prior of an elevator known by its description: wide (50-100 % of the centre for the
    /// drive and friction terms) so that data decide wherever they can.
    pub fn for_elevator(e: &Elevator) -> Self {
        let c = PhysParams::prior_centre(e);
        let m_r = e.rated_load_kg;
        Prior {
            centre: c,
            sd: [
                0.25 * m_r,
                0.5 * c.m0,
                1.0 * c.f_c,
                1.0 * c.c_visc,
                1.0 * c.kd,
                0.5 * c.ke,
                1.0 * c.u0.max(5.0),
                0.3,
                0.5 * m_r,
                EPS_PRIOR_SD,
            ],
        }
    }

    /// Σ ((θ_k − μ_k)/τ_k)².
    pub fn penalty(&self, p: &PhysParams) -> f64 {
        let (t, m) = (p.to_array(), self.centre.to_array());
        (0..N_PHYS)
            .map(|k| ((t[k] - m[k]) / self.sd[k]).powi(2))
            .sum()
    }
}

/// τ of the loss asymmetry ε around its centre 0 (a lossless drive): wide enough for a worm
/// gear's η of 0.6 (ε = 0.47) to be 1.6 τ away, so that the data decide.
const EPS_PRIOR_SD: f64 = 0.3;

/// The smooth map z → θ that keeps the positive parameters positive, the signed ones linear
/// in z (Δm and m_rope in units of a tenth of the rated load) and ε inside ±[`EPS_MAX`]:
/// ε = EPS_MAX·tanh(z/EPS_Z), a tenth of z near 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamMap {
    centre: [f64; N_PHYS],
    delta_m_scale: f64,
}

const LN2: f64 = std::f64::consts::LN_2;

/// z per unit of ε/EPS_MAX's atanh: dε/dz = EPS_MAX/EPS_Z = 0.1 at ε = 0, a step of z
/// of the size the other parameters take moves ε by a tenth.
const EPS_Z: f64 = 8.0;

/// The share of ±EPS_MAX beyond which z(ε) is taken at the edge (atanh(1) is infinite).
const EPS_EDGE: f64 = 1.0 - 1e-12;

fn softplus(z: f64) -> f64 {
    if z > 30.0 {
        z
    } else {
        z.exp().ln_1p()
    }
}

fn sigmoid(z: f64) -> f64 {
    1.0 / (1.0 + (-z).exp())
}

impl ParamMap {
    /// The map centred on the prior: z = 0 gives the prior centre.
    pub fn new(prior: &Prior, rated_load_kg: f64) -> Self {
        ParamMap {
            centre: prior.centre.to_array(),
            delta_m_scale: 0.1 * rated_load_kg,
        }
    }

    /// θ(z).
    pub fn theta(&self, z: &[f64]) -> PhysParams {
        let mut t = [0.0; N_PHYS];
        for k in 0..N_PHYS {
            t[k] = if k == PhysParams::EPS {
                self.centre[k] + EPS_MAX * (z[k] / EPS_Z).tanh()
            } else if PhysParams::SIGNED[k] {
                self.centre[k] + self.delta_m_scale * z[k]
            } else {
                self.centre[k] * softplus(z[k]) / LN2
            };
        }
        PhysParams::from_array(t)
    }

    /// dθ_k/dz_k.
    pub fn dtheta_dz(&self, z: &[f64]) -> [f64; N_PHYS] {
        let mut d = [0.0; N_PHYS];
        for k in 0..N_PHYS {
            d[k] = if k == PhysParams::EPS {
                let th = (z[k] / EPS_Z).tanh();
                EPS_MAX / EPS_Z * (1.0 - th * th)
            } else if PhysParams::SIGNED[k] {
                self.delta_m_scale
            } else {
                self.centre[k] * sigmoid(z[k]) / LN2
            };
        }
        d
    }

    /// z(θ); positive parameters are floored at 10⁻⁶ of their centre.
    pub fn z(&self, p: &PhysParams) -> [f64; N_PHYS] {
        let t = p.to_array();
        let mut z = [0.0; N_PHYS];
        for k in 0..N_PHYS {
            if k == PhysParams::EPS {
                // Inside the open interval, so that atanh stays finite.
                let y = ((t[k] - self.centre[k]) / EPS_MAX).clamp(-EPS_EDGE, EPS_EDGE);
                z[k] = EPS_Z * y.atanh();
                continue;
            }
            if PhysParams::SIGNED[k] {
                z[k] = (t[k] - self.centre[k]) / self.delta_m_scale;
                continue;
            }
            let y = (t[k] / self.centre[k] * LN2).max(1e-6 * LN2);
            // inverse softplus: ln(e^y − 1)
            z[k] = if y > 30.0 { y } else { y.exp_m1().ln() };
        }
        z
    }
}

/// Weights and scales of the objective.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LossWeights {
    /// w_U: weight of the electrical residual.
    pub w_u: f64,
    /// w_F: weight of the mechanical residual.
    pub w_f: f64,
    /// w_P: weight of the prior.
    pub w_p: f64,
    /// w_N: price of the network's corrections.
    pub w_n: f64,
    /// σ_U: voltage noise scale (V).
    pub sigma_u: f64,
    /// σ_F: force noise scale (N).
    pub sigma_f: f64,
}

/// Derivatives of the physical model for one observation with respect to θ.
struct PhysEval {
    value: HeldPhysics,
    du: [f64; N_PHYS],
    df: [f64; N_PHYS],
}

/// F, U_phys and F_U of one observation at a fixed θ.
#[derive(Clone, Copy, Debug)]
pub struct HeldPhysics {
    f: f64,
    u: f64,
    f_u: f64,
}

/// F, U_phys, F_U and their θ-derivatives for one observation.
fn phys_eval(p: &PhysParams, motor_ref: &PhysParams, o: &Obs, m_r: f64) -> PhysEval {
    let s = f64::from(o.s);
    let f = p.force(o.s, o.v, o.lambda, o.a, o.q, m_r);
    let u = p.voltage(o.s, o.v, f);
    // dF/dθ: Δm, m0, f_c, c and m_rope
    let g = crate::elevator::G;
    let df = [g, o.a, s, o.v, 0.0, 0.0, 0.0, 0.0, g * o.q, 0.0];
    let du = p.du_dtheta_at(o.s, o.v, o.a, o.q, f);
    // F_U through the reference motor model: no gradient flows into θ from here.
    let f_u = motor_ref.force_from_voltage(o.s, o.v, o.u, f);
    PhysEval {
        value: HeldPhysics { f, u, f_u },
        du,
        df,
    }
}

/// The objective over one training set.
pub struct Objective<'a> {
    /// Observations (moving samples and aggregated standstill samples).
    pub data: &'a [Obs],
    /// Rated load M_r (kg).
    pub rated_load_kg: f64,
    /// The prior on θ.
    pub prior: Prior,
    /// The map z → θ.
    pub map: ParamMap,
    /// Weights and scales.
    pub weights: LossWeights,
    /// Network input divisors (v, λ, a).
    pub input_scale: [f64; 3],
    /// Network output multipliers (δU, δF).
    pub output_scale: [f64; 2],
    /// Motor parameters with which F_U is evaluated, held fixed during the optimisation.
    pub motor_ref: PhysParams,
}

/// Per-evaluation statistics beside the loss.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LossStats {
    /// Weighted RMS of r_U over moving samples (V).
    pub rms_u: f64,
    /// Weighted RMS of r_F over moving samples (N).
    pub rms_f: f64,
}

impl Objective<'_> {
    /// Loss at `x` = (z, network weights); writes the gradient into `grad` when given.
    ///
    /// Runs in the processor's widest vectors ([`crate::wide`]), with the same bits.
    pub fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> (f64, LossStats) {
        crate::wide::wide(
            #[inline(always)]
            || self.eval_here(x, grad, None),
        )
    }

    /// The loss and gradient at `x`; with `held`, θ is the one `held` was computed at: each
    /// observation's physics is read from it instead of evaluated, and θ's gradient is 0.
    #[inline(always)]
    fn eval_here(
        &self,
        x: &[f64],
        mut grad: Option<&mut [f64]>,
        held: Option<&[HeldPhysics]>,
    ) -> (f64, LossStats) {
        let (z, w) = x.split_at(N_PHYS);
        let p = self.map.theta(z);
        let lw = &self.weights;
        let (iu2, if2) = (
            1.0 / (lw.sigma_u * lw.sigma_u),
            1.0 / (lw.sigma_f * lw.sigma_f),
        );
        let mut gtheta = [0.0; N_PHYS];
        if let Some(g) = grad.as_deref_mut() {
            g.iter_mut().for_each(|v| *v = 0.0);
        }
        let (mut sum, mut wsum) = (0.0, 0.0);
        let (mut su, mut sf, mut wm) = (0.0, 0.0, 0.0);
        let mut cache = NetCache::<LANES>::default();
        for (c, chunk) in self.data.chunks(LANES).enumerate() {
            let xin: [[f64; 3]; LANES] = std::array::from_fn(|l| {
                chunk.get(l).map_or([0.0; 3], |o| {
                    [
                        o.v / self.input_scale[0],
                        o.lambda / self.input_scale[1],
                        o.a / self.input_scale[2],
                    ]
                })
            });
            let y = forward_lanes(w, &xin, &mut cache);
            let mut dy = [[0.0; LANES]; 2];
            for (l, o) in chunk.iter().enumerate() {
                let (pe, derivatives) = match held {
                    Some(h) => (h[c * LANES + l], None),
                    None => {
                        let pe = phys_eval(&p, &self.motor_ref, o, self.rated_load_kg);
                        (pe.value, Some(pe))
                    }
                };
                let (du, df) = (
                    y[0][l] * self.output_scale[0],
                    y[1][l] * self.output_scale[1],
                );
                let r_u = o.u - pe.u - du;
                let mut li = lw.w_u * r_u * r_u * iu2 + lw.w_n * (du * du * iu2 + df * df * if2);
                let g_du = -2.0 * lw.w_u * r_u * iu2 + 2.0 * lw.w_n * du * iu2;
                let mut g_df = 2.0 * lw.w_n * df * if2;
                let r_f = pe.f + df - pe.f_u;
                if o.s != 0 {
                    li += lw.w_f * r_f * r_f * if2;
                    g_df += 2.0 * lw.w_f * r_f * if2;
                    su += o.w * r_u * r_u;
                    sf += o.w * r_f * r_f;
                    wm += o.w;
                }
                if let Some(d) = derivatives {
                    let mut g_th = d.du.map(|d| -2.0 * lw.w_u * r_u * iu2 * d);
                    if o.s != 0 {
                        for (g, d) in g_th.iter_mut().zip(d.df) {
                            *g += 2.0 * lw.w_f * r_f * if2 * d;
                        }
                    }
                    for k in 0..N_PHYS {
                        gtheta[k] += o.w * g_th[k];
                    }
                }
                sum += o.w * li;
                wsum += o.w;
                dy[0][l] = o.w * g_du * self.output_scale[0];
                dy[1][l] = o.w * g_df * self.output_scale[1];
            }
            if let Some(g) = grad.as_deref_mut() {
                backward_lanes(w, &cache, &dy, chunk.len(), &mut g[N_PHYS..]);
            }
        }
        // Prior.
        let (t, m) = (p.to_array(), self.prior.centre.to_array());
        for k in 0..N_PHYS {
            let d = (t[k] - m[k]) / self.prior.sd[k];
            sum += lw.w_p * d * d;
            gtheta[k] += 2.0 * lw.w_p * d / self.prior.sd[k];
        }
        let norm = 1.0 / wsum.max(f64::MIN_POSITIVE);
        if let Some(g) = grad {
            let dz = self.map.dtheta_dz(z);
            for k in 0..N_PHYS {
                g[k] = if held.is_some() {
                    0.0
                } else {
                    gtheta[k] * dz[k] * norm
                };
            }
            for v in &mut g[N_PHYS..] {
                *v *= norm;
            }
        }
        let stats = if wm > 0.0 {
            LossStats {
                rms_u: (su / wm).sqrt(),
                rms_f: (sf / wm).sqrt(),
            }
        } else {
            LossStats::default()
        };
        (sum * norm, stats)
    }
}

/// [`Objective`] with θ held where it is: each observation's physics computed once, so that
/// an evaluation costs the network's passes alone (stage 2, where only the network moves).
/// The same loss and network gradient as [`Objective::eval`], bit for bit; θ's gradient reads
/// 0, so a quasi-Newton solver never moves it.
pub struct HeldTheta<'a> {
    objective: &'a Objective<'a>,
    z: [f64; N_PHYS],
    physics: Vec<HeldPhysics>,
}

impl<'a> HeldTheta<'a> {
    /// `objective` with θ held at `z`.
    pub fn new(objective: &'a Objective<'a>, z: &[f64; N_PHYS]) -> Self {
        let p = objective.map.theta(z);
        let physics = objective
            .data
            .iter()
            .map(|o| phys_eval(&p, &objective.motor_ref, o, objective.rated_load_kg).value)
            .collect();
        HeldTheta {
            objective,
            z: *z,
            physics,
        }
    }

    /// Loss at `x` = (z, network weights), whose z must be the held one; writes the gradient
    /// (0 for z) into `grad` when given.
    ///
    /// # Panics
    /// When `x` holds another z.
    pub fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> (f64, LossStats) {
        assert!(x[..N_PHYS] == self.z, "HeldTheta evaluated at another θ");
        crate::wide::wide(
            #[inline(always)]
            || self.objective.eval_here(x, grad, Some(&self.physics)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn objective(data: &[Obs]) -> Objective<'_> {
        let e = Elevator::new(1000.0, 1.75, 26);
        let prior = Prior::for_elevator(&e);
        Objective {
            data,
            rated_load_kg: 1000.0,
            prior,
            map: ParamMap::new(&prior, 1000.0),
            weights: LossWeights {
                w_u: 1.0,
                w_f: 0.7,
                w_p: 1.0,
                w_n: 0.3,
                sigma_u: 2.0,
                sigma_f: 300.0,
            },
            input_scale: [1.75, 1.0, 1.0],
            output_scale: [5.0, 400.0],
            motor_ref: PhysParams::prior_centre(&e),
        }
    }

    fn random_data(rng: &mut Rng, n: usize) -> Vec<Obs> {
        (0..n)
            .map(|i| {
                let s = [1i8, -1, 0][i % 3];
                let v = f64::from(s) * rng.uniform(0.1, 1.75);
                Obs {
                    s,
                    v,
                    lambda: rng.uniform(0.0, 0.8),
                    a: rng.uniform(-1.0, 1.0),
                    q: rng.uniform(-0.5, 0.5),
                    u: rng.uniform(0.0, 400.0),
                    w: rng.uniform(0.2, 1.0),
                }
            })
            .collect()
    }

    #[test]
    fn gradient_matches_central_differences() {
        let mut rng = Rng::new(11);
        let data = random_data(&mut rng, 30);
        let obj = objective(&data);
        let x: Vec<f64> = (0..N_UNKNOWNS).map(|_| rng.uniform(-0.5, 0.5)).collect();
        let mut g = vec![0.0; N_UNKNOWNS];
        obj.eval(&x, Some(&mut g));
        for i in (0..N_UNKNOWNS).step_by(7).chain(0..N_PHYS) {
            let h = 1e-5;
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[i] += h;
            xm[i] -= h;
            let num = (obj.eval(&xp, None).0 - obj.eval(&xm, None).0) / (2.0 * h);
            assert!(
                (num - g[i]).abs() <= 1e-5 * (1.0 + num.abs()),
                "unknown {i}: numeric {num} analytic {}",
                g[i]
            );
        }
    }

    #[test]
    fn holding_theta_gives_the_loss_and_network_gradient_bit_for_bit() {
        // 37 observations: chunks of lanes and a partial one, all three directions.
        let mut rng = Rng::new(12);
        let data = random_data(&mut rng, 37);
        let obj = objective(&data);
        let x: Vec<f64> = (0..N_UNKNOWNS).map(|_| rng.uniform(-0.5, 0.5)).collect();
        let z: [f64; N_PHYS] = x[..N_PHYS].try_into().unwrap();
        let held = HeldTheta::new(&obj, &z);
        let (mut g, mut gh) = (vec![0.0; N_UNKNOWNS], vec![1.0; N_UNKNOWNS]);
        let (loss, st) = obj.eval(&x, Some(&mut g));
        let (loss_h, st_h) = held.eval(&x, Some(&mut gh));
        assert_eq!(loss.to_bits(), loss_h.to_bits());
        assert_eq!(st, st_h);
        assert!(gh[..N_PHYS].iter().all(|&v| v == 0.0));
        assert!(g[..N_PHYS].iter().any(|&v| v != 0.0));
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&g[N_PHYS..]), bits(&gh[N_PHYS..]));
    }

    #[test]
    fn the_loss_predicts_the_voltage_the_model_does() {
        let mut rng = Rng::new(5);
        let e = Elevator::new(1000.0, 1.75, 26);
        let p = PhysParams::prior_centre(&e);
        for o in random_data(&mut rng, 30) {
            assert_eq!(phys_eval(&p, &p, &o, 1000.0).value.u, o.u_phys(&p, 1000.0));
        }
    }

    #[test]
    fn parameter_map_round_trips_and_keeps_positivity() {
        let e = Elevator::new(1000.0, 1.75, 26);
        let prior = Prior::for_elevator(&e);
        let map = ParamMap::new(&prior, 1000.0);
        let p = PhysParams {
            delta_m: -420.0,
            m0: 3900.0,
            f_c: 250.0,
            c_visc: 80.0,
            kd: 0.004,
            ke: 190.0,
            u0: 6.0,
            alpha_down: 0.85,
            m_rope: -150.0,
            loss_asymmetry: 0.16,
        };
        let back = map.theta(&map.z(&p)).to_array();
        for (a, b) in back.iter().zip(p.to_array()) {
            assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "{a} vs {b}");
        }
        let low = map.theta(&[-50.0; N_PHYS]);
        assert!(
            low.loss_asymmetry > -EPS_MAX && map.theta(&[50.0; N_PHYS]).loss_asymmetry < EPS_MAX
        );
        let positive = low
            .to_array()
            .into_iter()
            .zip(PhysParams::SIGNED)
            .filter(|(_, signed)| !signed);
        assert!(positive.clone().count() == 7 && positive.into_iter().all(|(v, _)| v > 0.0));
    }
}
