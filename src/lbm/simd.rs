//! The numbers the kernel computes with: one cell (`f64`) or a block of [`LANES`] cells (a
//! vector). The collision and the forcing states are written once, generic over [`Real`], so
//! that a block and the cell-by-cell reference run the same IEEE operations in the same order
//! (add, subtract, multiply, divide, square root and fused multiply-add are each rounded once,
//! whatever the lane count): the same bits.
//!
//! The vector types wrap the `core::arch` registers: [`V512`] (one AVX-512 register, used
//! inside functions compiled with avx512f), [`V256x2`] (two AVX2 registers, with avx2 and fma)
//! and [`VArr`] (eight plain f64, anywhere). Their operations are `#[inline(always)]`, so that
//! they vanish into the kernel instantiated inside a `#[target_feature]` function; called
//! anywhere else, `V512` and `V256x2` would need the CPU features that the caller must have
//! checked.

use crate::special::arith::Arith;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// `v3!(k => expr)`: the array of `expr` at k = 0, 1, 2, written out without a closure (the
/// vector operations inside a closure are not inlined into the kernel).
macro_rules! v3 {
    ($k:ident => $e:expr) => {
        [
            {
                let $k = 0usize;
                $e
            },
            {
                let $k = 1usize;
                $e
            },
            {
                let $k = 2usize;
                $e
            },
        ]
    };
}
pub(crate) use v3;

/// Whether the CPU has AVX-512 (avx512f, avx2, fma): the kernel's widest path.
#[cfg(target_arch = "x86_64")]
pub fn has_avx512() -> bool {
    is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("avx2")
        && is_x86_feature_detected!("fma")
}

/// Whether the CPU has AVX-512: never off x86-64.
#[cfg(not(target_arch = "x86_64"))]
pub fn has_avx512() -> bool {
    false
}

/// Cells in a block of the kernel: one AVX-512 register of f64 (two AVX2 ones).
pub const LANES: usize = 8;

/// The cells a block's lanes stand for, and whether they are consecutive (then a per-cell
/// field is one slice load).
#[derive(Debug, Clone, Copy)]
pub struct Cells<'a> {
    pub idx: &'a [usize],
    pub contiguous: bool,
}

