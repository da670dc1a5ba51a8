//! Population storage laid out for whole-cache-line stores. The kernel (pull scheme, two
//! arrays) reads Q populations per cell from one array and writes Q to the other; a normal
//! store first reads each destination line into the cache (write-allocate), so a step moves
//! 3 Q doubles per cell. A non-temporal store of a whole 64-byte line skips that read: 2 Q.
//! Contiguous blocks of the kernel start at x = 1, 9, 17, ... of a row, so the array is placed
//! with its element 1 on a line boundary; with nx a multiple of 8 every such block of every
//! row and population is then one whole line.

use super::collision::LANES;
use std::ops::{Deref, DerefMut};

/// Bytes of a cache line, the unit a non-temporal store writes without reading.
pub const LINE_BYTES: usize = 64;

/// One cache line of populations.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
struct Line([f64; LANES]);

const _: () = assert!(std::mem::size_of::<Line>() == LINE_BYTES);

/// A population array (as `[f64]` through `Deref`) whose element 1 starts a cache line.
#[derive(Debug, Clone)]
pub struct Populations {
    lines: Vec<Line>,
    len: usize,
}

impl Populations {
    /// `len` zeros.
    pub fn zeros(len: usize) -> Populations {
        // LANES - 1 elements of padding before element 0, then len elements
        let lines = (len + 2 * LANES - 2) / LANES;
        Populations {
            lines: vec![Line::default(); lines],
            len,
        }
    }
}

impl Deref for Populations {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        // SAFETY: `lines` holds at least LANES - 1 + len contiguous, initialised f64 (a Line
        // is [f64; LANES] with no padding), borrowed for the lifetime of &self.
        unsafe {
            std::slice::from_raw_parts((self.lines.as_ptr() as *const f64).add(LANES - 1), self.len)
        }
    }
}

impl DerefMut for Populations {
    fn deref_mut(&mut self) -> &mut [f64] {
        // SAFETY: as in `deref`, borrowed mutably for the lifetime of &mut self.
        unsafe {
            std::slice::from_raw_parts_mut(
                (self.lines.as_mut_ptr() as *mut f64).add(LANES - 1),
                self.len,
            )
        }
    }
}

/// Writes the block `v` to `dst` (one whole, line-aligned cache line) with non-temporal
/// stores. Only called from kernels compiled with AVX, which the caller has detected; the
/// caller fences (`_mm_sfence`) before other threads read the array.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn stream_line(dst: &mut [f64], v: &[f64; LANES]) {
    use std::arch::x86_64::{_mm256_loadu_pd, _mm256_stream_pd};
    debug_assert!(dst.len() == LANES && (dst.as_ptr() as usize) % LINE_BYTES == 0);
    // SAFETY: dst holds LANES = 8 doubles on a 64-byte boundary, so both halves are 32-byte
    // aligned as vmovntpd requires; the caller runs only where AVX was detected.
    unsafe {
        let p = dst.as_mut_ptr();
        _mm256_stream_pd(p, _mm256_loadu_pd(v.as_ptr()));
        _mm256_stream_pd(p.add(4), _mm256_loadu_pd(v.as_ptr().add(4)));
    }
}

/// Elsewhere a plain copy.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub fn stream_line(dst: &mut [f64], v: &[f64; LANES]) {
    dst.copy_from_slice(v);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn element_one_starts_a_line_and_the_length_is_exact() {
        for len in [1, 7, 8, 9, 100, 1000] {
            let mut p = Populations::zeros(len);
            assert_eq!(p.len(), len);
            assert_eq!((p[1..].as_ptr() as usize) % LINE_BYTES, 0);
            p[len - 1] = 1.0;
            assert!(p[..len - 1].iter().all(|&v| v == 0.0));
        }
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn streamed_line_reads_back() {
        if !is_x86_feature_detected!("avx") {
            eprintln!("skipped: this CPU has no AVX");
            return;
        }
        let mut p = Populations::zeros(40);
        let v: [f64; LANES] = std::array::from_fn(|l| l as f64 + 0.5);
        stream_line(&mut p[9..17], &v);
        // SAFETY: AVX (and so SSE2) was detected above.
        unsafe { std::arch::x86_64::_mm_sfence() };
        assert_eq!(&p[9..17], &v);
        assert!(p[..9].iter().chain(&p[17..]).all(|&x| x == 0.0));
    }
}
