//! rmw_zenoh's names: the key expression of a topic's data and the liveliness tokens that make a
//! node and its publishers and subscriptions appear in the ROS 2 graph (`ros2 node list`,
//! `ros2 topic info`). Built here and nowhere else.

use crate::error::Ros2Error;
use crate::msgs::{dds_type_name, RosMessage};

/// rmw_zenoh's liveliness admin space.
pub const ADMIN_SPACE: &str = "@ros2_lv";

/// What kind of graph entity a token announces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntityKind {
    Publisher,
    Subscription,
    ServiceServer,
    ServiceClient,
}

impl EntityKind {
    fn code(self) -> &'static str {
        match self {
            EntityKind::Publisher => "MP",
            EntityKind::Subscription => "MS",
            EntityKind::ServiceServer => "SS",
            EntityKind::ServiceClient => "SC",
        }
    }
}

/// A QoS profile as far as the graph tokens tell it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    pub reliable: bool,
    pub transient_local: bool,
    pub depth: u32,
}

impl Qos {
    /// ROS 2's default: reliable, volatile, keep last 10.
    pub const DEFAULT: Qos = Qos { reliable: true, transient_local: false, depth: 10 };
    /// Sensor data: best effort, keep last 5.
    pub const SENSOR: Qos = Qos { reliable: false, transient_local: false, depth: 5 };

    /// rmw_zenoh's compact form: `reliability:durability:kind,depth:deadline:lifespan:liveliness`,
    /// defaults left empty.
    pub fn encode(&self) -> String {
        let reliability = if self.reliable { "" } else { "2" };
        let durability = if self.transient_local { "1" } else { "" };
        format!("{reliability}:{durability}:,{}:,:,:,,", self.depth)
    }
}

/// `/`-separated ROS names become one key chunk: `/` → `%`, the root namespace is `%`.
pub fn mangle(name: &str) -> String {
    if name.is_empty() || name == "/" {
        "%".to_string()
    } else {
        name.replace('/', "%")
    }
}

/// Checks a ROS name (topic, namespace, node): `[A-Za-z0-9_/~]`, no empty segment, not too
/// long. `what` names the field in the error.
pub fn validate_name(what: &str, name: &str) -> Result<(), Ros2Error> {
    let bad = |why: &str| Err(Ros2Error::Config(format!("{what}: {name:?} {why}")));
    if name.is_empty() {
        return bad("is empty");
    }
    if name.len() > 200 {
        return bad("is longer than 200 characters");
    }
    if !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/') {
        return bad("may hold only A-Z a-z 0-9 _ and /");
    }
    if name != "/" && (name.ends_with('/') || name.contains("//")) {
        return bad("has an empty segment");
    }
    if name.split('/').any(|s| s.starts_with(|c: char| c.is_ascii_digit())) {
        return bad("has a segment starting with a digit");
    }
    Ok(())
}

/// A topic's fully qualified name in `namespace` (absolute names stay as they are).
pub fn qualify(namespace: &str, topic: &str) -> String {
    if topic.starts_with('/') {
        topic.to_string()
    } else if namespace == "/" || namespace.is_empty() {
        format!("/{topic}")
    } else {
        format!("{}/{topic}", namespace.trim_end_matches('/'))
    }
}

/// The node an mrmm robot is in the ROS 2 graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Node {
    pub domain_id: u32,
    /// The Zenoh session's id, as rmw_zenoh writes it.
    pub zid: String,
    pub id: u32,
    pub namespace: String,
    pub name: String,
}

impl Node {
    /// The key expression of `topic`'s data for messages of type `T`:
    /// `<domain>/<fully qualified topic without its leading />/<DDS type>/<type hash>`.
    pub fn topic_key<T: RosMessage>(&self, topic: &str) -> String {
        self.service_key(topic, &dds_type_name(T::TYPE), T::HASH)
    }

    /// The node's own liveliness token.
    pub fn token(&self) -> String {
        format!("{ADMIN_SPACE}/{}/{}/{}/{}/NN/%/{}/{}", self.domain_id, self.zid, self.id, self.id, mangle(&self.namespace), mangle(&self.name))
    }

    /// The liveliness token of one of the node's publishers or subscriptions.
    pub fn entity_token<T: RosMessage>(&self, entity_id: u32, kind: EntityKind, topic: &str, qos: Qos) -> String {
        self.token_for(entity_id, kind, topic, &dds_type_name(T::TYPE), T::HASH, qos)
    }

    /// The key expression of a topic or service (or an action's service) whose type and hash
    /// are known only at run time: `<domain>/<fully qualified name without its leading />/<DDS
    /// type>/<hash>`.
    pub fn service_key(&self, name: &str, dds_type: &str, hash: &str) -> String {
        let fq = qualify(&self.namespace, name);
        format!("{}/{}/{dds_type}/{hash}", self.domain_id, fq.trim_start_matches('/'))
    }

    /// The liveliness token of any entity of the node, its type given as a DDS type name.
    pub fn token_for(&self, entity_id: u32, kind: EntityKind, topic: &str, dds_type: &str, hash: &str, qos: Qos) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{}/{entity_id}/{}/%/{}/{}/{}/{}/{}/{}",
            self.domain_id,
            self.zid,
            self.id,
            kind.code(),
            mangle(&self.namespace),
            mangle(&self.name),
            mangle(&qualify(&self.namespace, topic)),
            dds_type,
            hash,
            qos.encode()
        )
    }
}

