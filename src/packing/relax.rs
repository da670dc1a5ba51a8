//! Collective overlap removal ([`Scheme::Relax`](super::Scheme::Relax)).
//!
//! The schemes of the thesis move one particle at a time (Gauss-Seidel): near jamming a
//! particle can only leave an overlap by creating another, and the compression stalls with a
//! contact network short of isostatic (1000 spheres: 5.58 contacts per particle with rattlers
//! removed, against the 6 of a jammed frictionless packing). Here every particle moves at once
//! down the gradient of the harmonic overlap energy
//!
//!   U = 1/2 sum_(i<j) delta_ij^2        (unit stiffness; delta_ij the overlap depth),
//!
//! so particle i feels F_i = -sum_j delta_ij n_ij at its contact points r_c,ij (torque
//! r_c,ij x F), with the mass and inertia tensor of the revised scheme (mass = volume,
//! thesis sec. 3.6). The descent is the FIRE minimiser (Bitzek, Koskinen, Gaehler, Moseler and
//! Gumbsch, Phys. Rev. Lett. 97, 170201, 2006): damped dynamics whose velocity is mixed
//! towards the force and zeroed when the power F.v turns negative. This is the molecular
//! dynamics settling that Wouterse, Luding and Philipse (Granular Matter 11, 169, 2009;
//! thesis ref. [15]) combine with the MCM to settle contacts.
//!
//! Acceptance is the MCM's: the step succeeds when no overlap is deeper than `overlap_tol`;
//! it fails (revert, halve Delta V) when the budget of `tries_per_particle` N particle moves
//! is spent (one iteration moves all N particles), or earlier when the descent has reached a
//! force-balanced minimum whose overlaps are still deeper than the tolerance: the compressed
//! configuration is jammed and no further iteration can remove them.

use super::{list_gap_bound, neighbour_lists, overlaps_of, species, Packing, Setup};
use crate::Result;
use nalgebra::{UnitQuaternion, Vector3};
use rayon::prelude::*;

/// Force, torque, deepest overlap and residual force of one particle.
type ParticleLoad = (Vector3<f64>, Vector3<f64>, f64, f64);

/// FIRE constants of Bitzek et al. (2006): steps with positive power before dt grows, growth
/// and shrink factors of dt, initial mixing alpha and its decay.
const N_MIN: u32 = 5;
const F_INC: f64 = 1.1;
const F_DEC: f64 = 0.5;
const ALPHA_START: f64 = 0.1;
const F_ALPHA: f64 = 0.99;
/// Largest time step, in units of the initial one (1000 spheres, seed 1, initial step 0.1:
/// 2, 3, 4, 6, 10 took 8.9, 7.7, 7.2, 16.4, 14.4 CPU s to the same density; 4 is the default).
const DT_MAX_FACTOR: f64 = 4.0;
/// Largest displacement of any particle point in one iteration (D): the overlaps of one
/// compression step are far smaller, and the neighbour lists follow each move.
const MAX_STEP: f64 = 0.02;
/// Largest neighbour-list skin (D). Relaxation moves are small (MAX_STEP and far less near
/// jamming), so a thin skin rarely triggers a rebuild and keeps the lists short: 1000
/// spheres, seed 1, one thread, best of 3: skin 0.3, 0.1, 0.05 took 4.13, 3.88, 3.88 CPU s,
/// bitwise the same packing (the lists hold every overlapping pair in index order either way).
const RELAX_SKIN: f64 = 0.1;
/// The skin for spheres in the periodic box (closed-form force loops): at N = 10000 the
/// branch-free loop takes a square root and a division for every list entry, so shorter lists
/// pay. Built-in sphere scene, seed 1, one thread, CPU s, same packing bit for bit: N = 10000,
/// six interleaved pairs, 0.1: 44.16, 44.39, 43.24, 44.77, 44.81, 47.44 (median 44.6), 0.03:
/// 42.15, 41.65, 41.64, 42.45, 44.06, 47.93 (median 42.3); 0.05 took 47.18 and 43.65. N = 1000,
/// four pairs: 0.1 3.85-4.25, 0.03 3.95-4.35 (no difference); 0.02 and 0.01 were no better.
const SPHERE_RELAX_SKIN: f64 = 0.03;
/// Particles per rayon task in the force loop.
const PARALLEL_CHUNK: usize = 256;
/// Smallest packing whose force loop runs on the rayon pool (see `relax_in_order`). Spheres'
/// jamming schedule (built-in `packing-spheres`, seed 1), wall seconds with the loop on the
/// calling thread / on a pool of two threads: N = 2000 10.6 / 12.9, N = 5000 28.9-33.4 /
/// 26.8-28.4, N = 10000 71.6 / 67.9. The pool pays only from several thousand particles.
/// Again with the pairwise sphere loop (`sphere_forces_pairwise`, same scene, wall s, two
/// runs each, on the calling thread / on the pool): N = 1000 3.26, 3.34 / 3.66, 3.97; N = 2000
/// 7.88, 7.89 / 8.31, 8.59; N = 5000 17.79, 20.35 / 18.83, 17.73 (a wash); N = 10000 38.1,
/// 39.8 / 32.9 (`porelab bench packing`, seeds 1-2 / seed 1).
const PARALLEL_MIN_PARTICLES: usize = 5000;
/// A configuration is a force-balanced (jammed) minimum when the largest residual force is
/// below this fraction of the deepest overlap (an isolated overlap has force = depth).
/// (1e-2 gave up too early: one seed of 1000 spheres ended with 5.50 contacts instead of 5.76.)
const BALANCED: f64 = 1e-3;

