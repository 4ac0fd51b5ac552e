//! The simulator's time loop: dispatcher, motion, doors and brake, the plant's physics and
//! the logger, second by second (timings and equations in the module docs of [`super`]).

use super::service::DOOR_STREAM_SALT;
use super::*;
use crate::sample::DAY_S;

/// Most calls waiting at once; beyond it new calls are dropped (people take the stairs).
const MAX_QUEUE: usize = 400;

/// Most reopenings in a row after one door cycle: a door that bounces more often than this is
/// taken out of the loop by the controller (and the simulation cannot loop for ever).
const MAX_REOPENINGS: u32 = 5;

/// Motion of the car during one stretch of time.
#[derive(Clone, Copy)]
enum Motion<'c> {
    /// Standing at the current position.
    Rest,
    /// Travelling along `curve`, started at `t0` from `from` in direction `dir`.
    Travel {
        curve: &'c SCurve,
        t0: f64,
        from: f64,
        dir: i8,
    },
}

/// The dispatcher and the time loop (door and brake timings in the module docs).
///
/// Calls are served one direction at a time: riders are dropped off nearest first, waiting
/// groups at a landing board when they go the car's way and fit in the rated load.
pub(super) struct Engine<'a, S: SimSink> {
    cfg: &'a SimConfig,
    p: &'a SimElevator,
    sink: &'a mut S,
    progress: &'a mut dyn FnMut(f64),
    rng: Rng,
    noise_raw: Rng,
    noise_grid: Rng,
    traffic: Traffic,
    next_call: Call,
    queue: VecDeque<Call>,
    clocks: [SensorClock; 6],
    logger: RawLogger,
    t: f64,
    end: f64,
    next_grid: f64,
    next_day: f64,
    floor: usize,
    pos: f64,
    dir_travel: i8,
    riders: Vec<(usize, f64)>,
    load_kg: f64,
    door: bool,
    /// The drive is energised: from the brake lift before a trip to the brake drop after it.
    energised: bool,
    dir_signal: i8,
    rise_k: f64,
    stuck_speed: Option<f64>,
    summary: SimSummary,
    load_time: f64,
    imbalance_time: f64,
    /// The doors' own random stream ([`DOOR_STREAM_SALT`]); never drawn with ideal doors.
    door_rng: Rng,
    /// Outages still to come, earliest first.
    outages: Vec<OutagePlan>,
    /// Outages as they happened.
    outages_done: Vec<OutageTruth>,
}

impl<'a, S: SimSink> Engine<'a, S> {
    pub(super) fn new(
        cfg: &'a SimConfig,
        p: &'a SimElevator,
        rng: &mut Rng,
        sink: &'a mut S,
        progress: &'a mut dyn FnMut(f64),
    ) -> Self {
        let start = cfg.start_s;
        let floors = p.floor_positions_m.len();
        let mut traffic = Traffic::new(
            rng.fork(),
            floors,
            p.rated.rated_load_kg,
            cfg.traffic_scale,
            start,
        );
        let next_call = traffic.next_call();
        let sp = &p.sensors;
        let clocks = std::array::from_fn(|k| {
            SensorClock::new(
                rng.fork(),
                start,
                sp.clock_ppm[k],
                sp.jitter_s,
                cfg.dropouts_per_day,
            )
        });
        let floor = rng.below(floors as u64) as usize;
        Engine {
            cfg,
            p,
            sink,
            progress,
            rng: rng.fork(),
            noise_raw: rng.fork(),
            noise_grid: rng.fork(),
            traffic,
            next_call,
            queue: VecDeque::new(),
            clocks,
            logger: RawLogger::new(rng.fork(), start),
            t: start,
            end: start + cfg.duration_s(),
            next_grid: start.ceil(),
            next_day: start + DAY_S,
            floor,
            pos: p.floor_positions_m[floor],
            dir_travel: 1,
            riders: Vec::new(),
            load_kg: 0.0,
            door: false,
            energised: false,
            dir_signal: 0,
            rise_k: 0.09 * p.thermal.rise_full_k,
            stuck_speed: None,
            summary: SimSummary {
                kd_thermal_range: (f64::INFINITY, f64::NEG_INFINITY),
                ..SimSummary::default()
            },
            load_time: 0.0,
            imbalance_time: 0.0,
            door_rng: Rng::new(cfg.seed ^ DOOR_STREAM_SALT),
            outages: {
                let mut o = cfg.outages.clone();
                o.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
                o
            },
            outages_done: Vec::new(),
        }
    }

