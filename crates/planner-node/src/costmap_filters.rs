//! Nav2's costmap filters for the node's own costmap and drive: keepout, speed and binary
//! zones.
//!
//! - Keepout (Nav2's KeepoutFilter): a mask (nav_msgs/OccupancyGrid) latched by a filter mask
//!   server is laid over the grid the node plans on (`keepout_mask_topic`, or the topic named
//!   by `keepout_filter_info_topic`'s info).
//! - Speed (Nav2's SpeedFilter, with `follow_plan`): the mask cell under the robot, through
//!   the info's `base + value * multiplier`, is the speed limit the follower drives under, in
//!   percent of the top speed or in m/s, as a SpeedLimit on `speed_limit_topic` would set it.
//! - Binary (Nav2's BinaryFilter, `binary_filter`): the mask cell under the robot, through the
//!   info's `base + value * multiplier`, switches a state (std_msgs/Bool on
//!   `binary_filter.binary_state_topic`) when it passes `flip_threshold`.
//!
//! As Nav2's filters, the node finds a mask through a nav2_msgs/CostmapFilterInfo latched by
//! costmap_filter_info_server: a new info moves the node to its mask topic, and the last good
//! mask stays in force until the new topic's first mask arrives.

use crate::convert;
use crate::inputs::speed_cap;
use crate::outputs::Outputs;
use crate::result::{Failure, Outcome, ResultCode};
use crate::state::Shared;
use log::{debug, error, info, warn};
use patrol_msgs::nav2_msgs::{CostmapFilterInfo, SpeedLimit};
use patrol_msgs::nav_msgs::OccupancyGrid;
use patrol_msgs::std_msgs::Bool;
use planner_core::geometry::Point2;
use planner_core::grid::GridMap;
use ros2_client::{MessageTypeName, Name, Node, Publisher, Subscription};
use ros_edge::naming::Naming;
use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex, RwLock};
use std::time::Duration;

/// The filters the node runs, each as its Nav2 namesake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Keepout,
    Speed,
    Binary,
}

impl Filter {
    fn name(self) -> &'static str {
        match self {
            Filter::Keepout => "keepout",
            Filter::Speed => "speed",
            Filter::Binary => "binary",
        }
    }

    /// The parameter that names this filter's info topic, for messages.
    fn info_parameter(self) -> &'static str {
        match self {
            Filter::Keepout => "keepout_filter_info_topic",
            Filter::Speed => "speed_filter_info_topic",
            Filter::Binary => "binary_filter.filter_info_topic",
        }
    }

    /// The filter of an info's type, as Nav2's CostmapFilterInfo numbers them.
    fn of_type(info_type: u8) -> Option<Filter> {
        match info_type {
            CostmapFilterInfo::KEEPOUT => Some(Filter::Keepout),
            CostmapFilterInfo::SPEED_PERCENT | CostmapFilterInfo::SPEED_ABSOLUTE => {
                Some(Filter::Speed)
            }
            CostmapFilterInfo::BINARY => Some(Filter::Binary),
            _ => None,
        }
    }

    /// Where this filter's zones are kept: none for keepout, whose mask goes into the grid.
    fn zones(self, s: &Shared) -> Option<&RwLock<Zones>> {
        match self {
            Filter::Keepout => None,
            Filter::Speed => Some(&s.speed_zones),
            Filter::Binary => Some(&s.binary_zones),
        }
    }
}

/// How a zone mask's values read, from its filter info.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// A speed mask's limits (info types 1 and 2).
    Speed(SpeedConversion),
    /// A binary mask's filter values (info type 3), `base + value * multiplier`.
    Binary { base: f64, multiplier: f64 },
}

/// How a speed mask's values read as limits: Nav2's SpeedFilter's `base + value * multiplier`,
/// in percent of the top speed (info type 1) or in m/s (type 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedConversion {
    pub percentage: bool,
    pub base: f64,
    pub multiplier: f64,
}

