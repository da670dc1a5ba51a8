//! Cases 601-608: the Monte-Carlo deposition engine of seed 000 (src/deposition) and the
//! layer observables of src/analysis (slab porosity, height map).

use super::common::required_seed;
use crate::analysis::height_map::height_map;
use crate::analysis::slab::{solid_fraction_between, PosedEllipsoid};
use crate::deposition::driver::run_layer;
use crate::deposition::grain::{Grain, GrainPose};
use crate::deposition::measure::measure;
use crate::deposition::moves;
use crate::deposition::Layer;
use crate::deposition::{Moves, StopRule};
use crate::driver::NoHooks;
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

fn z_of(samples: &[f64], mu: f64) -> f64 {
    let n = samples.len() as f64;
    let m = samples.iter().sum::<f64>() / n;
    let var = samples.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m - mu) / (var / n).sqrt()
}

register!("601" => case_601);
/// Case 601: the move generator. Eq. A14 for every move (worst relative deviation), and
/// z-scores of E[dz^2] = K/12 and E|dz| = c sqrt(K) over `moves` draws.
pub fn case_601(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 601 needs a seed")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let k = t.f64(i, "k_max_m2")?;
        let axes = [t.f64(i, "a_m")?, t.f64(i, "b_m")?, t.f64(i, "c_m")?];
        let n = t.f64(i, "moves")? as usize;
        let g = Grain::new(axes, 0, 2500.0, 1000.0, 9.8)?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed + i as u64);
        let (mut worst, mut dz2, mut adz) = (0.0f64, Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            let m = moves::draw(&mut rng, k, &g.inertia_per_volume_m2);
            let lhs = m.kinetic_measure(&g.inertia_per_volume_m2);
            if m.budget_m2 > 0.0 {
                worst = worst.max((lhs - m.budget_m2).abs() / m.budget_m2);
            }
            if m.budget_m2 > k {
                worst = f64::INFINITY;
            }
            dz2.push(m.translation_m[2].powi(2) / k);
            adz.push(m.translation_m[2].abs() / k.sqrt());
        }
        let label = t.str(i, "label")?;
        rows.push(Row::new(
            format!("{label}: eq. A14 worst rel. deviation"),
            worst,
            0.0,
            1.0,
        ));
        rows.push(Row::new(
            format!("{label}: z of E[dz^2] = K/12"),
            z_of(&dz2, t.f64(i, "e_dz2_over_k")?),
            0.0,
            1.0,
        ));
        rows.push(Row::new(
            format!("{label}: z of E|dz| = c sqrt(K)"),
            z_of(&adz, t.f64(i, "e_abs_dz_over_sqrt_k")?),
            0.0,
            1.0,
        ));
    }
    Ok(rows)
}

/// A layer of given grains and poses in a box of side `l`.
fn layer_of(grains: Vec<Grain>, poses: Vec<GrainPose>, l: f64) -> Layer {
    let top = poses.iter().map(|p| p.position.z).fold(0.0, f64::max);
    Layer {
        grains,
        poses,
        box_side_m: l,
        film_height_m: top,
    }
}

/// Table B1's moves and stop rule with K_max `k`, `max_sweeps` and `stop_fraction`.
fn params(k: f64, max_sweeps: u64, stop_fraction: f64) -> (Moves, StopRule) {
    (
        Moves {
            k_max_m2: k,
            ..Moves::table_b1()
        },
        StopRule {
            fraction: stop_fraction,
            ..StopRule::table_b1(max_sweeps)
        },
    )
}