/// A publisher or subscription another node announces in the graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    pub node: String,
    pub kind: EntityKind,
    /// Fully qualified topic name.
    pub topic: String,
    /// DDS type name.
    pub dds_type: String,
    pub hash: String,
}

/// Reads a graph token's key expression; `None` for nodes, other domains and anything malformed.
pub fn parse_endpoint(domain_id: u32, key: &str) -> Option<Endpoint> {
    let parts: Vec<&str> = key.split('/').collect();
    if parts.len() < 12 || parts[0] != ADMIN_SPACE || parts[1].parse::<u32>().ok()? != domain_id {
        return None;
    }
    let kind = match parts[5] {
        "MP" => EntityKind::Publisher,
        "MS" => EntityKind::Subscription,
        "SS" => EntityKind::ServiceServer,
        "SC" => EntityKind::ServiceClient,
        _ => return None,
    };
    let demangle = |s: &str| if s == "%" { "/".to_string() } else { s.replace('%', "/") };
    Some(Endpoint {
        node: demangle(parts[8]).trim_start_matches('/').to_string(),
        kind,
        topic: demangle(parts[9]),
        dds_type: parts[10].to_string(),
        hash: parts[11].to_string(),
    })
}

/// What is wrong between a peer's endpoint and the type this node speaks on `topic` (fully
/// qualified), if anything: the same topic with another type or another hash carries nothing
/// between the two (rmw_zenoh's keys differ), so it deserves a clear warning.
pub fn mismatch<T: RosMessage>(topic: &str, e: &Endpoint) -> Option<String> {
    if e.topic != topic || !matches!(e.kind, EntityKind::Publisher | EntityKind::Subscription) {
        return None;
    }
    let ours = dds_type_name(T::TYPE);
    if e.dds_type != ours {
        Some(format!("node {} has {topic} as {}, mrmm speaks {} there: nothing flows between them", e.node, e.dds_type, T::TYPE))
    } else if e.hash != T::HASH {
        Some(format!(
            "node {} has {topic} with type hash {}, mrmm speaks {} ({}, ROS 2 Jazzy and later): another ROS 2 distribution or type definition, nothing flows between them",
            e.node,
            e.hash,
            T::HASH,
            T::TYPE
        ))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::Twist;

    fn node(ns: &str) -> Node {
        Node { domain_id: 0, zid: "a1b2".into(), id: 0, namespace: ns.into(), name: "mrmm_r1".into() }
    }

    #[test]
    fn keys_and_tokens_as_rmw_zenoh_writes_them() {
        let n = node("/");
        assert_eq!(n.topic_key::<Twist>("/cmd_vel"), format!("0/cmd_vel/geometry_msgs::msg::dds_::Twist_/{}", Twist::HASH));
        assert_eq!(n.token(), "@ros2_lv/0/a1b2/0/0/NN/%/%/mrmm_r1");
        assert_eq!(
            n.entity_token::<Twist>(3, EntityKind::Publisher, "/cmd_vel", Qos::DEFAULT),
            format!("@ros2_lv/0/a1b2/0/3/MP/%/%/mrmm_r1/%cmd_vel/geometry_msgs::msg::dds_::Twist_/{}/::,10:,:,:,,", Twist::HASH)
        );
        let r = node("/robot1");
        assert_eq!(r.topic_key::<Twist>("cmd_vel"), format!("0/robot1/cmd_vel/geometry_msgs::msg::dds_::Twist_/{}", Twist::HASH));
        assert!(r.token().ends_with("/NN/%/%robot1/mrmm_r1"));
        assert_eq!(Qos::SENSOR.encode(), "2::,5:,:,:,,");
    }

    #[test]
    fn peers_with_another_type_hash_are_named() {
        let n = node("/");
        let ours = n.entity_token::<Twist>(3, EntityKind::Publisher, "/cmd_vel", Qos::DEFAULT);
        let e = parse_endpoint(0, &ours).expect("parses");
        assert_eq!((e.node.as_str(), e.topic.as_str(), e.kind), ("mrmm_r1", "/cmd_vel", EntityKind::Publisher));
        assert_eq!(mismatch::<Twist>("/cmd_vel", &e), None);
        let other = ours.replace(Twist::HASH, "RIHS01_00");
        let why = mismatch::<Twist>("/cmd_vel", &parse_endpoint(0, &other).expect("parses")).expect("a mismatch");
        assert!(why.contains("RIHS01_00") && why.contains("mrmm_r1"), "{why}");
        assert_eq!(mismatch::<Twist>("/odom", &e), None, "another topic");
        assert_eq!(parse_endpoint(1, &ours), None, "another domain");
        assert_eq!(parse_endpoint(0, &n.token()), None, "a node");
        assert_eq!(parse_endpoint(0, "@ros2_lv/x/y"), None);
    }

    #[test]
    fn names_are_checked() {
        for good in ["/", "/odom", "cmd_vel", "/robot1/odom", "/a_b/c9"] {
            assert!(validate_name("t", good).is_ok(), "{good}");
        }
        for bad in ["", "/odom/", "a//b", "/1odom", "/odom*", "/a b", "@x"] {
            assert!(validate_name("t", bad).is_err(), "{bad}");
        }
    }
}
