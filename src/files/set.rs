//! The files of one run written as a set ([`FileSet`]): a failure or an interrupt before
//! the last of them is written leaves every earlier file as it was, never a mix of new and
//! old ones.
//!
//! Each file goes to a temporary `.NAME.tmp-PID-N.EXT` beside it (its extension kept, for
//! the writers that pick the format by it), registered for removal on SIGINT or SIGTERM like
//! [`write_atomic`]'s; once all are written each is renamed over its name, in the order
//! staged, an earlier file kept aside (hard-linked or copied to a temporary name) until
//! every one is in place. Where one cannot be placed, those placed before it get their
//! earlier files back; SIGINT and SIGTERM wait until the commit is over (a second one ends
//! it at once). A file whose name is a link or
//! a device is written through ([`write_atomic`]) after the renames, which it cannot undo:
//! where a second such file fails, the first stays written. A temporary a killed run
//! leaves is removed by [`remove_stale_temps`], which each set runs on the folders it
//! writes into.

use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::{FileError, interrupt, remove_stale_temps, write_atomic};

/// Files written as one set (module doc): write each into [`FileSet::stage`]'s temporary,
/// then [`FileSet::commit`]. Dropped without a commit, the set removes its temporaries.
#[derive(Debug, Default)]
pub struct FileSet {
    staged: Vec<Staged>,
    /// The folders its files go into, each cleared of stale temporaries once.
    dirs: Vec<PathBuf>,
    /// Files an earlier run may have left that this one does not write
    /// ([`FileSet::replaces`]).
    earlier: Vec<PathBuf>,
}

#[derive(Debug)]
struct Staged {
    tmp: PathBuf,
    path: PathBuf,
    slot: Option<usize>,
}

impl FileSet {
    /// An empty set.
    pub fn new() -> FileSet {
        FileSet::default()
    }

    /// The temporary to write `path`'s bytes to, in `path`'s folder.
    pub fn stage(&mut self, path: &Path) -> PathBuf {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if !self.dirs.contains(&dir) {
            remove_stale_temps(&dir);
            self.dirs.push(dir.clone());
        }
        let tmp = temporary_beside(&dir, path);
        let slot = interrupt::register(&tmp);
        self.staged.push(Staged {
            tmp: tmp.clone(),
            path: path.to_path_buf(),
            slot,
        });
        tmp
    }

    /// Marks `path` as one of the set's files in some runs: when this run does not stage it,
    /// [`FileSet::commit`] removes an earlier run's copy, so the files describe one run.
    pub fn replaces(&mut self, path: &Path) {
        self.earlier.push(path.to_path_buf());
    }

    /// Puts every staged file in its place (module doc: all of them or, where one cannot
    /// be placed, none of the renamed ones), then removes the [`FileSet::replaces`] files
    /// it did not stage.
    ///
    /// # Errors
    /// [`FileError::Io`] naming the file that could not be placed (the temporaries are
    /// removed and the earlier files restored), or [`write_atomic`]'s error for a link or
    /// device in the way; [`FileError::Io`] naming a [`FileSet::replaces`] file that could
    /// not be removed, with the new set already in place.
    pub fn commit(mut self) -> Result<(), FileError> {
        let _hold = interrupt::hold();
        let written: Vec<PathBuf> = self.staged.iter().map(|s| s.path.clone()).collect();
        let (plain, through): (Vec<Staged>, Vec<Staged>) = std::mem::take(&mut self.staged)
            .into_iter()
            .partition(|s| is_plain_or_absent(&s.path));
        let mut placed: Vec<Placed> = Vec::with_capacity(plain.len());
        let mut rest = plain.into_iter().chain(through);
        while let Some(staged) = rest.next() {
            let outcome = if is_plain_or_absent(&staged.path) {
                rename_keeping_earlier(&staged.tmp, &staged.path).map(|earlier| {
                    placed.push(Placed {
                        path: staged.path.clone(),
                        earlier,
                    })
                })
            } else {
                write_through(&staged.tmp, &staged.path)
            };
            if let Err(e) = outcome {
                restore(&placed);
                self.staged.push(staged);
                self.staged.extend(rest);
                return Err(e);
            }
            interrupt::unregister(staged.slot);
            #[cfg(feature = "test-hooks")]
            interrupt_after_placing(&staged.path);
        }
        for p in &placed {
            if let Earlier::Aside(aside) = &p.earlier {
                let _ = fs::remove_file(aside); // only a kept-aside copy; the sweep takes it
            }
        }
        for path in self.earlier.iter().filter(|p| !written.contains(p)) {
            match fs::remove_file(path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(FileError::Io {
                        path: path.clone(),
                        action: "remove it (an earlier run's file)",
                        cause: e,
                    });
                }
                _ => {}
            }
        }
        for dir in &self.dirs {
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all(); // not supported everywhere; the renames are done
            }
        }
        Ok(())
    }
}

