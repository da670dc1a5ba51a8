//! Contact laws, composed after LAMMPS's `GranularModel`: a normal elastic sub-model, a normal
//! damping sub-model and a tangential sub-model, each a small type with its own parameters.
//! One [`ContactModel`] serves sphere–sphere and sphere–wall contacts alike: a flat wall is a
//! sphere of infinite radius and mass, so its effective radius is the sphere's radius and its
//! effective mass the sphere's mass, and the effective moduli follow the same rule
//! ([`PairMaterial::new`]).
//!
//! Sign conventions: `n` is the unit normal from body j to body i, `delta` > 0 the overlap,
//! `v_rel` the velocity of i's contact point relative to j's. The force returned acts on i.

use super::lanes::{Lane, V3};
use crate::error::{invalid, require_positive};
use crate::Result;
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Elastic constants of one material (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    pub young_pa: f64,
    pub poisson: f64,
}

impl Material {
    pub fn new(young_pa: f64, poisson: f64) -> Result<Material> {
        require_positive(young_pa, || format!("Young's modulus {young_pa} Pa"))?;
        if !(poisson.is_finite() && poisson > -1.0 && poisson < 0.5) {
            return invalid(format!("Poisson ratio {poisson}: must lie in (-1, 0.5)"));
        }
        Ok(Material { young_pa, poisson })
    }

    /// Shear modulus G = E / (2 (1 + nu)).
    pub fn shear_pa(&self) -> f64 {
        self.young_pa / (2.0 * (1.0 + self.poisson))
    }
}

/// Effective moduli of a contact between two materials (Hertz and Mindlin; the rule of
/// LAMMPS `hertz/material` and `mindlin`):
/// 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 and 1/G* = 2 (2 - nu1)(1 + nu1)/E1 + 2 (2 - nu2)(1 + nu2)/E2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairMaterial {
    pub e_star_pa: f64,
    pub g_star_pa: f64,
}

impl PairMaterial {
    pub fn new(a: &Material, b: &Material) -> PairMaterial {
        let inv_e =
            (1.0 - a.poisson * a.poisson) / a.young_pa + (1.0 - b.poisson * b.poisson) / b.young_pa;
        let inv_g = 2.0 * (2.0 - a.poisson) * (1.0 + a.poisson) / a.young_pa
            + 2.0 * (2.0 - b.poisson) * (1.0 + b.poisson) / b.young_pa;
        PairMaterial {
            e_star_pa: 1.0 / inv_e,
            g_star_pa: 1.0 / inv_g,
        }
    }
}

/// Normal elastic force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NormalModel {
    /// Hertz: F = (4/3) E* sqrt(R* delta) delta, contact stiffness S_n = 2 E* sqrt(R* delta).
    Hertz,
    /// Linear spring (Cundall & Strack 1979): F = k_n delta.
    Linear { k_n_n_per_m: f64 },
}

impl NormalModel {
    /// The linear spring of stiffness `k_n_n_per_m` (N/m).
    pub fn linear(k_n_n_per_m: f64) -> Result<NormalModel> {
        let m = NormalModel::Linear { k_n_n_per_m };
        m.check()?;
        Ok(m)
    }

    /// The rules of its coefficients (as LAMMPS's `coeffs_to_local`): k_n positive and finite.
    pub fn check(&self) -> Result<()> {
        if let NormalModel::Linear { k_n_n_per_m } = *self {
            require_positive(k_n_n_per_m, || {
                format!("normal stiffness k_n = {k_n_n_per_m} N/m")
            })?;
        }
        Ok(())
    }

    /// Whether the law reads the elastic moduli (Hertz) rather than a stiffness of its own.
    pub fn is_hertz(&self) -> bool {
        matches!(self, NormalModel::Hertz)
    }

    /// (elastic force magnitude, contact stiffness S_n = dF/d delta) at overlap `delta` > 0.
    #[inline(always)]
    pub fn elastic(&self, delta: f64, r_eff: f64, e_star: f64) -> (f64, f64) {
        self.elastic_lanes(delta, r_eff, e_star)
    }

    /// [`NormalModel::elastic`] of contacts side by side.
    #[inline(always)]
    pub fn elastic_lanes<T: Lane>(&self, delta: T, r_eff: T, e_star: f64) -> (T, T) {
        match *self {
            NormalModel::Hertz => {
                let s = T::splat(2.0 * e_star) * (r_eff * delta).sqrt();
                (s * delta * T::splat(2.0 / 3.0), s)
            }
            NormalModel::Linear { k_n_n_per_m: k } => (T::splat(k) * delta, T::splat(k)),
        }
    }

