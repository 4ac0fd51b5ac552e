//! The store: one SQLite database in WAL mode, `DATA/liftwatch.db`.
//!
//! ```text
//! elevators    id, name, group, rated values, timezone, rebaseline generation
//! batches      seq (autoincrement), elevator, received, t range, rows, data (17 bytes a reading)
//! checkpoints  elevator, applied_seq, model_version, rebaseline_gen, aligner + monitor state
//! trips        elevator, seq, start, end, the trip row as `monitor --rows trip` writes it
//! events       elevator, seq, time, level, the events.jsonl line, label
//! models       elevator, version, created, source, note, fingerprint, status, active, body
//! maintenance  elevator, time, work, finding, rebaseline, created
//! ```
//!
//! A telemetry request's good rows become ONE batch, committed before the HTTP 200, so a
//! confirmed request is durable. The worker writes its outputs (trips, events) and its
//! checkpoint in one transaction, so the outputs always belong to the checkpoint: a restart
//! resumes from it and re-applies the later batches.

use liftwatch::sample::DAY_S;
use std::path::Path;
use std::time::Duration;

use liftwatch::ingest::Signal;
use rusqlite::{params, Connection, OptionalExtension};

/// Name of the database file inside `--data`.
pub const DB_FILE: &str = "liftwatch.db";

/// How long a connection waits for another's write lock before giving up: the worker's
/// checkpoint transactions take milliseconds, so this is a wide margin.
const BUSY_TIMEOUT: Duration = Duration::from_secs(10);

/// Bytes of one reading in a batch: signal (1), time (8), value (8), little-endian.
pub const READING_BYTES: usize = 17;

