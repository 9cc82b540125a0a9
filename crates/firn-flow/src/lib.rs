//! firn-flow: particles carried by a curl-noise flow, after seed 002 (a 3D
//! particle system driven by the curl noise of Bridson, Hourihan and
//! Nordenstam 2007, "Curl-noise for procedural fluid flow"), on all CPU
//! cores and deterministic.
//!
//! The velocity is the curl of a vector potential, so it is divergence-free
//! and particles neither bunch up nor thin out:
//!
//! - [`noise`]: 3D simplex noise with its analytic gradient;
//! - [`field`]: the potential ψ = turbulence + background (seed eq. 1), the
//!   sphere obstacles ([`obstacles`], seed eq. 2-3) and the velocity
//!   v = s · curl ψ' (seed eq. 4), exact or by central differences;
//! - [`emitters`], [`particles`], [`trails`]: where particles are born, their
//!   state (structure of arrays) and their recent positions;
//! - [`snapshot`] and [`view`]: a flow's state as plain arrays (where
//!   every backend starts, [`FlowSnapshot::initial`]) and borrowed from a
//!   simulation or a snapshot alike ([`FlowView`]);
//! - [`integrate`] and [`simulation`]: RK2/RK4 steps, 16 (AVX-512), 16
//!   (AVX2, two registers) or 8 portable lanes per SIMD batch, chosen at run time ([`Simd`]), in
//!   parallel with rayon, bit-identical for any thread count and code path;
//! - [`parts`]: the flow cut into parts for processes that each step one
//!   (firn-mpi), with the bits of the whole;
//! - [`lanes`]: the number types the field is written over.
//!
//! ```no_run
//! use firn_core::Scene;
//! use firn_flow::FlowSimulation;
//!
//! let scene = Scene::load("scenes/curl-noise-demo.toml".as_ref())?;
//! let mut flow = FlowSimulation::new(scene)?;
//! for _ in 0..30 {
//!     flow.advance_frame();
//! }
//! println!("{} particles at t = {} s", flow.len(), flow.time());
//! let colors = flow.colors_by_position();
//! if let Some(trails) = flow.trails() {
//!     let first: Vec<_> = trails.iter(0).collect(); // oldest to newest
//!     println!("{:?} {:?}", colors[0], first);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod batch;
pub mod emitters;
pub mod field;
pub mod integrate;
pub mod lanes;
#[cfg(target_arch = "x86_64")]
mod lanes_avx2;
#[cfg(target_arch = "x86_64")]
mod lanes_avx512;
mod lanes_f64;
pub mod noise;
pub mod obstacles;
pub mod particles;
pub mod parts;
pub mod random;
pub mod simulation;
pub mod snapshot;
pub mod trails;
pub mod view;

pub use field::FlowField;
pub use integrate::Simd;
pub use particles::FlowParticles;
pub use parts::{FlowPart, FlowPartState};
pub use simulation::{FlowError, FlowSimulation, position_color, scene_with_settings};
pub use snapshot::FlowSnapshot;
pub use trails::{Trails, TrailsView};
pub use view::FlowView;
