//! Keepout zones, as Nav2's keepout filter takes them for costmap_2d: a mask
//! (nav_msgs/OccupancyGrid) latched by a filter mask server, laid over the node's own costmap.
//! The mask's topic is given directly (`keepout_mask_topic`) or, as Nav2's KeepoutFilter finds
//! it, named by a nav2_msgs/CostmapFilterInfo latched on `keepout_filter_info_topic` by Nav2's
//! costmap_filter_info_server; a new info moves the node to its mask topic, the last good mask
//! staying in force until the new topic's first mask arrives (as Nav2's filter keeps it).

use crate::convert;
use crate::outputs::Outputs;
use crate::result::{Failure, Outcome, ResultCode};
use crate::state::Shared;
use log::{error, info, warn};
use patrol_msgs::nav2_msgs::CostmapFilterInfo;
use patrol_msgs::nav_msgs::OccupancyGrid;
use ros2_client::{MessageTypeName, Node, Subscription};
use ros_edge::naming::Naming;
use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex};

/// The keepout masks on `topic`: each one checked (a map's bounds and cell cap; in the global
/// frame, as this node has no transform to lay a mask of another frame by) and kept for every
/// grid made from now on; the current grid is made again under it at once, and the path being
/// followed checked against it (`inputs::remake_grid_on_change`): a path through a new keepout
/// zone is planned again. A mask refused is reported on `/diagnostics` and the last good one
/// stays.
pub async fn receive_masks(
    s: Arc<Shared>,
    o: Outputs,
    topic: String,
    sub: Subscription<OccupancyGrid>,
) {
    loop {
        let msg = match sub.async_take().await {
            Ok((msg, _)) => msg,
            Err(e) => {
                warn!("{topic}: {e:?}");
                continue;
            }
        };
        let frame = msg.header.frame_id.clone();
        let global = s.params.global_frame.clone();
        let checked = tokio::task::spawn_blocking(move || {
            if !frame.is_empty() && frame != global {
                return Err(format!(
                    "the mask is in frame `{frame}` and the node plans in `{global}`: publish it in `{global}`"
                ));
            }
            convert::grid_from_msg(&msg).map_err(|e| e.to_string())
        })
        .await;
        match checked {
            Ok(Ok(mask)) => {
                let info = *mask.info();
                *s.keepout.write().expect("lock") = Some(Arc::new(mask));
                info!(
                    "keepout mask from {topic}: {} x {} cells of {:.3} m",
                    info.width, info.height, info.resolution
                );
                s.settings_changed.notify_one();
            }
            Ok(Err(why)) => {
                refuse(
                    &s,
                    &o,
                    format!("keepout mask on {topic} refused, keeping the last good one: {why}"),
                )
                .await
            }
            Err(e) => error!("keepout mask task: {e}"),
        }
    }
}

/// The filter infos on `keepout_filter_info_topic`, as Nav2's KeepoutFilter follows its
/// `filter_info_topic`: each good one (a keepout filter's, naming a valid topic) subscribes the
/// node to its mask topic, latched, in place of the previous one, and its masks are taken as
/// [`receive_masks`] takes them. An info refused (a speed filter's, no topic) is reported on
/// `/diagnostics` and the node stays on the mask topic it had.
pub async fn receive_filter_info(
    s: Arc<Shared>,
    o: Outputs,
    node: Arc<Mutex<Node>>,
    naming: Naming,
    sub: Subscription<CostmapFilterInfo>,
) {
    let info_topic = s.params.keepout_filter_info_topic.clone();
    // The current mask topic's reader and what it does with each mask; none until a good info.
    let mut masks: Pin<Box<dyn Future<Output = ()> + Send>> = Box::pin(std::future::pending());
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
        let subscribed = mask_topic_of(&info).and_then(|topic| {
            if (info.base, info.multiplier) != (0.0, 1.0) {
                // As Nav2's KeepoutFilter: it says so and reads the mask as occupancy anyway.
                warn!(
                    "{info_topic}: a keepout filter reads its mask as occupancy: base {} and multiplier {} are not used (set 0 and 1)",
                    info.base, info.multiplier
                );
            }
            subscribe(&node, &naming, topic)
        });
        match subscribed {
            Ok((topic, reader)) => {
                info!("{info_topic}: keepout masks from {topic}");
                masks = Box::pin(receive_masks(s.clone(), o.clone(), topic, reader));
            }
            Err(why) => {
                refuse(
                    &s,
                    &o,
                    format!(
                        "keepout filter info on {info_topic} refused, keeping the mask topic it had: {why}"
                    ),
                )
                .await
            }
        }
    }
}

