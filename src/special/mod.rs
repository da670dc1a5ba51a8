//! Special functions: elliptic integrals (the parameter-vs-modulus convention is handled here
//! and nowhere else), automatic differentiation, quadrature rules used by the oracles, and a
//! small dense linear solve.

pub mod arith;
pub mod autodiff;
pub mod bulirsch;
pub mod double_double;
pub mod elliptic;
pub mod lu;
pub mod quadrature;
pub mod root;
