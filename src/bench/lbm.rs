//! `porelab bench lbm`: million lattice updates per second (MLUPS) of the fused kernel for
//! each lattice and collision, plain and porous, at one and two threads, against the memory
//! bandwidth measured by a STREAM-type triad on the same machine in the same run, and against
//! the peer lbmpy (benches/peer_lbmpy.py) run in the same measurement when python finds it:
//! its plain kernel on the open box beside porelab's plain one, and its dense kernel with
//! NoSlip (halfway bounce-back) on the same solid mask, written as `mask-NAME-N.npy` beside
//! the CSV, beside the pore kernels (`pores`, `fluid`), both per fluid cell.
//! The pore-resolving measurements run on a solid mask, the random one (solid fraction 0.6) at
//! each size and, with `--packing`, a packing voxelised at `--packing-cells`: `pores` with the
//! box kernel (every cell stored, fluid runs updated), `fluid` with the fluid-list kernel
//! ([`crate::lbm::fluid`]); both count fluid cells only, and their "fraction of the limit"
//! uses the same bytes per update, so it says how much of the bandwidth the sparse fluid gets.
//! Each prints the bytes its kernel holds. The limit counts
//! 3 x 8 Q bytes per update (the write-allocate read included, as the triad counts it); where
//! the kernel stores non-temporally it moves 2 x 8 Q, and the run also reports the fraction of
//! that higher limit.

use crate::error::{invalid, Result};
use crate::io::CsvTable;
use crate::lbm::voxels::voxelise;
use crate::lbm::{
    Accel, CollisionKind, CollisionModel, Dims, Domain, ForcingModel, LatticeKind, Lbm, Medium,
    Setup, Storage, Tau,
};
use std::time::Instant;

#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// Cube edges to measure.
    #[arg(long, value_delimiter = ',', default_values_t = vec![64, 128])]
    pub sizes: Vec<usize>,
    /// Thread counts.
    #[arg(long, value_delimiter = ',', default_values_t = vec![1, 2])]
    pub threads: Vec<usize>,
    /// Seconds of stepping per measurement (at least 3 steps are timed).
    #[arg(long, default_value_t = 2.0)]
    pub seconds: f64,
    /// Lattices to measure (D3Q15, D3Q19).
    #[arg(long, value_delimiter = ',', default_values_t = vec!["D3Q15".to_string(), "D3Q19".to_string()])]
    pub lattices: Vec<String>,
    /// Collisions to measure (bgk, trt).
    #[arg(long, value_delimiter = ',', default_values_t = vec!["bgk".to_string(), "trt".to_string()])]
    pub collisions: Vec<String>,
    /// Kernels to measure: plain (Guo body force), porous (Guo-Zhao), pores (solid mask, box
    /// kernel), fluid (solid mask, fluid-list kernel).
    #[arg(long, value_delimiter = ',', default_values_t = vec!["plain".to_string(), "porous".to_string(), "pores".to_string(), "fluid".to_string()])]
    pub modes: Vec<String>,
    /// A packing (XYZ file) whose voxel mask the pores and fluid kernels also run on.
    #[arg(long)]
    pub packing: Option<std::path::PathBuf>,
    /// Cells along the packing box's x edge, one measurement each.
    #[arg(long, value_delimiter = ',', default_values_t = vec![64, 96])]
    pub packing_cells: Vec<usize>,
    /// Skip the lbmpy peer.
    #[arg(long)]
    pub no_peer: bool,
    /// Output stores of the kernel: auto (non-temporal when the two population arrays exceed
    /// the last-level cache), normal, or streaming (non-temporal; AVX-512 only).
    #[arg(long, default_value = "auto")]
    pub stores: String,
    /// Rounds per configuration, lbmpy and each porelab kernel taking turns in every round;
    /// each figure is the best of the rounds (as the triad's), so that a round slowed by other
    /// work on a shared machine does not count against either code.
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// Output CSV (default target/porelab/bench/lbm.csv).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
}

