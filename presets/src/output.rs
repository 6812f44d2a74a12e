//! Writing files without ever losing the old one.
//!
//! Every file Struck writes (rendered WAVs, materials, banks, estimator reports) goes to a
//! temporary file in the destination's folder and is renamed over the destination only once it
//! is complete ([`AtomicFile`]). A failed or interrupted write leaves an existing file as it
//! was: it is never truncated first. [`check_output`] makes the checks that can fail (missing
//! or read-only folder, destination that is a folder, read-only file, output that is one of the
//! inputs) before long work starts.
//!
//! A destination that is a link is followed: the file it points to is replaced and the link
//! stays. A destination that is not a regular file (`/dev/null`, a named pipe, a terminal) or
//! that names an open file descriptor (`/dev/stdout`, `/dev/fd/3`) is never replaced: the
//! output is completed in a temporary file in the system's temporary folder and then copied
//! into it, so writing to a device or a pipe works as a shell redirection does and a device's
//! failure (`/dev/full`) is an error.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

/// Why an output file cannot be written. Every message starts with "cannot write PATH" and
/// says what to do.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The destination's folder does not exist.
    #[error("cannot write {}: the folder {} does not exist; create it first", path.display(), folder.display())]
    NoFolder {
        /// The destination.
        path: PathBuf,
        /// Its folder.
        folder: PathBuf,
    },
    /// A temporary file cannot be created in the destination's folder.
    #[error("cannot write {}: cannot create a file in {} ({source}); choose a writable folder", path.display(), folder.display())]
    FolderNotWritable {
        /// The destination.
        path: PathBuf,
        /// Its folder.
        folder: PathBuf,
        /// What the system said.
        #[source]
        source: io::Error,
    },
    /// The destination is a folder.
    #[error("cannot write {}: it is a folder; give a file name", path.display())]
    IsAFolder {
        /// The destination.
        path: PathBuf,
    },
    /// The destination exists and is read-only.
    #[error("cannot write {}: the existing file is read-only; make it writable or choose another name", path.display())]
    ReadOnly {
        /// The destination.
        path: PathBuf,
    },
    /// The destination is one of the command's inputs.
    #[error("cannot write {}: it is also an input ({}); choose another output file", path.display(), input.display())]
    SameAsInput {
        /// The destination.
        path: PathBuf,
        /// The input it names.
        input: PathBuf,
    },
    /// The same file is given for two outputs.
    #[error("cannot write {}: it is given for two outputs; give each output its own file", path.display())]
    Twice {
        /// The file.
        path: PathBuf,
    },
    /// The destination is an existing file of another kind than the output (a recording
    /// where a material goes): a mistyped `--out` would destroy it.
    #[error("cannot write {}: it is {found}, and this output is {kind}; Struck does not replace a file of another kind: choose another name (or delete it first)", path.display())]
    OtherKind {
        /// The destination.
        path: PathBuf,
        /// What the existing file is ("a WAV recording", "a MIDI file", …).
        found: &'static str,
        /// What the output is ("JSON", "a WAV file").
        kind: &'static str,
    },
    /// Writing, syncing or renaming failed.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The destination.
        path: PathBuf,
        /// What the system said.
        #[source]
        source: io::Error,
    },
}

/// The folder `path` is in (`.` for a bare file name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Whether `a` and `b` name the same existing file (after following links; hard links
/// included on Unix). `false` if either does not exist.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (fs::metadata(a), fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!((fs::canonicalize(a), fs::canonicalize(b)), (Ok(x), Ok(y)) if x == y)
    }
}

/// What an output file holds, for [`check_kind`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A JSON document (a material, a bank, a report).
    Json,
    /// A WAV file (a render, a residual).
    Wav,
}

/// Whether the first bytes `head` of a file are a WAV header.
fn is_wav(head: &[u8]) -> bool {
    head.len() >= 12 && matches!(&head[..4], b"RIFF" | b"RIFX" | b"RF64" | b"BW64") && &head[8..12] == b"WAVE"
}

/// The binary kinds a preset path is mistaken for, by a file's first bytes: "a WAV
/// recording", "a MIDI file", else `None`.
pub(crate) fn binary_kind(head: &[u8]) -> Option<&'static str> {
    if is_wav(head) {
        Some("a WAV recording")
    } else if head.starts_with(b"MThd") {
        Some("a MIDI file")
    } else {
        None
    }
}

