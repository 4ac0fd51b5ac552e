//! Simulator: the hidden physical elevator (richer than the identification model).
//!
//! ```text
//! M_tot = m_car + m_load + m_cw + μ·L_rope + μ_tc·L_tc/2 + m_rot
//! m_eq(x) = m_car + m_load − m_cw + μ·(H − 2x + o_c − o_w) + μ_tc·(x − H/2)/2
//! F    = M_tot·a + m_eq(x)·g + k_f·F_c,s·s·(1 + k_st·exp(−(v/v_st)²)) + k_f·c·v + F_brake
//! U    = U0 + Ke·|v| + φ(s)·Kd(t)·F·s            φ(+1) = 1, φ(−1) = α_down
//!        × η^(−1) motoring (F·s > 0), × η regenerating   η: transmission efficiency
//! Kd(t) = Kd·(1 + 0.0039/K·(T_w(t) − T_ref))·k_motor
//! T_w  = T_amb(t) + ΔT,  dΔT/dt = (ΔT_full·(F/F_ref)²·[moving] − ΔT)/τ_th
//! L%   = 100·(m_load·(g + a) + m_platform·a)/(M_r·g)
//! ```
//!
//! Everything the identification model (MODEL.md) leaves out is here on purpose, so that
//! fitting simulated data is an honest test: the rope imbalance changes sign over the
//! travel (no compensation chain), friction differs slightly by direction and rises near
//! standstill (Stribeck), the winding resistance follows a daily thermal cycle, and the load
//! cell feels the platform's inertia. See [`super`] for the numbers and their sources.

use serde::{Deserialize, Serialize};

use crate::elevator::{Elevator, G};
use crate::model::physics::PhysParams;
use crate::rng::Rng;
use crate::sample::HOUR_S;

use super::scenario::{brake_weight, Effects};

/// Temperature coefficient of copper resistance (1/K).
pub const COPPER_ALPHA_PER_K: f64 = 0.0039;

/// Winding thermal model: machine-room ambient plus a first-order rise driven by copper losses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Thermal {
    /// Daily mean machine-room temperature (°C).
    pub ambient_mean_c: f64,
    /// Half peak-to-peak daily ambient swing (K), warmest at 15:00.
    pub ambient_swing_k: f64,
    /// Winding rise at a continuous force of (1 − q)·M_r·g (K).
    pub rise_full_k: f64,
    /// Winding thermal time constant (s).
    pub tau_s: f64,
    /// Temperature at which Kd has its nominal value (°C).
    pub t_ref_c: f64,
}

/// What the voltage sensor reads with the drive off (V): an offset of a few tenths of a volt.
pub const DRIVE_OFF_IDLE_V: f64 = 0.3;

/// What the drive does at standstill.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum DriveAtRest {
    /// Energised between trips: the voltage reads U0, MODEL.md's base voltage.
    #[default]
    Energised,
    /// Switched off between trips: the voltage reads the sensor's offset `idle_v`. The drive
    /// is energised only from the brake lift to the brake drop of a trip, and holds the car
    /// with pre-torque meanwhile: U0 plus the resistive drop of the holding force,
    /// U0 + Kd·|m_eq·g|.
    Off {
        /// What the voltage sensor reads with the drive off (V).
        idle_v: f64,
    },
}

/// Sensor characteristics of one installation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorSpec {
    /// Speed encoder noise, one sigma (m/s).
    pub speed_noise_mps: f64,
    /// Speed quantisation step (m/s).
    pub speed_quant_mps: f64,
    /// Voltage noise, one sigma (V).
    pub voltage_noise_v: f64,
    /// Voltage quantisation step (V).
    pub voltage_quant_v: f64,
    /// Load-cell noise, one sigma (% of rated).
    pub load_noise_pct: f64,
    /// Load-cell quantisation step (% of rated).
    pub load_quant_pct: f64,
    /// Sampling-instant jitter, one sigma (s).
    pub jitter_s: f64,
    /// Measurement latency per signal in [`super::logger::SIMULATED`] order (s).
    pub latency_s: [f64; 6],
    /// Sampling-clock rate error per signal, parts per million.
    pub clock_ppm: [f64; 6],
}

