//! Math helpers shared by the solvers: interpolation kernels, SIMD lanes and the 3x3 SVD.

pub mod bspline;
pub mod exp;
pub mod lanes;
pub mod svd;
