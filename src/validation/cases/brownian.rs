//! Brownian-dynamics validation cases 401-408 (thesis 003, chapter 6 and eq. 7.5-7.7):
//!
//! * 401 Stokes-Einstein MSD of free diffusion: chi-square with 3N degrees of freedom;
//! * 402 drift under a constant force at T > 0 (z-test of the mean displacement);
//! * 403 RPY / Oseen / free-draining two-sphere mobilities, symmetry, positive definiteness;
//! * 404 sample covariance of the Cholesky noise against 2 D dt;
//! * 405 Mie repulsion closed forms; dipole and field-gradient forces against complex-step
//!   derivatives of the energies (implemented here, independently of the code under test);
//! * 406 Langevin function and magnetization law (mpmath values, eq. 7.7 slope, saturation);
//! * 407 TEA-HI closed forms (diagonal and equal-off-diagonal mobilities reproduced exactly);
//! * 408 drift at T = 0 (exact, free-draining and hydrodynamic pairs).

use super::common::no_rows;
use crate::brownian::driver::run_steps;
use crate::brownian::forces::{FieldFn, WithUniform};
use crate::brownian::{
    dipole_energy, dipole_force, langevin, mobility_matrix, run_rng, standard_normal, Fluid,
    Hydrodynamics, LangevinMoment, Magnetic, Mie, NoiseGenerator, NoiseMethod, Particles, Setup,
    Simulation,
};
use crate::consts::{KB, MU0};
use crate::driver::NoHooks;
use crate::validation::{CaseContext, Row, Table};
use crate::{Error, Result};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rand::Rng;
use rayon::prelude::*;
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};
use std::f64::consts::PI;

fn seed(ctx: &CaseContext) -> Result<u64> {
    ctx.seed
        .ok_or_else(|| Error::Validation(format!("case {}: case.toml needs a seed", ctx.id)))
}

fn verr(e: impl std::fmt::Display) -> Error {
    Error::Validation(e.to_string())
}

/// z = Phi^-1(F(S)) for a chi-square statistic with `dof` degrees of freedom, using the upper
/// tail above the median so that no precision is lost for large S.
fn chi2_z(s: f64, dof: f64) -> Result<f64> {
    let chi = ChiSquared::new(dof).map_err(verr)?;
    let nrm = Normal::new(0.0, 1.0).map_err(verr)?;
    let p = chi.cdf(s);
    Ok(if p < 0.5 {
        nrm.inverse_cdf(p)
    } else {
        -nrm.inverse_cdf(chi.sf(s))
    })
}

/// N particles on a cubic lattice of spacing 4a (no overlaps; free diffusion ignores them).
fn lattice(n: usize, a: f64) -> Vec<Vector3<f64>> {
    crate::brownian::cubic_lattice(n, 4.0 * a)
}

fn hydro(t: &Table, i: usize) -> Result<Hydrodynamics> {
    match t.str(i, "hydrodynamics")? {
        "free" => Ok(Hydrodynamics::FreeDraining),
        "rpy" => Ok(Hydrodynamics::Rpy),
        "oseen" => Ok(Hydrodynamics::Oseen),
        o => Err(Error::Validation(format!(
            "{} line {}: unknown hydrodynamics '{o}'",
            t.path().display(),
            t.line(i)
        ))),
    }
}

fn usize_col(t: &Table, i: usize, name: &str) -> Result<usize> {
    let v = t.f64(i, name)?;
    if !(v >= 0.0 && v.fract() == 0.0) {
        return Err(Error::Validation(format!(
            "{} line {}: {name} = {v} must be a non-negative integer",
            t.path().display(),
            t.line(i)
        )));
    }
    Ok(v as usize)
}

struct RunSpec {
    label: String,
    n: usize,
    a: f64,
    temp: f64,
    eta: f64,
    dt: f64,
    steps: u64,
    run: u64,
    force: Vector3<f64>,
}

