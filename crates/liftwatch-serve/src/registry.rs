//! Model management and the stored outputs: telemetry parsing, the model registry (upload,
//! activate, rollback, fit from history), maintenance visits, the row and event lists and the
//! metrics text.
//!
//! ```text
//! upload    file::load_str (the CLI's checks) → version n+1, `ready`; the first is activated
//! activate  one active version per elevator; the worker restarts the monitor from a fresh
//!           state of it at the stream position it has reached (a rollback is an activation)
//! fit       stored raw batches of [from, to] → Aligner → a spill in --data → fit::fit in a
//!           thread → `proposed`
//! visit     labels the open events confirmed / not_found; rebaseline → fresh monitor state
//! ```

use liftwatch::sample::DAY_S;
use std::collections::HashMap;
use std::io::Cursor;
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Arc;

use axum::http::StatusCode;
use liftwatch::align::{AlignConfig, Aligner, SpillSink};
use liftwatch::ingest::csv::RowReader;
use liftwatch::ingest::{IngestReport, Layout, Signal};
use rusqlite::{params, Connection, OptionalExtension};
use serde::Deserialize;
use serde_json::{json, Map, Value};

use crate::config::{one_line, ElevatorInfo};
use crate::error::ApiError;
use crate::{log, store, Shared};

/// The raw header the row parser needs; prepended when a body comes without it.
const RAW_HEADER: &str = "time,signal,value\n";

/// Name of a request body in messages.
const BODY_NAME: &str = "request body";

/// The good readings of a telemetry body and what was skipped.
#[derive(Debug, Default)]
pub struct Parsed {
    /// Readings in body order.
    pub readings: Vec<(Signal, f64, f64)>,
    /// Bad rows skipped.
    pub bad: u64,
    /// Rows with an empty value (not readings, not bad).
    pub missing: u64,
    /// Rows of unknown signals.
    pub unknown: u64,
    /// Line of the first bad row.
    pub first_bad_line: Option<u64>,
    /// Why it was bad.
    pub first_bad_reason: Option<String>,
}

/// Parses a telemetry body with the library's row parser (CSV `time,signal,value`, header
/// optional; or JSON lines turned into those rows first).
///
/// # Errors
/// 413 for more rows than `max_rows`; 400 for a body with no good row, or of the aligned
/// layout.
pub fn parse_telemetry(body: &[u8], ndjson: bool, max_rows: usize) -> Result<Parsed, ApiError> {
    // Rows: the lines that hold anything, the header line left out (the final line break
    // and blank lines are no rows).
    let mut segments = body.split(|&b| b == b'\n');
    let first = segments
        .next()
        .map(|l| l.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(l).trim_ascii())
        .unwrap_or(b"");
    let header = first.len() >= 4 && first[..4].eq_ignore_ascii_case(b"time");
    let rows = usize::from(!header && !first.is_empty())
        + segments.filter(|l| !l.trim_ascii().is_empty()).count();
    if rows > max_rows {
        return Err(ApiError(
            StatusCode::PAYLOAD_TOO_LARGE,
            format!(
                "{rows} rows, more than the {max_rows} a request may carry (max_rows_per_request)"
            ),
        ));
    }
    let mut pre = Parsed::default();
    // For JSON lines, the body's line of each CSV row (the CSV's line k + 2 is `origin[k]`):
    // the lines that are no object and the blank ones have no row.
    let mut origin = Vec::new();
    let text: Vec<u8> = if ndjson {
        json_lines_to_csv(body, &mut pre, &mut origin)
    } else {
        let first = body.split(|&b| b == b'\n').next().unwrap_or(b"");
        let first = first.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(first);
        if first
            .trim_ascii()
            .to_ascii_lowercase()
            .starts_with(b"time,")
        {
            body.to_vec()
        } else {
            let mut t = RAW_HEADER.as_bytes().to_vec();
            t.extend_from_slice(body);
            t
        }
    };
    let mut rows = RowReader::new(Cursor::new(&text), Path::new(BODY_NAME))
        .map_err(|e| ApiError::bad(e.to_string()))?;
    if rows.layout() != Layout::Raw {
        return Err(ApiError::bad(
            "aligned rows are not accepted here: send the raw `time,signal,value` rows",
        ));
    }
    let mut report = IngestReport::new(Layout::Raw);
    let mut readings = Vec::new();
    let mut lines = Vec::new();
    rows.for_each_reading::<liftwatch::Error>(&mut report, |t, sig, v, line| {
        readings.push((sig, t, v));
        lines.push(line);
        Ok(ControlFlow::Continue(()))
    })
    .map_err(|e| ApiError::bad(e.to_string()))?;
    let shift = u64::from(!ndjson && text.len() != body.len());
    // A line of the text read, as a line of the body as sent.
    let body_line = |l: u64| {
        if ndjson {
            let k = usize::try_from(l.saturating_sub(2)).unwrap_or(usize::MAX);
            origin.get(k).copied().unwrap_or(l)
        } else {
            l - shift
        }
    };
    let isolated = isolated_in_time(&readings);
    if let Some(&first) = isolated.first() {
        report.bad_rows += isolated.len() as u64;
        let line = lines[first];
        if report.first_bad_lines.first().map_or(true, |&l| line < l) {
            report.first_bad_lines.insert(0, line);
            report.first_bad_reason = Some(format!(
                "line {line}: time {} s is more than {ISOLATION_S} s from the rest of the batch, with fewer than {ISOLATION_COMPANIONS} readings near it: a clock glitch, not telemetry",
                liftwatch::error::number(readings[first].1)
            ));
        }
        let mut keep = vec![true; readings.len()];
        for &i in &isolated {
            keep[i] = false;
        }
        let mut k = keep.iter();
        readings.retain(|_| *k.next().unwrap_or(&true));
    }
    // The first bad line of the body: a JSON line that was no object, or a row the library
    // refused, whichever comes first. The library's reason opens with `line N: ` counted in
    // the text it read: dropped, the line is `first_bad_line`, counted in the body as sent.
    let library = report.first_bad_lines.first().map(|&l| {
        let why = report.first_bad_reason.as_deref().map(strip_line_prefix);
        (body_line(l), why.map(str::to_string))
    });
    let (first_bad_line, first_bad_reason) = match (pre.first_bad_line, library) {
        (Some(p), Some((l, why))) if l < p => (Some(l), why),
        (Some(p), _) => (Some(p), pre.first_bad_reason.take()),
        (None, Some((l, why))) => (Some(l), why),
        (None, None) => (None, None),
    };
    let mut out = Parsed {
        readings,
        bad: report.bad_rows + pre.bad,
        missing: report.missing_values,
        unknown: report.unknown_rows(),
        first_bad_line,
        first_bad_reason,
    };
    if out.readings.is_empty() {
        let why = match (&out.first_bad_line, &out.first_bad_reason) {
            (Some(l), Some(r)) => format!("no good row ({} bad; first at line {l}: {r})", out.bad),
            _ if out.unknown > 0 => {
                format!("no good row ({} rows of unknown signals)", out.unknown)
            }
            _ => "no good row: expected `time,signal,value` rows".to_string(),
        };
        return Err(ApiError::bad(why));
    }
    out.first_bad_reason = out.first_bad_reason.map(|r| one_line(&r));
    Ok(out)
}

