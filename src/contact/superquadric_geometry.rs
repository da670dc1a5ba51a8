//! Body-frame geometry of the superquadric sum_k |x_k / a_k|^g_k = 1 (thesis 003 eq. 4.3-4.6,
//! 4.33), self-contained for the contact code: implicit function, gradient, diagonal Hessian,
//! radial projection onto the surface, support point, bounding radius, surface samples.
//! Ellipsoids are exponents 2, spheres equal semi-axes too.

use nalgebra::Vector3;

/// r^p for r >= 0: integer p (superballs of exponent 3, 4, 5, ...; the exponents 2 of
/// ellipsoids and spheres, and g - 1, g - 2 in the derivatives) by multiplication (within a
/// few ulp of `powf`), other p by `powf`. libm's pow was the largest cost of a superball
/// packing (44% of the run time after the other fixes, perf). The test for an integer p casts
/// instead of calling `fract`, whose `trunc` is a libm call on the baseline x86-64 target (4%
/// of the built-in `packing-superballs`, perf): in [0, 64], p as u32 truncates, so it gives p
/// back exactly when p is an integer.
#[inline]
fn rpow(r: f64, p: f64) -> f64 {
    match integer_exponent(p) {
        Some(k) => powi_inline(r, k),
        None => r.powf(p),
    }
}

/// p as an integer when it is one of 0, 1, ..., 64 (see [`rpow`]).
#[inline]
fn integer_exponent(p: f64) -> Option<u32> {
    ((0.0..=64.0).contains(&p) && (p as u32) as f64 == p).then_some(p as u32)
}

/// a^b by binary powering in the order of `f64::powi` (compiler-builtins' `__powidf2`: square
/// a, multiply the set bits of b into the result from the lowest), so bitwise the same value
/// (tested below), but inlined: the call to `__powidf2` took 9% of a gamma = 5 superball
/// packing (perf); inlined, 50 superballs of gamma 5 (case 509's schedule) took
/// 19.46 against 20.13 CPU s (means of 4 runs, same final.xyz).
#[inline]
fn powi_inline(mut a: f64, mut b: u32) -> f64 {
    let mut r = 1.0;
    loop {
        if b & 1 != 0 {
            r *= a;
        }
        b >>= 1;
        if b == 0 {
            return r;
        }
        a *= a;
    }
}

/// |x / a|^g.
#[inline]
fn powabs(x: f64, a: f64, g: f64) -> f64 {
    rpow((x / a).abs(), g)
}

/// F(x) = sum |x_k/a_k|^g_k - 1 (< 0 inside).
pub fn implicit(a: &[f64; 3], g: &[f64; 3], x: &Vector3<f64>) -> f64 {
    powabs(x.x, a[0], g[0]) + powabs(x.y, a[1], g[1]) + powabs(x.z, a[2], g[2]) - 1.0
}

/// Gradient of F (eq. 4.6): g_k / a_k sgn(x_k) |x_k/a_k|^(g_k - 1).
pub fn gradient(a: &[f64; 3], g: &[f64; 3], x: &Vector3<f64>) -> Vector3<f64> {
    Vector3::from_fn(|k, _| {
        let r = (x[k] / a[k]).abs();
        let m = rpow(r, g[k] - 1.0);
        (g[k] / a[k]) * m * x[k].signum() * if x[k] == 0.0 { 0.0 } else { 1.0 }
    })
}

/// Diagonal of the Hessian of F (eq. 4.33): g_k (g_k - 1) / a_k^2 |x_k/a_k|^(g_k - 2).
pub fn hessian_diag(a: &[f64; 3], g: &[f64; 3], x: &Vector3<f64>) -> Vector3<f64> {
    Vector3::from_fn(|k, _| {
        let r = (x[k] / a[k]).abs();
        let m = rpow(r, g[k] - 2.0);
        g[k] * (g[k] - 1.0) / (a[k] * a[k]) * m
    })
}

