//! Outputs written as one unit: nothing half-written, nothing mismatched,
//! nothing left behind.
//!
//! - [`AtomicWrites`] stages files under temporary names in their target
//!   directories (a hidden `.{name}.{pid}-{n}.tmp.{ext}`, same extension so
//!   format detection by extension keeps working, same directory so the
//!   rename never crosses file systems), flushes each to disk, and only
//!   when every file has been written renames them over their targets. A
//!   failed write removes the staged files and leaves every target as it
//!   was: `render -o x.exr` never leaves a new EXR beside an old PNG.
//! - [`StagedDir`] does the same for a directory of outputs (`compare`,
//!   `sweep`, `tune`): the run writes into a hidden staging directory
//!   inside the output directory, and [`StagedDir::commit`] moves the files
//!   in (the report last) only once the run has succeeded. A failed run
//!   leaves the previous run's files untouched; files of the output
//!   directory that this run does not write are never touched.
//! - A target is never something the run reads or a special file:
//!   [`check_writable`] (which every write above runs first, and whose
//!   checks [`StagedDir::commit`] runs on every file of the directory
//!   before it moves any in) refuses a
//!   path that exists and is not a regular file (a rename would replace a
//!   FIFO or a device node with a file) and one the process has read as
//!   an input ([`note_input`]: scenes, meshes, material libraries, EXR
//!   references and cache entries; in the `mdas` command, which calls
//!   [`guard_inputs`], not in a program using the library).
//! - An interrupt (SIGINT, SIGTERM, SIGHUP; [`install_interrupt_cleanup`])
//!   removes every staged file and staging directory before the process
//!   exits with status 130, so no hidden temporary is left behind. Only
//!   SIGKILL or a power cut can leave one (named as above, safe to
//!   delete); the next [`StagedDir`] in the same directory removes the
//!   staging directories of processes that no longer run.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use anyhow::{anyhow, bail, Context, Result};

/// Distinguishes temporary names of concurrent writes in one process (the
/// pid alone does not: tests and worker threads share it).
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Staged files and directories that an interrupt must remove.
static PENDING: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// The files this process has read as inputs, canonical ([`note_input`]).
static INPUTS: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// Whether inputs are recorded ([`guard_inputs`]): the `mdas` command
/// turns it on; a program using the library reads and rewrites its own
/// files as it pleases.
static GUARD_INPUTS: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// From now on, every file read as an input ([`note_input`]) is refused
/// as an output target by [`check_writable`]. The `mdas` command calls it
/// first thing: no output of a run replaces one of its inputs.
pub fn guard_inputs() {
    GUARD_INPUTS.store(true, Ordering::Relaxed);
}

/// `path` with its directory made canonical (links resolved, `..` gone)
/// and, if it exists, itself: two names of one file compare equal, and a
/// file not yet written still has a name to compare.
fn canonical(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.unwrap_or(Path::new(".")).canonicalize().ok()?;
    Some(dir.join(path.file_name()?))
}

/// Records that the process read `path` as an input: [`check_writable`]
/// refuses it as a target from then on (`--json-out scene.toml`, `-o`
/// naming the scene's OBJ). Readers call it as they open a file; it
/// records nothing until [`guard_inputs`] is called.
pub fn note_input(path: &Path) {
    if !GUARD_INPUTS.load(Ordering::Relaxed) {
        return;
    }
    if let Some(p) = canonical(path) {
        INPUTS.lock().unwrap_or_else(|e| e.into_inner()).insert(p);
    }
}

