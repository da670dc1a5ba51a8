//! The field tensor of one finite cylinder tabulated in its own frame, to a relative error
//! target: identical cylinders (the fibres of a bed) share one table, and a lookup costs a few
//! hundred multiply-adds instead of the elliptic integrals of [`super::kernel`].
//!
//! **What is tabulated.** Outside the cylinder psi(rho, z) (thesis ch. 5; see `kernel`) is
//! harmonic, so the tensor T = Hess psi and its gradient follow from six functions of
//! (rho, z), each even in rho:
//!   P = psi_rho/rho,  Q = P_z,  W = P_rho/rho,  Qz = Q_z,  Wz = W_z,  V = W_rho/rho,
//! with Z = psi_zz = -2P - rho^2 W (Laplace), Q_rho = rho Wz, Z_rho = rho Qz and
//! Z_z = -2Q - rho^2 Wz. In Cartesian form T_xx = P + x^2 W, T_xy = x y W, T_yy = P + y^2 W,
//! T_xz = x Q, T_yz = y Q, T_zz = Z, and every derivative is a polynomial in x, y times one of
//! the six functions, so no division by rho appears. P, W, V, Qz are even in z; Q, Wz odd.
//!
//! **How.** The quarter plane rho, z >= 0 up to the table's extent is cut into a graded grid of
//! rectangles, each refined as a quadtree until the tensor-product Chebyshev interpolant of
//! degree n - 1 (n x n first-kind nodes) of the six functions gives T and grad T within the
//! relative tolerance (Frobenius norms) at 16 test points of the rectangle (its corners, edge
//! thirds and inner points), checked against the exact kernel. A rectangle that still fails at
//! the deepest level is evaluated by the exact kernel, as is the exclusion zone
//! rho < R + delta, |z| < L + delta around the cylinder (the field is singular at the rims and
//! discontinuous across the surface there) and everything beyond the extent.

use super::Cylinder;
use crate::error::{invalid, require_positive, Result};
use crate::special::autodiff::{Dual, Real};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

type D3 = Dual<f64, 3>;

/// The six tabulated functions, in this order (module documentation).
const FUNCTIONS: usize = 6;
const TEST_FRACTIONS: [f64; 4] = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];
/// Azimuth of the test points (rad): every Cartesian entry of T is non-zero there.
const TEST_AZIMUTH: f64 = 0.7;
/// Quadtree levels below a top rectangle before a rectangle is left to the exact kernel.
const MAX_DEPTH: u32 = 14;

/// Accuracy and extent of a [`CylinderTable`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableSpec {
    /// Relative error target for T and grad T (Frobenius norms), per point.
    pub tolerance: f64,
    /// Chebyshev nodes per axis in a rectangle (4 to 16).
    pub nodes: usize,
    /// Margin delta (m) of the exact zone rho < R + delta, |z| < L + delta.
    pub exact_margin_m: f64,
    /// Largest rho and |z| (m) tabulated; beyond, the exact kernel.
    pub extent_m: f64,
}

impl TableSpec {
    /// Checks every value; `what` prefixes the message.
    pub fn check(&self) -> Result<()> {
        if !(self.tolerance.is_finite() && self.tolerance >= 1e-13 && self.tolerance < 1.0) {
            return invalid(format!(
                "field table tolerance {}: must be in [1e-13, 1) (relative)",
                self.tolerance
            ));
        }
        if !(4..=16).contains(&self.nodes) {
            return invalid(format!(
                "field table nodes per axis {}: must be between 4 and 16",
                self.nodes
            ));
        }
        require_positive(self.exact_margin_m, || {
            format!("field table exact margin {} m", self.exact_margin_m)
        })?;
        require_positive(self.extent_m, || {
            format!("field table extent {} m", self.extent_m)
        })?;
        Ok(())
    }
}

/// What building a table did (for reports and benchmarks).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TableStats {
    pub rectangles: usize,
    /// Rectangles left to the exact kernel after `MAX_DEPTH` refinements.
    pub exact_rectangles: usize,
    pub deepest_level: u32,
    /// Worst relative error of T or grad T over the accepted rectangles' test points.
    pub worst_test_error: f64,
    pub bytes: usize,
}

