//! Where the robot is in the map frame, from odometry and map-frame pose estimates, the way a
//! Nav2 stack composes them through TF: `map -> odom` (AMCL's correction) times `odom ->
//! base_link` (the odometry, from `/tf` or `/odom`: `Shared::odometry`).
//!
//! The node keeps `map -> odom` itself, not only as `/tf` last said it (tf_buffer.rs keeps
//! that), because it also localizes from pose estimates: the `map_to_odom` parameter at
//! first, then, with `track_map_to_odom`, re-anchored on every map-frame pose of the robot
//! (`/amcl_pose`, or a user's `/initialpose` from RViz) so that the odometry of that moment maps
//! onto it, exactly the transform AMCL publishes. Between estimates, odometry carries the pose
//! at its own rate, so the follower sees a smooth map-frame pose and the start of a plan is
//! never older than the last odometry.

use nalgebra::{Isometry2, Vector2};
use planner_core::geometry::Pose2;
use std::collections::VecDeque;

/// How much odometry is kept to match a pose estimate's stamp (s).
const HISTORY_S: f64 = 2.0;
/// The most odometry poses kept, whatever their stamps: 2 s of odometry at 500 Hz. Odometry
/// whose stamp never advances (left unset by a driver, or `ros2 topic pub`) is never older than
/// [`HISTORY_S`], and without this cap would be kept for ever and scanned by every estimate.
const HISTORY_LEN: usize = 1_000;

fn iso(p: Pose2) -> Isometry2<f64> {
    Isometry2::new(Vector2::new(p.x, p.y), p.yaw)
}

fn pose(i: &Isometry2<f64>) -> Pose2 {
    Pose2::new(i.translation.x, i.translation.y, i.rotation.angle())
}

/// The `map -> odom` estimate and the recent odometry it is anchored with.
#[derive(Clone, Debug)]
pub struct Localization {
    map_to_odom: Isometry2<f64>,
    track: bool,
    /// (stamp in s, pose in odom), oldest first.
    history: VecDeque<(f64, Isometry2<f64>)>,
}

impl Localization {
    /// Starts from a fixed `map_to_odom`; with `track`, pose estimates re-anchor it.
    pub fn new(map_to_odom: Pose2, track: bool) -> Self {
        Self {
            map_to_odom: iso(map_to_odom),
            track,
            history: VecDeque::new(),
        }
    }

    /// The current `map -> odom` transform, as a pose.
    pub fn map_to_odom(&self) -> Pose2 {
        pose(&self.map_to_odom)
    }

    /// An odometry pose (odom frame) stamped `stamp` (s); returns the robot's map-frame pose.
    pub fn odometry(&mut self, stamp: f64, in_odom: Pose2) -> Pose2 {
        let o = iso(in_odom);
        // Stamps from another clock or going backwards (a restarted bridge) start a new history.
        if self.history.back().is_some_and(|(t, _)| stamp < *t) {
            self.history.clear();
        }
        self.history.push_back((stamp, o));
        while self.history.len() > HISTORY_LEN
            || self
                .history
                .front()
                .is_some_and(|(t, _)| stamp - t > HISTORY_S)
        {
            self.history.pop_front();
        }
        pose(&(self.map_to_odom * o))
    }

    /// A `map -> odom` transform from whoever localizes the robot and says so on `/tf` (AMCL,
    /// slam_toolbox): it replaces the estimate as a TF lookup would. Ignored when not tracking.
    pub fn set_map_to_odom(&mut self, map_to_odom: Pose2) {
        if self.track {
            self.map_to_odom = iso(map_to_odom);
        }
    }

    /// A map-frame pose of the robot at `stamp` (s; 0 for "now", as hand-made messages often
    /// carry). Re-anchors `map -> odom` on the odometry nearest that time and returns the new
    /// transform; `None` when not tracking or no odometry has arrived yet.
    pub fn anchor(&mut self, stamp: f64, in_map: Pose2) -> Option<Pose2> {
        if !self.track {
            return None;
        }
        let odom = if stamp == 0.0 {
            self.history.back()?.1
        } else {
            self.history
                .iter()
                .min_by(|a, b| (a.0 - stamp).abs().total_cmp(&(b.0 - stamp).abs()))?
                .1
        };
        self.map_to_odom = iso(in_map) * odom.inverse();
        Some(self.map_to_odom())
    }
}