/// Removes the overlaps of `p` by collective relaxation; Ok(tries) when no overlap is deeper
/// than `prm.overlap_tol`, Err(tries) when the budget ran out or the configuration is jammed
/// (see the module docs). Tries count particle moves: N per iteration.
///
/// The descent runs on a copy whose particles are renumbered along a Z-order curve of their
/// positions (neighbours in space are neighbours in memory), and the result is written back
/// in the caller's numbering.
pub(super) fn relax_overlaps(
    p: &mut Packing,
    props: &[species::Props],
    prm: &Setup,
    budget: u64,
) -> Result<std::result::Result<u64, u64>> {
    let order = z_order(&p.positions);
    let mut q = p.renumbered(&order);
    let parallel = rayon::current_num_threads() > 1 && p.n() >= PARALLEL_MIN_PARTICLES;
    let result = relax_in_order(&mut q, props, prm, budget, parallel);
    for (k, &i) in order.iter().enumerate() {
        p.positions[i] = q.positions[k];
        p.orientations[i] = q.orientations[k];
    }
    result
}

/// Particle indices sorted along a Z-order (Morton) curve of cells of edge Z_CELL: the
/// force loop then reads list neighbours from nearby memory (also the numbering of large
/// random starts, `Z_ORDER_MIN_PARTICLES`). Without it a move cost 217 ns
/// at N = 1000 and 294 ns at N = 10000 (one thread; the positions of a list no longer share
/// cache lines once the packing outgrows the cache).
pub(super) fn z_order(x: &[Vector3<f64>]) -> Vec<usize> {
    const Z_CELL: f64 = 2.0;
    let lower = x
        .iter()
        .fold(Vector3::repeat(f64::INFINITY), |m, v| m.inf(v));
    // Interleave the low 21 bits of the three cell coordinates.
    let spread = |c: u64| {
        let mut r = 0u64;
        for b in 0..21 {
            r |= ((c >> b) & 1) << (3 * b);
        }
        r
    };
    let key = |v: &Vector3<f64>| {
        let c = ((v - lower) / Z_CELL).map(|t| t.max(0.0) as u64);
        spread(c.x) | spread(c.y) << 1 | spread(c.z) << 2
    };
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by_key(|&i| (key(&x[i]), i));
    order
}

