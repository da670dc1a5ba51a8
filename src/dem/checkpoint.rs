//! The complete dynamic state of a [`Dem`] as plain data, every f64 kept as its IEEE bits, so
//! that a run restored from it continues bitwise as the uninterrupted run would: positions,
//! velocities (half-step and predicted full-step), spins, the last forces and torques (the
//! next half-kick uses them), the neighbour list with its tangential springs and the positions
//! at its last build (which decide the next rebuild), the wall springs and forces, the top
//! wall, the clock and the step count. What the setup fixes (radii, masses, materials, the
//! time step) is rebuilt from the setup and checked against the stored values.

use super::engine::Dem;
use super::neighbour::Pair;
use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Bits of three f64.
type V3 = [u64; 3];

fn to_bits(v: &Vector3<f64>) -> V3 {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

fn from_bits(b: &V3) -> Vector3<f64> {
    Vector3::new(
        f64::from_bits(b[0]),
        f64::from_bits(b[1]),
        f64::from_bits(b[2]),
    )
}

fn vecs_to_bits(v: &[Vector3<f64>]) -> Vec<V3> {
    v.iter().map(to_bits).collect()
}

fn vecs_from_bits(v: &[V3]) -> Vec<Vector3<f64>> {
    v.iter().map(from_bits).collect()
}

/// One neighbour-list pair: (i, j, xi, delta bits). (The pairs' forces are not state: every
/// step computes them before it reads them.)
type PairBits = (u32, u32, V3, u64);

/// The state of a DEM run (see the module note).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DemState {
    pub dt_s: u64,
    pub time_s: u64,
    pub steps: u64,
    pub top_z_m: u64,
    pub top_v_m_s: u64,
    pub floor_force_n: u64,
    pub top_force_n: u64,
    pub top_stiffness_n_per_m: u64,
    pub radius: Vec<u64>,
    pub pos: Vec<V3>,
    pub vel: Vec<V3>,
    pub omega: Vec<V3>,
    pub vel_full: Vec<V3>,
    pub omega_full: Vec<V3>,
    pub force: Vec<V3>,
    pub torque: Vec<V3>,
    pub external: Vec<V3>,
    pub wall_xi: Vec<[V3; 2]>,
    pub wall_fz: Vec<[u64; 3]>,
    /// Per particle force of both walls, and its sum (the coupled momentum ledger reads it).
    pub wall_f: Vec<V3>,
    pub wall_force_n: V3,
    pub pairs: Vec<PairBits>,
    pub first_start: Vec<u32>,
    pub second_start: Vec<u32>,
    pub second_pairs: Vec<u32>,
    pub pos_at_build: Vec<V3>,
    pub builds: usize,
}

impl Dem {
    /// The dynamic state, exactly.
    pub fn save_state(&self) -> DemState {
        DemState {
            dt_s: self.dt_s.to_bits(),
            time_s: self.time_s.to_bits(),
            steps: self.steps,
            top_z_m: self.top_z_m.to_bits(),
            top_v_m_s: self.top_v_m_s.to_bits(),
            floor_force_n: self.floor_force_n.to_bits(),
            top_force_n: self.top_force_n.to_bits(),
            top_stiffness_n_per_m: self.top_stiffness_n_per_m.to_bits(),
            radius: self.p.radius.iter().map(|r| r.to_bits()).collect(),
            pos: vecs_to_bits(&self.p.pos),
            vel: vecs_to_bits(&self.p.vel),
            omega: vecs_to_bits(&self.p.omega),
            vel_full: vecs_to_bits(&self.vel_full),
            omega_full: vecs_to_bits(&self.omega_full),
            force: vecs_to_bits(&self.force),
            torque: vecs_to_bits(&self.torque),
            external: vecs_to_bits(&self.external),
            wall_xi: self
                .wall_xi
                .iter()
                .map(|w| [to_bits(&w[0]), to_bits(&w[1])])
                .collect(),
            wall_fz: self
                .wall_fz
                .iter()
                .map(|w| [w[0].to_bits(), w[1].to_bits(), w[2].to_bits()])
                .collect(),
            wall_f: vecs_to_bits(&self.wall_f),
            wall_force_n: to_bits(&self.wall_force_n),
            pairs: self
                .nl
                .pairs
                .iter()
                .map(|p| (p.i, p.j, to_bits(&p.xi), p.delta.to_bits()))
                .collect(),
            first_start: self.nl.first_start.clone(),
            second_start: self.nl.second_start.clone(),
            second_pairs: self.nl.second_pairs.clone(),
            pos_at_build: vecs_to_bits(&self.nl.pos_at_build),
            builds: self.nl.builds,
        }
    }

