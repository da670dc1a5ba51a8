//! `porelab bench packing`: seconds to jam, reached density and contacts, against N, for the
//! mechanical contraction method (thesis 003 ch. 2-3), and the reached packing fraction
//! against the work spent (work-precision).
//!
//! Sections:
//! 1. jamming: spheres with the jamming schedule of the built-in scene `packing-spheres`
//!    ([`Setup::jammed_spheres`], case 512: compacting stage, then collective relaxation
//!    with a stage budget) for N = 250, 500, 1000 (and 2000, 5000, 10000, 20000, 40000 up to
//!    `--max-n`), seeds 1..=`--seeds` each, the Gauss-Seidel-only schedule of case 506
//!    (`spheres_gs`) at N = 250 and 1000 as the baseline, and spherocylinders L/D = 5 with the schedule of case
//!    504, each timed on a rayon pool of one thread and, for N = 1000 and 10000, of two: packing
//!    fraction, contacts at the smallest cut-off, contacts extrapolated to zero cut-off with
//!    rattlers removed (sec. 2.2.5), seconds, moves and moves per second; per N the means over
//!    the seeds, and the exponents b of CPU seconds ~ N^b and of moves per particle ~ N^b
//!    from log-log fits (over all N, and over N >= 5000, above the step in the cost of a move
//!    where the relaxation's arrays outgrow a core's L2 cache), and for each tenfold step in N
//!    the CPU ratio split into its two factors, moves per particle and CPU seconds per move.
//!    The Gauss-Seidel moves of the thesis' schemes are sequential; the relaxation stage
//!    computes its forces in parallel from 5000 particles on (results independent of the
//!    thread count).
//! 2. work-precision of the compacting scheme: N = 500 spheres, one stage (original scheme,
//!    Delta V = 0.01 N halved 6 times): packing fraction against the try budget per step
//!    (100 ... 3000 N) for beta = 0.5 (thesis) and 1.3 (over-relaxation).
//! 3. work-precision of the jamming schedule: N = 1000 spheres, the relaxation stage's budget
//!    from 4000 N moves to unbounded, seeds 1..=`--seeds`: packing fraction and contacts
//!    reached against the moves spent.
//!
//! Peer: PackingGeneration (force-biased + Lubachevsky-Stillinger) jams N = 1000
//! spheres to phi = 0.637 with about 5.6 contacts in about 8 s and N = 10000 to 0.639 in about
//! 110 s on this class of machine; it is not installed here, so only porelab is timed.
//!
//! Output: tables on stdout and
//! `target/porelab/bench-packing-{jamming,work-precision,jamming-work-precision}.csv`.

use crate::error::invalid;
use crate::packing::measure::measure;
use crate::packing::{run_to_end, Scheme, Setup};

use crate::Result;
use std::time::Instant;

#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// Largest N of the sphere sweep 250, 500, 1000, 2000, 5000, 10000, 20000, 40000.
    #[arg(long, default_value_t = 1000)]
    pub max_n: usize,
    /// Skip the spherocylinder runs.
    #[arg(long)]
    pub spheres_only: bool,
    /// Skip the work-precision sections.
    #[arg(long)]
    pub no_work_precision: bool,
    /// Seeds 1..=K for the sphere sweep and the jamming work-precision (the moves per particle
    /// vary 2x between seeds at N = 1000, so one seed is not a timing).
    #[arg(long, default_value_t = 1)]
    pub seeds: u64,
}

const SIZES: [usize; 8] = [250, 500, 1000, 2000, 5000, 10000, 20000, 40000];
/// The sizes from which a move costs the same (measured with commit fcc0f8b: moves per CPU
/// second 6.0-6.4e6 up to N = 2000, 5.1-5.2e6 from 5000 on): the fit over them is the asymptotic exponent.
const LARGE_N: usize = 5000;
const SEED: u64 = 1;
/// Contact cut-offs for the extrapolation to zero (thesis sec. 2.2.5: 1e-8 ... 1e-5).
const CUTOFFS: [f64; 4] = [1e-8, 1e-7, 1e-6, 1e-5];

