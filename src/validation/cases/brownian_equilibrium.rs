//! Brownian-dynamics equilibrium cases 413 and 414: the positions sampled by the Ermak–McCammon
//! update (thesis 003, eq. 6.3, 6.11) in a harmonic trap follow the Boltzmann law
//! (Kolmogorov–Smirnov test): 413 free-draining against the exact law of the discrete-time
//! process, 414 with RPY hydrodynamic interactions (eq. 6.10; Cholesky or TEA-HI noise) against
//! the continuous law at a time step whose bias is bounded below the KS resolution.
//!
//! Independent particles (free-draining, no repulsion, no dipole pairs) in the isotropic trap
//! U = k |r|^2 / 2, i.e. F = -k r, built by [`crate::brownian::integrator::Magnetic::harmonic_trap`] through
//! the engine's field-source hook. Per coordinate the update is the linear Gaussian recursion
//!   x' = (1 - a) x + sqrt(2 kB T mu dt) g,   a = mu k dt,   mu = 1 / (6 pi eta R) (eq. 6.1),
//! whose stationary law (for 0 < a < 2) is exactly normal with variance
//!   s^2 = 2 kB T mu dt / (1 - (1 - a)^2) = (kB T / k) / (1 - a / 2),
//! i.e. the continuous Boltzmann law N(0, kB T / k) up to the O(dt) factor 1 / (1 - a/2). The
//! expected law of the case is this exact discrete-time law, so the test holds for any a.
//! Every sampled coordinate x is mapped to u = Phi(x / s); under the hypothesis the u are
//! independent uniforms (see the memory bounds below) and their Kolmogorov–Smirnov distance
//! D from U(0, 1) has the Kolmogorov distribution.

use super::common::{non_empty, required_seed};
use crate::brownian::driver::{run_sampled, run_steps};
use crate::brownian::{
    cubic_lattice, mobility_matrix, run_rng, stokes_mobility, Fluid, Hydrodynamics, Magnetic,
    NoiseMethod, Particles, Setup, Simulation, StepGuard,
};
use crate::consts::KB;
use crate::driver::NoHooks;
use crate::validation::{CaseContext, Row, Table};
use crate::{Error, Result};
use nalgebra::Vector3;
use rayon::prelude::*;
use statrs::distribution::{ContinuousCDF, Normal};
use std::f64::consts::PI;

/// The largest allowed correlation between two samples of one particle coordinate, and the
/// largest allowed memory of the initial lattice (in units of s) at the first sample.
const MAX_MEMORY: f64 = 1e-6;

/// One row of expected.csv: `runs` independent simulations of `n` particles.
#[derive(Debug, Clone)]
struct TrapSpec {
    label: String,
    /// Mobility and noise: free-draining, or RPY with Cholesky or TEA-HI noise.
    hydrodynamics: Hydrodynamics,
    noise: NoiseMethod,
    n: usize,
    runs: u64,
    radius: f64,
    temperature: f64,
    viscosity: f64,
    stiffness: f64,
    dt: f64,
    burn_in: u64,
    every: u64,
    snapshots: usize,
    guard: f64,
    first_stream: u64,
}

impl TrapSpec {
    /// a = mu k dt with the Stokes mobility mu = 1 / (6 pi eta R) (eq. 6.1).
    fn a(&self) -> f64 {
        self.stiffness * self.dt / (6.0 * PI * self.viscosity * self.radius)
    }
    /// Standard deviation (m) of the exact stationary law of the discrete-time process at
    /// temperature `temperature` (K): sqrt((kB T / k) / (1 - a/2)).
    fn discrete_sd(&self, temperature: f64) -> f64 {
        (KB * temperature / self.stiffness / (1.0 - 0.5 * self.a())).sqrt()
    }
    /// Number of samples (coordinates) the row produces.
    fn samples(&self) -> usize {
        3 * self.n * self.runs as usize * self.snapshots
    }
}

/// Column `name` of row `i` as an integer >= `min`.
fn integer(t: &Table, i: usize, name: &str, min: u64) -> Result<u64> {
    let v = t.f64(i, name)?;
    if v >= min as f64 && v.fract() == 0.0 && v < 1e15 {
        Ok(v as u64)
    } else {
        Err(Error::Validation(format!(
            "{} line {}: {name} = {v} must be an integer >= {min}",
            t.path().display(),
            t.line(i)
        )))
    }
}