/// The descent itself. `parallel`: sum the forces on the rayon pool. Small packings (or a pool
/// of one thread) sum them on the calling thread: handing each iteration's loop to the pool
/// costs context switches (two per iteration with one thread: 1.2 s of system time and 46000
/// switches in a 1000-sphere run of 7-8 CPU s), which outweigh the second core below several
/// thousand particles. Either way each particle sums its own pairs in list order and the
/// maxima are exact, so the result is bitwise the same (tested below).
fn relax_in_order(
    p: &mut Packing,
    props: &[species::Props],
    prm: &Setup,
    budget: u64,
    parallel: bool,
) -> Result<std::result::Result<u64, u64>> {
    let n = p.n();
    let spc = p.particles.species.clone();
    let list_gap =
        |p: &Packing, i: usize, j: usize, d: &Vector3<f64>| list_gap_bound(props, &spc, p, i, j, d);
    // Spheres in the periodic box (no wall particles): the pair forces in closed form.
    let spheres_in_box = p.container == super::Container::Periodic
        && props.iter().all(|s| s.sphere && s.sq.is_none());
    let skin = if spheres_in_box {
        SPHERE_RELAX_SKIN
    } else {
        RELAX_SKIN
    };
    let mut nb = neighbour_lists(p, props, &list_gap, skin)?;
    let equal_radius = equal_radius_of(props);
    // Without a rotating particle the torques and angular velocities stay zero and their
    // terms (+0.0) are skipped below: the sums are bitwise the same without them.
    let rotating = props.iter().any(|s| !s.sphere);
    let zero = Vector3::zeros();
    // Angular velocities and accelerations only when something rotates (a packing of spheres
    // then streams neither); the accelerations are those of the current iteration, one buffer
    // each for the whole run.
    let n_rotating = if rotating { n } else { 0 };
    let (mut v, mut w) = (vec![zero; n], vec![zero; n_rotating]);
    let (mut force, mut torque) = (vec![zero; n], vec![zero; n]);
    let (mut accel, mut accel_w) = (vec![zero; n], vec![zero; n_rotating]);
    let (mut dt, mut alpha, mut positive_steps) = (prm.dt, ALPHA_START, 0u32);
    let mut tries = 0u64;
    // Scratch of `sphere_forces_pairwise`, one index range per thread of the pool when the
    // force loop runs in parallel; allocated once for the whole descent.
    let mut ranges: Vec<RangeScratch> = (0..if parallel {
        rayon::current_num_threads()
    } else {
        1
    })
        .map(|_| RangeScratch::default())
        .collect();
    loop {
        // Forces and torques of U, the deepest overlap and the largest residual force (a
        // torque counts as the force at the particle's bounding radius). Each particle sums its
        // own pairs in list order, so the result does not depend on the thread count (spheres
        // in the box: `sphere_forces_pairwise`, one index range per thread). The
        // loads go straight into `force` and `torque` (no per-iteration buffer: at N = 10000
        // the arrays of one iteration already outgrow the cache), and the two maxima are
        // exact in any reduction order.
        let load = |ov: &mut Vec<super::Overlap>,
                    (i, (f_out, t_out)): (usize, (&mut Vector3<f64>, &mut Vector3<f64>))|
         -> Result<(f64, f64)> {
            let (f, t, d, res) = load_of(p, props, &spc, i, &nb.lists[i], ov)?;
            *f_out = f;
            *t_out = t;
            Ok((d, res))
        };
        let max2 = |a: (f64, f64), b: (f64, f64)| (a.0.max(b.0), a.1.max(b.1));
        let (deepest, residual) = if spheres_in_box {
            let lists = &nb.lists;
            sphere_forces_pairwise(p, props, &spc, equal_radius, lists, &mut force, &mut ranges)
        } else if parallel {
            force
                .par_iter_mut()
                .zip(torque.par_iter_mut())
                .enumerate()
                .with_min_len(PARALLEL_CHUNK)
                .map_init(Vec::new, load)
                .try_reduce(|| (0.0, 0.0), |a, b| Ok(max2(a, b)))?
        } else {
            let mut ov = Vec::new();
            force
                .iter_mut()
                .zip(torque.iter_mut())
                .enumerate()
                .try_fold((0.0, 0.0), |acc, item| {
                    Ok::<_, crate::Error>(max2(acc, load(&mut ov, item)?))
                })?
        };
        if deepest <= prm.overlap_tol {
            return Ok(Ok(tries));
        }
        if residual < BALANCED * deepest || tries + n as u64 > budget {
            return Ok(Err(tries));
        }
        tries += n as u64;
        // FIRE: the power decides whether the descent is still going downhill.
        let power: f64 = if rotating {
            (0..n)
                .map(|i| force[i].dot(&v[i]) + torque[i].dot(&w[i]))
                .sum()
        } else {
            (0..n).map(|i| force[i].dot(&v[i])).sum()
        };
        if power > 0.0 {
            positive_steps += 1;
            if positive_steps > N_MIN {
                dt = (dt * F_INC).min(DT_MAX_FACTOR * prm.dt);
                alpha *= F_ALPHA;
            }
        } else {
            positive_steps = 0;
            dt *= F_DEC;
            alpha = ALPHA_START;
            v.fill(zero);
            w.fill(zero);
        }
        // Semi-implicit Euler velocities, then the FIRE mixing towards the acceleration, both
        // norms in the kinetic-energy metric (m v^2 + w . I w), so translation and rotation mix
        // in consistent units.
        let (mut v2, mut a2) = (0.0, 0.0);
        for i in 0..n {
            let body = &props[spc[i]];
            let a = force[i] / body.mass;
            v[i] += dt * a;
            if rotating {
                let b = if body.sphere {
                    zero
                } else {
                    super::inverse_inertia_world(&p.orientations[i], &body.inertia) * torque[i]
                };
                w[i] += dt * b;
                v2 +=
                    body.mass * v[i].norm_squared() + w[i].dot(&(inertia_world(p, body, i) * w[i]));
                a2 += force[i].dot(&a) + torque[i].dot(&b);
                accel[i] = a;
                accel_w[i] = b;
            } else {
                v2 += body.mass * v[i].norm_squared();
                a2 += force[i].dot(&a);
                accel[i] = a;
            }
        }
        // The FIRE mixing (when there is a force at all), then the move, particle by particle.
        let mix = (a2 > 0.0).then(|| alpha * (v2 / a2).sqrt());
        for i in 0..n {
            if let Some(mix) = mix {
                v[i] = (1.0 - alpha) * v[i] + mix * accel[i];
                if rotating {
                    w[i] = (1.0 - alpha) * w[i] + mix * accel_w[i];
                }
            }
            let body = &props[spc[i]];
            let mut dx = dt * v[i];
            if dx.norm() > MAX_STEP {
                dx *= MAX_STEP / dx.norm();
            }
            p.positions[i] = p.container.wrap(&(p.positions[i] + dx), p.box_length);
            if !body.sphere {
                let mut dtheta = dt * w[i];
                let lever = body.bound;
                if lever * dtheta.norm() > MAX_STEP {
                    dtheta *= MAX_STEP / (lever * dtheta.norm());
                }
                let q = UnitQuaternion::from_scaled_axis(dtheta) * p.orientations[i];
                p.orientations[i] = UnitQuaternion::new_normalize(*q.quaternion());
            }
            nb.moved(p, i, &list_gap);
        }
    }
}