    /// The outages as they happened, in time order.
    pub(super) fn outages_done(&mut self) -> Vec<OutageTruth> {
        std::mem::take(&mut self.outages_done)
    }

    /// The first outage of `kind` due by now, taken off the list.
    fn take_due(&mut self, kind: OutageKind) -> Option<OutagePlan> {
        let k = self
            .outages
            .iter()
            .position(|o| o.kind == kind && o.start_s <= self.t)?;
        Some(self.outages.remove(k))
    }

    /// Start of the next out-of-service period still to come (∞ when none): idle rests end
    /// there, so the car goes out of service on time.
    fn next_out_of_service(&self) -> f64 {
        self.outages
            .iter()
            .filter(|o| o.kind == OutageKind::OutOfService)
            .map(|o| o.start_s)
            .fold(f64::INFINITY, f64::min)
    }

    /// Out of service: the car stands at its landing, door open or closed (drawn), for the
    /// plan's duration; calls keep arriving and wait (or are dropped).
    fn out_of_service(&mut self, plan: OutagePlan) -> Result<()> {
        let door_open = self.door_rng.chance(0.5);
        let start = self.t;
        self.door = door_open;
        // Calls arriving meanwhile are admitted (or dropped) at the next turn of the loop.
        self.rest(start + plan.duration_s)?;
        self.door = false;
        self.outages_done.push(OutageTruth {
            kind: plan.kind,
            start_s: start,
            end_s: self.t,
            door_open,
            position: format!("landing {}", self.floor + 1),
        });
        Ok(())
    }

    pub(super) fn run(&mut self) -> Result<()> {
        while self.t < self.end {
            self.admit_calls();
            if let Some(plan) = self.take_due(OutageKind::OutOfService) {
                self.out_of_service(plan)?;
                continue;
            }
            if !self.riders.is_empty() {
                let dest = self.next_stop();
                self.travel_to(dest)?;
                self.stop_and_transfer()?;
            } else if let Some(origin) = self.queue.front().map(|c| c.origin) {
                self.travel_to(origin)?;
                self.stop_and_transfer()?;
            } else {
                let until = self
                    .next_call
                    .time
                    .min(self.end)
                    .min(self.next_out_of_service().max(self.t));
                if self.floor != 0 && until - self.t > 300.0 && self.rng.chance(0.5) {
                    self.rest(self.t + 300.0)?;
                    self.travel_to(0)?;
                } else {
                    self.rest(until)?;
                }
            }
        }
        Ok(())
    }

    pub(super) fn finish(&mut self) -> Result<SimSummary> {
        let sink = &mut *self.sink;
        let mut n = 0u64;
        self.logger.flush_all(&mut |r| {
            n += 1;
            sink.raw(r)
        })?;
        self.summary.raw_rows += n;
        self.summary.days = self.cfg.days;
        self.summary.mean_load_ratio_moving = if self.summary.moving_s > 0.0 {
            self.load_time / self.summary.moving_s
        } else {
            0.0
        };
        if self.summary.moving_s > 0.0 {
            self.summary.mean_imbalance_moving_kg = self.imbalance_time / self.summary.moving_s;
        }
        Ok(self.summary.clone())
    }

    fn admit_calls(&mut self) {
        while self.next_call.time <= self.t {
            let call = std::mem::replace(&mut self.next_call, self.traffic.next_call());
            if self.queue.len() < MAX_QUEUE {
                self.queue.push_back(call);
            } else {
                self.summary.dropped_calls += 1;
            }
        }
    }

    /// The nearest rider destination ahead in the travel direction, else the nearest behind.
    fn next_stop(&mut self) -> usize {
        let f = self.floor;
        let ahead = |d: i8| {
            self.riders
                .iter()
                .map(|r| r.0)
                .filter(|&x| if d > 0 { x > f } else { x < f })
                .min_by_key(|&x| x.abs_diff(f))
        };
        match ahead(self.dir_travel) {
            Some(x) => x,
            None => {
                self.dir_travel = -self.dir_travel;
                ahead(self.dir_travel).unwrap_or(f)
            }
        }
    }

    fn rest(&mut self, until: f64) -> Result<()> {
        self.advance(until, Motion::Rest)
    }

    /// Brake lift, S-curve trip, levelling; the car ends level with landing `dest`.
    fn travel_to(&mut self, dest: usize) -> Result<()> {
        if dest == self.floor {
            return Ok(());
        }
        let dir: i8 = if dest > self.floor { 1 } else { -1 };
        self.dir_travel = dir;
        if let Some(plan) = self.take_due(OutageKind::StuckBetweenFloors) {
            return self.stuck_trip(dest, dir, plan);
        }
        self.run_to(self.p.floor_positions_m[dest], dir)?;
        self.floor = dest;
        Ok(())
    }

