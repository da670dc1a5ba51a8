//! A minimal double-double (about 106-bit) arithmetic, used where an oracle needs an input
//! combination (e.g. the cylindrical radius sqrt(x^2 + y^2) close to the cylinder radius)
//! correct to the last bit. Error-free transformations TwoSum and TwoProd (with `mul_add`).

/// An unevaluated sum hi + lo with |lo| <= ulp(hi) / 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DD {
    pub hi: f64,
    pub lo: f64,
}

/// s + e = a + b exactly.
#[inline]
pub fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

/// p + e = a * b exactly.
#[inline]
pub fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl DD {
    pub fn from_f64(x: f64) -> DD {
        DD { hi: x, lo: 0.0 }
    }
    fn renorm(hi: f64, lo: f64) -> DD {
        let (s, e) = two_sum(hi, lo);
        DD { hi: s, lo: e }
    }
    fn add_(self, o: DD) -> DD {
        let (s, e) = two_sum(self.hi, o.hi);
        let (t, f) = two_sum(self.lo, o.lo);
        let (s, e) = {
            let e = e + t;
            let (s, e) = two_sum(s, e);
            (s, e + f)
        };
        DD::renorm(s, e)
    }
    fn neg_(self) -> DD {
        DD {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
    fn sub_(self, o: DD) -> DD {
        self.add_(o.neg_())
    }
    fn mul_(self, o: DD) -> DD {
        let (p, e) = two_prod(self.hi, o.hi);
        let e = e + (self.hi * o.lo + self.lo * o.hi);
        DD::renorm(p, e)
    }
    fn div_(self, o: DD) -> DD {
        let q1 = self.hi / o.hi;
        let r = self.sub_(o.mul_(DD::from_f64(q1)));
        let q2 = r.hi / o.hi;
        let r = r.sub_(o.mul_(DD::from_f64(q2)));
        let q3 = r.hi / o.hi;
        DD::renorm(q1, q2).add_(DD::from_f64(q3))
    }
    /// Square root by one Newton step on the f64 root (Karp's trick).
    pub fn sqrt(self) -> DD {
        if self.hi <= 0.0 {
            return DD::from_f64(0.0);
        }
        let x = self.hi.sqrt();
        let (p, e) = two_prod(x, x);
        let r = self.sub_(DD { hi: p, lo: e });
        let corr = r.hi / (2.0 * x);
        DD::renorm(x, corr)
    }
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
}

macro_rules! dd_op {
    ($tr:ident, $m:ident, $f:ident) => {
        impl std::ops::$tr for DD {
            type Output = DD;
            fn $m(self, o: DD) -> DD {
                self.$f(o)
            }
        }
    };
}
dd_op!(Add, add, add_);
dd_op!(Sub, sub, sub_);
dd_op!(Mul, mul, mul_);
dd_op!(Div, div, div_);
impl std::ops::Neg for DD {
    type Output = DD;
    fn neg(self) -> DD {
        self.neg_()
    }
}

/// sqrt(x^2 + y^2) in double-double.
pub fn hypot_dd(x: f64, y: f64) -> DD {
    let (a, ea) = two_prod(x, x);
    let (b, eb) = two_prod(y, y);
    (DD { hi: a, lo: ea } + DD { hi: b, lo: eb }).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn hypot_exact_triple() {
        let r = hypot_dd(3.0, 4.0);
        assert_eq!(r.hi, 5.0);
        assert_eq!(r.lo, 0.0);
        // (1 + 2^-30)^2 split: sqrt of a dd square recovers it.
        let x = 1.0 + 2f64.powi(-30);
        let r = hypot_dd(x, 0.0);
        assert_eq!(r.hi, x);
        let third = DD::from_f64(1.0) / DD::from_f64(3.0);
        let back = third * DD::from_f64(3.0) - DD::from_f64(1.0);
        assert!(back.to_f64().abs() < 1e-31);
    }
}
