//! Readers and writers: CSV tables with units in the headers; atomic file writes; extended
//! XYZ particle configurations ([`xyz`]); LAMMPS dumps of spheres ([`lammps_dump`]); a
//! configuration from either, told by its content ([`configuration`]).

pub mod configuration;
pub mod csv_table;
pub mod lammps_dump;
pub mod plot;
pub mod vtk;
pub mod xyz;

pub use csv_table::CsvTable;

use crate::error::{invalid, Error};
use crate::Result;
use std::path::{Path, PathBuf};

/// The repository root, where `validation/` and `reference/` live: `$PORELAB_ROOT` if set,
/// else the crate's manifest folder.
pub fn repo_root() -> PathBuf {
    match std::env::var_os("PORELAB_ROOT") {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => PathBuf::from(env!("CARGO_MANIFEST_DIR")),
    }
}

/// FNV-1a 64 (Fowler, Noll & Vo; the offset basis and prime of the IETF draft
/// draft-eastlake-fnv): a stable hash of a scene's text, the same on every machine and build.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
/// reader never sees a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    create_dir(dir)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // process id and a counter: two threads writing the same file never share a temporary
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let k = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(".{name}.tmp-{}-{k}", std::process::id()));
    let named = |p: &Path, what: &str, e: std::io::Error| Error::File {
        path: p.display().to_string(),
        msg: format!("cannot {what}: {e}"),
    };
    std::fs::write(&tmp, bytes).map_err(|e| named(&tmp, "write", e))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        named(path, "write (rename from its temporary file)", e)
    })?;
    Ok(())
}

/// Whether process `pid` is running: it exists (`kill(pid, 0)`, no signal sent) and has not
/// ended unreaped (a zombie, state `Z` in `/proc/<pid>/stat`, has ended: a process whose
/// parent was killed is reparented to an init that, in some containers, never reaps).
pub fn process_running(pid: libc::pid_t) -> bool {
    if pid == std::process::id() as libc::pid_t {
        return true;
    }
    let exists = unsafe { libc::kill(pid, 0) } == 0
        || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM);
    let ended = std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|s| {
        s.rfind(')')
            .and_then(|i| s[i + 1..].split_whitespace().next())
            .is_some_and(|state| state == "Z" || state == "X")
    });
    exists && !ended
}

/// Removes the temporaries that [`write_atomic`] of files in `dir` left when their process was
/// killed mid-write (those of processes no longer running): a run resumed in a folder calls it
/// before it writes there again, so that the folder ends as an uninterrupted run's.
pub fn remove_stale_temporaries(dir: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        // ".<name>.tmp-<pid>-<k>"
        let Some(pid) = name
            .starts_with('.')
            .then(|| name.rsplit_once(".tmp-"))
            .flatten()
            .and_then(|(_, rest)| rest.split_once('-'))
            .and_then(|(pid, _)| pid.parse::<libc::pid_t>().ok())
        else {
            continue;
        };
        if !process_running(pid) {
            std::fs::remove_file(e.path()).map_err(|err| Error::File {
                path: e.path().display().to_string(),
                msg: format!("cannot remove a killed run's temporary file: {err}"),
            })?;
        }
    }
    Ok(())
}

/// `create_dir_all` whose error names the folder (an output folder that is a file, or under
/// a path that cannot hold folders, such as /proc).
pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::File {
        path: dir.display().to_string(),
        msg: format!("cannot create the output folder: {e}"),
    })
}

/// Parses "x,y,z" into three finite numbers; `option` names the option in the error.
pub fn parse_three(text: &str, option: &str) -> Result<[f64; 3]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return invalid(format!(
            "--{option} '{text}': expected three comma-separated numbers"
        ));
    }
    let mut v = [0.0; 3];
    for (k, p) in parts.iter().enumerate() {
        v[k] = p.parse::<f64>().map_err(|_| {
            Error::InvalidInput(format!("--{option} '{text}': '{p}' is not a number"))
        })?;
        if !v[k].is_finite() {
            return invalid(format!("--{option} '{text}': '{p}' is not finite"));
        }
    }
    Ok(v)
}
