//! Curved solid walls: where the solid's surface cuts each fluid-solid link, and the
//! interpolated bounce-back that puts the wall there.
//!
//! A link is a fluid node x and a lattice direction c whose neighbour x + c is solid; its wall
//! fraction q in (0, 1] places the surface at x + q c (the first crossing of the segment
//! x -> x + c with the surface). [`WallFractions`] holds q for every link of a mask, found by
//! a crossing rule ([`WallFractions::from_crossings`]): exactly for spheres and cylinders
//! ([`sphere_crossing`], a quadratic), by a root-find on a convex shape's inside-outside
//! function for the other particle shapes ([`convex_crossing`]).
//!
//! The bounce-back is Ginzburg's central linear interpolation (CLI; I. Ginzburg, F. Verhaeghe,
//! D. d'Humières, Commun. Comput. Phys. 3, 427 (2008), the linear family of their sec. 5;
//! I. Ginzburg, D. d'Humières, Phys. Rev. E 68, 066614 (2003)): with c pointing from the
//! boundary node x to the wall and post-collision populations f*,
//!
//! f_{-c}(x, t + 1) = f*_c(x) + kappa(q) [f*_c(x - c) - f*_{-c}(x)],
//! kappa(q) = (1 - 2q) / (1 + 2q),
//!
//! which is halfway bounce-back at q = 1/2. Its coefficients do not depend on the relaxation
//! times, so with TRT at a fixed magic parameter (Lambda = 3/16, [`super::collision::Trt`])
//! the steady flow, and so the permeability, does not depend on the viscosity. Where the
//! second node x - c is solid (a gap of one cell) the link falls back to halfway bounce-back.
//! CLI does not conserve mass exactly (the interpolated population is not the one that left);
//! the drift is measured in the pore mode's tests and stated in `benches/RESULTS.md`.
//!
//! Known limit: in a dense random packing CLI is unstable. On the 1000-sphere built-in packing
//! (24 to 40 cells across, 2.6 to 4.3 per diameter, D3Q19 TRT, tau 0.7 to 1.5, BGK and D3Q15
//! alike) a local mode grows about fourfold every 500 steps in pockets of fluid nodes with
//! 10-13 of their 18 neighbours solid, carried by links with small q (kappa -> 1, weights
//! 1, 1, -1), and an independent NumPy TRT + CLI code on the same voxels grows the same way.
//! What was tried (body force 1e-6, `--resolution N` runs N/2 then N; "grew" = Mach 0.3):
//! - another magic parameter (NumPy code, 24 cells, tau 1): Lambda = 1/4 grows 3.6x and
//!   Lambda = 1/12 5x per 500 steps (3/16: 4x);
//! - CLI with q raised to a floor q_c before kappa (the rule keeps CLI's form, so the wall
//!   stays independent of tau): q_c = 0.15 and 0.2 grew within 20,000 steps at 24 cells;
//!   q_c = 0.25 (|kappa| <= 1/3, CLI's own bound for q >= 1/2) ran 20,000 steps at 24, 32 and
//!   48 cells, tau 0.7 and 1, and 100,000 at 24 cells, tau 0.7, but grew after 65,100 steps
//!   at tau 1 and 32,600 at tau 1.5 (both on the 24-cell lattice);
//!   q_c = 0.3 and 0.35 grew at tau 1.5 (pair 12/24: 43,500 and 69,300 steps); only
//!   q_c = 1/2 (halfway bounce-back on every link with q < 1/2, a wall moved by up to half a
//!   cell towards the solid) ran 100,000 steps at tau 1.5;
//! - it is not a closed pocket's own mode: 2- to 6-node pockets with random q have spectral
//!   radius 1 (to 1e-14) under CLI;
//! - Bouzidi-Firdaouss-Lallemand's rule (non-negative weights summing to one) is stable
//!   (20,000 steps at 24 and 32 cells, tau 0.7 and 1), but its wall depends on tau: k rises
//!   28 % from tau 0.7 to 1 at 24 cells and 27 % at 32, and with it only below q = 1/4 (CLI
//!   above) 19 % and 17 %. Ginzburg, Verhaeghe & d'Humieres (2008) correct this with their
//!   parametrization term; its form was not at hand.
//! For comparison the staircase walls themselves seemed to move with tau on this packing (k
//! rose 4.2 %, 1.8 % and 0.6 % from tau 0.7 to 1 at 24, 32 and 48 cells; +8.5 % from tau 0.7 to
//! 2 at 12 cells, in this kernel and an independent NumPy code alike), though TRT at fixed
//! Lambda should not. The cause was the measurement: nodes in one-cell gaps carry modes of
//! eigenvalue -1 that a check at every even step reads as an offset of g/2 (see
//! [`super::driver::fields_over_two_steps`]). Averaged over two consecutive steps, k is the
//! same at tau 0.7, 1 and 2 to 9 digits (NumPy code, 12 cells). Whether those undamped modes
//! are what CLI's small-q weights turn into the growing ones above is not yet measured.
//! Hence staircase walls are the packings' default.

