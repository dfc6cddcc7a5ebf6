//! mrmm's client of Nav2's `NavigateToPose` action on the ROS link: learns the server's service
//! hashes from the graph, announces its three service clients once it has them, sends goals
//! and cancels as queries with rmw_zenoh's attachment, and reports every answer as an
//! [`Input::Goal`] (a goal's result may come hours later: each goal waits in its own task).

use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::Mutex;
use std::time::Duration;

use tokio::sync::mpsc;
use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::Session;

use crate::attachment::{new_gid, Attachment, Gid};
use crate::cdr;
use crate::error::Ros2Error;
use crate::graph::{Endpoint, EntityKind, Node, Qos};
use crate::link::{now_ns, Input};
use crate::msgs::Time;
use crate::nav2::{
    decode_accepted, decode_cancel, decode_feedback, decode_status, goal_request, ActionNames, CancelGoalRequest, GetResultRequest, GoalEvent, GoalId,
    GoalInfo, ServerHashes, CANCEL_GOAL_TYPE, FEEDBACK_TYPE, GET_RESULT_TYPE, SEND_GOAL_TYPE,
};

/// How long the server may take to accept or reject a goal, or to answer a cancel.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a goal may run before mrmm stops waiting for its result (and tries it again).
const RESULT_TIMEOUT: Duration = Duration::from_secs(3600);
/// Answers waiting for the robot's loop at most.
const QUEUE: usize = 64;
/// Entity ids of the three clients in the node (the topics use 1–3).
const FIRST_ENTITY: u32 = 10;

/// The action client.
pub struct NavClient {
    session: Session,
    node: Node,
    names: ActionNames,
    frame_id: String,
    hashes: Mutex<ServerHashes>,
    tokens: tokio::sync::Mutex<Vec<LivelinessToken>>,
    gid: Gid,
    seq: AtomicI64,
    /// The goal sent last and not cancelled: cancelled when the link closes.
    active: Mutex<Option<GoalId>>,
    tx: mpsc::Sender<Input>,
    rx: tokio::sync::Mutex<mpsc::Receiver<Input>>,
    /// The navigator's feedback, whatever its hash (only the newest few matter).
    feedback: Subscriber<RingChannelHandler<Sample>>,
}

impl NavClient {
    pub async fn new(session: Session, node: Node, action: &str, frame_id: &str) -> Result<Self, Ros2Error> {
        let (tx, rx) = mpsc::channel(QUEUE);
        let names = ActionNames::new(&node.namespace, action);
        let feedback =
            session.declare_subscriber(node.service_key(&names.feedback, FEEDBACK_TYPE, "*")).with(RingChannel::new(8)).await.map_err(Ros2Error::zenoh)?;
        Ok(NavClient {
            names,
            feedback,
            session,
            node,
            frame_id: frame_id.to_string(),
            hashes: Mutex::new(ServerHashes::default()),
            tokens: tokio::sync::Mutex::new(Vec::new()),
            gid: new_gid(),
            seq: AtomicI64::new(0),
            active: Mutex::new(None),
            tx,
            rx: tokio::sync::Mutex::new(rx),
        })
    }

