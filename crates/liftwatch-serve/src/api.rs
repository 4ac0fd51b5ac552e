//! The HTTP API (README, *Service*; `openapi.json`): routes, auth, bounds,
//! JSON errors.
//!
//! ```text
//! reads   GET /healthz /metrics /api/v1/openapi.json /api/v1/elevators[/{id}[/risk|/events|
//!         /models|/maintenance]] /api/v1/events            open, or token with read_token
//! writes  PUT /api/v1/elevators/{id}; POST …/telemetry …/models …/models/{v}/activate …/fit
//!         …/maintenance                                       `Authorization: Bearer TOKEN`
//! errors  {"error": "one line"} with a 4xx/5xx status
//! ```
//!
//! Bounds: the body (`max_body_bytes`, 413), rows per request (`max_rows_per_request`, 413),
//! elevators per instance (`max_elevators`, 409), ids `[A-Za-z0-9_-]{1,64}` (400): an id is a
//! key in the database, never a path.

use liftwatch::ingest::MAX_ABS_TIME_S;
use liftwatch::sample::DAY_S;
use std::sync::atomic::Ordering;
use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, QueryRejection};
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use serde_json::{json, Value};

use crate::config::{check_info, one_line, ElevatorInfo};
pub use crate::error::ApiError;
use crate::error::{check_id, db};
use crate::ingest::{full, ingest};
use crate::registry::{time_text, UNIX_CLOCK_FROM_S};
use crate::worker::Snapshot;
use crate::{log, registry, store, Shared};

/// The OpenAPI description, written by hand and embedded.
pub const OPENAPI: &str = include_str!("../openapi.json");

/// The dashboard's files (helper B's), embedded.
const INDEX_HTML: &str = include_str!("../assets/index.html");
const APP_JS: &str = include_str!("../assets/app.js");
const STYLE_CSS: &str = include_str!("../assets/style.css");

/// Default and largest `limit` of the row and event lists.
const DEFAULT_LIMIT: usize = 10_000;
const MAX_LIMIT: usize = 100_000;

type ApiResult = Result<Response, ApiError>;

/// The router over `shared`.
pub fn router(shared: Arc<Shared>) -> Router {
    let limit = shared.cfg.max_body_bytes;
    Router::new()
        .route(
            "/",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
                    INDEX_HTML,
                )
            }),
        )
        .route(
            "/app.js",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
                    APP_JS,
                )
            }),
        )
        .route(
            "/style.css",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/css; charset=utf-8")],
                    STYLE_CSS,
                )
            }),
        )
        .route("/healthz", get(healthz))
        .route("/metrics", get(metrics))
        .route(
            "/api/v1/openapi.json",
            get(|| async { ([(header::CONTENT_TYPE, "application/json")], OPENAPI) }),
        )
        .route("/api/v1/elevators", get(list))
        .route("/api/v1/elevators/{id}", get(one).put(put_elevator))
        .route("/api/v1/elevators/{id}/telemetry", post(telemetry))
        .route("/api/v1/elevators/{id}/risk", get(risk))
        .route("/api/v1/elevators/{id}/events", get(events_of))
        .route("/api/v1/events", get(events_all))
        .route(
            "/api/v1/elevators/{id}/models",
            get(models).post(upload_model),
        )
        .route(
            "/api/v1/elevators/{id}/models/{version}/activate",
            post(activate),
        )
        .route("/api/v1/elevators/{id}/fit", post(fit))
        .route(
            "/api/v1/elevators/{id}/maintenance",
            get(visits).post(add_visit),
        )
        .fallback(|| async { ApiError::not_found("no such route; see /api/v1/openapi.json") })
        .method_not_allowed_fallback(|| async {
            ApiError(
                StatusCode::METHOD_NOT_ALLOWED,
                "this route does not take that method; see /api/v1/openapi.json".into(),
            )
        })
        .layer(DefaultBodyLimit::max(limit))
        .layer(axum::middleware::from_fn_with_state(
            shared.clone(),
            writes_first,
        ))
        .with_state(shared)
}

/// How long a write's body may take to arrive (s): 8 MiB at a slow 150 kB/s. A client that
/// stops sending holds a connection and the body read so far; after this it gets 408.
const BODY_TIMEOUT_S: u64 = 60;

