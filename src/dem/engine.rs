//! The DEM integrator: soft spheres between a floor (z = 0) and a top wall, periodic in x and
//! y, driven by gravity, a uniform Stokes drag and a pressure-controlled top wall.
//!
//! Newton's law for translation and rotation (seed 002 eq. 1): m dv/dt = F_contact + F_drag +
//! m' g, I dw/dt = sum of (-R n) x F_t (the tangential forces at the contact points, lever arm R:
//! the rigid-sphere limit, so that the rolling closed forms hold at any overlap).
//!
//! Time stepping: velocity Verlet (the half-step leapfrog of the seed with synchronised
//! velocities). Velocity-dependent forces (dashpots, drag) use the full-step velocity predicted
//! from the last force, v(n+1) ~ v(n+1/2) + dt/2 a(n), which keeps the scheme second order
//! with damping (the half-step velocity that LAMMPS uses is first order in the dashpot); the
//! tangential spring advances by the half-step (midpoint) velocity times dt.
//!
//! Determinism: pair forces are computed per pair into the list (in parallel), then gathered
//! per particle in the list's fixed order (in parallel over particles); sums that drive the
//! dynamics (the top wall's force) are serial. On one thread the pair loop adds each force
//! into both members as it goes, which is the gather's order. The same seed gives bitwise the
//! same run at any thread count.

use super::lanes::{Lane, V3};
use super::model::{ContactLanes, ContactModel, ContactState, DampingModel, PairMaterial};
use super::neighbour::{moved_beyond, wrap_delta, NeighbourList, Pair, PairForce, PAR_MIN};
use super::particles::Particles;
use super::setup::{Drag, Setup, TopWall, WALL_RELAXATION};
use crate::error::{invalid, require_positive};
use crate::Result;
use nalgebra::Vector3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// The particles' state that the force loops read: positions, half-step and predicted
/// full-step velocities and spins, radii, masses.
#[derive(Clone, Copy)]
struct Bodies<'a> {
    pos: &'a [Vector3<f64>],
    vel: &'a [Vector3<f64>],
    om: &'a [Vector3<f64>],
    vf: &'a [Vector3<f64>],
    omf: &'a [Vector3<f64>],
    rad: &'a [f64],
    mass: &'a [f64],
}

/// What the pair force reads: box, contact model, time step and the particles' state.
pub(super) struct PairCtx<'a> {
    lx: f64,
    ly: f64,
    model: ContactModel,
    dt: f64,
    friction: bool,
    pp: PairMaterial,
    b: Bodies<'a>,
}

/// The contact forces of `T::LANES` neighbour pairs side by side, one per lane (and their
/// tangential histories), or their resets for pairs that are apart: lane l holds bitwise the
/// result of the pair alone (see [`ContactModel::force_lanes`]). Each touching pair's force
/// and n x F_t go into `forces` (the pairs' entries), or with `sums` into both members' sums at
/// once, in list order.
#[inline(always)]
fn pair_forces<T: Lane>(
    c: &PairCtx,
    prs: &mut [Pair],
    forces: Option<&mut [PairForce]>,
    sums: Option<&mut PairSums>,
) {
    debug_assert_eq!(prs.len(), T::LANES);
    let mut i = [0usize; 4];
    let mut j = [0usize; 4];
    for (l, pr) in prs.iter().enumerate() {
        (i[l], j[l]) = (pr.i as usize, pr.j as usize);
    }
    let d = V3::<T> {
        x: T::from_fn(|l| wrap_delta(c.b.pos[i[l]].x - c.b.pos[j[l]].x, c.lx)),
        y: T::from_fn(|l| wrap_delta(c.b.pos[i[l]].y - c.b.pos[j[l]].y, c.ly)),
        z: T::from_fn(|l| c.b.pos[i[l]].z - c.b.pos[j[l]].z),
    };
    let ri = T::from_fn(|l| c.b.rad[i[l]]);
    let rj = T::from_fn(|l| c.b.rad[j[l]]);
    let dist2 = d.norm_squared();
    let rs = ri + rj;
    let touching = dist2.lt(rs * rs);
    let dist = dist2.sqrt();
    let n = d.scale(T::splat(1.0) / dist);
    let rel = |v: &[Vector3<f64>]| V3::<T>::from_fn(|l| v[i[l]] - v[j[l]]);
    let (v_half, v_full) = if c.friction {
        let spin_half = V3::<T>::from_fn(|l| c.b.om[i[l]] * ri.lane(l) + c.b.om[j[l]] * rj.lane(l));
        let spin_full =
            V3::<T>::from_fn(|l| c.b.omf[i[l]] * ri.lane(l) + c.b.omf[j[l]] * rj.lane(l));
        (
            rel(c.b.vel).sub(&spin_half.cross(&n)),
            rel(c.b.vf).sub(&spin_full.cross(&n)),
        )
    } else {
        (rel(c.b.vel), rel(c.b.vf))
    };
    let (mi, mj) = (
        T::from_fn(|l| c.b.mass[i[l]]),
        T::from_fn(|l| c.b.mass[j[l]]),
    );
    let state = ContactLanes {
        delta: rs - dist,
        n,
        v_half,
        v_full,
        r_eff: ri * rj / rs,
        m_eff: mi * mj / (mi + mj),
        dt: c.dt,
    };
    let mut xi = V3::from_fn(|l| prs[l].xi);
    let (f, ft) = c.model.force_lanes(&state, &c.pp, &mut xi);
    let n_cross_ft = n.cross(&ft);
    for (l, pr) in prs.iter_mut().enumerate() {
        if T::mask_lane(touching, l) {
            pr.delta = state.delta.lane(l);
            pr.xi = xi.lane(l);
        } else {
            // apart: history cleared when the pair touched at the last step; only the sign of
            // delta is used until it touches again
            if pr.delta > 0.0 {
                pr.xi = Vector3::zeros();
            }
            pr.delta = -1.0;
        }
    }
    if let Some(fs) = forces {
        // the pairs the sums take (delta > 0); one that is apart adds +0 to the gather's
        // sums, which leaves them bitwise as they are (a sum that starts at +0 is never -0),
        // so the gather need not read the pairs
        for (l, (pf, pr)) in fs.iter_mut().zip(prs.iter()).enumerate() {
            (pf.force, pf.n_cross_ft) = if pr.delta > 0.0 {
                (f.lane(l), n_cross_ft.lane(l))
            } else {
                (Vector3::zeros(), Vector3::zeros())
            };
        }
    }
    if let Some(s) = sums {
        // the gather's order for each particle: the pairs where it is second, by first
        // member, then those where it is first; that is, the list order
        for (l, pr) in prs.iter().enumerate() {
            if pr.delta > 0.0 {
                let (fl, nl) = (f.lane(l), n_cross_ft.lane(l));
                s.force[i[l]] += fl;
                s.n_cross_ft[i[l]] += nl;
                s.force[j[l]] -= fl;
                s.n_cross_ft[j[l]] += nl;
            }
        }
    }
}

/// Per particle, the sums of its pairs' forces and of their n x F_t, accumulated by the pair
/// loop on one thread; zero outside a step's force computation (the gather takes them).
pub(super) struct PairSums<'a> {
    force: &'a mut [Vector3<f64>],
    n_cross_ft: &'a mut [Vector3<f64>],
}

