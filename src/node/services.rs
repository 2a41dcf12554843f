//! The node's services: `std_srvs/Trigger` (/truss/{reset,pause,resume,step})
//! and simulation_interfaces 2.x (/truss/{get_simulator_features,
//! get_simulation_state, set_simulation_state, reset_simulation,
//! step_simulation}).
//!
//! Each request is answered in its own client's service mapping, with no flag:
//! rmw_cyclonedds_cpp puts a 16-byte request header (client id, sequence
//! number) before the request in the payload; rmw_fastrtps_cpp (ROS 2's
//! default) and rmw_connextdds send the bare request and carry its id in the
//! RTPS inline QoS (related_sample_identity). The vendor id opening the
//! client's GUID tells Cyclone DDS and Fast DDS clients apart; for others,
//! every simulation request type served here serializes to at most
//! [`MAX_REQUEST_BYTES`] (< 16 even with Fast DDS's 4-byte padding), so the
//! payload length does ([`request_mapping`]).
//!
//! A reply is held until the reply writer has matched a reader in the
//! client's participant (at most [`REPLY_HOLD`]): a client may see the service
//! before the node sees the client (discovery is not symmetric), and a reply
//! written before the match is lost (volatile), the client waiting forever.
//!
//! [`Control`] is the run state (playing, paused, stopped) and what each
//! request does to it; it is pure, so tests drive it without DDS.

use super::log::node_log;
use super::msgs::sim_if::*;
use super::msgs::*;
use crate::solver::Simulator;
use ros2_client::{Message, Name, Node, Server, ServiceMapping, ServiceTypeName};
use std::time::{Duration, Instant};

/// Length of rmw_cyclonedds_cpp's request/reply header (8-byte client id,
/// 8-byte sequence number).
pub const CYCLONE_HEADER_BYTES: usize = 16;
/// The largest CDR size of a request type served here (StepSimulation's uint64).
pub const MAX_REQUEST_BYTES: usize = 8;
/// Longest a reply waits for the client's reply reader to match.
pub const REPLY_HOLD: Duration = Duration::from_secs(5);
/// Most requests taken per service and wake-up.
const MAX_REQS_PER_WAKE: usize = 64;
/// Most replies held per service (beyond this a reply goes out at once).
const MAX_HELD_REPLIES: usize = 256;
/// Most steps one StepSimulation call may ask for (the loop blocks meanwhile).
pub const MAX_STEPS_PER_CALL: u64 = 10_000;

/// The first two bytes of a participant's GUID prefix in Cyclone DDS and in
/// Fast DDS: their RTPS vendor ids (each writes its own there).
pub const VENDOR_ECLIPSE_CYCLONE: [u8; 2] = [0x01, 0x10];
pub const VENDOR_EPROSIMA_FASTDDS: [u8; 2] = [0x01, 0x0f];

/// The mapping of a request. A client in a Cyclone DDS participant is
/// rmw_cyclonedds' (Cyclone mapping), one in a Fast DDS participant
/// rmw_fastrtps' (Enhanced), told by the vendor id opening the request
/// writer's GUID. Others by the payload length (CDR bytes after the
/// encapsulation header): a Cyclone-mapped request is at least the 16-byte
/// header plus one byte; an Enhanced one of the simulation services is the
/// bare request, at most [`MAX_REQUEST_BYTES`] plus 3 bytes of alignment
/// padding. (The parameter services' requests are longer: their clients need
/// the vendor rule.)
pub fn request_mapping(payload_len: usize, client_guid: &[u8]) -> ServiceMapping {
    match client_guid.get(..2) {
        Some(v) if v == VENDOR_ECLIPSE_CYCLONE => ServiceMapping::Cyclone,
        Some(v) if v == VENDOR_EPROSIMA_FASTDDS => ServiceMapping::Enhanced,
        _ if payload_len >= CYCLONE_HEADER_BYTES => ServiceMapping::Cyclone,
        _ => ServiceMapping::Enhanced,
    }
}

