//! Robot configuration: a JSON5 file, validated into typed values with one-line errors.

use std::path::Path;

use mrmm_net::net::{validate_endpoints_for, validate_max_message_size, JoinMode, ZenohSection};
use mrmm_proto::config::{load_json5, parse_json5, positive, within};
use mrmm_proto::{validate_id, Pose, SecuritySection};
use serde::Deserialize;

use crate::error::PeerError;
use mrmm_core::body::battery::{Battery, BatteryModel};
use mrmm_core::body::Limits;
use mrmm_core::robot::{BodyKind, Nav2Setup, RobotSetup};
use mrmm_proto::nav::DriveMode;

/// Everything a robot peer needs to start (`mrmm robot --config robot.json5`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotConfig {
    /// Unique robot id, one key chunk.
    pub id: String,
    /// Robot type (e.g. `ground`, `aerial`): recipes choose behaviours per type.
    #[serde(rename = "type")]
    pub robot_type: String,
    #[serde(default)]
    pub capabilities: Vec<String>,
    pub kinematics: Kinematics,
    #[serde(default)]
    pub start: StartPose,
    /// Simulated seconds per wall-clock second.
    #[serde(default = "default_time_scale")]
    pub time_scale: f64,
    /// Telemetry publications per wall-clock second.
    #[serde(default = "default_telemetry_hz")]
    pub telemetry_hz: f64,
    #[serde(default)]
    pub zenoh: ZenohSection,
    /// Certificates of this robot (`mrmm pki issue DIR --role robot --id ID`); without it the
    /// robot runs insecure (plain TCP). Relative paths are relative to the config file.
    #[serde(default)]
    pub security: Option<SecuritySection>,
    /// Where the robot keeps its chain state (vote promises, the mission snapshots it
    /// replicates), so a crash-restart loses nothing and votes at once. Without it the robot is
    /// stateless: after a restart it holds nothing, waits out a 2 s quarantine before voting, and
    /// relies on its teammates and central's journal. Relative to the config file.
    #[serde(default)]
    pub state_dir: Option<std::path::PathBuf>,
    /// The body: `{ kind: "sim" }` (the default, a simulated unicycle) or `{ kind: "ros2", … }`
    /// (a ROS 2 robot reached over rmw_zenoh, see docs/ros2.md).
    #[serde(default)]
    pub body: BodySection,
    /// The simulated body's battery (left out: it never runs out; a ROS 2 robot reports its own).
    #[serde(default)]
    pub battery: Option<BatterySection>,
}

/// A simulated battery: `{ life_s: 600 }` (a full charge drives 600 s at top speed), or its model
/// in full; `charge` (0–1, default 1) is where it starts.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatterySection {
    pub life_s: Option<f64>,
    pub capacity_wh: Option<f64>,
    #[serde(default)]
    pub per_metre_wh: f64,
    #[serde(default)]
    pub per_radian_wh: f64,
    #[serde(default)]
    pub idle_w: f64,
    pub charge_w: Option<f64>,
    #[serde(default = "full")]
    pub charge: f64,
}

fn full() -> f64 {
    1.0
}

impl BatterySection {
    /// The model it describes at top speed `speed`; the error is `battery.field: problem`.
    pub fn model(&self, speed: f64) -> Result<BatteryModel, String> {
        if !(self.charge.is_finite() && (0.0..=1.0).contains(&self.charge)) {
            return Err(format!("battery.charge: must be within 0–1 (got {})", self.charge));
        }
        let model = match (self.life_s, self.capacity_wh, self.charge_w) {
            (Some(life), None, None) => {
                if self.per_metre_wh != 0.0 || self.per_radian_wh != 0.0 || self.idle_w != 0.0 {
                    return Err("battery: give life_s or the model (capacity_wh, per_metre_wh, idle_w, charge_w), not both".into());
                }
                positive("battery.life_s", life, 1e7)?;
                BatteryModel::lasting(life, speed)
            }
            (None, Some(capacity_wh), Some(charge_w)) => {
                BatteryModel { capacity_wh, per_metre_wh: self.per_metre_wh, per_radian_wh: self.per_radian_wh, idle_w: self.idle_w, charge_w }
            }
            (None, None, _) | (None, _, None) => return Err("battery: give life_s, or capacity_wh and charge_w with per_metre_wh or idle_w".into()),
            _ => return Err("battery: give life_s or the model (capacity_wh, per_metre_wh, idle_w, charge_w), not both".into()),
        };
        model.check().map_err(|e| format!("battery.{e}"))?;
        Ok(model)
    }
}

