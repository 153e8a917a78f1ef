//! Output folders that lose nothing: every command writes its files into a staging folder
//! inside the output folder and moves them into place only when all of them are written.
//!
//! Rules (the user's files are never at risk):
//! - a command replaces only files that a flexarm command wrote into that folder before (the
//!   folder's manifest, `.flexarm-outputs`, lists them); any other file of the same name is left
//!   alone and the command fails, unless `--force`;
//! - a command's earlier files that this run did not write again are removed, so no stale figure
//!   sits beside new data; files of other commands stay (`run` after `paper` keeps the study);
//! - an error before the end leaves the folder as it was: the staging folder is removed (and
//!   the output folder too, when the command created it and it is still empty), nothing
//!   half-written looks like a result;
//! - commands that finish at once into one folder (parallel `run`s) take turns: each holds an
//!   OS lock on the folder (`File::lock`; on a system that cannot open a folder as a file, on
//!   a `.flexarm-outputs.lock` file in it) while it moves its files and updates the manifest,
//!   so each one's update starts from the last one's and no entry is lost;
//! - paths are relative to the current directory, like any command-line tool's (`out/` by
//!   default).

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The manifest's name: one `command<TAB>file` line per file a flexarm command wrote.
pub const MANIFEST: &str = ".flexarm-outputs";
/// The file whose lock a commit holds where the folder itself cannot be locked (empty; it
/// stays).
pub const LOCK: &str = ".flexarm-outputs.lock";

/// Output folders opened by this process: each staging folder's name is its own.
static OPENED: AtomicU64 = AtomicU64::new(0);

/// An output folder being written by one command.
pub struct OutDir {
    dir: PathBuf,
    staging: PathBuf,
    command: String,
    force: bool,
    committed: bool,
    /// The folders [`Self::open`] created, outermost first: removed again, when empty, if the
    /// command does not commit.
    created: Vec<PathBuf>,
}

fn io(what: &str, path: &Path, e: std::io::Error) -> String {
    format!("cannot {what} {}: {e}", path.display())
}

/// Checks that `name` can name a file inside an output folder: not empty, no path separator,
/// not `.` or `..`, not hidden, printable ASCII letters, digits, `_`, `-` and `.` only.
pub fn check_file_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && name.len() <= 100
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{name:?} is not a plain file name (1 to 100 of A–Z, a–z, 0–9, '_', '-', '.', not starting with '.')"
        ))
    }
}

impl OutDir {
    /// Opens `dir` (created if missing) for `command` (a stable key such as `paper` or
    /// `run:trapezoid`) and a fresh staging folder inside it.
    pub fn open(dir: &Path, command: &str, force: bool) -> Result<Self, String> {
        // The folders that do not exist yet, outermost first.
        let mut created: Vec<PathBuf> = dir
            .ancestors()
            .filter(|a| !a.as_os_str().is_empty())
            .take_while(|a| !a.exists())
            .map(Path::to_path_buf)
            .collect();
        created.reverse();
        let mut out = Self {
            dir: dir.to_path_buf(),
            staging: dir.join(format!(
                ".flexarm-staging-{}-{}",
                std::process::id(),
                OPENED.fetch_add(1, Ordering::Relaxed)
            )),
            command: command.to_string(),
            force,
            committed: false,
            created: Vec::new(),
        };
        let made = fs::create_dir_all(dir).map_err(|e| io("create", dir, e));
        // What exists now of what did not (all of it, unless creating failed midway).
        out.created = created.into_iter().filter(|d| d.exists()).collect();
        made?;
        if out.staging.exists() {
            fs::remove_dir_all(&out.staging).map_err(|e| io("clear", &out.staging, e))?;
        }
        fs::create_dir(&out.staging).map_err(|e| io("create", &out.staging, e))?;
        Ok(out)
    }

    /// Where the command writes its files until [`Self::commit`].
    pub fn staging(&self) -> &Path {
        &self.staging
    }

