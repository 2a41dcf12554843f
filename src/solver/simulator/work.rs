//! The stages' buffers that the workspace (`Core`) holds: the Newton
//! steps' and the speed-controlled motors'. A leaf of the simulator's
//! modules: the stages that use them import it, it imports none of them.

use crate::solver::linsolve::gmres::Gmres;
use crate::solver::linsolve::solve_small;
use crate::solver::model::Model;
use crate::solver::state::{MotorHold, State};
use crate::solver::{MotorConflict, SolverError};

/// Buffers of the Newton steps (made once; rows-sized ones follow the pattern).
pub(super) struct NewtonWork {
    pub(super) n: usize,
    /// The accepted iterate, its residual G(A) - A and kinetic norm; direction; step fraction.
    pub(super) a_acc: Vec<f64>,
    pub(super) r_acc: Vec<f64>,
    pub(super) norm_acc: f64,
    pub(super) dir: Vec<f64>,
    pub(super) alpha: f64,
    /// Line search: trials since the last accepted iterate, the bracket's ends (alpha, <R, d>) on
    /// the accepted side and across the sign change, and which end the last trial replaced.
    pub(super) trials: usize,
    pub(super) lo: (f64, f64),
    pub(super) hi: Option<(f64, f64)>,
    pub(super) kept_side: i8,
    pub(super) r_dir0: f64,
    /// The largest |G' v| over the GMRES basis vectors (unit kinetic norm) of this Newmark step's
    /// Newton steps: the friction blend's stiffness h/2 |P M^-1 dQ/dV| seen by the iteration
    /// (1 and above: it alone makes the plain iteration diverge).
    pub gain: f64,
    /// The directions take the friction's secant slopes back to the step
    /// start: the Newton steps' retry after a failed line search.
    pub secant: bool,
    pub(super) gmres: Gmres,
    // operator work: dv, dQ, the constrained response, multipliers, zero c
    pub(super) dv: Vec<f64>,
    pub(super) dq: Vec<f64>,
    pub(super) da: Vec<f64>,
    pub(super) lambda: Vec<f64>,
    pub(super) zero_c: Vec<f64>,
}

impl NewtonWork {
    pub fn new(kmax: usize, n: usize, rows: usize) -> NewtonWork {
        NewtonWork {
            n,
            a_acc: vec![0.0; n],
            r_acc: vec![0.0; n],
            norm_acc: f64::INFINITY,
            dir: vec![0.0; n],
            alpha: 1.0,
            trials: 0,
            lo: (0.0, 0.0),
            hi: None,
            kept_side: 0,
            r_dir0: 0.0,
            gain: 0.0,
            secant: false,
            gmres: Gmres::new(kmax, n),
            dv: vec![0.0; n],
            dq: vec![0.0; n],
            da: vec![0.0; n],
            lambda: vec![0.0; rows],
            zero_c: vec![0.0; rows],
        }
    }

    /// Rows-sized buffers for a new Jacobian pattern.
    pub fn set_rows(&mut self, rows: usize) {
        self.lambda.resize(rows, 0.0);
        self.zero_c.resize(rows, 0.0);
    }
}

/// Buffers of the motors' solves, reused across steps.
#[derive(Debug, Default)]
pub(super) struct MotorWork {
    /// Per cable: the reel-in speed while it tracks in the trial (m/s), else None.
    pub speed_m_s: Vec<Option<f64>>,
    /// Per cable: its engagement conflicted with the tracking motors (a singular system depends on
    /// the configuration): not tried again in this step unless a motor releases or engages.
    pub conflicted: Vec<bool>,
    /// Per cable: the length it holds at the trial's end (m), while it tracks.
    pub target_m: Vec<f64>,
    /// Per cable: joint forces of a unit tension (or grad L), the responses to them (A, lambda).
    pub(super) g: Vec<Vec<f64>>,
    pub(super) resp: Vec<Vec<f64>>,
    pub(super) resp_lambda: Vec<Vec<f64>>,
    pub(super) a0: Vec<f64>,
    pub(super) lambda0: Vec<f64>,
    pub(super) q_save: Vec<f64>,
    /// Per cable: its mobility were the structure free, the scale of its diagonal
    /// (`Core::motor_responses`); and a joint-sized scratch.
    pub(super) free: Vec<f64>,
    pub(super) scratch: Vec<f64>,
    pub(super) c_save: Vec<f64>,
    /// The k x k system (row-major) and its right side / solution, in the tracking cables' order.
    pub(super) mat: Vec<f64>,
    pub(super) rhs: Vec<f64>,
    pub(super) order: Vec<usize>,
}