    /// A graph token appeared (or went, `gone`): learns the server's hashes; when the server
    /// becomes complete or incomplete, (un)announces the clients and says so.
    pub async fn on_graph(&self, e: &Endpoint, gone: bool) -> Option<Input> {
        let (was, now, hashes) = {
            let mut h = self.hashes.lock().unwrap_or_else(|p| p.into_inner());
            let was = h.complete();
            if !h.learn(&self.names, e, gone) {
                return None;
            }
            (was, h.complete(), h.clone())
        };
        let mut tokens = self.tokens.lock().await;
        tokens.clear();
        if now {
            let ours = [
                (&self.names.send_goal, SEND_GOAL_TYPE, &hashes.send_goal),
                (&self.names.get_result, GET_RESULT_TYPE, &hashes.get_result),
                (&self.names.cancel_goal, CANCEL_GOAL_TYPE, &hashes.cancel_goal),
            ];
            let clients = ours.into_iter().map(|(name, dds, hash)| (EntityKind::ServiceClient, name, dds, hash));
            let feedback = hashes.feedback.is_some().then_some((EntityKind::Subscription, &self.names.feedback, FEEDBACK_TYPE, &hashes.feedback));
            for (i, (kind, name, dds, hash)) in (0u32..).zip(clients.chain(feedback)) {
                let key = self.node.token_for(FIRST_ENTITY + i, kind, name, dds, hash.as_deref().unwrap_or_default(), Qos::DEFAULT);
                match self.session.liveliness().declare_token(key).await {
                    Ok(t) => tokens.push(t),
                    Err(e) => tracing::warn!("ROS 2 body: cannot announce the Nav2 client: {e}"),
                }
            }
            tracing::info!(action = %self.names.send_goal, "ROS 2 body: Nav2 action server found");
        }
        (was != now).then_some(Input::Nav2Server(now))
    }

    /// The next answer or feedback about a goal.
    pub async fn next(&self) -> Input {
        let answers = async {
            match self.rx.lock().await.recv().await {
                Some(i) => i,
                None => std::future::pending().await,
            }
        };
        let feedback = async {
            match self.feedback.recv_async().await {
                Ok(s) if s.payload().len() > cdr::MAX_PAYLOAD => {
                    Input::Malformed { topic: self.names.feedback.clone(), error: format!("{} bytes", s.payload().len()) }
                }
                Ok(s) => match decode_feedback(&s.payload().to_bytes()) {
                    Ok((id, event)) => Input::Goal { id, event },
                    Err(e) => Input::Malformed { topic: self.names.feedback.clone(), error: e.to_string() },
                },
                Err(_) => std::future::pending().await,
            }
        };
        tokio::select! {
            i = answers => i,
            i = feedback => i,
        }
    }

    fn keys(&self) -> Option<(String, String, String)> {
        let h = self.hashes.lock().unwrap_or_else(|p| p.into_inner());
        Some((
            self.node.service_key(&self.names.send_goal, SEND_GOAL_TYPE, h.send_goal.as_deref()?),
            self.node.service_key(&self.names.get_result, GET_RESULT_TYPE, h.get_result.as_deref()?),
            self.node.service_key(&self.names.cancel_goal, CANCEL_GOAL_TYPE, h.cancel_goal.as_deref()?),
        ))
    }

    fn attachment(&self) -> Attachment {
        let seq = self.seq.fetch_add(1, Ordering::Relaxed).saturating_add(1);
        Attachment { sequence_number: seq, source_timestamp: now_ns(), source_gid: self.gid }
    }

    /// Sends goal `id`; its acceptance and then its result come back through [`Self::next`].
    pub fn send_goal(&self, id: GoalId, x: f64, y: f64, yaw: f64) {
        let tx = self.tx.clone();
        let fail = |why: String| {
            let tx = tx.clone();
            tokio::spawn(async move {
                let _ = tx.send(Input::Goal { id, event: GoalEvent::Failed(why) }).await;
            });
        };
        let Some((send_key, result_key, _)) = self.keys() else {
            return fail("the action server is not in the ROS graph".into());
        };
        let request = match goal_request(id, &self.frame_id, stamp(), x, y, yaw) {
            Ok(r) => r,
            Err(e) => return fail(e.to_string()),
        };
        let result_request = match cdr::encode_named("NavigateToPose_GetResult_Request", &GetResultRequest { goal_id: id }) {
            Ok(r) => r,
            Err(e) => return fail(e.to_string()),
        };
        *self.active.lock().unwrap_or_else(|p| p.into_inner()) = Some(id);
        let (a1, a2) = (self.attachment(), self.attachment());
        let session = self.session.clone();
        tokio::spawn(async move {
            let event = match call(&session, &send_key, request, a1, ANSWER_TIMEOUT).await {
                Ok(bytes) => match decode_accepted(&bytes) {
                    Ok(true) => GoalEvent::Accepted,
                    Ok(false) => GoalEvent::Rejected,
                    Err(e) => GoalEvent::Failed(e.to_string()),
                },
                Err(why) => GoalEvent::Failed(why),
            };
            let accepted = event == GoalEvent::Accepted;
            if tx.send(Input::Goal { id, event }).await.is_err() || !accepted {
                return;
            }
            let event = match call(&session, &result_key, result_request, a2, RESULT_TIMEOUT).await {
                Ok(bytes) => decode_status(&bytes).map_or_else(|e| GoalEvent::Failed(e.to_string()), GoalEvent::Finished),
                Err(why) => GoalEvent::Failed(why),
            };
            let _ = tx.send(Input::Goal { id, event }).await;
        });
    }

