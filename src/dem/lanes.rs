//! Contacts side by side: the contact law is written once over a [`Lane`] type, which is either
//! one `f64` (one contact) or [`F64x4`] (four contacts in one AVX register). Every lane
//! operation is the IEEE operation of the scalar code (add, sub, mul, div and sqrt are
//! correctly rounded, neg and abs flip or clear the sign bit, comparisons are ordered), and
//! branches become per-lane selects, so a contact's force has the same bits whichever way it
//! was evaluated.

use crate::special::arith::Arith;
use nalgebra::Vector3;
use std::ops::{BitAnd, Not};

/// One value per contact.
pub trait Lane: Arith {
    /// Contacts per value.
    const LANES: usize;
    /// One condition per contact.
    type Mask: Copy + BitAnd<Output = Self::Mask> + Not<Output = Self::Mask>;
    fn splat(x: f64) -> Self;
    /// Lane l = f(l).
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    fn lane(self, l: usize) -> f64;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// self > o (false where either is NaN).
    fn gt(self, o: Self) -> Self::Mask;
    /// self < o (false where either is NaN).
    fn lt(self, o: Self) -> Self::Mask;
    /// Lane of `a` where `m`, else of `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    fn mask_lane(m: Self::Mask, l: usize) -> bool;
    /// Whether the condition holds in some lane.
    fn any(m: Self::Mask) -> bool;
}