/// Every write (any method but GET and HEAD) is checked for its token before its body is
/// read, and its body must arrive within [`BODY_TIMEOUT_S`]: unauthenticated clients sending
/// 8 MiB bodies slowly had pinned that memory per connection for as long as they liked.
async fn writes_first(
    State(s): State<Arc<Shared>>,
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    let method = req.method();
    if method == axum::http::Method::GET || method == axum::http::Method::HEAD {
        return next.run(req).await;
    }
    if let Err(e) = check_write(&s, req.headers()) {
        return refused(&s, e).into_response();
    }
    let (parts, body) = req.into_parts();
    let max = s.cfg.max_body_bytes;
    let too_large = || {
        ApiError(
            StatusCode::PAYLOAD_TOO_LARGE,
            format!("the body is larger than {max} bytes"),
        )
    };
    // A declared length over the limit is refused before a byte of the body is waited for.
    let declared = parts
        .headers
        .get(axum::http::header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    if declared.is_some_and(|n| n > max as u64) {
        return refused(&s, too_large()).into_response();
    }
    let read = axum::body::to_bytes(body, max);
    let bytes =
        match tokio::time::timeout(std::time::Duration::from_secs(BODY_TIMEOUT_S), read).await {
            Ok(Ok(b)) => b,
            Ok(Err(_)) => {
                // Within its declared length, a body that fails to arrive was cut off; a
                // chunked one fails here only beyond the limit.
                let e = match declared {
                    Some(n) => ApiError(
                        StatusCode::BAD_REQUEST,
                        format!("the body ended before its Content-Length of {n} bytes"),
                    ),
                    None => too_large(),
                };
                return refused(&s, e).into_response();
            }
            Err(_) => {
                return refused(
                    &s,
                    ApiError(
                        StatusCode::REQUEST_TIMEOUT,
                        format!("the body did not arrive within {BODY_TIMEOUT_S} s"),
                    ),
                )
                .into_response()
            }
        };
    next.run(axum::extract::Request::from_parts(
        parts,
        axum::body::Body::from(bytes),
    ))
    .await
}

/// Runs blocking database work off the async threads.
async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| ApiError::internal(format!("worker task failed: {e}")))?
}

/// Counts a refused request and passes the error on.
fn refused(s: &Shared, e: ApiError) -> ApiError {
    if e.0.is_client_error() {
        s.refused.fetch_add(1, Ordering::Relaxed);
    }
    e
}

fn bearer(headers: &HeaderMap) -> Option<&str> {
    headers
        .get(header::AUTHORIZATION)?
        .to_str()
        .ok()?
        .strip_prefix("Bearer ")
        .map(str::trim)
}

/// Compares in time independent of where the first difference is.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

fn check_write(s: &Shared, headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(token) = &s.token else {
        return Err(ApiError(
            StatusCode::FORBIDDEN,
            "writes are disabled: this server was started without a token (--token-file or LIFTWATCH_TOKEN)".into(),
        ));
    };
    match bearer(headers) {
        None => Err(ApiError(
            StatusCode::UNAUTHORIZED,
            "this write needs `Authorization: Bearer <token>`".into(),
        )),
        Some(t) if same(t, token) => Ok(()),
        Some(_) => Err(ApiError(StatusCode::UNAUTHORIZED, "wrong token".into())),
    }
}

fn check_read(s: &Shared, headers: &HeaderMap) -> Result<(), ApiError> {
    if s.cfg.read_token {
        check_write(s, headers)
    } else {
        Ok(())
    }
}

fn body_of(body: Result<Bytes, BytesRejection>) -> Result<Bytes, ApiError> {
    body.map_err(|r| {
        let status = r.status();
        let why = if status == StatusCode::PAYLOAD_TOO_LARGE {
            "the body is larger than max_body_bytes allows".to_string()
        } else {
            r.body_text()
        };
        ApiError(status, why)
    })
}

/// The stored description of `id`, 404 when unknown.
fn info_of(conn: &rusqlite::Connection, id: &str) -> Result<ElevatorInfo, ApiError> {
    use rusqlite::OptionalExtension;
    let text: Option<String> = conn
        .query_row("SELECT info FROM elevators WHERE id = ?1", [id], |r| {
            r.get(0)
        })
        .optional()
        .map_err(db)?;
    let text = text.ok_or_else(|| ApiError::not_found(format!("no elevator `{id}`")))?;
    serde_json::from_str(&text).map_err(db)
}

