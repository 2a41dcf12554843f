//! Speed-controlled motors (`Simulator::set_cable_speed`) against oracles
//! that need no simulator: the one-unit mast's kinematics under a cable
//! length prescribed in time (its tension in closed form from the power
//! balance), the energy ledger, and the drive's tension limit.

use truss_deploy::model::generate::{self, MastParams};
use truss_deploy::model::parse;
use truss_deploy::solver::state::MotorHold;
use truss_deploy::solver::{Options, Simulator};

/// A frictionless one-unit mast from 30 degrees, joint damping 0.3 N s/m:
/// one mechanism, whose motion has closed forms.
pub fn one_unit_mast() -> MastParams {
    MastParams {
        units: 1,
        friction_mu: 0.0,
        damping_n_s_per_m: 0.3,
        start_deg: 30.0,
        ..MastParams::default()
    }
}

fn mast_sim(p: &MastParams) -> Simulator {
    mast_sim_members(p, false)
}

/// The generated mast with rigid or elastic members (`[solver]
/// elastic_members`: the index-3 step, where the motor holds its length
/// inside the Newmark iteration instead of by projection).
fn mast_sim_members(p: &MastParams, elastic: bool) -> Simulator {
    let text = generate::mast(p).expect("valid params").to_toml();
    let text = format!("{text}\n[solver]\nelastic_members = {elastic}\n");
    let m = parse(&text, "mast.toml").expect("model loads").model;
    Simulator::new(m, Options::default()).expect("simulator")
}

/// The tension of a frictionless cable that reels a one-DOF mast in at the
/// constant speed s, from its kinematics alone: with L(phi) = (N+1) l cos phi
/// + N l and L(t) = L(phi0) - s t, phidot = s / ((N+1) l sin phi) and
/// phiddot = -phidot^2 cos phi / sin phi; with m(phi) = sum_i m_i |x_i'|^2
/// the kinetic energy is 1/2 m phidot^2, and the drive's power T s pays its
/// rate and the joint damping c sum_i |x_i'|^2 phidot^2:
///   T = (m phidot phiddot + sum_i m_i (x_i' . x_i'') phidot^3
///        + c sum_i |x_i'|^2 phidot^2) / s.
fn closed_form_tension(p: &MastParams, speed: f64, t: f64) -> (f64, f64) {
    let (n, l) = (p.units, p.rod_length_m);
    let nf = n as f64;
    let cos_phi = p.start_deg.to_radians().cos() - speed * t / ((nf + 1.0) * l);
    let phi = cos_phi.acos();
    let phid = speed / ((nf + 1.0) * l * phi.sin());
    let phidd = -phid * phid * phi.cos() / phi.sin();
    let d1 = generate::mast_velocity_coefficients(n, l, phi);
    // x'' of the closed form: level u's left joint (0, 0, -u l sin phi),
    // its right joint (-l cos phi, 0, -u l sin phi)
    let d2: Vec<[f64; 3]> = (0..=n)
        .flat_map(|u| {
            let z = -(u as f64) * l * phi.sin();
            [[0.0, 0.0, z], [-l * phi.cos(), 0.0, z]]
        })
        .collect();
    let (mut m_phi, mut m_dot) = (0.0, 0.0);
    for (a, b) in d1.iter().zip(&d2) {
        m_phi += a.iter().map(|v| v * v).sum::<f64>();
        m_dot += a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    }
    let mass = p.joint_mass_kg;
    let power = mass * m_phi * phid * phidd
        + mass * m_dot * phid.powi(3)
        + p.damping_n_s_per_m * m_phi * phid * phid;
    (power / speed, phi)
}

