//! Fleet identities as every node names them: roles, senders (`<role>:<id>`) and the `security`
//! section of a config. The certificates, seals and keys that prove them are `mrmm-net`'s
//! (`mrmm_net::security`); see `docs/security.md` for the threat model.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::keys::validate_id;

/// What a node is allowed to be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// A human operator's tool: may command the fleet through central.
    Operator,
    /// The central node: router, system manager, agent, its own mission host and planner.
    Central,
    /// A robot (and the mission host every robot runs).
    Robot,
    /// A mission host on another node (`mrmm mission-host`).
    Host,
    /// A planner service (`mrmm planner-service`).
    Planner,
    /// A site router (`mrmm router`): routes between sites, has no authority of its own.
    Router,
}

impl Role {
    pub const ALL: [Role; 6] = [Role::Operator, Role::Central, Role::Robot, Role::Host, Role::Planner, Role::Router];

    pub fn as_str(self) -> &'static str {
        match self {
            Role::Operator => "operator",
            Role::Central => "central",
            Role::Robot => "robot",
            Role::Host => "host",
            Role::Planner => "planner",
            Role::Router => "router",
        }
    }

    pub fn parse(s: &str) -> Option<Role> {
        Role::ALL.into_iter().find(|r| r.as_str() == s)
    }

    /// The role's one-byte code in a seal.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The role of a seal's code.
    pub fn from_code(c: u8) -> Option<Role> {
        Role::ALL.get(usize::from(c)).copied()
    }

    /// Nodes that may hold and lead mission managers (central, mission hosts, robots).
    pub fn hosts_missions(self) -> bool {
        matches!(self, Role::Central | Role::Host | Role::Robot)
    }
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A sender: proven by its certificate in a secure fleet, claimed in an insecure one.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Sender {
    pub role: Role,
    pub id: String,
}

impl Sender {
    pub fn new(role: Role, id: impl Into<String>) -> Sender {
        Sender { role, id: id.into() }
    }

    /// The certificate common name of this identity: `<role>:<id>` (ids never contain `:`, so a
    /// name can only mean one role).
    pub fn common_name(&self) -> String {
        format!("{}:{}", self.role, self.id)
    }

    /// Parses a common name `<role>:<id>`.
    pub fn from_common_name(cn: &str) -> Option<Sender> {
        let (role, id) = cn.split_once(':')?;
        validate_id(id).ok()?;
        Some(Sender { role: Role::parse(role)?, id: id.to_string() })
    }

    pub fn is(&self, role: Role, id: &str) -> bool {
        self.role == role && self.id == id
    }
}

impl fmt::Display for Sender {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.role, self.id)
    }
}

/// Default replay window: a sealed message older (or further in the future) than this is refused.
pub const DEFAULT_MAX_AGE_S: u64 = 120;

/// The `security` section of a node's config: where its certificate, key and the fleet CA are.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SecuritySection {
    /// The fleet CA certificate (PEM), `ca.crt` of `mrmm pki init`.
    pub ca: PathBuf,
    /// This node's certificate (PEM), from `mrmm pki issue`.
    pub cert: PathBuf,
    /// This node's private key (PEM, PKCS#8).
    pub key: PathBuf,
    /// Check, when connecting, that the other node's certificate names the address dialled (its
    /// certificate needs that address as a subject alternative name: `mrmm pki issue --san`).
    #[serde(default)]
    pub verify_names: bool,
    /// Seconds a sealed message stays acceptable (and the clock difference tolerated).
    #[serde(default = "default_max_age")]
    pub max_age_s: u64,
    /// Central only: ids of the operator certificates allowed to command the fleet.
    #[serde(default)]
    pub operators: Vec<String>,
}

fn default_max_age() -> u64 {
    DEFAULT_MAX_AGE_S
}

impl SecuritySection {
    /// The files of a PKI directory for identity `name` (`DIR/ca.crt`, `DIR/NAME.crt`, `DIR/NAME.key`).
    pub fn from_dir(dir: &Path, name: &str) -> SecuritySection {
        SecuritySection {
            ca: dir.join("ca.crt"),
            cert: dir.join(format!("{name}.crt")),
            key: dir.join(format!("{name}.key")),
            verify_names: false,
            max_age_s: DEFAULT_MAX_AGE_S,
            operators: vec![],
        }
    }

    /// The same section for node `name`: its certificate and key `<name>.crt`, `<name>.key`
    /// beside this one's (a template's, for many robots from one config).
    pub fn for_name(&self, name: &str) -> SecuritySection {
        let dir = self.cert.parent().map(Path::to_path_buf).unwrap_or_default();
        SecuritySection { cert: dir.join(format!("{name}.crt")), key: dir.join(format!("{name}.key")), ..self.clone() }
    }

    /// Checks the numbers and names of the section (files are checked when the identity is loaded).
    pub fn validate(&self, field: &str) -> Result<(), String> {
        if !(1..=86_400).contains(&self.max_age_s) {
            return Err(format!("{field}.max_age_s: must be in [1, 86400] seconds (got {})", self.max_age_s));
        }
        for (i, o) in self.operators.iter().enumerate() {
            validate_id(o).map_err(|e| format!("{field}.operators[{i}]: {e}"))?;
        }
        Ok(())
    }
}