/// A simulated traction elevator with its hidden true values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimElevator {
    /// The public description (rated values only).
    pub rated: Elevator,
    /// Height of each landing above the lowest one (m), floor 1 first.
    pub floor_positions_m: Vec<f64>,
    /// Empty car mass incl. sling and platform (kg).
    pub car_mass_kg: f64,
    /// Part of the car above the load cell: platform floor and cab (kg).
    pub platform_mass_kg: f64,
    /// Counterweight balance ratio q (counterweight = car + q·M_r).
    pub counterweight_ratio: f64,
    /// Suspension rope mass per metre, all ropes, 1:1 roping (kg/m).
    pub rope_kg_per_m: f64,
    /// Travelling cable mass per metre (kg/m).
    pub travelling_cable_kg_per_m: f64,
    /// Rope length from sheave to car with the car at the top landing (m).
    pub overhead_car_m: f64,
    /// Rope length from sheave to counterweight with the car at the bottom landing (m).
    pub overhead_cw_m: f64,
    /// Rotating inertia of sheave and motor as equivalent translating mass J/r² (kg).
    pub rotating_mass_kg: f64,
    /// Rated acceleration (m/s²).
    pub accel_mps2: f64,
    /// Jerk limit (m/s³).
    pub jerk_mps3: f64,
    /// Coulomb friction F_c, mean of both directions (N).
    pub f_c: f64,
    /// Relative friction difference: up uses F_c·(1 + asym), down F_c·(1 − asym).
    pub f_c_asym: f64,
    /// Stribeck rise of friction near standstill, relative (1).
    pub stribeck_ratio: f64,
    /// Stribeck speed (m/s).
    pub stribeck_speed_mps: f64,
    /// Viscous friction c (N·s/m).
    pub c_visc: f64,
    /// Kd at the reference winding temperature (V/N).
    pub kd: f64,
    /// Back-EMF coefficient Ke (V·s/m).
    pub ke: f64,
    /// Base voltage U0 (V).
    pub u0: f64,
    /// Directional response α_down (1).
    pub alpha_down: f64,
    /// Winding thermal model.
    pub thermal: Thermal,
    /// The drive at standstill (energised unless set: the draw of [`SimElevator::from_elevator`]
    /// keeps its seeds).
    #[serde(default)]
    pub drive_at_rest: DriveAtRest,
    /// η: the transmission's efficiency between the motor and the car (ropes bending over the
    /// sheave, bearings, a gearbox where there is one). The motor supplies F/η while it drives
    /// the car (F·s > 0) and receives F·η while the car drives it (regenerating), so the
    /// resistive voltage is keyed to the power's direction, not the car's: an empty car going
    /// down is driven, a full one brakes. 1 (the default, and in truth files written before it
    /// was kept) leaves MODEL.md's directional response φ(s) as the drive's only asymmetry;
    /// gearless machines run at 0.85-0.95, geared ones lower.
    #[serde(default = "lossless")]
    pub efficiency: f64,
    /// How much of the load's inertia the load cell feels: 1 for a cell under the platform,
    /// 0 for the paper's constant-k cell (`load = 100·λ + a/k`), which feels a fixed mass only.
    #[serde(default = "unit_gain")]
    pub load_cell_load_gain: f64,
    /// Sensors.
    pub sensors: SensorSpec,
}

/// The load gain of a cell under the platform.
fn unit_gain() -> f64 {
    1.0
}

/// The lowest transmission efficiency a plant takes: below one half a worm gear locks
/// itself, and no traction machine of the contract's range runs that lossy.
pub const MIN_EFFICIENCY: f64 = 0.5;

/// Why a transmission efficiency `eta` is refused; `None` when it lies between
/// [`MIN_EFFICIENCY`] and 1.
pub fn efficiency_problem(eta: f64) -> Option<String> {
    (!(MIN_EFFICIENCY..=1.0).contains(&eta)).then(|| {
        format!(
            "{} must lie between {MIN_EFFICIENCY} and 1",
            crate::error::number(eta)
        )
    })
}

/// The efficiency of a transmission without losses.
fn lossless() -> f64 {
    1.0
}