/// The point t x on the surface (t > 0), for x != 0: Newton on the convex increasing
/// psi(s) = ln sum exp(g_k (s + ln|x_k/a_k|)), s = ln t, started right of the root
/// (monotone convergence). Returns x unchanged for x = 0.
pub fn project_radial(a: &[f64; 3], g: &[f64; 3], x: &Vector3<f64>) -> Vector3<f64> {
    // The non-zero components as (ln|x_k/a_k|, g_k), in a fixed array (no allocation: this
    // runs in every Newton step of the contact solver).
    let mut buf = [(0.0, 0.0); 3];
    let mut len = 0;
    for k in (0..3).filter(|&k| x[k] != 0.0) {
        buf[len] = ((x[k] / a[k]).abs().ln(), g[k]);
        len += 1;
    }
    let l = &buf[..len];
    if l.is_empty() {
        return *x;
    }
    // start where the largest term is 1: psi >= 0
    let mut s = l.iter().map(|&(lk, _)| -lk).fold(f64::INFINITY, f64::min);
    for _ in 0..100 {
        let m = l
            .iter()
            .map(|&(lk, gk)| gk * (s + lk))
            .fold(f64::NEG_INFINITY, f64::max);
        let (mut sum, mut dsum) = (0.0, 0.0);
        for &(lk, gk) in l {
            let e = (gk * (s + lk) - m).exp();
            sum += e;
            dsum += gk * e;
        }
        let psi = m + sum.ln();
        let step = psi / (dsum / sum);
        s -= step;
        if step.abs() <= 1e-16 * s.abs().max(1.0) || psi <= 0.0 {
            break;
        }
    }
    x * s.exp()
}

/// Rounding level of F near the surface (a few ulp of 1): projections stop there.
const F_NOISE: f64 = 4.0 * f64::EPSILON;

/// The surface point on the line through x along the normal direction at x (the foot of a
/// near-surface point): root of f(t) = F(x + t n) bracketed from t = 0 by doubling the first
/// Newton step, then Illinois regula falsi. Falls back to the radial projection when the
/// gradient vanishes or no bracket is found.
pub fn project_normal(a: &[f64; 3], g: &[f64; 3], x: &Vector3<f64>) -> Vector3<f64> {
    let f0 = implicit(a, g, x);
    // on the surface to the rounding of F (see the stopping rule below)
    if f0.abs() <= F_NOISE {
        return *x;
    }
    let gr = gradient(a, g, x);
    let gn = gr.norm();
    if !(gn > 0.0 && gn.is_finite()) {
        return project_radial(a, g, x);
    }
    let n = gr / gn;
    let f = |t: f64| implicit(a, g, &(x + n * t));
    // first Newton step, in the direction that reduces |F|
    let mut t1 = -f0 / gn;
    if !t1.is_finite() || t1 == 0.0 {
        return project_radial(a, g, x);
    }
    let (mut t_lo, mut f_lo) = (0.0, f0);
    let mut f1 = f(t1);
    let mut n_expand = 0;
    while f1.signum() == f0.signum() {
        t_lo = t1;
        f_lo = f1;
        t1 *= 2.0;
        f1 = f(t1);
        n_expand += 1;
        if n_expand > 60 || !f1.is_finite() {
            return project_radial(a, g, x);
        }
    }
    let (mut ta, mut fa, mut tb, mut fb) = (t_lo, f_lo, t1, f1);
    let mut side = 0i32;
    for _ in 0..200 {
        let t = (ta * fb - tb * fa) / (fb - fa);
        let ft = f(t);
        if ft == 0.0 || (tb - ta).abs() <= 1e-17 * (ta.abs() + tb.abs()) {
            return x + n * t;
        }
        if ft.signum() == fb.signum() {
            tb = t;
            fb = ft;
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        } else {
            ta = t;
            fa = ft;
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        }
        // F = sum of terms of order 1, minus 1: below a few ulp(1) its value is rounding
        // noise (it takes the values 0, -1.1e-16, 2.2e-16, ...), so iterating further only
        // hunts for an exact zero. With the former threshold 1e-16 (below that noise) the
        // iteration averaged 7.3 evaluations per call and this function took half the run time
        // of a superball packing (perf); the point moves by about 1e-16 D.
        if fa.abs().min(fb.abs()) <= F_NOISE {
            break;
        }
    }
    let t = if fa.abs() < fb.abs() { ta } else { tb };
    x + n * t
}