/// What the first bytes of an existing file say it is: `None` for the kind `kind` itself (or
/// an empty file), else how to name it.
fn other_kind(head: &[u8], kind: Kind) -> Option<&'static str> {
    let wav = is_wav(head);
    let text = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    let json = text.iter().find(|b| !b.is_ascii_whitespace()).is_some_and(|&b| b == b'{' || b == b'[');
    let blank = text.iter().all(u8::is_ascii_whitespace);
    match kind {
        _ if blank => None,
        Kind::Json if json => None,
        Kind::Wav if wav => None,
        _ if wav => Some("a WAV recording"),
        _ if json => Some("a JSON file"),
        _ if head.starts_with(b"MThd") => Some("a MIDI file"),
        Kind::Json => Some("not a JSON file"),
        Kind::Wav => Some("not a WAV file"),
    }
}

/// Checks that `path`, if it is an existing regular file, holds what the output is (its
/// first bytes: a WAV header for a WAV output, `{` or `[` for JSON; an empty file is
/// anything): `struck estimate --out take1.wav take2.wav` would otherwise replace the
/// recording `take1.wav` with a material. Devices, pipes and descriptors are not looked
/// at (nothing there is replaced), nor a file that cannot be read (writing it will say why).
///
/// # Errors
/// [`OutputError::OtherKind`].
pub fn check_kind(path: &Path, kind: Kind) -> Result<(), OutputError> {
    use std::io::Read;
    let (target, stream) = resolve_target(path);
    if stream || !fs::metadata(&target).is_ok_and(|m| m.is_file()) {
        return Ok(());
    }
    let mut head = Vec::with_capacity(64);
    let Ok(file) = File::open(&target) else { return Ok(()) };
    if file.take(64).read_to_end(&mut head).is_err() {
        return Ok(());
    }
    match other_kind(&head, kind) {
        Some(found) => Err(OutputError::OtherKind {
            path: path.to_path_buf(),
            found,
            kind: match kind {
                Kind::Json => "JSON",
                Kind::Wav => "a WAV file",
            },
        }),
        None => Ok(()),
    }
}

/// Checks, before long work, that `path` can be written and is none of `inputs`: its folder
/// exists and accepts a new file (one is created and removed), it is not a folder, not a
/// read-only file, not the same file as an input, and not an existing file of another kind
/// than `kind` ([`check_kind`]).
///
/// # Errors
/// The first problem found, as an [`OutputError`].
pub fn check_output(path: &Path, inputs: &[&Path], kind: Kind) -> Result<(), OutputError> {
    check_not_input(path, inputs)?;
    check_kind(path, kind)?;
    // Creating (and dropping) the temporary file proves the folder is writable.
    AtomicFile::create(path).map(drop)
}

/// Checks that `path` is none of `inputs` (the same file through any spelling or link).
///
/// # Errors
/// [`OutputError::SameAsInput`] naming the input.
pub fn check_not_input(path: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    match inputs.iter().find(|input| same_file(path, input)) {
        Some(input) => Err(OutputError::SameAsInput { path: path.to_path_buf(), input: input.to_path_buf() }),
        None => Ok(()),
    }
}

/// Checks that `outputs` are distinct files: `--out x --report x` would keep only one. The
/// null device may be given for several (each output is discarded, as asked).
///
/// # Errors
/// [`OutputError::Twice`] naming the repeated path.
pub fn check_distinct(outputs: &[&Path]) -> Result<(), OutputError> {
    for (i, a) in outputs.iter().enumerate() {
        for b in &outputs[i + 1..] {
            let same = a == b || same_file(a, b) || matches!((absolute(a), absolute(b)), (Some(x), Some(y)) if x == y);
            // The null device discards what each output writes: nothing is lost.
            if same && !is_null_device(a) {
                return Err(OutputError::Twice { path: b.to_path_buf() });
            }
        }
    }
    Ok(())
}