impl SimElevator {
    /// Draws plausible hidden values for the elevator `e` (rated values and optional keys).
    ///
    /// Optional keys of `e` (car mass, counterweight ratio, floor height, rated voltage) are
    /// used as given; every other value is drawn from the ranges documented in [`super`].
    pub fn from_elevator(e: &Elevator, rng: &mut Rng) -> Self {
        let m_r = e.rated_load_kg;
        let v_r = e.rated_speed_mps;
        let u_r = e.rated_voltage();
        let floors = e.floors.max(2) as usize;
        let typical = e.floor_height_m.unwrap_or_else(|| rng.uniform(3.0, 3.6));
        let mut floor_positions_m = Vec::with_capacity(floors);
        let mut x = 0.0;
        floor_positions_m.push(x);
        for i in 1..floors {
            // The lobby storey is taller; every storey varies by up to ±8 %.
            let base = if i == 1 {
                typical * rng.uniform(1.25, 1.45)
            } else {
                typical
            };
            x += base * (1.0 + rng.uniform(-0.08, 0.08));
            floor_positions_m.push(x);
        }
        let car = e.car_mass_kg.unwrap_or_else(|| m_r * rng.uniform(1.0, 1.4));
        let q = e
            .counterweight_ratio
            .unwrap_or_else(|| rng.uniform(0.40, 0.50));
        let cw = car + q * m_r;
        let rope_kg_per_m = m_r / 1000.0 * rng.uniform(1.2, 2.4);
        let rotating_mass_kg = rng.uniform(0.06, 0.14) * (car + cw);
        let f_c = rng.uniform(0.010, 0.020) * (car + m_r) * G;
        let c_visc = rng.uniform(0.3, 0.7) * f_c / v_r;
        let kd = rng.uniform(0.05, 0.09) * u_r / ((1.0 - q) * m_r * G);
        let overhead = rng.uniform(3.5, 5.0);
        let rated = Elevator {
            car_mass_kg: None,
            counterweight_ratio: None,
            floor_height_m: None,
            ..e.clone()
        };
        let mut s = SimElevator {
            rated,
            floor_positions_m,
            car_mass_kg: car,
            platform_mass_kg: car * rng.uniform(0.15, 0.30),
            counterweight_ratio: q,
            rope_kg_per_m,
            travelling_cable_kg_per_m: rng.uniform(0.4, 1.0),
            overhead_car_m: overhead,
            overhead_cw_m: overhead + rng.uniform(-0.5, 0.5),
            rotating_mass_kg,
            accel_mps2: rng.uniform(0.6, 1.0),
            jerk_mps3: rng.uniform(0.8, 1.5),
            f_c,
            f_c_asym: rng.uniform(-0.05, 0.05),
            stribeck_ratio: rng.uniform(0.2, 0.4),
            stribeck_speed_mps: rng.uniform(0.03, 0.08),
            c_visc,
            kd,
            ke: rng.uniform(0.80, 0.90) * u_r / v_r,
            u0: rng.uniform(0.01, 0.03) * u_r,
            alpha_down: rng.uniform(0.80, 0.95),
            thermal: Thermal {
                ambient_mean_c: rng.uniform(18.0, 28.0),
                ambient_swing_k: rng.uniform(1.5, 3.0),
                rise_full_k: rng.uniform(100.0, 150.0),
                tau_s: rng.uniform(1800.0, 3600.0),
                t_ref_c: 0.0,
            },
            drive_at_rest: DriveAtRest::Energised,
            efficiency: 1.0,
            load_cell_load_gain: 1.0,
            sensors: SensorSpec {
                speed_noise_mps: rng.uniform(0.003, 0.007),
                speed_quant_mps: 0.001,
                voltage_noise_v: rng.uniform(0.6, 1.2),
                voltage_quant_v: [0.1, 0.25, 0.5][rng.below(3) as usize],
                load_noise_pct: rng.uniform(0.3, 0.7),
                load_quant_pct: 1.0,
                jitter_s: rng.uniform(0.01, 0.04),
                latency_s: std::array::from_fn(|_| rng.uniform(0.0, 0.05)),
                clock_ppm: std::array::from_fn(|_| rng.uniform(-100.0, 100.0)),
            },
        };
        // Nominal Kd holds at ambient mean plus the rise of a typical weekday duty (~9 % of the
        // full-force rise), so that the daily drift swings around 1.
        s.thermal.t_ref_c = s.thermal.ambient_mean_c + 0.09 * s.thermal.rise_full_k;
        s
    }

