//! porelab command line: validate | reference regen | run | field | bench.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "porelab",
    version,
    about = "Particles packing, depositing and captured in random porous media, with proofs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the validation cases (fast tier by default) and write a report under target/porelab/.
    Validate {
        /// Case id prefixes to run (e.g. 1 or 104); all cases when empty.
        ids: Vec<String>,
        /// Include the slow tier.
        #[arg(long)]
        all: bool,
    },
    /// Independent reference tables in reference/.
    Reference {
        #[command(subcommand)]
        action: ReferenceAction,
    },
    /// Field of a uniformly magnetized cylinder at the points of a CSV file (header x,y,z in m).
    Field(porelab::cli::field::FieldArgs),
    /// Contact of shape pairs, one JSON pair per line ({"a": SHAPE, "b": SHAPE}).
    Contact(porelab::cli::contact::ContactArgs),
    /// Volume, principal inertia (unit density) and bounding radius of one particle shape.
    Shape(porelab::cli::shape::ShapeArgs),
    /// Happel-Brenner translational resistances of an ellipsoid in Stokes flow.
    Drag(porelab::cli::drag::DragArgs),
    /// Run a scene file (TOML; schema in README) or a built-in scene.
    Run {
        /// The scene file.
        scene: Option<std::path::PathBuf>,
        /// Run the built-in scene of this name instead (see --list).
        #[arg(long)]
        builtin: Option<String>,
        /// List the built-in scenes.
        #[arg(long)]
        list: bool,
        /// Print the built-in scene of this name (TOML) to start a scene file from.
        #[arg(long, value_name = "NAME")]
        show: Option<String>,
        /// Output folder (default target/porelab/run/<scene name>/).
        #[arg(long)]
        out: Option<std::path::PathBuf>,
        /// Worker threads for independent runs (default: all cores); results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Packing, deposition, DEM, LBM and coupled runs: seconds between checkpoints (0: after
        /// every compression step, deposition sweep, DEM or LBM check or coupled porosity row). A packing checkpoint is also written after every halving of Delta V
        /// and at the end.
        #[arg(long, default_value_t = 10.0)]
        checkpoint_every: f64,
        /// Parse and check the scene as a run does before it starts, then stop: no run, no
        /// output folder (exit 0 and one line on stdout when the scene would start).
        #[arg(long)]
        check: bool,
    },
    /// Permeability of a periodic particle configuration (extended XYZ) by lattice Boltzmann.
    Permeability(porelab::cli::permeability::PermeabilityArgs),
    /// Parameter sweeps and ensembles: plan, run locally or as a Slurm job array, collect.
    Sweep(porelab::sweep::SweepArgs),
    /// Work-precision benchmarks.
    Bench {
        #[command(subcommand)]
        what: BenchWhat,
    },
}

#[derive(Subcommand)]
enum ReferenceAction {
    /// Recompute generated reference tables (all, or the one named) without the code under test.
    Regen { name: Option<String> },
    /// List the generated reference tables.
    List,
}

#[derive(Subcommand)]
enum BenchWhat {
    /// Cylinder field: points per second and error against the oracle.
    Field(porelab::bench::field::BenchArgs),
    /// Brownian dynamics: particle-steps per second against N and method, field-evaluation
    /// share, and work-precision against the time step.
    Brownian(porelab::bench::brownian::BenchArgs),
    /// Packing (MCM): seconds to jam against N, density and contacts, one and two threads,
    /// and the reached packing fraction against the try budget.
    Packing(porelab::bench::packing::BenchArgs),
    /// Deposition: trial moves per second for spheres, platelets and needles, and the share
    /// of pair tests settled by each prefilter.
    Deposition(porelab::bench::deposition::BenchArgs),
    /// Lattice Boltzmann: MLUPS per lattice, collision and forcing against the measured
    /// memory-bandwidth limit and the lbmpy peer.
    Lbm(porelab::bench::lbm::BenchArgs),
    /// DEM: particle-steps per second per core against N, one and two threads, neighbour
    /// share, side by side with LAMMPS.
    Dem(porelab::bench::dem::BenchArgs),
    /// Sweeps: per-job overhead of plan, launch and collect; a 100-job sweep on 1 and 2 workers.
    Sweep(porelab::bench::sweep::BenchArgs),
    /// Coupled LBM-DEM: seconds per simulated second of the built-in scenes and the shares of
    /// LBM, DEM and the coupling, both porosity variants, one and two threads.
    Coupled(porelab::bench::coupled::BenchArgs),
    /// Filter: particle-steps per second per core of the fibre-bed field, fast (near exact +
    /// far grid) against the exact superposition, with the force error of each.
    Filter(porelab::bench::filter::BenchArgs),
}

