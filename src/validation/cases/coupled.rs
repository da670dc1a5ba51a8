//! Cases 811-814: the two-way coupled LBM–DEM of seed 002 ("Two-way coupling algorithm").
//! Expected values are closed forms written out here (Ergun 1952, Wen & Yu 1966 as combined by
//! Gidaspow 1994, Stokes 1851), never values of the code under test.

use crate::coupled::{driver, Basesheet, Coupled, Overlap, Switch};
use crate::dem::{
    ContactModel, DampingModel, ImpactSpeed, Material, NormalModel, Particles, Setup, Start,
    TangentialModel,
};
use crate::driver::Hooks;
use crate::error::invalid;
use crate::lbm::{CollisionKind, CollisionModel, LatticeKind, Tau};
use crate::validation::{CaseContext, Row};
use crate::Result;
use nalgebra::Vector3;
use rand::SeedableRng;
use std::f64::consts::PI;

/// The DEM of the coupled cases: Hertz–Mindlin (E = 1e7 Pa, nu = 0.3, e = 0.5, mu = 0.3) in
/// the box `l` (fixed top wall at l_z), gravity `g` along -z, buoyancy in a fluid of density
/// `rho_f`, the particles `p` and the impact speed `v` of the time-step rule.
fn dem_setup(l: [f64; 3], rho_p: f64, g: f64, rho_f: f64, p: Particles, v: f64) -> Result<Setup> {
    let mat = Material::new(1e7, 0.3)?;
    let contact = hertz_mindlin(TangentialModel::mindlin(0.3, 1.0)?)?;
    let mut s = Setup::in_box(l, contact, mat, rho_p, Start::Given(p));
    s.gravity_m_s2 = Vector3::new(0.0, 0.0, -g);
    s.fluid_density_kg_m3 = rho_f;
    s.impact_speed = ImpactSpeed::Given { m_s: v };
    Ok(s)
}

/// Hertz with restitution damping (e = 0.5) and the tangential law `t`.
fn hertz_mindlin(t: TangentialModel) -> Result<ContactModel> {
    ContactModel::new(NormalModel::Hertz, DampingModel::restitution(0.5)?, t)
}

/// The coupled setup of the cases: the DEM `dem` in a D3Q15 BGK fluid of relaxation time
/// `tau` (the lattice spans the DEM box), exact overlaps, eps_min 0.1.
#[allow(clippy::too_many_arguments)]
fn coupled_setup(
    dem: Setup,
    dx: f64,
    tau: f64,
    mu: f64,
    switch: Switch,
    grad_p: Vector3<f64>,
    balance: bool,
    m: u64,
    frozen: bool,
) -> Result<crate::coupled::Setup> {
    Ok(crate::coupled::Setup {
        dem,
        dx_m: dx,
        lattice: LatticeKind::D3Q15,
        collision: CollisionModel::new(CollisionKind::Bgk, Tau::new(tau)?),
        fluid_density_kg_m3: 1000.0,
        viscosity_pa_s: mu,
        overlap: Overlap::Exact,
        switch,
        eps_min: 0.1,
        grad_p_pa_m: grad_p,
        balance_weight: balance,
        dem_steps: m,
        max_move_cells: 0.1,
        max_relaxation: 1.0,
        frozen,
        basesheet: None,
    })
}

/// Mean superficial fluid velocity along z over the lattice (m/s).
fn mean_uz(c: &Coupled) -> f64 {
    let v = c.velocity_si();
    v.iter().map(|w| w[2]).sum::<f64>() / v.len() as f64
}

/// Gidaspow's beta (per unit mixture volume) at porosity eps and interstitial slip w (SI),
/// blended (Huilin & Gidaspow 2003) or switched at eps = 0.8.
fn beta_gidaspow(eps: f64, d: f64, mu: f64, rho: f64, w: f64, blend: bool) -> f64 {
    let ergun = 150.0 * (1.0 - eps).powi(2) * mu / (eps * d * d) + 1.75 * (1.0 - eps) * rho * w / d;
    let re = eps * rho * w * d / mu;
    let cd_re = if re < 1000.0 {
        24.0 * (1.0 + 0.15 * re.powf(0.687))
    } else {
        0.44 * re
    };
    // 3/4 C_d eps (1 - eps) rho w / d eps^-2.65 with C_d Re = cd_re
    let wen_yu = 0.75 * cd_re * mu / (eps * d * d) * eps * (1.0 - eps) * eps.powf(-2.65);
    let phi = if blend {
        0.5 + (262.5 * (eps - 0.8)).atan() / PI
    } else if eps < 0.8 {
        0.0
    } else {
        1.0
    };
    (1.0 - phi) * ergun + phi * wen_yu
}

register!("811" => case_811);
/// Case 811: phase momentum balance and fluid mass, every coupling step, for a settling
/// suspension with contacts (no wall contact).
pub fn case_811(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let n = t.f64(i, "n")? as usize;
        let d = t.f64(i, "diameter_m")?;
        let dx = t.f64(i, "dx_m")?;
        let cells = [t.f64(i, "nx")?, t.f64(i, "ny")?, t.f64(i, "nz")?];
        let l = [cells[0] * dx, cells[1] * dx, cells[2] * dx];
        let steps = t.f64(i, "steps")? as u64;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(ctx.seed.unwrap_or(1) + i as u64);
        let radius = vec![0.5 * d; n];
        // dispersed in the middle half of the height, far from the walls
        let mut pos =
            crate::dem::start::random_dispersion(&radius, l[0], l[1], 0.5 * l[2], &mut rng)?;
        for p in pos.iter_mut() {
            p.z += 0.25 * l[2];
        }
        let p = Particles::at_rest(pos, radius, 2500.0);
        let dem = dem_setup(l, 2500.0, 9.81, 1000.0, p, 0.1)?;
        let grad = Vector3::new(t.f64(i, "grad_p_x_pa_m")?, 0.0, 0.0);
        let cs = coupled_setup(
            dem,
            dx,
            t.f64(i, "tau")?,
            t.f64(i, "viscosity_pa_s")?,
            Switch::Blend,
            grad,
            true,
            t.f64(i, "dem_steps")? as u64,
            false,
        )?;
        let mut c = Coupled::new(cs)?;
        let m0 = c.lbm.mass();
        let mut worst_mass: f64 = 0.0;
        let mut exchanged: f64 = 0.0;
        for s in 0..steps {
            c.step()?;
            exchanged = exchanged.max(c.hydro_n.iter().map(|f| f.norm()).sum::<f64>());
            worst_mass = worst_mass.max((c.lbm.mass() - m0).abs() / m0);
            if let Some(k) =
                (0..c.dem.p.len()).find(|&k| c.dem.p.pos[k].z < d || c.dem.p.pos[k].z > l[2] - d)
            {
                return invalid(format!(
                    "case 811: particle {k} reached a wall at step {s}: this case keeps to the \
                     free suspension (case 815 has the walls); shorten the run"
                ));
            }
        }
        if exchanged <= 0.0 {
            return invalid("case 811: no force exchanged: the test would be empty");
        }
        let tol = t.f64(i, "rounding_tolerance")?;
        rows.push(Row::new(
            format!("n={n} worst |dP_f + dP_s - J_ext| / scale over {steps} steps"),
            c.worst_balance,
            0.0,
            tol,
        ));
        rows.push(Row::new(
            format!("n={n} worst fluid mass drift"),
            worst_mass,
            0.0,
            tol,
        ));
    }
    Ok(rows)
}

