//! Stage `events`: lock conditions inside a trial step.
//!
//! Every lockable element describes its lock condition (`Constraint::
//! lock_condition`: a signed gap g whose zero is the latch, and its rate).
//! When g changes sign inside the step, or the step's cubic Hermite
//! interpolant shows it touching zero and turning back (both ends on the
//! same side; confirmed on the step map), the step is redone with the length
//! h* at which g(h*) = 0 (root of the step map itself, by the Illinois
//! method). The impact stage then latches the element.
//!
//! Give-ups: a root search that ends at its iteration limit with |g| above
//! the latch tolerance is an error (`SolverError::LatchSearch`); a lockable
//! element found past its lock without latching after a latch event is an
//! error (`SolverError::MissedLatch`); a touch whose check step fails fails
//! the sub-step (retried shorter, as any failed sub-step).

use super::Simulator;
use crate::solver::elements::Constraint;
use crate::solver::linsolve::SolveMode;
use crate::solver::model::Model;
use crate::solver::SolverError;

/// The lock gap of element e at x (NaN for an element that does not lock).
pub(super) fn gap(model: &Model, e: usize, x: &[f64]) -> f64 {
    model.elements[e].lock_gap(x).unwrap_or(f64::NAN)
}

/// The first lockable element (other than `except`, not `held`: latched or
/// engaging) whose gap has changed sign between x0 and x1 and ended more than
/// `tol` past zero.
pub(super) fn crossed_unlatched(
    model: &Model,
    held: &dyn Fn(usize) -> bool,
    x0: &[f64],
    x1: &[f64],
    tol: f64,
    except: Option<usize>,
) -> Option<usize> {
    model.locks.iter().copied().find(|&e| {
        if Some(e) == except || held(e) {
            return false;
        }
        let (g0, g1) = (gap(model, e, x0), gap(model, e, x1));
        g0 != 0.0 && g0 * g1 < 0.0 && g1.abs() > tol
    })
}

/// The cubic Hermite basis at fraction s of a step: [h00, h10, h01, h11],
/// p(s) = h00 p0 + h10 h p0' + h01 p1 + h11 h p1'.
pub(super) fn hermite_basis(s: f64) -> [f64; 4] {
    let (s2, s3) = (s * s, s * s * s);
    [
        2.0 * s3 - 3.0 * s2 + 1.0,
        s3 - 2.0 * s2 + s,
        -2.0 * s3 + 3.0 * s2,
        s3 - s2,
    ]
}

/// Writes the cubic Hermite interpolant, at fraction s of a step of length h,
/// of the joints `joints` into `out` (other entries untouched).
fn hermite_joints(
    (x0, v0, x1, v1): (&[f64], &[f64], &[f64], &[f64]),
    h: f64,
    s: f64,
    joints: &[usize],
    out: &mut [f64],
) {
    let [h00, h10, h01, h11] = hermite_basis(s);
    for &j in joints {
        for i in 3 * j..3 * j + 3 {
            out[i] = h00 * x0[i] + h10 * h * v0[i] + h01 * x1[i] + h11 * h * v1[i];
        }
    }
}

/// The element's gap along the step's interpolant at fraction s (the
/// element's own joints are interpolated into `scratch`).
fn interpolated_gap(
    el: &dyn Constraint,
    ends: (&[f64], &[f64], &[f64], &[f64]),
    h: f64,
    s: f64,
    scratch: &mut [f64],
) -> f64 {
    hermite_joints(ends, h, s, el.joints(), scratch);
    el.lock_gap(scratch).unwrap_or(f64::NAN)
}