register!("602" => case_602);
/// Case 602: an isolated sphere far above the substrate at T = 0: z-scores of the accepted
/// fraction (1/2) and of the mean descent per trial (c/2 sqrt(K)).
pub fn case_602(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 602 needs a seed")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let r = t.f64(i, "radius_m")?;
        let k = t.f64(i, "k_max_m2")?;
        let n = t.f64(i, "trials")? as u64;
        let g = Grain::new([r; 3], 0, 2500.0, 1000.0, 9.8)?;
        // Start high enough never to reach the substrate: n trials descend < n sqrt(K).
        let z0 = r + (n as f64) * k.sqrt();
        let pose = GrainPose {
            position: Vector3::new(5.0 * r, 5.0 * r, z0),
            orientation: UnitQuaternion::identity(),
        };
        let layer = layer_of(vec![g], vec![pose], 10.0 * r);
        let rng = ChaCha8Rng::seed_from_u64(seed + i as u64);
        // A window as long as the run: the stop rule cannot end it early.
        let (moves, mut stop) = params(k, n, 1e-300);
        stop.window = n;
        let (layer, out) = run_layer(layer, moves, stop, rng, &mut NoHooks)?;
        if out.moves != n {
            return Err(Error::Validation(format!(
                "case 602: the run stopped after {} of {n} trials",
                out.moves
            )));
        }
        let nf = n as f64;
        let p = out.accepted as f64 / nf;
        let label = t.str(i, "label")?;
        rows.push(Row::new(
            format!("{label}: z of acceptance {p:.5} against 1/2"),
            (p - 0.5) / (0.25 / nf).sqrt(),
            0.0,
            1.0,
        ));
        // Per trial the descent D = -dz 1{dz < 0}: E D = c/2 sqrt(K), E D^2 = K/24.
        let mean_d = (z0 - layer.poses[0].position.z) / nf / k.sqrt();
        let e_d = t.f64(i, "descent_over_sqrt_k")?;
        let var_d = 1.0 / 24.0 - e_d * e_d;
        rows.push(Row::new(
            format!("{label}: z of descent per trial {mean_d:.6} sqrt(K)"),
            (mean_d - e_d) / (var_d / nf).sqrt(),
            0.0,
            1.0,
        ));
    }
    Ok(rows)
}

/// Closed-form translational resistances (per unit viscosity) of a spheroid with semi-axis
/// `a_sym` along its symmetry axis and `a_eq` across it: (along the axis, across it).
/// Oberbeck (1876); Happel & Brenner (1965) sec. 5-11; Kim & Karrila (1991) table 3.4.
fn spheroid_resistances(a_sym: f64, a_eq: f64) -> (f64, f64) {
    if a_sym > a_eq {
        // Prolate: a = a_sym, e = sqrt(1 - b^2/a^2), L = ln((1+e)/(1-e)).
        let a = a_sym;
        let e = (1.0 - (a_eq / a).powi(2)).sqrt();
        let l = ((1.0 + e) / (1.0 - e)).ln();
        let ax = 16.0 * PI * a * e.powi(3) / ((1.0 + e * e) * l - 2.0 * e);
        let tr = 32.0 * PI * a * e.powi(3) / (2.0 * e + (3.0 * e * e - 1.0) * l);
        (ax, tr)
    } else {
        // Oblate: a = a_eq, e = sqrt(1 - c^2/a^2).
        let a = a_eq;
        let e = (1.0 - (a_sym / a).powi(2)).sqrt();
        let s = (1.0 - e * e).sqrt();
        let ax = 8.0 * PI * a * e.powi(3) / (e * s - (1.0 - 2.0 * e * e) * e.asin());
        let tr = 16.0 * PI * a * e.powi(3) / ((1.0 + 2.0 * e * e) * e.asin() - e * s);
        (ax, tr)
    }
}

/// The 24 rotations of the cube.
fn cube_group() -> Vec<UnitQuaternion<f64>> {
    let mut out = Vec::new();
    let perms = [
        [0, 1, 2],
        [1, 2, 0],
        [2, 0, 1],
        [0, 2, 1],
        [2, 1, 0],
        [1, 0, 2],
    ];
    for (pi, p) in perms.iter().enumerate() {
        let even = pi < 3;
        for signs in 0..8u32 {
            let s = [0, 1, 2].map(|k| if signs >> k & 1 == 1 { -1.0 } else { 1.0 });
            let neg = s.iter().filter(|&&x| x < 0.0).count() % 2 == 1;
            if even == neg {
                continue; // determinant -1
            }
            let mut m = nalgebra::Matrix3::zeros();
            for r in 0..3 {
                m[(r, p[r])] = s[r];
            }
            out.push(UnitQuaternion::from_rotation_matrix(
                &nalgebra::Rotation3::from_matrix_unchecked(m),
            ));
        }
    }
    out
}