    /// A trip towards `dest` that stops between the two landings half-way along it, stands
    /// there for the plan's duration (door closed, brake dropped), then a rescue run to the
    /// landing ahead.
    fn stuck_trip(&mut self, dest: usize, dir: i8, plan: OutagePlan) -> Result<()> {
        let from = self.floor;
        // The landing gap (a, b), b one landing ahead of a, half-way from `from` to `dest`.
        let (a, b) = if dir > 0 {
            let a = from + (dest - from - 1) / 2;
            (a, a + 1)
        } else {
            let a = from - (from - dest - 1) / 2;
            (a, a - 1)
        };
        let fl = &self.p.floor_positions_m;
        let between = 0.5 * (fl[a] + fl[b]);
        self.run_to(between, dir)?;
        let start = self.t;
        self.rest(start + plan.duration_s)?;
        let end = self.t;
        let ahead = self.p.floor_positions_m[b];
        self.run_to(ahead, dir)?;
        self.floor = b;
        let (lo, hi) = (a.min(b) + 1, a.max(b) + 1);
        self.outages_done.push(OutageTruth {
            kind: plan.kind,
            start_s: start,
            end_s: end,
            door_open: false,
            position: format!("between landings {lo} and {hi}"),
        });
        Ok(())
    }

    /// Brake lift, S-curve run to position `target` in direction `dir`, levelling.
    fn run_to(&mut self, target: f64, dir: i8) -> Result<()> {
        self.dir_signal = dir;
        self.energised = true;
        let lift = self.rng.uniform(0.5, 1.2);
        self.rest(self.t + lift)?;
        let p = self.p;
        let curve = SCurve::new(
            (target - self.pos).abs(),
            p.rated.rated_speed_mps,
            p.accel_mps2,
            p.jerk_mps3,
        );
        let t0 = self.t;
        self.advance(
            t0 + curve.duration(),
            Motion::Travel {
                curve: &curve,
                t0,
                from: self.pos,
                dir,
            },
        )?;
        self.pos = target;
        self.summary.trips += 1;
        let level = self.rng.uniform(0.3, 0.8);
        self.rest(self.t + level)?;
        self.dir_signal = 0;
        self.energised = false;
        Ok(())
    }

    /// Door cycle: riders for this landing leave, waiting calls going our way board.
    fn stop_and_transfer(&mut self) -> Result<()> {
        self.door = true;
        // × 1 exactly for ideal or unworn doors: the same times as before doors were modelled.
        let opening = self.rng.uniform(1.5, 2.5) * self.cfg.doors.slow_factor(self.t);
        self.rest(self.t + opening)?;
        let here = self.floor;
        let mut k = 0;
        while k < self.riders.len() {
            if self.riders[k].0 == here {
                let (_, m) = self.riders.swap_remove(k);
                let step = self.rng.uniform(0.8, 1.5);
                self.rest(self.t + step)?;
                self.load_kg = (self.load_kg - m).max(0.0);
                if self.riders.is_empty() {
                    self.load_kg = 0.0;
                }
            } else {
                k += 1;
            }
        }
        if self.riders.is_empty() {
            if let Some(c) = self.queue.iter().find(|c| c.origin == here) {
                self.dir_travel = c.direction();
            }
        }
        let mut i = 0;
        while i < self.queue.len() {
            let c = &self.queue[i];
            let room = self.p.rated.rated_load_kg - self.load_kg;
            let mass: f64 = c.riders.iter().map(|r| r.1).sum();
            if c.origin == here && c.direction() == self.dir_travel && mass <= room {
                let call = self
                    .queue
                    .remove(i)
                    .expect("index is below the queue length");
                for r in call.riders {
                    let step = self.rng.uniform(0.8, 1.5);
                    self.rest(self.t + step)?;
                    self.load_kg += r.1;
                    self.riders.push(r);
                    self.summary.riders += 1;
                }
            } else {
                i += 1;
            }
        }
        let open = self.rng.uniform(3.0, 6.0);
        self.rest(self.t + open)?;
        let closing = self.rng.uniform(2.0, 3.5) * self.cfg.doors.slow_factor(self.t);
        self.rest(self.t + closing)?;
        self.door = false;
        self.reopenings()
    }

