//! Job claims: the one process that runs job NNNNN holds `jobs/NNNNN/claim.json`, holding its
//! host, pid, the process's start time (clock ticks since boot, `/proc/<pid>/stat` field 22) and
//! the boot id. The claim is written whole to a temporary file and then hard-linked to its name
//! (link(2) fails when the name exists: atomic on local and NFS file systems), so a process
//! killed while claiming never leaves an empty claim; where hard links are refused the file is
//! created with O_EXCL and then written.
//!
//! A claim is live when, on its own host, a process of that pid with that start time and boot
//! exists (a reused pid has another start time); a claim of another host is live while its
//! holder refreshes the file's modification time (every [`HEARTBEAT`]) and taken as dead after
//! [`STALE_AFTER`] without it. A live claim is never taken; a dead one is taken over under a
//! short-lived `claim.takeover` mutex (also O_EXCL), so two processes that both find the same
//! dead claim cannot both take it.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, SystemTime};

pub const CLAIM: &str = "claim.json";
const TAKEOVER: &str = "claim.takeover";
/// How often a holder refreshes its claim's modification time.
pub const HEARTBEAT: Duration = Duration::from_secs(30);
/// A claim of another host older than this (no heartbeat) is dead.
pub const STALE_AFTER: Duration = Duration::from_secs(300);
/// A takeover mutex older than this was left by a killed process.
const TAKEOVER_STALE: Duration = Duration::from_secs(60);

/// Who holds a claim.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Owner {
    pub host: String,
    pub pid: u32,
    /// Clock ticks after boot at which the process started (`/proc/<pid>/stat` field 22).
    pub start_ticks: u64,
    pub boot_id: String,
    /// `$SLURM_JOB_ID` of the holder, when it runs under Slurm.
    pub slurm_job: Option<String>,
}

fn read_trim(p: &str) -> String {
    std::fs::read_to_string(p)
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}

/// The start time of process `pid` (field 22 of `/proc/<pid>/stat`), None when it is gone or
/// has ended and not yet been reaped: a zombie (state `Z`, or `X` while being reaped) keeps its
/// `/proc` entry until its parent waits for it, and a job process whose runner was killed is
/// reparented to an init that, in some containers, never does.
fn start_ticks(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) is in parentheses and may hold spaces: count after the last ')'.
    let mut fields = stat[stat.rfind(')')? + 1..].split_whitespace();
    let state = fields.next()?;
    if state == "Z" || state == "X" {
        return None;
    }
    fields.nth(18)?.parse().ok()
}

impl Owner {
    /// This process.
    pub fn me() -> Owner {
        let pid = std::process::id();
        Owner {
            host: read_trim("/proc/sys/kernel/hostname"),
            pid,
            start_ticks: start_ticks(pid).unwrap_or(0),
            boot_id: read_trim("/proc/sys/kernel/random/boot_id"),
            slurm_job: std::env::var("SLURM_JOB_ID").ok(),
        }
    }

    /// True while the holder may still be running: on this host and boot, the process with
    /// that pid and start time exists; on another host, the claim was refreshed within
    /// [`STALE_AFTER`] (`age`: time since the claim file was last modified).
    pub fn is_live(&self, age: Duration) -> bool {
        let me = Owner::me();
        if self.host == me.host && !me.host.is_empty() {
            self.boot_id == me.boot_id && start_ticks(self.pid) == Some(self.start_ticks)
        } else {
            age < STALE_AFTER
        }
    }

    pub fn describe(&self) -> String {
        let slurm = self
            .slurm_job
            .as_ref()
            .map(|j| format!(", Slurm job {j}"))
            .unwrap_or_default();
        format!("pid {} on {}{slurm}", self.pid, self.host)
    }
}

/// The holder of the claim in job folder `d` and the claim's age, None when there is no claim
/// (an unreadable claim, e.g. caught half-written, counts as live for [`STALE_AFTER`]).
pub fn holder(d: &Path) -> Option<(std::result::Result<Owner, String>, Duration)> {
    let path = d.join(CLAIM);
    let meta = std::fs::metadata(&path).ok()?;
    let age = meta
        .modified()
        .ok()
        .and_then(|m| SystemTime::now().duration_since(m).ok())
        .unwrap_or_default();
    let owner = std::fs::read_to_string(&path)
        .map_err(|e| e.to_string())
        .and_then(|t| serde_json::from_str::<Owner>(&t).map_err(|e| e.to_string()));
    Some((owner, age))
}

/// The live holder of job folder `d`'s claim, if any.
pub fn live_holder(d: &Path) -> Option<Owner> {
    match holder(d)? {
        (Ok(o), age) => o.is_live(age).then_some(o),
        (Err(_), age) => (age < STALE_AFTER).then(|| Owner {
            host: "(unreadable claim)".into(),
            pid: 0,
            start_ticks: 0,
            boot_id: String::new(),
            slurm_job: None,
        }),
    }
}