    /// Elastic energy stored at overlap `delta` (J): (8/15) E* sqrt(R*) delta^(5/2) or k delta^2 / 2.
    pub fn potential(&self, delta: f64, r_eff: f64, e_star: f64) -> f64 {
        if delta <= 0.0 {
            return 0.0;
        }
        match *self {
            NormalModel::Hertz => (8.0 / 15.0) * e_star * r_eff.sqrt() * delta.powf(2.5),
            NormalModel::Linear { k_n_n_per_m: k } => 0.5 * k * delta * delta,
        }
    }

    /// The factor c in the restitution damping eta_n = 2 (-beta) sqrt(c S_n m*): 1 for the
    /// linear spring (exact), 5/6 for Hertz (Tsuji et al. 1992 scaling, the LIGGGHTS and
    /// LAMMPS `coeff_restitution` form).
    fn damping_factor(&self) -> f64 {
        match self {
            NormalModel::Hertz => 5.0 / 6.0,
            NormalModel::Linear { .. } => 1.0,
        }
    }
}

/// Normal viscous damping F_d = -eta_n (v_rel . n) n.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DampingModel {
    /// No dissipation.
    None,
    /// eta_n = -2 beta sqrt(c S_n m*), beta = ln e / sqrt(ln^2 e + pi^2): for the linear spring
    /// the exact dashpot of restitution e (e = exp(-pi zeta / sqrt(1 - zeta^2)), zeta = -beta);
    /// for Hertz the LIGGGHTS form (c = 5/6), whose restitution does not depend on the impact
    /// velocity but is not exactly e.
    Restitution { coeff: f64, neg_beta: f64 },
    /// Zhou et al. (2002) normal damping, read as eta_n = c_n sqrt(6 m* S_n) with
    /// S_n = 2 E* sqrt(R* delta) (for equal materials 2 E* = E/(1 - nu^2), the reading
    /// F_dn = -c_n (6 m* E/(1 - nu^2) sqrt(R* delta))^(1/2) v_n); c_n is dimensionless.
    Zhou { c_n: f64 },
}

impl DampingModel {
    /// Damping set by a coefficient of restitution 0 < e <= 1 (e = 1: no damping).
    pub fn restitution(e: f64) -> Result<DampingModel> {
        if !(e.is_finite() && e > 0.0 && e <= 1.0) {
            return invalid(format!(
                "coefficient of restitution {e}: must lie in (0, 1]"
            ));
        }
        if e == 1.0 {
            return Ok(DampingModel::None);
        }
        let l = e.ln();
        Ok(DampingModel::Restitution {
            coeff: e,
            neg_beta: -l / (l * l + PI * PI).sqrt(),
        })
    }

    /// The damping of Zhou et al. (2002) with coefficient c_n >= 0 (c_n = 0: no damping).
    pub fn zhou(c_n: f64) -> Result<DampingModel> {
        if c_n == 0.0 {
            return Ok(DampingModel::None);
        }
        let m = DampingModel::Zhou { c_n };
        m.check()?;
        Ok(m)
    }

    /// The rules of its coefficients: a restitution in (0, 1) with the beta it implies, c_n >= 0
    /// and finite.
    pub fn check(&self) -> Result<()> {
        match *self {
            DampingModel::None => Ok(()),
            DampingModel::Restitution { coeff, neg_beta } => {
                match DampingModel::restitution(coeff)? {
                    DampingModel::Restitution { neg_beta: b, .. } if b == neg_beta => Ok(()),
                    _ => invalid(format!(
                        "restitution damping: beta = {} does not follow from the coefficient of \
                     restitution {coeff} (build it with DampingModel::restitution)",
                        -neg_beta
                    )),
                }
            }
            DampingModel::Zhou { c_n } => {
                if c_n.is_finite() && c_n >= 0.0 {
                    Ok(())
                } else {
                    invalid(format!(
                        "normal damping coefficient c_n = {c_n}: must be >= 0 and finite"
                    ))
                }
            }
        }
    }

    /// eta_n of contacts side by side.
    #[inline(always)]
    fn eta_lanes<T: Lane>(&self, normal: &NormalModel, s_n: T, m_eff: T) -> T {
        match *self {
            DampingModel::None => T::splat(0.0),
            DampingModel::Restitution { neg_beta, .. } => {
                T::splat(2.0 * neg_beta) * (T::splat(normal.damping_factor()) * s_n * m_eff).sqrt()
            }
            DampingModel::Zhou { c_n } => T::splat(c_n) * (T::splat(6.0) * m_eff * s_n).sqrt(),
        }
    }
}

