//! The operator bounds shared by the number types that kernels are written over once: dual
//! numbers ([`super::autodiff::Real`]), lanes of DEM contacts (`dem::lanes::Lane`) and blocks
//! of lattice cells (`lbm::simd::Real`).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A copyable type with +, -, *, / and unary - on itself (implemented for every such type).
pub trait Arith:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
}

impl<T> Arith for T where
    T: Copy
        + Add<Output = T>
        + Sub<Output = T>
        + Mul<Output = T>
        + Div<Output = T>
        + Neg<Output = T>
{
}