fn run_specs(t: &Table, with_force: bool) -> Result<Vec<RunSpec>> {
    let mut v = Vec::new();
    for i in 0..t.len() {
        v.push(RunSpec {
            label: t.str(i, "label")?.to_string(),
            n: usize_col(t, i, "n_particles")?,
            a: t.f64(i, "radius_m")?,
            temp: t.f64(i, "temperature_K")?,
            eta: t.f64(i, "viscosity_Pa_s")?,
            dt: t.f64(i, "dt_s")?,
            steps: usize_col(t, i, "steps")? as u64,
            run: usize_col(t, i, "run")? as u64,
            force: if with_force {
                Vector3::new(t.f64(i, "Fx_N")?, t.f64(i, "Fy_N")?, t.f64(i, "Fz_N")?)
            } else {
                Vector3::zeros()
            },
        });
    }
    if v.is_empty() {
        return Err(no_rows(t));
    }
    Ok(v)
}

/// Runs one free-draining simulation; returns the displacements.
fn displacements(spec: &RunSpec, seed: u64) -> Result<Vec<Vector3<f64>>> {
    let p0 = lattice(spec.n, spec.a);
    let mut setup = Setup::new(
        Particles::new(p0.clone(), spec.a)?,
        Fluid::new(spec.temp, spec.eta)?,
        spec.dt,
    )?;
    setup.constant_force = spec.force;
    let mut sim = Simulation::new(setup, run_rng(seed, spec.run))?;
    run_steps(&mut sim, spec.steps, &mut NoHooks)?;
    Ok(sim
        .particles()
        .positions
        .iter()
        .zip(&p0)
        .map(|(p, q)| p - q)
        .collect())
}

/// Runs the rows in parallel and the first one again serially: the results must be bitwise
/// identical (one random stream per run, independent of threads).
fn all_displacements(specs: &[RunSpec], seed: u64) -> Result<Vec<Vec<Vector3<f64>>>> {
    let par: Vec<Vec<Vector3<f64>>> = specs
        .par_iter()
        .map(|s| displacements(s, seed))
        .collect::<Result<_>>()?;
    let again = displacements(&specs[0], seed)?;
    if again != par[0] {
        return Err(Error::Validation(format!(
            "{}: the serial rerun differs from the parallel run (results depend on threads)",
            specs[0].label
        )));
    }
    Ok(par)
}

register!("401" => case_401);
/// Case 401: S = sum |dr|^2 / (2 D t), D = kB T / (6 pi eta a), is chi-square(3N); the row is
/// z = Phi^-1(F(S)) (expected 0), with the acceptance |z| <= z of case.toml.
pub fn case_401(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let specs = run_specs(&t, false)?;
    let seed = seed(ctx)?;
    let disp = all_displacements(&specs, seed)?;
    let mut rows = Vec::new();
    for (i, (s, d)) in specs.iter().zip(&disp).enumerate() {
        let dcoef = KB * s.temp / (6.0 * PI * s.eta * s.a);
        let time = s.steps as f64 * s.dt;
        let stat: f64 = d.iter().map(|v| v.norm_squared()).sum::<f64>() / (2.0 * dcoef * time);
        let dof = 3.0 * s.n as f64;
        let z = chi2_z(stat, dof)?;
        rows.push(Row::new(
            format!("{} (S = {stat:.2}, 3N = {dof})", s.label),
            z,
            t.f64(i, "expected_z")?,
            1.0,
        ));
    }
    Ok(rows)
}

