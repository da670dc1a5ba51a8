//! The field of many identical magnetized cylinders (the fibres of a filter bed) in a periodic
//! cell: the model, its exact superposition, and a fast representation chosen by an error
//! target.
//!
//! **The model** ([`FibreAssembly`]). Each fibre is a uniformly magnetized finite cylinder
//! (thesis ch. 5; its magnetization is set by the caller, mutual magnetization neglected as in
//! thesis sec. 5.6). In a periodic cell every fibre has images; the field at x is the applied
//! H0 plus the fields of all images whose centre lies within the cutoff radius r_c of x, each
//! weighted by a smooth taper t(r) that falls from 1 to 0 over the last `taper_m` before r_c (so
//! the field is smooth and periodic; the gradient sum converges absolutely, the taper only
//! drops fibres farther than r_c - taper). Without periodic directions every fibre counts once
//! and no cutoff is needed. [`FibreAssembly::exact`] sums the exact kernel over the images.
//!
//! **The fast representation** ([`FastAssembly`]). Each image's field is split by a smooth
//! window s(q) of its ellipsoidal distance q = sqrt((rho/alpha)^2 + (z/beta)^2) (fibre frame,
//! alpha = R + w, beta = L + w for the window margin w): s = 0 for q <= 1, 1 for q >= q_out.
//! * near part (1 - s) H_i: evaluated per point for the images whose window reaches the point
//!   (a bin list), from the tabulated cylinder field ([`CylinderTable`]; exact kernel within the
//!   table's exact zone next to the fibre);
//! * far part: F(x) = sum_i s_i t_i H_i and its gradient, smooth everywhere (s vanishes where
//!   an image's field is not), stored on a periodic grid and interpolated by tensor-product
//!   Lagrange polynomials of `order` points per axis (F and each entry of its gradient
//!   separately).
//! The grid is computed with the same table. Errors: the table's tolerance plus the
//! interpolation error, measured against [`FibreAssembly::exact`] by
//! [`FastAssembly::measure_error`].

use super::cylinder_table::{CylinderTable, TableSpec, TableStats};
use super::Cylinder;
use crate::error::{invalid, require_positive, Result};
use nalgebra::{Matrix3, Rotation3, Vector3};
use rayon::prelude::*;

mod tabulated;
pub use tabulated::{BinFar, TabulatedAssembly, TabulatedStats};

/// An orthorhombic cell [0, L_x) x [0, L_y) x [0, L_z) (m), periodic along the marked axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub lengths_m: [f64; 3],
    pub periodic: [bool; 3],
}

impl Cell {
    pub fn new(lengths_m: [f64; 3], periodic: [bool; 3]) -> Result<Cell> {
        for (k, l) in lengths_m.iter().enumerate() {
            require_positive(*l, || format!("cell edge {} = {l} m", ["x", "y", "z"][k]))?;
        }
        Ok(Cell {
            lengths_m,
            periodic,
        })
    }
    /// `p` wrapped into the cell along its periodic axes.
    pub fn wrap(&self, p: &Vector3<f64>) -> Vector3<f64> {
        Vector3::from_fn(|k, _| {
            if self.periodic[k] {
                p[k].rem_euclid(self.lengths_m[k])
            } else {
                p[k]
            }
        })
    }
    /// The image shift n . L (m) for integer image index n.
    pub fn shift(&self, n: [i32; 3]) -> Vector3<f64> {
        Vector3::from_fn(|k, _| n[k] as f64 * self.lengths_m[k])
    }
    pub fn any_periodic(&self) -> bool {
        self.periodic.iter().any(|&p| p)
    }
}

/// The cutoff of the image sum: images whose centre is within `radius_m` of the point count,
/// weighted by a taper from 1 at `radius_m - taper_m` to 0 at `radius_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cutoff {
    pub radius_m: f64,
    pub taper_m: f64,
}

impl Cutoff {
    pub fn new(radius_m: f64, taper_m: f64) -> Result<Cutoff> {
        require_positive(radius_m, || format!("field cutoff radius {radius_m} m"))?;
        require_positive(taper_m, || format!("field cutoff taper {taper_m} m"))?;
        if taper_m >= radius_m {
            return invalid(format!(
                "field cutoff taper {taper_m} m: must be shorter than the cutoff radius \
                 {radius_m} m"
            ));
        }
        Ok(Cutoff { radius_m, taper_m })
    }
    /// (t, dt/dr) at centre distance r.
    #[inline]
    fn weight(&self, r: f64) -> (f64, f64) {
        let r0 = self.radius_m - self.taper_m;
        if r <= r0 {
            return (1.0, 0.0);
        }
        if r >= self.radius_m {
            return (0.0, 0.0);
        }
        let (s, ds) = smoothstep((r - r0) / self.taper_m);
        (1.0 - s, -ds / self.taper_m)
    }
}