/// Which body the robot drives.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum BodySection {
    /// The simulated unicycle (kinematics, start pose and time scale apply).
    #[default]
    Sim,
    /// A ROS 2 robot: its graph over rmw_zenoh.
    Ros2(Box<mrmm_ros2::Ros2Body>),
    /// A VDA 5050 vehicle, driven through the gateway that runs its robot (`mrmm vda5050`): not
    /// for config files.
    #[serde(skip)]
    Vda5050 {
        /// Order ids begin with this.
        order_prefix: String,
        /// The `mapId` of its orders' nodes.
        map_id: String,
    },
}

/// Makes the paths of a `security` section relative to the directory of the file it was read from.
pub fn resolve_security_paths(section: &mut SecuritySection, config_file: &Path) {
    let Some(dir) = config_file.parent() else { return };
    for p in [&mut section.ca, &mut section.cert, &mut section.key] {
        if p.is_relative() {
            *p = dir.join(&*p);
        }
    }
}

/// Physical limits of the simulated body.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Kinematics {
    /// m/s
    pub max_speed: f64,
    /// rad/s
    pub max_turn_rate: f64,
}

/// Where the robot starts.
#[derive(Debug, Clone, Copy, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct StartPose {
    pub x: f64,
    pub y: f64,
    #[serde(default)]
    pub theta: f64,
}

fn default_time_scale() -> f64 {
    1.0
}
fn default_telemetry_hz() -> f64 {
    5.0
}

impl RobotConfig {
    /// Reads and validates a robot config file.
    pub fn load(path: &Path) -> Result<Self, PeerError> {
        let cfg = Self::read(path)?;
        cfg.validate().map_err(|e| PeerError::Config(format!("{}: {e}", path.display())))?;
        Ok(cfg)
    }

    /// Reads a config file without validating it, its relative paths resolved against the
    /// file's directory: for a command line that overrides some of it (`--pki`, `--connect`)
    /// and validates the result — a `quic/` endpoint's certificates may come from the flags.
    pub fn read(path: &Path) -> Result<Self, PeerError> {
        let mut cfg: RobotConfig = load_json5(path)?;
        if let Some(sec) = cfg.security.as_mut() {
            resolve_security_paths(sec, path);
        }
        if let (Some(dir), Some(base)) = (cfg.state_dir.as_mut(), path.parent()) {
            if dir.is_relative() {
                *dir = base.join(&*dir);
            }
        }
        Ok(cfg)
    }

    /// Parses and validates a config given as text (`origin` names it in errors).
    pub fn from_json5(origin: &str, text: &str) -> Result<Self, PeerError> {
        let cfg: RobotConfig = parse_json5(origin, text)?;
        cfg.validate().map_err(|e| PeerError::Config(format!("{origin}: {e}")))?;
        Ok(cfg)
    }