fn specs(t: &Table) -> Result<Vec<TrapSpec>> {
    non_empty(t)?;
    (0..t.len())
        .map(|i| {
            let (hydrodynamics, noise) = match t.str(i, "hydrodynamics")? {
                "free" => (Hydrodynamics::FreeDraining, NoiseMethod::Cholesky),
                "rpy-cholesky" => (Hydrodynamics::Rpy, NoiseMethod::Cholesky),
                "rpy-tea-hi" => (Hydrodynamics::Rpy, NoiseMethod::TeaHi),
                o => {
                    return Err(Error::Validation(format!(
                        "{} line {}: hydrodynamics '{o}' is not free, rpy-cholesky or rpy-tea-hi",
                        t.path().display(),
                        t.line(i)
                    )))
                }
            };
            let s = TrapSpec {
                label: t.str(i, "label")?.to_string(),
                hydrodynamics,
                noise,
                n: integer(t, i, "n_particles", 1)? as usize,
                runs: integer(t, i, "runs", 1)?,
                radius: t.f64(i, "radius_m")?,
                temperature: t.f64(i, "temperature_K")?,
                viscosity: t.f64(i, "viscosity_Pa_s")?,
                stiffness: t.f64(i, "trap_k_N_per_m")?,
                dt: t.f64(i, "dt_s")?,
                burn_in: integer(t, i, "burn_in_steps", 1)?,
                every: integer(t, i, "sample_every_steps", 1)?,
                snapshots: integer(t, i, "snapshots", 1)? as usize,
                guard: t.f64(i, "guard_max_fraction")?,
                first_stream: integer(t, i, "first_stream", 0)?,
            };
            check_memory(&s)?;
            Ok(s)
        })
        .collect()
}

/// Centred simple cubic lattice of spacing 2.002 R (no initial overlap).
fn start_positions(s: &TrapSpec) -> Vec<Vector3<f64>> {
    let p = cubic_lattice(s.n, 2.002 * s.radius);
    let c = p.iter().sum::<Vector3<f64>>() / s.n as f64;
    p.into_iter().map(|q| q - c).collect()
}

/// Refuses a row whose samples are not independent to within [`MAX_MEMORY`]: the correlation
/// of one coordinate across `every` steps is (1 - a)^every, and the mean left over from the
/// start r0 after `burn_in` steps is (1 - a)^burn_in |r0| (exact for the linear recursion).
fn check_memory(s: &TrapSpec) -> Result<()> {
    let a = s.a();
    if !(a > 0.0 && a < 2.0) {
        return Err(Error::Validation(format!(
            "{}: a = mu k dt = {a} must lie in (0, 2) for a stationary law",
            s.label
        )));
    }
    let rho = (1.0 - a).abs();
    let r0 = start_positions(s)
        .iter()
        .map(|p| p.norm())
        .fold(0.0, f64::max);
    let corr = rho.powf(s.every as f64);
    let memory = rho.powf(s.burn_in as f64) * r0 / s.discrete_sd(s.temperature);
    if corr > MAX_MEMORY || memory > MAX_MEMORY {
        return Err(Error::Validation(format!(
            "{}: samples not independent enough: correlation (1-a)^every = {corr:e}, initial \
             memory (1-a)^burn_in |r0|/s = {memory:e}; both must be <= {MAX_MEMORY:e}",
            s.label
        )));
    }
    Ok(())
}

/// What one run produced: the sampled coordinates (m), snapshot after snapshot, and the range
/// of the eigenvalues of M / mu0 over the snapshot configurations ((1, 1) without HI).
struct RunOut {
    x: Vec<f64>,
    lambda: (f64, f64),
}