    /// Cancels goal `id` (its result then says cancelled; the answer to the cancel is logged).
    pub fn cancel_goal(&self, id: GoalId) {
        {
            let mut active = self.active.lock().unwrap_or_else(|p| p.into_inner());
            if *active == Some(id) {
                *active = None;
            }
        }
        let Some(fut) = self.cancel_call(id) else { return };
        tokio::spawn(fut);
    }

    fn cancel_call(&self, id: GoalId) -> Option<impl std::future::Future<Output = ()> + Send + 'static> {
        let (_, _, key) = self.keys()?;
        let request = cdr::encode_named("CancelGoal_Request", &CancelGoalRequest { goal_info: GoalInfo { goal_id: id, stamp: Time::default() } }).ok()?;
        let (session, a) = (self.session.clone(), self.attachment());
        Some(async move {
            match call(&session, &key, request, a, ANSWER_TIMEOUT).await.map(|b| decode_cancel(&b)) {
                Ok(Ok(0)) => tracing::info!("ROS 2 body: Nav2 goal cancelled"),
                Ok(Ok(code)) => tracing::info!(code, "ROS 2 body: Nav2 did not cancel the goal (already over or unknown)"),
                Ok(Err(e)) => tracing::warn!("ROS 2 body: Nav2 cancel answer: {e}"),
                Err(e) => tracing::warn!("ROS 2 body: Nav2 cancel: {e}"),
            }
        })
    }

    /// Cancels the goal still running, waiting for the answer (the link is closing).
    pub async fn cancel_active(&self) {
        let id = self.active.lock().unwrap_or_else(|p| p.into_inner()).take();
        if let Some(fut) = id.and_then(|id| self.cancel_call(id)) {
            fut.await;
        }
    }
}

/// One service call: the first reply's payload, or why there is none.
async fn call(session: &Session, key: &str, request: Vec<u8>, a: Attachment, timeout: Duration) -> Result<Vec<u8>, String> {
    let replies = session.get(key).payload(request).attachment(a.to_zbytes()).timeout(timeout).await.map_err(|e| Ros2Error::zenoh(e).to_string())?;
    match replies.recv_async().await {
        Ok(reply) => match reply.result() {
            Ok(sample) if sample.payload().len() > cdr::MAX_PAYLOAD => Err(format!("an answer of {} bytes", sample.payload().len())),
            Ok(sample) => Ok(sample.payload().to_bytes().into_owned()),
            Err(e) => {
                Err(format!("the server answered with an error: {}", String::from_utf8_lossy(&e.payload().to_bytes()).chars().take(120).collect::<String>()))
            }
        },
        Err(_) => Err(format!("no answer within {} s", timeout.as_secs())),
    }
}

fn stamp() -> Time {
    let ns = now_ns();
    Time { sec: i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX), nanosec: u32::try_from(ns % 1_000_000_000).unwrap_or(0) }
}
