//! The transforms on `/tf` and `/tf_static`, kept as tf2's `BufferCore` keeps them, so that a
//! goal, a start or a path may be stamped in any frame of the robot's TF tree (a camera's, a
//! docking station's, `base_footprint`), as planner_server transforms poses into its global
//! frame.
//!
//! The node keeps its own `map -> odom` and the robot's pose (localization.rs): those are what
//! it plans from, and a pose in one of those frames is carried with them, not with `/tf`'s
//! copies, so that a goal "two metres ahead" and the start of its plan agree. The buffer is
//! walked from a pose's frame up its parents to the first of those known frames
//! ([`TfBuffer::to_known_frame`]); only the edges above the known frames come from here.
//!
//! As tf2: each child frame has one parent (a transform naming another parent replaces the
//! edge); `/tf_static` transforms hold at every time; dynamic ones are kept for
//! [`CACHE_S`] and looked up at a pose's stamp, interpolated (translation linearly, rotation by
//! slerp), stamp 0 meaning the latest; a stamp outside the kept span is an extrapolation error,
//! which the caller may wait out (`transform_tolerance`), as tf2_ros' `Buffer::transform` with a
//! timeout waits. Quaternions whose squared length is more than 0.01 from 1 are refused, as tf2
//! refuses them; nearer ones are normalised.
//!
//! Unlike tf2, the buffer is bounded ([`MAX_FRAMES`], [`MAX_PER_EDGE`]): no stream of
//! transforms can make it grow without end.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use std::collections::{HashMap, VecDeque};

/// How long dynamic transforms are kept (s): tf2's default cache time.
pub const CACHE_S: f64 = 10.0;
/// The most child frames kept; a transform for a frame beyond them is refused. A robot's tree
/// has tens of frames (robot_state_publisher's links, the map, odom, a few sensors).
pub const MAX_FRAMES: usize = 512;
/// The most transforms kept per edge, newest kept: 10 s at 50 Hz. At most
/// `MAX_FRAMES * MAX_PER_EDGE` stamped transforms of 64 B, 16 MB, whatever is published.
pub const MAX_PER_EDGE: usize = 512;

/// One transform as it arrives: `parent -> child` at `stamp` (s).
#[derive(Clone, Debug)]
pub struct Stamped<'a> {
    pub parent: &'a str,
    pub child: &'a str,
    pub stamp: f64,
    pub translation: [f64; 3],
    /// `[x, y, z, w]`, as geometry_msgs/Quaternion.
    pub rotation: [f64; 4],
}

/// Why a transform was not kept, or a frame could not be placed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TfError {
    #[error("transform `{parent}` -> `{child}` refused: {why}")]
    Refused {
        parent: String,
        child: String,
        why: String,
    },
    #[error(
        "frame `{frame}` is not connected to {known}: {}",
        if reached == frame {
            format!("no transform names `{frame}` as its child on /tf or /tf_static")
        } else {
            format!(
                "its parents on /tf and /tf_static end at `{reached}`, which has no parent"
            )
        }
    )]
    NotConnected {
        frame: String,
        reached: String,
        known: String,
    },
    #[error(
        "`{parent}` -> `{child}` is known from {first:.3} s to {last:.3} s, not at {stamp:.3} s \
         (the pose's stamp)"
    )]
    Extrapolation {
        parent: String,
        child: String,
        stamp: f64,
        first: f64,
        last: f64,
    },
    #[error("frame `{0}`'s parents on /tf and /tf_static form a loop")]
    Loop(String),
}

/// One child frame's edge to its parent.
#[derive(Clone, Debug)]
struct Edge {
    parent: String,
    transforms: Transforms,
}

#[derive(Clone, Debug)]
enum Transforms {
    /// From `/tf_static`: holds at every time.
    Static(Isometry3<f64>),
    /// From `/tf`: (stamp, transform), oldest first, stamps distinct.
    Dynamic(VecDeque<(f64, Isometry3<f64>)>),
}

/// The TF tree: each child frame's parent and the transforms between them.
#[derive(Clone, Debug, Default)]
pub struct TfBuffer {
    edges: HashMap<String, Edge>,
}

