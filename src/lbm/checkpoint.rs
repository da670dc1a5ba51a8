//! The state of a steady LBM run as plain data, every f64 kept as its IEEE bits, so that a
//! run restored from it continues bitwise as the uninterrupted run would: the post-collision
//! populations (unpadded order, [`Lbm::populations`]), the step count, and the convergence
//! monitor of the last check ([`Monitor`]: the run's first step, the mean velocity, the first
//! residual). The lattice, geometry, forcing and boundary planes follow from the setup; the
//! boundary planes' last rebuilt states are recomputed by the next step before anything reads
//! them.

use super::driver::Steady;
use super::engine::Lbm;
use super::engine::Monitor;
use super::pore::PoreResult;
use super::problems::Permeability;
use super::solver::Fields;
use crate::error::invalid;
use crate::Result;
use serde::{Deserialize, Serialize};

/// The state of a steady run (see the module note).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LbmState {
    pub cells: usize,
    pub populations: Vec<u64>,
    pub steps: u64,
    pub start_steps: u64,
    pub mean_u: [u64; 3],
    pub first_residual: Option<u64>,
}

impl Lbm {
    /// The state at the last check of a steady run (None before its first check).
    pub fn save_state(&self) -> Option<LbmState> {
        let m = self.monitor?;
        Some(LbmState {
            cells: self.dims().cells(),
            populations: self.populations().iter().map(|x| x.to_bits()).collect(),
            steps: self.steps(),
            start_steps: m.start_steps,
            mean_u: m.mean_u.map(f64::to_bits),
            first_residual: m.first_residual.map(f64::to_bits),
        })
    }

    /// Replaces the populations and the step count by those of `s`, saved from a run of the
    /// same setup; the next steady run continues from its monitor.
    pub fn load_state(&mut self, s: &LbmState) -> Result<()> {
        let cells = self.dims().cells();
        if s.cells != cells {
            return invalid(format!(
                "checkpoint: {} lattice cells, the setup gives {cells}",
                s.cells
            ));
        }
        if s.start_steps > s.steps {
            return invalid(format!(
                "checkpoint: the run starts at step {} after its step {}",
                s.start_steps, s.steps
            ));
        }
        let f: Vec<f64> = s.populations.iter().map(|&b| f64::from_bits(b)).collect();
        if f.iter().any(|x| !x.is_finite()) {
            return invalid("checkpoint: non-finite populations");
        }
        self.restore_populations(&f, s.steps)
            .map_err(|e| crate::Error::InvalidInput(format!("checkpoint: {e}")))?;
        let m = Monitor {
            start_steps: s.start_steps,
            mean_u: s.mean_u.map(f64::from_bits),
            first_residual: s.first_residual.map(f64::from_bits),
        };
        self.monitor = Some(m);
        self.resumed = Some(m);
        Ok(())
    }
}

impl Lbm {
    /// The superficial mean velocity at the last check of a steady run (None before its first
    /// check): what the run's stop rule and a checkpoint's monitor hold.
    pub fn checked_mean_u(&self) -> Option<[f64; 3]> {
        self.monitor.map(|m| m.mean_u)
    }
}

/// A finished pore-resolving run ([`PoreResult`], a rung of a ladder) as plain data, every
/// f64 as its IEEE bits; its fields only where they are kept (`fields`: rho, then u).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoreResultState {
    pub n: usize,
    /// k (configuration unit^2), porosity, Re.
    pub k_porosity_re: [u64; 3],
    /// The lattice run: k, nu, porosity, mean u_x, largest |u|, residual, mass change.
    pub lattice: [u64; 7],
    pub steps: u64,
    pub converged: bool,
    /// The steady run's superficial mean velocity.
    pub mean_u: [u64; 3],
    pub fields: Option<(Vec<u64>, Vec<[u64; 3]>)>,
}