#[derive(Debug, Clone, Copy)]
enum Node {
    /// Chebyshev coefficients at `offset` in `coeffs` (FUNCTIONS n^2 values) over the
    /// rectangle with centre (rc, zc) and inverse half-widths (irh, izh).
    Leaf {
        offset: usize,
        rc: f64,
        zc: f64,
        irh: f64,
        izh: f64,
    },
    /// Four children at `first` .. `first + 4` (index 1 bit: rho >= rm, 2 bit: z >= zm).
    Split { first: usize, rm: f64, zm: f64 },
    /// Evaluated by the exact kernel.
    Exact,
}

/// The tabulated field tensor of one cylinder (module documentation).
#[derive(Debug, Clone)]
pub struct CylinderTable {
    cylinder: Cylinder,
    spec: TableSpec,
    rho_breaks: Vec<f64>,
    z_breaks: Vec<f64>,
    /// Root node of each top rectangle, rho index fastest.
    top: Vec<usize>,
    nodes: Vec<Node>,
    coeffs: Vec<f64>,
    stats: TableStats,
}

/// A subtree built for one top rectangle, its indices local to it.
struct Subtree {
    nodes: Vec<Node>,
    coeffs: Vec<f64>,
    stats: TableStats,
}

impl CylinderTable {
    /// Builds the table of `cylinder` to `spec` (checked). Deterministic: the rectangles are
    /// built in parallel and joined in a fixed order.
    pub fn new(cylinder: Cylinder, spec: TableSpec) -> Result<CylinderTable> {
        spec.check()?;
        let (r, l) = (cylinder.radius_m(), cylinder.half_length_m());
        let (re, ze) = (r + spec.exact_margin_m, l + spec.exact_margin_m);
        if spec.extent_m <= re.max(ze) {
            return invalid(format!(
                "field table extent {} m: must exceed the exact zone (rho < {re} m, |z| < {ze} m)",
                spec.extent_m
            ));
        }
        let rho_breaks = graded_breaks(re, spec.extent_m, re);
        let z_breaks = graded_breaks(ze, spec.extent_m, re);
        let (nr, nz) = (rho_breaks.len() - 1, z_breaks.len() - 1);
        let rects: Vec<(usize, usize)> = (0..nz)
            .flat_map(|iz| (0..nr).map(move |ir| (ir, iz)))
            .collect();
        let subtrees: Vec<Subtree> = rects
            .par_iter()
            .map(|&(ir, iz)| {
                let b = [
                    rho_breaks[ir],
                    rho_breaks[ir + 1],
                    z_breaks[iz],
                    z_breaks[iz + 1],
                ];
                if b[1] <= re && b[3] <= ze {
                    // the exact zone
                    Subtree {
                        nodes: vec![Node::Exact],
                        coeffs: Vec::new(),
                        stats: TableStats::default(),
                    }
                } else {
                    build_subtree(&cylinder, &spec, b)
                }
            })
            .collect();
        let mut t = CylinderTable {
            cylinder,
            spec,
            rho_breaks,
            z_breaks,
            top: Vec::with_capacity(subtrees.len()),
            nodes: Vec::new(),
            coeffs: Vec::new(),
            stats: TableStats::default(),
        };
        for s in subtrees {
            let (n0, c0) = (t.nodes.len(), t.coeffs.len());
            t.top.push(n0);
            t.nodes.extend(s.nodes.into_iter().map(|n| match n {
                Node::Leaf {
                    offset,
                    rc,
                    zc,
                    irh,
                    izh,
                } => Node::Leaf {
                    offset: offset + c0,
                    rc,
                    zc,
                    irh,
                    izh,
                },
                Node::Split { first, rm, zm } => Node::Split {
                    first: first + n0,
                    rm,
                    zm,
                },
                Node::Exact => Node::Exact,
            }));
            t.coeffs.extend(s.coeffs);
            t.stats.rectangles += s.stats.rectangles;
            t.stats.exact_rectangles += s.stats.exact_rectangles;
            t.stats.deepest_level = t.stats.deepest_level.max(s.stats.deepest_level);
            t.stats.worst_test_error = t.stats.worst_test_error.max(s.stats.worst_test_error);
        }
        t.stats.bytes = 8 * t.coeffs.len() + std::mem::size_of::<Node>() * t.nodes.len();
        Ok(t)
    }

    pub fn cylinder(&self) -> &Cylinder {
        &self.cylinder
    }
    pub fn spec(&self) -> &TableSpec {
        &self.spec
    }
    pub fn stats(&self) -> &TableStats {
        &self.stats
    }