use crate::error::{invalid, Result};
use std::collections::HashMap;

/// Key of a (cell, direction) pair: the cell index times 27 plus the direction's index among
/// the 27 vectors of {-1, 0, 1}^3.
fn key(cell: usize, c: [i32; 3]) -> u64 {
    let d = (c[0] + 1) + 3 * (c[1] + 1) + 9 * (c[2] + 1);
    cell as u64 * 27 + d as u64
}

/// The 26 directions of {-1, 0, 1}^3 but the rest vector: every link of D3Q15 and D3Q19.
pub fn neighbour_directions() -> impl Iterator<Item = [i32; 3]> {
    (0..27)
        .map(|d: i32| [d % 3 - 1, (d / 3) % 3 - 1, d / 9 - 1])
        .filter(|c| *c != [0, 0, 0])
}

/// The wall fraction q of every fluid-solid link of a mask: the surface lies at x + q c on the
/// link from the fluid node x along c to its solid neighbour.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WallFractions {
    /// (key, q) sorted by key.
    entries: Vec<(u64, f64)>,
}

impl WallFractions {
    /// From (fluid cell, direction to the solid neighbour, q); a link given twice keeps the
    /// smaller q (the first crossing). Refuses a q outside (0, 1].
    pub fn new(links: impl IntoIterator<Item = (usize, [i32; 3], f64)>) -> Result<WallFractions> {
        let mut m: HashMap<u64, f64> = HashMap::new();
        for (cell, c, q) in links {
            if !(q > 0.0 && q <= 1.0) {
                return invalid(format!(
                    "wall fraction {q} of the link from cell {cell} along {c:?}: must lie in \
                     (0, 1]"
                ));
            }
            let e = m.entry(key(cell, c)).or_insert(q);
            *e = e.min(q);
        }
        let mut entries: Vec<(u64, f64)> = m.into_iter().collect();
        entries.sort_unstable_by_key(|e| e.0);
        Ok(WallFractions { entries })
    }

    /// q of every link of the mask `solid` on the periodic lattice `dims` from
    /// `crossing(x, c)`: the first crossing (in (0, 1]) of the segment from the fluid cell
    /// centre x (cell units, cell (i, j, k) centred at (i + 1/2, j + 1/2, k + 1/2), unwrapped)
    /// to x + c; a link without a crossing falls back to halfway bounce-back.
    pub fn from_crossings(
        dims: super::Dims,
        solid: &[bool],
        crossing: impl Fn([f64; 3], [i32; 3]) -> Option<f64>,
    ) -> Result<WallFractions> {
        let mut links = Vec::new();
        for cell in 0..dims.cells() {
            if solid[cell] {
                continue;
            }
            let p = dims.coords(cell);
            for c in neighbour_directions() {
                let n = dims.shifted(p, c);
                if !solid[dims.cell(n[0], n[1], n[2])] {
                    continue;
                }
                let x = p.map(|v| v as f64 + 0.5);
                if let Some(q) = crossing(x, c) {
                    links.push((cell, c, clamp_fraction(q)));
                }
            }
        }
        WallFractions::new(links)
    }

