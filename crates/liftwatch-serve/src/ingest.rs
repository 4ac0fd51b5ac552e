//! The one ingest path of raw telemetry, whatever carried it (HTTP, MQTT): parse with the
//! library's row parser, store one batch, committed, wake the worker.

use axum::http::StatusCode;
use serde_json::{json, Value};

use crate::error::{check_id, db, ApiError};
use crate::{log, registry, store, Shared};

/// 409: the instance holds its maximum of elevators.
pub fn full(s: &Shared) -> ApiError {
    ApiError(
        StatusCode::CONFLICT,
        format!(
            "this instance holds its maximum of {} elevators (max_elevators)",
            s.cfg.max_elevators
        ),
    )
}

/// Takes one batch of raw telemetry for elevator `id`, whatever carried it (HTTP, MQTT):
/// parses it with the library's row parser (bad rows counted and skipped), stores the good rows
/// as one batch, committed, and wakes the worker. Returns the receipt the HTTP answer and the
/// logs carry. Blocking: the store is written.
///
/// # Errors
/// A 400 for a body with no usable row or an id out of form, 409 when the instance is full,
/// 500 for the database.
pub fn ingest(s: &Shared, id: &str, body: &[u8], ndjson: bool) -> Result<Value, ApiError> {
    check_id(id)?;
    let parsed = registry::parse_telemetry(body, ndjson, s.cfg.max_rows_per_request)?;
    let (seq, existed) = {
        let conn = s
            .writer
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let exists = store::elevator_exists(&conn, id).map_err(db)?;
        if !exists && store::elevator_count(&conn).map_err(db)? >= s.cfg.max_elevators {
            return Err(full(s));
        }
        let tx = conn.unchecked_transaction().map_err(db)?;
        if !exists {
            store::put_elevator(&tx, id, "{}").map_err(db)?;
        }
        let seq = store::append_batch(&tx, id, &parsed.readings).map_err(db)?;
        tx.commit().map_err(db)?;
        (seq, exists)
    };
    if !existed {
        log(
            "info",
            &format!("elevator {id} created by its first telemetry"),
        );
    }
    {
        let mut m = s
            .ingest
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let e = m.entry(id.to_string()).or_default();
        e.requests += 1;
        e.rows += parsed.readings.len() as u64;
        e.bad += parsed.bad;
    }
    s.poke(id);
    Ok(json!({
        "accepted": parsed.readings.len(),
        "bad": parsed.bad,
        "missing": parsed.missing,
        "unknown_signals": parsed.unknown,
        "first_bad_line": parsed.first_bad_line,
        "first_bad_reason": parsed.first_bad_reason,
        "seq": seq,
    }))
}