    /// The leaf holding (rho, |z|), or None where the exact kernel answers.
    #[inline]
    fn leaf_at(&self, rho: f64, az: f64) -> Option<(usize, f64, f64)> {
        let (rb, zb) = (&self.rho_breaks, &self.z_breaks);
        if rho >= rb[rb.len() - 1] || az >= zb[zb.len() - 1] {
            return None;
        }
        let ir = rb.partition_point(|&b| b <= rho) - 1;
        let iz = zb.partition_point(|&b| b <= az) - 1;
        let mut k = self.top[iz * (rb.len() - 1) + ir];
        loop {
            match self.nodes[k] {
                Node::Leaf {
                    offset,
                    rc,
                    zc,
                    irh,
                    izh,
                } => {
                    // clamp rounding at the rectangle's edges into [-1, 1]
                    let u = ((rho - rc) * irh).clamp(-1.0, 1.0);
                    let w = ((az - zc) * izh).clamp(-1.0, 1.0);
                    return Some((offset, u, w));
                }
                Node::Split { first, rm, zm } => {
                    k = first + usize::from(rho >= rm) + 2 * usize::from(az >= zm);
                }
                Node::Exact => return None,
            }
        }
    }

    /// The six functions at (rho, z) from the table, or None where the exact kernel answers.
    #[inline]
    fn functions(&self, rho: f64, z: f64) -> Option<[f64; FUNCTIONS]> {
        let (offset, u, w) = self.leaf_at(rho, z.abs())?;
        let n = self.spec.nodes;
        let tu = chebyshev_values(u, n);
        let tw = chebyshev_values(w, n);
        let c = &self.coeffs[offset..offset + FUNCTIONS * n * n];
        let mut f = [0.0; FUNCTIONS];
        for (k, fk) in f.iter_mut().enumerate() {
            let ck = &c[k * n * n..(k + 1) * n * n];
            let mut s = 0.0;
            for j in 0..n {
                let row = &ck[j * n..(j + 1) * n];
                let mut r = 0.0;
                for i in 0..n {
                    r += row[i] * tu[i];
                }
                s += r * tw[j];
            }
            *fk = s;
        }
        if z < 0.0 {
            // Q and Wz are odd in z
            f[1] = -f[1];
            f[4] = -f[4];
        }
        Some(f)
    }

    /// True where [`CylinderTable::h_and_gradient`] answers from the table (not the kernel).
    pub fn tabulated(&self, p: &Vector3<f64>) -> bool {
        self.leaf_at(p.x.hypot(p.y), p.z.abs()).is_some()
    }

    /// (H in A/m, dH_i/dx_j in A/m^2) at p (m, cylinder frame) for magnetization m (A/m,
    /// cylinder frame): from the table where it holds, else from the exact kernel.
    #[inline]
    pub fn h_and_gradient(
        &self,
        m: &Vector3<f64>,
        p: &Vector3<f64>,
    ) -> (Vector3<f64>, Matrix3<f64>) {
        match self.functions(p.x.hypot(p.y), p.z) {
            Some(f) => field_from_functions(&f, m, p),
            None => self.cylinder.h_and_gradient(m, p),
        }
    }
}

/// Break points from 0: [0, first] as one piece, then pieces growing geometrically by 1.5 from
/// `step0`, the last ending at `end`.
fn graded_breaks(first: f64, end: f64, step0: f64) -> Vec<f64> {
    let mut b = vec![0.0];
    // the exact zone's long side (z up to L + delta) in pieces of about step0
    let pieces = (first / step0).ceil().max(1.0) as usize;
    for k in 1..=pieces {
        b.push(first * k as f64 / pieces as f64);
    }
    let mut step = step0;
    let mut x = first;
    while x < end {
        step *= 1.5;
        x = (x + step).min(end);
        if end - x < 0.5 * step {
            x = end;
        }
        b.push(x);
    }
    b.dedup();
    b
}

/// T_0(x) .. T_{n-1}(x).
#[inline]
fn chebyshev_values(x: f64, n: usize) -> [f64; 16] {
    let mut t = [0.0; 16];
    t[0] = 1.0;
    if n > 1 {
        t[1] = x;
    }
    for k in 2..n {
        t[k] = 2.0 * x * t[k - 1] - t[k - 2];
    }
    t
}