    /// The public description: rated values only, as an owner knows them.
    pub fn to_elevator(&self) -> Elevator {
        self.rated.clone()
    }

    /// Travel height H between the lowest and highest landing (m).
    pub fn travel_m(&self) -> f64 {
        self.floor_positions_m.last().copied().unwrap_or(0.0)
    }

    /// Counterweight mass (kg).
    pub fn counterweight_mass_kg(&self) -> f64 {
        self.car_mass_kg + self.counterweight_ratio * self.rated.rated_load_kg
    }

    /// Rope and travelling-cable imbalance felt on the car side at height `x` (kg, + pulls down).
    pub fn imbalance_kg(&self, x: f64) -> f64 {
        let h = self.travel_m();
        let ropes = self.rope_kg_per_m * ((h - x + self.overhead_car_m) - (x + self.overhead_cw_m));
        let cable = self.travelling_cable_kg_per_m * (x - 0.5 * h) / 2.0;
        ropes + cable
    }

    /// m_eq(x): car and load against counterweight, ropes and cable at height `x` (kg, + pulls
    /// the car down).
    pub fn unbalanced_mass_kg(&self, x: f64, load_kg: f64) -> f64 {
        self.car_mass_kg + load_kg - self.counterweight_mass_kg() + self.imbalance_kg(x)
    }

    /// Moving mass with an empty car, rotating inertia included (kg).
    pub fn m0(&self) -> f64 {
        let h = self.travel_m();
        let ropes = self.rope_kg_per_m * (2.0 * h + self.overhead_car_m + self.overhead_cw_m);
        let cable = self.travelling_cable_kg_per_m * h / 2.0;
        self.car_mass_kg + self.counterweight_mass_kg() + ropes + cable + self.rotating_mass_kg
    }

    /// Driving force on the car side (N, + up) at height `x`, velocity `v` (+ up), acceleration
    /// `a`, load `load_kg`, with the degradation effects `fx`.
    pub fn force(&self, x: f64, v: f64, a: f64, load_kg: f64, fx: &Effects) -> f64 {
        let s = sign(v);
        let m_tot = self.m0() + load_kg;
        let m_eq = self.unbalanced_mass_kg(x, load_kg);
        let fc_dir = self.f_c * (1.0 + f64::from(s) * self.f_c_asym);
        let stribeck = 1.0 + self.stribeck_ratio * (-(v / self.stribeck_speed_mps).powi(2)).exp();
        let friction = fx.friction_factor * (fc_dir * f64::from(s) * stribeck + self.c_visc * v);
        let brake = fx.brake_drag_n * brake_weight(s, a * f64::from(s)) * f64::from(s);
        m_tot * a + m_eq * G + friction + brake
    }

    /// Winding temperature-rise steady state for a driving force (K), zero at rest.
    pub fn heating_k(&self, force: f64, moving: bool) -> f64 {
        if !moving {
            return 0.0;
        }
        let f_ref = (1.0 - self.counterweight_ratio) * self.rated.rated_load_kg * G;
        self.thermal.rise_full_k * (force / f_ref).powi(2)
    }

    /// Machine-room temperature at time `t` (°C), warmest at 15:00.
    pub fn ambient_c(&self, t: f64) -> f64 {
        let hour = (t / HOUR_S).rem_euclid(24.0);
        self.thermal.ambient_mean_c
            + self.thermal.ambient_swing_k * (std::f64::consts::TAU * (hour - 15.0) / 24.0).cos()
    }

    /// Thermal factor of Kd for a winding rise `rise_k` above ambient at time `t`.
    pub fn kd_thermal_factor(&self, t: f64, rise_k: f64) -> f64 {
        1.0 + COPPER_ALPHA_PER_K * (self.ambient_c(t) + rise_k - self.thermal.t_ref_c)
    }

    /// Motor voltage magnitude (V) for velocity `v`, force `force` and the current `kd`.
    pub fn voltage(&self, v: f64, force: f64, kd: f64) -> f64 {
        let s = sign(v);
        let phi = if s < 0 { self.alpha_down } else { 1.0 };
        let drop = kd * force * f64::from(s);
        (self.u0 + self.ke * v.abs() + phi * self.transmission(drop) * drop).max(0.0)
    }

