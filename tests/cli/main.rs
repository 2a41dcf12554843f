//! The command line as a user runs it: the built binary on model files,
//! its outputs, plots, exit statuses and error messages.

mod cli;
mod cli_plots;
mod docs;
mod malformed_corpus;
mod model_errors;
mod run_outcomes;
mod sweep;
