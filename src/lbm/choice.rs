//! Run-time choice of lattice and collision, turned into the compile-time types of one
//! monomorphised kernel: a [`Job`] is written once, generically, and [`dispatch`] calls it
//! with the chosen types.

use super::collision::{Bgk, Collision, Trt};
use super::lattice::{Lattice, D3Q15, D3Q19};
use crate::error::{invalid, Result};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LatticeKind {
    D3Q15,
    D3Q19,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CollisionKind {
    Bgk,
    /// TRT with Lambda = 3/16.
    Trt,
}

impl LatticeKind {
    pub fn parse(s: &str, key: &str) -> Result<LatticeKind> {
        match s.to_ascii_uppercase().as_str() {
            "D3Q15" => Ok(LatticeKind::D3Q15),
            "D3Q19" => Ok(LatticeKind::D3Q19),
            _ => invalid(format!("{key} = \"{s}\": must be \"D3Q15\" or \"D3Q19\"")),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            LatticeKind::D3Q15 => D3Q15::NAME,
            LatticeKind::D3Q19 => D3Q19::NAME,
        }
    }
    pub fn q(self) -> usize {
        match self {
            LatticeKind::D3Q15 => D3Q15::Q,
            LatticeKind::D3Q19 => D3Q19::Q,
        }
    }
}

impl CollisionKind {
    pub fn parse(s: &str, key: &str) -> Result<CollisionKind> {
        match s.to_ascii_uppercase().as_str() {
            "BGK" => Ok(CollisionKind::Bgk),
            "TRT" => Ok(CollisionKind::Trt),
            _ => invalid(format!("{key} = \"{s}\": must be \"bgk\" or \"trt\"")),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            CollisionKind::Bgk => Bgk::NAME,
            CollisionKind::Trt => Trt::NAME,
        }
    }
}

/// Work that is generic in the lattice and the collision.
pub trait Job {
    type Out;
    fn run<L: Lattice, C: Collision>(self, collision: C) -> Self::Out;
}

/// Runs `job` with the chosen lattice and collision at relaxation time `tau`.
pub fn dispatch<J: Job>(lat: LatticeKind, coll: CollisionKind, tau: f64, job: J) -> J::Out {
    match (lat, coll) {
        (LatticeKind::D3Q15, CollisionKind::Bgk) => job.run::<D3Q15, _>(Bgk::from_tau(tau)),
        (LatticeKind::D3Q15, CollisionKind::Trt) => job.run::<D3Q15, _>(Trt::magic(tau)),
        (LatticeKind::D3Q19, CollisionKind::Bgk) => job.run::<D3Q19, _>(Bgk::from_tau(tau)),
        (LatticeKind::D3Q19, CollisionKind::Trt) => job.run::<D3Q19, _>(Trt::magic(tau)),
    }
}
