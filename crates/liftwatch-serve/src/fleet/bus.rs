//! The fleet's log, on NATS JetStream: the only file of the crate that speaks NATS.
//!
//! ```text
//! liftwatch.telemetry.{id}  (or MQTT liftwatch/{id}/telemetry = liftwatch.{id}.telemetry)
//!     ─ the server's mapping {{partition(P,1)}} ─ liftwatch.part.{p}.{id}
//!     ─ stream LIFTWATCH_TELEMETRY ─ durable pull consumer part-{p} (ack all)
//! KV liftwatch_leases   part.{p} = worker (revision = compare-and-swap), worker.{w} heartbeat;
//!                       the bucket's max_age is the lease: an entry not renewed disappears
//! KV liftwatch_state    {id} = checkpoint (aligner, monitor, counters, stream seq it covers)
//! KV liftwatch_models   body.{digest} = model file, active.{id} = digest (revision = version)
//! stream LIFTWATCH_OUT  liftwatch.risk.{id}, liftwatch.events.{id}, Nats-Msg-Id deduplicated
//! ```
//!
//! What [`super`] asks of a log is the set of methods of [`Bus`]; a Kafka consumer group keyed
//! by elevator id provides each of them (README, *Fleet*): partitions and their committed
//! offsets, group membership for the leases, a compacted topic for the states and models, an
//! idempotent producer for the outputs.

use liftwatch::sample::DAY_S;
use std::collections::HashMap;
use std::time::Duration;

use async_nats::jetstream::consumer::{pull, AckPolicy, DeliverPolicy};
use async_nats::jetstream::{self, kv, stream};
use async_nats::HeaderMap;
use bytes::Bytes;
use futures_util::StreamExt;

/// How long [`Bus::states`] and [`Bus::outputs`] wait for the checkpoints or the outputs of
/// the whole fleet: 10,000 checkpoints come back in seconds; past this the cluster is not
/// answering.
pub const STATES_PATIENCE: Duration = Duration::from_secs(30);

/// Requests [`Bus::states`] and [`Bus::outputs`] keep in flight: enough to hide a loopback round trip behind
/// the others, few enough not to queue behind a worker's checkpoints.
const READS_IN_FLIGHT: usize = 64;

/// The telemetry stream.
pub const TELEMETRY_STREAM: &str = "LIFTWATCH_TELEMETRY";
/// The outputs stream.
pub const OUTPUT_STREAM: &str = "LIFTWATCH_OUT";
/// The bucket of leases and worker heartbeats.
pub const LEASES: &str = "liftwatch_leases";
/// The bucket of per-elevator checkpoints.
pub const STATE: &str = "liftwatch_state";
/// The bucket of models.
pub const MODELS: &str = "liftwatch_models";

/// How long the outputs stream remembers a message id: a replay after a takeover that comes
/// later than this could publish an output twice (a takeover takes a lease, seconds).
pub const DEDUP_WINDOW: Duration = Duration::from_secs(600);

/// Longest wait of one request to the server.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(10);

/// The subject a gateway publishes elevator `id`'s telemetry on.
pub fn telemetry_subject(id: &str) -> String {
    format!("liftwatch.telemetry.{id}")
}

/// The `mappings` block of the server configuration for `partitions` partitions: both the
/// NATS subject and the MQTT topic `liftwatch/{id}/telemetry` go to the partition subject.
pub fn server_mappings(partitions: u32) -> String {
    let to = format!("liftwatch.part.{{{{partition({partitions},1)}}}}.{{{{wildcard(1)}}}}");
    format!("mappings = {{\n  \"liftwatch.telemetry.*\": \"{to}\"\n  \"liftwatch.*.telemetry\": \"{to}\"\n}}\n")
}

/// The elevator id of a partition subject `liftwatch.part.{p}.{id}`.
fn id_of_subject(subject: &str) -> Option<&str> {
    let rest = subject.strip_prefix("liftwatch.part.")?;
    let (_, id) = rest.split_once('.')?;
    Some(id).filter(|id| !id.is_empty() && !id.contains('.'))
}