/// The frames whose transform to the global frame the node keeps itself, besides the global
/// frame: the two it keeps anyway, `global -> odom` (its `map -> odom` estimate above) and `global -> robot_base_frame`
/// (the robot's current pose). Those cover most of what a Nav2 user sends: RViz's "2D Goal
/// Pose" in its fixed frame (`map`, or `odom` when there is no map localization), and a
/// script's "two metres ahead" in `base_link`. A pose in any other frame reaches one of these
/// through the TF tree (tf_buffer.rs); the node's own transform carries it the rest of the way,
/// so that a goal ahead of the robot and the start of its plan agree on where the robot is.
pub struct KnownFrames<'a> {
    pub global: &'a str,
    pub odom: &'a str,
    pub map_to_odom: Pose2,
    pub base: &'a str,
    /// The robot's pose in the global frame, once one has arrived.
    pub robot: Option<Pose2>,
}

impl KnownFrames<'_> {
    /// Whether `frame` is one of these (an empty frame is the global frame, as Nav2 reads it).
    pub fn knows(&self, frame: &str) -> bool {
        frame.is_empty() || [self.global, self.odom, self.base].contains(&frame)
    }

    /// Their names, for an error that says none was reached.
    pub fn names(&self) -> String {
        format!("`{}`, `{}` or `{}`", self.global, self.odom, self.base)
    }

    /// The pose of `frame`, one of these, in the global frame, or why the node has none yet.
    pub fn in_global(&self, frame: &str) -> Result<Pose2, String> {
        if frame.is_empty() || frame == self.global {
            Ok(Pose2::new(0.0, 0.0, 0.0))
        } else if frame == self.odom {
            Ok(self.map_to_odom)
        } else if frame == self.base {
            self.robot.ok_or_else(|| {
                format!(
                    "pose is in `{frame}` and the robot has no pose in `{}` yet: publish \
                     /initialpose, /amcl_pose or /odom",
                    self.global
                )
            })
        } else {
            Err(format!(
                "frame `{frame}` is none of {}, which the node keeps itself",
                self.names()
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// `a` then `b`: the pose `b`, given in the frame whose pose is `a`, in `a`'s parent frame.
    fn compose(a: Pose2, b: Pose2) -> Pose2 {
        pose(&(iso(a) * iso(b)))
    }

    #[test]
    fn a_pose_in_odom_or_base_link_is_carried_into_the_map() {
        let frames = KnownFrames {
            global: "map",
            odom: "odom",
            map_to_odom: Pose2::new(1.0, 2.0, FRAC_PI_2),
            base: "base_link",
            robot: Some(Pose2::new(5.0, 5.0, -FRAC_PI_2)),
        };
        let ahead = Pose2::new(2.0, 0.0, 0.0);
        let at = |frame| compose(frames.in_global(frame).unwrap(), ahead);
        assert!(close(at("map"), ahead));
        assert!(close(at(""), ahead));
        // odom's x axis is the map's +y: 2 m along it from (1, 2), facing +y.
        assert!(close(at("odom"), Pose2::new(1.0, 4.0, FRAC_PI_2)));
        // The robot faces -y: two metres ahead of it is (5, 3).
        assert!(close(at("base_link"), Pose2::new(5.0, 3.0, -FRAC_PI_2)));
        assert!(["map", "", "odom", "base_link"]
            .iter()
            .all(|f| frames.knows(f)));
        assert!(!frames.knows("camera"));
        let unknown = frames.in_global("camera").unwrap_err();
        assert!(
            unknown.contains("`camera`") && unknown.contains("`odom`"),
            "{unknown}"
        );
        let nowhere = KnownFrames {
            robot: None,
            ..frames
        };
        assert!(nowhere
            .in_global("base_link")
            .unwrap_err()
            .contains("no pose"));
        assert!(nowhere.in_global("odom").is_ok());
    }

    fn close(a: Pose2, b: Pose2) -> bool {
        (a.x - b.x).abs() < 1e-12 && (a.y - b.y).abs() < 1e-12 && (a.yaw - b.yaw).abs() < 1e-12
    }

    /// Odometry stamped 0 again and again (never older than the history's 2 s) is kept up to
    /// the cap, the newest kept.
    #[test]
    fn odometry_that_never_ages_is_kept_to_the_cap() {
        let mut l = Localization::new(Pose2::new(0.0, 0.0, 0.0), true);
        for i in 0..5 * HISTORY_LEN {
            l.odometry(0.0, Pose2::new(i as f64, 0.0, 0.0));
        }
        assert_eq!(l.history.len(), HISTORY_LEN);
        assert_eq!(
            l.history.back().unwrap().1.translation.x,
            (5 * HISTORY_LEN - 1) as f64
        );
    }

    #[test]
    fn a_fixed_transform_until_an_estimate_arrives() {
        let mut l = Localization::new(Pose2::new(1.0, 2.0, FRAC_PI_2), true);
        // odom (1, 0) turned by 90 degrees and shifted: (1, 3).
        assert!(close(
            l.odometry(1.0, Pose2::new(1.0, 0.0, 0.0)),
            Pose2::new(1.0, 3.0, FRAC_PI_2)
        ));
    }

    #[test]
    fn an_estimate_reanchors_and_odometry_carries_on_from_it() {
        let mut l = Localization::new(Pose2::new(0.0, 0.0, 0.0), true);
        l.odometry(10.0, Pose2::new(0.0, 0.0, 0.0));
        // The robot is really at (1, 1) facing +y.
        l.anchor(10.0, Pose2::new(1.0, 1.0, FRAC_PI_2)).unwrap();
        // Half a metre forward in odom is half a metre along +y in the map.
        let p = l.odometry(10.5, Pose2::new(0.5, 0.0, 0.0));
        assert!(close(p, Pose2::new(1.0, 1.5, FRAC_PI_2)), "{p:?}");
    }

    #[test]
    fn the_estimate_is_matched_with_the_odometry_of_its_time() {
        let mut l = Localization::new(Pose2::new(0.0, 0.0, 0.0), true);
        for k in 0..=10 {
            l.odometry(100.0 + 0.1 * k as f64, Pose2::new(0.1 * k as f64, 0.0, 0.0));
        }
        // AMCL says: at t = 100.5 (odom x = 0.5) the robot was at map (3, 0).
        l.anchor(100.5, Pose2::new(3.0, 0.0, 0.0)).unwrap();
        assert!(close(l.map_to_odom(), Pose2::new(2.5, 0.0, 0.0)));
        // A zero stamp means "now": the latest odometry (x = 1.0).
        l.anchor(0.0, Pose2::new(3.0, 0.0, 0.0)).unwrap();
        assert!(close(l.map_to_odom(), Pose2::new(2.0, 0.0, 0.0)));
    }

    #[test]
    fn a_transform_from_tf_replaces_the_estimate_when_tracking() {
        let mut l = Localization::new(Pose2::new(0.0, 0.0, 0.0), true);
        l.odometry(1.0, Pose2::new(0.0, 0.0, 0.0));
        l.anchor(1.0, Pose2::new(5.0, 5.0, 0.0)).unwrap();
        l.set_map_to_odom(Pose2::new(2.0, 1.0, FRAC_PI_2));
        // odom (1, 0) is (2, 2) in the map: turned to +y, then shifted.
        let p = l.odometry(1.1, Pose2::new(1.0, 0.0, 0.0));
        assert!(close(p, Pose2::new(2.0, 2.0, FRAC_PI_2)), "{p:?}");
        let mut fixed = Localization::new(Pose2::new(0.5, 0.0, 0.0), false);
        fixed.set_map_to_odom(Pose2::new(2.0, 1.0, 0.0));
        assert!(close(fixed.map_to_odom(), Pose2::new(0.5, 0.0, 0.0)));
    }

    #[test]
    fn no_anchor_without_odometry_or_tracking() {
        assert!(Localization::new(Pose2::new(0.0, 0.0, 0.0), true)
            .anchor(0.0, Pose2::new(1.0, 1.0, 0.0))
            .is_none());
        let mut fixed = Localization::new(Pose2::new(0.5, 0.0, 0.0), false);
        fixed.odometry(1.0, Pose2::new(0.0, 0.0, 0.0));
        assert!(fixed.anchor(1.0, Pose2::new(9.0, 9.0, 0.0)).is_none());
        assert!(close(fixed.map_to_odom(), Pose2::new(0.5, 0.0, 0.0)));
    }

    #[test]
    fn old_odometry_is_forgotten_and_a_clock_jump_restarts_the_history() {
        let mut l = Localization::new(Pose2::new(0.0, 0.0, 0.0), true);
        for k in 0..100 {
            l.odometry(k as f64 * 0.1, Pose2::new(0.0, 0.0, 0.0));
        }
        assert!(l.history.len() <= 21);
        l.odometry(1.0, Pose2::new(0.0, 0.0, 0.0));
        assert_eq!(l.history.len(), 1);
    }
}