/// Tangential force: a spring on the accumulated tangential displacement xi (history per
/// contact), a dashpot eta_t = ratio * eta_n, and the Coulomb limit |F_t| <= mu |F_n|.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TangentialModel {
    /// Frictionless: no tangential force, no rotation needed.
    None,
    /// Mindlin: k_t = 8 G* sqrt(R* delta) (LAMMPS `tangential mindlin NULL`).
    Mindlin { mu: f64, damp_ratio: f64 },
    /// Linear (Cundall & Strack 1979): k_t = kt_over_kn * k_n.
    Linear {
        kt_over_kn: f64,
        mu: f64,
        damp_ratio: f64,
    },
    /// Zhou et al. (2002), the Mindlin–Deresiewicz law as simplified there (see
    /// [`zhou_tangential`]): F_t = -mu |F_cn| (1 - (1 - x)^(3/2)) xi_hat with
    /// x = min(|xi|, xi_max) / xi_max, and the dashpot
    /// -c_t (6 mu m* |F_cn| sqrt(1 - x) / xi_max)^(1/2) v_t.
    Zhou { mu: f64, c_t: f64 },
}

impl TangentialModel {
    /// Mindlin's spring with Coulomb coefficient `mu` and dashpot ratio eta_t / eta_n.
    pub fn mindlin(mu: f64, damp_ratio: f64) -> Result<TangentialModel> {
        let m = TangentialModel::Mindlin { mu, damp_ratio };
        m.check()?;
        Ok(m)
    }

    /// The linear spring k_t = `kt_over_kn` k_n with Coulomb coefficient `mu` and dashpot ratio
    /// eta_t / eta_n.
    pub fn linear(kt_over_kn: f64, mu: f64, damp_ratio: f64) -> Result<TangentialModel> {
        let m = TangentialModel::Linear {
            kt_over_kn,
            mu,
            damp_ratio,
        };
        m.check()?;
        Ok(m)
    }

    /// The law of Zhou et al. (2002) with Coulomb coefficient `mu` > 0 and dashpot coefficient
    /// `c_t` >= 0.
    pub fn zhou(mu: f64, c_t: f64) -> Result<TangentialModel> {
        let m = TangentialModel::Zhou { mu, c_t };
        m.check()?;
        Ok(m)
    }

    /// The rules of its coefficients: mu >= 0 (> 0 for Zhou's law, whose spring is scaled by
    /// mu), dashpot ratios and coefficients >= 0, k_t / k_n positive; all finite.
    pub fn check(&self) -> Result<()> {
        let at_least_zero = |v: f64, what: &str| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                invalid(format!("{what} = {v}: must be >= 0 and finite"))
            }
        };
        match *self {
            TangentialModel::None => Ok(()),
            TangentialModel::Mindlin { mu, damp_ratio } => {
                at_least_zero(mu, "friction coefficient mu")?;
                at_least_zero(damp_ratio, "tangential damping ratio eta_t / eta_n")
            }
            TangentialModel::Linear {
                kt_over_kn,
                mu,
                damp_ratio,
            } => {
                require_positive(kt_over_kn, || {
                    format!("stiffness ratio k_t / k_n = {kt_over_kn}")
                })?;
                at_least_zero(mu, "friction coefficient mu")?;
                at_least_zero(damp_ratio, "tangential damping ratio eta_t / eta_n")
            }
            TangentialModel::Zhou { mu, c_t } => {
                if !(mu.is_finite() && mu > 0.0) {
                    return invalid(format!(
                        "friction coefficient mu = {mu}: must be > 0 and finite for the Zhou law"
                    ));
                }
                at_least_zero(c_t, "tangential damping coefficient c_t")
            }
        }
    }

    pub fn is_none(&self) -> bool {
        matches!(self, TangentialModel::None)
    }

    /// The Coulomb coefficient mu (None: frictionless).
    pub fn friction(&self) -> Option<f64> {
        match *self {
            TangentialModel::None => None,
            TangentialModel::Mindlin { mu, .. }
            | TangentialModel::Linear { mu, .. }
            | TangentialModel::Zhou { mu, .. } => Some(mu),
        }
    }

    /// (k_t, eta_t, mu) of contacts side by side.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn parameters_lanes<T: Lane>(
        &self,
        normal: &NormalModel,
        s_n: T,
        eta_n: T,
        delta: T,
        r_eff: T,
        e_star: f64,
        g_star: f64,
    ) -> (T, T, f64) {
        let zero = T::splat(0.0);
        match *self {
            TangentialModel::None => (zero, zero, 0.0),
            TangentialModel::Mindlin { mu, damp_ratio } => {
                // 8 G* sqrt(R* delta); with a Hertz normal S_n = 2 E* sqrt(R* delta) holds the root
                let k_t = match normal {
                    NormalModel::Hertz => T::splat(4.0 * g_star / e_star) * s_n,
                    NormalModel::Linear { .. } => T::splat(8.0 * g_star) * (r_eff * delta).sqrt(),
                };
                (k_t, T::splat(damp_ratio) * eta_n, mu)
            }
            TangentialModel::Linear {
                kt_over_kn,
                mu,
                damp_ratio,
            } => (T::splat(kt_over_kn) * s_n, T::splat(damp_ratio) * eta_n, mu),
            // a nonlinear spring: its force is computed in `zhou_tangential`
            TangentialModel::Zhou { mu, .. } => (zero, zero, mu),
        }
    }
}

