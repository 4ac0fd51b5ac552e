//! The worker: applies the stored batches per elevator in seq order, readings → [`Aligner`] →
//! [`Monitor::push`] → trip rows and events, and checkpoints.
//!
//! ```text
//! batch seq n of elevator E   decode → Aligner::push (late, duplicate: counted, dropped)
//!                             → samples → Monitor::push → rows with trip_end → trip rows
//!                                                        → rows with an event  → events
//! checkpoint (every checkpoint_every_s of wall time, or checkpoint_every_batches batches,
//! and at shutdown): ONE transaction with the outputs since the last checkpoint AND, per
//! elevator, the aligner state, the monitor state and the last applied seq
//! ```
//!
//! Outputs and state commit together, so a `kill -9` at any instant leaves a checkpoint whose
//! outputs are exactly those of the batches up to its seq; the restart resumes there and
//! re-applies the later batches, which are still stored. Nothing is lost or counted twice, and
//! the checkpoint frequency does not change a single output.
//!
//! Model changes (an activation, a rollback, a re-baseline after repair) are taken between two
//! batches: the monitor restarts from a fresh state of the active model at the stream position
//! the worker has reached. The aligner is never restarted: the samples go on.

use liftwatch::sample::HOUR_S;
use std::collections::{BTreeSet, HashMap};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use liftwatch::align::{AlignConfig, Aligner, AlignerCounts, SampleSink};
use liftwatch::fit::FittedModel;
use liftwatch::monitor::{Method, Monitor, MonitorRow, MonitorState, TimeFormat, TripRowWriter};
use liftwatch::verdict::Verdict;
use liftwatch::Sample;
use rusqlite::{params, Connection, OptionalExtension};
use serde::{Deserialize, Serialize};

use crate::store;
use crate::{log, Shared};

/// Batches one elevator applies before the worker turns to the next one: a backlog of one
/// elevator does not hold the others up for more than this.
const BATCHES_PER_TURN: i64 = 64;

/// Wall time between two prunings of old raw batches (s).
const PRUNE_EVERY_S: f64 = HOUR_S;

/// Longest wait for a message when nothing is pending: how quickly shutdown is noticed.
const IDLE_WAIT: Duration = Duration::from_millis(500);

/// A message to the worker.
#[derive(Debug)]
pub enum Msg {
    /// New batches, or a model or maintenance change, for this elevator.
    Work(String),
    /// Final checkpoint, then stop.
    Stop,
}

/// Counters the worker keeps beside the aligner's, checkpointed with it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Counters {
    /// Batches applied.
    pub batches: u64,
    /// Readings in them.
    pub readings: u64,
    /// Aligned samples no model watched (before the first activation).
    pub unwatched: u64,
    /// Door openings (door rising through 0.5).
    pub door_cycles: u64,
    /// The last door value seen (NaN before any).
    #[serde(with = "liftwatch::exact")]
    pub last_door: f64,
    /// Time of the first aligned sample (s), NaN before any.
    #[serde(with = "liftwatch::exact")]
    pub first_time: f64,
    /// Time of the last aligned sample (s), NaN before any.
    #[serde(with = "liftwatch::exact")]
    pub last_time: f64,
}

impl Counters {
    /// Nothing counted yet.
    pub fn new() -> Self {
        Counters {
            last_door: f64::NAN,
            first_time: f64::NAN,
            last_time: f64::NAN,
            ..Counters::default()
        }
    }
}

/// What the API shows of an elevator's monitor: taken at each checkpoint, so it matches the
/// stored rows.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    /// Version of the model the monitor runs, if any.
    pub model_version: Option<i64>,
    /// The verdict JSON text, as `liftwatch status --json` prints it; `None` without a model.
    pub verdict: Option<String>,
    /// Level (`normal`, `advisory`, `alarm`).
    pub level: String,
    /// Combined risk R (NaN without a model).
    pub risk: f64,
    /// Complete trips seen by the monitor.
    pub trips: u64,
    /// The aligner's counters.
    pub counts: AlignerCounts,
    /// The worker's counters.
    pub counters: Counters,
    /// Last seq applied and checkpointed.
    pub applied_seq: i64,
}