register!("402" => case_402);
/// Case 402: per component, z = sum_i (dx_ic - F_c t / (6 pi eta a)) / sqrt(N 2 D t).
pub fn case_402(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let specs = run_specs(&t, true)?;
    let seed = seed(ctx)?;
    let disp = all_displacements(&specs, seed)?;
    let mut rows = Vec::new();
    for (i, (s, d)) in specs.iter().zip(&disp).enumerate() {
        let mu = 1.0 / (6.0 * PI * s.eta * s.a);
        let dcoef = KB * s.temp * mu;
        let time = s.steps as f64 * s.dt;
        for (c, name) in ["x", "y", "z"].iter().enumerate() {
            let drift = mu * s.force[c] * time;
            let sum: f64 = d.iter().map(|v| v[c] - drift).sum();
            let z = sum / (s.n as f64 * 2.0 * dcoef * time).sqrt();
            rows.push(Row::new(
                format!("{} {name} (drift {drift:.3e} m)", s.label),
                z,
                t.f64(i, "expected_z")?,
                1.0,
            ));
        }
    }
    Ok(rows)
}

register!("403" => case_403);
/// Case 403: two-sphere mobilities from the table; symmetry and positive definiteness of the
/// RPY matrix over random dense configurations (checked here, rows with expected 0).
pub fn case_403(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let eta = 1.0e-3;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let kind = match t.str(i, "kind")? {
            "rpy" => Hydrodynamics::Rpy,
            "oseen" => Hydrodynamics::Oseen,
            "free" => Hydrodynamics::FreeDraining,
            o => return Err(Error::Validation(format!("unknown kind '{o}'"))),
        };
        let a = t.f64(i, "radius_m")?;
        let r = t.f64(i, "r_over_a")? * a;
        let sign = match t.str(i, "motion")? {
            "together" => 1.0,
            "apart" => -1.0,
            o => return Err(Error::Validation(format!("unknown motion '{o}'"))),
        };
        let c = match t.str(i, "direction")? {
            "along" => 0,
            "across" => 1,
            o => return Err(Error::Validation(format!("unknown direction '{o}'"))),
        };
        let m = mobility_matrix(kind, &[Vector3::zeros(), Vector3::new(r, 0.0, 0.0)], a, eta)?;
        let f = 1e-14;
        let mut fv = DVector::zeros(6);
        fv[c] = f;
        fv[3 + c] = sign * f;
        let v = m * fv;
        let mu0 = 1.0 / (6.0 * PI * eta * a);
        rows.push(Row::new(
            t.str(i, "label")?,
            v[c] / (mu0 * f),
            t.f64(i, "expected_factor")?,
            1.0,
        ));
    }
    // Random dense configurations: N = 30 spheres uniform in a cube at nominal volume
    // fraction 0.5 (overlaps allowed: the r < 2a branch is exercised).
    let mut rng = run_rng(seed(ctx)?, 0);
    let a: f64 = 1e-7;
    let n = 30;
    let side = (n as f64 * 4.0 / 3.0 * PI * a.powi(3) / 0.5).cbrt();
    let mu0 = 1.0 / (6.0 * PI * eta * a);
    for k in 0..20 {
        let pos: Vec<Vector3<f64>> = (0..n)
            .map(|_| Vector3::new(rng.gen::<f64>(), rng.gen::<f64>(), rng.gen::<f64>()) * side)
            .collect();
        let m = mobility_matrix(Hydrodynamics::Rpy, &pos, a, eta)?;
        let asym = (&m - m.transpose()).abs().max() / mu0;
        rows.push(Row::new(
            format!("config {k}: max |M - M^T| / mu0"),
            asym,
            0.0,
            1.0,
        ));
        let lmin = m.symmetric_eigenvalues().min() / mu0;
        rows.push(Row::new(
            format!("config {k}: positive definite (lambda_min/mu0 = {lmin:.4e})"),
            if lmin > 0.0 { 0.0 } else { lmin },
            0.0,
            1.0,
        ));
    }
    Ok(rows)
}

fn config_positions(n: usize, spacing: f64) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|k| Vector3::new(k as f64, 0.6 * (k % 2) as f64, 0.35 * (k / 2) as f64) * spacing)
        .collect()
}