/// What a frictionless one-unit mast reeled in at 0.02 m/s does, against
/// its kinematics: steps checked while tracking, the largest
/// |L - (L(0) - s t)| (m), the largest relative errors against the closed
/// form of the motor's tension at the steps' ends and of its mean over each
/// step after the first (the motor's work over it by the cable reeled in,
/// against the closed form at the step's middle), the deploy time and the kinematics'
/// L(phi0) - L(phi_d) over s. Every step before the latch tracks; the latch
/// releases the motor to its tension limit.
fn one_unit_mast_at_speed(elastic: bool) -> (usize, f64, [f64; 2], f64, f64) {
    // (from 30 deg the cable stays taut at 0.02 m/s: nearer the flat state
    // the mast must slow faster than the damping slows it, and a cable
    // reeling in at a constant speed goes slack, as the closed form's
    // negative tension says)
    let p = one_unit_mast();
    let speed = 0.02;
    let mut sim = mast_sim_members(&p, elastic);
    sim.set_cable_speed(0, Some(speed)).expect("speed command");
    let l0 = sim.model().cables[0].length_m(&sim.model().x0);
    let (mut worst_len, mut worst_t, mut checked) = (0.0f64, [0.0f64; 2], 0);
    let dt = 0.05;
    while !sim.state().deployed {
        assert!(sim.state().t_s < 200.0, "not deployed by 200 s");
        let (work0, reeled0) = (
            sim.state().energy.motor_work_j,
            sim.state().reeled_in_m(sim.model(), 0),
        );
        sim.step(dt).expect("step");
        let s = sim.state();
        if s.deployed {
            break;
        }
        let mean_n = (s.energy.motor_work_j - work0) / (s.reeled_in_m(sim.model(), 0) - reeled0);
        let (t_mid, _) = closed_form_tension(&p, speed, s.t_s - 0.5 * dt);
        // (after the first step, which holds the engagement's transient)
        if checked > 0 {
            worst_t[1] = worst_t[1].max((mean_n - t_mid).abs() / t_mid);
        }
        assert_eq!(s.motors[0].hold, MotorHold::Tracking, "at t = {}", s.t_s);
        let len = sim.model().cables[0].length_m(&s.x);
        worst_len = worst_len.max((len - (l0 - speed * s.t_s)).abs());
        let (t_exact, _) = closed_form_tension(&p, speed, s.t_s);
        let rel = (s.motor_tension_n(0) - t_exact).abs() / t_exact.abs();
        worst_t[0] = worst_t[0].max(rel);
        checked += 1;
    }
    // deployed when the cable has been reeled in by L(phi0) - L(phi_d)
    let l_d = generate::mast_cable_length(1, p.rod_length_m, p.deploy_deg.to_radians());
    let t_d = (l0 - l_d) / speed;
    let t = sim.state().deploy_time_s.unwrap();
    eprintln!(
        "one-unit mast at {speed} m/s, elastic members {elastic}: {checked} steps, \
         |L - (L0 - s t)| <= {worst_len:.2e} m, tension rel. error <= {:.2e} at the steps' ends, \
         {:.2e} over each step, \
         deployed at {t} s (kinematics {t_d} s), {} sub-steps",
        worst_t[0],
        worst_t[1],
        sim.solver_stats().substeps
    );
    assert_eq!(sim.state().motors[0].hold, MotorHold::AtLimit);
    assert!(sim.solver_stats().motor_releases >= 1);
    (checked, worst_len, worst_t, t, t_d)
}

/// Rigid members: the cable length follows L(0) - s t to 1e-9 m at every
/// step, the motor's tension the closed form of the kinematics to 1e-6
/// (relative) and its mean over a step the closed form at the step's
/// middle to 1e-4 (the trapezoid's own difference, h^2 T''/8), the deploy
/// time the kinematics' to 1e-6 s.
#[test]
fn a_frictionless_one_unit_mast_follows_the_speed_and_its_tension_the_closed_form() {
    one_unit_mast_within(false, 1e-9, 1e-6);
}

