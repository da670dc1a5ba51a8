//! Special functions: elliptic integrals (the parameter-vs-modulus convention is handled here
//! and nowhere else) and quadrature rules used by the oracles.

pub mod elliptic;
