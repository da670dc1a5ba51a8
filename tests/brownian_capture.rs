//! Capture by a Stoner–Wohlfarth-magnetized cylinder in a short Brownian run (thesis 003,
//! section 6.3), and the magnetization angle of the thesis cylinders in the 1 T field.
//! `cargo test --release --test brownian_capture -- --nocapture` prints the tables.

use nalgebra::Vector3;
use porelab::brownian::capture::{CaptureSet, CylinderBody};
use porelab::brownian::driver::run_steps;
use porelab::brownian::forces::WithUniform;
use porelab::brownian::magnetization::{
    cylinder_demag_factors, stoner_wohlfarth_magnet, StonerWohlfarth, THESIS_SATURATION,
};
use porelab::brownian::{
    run_rng, Fluid, LangevinMoment, Magnetic, Particles, Setup, Simulation, StepGuard,
};
use porelab::consts::MU0;
use porelab::driver::Hooks;
use porelab::magnetics::Cylinder;

const D_CYL: f64 = 600e-6;

/// Effective magnetization angle (from the axis) of the thesis cylinders (D = 600 um,
/// Ms = 985 kA/m) with the axis at alpha to a 1 T field: 0 at alpha = 0, between the axis and
/// the field otherwise, |M| = Ms, and non-decreasing in alpha.
#[test]
fn thesis_cylinders_in_one_tesla() {
    let h0 = 1.0 / MU0;
    for ld in [5.0 / 3.0, 20.0 / 3.0, 20.0] {
        let cyl = Cylinder::new(0.5 * D_CYL, 0.5 * ld * D_CYL).unwrap();
        let sw = StonerWohlfarth::for_cylinder(&cyl, THESIS_SATURATION).unwrap();
        let (np, nt) = cylinder_demag_factors(0.5 * D_CYL, 0.5 * ld * D_CYL).unwrap();
        println!(
            "L/D = {ld:.3}: N_par = {np:.6}, N_perp = {nt:.6}, H_K = {:.4e} A/m, h = H/H_K = {:.4}",
            sw.anisotropy_field(),
            h0 / sw.anisotropy_field()
        );
        let mut last = 0.0;
        for k in 0..=6 {
            let alpha = (15.0 * k as f64).to_radians();
            let axis = Vector3::new(alpha.cos(), 0.0, alpha.sin());
            let m = sw
                .magnetization(&axis, &Vector3::new(h0, 0.0, 0.0))
                .unwrap();
            assert!((m.norm() / THESIS_SATURATION - 1.0).abs() < 1e-14);
            let theta = (m.dot(&axis) / m.norm()).clamp(-1.0, 1.0).acos();
            println!(
                "  alpha = {:>4.1} deg: theta(M, axis) = {:>8.4} deg",
                alpha.to_degrees(),
                theta.to_degrees()
            );
            assert!(
                theta >= last - 1e-12 && theta <= alpha + 1e-12,
                "{theta} {alpha}"
            );
            if k == 0 {
                assert_eq!(theta, 0.0);
            }
            last = theta;
        }
    }
}

/// Particles of R = 75 nm (Table 6.1) started 1-4 um from the mid-plane surface of a
/// transversely placed L/D = 20 cylinder, on the side the magnetization points to, are captured
/// within 0.05 s; captured particles stay where they were captured; the far particle is not.
#[test]
fn side_particles_are_captured_and_stay_fixed() {
    let a = 75e-9;
    let rc = 0.5 * D_CYL;
    let cyl = Cylinder::new(rc, 10.0 * D_CYL).unwrap();
    let h0 = Vector3::new(1.0 / MU0, 0.0, 0.0);
    // Axis along z, field along x (alpha = 90 degrees).
    let magnet =
        stoner_wohlfarth_magnet(cyl, Vector3::zeros(), Vector3::z(), &h0, THESIS_SATURATION)
            .unwrap();
    let body = CylinderBody::from_magnet(&magnet).unwrap();
    let mut pos: Vec<Vector3<f64>> = (0..6)
        .map(|k| Vector3::new(rc + 1e-6 + 0.6e-6 * k as f64, 0.0, 1e-6 * k as f64))
        .collect();
    pos.push(Vector3::new(0.0, 0.0, 10.0 * D_CYL + 500e-6)); // far above the cap
    let particles = Particles::new(pos, a).unwrap();
    let n = particles.len();
    let fluid = Fluid::new(298.0, 1e-3).unwrap();
    let mut setup = Setup::new(particles, fluid, 5e-5).unwrap();
    setup.magnetic = Some(Magnetic {
        source: Box::new(WithUniform { h0, source: magnet }),
        moment: LangevinMoment::fixed(0.870e-16).unwrap(),
        dipole_pairs: false,
        cutoff: 30.0 * a,
    });
    setup.guard = StepGuard::Substep {
        max_fraction: 0.1,
        max_halvings: 12,
    };
    setup.capture = Some(CaptureSet::new(vec![body], n));
    let mut sim = Simulation::new(setup, run_rng(4120, 0)).unwrap();
    /// After every step: every captured particle sits where it was captured.
    struct StayFixed;
    impl Hooks<Simulation> for StayFixed {
        fn progress(&mut self, sim: &Simulation, _: Option<f64>, _: &str) {
            let capture = sim.capture().unwrap();
            for (i, p) in sim.particles().positions.iter().enumerate() {
                if let Some(c) = capture.capture(i) {
                    assert_eq!(*p, c.position);
                }
            }
        }
    }
    run_steps(&mut sim, 1000, &mut StayFixed).unwrap();
    let capture = sim.capture().unwrap();
    let deepest = (0..n)
        .filter_map(|i| capture.capture(i))
        .map(|c| body.signed_distance(&c.position) / a)
        .fold(f64::INFINITY, f64::min);
    let times: Vec<String> = (0..n)
        .map(|i| match capture.capture(i) {
            Some(c) => format!("{:.4} s", c.time),
            None => "-".into(),
        })
        .collect();
    println!(
        "capture times {times:?}; fraction {:.3}; smallest surface distance at capture {deepest:.3} R",
        capture.fraction()
    );
    assert_eq!(capture.fraction_of(&[0, 1, 2, 3, 4, 5]), 1.0);
    assert!(!capture.is_captured(6));
    // Captured on contact: within one radius of the surface, not deep inside.
    assert!(deepest > -1.0, "{deepest}");
}