/// Whether `path` is the system's null device (`/dev/null` through any spelling or link).
fn is_null_device(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::{FileTypeExt, MetadataExt};
        match (fs::metadata(path), fs::metadata("/dev/null")) {
            (Ok(m), Ok(null)) => m.file_type().is_char_device() && m.rdev() == null.rdev(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        path.to_str().is_some_and(|p| p.eq_ignore_ascii_case("NUL"))
    }
}

/// `path` with its folder canonicalised (the file itself need not exist).
fn absolute(path: &Path) -> Option<PathBuf> {
    let folder = fs::canonicalize(folder_of(path)).ok()?;
    Some(folder.join(path.file_name()?))
}

/// Distinguishes temporary files of one process.
static COUNTER: AtomicU32 = AtomicU32::new(0);

/// A file being written: a temporary file beside the destination (in the system's temporary
/// folder for a stream, see the module's doc), renamed over it (copied into a stream) by
/// [`commit`](Self::commit). Dropped without a commit (an error, a panic), the temporary file
/// is removed and the destination is untouched.
///
/// Writes are buffered; the file is flushed and synced to disk before the rename.
#[derive(Debug)]
pub struct AtomicFile {
    /// The destination as the user named it (for messages).
    dest: PathBuf,
    /// Where the output goes: `dest` with its links followed (a regular file, replaced by the
    /// rename), or `dest` itself when it is a device, a pipe or a descriptor (written into on
    /// commit).
    target: PathBuf,
    /// The target is a stream ([`resolve_target`]): copy into it rather than rename over it.
    stream: bool,
    tmp: PathBuf,
    /// `None` only once committed.
    file: Option<BufWriter<File>>,
    /// The temporary file's slot in [`interrupt`]'s list (removed on an interrupt).
    slot: Option<usize>,
}

/// Links followed at most (as the system's own limit).
const MAX_LINKS: usize = 40;

/// Whether `path` names an open file descriptor (`/dev/stdout`, `/dev/stderr`, `/dev/fd/N`,
/// `/proc/…/fd/N`): the file behind it is the one the shell opened, written into, never
/// replaced (renaming over what it resolves to would leave the shell writing to a deleted
/// file).
fn is_descriptor(path: &Path) -> bool {
    let p = path.to_string_lossy();
    matches!(p.as_ref(), "/dev/stdout" | "/dev/stderr")
        || p.strip_prefix("/dev/fd/").is_some_and(|n| n.parse::<u32>().is_ok())
        || (p.starts_with("/proc/") && path.parent().is_some_and(|f| f.ends_with("fd")))
}

/// Where writing `dest` should go, and whether that is a stream (a device, a pipe, a socket,
/// or an open file descriptor) rather than a regular file. A link to an existing file resolves
/// to that file; a dangling link to the path it names (the file is created there, as a shell
/// redirection does).
fn resolve_target(dest: &Path) -> (PathBuf, bool) {
    let descriptor = is_descriptor(dest);
    match fs::metadata(dest) {
        Ok(m) if !m.is_file() && !m.is_dir() => return (dest.to_path_buf(), true),
        Ok(m) if m.is_file() && descriptor => return (dest.to_path_buf(), true),
        Ok(m) if m.is_file() => return (fs::canonicalize(dest).unwrap_or_else(|_| dest.to_path_buf()), false),
        Ok(_) => return (dest.to_path_buf(), false),
        Err(_) => {}
    }
    // Missing: a dangling link names the file to create.
    let mut path = dest.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&path) {
            Ok(m) if m.file_type().is_symlink() => match fs::read_link(&path) {
                Ok(to) => path = folder_of(&path).join(to),
                Err(_) => break,
            },
            _ => break,
        }
    }
    (path, false)
}

