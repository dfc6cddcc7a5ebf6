//! Plain-text tables for the terminal.

use mrmm_proto::{MapInfo, RobotView};

/// Renders rows under a header, columns padded to their widest cell.
pub fn render(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut widths: Vec<usize> = header.iter().map(|h| h.chars().count()).collect();
    for row in rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |cells: &mut dyn Iterator<Item = &str>| {
        let s: Vec<String> = cells.zip(&widths).map(|(c, w)| format!("{c:<w$}")).collect();
        s.join("  ").trim_end().to_string()
    };
    let mut out = line(&mut header.iter().copied());
    out.push('\n');
    for row in rows {
        out.push_str(&line(&mut row.iter().map(String::as_str)));
        out.push('\n');
    }
    out
}

/// The fleet table; with a VEHICLE column where a robot is a VDA 5050 vehicle.
pub fn robots(views: &[RobotView]) -> String {
    let vehicles = views.iter().any(|v| v.vehicle.is_some());
    let rows: Vec<Vec<String>> = views
        .iter()
        .map(|v| {
            let pose = v.pose.map(|p| format!("({:7.2}, {:7.2}) {:5.0}°", p.x, p.y, p.theta.to_degrees())).unwrap_or_else(|| "-".into());
            let mut row = vec![
                v.id.to_string(),
                v.robot_type.clone(),
                v.status.as_str().to_string(),
                battery(v.battery.as_ref()),
                v.mission.as_ref().map(|x| x.as_str()).unwrap_or("-").to_string(),
                v.behaviour.clone().unwrap_or_else(|| "-".into()),
                pose,
                v.capabilities.join(","),
            ];
            if vehicles {
                row.push(vehicle(v.vehicle.as_ref()));
            }
            row
        })
        .collect();
    let mut header = vec!["ID", "TYPE", "STATUS", "BATTERY", "MISSION", "BEHAVIOUR", "POSE (x, y) heading", "CAPABILITIES"];
    if vehicles {
        header.push("VEHICLE");
    }
    render(&header, &rows)
}

/// A VDA 5050 vehicle's cell: `@pantry driving`, `@v12 paused FATAL orderError (+1)`, `-` for
/// another robot.
fn vehicle(v: Option<&mrmm_proto::VehicleState>) -> String {
    let Some(v) = v else { return "-".into() };
    let mut cell = if v.last_node.is_empty() { "@-".to_string() } else { format!("@{}", v.last_node) };
    if v.paused {
        cell.push_str(" paused");
    } else if v.driving {
        cell.push_str(" driving");
    }
    if let Some(e) = v.errors.first() {
        cell.push_str(&format!(" {} {}", e.level, e.kind));
        if v.errors.len() > 1 {
            cell.push_str(&format!(" (+{})", v.errors.len() - 1));
        }
    }
    cell
}

/// A battery's cell: `73% 410 m`, `40% charging`, `-` without one.
fn battery(b: Option<&mrmm_proto::BatteryState>) -> String {
    let Some(b) = b else { return "-".into() };
    let charge = format!("{:.0}%", b.charge * 100.0);
    match (b.charging, b.reach_m) {
        (true, _) => format!("{charge} charging"),
        (false, Some(r)) => format!("{charge} {r:.0} m"),
        (false, None) => charge,
    }
}

/// The maps table: the hash abbreviated to 12 digits (`--json` shows it whole).
pub fn maps(maps: &[MapInfo]) -> String {
    if maps.is_empty() {
        return "no maps (give central --map NAME=FILE, or maps in its config)\n".into();
    }
    let rows: Vec<Vec<String>> = maps
        .iter()
        .map(|m| {
            vec![
                if m.superseded { format!("{} (superseded)", m.name) } else { m.name.clone() },
                m.format.clone(),
                m.size.clone(),
                format!("{} KiB", m.bytes.div_ceil(1024)),
                format!("({:.1}, {:.1}) – ({:.1}, {:.1})", m.min.x, m.min.y, m.max.x, m.max.y),
                m.chargers.len().to_string(),
                m.hash.chars().take(12).collect(),
            ]
        })
        .collect();
    render(&["NAME", "FORMAT", "SIZE", "BYTES", "EXTENT (m)", "CHARGERS", "HASH"], &rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pads_columns() {
        let t = render(&["A", "BB"], &[vec!["xxx".into(), "y".into()]]);
        assert_eq!(t, "A    BB\nxxx  y\n");
    }

    #[test]
    fn the_fleet_table_shows_batteries() {
        use mrmm_proto::{BatteryState, RobotStatus};
        let view = |id: &str, battery| RobotView {
            id: id.into(),
            robot_type: "ground".into(),
            capabilities: vec![],
            status: RobotStatus::Idle,
            mission: None,
            pose: None,
            behaviour: None,
            goal: None,
            last_mission: None,
            stuck: None,
            battery,
            vehicle: None,
        };
        let t = robots(&[
            view("r1", Some(BatteryState { charge: 0.734, charging: false, reach_m: Some(410.4) })),
            view("r2", Some(BatteryState { charge: 0.4, charging: true, reach_m: Some(1.0) })),
            view("r3", Some(BatteryState { charge: 0.05, charging: false, reach_m: None })),
            view("r4", None),
        ]);
        let lines: Vec<&str> = t.lines().collect();
        assert!(lines[0].contains("STATUS  BATTERY"), "{t}");
        assert!(lines[1].contains("idle    73% 410 m"), "{t}");
        assert!(lines[2].contains("40% charging"), "{t}");
        assert!(lines[3].contains(" 5% "), "{t}");
        assert!(lines[4].contains("idle    -"), "{t}");
        assert!(!lines[0].contains("VEHICLE"), "no vehicle, no column: {t}");
    }

    #[test]
    fn the_fleet_table_shows_what_a_vehicle_says_of_itself() {
        use mrmm_proto::{RobotStatus, VehicleError, VehicleState};
        let mut agv = RobotView {
            id: "agv1".into(),
            robot_type: "ground".into(),
            capabilities: vec![],
            status: RobotStatus::Busy,
            mission: None,
            pose: None,
            behaviour: None,
            goal: None,
            last_mission: None,
            stuck: None,
            battery: None,
            vehicle: Some(VehicleState { last_node: "pantry".into(), driving: true, ..VehicleState::default() }),
        };
        let robot = RobotView { id: "r1".into(), vehicle: None, ..agv.clone() };
        let t = robots(&[agv.clone(), robot.clone()]);
        assert!(t.lines().next().is_some_and(|h| h.ends_with("VEHICLE")) && t.contains("@pantry driving"), "{t}");
        let error = |level: &str, kind: &str| VehicleError { kind: kind.into(), level: level.into(), description: None };
        agv.vehicle = Some(VehicleState {
            last_node: "v12".into(),
            paused: true,
            errors: vec![error("FATAL", "orderError"), error("WARNING", "x")],
            ..VehicleState::default()
        });
        assert!(robots(&[agv, robot]).contains("@v12 paused FATAL orderError (+1)"));
    }
}
