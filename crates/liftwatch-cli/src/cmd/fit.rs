//! `liftwatch fit`: healthy telemetry → features → hybrid model → calibrated risk → model file.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use liftwatch::align::{read_series, AlignConfig};
use liftwatch::model::train::{Optimizer, TrainPoint};
use liftwatch::model::TrainConfig;
use liftwatch::Elevator;
use liftwatch::{file, fit};

/// Flags of `liftwatch fit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Healthy telemetry, raw or aligned.
    #[arg(long)]
    pub input: PathBuf,
    /// Elevator description (TOML).
    #[arg(long)]
    pub elevator: PathBuf,
    /// Where to write the model (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Optimiser of the hybrid stage: lbfgs (default) or adam (the paper's schedule).
    #[arg(long, value_enum, default_value_t = OptimizerArg::Lbfgs)]
    pub optimizer: OptimizerArg,
    /// Iterations of the hybrid stage (L-BFGS iterations or Adam epochs; default 1500 or 20000).
    #[arg(long)]
    pub epochs: Option<usize>,
    /// Adam's learning rate.
    #[arg(long, default_value_t = 1e-3)]
    pub learning_rate: f64,
    /// Seed of the network's initial weights.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Alignment step (s) for raw input.
    #[arg(long, default_value_t = 1.0)]
    pub step: f64,
    /// Print no progress lines.
    #[arg(long)]
    pub quiet: bool,
}

/// The optimiser choice on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum OptimizerArg {
    /// Gauss-Newton on the physics, then L-BFGS on the hybrid model.
    Lbfgs,
    /// Adam on everything from the prior, full batch (the paper).
    Adam,
}

/// Runs `fit`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let elevator = Elevator::from_toml_file(&args.elevator)?;
    let align = AlignConfig::default().with_step(args.step)?;
    let (series, report) = read_series(&args.input, &align)?;
    if let Some(w) = report.warning() {
        eprintln!("warning: {w}");
    }
    let (optimizer, epochs) = match args.optimizer {
        OptimizerArg::Lbfgs => (
            Optimizer::Lbfgs,
            args.epochs.unwrap_or(TrainConfig::default().epochs),
        ),
        OptimizerArg::Adam => (Optimizer::Adam, args.epochs.unwrap_or(20_000)),
    };
    let cfg = TrainConfig {
        optimizer,
        epochs,
        learning_rate: args.learning_rate,
        seed: args.seed,
        log_every: if optimizer == Optimizer::Adam {
            1000
        } else {
            50
        },
        ..TrainConfig::default()
    };
    eprintln!(
        "fit: {} samples ({:.1} h) from {}",
        series.len(),
        series.duration_s() / 3600.0,
        args.input.display()
    );
    let started = Instant::now();
    let quiet = args.quiet;
    let mut progress = |p: &TrainPoint| {
        if !quiet {
            eprintln!(
                "  stage {} iteration {:>5}  loss {:.4e}  rms r_U {:.2} V  rms r_F {:.0} N",
                p.stage, p.iteration, p.loss, p.rms_u_v, p.rms_f_n
            );
        }
    };
    let outcome = fit::fit(&series, &elevator, &cfg, &mut progress)
        .with_context(|| format!("fitting {}", args.input.display()))?;
    let seconds = started.elapsed().as_secs_f64();
    file::save(&args.out, &outcome.model)?;
    print!(
        "{}",
        summary(&outcome.model, outcome.features.trips.len(), seconds)
    );
    println!("wrote {}", args.out.display());
    Ok(())
}

/// The on-screen summary of a fit: parameters with standard errors, warnings, calibration.
pub fn summary(m: &fit::FittedModel, trips: usize, seconds: f64) -> String {
    use std::fmt::Write;
    let f = &m.summary;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "fitted in {seconds:.2} s: {} moving samples in {trips} trips, {} standstill; rms r_U {:.2} V, rms r_F {:.0} N",
        f.moving_samples, f.standstill_samples, f.rms_u_v, f.rms_f_n
    );
    let _ = writeln!(
        s,
        "{:<27} {:>12} {:>11}  {:<6} decided by",
        "parameter", "value", "std error", "unit"
    );
    for r in &f.parameters {
        let se = r
            .std_error
            .map_or_else(|| "n/a".to_string(), |v| format!("{v:.5}"));
        let _ = writeln!(
            s,
            "{:<27} {:>12.5} {:>11}  {:<6} {}",
            r.name,
            r.value,
            se,
            r.unit,
            if r.determined {
                "data"
            } else {
                "prior (weakly identifiable)"
            }
        );
    }
    for w in &f.warnings {
        let _ = writeln!(s, "note: {w}");
    }
    let _ = writeln!(
        s,
        "healthy scales: σ_U {:.2} V, σ_F {:.0} N; risk thresholds: advisory {:.3}, alarm {:.3}",
        m.hybrid.scales.sigma_u_v, m.hybrid.scales.sigma_f_n, m.risk.advisory, m.risk.alarm
    );
    s
}
