//! A curl-noise particle flow built in code: a stream of particles born on a
//! disc, pushed upwards at birth and carried by the turbulence towards a
//! sphere the flow goes around.
//!
//! Adding an emitter makes the scene a flow; the flow's other settings are
//! the defaults a scene file gets for its domain (noise length scale a fifth
//! of the domain, and so on). `build` checks the scene as a file is checked.
//!
//! Run with `cargo run --release -p firn-examples --example flow_in_code`.

use std::error::Error;

use firn_core::Scene;
use firn_core::scene::{FlowEmitter, FlowEmitterShape, FlowObstacle};
use firn_flow::FlowSimulation;
use glam::Vec3;

fn main() -> Result<(), Box<dyn Error>> {
    let scene = Scene::builder("stream-in-code")
        // A flow has no grid; the spacing only sizes the rendered points.
        .domain(Vec3::ZERO, Vec3::splat(10.0), 0.1)
        .duration(2.0)
        .fps(10.0)
        .obstacle(FlowObstacle::new(Vec3::new(5.0, 6.0, 5.0), 1.5))
        .emitter(
            FlowEmitter::rate(
                FlowEmitterShape::Disc {
                    center: Vec3::new(5.0, 1.0, 5.0),
                    radius: 1.0,
                    normal: Vec3::Y,
                },
                2000.0,
            )
            .lifetime(3.0)
            .velocity(Vec3::new(0.0, 4.0, 0.0), 1.0),
        )
        .build()?;

    let mut flow = FlowSimulation::new(scene)?;
    for _ in 0..flow.scene().time.frame_count() {
        flow.advance_frame();
        let top = flow.positions().iter().map(|p| p.y).fold(0.0, f32::max);
        println!(
            "t = {:.1} s  {:5} particles  highest at y = {top:.2} m",
            flow.time(),
            flow.len()
        );
    }
    Ok(())
}