/// One elevator's running pipeline.
struct Runtime {
    aligner: Aligner,
    monitor: Option<Monitor>,
    model: Option<(i64, Arc<FittedModel>)>,
    rebaseline_gen: i64,
    applied_seq: i64,
    counters: Counters,
    trips: Vec<TripOut>,
    events: Vec<EventOut>,
    dirty: bool,
}

/// A trip row as the workers collect it: (seq of its batch, start, end, CSV line).
pub type TripOut = (i64, f64, f64, String);

/// An event as the workers collect it: (seq of its batch, time, level, line).
pub type EventOut = (i64, f64, String, String);

/// The aligner's sink: samples into the monitor, outputs collected until the checkpoint. The
/// one step of both workers (this embedded one and [`crate::fleet`]'s).
pub struct Feed<'a> {
    /// The elevator's monitor, `None` before a model is active.
    pub monitor: Option<&'a mut Monitor>,
    /// The worker's counters.
    pub counters: &'a mut Counters,
    /// Trip rows out.
    pub trips: &'a mut Vec<TripOut>,
    /// Events out.
    pub events: &'a mut Vec<EventOut>,
    /// The seq of the batch being applied.
    pub seq: i64,
}

impl Feed<'_> {
    /// Applies one batch's readings through `aligner` into this feed and counts the batch.
    ///
    /// # Errors
    /// The aligner's or the monitor's error, as one line.
    pub fn apply(
        &mut self,
        aligner: &mut Aligner,
        readings: &[(liftwatch::ingest::Signal, f64, f64)],
    ) -> Result<(), String> {
        for (sig, t, v) in readings {
            aligner
                .push(*sig, *t, *v, self)
                .map_err(|e| e.to_string())?;
        }
        self.counters.batches += 1;
        self.counters.readings += readings.len() as u64;
        Ok(())
    }
}

impl SampleSink for Feed<'_> {
    type Error = liftwatch::Error;

    fn start(&mut self, _has_current: bool) -> liftwatch::Result<()> {
        Ok(())
    }

    fn push(&mut self, s: &Sample) -> liftwatch::Result<()> {
        let c = &mut *self.counters;
        if c.first_time.is_nan() {
            c.first_time = s.time;
        }
        c.last_time = s.time;
        if s.door.is_finite() {
            if s.door >= 0.5 && c.last_door < 0.5 {
                c.door_cycles += 1;
            }
            c.last_door = s.door;
        }
        let Some(m) = self.monitor.as_deref_mut() else {
            c.unwatched += 1;
            return Ok(());
        };
        let mut row = MonitorRow::EMPTY;
        if m.push_into(s, &mut row) {
            if let Some(line) = trip_line(&row) {
                let t = &row.trip_end.expect("trip_line saw it").trip;
                self.trips.push((self.seq, t.start_time, t.end_time, line));
            }
            if let Some(e) = &row.event {
                self.events.push((
                    self.seq,
                    e.time,
                    e.level.as_str().to_string(),
                    m.event_line(e),
                ));
            }
            // Availability and doors (an outage's start and end, the door advisory), the
            // same lines as the events file, in the same order.
            if let Some(e) = row.operation.as_deref() {
                let level = match e {
                    liftwatch::operation::OperationEvent::Door { raised: true, .. } => "advisory",
                    liftwatch::operation::OperationEvent::Door { raised: false, .. } => "normal",
                    _ => "outage",
                };
                self.events.push((
                    self.seq,
                    e.time(),
                    level.to_string(),
                    m.operation_event_line(e),
                ));
            }
        }
        Ok(())
    }
}