/// H and its gradient from the six functions at p (cylinder frame), by dual numbers in
/// (x, y, z): module documentation for the formulas.
#[inline]
fn field_from_functions(
    f: &[f64; FUNCTIONS],
    m: &Vector3<f64>,
    p: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>) {
    let t = tensor_from_functions(f, p);
    let h = |i: usize| t[i][0].scale(m.x) + t[i][1].scale(m.y) + t[i][2].scale(m.z);
    let (hx, hy, hz) = (h(0), h(1), h(2));
    (
        Vector3::new(hx.v, hy.v, hz.v),
        Matrix3::from_fn(|i, j| [hx, hy, hz][i].d[j]),
    )
}

/// T with its gradient (entries: value, d/dx, d/dy, d/dz) from the six functions at p.
fn tensor_from_functions(f: &[f64; FUNCTIONS], p: &Vector3<f64>) -> [[D3; 3]; 3] {
    let [pv, q, w, qz, wz, v] = *f;
    let (x, y) = (p.x, p.y);
    let rho2 = x * x + y * y;
    let pd = D3 {
        v: pv,
        d: [x * w, y * w, q],
    };
    let qd = D3 {
        v: q,
        d: [x * wz, y * wz, qz],
    };
    let wd = D3 {
        v: w,
        d: [x * v, y * v, wz],
    };
    let zd = D3 {
        v: -2.0 * pv - rho2 * w,
        d: [x * qz, y * qz, -2.0 * q - rho2 * wz],
    };
    let xd = D3::variable(x, 0);
    let yd = D3::variable(y, 1);
    let txy = xd * yd * wd;
    let txz = xd * qd;
    let tyz = yd * qd;
    [
        [pd + xd * xd * wd, txy, txz],
        [txy, pd + yd * yd * wd, tyz],
        [txz, tyz, zd],
    ]
}

/// The exact tensor with its gradient from the kernel (columns T e_j from three evaluations).
fn exact_tensor(c: &Cylinder, p: &Vector3<f64>) -> [[D3; 3]; 3] {
    let mut t = [[D3::constant(0.0); 3]; 3];
    for (j, e) in [Vector3::x(), Vector3::y(), Vector3::z()]
        .iter()
        .enumerate()
    {
        let (h, g) = c.h_and_gradient(e, p);
        for i in 0..3 {
            t[i][j] = D3 {
                v: h[i],
                d: [g[(i, 0)], g[(i, 1)], g[(i, 2)]],
            };
        }
    }
    t
}

/// The six functions at (rho, 0, z), rho > 0, from the exact tensor (module documentation).
fn exact_functions(c: &Cylinder, rho: f64, z: f64) -> [f64; FUNCTIONS] {
    let t = exact_tensor(c, &Vector3::new(rho, 0.0, z));
    let (r2, r3) = (rho * rho, rho * rho * rho);
    let w = (t[0][0].v - t[1][1].v) / r2;
    [
        t[1][1].v,
        t[0][2].v / rho,
        w,
        t[0][2].d[2] / rho,
        (t[0][0].d[2] - t[1][1].d[2]) / r2,
        (t[0][0].d[0] - t[1][1].d[0] - 2.0 * rho * w) / r3,
    ]
}

/// Relative Frobenius errors (T, grad T) of `a` against `b`.
fn tensor_errors(a: &[[D3; 3]; 3], b: &[[D3; 3]; 3]) -> (f64, f64) {
    let (mut dt, mut nt, mut dg, mut ng) = (0.0, 0.0, 0.0, 0.0);
    for i in 0..3 {
        for j in 0..3 {
            dt += (a[i][j].v - b[i][j].v).powi(2);
            nt += b[i][j].v.powi(2);
            for k in 0..3 {
                dg += (a[i][j].d[k] - b[i][j].d[k]).powi(2);
                ng += b[i][j].d[k].powi(2);
            }
        }
    }
    ((dt / nt).sqrt(), (dg / ng).sqrt())
}