/// Force, torque, deepest overlap and residual force of particle i from its overlapping list
/// neighbours (any shape and container; `ov` is scratch space).
fn load_of(
    p: &Packing,
    props: &[species::Props],
    spc: &[usize],
    i: usize,
    list: &[usize],
    ov: &mut Vec<super::Overlap>,
) -> Result<ParticleLoad> {
    overlaps_of(p, props, i, list, 0.0, ov)?;
    let body = &props[spc[i]];
    let zero = Vector3::zeros();
    let (mut f, mut t, mut deepest) = (zero, zero, 0.0f64);
    for o in ov.iter() {
        deepest = deepest.max(o.depth);
        let fo = -o.depth * o.normal;
        f += fo;
        if !body.sphere {
            t += o.rc.cross(&fo);
        }
    }
    Ok((f, t, deepest, f.norm().max(t.norm() / body.bound)))
}

/// The force term -delta n of sphere pair (i, j) on i at `xi` (radius `ri`; j's radius `rj`),
/// the overlap delta and whether the centres are apart (|d| > 0), with n = d / |d| (x for
/// coincident centres) and delta = (r_i + r_j - |d|) clamped at 0: the generic loop's
/// F_i += gap n over the overlapping pairs of [`overlaps_of`], computed for every list pair
/// without a branch. A pair apart gives -0 n,
/// signed zeros, which leave a sum bitwise unchanged: x + (+-0) = x for every x but -0, and a
/// force never holds a -0 (it starts at +0, and rounding to nearest gives +0 both for +0 + -0
/// and for an exact cancellation).
#[inline(always)]
fn sphere_pair_term(
    p: &Packing,
    xi: &Vector3<f64>,
    ri: f64,
    j: usize,
    rj: f64,
) -> (Vector3<f64>, f64, bool) {
    let d = p.container.separation(xi, &p.positions[j], p.box_length);
    let dist = d.norm_squared().sqrt();
    // -gap when the pair overlaps (negation and the rounded difference commute).
    let overlap = ((ri + rj) - dist).max(0.0);
    let n = if dist > 0.0 { d / dist } else { Vector3::x() };
    (-overlap * n, overlap, dist > 0.0)
}