/// The schema, created when missing.
const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS elevators (
    id TEXT PRIMARY KEY,
    info TEXT NOT NULL,
    created REAL NOT NULL,
    rebaseline_gen INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS batches (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    elevator TEXT NOT NULL,
    received REAL NOT NULL,
    t_min REAL,
    t_max REAL,
    rows INTEGER NOT NULL,
    data BLOB NOT NULL
);
CREATE INDEX IF NOT EXISTS batches_by_elevator ON batches(elevator, seq);
CREATE TABLE IF NOT EXISTS checkpoints (
    elevator TEXT PRIMARY KEY,
    applied_seq INTEGER NOT NULL,
    model_version INTEGER,
    rebaseline_gen INTEGER NOT NULL,
    aligner TEXT NOT NULL,
    monitor TEXT,
    counters TEXT NOT NULL,
    updated REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS trips (
    elevator TEXT NOT NULL,
    seq INTEGER NOT NULL,
    start REAL NOT NULL,
    end_time REAL NOT NULL,
    row TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS trips_by_elevator ON trips(elevator, start);
CREATE TABLE IF NOT EXISTS events (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    elevator TEXT NOT NULL,
    seq INTEGER NOT NULL,
    time REAL NOT NULL,
    level TEXT NOT NULL,
    line TEXT NOT NULL,
    label TEXT
);
CREATE INDEX IF NOT EXISTS events_by_elevator ON events(elevator, id);
CREATE TABLE IF NOT EXISTS models (
    elevator TEXT NOT NULL,
    version INTEGER NOT NULL,
    created REAL NOT NULL,
    source TEXT NOT NULL,
    note TEXT,
    fingerprint TEXT,
    status TEXT NOT NULL,
    active INTEGER NOT NULL DEFAULT 0,
    body TEXT,
    PRIMARY KEY (elevator, version)
);
CREATE TABLE IF NOT EXISTS maintenance (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    elevator TEXT NOT NULL,
    time REAL NOT NULL,
    work TEXT NOT NULL,
    finding TEXT NOT NULL,
    rebaseline INTEGER NOT NULL,
    labelled INTEGER NOT NULL,
    created REAL NOT NULL
);
";

/// Opens (creating when missing) the database in `dir`, WAL mode, schema in place.
///
/// # Errors
/// SQLite's error, as one line.
pub fn open(dir: &Path) -> Result<Connection, String> {
    let path = dir.join(DB_FILE);
    let mut conn = Connection::open(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    // Every transaction takes the write lock when it begins: a deferred one that reads first
    // and writes later fails at once (SQLITE_BUSY, no waiting) when another connection wrote
    // in between.
    conn.set_transaction_behavior(rusqlite::TransactionBehavior::Immediate);
    conn.busy_timeout(BUSY_TIMEOUT).map_err(|e| e.to_string())?;
    // WAL: readers never block the writer; synchronous=FULL: a commit is on disk when it
    // returns (a confirmed request survives a power cut, not only a kill).
    conn.pragma_update(None, "journal_mode", "WAL")
        .map_err(|e| format!("{}: cannot use WAL mode: {e}", path.display()))?;
    conn.pragma_update(None, "synchronous", "FULL")
        .map_err(|e| e.to_string())?;
    conn.pragma_update(None, "foreign_keys", "ON")
        .map_err(|e| e.to_string())?;
    conn.execute_batch(SCHEMA)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(conn)
}

/// Seconds since the Unix epoch, the wall clock of `received`, `created`, `updated`.
pub fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Packs readings as [`READING_BYTES`] each.
pub fn encode(readings: &[(Signal, f64, f64)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(readings.len() * READING_BYTES);
    for (sig, t, v) in readings {
        out.push(sig.index() as u8);
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Unpacks a batch; a damaged blob gives the readings before the damage and `false`.
pub fn decode(data: &[u8]) -> (Vec<(Signal, f64, f64)>, bool) {
    let mut out = Vec::with_capacity(data.len() / READING_BYTES);
    for chunk in data.chunks(READING_BYTES) {
        let Ok(bytes) = <[u8; READING_BYTES]>::try_from(chunk) else {
            return (out, false);
        };
        let Some(sig) = Signal::ALL.get(usize::from(bytes[0])) else {
            return (out, false);
        };
        let num = |i: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[i..i + 8]);
            f64::from_le_bytes(b)
        };
        out.push((*sig, num(1), num(9)));
    }
    (out, true)
}

/// Whether the elevator is known.
///
/// # Errors
/// SQLite's error.
pub fn elevator_exists(conn: &Connection, id: &str) -> rusqlite::Result<bool> {
    conn.query_row("SELECT 1 FROM elevators WHERE id = ?1", [id], |_| Ok(()))
        .optional()
        .map(|r| r.is_some())
}

/// Number of elevators.
///
/// # Errors
/// SQLite's error.
pub fn elevator_count(conn: &Connection) -> rusqlite::Result<usize> {
    conn.query_row("SELECT COUNT(*) FROM elevators", [], |r| r.get::<_, i64>(0))
        .map(|n| usize::try_from(n).unwrap_or(0))
}

/// Creates or replaces the description of an elevator (its generation is kept).
///
/// # Errors
/// SQLite's error.
pub fn put_elevator(conn: &Connection, id: &str, info_json: &str) -> rusqlite::Result<()> {
    conn.execute(
        "INSERT INTO elevators (id, info, created) VALUES (?1, ?2, ?3)
         ON CONFLICT(id) DO UPDATE SET info = excluded.info",
        params![id, info_json, now()],
    )
    .map(|_| ())
}

/// Appends one batch; returns its seq.
///
/// # Errors
/// SQLite's error.
pub fn append_batch(
    conn: &Connection,
    id: &str,
    readings: &[(Signal, f64, f64)],
) -> rusqlite::Result<i64> {
    let (lo, hi) = readings
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
            (lo.min(r.1), hi.max(r.1))
        });
    conn.execute(
        "INSERT INTO batches (elevator, received, t_min, t_max, rows, data) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
        params![id, now(), lo, hi, readings.len() as i64, encode(readings)],
    )?;
    Ok(conn.last_insert_rowid())
}

/// Deletes raw batches already applied and older than `keep_days`; returns how many.
///
/// # Errors
/// SQLite's error.
pub fn prune(conn: &Connection, keep_days: f64) -> rusqlite::Result<usize> {
    conn.execute(
        "DELETE FROM batches WHERE received < ?1 AND seq <= COALESCE(
             (SELECT applied_seq FROM checkpoints c WHERE c.elevator = batches.elevator), 0)",
        params![now() - keep_days * DAY_S],
    )
}

/// Marks the fits a stop interrupted (`fitting` at start-up: their thread is gone) as
/// `failed`; returns how many.
///
/// # Errors
/// SQLite's error.
pub fn fail_interrupted_fits(conn: &Connection) -> rusqlite::Result<usize> {
    conn.execute(
        "UPDATE models SET status = 'failed', note = COALESCE(note, '') || '; interrupted: the service stopped during the fit'
         WHERE status = 'fitting'",
        [],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pruning_removes_only_old_applied_batches() {
        let dir = std::env::temp_dir().join(format!("liftwatch-store-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let conn = open(&dir).unwrap();
        put_elevator(&conn, "a", "{}").unwrap();
        let r = [(Signal::Speed, 1.0, 0.0)];
        let first = append_batch(&conn, "a", &r).unwrap();
        append_batch(&conn, "a", &r).unwrap();
        conn.execute(
            "INSERT INTO checkpoints (elevator, applied_seq, rebaseline_gen, aligner, counters, updated) VALUES ('a', ?1, 0, '{}', '{}', 0)",
            [first],
        )
        .unwrap();
        assert_eq!(prune(&conn, 1.0).unwrap(), 0, "younger than a day");
        assert_eq!(prune(&conn, 0.0).unwrap(), 1, "only the applied one");
        let left: i64 = conn
            .query_row("SELECT MIN(seq) FROM batches", [], |r| r.get(0))
            .unwrap();
        assert!(left > first);
        drop(conn);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn batches_round_trip_bit_for_bit_and_damage_is_seen() {
        let r = vec![
            (Signal::Speed, 1.25, -0.0),
            (Signal::Door, 1e9 + 0.1, 1.0),
            (Signal::Current, -3.0, f64::MAX),
        ];
        let data = encode(&r);
        assert_eq!(data.len(), 3 * READING_BYTES);
        let (back, ok) = decode(&data);
        assert!(ok);
        assert_eq!(format!("{back:?}"), format!("{r:?}"));
        let (part, ok) = decode(&data[..40]);
        assert!(!ok);
        assert_eq!(part.len(), 2);
    }
}