/// Spherocylinders L/D = 5 with the schedule of case 504 (original scheme, Delta V = 0.05 N
/// halved 3 times, 50 N tries).
fn rods_aspect5(n: usize, seed: u64) -> Setup {
    let mut p = Setup::new(n, 5.0, seed);
    p.scheme = Scheme::Original;
    p.delta_v_per_particle = 0.05;
    p.halvings = 3;
    p.tries_per_particle = 50.0;
    p
}

/// CPU seconds (user + system, all threads) of this process so far, from /proc/self/stat
/// (fields 14-15, in clock ticks of 1/100 s, the Linux USER_HZ); NaN where it cannot be read.
/// On a shared machine the wall time of a run includes the time other processes held the
/// cores; the CPU time does not.
fn process_cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // The command name (field 2) is in parentheses and may contain spaces.
    let Some(rest) = stat.rfind(')').map(|k| &stat[k + 1..]) else {
        return f64::NAN;
    };
    let f: Vec<&str> = rest.split_whitespace().collect();
    // rest starts at field 3 (state): utime is field 14, stime field 15.
    match (
        f.get(11).map(|s| s.parse::<f64>()),
        f.get(12).map(|s| s.parse::<f64>()),
    ) {
        (Some(Ok(u)), Some(Ok(s))) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

/// One timed run.
#[derive(Debug, Clone, Copy)]
struct Timed {
    phi: f64,
    /// Mean contacts at the smallest cut-off (1e-8 D), all particles.
    contacts_raw: f64,
    /// Contacts extrapolated to zero cut-off, rattlers removed (sec. 2.2.5).
    contacts0: f64,
    wall_seconds: f64,
    moves: u64,
    /// CPU seconds of the whole process for the run and its analysis.
    cpu_seconds: f64,
    /// CPU seconds of the engine alone (the jamming, without the analysis of the result):
    /// what "seconds to jam" means, and what the scaling exponent is fitted to.
    engine_cpu_seconds: f64,
}

impl Timed {
    /// The target for N = 1000 spheres, PackingGeneration's quoted result (bench docs above):
    /// phi >= 0.635 with >= 5.5 contacts.
    fn meets_goal(&self) -> bool {
        self.phi >= 0.635 && self.contacts0 >= 5.5
    }
}

/// Means and minima over the seeds of one setting.
struct OverSeeds {
    runs: Vec<Timed>,
}

impl OverSeeds {
    fn mean(&self, f: fn(&Timed) -> f64) -> f64 {
        self.runs.iter().map(f).sum::<f64>() / self.runs.len() as f64
    }
    fn min(&self, f: fn(&Timed) -> f64) -> f64 {
        self.runs.iter().map(f).fold(f64::INFINITY, f64::min)
    }
    fn max(&self, f: fn(&Timed) -> f64) -> f64 {
        self.runs.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
    }
    fn meeting_goal(&self) -> usize {
        self.runs.iter().filter(|r| r.meets_goal()).count()
    }
}

fn timed(prm: &Setup, threads: usize) -> Result<Timed> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| crate::Error::InvalidInput(format!("thread pool: {e}")))?;
    pool.install(|| {
        let (t, cpu) = (Instant::now(), process_cpu_seconds());
        let r = run_to_end(prm.clone())?;
        let engine_cpu_seconds = process_cpu_seconds() - cpu;
        let min_contacts = if prm.length == 0.0 { 4 } else { 5 };
        let m = measure(&r.packing, &CUTOFFS, min_contacts, 200)?;
        let wall_seconds = t.elapsed().as_secs_f64();
        Ok(Timed {
            phi: m.packing_fraction,
            contacts_raw: m.contacts_at_cutoffs[0],
            contacts0: m.contacts_extrapolated_no_rattlers.ok_or_else(|| {
                crate::Error::InvalidInput(format!(
                    "N = {}, seed {}: every particle is a rattler; no contact number to report",
                    prm.n, prm.seed
                ))
            })?,
            wall_seconds,
            moves: r.total_tries,
            cpu_seconds: process_cpu_seconds() - cpu,
            engine_cpu_seconds,
        })
    })
}

/// Engine CPU nanoseconds per particle move.
fn ns_per_move(engine_cpu_seconds: f64, moves_per_particle: f64, n: usize) -> f64 {
    1e9 * engine_cpu_seconds / (moves_per_particle * n as f64)
}

