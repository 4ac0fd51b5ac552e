//! The service's error answer: a status and one line, `{"error": "…"}` on the wire; and the
//! checks every entry (HTTP, MQTT) shares.

use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde_json::json;

use crate::config::{one_line, valid_id};
use crate::log;

/// An error answer: status and one line.
#[derive(Debug)]
pub struct ApiError(pub StatusCode, pub String);

impl ApiError {
    /// 400: the request is wrong.
    pub fn bad(msg: impl Into<String>) -> Self {
        ApiError(StatusCode::BAD_REQUEST, msg.into())
    }
    /// 404: no such elevator, model or route.
    pub fn not_found(msg: impl Into<String>) -> Self {
        ApiError(StatusCode::NOT_FOUND, msg.into())
    }
    /// 500: the service failed (the database).
    pub fn internal(msg: impl Into<String>) -> Self {
        ApiError(StatusCode::INTERNAL_SERVER_ERROR, msg.into())
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if self.0.is_server_error() {
            log(
                "error",
                &format!("{}: {}", self.0.as_u16(), one_line(&self.1)),
            );
        }
        let body = json!({ "error": one_line(&self.1) });
        (self.0, Json(body)).into_response()
    }
}

/// 400 unless `id` is `[A-Za-z0-9_-]{1,64}`.
///
/// # Errors
/// The 400.
pub fn check_id(id: &str) -> Result<(), ApiError> {
    if valid_id(id) {
        Ok(())
    } else {
        Err(ApiError::bad(format!(
            "elevator id `{}` is not [A-Za-z0-9_-]{{1,64}}",
            one_line(id)
        )))
    }
}

/// A database failure as a 500.
pub fn db(e: impl std::fmt::Display) -> ApiError {
    ApiError::internal(format!("database: {e}"))
}