struct Held<Resp> {
    id: ros2_client::RmwRequestId,
    resp: Resp,
    mapping: ServiceMapping,
    client: ros2_client::Gid,
    deadline: Instant,
}

/// A request answered later (an action's get_result).
struct Parked<Req> {
    id: ros2_client::RmwRequestId,
    req: Req,
    mapping: ServiceMapping,
    client: ros2_client::Gid,
}

/// One service server answering every client in its own mapping.
pub struct Service<Req: Message, Resp: Message> {
    pub name: String,
    server: Server<Req, Resp>,
    forced: Option<ServiceMapping>,
    held: Vec<Held<Resp>>,
    parked: Vec<Parked<Req>>,
    bad_request_logged: bool,
}

impl<Req: Message + Clone + 'static, Resp: Message + 'static> Service<Req, Resp> {
    /// `forced`: answer every request in this mapping instead of detecting it.
    pub fn new(
        node: &mut Node,
        name: &Name,
        ty: &ServiceTypeName,
        forced: Option<ServiceMapping>,
    ) -> Result<Self, String> {
        let server = node
            .create_server::<Req, Resp>(
                forced.unwrap_or(ServiceMapping::Cyclone), // not used: see receive_request_any_mapping
                name,
                ty,
                super::qos::reliable10(),
                super::qos::reliable10(),
            )
            .map_err(|e| format!("create service {name}: {e:?}"))?;
        Ok(Service {
            name: name.to_string(),
            server,
            forced,
            held: Vec::new(),
            parked: Vec::new(),
            bad_request_logged: false,
        })
    }

    /// Answers the pending requests with `handle`; returns how many there were.
    pub fn serve(
        &mut self,
        node: &Node,
        now: Instant,
        mut handle: impl FnMut(Req) -> Resp,
    ) -> usize {
        self.serve_or_park(node, now, |r| Some(handle(r.clone())))
    }

    /// As [`Self::serve`], but `handle` may answer None: the request waits
    /// for [`Self::answer_parked`] (at most [`MAX_HELD_REPLIES`] wait; beyond
    /// that a request is dropped, its client waiting in vain, and logged).
    pub fn serve_or_park(
        &mut self,
        node: &Node,
        now: Instant,
        mut handle: impl FnMut(&Req) -> Option<Resp>,
    ) -> usize {
        let forced = self.forced;
        let mut n = 0;
        for _ in 0..MAX_REQS_PER_WAKE {
            let got = self.server.receive_request_any_mapping(|payload, info| {
                forced.unwrap_or_else(|| {
                    request_mapping(payload.len(), info.publisher_gid().as_bytes())
                })
            });
            match got {
                Ok(Some((id, req, mapping, info))) => {
                    n += 1;
                    let Some(resp) = handle(&req) else {
                        if self.parked.len() < MAX_HELD_REPLIES {
                            self.parked.push(Parked {
                                id,
                                req,
                                mapping,
                                client: info.publisher_gid(),
                            });
                        } else {
                            node_log!(
                                Warn,
                                "service {}: too many waiting requests; one dropped",
                                self.name
                            );
                        }
                        continue;
                    };
                    self.held.push(Held {
                        id,
                        resp,
                        mapping,
                        client: info.publisher_gid(),
                        deadline: now + REPLY_HOLD,
                    });
                    if self.held.len() > MAX_HELD_REPLIES {
                        let h = self.held.remove(0);
                        self.send(h);
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    // the reader has moved past it: read on
                    if !self.bad_request_logged {
                        node_log!(Warn,
                            "service {}: undecodable request skipped ({e:?}); further ones are not logged",
                            self.name
                        );
                        self.bad_request_logged = true;
                    }
                }
            }
        }
        self.flush(node, now);
        n
    }

    /// Answers the parked requests `f` has an answer for now.
    pub fn answer_parked(
        &mut self,
        node: &Node,
        now: Instant,
        mut f: impl FnMut(&Req) -> Option<Resp>,
    ) {
        let mut k = 0;
        while k < self.parked.len() {
            match f(&self.parked[k].req) {
                Some(resp) => {
                    let p = self.parked.swap_remove(k);
                    self.held.push(Held {
                        id: p.id,
                        resp,
                        mapping: p.mapping,
                        client: p.client,
                        deadline: now + REPLY_HOLD,
                    });
                }
                None => k += 1,
            }
        }
        self.flush(node, now);
    }

    /// Sends the held replies whose client's reply reader has matched (or
    /// whose hold has run out).
    pub fn flush(&mut self, node: &Node, now: Instant) {
        let writer = self.server.response_writer_guid();
        let mut k = 0;
        while k < self.held.len() {
            let h = &self.held[k];
            let client = ros2_client::dds::rustdds::GUID::from(h.client);
            let matched = node.writer_matched_participant(writer, client);
            if matched || now >= h.deadline {
                if !matched {
                    node_log!(Warn,
                        "service {}: the client's reply reader did not match within {} s; replying anyway",
                        self.name,
                        REPLY_HOLD.as_secs()
                    );
                }
                let h = self.held.swap_remove(k);
                self.send(h);
            } else {
                k += 1;
            }
        }
    }

    fn send(&self, h: Held<Resp>) {
        if let Err(e) = self
            .server
            .send_response_with_mapping(h.id, h.resp, h.mapping)
        {
            node_log!(Warn, "service {} response: {e:?}", self.name);
        }
    }
}

/// Playing, paused or stopped (paused at the reset state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunState {
    Playing,
    Paused,
    Stopped,
}