/// A model digest: FNV-1a of the file, 64 bits in hex (a content key, not a safeguard).
pub fn digest(body: &[u8]) -> String {
    format!("{:016x}", liftwatch::file::fnv1a(body))
}

/// A partition being read: JetStream's durable pull consumer `part-{p}`.
pub type Partition = async_nats::jetstream::consumer::PullConsumer;

/// One telemetry message of a partition.
pub struct Record {
    /// Its stream sequence: the position a checkpoint covers.
    pub seq: u64,
    /// Its delivery number on this reading of the partition (1, 2, …): a number skipped is a
    /// delivery that never arrived (a fetch that ended while it was on its way).
    pub delivery: u64,
    /// The elevator.
    pub id: String,
    /// The raw body (`time,signal,value` CSV or JSON lines), as over HTTP.
    pub body: Bytes,
    /// What commits the partition up to here.
    pub position: Position,
}

/// A partition's position, committed once the checkpoints that cover it are written.
pub struct Position(jetstream::Message);

/// One output line to publish.
pub struct Output {
    /// `risk` or `events`.
    pub kind: &'static str,
    /// The elevator.
    pub id: String,
    /// The deduplication id: the same output of a replay has the same one.
    pub msg_id: String,
    /// The line.
    pub line: String,
}

/// An output as a reader of the outputs stream sees it.
#[derive(Clone, Debug)]
pub struct Published {
    /// Its subject.
    pub subject: String,
    /// Its deduplication id.
    pub msg_id: String,
    /// The line.
    pub line: String,
    /// When the stream stored it (Unix s).
    pub stored: f64,
}

/// The fleet's connection to JetStream.
pub struct Bus {
    client: async_nats::Client,
    js: jetstream::Context,
    telemetry: stream::Stream,
    leases: kv::Store,
    state: kv::Store,
    models: kv::Store,
}

/// One line for any error of the client.
fn line(what: &str, e: impl std::fmt::Display) -> String {
    format!("{what}: {}", crate::config::one_line(&e.to_string()))
}

impl Bus {
    /// Connects to `urls` (comma-separated) and makes sure the streams and buckets exist.
    ///
    /// # Errors
    /// One line: the address, the connection, a stream or bucket that cannot be made.
    pub async fn connect(
        urls: &str,
        name: &str,
        replicas: usize,
        lease_s: f64,
        keep_days: f64,
    ) -> Result<Bus, String> {
        let servers: Vec<async_nats::ServerAddr> = crate::config::nats_servers(urls)?
            .iter()
            .map(|u| u.parse().map_err(|e| line(u, e)))
            .collect::<Result<_, _>>()?;
        let client = async_nats::ConnectOptions::new()
            .name(name)
            .request_timeout(Some(REQUEST_TIMEOUT))
            .connect(servers)
            .await
            .map_err(|e| line(&format!("nats {urls}"), e))?;
        let js = jetstream::new(client.clone());
        let keep = Duration::from_secs_f64(keep_days.max(1.0) * DAY_S);
        let telemetry = ensure_stream(
            &js,
            stream::Config {
                name: TELEMETRY_STREAM.into(),
                subjects: vec!["liftwatch.part.*.*".into()],
                max_age: keep,
                num_replicas: replicas,
                ..Default::default()
            },
        )
        .await?;
        ensure_stream(
            &js,
            stream::Config {
                name: OUTPUT_STREAM.into(),
                subjects: vec!["liftwatch.risk.*".into(), "liftwatch.events.*".into()],
                max_age: keep,
                duplicate_window: DEDUP_WINDOW,
                num_replicas: replicas,
                ..Default::default()
            },
        )
        .await?;
        let bucket = |name: &str, history: i64, max_age: Duration| kv::Config {
            bucket: name.into(),
            history,
            max_age,
            num_replicas: replicas,
            ..Default::default()
        };
        let leases =
            ensure_bucket(&js, || bucket(LEASES, 1, Duration::from_secs_f64(lease_s))).await?;
        let state = ensure_bucket(&js, || bucket(STATE, 1, Duration::ZERO)).await?;
        let models = ensure_bucket(&js, || bucket(MODELS, 16, Duration::ZERO)).await?;
        Ok(Bus {
            client,
            js,
            telemetry,
            leases,
            state,
            models,
        })
    }