/// Scratch of one index range of [`sphere_forces_pairwise`]: for each of the range's
/// particles, how many entries at the head of its list are already summed into its force.
#[derive(Default)]
struct RangeScratch {
    summed: Vec<u32>,
}

/// All sphere forces of the packing, each pair within an index range computed once (Newton's
/// third law); bitwise the generic loop over [`overlaps_of`] (tested below), so which loop a
/// sphere takes does not change a packing.
///
/// The particles are split into one contiguous index range per scratch (one per thread); a
/// pair across two ranges is computed on both sides. Particle i adds its terms
/// ([`sphere_pair_term`]) in list order, as the generic loop does, starting from +0. Its list
/// (sorted, and symmetric: j is in i's list when i is in j's) holds the entries below its
/// range, summed first, in a pass over the range before the pairs; then those in its range
/// below i, whose terms those particles added to i's force when they were processed, in
/// index order, which is list order; then those in its range above i, computed here, each
/// adding the opposite term to j's force; then those above the range, computed here. The
/// opposite term is exact: the minimum-image separation of (j, i) is the negated one of
/// (i, j) bit for bit (IEEE subtraction and rounding to nearest are odd), so |d|, the overlap
/// and d / |d| come out the same but for the sign; coincident centres (|d| = 0) take n = x on
/// both sides.
///
/// Against the per-particle loop it replaced (same packings bit for bit), `porelab bench
/// packing`, engine CPU s, means of seeds 1-2, one thread: N = 1000 3.63 -> 3.32, N = 10000
/// 40.76 -> 38.91; two threads, N = 10000, wall s: 37.59 -> 32.91. Skipping the pairs apart
/// by a branch instead (built-in scene, seed 1, CPU s): N = 1000 3.07-3.10 against 3.04-3.11,
/// N = 10000 39.1-39.2 against 35.7-36.6. The opposite terms went first to a buffer of one
/// slot per list entry (24 bytes each, the largest array of the descent) and were summed at
/// j's turn; adding them to j's force at once gives the same sums in the same order without
/// it (benches/RESULTS.md, packing). Writes `force`; returns (deepest overlap,
/// largest |force|).
fn sphere_forces_pairwise(
    p: &Packing,
    props: &[species::Props],
    spc: &[usize],
    equal_radius: Option<f64>,
    lists: &super::neighbours::Lists,
    force: &mut [Vector3<f64>],
    scratch: &mut [RangeScratch],
) -> (f64, f64) {
    let n = p.n();
    let range_len = n.div_ceil(scratch.len()).max(1);
    let radius = |j: usize| equal_radius.unwrap_or_else(|| props[spc[j]].r);
    let one_range = |(k, (force, s)): (usize, (&mut [Vector3<f64>], &mut RangeScratch))| {
        let (lo, hi) = (k * range_len, k * range_len + force.len());
        let summed = &mut s.summed;
        summed.clear();
        summed.resize(hi - lo, 0);
        let (mut deepest, mut residual) = (0.0f64, 0.0f64);
        // The entries below the range, first in every list (none in the first range).
        for (i, (f_out, done)) in (lo..hi).zip(force.iter_mut().zip(summed.iter_mut())) {
            let mut f = Vector3::zeros();
            if lo > 0 {
                let (xi, ri) = (&p.positions[i], props[spc[i]].r);
                for &j in lists[i].iter().take_while(|&&j| j < lo) {
                    let (t, overlap, _) = sphere_pair_term(p, xi, ri, j, radius(j));
                    deepest = deepest.max(overlap);
                    f += t;
                    *done += 1;
                }
            }
            *f_out = f;
        }
        for i in lo..hi {
            let (xi, ri) = (p.positions[i], props[spc[i]].r);
            let list = &lists[i];
            let mut f = force[i - lo];
            let mut k = summed[i - lo] as usize;
            debug_assert!(list[..k].iter().all(|&j| j < i) && list[k..].iter().all(|&j| j > i));
            while k < list.len() && list[k] < hi {
                let j = list[k];
                k += 1;
                let (t, overlap, apart) = sphere_pair_term(p, &xi, ri, j, radius(j));
                deepest = deepest.max(overlap);
                f += t;
                // The opposite term (the same one for coincident centres).
                force[j - lo] += if apart { -t } else { t };
                summed[j - lo] += 1;
            }
            for &j in &list[k..] {
                let (t, overlap, _) = sphere_pair_term(p, &xi, ri, j, radius(j));
                deepest = deepest.max(overlap);
                f += t;
            }
            residual = residual.max(f.norm());
            force[i - lo] = f;
        }
        (deepest, residual)
    };
    let max2 = |a: (f64, f64), b: (f64, f64)| (a.0.max(b.0), a.1.max(b.1));
    if scratch.len() == 1 {
        one_range((0, (force, &mut scratch[0])))
    } else {
        force
            .par_chunks_mut(range_len)
            .zip(scratch.par_iter_mut())
            .enumerate()
            .map(one_range)
            .reduce(|| (0.0, 0.0), max2)
    }
}