fn num(x: f64) -> Value {
    serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
}

/// The Summary of the contract as JSON text, with `extra` fields (the model) beside. The
/// verdict is spliced in as the text `liftwatch status --json` prints, field order included.
fn summary(
    id: &str,
    info: &ElevatorInfo,
    snap: Option<&Snapshot>,
    open_events: i64,
    extra: Option<(&str, Value)>,
) -> String {
    let snap = snap.cloned().unwrap_or_default();
    let c = &snap.counters;
    // Before the worker's first checkpoint of this elevator nothing was watched: no time, no
    // level (the defaults' 0 s and "" were shown as if they were).
    let last = if snap.counts.samples > 0 {
        c.last_time
    } else {
        f64::NAN
    };
    let days = (c.last_time - c.first_time) / DAY_S;
    let per_day = |n: u64| {
        if days > 0.0 {
            num(n as f64 / days)
        } else {
            Value::Null
        }
    };
    let lag = if last.is_finite() && last > UNIX_CLOCK_FROM_S {
        num(store::now() - last)
    } else {
        Value::Null
    };
    let mut v = json!({
        "id": id,
        "name": info.name,
        "group": info.group,
        "rated_load_kg": info.rated_load_kg,
        "rated_speed_mps": info.rated_speed_mps,
        "floors": info.floors,
        "model_version": snap.model_version,
        "last_time": num(last),
        "last_time_text": time_text(last, info),
        "lag_s": lag,
        "samples": snap.counts.samples,
        "trips": snap.trips,
        "trips_per_day": per_day(snap.trips),
        "door_cycles_per_day": per_day(c.door_cycles),
        "open_events": open_events,
        "level": (!snap.level.is_empty()).then_some(&snap.level),
        "applied_seq": snap.applied_seq,
    });
    if let Some((key, value)) = extra {
        v[key] = value;
    }
    let text = v.to_string();
    let body = text.strip_suffix('}').unwrap_or(&text);
    let verdict = snap.verdict.as_deref().unwrap_or("null");
    format!("{body},\"verdict\":{verdict}}}")
}

/// Unlabelled advisory and alarm events per elevator.
fn open_events(
    conn: &rusqlite::Connection,
) -> Result<std::collections::HashMap<String, i64>, ApiError> {
    let mut st = conn
        .prepare("SELECT elevator, COUNT(*) FROM events WHERE label IS NULL AND level IN ('advisory', 'alarm') GROUP BY elevator")
        .map_err(db)?;
    let rows = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .and_then(|r| r.collect())
        .map_err(db)?;
    Ok(rows)
}

async fn healthz(State(s): State<Arc<Shared>>) -> ApiResult {
    let s2 = s.clone();
    let pending = blocking(move || {
        s2.read(|c| registry::queue_depths(c).map_err(|e| e.to_string()))
            .map_err(db)
    })
    .await?;
    let depth: i64 = pending.values().map(|(n, _)| n).sum();
    if !s.worker_alive.load(Ordering::Relaxed) {
        let body = json!({"status": "worker stopped", "queue_depth": depth});
        return Ok((StatusCode::SERVICE_UNAVAILABLE, Json(body)).into_response());
    }
    Ok(Json(json!({"status": "ok", "queue_depth": depth})).into_response())
}

