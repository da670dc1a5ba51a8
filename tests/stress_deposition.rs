//! Stress runs of the deposition engine (seed 000): extreme aspect ratios, dense starts, tiny
//! K_max, polydisperse blends. Every run must end with an overlap-free deposit or a clear
//! error, never overlapping and never with a non-finite coordinate. The overlap check here is
//! independent of the engine's neighbour search and prefilters: all pairs, all nine lateral
//! images, the full Perram-Wertheim maximum (no early exit), and the substrate by the
//! rotation matrix.

use porelab::contact::contact_ellipsoid_ellipsoid::pw_max;
use porelab::contact::Pose;
use porelab::deposition::Layer;
use porelab::driver::NoHooks;
use porelab::scene::deposition::{parse_scene, run_one};

/// Deepest overlap found: (1 - sqrt(max F)) for pairs (0 if none), and the deepest substrate
/// penetration relative to the particle's half height.
fn independent_overlap(layer: &Layer) -> (f64, f64) {
    let l = layer.box_side_m;
    let mut worst_pair = 0.0f64;
    let mut worst_floor = 0.0f64;
    let n = layer.grains.len();
    for i in 0..n {
        let gi = &layer.grains[i];
        let pi = &layer.poses[i];
        let r = pi.orientation.to_rotation_matrix().into_inner();
        let [a, b, c] = gi.semi_axes;
        let hh =
            ((a * r[(2, 0)]).powi(2) + (b * r[(2, 1)]).powi(2) + (c * r[(2, 2)]).powi(2)).sqrt();
        worst_floor = worst_floor.max((hh - pi.position.z) / hh);
        assert!(
            pi.position.iter().all(|x| x.is_finite()),
            "particle {i} not finite"
        );
        for j in i..n {
            let gj = &layer.grains[j];
            let pj = &layer.poses[j];
            for sx in -1..=1 {
                for sy in -1..=1 {
                    if i == j && sx == 0 && sy == 0 {
                        continue;
                    }
                    let shift = nalgebra::Vector3::new(sx as f64 * l, sy as f64 * l, 0.0);
                    let pb = pj.position + shift;
                    let reach = gi.outer_radius_m + gj.outer_radius_m;
                    if (pb - pi.position).norm() >= reach {
                        continue;
                    }
                    let f = pw_max(
                        &Pose::new(pi.position, pi.orientation),
                        &gi.semi_axes,
                        &Pose::new(pb, pj.orientation),
                        &gj.semi_axes,
                    )
                    .f;
                    worst_pair = worst_pair.max(1.0 - f.max(0.0).sqrt());
                }
            }
        }
    }
    (worst_pair, worst_floor)
}

fn scene(particles: usize, solids: f64, species: &str, extra: &str) -> String {
    format!(
        "kind = \"deposition\"\nseed = 9\nruns = 1\n[film]\nparticles = {particles}\n\
         solids_percent = {solids}\n{species}\n{extra}\n"
    )
}

#[test]
fn stress_runs_end_overlap_free_or_with_a_clear_error() {
    let sp = |axes: &str| format!("[[species]]\nname = \"p\"\nsemi_axes_m = {axes}\n");
    let cases = vec![
        ("platelets aspect 50", scene(60, 40.0, &sp("[1e-6, 1e-6, 0.02e-6]"), "[deposition]\nmax_sweeps = 3000")),
        ("needles aspect 50", scene(60, 40.0, &sp("[1e-6, 0.02e-6, 0.02e-6]"), "[deposition]\nmax_sweeps = 3000")),
        ("needles aspect 50, 65 % solids", scene(60, 65.0, &sp("[1e-6, 0.02e-6, 0.02e-6]"), "[deposition]\nmax_sweeps = 3000")),
        ("spheres, dense start 72 % solids", scene(150, 72.0, &sp("[0.5e-6, 0.5e-6, 0.5e-6]"), "")),
        ("triaxial, tiny K_max", scene(80, 60.0, &sp("[0.5e-6, 0.3e-6, 0.1e-6]"), "[deposition]\nk_max_m2 = 1e-20\nmax_sweeps = 300")),
        (
            "polydisperse blend",
            scene(
                150,
                60.0,
                "[[species]]\nname = \"clay\"\nsemi_axes_m = [0.5e-6, 0.5e-6, 0.1e-6]\nlognormal_sigma = 0.3\n\
                 [[species]]\nname = \"gcc\"\nsemi_axes_m = [0.3e-6, 0.15e-6, 0.15e-6]\n\
                 size_table = [[0.5, 1.0], [1.0, 2.0], [2.0, 0.5]]",
                "[deposition]\nmax_sweeps = 3000",
            ),
        ),
    ];
    let mut failures = 0;
    for (name, text) in &cases {
        let s = parse_scene(text, name).unwrap_or_else(|e| panic!("{name}: scene refused: {e}"));
        match run_one(&s, 0, &mut NoHooks) {
            Ok(r) => {
                let (pair, floor) = independent_overlap(&r.deposit.layer);
                println!(
                    "{name}: {} sweeps, converged {}, deepest pair overlap {pair:.2e}, floor {floor:.2e}",
                    r.deposit.outcome.sweeps, r.deposit.outcome.converged
                );
                // Touching pairs reach F = 1 to the PW tolerance (1e-10 in lambda).
                assert!(pair < 1e-8, "{name}: overlapping deposit ({pair:e})");
                assert!(
                    floor <= 1e-12,
                    "{name}: particle below the substrate ({floor:e})"
                );
                assert!(r.measures.layer_porosity.is_finite());
            }
            Err(e) => {
                failures += 1;
                let m = e.to_string();
                println!("{name}: clear error: {m}");
                assert!(
                    m.len() > 20 && !m.contains("NaN"),
                    "{name}: unclear error `{m}`"
                );
            }
        }
    }
    println!(
        "{failures} of {} stress runs ended with an error",
        cases.len()
    );
}

#[test]
fn bad_scene_values_name_the_key() {
    let sp = "[[species]]\nname = \"p\"\nsemi_axes_m = [1e-6, 1e-6, 1e-7]\n";
    for (extra, key) in [
        ("[deposition]\nk_max_m2 = -1", "k_max_m2"),
        ("[deposition]\nstop_fraction = 2", "stop_fraction"),
        ("[deposition]\ntemperature_K = -3", "temperature_K"),
        ("[start]\nrsa_limit = 0.5", "rsa_limit"),
        (
            "[analysis]\nnodes_per_shortest_semi_axis = 1",
            "nodes_per_shortest_semi_axis",
        ),
        ("[deposition]\nviscosty_pa_s = 1", "viscosty_pa_s"),
    ] {
        let text = scene(50, 60.0, sp, extra);
        let e = parse_scene(&text, "s.toml")
            .err()
            .unwrap_or_else(|| panic!("{extra}: accepted"));
        assert!(
            e.to_string().contains(key),
            "{extra}: `{e}` does not name {key}"
        );
    }
    let e = parse_scene(&scene(50, 120.0, sp, ""), "s.toml")
        .err()
        .unwrap();
    assert!(e.to_string().contains("solids_percent"), "{e}");
}