/// Run `run` of row `s`: `snapshots` snapshots of all 3n coordinates, taken every `every` steps
/// after `burn_in` steps, with the engine at temperature `temperature` (K).
fn run_samples(s: &TrapSpec, temperature: f64, seed: u64, run: u64) -> Result<RunOut> {
    let mut setup = Setup::new(
        Particles::new(start_positions(s), s.radius)?,
        Fluid::new(temperature, s.viscosity)?,
        s.dt,
    )?;
    setup.hydrodynamics = s.hydrodynamics;
    setup.noise = s.noise;
    setup.magnetic = Some(Magnetic::harmonic_trap(s.stiffness)?);
    setup.guard = StepGuard::Refuse {
        max_fraction: s.guard,
    };
    let mu0 = stokes_mobility(s.viscosity, s.radius)?;
    let mut sim = Simulation::new(setup, run_rng(seed, s.first_stream + run))?;
    run_steps(&mut sim, s.burn_in, &mut NoHooks)?;
    let mut x = Vec::with_capacity(3 * s.n * s.snapshots);
    let mut lambda = (1.0f64, 1.0f64);
    let steps = s.snapshots as u64 * s.every;
    run_sampled(&mut sim, steps, s.every, &mut NoHooks, |sim| {
        let pos = &sim.particles().positions;
        x.extend(pos.iter().flat_map(|p| p.iter().copied()));
        if s.hydrodynamics != Hydrodynamics::FreeDraining {
            let ev = mobility_matrix(s.hydrodynamics, pos, s.radius, s.viscosity)?
                .symmetric_eigenvalues();
            lambda = (lambda.0.min(ev.min() / mu0), lambda.1.max(ev.max() / mu0));
        }
        Ok(())
    })?;
    Ok(RunOut { x, lambda })
}

/// All runs of row `s` (in parallel, each on its own stream), engine at `temperature`.
fn row_runs(s: &TrapSpec, temperature: f64, seed: u64) -> Result<Vec<RunOut>> {
    (0..s.runs)
        .into_par_iter()
        .map(|r| run_samples(s, temperature, seed, r))
        .collect()
}

/// All samples of row `s`, engine at `temperature`.
fn row_samples(s: &TrapSpec, temperature: f64, seed: u64) -> Result<Vec<f64>> {
    Ok(row_runs(s, temperature, seed)?
        .into_iter()
        .flat_map(|r| r.x)
        .collect())
}

/// Kolmogorov–Smirnov distance D = sup |F_n(u) - u| of a sample from U(0, 1) (NaN sorts last
/// and gives D = NaN).
pub(crate) fn ks_uniform_distance(u: &[f64]) -> f64 {
    let mut v = u.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len() as f64;
    let mut d = 0.0f64;
    for (i, &x) in v.iter().enumerate() {
        if x.is_nan() {
            return f64::NAN;
        }
        d = d.max((i as f64 + 1.0) / n - x).max(x - i as f64 / n);
    }
    d
}

/// Survival function Q(lambda) = P(K > lambda) of the Kolmogorov distribution,
///   Q = 2 sum_{j>=1} (-1)^(j-1) exp(-2 j^2 lambda^2)                       (lambda >= 1.18),
///   1 - Q = (sqrt(2 pi) / lambda) sum_{j>=1} exp(-(2j-1)^2 pi^2 / (8 lambda^2)) (lambda < 1.18),
/// the two equivalent series (Jacobi theta transformation) each used where it converges fast
/// (Numerical Recipes, 3rd ed., section 6.14.12).
pub(crate) fn kolmogorov_sf(lambda: f64) -> f64 {
    if lambda.is_nan() {
        return f64::NAN;
    }
    if lambda <= 0.0 {
        return 1.0;
    }
    if lambda < 1.18 {
        let y = -PI * PI / (8.0 * lambda * lambda);
        let s: f64 = (1..=20)
            .map(|j| (((2 * j - 1) * (2 * j - 1)) as f64 * y).exp())
            .sum();
        1.0 - (2.0 * PI).sqrt() / lambda * s
    } else {
        let s: f64 = (1..=100)
            .map(|j| {
                let sign = if j % 2 == 1 { 1.0 } else { -1.0 };
                sign * (-2.0 * (j * j) as f64 * lambda * lambda).exp()
            })
            .sum();
        2.0 * s
    }
}

/// P-value of the KS distance `d` of a sample of size `n`: Q((sqrt n + 0.12 + 0.11 / sqrt n) d),
/// Stephens' finite-n correction of the asymptotic Kolmogorov law (M. A. Stephens, J. R. Stat.
/// Soc. B 32, 115 (1970); Numerical Recipes 3rd ed. eq. 14.3.18), accurate for n >= 35.
pub(crate) fn ks_p_value(d: f64, n: usize) -> f64 {
    let sn = (n as f64).sqrt();
    kolmogorov_sf((sn + 0.12 + 0.11 / sn) * d)
}

