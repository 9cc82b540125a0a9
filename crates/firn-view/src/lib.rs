//! firn-view: the interactive viewer (`firn view`). A window (winit + wgpu)
//! runs a scene live on the CPU or the GPU, or plays back a finished run
//! from its caches, with an orbit camera, a parameter panel (egui) and the
//! physics in a fixed-timestep loop (thesis §5.2, Quellcode 6).

#![warn(missing_docs)]

pub mod draw;
