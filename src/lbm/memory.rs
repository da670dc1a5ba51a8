//! Where the kernel's arrays sit in the memory system: the size of the last-level cache (which
//! decides the non-temporal stores and the prefetch) and huge-page backing for the population
//! arrays and the per-cell fields, the strides that keep arrays read side by side out of
//! each other's cache sets, the layout of the population arrays ([`Layout`]) and the check
//! that a lattice fits into the memory available before anything is allocated.

use super::dims::Dims;
use super::simd::LANES;
use crate::error::{invalid, Result};

/// The stride (values of 8 bytes) at which to lay out arrays of `values` values one after
/// another that a block reads at the same index: one cache line more where `values` is a
/// multiple of 16, so that the stride is an odd number of lines. Else (every power-of-two
/// lattice) the arrays start a multiple of 4 KiB apart and a block's loads all fall into the
/// same cache sets.
pub fn stride_off_sets(values: usize) -> usize {
    if values.is_multiple_of(16) {
        values + 8
    } else {
        values
    }
}

/// Bytes of the largest CPU cache (Linux sysfs, cpu 0), 32 MiB where it cannot be read.
pub fn last_level_cache_bytes() -> u64 {
    static BYTES: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *BYTES.get_or_init(|| {
        let dir = std::path::Path::new("/sys/devices/system/cpu/cpu0/cache");
        let size = |e: std::fs::DirEntry| -> Option<u64> {
            let s = std::fs::read_to_string(e.path().join("size")).ok()?;
            let s = s.trim();
            let (num, mult) = match s.strip_suffix('K') {
                Some(n) => (n, 1 << 10),
                None => match s.strip_suffix('M') {
                    Some(n) => (n, 1 << 20),
                    None => (s, 1),
                },
            };
            num.parse::<u64>().ok().map(|n| n * mult)
        };
        std::fs::read_dir(dir)
            .ok()
            .and_then(|d| d.flatten().filter_map(size).max())
            .unwrap_or(32 << 20)
    })
}

/// `vec![value; n]`, backed by transparent huge pages where the system grants them only on
/// request (Linux `madvise` mode): the kernel pulls 15-19 upstream rows and writes as many,
/// each crossing a 4 KiB page every 512 values, and with 2 MiB pages those crossings stop
/// costing a page walk each. Advice only: a refusal, or another system, leaves ordinary pages.
pub fn vec_on_huge_pages<T: Clone>(n: usize, value: T) -> Vec<T> {
    let mut v: Vec<T> = Vec::with_capacity(n);
    let bytes = n * std::mem::size_of::<T>();
    #[cfg(target_os = "linux")]
    if bytes >= 2 << 20 {
        const PAGE: usize = 4096;
        let ptr = v.as_mut_ptr() as usize;
        let (start, end) = (ptr.next_multiple_of(PAGE), (ptr + bytes) / PAGE * PAGE);
        // SAFETY: madvise only changes how the kernel backs the range, which lies inside this
        // allocation (not yet written); it reads and writes no memory.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = bytes;
    v.resize(n, value);
    v
}

/// One cache line of populations: the unit of [`Populations`]' storage.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
struct Line([f64; LANES]);

/// A population array that starts on a cache line, so that with nx a multiple of [`LANES`]
/// every contiguous block of the kernel is one aligned load or store per population.
pub struct Populations {
    lines: Vec<Line>,
    len: usize,
}

impl Populations {
    pub fn zeros(len: usize) -> Populations {
        Populations {
            lines: vec_on_huge_pages(len.div_ceil(LANES), Line::default()),
            len,
        }
    }
}

impl std::ops::Deref for Populations {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        // SAFETY: `Line` is repr(C) around [f64; LANES] (size 8 LANES, no padding), so the
        // lines are `LANES * lines.len() >= len` contiguous, initialised f64.
        unsafe { std::slice::from_raw_parts(self.lines.as_ptr().cast::<f64>(), self.len) }
    }
}

impl std::ops::DerefMut for Populations {
    fn deref_mut(&mut self) -> &mut [f64] {
        // SAFETY: as in `deref`, through the unique borrow of the lines.
        unsafe { std::slice::from_raw_parts_mut(self.lines.as_mut_ptr().cast::<f64>(), self.len) }
    }
}

/// Where population q of cell (x, y, z) lives in the population arrays:
/// `z z_stride + q q_stride + y nx + x` with q_stride = ny nx (plus one cache line at
/// power-of-two sizes, see [`stride_off_sets`]) and z_stride = Q q_stride, the one place the
/// kernel, the boundaries and the sums take the index from.
#[derive(Debug, Clone, Copy)]
pub struct Layout {
    pub nx: usize,
    pub nz: usize,
    pub q_stride: usize,
    pub z_stride: usize,
}

impl Layout {
    pub fn new(d: &Dims, q: usize) -> Layout {
        let q_stride = stride_off_sets(d.ny * d.nx);
        Layout {
            nx: d.nx,
            nz: d.nz,
            q_stride,
            z_stride: q * q_stride,
        }
    }

    /// Values in one population array.
    pub fn values(&self) -> usize {
        self.nz * self.z_stride
    }

    #[inline(always)]
    pub fn index(&self, z: usize, q: usize, y: usize, x: usize) -> usize {
        z * self.z_stride + q * self.q_stride + y * self.nx + x
    }
}

/// Bytes a solver of `cells` cells with `q` populations allocates (two population arrays,
/// mask, and `extra_per_cell` bytes of forcing fields).
pub fn bytes_needed(cells: usize, q: usize, extra_per_cell: usize) -> u128 {
    cells as u128 * (2 * 8 * q as u128 + 1 + extra_per_cell as u128)
}

/// Memory this process may take: MemAvailable of /proc/meminfo, or None where unknown.
pub fn memory_available() -> Option<u128> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u128 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses a lattice whose arrays need more than the available memory, before allocating.
pub fn check_memory(dims: Dims, q: usize, extra_per_cell: usize) -> Result<()> {
    let need = bytes_needed(dims.cells(), q, extra_per_cell);
    if let Some(avail) = memory_available() {
        if need > avail {
            return invalid(format!(
                "lattice {} x {} x {} with Q = {q} needs {:.2} GiB, more than the {:.2} GiB of \
                 memory available: use a coarser resolution",
                dims.nx,
                dims.ny,
                dims.nz,
                need as f64 / 1073741824.0,
                avail as f64 / 1073741824.0
            ));
        }
    }
    Ok(())
}