    // ── partitions ──────────────────────────────────────────────────────────────────────

    /// Opens partition `p` at its committed position: the durable consumer `part-{p}` is made
    /// anew from its acknowledgement floor, so whatever the last owner fetched and did not
    /// commit comes again, in order.
    ///
    /// # Errors
    /// One line from the server.
    pub async fn open(&self, p: u32) -> Result<Partition, String> {
        let name = format!("part-{p}");
        let floor = match self.telemetry.get_consumer::<pull::Config>(&name).await {
            Ok(mut c) => {
                let f = c
                    .info()
                    .await
                    .map_err(|e| line(&name, e))?
                    .ack_floor
                    .stream_sequence;
                self.telemetry
                    .delete_consumer(&name)
                    .await
                    .map_err(|e| line(&name, e))?;
                f
            }
            Err(_) => 0,
        };
        let deliver_policy = if floor == 0 {
            DeliverPolicy::All
        } else {
            DeliverPolicy::ByStartSequence {
                start_sequence: floor + 1,
            }
        };
        self.telemetry
            .create_consumer(pull::Config {
                durable_name: Some(name.clone()),
                filter_subject: format!("liftwatch.part.{p}.*"),
                deliver_policy,
                ack_policy: AckPolicy::All,
                ack_wait: Duration::from_secs(3600),
                max_ack_pending: -1,
                ..Default::default()
            })
            .await
            .map_err(|e| line(&name, e))
    }

    /// Up to `max` records of a partition, those there now (waits at most `wait`).
    ///
    /// # Errors
    /// One line from the server.
    pub async fn fetch(
        &self,
        consumer: &Partition,
        max: usize,
        wait: Duration,
    ) -> Result<Vec<Record>, String> {
        let mut batch = consumer
            .fetch()
            .max_messages(max)
            .expires(wait)
            .messages()
            .await
            .map_err(|e| line("fetch", e))?;
        let mut out = Vec::new();
        while let Some(m) = batch.next().await {
            let m = m.map_err(|e| line("fetch", e))?;
            let (seq, delivery) = {
                let i = m.info().map_err(|e| line("fetch", e))?;
                (i.stream_sequence, i.consumer_sequence)
            };
            let id = id_of_subject(&m.subject)
                .expect("the consumer's filter liftwatch.part.{p}.* leaves one token after p")
                .to_string();
            out.push(Record {
                seq,
                delivery,
                id,
                body: m.payload.clone(),
                position: Position(m),
            });
        }
        Ok(out)
    }

    /// Commits a partition up to `pos` (and everything before it).
    ///
    /// # Errors
    /// One line from the server.
    pub async fn commit(&self, pos: &Position) -> Result<(), String> {
        pos.0.ack().await.map_err(|e| line("commit", e))
    }

    // ── leases ──────────────────────────────────────────────────────────────────────────

    /// Announces worker `w` as alive (an entry of the lease bucket, gone a lease after its
    /// last renewal).
    ///
    /// # Errors
    /// One line from the server.
    pub async fn heartbeat(&self, w: &str) -> Result<(), String> {
        self.leases
            .put(format!("worker.{w}"), Bytes::from_static(b"alive"))
            .await
            .map(|_| ())
            .map_err(|e| line("heartbeat", e))
    }

