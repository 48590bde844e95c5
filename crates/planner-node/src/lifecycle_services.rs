//! The lifecycle services and topic of a managed node, on the node's own names (`~/change_state`,
//! `~/get_state`, `~/get_available_states`, `~/get_available_transitions`,
//! `~/get_transition_graph`, `~/transition_event`), as rclcpp_lifecycle offers them, and the
//! bond heartbeat Nav2's lifecycle manager watches.
//!
//! The state machine itself is [`crate::lifecycle`]; this module is its ROS face.

use crate::lifecycle::{State, Transition};
use crate::state::Shared;
use log::{info, warn};
use patrol_msgs::lifecycle_msgs::*;
use ros2_client::Publisher;
use ros_edge::service::ServiceServer;
use std::sync::Arc;

/// ChangeState: applies an allowed transition and reports it on `transition_event`; a
/// transition not allowed from the current state is refused (`success: false`), as rclcpp
/// refuses it. Deactivating stops the robot: the follower brakes to a stop.
pub async fn change_state(
    s: Arc<Shared>,
    server: ServiceServer<ChangeStateRequest, ChangeStateResponse>,
    events: Publisher<TransitionEvent>,
) {
    loop {
        let (id, req) = server.next_request().await;
        let (success, event) = {
            let mut state = s.lifecycle.write().expect("lock");
            let current = *state;
            match Transition::from_request(&req.transition, current)
                .and_then(|t| current.after(t).map(|next| (t, next)))
            {
                Some((t, next)) => {
                    *state = next;
                    let event = TransitionEvent {
                        timestamp: stamp_ns(),
                        transition: t.msg(),
                        start_state: current.msg(),
                        goal_state: next.msg(),
                    };
                    info!(
                        "lifecycle: {} -> {} ({})",
                        current.label(),
                        next.label(),
                        t.label()
                    );
                    (true, Some(event))
                }
                None => {
                    warn!(
                        "lifecycle: transition {} `{}` is not allowed from {}",
                        req.transition.id,
                        req.transition.label,
                        current.label()
                    );
                    (false, None)
                }
            }
        };
        // Out of the lifecycle's lock (the follower's is taken first everywhere else): a node
        // no longer active stops the robot. A plan finishing later is not handed to the
        // follower (`Shared::follow` refuses while inactive), and each action's drive ends
        // with the node's reason.
        if *s.lifecycle.read().expect("lock") != State::Active {
            *s.follower.lock().expect("lock") = None;
            *s.followed.lock().expect("lock") = None;
            *s.motion.lock().expect("lock") = None;
            s.end_topic_navigation();
        }
        if let Some(event) = event {
            if let Err(e) = events.async_publish(event).await {
                warn!("transition_event: {e:?}");
            }
        }
        server.respond(id, ChangeStateResponse { success }).await;
    }
}

/// GetState.
pub async fn get_state(s: Arc<Shared>, server: ServiceServer<EmptyRequest, GetStateResponse>) {
    loop {
        let (id, _) = server.next_request().await;
        let current_state = s.lifecycle.read().expect("lock").msg();
        server.respond(id, GetStateResponse { current_state }).await;
    }
}

/// GetAvailableStates: the four primary states.
pub async fn get_available_states(server: ServiceServer<EmptyRequest, GetAvailableStatesResponse>) {
    loop {
        let (id, _) = server.next_request().await;
        let available_states = State::all().map(State::msg).to_vec();
        server
            .respond(id, GetAvailableStatesResponse { available_states })
            .await;
    }
}

/// GetAvailableTransitions (from the current state) or, with `whole_graph`,
/// GetTransitionGraph (from every state).
pub async fn get_transitions(
    s: Arc<Shared>,
    server: ServiceServer<EmptyRequest, GetAvailableTransitionsResponse>,
    whole_graph: bool,
) {
    loop {
        let (id, _) = server.next_request().await;
        let available_transitions = if whole_graph {
            State::all()
                .iter()
                .flat_map(|st| st.descriptions())
                .collect()
        } else {
            s.lifecycle.read().expect("lock").descriptions()
        };
        server
            .respond(
                id,
                GetAvailableTransitionsResponse {
                    available_transitions,
                },
            )
            .await;
    }
}

/// The bond heartbeat Nav2's lifecycle manager expects of a server (bondcpp's protocol, as
/// nav2_util::LifecycleNode creates it on activate): while active, `bond/Status` with the
/// node's name as the bond id, this process's instance id and `active: true`, every
/// `period`; on leaving active, a few `active: false` to break the bond cleanly.
pub async fn bond(
    s: Arc<Shared>,
    publisher: Publisher<patrol_msgs::bond::Status>,
    node_name: String,
    period: f64,
) {
    use patrol_msgs::bond::Status;
    let instance_id = format!("{}-{:016x}", std::process::id(), rand::random::<u64>());
    let status = |active: bool| Status {
        header: patrol_msgs::std_msgs::Header {
            stamp: ros_edge::now(),
            frame_id: String::new(),
        },
        id: node_name.clone(),
        instance_id: instance_id.clone(),
        active,
        heartbeat_timeout: 4.0,
        heartbeat_period: period as f32,
    };
    let mut ticker = tokio::time::interval(std::time::Duration::from_secs_f64(period));
    // Breaking statuses still to send after leaving active.
    let mut breaking = 0;
    loop {
        ticker.tick().await;
        let active = *s.lifecycle.read().expect("lock") == State::Active;
        if active {
            breaking = 3;
        } else if breaking > 0 {
            breaking -= 1;
        } else {
            continue;
        }
        if let Err(e) = publisher.async_publish(status(active)).await {
            warn!("bond: {e:?}");
        }
    }
}

fn stamp_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}