/// (S(u), S'(u)): a C-infinity step from 0 at u <= 0 to 1 at u >= 1,
/// S = f(u) / (f(u) + f(1 - u)) with f(u) = exp(-1/u).
#[inline]
pub fn smoothstep(u: f64) -> (f64, f64) {
    if u <= 0.0 {
        return (0.0, 0.0);
    }
    if u >= 1.0 {
        return (1.0, 0.0);
    }
    let a = (-1.0 / u).exp();
    let b = (-1.0 / (1.0 - u)).exp();
    let s = a + b;
    (
        a / s,
        a * b * (1.0 / (u * u) + 1.0 / ((1.0 - u) * (1.0 - u))) / (s * s),
    )
}

/// Identical fibres (one cylinder shape) posed in a cell, each with its own magnetization.
#[derive(Debug, Clone)]
pub struct FibreAssembly {
    cylinder: Cylinder,
    cell: Cell,
    cutoff: Option<Cutoff>,
    centres: Vec<Vector3<f64>>,
    /// cylinder frame -> world
    rotations: Vec<Rotation3<f64>>,
    /// magnetization in each fibre's frame (A/m)
    m_local: Vec<Vector3<f64>>,
    /// applied field (A/m)
    h0: Vector3<f64>,
    /// image index ranges per axis that can fall within the cutoff of a point in the cell
    image_range: [i32; 3],
}

/// One image of a fibre: the fibre's index and its shift (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Image {
    pub fibre: u32,
    pub shift: Vector3<f64>,
}

impl FibreAssembly {
    /// `axes` need not be unit; `magnetizations` in world coordinates (A/m); `h0` the applied
    /// field (A/m). A cell with a periodic axis needs a cutoff no longer than... any length
    /// (images are enumerated as far as the cutoff reaches).
    pub fn new(
        cylinder: Cylinder,
        cell: Cell,
        cutoff: Option<Cutoff>,
        centres: Vec<Vector3<f64>>,
        axes: &[Vector3<f64>],
        magnetizations: &[Vector3<f64>],
        h0: Vector3<f64>,
    ) -> Result<FibreAssembly> {
        if centres.len() != axes.len() || centres.len() != magnetizations.len() {
            return invalid(format!(
                "fibres: {} centres, {} axes, {} magnetizations: need one of each per fibre",
                centres.len(),
                axes.len(),
                magnetizations.len()
            ));
        }
        if cell.any_periodic() && cutoff.is_none() {
            return invalid("a periodic cell needs a field cutoff radius (images are infinite)");
        }
        if !h0.iter().all(|v| v.is_finite()) {
            return invalid(format!("applied field {h0:?} A/m: must be finite"));
        }
        let mut rotations = Vec::with_capacity(axes.len());
        let mut m_local = Vec::with_capacity(axes.len());
        for (i, ((c, a), m)) in centres.iter().zip(axes).zip(magnetizations).enumerate() {
            let n = a.norm();
            if !(c.iter().all(|v| v.is_finite()) && n.is_finite() && n > 0.0) {
                return invalid(format!(
                    "fibre {i}: centre {c:?} m and axis {a:?} must be finite, the axis non-zero"
                ));
            }
            if !m.iter().all(|v| v.is_finite()) {
                return invalid(format!("fibre {i}: magnetization {m:?} A/m must be finite"));
            }
            let rot = Rotation3::rotation_between(&Vector3::z(), &(a / n)).unwrap_or_else(|| {
                Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
            });
            m_local.push(rot.inverse() * m);
            rotations.push(rot);
        }
        let image_range = match cutoff {
            None => [0; 3],
            Some(c) => std::array::from_fn(|k| {
                if cell.periodic[k] {
                    (c.radius_m / cell.lengths_m[k]).ceil() as i32 + 1
                } else {
                    0
                }
            }),
        };
        Ok(FibreAssembly {
            cylinder,
            cell,
            cutoff,
            centres,
            rotations,
            m_local,
            h0,
            image_range,
        })
    }