impl AtomicFile {
    /// Creates the temporary file for `dest` (a hidden `.NAME.PID-N.tmp` in the same folder,
    /// with the existing file's permissions if there is one).
    ///
    /// # Errors
    /// [`OutputError::IsAFolder`], [`OutputError::ReadOnly`], [`OutputError::NoFolder`],
    /// [`OutputError::FolderNotWritable`] or [`OutputError::Io`].
    pub fn create(dest: &Path) -> Result<Self, OutputError> {
        let path = dest.to_path_buf();
        let (target, stream) = resolve_target(dest);
        let existing = fs::metadata(&target).ok();
        if let Some(m) = &existing {
            if m.is_dir() {
                return Err(OutputError::IsAFolder { path });
            }
            if m.permissions().readonly() {
                return Err(OutputError::ReadOnly { path });
            }
        }
        let Some(name) = target.file_name() else {
            return Err(OutputError::IsAFolder { path });
        };
        if stream {
            // Completed in the system's temporary folder, then copied into the stream.
            return Self::create_in(path, target.clone(), true, &std::env::temp_dir(), name, None);
        }
        let folder = folder_of(&target);
        match fs::metadata(&folder) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => {
                let source = io::Error::new(io::ErrorKind::NotADirectory, "not a folder");
                return Err(OutputError::FolderNotWritable { path, folder, source });
            }
            Err(_) => return Err(OutputError::NoFolder { path, folder }),
        }
        Self::create_in(path, target.clone(), false, &folder, name, existing.as_ref())
    }

    /// Creates the temporary file `.NAME.PID-N.tmp` in `folder`.
    fn create_in(
        path: PathBuf,
        target: PathBuf,
        stream: bool,
        folder: &Path,
        name: &std::ffi::OsStr,
        existing: Option<&fs::Metadata>,
    ) -> Result<Self, OutputError> {
        let pid = std::process::id();
        let mut attempt = 0;
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let mut tmp_name = std::ffi::OsString::from(if stream { ".struck-" } else { "." });
            tmp_name.push(name);
            tmp_name.push(format!(".{pid}-{n}.tmp"));
            let tmp = folder.join(tmp_name);
            // A stream's copy is read back on commit.
            match OpenOptions::new().read(stream).write(true).create_new(true).open(&tmp) {
                Ok(file) => {
                    if let Some(m) = existing {
                        // Keep the replaced file's mode (e.g. group-readable); best effort.
                        let _ = file.set_permissions(m.permissions());
                    }
                    let file = Some(BufWriter::with_capacity(1 << 16, file));
                    let slot = interrupt::register(&tmp);
                    return Ok(AtomicFile { dest: path, target, stream, tmp, file, slot });
                }
                // A leftover of a killed run with the same pid and counter: try the next name.
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempt < 100 => attempt += 1,
                Err(source) => {
                    return Err(OutputError::FolderNotWritable { path, folder: folder.to_path_buf(), source });
                }
            }
        }
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        &self.dest
    }

    /// Whether the destination is a stream (a device, a pipe, a descriptor): written into on
    /// [`commit`](Self::commit), where it can still fail (`/dev/full`), and not undone.
    pub fn is_stream(&self) -> bool {
        self.stream
    }

    /// Flushes the buffer and syncs the temporary file to disk, without renaming it: with
    /// several outputs, sync them all before committing any, so that a full disk leaves every
    /// destination untouched.
    ///
    /// # Errors
    /// [`OutputError::Io`] (the destination is untouched).
    pub fn sync(&mut self) -> Result<(), OutputError> {
        let path = self.dest.clone();
        let io = |source| OutputError::Io { path, source };
        match self.writer().and_then(|w| w.flush().and_then(|()| w.get_ref().sync_all())) {
            Ok(()) => Ok(()),
            Err(e) => Err(io(e)),
        }
    }

    /// Flushes, syncs and renames the temporary file over the destination.
    ///
    /// # Errors
    /// [`OutputError::Io`]; the temporary file is then removed and the destination untouched.
    pub fn commit(mut self) -> Result<(), OutputError> {
        self.sync()?;
        let io = |source| OutputError::Io { path: self.dest.clone(), source };
        // Dropping the writer closes the file (its buffer is empty after `sync`).
        let file = self.file.take();
        if self.stream {
            let copied = file.map_or(Ok(()), |w| Self::copy_into(w.into_parts().0, &self.target));
            let _ = fs::remove_file(&self.tmp);
            return copied.map_err(io);
        }
        drop(file);
        if let Err(e) = fs::rename(&self.tmp, &self.target) {
            let _ = fs::remove_file(&self.tmp);
            return Err(io(e));
        }
        // The rename is durable once the folder itself is synced (best effort: not every
        // platform can open a folder).
        if let Ok(dir) = File::open(folder_of(&self.target)) {
            let _ = dir.sync_all();
        }
        Ok(())
    }

    /// Copies the completed temporary file `tmp` into the stream `target` (opened for writing
    /// only now: a pipe's reader sees the whole output or nothing).
    fn copy_into(mut tmp: File, target: &Path) -> io::Result<()> {
        tmp.seek(SeekFrom::Start(0))?;
        if same_file(target, Path::new("/dev/stdout")) {
            // The process's own standard output: through its handle, so that what the command
            // prints before and after lands in order (a second handle on a file behind it
            // would write from its own position).
            let mut out = io::stdout().lock();
            out.flush()?;
            io::copy(&mut tmp, &mut out)?;
            return out.flush();
        }
        // Appending: a file behind a descriptor keeps what the shell's `>>` put there first.
        let mut out = OpenOptions::new().append(true).open(target)?;
        io::copy(&mut tmp, &mut out)?;
        out.flush()
    }

    fn writer(&mut self) -> io::Result<&mut BufWriter<File>> {
        self.file.as_mut().ok_or_else(|| io::Error::other("the file was already committed"))
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer()?.write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.writer()?.write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.writer()?.flush()
    }
}