/// The run state and the wall-clock anchor of real-time stepping.
#[derive(Debug)]
pub struct Control {
    pub run: RunState,
    /// Sim time target = anchor_sim + rtf * (now - anchor_wall).
    pub anchor_wall: Instant,
    pub anchor_sim: f64,
    /// A step failed (why): hold the state until a reset.
    pub step_failure: Option<String>,
    /// Steps taken by services (for the run summary).
    pub steps: u64,
    dt: f64,
}

fn result(code: u8, msg: impl Into<String>) -> ResultResponse {
    ResultResponse {
        result: SimResult {
            result: code,
            error_message: msg.into(),
        },
    }
}

impl Control {
    pub fn new(paused: bool, sim: &Simulator, dt: f64) -> Control {
        Control {
            run: if paused {
                RunState::Paused
            } else {
                RunState::Playing
            },
            anchor_wall: Instant::now(),
            anchor_sim: sim.state().t_s,
            step_failure: None,
            steps: 0,
            dt,
        }
    }

    pub fn paused(&self) -> bool {
        self.run != RunState::Playing
    }

    fn resync(&mut self, sim: &Simulator) {
        self.anchor_wall = Instant::now();
        self.anchor_sim = sim.state().t_s;
    }

    fn play(&mut self, sim: &Simulator) {
        self.run = RunState::Playing;
        self.resync(sim);
    }

    fn do_reset(&mut self, sim: &mut Simulator) -> Result<(), String> {
        sim.reset().map_err(|e| format!("reset failed: {e}"))?;
        self.step_failure = None;
        self.resync(sim);
        Ok(())
    }

    /// Steps `n` times while paused, stopping early at full deployment or a
    /// failed step; returns the steps taken and why it stopped early.
    pub fn step_paused(&mut self, sim: &mut Simulator, n: u64) -> (u64, Option<String>) {
        let mut done = 0;
        while done < n {
            if sim.state().deployed {
                return (done, Some("fully deployed: the state is held".into()));
            }
            if self.step_failure.is_some() {
                return (
                    done,
                    Some("a step failed earlier: reset to continue".into()),
                );
            }
            if let Err(e) = sim.step(self.dt) {
                let why = format!("step failed at t = {:.4} s: {e}", sim.state().t_s);
                self.step_failure = Some(why.clone());
                return (done, Some(why));
            }
            done += 1;
            self.steps += 1;
        }
        (done, None)
    }