fn pending() -> std::sync::MutexGuard<'static, BTreeSet<PathBuf>> {
    // A panic while the lock was held cannot leave the set inconsistent.
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every staged file and staging directory (what the interrupt
/// handler does before exiting); returns how many were removed.
pub fn remove_pending() -> usize {
    remove_pending_under(Path::new(""))
}

/// [`remove_pending`] for the staged paths under `root` only ("" is every
/// path).
fn remove_pending_under(root: &Path) -> usize {
    let paths: Vec<PathBuf> = {
        let mut set = pending();
        let ours: Vec<PathBuf> = set
            .iter()
            .filter(|p| p.starts_with(root))
            .cloned()
            .collect();
        for p in &ours {
            set.remove(p);
        }
        ours
    };
    paths
        .iter()
        .filter(|p| {
            if p.is_dir() {
                fs::remove_dir_all(p).is_ok()
            } else {
                fs::remove_file(p).is_ok()
            }
        })
        .count()
}

/// The paths an interrupt would remove now (for tests).
pub fn pending_paths() -> Vec<PathBuf> {
    pending().iter().cloned().collect()
}

/// Installs the handler that removes staged outputs on SIGINT, SIGTERM and
/// SIGHUP and exits with status 130. Called once by the `mdas` binary; a
/// library user keeps their own signal handling.
pub fn install_interrupt_cleanup() -> Result<()> {
    ctrlc::set_handler(|| {
        let removed = remove_pending();
        if removed > 0 {
            eprintln!("interrupted: {removed} partial output(s) removed");
        } else {
            eprintln!("interrupted");
        }
        std::process::exit(130);
    })
    .map_err(|e| anyhow!("cannot install the interrupt handler: {e}"))
}

/// A staged path, removed when dropped unless disarmed (errors and panics
/// alike), and by an interrupt while it exists.
struct Staged {
    path: PathBuf,
    armed: bool,
}

impl Staged {
    fn new(path: PathBuf) -> Staged {
        pending().insert(path.clone());
        Staged { path, armed: true }
    }

    /// The path now belongs to the caller (renamed into place).
    fn disarm(mut self) {
        pending().remove(&self.path);
        self.armed = false;
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if self.armed {
            pending().remove(&self.path);
            // Best effort: the writer may have failed before creating it.
            if self.path.is_dir() {
                let _ = fs::remove_dir_all(&self.path);
            } else {
                let _ = fs::remove_file(&self.path);
            }
        }
    }
}

/// The hidden temporary name for `path` (see the module docs).
fn temp_path_for(path: &Path) -> Result<PathBuf> {
    let file_name = path
        .file_name()
        .ok_or_else(|| anyhow!("cannot write {}: the path has no file name", path.display()))?;
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(file_name);
    temp_name.push(format!(
        ".{}-{}.tmp",
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    if let Some(extension) = path.extension() {
        temp_name.push(".");
        temp_name.push(extension);
    }
    Ok(path.with_file_name(temp_name))
}

/// Undoes [`note_input`] for a file its owner means to replace: the
/// reference cache rebuilding an entry it read and found damaged.
pub fn release_input(path: &Path) {
    if let Some(p) = canonical(path) {
        INPUTS.lock().unwrap_or_else(|e| e.into_inner()).remove(&p);
    }
}

/// Checks that `path` can be written: its directory exists, and it is
/// neither a directory, nor another file that is not a regular one (a
/// FIFO, socket or device: the rename that lands an output would replace
/// it), nor an input this process has read ([`note_input`]). Cheap;
/// callers run it before any GPU work so that a bad output path fails in
/// milliseconds, not after the render.
pub fn check_writable(path: &Path) -> Result<()> {
    // `x.exr/` names a directory to the file system (the final rename
    // fails), though its file name reads `x.exr`.
    if path
        .as_os_str()
        .to_string_lossy()
        .ends_with(std::path::MAIN_SEPARATOR)
    {
        bail!(
            "cannot write {}: a file's path cannot end with '{}'",
            path.display(),
            std::path::MAIN_SEPARATOR
        );
    }
    let directory = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    if !directory.is_dir() {
        bail!(
            "cannot write {}: directory {} does not exist",
            path.display(),
            directory.display()
        );
    }
    check_target(path)?;
    let probe = temp_path_for(path)?;
    let staged = Staged::new(probe.clone());
    fs::write(&probe, b"").with_context(|| {
        format!(
            "cannot write {}: directory {} is not writable",
            path.display(),
            directory.display()
        )
    })?;
    drop(staged);
    Ok(())
}

/// What a rename over `path` must not replace: a directory, another file
/// that is not a regular one (a FIFO, socket or device) or an input this
/// process has read ([`note_input`]). [`check_writable`] and
/// [`StagedDir::commit`] (for every file it moves in) run it.
fn check_target(path: &Path) -> Result<()> {
    if path.is_dir() {
        bail!("cannot write {}: it is a directory", path.display());
    }
    if let Ok(meta) = fs::metadata(path) {
        if !meta.is_file() {
            bail!(
                "cannot write {}: it exists and is not a regular file (a FIFO, socket or device), which writing the output would replace; choose another path",
                path.display()
            );
        }
    }
    if let Some(p) = canonical(path) {
        if INPUTS
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .contains(&p)
        {
            bail!(
                "cannot write {}: it is an input of this run; choose another path",
                path.display()
            );
        }
    }
    Ok(())
}

/// Files written as one unit (see the module docs).
#[derive(Default)]
pub struct AtomicWrites {
    staged: Vec<(PathBuf, Staged)>,
}

impl AtomicWrites {
    pub fn new() -> AtomicWrites {
        AtomicWrites::default()
    }

    /// Calls `write` with a temporary path beside `path` and flushes what it
    /// wrote to disk; `path` itself is untouched until [`Self::commit`].
    /// Errors say `cannot write {path}: ...`.
    pub fn stage(&mut self, path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
        if self.staged.iter().any(|(target, _)| target == path) {
            bail!("cannot write {}: it is written twice", path.display());
        }
        check_writable(path)?;
        let temp = temp_path_for(path)?;
        let staged = Staged::new(temp.clone());
        write(&temp).with_context(|| format!("cannot write {}", path.display()))?;
        if !temp.is_file() {
            bail!(
                "cannot write {}: the writer did not create the temporary file {}",
                path.display(),
                temp.display()
            );
        }
        // Make the data durable before the rename makes it visible.
        fs::File::open(&temp)
            .and_then(|file| file.sync_all())
            .with_context(|| {
                format!(
                    "cannot write {}: flushing {} failed",
                    path.display(),
                    temp.display()
                )
            })?;
        self.staged.push((path.to_path_buf(), staged));
        Ok(())
    }

    /// Renames every staged file over its target, in the order staged. A
    /// rename within one directory does not fail short of the file system
    /// failing; if one does, the files not yet renamed are removed and the
    /// error names the file.
    pub fn commit(self) -> Result<()> {
        for (target, staged) in self.staged {
            fs::rename(&staged.path, &target).with_context(|| {
                format!(
                    "cannot write {}: renaming {} over it failed",
                    target.display(),
                    staged.path.display()
                )
            })?;
            staged.disarm();
        }
        Ok(())
    }
}

/// Writes `path` atomically: [`AtomicWrites`] with one file.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let mut writes = AtomicWrites::new();
    writes.stage(path, write)?;
    writes.commit()
}

/// Removes the staging directories (`.mdas-partial-{pid}-{n}`) that
/// processes no longer running left in `target`: a run killed with SIGKILL
/// cannot clean up after itself, so the next run into the same directory
/// does (issue 54 item 7). A directory whose process is alive, or whose
/// name does not parse, is left alone. Returns how many were removed.
fn sweep_stale_staging(target: &Path) -> usize {
    // Liveness is read from /proc: without it (not Linux), sweep nothing.
    if !Path::new("/proc/self").exists() {
        return 0;
    }
    let Ok(entries) = fs::read_dir(target) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(".mdas-partial-")) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        let alive = pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists();
        if !alive && entry.path().is_dir() && fs::remove_dir_all(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// What [`StagedDir::new`] refuses of `target` without writing anything:
/// a path that exists and is not a directory. A run that makes several
/// output directories (`compare --frames`) checks them all before its
/// first render.
pub fn check_dir_target(target: &Path) -> Result<()> {
    if target.exists() && !target.is_dir() {
        bail!("output directory {} is not a directory", target.display());
    }
    Ok(())
}

/// A directory of outputs written as one unit (see the module docs).
pub struct StagedDir {
    target: PathBuf,
    staging: Option<Staged>,
    /// The directories this run created for the target (it and the
    /// ancestors that did not exist, deepest first): a failed run removes
    /// them again, each if empty.
    created: Vec<PathBuf>,
}

impl StagedDir {
    /// Creates `target` if needed and a hidden staging directory inside it,
    /// checking both are writable (before any GPU work).
    pub fn new(target: &Path) -> Result<StagedDir> {
        let created: Vec<PathBuf> = target
            .ancestors()
            .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
            .map(Path::to_path_buf)
            .collect();
        check_dir_target(target)?;
        fs::create_dir_all(target)
            .with_context(|| format!("cannot create output directory {}", target.display()))?;
        sweep_stale_staging(target);
        let mut dir = StagedDir {
            target: target.to_path_buf(),
            staging: None,
            created,
        };
        let path = target.join(format!(
            ".mdas-partial-{}-{}",
            std::process::id(),
            TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let staged = Staged::new(path.clone());
        fs::create_dir(&path)
            .with_context(|| format!("output directory {} is not writable", target.display()))?;
        dir.staging = Some(staged);
        Ok(dir)
    }

    /// Where the run writes its files.
    pub fn path(&self) -> &Path {
        &self.staging.as_ref().expect("staging until committed").path
    }

    /// The output directory the files go to.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Moves every file of the staging directory into the output directory
    /// (`last` after the others, so a reader that sees a new report sees
    /// the new images), then removes the staging directory. Returns the
    /// moved file names, sorted.
    pub fn commit(mut self, last: &str) -> Result<Vec<String>> {
        let staging = self.staging.take().expect("committed once");
        let mut names: Vec<String> = fs::read_dir(&staging.path)
            .with_context(|| format!("cannot list {}", staging.path.display()))?
            .map(|e| Ok(e?.file_name().to_string_lossy().into_owned()))
            .collect::<std::io::Result<_>>()?;
        names.sort_by_key(|n| (n == last, n.clone()));
        // Every target first, so that a refused one leaves the output
        // directory as it was: a FIFO, device or input named like an
        // output is refused (issue 67, hostile inputs class 4), not
        // replaced by the rename.
        for name in &names {
            check_target(&self.target.join(name))?;
        }
        for name in &names {
            let to = self.target.join(name);
            fs::rename(staging.path.join(name), &to)
                .with_context(|| format!("cannot move {name} into {}", self.target.display()))?;
        }
        // Dropping the armed guard removes the (now empty) staging directory.
        drop(staging);
        self.created.clear();
        Ok(names)
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        // Removes the staging directory with whatever the run wrote.
        self.staging.take();
        // remove_dir refuses a directory where anything else appeared
        // meanwhile, and then its ancestors hold it.
        for dir in &self.created {
            if fs::remove_dir(dir).is_err() {
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("mdas-atomic-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    /// A failure in the second file of a unit leaves the first target as it
    /// was and no temporary file behind.
    #[test]
    fn a_failed_unit_changes_no_target() {
        let dir = test_dir("unit");
        let (a, b) = (dir.join("a.exr"), dir.join("a.png"));
        fs::write(&a, b"old a").unwrap();
        fs::write(&b, b"old b").unwrap();
        let mut w = AtomicWrites::new();
        w.stage(&a, |t| Ok(fs::write(t, b"new a")?)).unwrap();
        assert!(w.stage(&b, |_| bail!("disk full")).is_err());
        drop(w);
        assert_eq!(fs::read(&a).unwrap(), b"old a");
        assert_eq!(entries(&dir), ["a.exr", "a.png"]);
        let mut w = AtomicWrites::new();
        w.stage(&a, |t| Ok(fs::write(t, b"new a")?)).unwrap();
        w.stage(&b, |t| Ok(fs::write(t, b"new b")?)).unwrap();
        assert_eq!(
            fs::read(&a).unwrap(),
            b"old a",
            "nothing moves before commit"
        );
        w.commit().unwrap();
        assert_eq!(fs::read(&b).unwrap(), b"new b");
        assert_eq!(entries(&dir), ["a.exr", "a.png"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    /// A staged directory is invisible until committed, a dropped one leaves
    /// the old outputs and the user's own files alone, and the directories
    /// this run created are removed again when the run fails.
    /// A staging directory left by a process that no longer runs (a
    /// SIGKILLed `compare`) is swept by the next run into the same
    /// directory; a live process's, and names that do not parse, are not.
    #[test]
    fn stale_staging_directories_of_dead_processes_are_swept() {
        let dir = test_dir("sweep");
        // Above Linux's largest pid (2^22): no such process.
        let dead = dir.join(".mdas-partial-4000000000-3");
        let live = dir.join(format!(".mdas-partial-{}-99", std::process::id()));
        let odd = dir.join(".mdas-partial-x");
        for d in [&dead, &live, &odd] {
            fs::create_dir_all(d).unwrap();
            fs::write(d.join("render.exr"), b"partial").unwrap();
        }
        let staged = StagedDir::new(&dir).unwrap();
        assert!(
            !dead.exists(),
            "the dead process's staging directory stayed"
        );
        assert!(live.exists() && odd.exists());
        drop(staged);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_staged_directory_lands_whole_or_not_at_all() {
        let dir = test_dir("dir");
        fs::write(dir.join("report.json"), b"old").unwrap();
        fs::write(dir.join("notes.txt"), b"mine").unwrap();
        let staged = StagedDir::new(&dir).unwrap();
        fs::write(staged.path().join("image.png"), b"new").unwrap();
        fs::write(staged.path().join("report.json"), b"new").unwrap();
        assert!(pending_paths().contains(&staged.path().to_path_buf()));
        drop(staged);
        assert_eq!(entries(&dir), ["notes.txt", "report.json"]);
        assert_eq!(fs::read(dir.join("report.json")).unwrap(), b"old");

        let staged = StagedDir::new(&dir).unwrap();
        fs::write(staged.path().join("image.png"), b"new").unwrap();
        fs::write(staged.path().join("report.json"), b"new").unwrap();
        let moved = staged.commit("report.json").unwrap();
        assert_eq!(moved, ["image.png", "report.json"]);
        assert_eq!(entries(&dir), ["image.png", "notes.txt", "report.json"]);
        assert_eq!(fs::read(dir.join("report.json")).unwrap(), b"new");

        let fresh = dir.join("fresh");
        drop(StagedDir::new(&fresh).unwrap());
        assert!(!fresh.exists());
        // Missing ancestors too (issue 54 item 7: `--out new/a/b` left
        // new/a), but not one where something else appeared.
        drop(StagedDir::new(&dir.join("new/a/b")).unwrap());
        assert!(!dir.join("new").exists());
        let staged = StagedDir::new(&dir.join("new/a/b")).unwrap();
        fs::write(dir.join("new/mine.txt"), b"mine").unwrap();
        drop(staged);
        assert_eq!(entries(&dir.join("new")), ["mine.txt"]);
        fs::remove_dir_all(dir.join("new")).unwrap();
        fs::write(&fresh, b"a file").unwrap();
        assert!(StagedDir::new(&fresh).is_err());
        fs::remove_dir_all(&dir).unwrap();
    }

    /// A FIFO named like a staged file is refused at the commit and left
    /// a FIFO, and no file of the run is moved in (issue 67, hostile
    /// inputs class 4: the rename replaced it).
    #[test]
    fn a_fifo_named_like_a_staged_file_is_refused_whole() {
        use std::os::unix::fs::FileTypeExt;
        let dir = test_dir("fifo-target");
        let made = std::process::Command::new("mkfifo")
            .arg(dir.join("b.json"))
            .status()
            .unwrap();
        assert!(made.success());
        let staged = StagedDir::new(&dir).unwrap();
        fs::write(staged.path().join("a.csv"), b"a").unwrap();
        fs::write(staged.path().join("b.json"), b"b").unwrap();
        let e = staged.commit("b.json").unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
        assert_eq!(entries(&dir), ["b.json"]);
        let kind = fs::symlink_metadata(dir.join("b.json"))
            .unwrap()
            .file_type();
        assert!(kind.is_fifo());
        fs::remove_dir_all(&dir).unwrap();
    }

    /// What the interrupt handler removes: every staged file and staging
    /// directory that exists at that moment, and nothing else.
    #[test]
    fn an_interrupt_removes_staged_files() {
        let dir = test_dir("interrupt");
        let keep = dir.join("keep.exr");
        fs::write(&keep, b"keep").unwrap();
        let staged = StagedDir::new(&dir.join("out")).unwrap();
        let file = Staged::new(temp_path_for(&keep).unwrap());
        fs::write(&file.path, b"partial").unwrap();
        let (a, b) = (file.path.clone(), staged.path().to_path_buf());
        assert!(a.exists() && b.exists());
        // Other tests stage files concurrently: remove only ours.
        assert_eq!(remove_pending_under(&dir), 2);
        assert!(!a.exists() && !b.exists() && keep.exists());
        drop((file, staged));
        fs::remove_dir_all(&dir).unwrap();
    }
}
