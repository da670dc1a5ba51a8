use super::*;
use crate::analysis;

/// Parameters of a short test run: scheme, Delta V per particle, halvings, tries per particle.
fn quick(n: usize, length: f64, seed: u64, scheme: Scheme, dv: f64, h: u32, tries: f64) -> Setup {
    let mut prm = Setup::new(n, length, seed);
    prm.scheme = scheme;
    prm.delta_v_per_particle = dv;
    prm.halvings = h;
    prm.tries_per_particle = tries;
    prm
}

#[test]
fn inertia_of_sphere_and_volume() {
    // L = 0: I = 2/5 m R^2 for a sphere; V = pi/6 for diameter 1.
    let (ixy, iz) = principal_inertia(0.0, 1.0);
    assert!((ixy - 0.4 * 0.25).abs() < 1e-15 && (iz - 0.1).abs() < 1e-15);
    assert!((particle_volume(0.0) - std::f64::consts::PI / 6.0).abs() < 1e-15);
}

#[test]
fn bad_parameters_are_errors() {
    let mut p = Setup::new(10, 0.0, 1);
    p.phi0 = 0.5;
    assert!(run_to_end(p.clone())
        .unwrap_err()
        .to_string()
        .contains("phi0"));
    let mut p = Setup::new(1, 0.0, 1);
    assert!(p.validate().is_err());
    p = Setup::new(10, -1.0, 1);
    assert!(p.validate().unwrap_err().to_string().contains("length"));
    p = Setup::new(10, 0.0, 1);
    p.dt = f64::NAN;
    assert!(p.validate().unwrap_err().to_string().contains("dt"));
    for bad in [f64::NAN, f64::INFINITY, -1.0, 100.0] {
        p = Setup::new(10, 0.0, 1);
        p.stage_budget_per_particle = Some(bad);
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("stage_budget_per_particle"), "{bad}: {e}");
    }
    // Too few long rods for the periodic box (the minimum image would miss contacts).
    assert!(random_start(10, 8.0, 0.05, 1).is_err());
}

#[test]
fn random_start_is_overlap_free_and_deterministic() {
    for &l in &[0.0, 2.0] {
        let a = random_start(60, l, 0.05, 7).unwrap();
        let b = random_start(60, l, 0.05, 7).unwrap();
        assert_eq!(a.positions, b.positions);
        assert!((a.packing_fraction() - 0.05).abs() < 1e-12);
        analysis::check_no_overlap(&a.view(), 0.0).unwrap();
    }
}

/// A large start is the random sequential addition renumbered along the Z-order curve: the
/// same particles (position, orientation and species together), numbered in the curve's order
/// (z_order of the result is the identity); a smaller one keeps the addition's numbering.
/// A mixture of two sphere sizes and rods, so a species left behind by the renumbering shows.
#[test]
fn large_starts_are_numbered_along_the_z_order_curve() {
    use crate::contact::ContactShape;
    let rod = ParticleShapes::monodisperse(1, 1.0).shapes[0];
    for (n, renumbered) in [(Z_ORDER_MIN_PARTICLES, true), (400, false)] {
        let particles = ParticleShapes::mixture(&[
            (ContactShape::Sphere { radius: 0.5 }, n / 2),
            (ContactShape::Sphere { radius: 0.35 }, n / 4),
            (rod, n - n / 2 - n / 4),
        ]);
        let placed =
            random_sequential_addition(Container::Periodic, particles.clone(), 0.05, 3).unwrap();
        let start = random_start_of(Container::Periodic, particles, 0.05, 3).unwrap();
        let identity: Vec<usize> = (0..n).collect();
        assert_eq!(relax::z_order(&start.positions) == identity, renumbered);
        assert!(relax::z_order(&placed.positions) != identity);
        let key = |p: &Packing, i: usize| {
            let q = p.orientations[i].quaternion();
            let bits = [
                p.positions[i].x,
                p.positions[i].y,
                p.positions[i].z,
                q.w,
                q.i,
                q.j,
                q.k,
            ];
            (bits.map(f64::to_bits), p.particles.species[i])
        };
        let sorted = |p: &Packing| {
            let mut v: Vec<_> = (0..n).map(|i| key(p, i)).collect();
            v.sort_unstable();
            v
        };
        assert_eq!(sorted(&start), sorted(&placed));
        assert_eq!(start.positions == placed.positions, !renumbered);
    }
}