/// [`pair_forces`] on every pair of `prs`, `T::LANES` at a time (`forces`: the pairs'
/// entries, as many).
#[inline(always)]
fn each_pair<T: Lane>(
    prs: &mut [Pair],
    forces: Option<&mut [PairForce]>,
    ctx: &PairCtx,
    mut sums: Option<&mut PairSums>,
) {
    match forces {
        Some(fs) => {
            debug_assert_eq!(fs.len(), prs.len());
            let mut blocks = prs.chunks_exact_mut(T::LANES);
            let mut f_blocks = fs.chunks_exact_mut(T::LANES);
            for (b, f) in (&mut blocks).zip(&mut f_blocks) {
                pair_forces::<T>(ctx, b, Some(f), None);
            }
            let tail = blocks.into_remainder().iter_mut();
            for (pr, f) in tail.zip(f_blocks.into_remainder()) {
                let (pr, f) = (std::slice::from_mut(pr), std::slice::from_mut(f));
                pair_forces::<f64>(ctx, pr, Some(f), None);
            }
        }
        None => {
            let mut blocks = prs.chunks_exact_mut(T::LANES);
            for b in &mut blocks {
                pair_forces::<T>(ctx, b, None, sums.as_deref_mut());
            }
            for pr in blocks.into_remainder() {
                let pr = std::slice::from_mut(pr);
                pair_forces::<f64>(ctx, pr, None, sums.as_deref_mut());
            }
        }
    }
}

/// What the per-particle gather reads: the pair list with its forces, the particles' state
/// (each particle's own half-step velocity and spin come with [`GatherOut`]), walls, gravity,
/// drag and external forces, and the second half kick when the gather ends a step.
pub(super) struct GatherCtx<'a> {
    nl: &'a NeighbourList,
    pos: &'a [Vector3<f64>],
    vf: &'a [Vector3<f64>],
    omf: &'a [Vector3<f64>],
    rad: &'a [f64],
    mass: &'a [f64],
    pw: PairMaterial,
    model: ContactModel,
    friction: bool,
    dt: f64,
    top_z: f64,
    top_v: f64,
    g: Vector3<f64>,
    drag: Option<Drag>,
    external: &'a [Vector3<f64>],
    kick: Option<HalfKick<'a>>,
}

/// The second half kick, v(n+1) = v(n+1/2) + a(n+1) dt/2 (the same for the spin), taken by the
/// gather on each particle as soon as its force is summed.
struct HalfKick<'a> {
    inv_mass: &'a [f64],
    inv_inertia: &'a [f64],
    rotation: bool,
}

/// What the gather writes, for a run of consecutive particles, and their half-step velocity
/// and spin (read by the wall contacts, then kicked to the full step).
pub(super) struct GatherOut<'a> {
    pub(super) force: &'a mut [Vector3<f64>],
    pub(super) torque: &'a mut [Vector3<f64>],
    pub(super) wall_xi: &'a mut [[Vector3<f64>; 2]],
    pub(super) wall_fz: &'a mut [[f64; 3]],
    pub(super) wall_f: &'a mut [Vector3<f64>],
    pub(super) vel: &'a mut [Vector3<f64>],
    pub(super) omega: &'a mut [Vector3<f64>],
    /// The pair loop's sums, when it made them: taken (and left zero) instead of gathering.
    pub(super) pair_sums: Option<PairSums<'a>>,
}

/// Particles from which the per-particle loops run in parallel.
pub(super) const PAR_MIN_PARTICLES: usize = 512;

/// Parallel tasks per thread of the pool in each parallel loop: few, so that a loop costs few
/// hand-overs between threads, but more than one, so that a thread delayed by other work on the
/// machine leaves some of its share to the other (four measured best of one, two and four).
const TASKS_PER_THREAD: usize = 4;

/// The length of the parallel tasks that split `len` items evenly into `tasks_per_thread` per
/// thread, a multiple of `align`. (Every item's result is independent of where the tasks
/// split.)
pub(super) fn task_len(len: usize, align: usize, tasks_per_thread: usize) -> usize {
    len.div_ceil(tasks_per_thread * rayon::current_num_threads())
        .next_multiple_of(align)
        .max(align)
}

/// Force and torque on particles start.. (as many as `out` holds): the pair forces in the
/// list's fixed order, the walls, gravity, external force and drag; then the second half kick
/// when `c.kick` asks for it.
#[inline(always)]
fn gather(c: &GatherCtx, start: usize, mut out: GatherOut) {
    let GatherCtx {
        nl,
        pos,
        vf,
        omf,
        rad,
        mass,
        pw,
        model,
        friction,
        dt,
        top_z,
        top_v,
        g,
        drag,
        external,
        kick,
    } = c;
    let (model, friction, dt, top_z, top_v) = (*model, *friction, *dt, *top_z, *top_v);
    let h = 0.5 * dt;
    for (offset, ((((f_out, t_out), wxi), wfz), wf)) in out
        .force
        .iter_mut()
        .zip(out.torque.iter_mut())
        .zip(out.wall_xi.iter_mut())
        .zip(out.wall_fz.iter_mut())
        .zip(out.wall_f.iter_mut())
        .enumerate()
    {
        let i = start + offset;
        let (vel, om) = (&mut out.vel[offset], &mut out.omega[offset]);
        let mut f = Vector3::zeros();
        let mut nxft = Vector3::zeros();
        if let Some(s) = &mut out.pair_sums {
            f = std::mem::take(&mut s.force[offset]);
            nxft = std::mem::take(&mut s.n_cross_ft[offset]);
        } else {
            let second = nl.second_start[i] as usize..nl.second_start[i + 1] as usize;
            for &k in &nl.second_pairs[second] {
                let pf = &nl.forces[k as usize];
                f -= pf.force;
                nxft += pf.n_cross_ft;
            }
            for pf in &nl.forces[nl.first_start[i] as usize..nl.first_start[i + 1] as usize] {
                f += pf.force;
                nxft += pf.n_cross_ft;
            }
        }
        let r = rad[i];
        let mut wall_sum: Option<Vector3<f64>> = None;
        // walls: spheres of infinite radius and mass (R* = R, m* = m)
        for (k, (dist, nz, wall_v)) in [(pos[i].z, 1.0, 0.0), (top_z - pos[i].z, -1.0, top_v)]
            .into_iter()
            .enumerate()
        {
            let delta = r - dist;
            if delta <= 0.0 {
                clear(wxi[k].as_mut_slice());
                // the wall's force slot, and the top wall's contact stiffness
                let fz = if k == 1 { 1..3 } else { 0..1 };
                clear(&mut wfz[fz]);
                continue;
            }
            if k == 1 {
                wfz[2] = model.normal.elastic(delta, r, pw.e_star_pa).1;
            }
            let n = Vector3::new(0.0, 0.0, nz);
            let wv = Vector3::new(0.0, 0.0, wall_v);
            let (v_half, v_full) = if friction {
                (
                    *vel - wv - (*om * r).cross(&n),
                    vf[i] - wv - (omf[i] * r).cross(&n),
                )
            } else {
                (*vel - wv, vf[i] - wv)
            };
            let c = ContactState {
                delta,
                n,
                v_half,
                v_full,
                r_eff: r,
                m_eff: mass[i],
                dt,
            };
            let (fw, ft) = model.force(&c, &pw, &mut wxi[k]);
            f += fw;
            *wall_sum.get_or_insert_with(Vector3::zeros) += fw;
            nxft += n.cross(&ft);
            wfz[k] = fw.z;
        }
        match wall_sum {
            Some(sum) => *wf = sum,
            None => clear(wf.as_mut_slice()),
        }
        f += g * mass[i];
        if let Some(e) = external.get(i) {
            f += *e;
        }
        if let Some(d) = &drag {
            f += (d.fluid_velocity_m_s - vf[i]) * (6.0 * PI * d.viscosity_pa_s * r);
        }
        *f_out = f;
        *t_out = -nxft * r;
        if let Some(k) = kick {
            *vel += f * (k.inv_mass[i] * h);
            if k.rotation {
                *om += *t_out * (k.inv_inertia[i] * h);
            }
        }
    }
}