register!("603" => case_603);
/// Case 603: the vertical drag coefficient of posed spheroids (eq. A3 with A11) against the
/// closed forms rotated, C = C_ax cos^2 + C_tr sin^2, and the orientation mean over the cube
/// group against (C_a + C_b + C_c)/3 for triaxial ellipsoids.
pub fn case_603(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let group = cube_group();
    if group.len() != 24 {
        return Err(Error::Validation(format!(
            "cube group has {} rotations",
            group.len()
        )));
    }
    for i in 0..t.len() {
        let axes = [t.f64(i, "a_m")?, t.f64(i, "b_m")?, t.f64(i, "c_m")?];
        let tilt = t.f64(i, "tilt_deg")?.to_radians();
        let label = t.str(i, "label")?;
        let g = Grain::new(axes, 0, 2500.0, 1000.0, 9.8)?;
        // Body axes: c is the symmetry axis when a == b; tilt it by `tilt` about world x.
        let q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt)
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.37);
        let got = g.drag_zz(&q);
        if axes[0] == axes[1] {
            let (ax, tr) = spheroid_resistances(axes[2], axes[0]);
            let want = ax * tilt.cos().powi(2) + tr * tilt.sin().powi(2);
            rows.push(Row::new(
                format!("{label} tilt {:.0} deg", tilt.to_degrees()),
                got,
                want,
                want,
            ));
        }
        let base = UnitQuaternion::from_euler_angles(0.3, -0.8, 1.9);
        let mean = group.iter().map(|r| g.drag_zz(&(r * base))).sum::<f64>() / 24.0;
        let want = g.drag_m.iter().sum::<f64>() / 3.0;
        rows.push(Row::new(
            format!("{label}: cube-group mean = trace/3"),
            mean,
            want,
            want,
        ));
    }
    Ok(rows)
}

register!("604" => case_604);
/// Case 604: exact slab volumes. Slices of random posed ellipsoids sum to 4/3 pi abc; the
/// porosity of whole periods of simple cubic and FCC sphere lattices.
pub fn case_604(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 604 needs a seed")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let kind = t.str(i, "kind")?;
        let want = t.f64(i, "expected_porosity")?;
        let label = t.str(i, "label")?;
        match kind {
            "slices" => {
                let mut rng = ChaCha8Rng::seed_from_u64(seed + i as u64);
                let mut worst = 0.0f64;
                for _ in 0..200 {
                    let axes = [0.0; 3].map(|_: f64| 0.1 + rng.gen::<f64>());
                    let e = PosedEllipsoid {
                        semi_axes: axes,
                        position: Vector3::new(0.0, 0.0, 3.0 + rng.gen::<f64>()),
                        orientation: UnitQuaternion::from_euler_angles(
                            rng.gen::<f64>() * 6.3,
                            rng.gen::<f64>() * 6.3,
                            rng.gen::<f64>() * 6.3,
                        ),
                    };
                    let n = 1 + rng.gen_range(0..50);
                    let s: f64 = (0..n)
                        .map(|k| {
                            e.volume_between(
                                8.0 * k as f64 / n as f64,
                                8.0 * (k + 1) as f64 / n as f64,
                            )
                        })
                        .sum();
                    worst = worst.max((s - e.volume()).abs() / e.volume());
                }
                rows.push(Row::new(
                    format!("{label}: worst rel. error of the slice sum"),
                    worst,
                    want,
                    1.0,
                ));
            }
            "sc" | "fcc" => {
                let r = 1.0;
                let cells = 4usize;
                let (a, basis): (f64, Vec<[f64; 3]>) = if kind == "sc" {
                    (2.0 * r, vec![[0.0; 3]])
                } else {
                    let a = 2.0 * 2f64.sqrt() * r;
                    (
                        a,
                        vec![
                            [0.0, 0.0, 0.0],
                            [0.5, 0.5, 0.0],
                            [0.5, 0.0, 0.5],
                            [0.0, 0.5, 0.5],
                        ],
                    )
                };
                let mut parts = Vec::new();
                // Layers from below the slab to above it, so that every slab point is covered.
                for ix in 0..cells {
                    for iy in 0..cells {
                        for iz in 0..(cells + 3) {
                            for b in &basis {
                                parts.push(PosedEllipsoid {
                                    semi_axes: [r; 3],
                                    position: Vector3::new(
                                        (ix as f64 + b[0]) * a,
                                        (iy as f64 + b[1]) * a,
                                        (iz as f64 + b[2]) * a,
                                    ),
                                    orientation: UnitQuaternion::identity(),
                                });
                            }
                        }
                    }
                }
                let l = cells as f64 * a;
                // Spheres cut by the box's x-y faces: their periodic images are also listed,
                // so the cut parts outside are made up for by the images' parts inside; the
                // x-y integral of each slice is then the periodic one (slab volumes depend on
                // z only).
                let phi = solid_fraction_between(&parts, l * l, a, 3.0 * a);
                rows.push(Row::new(
                    format!("{label}: porosity of two periods"),
                    1.0 - phi,
                    want,
                    want,
                ));
            }
            o => return Err(Error::Validation(format!("case 604: unknown kind `{o}`"))),
        }
    }
    Ok(rows)
}

