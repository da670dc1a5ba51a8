//! The complete dynamic state of a [`Coupled`] system as plain data (every f64 as its IEEE
//! bits), so that a run restored from it continues bitwise as the uninterrupted run would:
//!
//! * the DEM state of [`crate::dem::checkpoint`] (positions, velocities, the last and the
//!   external forces, neighbour list with tangential springs, wall springs);
//! * the fluid's post-collision populations and the LBM step count;
//! * the lagged slip |u - w| of every cell (Wen–Yu's Re of the next porosity update reads it);
//! * the coupling step count, the clock, the worst momentum imbalance and the largest
//!   displacement seen (the summary reports both).
//!
//! Everything else of a coupling step (porosity, overlaps, Guo–Zhao fields, the record, the
//! hydrodynamic forces) is recomputed from these before it is read (the porosity on loading).
//! The coupled run draws no random numbers after the DEM's initial dispersion, which the scene
//! rebuilds from its seed.

use super::engine::Coupled;
use crate::dem::checkpoint::DemState;
use crate::error::invalid;
use crate::Result;
use serde::{Deserialize, Serialize};

/// The state of a coupled run (see the module note).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoupledState {
    pub dem: DemState,
    pub populations: Vec<u64>,
    pub lbm_steps: u64,
    pub slip: Vec<u64>,
    pub steps: u64,
    pub time_s: u64,
    pub worst_balance: u64,
    pub max_move_seen_cells: u64,
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn floats(v: &[u64]) -> Vec<f64> {
    v.iter().map(|&b| f64::from_bits(b)).collect()
}

impl Coupled {
    /// The dynamic state, exactly.
    pub fn save_state(&self) -> CoupledState {
        CoupledState {
            dem: self.dem.save_state(),
            populations: bits(&self.lbm.populations()),
            lbm_steps: self.lbm.steps(),
            slip: bits(&self.slip),
            steps: self.steps,
            time_s: self.time_s.to_bits(),
            worst_balance: self.worst_balance.to_bits(),
            max_move_seen_cells: self.max_move_seen_cells.to_bits(),
        }
    }

    /// Replaces the dynamic state by `s`, taken from a run of the same scene (same particles,
    /// lattice and time steps; the DEM part checks its own).
    pub fn load_state(&mut self, s: &CoupledState) -> Result<()> {
        let cells = self.dims.cells();
        if s.slip.len() != cells {
            return invalid(format!(
                "checkpoint: {} lattice cells, the scene gives {cells}",
                s.slip.len()
            ));
        }
        self.dem.load_state(&s.dem)?;
        self.lbm
            .restore_populations(&floats(&s.populations), s.lbm_steps)
            .map_err(|e| crate::Error::InvalidInput(format!("checkpoint: {e}")))?;
        self.slip = floats(&s.slip);
        self.steps = s.steps;
        self.time_s = f64::from_bits(s.time_s);
        self.worst_balance = f64::from_bits(s.worst_balance);
        self.max_move_seen_cells = f64::from_bits(s.max_move_seen_cells);
        if !(self.lbm.mass().is_finite() && self.slip.iter().all(|v| v.is_finite())) {
            return invalid("checkpoint: non-finite fluid state");
        }
        // the porosity of the restored positions (and the lagged slip), as the step left it
        self.update_porosity()
    }
}