/// Elastic members (the motor's length held at the step's end with the
/// members' relaxation, `motor_tensions`): the same oracles, the length to
/// 1e-8 m, the tension at the steps' ends and its mean over each step to
/// 1e-4 (measured 1.2e-5 and 8.7e-6), the deploy time to 1e-6 s. With
/// `restart_substeps = 0` (no backward-Euler sub-steps after the
/// engagement) the tension rings about the closed form by half its value;
/// with 1, by 4.5 %.
#[test]
fn with_elastic_members_the_one_unit_mast_follows_the_speed_and_the_closed_form() {
    one_unit_mast_within(true, 1e-8, 1e-4);
}

/// `one_unit_mast_at_speed` against its oracles: over 100 steps checked,
/// the length within `len_m`, the tension at the steps' ends within
/// `end_rel` and its step mean within 1e-4, the deploy time within 1e-6 s.
fn one_unit_mast_within(elastic: bool, len_m: f64, end_rel: f64) {
    let (checked, worst_len, worst_t, t, t_d) = one_unit_mast_at_speed(elastic);
    assert!(checked > 100, "{checked} steps checked");
    assert!(worst_len < len_m, "{worst_len}");
    assert!(worst_t[0] < end_rel && worst_t[1] < 1e-4, "{worst_t:?}");
    assert!(
        (t - t_d).abs() < 1e-6,
        "deployed at {t} s, the kinematics say {t_d} s"
    );
}

/// The four-unit mast with pulley friction and damping at a commanded
/// speed: the motor's work (its tension by the trapezoid over the cable
/// reeled in) equals the kinetic energy plus every loss, to 1e-6 of the
/// energy that flowed, over the whole deployment and its latch, with rigid
/// and with elastic members (their strain energy and dampers' loss among
/// the losses); the cable length follows L(0) - s t to 1e-9 m (rigid: by
/// projection) and 1e-8 m (elastic: held inside the step).
#[test]
fn a_speed_controlled_mast_with_friction_balances_its_motor_work() {
    for (elastic, len_tol) in [(false, 1e-9), (true, 1e-8)] {
        let p = MastParams {
            friction_mu: 0.1,
            damping_n_s_per_m: 0.5,
            start_deg: 30.0,
            ..MastParams::default()
        };
        let speed = 0.01;
        let mut sim = mast_sim_members(&p, elastic);
        sim.set_cable_speed(0, Some(speed)).expect("speed command");
        let l0 = sim.model().cables[0].length_m(&sim.model().x0);
        let mut worst_len = 0.0f64;
        while !sim.state().deployed {
            assert!(sim.state().t_s < 300.0, "not deployed by 300 s");
            sim.step(0.05).expect("step");
            let s = sim.state();
            if !s.deployed {
                let len = sim.model().cables[0].length_m(&s.x);
                worst_len = worst_len.max((len - (l0 - speed * s.t_s)).abs());
            }
        }
        for _ in 0..20 {
            sim.step(0.05).expect("step after the latch");
        }
        let s = sim.state();
        let e = &s.energy;
        let kinetic = s.kinetic_energy_j(sim.model());
        let spent = kinetic
            + e.friction_loss_j
            + e.damping_loss_j
            + e.lock_loss_j
            + e.latch_damping_loss_j
            + e.latch_spring_energy_j
            + e.element_spring_energy_j
            + e.member_strain_energy_j
            + e.member_damping_loss_j
            - e.gravity_work_j
            - e.integrator_work_j;
        let rel = (e.motor_work_j - spent).abs() / e.motor_work_j.abs();
        eprintln!(
            "four-unit mast at {speed} m/s, mu 0.1, elastic members {elastic}: deployed at {:?} s, \
             motor work {:.6e} J, kinetic + losses {spent:.6e} J, rel {rel:.2e}, friction {:.3e} J, \
             |L - (L0 - s t)| <= {worst_len:.2e} m",
            s.deploy_time_s, e.motor_work_j, e.friction_loss_j
        );
        assert!(
            e.friction_loss_j > 1e-3 * e.motor_work_j,
            "friction took {}",
            e.friction_loss_j
        );
        assert!(rel < 1e-6, "motor work vs kinetic + losses: {rel:e}");
        assert!(s.energy.balance_rel_error(kinetic) < 1e-6);
        assert!(worst_len < len_tol, "{worst_len}");
    }
}