/// The trip CSV line (`monitor --rows trip`, epoch times) of a row that reports a trip.
pub fn trip_line(row: &MonitorRow) -> Option<String> {
    row.trip_end.as_ref()?;
    let mut w = TripRowWriter::new(Vec::new(), TimeFormat::Epoch).ok()?;
    w.write(row).ok()?;
    let bytes = w.into_inner().ok()?;
    let text = String::from_utf8(bytes).ok()?;
    let line = text.lines().nth(1)?;
    Some(line.to_string())
}

/// The worker's loop; returns at [`Msg::Stop`] (or when every sender is gone) after a final
/// checkpoint.
pub fn run(mut conn: Connection, shared: Arc<Shared>, rx: Receiver<Msg>) {
    /// Clears [`Shared::worker_alive`] however the worker ends, a panic included.
    struct Alive(Arc<Shared>);
    impl Drop for Alive {
        fn drop(&mut self) {
            self.0
                .worker_alive
                .store(false, std::sync::atomic::Ordering::Relaxed);
        }
    }
    let _alive = Alive(shared.clone());
    let mut w = Worker {
        runtimes: HashMap::new(),
        models: HashMap::new(),
        shared,
        since_checkpoint: 0,
        last_checkpoint: Instant::now(),
        last_prune: f64::NEG_INFINITY,
    };
    let mut active: BTreeSet<String> = match all_elevators(&conn) {
        Ok(ids) => ids.into_iter().collect(),
        Err(e) => {
            log("error", &format!("cannot list elevators: {e}"));
            BTreeSet::new()
        }
    };
    for id in active.clone() {
        if let Err(e) = w.load(&conn, &id) {
            log("error", &format!("elevator {id}: cannot resume: {e}"));
            active.remove(&id);
        }
    }
    w.publish_all();
    let every = Duration::from_secs_f64(w.shared.cfg.checkpoint_every_s);
    loop {
        let wait = if !active.is_empty() {
            Duration::ZERO
        } else if w.dirty() {
            every.saturating_sub(w.last_checkpoint.elapsed())
        } else {
            IDLE_WAIT
        };
        let mut stop = false;
        match rx.recv_timeout(wait) {
            Ok(Msg::Work(id)) => {
                active.insert(id);
            }
            Ok(Msg::Stop) | Err(RecvTimeoutError::Disconnected) => stop = true,
            Err(RecvTimeoutError::Timeout) => {}
        }
        while let Ok(msg) = rx.try_recv() {
            match msg {
                Msg::Work(id) => {
                    active.insert(id);
                }
                Msg::Stop => stop = true,
            }
        }
        if stop {
            break;
        }
        let turn: Vec<String> = active.iter().cloned().collect();
        for id in turn {
            match w.apply_turn(&conn, &id) {
                Ok(true) => {}
                Ok(false) => {
                    active.remove(&id);
                }
                Err(e) => {
                    log("error", &format!("elevator {id}: {e}"));
                    active.remove(&id);
                }
            }
            if w.since_checkpoint >= w.shared.cfg.checkpoint_every_batches {
                w.checkpoint(&mut conn);
            }
        }
        if w.dirty() && w.last_checkpoint.elapsed() >= every {
            w.checkpoint(&mut conn);
        }
        if store::now() - w.last_prune >= PRUNE_EVERY_S {
            w.last_prune = store::now();
            match store::prune(&conn, w.shared.cfg.keep_raw_days) {
                Ok(0) => {}
                Ok(n) => log("info", &format!("pruned {n} raw batches")),
                Err(e) => log("error", &format!("cannot prune raw batches: {e}")),
            }
        }
    }
    w.checkpoint(&mut conn);
    log("info", "worker stopped after its final checkpoint");
}

/// Every elevator id in the store.
fn all_elevators(conn: &Connection) -> rusqlite::Result<Vec<String>> {
    let mut st = conn.prepare("SELECT id FROM elevators ORDER BY id")?;
    let ids = st.query_map([], |r| r.get(0))?.collect();
    ids
}

