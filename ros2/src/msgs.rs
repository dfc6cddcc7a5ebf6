//! The ROS 2 messages a robot body exchanges, as serde types in CDR field order, each with its
//! ROS type name and its Jazzy type hash (RIHS01; checked against independent implementations in
//! `tests/ros2.rs`).

use serde::{Deserialize, Serialize};
use serde_big_array::BigArray;

/// A ROS 2 message type this crate can put on the wire.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> {
    /// `package/msg/Name`.
    const TYPE: &'static str;
    /// The RIHS01 hash of the type's description (ROS 2 Jazzy and later).
    const HASH: &'static str;
}

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// Seconds as a float (for staleness checks and logs).
    pub fn as_secs_f64(self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Twist`: what `/cmd_vel` carries.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    pub linear: Vector3,
    pub angular: Vector3,
}

impl Twist {
    /// A planar twist: `v` m/s forward, `omega` rad/s about z.
    pub fn planar(v: f64, omega: f64) -> Self {
        Twist { linear: Vector3 { x: v, y: 0.0, z: 0.0 }, angular: Vector3 { x: 0.0, y: 0.0, z: omega } }
    }

    pub fn is_zero(&self) -> bool {
        *self == Twist::default()
    }
}

impl RosMessage for Twist {
    const TYPE: &'static str = "geometry_msgs/msg/Twist";
    const HASH: &'static str = "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a";
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

impl Quaternion {
    /// A rotation of `yaw` radians about z.
    pub fn from_yaw(yaw: f64) -> Self {
        let h = yaw / 2.0;
        Quaternion { x: 0.0, y: 0.0, z: h.sin(), w: h.cos() }
    }

    /// The heading about z of this rotation (any roll and pitch ignored).
    pub fn yaw(&self) -> f64 {
        let siny = 2.0 * (self.w * self.z + self.x * self.y);
        let cosy = 1.0 - 2.0 * (self.y * self.y + self.z * self.z);
        siny.atan2(cosy)
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    pub pose: Pose,
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

impl Default for PoseWithCovariance {
    fn default() -> Self {
        PoseWithCovariance { pose: Pose::default(), covariance: [0.0; 36] }
    }
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    pub twist: Twist,
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

impl Default for TwistWithCovariance {
    fn default() -> Self {
        TwistWithCovariance { twist: Twist::default(), covariance: [0.0; 36] }
    }
}

/// `nav_msgs/msg/Odometry`: what `/odom` carries.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Odometry {
    pub header: Header,
    pub child_frame_id: String,
    pub pose: PoseWithCovariance,
    pub twist: TwistWithCovariance,
}

impl RosMessage for Odometry {
    const TYPE: &'static str = "nav_msgs/msg/Odometry";
    const HASH: &'static str = "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0";
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped`: what a localiser (`/amcl_pose`) publishes.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    pub header: Header,
    pub pose: PoseWithCovariance,
}

impl RosMessage for PoseWithCovarianceStamped {
    const TYPE: &'static str = "geometry_msgs/msg/PoseWithCovarianceStamped";
    const HASH: &'static str = "RIHS01_26432f9803e43727d3c8f668d1fdb3c630f548af631e2f4e31382371bfea3b6e";
}

/// `sensor_msgs/msg/BatteryState`: what a robot's battery driver publishes (`/battery_state`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct BatteryState {
    pub header: Header,
    pub voltage: f32,
    pub temperature: f32,
    pub current: f32,
    /// Charge left, Ah (NaN if not measured).
    pub charge: f32,
    /// Capacity when full, Ah (NaN if not measured).
    pub capacity: f32,
    pub design_capacity: f32,
    /// Charge left, 0–1 (NaN if not measured).
    pub percentage: f32,
    pub power_supply_status: u8,
    pub power_supply_health: u8,
    pub power_supply_technology: u8,
    pub present: bool,
    pub cell_voltage: Vec<f32>,
    pub cell_temperature: Vec<f32>,
    pub location: String,
    pub serial_number: String,
}

