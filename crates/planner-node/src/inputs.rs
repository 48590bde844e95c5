//! The node's inputs, one task each: maps from `/map`, start poses from `/initialpose`,
//! `/amcl_pose` and the odometry (`odom -> base_link` on `/tf`, else `/odom`), the TF tree and
//! `map -> odom` from `/tf` and `/tf_static`, and goals from
//! `/goal_pose`. Each message is checked on arrival; a bad one is answered on `/diagnostics`
//! (maps, goals) or logged (poses, transforms), and the task goes on.

use crate::convert;
use crate::navigate::NavigateGoal;
use crate::outputs::Outputs;
use crate::planning::install_map;
use crate::result::{Failure, Outcome, ResultCode};
use crate::state::{path_length, GoalRequest, GoalSlot, MapState, OdometrySource, Shared};
use crate::tf_buffer::Stamped;
use chassis::Twist2;
use log::{debug, error, info, log, warn, Level};
use patrol_msgs::geometry_msgs::{PoseStamped, PoseWithCovarianceStamped};
use patrol_msgs::map_msgs::OccupancyGridUpdate;
use patrol_msgs::nav2_msgs::{NavigateToPoseGoal, SpeedLimit};
use patrol_msgs::nav_msgs::{OccupancyGrid, Odometry};
use patrol_msgs::rosgraph_msgs::Clock;
use patrol_msgs::std_msgs::Empty;
use patrol_msgs::tf2_msgs::TFMessage;
use ros2_client::{Gid, Subscription};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Weak};
use std::time::Instant;
use tokio::sync::watch;

/// `/map`: each valid map replaces the current one (also while a plan runs: that plan keeps the
/// map it started with); a malformed one is refused and the last good map kept. While a plan is
/// being followed, the new map is checked against the rest of it: the goal is planned again
/// (through `slot`, as a new goal) only when the map blocks the path, and the path is kept
/// otherwise (Nav2's replanning on an invalid path, navigation2 PR 2841).
///
/// With `updates` (a costmap topic's `<topic>_updates`), each partial update costmap_2d sends
/// between full costmaps is written into the last full costmap accepted, which then replaces the
/// current map as a full one would; an update before any costmap, or outside it, is refused.
///
/// `own` is the node's own `/map` writer (it latches the map it loads from `map_yaml`): DDS
/// delivers that sample back to this subscription, and the map is already installed, so it is
/// skipped rather than converted a second time (at 4000 x 4000 that is 16 M cells and a second
/// of work for nothing).
pub async fn receive_maps(
    s: Arc<Shared>,
    o: Outputs,
    sub: Subscription<OccupancyGrid>,
    updates: Option<Subscription<OccupancyGridUpdate>>,
    slot: watch::Sender<GoalSlot>,
    source: &'static str,
    own: Option<Gid>,
) {
    // The last full costmap accepted, as updates are written into it (with `updates` only).
    let mut last: Option<OccupancyGrid> = None;
    loop {
        let update = async {
            match &updates {
                Some(u) => u.async_take().await,
                None => std::future::pending().await,
            }
        };
        let refuse = |why: String| {
            let f = Failure::new(
                ResultCode::InvalidInput,
                format!("map on {source} refused, keeping the last good one: {why}"),
            );
            let planner = s.live.read().expect("lock").planner;
            (f, planner)
        };
        // A full costmap first: an update waiting beside it belongs to it, not to the one before.
        let (msg, level) = tokio::select! {
            biased;
            taken = sub.async_take() => match taken {
                Ok((_, info)) if own.is_some_and(|g| g == info.publisher_gid()) => {
                    log::debug!("{source}: our own map_yaml sample, already installed");
                    continue;
                }
                Ok((msg, _)) => (msg, Level::Info),
                Err(e) => {
                    warn!("{source}: {e:?}");
                    continue;
                }
            },
            taken = update => match taken {
                Ok((u, _)) => {
                    // Patched on a copy: the last good costmap stays as it is if this fails.
                    let Some(mut costmap) = last.clone() else {
                        warn!("{source}: an update before any full costmap, ignored");
                        continue;
                    };
                    if let Err(why) = convert::apply_update(&mut costmap, &u) {
                        let (f, planner) = refuse(why);
                        o.diagnose(&s, &Outcome::failed(planner, 0, f)).await;
                        continue;
                    }
                    // About once a second with costmap_2d's defaults: not for the info log.
                    (costmap, Level::Debug)
                }
                Err(e) => {
                    warn!("{source} updates: {e:?}");
                    continue;
                }
            },
        };
        let keep = updates.is_some();
        let converted = tokio::task::spawn_blocking(move || {
            let map = convert::grid_from_msg(&msg);
            (map, msg)
        })
        .await;
        match converted {
            Ok((Ok(map), msg)) => {
                if keep {
                    last = Some(msg);
                }
                if let Some(map) = install_map(&s, map, source, level).await {
                    replan_if_blocked(&s, &slot, &map, "the new map", Level::Info);
                }
            }
            Ok((Err(e), _)) => {
                let (f, planner) = refuse(e.to_string());
                o.diagnose(&s, &Outcome::failed(planner, 0, f)).await;
            }
            Err(e) => error!("map task: {e}"),
        }
    }
}