/// A claim held by this process: refreshed by a heartbeat thread, removed when dropped.
pub struct Claim {
    path: PathBuf,
    stop: Arc<AtomicBool>,
}

/// What [`try_claim`] found.
pub enum Claimed {
    Mine(Claim),
    /// A live claim of another process.
    Held(Owner),
}

fn io_err(path: &Path, e: std::io::Error) -> Error {
    Error::File {
        path: path.display().to_string(),
        msg: e.to_string(),
    }
}

/// Creates `path` holding `text` unless it exists (false then): written whole to a temporary
/// and hard-linked to `path`, so `path` never exists with part of `text`.
fn create_exclusive(path: &Path, text: &str) -> Result<bool> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let k = COUNTER.fetch_add(1, Ordering::Relaxed);
    // named as `crate::io::write_atomic`'s temporaries, which remove_stale_temporaries clears
    let tmp = dir.join(format!(".{name}.tmp-{}-{k}", std::process::id()));
    std::fs::write(&tmp, text.as_bytes())
        .and_then(|_| std::fs::File::open(&tmp)?.sync_all())
        .map_err(|e| io_err(&tmp, e))?;
    let linked = std::fs::hard_link(&tmp, path);
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(false),
        // a file system without hard links (EPERM, EOPNOTSUPP)
        Err(_) => create_exclusive_then_write(path, text),
    }
}