#[test]
fn two_overlapping_spheres_are_separated() {
    for scheme in [Scheme::Revised, Scheme::Original] {
        let mut p = Packing {
            container: Container::Periodic,
            box_length: 10.0,
            particles: ParticleShapes::monodisperse(2, 0.0),
            positions: vec![Vector3::new(5.0, 5.0, 5.0), Vector3::new(5.9, 5.0, 5.0)],
            orientations: vec![UnitQuaternion::identity(); 2],
        };
        let mut prm = Setup::new(2, 0.0, 1);
        prm.scheme = scheme;
        let r = remove_overlaps(&mut p, &prm, 10_000).unwrap();
        assert!(r.is_ok(), "{scheme:?}: {r:?}");
        let d = (p.positions[1] - p.positions[0]).norm();
        assert!(d > 1.0 - prm.overlap_tol, "{scheme:?}: d = {d}");
        // Pushes along the line of centres only.
        for x in &p.positions {
            assert!((x.y - 5.0).abs() < 1e-12 && (x.z - 5.0).abs() < 1e-12);
        }
    }
}

#[test]
fn crossed_rods_are_separated_with_rotation() {
    // Two L = 3 rods crossing at an angle with a deep overlap, off-centre contact: the moves
    // must translate and rotate them apart.
    for scheme in [Scheme::Revised, Scheme::Original] {
        let q0 = UnitQuaternion::rotation_between(&Vector3::z(), &Vector3::x()).unwrap();
        let q1 =
            UnitQuaternion::rotation_between(&Vector3::z(), &Vector3::new(1.0, 1.0, 0.0)).unwrap();
        let mut p = Packing {
            container: Container::Periodic,
            box_length: 12.0,
            particles: ParticleShapes::monodisperse(2, 3.0),
            positions: vec![Vector3::new(6.0, 6.0, 6.0), Vector3::new(6.8, 6.5, 6.6)],
            orientations: vec![q0, q1],
        };
        let mut prm = Setup::new(2, 3.0, 1);
        prm.scheme = scheme;
        let r = remove_overlaps(&mut p, &prm, 100_000).unwrap();
        assert!(r.is_ok(), "{scheme:?}: {r:?}");
        let w = analysis::worst_gap(&p.view()).unwrap();
        if let Some(w) = w {
            assert!(w.gap >= -prm.overlap_tol, "{scheme:?}: {w:?}");
        }
        assert!(
            p.orientations[0].angle_to(&q0) > 0.0,
            "{scheme:?}: no rotation"
        );
    }
}

#[test]
fn small_sphere_run_is_overlap_free_dense_and_deterministic() {
    let prm = quick(40, 0.0, 3, Scheme::Original, 0.02, 3, 50.0);
    let a = run_to_end(prm.clone()).unwrap();
    let b = run_to_end(prm.clone()).unwrap();
    assert_eq!(a.packing.positions, b.packing.positions);
    assert!(a.jammed);
    analysis::check_no_overlap(&a.packing.view(), prm.overlap_tol).unwrap();
    // Any jammed sphere packing is denser than random loose packing (~0.55); 40 spheres with
    // few tries: only check that it compressed far beyond the start.
    assert!(
        a.packing.packing_fraction() > 0.45,
        "{}",
        a.packing.packing_fraction()
    );
    let hist = &a.history;
    assert!(hist
        .windows(2)
        .all(|w| w[1].packing_fraction > w[0].packing_fraction));
}

#[test]
fn small_rod_run_is_overlap_free() {
    for scheme in [Scheme::Revised, Scheme::Original] {
        let prm = quick(40, 1.0, 5, scheme, 0.05, 3, 100.0);
        let a = run_to_end(prm.clone()).unwrap();
        analysis::check_no_overlap(&a.packing.view(), prm.overlap_tol).unwrap();
        let phi = a.packing.packing_fraction();
        assert!(phi > 0.3, "{scheme:?}: phi = {phi}");
    }
}