    pub fn cylinder(&self) -> &Cylinder {
        &self.cylinder
    }
    pub fn cell(&self) -> &Cell {
        &self.cell
    }
    pub fn cutoff(&self) -> Option<Cutoff> {
        self.cutoff
    }
    pub fn len(&self) -> usize {
        self.centres.len()
    }
    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }
    pub fn applied_field(&self) -> Vector3<f64> {
        self.h0
    }
    pub fn centre(&self, i: usize) -> Vector3<f64> {
        self.centres[i]
    }
    pub fn axis(&self, i: usize) -> Vector3<f64> {
        self.rotations[i] * Vector3::z()
    }
    pub fn magnetization(&self, i: usize) -> Vector3<f64> {
        self.rotations[i] * self.m_local[i]
    }

    /// Every image whose centre lies within `radius` (m) of `p` (p in the cell or anywhere).
    pub fn images_within(&self, p: &Vector3<f64>, radius: f64, out: &mut Vec<Image>) {
        out.clear();
        let r2 = radius * radius;
        let [ax, ay, az] = self.image_range;
        for (i, c) in self.centres.iter().enumerate() {
            // the image nearest p along each periodic axis, then neighbours
            let base: [i32; 3] = std::array::from_fn(|k| {
                if self.cell.periodic[k] {
                    ((p[k] - c[k]) / self.cell.lengths_m[k]).round() as i32
                } else {
                    0
                }
            });
            for nz in -az..=az {
                for ny in -ay..=ay {
                    for nx in -ax..=ax {
                        let n = [base[0] + nx, base[1] + ny, base[2] + nz];
                        let shift = self.cell.shift(n);
                        if (c + shift - p).norm_squared() < r2 {
                            out.push(Image {
                                fibre: i as u32,
                                shift,
                            });
                        }
                    }
                }
            }
        }
    }

    /// The images that count at `p`: within the cutoff, or every fibre once without one.
    fn counting_images(&self, p: &Vector3<f64>, out: &mut Vec<Image>) {
        match self.cutoff {
            Some(c) => self.images_within(p, c.radius_m, out),
            None => {
                out.clear();
                out.extend((0..self.centres.len()).map(|i| Image {
                    fibre: i as u32,
                    shift: Vector3::zeros(),
                }))
            }
        }
    }

    /// (H, dH_i/dx_j) of one image at p (world), from `eval` in the fibre frame
    /// (`eval(m_local, p_local)`), without the cutoff weight.
    #[inline]
    fn image_field(
        &self,
        im: &Image,
        p: &Vector3<f64>,
        eval: impl Fn(&Vector3<f64>, &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>),
    ) -> (Vector3<f64>, Matrix3<f64>) {
        let i = im.fibre as usize;
        let rot = &self.rotations[i];
        let pl = rot.inverse() * (p - self.centres[i] - im.shift);
        let (h, g) = eval(&self.m_local[i], &pl);
        let r = rot.matrix();
        (r * h, r * g * r.transpose())
    }

    /// Adds weight t(r) times an image's field, with the taper's gradient term H (x) grad t.
    #[inline]
    fn add_tapered(
        &self,
        im: &Image,
        p: &Vector3<f64>,
        hg: (Vector3<f64>, Matrix3<f64>),
        acc: &mut (Vector3<f64>, Matrix3<f64>),
    ) {
        let (h, g) = hg;
        match self.cutoff {
            None => {
                acc.0 += h;
                acc.1 += g;
            }
            Some(c) => {
                let d = p - self.centres[im.fibre as usize] - im.shift;
                let r = d.norm();
                let (t, dt) = c.weight(r);
                acc.0 += h * t;
                acc.1 += g * t;
                if dt != 0.0 {
                    acc.1 += h * (d * (dt / r)).transpose();
                }
            }
        }
    }

    /// The exact superposition at p (world, m): H (A/m, applied field included) and
    /// dH_i/dx_j (A/m^2), every counting image by the exact kernel.
    pub fn exact(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        let p = self.cell.wrap(p);
        let mut images = Vec::new();
        self.counting_images(&p, &mut images);
        self.sum_images(&p, &images, |m, q| self.cylinder.h_and_gradient(m, q))
    }

    /// H0 plus the tapered sum over `images` at p (wrapped), each image's field from `eval`
    /// in its fibre's frame; images beyond the cutoff add nothing.
    #[inline]
    fn sum_images(
        &self,
        p: &Vector3<f64>,
        images: &[Image],
        eval: impl Fn(&Vector3<f64>, &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>),
    ) -> (Vector3<f64>, Matrix3<f64>) {
        let r2 = self
            .cutoff
            .map_or(f64::INFINITY, |c| c.radius_m * c.radius_m);
        let mut acc = (self.h0, Matrix3::zeros());
        for im in images {
            let d = p - self.centres[im.fibre as usize] - im.shift;
            if d.norm_squared() >= r2 {
                continue;
            }
            let hg = self.image_field(im, p, &eval);
            self.add_tapered(im, p, hg, &mut acc);
        }
        acc
    }
}