/// After a new map (or a new inflation of it, a new keepout mask: `why`): the part of the
/// followed path still ahead of the robot (from the path point it has come to) is checked
/// against `map` with `is_path_valid`'s rule, once per grid and path
/// ([`Shared::checked_grid`]); if the map blocks it, its goal goes back into the goal slot,
/// with the via poses not yet passed (`navigate_through_poses`), and is planned again from
/// where the robot is. `kept` is the level the log says a free path was kept at.
pub fn replan_if_blocked(
    s: &Shared,
    slot: &watch::Sender<GoalSlot>,
    map: &Arc<MapState>,
    why: &str,
    kept: Level,
) {
    // How far along its path the robot has come (the follower's progress, which only grows,
    // so a path that passes a place twice is judged from the right passage), with the path:
    // both under their locks, in the node's lock order. The goals still ahead are taken again
    // when the replan starts (planning.rs).
    let (nearest, followed) = {
        let follower = s.follower.lock().expect("lock");
        let followed = s.followed.lock().expect("lock");
        (
            follower.as_ref().map_or(0, |f| f.progress()),
            followed.clone(),
        )
    };
    let Some(followed) = followed else {
        return;
    };
    {
        let mut checked = s.checked_grid.lock().expect("lock");
        let this = (Arc::downgrade(map), Arc::downgrade(&followed.path));
        if Weak::ptr_eq(&checked.0, &this.0) && Weak::ptr_eq(&checked.1, &this.1) {
            return;
        }
        *checked = this;
    }
    let path = &followed.path;
    // The robot's own pose may be inside the new map's inflated band; the path ahead must not be.
    let ahead = &path[(nearest + 1).min(path.len())..];
    let invalid = crate::actions::invalid_poses(&map.grid, ahead);
    if let Some(first) = invalid.first() {
        info!(
            "{why} blocks the path being followed ({} of its poses ahead, the first {:.2} m on): replanning",
            invalid.len(),
            path_length(&ahead[..=*first as usize])
        );
        // Planned again for the goal that has the robot, as its own: a drive of an action
        // (drive.rs) goes on watching the new path, and a newer goal is not overridden.
        // Checked under the slot's own lock, so a newer goal sent meanwhile is not overwritten.
        let owner = followed.owner;
        slot.send_if_modified(|v| {
            s.owns_robot(owner) && {
                *v = Some(GoalRequest {
                    owner,
                    goals: followed.goals_ahead(nearest),
                    replaces: Some(path.clone()),
                });
                true
            }
        });
    } else {
        log!(kept, "{why}: the path being followed is still free, kept");
    }
}

/// Makes the planning grid again each time [`Shared::settings_changed`] is told and the costmap
/// parameters, the keepout mask or the obstacles the scans have shown differ from the grid's,
/// so the next plan does not wait for it, then checks the path being followed against the new
/// grid as against a new map: a wider inflation, a new keepout zone or an obstacle seen across
/// it may block it, as a costmap update makes Nav2's IsPathValid fail and its tree replan. Each grid is checked once, also one a plan made again
/// first.
///
/// Each path handed to the follower is checked too, against the grid as it is then: a plan takes
/// its grid when it starts, and a new map, inflation or keepout mask installed while it ran was
/// checked against the path before it, not against this one.
pub async fn remake_grid_on_change(s: Arc<Shared>, slot: watch::Sender<GoalSlot>) {
    loop {
        let (why, kept) = tokio::select! {
            _ = s.settings_changed.notified() => ("the new inflation, keepout mask or obstacles seen", Level::Info),
            _ = s.path_installed.notified() => ("the grid as it is now", Level::Debug),
        };
        if let Some(map) = s.current_map_off_thread().await {
            replan_if_blocked(&s, &slot, &map, why, kept);
        }
    }
}

