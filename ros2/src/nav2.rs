//! Nav2's `NavigateToPose` action as rmw_zenoh carries it: three services under
//! `<action>/_action/` (`send_goal`, `get_result`, `cancel_goal`), each a Zenoh query with the
//! usual attachment. Only what is the same in every Nav2 release is encoded here: the goal (a
//! stamped pose and a behaviour-tree name), the send-goal answer, the status that opens a result
//! and the cancel request. The services' type hashes are learned from the action server's graph
//! tokens ([`ServerHashes`]): `nav2_msgs` changed between releases of one ROS distribution (the
//! result's error fields), so a hash compiled in would miss some servers a lenient client serves.

use serde::{Deserialize, Serialize};

use crate::cdr;
use crate::error::Ros2Error;
use crate::graph::{qualify, Endpoint, EntityKind};
use crate::msgs::{Header, Point, Pose, Quaternion, Time};

/// DDS type names of the action's services, as rmw_zenoh writes them in keys and tokens.
pub const SEND_GOAL_TYPE: &str = "nav2_msgs::action::dds_::NavigateToPose_SendGoal_";
pub const GET_RESULT_TYPE: &str = "nav2_msgs::action::dds_::NavigateToPose_GetResult_";
pub const CANCEL_GOAL_TYPE: &str = "action_msgs::srv::dds_::CancelGoal_";
/// DDS type name of the action's feedback topic.
pub const FEEDBACK_TYPE: &str = "nav2_msgs::action::dds_::NavigateToPose_FeedbackMessage_";

/// Goal ids, events and status codes as the robot's machine hears them (declared, I/O-free, in
/// the protocol crate).
pub use mrmm_proto::nav::{status, GoalEvent, GoalId};

/// The three services' names under an action (fully qualified in `namespace`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ActionNames {
    pub send_goal: String,
    pub get_result: String,
    pub cancel_goal: String,
    pub feedback: String,
}

impl ActionNames {
    pub fn new(namespace: &str, action: &str) -> Self {
        let base = qualify(namespace, action);
        ActionNames {
            send_goal: format!("{base}/_action/send_goal"),
            get_result: format!("{base}/_action/get_result"),
            cancel_goal: format!("{base}/_action/cancel_goal"),
            feedback: format!("{base}/_action/feedback"),
        }
    }
}

/// The type hashes an action server announces for its services.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ServerHashes {
    pub send_goal: Option<String>,
    pub get_result: Option<String>,
    pub cancel_goal: Option<String>,
    /// The feedback publisher's hash (not needed to send goals).
    pub feedback: Option<String>,
}

impl ServerHashes {
    /// Whether every service of the server is known: goals can be sent.
    pub fn complete(&self) -> bool {
        self.send_goal.is_some() && self.get_result.is_some() && self.cancel_goal.is_some()
    }

    /// Takes in a graph endpoint: a service server of this action with the expected type and a
    /// well-formed hash (a hostile token cannot put wildcards into our keys). `gone` is a token
    /// that went away. Returns whether anything changed.
    pub fn learn(&mut self, names: &ActionNames, e: &Endpoint, gone: bool) -> bool {
        if !valid_hash(&e.hash) {
            return false;
        }
        let server = e.kind == EntityKind::ServiceServer;
        let slot = if e.kind == EntityKind::Publisher && e.topic == names.feedback && e.dds_type == FEEDBACK_TYPE {
            &mut self.feedback
        } else if !server {
            return false;
        } else if e.topic == names.send_goal && e.dds_type == SEND_GOAL_TYPE {
            &mut self.send_goal
        } else if e.topic == names.get_result && e.dds_type == GET_RESULT_TYPE {
            &mut self.get_result
        } else if e.topic == names.cancel_goal && e.dds_type == CANCEL_GOAL_TYPE {
            &mut self.cancel_goal
        } else {
            return false;
        };
        let new = if gone { slot.as_ref().filter(|h| **h != e.hash).cloned() } else { Some(e.hash.clone()) };
        let changed = *slot != new;
        *slot = new;
        changed
    }
}

/// `RIHS01_` and 64 hex digits.
pub fn valid_hash(h: &str) -> bool {
    h.strip_prefix("RIHS01_").is_some_and(|d| d.len() == 64 && d.bytes().all(|b| b.is_ascii_hexdigit()))
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    pub header: Header,
    pub pose: Pose,
}

