//! The run-time-against-error harness behind `garmatnet bench`, and the numerical stress
//! test of a trained predictor.

pub(crate) mod bench;
pub(crate) mod bench_report;
pub(crate) mod stress;
