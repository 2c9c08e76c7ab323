//! [`ApiError`]: every way a request fails, each with its HTTP status and a JSON body
//! `{"error": "...", "field": "..."}` (`field` only where one field is to blame).

use axum::Json;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use thiserror::Error;

use crate::daemon::SubmitError;

/// Why a request failed.
#[derive(Debug, Error)]
pub enum ApiError {
    /// A robot, move or path that does not exist (404).
    #[error("{message}")]
    NotFound {
        /// What was not found and what there is.
        message: String,
        /// The path parameter to blame (`robot`, `id`), if any.
        field: Option<&'static str>,
    },
    /// A body that is not JSON, not a move order, or an order with a bad field (400).
    #[error("{message}")]
    BadRequest {
        /// What is wrong.
        message: String,
        /// The field to blame, when one is.
        field: Option<String>,
    },
    /// An order that cannot be planned from where the robot is or will be (422).
    #[error("{0}")]
    Unplannable(String),
    /// A command that did not reach the PLC (502).
    #[error("{0}")]
    PlcUnreachable(String),
    /// The daemon is shutting down (503).
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// A TCP request without the right bearer token (401).
    #[error("missing or wrong bearer token: send Authorization: Bearer <token>")]
    Unauthorized,
    /// A method the path does not take (405).
    #[error("method not allowed here")]
    MethodNotAllowed,
}

/// The JSON body of an error.
#[derive(Debug, Serialize)]
struct ErrorBody<'a> {
    error: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    field: Option<&'a str>,
}

impl ApiError {
    /// The HTTP status this error answers with.
    #[must_use]
    pub fn status(&self) -> StatusCode {
        match self {
            Self::NotFound { .. } => StatusCode::NOT_FOUND,
            Self::BadRequest { .. } => StatusCode::BAD_REQUEST,
            Self::Unplannable(_) => StatusCode::UNPROCESSABLE_ENTITY,
            Self::PlcUnreachable(_) => StatusCode::BAD_GATEWAY,
            Self::ShuttingDown => StatusCode::SERVICE_UNAVAILABLE,
            Self::Unauthorized => StatusCode::UNAUTHORIZED,
            Self::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
        }
    }

    fn field(&self) -> Option<&str> {
        match self {
            Self::NotFound { field, .. } => *field,
            Self::BadRequest { field, .. } => field.as_deref(),
            _ => None,
        }
    }
}

impl From<SubmitError> for ApiError {
    fn from(e: SubmitError) -> Self {
        match e {
            SubmitError::Order(order) => Self::BadRequest {
                message: order.to_string(),
                field: Some(order.field.to_owned()),
            },
            SubmitError::Plan(plan) => Self::Unplannable(plan.to_string()),
            SubmitError::ShuttingDown => Self::ShuttingDown,
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = ErrorBody {
            error: self.to_string(),
            field: self.field(),
        };
        let mut response = (self.status(), Json(body)).into_response();
        if matches!(self, Self::Unauthorized) {
            response.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                header::HeaderValue::from_static("Bearer"),
            );
        }
        response
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::OrderError;

    #[test]
    fn order_error_is_a_bad_request_naming_its_field() {
        let e = ApiError::from(SubmitError::Order(OrderError {
            field: "speed_mm_s",
            value: "0".into(),
            reason: "must be a number above 0".into(),
        }));
        assert_eq!(e.status(), StatusCode::BAD_REQUEST);
        assert_eq!(e.field(), Some("speed_mm_s"));
    }

    #[test]
    fn error_body_leaves_out_an_absent_field() {
        let body = ErrorBody {
            error: "x".into(),
            field: None,
        };
        assert_eq!(serde_json::to_string(&body).unwrap(), r#"{"error":"x"}"#);
    }
}
