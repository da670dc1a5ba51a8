//! Special functions: elliptic integrals (the parameter-vs-modulus convention is handled here
//! and nowhere else), automatic differentiation, and quadrature rules used by the oracles.

pub mod autodiff;
pub mod bulirsch;
pub mod double_double;
pub mod elliptic;
pub mod quadrature;
