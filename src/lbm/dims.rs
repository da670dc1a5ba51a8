//! The lattice's extent and its cell indexing.

use crate::error::{invalid, Result};

/// Lattice extent (cells along x, y, z); all boundaries are periodic unless a solid mask
/// closes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dims {
    pub nx: usize,
    pub ny: usize,
    pub nz: usize,
}

impl Dims {
    pub fn new(nx: usize, ny: usize, nz: usize) -> Result<Dims> {
        if nx == 0 || ny == 0 || nz == 0 {
            return invalid(format!(
                "lattice size {nx} x {ny} x {nz}: every extent must be at least 1 cell"
            ));
        }
        nx.checked_mul(ny)
            .and_then(|v| v.checked_mul(nz))
            .filter(|&n| n < u32::MAX as usize)
            .map(|_| Dims { nx, ny, nz })
            .ok_or_else(|| {
                crate::Error::InvalidInput(format!(
                    "lattice size {nx} x {ny} x {nz}: more than 2^32 cells"
                ))
            })
    }
    pub fn cells(&self) -> usize {
        self.nx * self.ny * self.nz
    }
    #[inline(always)]
    pub fn cell(&self, x: usize, y: usize, z: usize) -> usize {
        (z * self.ny + y) * self.nx + x
    }
    /// (x, y, z) of a cell index.
    pub fn coords(&self, cell: usize) -> [usize; 3] {
        [
            cell % self.nx,
            (cell / self.nx) % self.ny,
            cell / (self.nx * self.ny),
        ]
    }
    /// The periodic neighbour of (x, y, z) displaced by d.
    #[inline(always)]
    pub fn shifted(&self, p: [usize; 3], d: [i32; 3]) -> [usize; 3] {
        let w = |v: usize, d: i32, n: usize| ((v as i64 + d as i64).rem_euclid(n as i64)) as usize;
        [
            w(p[0], d[0], self.nx),
            w(p[1], d[1], self.ny),
            w(p[2], d[2], self.nz),
        ]
    }
}