/// Chebyshev coefficients of the six functions over rectangle b = [r0, r1, z0, z1] from their
/// values at the n x n first-kind nodes.
fn fit(c: &Cylinder, n: usize, b: [f64; 4]) -> Vec<f64> {
    let nodes: Vec<f64> = (0..n)
        .map(|k| (std::f64::consts::PI * (k as f64 + 0.5) / n as f64).cos())
        .collect();
    let map = |u: f64, lo: f64, hi: f64| 0.5 * (lo + hi) + 0.5 * (hi - lo) * u;
    // values[f][j][i] at (rho_i, z_j)
    let mut values = vec![0.0; FUNCTIONS * n * n];
    for (j, &wj) in nodes.iter().enumerate() {
        for (i, &ui) in nodes.iter().enumerate() {
            let f = exact_functions(c, map(ui, b[0], b[1]), map(wj, b[2], b[3]));
            for (k, fk) in f.iter().enumerate() {
                values[k * n * n + j * n + i] = *fk;
            }
        }
    }
    // T_a(node_i) = cos(a pi (i + 1/2) / n)
    let basis: Vec<f64> = (0..n * n)
        .map(|ai| {
            let (a, i) = (ai / n, ai % n);
            (std::f64::consts::PI * a as f64 * (i as f64 + 0.5) / n as f64).cos()
        })
        .collect();
    let norm = |a: usize| {
        if a == 0 {
            1.0 / n as f64
        } else {
            2.0 / n as f64
        }
    };
    let mut coeffs = vec![0.0; FUNCTIONS * n * n];
    let mut tmp = vec![0.0; n * n];
    for k in 0..FUNCTIONS {
        let v = &values[k * n * n..(k + 1) * n * n];
        // along rho: tmp[j][a] = norm(a) sum_i v[j][i] T_a(u_i)
        for j in 0..n {
            for a in 0..n {
                tmp[j * n + a] =
                    norm(a) * (0..n).map(|i| v[j * n + i] * basis[a * n + i]).sum::<f64>();
            }
        }
        // along z: c[b][a] = norm(b) sum_j tmp[j][a] T_b(w_j)
        for bb in 0..n {
            for a in 0..n {
                coeffs[k * n * n + bb * n + a] = norm(bb)
                    * (0..n)
                        .map(|j| tmp[j * n + a] * basis[bb * n + j])
                        .sum::<f64>();
            }
        }
    }
    coeffs
}

/// The quadtree of one top rectangle.
fn build_subtree(c: &Cylinder, spec: &TableSpec, b: [f64; 4]) -> Subtree {
    let mut s = Subtree {
        nodes: vec![Node::Exact],
        coeffs: Vec::new(),
        stats: TableStats::default(),
    };
    refine(c, spec, b, 0, 0, &mut s);
    s
}

