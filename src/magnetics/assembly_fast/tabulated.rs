//! The superposition of a [`FibreAssembly`] with every image from one shared
//! [`CylinderTable`]: the model's sum term for term (same images, same taper, same order), each
//! image's exact kernel replaced by the table lookup (exact kernel in the table's exact zone
//! next to the fibre), and the images that can count at a point listed per bin beforehand
//! instead of enumerated over all fibres. No window and no grid: the error is the table's alone
//! (its relative tolerance per image, for T and grad T), so it falls with the tolerance down to
//! rounding, and the cost is one lookup (6 n^2 multiply-adds) per counting image instead of
//! the elliptic integrals of the exact kernel.

use super::{bin_centre, Bins, FibreAssembly, Image};
use crate::error::{invalid, require_positive, Result};
use crate::magnetics::cylinder_table::{CylinderTable, TableSpec, TableStats};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

/// What building a [`TabulatedAssembly`] produced (for reports and benchmarks).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TabulatedStats {
    pub table: TableStats,
    pub bins: [usize; 3],
    /// Mean images listed per bin (those within the cutoff plus the bin's radius).
    pub images_per_bin: f64,
    pub build_seconds: f64,
}

/// The tabulated superposition of a periodic [`FibreAssembly`] (module documentation).
#[derive(Debug, Clone)]
pub struct TabulatedAssembly {
    model: FibreAssembly,
    table: CylinderTable,
    bins: Bins,
    stats: TabulatedStats,
}

impl TabulatedAssembly {
    /// Builds the table to `spec` (its extent raised to the cutoff radius where shorter) and
    /// the per-bin image lists, bins of edge at most `bin_edge_m`, for `model` (periodic along
    /// x, y and z, with a cutoff).
    pub fn new(
        model: FibreAssembly,
        spec: TableSpec,
        bin_edge_m: f64,
    ) -> Result<TabulatedAssembly> {
        let t0 = std::time::Instant::now();
        require_positive(bin_edge_m, || format!("field bin edge {bin_edge_m} m"))?;
        let cell = *model.cell();
        if cell.periodic != [true; 3] {
            return invalid("the tabulated field needs a cell periodic along x, y and z");
        }
        let Some(cutoff) = model.cutoff() else {
            return invalid("the tabulated field needs a field cutoff");
        };
        let table = CylinderTable::new(
            model.cylinder,
            TableSpec {
                extent_m: spec.extent_m.max(cutoff.radius_m),
                ..spec
            },
        )?;
        let n: [usize; 3] = cell
            .lengths_m
            .map(|len| (len / bin_edge_m).ceil().max(1.0) as usize);
        let size: [f64; 3] = std::array::from_fn(|k| cell.lengths_m[k] / n[k] as f64);
        let bin_radius = 0.5 * size[0].hypot(size[1]).hypot(size[2]);
        let total = n[0] * n[1] * n[2];
        if total > 1 << 24 {
            return invalid(format!(
                "field bin edge {bin_edge_m} m: {total} bins; use larger bins"
            ));
        }
        let lists: Vec<Vec<Image>> = (0..total)
            .into_par_iter()
            .map(|b| {
                let mut l = Vec::new();
                model.images_within(
                    &bin_centre(n, size, b),
                    cutoff.radius_m + bin_radius,
                    &mut l,
                );
                l
            })
            .collect();
        let bins = Bins::from_lists(n, size, lists)?;
        let stats = TabulatedStats {
            table: *table.stats(),
            bins: n,
            images_per_bin: bins.images.len() as f64 / total as f64,
            build_seconds: t0.elapsed().as_secs_f64(),
        };
        Ok(TabulatedAssembly {
            model,
            table,
            bins,
            stats,
        })
    }

    pub fn model(&self) -> &FibreAssembly {
        &self.model
    }
    pub fn stats(&self) -> &TabulatedStats {
        &self.stats
    }

    /// (H, dH_i/dx_j) at p (world, m), applied field included: the model's tapered image sum
    /// with the table for the kernel.
    #[inline]
    pub fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        let p = self.model.cell.wrap(p);
        self.model
            .sum_images(&p, self.bins.of(&p), |m, q| self.table.h_and_gradient(m, q))
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::bed;
    use super::*;

    /// With the table's tolerance at 1e-10 the tabulated sum is the exact superposition to
    /// 1e-8 (T and grad T per image, summed over the images) at random points off the fibres,
    /// periodic images and taper included; a loose table (1e-3) is measurably worse, so the
    /// comparison can fail.
    #[test]
    fn tabulated_sum_is_the_exact_superposition_to_the_table_tolerance() {
        use rand::{Rng, SeedableRng};
        let model = bed(10, 4, 4.5e-3);
        let spec = |tolerance| TableSpec {
            tolerance,
            nodes: 10,
            exact_margin_m: 2e-5,
            extent_m: 0.0,
        };
        let fine = TabulatedAssembly::new(model.clone(), spec(1e-10), 1e-3).unwrap();
        let coarse = TabulatedAssembly::new(model.clone(), spec(1e-3), 1e-3).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (mut worst_fine, mut worst_coarse) = (0.0f64, 0.0f64);
        let mut checked = 0;
        while checked < 300 {
            let p = Vector3::from_fn(|_, _| rng.gen_range(-4e-3..8e-3));
            let pw = model.cell().wrap(&p);
            let mut ims = Vec::new();
            model.images_within(&pw, 3e-3, &mut ims);
            let inside = ims.iter().any(|im| {
                let i = im.fibre as usize;
                let d = pw - model.centre(i) - im.shift;
                let z = d.dot(&model.axis(i));
                (d - model.axis(i) * z).norm() <= 2.0e-4 && z.abs() <= 1e-3
            });
            if inside {
                continue;
            }
            let (he, ge) = model.exact(&p);
            let err = |(h, g): (Vector3<f64>, Matrix3<f64>)| {
                ((h - he).norm() / he.norm()).max((g - ge).norm() / ge.norm())
            };
            worst_fine = worst_fine.max(err(fine.h_and_gradient(&p)));
            worst_coarse = worst_coarse.max(err(coarse.h_and_gradient(&p)));
            checked += 1;
        }
        assert!(
            worst_fine < 1e-8,
            "fine table: worst relative error {worst_fine:e}"
        );
        assert!(
            worst_coarse > 10.0 * worst_fine,
            "coarse {worst_coarse:e} fine {worst_fine:e}"
        );
    }

    #[test]
    fn bad_input_is_refused_by_name() {
        let spec = TableSpec {
            tolerance: 1e-6,
            nodes: 8,
            exact_margin_m: 2e-5,
            extent_m: 0.0,
        };
        let e = TabulatedAssembly::new(bed(3, 1, 4.5e-3), spec, 0.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bin edge"), "{e}");
    }
}