/// How far a reading's time may lie from the batch's median before it needs company (s): the
/// alignment's reorder window, within which it sorts readings anyway.
const ISOLATION_S: f64 = 600.0;

/// Other readings within [`ISOLATION_S`] that make a far-off reading telemetry rather than a
/// clock glitch: the first seconds after a logger's restart bring several at once.
const ISOLATION_COMPANIONS: usize = 2;

/// Readings a batch needs before a reading is judged against it.
const ISOLATION_MIN_BATCH: usize = 20;

/// The indices (in body order) of readings far from the batch's median time with fewer than
/// [`ISOLATION_COMPANIONS`] others near them. One such reading (a gateway's clock glitch, a
/// bit flip in a timestamp) was accepted, moved the alignment's clock to itself, and made
/// every later row of the elevator late, acknowledged and dropped, until real time caught up.
fn isolated_in_time(readings: &[(Signal, f64, f64)]) -> Vec<usize> {
    if readings.len() < ISOLATION_MIN_BATCH {
        return Vec::new();
    }
    let mut times: Vec<f64> = readings.iter().map(|r| r.1).collect();
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    let near = |t: f64| {
        let lo = times.partition_point(|&x| x < t - ISOLATION_S);
        let hi = times.partition_point(|&x| x <= t + ISOLATION_S);
        hi - lo - 1
    };
    readings
        .iter()
        .enumerate()
        .filter(|(_, r)| (r.1 - median).abs() > ISOLATION_S && near(r.1) < ISOLATION_COMPANIONS)
        .map(|(i, _)| i)
        .collect()
}

/// `why` without a leading `line N: `.
fn strip_line_prefix(why: &str) -> &str {
    why.strip_prefix("line ")
        .and_then(|r| r.split_once(": "))
        .filter(|(n, _)| n.bytes().all(|b| b.is_ascii_digit()))
        .map_or(why, |(_, rest)| rest)
}

/// JSON lines `{"time":…,"signal":…,"value":…}` as raw CSV rows; a line that is not such an
/// object is counted bad (its line number kept) and left out.
/// `origin` gets the body's line (from 1) of each row written.
fn json_lines_to_csv(body: &[u8], p: &mut Parsed, origin: &mut Vec<u64>) -> Vec<u8> {
    let mut out = RAW_HEADER.as_bytes().to_vec();
    for (i, line) in body.split(|&b| b == b'\n').enumerate() {
        if line.trim_ascii().is_empty() {
            continue;
        }
        let field = |v: &Value| match v {
            Value::Number(n) => Some(n.to_string()),
            Value::String(s) if !s.contains([',', '"', '\n', '\r']) => Some(s.clone()),
            Value::Null => Some(String::new()),
            _ => None,
        };
        let row = serde_json::from_slice::<Value>(line).ok().and_then(|v| {
            Some(format!(
                "{},{},{}\n",
                field(v.get("time")?)?,
                field(v.get("signal")?)?,
                field(v.get("value").unwrap_or(&Value::Null))?
            ))
        });
        match row {
            Some(r) => {
                out.extend_from_slice(r.as_bytes());
                origin.push(i as u64 + 1);
            }
            None => {
                p.bad += 1;
                if p.first_bad_line.is_none() {
                    p.first_bad_line = Some(i as u64 + 1);
                    p.first_bad_reason =
                        Some("not a JSON object with `time`, `signal` and `value`".into());
                }
            }
        }
    }
    out
}

/// Version, created, source, note, fingerprint, status, active of a stored model.
type ModelRow = (
    i64,
    f64,
    String,
    Option<String>,
    Option<String>,
    String,
    bool,
    Option<String>,
);

fn model_rows(conn: &Connection, id: &str) -> rusqlite::Result<Vec<ModelRow>> {
    let mut st = conn.prepare(
        "SELECT version, created, source, note, fingerprint, status, active, body FROM models
         WHERE elevator = ?1 ORDER BY version",
    )?;
    let rows = st
        .query_map([id], |r| {
            Ok((
                r.get(0)?,
                r.get(1)?,
                r.get(2)?,
                r.get(3)?,
                r.get(4)?,
                r.get(5)?,
                r.get::<_, i64>(6)? != 0,
                r.get(7)?,
            ))
        })?
        .collect();
    rows
}

/// The fitted physical parameters of a model document: `{name: {value, std_error, unit,
/// determined, corrected}}` (`corrected`: the value with the speed noise taken out, null when
/// the fit measured none).
fn parameters(body: &str) -> Value {
    let Ok(doc) = serde_json::from_str::<Value>(body) else {
        return Value::Null;
    };
    let mut out = serde_json::Map::new();
    if let Some(list) = doc.pointer("/fit/parameters").and_then(Value::as_array) {
        for p in list {
            if let Some(name) = p.get("name").and_then(Value::as_str) {
                out.insert(
                    name.to_string(),
                    json!({
                        "value": p.get("value"),
                        "std_error": p.get("std_error"),
                        "unit": p.get("unit"),
                        "determined": p.get("determined"),
                        "corrected": p.get("corrected"),
                    }),
                );
            }
        }
    }
    Value::Object(out)
}

