//! Hydrodynamic resistance: Stokes sphere and Happel-Brenner ellipsoids (seed 000 appendix A).