impl Lane for f64 {
    const LANES: usize = 1;
    type Mask = bool;
    #[inline(always)]
    fn splat(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> f64 {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _: usize) -> f64 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f64 {
        f64::abs(self)
    }
    #[inline(always)]
    fn gt(self, o: f64) -> bool {
        self > o
    }
    #[inline(always)]
    fn lt(self, o: f64) -> bool {
        self < o
    }
    #[inline(always)]
    fn select(m: bool, a: f64, b: f64) -> f64 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn mask_lane(m: bool, _: usize) -> bool {
        m
    }
    #[inline(always)]
    fn any(m: bool) -> bool {
        m
    }
}

/// A three-vector of lanes (x, y, z each one [`Lane`]). Each operation is the one nalgebra
/// performs on a `Vector3`, in the same order (dot: (x x' + y y') + z z'; cross: x = y z' -
/// z y', ...), so lane l holds the bits of the scalar computation.
#[derive(Debug, Clone, Copy)]
pub struct V3<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

impl<T: Lane> V3<T> {
    #[inline(always)]
    pub fn zeros() -> Self {
        let z = T::splat(0.0);
        V3 { x: z, y: z, z }
    }
    /// Lane l = f(l).
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> Vector3<f64>) -> Self {
        let mut v = [Vector3::zeros(); 4];
        for (l, vl) in v.iter_mut().enumerate().take(T::LANES) {
            *vl = f(l);
        }
        V3 {
            x: T::from_fn(|l| v[l].x),
            y: T::from_fn(|l| v[l].y),
            z: T::from_fn(|l| v[l].z),
        }
    }
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Vector3<f64> {
        Vector3::new(self.x.lane(l), self.y.lane(l), self.z.lane(l))
    }
    #[inline(always)]
    pub fn add(&self, o: &Self) -> Self {
        V3 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
    #[inline(always)]
    pub fn sub(&self, o: &Self) -> Self {
        V3 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
    #[inline(always)]
    pub fn neg(&self) -> Self {
        V3 {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
    #[inline(always)]
    pub fn scale(&self, s: T) -> Self {
        V3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
    #[inline(always)]
    pub fn div(&self, s: T) -> Self {
        V3 {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }
    #[inline(always)]
    pub fn dot(&self, o: &Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn norm_squared(&self) -> T {
        self.dot(self)
    }
    /// self x o.
    #[inline(always)]
    pub fn cross(&self, o: &Self) -> Self {
        V3 {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }
    /// Lane of `a` where `m`, else of `b`.
    #[inline(always)]
    pub fn select(m: T::Mask, a: &Self, b: &Self) -> Self {
        V3 {
            x: T::select(m, a.x, b.x),
            y: T::select(m, a.y, b.y),
            z: T::select(m, a.z, b.z),
        }
    }
}

impl V3<f64> {
    #[inline(always)]
    pub fn of(v: &Vector3<f64>) -> V3<f64> {
        V3 {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx::F64x4;

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::Lane;
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, Div, Mul, Neg, Not, Sub};

    /// Four contacts in one AVX register.
    ///
    /// Safety: a value of this type exists only where the CPU has AVX. The type is private to
    /// the crate and made only by code reached after `is_x86_feature_detected!("avx2")` (the
    /// pair loop's AVX2 copy, and a test that checks first), into which its methods inline.
    #[derive(Debug, Clone, Copy)]
    pub(crate) struct F64x4(__m256d);

    /// Four conditions (all bits set where true).
    #[derive(Debug, Clone, Copy)]
    pub(crate) struct Mask4(__m256d);

    macro_rules! binop {
        ($tr:ident, $f:ident, $intr:ident) => {
            impl $tr for F64x4 {
                type Output = F64x4;
                #[inline(always)]
                fn $f(self, o: F64x4) -> F64x4 {
                    // SAFETY: see the type's invariant
                    F64x4(unsafe { $intr(self.0, o.0) })
                }
            }
        };
    }
    binop!(Add, add, _mm256_add_pd);
    binop!(Sub, sub, _mm256_sub_pd);
    binop!(Mul, mul, _mm256_mul_pd);
    binop!(Div, div, _mm256_div_pd);

    impl Neg for F64x4 {
        type Output = F64x4;
        #[inline(always)]
        fn neg(self) -> F64x4 {
            // SAFETY: see the type's invariant; xor with -0.0 flips the sign bit only
            F64x4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
        }
    }

    impl BitAnd for Mask4 {
        type Output = Mask4;
        #[inline(always)]
        fn bitand(self, o: Mask4) -> Mask4 {
            // SAFETY: see F64x4's invariant
            Mask4(unsafe { _mm256_and_pd(self.0, o.0) })
        }
    }

    impl Not for Mask4 {
        type Output = Mask4;
        #[inline(always)]
        fn not(self) -> Mask4 {
            // SAFETY: see F64x4's invariant
            Mask4(unsafe { _mm256_xor_pd(self.0, _mm256_castsi256_pd(_mm256_set1_epi64x(-1))) })
        }
    }

    impl Lane for F64x4 {
        const LANES: usize = 4;
        type Mask = Mask4;
        #[inline(always)]
        fn splat(x: f64) -> F64x4 {
            // SAFETY: see the type's invariant
            F64x4(unsafe { _mm256_set1_pd(x) })
        }
        #[inline(always)]
        fn from_fn(mut f: impl FnMut(usize) -> f64) -> F64x4 {
            let v = [f(0), f(1), f(2), f(3)];
            // SAFETY: see the type's invariant; the array holds four doubles
            F64x4(unsafe { _mm256_loadu_pd(v.as_ptr()) })
        }
        #[inline(always)]
        fn lane(self, l: usize) -> f64 {
            let mut v = [0.0; 4];
            // SAFETY: see the type's invariant; the array holds four doubles
            unsafe { _mm256_storeu_pd(v.as_mut_ptr(), self.0) };
            v[l]
        }
        #[inline(always)]
        fn sqrt(self) -> F64x4 {
            // SAFETY: see the type's invariant
            F64x4(unsafe { _mm256_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn abs(self) -> F64x4 {
            // SAFETY: see the type's invariant; clears the sign bit only
            F64x4(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
        }
        #[inline(always)]
        fn gt(self, o: F64x4) -> Mask4 {
            // SAFETY: see the type's invariant
            Mask4(unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: F64x4) -> Mask4 {
            // SAFETY: see the type's invariant
            Mask4(unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn select(m: Mask4, a: F64x4, b: F64x4) -> F64x4 {
            // SAFETY: see the type's invariant; blendv takes a where the mask's sign bit is set
            F64x4(unsafe { _mm256_blendv_pd(b.0, a.0, m.0) })
        }
        #[inline(always)]
        fn mask_lane(m: Mask4, l: usize) -> bool {
            // SAFETY: see the type's invariant
            (unsafe { _mm256_movemask_pd(m.0) } >> l) & 1 == 1
        }
        #[inline(always)]
        fn any(m: Mask4) -> bool {
            // SAFETY: see the type's invariant
            (unsafe { _mm256_movemask_pd(m.0) }) != 0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each lane operation of F64x4 gives the bits of the f64 operation, signs of zero, NaN and
    /// infinities included; `any` is the or of the lanes.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn f64x4_lanes_equal_scalar_bits() {
        if !is_x86_feature_detected!("avx2") {
            eprintln!("skipped: this CPU has no AVX2, so F64x4 is never used");
            return;
        }
        let vals = [
            0.0,
            -0.0,
            1.0,
            -2.5,
            1e-300,
            3e300,
            f64::INFINITY,
            -f64::INFINITY,
            f64::NAN,
            0.1,
            7.0,
            -1e-12,
        ];
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for a in vals.windows(4) {
            for b in vals.windows(4).rev() {
                let (va, vb) = (F64x4::from_fn(|l| a[l]), F64x4::from_fn(|l| b[l]));
                for l in 0..4 {
                    let (x, y) = (a[l], b[l]);
                    assert!(same((va + vb).lane(l), x + y));
                    assert!(same((va - vb).lane(l), x - y));
                    assert!(same((va * vb).lane(l), x * y));
                    assert!(same((va / vb).lane(l), x / y));
                    assert!(same((-va).lane(l), -x));
                    assert!(same(va.abs().lane(l), x.abs()));
                    assert!(same(va.sqrt().lane(l), x.sqrt()));
                    assert_eq!(F64x4::mask_lane(va.gt(vb), l), x > y);
                    assert_eq!(F64x4::mask_lane(va.lt(vb), l), x < y);
                    assert_eq!(F64x4::mask_lane(!va.lt(vb), l), !(x < y));
                    assert_eq!(F64x4::mask_lane(va.lt(vb) & va.gt(vb), l), false);
                    let m = va.gt(vb);
                    assert!(same(
                        F64x4::select(m, va, vb).lane(l),
                        if x > y { x } else { y }
                    ));
                }
                let m = va.gt(vb);
                assert_eq!(F64x4::any(m), (0..4).any(|l| a[l] > b[l]));
            }
        }
    }
}