/// Support point: the surface point maximising d . x (body frame). Stationarity gives
/// |x_k/a_k| = (|d_k| a_k / (mu g_k))^(1/(g_k-1)); mu solves
/// phi(l) = ln sum exp(e_k (L_k - l)) = 0, l = ln mu, e_k = g_k/(g_k-1), L_k = ln(|d_k| a_k/g_k),
/// convex decreasing: Newton from the left (l = max L_k) converges monotonically.
pub fn support(a: &[f64; 3], g: &[f64; 3], d: &Vector3<f64>) -> Vector3<f64> {
    let mut buf = [(0usize, 0.0, 0.0); 3];
    let mut len = 0;
    for k in (0..3).filter(|&k| d[k] != 0.0) {
        buf[len] = (k, (d[k].abs() * a[k] / g[k]).ln(), g[k] / (g[k] - 1.0));
        len += 1;
    }
    let terms = &buf[..len];
    if terms.is_empty() {
        return Vector3::new(0.0, 0.0, a[2]);
    }
    let mut l = terms.iter().map(|t| t.1).fold(f64::NEG_INFINITY, f64::max);
    for _ in 0..100 {
        let m = terms
            .iter()
            .map(|&(_, lk, ek)| ek * (lk - l))
            .fold(f64::NEG_INFINITY, f64::max);
        let (mut sum, mut dsum) = (0.0, 0.0);
        for &(_, lk, ek) in terms {
            let e = (ek * (lk - l) - m).exp();
            sum += e;
            dsum += ek * e;
        }
        let phi = m + sum.ln();
        let step = phi / (dsum / sum);
        l += step;
        if step.abs() <= 1e-16 * l.abs().max(1.0) || phi <= 0.0 {
            break;
        }
    }
    let mut x = Vector3::zeros();
    for &(k, lk, _) in terms {
        // |x_k/a_k| = exp((L_k - l)/(g_k - 1))
        x[k] = a[k] * ((lk - l) / (g[k] - 1.0)).exp() * d[k].signum();
    }
    // polish onto the surface (rounding of the exponentials)
    project_radial(a, g, &x)
}

/// Bounding radius max |x| on the surface. With u_k = |x_k/a_k|^g_k (sum u = 1),
/// |x|^2 = sum a_k^2 u_k^(2/g_k) is concave on the simplex; its maximum is found from the KKT
/// conditions by bisection on the multiplier (closed form eq. 4.38 when all g are equal).
pub fn bounding_radius(a: &[f64; 3], g: &[f64; 3]) -> f64 {
    let c: Vec<f64> = g.iter().map(|gk| 2.0 / gk).collect();
    let a2: Vec<f64> = a.iter().map(|x| x * x).collect();
    // u_k(mu) for the strictly concave terms (c < 1), 0 for the linear ones.
    let u_of = |mu: f64| -> [f64; 3] {
        let mut u = [0.0; 3];
        for k in 0..3 {
            if c[k] < 1.0 {
                u[k] = (mu / (a2[k] * c[k])).powf(1.0 / (c[k] - 1.0)).min(1.0);
            }
        }
        u
    };
    let amax2 = a2.iter().cloned().fold(0.0, f64::max);
    let lin_max = (0..3)
        .filter(|&k| c[k] >= 1.0)
        .map(|k| a2[k])
        .fold(0.0, f64::max);
    let value = |u: &[f64; 3]| -> f64 { (0..3).map(|k| a2[k] * u[k].max(0.0).powf(c[k])).sum() };
    // Candidate 1: all mass on strictly concave terms, sum u(mu) = 1 (mu >= lin_max).
    let mut best: f64 = 0.0;
    let (mut lo, mut hi) = (lin_max.max(1e-300), amax2 * 1e3 + lin_max);
    let total = |mu: f64| u_of(mu).iter().sum::<f64>();
    if total(lo) >= 1.0 {
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if total(mid) > 1.0 {
                lo = mid
            } else {
                hi = mid
            }
        }
        let mut u = u_of(hi);
        let s: f64 = u.iter().sum();
        if s > 0.0 {
            for v in u.iter_mut() {
                *v /= s;
            }
        }
        best = best.max(value(&u));
    } else {
        // mu = lin_max: the concave terms take u(lin_max), the best linear term the rest.
        let mut u = u_of(lin_max);
        let s: f64 = u.iter().sum();
        let kl = (0..3)
            .filter(|&k| c[k] >= 1.0)
            .max_by(|&i, &j| a2[i].partial_cmp(&a2[j]).unwrap())
            .unwrap();
        u[kl] = 1.0 - s;
        best = best.max(value(&u));
    }
    // Vertices (single-axis points) are always feasible.
    best = best.max(amax2);
    best.sqrt() * (1.0 + 1e-12)
}