    /// Checks every value; the error is `field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        validate_id(&self.id).map_err(|_| format!("id: invalid robot id {:?}: use 1 to 64 characters of A-Z a-z 0-9 _ -", self.id))?;
        validate_id(&self.robot_type).map_err(|_| format!("type: {:?} must be 1 to 64 characters of A-Z a-z 0-9 _ -", self.robot_type))?;
        if self.capabilities.len() > mrmm_proto::MAX_CAPABILITIES {
            return Err(format!("capabilities: at most {} (got {})", mrmm_proto::MAX_CAPABILITIES, self.capabilities.len()));
        }
        for (i, c) in self.capabilities.iter().enumerate() {
            mrmm_proto::validate_capability(c).map_err(|e| format!("capabilities[{i}]: {e}"))?;
        }
        within("kinematics.max_speed", self.kinematics.max_speed, mrmm_proto::MIN_SPEED, mrmm_proto::MAX_SPEED)?;
        within("kinematics.max_turn_rate", self.kinematics.max_turn_rate, mrmm_proto::MIN_TURN_RATE, mrmm_proto::MAX_TURN_RATE)?;
        for (name, v) in [("start.x", self.start.x), ("start.y", self.start.y), ("start.theta", self.start.theta)] {
            if !v.is_finite() {
                return Err(format!("{name}: must be a finite number (got {v})"));
            }
        }
        within("time_scale", self.time_scale, *mrmm_proto::TIME_SCALES.start(), *mrmm_proto::TIME_SCALES.end())?;
        positive("telemetry_hz", self.telemetry_hz, 100.0)?;
        let secure = self.security.is_some();
        validate_endpoints_for("zenoh.listen", &self.zenoh.listen, secure)?;
        validate_endpoints_for("zenoh.connect", &self.zenoh.connect, secure)?;
        validate_max_message_size("zenoh.max_message_size", self.zenoh.max_message_size)?;
        if self.zenoh.mode == JoinMode::Client && self.zenoh.connect.is_empty() {
            return Err(
                "zenoh.connect: a client (zenoh.mode: client) needs a router to connect to: its site's router first, then fallbacks such as central".into()
            );
        }
        if let Some(sec) = &self.security {
            sec.validate("security")?;
            if !sec.operators.is_empty() {
                return Err("security.operators: only central's config lists operators".into());
            }
        }
        if let Some(dir) = &self.state_dir {
            if dir.as_os_str().is_empty() {
                return Err("state_dir: empty path (leave it out for a stateless robot)".into());
            }
            if dir.is_file() {
                return Err(format!("state_dir: {} is a file, not a directory", dir.display()));
            }
        }
        if let BodySection::Ros2(b) = &self.body {
            b.validate().map_err(|e| e.to_string())?;
            if self.time_scale != 1.0 {
                return Err(format!("time_scale: a ROS 2 body runs in real time: leave time_scale out or set it to 1 (got {})", self.time_scale));
            }
        }
        if let Some(b) = &self.battery {
            if matches!(self.body, BodySection::Ros2(_)) {
                return Err("battery: a ROS 2 robot reports its own battery (sensor_msgs/BatteryState): leave the section out".into());
            }
            b.model(self.kinematics.max_speed)?;
        }
        if self.zenoh.lease_ms < 100 || self.zenoh.lease_ms > 60_000 {
            return Err(format!("zenoh.lease_ms: must be 100..=60000 (got {})", self.zenoh.lease_ms));
        }
        Ok(())
    }

    pub fn limits(&self) -> Limits {
        Limits { max_speed: self.kinematics.max_speed, max_turn_rate: self.kinematics.max_turn_rate }
    }

    pub fn start_pose(&self) -> Pose {
        Pose { x: self.start.x, y: self.start.y, theta: self.start.theta }
    }

    /// What the robot's machine is made of (a Nav2 body's goal ids seeded at random: they must
    /// not repeat across restarts).
    pub fn setup(&self) -> RobotSetup {
        let body = match &self.body {
            BodySection::Sim => BodyKind::Sim,
            BodySection::Vda5050 { order_prefix, map_id } => BodyKind::Vda { order_prefix: order_prefix.clone(), map_id: map_id.clone() },
            BodySection::Ros2(b) => BodyKind::Ros {
                odom_timeout_s: b.odom_timeout_ms as f64 / 1000.0,
                stop_on_fleet_loss: b.stop_on_fleet_loss,
                localised: b.pose_topic.is_some(),
                nav2: (b.drive == DriveMode::Nav2).then(|| Nav2Setup { action: b.nav2_action.clone(), goal_seed: rand::random() }),
            },
        };
        RobotSetup {
            id: self.id.as_str().into(),
            robot_type: self.robot_type.clone(),
            capabilities: self.capabilities.clone(),
            limits: self.limits(),
            start: self.start_pose(),
            time_scale: self.time_scale,
            durable: self.state_dir.is_some(),
            body,
            // Validated: a model that does not work never gets here.
            battery: self.battery.and_then(|b| b.model(self.kinematics.max_speed).ok().map(|m| Battery::new(m, b.charge))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"{
        id: "r1", type: "ground", capabilities: ["camera"],
        kinematics: { max_speed: 1.2, max_turn_rate: 2.0 },
        start: { x: 1, y: 2 },
        zenoh: { listen: ["tcp/127.0.0.1:7501"], connect: ["tcp/127.0.0.1:7447"] },
    }"#;

    fn err(text: &str) -> String {
        RobotConfig::from_json5("robot.json5", text).expect_err("should fail").to_string()
    }

    #[test]
    fn good_config_loads_with_defaults() {
        let c = RobotConfig::from_json5("robot.json5", GOOD).expect("valid");
        assert_eq!(c.id, "r1");
        assert_eq!(c.time_scale, 1.0);
        assert_eq!(c.zenoh.lease_ms, 1000);
        assert_eq!(c.start_pose(), Pose { x: 1.0, y: 2.0, theta: 0.0 });
    }

    #[test]
    fn errors_name_file_field_and_problem() {
        let e = err(&GOOD.replace("max_speed: 1.2", "max_speed: -1"));
        assert!(e.starts_with("robot.json5: kinematics.max_speed: must be"), "{e}");
        let e = err(&GOOD.replace("max_turn_rate: 2.0", "max_turn_rate: 0.001"));
        assert!(e.starts_with("robot.json5: kinematics.max_turn_rate: must be a number in [0.01, 1000]"), "{e}");
        let e = err(&GOOD.replace("max_speed: 1.2", "max_speed: \"fast\""));
        assert!(e.contains("kinematics.max_speed"), "{e}");
        let e = err(&GOOD.replace("id: \"r1\", ", ""));
        assert!(e.contains("missing field `id`"), "{e}");
        let e = err(&GOOD.replace("capabilities", "capabilites"));
        assert!(e.contains("unknown field `capabilites`"), "{e}");
        let e = err(&GOOD.replace("[\"camera\"]", "[\"camera\", \"night vision\"]"));
        assert!(e.starts_with("robot.json5: capabilities[1]: bad capability \"night vision\""), "{e}");
        let e = err(&GOOD.replace("\"r1\"", "\"r/1\""));
        assert!(e.starts_with("robot.json5: id: invalid robot id"), "{e}");
        let e = err("{ id: ");
        assert!(e.starts_with("robot.json5: "), "{e}");
        assert!(!e.contains('\n'));
        let wildcard = ["0", "0", "0", "0"].join(".");
        let e = err(&GOOD.replace("127.0.0.1:7501", &format!("{wildcard}:7501")));
        assert!(e.contains("zenoh.listen[0]"), "{e}");
    }

    #[test]
    fn a_client_robot_names_its_router() {
        assert_eq!(RobotConfig::from_json5("r", GOOD).expect("valid").zenoh.mode, JoinMode::Peer);
        let client = GOOD.replace("connect: [", "mode: \"client\", connect: [");
        assert_eq!(RobotConfig::from_json5("r", &client).expect("valid").zenoh.mode, JoinMode::Client);
        let e = err(&client.replace("[\"tcp/127.0.0.1:7447\"]", "[]"));
        assert!(e.starts_with("robot.json5: zenoh.connect: a client (zenoh.mode: client) needs a router"), "{e}");
        let e = err(&GOOD.replace("connect: [", "mode: \"router\", connect: ["));
        assert!(e.contains("zenoh.mode") && e.contains("unknown variant `router`") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn a_ros2_body_is_checked_field_by_field() {
        let ros = |body: &str| GOOD.replace("start: { x: 1, y: 2 },", &format!("start: {{ x: 1, y: 2 }}, body: {body},"));
        let c = RobotConfig::from_json5("robot.json5", &ros(r#"{ kind: "ros2", namespace: "/robot1", odom_topic: "odom" }"#)).expect("valid");
        let BodySection::Ros2(b) = &c.body else { panic!("{:?}", c.body) };
        assert_eq!((b.router.as_str(), b.cmd_vel_topic.as_str(), b.odom_timeout_ms), ("tcp/127.0.0.1:7447", "/cmd_vel", 500));
        assert!(matches!(RobotConfig::from_json5("r", GOOD).expect("valid").body, BodySection::Sim));
        for (body, expect) in [
            (r#"{ kind: "ros3" }"#, "body"),
            (r#"{ kind: "ros2", router: "udp/127.0.0.1:7447" }"#, "body.router:"),
            (r#"{ kind: "ros2", cmd_vel_topic: "/cmd vel" }"#, "body.cmd_vel_topic:"),
            (r#"{ kind: "ros2", namespace: "robot1" }"#, "body.namespace:"),
            (r#"{ kind: "ros2", odom_timeout_ms: 5 }"#, "body.odom_timeout_ms:"),
            (r#"{ kind: "ros2", domain_id: 300 }"#, "body.domain_id:"),
            (r#"{ kind: "ros2", drive: "teleport" }"#, "body"),
            (r#"{ kind: "ros2", odom_topc: "/odom" }"#, "odom_topc"),
        ] {
            let e = err(&ros(body));
            assert!(e.contains(expect) && !e.contains('\n'), "{body}: {e}");
        }
        let e = err(&ros(r#"{ kind: "ros2" }"#).replace("start:", "time_scale: 4, start:"));
        assert!(e.contains("time_scale: a ROS 2 body runs in real time"), "{e}");
    }

    #[test]
    fn a_battery_is_a_life_or_a_model_and_errors_name_its_field() {
        let with = |battery: &str| GOOD.replace("start: { x: 1, y: 2 },", &format!("start: {{ x: 1, y: 2 }}, battery: {battery},"));
        let c = RobotConfig::from_json5("robot.json5", &with("{ life_s: 600, charge: 0.5 }")).expect("valid");
        let b = c.setup().battery.expect("a battery");
        assert_eq!(b.charge(), 0.5);
        // A full charge drives 600 s at the top speed, 1.2 m/s.
        assert!((b.reach_m(1.2) - 0.5 * 720.0).abs() < 1e-6, "{}", b.reach_m(1.2));
        let c = RobotConfig::from_json5("r", &with("{ capacity_wh: 400, per_metre_wh: 0.1, idle_w: 20, charge_w: 200 }")).expect("valid");
        assert_eq!(c.setup().battery.expect("a battery").model().capacity_wh, 400.0);
        assert!(RobotConfig::from_json5("r", GOOD).expect("valid").setup().battery.is_none());
        for (battery, expect) in [
            ("{ life_s: -5 }", "battery.life_s:"),
            ("{ life_s: 600, charge: 1.5 }", "battery.charge:"),
            ("{ life_s: 600, idle_w: 3 }", "not both"),
            ("{ capacity_wh: 400, charge_w: 100 }", "never drains"),
            ("{ capacity_wh: 400, idle_w: 10 }", "battery: give life_s"),
            ("{ capacity_wh: 0, idle_w: 10, charge_w: 5 }", "battery.capacity_wh:"),
            ("{ life_s: 60, lifetime: 3 }", "lifetime"),
        ] {
            let e = err(&with(battery));
            assert!(e.contains(expect) && !e.contains('\n'), "{battery}: {e}");
        }
        let ros = with("{ life_s: 60 }").replace("start:", r#"body: { kind: "ros2" }, start:"#);
        assert!(err(&ros).contains("a ROS 2 robot reports its own battery"));
    }

    #[test]
    fn missing_file_is_one_line() {
        let e = RobotConfig::load(Path::new("/nonexistent/robot.json5")).expect_err("missing");
        assert!(e.to_string().starts_with("/nonexistent/robot.json5: cannot read"));
    }
}
