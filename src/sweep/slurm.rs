//! `porelab sweep slurm DIR`: Slurm job arrays (`sbatch --array`) of the jobs still to run.
//!
//! `DIR/sweep.sbatch` runs `porelab sweep job DIR $((PORELAB_JOB_BASE + SLURM_ARRAY_TASK_ID))`;
//! its exit code (0 done, 1 failed, 128 + signal when stopped) is what Slurm records, its
//! output goes to `DIR/slurm/%A_%a.out` (array job id, task id). A cluster's MaxArraySize
//! (`scontrol show config`) bounds task ids to 0..MaxArraySize-1, so the jobs are split into
//! blocks of ids [base, base + MaxArraySize), one array per block, each submitted with
//! `--export=ALL,PORELAB_JOB_BASE=base`. Only jobs still to run are listed: not done, not
//! running (a live claim), not failed unless `--retry-failed`, and not queued in an array this
//! command submitted before (`DIR/slurm/arrays.csv`, asked of `squeue`).
//!
//! With `--time`, tasks get SIGUSR1 `--signal-before` seconds before the limit (`#SBATCH
//! --signal=B:USR1@S`): the job writes its checkpoint and stops as "timed out", and the next
//! submission resumes it. `--requeue` also makes such a task requeue itself (`scontrol
//! requeue`) and lets Slurm requeue tasks of a failed node or a preemption.

use super::{at_least_one, unfinished, Plan};
use crate::error::{invalid, Error, Result};
use crate::io::{create_dir, write_atomic};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

#[derive(Debug, clap::Args)]
pub struct SlurmArgs {
    pub dir: PathBuf,
    /// Slurm partition (sbatch --partition).
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit of each task, [D-]HH:MM:SS.
    #[arg(long)]
    pub time: Option<String>,
    /// With --time: seconds before the limit at which a task is told (SIGUSR1) to write its
    /// checkpoint and stop.
    #[arg(long, default_value_t = 120)]
    pub signal_before: u32,
    /// Most tasks running at once (each array's %K).
    #[arg(long)]
    pub max_running: Option<usize>,
    /// CPUs per task (sbatch --cpus-per-task), also the job's worker threads.
    #[arg(long, default_value_t = 1)]
    pub cpus_per_task: usize,
    /// Memory per task (sbatch --mem, e.g. 4G).
    #[arg(long)]
    pub mem: Option<String>,
    /// Account charged (sbatch --account).
    #[arg(long)]
    pub account: Option<String>,
    /// Quality of service (sbatch --qos).
    #[arg(long)]
    pub qos: Option<String>,
    /// Generic resources per task (sbatch --gres, e.g. gpu:1).
    #[arg(long)]
    pub gres: Option<String>,
    /// Requeue tasks at their time limit (they resume from their checkpoint) and on node
    /// failure or preemption (sbatch --requeue).
    #[arg(long)]
    pub requeue: bool,
    /// Largest array size (task ids 0..N-1); default: the cluster's MaxArraySize.
    #[arg(long)]
    pub max_array_size: Option<usize>,
    /// Include failed jobs in the arrays.
    #[arg(long)]
    pub retry_failed: bool,
    /// Submit with `sbatch --parsable` and print each array's job id.
    #[arg(long)]
    pub submit: bool,
    /// With --submit: also submit `porelab sweep collect DIR` as a job that starts when every
    /// array has ended (--dependency=afterany); its output in DIR/slurm/collect-%j.out.
    #[arg(long)]
    pub collect: bool,
}

/// Task ids as Slurm's --array list: runs of consecutive ids as ranges ("0-3,7,9-10").
pub fn array_list(ids: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut k = 0;
    while k < ids.len() {
        let start = ids[k];
        let mut end = start;
        while k + 1 < ids.len() && ids[k + 1] == end + 1 {
            k += 1;
            end = ids[k];
        }
        parts.push(if end == start {
            start.to_string()
        } else {
            format!("{start}-{end}")
        });
        k += 1;
    }
    parts.join(",")
}

/// One array: job ids `base + task id`.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub base: usize,
    /// Task ids (job - base), each below the array size.
    pub tasks: Vec<usize>,
}

/// Splits sorted job ids into arrays whose task ids stay below `max_array_size`: a block
/// starts at its first job and takes the jobs below first + max_array_size.
pub fn blocks(jobs: &[usize], max_array_size: usize) -> Vec<Block> {
    let mut out: Vec<Block> = Vec::new();
    for &j in jobs {
        match out.last_mut() {
            Some(b) if j - b.base < max_array_size => b.tasks.push(j - b.base),
            _ => out.push(Block {
                base: j,
                tasks: vec![0],
            }),
        }
    }
    out
}