impl Seek for AtomicFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.writer()?.seek(pos)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(writer) = self.file.take() {
            // Not committed: discard (without flushing the buffer into a file about to go).
            let (file, _) = writer.into_parts();
            drop(file);
            let _ = fs::remove_file(&self.tmp);
        }
        // Committed (renamed or copied) or removed: no longer the handler's.
        interrupt::release(self.slot.take());
    }
}

/// Commits several outputs of one command: all synced first, then the streams written (a
/// device or pipe can still fail there, e.g. `/dev/full`), then the regular files renamed. A
/// failure before the renames leaves every regular destination untouched.
///
/// # Errors
/// The first output's error ([`AtomicFile::sync`], [`AtomicFile::commit`]).
pub fn commit_all(mut files: Vec<AtomicFile>) -> Result<(), OutputError> {
    for f in &mut files {
        f.sync()?;
    }
    let (streams, regular): (Vec<_>, Vec<_>) = files.into_iter().partition(AtomicFile::is_stream);
    for f in streams.into_iter().chain(regular) {
        f.commit()?;
    }
    Ok(())
}

/// Writes `bytes` to `path` through an [`AtomicFile`].
///
/// # Errors
/// As [`AtomicFile::create`] and [`AtomicFile::commit`].
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|source| OutputError::Io { path: path.to_path_buf(), source })?;
    f.commit()
}

/// Temporary outputs removed when the process is interrupted (SIGINT, SIGTERM, SIGHUP):
/// Ctrl-C during a long render must not leave a hidden `.NAME.PID-N.tmp` of a gigabyte
/// behind. [`install_interrupt_cleanup`] sets the handlers (the command-line tool does; a
/// plugin or library user does not, and then nothing is registered); [`AtomicFile`]
/// registers its temporary file while it exists.
#[cfg(unix)]
mod interrupt {
    use std::ffi::{c_char, CString};
    use std::os::unix::ffi::OsStrExt;
    use std::path::Path;
    use std::sync::atomic::{AtomicBool, AtomicPtr, Ordering};

    /// At most this many outputs at once are cleaned up (a command writes one to three).
    const SLOTS: usize = 32;
    static PATHS: [AtomicPtr<c_char>; SLOTS] = [const { AtomicPtr::new(std::ptr::null_mut()) }; SLOTS];
    /// Whether [`install`] ran: without a handler nothing is registered.
    static INSTALLED: AtomicBool = AtomicBool::new(false);

    /// Adds `tmp` to the list; `None` without a handler, when the list is full or the path
    /// has a NUL byte.
    pub(super) fn register(tmp: &Path) -> Option<usize> {
        if !INSTALLED.load(Ordering::Acquire) {
            return None;
        }
        let c = CString::new(tmp.as_os_str().as_bytes()).ok()?.into_raw();
        for (i, slot) in PATHS.iter().enumerate() {
            if slot.compare_exchange(std::ptr::null_mut(), c, Ordering::AcqRel, Ordering::Relaxed).is_ok() {
                return Some(i);
            }
        }
        // SAFETY: `c` came from `CString::into_raw` above and was stored nowhere.
        drop(unsafe { CString::from_raw(c) });
        None
    }