register!("404" => case_404);
/// Case 404: z-scores of the sample covariance entries of the Cholesky noise.
pub fn case_404(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = seed(ctx)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let kind = hydro(&t, i)?;
        let n = usize_col(&t, i, "n_particles")?;
        let a = t.f64(i, "radius_m")?;
        let pos = config_positions(n, t.f64(i, "spacing_over_a")? * a);
        let fluid = Fluid::new(t.f64(i, "temperature_K")?, t.f64(i, "viscosity_Pa_s")?)?;
        let dt = t.f64(i, "dt_s")?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::Validation(format!("dt_s = {dt}: must be positive")));
        }
        let samples = usize_col(&t, i, "samples")?;
        let m = mobility_matrix(kind, &pos, a, fluid.viscosity_pa_s())?;
        let gen = NoiseGenerator::new(NoiseMethod::Cholesky, &m)?;
        let amp = (2.0 * fluid.kt() * dt).sqrt();
        let sigma = &m * (2.0 * fluid.kt() * dt);
        let dim = 3 * n;
        let mut acc = DMatrix::<f64>::zeros(dim, dim);
        let mut rng = run_rng(seed, usize_col(&t, i, "run")? as u64);
        for _ in 0..samples {
            let g = DVector::from_fn(dim, |_, _| standard_normal(&mut rng));
            let x = gen.apply(&g, amp);
            acc.ger(1.0, &x, &x, 1.0);
        }
        let label = t.str(i, "label")?;
        let ns = samples as f64;
        for k in 0..dim {
            for l in k..dim {
                let s = acc[(k, l)] / ns;
                let var = (sigma[(k, k)] * sigma[(l, l)] + sigma[(k, l)].powi(2)) / ns;
                rows.push(Row::new(
                    format!("{label} entry ({k},{l})"),
                    (s - sigma[(k, l)]) / var.sqrt(),
                    t.f64(i, "expected_z")?,
                    1.0,
                ));
            }
        }
    }
    Ok(rows)
}

/// Minimal complex numbers for complex-step differentiation (f'(x) = Im f(x + i h) / h).
#[derive(Clone, Copy, Debug)]
struct C {
    re: f64,
    im: f64,
}

impl C {
    fn new(re: f64, im: f64) -> C {
        C { re, im }
    }
    fn add(self, o: C) -> C {
        C::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: C) -> C {
        C::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: C) -> C {
        C::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn scale(self, s: f64) -> C {
        C::new(self.re * s, self.im * s)
    }
    fn inv(self) -> C {
        let d = self.re * self.re + self.im * self.im;
        C::new(self.re / d, -self.im / d)
    }
    /// Principal square root for re > 0 (near the positive real axis, where it is used):
    /// s = sqrt((|z| + re) / 2), sqrt(z) = s + i im / (2 s) (no cancellation in the imaginary
    /// part, which carries the complex-step derivative).
    fn sqrt(self) -> C {
        let r = self.re.hypot(self.im);
        let s = ((r + self.re) / 2.0).sqrt();
        C::new(s, self.im / (2.0 * s))
    }
    fn powi(self, n: i32) -> C {
        let mut out = C::new(1.0, 0.0);
        for _ in 0..n {
            out = out.mul(self);
        }
        out
    }
}

fn cdot(r: &[C; 3], v: &Vector3<f64>) -> C {
    r[0].scale(v.x).add(r[1].scale(v.y)).add(r[2].scale(v.z))
}

/// Eq. 6.21 in complex arithmetic, written from the thesis (independent of porelab's code).
fn dipole_energy_c(r: &[C; 3], a: &Vector3<f64>, b: &Vector3<f64>) -> C {
    let r2 = r[0].mul(r[0]).add(r[1].mul(r[1])).add(r[2].mul(r[2]));
    let rn = r2.sqrt();
    let inv3 = rn.mul(r2).inv();
    let inv5 = inv3.mul(r2.inv());
    let t1 = cdot(r, a).mul(cdot(r, b)).mul(inv5).scale(3.0);
    let t2 = inv3.scale(a.dot(b));
    t1.sub(t2).scale(-MU0 / (4.0 * PI))
}

/// H of a point dipole p at the origin (A/m), complex: (1/4 pi) (3 (p.r) r / r^5 - p / r^3).
fn dipole_h_c(r: &[C; 3], p: &Vector3<f64>) -> [C; 3] {
    let r2 = r[0].mul(r[0]).add(r[1].mul(r[1])).add(r[2].mul(r[2]));
    let rn = r2.sqrt();
    let inv3 = rn.mul(r2).inv();
    let inv5 = inv3.mul(r2.inv());
    let pr = cdot(r, p);
    let mut h = [C::new(0.0, 0.0); 3];
    for k in 0..3 {
        h[k] = pr
            .mul(r[k])
            .mul(inv5)
            .scale(3.0)
            .sub(inv3.scale(p[k]))
            .scale(1.0 / (4.0 * PI));
    }
    h
}

fn perturbed(x: &Vector3<f64>, k: usize, h: f64) -> [C; 3] {
    let mut r = [C::new(x.x, 0.0), C::new(x.y, 0.0), C::new(x.z, 0.0)];
    r[k].im = h;
    r
}

fn unit_random<R: Rng>(rng: &mut R) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            standard_normal(rng),
            standard_normal(rng),
            standard_normal(rng),
        );
        let n = v.norm();
        if n > 1e-3 {
            return v / n;
        }
    }
}