/// A contact model: normal elasticity + normal damping + tangential law, chosen separately and
/// checked together once ([`ContactModel::new`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactModel {
    pub(super) normal: NormalModel,
    pub(super) damping: DampingModel,
    pub(super) tangential: TangentialModel,
    pub(super) limit: CoulombLimit,
}

/// How the normal dashpot and the Coulomb limit meet: at the end of a damped contact, where
/// the dashpot outgrows the elastic force, and while the contact slides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CoulombLimit {
    /// The normal force never pulls: F_n = max(F_el + F_damp, 0) (LAMMPS `pair granular`
    /// keyword `limit_damping`, src/GRANULAR/granular_model.cpp; LIGGGHTS `limitForce on`,
    /// doc/gran_model_hertz.html), and the Coulomb limit is mu F_n. When the trial force
    /// -k_t xi - eta_t v_t exceeds it the contact slides: F_t = mu F_n along the trial force,
    /// carried by the spring alone (xi truncated to -F_t / k_t) and the tangential dashpot adds
    /// nothing, as in LIGGGHTS (src/tangential_model_history.h), which however tests the spring
    /// alone against the limit and adds the dashpot below it; here |F_t| never exceeds mu F_n.
    /// A sliding contact then carries exactly mu F_n at every step, so a contact that slides
    /// throughout has J_t = mu J_n (case 712).
    #[default]
    NoTension,
    /// LAMMPS `pair granular` without `limit_damping` (src/GRANULAR/gran_sub_mod_tangential.cpp):
    /// the normal dashpot may pull at the end of a contact, the limit is mu |F_n|, and a sliding
    /// contact's spring is reset to xi = -(F_t + eta_t v_t) / k_t, the dashpot counted inside the
    /// limit (the spring then works against the dashpot, and the force falls below the limit as
    /// eta_t falls). porelab's law before 2026-12.
    DashpotInLimit,
}

impl CoulombLimit {
    /// The scene-file name (`[contact] coulomb_limit`).
    pub fn name(self) -> &'static str {
        match self {
            CoulombLimit::NoTension => "no-tension",
            CoulombLimit::DashpotInLimit => "dashpot-in-limit",
        }
    }
}

/// The state of one contact for [`ContactModel::force`].
#[derive(Debug, Clone, Copy)]
pub struct ContactState {
    /// Overlap (m), > 0.
    pub delta: f64,
    /// Unit normal from j to i.
    pub n: Vector3<f64>,
    /// Contact-point velocity of i relative to j at the half step (drives the spring).
    pub v_half: Vector3<f64>,
    /// Contact-point velocity of i relative to j predicted at the full step (drives dashpots).
    pub v_full: Vector3<f64>,
    pub r_eff: f64,
    pub m_eff: f64,
    pub dt: f64,
}

/// [`ContactState`] of several contacts side by side, one per lane (see
/// [`ContactModel::force_lanes`]).
#[derive(Debug, Clone, Copy)]
pub struct ContactLanes<T> {
    pub delta: T,
    pub n: V3<T>,
    pub v_half: V3<T>,
    pub v_full: V3<T>,
    pub r_eff: T,
    pub m_eff: T,
    pub dt: f64,
}

impl ContactModel {
    /// The model of these sub-models, each checked against the rules of its coefficients, and
    /// the rules of their combination: the damping and the tangential law of Zhou et al.
    /// (2002) are written for a Hertz normal force (their scales are Hertz's stiffness and
    /// Mindlin–Deresiewicz's slip displacement).
    pub fn new(
        normal: NormalModel,
        damping: DampingModel,
        tangential: TangentialModel,
    ) -> Result<ContactModel> {
        normal.check()?;
        damping.check()?;
        tangential.check()?;
        if !normal.is_hertz() {
            if let DampingModel::Zhou { .. } = damping {
                return invalid("the damping of Zhou et al. (2002) needs a Hertz normal force");
            }
            if let TangentialModel::Zhou { .. } = tangential {
                return invalid(
                    "the tangential law of Zhou et al. (2002) needs a Hertz normal force",
                );
            }
        }
        Ok(ContactModel {
            normal,
            damping,
            tangential,
            limit: CoulombLimit::default(),
        })
    }

    /// The same model with the Coulomb limit `limit` (default [`CoulombLimit::NoTension`]).
    pub fn with_limit(self, limit: CoulombLimit) -> ContactModel {
        ContactModel { limit, ..self }
    }

