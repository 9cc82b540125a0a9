//! The solids the snow pushes: a scene's `[[rigid_bodies]]` simulated by
//! rapier (dimforge's rigid-body engine, built with its
//! `enhanced-determinism` feature and without threads, so that a run gives
//! the same bits on any machine and thread count).
//!
//! [`RigidWorld`] holds the bodies, the scene's colliders (fixed, or moved
//! as rapier's kinematic bodies along their motion) and the six domain walls.
//! The snow solver (firn-mpm) reads the bodies' [`BodyState`]s at the start
//! of a substep, lets the grid meet them as moving colliders, and hands back
//! the momentum the snow took from each ([`BodyImpulse`]); the world applies
//! it and steps by the same Δt ([`RigidWorld::step`]). Nothing of the
//! rigid dynamics is written here: shapes, mass properties, contacts
//! between solids and their integration are rapier's.
//!
//! rapier works in its own glam version: [`convert`] moves vectors and
//! rotations across by their components.

mod convert;
mod shapes;
mod world;

pub use world::{BodyImpulse, BodyState, RigidError, RigidWorld};