struct Worker {
    runtimes: HashMap<String, Runtime>,
    models: HashMap<(String, i64), Arc<FittedModel>>,
    shared: Arc<Shared>,
    since_checkpoint: u64,
    last_checkpoint: Instant,
    last_prune: f64,
}

impl Worker {
    fn dirty(&self) -> bool {
        self.runtimes.values().any(|r| r.dirty)
    }

    fn align_config(&self) -> Result<AlignConfig, String> {
        AlignConfig::default()
            .with_reorder_window(self.shared.cfg.reorder_window_s)
            .map_err(|e| e.to_string())
    }

    /// The model `version` of `id`, parsed once.
    fn model(
        &mut self,
        conn: &Connection,
        id: &str,
        version: i64,
    ) -> Result<Arc<FittedModel>, String> {
        if let Some(m) = self.models.get(&(id.to_string(), version)) {
            return Ok(m.clone());
        }
        let body: String = conn
            .query_row(
                "SELECT body FROM models WHERE elevator = ?1 AND version = ?2 AND body IS NOT NULL",
                params![id, version],
                |r| r.get(0),
            )
            .map_err(|e| format!("model {version}: {e}"))?;
        let m = liftwatch::file::load_str(&body, std::path::Path::new("stored model"))
            .map_err(|e| e.to_string())?;
        let m = Arc::new(m);
        self.models.insert((id.to_string(), version), m.clone());
        Ok(m)
    }

    /// Loads an elevator's runtime from its checkpoint, or a fresh one.
    fn load(&mut self, conn: &Connection, id: &str) -> Result<(), String> {
        let row = conn
            .query_row(
                "SELECT applied_seq, model_version, rebaseline_gen, aligner, monitor, counters
                 FROM checkpoints WHERE elevator = ?1",
                [id],
                |r| {
                    Ok((
                        r.get::<_, i64>(0)?,
                        r.get::<_, Option<i64>>(1)?,
                        r.get::<_, i64>(2)?,
                        r.get::<_, String>(3)?,
                        r.get::<_, Option<String>>(4)?,
                        r.get::<_, String>(5)?,
                    ))
                },
            )
            .optional()
            .map_err(|e| e.to_string())?;
        let rt = match row {
            None => Runtime {
                aligner: Aligner::new(&self.align_config()?).map_err(|e| e.to_string())?,
                monitor: None,
                model: None,
                rebaseline_gen: current_gen(conn, id)?,
                applied_seq: 0,
                counters: Counters::new(),
                trips: Vec::new(),
                events: Vec::new(),
                dirty: false,
            },
            Some((applied_seq, version, gen, aligner, monitor, counters)) => {
                let aligner: Aligner =
                    serde_json::from_str(&aligner).map_err(|e| format!("aligner state: {e}"))?;
                let counters: Counters =
                    serde_json::from_str(&counters).map_err(|e| format!("counters: {e}"))?;
                let (model, monitor) = match (version, monitor) {
                    (Some(v), Some(text)) => {
                        let m = self.model(conn, id, v)?;
                        let mon = resume_or_restart(&m, &text, id, &v.to_string());
                        (Some((v, m)), Some(mon))
                    }
                    _ => (None, None),
                };
                Runtime {
                    aligner,
                    monitor,
                    model,
                    rebaseline_gen: gen,
                    applied_seq,
                    counters,
                    trips: Vec::new(),
                    events: Vec::new(),
                    dirty: false,
                }
            }
        };
        self.runtimes.insert(id.to_string(), rt);
        Ok(())
    }