    pub fn limit(&self) -> CoulombLimit {
        self.limit
    }

    pub fn normal(&self) -> NormalModel {
        self.normal
    }

    pub fn damping(&self) -> DampingModel {
        self.damping
    }

    pub fn tangential(&self) -> TangentialModel {
        self.tangential
    }

    /// Whether the model reads the materials' elastic moduli (Hertz normal force, Mindlin's
    /// and Zhou's tangential springs); linear springs carry their own stiffness.
    pub fn reads_moduli(&self) -> bool {
        self.normal.is_hertz()
            || matches!(
                self.tangential,
                TangentialModel::Mindlin { .. } | TangentialModel::Zhou { .. }
            )
    }

    /// Duration (s) of a head-on contact of a pair of effective mass `m_eff`, radius `r_eff`
    /// and modulus `e_star` at relative speed `v`: for the linear spring pi / omega_d with
    /// omega_d = sqrt(k_n / m*) sqrt(1 - zeta^2) (its restitution damping included, exact); for
    /// Hertz the undamped time of [`hertz_contact_time`] (v at least 1e-12 m/s).
    pub fn contact_time(&self, m_eff: f64, r_eff: f64, e_star: f64, v: f64) -> f64 {
        match self.normal {
            NormalModel::Linear { k_n_n_per_m } => {
                let w0 = (k_n_n_per_m / m_eff).sqrt();
                let zeta = match self.damping {
                    DampingModel::None => 0.0,
                    DampingModel::Restitution { neg_beta, .. } => neg_beta,
                    // refused with a linear spring by `new`
                    DampingModel::Zhou { .. } => 0.0,
                };
                PI / (w0 * (1.0 - zeta * zeta).sqrt())
            }
            NormalModel::Hertz => hertz_contact_time(m_eff, r_eff, e_star, v.max(1e-12)),
        }
    }

    /// Force on i, and its tangential part, for one contact; advances the tangential
    /// displacement `xi` (history) over the step (see [`ContactModel::force_lanes`]).
    #[inline(always)]
    pub fn force(
        &self,
        c: &ContactState,
        mat: &PairMaterial,
        xi: &mut Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let one = ContactLanes {
            delta: c.delta,
            n: V3::of(&c.n),
            v_half: V3::of(&c.v_half),
            v_full: V3::of(&c.v_full),
            r_eff: c.r_eff,
            m_eff: c.m_eff,
            dt: c.dt,
        };
        let mut xi_lane = V3::of(xi);
        let (f, ft) = self.force_lanes(&one, mat, &mut xi_lane);
        *xi = xi_lane.lane(0);
        (f.lane(0), ft.lane(0))
    }

    /// [`ContactModel::force`] of contacts side by side, one per lane: each lane performs the
    /// scalar operations in the scalar order, branches becoming per-lane selects, so a
    /// contact's bits do not depend on the lane type (see [`super::lanes`]).
    ///
    /// The tangential displacement xi is first turned onto the current tangent plane with its
    /// length kept (LAMMPS), then xi += v_t(half step) dt; when the Coulomb limit binds, xi is
    /// reset to the spring length that gives the limited force (with or without the dashpot,
    /// [`CoulombLimit`]).
    #[inline(always)]
    pub fn force_lanes<T: Lane>(
        &self,
        c: &ContactLanes<T>,
        mat: &PairMaterial,
        xi: &mut V3<T>,
    ) -> (V3<T>, V3<T>) {
        let (f_el, s_n) = self.normal.elastic_lanes(c.delta, c.r_eff, mat.e_star_pa);
        let eta_n = self.damping.eta_lanes(&self.normal, s_n, c.m_eff);
        let vn_full = c.v_full.dot(&c.n);
        let f_n = f_el - eta_n * vn_full;
        let zero = T::splat(0.0);
        let f_n = match self.limit {
            CoulombLimit::NoTension => T::select(f_n.lt(zero), zero, f_n),
            CoulombLimit::DashpotInLimit => f_n,
        };
        let f = c.n.scale(f_n);
        if self.tangential.is_none() {
            return (f, V3::zeros());
        }
        let (k_t, eta_t, mu) = self.tangential.parameters_lanes(
            &self.normal,
            s_n,
            eta_n,
            c.delta,
            c.r_eff,
            mat.e_star_pa,
            mat.g_star_pa,
        );
        // history onto the tangent plane, length kept
        let len0 = xi.norm_squared();
        let turned = xi.sub(&c.n.scale(xi.dot(&c.n)));
        let len1 = turned.norm_squared();
        let kept = turned.scale((len0 / len1).sqrt());
        let turned = V3::select(len1.gt(zero), &kept, &turned);
        let xi_turned = V3::select(len0.gt(zero), &turned, xi);
        let vt_half = c.v_half.sub(&c.n.scale(c.v_half.dot(&c.n)));
        let vt_full = c.v_full.sub(&c.n.scale(vn_full));
        *xi = xi_turned.add(&vt_half.scale(T::splat(c.dt)));
        if let TangentialModel::Zhou { mu, c_t } = self.tangential {
            let mut f_t = [Vector3::zeros(); 4];
            let mut xi_out = [Vector3::zeros(); 4];
            for l in 0..T::LANES {
                let xi_max = zhou_slip_displacement(mu, c.delta.lane(l), mat);
                xi_out[l] = xi.lane(l);
                let vt = vt_full.lane(l);
                f_t[l] = zhou_tangential(
                    mu,
                    c_t,
                    f_el.lane(l),
                    xi_max,
                    c.m_eff.lane(l),
                    &mut xi_out[l],
                    &vt,
                );
            }
            *xi = V3::from_fn(|l| xi_out[l]);
            let f_t = V3::from_fn(|l| f_t[l]);
            return (f.add(&f_t), f_t);
        }
        let f_t = xi.scale(k_t).neg().sub(&vt_full.scale(eta_t));
        let limit = T::splat(mu) * f_n.abs();
        let ft2 = f_t.norm_squared();
        let slides = ft2.gt(limit * limit);
        if !T::any(slides) {
            // no lane at the Coulomb limit: the selects below would keep every lane as it is
            return (f.add(&f_t), f_t);
        }
        let f_t_limited = f_t.scale(limit / ft2.sqrt());
        let xi_limited = match self.limit {
            CoulombLimit::NoTension => f_t_limited.neg().div(k_t),
            CoulombLimit::DashpotInLimit => f_t_limited.add(&vt_full.scale(eta_t)).neg().div(k_t),
        };
        *xi = V3::select(slides & k_t.gt(zero), &xi_limited, xi);
        let f_t = V3::select(slides, &f_t_limited, &f_t);
        (f.add(&f_t), f_t)
    }

