//! Math helpers shared by the solvers: interpolation kernels and the 3x3 SVD.

pub mod bspline;
pub mod svd;
