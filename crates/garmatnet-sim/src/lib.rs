//! The mass-spring drape solver that makes garmatnet's ground truth, and dataset generation.
