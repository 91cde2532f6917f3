//! How shvis reads and writes files: bounded reads, atomic writes, stale temporaries,
//! early write checks and the manifest that marks a bake's output directory complete.
//!
//! - **Reads** of inputs go through [`read_bounded`]: only regular files (a link to
//!   `/dev/zero` or a FIFO would be read forever), at most a stated number of bytes.
//! - **Writes** go through [`write_atomic`]: the bytes go to `.NAME.tmp-PID-N` in the same
//!   directory, are fsynced and renamed over `NAME` (then a best-effort fsync of the
//!   directory), so a killed or failed run leaves the old file or none, never a truncated
//!   one, and a full disk is an error rather than a short file. A link to a regular file
//!   is written through (the link stays); a character device, or a link to one, is written
//!   into as `cp` does (an error on `/dev/full`); a block device, FIFO or socket is refused.
//!   On SIGINT or SIGTERM the
//!   temporaries being written are removed before the process exits (130 or 143;
//!   [`remove_temporaries_on_interrupt`]); [`remove_stale_temps`] deletes those of runs that
//!   were killed outright (their process is gone).
//! - **Folders written as one run** go through [`replace_dir`]: every file is written into a
//!   temporary folder `.NAME.tmp-PID-N` beside the output folder, which then takes the
//!   output's place in one rename (an atomic exchange where an earlier output is there), so
//!   a kill at any point leaves the earlier folder whole or the new one whole, and no file
//!   of an earlier run survives beside a new one's.
//! - **Sibling files written as one run** (`--out` and the side files named after it) go
//!   through a [`FileSet`]: each is written to a temporary beside it, and all are renamed
//!   into place only once every one is written, so a failure halfway leaves the earlier
//!   files, not a mix.
//! - [`check_writable_dir`] creates a directory and a probe file in it before any work, so
//!   an unwritable `--out` or cache is reported before a bake, not after.
//! - A [`Manifest`] (`manifest.json`, written last) lists a directory's files with their
//!   sizes and [`hash64`]: a directory without one, or whose
//!   files do not match it, is incomplete ([`Manifest::verify`]).
//! - Built with the `test-hooks` feature (`make test`), [`write_atomic`] reads two test
//!   hooks from the environment that kill or interrupt the process halfway through a named
//!   file (`KILL_WHILE_WRITING_ENV`, `INTERRUPT_WHILE_WRITING_ENV`); other builds have
//!   neither.
//!
//! OpenEXR: the `exr` crate's default encoding writes tiles in whatever order its worker
//! threads finish (`LineOrder::Unspecified`), so two runs with identical pixels give
//! different files. [`EXR_ENCODING`] keeps its compression and tiling but asks for
//! increasing line order, which the writer sorts into, whatever the thread count.

pub mod clock;
pub mod hash;
pub mod ktx2;
mod set;
pub mod stdout;

pub use hash::{Hasher64, hash64, splitmix64};
pub use set::FileSet;

use std::fs::{self, File};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use exr::prelude::{Encoding, LineOrder};

/// RLE, 64×64 tiles (exr's `FAST_LOSSLESS`), in increasing line order.
pub const EXR_ENCODING: Encoding = Encoding {
    line_order: LineOrder::Increasing,
    ..Encoding::FAST_LOSSLESS
};

/// Test hook of the `test-hooks` feature, not a user setting: when a file whose name equals
/// this variable's value is being written by [`write_atomic`], the process kills itself with
/// SIGKILL after writing half of the bytes (the kill-9 test of `tests/bad_input.rs`).
#[cfg(feature = "test-hooks")]
pub const KILL_WHILE_WRITING_ENV: &str = "SHVIS_TEST_KILL_WHILE_WRITING";

/// Test hook of the `test-hooks` feature, not a user setting: as [`KILL_WHILE_WRITING_ENV`],
/// but the process sends itself SIGINT (the interrupted-write test of `tests/reliability.rs`).
#[cfg(feature = "test-hooks")]
pub const INTERRUPT_WHILE_WRITING_ENV: &str = "SHVIS_TEST_INTERRUPT_WHILE_WRITING";

/// Test hook of the `test-hooks` feature, not a user setting: when a [`FileSet`]'s commit
/// has placed the file whose name equals this variable's value, the process sends itself
/// SIGINT (the interrupted-commit test of `tests/reliability.rs`).
#[cfg(feature = "test-hooks")]
pub const INTERRUPT_WHILE_COMMITTING_ENV: &str = "SHVIS_TEST_INTERRUPT_WHILE_COMMITTING";

/// Name of a bake output directory's manifest.
pub const MANIFEST_NAME: &str = "manifest.json";

