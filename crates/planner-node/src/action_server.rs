//! The door every action of the node goes through, as Nav2's `SimpleActionServer` is for its
//! servers: a goal is rejected while the node is not active (lifecycle), otherwise accepted and
//! run on a task of its own, and a client's cancel is accepted and noticed by the run, which
//! ends canceled. What a newer goal does to the running one is the action's [`Preemption`]:
//! it stops it (the driving actions, as bt_navigator's and behavior_server's are preempted), or
//! waits its turn (the planner's actions, as planner_server plans one goal to its end before
//! taking the next).
//! What a goal does (plan, patrol, drive) is the run's business: it gets the goal, a
//! [`GoalStop`] to poll, and a [`Feedback`] sender.

use crate::outputs::Outputs;
use crate::state::Shared;
use log::{info, warn};
use ros2_client::action::{AsyncActionServer, ExecutingGoalHandle, GoalEndStatus, GoalError};
use ros2_client::action_msgs::GoalId;
use ros2_client::Message;
use std::collections::BTreeSet;
use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What a newer goal of an action does to the one running.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preemption {
    /// The running goal stops, and ends aborted (bt_navigator, behavior_server,
    /// controller_server, waypoint_follower: the newer goal is where the robot goes now).
    Newest,
    /// The running goal runs to its end; the newer one waits for it, and an older one still
    /// waiting ends aborted with an empty result. planner_server's SimpleActionServer keeps one
    /// pending goal this way, so a script's `getPath` beside bt_navigator's replanning delays
    /// the tree's plan instead of aborting it (and the tree's recovery with it).
    Queue,
}

/// The goals of one action asked to stop.
#[derive(Default)]
struct Stops {
    /// Cancelled by a client and still running.
    cancelled: Mutex<BTreeSet<GoalId>>,
    /// The newest goal's number: an older running goal sees it change and stops.
    newest: AtomicU64,
}

/// Whether one goal is to stop, and why.
#[derive(Clone)]
pub struct GoalStop {
    stops: Arc<Stops>,
    number: u64,
    id: GoalId,
    /// Whether a newer goal stops this one once it runs ([`Preemption::Newest`]).
    preemptible: bool,
}

impl GoalStop {
    /// The stop of a goal no client can cancel or preempt (a `/goal_pose`'s drive): it ends
    /// only when a newer goal takes the robot, or the node stops.
    pub fn never() -> Self {
        Self {
            stops: Arc::new(Stops::default()),
            number: 0,
            id: GoalId::ZERO,
            preemptible: false,
        }
    }

    /// A newer goal of the same action has arrived, and stops this one.
    pub fn preempted(&self) -> bool {
        self.preemptible && self.replaced()
    }

    /// A newer goal of the same action has arrived.
    fn replaced(&self) -> bool {
        self.stops.newest.load(Ordering::SeqCst) != self.number
    }

    /// Cancelled by a client.
    fn cancelled(&self) -> bool {
        self.stops
            .cancelled
            .lock()
            .expect("lock")
            .contains(&self.id)
    }

    /// Preempted, or cancelled by a client.
    pub fn requested(&self) -> bool {
        self.preempted() || self.cancelled()
    }

    /// Why a goal that stopped on request stopped, for its result's message.
    pub fn reason(&self) -> &'static str {
        if self.preempted() {
            "preempted by a newer goal"
        } else {
            "canceled"
        }
    }

    /// How a goal that stopped on request ends: aborted when preempted (as Nav2's
    /// SimpleActionServer ends the goal a newer one replaces), canceled when a client asked.
    pub fn end_status(&self) -> GoalEndStatus {
        if self.preempted() {
            GoalEndStatus::Aborted
        } else {
            GoalEndStatus::Canceled
        }
    }
}

/// Sends one goal's feedback.
pub struct Feedback<G, R, F>
where
    G: Message + Clone,
    R: Message + Clone,
    F: Message,
{
    server: Arc<AsyncActionServer<G, R, F>>,
    executing: ExecutingGoalHandle<G>,
}

impl<G, R, F> Clone for Feedback<G, R, F>
where
    G: Message + Clone,
    R: Message + Clone,
    F: Message,
{
    fn clone(&self) -> Self {
        Self {
            server: self.server.clone(),
            executing: self.executing.clone(),
        }
    }
}

