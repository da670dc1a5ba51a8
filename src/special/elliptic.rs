//! Complete elliptic integrals. The `ellip` crate takes the *parameter* m = k^2; every
//! conversion from modulus k or complementary modulus kc happens here and nowhere else.
//!
//! Definitions (DLMF 19.2): K(m) = int_0^{pi/2} dt / sqrt(1 - m sin^2 t),
//! E(m) = int_0^{pi/2} sqrt(1 - m sin^2 t) dt,
//! Pi(n, m) = int_0^{pi/2} dt / ((1 - n sin^2 t) sqrt(1 - m sin^2 t)),
//! Bulirsch's cel(kc, p, a, b) = int_0^{pi/2} (a cos^2 t + b sin^2 t) /
//!     ((cos^2 t + p sin^2 t) sqrt(cos^2 t + kc^2 sin^2 t)) dt (thesis eq. 5.36).

use crate::error::{invalid, Result};

fn wrap(name: &str, r: std::result::Result<f64, &'static str>, args: &str) -> Result<f64> {
    r.or_else(|e| invalid(format!("{name}({args}): {e}")))
}

/// K(m), parameter m < 1.
pub fn ellip_k(m: f64) -> Result<f64> {
    wrap("K", ellip::ellipk(m), &format!("m={m}"))
}

/// E(m), parameter m <= 1.
pub fn ellip_e(m: f64) -> Result<f64> {
    wrap("E", ellip::ellipe(m), &format!("m={m}"))
}

/// Pi(n, m), characteristic n < 1, parameter m < 1.
pub fn ellip_pi(n: f64, m: f64) -> Result<f64> {
    wrap("Pi", ellip::ellippi(n, m), &format!("n={n}, m={m}"))
}

/// Bulirsch's general complete elliptic integral cel(kc, p, a, b), kc != 0, p != 0.
pub fn cel(kc: f64, p: f64, a: f64, b: f64) -> Result<f64> {
    wrap(
        "cel",
        ellip::cel(kc, p, a, b),
        &format!("kc={kc}, p={p}, a={a}, b={b}"),
    )
}

/// Carlson R_F(x, y, z).
pub fn carlson_rf(x: f64, y: f64, z: f64) -> Result<f64> {
    wrap("R_F", ellip::elliprf(x, y, z), &format!("{x}, {y}, {z}"))
}

/// Carlson R_D(x, y, z).
pub fn carlson_rd(x: f64, y: f64, z: f64) -> Result<f64> {
    wrap("R_D", ellip::elliprd(x, y, z), &format!("{x}, {y}, {z}"))
}

/// Carlson R_J(x, y, z, p).
pub fn carlson_rj(x: f64, y: f64, z: f64, p: f64) -> Result<f64> {
    wrap(
        "R_J",
        ellip::elliprj(x, y, z, p),
        &format!("{x}, {y}, {z}, {p}"),
    )
}