    /// The live workers and which of the `partitions` are under a lease.
    ///
    /// # Errors
    /// One line from the server.
    ///
    /// Neither read makes a consumer. The KV client lists keys through an ephemeral consumer,
    /// and the cluster placed those on a server just killed: until it counted that server out,
    /// every listing timed out (for tens of seconds to minutes in the fleet test), and with it
    /// every worker's share, so a partition dropped in the failover stayed unowned. The
    /// workers come from the stream's subject list, a request the bucket's leader answers;
    /// the leases from one direct get per partition, which any live replica answers.
    pub async fn members(&self, partitions: u32) -> Result<(Vec<String>, Vec<u32>), String> {
        let mut workers: Vec<String> = subjects(&self.leases, "worker.")
            .await?
            .into_iter()
            .map(|k| k["worker.".len()..].to_string())
            .collect();
        workers.sort();
        let entries = futures_util::future::join_all(
            (0..partitions).map(|p| self.leases.entry(format!("part.{p}"))),
        )
        .await;
        let mut taken = Vec::new();
        for (p, e) in (0..partitions).zip(entries) {
            let e = e.map_err(|e| line("leases", e))?;
            if e.is_some_and(|e| e.operation == kv::Operation::Put) {
                taken.push(p);
            }
        }
        Ok((workers, taken))
    }

    /// Takes the lease of partition `p` for `w` if nobody holds it: its revision, or `None`.
    ///
    /// # Errors
    /// One line from the server (a held lease is not an error).
    pub async fn acquire(&self, p: u32, w: &str) -> Result<Option<u64>, String> {
        match self
            .leases
            .create(format!("part.{p}"), Bytes::from(w.to_string()))
            .await
        {
            Ok(rev) => Ok(Some(rev)),
            Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => Ok(None),
            Err(e) => Err(line("lease", e)),
        }
    }

    /// Renews the lease of partition `p` held at `rev`: the new revision, or `None` when it was
    /// lost (expired and taken, or the revision moved on).
    ///
    /// # Errors
    /// One line when the server did not answer.
    pub async fn renew(&self, p: u32, w: &str, rev: u64) -> Result<Option<u64>, String> {
        match self
            .leases
            .update(format!("part.{p}"), Bytes::from(w.to_string()), rev)
            .await
        {
            Ok(r) => Ok(Some(r)),
            Err(e) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => Ok(None),
            Err(e) => Err(line("lease", e)),
        }
    }

    /// Gives the lease of partition `p` up (only if still held at `rev`).
    pub async fn release(&self, p: u32, rev: u64) {
        let _ = self
            .leases
            .delete_expect_revision(format!("part.{p}"), Some(rev))
            .await;
    }

    // ── checkpoints ─────────────────────────────────────────────────────────────────────

    /// The checkpoint of elevator `id` and its revision.
    ///
    /// # Errors
    /// One line from the server.
    pub async fn load_state(&self, id: &str) -> Result<Option<(u64, Bytes)>, String> {
        let e = self.state.entry(id).await.map_err(|e| line("state", e))?;
        Ok(e.filter(|e| e.operation == kv::Operation::Put)
            .map(|e| (e.revision, e.value)))
    }

    /// Writes the checkpoint of `id` over revision `rev` (`None`: the first): the new revision,
    /// or `Ok(None)` when another worker wrote it since (this worker lost the elevator).
    ///
    /// # Errors
    /// One line from the server.
    pub async fn save_state(
        &self,
        id: &str,
        rev: Option<u64>,
        value: Bytes,
    ) -> Result<Option<u64>, String> {
        let r = match rev {
            Some(rev) => self.state.update(id, value, rev).await.map_err(|e| {
                (
                    e.kind() == kv::UpdateErrorKind::WrongLastRevision,
                    line("state", e),
                )
            }),
            None => self.state.create(id, value).await.map_err(|e| {
                (
                    e.kind() == kv::CreateErrorKind::AlreadyExists,
                    line("state", e),
                )
            }),
        };
        match r {
            Ok(rev) => Ok(Some(rev)),
            Err((true, _)) => Ok(None),
            Err((false, e)) => Err(e),
        }
    }

    // ── outputs ─────────────────────────────────────────────────────────────────────────

