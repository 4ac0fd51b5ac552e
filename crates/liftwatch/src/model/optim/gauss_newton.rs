//! Stage 4, fit stage 1: the physics alone, by Gauss-Newton with Levenberg-Marquardt damping.
//!
//! ```text
//! C(z)  = Σ_i w_i·((U_i − U_phys(x_i; θ(z)))/σ_U)² − Σ_i w_i·(σ_v·D(s_i; θ)/σ_U)²
//!         + w_P·Σ_k ((θ_k − μ_k)/τ_k)²              D(s; θ) = ∂U/∂|v| = Ke + Γ·Kd·c
//! J_ik  = ∂U_phys/∂θ_k · dθ_k/dz_k / σ_U           the prior enters as pseudo-observations
//! E_ik  = σ_v·∂D(s_i)/∂θ_k · dθ_k/dz_k / σ_U       the speed noise's term, a negative square
//! H     = Σ_i w_i·(J_iᵀJ_i − E_iᵀE_i) + w_P·diag((dθ_k/dz_k/τ_k)²)
//! g     = Σ_i w_i·(r_i·J_i + σ_v·D(s_i)/σ_U·E_i) − prior terms
//! (H + μ·diag(H))·Δz = g,  z ← z + Δz when C does not rise
//! μ ← max(0.3·μ, 10⁻⁹) after an accepted step, μ ← 10·μ after a rejected one
//! ```
//!
//! The second sum is the errors-in-variables correction (corrected least squares: Fuller,
//! *Measurement Error Models*, 1987, §2.2; Nakamura, Biometrika 1990), 0 in stage 1 itself.
//! The speed regressor is read with its own noise σ_v, so at the true θ a sample's expected
//! squared residual is σ_U² + D²·σ_v², and plain least squares buys part of that back by
//! shrinking D: it attenuates Ke. While cruising |v| is nearly one value per direction, so
//! the back-EMF that Ke loses there, Ke·|v|, is made up by the one term that is also
//! constant per direction, Kd·F_c: half a per cent of Ke on a 1 m/s car is a few hundred
//! newtons of friction. Subtracting the noise's expected share removes the attenuation; σ_v
//! is measured on the training's cruising samples
//! ([`crate::model::train::speed_noise_of`]), and the fit reports the corrected θ beside the
//! plain one, which stays the better predictor from equally noisy readings
//! ([`crate::model::train::train`]). The acceleration's noise is left out: a varies over the
//! whole ramp, so its noise (σ_v/√2 per second for the central difference, about
//! 0.005 m/s²) against its spread (tenths of m/s²) attenuates M0 by about 10⁻⁴.
//!
//! Stopping rule: when an accepted step lowers C by less than 10⁻¹² of C; when 30 increases
//! of μ in a row find no step that lowers C; or after 100 iterations.

use crate::error::{Error, Result};
use crate::linalg::SquareMatrix;
use crate::model::loss::{Obs, ParamMap, Prior};
use crate::model::physics::{PhysParams, N_PHYS};

/// Most Gauss-Newton iterations (each one a fresh linearisation).
const MAX_ITER: usize = 100;
/// Most damping increases per iteration before the fit gives up improving.
const MAX_DAMPING_TRIES: usize = 30;
/// Initial damping μ, relative to the diagonal of H.
const MU_START: f64 = 1e-3;
/// Factor on μ after an accepted step: the model was trusted, trust it more.
const MU_SHRINK: f64 = 0.3;
/// Floor of μ.
const MU_MIN: f64 = 1e-9;
/// Factor on μ after a rejected step or a singular damped matrix.
const MU_GROW: f64 = 10.0;
/// Floor of a diagonal entry of H where it scales the damping, so a flat direction is damped.
const MIN_DIAG: f64 = 1e-12;
/// Relative decrease of C below which an accepted step means convergence.
const REL_TOL: f64 = 1e-12;
/// Floor of C where it divides the decrease, against a division by zero at a perfect fit.
const MIN_COST: f64 = 1e-300;

/// The least-squares problem of stage 1: the voltage equation on `data` with σ_U = `sigma_u`
/// and the prior (weight `w_p`) as pseudo-observations, over z of the map θ(z).
pub struct VoltageFit<'a> {
    /// Observations.
    pub data: &'a [Obs],
    /// The prior on θ.
    pub prior: &'a Prior,
    /// The map z → θ.
    pub map: &'a ParamMap,
    /// Rated load M_r (kg).
    pub rated_load_kg: f64,
    /// σ_U: voltage noise scale (V).
    pub sigma_u: f64,
    /// w_P: weight of the prior.
    pub w_p: f64,
    /// The speed reading's noise and what it acts on ([`SpeedNoise::NONE`] for none); see the
    /// module's notes.
    pub speed_noise: SpeedNoise,
}

/// σ_v, the noise of the speed reading (m/s). Its term D(s; θ) is one value for every sample
/// of one direction and one flow of power (Γ, [`crate::model::PhysParams::gain`]), so the
/// cost sums the moving observations' weights into those four groups (`FlowWeights`) and
/// takes D once per group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedNoise {
    sigma_mps: f64,
}

impl SpeedNoise {
    /// No speed noise: the plain least squares.
    pub const NONE: SpeedNoise = SpeedNoise { sigma_mps: 0.0 };

    /// σ_v = `sigma_mps`; [`SpeedNoise::NONE`] when it is not positive.
    pub fn new(sigma_mps: f64) -> SpeedNoise {
        if sigma_mps.is_nan() || sigma_mps <= 0.0 {
            return SpeedNoise::NONE;
        }
        SpeedNoise { sigma_mps }
    }
}

