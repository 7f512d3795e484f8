//! Predicts one drape with the shipped model, through the facade without its default
//! features: core and model only.

use garmatnet::{CapsuleBody, Detail, Material, Pose, Predictor};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let device = garmatnet::select_device("cpu")?;
    let predictor = Predictor::from_file(
        garmatnet::model::default_model_path(),
        CapsuleBody::smpl_neutral(),
        &device,
    )?;
    let mesh = predictor.predict(
        &Pose::zero(),
        &Material::preset("Denim Heavy")?,
        Detail::Full,
    )?;
    println!("{} vertices", mesh.vertex_count());
    Ok(())
}