/// The accuracy knobs of a [`FastAssembly`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FastSpec {
    /// The tabulated cylinder field for the near images and the grid (None: the exact kernel).
    pub table: Option<TableSpec>,
    /// Window margin w (m): the near window's inner ellipsoid has semi-axes R + w, L + w.
    pub window_margin_m: f64,
    /// Outer ellipsoid of the window, as a multiple q_out > 1 of the inner one.
    pub window_outer: f64,
    /// Far grid spacing (m, largest; each axis gets a whole number of nodes).
    pub grid_spacing_m: f64,
    /// Lagrange points per axis of the far grid's interpolation (even, 2 to 10).
    pub order: usize,
}

impl FastSpec {
    pub fn check(&self) -> Result<()> {
        if let Some(t) = &self.table {
            t.check()?;
        }
        require_positive(self.window_margin_m, || {
            format!("field window margin {} m", self.window_margin_m)
        })?;
        if !(self.window_outer.is_finite() && self.window_outer > 1.0) {
            return invalid(format!(
                "field window outer ratio {}: must be above 1",
                self.window_outer
            ));
        }
        require_positive(self.grid_spacing_m, || {
            format!("field grid spacing {} m", self.grid_spacing_m)
        })?;
        if !(2..=10).contains(&self.order) || self.order % 2 != 0 {
            return invalid(format!(
                "field grid order {}: must be even, 2 to 10 points per axis",
                self.order
            ));
        }
        Ok(())
    }
}

/// The near window of one fibre shape.
#[derive(Debug, Clone, Copy)]
struct Window {
    inv_a2: f64,
    inv_b2: f64,
    q_out2: f64,
    /// semi-axes of the outer ellipsoid (radial, axial)
    outer: (f64, f64),
}

impl Window {
    /// (s, grad s) at p_local (fibre frame): 0 inside q <= 1, 1 beyond q_out; `None` when
    /// s = 1 (the image belongs wholly to the far grid).
    #[inline]
    fn weight(&self, p: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
        let q2 = (p.x * p.x + p.y * p.y) * self.inv_a2 + p.z * p.z * self.inv_b2;
        if q2 >= self.q_out2 {
            return None;
        }
        if q2 <= 1.0 {
            return Some((0.0, Vector3::zeros()));
        }
        let span = self.q_out2 - 1.0;
        let (s, ds) = smoothstep((q2 - 1.0) / span);
        let k = 2.0 * ds / span;
        Some((
            s,
            Vector3::new(
                k * p.x * self.inv_a2,
                k * p.y * self.inv_a2,
                k * p.z * self.inv_b2,
            ),
        ))
    }
    /// (segment half-length, radius) of a capsule around the fibre axis containing the outer
    /// ellipsoid (a prolate spheroid of semi-axes A >= B lies inside the capsule of radius B
    /// about the segment of half-length A - B).
    fn capsule(&self) -> (f64, f64) {
        let (b, a) = self.outer;
        if a >= b {
            (a - b, b)
        } else {
            (0.0, b)
        }
    }
}

/// A uniform grid over the cell (periodic axes) listing, per bin, the images whose near
/// window reaches into it.
#[derive(Debug, Clone)]
struct Bins {
    n: [usize; 3],
    size: [f64; 3],
    start: Vec<u32>,
    images: Vec<Image>,
}

impl Bins {
    /// Bins of `size` (m), `n` per axis, from one image list per bin (x fastest).
    fn from_lists(n: [usize; 3], size: [f64; 3], lists: Vec<Vec<Image>>) -> Result<Bins> {
        let mut start = Vec::with_capacity(lists.len() + 1);
        let mut images = Vec::new();
        start.push(0u32);
        for l in lists {
            images.extend(l);
            if images.len() > u32::MAX as usize {
                return invalid("too many images for the bin lists: use smaller bins");
            }
            start.push(images.len() as u32);
        }
        Ok(Bins {
            n,
            size,
            start,
            images,
        })
    }
    #[inline]
    fn of(&self, p: &Vector3<f64>) -> &[Image] {
        self.list(self.index(p))
    }
    /// The bin holding p (in the cell).
    #[inline]
    fn index(&self, p: &Vector3<f64>) -> usize {
        let idx: [usize; 3] =
            std::array::from_fn(|k| ((p[k] / self.size[k]) as usize).min(self.n[k] - 1));
        (idx[2] * self.n[1] + idx[1]) * self.n[0] + idx[0]
    }
    #[inline]
    fn list(&self, b: usize) -> &[Image] {
        &self.images[self.start[b] as usize..self.start[b + 1] as usize]
    }
}

