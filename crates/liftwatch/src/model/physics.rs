//! The electromechanical model of drive and car (paper, Sec. 2.1-2.2; MODEL.md).
//!
//! ```text
//! m_eq  = Δm + λ·M_r + m_rope·q      M_tot = M0 + λ·M_r
//! q     = (floor − 1)/(floors − 1) − ½   relative height of the car, −½ bottom … +½ top
//! F     = M_tot·a + m_eq·g + F_c·s + c·v
//! U     = U0 + Ke·|v| + Γ·Kd·F·s      Γ = φ(s)·(1 + ε·sign(F·s))
//!                                     φ(+1) = 1, φ(−1) = α_down, φ(0) = 0
//! F_U   = (U − U0 − Ke·|v|) / (Γ·Kd·s)   the force the measured voltage implies (Γ at the
//!                                        model's force)
//! ```
//!
//! Deviation from MODEL.md: the term m_rope·q. Without a compensation chain the hoist ropes
//! (and the travelling cable the other way) move weight from one side of the sheave to the
//! other as the car travels, by about 2·ρ·travel from the bottom to the top landing (several
//! hundred kilograms in a tall building). Without it the fit blames that imbalance on whatever
//! correlates with position in the training data: on simulated up-peak traffic, where loaded
//! cars start at the lobby, Kd came out 12 % high; with it, within 1 %.
//!
//! Deviation from MODEL.md: the loss asymmetry ε. A transmission of efficiency η (a gear, the
//! sheave's rope bending, the drive's own losses) needs F/η from the motor while the motor
//! drives the car (F·s > 0, motoring) and gives back only F·η while the car drives the motor
//! (F·s < 0, regenerating): the resistive term's slope breaks at F = 0, by a factor 1/η² on a
//! line through the origin. With Γ = φ(s)·(1 + ε·sign(F·s)) that is
//! ε = (1/η − η)/(1/η + η) (0.16 for η = 0.85, 0.22 for 0.8), Kd then standing for
//! (R/Kt)·(1/η + η)/2. MODEL.md's φ(s) is keyed to the direction only, and the direction and
//! the power's flow coincide only for a car lighter than its counterweight: an empty car
//! regenerates going up and motors going down, so on light traffic α_down took the whole
//! 1/η² (1.11-1.28 on drives of η 0.8-0.85 whose true α_down was 0.84-0.93) and every loaded
//! trip, whose power flows the other way, was predicted with the other slope. The fault
//! signatures inherit Γ, so a drag, a friction rise and a motor fault are each weighed with
//! the slope their trip's power flow has. On a lossless drive ε fits near 0 and nothing
//! changes.

use serde::{Deserialize, Serialize};

use crate::elevator::{Elevator, G};

/// Number of physical parameters θ.
pub const N_PHYS: usize = 10;

/// Physical parameters θ of drive and car (paper, Sec. 2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhysParams {
    /// Δm: unbalanced mass with an empty car, car minus counterweight (kg); may be negative.
    pub delta_m: f64,
    /// M0: moving mass with an empty car, rotating inertia as equivalent mass (kg).
    pub m0: f64,
    /// F_c: Coulomb friction and brake drag, lumped (N).
    pub f_c: f64,
    /// c: viscous friction coefficient (N·s/m).
    pub c_visc: f64,
    /// Kd = R/Kt: electromechanical drive coefficient (V/N).
    pub kd: f64,
    /// Ke: back-EMF coefficient (V·s/m).
    pub ke: f64,
    /// U0: base voltage, what the drive shows at standstill (V).
    pub u0: f64,
    /// α_down: directional response of the resistive term in downward travel (1).
    pub alpha_down: f64,
    /// m_rope: change of the unbalanced mass from the bottom to the top landing (kg); negative
    /// when the hoist ropes outweigh the travelling cable.
    #[serde(default)]
    pub m_rope: f64,
    /// ε: the drive's loss asymmetry, the resistive term (1 + ε) times its lossless slope while
    /// motoring and (1 − ε) times while regenerating (1; module doc). 0 in a model file
    /// without it, the lossless drive of MODEL.md.
    #[serde(default)]
    pub loss_asymmetry: f64,
}

