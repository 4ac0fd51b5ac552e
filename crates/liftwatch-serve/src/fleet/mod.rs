//! The fleet mode, `liftwatch serve --nats URL`: N workers share the partitions of one
//! JetStream log, each running the embedded worker's step ([`Feed`]) on the elevators of the
//! partitions it holds.
//!
//! ```text
//! gateways ─ NATS liftwatch.telemetry.{id} / MQTT liftwatch/{id}/telemetry
//!     ─ server mapping {{partition(P,1)}} ─ stream LIFTWATCH_TELEMETRY, subjects liftwatch.part.{p}.{id}
//! worker: lease part.{p} (KV, compare-and-swap) ─ consumer part-{p} from its committed floor
//!     ─ per record, per elevator in stream order: seq ≤ checkpoint seq → skipped (replay)
//!                                                else parse → Aligner → Monitor (one Feed)
//!     ─ every checkpoint_every_s: outputs published (Nats-Msg-Id {id}:r|e:{seq}:{k}, stored)
//!       → checkpoints written (KV, revision CAS) → partition committed (ack all)
//! ```
//!
//! Outputs, then states, then the commit: a worker killed anywhere leaves checkpoints whose
//! seqs cover exactly the outputs stored before them; the next owner resumes each elevator from
//! its checkpoint and replays the rest of the partition, its outputs carrying the same message
//! ids, which the stream stores once. A worker that lost a lease (stalled longer than it) finds
//! the checkpoint revision moved on, and drops the partition without writing.
//!
//! Ownership: every worker renews its heartbeat and leases every third of `nats_lease_s` (a
//! task of its own, so a long turn never lets a lease lapse), and
//! holds ⌈P / live workers⌉ partitions at most: a joining worker makes the others give the
//! surplus up, a dead one's leases expire and the others take them over.
//!
//! Models: `active.{id}` of the models bucket names the digest of the active model; a change is
//! watched and taken between two records, as the embedded worker takes an activation: the
//! monitor restarts from a fresh state of the new model, the aligner goes on. Maintenance
//! visits (re-baselines) are not carried in this mode.

pub mod bus;
pub mod gateway;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::extract::{Path as UrlPath, State};
use axum::http::{HeaderMap, StatusCode};
use axum::routing::{get, post};
use bytes::Bytes;
use futures_util::StreamExt;
use liftwatch::align::{AlignConfig, Aligner};
use liftwatch::fit::FittedModel;
use liftwatch::monitor::{Method, Monitor};
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::config::{valid_id, Config};
use crate::worker::{Counters, EventOut, Feed, TripOut};
use crate::{log, registry};
use bus::{Bus, Output, Position};

/// Most records fetched from one partition in one turn.
const FETCH_MAX: usize = 256;

/// Longest wait of a fetch on a partition with nothing new.
const FETCH_WAIT: Duration = Duration::from_millis(50);

/// Pause before the models' watch is made again after it could not be made or ended: short
/// against the seconds a takeover takes, long enough not to load a cluster that is electing.
const WATCH_RETRY: Duration = Duration::from_secs(2);

/// One elevator's checkpoint in the state bucket: the same states the embedded worker stores,
/// and the stream sequence they cover.
#[derive(Serialize, Deserialize)]
struct Checkpoint {
    /// The last telemetry stream sequence applied.
    seq: u64,
    /// Digest and version of the model the monitor runs.
    model: Option<(String, u64)>,
    /// The aligner (with the readings it holds back).
    aligner: Aligner,
    /// The monitor state, JSON as the embedded checkpoint has it.
    monitor: Option<String>,
    /// The worker's counters.
    counters: Counters,
}

/// One elevator's running pipeline.
struct Elevator {
    partition: u32,
    aligner: Aligner,
    monitor: Option<Monitor>,
    model: Option<(String, u64)>,
    counters: Counters,
    applied_seq: u64,
    state_rev: Option<u64>,
    trips: Vec<TripOut>,
    events: Vec<EventOut>,
    dirty: bool,
}

