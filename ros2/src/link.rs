//! The robot's link to its own ROS 2 graph: a second Zenoh session, to the robot's ROS router
//! only (ROS traffic never enters the fleet mesh, nor fleet traffic the ROS graph), on which
//! mrmm is a node with a `cmd_vel` publisher and odometry (and pose) subscriptions, announced
//! with rmw_zenoh's liveliness tokens.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::sample::Sample;
use zenoh::Session;

use crate::action::NavClient;
use crate::attachment::{new_gid, Attachment, Gid};
use crate::cdr;
use crate::config::DriveMode;
use crate::config::Ros2Body;
use crate::error::Ros2Error;
use crate::graph::{mismatch, parse_endpoint, qualify, EntityKind, Node, Qos, ADMIN_SPACE};
use crate::msgs::{BatteryState, Odometry, PoseWithCovarianceStamped, RosMessage, Twist};
use crate::nav2::{GoalEvent, GoalId};

/// Samples waiting per subscription at most (the newest win: only the latest pose matters).
const QUEUE: usize = 16;

/// A planar pose from the ROS side: metres and radians in the body's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose2 {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

/// What the ROS graph told the body.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// Odometry: pose, forward speed and turn rate.
    Odometry { pose: Pose2, v: f64, omega: f64 },
    /// The localiser's pose.
    Pose(Pose2),
    /// The battery's charge (0–1) and whether it is charging.
    Battery { charge: f64, charging: bool },
    /// A payload that could not be read (logged and dropped by the caller).
    Malformed { topic: String, error: String },
    /// A node of the graph has one of our topics with another type or type hash: nothing flows
    /// between it and mrmm (the caller warns).
    Mismatch(String),
    /// Nav2's action server (all three of its services) appeared in the graph or left it.
    Nav2Server(bool),
    /// What became of a goal sent to Nav2.
    Goal { id: GoalId, event: GoalEvent },
}

/// The open link.
pub struct RosLink {
    session: Session,
    node: Node,
    cmd_vel: Publisher<'static>,
    cmd_vel_gid: Gid,
    seq: i64,
    odom: Subscriber<RingChannelHandler<Sample>>,
    pose: Option<Subscriber<RingChannelHandler<Sample>>>,
    battery: Option<Subscriber<RingChannelHandler<Sample>>>,
    odom_topic: String,
    pose_topic: Option<String>,
    battery_topic: Option<String>,
    /// The graph's tokens, to spot peers that speak another type on our topics.
    graph: Subscriber<RingChannelHandler<Sample>>,
    /// Our topics, fully qualified: cmd_vel, odometry, pose, battery.
    topics: (String, String, Option<String>, Option<String>),
    /// The Nav2 action client, with `drive: "nav2"`.
    nav: Option<NavClient>,
    _tokens: Vec<LivelinessToken>,
}

/// The Zenoh config of the ROS side: a peer like any rmw_zenoh node, connecting to the robot's
/// router (retrying while it is down), listening on loopback only, no multicast scouting.
pub fn zenoh_config(body: &Ros2Body) -> Result<zenoh::Config, Ros2Error> {
    let mut c = zenoh::Config::default();
    let router = format!("[{:?}]", body.router);
    for (key, value) in [
        ("mode", "\"peer\""),
        ("connect/endpoints", router.as_str()),
        ("connect/exit_on_failure", "false"),
        ("listen/endpoints", "[\"tcp/127.0.0.1:0\"]"),
        ("scouting/multicast/enabled", "false"),
    ] {
        c.insert_json5(key, value).map_err(|e| Ros2Error::Config(format!("zenoh config {key}: {e}")))?;
    }
    Ok(c)
}