impl TfBuffer {
    /// Keeps one transform (`is_static`: from `/tf_static`). Refused, and the buffer left as it
    /// was: an empty frame name, a frame its own parent, numbers that are not finite, a
    /// quaternion that is not a rotation, a new child frame beyond [`MAX_FRAMES`].
    pub fn insert(&mut self, t: &Stamped, is_static: bool) -> Result<(), TfError> {
        let refuse = |why: String| TfError::Refused {
            parent: t.parent.to_owned(),
            child: t.child.to_owned(),
            why,
        };
        if t.parent.is_empty() || t.child.is_empty() {
            return Err(refuse("a frame without a name".into()));
        }
        if t.parent == t.child {
            return Err(refuse("a frame cannot be its own parent".into()));
        }
        if !t.stamp.is_finite() || t.translation.iter().any(|v| !v.is_finite()) {
            return Err(refuse(format!(
                "numbers not finite: translation {:?} at {} s",
                t.translation, t.stamp
            )));
        }
        let [x, y, z, w] = t.rotation;
        let norm2 = x * x + y * y + z * z + w * w;
        // Written so that a NaN is refused too.
        if (norm2 - 1.0).abs().is_nan() || (norm2 - 1.0).abs() > 0.01 {
            return Err(refuse(format!(
                "quaternion ({x}, {y}, {z}, {w}) is not a rotation (squared length {norm2})"
            )));
        }
        let [tx, ty, tz] = t.translation;
        let iso = Isometry3::from_parts(
            Translation3::new(tx, ty, tz),
            UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
        );
        if !self.edges.contains_key(t.child) && self.edges.len() >= MAX_FRAMES {
            return Err(refuse(format!(
                "the buffer already holds {MAX_FRAMES} frames"
            )));
        }
        let edge = self
            .edges
            .entry(t.child.to_owned())
            .or_insert_with(|| Edge {
                parent: t.parent.to_owned(),
                transforms: Transforms::Dynamic(VecDeque::new()),
            });
        // A new parent, or a change between static and dynamic, starts the edge afresh.
        let same_kind = matches!(
            (&edge.transforms, is_static),
            (Transforms::Static(_), true) | (Transforms::Dynamic(_), false)
        );
        if edge.parent != t.parent || !same_kind {
            edge.parent = t.parent.to_owned();
            edge.transforms = Transforms::Dynamic(VecDeque::new());
        }
        if is_static {
            edge.transforms = Transforms::Static(iso);
        } else if let Transforms::Dynamic(kept) = &mut edge.transforms {
            keep(kept, t.stamp, iso);
        }
        Ok(())
    }

    /// Walks from `frame` up its parents to the first frame `known` accepts (`frame` itself
    /// included) and returns that frame's name and the transform from `frame` to it, each
    /// dynamic edge at `stamp` (s; 0: the latest).
    pub fn to_known_frame<'a>(
        &'a self,
        frame: &'a str,
        stamp: f64,
        known: impl Fn(&str) -> bool,
        known_names: &str,
    ) -> Result<(&'a str, Isometry3<f64>), TfError> {
        let mut to_at = Isometry3::identity();
        let reached = self.climb(frame, known, known_names, |child, edge| {
            to_at = edge.at(child, stamp)? * to_at;
            Ok(())
        })?;
        Ok((reached, to_at))
    }

    /// The frames from `frame` up to its ancestor `ancestor`, `frame` first and `ancestor`
    /// left out: the child frames of the edges between them.
    pub fn path_up_to<'a>(
        &'a self,
        frame: &'a str,
        ancestor: &str,
    ) -> Result<Vec<&'a str>, TfError> {
        let mut path = Vec::new();
        self.climb(
            frame,
            |f| f == ancestor,
            &format!("`{ancestor}`"),
            |child, _| {
                path.push(child);
                Ok(())
            },
        )?;
        Ok(path)
    }

    /// The transform along `path` (a [`TfBuffer::path_up_to`]'s, from its first frame up to
    /// the ancestor it ends under) as tf2 looks it up at time 0: at the latest time every
    /// dynamic edge on it reaches (the others interpolated there), and that time; `None` for
    /// the time when every edge on it is static.
    pub fn latest_along(&self, path: &[&str]) -> Result<(Isometry3<f64>, Option<f64>), TfError> {
        let edges = || path.iter().map(|child| (*child, &self.edges[*child]));
        let common = edges()
            .filter_map(|(_, edge)| match &edge.transforms {
                Transforms::Dynamic(kept) => kept.back().map(|(stamp, _)| *stamp),
                Transforms::Static(_) => None,
            })
            .reduce(f64::min);
        let mut transform = Isometry3::identity();
        for (child, edge) in edges() {
            transform = edge.at(child, common.unwrap_or(0.0))? * transform;
        }
        Ok((transform, common))
    }

    /// The one walk up the tree: from `frame` up its parents to the first frame `stop`
    /// accepts (`frame` itself included), `visit` called with each edge passed (its child
    /// frame first); returns the frame reached. An unconnected frame or a loop is an error.
    fn climb<'a>(
        &'a self,
        frame: &'a str,
        stop: impl Fn(&str) -> bool,
        stop_names: &str,
        mut visit: impl FnMut(&'a str, &'a Edge) -> Result<(), TfError>,
    ) -> Result<&'a str, TfError> {
        let mut at = frame;
        // A tree of n edges has paths of at most n edges; more is a loop.
        for _ in 0..=self.edges.len() {
            if stop(at) {
                return Ok(at);
            }
            let Some(edge) = self.edges.get(at) else {
                return Err(TfError::NotConnected {
                    frame: frame.to_owned(),
                    reached: at.to_owned(),
                    known: stop_names.to_owned(),
                });
            };
            visit(at, edge)?;
            at = &edge.parent;
        }
        Err(TfError::Loop(frame.to_owned()))
    }
}

