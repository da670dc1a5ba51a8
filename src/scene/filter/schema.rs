//! The filter scene file: its schema (serde, unknown keys refused by name, every choice an
//! enum) and the checks that turn it into a [`Plan`]: the bed read and scaled, the fibres'
//! magnetization, the particles and the run's options, everything a run fixes before the
//! flow is computed. Errors name the file, the key with its line, the value and the rule.

use super::flow::fibre_reynolds;
use crate::brownian::experiment::table_6_1_moment;
use crate::brownian::magnetization::{StonerWohlfarth, THESIS_SATURATION};
use crate::brownian::{Fluid, LangevinMoment};
use crate::consts::MU0;
use crate::error::{invalid, Error, Result};
use crate::filter::FibreBed;
use crate::io::xyz::{self, XyzParticle};
use crate::lbm::voxels::voxel_dims;
use crate::lbm::{CollisionKind, LatticeKind, Tau};
use crate::magnetics::assembly_fast::{Cell, Cutoff, FibreAssembly};
use crate::magnetics::cylinder_table::TableSpec;
use crate::magnetics::Cylinder;
use crate::scene::keys::parse_renamed;
use crate::scene::read_configuration;
use nalgebra::Vector3;
use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Scene {
    #[allow(dead_code)]
    kind: String,
    #[serde(default)]
    pub(super) title: String,
    pub(super) bed: BedSection,
    #[serde(default)]
    pub(super) field: FieldSection,
    pub(super) flow: FlowSection,
    #[serde(default)]
    pub(super) fluid: FluidSection,
    #[serde(default)]
    pub(super) particles: ParticlesSection,
    #[serde(default)]
    pub(super) run: RunSection,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct BedSection {
    /// Extended XYZ of spherocylinders in a periodic box (a packing scene's final.xyz), a
    /// path relative to the scene file, or `builtin:NAME`.
    pub(super) xyz: Option<String>,
    /// Or a packing scene (a path relative to the scene file, or `builtin:NAME` of a built-in
    /// packing) that the run carries out first, into `bed/` of its output folder, taking the
    /// bed from its final configuration.
    pub(super) packing: Option<String>,
    /// The configuration is scaled so that its fibres have this radius (m).
    pub(super) fibre_radius_m: f64,
    /// Flow-lattice voxels along the cell's x edge.
    pub(super) resolution: usize,
    /// Cells stacked along the flow (z).
    #[serde(default = "one_cell")]
    pub(super) cells_deep: usize,
}

fn one_cell() -> usize {
    1
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct FieldSection {
    /// Applied flux density mu0 H0 (T); 0: no field.
    pub(super) applied_T: f64,
    /// Direction of the applied field (any length, non-zero).
    pub(super) direction: [f64; 3],
    /// Saturation magnetization of the fibres (A/m).
    pub(super) saturation_a_per_m: f64,
    /// Images of fibres whose centre is within this distance count (m); default 1.5 times the
    /// longest cell edge.
    pub(super) cutoff_m: Option<f64>,
    /// How the superposition is evaluated.
    pub(super) method: FieldMethod,
    /// Tabulated: relative error target of each fibre's field and gradient from the shared
    /// cylinder table; default [`DEFAULT_TABLE_TOLERANCE`].
    pub(super) table_tolerance: Option<f64>,
}

/// How the fibres' superposition is evaluated at a particle: every counting image by the
/// exact kernel, or every counting image from one shared cylinder table
/// ([`crate::magnetics::assembly_fast::TabulatedAssembly`]: the same images, taper and order,
/// each kernel a table lookup).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum FieldMethod {
    Exact,
    Tabulated,
}

/// The table's relative tolerance when the scene gives none: a force error of about 2e-8
/// (median) and 2e-6 (largest) relative on a 200-fibre bed (benches/RESULTS.md, filter).
pub(super) const DEFAULT_TABLE_TOLERANCE: f64 = 1e-6;

impl Default for FieldSection {
    fn default() -> Self {
        FieldSection {
            applied_T: 0.0,
            direction: [0.0, 0.0, 1.0],
            saturation_a_per_m: THESIS_SATURATION,
            cutoff_m: None,
            method: FieldMethod::Exact,
            table_tolerance: None,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FlowSection {
    /// Exactly one of the superficial velocity and the pressure drop over the whole bed.
    pub(super) superficial_velocity_m_s: Option<f64>,
    pub(super) pressure_drop_pa: Option<f64>,
    #[serde(default = "d_force")]
    pub(super) force_lattice: f64,
    #[serde(default = "d_tau")]
    pub(super) tau: f64,
    #[serde(default = "d_tol")]
    pub(super) tol: f64,
    #[serde(default = "d_check")]
    pub(super) check_every: u64,
    #[serde(default = "d_lbm_steps")]
    pub(super) max_steps: u64,
}

fn d_force() -> f64 {
    1e-6
}
fn d_tau() -> f64 {
    1.0
}
fn d_tol() -> f64 {
    1e-7
}
fn d_check() -> u64 {
    100
}
fn d_lbm_steps() -> u64 {
    200_000
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct FluidSection {
    pub(super) viscosity_pa_s: f64,
    pub(super) density_kg_m3: f64,
    pub(super) temperature_K: f64,
}

impl Default for FluidSection {
    fn default() -> Self {
        FluidSection {
            viscosity_pa_s: 1e-3,
            density_kg_m3: 1000.0,
            temperature_K: 298.0,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum MomentLaw {
    Fixed,
    Langevin,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(non_snake_case)]
pub(super) struct ParticlesSection {
    pub(super) radius_m: f64,
    /// Moment (A m^2); default: thesis Table 6.1 for the radius.
    pub(super) moment_A_m2: Option<f64>,
    pub(super) moment_law: MomentLaw,
    pub(super) domain_moment_A_m2: Option<f64>,
    /// Particles fed at the inlet.
    pub(super) fed: usize,
}

impl Default for ParticlesSection {
    fn default() -> Self {
        ParticlesSection {
            radius_m: 75e-9,
            moment_A_m2: None,
            moment_law: MomentLaw::Fixed,
            domain_moment_A_m2: None,
            fed: 1000,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RunSection {
    pub(super) seed: u64,
    pub(super) dt_s: f64,
    pub(super) max_step_fraction: f64,
    pub(super) max_steps: u64,
}

impl Default for RunSection {
    fn default() -> Self {
        RunSection {
            seed: 1,
            dt_s: 1e-3,
            max_step_fraction: 0.05,
            max_steps: 1_000_000,
        }
    }
}

/// The scene checked: everything but the flow, which the run computes.
pub(super) struct Plan {
    pub source: String,
    pub bed: FibreBed,
    /// The field of the fibres (None without an applied field).
    pub field: Option<FieldPlan>,
    pub moment: LangevinMoment,
    pub fluid: Fluid,
    pub density_kg_m3: f64,
    pub flow: FlowPlan,
    /// Voxels along x, y, z of the cell.
    pub voxels: [usize; 3],
    pub cells_deep: usize,
    pub particles: usize,
    pub dt_s: f64,
    pub max_step_fraction: f64,
    pub max_steps: u64,
    pub seed: u64,
}

/// The fibres' field as the run builds it: the model and, for the tabulated method, the
/// cylinder table's accuracy and the edge of the bins listing each point's images.
#[derive(Debug, Clone)]
pub(super) struct FieldPlan {
    pub model: FibreAssembly,
    pub table: Option<(TableSpec, f64)>,
}

/// Bins of the tabulated field per cutoff radius: a bin lists the images within the cutoff
/// plus its half-diagonal, 1.35 times the sphere's at 8 bins per radius.
const BINS_PER_CUTOFF: f64 = 8.0;
/// Chebyshev nodes per axis of the table's rectangles and the exact zone around each fibre
/// (fibre radii), as measured in benches/RESULTS.md (filter).
const TABLE_NODES: usize = 10;
const TABLE_EXACT_MARGIN_RADII: f64 = 0.1;

/// How the flow is driven and solved.
#[derive(Debug, Clone, Copy)]
pub(super) struct FlowPlan {
    pub drive: Drive,
    pub lattice: LatticeKind,
    pub collision: CollisionKind,
    pub tau: f64,
    pub force_lattice: f64,
    pub tol: f64,
    pub check_every: u64,
    pub max_steps: u64,
}

/// The flow's strength: the superficial velocity (m/s), or the pressure drop over the whole
/// bed (Pa), which sets it through the bed's permeability (Darcy).
#[derive(Debug, Clone, Copy)]
pub(super) enum Drive {
    Superficial(f64),
    PressureDrop(f64),
}

/// " (line N)" of the first line assigning `key` in `text`, or "".
fn line_of(text: &str, key: &str) -> String {
    text.lines()
        .position(|l| {
            let code = l.split('#').next().unwrap_or("").trim_start();
            code.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map_or(String::new(), |k| format!(" (line {})", k + 1))
}

/// Where the bed comes from: `bed.xyz` or `bed.packing`, exactly one.
pub(super) enum BedSource<'a> {
    Xyz(&'a str),
    Packing(&'a str),
}

/// Parses a filter scene (read from `origin`) and checks every key that does not need the
/// bed's configuration ([`Scene::plan`] checks the rest).
pub(super) fn parse(text: &str, origin: &str) -> Result<Scene> {
    let scene: Scene = parse_renamed(text, origin).map_err(|e| Error::File {
        path: origin.to_string(),
        msg: e.to_string(),
    })?;
    scene.checked(text, origin)?;
    scene.bed_source(origin)?;
    Ok(scene)
}

/// What the keys fix without the bed: the flow's drive, the particles' moment law and the
/// temperature (K).
struct Checked {
    drive: Drive,
    moment: LangevinMoment,
    temperature_k: f64,
}

impl Scene {
    /// `bed.xyz` or `bed.packing`, refusing both and neither.
    pub(super) fn bed_source(&self, origin: &str) -> Result<BedSource<'_>> {
        match (&self.bed.xyz, &self.bed.packing) {
            (Some(x), None) => Ok(BedSource::Xyz(x)),
            (None, Some(p)) => Ok(BedSource::Packing(p)),
            _ => invalid(format!(
                "{origin}: [bed] needs exactly one of xyz (a configuration of spherocylinders) \
                 and packing (a packing scene run first)"
            )),
        }
    }

    /// The run's plan from the scene and the bed's configuration `(source, extended XYZ
    /// text)`.
    pub(super) fn plan(&self, text: &str, origin: &str, bed: (String, String)) -> Result<Plan> {
        let Checked {
            drive,
            moment,
            temperature_k: t,
        } = self.checked(text, origin)?;
        let (b, f, p) = (&self.bed, &self.field, &self.particles);
        let (fl, fu, r) = (&self.flow, &self.fluid, &self.run);
        let (source, xyz_text) = bed;
        let (cell, parts) = xyz::parse(&xyz_text, &source)?;
        let (dims, _) = voxel_dims(&cell, b.resolution).map_err(|e| {
            Error::InvalidInput(format!(
                "{origin}{}: bed {source} with bed.resolution = {}: {e}",
                line_of(text, "resolution"),
                b.resolution
            ))
        })?;
        let (scale, fibres) = fibres_of(&parts, b.fibre_radius_m, &source)?;
        let lengths_m = cell.lengths.map(|l| l * scale);
        let centres: Vec<_> = fibres
            .iter()
            .map(|f| (f.centre - Vector3::from(cell.origin)) * scale)
            .collect();
        let axes: Vec<_> = fibres.iter().map(|f| f.axis).collect();
        let half_length_m = fibres[0].half_length * scale;
        let bed = FibreBed::new(
            lengths_m,
            b.fibre_radius_m,
            half_length_m,
            &centres,
            &axes,
            p.radius_m,
        )?;
        // the field: each fibre magnetized by the applied field alone (Stoner-Wohlfarth with
        // the cylinder's demagnetizing factors, thesis sec. 6.3; mutual magnetization
        // neglected, thesis sec. 5.6)
        let dir = Vector3::from(f.direction);
        let field = if f.applied_T == 0.0 {
            None
        } else {
            let h0 = dir.normalize() * (f.applied_T / MU0);
            let cyl = Cylinder::new(b.fibre_radius_m, half_length_m)?;
            let sw = StonerWohlfarth::for_cylinder(&cyl, f.saturation_a_per_m)?;
            let ms = axes
                .iter()
                .map(|a| sw.magnetization(a, &h0))
                .collect::<Result<Vec<_>>>()?;
            let longest = lengths_m.iter().fold(0.0f64, |m, l| m.max(*l));
            let radius = f.cutoff_m.unwrap_or(1.5 * longest);
            let model = FibreAssembly::new(
                cyl,
                Cell::new(lengths_m, [true; 3])?,
                Some(Cutoff::new(radius, 0.25 * radius)?),
                centres,
                &axes,
                &ms,
                h0,
            )?;
            let table = (f.method == FieldMethod::Tabulated).then(|| {
                let spec = TableSpec {
                    tolerance: f.table_tolerance.unwrap_or(DEFAULT_TABLE_TOLERANCE),
                    nodes: TABLE_NODES,
                    exact_margin_m: TABLE_EXACT_MARGIN_RADII * b.fibre_radius_m,
                    // raised to the cutoff radius by the tabulated assembly
                    extent_m: radius,
                };
                (spec, radius / BINS_PER_CUTOFF)
            });
            Some(FieldPlan { model, table })
        };
        Ok(Plan {
            source,
            bed,
            field,
            moment,
            fluid: Fluid::new(t, fu.viscosity_pa_s)?,
            density_kg_m3: fu.density_kg_m3,
            flow: FlowPlan {
                drive,
                lattice: LatticeKind::D3Q19,
                collision: CollisionKind::Trt,
                tau: fl.tau,
                force_lattice: fl.force_lattice,
                tol: fl.tol,
                check_every: fl.check_every,
                max_steps: fl.max_steps,
            },
            voxels: [dims.nx, dims.ny, dims.nz],
            cells_deep: b.cells_deep,
            particles: p.fed,
            dt_s: r.dt_s,
            max_step_fraction: r.max_step_fraction,
            max_steps: r.max_steps,
            seed: r.seed,
        })
    }

    /// The checks of every key that does not need the bed's configuration.
    fn checked(&self, text: &str, origin: &str) -> Result<Checked> {
        let refuse = |key: &str, v: String, rule: &str| -> Error {
            let leaf = key.rsplit('.').next().unwrap_or(key);
            Error::InvalidInput(format!(
                "{origin}{}: {key} = {v}: {rule}",
                line_of(text, leaf)
            ))
        };
        let positive = |key: &str, v: f64| -> Result<f64> {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(refuse(key, v.to_string(), "must be positive and finite"))
            }
        };
        let Scene {
            bed: b,
            field: f,
            flow: fl,
            fluid: fu,
            particles: p,
            run: r,
            ..
        } = self;
        positive("bed.fibre_radius_m", b.fibre_radius_m)?;
        positive("particles.radius_m", p.radius_m)?;
        positive("fluid.viscosity_pa_s", fu.viscosity_pa_s)?;
        positive("fluid.density_kg_m3", fu.density_kg_m3)?;
        positive("run.dt_s", r.dt_s)?;
        positive("flow.force_lattice", fl.force_lattice)?;
        positive("flow.tol", fl.tol)?;
        positive("field.saturation_a_per_m", f.saturation_a_per_m)?;
        if let Some(c) = f.cutoff_m {
            positive("field.cutoff_m", c)?;
        }
        match (f.method, f.table_tolerance) {
            (FieldMethod::Exact, Some(tol)) => {
                return Err(refuse(
                    "field.table_tolerance",
                    tol.to_string(),
                    "applies to method = \"tabulated\" only (the field's method is \"exact\")",
                ))
            }
            (FieldMethod::Tabulated, Some(tol)) if !(1e-13..1e-1).contains(&tol) => {
                return Err(refuse(
                    "field.table_tolerance",
                    tol.to_string(),
                    "must be in [1e-13, 0.1) (the relative error of each fibre's field and \
                     gradient from the table)",
                ))
            }
            _ => {}
        }
        let t = fu.temperature_K;
        if !(t.is_finite() && t >= 0.0) {
            return Err(refuse(
                "fluid.temperature_K",
                t.to_string(),
                "must be finite and not negative (0: no thermal noise)",
            ));
        }
        if !(r.max_step_fraction > 0.0 && r.max_step_fraction <= 1.0) {
            return Err(refuse(
                "run.max_step_fraction",
                r.max_step_fraction.to_string(),
                "must be in (0, 1] (the largest step as a fraction of the fibre radius)",
            ));
        }
        Tau::new(fl.tau).map_err(|e| refuse("flow.tau", fl.tau.to_string(), &e.to_string()))?;
        for (key, v) in [
            ("bed.cells_deep", b.cells_deep),
            ("particles.fed", p.fed),
            ("flow.check_every", fl.check_every as usize),
            ("flow.max_steps", fl.max_steps as usize),
            ("run.max_steps", r.max_steps as usize),
        ] {
            if v == 0 {
                return Err(refuse(key, "0".into(), "must be at least 1"));
            }
        }
        let drive = match (fl.superficial_velocity_m_s, fl.pressure_drop_pa) {
            (Some(u), None) => {
                let u = positive("flow.superficial_velocity_m_s", u)?;
                fibre_reynolds(u, fu.density_kg_m3, b.fibre_radius_m, fu.viscosity_pa_s).map_err(
                    |e| {
                        refuse(
                            "flow.superficial_velocity_m_s",
                            u.to_string(),
                            &e.to_string(),
                        )
                    },
                )?;
                Drive::Superficial(u)
            }
            (None, Some(dp)) => Drive::PressureDrop(positive("flow.pressure_drop_pa", dp)?),
            _ => {
                return invalid(format!(
                    "{origin}: [flow] needs exactly one of superficial_velocity_m_s and \
                     pressure_drop_pa"
                ))
            }
        };
        let dir = Vector3::from(f.direction);
        if !(dir.norm() > 0.0 && dir.norm().is_finite()) {
            return Err(refuse(
                "field.direction",
                format!("{:?}", f.direction),
                "must be a finite non-zero vector",
            ));
        }
        if b.resolution < 4 {
            return Err(refuse(
                "bed.resolution",
                b.resolution.to_string(),
                "must be at least 4 voxels along the cell's x edge",
            ));
        }
        let magnitude = match p.moment_A_m2 {
            Some(m) => positive("particles.moment_A_m2", m)?,
            None => table_6_1_moment(p.radius_m).map_err(|e| {
                Error::InvalidInput(format!(
                    "{origin}: particles.moment_A_m2 not given and {e}; give the moment"
                ))
            })?,
        };
        let moment = match p.moment_law {
            MomentLaw::Fixed => LangevinMoment::fixed(magnitude)?,
            MomentLaw::Langevin => {
                let Some(d) = p.domain_moment_A_m2 else {
                    return invalid(format!(
                        "{origin}: particles.moment_law = \"langevin\" needs \
                         particles.domain_moment_A_m2"
                    ));
                };
                LangevinMoment::langevin(magnitude, positive("particles.domain_moment_A_m2", d)?)?
            }
        };
        Ok(Checked {
            drive,
            moment,
            temperature_k: t,
        })
    }
}

/// One fibre of the configuration (its length unit).
struct Fibre {
    centre: Vector3<f64>,
    axis: Vector3<f64>,
    half_length: f64,
}

/// The fibres of a configuration of identical spherocylinders and the scale (m per unit of
/// the file) that gives them radius `radius_m`. A spherocylinder of radius R and cylinder
/// length L becomes the solid cylinder of the same radius and volume (length L + 4R/3), so
/// that the bed keeps its solid fraction.
fn fibres_of(parts: &[XyzParticle], radius_m: f64, source: &str) -> Result<(f64, Vec<Fibre>)> {
    let Some(first) = parts.first() else {
        return invalid(format!("{source}: no particle: a filter bed needs fibres"));
    };
    let (r0, l0) = (first.radius, first.cylinder_length);
    let mut out = Vec::with_capacity(parts.len());
    for (i, p) in parts.iter().enumerate() {
        if p.species != "spherocylinder" || p.cylinder_length <= 0.0 {
            return invalid(format!(
                "{source}: particle {i} is a {} (cylinder length {}): a filter bed is made \
                 of spherocylinders (fibres) of positive length",
                p.species, p.cylinder_length
            ));
        }
        if (p.radius - r0).abs() > 1e-9 * r0 || (p.cylinder_length - l0).abs() > 1e-9 * l0 {
            return invalid(format!(
                "{source}: particle {i} has radius {} and cylinder length {}, particle 0 {r0} \
                 and {l0}: the fibres of a bed must be identical",
                p.radius, p.cylinder_length
            ));
        }
        out.push(Fibre {
            centre: p.position,
            axis: p.orientation * Vector3::z(),
            half_length: 0.5 * l0 + 2.0 * r0 / 3.0,
        });
    }
    Ok((radius_m / r0, out))
}

/// Configurations that built-in scenes name in `bed.xyz`.
const BUILTIN_XYZ: [(&str, &str); 2] = [
    (
        "filter-rods.xyz",
        include_str!("../builtin/filter-rods.xyz"),
    ),
    (
        "filter-bed-200.xyz",
        include_str!("../builtin/filter-bed-200.xyz"),
    ),
];

/// (where, text) of the configuration `bed.xyz` names ([`read_configuration`]).
pub(super) fn read_xyz(xyz: &str, origin: &str) -> Result<(String, String)> {
    read_configuration(xyz, "bed.xyz", origin, &BUILTIN_XYZ, "").map_err(|e| match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("{origin}: {m}")),
        e => e,
    })
}

/// (where, text) of the packing scene `bed.packing` names: a file relative to the scene's
/// folder or `builtin:NAME` of a built-in packing scene.
pub(super) fn read_packing(packing: &str, origin: &str) -> Result<(String, String)> {
    let builtins: Vec<(&str, &str)> = crate::scene::packing::builtins()
        .into_iter()
        .map(|b| (b.name, b.toml))
        .collect();
    read_configuration(packing, "bed.packing", origin, &builtins, "").map_err(|e| match e {
        Error::InvalidInput(m) => Error::InvalidInput(format!("{origin}: {m}")),
        e => e,
    })
}