impl Simulator {
    /// The unlocked element whose gap reaches zero first in the trial step, by
    /// the Hermite interpolant of the step, with the fraction s_hi of the step
    /// by which it has crossed: 1 when the gap changes sign over the step, less
    /// when it touches zero and turns back inside the step (both ends on the
    /// same side; s_hi is then the interpolant's turning point).
    /// Dips of the elements in `no_dips` (found not real on the step map) are
    /// not considered again; their sign changes are.
    pub(super) fn first_crossing(&mut self, h: f64, no_dips: &[usize]) -> Option<(usize, f64)> {
        let (model, s, c, st) = (&self.model, &self.state, &self.core, &self.settings);
        let scratch = &mut self.interp;
        let ends = (&s.x[..], &s.v[..], &c.x[..], &c.v[..]);
        let iterations = st.dip_search_iterations;
        let mut best: Option<(f64, usize, f64)> = None;
        for &e in &model.locks {
            if s.locked[e] || super::impact::engaging(s, c, e) {
                continue;
            }
            let el = model.elements[e].as_ref();
            let (Some(c0), Some(c1)) =
                (el.lock_condition(&s.x, &s.v), el.lock_condition(&c.x, &c.v))
            else {
                continue;
            };
            let (g0, g1) = (c0.gap_m, c1.gap_m);
            if g0 == 0.0 || g0.is_nan() || g1.is_nan() {
                continue;
            }
            // A sign change over the step, or else a touch and turn: the gap
            // closes at the start (g0 gdot0 < 0) and opens at the end
            // (g1 gdot1 > 0); then the interpolant's extremum (golden section
            // on the g0-signed gap, unimodal over one turn) decides.
            let crossed = g0 * g1 <= 0.0;
            if !crossed
                && (no_dips.contains(&e) || !(g0 * c0.rate_m_s < 0.0 && g1 * c1.rate_m_s > 0.0))
            {
                continue;
            }
            let mut g_at = |sf: f64| interpolated_gap(el, ends, h, sf, scratch);
            let s_hi = if crossed {
                1.0
            } else {
                let mut f = |sf: f64| g0.signum() * g_at(sf);
                let r = 0.5 * (5f64.sqrt() - 1.0);
                let (mut lo, mut hi) = (0.0, 1.0);
                let (mut m1, mut m2) = (hi - r * (hi - lo), lo + r * (hi - lo));
                let (mut f1, mut f2) = (f(m1), f(m2));
                for _ in 0..iterations {
                    if f1 < f2 {
                        hi = m2;
                        (m2, f2) = (m1, f1);
                        m1 = hi - r * (hi - lo);
                        f1 = f(m1);
                    } else {
                        lo = m1;
                        (m1, f1) = (m2, f2);
                        m2 = lo + r * (hi - lo);
                        f2 = f(m2);
                    }
                }
                let s_min = 0.5 * (lo + hi);
                if f(s_min) >= 0.0 {
                    continue;
                }
                s_min
            };
            // bisection on the interpolant for the fraction of the step
            let (mut lo, mut hi) = (0.0, s_hi);
            for _ in 0..iterations {
                let mid = 0.5 * (lo + hi);
                if g_at(mid) * g0 > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if best.map_or(true, |(sb, _, _)| hi < sb) {
                best = Some((hi, e, s_hi));
            }
        }
        best.map(|(_, e, s_hi)| (e, s_hi))
    }

    /// Finds h* in (0, h] with gap_target(step(h*)) = 0 by the Illinois method on the
    /// step map, leaving the trial at h*. If another element turns out to cross
    /// earlier, it becomes the target. Every trial step solves in least
    /// squares: they all lie just short of a latch, typically the flat
    /// deployed state where redundant rows are only nearly redundant.
    ///
    /// `s_hi` < 1 (a touch and turn inside the step): the step map is first
    /// evaluated at s_hi h for a bracket. A gap there within the latch
    /// tolerance is a touch: h* = s_hi h. A gap that has not crossed after
    /// all (the interpolant's dip was not real) gives None, with the trial
    /// left at whatever it last computed; a failed step there is the error.
    pub(super) fn locate_latch(
        &mut self,
        mut target: usize,
        h: f64,
        s_hi: f64,
    ) -> Result<Option<f64>, SolverError> {
        let st = &self.settings;
        let mode = SolveMode::MinNorm;
        self.core.stats.latch_searches += 1;
        let mut b = h;
        if s_hi < 1.0 {
            b = s_hi * h;
            self.core.stats.latch_search_steps += 1;
            // (a check step that fails fails the sub-step, which is then
            // retried shorter: a touch is not dropped unchecked)
            self.core.newmark(&self.model, &self.state, b, st, mode)?;
            // An element that has crossed by then comes first (e.g. the ring's
            // diagonals, just before its radial sleeves touch at the flat state).
            if let Some(other) = self.crossed_by(target) {
                target = other;
            } else {
                let (g0, gb) = (
                    gap(&self.model, target, &self.state.x),
                    gap(&self.model, target, &self.core.x),
                );
                if gb.abs() <= st.lock_tol_m {
                    return Ok(Some(b));
                }
                if gb * g0 > 0.0 {
                    return Ok(None);
                }
            }
        }
        let g0 = gap(&self.model, target, &self.state.x);
        let (mut a, mut ga) = (0.0, g0);
        let mut gb = gap(&self.model, target, &self.core.x);
        let mut side = 0i32;
        let mut iterations = 0;
        while iterations < self.settings.root_max_iterations {
            iterations += 1;
            // Illinois step (regula falsi with halving of the stale end)
            let mut m = (a * gb - b * ga) / (gb - ga);
            if !(m > a && m < b) {
                m = 0.5 * (a + b);
            }
            self.search_step(m)?;
            let st = &self.settings;
            let gm = gap(&self.model, target, &self.core.x);
            // did another element already cross before m?
            if let Some(other) = self.crossed_by(target) {
                target = other;
                a = 0.0;
                ga = gap(&self.model, target, &self.state.x);
                b = m;
                gb = gap(&self.model, target, &self.core.x);
                side = 0;
                // (a crossing within a vanishing part of the sub-step: the
                // step's projection carried the sleeves across, not the
                // motion, and nothing locates it in time)
                if b <= st.root_bracket_rel * h {
                    break;
                }
                continue;
            }
            if gm.abs() <= st.root_tol_m || (b - a) <= st.root_bracket_rel * h {
                return Ok(Some(m));
            }
            if gm * ga > 0.0 {
                a = m;
                ga = gm;
                if side == -1 {
                    gb *= 0.5;
                }
                side = -1;
            } else {
                b = m;
                gb = gm;
                if side == 1 {
                    ga *= 0.5;
                }
                side = 1;
            }
        }
        // Iteration limit: the far end of the bracket is accepted when the
        // latch will take it (within the latch tolerance; a counted
        // fallback), else the search has failed.
        self.search_step(b)?;
        let st = &self.settings;
        let gb = gap(&self.model, target, &self.core.x);
        if gb.abs() <= st.latch_tol_m() {
            self.core.stats.fallbacks.root_search_limit += 1;
            return Ok(Some(b));
        }
        Err(SolverError::LatchSearch {
            element: self.model.elements[target].name().to_string(),
            t_s: self.state.t_s + b,
            gap_m: gb,
            iterations,
        })
    }

    /// One trial step of length h of a latch search, in least squares (the
    /// trials lie just short of a latch); where that iteration does not
    /// converge, once more with basic solves (a counted fallback: near a
    /// latch whose rows are nearly redundant with others, the least-squares
    /// map can stall where the basic one, which drops them, contracts).
    fn search_step(&mut self, h: f64) -> Result<(), SolverError> {
        let st = &self.settings;
        self.core.stats.latch_search_steps += 1;
        match self
            .core
            .newmark(&self.model, &self.state, h, st, SolveMode::MinNorm)
        {
            Err(SolverError::NoConvergence { .. }) => {
                self.core.stats.fallbacks.latch_search_basic += 1;
                self.core.stats.latch_search_steps += 1;
                self.core
                    .newmark(&self.model, &self.state, h, st, SolveMode::Basic)
            }
            other => other,
        }
    }

    /// Another unlocked element whose gap has changed sign (beyond the latch
    /// tolerance) in the current trial.
    fn crossed_by(&self, target: usize) -> Option<usize> {
        let s = &self.state;
        crossed_unlatched(
            &self.model,
            &|e| s.locked[e] || self.engaged(e),
            &self.state.x,
            &self.core.x,
            self.settings.lock_tol_m,
            Some(target),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::{crossed_unlatched, gap};
    use crate::model::generate::{self, MastParams};

    /// The missed-latch check: a sleeve whose gap changed sign beyond the
    /// tolerance is found unless it is locked, excepted, or within tolerance.
    #[test]
    fn a_sleeve_past_its_lock_is_found() {
        let text = generate::mast(&MastParams::default()).unwrap().to_toml();
        let m = crate::model::parse(&text, "mast.toml").unwrap().model;
        let x0 = m.x0.clone();
        // stretch the folded mast along z: every sleeve ends past its lock
        let x1: Vec<f64> = x0
            .iter()
            .enumerate()
            .map(|(i, v)| if i % 3 == 2 { 20.0 * v } else { *v })
            .collect();
        let mut locked = vec![false; m.elements.len()];
        let e = crossed_unlatched(&m, &|e| locked[e], &x0, &x1, 1e-9, None).expect("a crossing");
        assert!(gap(&m, e, &x0) < 0.0 && gap(&m, e, &x1) > 1e-9);
        assert_eq!(
            crossed_unlatched(&m, &|e| locked[e], &x0, &x0, 1e-9, None),
            None
        );
        let other = crossed_unlatched(&m, &|e| locked[e], &x0, &x1, 1e-9, Some(e));
        assert!(other.is_some_and(|o| o != e));
        assert_eq!(
            crossed_unlatched(&m, &|e| locked[e], &x0, &x1, 1e3, None),
            None
        );
        for &k in &m.locks {
            locked[k] = true;
        }
        assert_eq!(
            crossed_unlatched(&m, &|e| locked[e], &x0, &x1, 1e-9, None),
            None
        );
    }
}