/// Adds a dynamic transform in stamp order (one of an equal stamp replaced), then drops what is
/// older than [`CACHE_S`] before the newest, and the oldest beyond [`MAX_PER_EDGE`]. A stamp
/// more than [`CACHE_S`] before the newest (a simulation or a bag started again) starts afresh.
fn keep(kept: &mut VecDeque<(f64, Isometry3<f64>)>, stamp: f64, iso: Isometry3<f64>) {
    if kept
        .back()
        .is_some_and(|(newest, _)| stamp < newest - CACHE_S)
    {
        kept.clear();
    }
    let i = kept.partition_point(|(s, _)| *s < stamp);
    match kept.get_mut(i) {
        Some(slot) if slot.0 == stamp => slot.1 = iso,
        _ => kept.insert(i, (stamp, iso)),
    }
    let newest = kept.back().map_or(stamp, |(s, _)| *s);
    while kept.len() > MAX_PER_EDGE || kept.front().is_some_and(|(s, _)| *s < newest - CACHE_S) {
        kept.pop_front();
    }
}

impl Edge {
    /// The transform from `child` to the parent at `stamp` (0: the latest).
    fn at(&self, child: &str, stamp: f64) -> Result<Isometry3<f64>, TfError> {
        let kept = match &self.transforms {
            Transforms::Static(iso) => return Ok(*iso),
            Transforms::Dynamic(kept) => kept,
        };
        let (Some(first), Some(last)) = (kept.front(), kept.back()) else {
            // Not reachable: an edge is made with its first transform.
            return Err(TfError::NotConnected {
                frame: child.to_owned(),
                reached: child.to_owned(),
                known: self.parent.clone(),
            });
        };
        if stamp == 0.0 {
            return Ok(last.1);
        }
        if stamp < first.0 || stamp > last.0 {
            return Err(TfError::Extrapolation {
                parent: self.parent.clone(),
                child: child.to_owned(),
                stamp,
                first: first.0,
                last: last.0,
            });
        }
        let i = kept.partition_point(|(s, _)| *s < stamp);
        let (s1, after) = kept[i];
        if s1 == stamp || i == 0 {
            return Ok(after);
        }
        let (s0, before) = kept[i - 1];
        Ok(interpolate(&before, &after, (stamp - s0) / (s1 - s0)))
    }
}