#[test]
fn wall_overlaps_are_removed_by_virtual_particles() {
    // A sphere whose centre lies 0.3 D beyond the allowed radius R_cyl - R, and a rod whose
    // upper end pokes through the wall: each is moved back inside (sec. 2.2.4, Fig. 2.4).
    for scheme in [Scheme::Revised, Scheme::Original] {
        for (length, x, q) in [
            (0.0, Vector3::new(1.8, 0.0, 5.0), UnitQuaternion::identity()),
            (
                2.0,
                Vector3::new(0.9, 0.3, 5.0),
                UnitQuaternion::rotation_between(&Vector3::z(), &Vector3::new(1.0, 0.0, 1.0))
                    .unwrap(),
            ),
        ] {
            let mut p = Packing {
                container: Container::Cylinder { diameter: 3.0 },
                box_length: 10.0,
                particles: ParticleShapes::monodisperse(1, length),
                positions: vec![x],
                orientations: vec![q],
            };
            let before = analysis::wall_penetration(&p.view()).unwrap().unwrap().1;
            assert!(before > 0.1, "{scheme:?} L = {length}: {before}");
            let mut prm = Setup::new(1, length, 1);
            prm.scheme = scheme;
            let r = remove_overlaps(&mut p, &prm, 10_000).unwrap();
            assert!(r.is_ok(), "{scheme:?} L = {length}: {r:?}");
            let after = analysis::wall_penetration(&p.view())
                .unwrap()
                .map_or(0.0, |w| w.1);
            assert!(after <= prm.overlap_tol, "{scheme:?} L = {length}: {after}");
            // Moved inwards, not along the axis (the wall is the only overlap).
            assert!(p.positions[0].xy().norm() < x.xy().norm());
        }
    }
}

#[test]
fn cylinder_run_is_overlap_free_and_inside() {
    // (The revised scheme at dt = 0.1 compacts little within 100 N tries; README.md at commit 2c48ccd.)
    for (length, scheme) in [(0.0, Scheme::Original), (1.0, Scheme::Original)] {
        let mut prm = quick(60, length, 8, scheme, 0.05, 3, 100.0);
        prm.container = Container::Cylinder { diameter: 3.5 };
        let a = run_to_end(prm.clone()).unwrap();
        let b = run_to_end(prm.clone()).unwrap();
        assert_eq!(a.packing.positions, b.packing.positions);
        // Independent check: all pairs over the z images, and every end point inside.
        analysis::check_no_overlap(&a.packing.view(), prm.overlap_tol * (1.0 + 1e-6)).unwrap();
        let phi = a.packing.packing_fraction();
        assert!(phi > 0.35 && phi < 0.7405, "L = {length}: phi = {phi}");
        assert_eq!(phi, analysis::packing_fraction(&a.packing.view()).unwrap());
    }
    // A cylinder narrower than a particle is refused, naming the rule.
    let mut prm = Setup::new(10, 0.0, 1);
    prm.container = Container::Cylinder { diameter: 0.9 };
    let e = run_to_end(prm.clone()).unwrap_err().to_string();
    assert!(e.contains("cylinder diameter 0.9"), "{e}");
}

