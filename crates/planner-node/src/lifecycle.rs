//! The managed-node state machine (ROS 2 design "Managed nodes", rclcpp_lifecycle), as Nav2's
//! lifecycle_manager drives planner_server: unconfigured -> configure -> inactive -> activate ->
//! active, back with deactivate and cleanup, and shutdown from any of them to finalized. Only an
//! active node plans; in every other state requests are refused with the state named.
//!
//! Pure: the services and the transition_event topic that expose it live in node.rs.

use patrol_msgs::lifecycle_msgs::{
    State as StateMsg, Transition as TransitionMsg, TransitionDescription,
};

/// The primary states, with lifecycle_msgs/State's ids.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum State {
    Unconfigured = 1,
    Inactive = 2,
    Active = 3,
    Finalized = 4,
}

/// The transitions a client may ask for, with lifecycle_msgs/Transition's ids.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Transition {
    Configure = 1,
    Cleanup = 2,
    Activate = 3,
    Deactivate = 4,
    UnconfiguredShutdown = 5,
    InactiveShutdown = 6,
    ActiveShutdown = 7,
}

impl State {
    pub fn label(self) -> &'static str {
        match self {
            State::Unconfigured => "unconfigured",
            State::Inactive => "inactive",
            State::Active => "active",
            State::Finalized => "finalized",
        }
    }

    pub fn msg(self) -> StateMsg {
        StateMsg {
            id: self as u8,
            label: self.label().into(),
        }
    }

    /// The transitions allowed from this state, in rclcpp's order.
    pub fn available(self) -> &'static [Transition] {
        match self {
            State::Unconfigured => &[Transition::Configure, Transition::UnconfiguredShutdown],
            State::Inactive => &[
                Transition::Cleanup,
                Transition::Activate,
                Transition::InactiveShutdown,
            ],
            State::Active => &[Transition::Deactivate, Transition::ActiveShutdown],
            State::Finalized => &[],
        }
    }

    /// The state a transition leads to from here, if it is allowed.
    pub fn after(self, t: Transition) -> Option<State> {
        self.available().contains(&t).then_some(match t {
            Transition::Configure | Transition::Deactivate => State::Inactive,
            Transition::Cleanup => State::Unconfigured,
            Transition::Activate => State::Active,
            _ => State::Finalized,
        })
    }

    /// The descriptions get_available_transitions answers with.
    pub fn descriptions(self) -> Vec<TransitionDescription> {
        self.available()
            .iter()
            .map(|&t| TransitionDescription {
                transition: t.msg(),
                start_state: self.msg(),
                goal_state: self.after(t).expect("available").msg(),
            })
            .collect()
    }

    /// The states get_available_states lists.
    pub fn all() -> [State; 4] {
        [
            State::Unconfigured,
            State::Inactive,
            State::Active,
            State::Finalized,
        ]
    }
}

impl Transition {
    pub fn label(self) -> &'static str {
        match self {
            Transition::Configure => "configure",
            Transition::Cleanup => "cleanup",
            Transition::Activate => "activate",
            Transition::Deactivate => "deactivate",
            _ => "shutdown",
        }
    }

    pub fn msg(self) -> TransitionMsg {
        TransitionMsg {
            id: self as u8,
            label: self.label().into(),
        }
    }

    /// A ChangeState request's transition: by id, or (id 0) by label, as rclcpp resolves it;
    /// "shutdown" means the shutdown transition of the current state.
    pub fn from_request(msg: &TransitionMsg, current: State) -> Option<Transition> {
        let all = [
            Transition::Configure,
            Transition::Cleanup,
            Transition::Activate,
            Transition::Deactivate,
            Transition::UnconfiguredShutdown,
            Transition::InactiveShutdown,
            Transition::ActiveShutdown,
        ];
        if msg.id != 0 {
            return all.into_iter().find(|t| *t as u8 == msg.id);
        }
        current
            .available()
            .iter()
            .copied()
            .find(|t| t.label() == msg.label)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_managed_node_graph() {
        let walk = [
            (Transition::Configure, State::Inactive),
            (Transition::Activate, State::Active),
            (Transition::Deactivate, State::Inactive),
            (Transition::Activate, State::Active),
            (Transition::ActiveShutdown, State::Finalized),
        ];
        let mut s = State::Unconfigured;
        for (t, next) in walk {
            s = s.after(t).unwrap_or_else(|| panic!("{t:?} from {s:?}"));
            assert_eq!(s, next);
        }
        assert!(State::Finalized.available().is_empty());
        assert_eq!(State::Unconfigured.after(Transition::Activate), None);
        assert_eq!(State::Active.after(Transition::Cleanup), None);
        assert_eq!(
            State::Inactive.after(Transition::Cleanup),
            Some(State::Unconfigured)
        );
        // rclcpp's ids and labels.
        assert_eq!(
            (State::Active.msg().id, State::Active.label()),
            (3, "active")
        );
        assert_eq!(Transition::InactiveShutdown.msg().id, 6);
        let by_label = TransitionMsg {
            id: 0,
            label: "shutdown".into(),
        };
        assert_eq!(
            Transition::from_request(&by_label, State::Active),
            Some(Transition::ActiveShutdown)
        );
        let descriptions = State::Inactive.descriptions();
        assert_eq!(descriptions.len(), 3);
        assert_eq!(descriptions[1].goal_state.label, "active");
    }
}