/// SIGINT to this thread once `path` is placed, where [`super::INTERRUPT_WHILE_COMMITTING_ENV`]
/// names it (the commit's hold defers it to the commit's end).
#[cfg(feature = "test-hooks")]
fn interrupt_after_placing(path: &Path) {
    let named = std::env::var_os(super::INTERRUPT_WHILE_COMMITTING_ENV);
    if named.is_some_and(|n| path.file_name() == Some(n.as_os_str())) {
        interrupt::raise_sigint();
    }
}

/// A file a commit renamed into place, and what became of its earlier file.
struct Placed {
    path: PathBuf,
    earlier: Earlier,
}

/// The file that was at a [`Placed`] file's name before the commit.
enum Earlier {
    /// None was there.
    Absent,
    /// Kept aside at this temporary name until the commit is over.
    Aside(PathBuf),
    /// There, but it could be neither hard-linked nor copied aside (a file this process
    /// cannot read, under `protected_hardlinks`): replaced for good.
    Unkept,
}

/// `.NAME.tmp-PID-N.EXT` in `dir` for `path` (its extension kept).
fn temporary_beside(dir: &Path, path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".to_string());
    let mut tmp_name = format!(
        ".{name}.tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    );
    if let Some(ext) = path.extension() {
        tmp_name.push('.');
        tmp_name.push_str(&ext.to_string_lossy());
    }
    dir.join(tmp_name)
}

/// Whether `path` is a plain file or nothing yet (renamed over; a link or a device is
/// written through).
fn is_plain_or_absent(path: &Path) -> bool {
    fs::symlink_metadata(path).map_or(true, |m| m.is_file())
}

/// Renames `tmp` over `path`, an earlier file at `path` first hard-linked to a temporary
/// name beside it (for [`restore`]); where the filesystem refuses the link, copied there;
/// where neither can be done, replaced without a copy ([`Earlier::Unkept`]).
fn rename_keeping_earlier(tmp: &Path, path: &Path) -> Result<Earlier, FileError> {
    let earlier = if path.exists() {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let aside = temporary_beside(dir, path);
        if fs::hard_link(path, &aside).is_ok() || copy_new(path, &aside).is_ok() {
            Earlier::Aside(aside)
        } else {
            Earlier::Unkept
        }
    } else {
        Earlier::Absent
    };
    if let Err(cause) = fs::rename(tmp, path) {
        if let Earlier::Aside(aside) = &earlier {
            let _ = fs::remove_file(aside);
        }
        return Err(FileError::Io {
            path: path.to_path_buf(),
            action: "write",
            cause,
        });
    }
    Ok(earlier)
}

/// Copies `from` to `to`, a name nothing holds (never over a file); a partial copy is
/// removed.
fn copy_new(from: &Path, to: &Path) -> std::io::Result<()> {
    let mut source = File::open(from)?;
    let mut copy = File::create_new(to)?;
    std::io::copy(&mut source, &mut copy)
        .map(drop)
        .inspect_err(|_| {
            let _ = fs::remove_file(to);
        })
}

/// Puts back what [`rename_keeping_earlier`] replaced, latest first: each earlier file
/// renamed back, a file that had none removed, one not kept left new. Best effort: the
/// commit already fails; an earlier file that cannot be put back is named in a warning
/// (the next run's sweep of temporaries would remove it).
fn restore(placed: &[Placed]) {
    for p in placed.iter().rev() {
        match &p.earlier {
            Earlier::Aside(aside) => {
                if let Err(e) = fs::rename(aside, &p.path) {
                    log::warn!(
                        "could not put back the earlier {} ({e}): it is at {}",
                        p.path.display(),
                        aside.display()
                    );
                }
            }
            Earlier::Absent => {
                let _ = fs::remove_file(&p.path);
            }
            Earlier::Unkept => {}
        }
    }
}

impl Drop for FileSet {
    fn drop(&mut self) {
        for staged in self.staged.drain(..) {
            let _ = fs::remove_file(&staged.tmp); // best effort: it may not have been written
            interrupt::unregister(staged.slot);
        }
    }
}

/// Writes `tmp`'s bytes through `path`, a link or a device, by [`write_atomic`] (which
/// writes through links to files and into devices), then removes `tmp`.
fn write_through(tmp: &Path, path: &Path) -> Result<(), FileError> {
    let bytes = fs::read(tmp).map_err(|cause| FileError::Io {
        path: path.to_path_buf(),
        action: "write",
        cause,
    })?;
    write_atomic(path, &bytes)?;
    let _ = fs::remove_file(tmp); // written through; a leftover is only a stale temporary
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("shvis-set-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_set_replaces_all_its_files_or_none() {
        let dir = scratch("whole");
        let (a, b) = (dir.join("a.png"), dir.join("a_d.exr"));
        fs::write(&a, b"old a").unwrap();
        fs::write(&b, b"old b").unwrap();
        // Half written, then a failure: the earlier files stay, no temporary is left.
        {
            let mut set = FileSet::new();
            let tmp = set.stage(&a);
            assert_eq!(tmp.extension().and_then(|e| e.to_str()), Some("png"));
            write_atomic(&tmp, b"new a").unwrap();
            let _ = set.stage(&b);
        }
        assert_eq!(names(&dir), ["a.png", "a_d.exr"]);
        assert_eq!(fs::read(&a).unwrap(), b"old a");
        // Written whole: both replaced at the commit, not before.
        let mut set = FileSet::new();
        write_atomic(&set.stage(&a), b"new a").unwrap();
        write_atomic(&set.stage(&b), b"new b").unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"old a");
        set.commit().unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"new a");
        assert_eq!(fs::read(&b).unwrap(), b"new b");
        assert_eq!(names(&dir), ["a.png", "a_d.exr"]);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_commit_that_cannot_place_a_file_puts_back_the_ones_it_placed() {
        let dir = scratch("undo");
        let (a, fresh, b) = (dir.join("a.png"), dir.join("new.png"), dir.join("b.exr"));
        fs::write(&a, b"old a").unwrap();
        // A folder where the set's last file goes: written through, and refused.
        fs::create_dir(&b).unwrap();
        let mut set = FileSet::new();
        write_atomic(&set.stage(&a), b"new a").unwrap();
        write_atomic(&set.stage(&fresh), b"new").unwrap();
        write_atomic(&set.stage(&b), b"new b").unwrap();
        assert!(set.commit().is_err());
        assert_eq!(fs::read(&a).unwrap(), b"old a");
        assert!(!fresh.exists(), "a file the set added stays out");
        assert_eq!(
            names(&dir),
            ["a.png", "b.exr"],
            "no temporary or kept-aside copy left"
        );
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_set_removes_the_files_of_an_earlier_run_it_does_not_write() {
        let dir = scratch("earlier");
        let (map, side) = (dir.join("n.png"), dir.join("n_cpu.png"));
        fs::write(&map, b"old").unwrap();
        fs::write(&side, b"old side").unwrap();
        let mut set = FileSet::new();
        write_atomic(&set.stage(&map), b"new").unwrap();
        set.replaces(&map);
        set.replaces(&side);
        set.replaces(&dir.join("n_diff.png"));
        set.commit().unwrap();
        assert_eq!(names(&dir), ["n.png"]);
        assert_eq!(fs::read(&map).unwrap(), b"new");
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_set_writes_through_links_to_files() {
        let dir = scratch("links");
        let target = dir.join("target.png");
        fs::write(&target, b"old").unwrap();
        let link = dir.join("link.png");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let mut set = FileSet::new();
        write_atomic(&set.stage(&link), b"new").unwrap();
        set.commit().unwrap();
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read(&target).unwrap(), b"new");
        assert_eq!(names(&dir), ["link.png", "target.png"]);
        let _ = fs::remove_dir_all(&dir);
    }
}