async fn list(State(s): State<Arc<Shared>>, headers: HeaderMap) -> ApiResult {
    check_read(&s, &headers).map_err(|e| refused(&s, e))?;
    let s2 = s.clone();
    let mut out = blocking(move || {
        s2.read(|c| {
            let open = open_events(c).map_err(|e| e.1)?;
            let mut st = c
                .prepare("SELECT id, info FROM elevators")
                .map_err(|e| e.to_string())?;
            let rows: Vec<(String, String)> = st
                .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
                .and_then(|r| r.collect())
                .map_err(|e| e.to_string())?;
            let snaps = s2
                .snapshots
                .read()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            Ok(rows
                .into_iter()
                .map(|(id, info)| {
                    let info: ElevatorInfo = serde_json::from_str(&info).unwrap_or_default();
                    let risk = snaps.get(&id).map_or(f64::NAN, |x| x.risk);
                    let open = open.get(&id).copied().unwrap_or(0);
                    let text = summary(&id, &info, snaps.get(&id), open, None);
                    (risk, id, text)
                })
                .collect::<Vec<_>>())
        })
        .map_err(db)
    })
    .await?;
    // Highest risk first; elevators without a risk last, then by id.
    out.sort_by(|a, b| {
        let key = |x: f64| if x.is_nan() { f64::NEG_INFINITY } else { x };
        key(b.0).total_cmp(&key(a.0)).then_with(|| a.1.cmp(&b.1))
    });
    let list: Vec<String> = out.into_iter().map(|x| x.2).collect();
    let body = format!("{{\"elevators\":[{}]}}", list.join(","));
    Ok(([(header::CONTENT_TYPE, "application/json")], body).into_response())
}