/// A speed the drive cannot hold against the damping: the motor releases to
/// its tension limit, pulls at that limit (never above it) and reels in
/// slower than commanded; a speed it can hold is held.
#[test]
fn the_tension_limit_stops_a_motor_that_cannot_hold_its_speed() {
    let p = MastParams {
        friction_mu: 0.0,
        damping_n_s_per_m: 5.0,
        max_tension_n: 0.5,
        start_deg: 30.0,
        ..MastParams::default()
    };
    // the tension that holds a speed at the start: the damping's, about
    // c m_phi phidot^2 / s (the inertia's share is small at low speed)
    let holds = |speed: f64| -> (MotorHold, f64, f64) {
        let mut sim = mast_sim(&p);
        sim.set_cable_speed(0, Some(speed)).unwrap();
        let mut top = 0.0f64;
        for _ in 0..40 {
            sim.step(0.05).unwrap();
            top = top.max(sim.state().motor_tension_n(0));
        }
        let s = sim.state();
        (s.motors[0].hold, top, s.reel_in_rate_m_s(sim.model(), 0))
    };
    let (hold, top, rate) = holds(0.2);
    eprintln!("0.2 m/s: {hold:?}, top tension {top} N, reel-in rate {rate} m/s");
    assert_eq!(hold, MotorHold::AtLimit);
    assert!(top <= 0.5, "tension {top} N above the 0.5 N limit");
    assert!(
        rate > 0.0 && rate < 0.2,
        "reel-in rate {rate} m/s at the limit"
    );
    let (hold, top, rate) = holds(0.005);
    eprintln!("0.005 m/s: {hold:?}, top tension {top} N, reel-in rate {rate} m/s");
    assert_eq!(hold, MotorHold::Tracking);
    assert!(top < 0.5);
    assert!((rate - 0.005).abs() < 1e-9, "reel-in rate {rate} m/s");
}

/// Bad speed commands are refused with a reason, and a tension command
/// returns the motor to tension control.
#[test]
fn speed_commands_are_checked_and_a_tension_command_ends_them() {
    let mut sim = mast_sim(&MastParams {
        start_deg: 30.0,
        damping_n_s_per_m: 0.5,
        ..MastParams::default()
    });
    assert!(sim.set_cable_speed(3, Some(0.1)).is_err());
    let e = sim.set_cable_speed(0, Some(f64::NAN)).unwrap_err();
    assert!(e.to_string().contains("finite"), "{e}");
    sim.set_cable_speed(0, Some(0.01)).unwrap();
    sim.step(0.05).unwrap();
    assert_eq!(sim.state().motors[0].hold, MotorHold::Tracking);
    sim.set_cable_tension(0, 0.05).unwrap();
    assert_eq!(sim.state().motors[0].hold, MotorHold::Tension);
    sim.step(0.05).unwrap();
    assert_eq!(sim.state().motor_tension_n(0), 0.05);
}

