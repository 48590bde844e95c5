//! Patrol routes: the order in which the patrol car visits its inspection points, and the legs
//! between them (project issue 15). Pure like the rest of the crate: the route file comes in as
//! bytes, nothing here reads a clock.
//!
//! A route ([`RouteFile`]) is a list of named inspection points, each a pose (map metres and the
//! yaw the car must face there) and a dwell time, plus where the robot starts (a pose, or by
//! default the first point) and optionally a `home` point to end at. [`plan_route`] answers with
//! the fastest order it finds, every leg's path, and the same totals for the order of the file.
//!
//! # The driving-time model
//! The car drives straight segments at `max_linear` (default 0.6 m/s) and turns in place at
//! `max_angular` (default 0.4 rad/s), the chassis' limits ([`DrivingModel`]). A leg from point
//! `a` to point `b` along a polyline with headings `h_1 .. h_k` takes
//!
//! ```text
//! time(a -> b) = length / max_linear
//!              + (|h_1 - yaw_a| + sum_i |h_{i+1} - h_i| + |yaw_b - h_k|) / max_angular
//! ```
//!
//! every angle difference wrapped to (-pi, pi] (a turn takes the short way round). The car faces
//! each point's yaw while it inspects, so the turn at a point, from the arriving heading to the
//! yaw and from the yaw to the next leg's first heading, splits exactly between the two legs: a
//! leg's time depends on its two ends only, and a route's time is the sum of its legs' times plus
//! every dwell. The start pose's yaw is the heading the robot has; a closed loop ends facing it
//! again. Acceleration is not modelled. The time matrix is asymmetric: the path `b -> a` is the
//! path `a -> b` reversed, with the same length and bends, but different turns at its ends.
//!
//! # How a route is planned
//! 1. The leg matrix ([`LegMatrix`]): one multi-target Dijkstra sweep per point on the planning
//!    grid gives the walk to every later point at once; each walk is string-pulled by the delete
//!    operation and measured. Points outside the map, in an obstacle (or its inflated band), or
//!    cut off from the start are reported in `skipped` with the reason and left out; the start
//!    itself must be usable ([`RouteError::StartUnusable`]).
//! 2. The order ([`order`]): the driving-time matrix (asymmetric) goes to Held-Karp (exact) up to
//!    [`EXACT_LIMIT`] points, and to a nearest-neighbour tour improved by reversal-aware 2-opt,
//!    Or-opt and seeded double-bridge kicks above that. The start is first; the tour ends
//!    anywhere (open route), at `home`, or back at the start (closed loop).
//! 3. The legs of the chosen order, and of the file's order, are planned again by a
//!    [`LegPlanner`] (any planner through [`crate::planner::solve`], e.g. any-angle with
//!    [`SolveLegs`]), each unordered pair once, or taken from the matrix when there is none or it
//!    fails (said in `notes`). Should the file's order come out faster on those legs (the matrix
//!    is a string-pulled estimate), it is kept, and `notes` says so.

pub mod file;
pub mod matrix;
pub mod model;
pub mod order;

pub use file::{RouteError, RouteFile, RoutePoint, RoutePose, MAX_POINTS, START_NAME};
pub use matrix::LegMatrix;
pub use model::{DrivingModel, LegCost, PathShape};
pub use order::{
    best_order, held_karp, heuristic, tour_cost, CostMatrix, HeuristicParams, OrderMethod, Tour,
    TourEnd, EXACT_LIMIT,
};

use crate::geometry::{Point2, Pose2};
use crate::grid::inflation::PlanningGrid;
use crate::planner::{solve, PlanContext, PlanError, Planner, PlannerRng, Query, SolveOptions};
use rand::SeedableRng;
use serde::Serialize;
use std::collections::HashMap;
use std::fmt;