/// The mask topic a keepout filter's info names, or why it names none.
fn mask_topic_of(info: &CostmapFilterInfo) -> Result<&str, String> {
    match info.r#type {
        CostmapFilterInfo::KEEPOUT => {}
        CostmapFilterInfo::SPEED_PERCENT | CostmapFilterInfo::SPEED_ABSOLUTE => {
            return Err(format!(
                "type {} is a speed filter's (0 is keepout): speed zones reach the follower as nav2_msgs/SpeedLimit on speed_limit_topic, from Nav2's SpeedFilter",
                info.r#type
            ))
        }
        other => return Err(format!("type {other} is no filter Nav2 knows (0 is keepout)")),
    }
    if info.filter_mask_topic.is_empty() {
        return Err("no filter_mask_topic".into());
    }
    Ok(&info.filter_mask_topic)
}

/// A latched reader of the masks on `topic` (resolved as every name of the node is), as
/// Nav2's filters read a filter mask server's.
fn subscribe(
    node: &Mutex<Node>,
    naming: &Naming,
    topic: &str,
) -> Result<(String, Subscription<OccupancyGrid>), String> {
    let name = naming
        .name(topic)
        .map_err(|e| format!("filter_mask_topic `{topic}`: {e}"))?;
    let latched = ros_edge::reliable(1, ros2_client::qos::Durability::TransientLocal);
    let mut node = node.lock().expect("lock");
    let t = node
        .create_topic(
            &name,
            MessageTypeName::new("nav_msgs", "OccupancyGrid"),
            &latched,
        )
        .map_err(|e| format!("filter_mask_topic `{topic}`: {e:?}"))?;
    let reader = node
        .create_subscription::<OccupancyGrid>(&t, Some(latched))
        .map_err(|e| format!("filter_mask_topic `{topic}`: {e:?}"))?;
    Ok((name.to_string(), reader))
}

/// Reports a refused mask or filter info on `/diagnostics` (the node goes on as it was).
async fn refuse(s: &Shared, o: &Outputs, message: String) {
    let planner = s.live.read().expect("lock").planner;
    let f = Failure::new(ResultCode::InvalidInput, message);
    warn!("{}", f.message);
    o.diagnose(s, &Outcome::failed(planner, 0, f)).await;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(r#type: u8, topic: &str) -> CostmapFilterInfo {
        CostmapFilterInfo {
            r#type,
            filter_mask_topic: topic.into(),
            multiplier: 1.0,
            ..Default::default()
        }
    }

    #[test]
    fn only_a_keepout_filters_info_with_a_topic_names_a_mask() {
        assert_eq!(
            mask_topic_of(&info(0, "/keepout_filter_mask")),
            Ok("/keepout_filter_mask")
        );
        let speed = mask_topic_of(&info(1, "/speed_filter_mask")).unwrap_err();
        assert!(
            speed.contains("speed filter") && speed.contains("SpeedLimit"),
            "{speed}"
        );
        assert!(mask_topic_of(&info(2, "/m"))
            .unwrap_err()
            .contains("speed filter"));
        assert!(mask_topic_of(&info(7, "/m"))
            .unwrap_err()
            .contains("type 7"));
        assert!(mask_topic_of(&info(0, ""))
            .unwrap_err()
            .contains("no filter_mask_topic"));
    }
}