impl<G, R, F> Feedback<G, R, F>
where
    G: Message + Clone,
    R: Message + Clone,
    F: Message,
{
    /// Publishes `feedback`; a goal that has ended meanwhile has none (nothing to do).
    pub async fn send(&self, feedback: F) {
        let _ = self
            .server
            .publish_feedback(self.executing.clone(), feedback)
            .await;
    }
}

/// Serves the action `name` until the node stops: each accepted goal runs `run(s, o, goal,
/// stop, feedback)` on a task of its own, after the running one under [`Preemption::Queue`],
/// and its result goes back to the client.
pub async fn serve<G, R, F, Run, Fut>(
    s: Arc<Shared>,
    o: Outputs,
    name: &'static str,
    preemption: Preemption,
    server: AsyncActionServer<G, R, F>,
    run: Run,
) where
    G: Message + Clone + Send + Sync + 'static,
    R: Message + Clone + Default + Send + Sync + 'static,
    F: Message + Send + Sync + 'static,
    Run: Fn(Arc<Shared>, Outputs, G, GoalStop, Feedback<G, R, F>) -> Fut,
    Fut: Future<Output = (GoalEndStatus, R)> + Send + 'static,
{
    let server = Arc::new(server);
    let stops = Arc::new(Stops::default());
    // Under Preemption::Queue, held by the goal that runs.
    let turn = Arc::new(tokio::sync::Mutex::new(()));
    let goals = async {
        loop {
            let handle = match server.receive_new_goal().await {
                Ok(h) => h,
                Err(e) => {
                    warn!("{name}: {e:?}");
                    continue;
                }
            };
            let Some(goal) = server.get_new_goal(handle.clone()) else {
                continue;
            };
            // Inactive (lifecycle): refused at the door, as Nav2's deactivated action servers do.
            if let Some(refusal) = s.refusal() {
                info!("{name}: goal rejected: {}", refusal.message);
                if let Err(e) = server.reject_goal(handle).await {
                    warn!("{name}: reject: {e:?}");
                }
                continue;
            }
            let accepted = match server.accept_goal(handle).await {
                Ok(a) => a,
                Err(e) => {
                    warn!("{name}: accept: {e:?}");
                    continue;
                }
            };
            let executing = match server.start_executing_goal(accepted.clone()).await {
                Ok(x) => x,
                Err(e) => {
                    // Accepted, so the client waits for an end: it gets one.
                    warn!("{name}: execute: {e:?}");
                    let _ = server.abort_accepted_goal(accepted).await;
                    continue;
                }
            };
            // Under Preemption::Queue the turn is taken here, in arrival order: a goal that finds
            // it free runs, even if a newer goal comes before its task has started.
            let held = match preemption {
                Preemption::Queue => turn.clone().try_lock_owned().ok(),
                Preemption::Newest => None,
            };
            // Only a goal that runs preempts the running one.
            let number = stops.newest.fetch_add(1, Ordering::SeqCst) + 1;
            let id = executing.goal_id();
            let stop = GoalStop {
                stops: stops.clone(),
                number,
                id,
                preemptible: preemption == Preemption::Newest,
            };
            let feedback = Feedback {
                server: server.clone(),
                executing: executing.clone(),
            };
            let waiting = stop.clone();
            let running = run(s.clone(), o.clone(), goal, stop, feedback);
            let (server, stops, turn) = (server.clone(), stops.clone(), turn.clone());
            let shared = s.clone();
            tokio::spawn(async move {
                let turn = match (preemption, held) {
                    (Preemption::Newest, _) => None,
                    (Preemption::Queue, Some(held)) => Some(held),
                    (Preemption::Queue, None) => {
                        match wait_for_turn(&turn, &waiting, &shared).await {
                            Ok(held) => Some(held),
                            Err((status, why)) => {
                                info!("{name}: goal {why}");
                                send_result(name, &server, executing, status, R::default()).await;
                                stops.cancelled.lock().expect("lock").remove(&id);
                                return;
                            }
                        }
                    }
                };
                let (status, result) = running.await;
                // The next goal runs while this one's client comes for its result (which may
                // take up to RESULT_TIMEOUT, or never come).
                drop(turn);
                send_result(name, &server, executing, status, result).await;
                // After the result, not before: until it is sent the goal still counts as
                // running, and a cancel then would be remembered for ever.
                stops.cancelled.lock().expect("lock").remove(&id);
            });
        }
    };
    // Goals and cancels side by side; both end when the node's task set is shut down.
    tokio::join!(goals, serve_cancels(name, server.clone(), stops.clone()));
}