/// The leases this worker holds (partition → revision), renewed by their own task so that a
/// long turn of the worker never lets one expire; a lost one is reported in `lost`.
#[derive(Default)]
struct Leases {
    held: tokio::sync::Mutex<HashMap<u32, u64>>,
    lost: Mutex<Vec<u32>>,
}

impl Elevator {
    /// An elevator seen for the first time: nothing applied, no model yet.
    fn fresh(partition: u32, aligner: Aligner) -> Elevator {
        Elevator {
            partition,
            aligner,
            monitor: None,
            model: None,
            counters: Counters::new(),
            applied_seq: 0,
            state_rev: None,
            trips: Vec::new(),
            events: Vec::new(),
            dirty: false,
        }
    }
}

/// A partition this worker holds.
struct Part {
    consumer: bus::Partition,
    /// The last delivery number applied on this consumer.
    delivered: u64,
    last: Option<Position>,
    ids: HashSet<String>,
}

/// What `/healthz` shows of the worker.
#[derive(Default)]
struct Stats {
    records: AtomicU64,
    skipped: AtomicU64,
    refused: AtomicU64,
    samples_elevators: AtomicU64,
    partitions: Mutex<Vec<u32>>,
}

/// What the HTTP handlers share.
struct Http {
    bus: Arc<Bus>,
    token: Option<String>,
    worker: String,
    stats: Arc<Stats>,
    max_body: usize,
}

/// The worker.
struct Fleet {
    bus: Arc<Bus>,
    cfg: Config,
    name: String,
    parts: BTreeMap<u32, Part>,
    elevators: HashMap<String, Elevator>,
    models: HashMap<String, Arc<FittedModel>>,
    active: Arc<Mutex<HashMap<String, (String, u64)>>>,
    leases: Arc<Leases>,
    stats: Arc<Stats>,
}

/// Runs the fleet worker until SIGTERM or ctrl-c: connects, listens on `cfg.listen` (health,
/// model upload), prints `liftwatch serve: listening on http://ADDR (nats URL)` to stderr, and
/// at the signal checkpoints and gives its partitions up.
///
/// # Errors
/// One line: the servers, the address, the runtime.
pub fn serve(cfg: Config, token: Option<String>) -> Result<(), String> {
    let urls = cfg.nats.clone().ok_or("the fleet mode needs nats")?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| format!("cannot start the runtime: {e}"))?;
    rt.block_on(async move {
        let name = format!(
            "w{}-{}",
            std::process::id(),
            crate::store::now().to_bits() % 1_000_000
        );
        let bus = Arc::new(
            Bus::connect(
                &urls,
                &name,
                cfg.nats_replicas,
                cfg.nats_lease_s,
                cfg.keep_raw_days,
            )
            .await?,
        );
        let stats = Arc::new(Stats::default());
        let addr: std::net::SocketAddr = cfg
            .listen
            .parse()
            .map_err(|_| format!("--listen `{}` is not an address:port", cfg.listen))?;
        let listener = tokio::net::TcpListener::bind(addr)
            .await
            .map_err(|e| format!("cannot listen on {addr}: {e}"))?;
        let local = listener.local_addr().map_err(|e| e.to_string())?;
        let app = axum::Router::new()
            .route("/healthz", get(healthz))
            .route("/api/v1/elevators/{id}/models", post(upload))
            .with_state(Arc::new(Http {
                bus: bus.clone(),
                token,
                worker: name.clone(),
                stats: stats.clone(),
                max_body: cfg.max_body_bytes,
            }))
            .layer(axum::extract::DefaultBodyLimit::max(cfg.max_body_bytes));
        tokio::spawn(async move {
            let _ = axum::serve(listener, app).await;
        });
        eprintln!("liftwatch serve: listening on http://{local} (nats {urls}, worker {name})");
        let mut fleet = Fleet {
            bus,
            cfg,
            name,
            parts: BTreeMap::new(),
            elevators: HashMap::new(),
            models: HashMap::new(),
            active: Arc::new(Mutex::new(HashMap::new())),
            leases: Arc::new(Leases::default()),
            stats,
        };
        fleet.run().await
    })
}