register!("812" => case_812);
/// Case 812: fixed bed of uniform porosity (one frozen sphere centred in each cell) under a
/// pressure gradient: the steady superficial velocity U satisfies grad p = beta(U) U / eps^2
/// (Ergun 150/1.75 below eps = 0.8 with the sharp switch; Gidaspow's blend otherwise), and the
/// bed carries the whole pressure drop.
pub fn case_812(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let dx = t.f64(i, "dx_m")?;
        let d = t.f64(i, "d_over_dx")? * dx;
        let mu = t.f64(i, "viscosity_pa_s")?;
        let gp = t.f64(i, "grad_p_pa_m")?;
        let blend = t.str(i, "switch")? == "blend";
        let n = 4usize;
        let l = [n as f64 * dx; 3];
        let mut pos = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    pos.push(Vector3::new(
                        (x as f64 + 0.5) * dx,
                        (y as f64 + 0.5) * dx,
                        (z as f64 + 0.5) * dx,
                    ));
                }
            }
        }
        let radius = vec![0.5 * d; pos.len()];
        let p = Particles::at_rest(pos, radius, 2500.0);
        let dem = dem_setup(l, 2500.0, 0.0, 1000.0, p, 0.1)?;
        let cs = coupled_setup(
            dem,
            dx,
            t.f64(i, "tau")?,
            mu,
            if blend { Switch::Blend } else { Switch::Sharp },
            Vector3::new(0.0, 0.0, gp),
            false,
            1,
            true,
        )?;
        let mut c = Coupled::new(cs)?;
        let steady = driver::run_to_steady(&mut c, 200_000, 1e-15, mean_uz)?;
        let u = steady.value;
        let eps = 1.0 - PI / 6.0 * (d / dx).powi(3);
        let speed = u.abs();
        let beta = beta_gidaspow(eps, d, mu, 1000.0, speed / eps, blend);
        let re = 1000.0 * speed * d / mu;
        let label = format!(
            "{} eps={eps:.4} Re_p={re:.3}",
            if blend { "blend" } else { "sharp (Ergun)" }
        );
        rows.push(Row::new(
            format!("{label}: beta U / eps^2 (Pa/m)"),
            beta * speed / (eps * eps),
            gp.abs(),
            gp.abs(),
        ));
        // the bed's share: hydrodynamic force on the spheres plus -grad p on their volume
        let vs: f64 = c
            .dem
            .p
            .radius
            .iter()
            .map(|r| 4.0 / 3.0 * PI * r.powi(3))
            .sum();
        let fz: f64 = c.hydro_n.iter().map(|f| f.z).sum::<f64>() - gp * vs;
        let total = -gp * l[0] * l[1] * l[2];
        rows.push(Row::new(
            format!("{label}: bed force / (-grad p V_box)"),
            fz / total,
            1.0,
            1.0,
        ));
        if !(steady.steady && u.is_finite()) {
            return invalid("case 812: no steady state");
        }
    }
    Ok(rows)
}

/// One sphere settling from rest in a periodic box whose weight is carried by the mean
/// pressure gradient; returns (terminal velocity, slip against the volume-weighted
/// interstitial fluid velocity of its cells weighted as Wen–Yu weights them, V_ic eps_c^-2.65,
/// and the volume-weighted eps^-2.65).
fn settle(
    dx: f64,
    d: f64,
    mu: f64,
    tau: f64,
    cells: usize,
    m: u64,
    steps: u64,
) -> Result<(f64, f64, f64)> {
    let l = [cells as f64 * dx; 3];
    let pos = vec![Vector3::new(0.37 * l[0], 0.61 * l[1], 0.8 * l[2])];
    let p = Particles::at_rest(pos, vec![0.5 * d], 2500.0);
    let dem = dem_setup(l, 2500.0, 9.81, 1000.0, p, 0.1)?;
    let cs = coupled_setup(
        dem,
        dx,
        tau,
        mu,
        Switch::Sharp,
        Vector3::zeros(),
        true,
        m,
        false,
    )?;
    let mut c = Coupled::new(cs)?;
    let mut v_sum = 0.0;
    let mut slip_sum = 0.0;
    let mut corr_sum = 0.0;
    let window = steps / 4;
    for s in 0..steps {
        c.step()?;
        if s >= steps - window {
            // interstitial fluid velocity over the sphere's cells
            let mut cells_v = Vec::new();
            let p = c.dem.p.pos[0];
            crate::coupled::porosity::sphere_cells(
                Overlap::Exact,
                [p.x, p.y, p.z],
                0.5 * d,
                [cells, cells, cells],
                dx,
                &mut cells_v,
            );
            let u = c.velocity_si();
            let vol: f64 = cells_v.iter().map(|e| e.1).sum();
            // Wen–Yu weights the cells by V_ic eps_c^-2.65
            let (mut uf, mut corr) = (0.0, 0.0);
            for &(cell, v) in &cells_v {
                let e = c.eps[cell as usize];
                let wgt = v / vol * e.powf(-2.65);
                uf += wgt * u[cell as usize][2] / e;
                corr += wgt;
            }
            uf /= corr;
            v_sum += c.dem.p.vel[0].z;
            slip_sum += c.dem.p.vel[0].z - uf;
            corr_sum += corr;
        }
    }
    let w = window as f64;
    Ok((v_sum / w, slip_sum / w, corr_sum / w))
}

