//! Route files (`config/routes/*.yaml`): `RouteFile::parse`, which validates.
//!
//! Checked: a parsed route validates again (validation is a pure check), has 1..=MAX_POINTS
//! points with finite coordinates, and `home_index` names one of them when `home` is set.
#![no_main]

use libfuzzer_sys::fuzz_target;
use planner_core::route::file::{RouteFile, MAX_POINTS};

fuzz_target!(|data: &[u8]| {
    if let Ok(route) = RouteFile::parse(data) {
        route.validate().expect("a parsed route validates again");
        assert!((1..=MAX_POINTS).contains(&route.points.len()));
        for p in &route.points {
            assert!(p.x.is_finite() && p.y.is_finite() && p.yaw.is_finite());
            assert!(p.dwell >= 0.0);
            let _ = p.pose();
        }
        if route.home.is_some() {
            let i = route.home_index().expect("home names a point");
            assert!(i < route.points.len());
        }
    }
});