/// The largest loss asymmetry |ε| the fit may reach: ε = 0.8 is a transmission of η = 0.33,
/// below any elevator's (worm gears run at 0.5-0.7, planetary and gearless drives above 0.9).
/// The map z → ε is 0.8·tanh(z/8), so that 1 ± ε stays positive.
pub const EPS_MAX: f64 = 0.8;

impl PhysParams {
    /// Parameter names in the order of [`PhysParams::to_array`], as in the model file.
    pub const NAMES: [&'static str; N_PHYS] = [
        "delta_m",
        "m0",
        "f_c",
        "c_visc",
        "kd",
        "ke",
        "u0",
        "alpha_down",
        "m_rope",
        "loss_asymmetry",
    ];
    /// Units, in the same order.
    pub const UNITS: [&'static str; N_PHYS] = [
        "kg", "kg", "N", "N s/m", "V/N", "V s/m", "V", "1", "kg", "1",
    ];
    /// Parameters that may take either sign (the others are positive).
    pub const SIGNED: [bool; N_PHYS] = [
        true, false, false, false, false, false, false, false, true, true,
    ];
    /// Index of ε in [`PhysParams::NAMES`]: the one signed parameter that is also bounded
    /// ([`EPS_MAX`]).
    pub const EPS: usize = 9;