/// Why a point was left out of the route.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkipReason {
    /// Its position is outside the map.
    OutsideMap,
    /// Its cell is an obstacle, unknown, or within the inflation radius of an obstacle.
    Occupied,
    /// It is free, but no path from the start reaches it.
    CutOff,
}

impl fmt::Display for SkipReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SkipReason::OutsideMap => "is outside the map",
            SkipReason::Occupied => {
                "is in an obstacle, in unknown space or within the inflation radius of an obstacle"
            }
            SkipReason::CutOff => "is cut off: no path from the start reaches it",
        })
    }
}

/// Serialised as its sentence.
impl Serialize for SkipReason {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A point left out, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Skipped {
    pub name: String,
    pub reason: SkipReason,
}

/// How to plan a route.
#[derive(Clone, Debug, PartialEq)]
pub struct RouteOptions {
    /// Return to the start (a closed loop) instead of ending anywhere or at `home`.
    pub closed: bool,
    pub model: DrivingModel,
    /// Up to this many points (the start not counted) the order is exact. Default
    /// [`EXACT_LIMIT`] (12); at most [`order::HELD_KARP_MAX`] is honoured.
    pub exact_limit: usize,
    pub heuristic: HeuristicParams,
}

impl Default for RouteOptions {
    fn default() -> Self {
        Self {
            closed: false,
            model: DrivingModel::default(),
            exact_limit: EXACT_LIMIT,
            heuristic: HeuristicParams::default(),
        }
    }
}

/// Plans one leg: a collision-free polyline in world metres from `from` to `to`, both ends
/// included. Any closure of that shape is one.
pub trait LegPlanner {
    fn plan_leg(&mut self, from: Point2, to: Point2) -> Result<Vec<Point2>, PlanError>;
}

impl<F: FnMut(Point2, Point2) -> Result<Vec<Point2>, PlanError>> LegPlanner for F {
    fn plan_leg(&mut self, from: Point2, to: Point2) -> Result<Vec<Point2>, PlanError> {
        self(from, to)
    }
}

/// Legs planned by any [`Planner`] through [`solve`], with no goal tolerance, no deadline, and a
/// fresh RNG seeded with `seed` for every leg (so a leg does not depend on the legs before it).
pub struct SolveLegs<'a> {
    pub planner: &'a dyn Planner,
    pub grid: &'a PlanningGrid,
    pub options: SolveOptions,
    pub seed: u64,
}

impl LegPlanner for SolveLegs<'_> {
    fn plan_leg(&mut self, from: Point2, to: Point2) -> Result<Vec<Point2>, PlanError> {
        let mut rng = PlannerRng::seed_from_u64(self.seed);
        let query = Query {
            start: from,
            goal: to,
            tolerance: 0.0,
        };
        let mut ctx = PlanContext::never_interrupted(&mut rng);
        Ok(solve(self.planner, self.grid, &query, self.options, &mut ctx)?.waypoints)
    }
}

/// One leg of a planned route.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Leg {
    pub from: String,
    pub to: String,
    pub length_m: f64,
    /// Turning in place, the turns at both ends included (rad).
    pub turning_rad: f64,
    /// Driving time: length and turning (s).
    pub time_s: f64,
    /// The path in world metres, from `from` to `to`.
    pub waypoints: Vec<Point2>,
}

/// A planned route.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RoutePlan {
    /// The points in visiting order (the start pose, when the file gives one, is not a point).
    pub order: Vec<String>,
    /// Whether the route returns to the start.
    pub closed: bool,
    pub legs: Vec<Leg>,
    pub total_length_m: f64,
    /// Driving, turning and every dwell (s).
    pub total_time_s: f64,
    /// The dwell part of the totals (s): the same for every order.
    pub dwell_s: f64,
    /// The file's order (reachable points only, `home` moved to the end).
    pub given_order: Vec<String>,
    pub given_order_length_m: f64,
    pub given_order_time_s: f64,
    /// How the order was found.
    pub method: OrderMethod,
    pub skipped: Vec<Skipped>,
    /// What else happened: a leg planner that failed, a home that was skipped, ...
    pub notes: Vec<String>,
}