impl SpeedConversion {
    /// The speed limit of a mask value as Nav2's SpeedFilter gives it (`getSpeedLimitAtPose`):
    /// 0 no limit (a SpeedLimit of 0), -1 (unknown) none at all (the limit in force stays),
    /// otherwise `base + value * multiplier`, where a percentage outside 0..=100 or a negative
    /// speed is no limit.
    pub fn limit(&self, value: i8) -> Option<SpeedLimit> {
        let speed_limit = match value {
            0 => 0.0,
            -1 => return None,
            v => {
                let limit = f64::from(v) * self.multiplier + self.base;
                let out_of_range = if self.percentage {
                    !(0.0..=100.0).contains(&limit)
                } else {
                    limit < 0.0
                };
                if out_of_range || !limit.is_finite() {
                    0.0
                } else {
                    limit
                }
            }
        };
        Some(SpeedLimit {
            percentage: self.percentage,
            speed_limit,
            ..Default::default()
        })
    }
}

/// The speed or binary zones in force: the last good mask and how it reads, and how the next
/// mask will read when the info moved to another topic (the old mask is not read in the new
/// topic's units: the new scale goes into force with the new topic's first mask).
#[derive(Default)]
pub struct Zones {
    pub reading: Option<Reading>,
    pub pending: Option<Reading>,
    pub mask: Option<Arc<GridMap>>,
}

/// The masks of `filter` on `topic`: each one checked (a map's bounds and cell cap; a mask in
/// another frame placed in the global frame through TF, its frame's latest transform, and
/// tried again every [`PLACE_RETRY`] while TF cannot place it) and put in force. A keepout
/// mask is kept for every grid made from now on; the current grid is made
/// again under it at once, and the path being followed checked against it
/// (`inputs::remake_grid_on_change`): a path through a new keepout zone is planned again. A
/// speed or binary mask is read at the robot's pose from the next control tick
/// ([`limit_speed_in_zones`], [`switch_in_zones`]).
/// A mask refused is reported on `/diagnostics` and the last good one stays.
pub async fn receive_masks(
    s: Arc<Shared>,
    o: Outputs,
    filter: Filter,
    topic: String,
    sub: Subscription<OccupancyGrid>,
) {
    let kind = filter.name();
    // A mask whose frame TF could not place yet (a latched mask that came before its frame's
    // transform), tried again every PLACE_RETRY until it is placed or a newer mask comes.
    let mut unplaced: Option<OccupancyGrid> = None;
    loop {
        let retrying = unplaced.is_some();
        let msg = tokio::select! {
            taken = sub.async_take() => match taken {
                Ok((msg, _)) => msg,
                Err(e) => {
                    warn!("{topic}: {e:?}");
                    continue;
                }
            },
            () = tokio::time::sleep(PLACE_RETRY), if retrying => match unplaced.take() {
                Some(msg) => msg,
                None => continue,
            },
        };
        // A mask in another frame (a docking station's, a floor's) is placed in the global
        // frame through TF, with the latest transform, as Nav2's filters look theirs up.
        let frame = msg.header.frame_id.clone();
        let placed = if frame.is_empty() || frame == s.params.global_frame {
            None
        } else {
            match s.frame_in_global(&frame, 0.0).await {
                Ok(at) => Some(at),
                Err(f) => {
                    let was_retry = retrying && unplaced.is_none();
                    unplaced = Some(msg);
                    // Reported once per mask, not at every retry.
                    if !was_retry {
                        let why = format!(
                            "{kind} mask on {topic} not placed yet, keeping the last good one \
                             and trying again every {} s: the mask's frame: {}",
                            PLACE_RETRY.as_secs_f64(),
                            f.message
                        );
                        refuse(&s, &o, why).await;
                    }
                    continue;
                }
            }
        };
        let checked = tokio::task::spawn_blocking(move || {
            let mask = convert::grid_from_msg(&msg).map_err(|e| e.to_string())?;
            match placed {
                None => Ok(mask),
                Some(at) => {
                    let origin = convert::iso3(mask.info().origin);
                    mask.placed_at(convert::planar(&(at * origin)))
                        .map_err(|e| e.to_string())
                }
            }
        })
        .await;
        match checked {
            Ok(Ok(mask)) => {
                let info = *mask.info();
                let mask = Some(Arc::new(mask));
                match filter.zones(&s) {
                    None => *s.keepout.write().expect("lock") = mask,
                    Some(zones) => {
                        let mut zones = zones.write().expect("lock");
                        zones.mask = mask;
                        // A new topic's first mask brings its info's scale with it.
                        if let Some(reading) = zones.pending.take() {
                            zones.reading = Some(reading);
                        }
                    }
                }
                info!(
                    "{kind} mask from {topic}: {} x {} cells of {:.3} m from ({:.3}, {:.3}, {:.3} rad)",
                    info.width,
                    info.height,
                    info.resolution,
                    info.origin.x,
                    info.origin.y,
                    info.origin.yaw
                );
                if filter == Filter::Keepout {
                    s.settings_changed.notify_one();
                }
            }
            Ok(Err(why)) => {
                refuse(
                    &s,
                    &o,
                    format!("{kind} mask on {topic} refused, keeping the last good one: {why}"),
                )
                .await
            }
            Err(e) => error!("{kind} mask task: {e}"),
        }
    }
}

