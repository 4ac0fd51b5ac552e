//! `liftwatch serve`: the paper's online-analysis and model-management layers (Sec. 4.3) as one
//! service over the library's pipeline.
//!
//! ```text
//! POST telemetry ─ row parser (ingest) ─ ONE batch in SQLite (WAL), committed ─ 200
//!                                              │
//!                       worker thread ─ per elevator, in seq order: Aligner ─ Monitor::push
//!                                              │
//!             trips, events + checkpoint (aligner state, monitor state, last seq) in ONE transaction
//! GET  elevators, risk, events, models, metrics ─ the store and the worker's snapshots
//! ```
//!
//! The modules: [`config`] the settings, [`store`] the database, [`worker`] the streaming
//! application and checkpoints, [`registry`] the models and maintenance visits, [`api`] the
//! HTTP routes, [`mqtt`] telemetry in and events out through a broker, [`replay`] the client
//! that sends a raw log to a server; [`fleet`] the scale-out mode on NATS JetStream, the same
//! worker step on partitions of one log. The library
//! (`liftwatch`) knows nothing of this crate.

pub mod api;
pub mod config;
pub mod error;
pub mod fleet;
pub mod ingest;
pub mod mqtt;
pub mod registry;
pub mod replay;
pub mod store;
pub mod worker;

use std::collections::HashMap;
use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, RwLock};

use config::Config;
use rusqlite::Connection;
use worker::{Msg, Snapshot};

/// Per-elevator ingest counters, for `/metrics` (since the start of the process).
#[derive(Clone, Copy, Debug, Default)]
pub struct IngestStats {
    /// Requests accepted.
    pub requests: u64,
    /// Good rows stored.
    pub rows: u64,
    /// Bad rows skipped.
    pub bad: u64,
}

/// What the HTTP handlers and the worker share.
pub struct Shared {
    /// Settings.
    pub cfg: Config,
    /// `--data`.
    pub data_dir: PathBuf,
    /// The write token; `None`: writes are refused.
    pub token: Option<String>,
    /// The connection of the API's writes (one writer at a time, as SQLite has it).
    pub writer: Mutex<Connection>,
    /// Idle read connections.
    pub readers: Mutex<Vec<Connection>>,
    /// The worker's snapshots per elevator.
    pub snapshots: RwLock<HashMap<String, Snapshot>>,
    /// Ingest counters per elevator.
    pub ingest: Mutex<HashMap<String, IngestStats>>,
    /// Requests refused (4xx), all routes.
    pub refused: AtomicU64,
    /// False once the worker thread has ended (a panic included): `/healthz` then says 503.
    pub worker_alive: AtomicBool,
    /// To the worker.
    pub worker: Mutex<Sender<Msg>>,
    /// The MQTT client that publishes events, once connected (`mqtt` in the config).
    pub events_mqtt: std::sync::OnceLock<rumqttc::Client>,
}

impl Shared {
    /// Tells the worker about new work for `id`.
    pub fn poke(&self, id: &str) {
        let tx = self
            .worker
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        // A send fails only once the worker stopped, at shutdown: the batch is stored and
        // applied at the next start.
        let _ = tx.send(Msg::Work(id.to_string()));
    }

    /// Runs `f` with a read connection (reused, or opened).
    ///
    /// # Errors
    /// `f`'s error, or the database's.
    pub fn read<T>(&self, f: impl FnOnce(&Connection) -> Result<T, String>) -> Result<T, String> {
        let conn = self
            .readers
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .pop();
        let conn = match conn {
            Some(c) => c,
            None => store::open(&self.data_dir)?,
        };
        let out = f(&conn);
        self.readers
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push(conn);
        out
    }
}

/// Writes one structured log line to stderr: `ts=… level=… msg="…"`.
pub fn log(level: &str, msg: &str) {
    let line = format!(
        "ts={:.3} level={level} msg={}\n",
        store::now(),
        serde_json::to_string(msg).unwrap_or_default()
    );
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}

/// How `serve` was asked to run.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// `--data`: the directory of `liftwatch.db`.
    pub data: PathBuf,
    /// Settings (the config file's, with `--listen` over it).
    pub cfg: Config,
    /// The write token, if any.
    pub token: Option<String>,
}

/// Reads a token file: its first line, trimmed; an empty one is refused.
///
/// # Errors
/// One line naming the file.
pub fn read_token_file(path: &Path) -> Result<String, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let token = text.lines().next().unwrap_or("").trim().to_string();
    if token.is_empty() {
        return Err(format!("{}: the token file is empty", path.display()));
    }
    Ok(token)
}

