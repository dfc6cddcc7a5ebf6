//! The request checks: the `Host` a request names, the token it presents, the command it asks for.

use super::*;
use axum::http::HeaderMap;

fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
    let mut h = HeaderMap::new();
    for (k, v) in pairs {
        h.insert(*k, HeaderValue::from_str(v).expect("header value"));
    }
    h
}

#[test]
fn only_a_loopback_host_with_this_port_is_served() {
    for ok in ["127.0.0.1:8080", "localhost:8080", "LOCALHOST:8080", "[::1]:8080"] {
        assert!(host_ok(&headers(&[("host", ok)]), 8080), "{ok}");
    }
    // A DNS name of another site that points here (rebinding), another port, no Host at all.
    for bad in ["evil.example:8080", "127.0.0.1:8081", "127.0.0.1", "127.0.0.1:8080.evil.example"] {
        assert!(!host_ok(&headers(&[("host", bad)]), 8080), "{bad}");
    }
    assert!(!host_ok(&HeaderMap::new(), 8080));
}

#[test]
fn the_token_comes_from_the_authorization_header_or_the_query() {
    let h = headers(&[("authorization", "Bearer abc")]);
    assert_eq!(presented(&h, None), Some("abc"));
    assert_eq!(presented(&h, Some("token=zzz")), Some("abc"), "the header wins");
    assert_eq!(presented(&HeaderMap::new(), Some("a=1&token=xyz")), Some("xyz"));
    assert_eq!(presented(&headers(&[("authorization", "Basic abc")]), None), None);
    assert_eq!(presented(&HeaderMap::new(), Some("tokens=xyz")), None);
    assert!(same("abc", "abc") && !same("abc", "abd") && !same("abc", "ab") && !same("", "a"));
}

#[test]
fn commands_map_to_the_operator_api_and_nothing_else() {
    assert_eq!(system_cmd("mission", "create"), Some(SystemCmd::Create));
    assert_eq!(system_cmd("mission", "terminate"), Some(SystemCmd::Terminate));
    assert_eq!(system_cmd("robot", "move"), Some(SystemCmd::Move));
    assert_eq!(system_cmd("robot", "goto"), Some(SystemCmd::Goto));
    assert_eq!(system_cmd("system", "shutdown"), None);
    assert_eq!(system_cmd("robot", "create"), None);
}

#[test]
fn an_assignment_takes_robots_and_a_mission_or_null_and_nothing_else() {
    let a: Assign = serde_json::from_str(r#"{"robots": ["r1", "r2"], "to": "p"}"#).expect("assign");
    assert_eq!((a.robots.len(), a.to.as_deref()), (2, Some("p")));
    let a: Assign = serde_json::from_str(r#"{"robots": ["r1"], "to": null}"#).expect("release");
    assert_eq!(a.to, None);
    assert!(serde_json::from_str::<Assign>(r#"{"robots": ["r1"], "to": "p", "host": "x"}"#).is_err());
}
