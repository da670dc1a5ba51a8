//! Stress and exploration runs of the MCM packing engine (`cargo test --release --test
//! stress_packing -- --ignored --nocapture`).

use porelab::analysis;
use porelab::contact::ContactShape;
use porelab::packing::{run_to_end, ParticleShapes, Scheme, Setup};
use std::time::Instant;

fn env_f(name: &str, d: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(d)
}

/// A run with parameters from the environment (MCM_N, MCM_L, MCM_DV, MCM_H, MCM_TRIES,
/// MCM_TOL, MCM_DT, MCM_SEED, MCM_ORIG), printing packing fraction, contacts and time.
#[test]
#[ignore = "exploration run driven by the MCM_* environment variables"]
fn explore() {
    let mut p = Setup::new(
        env_f("MCM_N", 200.0) as usize,
        env_f("MCM_L", 0.0),
        env_f("MCM_SEED", 1.0) as u64,
    );
    p.delta_v_per_particle = env_f("MCM_DV", p.delta_v_per_particle);
    p.halvings = env_f("MCM_H", p.halvings as f64) as u32;
    p.tries_per_particle = env_f("MCM_TRIES", p.tries_per_particle);
    p.overlap_tol = env_f("MCM_TOL", p.overlap_tol);
    p.dt = env_f("MCM_DT", p.dt);
    p.beta = env_f("MCM_BETA", p.beta);
    if env_f("MCM_ORIG", 0.0) > 0.0 {
        p.scheme = Scheme::Original;
    }
    let t = Instant::now();
    let mut r = run_to_end(p.clone()).unwrap();
    if env_f("MCM_H2", 0.0) > 0.0 {
        eprintln!(
            "stage 1: phi={:.4} steps={} tries={} secs={:.2}",
            r.packing.packing_fraction(),
            r.history.len(),
            r.total_tries,
            t.elapsed().as_secs_f64()
        );
        let mut q = p.clone();
        q.beta = env_f("MCM_BETA2", 0.5);
        q.halvings = env_f("MCM_H2", 0.0) as u32;
        q.delta_v_per_particle = env_f("MCM_DV2", p.delta_v_per_particle);
        q.tries_per_particle = env_f("MCM_TRIES2", p.tries_per_particle);
        q.dt = env_f("MCM_DT2", p.dt);
        if env_f("MCM_REV2", 0.0) > 0.0 {
            q.scheme = Scheme::Revised;
        }
        let r2 = porelab::packing::run_from(q.clone(), r.packing.clone()).unwrap();
        r = r2;
    }
    let secs = t.elapsed().as_secs_f64();
    let v = r.packing.view();
    let gaps = analysis::pair_gaps(&v, 1e-2).unwrap();
    let worst = gaps.iter().map(|g| g.gap).fold(f64::INFINITY, f64::min);
    let tol = p.overlap_tol;
    let deltas: Vec<f64> = vec![1e-8, 1e-7, 1e-6, 1e-5];
    let minc = if p.length == 0.0 { 4 } else { 5 };
    let (c0, _) = analysis::extrapolated_contacts(v.n(), &gaps, &deltas, Some(minc)).unwrap();
    let (c_raw, rat) = analysis::mean_contacts(v.n(), &gaps, 10.0 * tol, Some(minc));
    let (c_all, _) = analysis::mean_contacts(v.n(), &gaps, 10.0 * tol, None);
    let s = analysis::nematic_order(&r.packing.axes()).unwrap();
    eprintln!(
        "N={} L={} phi={:.4} steps={} failed={} tries={} worst_gap={:.2e} C(10tol)={:.3} C_norattle={:.3} rattlers={} C0={:.3} S={:.3} secs={:.2}",
        v.n(), p.length, r.packing.packing_fraction(), r.history.len(), r.failed_steps, r.total_tries, worst, c_all, c_raw, rat, c0, s, secs
    );
    for d in [1e-8, 1e-6, 1e-5, 1e-4, 1e-3] {
        eprintln!(
            "  C({d:e}) = {:.3}",
            analysis::mean_contacts(v.n(), &gaps, d, None).0
        );
    }
    for h in r.history.iter().rev().take(3) {
        eprintln!("  {:?}", h);
    }
}