register!("405" => case_405);
/// Case 405: Mie closed forms and dipole energies from the table; Mie, dipole and
/// field-gradient forces against complex-step derivatives of independently written energies.
pub fn case_405(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let kind = t.str(i, "kind")?;
        let label = t.str(i, "label")?;
        let expected = t.f64(i, "expected")?;
        let got = if kind.starts_with("dipole") {
            let (mm, d) = (1e-16, 1e-6);
            let unit = MU0 * mm * mm / (4.0 * PI * d * d * d);
            let (r, a, b) = match kind {
                "dipole_head_to_tail" => (Vector3::z() * d, Vector3::z() * mm, Vector3::z() * mm),
                "dipole_side_by_side" => (Vector3::x() * d, Vector3::z() * mm, Vector3::z() * mm),
                "dipole_perpendicular" => (Vector3::y() * d, Vector3::z() * mm, Vector3::x() * mm),
                o => return Err(Error::Validation(format!("unknown kind '{o}'"))),
            };
            dipole_energy(&r, &a, &b) / unit
        } else {
            let n = usize_col(&t, i, "n")? as i32;
            let m = usize_col(&t, i, "m")? as i32;
            let mie = Mie::new(n, m, 1.0, 1.0)?;
            match kind {
                "r_min" => mie.r_min(),
                "energy_unshifted_at_rmin" => mie.energy_unshifted(mie.r_min()),
                "energy_at_rmin" => mie.energy(mie.r_min() * (1.0 - f64::EPSILON)),
                "energy_unshifted" => mie.energy_unshifted(t.f64(i, "r_over_sigma")?),
                "energy" => mie.energy(t.f64(i, "r_over_sigma")?),
                o => return Err(Error::Validation(format!("unknown kind '{o}'"))),
            }
        };
        rows.push(Row::new(label, got, expected, expected.abs().max(1.0)));
    }
    // Mie force = -dU/dr by complex step of eq. 6.18 (sigma = eps = 1). Scale: the repulsive
    // term C n (sigma/r)^(n+1), against which the difference of the two terms cancels.
    for (n, m) in [(12, 6), (30, 15), (100, 50)] {
        let mie = Mie::new(n, m, 1.0, 1.0)?;
        let (nf, mf) = (n as f64, m as f64);
        let cpref = nf / (nf - mf) * (nf / mf).powf(mf / (nf - mf));
        for r in [0.9, 0.95, 0.99, 1.0, 1.01, 1.02, 1.04] {
            if r >= mie.r_min() {
                continue;
            }
            let h = 1e-30;
            let s = C::new(r, h).inv();
            let u = s.powi(n).sub(s.powi(m)).scale(cpref);
            let expected = -u.im / h;
            let scale = cpref * nf * (1.0 / r).powi(n + 1);
            rows.push(Row::new(
                format!("Mie({n},{m}) force at r = {r} sigma"),
                mie.force_magnitude(r),
                expected,
                scale,
            ));
        }
    }
    // Dipole forces against the complex-step gradient of eq. 6.21.
    let mut rng = run_rng(seed(ctx)?, 0);
    let a_rad = 1e-7;
    for k in 0..16 {
        let r = unit_random(&mut rng) * a_rad * (2.0 + 28.0 * rng.gen::<f64>());
        let ma = unit_random(&mut rng) * 10f64.powf(-17.0 + 2.0 * rng.gen::<f64>());
        let mb = unit_random(&mut rng) * 10f64.powf(-17.0 + 2.0 * rng.gen::<f64>());
        let got = dipole_force(&r, &ma, &mb);
        let h = 1e-30 * r.norm();
        let exp = Vector3::from_fn(|c, _| -dipole_energy_c(&perturbed(&r, c, h), &ma, &mb).im / h);
        for c in 0..3 {
            rows.push(Row::new(
                format!("dipole pair {k} F_{}", ["x", "y", "z"][c]),
                got[c],
                exp[c],
                exp.norm(),
            ));
        }
    }
    // Force on a particle (through Simulation::forces) in the field of a point dipole source
    // plus 1 T along x: F = grad(mu0 m . H) at fixed m, by complex step of H written here.
    let p_src = Vector3::new(0.3, -0.2, 1.0) * 1e-9; // A m^2
    let h0 = Vector3::new(1.0 / MU0, 0.0, 0.0);
    let field = move |x: &Vector3<f64>| -> (Vector3<f64>, Matrix3<f64>) {
        let hh = 1e-30 * x.norm();
        let hv = dipole_h_c(&perturbed(x, 0, 0.0), &p_src);
        let mut g = Matrix3::zeros();
        for j in 0..3 {
            let hc = dipole_h_c(&perturbed(x, j, hh), &p_src);
            for i in 0..3 {
                g[(i, j)] = hc[i].im / hh;
            }
        }
        (Vector3::new(hv[0].re, hv[1].re, hv[2].re), g)
    };
    let moment = LangevinMoment::fixed(0.870e-16)?;
    let fluid = Fluid::new(298.0, 1e-3)?;
    for k in 0..8 {
        let x = unit_random(&mut rng) * 1e-4 * (1.0 + rng.gen::<f64>());
        let mut setup = Setup::new(Particles::new(vec![x], 75e-9)?, fluid, 5e-5)?;
        setup.magnetic = Some(Magnetic {
            source: Box::new(WithUniform {
                h0,
                source: FieldFn(field),
            }),
            moment,
            dipole_pairs: false,
            cutoff: 30.0 * 75e-9,
        });
        let got = Simulation::new(setup, run_rng(0, 0))?.forces()?[0];
        let (htot, _) = field(&x);
        let mvec = moment.moment(&(htot + h0), fluid.kt());
        let hh = 1e-30 * x.norm();
        let exp = Vector3::from_fn(|c, _| {
            let hc = dipole_h_c(&perturbed(&x, c, hh), &p_src);
            MU0 * (mvec.x * hc[0].im + mvec.y * hc[1].im + mvec.z * hc[2].im) / hh
        });
        for c in 0..3 {
            rows.push(Row::new(
                format!("field-gradient force {k} F_{}", ["x", "y", "z"][c]),
                got[c],
                exp[c],
                exp.norm(),
            ));
        }
    }
    Ok(rows)
}