/// How often a mask whose frame TF cannot place yet is tried again.
const PLACE_RETRY: std::time::Duration = std::time::Duration::from_secs(1);

/// How many mask readers one filter makes over the node's life. ros2-client keeps a dropped
/// reader's id in the node's discovery announcements for good, so a publisher switching its
/// info between topics without end would grow them without end; a real stack switches a few
/// times (a floor changed, a mask server restarted elsewhere).
const MAX_MASK_READERS: usize = 64;

/// The filter infos of `filter` on `info_topic`, as Nav2's filters follow their
/// `filter_info_topic`: each good one (of this filter's kind, naming a valid topic) subscribes
/// the node to its mask topic, latched, in place of the previous one, and its masks are taken
/// by [`receive_masks`]; the last good mask stays in force until the new topic's first. A
/// speed or binary filter's info says how its mask reads ([`Zones`]): at once for the mask in
/// force when the topic is the same (the same mask server, rescaled: its reader goes on), else
/// with the new topic's first mask. An info refused (another filter's, no topic, past
/// [`MAX_MASK_READERS`]) is reported on `/diagnostics` and the node stays on the mask topic it
/// had.
pub async fn receive_filter_info(
    s: Arc<Shared>,
    o: Outputs,
    node: Arc<Mutex<Node>>,
    naming: Naming,
    filter: Filter,
    info_topic: String,
    sub: Subscription<CostmapFilterInfo>,
) {
    let kind = filter.name();
    // The current mask topic's reader and what it does with each mask; none until a good info.
    let mut masks: Pin<Box<dyn Future<Output = ()> + Send>> = Box::pin(std::future::pending());
    // The info in force and the topic it names (resolved).
    let mut in_force: Option<(CostmapFilterInfo, String)> = None;
    let mut readers_made = 0;
    loop {
        let msg = tokio::select! {
            taken = sub.async_take() => taken,
            () = &mut masks => continue,
        };
        let info = match msg {
            Ok((info, _)) => info,
            Err(e) => {
                warn!("{info_topic}: {e:?}");
                continue;
            }
        };
        // The same info again (an info server restarted, a flood of them): nothing to do.
        if in_force
            .as_ref()
            .is_some_and(|(old, _)| same_filter(old, &info))
        {
            debug!("{info_topic}: the info in force again");
            continue;
        }
        let named = read_info(&info, filter).and_then(|(topic, reading)| {
            let name = naming
                .name(topic)
                .map_err(|e| format!("filter_mask_topic `{topic}`: {e}"))?;
            Ok((name, reading))
        });
        let (name, reading) = match named {
            Ok(named) => named,
            Err(why) => {
                refuse_info(&s, &o, kind, &info_topic, why).await;
                continue;
            }
        };
        if filter == Filter::Keepout && (info.base, info.multiplier) != (0.0, 1.0) {
            // As Nav2's KeepoutFilter: it says so and reads the mask as occupancy anyway.
            warn!(
                "{info_topic}: a keepout filter reads its mask as occupancy: base {} and multiplier {} are not used (set 0 and 1)",
                info.base, info.multiplier
            );
        }
        let topic = name.to_string();
        if in_force.as_ref().is_some_and(|(_, old)| *old == topic) {
            // The same topic, rescaled: its reader goes on (a mask it is taking in is not
            // lost), and the new scale applies to the mask in force at once (or, while the
            // topic's first mask is awaited, to that one).
            if let (Some(reading), Some(zones)) = (reading, filter.zones(&s)) {
                let mut zones = zones.write().expect("lock");
                if zones.pending.is_some() {
                    zones.pending = Some(reading);
                } else {
                    zones.reading = Some(reading);
                }
            }
            info!("{info_topic}: the {kind} mask on {topic} read anew");
            in_force = Some((info, topic));
            continue;
        }
        if readers_made >= MAX_MASK_READERS {
            let why = format!(
                "the mask topic has changed {MAX_MASK_READERS} times, the most one node follows: restart the node"
            );
            refuse_info(&s, &o, kind, &info_topic, why).await;
            continue;
        }
        // Creating a reader is a blocking DDS call (and a discovery announcement).
        let (node, made) = (node.clone(), topic.clone());
        let reader = tokio::task::spawn_blocking(move || subscribe(&node, &name, &made))
            .await
            .unwrap_or_else(|e| Err(format!("the subscribing task failed: {e}")));
        let reader = match reader {
            Ok(reader) => reader,
            Err(why) => {
                refuse_info(&s, &o, kind, &info_topic, why).await;
                continue;
            }
        };
        readers_made += 1;
        if let (Some(reading), Some(zones)) = (reading, filter.zones(&s)) {
            zones.write().expect("lock").pending = Some(reading);
        }
        info!("{info_topic}: {kind} masks from {topic}");
        masks = Box::pin(receive_masks(
            s.clone(),
            o.clone(),
            filter,
            topic.clone(),
            reader,
        ));
        in_force = Some((info, topic));
    }
}

