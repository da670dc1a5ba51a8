//! Cases 930-932: seed 002's DEM packing figures end to end. 930 (Fig. 10): the bulk porosity
//! of the gravity-, compression- and drag-driven beds of the seed's 2014 spheres and the
//! vertical porosity gradient of the drag bed; 931 (Fig. 11): the drag-driven bed's pore sizes
//! shifted to smaller pores than the gravity bed's; 932 (Fig. 8): a polydisperse bed compressed
//! by a pressure-controlled wall from a loose to a dense state. Bands and the reading of the
//! seed's words are in each case's notes, fixed before measuring.

use super::common::band_rows;
use crate::analysis::pore_size::distribution_quantile;
use crate::analysis::rdf::Bed;
use crate::dem::{observe, settle, Stop, TopWall};
use crate::io::xyz;
use crate::scene::dem::{build, parse_scene, pore_sizes, DemScene};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A bed run to its stop rule: final centres and radii, the periodic sides, and the stop.
struct FinalBed {
    pos: Vec<Vector3<f64>>,
    radius: Vec<f64>,
    lx_m: f64,
    ly_m: f64,
    settled: bool,
    seconds: f64,
}

impl FinalBed {
    fn new(scene: &DemScene, dem: &crate::dem::Dem, stop: Stop, seconds: f64) -> FinalBed {
        FinalBed {
            pos: dem.p.pos.clone(),
            radius: dem.p.radius.clone(),
            lx_m: scene.setup.lx_m,
            ly_m: scene.setup.ly_m,
            settled: stop == Stop::AtRest,
            seconds,
        }
    }

    fn z(&self) -> Vec<f64> {
        self.pos.iter().map(|p| p.z).collect()
    }

    fn bed(&self) -> Bed<'_> {
        Bed {
            pos: &self.pos,
            radius: &self.radius,
            lx_m: self.lx_m,
            ly_m: self.ly_m,
        }
    }

    /// `*` when the bed was still moving at the scene's time limit (measured where it stands).
    fn mark(&self) -> &'static str {
        if self.settled {
            ""
        } else {
            "*"
        }
    }

    /// Porosity of the bulk region [2 <d>, top - 2 <d>] (seed 002 Fig. 10 away from floor and
    /// surface) and of its lower and upper thirds, by exact sphere-slab volumes.
    fn bulk_and_thirds(&self, what: &str) -> Result<(f64, f64, f64)> {
        let z = self.z();
        let r = &self.radius;
        let area = self.lx_m * self.ly_m;
        let top = observe::bed_top(&z, r);
        let (a, b) = observe::bulk_region(&z, r, top)
            .ok_or_else(|| Error::Validation(format!("{what}: bed too thin for a bulk region")))?;
        let third = (b - a) / 3.0;
        Ok((
            observe::slab_porosity(&z, r, area, a, b),
            observe::slab_porosity(&z, r, area, a, a + third),
            observe::slab_porosity(&z, r, area, b - third, b),
        ))
    }
}