/// Refuses a time limit that is not [D-]HH:MM:SS.
fn check_time(t: &str) -> Result<()> {
    let (days, hms) = match t.split_once('-') {
        Some((d, rest)) => (Some(d), rest),
        None => (None, t),
    };
    let fields: Vec<&str> = hms.split(':').collect();
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let ok = days.is_none_or(digits)
        && fields.len() == 3
        && fields.iter().all(|f| digits(f))
        && fields[1].parse::<u32>().is_ok_and(|m| m < 60)
        && fields[2].parse::<u32>().is_ok_and(|s| s < 60);
    if !ok {
        return invalid(format!(
            "--time {t}: must be [D-]HH:MM:SS (e.g. 01:30:00 or 2-00:00:00)"
        ));
    }
    Ok(())
}

/// Refuses an option value that would not stay one word in the script.
fn check_word(value: &str, option: &str) -> Result<()> {
    if value.is_empty()
        || !value
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.,:".contains(c))
    {
        return invalid(format!(
            "--{option} '{value}': use letters, digits and - _ . , : only"
        ));
    }
    Ok(())
}

/// The absolute path of `p` (the tasks may start in another working directory).
fn absolute(p: &Path) -> Result<PathBuf> {
    std::fs::canonicalize(p).map_err(|e| Error::File {
        path: p.display().to_string(),
        msg: e.to_string(),
    })
}

