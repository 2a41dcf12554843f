//! Sail (solar) array generator: see `sail()`.
use super::super::file::ModelDoc;

#[derive(Clone, Debug)]
pub struct SailParams {
    /// Number of deck bays (1 to 100); the paper's array has 4 scissor units per boom.
    pub bays: usize,
    pub tension_n: f64,
    pub friction_mu: f64,
    pub damping_n_s_per_m: f64,
    pub dt_s: f64,
}

impl Default for SailParams {
    fn default() -> Self {
        SailParams {
            bays: 4,
            tension_n: 10.0,
            friction_mu: 0.005,
            damping_n_s_per_m: 0.0,
            dt_s: 0.05,
        }
    }
}

pub fn sail(_p: &SailParams) -> Result<ModelDoc, String> {
    Err("the sail array generator is not written yet".into())
}
