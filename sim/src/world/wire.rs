//! Messages to robots as their drivers receive them — a key, a payload, a proven sender — and
//! translated by the robot machine's own ingress, as `mrmm_peer::runtime` does; and a forger
//! that publishes arrivals and releases in other robots' names, which every robot must refuse.

use mrmm_core::robot::{Incoming, Refused};
use mrmm_proto::{Key, Sender, SyncArrival, SyncRelease};

use super::*;
use mrmm_core::egress::{heard, Out};

/// A message on its way to a robot.
#[derive(Debug, Clone)]
pub(super) struct Wire {
    pub key: String,
    pub payload: Vec<u8>,
    pub put: bool,
    /// Its proven sender (liveliness tokens have none).
    pub from: Option<Sender>,
}

impl Wire {
    /// A sealed JSON message of `from` on `key`.
    pub fn json<T: serde::Serialize>(key: Key, body: &T, from: Sender) -> Wire {
        Wire { key: key.to_string(), payload: serde_json::to_vec(body).unwrap_or_default(), put: true, from: Some(from) }
    }

    /// A robot's telemetry, as it publishes it.
    pub fn telemetry(t: &mrmm_proto::Telemetry, from: Sender) -> Wire {
        Wire { key: Key::RobotTelemetry(t.id.clone()).to_string(), payload: mrmm_proto::encode_telemetry(t).unwrap_or_default(), put: true, from: Some(from) }
    }

    /// A liveliness token appearing (`up`) or going.
    pub fn token(key: Key, up: bool) -> Wire {
        Wire { key: key.to_string(), payload: Vec::new(), put: up, from: None }
    }
}

impl World {
    /// Node `i` publishes `out`: every machine whose subscriptions take its key in hears it
    /// (after the network's delay, unless the network loses it), as Zenoh would deliver it.
    pub(super) fn publish(&mut self, i: usize, out: Out) {
        self.report.sent += 1;
        self.published += 1;
        let msg = Wire { key: out.key.to_string(), payload: out.payload, put: true, from: Some(self.sender(i)) };
        let system = central::subscriptions();
        for j in 0..self.nodes.len() {
            let n = &self.nodes[j];
            let local = i == j;
            let robot = n.robot.is_some() && heard(&n.links.subscriptions(), &msg.key, local);
            let host = n.host.as_ref().is_some_and(|h| heard(&h.subscriptions(), &msg.key, local));
            let central = n.central.is_some() && heard(&system, &msg.key, local);
            for (hears, machine) in [(robot, 0), (host, 1), (central, 2)] {
                if hears && !self.lost() {
                    let at = self.now + self.delay();
                    let (from, to, msg) = (i, j, Box::new(msg.clone()));
                    let ev = match machine {
                        0 => Ev::Robot { from, to, msg },
                        1 => Ev::Host { from, to, msg },
                        _ => Ev::Central { from, to, msg },
                    };
                    self.queue.push(at, ev);
                }
            }
        }
    }
}

/// How often (simulated seconds, on average) the forger strikes.
const FORGE_EVERY: f64 = 7.0;

impl World {
    /// Robot `i` hears `msg`: its ingress makes it an event, or refuses it — which no message
    /// of an honest node of the simulation may be.
    pub(super) fn robot_hears(&mut self, i: usize, msg: Wire) -> Result<(), String> {
        let Some(r) = self.nodes[i].robot.as_ref() else {
            return Ok(());
        };
        match r.ingress(Incoming { key: &msg.key, payload: &msg.payload, put: msg.put, from: msg.from.as_ref() }) {
            Ok(ev) => self.robot(i, ev),
            Err(e) => Err(format!("{} refused an honest message on {}: {e}", self.nodes[i].name, msg.key)),
        }
    }

    /// Host `i` hears `msg` (on the node's host, if it has one): its ingress makes it an event,
    /// or refuses it — which no message of an honest node may be.
    pub(super) fn host_hears(&mut self, i: usize, msg: Wire) -> Result<(), String> {
        if self.nodes[i].host.is_none() {
            return Ok(());
        }
        match host::ingress(Incoming { key: &msg.key, payload: &msg.payload, put: msg.put, from: msg.from.as_ref() }) {
            Ok(ev) => self.host(i, ev),
            Err(e) => Err(format!("{}'s host refused an honest message on {}: {e}", self.nodes[i].name, msg.key)),
        }
    }

    /// Central (if node `i` runs it) hears `msg`: the system manager's ingress makes it an event,
    /// or refuses it — which no message of an honest node may be.
    pub(super) fn central_hears(&mut self, i: usize, msg: Wire) -> Result<(), String> {
        if self.nodes[i].central.is_none() {
            return Ok(());
        }
        match central::ingress(Incoming { key: &msg.key, payload: &msg.payload, put: msg.put, from: msg.from.as_ref() }) {
            Ok(ev) => self.central(i, ev),
            Err(e) => Err(format!("central refused an honest message on {}: {e}", msg.key)),
        }
    }