impl PoreResultState {
    /// The state of `r`, with its fields when `with_fields`.
    pub fn of(r: &PoreResult, with_fields: bool) -> PoreResultState {
        let p = &r.run;
        let f = &p.steady.fields;
        PoreResultState {
            n: r.n,
            k_porosity_re: [r.k, r.porosity, r.re].map(f64::to_bits),
            lattice: [
                p.k,
                p.nu,
                p.porosity,
                p.mean_u,
                p.u_max,
                p.residual,
                p.mass_change,
            ]
            .map(f64::to_bits),
            steps: p.steps,
            converged: p.converged,
            mean_u: p.steady.mean_u.map(f64::to_bits),
            fields: with_fields.then(|| {
                (
                    f.rho.iter().map(|x| x.to_bits()).collect(),
                    f.u.iter().map(|u| u.map(f64::to_bits)).collect(),
                )
            }),
        }
    }

    /// The result, bitwise as saved (empty fields where none were kept).
    pub fn result(&self) -> PoreResult {
        let f = f64::from_bits;
        let [k, porosity, re] = self.k_porosity_re.map(f);
        let [k_lattice, nu, porosity_lattice, mean_u, u_max, residual, mass_change] =
            self.lattice.map(f);
        let fields = match &self.fields {
            Some((rho, u)) => Fields {
                rho: rho.iter().map(|&b| f(b)).collect(),
                u: u.iter().map(|v| v.map(f)).collect(),
            },
            None => Fields {
                rho: Vec::new(),
                u: Vec::new(),
            },
        };
        PoreResult {
            n: self.n,
            k,
            porosity,
            re,
            run: Permeability {
                k: k_lattice,
                nu,
                porosity: porosity_lattice,
                mean_u,
                u_max,
                steps: self.steps,
                residual,
                converged: self.converged,
                steady: Steady {
                    fields,
                    mean_u: self.mean_u.map(f),
                    residual,
                    steps: self.steps,
                    converged: self.converged,
                    u_max,
                },
                mass_change,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::driver::{Hooks, NoHooks};
    use crate::lbm::driver::{run_steady, SteadyControl};
    use crate::lbm::problems::{DrivenChannel, Inlet};
    use crate::lbm::{CollisionKind, CollisionModel, LatticeKind, Lbm, Tau};
    use crate::Result;

    /// Stops after `n` checks, saving the state there through JSON; restores it when given.
    struct Interrupt {
        checks: u64,
        n: u64,
        saved: Option<String>,
    }

    impl Hooks<Lbm> for Interrupt {
        fn restore(&mut self, lbm: &mut Lbm) -> Result<()> {
            match self.saved.take() {
                Some(t) => lbm.load_state(&serde_json::from_str(&t).unwrap()),
                None => Ok(()),
            }
        }
        fn stop_requested(&mut self, lbm: &Lbm) -> bool {
            self.checks += 1;
            if self.checks == self.n {
                self.saved = Some(serde_json::to_string(&lbm.save_state().unwrap()).unwrap());
            }
            self.checks >= self.n
        }
    }

    /// A pressure-driven channel (inlet and outlet planes, whose last states the fields report)
    /// stopped after 3 checks and restored into a fresh engine ends bitwise as the
    /// uninterrupted run: the same fields, steps and residual.
    #[test]
    fn restored_steady_run_continues_bitwise() {
        let channel = DrivenChannel {
            h: 8,
            length: 16,
            inlet: Inlet::Density(1.001),
            rho_out: 1.0,
        };
        let coll = CollisionModel::new(CollisionKind::Trt, Tau::new(0.8).unwrap());
        let ctl = SteadyControl {
            check_every: 50,
            tol: 1e-9,
            max_steps: 4000,
        };
        let new = || Lbm::new(channel.setup(LatticeKind::D3Q19, coll).unwrap()).unwrap();
        let whole = run_steady(&mut new(), ctl, &mut NoHooks).unwrap();
        let mut stop = Interrupt {
            checks: 0,
            n: 3,
            saved: None,
        };
        let first = run_steady(&mut new(), ctl, &mut stop).unwrap();
        assert!(!first.converged && first.steps == 150 && whole.steps > 300);
        stop.n = u64::MAX;
        let resumed = run_steady(&mut new(), ctl, &mut stop).unwrap();
        assert_eq!(
            (resumed.steps, resumed.residual.to_bits()),
            (whole.steps, whole.residual.to_bits())
        );
        assert!(resumed.fields.u == whole.fields.u && resumed.fields.rho == whole.fields.rho);
    }
}
