//! The finished runs of an ensemble, kept on disk so that a killed ensemble resumes.
//!
//! Each independent run of a scene (one random stream, (seed, run)) is written, when it ends,
//! to `<out>/runs/<tag>.json` with the hash of the scene text. Run again into the same
//! folder, the scene loads those runs instead of recomputing them: the outputs are the same as
//! an uninterrupted run's, because a run depends on nothing but the scene and its index. A run
//! file written by a different scene text is refused, naming the file.

use crate::error::{Error, Result};
use crate::io::fnv1a64;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[derive(Serialize, Deserialize)]
struct Stored<T> {
    scene_hash: String,
    result: T,
}

/// Where one scene's finished runs live.
pub struct RunStore {
    dir: PathBuf,
    scene_hash: String,
}

impl RunStore {
    /// The store of the scene `text` under the output folder `out`.
    pub fn new(out: &Path, text: &str) -> RunStore {
        RunStore {
            dir: out.join("runs"),
            scene_hash: format!("{:016x}", fnv1a64(text.as_bytes())),
        }
    }

    fn path(&self, tag: &str) -> PathBuf {
        self.dir.join(format!("{tag}.json"))
    }

    /// The stored result of run `tag`, if it finished before.
    pub fn load<T: DeserializeOwned>(&self, tag: &str) -> Result<Option<T>> {
        let path = self.path(tag);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => {
                return Err(Error::File {
                    path: path.display().to_string(),
                    msg: format!("cannot read the finished run: {e}"),
                })
            }
        };
        let named = |msg: String| Error::File {
            path: path.display().to_string(),
            msg,
        };
        let stored: Stored<T> = serde_json::from_slice(&bytes).map_err(|e| {
            named(format!(
                "not a finished run of this porelab ({e}); delete {} to start afresh",
                self.dir.display()
            ))
        })?;
        if stored.scene_hash != self.scene_hash {
            return Err(named(format!(
                "written by a different scene (hash {} against {}); delete {} to start afresh",
                stored.scene_hash,
                self.scene_hash,
                self.dir.display()
            )));
        }
        Ok(Some(stored.result))
    }

    /// Stores the result of run `tag` (atomically).
    pub fn save<T: Serialize>(&self, tag: &str, result: &T) -> Result<()> {
        let stored = Stored {
            scene_hash: self.scene_hash.clone(),
            result,
        };
        let text = serde_json::to_vec(&stored)
            .map_err(|e| Error::InvalidInput(format!("run {tag}: cannot store the result: {e}")))?;
        crate::io::write_atomic(&self.path(tag), &text)
    }

    /// Refuses a folder that holds a run of another scene text, naming the first such file in
    /// name order. Checked before the runs start: the runs load their files in parallel, and
    /// the file an error names would otherwise depend on which worker read first.
    pub fn check_folder(&self) -> Result<()> {
        let Ok(entries) = std::fs::read_dir(&self.dir) else {
            // no folder: nothing stored yet (a folder that cannot be read fails at each load)
            return Ok(());
        };
        let mut tags: Vec<String> = entries
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|name| !name.starts_with('.'))
            .filter_map(|name| name.strip_suffix(".json").map(str::to_string))
            .collect();
        tags.sort();
        for tag in tags {
            self.load::<serde::de::IgnoredAny>(&tag)?;
        }
        Ok(())
    }

    /// The stored result of run `tag`, or `compute()`'s, stored before it is returned. The
    /// flag is true when the run was loaded.
    pub fn load_or_run<T: Serialize + DeserializeOwned>(
        &self,
        tag: &str,
        compute: impl FnOnce() -> Result<T>,
    ) -> Result<(T, bool)> {
        if let Some(r) = self.load(tag)? {
            return Ok((r, true));
        }
        let r = compute()?;
        self.save(tag, &r)?;
        Ok((r, false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stores_loads_and_refuses_another_scene() {
        let out = std::env::temp_dir().join(format!("porelab-runstore-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let a = RunStore::new(&out, "kind = \"brownian\"\n");
        let (v, loaded) = a
            .load_or_run("p0-r1", || Ok(vec![0.1f64, 1.0 / 3.0]))
            .unwrap();
        assert!(!loaded);
        let (w, loaded) = a
            .load_or_run("p0-r1", || -> Result<Vec<f64>> { panic!("must load") })
            .unwrap();
        assert!(loaded);
        assert_eq!(v, w, "floats round-trip exactly");
        let b = RunStore::new(&out, "kind = \"brownian\"\ntitle = \"x\"\n");
        let e = b.load::<Vec<f64>>("p0-r1").unwrap_err().to_string();
        assert!(
            e.contains("different scene") && e.contains("p0-r1.json"),
            "{e}"
        );
        // the folder check names the first foreign file in name order
        a.save("p0-r0", &vec![2.0f64]).unwrap();
        a.check_folder().unwrap();
        let e = b.check_folder().unwrap_err().to_string();
        assert!(
            e.contains("different scene") && e.contains("p0-r0.json"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&out);
    }
}