fn model_json(r: &ModelRow, params: &Value) -> Value {
    json!({
        "version": r.0,
        "created": r.1,
        "source": r.2,
        "note": r.3,
        "fingerprint": r.4,
        "status": r.5,
        "active": r.6,
        "parameters": params,
    })
}

/// Why the model of car `e` is not of the car the description `info` of `id` names; `None`
/// where every value the description gives agrees.
fn other_car(info: &ElevatorInfo, e: &liftwatch::Elevator, id: &str) -> Option<String> {
    let differs = |stored: Option<f64>, model: f64| {
        stored.is_some_and(|v| (v - model).abs() > 1e-6 * v.abs().max(1.0))
    };
    let other = differs(info.rated_load_kg, e.rated_load_kg)
        || differs(info.rated_speed_mps, e.rated_speed_mps)
        || info.floors.is_some_and(|f| f != e.floors);
    other.then(|| {
        format!(
            "the model is of a {} kg, {} m/s, {}-floor car; `{id}` is {} kg, {} m/s, {} floors",
            e.rated_load_kg,
            e.rated_speed_mps,
            e.floors,
            info.rated_load_kg.map_or("?".into(), |v| v.to_string()),
            info.rated_speed_mps.map_or("?".into(), |v| v.to_string()),
            info.floors.map_or("?".into(), |v| v.to_string()),
        )
    })
}

/// Refuses a new description `info` of `id` that names another car than its active model's
/// (409): the monitor would go on watching with the model of a car the elevator no longer
/// is. Deploy a model of the new car first, or describe the car its model is of.
///
/// # Errors
/// 409 naming both cars; the database's as 500.
pub fn check_description(conn: &Connection, id: &str, info: &ElevatorInfo) -> Result<(), ApiError> {
    let rows = model_rows(conn, id).map_err(|e| ApiError::internal(format!("database: {e}")))?;
    let Some(body) = rows.iter().find(|r| r.6).and_then(|r| r.7.as_deref()) else {
        return Ok(());
    };
    let Ok(model) = liftwatch::file::load_str(body, std::path::Path::new("active model")) else {
        return Ok(());
    };
    match other_car(info, &model.hybrid.elevator, id) {
        Some(why) => Err(ApiError(
            axum::http::StatusCode::CONFLICT,
            format!(
                "{why}: the active model is of the other car; deploy a model of this one first"
            ),
        )),
        None => Ok(()),
    }
}

/// The active model's description, `None` without one.
///
/// # Errors
/// The database's, as one line.
pub fn active_model_json(conn: &Connection, id: &str) -> Result<Option<Value>, String> {
    let rows = model_rows(conn, id).map_err(|e| e.to_string())?;
    Ok(rows.iter().find(|r| r.6).map(|r| {
        let p = r.7.as_deref().map_or(Value::Null, parameters);
        model_json(r, &p)
    }))
}

/// Every version with its parameter changes in percent against the active one.
///
/// # Errors
/// The database's, as one line.
pub fn model_list(conn: &Connection, id: &str) -> Result<Vec<Value>, String> {
    let rows = model_rows(conn, id).map_err(|e| e.to_string())?;
    let params: Vec<Value> = rows
        .iter()
        .map(|r| r.7.as_deref().map_or(Value::Null, parameters))
        .collect();
    let active = rows.iter().position(|r| r.6).map(|i| &params[i]);
    Ok(rows
        .iter()
        .zip(&params)
        .map(|(r, p)| {
            let mut v = model_json(r, p);
            let mut changes = serde_json::Map::new();
            if let (Some(Value::Object(a)), Value::Object(this)) = (active, p) {
                for (name, x) in this {
                    let new = x["value"].as_f64();
                    let old = a.get(name).and_then(|o| o["value"].as_f64());
                    let pct = match (new, old) {
                        (Some(n), Some(o)) if o != 0.0 => {
                            serde_json::Number::from_f64(100.0 * (n - o) / o.abs())
                                .map(Value::Number)
                        }
                        _ => None,
                    };
                    changes.insert(name.clone(), pct.unwrap_or(Value::Null));
                }
            }
            v["changes"] = Value::Object(changes);
            v
        })
        .collect())
}

/// Stores an uploaded model file after the CLI's checks; the elevator's first model is
/// activated at once.
///
/// # Errors
/// 400 for a file `liftwatch fit` did not write (wrong version, garbage, insane values) or of
/// another aligned step than the service's; nothing is stored then.
pub fn upload(
    conn: &Connection,
    id: &str,
    text: &str,
    source: &str,
    note: Option<&str>,
) -> Result<Value, ApiError> {
    let model = liftwatch::file::load_str(text, Path::new("uploaded model"))
        .map_err(|e| ApiError::bad(e.to_string()))?;
    let step = AlignConfig::default().step_s;
    if let Some(s) = model.step_s {
        if s != step {
            return Err(ApiError::bad(format!(
                "the model was fitted at a {s} s step; this service aligns at {step} s"
            )));
        }
    }
    // A model describes its elevator; one fitted for another car is refused where the stored
    // description says otherwise (a 630 kg model had been accepted for a 1000 kg car).
    let info: Option<String> = conn
        .query_row("SELECT info FROM elevators WHERE id = ?1", [id], |r| {
            r.get(0)
        })
        .optional()
        .map_err(|e| ApiError::internal(format!("database: {e}")))?;
    let info: ElevatorInfo = info
        .and_then(|i| serde_json::from_str(&i).ok())
        .unwrap_or_default();
    if let Some(why) = other_car(&info, &model.hybrid.elevator, id) {
        return Err(ApiError::bad(why));
    }
    let fingerprint = liftwatch::file::model_id(&model);
    store_model(
        conn,
        id,
        Some(text),
        &fingerprint,
        "ready",
        source,
        note,
        true,
    )
    .map_err(|e| ApiError::internal(format!("database: {e}")))
}