/// For every pair of swept sizes N and 10 N (linear scaling would give T(10 N) <= 10 T(N)),
/// the engine CPU ratio and its two factors: T(10 N) / T(N) = 10 x (moves per particle ratio)
/// x (CPU seconds per move ratio). `sweep` rows: (N, CPU s, moves per particle, engine CPU s).
fn tenfold_steps(sweep: &[(f64, f64, f64, f64)]) -> Vec<String> {
    let mut lines = Vec::new();
    for a in sweep {
        if let Some(b) = sweep.iter().find(|b| b.0 == 10.0 * a.0) {
            let per_move = |r: &(f64, f64, f64, f64)| ns_per_move(r.3, r.2, r.0 as usize);
            lines.push(format!(
                "N = {} -> {}: engine CPU x{:.2} = 10 x {:.3} (moves per particle) x {:.3} (CPU per move)",
                a.0,
                b.0,
                b.3 / a.3,
                b.2 / a.2,
                per_move(b) / per_move(a)
            ));
        }
    }
    lines
}

/// Least-squares slope of ln y against ln x.
fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

pub fn run_bench(args: &BenchArgs) -> Result<()> {
    if args.max_n < SIZES[0] {
        return invalid(format!(
            "--max-n {}: must be at least {}",
            args.max_n, SIZES[0]
        ));
    }
    if args.seeds == 0 {
        return invalid("--seeds 0: need at least one seed");
    }
    let out = std::path::Path::new("target/porelab");
    std::fs::create_dir_all(out)?;
    let mut csv = String::from(
        "particles,n,threads,packing_fraction,contacts_raw_1e-8,contacts_extrapolated_no_rattlers,seconds,cpu_seconds,engine_cpu_seconds,moves,moves_per_second\n",
    );
    println!(
        "# 1. jamming (seeds 1..={}; engine on one thread, analysis on the pool)",
        args.seeds
    );
    println!("particles        N  threads    phi   C(1e-8)  C0(no rattlers)  seconds  cpu_s  engine_cpu_s      moves  moves/s");
    let mut row = |what: &str, n: usize, threads: usize, r: Timed| {
        let (phi, c, c0, s, m, cpu, engine) = (
            r.phi,
            r.contacts_raw,
            r.contacts0,
            r.wall_seconds,
            r.moves,
            r.cpu_seconds,
            r.engine_cpu_seconds,
        );
        println!(
            "{what:<14} {n:>6} {threads:>4}  {phi:.4}  {c:>7.3}  {c0:>14.3}  {s:>8.2}  {cpu:>5.2}  {engine:>12.2}  {m:>9.3e}  {:.2e}",
            m as f64 / s
        );
        csv.push_str(&format!(
            "{what},{n},{threads},{phi},{c},{c0},{s},{cpu},{engine},{m},{}\n",
            m as f64 / s
        ));
    };
    // Per N: (N, mean CPU s, mean moves per particle, mean engine CPU s) over the seeds.
    let mut sweep: Vec<(f64, f64, f64, f64)> = Vec::new();
    let mut summary = Vec::new();
    for &n in SIZES.iter().filter(|&&n| n <= args.max_n) {
        let mut runs = Vec::new();
        for seed in 1..=args.seeds {
            let r = timed(&Setup::jammed_spheres(n, seed), 1)?;
            row(&format!("spheres s{seed}"), n, 1, r);
            runs.push(r);
        }
        // PackingGeneration's two quoted sizes; the relaxation's force loop goes to the pool only from
        // relax::PARALLEL_MIN_PARTICLES (5000) on, so at N = 1000 the second thread serves the
        // analysis alone.
        if n == 1000 || n == 10000 {
            let r2 = timed(&Setup::jammed_spheres(n, SEED), 2)?;
            row(&format!("spheres s{SEED}"), n, 2, r2);
        }
        let o = OverSeeds { runs };
        let moves_pp = o.mean(|r| r.moves as f64) / n as f64;
        sweep.push((
            n as f64,
            o.mean(|r| r.cpu_seconds),
            moves_pp,
            o.mean(|r| r.engine_cpu_seconds),
        ));
        summary.push(format!(
            "{n:>6}  {:>5}  {:.4} ({:.4})  {:.3} ({:.3})  {:>6.2} ({:.2}-{:.2})  {:>8.2}  {moves_pp:.2e}  {:>14.1}  {}/{}",
            o.runs.len(),
            o.mean(|r| r.phi),
            o.min(|r| r.phi),
            o.mean(|r| r.contacts0),
            o.min(|r| r.contacts0),
            o.mean(|r| r.cpu_seconds),
            o.min(|r| r.cpu_seconds),
            o.max(|r| r.cpu_seconds),
            o.mean(|r| r.engine_cpu_seconds),
            ns_per_move(o.mean(|r| r.engine_cpu_seconds), moves_pp, n),
            o.meeting_goal(),
            o.runs.len(),
        ));
    }
    // Baseline in the same run: the Gauss-Seidel-only schedule (case 506).
    for &n in [250, 1000].iter().filter(|&&n| n <= args.max_n) {
        let r = timed(&Setup::two_stage_spheres(n, SEED), 1)?;
        row("spheres_gs", n, 1, r);
    }
    if !args.spheres_only {
        for &n in [300, 1000].iter().filter(|&&n| n <= args.max_n) {
            row("rods_LD5", n, 1, timed(&rods_aspect5(n, SEED), 1)?);
        }
    }
    println!(
        "\nspheres, mean over seeds 1..={} (one thread):",
        args.seeds
    );
    println!("     N  seeds  phi (min)         C0 (min)       CPU s (min-max)    engine CPU s  moves/N  engine ns/move  phi>=0.635 & C0>=5.5");
    for line in &summary {
        println!("{line}");
    }
    if sweep.len() >= 2 {
        let ns: Vec<f64> = sweep.iter().map(|r| r.0).collect();
        let cpu: Vec<f64> = sweep.iter().map(|r| r.1).collect();
        let moves_pp: Vec<f64> = sweep.iter().map(|r| r.2).collect();
        let engine: Vec<f64> = sweep.iter().map(|r| r.3).collect();
        println!(
            "CPU seconds ~ N^b over the spheres: b = {:.2} for the jamming alone, {:.2} with the \
             analysis (1 = linear); moves per particle ~ N^{:.2} (0 = linear; deterministic, \
             unlike the seconds)",
            log_slope(&ns, &engine),
            log_slope(&ns, &cpu),
            log_slope(&ns, &moves_pp)
        );
        let large: Vec<_> = sweep.iter().filter(|r| r.0 >= LARGE_N as f64).collect();
        if large.len() >= 2 {
            let x: Vec<f64> = large.iter().map(|r| r.0).collect();
            let y: Vec<f64> = large.iter().map(|r| r.3).collect();
            println!(
                "over N >= {LARGE_N} only: engine CPU seconds ~ N^{:.2}",
                log_slope(&x, &y)
            );
        }
        for line in tenfold_steps(&sweep) {
            println!("{line}");
        }
    }
    std::fs::write(out.join("bench-packing-jamming.csv"), csv)?;
    if !args.no_work_precision {
        println!("\n# 2. work-precision: N = 500 spheres, one stage, original scheme, Delta V = 0.01 N halved 6 times");
        println!(" beta  tries/N      moves  seconds     phi");
        let mut wp = String::from("beta,tries_per_particle,moves,seconds,packing_fraction\n");
        for beta in [0.5, 1.3] {
            for tries in [100.0, 300.0, 1000.0, 3000.0] {
                let mut p = Setup::new(500, 0.0, SEED);
                p.scheme = Scheme::Original;
                p.beta = beta;
                p.tries_per_particle = tries;
                let t = Instant::now();
                let r = run_to_end(p)?;
                let s = t.elapsed().as_secs_f64();
                let phi = r.packing.packing_fraction();
                println!(
                    "{beta:>5}  {tries:>7}  {:>9.3e}  {s:>7.2}  {phi:.4}",
                    r.total_tries
                );
                wp.push_str(&format!("{beta},{tries},{},{s},{phi}\n", r.total_tries));
            }
        }
        std::fs::write(out.join("bench-packing-work-precision.csv"), wp)?;
    }
    if !args.no_work_precision {
        jamming_work_precision(args.seeds, out)?;
    }
    println!("\nwrote target/porelab/bench-packing-*.csv");
    Ok(())
}

