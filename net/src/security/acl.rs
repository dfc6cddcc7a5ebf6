//! Central's Zenoh access control: operator authority comes from the transport identity, so any
//! Zenoh client (Python, zenoh-cli) holding an operator certificate can command the fleet, and no
//! other certificate can — whatever it sends, its queries on `mrmm/system/cmd/**` never reach the
//! system manager.
//!
//! Zenoh enforces this per instance and per link: central checks what arrives on each of its
//! links. That is enough here because only central serves the operator API and Zenoh peers do not
//! relay queries for each other: a query that reaches central's queryable came over the link of
//! the node that made it. The same rules also keep anyone but central from serving
//! `mrmm/system/**` or `mrmm/agent/**` to central's clients (a forged answer to an operator).

use serde_json::{json, Value};

use super::{Role, Sender};
use mrmm_proto::keys::Pattern;

/// The `access_control` section of central's Zenoh config, letting the operators named
/// `operators` (ids of operator certificates) query `mrmm/system/cmd/**`.
pub fn central_acl(operators: &[String]) -> Value {
    let cns: Vec<String> = operators.iter().map(|o| Sender::new(Role::Operator, o.clone()).common_name()).collect();
    let mut subjects = vec![json!({ "id": "fleet", "link_protocols": ["tls", "quic"] })];
    let mut policies = vec![json!({ "rules": ["no-commands", "no-operator-api"], "subjects": ["fleet"] })];
    if !cns.is_empty() {
        subjects.push(json!({ "id": "operators", "cert_common_names": cns }));
        policies.push(json!({ "rules": ["commands"], "subjects": ["operators"] }));
    }
    json!({
        "enabled": true,
        "default_permission": "allow",
        "rules": [
            { "id": "no-commands", "messages": ["query"], "flows": ["ingress"], "permission": "deny",
              "key_exprs": [Pattern::SystemCmdAll.to_string()] },
            { "id": "commands", "messages": ["query"], "flows": ["ingress"], "permission": "allow",
              "key_exprs": [Pattern::SystemCmdAll.to_string()] },
            { "id": "no-operator-api", "messages": ["declare_queryable"], "flows": ["ingress"], "permission": "deny",
              "key_exprs": [Pattern::SystemAll.to_string(), Pattern::AgentAll.to_string()] },
        ],
        "subjects": subjects,
        "policies": policies,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_acl_is_a_valid_zenoh_config_naming_the_operators() {
        let acl = central_acl(&["alice".into(), "bob".into()]);
        let mut c = zenoh::Config::default();
        c.insert_json5("access_control", &acl.to_string()).expect("zenoh accepts it");
        let text = acl.to_string();
        assert!(text.contains("operator:alice") && text.contains("operator:bob"));
        // With no operator, nobody may command (the deny rule alone).
        let none = central_acl(&[]);
        assert_eq!(none["policies"].as_array().map(Vec::len), Some(1));
        c.insert_json5("access_control", &none.to_string()).expect("valid too");
    }
}
