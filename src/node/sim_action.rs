//! The SimulateSteps action (simulation_interfaces 2.x) at
//! `<ns>/truss/simulate_steps`, served by hand as rcl_action lays an action
//! out: services `_action/send_goal`, `_action/cancel_goal`,
//! `_action/get_result` (each answered in its client's service mapping, like
//! the node's other services) and topics `_action/feedback`,
//! `_action/status`. One goal at a time, taken while the simulation is paused
//! or stopped: it steps at the real-time factor (so a client can watch and
//! cancel), with feedback every [`FEEDBACK_EVERY_STEPS`] steps and at the end,
//! and leaves the simulation paused. A goal while playing ends at once,
//! aborted with RESULT_OPERATION_FAILED, as the .action file says; so does one
//! stopped early by full deployment or a failed step.

use super::msgs::action::*;
use super::msgs::sim_if::*;
use super::msgs::{sim_stamp, SimResult};
use super::services::{Control, RunState, Service};
use super::Naming;
use crate::solver::Simulator;
use ros2_client::builtin_interfaces::Time;
use ros2_client::{MessageTypeName, Node, Publisher, ServiceMapping, ServiceTypeName};
use std::time::Instant;

/// Feedback after this many steps (and after the last).
pub const FEEDBACK_EVERY_STEPS: u64 = 10;
/// Finished goals kept for get_result and the status list.
const KEPT_GOALS: usize = 16;

#[derive(Clone, Debug)]
struct Goal {
    id: GoalId,
    stamp: Time,
    steps: u64,
    done: u64,
    status: i8,
    result: SimResult,
}

impl Goal {
    fn terminal(&self) -> bool {
        matches!(
            self.status,
            STATUS_SUCCEEDED | STATUS_CANCELED | STATUS_ABORTED
        )
    }
    fn info(&self) -> GoalInfo {
        GoalInfo {
            goal_id: self.id,
            stamp: self.stamp,
        }
    }
}

pub struct SimulateSteps {
    send_goal: Service<SendGoalRequest, SendGoalResponse>,
    cancel: Service<CancelGoalRequest, CancelGoalResponse>,
    get_result: Service<GetResultRequest, GetResultResponse>,
    feedback: Publisher<FeedbackMessage>,
    status: Publisher<GoalStatusArray>,
    /// The goal being executed (last in `goals` when it is not terminal).
    goals: Vec<Goal>,
    status_dirty: bool,
}

fn sim_result(result: u8, msg: impl Into<String>) -> SimResult {
    SimResult {
        result,
        error_message: msg.into(),
    }
}

impl SimulateSteps {
    pub fn new(
        node: &mut Node,
        names: &Naming,
        forced: Option<ServiceMapping>,
    ) -> Result<Self, String> {
        let base = "truss/simulate_steps/_action";
        let action_srv =
            |t: &str| ServiceTypeName::new_prefix("simulation_interfaces", t, "action".into());
        let e = |what: &str, err: &dyn std::fmt::Debug| format!("create {what}: {err:?}");
        let status_t = node
            .create_topic(
                &names.name(&format!("{base}/status"))?,
                MessageTypeName::new("action_msgs", "GoalStatusArray"),
                &super::qos::latched(),
            )
            .map_err(|x| e("action status", &x))?;
        let feedback_t = node
            .create_topic(
                &names.name(&format!("{base}/feedback"))?,
                MessageTypeName::new_prefix(
                    "simulation_interfaces",
                    "SimulateSteps_FeedbackMessage",
                    "action".into(),
                ),
                &super::qos::reliable10(),
            )
            .map_err(|x| e("action feedback", &x))?;
        Ok(SimulateSteps {
            send_goal: Service::new(
                node,
                &names.name(&format!("{base}/send_goal"))?,
                &action_srv("SimulateSteps_SendGoal"),
                forced,
            )?,
            cancel: Service::new(
                node,
                &names.name(&format!("{base}/cancel_goal"))?,
                &ServiceTypeName::new("action_msgs", "CancelGoal"),
                forced,
            )?,
            get_result: Service::new(
                node,
                &names.name(&format!("{base}/get_result"))?,
                &action_srv("SimulateSteps_GetResult"),
                forced,
            )?,
            feedback: node
                .create_publisher(&feedback_t, None)
                .map_err(|x| e("action feedback", &x))?,
            status: node
                .create_publisher(&status_t, None)
                .map_err(|x| e("action status", &x))?,
            goals: Vec::new(),
            status_dirty: false,
        })
    }

    /// Whether a goal is being executed (the main loop then paces its steps).
    pub fn executing(&self) -> bool {
        self.goals.last().is_some_and(|g| !g.terminal())
    }