register!("813" => case_813);
/// Case 813: a single sphere settling at low Re: its slip against the local fluid equals the
/// single-particle limit of Wen & Yu (Stokes, corrected by the cell porosity eps^-2.65 and by
/// C_d Re / 24 = 1 + 0.15 Re^0.687), under the weight m' g (1 - V / V_box) left after the
/// balancing pressure gradient.
pub fn case_813(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let dx = t.f64(i, "dx_m")?;
        let d = t.f64(i, "d_over_dx")? * dx;
        let mu = t.f64(i, "viscosity_pa_s")?;
        let cells = t.f64(i, "cells")? as usize;
        let (v, slip, corr) = settle(
            dx,
            d,
            mu,
            t.f64(i, "tau")?,
            cells,
            t.f64(i, "dem_steps")? as u64,
            t.f64(i, "steps")? as u64,
        )?;
        let vol = PI / 6.0 * d.powi(3);
        let weight = (2500.0 - 1000.0) * vol * 9.81 * (1.0 - vol / (cells as f64 * dx).powi(3));
        let stokes = weight / (3.0 * PI * mu * d);
        // Wen–Yu: slip = stokes / (corr (1 + 0.15 Re^0.687)), Re = eps rho |slip| d / mu ~ rho
        // |slip| d / mu (eps within 1 % of 1 here): fixed point
        let mut s = stokes;
        for _ in 0..100 {
            let re = 1000.0 * s * d / mu;
            s = stokes / (corr * (1.0 + 0.15 * re.powf(0.687)));
        }
        rows.push(Row::new(
            format!("d/dx={} slip speed (m/s)", d / dx),
            -slip,
            s,
            s,
        ));
        eprintln!(
            "case 813: d/dx = {}: terminal velocity {:.4e} m/s = {:.4} x Stokes {:.4e} m/s \
             (the fluid dragged along by the sphere's own force); slip {:.4e} m/s",
            d / dx,
            -v,
            -v / stokes,
            stokes,
            -slip
        );
    }
    Ok(rows)
}

register!("814" => case_814);
/// Case 814: the settling sphere's terminal velocity does not depend on the number M of DEM
/// steps per LBM step (the seed's remark), M = 100, 300, 1000.
pub fn case_814(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    let mut reference = None;
    for i in 0..t.len() {
        let dx = t.f64(i, "dx_m")?;
        let m = t.f64(i, "dem_steps")? as u64;
        let (v, _, _) = settle(
            dx,
            t.f64(i, "d_over_dx")? * dx,
            t.f64(i, "viscosity_pa_s")?,
            t.f64(i, "tau")?,
            t.f64(i, "cells")? as usize,
            m,
            t.f64(i, "steps")? as u64,
        )?;
        let r = *reference.get_or_insert(v);
        rows.push(Row::new(
            format!("M={m} terminal velocity / M=first"),
            v / r,
            1.0,
            1.0,
        ));
    }
    Ok(rows)
}

register!("815" => case_815);
/// Case 815: the momentum ledger with the walls in it: particles of the coupled-quick built-in
/// settle onto the floor (and slide on it under a cross flow), or are held as a frozen bed;
/// every coupling step balances fluid + particle momentum against the external, wall and
/// constraint impulses.
pub fn case_815(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let variant = t.str(i, "variant")?;
        let g = [t.f64(i, "grad_p_x_pa_m")?, t.f64(i, "grad_p_z_pa_m")?];
        let text = include_str!("../../scene/builtin/coupled-quick.toml").replace(
            "pressure_gradient_pa_m = [0.0, 0.0, 500.0]",
            &format!("pressure_gradient_pa_m = [{:?}, 0.0, {:?}]", g[0], g[1]),
        );
        let text = text.replace("tau = 0.515", &format!("tau = {:?}", t.f64(i, "tau")?));
        let text = match &variant[..] {
            "settle" => text,
            "frozen" => text.replace(
                "max_relaxation = 1.0",
                "max_relaxation = 1.0\nfrozen = true",
            ),
            v => return invalid(format!("case 815: variant \"{v}\": settle or frozen")),
        };
        let scene = crate::scene::coupled::parse_scene(&text, "case 815")?;
        let mut c = crate::scene::coupled::build(&scene)?;
        let steps = t.f64(i, "steps")? as u64;
        let (mut wall_steps, mut wall_share, mut tangential) = (0u64, 0.0f64, 0.0f64);
        for _ in 0..steps {
            let b = c.step()?;
            if b.walls.norm() > 0.0 {
                wall_steps += 1;
                wall_share = wall_share.max(b.walls.norm() / b.scale);
                tangential = tangential.max(b.walls.x.hypot(b.walls.y) / b.scale);
            }
        }
        let min_share = t.f64(i, "min_wall_share")?;
        if wall_share < min_share {
            return invalid(format!(
                "case 815 {variant}: the walls carried at most {wall_share:.3e} of a step's \
                 impulse (< {min_share}): the test would not exercise them"
            ));
        }
        eprintln!(
            "case 815 {variant}: {wall_steps} of {steps} steps with wall impulse, largest share \
             {wall_share:.3}, largest tangential share {tangential:.2e}, worst imbalance {:.2e}",
            c.worst_balance
        );
        rows.push(Row::new(
            format!(
                "{variant} grad_p=({}, 0, {}) worst |dP_f + dP_s - J_ext - J_walls| / scale over \
                 {steps} steps",
                g[0], g[1]
            ),
            c.worst_balance,
            0.0,
            t.f64(i, "rounding_tolerance")?,
        ));
    }
    Ok(rows)
}