/// Creates `path` with O_EXCL and writes `text` into it; false when it exists.
fn create_exclusive_then_write(path: &Path, text: &str) -> Result<bool> {
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
    {
        Ok(mut f) => {
            f.write_all(text.as_bytes())
                .and_then(|_| f.sync_all())
                .map_err(|e| io_err(path, e))?;
            Ok(true)
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(false),
        Err(e) => Err(io_err(path, e)),
    }
}

/// Removes the dead claim `seen` (the text read when it was judged dead) unless another
/// process replaced it meanwhile; the takeover mutex makes the read-compare-remove atomic
/// among takers. False when another taker holds the mutex (try again later).
fn remove_dead(d: &Path, seen: &str) -> Result<bool> {
    let mutex = d.join(TAKEOVER);
    if !create_exclusive(
        &mutex,
        &serde_json::to_string(&Owner::me()).unwrap_or_default(),
    )? {
        let age = std::fs::metadata(&mutex)
            .and_then(|m| m.modified())
            .ok()
            .and_then(|m| SystemTime::now().duration_since(m).ok());
        let holder_ended = std::fs::read_to_string(&mutex)
            .ok()
            .and_then(|t| serde_json::from_str::<Owner>(&t).ok())
            .is_some_and(|o| !o.is_live(age.unwrap_or_default()));
        if holder_ended || age.is_some_and(|a| a > TAKEOVER_STALE) {
            let _ = std::fs::remove_file(&mutex);
        }
        return Ok(false);
    }
    let path = d.join(CLAIM);
    let result = match std::fs::read_to_string(&path) {
        Ok(now) if now == seen => std::fs::remove_file(&path).map_err(|e| io_err(&path, e)),
        _ => Ok(()),
    };
    let _ = std::fs::remove_file(&mutex);
    result.map(|_| true)
}

/// Claims job folder `d` for this process, taking over a dead claim; never a live one.
pub fn try_claim(d: &Path) -> Result<Claimed> {
    let path = d.join(CLAIM);
    let me = Owner::me();
    let text = serde_json::to_string(&me).map_err(|e| Error::Validation(e.to_string()))?;
    for _ in 0..20 {
        if create_exclusive(&path, &text)? {
            // under the claim: the temporaries of killed claimers can go
            crate::io::remove_stale_temporaries(d)?;
            let stop = Arc::new(AtomicBool::new(false));
            let (p, s) = (path.clone(), stop.clone());
            std::thread::spawn(move || {
                let tick = Duration::from_millis(250);
                let mut waited = Duration::ZERO;
                while !s.load(Ordering::SeqCst) {
                    std::thread::sleep(tick);
                    waited += tick;
                    if waited >= HEARTBEAT {
                        waited = Duration::ZERO;
                        if let Ok(f) = std::fs::OpenOptions::new().write(true).open(&p) {
                            let _ = f.set_modified(SystemTime::now());
                        }
                    }
                }
            });
            return Ok(Claimed::Mine(Claim { path, stop }));
        }
        let seen = std::fs::read_to_string(&path).unwrap_or_default();
        match holder(d) {
            None => continue, // released meanwhile
            Some((owner, age)) => {
                let live = match &owner {
                    Ok(o) => o.is_live(age),
                    Err(_) => age < STALE_AFTER,
                };
                if live {
                    return Ok(Claimed::Held(owner.unwrap_or_else(|_| Owner {
                        host: "(claim being written)".into(),
                        pid: 0,
                        start_ticks: 0,
                        boot_id: String::new(),
                        slurm_job: None,
                    })));
                }
            }
        }
        if !remove_dead(d, &seen)? {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    Err(Error::File {
        path: path.display().to_string(),
        msg: "could not claim the job: its claim kept changing over 20 tries".into(),
    })
}

impl Drop for Claim {
    /// Stops the heartbeat and removes the claim file (when it is still this process's).
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        let mine = serde_json::to_string(&Owner::me()).unwrap_or_default();
        if std::fs::read_to_string(&self.path).is_ok_and(|t| t == mine) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("porelab-claim-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_live_claim_is_never_taken_and_a_dead_one_is_taken_over() {
        let d = folder("live");
        let Claimed::Mine(c) = try_claim(&d).unwrap() else {
            panic!("an empty folder is claimed")
        };
        // This process is alive: a second claim (as another process would try) is refused.
        match try_claim(&d).unwrap() {
            Claimed::Held(o) => assert_eq!(o.pid, std::process::id()),
            Claimed::Mine(_) => panic!("a live claim was taken twice"),
        }
        assert!(live_holder(&d).is_some());
        drop(c);
        assert!(!d.join(CLAIM).exists(), "released on drop");
        // A claim of a process that has ended (a child that exited) is dead and taken over.
        let child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        let mut child = child;
        child.wait().unwrap();
        let dead = Owner {
            pid,
            start_ticks: 1,
            ..Owner::me()
        };
        std::fs::write(d.join(CLAIM), serde_json::to_string(&dead).unwrap()).unwrap();
        assert!(live_holder(&d).is_none());
        let Claimed::Mine(_c) = try_claim(&d).unwrap() else {
            panic!("a dead claim was not taken over")
        };
        let now: Owner =
            serde_json::from_str(&std::fs::read_to_string(d.join(CLAIM)).unwrap()).unwrap();
        assert_eq!(now, Owner::me());
    }

    #[test]
    fn a_reused_pid_with_another_start_time_is_dead() {
        let me = Owner::me();
        assert!(me.start_ticks > 0, "{me:?}");
        assert!(me.is_live(Duration::ZERO));
        let reused = Owner {
            start_ticks: me.start_ticks + 1,
            ..me.clone()
        };
        assert!(!reused.is_live(Duration::ZERO));
        // Another host: live only while its heartbeat is fresh.
        let far = Owner {
            host: format!("{}-elsewhere", me.host),
            ..me
        };
        assert!(far.is_live(HEARTBEAT));
        assert!(!far.is_live(STALE_AFTER + HEARTBEAT));
    }

    #[test]
    fn a_killed_holder_not_yet_reaped_is_dead() {
        // A job process whose runner was killed is reparented to init; where init never reaps
        // (some containers), it stays a zombie with its /proc entry and start time.
        let mut child = std::process::Command::new("sleep")
            .arg("30")
            .spawn()
            .unwrap();
        let pid = child.id();
        let holder = Owner {
            pid,
            start_ticks: start_ticks(pid).expect("a running child has a start time"),
            ..Owner::me()
        };
        assert!(holder.is_live(Duration::ZERO));
        child.kill().unwrap();
        let zombie = (0..500).any(|_| {
            std::thread::sleep(Duration::from_millis(2));
            std::fs::read_to_string(format!("/proc/{pid}/stat"))
                .is_ok_and(|s| s[s.rfind(')').unwrap() + 1..].trim_start().starts_with('Z'))
        });
        assert!(
            zombie,
            "the killed child did not become a zombie within 1 s"
        );
        assert!(!holder.is_live(Duration::ZERO), "a zombie holds no claim");
        child.wait().unwrap();
    }

    #[test]
    fn a_claimer_killed_mid_claim_leaves_no_live_claim() {
        // What a claimer killed between its temporary and the link leaves: the temporary (its
        // pid has ended), and no claim.json; the next claimer takes the job and clears it.
        let d = folder("killed-claimer");
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        let stale = d.join(format!(".{CLAIM}.tmp-{pid}-0"));
        std::fs::write(&stale, "{").unwrap();
        assert!(live_holder(&d).is_none());
        let Claimed::Mine(c) = try_claim(&d).unwrap() else {
            panic!("a folder with a killed claimer's temporary is claimed")
        };
        assert!(!stale.exists(), "the killed claimer's temporary is cleared");
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, vec![CLAIM.to_string()]);
        drop(c);
    }

    #[test]
    fn concurrent_claimers_get_one_claim() {
        let d = folder("race");
        let won = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|s| {
            for _ in 0..8 {
                s.spawn(|| {
                    if let Claimed::Mine(c) = try_claim(&d).unwrap() {
                        won.fetch_add(1, Ordering::SeqCst);
                        std::thread::sleep(Duration::from_millis(200));
                        std::mem::forget(c); // keep the file until every thread tried
                    }
                });
            }
        });
        assert_eq!(won.load(Ordering::SeqCst), 1);
    }
}