    /// Answers goal, cancel and result requests; returns how many came.
    pub fn serve(
        &mut self,
        node: &Node,
        ctl: &mut Control,
        sim: &Simulator,
        now: Instant,
    ) -> usize {
        let mut n = 0;
        let goals = &mut self.goals;
        let dirty = &mut self.status_dirty;
        n += self.send_goal.serve(node, now, |r| {
            let stamp = sim_stamp(sim.state().t_s);
            if goals.last().is_some_and(|g| !g.terminal()) {
                // one goal at a time
                return SendGoalResponse {
                    accepted: false,
                    stamp,
                };
            }
            let mut g = Goal {
                id: r.goal_id,
                stamp,
                steps: r.steps,
                done: 0,
                status: STATUS_EXECUTING,
                result: sim_result(RESULT_OK, ""),
            };
            let refuse = if ctl.run == RunState::Playing {
                Some("the simulation is playing: pause it first".to_string())
            } else if r.steps == 0 || r.steps > super::services::MAX_STEPS_PER_CALL {
                Some(format!(
                    "steps {} must be 1 to {}",
                    r.steps,
                    super::services::MAX_STEPS_PER_CALL
                ))
            } else {
                ctl.held(sim).map(|(_, why)| why)
            };
            if let Some(why) = refuse {
                g.status = STATUS_ABORTED;
                g.result = sim_result(RESULT_OPERATION_FAILED, why);
            } else {
                // paced from now at the real-time factor; ends paused
                ctl.run = RunState::Paused;
                ctl.anchor_wall = now;
                ctl.anchor_sim = sim.state().t_s;
            }
            goals.push(g);
            if goals.len() > KEPT_GOALS {
                goals.remove(0);
            }
            *dirty = true;
            SendGoalResponse {
                accepted: true,
                stamp,
            }
        });
        n += self.cancel.serve(node, now, |r| {
            let all = r.goal_info.goal_id == [0; 16];
            let mut canceling = Vec::new();
            let mut known = false;
            let mut terminated = false;
            for g in goals.iter_mut() {
                if all || g.id == r.goal_info.goal_id {
                    known = true;
                    if g.terminal() {
                        terminated = true;
                    } else {
                        g.status = STATUS_CANCELING;
                        canceling.push(g.info());
                        *dirty = true;
                    }
                }
            }
            CancelGoalResponse {
                return_code: if !canceling.is_empty() {
                    CANCEL_ERROR_NONE
                } else if known && terminated {
                    CANCEL_ERROR_GOAL_TERMINATED
                } else {
                    CANCEL_ERROR_UNKNOWN_GOAL_ID
                },
                goals_canceling: canceling,
            }
        });
        n += self
            .get_result
            .serve_or_park(node, now, |r| result_of(goals, &r.goal_id));
        n
    }

    /// Takes up to `due` steps of the executing goal (paced by the caller),
    /// with feedback every [`FEEDBACK_EVERY_STEPS`]; ends it when done,
    /// canceled, deployed or failed. Returns the steps taken.
    pub fn advance(&mut self, ctl: &mut Control, sim: &mut Simulator, due: u64) -> u64 {
        let Some(g) = self.goals.last_mut().filter(|g| !g.terminal()) else {
            return 0;
        };
        if g.status == STATUS_CANCELING {
            g.status = STATUS_CANCELED;
            g.result = sim_result(
                RESULT_OK,
                format!("canceled after {} of {} steps", g.done, g.steps),
            );
            self.status_dirty = true;
            return 0;
        }
        let mut taken = 0;
        while taken < due && g.done < g.steps {
            // to the next feedback point at most
            let chunk = (FEEDBACK_EVERY_STEPS - g.done % FEEDBACK_EVERY_STEPS)
                .min(g.steps - g.done)
                .min(due - taken);
            let (k, why) = ctl.step_paused(sim, chunk);
            g.done += k;
            taken += k;
            if g.done % FEEDBACK_EVERY_STEPS == 0 || g.done == g.steps || why.is_some() {
                let _ = self.feedback.publish(FeedbackMessage {
                    goal_id: g.id,
                    completed_steps: g.done,
                    remaining_steps: g.steps - g.done,
                });
            }
            if let Some(why) = why {
                g.status = STATUS_ABORTED;
                g.result = sim_result(
                    RESULT_OPERATION_FAILED,
                    format!("stopped after {} of {} steps: {why}", g.done, g.steps),
                );
                self.status_dirty = true;
                return taken;
            }
        }
        if g.done == g.steps {
            g.status = STATUS_SUCCEEDED;
            g.result = sim_result(RESULT_OK, format!("{} steps; paused", g.steps));
            self.status_dirty = true;
        }
        taken
    }

    /// Publishes the goal statuses if they changed, and answers the result
    /// requests of finished goals.
    pub fn finish(&mut self, node: &Node, now: Instant) {
        if self.status_dirty {
            let _ = self.status.publish(GoalStatusArray {
                status_list: self
                    .goals
                    .iter()
                    .map(|g| GoalStatus {
                        goal_info: g.info(),
                        status: g.status,
                    })
                    .collect(),
            });
            self.status_dirty = false;
        }
        let goals = &self.goals;
        self.get_result
            .answer_parked(node, now, |r| result_of(goals, &r.goal_id));
    }
}

/// The result of a finished goal, None while it runs; an unknown goal gets
/// STATUS_UNKNOWN at once (as rcl_action answers).
fn result_of(goals: &[Goal], id: &GoalId) -> Option<GetResultResponse> {
    match goals.iter().find(|g| &g.id == id) {
        None => Some(GetResultResponse {
            status: STATUS_UNKNOWN,
            result: sim_result(RESULT_OPERATION_FAILED, "unknown goal"),
        }),
        Some(g) if g.terminal() => Some(GetResultResponse {
            status: g.status,
            result: g.result.clone(),
        }),
        Some(_) => None,
    }
}