/// Centres of a jittered simple lattice of about `n_target` spheres of diameter `d` filling
/// the box `l` (x, y periodic; z between the walls, a radius clear of each): kx = ky columns
/// and kz layers chosen for the widest smallest gap with a count within 5 % of the target,
/// each centre moved by a uniform random offset of up to 0.45 of that gap in each axis. With
/// `cells_across` = Some(n), kx is a multiple of n: every vertical column of the n x n cells
/// holds the same sphere columns.
fn jittered_lattice(
    n_target: f64,
    d: f64,
    l: [f64; 3],
    cells_across: Option<usize>,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<Vec<Vector3<f64>>> {
    use rand::Rng;
    let mut best: Option<([f64; 3], f64)> = None;
    for kx in 1..=(l[0] / d) as usize {
        if cells_across.is_some_and(|n| kx % n != 0) {
            continue;
        }
        let kx = kx as f64;
        let kz = (n_target / (kx * kx)).round().max(1.0);
        if ((kx * kx * kz - n_target) / n_target).abs() > 0.05 {
            continue;
        }
        let gap = (l[0] / kx).min(l[1] / kx).min((l[2] - d) / kz) - d;
        if gap > best.map_or(0.0, |b| b.1) {
            best = Some(([kx, kx, kz], gap));
        }
    }
    let Some((k, gap)) = best else {
        return invalid(format!(
            "no simple lattice of {n_target:.0} spheres of {d} m fits the box {l:?} m"
        ));
    };
    let a = [l[0] / k[0], l[1] / k[1], (l[2] - d) / k[2]];
    let mut pos = Vec::new();
    for iz in 0..k[2] as usize {
        for iy in 0..k[1] as usize {
            for ix in 0..k[0] as usize {
                let mut j = || 0.45 * gap * (2.0 * rng.gen::<f64>() - 1.0);
                pos.push(Vector3::new(
                    (ix as f64 + 0.5) * a[0] + j(),
                    (iy as f64 + 0.5) * a[1] + j(),
                    0.5 * d + (iz as f64 + 0.5) * a[2] + j(),
                ));
            }
        }
    }
    Ok(pos)
}

register!("816" => case_816);
/// Case 816: hindered settling of a homogeneous suspension (the whole box filled) against
/// Richardson & Zaki: the effective exponent n = ln(U / U_t) / ln(eps) of the settling
/// velocity U relative to the zero-volume-flux frame over the isolated sphere's terminal
/// velocity U_t, against the cited low-Re band of n.
pub fn case_816(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let phi_target = t.f64(i, "solid_fraction")?;
        let dx = t.f64(i, "dx_m")?;
        let d = t.f64(i, "d_over_dx")? * dx;
        let mu = t.f64(i, "viscosity_pa_s")?;
        let rho_p = t.f64(i, "particle_density_kg_m3")?;
        let cells = [t.f64(i, "nx")?, t.f64(i, "ny")?, t.f64(i, "nz")?];
        let l = [cells[0] * dx, cells[1] * dx, cells[2] * dx];
        let steps = t.f64(i, "steps")? as u64;
        let vp = PI / 6.0 * d.powi(3);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(ctx.seed.unwrap_or(1) + i as u64);
        let n_target = phi_target * l[0] * l[1] * l[2] / vp;
        // the `arrangement` column; without it, the second protocol's rule: random sequential
        // addition below its jamming (~0.38), the widest-gap lattice above
        let arrangement = match t.col("arrangement").map(|_| t.str(i, "arrangement")) {
            Err(_) if phi_target <= 0.3 => "random",
            Err(_) => "lattice",
            Ok(a) => a?,
        };
        let pos = match arrangement {
            "random" => {
                let radius = vec![0.5 * d; n_target.round() as usize];
                crate::dem::start::random_dispersion(&radius, l[0], l[1], l[2], &mut rng)?
            }
            "lattice" => jittered_lattice(n_target, d, l, None, &mut rng)?,
            "cell-lattice" => jittered_lattice(n_target, d, l, Some(cells[0] as usize), &mut rng)?,
            other => {
                return invalid(format!(
                    "{} row {i}: arrangement {other:?} (random, lattice or cell-lattice)",
                    t.path().display()
                ))
            }
        };
        let n = pos.len();
        let p = Particles::at_rest(pos, vec![0.5 * d; n], rho_p);
        let mut setup = dem_setup(l, rho_p, 9.81, 1000.0, p, 0.01)?;
        setup.contact = hertz_mindlin(TangentialModel::None)?;
        let dem = setup;
        let mut cs = coupled_setup(
            dem,
            dx,
            t.f64(i, "tau")?,
            mu,
            Switch::Blend,
            Vector3::zeros(),
            true,
            t.f64(i, "dem_steps")? as u64,
            false,
        )?;
        cs.max_move_cells = t.f64(i, "max_move_cells")?;
        let mut c = Coupled::new(cs)?;
        // the cell-scale concentration the fluid sees: the spread of the cell porosity, and of
        // the mean porosity of each vertical column of cells (lateral differences in the
        // mixture's weight drive a convection the closure does not contain)
        let spread = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|e| (e - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        let nxy = (cells[0] * cells[1]) as usize;
        let column_eps: Vec<f64> = (0..nxy)
            .map(|col| c.eps.iter().skip(col).step_by(nxy).sum::<f64>() / cells[2])
            .collect();
        let (sd_cell, sd_column) = (spread(&c.eps), spread(&column_eps));
        // the middle half of the height, away from both walls
        let (z0, z1) = (0.25 * l[2], 0.75 * l[2]);
        let (k0, k1) = ((z0 / dx).round() as usize, (z1 / dx).round() as usize);
        let (mut u_sum, mut eps_sum, mut count) = (0.0, 0.0, 0.0);
        let mut samples = Vec::new();
        for s in 0..steps {
            c.step()?;
            if s < steps / 2 {
                continue;
            }
            let (mut vs, mut ns) = (0.0, 0.0);
            for k in 0..n {
                let z = c.dem.p.pos[k].z;
                if z >= z0 && z < z1 {
                    vs += c.dem.p.vel[k].z;
                    ns += 1.0;
                }
            }
            let u = c.velocity_si();
            let cells_mid = (k0 * nxy)..(k1 * nxy);
            let m = cells_mid.len() as f64;
            let u_sup: f64 = u[cells_mid.clone()].iter().map(|v| v[2]).sum::<f64>() / m;
            let eps: f64 = c.eps[cells_mid].iter().sum::<f64>() / m;
            // settling velocity relative to the zero-volume-flux frame: V_s - (phi V_s + u_sup)
            let settle = -(eps * vs / ns - u_sup);
            samples.push(settle);
            u_sum += settle;
            eps_sum += eps;
            count += 1.0;
        }
        let u_hs = u_sum / count;
        let eps = eps_sum / count;
        // isolated sphere: Stokes with Schiller & Naumann's 1 + 0.15 Re^0.687 (fixed point)
        let stokes = (rho_p - 1000.0) * 9.81 * d * d / (18.0 * mu);
        let mut u_t = stokes;
        for _ in 0..100 {
            u_t = stokes / (1.0 + 0.15 * (1000.0 * u_t * d / mu).powf(0.687));
        }
        // standard error of the window mean from 8 blocks
        let b = samples.len() / 8;
        let means: Vec<f64> = samples
            .chunks(b.max(1))
            .take(8)
            .map(|c| c.iter().sum::<f64>() / c.len() as f64)
            .collect();
        let mb = means.iter().sum::<f64>() / means.len() as f64;
        let se = (means.iter().map(|m| (m - mb).powi(2)).sum::<f64>()
            / (means.len() as f64 * (means.len() as f64 - 1.0)))
            .sqrt();
        let n_eff = (u_hs / u_t).ln() / eps.ln();
        // the closure's own low-Re prediction (Gidaspow blend, no Re correction):
        // beta slip = eps (1 - eps) (rho_p - rho_f) g, U = eps slip
        let beta_over_slip = beta_gidaspow(eps, d, mu, 1000.0, 0.0, true);
        let u_closure = eps * eps * (1.0 - eps) * (rho_p - 1000.0) * 9.81 / beta_over_slip;
        eprintln!(
            "case 816: phi = {:.4} ({n} spheres): U = {u_hs:.5e} m/s (block s.e. {se:.1e}), U_t \
             = {u_t:.5e} m/s, U/U_t = {:.4}, n = {n_eff:.3} (+-{:.3}); closure at low Re: U/U_t \
             = {:.4}, n = {:.3}; eps^4.65 = {:.4}; Re_t = {:.3e}; {arrangement}: porosity s.d. \
             {sd_cell:.4} per cell, {sd_column:.4} per column of cells; {:.1} s",
            1.0 - eps,
            u_hs / u_t,
            (se / u_hs) / eps.ln().abs(),
            u_closure / stokes,
            (u_closure / stokes).ln() / eps.ln(),
            eps.powf(4.65),
            1000.0 * u_t * d / mu,
            c.timing.lbm_s + c.timing.dem_s + c.timing.coupling_s
        );
        rows.push(Row::new(
            format!("phi={:.3} Richardson-Zaki exponent n", 1.0 - eps),
            n_eff,
            t.f64(i, "n_band_mid")?,
            1.0,
        ));
    }
    Ok(rows)
}

/// The collision of row `i`: its `collision` column ("bgk" or "trt", TRT with Lambda = 3/16)
/// at its `tau`; BGK, the seed's, where the table has no such column.
fn collision_of(t: &crate::validation::Table, i: usize) -> Result<CollisionModel> {
    let kind = match t.col("collision").map(|_| t.str(i, "collision")) {
        Err(_) => CollisionKind::Bgk,
        Ok(name) => match name? {
            "bgk" => CollisionKind::Bgk,
            "trt" => CollisionKind::Trt,
            other => {
                return invalid(format!(
                    "{} row {i}: collision {other:?} (bgk or trt)",
                    t.path().display()
                ))
            }
        },
    };
    Ok(CollisionModel::new(kind, Tau::new(t.f64(i, "tau")?)?))
}

register!("817" => case_817);
/// Case 817: the basesheet alone (no particles) under a mean pressure gradient in a periodic
/// column: the pressure drop across it from the fluid's own pressure field equals Darcy's
/// mu U h / K, and U equals the closed form of the column, grad p L K / (mu h).
pub fn case_817(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let dx = t.f64(i, "dx_m")?;
        let mu = t.f64(i, "viscosity_pa_s")?;
        let k = t.f64(i, "permeability_m2")?;
        let gp = t.f64(i, "grad_p_pa_m")?;
        let ns = t.f64(i, "sheet_cells")? as usize;
        let nc = t.f64(i, "clear_cells")? as usize;
        let l = [2.0 * dx, 2.0 * dx, nc as f64 * dx];
        let p = Particles::at_rest(vec![], vec![], 2500.0);
        let mut setup = dem_setup(l, 2500.0, 0.0, 1000.0, p, 0.1)?;
        // no particles: the neighbour skin is given (its default scales with a diameter)
        setup.skin_m = Some(0.1 * dx);
        let dem = setup;
        let mut cs = coupled_setup(
            dem,
            dx,
            t.f64(i, "tau")?,
            mu,
            Switch::Blend,
            Vector3::new(0.0, 0.0, gp),
            false,
            1,
            true,
        )?;
        cs.collision = collision_of(&t, i)?;
        let h = ns as f64 * dx;
        cs.basesheet = Some(Basesheet {
            thickness_m: h,
            permeability_m2: k,
        });
        let mut c = Coupled::new(cs)?;
        let nxy = 4;
        let nz = ns + nc;
        let flux = |c: &Coupled| -> f64 {
            // mass-flux velocity through the sheet (m/s): sum rho u / (rho_0 cells)
            let s: f64 = (0..ns * nxy)
                .map(|cell| c.record.rho[cell] * c.record.u[cell][2])
                .sum();
            s / (ns * nxy) as f64 * dx / c.units.dt
        };
        let steady = driver::run_to_steady(&mut c, 200_000, 1e-15, flux)?;
        let (u, steps) = (steady.value, steady.steps);
        // the worst over every step of the run
        let worst_balance = c.worst_balance;
        if !(steady.steady && u.is_finite()) {
            return invalid(format!(
                "case 817 row {i}: no steady state in {steps} steps"
            ));
        }
        // The steady 1D momentum balance of the fluid between a layer m above the sheet
        // (centre (ns + m + 1/2) dx) and one m below it through the periodic boundary (centre
        // -(m + 1/2) dx): the momentum flux c_s^2 rho + rho u_z^2 of the two layers differs by
        // the drive on the fluid between them minus the sheet's drag. The drive is an
        // acceleration g = grad_p / rho_f acting on the local density, rho_c g per cell (half
        // of each end layer), not rho_f g: the weakly compressible fluid's density varies by
        // up to drop / (rho_f c_s^2) along the column, 0.26 in the tau = 0.8 rows.
        let p = c.pressure_si();
        let rho = &c.record.rho;
        let to_pa = c.setup.fluid_density_kg_m3 * (dx / c.units.dt).powi(2);
        let rho_uu: Vec<f64> = (0..rho.len())
            .map(|cell| rho[cell] * c.record.u[cell][2].powi(2) * to_pa)
            .collect();
        let layer =
            |v: &[f64], kz: usize| v[kz * nxy..(kz + 1) * nxy].iter().sum::<f64>() / nxy as f64;
        let (above, below) = (|m: usize| ns + m, |m: usize| nz - 1 - m);
        let drive = |m: usize| {
            let path: Vec<usize> = (below(m)..nz).chain(0..=above(m)).collect();
            let last = path.len() - 1;
            let cells: f64 = path
                .iter()
                .enumerate()
                .map(|(j, &kz)| if j == 0 || j == last { 0.5 } else { 1.0 } * layer(rho, kz))
                .sum();
            gp * dx * cells
        };
        let flux = |m: usize| {
            layer(&p, above(m)) + layer(&rho_uu, above(m))
                - layer(&p, below(m))
                - layer(&rho_uu, below(m))
        };
        let drop_at = |m: usize| flux(m) + drive(m);
        // the first protocol's reading: c_s^2 rho alone and the drive taken as rho_f g
        let drop_rho_f = |m: usize| {
            layer(&p, above(m)) - layer(&p, below(m)) + gp * (ns + 2 * m + 1) as f64 * dx
        };
        let darcy = mu * u.abs() * h / k;
        let column = gp * nz as f64 * dx * k / (mu * h);
        let (lo, hi) = rho
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| {
                (a.min(r), b.max(r))
            });
        let relative = |f: &dyn Fn(usize) -> f64| {
            (0..nc / 2)
                .map(|m| format!("{:.2e}", f(m) / darcy - 1.0))
                .collect::<Vec<_>>()
                .join(", ")
        };
        eprintln!(
            "case 817 row {i}: density {lo:.4}..{hi:.4} rho_f; drop / Darcy - 1 at m = 0..{}: \
             {} (c_s^2 rho with rho_f g: {})",
            nc / 2 - 1,
            relative(&drop_at),
            relative(&drop_rho_f)
        );
        let label = format!(
            "{} K={k:e} m^2 h={ns}dx grad_p={gp} Pa/m (K/dx^2={:.2e}, U={:.3e} m/s, {steps} steps)",
            t.str(i, "collision")?.to_uppercase(),
            k / (dx * dx),
            u.abs()
        );
        for (m, at) in [(0, "at the sheet's faces"), (nc / 2 - 1, "mid clear fluid")] {
            rows.push(Row::new(
                format!("{label}: drop across the sheet (Pa), read {at}, vs mu U h / K"),
                drop_at(m),
                darcy,
                darcy,
            ));
        }
        rows.push(Row::new(
            format!("{label}: U vs grad_p L K / (mu h)"),
            u.abs(),
            column,
            column,
        ));
        rows.push(Row::new(
            format!("{label}: worst momentum imbalance"),
            worst_balance,
            0.0,
            1.0,
        ));
    }
    Ok(rows)
}

