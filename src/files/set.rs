//! The files of one run written as a set ([`FileSet`]): a failure or an interrupt before
//! the last of them is written leaves every earlier file as it was, never a mix of new and
//! old ones.
//!
//! Each file goes to a temporary `.NAME.tmp-PID-N.EXT` beside it (its extension kept, for
//! the writers that pick the format by it), registered for removal on SIGINT or SIGTERM like
//! [`write_atomic`]'s; once all are written each is renamed over its name, in the order
//! staged. A temporary a killed run leaves is removed by [`remove_stale_temps`], which each
//! set runs on the folders it writes into.

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
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if !self.dirs.contains(&dir) {
            remove_stale_temps(&dir);
            self.dirs.push(dir.clone());
        }
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
        let tmp = dir.join(tmp_name);
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

    /// Puts every staged file in its place, in the order staged, then removes the
    /// [`FileSet::replaces`] files it did not stage.
    ///
    /// # Errors
    /// [`FileError::Io`] naming the file that could not be placed (the temporaries not yet
    /// placed are removed), or [`write_atomic`]'s error for a link or device in the way.
    pub fn commit(mut self) -> Result<(), FileError> {
        let written: Vec<PathBuf> = self.staged.iter().map(|s| s.path.clone()).collect();
        let mut rest = std::mem::take(&mut self.staged).into_iter();
        while let Some(staged) = rest.next() {
            if let Err(e) = place(&staged.tmp, &staged.path) {
                self.staged.push(staged);
                self.staged.extend(rest);
                return Err(e);
            }
            interrupt::unregister(staged.slot);
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

impl Drop for FileSet {
    fn drop(&mut self) {
        for staged in self.staged.drain(..) {
            let _ = fs::remove_file(&staged.tmp); // best effort: it may not have been written
            interrupt::unregister(staged.slot);
        }
    }
}

/// Renames `tmp` over `path`; where `path` is a link or a device, writes its bytes through
/// [`write_atomic`] instead, which writes through links to files and into devices.
fn place(tmp: &Path, path: &Path) -> Result<(), FileError> {
    let io = |cause| FileError::Io {
        path: path.to_path_buf(),
        action: "write",
        cause,
    };
    let plain = match fs::symlink_metadata(path) {
        Ok(m) => m.is_file(),
        Err(_) => true,
    };
    if plain {
        return fs::rename(tmp, path).map_err(io);
    }
    let bytes = fs::read(tmp).map_err(io)?;
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
