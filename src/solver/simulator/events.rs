//! Stage `events`: lock conditions inside a trial step (docs/solver.md, Latches).
//!
//! Each lockable element gives a signed gap g whose zero is the latch, and its rate
//! (`Constraint::lock_condition`). When g changes sign inside the step, or the step's cubic
//! Hermite interpolant touches zero and turns back (confirmed on the step map), the step is redone
//! with the length h* at which g(h*) = 0 (Illinois root of the step map). The impact stage then
//! latches the element.
//!
//! Errors: a root search at its iteration limit with |g| above the latch tolerance
//! (`SolverError::LatchSearch`); an element found past its lock without latching after a latch
//! event (`SolverError::MissedLatch`). A touch whose check step fails fails the sub-step.

use super::core::StepRule;
use super::sim::Simulator;
use crate::solver::elements::Constraint;
use crate::solver::linsolve::SolveMode;
use crate::solver::model::Model;
use crate::solver::state::State;
use crate::solver::SolverError;

/// Whether a sleeve is held at its lock: latched, or its compliant latch
/// engaged (its transient lasts) or waiting for the others' to end.
pub(super) fn held(s: &State, e: usize) -> bool {
    s.locked[e]
        || s.transients.iter().any(|t| t.element == e)
        || s.carry.waiting.iter().any(|w| w.element == e)
}

/// The first lockable element other than `except` and not `held` (latched or engaging) whose gap
/// changed sign between x0 and x1 and ended more than `tol` past zero.
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
        let (g0, g1) = (model.lock_gap_m(e, x0), model.lock_gap_m(e, x1));
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

/// Writes the cubic Hermite interpolant of `joints` at fraction s of a step of length h to `out`.
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

/// The element's gap at fraction s of the step's interpolant (its joints written to `scratch`).
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
    /// The unlocked element whose gap reaches zero first on the step's Hermite interpolant, with
    /// the fraction s_hi of the step by which it has crossed: 1 for a sign change over the step,
    /// else the interpolant's turning point (a touch and turn). Dips of the elements in `no_dips`
    /// (not real on the step map) are skipped; their sign changes are not.
    pub(super) fn first_crossing(&mut self, h: f64, no_dips: &[usize]) -> Option<(usize, f64)> {
        let (model, s, c, st) = (&self.model, &self.state, &self.core, &self.settings);
        let scratch = &mut self.interp;
        let ends = (&s.x[..], &s.v[..], &c.x[..], &c.v[..]);
        let iterations = st.dip_search_iterations;
        let mut best: Option<(f64, usize, f64)> = None;
        for &e in &model.locks {
            if held(s, e) {
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
            // A sign change, or a touch and turn (g0 gdot0 < 0, g1 gdot1 > 0): then the
            // interpolant's extremum decides (golden section on the g0-signed gap, unimodal over
            // one turn).
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

    /// Finds h* in (0, h] with gap_target(step(h*)) = 0 by the Illinois method on the step map,
    /// leaving the trial at h*; an element found crossing earlier becomes the target. Trial steps
    /// solve in least squares (`search_step`).
    ///
    /// `s_hi` < 1: the step map is first evaluated at s_hi h for a bracket. A gap there within
    /// the latch tolerance is a touch (h* = s_hi h); one not crossed (the dip was not real) gives
    /// None, the trial left at its last computation.
    pub(super) fn locate_latch(
        &mut self,
        mut target: usize,
        (h, rule): (f64, StepRule),
        s_hi: f64,
    ) -> Result<Option<f64>, SolverError> {
        let mode = SolveMode::MinNorm;
        self.core.stats.latch_searches += 1;
        let mut b = h;
        if s_hi < 1.0 {
            b = s_hi * h;
            self.core.stats.latch_search_steps += 1;
            // a failing check step fails the sub-step: a touch is never dropped unchecked
            self.newmark_trial(b, rule, mode)?;
            let st = &self.settings;
            // an element crossed by then comes first (ring diagonals before radial sleeves touch)
            if let Some(other) = self.crossed_by(target) {
                target = other;
            } else {
                let (g0, gb) = (
                    self.model.lock_gap_m(target, &self.state.x),
                    self.model.lock_gap_m(target, &self.core.x),
                );
                if gb.abs() <= st.lock_tol_m {
                    return Ok(Some(b));
                }
                if gb * g0 > 0.0 {
                    return Ok(None);
                }
            }
        }
        let g0 = self.model.lock_gap_m(target, &self.state.x);
        let (mut a, mut ga) = (0.0, g0);
        let mut gb = self.model.lock_gap_m(target, &self.core.x);
        let mut side = 0i32;
        let mut iterations = 0;
        while iterations < self.settings.root_max_iterations {
            iterations += 1;
            // Illinois step (regula falsi with halving of the stale end)
            let mut m = (a * gb - b * ga) / (gb - ga);
            if !(m > a && m < b) {
                m = 0.5 * (a + b);
            }
            self.search_step(m, rule)?;
            let st = &self.settings;
            let gm = self.model.lock_gap_m(target, &self.core.x);
            // did another element already cross before m?
            if let Some(other) = self.crossed_by(target) {
                target = other;
                a = 0.0;
                ga = self.model.lock_gap_m(target, &self.state.x);
                b = m;
                gb = self.model.lock_gap_m(target, &self.core.x);
                side = 0;
                // a crossing within a vanishing part of the sub-step is the projection's,
                // not the motion's: nothing locates it in time
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
        // iteration limit: the bracket's far end is accepted within the latch tolerance
        // (counted fallback), else the search has failed
        self.search_step(b, rule)?;
        let st = &self.settings;
        let gb = self.model.lock_gap_m(target, &self.core.x);
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

    /// One latch-search trial step of length h, in least squares: trials lie just short of a latch,
    /// typically the flat deployed state, where redundant rows are only nearly redundant. One that
    /// fails fails the sub-step: retried shorter down to `min_substep_fraction`, else the error.
    fn search_step(&mut self, h: f64, rule: StepRule) -> Result<(), SolverError> {
        self.core.stats.latch_search_steps += 1;
        self.newmark_trial(h, rule, SolveMode::MinNorm)
    }

    /// Another unlocked element whose gap changed sign beyond the latch tolerance in this trial.
    fn crossed_by(&self, target: usize) -> Option<usize> {
        crossed_unlatched(
            &self.model,
            &|e| held(&self.state, e),
            &self.state.x,
            &self.core.x,
            self.settings.lock_tol_m,
            Some(target),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::crossed_unlatched;
    use crate::model::generate::{self, MastParams};

    /// The missed-latch check finds a sleeve past its lock unless locked, excepted or within `tol`.
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
        assert!(m.lock_gap_m(e, &x0) < 0.0 && m.lock_gap_m(e, &x1) > 1e-9);
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
