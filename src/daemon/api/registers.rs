//! The register gateway over HTTP: `GET` and `PUT /v1/robots/{name}/registers/{address}`, DT
//! words and X, Y, R bits as the robot's access list allows (docs/API.md).

use std::collections::HashMap;

use axum::Json;
use axum::extract::{Path, Query, State};
use serde::{Deserialize, Serialize};

use super::Api;
use super::body::JsonBody;
use super::error::ApiError;
use crate::daemon::{Values, values_from_json};
use crate::gateway::Address;

/// What a read or a write answers.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Registers {
    /// The first address, as Panasonic writes it.
    pub address: String,
    /// How many words or bits.
    pub count: usize,
    /// What was read, or written.
    pub values: Values,
}

/// A write's body: words as numbers, bits as `true`/`false` or 1/0 (checked against the area).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegisterWrite {
    /// The values, from the address on.
    pub values: Vec<serde_json::Value>,
}

pub(super) async fn read(
    State(api): State<Api>,
    Path((name, address)): Path<(String, String)>,
    Query(query): Query<HashMap<String, String>>,
) -> Result<Json<Registers>, ApiError> {
    let robot = api.robot(&name)?;
    let start = address_of(&address)?;
    let count = count_of(&query)?;
    let values = robot.read_registers(start, count).await?;
    Ok(Json(Registers {
        address: start.to_string(),
        count: values.len(),
        values,
    }))
}

pub(super) async fn write(
    State(api): State<Api>,
    Path((name, address)): Path<(String, String)>,
    JsonBody(body): JsonBody,
) -> Result<Json<Registers>, ApiError> {
    let robot = api.robot(&name)?;
    let start = address_of(&address)?;
    let body: RegisterWrite = serde_json::from_slice(&body).map_err(|e| ApiError::BadRequest {
        message: format!("the body must be {{\"values\": [...]}}: {e}"),
        field: Some("values".into()),
    })?;
    let values = values_from_json(start.area, &body.values).map_err(|e| ApiError::BadRequest {
        message: e.to_string(),
        field: Some("values".into()),
    })?;
    tracing::info!(robot = %name, address = %start, count = values.len(), "register write");
    robot.write_registers(start, values.clone()).await?;
    Ok(Json(Registers {
        address: start.to_string(),
        count: values.len(),
        values,
    }))
}

fn address_of(text: &str) -> Result<Address, ApiError> {
    text.parse()
        .map_err(|e: crate::gateway::AddressError| ApiError::BadRequest {
            message: format!("address {text:?}: {}", e.reason),
            field: Some("address".into()),
        })
}

/// `?count=N`, 1 without one.
fn count_of(query: &HashMap<String, String>) -> Result<u32, ApiError> {
    if let Some(other) = query.keys().find(|k| k.as_str() != "count") {
        return Err(ApiError::BadRequest {
            message: format!("unknown query parameter {other:?}; there is only count"),
            field: Some(other.clone()),
        });
    }
    query.get("count").map_or(Ok(1), |text| {
        text.parse().map_err(|_| ApiError::BadRequest {
            message: format!("count = {text:?}: must be a whole number of words or bits"),
            field: Some("count".into()),
        })
    })
}
