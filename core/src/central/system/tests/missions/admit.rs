//! A command to a member that was lost on the way (an admission naming its mission's new head,
//! say) is followed by a fresh admission, at most once per retry period.

use super::*;
use crate::at;
use mrmm_proto::Time;

#[test]
fn a_member_whose_command_was_lost_is_admitted_again() {
    let mut sm = with_host(&["r1", "r2", "r3"]);
    assert!(create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1", "r2"], {WAYPOINTS}}}"#)).replies[0].1.is_ok());
    let lost = |sm: &mut SystemManager, now: Time, robot: &str| {
        sm.drive(now, Event::RobotCommandDone { req: None, robot: robot.into(), result: Err("no answer".into()) })
    };
    let admits = |cmds: &[Command]| -> Vec<String> {
        cmds.iter()
            .filter_map(|c| match c {
                Command::SendToRobot { robot, cmd: RobotCommand::Admit { mission, managers, members }, .. } => {
                    Some(format!("{robot} {mission} {} {}", managers.join(","), members.join(",")))
                }
                _ => None,
            })
            .collect()
    };
    assert_eq!(admits(&lost(&mut sm, at(10.0), "r1")), ["r1 p central r1,r2"]);
    assert!(admits(&lost(&mut sm, at(11.0), "r1")).is_empty(), "not again within the retry period");
    assert_eq!(admits(&lost(&mut sm, at(12.5), "r1")).len(), 1);
    // A robot in no mission, or lost, is not admitted anywhere.
    assert!(lost(&mut sm, at(13.0), "r3").is_empty());
    sm.drive(at(13.0), Event::RobotGone { id: "r2".into() });
    assert!(admits(&lost(&mut sm, at(14.0), "r2")).is_empty());
}
