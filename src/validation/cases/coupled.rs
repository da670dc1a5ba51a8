//! Cases 811-814: the two-way coupled LBM–DEM of seed 002 ("Two-way coupling algorithm").
//! Expected values are closed forms written out here (Ergun 1952, Wen & Yu 1966 as combined by
//! Gidaspow 1994, Stokes 1851), never values of the code under test.

use super::common::non_empty;
use crate::coupled::{Basesheet, Coupled, CoupledSetup, Overlap, Switch};
use crate::dem::{
    ContactModel, DampingModel, Dem, DemSetup, Material, NormalModel, Particles, TangentialModel,
    TopWall,
};
use crate::error::invalid;
use crate::validation::{CaseContext, Row};
use crate::Result;
use nalgebra::Vector3;
use rand::SeedableRng;
use std::f64::consts::PI;

fn dem_setup(l: [f64; 3], rho_p: f64, g: f64, rho_f: f64) -> Result<DemSetup> {
    let mat = Material::new(1e7, 0.3)?;
    Ok(DemSetup {
        lx_m: l[0],
        ly_m: l[1],
        contact: ContactModel {
            normal: NormalModel::Hertz,
            damping: DampingModel::restitution(0.5)?,
            tangential: TangentialModel::Mindlin {
                mu: 0.3,
                damp_ratio: 1.0,
            },
        },
        particle_material: mat,
        wall_material: mat,
        density_kg_m3: rho_p,
        gravity_m_s2: Vector3::new(0.0, 0.0, -g),
        fluid_density_kg_m3: rho_f,
        drag: None,
        top: TopWall::Fixed { z_m: l[2] },
        dt_s: None,
        skin_m: None,
    })
}