register!("406" => case_406);
/// Case 406: L(x) and L(x)/x against mpmath; m/m_s of the law against mpmath; the low-field
/// slope (eq. 7.7) and saturation checked here against their closed forms.
pub fn case_406(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let kind = t.str(i, "kind")?;
        let expected = t.f64(i, "expected")?;
        let got = match kind {
            "L" => langevin(t.f64(i, "x")?),
            "L_over_x" => {
                let x = t.f64(i, "x")?;
                langevin(x) / x
            }
            "moment" => {
                let ms = t.f64(i, "saturation_Am2")?;
                let law = LangevinMoment::langevin(ms, t.f64(i, "domain_Am2")?)?;
                law.magnitude(t.f64(i, "H_A_per_m")?, KB * t.f64(i, "temperature_K")?) / ms
            }
            o => return Err(Error::Validation(format!("unknown kind '{o}'"))),
        };
        rows.push(Row::new(t.str(i, "label")?, got, expected, expected.abs()));
    }
    // Eq. 7.7: m / H -> m_s mu0 mu_d / (3 kB T) as H -> 0 (at xi = 1e-9 the next term is
    // xi^2 / 15 ~ 7e-20 relative); saturation m -> m_s (xi = 1e12: 1 - 1e-12).
    let (ms, md, temp) = (0.870e-16, 2.335e-19, 298.0);
    let law = LangevinMoment::langevin(ms, md)?;
    let kt = KB * temp;
    for xi in [1e-9, 1e-6] {
        let h = xi * kt / (MU0 * md);
        let slope = ms * MU0 * md / (3.0 * kt);
        let corr = 1.0 - xi * xi / 15.0;
        rows.push(Row::new(
            format!("eq. 7.7 slope at xi = {xi:e}: (m/H) / (m_s mu0 mu_d / 3kT)"),
            law.magnitude(h, kt) / h / slope,
            corr,
            1.0,
        ));
    }
    for xi in [1e6, 1e12, 1e100] {
        let h = xi * kt / (MU0 * md);
        rows.push(Row::new(
            format!("saturation at xi = {xi:e}: m/m_s"),
            law.magnitude(h, kt) / ms,
            1.0 - 1.0 / xi,
            1.0,
        ));
    }
    rows.push(Row::new(
        "saturated at T = 0: m/m_s",
        law.magnitude(1.0, 0.0) / ms,
        1.0,
        1.0,
    ));
    Ok(rows)
}