/// Ergun's gradient (Pa/m) at porosity `eps`, diameter `d` and superficial velocity `u` (SI).
fn ergun_gradient(eps: f64, d: f64, mu: f64, rho: f64, u: f64) -> f64 {
    150.0 * mu * (1.0 - eps).powi(2) * u / (eps.powi(3) * d * d)
        + 1.75 * rho * (1.0 - eps) * u * u / (eps.powi(3) * d)
}

/// [`crate::special::root::increasing_root`] with the bracket allowed up to 1e12.
fn increasing_root(f: impl Fn(f64) -> f64, target: f64) -> f64 {
    crate::special::root::increasing_root(f, target, 1e12)
}

/// Porosity of each cell of a periodic lattice by the solid length along x of `k`^2 lines
/// per cell (midpoints in y and z; the union of the spheres' chords, clipped to the cell, in
/// closed form), independent of the engine's sphere-cube volumes.
fn chord_porosity(pos: &[Vector3<f64>], r: f64, n: [usize; 3], dx: f64, k: usize) -> Vec<f64> {
    let l = [n[0] as f64 * dx, n[1] as f64 * dx, n[2] as f64 * dx];
    let h = dx / k as f64;
    let cells = n[0] * n[1] * n[2];
    let mut eps = vec![0.0; cells];
    for (c, e) in eps.iter_mut().enumerate() {
        let (cx, cy, cz) = (c % n[0], (c / n[0]) % n[1], c / (n[0] * n[1]));
        let (x0, x1) = (cx as f64 * dx, (cx + 1) as f64 * dx);
        let mut solid = 0.0;
        for a in 0..k {
            for b in 0..k {
                let y = cy as f64 * dx + (a as f64 + 0.5) * h;
                let z = cz as f64 * dx + (b as f64 + 0.5) * h;
                // chords of every sphere image crossing this line, as x intervals
                let mut iv: Vec<(f64, f64)> = Vec::new();
                for p in pos {
                    let mut dy = y - p.y;
                    dy -= l[1] * (dy / l[1]).round();
                    let mut dz = z - p.z;
                    dz -= l[2] * (dz / l[2]).round();
                    let s2 = r * r - dy * dy - dz * dz;
                    if s2 <= 0.0 {
                        continue;
                    }
                    let half = s2.sqrt();
                    for img in [-l[0], 0.0, l[0]] {
                        let (lo, hi) = ((p.x + img - half).max(x0), (p.x + img + half).min(x1));
                        if hi > lo {
                            iv.push((lo, hi));
                        }
                    }
                }
                iv.sort_by(|u, v| u.0.total_cmp(&v.0));
                let (mut end, mut len) = (f64::NEG_INFINITY, 0.0);
                for (lo, hi) in iv {
                    let lo = lo.max(end);
                    if hi > lo {
                        len += hi - lo;
                        end = hi;
                    }
                }
                solid += len;
            }
        }
        *e = 1.0 - solid / (k * k) as f64 / dx;
    }
    eps
}