    /// The values that motion with standstill determines through the voltage (README,
    /// *Identifiability*), named: Δm, M0, Kd, U0, α_down and the back-EMF combinations
    /// Ke + Kd·c going up and Ke + α_down·Kd·c going down. Ke and c alone part only through
    /// α_down ≠ 1, and F_c is a small difference of two large constants (Δm·g ± F_c).
    pub fn determined(&self) -> [(&'static str, f64); 7] {
        [
            ("delta_m", self.delta_m),
            ("m0", self.m0),
            ("kd", self.kd),
            ("u0", self.u0),
            ("alpha_down", self.alpha_down),
            ("ke + kd*c_visc", self.ke + self.kd * self.c_visc),
            (
                "ke + alpha_down*kd*c_visc",
                self.ke + self.alpha_down * self.kd * self.c_visc,
            ),
        ]
    }

    /// The parameters as an array in the order of [`PhysParams::NAMES`].
    pub fn to_array(&self) -> [f64; N_PHYS] {
        [
            self.delta_m,
            self.m0,
            self.f_c,
            self.c_visc,
            self.kd,
            self.ke,
            self.u0,
            self.alpha_down,
            self.m_rope,
            self.loss_asymmetry,
        ]
    }

    /// The parameters from an array in the order of [`PhysParams::NAMES`].
    pub fn from_array(a: [f64; N_PHYS]) -> Self {
        PhysParams {
            delta_m: a[0],
            m0: a[1],
            f_c: a[2],
            c_visc: a[3],
            kd: a[4],
            ke: a[5],
            u0: a[6],
            alpha_down: a[7],
            m_rope: a[8],
            loss_asymmetry: a[9],
        }
    }

    /// Plausible values for an elevator known only by its description: the centres of the priors.
    pub fn prior_centre(e: &Elevator) -> Self {
        let m_r = e.rated_load_kg;
        let v_r = e.rated_speed_mps;
        let u_r = e.rated_voltage();
        // Friction about 1.5 % of the suspended weight of car and rated load.
        let f_c = 0.015 * (e.car_mass() + m_r) * G;
        // Resistive drop about 7 % of rated voltage at the full-load motoring force.
        let kd = 0.07 * u_r / ((1.0 - e.counterweight_ratio()) * m_r * G);
        PhysParams {
            delta_m: e.expected_delta_m(),
            m0: e.expected_m0(),
            f_c,
            c_visc: 0.5 * f_c / v_r,
            kd,
            ke: 0.85 * u_r / v_r,
            u0: 0.02 * u_r,
            alpha_down: 1.0,
            m_rope: 0.0,
            loss_asymmetry: 0.0,
        }
    }

    /// q: relative height of the car from the floor indicator, −½ at the bottom landing, +½ at
    /// the top; 0 (mid-travel) when the floor is unknown.
    pub fn relative_height(floor: f64, floors: u32) -> f64 {
        if !floor.is_finite() || floors < 2 {
            return 0.0;
        }
        ((floor - 1.0) / f64::from(floors - 1)).clamp(0.0, 1.0) - 0.5
    }

    /// φ(s): the directional response, 1 up, α_down down, 0 at rest.
    pub fn phi(&self, s: i8) -> f64 {
        match s {
            1 => 1.0,
            -1 => self.alpha_down,
            _ => 0.0,
        }
    }

    /// Γ: the resistive term's gain at force `force` in direction `s`, φ(s)·(1 + ε·sign(F·s));
    /// 0 at rest. At F = 0 exactly it is φ(s) (the term is 0 there either way).
    pub fn gain(&self, s: i8, force: f64) -> f64 {
        let flow = force * f64::from(s);
        let k = if flow > 0.0 {
            self.loss_asymmetry
        } else if flow < 0.0 {
            -self.loss_asymmetry
        } else {
            0.0
        };
        self.phi(s) * (1.0 + k)
    }

    /// F: driving force on the car side (N, + up) that the dynamics require.
    /// `q` is the relative height of [`PhysParams::relative_height`].
    pub fn force(&self, s: i8, v: f64, lambda: f64, a: f64, q: f64, rated_load_kg: f64) -> f64 {
        self.inertia_and_weight(lambda, a, q, rated_load_kg)
            + self.f_c * f64::from(s)
            + self.c_visc * v
    }

    /// Newton without friction: M_tot·a + m_eq·g (N), the part of [`PhysParams::force`] that
    /// is not F_b; the conventional baseline reads friction as what the voltage's force leaves
    /// over it.
    pub fn inertia_and_weight(&self, lambda: f64, a: f64, q: f64, rated_load_kg: f64) -> f64 {
        let m_tot = self.m0 + lambda * rated_load_kg;
        let m_eq = self.delta_m + lambda * rated_load_kg + self.m_rope * q;
        m_tot * a + m_eq * G
    }

    /// U: motor voltage magnitude (V) for a driving force `force`.
    pub fn voltage(&self, s: i8, v: f64, force: f64) -> f64 {
        self.u0 + self.ke * v.abs() + self.gain(s, force) * self.kd * force * f64::from(s)
    }

    /// F_U: the force (N) that a measured voltage implies through the motor model; NaN at rest.
    /// The slope is the one of the power flow of `predicted`, the model's own force at the
    /// sample: F = (U − U0 − Ke·|v|)/(Γ·Kd·s) with Γ at `predicted`. Chosen by the sign of the
    /// measured voltage instead, a reading whose noise crosses the break near F = 0 would take
    /// the other slope, and the implied force's noise would bend where the model's is straight.
    pub fn force_from_voltage(&self, s: i8, v: f64, voltage: f64, predicted: f64) -> f64 {
        if s == 0 {
            return f64::NAN;
        }
        (voltage - self.u0 - self.ke * v.abs()) / (self.gain(s, predicted) * self.kd * f64::from(s))
    }

    /// ∂U/∂θ: the derivative of the voltage equation with respect to θ, in the order of
    /// [`PhysParams::NAMES`], at one operating point (arguments as in [`PhysParams::force`]).
    ///
    /// ```text
    /// ∂U/∂θ_k = Γ·Kd·s·∂F/∂θ_k   for Δm, M0, F_c, c, m_rope  (∂F/∂θ = g, a, s, v, g·q)
    /// ∂U/∂Kd = Γ·s·F    ∂U/∂Ke = |v|    ∂U/∂U0 = 1    ∂U/∂α_down = (Γ/α_down)·Kd·s·F when s = −1
    /// ∂U/∂ε = φ·Kd·|F|   (Γ's break at F = 0 is where the resistive term is 0)
    /// ```
    pub fn du_dtheta(
        &self,
        s: i8,
        v: f64,
        lambda: f64,
        a: f64,
        q: f64,
        rated_load_kg: f64,
    ) -> [f64; N_PHYS] {
        let f = self.force(s, v, lambda, a, q, rated_load_kg);
        self.du_dtheta_at(s, v, a, q, f)
    }

    /// ∂U/∂|v| in direction `s` (±1) at force `force`: Ke + Γ·Kd·c, the back-EMF and the
    /// viscous friction's share (V·s/m). An error e in the speed reading moves the predicted
    /// voltage by this times e.
    pub fn du_dspeed(&self, s: i8, force: f64) -> f64 {
        self.ke + self.gain(s, force) * self.kd * self.c_visc
    }

    /// ∂(∂U/∂|v|)/∂θ in direction `s` (±1) at force `force`, in the order of
    /// [`PhysParams::NAMES`]: c, Kd, Ke, ε and, down, α_down.
    pub fn du_dspeed_dtheta(&self, s: i8, force: f64) -> [f64; N_PHYS] {
        let gain = self.gain(s, force);
        let mut d = [0.0; N_PHYS];
        d[3] = gain * self.kd;
        d[4] = gain * self.c_visc;
        d[5] = 1.0;
        if s == -1 {
            d[7] = gain / self.alpha_down * self.kd * self.c_visc;
        }
        d[Self::EPS] = self.phi(s) * (force * f64::from(s)).signum() * self.kd * self.c_visc;
        d
    }

    /// [`Self::du_dtheta`] for a caller that has the force F at the point already.
    pub fn du_dtheta_at(&self, s: i8, v: f64, a: f64, q: f64, f: f64) -> [f64; N_PHYS] {
        let sf = f64::from(s);
        let gain = self.gain(s, f);
        let k = gain * self.kd * sf;
        [
            k * G,
            k * a,
            k * sf,
            k * v,
            gain * sf * f,
            v.abs(),
            1.0,
            if s == -1 {
                gain / self.alpha_down * self.kd * sf * f
            } else {
                0.0
            },
            k * G * q,
            self.phi(s) * self.kd * f.abs(),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voltage_and_implied_force_are_inverse() {
        let p = PhysParams::prior_centre(&Elevator::new(1000.0, 1.75, 26));
        for (s, v, lam, a) in [
            (1, 1.7, 0.3, 0.2),
            (-1, -1.2, 0.05, -0.4),
            (1, 0.3, 0.9, 0.8),
        ] {
            let f = p.force(s, v, lam, a, 0.2, 1000.0);
            let u = p.voltage(s, v, f);
            assert!((p.force_from_voltage(s, v, u, f) - f).abs() < 1e-6 * f.abs().max(1.0));
        }
        assert!(p.force_from_voltage(0, 0.0, 10.0, 0.0).is_nan());
    }

    #[test]
    fn an_empty_car_going_up_regenerates() {
        // The counterweight outweighs an empty car: lifting it takes negative force, and the
        // resistive term lowers the voltage below the back-EMF line.
        let p = PhysParams::prior_centre(&Elevator::new(1000.0, 1.75, 26));
        let f = p.force(1, 1.75, 0.0, 0.0, 0.0, 1000.0);
        assert!(f < 0.0);
        assert!(p.voltage(1, 1.75, f) < p.u0 + p.ke * 1.75);
    }
}
