//! Math helpers shared by the solvers: interpolation kernels, SIMD lanes, the 3x3 SVD and
//! the polar rotation of near-rotations.

pub mod bspline;
pub mod exp;
pub mod isa;
pub mod lanes;
pub mod polar;
pub mod svd;