/// The speed limits on `speed_limit_topic`, as controller_server takes them for its controller
/// (Nav2's speed filter publishes one as the robot enters or leaves a slow zone): in percent of
/// the top speed or in m/s, 0 lifting the limit; the follower drives every plan under the one
/// in force ([`Shared::drive_limits`]), never faster than the chassis' limit. A limit that is
/// not a finite, non-negative number is refused (logged) and the one in force stays.
pub async fn receive_speed_limits(s: Arc<Shared>, sub: Subscription<SpeedLimit>) {
    let topic = s.params.speed_limit_topic.clone();
    loop {
        let Ok((msg, _)) = sub.async_take().await else {
            continue;
        };
        let Some(limit) = speed_cap(&msg, s.params.twist_limits.max_linear) else {
            warn!(
                "{topic}: speed limit {} refused (a finite number, at least 0), the one in force stays",
                msg.speed_limit
            );
            continue;
        };
        let before = std::mem::replace(&mut *s.speed_limit.write().expect("lock"), limit);
        if before != limit {
            match limit {
                Some(v) => info!("{topic}: driving at most {v:.3} m/s"),
                None => info!("{topic}: speed limit lifted"),
            }
        }
    }
}

/// The speed limit a SpeedLimit sets, as Nav2's regulated pure pursuit reads it
/// (`setSpeedLimit`): `Some(None)` for 0 (no limit), else `Some` of the top speed in m/s (a
/// percentage of `max_linear`, or the value); `None` for a value that is not a finite,
/// non-negative number.
pub fn speed_cap(msg: &SpeedLimit, max_linear: f64) -> Option<Option<f64>> {
    let v = msg.speed_limit;
    if !v.is_finite() || v < 0.0 {
        return None;
    }
    Some(if v == 0.0 {
        None
    } else if msg.percentage {
        Some(max_linear * v / 100.0)
    } else {
        Some(v)
    })
}

/// `/initialpose` or `/amcl_pose` (`name`): the start of the next plan, and (with
/// `track_map_to_odom`) the anchor of `map -> odom` for the odometry that follows.
pub async fn receive_start_poses(
    s: Arc<Shared>,
    name: &'static str,
    sub: Subscription<PoseWithCovarianceStamped>,
) {
    loop {
        let Ok((msg, _)) = sub.async_take().await else {
            continue;
        };
        let stamp = convert::seconds(&msg.header.stamp);
        let stamped = PoseStamped {
            header: msg.header,
            pose: msg.pose.pose,
        };
        match convert::pose_in_frame(&stamped, &s.params.global_frame) {
            Ok(p) => {
                *s.start.write().expect("lock") = Some((p, Instant::now()));
                let anchored = s.localization.lock().expect("lock").anchor(stamp, p);
                if let Some(t) = anchored {
                    // AMCL sends one per update: only a user's initial pose is worth a line.
                    let level = if name == "/initialpose" {
                        Level::Info
                    } else {
                        Level::Debug
                    };
                    log!(
                        level,
                        "{name}: map -> odom now ({:.3}, {:.3}, {:.3} rad)",
                        t.x,
                        t.y,
                        t.yaw
                    );
                }
            }
            Err(f) => warn!("{name} ignored: {}", f.message),
        }
    }
}

/// Signals counted as they come (std_msgs/Empty on `topic`): `counter(s)` goes up by one for
/// each, and whoever waits for one compares it with the count when it began waiting. So a
/// patrol waits at a waypoint for the inspection's word (`input_at_waypoint`, Nav2's
/// InputAtWaypoint), and an assisted teleop for the operator's end (`preempt_teleop`).
pub async fn count_signals(
    s: Arc<Shared>,
    topic: String,
    sub: Subscription<Empty>,
    counter: fn(&Shared) -> &AtomicU64,
) {
    loop {
        match sub.async_take().await {
            Ok(_) => {
                counter(&s).fetch_add(1, Ordering::SeqCst);
            }
            Err(e) => warn!("{topic}: {e:?}"),
        }
    }
}