    /// The final folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn manifest(&self) -> Result<Vec<(String, String)>, String> {
        let path = self.dir.join(MANIFEST);
        match fs::read_to_string(&path) {
            Ok(text) => Ok(text
                .lines()
                .filter_map(|l| l.split_once('\t'))
                .filter(|(_, f)| check_file_name(f).is_ok())
                .map(|(c, f)| (c.to_string(), f.to_string()))
                .collect()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Vec::new()),
            Err(e) => Err(io("read", &path, e)),
        }
    }

    /// Moves the staged files into the folder, removes this command's stale files and records
    /// the new set. Returns the names written, sorted. Fails, changing nothing, if a staged
    /// name collides with a file no flexarm command wrote (without `force`).
    pub fn commit(mut self) -> Result<Vec<String>, String> {
        // One commit at a time in this folder; the lock goes when `_lock` is dropped.
        let _lock = lock(&self.dir)?;
        let mut names = BTreeSet::new();
        for entry in fs::read_dir(&self.staging).map_err(|e| io("read", &self.staging, e))? {
            let entry = entry.map_err(|e| io("read", &self.staging, e))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            check_file_name(&name)?;
            names.insert(name);
        }
        let manifest = self.manifest()?;
        let ours: BTreeSet<&str> = manifest.iter().map(|(_, f)| f.as_str()).collect();
        if !self.force {
            for n in &names {
                let target = self.dir.join(n);
                if target.exists() && !ours.contains(n.as_str()) {
                    return Err(format!(
                        "{} exists and was not written by flexarm: not replaced (choose another --out, or --force)",
                        target.display()
                    ));
                }
            }
        }
        for n in &names {
            let (from, to) = (self.staging.join(n), self.dir.join(n));
            fs::rename(&from, &to).map_err(|e| io("move into place", &to, e))?;
        }
        // This command's earlier files that it did not write again.
        for (c, f) in &manifest {
            if *c == self.command && !names.contains(f) {
                let _ = fs::remove_file(self.dir.join(f));
            }
        }
        let mut lines: Vec<String> = manifest
            .iter()
            .filter(|(c, f)| *c != self.command && !names.contains(f))
            .map(|(c, f)| format!("{c}\t{f}"))
            .collect();
        lines.extend(names.iter().map(|n| format!("{}\t{n}", self.command)));
        lines.sort();
        let tmp = self.staging.join(".manifest");
        fs::write(&tmp, lines.join("\n") + "\n").map_err(|e| io("write", &tmp, e))?;
        let path = self.dir.join(MANIFEST);
        fs::rename(&tmp, &path).map_err(|e| io("write", &path, e))?;
        self.committed = true;
        let _ = fs::remove_dir_all(&self.staging);
        Ok(names.into_iter().collect())
    }

    /// [`Self::commit`] of the staged files named in `keep` only, the others discarded: what a
    /// command keeps of a failed run (an experiment's record whose fit failed), its earlier
    /// files gone as after any commit.
    pub fn commit_only(self, keep: &[&str]) -> Result<Vec<String>, String> {
        for entry in fs::read_dir(&self.staging).map_err(|e| io("read", &self.staging, e))? {
            let entry = entry.map_err(|e| io("read", &self.staging, e))?;
            if !keep.iter().any(|k| entry.file_name() == *k) {
                fs::remove_file(entry.path()).map_err(|e| io("remove", &entry.path(), e))?;
            }
        }
        self.commit()
    }
}

/// An exclusive lock on the folder `dir`, held until the file is dropped.
fn lock(dir: &Path) -> Result<fs::File, String> {
    let file = fs::File::open(dir).or_else(|_| {
        let path = dir.join(LOCK);
        fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|e| io("open", &path, e))
    })?;
    file.lock().map_err(|e| io("lock", dir, e))?;
    Ok(file)
}