    /// Takes a path off the list. Its string is left allocated (a few bytes per output of a
    /// command-line run): a handler running at this moment on another thread may still be
    /// reading it.
    pub(super) fn release(slot: Option<usize>) {
        if let Some(i) = slot {
            PATHS[i].store(std::ptr::null_mut(), Ordering::Release);
        }
    }

    extern "C" fn on_signal(sig: libc::c_int) {
        for slot in &PATHS {
            let p = slot.load(Ordering::Acquire);
            if !p.is_null() {
                // SAFETY: a NUL-terminated string that is never freed; unlink is
                // async-signal-safe.
                unsafe { libc::unlink(p) };
            }
        }
        // SAFETY: async-signal-safe calls; the default action then ends the process with
        // the signal, as the shell expects (exit status 128 + sig).
        unsafe {
            libc::signal(sig, libc::SIG_DFL);
            libc::raise(sig);
        }
    }

    /// Sets the handler for each signal that is not ignored (`nohup` ignores SIGHUP, a
    /// shell's background job SIGINT: they stay ignored).
    pub(super) fn install() {
        for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            // SAFETY: reads the current action (a null new action changes nothing), then
            // installs a handler that only makes async-signal-safe calls.
            unsafe {
                let mut old: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(sig, std::ptr::null(), &mut old) != 0 || old.sa_sigaction == libc::SIG_IGN {
                    continue;
                }
                libc::signal(sig, on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t);
            }
        }
        INSTALLED.store(true, Ordering::Release);
    }
}

/// Elsewhere nothing is registered and no handler is set.
#[cfg(not(unix))]
mod interrupt {
    pub(super) fn register(_tmp: &std::path::Path) -> Option<usize> {
        None
    }
    pub(super) fn release(_slot: Option<usize>) {}
    pub(super) fn install() {}
}