async fn healthz(State(h): State<Arc<Http>>) -> axum::Json<serde_json::Value> {
    let s = &h.stats;
    axum::Json(json!({
        "mode": "nats",
        "worker": h.worker,
        "partitions": *s.partitions.lock().unwrap_or_else(std::sync::PoisonError::into_inner),
        "elevators": s.samples_elevators.load(Ordering::Relaxed),
        "records": s.records.load(Ordering::Relaxed),
        "records_replayed": s.skipped.load(Ordering::Relaxed),
        "records_refused": s.refused.load(Ordering::Relaxed),
    }))
}

/// `POST /api/v1/elevators/{id}/models`: stores the model file and activates it.
async fn upload(
    State(h): State<Arc<Http>>,
    UrlPath(id): UrlPath<String>,
    headers: HeaderMap,
    body: Bytes,
) -> (StatusCode, axum::Json<serde_json::Value>) {
    let err = |c: StatusCode, m: String| (c, axum::Json(json!({ "error": m })));
    let given = headers
        .get("authorization")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    match (&h.token, given) {
        (Some(t), Some(g)) if t == g => {}
        (None, _) => {
            return err(
                StatusCode::FORBIDDEN,
                "this service is read-only (no token)".into(),
            )
        }
        _ => return err(StatusCode::UNAUTHORIZED, "a write needs the token".into()),
    }
    if !valid_id(&id) {
        return err(
            StatusCode::BAD_REQUEST,
            "elevator id is not [A-Za-z0-9_-]{1,64}".into(),
        );
    }
    if body.len() > h.max_body {
        return err(
            StatusCode::PAYLOAD_TOO_LARGE,
            "model larger than max_body_bytes".into(),
        );
    }
    if let Err(e) = liftwatch::file::load_str(
        &String::from_utf8_lossy(&body),
        std::path::Path::new("request body"),
    ) {
        return err(StatusCode::BAD_REQUEST, e.to_string());
    }
    match h.bus.put_model(&id, &body).await {
        Ok(v) => (
            StatusCode::CREATED,
            axum::Json(json!({ "version": v, "digest": bus::digest(&body), "active": true })),
        ),
        Err(e) => err(StatusCode::SERVICE_UNAVAILABLE, e),
    }
}