/// Inserts a model version (and the elevator if new); activates it when `activate_if_first`
/// and no version is active.
#[allow(clippy::too_many_arguments)]
fn store_model(
    conn: &Connection,
    id: &str,
    body: Option<&str>,
    fingerprint: &str,
    status: &str,
    source: &str,
    note: Option<&str>,
    activate_if_first: bool,
) -> rusqlite::Result<Value> {
    let tx = conn.unchecked_transaction()?;
    if !store::elevator_exists(&tx, id)? {
        store::put_elevator(&tx, id, "{}")?;
    }
    let version: i64 = tx.query_row(
        "SELECT COALESCE(MAX(version), 0) + 1 FROM models WHERE elevator = ?1",
        [id],
        |r| r.get(0),
    )?;
    let none_active: bool = tx.query_row(
        "SELECT COUNT(*) = 0 FROM models WHERE elevator = ?1 AND active = 1",
        [id],
        |r| r.get(0),
    )?;
    let active = activate_if_first && none_active;
    tx.execute(
        "INSERT INTO models (elevator, version, created, source, note, fingerprint, status, active, body)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
        params![id, version, store::now(), source, note, fingerprint, status, active, body],
    )?;
    tx.commit()?;
    Ok(
        json!({"id": id, "version": version, "fingerprint": fingerprint, "active": active, "status": status}),
    )
}

/// Makes `version` the active model (activation and rollback alike).
///
/// # Errors
/// 404 for an unknown version; 409 for one still fitting or failed.
pub fn activate(conn: &Connection, id: &str, version: i64) -> Result<(), ApiError> {
    let status: Option<String> = conn
        .query_row(
            "SELECT status FROM models WHERE elevator = ?1 AND version = ?2",
            params![id, version],
            |r| r.get(0),
        )
        .optional()
        .map_err(|e| ApiError::internal(format!("database: {e}")))?;
    match status.as_deref() {
        None => Err(ApiError::not_found(format!(
            "elevator `{id}` has no model {version}"
        ))),
        Some("ready" | "proposed") => {
            let tx = conn
                .unchecked_transaction()
                .map_err(|e| ApiError::internal(e.to_string()))?;
            tx.execute("UPDATE models SET active = 0 WHERE elevator = ?1", [id])
                .and_then(|_| {
                    tx.execute(
                        "UPDATE models SET active = 1, status = 'ready' WHERE elevator = ?1 AND version = ?2",
                        params![id, version],
                    )
                })
                .and_then(|_| tx.commit())
                .map_err(|e| ApiError::internal(format!("database: {e}")))
        }
        Some(other) => Err(ApiError(
            StatusCode::CONFLICT,
            format!("model {version} is `{other}`, not a model that can run"),
        )),
    }
}

/// `POST …/fit`: the time range of stored telemetry to fit on, and a note.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitRequest {
    /// Start of the healthy range (data clock, s); default the oldest stored.
    pub from: Option<f64>,
    /// End (s); default the newest stored.
    pub to: Option<f64>,
    /// Why this fit.
    pub note: Option<String>,
    /// Iterations of the hybrid stage (default the CLI's `fit` default), at most
    /// [`MAX_FIT_EPOCHS`].
    pub epochs: Option<usize>,
}

/// Most iterations a fit request may ask for: the largest Adam schedule the CLI documents.
pub const MAX_FIT_EPOCHS: usize = 20_000;

/// Longest span of stored telemetry one fit aligns (s): 31 days, about 2.7 M samples at 1 s
/// and half a GB of fit (180 bytes a sample). The span is the times', not the data's: one
/// reading a hundred days off had a fit of an hour's data take 1.6 GB.
pub const MAX_FIT_SPAN_S: f64 = 31.0 * DAY_S;

/// Longest note a fit request may carry (characters).
const MAX_NOTE_CHARS: usize = 1000;

/// Fits run one at a time: each holds its series and features in memory, and the service's
/// memory should not grow with the number of requests.
static ONE_FIT: std::sync::Mutex<()> = std::sync::Mutex::new(());

impl FitRequest {
    /// 400 for a request the fit would refuse later: epochs beyond [`MAX_FIT_EPOCHS`], a
    /// range that ends before it starts or is not a number, a note beyond a thousand
    /// characters.
    fn check(&self) -> Result<(), ApiError> {
        if let Some(n) = self.epochs {
            if n > MAX_FIT_EPOCHS {
                return Err(ApiError::bad(format!(
                    "epochs {n} is more than {MAX_FIT_EPOCHS}"
                )));
            }
        }
        for (name, t) in [("from", self.from), ("to", self.to)] {
            if t.is_some_and(|t| !t.is_finite()) {
                return Err(ApiError::bad(format!("`{name}` is not a finite time")));
            }
        }
        if let (Some(a), Some(b)) = (self.from, self.to) {
            if a > b {
                return Err(ApiError::bad(format!(
                    "`from` {} is after `to` {}",
                    liftwatch::error::number(a),
                    liftwatch::error::number(b)
                )));
            }
        }
        if self
            .note
            .as_ref()
            .is_some_and(|n| n.chars().count() > MAX_NOTE_CHARS)
        {
            return Err(ApiError::bad(format!(
                "the note is longer than {MAX_NOTE_CHARS} characters"
            )));
        }
        Ok(())
    }
}