/// The robot's pose (latest `/odom`, in the global frame) at each tick of the control rate
/// that has fresh odometry: where the speed and binary filters read their masks, as Nav2's
/// filters read theirs at the costmap's robot pose. A tick without fresh odometry is passed
/// over (the filter's state stays), and so are ticks missed while the task was late.
struct RobotPoses {
    ticker: tokio::time::Interval,
}

impl RobotPoses {
    fn new(s: &Shared) -> Self {
        let mut ticker =
            tokio::time::interval(Duration::from_secs_f64(1.0 / s.params.control_rate_hz));
        ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        Self { ticker }
    }

    async fn next(&mut self, s: &Shared) -> planner_core::geometry::Pose2 {
        loop {
            self.ticker.tick().await;
            if let Some(pose) = s.fresh_odom() {
                return pose;
            }
        }
    }
}

/// The speed filter at work, as Nav2's SpeedFilter runs in its costmap's update: at the
/// follower's rate, the speed mask's cell under the robot (latest `/odom`) is read as a limit;
/// when the limit read changes it is put in force as a SpeedLimit on `speed_limit_topic`
/// would be, so the latest of the two wins, as in controller_server. Off the mask, on an
/// unknown cell or without fresh odometry, the limit in force stays.
pub async fn limit_speed_in_zones(s: Arc<Shared>) {
    let mut poses = RobotPoses::new(&s);
    // The limit this filter last put in force; at first none, as Nav2's SpeedFilter starts
    // (so a robot starting off every zone leaves a limit sent on `speed_limit_topic` alone).
    let mut last: Option<f64> = None;
    loop {
        let pose = poses.next(&s).await;
        let read = {
            let zones = s.speed_zones.read().expect("lock");
            let (Some(Reading::Speed(conversion)), Some(mask)) =
                (zones.reading, zones.mask.as_ref())
            else {
                continue;
            };
            speed_limit_at(mask, conversion, Point2::new(pose.x, pose.y))
        };
        let Some(cap) = read.and_then(|msg| speed_cap(&msg, s.params.twist_limits.max_linear))
        else {
            continue;
        };
        if last != cap {
            last = cap;
            *s.speed_limit.write().expect("lock") = cap;
            match cap {
                Some(v) => info!("speed zone: driving at most {v:.3} m/s"),
                None => info!("speed zone: no limit here"),
            }
        }
    }
}

