//! Stress and bad-input tests of the DEM engine: a time step too large for the stiffness is
//! refused with a message naming it; stiff materials (E = 1e11 Pa) and a size ratio of 10 run
//! without NaN or spheres lost through the walls; results do not depend on the thread count
//! (one-loop-at-a-time steps against the team of threads, with and without a pressure wall).

use nalgebra::Vector3;
use porelab::dem::{
    start::random_dispersion, ContactModel, DampingModel, Dem, ImpactSpeed, Material, NormalModel,
    Particles, Setup, Start, TangentialModel, TimeStep, TopWall, WallLedger,
};
use rand::{Rng, SeedableRng};

/// Hertz–Mindlin spheres (E = `young`, nu = 0.3, e = 0.5, mu = 0.5) under gravity in an l x l x
/// h box, starting from `p`; the time step's impact speed 1 m/s.
fn setup(young: f64, l: f64, h: f64, p: Particles) -> Setup {
    let contact = ContactModel::new(
        NormalModel::Hertz,
        DampingModel::restitution(0.5).unwrap(),
        TangentialModel::mindlin(0.5, 1.0).unwrap(),
    )
    .unwrap();
    let material = Material::new(young, 0.3).unwrap();
    let mut s = Setup::in_box([l, l, h], contact, material, 2500.0, Start::Given(p));
    s.gravity_m_s2 = Vector3::new(0.0, 0.0, -9.81);
    s.impact_speed = ImpactSpeed::Given { m_s: 1.0 };
    s
}

fn bed(young: f64, radii: Vec<f64>, seed: u64) -> Setup {
    let r_max = radii.iter().cloned().fold(0.0, f64::max);
    let l = 12.0 * r_max;
    let solid: f64 = radii
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
        .sum();
    let h = (solid / (0.2 * l * l)).max(6.0 * r_max);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let pos = random_dispersion(&radii, l, l, h, &mut rng).unwrap();
    setup(young, l, h, Particles::at_rest(pos, radii, 2500.0))
}

fn all_inside(dem: &Dem) {
    for (i, x) in dem.p.pos.iter().enumerate() {
        assert!(x.iter().all(|c| c.is_finite()), "particle {i} not finite");
        let r = dem.p.radius[i];
        assert!(
            x.z > 0.5 * r && x.z < dem.top_z_m - 0.5 * r,
            "particle {i} through a wall: z = {}",
            x.z
        );
        let (lx, ly) = (dem.setup().lx_m, dem.setup().ly_m);
        assert!(x.x >= 0.0 && x.x < lx && x.y >= 0.0 && x.y < ly);
    }
}

#[test]
fn too_large_time_step_is_refused() {
    let mut s = bed(1e7, vec![2e-4; 50], 1);
    s.time_step = TimeStep::Given { dt_s: 1e-3 };
    let e = Dem::new(s)
        .err()
        .expect("dt = 1e-3 s must be refused")
        .to_string();
    assert!(e.contains("dt = 1e-3") && e.contains("too large"), "{e}");
}

#[test]
fn stiff_material_runs_clean() {
    let mut dem = Dem::new(bed(1e11, vec![2e-4; 100], 2)).unwrap();
    dem.run(20_000).unwrap();
    all_inside(&dem);
    assert!(dem.max_overlap_ratio() < 0.01);
}

#[test]
fn size_ratio_ten_runs_clean() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let radii: Vec<f64> = (0..300)
        .map(|k| {
            if k < 10 {
                1e-3
            } else {
                1e-4 * (1.0 + 0.1 * rng.gen::<f64>())
            }
        })
        .collect();
    let mut dem = Dem::new(bed(1e7, radii, 4)).unwrap();
    dem.run(20_000).unwrap();
    all_inside(&dem);
}

#[test]
fn same_result_at_any_thread_count() {
    // one thread steps one loop at a time; two and three run the steps as a team between
    // list rebuilds, entered afresh at every call of `run`; a pressure wall as well, and the
    // walls' impulse summed step by step
    let run = |threads: usize, pressure: bool, pieces: u64| {
        let mut s = bed(1e7, vec![2e-4; 3000], 5);
        // random velocities up to 0.2 m/s, so that spheres collide and the list is rebuilt
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let Start::Given(p) = &mut s.start else {
            unreachable!()
        };
        for v in p.vel.iter_mut() {
            *v = Vector3::from_fn(|_, _| 0.2 * (rng.gen::<f64>() - 0.5));
        }
        if pressure {
            let TopWall::Fixed { z_m } = s.top else {
                unreachable!()
            };
            s.top = TopWall::Pressure {
                z0_m: z_m,
                target_pa: 20.0,
                speed_max_m_s: 2.0,
            };
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut dem = Dem::new(s).unwrap();
            dem.wall_ledger = Some(WallLedger::default());
            for _ in 0..pieces {
                dem.run(2400 / pieces).unwrap();
            }
            let ledger = dem.wall_ledger.unwrap();
            assert!(ledger.magnitude_ns > 0.0, "the walls are hit: {ledger:?}");
            assert!(
                dem.nl.builds > 2,
                "the run rebuilds its list: {}",
                dem.nl.builds
            );
            (
                dem.p.pos.clone(),
                dem.p.vel.clone(),
                dem.p.omega.clone(),
                dem.top_z_m.to_bits(),
                dem.top_force_n.to_bits(),
                dem.steps,
                ledger.impulse_ns.map(f64::to_bits),
                ledger.magnitude_ns.to_bits(),
            )
        })
    };
    for pressure in [false, true] {
        let one = run(1, pressure, 1);
        assert!(one == run(2, pressure, 1), "pressure wall {pressure}");
        assert!(one == run(3, pressure, 3), "pressure wall {pressure}");
    }
}
