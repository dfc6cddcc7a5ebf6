//! The maps the console draws, as they arrive from the fleet: where each lies (and a graph's
//! lanes) as JSON, a grid's image as PNG.

use axum::extract::{Path, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;

use super::{error, AppState};

/// `GET /api/map/<hash>`: where a map lies and, for a graph, its lanes (404 while it is being
/// fetched).
pub(super) async fn layer(State(st): State<AppState>, Path(hash): Path<String>) -> Response {
    match st.maps.lock().ok().and_then(|m| m.get(&hash).map(|l| l.json.clone())) {
        Some(v) => Json(v).into_response(),
        None => error(StatusCode::NOT_FOUND, format!("no map {hash} (yet)")),
    }
}

/// `GET /api/map/<hash>/png`: a grid map's image.
pub(super) async fn png(State(st): State<AppState>, Path(hash): Path<String>) -> Response {
    match st.maps.lock().ok().and_then(|m| m.get(&hash).and_then(|l| l.png.clone())) {
        Some(png) => {
            let mut r = (*png).clone().into_response();
            r.headers_mut().insert(header::CONTENT_TYPE, HeaderValue::from_static("image/png"));
            r.headers_mut().insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
            r
        }
        None => error(StatusCode::NOT_FOUND, format!("no image of map {hash} (yet)")),
    }
}
