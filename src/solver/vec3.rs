//! 3-vectors of joint positions, velocities and forces.
pub type Vec3 = nalgebra::Vector3<f64>;