/// The nodes of a route: the start pose (when given) and the points.
struct Nodes {
    names: Vec<String>,
    poses: Vec<Pose2>,
    dwell: Vec<f64>,
}

impl Nodes {
    fn of(route: &RouteFile) -> Self {
        let mut nodes = Nodes {
            names: Vec::new(),
            poses: Vec::new(),
            dwell: Vec::new(),
        };
        if let Some(s) = route.start {
            nodes.names.push(START_NAME.to_string());
            nodes.poses.push(s.into());
            nodes.dwell.push(0.0);
        }
        for p in &route.points {
            nodes.names.push(p.name.clone());
            nodes.poses.push(p.pose());
            nodes.dwell.push(p.dwell);
        }
        nodes
    }
}

/// Plans a route on a planning grid: see the module doc. `legs` plans the chosen legs; `None`
/// takes them from the leg matrix.
pub fn plan_route(
    grid: &PlanningGrid,
    route: &RouteFile,
    options: &RouteOptions,
    legs: Option<&mut dyn LegPlanner>,
) -> Result<RoutePlan, RouteError> {
    route.validate()?;
    options.model.validate()?;
    if options.closed && route.home.is_some() {
        return Err(RouteError::HomeWithLoop);
    }
    let nodes = Nodes::of(route);
    let offset = usize::from(route.start.is_some());
    let mut notes = Vec::new();
    let mut closed = options.closed;
    let mut home = route.home_index().map(|k| k + offset);
    if home == Some(0) {
        notes.push(format!(
            "home `{}` is where the route starts: planned as a closed loop",
            nodes.names[0]
        ));
        (closed, home) = (true, None);
    }
    let positions: Vec<Point2> = nodes.poses.iter().map(Pose2::position).collect();
    let matrix = LegMatrix::build(grid, &positions).map_err(|reason| {
        let p = positions[0];
        RouteError::StartUnusable {
            what: match route.start {
                Some(_) => format!("pose ({}, {})", p.x, p.y),
                None => format!("point `{}` ({}, {})", nodes.names[0], p.x, p.y),
            },
            reason,
        }
    })?;
    let skipped: Vec<Skipped> = matrix
        .unreachable
        .iter()
        .map(|&(k, reason)| Skipped {
            name: nodes.names[k].clone(),
            reason,
        })
        .collect();
    if matrix.len() == offset {
        return Err(RouteError::NothingReachable(skipped));
    }
    let end = match home {
        _ if closed => TourEnd::Start,
        None => TourEnd::Anywhere,
        Some(h) => match matrix.nodes.iter().position(|&k| k == h) {
            Some(x) => TourEnd::At(x),
            None => {
                notes.push(format!(
                    "home `{}` is skipped: the route ends at its last reachable point",
                    nodes.names[h]
                ));
                TourEnd::Anywhere
            }
        },
    };
    let yaws: Vec<f64> = matrix.nodes.iter().map(|&k| nodes.poses[k].yaw).collect();
    let times = matrix.times(&yaws, &options.model);
    let (tour, method) = best_order(&times, end, options.exact_limit, &options.heuristic);
    let mut given: Vec<usize> = (0..matrix.len())
        .filter(|&x| TourEnd::At(x) != end)
        .collect();
    if let TourEnd::At(h) = end {
        given.push(h);
    }
    let mut builder = LegBuilder {
        matrix: &matrix,
        nodes: &nodes,
        model: &options.model,
        planner: legs,
        planned: HashMap::new(),
        notes: &mut notes,
    };
    let mut chosen = builder.route(&tour.order, closed);
    let given_route = builder.route(&given, closed);
    if given_route.time_s < chosen.time_s - 1e-9 {
        notes.push(format!(
            "the file's order is faster on the planned legs ({:.2} s against {:.2} s): kept",
            given_route.time_s, chosen.time_s
        ));
        chosen = given_route.clone();
    }
    let dwell_s: f64 = matrix.nodes.iter().map(|&k| nodes.dwell[k]).sum();
    let names = |order: &[usize]| -> Vec<String> {
        order
            .iter()
            .filter(|&&x| matrix.nodes[x] >= offset)
            .map(|&x| nodes.names[matrix.nodes[x]].clone())
            .collect()
    };
    Ok(RoutePlan {
        order: names(&chosen.order),
        closed,
        total_length_m: chosen.length_m,
        total_time_s: chosen.time_s + dwell_s,
        legs: chosen.legs,
        dwell_s,
        given_order: names(&given),
        given_order_length_m: given_route.length_m,
        given_order_time_s: given_route.time_s + dwell_s,
        method,
        skipped,
        notes,
    })
}

