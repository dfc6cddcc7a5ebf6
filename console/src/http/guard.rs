//! Who may call the console: every request must name this server by its loopback address (a
//! page of another site cannot reach it through a DNS name that points here), and every API call
//! must carry the console's token.

use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::middleware::Next;
use axum::response::Response;

use super::{error, AppState};

/// Whether `Host` names this server by a loopback address.
pub fn host_ok(headers: &HeaderMap, port: u16) -> bool {
    let Some(host) = headers.get(header::HOST).and_then(|h| h.to_str().ok()) else { return false };
    [format!("127.0.0.1:{port}"), format!("localhost:{port}"), format!("[::1]:{port}")].iter().any(|ok| ok.eq_ignore_ascii_case(host))
}

/// The token a request presents: `Authorization: Bearer …`, else the `token` query parameter.
pub(super) fn presented<'a>(headers: &'a HeaderMap, query: Option<&'a str>) -> Option<&'a str> {
    if let Some(v) = headers.get(header::AUTHORIZATION).and_then(|h| h.to_str().ok()) {
        return v.strip_prefix("Bearer ");
    }
    query?.split('&').find_map(|kv| kv.strip_prefix("token="))
}

/// Compares in time that does not depend on where the two differ.
pub(super) fn same(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

pub(super) async fn guard(State(st): State<AppState>, req: Request, next: Next) -> Response {
    if !host_ok(req.headers(), st.port) {
        return error(StatusCode::FORBIDDEN, format!("this console answers only as 127.0.0.1:{} (or localhost)", st.port));
    }
    if req.uri().path().starts_with("/api/") && !presented(req.headers(), req.uri().query()).is_some_and(|t| same(t, &st.token)) {
        return error(StatusCode::UNAUTHORIZED, "missing or wrong console token: open the URL `mrmm console` printed");
    }
    next.run(req).await
}