/// Sets `xs` to +0 where it is not already, writing nothing when it is (the walls' arrays of
/// particles away from the walls: their cache lines stay clean, and are never written back).
#[inline(always)]
fn clear(xs: &mut [f64]) {
    if xs.iter().any(|x| x.to_bits() != 0) {
        xs.fill(0.0);
    }
}

/// What the integrator's kicks read.
pub(super) struct KickCtx<'a> {
    force: &'a [Vector3<f64>],
    torque: &'a [Vector3<f64>],
    inv_mass: &'a [f64],
    inv_inertia: &'a [f64],
    dt: f64,
    lx: f64,
    ly: f64,
    rotation: bool,
    /// The neighbour list's positions at its build and its squared drift limit (None: the list
    /// must be rebuilt anyway).
    at_build: Option<(&'a [Vector3<f64>], f64)>,
}

/// What the first kick and the drift move, for a run of consecutive particles.
pub(super) struct KickOut<'a> {
    pub(super) pos: &'a mut [Vector3<f64>],
    pub(super) vel: &'a mut [Vector3<f64>],
    pub(super) vel_full: &'a mut [Vector3<f64>],
    pub(super) omega: &'a mut [Vector3<f64>],
    pub(super) omega_full: &'a mut [Vector3<f64>],
}

/// Half kick and drift of particles start..: v(n+1/2) = v(n) + a dt/2, x(n+1) = x(n) +
/// v(n+1/2) dt (wrapped in x and y), and the full-step velocity predicted for the dashpots,
/// v(n+1) ~ v(n+1/2) + a dt/2 (the same for the spin). True when some particle of the run
/// moved past the neighbour list's drift limit (or the list is due anyway).
#[inline(always)]
fn kick_drift(c: &KickCtx, start: usize, out: KickOut) -> bool {
    let h = 0.5 * c.dt;
    let mut moved = c.at_build.is_none();
    for (offset, ((((x, v), vf), w), wf)) in out
        .pos
        .iter_mut()
        .zip(out.vel.iter_mut())
        .zip(out.vel_full.iter_mut())
        .zip(out.omega.iter_mut())
        .zip(out.omega_full.iter_mut())
        .enumerate()
    {
        let i = start + offset;
        let a = c.force[i] * c.inv_mass[i];
        *v += a * h;
        *x += *v * c.dt;
        x.x = wrap_into(x.x, c.lx);
        x.y = wrap_into(x.y, c.ly);
        *vf = *v + a * h;
        if c.rotation {
            let b = c.torque[i] * c.inv_inertia[i];
            *w += b * h;
            *wf = *w + b * h;
        }
        if let Some((at, lim2)) = c.at_build {
            moved |= moved_beyond(x, &at[i], c.lx, c.ly, lim2);
        }
    }
    moved
}

/// `$run`: `$fast` compiled for AVX2 + FMA (as `$avx2`) where the CPU has them, else `$slow`
/// (the same function on baseline x86-64, or its scalar form). Rust never fuses a multiply and
/// an add by itself and every lane operation is the scalar one, so the bits are the same either
/// way; the three-operand VEX forms spare the register copies of the baseline SSE2 code.
macro_rules! avx2_copy {
    ($run:ident, $avx2:ident: $fast:expr, else $slow:expr, ($($a:ident: $t:ty),*) -> $r:ty) => {
        /// # Safety
        /// The caller must have checked that the CPU supports avx2 and fma.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        unsafe fn $avx2($($a: $t),*) -> $r {
            $fast($($a),*)
        }
        #[inline(always)]
        pub(super) fn $run($($a: $t),*) -> $r {
            #[cfg(target_arch = "x86_64")]
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                // SAFETY: avx2 and fma were detected just above.
                return unsafe { $avx2($($a),*) };
            }
            $slow($($a),*)
        }
    };
}
avx2_copy!(run_pairs, each_pair_avx2: each_pair::<super::lanes::F64x4>, else each_pair::<f64>,
    (prs: &mut [Pair], forces: Option<&mut [PairForce]>, ctx: &PairCtx,
        sums: Option<&mut PairSums>) -> ());
avx2_copy!(run_gather, gather_avx2: gather, else gather,
    (c: &GatherCtx, start: usize, out: GatherOut) -> ());
avx2_copy!(run_kick_drift, kick_drift_avx2: kick_drift, else kick_drift,
    (c: &KickCtx, start: usize, out: KickOut) -> bool);

/// x wrapped into [0, l) after a move shorter than l.
#[inline(always)]
fn wrap_into(x: f64, l: f64) -> f64 {
    if x >= l {
        x - l
    } else if x < 0.0 {
        x + l
    } else {
        x
    }
}

/// The top wall's height after a step of `dt` at `top_v` from `top_z`; an error when it reaches
/// the floor (at time `time_s`).
pub(super) fn next_top_z(top_z: f64, top_v: f64, dt: f64, time_s: f64) -> Result<f64> {
    let z = top_z + top_v * dt;
    if z <= 0.0 {
        return invalid(format!(
            "top wall reached the floor at t = {time_s:e} s: the target pressure cannot be held \
             by these particles"
        ));
    }
    Ok(z)
}

/// The walls' forces on the particles summed after a gather (see [`Dem`]'s fields of the same
/// names).
pub(super) struct WallTotals {
    floor_force_n: f64,
    top_force_n: f64,
    top_stiffness_n_per_m: f64,
    pub(super) top_elastic_force_n: f64,
    pub(super) wall_force_n: Vector3<f64>,
}

impl WallTotals {
    pub(super) fn top_stiffness(&self) -> f64 {
        self.top_stiffness_n_per_m
    }

    pub(super) fn floor_force_n(&self) -> f64 {
        self.floor_force_n
    }
}

/// The walls' impulse on the particles over the steps run since it was set, by the trapezoidal
/// rule on the total wall force at both ends of each step (velocity Verlet kicks with the mean
/// of the two), the same sum of the force's magnitude (the scale of a momentum balance), and
/// the floor's z impulse alone.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WallLedger {
    /// N s.
    pub impulse_ns: Vector3<f64>,
    /// N s.
    pub magnitude_ns: f64,
    /// N s.
    pub floor_impulse_ns: f64,
}

