//! firn-mpm: the CPU Material Point Method snow solver of Stomakhin et al. 2013,
//! as the thesis describes it (§3.4), with APIC as a second transfer scheme.
//!
//! Parallel with rayon and deterministic: the scatter colours grid blocks so no
//! two threads add to the same node ([`binning`]), so the same scene gives the
//! same bits whatever the thread count.
//!
//! ```no_run
//! use firn_core::Scene;
//! use firn_mpm::Simulation;
//!
//! let scene = Scene::load("scenes/snowball-wall.toml".as_ref())?;
//! let mut simulation = Simulation::new(scene)?;
//! simulation.advance_to(0.1)?;
//! println!("{} particles, centre of mass {:?}",
//!     simulation.particles().len(), simulation.diagnostics().center_of_mass);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod binning;
pub mod block_sums;
pub mod contact;
pub mod coupling;
pub mod diagnostics;
mod disjoint;
pub mod g2p;
pub mod grid;
pub mod grid_update;
pub mod implicit;
pub mod live;
mod local_nodes;
pub mod p2g;
pub mod particles;
pub mod profile;
pub mod reference;
pub mod simulation;
pub mod snapshot;
pub mod snow_model;
pub mod spindrift;
pub mod view;
pub mod wind;

pub use block_sums::SumTrade;
pub use implicit::SolverStats;
pub use particles::{Particles, PermuteBuffers};
pub use profile::PhaseTimes;
pub use simulation::{Diagnostics, Simulation, SimulationError, Snapshot};
pub use spindrift::{Drift, Escaped};
pub use view::SnowView;
