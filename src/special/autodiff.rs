//! Forward-mode automatic differentiation: a dual number carrying N first derivatives.
//!
//! Kernels written generically over [`Real`] run on `f64` for values and on [`Dual`] for exact
//! derivatives (to rounding) without finite differences; `Dual<Dual<f64, 3>, 1>` nests.

use super::arith::Arith;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// The scalar operations the field kernels need.
pub trait Real: Arith + std::fmt::Debug {
    fn cst(v: f64) -> Self;
    /// The plain value (derivative parts dropped), for branch decisions.
    fn val(&self) -> f64;
    fn sqrt(self) -> Self;
    fn ln(self) -> Self;
    fn scale(self, s: f64) -> Self;
    /// The same number with its value replaced by `v` (derivative parts kept): for quantities
    /// whose value is computed more accurately elsewhere (e.g. in compensated arithmetic).
    fn with_value(self, v: f64) -> Self;
    /// Relative agreement at which AGM-type loops may stop. The value converges quadratically:
    /// stopping at a relative difference d of the means leaves d^2/16 in K (6e-18 for 1e-8,
    /// Bulirsch's own 10^(-D/2) for D = 16 digits), but the derivative parts carry the
    /// first-order remainder: dual numbers iterate to 1e-15.
    const AGM_TOLERANCE: f64 = 1e-8;
    /// True for dual numbers: derivatives of a difference cancel sooner than its value, so
    /// cancellation guards switch to their stable forms at lower ratios.
    const DERIVATIVES: bool = false;
}

impl Real for f64 {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn val(&self) -> f64 {
        *self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        f64::ln(self)
    }
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        self * s
    }
    #[inline(always)]
    fn with_value(self, v: f64) -> Self {
        v
    }
}

/// Value `v` and derivatives `d[k]` with respect to N independent variables.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<T: Real, const N: usize> {
    pub v: T,
    pub d: [T; N],
}

impl<T: Real, const N: usize> Dual<T, N> {
    pub fn constant(v: T) -> Self {
        Dual {
            v,
            d: [T::cst(0.0); N],
        }
    }
    /// The k-th independent variable with value v.
    pub fn variable(v: T, k: usize) -> Self {
        let mut d = [T::cst(0.0); N];
        d[k] = T::cst(1.0);
        Dual { v, d }
    }
    #[inline(always)]
    fn chain(self, fv: T, dfdx: T) -> Self {
        let mut d = self.d;
        for x in d.iter_mut() {
            *x = *x * dfdx;
        }
        Dual { v: fv, d }
    }
}

impl<T: Real, const N: usize> Add for Dual<T, N> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        let mut d = self.d;
        for (dk, ok) in d.iter_mut().zip(o.d) {
            *dk = *dk + ok;
        }
        Dual { v: self.v + o.v, d }
    }
}
impl<T: Real, const N: usize> Sub for Dual<T, N> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        let mut d = self.d;
        for (dk, ok) in d.iter_mut().zip(o.d) {
            *dk = *dk - ok;
        }
        Dual { v: self.v - o.v, d }
    }
}
impl<T: Real, const N: usize> Mul for Dual<T, N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut d = self.d;
        for (dk, ok) in d.iter_mut().zip(o.d) {
            *dk = *dk * o.v + self.v * ok;
        }
        Dual { v: self.v * o.v, d }
    }
}
impl<T: Real, const N: usize> Div for Dual<T, N> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let q = self.v / o.v;
        let mut d = self.d;
        for (dk, ok) in d.iter_mut().zip(o.d) {
            *dk = (*dk - q * ok) / o.v;
        }
        Dual { v: q, d }
    }
}
impl<T: Real, const N: usize> Neg for Dual<T, N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let mut d = self.d;
        for x in d.iter_mut() {
            *x = -*x;
        }
        Dual { v: -self.v, d }
    }
}

impl<T: Real, const N: usize> Real for Dual<T, N> {
    const AGM_TOLERANCE: f64 = 1e-15;
    const DERIVATIVES: bool = true;
    #[inline(always)]
    fn cst(v: f64) -> Self {
        Dual::constant(T::cst(v))
    }
    #[inline(always)]
    fn val(&self) -> f64 {
        self.v.val()
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        // d sqrt(x) = dx / (2 sqrt x); at x = 0 the derivative parts are left at 0 * inf -> the
        // caller must not differentiate sqrt at 0 (kernels special-case rho = 0).
        let inv = T::cst(0.5) / s;
        self.chain(s, inv)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        let l = self.v.ln();
        let inv = T::cst(1.0) / self.v;
        self.chain(l, inv)
    }
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        let mut d = self.d;
        for x in d.iter_mut() {
            *x = x.scale(s);
        }
        Dual {
            v: self.v.scale(s),
            d,
        }
    }
    #[inline(always)]
    fn with_value(self, v: f64) -> Self {
        Dual {
            v: self.v.with_value(v),
            d: self.d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn derivatives_of_a_rational_and_sqrt() {
        // f(x, y) = sqrt(x^2 + y^2) / (1 + x y) at (0.3, 0.4); derivatives by hand.
        let x = Dual::<f64, 2>::variable(0.3, 0);
        let y = Dual::<f64, 2>::variable(0.4, 1);
        let f = (x * x + y * y).sqrt() / (Dual::cst(1.0) + x * y);
        let r = 0.5f64;
        let den = 1.0 + 0.12;
        let dfdx = (0.3 / r) / den - r * 0.4 / (den * den);
        let dfdy = (0.4 / r) / den - r * 0.3 / (den * den);
        assert!((f.v - r / den).abs() < 1e-16);
        assert!((f.d[0] - dfdx).abs() < 1e-15);
        assert!((f.d[1] - dfdy).abs() < 1e-15);
    }
}
