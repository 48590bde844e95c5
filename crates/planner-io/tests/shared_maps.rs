//! Every map and scenario file under `../shared/maps/` must load (the foundation issue's
//! requirement), and the loaded maps must look like what their sources say.

use planner_io::*;
use std::path::PathBuf;

fn shared() -> PathBuf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps");
    assert!(
        p.is_dir(),
        "{} is missing: the tests need ../shared beside the repository",
        p.display()
    );
    p
}

fn files(dir: &str, suffix: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = walk(&shared().join(dir))
        .into_iter()
        .filter(|p| p.to_string_lossy().ends_with(suffix))
        .collect();
    v.sort();
    v
}

fn walk(dir: &PathBuf) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn every_map_server_map_loads() {
    let mut yamls: Vec<PathBuf> = files("ros", ".yaml");
    yamls.extend(
        files("bench", ".yaml")
            .into_iter()
            .filter(|p| !p.to_string_lossy().ends_with(".scen.yaml")),
    );
    assert!(
        yamls.len() >= 11,
        "expected the 6 ROS and 5 bench maps, found {}",
        yamls.len()
    );
    for y in yamls {
        let map = load_map_server(&y).unwrap_or_else(|e| panic!("{e}"));
        let free = map.data().iter().filter(|&&v| v == 0).count();
        let occupied = map.data().iter().filter(|&&v| v >= 65).count();
        assert!(
            free > 0 && occupied > 0,
            "{}: {free} free, {occupied} occupied cells",
            y.display()
        );
    }
}

#[test]
fn ros_maps_have_their_documented_sizes() {
    let size = |p: &str| {
        let m = load_map_server(&shared().join(p)).unwrap();
        (m.width(), m.height(), m.info().resolution)
    };
    assert_eq!(size("ros/nav2_depot/depot.yaml"), (604, 307, 0.05));
    // GIMP comment line in the PGM header.
    assert_eq!(
        size("ros/nav2_warehouse/warehouse.yaml"),
        (1006, 1674, 0.03)
    );
    // RGB PNG.
    assert_eq!(
        size("ros/aws_small_warehouse_005/map.yaml"),
        (286, 423, 0.05)
    );
    assert_eq!(size("bench/substation_1000.yaml"), (1000, 1000, 0.5));
}

#[test]
fn every_moving_ai_map_and_scenario_loads() {
    let maps = files("movingai", ".map");
    assert_eq!(maps.len(), 8);
    for m in &maps {
        load_movingai_map(m).unwrap_or_else(|e| panic!("{e}"));
    }
    for s in files("movingai", ".scen") {
        let rows = load_movingai_scenarios(&s).unwrap_or_else(|e| panic!("{e}"));
        assert!(!rows.is_empty(), "{}", s.display());
        // The map column's base name names a map we have.
        assert!(
            maps.iter()
                .any(|m| m.file_name().unwrap().to_string_lossy() == rows[0].map),
            "{}",
            rows[0].map
        );
    }
}

#[test]
fn every_bench_scenario_file_loads_with_points_inside_its_map() {
    let scens = files("bench", ".scen.yaml");
    assert_eq!(scens.len(), 5);
    for s in scens {
        let (file, map_path) = load_scenario_file(&s).unwrap_or_else(|e| panic!("{e}"));
        let map = load_map_server(&map_path).unwrap();
        for sc in &file.scenarios {
            assert!(
                map.info().world_to_cell(sc.start()).is_some(),
                "{}: {} start",
                s.display(),
                sc.name
            );
            assert!(
                map.info().world_to_cell(sc.goal()).is_some(),
                "{}: {} goal",
                s.display(),
                sc.name
            );
        }
    }
}

/// The shipped parameter file loads, and says exactly the built-in defaults (so the comments in
/// it tell the truth).
#[test]
fn shipped_config_is_the_defaults() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/planner.yaml");
    let config = load_planner_config(&path).unwrap();
    assert_eq!(config, planner_core::config::PlannerConfig::default());
}

/// A typo inside a section is an error that names the key.
#[test]
fn config_typos_are_errors() {
    let dir = std::env::temp_dir().join(format!("planner-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("bad.yaml");
    std::fs::write(
        &p,
        "patrol_planner:\n  ros__parameters:\n    costmap: {robot_raduis: 0.3}\n",
    )
    .unwrap();
    let err = load_planner_config(&p).unwrap_err().to_string();
    assert!(err.contains("robot_raduis"), "{err}");
    std::fs::write(
        &p,
        "patrol_planner:\n  ros__parameters:\n    planner: dijkstra\n",
    )
    .unwrap();
    let err = load_planner_config(&p).unwrap_err().to_string();
    assert!(err.contains("unknown planner `dijkstra`"), "{err}");
}

/// A map_server YAML whose image is missing fails with the image's path in the message.
#[test]
fn a_missing_image_is_an_error_naming_it() {
    let dir = std::env::temp_dir().join(format!("planner-io-missing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let yaml = dir.join("m.yaml");
    std::fs::write(
        &yaml,
        "image: nowhere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n",
    )
    .unwrap();
    let err = load_map_server(&yaml).unwrap_err();
    assert!(matches!(err, LoadError::MapImage { .. }), "{err}");
    // Both files named: the YAML that says where the image is, and the image.
    assert!(err.to_string().contains("nowhere.pgm"), "{err}");
    assert!(err.to_string().contains("m.yaml"), "{err}");
    // The reason is in the message, and not again as its source: an error-chain printer
    // (anyhow's `{:#}`, the CLI's) says it once.
    assert!(std::error::Error::source(&err).is_none(), "{err}");
    std::fs::write(
        &yaml,
        "image: nowhere.pgm\nresolution: 0\norigin: [0, 0, 0]\n",
    )
    .unwrap();
    let err = load_map_server(&yaml).unwrap_err();
    assert!(std::error::Error::source(&err).is_none(), "{err}");
    assert_eq!(
        err.to_string().matches("resolution 0 m").count(),
        1,
        "{err}"
    );
}

/// Files that are not files, or too big, are refused before they are read: `image: /dev/zero`
/// used to read until memory ran out.
#[test]
fn a_map_image_that_is_not_a_regular_file_is_refused() {
    let dir = std::env::temp_dir().join(format!("planner-io-devzero-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let yaml = dir.join("zero.yaml");
    std::fs::write(
        &yaml,
        "image: /dev/zero\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    let err = planner_io::load_map_server(&yaml).unwrap_err().to_string();
    assert!(
        err.contains("/dev/zero") && err.contains("not a regular file"),
        "{err}"
    );
    // A directory given as a map is refused the same way.
    let err = planner_io::load_map(&dir).unwrap_err().to_string();
    assert!(err.contains("not a regular file"), "{err}");
}

/// A parameter file nested 100,000 levels deep is refused at once (it took 20 s to parse).
#[test]
fn a_deeply_nested_parameter_file_is_refused_quickly() {
    let dir = std::env::temp_dir().join(format!("planner-io-deep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("deep.yaml");
    std::fs::write(
        &p,
        format!(
            "patrol_planner:\n  ros__parameters:\n    planner: {}astar{}\n",
            "[".repeat(100_000),
            "]".repeat(100_000)
        ),
    )
    .unwrap();
    let t0 = std::time::Instant::now();
    let err = load_planner_config(&p).unwrap_err().to_string();
    assert!(err.contains("nested deeper"), "{err}");
    assert!(t0.elapsed().as_secs() < 2);
}