/// Removes the temporary files of unfinished [`AtomicFile`]s when the process is interrupted
/// by SIGINT, SIGTERM or SIGHUP (those not ignored), then ends it with that signal. For
/// programs (the command-line tool); call once at start. Unix only (elsewhere a no-op).
pub fn install_interrupt_cleanup() {
    interrupt::install();
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("struck-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Files in `dir` other than `keep`.
    fn others(dir: &Path, keep: &str) -> Vec<String> {
        fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n != keep)
            .collect()
    }

    #[test]
    fn a_dropped_file_leaves_the_old_one_and_no_temporary() {
        let dir = scratch("drop");
        let dest = dir.join("out.txt");
        fs::write(&dest, "old").unwrap();
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(&[b'x'; 100_000]).unwrap();
        // Mid-write, the destination still holds the old content.
        assert_eq!(fs::read_to_string(&dest).unwrap(), "old");
        drop(f);
        assert_eq!(fs::read_to_string(&dest).unwrap(), "old");
        assert!(others(&dir, "out.txt").is_empty(), "{:?}", others(&dir, "out.txt"));
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn a_commit_replaces_the_file_and_keeps_its_mode() {
        let dir = scratch("commit");
        let dest = dir.join("out.txt");
        fs::write(&dest, "old").unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            fs::set_permissions(&dest, fs::Permissions::from_mode(0o640)).unwrap();
        }
        write_atomically(&dest, b"new").unwrap();
        assert_eq!(fs::read_to_string(&dest).unwrap(), "new");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(fs::metadata(&dest).unwrap().permissions().mode() & 0o777, 0o640);
        }
        assert!(others(&dir, "out.txt").is_empty());
        let _ = fs::remove_dir_all(dir);
    }

    /// A mistyped `--out` naming a recording (or a material where a render goes) is refused,
    /// and the file is left as it was; a file of the output's own kind, an empty one and a
    /// new name are fine.
    #[test]
    fn a_file_of_another_kind_is_not_replaced() {
        let dir = scratch("kind");
        let wav = dir.join("take1.wav");
        let mut header = b"RIFF\x24\x00\x00\x00WAVEfmt ".to_vec();
        header.extend_from_slice(&[0; 24]);
        fs::write(&wav, &header).unwrap();
        let json = dir.join("mat.json");
        fs::write(&json, "\u{feff}\n  {\"id\": \"m\"}").unwrap();
        let notes = dir.join("notes.txt");
        fs::write(&notes, "struck glass, take 3").unwrap();
        let midi = dir.join("phrase.mid");
        fs::write(&midi, b"MThd\x00\x00\x00\x06").unwrap();
        let empty = dir.join("empty.json");
        fs::write(&empty, "").unwrap();
        let found = |p: &Path, k: Kind| match check_output(p, &[], k) {
            Err(OutputError::OtherKind { found, .. }) => Some(found),
            Err(e) => panic!("{e}"),
            Ok(()) => None,
        };
        assert_eq!(found(&wav, Kind::Json), Some("a WAV recording"));
        assert_eq!(found(&json, Kind::Wav), Some("a JSON file"));
        assert_eq!(found(&midi, Kind::Wav), Some("a MIDI file"));
        assert_eq!(found(&notes, Kind::Json), Some("not a JSON file"));
        assert_eq!(found(&wav, Kind::Wav), None);
        assert_eq!(found(&json, Kind::Json), None);
        assert_eq!(found(&empty, Kind::Wav), None);
        assert_eq!(found(&dir.join("new.wav"), Kind::Json), None);
        let e = check_output(&wav, &[], Kind::Json).unwrap_err().to_string();
        assert!(e.starts_with("cannot write ") && e.contains("choose another name"), "{e}");
        assert_eq!(fs::read(&wav).unwrap(), header);
        // Through a link: what it points to is looked at.
        #[cfg(unix)]
        {
            let link = dir.join("link.json");
            std::os::unix::fs::symlink(&wav, &link).unwrap();
            assert_eq!(found(&link, Kind::Json), Some("a WAV recording"));
        }
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn bad_destinations_are_refused_before_any_write() {
        let dir = scratch("refuse");
        let missing = dir.join("no-such-folder").join("x.json");
        assert!(matches!(check_output(&missing, &[], Kind::Json), Err(OutputError::NoFolder { .. })));
        assert!(matches!(check_output(&dir, &[], Kind::Json), Err(OutputError::IsAFolder { .. })));
        let input = dir.join("in.wav");
        fs::write(&input, "input").unwrap();
        // The same file through another spelling of its path.
        let other_spelling = dir.join(".").join("in.wav");
        let e = check_output(&other_spelling, &[&input], Kind::Json).unwrap_err();
        assert!(matches!(e, OutputError::SameAsInput { .. }), "{e}");
        assert!(e.to_string().starts_with("cannot write "), "{e}");
        assert_eq!(fs::read_to_string(&input).unwrap(), "input");
        let ro = dir.join("ro.json");
        fs::write(&ro, "{\"keep\": 1}").unwrap();
        let mut p = fs::metadata(&ro).unwrap().permissions();
        p.set_readonly(true);
        fs::set_permissions(&ro, p).unwrap();
        assert!(matches!(check_output(&ro, &[], Kind::Json), Err(OutputError::ReadOnly { .. })));
        assert!(check_output(&dir.join("fine.json"), &[&input], Kind::Json).is_ok());
        assert!(!dir.join("fine.json").exists());
        assert!(check_distinct(&[&dir.join("a.json"), &dir.join("./a.json")]).is_err());
        assert!(check_distinct(&[&dir.join("a.json"), &dir.join("b.json")]).is_ok());
        // The null device discards both outputs, as asked; a link to it is the same device.
        #[cfg(unix)]
        {
            let null = Path::new("/dev/null");
            assert!(check_distinct(&[null, null]).is_ok());
            let link = dir.join("null-link");
            std::os::unix::fs::symlink(null, &link).unwrap();
            assert!(check_distinct(&[null, &link]).is_ok());
            fs::remove_file(&link).unwrap();
            assert!(check_distinct(&[&dir.join("a.json"), null, &dir.join("a.json")]).is_err());
        }
        assert_eq!(others(&dir, "").len(), 2, "only in.wav and ro.json remain");
        let mut p = fs::metadata(&ro).unwrap().permissions();
        #[allow(clippy::permissions_set_readonly_false)]
        p.set_readonly(false);
        fs::set_permissions(&ro, p).unwrap();
        let _ = fs::remove_dir_all(dir);
    }

    #[cfg(unix)]
    #[test]
    fn a_link_is_followed_and_stays_a_link() {
        let dir = scratch("link");
        let real = dir.join("real.json");
        fs::write(&real, "old").unwrap();
        let link = dir.join("link.json");
        std::os::unix::fs::symlink("real.json", &link).unwrap();
        write_atomically(&link, b"new").unwrap();
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link was replaced");
        assert_eq!(fs::read_to_string(&real).unwrap(), "new");
        // A dangling link: the file it names is created.
        let dangling = dir.join("dangling.json");
        std::os::unix::fs::symlink("made.json", &dangling).unwrap();
        write_atomically(&dangling, b"made").unwrap();
        assert!(fs::symlink_metadata(&dangling).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_to_string(dir.join("made.json")).unwrap(), "made");
        let mut left = others(&dir, "");
        left.sort();
        assert_eq!(left, ["dangling.json", "link.json", "made.json", "real.json"]);
        let _ = fs::remove_dir_all(dir);
    }

    #[cfg(unix)]
    #[test]
    fn a_named_pipe_is_written_into_not_replaced() {
        let dir = scratch("fifo");
        let fifo = dir.join("report.json");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("mkfifo is not available: skipped");
            return;
        }
        check_output(&fifo, &[], Kind::Json).unwrap();
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || fs::read(fifo).unwrap())
        };
        let mut f = AtomicFile::create(&fifo).unwrap();
        f.write_all(&[b'x'; 200_000]).unwrap();
        f.commit().unwrap();
        assert_eq!(reader.join().unwrap().len(), 200_000, "the reader got the whole output");
        use std::os::unix::fs::FileTypeExt;
        assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the pipe was replaced");
        assert!(others(&dir, "report.json").is_empty());
        let _ = fs::remove_dir_all(dir);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn devices_are_written_into_and_their_errors_reported() {
        use std::os::unix::fs::FileTypeExt;
        let is_char = |p: &str| fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_char_device());
        if !is_char("/dev/null") || !is_char("/dev/full") {
            eprintln!("no /dev/null or /dev/full: skipped");
            return;
        }
        assert_eq!(resolve_target(Path::new("/dev/null")), (PathBuf::from("/dev/null"), true));
        write_atomically(Path::new("/dev/null"), b"gone").unwrap();
        assert!(is_char("/dev/null"), "/dev/null is no longer a device");
        let e = write_atomically(Path::new("/dev/full"), &[0; 10_000]).unwrap_err();
        assert!(matches!(e, OutputError::Io { .. }), "{e}");
        assert!(e.to_string().starts_with("cannot write /dev/full: "), "{e}");
        assert!(is_char("/dev/full"), "/dev/full is no longer a device");
    }

    /// A command's outputs committed together: a stream that fails (a full device) fails
    /// before any regular file is replaced (`estimate --out m.json --report /dev/full`
    /// replaced the material, then exited 1).
    #[cfg(target_os = "linux")]
    #[test]
    fn a_failing_stream_among_outputs_leaves_the_files_untouched() {
        if fs::metadata("/dev/full").is_err() {
            eprintln!("no /dev/full: skipped");
            return;
        }
        let dir = scratch("commit-all");
        let kept = dir.join("material.json");
        fs::write(&kept, b"the user's material").unwrap();
        let mut material = AtomicFile::create(&kept).unwrap();
        material.write_all(b"new material").unwrap();
        let mut report = AtomicFile::create(Path::new("/dev/full")).unwrap();
        report.write_all(&[b'x'; 10_000]).unwrap();
        assert!(report.is_stream() && !material.is_stream());
        // The material listed first, as `estimate` stages them.
        let e = commit_all(vec![material, report]).unwrap_err();
        assert!(e.to_string().starts_with("cannot write /dev/full: "), "{e}");
        assert_eq!(fs::read(&kept).unwrap(), b"the user's material");
        assert!(others(&dir, "material.json").is_empty(), "a temporary file was left");
        // Both regular: both replaced.
        let other = dir.join("report.json");
        let mut a = AtomicFile::create(&kept).unwrap();
        a.write_all(b"new material").unwrap();
        let mut b = AtomicFile::create(&other).unwrap();
        b.write_all(b"report").unwrap();
        commit_all(vec![a, b]).unwrap();
        assert_eq!(fs::read(&kept).unwrap(), b"new material");
        assert_eq!(fs::read(&other).unwrap(), b"report");
        let _ = fs::remove_dir_all(dir);
    }
}