impl RosLink {
    /// Opens the link as `robot_id`'s node. Returns once the session is open; the router may
    /// still be unreachable (Zenoh keeps trying).
    pub async fn open(body: &Ros2Body, robot_id: &str) -> Result<Self, Ros2Error> {
        body.validate()?;
        let session = zenoh::open(zenoh_config(body)?).await.map_err(Ros2Error::zenoh)?;
        let node =
            Node { domain_id: body.domain_id, zid: session.zid().to_string(), id: 0, namespace: body.namespace.clone(), name: body.node_name_for(robot_id) };
        let mut tokens = Vec::new();
        let token = |key: String| {
            let s = session.clone();
            async move { s.liveliness().declare_token(key).await.map_err(Ros2Error::zenoh) }
        };
        tokens.push(token(node.token()).await?);
        let cmd_vel = session.declare_publisher(node.topic_key::<Twist>(&body.cmd_vel_topic)).await.map_err(Ros2Error::zenoh)?;
        tokens.push(token(node.entity_token::<Twist>(1, EntityKind::Publisher, &body.cmd_vel_topic, Qos::DEFAULT)).await?);
        let odom = session.declare_subscriber(node.topic_key::<Odometry>(&body.odom_topic)).with(RingChannel::new(QUEUE)).await.map_err(Ros2Error::zenoh)?;
        tokens.push(token(node.entity_token::<Odometry>(2, EntityKind::Subscription, &body.odom_topic, Qos::DEFAULT)).await?);
        let pose = match &body.pose_topic {
            Some(t) => {
                let sub =
                    session.declare_subscriber(node.topic_key::<PoseWithCovarianceStamped>(t)).with(RingChannel::new(QUEUE)).await.map_err(Ros2Error::zenoh)?;
                tokens.push(token(node.entity_token::<PoseWithCovarianceStamped>(3, EntityKind::Subscription, t, Qos::DEFAULT)).await?);
                Some(sub)
            }
            None => None,
        };
        let battery = match &body.battery_topic {
            Some(t) => {
                let sub = session.declare_subscriber(node.topic_key::<BatteryState>(t)).with(RingChannel::new(QUEUE)).await.map_err(Ros2Error::zenoh)?;
                tokens.push(token(node.entity_token::<BatteryState>(4, EntityKind::Subscription, t, Qos::DEFAULT)).await?);
                Some(sub)
            }
            None => None,
        };
        let graph = session
            .liveliness()
            .declare_subscriber(format!("{ADMIN_SPACE}/{}/**", body.domain_id))
            .history(true)
            .with(RingChannel::new(QUEUE * 8))
            .await
            .map_err(Ros2Error::zenoh)?;
        let topics = (
            qualify(&node.namespace, &body.cmd_vel_topic),
            qualify(&node.namespace, &body.odom_topic),
            body.pose_topic.as_ref().map(|t| qualify(&node.namespace, t)),
            body.battery_topic.as_ref().map(|t| qualify(&node.namespace, t)),
        );
        let nav = match body.drive {
            DriveMode::Nav2 => Some(NavClient::new(session.clone(), node.clone(), &body.nav2_action, &body.frame_id).await?),
            DriveMode::CmdVel => None,
        };
        tracing::info!(node = %node.name, namespace = %node.namespace, router = %body.router, "ROS 2 body: node declared (rmw_zenoh)");
        Ok(RosLink {
            session,
            node,
            cmd_vel,
            cmd_vel_gid: new_gid(),
            seq: 0,
            odom,
            pose,
            battery,
            odom_topic: body.odom_topic.clone(),
            pose_topic: body.pose_topic.clone(),
            battery_topic: body.battery_topic.clone(),
            graph,
            topics,
            nav,
            _tokens: tokens,
        })
    }

    /// The node mrmm is in the ROS graph.
    pub fn node(&self) -> &Node {
        &self.node
    }

    /// Publishes a velocity command.
    pub async fn send_twist(&mut self, t: Twist) -> Result<(), Ros2Error> {
        self.seq = self.seq.saturating_add(1);
        let attachment = Attachment { sequence_number: self.seq, source_timestamp: now_ns(), source_gid: self.cmd_vel_gid };
        self.cmd_vel.put(cdr::encode(&t)?).attachment(attachment.to_zbytes()).await.map_err(Ros2Error::zenoh)
    }

    /// Sends a Nav2 goal (answers come through [`Self::recv`]); nothing without a Nav2 drive.
    pub fn send_goal(&self, id: GoalId, x: f64, y: f64, yaw: f64) {
        if let Some(n) = &self.nav {
            n.send_goal(id, x, y, yaw);
        }
    }

    /// Cancels a Nav2 goal.
    pub fn cancel_goal(&self, id: GoalId) {
        if let Some(n) = &self.nav {
            n.cancel_goal(id);
        }
    }

    /// The next input from the ROS graph (cancellation-safe: nothing is lost when another branch
    /// of a `select!` wins).
    pub async fn recv(&self) -> Input {
        loop {
            if let Some(input) = self.recv_one().await {
                return input;
            }
        }
    }