impl BatteryState {
    /// `power_supply_status` of a battery that is charging.
    pub const CHARGING: u8 = 1;
    /// `power_supply_status` of a full battery (on its charger).
    pub const FULL: u8 = 4;

    /// Its charge, 0–1: `percentage`, else `charge / capacity`; an error says why neither
    /// gives one.
    pub fn fraction(&self) -> Result<f64, String> {
        let p = f64::from(self.percentage);
        if p.is_finite() {
            if !(0.0..=1.0).contains(&p) {
                return Err(format!("{}: percentage {p} is not within 0–1", Self::TYPE));
            }
            return Ok(p);
        }
        let (c, cap) = (f64::from(self.charge), f64::from(self.capacity));
        if c.is_finite() && cap.is_finite() && cap > 0.0 && c >= 0.0 {
            return Ok((c / cap).min(1.0));
        }
        Err(format!("{}: neither percentage nor charge and capacity measured", Self::TYPE))
    }
}

impl RosMessage for BatteryState {
    const TYPE: &'static str = "sensor_msgs/msg/BatteryState";
    const HASH: &'static str = "RIHS01_4bee5dfce981c98faa6828b868307a0a73f992ed0789f374ee96c8f840e69741";
}

/// The DDS name of a ROS type, as rmw_zenoh puts it in key expressions:
/// `geometry_msgs/msg/Twist` → `geometry_msgs::msg::dds_::Twist_`.
pub fn dds_type_name(ros_type: &str) -> String {
    match ros_type.rsplit_once('/') {
        Some((pkg_kind, name)) => format!("{}::dds_::{name}_", pkg_kind.replace('/', "::")),
        None => format!("{ros_type}_"),
    }
}

/// Every message type of this crate: (type, hash), for checks against other implementations.
pub fn known_types() -> Vec<(&'static str, &'static str)> {
    vec![
        (Twist::TYPE, Twist::HASH),
        (Odometry::TYPE, Odometry::HASH),
        (PoseWithCovarianceStamped::TYPE, PoseWithCovarianceStamped::HASH),
        (BatteryState::TYPE, BatteryState::HASH),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_names() {
        assert_eq!(dds_type_name("geometry_msgs/msg/Twist"), "geometry_msgs::msg::dds_::Twist_");
        assert_eq!(dds_type_name("nav_msgs/msg/Odometry"), "nav_msgs::msg::dds_::Odometry_");
    }

    #[test]
    fn a_battery_state_gives_its_charge_or_says_why_not() {
        let b = BatteryState { percentage: 0.42, charge: f32::NAN, capacity: f32::NAN, ..BatteryState::default() };
        assert!((b.fraction().expect("percentage") - 0.42).abs() < 1e-6);
        let b = BatteryState { percentage: f32::NAN, charge: 5.0, capacity: 20.0, ..BatteryState::default() };
        assert!((b.fraction().expect("charge over capacity") - 0.25).abs() < 1e-9);
        let b = BatteryState { percentage: 85.0, ..BatteryState::default() };
        assert!(b.fraction().expect_err("a percent").contains("not within 0–1"));
        let b = BatteryState { percentage: f32::NAN, charge: f32::NAN, capacity: 20.0, ..BatteryState::default() };
        assert!(b.fraction().expect_err("unmeasured").contains("neither"));
        // A CDR round trip, sequences and strings included.
        let b = BatteryState { percentage: 0.5, cell_voltage: vec![3.7, 3.8], location: "slot 1".into(), power_supply_status: 1, ..BatteryState::default() };
        let bytes = crate::cdr::encode(&b).expect("encode");
        assert_eq!(crate::cdr::decode::<BatteryState>(&bytes).expect("decode"), b);
    }

    #[test]
    fn yaw_round_trip() {
        for yaw in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            assert!((Quaternion::from_yaw(yaw).yaw() - yaw).abs() < 1e-12);
        }
    }
}