/// The far part on a periodic grid: per node F (3) then its gradient (9, row-major).
#[derive(Debug, Clone)]
struct FarGrid {
    n: [usize; 3],
    h: [f64; 3],
    order: usize,
    values: Vec<[f64; 12]>,
}

impl FarGrid {
    /// Lagrange weights of the `order` nodes around x along axis k, and the first node index.
    #[inline]
    fn weights(&self, x: f64, k: usize, w: &mut [f64; 10]) -> i64 {
        let t = x / self.h[k];
        let i0 = t.floor();
        let xi = t - i0;
        let half = (self.order / 2) as i64;
        let first = i0 as i64 - half + 1;
        let o = self.order;
        for (m, wm) in w.iter_mut().enumerate().take(o) {
            let xm = (m as i64 - half + 1) as f64;
            let mut num = 1.0;
            let mut den = 1.0;
            for n in 0..o {
                if n != m {
                    let xn = (n as i64 - half + 1) as f64;
                    num *= xi - xn;
                    den *= xm - xn;
                }
            }
            *wm = num / den;
        }
        first
    }

    #[inline]
    fn interpolate(&self, p: &Vector3<f64>) -> [f64; 12] {
        let (mut wx, mut wy, mut wz) = ([0.0; 10], [0.0; 10], [0.0; 10]);
        let fx = self.weights(p.x, 0, &mut wx);
        let fy = self.weights(p.y, 1, &mut wy);
        let fz = self.weights(p.z, 2, &mut wz);
        let [nx, ny, nz] = self.n.map(|v| v as i64);
        let mut out = [0.0; 12];
        for (c, wc) in wz.iter().enumerate().take(self.order) {
            let iz = (fz + c as i64).rem_euclid(nz) as usize;
            for (b, wb) in wy.iter().enumerate().take(self.order) {
                let iy = (fy + b as i64).rem_euclid(ny) as usize;
                let row = (iz * self.n[1] + iy) * self.n[0];
                let wcb = wc * wb;
                for (a, wa) in wx.iter().enumerate().take(self.order) {
                    let ix = (fx + a as i64).rem_euclid(nx) as usize;
                    let w = wcb * wa;
                    let v = &self.values[row + ix];
                    for k in 0..12 {
                        out[k] += w * v[k];
                    }
                }
            }
        }
        out
    }
}

/// What building a [`FastAssembly`] produced (for reports and benchmarks).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FastStats {
    /// Zero without a table.
    pub table: TableStats,
    pub grid_nodes: [usize; 3],
    pub grid_bytes: usize,
    /// Mean near images per bin (upper bound of the near images evaluated at a point).
    pub near_images_per_bin: f64,
    pub build_seconds: f64,
}

/// The fast representation of a [`FibreAssembly`] (module documentation).
#[derive(Debug, Clone)]
pub struct FastAssembly {
    model: FibreAssembly,
    spec: FastSpec,
    table: Option<CylinderTable>,
    window: Window,
    bins: Bins,
    grid: FarGrid,
    stats: FastStats,
}