register!("605" => case_605);
/// Case 605: RMS roughness of constructed monolayers of spheres at coverage theta against
/// r sqrt(17 theta / 6 - 25 theta^2 / 9) (a node has height 0 or r + sqrt(r^2 - rho^2)).
pub fn case_605(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let r = t.f64(i, "radius_m")?;
        let per_side = t.f64(i, "spheres_per_side")? as usize;
        let spacing = t.f64(i, "spacing_over_radius")? * r;
        let nodes_per_radius = t.f64(i, "nodes_per_radius")?;
        let l = per_side as f64 * spacing;
        let mut parts = Vec::new();
        for ix in 0..per_side {
            for iy in 0..per_side {
                parts.push(PosedEllipsoid {
                    semi_axes: [r; 3],
                    position: Vector3::new(
                        (ix as f64 + 0.3) * spacing,
                        (iy as f64 + 0.6) * spacing,
                        r,
                    ),
                    orientation: UnitQuaternion::identity(),
                });
            }
        }
        let theta = parts.len() as f64 * PI * r * r / (l * l);
        let n = (l / r * nodes_per_radius).round() as usize;
        let hm = height_map(&parts, l, n, 1e-3 * r)?;
        let want = r * (17.0 * theta / 6.0 - 25.0 * theta * theta / 9.0).sqrt();
        rows.push(Row::new(
            format!("theta = {theta:.4}, {nodes_per_radius} nodes per radius"),
            hm.rms_roughness_m(),
            want,
            want,
        ));
        rows.push(Row::new(
            format!("theta = {theta:.4}: first-layer coverage"),
            hm.first_layer_coverage(),
            theta,
            theta,
        ));
    }
    Ok(rows)
}