    /// Reopenings after the door shut (never with ideal doors, which draw nothing here): the
    /// door stays shut 0.5-3 s, opens again, dwells 1-3 s and closes, while the draw says so.
    fn reopenings(&mut self) -> Result<()> {
        if self.cfg.doors.is_ideal() {
            return Ok(());
        }
        let mut n = 0;
        while n < MAX_REOPENINGS
            && self
                .door_rng
                .chance(self.cfg.doors.reopen_probability(self.t))
        {
            n += 1;
            let shut = self.door_rng.uniform(0.5, 3.0);
            self.rest(self.t + shut)?;
            self.door = true;
            let slow = self.cfg.doors.slow_factor(self.t);
            let opening = self.door_rng.uniform(1.5, 2.5) * slow;
            self.rest(self.t + opening)?;
            let dwell = self.door_rng.uniform(1.0, 3.0);
            self.rest(self.t + dwell)?;
            let closing = self.door_rng.uniform(2.0, 3.5) * slow;
            self.rest(self.t + closing)?;
            self.door = false;
        }
        Ok(())
    }

    /// Position, signed velocity and acceleration at `t`.
    fn kin(&self, m: Motion, t: f64) -> (f64, f64, f64) {
        match m {
            Motion::Rest => (self.pos, 0.0, 0.0),
            Motion::Travel {
                curve,
                t0,
                from,
                dir,
            } => {
                let k = curve.at(t - t0);
                let d = f64::from(dir);
                (from + d * k.distance, d * k.speed, d * k.accel)
            }
        }
    }

    /// Advances time to `until` (capped at the end of the run), sampling every sensor and grid
    /// instant on the way. Travel is stepped at 10 Hz for the winding temperature; rest is
    /// one step, its thermal decay taken analytically.
    fn advance(&mut self, until: f64, m: Motion) -> Result<()> {
        let until = until.min(self.end);
        let travelling = matches!(m, Motion::Travel { .. });
        while self.t < until {
            let b = if travelling {
                (self.t + 0.1).min(until)
            } else {
                until
            };
            self.sample_until(b, m)?;
            let dt = b - self.t;
            let target = if travelling {
                let mid = 0.5 * (self.t + b);
                let (x, v, a) = self.kin(m, mid);
                let fx = self.cfg.scenario.effects_at(mid, self.p.f_c);
                self.summary.moving_s += dt;
                self.load_time += dt * self.load_kg / self.p.rated.rated_load_kg;
                self.imbalance_time += dt * self.p.imbalance_kg(x);
                self.p
                    .heating_k(self.p.force(x, v, a, self.load_kg, &fx), true)
            } else {
                0.0
            };
            self.rise_k = target + (self.rise_k - target) * (-dt / self.p.thermal.tau_s).exp();
            self.t = b;
            let sink = &mut *self.sink;
            let mut n = 0u64;
            self.logger.flush_until(b, &mut |r| {
                n += 1;
                sink.raw(r)
            })?;
            self.summary.raw_rows += n;
        }
        Ok(())
    }

    /// Emits, in time order, every raw sample and grid row before `b`.
    fn sample_until(&mut self, b: f64, m: Motion) -> Result<()> {
        loop {
            let mut which = SIMULATED.len();
            let mut tmin = self.next_grid;
            for (k, c) in self.clocks.iter().enumerate() {
                if c.next < tmin {
                    tmin = c.next;
                    which = k;
                }
            }
            if tmin >= b || tmin >= self.end {
                return Ok(());
            }
            if which == SIMULATED.len() {
                self.emit_grid(tmin, m)?;
                self.next_grid += 1.0;
            } else {
                let signal = SIMULATED[which];
                if !self.clocks[which].dropouts.silent(tmin) {
                    let mut rng = std::mem::replace(&mut self.noise_raw, Rng::new(0));
                    let value = self.reading(signal, tmin, m, &mut rng);
                    self.noise_raw = rng;
                    self.logger.push(RawRow {
                        time: tmin,
                        signal,
                        value,
                    });
                }
                self.clocks[which].advance();
            }
        }
    }

    /// Current Kd including the thermal factor and the motor degradation.
    fn kd_at(&self, t: f64, fx: &Effects) -> f64 {
        self.p.kd * self.p.kd_thermal_factor(t, self.rise_k) * fx.kd_factor
    }