/// Superball packings (thesis 003 sec. 4.5, Fig. 4.5; case 509) with parameters from the
/// environment: SB_N (particles, 50), SB_GAMMA (3), SB_SEED (1), SB_TRIES (tries per particle,
/// 100), SB_DT (0.5), SB_DV (Delta V per particle, 0.02), SB_H (halvings, 3), SB_CHECK (1:
/// certified and sampled overlap checks and contacts of the final configuration, 0: none).
/// Prints one `RESULT` line.
#[test]
#[ignore = "exploration run driven by the SB_* environment variables"]
fn explore_superballs() {
    let n = env_f("SB_N", 50.0) as usize;
    let g = env_f("SB_GAMMA", 3.0);
    let mut p = Setup::new(n, 0.0, env_f("SB_SEED", 1.0) as u64);
    p.particles = Some(ParticleShapes::mixture(&[(
        ContactShape::Superquadric {
            semi_axes: [0.5; 3],
            exponents: [g; 3],
        },
        n,
    )]));
    p.scheme = Scheme::Revised;
    p.dt = env_f("SB_DT", 0.5);
    p.delta_v_per_particle = env_f("SB_DV", 0.02);
    p.halvings = env_f("SB_H", 3.0) as u32;
    p.tries_per_particle = env_f("SB_TRIES", 100.0);
    p.overlap_tol = 1e-4;
    let t = Instant::now();
    let r = run_to_end(p.clone()).unwrap();
    let secs = t.elapsed().as_secs_f64();
    let v = r.packing.view();
    let mut line = format!(
        "RESULT N={n} gamma={g} seed={} tries={} dt={} dv={} h={} phi={:.5} steps={} failed={} moves={} secs={:.2}",
        p.seed,
        p.tries_per_particle,
        p.dt,
        p.delta_v_per_particle,
        p.halvings,
        r.packing.packing_fraction(),
        r.history.len(),
        r.failed_steps,
        r.total_tries,
        secs
    );
    if env_f("SB_CHECK", 1.0) > 0.0 {
        let gaps = analysis::pair_gaps(&v, 1e-3).unwrap();
        let worst = gaps.iter().map(|g| g.gap).fold(f64::INFINITY, f64::min);
        let (c, _) = analysis::mean_contacts(v.n(), &gaps, 1e-3, None);
        let s = analysis::sampled_overlap(&v, analysis::OVERLAP_SAMPLES).unwrap();
        line += &format!(
            " worst_gap={worst:.3e} sampled={:.3e} C(1e-3)={c:.3}",
            s.worst.map_or(0.0, |w| w.2)
        );
    }
    println!("{line}");
}

/// Rods too long for the periodic box: a clear error naming the rule, never a silent result.
#[test]
fn long_rods_in_small_box_are_an_error() {
    let p = Setup::new(50, 20.0, 1);
    let e = run_to_end(p.clone()).unwrap_err().to_string();
    assert!(
        e.contains("box length") && e.contains("more particles"),
        "{e}"
    );
}

/// A tiny Delta V with a step limit ends overlap-free (not jammed), with the history
/// monotone.
#[test]
fn tiny_delta_v_ends_overlap_free() {
    let mut p = Setup::new(64, 1.0, 2);
    p.delta_v_per_particle = 1e-9;
    p.max_steps = 20;
    let r = run_to_end(p.clone()).unwrap();
    assert!(!r.jammed);
    assert_eq!(r.history.len(), 20);
    analysis::check_no_overlap(&r.packing.view(), p.overlap_tol * (1.0 + 1e-6)).unwrap();
}

/// Runs `p` and asserts the stress contract: the run ends overlap-free (brute force, contact
/// tolerance) or stops with the minimum-image error once the box is shorter than twice a rod;
/// never a silently overlapping result.
fn overlap_free_or_box_error(p: &Setup, label: &str) {
    match run_to_end(p.clone()) {
        Ok(r) => {
            analysis::check_no_overlap(&r.packing.view(), p.overlap_tol * (1.0 + 1e-6)).unwrap();
            eprintln!(
                "{label}, {:?}: phi = {:.5}, steps = {}",
                p.scheme,
                r.packing.packing_fraction(),
                r.history.len()
            );
        }
        Err(e) => {
            let e = e.to_string();
            assert!(e.contains("box length") && e.contains("pair cutoff"), "{e}");
            eprintln!("{label}, {:?}: {e}", p.scheme);
        }
    }
}

/// Aspect ratio 10 with a small try budget, with the original scheme and with the collective
/// relaxation.
#[test]
fn aspect_ten_ends_overlap_free() {
    for scheme in [Scheme::Original, Scheme::Relax] {
        let mut p = Setup::new(300, 10.0, 3);
        p.scheme = scheme;
        p.dt = 0.5;
        p.delta_v_per_particle = 0.5;
        p.halvings = 1;
        p.tries_per_particle = 20.0;
        overlap_free_or_box_error(&p, "L/D = 10");
    }
}

/// Aspect ratio L/D = 100 (thesis: phi0 = 0.005 for aspect ratios >= 50, sec. 2.2.6) with a
/// coarse schedule, original scheme and collective relaxation.
#[test]
fn aspect_hundred_ends_overlap_free_or_with_a_clear_error() {
    for scheme in [Scheme::Original, Scheme::Relax] {
        let mut p = Setup::new(600, 100.0, 4);
        p.scheme = scheme;
        p.dt = 1.0;
        p.phi0 = 0.005;
        p.delta_v_per_particle = 500.0;
        p.halvings = 1;
        // One relaxation iteration moves every rod; it needs more of them than single moves.
        p.tries_per_particle = if scheme == Scheme::Relax { 200.0 } else { 5.0 };
        p.max_steps = 10;
        overlap_free_or_box_error(&p, "L/D = 100");
    }
}