/// Errors of this module: one line naming the file.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// Opening, reading or writing failed.
    #[error("{}: cannot {action}: {cause}", .path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What was being done ("read", "write", "create the directory").
        action: &'static str,
        /// The I/O error (in the message, so not also a `source()` that `{:#}` repeats).
        cause: io::Error,
    },
    /// Not a regular file (a device, FIFO, socket or directory).
    #[error("{}: not a regular file ({kind}); give a file", .path.display())]
    NotRegular {
        /// The path.
        path: PathBuf,
        /// What it is.
        kind: &'static str,
    },
    /// A directory shvis must write into cannot be used.
    #[error("{}: {what} is not writable: {cause}", .path.display())]
    Unwritable {
        /// The directory (or the file in the way).
        path: PathBuf,
        /// The option or role (`--out`, `the bake cache (SHVIS_CACHE_DIR)`).
        what: String,
        /// Why.
        cause: io::Error,
    },
    /// An output of a run is one of its inputs.
    #[error("{}: {output} would overwrite {input} of this run; choose another name", .path.display())]
    OutputIsInput {
        /// The file.
        path: PathBuf,
        /// The option that writes it (`--out`, `--gltf`, or a side file of `--out`).
        output: String,
        /// The option it is read by.
        input: String,
    },
    /// An input of a run lies inside a folder the run writes.
    #[error("{}: the {input} lies inside {output}; move it or choose another --out", .path.display())]
    InputInOutputFolder {
        /// The input file.
        path: PathBuf,
        /// The folder's option and what the run does to it.
        output: String,
        /// The option that names the input.
        input: String,
    },
    /// Larger than the reader accepts.
    #[error("{}: {bytes} bytes is more than the {limit} bytes accepted for {what}", .path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size.
        bytes: u64,
        /// The limit.
        limit: u64,
        /// What kind of file it was read as.
        what: &'static str,
    },
}

/// A decoder's error in words a user can act on: the decoder's own text, with "(the file
/// ends early: truncated?)" where that text is how the decoder says so.
pub fn decoder_error(format: &str, error: impl std::fmt::Display) -> String {
    let text = error.to_string();
    let truncated = [
        "failed to fill whole buffer",
        "EOF while parsing",
        "reference to missing bytes",
        "unexpected end of file",
        "UnexpectedEof",
    ]
    .iter()
    .any(|p| text.contains(p));
    if truncated {
        format!("invalid {format}: {text} (the file ends early: truncated?)")
    } else {
        format!("invalid {format}: {text}")
    }
}

