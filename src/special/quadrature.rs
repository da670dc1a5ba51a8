//! Adaptive Gauss–Kronrod quadrature (G10/K21, QUADPACK nodes) for vector-valued integrands,
//! used by the brute-force oracles in `reference/`.
//!
//! The routine is globally adaptive: it keeps every subinterval with its Kronrod value, its
//! error estimate |K21 - G10| (a deliberately conservative estimate: it is the error of the
//! 10-point Gauss value, much larger than that of the Kronrod value that is returned) and its
//! integral of |f|, and bisects the interval with the largest error until the summed error is
//! below the tolerance. Intervals whose error is at the rounding level of the integrand are not
//! split further. The returned error adds a rounding term `ROUND eps * integral |f|`.

// The rule constants are quoted to QUADPACK's 33 digits on purpose.
#![allow(clippy::excessive_precision)]

/// Abscissae of the 21-point Kronrod rule on [-1, 1] (non-negative half, descending).
const XGK: [f64; 11] = [
    0.995_657_163_025_808_080_735_527_280_689_003,
    0.973_906_528_517_171_720_077_964_012_084_452,
    0.930_157_491_355_708_226_001_207_180_059_508,
    0.865_063_366_688_984_510_732_096_688_423_493,
    0.780_817_726_586_416_897_063_717_578_345_042,
    0.679_409_568_299_024_406_234_327_365_114_874,
    0.562_757_134_668_604_683_339_000_099_272_694,
    0.433_395_394_129_247_190_799_265_943_165_784,
    0.294_392_862_701_460_198_131_126_603_103_866,
    0.148_874_338_981_631_210_884_826_001_129_720,
    0.0,
];
/// Weights of the 21-point Kronrod rule.
const WGK: [f64; 11] = [
    0.011_694_638_867_371_874_278_064_396_062_192,
    0.032_558_162_307_964_727_478_818_972_459_390,
    0.054_755_896_574_351_996_031_381_300_244_580,
    0.075_039_674_810_919_952_767_043_140_916_190,
    0.093_125_454_583_697_605_535_065_465_083_366,
    0.109_387_158_802_297_641_899_210_590_325_805,
    0.123_491_976_262_065_851_077_208_977_252_742,
    0.134_709_217_311_473_325_928_054_001_771_707,
    0.142_775_938_577_060_080_797_094_273_138_717,
    0.147_739_104_901_338_491_374_841_515_972_068,
    0.149_445_554_002_916_905_664_936_468_389_821,
];
/// Weights of the 10-point Gauss rule (its nodes are XGK[1], XGK[3], ..., XGK[9]).
const WG: [f64; 5] = [
    0.066_671_344_308_688_137_593_568_809_893_332,
    0.149_451_349_150_580_593_145_776_339_657_697,
    0.219_086_362_515_982_043_995_534_934_228_163,
    0.269_266_719_309_996_355_091_226_921_569_469,
    0.295_524_224_714_752_870_173_892_994_651_338,
];

/// Rounding term of the error estimate, in units of eps times the integral of |f|: the
/// integrands of the oracles are a few tens of flops whose rounding errors are independent
/// from node to node, so 4 eps per unit of |f| is a generous bound on what accumulates.
pub const ROUND: f64 = 4.0;

/// Result of [`integrate`].
#[derive(Debug, Clone)]
pub struct QuadResult<const N: usize> {
    /// Integral of each component.
    pub value: [f64; N],
    /// Estimated absolute error (Euclidean norm over components): summed |K21 - G10| plus the
    /// rounding term.
    pub abs_err: f64,
    /// Number of subintervals used.
    pub intervals: usize,
    /// Number of integrand evaluations.
    pub evals: usize,
    /// False when the interval budget was exhausted before the tolerance was reached (true
    /// when it was reached or when every interval is limited by rounding; `abs_err` is
    /// honest in both cases).
    pub converged: bool,
}

#[derive(Clone)]
struct Piece<const N: usize> {
    a: f64,
    b: f64,
    val: [f64; N],
    err: f64,
    resabs: f64,
    splittable: bool,
    depth: u32,
}