#[allow(clippy::too_many_arguments)]
fn coupled_setup(
    dx: f64,
    tau: f64,
    mu: f64,
    nz: usize,
    switch: Switch,
    grad_p: Vector3<f64>,
    balance: bool,
    m: u64,
    frozen: bool,
) -> CoupledSetup {
    CoupledSetup {
        dx_m: dx,
        tau,
        fluid_density_kg_m3: 1000.0,
        viscosity_pa_s: mu,
        nz,
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
    }
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

/// Case 811: phase momentum balance and fluid mass, every coupling step, for a settling
/// suspension with contacts (no wall contact).
pub fn case_811(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
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
        let setup = dem_setup(l, 2500.0, 9.81, 1000.0)?;
        let dem = Dem::new(setup, Particles::at_rest(pos, radius, 2500.0), 0.1)?;
        let grad = Vector3::new(t.f64(i, "grad_p_x_pa_m")?, 0.0, 0.0);
        let cs = coupled_setup(
            dx,
            t.f64(i, "tau")?,
            t.f64(i, "viscosity_pa_s")?,
            cells[2] as usize,
            Switch::Blend,
            grad,
            true,
            t.f64(i, "dem_steps")? as u64,
            false,
        );
        let mut c = Coupled::new(dem, cs)?;
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

/// Case 812: fixed bed of uniform porosity (one frozen sphere centred in each cell) under a
/// pressure gradient: the steady superficial velocity U satisfies grad p = beta(U) U / eps^2
/// (Ergun 150/1.75 below eps = 0.8 with the sharp switch; Gidaspow's blend otherwise), and the
/// bed carries the whole pressure drop.
pub fn case_812(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
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
        let setup = dem_setup(l, 2500.0, 0.0, 1000.0)?;
        let dem = Dem::new(setup, Particles::at_rest(pos, radius, 2500.0), 0.1)?;
        let cs = coupled_setup(
            dx,
            t.f64(i, "tau")?,
            mu,
            n,
            if blend { Switch::Blend } else { Switch::Sharp },
            Vector3::new(0.0, 0.0, gp),
            false,
            1,
            true,
        );
        let mut c = Coupled::new(dem, cs)?;
        let mut u_prev = f64::INFINITY;
        let mut u = 0.0;
        for _ in 0..200_000 {
            c.step()?;
            let v = c.velocity_si();
            u = v.iter().map(|w| w[2]).sum::<f64>() / v.len() as f64;
            if (u - u_prev).abs() <= 1e-15 * u.abs() {
                break;
            }
            u_prev = u;
        }
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
        if u_prev.is_infinite() || !u.is_finite() {
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
    let setup = dem_setup(l, 2500.0, 9.81, 1000.0)?;
    let dem = Dem::new(setup, Particles::at_rest(pos, vec![0.5 * d], 2500.0), 0.1)?;
    let cs = coupled_setup(
        dx,
        tau,
        mu,
        cells,
        Switch::Sharp,
        Vector3::zeros(),
        true,
        m,
        false,
    );
    let mut c = Coupled::new(dem, cs)?;
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

/// Case 813: a single sphere settling at low Re: its slip against the local fluid equals the
/// single-particle limit of Wen & Yu (Stokes, corrected by the cell porosity eps^-2.65 and by
/// C_d Re / 24 = 1 + 0.15 Re^0.687), under the weight m' g (1 - V / V_box) left after the
/// balancing pressure gradient.
pub fn case_813(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
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

/// Case 814: the settling sphere's terminal velocity does not depend on the number M of DEM
/// steps per LBM step (the seed's remark), M = 100, 300, 1000.
pub fn case_814(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
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

/// Case 815: the momentum ledger with the walls in it: particles of the coupled-quick built-in
/// settle onto the floor (and slide on it under a cross flow), or are held as a frozen bed;
/// every coupling step balances fluid + particle momentum against the external, wall and
/// constraint impulses.
pub fn case_815(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
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
/// each centre moved by a uniform random offset of up to 0.45 of that gap in each axis.
fn jittered_lattice(
    n_target: f64,
    d: f64,
    l: [f64; 3],
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<Vec<Vector3<f64>>> {
    use rand::Rng;
    let mut best: Option<([f64; 3], f64)> = None;
    for kx in 1..=(l[0] / d) as usize {
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

/// Case 816: hindered settling of a homogeneous suspension (the whole box filled) against
/// Richardson & Zaki: the effective exponent n = ln(U / U_t) / ln(eps) of the settling
/// velocity U relative to the zero-volume-flux frame over the isolated sphere's terminal
/// velocity U_t, against the cited low-Re band of n.
pub fn case_816(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
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
        // random sequential addition below its jamming (~0.38), a jittered lattice above
        let pos = if phi_target <= 0.3 {
            let radius = vec![0.5 * d; n_target.round() as usize];
            crate::dem::start::random_dispersion(&radius, l[0], l[1], l[2], &mut rng)?
        } else {
            jittered_lattice(n_target, d, l, &mut rng)?
        };
        let n = pos.len();
        let mut setup = dem_setup(l, rho_p, 9.81, 1000.0)?;
        setup.contact.tangential = crate::dem::TangentialModel::None;
        let dem = Dem::new(
            setup,
            Particles::at_rest(pos, vec![0.5 * d; n], rho_p),
            0.01,
        )?;
        let mut cs = coupled_setup(
            dx,
            t.f64(i, "tau")?,
            mu,
            cells[2] as usize,
            Switch::Blend,
            Vector3::zeros(),
            true,
            t.f64(i, "dem_steps")? as u64,
            false,
        );
        cs.max_move_cells = t.f64(i, "max_move_cells")?;
        let mut c = Coupled::new(dem, cs)?;
        // the middle half of the height, away from both walls
        let (z0, z1) = (0.25 * l[2], 0.75 * l[2]);
        let nxy = (cells[0] * cells[1]) as usize;
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
             = {:.4}, n = {:.3}; eps^4.65 = {:.4}; Re_t = {:.3e}; {:.1} s",
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

/// Case 817: the basesheet alone (no particles) under a mean pressure gradient in a periodic
/// column: the pressure drop across it from the fluid's own pressure field equals Darcy's
/// mu U h / K, and U equals the closed form of the column, grad p L K / (mu h).
pub fn case_817(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    non_empty(&t)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let dx = t.f64(i, "dx_m")?;
        let mu = t.f64(i, "viscosity_pa_s")?;
        let k = t.f64(i, "permeability_m2")?;
        let gp = t.f64(i, "grad_p_pa_m")?;
        let ns = t.f64(i, "sheet_cells")? as usize;
        let nc = t.f64(i, "clear_cells")? as usize;
        let l = [2.0 * dx, 2.0 * dx, nc as f64 * dx];
        let mut setup = dem_setup(l, 2500.0, 0.0, 1000.0)?;
        // no particles: the neighbour skin is given (its default scales with a diameter)
        setup.skin_m = Some(0.1 * dx);
        let dem = Dem::new(setup, Particles::at_rest(vec![], vec![], 2500.0), 0.1)?;
        let mut cs = coupled_setup(
            dx,
            t.f64(i, "tau")?,
            mu,
            nc,
            Switch::Blend,
            Vector3::new(0.0, 0.0, gp),
            false,
            1,
            true,
        );
        let h = ns as f64 * dx;
        cs.basesheet = Some(Basesheet {
            thickness_m: h,
            permeability_m2: k,
        });
        let mut c = Coupled::new(dem, cs)?;
        let nxy = 4;
        let nz = ns + nc;
        let flux = |c: &Coupled| -> f64 {
            // mass-flux velocity through the sheet (m/s): sum rho u / (rho_0 cells)
            let s: f64 = (0..ns * nxy)
                .map(|cell| c.record.rho[cell] * c.record.u[cell][2])
                .sum();
            s / (ns * nxy) as f64 * dx / c.units.dt
        };
        let (mut u, mut u_prev, mut steps) = (0.0, f64::INFINITY, 0);
        let mut worst_balance: f64 = 0.0;
        while steps < 200_000 {
            let b = c.step()?;
            worst_balance = worst_balance.max(b.relative_error());
            steps += 1;
            u = flux(&c);
            if (u - u_prev).abs() <= 1e-15 * u.abs() {
                break;
            }
            u_prev = u;
        }
        if !u.is_finite() || (u - u_prev).abs() > 1e-15 * u.abs() {
            return invalid(format!(
                "case 817 row {i}: no steady state in {steps} steps"
            ));
        }
        // real pressure = LBM deviation + the imposed mean gradient, in the plug flow of the
        // clear fluid m layers above the sheet (centre (ns + m + 1/2) dx) and m layers below
        // it through the periodic boundary (centre -(m + 1/2) dx); m = 0: the layers touching
        // the sheet, m = nc/2 - 1: the middle of the clear fluid (the row)
        let p = c.pressure_si();
        let layer = |kz: usize| p[kz * nxy..(kz + 1) * nxy].iter().sum::<f64>() / nxy as f64;
        let drop_at =
            |m: usize| layer(ns + m) - layer(nz - 1 - m) + gp * (ns + 2 * m + 1) as f64 * dx;
        let drop = drop_at(nc / 2 - 1);
        let darcy = mu * u.abs() * h / k;
        let column = gp * nz as f64 * dx * k / (mu * h);
        eprintln!(
            "case 817 row {i}: drop / Darcy - 1 at m = 0..{}: {:?}",
            nc / 2 - 1,
            (0..nc / 2)
                .map(|m| format!("{:.2e}", drop_at(m) / darcy - 1.0))
                .collect::<Vec<_>>()
        );
        let label = format!(
            "K={k:e} m^2 h={ns}dx grad_p={gp} Pa/m (K/dx^2={:.2e}, U={:.3e} m/s, {steps} steps)",
            k / (dx * dx),
            u.abs()
        );
        rows.push(Row::new(
            format!("{label}: drop across the sheet (Pa) vs mu U h / K"),
            drop,
            darcy,
            darcy,
        ));
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