/// The file `path` names once symbolic links and `.`/`..` are resolved: a path that does not
/// exist yet by its folder's resolved path and its name.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = fs::canonicalize(path) {
        return p;
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match (fs::canonicalize(dir), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

/// Refuses a run whose outputs include one of its inputs — the same file once links are
/// followed (an output written through a symbolic link lands on the link's target, so a link
/// to an input is caught too). `outputs` and `inputs` pair each path with the option that
/// names it.
///
/// # Errors
/// [`FileError::OutputIsInput`] for the first output that is an input.
pub fn check_outputs_spare_inputs(
    outputs: &[(String, PathBuf)],
    inputs: &[(&str, &Path)],
) -> Result<(), FileError> {
    let inputs: Vec<(&str, PathBuf)> = inputs
        .iter()
        .filter(|(_, p)| p.exists())
        .map(|&(option, p)| (option, resolved(p)))
        .collect();
    for (output, path) in outputs {
        let target = resolved(path);
        if let Some((input, _)) = inputs.iter().find(|(_, p)| *p == target) {
            return Err(FileError::OutputIsInput {
                path: path.clone(),
                output: output.clone(),
                input: format!("the {input} input"),
            });
        }
    }
    Ok(())
}

/// Refuses a run that replaces the folder `dir` whole ([`replace_dir`]) while one of its
/// inputs lies inside it (links followed): the replacement would delete it. `inputs` pair
/// each path with the option that names it; `output` names the folder's option.
///
/// # Errors
/// [`FileError::OutputIsInput`] for the first input inside `dir`.
pub fn check_inputs_outside(
    dir: &Path,
    output: &str,
    inputs: &[(&str, &Path)],
) -> Result<(), FileError> {
    let dir = resolved(dir);
    for &(option, path) in inputs {
        if path.exists() && resolved(path).starts_with(&dir) {
            return Err(FileError::InputInOutputFolder {
                path: path.to_path_buf(),
                output: output.to_string(),
                input: format!("{option} input"),
            });
        }
    }
    Ok(())
}

/// The bytes of the regular file at `path` (links followed), if it holds at most `limit`
/// bytes; `what` names the kind of input in the error.
///
/// # Errors
/// [`FileError::NotRegular`] for devices, FIFOs, sockets and directories,
/// [`FileError::TooLarge`], [`FileError::Io`].
pub fn read_bounded(path: &Path, limit: u64, what: &'static str) -> Result<Vec<u8>, FileError> {
    let io_err = |source| FileError::Io {
        path: path.to_path_buf(),
        action: "read",
        cause: source,
    };
    let meta = fs::metadata(path).map_err(io_err)?;
    check_regular(path, &meta)?;
    if meta.len() > limit {
        return Err(FileError::TooLarge {
            path: path.to_path_buf(),
            bytes: meta.len(),
            limit,
            what,
        });
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // `take` guards against a file that grows while it is read.
    File::open(path)
        .and_then(|f| f.take(limit.saturating_add(1)).read_to_end(&mut bytes))
        .map_err(io_err)?;
    if bytes.len() as u64 > limit {
        return Err(FileError::TooLarge {
            path: path.to_path_buf(),
            bytes: bytes.len() as u64,
            limit,
            what,
        });
    }
    Ok(bytes)
}

fn check_regular(path: &Path, meta: &fs::Metadata) -> Result<(), FileError> {
    if meta.is_file() {
        return Ok(());
    }
    let kind = if meta.is_dir() {
        "a directory"
    } else {
        special_kind(meta)
    };
    Err(FileError::NotRegular {
        path: path.to_path_buf(),
        kind,
    })
}

#[cfg(unix)]
fn special_kind(meta: &fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_char_device() || t.is_block_device() {
        "a device"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &fs::Metadata) -> &'static str {
    "not a file"
}

/// Writes `bytes` to `path` atomically (module doc): temporary file in the same directory,
/// fsync, rename, best-effort fsync of the directory. The directory must exist. Through a
/// symbolic link to a regular file, that file is written and the link kept; a device,
/// FIFO or socket at `path` is refused.
///
/// # Errors
/// [`FileError::Io`] naming `path` when any step fails (the temporary file is removed).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    use std::os::unix::fs::FileTypeExt;
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    // A symbolic link to a regular file is written through: that file is replaced and the
    // link stays. A character device, or a link to one, is written into as `cp` does (an
    // error on /dev/full). A link to anything else (a dangling name) is replaced itself.
    let through_link = fs::symlink_metadata(path)
        .is_ok_and(|m| m.file_type().is_symlink())
        .then(|| fs::canonicalize(path).ok())
        .flatten()
        .filter(|target| {
            fs::metadata(target).is_ok_and(|m| m.is_file() || m.file_type().is_char_device())
        });
    let path = through_link.as_deref().unwrap_or(path);
    if fs::metadata(path).is_ok_and(|m| m.file_type().is_char_device()) {
        return write_into_device(path, bytes);
    }
    // Never rename over a block device, FIFO or socket.
    if let Ok(m) = fs::symlink_metadata(path) {
        let t = m.file_type();
        if !(t.is_file() || t.is_symlink() || t.is_dir()) {
            return Err(FileError::NotRegular {
                path: path.to_path_buf(),
                kind: special_kind(&m),
            });
        }
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".to_string());
    let tmp = dir.join(format!(
        ".{name}.tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let slot = interrupt::register(&tmp);
    let result = (|| {
        let mut file = fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        #[cfg(feature = "test-hooks")]
        interrupt_while_writing(&mut file, &name, bytes)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        fs::rename(&tmp, path)
    })();
    interrupt::unregister(slot);
    if let Err(source) = result {
        let _ = fs::remove_file(&tmp); // best effort: the error below is what matters
        return Err(FileError::Io {
            path: path.to_path_buf(),
            action: "write",
            cause: source,
        });
    }
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all(); // not supported everywhere; the rename is already done
    }
    Ok(())
}

/// Writes `bytes` into the character device `path` (`/dev/null`, `/dev/full`, a terminal)
/// as `cp` does: no temporary, no rename, the device's error (ENOSPC) returned.
fn write_into_device(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    let io = |cause| FileError::Io {
        path: path.to_path_buf(),
        action: "write",
        cause,
    };
    let mut device = fs::OpenOptions::new().write(true).open(path).map_err(io)?;
    device
        .write_all(bytes)
        .and_then(|()| device.flush())
        .map_err(io)
}

/// Whether [`replace_dir`] may take `dir`'s place, checked before a run's work. Returns
/// the folder it would replace (links and `.`/`..` resolved) and whether it exists: it
/// must be empty or `replaceable` (an earlier run's), and neither the current folder nor
/// one holding it, nor a mount point (a folder that cannot be renamed); its parent must
/// take files (created where missing).
///
/// # Errors
/// [`FileError::Unwritable`] naming `dir` for any of these.
pub fn check_replaceable_dir(
    dir: &Path,
    what: &str,
    replaceable: impl Fn(&Path) -> bool,
) -> Result<(PathBuf, bool), FileError> {
    let unwritable = |cause: io::Error| FileError::Unwritable {
        path: dir.to_path_buf(),
        what: what.to_string(),
        cause,
    };
    let refuse = |why: &str| unwritable(io::Error::other(why.to_string()));
    if dir.as_os_str().is_empty() {
        return Err(refuse("the name is empty"));
    }
    let target = resolved(dir);
    let parent = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let exists = match fs::metadata(&target) {
        Ok(m) if m.is_dir() => {
            if std::env::current_dir().is_ok_and(|cwd| cwd.starts_with(&target)) {
                return Err(refuse(
                    "it is the current folder or holds it, which cannot be replaced; name a folder inside it",
                ));
            }
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                if fs::metadata(&parent).is_ok_and(|p| p.dev() != m.dev()) {
                    return Err(refuse(
                        "it is a mount point, which cannot be replaced; name a folder inside it",
                    ));
                }
            }
            let empty = fs::read_dir(&target).is_ok_and(|mut entries| entries.next().is_none());
            if !empty && !replaceable(&target) {
                return Err(refuse(
                    "it holds files that are not an earlier run's; choose a new or empty folder",
                ));
            }
            true
        }
        Ok(_) if target != dir => {
            return Err(refuse(&format!(
                "it leads to {}, which is not a directory",
                target.display()
            )));
        }
        Ok(_) => return Err(refuse("it exists and is not a directory")),
        Err(_) => false,
    };
    check_writable_dir(&parent, what).map_err(|e| match e {
        FileError::Unwritable { cause, .. } => unwritable(io::Error::new(
            cause.kind(),
            format!(
                "its folder {} does not take files: {cause}",
                parent.display()
            ),
        )),
        e => e,
    })?;
    Ok((target, exists))
}

/// Writes the output folder `dir` as one run ([`write_atomic`]'s guarantee for a folder): a
/// temporary folder `.NAME.tmp-PID-N` beside `dir` is created, `fill` writes every file
/// into it, and it takes `dir`'s place in one step — `rename` where `dir` does not exist,
/// an atomic exchange (`renameat2(RENAME_EXCHANGE)`) where it does, after which the
/// earlier folder is removed. A kill at any point leaves the earlier folder whole or the
/// new one whole; the temporary a killed run leaves is removed by the next run in the
/// same parent ([`remove_stale_temps`]). An existing `dir` is replaced only when it is
/// empty or `replaceable(dir)` (an earlier run's folder): anything else is refused. Through
/// a symbolic link to a folder, the link's target is replaced and the link kept. `what`
/// names the option in errors.
///
/// # Errors
/// [`FileError::Unwritable`] for a `dir` that is not a folder or holds other files;
/// `fill`'s error (the temporary folder removed); [`FileError::Io`] for a step that fails.
pub fn replace_dir(
    dir: &Path,
    what: &str,
    replaceable: impl Fn(&Path) -> bool,
    fill: impl FnOnce(&Path) -> Result<(), FileError>,
) -> Result<(), FileError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let io_error = |path: &Path, action: &'static str| {
        let path = path.to_path_buf();
        move |cause| FileError::Io {
            path,
            action,
            cause,
        }
    };
    let (target, exists) = check_replaceable_dir(dir, what, &replaceable)?;
    let dir = target.as_path();
    let parent = match dir.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    fs::create_dir_all(parent).map_err(io_error(parent, "create the directory"))?;
    remove_stale_temps(parent);
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".to_string());
    let tmp = parent.join(format!(
        ".{name}.tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    fs::create_dir(&tmp).map_err(io_error(&tmp, "create the directory"))?;
    let filled = fill(&tmp).and_then(|()| {
        File::open(&tmp)
            .and_then(|d| d.sync_all())
            .map_err(io_error(&tmp, "write"))
    });
    if let Err(e) = filled {
        let _ = fs::remove_dir_all(&tmp); // best effort: the error below is what matters
        return Err(e);
    }
    let placed = if exists {
        exchange(&tmp, dir).or_else(|e| match e.raw_os_error() {
            // A file system without the exchange: the earlier folder steps aside first.
            Some(libc::EINVAL | libc::ENOSYS | libc::ENOTSUP) => {
                let aside = parent.join(format!(
                    ".{name}.tmp-{}-{}",
                    std::process::id(),
                    COUNTER.fetch_add(1, Ordering::Relaxed)
                ));
                fs::rename(dir, &aside)?;
                fs::rename(&tmp, dir)?;
                fs::rename(&aside, &tmp)
            }
            _ => Err(e),
        })
    } else {
        fs::rename(&tmp, dir)
    };
    if let Err(cause) = placed {
        let _ = fs::remove_dir_all(&tmp);
        return Err(FileError::Io {
            path: dir.to_path_buf(),
            action: "replace",
            cause,
        });
    }
    if exists {
        // The temporary's name now holds the earlier folder.
        let _ = fs::remove_dir_all(&tmp);
    }
    if let Ok(d) = File::open(parent) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Swaps the names `a` and `b` in one step (Linux `renameat2` with `RENAME_EXCHANGE`).
#[allow(unsafe_code)]
fn exchange(a: &Path, b: &Path) -> io::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let c = |p: &Path| {
        std::ffi::CString::new(p.as_os_str().as_bytes())
            .map_err(|_| io::Error::other("NUL in path"))
    };
    let (a, b) = (c(a)?, c(b)?);
    // SAFETY: both pointers are NUL-terminated strings that outlive the call; renameat2
    // reads them and touches no other memory of ours.
    let r = unsafe {
        libc::renameat2(
            libc::AT_FDCWD,
            a.as_ptr(),
            libc::AT_FDCWD,
            b.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// [`write_atomic`] with the plain I/O error (for callers that name the file themselves):
/// the drop-in replacement of `std::fs::write` in shvis.
///
/// # Errors
/// The I/O error of the step that failed.
pub fn write(path: impl AsRef<Path>, bytes: impl AsRef<[u8]>) -> io::Result<()> {
    write_atomic(path.as_ref(), bytes.as_ref()).map_err(|e| match e {
        FileError::Io { cause, .. } => cause,
        e => io::Error::other(e.to_string()),
    })
}

/// Removes the temporaries [`write_atomic`] is writing when SIGINT or SIGTERM arrives, then
/// exits with 128 + the signal (what the default action would report). Call once, early.
pub fn remove_temporaries_on_interrupt() {
    interrupt::install();
}

/// The temporaries being written, in a fixed table of slots that a signal handler can read
/// without locks: a slot holds a leaked C string, taken by whichever of the writer (after
/// its rename) and the handler swaps it out first — the writer frees it, the handler only
/// unlinks it and exits, so neither ever uses a freed pointer.
#[allow(unsafe_code)]
mod interrupt {
    use std::ffi::{CString, c_char};
    use std::path::Path;
    use std::sync::atomic::{AtomicI32, AtomicPtr, AtomicUsize, Ordering};

    const SLOTS: usize = 64;
    static WRITING: [AtomicPtr<c_char>; SLOTS] =
        [const { AtomicPtr::new(std::ptr::null_mut()) }; SLOTS];
    /// How many [`Hold`]s are alive, with [`EXITING`] set once a thread has begun to act
    /// on a signal (remove the temporaries, exit): one word, so that a hold taken and a
    /// signal acted on are ordered whichever threads they happen on.
    static STATE: AtomicUsize = AtomicUsize::new(0);
    const EXITING: usize = 1 << (usize::BITS - 1);
    /// The signal that arrived, 0 for none.
    static PENDING: AtomicI32 = AtomicI32::new(0);

    /// While alive, SIGINT and SIGTERM wait: the handler (on whichever thread) notes the
    /// signal and returns, and the last hold to go acts on it (removes the temporaries,
    /// exits). A set's commit holds one, so an interrupt cannot land between two of its
    /// renames. A second signal while one waits acts at once (a commit writing through a
    /// device can block; a second Ctrl-C ends it).
    pub(super) struct Hold(());

    pub(super) fn hold() -> Hold {
        loop {
            let state = STATE.load(Ordering::SeqCst);
            if state & EXITING != 0 {
                // Another thread is removing the temporaries and ends the process.
                loop {
                    std::thread::park();
                }
            }
            if STATE
                .compare_exchange(state, state + 1, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
            {
                return Hold(());
            }
        }
    }

    impl Drop for Hold {
        fn drop(&mut self) {
            // The handler stores PENDING before it reads STATE: if it saw this hold, this
            // load sees its signal.
            if STATE.fetch_sub(1, Ordering::SeqCst) == 1 {
                let signal = PENDING.load(Ordering::SeqCst);
                if signal != 0
                    && STATE
                        .compare_exchange(0, EXITING, Ordering::SeqCst, Ordering::SeqCst)
                        .is_ok()
                {
                    exit_removing_temporaries(signal);
                }
            }
        }
    }

    /// Records `tmp`; `None` when every slot is taken (then it is left to
    /// `remove_stale_temps` of the next run).
    pub(super) fn register(tmp: &Path) -> Option<usize> {
        use std::os::unix::ffi::OsStrExt;
        let c = CString::new(tmp.as_os_str().as_bytes()).ok()?.into_raw();
        for (i, slot) in WRITING.iter().enumerate() {
            if slot
                .compare_exchange(std::ptr::null_mut(), c, Ordering::AcqRel, Ordering::Relaxed)
                .is_ok()
            {
                return Some(i);
            }
        }
        // SAFETY: `c` came from `into_raw` just above and was stored nowhere.
        drop(unsafe { CString::from_raw(c) });
        None
    }

    pub(super) fn unregister(slot: Option<usize>) {
        if let Some(i) = slot {
            let c = WRITING[i].swap(std::ptr::null_mut(), Ordering::AcqRel);
            if !c.is_null() {
                // SAFETY: the pointer came from `into_raw` in `register`, and the swap took it
                // out of the table: the handler can no longer see it.
                drop(unsafe { CString::from_raw(c) });
            }
        }
    }

    extern "C" fn on_signal(signal: libc::c_int) {
        let earlier = PENDING.swap(signal, Ordering::SeqCst);
        loop {
            let state = STATE.load(Ordering::SeqCst);
            if state & EXITING != 0 {
                return; // another thread acts on it
            }
            // Holds alive: the last to go acts on the signal, unless it is the second.
            if state != 0 && earlier == 0 {
                return;
            }
            if STATE
                .compare_exchange(state, state | EXITING, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
            {
                exit_removing_temporaries(signal);
            }
        }
    }

    /// Unlinks every registered temporary and exits with 128 + `signal`; only
    /// async-signal-safe calls.
    fn exit_removing_temporaries(signal: libc::c_int) -> ! {
        for slot in &WRITING {
            let c = slot.swap(std::ptr::null_mut(), Ordering::AcqRel);
            if !c.is_null() {
                // SAFETY: a valid C string from `register`; unlink is async-signal-safe.
                unsafe {
                    libc::unlink(c);
                }
            }
        }
        // SAFETY: _exit is async-signal-safe and ends the process without unwinding.
        unsafe { libc::_exit(128 + signal) }
    }

    pub(super) fn install() {
        for signal in [libc::SIGINT, libc::SIGTERM] {
            // SAFETY: installs a handler that only touches atomics and async-signal-safe calls.
            unsafe {
                libc::signal(
                    signal,
                    on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t,
                );
            }
        }
    }

    /// SIGINT to this thread, for the interrupted-write hook (feature `test-hooks`).
    #[cfg(feature = "test-hooks")]
    pub(super) fn raise_sigint() {
        // SAFETY: raise(3) on this thread; the handler runs and exits the process.
        unsafe {
            libc::raise(libc::SIGINT);
        }
    }
}

/// The test hooks of [`write_atomic`] (feature `test-hooks`): with `name` in
/// [`KILL_WHILE_WRITING_ENV`], writes half of `bytes` to `file`, syncs it and kills the
/// process; with `name` in [`INTERRUPT_WHILE_WRITING_ENV`], writes half of `bytes` and
/// raises SIGINT (the handler of [`remove_temporaries_on_interrupt`] then exits). Otherwise
/// does nothing. A [`FileSet`]'s temporary counts as the file it stands for.
#[cfg(feature = "test-hooks")]
fn interrupt_while_writing(file: &mut File, name: &str, bytes: &[u8]) -> io::Result<()> {
    let names = |var: &str| {
        std::env::var_os(var).is_some_and(|v| {
            let v = v.to_string_lossy();
            v == name || name.starts_with(&format!(".{v}.tmp-"))
        })
    };
    if names(KILL_WHILE_WRITING_ENV) {
        file.write_all(&bytes[..bytes.len() / 2])?;
        file.sync_all()?;
        kill_self();
    }
    if names(INTERRUPT_WHILE_WRITING_ENV) {
        file.write_all(&bytes[..bytes.len() / 2])?;
        interrupt::raise_sigint();
    }
    Ok(())
}

/// SIGKILL to this process ([`KILL_WHILE_WRITING_ENV`]): no destructors, no flushing.
#[cfg(feature = "test-hooks")]
#[allow(unsafe_code)]
fn kill_self() -> ! {
    #[cfg(target_os = "linux")]
    // SAFETY: kill(2) on our own PID with a valid signal number has no memory effects.
    unsafe {
        libc::kill(libc::getpid(), libc::SIGKILL);
    }
    std::process::abort();
}

/// Removes temporaries `.NAME.tmp-PID-N` (files, [`FileSet`]'s with their extension after
/// N, or [`replace_dir`]'s folders) in `dir` left
/// by processes that no longer run
/// (on systems without `/proc`, those older than a day); returns how many were removed.
/// Best effort: unreadable directories and entries are skipped.
pub fn remove_stale_temps(dir: &Path) -> usize {
    let Ok(entries) = fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = temp_owner(&name) else {
            continue;
        };
        if pid == std::process::id() || process_alive(pid, &entry) {
            continue;
        }
        let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
        let gone = if is_dir {
            fs::remove_dir_all(entry.path())
        } else {
            fs::remove_file(entry.path())
        };
        if gone.is_ok() {
            log::info!("removed {} (left by a killed run)", entry.path().display());
            removed += 1;
        }
    }
    removed
}

/// The PID in a temporary's name `.NAME.tmp-PID-N` (or a [`FileSet`]'s `.NAME.tmp-PID-N.EXT`),
/// `None` for other names.
fn temp_owner(name: &str) -> Option<u32> {
    if !name.starts_with('.') {
        return None;
    }
    let (head, tail) = name.rsplit_once(".tmp-")?;
    let (pid, n) = tail.split_once('-')?;
    // A set's temporary keeps its file's extension: `.NAME.tmp-PID-N.EXT` with NAME ending
    // in `.EXT`.
    let n = match n.split_once('.') {
        Some((n, ext)) if head.ends_with(&format!(".{ext}")) => n,
        Some(_) => return None,
        None => n,
    };
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

fn process_alive(pid: u32, entry: &fs::DirEntry) -> bool {
    if Path::new("/proc/self").exists() {
        return Path::new(&format!("/proc/{pid}")).exists();
    }
    let day = std::time::Duration::from_secs(24 * 3600);
    entry
        .metadata()
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_none_or(|age| age < day)
}

/// Creates `dir` (and its parents) and checks that a file can be created in it; `what`
/// names the option in the error (`--out`, `the bake cache`).
///
/// # Errors
/// One line naming `dir`, `what` and the cause.
pub fn check_writable_dir(dir: &Path, what: &str) -> Result<(), FileError> {
    let unwritable = |cause| FileError::Unwritable {
        path: dir.to_path_buf(),
        what: what.to_string(),
        cause,
    };
    if let Ok(meta) = fs::metadata(dir)
        && !meta.is_dir()
    {
        return Err(unwritable(io::Error::other(
            "it exists and is not a directory",
        )));
    }
    fs::create_dir_all(dir).map_err(unwritable)?;
    let probe = dir.join(format!(".shvis-write-check-{}", std::process::id()));
    let written = File::create(&probe).and_then(|mut f| f.write_all(b"shvis"));
    // Removed whether the write worked or not (a full disk creates the file, then fails).
    let _ = fs::remove_file(&probe);
    written.map_err(unwritable)
}

/// [`check_writable_dir`] for the directory an output file goes into.
///
/// # Errors
/// As [`check_writable_dir`].
pub fn check_writable_file(path: &Path, what: &str) -> Result<(), FileError> {
    if let Ok(meta) = fs::metadata(path)
        && meta.is_dir()
    {
        return Err(FileError::Unwritable {
            path: path.to_path_buf(),
            what: what.to_string(),
            cause: io::Error::other("it is a directory"),
        });
    }
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => check_writable_dir(d, what),
        _ => check_writable_dir(Path::new("."), what),
    }
}

/// One file of a [`Manifest`].
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ManifestEntry {
    /// File name in the directory.
    pub name: String,
    /// Size in bytes.
    pub bytes: u64,
    /// `hash64` of the content, 16 hex digits.
    pub hash: String,
}

/// What a complete output directory holds: the settings that made it and its files.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Manifest {
    /// The shvis version that wrote it.
    pub shvis: String,
    /// The settings, as the writer describes them.
    pub settings: serde_json::Value,
    /// The files, in writing order.
    pub files: Vec<ManifestEntry>,
}

impl Manifest {
    /// A manifest of `settings` and the given files' `(name, content)`.
    pub fn new<'a>(
        settings: serde_json::Value,
        files: impl IntoIterator<Item = (String, &'a [u8])>,
    ) -> Manifest {
        Manifest {
            shvis: env!("CARGO_PKG_VERSION").to_string(),
            settings,
            files: files
                .into_iter()
                .map(|(name, bytes)| ManifestEntry {
                    name,
                    bytes: bytes.len() as u64,
                    hash: format!("{:016x}", hash64(bytes)),
                })
                .collect(),
        }
    }

    /// Writes it as `dir/manifest.json` (atomically; write it after the files).
    ///
    /// # Errors
    /// As [`write_atomic`].
    pub fn write(&self, dir: &Path) -> Result<(), FileError> {
        let text = serde_json::to_string_pretty(self).expect("a manifest serializes");
        write_atomic(&dir.join(MANIFEST_NAME), (text + "\n").as_bytes())
    }

    /// The manifest of `dir` when it is there and every file it lists has its size and
    /// hash; `Err` says, in one line, why the directory is incomplete.
    pub fn verify(dir: &Path) -> Result<Manifest, String> {
        let path = dir.join(MANIFEST_NAME);
        let bytes = read_bounded(&path, 1 << 20, "a manifest").map_err(|e| match e {
            FileError::Io { cause, .. } if cause.kind() == io::ErrorKind::NotFound => format!(
                "{}: no {MANIFEST_NAME}: not a complete output folder (incomplete, or not one of shvis's)",
                dir.display()
            ),
            e => e.to_string(),
        })?;
        let manifest: Manifest = serde_json::from_slice(&bytes)
            .map_err(|e| format!("{}: unreadable ({e})", path.display()))?;
        for f in &manifest.files {
            let plain = Path::new(&f.name)
                .components()
                .map(|c| matches!(c, std::path::Component::Normal(_)))
                .eq([true]);
            if !plain || f.name == MANIFEST_NAME {
                return Err(format!(
                    "{}: lists '{}', which is not a file of the folder",
                    path.display(),
                    f.name
                ));
            }
            let file = dir.join(&f.name);
            let content = read_bounded(&file, f.bytes, "a listed file")
                .map_err(|e| format!("{}: does not match {MANIFEST_NAME} ({e})", file.display()))?;
            let hash = format!("{:016x}", hash64(&content));
            if content.len() as u64 != f.bytes || hash != f.hash {
                return Err(format!(
                    "{}: does not match {MANIFEST_NAME} ({} bytes, hash {hash}; listed {} bytes, hash {})",
                    file.display(),
                    content.len(),
                    f.bytes,
                    f.hash
                ));
            }
        }
        Ok(manifest)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("shvis-files-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn temp_names_parse_back_to_their_pid() {
        assert_eq!(temp_owner(".visibility-ab.bin.tmp-1234-7"), Some(1234));
        assert_eq!(temp_owner(".x.png.tmp-1-0"), Some(1));
        assert_eq!(temp_owner(".x.png.tmp-1-0.png"), Some(1));
        assert_eq!(temp_owner(".x.png.tmp-1-a.png"), None);
        // A user's file of that shape whose name does not end in the extension.
        assert_eq!(temp_owner(".notes.tmp-2024-01.md"), None);
        assert_eq!(temp_owner("x.png.tmp-1-0"), None);
        assert_eq!(temp_owner(".x.tmp-a-0"), None);
        assert_eq!(temp_owner(".x.png"), None);
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = scratch("atomic");
        let path = dir.join("a.txt");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two!").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"two!");
        let names: Vec<_> = fs::read_dir(&dir).unwrap().flatten().collect();
        assert_eq!(names.len(), 1, "{names:?}");
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn stale_temps_of_dead_processes_are_removed_live_ones_kept() {
        let dir = scratch("stale");
        // PID 0x7fff_fff0 is above any Linux pid_max.
        let dead = dir.join(".a.bin.tmp-2147483632-0");
        let live = dir.join(format!(".b.bin.tmp-{}-0", std::process::id()));
        let other = dir.join("c.bin");
        for p in [&dead, &live, &other] {
            fs::write(p, b"x").unwrap();
        }
        assert_eq!(remove_stale_temps(&dir), 1);
        assert!(!dead.exists() && live.exists() && other.exists());
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn writes_go_through_links_to_files_and_never_over_special_files() {
        let dir = scratch("links");
        let target = dir.join("target.txt");
        fs::write(&target, b"old").unwrap();
        let link = dir.join("link.txt");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read(&target).unwrap(), b"new");
        // A FIFO: refused directly; a link to it is replaced, the FIFO left alone.
        let fifo = dir.join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let e = write_atomic(&fifo, b"x").unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{e}");
            let to_fifo = dir.join("to-fifo");
            std::os::unix::fs::symlink(&fifo, &to_fifo).unwrap();
            write_atomic(&to_fifo, b"x").unwrap();
            assert_eq!(fs::read(&to_fifo).unwrap(), b"x");
            use std::os::unix::fs::FileTypeExt;
            assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        }
        // A character device, or a link to one, is written into as `cp` does: the link
        // stays, /dev/full is an error, /dev/null takes the bytes.
        let to_full = dir.join("to-full");
        std::os::unix::fs::symlink("/dev/full", &to_full).unwrap();
        let e = write_atomic(&to_full, b"x").unwrap_err();
        assert!(e.to_string().contains("No space left on device"), "{e}");
        let to_null = dir.join("to-null");
        std::os::unix::fs::symlink("/dev/null", &to_null).unwrap();
        write_atomic(&to_null, b"x").unwrap();
        write_atomic(Path::new("/dev/null"), b"x").unwrap();
        for link in [&to_full, &to_null] {
            assert!(
                fs::symlink_metadata(link).unwrap().file_type().is_symlink(),
                "{link:?}"
            );
        }
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn bounded_read_refuses_devices_and_oversized_files() {
        let dir = scratch("bounded");
        let f = dir.join("f");
        fs::write(&f, [0u8; 100]).unwrap();
        assert_eq!(read_bounded(&f, 100, "x").unwrap().len(), 100);
        let e = read_bounded(&f, 99, "an environment map").unwrap_err();
        assert!(e.to_string().contains("more than the 99 bytes"), "{e}");
        let e = read_bounded(Path::new("/dev/zero"), 1 << 30, "x").unwrap_err();
        assert!(
            e.to_string().contains("not a regular file (a device)"),
            "{e}"
        );
        let e = read_bounded(&dir, 1 << 30, "x").unwrap_err();
        assert!(e.to_string().contains("a directory"), "{e}");
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn manifest_detects_a_changed_or_missing_file() {
        let dir = scratch("manifest");
        assert!(Manifest::verify(&dir).unwrap_err().contains("incomplete"));
        let (a, b) = (b"alpha".as_slice(), b"beta".as_slice());
        write_atomic(&dir.join("a"), a).unwrap();
        write_atomic(&dir.join("b"), b).unwrap();
        let m = Manifest::new(
            serde_json::json!({"res": 16}),
            [("a".to_string(), a), ("b".to_string(), b)],
        );
        m.write(&dir).unwrap();
        assert_eq!(Manifest::verify(&dir).unwrap(), m);
        fs::write(dir.join("b"), b"bets").unwrap();
        assert!(
            Manifest::verify(&dir)
                .unwrap_err()
                .contains("does not match")
        );
        fs::remove_file(dir.join("b")).unwrap();
        assert!(
            Manifest::verify(&dir)
                .unwrap_err()
                .contains("does not match")
        );
        fs::remove_file(dir.join(MANIFEST_NAME)).unwrap();
        assert!(Manifest::verify(&dir).unwrap_err().contains("incomplete"));
        let _ = fs::remove_dir_all(&dir);
    }
}
