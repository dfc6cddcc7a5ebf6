//! `mrmm op goto | move | capabilities | crash | charge | release`: orders about one robot,
//! through central.

use mrmm_net::client::Client;
use mrmm_proto::{self as proto, CapabilitiesRequest, CommandAck, GotoRequest, RobotMove};
use serde_json::Value;

use super::print_json;

#[derive(Debug, clap::Subcommand)]
pub(super) enum Order {
    /// Drive a robot to (x, y) (`mrmm/system/cmd/robot/goto`); on a map (central's only one, or
    /// the one named) along its corridors.
    #[command(allow_negative_numbers = true)]
    Goto {
        robot: String,
        x: f64,
        y: f64,
        #[arg(long)]
        map: Option<String>,
    },
    /// Move a robot to another mission, or out of its mission with `none`
    /// (`mrmm/system/cmd/robot/move`).
    Move {
        robot: String,
        to: String,
        /// Take this member's place (a hand-over): it is freed, the robot carries on its plan
        /// from where it is, the other members go on without a replan.
        #[arg(long, value_name = "MEMBER")]
        replacing: Option<String>,
    },
    /// Change what a robot can do (a sensor broke, a tool was fitted); it leaves a mission that
    /// requires what it no longer has (`mrmm/system/cmd/robot/capabilities`).
    Capabilities {
        robot: String,
        /// A capability it now has (repeatable).
        #[arg(long)]
        add: Vec<String>,
        /// A capability it no longer has (repeatable).
        #[arg(long)]
        remove: Vec<String>,
    },
    /// Crash a simulated robot, as if its computer died: its missions replan without it
    /// (`mrmm/system/cmd/robot/crash`; `start ID` on its `mrmm sim-fleet` brings it back). A
    /// robot with a ROS 2 body refuses.
    Crash { robot: String },
    /// Send a robot to charge now, whatever its charge: out of its mission (a spare moved in
    /// where its team would fall short) to the nearest free charger of its map
    /// (`mrmm/system/cmd/robot/charge`).
    Charge { robot: String },
    /// End a robot's charging: unplugged, back to the mission it left if that mission is short of
    /// it (`mrmm/system/cmd/robot/release`).
    Release { robot: String },
}

pub(super) async fn exec(client: &Client, order: Order, json: bool) -> anyhow::Result<()> {
    match order {
        Order::Goto { robot, x, y, map } => {
            let req = GotoRequest { robot: robot.into(), x, y, map };
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&req)).await?;
            if json {
                return print_json(&v);
            }
            let ack: CommandAck = serde_json::from_value(v)?;
            println!("{}: {}", ack.robot, ack.behaviour.describe());
        }
        Order::Move { robot, to, replacing } => {
            let to = (to != "none").then_some(to);
            let mv = RobotMove { robot: robot.into(), to: to.map(Into::into), replaces: replacing.clone().map(Into::into) };
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Move), Some(&mv)).await?;
            if json {
                return print_json(&v);
            }
            let instead = replacing.map(|r| format!(" (in place of {r})")).unwrap_or_default();
            println!("{}: {} → {}{instead}", v["robot"].as_str().unwrap_or("?"), v["from"].as_str().unwrap_or("none"), v["to"].as_str().unwrap_or("none"));
        }
        Order::Capabilities { robot, add, remove } => {
            if add.is_empty() && remove.is_empty() {
                anyhow::bail!("give --add NAME or --remove NAME (repeatable)");
            }
            let req = CapabilitiesRequest { robot: robot.into(), add, remove };
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Capabilities), Some(&req)).await?;
            if json {
                return print_json(&v);
            }
            let ack: CommandAck = serde_json::from_value(v.clone())?;
            let has = ack.capabilities.unwrap_or_default();
            println!("{}: {}", ack.robot, if has.is_empty() { "no capabilities".to_string() } else { has.join(", ") });
            if let Some(m) = v["left"].as_str() {
                println!("{} left mission {m}: it requires what the robot no longer has", ack.robot);
            }
        }
        Order::Crash { robot } => {
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Crash), Some(&proto::CrashRequest { robot: robot.into() })).await?;
            if json {
                return print_json(&v);
            }
            let ack: CommandAck = serde_json::from_value(v)?;
            println!("{}: crashed", ack.robot);
        }
        Order::Charge { robot } => {
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Charge), Some(&proto::ChargeRequest { robot: robot.into() })).await?;
            if json {
                return print_json(&v);
            }
            let at = &v["charger"]["at"];
            println!(
                "{}: to charger {} of map {} at ({}, {})",
                v["robot"].as_str().unwrap_or("?"),
                v["charger"]["name"].as_str().unwrap_or("?"),
                v["map"].as_str().unwrap_or("?"),
                at["x"],
                at["y"]
            );
        }
        Order::Release { robot } => {
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Release), Some(&proto::ChargeRequest { robot: robot.into() })).await?;
            if json {
                return print_json(&v);
            }
            println!("{}: released from charging", v["robot"].as_str().unwrap_or("?"));
        }
    }
    Ok(())
}