/// The stdout of a Slurm command, or an error naming it.
fn slurm_out(cmd: &mut Command) -> Result<String> {
    let name = format!("{cmd:?}");
    let out = cmd
        .output()
        .map_err(|e| Error::Validation(format!("cannot run {name}: {e} (is Slurm installed?)")))?;
    if !out.status.success() {
        return Err(Error::Validation(format!(
            "{name} failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// MaxArraySize from `scontrol show config` ("MaxArraySize = 1001").
pub fn cluster_max_array_size() -> Result<usize> {
    let text = slurm_out(Command::new("scontrol").args(["show", "config"]))?;
    text.lines()
        .find_map(|l| {
            let (k, v) = l.split_once('=')?;
            (k.trim() == "MaxArraySize").then(|| v.trim().parse::<usize>().ok())?
        })
        .filter(|&n| n > 0)
        .ok_or_else(|| {
            Error::Validation(
                "`scontrol show config` names no MaxArraySize; give --max-array-size".into(),
            )
        })
}

/// The arrays submitted before: `DIR/slurm/arrays.csv` rows `array_job_id,base`.
const ARRAYS: &str = "arrays.csv";

/// The jobs of earlier arrays that Slurm still holds (pending or running), from `squeue`.
fn queued_jobs(dir: &Path) -> Result<BTreeSet<usize>> {
    let Ok(text) = std::fs::read_to_string(dir.join("slurm").join(ARRAYS)) else {
        return Ok(BTreeSet::new());
    };
    let arrays: Vec<(String, usize)> = text
        .lines()
        .filter_map(|l| {
            let (id, base) = l.split_once(',')?;
            Some((id.to_string(), base.parse().ok()?))
        })
        .collect();
    if arrays.is_empty() {
        return Ok(BTreeSet::new());
    }
    // -r: one line per task, "ARRAYID_TASK"; ids Slurm has forgotten make squeue fail, so
    // each array is asked on its own.
    let mut queued = BTreeSet::new();
    for (id, base) in &arrays {
        let Ok(out) = slurm_out(Command::new("squeue").args(["-h", "-r", "-j", id, "-o", "%i"]))
        else {
            continue;
        };
        for line in out.lines() {
            if let Some(task) = line
                .trim()
                .rsplit_once('_')
                .and_then(|(_, t)| t.parse::<usize>().ok())
            {
                queued.insert(base + task);
            }
        }
    }
    Ok(queued)
}

/// What `write_script` decided.
pub struct Arrays {
    pub script: PathBuf,
    pub blocks: Vec<Block>,
    /// The `--array` value of each block (with %K).
    pub specs: Vec<String>,
}

/// Writes `DIR/sweep.sbatch` for the jobs still to run; returns it with the arrays to
/// submit, or None when there is nothing to submit (the reason printed).
pub fn write_script(a: &SlurmArgs) -> Result<Option<Arrays>> {
    if let Some(t) = &a.time {
        check_time(t)?;
    }
    for (value, option) in [
        (&a.partition, "partition"),
        (&a.mem, "mem"),
        (&a.account, "account"),
        (&a.qos, "qos"),
        (&a.gres, "gres"),
    ] {
        if let Some(v) = value {
            check_word(v, option)?;
        }
    }
    if let Some(k) = a.max_running {
        at_least_one(k, "max-running")?;
    }
    if let Some(k) = a.max_array_size {
        at_least_one(k, "max-array-size")?;
    }
    at_least_one(a.cpus_per_task, "cpus-per-task")?;
    if a.collect && !a.submit {
        return invalid("--collect: needs --submit (it depends on the arrays' job ids)");
    }
    let dir = absolute(&a.dir)?;
    if dir.display().to_string().contains(char::is_whitespace) {
        return invalid(format!(
            "{}: sbatch's #SBATCH --output cannot hold a path with spaces; move the sweep",
            dir.display()
        ));
    }
    let plan = Plan::read(&dir)?;
    let queued = queued_jobs(&dir)?;
    let ids: Vec<usize> = unfinished(&dir, &plan, a.retry_failed)
        .into_iter()
        .filter(|j| !queued.contains(j))
        .collect();
    let script = dir.join("sweep.sbatch");
    if ids.is_empty() {
        let c = super::status::counts(&dir, &plan);
        eprintln!(
            "porelab sweep slurm: nothing to submit for {}: {}{}{}",
            dir.display(),
            c.line(plan.jobs.len()),
            if queued.is_empty() {
                String::new()
            } else {
                format!("; {} job(s) still queued in earlier arrays", queued.len())
            },
            if c.failed.is_empty() {
                ""
            } else {
                "; failed jobs are submitted again only with --retry-failed"
            }
        );
        let _ = std::fs::remove_file(&script);
        return Ok(None);
    }
    let max_size = match a.max_array_size {
        Some(n) => n,
        None => cluster_max_array_size()?,
    };
    let blocks = blocks(&ids, max_size);
    create_dir(&dir.join("slurm"))?;
    let exe = std::env::current_exe()?;
    let quote = |p: &Path| format!("'{}'", p.display().to_string().replace('\'', r"'\''"));
    let mut s = String::from("#!/bin/bash\n");
    s += &format!(
        "# porelab sweep: {} of {} jobs of {}, in {} array(s) (MaxArraySize {max_size}); task\n\
         # a of an array runs job PORELAB_JOB_BASE + a (`porelab sweep slurm` sets the base)\n",
        ids.len(),
        plan.jobs.len(),
        dir.display(),
        blocks.len()
    );
    s += "#SBATCH --job-name=porelab-sweep\n";
    s += &format!("#SBATCH --output={}/slurm/%A_%a.out\n", dir.display());
    s += "#SBATCH --ntasks=1\n";
    s += &format!("#SBATCH --cpus-per-task={}\n", a.cpus_per_task);
    for (value, option) in [
        (&a.partition, "partition"),
        (&a.time, "time"),
        (&a.mem, "mem"),
        (&a.account, "account"),
        (&a.qos, "qos"),
        (&a.gres, "gres"),
    ] {
        if let Some(v) = value {
            s += &format!("#SBATCH --{option}={v}\n");
        }
    }
    if a.time.is_some() {
        s += &format!("#SBATCH --signal=B:USR1@{}\n", a.signal_before);
    }
    // a requeued task appends to its output file (Slurm truncates it otherwise), so that the
    // log of the run it resumes stays
    s += if a.requeue {
        "#SBATCH --requeue\n#SBATCH --open-mode=append\n"
    } else {
        "#SBATCH --no-requeue\n"
    };
    s += &format!(
        "exec {} sweep job {} \"$((${{PORELAB_JOB_BASE:-0}} + SLURM_ARRAY_TASK_ID))\" \
         --threads {}{}\n",
        quote(&exe),
        quote(&dir),
        a.cpus_per_task,
        if a.requeue { " --requeue" } else { "" }
    );
    write_atomic(&script, s.as_bytes())?;
    let specs: Vec<String> = blocks
        .iter()
        .map(|b| {
            format!(
                "{}{}",
                array_list(&b.tasks),
                a.max_running.map(|k| format!("%{k}")).unwrap_or_default()
            )
        })
        .collect();
    eprintln!(
        "porelab sweep slurm: wrote {} ({} tasks in {} array(s), MaxArraySize {max_size})",
        script.display(),
        ids.len(),
        blocks.len()
    );
    Ok(Some(Arrays {
        script,
        blocks,
        specs,
    }))
}

/// The sbatch arguments of one array.
fn sbatch_args(arrays: &Arrays, k: usize) -> Vec<String> {
    vec![
        format!("--array={}", arrays.specs[k]),
        format!("--export=ALL,PORELAB_JOB_BASE={}", arrays.blocks[k].base),
        arrays.script.display().to_string(),
    ]
}

/// Runs `sbatch --parsable ARGS`; returns the job id.
fn sbatch(args: &[String]) -> Result<String> {
    let text = slurm_out(Command::new("sbatch").arg("--parsable").args(args))?;
    // --parsable prints "jobid" or "jobid;cluster".
    Ok(text.trim().split(';').next().unwrap_or("").to_string())
}

/// `porelab sweep slurm`: writes the script and prints the sbatch command of each array, or
/// with --submit submits them (and the collect job with --collect) and prints their job ids.
/// Exit code 1 when nothing is left to submit but some jobs failed.
pub fn cli_slurm(a: &SlurmArgs) -> Result<ExitCode> {
    let Some(arrays) = write_script(a)? else {
        let dir = absolute(&a.dir)?;
        let plan = Plan::read(&dir)?;
        let c = super::status::counts(&dir, &plan);
        return Ok(if c.failed.is_empty() {
            ExitCode::SUCCESS
        } else {
            ExitCode::from(1)
        });
    };
    if !a.submit {
        for k in 0..arrays.blocks.len() {
            println!("sbatch {}", sbatch_args(&arrays, k).join(" "));
        }
        return Ok(ExitCode::SUCCESS);
    }
    let dir = absolute(&a.dir)?;
    let mut ids = Vec::new();
    for k in 0..arrays.blocks.len() {
        let id = sbatch(&sbatch_args(&arrays, k))?;
        // Recorded at once, so a later submission leaves this array's queued tasks alone
        // even when this process is killed before the next array.
        let path = dir.join("slurm").join(ARRAYS);
        let mut text = std::fs::read_to_string(&path).unwrap_or_default();
        text += &format!("{id},{}\n", arrays.blocks[k].base);
        write_atomic(&path, text.as_bytes())?;
        println!("{id}");
        ids.push(id);
    }
    if a.collect {
        let exe = std::env::current_exe()?;
        let id = sbatch(&[
            format!("--dependency=afterany:{}", ids.join(":")),
            "--job-name=porelab-collect".into(),
            "--ntasks=1".into(),
            format!("--output={}/slurm/collect-%j.out", dir.display()),
            format!(
                "--wrap=exec '{}' sweep collect '{}'",
                exe.display(),
                dir.display()
            ),
        ])?;
        eprintln!("porelab sweep slurm: collect job {id} waits for the arrays");
        println!("{id}");
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_lists_compress_runs() {
        assert_eq!(array_list(&[0, 1, 2, 3]), "0-3");
        assert_eq!(array_list(&[0, 2, 3, 4, 7, 9, 10]), "0,2-4,7,9-10");
        assert_eq!(array_list(&[5]), "5");
    }

    #[test]
    fn blocks_keep_task_ids_below_the_array_size() {
        let jobs: Vec<usize> = (0..12).collect();
        let b = blocks(&jobs, 5);
        assert_eq!(b.len(), 3);
        assert_eq!((b[0].base, b[0].tasks.clone()), (0, vec![0, 1, 2, 3, 4]));
        assert_eq!((b[2].base, b[2].tasks.clone()), (10, vec![0, 1]));
        // Only the last 200 of 1200 jobs pending: one array based at 1000, not ids up to 1199.
        let tail: Vec<usize> = (1000..1200).collect();
        let b = blocks(&tail, 1001);
        assert_eq!(b.len(), 1);
        assert_eq!(
            (b[0].base, array_list(&b[0].tasks)),
            (1000, "0-199".to_string())
        );
        // Gaps stay inside a block while the ids fit.
        let b = blocks(&[3, 4, 9, 12], 8);
        assert_eq!(b.len(), 2);
        assert_eq!((b[0].base, b[0].tasks.clone()), (3, vec![0, 1, 6]));
        assert_eq!((b[1].base, b[1].tasks.clone()), (12, vec![0]));
    }

    #[test]
    fn times_are_checked() {
        for ok in ["01:30:00", "2-00:00:00", "100:00:00"] {
            assert!(check_time(ok).is_ok(), "{ok}");
        }
        for bad in ["1:30", "01:60:00", "ab:00:00", "1-2-00:00:00", ""] {
            let e = check_time(bad).unwrap_err().to_string();
            assert!(e.contains("--time") && e.contains("HH:MM:SS"), "{e}");
        }
    }
}
