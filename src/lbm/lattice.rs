//! Velocity sets. Directions are ordered rest first, then opposite pairs (2k-1, 2k), so that
//! the opposite of q > 0 is q + 1 for odd q and q - 1 for even q (the two-relaxation-time
//! collision and the bounce-back walk the pairs).

/// A DdQq velocity set with its weights; `Pop` is the array of one cell's populations.
pub trait Lattice: Copy + Send + Sync + 'static {
    const NAME: &'static str;
    const Q: usize;
    /// Lattice velocities c_q (lattice units).
    const C: &'static [[i32; 3]];
    /// Weights w_q (sum 1; sum w c c = c_s^2 I with c_s^2 = 1/3).
    const W: &'static [f64];
    type Pop: Copy + Default + AsRef<[f64]> + AsMut<[f64]> + Send + Sync;
}

/// The opposite direction of q (c_opp = -c_q): pairs (2p + 1, 2p + 2), q = 0 its own. Written
/// without a branch on q's parity, which a link list (q in no order) would mispredict.
#[inline(always)]
pub const fn opposite(q: usize) -> usize {
    if q == 0 {
        0
    } else {
        q - 1 + 2 * (q & 1)
    }
}

/// The largest Q of the velocity sets here (D3Q19): the row count of the kernel's blocks.
pub const QMAX: usize = 19;

/// `each_q!(L, q, { body })` runs the body for q = 0..L::Q, written out once per q so that
/// every q is a constant in the kernel (its c_q and w_q fold in, and per-q arrays live in
/// registers).
macro_rules! each_q {
    ($L:ident, $q:ident, $body:block) => {
        each_q!(@ $L, $q, $body, 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18)
    };
    (@ $L:ident, $q:ident, $body:block, $($n:literal)*) => {$(
        if $n < $L::Q {
            let $q: usize = $n;
            $body
        }
    )*};
}

/// `each_pair!(L, q, { body })`: the body for the first direction q = 1, 3, 5, .. of every
/// opposite pair (q, q + 1), unrolled like [`each_q`].
macro_rules! each_pair {
    ($L:ident, $q:ident, $body:block) => {
        each_q!(@ $L, $q, $body, 1 3 5 7 9 11 13 15 17)
    };
}

pub(crate) use {each_pair, each_q};

/// Squared speed of sound in lattice units (seed 002 eq. 9: c_s^2 = 3 (1 - w_0) / 7 = 1/3 for
/// D3Q15's w_0 = 2/9; the same 1/3 holds for D3Q19).
pub const CS2: f64 = 1.0 / 3.0;

/// rho = sum f, j = sum f c (seed 002 eq. 6-7).
#[inline(always)]
pub fn density_momentum<L: Lattice>(p: &L::Pop) -> (f64, [f64; 3]) {
    let p = p.as_ref();
    let mut rho = 0.0;
    let mut j = [0.0; 3];
    for (c, &f) in L::C.iter().zip(p) {
        rho += f;
        j[0] += c[0] as f64 * f;
        j[1] += c[1] as f64 * f;
        j[2] += c[2] as f64 * f;
    }
    (rho, j)
}

/// D3Q15: the seed's lattice (seed 002 Fig. 5, eq. 5: w_0 = 2/9, w_1..6 = 1/9, w_7..14 = 1/72).
#[derive(Debug, Clone, Copy, Default)]
pub struct D3Q15;

/// D3Q19: rest, 6 face and 12 edge neighbours (w = 1/3, 1/18, 1/36).
#[derive(Debug, Clone, Copy, Default)]
pub struct D3Q19;

const W15: [f64; 15] = {
    let mut w = [1.0 / 72.0; 15];
    w[0] = 2.0 / 9.0;
    let mut q = 1;
    while q <= 6 {
        w[q] = 1.0 / 9.0;
        q += 1;
    }
    w
};

const W19: [f64; 19] = {
    let mut w = [1.0 / 36.0; 19];
    w[0] = 1.0 / 3.0;
    let mut q = 1;
    while q <= 6 {
        w[q] = 1.0 / 18.0;
        q += 1;
    }
    w
};