/// The speed limit of the mask's cell under `at`, if `at` is on the mask and the cell known.
fn speed_limit_at(mask: &GridMap, conversion: SpeedConversion, at: Point2) -> Option<SpeedLimit> {
    let cell = mask.info().world_to_cell(at)?;
    conversion.limit(mask.value(cell))
}

/// The binary filter at work, as Nav2's BinaryFilter runs in its costmap's update: at the
/// node's control rate, the binary mask's cell under the robot (latest `/odom`) is read as
/// `base + value * multiplier`; above `flip_threshold` the state is the opposite of
/// `default_state`, else `default_state`, and so it is off the mask. An unknown cell, or no
/// fresh odometry, leaves the state as it is. The state goes out at start, as Nav2's filter
/// starts, and then on each change only (Nav2 publishes the default again on every update
/// while the robot is off the mask; the topic is latched, so a node started later reads the
/// state in force either way).
pub async fn switch_in_zones(s: Arc<Shared>, state_pub: Publisher<Bool>, topic: String) {
    let params = s.params.binary_filter.clone();
    let mut state = params.default_state;
    publish_state(&state_pub, &topic, state).await;
    info!(
        "binary filter: its state on {topic}, {} at start",
        on_off(state)
    );
    let mut poses = RobotPoses::new(&s);
    loop {
        let pose = poses.next(&s).await;
        let read = {
            let zones = s.binary_zones.read().expect("lock");
            let (Some(Reading::Binary { base, multiplier }), Some(mask)) =
                (zones.reading, zones.mask.as_ref())
            else {
                continue;
            };
            let under = filter_value_at(mask, base, multiplier, Point2::new(pose.x, pose.y));
            binary_state(under, params.flip_threshold, params.default_state)
        };
        if let Some(next) = read {
            if next != state {
                state = next;
                publish_state(&state_pub, &topic, state).await;
                info!("binary filter: switched {}", on_off(state));
            }
        }
    }
}

async fn publish_state(publisher: &Publisher<Bool>, topic: &str, state: bool) {
    if let Err(e) = publisher.async_publish(Bool { data: state }).await {
        warn!("{topic}: {e:?}");
    }
}

fn on_off(state: bool) -> &'static str {
    if state {
        "on"
    } else {
        "off"
    }
}

/// What a binary mask says where the robot is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum UnderRobot {
    /// The robot is off the mask.
    OffMask,
    /// The cell is unknown (-1).
    Unknown,
    /// The cell's filter value, `base + value * multiplier`.
    Value(f64),
}

/// What the binary mask says at `at`, its values read through `base` and `multiplier`.
fn filter_value_at(mask: &GridMap, base: f64, multiplier: f64, at: Point2) -> UnderRobot {
    match mask.info().world_to_cell(at).map(|cell| mask.value(cell)) {
        None => UnderRobot::OffMask,
        Some(-1) => UnderRobot::Unknown,
        Some(v) => UnderRobot::Value(base + f64::from(v) * multiplier),
    }
}