/// The operator's commands for assisted_teleop (`behavior_server.cmd_vel_teleop`): the latest
/// is kept, with when it came, whatever the node is doing (Nav2's behavior server keeps its
/// subscription too).
pub async fn receive_teleop<M>(s: Arc<Shared>, sub: Subscription<M>, twist: fn(&M) -> Twist2)
where
    M: ros2_client::Message + 'static,
{
    loop {
        match sub.async_take().await {
            Ok((msg, _)) => *s.teleop.lock().expect("lock") = Some((twist(&msg), Instant::now())),
            Err(e) => warn!("{}: {e:?}", s.params.behavior_server.cmd_vel_teleop),
        }
    }
}

/// `/clock` (with `use_sim_time`): the simulation's time, which every stamp from now on is.
pub async fn receive_clock(sub: Subscription<Clock>) {
    loop {
        match sub.async_take().await {
            Ok((msg, _)) => ros_edge::set_sim_time(msg.clock),
            Err(e) => warn!("/clock: {e:?}"),
        }
    }
}

/// `/odom`, through the current `map -> odom` (localization.rs): the start of the next plan and
/// the follower's feedback.
pub async fn receive_odometry(s: Arc<Shared>, sub: Subscription<Odometry>) {
    loop {
        let Ok((msg, _)) = sub.async_take().await else {
            continue;
        };
        match convert::pose2(&msg.pose.pose) {
            Ok(p) => {
                s.odometry(
                    OdometrySource::Topic,
                    convert::seconds(&msg.header.stamp),
                    p,
                );
            }
            Err(f) => warn!("/odom ignored: {}", f.message),
        }
    }
}

/// `/tf` or `/tf_static` (`name`): every transform goes into the node's TF buffer
/// (tf_buffer.rs), the frames goals may be stamped in. A `global_frame -> odom_frame` one
/// (AMCL, slam_toolbox, cartographer, a static publisher) also becomes the node's `map -> odom`,
/// as a TF lookup would make it, with `track_map_to_odom`; one that moves `robot_base_frame`
/// in `odom_frame` (`odom -> base_link`, or `odom -> base_footprint` under a static
/// `base_footprint -> base_link`) is odometry, the robot's pose as Nav2 reads it
/// ([`Shared::odometry`]). A refused transform is logged once per child frame, not at the
/// publisher's rate.
pub async fn receive_transforms(s: Arc<Shared>, name: &'static str, sub: Subscription<TFMessage>) {
    let (parent, child) = (s.params.global_frame.as_str(), s.params.odom_frame.as_str());
    let base = s.params.robot_base_frame.as_str();
    let is_static = name.ends_with("_static");
    let mut announced = false;
    let mut refused = std::collections::HashSet::new();
    // The stamp of the last odometry taken from /tf.
    let mut last_odometry = None;
    loop {
        let Ok((msg, _)) = sub.async_take().await else {
            continue;
        };
        {
            let mut tf = s.tf.lock().expect("lock");
            for t in &msg.transforms {
                let (r, v) = (&t.transform.rotation, &t.transform.translation);
                let stamped = Stamped {
                    parent: convert::frame_name(&t.header.frame_id),
                    child: convert::frame_name(&t.child_frame_id),
                    stamp: convert::seconds(&t.header.stamp),
                    translation: [v.x, v.y, v.z],
                    rotation: [r.x, r.y, r.z, r.w],
                };
                if let Err(e) = tf.insert(&stamped, is_static) {
                    // Bounded as the buffer is: one line per frame, for at most as many frames.
                    if refused.len() < crate::tf_buffer::MAX_FRAMES
                        && refused.insert(stamped.child.to_owned())
                    {
                        warn!("{name}: {e}");
                    }
                }
            }
        }
        let ours = msg.transforms.iter().filter(|t| {
            convert::frame_name(&t.header.frame_id) == parent
                && convert::frame_name(&t.child_frame_id) == child
        });
        for t in ours {
            if !s.params.track_map_to_odom {
                break;
            }
            match convert::transform2(&t.transform) {
                Ok(p) => {
                    s.localization.lock().expect("lock").set_map_to_odom(p);
                    // AMCL and SLAM send one per update: only the first is worth a line.
                    let level = if announced { Level::Debug } else { Level::Info };
                    announced = true;
                    log!(
                        level,
                        "{name}: {parent} -> {child} now ({:.3}, {:.3}, {:.3} rad)",
                        p.x,
                        p.y,
                        p.yaw
                    );
                }
                Err(f) => warn!("{name}: {parent} -> {child} ignored: {}", f.message),
            }
        }
        if !is_static {
            odometry_from_tf(&s, &msg, base, child, &mut last_odometry);
        }
    }
}