/// Registers a `fitting` version and fits it in a background thread from the stored raw
/// batches of the range; the version becomes `proposed` (or `failed`, with the reason in its
/// note). Returns the version.
///
/// # Errors
/// 404 for an unknown elevator; 400 without the rated values to describe it.
pub fn start_fit(shared: Arc<Shared>, id: &str, req: FitRequest) -> Result<i64, ApiError> {
    req.check()?;
    let db = |e: rusqlite::Error| ApiError::internal(format!("database: {e}"));
    let conn = shared
        .writer
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let info: Option<String> = conn
        .query_row("SELECT info FROM elevators WHERE id = ?1", [id], |r| {
            r.get(0)
        })
        .optional()
        .map_err(db)?;
    let info: ElevatorInfo = serde_json::from_str(
        &info.ok_or_else(|| ApiError::not_found(format!("no elevator `{id}`")))?,
    )
    .unwrap_or_default();
    // The description: the active model's, else the stored rated values.
    let active_body: Option<String> = conn
        .query_row(
            "SELECT body FROM models WHERE elevator = ?1 AND active = 1",
            [id],
            |r| r.get(0),
        )
        .optional()
        .map_err(db)?
        .flatten();
    let elevator = match active_body.and_then(|b| liftwatch::file::load_str(&b, Path::new("active model")).ok()) {
        Some(m) => m.hybrid.elevator,
        None => match (info.rated_load_kg, info.rated_speed_mps, info.floors) {
            (Some(l), Some(s), Some(f)) => {
                let mut e = liftwatch::Elevator::new(l, s, f);
                e.name = info.name.clone();
                e.timezone = info.timezone.clone();
                e
            }
            _ => {
                return Err(ApiError::bad(
                    "no active model and no rated_load_kg, rated_speed_mps and floors (PUT the elevator first)",
                ))
            }
        },
    };
    let note = req
        .note
        .clone()
        .unwrap_or_else(|| "fit from stored telemetry".into());
    let v = store_model(&conn, id, None, "", "fitting", "fit", Some(&note), false).map_err(db)?;
    drop(conn);
    let version = v["version"].as_i64().unwrap_or(0);
    let id = id.to_string();
    std::thread::Builder::new()
        .name("liftwatch-fit".into())
        .spawn(move || {
            let result = {
                let _one = ONE_FIT.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                fit_from_history(&shared, &id, &req, &elevator)
            };
            let conn = shared.writer.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let done = match result {
                Ok((text, fp, summary)) => conn.execute(
                    "UPDATE models SET status = 'proposed', body = ?3, fingerprint = ?4, note = ?5 WHERE elevator = ?1 AND version = ?2",
                    params![id, version, text, fp, format!("{note}; {summary}")],
                ),
                Err(why) => {
                    log("warn", &format!("elevator {id}: fit of model {version} failed: {why}"));
                    conn.execute(
                        "UPDATE models SET status = 'failed', note = ?3 WHERE elevator = ?1 AND version = ?2",
                        params![id, version, one_line(&why)],
                    )
                }
            };
            if let Err(e) = done {
                log("error", &format!("elevator {id}: cannot record the fit of model {version}: {e}"));
            }
        })
        .map_err(|e| ApiError::internal(format!("cannot start the fit: {e}")))?;
    Ok(version)
}

/// Reorder window of a fit from history (s): the stored batches are in arrival order, as a
/// file is, so the file default applies.
const FIT_REORDER_WINDOW_S: f64 = 600.0;

fn fit_from_history(
    shared: &Shared,
    id: &str,
    req: &FitRequest,
    elevator: &liftwatch::Elevator,
) -> Result<(String, String, String), String> {
    let (lo, hi) = (
        req.from.unwrap_or(f64::NEG_INFINITY),
        req.to.unwrap_or(f64::INFINITY),
    );
    let cfg = AlignConfig::default()
        .with_reorder_window(FIT_REORDER_WINDOW_S)
        .map_err(|e| e.to_string())?;
    let mut aligner = Aligner::new(&cfg).map_err(|e| e.to_string())?;
    // The aligned samples wait on disk for the fit's passes, beside the store: a month of
    // them held in memory is 166 MB per fit under way.
    let mut samples = SpillSink::new_in(&shared.data_dir).map_err(|e| e.to_string())?;
    let (mut first, mut last) = (f64::INFINITY, f64::NEG_INFINITY);
    shared.read(|c| {
        let mut st = c
            .prepare("SELECT data FROM batches WHERE elevator = ?1 AND t_max >= ?2 AND t_min <= ?3 ORDER BY seq")
            .map_err(|e| e.to_string())?;
        let mut rows = st.query(params![id, lo, hi]).map_err(|e| e.to_string())?;
        while let Some(r) = rows.next().map_err(|e| e.to_string())? {
            let data: Vec<u8> = r.get(0).map_err(|e| e.to_string())?;
            for (sig, t, v) in store::decode(&data).0 {
                if (lo..=hi).contains(&t) {
                    (first, last) = (first.min(t), last.max(t));
                    if last - first > MAX_FIT_SPAN_S {
                        return Err(format!(
                            "the stored telemetry of the range spans more than {} days (from {} s to at least {} s): fit a shorter range with `from` and `to`",
                            MAX_FIT_SPAN_S / DAY_S,
                            liftwatch::error::number(first),
                            liftwatch::error::number(last)
                        ));
                    }
                    aligner.push(sig, t, v, &mut samples).map_err(|e| e.to_string())?;
                }
            }
        }
        Ok(())
    })?;
    aligner.flush(&mut samples).map_err(|e| e.to_string())?;
    let series = samples.finish(cfg.step_s).map_err(|e| e.to_string())?;
    if series.is_empty() {
        return Err("no stored telemetry in the range (raw batches are kept keep_raw_days)".into());
    }
    let mut train = liftwatch::model::train::TrainConfig::default();
    if let Some(n) = req.epochs {
        train.epochs = n;
    }
    let outcome =
        liftwatch::fit::fit(&series, elevator, &train, &mut |_| {}).map_err(|e| e.to_string())?;
    let text = serde_json::to_string_pretty(&outcome.model).map_err(|e| e.to_string())?;
    // The same checks as an upload: a fit the registry would refuse is a failed fit.
    liftwatch::file::load_str(&text, Path::new("fitted model")).map_err(|e| e.to_string())?;
    let fp = liftwatch::file::model_id(&outcome.model);
    let summary = format!("{} aligned samples", series.len());
    Ok((text, fp, summary))
}