/// Runs the service until SIGTERM or ctrl-c: opens the store, starts the worker, listens,
/// prints `liftwatch serve: listening on http://ADDR (data DIR)` to stderr, and at the signal
/// stops taking requests, lets the worker write its final checkpoint, and returns.
///
/// # Errors
/// One line: the data directory, the database, the address.
pub fn serve(opts: ServeOptions) -> Result<(), String> {
    std::fs::create_dir_all(&opts.data).map_err(|e| {
        format!(
            "{}: cannot create the data directory: {e}",
            opts.data.display()
        )
    })?;
    let writer = store::open(&opts.data)?;
    let interrupted = store::fail_interrupted_fits(&writer).map_err(|e| e.to_string())?;
    if interrupted > 0 {
        log(
            "warn",
            &format!("{interrupted} fits were interrupted by the last stop: marked failed"),
        );
    }
    for e in &opts.cfg.elevators {
        let id = e.id.clone().unwrap_or_default();
        let mut info = e.clone();
        info.id = None;
        let json = serde_json::to_string(&info).map_err(|e| e.to_string())?;
        store::put_elevator(&writer, &id, &json).map_err(|e| e.to_string())?;
    }
    let worker_conn = store::open(&opts.data)?;
    let (tx, rx) = std::sync::mpsc::channel();
    let shared = Arc::new(Shared {
        cfg: opts.cfg.clone(),
        data_dir: opts.data.clone(),
        token: opts.token.clone(),
        writer: Mutex::new(writer),
        readers: Mutex::new(Vec::new()),
        snapshots: RwLock::new(HashMap::new()),
        ingest: Mutex::new(HashMap::new()),
        refused: AtomicU64::new(0),
        worker_alive: AtomicBool::new(true),
        worker: Mutex::new(tx.clone()),
        events_mqtt: std::sync::OnceLock::new(),
    });
    if let Some(url) = &opts.cfg.mqtt {
        let broker = config::Broker::parse(url).map_err(|e| format!("--mqtt {e}"))?;
        let client = mqtt::start(shared.clone(), &broker, &opts.cfg.mqtt_client_id)?;
        let _ = shared.events_mqtt.set(client);
        log(
            "info",
            &format!(
                "mqtt: taking telemetry from {} on {}",
                broker.display(),
                mqtt::TELEMETRY_FILTER
            ),
        );
    }
    let worker_shared = shared.clone();
    let worker = std::thread::Builder::new()
        .name("liftwatch-worker".into())
        .spawn(move || worker::run(worker_conn, worker_shared, rx))
        .map_err(|e| format!("cannot start the worker: {e}"))?;
    let addr: SocketAddr = opts
        .cfg
        .listen
        .parse()
        .map_err(|_| format!("--listen `{}` is not an address:port", opts.cfg.listen))?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| format!("cannot start the runtime: {e}"))?;
    let result = rt.block_on(async {
        let listener = tokio::net::TcpListener::bind(addr)
            .await
            .map_err(|e| format!("cannot listen on {addr}: {e}"))?;
        let local = listener.local_addr().map_err(|e| e.to_string())?;
        eprintln!(
            "liftwatch serve: listening on http://{local} (data {})",
            opts.data.display()
        );
        if shared.token.is_none() {
            log("warn", "no token (--token-file or LIFTWATCH_TOKEN): writes are refused, the service is read-only");
        }
        let app = api::router(shared.clone());
        let signalled = Arc::new(tokio::sync::Notify::new());
        let notify = signalled.clone();
        let server = axum::serve(listener, app).with_graceful_shutdown(async move {
            shutdown_signal().await;
            notify.notify_one();
        });
        // Graceful, but not waiting on a client: a connection that sent half a request header
        // held the final checkpoint for hyper's header timeout, past the grace a supervisor
        // gives (docker's 10 s, then SIGKILL).
        tokio::select! {
            r = std::future::IntoFuture::into_future(server) => r.map_err(|e| format!("server: {e}")),
            () = async {
                signalled.notified().await;
                tokio::time::sleep(SHUTDOWN_GRACE).await;
            } => {
                log("warn", &format!("connections still open {} s after the signal: closed", SHUTDOWN_GRACE.as_secs()));
                Ok(())
            }
        }
    });
    log("info", "shutting down: final checkpoint");
    let _ = tx.send(Msg::Stop);
    drop(tx);
    let _ = worker.join();
    result
}

/// How long requests under way may take to finish after SIGTERM or ctrl-c before their
/// connections are closed and the final checkpoint is written: an ingest of the largest
/// batch takes well under a second; a client that has not sent its request by then gets no
/// answer (and resends: nothing unanswered was confirmed).
const SHUTDOWN_GRACE: std::time::Duration = std::time::Duration::from_secs(5);

/// Resolves at SIGTERM or ctrl-c.
pub(crate) async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {},
        () = term => {},
    }
}
