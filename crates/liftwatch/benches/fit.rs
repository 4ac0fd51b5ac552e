//! Fit benchmark: the paper's data size, 3 h at 1 Hz (10,800 samples), on one core.
//!
//! Compares liftwatch's fit with one draw of the network (Gauss-Newton on the physics, then
//! L-BFGS on the network, θ held) with its Adam option run as the paper trains (20,000
//! full-batch epochs from the prior): wall time and the RMS of the voltage residual each
//! reaches. Then the default fit, two draws of the network each on a thread of its own, the
//! better kept: its wall time on this machine's cores.
//!
//! Run: `cargo bench -p liftwatch --bench fit` (`FIT_BENCH_ADAM_EPOCHS=2000` for a quick look,
//! `FIT_BENCH_LBFGS_ITERS=N` to change the L-BFGS iteration cap).

use liftwatch::sample::HOUR_S;
use std::time::Instant;

use liftwatch::features::{extract, fit_load_cell, FeatureConfig};
use liftwatch::model::train::{observations_weighted, train, Optimizer, INTERPOLATION_NOISE_SHARE};
use liftwatch::model::{PhysParams, TrainConfig};
use liftwatch::sim::{simulate, SimConfig};
use liftwatch::Elevator;

fn main() {
    let elevator = Elevator::new(1000.0, 1.75, 26);
    let mut sim = SimConfig::new(elevator.clone(), 0.125, 7);
    sim.start_s = 8.0 * HOUR_S; // 08:00-11:00, morning traffic as in the paper's recording
    let out = simulate(&sim).expect("the benchmark's settings are valid");
    let series = out.aligned();
    let fcfg =
        fit_load_cell(&series, &FeatureConfig::for_elevator(&elevator)).expect("enough motion");
    let feats = extract(&series, &fcfg);
    let prior = PhysParams::prior_centre(&elevator);
    let o = observations_weighted(
        &feats.rows,
        elevator.floors,
        0.1,
        prior.ke,
        INTERPOLATION_NOISE_SHARE * elevator.rated_voltage(),
    )
    .expect("enough motion");
    let (moving, rest) = (o.moving, o.standstill);
    println!(
        "data: {} samples, {} trips, {moving} moving samples, {rest} standstill ({} observations after grouping)",
        series.len(),
        feats.trips.len(),
        o.obs.len()
    );

    let iters = std::env::var("FIT_BENCH_LBFGS_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(TrainConfig::default().epochs);
    let lbfgs = TrainConfig {
        epochs: iters,
        draws: 1,
        log_every: 0,
        ..TrainConfig::default()
    };
    let median5 = |cfg: &TrainConfig| {
        let mut times = Vec::new();
        let mut fit = None;
        for _ in 0..5 {
            let t = Instant::now();
            fit = Some(train(&o, &elevator, cfg, &mut |_| {}).expect("fit"));
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        (times[2], fit.expect("ran five times"))
    };
    let (one_draw, fit) = median5(&lbfgs);
    println!(
        "gauss-newton + l-bfgs, one draw ({} iterations): median {:.3} s of 5 runs, rms r_U {:.3} V, loss {:.4e}",
        fit.summary.iterations, one_draw, fit.summary.rms_u_v, fit.summary.loss_final
    );
    let default = TrainConfig {
        draws: TrainConfig::default().draws,
        ..lbfgs.clone()
    };
    let (both, best) = median5(&default);
    println!(
        "the same, {} draws on threads of their own (the default): median {:.3} s of 5 runs ({:.2}x one draw), rms r_U {:.3} V, loss {:.4e}",
        default.draws,
        both,
        both / one_draw,
        best.summary.rms_u_v,
        best.summary.loss_final
    );

    let epochs = std::env::var("FIT_BENCH_ADAM_EPOCHS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_000);
    let adam = TrainConfig {
        optimizer: Optimizer::Adam,
        epochs,
        log_every: 0,
        ..TrainConfig::default()
    };
    let t = Instant::now();
    let a = train(&o, &elevator, &adam, &mut |_| {}).expect("fit");
    let ta = t.elapsed().as_secs_f64();
    println!(
        "adam ({epochs} epochs from the prior): {ta:.3} s, rms r_U {:.3} V, loss {:.4e}",
        a.summary.rms_u_v, a.summary.loss_final
    );
    println!(
        "speed-up {:.1}x; rms ratio l-bfgs/adam {:.3}",
        ta / one_draw,
        fit.summary.rms_u_v / a.summary.rms_u_v
    );
    // Kd drifts with winding temperature: the truth to compare with is its mean while moving.
    let moving: Vec<f64> = out
        .rows
        .iter()
        .filter(|r| r.v_true.abs() > 0.05)
        .map(|r| r.kd_true)
        .collect();
    let kd_mean = moving.iter().sum::<f64>() / moving.len() as f64;
    let stage1 = fit.summary.history.first().map_or(f64::NAN, |p| p.theta[4]);
    println!("kd: truth (mean while moving) {kd_mean:.5}, physics stage {stage1:.5}, l-bfgs {:.5}, adam {:.5}", fit.parameters.kd, a.parameters.kd);
    println!(
        "truth {:?}\nlbfgs {:?}\nadam {:?}",
        out.truth.parameters, fit.parameters, a.parameters
    );
}