/// The legs of one order and their driving totals.
#[derive(Clone)]
struct PlannedRoute {
    order: Vec<usize>,
    legs: Vec<Leg>,
    length_m: f64,
    time_s: f64,
}

/// Plans legs (matrix indices) once per unordered pair.
struct LegBuilder<'a, 'p> {
    matrix: &'a LegMatrix,
    nodes: &'a Nodes,
    model: &'a DrivingModel,
    planner: Option<&'p mut dyn LegPlanner>,
    /// The path from the smaller index to the larger.
    planned: HashMap<(usize, usize), Vec<Point2>>,
    notes: &'a mut Vec<String>,
}

impl LegBuilder<'_, '_> {
    fn path(&mut self, a: usize, b: usize) -> Vec<Point2> {
        let key = (a.min(b), a.max(b));
        if !self.planned.contains_key(&key) {
            let (from, to) = key;
            let matrix = self.matrix;
            let position = |x: usize| self.nodes.poses[matrix.nodes[x]].position();
            let path = match self.planner.as_deref_mut() {
                // Within one cell the leg is the straight segment: no planner needed.
                Some(p) if !matrix.same_cell(from, to) => {
                    match p.plan_leg(position(from), position(to)) {
                        Ok(path) => path,
                        Err(e) => {
                            self.notes.push(format!(
                                "leg `{}` - `{}`: {e}; the matrix's string-pulled path is used",
                                self.nodes.names[matrix.nodes[from]],
                                self.nodes.names[matrix.nodes[to]]
                            ));
                            matrix.path(from, to)
                        }
                    }
                }
                _ => matrix.path(from, to),
            };
            self.planned.insert(key, path);
        }
        let mut path = self.planned[&key].clone();
        if a > b {
            path.reverse();
        }
        path
    }