/// A binary sphere mixture (d = 1 and 1.4) and a sphere + rod mixture pack overlap-free with
/// both schemes; the packing fraction is the closed form sum n_k V_k / L^3 (V = pi d^3 / 6 for
/// spheres, pi R^2 (4R/3 + L) for rods, thesis eq. 2.2), computed here from the parameters.
#[test]
fn mixtures_pack_overlap_free_with_both_schemes() {
    use crate::contact::ContactShape as C;
    let pi = std::f64::consts::PI;
    let cases = [
        (
            vec![
                (C::Sphere { radius: 0.5 }, 60),
                (C::Sphere { radius: 0.7 }, 40),
            ],
            60.0 * pi / 6.0 + 40.0 * pi * 1.4f64.powi(3) / 6.0,
        ),
        (
            vec![
                (C::Sphere { radius: 0.5 }, 50),
                (
                    C::Spherocylinder {
                        radius: 0.4,
                        length: 1.2,
                    },
                    50,
                ),
            ],
            50.0 * pi / 6.0 + 50.0 * pi * 0.16 * (4.0 / 3.0 * 0.4 + 1.2),
        ),
    ];
    for (parts, vol) in cases {
        for scheme in [Scheme::Revised, Scheme::Original] {
            let n = parts.iter().map(|(_, c)| c).sum();
            let mut prm = quick(n, 0.0, 5, scheme, 0.02, 3, 100.0);
            prm.dt = 0.5;
            prm.particles = Some(ParticleShapes::mixture(&parts));
            let r = run_to_end(prm.clone()).unwrap();
            let p = &r.packing;
            analysis::check_no_overlap(&p.view(), prm.overlap_tol).unwrap();
            let phi = vol / p.box_length.powi(3);
            assert!(
                (p.packing_fraction() - phi).abs() < 1e-12 * phi,
                "{scheme:?}: {} vs {phi}",
                p.packing_fraction()
            );
            assert!(phi > 0.4, "{scheme:?}: compressed only to {phi}");
            // The large particles were placed first and every particle kept its species.
            assert_eq!(p.particles, ParticleShapes::mixture(&parts));
        }
    }
}

/// Monodisperse parameters given as a one-species table reproduce the classic run bitwise.
#[test]
fn one_species_table_is_the_monodisperse_run() {
    let a = quick(40, 0.6, 8, Scheme::Original, 0.02, 2, 50.0);
    let mut b = a.clone();
    b.particles = Some(ParticleShapes::monodisperse(40, 0.6));
    let (ra, rb) = (
        run_to_end(a.clone()).unwrap(),
        run_to_end(b.clone()).unwrap(),
    );
    assert_eq!(ra.packing.positions, rb.packing.positions);
    assert_eq!(ra.packing.orientations, rb.packing.orientations);
}

/// Bad particle tables are errors naming the rule.
#[test]
fn bad_particle_tables_are_errors() {
    use crate::contact::ContactShape as C;
    let mut p = Setup::new(3, 0.0, 1);
    p.particles = Some(ParticleShapes::mixture(&[(C::Sphere { radius: 0.5 }, 2)]));
    assert!(p.validate().unwrap_err().to_string().contains("n = 3"));
    p.particles = Some(ParticleShapes::mixture(&[(C::Sphere { radius: -0.5 }, 3)]));
    assert!(p.validate().unwrap_err().to_string().contains("radius"));
    let sb = C::Superquadric {
        semi_axes: [0.5; 3],
        exponents: [3.0; 3],
    };
    p.particles = Some(ParticleShapes::mixture(&[(sb, 3)]));
    p.scheme = Scheme::Original;
    assert!(p.validate().unwrap_err().to_string().contains("revised"));
}

/// The solver-free sampled pair check and [`analysis::check_no_overlap`] (walls included) of a
/// packing with superquadrics, both asserted within `tol`; returns the deepest sampled pair
/// overlap and the sample spacing.
pub(super) fn assert_sampled_overlap_free(p: &Packing, tol: f64) -> (f64, f64) {
    let s = analysis::sampled_overlap(&p.view(), analysis::OVERLAP_SAMPLES).unwrap();
    let deepest = s.worst.map_or(0.0, |w| w.2);
    assert!(deepest <= tol, "{:?} in {:?}", s.worst, p.container);
    analysis::check_no_overlap(&p.view(), tol).unwrap();
    (deepest, s.spacing)
}