impl WallLedger {
    /// Adds a step of `dt_s` from wall force `before_n` to `after_n` (both walls) and floor z
    /// force `floor_before_n` to `floor_after_n`.
    pub(super) fn add(
        &mut self,
        (before_n, floor_before_n): (Vector3<f64>, f64),
        (after_n, floor_after_n): (Vector3<f64>, f64),
        dt_s: f64,
    ) {
        let h = 0.5 * dt_s;
        self.impulse_ns += (before_n + after_n) * h;
        self.magnitude_ns += (before_n.norm() + after_n.norm()) * h;
        self.floor_impulse_ns += (floor_before_n + floor_after_n) * h;
    }
}

/// Which terms the run evaluates (printed before a run).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveTerms {
    pub friction_rotation: bool,
    pub damping: bool,
    pub gravity: bool,
    pub drag: bool,
    pub pressure_wall: bool,
    /// Per-particle external forces set through [`Dem::set_external_forces`].
    pub external: bool,
}

impl ActiveTerms {
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = vec!["normal contact"];
        for (on, name) in [
            (self.damping, "normal damping"),
            (self.friction_rotation, "tangential friction + rotation"),
            (self.gravity, "gravity"),
            (self.drag, "uniform Stokes drag"),
            (self.pressure_wall, "pressure-controlled top wall"),
            (self.external, "per-particle external force"),
        ] {
            if on {
                v.push(name);
            }
        }
        v
    }
}

/// Neighbour-list pairs per sphere assumed by [`Dem::estimated_bytes`] (a dense bed has about
/// 6 contacts per sphere, 3 pairs; the skin roughly triples the candidates).
const PAIRS_PER_PARTICLE: f64 = 10.0;

/// Bytes per sphere of the per-particle arrays: 13 vectors (position, velocities, spins, force,
/// torque, full-step velocities, wall springs and forces, external force, pair sums) and 7
/// scalars (radius, mass, inverses, wall forces).
const BYTES_PER_PARTICLE: f64 = (13 * 24 + 7 * 8) as f64;

/// A DEM system and its integrator state.
pub struct Dem {
    pub p: Particles,
    /// The setup it was built from (its start: the particles at t = 0).
    pub(super) setup: Setup,
    /// The time step in use (s): the setup's, or one set by [`Dem::with_time_step`].
    pub(super) dt_s: f64,
    pub time_s: f64,
    pub steps: u64,
    /// Current top-wall height and velocity.
    pub top_z_m: f64,
    pub top_v_m_s: f64,
    /// z force of the floor on the particles and of the particles on the top wall (N), last step.
    pub floor_force_n: f64,
    pub top_force_n: f64,
    /// Sum of the contact stiffnesses S_n of the top wall's contacts (N/m), last step.
    pub top_stiffness_n_per_m: f64,
    /// Elastic part of the particles' force on the top wall (N), last step: what the pressure
    /// controller compares with its target (recomputed every step, so not checkpointed).
    pub top_elastic_force_n: f64,
    /// Total force of both walls on the particles (N, normal and tangential), last step.
    pub wall_force_n: Vector3<f64>,
    /// When set, the walls' impulse on the particles is added to it every step (for a caller
    /// that runs several steps at once and balances momentum over them).
    pub wall_ledger: Option<WallLedger>,
    pub nl: NeighbourList,
    pub(super) force: Vec<Vector3<f64>>,
    pub(super) torque: Vec<Vector3<f64>>,
    pub(super) vel_full: Vec<Vector3<f64>>,
    pub(super) omega_full: Vec<Vector3<f64>>,
    inv_mass: Vec<f64>,
    inv_inertia: Vec<f64>,
    /// Effective (buoyant) mass factor 1 - rho_f / rho_p.
    buoyancy: f64,
    pub(super) wall_xi: Vec<[Vector3<f64>; 2]>,
    /// Per particle: z force of the floor, of the top wall, and the top contact's stiffness S_n.
    pub(super) wall_fz: Vec<[f64; 3]>,
    /// Per particle: force of both walls (normal and tangential).
    pub(super) wall_f: Vec<Vector3<f64>>,
    pp: PairMaterial,
    pw: PairMaterial,
    pub(super) active: ActiveTerms,
    /// Seconds spent rebuilding the neighbour list.
    pub neighbour_seconds: f64,
    /// Per-particle external force (N), empty until set.
    pub(super) external: Vec<Vector3<f64>>,
    /// The one-thread pair loop's per-particle sums of force and n x F_t (zero between steps).
    pair_force_sum: Vec<Vector3<f64>>,
    pair_n_cross_ft_sum: Vec<Vector3<f64>>,
    /// The team thread whose first claimed chunk panics (tests of the team's failure path).
    #[cfg(test)]
    pub(super) fail_team_thread: Option<usize>,
}

impl Dem {
    /// Checks the setup ([`Setup::check`]), makes the start's particles, checks them, takes
    /// the time step and the skin from the setup and computes the initial forces.
    pub fn new(setup: Setup) -> Result<Dem> {
        setup.check()?;
        let p = setup.start_particles()?;
        let n = p.len();
        let z0 = setup.top.z0_m();
        if p.vel.len() != n || p.omega.len() != n || p.radius.len() != n || p.mass.len() != n {
            return invalid(
                "particles: position, velocity, spin, radius and mass arrays differ in length",
            );
        }
        for i in 0..n {
            let r = p.radius[i];
            require_positive(r, || format!("particle {i}: radius {r} m"))?;
            let x = p.pos[i];
            if !x
                .iter()
                .chain(p.vel[i].iter())
                .chain(p.omega[i].iter())
                .all(|c| c.is_finite())
            {
                return invalid(format!(
                    "particle {i}: position, velocity and spin must be finite"
                ));
            }
            if x.z < 0.0 || x.z > z0 {
                return invalid(format!(
                    "particle {i}: centre height {} m outside the walls [0, {z0}] m",
                    x.z
                ));
            }
        }
        let dt = setup.time_step_s()?;
        let skin = setup.skin_or_default_m();
        let inv_mass = p.mass.iter().map(|m| 1.0 / m).collect();
        let inv_inertia = p
            .mass
            .iter()
            .zip(&p.radius)
            .map(|(m, r)| 1.0 / (0.4 * m * r * r))
            .collect();
        let active = ActiveTerms {
            friction_rotation: setup.contact.has_friction(),
            damping: setup.contact.damping != DampingModel::None,
            gravity: setup.gravity_m_s2 != Vector3::zeros(),
            drag: setup.drag.is_some(),
            pressure_wall: matches!(setup.top, TopWall::Pressure { .. }),
            external: false,
        };
        let mut dem = Dem {
            pp: PairMaterial::new(&setup.particle_material, &setup.particle_material),
            pw: PairMaterial::new(&setup.particle_material, &setup.wall_material),
            buoyancy: 1.0 - setup.fluid_density_kg_m3 / setup.density_kg_m3,
            vel_full: p.vel.clone(),
            omega_full: p.omega.clone(),
            force: vec![Vector3::zeros(); n],
            torque: vec![Vector3::zeros(); n],
            wall_xi: vec![[Vector3::zeros(); 2]; n],
            wall_fz: vec![[0.0; 3]; n],
            wall_f: vec![Vector3::zeros(); n],
            inv_mass,
            inv_inertia,
            nl: NeighbourList::new(skin),
            dt_s: dt,
            time_s: 0.0,
            steps: 0,
            top_z_m: z0,
            top_v_m_s: 0.0,
            floor_force_n: 0.0,
            top_force_n: 0.0,
            top_stiffness_n_per_m: 0.0,
            top_elastic_force_n: 0.0,
            wall_force_n: Vector3::zeros(),
            wall_ledger: None,
            active,
            neighbour_seconds: 0.0,
            external: Vec::new(),
            pair_force_sum: vec![Vector3::zeros(); n],
            pair_n_cross_ft_sum: vec![Vector3::zeros(); n],
            #[cfg(test)]
            fail_team_thread: None,
            p,
            setup,
        };
        for x in dem.p.pos.iter_mut() {
            x.x = x.x.rem_euclid(dem.setup.lx_m);
            x.y = x.y.rem_euclid(dem.setup.ly_m);
        }
        dem.rebuild()?;
        // first forces with the initial velocities; the tangential springs start at zero
        dem.compute_forces(false);
        for xi in dem.wall_xi.iter_mut() {
            *xi = [Vector3::zeros(); 2];
        }
        for pr in dem.nl.pairs.iter_mut() {
            pr.xi = Vector3::zeros();
        }
        Ok(dem)
    }