register!("840" => case_840);
/// Case 840: random fixed beds (MCM in a periodic cube, DEM settled on a floor) frozen in the
/// coupled engine under a pressure gradient: grad p / Ergun(eps_b, U) between the bounds of
/// the bed's counted porosity field (columns in parallel: upper; layers in series: lower).
pub fn case_840(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let (rho, mu) = (1000.0, 1e-3);
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let file = t.str(i, "bed")?;
        let d = t.f64(i, "diameter_m")?;
        let nx = t.f64(i, "cells_x")? as usize;
        let re_target = t.f64(i, "re_p")?;
        let tau = t.f64(i, "tau")?;
        let path = ctx.case_dir.join("beds").join(file);
        let text = std::fs::read_to_string(&path).map_err(|e| crate::Error::File {
            path: path.display().to_string(),
            msg: e.to_string(),
        })?;
        let (cell, parts) = crate::io::xyz::parse(&text, &path.display().to_string())?;
        let r_file = parts[0].radius;
        if parts.iter().any(|p| p.radius != r_file) {
            return invalid(format!("case 840: {file}: the bed must be monodisperse"));
        }
        let s = d / (2.0 * r_file);
        let r = 0.5 * d;
        let lx = cell.lengths[0] * s;
        let dx = lx / nx as f64;
        let ny = (cell.lengths[1] * s / dx).round() as usize;
        let top = parts
            .iter()
            .map(|p| p.position.z * s + r)
            .fold(f64::MIN, f64::max);
        let nz = if cell.pbc[2] {
            (cell.lengths[2] * s / dx).round() as usize
        } else {
            (top / dx).ceil() as usize
        };
        let l = [lx, ny as f64 * dx, nz as f64 * dx];
        let pos: Vec<Vector3<f64>> = parts
            .iter()
            .map(|p| {
                let q = p.position * s;
                Vector3::new(
                    q.x.rem_euclid(l[0]),
                    q.y.rem_euclid(l[1]),
                    q.z.rem_euclid(l[2]),
                )
            })
            .collect();
        let n = pos.len();
        let eps_b = 1.0 - n as f64 * PI / 6.0 * d.powi(3) / (l[0] * l[1] * l[2]);
        let u_target = re_target * mu / (rho * d);
        let gp = ergun_gradient(eps_b, d, mu, rho, u_target);
        let p = Particles::at_rest(pos.clone(), vec![r; n], 2500.0);
        let dem = dem_setup(l, 2500.0, 0.0, rho, p, 0.1)?;
        let mut cs = coupled_setup(
            dem,
            dx,
            tau,
            mu,
            Switch::Sharp,
            Vector3::new(0.0, 0.0, gp),
            false,
            1,
            true,
        )?;
        cs.collision = collision_of(&t, i)?;
        let mut c = Coupled::new(cs)?;
        let steady = driver::run_to_steady(&mut c, 400_000, 1e-10, |c| -mean_uz(c))?;
        let u = steady.value;
        if !(steady.steady && u > 0.0) {
            return invalid(format!(
                "case 840: {file}: no steady downward flow (U = {u})"
            ));
        }
        let e_ref = ergun_gradient(eps_b, d, mu, rho, u);
        let ratio = gp / e_ref;
        // the bed's porosity field, counted independently
        let dims = [nx, ny, nz];
        let eps_c = chord_porosity(&pos, r, dims, dx, 64);
        // the quadrature's error, estimated by the halved resolution
        let amb: Vec<f64> = chord_porosity(&pos, r, dims, dx, 32)
            .iter()
            .zip(&eps_c)
            .map(|(a, b)| (a - b).abs().max(1e-6))
            .collect();
        let psi = |e: f64, w: f64| -> f64 {
            let e = e.clamp(0.1, 1.0);
            if e >= 1.0 {
                0.0
            } else {
                beta_gidaspow(e, d, mu, rho, w / e, false) * w / (e * e)
            }
        };
        let nxy = nx * ny;
        // lower: layers in series, the cells of a layer in parallel at one gradient
        let mut dp_lo = 0.0;
        for k in 0..nz {
            let layer: Vec<f64> = (0..nxy)
                .map(|j| eps_c[k * nxy + j] + amb[k * nxy + j])
                .collect();
            let flux = |g: f64| -> f64 {
                layer
                    .iter()
                    .map(|&e| increasing_root(|w| psi(e, w), g))
                    .sum::<f64>()
                    / nxy as f64
            };
            dp_lo += increasing_root(flux, u) * dx;
        }
        // upper: columns of cells in series, the columns in parallel at one gradient
        let cols: Vec<Vec<f64>> = (0..nxy)
            .map(|j| {
                (0..nz)
                    .map(|k| eps_c[k * nxy + j] - amb[k * nxy + j])
                    .collect()
            })
            .collect();
        let flux = |g: f64| -> f64 {
            cols.iter()
                .map(|col| {
                    increasing_root(
                        |w| col.iter().map(|&e| psi(e, w)).sum::<f64>() / nz as f64,
                        g,
                    )
                })
                .sum::<f64>()
                / nxy as f64
        };
        let g_hi = increasing_root(flux, u);
        let (r_lo, r_hi) = (dp_lo / l[2] / e_ref, g_hi / e_ref);
        let re = rho * u * d / mu;
        let worst_map = (0..eps_c.len())
            .filter(|&q| c.eps[q] > c.setup.eps_min)
            .map(|q| (c.eps[q] - eps_c[q]).abs() / amb[q].max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max);
        eprintln!(
            "840 {file} Re_p {re:.3} tau {tau}: eps_b {eps_b:.4}, lattice {nx}x{ny}x{nz}, U {u:.4e} m/s, \
             R {ratio:.4} in [{r_lo:.4}, {r_hi:.4}]"
        );
        let label = format!(
            "{file} eps_b={eps_b:.3} Re_p={re:.2}{}",
            match t.col("collision") {
                Ok(_) => format!(" {} tau={tau}", t.str(i, "collision")?.to_uppercase()),
                Err(_) => String::new(),
            }
        );
        rows.push(Row::new(
            format!("{label}: grad p / Ergun(eps_b, U) in [{r_lo:.3}, {r_hi:.3}]"),
            ratio,
            0.5 * (r_lo + r_hi),
            0.5 * (r_hi - r_lo),
        ));
        rows.push(Row::new(
            format!("{label}: max |eps_engine - eps_chords| / its quadrature error"),
            worst_map,
            0.0,
            1.0,
        ));
        rows.push(Row::new(
            format!("{label}: Re_p against its target {re_target}"),
            re,
            re_target,
            0.5 * re_target,
        ));
    }
    Ok(rows)
}

