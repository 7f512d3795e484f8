//! The two GarMatNet networks in Burn, the typed predictor and model files.