/// Smoke test (fast tier): a small superball packing (thesis ch. 4, revised scheme) ends
/// overlap-free under the solver-free sampled check, compressed far beyond its start.
#[test]
fn small_superball_packing_is_overlap_free_by_the_sampled_check() {
    use crate::contact::ContactShape as C;
    let sb = C::Superquadric {
        semi_axes: [0.5; 3],
        exponents: [3.0; 3],
    };
    let mut prm = quick(24, 0.0, 4, Scheme::Revised, 0.05, 1, 50.0);
    prm.dt = 0.5;
    prm.particles = Some(ParticleShapes::mixture(&[(sb, 24)]));
    let t = std::time::Instant::now();
    let r = run_to_end(prm.clone()).unwrap();
    let p = &r.packing;
    let (deepest, spacing) = assert_sampled_overlap_free(p, prm.overlap_tol);
    let phi = p.packing_fraction();
    eprintln!(
        "24 superballs g = 3: phi = {phi:.4}, deepest sampled {deepest:.2e}, spacing {:.4}, \
         {} tries, {:.1} s",
        spacing,
        r.total_tries,
        t.elapsed().as_secs_f64()
    );
    assert!(phi > 0.4, "phi = {phi}");
}

/// A dense polydisperse packing (diameters 0.5-1.5, one species per particle, original scheme
/// with beta 1.3 to compact hard, then optionally the collective relaxation) ends overlap-free by the brute-force check (a
/// stress test of dense polydisperse mixtures).
#[test]
fn dense_polydisperse_spheres_end_overlap_free() {
    use crate::contact::ContactShape as C;
    let n = 150;
    // Diameters spread evenly over [0.5, 1.5] in a scrambled order (golden-ratio sequence).
    let shapes = (0..n)
        .map(|k| C::Sphere {
            radius: 0.5 * (0.5 + (k as f64 * 0.618_033_988_749_895).fract()),
        })
        .collect();
    let mut prm = quick(n, 0.0, 6, Scheme::Original, 0.02, 3, 200.0);
    prm.beta = 1.3;
    prm.particles = Some(ParticleShapes::per_particle(shapes));
    // Also with the collective relaxation as final stage (forces of unequal spheres).
    let relax = Stage {
        scheme: Scheme::Relax,
        delta_v_per_particle: 0.002,
        halvings: 3,
        tries_per_particle: 1000.0,
        stage_budget_per_particle: None,
        beta: 1.3,
        dt: 0.1,
    };
    for last in [None, Some(relax)] {
        prm.final_stage = last;
        let r = run_to_end(prm.clone()).unwrap();
        analysis::check_no_overlap(&r.packing.view(), prm.overlap_tol).unwrap();
        assert!(
            r.packing.packing_fraction() > 0.55,
            "{}",
            r.packing.packing_fraction()
        );
    }
}

/// Two equal spheres overlapping by 0.19 D: the collective relaxation separates them to within
/// the tolerance, moving them symmetrically (the pair forces are equal and opposite, so the
/// centre of mass stays put), and a rerun gives bitwise the same positions.
#[test]
fn relax_separates_a_pair_and_keeps_the_centre_of_mass() {
    let mut prm = quick(2, 0.0, 1, Scheme::Relax, 0.01, 0, 1000.0);
    prm.dt = 0.1;
    let mk = || Packing {
        container: Container::Periodic,
        box_length: 6.0,
        particles: ParticleShapes::monodisperse(2, 0.0),
        positions: vec![Vector3::new(2.6, 3.0, 3.0), Vector3::new(3.4, 3.1, 2.9)],
        orientations: vec![UnitQuaternion::identity(); 2],
    };
    let com0 = (mk().positions[0] + mk().positions[1]) / 2.0;
    let (mut a, mut b) = (mk(), mk());
    let tries = remove_overlaps(&mut a, &prm, 2000).unwrap().unwrap();
    remove_overlaps(&mut b, &prm, 2000).unwrap().unwrap();
    assert_eq!(a.positions, b.positions);
    let d = (a.positions[1] - a.positions[0]).norm();
    // FIRE carries momentum: the last iteration may overshoot contact, by at most one step of
    // each particle (relax::MAX_STEP = 0.02 D).
    assert!(
        d >= 1.0 - prm.overlap_tol && d < 1.04,
        "distance {d}, {tries} tries"
    );
    let com = (a.positions[0] + a.positions[1]) / 2.0;
    assert!(
        (com - com0).norm() < 1e-14,
        "centre of mass moved {:e}",
        (com - com0).norm()
    );
}