    /// Whether the model needs rotation (a tangential force).
    pub fn has_friction(&self) -> bool {
        !self.tangential.is_none()
    }
}

/// Tangential displacement at full mobilisation of the Zhou et al. (2002) law: for equal
/// materials xi_max = mu delta (2 - nu) / (2 (1 - nu)) (Mindlin & Deresiewicz 1953 for a Hertz
/// contact). Written as mu delta E* / (4 G*), which is that expression for equal materials and,
/// for unequal ones (a sphere on a wall), keeps the law's initial stiffness
/// dF_t/dxi(0) = 3 mu F_cn / (2 xi_max) equal to Mindlin's 8 G* sqrt(R* delta).
pub fn zhou_slip_displacement(mu: f64, delta: f64, mat: &PairMaterial) -> f64 {
    mu * delta * mat.e_star_pa / (4.0 * mat.g_star_pa)
}

/// Tangential force of the Zhou et al. (2002) law (spring + dashpot) on i, given the elastic
/// normal force `f_cn` >= 0, the slip displacement `xi_max` and the accumulated tangential
/// displacement `xi` (on the tangent plane). While |xi| < xi_max the spring is
/// F = -mu f_cn (1 - (1 - |xi|/xi_max)^(3/2)) xi_hat, which reaches mu f_cn at |xi| = xi_max;
/// beyond, the contact slides: |xi| is held at xi_max (so that unloading starts from full
/// mobilisation) and the dashpot, proportional to (1 - |xi|/xi_max)^(1/4), vanishes.
/// The dashpot is -c_t (6 mu m* f_cn sqrt(1 - x) / xi_max)^(1/2) v_t, i.e. c_t times
/// (4 m* k_t)^(1/2) with k_t = dF/d|xi| the spring's tangent stiffness.
#[inline(always)]
pub fn zhou_tangential(
    mu: f64,
    c_t: f64,
    f_cn: f64,
    xi_max: f64,
    m_eff: f64,
    xi: &mut Vector3<f64>,
    vt: &Vector3<f64>,
) -> Vector3<f64> {
    if !(xi_max > 0.0) {
        *xi = Vector3::zeros();
        return Vector3::zeros();
    }
    let mut len = xi.norm();
    if len > xi_max {
        *xi *= xi_max / len;
        len = xi_max;
    }
    let x = len / xi_max;
    let rest = 1.0 - x;
    let mut f = Vector3::zeros();
    if len > 0.0 {
        f -= *xi * (mu * f_cn * (1.0 - rest * rest.sqrt()) / len);
    }
    if c_t > 0.0 && rest > 0.0 {
        f -= vt * (c_t * (6.0 * mu * m_eff * f_cn * rest.sqrt() / xi_max).sqrt());
    }
    f
}

