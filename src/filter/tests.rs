//! Tests of the filter engine against independent counts and limits.

use super::*;
use crate::brownian::forces::FieldFn;
use crate::brownian::{Fluid, LangevinMoment};
use crate::driver::NoHooks;
use nalgebra::{Matrix3, Vector3};

const CELL: [f64; 3] = [1e-3, 1e-3, 1e-3];
const FIBRE_R: f64 = 5e-5;
const FIBRE_L: f64 = 3e-4;
const PARTICLE_R: f64 = 1e-7;

fn fibres(n: usize, seed: u64) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    random_transverse_fibres(n, CELL, FIBRE_R, seed)
}

fn plug_flow(u: f64) -> VelocityLattice {
    VelocityLattice::from_fn([8, 8, 8], CELL[0] / 8.0, |_| Vector3::new(0.0, 0.0, u)).unwrap()
}

fn setup(
    n_fibres: usize,
    particles: usize,
    temperature_k: f64,
    field: Option<Box<dyn crate::brownian::FieldSource>>,
    moment: f64,
) -> Setup {
    let (c, a) = fibres(n_fibres, 7);
    Setup {
        bed: FibreBed::new(CELL, FIBRE_R, FIBRE_L, &c, &a, PARTICLE_R).unwrap(),
        flow: plug_flow(1e-3),
        wall_layer_m: 0.0,
        field,
        moment: LangevinMoment::fixed(moment).unwrap(),
        fluid: Fluid::new(temperature_k, 1e-3).unwrap(),
        particles,
        cells_deep: 2,
        dt_s: 2e-3,
        max_step_fraction: 0.05,
        seed: 11,
    }
}

/// A smooth periodic field with a gradient, for tests of the stepping (not of physics).
fn wavy_field() -> Box<dyn crate::brownian::FieldSource> {
    let k = std::f64::consts::TAU / CELL[0];
    Box::new(FieldFn(move |p: &Vector3<f64>| {
        let (s, c) = (k * p.x).sin_cos();
        let h = Vector3::new(1e4 * s, 0.0, 5e4);
        let mut g = Matrix3::zeros();
        g[(0, 0)] = 1e4 * k * c;
        (h, g)
    }))
}

/// Every fate is true of the particle's position: a captured particle is in contact with its
/// fibre (some periodic image, checked by brute force), a passed one beyond the outlet, one
/// inside within the bed and touching nothing; and fed = captured + passed + inside after
/// every step.
#[test]
fn fates_are_true_and_counts_add_up() {
    let mut f = Filter::new(setup(6, 300, 298.0, Some(wavy_field()), 1e-17)).unwrap();
    let near = |p: &Vector3<f64>, fibre: &crate::brownian::capture::CylinderBody| {
        (-1..=1).any(|sx: i32| {
            (-1..=1).any(|sy: i32| {
                (-3..=3).any(|sz: i32| {
                    let s = Vector3::new(sx as f64, sy as f64, sz as f64)
                        .component_mul(&Vector3::from(CELL));
                    fibre.signed_distance(&(p - s)) <= PARTICLE_R
                })
            })
        })
    };
    // 2 mm at 1 mm/s in steps of 2 ms: past the outlet after about 1000 steps
    for _ in 0..1100 {
        f.step().unwrap();
        let c = f.counts();
        assert_eq!(c.fed, 300);
        assert_eq!(c.captured + c.passed + c.inside, c.fed);
        for t in f.tracers() {
            match t.fate {
                Fate::Captured {
                    fibre, position, ..
                } => {
                    assert_eq!(position, t.position);
                    assert!(near(&position, &f.bed().fibres()[fibre]), "{position}");
                }
                Fate::Passed { .. } => assert!(t.position.z >= f.depth_m()),
                Fate::Inside => {
                    assert!((0.0..f.depth_m()).contains(&t.position.z));
                    assert!(!f.bed().fibres().iter().any(|b| near(&t.position, b)));
                }
            }
        }
    }
    let c = f.counts();
    assert!(c.captured > 0 && c.passed > 0, "{c:?}");
}

/// The fibres of [`setup`] magnetized along z (1e5 A/m each) under 0.1 T along z, their images
/// within 0.8 mm counting, every image from one cylinder table (tolerance 1e-6, 0.2 mm bins).
fn tabulated_field() -> Box<dyn crate::brownian::FieldSource> {
    use crate::magnetics::assembly_fast::{Cell, Cutoff, FibreAssembly, TabulatedAssembly};
    use crate::magnetics::cylinder_table::TableSpec;
    let (c, a) = fibres(6, 7);
    let m = vec![Vector3::new(0.0, 0.0, 1e5); c.len()];
    let model = FibreAssembly::new(
        crate::magnetics::Cylinder::new(FIBRE_R, FIBRE_L).unwrap(),
        Cell::new(CELL, [true; 3]).unwrap(),
        Some(Cutoff::new(8e-4, 2e-4).unwrap()),
        c,
        &a,
        &m,
        Vector3::new(0.0, 0.0, 0.1 / crate::consts::MU0),
    )
    .unwrap();
    let spec = TableSpec {
        tolerance: 1e-6,
        nodes: 10,
        exact_margin_m: 5e-6,
        extent_m: 8e-4,
    };
    Box::new(TabulatedAssembly::new(model, spec, 2e-4, None).unwrap())
}

/// The same seed gives bit-identical particles on one thread and on two, with a smooth test
/// field and with the tabulated superposition of the fibres (its table built on the run's
/// threads too).
#[test]
fn results_do_not_depend_on_the_thread_count() {
    let run = |threads: usize, tabulated: bool| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let field = if tabulated {
                tabulated_field()
            } else {
                wavy_field()
            };
            let mut f = Filter::new(setup(6, 200, 298.0, Some(field), 1e-17)).unwrap();
            driver::run_to_end(&mut f, 150, &mut NoHooks).unwrap();
            f.tracers()
                .iter()
                .map(|t| (t.position, t.fate, t.max_depth_m))
                .collect::<Vec<_>>()
        })
    };
    for tabulated in [false, true] {
        let (a, b) = (run(1, tabulated), run(2, tabulated));
        assert_eq!(a, b, "tabulated: {tabulated}");
    }
    // the field acts: the tabulated run differs from the smooth field's
    assert_ne!(run(2, false), run(2, true));
}

// The interception limit (no field, no noise: captured exactly when the straight path meets a
// fibre, by an independent 2-D count) is validation case 450.

#[test]
fn bad_setups_are_refused_by_name() {
    let mut s = setup(2, 10, 298.0, None, 0.0);
    s.dt_s = 100.0;
    let e = Filter::new(s).err().unwrap().to_string();
    assert!(e.contains("dt_s = 100 s"), "{e}");
    let mut s = setup(2, 10, 298.0, None, 0.0);
    s.flow = VelocityLattice::from_fn([8, 8, 4], CELL[0] / 8.0, |_| Vector3::z()).unwrap();
    let e = Filter::new(s).err().unwrap().to_string();
    assert!(e.contains("cell edge z"), "{e}");
    let mut s = setup(2, 10, 298.0, None, 0.0);
    s.flow = plug_flow(-1e-3);
    let e = Filter::new(s).err().unwrap().to_string();
    assert!(e.contains("inlet"), "{e}");
}
