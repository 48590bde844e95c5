//! The route file: where the robot is, the inspection points and where to end, as YAML.
//!
//! ```yaml
//! start: {x: 0.5, y: 0.5, yaw: 0.0}   # optional: the robot's pose; default the first point's
//! home: dock                          # optional: the point to end at (an open route)
//! points:                             # at most MAX_POINTS; names unique
//!   - {name: rack_a1, x: 2.1, y: 3.3, yaw: 1.57, dwell: 10.0}
//!   - {name: dock, x: 0.5, y: 1.0, yaw: 0.0, dwell: 0.0}
//! ```
//!
//! Positions are map metres, `yaw` the heading (rad, counter-clockwise from +x) the car must face
//! at the point, `dwell` the seconds it stays there. Parsed from bytes: reading the file is the
//! caller's job.

use crate::geometry::Pose2;
use crate::params::ParamError;
use serde::{Deserialize, Serialize};

/// The most points a route may have. The leg matrix holds a path for every pair of points
/// (125 000 at this size) and the heuristic's local search is quadratic per pass.
pub const MAX_POINTS: usize = 500;

/// The name the start pose goes by in legs (`from: start`); a point may not take it when the file
/// gives a start pose.
pub const START_NAME: &str = "start";

/// A pose in the file: map metres and a heading in radians.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoutePose {
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}

impl From<RoutePose> for Pose2 {
    fn from(p: RoutePose) -> Self {
        Pose2::new(p.x, p.y, p.yaw)
    }
}

/// One inspection point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoutePoint {
    pub name: String,
    pub x: f64,
    pub y: f64,
    /// The heading the car faces while it inspects (rad).
    pub yaw: f64,
    /// How long it stays (s), 0 or more.
    pub dwell: f64,
}

impl RoutePoint {
    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.x, self.y, self.yaw)
    }
}

/// A route file as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RouteFile {
    /// Where the robot is; `None`: at the first point, which is then visited first.
    #[serde(default)]
    pub start: Option<RoutePose>,
    /// The name of the point to end at; `None`: end anywhere (or back at the start for a loop).
    #[serde(default)]
    pub home: Option<String>,
    pub points: Vec<RoutePoint>,
}

/// The longest stay at a point (s): a day. A longer one is a typo, and sums of them overflow.
pub const MAX_DWELL_S: f64 = 86_400.0;

/// What can be wrong with a route, or keep it from being planned at all.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RouteError {
    #[error("route file: {0}")]
    Format(String),
    #[error("the route has no points")]
    NoPoints,
    #[error("the route has {count} points, more than the limit of {limit}")]
    TooManyPoints { count: usize, limit: usize },
    #[error("point {index} (counting from 0) has an empty name")]
    EmptyName { index: usize },
    #[error("two points are named `{0}`")]
    DuplicateName(String),
    #[error("a point is named `{START_NAME}`, the name of the start pose in legs: rename it")]
    ReservedName,
    #[error("{what}: {field} is {value}, not a finite number")]
    NonFinite {
        what: String,
        field: &'static str,
        value: f64,
    },
    #[error("point `{name}`: dwell {dwell} s is outside 0..={MAX_DWELL_S} s")]
    DwellOutOfRange { name: String, dwell: f64 },
    #[error("home `{0}` is not the name of a point of the route")]
    UnknownHome(String),
    #[error("a closed loop ends where it starts: `home` is for open routes")]
    HomeWithLoop,
    #[error("driving model: {0}")]
    Model(#[from] ParamError),
    #[error("the start {what} cannot be used: {reason}")]
    StartUnusable {
        what: String,
        reason: super::SkipReason,
    },
    #[error("no point of the route is reachable from the start: {}", .0.iter().map(|s| format!("`{}` {}", s.name, s.reason)).collect::<Vec<_>>().join("; "))]
    NothingReachable(Vec<super::Skipped>),
}

impl RouteFile {
    /// Parses and validates a route file (after the shared guard against oversized or absurdly
    /// nested YAML).
    pub fn parse(yaml: &[u8]) -> Result<Self, RouteError> {
        input_guard::yaml::check(yaml).map_err(RouteError::Format)?;
        let file: RouteFile =
            serde_yaml::from_slice(yaml).map_err(|e| RouteError::Format(e.to_string()))?;
        file.validate()?;
        Ok(file)
    }