/// How often a goal waiting its turn looks whether it may run, was replaced or cancelled.
const TURN_POLL: Duration = Duration::from_millis(10);

/// Waits until the goal of `stop` may run (the turn is free) and returns the turn, held until
/// the goal's run ends; or how the goal ends without running, and why: aborted when a newer
/// goal has come meanwhile (the newest waits, as Nav2's pending slot holds one) or the node
/// was deactivated (as Nav2's deactivated server ends its pending goal), canceled when its
/// client cancelled it. The goal shows EXECUTING while it waits, as planner_server's pending
/// goal does (nav2_util's SimpleActionServer accepts every goal with ACCEPT_AND_EXECUTE); and
/// ros2-client sends a result only for an executing goal.
async fn wait_for_turn(
    turn: &Arc<tokio::sync::Mutex<()>>,
    stop: &GoalStop,
    s: &Shared,
) -> Result<tokio::sync::OwnedMutexGuard<()>, (GoalEndStatus, &'static str)> {
    loop {
        if stop.replaced() {
            return Err((
                GoalEndStatus::Aborted,
                "replaced by a newer goal while it waited for the running one: aborted",
            ));
        }
        if s.refusal().is_some() {
            return Err((
                GoalEndStatus::Aborted,
                "ended while it waited for the running one: the node was deactivated",
            ));
        }
        if stop.cancelled() {
            return Err((
                GoalEndStatus::Canceled,
                "canceled while it waited for the running one",
            ));
        }
        if let Ok(held) = turn.clone().try_lock_owned() {
            return Ok(held);
        }
        tokio::time::sleep(TURN_POLL).await;
    }
}

/// How long a finished goal's result waits for its client to ask for it, as rcl_action keeps
/// results for its `result_timeout` (15 minutes) by default.
const RESULT_TIMEOUT: Duration = Duration::from_secs(900);

/// How long one try at sending a result waits for its request before it starts again.
const RESULT_RETRY: Duration = Duration::from_millis(250);

/// Answers the client's request for one goal's result. ros2-client reads result requests only
/// while a result is being sent: a try waiting for its own request stores the others it reads
/// for their goals, but a try already waiting for one that another try has read and stored
/// would wait for ever (two goals ending together, their clients asking afterwards). So each
/// try gives up after [`RESULT_RETRY`] and the next looks among the stored requests first,
/// until the client has asked or [`RESULT_TIMEOUT`] has passed. A try cut short loses
/// nothing: a request is stored or answered in the same step it is read.
async fn send_result<G, R, F>(
    name: &'static str,
    server: &AsyncActionServer<G, R, F>,
    executing: ExecutingGoalHandle<G>,
    status: GoalEndStatus,
    result: R,
) where
    G: Message + Clone,
    R: Message + Clone + 'static,
    F: Message,
{
    let waiting = Instant::now();
    loop {
        let attempt = server.send_result_response(executing.clone(), status, result.clone());
        match tokio::time::timeout(RESULT_RETRY, attempt).await {
            Ok(Ok(())) => return,
            // A request that could not be read (another client's, perhaps): the next try goes
            // on reading.
            Ok(Err(GoalError::DDSReadError(e))) => warn!("{name}: a result request: {e:?}"),
            Ok(Err(e)) => return warn!("{name}: result: {e:?}"),
            Err(_) if waiting.elapsed() < RESULT_TIMEOUT => continue,
            Err(_) => {
                return warn!(
                    "{name}: result: no client asked for it in {} s; dropped",
                    RESULT_TIMEOUT.as_secs()
                )
            }
        }
    }
}

/// Accepts every cancel request for a goal still running; the goal's run notices it
/// ([`GoalStop::requested`]) and ends it as canceled.
async fn serve_cancels<G, R, F>(
    name: &'static str,
    server: Arc<AsyncActionServer<G, R, F>>,
    stops: Arc<Stops>,
) where
    G: Message + Clone,
    R: Message + Clone,
    F: Message,
{
    loop {
        let handle = match server.receive_cancel_request().await {
            Ok(h) => h,
            Err(e) => {
                warn!("{name} cancel: {e:?}");
                continue;
            }
        };
        let goals: Vec<GoalId> = handle.goals().collect();
        stops
            .cancelled
            .lock()
            .expect("lock")
            .extend(goals.iter().copied());
        if let Err(e) = server
            .respond_to_cancel_requests(&handle, goals.into_iter())
            .await
        {
            warn!("{name} cancel response: {e:?}");
        }
    }
}
