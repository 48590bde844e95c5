//! `patrol-plan route` on the bundled data-center map and patrol route, run as a user runs it.

use serde_json::Value;
use std::path::PathBuf;

mod common;
use common::{patrol_plan, repo, scratch_dir};

/// `route` on the bundled files with extra arguments: the parsed JSON.
fn route(points: &str, extra: &[&str]) -> Value {
    let map = repo("config/maps/datacenter_100.yaml");
    let mut args = vec!["route", "--map", &map, "--points", points];
    args.extend_from_slice(extra);
    let (ok, stdout, stderr) = patrol_plan(&args);
    assert!(ok, "{stderr}");
    serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{e}: {stdout}"))
}

fn names(v: &Value) -> Vec<&str> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect()
}

fn temp(name: &str) -> PathBuf {
    scratch_dir("route").join(name)
}

/// The bundled route: every point reached, a better order than the file's, the documented fields,
/// legs that run from point to point and add up to the totals, and a picture.
#[test]
fn the_bundled_patrol_is_ordered_better_than_written() {
    let points = repo("config/routes/datacenter_patrol.yaml");
    let svg = temp("patrol.svg");
    let v = route(&points, &["--svg", svg.to_str().unwrap()]);
    for key in [
        "planner",
        "order",
        "legs",
        "total_length_m",
        "total_time_s",
        "given_order_length_m",
        "given_order_time_s",
        "skipped",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    assert_eq!(v["planner"], "any_angle");
    assert_eq!(v["method"], "held_karp");
    assert_eq!(v["skipped"], serde_json::json!([]));
    let order = names(&v["order"]);
    let mut sorted = order.clone();
    sorted.sort_unstable();
    let mut given = names(&v["given_order"]);
    given.sort_unstable();
    assert_eq!(order.len(), 10);
    assert_eq!(sorted, given, "the same points in another order");
    let total = v["total_time_s"].as_f64().unwrap();
    let given_total = v["given_order_time_s"].as_f64().unwrap();
    assert!(total < 0.8 * given_total, "{total} vs {given_total}");
    assert!(v["total_length_m"].as_f64().unwrap() < v["given_order_length_m"].as_f64().unwrap());
    // The legs: start -> the order, each from point to point, summing to the totals.
    let legs = v["legs"].as_array().unwrap();
    assert_eq!(legs.len(), 10);
    assert_eq!(legs[0]["from"], "start");
    let wp = legs[0]["waypoints"].as_array().unwrap();
    assert_eq!(wp[0], serde_json::json!([0.5, 0.5]));
    let (mut length, mut time) = (0.0, 0.0);
    for (leg, to) in legs.iter().zip(&order) {
        assert_eq!(leg["to"], *to);
        let speed_bound = leg["length_m"].as_f64().unwrap() / 0.6;
        assert!(leg["time_s"].as_f64().unwrap() >= speed_bound - 1e-9);
        length += leg["length_m"].as_f64().unwrap();
        time += leg["time_s"].as_f64().unwrap();
    }
    for pair in legs.windows(2) {
        assert_eq!(pair[0]["to"], pair[1]["from"]);
        let end = pair[0]["waypoints"].as_array().unwrap().last().unwrap();
        assert_eq!(end, &pair[1]["waypoints"][0]);
    }
    assert!((length - v["total_length_m"].as_f64().unwrap()).abs() < 1e-6);
    let dwell = v["dwell_s"].as_f64().unwrap();
    assert_eq!(dwell, 93.0, "the file's dwell times");
    assert!((time + dwell - total).abs() < 1e-6);
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(picture.matches("<polyline").count(), 10);
    assert!(picture.contains(">10</text>") && picture.contains(">S</text>"));
}

/// Closed loops return to the start; `--home` ends at the named point; A* legs are never shorter
/// than the any-angle ones.
#[test]
fn loop_home_and_planner() {
    let points = repo("config/routes/datacenter_patrol.yaml");
    let open = route(&points, &[]);
    let closed = route(&points, &["--loop"]);
    let legs = closed["legs"].as_array().unwrap();
    assert_eq!(legs.len(), 11);
    assert_eq!(legs[10]["to"], "start");
    assert_eq!(closed["closed"], true);
    assert!(closed["total_time_s"].as_f64().unwrap() > open["total_time_s"].as_f64().unwrap());
    let home = route(&points, &["--home", "row4_north"]);
    assert_eq!(*names(&home["order"]).last().unwrap(), "row4_north");
    assert_eq!(*names(&home["given_order"]).last().unwrap(), "row4_north");
    let astar = route(&points, &["--planner", "astar"]);
    assert_eq!(astar["planner"], "astar");
    assert!(
        astar["total_length_m"].as_f64().unwrap()
            >= open["total_length_m"].as_f64().unwrap() - 1e-6
    );
    let map = repo("config/maps/datacenter_100.yaml");
    let (ok, _, stderr) = patrol_plan(&[
        "route",
        "--map",
        &map,
        "--points",
        &points,
        "--loop",
        "--home",
        "row4_north",
    ]);
    assert!(!ok && stderr.contains("cannot be used with"), "{stderr}");
    let (ok, _, stderr) = patrol_plan(&[
        "route", "--map", &map, "--points", &points, "--home", "nowhere",
    ]);
    assert!(
        !ok && stderr.contains("home `nowhere` is not the name of a point"),
        "{stderr}"
    );
}

/// A point inside a cabinet and one off the map are skipped with their reasons, not dropped;
/// a bad file is an error naming the mistake and the file.
#[test]
fn unreachable_points_are_reported_and_bad_files_refused() {
    let file = temp("skips.yaml");
    std::fs::write(
        &file,
        "points:\n  - {name: row1_south, x: 3.1, y: 0.9, yaw: 1.5708, dwell: 5}\n  - {name: inside_row1, x: 3.1, y: 2.2, yaw: 0, dwell: 5}\n  - {name: off_map, x: 25.0, y: 5.0, yaw: 0, dwell: 5}\n  - {name: row2_south, x: 12.5, y: 0.9, yaw: 1.5708, dwell: 5}\n",
    )
    .unwrap();
    let v = route(file.to_str().unwrap(), &[]);
    assert_eq!(names(&v["order"]), ["row1_south", "row2_south"]);
    let skipped = v["skipped"].as_array().unwrap();
    assert_eq!(skipped.len(), 2);
    assert_eq!(skipped[0]["name"], "inside_row1");
    assert!(skipped[0]["reason"].as_str().unwrap().contains("obstacle"));
    assert_eq!(skipped[1]["name"], "off_map");
    assert!(skipped[1]["reason"]
        .as_str()
        .unwrap()
        .contains("outside the map"));
    let bad = temp("duplicate.yaml");
    std::fs::write(
        &bad,
        "points:\n  - {name: a, x: 3.1, y: 0.9, yaw: 0, dwell: 5}\n  - {name: a, x: 12.5, y: 0.9, yaw: 0, dwell: 5}\n",
    )
    .unwrap();
    let map = repo("config/maps/datacenter_100.yaml");
    let (ok, _, stderr) = patrol_plan(&["route", "--map", &map, "--points", bad.to_str().unwrap()]);
    assert!(!ok, "{stderr}");
    assert!(
        stderr.contains("duplicate.yaml") && stderr.contains("two points are named `a`"),
        "{stderr}"
    );
}