/// About n surface points: directions of a Fibonacci sphere, stretched by the semi-axes and
/// projected radially onto the surface. Returns (points, unit outward normals).
pub fn surface_samples(
    a: &[f64; 3],
    g: &[f64; 3],
    n: usize,
) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let n = n.max(8);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut pts = Vec::with_capacity(n);
    let mut nrm = Vec::with_capacity(n);
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = golden * i as f64;
        let d = Vector3::new(r * phi.cos() * a[0], r * phi.sin() * a[1], z * a[2]);
        let p = project_radial(a, g, &d);
        pts.push(p);
        nrm.push(gradient(a, g, &p).normalize());
    }
    (pts, nrm)
}

#[cfg(test)]
mod tests {
    /// The inlined powering gives bitwise the value of `f64::powi` for every exponent rpow
    /// sends to it (0..=64), on 20000 bases spread over 1e-12..1e3 and the edge values 0, 1.
    /// The cast test for an integer exponent decides as `fract` does (the test it replaced):
    /// integers, halves, one ulp either side of an integer, negatives, beyond 64, -0, NaN and
    /// infinities.
    #[test]
    fn integer_exponent_decides_as_fract() {
        let mut ps = vec![
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -1.0,
            64.5,
            65.0,
        ];
        for k in 0..=64 {
            let p = k as f64;
            ps.extend([p, p + 0.5, f64::from_bits(p.to_bits() + 1)]);
            if k > 0 {
                ps.push(f64::from_bits(p.to_bits() - 1));
            }
        }
        for p in ps {
            let by_fract = p.fract() == 0.0 && (0.0..=64.0).contains(&p);
            assert_eq!(integer_exponent(p).is_some(), by_fract, "p = {p}");
            if let Some(k) = integer_exponent(p) {
                assert_eq!(k as f64, p);
            }
        }
    }

    #[test]
    fn powi_inline_is_bitwise_powi() {
        let mut bases = vec![0.0, 1.0, f64::MIN_POSITIVE, 0.5, 2.0];
        let mut x = 0.123_456_789f64;
        for _ in 0..20000 {
            x = (x * 9_973.0 + 0.618_033_988_75).fract();
            bases.push(10f64.powf(-12.0 + 15.0 * x));
        }
        for &a in &bases {
            for b in 0..=64u32 {
                assert_eq!(
                    super::powi_inline(a, b).to_bits(),
                    a.powi(b as i32).to_bits(),
                    "{a}^{b}"
                );
            }
        }
    }

    use super::*;

    #[test]
    fn support_is_on_surface_and_maximal() {
        let a = [1.0, 0.3, 2.0];
        let g = [2.0, 7.0, 20.0];
        let d = Vector3::new(0.3, -0.7, 0.2);
        let s = support(&a, &g, &d);
        assert!(implicit(&a, &g, &s).abs() < 1e-13);
        // normal parallel to d
        let n = gradient(&a, &g, &s).normalize();
        assert!((n - d.normalize()).norm() < 1e-10, "{n} vs {d}");
        let (pts, _) = surface_samples(&a, &g, 2000);
        let best = pts
            .iter()
            .map(|p| p.dot(&d))
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(s.dot(&d) >= best - 1e-14);
    }

    #[test]
    fn bounding_radius_closed_forms() {
        // ellipsoid: max semi-axis; superball eq. 4.39: r^2 = 3^(1 - 2/g) a^2
        assert!((bounding_radius(&[1.0, 2.0, 0.5], &[2.0; 3]) - 2.0).abs() < 1e-9);
        let g = 6.0;
        let r = 3f64.powf(1.0 - 2.0 / g).sqrt();
        assert!((bounding_radius(&[1.0; 3], &[g; 3]) - r).abs() < 1e-9);
        // eq. 4.38 supercuboid
        let a = [1.0f64, 2.0, 3.0];
        let e = 2.0 / g;
        let r2: f64 = a
            .iter()
            .map(|x| (x * x).powf(1.0 / (1.0 - e)))
            .sum::<f64>()
            .powf(1.0 - e);
        assert!((bounding_radius(&a, &[g; 3]) - r2.sqrt()).abs() < 1e-9);
        // mixed: never below the samples
        let (a, g) = ([1.0, 0.5, 3.0], [2.0, 9.0, 4.0]);
        let br = bounding_radius(&a, &g);
        let (pts, _) = surface_samples(&a, &g, 5000);
        let m = pts.iter().map(|p| p.norm()).fold(0.0, f64::max);
        assert!(br >= m && br < m * 1.01, "{br} {m}");
    }
}
