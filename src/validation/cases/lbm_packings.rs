//! Cases 920-922 (thesis 003 ch. 7): the permeability of porelab's own random packings (MCM,
//! periodic box) by the pore-resolving lattice Boltzmann solver ([`crate::lbm::pore`]), read
//! as the Kozeny constant of eq. 7.4, k = (1 - phi)^3 nu^2 / (C_KC phi^2).
//!
//! * 920 (slow): spheres at packing fractions along one MCM run (the jamming schedule stopped
//!   at the first accepted step past each target, and its jammed end): C_KC with nu = V/S = D/6
//!   against Carman's 5 (the "180" of the sphere form).
//! * 921 and 922 (slow): spherocylinders at their random-packing densities (L/D 1-5 and the
//!   long rods 10-20): C_KC with the exact nu = V/S and with the long-rod nu = D/4 (thesis
//!   sec. 7.2.2), against L/D.

use crate::driver::{Hooks, NoHooks};
use crate::error::invalid;
use crate::io::xyz::{Cell, XyzParticle};
use crate::lbm::pore::{kozeny_constant, pore_permeability, PoreOptions};
use crate::lbm::voxels::voxelise;
use crate::lbm::{CollisionKind, CollisionModel, LatticeKind, SteadyControl, Tau};
use crate::packing::{self, Mcm, Packing, Setup};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};

fn seed(ctx: &CaseContext) -> Result<u64> {
    ctx.seed
        .ok_or_else(|| Error::Validation(format!("case {}: needs `seed` in case.toml", ctx.id)))
}

/// The pore-resolving run of these cases at relaxation time `tau` (1 unless a row sets it):
/// D3Q19 TRT (Lambda = 3/16: k independent of the viscosity, case 808), body force 1e-5 (Re on
/// V/S below 1e-3 at these k), steady to 1e-7 per 100 steps.
fn pore(tau: f64) -> Result<PoreOptions> {
    let ctl = SteadyControl {
        check_every: 100,
        tol: 1e-7,
        max_steps: 200_000,
    };
    let trt = CollisionModel::new(CollisionKind::Trt, Tau::new(tau)?);
    PoreOptions::new(LatticeKind::D3Q19, trt, (1e-5, "force"), ctl)
}

/// The particles of an MCM packing of equal spheres or spherocylinders (diameter 1, the
/// packing's length unit) in its periodic box, ready for [`voxelise`].
fn packing_particles(p: &Packing) -> Result<(Cell, Vec<XyzParticle>)> {
    let Some(length) = p.monodisperse_length() else {
        return invalid(
            "packing: only equal spheres or spherocylinders of diameter 1 are voxelised here",
        );
    };
    if p.container != packing::Container::Periodic {
        return invalid("packing: permeability needs the periodic box container");
    }
    let (species, shape) = if length > 0.0 {
        ("spherocylinder", [0.5, 0.5, length])
    } else {
        ("sphere", [0.5; 3])
    };
    let parts = (0..p.n())
        .map(|i| XyzParticle {
            species: species.to_string(),
            position: p.positions[i],
            orientation: p.orientations[i],
            aspherical_shape: shape,
            radius: 0.5,
            cylinder_length: length,
            roundness: [1.0, 1.0],
        })
        .collect();
    Ok((Cell::cubic(p.box_length), parts))
}

/// Configurations of one MCM run: the first accepted state at or past each of `targets`
/// (ascending packing fractions), then the final (jammed) state.
fn packings_along(prm: &Setup, targets: &[f64]) -> Result<Vec<Packing>> {
    /// Keeps the configuration after the step that first reaches each target.
    struct Along<'a> {
        next: std::iter::Peekable<std::slice::Iter<'a, f64>>,
        out: Vec<Packing>,
    }
    impl Hooks<Mcm> for Along<'_> {
        fn progress(&mut self, mcm: &Mcm, _: Option<f64>, _: &str) {
            let p = &mcm.state().packing;
            let phi = p.packing_fraction();
            while self.next.peek().is_some_and(|&&t| phi >= t) {
                self.next.next();
                self.out.push(p.clone());
            }
        }
    }
    let mut mcm = Mcm::new(prm.clone())?;
    let mut along = Along {
        next: targets.iter().peekable(),
        out: Vec::new(),
    };
    packing::driver::run(&mut mcm, &mut along)?;
    along.out.push(mcm.state().packing.clone());
    Ok(along.out)
}

/// One packing's permeability at two resolutions (cells per diameter).
struct KcPoint {
    phi: f64,
    v_over_s: f64,
    /// k / D^2 at the coarse and the fine lattice.
    k: [f64; 2],
    /// Voxel solid fraction at the fine lattice.
    phi_voxels: f64,
    re: f64,
}

