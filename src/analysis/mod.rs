//! Observables of particle configurations, one file per family: packing fraction
//! (`volume`), pair gaps and the independent overlap checks (`gaps`, `overlap`), contact
//! numbers (raw, at a gap cut-off, extrapolated to zero cut-off, with rattlers removed;
//! `contacts`), order parameters S and S4 (`order`), g(r) (`radial_distribution`), and
//! orientation near walls and over the sphere (`orientation`); porosity profiles and height
//! maps of deposits (`slab`, `height_map`).
//!
//! The functions take plain data ([`Configuration`]: particles of a species table of
//! contact-module shapes in a periodic cubic box, a hard cylinder or a hard wedge), so they
//! depend on no engine. Pair gaps are checked against a brute force over **all pairs and all
//! 27 periodic images** (no cell list, no minimum image), so they check an engine's neighbour
//! search rather than repeat it.

mod cells;
mod configuration;
mod contacts;
mod gaps;
pub mod height_map;
mod order;
mod orientation;
mod overlap;
pub mod pore_size;
mod radial_distribution;
pub mod rdf;
mod sampled;
pub mod slab;
mod volume;

#[cfg(test)]
mod tests;

pub use configuration::{rod_parameters, total_volume, Configuration, Rods};
pub use contacts::{contact_counts, cutoff_where_all_rattle, extrapolated_contacts, mean_contacts};
pub use gaps::{pair_gaps, pair_gaps_brute_force, worst_gap, PairGap, PERTURB_ANGLE};
pub use order::{cubatic_order, nematic_order};
pub use orientation::{orientation_histogram, wall_aligned_fraction};
pub use overlap::{check_no_overlap, wall_penetration, OVERLAP_SAMPLES};
pub use radial_distribution::radial_distribution;
pub use sampled::{sampled_overlap, SampledOverlap};
pub use volume::packing_fraction;
