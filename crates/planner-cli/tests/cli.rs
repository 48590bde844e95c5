//! The `patrol-plan` binary, run as a user runs it, on the shared maps.

mod common;
use common::{patrol_plan, scratch_dir, scratch_file, shared};

/// A* matches the published optimal length of every scenario of the small Moving AI maps.
#[test]
fn movingai_small_maps_all_pass() {
    for (map, scen, n) in [
        ("maze-32-32-2.map", "maze-32-32-2-random-1.scen", 333),
        ("room-32-32-4.map", "room-32-32-4-random-1.scen", 341),
        ("random-32-32-20.map", "random-32-32-20-random-1.scen", 409),
        ("arena.map", "arena.map.scen", 160),
    ] {
        let m = shared(&format!("movingai/{map}"));
        let s = shared(&format!("movingai/{scen}"));
        let (ok, stdout, stderr) = patrol_plan(&[
            "movingai",
            "--map",
            m.to_str().unwrap(),
            "--scen",
            s.to_str().unwrap(),
        ]);
        assert!(ok, "{map}: {stdout}{stderr}");
        assert_eq!(
            stdout.lines().last().unwrap(),
            format!("{n} passed, 0 failed"),
            "{map}"
        );
    }
}

/// A wrong optimum is reported as a failure with a non-zero exit: the check can fail.
#[test]
fn movingai_reports_a_wrong_optimum() {
    // The first arena row has optimum 1; claim 2.
    let scen = scratch_file(
        "test",
        "arena.map.scen",
        "version 1\n0\tmaps/dao/arena.map\t49\t49\t1\t11\t1\t12\t2\n",
    );
    let m = shared("movingai/arena.map");
    let (ok, stdout, _) = patrol_plan(&[
        "movingai",
        "--map",
        m.to_str().unwrap(),
        "--scen",
        scen.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(stdout.ends_with("0 passed, 1 failed\n"), "{stdout}");
}

/// `plan` prints one JSON object with the documented fields, on a map_server map.
#[test]
fn plan_prints_the_documented_json() {
    let map = shared("bench/datacenter_100.yaml");
    let svg = std::env::temp_dir().join(format!("patrol-plan-{}.svg", std::process::id()));
    let (ok, stdout, stderr) = patrol_plan(&[
        "plan",
        "--map",
        map.to_str().unwrap(),
        "--start",
        "0.1,0.1",
        "--goal",
        "19.9,19.9",
        "--planner",
        "astar",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    for key in [
        "planner",
        "seed",
        "length_m",
        "turning_rad",
        "turns",
        "min_clearance_m",
        "collision_free",
        "time_ms",
        "reference_length_m",
        "waypoints",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {stdout}");
    }
    assert_eq!(v["collision_free"], true);
    let len = v["length_m"].as_f64().unwrap();
    let reference = v["reference_length_m"].as_f64().unwrap();
    // The straight line is 28.14 m; cabinets force a detour; any-angle is never longer than A*.
    assert!(
        reference > 28.14 && reference <= len,
        "{reference} vs {len}"
    );
    let wp = v["waypoints"].as_array().unwrap();
    assert_eq!(wp[0], serde_json::json!([0.1, 0.1]));
    assert_eq!(wp[wp.len() - 1], serde_json::json!([19.9, 19.9]));
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(picture.starts_with("<svg") && picture.contains("<polyline"));
}

/// `plan --via`: one path through the via points in order, measured whole, with the any-angle
/// reference through the same points; a via point in a cabinet is refused with its code.
#[test]
fn plan_goes_through_via_points_in_order() {
    let map = shared("bench/datacenter_100.yaml");
    let m = map.to_str().unwrap();
    let plan = |planner: &str, via: &[&str]| {
        let mut args = vec!["plan", "--map", m, "--start", "0.5,0.5", "--goal", "1,0.6"];
        for v in via {
            args.extend(["--via", v]);
        }
        args.extend(["--planner", planner]);
        let (ok, stdout, stderr) = patrol_plan(&args);
        (
            ok,
            serde_json::from_str::<serde_json::Value>(&stdout).unwrap(),
            stderr,
        )
    };
    let (ok, v, stderr) = plan("mocmcso", &["9,9", "0.5,9"]);
    assert!(ok, "{stderr}");
    assert_eq!(v["via"], serde_json::json!([[9.0, 9.0], [0.5, 9.0]]));
    assert_eq!(v["collision_free"], true);
    // Out to (9, 9), across to (0.5, 9) and back: at least the three straight legs.
    let legs = 12.02 + 8.5 + 8.41;
    let (len, reference) = (
        v["length_m"].as_f64().unwrap(),
        v["reference_length_m"].as_f64().unwrap(),
    );
    assert!(
        reference >= legs && reference <= len,
        "{reference} vs {len}"
    );
    let wp: Vec<[f64; 2]> = serde_json::from_value(v["waypoints"].clone()).unwrap();
    let at = |p: [f64; 2]| {
        wp.iter()
            .position(|w| (w[0] - p[0]).hypot(w[1] - p[1]) < 1e-9)
    };
    let (first, second) = (at([9.0, 9.0]).unwrap(), at([0.5, 9.0]).unwrap());
    assert!(first < second, "passed in order");
    // Without via points there is none in the output.
    let (ok, v, _) = plan("astar", &[]);
    assert!(ok && v.get("via").is_none());
    let (ok, v, stderr) = plan("astar", &["5.5,5.5"]);
    assert!(!ok && v["error_code"] == 206, "{v}");
    assert!(stderr.contains("through 1 via point"), "{stderr}");
}

/// A plan that cannot be made says why as Nav2 would: the code, its number and the reason, as
/// JSON on stdout and in the error line, with a failing exit.
#[test]
fn plan_failure_carries_the_nav2_code() {
    let map = shared("bench/datacenter_100.yaml");
    let m = map.to_str().unwrap();
    for (goal, code, name) in [
        ("5.5,5.5", 206, "GOAL_OCCUPIED"),
        ("500,5", 204, "GOAL_OUTSIDE_MAP"),
    ] {
        let (ok, stdout, stderr) =
            patrol_plan(&["plan", "--map", m, "--start", "0.1,0.1", "--goal", goal]);
        assert!(!ok, "{goal}: {stdout}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert_eq!(v["error_code"], code, "{goal}: {stdout}");
        assert_eq!(v["error_name"], name, "{goal}: {stdout}");
        assert_eq!(v["planner"], "mocmcso");
        assert!(
            v["error_msg"].as_str().unwrap().contains("goal"),
            "{stdout}"
        );
        assert!(stderr.contains(&format!("{name} ({code})")), "{stderr}");
    }
}

/// A multi-objective planner's picture carries its Pareto front beside the map.
#[test]
fn plan_svg_draws_the_pareto_front_of_mocmcso() {
    let map = shared("bench/substation_20_complex.yaml");
    let svg = std::env::temp_dir().join(format!("patrol-plan-mo-{}.svg", std::process::id()));
    let (ok, stdout, stderr) = patrol_plan(&[
        "plan",
        "--map",
        map.to_str().unwrap(),
        "--start",
        "19.5,0.5",
        "--goal",
        "0.5,19.5",
        "--planner",
        "mocmcso",
        "--seed",
        "3",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["planner"], "mocmcso");
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(
        picture.contains("Pareto front:") && picture.contains("chosen (eq. 19-21)"),
        "no Pareto panel"
    );
}

/// Bad requests fail with a reason, not a panic.
#[test]
fn plan_rejects_bad_requests_with_a_reason() {
    let map = shared("bench/datacenter_100.yaml");
    let m = map.to_str().unwrap();
    let (ok, _, stderr) =
        patrol_plan(&["plan", "--map", m, "--start", "0.1,0.1", "--goal", "25,5"]);
    assert!(!ok && stderr.contains("outside the map"), "{stderr}");
    let (ok, _, stderr) = patrol_plan(&[
        "plan",
        "--map",
        m,
        "--start",
        "0.1,0.1",
        "--goal",
        "5,5",
        "--planner",
        "nope",
    ]);
    assert!(!ok && stderr.contains("unknown planner"), "{stderr}");
    let (ok, _, stderr) = patrol_plan(&["plan", "--map", m, "--start", "nan,0", "--goal", "5,5"]);
    assert!(!ok && stderr.contains("finite"), "{stderr}");
}

/// `bench --planners astar,any_angle --runs 2` on a scenario file, its JSON and Markdown written
/// beside `out` (`out.json`, `out.md`): the rows and the table.
fn bench_astar_and_any_angle(
    scen: &std::path::Path,
    out: &std::path::Path,
) -> (Vec<serde_json::Value>, String) {
    let (json, md) = (out.with_extension("json"), out.with_extension("md"));
    let (ok, _, stderr) = patrol_plan(&[
        "bench",
        "--scenarios",
        scen.to_str().unwrap(),
        "--planners",
        "astar,any_angle",
        "--runs",
        "2",
        "--json",
        json.to_str().unwrap(),
        "--markdown",
        md.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    let rows = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (rows, std::fs::read_to_string(&md).unwrap())
}

/// `bench` writes one row per scenario x planner with the documented fields, and a Markdown table.
#[test]
fn bench_writes_rows_and_markdown() {
    let scen = shared("bench/substation_20_complex.scen.yaml");
    let dir = scratch_dir("bench");
    let (rows, table) = bench_astar_and_any_angle(&scen, &dir.join("b"));
    assert_eq!(rows.len(), 2 * 2);
    for r in &rows {
        for key in [
            "map",
            "scenario",
            "planner",
            "runs",
            "successes",
            "collision_free",
            "length_m_best",
            "length_m_mean",
            "turning_rad_best",
            "turning_rad_mean",
            "min_clearance_m_mean",
            "time_ms_median",
            "reference_length_m",
        ] {
            assert!(r.get(key).is_some(), "missing {key}");
        }
        assert_eq!(r["successes"], 2);
        assert_eq!(r["collision_free"], 2);
        assert!(
            r["length_m_mean"].as_f64().unwrap()
                >= r["reference_length_m"].as_f64().unwrap() - 1e-6
        );
    }
    // Each row names its query: `plan` with that start and goal replays it.
    let row = rows
        .iter()
        .find(|r| r["scenario"] == "lower_right_to_upper_left" && r["planner"] == "astar")
        .unwrap();
    assert_eq!(row["start"], serde_json::json!([19.5, 0.5]));
    assert_eq!(row["goal"], serde_json::json!([0.5, 19.5]));
    let xy = |v: &serde_json::Value| format!("{},{}", v[0], v[1]);
    let map = shared("bench/substation_20_complex.yaml");
    let (ok, stdout, stderr) = patrol_plan(&[
        "plan",
        "--map",
        map.to_str().unwrap(),
        "--start",
        &xy(&row["start"]),
        "--goal",
        &xy(&row["goal"]),
        "--planner",
        "astar",
    ]);
    assert!(ok, "{stderr}");
    let replay: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(replay["length_m"], row["length_m_best"]);
    assert!(
        table.contains("| substation_20_complex | lower_right_to_upper_left | any_angle |"),
        "{table}"
    );
}

/// A misspelt top-level key in the parameter file is an error naming the key and the file (the
/// node refuses the same file with the same message), not a silent run of the defaults.
#[test]
fn a_top_level_typo_in_the_config_is_an_error() {
    let file = scratch_file(
        "typo",
        "typo.yaml",
        "patrol_planner:\n  ros__parameters:\n    max_planing_time: 1.0\n",
    );
    let expected = planner_io::parameters::load_parameter_file(&file)
        .unwrap_err()
        .to_string();
    let map = shared("bench/datacenter_100.yaml");
    let (ok, _, stderr) = patrol_plan(&[
        "plan",
        "--map",
        map.to_str().unwrap(),
        "--start",
        "0.1,0.1",
        "--goal",
        "5.1,5.1",
        "--config",
        file.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(expected.contains("`max_planing_time`"), "{expected}");
    assert!(stderr.contains(&expected), "{stderr}");
}

/// `plan` says why the run stopped (the swarm's default patience ends it before its iterations).
#[test]
fn plan_prints_the_termination() {
    let map = shared("bench/datacenter_100.yaml");
    for (planner, termination) in [("astar", "completed"), ("mocmcso", "converged")] {
        let (ok, stdout, stderr) = patrol_plan(&[
            "plan",
            "--map",
            map.to_str().unwrap(),
            "--start",
            "0.1,0.1",
            "--goal",
            "5.1,5.1",
            "--planner",
            planner,
        ]);
        assert!(ok, "{stderr}");
        assert!(
            stdout.contains(&format!("\"termination\":\"{termination}\"")),
            "{planner}: {stdout}"
        );
    }
}

/// Queries A* answers itself (no path across a wall; a goal off the map) are the bench's
/// unsolvable ones, and its summary counts a planner's runs that answer them as A* does; a NaN
/// in the scenario file, `--only` naming no scenario and `--runs 0` are refused.
#[test]
fn bench_counts_the_answers_to_unsolvable_queries() {
    let dir = scratch_dir("split");
    // 50 x 50 cells of 0.2 m, free but for a wall across the middle (columns 24 and 25).
    let mut pgm = b"P5\n50 50\n255\n".to_vec();
    for _ in 0..50 {
        pgm.extend((0..50).map(|x| if x == 24 || x == 25 { 0u8 } else { 254 }));
    }
    std::fs::write(dir.join("split.pgm"), pgm).unwrap();
    std::fs::write(
        dir.join("split.yaml"),
        "image: split.pgm\nresolution: 0.2\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n\
         occupied_thresh: 0.65\nfree_thresh: 0.196\n",
    )
    .unwrap();
    let scen = dir.join("split.scen.yaml");
    std::fs::write(
        &scen,
        "map: split.yaml\nscenarios:\n  - {name: cut, start: [1.5, 5.0], goal: [8.5, 5.0]}\n  \
         - {name: ok, start: [1.5, 5.0], goal: [1.5, 8.0]}\n  \
         - {name: off, start: [1.5, 5.0], goal: [80.0, 5.0]}\n",
    )
    .unwrap();
    let (rows, table) = bench_astar_and_any_angle(&scen, &dir.join("s"));
    for r in &rows {
        let unsolvable = r["scenario"] != "ok";
        assert_eq!(r["astar_found_path"], !unsolvable, "{r}");
        assert_eq!(r["astar_failure"].is_string(), unsolvable, "{r}");
    }
    for planner in ["astar", "any_angle"] {
        let line = format!("| split | {planner} | 2/2 | 2 | 4/4 |");
        assert!(table.contains(&line), "{line} not in\n{table}");
    }
    // Refused up front: a coordinate that is no number, a typo in --only, no runs.
    let nan = dir.join("nan.scen.yaml");
    std::fs::write(
        &nan,
        "map: split.yaml\nscenarios:\n  - {name: a, start: [.nan, 5.0], goal: [8.5, 5.0]}\n",
    )
    .unwrap();
    let (ok, _, stderr) = patrol_plan(&["bench", "--scenarios", nan.to_str().unwrap()]);
    assert!(!ok && stderr.contains("not a finite number"), "{stderr}");
    let s = scen.to_str().unwrap();
    let (ok, _, stderr) = patrol_plan(&["bench", "--scenarios", s, "--only", "nosuch"]);
    assert!(!ok && stderr.contains("`nosuch`"), "{stderr}");
    let (ok, _, stderr) = patrol_plan(&["bench", "--scenarios", s, "--runs", "0"]);
    assert!(!ok && stderr.contains("--runs"), "{stderr}");
}

/// What the command prints goes to standard output; a write that fails (a full disk) is an
/// error that says so and a failed exit, not a panic with a backtrace.
#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_on_standard_output_is_an_error_not_a_panic() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_patrol-plan"))
        .arg("planners")
        .stdout(std::fs::File::create("/dev/full").unwrap())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("writing standard output") && !stderr.contains("panicked"),
        "{stderr}"
    );
}

/// `costmap.downsampling_factor`: the plan is made on the coarser grid, which is made from the
/// inflated full-resolution grid, so on the map as it is the path keeps the whole inflated
/// radius from every obstacle: nothing is given up for the speed.
#[test]
fn a_downsampled_map_gives_paths_clear_on_the_full_map() {
    use planner_core::geometry::Point2;
    use planner_core::grid::inflation::{InflationConfig, PlanningGrid};
    let map_path = shared("ros/nav2_warehouse/warehouse.yaml");
    let config = scratch_file(
        "ds",
        "ds.yaml",
        "patrol_planner:\n  ros__parameters:\n    costmap:\n      downsampling_factor: 2\n",
    );
    let fine_map = planner_io::load_map(&map_path).unwrap();
    let fine = PlanningGrid::new(&fine_map, &InflationConfig::default()).unwrap();
    for planner in ["astar", "mocmcso"] {
        let (ok, stdout, stderr) = patrol_plan(&[
            "plan",
            "--map",
            map_path.to_str().unwrap(),
            "--start=-10.585,-14.965",
            "--goal=9.035,15.185",
            "--planner",
            planner,
            "--config",
            config.to_str().unwrap(),
        ]);
        assert!(ok, "{planner}: {stderr}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let wp: Vec<[f64; 2]> = serde_json::from_value(v["waypoints"].clone()).unwrap();
        let on_fine: Vec<Point2> = wp
            .iter()
            .map(|&[x, y]| fine_map.info().world_to_grid(Point2::new(x, y)))
            .collect();
        assert!(
            planner_core::grid::raycast::path_is_free(&fine, &on_fine),
            "{planner}: the path crosses the full map's inflated band"
        );
        let length = v["length_m"].as_f64().unwrap();
        assert!(length > 30.0, "{planner}: {length}");
    }
    // Planned on a quarter of the cells: A* expands well under half as many.
    let expanded = |config: Option<&str>| {
        let mut args = vec![
            "plan",
            "--map",
            map_path.to_str().unwrap(),
            "--start=-10.585,-14.965",
            "--goal=9.035,15.185",
            "--planner",
            "astar",
        ];
        args.extend(config.map(|c| ["--config", c]).into_iter().flatten());
        let (ok, stdout, stderr) = patrol_plan(&args);
        assert!(ok, "{stderr}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        v["iterations"].as_u64().unwrap()
    };
    let (coarse, full) = (expanded(config.to_str()), expanded(None));
    assert!(coarse * 10 < full * 4, "{coarse} against {full}");
}

/// `plan --keepout`: a keepout mask of its own resolution and origin keeps the path out of its
/// black zone (the path goes round, longer); a mask that cannot be read is an error naming it.
#[test]
fn plan_keeps_out_of_a_keepout_masks_zone() {
    let pgm = |w: usize, h: usize, black: &dyn Fn(usize, usize) -> bool| {
        let mut bytes = format!("P5\n{w} {h}\n255\n").into_bytes();
        for row in 0..h {
            for col in 0..w {
                bytes.push(if black(col, row) { 0 } else { 254 });
            }
        }
        bytes
    };
    let yaml = |image: &str, res: f64, x: f64| {
        format!("image: {image}\nresolution: {res}\norigin: [{x}, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    };
    // A 10 m x 6 m open room at 0.1 m; the zone x 4..6 m, y 0..4.6 m on a 0.2 m mask from (3, 0)
    // (image rows top-down: the zone is the bottom 23 of 30 rows, columns 5..15). Round its top
    // the path is about 10 m against 8 m straight.
    scratch_file("keepout", "room.pgm", pgm(100, 60, &|_, _| false));
    let room = scratch_file("keepout", "room.yaml", yaml("room.pgm", 0.1, 0.0));
    scratch_file(
        "keepout",
        "mask.pgm",
        pgm(25, 30, &|c, r| (5..15).contains(&c) && r >= 7),
    );
    let mask = scratch_file("keepout", "mask.yaml", yaml("mask.pgm", 0.2, 3.0));
    let plan = |extra: &[&str]| {
        let mut args = vec![
            "plan",
            "--map",
            room.to_str().unwrap(),
            "--start",
            "1,2",
            "--goal",
            "9,2",
            "--planner",
            "astar",
        ];
        args.extend_from_slice(extra);
        patrol_plan(&args)
    };
    let through_zone = |v: &serde_json::Value| {
        v["waypoints"].as_array().unwrap().windows(2).any(|w| {
            let (a, b) = (&w[0], &w[1]);
            let (ax, ay, bx, by) = (
                a[0].as_f64().unwrap(),
                a[1].as_f64().unwrap(),
                b[0].as_f64().unwrap(),
                b[1].as_f64().unwrap(),
            );
            // Sampled along each segment: any point inside the zone.
            (0..=20).any(|k| {
                let t = k as f64 / 20.0;
                let (x, y) = (ax + t * (bx - ax), ay + t * (by - ay));
                (4.0..=6.0).contains(&x) && y <= 4.6
            })
        })
    };
    let (ok, open, err) = plan(&[]);
    assert!(ok, "{err}");
    let open: serde_json::Value = serde_json::from_str(&open).unwrap();
    assert!(
        through_zone(&open),
        "on the open room the path runs straight: {open}"
    );
    let (ok, kept, err) = plan(&["--keepout", mask.to_str().unwrap()]);
    assert!(ok, "{err}");
    let kept: serde_json::Value = serde_json::from_str(&kept).unwrap();
    assert!(!through_zone(&kept), "through the keepout zone: {kept}");
    assert!(kept["length_m"].as_f64().unwrap() > open["length_m"].as_f64().unwrap() + 1.5);
    let (ok, _, err) = plan(&["--keepout", "/nonexistent/mask.yaml"]);
    assert!(!ok && err.contains("/nonexistent/mask.yaml"), "{err}");

    // The README's example: the bundled mask closes datacenter_100's west aisle at y 6-9 m,
    // which A*'s path takes without it.
    let bundled = |extra: &[&str]| {
        let map = common::repo("config/maps/datacenter_100.yaml");
        let mut args = vec![
            "plan",
            "--map",
            &map,
            "--start",
            "0.5,0.5",
            "--goal",
            "19.5,19.5",
            "--planner",
            "astar",
        ];
        args.extend_from_slice(extra);
        let (ok, out, err) = patrol_plan(&args);
        assert!(ok, "{err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        v["waypoints"].as_array().unwrap().windows(2).any(|w| {
            let p = |i: usize, k: usize| w[i][k].as_f64().unwrap();
            (0..=20).any(|k| {
                let t = k as f64 / 20.0;
                let (x, y) = (
                    p(0, 0) + t * (p(1, 0) - p(0, 0)),
                    p(0, 1) + t * (p(1, 1) - p(0, 1)),
                );
                x < 2.0 && (6.0..9.0).contains(&y)
            })
        })
    };
    assert!(bundled(&[]), "the open map's path takes the west aisle");
    let mask = common::repo("config/maps/datacenter_100_keepout.yaml");
    assert!(!bundled(&["--keepout", &mask]), "through the closed aisle");
}