    /// The transmission's factor on the resistive voltage `drop` = Kd·F·s: 1/η when the motor
    /// drives the car (a positive drop), η when the car drives the motor.
    fn transmission(&self, drop: f64) -> f64 {
        if drop > 0.0 {
            1.0 / self.efficiency
        } else {
            self.efficiency
        }
    }

    /// Motor voltage magnitude (V) the drive shows at height `x`, velocity `v`, force `force`,
    /// `load_kg` aboard and the current `kd`: [`SimElevator::voltage`], except at rest on a
    /// drive that is off there: the sensor's offset, or U0 plus the resistive drop of the
    /// pre-torque holding the car while `energised` (brake lift and drop).
    pub fn drive_voltage(
        &self,
        (x, v): (f64, f64),
        force: f64,
        load_kg: f64,
        energised: bool,
        kd: f64,
    ) -> f64 {
        match self.drive_at_rest {
            DriveAtRest::Off { idle_v } if sign(v) == 0 && !energised => idle_v,
            DriveAtRest::Off { .. } if sign(v) == 0 => {
                self.u0 + kd * (self.unbalanced_mass_kg(x, load_kg) * G).abs()
            }
            _ => self.voltage(v, force, kd),
        }
    }

    /// Load-cell reading without noise (% of rated): the cell carries platform and load, and
    /// feels the inertia of the platform and of the share `load_cell_load_gain` of the load.
    pub fn load_cell_pct(&self, load_kg: f64, a: f64) -> f64 {
        let felt = load_kg * (G + self.load_cell_load_gain * a) + self.platform_mass_kg * a;
        100.0 * felt / (self.rated.rated_load_kg * G)
    }

    /// The true parameters in the identification model's terms (MODEL.md and
    /// `model::physics`): M0 with rotating inertia, mean F_c, c, nominal Kd times the mean of
    /// the transmission's two slopes, Ke, U0, α_down, ε of the transmission's η, and the
    /// position terms Δm + m_rope·q as the least-squares line of the true imbalance
    /// over the landings, q = (floor − 1)/(floors − 1) − ½ (the landings are unevenly spaced,
    /// so the line is the best the floor-indexed model can do, not an exact match).
    pub fn true_params(&self) -> PhysParams {
        let n = self.floor_positions_m.len();
        let (mut mean, mut sqq, mut sqi) = (0.0, 0.0, 0.0);
        for (i, &x) in self.floor_positions_m.iter().enumerate() {
            let q = if n > 1 {
                i as f64 / (n - 1) as f64 - 0.5
            } else {
                0.0
            };
            let imb = self.imbalance_kg(x);
            mean += imb / n.max(1) as f64;
            sqq += q * q;
            sqi += q * imb;
        }
        PhysParams {
            delta_m: self.car_mass_kg - self.counterweight_mass_kg() + mean,
            m0: self.m0(),
            f_c: self.f_c,
            c_visc: self.c_visc,
            // Γ's mean slope and its asymmetry (model::physics): 1/η motoring, η regenerating.
            kd: self.kd * (1.0 / self.efficiency + self.efficiency) / 2.0,
            ke: self.ke,
            u0: self.u0,
            alpha_down: self.alpha_down,
            m_rope: if sqq > 0.0 { sqi / sqq } else { 0.0 },
            loss_asymmetry: (1.0 / self.efficiency - self.efficiency)
                / (1.0 / self.efficiency + self.efficiency),
        }
    }
}