/// Bytes moved per cell update by a two-array pull kernel: read and write Q doubles, plus the
/// write-allocate read of the destination (counted, as the triad below counts it).
pub fn bytes_per_update(q: usize) -> f64 {
    3.0 * 8.0 * q as f64
}

/// STREAM-type triad a = b + s c over arrays far larger than the caches; GB/s counting
/// 4 x 8 bytes per element (2 reads, 1 write, 1 write-allocate read), best of 5.
pub fn triad_gb_per_s(threads: usize) -> Result<f64> {
    use rayon::prelude::*;
    let n = 1 << 25; // 3 arrays x 256 MiB
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| crate::Error::InvalidInput(format!("thread pool: {e}")))?;
    pool.install(|| {
        let mut a = vec![0.0f64; n];
        let b = vec![1.0f64; n];
        let c = vec![2.0f64; n];
        let chunk = n / (threads * 8).max(1);
        let mut best = f64::INFINITY;
        for rep in 0..5 {
            let s = 0.5 + rep as f64;
            let t = Instant::now();
            a.par_chunks_mut(chunk)
                .zip(b.par_chunks(chunk))
                .zip(c.par_chunks(chunk))
                .for_each(|((a, b), c)| {
                    for i in 0..a.len() {
                        a[i] = b[i] + s * c[i];
                    }
                });
            best = best.min(t.elapsed().as_secs_f64());
        }
        std::hint::black_box(&a);
        Ok(4.0 * 8.0 * n as f64 / best / 1e9)
    })
}

/// What a measurement runs: the plain kernel (Guo body force) or the Guo-Zhao porous kernel
/// on the open box, or a pore-resolving kernel on the grid's solid mask: the box kernel
/// (pores) or the fluid-list kernel (fluid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    Plain,
    Porous,
    Pores,
    Fluid,
}

impl Mode {
    /// The forcing column of the CSV.
    fn forcing(self) -> &'static str {
        match self {
            Mode::Porous => "guo-zhao",
            _ => "guo",
        }
    }

    fn name(self) -> &'static str {
        match self {
            Mode::Plain => "plain",
            Mode::Porous => "porous",
            Mode::Pores => "pores",
            Mode::Fluid => "fluid",
        }
    }

    fn on_mask(self) -> bool {
        matches!(self, Mode::Pores | Mode::Fluid)
    }
}

/// A lattice a measurement runs on, and the solid mask of its pore-resolving kernels.
#[derive(Debug, Clone)]
pub struct Grid {
    /// The mask's name in the CSV: `random0.6` or `packing`.
    pub mask: String,
    pub dims: Dims,
    pub solid: Vec<bool>,
}

impl Grid {
    /// The n^3 box with the random mask of solid fraction [`PORE_SOLID_FRACTION`].
    pub fn random(n: usize) -> Result<Grid> {
        let dims = Dims::new(n, n, n)?;
        Ok(Grid {
            mask: format!("random{PORE_SOLID_FRACTION}"),
            dims,
            solid: random_mask(dims.cells(), PORE_SOLID_FRACTION),
        })
    }

    /// The packing of the XYZ file `path` voxelised at `n` cells along its box's x edge.
    pub fn packing(path: &std::path::Path, n: usize) -> Result<Grid> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            crate::Error::InvalidInput(format!("--packing {}: {e}", path.display()))
        })?;
        let (cell, parts) = crate::io::xyz::parse(&text, &path.display().to_string())?;
        let v = voxelise(&cell, &parts, n)?;
        Ok(Grid {
            mask: "packing".into(),
            dims: v.dims,
            solid: v.solid,
        })
    }
}