impl FastAssembly {
    /// Builds the table, the near-image bins and the far grid for `model`, which must be
    /// periodic along every axis.
    pub fn new(model: FibreAssembly, spec: FastSpec) -> Result<FastAssembly> {
        let t0 = std::time::Instant::now();
        spec.check()?;
        let cell = *model.cell();
        if cell.periodic != [true; 3] {
            return invalid("the fast field representation needs a cell periodic along x, y and z");
        }
        let Some(cutoff) = model.cutoff() else {
            return invalid("the fast field representation needs a field cutoff");
        };
        let (r, l) = (model.cylinder.radius_m(), model.cylinder.half_length_m());
        let (alpha, beta) = (r + spec.window_margin_m, l + spec.window_margin_m);
        let window = Window {
            inv_a2: 1.0 / (alpha * alpha),
            inv_b2: 1.0 / (beta * beta),
            q_out2: spec.window_outer * spec.window_outer,
            outer: (alpha * spec.window_outer, beta * spec.window_outer),
        };
        // the fibre must lie inside the inner ellipsoid (there s = 0)
        if (r / alpha).powi(2) + (l / beta).powi(2) >= 1.0 {
            return invalid(format!(
                "field window margin {} m: the inner ellipsoid (semi-axes {alpha} m, {beta} m) \
                 must contain the fibre (R = {r} m, L = {l} m); use a larger margin",
                spec.window_margin_m
            ));
        }
        let bin_size = cell.lengths_m.map(|len| {
            let n = (len / (0.5 * window.outer.0)).floor().max(1.0);
            len / n
        });
        let bin_radius = 0.5 * (bin_size[0].hypot(bin_size[1])).hypot(bin_size[2]);
        let (seg, rad) = window.capsule();
        let reach = seg.hypot(rad) + bin_radius;
        if reach > cutoff.radius_m - cutoff.taper_m {
            return invalid(format!(
                "field cutoff {} m (taper {} m): must exceed the near window's reach {reach:.4e} m \
                 (window margin {} m, outer ratio {}) by the taper; raise the cutoff or narrow the \
                 window",
                cutoff.radius_m, cutoff.taper_m, spec.window_margin_m, spec.window_outer
            ));
        }
        let table = match spec.table {
            None => None,
            Some(t) => Some(CylinderTable::new(
                model.cylinder,
                TableSpec {
                    extent_m: t.extent_m.max(cutoff.radius_m + 2.0 * l),
                    ..t
                },
            )?),
        };
        let bins = build_bins(&model, &window, bin_size, bin_radius + rad, seg)?;
        let n: [usize; 3] = std::array::from_fn(|k| {
            (cell.lengths_m[k] / spec.grid_spacing_m).ceil().max(4.0) as usize
        });
        let h: [f64; 3] = std::array::from_fn(|k| cell.lengths_m[k] / n[k] as f64);
        let bytes = 96.0 * (n[0] * n[1] * n[2]) as f64;
        if bytes > 4e9 {
            return invalid(format!(
                "field grid spacing {} m: {} x {} x {} nodes need {:.1} GB; use a coarser grid",
                spec.grid_spacing_m,
                n[0],
                n[1],
                n[2],
                bytes / 1e9
            ));
        }
        let mut fast = FastAssembly {
            model,
            spec,
            table,
            window,
            bins,
            grid: FarGrid {
                n,
                h,
                order: spec.order,
                values: Vec::new(),
            },
            stats: FastStats::default(),
        };
        fast.grid.values = fast.far_values();
        fast.stats = FastStats {
            table: fast.table.as_ref().map(|t| *t.stats()).unwrap_or_default(),
            grid_nodes: n,
            grid_bytes: 96 * fast.grid.values.len(),
            near_images_per_bin: fast.bins.images.len() as f64 / (fast.bins.start.len() - 1) as f64,
            build_seconds: t0.elapsed().as_secs_f64(),
        };
        Ok(fast)
    }

    pub fn model(&self) -> &FibreAssembly {
        &self.model
    }
    pub fn spec(&self) -> &FastSpec {
        &self.spec
    }
    pub fn stats(&self) -> &FastStats {
        &self.stats
    }

    /// One image's (H, dH_i/dx_j) in its fibre's frame: the table where there is one, else
    /// the exact kernel.
    #[inline]
    fn local_field(&self, m: &Vector3<f64>, pl: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        match &self.table {
            Some(t) => t.h_and_gradient(m, pl),
            None => self.model.cylinder.h_and_gradient(m, pl),
        }
    }

    /// F and grad F at every grid node (the far part).
    fn far_values(&self) -> Vec<[f64; 12]> {
        let g = &self.grid;
        let total = g.n[0] * g.n[1] * g.n[2];
        (0..total)
            .into_par_iter()
            .map_init(Vec::new, |images, idx| {
                let (ix, iy, iz) = (
                    idx % g.n[0],
                    (idx / g.n[0]) % g.n[1],
                    idx / (g.n[0] * g.n[1]),
                );
                let p = Vector3::new(ix as f64 * g.h[0], iy as f64 * g.h[1], iz as f64 * g.h[2]);
                self.model.counting_images(&p, images);
                let mut acc = (Vector3::zeros(), Matrix3::zeros());
                for im in images.iter() {
                    let i = im.fibre as usize;
                    let rot = &self.model.rotations[i];
                    let pl = rot.inverse() * (p - self.model.centres[i] - im.shift);
                    let (s, grad_s) = match self.window.weight(&pl) {
                        None => (1.0, Vector3::zeros()),
                        Some((s, _)) if s == 0.0 => continue,
                        Some(w) => w,
                    };
                    let (hl, gl) = self.local_field(&self.model.m_local[i], &pl);
                    // s H and its gradient in the fibre frame, then to the world
                    let (hw, gw) = (hl * s, gl * s + hl * grad_s.transpose());
                    let rm = rot.matrix();
                    let hg = (rm * hw, rm * gw * rm.transpose());
                    self.model.add_tapered(im, &p, hg, &mut acc);
                }
                let mut v = [0.0; 12];
                v[..3].copy_from_slice(acc.0.as_slice());
                for i in 0..3 {
                    for j in 0..3 {
                        v[3 + 3 * i + j] = acc.1[(i, j)];
                    }
                }
                v
            })
            .collect()
    }