impl<'a> Cells<'a> {
    /// One cell.
    pub fn one(idx: &'a [usize; 1]) -> Cells<'a> {
        Cells {
            idx,
            contiguous: true,
        }
    }
}

/// A number of the kernel: `LANES` cells at once.
pub trait Real: Arith {
    const LANES: usize;
    fn splat(v: f64) -> Self;
    /// self * a + b, rounded once.
    fn mul_add(self, a: Self, b: Self) -> Self;
    fn sqrt(self) -> Self;
    /// The first `LANES` values of `s`.
    fn load(s: &[f64]) -> Self;
    /// Into the first `LANES` values of `s`.
    fn store(self, s: &mut [f64]);
    /// As [`Real::store`], past the caches where the type can (a whole aligned cache line,
    /// written non-temporally: no read of the line first). Callers end with [`Real::fence`].
    #[inline(always)]
    fn store_stream(self, s: &mut [f64]) {
        self.store(s)
    }
    /// Orders the non-temporal stores before any later store.
    #[inline(always)]
    fn fence() {}
    /// Lane l: `s[idx[l]]` (indices below `s.len()`, bounds-checked).
    #[inline(always)]
    fn gather(s: &[f64], idx: &[u32]) -> Self {
        let mut v = [0.0; LANES];
        for (vl, &i) in v.iter_mut().zip(&idx[..Self::LANES]) {
            *vl = s[i as usize];
        }
        Self::load(&v)
    }
    /// Lane l: `field[cells.idx[l]]`.
    #[inline(always)]
    fn field(field: &[f64], cells: Cells) -> Self {
        if cells.contiguous {
            let c0 = cells.idx[0];
            Self::load(&field[c0..c0 + Self::LANES])
        } else {
            let mut v = [0.0; LANES];
            for (vl, &c) in v.iter_mut().zip(cells.idx) {
                *vl = field[c];
            }
            Self::load(&v)
        }
    }
}

impl Real for f64 {
    const LANES: usize = 1;
    #[inline(always)]
    fn splat(v: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn mul_add(self, a: f64, b: f64) -> f64 {
        f64::mul_add(self, a, b)
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn load(s: &[f64]) -> f64 {
        s[0]
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        s[0] = self;
    }
}

/// Eight f64 in an array: the portable block (loops the compiler may vectorise; its
/// `mul_add` is the library's fused multiply-add, exact but slow without FMA hardware).
#[derive(Debug, Clone, Copy)]
pub struct VArr([f64; LANES]);

macro_rules! varr_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for VArr {
            type Output = VArr;
            #[inline(always)]
            fn $f(self, b: VArr) -> VArr {
                VArr(std::array::from_fn(|l| self.0[l] $op b.0[l]))
            }
        }
    };
}
varr_op!(Add, add, +);
varr_op!(Sub, sub, -);
varr_op!(Mul, mul, *);
varr_op!(Div, div, /);

impl Neg for VArr {
    type Output = VArr;
    #[inline(always)]
    fn neg(self) -> VArr {
        VArr(self.0.map(|v| -v))
    }
}

impl Real for VArr {
    const LANES: usize = LANES;
    #[inline(always)]
    fn splat(v: f64) -> VArr {
        VArr([v; LANES])
    }
    #[inline(always)]
    fn mul_add(self, a: VArr, b: VArr) -> VArr {
        VArr(std::array::from_fn(|l| self.0[l].mul_add(a.0[l], b.0[l])))
    }
    #[inline(always)]
    fn sqrt(self) -> VArr {
        VArr(self.0.map(f64::sqrt))
    }
    #[inline(always)]
    fn load(s: &[f64]) -> VArr {
        VArr(s[..LANES].try_into().unwrap())
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        s[..LANES].copy_from_slice(&self.0);
    }
}

#[cfg(target_arch = "x86_64")]
pub use x86::{V256x2, V512};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Real, LANES};
    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Neg, Sub};

    /// One AVX-512 register of eight f64. Only for code compiled with avx512f.
    #[derive(Clone, Copy)]
    pub struct V512(__m512d);

    /// Two AVX2 registers of four f64. Only for code compiled with avx2 and fma.
    #[derive(Clone, Copy)]
    pub struct V256x2(__m256d, __m256d);

    macro_rules! op {
        ($tr:ident, $f:ident, $i512:ident, $i256:ident) => {
            impl $tr for V512 {
                type Output = V512;
                #[inline(always)]
                fn $f(self, b: V512) -> V512 {
                    // SAFETY: V512 lives only in code compiled with avx512f (module doc).
                    V512(unsafe { $i512(self.0, b.0) })
                }
            }
            impl $tr for V256x2 {
                type Output = V256x2;
                #[inline(always)]
                fn $f(self, b: V256x2) -> V256x2 {
                    // SAFETY: V256x2 lives only in code compiled with avx2 (module doc).
                    unsafe { V256x2($i256(self.0, b.0), $i256(self.1, b.1)) }
                }
            }
        };
    }
    op!(Add, add, _mm512_add_pd, _mm256_add_pd);
    op!(Sub, sub, _mm512_sub_pd, _mm256_sub_pd);
    op!(Mul, mul, _mm512_mul_pd, _mm256_mul_pd);
    op!(Div, div, _mm512_div_pd, _mm256_div_pd);

    impl Neg for V512 {
        type Output = V512;
        #[inline(always)]
        fn neg(self) -> V512 {
            // the sign bit flipped: exact, as -x on one f64
            // SAFETY: as the operators above.
            unsafe {
                V512(_mm512_castsi512_pd(_mm512_xor_si512(
                    _mm512_castpd_si512(self.0),
                    _mm512_set1_epi64(i64::MIN),
                )))
            }
        }
    }

    impl Neg for V256x2 {
        type Output = V256x2;
        #[inline(always)]
        fn neg(self) -> V256x2 {
            // SAFETY: as the operators above.
            unsafe {
                let m = _mm256_set1_pd(-0.0);
                V256x2(_mm256_xor_pd(self.0, m), _mm256_xor_pd(self.1, m))
            }
        }
    }

    impl Real for V512 {
        const LANES: usize = LANES;
        #[inline(always)]
        fn splat(v: f64) -> V512 {
            // SAFETY: as the operators above.
            V512(unsafe { _mm512_set1_pd(v) })
        }
        #[inline(always)]
        fn mul_add(self, a: V512, b: V512) -> V512 {
            // SAFETY: as the operators above.
            V512(unsafe { _mm512_fmadd_pd(self.0, a.0, b.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> V512 {
            // SAFETY: as the operators above.
            V512(unsafe { _mm512_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn load(s: &[f64]) -> V512 {
            let s = &s[..LANES];
            // SAFETY: eight readable f64 (the slice above); unaligned load.
            V512(unsafe { _mm512_loadu_pd(s.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, s: &mut [f64]) {
            let s = &mut s[..LANES];
            // SAFETY: eight writable f64 (the slice above); unaligned store.
            unsafe { _mm512_storeu_pd(s.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn store_stream(self, s: &mut [f64]) {
            let s = &mut s[..LANES];
            if (s.as_ptr() as usize).is_multiple_of(64) {
                // SAFETY: eight writable f64 on one cache line (checked above).
                unsafe { _mm512_stream_pd(s.as_mut_ptr(), self.0) }
            } else {
                self.store(s)
            }
        }
        #[inline(always)]
        fn fence() {
            // SAFETY: sfence has no precondition.
            unsafe { _mm_sfence() }
        }
    }

    impl Real for V256x2 {
        const LANES: usize = LANES;
        #[inline(always)]
        fn splat(v: f64) -> V256x2 {
            // SAFETY: as the operators above.
            unsafe { V256x2(_mm256_set1_pd(v), _mm256_set1_pd(v)) }
        }
        #[inline(always)]
        fn mul_add(self, a: V256x2, b: V256x2) -> V256x2 {
            // SAFETY: as the operators above (with fma).
            unsafe {
                V256x2(
                    _mm256_fmadd_pd(self.0, a.0, b.0),
                    _mm256_fmadd_pd(self.1, a.1, b.1),
                )
            }
        }
        #[inline(always)]
        fn sqrt(self) -> V256x2 {
            // SAFETY: as the operators above.
            unsafe { V256x2(_mm256_sqrt_pd(self.0), _mm256_sqrt_pd(self.1)) }
        }
        #[inline(always)]
        fn load(s: &[f64]) -> V256x2 {
            let s = &s[..LANES];
            // SAFETY: eight readable f64 (the slice above); unaligned loads.
            unsafe {
                V256x2(
                    _mm256_loadu_pd(s.as_ptr()),
                    _mm256_loadu_pd(s.as_ptr().add(4)),
                )
            }
        }
        #[inline(always)]
        fn store(self, s: &mut [f64]) {
            let s = &mut s[..LANES];
            // SAFETY: eight writable f64 (the slice above); unaligned stores.
            unsafe {
                _mm256_storeu_pd(s.as_mut_ptr(), self.0);
                _mm256_storeu_pd(s.as_mut_ptr().add(4), self.1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation of a vector type gives, lane by lane, the bits of the same operation on
    /// one f64 (signed zeros, subnormals and a NaN-free spread of magnitudes included).
    #[inline(always)]
    fn lanes_equal_scalar<R: Real>() {
        let a = [1.5, -0.0, 3e-310, -7.25, 1e300, 0.1, 2.0 / 3.0, 1e-8];
        let b = [0.3, 2.0, -1e-300, 0.125, -1e-10, 7.0, -1.0 / 3.0, 5.0];
        let c = [-0.7, 0.0, 4.0, 1e-20, 3.0, -0.2, 0.5, 1e8];
        let (va, vb, vc) = (R::load(&a), R::load(&b), R::load(&c));
        type Scalar = fn(f64, f64, f64) -> f64;
        let ops: [(R, Scalar); 8] = [
            (va + vb, |a, b, _| a + b),
            (va - vb, |a, b, _| a - b),
            (va * vb, |a, b, _| a * b),
            (va / vb, |a, b, _| a / b),
            (-va, |a, _, _| -a),
            ((va * va).sqrt(), |a, _, _| (a * a).sqrt()),
            (va.mul_add(vb, vc), |a, b, c| a.mul_add(b, c)),
            (R::splat(0.25) * va, |a, _, _| 0.25 * a),
        ];
        for (k, (v, f)) in ops.iter().enumerate() {
            let mut out = [0.0; LANES];
            v.store(&mut out);
            for l in 0..LANES {
                assert_eq!(
                    out[l].to_bits(),
                    f(a[l], b[l], c[l]).to_bits(),
                    "op {k} lane {l}"
                );
            }
        }
        let field: Vec<f64> = (0..20).map(|i| i as f64 * 0.5).collect();
        let idx = [3, 17, 0, 5, 5, 9, 12, 1];
        let mut out = [0.0; LANES];
        R::field(
            &field,
            Cells {
                idx: &idx,
                contiguous: false,
            },
        )
        .store(&mut out);
        assert_eq!(out, idx.map(|i| field[i]));
        let run = [4, 5, 6, 7, 8, 9, 10, 11];
        R::field(
            &field,
            Cells {
                idx: &run,
                contiguous: true,
            },
        )
        .store(&mut out);
        assert_eq!(out, run.map(|i| field[i]));
    }

    #[test]
    fn portable_block_equals_scalar_bitwise() {
        lanes_equal_scalar::<VArr>();
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_blocks_equal_scalar_bitwise() {
        #[target_feature(enable = "avx2,fma")]
        unsafe fn avx2() {
            lanes_equal_scalar::<V256x2>();
        }
        #[target_feature(enable = "avx512f,avx2,fma")]
        unsafe fn avx512() {
            lanes_equal_scalar::<V512>();
        }
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            // SAFETY: the features were detected.
            unsafe { avx2() };
        } else {
            eprintln!("skipped the AVX2 lanes: this CPU has no avx2 and fma");
        }
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: the feature was detected.
            unsafe { avx512() };
        } else {
            eprintln!("skipped the AVX-512 lanes: this CPU has no avx512f");
        }
    }
}