/// The built-in seed bed (seed 002 Fig. 12) run to its end: the porosity profile and mean
/// superficial |u_z| at every profile time, the lattice spacing and height, and the final
/// sphere heights and radii. Kept for the process, so that cases 940 and 941 share one run.
struct SeedBedRun {
    series: Vec<(f64, Vec<f64>, f64)>,
    dz: f64,
    height: f64,
    z: Vec<f64>,
    r: Vec<f64>,
    area: f64,
}

fn seed_bed_run(overlap: &str) -> Result<std::sync::Arc<SeedBedRun>> {
    use std::sync::{Arc, Mutex};
    static CACHE: Mutex<Vec<(String, Arc<SeedBedRun>)>> = Mutex::new(Vec::new());
    // held for the whole run: a case asking while the other computes waits for its result
    let mut cache = CACHE
        .lock()
        .map_err(|_| crate::Error::Validation("seed-bed cache poisoned".into()))?;
    if let Some((_, r)) = cache.iter().find(|(k, _)| k == overlap) {
        return Ok(r.clone());
    }
    let text = include_str!("../../scene/builtin/coupled-seed-bed.toml")
        .replace("overlap = \"exact\"", &format!("overlap = \"{overlap}\""));
    let scene = crate::scene::coupled::parse_scene(&text, "coupled-seed-bed")?;
    let mut c = crate::scene::coupled::build(&scene)?;
    /// The porosity profile and mean |u_z| at every profile time.
    struct Profiles {
        every: u64,
        series: Vec<(f64, Vec<f64>, f64)>,
    }
    impl Hooks<Coupled> for Profiles {
        fn progress(&mut self, c: &Coupled, _: Option<f64>, _: &str) {
            if c.steps % self.every == 0 {
                self.series
                    .push((c.time_s, c.porosity_profile(), mean_uz(c).abs()));
            }
        }
    }
    let mut profiles = Profiles {
        every: ((scene.profile_every_s / c.units.dt).round() as u64).max(1),
        series: Vec::new(),
    };
    let end = driver::steps_for(&c, scene.time_s);
    driver::run_to_step(&mut c, end, &mut profiles)?;
    let series = profiles.series;
    let run = Arc::new(SeedBedRun {
        series,
        dz: c.setup.dx_m,
        height: c.dims.nz as f64 * c.setup.dx_m,
        z: c.dem.p.pos.iter().map(|p| p.z).collect(),
        r: c.dem.p.radius.clone(),
        area: c.dem.setup().lx_m * c.dem.setup().ly_m,
    });
    cache.push((overlap.to_string(), run.clone()));
    Ok(run)
}