    /// q of the link from `cell` along `c`, if known.
    pub fn get(&self, cell: usize, c: [i32; 3]) -> Option<f64> {
        let k = key(cell, c);
        self.entries
            .binary_search_by_key(&k, |e| e.0)
            .ok()
            .map(|i| self.entries[i].1)
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// The smallest wall fraction kept: a surface through the fluid node itself (q = 0) is put a
/// hair inside the link, where CLI's kappa is 1 - 4e-12.
pub const Q_MIN: f64 = 1e-12;

/// q clamped into [Q_MIN, 1].
pub fn clamp_fraction(q: f64) -> f64 {
    q.clamp(Q_MIN, 1.0)
}

/// CLI's interpolation coefficient kappa(q) = (1 - 2q) / (1 + 2q) (Ginzburg, Verhaeghe &
/// d'Humières 2008): 0 at q = 1/2 (halfway bounce-back), in (-1/3, 1) for q in (0, 1].
pub fn cli_kappa(q: f64) -> f64 {
    (1.0 - 2.0 * q) / (1.0 + 2.0 * q)
}

/// The first t in [0, 1] at which the segment a + t d enters the ball of radius `r` about
/// `centre` (None if it does not; `a` is taken to lie outside): the smaller root of
/// |a - centre + t d|^2 = r^2.
pub fn sphere_crossing(a: [f64; 3], d: [f64; 3], centre: [f64; 3], r: f64) -> Option<f64> {
    let w = [0, 1, 2].map(|k| a[k] - centre[k]);
    let dd: f64 = d.iter().map(|v| v * v).sum();
    let wd: f64 = (0..3).map(|k| w[k] * d[k]).sum();
    let ww: f64 = w.iter().map(|v| v * v).sum();
    let disc = wd * wd - dd * (ww - r * r);
    if dd == 0.0 || disc < 0.0 {
        return None;
    }
    let t = (-wd - disc.sqrt()) / dd;
    (t <= 1.0 && -wd >= 0.0).then_some(t.max(0.0))
}

/// The first t in [0, 1] where a convex function f along a segment (f(t) = the shape's
/// inside-outside function at the segment's point t; f(0) >= 0: the start is outside) drops
/// below 0. When f(1) < 0 the crossing is bracketed at once; else the minimum of f on [0, 1]
/// is found by golden-section search (f is convex along a line for every porelab shape) and,
/// if below 0, brackets the crossing with 0. Bisection to 1e-13.
pub fn convex_crossing(f: impl Fn(f64) -> f64) -> Option<f64> {
    let end = if f(1.0) < 0.0 {
        1.0
    } else {
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let (mut lo, mut hi) = (0.0, 1.0);
        let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (mut f1, mut f2) = (f(x1), f(x2));
        while hi - lo > 1e-10 {
            if f1 < 0.0 {
                break;
            }
            if f1 < f2 {
                hi = x2;
                (x2, f2) = (x1, f1);
                x1 = hi - g * (hi - lo);
                f1 = f(x1);
            } else {
                lo = x1;
                (x1, f1) = (x2, f2);
                x2 = lo + g * (hi - lo);
                f2 = f(x2);
            }
        }
        if f1 < 0.0 {
            x1
        } else if f2 < 0.0 {
            x2
        } else {
            return None;
        }
    };
    let (mut lo, mut hi) = (0.0, end);
    while hi - lo > 1e-13 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quadratic and the root-find agree on a sphere; a chord that misses, or a ball behind
    /// the start, gives None; CLI's kappa is halfway bounce-back at q = 1/2.
    #[test]
    fn crossings_and_kappa() {
        let (a, d, c, r) = ([0.0, 0.1, 0.0], [1.0, 0.0, 0.0], [1.3, 0.0, 0.0], 0.5);
        let t = sphere_crossing(a, d, c, r).unwrap();
        let exact = 1.3 - (0.25f64 - 0.01).sqrt();
        assert!((t - exact).abs() < 1e-15, "{t} {exact}");
        let f = |t: f64| {
            let p = [a[0] + t * d[0] - c[0], a[1] - c[1], 0.0];
            (p[0] * p[0] + p[1] * p[1]).sqrt() - r
        };
        assert!((convex_crossing(f).unwrap() - exact).abs() < 1e-12);
        // a chord through the ball that ends outside it: the golden-section branch
        let g = |t: f64| ((t * 3.0 - 1.5f64).powi(2) + 0.04).sqrt() - 0.5;
        let want = (1.5 - (0.25f64 - 0.04).sqrt()) / 3.0;
        assert!((convex_crossing(g).unwrap() - want).abs() < 1e-12);
        assert!(sphere_crossing(a, d, [1.3, 0.7, 0.0], r).is_none());
        assert!(sphere_crossing(a, d, [-1.0, 0.0, 0.0], r).is_none());
        assert!(convex_crossing(|t| (t - 0.5).abs() + 0.1).is_none());
        assert_eq!(cli_kappa(0.5), 0.0);
        assert!((cli_kappa(1.0) + 1.0 / 3.0).abs() < 1e-15);
        let w = WallFractions::new([(3, [1, 0, 0], 0.4), (3, [1, 0, 0], 0.3)]).unwrap();
        assert_eq!(w.get(3, [1, 0, 0]), Some(0.3));
        assert_eq!(w.get(3, [0, 1, 0]), None);
        let e = WallFractions::new([(3, [1, 0, 0], 1.5)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("wall fraction 1.5"), "{e}");
    }
}