impl Lattice for D3Q15 {
    const NAME: &'static str = "D3Q15";
    const Q: usize = 15;
    const C: &'static [[i32; 3]] = &[
        [0, 0, 0],
        [1, 0, 0],
        [-1, 0, 0],
        [0, 1, 0],
        [0, -1, 0],
        [0, 0, 1],
        [0, 0, -1],
        [1, 1, 1],
        [-1, -1, -1],
        [1, 1, -1],
        [-1, -1, 1],
        [1, -1, 1],
        [-1, 1, -1],
        [-1, 1, 1],
        [1, -1, -1],
    ];
    const W: &'static [f64] = &W15;
    type Pop = [f64; 15];
}

impl Lattice for D3Q19 {
    const NAME: &'static str = "D3Q19";
    const Q: usize = 19;
    const C: &'static [[i32; 3]] = &[
        [0, 0, 0],
        [1, 0, 0],
        [-1, 0, 0],
        [0, 1, 0],
        [0, -1, 0],
        [0, 0, 1],
        [0, 0, -1],
        [1, 1, 0],
        [-1, -1, 0],
        [1, -1, 0],
        [-1, 1, 0],
        [1, 0, 1],
        [-1, 0, -1],
        [1, 0, -1],
        [-1, 0, 1],
        [0, 1, 1],
        [0, -1, -1],
        [0, 1, -1],
        [0, -1, 1],
    ];
    const W: &'static [f64] = &W19;
    type Pop = [f64; 19];
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The moment conditions every isotropic velocity set must meet, exactly in rationals:
    /// sum w = 1, sum w c = 0, sum w c_a c_b = c_s^2 delta_ab, third moments 0, and the fourth
    /// moment sum w c_a c_b c_c c_d = c_s^4 (delta delta + 2 perms) that Navier-Stokes needs.
    fn moments<L: Lattice>() {
        assert_eq!(L::C.len(), L::Q);
        assert_eq!(L::W.len(), L::Q);
        assert_eq!(L::Pop::default().as_ref().len(), L::Q);
        let s: f64 = L::W.iter().sum();
        assert!((s - 1.0).abs() < 1e-15, "{} sum w = {s}", L::NAME);
        for q in 0..L::Q {
            let o = opposite(q);
            for a in 0..3 {
                assert_eq!(L::C[q][a], -L::C[o][a], "{} opposite of {q}", L::NAME);
            }
            assert_eq!(L::W[q], L::W[o]);
        }
        let d = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
        for a in 0..3 {
            for b in 0..3 {
                let m2: f64 = (0..L::Q)
                    .map(|q| L::W[q] * (L::C[q][a] * L::C[q][b]) as f64)
                    .sum();
                assert!((m2 - CS2 * d(a, b)).abs() < 1e-15);
                for c in 0..3 {
                    let m3: f64 = (0..L::Q)
                        .map(|q| L::W[q] * (L::C[q][a] * L::C[q][b] * L::C[q][c]) as f64)
                        .sum();
                    assert!(m3.abs() < 1e-15);
                    for e in 0..3 {
                        let m4: f64 = (0..L::Q)
                            .map(|q| {
                                L::W[q] * (L::C[q][a] * L::C[q][b] * L::C[q][c] * L::C[q][e]) as f64
                            })
                            .sum();
                        let want =
                            CS2 * CS2 * (d(a, b) * d(c, e) + d(a, c) * d(b, e) + d(a, e) * d(b, c));
                        assert!((m4 - want).abs() < 1e-15, "{} m4 {a}{b}{c}{e}", L::NAME);
                    }
                }
            }
        }
    }

    #[test]
    fn d3q15_moments() {
        moments::<D3Q15>();
        assert_eq!(D3Q15::W[0], 2.0 / 9.0);
        assert_eq!(D3Q15::W[1], 1.0 / 9.0);
        assert_eq!(D3Q15::W[14], 1.0 / 72.0);
    }

    #[test]
    fn d3q19_moments() {
        moments::<D3Q19>();
    }
}
