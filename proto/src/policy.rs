//! Who may publish what: the one rule per kind of publication that every node, the viewer and
//! the console apply to a publication's proven sender ([`crate::Mesh::entitled`]), instead of a
//! check written at each place that hears one.

use crate::security::{Role, Sender};

/// A publication, with the id it speaks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Publication<'a> {
    /// Robot `id`'s telemetry.
    Telemetry(&'a str),
    /// Robot `id`'s arrival at a barrier.
    Arrival(&'a str),
    /// A barrier's release announced by its leader, robot `id`.
    Release(&'a str),
    /// The advising agent's advice.
    Advice,
    /// A mission's status, published by its head on node `manager` (as the status says).
    Status { manager: &'a str },
}

impl Publication<'_> {
    /// What was attempted, as a refusal says it: `publish the telemetry of r1`.
    pub fn what(&self) -> String {
        match self {
            Publication::Telemetry(id) => format!("publish the telemetry of {id}"),
            Publication::Arrival(id) => format!("publish the barrier arrival of {id}"),
            Publication::Release(id) => format!("publish the barrier release of {id}"),
            Publication::Advice => "publish advice".to_string(),
            Publication::Status { manager } => format!("report a mission as managed by {manager}"),
        }
    }
}

/// Whether `from` may publish `p`: a robot speaks only for itself (its telemetry, its arrivals,
/// the releases it announces as leader), advice comes from central. `Err` says what was
/// attempted.
pub fn may_publish(p: Publication<'_>, from: &Sender) -> Result<(), String> {
    let ok = match p {
        Publication::Telemetry(id) | Publication::Arrival(id) | Publication::Release(id) => from.is(Role::Robot, id),
        Publication::Advice => from.role == Role::Central,
        Publication::Status { manager } => from.id == manager && from.role.hosts_missions(),
    };
    if ok {
        Ok(())
    } else {
        Err(p.what())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_speaks_only_for_itself_and_advice_only_comes_from_central() {
        let r1 = Sender::new(Role::Robot, "r1");
        for p in [Publication::Telemetry("r1"), Publication::Arrival("r1"), Publication::Release("r1")] {
            assert_eq!(may_publish(p, &r1), Ok(()));
        }
        assert_eq!(may_publish(Publication::Telemetry("r2"), &r1), Err("publish the telemetry of r2".to_string()));
        assert_eq!(may_publish(Publication::Arrival("r2"), &r1), Err("publish the barrier arrival of r2".to_string()));
        // The same id under another role is someone else.
        for role in [Role::Operator, Role::Host, Role::Central] {
            assert!(may_publish(Publication::Release("r1"), &Sender::new(role, "r1")).is_err());
        }
        assert_eq!(may_publish(Publication::Advice, &Sender::new(Role::Central, "central")), Ok(()));
        assert_eq!(may_publish(Publication::Advice, &r1), Err("publish advice".to_string()));
        // A mission's status comes from the node that manages it, a node that hosts missions.
        assert_eq!(may_publish(Publication::Status { manager: "r1" }, &r1), Ok(()));
        assert!(may_publish(Publication::Status { manager: "r2" }, &r1).is_err());
        assert!(may_publish(Publication::Status { manager: "op" }, &Sender::new(Role::Operator, "op")).is_err());
    }
}