fn kc_point(p: &Packing, cells_per_d: [f64; 2], opts: &PoreOptions) -> Result<KcPoint> {
    let (cell, parts) = packing_particles(p)?;
    let mut k = [0.0; 2];
    let (mut phi_voxels, mut re, mut v_over_s) = (0.0, 0.0, 0.0);
    for (j, &c) in cells_per_d.iter().enumerate() {
        let n = (c * p.box_length).round() as usize;
        let v = voxelise(&cell, &parts, n)?;
        let r = pore_permeability(&v, opts, &mut NoHooks)?;
        if !r.run.converged {
            return Err(Error::Validation(format!(
                "phi = {:.4}, n = {n}: not steady after {} steps (residual {:e})",
                p.packing_fraction(),
                r.run.steps,
                r.run.residual
            )));
        }
        k[j] = r.k;
        phi_voxels = 1.0 - r.porosity;
        re = r.re;
        v_over_s = v.v_over_s.unwrap_or(f64::NAN);
    }
    Ok(KcPoint {
        phi: p.packing_fraction(),
        v_over_s,
        k,
        phi_voxels,
        re,
    })
}

/// Rows of one point: C_KC at the fine lattice against `want` (scale `want`) for each named
/// length nu, and the relative change of C_KC from the coarse to the fine lattice against 0
/// (scale 1; the same for every nu, C_KC being proportional to 1/k).
fn kc_rows(label: &str, pt: &KcPoint, nus: &[(&str, f64)], want: f64, ctx_id: &str) -> Vec<Row> {
    let change = pt.k[0] / pt.k[1] - 1.0;
    eprintln!(
        "{ctx_id} {label}: phi {:.4} (voxels {:.4}), V/S {:.4}: k/D^2 {:.4e} -> {:.4e} \
         ({:+.2} % in C_KC), Re {:.1e}",
        pt.phi,
        pt.phi_voxels,
        pt.v_over_s,
        pt.k[0],
        pt.k[1],
        100.0 * change,
        pt.re
    );
    let mut rows = Vec::new();
    for &(name, nu) in nus {
        let c = pt.k.map(|k| kozeny_constant(k, pt.phi, nu));
        eprintln!(
            "{ctx_id} {label}: C_KC (nu = {name} = {nu:.4}) {:.3} -> {:.3}",
            c[0], c[1]
        );
        rows.push(Row::new(
            format!("{label} C_KC nu={name}"),
            c[1],
            want,
            want,
        ));
    }
    rows.push(Row::new(
        format!("{label} C_KC change coarse->fine"),
        change,
        0.0,
        1.0,
    ));
    rows
}

register!("920" => case_920);
/// Case 920: spheres; expected.csv `target_phi,cells_coarse,cells_fine,c_kc` (one row per
/// target; a target of 1 stands for the jammed end of the run).
pub fn case_920(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let targets: Vec<f64> = t.f64_col("target_phi")?;
    let n = t.f64(0, "particles")? as usize;
    let prm = Setup::jammed_spheres(n, seed(ctx)?);
    let below_one: Vec<f64> = targets.iter().cloned().filter(|&x| x < 1.0).collect();
    let packs = packings_along(&prm, &below_one)?;
    let mut rows = Vec::new();
    for (i, &target) in targets.iter().enumerate() {
        let p = if target < 1.0 {
            packs.get(i).ok_or_else(|| {
                Error::Validation(format!(
                    "the MCM run jammed before phi = {target} (final phi {:.4})",
                    packs.last().map_or(f64::NAN, |p| p.packing_fraction())
                ))
            })?
        } else {
            packs.last().expect("the final state is always there")
        };
        let cells = [t.f64(i, "cells_coarse")?, t.f64(i, "cells_fine")?];
        let pt = kc_point(p, cells, &pore(1.0)?)?;
        let label = format!("spheres N={n} phi={:.3} D={}", pt.phi, cells[1]);
        // nu = V/S = D/6 for spheres
        let nus = [("V/S", pt.v_over_s)];
        rows.extend(kc_rows(&label, &pt, &nus, t.f64(i, "c_kc")?, &ctx.id));
    }
    Ok(rows)
}

register!("921", "922" => case_921_922);
/// Cases 921 and 922: spherocylinders; expected.csv `length_over_diameter,particles,tau,
/// cells_coarse,cells_fine,c_kc`, one MCM run per row (the jamming schedule with the rod length
/// set, as case 514), its jammed end: C_KC with nu = V/S and with the long-rod nu = D/4.
pub fn case_921_922(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let s = seed(ctx)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let aspect = t.f64(i, "length_over_diameter")?;
        let n = t.f64(i, "particles")? as usize;
        let mut prm = Setup::jammed_spheres(n, s);
        prm.length = aspect;
        let r = packing::run_to_end(prm)?;
        let cells = [t.f64(i, "cells_coarse")?, t.f64(i, "cells_fine")?];
        let pt = kc_point(&r.packing, cells, &pore(t.f64(i, "tau")?)?)?;
        // thesis eq. 7.2 with <C> = 9.8: the random-contact phi of long rods, for comparison
        eprintln!(
            "{} L/D={aspect}: MCM phi {:.4}, random contact equation (eq. 7.2) 4.9 D/L = {:.3}",
            ctx.id,
            pt.phi,
            4.9 / aspect
        );
        let label = format!("rods L/D={aspect} N={n} phi={:.3} D={}", pt.phi, cells[1]);
        let nus = [("V/S", pt.v_over_s), ("D/4", 0.25)];
        rows.extend(kc_rows(&label, &pt, &nus, t.f64(i, "c_kc")?, &ctx.id));
    }
    Ok(rows)
}
