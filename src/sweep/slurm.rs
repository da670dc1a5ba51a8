//! `porelab sweep slurm DIR`: a Slurm job array (`sbatch --array`) of the unfinished jobs.
//! Each array task runs `porelab sweep job DIR $SLURM_ARRAY_TASK_ID`, whose exit code (0 done,
//! 1 failed) is what `sacct` reports; its output goes to `DIR/slurm/%A_%a.out` (array job id,
//! task id). Writing the script again after some tasks finished lists only the rest.

use super::{at_least_one, unfinished, Plan};
use crate::error::{invalid, Error, Result};
use crate::io::{create_dir, write_atomic};
use std::path::{Path, PathBuf};

#[derive(Debug, clap::Args)]
pub struct SlurmArgs {
    pub dir: PathBuf,
    /// Slurm partition (sbatch --partition).
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit of each task, [D-]HH:MM:SS.
    #[arg(long)]
    pub time: Option<String>,
    /// Most tasks running at once (the array's %K).
    #[arg(long)]
    pub max_running: Option<usize>,
    /// CPUs per task (sbatch --cpus-per-task), also the job's worker threads.
    #[arg(long, default_value_t = 1)]
    pub cpus_per_task: usize,
    /// Include failed jobs in the array.
    #[arg(long)]
    pub retry_failed: bool,
    /// Submit with `sbatch --parsable` and print the array's job id.
    #[arg(long)]
    pub submit: bool,
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
            .all(|c| c.is_ascii_alphanumeric() || "-_.,".contains(c))
    {
        return invalid(format!(
            "--{option} '{value}': use letters, digits and - _ . , only"
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

/// Writes `DIR/sweep.sbatch` for the unfinished jobs; returns its path, or None when every job
/// is finished.
pub fn write_script(a: &SlurmArgs) -> Result<Option<PathBuf>> {
    if let Some(t) = &a.time {
        check_time(t)?;
    }
    if let Some(p) = &a.partition {
        check_word(p, "partition")?;
    }
    if let Some(k) = a.max_running {
        at_least_one(k, "max-running")?;
    }
    at_least_one(a.cpus_per_task, "cpus-per-task")?;
    let dir = absolute(&a.dir)?;
    let plan = Plan::read(&dir)?;
    let ids = unfinished(&dir, &plan, a.retry_failed);
    let script = dir.join("sweep.sbatch");
    if ids.is_empty() {
        eprintln!(
            "porelab sweep slurm: every job of {} is finished; no array written",
            dir.display()
        );
        let _ = std::fs::remove_file(&script);
        return Ok(None);
    }
    let max_id = *ids.last().expect("not empty");
    if max_id > 1000 {
        eprintln!(
            "porelab sweep slurm: task ids up to {max_id}: Slurm's default MaxArraySize (1001) \
             allows ids up to 1000; the cluster's slurm.conf must allow more"
        );
    }
    create_dir(&dir.join("slurm"))?;
    let exe = std::env::current_exe()?;
    let quote = |p: &Path| format!("'{}'", p.display().to_string().replace('\'', r"'\''"));
    let mut s = String::from("#!/bin/bash\n");
    s += &format!(
        "# porelab sweep: {} of {} jobs of {}\n",
        ids.len(),
        plan.jobs.len(),
        dir.display()
    );
    s += "#SBATCH --job-name=porelab-sweep\n";
    s += &format!(
        "#SBATCH --array={}{}\n",
        array_list(&ids),
        a.max_running.map(|k| format!("%{k}")).unwrap_or_default()
    );
    s += &format!("#SBATCH --output={}/slurm/%A_%a.out\n", dir.display());
    s += "#SBATCH --ntasks=1\n";
    s += &format!("#SBATCH --cpus-per-task={}\n", a.cpus_per_task);
    if let Some(p) = &a.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &a.time {
        s += &format!("#SBATCH --time={t}\n");
    }
    s += &format!(
        "exec {} sweep job {} \"$SLURM_ARRAY_TASK_ID\" --threads {}\n",
        quote(&exe),
        quote(&dir),
        a.cpus_per_task
    );
    if dir.display().to_string().contains(char::is_whitespace) {
        return invalid(format!(
            "{}: sbatch's #SBATCH --output cannot hold a path with spaces; move the sweep",
            dir.display()
        ));
    }
    write_atomic(&script, s.as_bytes())?;
    eprintln!(
        "porelab sweep slurm: wrote {} ({} tasks: --array={})",
        script.display(),
        ids.len(),
        array_list(&ids)
    );
    Ok(Some(script))
}

/// `porelab sweep slurm`: writes the script and, with --submit, prints the array's job id.
pub fn cli_slurm(a: &SlurmArgs) -> Result<()> {
    let Some(script) = write_script(a)? else {
        return Ok(());
    };
    if !a.submit {
        println!("{}", script.display());
        return Ok(());
    }
    let out = std::process::Command::new("sbatch")
        .arg("--parsable")
        .arg(&script)
        .output()
        .map_err(|e| Error::Validation(format!("cannot run sbatch: {e} (is Slurm installed?)")))?;
    if !out.status.success() {
        return Err(Error::Validation(format!(
            "sbatch {} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    // --parsable prints "jobid" or "jobid;cluster".
    let text = String::from_utf8_lossy(&out.stdout);
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    println!("{id}");
    Ok(())
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