    /// The next strike of the forger, from a random stream of its own (the honest nodes' draws
    /// stay as they were).
    pub(super) fn schedule_forgery(&mut self) {
        if self.cfg.robots > 1 {
            let at = self.now + self.forge_rng.gen_range(0.2 * FORGE_EVERY..1.8 * FORGE_EVERY);
            if at < self.end() {
                self.queue.push(at, Ev::Forge);
            }
        }
    }

    /// A robot in a team (proven as itself) publishes an arrival and a release in a teammate's
    /// name, and one arrival comes unsealed: every teammate must refuse all three, and nothing
    /// of the world changes.
    pub(super) fn forge(&mut self) -> Result<(), String> {
        self.schedule_forgery();
        let teamed: Vec<usize> =
            (0..self.nodes.len()).filter(|&i| self.links.up[i] && self.nodes[i].links.team().is_some() && self.nodes[i].robot.is_some()).collect();
        if teamed.len() < 2 {
            return Ok(());
        }
        let forger = teamed[self.forge_rng.gen_range(0..teamed.len())];
        let Some(team) = self.nodes[forger].links.team().map(|t| t.team.clone()) else { return Ok(()) };
        let victims: Vec<usize> = teamed.iter().copied().filter(|&j| j != forger && self.nodes[j].links.team().is_some_and(|t| t.team == team)).collect();
        let Some(&victim) = victims.first() else { return Ok(()) };
        let (name, claimed) = (self.nodes[forger].name.clone(), self.nodes[victim].name.clone());
        let epoch = self.nodes[victim].robot.as_ref().and_then(|r| r.executor()).map_or(0, |e| e.epoch());
        let me = self.sender(forger);
        let forged = [
            Wire::json(
                Key::TeamSync { team: team.clone(), point: 0, round: 0 },
                &SyncArrival { robot: claimed.clone().into(), epoch, point: 0, round: 0 },
                me.clone(),
            ),
            Wire::json(
                Key::TeamRelease { team: team.clone(), point: 0, round: 0 },
                &SyncRelease { leader: claimed.clone().into(), epoch, point: 0, round: 0 },
                me,
            ),
            Wire {
                from: None,
                ..Wire::json(
                    Key::TeamSync { team, point: 0, round: 0 },
                    &SyncArrival { robot: name.clone().into(), epoch, point: 0, round: 0 },
                    self.sender(forger),
                )
            },
        ];
        self.log(|| format!("{name} forges an arrival, a release and the telemetry of {claimed}, and an operator a chain message"));
        // At every host: the victim's telemetry from the forger, a chain message from an operator.
        let telemetry = mrmm_proto::Telemetry::resting(&claimed, self.now.secs());
        let at_hosts = [
            Wire::telemetry(&telemetry, self.sender(forger)),
            Wire::json(
                Key::HostChain(claimed.clone().into()),
                &mrmm_proto::ChainEnvelope { mission: "m".into(), from: "op".into(), msg: mrmm_proto::chain::Msg::Grant { epoch: 1 } },
                Sender::new(mrmm_proto::Role::Operator, "op"),
            ),
        ];
        // At central: the victim's telemetry from the forger.
        if self.nodes.iter().any(|n| n.central.is_some()) {
            let msg = &at_hosts[0];
            match central::ingress(Incoming { key: &msg.key, payload: &msg.payload, put: msg.put, from: msg.from.as_ref() }) {
                Err(Refused::NotEntitled { .. }) => self.report.forged_refused += 1,
                other => return Err(format!("central took a forgery on {}: {other:?}", msg.key)),
            }
        }
        for j in (0..self.nodes.len()).filter(|&j| self.nodes[j].host.is_some()) {
            for msg in &at_hosts {
                match host::ingress(Incoming { key: &msg.key, payload: &msg.payload, put: msg.put, from: msg.from.as_ref() }) {
                    Err(Refused::NotEntitled { .. }) => self.report.forged_refused += 1,
                    other => return Err(format!("{}'s host took a forgery on {}: {other:?}", self.nodes[j].name, msg.key)),
                }
            }
        }
        for j in victims {
            for msg in &forged {
                let Some(r) = self.nodes[j].robot.as_ref() else { continue };
                match r.ingress(Incoming { key: &msg.key, payload: &msg.payload, put: msg.put, from: msg.from.as_ref() }) {
                    Err(Refused::NotEntitled { .. } | Refused::Unproven { .. }) => self.report.forged_refused += 1,
                    other => return Err(format!("{} took a forgery of {name} on {}: {other:?}", self.nodes[j].name, msg.key)),
                }
            }
        }
        Ok(())
    }
}
