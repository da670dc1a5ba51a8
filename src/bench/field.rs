//! `porelab bench field`: points per second against error for the cylinder field.
//!
//! Random points (fixed seed) fill a box around a cylinder R = 1 m, L = 2 m (inside and
//! outside, |x|,|y| <= 3 m, |z| <= 5 m). For each magnetization (longitudinal, transverse,
//! oblique), with and without the gradient, on one thread and on all threads, it times the
//! whole batch and measures the worst error against the independent oracle
//! (`reference::cylinder_field`) on a sample of the same points. The oracle's own rate is
//! reported for comparison. Output: a table on stdout and `target/porelab/bench-field.csv`.

use crate::magnetics::kernel::Regime;
use crate::magnetics::Cylinder;
use crate::reference::cylinder_field::{oracle_h, oracle_h_gradient};
use crate::Result;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::time::Instant;

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Number of random points around the cylinder.
    #[arg(long, default_value_t = 1_000_000)]
    pub points: usize,
    /// Points of the batch that are also checked against the oracle.
    #[arg(long, default_value_t = 300)]
    pub sample: usize,
}

/// One row of the benchmark table.
#[derive(Debug, Clone)]
pub struct BenchRow {
    pub magnetization: &'static str,
    pub gradient: bool,
    pub threads: usize,
    pub points_per_second: f64,
    pub max_rel_error: f64,
}

fn random_points(n: usize, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            Vector3::new(
                rng.gen_range(-3.0..3.0),
                rng.gen_range(-3.0..3.0),
                rng.gen_range(-5.0..5.0),
            )
        })
        .collect()
}

fn time_batch(
    cyl: &Cylinder,
    m: &Vector3<f64>,
    pts: &[Vector3<f64>],
    gradient: bool,
    threads: usize,
) -> Result<f64> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| crate::Error::Validation(format!("thread pool: {e}")))?;
    let start = Instant::now();
    let checksum: f64 = pool.install(|| {
        if gradient {
            pts.par_iter().map(|p| cyl.h_gradient(m, p)[(0, 0)]).sum()
        } else {
            pts.par_iter().map(|p| cyl.h_field(m, p).x).sum()
        }
    });
    let secs = start.elapsed().as_secs_f64();
    std::hint::black_box(checksum);
    Ok(pts.len() as f64 / secs)
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.points == 0 {
        return crate::error::invalid("--points must be at least 1");
    }
    if args.sample == 0 {
        // With no point checked the reported error would be 0 with nothing checked.
        return crate::error::invalid(
            "--sample 0: at least one point must be checked against the oracle",
        );
    }
    let (r, l) = (1.0, 2.0);
    let cyl = Cylinder::new(r, l)?;
    let pts = random_points(args.points, 20261124);
    let sample = &pts[..args.sample.min(pts.len())];
    let m0 = 1e6;
    let cases: [(&str, Vector3<f64>); 3] = [
        ("longitudinal", Vector3::new(0.0, 0.0, m0)),
        ("transverse", Vector3::new(m0, 0.0, 0.0)),
        ("oblique", Vector3::new(1.0, 1.0, 1.0) * (m0 / 3f64.sqrt())),
    ];
    let mut counts = [0usize; 3];
    for p in &pts {
        let (_, reg) = cyl.field_tensor_with_regime(p);
        counts[reg as usize] += 1;
    }
    eprintln!(
        "points: {} (multipole {:.1}%, slab quadrature {:.1}%, closed form {:.1}%), oracle sample {}",
        pts.len(),
        100.0 * counts[Regime::Multipole as usize] as f64 / pts.len() as f64,
        100.0 * counts[Regime::SlabQuadrature as usize] as f64 / pts.len() as f64,
        100.0 * counts[Regime::ClosedForm as usize] as f64 / pts.len() as f64,
        sample.len()
    );
    let all = rayon::current_num_threads();
    let mut rows = Vec::new();
    let mut oracle_rates = Vec::new();
    for (name, m) in &cases {
        for gradient in [false, true] {
            // Error against the oracle on the sample (and the oracle's rate).
            let t0 = Instant::now();
            let mut worst: f64 = 0.0;
            for p in sample {
                let err = if gradient {
                    let (g_ref, _) = oracle_h_gradient(r, l, m, p);
                    (cyl.h_gradient(m, p) - g_ref).norm() / g_ref.norm()
                } else {
                    let (h_ref, _) = oracle_h(r, l, m, p);
                    (cyl.h_field(m, p) - h_ref).norm() / h_ref.norm()
                };
                worst = worst.max(err);
            }
            oracle_rates.push((
                *name,
                gradient,
                sample.len() as f64 / t0.elapsed().as_secs_f64(),
            ));
            let mut threads_list = vec![1];
            if all > 1 {
                threads_list.push(all);
            }
            for threads in threads_list {
                let pps = time_batch(&cyl, m, &pts, gradient, threads)?;
                rows.push(BenchRow {
                    magnetization: name,
                    gradient,
                    threads,
                    points_per_second: pps,
                    max_rel_error: worst,
                });
            }
        }
    }
    println!(
        "{:<13} {:>8} {:>7} {:>16} {:>14}",
        "magnetization", "gradient", "threads", "points/s", "max rel error"
    );
    let mut csv = String::from("magnetization,gradient,threads,points_per_second,max_rel_error\n");
    for row in &rows {
        println!(
            "{:<13} {:>8} {:>7} {:>16.4e} {:>14.3e}",
            row.magnetization, row.gradient, row.threads, row.points_per_second, row.max_rel_error
        );
        csv.push_str(&format!(
            "{},{},{},{:.6e},{:.6e}\n",
            row.magnetization, row.gradient, row.threads, row.points_per_second, row.max_rel_error
        ));
    }
    println!("brute-force oracle (one thread, on the sample):");
    for (name, gradient, rate) in &oracle_rates {
        println!("  {name:<13} gradient={gradient:<5} {rate:.3e} points/s");
    }
    // Under the working folder, like every other output (not the build's source path).
    let dir = std::path::Path::new("target/porelab");
    std::fs::create_dir_all(dir)?;
    let path = dir.join("bench-field.csv");
    crate::io::write_atomic(&path, csv.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}