register!("407" => case_407);
/// Case 407: B B^T of TEA-HI equals M for diagonal and equal-off-diagonal M.
pub fn case_407(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let n = usize_col(&t, i, "n_rows")?;
        let d = t.f64(i, "d")?;
        let m = match t.str(i, "kind")? {
            "diagonal" => {
                let spread = t.f64(i, "spread")?;
                DMatrix::from_diagonal(&DVector::from_fn(n, |k, _| d * (1.0 + k as f64 * spread)))
            }
            "equal" => {
                let c = t.f64(i, "c")?;
                DMatrix::from_fn(n, n, |k, l| if k == l { d } else { c * d })
            }
            o => return Err(Error::Validation(format!("unknown kind '{o}'"))),
        };
        let gen = NoiseGenerator::new(NoiseMethod::TeaHi, &m)?;
        let b = gen.factor();
        let p = b * b.transpose();
        let scale = m.diagonal().max();
        let label = t.str(i, "label")?;
        for k in 0..n {
            for l in k..n {
                rows.push(Row::new(
                    format!("{label} ({k},{l})"),
                    p[(k, l)],
                    m[(k, l)],
                    scale,
                ));
            }
        }
    }
    Ok(rows)
}

register!("408" => case_408);
/// Case 408: displacement at T = 0 after `steps` steps equals factor F t / (6 pi eta a).
pub fn case_408(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let kind = hydro(&t, i)?;
        let n = usize_col(&t, i, "n_particles")?;
        let a = t.f64(i, "radius_m")?;
        let eta = t.f64(i, "viscosity_Pa_s")?;
        let dt = t.f64(i, "dt_s")?;
        let steps = usize_col(&t, i, "steps")?;
        let f = Vector3::new(t.f64(i, "Fx_N")?, t.f64(i, "Fy_N")?, t.f64(i, "Fz_N")?);
        let sep = t.f64(i, "separation_over_a")? * a;
        let p0: Vec<Vector3<f64>> = (0..n)
            .map(|k| Vector3::new(k as f64 * sep, 0.0, 0.0))
            .collect();
        let mut setup = Setup::new(Particles::new(p0.clone(), a)?, Fluid::new(0.0, eta)?, dt)?;
        setup.hydrodynamics = kind;
        setup.constant_force = f;
        let mut sim = Simulation::new(setup, run_rng(0, 0))?;
        run_steps(&mut sim, steps as u64, &mut NoHooks)?;
        let expected = f * (t.f64(i, "factor")? * steps as f64 * dt / (6.0 * PI * eta * a));
        let label = t.str(i, "label")?;
        for (k, (p, q)) in sim.particles().positions.iter().zip(&p0).enumerate() {
            let d = p - q;
            for c in 0..3 {
                rows.push(Row::new(
                    format!("{label} particle {k} d{}", ["x", "y", "z"][c]),
                    d[c],
                    expected[c],
                    expected.norm(),
                ));
            }
        }
    }
    Ok(rows)
}