/// `nav2_msgs/action/NavigateToPose_SendGoal_Request`: the goal id and the goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SendGoalRequest {
    pub goal_id: GoalId,
    pub pose: PoseStamped,
    /// Empty: the navigator's default tree.
    pub behavior_tree: String,
}

/// `…_SendGoal_Response`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SendGoalResponse {
    pub accepted: bool,
    pub stamp: Time,
}

/// `…_GetResult_Request`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GetResultRequest {
    pub goal_id: GoalId,
}

/// The first field of `…_GetResult_Response`: the goal's final status (the result that follows
/// differs between Nav2 releases and is not needed).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GetResultStatus {
    pub status: i8,
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RosDuration {
    pub sec: i32,
    pub nanosec: u32,
}

/// `nav2_msgs/action/NavigateToPose_FeedbackMessage` (the same from Humble to Jazzy).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeedbackMessage {
    pub goal_id: GoalId,
    pub current_pose: PoseStamped,
    pub navigation_time: RosDuration,
    pub estimated_time_remaining: RosDuration,
    pub number_of_recoveries: i16,
    pub distance_remaining: f32,
}

/// Reads a feedback message: the goal it is about and what it says.
pub fn decode_feedback(bytes: &[u8]) -> Result<(GoalId, GoalEvent), Ros2Error> {
    let f = cdr::decode_named::<FeedbackMessage>("NavigateToPose_FeedbackMessage", bytes)?;
    let recoveries = u16::try_from(f.number_of_recoveries).unwrap_or(0);
    let distance_remaining = if f.distance_remaining.is_finite() { f.distance_remaining } else { 0.0 };
    Ok((f.goal_id, GoalEvent::Feedback { recoveries, distance_remaining }))
}

/// `action_msgs/msg/GoalInfo`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GoalInfo {
    pub goal_id: GoalId,
    pub stamp: Time,
}

/// `action_msgs/srv/CancelGoal_Request`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CancelGoalRequest {
    pub goal_info: GoalInfo,
}

/// The first field of `action_msgs/srv/CancelGoal_Response`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CancelGoalReturn {
    pub return_code: i8,
}

/// The send-goal request for a goal at (`x`, `y`) facing `yaw`, in `frame_id`, stamped `stamp`.
pub fn goal_request(goal_id: GoalId, frame_id: &str, stamp: Time, x: f64, y: f64, yaw: f64) -> Result<Vec<u8>, Ros2Error> {
    if !(x.is_finite() && y.is_finite() && yaw.is_finite()) {
        return Err(Ros2Error::Encode { name: "NavigateToPose goal".into(), source: "non-finite pose".into() });
    }
    let pose = PoseStamped {
        header: Header { stamp, frame_id: frame_id.to_string() },
        pose: Pose { position: Point { x, y, z: 0.0 }, orientation: Quaternion::from_yaw(yaw) },
    };
    cdr::encode_named("NavigateToPose_SendGoal_Request", &SendGoalRequest { goal_id, pose, behavior_tree: String::new() })
}

/// Reads a send-goal answer: whether the goal was accepted.
pub fn decode_accepted(bytes: &[u8]) -> Result<bool, Ros2Error> {
    cdr::decode_named::<SendGoalResponse>("NavigateToPose_SendGoal_Response", bytes).map(|r| r.accepted)
}

/// Reads a get-result answer's status.
pub fn decode_status(bytes: &[u8]) -> Result<i8, Ros2Error> {
    cdr::decode_named::<GetResultStatus>("NavigateToPose_GetResult_Response", bytes).map(|r| r.status)
}

