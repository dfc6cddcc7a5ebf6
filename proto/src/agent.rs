//! Advising-agent payloads (JSON).

use serde::{Deserialize, Serialize};

use crate::time::Time;

/// How urgent a piece of advice is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Priority {
    Info,
    Warning,
    Critical,
}

/// One piece of advice: what, why, the numbers, and the command that would act on it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Advice {
    /// Stable identity: the same situation keeps the same id while it stands.
    pub id: String,
    pub priority: Priority,
    /// One line for the operator.
    pub reason: String,
    /// The numbers behind it.
    pub evidence: serde_json::Value,
    /// A command ready to run (`mrmm op …`), if there is one.
    pub suggestion: Option<String>,
    /// The same suggestion as the operator API's move (`mrmm/system/cmd/robot/move`), for a
    /// client to carry out as it is (the browser console's *Apply*).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action: Option<crate::RobotMove>,
    /// Raised at (seconds since central started).
    pub since: Time,
    /// `act` autonomy ran the suggestion.
    #[serde(default)]
    pub acted: bool,
    /// How the agent's own action went (`done`, `failed: …`), when it acted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outcome: Option<String>,
}

/// A change in the advice, published on `mrmm/agent/advice/live`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum AdviceEvent {
    Raised(Advice),
    Withdrawn { id: String, reason: String },
}