impl Grid {
    /// Writes the solid mask as a NumPy `.npy` file: uint8, 1 = solid, shape (nz, ny, nx) in C
    /// order, so x runs fastest as in porelab's box (the peer's `--mask`).
    pub fn write_npy(&self, path: &std::path::Path) -> Result<()> {
        let d = self.dims;
        let mut header = format!(
            "{{'descr': '|u1', 'fortran_order': False, 'shape': ({}, {}, {}), }}",
            d.nz, d.ny, d.nx
        );
        // NPY 1.0: magic, version, u16 header length; header padded with spaces and ended by
        // a newline so that the data start on a multiple of 64 bytes
        let unpadded = 10 + header.len() + 1;
        header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
        header.push('\n');
        let mut bytes = Vec::with_capacity(10 + header.len() + self.solid.len());
        bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
        bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
        bytes.extend_from_slice(header.as_bytes());
        bytes.extend(self.solid.iter().map(|&s| s as u8));
        std::fs::write(path, bytes)
            .map_err(|e| crate::Error::InvalidInput(format!("mask {}: {e}", path.display())))
    }
}

/// Solid fraction of the pore-resolving measurement.
const PORE_SOLID_FRACTION: f64 = 0.6;

/// A solid mask of `cells` cells, each solid with probability `fraction`, independently
/// (splitmix64 from a fixed seed, so every run times the same mask).
fn random_mask(cells: usize, fraction: f64) -> Vec<bool> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    (0..cells)
        .map(|_| {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            ((z >> 11) as f64 / (1u64 << 53) as f64) < fraction
        })
        .collect()
}

/// MLUPS, whether the kernel stored non-temporally, and the bytes the kernel holds.
type Timing = (f64, bool, usize);

/// The flow a measurement times: on the grid's lattice at tau = 1 under a body force of 1e-6
/// along x, the open box (plain), a Guo-Zhao medium whose porosity varies from cell to cell
/// (porous), or the grid's solid mask in the box kernel (pores) or the fluid list (fluid).
fn flow(lat: LatticeKind, coll: CollisionKind, mode: Mode, grid: &Grid) -> Result<Lbm> {
    let d = grid.dims;
    let g = Accel::new([1e-6, 0.0, 0.0])?;
    let collision = CollisionModel::new(coll, Tau::new(1.0)?);
    let on_mask = |storage| -> Result<Setup> {
        let domain = Domain::with_solid(d, grid.solid.clone())?;
        Ok(Setup::new(lat, collision, domain).with_storage(storage))
    };
    let setup = match mode {
        Mode::Pores => on_mask(Storage::Box)?,
        Mode::Fluid => on_mask(Storage::FluidList)?,
        _ => Setup::new(lat, collision, Domain::open(d)).with_storage(Storage::Box),
    };
    let forcing = match mode {
        Mode::Porous => ForcingModel::Porous(Medium::clear(g, true)),
        _ => ForcingModel::Body(g),
    };
    let mut lbm = Lbm::new(setup.with_forcing(forcing))?;
    if let Some(p) = lbm.porous_mut() {
        for c in 0..d.cells() {
            p.set(c, 0.4 + 0.5 * ((c % 13) as f64 / 13.0), 1e-2)
                .map_err(crate::Error::InvalidInput)?;
        }
    }
    Ok(lbm)
}

fn time_steps(mut s: Lbm, seconds: f64, stores: Option<bool>) -> Result<Timing> {
    s.set_streaming_stores(stores);
    let streaming = s.streaming_stores() && crate::lbm::simd::has_avx512();
    s.step()?; // warm-up
    let t = Instant::now();
    let mut steps = 0u64;
    while steps < 3 || t.elapsed().as_secs_f64() < seconds {
        s.step()?;
        steps += 1;
    }
    let dt = t.elapsed().as_secs_f64();
    Ok((
        s.geometry().fluid_cells() as f64 * steps as f64 / dt / 1e6,
        streaming,
        s.kernel_bytes(),
    ))
}