impl Fleet {
    async fn run(&mut self) -> Result<(), String> {
        tokio::spawn(follow_models(self.bus.clone(), self.active.clone()));
        let mut stop = Box::pin(crate::shutdown_signal());
        let tick = Duration::from_secs_f64(self.cfg.nats_lease_s / 3.0);
        tokio::spawn(renew(
            self.bus.clone(),
            self.name.clone(),
            self.leases.clone(),
            tick,
        ));
        let every = Duration::from_secs_f64(self.cfg.checkpoint_every_s);
        let (mut last_tick, mut last_ckpt) = (Instant::now() - tick, Instant::now());
        loop {
            let lost: Vec<u32> = std::mem::take(
                &mut *self
                    .leases
                    .lost
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner),
            );
            for p in lost {
                log("warn", &format!("partition {p}: lease lost; dropped"));
                self.lose(p);
            }
            if last_tick.elapsed() >= tick {
                last_tick = Instant::now();
                if let Err(e) = self.ownership().await {
                    log("warn", &format!("leases: {e}"));
                }
            }
            let mut got = 0;
            let ps: Vec<u32> = self.parts.keys().copied().collect();
            for p in ps {
                tokio::select! {
                    r = self.turn(p) => match r {
                        Ok(n) => got += n,
                        Err(e) => {
                            log("warn", &format!("partition {p}: {e}; given up, to be taken anew"));
                            self.give_up(p).await;
                        }
                    },
                    () = &mut stop => {
                        self.finish().await;
                        return Ok(());
                    }
                }
            }
            if last_ckpt.elapsed() >= every {
                last_ckpt = Instant::now();
                for p in self.parts.keys().copied().collect::<Vec<_>>() {
                    self.checkpoint(p).await;
                }
            }
            if got == 0 {
                tokio::select! {
                    () = tokio::time::sleep(FETCH_WAIT) => {},
                    () = &mut stop => {
                        self.finish().await;
                        return Ok(());
                    }
                }
            }
        }
    }

    /// Final checkpoints; the leases are given up.
    async fn finish(&mut self) {
        log(
            "info",
            "shutting down: final checkpoint, partitions given up",
        );
        for p in self.parts.keys().copied().collect::<Vec<_>>() {
            self.checkpoint(p).await;
            self.give_up(p).await;
        }
        self.bus.flush().await;
    }

    /// Gives partition `p` up: its lease is released (if still held), its elevators forgotten.
    async fn give_up(&mut self, p: u32) {
        let rev = self.leases.held.lock().await.remove(&p);
        if let Some(rev) = rev {
            self.bus.release(p, rev).await;
        }
        self.lose(p);
    }

    /// The fair share: give the surplus up, take free partitions.
    async fn ownership(&mut self) -> Result<(), String> {
        self.bus.heartbeat(&self.name).await?;
        let (workers, taken) = self.bus.members(self.cfg.nats_partitions).await?;
        let parts = self.cfg.nats_partitions;
        let share = parts.div_ceil(workers.len().max(1) as u32) as usize;
        while self.parts.len() > share {
            let p = *self.parts.keys().next_back().expect("more than the share");
            self.checkpoint(p).await;
            self.give_up(p).await;
            log(
                "info",
                &format!("partition {p}: given up ({} workers)", workers.len()),
            );
        }
        let taken: HashSet<u32> = taken.into_iter().collect();
        for p in 0..parts {
            if self.parts.len() >= share {
                break;
            }
            if taken.contains(&p) || self.parts.contains_key(&p) {
                continue;
            }
            let t0 = Instant::now();
            let Some(rev) = self.bus.acquire(p, &self.name).await? else {
                continue;
            };
            self.leases.held.lock().await.insert(p, rev);
            let consumer = match self.bus.open(p).await {
                Ok(c) => c,
                Err(e) => {
                    self.give_up(p).await;
                    return Err(e);
                }
            };
            self.parts.insert(
                p,
                Part {
                    consumer,
                    delivered: 0,
                    last: None,
                    ids: HashSet::new(),
                },
            );
            log(
                "info",
                &format!(
                    "partition {p}: taken in {:.0} ms",
                    t0.elapsed().as_secs_f64() * 1e3
                ),
            );
        }
        *self
            .stats
            .partitions
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) =
            self.parts.keys().copied().collect();
        Ok(())
    }

    /// Forgets partition `p` without writing anything (its lease is gone, or given up after its
    /// checkpoint): its next owner resumes from the checkpoints.
    fn lose(&mut self, p: u32) {
        if let Some(part) = self.parts.remove(&p) {
            self.drop_elevators(&part);
        }
    }

    fn drop_elevators(&mut self, part: &Part) {
        for id in &part.ids {
            self.elevators.remove(id);
        }
        self.stats
            .samples_elevators
            .store(self.elevators.len() as u64, Ordering::Relaxed);
    }

    /// Fetches and applies one batch of partition `p`: the number of records.
    async fn turn(&mut self, p: u32) -> Result<usize, String> {
        let recs = {
            let part = &self.parts[&p];
            self.bus
                .fetch(&part.consumer, FETCH_MAX, FETCH_WAIT)
                .await?
        };
        let n = recs.len();
        for rec in recs {
            let expected = self.parts[&p].delivered + 1;
            if rec.delivery != expected {
                // A delivery went missing: nothing after it may be applied or committed. The
                // partition is read again from its committed floor; the elevators keep their
                // state and skip what they already applied.
                log(
                    "warn",
                    &format!("partition {p}: delivery {} came instead of {expected}; read again from the committed floor", rec.delivery),
                );
                let consumer = self.bus.open(p).await?;
                let part = self.parts.get_mut(&p).expect("held");
                part.consumer = consumer;
                part.delivered = 0;
                part.last = None;
                return Ok(n);
            }
            self.parts.get_mut(&p).expect("held").delivered = rec.delivery;
            if !self.elevators.contains_key(&rec.id) {
                self.load(p, &rec.id).await?;
                self.parts
                    .get_mut(&p)
                    .expect("held")
                    .ids
                    .insert(rec.id.clone());
            }
            self.switch_model(&rec.id).await?;
            self.stats.records.fetch_add(1, Ordering::Relaxed);
            let e = self.elevators.get_mut(&rec.id).expect("loaded above");
            if rec.seq <= e.applied_seq {
                self.stats.skipped.fetch_add(1, Ordering::Relaxed);
            } else {
                let ndjson = rec
                    .body
                    .iter()
                    .find(|b| !b.is_ascii_whitespace())
                    .is_some_and(|&b| b == b'{');
                match registry::parse_telemetry(&rec.body, ndjson, self.cfg.max_rows_per_request) {
                    Ok(parsed) => {
                        let mut feed = Feed {
                            monitor: e.monitor.as_mut(),
                            counters: &mut e.counters,
                            trips: &mut e.trips,
                            events: &mut e.events,
                            seq: rec.seq as i64,
                        };
                        feed.apply(&mut e.aligner, &parsed.readings)
                            .map_err(|why| format!("elevator {}: {why}", rec.id))?;
                    }
                    Err(why) => {
                        self.stats.refused.fetch_add(1, Ordering::Relaxed);
                        log(
                            "warn",
                            &format!("elevator {}: record {} refused: {}", rec.id, rec.seq, why.1),
                        );
                    }
                }
                e.applied_seq = rec.seq;
                e.dirty = true;
            }
            self.parts.get_mut(&p).expect("held").last = Some(rec.position);
        }
        Ok(n)
    }

    /// The model file of digest `d`, parsed once.
    async fn model(&mut self, d: &str) -> Result<Arc<FittedModel>, String> {
        if let Some(m) = self.models.get(d) {
            return Ok(m.clone());
        }
        let body = self.bus.model_body(d).await?;
        let m = liftwatch::file::load_str(
            &String::from_utf8_lossy(&body),
            std::path::Path::new("stored model"),
        )
        .map_err(|e| e.to_string())?;
        let m = Arc::new(m);
        self.models.insert(d.to_string(), m.clone());
        Ok(m)
    }

    /// Loads elevator `id` of partition `p` from its checkpoint, or fresh.
    async fn load(&mut self, p: u32, id: &str) -> Result<(), String> {
        let e = match self.bus.load_state(id).await? {
            None => Elevator::fresh(
                p,
                Aligner::new(
                    &AlignConfig::default()
                        .with_reorder_window(self.cfg.reorder_window_s)
                        .map_err(|e| e.to_string())?,
                )
                .map_err(|e| e.to_string())?,
            ),
            Some((rev, bytes)) => {
                let c: Checkpoint = serde_json::from_slice(&bytes)
                    .map_err(|e| format!("elevator {id}: checkpoint: {e}"))?;
                let monitor = match (&c.model, &c.monitor) {
                    (Some((d, _)), Some(text)) => {
                        let m = self.model(d).await?;
                        Some(crate::worker::resume_or_restart(&m, text, id, d))
                    }
                    _ => None,
                };
                Elevator {
                    partition: p,
                    aligner: c.aligner,
                    monitor,
                    model: c.model,
                    counters: c.counters,
                    applied_seq: c.seq,
                    state_rev: Some(rev),
                    trips: Vec::new(),
                    events: Vec::new(),
                    dirty: false,
                }
            }
        };
        if let Some((d, rev)) = self.bus.active_model(id).await? {
            let mut a = self
                .active
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            note_active(&mut a, id, d, rev);
        }
        self.elevators.insert(id.to_string(), e);
        self.stats
            .samples_elevators
            .store(self.elevators.len() as u64, Ordering::Relaxed);
        Ok(())
    }

    /// Restarts the monitor of `id` on its active model when that changed.
    async fn switch_model(&mut self, id: &str) -> Result<(), String> {
        let active = self
            .active
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .get(id)
            .cloned();
        let current = self.elevators[id].model.clone();
        if active.as_ref().map(|a| &a.0) == current.as_ref().map(|c| &c.0) {
            return Ok(());
        }
        let monitor = match &active {
            Some((d, _)) => Some(Monitor::new(&*self.model(d).await?, Method::Pinn)),
            None => None,
        };
        let e = self.elevators.get_mut(id).expect("loaded");
        log(
            "info",
            &format!(
                "elevator {id}: monitor restarts (model), model {:?}, at seq {}",
                active.as_ref().map(|a| a.1),
                e.applied_seq
            ),
        );
        e.monitor = monitor;
        e.model = active;
        e.dirty = true;
        Ok(())
    }

    /// Publishes the outputs of partition `p`, writes its dirty checkpoints, commits it.
    async fn checkpoint(&mut self, p: u32) {
        let Some(part) = self.parts.get(&p) else {
            return;
        };
        let dirty: Vec<String> = part
            .ids
            .iter()
            .filter(|id| self.elevators.get(*id).is_some_and(|e| e.dirty))
            .cloned()
            .collect();
        let mut outs = Vec::new();
        for id in &dirty {
            let e = &self.elevators[id];
            debug_assert_eq!(e.partition, p);
            outs.extend(outputs(id, e));
        }
        if let Err(e) = self.bus.publish(&outs).await {
            log(
                "warn",
                &format!("partition {p}: outputs not stored, retried: {e}"),
            );
            return;
        }
        let mut writes = Vec::with_capacity(dirty.len());
        for id in &dirty {
            let e = &self.elevators[id];
            let c = Checkpoint {
                seq: e.applied_seq,
                model: e.model.clone(),
                aligner: e.aligner.clone(),
                monitor: e.monitor.as_ref().map(|m| {
                    serde_json::to_string(m.state_ref()).expect("a monitor state always serialises")
                }),
                counters: e.counters,
            };
            let bytes =
                Bytes::from(serde_json::to_vec(&c).expect("a checkpoint always serialises"));
            writes.push(self.bus.save_state(id, e.state_rev, bytes));
        }
        let results = futures_util::future::join_all(writes).await;
        let mut fenced = false;
        for (id, r) in dirty.iter().zip(results) {
            match r {
                Ok(Some(rev)) => {
                    let e = self.elevators.get_mut(id).expect("listed");
                    e.state_rev = Some(rev);
                    e.trips.clear();
                    e.events.clear();
                    e.dirty = false;
                }
                Ok(None) => fenced = true,
                Err(e) => {
                    log(
                        "warn",
                        &format!("partition {p}: checkpoint of {id} failed: {e}"),
                    );
                    return;
                }
            }
        }
        if fenced {
            log(
                "warn",
                &format!("partition {p}: another worker wrote its checkpoints; dropped"),
            );
            self.give_up(p).await;
            return;
        }
        let part = self.parts.get_mut(&p).expect("held");
        if let Some(pos) = part.last.take() {
            if let Err(e) = self.bus.commit(&pos).await {
                log(
                    "warn",
                    &format!("partition {p}: commit failed, the replay is longer: {e}"),
                );
            }
        }
    }
}