    /// (H, dH_i/dx_j) at p (world, m): applied field + near images + far grid.
    #[inline]
    pub fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        let p = self.model.cell.wrap(p);
        let far = self.grid.interpolate(&p);
        let mut h = self.model.h0 + Vector3::new(far[0], far[1], far[2]);
        let mut g = Matrix3::from_fn(|i, j| far[3 + 3 * i + j]);
        for im in self.bins.of(&p) {
            let i = im.fibre as usize;
            let rot = &self.model.rotations[i];
            let pl = rot.inverse() * (p - self.model.centres[i] - im.shift);
            let Some((s, grad_s)) = self.window.weight(&pl) else {
                continue;
            };
            let (hl, gl) = self.local_field(&self.model.m_local[i], &pl);
            let hw = hl * (1.0 - s);
            let gw = gl * (1.0 - s) - hl * grad_s.transpose();
            let rm = rot.matrix();
            h += rm * hw;
            g += rm * gw * rm.transpose();
        }
        (h, g)
    }

    /// Relative errors of the fast field against the exact superposition at `points`:
    /// per point |dF| / |F| of the force on a unit moment along H (the gradient contracted
    /// with H/|H|) and |dH| / |H|. Returns the two lists, in the order of `points`.
    pub fn measure_error(&self, points: &[Vector3<f64>]) -> (Vec<f64>, Vec<f64>) {
        points
            .par_iter()
            .map(|p| {
                let (hf, gf) = self.h_and_gradient(p);
                let (he, ge) = self.model.exact(p);
                let u = he / he.norm();
                let (ff, fe) = (gf * u, ge * u);
                ((ff - fe).norm() / fe.norm(), (hf - he).norm() / he.norm())
            })
            .unzip()
    }
}

/// The centre (m) of bin `b` of `n` bins of `size` per axis (x fastest).
fn bin_centre(n: [usize; 3], size: [f64; 3], b: usize) -> Vector3<f64> {
    let idx = [b % n[0], (b / n[0]) % n[1], b / (n[0] * n[1])];
    Vector3::from_fn(|k, _| (idx[k] as f64 + 0.5) * size[k])
}