/// Direction of motion: +1, −1, or 0 below 1 mm/s.
pub fn sign(v: f64) -> i8 {
    if v > 1e-3 {
        1
    } else if v < -1e-3 {
        -1
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plant() -> SimElevator {
        SimElevator::from_elevator(&Elevator::new(1000.0, 1.75, 20), &mut Rng::new(3))
    }

    const NONE: Effects = Effects {
        severity: 0.0,
        kd_factor: 1.0,
        friction_factor: 1.0,
        brake_drag_n: 0.0,
    };

    #[test]
    fn empty_car_going_up_regenerates_and_full_car_motors() {
        let p = plant();
        let x = 0.5 * p.travel_m();
        let f_empty = p.force(x, 1.75, 0.0, 0.0, &NONE);
        assert!(
            f_empty < 0.0,
            "counterweight outweighs the empty car: {f_empty}"
        );
        assert!(p.voltage(1.75, f_empty, p.kd) < p.u0 + p.ke * 1.75);
        let f_full = p.force(x, 1.75, 0.0, 1000.0, &NONE);
        assert!(f_full > 0.0 && p.voltage(1.75, f_full, p.kd) > p.u0 + p.ke * 1.75);
        assert_eq!(p.voltage(0.0, 1234.0, p.kd), p.u0);
    }

    #[test]
    fn a_lossy_transmission_asks_more_voltage_driving_and_gives_less_back_braking() {
        let mut p = plant();
        let x = 0.5 * p.travel_m();
        let (v, kd) = (1.75f64, p.kd);
        let emf = p.u0 + p.ke * v;
        // Full car up: the motor drives. Empty car up: the counterweight drives the motor.
        let f_full = p.force(x, v, 0.0, 1000.0, &NONE);
        let f_empty = p.force(x, v, 0.0, 0.0, &NONE);
        let (full, empty) = (p.voltage(v, f_full, kd), p.voltage(v, f_empty, kd));
        p.efficiency = 0.8;
        let (full_lossy, empty_lossy) = (p.voltage(v, f_full, kd), p.voltage(v, f_empty, kd));
        assert!(((full_lossy - emf) / (full - emf) - 1.0 / 0.8).abs() < 1e-12);
        assert!(((empty_lossy - emf) / (empty - emf) - 0.8).abs() < 1e-12);
        // Going down the roles swap: the empty car is driven down against the counterweight.
        let f_empty_down = p.force(x, -v, 0.0, 0.0, &NONE);
        let drop_down = p.voltage(-v, f_empty_down, kd) - emf;
        let expected = p.alpha_down * kd * -f_empty_down / 0.8;
        assert!(drop_down > 0.0 && (drop_down - expected).abs() < 1e-9);
    }

    #[test]
    fn rope_imbalance_changes_sign_over_the_travel_and_its_line_fits_the_landings() {
        let p = plant();
        assert!(p.imbalance_kg(0.0) > 0.0);
        assert!(p.imbalance_kg(p.travel_m()) < 0.0);
        let th = p.true_params();
        assert!(
            th.m_rope < 0.0,
            "ropes outweigh the travelling cable: {}",
            th.m_rope
        );
        let ends = p.imbalance_kg(p.travel_m()) - p.imbalance_kg(0.0);
        assert!(
            (th.m_rope / ends - 1.0).abs() < 0.15,
            "{} vs {ends}",
            th.m_rope
        );
        let n = p.floor_positions_m.len();
        let empty = p.car_mass_kg - p.counterweight_mass_kg();
        for (i, &x) in p.floor_positions_m.iter().enumerate() {
            let q = i as f64 / (n - 1) as f64 - 0.5;
            let line = th.delta_m + th.m_rope * q;
            assert!(
                (line - empty - p.imbalance_kg(x)).abs() < 0.1 * ends.abs(),
                "landing {i}"
            );
        }
    }

    #[test]
    fn load_cell_at_rest_reads_the_load_and_feels_inertia_when_accelerating() {
        let p = plant();
        assert!((p.load_cell_pct(150.0, 0.0) - 15.0).abs() < 1e-9);
        assert!(p.load_cell_pct(0.0, 0.8) > 0.0);
        assert!(p.load_cell_pct(150.0, -0.8) < 15.0);
    }

    #[test]
    fn drawn_values_stay_in_their_documented_ranges() {
        for seed in 0..20 {
            let p =
                SimElevator::from_elevator(&Elevator::new(1000.0, 1.6, 16), &mut Rng::new(seed));
            assert!((0.40..=0.50).contains(&p.counterweight_ratio));
            assert!((0.6..=1.0).contains(&p.accel_mps2) && (0.8..=1.5).contains(&p.jerk_mps3));
            assert_eq!(p.floor_positions_m.len(), 16);
            let heights: Vec<f64> = p
                .floor_positions_m
                .windows(2)
                .map(|w| w[1] - w[0])
                .collect();
            assert!(
                heights[0] > heights[1..].iter().cloned().fold(0.0, f64::max) * 0.95,
                "lobby is taller"
            );
            assert_eq!(p.to_elevator(), Elevator::new(1000.0, 1.6, 16));
        }
    }
}