    /// Publishes `outputs` and waits until the stream has stored each (a duplicate id is
    /// stored once).
    ///
    /// # Errors
    /// One line from the server.
    pub async fn publish(&self, outputs: &[Output]) -> Result<(), String> {
        let mut acks = Vec::with_capacity(outputs.len());
        for o in outputs {
            let mut h = HeaderMap::new();
            h.insert(async_nats::header::NATS_MESSAGE_ID, o.msg_id.as_str());
            let ack = self
                .js
                .publish_with_headers(
                    format!("liftwatch.{}.{}", o.kind, o.id),
                    h,
                    Bytes::from(o.line.clone()),
                )
                .await
                .map_err(|e| line("publish", e))?;
            acks.push(ack);
        }
        for a in acks {
            a.await.map_err(|e| line("publish", e))?;
        }
        Ok(())
    }

    /// Every output stored so far, in stream order (a reader's view, for tests and tools).
    ///
    /// # Errors
    /// One line from the server.
    ///
    /// Read by sequence, `READS_IN_FLIGHT` (64) requests at a time, each answered by the
    /// stream's leader, rather than through a consumer that may be placed on a dead server
    /// ([`Bus::members`]). Gives up after [`STATES_PATIENCE`].
    pub async fn outputs(&self) -> Result<Vec<Published>, String> {
        let read = async {
            let stream = self
                .js
                .get_stream(OUTPUT_STREAM)
                .await
                .map_err(|e| line("outputs", e))?;
            // Fresh from the server: `Stream::cached_info` is as old as the handle.
            let state = stream
                .get_info()
                .await
                .map_err(|e| line("outputs", e))?
                .state;
            if state.messages == 0 {
                return Ok(Vec::new());
            }
            let stream = &stream;
            let got: Vec<_> =
                futures_util::stream::iter(state.first_sequence..=state.last_sequence)
                    .map(|seq| async move { stream.get_raw_message(seq).await })
                    .buffered(READS_IN_FLIGHT)
                    .collect()
                    .await;
            let mut out = Vec::with_capacity(got.len());
            for m in got {
                let m = match m {
                    Ok(m) => m,
                    // Aged out since the stream's state was read.
                    Err(e) if e.kind() == stream::LastRawMessageErrorKind::NoMessageFound => {
                        continue
                    }
                    Err(e) => return Err(line("outputs", e)),
                };
                out.push(Published {
                    subject: m.subject.to_string(),
                    msg_id: m
                        .headers
                        .get(async_nats::header::NATS_MESSAGE_ID)
                        .map(|v| v.to_string())
                        .unwrap_or_default(),
                    line: String::from_utf8_lossy(&m.payload).into_owned(),
                    stored: m.time.unix_timestamp_nanos() as f64 * 1e-9,
                });
            }
            Ok(out)
        };
        tokio::time::timeout(STATES_PATIENCE, read)
            .await
            .unwrap_or_else(|_| Err("outputs: timed out reading the stream".to_string()))
    }

    // ── telemetry in (a gateway) ────────────────────────────────────────────────────────

    /// Publishes one telemetry body of elevator `id` and waits until the stream stored it:
    /// its stream sequence. Its message id is the elevator and the digest of the body, so a
    /// retry within the stream's duplicate window (2 min) is not stored twice.
    ///
    /// # Errors
    /// One line from the server (no stream answers: the server has no partition mapping).
    pub async fn publish_telemetry(&self, id: &str, body: Bytes) -> Result<u64, String> {
        // The same body sent again (a retry after a lost acknowledgement) is stored once.
        let mut h = HeaderMap::new();
        h.insert(
            async_nats::header::NATS_MESSAGE_ID,
            format!("{id}:{}", digest(&body)).as_str(),
        );
        let ack = self
            .js
            .publish_with_headers(telemetry_subject(id), h, body)
            .await
            .map_err(|e| line("telemetry", e))?
            .await
            .map_err(|e| line("telemetry", e))?;
        Ok(ack.sequence)
    }