fn main() -> ExitCode {
    // a negative number is a value for its option to check, not an unknown flag
    fn negatives_allowed(c: clap::Command) -> clap::Command {
        c.allow_negative_numbers(true)
            .mut_subcommands(negatives_allowed)
    }
    let cli = match Cli::from_arg_matches(&negatives_allowed(Cli::command()).get_matches()) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result: porelab::Result<ExitCode> = match cli.command {
        Command::Validate { ids, all } => porelab::validation::cli_validate(&ids, all),
        Command::Reference { action } => match action {
            ReferenceAction::Regen { name } => {
                porelab::reference::cli_regen(name.as_deref()).map(|_| ExitCode::SUCCESS)
            }
            ReferenceAction::List => porelab::reference::cli_list().map(|_| ExitCode::SUCCESS),
        },
        Command::Field(args) => porelab::cli::field::run_field(&args),
        Command::Contact(args) => porelab::cli::contact::run_contact(&args),
        Command::Shape(args) => porelab::cli::shape::run_shape(&args),
        Command::Drag(args) => porelab::cli::drag::run_drag(&args),
        Command::Permeability(args) => porelab::cli::permeability::run_permeability(&args),
        Command::Run {
            show: Some(name), ..
        } => porelab::scene::cli_show(&name).map(|_| ExitCode::SUCCESS),
        Command::Run {
            scene,
            builtin,
            list,
            show: None,
            out,
            threads,
            quiet,
            checkpoint_every,
            check,
        } => porelab::scene::cli_run(
            scene.as_deref(),
            builtin.as_deref(),
            list,
            check,
            &porelab::scene::RunOptions {
                out,
                threads,
                quiet,
                checkpoint_every_seconds: Some(checkpoint_every),
            },
        )
        .map(|_| ExitCode::SUCCESS),
        Command::Sweep(args) => porelab::sweep::cli(&args),
        Command::Bench { what } => match what {
            BenchWhat::Field(args) => porelab::bench::field::run(&args).map(|_| ExitCode::SUCCESS),
            BenchWhat::Brownian(args) => {
                porelab::bench::brownian::run(&args).map(|_| ExitCode::SUCCESS)
            }
            BenchWhat::Packing(args) => {
                porelab::bench::packing::run_bench(&args).map(|_| ExitCode::SUCCESS)
            }
            BenchWhat::Deposition(args) => {
                porelab::bench::deposition::run(&args).map(|_| ExitCode::SUCCESS)
            }
            BenchWhat::Lbm(args) => porelab::bench::lbm::run(&args).map(|_| ExitCode::SUCCESS),
            BenchWhat::Dem(args) => porelab::bench::dem::run(&args).map(|_| ExitCode::SUCCESS),
            BenchWhat::Sweep(args) => porelab::bench::sweep::run(&args).map(|_| ExitCode::SUCCESS),
            BenchWhat::Coupled(args) => {
                porelab::bench::coupled::run(&args).map(|_| ExitCode::SUCCESS)
            }
            BenchWhat::Filter(args) => {
                porelab::bench::filter::run(&args).map(|_| ExitCode::SUCCESS)
            }
        },
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("porelab: {e}");
            ExitCode::from(2)
        }
    }
}