/// Positions for case 409: `n` spheres of radius `a` uniform in a cube at nominal volume
/// fraction `phi` without overlaps (random sequential addition), or a straight chain along x
/// at centre spacing `spacing` x 2a when `phi` is 0.
fn config_409<R: Rng>(rng: &mut R, n: usize, a: f64, phi: f64, spacing: f64) -> Vec<Vector3<f64>> {
    if phi == 0.0 {
        return (0..n)
            .map(|k| Vector3::new(k as f64 * spacing * 2.0 * a, 0.0, 0.0))
            .collect();
    }
    let side = (n as f64 * 4.0 / 3.0 * PI * a.powi(3) / phi).cbrt();
    let mut pos: Vec<Vector3<f64>> = Vec::with_capacity(n);
    while pos.len() < n {
        let p = Vector3::new(rng.gen::<f64>(), rng.gen::<f64>(), rng.gen::<f64>()) * side;
        if pos.iter().all(|q| (p - q).norm() >= 2.0 * a) {
            pos.push(p);
        }
    }
    pos
}

register!("409" => case_409);
/// Case 409: collective (centre-of-mass) diffusion of TEA-HI against the exact (Cholesky)
/// covariance, e^T B B^T e / e^T M e for e the uniform translation along x, y, z.
pub fn case_409(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = seed(ctx)?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let n = usize_col(&t, i, "n_particles")?;
        let a = t.f64(i, "radius_m")?;
        let mut rng = run_rng(seed, usize_col(&t, i, "run")? as u64);
        let pos = config_409(
            &mut rng,
            n,
            a,
            t.f64(i, "volume_fraction")?,
            t.f64(i, "chain_spacing_over_2a")?,
        );
        let m = mobility_matrix(Hydrodynamics::Rpy, &pos, a, 1e-3)?;
        let gen = NoiseGenerator::new(NoiseMethod::TeaHi, &m)?;
        let b = gen.factor();
        let cov = b * b.transpose();
        for (c, name) in ["x", "y", "z"].iter().enumerate() {
            let e = DVector::from_fn(3 * n, |k, _| if k % 3 == c { 1.0 } else { 0.0 });
            let exact = e.dot(&(&m * &e));
            let tea = e.dot(&(&cov * &e));
            rows.push(Row::new(
                format!("{} {name}", t.str(i, "label")?),
                tea / exact,
                t.f64(i, "expected_ratio")?,
                1.0,
            ));
        }
    }
    Ok(rows)
}