/// The state Nav2's BinaryFilter puts in force for what the mask says under the robot: the
/// default off the mask, the opposite above the threshold; none (the state stays) on an
/// unknown cell.
fn binary_state(under: UnderRobot, flip_threshold: f64, default_state: bool) -> Option<bool> {
    match under {
        UnderRobot::OffMask => Some(default_state),
        UnderRobot::Unknown => None,
        UnderRobot::Value(v) => Some(if v > flip_threshold {
            !default_state
        } else {
            default_state
        }),
    }
}

/// Whether two infos describe the same filter (their stamps aside).
fn same_filter(a: &CostmapFilterInfo, b: &CostmapFilterInfo) -> bool {
    (a.r#type, &a.filter_mask_topic, a.base, a.multiplier)
        == (b.r#type, &b.filter_mask_topic, b.base, b.multiplier)
}

/// The mask topic `filter`'s info names, with (a speed or binary filter's) how its mask
/// reads, or why the info is none of `filter`'s.
fn read_info(info: &CostmapFilterInfo, filter: Filter) -> Result<(&str, Option<Reading>), String> {
    let Some(of_type) = Filter::of_type(info.r#type) else {
        return Err(format!("type {} is no filter Nav2 knows", info.r#type));
    };
    if of_type != filter {
        return Err(format!(
            "type {} is a {} filter's: give it to {}",
            info.r#type,
            of_type.name(),
            of_type.info_parameter()
        ));
    }
    if filter != Filter::Keepout && !(info.base.is_finite() && info.multiplier.is_finite()) {
        return Err(format!(
            "base {} and multiplier {} must be finite",
            info.base, info.multiplier
        ));
    }
    let (base, multiplier) = (f64::from(info.base), f64::from(info.multiplier));
    let reading = match filter {
        Filter::Keepout => None,
        Filter::Speed => Some(Reading::Speed(SpeedConversion {
            percentage: info.r#type == CostmapFilterInfo::SPEED_PERCENT,
            base,
            multiplier,
        })),
        Filter::Binary => Some(Reading::Binary { base, multiplier }),
    };
    if info.filter_mask_topic.is_empty() {
        return Err("no filter_mask_topic".into());
    }
    Ok((&info.filter_mask_topic, reading))
}

/// A latched reader of the masks on `name` (resolved as every name of the node is), as
/// Nav2's filters read a filter mask server's.
fn subscribe(
    node: &Mutex<Node>,
    name: &Name,
    topic: &str,
) -> Result<Subscription<OccupancyGrid>, String> {
    let latched = ros_edge::reliable(1, ros2_client::qos::Durability::TransientLocal);
    let mut node = node.lock().expect("lock");
    let t = node
        .create_topic(
            name,
            MessageTypeName::new("nav_msgs", "OccupancyGrid"),
            &latched,
        )
        .map_err(|e| format!("filter_mask_topic `{topic}`: {e:?}"))?;
    node.create_subscription::<OccupancyGrid>(&t, Some(latched))
        .map_err(|e| format!("filter_mask_topic `{topic}`: {e:?}"))
}

/// Reports a refused filter info on `/diagnostics`: the node stays on the mask topic it had.
async fn refuse_info(s: &Shared, o: &Outputs, kind: &str, info_topic: &str, why: String) {
    let message =
        format!("{kind} filter info on {info_topic} refused, keeping the mask topic it had: {why}");
    refuse(s, o, message).await
}

/// Reports a refused mask or filter info on `/diagnostics`, which logs it too (the node goes
/// on as it was).
async fn refuse(s: &Shared, o: &Outputs, message: String) {
    let planner = s.live.read().expect("lock").planner;
    let f = Failure::new(ResultCode::InvalidInput, message);
    o.diagnose(s, &Outcome::failed(planner, 0, f)).await;
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner_core::geometry::Pose2;
    use planner_core::grid::MapInfo;

    /// A 4 x 1 mask of 0.5 m cells from x = 1 m to 3 m, along y 0 to 0.5 m.
    fn strip_mask(values: [i8; 4]) -> GridMap {
        let info = MapInfo {
            resolution: 0.5,
            width: 4,
            height: 1,
            origin: Pose2 {
                x: 1.0,
                y: 0.0,
                yaw: 0.0,
            },
        };
        GridMap::new(info, values.to_vec()).unwrap()
    }

    fn info(r#type: u8, topic: &str, base: f32, multiplier: f32) -> CostmapFilterInfo {
        CostmapFilterInfo {
            r#type,
            filter_mask_topic: topic.into(),
            base,
            multiplier,
            ..Default::default()
        }
    }

    #[test]
    fn only_an_info_of_the_filters_own_kind_with_a_topic_names_a_mask() {
        let keepout = info(0, "/keepout_filter_mask", 0.0, 1.0);
        assert_eq!(
            read_info(&keepout, Filter::Keepout),
            Ok(("/keepout_filter_mask", None))
        );
        let speed = info(1, "/speed_filter_mask", 100.0, -1.0);
        let err = read_info(&speed, Filter::Keepout).unwrap_err();
        assert!(
            err.contains("speed filter") && err.contains("speed_filter_info_topic"),
            "{err}"
        );
        assert_eq!(
            read_info(&speed, Filter::Speed),
            Ok((
                "/speed_filter_mask",
                Some(Reading::Speed(SpeedConversion {
                    percentage: true,
                    base: 100.0,
                    multiplier: -1.0
                }))
            ))
        );
        let absolute = info(2, "/m", 0.0, 0.01);
        assert!(matches!(
            read_info(&absolute, Filter::Speed),
            Ok((
                _,
                Some(Reading::Speed(SpeedConversion {
                    percentage: false,
                    ..
                }))
            ))
        ));
        let binary = info(3, "/binary_filter_mask", 0.0, 1.0);
        assert_eq!(
            read_info(&binary, Filter::Binary),
            Ok((
                "/binary_filter_mask",
                Some(Reading::Binary {
                    base: 0.0,
                    multiplier: 1.0
                })
            ))
        );
        for other in [Filter::Keepout, Filter::Speed] {
            let err = read_info(&binary, other).unwrap_err();
            assert!(
                err.contains("binary filter") && err.contains("binary_filter.filter_info_topic"),
                "{err}"
            );
        }
        assert!(read_info(&speed, Filter::Binary)
            .unwrap_err()
            .contains("speed_filter_info_topic"));
        assert!(
            read_info(&info(3, "/m", 0.0, f32::INFINITY), Filter::Binary)
                .unwrap_err()
                .contains("finite")
        );
        assert!(read_info(&keepout, Filter::Speed)
            .unwrap_err()
            .contains("keepout_filter_info_topic"));
        assert!(read_info(&info(7, "/m", 0.0, 1.0), Filter::Keepout)
            .unwrap_err()
            .contains("type 7"));
        assert!(read_info(&info(0, "", 0.0, 1.0), Filter::Keepout)
            .unwrap_err()
            .contains("no filter_mask_topic"));
        assert!(read_info(&info(1, "/m", f32::NAN, 1.0), Filter::Speed)
            .unwrap_err()
            .contains("finite"));
    }

    #[test]
    fn an_info_again_with_another_stamp_is_the_same_filter() {
        let a = info(1, "/speed_filter_mask", 0.0, 1.0);
        let mut again = a.clone();
        again.header.stamp.sec = 9;
        assert!(same_filter(&a, &again));
        for other in [
            info(2, "/speed_filter_mask", 0.0, 1.0),
            info(1, "/other_mask", 0.0, 1.0),
            info(1, "/speed_filter_mask", 5.0, 1.0),
            info(1, "/speed_filter_mask", 0.0, 2.0),
        ] {
            assert!(!same_filter(&a, &other), "{other:?}");
        }
    }

    #[test]
    fn a_speed_mask_reads_as_nav2s_speed_filter_reads_it() {
        // Nav2's speed_filter_params example: percent, base 100, multiplier -1 (mask 40 -> 60 %).
        let percent = SpeedConversion {
            percentage: true,
            base: 100.0,
            multiplier: -1.0,
        };
        let limit = |c: SpeedConversion, v| c.limit(v).map(|m| (m.percentage, m.speed_limit));
        assert_eq!(limit(percent, 40), Some((true, 60.0)));
        assert_eq!(limit(percent, 0), Some((true, 0.0)), "0: no limit");
        assert_eq!(
            limit(percent, -1),
            None,
            "unknown: the limit in force stays"
        );
        let doubled = SpeedConversion {
            multiplier: 2.0,
            base: 0.0,
            ..percent
        };
        assert_eq!(
            limit(doubled, 60),
            Some((true, 0.0)),
            "120 %: out of range, no limit"
        );
        let absolute = SpeedConversion {
            percentage: false,
            base: 0.0,
            multiplier: 0.01,
        };
        assert_eq!(limit(absolute, 30), Some((false, 0.3)));
        let negative = SpeedConversion {
            base: -1.0,
            ..absolute
        };
        assert_eq!(
            limit(negative, 30),
            Some((false, 0.0)),
            "below 0 m/s: no limit"
        );
    }

    #[test]
    fn the_speed_limit_is_the_masks_cell_under_the_robot() {
        // Free, 50, unknown, 20.
        let mask = strip_mask([0, 50, -1, 20]);
        let percent = SpeedConversion {
            percentage: true,
            base: 0.0,
            multiplier: 1.0,
        };
        let at = |x| speed_limit_at(&mask, percent, Point2::new(x, 0.25)).map(|m| m.speed_limit);
        assert_eq!(at(1.2), Some(0.0));
        assert_eq!(at(1.7), Some(50.0));
        assert_eq!(at(2.2), None, "unknown cell");
        assert_eq!(at(2.7), Some(20.0));
        assert_eq!(at(0.5), None, "off the mask");
        assert_eq!(at(3.2), None, "off the mask");
    }

    #[test]
    fn the_binary_state_flips_above_the_threshold_as_nav2s_binary_filter() {
        // Free, 100, unknown, 50.
        let mask = strip_mask([0, 100, -1, 50]);
        let under = |x| filter_value_at(&mask, 0.0, 1.0, Point2::new(x, 0.25));
        assert_eq!(under(1.2), UnderRobot::Value(0.0));
        assert_eq!(under(1.7), UnderRobot::Value(100.0));
        assert_eq!(under(2.2), UnderRobot::Unknown);
        assert_eq!(under(0.5), UnderRobot::OffMask);
        assert_eq!(
            filter_value_at(&mask, 10.0, -0.5, Point2::new(1.7, 0.25)),
            UnderRobot::Value(-40.0),
            "base + value * multiplier"
        );
        // Nav2's default: off by default, on above 50 (strictly: 50 itself stays off).
        let state = |x| binary_state(under(x), 50.0, false);
        assert_eq!(state(1.2), Some(false));
        assert_eq!(state(1.7), Some(true));
        assert_eq!(state(2.7), Some(false), "50 is not above 50");
        assert_eq!(state(2.2), None, "unknown: the state stays");
        assert_eq!(state(0.5), Some(false), "off the mask: the default");
        // On by default: the zone switches it off, and off the mask it is on again.
        assert_eq!(binary_state(under(1.7), 50.0, true), Some(false));
        assert_eq!(binary_state(under(3.5), 50.0, true), Some(true));
    }
}