/// Reeled in at a constant speed from near its flat state, the mast must
/// slow faster than its damping slows it: the closed form's tension is
/// negative there, so the cable goes slack (the motor at zero tension) and
/// takes up again once the mast runs no faster than the cable. The
/// take-up's velocity jump is booked as the drive's work (exact), so what
/// the ledger misses is the integrator's error, of second order: it falls
/// about fourfold when the step halves.
#[test]
fn a_cable_reeled_in_from_near_flat_goes_slack_and_takes_up_again() {
    let p = MastParams {
        friction_mu: 0.1,
        damping_n_s_per_m: 0.2,
        ..MastParams::default()
    };
    let run = |dt: f64, step_control: bool| -> f64 {
        // (without the ledger's step-size control, which bounds the miss per
        // second whatever the step, the plain integrator's order shows)
        let text = generate::mast(&p).unwrap().to_toml();
        let mut m = parse(&text, "mast.toml").unwrap().model;
        if !step_control {
            m.solver.ledger_budget_rel_per_s = 0.0;
        }
        let mut sim = Simulator::new(m, Options::default()).unwrap();
        sim.set_cable_speed(0, Some(0.05)).unwrap();
        let mut seen_slack = false;
        while !sim.state().deployed {
            assert!(sim.state().t_s < 100.0, "not deployed by 100 s");
            sim.step(dt).unwrap();
            let s = sim.state();
            seen_slack |= s.motors[0].hold == MotorHold::Slack;
            assert!(s.motor_tension_n(0) >= 0.0 && s.motor_tension_n(0) <= 1.0);
        }
        let (s, stats) = (sim.state(), sim.solver_stats());
        let balance = s.energy.balance_rel_error(s.kinetic_energy_j(sim.model()));
        eprintln!(
            "from 5 deg at 0.05 m/s, dt {dt}, step control {step_control}: slack seen {seen_slack}, {} releases, {} engagements, \
             deployed at {:?} s, balance {balance:.2e}",
            stats.motor_releases, stats.motor_engagements, s.deploy_time_s
        );
        assert!(seen_slack);
        assert!(stats.motor_engagements >= 2, "{}", stats.motor_engagements);
        balance
    };
    let controlled = run(0.05, true);
    assert!(controlled < 1e-5, "{controlled:e}");
    let (coarse, fine) = (run(0.05, false), run(0.025, false));
    assert!(
        fine < coarse / 3.0,
        "balance {coarse:e} at dt 0.05, {fine:e} at dt 0.025"
    );
}

/// The synchronized ring has one mechanism and two drive cables: with rigid
/// members both at a speed would ask one motion for two speeds (the
/// motors' system is singular in its second column). The second speed
/// command is refused, naming both cables, and leaves the state and that
/// cable's motor as they were (at its tension); the ring steps on under the
/// first. With elastic members the members' stretch takes the difference
/// (the system's second pivot is 1.3e-3 of the first, not 1e-13): both
/// commands are taken, and the motors pull against each other through the
/// members until one is at its tension limit.
#[test]
fn two_speed_controlled_cables_on_one_motion_are_refused_by_name() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models/double_ring_synchronized.toml");
    for elastic in [false, true] {
        let mut model = truss_deploy::model::load(&path)
            .expect("bundled model")
            .model;
        model.solver.elastic_members = elastic;
        assert_eq!(model.cables.len(), 2);
        let names: Vec<String> = model.cables.iter().map(|c| c.name.clone()).collect();
        let mut sim = Simulator::new(model, Options::default()).expect("simulator");
        sim.set_cable_speed(0, Some(0.1)).unwrap();
        let (v, energy) = (sim.state().v.clone(), sim.state().energy.clone());
        let motor = sim.state().motors[1].clone();
        let cmd_n = sim.state().cable_tension_cmd_n.clone();
        let second = sim.set_cable_speed(1, Some(0.1));
        if elastic {
            assert!(second.is_ok(), "{second:?}");
            assert_eq!(sim.state().motors[1].hold, MotorHold::Tracking);
            sim.step(0.05).unwrap();
            // (both at their speed, pulling against each other through the
            // members: in the first step one reaches its tension limit)
            let s = sim.state();
            assert!(s.motors.iter().all(|m| m.speed_cmd_m_s == Some(0.1)));
            assert!(s.motors.iter().any(|m| m.hold == MotorHold::Tracking));
            assert!(s.motors.iter().any(|m| m.hold == MotorHold::AtLimit));
        } else {
            let e = second.unwrap_err().to_string();
            assert!(
                e.contains("same motion") && e.contains(&names[0]) && e.contains(&names[1]),
                "{e}"
            );
            assert_eq!(sim.state().v, v);
            assert_eq!(sim.state().energy, energy);
            assert_eq!(sim.state().motors[1], motor);
            assert_eq!(sim.state().cable_tension_cmd_n, cmd_n);
            assert_eq!(sim.state().motors[1].hold, MotorHold::Tension);
        }
        for _ in 0..4 {
            sim.step(0.05).unwrap();
        }
        // (with elastic members the two motors pull against each other
        // through the members until one's tension leaves its range)
        if !elastic {
            assert_eq!(sim.state().motors[0].hold, MotorHold::Tracking);
        }
        assert!(sim.state().reeled_in_m(sim.model(), 0) > 0.0);
    }
}