/// Two-sided normal equivalent of a p-value, z = Phi^-1(1 - p/2) >= 0 (p = 1 -> 0; p = 0 ->
/// infinity), so that |z| <= 4.8916 is p >= 1e-6.
fn z_of_p(p: f64) -> Result<f64> {
    let nrm = Normal::new(0.0, 1.0).map_err(|e| Error::Validation(e.to_string()))?;
    Ok(-nrm.inverse_cdf(0.5 * p))
}

/// KS test of the samples `x` (m) against N(0, sd^2): (D, n, p).
fn ks_normal(x: &[f64], sd: f64) -> Result<(f64, usize, f64)> {
    let nrm = Normal::new(0.0, sd).map_err(|e| Error::Validation(e.to_string()))?;
    let u: Vec<f64> = x.iter().map(|&v| nrm.cdf(v)).collect();
    let d = ks_uniform_distance(&u);
    Ok((d, u.len(), ks_p_value(d, u.len())))
}

register!("413" => case_413);
/// Case 413: per row, the KS test of all sampled coordinates against the exact discrete-time
/// stationary law N(0, (kB T / k) / (1 - a/2)); the row is the z-equivalent of the p-value
/// (expected 0; the case's z = 4.8916 is alpha = 1e-6 per row). The last row's first run is
/// rerun serially and must reproduce the parallel samples bitwise.
pub fn case_413(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let specs = specs(&t)?;
    if let Some(s) = specs
        .iter()
        .find(|s| s.hydrodynamics != Hydrodynamics::FreeDraining)
    {
        return Err(Error::Validation(format!(
            "{}: case 413 needs free-draining rows (the exact discrete law is per coordinate)",
            s.label
        )));
    }
    let seed = required_seed(ctx, "case 413: case.toml needs a seed")?;
    let samples: Vec<Vec<f64>> = specs
        .par_iter()
        .map(|s| row_samples(s, s.temperature, seed))
        .collect::<Result<_>>()?;
    let last = specs.len() - 1;
    let again = run_samples(&specs[last], specs[last].temperature, seed, 0)?.x;
    if again[..] != samples[last][..again.len()] {
        return Err(Error::Validation(format!(
            "{}: the serial rerun differs from the parallel run (results depend on threads)",
            specs[last].label
        )));
    }
    let mut rows = Vec::new();
    for (i, (s, x)) in specs.iter().zip(&samples).enumerate() {
        debug_assert_eq!(x.len(), s.samples());
        let (d, n, p) = ks_normal(x, s.discrete_sd(s.temperature))?;
        rows.push(Row::new(
            format!(
                "{} (a = {:.4}, n = {n}, D = {d:.5}, p = {p:.3e})",
                s.label,
                s.a()
            ),
            z_of_p(p)?,
            t.f64(i, "expected_z")?,
            1.0,
        ));
    }
    Ok(rows)
}

/// Refuses an HI row whose O(dt) bias could be visible. For a constant mobility M the
/// recursion x' = (I - k dt M) x + noise has the stationary covariance
/// (kB T / k) (I - a M / (2 mu0))^-1 (a = mu0 k dt), so the variance bias is at most
/// eps = (a lambda_max / 2) / (1 - a lambda_max / 2), lambda_max the largest eigenvalue of
/// M / mu0 (measured over the snapshots). A variance error eps moves the normal CDF by at most
/// phi(1) eps / 2 = 0.121 eps; that must stay below a tenth of the KS critical distance
/// K_alpha / sqrt(n), K_alpha = sqrt(ln(2 / alpha) / 2), alpha = 1e-6.
/// Independence: the spacing satisfies (1 - a)^every <= 1e-6 for the free-draining rate
/// (checked with the row); pairs that come close relax more slowly (smallest measured
/// eigenvalue reported in the row label), which the lag-one correlation row tests. Residual
/// correlation only widens the null distribution of D, so it cannot make a wrong law pass.
fn check_hi_row(s: &TrapSpec, lambda_max: f64, n: usize) -> Result<f64> {
    let x = 0.5 * s.a() * lambda_max;
    let eps = x / (1.0 - x);
    let shift = 0.5 * eps * (-0.5f64).exp() / (2.0 * PI).sqrt();
    let critical = (2e6f64.ln() / 2.0).sqrt() / (n as f64).sqrt();
    if !(x < 1.0 && shift <= 0.1 * critical) {
        return Err(Error::Validation(format!(
            "{}: largest measured eigenvalue of M/mu0 {lambda_max:.3} with a = {:.4}: the O(dt) \
             bias moves the CDF by {shift:e}, more than a tenth of the KS critical distance \
             ({:e}); use a smaller dt",
            s.label,
            s.a(),
            0.1 * critical
        )));
    }
    Ok(eps)
}