/// `POST …/maintenance`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Visit {
    /// When (data clock, s): the open events at or before it are labelled.
    pub time: f64,
    /// What was done.
    pub work: String,
    /// What was found: `confirmed` (the fault was there) or `not_found`.
    pub finding: String,
    /// Restart the monitor's risk from a fresh state of the active model ("after repair").
    #[serde(default)]
    pub rebaseline: bool,
}

/// Longest `work` text (characters).
const MAX_WORK_CHARS: usize = 2000;

/// Stores a visit, labels the open events, bumps the re-baseline generation when asked.
///
/// # Errors
/// 400 for a bad visit.
pub fn add_visit(conn: &Connection, id: &str, v: &Visit) -> Result<Value, ApiError> {
    let max = liftwatch::ingest::MAX_ABS_TIME_S;
    if !(-max..=max).contains(&v.time) {
        return Err(ApiError::bad(format!(
            "time must be a number of seconds within ±{max:e}, as telemetry times are"
        )));
    }
    if !matches!(v.finding.as_str(), "confirmed" | "not_found") {
        return Err(ApiError::bad(format!(
            "finding `{}`, expected confirmed or not_found",
            one_line(&v.finding)
        )));
    }
    if v.work.chars().count() > MAX_WORK_CHARS {
        return Err(ApiError::bad(format!(
            "work is longer than {MAX_WORK_CHARS} characters"
        )));
    }
    let db = |e: rusqlite::Error| ApiError::internal(format!("database: {e}"));
    let tx = conn.unchecked_transaction().map_err(db)?;
    let labelled = tx
        .execute(
            "UPDATE events SET label = ?2 WHERE elevator = ?1 AND label IS NULL AND level IN ('advisory', 'alarm') AND time <= ?3",
            params![id, v.finding, v.time],
        )
        .map_err(db)?;
    tx.execute(
        "INSERT INTO maintenance (elevator, time, work, finding, rebaseline, labelled, created) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
        params![id, v.time, v.work, v.finding, v.rebaseline, labelled as i64, store::now()],
    )
    .map_err(db)?;
    if v.rebaseline {
        tx.execute(
            "UPDATE elevators SET rebaseline_gen = rebaseline_gen + 1 WHERE id = ?1",
            [id],
        )
        .map_err(db)?;
    }
    tx.commit().map_err(db)?;
    Ok(json!({"id": id, "labelled_events": labelled, "rebaseline": v.rebaseline}))
}

/// The visits of an elevator, oldest first.
///
/// # Errors
/// The database's.
pub fn visit_list(
    conn: &Connection,
    id: &str,
    info: &ElevatorInfo,
) -> rusqlite::Result<Vec<Value>> {
    let mut st = conn.prepare(
        "SELECT time, work, finding, rebaseline, labelled, created FROM maintenance WHERE elevator = ?1 ORDER BY id",
    )?;
    let rows = st
        .query_map([id], |r| {
            let t: f64 = r.get(0)?;
            Ok(json!({
                "time": t,
                "time_text": time_text(t, info),
                "work": r.get::<_, String>(1)?,
                "finding": r.get::<_, String>(2)?,
                "rebaseline": r.get::<_, bool>(3)?,
                "labelled_events": r.get::<_, i64>(4)?,
                "created": r.get::<_, f64>(5)?,
            }))
        })?
        .collect();
    rows
}

/// The stored trip rows of `[from, to]` (by start), oldest first.
///
/// # Errors
/// The database's.
pub fn trip_rows(
    conn: &Connection,
    id: &str,
    from: &Option<f64>,
    to: &Option<f64>,
    limit: usize,
    info: &ElevatorInfo,
) -> rusqlite::Result<Vec<Value>> {
    let mut st = conn.prepare(
        "SELECT row FROM trips WHERE elevator = ?1 AND start >= ?2 AND start <= ?3 ORDER BY start, seq LIMIT ?4",
    )?;
    let rows = st
        .query_map(
            params![
                id,
                from.unwrap_or(f64::MIN),
                to.unwrap_or(f64::MAX),
                limit as i64
            ],
            |r| r.get::<_, String>(0),
        )?
        .map(|r| r.map(|line| trip_object(&line, info)))
        .collect();
    rows
}

/// Events, fleet-wide or of one elevator, oldest first, each as the JSON text of one object:
/// `elevator`, `id`, `seq`, then the events.jsonl line's fields as stored (spliced as text, so
/// every float keeps the digits `liftwatch monitor` writes), then `time_text` and `label`.
///
/// # Errors
/// The database's.
pub fn event_list(
    conn: &Connection,
    id: Option<&str>,
    from: &Option<f64>,
    to: &Option<f64>,
    level: Option<&str>,
    limit: usize,
) -> rusqlite::Result<Vec<String>> {
    let mut st = conn.prepare(
        "SELECT e.id, e.elevator, e.seq, e.line, e.label, e.time, el.info FROM events e
         JOIN elevators el ON el.id = e.elevator
         WHERE (?1 IS NULL OR e.elevator = ?1) AND e.time >= ?2 AND e.time <= ?3
           AND (?4 IS NULL OR e.level = ?4)
         ORDER BY e.time, e.id LIMIT ?5",
    )?;
    let rows = st
        .query_map(
            params![
                id,
                from.unwrap_or(f64::MIN),
                to.unwrap_or(f64::MAX),
                level,
                limit as i64
            ],
            |r| {
                let line: String = r.get(3)?;
                let info: ElevatorInfo =
                    serde_json::from_str(&r.get::<_, String>(6)?).unwrap_or_default();
                let head = json!({
                    "elevator": r.get::<_, String>(1)?,
                    "id": r.get::<_, i64>(0)?,
                    "seq": r.get::<_, i64>(2)?,
                })
                .to_string();
                let tail = json!({
                    "time_text": time_text(r.get(5)?, &info),
                    "label": r.get::<_, Option<String>>(4)?,
                })
                .to_string();
                // The stored line is one JSON object written by `Monitor::event_line`.
                let body = line
                    .trim()
                    .strip_prefix('{')
                    .and_then(|b| b.strip_suffix('}'))
                    .unwrap_or("");
                let sep = if body.is_empty() { "" } else { "," };
                Ok(format!(
                    "{},{body}{sep}{}",
                    head.strip_suffix('}').unwrap_or(&head),
                    tail.strip_prefix('{').unwrap_or(&tail)
                ))
            },
        )?
        .collect();
    rows
}