    /// Takes a model activation or a re-baseline, if one is pending, before the next batch.
    fn control(&mut self, conn: &Connection, id: &str) -> Result<(), String> {
        let active: Option<i64> = conn
            .query_row(
                "SELECT version FROM models WHERE elevator = ?1 AND active = 1",
                [id],
                |r| r.get(0),
            )
            .optional()
            .map_err(|e| e.to_string())?;
        let gen = current_gen(conn, id)?;
        let model = match active {
            Some(v) => Some((v, self.model(conn, id, v)?)),
            None => None,
        };
        let rt = self.runtimes.get_mut(id).expect("loaded before control");
        let changed_model = rt.model.as_ref().map(|m| m.0) != active;
        if changed_model || rt.rebaseline_gen != gen {
            let why = if changed_model {
                "model"
            } else {
                "re-baseline"
            };
            rt.monitor = model.as_ref().map(|(_, m)| Monitor::new(m, Method::Pinn));
            rt.model = model;
            rt.rebaseline_gen = gen;
            rt.dirty = true;
            log(
                "info",
                &format!(
                    "elevator {id}: monitor restarts ({why}), model {:?}, at seq {}",
                    active, rt.applied_seq
                ),
            );
        }
        Ok(())
    }

    /// Applies up to [`BATCHES_PER_TURN`] pending batches; true when more remain.
    fn apply_turn(&mut self, conn: &Connection, id: &str) -> Result<bool, String> {
        if !self.runtimes.contains_key(id) {
            self.load(conn, id)?;
        }
        self.control(conn, id)?;
        let after = self.runtimes[id].applied_seq;
        let mut st = conn
            .prepare_cached(
                "SELECT seq, data FROM batches WHERE elevator = ?1 AND seq > ?2 ORDER BY seq LIMIT ?3",
            )
            .map_err(|e| e.to_string())?;
        let batches: Vec<(i64, Vec<u8>)> = st
            .query_map(params![id, after, BATCHES_PER_TURN], |r| {
                Ok((r.get(0)?, r.get(1)?))
            })
            .and_then(|rows| rows.collect())
            .map_err(|e| e.to_string())?;
        let more = batches.len() as i64 == BATCHES_PER_TURN;
        let rt = self.runtimes.get_mut(id).expect("loaded above");
        for (seq, data) in batches {
            let (readings, whole) = store::decode(&data);
            if !whole {
                log("error", &format!("elevator {id}: batch {seq} is damaged; its readings before the damage are applied"));
            }
            let mut feed = Feed {
                monitor: rt.monitor.as_mut(),
                counters: &mut rt.counters,
                trips: &mut rt.trips,
                events: &mut rt.events,
                seq,
            };
            feed.apply(&mut rt.aligner, &readings)?;
            rt.applied_seq = seq;
            rt.dirty = true;
            self.since_checkpoint += 1;
        }
        Ok(more)
    }

    /// Writes every dirty runtime's outputs and state in one transaction.
    fn checkpoint(&mut self, conn: &mut Connection) {
        let dirty: Vec<String> = self
            .runtimes
            .iter()
            .filter(|(_, r)| r.dirty)
            .map(|(id, _)| id.clone())
            .collect();
        self.last_checkpoint = Instant::now();
        self.since_checkpoint = 0;
        if dirty.is_empty() {
            return;
        }
        if let Err(e) = self.write_checkpoint(conn, &dirty) {
            // Nothing was committed: the outputs stay buffered and the next checkpoint retries.
            log(
                "error",
                &format!("checkpoint failed, retried at the next one: {e}"),
            );
            return;
        }
        if let Some(client) = self.shared.events_mqtt.get() {
            for id in &dirty {
                let lines: Vec<&str> = self.runtimes[id]
                    .events
                    .iter()
                    .map(|e| e.3.as_str())
                    .collect();
                crate::mqtt::publish_events(client, id, &lines);
            }
        }
        for id in &dirty {
            let rt = self.runtimes.get_mut(id).expect("listed above");
            rt.trips.clear();
            rt.events.clear();
            rt.dirty = false;
        }
        for id in &dirty {
            self.publish(id);
        }
    }

