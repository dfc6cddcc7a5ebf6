//! The console's HTTP side: the page, the fleet as JSON and as server-sent events, and commands
//! forwarded to central's operator API. Every request must name this server by its loopback
//! address (a page of another site cannot reach it through a DNS name that points here), and
//! every API call must carry the console's token (`Authorization: Bearer …`, or `?token=…` for
//! the event stream, which browsers open without headers).

use std::convert::Infallible;
use std::sync::Arc;

use axum::extract::rejection::JsonRejection;
use axum::extract::{DefaultBodyLimit, Path, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::middleware;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use futures_util::Stream;
use mrmm_net::client::Client;
use mrmm_proto::QueryError;
use mrmm_proto::{ErrorCode, ErrorReply, Key, ProtoError, RobotMove, SystemCmd};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use tokio::sync::watch;

use crate::model::Snapshot;

mod guard;
mod maps;

use guard::guard;
pub use guard::host_ok;
#[cfg(test)]
use guard::{presented, same};

/// Largest request body: a mission create with a few thousand waypoints fits.
pub const MAX_BODY: usize = 256 * 1024;
/// Most robots one assignment moves.
pub const MAX_ASSIGN: usize = 1000;

const INDEX: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/console.js");
const STYLE: &str = include_str!("page/console.css");

/// What every handler shares.
#[derive(Clone)]
pub struct AppState {
    pub client: Arc<Client>,
    pub snapshots: watch::Receiver<Arc<Snapshot>>,
    pub token: Arc<str>,
    /// The port this server listens on (the `Host` every request must name).
    pub port: u16,
    /// The maps' layers, as they arrive.
    pub maps: crate::layers::Layers,
}

/// The console's routes.
pub fn router(state: AppState) -> Router {
    Router::new()
        .route("/", get(|| async { page(INDEX, "text/html; charset=utf-8") }))
        .route("/console.js", get(|| async { page(SCRIPT, "text/javascript; charset=utf-8") }))
        .route("/console.css", get(|| async { page(STYLE, "text/css; charset=utf-8") }))
        .route("/api/state", get(state_now))
        .route("/api/events", get(events))
        .route("/api/cmd/{group}/{verb}", post(command))
        .route("/api/assign", post(assign))
        .route("/api/map/{hash}", get(maps::layer))
        .route("/api/map/{hash}/png", get(maps::png))
        .layer(middleware::from_fn_with_state(state.clone(), guard))
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .with_state(state)
}

fn page(body: &'static str, kind: &'static str) -> Response {
    let mut r = body.into_response();
    let h = r.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(kind));
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static("default-src 'self'; script-src 'self'; style-src 'self'; connect-src 'self'; img-src 'self' data:; frame-ancestors 'none'"),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(header::REFERRER_POLICY, HeaderValue::from_static("no-referrer"));
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

fn error(status: StatusCode, msg: impl Into<String>) -> Response {
    (status, Json(json!({ "error": msg.into() }))).into_response()
}

async fn state_now(State(st): State<AppState>) -> Json<Snapshot> {
    Json((**st.snapshots.borrow()).clone())
}

/// The fleet as server-sent events: `state` with the whole snapshot, now and at every change.
async fn events(State(st): State<AppState>) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let stream = futures_util::stream::unfold((st.snapshots.clone(), true), |(mut rx, first)| async move {
        if !first && rx.changed().await.is_err() {
            return None;
        }
        let snap = rx.borrow_and_update().clone();
        let ev = Event::default().event("state").json_data(&*snap).unwrap_or_else(|e| Event::default().event("failure").data(e.to_string()));
        Some((Ok(ev), (rx, false)))
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}

/// The operator API's command for `/api/cmd/<group>/<verb>`.
fn system_cmd(group: &str, verb: &str) -> Option<SystemCmd> {
    Some(match (group, verb) {
        ("mission", "create") => SystemCmd::Create,
        ("mission", "terminate") => SystemCmd::Terminate,
        ("mission", "update") => SystemCmd::Update,
        ("mission", "pause") => SystemCmd::Pause,
        ("mission", "resume") => SystemCmd::Resume,
        ("robot", "move") => SystemCmd::Move,
        ("robot", "goto") => SystemCmd::Goto,
        ("robot", "capabilities") => SystemCmd::Capabilities,
        ("robot", "crash") => SystemCmd::Crash,
        ("robot", "charge") => SystemCmd::Charge,
        ("robot", "release") => SystemCmd::Release,
        ("traffic", "clear") => SystemCmd::ClearTraffic,
        _ => return None,
    })
}

/// Central's answer to a command, as an HTTP response: its JSON, or its error with its code
/// (`{"error", "code"}`, the status by the code: [`status_of`]); 502, code `busy`, when central
/// could not be asked.
async fn forward(client: &Client, cmd: SystemCmd, body: &Value) -> Result<Value, (StatusCode, ErrorReply)> {
    match client.query::<Value>(Key::SystemCmd(cmd), Some(body)).await {
        Ok(v) => Ok(v),
        Err(ProtoError::Query(QueryError::Remote(e))) => Err((status_of(&e), e)),
        Err(e) => Err((StatusCode::BAD_GATEWAY, ErrorReply::busy(e.to_string()))),
    }
}

/// The HTTP status of central's error, by its code: 404 not found, 409 conflict, 503 busy, 403
/// forbidden, else 400.
fn status_of(e: &ErrorReply) -> StatusCode {
    match e.code {
        Some(ErrorCode::NotFound) => StatusCode::NOT_FOUND,
        Some(ErrorCode::Conflict) => StatusCode::CONFLICT,
        Some(ErrorCode::Busy) => StatusCode::SERVICE_UNAVAILABLE,
        Some(ErrorCode::Forbidden | ErrorCode::Refused) => StatusCode::FORBIDDEN,
        _ => StatusCode::BAD_REQUEST,
    }
}

async fn command(State(st): State<AppState>, Path((group, verb)): Path<(String, String)>, body: Result<Json<Value>, JsonRejection>) -> Response {
    let Some(cmd) = system_cmd(&group, &verb) else {
        return error(
            StatusCode::NOT_FOUND,
            format!("no command {group}/{verb}: mission/create, mission/update, mission/pause, mission/resume, mission/terminate, robot/move, robot/goto, robot/capabilities, traffic/clear"),
        );
    };
    let Json(body) = match body {
        Ok(b) => b,
        Err(e) => return error(StatusCode::BAD_REQUEST, e.body_text()),
    };
    match forward(&st.client, cmd, &body).await {
        Ok(v) => Json(v).into_response(),
        Err((status, e)) => (status, Json(e)).into_response(),
    }
}

/// `POST /api/assign`: moves each robot to mission `to` (or out of its mission, `null`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Assign {
    pub robots: Vec<String>,
    pub to: Option<String>,
}

/// One robot's move in an assignment.
#[derive(Debug, Serialize)]
pub struct Moved {
    pub robot: String,
    pub ok: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

async fn assign(State(st): State<AppState>, body: Result<Json<Assign>, JsonRejection>) -> Response {
    let Json(a) = match body {
        Ok(b) => b,
        Err(e) => return error(StatusCode::BAD_REQUEST, e.body_text()),
    };
    if a.robots.is_empty() || a.robots.len() > MAX_ASSIGN {
        return error(StatusCode::BAD_REQUEST, format!("robots: give 1 to {MAX_ASSIGN} robot ids"));
    }
    // One at a time, in order: central replans the mission after each move anyway.
    let mut results = Vec::with_capacity(a.robots.len());
    for robot in a.robots {
        let mv = RobotMove { robot: robot.as_str().into(), to: a.to.as_deref().map(Into::into), replaces: None };
        let body = match serde_json::to_value(&mv) {
            Ok(b) => b,
            Err(e) => return error(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()),
        };
        let error = forward(&st.client, SystemCmd::Move, &body).await.err().map(|(_, e)| e.error);
        results.push(Moved { robot, ok: error.is_none(), error });
    }
    let status = if results.iter().all(|m| m.ok) { StatusCode::OK } else { StatusCode::MULTI_STATUS };
    (status, Json(json!({ "results": results }))).into_response()
}

#[cfg(test)]
mod tests;