/// The built-in seed bed `name` (dem-seed-gravity, -compression, -drag) run to its stop rule
/// once and kept for the process, so that cases 930 and 931 share the gravity and drag runs;
/// also kept on disk under `target/porelab/validation-beds/` (keyed by the scene text's hash),
/// so that a later run of the cases re-measures the same final beds without re-running them.
fn seed_bed(root: &std::path::Path, name: &'static str) -> Result<Arc<FinalBed>> {
    static CACHE: Mutex<Vec<(&'static str, Arc<FinalBed>)>> = Mutex::new(Vec::new());
    // held for the whole run: a case asking while another computes waits for its result
    let mut cache = CACHE
        .lock()
        .map_err(|_| Error::Validation("seed-bed cache poisoned".into()))?;
    if let Some((_, b)) = cache.iter().find(|(k, _)| *k == name) {
        return Ok(b.clone());
    }
    let text = match name {
        "dem-seed-gravity" => include_str!("../../scene/builtin/dem-seed-gravity.toml"),
        "dem-seed-compression" => include_str!("../../scene/builtin/dem-seed-compression.toml"),
        "dem-seed-drag" => include_str!("../../scene/builtin/dem-seed-drag.toml"),
        _ => return Err(Error::Validation(format!("no seed bed `{name}`"))),
    };
    let scene = parse_scene(text, name)?;
    let stem = root
        .join("target/porelab/validation-beds")
        .join(format!("{name}-{}", scene.fingerprint));
    let bed = Arc::new(match read_bed(&scene, &stem)? {
        Some(b) => b,
        None => {
            let mut dem = build(&scene)?;
            let clock = Instant::now();
            let stop = settle(&mut dem, &scene.rule)?;
            let b = FinalBed::new(&scene, &dem, stop, clock.elapsed().as_secs_f64());
            eprintln!(
                "{name}: {} at t = {:.3} s ({} steps, {:.0} s)",
                stop.reason(&scene.rule),
                dem.time_s,
                dem.steps,
                b.seconds
            );
            write_bed(&b, &stem)?;
            b
        }
    });
    cache.push((name, bed.clone()));
    Ok(bed)
}

/// Writes a final bed as `stem.xyz` and its stop (settled or not, wall seconds) as `stem.stop`.
fn write_bed(b: &FinalBed, stem: &std::path::Path) -> Result<()> {
    let parts: Vec<_> = (0..b.pos.len())
        .map(|i| xyz::XyzParticle::sphere(b.pos[i], b.radius[i]))
        .collect();
    let cell = xyz::Cell {
        lengths: [b.lx_m, b.ly_m, observe::bed_top(&b.z(), &b.radius)],
        origin: [0.0; 3],
        pbc: [true, true, false],
    };
    if let Some(dir) = stem.parent() {
        std::fs::create_dir_all(dir)?;
    }
    xyz::write(&stem.with_extension("xyz"), &cell, &parts, &[])?;
    let stop = format!("{}\n{}\n", b.settled, b.seconds);
    crate::io::write_atomic(&stem.with_extension("stop"), stop.as_bytes())
}

/// The final bed kept at `stem` by [`write_bed`], if there is one.
fn read_bed(scene: &DemScene, stem: &std::path::Path) -> Result<Option<FinalBed>> {
    let (Ok(text), Ok(stop)) = (
        std::fs::read_to_string(stem.with_extension("xyz")),
        std::fs::read_to_string(stem.with_extension("stop")),
    ) else {
        return Ok(None);
    };
    let origin = stem.with_extension("xyz").display().to_string();
    let (_, parts) = xyz::parse(&text, &origin)?;
    let mut lines = stop.lines();
    let settled = lines.next() == Some("true");
    let seconds = lines
        .next()
        .and_then(|l| l.parse().ok())
        .unwrap_or(f64::NAN);
    eprintln!("{origin}: final bed read back (settled: {settled}, run {seconds:.0} s)");
    Ok(Some(FinalBed {
        pos: parts.iter().map(|p| p.position).collect(),
        radius: parts.iter().map(|p| p.radius).collect(),
        lx_m: scene.setup.lx_m,
        ly_m: scene.setup.ly_m,
        settled,
        seconds,
    }))
}

/// Measured quantities with a detail appended to their row labels.
type Measured = BTreeMap<&'static str, (f64, String)>;

/// Rows of `band_rows` for the measured quantities, each label followed by its detail.
fn detailed_rows(ctx: &CaseContext, m: &Measured) -> Result<Vec<Row>> {
    let got: BTreeMap<&str, f64> = m.iter().map(|(k, v)| (*k, v.0)).collect();
    let mut rows = band_rows(ctx, &got)?;
    for row in &mut rows {
        if let Some((_, (_, detail))) = m
            .iter()
            .find(|(k, _)| row.label.starts_with(&format!("{k} in ")))
        {
            row.label = format!("{} ({detail})", row.label);
        }
        eprintln!("{}: {:.4}: {}", ctx.id, row.got, row.label);
    }
    Ok(rows)
}

register!("930" => case_930);
/// Case 930 (seed 002 Fig. 10): bulk porosity of the three seed beds, the compression bed's
/// porosity below the gravity bed's, no gradient in the compression bed, a gradient (lower
/// third denser than the upper third) in the drag bed.
pub fn case_930(ctx: &CaseContext) -> Result<Vec<Row>> {
    let g = seed_bed(&ctx.repo_root, "dem-seed-gravity")?;
    let c = seed_bed(&ctx.repo_root, "dem-seed-compression")?;
    let d = seed_bed(&ctx.repo_root, "dem-seed-drag")?;
    let (g_bulk, _, _) = g.bulk_and_thirds("gravity")?;
    let (c_bulk, c_lo, c_hi) = c.bulk_and_thirds("compression")?;
    let (d_bulk, d_lo, d_hi) = d.bulk_and_thirds("drag")?;
    let mut m = Measured::new();
    let thirds = |lo: f64, hi: f64| format!("upper third {hi:.4}, lower third {lo:.4}");
    m.insert(
        "gravity_bulk_porosity",
        (g_bulk, format!("{g_bulk:.4}{}", g.mark())),
    );
    m.insert(
        "compression_bulk_porosity",
        (c_bulk, format!("{c_bulk:.4}{}", c.mark())),
    );
    m.insert(
        "gravity_minus_compression_bulk",
        (
            g_bulk - c_bulk,
            format!("gravity {g_bulk:.4} minus compression {c_bulk:.4}"),
        ),
    );
    m.insert(
        "compression_upper_minus_lower_third",
        (c_hi - c_lo, thirds(c_lo, c_hi)),
    );
    m.insert(
        "drag_bulk_porosity",
        (d_bulk, format!("{d_bulk:.4}{}", d.mark())),
    );
    m.insert(
        "drag_upper_minus_lower_third",
        (d_hi - d_lo, thirds(d_lo, d_hi)),
    );
    detailed_rows(ctx, &m)
}

/// Voxels per sphere diameter of the pore-size grid of case 931 (edge 40 um for d = 400 um).
const PORE_VOXELS_PER_D: f64 = 10.0;

register!("931" => case_931);
/// Case 931 (seed 002 Fig. 11): the pore-volume-weighted median and 75th percentile of the
/// local-thickness pore diameter (over d) of the drag bed below the gravity bed's.
pub fn case_931(ctx: &CaseContext) -> Result<Vec<Row>> {
    let mut q = Vec::new();
    for name in ["dem-seed-gravity", "dem-seed-drag"] {
        let b = seed_bed(&ctx.repo_root, name)?;
        let dmean = b.bed().mean_diameter();
        let (rows, _) = pore_sizes(&b.bed(), PORE_VOXELS_PER_D)
            .map_err(|e| Error::Validation(format!("{name}: pore sizes: {e}")))?;
        let large: f64 = rows
            .iter()
            .filter(|(dp, _)| dp / dmean > 0.4)
            .map(|r| r.1)
            .sum();
        q.push((
            distribution_quantile(&rows, 0.5) / dmean,
            distribution_quantile(&rows, 0.75) / dmean,
            large,
            b.mark(),
        ));
    }
    let (g, d) = (q[0], q[1]);
    let detail = |i: usize| {
        format!(
            "gravity{} {:.3}, drag{} {:.3}; pore volume above 0.4 d: gravity {:.3}, drag {:.3}",
            g.3,
            if i == 0 { g.0 } else { g.1 },
            d.3,
            if i == 0 { d.0 } else { d.1 },
            g.2,
            d.2
        )
    };
    let mut m = Measured::new();
    m.insert("gravity_minus_drag_median_over_d", (g.0 - d.0, detail(0)));
    m.insert("gravity_minus_drag_p75_over_d", (g.1 - d.1, detail(1)));
    detailed_rows(ctx, &m)
}

/// Target pressure of case 932's second (compression) stage: ten times the built-in
/// dem-seed-compression's 184 Pa (the seed beds' weight per area).
const FIG8_FINAL_PRESSURE_PA: f64 = 1840.0;

register!("932" => case_932);
/// Case 932 (seed 002 Fig. 8): the polydisperse bed of the case's `scene.toml` compressed by
/// its pressure wall to a loose "initial" state, then the wall's target raised to
/// [`FIG8_FINAL_PRESSURE_PA`] and run to its stop rule again: bulk porosity of both states.
pub fn case_932(ctx: &CaseContext) -> Result<Vec<Row>> {
    let path = ctx.case_dir.join("scene.toml");
    let text = std::fs::read_to_string(&path).map_err(|e| Error::File {
        path: path.display().to_string(),
        msg: e.to_string(),
    })?;
    let scene = parse_scene(&text, &path.display().to_string())?;
    let mut dem = build(&scene)?;
    let clock = Instant::now();
    let stop1 = settle(&mut dem, &scene.rule)?;
    let initial = FinalBed::new(&scene, &dem, stop1, clock.elapsed().as_secs_f64());
    let p1 = dem.top_force_n / (scene.setup.lx_m * scene.setup.ly_m);
    if !matches!(scene.setup.top, TopWall::Pressure { .. }) {
        return Err(Error::Validation(format!(
            "{}: case 932 needs a pressure-controlled top wall (drivers.top_pressure_pa)",
            path.display()
        )));
    }
    dem.set_top_pressure(FIG8_FINAL_PRESSURE_PA)?;
    // the second stage gets the same simulated-time allowance as the first
    let rule2 = scene
        .rule
        .with_max_time_s(scene.rule.max_time_s() + dem.time_s)?;
    let stop2 = settle(&mut dem, &rule2)?;
    let fin = FinalBed::new(&scene, &dem, stop2, clock.elapsed().as_secs_f64());
    let p2 = dem.top_force_n / (scene.setup.lx_m * scene.setup.ly_m);
    let (stop1, stop2) = (stop1.reason(&scene.rule), stop2.reason(&rule2));
    let (e1, _, _) = initial.bulk_and_thirds("initial state")?;
    let (e2, _, _) = fin.bulk_and_thirds("final state")?;
    eprintln!(
        "932: initial {e1:.4} ({stop1}; wall {p1:.1} Pa), final {e2:.4} ({stop2}; wall {p2:.1} Pa, \
         max overlap/d {:.2e}), t = {:.3} s, {:.0} s",
        dem.max_overlap_ratio(),
        dem.time_s,
        fin.seconds
    );
    let mut m = Measured::new();
    m.insert(
        "initial_bulk_porosity",
        (e1, format!("{e1:.4}{}, wall {p1:.1} Pa", initial.mark())),
    );
    m.insert(
        "final_bulk_porosity",
        (e2, format!("{e2:.4}{}, wall {p2:.1} Pa", fin.mark())),
    );
    m.insert(
        "initial_minus_final",
        (e1 - e2, format!("initial {e1:.4} minus final {e2:.4}")),
    );
    detailed_rows(ctx, &m)
}