    fn write_checkpoint(&self, conn: &mut Connection, dirty: &[String]) -> rusqlite::Result<()> {
        let tx = conn.transaction()?;
        {
            let mut trip = tx.prepare_cached(
                "INSERT INTO trips (elevator, seq, start, end_time, row) VALUES (?1, ?2, ?3, ?4, ?5)",
            )?;
            let mut event = tx.prepare_cached(
                "INSERT INTO events (elevator, seq, time, level, line) VALUES (?1, ?2, ?3, ?4, ?5)",
            )?;
            let mut ckpt = tx.prepare_cached(
                "INSERT INTO checkpoints (elevator, applied_seq, model_version, rebaseline_gen, aligner, monitor, counters, updated)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)
                 ON CONFLICT(elevator) DO UPDATE SET applied_seq = excluded.applied_seq,
                   model_version = excluded.model_version, rebaseline_gen = excluded.rebaseline_gen,
                   aligner = excluded.aligner, monitor = excluded.monitor,
                   counters = excluded.counters, updated = excluded.updated",
            )?;
            for id in dirty {
                let rt = &self.runtimes[id];
                for (seq, start, end, line) in &rt.trips {
                    trip.execute(params![id, seq, start, end, line])?;
                }
                for (seq, time, level, line) in &rt.events {
                    event.execute(params![id, seq, time, level, line])?;
                }
                let aligner =
                    serde_json::to_string(&rt.aligner).expect("an aligner state always serialises");
                let monitor = rt.monitor.as_ref().map(|m| {
                    serde_json::to_string(m.state_ref()).expect("a monitor state always serialises")
                });
                let counters =
                    serde_json::to_string(&rt.counters).expect("counters always serialise");
                ckpt.execute(params![
                    id,
                    rt.applied_seq,
                    rt.model.as_ref().map(|m| m.0),
                    rt.rebaseline_gen,
                    aligner,
                    monitor,
                    counters,
                    store::now()
                ])?;
            }
        }
        tx.commit()
    }

    fn publish_all(&self) {
        for id in self.runtimes.keys() {
            self.publish(id);
        }
    }

    /// Publishes the snapshot of `id` for the API.
    fn publish(&self, id: &str) {
        let rt = &self.runtimes[id];
        let (verdict, level, risk, trips) = match (&rt.model, &rt.monitor) {
            (Some((_, m)), Some(mon)) => {
                let st = mon.state_ref();
                let v = Verdict::new(m, st);
                (
                    serde_json::to_string(&v).ok(),
                    st.level().as_str().to_string(),
                    v.risk[0],
                    st.trips,
                )
            }
            _ => (None, "normal".to_string(), f64::NAN, 0),
        };
        let snap = Snapshot {
            model_version: rt.model.as_ref().map(|m| m.0),
            verdict,
            level,
            risk,
            trips,
            counts: rt.aligner.counts(),
            counters: rt.counters,
            applied_seq: rt.applied_seq,
        };
        self.shared
            .snapshots
            .write()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .insert(id.to_string(), snap);
    }
}

/// The elevator's re-baseline generation (bumped by a maintenance visit with `rebaseline`).
fn current_gen(conn: &Connection, id: &str) -> Result<i64, String> {
    conn.query_row(
        "SELECT rebaseline_gen FROM elevators WHERE id = ?1",
        [id],
        |r| r.get(0),
    )
    .optional()
    .map(|g| g.unwrap_or(0))
    .map_err(|e| e.to_string())
}

/// The monitor of a checkpoint's state `text` with `model` (named `model_name` in the log), or,
/// when that state does not resume (another build's: another format, or a model identity it
/// took otherwise), a fresh monitor of the model, logged: monitoring goes on afresh rather than
/// not at all, as after a re-baseline. The single-node worker's and the fleet's.
pub(crate) fn resume_or_restart(
    model: &FittedModel,
    text: &str,
    id: &str,
    model_name: &str,
) -> Monitor {
    MonitorState::from_slice(text.as_bytes(), std::path::Path::new("checkpoint"))
        .and_then(|st| Monitor::resume(model, st))
        .unwrap_or_else(|e| {
            log(
                "error",
                &format!("elevator {id}: its checkpoint does not resume ({e}); the monitor restarts from model {model_name}"),
            );
            Monitor::new(model, Method::Pinn)
        })
}