/// tf2's interpolation: the translation linearly, the rotation by slerp (the nearer of the two
/// when they are half a turn apart, where slerp has no one answer).
fn interpolate(a: &Isometry3<f64>, b: &Isometry3<f64>, t: f64) -> Isometry3<f64> {
    let translation = a.translation.vector.lerp(&b.translation.vector, t);
    let rotation = a
        .rotation
        .try_slerp(&b.rotation, t, 1e-9)
        .unwrap_or(if t < 0.5 { a.rotation } else { b.rotation });
    Isometry3::from_parts(translation.into(), rotation)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn planar(
        parent: &'static str,
        child: &'static str,
        stamp: f64,
        x: f64,
        y: f64,
        yaw: f64,
    ) -> Stamped<'static> {
        Stamped {
            parent,
            child,
            stamp,
            translation: [x, y, 0.0],
            rotation: [0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()],
        }
    }

    fn known_base(frame: &str) -> bool {
        frame == "base_link" || frame == "map"
    }

    fn place(b: &TfBuffer, frame: &str, stamp: f64, x: f64, y: f64) -> (String, [f64; 3]) {
        let (known, t) = b
            .to_known_frame(frame, stamp, known_base, "`map` or `base_link`")
            .unwrap();
        let p = t * nalgebra::Point3::new(x, y, 0.0);
        (known.to_owned(), [p.x, p.y, p.z])
    }

    fn near(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(p, q)| (p - q).abs() < 1e-9)
    }

    /// A camera 0.2 m ahead of base_link, 0.5 m up, and its optical frame (z forward, x right,
    /// y down, as robot_state_publisher gives it): a point 2 m along the optical axis is 2.2 m
    /// ahead of the robot at the camera's height; the walk stops at base_link.
    #[test]
    fn a_chain_of_static_frames_reaches_the_known_frame() {
        let mut b = TfBuffer::default();
        let mut camera = planar("base_link", "camera_link", 0.0, 0.2, 0.0, 0.0);
        camera.translation[2] = 0.5;
        b.insert(&camera, true).unwrap();
        // optical = roll -90 degrees then yaw -90 degrees: quaternion (-0.5, 0.5, -0.5, 0.5).
        let optical = Stamped {
            parent: "camera_link",
            child: "camera_optical",
            stamp: 0.0,
            translation: [0.0; 3],
            rotation: [-0.5, 0.5, -0.5, 0.5],
        };
        b.insert(&optical, true).unwrap();
        let (known, t) = b
            .to_known_frame("camera_optical", 5.0, known_base, "")
            .unwrap();
        assert_eq!(known, "base_link");
        let p = t * nalgebra::Point3::new(0.0, 0.0, 2.0);
        assert!(near([p.x, p.y, p.z], [2.2, 0.0, 0.5]), "{p}");
        // Optical x (right) is base_link's -y.
        let right = t * nalgebra::Point3::new(1.0, 0.0, 0.0);
        assert!(
            near([right.x, right.y, right.z], [0.2, -1.0, 0.5]),
            "{right}"
        );
        // A known frame is its own answer, with no transform needed.
        assert_eq!(
            place(&b, "map", 0.0, 1.0, 2.0),
            ("map".into(), [1.0, 2.0, 0.0])
        );
    }

    /// A dynamic edge is looked up at the stamp, interpolated between the two transforms around
    /// it; stamp 0 takes the latest; outside the kept span is an extrapolation error.
    #[test]
    fn a_dynamic_edge_is_interpolated_at_the_stamp() {
        let mut b = TfBuffer::default();
        b.insert(&planar("map", "dock", 10.0, 0.0, 0.0, 0.0), false)
            .unwrap();
        b.insert(&planar("map", "dock", 12.0, 2.0, 0.0, FRAC_PI_2), false)
            .unwrap();
        let (_, at11) = b.to_known_frame("dock", 11.0, known_base, "").unwrap();
        assert!(near(
            [
                at11.translation.x,
                at11.translation.y,
                at11.rotation.angle()
            ],
            [1.0, 0.0, FRAC_PI_2 / 2.0]
        ));
        assert!(near(place(&b, "dock", 0.0, 1.0, 0.0).1, [2.0, 1.0, 0.0]));
        assert!(near(place(&b, "dock", 10.0, 1.0, 0.0).1, [1.0, 0.0, 0.0]));
        for stamp in [9.9, 12.1] {
            let e = b.to_known_frame("dock", stamp, known_base, "").unwrap_err();
            assert!(
                matches!(e, TfError::Extrapolation { first, last, .. } if first == 10.0 && last == 12.0),
                "{e}"
            );
            assert!(e.to_string().contains("`map` -> `dock`"), "{e}");
        }
    }

    /// The robot's pose as Nav2 reads it, `odom -> base_footprint` from odometry at 50 Hz and
    /// a static `base_footprint -> base_link`, looked up at the latest time: the dynamic edge's
    /// newest transform; with two dynamic edges, the older of their newest times, the other
    /// interpolated there (tf2's latest common time).
    #[test]
    fn the_latest_lookup_is_at_the_latest_common_time() {
        let mut b = TfBuffer::default();
        b.insert(
            &planar("base_footprint", "base_link", 0.0, 0.1, 0.0, 0.0),
            true,
        )
        .unwrap();
        assert!(matches!(
            b.path_up_to("base_link", "odom"),
            Err(TfError::NotConnected { .. })
        ));
        b.insert(
            &planar("odom", "base_footprint", 5.00, 1.0, 0.0, 0.0),
            false,
        )
        .unwrap();
        b.insert(
            &planar("odom", "base_footprint", 5.02, 2.0, 0.0, FRAC_PI_2),
            false,
        )
        .unwrap();
        assert_eq!(
            b.path_up_to("base_link", "odom").unwrap(),
            ["base_link", "base_footprint"]
        );
        assert!(b.path_up_to("odom", "odom").unwrap().is_empty());
        fn latest(
            b: &TfBuffer,
            frame: &str,
            ancestor: &str,
        ) -> Result<(Isometry3<f64>, Option<f64>), TfError> {
            b.latest_along(&b.path_up_to(frame, ancestor)?)
        }
        let pose = |(t, stamp): (Isometry3<f64>, Option<f64>)| {
            (
                [t.translation.x, t.translation.y, t.rotation.angle()],
                stamp,
            )
        };
        let (at, stamp) = pose(latest(&b, "base_link", "odom").unwrap());
        assert!(near(at, [2.0, 0.1, FRAC_PI_2]), "{at:?}");
        assert_eq!(stamp, Some(5.02));
        // map -> odom from a localizer at 5.01 s and 4.99 s: the chain's latest common time is
        // 5.01 s, where odom -> base_footprint is halfway between its two transforms.
        b.insert(&planar("map", "odom", 4.99, 0.0, 0.0, 0.0), false)
            .unwrap();
        b.insert(&planar("map", "odom", 5.01, 0.0, 10.0, 0.0), false)
            .unwrap();
        let (at, stamp) = pose(latest(&b, "base_link", "map").unwrap());
        assert_eq!(stamp, Some(5.01));
        let half_turn = FRAC_PI_2 / 2.0;
        assert!(
            near(
                at,
                [
                    1.5 + 0.1 * half_turn.cos(),
                    10.0 + 0.1 * half_turn.sin(),
                    half_turn
                ]
            ),
            "{at:?}"
        );
        // Static edges only: no time.
        assert_eq!(
            pose(latest(&b, "base_link", "base_footprint").unwrap()).1,
            None
        );
    }

    /// Frames that lead nowhere known, or in a loop, are named in the error.
    #[test]
    fn unconnected_frames_and_loops_are_errors_naming_the_frames() {
        let mut b = TfBuffer::default();
        let e = b
            .to_known_frame("camera", 0.0, known_base, "`map`")
            .unwrap_err();
        assert_eq!(e.to_string(), "frame `camera` is not connected to `map`: no transform names `camera` as its child on /tf or /tf_static");
        b.insert(&planar("mast", "camera", 0.0, 0.0, 0.0, 0.0), true)
            .unwrap();
        let e = b
            .to_known_frame("camera", 0.0, known_base, "`map`")
            .unwrap_err();
        assert!(
            e.to_string().contains("end at `mast`, which has no parent"),
            "{e}"
        );
        b.insert(&planar("camera", "mast", 0.0, 0.0, 0.0, 0.0), true)
            .unwrap();
        let e = b
            .to_known_frame("camera", 0.0, known_base, "`map`")
            .unwrap_err();
        assert_eq!(e, TfError::Loop("camera".into()));
    }

    /// What tf2 refuses is refused and leaves the buffer as it was; a quaternion a little off
    /// unit length is normalised.
    #[test]
    fn bad_transforms_are_refused() {
        let mut b = TfBuffer::default();
        let good = planar("map", "dock", 1.0, 1.0, 0.0, 0.0);
        let bad = [
            Stamped {
                parent: "",
                ..good.clone()
            },
            Stamped {
                child: "map",
                ..good.clone()
            },
            Stamped {
                translation: [f64::NAN, 0.0, 0.0],
                ..good.clone()
            },
            Stamped {
                stamp: f64::INFINITY,
                ..good.clone()
            },
            Stamped {
                rotation: [0.0, 0.0, 0.0, 0.0],
                ..good.clone()
            },
            Stamped {
                rotation: [0.0, 0.0, 0.0, f64::NAN],
                ..good.clone()
            },
            Stamped {
                rotation: [0.0, 0.0, 0.0, 1.2],
                ..good.clone()
            },
        ];
        for t in &bad {
            assert!(
                matches!(b.insert(t, false), Err(TfError::Refused { .. })),
                "{t:?}"
            );
        }
        assert!(b.edges.is_empty());
        b.insert(
            &Stamped {
                rotation: [0.0, 0.0, 0.0, 1.004],
                ..good
            },
            false,
        )
        .unwrap();
        let (_, t) = b.to_known_frame("dock", 0.0, known_base, "").unwrap();
        assert!((t.rotation.quaternion().norm() - 1.0).abs() < 1e-12);
    }

    /// A child's new parent replaces the edge (tf2 keeps one parent per child); a static
    /// transform replaces a dynamic one's history and the other way round.
    #[test]
    fn a_new_parent_or_kind_replaces_the_edge() {
        let mut b = TfBuffer::default();
        b.insert(&planar("base_link", "tag", 0.0, 1.0, 0.0, 0.0), true)
            .unwrap();
        assert_eq!(place(&b, "tag", 0.0, 0.0, 0.0).0, "base_link");
        b.insert(&planar("map", "tag", 3.0, 5.0, 0.0, 0.0), false)
            .unwrap();
        assert_eq!(
            place(&b, "tag", 0.0, 0.0, 0.0),
            ("map".into(), [5.0, 0.0, 0.0])
        );
        b.insert(&planar("map", "tag", 0.0, 7.0, 0.0, 0.0), true)
            .unwrap();
        assert!(near(place(&b, "tag", 99.0, 0.0, 0.0).1, [7.0, 0.0, 0.0]));
    }

    /// The history keeps CACHE_S before its newest and at most MAX_PER_EDGE transforms;
    /// transforms out of order are put in order; a jump back of more than CACHE_S (a
    /// simulation restarted) starts afresh; no more than MAX_FRAMES frames are kept.
    #[test]
    fn the_buffer_stays_bounded_and_ordered() {
        let mut b = TfBuffer::default();
        for i in 0..3 * MAX_PER_EDGE {
            b.insert(
                &planar("map", "dock", 100.0 + i as f64 * 0.001, i as f64, 0.0, 0.0),
                false,
            )
            .unwrap();
        }
        let kept = |b: &TfBuffer| match &b.edges["dock"].transforms {
            Transforms::Dynamic(k) => k.iter().map(|(s, _)| *s).collect::<Vec<_>>(),
            Transforms::Static(_) => panic!("static"),
        };
        assert_eq!(kept(&b).len(), MAX_PER_EDGE);
        b.insert(&planar("map", "dock", 120.0, 0.0, 0.0, 0.0), false)
            .unwrap();
        assert_eq!(kept(&b), vec![120.0], "older than CACHE_S before 120 s");
        b.insert(&planar("map", "dock", 115.0, 0.0, 0.0, 0.0), false)
            .unwrap();
        b.insert(&planar("map", "dock", 118.0, 0.0, 0.0, 0.0), false)
            .unwrap();
        assert_eq!(kept(&b), vec![115.0, 118.0, 120.0]);
        b.insert(&planar("map", "dock", 3.0, 0.0, 0.0, 0.0), false)
            .unwrap();
        assert_eq!(kept(&b), vec![3.0]);
        for i in 0..2 * MAX_FRAMES {
            let name: &'static str = Box::leak(format!("f{i}").into_boxed_str());
            let r = b.insert(&planar("map", name, 0.0, 0.0, 0.0, 0.0), true);
            assert_eq!(r.is_ok(), i + 1 < MAX_FRAMES, "frame {i}");
        }
        assert_eq!(b.edges.len(), MAX_FRAMES);
        // A frame already kept still takes new transforms.
        b.insert(&planar("map", "dock", 4.0, 0.0, 0.0, 0.0), false)
            .unwrap();
    }
}
