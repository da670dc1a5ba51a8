//! Ellipsoid-ellipsoid overlap by the Perram-Wertheim contact function (J. W. Perram and
//! M. S. Wertheim, J. Comput. Phys. 58, 409 (1985); seed 000 appendix A).
//!
//! With the ellipsoids written as (x - r_a)^T A (x - r_a) <= 1, A = R_a diag(a^-2) R_a^T,
//!
//!   F(lambda) = lambda (1 - lambda) r^T [ (1 - lambda) A^-1 + lambda B^-1 ]^-1 r,   r = r_b - r_a,
//!
//! on 0 <= lambda <= 1. max F < 1: overlap; = 1: tangent; > 1: apart. sqrt(max F) is the
//! contact scale factor: both ellipsoids scaled by it about their centres just touch.
//! F is maximised by Brent's method (golden section + parabolic interpolation, Numerical
//! Recipes `brent`) on [0, 1]; the overlap test [`pw_overlap`] starts at lambda = 1/2 and stops
//! as soon as some F(lambda) > 1 (non-overlap proven), as in seed 000.
//!
//! The contact points, gap and normal of an ellipsoid pair come from the common-normal
//! Newton-Raphson (ellipsoids as superquadrics with exponents 2); PW supplies `pw_scale`.

use super::{Contact, ContactResult, NrOptions, Pose, SqBody, SqShape};
use nalgebra::{Matrix3, Vector3};

/// A^-1 = R diag(a^2) R^T of an ellipsoid.
fn inv_shape_matrix(p: &Pose, a: &[f64; 3]) -> Matrix3<f64> {
    let r = p.rotation();
    r * Matrix3::from_diagonal(&Vector3::new(a[0] * a[0], a[1] * a[1], a[2] * a[2])) * r.transpose()
}

/// The PW contact function of two ellipsoids, F(lambda) (a closure over the pair).
pub fn pw_contact_function<'x>(
    pa: &Pose,
    a: &[f64; 3],
    pb: &Pose,
    b: &[f64; 3],
) -> impl Fn(f64) -> f64 + 'x {
    let ainv = inv_shape_matrix(pa, a);
    let binv = inv_shape_matrix(pb, b);
    let r = pb.position - pa.position;
    move |lambda: f64| {
        let c = ainv * (1.0 - lambda) + binv * lambda;
        match c.cholesky() {
            Some(ch) => lambda * (1.0 - lambda) * r.dot(&ch.solve(&r)),
            None => 0.0,
        }
    }
}

/// Result of the PW maximisation.
#[derive(Debug, Clone, Copy)]
pub struct PwResult {
    /// Maximising lambda (or where the early exit happened).
    pub lambda: f64,
    /// F at `lambda`.
    pub f: f64,
    /// Function evaluations.
    pub evaluations: usize,
    /// True when stopped early because F > 1 (only for the overlap test).
    pub early_exit: bool,
}

const CGOLD: f64 = 0.381_966_011_250_105_1;

/// Brent maximisation of F on [0, 1], started at lambda = 1/2. With `exit_above = Some(1.0)`
/// it stops as soon as F > 1.
fn brent_max(f: &dyn Fn(f64) -> f64, tol: f64, exit_above: Option<f64>) -> PwResult {
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let mut x = 0.5;
    let (mut w, mut v) = (x, x);
    // minimise g = -F
    let mut fx = -f(x);
    let mut evals = 1;
    if let Some(t) = exit_above {
        if -fx > t {
            return PwResult {
                lambda: x,
                f: -fx,
                evaluations: evals,
                early_exit: true,
            };
        }
    }
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let xm = 0.5 * (a + b);
        let tol1 = tol * x.abs() + 1e-14;
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if p.abs() >= (0.5 * q * etemp).abs() || p <= q * (a - x) || p >= q * (b - x) {
                e = if x >= xm { a - x } else { b - x };
                d = CGOLD * e;
            } else {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
            }
        } else {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = -f(u);
        evals += 1;
        if let Some(t) = exit_above {
            if -fu > t {
                return PwResult {
                    lambda: u,
                    f: -fu,
                    evaluations: evals,
                    early_exit: true,
                };
            }
        }
        if fu <= fx {
            if u >= x {
                a = x
            } else {
                b = x
            }
            v = w;
            w = x;
            x = u;
            fv = fw;
            fw = fx;
            fx = fu;
        } else {
            if u < x {
                a = u
            } else {
                b = u
            }
            if fu <= fw || w == x {
                v = w;
                w = u;
                fv = fw;
                fw = fu;
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    PwResult {
        lambda: x,
        f: -fx,
        evaluations: evals,
        early_exit: false,
    }
}

/// max over lambda of the PW contact function (full Brent maximisation, lambda to ~1e-10).
pub fn pw_max(pa: &Pose, a: &[f64; 3], pb: &Pose, b: &[f64; 3]) -> PwResult {
    let f = pw_contact_function(pa, a, pb, b);
    brent_max(&f, 1e-10, None)
}

/// PW overlap test with the early exit on F(lambda) > 1: returns (overlap, details).
pub fn pw_overlap(pa: &Pose, a: &[f64; 3], pb: &Pose, b: &[f64; 3]) -> (bool, PwResult) {
    let f = pw_contact_function(pa, a, pb, b);
    let res = brent_max(&f, 1e-10, Some(1.0));
    (!res.early_exit && res.f < 1.0, res)
}

/// Full contact of two ellipsoids: points, normal and gap by the certified common-normal
/// Newton-Raphson, plus the PW scale factor sqrt(max F).
pub fn contact_ellipsoid_ellipsoid(
    pa: &Pose,
    a: [f64; 3],
    pb: &Pose,
    b: [f64; 3],
) -> ContactResult<Contact> {
    let pw = pw_max(pa, &a, pb, &b);
    let sa = SqBody::new(SqShape::new(a, [2.0; 3]), *pa);
    let sb = SqBody::new(SqShape::new(b, [2.0; 3]), *pb);
    let mut c = super::contact_superquadric_superquadric(&sa, &sb, &NrOptions::default())?;
    c.pw_scale = Some(pw.f.max(0.0).sqrt());
    Ok(c)
}