register!("940" => case_940);
/// Case 940 (seed 002 Fig. 12): the built-in 2014-sphere bed under a pressure drop; zones
/// on the porosity profile by thresholds fixed in the case notes, interface positions and
/// speeds, and the decay of the flow through the consolidating bed.
pub fn case_940(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let eps_free = t.f64(0, "eps_free_min")?;
    let eps_bed = t.f64(0, "eps_bed_max")?;
    let run = seed_bed_run(t.str(0, "overlap")?)?;
    let dz = run.dz;
    // (time, top of the suspension, top of the fixed bed, mean superficial |u_z|)
    let series: Vec<(f64, f64, f64, f64)> = run
        .series
        .iter()
        .map(|(time, prof, u)| {
            let h = prof.len() as f64 * dz;
            let z_s = prof
                .iter()
                .rposition(|&e| e < eps_free)
                .map_or(0.0, |k| (k + 1) as f64 * dz);
            let z_b = prof
                .iter()
                .position(|&e| e > eps_bed)
                .map_or(h, |k| k as f64 * dz);
            (*time, z_s, z_b, *u)
        })
        .collect();
    let h = run.height;
    // the times with three zones: a fixed bed, a suspension above it, free fluid above that
    let three: Vec<&(f64, f64, f64, f64)> = series
        .iter()
        .filter(|s| s.2 > 0.0 && s.1 > s.2 && s.1 < h)
        .collect();
    for s in &series {
        eprintln!(
            "940 t = {:.3} s: suspension top {:.2} mm, bed top {:.2} mm, U {:.3e} m/s",
            s.0,
            s.1 * 1e3,
            s.2 * 1e3,
            s.3
        );
    }
    let n3 = three.len();
    let mut rows = vec![Row::new(
        format!(
            "profile times with free fluid, suspension and fixed bed (of {})",
            series.len()
        ),
        n3 as f64,
        0.5 * (3.0 + series.len() as f64),
        0.5 * (series.len() as f64 - 3.0),
    )];
    if n3 < 3 {
        return Ok(rows);
    }
    // least-squares speeds with their standard errors
    let fit = |k: usize| -> (f64, f64) {
        let n = n3 as f64;
        let tm = three.iter().map(|s| s.0).sum::<f64>() / n;
        let ym = three
            .iter()
            .map(|s| if k == 1 { s.1 } else { s.2 })
            .sum::<f64>()
            / n;
        let (mut sxx, mut sxy) = (0.0, 0.0);
        for s in &three {
            let y = if k == 1 { s.1 } else { s.2 };
            sxx += (s.0 - tm).powi(2);
            sxy += (s.0 - tm) * (y - ym);
        }
        let b = sxy / sxx;
        let res: f64 = three
            .iter()
            .map(|s| {
                let y = if k == 1 { s.1 } else { s.2 };
                (y - ym - b * (s.0 - tm)).powi(2)
            })
            .sum();
        let se = (res / (n - 2.0).max(1.0) / sxx).sqrt();
        (b, se)
    };
    let (v_s, se_s) = fit(1);
    let (v_b, se_b) = fit(2);
    eprintln!(
        "940: {n3} times with three zones, from {:.3} s to {:.3} s; suspension top {:.3e} +- {:.1e} \
         m/s, bed top {:.3e} +- {:.1e} m/s",
        three[0].0,
        three[n3 - 1].0,
        v_s,
        se_s,
        v_b,
        se_b
    );
    let z = (v_b - v_s) / (se_s * se_s + se_b * se_b).sqrt().max(f64::MIN_POSITIVE);
    let z_min = t.f64(0, "speed_z_min")?;
    // one-sided checks as bands: [z_min, z_min + 1000], speeds of either sign up to 1 m/s
    rows.push(Row::new(
        format!(
            "interfaces at different speeds: (v_bed - v_susp) / SE (v_susp {:.3} mm/s, v_bed {:.3} mm/s)",
            v_s * 1e3,
            v_b * 1e3
        ),
        z,
        z_min + 500.0,
        500.0,
    ));
    rows.push(Row::new(
        "top of the suspension moves down (mm/s)",
        v_s * 1e3,
        -500.0,
        500.0,
    ));
    rows.push(Row::new(
        "top of the fixed bed moves up (mm/s)",
        v_b * 1e3,
        500.0,
        500.0,
    ));
    let peak = series.iter().map(|s| s.3).fold(0.0, f64::max);
    let last = series.last().map_or(0.0, |s| s.3);
    let most = t.f64(0, "flow_end_over_peak_max")?;
    rows.push(Row::new(
        "superficial flow at the end over its peak",
        last / peak,
        0.5 * most,
        0.5 * most,
    ));
    Ok(rows)
}

register!("941" => case_941);
/// Case 941: the bottom of the coupled seed bed (case 940's run) against the uniform-drag DEM
/// packing of the same spheres (built-in dem-seed-drag): porosity of a bottom window.
pub fn case_941(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let run = seed_bed_run(t.str(0, "overlap")?)?;
    let d = 2.0 * run.r[0];
    let (a, b) = (
        t.f64(0, "window_lo_over_d")? * d,
        t.f64(0, "window_hi_over_d")? * d,
    );
    let margin = t.f64(0, "margin")?;
    let coupled = crate::dem::observe::slab_porosity(&run.z, &run.r, run.area, a, b);
    let scene = crate::scene::dem::parse_scene(
        include_str!("../../scene/builtin/dem-seed-drag.toml"),
        "dem-seed-drag",
    )?;
    let mut dem = crate::scene::dem::build(&scene)?;
    let stop = crate::dem::settle(&mut dem, &scene.rule)?.reason(&scene.rule);
    let z: Vec<f64> = dem.p.pos.iter().map(|p| p.z).collect();
    let area = scene.setup.lx_m * scene.setup.ly_m;
    let drag = crate::dem::observe::slab_porosity(&z, &dem.p.radius, area, a, b);
    eprintln!(
        "941: porosity of z in [{a:.2e}, {b:.2e}] m: coupled {coupled:.4}, uniform drag {drag:.4} \
         (DEM stop: {stop})"
    );
    Ok(vec![Row::new(
        format!(
            "bottom porosity, coupled {coupled:.4} minus uniform drag {drag:.4}, at least {margin}"
        ),
        coupled - drag,
        margin + 0.5,
        0.5,
    )])
}
