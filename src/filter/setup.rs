//! What a filter run is: the bed, the carrier flow, the magnetic field of the fibres, the
//! particles (radius, moment law, how many), the solvent, the time step, the depth and the seed.

use super::bed::FibreBed;
use super::flow::VelocityLattice;
use crate::brownian::{FieldSource, Fluid, LangevinMoment};
use crate::error::{invalid, require_positive, Result};

/// A filter run (module documentation of [`super`] for the model). The particles are fed as
/// one pulse at t = 0 on the inlet plane z = 0, in proportion to the local axial flux.
pub struct Setup {
    pub bed: FibreBed,
    pub flow: VelocityLattice,
    /// H (A/m, applied field included) and dH_i/dx_j of the fibres, periodic in the cell
    /// (None: no field, no magnetic force).
    pub field: Option<Box<dyn FieldSource>>,
    pub moment: LangevinMoment,
    pub fluid: Fluid,
    /// Particles fed at the inlet.
    pub particles: usize,
    /// The bed's depth in cells along z (the flow direction): particles pass at z = cells L_z.
    pub cells_deep: usize,
    /// Time step (s); each particle subdivides it where its drift would move it too far.
    pub dt_s: f64,
    /// Largest displacement of one (sub)step (m), as a fraction of the fibre radius.
    pub max_step_fraction: f64,
    /// Thickness (m) of the layer around the exact fibre surfaces in which the flow is made
    /// to vanish on them ([`super::wall`]; about one voxel of the flow lattice). 0: the
    /// lattice's interpolation everywhere (a flow that is not a Stokes flow past the fibres,
    /// such as a plug flow, or one that already vanishes on them).
    pub wall_layer_m: f64,
    pub seed: u64,
}

impl Setup {
    /// Checks what [`super::Filter::new`] relies on.
    pub fn check(&self) -> Result<()> {
        require_positive(self.dt_s, || {
            format!("filter time step dt_s = {} s", self.dt_s)
        })?;
        if !(self.max_step_fraction > 0.0 && self.max_step_fraction <= 1.0) {
            return invalid(format!(
                "filter max_step_fraction = {}: must be in (0, 1]",
                self.max_step_fraction
            ));
        }
        if !(self.wall_layer_m.is_finite() && self.wall_layer_m >= 0.0) {
            return invalid(format!(
                "filter wall_layer_m = {} m: must be finite and >= 0",
                self.wall_layer_m
            ));
        }
        if self.particles == 0 {
            return invalid("filter particles = 0: feed at least one particle");
        }
        if self.cells_deep == 0 {
            return invalid("filter cells_deep = 0: the bed needs at least one cell");
        }
        let (lb, lf) = (self.bed.lengths_m(), self.flow.lengths_m());
        for k in 0..3 {
            if (lb[k] - lf[k]).abs() > 1e-9 * lb[k] {
                return invalid(format!(
                    "filter cell edge {}: the bed's {} m and the flow lattice's {} m differ",
                    ["x", "y", "z"][k],
                    lb[k],
                    lf[k]
                ));
            }
        }
        if self.flow.inlet_flux_weights().iter().sum::<f64>() <= 0.0 {
            return invalid("filter flow: no positive axial velocity on the inlet layer (z = 0)");
        }
        Ok(())
    }
}
