//! Datasets, splits, training, evaluation, baselines and reports for GarMatNet.