/// Relaxation-stage budgets per particle of the jamming work-precision section (None: the
/// stage ends only on its halvings).
const JAM_BUDGETS: [Option<f64>; 6] = [
    Some(4000.0),
    Some(8000.0),
    Some(15000.0),
    Some(25000.0),
    Some(40000.0),
    None,
];

/// Section 3: the jamming schedule at N = 1000 against the relaxation stage's budget
/// (`stage_budget_per_particle`): packing fraction and contacts reached for the moves spent,
/// mean over seeds 1..=`seeds`.
fn jamming_work_precision(seeds: u64, out: &std::path::Path) -> Result<()> {
    const N: usize = 1000;
    println!(
        "\n# 3. work-precision of the jamming schedule: N = {N} spheres, relaxation-stage budget, seeds 1..={seeds}"
    );
    println!("budget/N  moves/N     phi (min)        C0 (min)      CPU s  phi>=0.635 & C0>=5.5");
    let mut wp = String::from(
        "stage_budget_per_particle,seeds,moves_per_particle,packing_fraction_mean,packing_fraction_min,contacts_extrapolated_mean,contacts_extrapolated_min,cpu_seconds_mean,meeting_goal\n",
    );
    for budget in JAM_BUDGETS {
        let mut runs = Vec::new();
        for seed in 1..=seeds {
            let mut p = Setup::jammed_spheres(N, seed);
            if let Some(st) = p.final_stage.as_mut() {
                st.stage_budget_per_particle = budget;
            }
            runs.push(timed(&p, 1)?);
        }
        let o = OverSeeds { runs };
        let name = budget.map_or("none".to_string(), |b| format!("{b}"));
        let moves_pp = o.mean(|r| r.moves as f64) / N as f64;
        let (phi, phi_min) = (o.mean(|r| r.phi), o.min(|r| r.phi));
        let (c0, c0_min) = (o.mean(|r| r.contacts0), o.min(|r| r.contacts0));
        let (cpu, ok) = (o.mean(|r| r.cpu_seconds), o.meeting_goal());
        println!(
            "{name:>8}  {moves_pp:>7.0}  {phi:.4} ({phi_min:.4})  {c0:.3} ({c0_min:.3})  {cpu:>6.2}  {ok}/{}",
            o.runs.len()
        );
        wp.push_str(&format!(
            "{name},{seeds},{moves_pp},{phi},{phi_min},{c0},{c0_min},{cpu},{ok}\n"
        ));
    }
    std::fs::write(out.join("bench-packing-jamming-work-precision.csv"), wp)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two factors of a tenfold step multiply back to the CPU ratio over 10, and only
    /// sizes with a tenfold partner give a line.
    #[test]
    fn tenfold_step_factors_multiply_to_the_cpu_ratio() {
        // (N, CPU s, moves per particle, engine CPU s)
        let sweep = [
            (1000.0, 3.5, 2.9e4, 3.3),
            (2000.0, 7.5, 3.0e4, 7.3),
            (10000.0, 40.0, 3.1e4, 38.9),
        ];
        let lines = tenfold_steps(&sweep);
        assert_eq!(lines.len(), 1, "{lines:?}");
        let moves: f64 = 3.1e4 / 2.9e4;
        let per_move: f64 = (38.9 / (3.1e4 * 1e4)) / (3.3 / (2.9e4 * 1e3));
        assert!((10.0 * moves * per_move - 38.9 / 3.3).abs() < 1e-12);
        assert!(
            lines[0].contains(&format!("x{:.2}", 38.9 / 3.3)),
            "{}",
            lines[0]
        );
        assert!(lines[0].contains(&format!("{moves:.3}")), "{}", lines[0]);
        assert!(lines[0].contains(&format!("{per_move:.3}")), "{}", lines[0]);
        assert!((ns_per_move(3.3, 2.9e4, 1000) - 1e9 * 3.3 / 2.9e7).abs() < 1e-9);
    }
}