/// MLUPS (fluid cells updated) of one configuration on `threads` threads, and whether the
/// kernel stored non-temporally (`stores`: None for the solver's default).
pub fn mlups(
    lat: LatticeKind,
    coll: CollisionKind,
    mode: Mode,
    (grid, threads): (&Grid, usize),
    seconds: f64,
    stores: Option<bool>,
) -> Result<Timing> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| crate::Error::InvalidInput(format!("thread pool: {e}")))?;
    pool.install(|| time_steps(flow(lat, coll, mode, grid)?, seconds, stores))
}

/// What the lbmpy peer runs: its plain kernel on the open n^3 box, or its dense kernel with
/// NoSlip on the solid mask of a `.npy` file ([`Grid::write_npy`]), MLUPS per fluid cell.
#[derive(Debug, Clone, Copy)]
pub enum PeerProblem<'a> {
    Open(usize),
    Mask(&'a std::path::Path),
}

/// lbmpy's MLUPS for (lattice, collision, problem, threads), run by benches/peer_lbmpy.py;
/// Err with the reason when python or lbmpy is missing or the peer fails.
pub fn peer_mlups(
    lat: LatticeKind,
    coll: CollisionKind,
    problem: PeerProblem,
    threads: usize,
    seconds: f64,
) -> std::result::Result<f64, String> {
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/peer_lbmpy.py");
    let mut cmd = std::process::Command::new("python3");
    cmd.arg(&script).args([
        "--stencil",
        lat.name(),
        "--method",
        match coll {
            CollisionKind::Bgk => "srt",
            CollisionKind::Trt => "trt",
        },
        "--seconds",
        &seconds.to_string(),
    ]);
    match problem {
        PeerProblem::Open(n) => cmd.args(["--n", &n.to_string()]),
        PeerProblem::Mask(path) => cmd.arg("--mask").arg(path),
    };
    let out = cmd
        .env("OMP_NUM_THREADS", threads.to_string())
        .output()
        .map_err(|e| format!("python3 not runnable: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
    }
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(|l| l.strip_prefix("MLUPS "))
        .and_then(|v| v.trim().parse().ok())
        .ok_or_else(|| format!("peer printed no MLUPS line: {text}"))
}

/// A peer's best MLUPS so far, or why it was not measured.
type PeerResult = std::result::Result<f64, String>;

/// Runs the peer once more and keeps the better figure; a failed run replaces the figure by
/// its reason, and a peer not measured stays so.
fn keep_best(peer: &mut PeerResult, run: impl FnOnce() -> PeerResult) {
    if let Ok(p) = *peer {
        *peer = run().map(|q| q.max(p));
    }
}

/// What `bench lbm` measures: the lattices, collisions and kernels of its arguments, and the
/// kernel's stores (None: the default rule).
type Choices = (
    Vec<LatticeKind>,
    Vec<CollisionKind>,
    Vec<Mode>,
    Option<bool>,
);

fn choices(args: &BenchArgs) -> Result<Choices> {
    if args.sizes.is_empty() || args.threads.is_empty() || args.threads.contains(&0) {
        return invalid("bench lbm: --sizes and --threads need at least one value, threads >= 1");
    }
    if let Some(n) = args.sizes.iter().find(|&&n| n < 4) {
        return invalid(format!(
            "bench lbm: --sizes {n}: each lattice edge must be >= 4 cells"
        ));
    }
    if args.rounds == 0 {
        return invalid("bench lbm: --rounds must be at least 1");
    }
    let lattices = args
        .lattices
        .iter()
        .map(|s| LatticeKind::parse(s, "--lattices"))
        .collect::<Result<Vec<_>>>()?;
    let collisions = args
        .collisions
        .iter()
        .map(|s| CollisionKind::parse(s, "--collisions"))
        .collect::<Result<Vec<_>>>()?;
    let modes = args
        .modes
        .iter()
        .map(|s| match s.to_ascii_lowercase().as_str() {
            "plain" => Ok(Mode::Plain),
            "porous" => Ok(Mode::Porous),
            "pores" => Ok(Mode::Pores),
            "fluid" => Ok(Mode::Fluid),
            _ => invalid(format!(
                "--modes {s}: must be plain, porous, pores or fluid"
            )),
        })
        .collect::<Result<Vec<_>>>()?;
    let stores = match args.stores.to_ascii_lowercase().as_str() {
        "auto" => None,
        "normal" => Some(false),
        "streaming" => Some(true),
        s => return invalid(format!("--stores {s}: must be auto, normal or streaming")),
    };
    if lattices.is_empty() || collisions.is_empty() || modes.is_empty() {
        return invalid("bench lbm: --lattices, --collisions and --modes need at least one value");
    }
    Ok((lattices, collisions, modes, stores))
}

/// The columns of the benchmark's CSV.
const COLUMNS: [&str; 14] = [
    "lattice",
    "collision",
    "forcing",
    "mask",
    "kernel_mib",
    "n",
    "threads",
    "mlups",
    "bandwidth_limit_mlups",
    "fraction_of_limit",
    "nontemporal_stores",
    "fraction_of_nontemporal_limit",
    "peer_lbmpy_mlups",
    "ratio_to_peer",
];

pub fn run(args: &BenchArgs) -> Result<()> {
    let (lattices, collisions, modes, stores) = choices(args)?;
    let mut csv = CsvTable::new(&COLUMNS);
    let mut grids = args
        .sizes
        .iter()
        .map(|&n| Grid::random(n))
        .collect::<Result<Vec<_>>>()?;
    if let Some(path) = &args.packing {
        for &n in &args.packing_cells {
            grids.push(Grid::packing(path, n)?);
        }
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| std::path::PathBuf::from("target/porelab/bench/lbm.csv"));
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    // the masks the peer's dense kernel with NoSlip runs on, beside the CSV
    let mask_files = grids
        .iter()
        .map(|g| -> Result<Option<std::path::PathBuf>> {
            if args.no_peer || !modes.iter().any(|m| m.on_mask()) {
                return Ok(None);
            }
            let path = out.with_file_name(format!("mask-{}-{}.npy", g.mask, g.dims.nx));
            g.write_npy(&path)?;
            println!("wrote {}", path.display());
            Ok(Some(path))
        })
        .collect::<Result<Vec<_>>>()?;
    for &th in &args.threads {
        let bw = triad_gb_per_s(th)?;
        println!("triad bandwidth, {th} thread(s): {bw:.1} GB/s (4 x 8 bytes per element)");
        for (grid, mask_file) in grids.iter().zip(&mask_files) {
            let n = grid.dims.nx;
            let fluid = grid.solid.iter().filter(|s| !**s).count();
            for &lat in &lattices {
                let limit = bw * 1e9 / bytes_per_update(lat.q()) / 1e6;
                for &coll in &collisions {
                    // lbmpy's plain kernel beside the plain one, its dense kernel with NoSlip
                    // beside the pore kernels; best of the rounds
                    let mut peer_open: PeerResult = if args.no_peer {
                        Err("--no-peer".to_string())
                    } else if grid.dims != Dims::new(n, n, n)? {
                        Err("the peer runs cubes only".to_string())
                    } else if !modes.contains(&Mode::Plain) {
                        Err("plain kernel not selected".to_string())
                    } else {
                        Ok(0.0)
                    };
                    let mut peer_mask: PeerResult = match mask_file {
                        Some(_) => Ok(0.0),
                        None => Err("--no-peer".to_string()),
                    };
                    let mut best = vec![(0.0f64, false, 0); modes.len()];
                    for _ in 0..args.rounds {
                        keep_best(&mut peer_open, || {
                            peer_mlups(lat, coll, PeerProblem::Open(n), th, args.seconds)
                        });
                        if let Some(path) = mask_file {
                            keep_best(&mut peer_mask, || {
                                peer_mlups(lat, coll, PeerProblem::Mask(path), th, args.seconds)
                            });
                        }
                        for (b, &mode) in best.iter_mut().zip(&modes) {
                            let t = mlups(lat, coll, mode, (grid, th), args.seconds, stores)?;
                            *b = (b.0.max(t.0), t.1, t.2);
                        }
                    }
                    // non-temporal stores skip the write-allocate read: 2 x 8 Q bytes a cell
                    let nt_limit = limit * 1.5;
                    for (&mode, &(m, nt, bytes)) in modes.iter().zip(&best) {
                        let mib = bytes as f64 / 1048576.0;
                        let mask = if mode.on_mask() {
                            grid.mask.as_str()
                        } else {
                            "open"
                        };
                        let peer = match mode {
                            Mode::Plain => Some(&peer_open),
                            Mode::Pores | Mode::Fluid => Some(&peer_mask),
                            Mode::Porous => None,
                        };
                        let (pm, ratio) = match peer {
                            Some(Ok(p)) => (format!("{p:.2}"), format!("{:.3}", m / p)),
                            _ => (String::new(), String::new()),
                        };
                        println!(
                            "{} {} {:<6} {mask:<10} {n:>3}^3 ({:.3} fluid) {th} thr: {m:7.2} MLUPS, {mib:7.1} MiB, {:5.1} % of the {limit:.1} MLUPS limit{}{}",
                            lat.name(),
                            coll.name(),
                            mode.name(),
                            if mode.on_mask() { fluid as f64 / grid.dims.cells() as f64 } else { 1.0 },
                            100.0 * m / limit,
                            if nt {
                                format!(" (non-temporal stores: {:.1} % of their {nt_limit:.1})", 100.0 * m / nt_limit)
                            } else {
                                String::new()
                            },
                            match peer {
                                Some(Ok(p)) => format!(", lbmpy {p:.2} MLUPS (ratio {:.2})", m / p),
                                Some(Err(e)) => format!(", lbmpy not measured: {}", e.lines().last().unwrap_or("")),
                                None => String::new(),
                            }
                        );
                        csv.row([
                            lat.name().to_string(),
                            coll.name().to_string(),
                            mode.forcing().to_string(),
                            mask.to_string(),
                            format!("{mib:.2}"),
                            n.to_string(),
                            th.to_string(),
                            format!("{m:.3}"),
                            format!("{limit:.2}"),
                            format!("{:.4}", m / limit),
                            nt.to_string(),
                            format!("{:.4}", if nt { m / nt_limit } else { m / limit }),
                            pm,
                            ratio,
                        ]);
                    }
                }
            }
        }
    }
    csv.write(&out)?;
    println!("wrote {}", out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The NPY 1.0 layout (numpy's format spec): magic, version 1.0, a little-endian u16
    /// header length, a header dict ending in a newline with the data starting on a multiple
    /// of 64 bytes, then one byte per cell in the box's order (x fastest).
    #[test]
    fn mask_npy_has_the_npy_layout_and_the_cells_in_box_order() {
        let dims = Dims::new(5, 3, 2).unwrap();
        let solid: Vec<bool> = (0..dims.cells()).map(|c| c % 3 == 1).collect();
        let grid = Grid {
            mask: "test".into(),
            dims,
            solid: solid.clone(),
        };
        let path = std::env::temp_dir().join(format!("porelab-mask-{}.npy", std::process::id()));
        grid.write_npy(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + len) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + len]).unwrap();
        assert!(header.ends_with('\n'), "{header:?}");
        assert!(header.contains("'descr': '|u1'"), "{header}");
        assert!(header.contains("'shape': (2, 3, 5)"), "{header}");
        let data: Vec<bool> = bytes[10 + len..].iter().map(|&b| b == 1).collect();
        assert_eq!(data, solid);
        assert!(bytes[10 + len..].iter().all(|&b| b <= 1));
    }
}