register!("606" => case_606);
/// Case 606: a periodic square column of side L, d < L < sqrt(2) d: one sphere per layer,
/// each ends in the hollow of the one below, z_k - z_(k-1) = sqrt(d^2 - L^2/2) (z_1 = r).
/// The spheres are released one at a time, each 1 d above the top of the settled stack, and
/// each stage runs to the row's stop rule. Row per layer: the remaining gap
/// e = (z_k - z_(k-1)) - dz against 0, within the residual that stop rule leaves at T = 0
/// (columns residual_substrate_m for layer 1 and residual_hollow_m above it: the largest gap of
/// independent walkers under the same rule, reference/scripts/deposition_stop_residual_606.py).
/// A sphere locked on a ridge top (0.15-0.29 d up) fails.
pub fn case_606(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 606 needs a seed")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let r = t.f64(i, "radius_m")?;
        let d = 2.0 * r;
        let l = t.f64(i, "side_over_diameter")? * d;
        let n = t.f64(i, "spheres")? as usize;
        let k = t.f64(i, "k_max_m2")?;
        let fraction = t.f64(i, "stop_fraction")?;
        let window = t.f64(i, "stop_window")? as u64;
        let residual = [
            t.f64(i, "residual_substrate_m")?,
            t.f64(i, "residual_hollow_m")?,
        ];
        let g = Grain::new([r; 3], 0, 2500.0, 1000.0, 9.8)?;
        let dz = (d * d - l * l / 2.0).sqrt();
        let mut poses: Vec<GrainPose> = Vec::new();
        for j in 0..n {
            let mut rng = ChaCha8Rng::seed_from_u64(seed + i as u64);
            rng.set_stream(j as u64 + 1);
            let top = poses.iter().map(|p| p.position.z).fold(0.0, f64::max);
            poses.push(GrainPose {
                position: Vector3::new(
                    rng.gen::<f64>() * l,
                    rng.gen::<f64>() * l,
                    if j == 0 { r + 0.5 * d } else { top + 2.0 * d },
                ),
                orientation: UnitQuaternion::identity(),
            });
            let (moves, mut stop) = params(k, 20_000_000, fraction);
            stop.window = window;
            let layer = layer_of(vec![g; j + 1], poses.clone(), l);
            let (layer, out) = run_layer(layer, moves, stop, rng, &mut NoHooks)?;
            if !out.converged {
                return Err(Error::Validation(format!(
                    "case 606: no convergence in {} sweeps (L = {:.3} d, sphere {})",
                    out.sweeps,
                    l / d,
                    j + 1
                )));
            }
            let mut z: Vec<f64> = layer.poses.iter().map(|p| p.position.z).collect();
            z.sort_by(f64::total_cmp);
            let gap = if j == 0 {
                z[0] - r
            } else {
                z[j] - z[j - 1] - dz
            };
            rows.push(Row::new(
                format!(
                    "L = {:.3} d, layer {}: gap above its rest height (m; {} sweeps)",
                    l / d,
                    j + 1,
                    out.sweeps
                ),
                gap,
                0.0,
                residual[usize::from(j > 0)],
            ));
            poses = layer.poses;
        }
    }
    Ok(rows)
}

register!("607" => case_607);
/// Case 607: metamorphic. Spheres at T = 0 give bitwise the same deposit when viscosity,
/// gravity or density change (the sign of dE is the sign of dz), and all lengths scaled by a
/// power of two s (K_max by s^2) give positions scaled by s exactly.
pub fn case_607(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 607 needs a seed")?;
    let run = |scale: f64, viscosity: f64, g_acc: f64, density: f64| -> Result<Vec<Vector3<f64>>> {
        let r = 0.5e-6 * scale;
        let grains: Vec<Grain> = (0..120)
            .map(|_| Grain::new([r; 3], 0, density, 1000.0, g_acc))
            .collect::<Result<_>>()?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let opts = crate::deposition::film::FilmOptions {
            rsa_limit: 0.3,
            tries_per_particle: 5000,
            max_growth_rounds: 20_000,
            k_max_m2: 1e-14 * scale * scale,
        };
        let layer = crate::deposition::film::build(grains, 4e-6 * scale, 0.35, &opts, &mut rng)?;
        let (mut moves, stop) = params(1e-14 * scale * scale, 100_000, 1e-3);
        moves.energy.viscosity_pa_s = viscosity;
        let (layer, _) = run_layer(layer, moves, stop, rng, &mut NoHooks)?;
        Ok(layer.poses.iter().map(|p| p.position).collect())
    };
    let base = run(1.0, 0.01, 9.8, 2500.0)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let s = t.f64(i, "length_scale")?;
        let got = run(
            s,
            t.f64(i, "viscosity_pa_s")?,
            t.f64(i, "gravity_m_s2")?,
            t.f64(i, "density_kg_m3")?,
        )?;
        let worst = base
            .iter()
            .zip(&got)
            .map(|(a, b)| (b / s - a).norm() / 1e-6)
            .fold(0.0, f64::max);
        rows.push(Row::new(t.str(i, "label")?, worst, 0.0, 1.0));
    }
    Ok(rows)
}