/// The robot's pose in `odom` from the TF buffer, when `msg` moved one of the frames between
/// `base` and `odom` (a message about other frames, a joint's or a cart's, gives no new
/// odometry, and must not keep an odometry that stopped looking fresh). Looked up at the
/// latest time all those frames reach, as Nav2 looks the robot's pose up at time 0, and taken
/// only when that time is new (`last`: a transform refused, or older than the buffer's newest,
/// moves nothing) and not more than `pose_timeout` behind the newest transform of the chain in
/// `msg` (another link of the chain that stopped would hold the lookup back: Nav2's
/// `getRobotPose` refuses a pose older than its tolerance).
fn odometry_from_tf(s: &Shared, msg: &TFMessage, base: &str, odom: &str, last: &mut Option<f64>) {
    let (latest, newest) = {
        let tf = s.tf.lock().expect("lock");
        let Ok(path) = tf.path_up_to(base, odom) else {
            return;
        };
        let newest = msg
            .transforms
            .iter()
            .filter(|t| path.contains(&convert::frame_name(&t.child_frame_id)))
            .map(|t| convert::seconds(&t.header.stamp))
            .reduce(f64::max);
        let Some(newest) = newest else {
            return;
        };
        (tf.latest_along(&path), newest)
    };
    match latest {
        Ok((t, Some(stamp))) => {
            if *last == Some(stamp) && stamp != 0.0 {
                return;
            }
            if newest - stamp > s.params.pose_timeout {
                debug!(
                    "/tf: `{odom}` -> `{base}` known only up to {stamp:.3} s, {:.3} s behind its \
                     newest link: not taken as odometry",
                    newest - stamp
                );
                return;
            }
            *last = Some(stamp);
            s.odometry(OdometrySource::Tf, stamp, convert::planar(&t));
        }
        // Every edge static: a robot that never moves is no odometry.
        Ok((_, None)) => {}
        Err(e) => debug!("/tf: no odometry from it: {e}"),
    }
}

/// `/goal_pose`: a valid goal is numbered (which cancels a plan still running for an older one)
/// and put in the slot the planning task watches; a bad one is answered at once.
pub async fn receive_goals(
    s: Arc<Shared>,
    o: Outputs,
    sub: Subscription<PoseStamped>,
    slot: watch::Sender<GoalSlot>,
) {
    loop {
        let Ok((msg, _)) = sub.async_take().await else {
            continue;
        };
        // bt_navigator hands a /goal_pose to its navigate_to_pose navigator: it preempts a
        // navigate_to_pose goal and is refused while navigate_through_poses drives.
        let owner = s.pose_in_global(&msg).await.and_then(|goal| {
            let owner = s.take_robot_as(NavigateToPoseGoal::NAME).map_err(|other| {
                Failure::new(
                    ResultCode::Busy,
                    format!(
                        "/goal_pose refused: {other} is navigating: one navigation at a time, \
                         as bt_navigator; cancel it first"
                    ),
                )
            })?;
            Ok((owner, goal))
        });
        match owner {
            Ok((owner, goal)) => {
                // Fails only when the planning task has ended, i.e. during shutdown.
                let _ = slot.send(Some(GoalRequest {
                    owner,
                    goals: vec![goal],
                    replaces: None,
                }));
            }
            // Logged with the rest of the answers, by diagnose.
            Err(f) => {
                let planner = s.live.read().expect("lock").planner;
                o.diagnose(&s, &Outcome::failed(planner, 0, f)).await
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nav2's reading of a SpeedLimit: 0 lifts the limit, a percentage is of the top speed, an
    /// absolute value is m/s; NaN, infinities and negative values are refused.
    #[test]
    fn speed_limits_read_as_nav2s_controller_reads_them() {
        let limit = |percentage, speed_limit| SpeedLimit {
            percentage,
            speed_limit,
            ..SpeedLimit::default()
        };
        assert_eq!(speed_cap(&limit(true, 0.0), 0.6), Some(None));
        assert_eq!(speed_cap(&limit(false, 0.0), 0.6), Some(None));
        assert_eq!(speed_cap(&limit(true, 50.0), 0.6), Some(Some(0.3)));
        assert_eq!(speed_cap(&limit(false, 0.25), 0.6), Some(Some(0.25)));
        for bad in [f64::NAN, f64::INFINITY, -1.0] {
            assert_eq!(speed_cap(&limit(true, bad), 0.6), None, "{bad}");
        }
    }
}