/// Notes model `d` (version `rev`) as the active one of `id` unless a later one is known: the
/// watch and the lookup at an elevator's load may come in either order.
fn note_active(a: &mut HashMap<String, (String, u64)>, id: &str, d: String, rev: u64) {
    if a.get(id).map_or(true, |x| x.1 < rev) {
        a.insert(id.to_string(), (d, rev));
    }
}

/// The models task: a watch on the active models is made, then every active model is read
/// once (a change between the two comes through the watch too, and the later revision wins),
/// then the watch's changes are taken as they come; all of it again, after [`WATCH_RETRY`],
/// when the watch cannot be made or ends. The worker does not wait for it: while a server is
/// down the cluster may place the watch's consumer on it (`Bus::members`), and a worker must
/// start all the same; each elevator's model is looked up when it is loaded anyway.
async fn follow_models(bus: Arc<Bus>, active: Arc<Mutex<HashMap<String, (String, u64)>>>) {
    let apply = |(id, d, rev): (String, Option<String>, u64)| {
        let mut a = active
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        match d {
            Some(d) => note_active(&mut a, &id, d, rev),
            None => {
                a.remove(&id);
            }
        }
    };
    loop {
        let watched = async {
            let mut watch = Box::pin(bus.watch_models().await?);
            for change in bus.active_models().await? {
                apply(change);
            }
            while let Some(change) = watch.next().await {
                apply(change);
            }
            Err::<(), _>("the watch ended".to_string())
        };
        if let Err(e) = watched.await {
            log(
                "warn",
                &format!(
                    "models: {e}; watched again in {} s",
                    WATCH_RETRY.as_secs_f64()
                ),
            );
        }
        tokio::time::sleep(WATCH_RETRY).await;
    }
}

