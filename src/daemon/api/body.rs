//! Request bodies: [`JsonBody`], a body read whole up to [`MAX_BODY_BYTES`] (a bigger one is a
//! 413 naming its size and the limit), and [`json_errors`], which turns any error response the
//! router's own machinery makes in plain text (an extractor's rejection) into the API's JSON
//! error shape.
//!
//! ```text
//!  Content-Length over the limit  -> 413 at once, nothing read
//!  a body that grows over it      -> 413 as soon as it does (chunked: its size is unknown)
//!  any other error not in JSON    -> {"error": "<its text>"} with the same status
//! ```

use axum::body::Bytes;
use axum::extract::{FromRequest, Request};
use axum::http::{HeaderMap, HeaderValue, header};
use axum::response::{IntoResponse, Response};
use http_body_util::LengthLimitError;

use super::error::ApiError;

/// The largest request body the API reads, bytes (2 MiB: a path order twice the largest path
/// file `linterpd run` sends).
pub const MAX_BODY_BYTES: usize = 2 << 20;
/// The most of a plain-text error body [`json_errors`] carries over.
const MAX_ERROR_TEXT_BYTES: usize = 4_096;

/// A request's body, at most [`MAX_BODY_BYTES`].
#[derive(Debug)]
pub(super) struct JsonBody(pub(super) Bytes);

impl<S: Send + Sync> FromRequest<S> for JsonBody {
    type Rejection = ApiError;

    async fn from_request(request: Request, _: &S) -> Result<Self, ApiError> {
        if let Some(bytes) = declared_length(request.headers())
            && bytes > MAX_BODY_BYTES as u64
        {
            return Err(too_large(Some(bytes)));
        }
        axum::body::to_bytes(request.into_body(), MAX_BODY_BYTES)
            .await
            .map(JsonBody)
            .map_err(|e| {
                if std::error::Error::source(&e)
                    .is_some_and(<dyn std::error::Error>::is::<LengthLimitError>)
                {
                    too_large(None)
                } else {
                    ApiError::BadRequest {
                        message: format!("cannot read the body: {e}"),
                        field: None,
                    }
                }
            })
    }
}

/// The body's size as its `Content-Length` gives it, if it does.
fn declared_length(headers: &HeaderMap) -> Option<u64> {
    headers
        .get(header::CONTENT_LENGTH)?
        .to_str()
        .ok()?
        .parse()
        .ok()
}

fn too_large(bytes: Option<u64>) -> ApiError {
    ApiError::TooLarge {
        bytes,
        limit: MAX_BODY_BYTES,
    }
}

/// Middleware: an error response (4xx, 5xx) that is not JSON becomes `{"error": text}`, the
/// text its body's (lower case first letter) or, for an empty one, its status' reason.
pub(super) async fn json_errors(response: Response) -> Response {
    let status = response.status();
    if !(status.is_client_error() || status.is_server_error()) || is_json(response.headers()) {
        return response;
    }
    let (parts, body) = response.into_parts();
    let text = axum::body::to_bytes(body, MAX_ERROR_TEXT_BYTES)
        .await
        .map(|b| String::from_utf8_lossy(&b).trim().to_owned())
        .unwrap_or_default();
    let message = if text.is_empty() {
        status.canonical_reason().unwrap_or("error").to_lowercase()
    } else {
        lower_first(&text)
    };
    let mut json = ApiError::Other { status, message }.into_response();
    for (name, value) in &parts.headers {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH {
            json.headers_mut().insert(name, value.clone());
        }
    }
    json
}

fn is_json(headers: &HeaderMap) -> bool {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v: &HeaderValue| v.to_str().ok())
        .is_some_and(|t| t.starts_with("application/json"))
}

/// `text` with its first letter in lower case, as the API's messages are.
fn lower_first(text: &str) -> String {
    let mut chars = text.chars();
    chars.next().map_or_else(String::new, |first| {
        first.to_lowercase().chain(chars).collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::StatusCode;

    #[tokio::test]
    async fn a_plain_text_rejection_becomes_the_json_error_shape() {
        let plain = (StatusCode::BAD_REQUEST, "Invalid URL: bad escape").into_response();
        let json = json_errors(plain).await;
        assert_eq!(json.status(), StatusCode::BAD_REQUEST);
        assert!(is_json(json.headers()));
        let body = axum::body::to_bytes(json.into_body(), 1_000).await.unwrap();
        assert_eq!(&body[..], br#"{"error":"invalid URL: bad escape"}"#);
    }

    #[tokio::test]
    async fn an_empty_error_body_says_its_status() {
        let empty = StatusCode::UNSUPPORTED_MEDIA_TYPE.into_response();
        let json = json_errors(empty).await;
        let body = axum::body::to_bytes(json.into_body(), 1_000).await.unwrap();
        assert_eq!(&body[..], br#"{"error":"unsupported media type"}"#);
    }

    #[test]
    fn too_large_names_the_size_and_the_limit() {
        assert_eq!(
            too_large(Some(10_485_760)).to_string(),
            "the body is 10485760 bytes; at most 2097152 bytes"
        );
        assert_eq!(
            too_large(None).to_string(),
            "the body is more than 2097152 bytes; at most 2097152 bytes"
        );
    }
}