/// Per elevator: batches stored but not yet applied and checkpointed, and the wall-clock
/// age of the oldest of them (s).
///
/// # Errors
/// The database's.
pub fn queue_depths(conn: &Connection) -> rusqlite::Result<HashMap<String, (i64, f64)>> {
    let mut st = conn.prepare(
        "SELECT b.elevator, COUNT(*), MIN(b.received) FROM batches b
         LEFT JOIN checkpoints c ON c.elevator = b.elevator
         WHERE b.seq > COALESCE(c.applied_seq, 0) GROUP BY b.elevator",
    )?;
    let now = store::now();
    let rows = st
        .query_map([], |r| {
            Ok((
                r.get::<_, String>(0)?,
                (r.get::<_, i64>(1)?, now - r.get::<_, f64>(2)?),
            ))
        })?
        .collect();
    rows
}

/// The Prometheus text of `/metrics`.
pub fn metrics_text(s: &Shared, depths: &HashMap<String, (i64, f64)>) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let snaps = s
        .snapshots
        .read()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let ingest = s
        .ingest
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .clone();
    let mut ids: Vec<&String> = snaps
        .keys()
        .chain(ingest.keys())
        .chain(depths.keys())
        .collect();
    ids.sort();
    ids.dedup();
    let mut family = |name: &str, help: &str, kind: &str, f: &dyn Fn(&str) -> Option<f64>| {
        let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} {kind}");
        for id in &ids {
            if let Some(v) = f(id) {
                let _ = writeln!(out, "{name}{{elevator=\"{id}\"}} {}", prom(v));
            }
        }
    };
    let level_num = |l: &str| match l {
        "alarm" => 2.0,
        "advisory" => 1.0,
        _ => 0.0,
    };
    family(
        "liftwatch_risk",
        "Combined risk R of the elevator's monitor.",
        "gauge",
        &|id| snaps.get(id).map(|x| x.risk).filter(|r| r.is_finite()),
    );
    family(
        "liftwatch_level",
        "Level: 0 normal, 1 advisory, 2 alarm.",
        "gauge",
        &|id| snaps.get(id).map(|x| level_num(&x.level)),
    );
    family(
        "liftwatch_rows_ingested_total",
        "Good telemetry rows stored (since start).",
        "counter",
        &|id| ingest.get(id).map(|x| x.rows as f64),
    );
    family(
        "liftwatch_rows_bad_total",
        "Bad telemetry rows skipped (since start).",
        "counter",
        &|id| ingest.get(id).map(|x| x.bad as f64),
    );
    family(
        "liftwatch_rows_duplicate_total",
        "Readings dropped as re-sent duplicates.",
        "counter",
        &|id| snaps.get(id).map(|x| x.counts.duplicate as f64),
    );
    family(
        "liftwatch_rows_late_total",
        "Readings dropped as older than the reorder window.",
        "counter",
        &|id| {
            snaps
                .get(id)
                .map(|x| (x.counts.late + x.counts.late_current + x.counts.out_of_span) as f64)
        },
    );
    family(
        "liftwatch_rows_glitch_total",
        "Readings dropped as clock glitches: far ahead of every time taken, and not followed.",
        "counter",
        &|id| snaps.get(id).map(|x| x.counts.glitches as f64),
    );
    family(
        "liftwatch_samples_total",
        "Aligned samples produced.",
        "counter",
        &|id| snaps.get(id).map(|x| x.counts.samples as f64),
    );
    family(
        "liftwatch_applied_seq",
        "Last batch seq applied and checkpointed: outputs are stored up to it.",
        "gauge",
        &|id| snaps.get(id).map(|x| x.applied_seq as f64),
    );
    family(
        "liftwatch_queue_depth",
        "Batches stored, not yet applied and checkpointed.",
        "gauge",
        &|id| Some(depths.get(id).map_or(0.0, |d| d.0 as f64)),
    );
    family(
        "liftwatch_apply_lag_seconds",
        "Wall-clock age of the oldest batch not yet checkpointed.",
        "gauge",
        &|id| Some(depths.get(id).map_or(0.0, |d| d.1.max(0.0))),
    );
    let _ = writeln!(
        out,
        "# HELP liftwatch_requests_refused_total Requests answered with a 4xx.\n# TYPE liftwatch_requests_refused_total counter\nliftwatch_requests_refused_total {}",
        s.refused.load(std::sync::atomic::Ordering::Relaxed)
    );
    out
}

fn prom(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else if v.is_nan() {
        "NaN".into()
    } else if v > 0.0 {
        "+Inf".into()
    } else {
        "-Inf".into()
    }
}

/// Data-clock times above this are Unix time (2001-09-09 onwards), as the library reads them:
/// only those get an RFC 3339 text.
pub const UNIX_CLOCK_FROM_S: f64 = 1e8;

/// RFC 3339 text of a data-clock time at the elevator's offset, when the clock is Unix time.
pub fn time_text(t: f64, info: &ElevatorInfo) -> Value {
    if !(t.is_finite() && t > UNIX_CLOCK_FROM_S) {
        return Value::Null;
    }
    let offset = info
        .timezone
        .as_deref()
        .and_then(|tz| crate::config::utc_offset(tz).ok())
        .unwrap_or(0);
    Value::String(liftwatch::ingest::time::format_rfc3339(t, offset))
}

/// A number as JSON, NaN as null.
fn num(x: f64) -> Value {
    serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
}

