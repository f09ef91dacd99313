//! Every failed request gets `{"error": "one line"}` with its status (docs/serve-api.md,
//! "Errors"): [`ApiError`] for the handlers' own errors, [`json_error_bodies`] for the
//! answers axum and the layers make themselves (405, a caught panic).

use axum::Json;
use axum::body::Body;
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use rigfit_formats::FormatError;
use serde_json::json;

/// A failed request: the status and the one line the answer carries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ApiError {
    pub status: StatusCode,
    pub message: String,
}

impl ApiError {
    pub fn new(status: StatusCode, message: impl Into<String>) -> Self {
        // One line, whatever the source said.
        let message = message.into().replace(['\n', '\r'], " ");
        Self { status, message }
    }

    /// 400: malformed JSON or bad values.
    pub fn bad_request(message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, message)
    }

    /// 404: an unknown character or path.
    pub fn not_found(message: impl Into<String>) -> Self {
        Self::new(StatusCode::NOT_FOUND, message)
    }

    /// 422: a well-formed request the solver refuses.
    pub fn unprocessable(message: impl Into<String>) -> Self {
        Self::new(StatusCode::UNPROCESSABLE_ENTITY, message)
    }

    /// 500: a bug (a panic, a task that did not finish).
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, message)
    }

    /// The error of a reader or writer: 415 for a file type rigfit does not know, 400 for
    /// anything else; the line is the one the command line prints.
    pub fn from_format(error: &FormatError) -> Self {
        let status = match error {
            FormatError::Unsupported { .. } => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            FormatError::Parse { .. } | FormatError::Io { .. } => StatusCode::BAD_REQUEST,
        };
        Self::new(status, error.to_string())
    }
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.status.as_u16(), self.message)
    }
}

impl std::error::Error for ApiError {}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if self.status.is_server_error() {
            tracing::error!("{}", self.message);
        }
        (self.status, Json(json!({ "error": self.message }))).into_response()
    }
}

/// True when a response already carries a JSON body.
fn is_json(response: &Response) -> bool {
    response
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"))
}

/// Middleware (for `axum::middleware::map_response`): gives every error answer that is not
/// JSON yet (axum's 405, a layer's plain-text answer) the `{"error": ...}` shape, keeping its
/// status and headers such as `Allow`.
pub async fn json_error_bodies(response: Response) -> Response {
    let status = response.status();
    if !(status.is_client_error() || status.is_server_error()) || is_json(&response) {
        return response;
    }
    let message = match status {
        StatusCode::METHOD_NOT_ALLOWED => "method not allowed for this path".to_string(),
        StatusCode::PAYLOAD_TOO_LARGE => "request body too large".to_string(),
        _ => status
            .canonical_reason()
            .unwrap_or("request failed")
            .to_ascii_lowercase(),
    };
    let (mut parts, _) = response.into_parts();
    let body = json!({ "error": message }).to_string();
    parts.headers.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/json"),
    );
    parts.headers.remove(header::CONTENT_LENGTH);
    Response::from_parts(parts, Body::from(body))
}

/// The answer to a handler that panicked (for `CatchPanicLayer::custom`): 500 with the panic's
/// message as the error line. The server goes on serving.
pub fn panic_response(panic: Box<dyn std::any::Any + Send + 'static>) -> Response {
    panic_error(panic.as_ref()).into_response()
}

/// A 500 naming what a panic said.
pub fn panic_error(panic: &(dyn std::any::Any + Send)) -> ApiError {
    let detail = panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_string()))
        .unwrap_or_else(|| "unknown panic".to_string());
    ApiError::internal(format!("internal error (a bug in rigfit): {detail}"))
}
