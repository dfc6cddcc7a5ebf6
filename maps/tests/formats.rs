//! Each format against real files written by its own tools, and against malformed ones: every
//! refusal names the file, the line or field, and the problem.

use std::path::PathBuf;

use mrmm_maps::{nav2, patrolling_sim, rmf, Bundle, Format, Map, MapError, Point};

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data").join(rel)
}

fn read(rel: &str) -> Vec<u8> {
    std::fs::read(data(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn bundle(rel: &str) -> Bundle {
    Bundle::collect(&data(rel).to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string())).expect("bundle")
}

/// nav2_map_server's own expected occupancy of its test map (`g_valid_image_content` in its
/// test_constants.cpp), in `OccupancyGrid.data` order.
const NAV2_TESTMAP: [i8; 100] = [
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 100, 100, 100, 100, 0, 0, 100, 100, 100, 0, 100, 100, 100, 100, 0, 0, 100, 100, 100, 0, 100, 0, 0, 0, 0, 0, 0, 0, 0, 0, 100,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 100, 0, 0, 0, 0, 0, 100, 100, 0, 0, 100, 0, 0, 0, 0, 0, 100, 100, 0, 0, 100, 0, 0, 0, 0, 0, 100, 100, 0, 0, 100, 0, 0, 0, 0, 0,
    100, 100, 0, 0, 100, 0, 0, 0, 0, 0, 0, 0, 0, 0,
];

#[test]
fn nav2_test_map_converts_as_map_server_does_from_pgm_and_png() {
    let meta = nav2::parse_yaml("testmap.yaml", std::str::from_utf8(&read("nav2/testmap.yaml")).unwrap()).expect("yaml");
    assert_eq!(meta.image, "testmap.png");
    assert_eq!(meta.origin, [2.0, 3.0, 1.0]);
    for image in ["nav2/testmap.pgm", "nav2/testmap.png"] {
        let g = nav2::grid(&meta, image, &read(image)).expect(image);
        assert_eq!((g.width, g.height, g.resolution), (10, 10, 0.1), "{image}");
        assert_eq!(g.data, NAV2_TESTMAP, "{image}: occupancy differs from nav2_map_server's expectation");
    }
    let (format, map) = bundle("nav2/testmap.yaml").load().expect("bundle loads");
    assert_eq!(format, Format::Nav2);
    assert_eq!(map.grid().expect("grid").data, NAV2_TESTMAP);
}

#[test]
fn a_map_written_by_map_saver_loads() {
    let b = bundle("nav2/tb3_sandbox.yaml");
    assert_eq!(b.files.len(), 2, "the YAML and its image");
    let (format, map) = b.load().expect("load");
    let s = map.summary(format);
    let g = s.grid.expect("grid");
    assert_eq!((g.width, g.height, g.resolution), (384, 384, 0.05));
    assert!(g.free_m2 > 15.0 && g.occupied_m2 > 1.0 && g.unknown_m2 > 300.0, "{g:?}");
    assert_eq!(s.min, Point::new(-10.0, -10.0));
    // The TurtleBot3 world's robot starts at (-2, -0.5): free; far outside the arena: unknown.
    let grid = map.grid().unwrap();
    assert!(grid.is_free(Point::new(-2.0, -0.5)));
    assert_eq!(grid.at(Point::new(-9.0, -9.0)), Some(-1));
    // The same bundle hashes the same, and survives the wire.
    let back = Bundle::decode("wire", &b.encode()).expect("decode");
    assert_eq!(back, b);
    assert_eq!(back.hash(), b.hash());
    assert_eq!(b.hash().len(), 64);
}

#[test]
fn every_patrolling_sim_graph_loads() {
    let expect = [
        ("1r5", 12),
        ("DIAG_floor1", 60),
        ("DIAG_labs", 27),
        ("broughton", 163),
        ("ctcv", 18),
        ("cumberland", 40),
        ("example", 29),
        ("grid", 25),
        ("move_base_arena", 14),
    ];
    for (name, n) in expect {
        let text = String::from_utf8(read(&format!("patrolling_sim/{name}.graph"))).unwrap();
        let g = patrolling_sim::parse(name, &text).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(g.vertices.len(), n, "{name}");
        // Undirected: every edge has its reverse.
        for e in &g.edges {
            assert!(g.edges.iter().any(|r| r.from == e.to && r.to == e.from), "{name}: {} → {} one way", e.from, e.to);
        }
        // Drawn on its floor plan, shipped beside it: every vertex stands in free space of it.
        let (format, plan) = bundle(&format!("patrolling_sim/{name}.yaml")).load().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(format, Format::Nav2, "{name}");
        let grid = plan.grid().expect("a grid");
        for v in &g.vertices {
            assert!(grid.is_free(v.at), "{name}: vertex {} at ({:.2}, {:.2}) is not in free space of its floor plan", v.name, v.at.x, v.at.y);
        }
    }
    // broughton: vertex 0 at (173, 289) px, 0.1 m/px, offset 0; its edge to 1 costs 159 px.
    let g = patrolling_sim::parse("broughton", &String::from_utf8(read("patrolling_sim/broughton.graph")).unwrap()).unwrap();
    assert!((g.vertices[0].at.x - 17.3).abs() < 1e-9 && (g.vertices[0].at.y - 28.9).abs() < 1e-9);
    let e = g.edges.iter().find(|e| e.from == 0 && e.to == 1).expect("0 → 1");
    assert!((e.length - 15.9).abs() < 1e-9);
    assert_eq!(bundle("patrolling_sim/broughton.graph").format().unwrap(), Format::PatrollingSim);
}

/// The bundle of `graph` on `plan`, loaded once as every node that holds it does.
fn on_plan(graph: &str, plan: &str) -> Result<Bundle, MapError> {
    let b = Bundle::collect_on_plan(&data(graph).to_string_lossy(), &data(plan).to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string()))?;
    b.load().map(|_| b)
}

#[test]
fn a_graph_travels_with_its_floor_plan_and_loads_with_lanes_passing_where_it_has_room() {
    let plain = bundle("patrolling_sim/ctcv.graph");
    let b = on_plan("patrolling_sim/ctcv.graph", "patrolling_sim/ctcv.yaml").expect("ctcv on its plan");
    assert_eq!(b.files.len(), 3, "the graph, the plan's YAML and its image: {:?}", b.files.keys().collect::<Vec<_>>());
    assert_ne!(b.hash(), plain.hash(), "the plan is part of what the map's hash names");
    let (format, map) = b.load().expect("load");
    assert_eq!(format, Format::PatrollingSim);
    let g = map.graph().expect("a graph");
    // Marked as the roadmap marks a hand-drawn graph on its plan, and nothing else changed.
    let Map::Graph(bare) = plain.load().expect("plain").1 else { panic!("a graph") };
    let (_, plan) = bundle("patrolling_sim/ctcv.yaml").load().expect("plan");
    let p = mrmm_maps::roadmap::Params::default();
    let expect = mrmm_maps::roadmap::mark_passing_on(plan.grid().expect("grid"), bare.clone(), p.radius, p.passing);
    assert_eq!(g, &expect);
    let s = map.summary(format).graph.expect("graph summary");
    assert!(s.passing > 0 && s.passing < g.lanes().len(), "{} of {} lanes passing", s.passing, g.lanes().len());
    assert_eq!(bare.summary().passing, 0, "a .graph marks none");
    // The same on whoever fetches it: the bundle survives the wire and loads the same.
    let back = Bundle::decode("wire", &b.encode()).expect("decode");
    assert_eq!((back.hash(), back.load().expect("load back").1), (b.hash(), map));
}

#[test]
fn a_floor_plan_that_is_not_the_graphs_is_refused_naming_what_is_wrong() {
    // Another map's plan: the graph's vertices are not in its free space.
    let e = err_text(on_plan("patrolling_sim/broughton.graph", "patrolling_sim/1r5.yaml").expect_err("1r5's plan under broughton"));
    assert!(e.contains("broughton.graph: vertex") && e.contains("is not in free space of its floor plan"), "{e}");
    // A graph as the plan, and a plan for a grid map.
    let e = err_text(on_plan("patrolling_sim/1r5.graph", "patrolling_sim/ctcv.graph").expect_err("a graph as plan"));
    assert!(e.contains("ctcv.graph: a floor plan is a Nav2 map's YAML"), "{e}");
    let e = err_text(on_plan("patrolling_sim/1r5.yaml", "patrolling_sim/1r5.yaml").expect_err("a grid map on a plan"));
    assert!(e.contains("1r5.yaml is a grid map"), "{e}");
    let e = err_text(on_plan("patrolling_sim/1r5.graph", "patrolling_sim/nowhere.yaml").expect_err("no plan"));
    assert!(e.contains("nowhere.yaml"), "{e}");
}

#[test]
fn open_rmf_office_graph_loads() {
    let text = String::from_utf8(read("open_rmf/office.nav_graph.yaml")).unwrap();
    let g = rmf::parse("office", &text).expect("office");
    assert!(g.vertices.len() > 20, "{}", g.vertices.len());
    let d2 = g.vertices.iter().find(|v| v.name == "patrol_D2").expect("patrol_D2");
    assert!((d2.at.x - 10.247854072726847).abs() < 1e-9 && (d2.at.y + 3.09205587858002).abs() < 1e-9);
    // Lanes are one way each; the generator writes both directions.
    assert!(g.edges.iter().any(|e| e.from == 0 && e.to == 1) && g.edges.iter().any(|e| e.from == 1 && e.to == 0));
    // Its two chargers (is_charger), as the Open-RMF demo building marks them; written back and
    // read again, they stay chargers.
    let chargers: Vec<&str> = g.chargers().map(|v| v.name.as_str()).collect();
    assert_eq!(chargers, ["tinyRobot1_charger", "tinyRobot2_charger"]);
    let again = rmf::parse("again", &rmf::write(&g, "office", "L1")).expect("written");
    assert_eq!(again.chargers().map(|v| v.name.as_str()).collect::<Vec<_>>(), chargers);
    // The office marks no lane passing.
    assert!(g.edges.iter().all(|e| !e.passing));
    let (format, map) = bundle("open_rmf/office.nav_graph.yaml").load().unwrap();
    assert_eq!(format, Format::OpenRmf);
    assert!(matches!(map, Map::Graph(_)));
}

#[test]
fn a_lane_marked_passing_is_read_among_open_rmf_properties_and_written_back() {
    // Lane properties as rmf_building_map_tools writes them, with mrmm's own beside them.
    let text = "levels:\n  L1:\n    vertices:\n    - [0, 0, {name: a}]\n    - [4, 0, {name: b}]\n    - [4, 3, {name: c}]\n    lanes:\n    \
                - [0, 1, {speed_limit: 0.0, orientation_constraint: forward, passing: true}]\n    \
                - [1, 0, {passing: true, mutex: corridor}]\n    - [1, 2, {speed_limit: 0.5}]\n    - [2, 1, {}]\n";
    let g = rmf::parse("nav.yaml", text).expect("graph");
    let passing: Vec<(u32, u32)> = g.edges.iter().filter(|e| e.passing).map(|e| (e.from, e.to)).collect();
    assert_eq!(passing, [(0, 1), (1, 0)]);
    assert_eq!(rmf::parse("again", &rmf::write(&g, "b", "L1")).expect("written"), g);
    // Anything but a boolean is an error that names the line.
    let e = err_text(rmf::parse("nav.yaml", &text.replace("passing: true, mutex", "passing: wide, mutex")).unwrap_err());
    assert!(e.starts_with("nav.yaml: line 9 column 24") && e.contains("boolean"), "{e}");
}

fn err_text(e: MapError) -> String {
    let s = e.to_string();
    assert!(!s.contains('\n'), "one line: {s}");
    s
}

#[test]
fn malformed_nav2_maps_name_the_file_the_field_and_the_problem() {
    let yaml = |t: &str| err_text(nav2::parse_yaml("m.yaml", t).unwrap_err());
    let e = yaml("image: a.pgm\nresolution: x\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n");
    assert!(e.starts_with("m.yaml: line 2 column") && e.contains("float"), "{e}");
    let e = yaml("image: a.pgm\nresolution: 0.05\norigin: [0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n");
    assert_eq!(e, "m.yaml: field origin: has 2 elements, not 3 (x, y, yaw)");
    let e = yaml("image: a.pgm\nresolution: -1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n");
    assert!(e.starts_with("m.yaml: field resolution: -1"), "{e}");
    let e = yaml("image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.2\nfree_thresh: 0.65\n");
    assert!(e.starts_with("m.yaml: field free_thresh"), "{e}");
    let e = yaml("image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.2\n");
    assert!(e.contains("occupied_thresh"), "{e}");
    let e = yaml("image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\nmode: fancy\n");
    assert!(e.starts_with("m.yaml: line 6"), "{e}");

    let meta = nav2::parse_yaml("m.yaml", "image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n").unwrap();
    // A truncated image.
    let e = err_text(nav2::grid(&meta, "a.pgm", b"P5\n10 10\n255\n\x00\x01").unwrap_err());
    assert!(e.starts_with("a.pgm: image data: "), "{e}");
    // A header claiming 30 000 × 30 000 pixels is refused before anything is allocated.
    let e = err_text(nav2::grid(&meta, "a.pgm", b"P5\n30000 30000\n255\n").unwrap_err());
    assert!(e.starts_with("a.pgm: 30000 × 30000 pixels"), "{e}");
    let e = err_text(nav2::grid(&meta, "a.pgm", b"hello, not an image").unwrap_err());
    assert!(e.starts_with("a.pgm: image: "), "{e}");
    // The image the YAML names is not there.
    let e = err_text(
        Bundle::collect("dir/m.yaml", |p| {
            if p == "dir/m.yaml" {
                Ok(b"image: gone.pgm\nresolution: 0.05\norigin: [0,0,0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n".to_vec())
            } else {
                Err("no such file".into())
            }
        })
        .unwrap_err(),
    );
    assert_eq!(e, "dir/gone.pgm: the image dir/m.yaml names: no such file");
}

#[test]
fn malformed_graphs_name_the_file_the_line_and_the_problem() {
    let g = |t: &str| err_text(patrolling_sim::parse("g.graph", t).unwrap_err());
    let head = "2\n100\n100\n0.1\n0\n0\n\n";
    assert_eq!(g(&format!("{head}0\n1\n1\n1\n1\nUP\n10\n")), "g.graph: line 13: vertex 0: direction \"UP\" is not one of N NE E SE S SW W NW");
    assert_eq!(g(&format!("{head}0\n1\n1\n1\n5\nN\n10\n")), "g.graph: line 12: vertex 0: neighbour 5 is not one of the 2 vertices");
    assert_eq!(g(&format!("{head}0\n1\n1\n0\n\n")), "g.graph: line 11: the file ends where a vertex id should be");
    assert_eq!(g(&format!("{head}0\n1\n1\n0\n\n1\n2\n2\n0\n\n7\n")), "g.graph: line 18: \"7\" after the last of the 2 vertices");
    assert!(g("99999999\n").contains("99999999 vertices: give 1 to 20000"));
    assert_eq!(g(&format!("{head}0\n1\nx\n")), "g.graph: line 10: y: \"x\" is not a number");

    let r = |t: &str| err_text(rmf::parse("nav.yaml", t).unwrap_err());
    assert_eq!(
        r("levels:\n  L1:\n    vertices:\n    - [0, 0, {name: a}]\n    lanes:\n    - [0, 3, {}]\n"),
        "nav.yaml: levels.L1.lanes[0]: joins 0 and 3, but the level has 1 vertices"
    );
    assert!(r("levels:\n  L1:\n    vertices: []\n  L2:\n    vertices: []\n").contains("more than one level"));
    assert!(r("levels:\n  L1:\n    vertices:\n    - [0, zero, {}]\n").starts_with("nav.yaml: line 4"));
    assert_eq!(
        r("levels:\n  L1:\n    vertices:\n    - [0, 0, {name: a}]\n    - [1, 0, {name: a}]\n"),
        "nav.yaml: levels.L1.vertices[1]: a second vertex named \"a\""
    );
    let e = err_text(Bundle::collect("x.yaml", |_| Ok(b"hello: 1\n".to_vec())).unwrap_err());
    assert!(e.starts_with("x.yaml: top level: neither a Nav2 map"), "{e}");
}

#[test]
fn the_demo_building_is_a_nav2_map_with_its_corridor_free() {
    let (format, map) = bundle("building/building.yaml").load().expect("building");
    assert_eq!(format, Format::Nav2);
    let g = map.grid().unwrap();
    assert_eq!((g.width, g.height, g.resolution), (420, 260, 0.1));
    assert!(g.is_free(Point::new(0.0, 0.0)), "the corridor");
    assert_eq!(g.at(Point::new(-4.0, 6.0)), Some(100), "an office wall");
    assert_eq!(g.at(Point::new(-20.8, 0.0)), Some(-1), "outside is unknown");
}