    /// One sensor reading at `t`: the plant state `latency` earlier, plus noise and quantisation.
    fn reading(&mut self, signal: Signal, t: f64, m: Motion, rng: &mut Rng) -> f64 {
        let sp = &self.p.sensors;
        let ts = t - sp.latency_s[signal.index()];
        // `+ 0.0` turns a rounded −0 into 0, so files never show `-0.0`.
        let quant = |v: f64, q: f64| (v / q).round() * q + 0.0;
        match signal {
            Signal::Speed => {
                if let Some(f) = &self.cfg.sensor_fault {
                    if f.speed_stuck(t) {
                        let (_, v, _) = self.kin(m, ts);
                        return *self
                            .stuck_speed
                            .get_or_insert(quant(v.abs(), sp.speed_quant_mps));
                    }
                    self.stuck_speed = None;
                }
                let (_, v, _) = self.kin(m, ts);
                if sign(v) == 0 {
                    0.0
                } else {
                    quant(
                        (v.abs() + sp.speed_noise_mps * rng.normal()).max(0.0),
                        sp.speed_quant_mps,
                    )
                }
            }
            Signal::Direction => f64::from(self.dir_signal),
            Signal::Voltage => {
                let (x, v, a) = self.kin(m, ts);
                let fx = self.cfg.scenario.effects_at(ts, self.p.f_c);
                let f = self.p.force(x, v, a, self.load_kg, &fx);
                let kd = self.kd_at(ts, &fx);
                let offset = self
                    .cfg
                    .sensor_fault
                    .as_ref()
                    .map_or(0.0, |f| f.voltage_offset_v(t));
                let u = self
                    .p
                    .drive_voltage((x, v), f, self.load_kg, self.energised, kd)
                    + offset;
                quant(
                    (u + sp.voltage_noise_v * rng.normal()).max(0.0),
                    sp.voltage_quant_v,
                )
            }
            Signal::Load => {
                let (_, _, a) = self.kin(m, ts);
                let drift = self
                    .cfg
                    .sensor_fault
                    .as_ref()
                    .map_or(0.0, |f| f.load_offset_pct(t));
                let l = self.p.load_cell_pct(self.load_kg, a)
                    + drift
                    + sp.load_noise_pct * rng.normal();
                quant(l, sp.load_quant_pct)
            }
            Signal::Door => f64::from(u8::from(self.door)),
            // Not simulated: SIMULATED never yields it.
            Signal::Current => f64::NAN,
            Signal::Floor => {
                let (x, _, _) = self.kin(m, ts);
                let fl = &self.p.floor_positions_m;
                let i = fl.partition_point(|&h| h < x);
                let nearest = if i == 0 {
                    0
                } else if i >= fl.len() || x - fl[i - 1] < fl[i] - x {
                    i - 1
                } else {
                    i
                };
                (nearest + 1) as f64
            }
        }
    }

    /// One grid second: sensor models at the grid instant (silent sensors missing) and truth.
    fn emit_grid(&mut self, t: f64, m: Motion) -> Result<()> {
        let mut rng = std::mem::replace(&mut self.noise_grid, Rng::new(0));
        let mut vals = [f64::NAN; 6];
        for s in SIMULATED {
            let k = s.index();
            if !self.clocks[k].dropouts.silent(t) {
                vals[k] = self.reading(s, t, m, &mut rng);
            }
        }
        self.noise_grid = rng;
        let (x, v, a) = self.kin(m, t);
        let fx = self.cfg.scenario.effects_at(t, self.p.f_c);
        let moving = sign(v) != 0;
        let kd = self.kd_at(t, &fx);
        let force = if moving {
            self.p.force(x, v, a, self.load_kg, &fx)
        } else {
            0.0
        };
        let thermal = self.p.kd_thermal_factor(t, self.rise_k);
        let r = &mut self.summary.kd_thermal_range;
        *r = (r.0.min(thermal), r.1.max(thermal));
        let row = TruthRow {
            sample: Sample {
                time: t,
                speed: vals[0],
                direction: vals[1],
                voltage: vals[2],
                load: vals[3],
                door: vals[4],
                floor: vals[5],
                current: f64::NAN,
            },
            v_true: v,
            accel_true: a,
            pos_true: x,
            load_true: self.load_kg / self.p.rated.rated_load_kg,
            force_true: force,
            voltage_true: self
                .p
                .drive_voltage((x, v), force, self.load_kg, self.energised, kd),
            kd_true: kd,
            severity: fx.severity,
        };
        self.sink.truth(&row)?;
        self.summary.truth_rows += 1;
        if t >= self.next_day {
            (self.progress)((t - self.cfg.start_s) / DAY_S);
            self.next_day += DAY_S;
        }
        Ok(())
    }
}