fn norm<const N: usize>(v: &[f64; N]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// One G10/K21 panel on [a, b]: (Kronrod value, |K - G| norm, integral of |f| norm).
fn gk21<const N: usize, F: FnMut(f64) -> [f64; N]>(
    f: &mut F,
    a: f64,
    b: f64,
) -> ([f64; N], f64, f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let mut k = [0.0; N];
    let mut g = [0.0; N];
    let mut abs = [0.0; N];
    let fc = f(c);
    for i in 0..N {
        k[i] = WGK[10] * fc[i];
        abs[i] = WGK[10] * fc[i].abs();
    }
    for j in 0..10 {
        let dx = h * XGK[j];
        let f1 = f(c - dx);
        let f2 = f(c + dx);
        for i in 0..N {
            k[i] += WGK[j] * (f1[i] + f2[i]);
            abs[i] += WGK[j] * (f1[i].abs() + f2[i].abs());
            if j % 2 == 1 {
                g[i] += WG[j / 2] * (f1[i] + f2[i]);
            }
        }
    }
    let mut d = [0.0; N];
    for i in 0..N {
        k[i] *= h;
        g[i] *= h;
        abs[i] *= h.abs();
        d[i] = k[i] - g[i];
    }
    (k, norm(&d), norm(&abs))
}

/// Integrates the vector function `f` over [a, b] split first at the given increasing
/// `breaks` (all inside (a, b)); refines until the summed error estimate is at most
/// `tol(current value)` (an absolute tolerance, typically a relative tolerance times a running
/// magnitude), or `max_intervals` subintervals are used.
pub fn integrate<const N: usize, F, T>(
    mut f: F,
    a: f64,
    b: f64,
    breaks: &[f64],
    tol: T,
    max_intervals: usize,
) -> QuadResult<N>
where
    F: FnMut(f64) -> [f64; N],
    T: Fn(&[f64; N]) -> f64,
{
    let eps = f64::EPSILON;
    let mut pts = vec![a];
    pts.extend(breaks.iter().copied().filter(|&x| x > a && x < b));
    pts.push(b);
    let mut pieces: Vec<Piece<N>> = Vec::new();
    let mut evals = 0usize;
    for w in pts.windows(2) {
        let (val, err, resabs) = gk21(&mut f, w[0], w[1]);
        evals += 21;
        pieces.push(Piece {
            a: w[0],
            b: w[1],
            val,
            err,
            resabs,
            splittable: true,
            depth: 0,
        });
    }
    let mut converged = false;
    loop {
        let mut total = [0.0; N];
        let mut err = 0.0;
        for p in &pieces {
            for (t, v) in total.iter_mut().zip(p.val.iter()) {
                *t += v;
            }
            err += p.err;
        }
        if err <= tol(&total) {
            converged = true;
            break;
        }
        if pieces.len() >= max_intervals {
            break;
        }
        // The splittable piece with the largest error.
        let mut best: Option<usize> = None;
        for (i, p) in pieces.iter().enumerate() {
            if p.splittable && best.is_none_or(|j| p.err > pieces[j].err) {
                best = Some(i);
            }
        }
        let Some(i) = best else {
            // Every remaining interval is at the rounding level of the integrand: the
            // returned error (which includes those levels) is all that can be achieved.
            converged = true;
            break;
        };
        let p = pieces[i].clone();
        let m = 0.5 * (p.a + p.b);
        if p.err <= 50.0 * eps * p.resabs
            || !(m > p.a && m < p.b)
            || (p.b - p.a) < 1e-15 * (b - a).abs()
        {
            pieces[i].splittable = false;
            continue;
        }
        let (v1, e1, r1) = gk21(&mut f, p.a, m);
        let (v2, e2, r2) = gk21(&mut f, m, p.b);
        evals += 42;
        // No progress from repeated bisection means the error is noise (rounding inside the
        // integrand): keep the halves, count their error, and stop refining them.
        let progress = p.depth < 6 || e1 + e2 < 0.7 * p.err;
        pieces[i] = Piece {
            a: p.a,
            b: m,
            val: v1,
            err: e1,
            resabs: r1,
            splittable: progress,
            depth: p.depth + 1,
        };
        pieces.push(Piece {
            a: m,
            b: p.b,
            val: v2,
            err: e2,
            resabs: r2,
            splittable: progress,
            depth: p.depth + 1,
        });
    }
    // Sum the values in order of position (pairwise-ish summation is not needed at this size).
    pieces.sort_by(|x, y| x.a.partial_cmp(&y.a).unwrap());
    let mut value = [0.0; N];
    let mut err = 0.0;
    let mut resabs = 0.0;
    for p in &pieces {
        for (t, v) in value.iter_mut().zip(p.val.iter()) {
            *t += v;
        }
        err += p.err;
        resabs += p.resabs;
    }
    QuadResult {
        value,
        abs_err: err + ROUND * eps * resabs,
        intervals: pieces.len(),
        evals,
        converged,
    }
}

/// Convenience wrapper for a scalar integrand with a relative and an absolute tolerance.
pub fn integrate_scalar<F: FnMut(f64) -> f64>(
    mut f: F,
    a: f64,
    b: f64,
    rtol: f64,
    atol: f64,
) -> (f64, f64) {
    let r = integrate::<1, _, _>(|x| [f(x)], a, b, &[], |v| atol.max(rtol * v[0].abs()), 4000);
    (r.value[0], r.abs_err)
}

/// Nodes and weights of the n-point Gauss–Legendre rule on [-1, 1] (Newton on P_n from the
/// Chebyshev guesses; Abramowitz & Stegun 25.4.29).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 0 { 1.0 } else { p1 };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (x * pn - pm) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_exactness() {
        // K21 is exact to degree 31, G10 to degree 19: |K - G| vanishes (to rounding) for x^19.
        for deg in [0u32, 5, 19] {
            let (_, e, _) = gk21(&mut |x: f64| [x.powi(deg as i32)], 0.0, 1.0);
            assert!(e < 1e-15, "deg {deg}: {e}");
        }
        for deg in [20u32, 25, 31] {
            let (k, _, _) = gk21(&mut |x: f64| [x.powi(deg as i32)], 0.0, 1.0);
            let exact = 1.0 / (deg as f64 + 1.0);
            assert!(
                (k[0] - exact).abs() < 1e-15,
                "deg {deg}: {} vs {exact}",
                k[0]
            );
        }
    }

    #[test]
    fn peaked_integrand() {
        // int_0^1 e / (e^2 + x^2) dx = atan(1/e)
        let e = 1e-9;
        let breaks: Vec<f64> = (1..40).map(|k| 0.5f64.powi(k)).rev().collect();
        let r = integrate::<1, _, _>(
            |x| [e / (e * e + x * x)],
            0.0,
            1.0,
            &breaks,
            |v| 1e-15 * v[0].abs(),
            5000,
        );
        let exact = (1.0 / e).atan();
        assert!(
            (r.value[0] - exact).abs() < 2e-15 * exact,
            "{} vs {exact}",
            r.value[0]
        );
        assert!(r.converged);
    }
}