/// The measures of every run of the monodisperse sphere deposit of row `i` of a 608/609
/// table (columns radius_m, particles, box_side_m, solids_percent, runs, and the stop rule:
/// stop_window, stop_supported_fraction and stop_accepted_rate, 0 for neither (the seed's
/// displacement rule), and max_sweeps), in parallel. A run that ends at max_sweeps fails the
/// case.
fn sphere_deposit_runs(
    t: &crate::validation::Table,
    i: usize,
    seed: u64,
    id: &str,
) -> Result<Vec<crate::deposition::measure::DepositMeasures>> {
    let mut rest_rule = format!("stop_window = {}\n", t.f64(i, "stop_window")? as u64);
    for key in ["stop_supported_fraction", "stop_accepted_rate"] {
        let v = t.f64(i, key)?;
        if v > 0.0 {
            rest_rule += &format!("{key} = {v}\n");
        }
    }
    let text = format!(
        "kind = \"deposition\"\nseed = {seed}\nruns = {}\n[film]\nparticles = {}\n\
         box_side_m = {}\nsolids_percent = {}\n[[species]]\nname = \"sphere\"\n\
         semi_axes_m = [{r}, {r}, {r}]\n[deposition]\nmax_sweeps = {}\n{rest_rule}",
        t.f64(i, "runs")? as usize,
        t.f64(i, "particles")? as usize,
        t.f64(i, "box_side_m")?,
        t.f64(i, "solids_percent")?,
        t.f64(i, "max_sweeps")? as u64,
        r = t.f64(i, "radius_m")?,
    );
    let scene = crate::scene::deposition::parse_scene(&text, id)?;
    use rayon::prelude::*;
    (0..scene.runs)
        .into_par_iter()
        .map(|k| {
            let d = crate::deposition::driver::run_one(&scene.setup, k, &mut NoHooks)?;
            if !d.outcome.converged {
                return Err(Error::Validation(format!(
                    "{id}: run {k} reached max_sweeps = {} before its stop rule",
                    d.outcome.sweeps
                )));
            }
            let m = measure(&d.layer, scene.setup.species.len(), &scene.measure)?;
            eprintln!(
                "{id} run {k}: {} sweeps, supported fraction {:?}, first-layer coverage {:.4}, \
                 core porosity {:?}",
                d.outcome.sweeps, m.supported_fraction, m.first_layer_coverage, m.core_porosity
            );
            Ok(m)
        })
        .collect()
}

/// A row: the mean over runs of `values`, against the band [band_low, band_high] of row `i`.
fn band_row(t: &crate::validation::Table, i: usize, what: &str, values: &[f64]) -> Result<Row> {
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let (lo, hi) = (t.f64(i, "band_low")?, t.f64(i, "band_high")?);
    let list: Vec<String> = values.iter().map(|p| format!("{p:.4}")).collect();
    Ok(Row::new(
        format!(
            "{} runs: mean {what} (runs {})",
            values.len(),
            list.join(" ")
        ),
        mean,
        0.5 * (lo + hi),
        0.5 * (hi - lo),
    ))
}

register!("608" => case_608);
/// Case 608: core packing fraction of monodisperse spheres deposited from the Table B1
/// colour (mean over runs), against the band between random loose packing and sequential
/// gravitational deposition; rows also give each run's value for review.
pub fn case_608(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 608 needs a seed")?;
    (0..t.len())
        .map(|i| {
            let rate = t.f64(i, "stop_accepted_rate")?;
            let what = if rate > 0.0 {
                format!("core packing fraction, accepted-move rest rule {rate}")
            } else {
                "core packing fraction".to_string()
            };
            let phis: Vec<f64> = sphere_deposit_runs(&t, i, seed, "case 608")?
                .iter()
                .map(|m| {
                    m.core_porosity.map(|p| 1.0 - p).ok_or_else(|| {
                        Error::Validation("case 608: layer too thin for a core porosity".into())
                    })
                })
                .collect::<Result<_>>()?;
            band_row(&t, i, &what, &phis)
        })
        .collect()
}

register!("609" => case_609);
/// Case 609: first-layer coverage of the substrate by monodisperse spheres deposited from the
/// Table B1 colour (mean over runs), between the random sequential adsorption jamming limit of
/// discs and hexagonal close packing.
pub fn case_609(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 609 needs a seed")?;
    (0..t.len())
        .map(|i| {
            let cover: Vec<f64> = sphere_deposit_runs(&t, i, seed, "case 609")?
                .iter()
                .map(|m| m.first_layer_coverage)
                .collect();
            band_row(&t, i, "first-layer coverage", &cover)
        })
        .collect()
}