/// Σ w of the moving observations by direction and power flow at one θ: `[up, down]` ×
/// `[motoring, regenerating]`, with a force of that flow to evaluate Γ at.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct FlowWeights([[f64; 2]; 2]);

impl FlowWeights {
    /// Counts observation `o` of driving force `f` (N).
    fn add(&mut self, o: &Obs, f: f64) {
        let dir = match o.s {
            1 => 0,
            -1 => 1,
            _ => return,
        };
        let flow = usize::from(f * f64::from(o.s) < 0.0);
        self.0[dir][flow] += o.w;
    }

    /// The four groups as (s, a force of the group's flow, Σ w).
    fn groups(&self) -> [(i8, f64, f64); 4] {
        let [[um, ur], [dm, dr]] = self.0;
        [(1, 1.0, um), (1, -1.0, ur), (-1, -1.0, dm), (-1, 1.0, dr)]
    }
}

impl VoltageFit<'_> {
    /// Minimises C from `z`, counting iterations in `iteration` and calling `on_step` with
    /// the iteration and z after each accepted step; returns ẑ.
    ///
    /// # Errors
    /// [`Error::Unidentifiable`] when C is not finite at the end (the fit diverged).
    pub fn solve(
        &self,
        mut z: [f64; N_PHYS],
        iteration: &mut usize,
        on_step: &mut dyn FnMut(usize, &[f64; N_PHYS]),
    ) -> Result<[f64; N_PHYS]> {
        let mut mu = MU_START;
        let mut c = self.cost(&z);
        for _ in 0..MAX_ITER {
            *iteration += 1;
            let (h, g) = self.normal_equations(&z);
            let mut improved = false;
            for _ in 0..MAX_DAMPING_TRIES {
                let mut hd = h.clone();
                for k in 0..N_PHYS {
                    *hd.at(k, k) += mu * h.get(k, k).max(MIN_DIAG);
                }
                let Some(l) = hd.cholesky() else {
                    mu *= MU_GROW;
                    continue;
                };
                let step = l.cholesky_solve(&g);
                let mut zn = z;
                for k in 0..N_PHYS {
                    zn[k] += step[k];
                }
                let cn = self.cost(&zn);
                if cn.is_finite() && cn <= c {
                    let rel = (c - cn) / c.max(MIN_COST);
                    z = zn;
                    c = cn;
                    mu = (mu * MU_SHRINK).max(MU_MIN);
                    improved = true;
                    on_step(*iteration, &z);
                    if rel < REL_TOL {
                        return Ok(z);
                    }
                    break;
                }
                mu *= MU_GROW;
            }
            if !improved {
                break;
            }
        }
        if !c.is_finite() {
            return Err(Error::Unidentifiable("the physical fit diverged".into()));
        }
        Ok(z)
    }

    /// C(z).
    fn cost(&self, z: &[f64; N_PHYS]) -> f64 {
        let p = self.map.theta(z);
        let mut d = 0.0;
        let mut flows = FlowWeights::default();
        for o in self.data {
            let f = p.force(o.s, o.v, o.lambda, o.a, o.q, self.rated_load_kg);
            d += o.w * ((o.u - p.voltage(o.s, o.v, f)) / self.sigma_u).powi(2);
            flows.add(o, f);
        }
        d - self.speed_noise_share(&p, &flows) + self.w_p * self.prior.penalty(&p)
    }

    /// Σ_i w_i·(σ_v·D(s_i; θ)/σ_U)²: the speed noise's expected share of the cost; 0
    /// without a speed noise.
    fn speed_noise_share(&self, p: &PhysParams, flows: &FlowWeights) -> f64 {
        let sigma = self.speed_noise.sigma_mps;
        if sigma <= 0.0 {
            return 0.0;
        }
        flows
            .groups()
            .into_iter()
            .map(|(s, f, w)| w * (sigma * p.du_dspeed(s, f) / self.sigma_u).powi(2))
            .sum()
    }

    /// H = JᵀWJ and g = JᵀWr at z, the prior included.
    fn normal_equations(&self, z: &[f64; N_PHYS]) -> (SquareMatrix, [f64; N_PHYS]) {
        let (m_r, sigma_u, w_p, prior) = (self.rated_load_kg, self.sigma_u, self.w_p, self.prior);
        let p = self.map.theta(z);
        let dz = self.map.dtheta_dz(z);
        let mut h = SquareMatrix::zeros(N_PHYS);
        let mut g = [0.0; N_PHYS];
        let mut flows = FlowWeights::default();
        for o in self.data {
            let f = p.force(o.s, o.v, o.lambda, o.a, o.q, m_r);
            let r = (o.u - p.voltage(o.s, o.v, f)) / sigma_u;
            let mut j = p.du_dtheta_at(o.s, o.v, o.a, o.q, f);
            flows.add(o, f);
            for k in 0..N_PHYS {
                j[k] *= dz[k] / sigma_u;
                g[k] += o.w * r * j[k];
            }
            h.add_outer(&j, o.w);
        }
        if self.speed_noise.sigma_mps > 0.0 {
            let scale = self.speed_noise.sigma_mps / sigma_u;
            for (s, f, w) in flows.groups() {
                let e = scale * p.du_dspeed(s, f);
                let mut de = p.du_dspeed_dtheta(s, f);
                for k in 0..N_PHYS {
                    de[k] *= scale * dz[k];
                    g[k] += w * e * de[k];
                }
                h.add_outer(&de, -w);
            }
        }
        let (t, m) = (p.to_array(), prior.centre.to_array());
        for k in 0..N_PHYS {
            let jk = dz[k] / prior.sd[k];
            *h.at(k, k) += w_p * jk * jk;
            g[k] -= w_p * (t[k] - m[k]) / prior.sd[k] * jk;
        }
        (h, g)
    }
}
