//! `liftwatch serve`: the service of `liftwatch_serve` (README, *Service*): ingest, online
//! monitor, store, model registry, API. Runs until SIGTERM or ctrl-c.

use std::path::PathBuf;

use liftwatch_serve::config::Config;
use liftwatch_serve::{read_token_file, serve, ServeOptions};

/// Environment variable holding the write token (also read by `replay`).
pub const TOKEN_ENV: &str = "LIFTWATCH_TOKEN";

/// Flags of `liftwatch serve`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Data directory: the store `liftwatch.db` (created if missing); else the config's `data`.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Address to listen on (port 0: a free one, printed); default the config's, else
    /// 127.0.0.1:8080.
    #[arg(long)]
    pub listen: Option<String>,
    /// File whose first line is the write token (else LIFTWATCH_TOKEN; without either, the
    /// service is read-only).
    #[arg(long = "token-file")]
    pub token_file: Option<PathBuf>,
    /// Config file (TOML): listen, reorder window, checkpoints, limits, elevators.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// MQTT broker to take telemetry from (`liftwatch/{id}/telemetry`) and publish events to
    /// (`liftwatch/{id}/events`): `mqtt://[user:password@]host[:port]` (over the config's).
    #[arg(long)]
    pub mqtt: Option<String>,
    /// NATS servers (nats://host:port[,…]): run as a worker of the fleet mode on JetStream
    /// instead of the embedded store (over the config's `nats`); `--data` is not used then.
    #[arg(long)]
    pub nats: Option<String>,
    /// Days raw telemetry batches are kept for fitting from history (over the config's).
    #[arg(long = "keep-raw-days")]
    pub keep_raw_days: Option<f64>,
}

/// The token from `--token-file`, else the environment.
pub fn token(file: Option<&PathBuf>) -> anyhow::Result<Option<String>> {
    if let Some(p) = file {
        return Ok(Some(read_token_file(p).map_err(anyhow::Error::msg)?));
    }
    Ok(std::env::var(TOKEN_ENV)
        .ok()
        .map(|t| t.trim().to_string())
        .filter(|t| !t.is_empty()))
}

/// Runs `serve`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut cfg = match &args.config {
        Some(p) => Config::load(p).map_err(anyhow::Error::msg)?,
        None => Config::default(),
    };
    if let Some(l) = args.listen {
        cfg.listen = l;
    }
    if let Some(m) = args.mqtt {
        cfg.mqtt = Some(m);
    }
    if let Some(d) = args.keep_raw_days {
        cfg.keep_raw_days = d;
    }
    if let Some(n) = args.nats {
        cfg.nats = Some(n);
    }
    cfg.validate().map_err(anyhow::Error::msg)?;
    if cfg.nats.is_some() {
        let token = token(args.token_file.as_ref())?;
        return liftwatch_serve::fleet::serve(cfg, token).map_err(anyhow::Error::msg);
    }
    let Some(data) = args.data.or_else(|| cfg.data.clone()) else {
        anyhow::bail!("--data DIR is required (or `data` in the --config file)");
    };
    let token = token(args.token_file.as_ref())?;
    serve(ServeOptions { data, cfg, token }).map_err(anyhow::Error::msg)
}