/// A JSON object from the trip CSV line: numbers as numbers, empty fields as null.
pub fn trip_object(line: &str, info: &ElevatorInfo) -> Value {
    let mut m = Map::new();
    let header = liftwatch::monitor::TRIP_CSV_HEADER.split(',');
    for (name, field) in header.zip(line.split(',')) {
        let v = if field.is_empty() {
            Value::Null
        } else if matches!(name, "level" | "mode") {
            Value::String(field.to_string())
        } else {
            field.parse::<f64>().map_or(Value::Null, num)
        };
        m.insert(name.to_string(), v);
    }
    for key in ["start", "end"] {
        let t = m.get(key).and_then(Value::as_f64).unwrap_or(f64::NAN);
        m.insert(format!("{key}_text"), time_text(t, info));
    }
    Value::Object(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lone_reading_far_from_its_batch_is_bad_and_a_gap_with_company_is_not() {
        let mut body: String = (0..30).map(|k| format!("{k},speed,0\n")).collect();
        body.push_str("8640000,speed,0\n");
        let p = parse_telemetry(body.as_bytes(), false, 1000).unwrap();
        assert_eq!((p.readings.len(), p.bad), (30, 1));
        assert_eq!(p.first_bad_line, Some(31));
        assert!(p.first_bad_reason.unwrap().contains("clock glitch"));
        // A logger back after a day: three readings at once are telemetry.
        let mut body: String = (0..30).map(|k| format!("{k},speed,0\n")).collect();
        body.push_str("86400,speed,0\n86400.5,door,1\n86401,speed,0\n");
        let p = parse_telemetry(body.as_bytes(), false, 1000).unwrap();
        assert_eq!((p.readings.len(), p.bad), (33, 0));
    }

    #[test]
    fn a_bad_json_line_is_named_by_its_line_in_the_body_as_sent() {
        let good = |t: u32| format!("{{\"time\":{t},\"signal\":\"speed\",\"value\":0}}\n");
        // A blank line and a line that is no object come before a row the library refuses:
        // the refused row is the body's line 5, not the converted text's.
        let body = format!(
            "{}\n[1,2]\n{}{{\"time\":3,\"signal\":\"speed\",\"value\":\"fast\"}}\n",
            good(1),
            good(2)
        );
        let p = parse_telemetry(body.as_bytes(), true, 100).unwrap();
        assert_eq!((p.readings.len(), p.bad), (2, 2));
        assert_eq!(p.first_bad_line, Some(3), "the array comes first");
        // The refused row alone, after two lines of no row: its own line, its own reason.
        let body = format!(
            "\n\n{}{}{{\"time\":3,\"signal\":\"speed\",\"value\":\"fast\"}}\n",
            good(1),
            good(2)
        );
        let p = parse_telemetry(body.as_bytes(), true, 100).unwrap();
        assert_eq!(p.first_bad_line, Some(5));
        let why = p.first_bad_reason.unwrap();
        assert!(why.contains("fast") && !why.contains("line "), "{why}");
        // A refused row before a line that is no object is the first bad line.
        let body = format!(
            "{{\"time\":1,\"signal\":\"speed\",\"value\":\"x\"}}\n{}7\n",
            good(2)
        );
        let p = parse_telemetry(body.as_bytes(), true, 100).unwrap();
        assert_eq!((p.bad, p.first_bad_line), (2, Some(1)));
    }

    #[test]
    fn the_row_bound_counts_rows_not_the_header_or_line_breaks() {
        let rows = "1,speed,0.5\n2,door,1\n\n3,speed,0\n";
        assert!(parse_telemetry(rows.as_bytes(), false, 3).is_ok());
        let with_header = format!("time,signal,value\n{rows}");
        assert!(parse_telemetry(with_header.as_bytes(), false, 3).is_ok());
        let more = format!("{with_header}4,speed,0\n");
        let err = parse_telemetry(more.as_bytes(), false, 3).unwrap_err();
        assert_eq!(err.0, StatusCode::PAYLOAD_TOO_LARGE);
        assert!(err.1.starts_with("4 rows"), "{}", err.1);
    }

    #[test]
    fn a_body_without_header_and_json_lines_give_the_same_readings() {
        let with =
            parse_telemetry(b"time,signal,value\n1,speed,0.5\n2,door,1\n", false, 10).unwrap();
        let without = parse_telemetry(b"1,speed,0.5\n2,door,1\n", false, 10).unwrap();
        let json = parse_telemetry(
            b"{\"time\":1,\"signal\":\"speed\",\"value\":0.5}\n{\"time\":\"2\",\"signal\":\"door\",\"value\":1}\n",
            true,
            10,
        )
        .unwrap();
        assert_eq!(with.readings.len(), 2);
        assert_eq!(
            format!("{:?}", with.readings),
            format!("{:?}", without.readings)
        );
        assert_eq!(
            format!("{:?}", with.readings),
            format!("{:?}", json.readings)
        );
    }

    #[test]
    fn bad_rows_are_counted_with_the_line_of_the_body_as_sent() {
        let p = parse_telemetry(b"1,speed,0\nx,speed,1\n2,speed,0\n", false, 10).unwrap();
        assert_eq!((p.readings.len(), p.bad, p.first_bad_line), (2, 1, Some(2)));
        assert!(!p.first_bad_reason.unwrap().starts_with("line"));
        let p = parse_telemetry(
            b"{\"time\":1}\n{\"time\":1,\"signal\":\"speed\",\"value\":0}\n",
            true,
            10,
        )
        .unwrap();
        assert_eq!((p.readings.len(), p.bad, p.first_bad_line), (1, 1, Some(1)));
    }

    #[test]
    fn too_many_rows_or_no_good_row_is_refused() {
        let e = parse_telemetry(b"1,speed,0\n2,speed,0\n3,speed,0\n", false, 2).unwrap_err();
        assert_eq!(e.0, StatusCode::PAYLOAD_TOO_LARGE);
        let e = parse_telemetry(b"garbage\n", false, 10).unwrap_err();
        assert_eq!(e.0, StatusCode::BAD_REQUEST);
        let e = parse_telemetry(b"1,warp,0\n", false, 10).unwrap_err();
        assert!(e.1.contains("unknown signals"), "{}", e.1);
    }
}
