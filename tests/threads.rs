//! The types an application keeps across frames can move to, and be shared between, threads
//! (`Send + Sync`): a game predicts on a worker thread, a tool drapes several garments in
//! parallel. A change that loses either (an `Rc`, a `RefCell` cache) fails to compile here.

use garmatnet::{
    CapsuleBody, DrapeSolver, FrameStepper, GarMatNetModel, Garment, GarmentMesh, Material, Pose,
    PosedBody, Predictor, Scene,
};

fn send_sync<T: Send + Sync>() {}

#[test]
fn what_an_application_keeps_crosses_threads() {
    send_sync::<Predictor>();
    send_sync::<GarMatNetModel>();
    send_sync::<Scene>();
    send_sync::<DrapeSolver>();
    send_sync::<FrameStepper>();
    send_sync::<(Garment, CapsuleBody, PosedBody, Material, Pose, GarmentMesh)>();
}
