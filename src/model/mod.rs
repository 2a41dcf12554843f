//! Model files: the TOML format ([`file`]) and the parametric generators ([`generate`]).
pub mod file;
pub mod generate;

pub use file::{load, parse, LoadedModel, ModelDoc, ModelFileError};
