//! The stepping loop, as a pipeline of stages (one module each):
//!
//! ```text
//! step(dt) ─┬─ command changed? ── integrator::consistent_accelerations (restart)
//!           └─ per sub-step h:
//!                integrator::newmark ──── projection (positions, velocities)
//!                                         motor (speed-controlled cables)
//!                events::first_crossing ─ none ──────────────── ledger::accept
//!                        │ a crossing or a touch
//!                events::locate_latch (root of the step map) ── ledger::accept
//!                impact::latch (velocity jump, impulses, mobility)
//!                motor::motors_after_substep (release, engage)
//!                momentum::hold (a free-floating model's P and L)
//! ```
//!
//! Compliant elements and latches (`crate::solver::springs`) add their forces
//! in the integrator and their energy in the ledger. With elastic members the
//! Newmark iteration holds Phi + tau Phidot + c lambda = 0 and nothing is
//! projected. `core` holds the buffers, the Jacobian, the backend and the
//! counters; every numeric policy is the model's [`SolverSettings`].

mod core;
mod events;
mod impact;
mod integrator;
mod ledger;
mod momentum;
mod motor;
mod newton;
mod projection;
mod sim;
mod step;
mod work;

pub use sim::Simulator;
