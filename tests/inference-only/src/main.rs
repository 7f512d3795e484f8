//! Predicts one drape with the shipped model, through the facade without its default
//! features: core and model only.

use garmatnet::{Detail, Material, Pose, Predictor};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let device = garmatnet::select_device("cpu")?;
    let predictor = Predictor::default_tshirt(&device)?;
    let denim = Material::preset("Denim Heavy")?;
    let mesh = predictor.predict(&Pose::zero(), &denim, Detail::Full)?;
    println!("{} vertices", mesh.into_tri_mesh()?.vertex_count());
    Ok(())
}