async fn one(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> ApiResult {
    check_read(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let s2 = s.clone();
    let v = blocking(move || {
        let (info, open, model) = s2
            .read(|c| {
                let info = info_of(c, &id).map_err(|e| e.1)?;
                let open = open_events(c)
                    .map_err(|e| e.1)?
                    .get(&id)
                    .copied()
                    .unwrap_or(0);
                let model = registry::active_model_json(c, &id)?;
                Ok((info, open, model))
            })
            .map_err(|e| {
                if e.starts_with("no elevator") {
                    ApiError::not_found(e)
                } else {
                    db(e)
                }
            })?;
        let snaps = s2
            .snapshots
            .read()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let model = model.unwrap_or(Value::Null);
        Ok(summary(
            &id,
            &info,
            snaps.get(&id),
            open,
            Some(("model", model)),
        ))
    })
    .await
    .map_err(|e| refused(&s, e))?;
    Ok(([(header::CONTENT_TYPE, "application/json")], v).into_response())
}

async fn put_elevator(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    check_write(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let body = body_of(body).map_err(|e| refused(&s, e))?;
    let value: serde_json::Value = serde_json::from_slice(&body)
        .map_err(|e| refused(&s, ApiError::bad(format!("elevator description: {e}"))))?;
    if !value.is_object() {
        return Err(refused(
            &s,
            ApiError::bad("elevator description: expected a JSON object"),
        ));
    }
    let mut info: ElevatorInfo = serde_json::from_value(value)
        .map_err(|e| refused(&s, ApiError::bad(format!("elevator description: {e}"))))?;
    info.id = None;
    check_info(&info).map_err(|e| refused(&s, ApiError::bad(e)))?;
    let s2 = s.clone();
    let id2 = id.clone();
    blocking(move || {
        let conn = s2
            .writer
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if !store::elevator_exists(&conn, &id2).map_err(db)?
            && store::elevator_count(&conn).map_err(db)? >= s2.cfg.max_elevators
        {
            return Err(full(&s2));
        }
        registry::check_description(&conn, &id2, &info)?;
        let json = serde_json::to_string(&info).map_err(db)?;
        store::put_elevator(&conn, &id2, &json).map_err(db)
    })
    .await
    .map_err(|e| refused(&s, e))?;
    log("info", &format!("elevator {id} described"));
    Ok(Json(json!({"id": id, "ok": true})).into_response())
}

async fn telemetry(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    check_write(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let body = body_of(body).map_err(|e| refused(&s, e))?;
    let ndjson = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| {
            v.starts_with("application/x-ndjson") || v.starts_with("application/jsonl")
        });
    let s2 = s.clone();
    let receipt = blocking(move || ingest(&s2, &id, &body, ndjson))
        .await
        .map_err(|e| refused(&s, e))?;
    Ok(Json(receipt).into_response())
}

/// `from`, `to`, `limit` and `level` of the list endpoints.
#[derive(Debug, Deserialize)]
struct ListQuery {
    from: Option<f64>,
    to: Option<f64>,
    limit: Option<usize>,
    level: Option<String>,
}

fn query_of(q: Result<Query<ListQuery>, QueryRejection>) -> Result<ListQuery, ApiError> {
    let q = q
        .map_err(|e| ApiError::bad(format!("query: {}", e.body_text())))?
        .0;
    for (name, t) in [("from", q.from), ("to", q.to)] {
        // Times are the telemetry's: a NaN, an infinity or 1e400 is no time to list from.
        if t.is_some_and(|t| !(-MAX_ABS_TIME_S..=MAX_ABS_TIME_S).contains(&t)) {
            return Err(ApiError::bad(format!(
                "{name}: expected a time within ±{MAX_ABS_TIME_S:e} s, as telemetry times are"
            )));
        }
    }
    if let Some(l) = &q.level {
        if !matches!(l.as_str(), "normal" | "advisory" | "alarm") {
            return Err(ApiError::bad(format!(
                "level `{}`, expected normal, advisory or alarm",
                one_line(l)
            )));
        }
    }
    Ok(q)
}

async fn risk(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    q: Result<Query<ListQuery>, QueryRejection>,
) -> ApiResult {
    check_read(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let q = query_of(q).map_err(|e| refused(&s, e))?;
    let s2 = s.clone();
    let rows = blocking(move || {
        s2.read(|c| {
            let info = info_of(c, &id).map_err(|e| e.1)?;
            registry::trip_rows(c, &id, &q.from, &q.to, limit(q.limit), &info)
                .map_err(|e| e.to_string())
        })
        .map_err(|e| {
            if e.starts_with("no elevator") {
                ApiError::not_found(e)
            } else {
                db(e)
            }
        })
    })
    .await
    .map_err(|e| refused(&s, e))?;
    Ok(Json(json!({ "rows": rows })).into_response())
}

fn limit(l: Option<usize>) -> usize {
    l.unwrap_or(DEFAULT_LIMIT).min(MAX_LIMIT)
}

async fn events_of(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    q: Result<Query<ListQuery>, QueryRejection>,
) -> ApiResult {
    check_read(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let q = query_of(q).map_err(|e| refused(&s, e))?;
    events(s, Some(id), q).await
}

async fn events_all(
    State(s): State<Arc<Shared>>,
    headers: HeaderMap,
    q: Result<Query<ListQuery>, QueryRejection>,
) -> ApiResult {
    check_read(&s, &headers).map_err(|e| refused(&s, e))?;
    let q = query_of(q).map_err(|e| refused(&s, e))?;
    events(s, None, q).await
}

async fn events(s: Arc<Shared>, id: Option<String>, q: ListQuery) -> ApiResult {
    let s2 = s.clone();
    let list = blocking(move || {
        s2.read(|c| {
            if let Some(id) = &id {
                info_of(c, id).map_err(|e| e.1)?;
            }
            registry::event_list(
                c,
                id.as_deref(),
                &q.from,
                &q.to,
                q.level.as_deref(),
                limit(q.limit),
            )
            .map_err(|e| e.to_string())
        })
        .map_err(|e| {
            if e.starts_with("no elevator") {
                ApiError::not_found(e)
            } else {
                db(e)
            }
        })
    })
    .await
    .map_err(|e| refused(&s, e))?;
    let body = format!("{{\"events\":[{}]}}", list.join(","));
    Ok(([(header::CONTENT_TYPE, "application/json")], body).into_response())
}

async fn models(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> ApiResult {
    check_read(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let s2 = s.clone();
    let list = blocking(move || {
        s2.read(|c| {
            info_of(c, &id).map_err(|e| e.1)?;
            registry::model_list(c, &id)
        })
        .map_err(|e| {
            if e.starts_with("no elevator") {
                ApiError::not_found(e)
            } else {
                db(e)
            }
        })
    })
    .await
    .map_err(|e| refused(&s, e))?;
    Ok(Json(json!({ "models": list })).into_response())
}

/// `?source=` and `?note=` of an upload.
#[derive(Debug, Deserialize)]
struct UploadQuery {
    note: Option<String>,
    source: Option<String>,
}

async fn upload_model(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    q: Result<Query<UploadQuery>, QueryRejection>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    check_write(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let body = body_of(body).map_err(|e| refused(&s, e))?;
    let q = q
        .map_err(|e| refused(&s, ApiError::bad(format!("query: {}", e.body_text()))))?
        .0;
    let s2 = s.clone();
    let id2 = id.clone();
    let v = blocking(move || {
        let text =
            std::str::from_utf8(&body).map_err(|_| ApiError::bad("the model is not UTF-8 text"))?;
        let conn = s2
            .writer
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if !store::elevator_exists(&conn, &id2).map_err(db)?
            && store::elevator_count(&conn).map_err(db)? >= s2.cfg.max_elevators
        {
            return Err(full(&s2));
        }
        registry::upload(
            &conn,
            &id2,
            text,
            q.source.as_deref().unwrap_or("upload"),
            q.note.as_deref(),
        )
    })
    .await
    .map_err(|e| refused(&s, e))?;
    log(
        "info",
        &format!("elevator {id}: model {} uploaded", v["version"]),
    );
    s.poke(&id);
    Ok((StatusCode::CREATED, Json(v)).into_response())
}

async fn activate(
    State(s): State<Arc<Shared>>,
    Path((id, version)): Path<(String, String)>,
    headers: HeaderMap,
) -> ApiResult {
    check_write(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let version: i64 = version.parse().map_err(|_| {
        refused(
            &s,
            ApiError::bad(format!(
                "model version `{}` is not a number",
                one_line(&version)
            )),
        )
    })?;
    let s2 = s.clone();
    let id2 = id.clone();
    blocking(move || {
        let conn = s2
            .writer
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        registry::activate(&conn, &id2, version)
    })
    .await
    .map_err(|e| refused(&s, e))?;
    log("info", &format!("elevator {id}: model {version} activated"));
    s.poke(&id);
    Ok(Json(json!({"id": id, "active": version})).into_response())
}

async fn fit(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    check_write(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let body = body_of(body).map_err(|e| refused(&s, e))?;
    let req: registry::FitRequest = if body.is_empty() {
        registry::FitRequest::default()
    } else {
        serde_json::from_slice(&body)
            .map_err(|e| refused(&s, ApiError::bad(format!("fit request: {e}"))))?
    };
    let s2 = s.clone();
    let id2 = id.clone();
    let version = blocking(move || registry::start_fit(s2, &id2, req))
        .await
        .map_err(|e| refused(&s, e))?;
    log(
        "info",
        &format!("elevator {id}: fit of model {version} started"),
    );
    Ok((
        StatusCode::ACCEPTED,
        Json(json!({"id": id, "version": version, "status": "fitting"})),
    )
        .into_response())
}

async fn visits(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> ApiResult {
    check_read(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let s2 = s.clone();
    let list = blocking(move || {
        s2.read(|c| {
            let info = info_of(c, &id).map_err(|e| e.1)?;
            registry::visit_list(c, &id, &info).map_err(|e| e.to_string())
        })
        .map_err(|e| {
            if e.starts_with("no elevator") {
                ApiError::not_found(e)
            } else {
                db(e)
            }
        })
    })
    .await
    .map_err(|e| refused(&s, e))?;
    Ok(Json(json!({ "visits": list })).into_response())
}

async fn add_visit(
    State(s): State<Arc<Shared>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    check_write(&s, &headers)
        .and_then(|()| check_id(&id))
        .map_err(|e| refused(&s, e))?;
    let body = body_of(body).map_err(|e| refused(&s, e))?;
    let visit: registry::Visit = serde_json::from_slice(&body)
        .map_err(|e| refused(&s, ApiError::bad(format!("maintenance visit: {e}"))))?;
    let s2 = s.clone();
    let id2 = id.clone();
    let v = blocking(move || {
        let conn = s2
            .writer
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        info_of(&conn, &id2)?;
        registry::add_visit(&conn, &id2, &visit)
    })
    .await
    .map_err(|e| refused(&s, e))?;
    log(
        "info",
        &format!("elevator {id}: maintenance visit recorded"),
    );
    s.poke(&id);
    Ok((StatusCode::CREATED, Json(v)).into_response())
}

async fn metrics(State(s): State<Arc<Shared>>, headers: HeaderMap) -> ApiResult {
    check_read(&s, &headers).map_err(|e| refused(&s, e))?;
    let s2 = s.clone();
    let text = blocking(move || {
        let depths = s2
            .read(|c| registry::queue_depths(c).map_err(|e| e.to_string()))
            .map_err(db)?;
        Ok(crate::registry::metrics_text(&s2, &depths))
    })
    .await?;
    Ok(([(header::CONTENT_TYPE, "text/plain; version=0.0.4")], text).into_response())
}