    /// std_srvs/Trigger services: `which` is reset, pause, resume or step.
    pub fn trigger(&mut self, which: &str, sim: &mut Simulator) -> TriggerResponse {
        let t = sim.state().t_s;
        let (success, message) = match which {
            "reset" => match self.do_reset(sim) {
                Ok(()) => (
                    true,
                    "reset to t = 0 with the model's cable tensions".to_string(),
                ),
                Err(e) => (false, e),
            },
            "pause" => {
                self.run = RunState::Paused;
                (true, format!("paused at t = {t:.3} s"))
            }
            "resume" => {
                self.play(sim);
                (true, format!("running from t = {t:.3} s"))
            }
            _ => {
                self.run = RunState::Paused;
                match self.step_paused(sim, 1) {
                    (1, _) => (
                        true,
                        format!("one step of {} s from t = {t:.3} s; paused", self.dt),
                    ),
                    (_, why) => (false, why.unwrap_or_default()),
                }
            }
        };
        TriggerResponse { success, message }
    }

    pub fn features(&self) -> GetSimulatorFeaturesResponse {
        GetSimulatorFeaturesResponse {
            features: SimulatorFeatures {
                features: vec![
                    SIMULATION_RESET,
                    SIMULATION_STATE_GETTING,
                    SIMULATION_STATE_SETTING,
                    SIMULATION_STATE_PAUSE,
                    STEP_SIMULATION_SINGLE,
                    STEP_SIMULATION_MULTIPLE,
                    STEP_SIMULATION_ACTION,
                ],
                spawn_formats: Vec::new(),
                custom_info: format!(
                    "truss-deploy {}: deployment of space deployable trusses; reset is whole \
                     (time and state: SCOPE_DEFAULT or SCOPE_ALL); no entities or worlds; \
                     the SimulateSteps action at /truss/simulate_steps steps at the real-time \
                     factor",
                    env!("CARGO_PKG_VERSION")
                ),
            },
        }
    }

    /// Why the simulation holds its state (time does not advance) although
    /// it may be playing: a failed step (a failure result) or full deployment.
    pub fn held(&self, sim: &Simulator) -> Option<(u8, String)> {
        if let Some(why) = &self.step_failure {
            Some((
                RESULT_OPERATION_FAILED,
                format!("{why}; holding the last state: reset to continue"),
            ))
        } else if sim.state().deployed {
            Some((
                RESULT_OK,
                "fully deployed: holding the final state; reset to run again".into(),
            ))
        } else {
            None
        }
    }

    /// GetSimulationState. While the state is held (see [`Self::held`]) a
    /// playing simulation is reported PAUSED, with the reason in the result.
    pub fn state_msg(&self, sim: &Simulator) -> GetSimulationStateResponse {
        let held = self.held(sim);
        let (result, error_message) = held.clone().unwrap_or((RESULT_OK, String::new()));
        GetSimulationStateResponse {
            state: SimulationState {
                state: match self.run {
                    RunState::Playing if held.is_some() => STATE_PAUSED,
                    RunState::Playing => STATE_PLAYING,
                    RunState::Paused => STATE_PAUSED,
                    RunState::Stopped => STATE_STOPPED,
                },
            },
            result: SimResult {
                result,
                error_message,
            },
        }
    }

    /// SetSimulationState: PLAYING, PAUSED, STOPPED (= pause and reset).
    pub fn set_state(&mut self, target: u8, sim: &mut Simulator) -> ResultResponse {
        let now = self.run;
        let want = match target {
            STATE_PLAYING => RunState::Playing,
            STATE_PAUSED => RunState::Paused,
            STATE_STOPPED => RunState::Stopped,
            other => {
                return result(
                    RESULT_FEATURE_UNSUPPORTED,
                    format!(
                        "state {other} is not supported: use STATE_STOPPED (0), STATE_PLAYING (1) or STATE_PAUSED (2)"
                    ),
                )
            }
        };
        if want == RunState::Playing {
            if let Some((_, why)) = self.held(sim) {
                return result(RESULT_OPERATION_FAILED, format!("cannot play: {why}"));
            }
        }
        if want == now {
            return result(ALREADY_IN_TARGET_STATE, "already in the target state");
        }
        match want {
            RunState::Playing => self.play(sim),
            RunState::Paused => self.run = RunState::Paused,
            RunState::Stopped => {
                if let Err(e) = self.do_reset(sim) {
                    return result(RESULT_OPERATION_FAILED, e);
                }
                self.run = RunState::Stopped;
            }
        }
        result(RESULT_OK, "")
    }

