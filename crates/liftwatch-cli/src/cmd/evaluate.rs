//! `liftwatch evaluate`: the seeded comparison suite of [`liftwatch::evaluate`] — liftwatch
//! against the fixed-threshold baseline, a CUSUM and an EWMA chart over simulated elevators
//! and degradations (paper, Sec. 5.3-5.4).
//!
//! Prints an aligned table on stdout, progress on stderr, and writes `evaluation.json` (every
//! case, every metric, the calibrations) into `--out`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use liftwatch::evaluate::{run_suite, table, SuiteConfig};

/// Flags of `liftwatch evaluate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created if missing) for `evaluation.json`.
    #[arg(long, default_value = "liftwatch-eval")]
    pub out: PathBuf,
    /// Run the small subset (one elevator, short spans) for tests and CI.
    #[arg(long)]
    pub quick: bool,
    /// Base seed: every simulated plant and run derives its seed from it.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads; the results do not depend on it.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
}

/// Runs `evaluate`.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.threads >= 1, "--threads must be at least 1");
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut cfg = SuiteConfig::new(args.seed, args.quick);
    cfg.threads = args.threads;
    let clock = Instant::now();
    eprintln!(
        "evaluate: {} suite, seed {}, {} thread(s)",
        if args.quick { "quick" } else { "full" },
        args.seed,
        args.threads
    );
    let ev = run_suite(&cfg, &|line| eprintln!("evaluate: {line}")).context("evaluation")?;
    print!("{}", table(&ev));
    let path = args.out.join("evaluation.json");
    let json = serde_json::to_vec_pretty(&ev).context("serialising the evaluation")?;
    liftwatch::output::write_atomic(&path, &json)?;
    eprintln!(
        "evaluate: {} cases in {:.0} s, wrote {}",
        ev.cases.len(),
        clock.elapsed().as_secs_f64(),
        path.display()
    );
    Ok(())
}