/// The near-image lists of `bins` of the given size: an image belongs to a bin when its window
/// capsule (segment half-length `seg`, radius `reach` - the bin radius) reaches the bin's
/// bounding sphere.
fn build_bins(
    model: &FibreAssembly,
    _window: &Window,
    size: [f64; 3],
    reach: f64,
    seg: f64,
) -> Result<Bins> {
    let cell = model.cell();
    let n: [usize; 3] = std::array::from_fn(|k| (cell.lengths_m[k] / size[k]).round() as usize);
    let total = n[0] * n[1] * n[2];
    let lists: Vec<Vec<Image>> = (0..total)
        .into_par_iter()
        .map_init(Vec::new, |cand, b| {
            let centre = bin_centre(n, size, b);
            model.images_within(&centre, reach + seg, cand);
            cand.iter()
                .copied()
                .filter(|im| {
                    let i = im.fibre as usize;
                    let a = model.axis(i);
                    let d = centre - model.centres[i] - im.shift;
                    let t = d.dot(&a).clamp(-seg, seg);
                    (d - a * t).norm() <= reach
                })
                .collect()
        })
        .collect();
    Bins::from_lists(n, size, lists)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A small random bed: `n` fibres R = 0.2 mm, L/D = 5, in a periodic cube of edge 4 mm,
    /// magnetized along their axis' projection (any fixed law will do for the field tests).
    pub(super) fn bed(n: usize, seed: u64, cutoff: f64) -> FibreAssembly {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let cyl = Cylinder::new(2e-4, 1e-3).unwrap();
        let cell = Cell::new([4e-3; 3], [true; 3]).unwrap();
        let mut centres = Vec::new();
        let mut axes = Vec::new();
        let mut ms = Vec::new();
        for _ in 0..n {
            centres.push(Vector3::from_fn(|_, _| rng.gen_range(0.0..4e-3)));
            let a = Vector3::from_fn(|_, _| rng.gen_range(-1.0..1.0)).normalize();
            axes.push(a);
            ms.push((a * 0.6 + Vector3::x() * 0.8) * 1e6);
        }
        FibreAssembly::new(
            cyl,
            cell,
            Some(Cutoff::new(cutoff, 1e-3).unwrap()),
            centres,
            &axes,
            &ms,
            Vector3::new(8e5, 0.0, 0.0),
        )
        .unwrap()
    }

    #[test]
    fn smoothstep_is_a_smooth_step() {
        assert_eq!(smoothstep(-1.0), (0.0, 0.0));
        assert_eq!(smoothstep(2.0), (1.0, 0.0));
        let (s, _) = smoothstep(0.5);
        assert!((s - 0.5).abs() < 1e-15);
        for &u in &[0.1, 0.37, 0.8] {
            let h = 1e-6;
            let fd = (smoothstep(u + h).0 - smoothstep(u - h).0) / (2.0 * h);
            assert!((fd - smoothstep(u).1).abs() < 1e-8, "{u}");
        }
    }

    /// The image sum is periodic and its gradient is the derivative of its field (central
    /// differences), taper included.
    #[test]
    fn exact_superposition_is_periodic_and_consistent() {
        let a = bed(6, 1, 5e-3);
        let p = Vector3::new(1.1e-3, 2.7e-3, 0.3e-3);
        let (h, g) = a.exact(&p);
        let (h2, g2) = a.exact(&(p + Vector3::new(4e-3, -8e-3, 4e-3)));
        assert!((h - h2).norm() < 1e-9 * h.norm() && (g - g2).norm() < 1e-9 * g.norm());
        let d = 1e-8;
        for k in 0..3 {
            let e = Vector3::from_fn(|i, _| if i == k { d } else { 0.0 });
            let fd = (a.exact(&(p + e)).0 - a.exact(&(p - e)).0) / (2.0 * d);
            let col = g.column(k);
            assert!((fd - col).norm() < 1e-5 * g.norm(), "{k}: {fd} vs {col}");
        }
    }

    /// At the far grid's nodes the interpolation returns the stored sums, so the fast field
    /// there is the exact superposition to rounding: this checks the near/far split itself
    /// (the near-image lists, the window's weights and gradient terms, the taper), apart from
    /// the interpolation error between nodes (measured by `porelab bench filter`).
    #[test]
    fn fast_field_is_the_exact_superposition_at_grid_nodes() {
        let a = bed(12, 2, 4.5e-3);
        let spec = FastSpec {
            table: None,
            window_margin_m: 4e-4,
            window_outer: 1.5,
            grid_spacing_m: 4e-4,
            order: 4,
        };
        let f = FastAssembly::new(a, spec).unwrap();
        let n = f.stats().grid_nodes;
        let h = 4e-3 / n[0] as f64;
        let (mut checked, mut near_points) = (0, 0);
        let mut worst = 0.0f64;
        for iz in 0..n[2] {
            for iy in 0..n[1] {
                for ix in 0..n[0] {
                    let p = Vector3::new(ix as f64, iy as f64, iz as f64) * h;
                    let m = f.model();
                    let mut ims = Vec::new();
                    m.images_within(&p, 3e-3, &mut ims);
                    let inside = ims.iter().any(|im| {
                        let i = im.fibre as usize;
                        let d = p - m.centre(i) - im.shift;
                        let z = d.dot(&m.axis(i));
                        (d - m.axis(i) * z).norm() <= 2.0e-4 && z.abs() <= 1e-3
                    });
                    if inside {
                        continue;
                    }
                    near_points += usize::from(!f.bins.of(&f.model.cell.wrap(&p)).is_empty());
                    let (hf, gf) = f.h_and_gradient(&p);
                    let (he, ge) = m.exact(&p);
                    worst = worst
                        .max((hf - he).norm() / he.norm())
                        .max((gf - ge).norm() / ge.norm());
                    checked += 1;
                }
            }
        }
        assert!(
            checked > 800 && near_points > 100,
            "{checked} {near_points}"
        );
        assert!(worst < 1e-10, "worst relative difference {worst:e}");
    }
}