impl Drop for OutDir {
    /// Without a commit, the staging folder and everything in it go, and the folders `open`
    /// created if nothing else is in them.
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.staging);
            for d in self.created.iter().rev() {
                // Fails, and keeps the folder, when something else is in it.
                let _ = fs::remove_dir(d);
            }
        }
    }
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that
/// `path` holds either its old content or the whole new one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    // The error names the user's path, not the temporary file.
    fs::write(&tmp, bytes).map_err(|e| io("write", path, e))?;
    fs::rename(&tmp, path).map_err(|e| {
        let _ = fs::remove_file(&tmp);
        io("write", path, e)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("flexarm-outdir-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        d
    }

    fn write(o: &OutDir, name: &str, text: &str) {
        fs::write(o.staging().join(name), text).unwrap();
    }

    #[test]
    fn plain_names_only() {
        for bad in [
            "",
            "..",
            ".",
            "../x",
            "/etc/passwd",
            "a/b",
            ".hidden",
            "a b",
            "é",
        ] {
            assert!(check_file_name(bad).is_err(), "{bad:?}");
        }
        for good in ["trapezoid", "run-1.csv", "A_b.9"] {
            assert!(check_file_name(good).is_ok(), "{good:?}");
        }
    }

    #[test]
    fn commit_moves_replaces_its_own_and_removes_its_stale_files() {
        let d = scratch("commit");
        let o = OutDir::open(&d, "paper", false).unwrap();
        write(&o, "a.csv", "1");
        write(&o, "b.svg", "1");
        assert_eq!(o.commit().unwrap(), ["a.csv", "b.svg"]);
        // Another command's file stays; the same command's stale file goes.
        let o = OutDir::open(&d, "run:x", false).unwrap();
        write(&o, "x.csv", "2");
        o.commit().unwrap();
        let o = OutDir::open(&d, "paper", false).unwrap();
        write(&o, "a.csv", "3");
        o.commit().unwrap();
        assert_eq!(fs::read_to_string(d.join("a.csv")).unwrap(), "3");
        assert!(!d.join("b.svg").exists(), "stale figure removed");
        assert!(d.join("x.csv").exists(), "the other command's file kept");
        let entries: Vec<_> = fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(
            !entries
                .iter()
                .any(|e| e.to_string_lossy().starts_with(".flexarm-staging")),
            "{entries:?}"
        );
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_file_that_is_not_ours_is_not_replaced_without_force() {
        let d = scratch("foreign");
        fs::create_dir_all(&d).unwrap();
        fs::write(d.join("notes.md"), "mine").unwrap();
        let o = OutDir::open(&d, "paper", false).unwrap();
        write(&o, "notes.md", "generated");
        write(&o, "a.csv", "1");
        let e = o.commit().unwrap_err();
        assert!(e.contains("not written by flexarm"), "{e}");
        assert_eq!(fs::read_to_string(d.join("notes.md")).unwrap(), "mine");
        assert!(
            !d.join("a.csv").exists(),
            "nothing moved when one name collides"
        );
        let o = OutDir::open(&d, "paper", true).unwrap();
        write(&o, "notes.md", "generated");
        o.commit().unwrap();
        assert_eq!(fs::read_to_string(d.join("notes.md")).unwrap(), "generated");
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn commit_only_keeps_the_named_files_and_drops_the_earlier_run() {
        let d = scratch("only");
        let o = OutDir::open(&d, "identify:modes", false).unwrap();
        write(&o, "modes_record.csv", "1");
        write(&o, "modes.md", "1");
        o.commit().unwrap();
        // The next run's fit fails after writing part of its report: the record alone stays.
        let o = OutDir::open(&d, "identify:modes", false).unwrap();
        write(&o, "modes_record.csv", "2");
        write(&o, "modes.md", "half");
        assert_eq!(
            o.commit_only(&["modes_record.csv"]).unwrap(),
            ["modes_record.csv"]
        );
        assert_eq!(fs::read_to_string(d.join("modes_record.csv")).unwrap(), "2");
        assert!(
            !d.join("modes.md").exists(),
            "neither the half report nor the earlier one"
        );
        assert_eq!(
            fs::read_to_string(d.join(MANIFEST)).unwrap(),
            "identify:modes\tmodes_record.csv\n"
        );
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn without_commit_nothing_appears() {
        let d = scratch("drop");
        {
            let o = OutDir::open(&d, "paper", false).unwrap();
            write(&o, "a.csv", "1");
        }
        assert!(!d.exists(), "not even the folder it created");
        // A folder that was there stays, empty.
        fs::create_dir_all(&d).unwrap();
        drop(OutDir::open(&d, "paper", false).unwrap());
        assert_eq!(fs::read_dir(&d).unwrap().count(), 0);
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_failed_command_leaves_no_folder_it_created() {
        let d = scratch("created");
        let deep = d.join("a").join("b");
        {
            let o = OutDir::open(&deep, "optimize", false).unwrap();
            write(&o, "x.csv", "1");
        }
        assert!(!d.exists(), "every folder open created is gone");
        // A folder that was there stays, and so does one that got another file meanwhile.
        fs::create_dir_all(&d).unwrap();
        {
            let _o = OutDir::open(&deep, "optimize", false).unwrap();
            fs::write(d.join("a").join("mine.txt"), "mine").unwrap();
        }
        assert!(d.join("a").join("mine.txt").exists());
        assert!(!deep.exists());
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn commits_at_once_into_one_folder_keep_every_entry() {
        let d = scratch("parallel");
        let runs: Vec<String> = (0..12).map(|i| format!("run:r{i}")).collect();
        // Every thread stages first, then all commit together.
        let staged: Vec<OutDir> = runs
            .iter()
            .map(|c| {
                let o = OutDir::open(&d, c, false).unwrap();
                write(&o, &format!("{}.csv", &c[4..]), c);
                o
            })
            .collect();
        let barrier = std::sync::Barrier::new(staged.len());
        std::thread::scope(|s| {
            for o in staged {
                let barrier = &barrier;
                s.spawn(move || {
                    barrier.wait();
                    o.commit().unwrap();
                });
            }
        });
        let manifest = fs::read_to_string(d.join(MANIFEST)).unwrap();
        for c in &runs {
            assert!(
                manifest.contains(&format!("{c}\t{}.csv\n", &c[4..])),
                "{c} lost: {manifest}"
            );
        }
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn atomic_write_names_the_path_asked_for() {
        let d = scratch("atomic-missing");
        let p = d.join("nodir").join("g.rs");
        let e = write_atomic(&p, b"x").unwrap_err();
        assert!(
            e.starts_with(&format!("cannot write {}: ", p.display())),
            "{e}"
        );
        assert!(!e.contains(".tmp-"), "{e}");
    }

    #[test]
    fn atomic_write_replaces_whole() {
        let d = scratch("atomic");
        fs::create_dir_all(&d).unwrap();
        let p = d.join("f.rs");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(fs::read_to_string(&p).unwrap(), "two");
        assert_eq!(fs::read_dir(&d).unwrap().count(), 1, "no temporary left");
        fs::remove_dir_all(&d).unwrap();
    }
}