/// z of the lag-one sample correlation of each coordinate between successive snapshots,
/// r = sum x_s x_(s+1) / sqrt(sum x_s^2 sum x_(s+1)^2) over all runs and coordinates (mean 0
/// known): r sqrt(m) is standard normal for m independent pairs.
fn lag_correlation_z(runs: &[RunOut], width: usize) -> f64 {
    let (mut sxy, mut sxx, mut syy, mut m) = (0.0, 0.0, 0.0, 0usize);
    for r in runs {
        for (a, b) in r.x.iter().zip(r.x.iter().skip(width)) {
            sxy += a * b;
            sxx += a * a;
            syy += b * b;
            m += 1;
        }
    }
    sxy / (sxx * syy).sqrt() * (m as f64).sqrt()
}

register!("414" => case_414);
/// Case 414: particles in the trap with RPY hydrodynamic interactions (Cholesky or TEA-HI
/// noise). RPY has zero divergence, so the update (eq. 6.11) has the Boltzmann law
/// N(0, kB T / k) per coordinate as its dt -> 0 stationary law whatever the mobility; dt is
/// chosen so that the O(dt) bias is below a tenth of the KS resolution ([`check_hi_row`], from
/// the measured mobility spectrum). Rows per spec: the KS z against N(0, kB T / k), and the z
/// of the lag-one correlation between successive snapshots (independence of the samples).
pub fn case_414(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let specs = specs(&t)?;
    let seed = required_seed(ctx, "case 414: case.toml needs a seed")?;
    let runs: Vec<Vec<RunOut>> = specs
        .par_iter()
        .map(|s| row_runs(s, s.temperature, seed))
        .collect::<Result<_>>()?;
    let mut rows = Vec::new();
    for (i, (s, out)) in specs.iter().zip(&runs).enumerate() {
        let lambda = out.iter().fold((f64::INFINITY, 0.0f64), |l, r| {
            (l.0.min(r.lambda.0), l.1.max(r.lambda.1))
        });
        let x: Vec<f64> = out.iter().flat_map(|r| r.x.iter().copied()).collect();
        let eps = check_hi_row(s, lambda.1, x.len())?;
        let (d, n, p) = ks_normal(&x, (KB * s.temperature / s.stiffness).sqrt())?;
        let expected = t.f64(i, "expected_z")?;
        rows.push(Row::new(
            format!(
                "{} KS (a = {:.4}, lambda in [{:.3}, {:.3}], bias <= {eps:.1e}, n = {n}, D = {d:.5}, p = {p:.3e})",
                s.label,
                s.a(),
                lambda.0,
                lambda.1
            ),
            z_of_p(p)?,
            expected,
            1.0,
        ));
        rows.push(Row::new(
            format!("{} lag-one correlation", s.label),
            lag_correlation_z(out, 3 * s.n),
            expected,
            1.0,
        ));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Alpha of case 413 (per row).
    const ALPHA: f64 = 1e-6;

    fn spec(label: &str) -> TrapSpec {
        let path = crate::validation::repo_root()
            .join("validation/413-boltzmann-equilibrium/expected.csv");
        let t = Table::read(path).unwrap();
        specs(&t)
            .unwrap()
            .into_iter()
            .find(|s| s.label.starts_with(label))
            .unwrap()
    }

    #[test]
    fn kolmogorov_quantiles() {
        // Asymptotic critical values K_alpha with Q(K_alpha) = alpha (Smirnov 1948 table;
        // e.g. Numerical Recipes, 3rd ed., section 14.3.3): 1.3581 (0.05), 1.6276 (0.01),
        // 1.9495 (0.001), to the 4 decimals given.
        for (k, alpha) in [(1.3581, 0.05), (1.6276, 0.01), (1.9495, 0.001)] {
            let q = kolmogorov_sf(k);
            assert!((q - alpha).abs() < 1e-3 * alpha, "{k}: {q}");
        }
        // The two series agree where both converge.
        for l in [0.9, 1.18, 1.5] {
            let y = -PI * PI / (8.0 * l * l);
            let s: f64 = (1..=20)
                .map(|j| (((2 * j - 1) * (2 * j - 1)) as f64 * y).exp())
                .sum();
            let small = 1.0 - (2.0 * PI).sqrt() / l * s;
            let large: f64 = 2.0
                * (1..=100)
                    .map(|j| {
                        let sgn = if j % 2 == 1 { 1.0 } else { -1.0 };
                        sgn * (-2.0 * (j * j) as f64 * l * l).exp()
                    })
                    .sum::<f64>();
            assert!((small - large).abs() < 1e-14, "{l}: {small} {large}");
        }
        assert_eq!(kolmogorov_sf(0.0), 1.0);
        assert!(kolmogorov_sf(0.2) > 0.999_999);
    }

    #[test]
    fn ks_distance_closed_forms() {
        // The midpoints (i - 1/2)/n have D = 1/(2n); n copies of 0 have D = 1.
        let n = 1000;
        let u: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64).collect();
        assert!((ks_uniform_distance(&u) - 0.5 / n as f64).abs() < 1e-15);
        assert_eq!(ks_uniform_distance(&[0.0; 10]), 1.0);
        assert!(ks_uniform_distance(&[0.5, f64::NAN]).is_nan());
    }

    /// The same test rejects a wrong temperature: the engine runs at 1.25 T while the law is
    /// that of T (sd ratio 1.118, expected D ~ 0.03 against the 1e-6 critical value
    /// ~ 2.76 / sqrt(n) = 0.016 for the 30000 samples of the row).
    #[test]
    fn wrong_temperature_rejected() {
        let s = spec("thesis");
        let x = row_samples(&s, 1.25 * s.temperature, 4130).unwrap();
        let (d, n, p) = ks_normal(&x, s.discrete_sd(s.temperature)).unwrap();
        eprintln!("engine at 1.25 T, law of T: D = {d}, n = {n}, p = {p:e}");
        assert!(p < ALPHA, "D = {d}, n = {n}, p = {p}");
        // ... and accepts the law of the temperature it ran at.
        let (d, n, p) = ks_normal(&x, s.discrete_sd(1.25 * s.temperature)).unwrap();
        assert!(p >= ALPHA, "D = {d}, n = {n}, p = {p}");
    }

    /// At a = mu k dt = 0.5 the continuous Boltzmann law N(0, kB T / k) is rejected (the
    /// discrete law has 4/3 of its variance): the test resolves the O(dt) bias of the update.
    #[test]
    fn continuous_law_rejected_at_large_step() {
        let s = spec("large step");
        let x = row_samples(&s, s.temperature, 4131).unwrap();
        let (d, n, p) = ks_normal(&x, (KB * s.temperature / s.stiffness).sqrt()).unwrap();
        eprintln!("a = {}, continuous law: D = {d}, n = {n}, p = {p:e}", s.a());
        assert!(p < ALPHA, "D = {d}, n = {n}, p = {p}");
    }

    /// Case 414's test rejects the RPY (Cholesky) engine run at 2 T against the law of T
    /// (sd ratio 1.41: expected D ~ 0.08 against the 1e-6 critical value ~ 0.05 at n = 3000).
    #[test]
    fn rpy_wrong_temperature_rejected() {
        let path = crate::validation::repo_root()
            .join("validation/414-boltzmann-equilibrium-rpy/expected.csv");
        let mut s = specs(&Table::read(path).unwrap()).unwrap().remove(0);
        assert_eq!(s.hydrodynamics, Hydrodynamics::Rpy);
        (s.runs, s.snapshots) = (1, 100);
        let x = row_samples(&s, 2.0 * s.temperature, 4140).unwrap();
        let (d, n, p) = ks_normal(&x, (KB * s.temperature / s.stiffness).sqrt()).unwrap();
        eprintln!("RPY engine at 2 T, law of T: D = {d}, n = {n}, p = {p:e}");
        assert!(p < ALPHA, "D = {d}, n = {n}, p = {p}");
    }

    #[test]
    fn memory_bound_enforced() {
        let mut s = spec("thesis");
        s.every = 10;
        let e = check_memory(&s).unwrap_err().to_string();
        assert!(e.contains("not independent"), "{e}");
    }
}