/// A force-balanced jammed configuration is recognised as such: four spheres on a line
/// around a periodic box of length 3.9 (each overlaps both neighbours by 0.025 D, the forces
/// cancel exactly); the relaxation gives up before its first move instead of spending its
/// budget, and leaves the configuration unchanged.
#[test]
fn relax_detects_a_balanced_jammed_configuration() {
    let prm = quick(4, 0.0, 1, Scheme::Relax, 0.01, 0, 1000.0);
    let l = 3.9;
    let mut p = Packing {
        container: Container::Periodic,
        box_length: l,
        particles: ParticleShapes::monodisperse(4, 0.0),
        positions: (0..4)
            .map(|k| Vector3::new(k as f64 * l / 4.0, 0.5, 0.5))
            .collect(),
        orientations: vec![UnitQuaternion::identity(); 4],
    };
    let before = p.positions.clone();
    assert_eq!(remove_overlaps(&mut p, &prm, 4000).unwrap(), Err(0));
    assert_eq!(p.positions, before);
}

/// Spherocylinders (L/D = 2) packed with the relaxation as final stage: overlap-free by the
/// brute-force check, denser than the start, orientations changed (torques act), and the run
/// is reproducible.
#[test]
fn relax_stage_packs_spherocylinders_overlap_free() {
    let mut prm = quick(150, 2.0, 5, Scheme::Original, 0.05, 0, 200.0);
    prm.final_stage = Some(Stage {
        scheme: Scheme::Relax,
        delta_v_per_particle: 0.01,
        halvings: 2,
        tries_per_particle: 500.0,
        stage_budget_per_particle: None,
        beta: 0.5,
        dt: 0.2,
    });
    let a = run_to_end(prm.clone()).unwrap();
    let b = run_to_end(prm.clone()).unwrap();
    assert_eq!(a.packing.orientations, b.packing.orientations);
    analysis::check_no_overlap(&a.packing.view(), prm.overlap_tol).unwrap();
    assert!(
        a.packing.packing_fraction() > 0.4,
        "{}",
        a.packing.packing_fraction()
    );
}

/// The sphere jamming schedule on 200 spheres: overlap-free, dense, and a contact network
/// with at least 5.5 contacts per non-rattler (extrapolated to zero cut-off, sec. 2.2.5).
#[test]
fn jammed_spheres_schedule_settles_contacts() {
    let prm = Setup::jammed_spheres(200, 3);
    let r = run_to_end(prm.clone()).unwrap();
    let v = r.packing.view();
    analysis::check_no_overlap(&v, prm.overlap_tol).unwrap();
    let gaps = analysis::pair_gaps(&v, 1e-5).unwrap();
    let (c0, _) =
        analysis::extrapolated_contacts(200, &gaps, &[1e-8, 1e-7, 1e-6, 1e-5], Some(4)).unwrap();
    let phi = r.packing.packing_fraction();
    eprintln!(
        "200 spheres, jammed schedule: phi {phi:.4}, C0 {c0:.3}, {} tries",
        r.total_tries
    );
    assert!(phi > 0.62 && c0 > 5.5, "phi {phi}, contacts {c0}");
}