    // ── models ──────────────────────────────────────────────────────────────────────────

    /// Stores a model file (once per content) and makes it the active model of `id`: its
    /// version (the revision of `active.{id}`).
    ///
    /// # Errors
    /// One line from the server.
    pub async fn put_model(&self, id: &str, body: &[u8]) -> Result<u64, String> {
        let d = digest(body);
        let key = format!("body.{d}");
        if self
            .models
            .get(&key)
            .await
            .map_err(|e| line("model", e))?
            .is_none()
        {
            self.models
                .put(&key, Bytes::copy_from_slice(body))
                .await
                .map_err(|e| line("model", e))?;
        }
        self.models
            .put(format!("active.{id}"), Bytes::from(d))
            .await
            .map_err(|e| line("model", e))
    }

    /// The model file of digest `d`.
    ///
    /// # Errors
    /// One line: the server, or no such model.
    pub async fn model_body(&self, d: &str) -> Result<Bytes, String> {
        self.models
            .get(format!("body.{d}"))
            .await
            .map_err(|e| line("model", e))?
            .ok_or_else(|| format!("model {d} is not in the {MODELS} bucket"))
    }

    /// The active model of `id`: (digest, version).
    ///
    /// # Errors
    /// One line from the server.
    pub async fn active_model(&self, id: &str) -> Result<Option<(String, u64)>, String> {
        let e = self
            .models
            .entry(format!("active.{id}"))
            .await
            .map_err(|e| line("model", e))?;
        Ok(e.filter(|e| e.operation == kv::Operation::Put)
            .map(|e| (String::from_utf8_lossy(&e.value).into_owned(), e.revision)))
    }

    /// Each change of an active model from now on: (id, digest or `None` when deactivated,
    /// version). (A watch with history ends at once on an empty bucket in this client, so the
    /// current ones are read with [`Bus::active_models`] instead.)
    ///
    /// # Errors
    /// One line from the server.
    pub async fn watch_models(
        &self,
    ) -> Result<impl futures_util::Stream<Item = (String, Option<String>, u64)>, String> {
        let w = self
            .models
            .watch("active.*")
            .await
            .map_err(|e| line("models", e))?;
        Ok(w.filter_map(|e| async move { model_change(&e.ok()?) }))
    }

    /// Every elevator's active model now, as [`Bus::watch_models`] gives a change; read by key
    /// like [`Bus::states`].
    ///
    /// # Errors
    /// One line from the server.
    pub async fn active_models(&self) -> Result<Vec<(String, Option<String>, u64)>, String> {
        Ok(entries(&self.models, "active.")
            .await?
            .iter()
            .filter_map(model_change)
            .collect())
    }

    /// Every checkpoint (id → JSON), for tests and tools.
    ///
    /// # Errors
    /// One line from the server.
    ///
    /// The keys come from the stream's subject list and the values from direct gets,
    /// `READS_IN_FLIGHT` (64) at a time, for the reason given at [`Bus::members`]: a listing
    /// through a consumer can be placed on a dead server. (One `get` at a time, 10,000
    /// checkpoints did not come back within a minute.) The read gives up after
    /// [`STATES_PATIENCE`].
    pub async fn states(&self) -> Result<HashMap<String, Bytes>, String> {
        let read = async {
            Ok(entries(&self.state, "")
                .await?
                .into_iter()
                .filter(|e| e.operation == kv::Operation::Put)
                .map(|e| (e.key, e.value))
                .collect())
        };
        tokio::time::timeout(STATES_PATIENCE, read)
            .await
            .unwrap_or_else(|_| Err("state: timed out reading the checkpoints".to_string()))
    }

    /// Flushes what the client has buffered.
    pub async fn flush(&self) {
        let _ = self.client.flush().await;
    }
}