/// The lifecycle services and topic of a managed node, on the node's own names (`~/change_state`,
/// `~/get_state`, `~/get_available_states`, `~/get_available_transitions`,
/// `~/get_transition_graph`, `~/transition_event`), as rclcpp_lifecycle offers them.
pub mod serve {
    use super::{State, Transition};
    use crate::state::Shared;
    use log::{info, warn};
    use patrol_msgs::lifecycle_msgs::*;
    use ros2_client::{Publisher, Server};
    use std::sync::Arc;

    /// ChangeState: applies an allowed transition and reports it on `transition_event`; a
    /// transition not allowed from the current state is refused (`success: false`), as rclcpp
    /// refuses it. Deactivating stops the robot: the follower brakes to a stop.
    pub async fn change_state(
        s: Arc<Shared>,
        server: Server<ChangeStateRequest, ChangeStateResponse>,
        events: Publisher<TransitionEvent>,
    ) {
        loop {
            let Ok((id, req)) = server.async_receive_request().await else {
                continue;
            };
            let (success, event) = {
                let mut state = s.lifecycle.write().expect("lock");
                let current = *state;
                match Transition::from_request(&req.transition, current)
                    .and_then(|t| current.after(t).map(|next| (t, next)))
                {
                    Some((t, next)) => {
                        *state = next;
                        if next != State::Active {
                            *s.follower.lock().expect("lock") = None;
                        }
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
            if let Some(event) = event {
                if let Err(e) = events.async_publish(event).await {
                    warn!("transition_event: {e:?}");
                }
            }
            if let Err(e) = server
                .async_send_response(id, ChangeStateResponse { success })
                .await
            {
                warn!("change_state response: {e:?}");
            }
        }
    }

    /// GetState.
    pub async fn get_state(s: Arc<Shared>, server: Server<EmptyRequest, GetStateResponse>) {
        loop {
            let Ok((id, _)) = server.async_receive_request().await else {
                continue;
            };
            let current_state = s.lifecycle.read().expect("lock").msg();
            if let Err(e) = server
                .async_send_response(id, GetStateResponse { current_state })
                .await
            {
                warn!("get_state response: {e:?}");
            }
        }
    }

    /// GetAvailableStates: the four primary states.
    pub async fn get_available_states(server: Server<EmptyRequest, GetAvailableStatesResponse>) {
        loop {
            let Ok((id, _)) = server.async_receive_request().await else {
                continue;
            };
            let available_states = State::all().map(State::msg).to_vec();
            if let Err(e) = server
                .async_send_response(id, GetAvailableStatesResponse { available_states })
                .await
            {
                warn!("get_available_states response: {e:?}");
            }
        }
    }

    /// GetAvailableTransitions (from the current state) or, with `whole_graph`,
    /// GetTransitionGraph (from every state).
    pub async fn get_transitions(
        s: Arc<Shared>,
        server: Server<EmptyRequest, GetAvailableTransitionsResponse>,
        whole_graph: bool,
    ) {
        loop {
            let Ok((id, _)) = server.async_receive_request().await else {
                continue;
            };
            let available_transitions = if whole_graph {
                State::all()
                    .iter()
                    .flat_map(|st| st.descriptions())
                    .collect()
            } else {
                s.lifecycle.read().expect("lock").descriptions()
            };
            if let Err(e) = server
                .async_send_response(
                    id,
                    GetAvailableTransitionsResponse {
                        available_transitions,
                    },
                )
                .await
            {
                warn!("get_available_transitions response: {e:?}");
            }
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
}