/// A stage budget bounds the moves of its stage (accepted and failed steps) by
/// `stage_budget_per_particle` N, ends the stage before its halvings are spent, and keeps every
/// accepted step: the budgeted run is the unbudgeted one cut short (same configurations up to
/// the cut, since the run uses no random numbers after the start).
#[test]
fn stage_budget_bounds_the_moves_and_cuts_the_run_short() {
    let n = 200;
    let mut free = Setup::jammed_spheres(n, 3);
    free.final_stage.as_mut().unwrap().stage_budget_per_particle = None;
    let full = run_to_end(free.clone()).unwrap();
    assert!(!full.stage_budget_spent);
    // Stage 2's moves in the unbudgeted run: everything after stage 1's last step.
    let mut state = Mcm::new(free.clone()).unwrap();
    while state.state().stage == 0 {
        state.step().unwrap();
    }
    let stage1_tries = state.state().total_tries;
    let stage2_full = full.total_tries - stage1_tries;
    // Half of it, but at least one step's budget.
    let budget_pp = (stage2_full as f64 / n as f64 / 2.0).max(2000.0);
    let mut capped = free.clone();
    capped
        .final_stage
        .as_mut()
        .unwrap()
        .stage_budget_per_particle = Some(budget_pp);
    let cut = run_to_end(capped.clone()).unwrap();
    assert!(cut.stage_budget_spent && cut.jammed);
    let stage2_cut = cut.total_tries - stage1_tries;
    assert!(
        stage2_cut as f64 <= budget_pp * n as f64 && stage2_cut < stage2_full,
        "stage 2 moves {stage2_cut} (budget {}, unbudgeted {stage2_full})",
        budget_pp * n as f64
    );
    // Every accepted step of the cut run is the unbudgeted run's step.
    assert!(cut.history.len() <= full.history.len());
    for (a, b) in cut.history.iter().zip(&full.history) {
        assert_eq!(
            (a.packing_fraction.to_bits(), a.tries),
            (b.packing_fraction.to_bits(), b.tries)
        );
    }
    analysis::check_no_overlap(&cut.packing.view(), capped.overlap_tol).unwrap();
    // A budget below one step's is refused by name.
    let mut bad = free.clone();
    bad.final_stage.as_mut().unwrap().stage_budget_per_particle = Some(100.0);
    let e = bad.validate().unwrap_err().to_string();
    assert!(e.contains("stage_budget_per_particle"), "{e}");
}

/// The analysis' cell-binned pair search returns the brute force's list, pair for pair and gap for gap
/// (bitwise): a dense sphere packing (many near contacts, pairs through the boundary),
/// random rods, and a mixture of superballs, ellipsoids and spheres with overlaps, at gaps
/// from 0 to 1; and boxes that fit fewer than three reaches (the brute force itself).
#[test]
fn binned_pair_search_equals_the_brute_force() {
    use crate::analysis::{pair_gaps, pair_gaps_brute_force, Configuration};
    use crate::contact::pairgen::random_rotation;
    use crate::contact::ContactShape;
    use rand::{Rng, SeedableRng};
    let mut prm = Setup::new(400, 0.0, 7);
    prm.scheme = Scheme::Original;
    let dense = run_to_end(prm.clone()).unwrap().packing;
    let rods = random_start(300, 1.0, 0.3, 4).unwrap();
    let small = random_start(40, 0.0, 0.3, 4).unwrap();
    let mut checked = 0;
    for p in [&dense, &rods, &small] {
        let v = p.view();
        for max_gap in [0.0, 1e-3, 0.3, 1.0] {
            let binned = pair_gaps(&v, max_gap).unwrap();
            assert_eq!(binned, pair_gaps_brute_force(&v, max_gap).unwrap());
            checked += binned.len();
        }
    }
    // Mixture: superballs (gamma 3), ellipsoids and spheres at random in a box of 3.3
    // reaches, overlaps included.
    let shapes = [
        ContactShape::Superquadric {
            semi_axes: [0.5; 3],
            exponents: [3.0; 3],
        },
        ContactShape::Ellipsoid {
            semi_axes: [0.6, 0.4, 0.3],
        },
        ContactShape::Sphere { radius: 0.45 },
    ];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let box_length = 7.0;
    let n = 150;
    let species: Vec<usize> = (0..n).map(|i| i % 3).collect();
    let pos: Vec<Vector3<f64>> = (0..n)
        .map(|_| Vector3::new(rng.gen(), rng.gen(), rng.gen()) * box_length)
        .collect();
    let ori: Vec<UnitQuaternion<f64>> = (0..n).map(|_| random_rotation(&mut rng)).collect();
    let r = Configuration::periodic(box_length, &shapes, &species, &pos, &ori);
    let binned = pair_gaps(&r, 0.1).unwrap();
    assert_eq!(binned, pair_gaps_brute_force(&r, 0.1).unwrap());
    assert!(binned.iter().any(|g| g.gap < 0.0));
    checked += binned.len();
    assert!(checked > 5000, "{checked} pairs");
}
