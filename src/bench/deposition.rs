//! `porelab bench deposition`: trial moves per second for spheres, platelets and needles, the
//! share of pair tests settled by each prefilter, and seconds per run on one thread.

use crate::deposition::driver::run_layer;
use crate::deposition::film::{build, Colour, FilmOptions};
use crate::deposition::grain::Grain;
use crate::deposition::{Deposition, Moves, StopRule};
use crate::driver::Hooks;
use crate::Result;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Particles per run.
    #[arg(long, default_value_t = 400)]
    pub particles: usize,
    /// Sweep guard per run (the stop rule usually ends the run first).
    #[arg(long, default_value_t = 20_000)]
    pub max_sweeps: u64,
}

/// (sweep, seconds since `t0`) after every sweep.
struct Stamps {
    t0: Instant,
    stamps: Vec<(u64, f64)>,
}

impl Hooks<Deposition> for Stamps {
    fn progress(&mut self, d: &Deposition, _: Option<f64>, _: &str) {
        let sweep = d.outcome().sweeps;
        self.stamps.push((sweep, self.t0.elapsed().as_secs_f64()));
    }
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let shapes: [(&str, [f64; 3]); 5] = [
        ("spheres", [0.5e-6; 3]),
        ("platelets aspect 4", [0.5e-6, 0.5e-6, 0.125e-6]),
        ("needles aspect 4", [0.5e-6, 0.125e-6, 0.125e-6]),
        ("platelets aspect 10", [0.5e-6, 0.5e-6, 0.05e-6]),
        ("needles aspect 10", [0.5e-6, 0.05e-6, 0.05e-6]),
    ];
    let colour = Colour::table_b1(0.65);
    let phi = colour.pigment_volume_fraction()?;
    let rho_f = colour.fluid_density_kg_m3()?;
    println!(
        "shape,particles,sweeps,moves,start_s,deposit_s,moves_per_s,last_tenth_moves_per_s,\
         share_bounding,share_sphere_pairs,share_inscribed,share_perram_wertheim"
    );
    for (name, axes) in shapes {
        let grains: Vec<Grain> = (0..args.particles)
            .map(|_| Grain::new(axes, 0, 2500.0, rho_f, crate::consts::STANDARD_GRAVITY))
            .collect::<Result<_>>()?;
        let mut rng = ChaCha8Rng::seed_from_u64(6000);
        let opts = FilmOptions {
            rsa_limit: 0.3,
            tries_per_particle: 5000,
            max_growth_rounds: 20_000,
            k_max_m2: 1e-14,
        };
        let t0 = Instant::now();
        let layer = match build(grains, 5e-6, phi, &opts, &mut rng) {
            Ok(l) => l,
            Err(e) => {
                println!("{name},{},start failed: {e}", args.particles);
                continue;
            }
        };
        let start_s = t0.elapsed().as_secs_f64();
        let mut stamps = Stamps {
            t0: Instant::now(),
            stamps: Vec::new(),
        };
        let stop = StopRule::table_b1(args.max_sweeps);
        let (_, out) = run_layer(layer, Moves::table_b1(), stop, rng, &mut stamps)?;
        let dep_s = stamps.t0.elapsed().as_secs_f64();
        let stamps = stamps.stamps;
        // The rate over the last tenth of the sweeps: the dense, jammed end of the deposit.
        let cut = stamps[stamps.len() * 9 / 10];
        let last = (out.sweeps - cut.0) as f64 * args.particles as f64 / (dep_s - cut.1).max(1e-9);
        let c = &out.prefilters;
        let tot = c.total().max(1) as f64;
        println!(
            "{name},{},{},{},{start_s:.3},{dep_s:.3},{:.4e},{last:.4e},{:.4},{:.4},{:.4},{:.4}",
            args.particles,
            out.sweeps,
            out.moves,
            out.moves as f64 / dep_s,
            c.bounding_spheres as f64 / tot,
            c.sphere_pairs as f64 / tot,
            c.inscribed_spheres as f64 / tot,
            c.perram_wertheim as f64 / tot
        );
    }
    Ok(())
}