    /// Replaces the dynamic state by `s`, taken from a run of the same setup: the particle
    /// count, the radii and the time step must be bitwise those of this system.
    pub fn load_state(&mut self, s: &DemState) -> Result<()> {
        let n = self.p.len();
        let per_particle = [
            ("radius", s.radius.len()),
            ("pos", s.pos.len()),
            ("vel", s.vel.len()),
            ("omega", s.omega.len()),
            ("vel_full", s.vel_full.len()),
            ("omega_full", s.omega_full.len()),
            ("force", s.force.len()),
            ("torque", s.torque.len()),
            ("wall_xi", s.wall_xi.len()),
            ("wall_fz", s.wall_fz.len()),
            ("wall_f", s.wall_f.len()),
            ("pos_at_build", s.pos_at_build.len()),
        ];
        if let Some((name, len)) = per_particle.iter().find(|(_, len)| *len != n) {
            return invalid(format!(
                "checkpoint: {len} entries in `{name}`, but the setup has {n} particles"
            ));
        }
        if s.external.len() != n && !s.external.is_empty() {
            return invalid(format!(
                "checkpoint: {} external forces for {n} particles",
                s.external.len()
            ));
        }
        if let Some(i) = (0..n).find(|&i| s.radius[i] != self.p.radius[i].to_bits()) {
            return invalid(format!(
                "checkpoint: radius of particle {i} is {} m, the setup gives {} m",
                f64::from_bits(s.radius[i]),
                self.p.radius[i]
            ));
        }
        if s.dt_s != self.dt_s.to_bits() {
            return invalid(format!(
                "checkpoint: time step {} s, the setup gives {} s",
                f64::from_bits(s.dt_s),
                self.dt_s
            ));
        }
        let np = s.pairs.len();
        if s.first_start.len() != n + 1
            || s.second_start.len() != n + 1
            || s.second_pairs.len() != np
            || s.pairs
                .iter()
                .any(|p| p.0 as usize >= n || p.1 as usize >= n)
            || s.first_start
                .iter()
                .chain(&s.second_start)
                .chain(&s.second_pairs)
                .any(|&k| k as usize > np)
        {
            return invalid("checkpoint: the neighbour list is inconsistent with the particles");
        }
        let f = f64::from_bits;
        self.time_s = f(s.time_s);
        self.steps = s.steps;
        self.top_z_m = f(s.top_z_m);
        self.top_v_m_s = f(s.top_v_m_s);
        self.floor_force_n = f(s.floor_force_n);
        self.top_force_n = f(s.top_force_n);
        self.top_stiffness_n_per_m = f(s.top_stiffness_n_per_m);
        self.p.pos = vecs_from_bits(&s.pos);
        self.p.vel = vecs_from_bits(&s.vel);
        self.p.omega = vecs_from_bits(&s.omega);
        self.vel_full = vecs_from_bits(&s.vel_full);
        self.omega_full = vecs_from_bits(&s.omega_full);
        self.force = vecs_from_bits(&s.force);
        self.torque = vecs_from_bits(&s.torque);
        self.external = vecs_from_bits(&s.external);
        self.active.external = !self.external.is_empty();
        self.wall_xi = s
            .wall_xi
            .iter()
            .map(|w| [from_bits(&w[0]), from_bits(&w[1])])
            .collect();
        self.wall_fz = s
            .wall_fz
            .iter()
            .map(|w| [f(w[0]), f(w[1]), f(w[2])])
            .collect();
        self.wall_f = vecs_from_bits(&s.wall_f);
        self.wall_force_n = from_bits(&s.wall_force_n);
        self.nl.pairs = s
            .pairs
            .iter()
            .map(|p| Pair {
                i: p.0,
                j: p.1,
                delta: f(p.3),
                xi: from_bits(&p.2),
            })
            .collect();
        self.nl.first_start = s.first_start.clone();
        self.nl.second_start = s.second_start.clone();
        self.nl.second_pairs = s.second_pairs.clone();
        self.nl.pos_at_build = vecs_from_bits(&s.pos_at_build);
        self.nl.builds = s.builds;
        self.check_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::setup::testing::small_bed;

    /// The built-in small bed with 120 spheres at 68 % porosity, thrown at the floor so that
    /// contacts (with tangential springs) form within a few thousand steps.
    fn bed() -> Dem {
        let mut dem = Dem::new(small_bed(120, 0.68)).unwrap();
        for (k, v) in dem.p.vel.iter_mut().enumerate() {
            *v = Vector3::new(0.05 * ((k % 7) as f64 - 3.0), 0.0, -0.5);
        }
        dem
    }

    /// A run stopped half-way, saved through JSON and restored into a freshly built system
    /// ends in bitwise the state of the uninterrupted run (tangential springs included).
    #[test]
    fn restored_run_continues_bitwise() {
        let mut whole = bed();
        whole.run(20000).unwrap();
        let mut first = bed();
        first.run(10000).unwrap();
        let text = serde_json::to_string(&first.save_state()).unwrap();
        let mut second = bed();
        second
            .load_state(&serde_json::from_str(&text).unwrap())
            .unwrap();
        second.run(10000).unwrap();
        assert!(whole
            .nl
            .pairs
            .iter()
            .any(|p| p.delta > 0.0 && p.xi != Vector3::zeros()));
        assert_eq!(whole.save_state(), second.save_state());
    }

    #[test]
    fn a_foreign_state_is_refused() {
        let mut a = bed();
        let mut s = a.save_state();
        s.radius[3] = 1e-3f64.to_bits();
        let e = a.load_state(&s).unwrap_err().to_string();
        assert!(e.contains("radius of particle 3"), "{e}");
        let mut s = a.save_state();
        s.pos.pop();
        let e = a.load_state(&s).unwrap_err().to_string();
        assert!(e.contains("`pos`"), "{e}");
    }
}
