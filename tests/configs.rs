//! The shipped example configs load and validate.

use mrmm_manager::central::CentralConfig;
use mrmm_manager::site_router::RouterConfig;
use mrmm_peer::config::RobotConfig;
use std::path::Path;

#[test]
fn shipped_configs_are_valid() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let r = RobotConfig::load(&root.join("config/robot.json5")).expect("robot.json5");
    assert_eq!(r.id, "r1");
    let ros = RobotConfig::load(&root.join("config/robot-ros2.json5")).expect("robot-ros2.json5");
    assert!(matches!(ros.body, mrmm_peer::config::BodySection::Ros2(_)));
    let c = CentralConfig::load(&root.join("config/central.json5")).expect("central.json5");
    assert_eq!(c.listen, ["tcp/127.0.0.1:7447"]);
    let gw = mrmm_node::vda5050::GatewayConfig::read(&root.join("config/vda5050.json5")).expect("vda5050.json5");
    gw.validate().expect("vda5050.json5 valid");
    let agv = RobotConfig::load(&gw.robot).expect("agv.json5, the gateway's robot");
    assert_eq!(agv.capabilities, ["tow"]);
    let s = RouterConfig::load(&root.join("config/router.json5")).expect("router.json5");
    assert_eq!(s.connect, ["tcp/127.0.0.1:7447"]);
}
