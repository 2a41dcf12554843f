//! Double-ring truss generator: see `ring()`.
use super::super::file::ModelDoc;

#[derive(Clone, Debug)]
pub struct RingParams {
    pub sides: usize,
    pub tension_n: f64,
    pub friction_mu: f64,
    pub damping_n_s_per_m: f64,
    pub dt_s: f64,
}

impl Default for RingParams {
    fn default() -> Self {
        RingParams {
            sides: 18,
            tension_n: 15.0,
            friction_mu: 0.005,
            damping_n_s_per_m: 0.0,
            dt_s: 0.05,
        }
    }
}

pub fn ring(_p: &RingParams) -> Result<ModelDoc, String> {
    Err("the double-ring generator is not written yet".into())
}