/// The lease task: every `tick`, the worker's heartbeat and each held lease renewed (compare and
/// swap on its revision); a lease that cannot be renewed is reported lost.
async fn renew(bus: Arc<Bus>, name: String, leases: Arc<Leases>, tick: Duration) {
    loop {
        tokio::time::sleep(tick).await;
        if let Err(e) = bus.heartbeat(&name).await {
            log("warn", &format!("heartbeat: {e}"));
        }
        let mut held = leases.held.lock().await;
        let mut lost = Vec::new();
        for (p, rev) in held.iter_mut() {
            match bus.renew(*p, &name, *rev).await {
                Ok(Some(r)) => *rev = r,
                Ok(None) => lost.push(*p),
                // The server did not answer: the lease may still be ours; tried again next tick.
                Err(e) => log("warn", &format!("partition {p}: lease not renewed: {e}")),
            }
        }
        for p in &lost {
            held.remove(p);
        }
        drop(held);
        leases
            .lost
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .extend(lost);
    }
}

/// The outputs of an elevator since its checkpoint, each with an id a replay repeats:
/// `{id}:r:{seq}:{k}` for the k-th trip row of telemetry record `seq`, `{id}:e:…` for events.
fn outputs(id: &str, e: &Elevator) -> Vec<Output> {
    let trips = e.trips.iter().map(|t| ("risk", "r", t.0, &t.3));
    let events = e.events.iter().map(|ev| ("events", "e", ev.0, &ev.3));
    let mut out = Vec::new();
    let mut last = (None, 0usize);
    for (kind, tag, seq, line) in trips.chain(events) {
        // k counts the outputs of one kind from one record.
        let k = if last.0 == Some((tag, seq)) {
            last.1 + 1
        } else {
            0
        };
        last = (Some((tag, seq)), k);
        out.push(Output {
            kind,
            id: id.to_string(),
            msg_id: format!("{id}:{tag}:{seq}:{k}"),
            line: line.clone(),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn elevator() -> Elevator {
        Elevator::fresh(0, Aligner::new(&AlignConfig::default()).unwrap())
    }

    #[test]
    fn output_ids_name_the_record_and_repeat_in_a_replay() {
        let mut e = elevator();
        e.trips = vec![
            (7, 0.0, 1.0, "a".into()),
            (7, 2.0, 3.0, "b".into()),
            (9, 4.0, 5.0, "c".into()),
        ];
        e.events = vec![(7, 1.0, "advisory".into(), "{}".into())];
        let ids: Vec<String> = outputs("e1", &e).into_iter().map(|o| o.msg_id).collect();
        assert_eq!(ids, ["e1:r:7:0", "e1:r:7:1", "e1:r:9:0", "e1:e:7:0"]);
        let again: Vec<String> = outputs("e1", &e).into_iter().map(|o| o.msg_id).collect();
        assert_eq!(ids, again);
    }

    #[test]
    fn an_older_model_version_never_overrides_a_newer_one() {
        let mut a = HashMap::new();
        note_active(&mut a, "e1", "d2".into(), 5);
        note_active(&mut a, "e1", "d1".into(), 3);
        assert_eq!(a["e1"], ("d2".to_string(), 5));
        note_active(&mut a, "e1", "d3".into(), 6);
        assert_eq!(a["e1"], ("d3".to_string(), 6));
    }
}