    async fn recv_one(&self) -> Option<Input> {
        let pose = async {
            match &self.pose {
                Some(s) => s.recv_async().await.ok(),
                None => std::future::pending().await,
            }
        };
        let battery = async {
            match &self.battery {
                Some(s) => s.recv_async().await.ok(),
                None => std::future::pending().await,
            }
        };
        let goal = async {
            match &self.nav {
                Some(n) => n.next().await,
                None => std::future::pending().await,
            }
        };
        Some(tokio::select! {
            input = goal => input,
            s = self.odom.recv_async() => match s {
                Ok(s) => decode_odometry(&s.payload().to_bytes()).unwrap_or_else(|error| Input::Malformed { topic: self.odom_topic.clone(), error }),
                Err(_) => std::future::pending().await,
            },
            Some(s) = pose => match cdr::decode::<PoseWithCovarianceStamped>(&s.payload().to_bytes()) {
                Ok(p) => pose2(&p.pose.pose).map(Input::Pose).unwrap_or_else(|error| Input::Malformed { topic: self.pose_topic.clone().unwrap_or_default(), error }),
                Err(e) => Input::Malformed { topic: self.pose_topic.clone().unwrap_or_default(), error: e.to_string() },
            },
            Some(s) = battery => decode_battery(&s.payload().to_bytes()).unwrap_or_else(|error| Input::Malformed { topic: self.battery_topic.clone().unwrap_or_default(), error }),
            s = self.graph.recv_async() => {
                let Ok(s) = s else { return std::future::pending().await };
                let e = parse_endpoint(self.node.domain_id, s.key_expr().as_str())?;
                let gone = s.kind() != zenoh::sample::SampleKind::Put;
                if let Some(n) = &self.nav {
                    if let Some(input) = n.on_graph(&e, gone).await {
                        return Some(input);
                    }
                }
                if gone {
                    return None;
                }
                let (cmd_vel, odom, pose, battery) = &self.topics;
                let why = mismatch::<Twist>(cmd_vel, &e)
                    .or_else(|| mismatch::<Odometry>(odom, &e))
                    .or_else(|| pose.as_ref().and_then(|p| mismatch::<PoseWithCovarianceStamped>(p, &e)))
                    .or_else(|| battery.as_ref().and_then(|b| mismatch::<BatteryState>(b, &e)))?;
                Input::Mismatch(why)
            }
        })
    }

    /// Stops the robot and closes the session (tokens go, so the node leaves the graph).
    pub async fn close(mut self) {
        let _ = self.send_twist(Twist::default()).await;
        if let Some(n) = &self.nav {
            n.cancel_active().await;
        }
        let _ = tokio::time::timeout(Duration::from_secs(2), self.session.close()).await;
    }
}

/// Decodes odometry into a planar pose and speeds; non-finite numbers are refused.
pub fn decode_odometry(bytes: &[u8]) -> Result<Input, String> {
    let o = cdr::decode::<Odometry>(bytes).map_err(|e| e.to_string())?;
    let pose = pose2(&o.pose.pose)?;
    let (v, omega) = (o.twist.twist.linear.x, o.twist.twist.angular.z);
    if !(v.is_finite() && omega.is_finite()) {
        return Err(format!("{}: non-finite twist", Odometry::TYPE));
    }
    Ok(Input::Odometry { pose, v, omega })
}

/// Decodes a battery's state into its charge (0–1) and whether it charges.
pub fn decode_battery(bytes: &[u8]) -> Result<Input, String> {
    let b = cdr::decode::<BatteryState>(bytes).map_err(|e| e.to_string())?;
    let charge = b.fraction()?;
    Ok(Input::Battery { charge, charging: b.power_supply_status == BatteryState::CHARGING })
}

fn pose2(p: &crate::msgs::Pose) -> Result<Pose2, String> {
    let q = p.orientation;
    let out = Pose2 { x: p.position.x, y: p.position.y, theta: q.yaw() };
    if [out.x, out.y, out.theta, q.x, q.y, q.z, q.w].iter().all(|v| v.is_finite()) {
        Ok(out)
    } else {
        Err("non-finite pose".into())
    }
}

pub(crate) fn now_ns() -> i64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// Type names and hashes of what the link speaks (for `mrmm` diagnostics and tests).
pub fn spoken_types() -> [(&'static str, &'static str); 4] {
    [
        (Twist::TYPE, Twist::HASH),
        (Odometry::TYPE, Odometry::HASH),
        (PoseWithCovarianceStamped::TYPE, PoseWithCovarianceStamped::HASH),
        (BatteryState::TYPE, BatteryState::HASH),
    ]
}