    /// ResetSimulation: time and state together (scopes DEFAULT and ALL, or
    /// any scope with both TIME and STATE); the run state stays.
    pub fn reset(&mut self, scope: u8, sim: &mut Simulator) -> ResultResponse {
        let whole = scope == SCOPE_DEFAULT
            || scope == SCOPE_ALL
            || scope & (SCOPE_TIME | SCOPE_STATE) == (SCOPE_TIME | SCOPE_STATE);
        if !whole {
            return result(
                RESULT_FEATURE_UNSUPPORTED,
                format!(
                    "scope {scope}: this simulator resets time and state together \
                     (SCOPE_DEFAULT, SCOPE_ALL, or SCOPE_TIME|SCOPE_STATE)"
                ),
            );
        }
        match self.do_reset(sim) {
            Ok(()) => result(RESULT_OK, ""),
            Err(e) => result(RESULT_OPERATION_FAILED, e),
        }
    }

    /// StepSimulation: `steps` steps while paused (or stopped), then paused.
    pub fn step(&mut self, steps: u64, sim: &mut Simulator) -> ResultResponse {
        if self.run == RunState::Playing {
            // StepSimulation.srv: "Calling with simulation not paused will
            // return RESULT_OPERATION_FAILED and error message."
            return result(
                RESULT_OPERATION_FAILED,
                "the simulation is playing: pause it first (set_simulation_state PAUSED)",
            );
        }
        if steps == 0 || steps > MAX_STEPS_PER_CALL {
            return result(
                RESULT_OPERATION_FAILED,
                format!("steps = {steps}: ask for 1 to {MAX_STEPS_PER_CALL} steps per call"),
            );
        }
        self.run = RunState::Paused;
        match self.step_paused(sim, steps) {
            (_, None) => result(RESULT_OK, ""),
            (done, Some(why)) => result(
                RESULT_OPERATION_FAILED,
                format!("{done} of {steps} steps taken: {why}"),
            ),
        }
    }
}

const TRIGGERS: [&str; 4] = ["reset", "pause", "resume", "step"];

/// Every service of the node.
pub struct Services {
    trigger: Vec<Service<TriggerRequest, TriggerResponse>>,
    features: Service<EmptyRequest, GetSimulatorFeaturesResponse>,
    get_state: Service<EmptyRequest, GetSimulationStateResponse>,
    set_state: Service<SetSimulationStateRequest, ResultResponse>,
    reset: Service<ResetSimulationRequest, ResultResponse>,
    step: Service<StepSimulationRequest, ResultResponse>,
}

impl Services {
    /// Creates them under `<ns>/truss` (remappable).
    pub fn new(
        node: &mut Node,
        names: &super::Naming,
        forced: Option<ServiceMapping>,
    ) -> Result<Self, String> {
        let name = |b: &str| names.name(&format!("truss/{b}"));
        let si = |t: &str| ServiceTypeName::new("simulation_interfaces", t);
        let mut trigger = Vec::new();
        for b in TRIGGERS {
            trigger.push(Service::new(
                node,
                &name(b)?,
                &ServiceTypeName::new("std_srvs", "Trigger"),
                forced,
            )?);
        }
        Ok(Services {
            trigger,
            features: Service::new(
                node,
                &name("get_simulator_features")?,
                &si("GetSimulatorFeatures"),
                forced,
            )?,
            get_state: Service::new(
                node,
                &name("get_simulation_state")?,
                &si("GetSimulationState"),
                forced,
            )?,
            set_state: Service::new(
                node,
                &name("set_simulation_state")?,
                &si("SetSimulationState"),
                forced,
            )?,
            reset: Service::new(
                node,
                &name("reset_simulation")?,
                &si("ResetSimulation"),
                forced,
            )?,
            step: Service::new(
                node,
                &name("step_simulation")?,
                &si("StepSimulation"),
                forced,
            )?,
        })
    }