/// A hard cylinder barely wider than a sphere (D_cyl = 1.2): the spheres must line up; the
/// final configuration is overlap-free and inside the wall (independent check).
#[test]
fn narrow_cylinder_ends_overlap_free_and_inside() {
    let mut p = Setup::new(40, 0.0, 6);
    p.scheme = Scheme::Original;
    p.container = porelab::packing::Container::Cylinder { diameter: 1.2 };
    p.delta_v_per_particle = 0.05;
    p.halvings = 4;
    p.tries_per_particle = 100.0;
    let r = run_to_end(p.clone()).unwrap();
    analysis::check_no_overlap(&r.packing.view(), p.overlap_tol * (1.0 + 1e-6)).unwrap();
    // Centres lie within 0.1 of the axis, so neighbours along it are at least
    // sqrt(1 - 0.2^2) apart axially (lateral offset at most D_cyl - D = 0.2): at most one
    // sphere per 0.9798 of length, phi <= (pi/6) / (pi 0.36 0.9798) = 0.4725 (plus the allowed
    // overlap of 1e-4). A larger value would mean overlaps or wall penetration missed.
    let phi = r.packing.packing_fraction();
    let spacing = (1.0f64 - 0.2 * 0.2).sqrt() - p.overlap_tol;
    let bound = (std::f64::consts::PI / 6.0) / (std::f64::consts::PI * 0.36 * spacing);
    assert!(
        phi <= bound,
        "phi = {phi} above the single-file bound {bound}"
    );
    eprintln!("D_cyl = 1.2: phi = {phi:.4} (single-file bound {bound:.4})");
}

/// Tight wedges (thesis sec. 2.2.4), where a sphere wedged between two walls can be pushed
/// far through one of them: with the thesis' virtual-particle placement such spheres escaped
/// and the run ended "overlap-free" outside the walls (30 degrees, l_w,min + 1e-3: phi 0.381
/// against the one-row 0.324). Over 4 angles, 3 lengths just above l_w,min (eq. 2.12) and 3
/// seeds, every run must end inside the walls and overlap-free (independent brute force and
/// wall distances in `analysis`), and no denser than one row at spacing 1 - tol allows.
#[test]
fn tight_wedges_end_inside_and_overlap_free() {
    use porelab::packing::{wedge_min_length, Container, RADIUS};
    let (mut runs, mut failures) = (0, Vec::new());
    for deg in [9.0f64, 15.0, 30.0, 45.0] {
        let a = deg.to_radians();
        for eps in [1e-6, 1e-3, 1e-2] {
            for seed in 1..=3u64 {
                let l_w = wedge_min_length(RADIUS, 0.0, a) + eps;
                let mut p = Setup::new(40, 0.0, seed);
                p.scheme = Scheme::Original;
                p.container = Container::Wedge {
                    length: l_w,
                    angle_rad: a,
                };
                let r = run_to_end(p.clone()).unwrap();
                runs += 1;
                let v = r.packing.view();
                let ok = analysis::check_no_overlap(&v, p.overlap_tol * (1.0 + 1e-6));
                // One row at spacing >= 1 - tol: phi <= (pi/6) / (A_w (1 - tol)) up to the
                // sideways freedom, which at these eps changes the spacing by < 2e-4.
                let area = 0.5 * l_w * l_w * a.tan();
                let bound = std::f64::consts::PI / 6.0 / (area * (1.0 - p.overlap_tol - 2e-4));
                let phi = r.packing.packing_fraction();
                if ok.is_err() || (eps <= 1e-3 && phi > bound) {
                    failures.push(format!(
                        "{deg} deg, eps {eps}, seed {seed}: phi {phi}, {ok:?}"
                    ));
                }
            }
        }
    }
    eprintln!("tight wedges: {} of {runs} runs failed", failures.len());
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Work-precision of the MCM (benchmark): packing fraction reached against the try
/// budget per compression step, plain schedule (beta 0.5) and over-relaxed (beta 1.3), for
/// MCM_N spheres (default 500), printing tries, seconds and phi per budget.
#[test]
#[ignore = "benchmark: cargo test --release --test stress_packing -- --ignored --nocapture work_precision"]
fn work_precision() {
    let n = env_f("MCM_N", 500.0) as usize;
    eprintln!("N = {n} spheres, seed 1, original scheme, Delta V 0.01 N, 6 halvings");
    eprintln!("beta,tries_per_particle,total_tries,seconds,phi");
    for beta in [0.5, 1.3] {
        for tries in [100.0, 300.0, 1000.0, 3000.0] {
            let mut p = Setup::new(n, 0.0, 1);
            p.scheme = Scheme::Original;
            p.beta = beta;
            p.tries_per_particle = tries;
            let t = Instant::now();
            let r = run_to_end(p.clone()).unwrap();
            eprintln!(
                "{beta},{tries},{},{:.2},{:.4}",
                r.total_tries,
                t.elapsed().as_secs_f64(),
                r.packing.packing_fraction()
            );
        }
    }
}