/// An entry of `active.{id}` as a change: (id, digest or `None` when deleted, version).
fn model_change(e: &kv::Entry) -> Option<(String, Option<String>, u64)> {
    let id = e.key.strip_prefix("active.")?.to_string();
    let d =
        (e.operation == kv::Operation::Put).then(|| String::from_utf8_lossy(&e.value).into_owned());
    Some((id, d, e.revision))
}

/// The latest entry of every key of bucket `kv` that starts with `prefix` (a deleted key's
/// marker too, while the bucket keeps it): the keys from [`subjects`], each read by direct
/// get, `READS_IN_FLIGHT` at a time.
async fn entries(kv: &kv::Store, prefix: &str) -> Result<Vec<kv::Entry>, String> {
    let got: Vec<_> = futures_util::stream::iter(subjects(kv, prefix).await?)
        .map(|k| async move { kv.entry(k.as_str()).await })
        .buffer_unordered(READS_IN_FLIGHT)
        .collect()
        .await;
    let mut out = Vec::with_capacity(got.len());
    for e in got {
        out.extend(e.map_err(|e| line(&kv.name, e))?);
    }
    Ok(out)
}

/// The keys of bucket `kv` that start with `prefix`, from its stream's subject list (a
/// deleted key whose marker is still kept is listed too).
async fn subjects(kv: &kv::Store, prefix: &str) -> Result<Vec<String>, String> {
    let what = kv.name.as_str();
    let mut list = kv
        .stream
        .info_with_subjects(format!("{}{prefix}>", kv.prefix))
        .await
        .map_err(|e| line(what, e))?;
    let mut keys = Vec::new();
    while let Some(s) = list.next().await {
        let (subject, _) = s.map_err(|e| line(what, e))?;
        if let Some(k) = subject.strip_prefix(kv.prefix.as_str()) {
            keys.push(k.to_string());
        }
    }
    Ok(keys)
}

/// The stream of `cfg`, made if missing (several workers may start together).
async fn ensure_stream(
    js: &jetstream::Context,
    cfg: stream::Config,
) -> Result<stream::Stream, String> {
    let name = cfg.name.clone();
    for _ in 0..5 {
        if let Ok(s) = js.get_stream(&name).await {
            return Ok(s);
        }
        match js.create_stream(cfg.clone()).await {
            Ok(s) => return Ok(s),
            Err(e) => {
                crate::log("warn", &line(&format!("stream {name}"), e));
                tokio::time::sleep(Duration::from_millis(500)).await;
            }
        }
    }
    Err(format!(
        "stream {name}: cannot be made (is JetStream enabled on the server?)"
    ))
}

/// The bucket of `cfg`, made if missing.
async fn ensure_bucket(
    js: &jetstream::Context,
    cfg: impl Fn() -> kv::Config,
) -> Result<kv::Store, String> {
    let name = cfg().bucket;
    for _ in 0..5 {
        if let Ok(s) = js.get_key_value(&name).await {
            return Ok(s);
        }
        match js.create_key_value(cfg()).await {
            Ok(s) => return Ok(s),
            Err(e) => {
                crate::log("warn", &line(&format!("bucket {name}"), e));
                tokio::time::sleep(Duration::from_millis(500)).await;
            }
        }
    }
    Err(format!(
        "bucket {name}: cannot be made (is JetStream enabled on the server?)"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subjects_and_mappings_read_as_documented() {
        assert_eq!(id_of_subject("liftwatch.part.3.lift-7"), Some("lift-7"));
        assert_eq!(id_of_subject("liftwatch.part.3"), None);
        assert_eq!(id_of_subject("liftwatch.telemetry.x"), None);
        assert_eq!(telemetry_subject("e1"), "liftwatch.telemetry.e1");
        let m = server_mappings(8);
        assert!(
            m.contains(
                "\"liftwatch.telemetry.*\": \"liftwatch.part.{{partition(8,1)}}.{{wildcard(1)}}\""
            ),
            "{m}"
        );
        assert_eq!(digest(b""), "cbf29ce484222325");
        assert_ne!(digest(b"a"), digest(b"b"));
    }
}