    /// Serves every pending request; returns how many there were.
    pub fn serve(
        &mut self,
        node: &Node,
        ctl: &mut Control,
        sim: &mut Simulator,
        now: Instant,
    ) -> usize {
        let mut n = 0;
        for (k, srv) in self.trigger.iter_mut().enumerate() {
            n += srv.serve(node, now, |_| ctl.trigger(TRIGGERS[k], sim));
        }
        n += self.features.serve(node, now, |_| ctl.features());
        n += self.get_state.serve(node, now, |_| ctl.state_msg(sim));
        n += self
            .set_state
            .serve(node, now, |r| ctl.set_state(r.state.state, sim));
        n += self.reset.serve(node, now, |r| ctl.reset(r.scope, sim));
        n += self.step.serve(node, now, |r| ctl.step(r.steps, sim));
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Options;

    fn mast() -> Simulator {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/pantograph_mast.toml");
        let model = crate::model::load(std::path::Path::new(path))
            .expect("bundled model")
            .model;
        Simulator::new(model, Options::default()).expect("simulator")
    }

    /// Every request type's CDR payload is shorter than the Cyclone header,
    /// so that the length tells the mappings apart (with Fast DDS padding to
    /// a multiple of 4 bytes).
    #[test]
    fn request_payloads_are_shorter_than_the_cyclone_header() {
        use ros2_client::dds::rustdds::serialization::to_writer_with_rep_id;
        use ros2_client::dds::rustdds::RepresentationIdentifier;
        fn cdr<T: serde::Serialize>(x: &T) -> usize {
            let mut v: Vec<u8> = Vec::new();
            to_writer_with_rep_id(&mut v, x, RepresentationIdentifier::CDR_LE).expect("serialize");
            v.len()
        }
        let sizes = [
            cdr(&TriggerRequest::default()),
            cdr(&EmptyRequest::default()),
            cdr(&SetSimulationStateRequest::default()),
            cdr(&ResetSimulationRequest::default()),
            cdr(&StepSimulationRequest { steps: u64::MAX }),
        ];
        assert_eq!(sizes, [1, 1, 1, 1, 8]);
        for s in sizes {
            assert!(s <= MAX_REQUEST_BYTES, "{sizes:?}");
            let padded = s.div_ceil(4) * 4;
            assert_eq!(request_mapping(padded, &[0; 16]), ServiceMapping::Enhanced);
            assert_eq!(
                request_mapping(CYCLONE_HEADER_BYTES + s, &[0; 16]),
                ServiceMapping::Cyclone
            );
        }
        // a parameter request is longer: the client's vendor decides
        let mut cyclone = [0u8; 16];
        cyclone[..2].copy_from_slice(&VENDOR_ECLIPSE_CYCLONE);
        let mut fast = [0u8; 16];
        fast[..2].copy_from_slice(&VENDOR_EPROSIMA_FASTDDS);
        assert_eq!(request_mapping(40, &fast), ServiceMapping::Enhanced);
        assert_eq!(request_mapping(4, &cyclone), ServiceMapping::Cyclone);
    }

    /// Pause, step, resume, stop and reset do what simulation_interfaces says,
    /// and a step while playing or of 0 steps is refused with the state kept.
    #[test]
    fn simulation_interfaces_state_machine() {
        let mut sim = mast();
        let dt = sim.model().dt_s;
        let mut c = Control::new(false, &sim, dt);
        assert_eq!(c.state_msg(&sim).state.state, STATE_PLAYING);
        let r = c.step(1, &mut sim);
        assert_eq!(
            r.result.result, RESULT_OPERATION_FAILED,
            "step while playing"
        );
        assert_eq!(sim.state().t_s, 0.0);
        assert_eq!(c.set_state(STATE_PAUSED, &mut sim).result.result, RESULT_OK);
        assert_eq!(
            c.set_state(STATE_PAUSED, &mut sim).result.result,
            ALREADY_IN_TARGET_STATE
        );
        assert_eq!(c.step(3, &mut sim).result.result, RESULT_OK);
        assert!(
            (sim.state().t_s - 3.0 * dt).abs() < 1e-12,
            "{}",
            sim.state().t_s
        );
        assert_eq!(c.steps, 3);
        assert_eq!(c.step(0, &mut sim).result.result, RESULT_OPERATION_FAILED);
        assert_eq!(
            c.step(MAX_STEPS_PER_CALL + 1, &mut sim).result.result,
            RESULT_OPERATION_FAILED
        );
        assert_eq!(c.state_msg(&sim).state.state, STATE_PAUSED);
        assert_eq!(
            c.set_state(STATE_PLAYING, &mut sim).result.result,
            RESULT_OK
        );
        assert!(!c.paused());
        assert_eq!(
            c.set_state(STATE_STOPPED, &mut sim).result.result,
            RESULT_OK
        );
        assert_eq!(c.state_msg(&sim).state.state, STATE_STOPPED);
        assert_eq!(sim.state().t_s, 0.0, "stopped = paused and reset");
        assert!(c.paused());
        assert_eq!(
            c.set_state(3, &mut sim).result.result,
            RESULT_FEATURE_UNSUPPORTED
        );
        // step from stopped: allowed, ends paused
        assert_eq!(c.step(2, &mut sim).result.result, RESULT_OK);
        assert_eq!(c.state_msg(&sim).state.state, STATE_PAUSED);
        assert_eq!(
            c.reset(SCOPE_TIME, &mut sim).result.result,
            RESULT_FEATURE_UNSUPPORTED
        );
        assert!(sim.state().t_s > 0.0, "a refused reset leaves the state");
        assert_eq!(c.reset(SCOPE_DEFAULT, &mut sim).result.result, RESULT_OK);
        assert_eq!(sim.state().t_s, 0.0);
        assert_eq!(
            c.state_msg(&sim).state.state,
            STATE_PAUSED,
            "reset keeps the run state"
        );
        let f = c.features().features.features;
        for x in [
            SIMULATION_RESET,
            STEP_SIMULATION_SINGLE,
            SIMULATION_STATE_PAUSE,
        ] {
            assert!(f.contains(&x), "{f:?}");
        }
    }

    /// Held after a failed step or at full deployment, a playing simulation is
    /// reported PAUSED with the reason, and PLAYING is refused until a reset.
    #[test]
    fn a_held_simulation_is_not_reported_playing() {
        let mut sim = mast();
        let dt = sim.model().dt_s;
        let mut c = Control::new(false, &sim, dt);
        c.step_failure = Some("step failed at t = 0.0000 s: test".into());
        let m = c.state_msg(&sim);
        assert_eq!(m.state.state, STATE_PAUSED);
        assert_eq!(m.result.result, RESULT_OPERATION_FAILED);
        assert!(m.result.error_message.contains("reset to continue"));
        let r = c.set_state(STATE_PLAYING, &mut sim);
        assert_eq!(
            r.result.result, RESULT_OPERATION_FAILED,
            "{}",
            r.result.error_message
        );
        assert_eq!(c.reset(SCOPE_DEFAULT, &mut sim).result.result, RESULT_OK);
        assert_eq!(
            c.state_msg(&sim).state.state,
            STATE_PLAYING,
            "the reset clears it"
        );
        // deployment: the mast at its model tension deploys within 600 steps
        for _ in 0..600 {
            if sim.state().deployed {
                break;
            }
            sim.step(dt).unwrap();
        }
        assert!(sim.state().deployed);
        let m = c.state_msg(&sim);
        assert_eq!((m.state.state, m.result.result), (STATE_PAUSED, RESULT_OK));
        assert!(m.result.error_message.contains("fully deployed"));
    }
}