fn refine(c: &Cylinder, spec: &TableSpec, b: [f64; 4], depth: u32, at: usize, s: &mut Subtree) {
    let n = spec.nodes;
    let coeffs = fit(c, n, b);
    let (rc, zc) = (0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]));
    let (irh, izh) = (2.0 / (b[1] - b[0]), 2.0 / (b[3] - b[2]));
    let mut worst = 0.0f64;
    let (sin, cos) = TEST_AZIMUTH.sin_cos();
    'test: for &fz in &TEST_FRACTIONS {
        for &fr in &TEST_FRACTIONS {
            let rho = b[0] + fr * (b[1] - b[0]);
            let z = b[2] + fz * (b[3] - b[2]);
            if rho == 0.0 {
                // the axis itself: checked just off it (the functions' rho-parity holds it)
                continue;
            }
            let p = Vector3::new(rho * cos, rho * sin, z);
            let (u, w) = (
                ((rho - rc) * irh).clamp(-1.0, 1.0),
                ((z - zc) * izh).clamp(-1.0, 1.0),
            );
            let (tu, tw) = (chebyshev_values(u, n), chebyshev_values(w, n));
            let mut f = [0.0; FUNCTIONS];
            for (k, fk) in f.iter_mut().enumerate() {
                *fk = (0..n)
                    .map(|j| {
                        tw[j]
                            * (0..n)
                                .map(|i| coeffs[k * n * n + j * n + i] * tu[i])
                                .sum::<f64>()
                    })
                    .sum();
            }
            let (et, eg) = tensor_errors(&tensor_from_functions(&f, &p), &exact_tensor(c, &p));
            worst = worst.max(et).max(eg);
            if !(worst <= spec.tolerance) {
                break 'test;
            }
        }
    }
    s.stats.deepest_level = s.stats.deepest_level.max(depth);
    if worst <= spec.tolerance {
        s.nodes[at] = Node::Leaf {
            offset: s.coeffs.len(),
            rc,
            zc,
            irh,
            izh,
        };
        s.coeffs.extend(coeffs);
        s.stats.rectangles += 1;
        s.stats.worst_test_error = s.stats.worst_test_error.max(worst);
        return;
    }
    if depth >= MAX_DEPTH {
        s.nodes[at] = Node::Exact;
        s.stats.exact_rectangles += 1;
        return;
    }
    let first = s.nodes.len();
    s.nodes.extend([Node::Exact; 4]);
    s.nodes[at] = Node::Split {
        first,
        rm: rc,
        zm: zc,
    };
    for k in 0..4 {
        let (r0, r1) = if k & 1 == 0 { (b[0], rc) } else { (rc, b[1]) };
        let (z0, z1) = if k & 2 == 0 { (b[2], zc) } else { (zc, b[3]) };
        refine(c, spec, [r0, r1, z0, z1], depth + 1, first + k, s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn fibre() -> Cylinder {
        Cylinder::new(2e-4, 2e-3).unwrap()
    }

    /// The six functions reassembled give the kernel's tensor and gradient (the formulas of
    /// the module documentation), at points off the axis in every octant.
    #[test]
    fn assembly_from_functions_matches_the_kernel() {
        let c = fibre();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..200 {
            let rho = rng.gen_range(2.5e-4..4e-3);
            let z: f64 = rng.gen_range(-5e-3..5e-3);
            let phi = rng.gen_range(0.0..std::f64::consts::TAU);
            let mut f = exact_functions(&c, rho, z.abs());
            if z < 0.0 {
                f[1] = -f[1];
                f[4] = -f[4];
            }
            let p = Vector3::new(rho * phi.cos(), rho * phi.sin(), z);
            let (et, eg) = tensor_errors(&tensor_from_functions(&f, &p), &exact_tensor(&c, &p));
            assert!(et < 1e-12 && eg < 1e-10, "rho {rho} z {z}: {et:e} {eg:e}");
        }
    }

    /// The table meets its tolerance at random points it did not test at (H and grad H for a
    /// random magnetization), and answers from the kernel in the exact zone.
    #[test]
    fn table_meets_its_tolerance_between_test_points() {
        let c = fibre();
        let spec = TableSpec {
            tolerance: 1e-7,
            nodes: 8,
            exact_margin_m: 1e-4,
            extent_m: 6e-3,
        };
        let t = CylinderTable::new(c, spec).unwrap();
        let st = *t.stats();
        assert!(st.rectangles > 10 && st.worst_test_error <= 1e-7, "{st:?}");
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let m = Vector3::new(3e5, -2e5, 7e5);
        let (mut worst_h, mut worst_g) = (0.0f64, 0.0f64);
        let mut tabulated = 0;
        for _ in 0..20000 {
            let p = Vector3::new(
                rng.gen_range(-6e-3..6e-3),
                rng.gen_range(-6e-3..6e-3),
                rng.gen_range(-6e-3..6e-3),
            );
            if c.contains(&p) {
                continue;
            }
            let (h, g) = t.h_and_gradient(&m, &p);
            let (he, ge) = c.h_and_gradient(&m, &p);
            if t.tabulated(&p) {
                tabulated += 1;
                worst_h = worst_h.max((h - he).norm() / he.norm());
                worst_g = worst_g.max((g - ge).norm() / ge.norm());
            } else {
                assert_eq!((h, g), (he, ge));
            }
        }
        assert!(tabulated > 5000, "{tabulated}");
        // the tolerance holds for T and grad T; H = T m can lose what m's direction cancels
        assert!(worst_g < 1e-6 && worst_h < 1e-6, "{worst_h:e} {worst_g:e}");
    }

    #[test]
    fn bad_specs_are_refused_by_name() {
        let mut s = TableSpec {
            tolerance: 1e-6,
            nodes: 8,
            exact_margin_m: 1e-4,
            extent_m: 1e-2,
        };
        s.nodes = 20;
        let e = CylinderTable::new(fibre(), s).unwrap_err().to_string();
        assert!(e.contains("nodes per axis 20"), "{e}");
        s.nodes = 8;
        s.extent_m = 1e-3;
        let e = CylinderTable::new(fibre(), s).unwrap_err().to_string();
        assert!(e.contains("extent"), "{e}");
    }
}