    fn route(&mut self, order: &[usize], closed: bool) -> PlannedRoute {
        let mut pairs: Vec<(usize, usize)> = order.windows(2).map(|w| (w[0], w[1])).collect();
        if closed && order.len() > 1 {
            pairs.push((order[order.len() - 1], order[0]));
        }
        let legs: Vec<Leg> = pairs
            .into_iter()
            .map(|(a, b)| {
                let waypoints = self.path(a, b);
                let (na, nb) = (self.matrix.nodes[a], self.matrix.nodes[b]);
                let (ya, yb) = (self.nodes.poses[na].yaw, self.nodes.poses[nb].yaw);
                let cost = self.model.leg(&waypoints, ya, yb);
                Leg {
                    from: self.nodes.names[na].clone(),
                    to: self.nodes.names[nb].clone(),
                    length_m: cost.length_m,
                    turning_rad: cost.turning_rad,
                    time_s: cost.time_s,
                    waypoints,
                }
            })
            .collect();
        PlannedRoute {
            order: order.to_vec(),
            length_m: legs.iter().map(|l| l.length_m).sum(),
            time_s: legs.iter().map(|l| l.time_s).sum(),
            legs,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::raycast::path_is_free;
    use crate::search::any_angle::AnyAngle;
    use crate::test_support::grid_from_rows;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn point(name: &str, x: f64, y: f64, yaw: f64, dwell: f64) -> RoutePoint {
        RoutePoint {
            name: name.into(),
            x,
            y,
            yaw,
            dwell,
        }
    }

    fn open_floor(w: usize, h: usize) -> PlanningGrid {
        let rows = vec![".".repeat(w); h];
        grid_from_rows(&rows.iter().map(String::as_str).collect::<Vec<_>>())
    }

    #[test]
    fn a_hand_computed_route() {
        // From (0.5, 0.5) facing east, 5 m east to `a`, face north there for 10 s.
        let route = RouteFile {
            start: Some(RoutePose {
                x: 0.5,
                y: 0.5,
                yaw: 0.0,
            }),
            home: None,
            points: vec![point("a", 5.5, 0.5, FRAC_PI_2, 10.0)],
        };
        let plan = plan_route(&open_floor(8, 3), &route, &RouteOptions::default(), None).unwrap();
        assert_eq!(plan.order, vec!["a"]);
        assert_eq!(plan.legs.len(), 1);
        assert_eq!(
            (plan.legs[0].from.as_str(), plan.legs[0].to.as_str()),
            ("start", "a")
        );
        let drive = 5.0 / 0.6 + FRAC_PI_2 / 0.4;
        assert!((plan.legs[0].time_s - drive).abs() < 1e-9);
        assert!((plan.total_time_s - drive - 10.0).abs() < 1e-9);
        assert_eq!(plan.total_length_m, 5.0);
        // Closed: back west (turn north -> west, pi/2), then west -> east at the start (pi).
        let options = RouteOptions {
            closed: true,
            ..Default::default()
        };
        let plan = plan_route(&open_floor(8, 3), &route, &options, None).unwrap();
        assert_eq!(plan.legs.len(), 2);
        let back = 5.0 / 0.6 + (FRAC_PI_2 + PI) / 0.4;
        assert!(
            (plan.legs[1].time_s - back).abs() < 1e-9,
            "{}",
            plan.legs[1].time_s
        );
        assert!((plan.total_time_s - drive - back - 10.0).abs() < 1e-9);
    }

    /// Five points on a line in a poor file order: open, closed and home routes.
    fn line_route() -> RouteFile {
        RouteFile {
            start: Some(RoutePose {
                x: 0.5,
                y: 1.5,
                yaw: 0.0,
            }),
            home: None,
            points: [9.5, 3.5, 15.5, 6.5, 12.5]
                .iter()
                .enumerate()
                .map(|(i, &x)| point(&format!("p{x}"), x, 1.5, 0.0, i as f64))
                .collect(),
        }
    }

    #[test]
    fn open_closed_and_home() {
        let grid = open_floor(17, 3);
        let route = line_route();
        let open = plan_route(&grid, &route, &RouteOptions::default(), None).unwrap();
        assert_eq!(open.order, ["p3.5", "p6.5", "p9.5", "p12.5", "p15.5"]);
        assert_eq!(open.given_order, ["p9.5", "p3.5", "p15.5", "p6.5", "p12.5"]);
        assert_eq!(open.method, OrderMethod::HeldKarp);
        assert_eq!(open.legs.len(), 5);
        assert!((open.total_length_m - 15.0).abs() < 1e-9);
        assert!((open.dwell_s - 10.0).abs() < 1e-12);
        assert!(open.given_order_time_s > open.total_time_s + 10.0);
        assert!(open.given_order_length_m > open.total_length_m);
        let options = RouteOptions {
            closed: true,
            ..Default::default()
        };
        let closed = plan_route(&grid, &route, &options, None).unwrap();
        assert_eq!(closed.legs.len(), 6);
        assert_eq!(closed.legs.last().unwrap().to, "start");
        assert!((closed.total_length_m - 30.0).abs() < 1e-9);
        assert!(closed.total_time_s > open.total_time_s);
        let home = RouteFile {
            home: Some("p6.5".into()),
            ..route.clone()
        };
        let to_home = plan_route(&grid, &home, &RouteOptions::default(), None).unwrap();
        assert_eq!(to_home.order.last().unwrap(), "p6.5");
        assert_eq!(to_home.given_order.last().unwrap(), "p6.5");
        assert_eq!(to_home.legs.len(), 5);
        assert!(to_home.total_time_s > open.total_time_s);
        assert_eq!(
            plan_route(&grid, &home, &options, None).unwrap_err(),
            RouteError::HomeWithLoop
        );
        // Without a start pose the first point is the start, and a home there makes a loop.
        let from_first = RouteFile {
            start: None,
            home: Some("p9.5".into()),
            ..route
        };
        let plan = plan_route(&grid, &from_first, &RouteOptions::default(), None).unwrap();
        assert!(
            plan.closed && plan.notes[0].contains("closed loop"),
            "{:?}",
            plan.notes
        );
        assert_eq!(plan.order[0], "p9.5");
        assert_eq!(plan.legs.len(), 5);
        assert_eq!(plan.legs.last().unwrap().to, "p9.5");
    }

    #[test]
    fn unreachable_points_are_skipped_with_their_reason() {
        // Row 0 at the bottom; the right part is walled off by the `#` column.
        let grid = grid_from_rows(&["....#..", "....#..", ".##.#..", "....#.."]);
        let route = RouteFile {
            start: None,
            home: Some("boxed".into()),
            points: vec![
                point("a", 0.5, 0.5, 0.0, 1.0),
                point("b", 3.5, 3.5, 0.0, 1.0),
                point("wall", 1.5, 1.5, 0.0, 1.0),
                point("boxed", 6.5, 2.5, 0.0, 1.0),
                point("away", -3.0, 1.0, 0.0, 1.0),
                point("c", 0.5, 3.5, 0.0, 1.0),
            ],
        };
        let plan = plan_route(&grid, &route, &RouteOptions::default(), None).unwrap();
        let skipped: Vec<(&str, SkipReason)> = plan
            .skipped
            .iter()
            .map(|s| (s.name.as_str(), s.reason))
            .collect();
        assert_eq!(
            skipped,
            [
                ("wall", SkipReason::Occupied),
                ("boxed", SkipReason::CutOff),
                ("away", SkipReason::OutsideMap)
            ]
        );
        assert_eq!(plan.order.len(), 3);
        assert!(plan
            .notes
            .iter()
            .any(|n| n.contains("home `boxed` is skipped")));
        let json = serde_json_like(&plan.skipped[1]);
        assert!(json.contains("cut off"), "{json}");
        // Nothing reachable from a start pose is an error listing why; so is an unusable start.
        let lonely = RouteFile {
            start: Some(RoutePose {
                x: 0.5,
                y: 0.5,
                yaw: 0.0,
            }),
            home: None,
            points: vec![point("boxed", 6.5, 2.5, 0.0, 1.0)],
        };
        let err = plan_route(&grid, &lonely, &RouteOptions::default(), None).unwrap_err();
        assert!(matches!(err, RouteError::NothingReachable(_)));
        assert!(err.to_string().contains("`boxed` is cut off"), "{err}");
        let walled_start = RouteFile {
            start: Some(RoutePose {
                x: 2.5,
                y: 1.5,
                yaw: 0.0,
            }),
            ..lonely
        };
        let err = plan_route(&grid, &walled_start, &RouteOptions::default(), None).unwrap_err();
        assert!(
            err.to_string()
                .contains("start pose (2.5, 1.5) cannot be used: is in an obstacle"),
            "{err}"
        );
    }

    fn serde_json_like(s: &Skipped) -> String {
        // planner-core has no JSON dependency; YAML shows the same serialisation.
        serde_yaml::to_string(s).unwrap()
    }

    #[test]
    fn legs_are_planned_once_per_pair_by_the_leg_planner() {
        let grid = grid_from_rows(&["..........", "...####...", "..........", ".........."]);
        let route = RouteFile {
            start: None,
            home: None,
            points: vec![
                point("a", 0.5, 0.5, 0.0, 5.0),
                point("b", 9.5, 3.5, PI, 5.0),
                point("c", 0.5, 3.5, 0.0, 5.0),
                point("d", 9.5, 0.5, 0.0, 5.0),
            ],
        };
        let mut calls = Vec::new();
        let mut solver = SolveLegs {
            planner: &AnyAngle,
            grid: &grid,
            options: SolveOptions::default(),
            seed: 0,
        };
        let mut counting = |from: Point2, to: Point2| {
            calls.push((from, to));
            solver.plan_leg(from, to)
        };
        let options = RouteOptions {
            closed: true,
            ..Default::default()
        };
        let plan = plan_route(&grid, &route, &options, Some(&mut counting)).unwrap();
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        for legs in [&plan.order, &plan.given_order] {
            let idx = |n: &String| route.points.iter().position(|p| &p.name == n).unwrap();
            for k in 0..legs.len() {
                let (a, b) = (idx(&legs[k]), idx(&legs[(k + 1) % legs.len()]));
                pairs.push((a.min(b), a.max(b)));
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        assert_eq!(calls.len(), pairs.len(), "{calls:?}");
        for leg in &plan.legs {
            assert!(path_is_free(&grid, &leg.waypoints), "{leg:?}");
            let from = route.points.iter().find(|p| p.name == leg.from).unwrap();
            let to = route.points.iter().find(|p| p.name == leg.to).unwrap();
            assert_eq!(leg.waypoints[0], Point2::new(from.x, from.y));
            assert_eq!(*leg.waypoints.last().unwrap(), Point2::new(to.x, to.y));
        }
        // The given order crosses the room twice: the optimiser's own order beats it (not the
        // given order kept as the faster, which `plan_route` would fall back to).
        assert!(
            plan.total_time_s < plan.given_order_time_s - 1.0,
            "{} against {}",
            plan.total_time_s,
            plan.given_order_time_s
        );
        assert!(
            !plan
                .notes
                .iter()
                .any(|n| n.contains("file's order is faster")),
            "{:?}",
            plan.notes
        );
        // A leg planner that fails leaves the matrix's paths, and says so.
        let mut failing = |_: Point2, _: Point2| -> Result<Vec<Point2>, PlanError> {
            Err(PlanError::NoValidPath("test".into()))
        };
        let fallback = plan_route(&grid, &route, &options, Some(&mut failing)).unwrap();
        let matrix_only = plan_route(&grid, &route, &options, None).unwrap();
        assert_eq!(fallback.legs, matrix_only.legs);
        assert!(fallback
            .notes
            .iter()
            .any(|n| n.contains("no valid path: test")));
    }

    #[test]
    fn many_points_go_to_the_heuristic() {
        let grid = open_floor(30, 30);
        let mut r = crate::test_support::rng(3);
        let route = RouteFile {
            start: None,
            home: None,
            points: (0..30)
                .map(|i| {
                    use rand::Rng;
                    point(
                        &format!("p{i}"),
                        r.random_range(0.0..30.0),
                        r.random_range(0.0..30.0),
                        r.random_range(-PI..PI),
                        1.0,
                    )
                })
                .collect(),
        };
        let plan = plan_route(&grid, &route, &RouteOptions::default(), None).unwrap();
        assert_eq!(plan.method, OrderMethod::Heuristic);
        assert_eq!(plan.order.len(), 30);
        assert_eq!(plan.order[0], "p0");
        assert!(plan.total_time_s < plan.given_order_time_s);
    }
}