    /// The same system stepping with `dt_s` (s) from now on, once the setup accepts it for
    /// impacts up to `impact_speed_m_s` ([`Setup::check_time_step`]: at most t_c / 10 and the
    /// Rayleigh time).
    pub fn with_time_step(mut self, dt_s: f64, impact_speed_m_s: f64) -> Result<Dem> {
        self.dt_s = self.setup.check_time_step(dt_s, impact_speed_m_s)?;
        Ok(self)
    }

    /// The setup the system was built from.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// The time step in use (s).
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// The terms the steps evaluate.
    pub fn active(&self) -> &ActiveTerms {
        &self.active
    }

    /// Sets the target pressure (Pa, positive) of the pressure-controlled top wall from the
    /// next step on; a fixed top wall is refused.
    pub fn set_top_pressure(&mut self, target_pa: f64) -> Result<()> {
        match &mut self.setup.top {
            TopWall::Pressure { target_pa: t, .. } => {
                *t = require_positive(target_pa, || format!("target pressure {target_pa} Pa"))?;
                Ok(())
            }
            TopWall::Fixed { .. } => invalid(format!(
                "target pressure {target_pa} Pa: the top wall is fixed (no pressure control)"
            )),
        }
    }

    /// Sets a constant external force on every particle (N, one per particle, finite) that
    /// acts from now on, until the next call; the current step's forces are updated, so the
    /// next half-kick already uses it.
    pub fn set_external_forces(&mut self, f: &[Vector3<f64>]) -> Result<()> {
        if f.len() != self.p.len() {
            return invalid(format!(
                "external forces: {} given for {} particles",
                f.len(),
                self.p.len()
            ));
        }
        if let Some(i) = f.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
            return invalid(format!(
                "external force on particle {i}: {:?} N is not finite",
                f[i]
            ));
        }
        if self.external.len() != f.len() {
            self.external = vec![Vector3::zeros(); f.len()];
        }
        for ((tot, old), new) in self.force.iter_mut().zip(&mut self.external).zip(f) {
            *tot += *new - *old;
            *old = *new;
        }
        self.active.external = true;
        Ok(())
    }

    fn rebuild(&mut self) -> Result<()> {
        let t = std::time::Instant::now();
        let r = self.nl.build(
            &self.p.pos,
            &self.p.radius,
            self.setup.lx_m,
            self.setup.ly_m,
        );
        self.neighbour_seconds += t.elapsed().as_secs_f64();
        r
    }

    /// What the first half kick and the drift read.
    pub(super) fn kick_ctx(&self, n_particles: usize) -> KickCtx<'_> {
        KickCtx {
            force: &self.force,
            torque: &self.torque,
            inv_mass: &self.inv_mass,
            inv_inertia: &self.inv_inertia,
            dt: self.dt_s,
            lx: self.setup.lx_m,
            ly: self.setup.ly_m,
            rotation: self.active.friction_rotation,
            at_build: self.nl.built_positions(n_particles),
        }
    }

    /// The first half kick and the drift, in parallel over chunks of particles (the same bits
    /// at any thread count); true when the neighbour list must be rebuilt.
    fn kick_drift(&mut self) -> bool {
        let n = self.p.len();
        // the arrays the loop writes are moved out while its context borrows the rest
        let mut pos = std::mem::take(&mut self.p.pos);
        let mut vel = std::mem::take(&mut self.p.vel);
        let mut vel_full = std::mem::take(&mut self.vel_full);
        let mut omega = std::mem::take(&mut self.p.omega);
        let mut omega_full = std::mem::take(&mut self.omega_full);
        let ctx = self.kick_ctx(n);
        let moved = if n >= PAR_MIN_PARTICLES {
            let chunk = task_len(n, 8, TASKS_PER_THREAD);
            pos.par_chunks_mut(chunk)
                .zip(vel.par_chunks_mut(chunk))
                .zip(vel_full.par_chunks_mut(chunk))
                .zip(omega.par_chunks_mut(chunk))
                .zip(omega_full.par_chunks_mut(chunk))
                .enumerate()
                .map(|(k, ((((pos, vel), vel_full), omega), omega_full))| {
                    run_kick_drift(
                        &ctx,
                        k * chunk,
                        KickOut {
                            pos,
                            vel,
                            vel_full,
                            omega,
                            omega_full,
                        },
                    )
                })
                .reduce(|| false, |a, b| a || b)
        } else {
            let out = KickOut {
                pos: &mut pos,
                vel: &mut vel,
                vel_full: &mut vel_full,
                omega: &mut omega,
                omega_full: &mut omega_full,
            };
            run_kick_drift(&ctx, 0, out)
        };
        (self.p.pos, self.p.vel, self.vel_full) = (pos, vel, vel_full);
        (self.p.omega, self.omega_full) = (omega, omega_full);
        moved
    }

    /// One velocity-Verlet step.
    pub fn step(&mut self) -> Result<()> {
        let stale = self.kick_drift();
        self.top_z_m = next_top_z(self.top_z_m, self.top_v_m_s, self.dt_s, self.time_s)?;
        if stale {
            self.rebuild()?;
        }
        // the forces at the new positions, and the second half kick
        let wall_before = (self.wall_force_n, self.floor_force_n);
        self.compute_forces(true);
        if let Some(l) = &mut self.wall_ledger {
            l.add(
                wall_before,
                (self.wall_force_n, self.floor_force_n),
                self.dt_s,
            );
        }
        self.top_v_m_s = self.top_speed(self.top_elastic_force_n, self.top_stiffness_n_per_m);
        self.time_s += self.dt_s;
        self.steps += 1;
        Ok(())
    }

    /// The pressure wall's speed for the next step from the elastic part of its contact force
    /// and the summed stiffness of its contacts (a fixed wall keeps its speed, 0).
    pub(super) fn top_speed(&self, elastic_n: f64, stiffness_n_per_m: f64) -> f64 {
        match self.setup.top {
            TopWall::Fixed { .. } => self.top_v_m_s,
            TopWall::Pressure {
                target_pa,
                speed_max_m_s,
                ..
            } => {
                // without contact: approach at v_max; in contact: a relaxed Newton step on the
                // elastic wall force, dz = -WALL_RELAXATION (F_target - F_el) / K_top, capped
                // at v_max dt
                let f_target = target_pa * self.setup.lx_m * self.setup.ly_m;
                let err = f_target - elastic_n;
                if stiffness_n_per_m > 0.0 {
                    (-WALL_RELAXATION * err / (stiffness_n_per_m * self.dt_s))
                        .clamp(-speed_max_m_s, speed_max_m_s)
                } else {
                    -speed_max_m_s
                }
            }
        }
    }

    /// Runs `n` steps; fails on a non-finite state (checked at the end). On two threads or
    /// more, a bed of [`PAR_MIN_PARTICLES`] or more steps as one team of threads between
    /// neighbour-list rebuilds (see [`super::team`]): bitwise the steps of [`Dem::step`].
    pub fn run(&mut self, n: u64) -> Result<()> {
        if rayon::current_num_threads() < 2 || self.p.len() < PAR_MIN_PARTICLES {
            for _ in 0..n {
                self.step()?;
            }
        } else {
            let mut done = 0;
            // true when the team stopped after the first half of a step for a rebuild
            let mut half_done = false;
            while done < n {
                let stale = half_done || {
                    let stale = self.kick_drift();
                    self.top_z_m =
                        next_top_z(self.top_z_m, self.top_v_m_s, self.dt_s, self.time_s)?;
                    stale
                };
                if stale {
                    self.rebuild()?;
                }
                let (steps, stopped_half_way) = self.team_steps(n - done)?;
                done += steps;
                half_done = stopped_half_way;
            }
        }
        self.check_finite()
    }

    /// An error when some position or velocity is not finite.
    pub fn check_finite(&self) -> Result<()> {
        for i in 0..self.p.len() {
            if !self.p.pos[i]
                .iter()
                .chain(self.p.vel[i].iter())
                .all(|c| c.is_finite())
            {
                return invalid(format!(
                    "particle {i}: non-finite state at step {} (t = {:e} s, dt = {:e} s): the \
                     time step is too large for the contact stiffness",
                    self.steps, self.time_s, self.dt_s
                ));
            }
        }
        Ok(())
    }

    /// What the pair loop reads.
    pub(super) fn pair_ctx(&self) -> PairCtx<'_> {
        let model = self.setup.contact;
        PairCtx {
            lx: self.setup.lx_m,
            ly: self.setup.ly_m,
            model,
            dt: self.dt_s,
            friction: model.has_friction(),
            pp: self.pp,
            b: Bodies {
                pos: &self.p.pos,
                vel: &self.p.vel,
                om: &self.p.omega,
                vf: &self.vel_full,
                omf: &self.omega_full,
                rad: &self.p.radius,
                mass: &self.p.mass,
            },
        }
    }

    /// What the gather reads, with the top wall at `top_z` moving at `top_v`.
    pub(super) fn gather_ctx(&self, kick: bool, top_z: f64, top_v: f64) -> GatherCtx<'_> {
        let model = self.setup.contact;
        GatherCtx {
            nl: &self.nl,
            pos: &self.p.pos,
            vf: &self.vel_full,
            omf: &self.omega_full,
            rad: &self.p.radius,
            mass: &self.p.mass,
            pw: self.pw,
            model,
            friction: model.has_friction(),
            dt: self.dt_s,
            top_z,
            top_v,
            g: self.setup.gravity_m_s2 * self.buoyancy,
            drag: self.setup.drag,
            external: &self.external,
            kick: kick.then_some(HalfKick {
                inv_mass: &self.inv_mass,
                inv_inertia: &self.inv_inertia,
                rotation: self.active.friction_rotation,
            }),
        }
    }

    /// Contact forces on all pairs, then the per-particle gather with walls, gravity and drag,
    /// and the second half kick (`kick`).
    fn compute_forces(&mut self, kick: bool) {
        // the arrays each loop writes are moved out while its context borrows the rest
        // one thread: the pair loop adds each force into both members as it goes, in the
        // gather's order (bitwise the same sums), and the gather takes them; this spares the
        // gather's second pass over the pair list, and storing the forces
        let one_thread = rayon::current_num_threads() == 1;
        let mut forces = if one_thread {
            std::mem::take(&mut self.nl.forces)
        } else {
            self.nl.take_forces()
        };
        let mut pairs = std::mem::take(&mut self.nl.pairs);
        let mut sum_f = std::mem::take(&mut self.pair_force_sum);
        let mut sum_n = std::mem::take(&mut self.pair_n_cross_ft_sum);
        let ctx = self.pair_ctx();
        if one_thread {
            let mut sums = PairSums {
                force: &mut sum_f,
                n_cross_ft: &mut sum_n,
            };
            run_pairs(&mut pairs, None, &ctx, Some(&mut sums));
        } else if pairs.len() >= PAR_MIN {
            let chunk = task_len(pairs.len(), 4, TASKS_PER_THREAD);
            pairs
                .par_chunks_mut(chunk)
                .zip(forces.par_chunks_mut(chunk))
                .for_each(|(prs, fs)| run_pairs(prs, Some(fs), &ctx, None));
        } else {
            run_pairs(&mut pairs, Some(&mut forces), &ctx, None);
        }
        (self.nl.pairs, self.nl.forces) = (pairs, forces);
        let n = self.p.len();
        let mut force = std::mem::take(&mut self.force);
        let mut torque = std::mem::take(&mut self.torque);
        let mut wall_xi = std::mem::take(&mut self.wall_xi);
        let mut wall_fz = std::mem::take(&mut self.wall_fz);
        let mut wall_f = std::mem::take(&mut self.wall_f);
        let mut vel = std::mem::take(&mut self.p.vel);
        let mut omega = std::mem::take(&mut self.p.omega);
        let ctx = self.gather_ctx(kick, self.top_z_m, self.top_v_m_s);
        if !one_thread && n >= PAR_MIN_PARTICLES {
            let chunk = task_len(n, 8, TASKS_PER_THREAD);
            force
                .par_chunks_mut(chunk)
                .zip(torque.par_chunks_mut(chunk))
                .zip(wall_xi.par_chunks_mut(chunk))
                .zip(wall_fz.par_chunks_mut(chunk))
                .zip(wall_f.par_chunks_mut(chunk))
                .zip(vel.par_chunks_mut(chunk))
                .zip(omega.par_chunks_mut(chunk))
                .enumerate()
                .for_each(
                    |(k, ((((((force, torque), wall_xi), wall_fz), wall_f), vel), omega))| {
                        run_gather(
                            &ctx,
                            k * chunk,
                            GatherOut {
                                force,
                                torque,
                                wall_xi,
                                wall_fz,
                                wall_f,
                                vel,
                                omega,
                                pair_sums: None,
                            },
                        )
                    },
                );
        } else {
            let out = GatherOut {
                force: &mut force,
                torque: &mut torque,
                wall_xi: &mut wall_xi,
                wall_fz: &mut wall_fz,
                wall_f: &mut wall_f,
                vel: &mut vel,
                omega: &mut omega,
                pair_sums: one_thread.then_some(PairSums {
                    force: &mut sum_f,
                    n_cross_ft: &mut sum_n,
                }),
            };
            run_gather(&ctx, 0, out);
        }
        (self.force, self.torque, self.wall_xi) = (force, torque, wall_xi);
        (self.wall_fz, self.wall_f) = (wall_fz, wall_f);
        (self.p.vel, self.p.omega) = (vel, omega);
        (self.pair_force_sum, self.pair_n_cross_ft_sum) = (sum_f, sum_n);
        let totals = self.wall_totals(self.top_z_m);
        self.set_wall_totals(&totals);
    }

    /// The walls' forces summed over the particles (serially, in particle order) after a
    /// gather, the top wall at `top_z`.
    pub(super) fn wall_totals(&self, top_z: f64) -> WallTotals {
        let (mut fl, mut tp, mut kt) = (0.0, 0.0, 0.0);
        for w in &self.wall_fz {
            fl += w[0];
            tp -= w[1];
            kt += w[2];
        }
        // The controller's force is the elastic part alone: the total also holds the contacts'
        // damping, set by the wall's own velocity (eta v, with eta / dt far above K_top), and a
        // Newton step on the total alternated between +-v_max every step, the wall standing
        // still on average while shaking the top layer.
        let mut top_elastic = 0.0;
        if self.active.pressure_wall {
            let model = self.setup.contact;
            for (p, &r) in self.p.pos.iter().zip(&self.p.radius) {
                let delta = r - (top_z - p.z);
                if delta > 0.0 {
                    top_elastic += model.normal.elastic(delta, r, self.pw.e_star_pa).0;
                }
            }
        }
        WallTotals {
            floor_force_n: fl,
            top_force_n: tp,
            top_stiffness_n_per_m: kt,
            top_elastic_force_n: top_elastic,
            wall_force_n: self.wall_f.iter().fold(Vector3::zeros(), |a, w| a + w),
        }
    }

    pub(super) fn set_wall_totals(&mut self, t: &WallTotals) {
        self.floor_force_n = t.floor_force_n;
        self.top_force_n = t.top_force_n;
        self.top_stiffness_n_per_m = t.top_stiffness_n_per_m;
        self.top_elastic_force_n = t.top_elastic_force_n;
        self.wall_force_n = t.wall_force_n;
    }

    /// Translational + rotational kinetic energy (J) at the full step.
    pub fn kinetic_energy(&self) -> f64 {
        let mut e = 0.0;
        for i in 0..self.p.len() {
            let m = self.p.mass[i];
            e += 0.5 * m * self.p.vel[i].norm_squared()
                + 0.5 * self.p.omega[i].norm_squared() / self.inv_inertia[i];
        }
        e
    }

    /// The kinetic energy (J) that settling can remove, which a stop rule compares with its
    /// peak: the translation of every sphere and the rotation of the spheres that touch a
    /// neighbour or a wall. A sphere that touches nothing feels no torque and keeps its spin for
    /// ever; without gravity (a pressure-wall bed) rattlers float in their cages, and their spin
    /// held a bed's total kinetic energy on a plateau near 3e-4 of its peak.
    pub fn settling_kinetic_energy(&self) -> f64 {
        let n = self.p.len();
        let mut touching = vec![false; n];
        for pr in &self.nl.pairs {
            if pr.delta > 0.0 {
                touching[pr.i as usize] = true;
                touching[pr.j as usize] = true;
            }
        }
        let mut e = 0.0;
        for (i, &t) in touching.iter().enumerate() {
            let (z, r) = (self.p.pos[i].z, self.p.radius[i]);
            e += 0.5 * self.p.mass[i] * self.p.vel[i].norm_squared();
            if t || z < r || self.top_z_m - z < r {
                e += 0.5 * self.p.omega[i].norm_squared() / self.inv_inertia[i];
            }
        }
        e
    }

    /// Elastic energy of the normal contacts (J) (tangential springs not included).
    pub fn normal_elastic_energy(&self) -> f64 {
        let nm = self.setup.contact.normal;
        let mut e = 0.0;
        for pr in &self.nl.pairs {
            if pr.delta > 0.0 {
                let (ri, rj) = (self.p.radius[pr.i as usize], self.p.radius[pr.j as usize]);
                e += nm.potential(pr.delta, ri * rj / (ri + rj), self.pp.e_star_pa);
            }
        }
        for i in 0..self.p.len() {
            let r = self.p.radius[i];
            for dist in [self.p.pos[i].z, self.top_z_m - self.p.pos[i].z] {
                e += nm.potential(r - dist, r, self.pw.e_star_pa);
            }
        }
        e
    }

    /// Largest overlap relative to the smaller diameter of the pair (walls: the sphere's).
    pub fn max_overlap_ratio(&self) -> f64 {
        let mut m: f64 = 0.0;
        for pr in &self.nl.pairs {
            if pr.delta > 0.0 {
                let d = 2.0 * self.p.radius[pr.i as usize].min(self.p.radius[pr.j as usize]);
                m = m.max(pr.delta / d);
            }
        }
        for i in 0..self.p.len() {
            let r = self.p.radius[i];
            for dist in [self.p.pos[i].z, self.top_z_m - self.p.pos[i].z] {
                m = m.max((r - dist) / (2.0 * r));
            }
        }
        m
    }

    /// Number of sphere–sphere contacts (overlap > 0) of each particle.
    pub fn contact_counts(&self) -> Vec<usize> {
        let mut c = vec![0; self.p.len()];
        for pr in &self.nl.pairs {
            if pr.delta > 0.0 {
                c[pr.i as usize] += 1;
                c[pr.j as usize] += 1;
            }
        }
        c
    }

    /// Total contact force on each particle from the last step (N) (for tests).
    pub fn forces(&self) -> &[Vector3<f64>] {
        &self.force
    }

    /// The memory a bed of `n` spheres takes, estimated before anything is allocated (bytes):
    /// the per-particle arrays and a neighbour list of about 10 pairs per sphere (with the
    /// pair forces kept for the threaded gather).
    pub fn estimated_bytes(n: usize) -> f64 {
        let pair = (std::mem::size_of::<Pair>() + std::mem::size_of::<PairForce>()) as f64;
        n as f64 * (BYTES_PER_PARTICLE + PAIRS_PER_PARTICLE * pair)
    }

    /// The buoyant weight of all particles along gravity, sum m' |g| (N).
    pub fn buoyant_weight_n(&self) -> f64 {
        self.p.mass.iter().sum::<f64>() * self.buoyancy * self.setup.gravity_m_s2.norm()
    }

    /// The force the walls must carry when every particle is at rest: minus the sum of the
    /// body forces at zero velocity, buoyant weight m' g, Stokes drag 6 pi mu a U_F and the
    /// external forces (seed 002 eq. 1 with dv/dt = 0 and v = 0; contact forces cancel in pairs).
    pub fn rest_load_n(&self) -> Vector3<f64> {
        let mut load = -self.setup.gravity_m_s2 * (self.p.mass.iter().sum::<f64>() * self.buoyancy);
        if let Some(d) = &self.setup.drag {
            let radii: f64 = self.p.radius.iter().sum();
            load -= d.fluid_velocity_m_s * (6.0 * PI * d.viscosity_pa_s * radii);
        }
        for e in &self.external {
            load -= e;
        }
        load
    }
}