/// The radius shared by every species, if they share one: then every sphere contact
/// distance is 2r, and the sphere force loop need not read the neighbours' species (one
/// memory access less per neighbour).
fn equal_radius_of(props: &[species::Props]) -> Option<f64> {
    props
        .iter()
        .all(|s| s.r == props[0].r)
        .then_some(props[0].r)
}

/// World-frame inertia tensor of particle i (zero for spheres, which never rotate).
fn inertia_world(p: &Packing, body: &species::Props, i: usize) -> nalgebra::Matrix3<f64> {
    if body.sphere {
        return nalgebra::Matrix3::zeros();
    }
    let r = p.orientations[i].to_rotation_matrix();
    r.matrix() * nalgebra::Matrix3::from_diagonal(&body.inertia) * r.matrix().transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::{random_start_of, Container, ParticleShapes};

    /// The pairwise sphere loop gives bitwise the generic loop's force for every particle and
    /// its deepest overlap and largest residual, with one index range and with several
    /// (pairs across ranges), for a squeezed packing of equal spheres and one of two sizes
    /// (the `equal_radius` path and the per-neighbour radius), with two particles on the same
    /// centre (n = x on both sides): which loop a sphere takes does not change a packing.
    #[test]
    fn pairwise_sphere_loop_gives_bitwise_the_generic_load() {
        use crate::contact::ContactShape;
        let two_sizes = ParticleShapes::mixture(&[
            (ContactShape::Sphere { radius: 0.5 }, 300),
            (ContactShape::Sphere { radius: 0.35 }, 300),
        ]);
        for particles in [ParticleShapes::monodisperse(600, 0.0), two_sizes] {
            let mut p = random_start_of(Container::Periodic, particles, 0.1, 11).unwrap();
            let squeeze = (1.0f64 / 6.0).cbrt();
            p.box_length *= squeeze;
            for x in p.positions.iter_mut() {
                *x *= squeeze;
            }
            p.positions[200] = p.positions[100];
            let props = species::props_of(&p.particles).unwrap();
            let spc = p.particles.species.clone();
            let equal_radius = equal_radius_of(&props);
            let list_gap = |p: &Packing, i: usize, j: usize, d: &Vector3<f64>| {
                list_gap_bound(&props, &spc, p, i, j, d)
            };
            let nb = neighbour_lists(&p, &props, &list_gap, RELAX_SKIN).unwrap();
            assert!(nb.lists[100].contains(&200));
            let bits = |v: &Vector3<f64>| v.map(f64::to_bits);
            let (mut ov, mut overlapping, mut apart) = (Vec::new(), 0, 0);
            let (mut generic, mut deepest, mut residual) = (Vec::new(), 0.0f64, 0.0f64);
            for i in 0..p.n() {
                let list = &nb.lists[i];
                let (f, t, d, res) = load_of(&p, &props, &spc, i, list, &mut ov).unwrap();
                assert_eq!(t, Vector3::zeros());
                generic.push(bits(&f));
                (deepest, residual) = (deepest.max(d), residual.max(res));
                overlapping += ov.len();
                apart += list.len() - ov.len();
            }
            assert!(
                overlapping > 1000 && apart > 1000,
                "{overlapping} / {apart}"
            );
            for ranges in [1, 2, 3, 7] {
                let mut scratch: Vec<RangeScratch> =
                    (0..ranges).map(|_| RangeScratch::default()).collect();
                let mut force = vec![Vector3::repeat(f64::NAN); p.n()];
                let (d, res) = sphere_forces_pairwise(
                    &p,
                    &props,
                    &spc,
                    equal_radius,
                    &nb.lists,
                    &mut force,
                    &mut scratch,
                );
                for (i, f) in force.iter().enumerate() {
                    assert_eq!(bits(f), generic[i], "particle {i}, {ranges} ranges");
                }
                assert_eq!(d.to_bits(), deepest.to_bits(), "{ranges} ranges");
                assert_eq!(res.to_bits(), residual.to_bits(), "{ranges} ranges");
            }
        }
    }

    /// The force loop on a pool of two threads and on the calling thread give bitwise the same
    /// relaxation, for spheres (closed-form forces) and for spherocylinders (contact solver and
    /// torques): 600 particles of a dilute start squeezed to 4x the density, so that hundreds of
    /// pairs overlap, relaxed for at most 150 iterations.
    #[test]
    fn force_loop_on_the_pool_gives_the_serial_result() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        for length in [0.0, 1.5] {
            let particles = ParticleShapes::monodisperse(600, length);
            let mut start = random_start_of(Container::Periodic, particles, 0.1, 7).unwrap();
            let squeeze = 0.25f64.cbrt();
            start.box_length *= squeeze;
            for x in start.positions.iter_mut() {
                *x *= squeeze;
            }
            let props = species::props_of(&start.particles).unwrap();
            let mut prm = Setup::new(600, length, 7);
            prm.dt = 0.1;
            let budget = 150 * 600;
            let (mut serial, mut pooled) = (start.clone(), start.clone());
            let a = relax_in_order(&mut serial, &props, &prm, budget, false).unwrap();
            let b = pool
                .install(|| relax_in_order(&mut pooled, &props, &prm, budget, true))
                .unwrap();
            assert_eq!(a, b, "L/D {length}");
            assert_eq!(serial.positions, pooled.positions, "L/D {length}");
            assert_eq!(serial.orientations, pooled.orientations, "L/D {length}");
            assert_ne!(
                serial.positions, start.positions,
                "L/D {length}: nothing moved"
            );
        }
    }
}