impl MotorWork {
    pub fn new(model: &Model, rows: usize) -> MotorWork {
        let (n, nc) = (model.n_coords(), model.cables.len());
        MotorWork {
            speed_m_s: vec![None; nc],
            conflicted: vec![false; nc],
            target_m: vec![0.0; nc],
            g: vec![vec![0.0; n]; nc],
            resp: vec![vec![0.0; n]; nc],
            resp_lambda: vec![vec![0.0; rows]; nc],
            a0: vec![0.0; n],
            lambda0: vec![0.0; rows],
            q_save: vec![0.0; n],
            free: vec![0.0; nc],
            scratch: vec![0.0; n],
            c_save: vec![0.0; rows],
            mat: Vec::with_capacity(nc * nc),
            rhs: Vec::with_capacity(nc),
            order: Vec::with_capacity(nc),
        }
    }

    pub fn set_rows(&mut self, rows: usize) {
        for b in self.resp_lambda.iter_mut() {
            b.resize(rows, 0.0);
        }
        self.lambda0.resize(rows, 0.0);
        self.c_save.resize(rows, 0.0);
    }

    /// Solves the k x k system in `mat`, `rhs` (its solution into `rhs`); an error naming the
    /// cable where a diagonal is below `motor_pivot_rel` of its free value (the structure cannot
    /// move along it), or the cables where a pivot is below that of the largest diagonal (two
    /// motors move it alike).
    pub(super) fn solve(&mut self, model: &Model) -> Result<(), SolverError> {
        // (the diagonal grad L . d is the structure's mobility along the cable)
        let (k, tiny) = (self.rhs.len(), model.solver.motor_pivot_rel);
        let diag = |i: usize| self.mat[i * k + i];
        // (both negative for a tension, whose pull shortens the cable)
        let immobile = (0..k).find(|&i| !(diag(i) / self.free[self.order[i]] > tiny));
        let col = match immobile {
            Some(i) => i,
            None => match solve_small(&mut self.mat, &mut self.rhs, tiny) {
                Ok(()) => return Ok(()),
                Err(col) => col,
            },
        };
        let name = |oi: usize| model.cables[self.order[oi]].name.clone();
        Err(SolverError::MotorConflict(if immobile.is_some() {
            MotorConflict::Immobile { cable: name(col) }
        } else {
            MotorConflict::SameMotion {
                cable: name(col),
                others: (0..col).map(name).collect(),
            }
        }))
    }

    /// The tracking cables, in order, into `order`.
    pub(super) fn take_order(&mut self) {
        self.order.clear();
        let tracking = self
            .speed_m_s
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_some());
        self.order.extend(tracking.map(|(ci, _)| ci));
    }

    /// The largest |L_i(x) - target_i| over the tracking motors (m).
    pub fn length_miss_m(&self, model: &Model, x: &[f64]) -> f64 {
        (0..model.cables.len())
            .filter(|&ci| self.speed_m_s[ci].is_some())
            .map(|ci| (model.cables[ci].length_m(x) - self.target_m[ci]).abs())
            .fold(0.0, f64::max)
    }

    pub fn any_tracking(&self) -> bool {
        self.speed_m_s.iter().any(Option::is_some)
    }

    /// Takes the tracking motors of the state (their speeds), for solves at the state's time.
    pub fn take_modes(&mut self, s: &State) {
        for (w, m) in self.speed_m_s.iter_mut().zip(&s.motors) {
            *w = match m.hold {
                MotorHold::Tracking => m.speed_cmd_m_s,
                _ => None,
            };
        }
    }

    /// Motor `ci` at its commanded speed, with the state's tracking motors (`others`) or alone.
    pub(super) fn take_modes_with(&mut self, s: &State, ci: usize, others: bool) {
        if others {
            self.take_modes(s);
        } else {
            self.speed_m_s.fill(None);
        }
        self.speed_m_s[ci] = s.motors[ci].speed_cmd_m_s;
    }

    /// The lengths the tracking motors hold at the end of a trial of length h: L_ref - s h.
    pub fn set_targets(&mut self, s: &State, h: f64) {
        for (ci, m) in s.motors.iter().enumerate() {
            if let Some(speed) = self.speed_m_s[ci] {
                self.target_m[ci] = m.length_ref_m - speed * h;
            }
        }
    }
}