/// Reads a cancel answer's return code (0 none, 1 rejected, 2 unknown goal, 3 goal terminated).
pub fn decode_cancel(bytes: &[u8]) -> Result<i8, Ros2Error> {
    cdr::decode_named::<CancelGoalReturn>("CancelGoal_Response", bytes).map(|r| r.return_code)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::parse_endpoint;

    const H: &str = "RIHS01_0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";

    fn server(topic: &str, dds: &str, hash: &str) -> Endpoint {
        Endpoint { node: "bt_navigator".into(), kind: EntityKind::ServiceServer, topic: topic.into(), dds_type: dds.into(), hash: hash.into() }
    }

    #[test]
    fn hashes_are_learned_from_the_servers_tokens_only() {
        let names = ActionNames::new("/tb4_1", "navigate_to_pose");
        assert_eq!(names.send_goal, "/tb4_1/navigate_to_pose/_action/send_goal");
        let mut h = ServerHashes::default();
        assert!(h.learn(&names, &server(&names.send_goal, SEND_GOAL_TYPE, H), false));
        assert!(!h.learn(&names, &server(&names.send_goal, SEND_GOAL_TYPE, H), false), "no change");
        assert!(!h.learn(&names, &server(&names.get_result, SEND_GOAL_TYPE, H), false), "wrong type");
        assert!(!h.learn(&names, &server(&names.get_result, GET_RESULT_TYPE, "RIHS01_**"), false), "a wildcard is not a hash");
        assert!(!h.learn(&names, &server("/navigate_to_pose/_action/get_result", GET_RESULT_TYPE, H), false), "another namespace");
        let mut client = server(&names.get_result, GET_RESULT_TYPE, H);
        client.kind = EntityKind::ServiceClient;
        assert!(!h.learn(&names, &client, false), "a client");
        assert!(!h.complete());
        assert!(h.learn(&names, &server(&names.get_result, GET_RESULT_TYPE, H), false));
        assert!(h.learn(&names, &server(&names.cancel_goal, CANCEL_GOAL_TYPE, H), false));
        assert!(h.complete());
        let mut fb = server(&names.feedback, FEEDBACK_TYPE, H);
        assert!(!h.learn(&names, &fb, false), "feedback comes from a publisher");
        fb.kind = EntityKind::Publisher;
        assert!(h.learn(&names, &fb, false));
        assert_eq!(h.feedback.as_deref(), Some(H));
        assert!(h.learn(&names, &server(&names.send_goal, SEND_GOAL_TYPE, H), true), "server gone");
        assert!(!h.complete());
        // From a real token.
        let tok = format!("@ros2_lv/0/abc/3/7/SS/%/%tb4_1/bt_navigator/%tb4_1%navigate_to_pose%_action%send_goal/{SEND_GOAL_TYPE}/{H}/::,10:,:,:,,");
        let e = parse_endpoint(0, &tok).expect("parses");
        assert!(h.learn(&names, &e, false));
        assert_eq!(h.send_goal.as_deref(), Some(H));
    }

    #[test]
    fn goal_and_answers_have_ros_layouts() {
        let bytes = goal_request([7; 16], "map", Time { sec: 1, nanosec: 2 }, 1.5, -2.0, 0.0).expect("encode");
        // header, goal id (16), stamp (8), frame_id ("map\0" after its length: 8, so the doubles
        // fall on 8 without padding), 7 doubles, the empty tree name (its length and the NUL).
        assert_eq!(&bytes[4..20], &[7; 16]);
        assert_eq!(&bytes[32..36], b"map\0");
        assert_eq!(&bytes[36..44], &1.5f64.to_le_bytes());
        assert_eq!(bytes.len(), 4 + 16 + 8 + 8 + 56 + 4 + 1);
        let ok = cdr::encode_named("r", &SendGoalResponse { accepted: true, stamp: Time::default() }).expect("encode");
        assert_eq!(decode_accepted(&ok).ok(), Some(true));
        // A result with a tail (Jazzy's error code and message) still yields its status.
        let mut res = cdr::encode_named("r", &GetResultStatus { status: status::ABORTED }).expect("encode");
        res.extend_from_slice(&[0, 0x91, 0x23, 0, 0, 0, 0, 0]);
        assert_eq!(decode_status(&res).ok(), Some(status::ABORTED));
        assert!(decode_status(&[0, 1, 0]).is_err());
        assert!(decode_accepted(&[9, 9, 0, 0, 1]).is_err());
        assert!(goal_request([0; 16], "map", Time::default(), f64::NAN, 0.0, 0.0).is_err());
        let fb = FeedbackMessage {
            goal_id: [3; 16],
            current_pose: PoseStamped::default(),
            navigation_time: RosDuration { sec: 4, nanosec: 0 },
            estimated_time_remaining: RosDuration { sec: 2, nanosec: 0 },
            number_of_recoveries: 2,
            distance_remaining: 1.25,
        };
        let bytes = cdr::encode_named("f", &fb).expect("encode");
        assert_eq!(decode_feedback(&bytes).ok(), Some(([3; 16], GoalEvent::Feedback { recoveries: 2, distance_remaining: 1.25 })));
        let bad = FeedbackMessage { number_of_recoveries: -5, distance_remaining: f32::NAN, ..fb };
        let bytes = cdr::encode_named("f", &bad).expect("encode");
        assert_eq!(decode_feedback(&bytes).ok(), Some(([3; 16], GoalEvent::Feedback { recoveries: 0, distance_remaining: 0.0 })));
    }
}
