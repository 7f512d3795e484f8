//! Model files copied over networks: any bytes give a model or a typed error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("model.safetensors");
    std::fs::write(&path, data).expect("write input");
    let device = garmatnet_model::select_device("cpu").expect("cpu device");
    if let Ok(model) = garmatnet_model::GarMatNetModel::load(&path, &device) {
        model.validate().expect("a loaded model is consistent");
    }
});
