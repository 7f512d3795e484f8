//! Evaluation: the test split's errors (Table 2, Figs. 7–8), the predictions' physical
//! quality, reports and figures, and what a fabric calibration is worth.

pub(crate) mod calibration_eval;
pub(crate) mod evaluate;
pub(crate) mod fabric_reference;
pub(crate) mod figures;
pub(crate) mod physical_quality;
pub(crate) mod plots;
pub(crate) mod prediction_errors;
pub(crate) mod report;
pub(crate) mod report_markdown;
pub(crate) mod sample_measures;