/// A released motor whose engagement conflicts with a tracking one (rigid
/// members, the synchronized ring's two cables on one motion) stays released,
/// tried again once per step, not at every sub-step: the outer cable
/// (`outer_drive`), held to 2 N at 0.05 m/s, releases at once; the inner one
/// then tracks 0.1 m/s and runs the outer cable faster than its 0.05 m/s, so
/// that it would engage but cannot. Steps of STEP_S take several sub-steps.
#[test]
fn a_conflicting_engagement_is_tried_once_per_step() {
    const STEP_S: f64 = 0.5;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models/double_ring_synchronized.toml");
    let mut model = truss_deploy::model::load(&path)
        .expect("bundled model")
        .model;
    assert!(!model.solver.elastic_members);
    assert_eq!(model.cables[0].name, "outer_drive");
    model.cables[0].max_tension_n = 2.0;
    let mut sim = Simulator::new(model, Options::default()).expect("simulator");
    sim.set_cable_tension(1, 0.0).unwrap();
    sim.set_cable_speed(0, Some(0.05)).unwrap();
    sim.step(0.05).unwrap();
    assert_eq!(sim.state().motors[0].hold, MotorHold::AtLimit);
    sim.set_cable_speed(1, Some(0.1)).unwrap();
    assert_eq!(sim.state().motors[1].hold, MotorHold::Tracking);
    let (steps, before) = (8, sim.solver_stats().substeps);
    for _ in 0..steps {
        sim.step(STEP_S).unwrap();
    }
    let (s, st) = (sim.state(), sim.solver_stats());
    let substeps = st.substeps - before;
    println!(
        "{substeps} sub-steps in {steps} steps, {} conflicts, {} releases, {} engagements",
        st.motor_conflicts, st.motor_releases, st.motor_engagements
    );
    assert_eq!(s.motors[0].hold, MotorHold::AtLimit);
    assert_eq!(s.motors[1].hold, MotorHold::Tracking);
    assert!(s.reeled_in_m(sim.model(), 0) > 0.05 * s.t_s);
    assert!(st.motor_conflicts >= 1, "the engagement was tried");
    // (once per step or change of the motors, where the steps take several sub-steps)
    assert!(substeps >= 2 * steps, "{substeps} sub-steps");
    assert!(
        st.motor_conflicts <= steps + st.motor_releases + st.motor_engagements,
        "{st:?}"
    );
}

/// A speed command on a deployed mast, which no cable can move (every
/// sleeve latched: no mechanism), leaves its motor at the tension limit
/// instead of engaging it; the mast then holds.
#[test]
fn a_speed_command_on_a_locked_structure_leaves_the_motor_at_its_limit() {
    let mut sim = mast_sim(&MastParams::default());
    for _ in 0..2000 {
        if sim.state().deployed {
            break;
        }
        sim.step(0.05).unwrap();
    }
    assert!(sim.state().deployed && sim.state().mechanisms == 0);
    sim.set_cable_speed(0, Some(0.1)).unwrap();
    assert_eq!(sim.state().motors[0].hold, MotorHold::AtLimit);
    let max = sim.model().cables[0].max_tension_n;
    let x = sim.state().x.clone();
    sim.step(0.05).unwrap();
    assert_eq!(sim.state().motor_tension_n(0), max);
    let moved = x
        .iter()
        .zip(&sim.state().x)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(moved < 1e-9, "moved {moved} m");
}