#[cfg(test)]
mod tests {
    use super::super::setup::testing::small_bed;
    use super::Dem;
    use nalgebra::Vector3;

    /// The AVX2 pair loop (four pairs per register) gives every pair's force, torque term,
    /// overlap and history bit for bit as the scalar loop, for each contact model, with pairs
    /// apart, touching, newly apart and sliding, in a periodic box with polydisperse spheres.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn four_pair_lanes_equal_the_scalar_loop_bitwise() {
        use super::super::model::*;
        use super::super::neighbour::{Pair, PairForce};
        use super::{each_pair, each_pair_avx2, Bodies, PairCtx};
        use rand::{Rng, SeedableRng};
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            eprintln!("skipped: this CPU has no AVX2 + FMA, so the scalar loop is the only one");
            return;
        }
        let mat = Material::new(1e7, 0.3).unwrap();
        let pp = PairMaterial::new(&mat, &mat);
        let restitution = DampingModel::restitution(0.5).unwrap();
        let models = [
            (
                NormalModel::Hertz,
                restitution,
                TangentialModel::Mindlin {
                    mu: 0.3,
                    damp_ratio: 1.0,
                },
            ),
            (NormalModel::Hertz, restitution, TangentialModel::None),
            (
                NormalModel::Linear { k_n_n_per_m: 50.0 },
                restitution,
                TangentialModel::Linear {
                    kt_over_kn: 2.0 / 7.0,
                    mu: 0.5,
                    damp_ratio: 0.5,
                },
            ),
            (
                NormalModel::Hertz,
                DampingModel::Zhou { c_n: 0.3 },
                TangentialModel::Zhou { mu: 0.3, c_t: 0.3 },
            ),
        ];
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let (n, lx, ly) = (42, 1.2e-3, 1.0e-3);
        let v3 = |rng: &mut rand::rngs::StdRng, s: f64| {
            Vector3::new(
                rng.gen_range(-s..s),
                rng.gen_range(-s..s),
                rng.gen_range(-s..s),
            )
        };
        let pos: Vec<_> = (0..n)
            .map(|_| {
                Vector3::new(
                    rng.gen_range(0.0..lx),
                    rng.gen_range(0.0..ly),
                    rng.gen_range(0.0..8e-4),
                )
            })
            .collect();
        let rad: Vec<f64> = (0..n).map(|_| rng.gen_range(1e-4..3e-4)).collect();
        let mass: Vec<f64> = rad.iter().map(|r| 2500.0 * 4.19 * r * r * r).collect();
        let [vel, om, vf, omf]: [Vec<_>; 4] = std::array::from_fn(|k| {
            (0..n)
                .map(|_| v3(&mut rng, [0.05, 200.0, 0.05, 200.0][k]))
                .collect()
        });
        let (mut pairs, mut forces) = (Vec::new(), Vec::new());
        for i in 0..n as u32 {
            for j in i + 1..n as u32 {
                let touched = rng.gen_bool(0.5);
                pairs.push(Pair {
                    i,
                    j,
                    delta: if touched { 1e-6 } else { -1.0 },
                    xi: if touched && rng.gen_bool(0.8) {
                        v3(&mut rng, 2e-5)
                    } else {
                        Vector3::zeros()
                    },
                });
                forces.push(PairForce {
                    force: v3(&mut rng, 1.0),
                    n_cross_ft: v3(&mut rng, 1.0),
                });
            }
        }
        let (mut touching, mut sliding) = (0, 0);
        for (normal, damping, tangential) in models {
            let model = ContactModel::new(normal, damping, tangential).unwrap();
            let ctx = PairCtx {
                lx,
                ly,
                model,
                dt: 1e-6,
                friction: model.has_friction(),
                pp,
                b: Bodies {
                    pos: &pos,
                    vel: &vel,
                    om: &om,
                    vf: &vf,
                    omf: &omf,
                    rad: &rad,
                    mass: &mass,
                },
            };
            let (mut scalar, mut scalar_f) = (pairs.clone(), forces.clone());
            each_pair::<f64>(&mut scalar, Some(&mut scalar_f), &ctx, None);
            let (mut lanes, mut lanes_f) = (pairs.clone(), forces.clone());
            // SAFETY: avx2 and fma were detected above
            unsafe { each_pair_avx2(&mut lanes, Some(&mut lanes_f), &ctx, None) };
            let bits = |(p, f): (&Pair, &PairForce)| {
                [p.xi, f.force, f.n_cross_ft]
                    .iter()
                    .flat_map(|v| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>())
                    .chain([p.delta.to_bits()])
                    .collect::<Vec<_>>()
            };
            let scalar_all = scalar.iter().zip(&scalar_f);
            for (k, (a, b)) in scalar_all
                .clone()
                .zip(lanes.iter().zip(&lanes_f))
                .enumerate()
            {
                assert_eq!(bits(a), bits(b), "{model:?}: pair {k} differs: {a:?} {b:?}");
            }
            touching += scalar.iter().filter(|p| p.delta > 0.0).count();
            // sliding: |F_t| = mu |F_n|, with |F_t| = |n x F_t| and F_n^2 = |F|^2 - |F_t|^2
            if let TangentialModel::Mindlin { mu, .. } | TangentialModel::Linear { mu, .. } =
                tangential
            {
                sliding += scalar_all
                    .filter(|(p, f)| {
                        let ft2 = f.n_cross_ft.norm_squared();
                        let fn2 = f.force.norm_squared() - ft2;
                        p.delta > 0.0 && (ft2 - mu * mu * fn2).abs() <= 1e-9 * ft2
                    })
                    .count();
            }
        }
        assert!(pairs.len() % 4 != 0, "the scalar tail is exercised");
        assert!(
            touching > 40 && touching < 4 * pairs.len() - 40,
            "{touching} touching"
        );
        assert!(sliding > 20, "{sliding} sliding");
    }

    /// The stop rule's energy leaves out the spin of a sphere that touches nothing (no torque
    /// can remove it) and keeps every translation and the spin of a sphere in contact.
    #[test]
    fn settling_energy_leaves_out_only_the_free_spin() {
        let mut dem = Dem::new(small_bed(20, 0.75)).unwrap();
        dem.p.vel.iter_mut().for_each(|v| *v = Vector3::zeros());
        dem.p.omega.iter_mut().for_each(|w| *w = Vector3::zeros());
        let k = (0..dem.p.len())
            .find(|&i| {
                let (z, r) = (dem.p.pos[i].z, dem.p.radius[i]);
                z > r
                    && dem.top_z_m - z > r
                    && !dem
                        .nl
                        .pairs
                        .iter()
                        .any(|p| p.delta > 0.0 && (p.i as usize == i || p.j as usize == i))
            })
            .expect("a free sphere in the dispersed start");
        dem.p.omega[k] = Vector3::new(0.0, 30.0, 0.0);
        dem.p.vel[k] = Vector3::new(0.01, 0.0, 0.0);
        let spin = 0.5 * 900.0 / dem.inv_inertia[k];
        let translation = 0.5 * dem.p.mass[k] * 1e-4;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b;
        assert!(close(dem.kinetic_energy(), translation + spin));
        assert!(close(dem.settling_kinetic_energy(), translation));
        // resting on the floor, its spin can be removed by friction and counts
        dem.p.pos[k].z = 0.9 * dem.p.radius[k];
        assert!(close(dem.settling_kinetic_energy(), translation + spin));
    }
}