/// Hertz elastic contact time of a head-on impact at relative speed v (Johnson 1985, eq. 11.24):
/// t_c = 2.868 (m*^2 / (R* E*^2 v))^(1/5).
pub fn hertz_contact_time(m_eff: f64, r_eff: f64, e_star: f64, v: f64) -> f64 {
    2.868 * (m_eff * m_eff / (r_eff * e_star * e_star * v)).powf(0.2)
}

/// Rayleigh time of a sphere of radius r (Thornton & Randall / LIGGGHTS):
/// t_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766).
pub fn rayleigh_time(radius: f64, density: f64, mat: &Material) -> f64 {
    PI * radius * (density / mat.shear_pa()).sqrt() / (0.1631 * mat.poisson + 0.8766)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effective_moduli_same_material() {
        let m = Material::new(1e7, 0.3).unwrap();
        let p = PairMaterial::new(&m, &m);
        assert!((p.e_star_pa - 1e7 / (2.0 * 0.91)).abs() < 1e-6);
        assert!((p.g_star_pa - 1e7 / (4.0 * 1.7 * 1.3)).abs() < 1e-6);
    }

    #[test]
    fn hertz_force_is_derivative_of_potential() {
        let n = NormalModel::Hertz;
        let (d, r, e) = (1e-6, 1e-3, 1e8);
        let h = 1e-12;
        let num = (n.potential(d + h, r, e) - n.potential(d - h, r, e)) / (2.0 * h);
        let (f, s) = n.elastic(d, r, e);
        assert!((num - f).abs() < 1e-6 * f, "{num} {f}");
        let (f2, _) = n.elastic(d + h, r, e);
        let (f1, _) = n.elastic(d - h, r, e);
        assert!(((f2 - f1) / (2.0 * h) - s).abs() < 1e-5 * s);
    }

    #[test]
    fn restitution_damping_linear_beta() {
        let DampingModel::Restitution { neg_beta, .. } = DampingModel::restitution(0.5).unwrap()
        else {
            panic!()
        };
        // zeta = -ln e / sqrt(pi^2 + ln^2 e) recovers e = exp(-pi zeta / sqrt(1 - zeta^2))
        let e = (-PI * neg_beta / (1.0 - neg_beta * neg_beta).sqrt()).exp();
        assert!((e - 0.5).abs() < 1e-14);
        assert!(DampingModel::restitution(0.0).is_err());
        assert!(DampingModel::restitution(1.5).is_err());
        assert_eq!(DampingModel::restitution(1.0).unwrap(), DampingModel::None);
    }

    #[test]
    fn coulomb_limit_binds() {
        let m = ContactModel {
            normal: NormalModel::Linear {
                k_n_n_per_m: 1000.0,
            },
            damping: DampingModel::None,
            tangential: TangentialModel::Linear {
                kt_over_kn: 1.0,
                mu: 0.5,
                damp_ratio: 0.0,
            },
            limit: CoulombLimit::default(),
        };
        let mat = PairMaterial::new(
            &Material::new(1e7, 0.3).unwrap(),
            &Material::new(1e7, 0.3).unwrap(),
        );
        let c = ContactState {
            delta: 1e-3,
            n: Vector3::z(),
            v_half: Vector3::new(1.0, 0.0, 0.0),
            v_full: Vector3::new(1.0, 0.0, 0.0),
            r_eff: 1e-3,
            m_eff: 1e-3,
            dt: 1e-3,
        };
        let mut xi = Vector3::zeros();
        let (f, ft) = m.force(&c, &mat, &mut xi);
        assert!((f.z - 1.0).abs() < 1e-12);
        assert!((ft.x + 0.5).abs() < 1e-12, "{ft:?}");
        assert!((xi.x - 0.5e-3).abs() < 1e-15);
    }

    #[test]
    fn no_tension_limit_caps_spring_alone() {
        // a damped sliding contact in its rebound (v_n < 0 pulls): the default law gives no
        // tension and no tangential force; while sliding in compression the force is exactly
        // mu F_n, carried by the spring; the LAMMPS law keeps the tension and the dashpot
        let linear = |limit| {
            ContactModel::new(
                NormalModel::Linear {
                    k_n_n_per_m: 1000.0,
                },
                DampingModel::restitution(0.5).unwrap(),
                TangentialModel::Linear {
                    kt_over_kn: 1.0,
                    mu: 0.5,
                    damp_ratio: 1.0,
                },
            )
            .unwrap()
            .with_limit(limit)
        };
        let mat = PairMaterial::new(
            &Material::new(1e7, 0.3).unwrap(),
            &Material::new(1e7, 0.3).unwrap(),
        );
        let state = |vn: f64| ContactState {
            delta: 1e-6,
            n: Vector3::z(),
            v_half: Vector3::new(1.0, 0.0, vn),
            v_full: Vector3::new(1.0, 0.0, vn),
            r_eff: 1e-3,
            m_eff: 1e-3,
            dt: 1e-3,
        };
        let mut xi = Vector3::zeros();
        let (f, ft) = linear(CoulombLimit::NoTension).force(&state(10.0), &mat, &mut xi);
        assert_eq!((f.z, ft.norm(), xi.norm()), (0.0, 0.0, 0.0));
        let mut xi = Vector3::zeros();
        let (f, _) = linear(CoulombLimit::DashpotInLimit).force(&state(10.0), &mat, &mut xi);
        assert!(f.z < 0.0, "{f:?}");
        let mut xi = Vector3::zeros();
        let (f, ft) = linear(CoulombLimit::NoTension).force(&state(-1e-3), &mat, &mut xi);
        assert!(f.z > 0.0);
        assert!((ft.norm() - 0.5 * f.z).abs() <= 1e-15 * f.z, "{ft:?} {f:?}");
        assert!(
            (xi * 1000.0 + ft).norm() <= 1e-15 * ft.norm(),
            "{xi:?} {ft:?}"
        );
    }

    #[test]
    fn zhou_slip_displacement_equal_materials() {
        // Mindlin & Deresiewicz: xi_max = mu delta (2 - nu) / (2 (1 - nu))
        for nu in [0.0, 0.25, 0.3, 0.45] {
            let m = Material::new(1e8, nu).unwrap();
            let p = PairMaterial::new(&m, &m);
            let got = zhou_slip_displacement(0.4, 1e-6, &p);
            let want = 0.4 * 1e-6 * (2.0 - nu) / (2.0 * (1.0 - nu));
            assert!((got - want).abs() < 1e-14 * want, "{nu}: {got} {want}");
        }
    }

    #[test]
    fn zhou_tangential_spring_curve_and_limit() {
        let (mu, f_cn, xi_max) = (0.3, 2.0, 1e-6);
        for x in [0.0, 0.25, 0.5, 0.999, 1.0, 1.5, 3.0] {
            let mut xi = Vector3::new(x * xi_max, 0.0, 0.0);
            let f = zhou_tangential(mu, 0.0, f_cn, xi_max, 1.0, &mut xi, &Vector3::zeros());
            let xc: f64 = x.min(1.0);
            let want = -mu * f_cn * (1.0 - (1.0 - xc).powf(1.5));
            assert!(
                (f.x - want).abs() <= 1e-15 * mu * f_cn,
                "{x}: {} {want}",
                f.x
            );
            assert!((xi.x - xc * xi_max).abs() <= 1e-15 * xi_max);
        }
    }

    #[test]
    fn zhou_initial_stiffness_is_mindlin() {
        // dF_t/dxi at 0 = 3 mu F_cn / (2 xi_max) = 8 G* sqrt(R* delta) for any nu, mu
        let m = Material::new(1e8, 0.3).unwrap();
        let w = Material::new(2e9, 0.2).unwrap();
        for p in [PairMaterial::new(&m, &m), PairMaterial::new(&m, &w)] {
            let (r, d, mu) = (1e-3, 1e-6, 0.5);
            let (f_cn, _) = NormalModel::Hertz.elastic(d, r, p.e_star_pa);
            let xi_max = zhou_slip_displacement(mu, d, &p);
            let eps = 1e-9 * xi_max;
            let mut xi = Vector3::new(eps, 0.0, 0.0);
            let f = zhou_tangential(mu, 0.0, f_cn, xi_max, 1.0, &mut xi, &Vector3::zeros());
            let k = -f.x / eps;
            let mindlin = 8.0 * p.g_star_pa * (r * d).sqrt();
            assert!((k - mindlin).abs() < 1e-8 * mindlin, "{k} {mindlin}");
        }
    }

    #[test]
    fn zhou_dashpot_is_critical_fraction_of_tangent_stiffness() {
        // c_t (6 mu m f sqrt(1-x)/xi_max)^(1/2) = c_t (4 m k_t)^(1/2), k_t = 1.5 mu f sqrt(1-x)/xi_max
        let (mu, f_cn, xi_max, m, c_t, x) = (0.5, 3.0, 2e-6, 1e-3, 0.2, 0.3);
        let mut xi = Vector3::new(x * xi_max, 0.0, 0.0);
        let v = Vector3::new(0.0, 1e-3, 0.0);
        let f = zhou_tangential(mu, c_t, f_cn, xi_max, m, &mut xi, &v);
        let k_t = 1.5 * mu * f_cn * (1.0 - x).sqrt() / xi_max;
        let want = -c_t * (4.0 * m * k_t).sqrt() * v.y;
        assert!((f.y - want).abs() < 1e-14 * want.abs(), "{} {want}", f.y);
    }
}
