//! The managed-node state machine (ROS 2 design "Managed nodes", rclcpp_lifecycle), as Nav2's
//! lifecycle_manager drives planner_server: unconfigured -> configure -> inactive -> activate ->
//! active, back with deactivate and cleanup, and shutdown from any of them to finalized. Only an
//! active node plans; in every other state requests are refused with the state named.
//!
//! Pure: the services and the transition_event topic that expose it live in
//! lifecycle_services.rs.

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
