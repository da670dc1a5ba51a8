//! Root of an increasing scalar function by bracketing and bisection.

/// The root x in [0, inf) of an increasing `f` with f(0) <= target: the bracket doubles from
/// 1e-12 until f reaches the target (infinity if it has not by `x_max`), then 200 bisections
/// (to the last bit of the bracket).
pub fn increasing_root(f: impl Fn(f64) -> f64, target: f64, x_max: f64) -> f64 {
    let mut hi = 1e-12;
    while f(hi) < target {
        hi *= 2.0;
        if hi > x_max {
            return f64::INFINITY;
        }
    }
    let mut lo = 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    #[test]
    fn square_root_and_unreachable_target() {
        let r = super::increasing_root(|x| x * x, 2.0, 1e6);
        assert!((r - 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(
            super::increasing_root(|x| x.min(1.0), 2.0, 1e6),
            f64::INFINITY
        );
    }
}