    /// Checks everything that does not need the map: at least one and at most [`MAX_POINTS`]
    /// points, unique non-empty names (`start` reserved when a start pose is given), finite
    /// numbers, no negative dwell, a `home` that names a point.
    pub fn validate(&self) -> Result<(), RouteError> {
        if self.points.is_empty() {
            return Err(RouteError::NoPoints);
        }
        if self.points.len() > MAX_POINTS {
            return Err(RouteError::TooManyPoints {
                count: self.points.len(),
                limit: MAX_POINTS,
            });
        }
        let finite = |what: &dyn Fn() -> String, fields: &[(&'static str, f64)]| match fields
            .iter()
            .find(|(_, v)| !v.is_finite())
        {
            Some(&(field, value)) => Err(RouteError::NonFinite {
                what: what(),
                field,
                value,
            }),
            None => Ok(()),
        };
        if let Some(s) = &self.start {
            finite(
                &|| "start".into(),
                &[("x", s.x), ("y", s.y), ("yaw", s.yaw)],
            )?;
        }
        let mut names = std::collections::HashSet::new();
        for (index, p) in self.points.iter().enumerate() {
            if p.name.trim().is_empty() {
                return Err(RouteError::EmptyName { index });
            }
            if self.start.is_some() && p.name == START_NAME {
                return Err(RouteError::ReservedName);
            }
            if !names.insert(p.name.as_str()) {
                return Err(RouteError::DuplicateName(p.name.clone()));
            }
            let what = || format!("point `{}`", p.name);
            finite(
                &what,
                &[("x", p.x), ("y", p.y), ("yaw", p.yaw), ("dwell", p.dwell)],
            )?;
            if !(0.0..=MAX_DWELL_S).contains(&p.dwell) {
                return Err(RouteError::DwellOutOfRange {
                    name: p.name.clone(),
                    dwell: p.dwell,
                });
            }
        }
        if let Some(home) = &self.home {
            if !names.contains(home.as_str()) {
                return Err(RouteError::UnknownHome(home.clone()));
            }
        }
        Ok(())
    }

    /// The index of the `home` point, if any (the file must be valid).
    pub fn home_index(&self) -> Option<usize> {
        let home = self.home.as_deref()?;
        self.points.iter().position(|p| p.name == home)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<RouteFile, RouteError> {
        RouteFile::parse(text.as_bytes())
    }

    #[test]
    fn the_documented_example_parses() {
        let f = parse(
            "start: {x: 0.5, y: 0.5, yaw: 0.0}\nhome: dock\npoints:\n  - {name: rack_a1, x: 2.1, y: 3.3, yaw: 1.57, dwell: 10.0}\n  - {name: dock, x: 0.5, y: 1.0, yaw: 0.0, dwell: 0}\n",
        )
        .unwrap();
        assert_eq!(f.points.len(), 2);
        assert_eq!(f.home_index(), Some(1));
        assert_eq!(Pose2::from(f.start.unwrap()), Pose2::new(0.5, 0.5, 0.0));
        let minimal = parse("points: [{name: a, x: 1, y: 2, yaw: 0, dwell: 5}]").unwrap();
        assert_eq!((minimal.start, minimal.home), (None, None));
    }

    #[test]
    fn every_mistake_is_named() {
        let cases: &[(&str, &str)] = &[
            ("points: []", "no points"),
            ("pionts: []", "unknown field `pionts`"),
            ("points: [{name: a, x: 1, y: 2, yaw: 0, dwel: 5}]", "unknown field `dwel`"),
            ("points: [{name: a, x: 1, y: 2, dwell: 5}]", "missing field `yaw`"),
            ("start: {x: 0, y: 0, yaw: 0, z: 1}\npoints: [{name: a, x: 1, y: 2, yaw: 0, dwell: 5}]", "unknown field `z`"),
            ("points: [{name: a, x: 1, y: 2, yaw: 0, dwell: 5}, {name: a, x: 2, y: 2, yaw: 0, dwell: 5}]", "two points are named `a`"),
            ("points: [{name: ' ', x: 1, y: 2, yaw: 0, dwell: 5}]", "point 0 (counting from 0) has an empty name"),
            ("points: [{name: a, x: .nan, y: 2, yaw: 0, dwell: 5}]", "point `a`: x is NaN"),
            ("points: [{name: a, x: 1, y: 2, yaw: .inf, dwell: 5}]", "point `a`: yaw is inf"),
            ("points: [{name: a, x: 1, y: 2, yaw: 0, dwell: .nan}]", "point `a`: dwell is NaN"),
            ("points: [{name: a, x: 1, y: 2, yaw: 0, dwell: 1e308}]", "s is outside 0..=86400 s"),
            ("points: [{name: a, x: 1, y: 2, yaw: 0, dwell: -1}]", "point `a`: dwell -1 s is outside"),
            ("start: {x: 0, y: -.inf, yaw: 0}\npoints: [{name: a, x: 1, y: 2, yaw: 0, dwell: 5}]", "start: y is -inf"),
            ("home: dock\npoints: [{name: a, x: 1, y: 2, yaw: 0, dwell: 1}]", "home `dock` is not the name"),
            ("start: {x: 0, y: 0, yaw: 0}\npoints: [{name: start, x: 1, y: 2, yaw: 0, dwell: 1}]", "named `start`"),
        ];
        for (text, expected) in cases {
            let err = parse(text).unwrap_err().to_string();
            assert!(err.contains(expected), "{text}: {err}");
        }
        // Without a start pose, `start` is an ordinary name.
        assert!(parse("points: [{name: start, x: 1, y: 2, yaw: 0, dwell: 1}]").is_ok());
    }

    #[test]
    fn at_most_max_points() {
        let points = |n: usize| RouteFile {
            start: None,
            home: None,
            points: (0..n)
                .map(|i| RoutePoint {
                    name: format!("p{i}"),
                    x: i as f64,
                    y: 0.0,
                    yaw: 0.0,
                    dwell: 0.0,
                })
                .collect(),
        };
        assert!(points(MAX_POINTS).validate().is_ok());
        assert_eq!(
            points(MAX_POINTS + 1).validate(),
            Err(RouteError::TooManyPoints {
                count: MAX_POINTS + 1,
                limit: MAX_POINTS
            })
        );
    }
}
