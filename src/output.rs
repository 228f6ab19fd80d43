//! Everything the program writes: the terminal (standard output and error) and files.
//!
//! - Standard output: a closed pipe (`latticesim ... | head`) ends it quietly, the rest of
//!   the command goes on (files requested are still written) and the exit status is not
//!   changed; any other failure (a full disk) is reported once and makes the exit status 2.
//! - Standard error: written through [`say!`], never panicking; a closed pipe ends it
//!   quietly as it ends standard output, any other failure to write it makes the exit
//!   status 2.
//! - Files: written whole or not at all. [`AtomicFile`] writes into a new temporary file
//!   beside the target (never following a symbolic link) and renames it over the target
//!   when committed, so a reader, a crash or a kill sees the old file or the new one, never
//!   a part. Creating one is also how a command checks an output path before it does any
//!   work.
//! - Ctrl-C: [`on_interrupt`] is installed first thing. Until a command says it polls
//!   [`interrupted`] (the stepping loop of `run`), Ctrl-C removes the temporary files and
//!   exits 130 at once with a message.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicU8, Ordering};
use std::sync::Mutex;

/// Standard output was closed by its reader.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);
/// Standard error was closed by its reader.
static STDERR_CLOSED: AtomicBool = AtomicBool::new(false);
/// Writing standard output or standard error failed for another reason.
static FAILED: AtomicBool = AtomicBool::new(false);
/// Ctrl-C was pressed.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// 0: Ctrl-C exits at once; 1: the command polls [`interrupted`].
static POLLED: AtomicU8 = AtomicU8::new(0);
/// Temporary files not yet renamed, removed when Ctrl-C exits at once.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Flags Ctrl-C sets ([`also_on_interrupt`]).
static FLAGS: Mutex<Vec<std::sync::Arc<AtomicBool>>> = Mutex::new(Vec::new());

/// Writes a line to standard error (`eprintln!` that never panics).
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::output::stderr(&format!("{}\n", format_args!($($arg)*)))
    };
}
pub(crate) use say;

/// Writes to standard error; a closed pipe ends it quietly (`latticesim ... 2>&1 | head`,
/// as standard output), another failure is remembered for the exit status.
pub(crate) fn stderr(text: &str) {
    if STDERR_CLOSED.load(Ordering::SeqCst) {
        return;
    }
    if let Err(e) = std::io::stderr().lock().write_all(text.as_bytes()) {
        match e.kind() {
            ErrorKind::BrokenPipe => STDERR_CLOSED.store(true, Ordering::SeqCst),
            _ => FAILED.store(true, Ordering::SeqCst),
        }
    }
}

/// Writes to standard output (see the module's text for failures).
pub(crate) fn stdout(bytes: &[u8]) {
    if STDOUT_CLOSED.load(Ordering::SeqCst) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(bytes).and_then(|_| out.flush()) {
        if e.kind() == ErrorKind::BrokenPipe {
            STDOUT_CLOSED.store(true, Ordering::SeqCst);
        } else if !FAILED.swap(true, Ordering::SeqCst) {
            STDOUT_CLOSED.store(true, Ordering::SeqCst);
            stderr(&format!("error: cannot write to standard output: {e}\n"));
        }
    }
}

/// Standard output as a buffered writer, with the failures of [`stdout`] (a closed pipe
/// ends the output quietly); its writes never fail.
pub(crate) struct Stdout {
    buf: Vec<u8>,
}

impl Stdout {
    pub(crate) fn new() -> Stdout {
        Stdout {
            buf: Vec::with_capacity(1 << 16),
        }
    }
}

impl Write for Stdout {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.buf.extend_from_slice(bytes);
        if self.buf.len() >= 1 << 16 {
            self.flush()?;
        }
        Ok(bytes.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        stdout(&self.buf);
        self.buf.clear();
        Ok(())
    }
}

impl Drop for Stdout {
    fn drop(&mut self) {
        let _ = self.flush();
    }
}

/// The command's exit status, made 2 when the terminal output failed.
pub(crate) fn finish(code: ExitCode) -> ExitCode {
    if FAILED.load(Ordering::SeqCst) {
        ExitCode::from(2)
    } else {
        code
    }
}

/// Installs the Ctrl-C handler (see the module's text).
pub(crate) fn on_interrupt() {
    let _ = ctrlc::set_handler(|| {
        INTERRUPTED.store(true, Ordering::SeqCst);
        if let Ok(flags) = FLAGS.lock() {
            for f in flags.iter() {
                f.store(true, Ordering::SeqCst);
            }
        }
        if POLLED.load(Ordering::SeqCst) == 0 {
            let mut removed = false;
            if let Ok(pending) = PENDING.lock() {
                for p in pending.iter() {
                    removed |= std::fs::remove_file(p).is_ok();
                }
            }
            stderr(if removed {
                "interrupted; nothing was written\n"
            } else {
                "interrupted\n"
            });
            std::process::exit(130);
        }
    });
}

/// From now on the command polls [`interrupted`] and stops by itself.
pub(crate) fn poll_interrupts() {
    POLLED.store(1, Ordering::SeqCst);
}

/// Ctrl-C also sets `flag` (a flag that stops work on other threads, e.g. every run of a
/// sweep at its next step).
pub(crate) fn also_on_interrupt(flag: std::sync::Arc<AtomicBool>) {
    if interrupted() {
        flag.store(true, Ordering::SeqCst);
    }
    if let Ok(mut flags) = FLAGS.lock() {
        flags.push(flag);
    }
}

/// Whether Ctrl-C was pressed.
pub(crate) fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// A file written whole or not at all: a temporary file beside the target until
/// [`AtomicFile::commit`] renames it; dropped uncommitted, it is removed.
pub struct AtomicFile {
    path: PathBuf,
    /// The temporary file; `None` when the target is not a regular file (a device such as
    /// `/dev/null`, a pipe), which is written directly.
    tmp: Option<PathBuf>,
    file: Option<BufWriter<File>>,
    /// Flush the file to disk before the rename ([`AtomicFile::durable`]).
    sync: bool,
}

/// Removes the temporary files `PREFIX.PID.N.tmp` in `folder` whose process `PID` no
/// longer runs (a run killed while it wrote), and says so. Best effort: a folder that
/// cannot be listed is left as it is.
fn remove_stale(folder: &Path, prefix: &str) {
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(rest) = (name.to_str())
            .and_then(|n| n.strip_prefix(prefix))
            .and_then(|r| r.strip_prefix('.'))
            .and_then(|r| r.strip_suffix(".tmp"))
        else {
            continue;
        };
        let Some((pid, n)) = rest.split_once('.') else {
            continue;
        };
        let (Ok(pid), true) = (pid.parse::<u32>(), n.bytes().all(|b| b.is_ascii_digit())) else {
            continue;
        };
        if pid != std::process::id()
            && !process_runs(pid)
            && e.path().is_file()
            && std::fs::remove_file(e.path()).is_ok()
        {
            say!(
                "note: removed `{}`, left by a run (process {pid}) that was killed while it wrote",
                e.path().display()
            );
        }
    }
}

/// Whether process `pid` runs (on systems without `/proc`, taken to run: nothing removed).
/// A zombie does not: a run killed in a container whose first process is slow to reap it
/// stays one for a while, and its temporary file was left to a later run (seen with
/// `timeout -s KILL`).
fn process_runs(pid: u32) -> bool {
    let proc = Path::new("/proc");
    if !proc.is_dir() {
        return true;
    }
    match std::fs::read_to_string(proc.join(pid.to_string()).join("stat")) {
        // The state is the first field after the command's name, which ends at the last
        // `)` (the name may hold any character).
        Ok(stat) => {
            let state = stat
                .rsplit_once(')')
                .and_then(|(_, r)| r.trim_start().chars().next());
            !matches!(state, Some('Z' | 'X'))
        }
        Err(_) => proc.join(pid.to_string()).exists(),
    }
}

/// Opens a file that must not exist yet, without following a symbolic link.
pub(crate) fn create_new(path: &Path) -> std::io::Result<File> {
    let mut o = OpenOptions::new();
    o.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW).mode(0o644);
    }
    o.open(path)
}

/// Opens an existing file for reading without following a symbolic link.
pub(crate) fn open_no_follow(path: &Path) -> std::io::Result<File> {
    let mut o = OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW);
    }
    o.open(path)
}

impl AtomicFile {
    /// Starts writing `path`: fails now when its folder cannot take a new file or the path
    /// is a folder.
    pub fn create(path: &Path) -> std::io::Result<AtomicFile> {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        if path.is_dir() {
            return Err(std::io::Error::new(
                ErrorKind::IsADirectory,
                "it is a folder",
            ));
        }
        // A device or a pipe is written as it is: a rename would replace it.
        if let Ok(meta) = std::fs::metadata(path) {
            if !meta.is_file() {
                let file = OpenOptions::new().write(true).open(path)?;
                return Ok(AtomicFile {
                    path: path.to_path_buf(),
                    tmp: None,
                    file: Some(BufWriter::with_capacity(1 << 16, file)),
                    sync: false,
                });
            }
        }
        let name = path
            .file_name()
            .ok_or_else(|| std::io::Error::new(ErrorKind::InvalidInput, "it names no file"))?;
        let folder = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        // `.NAME.PID.N.tmp`, NAME cut to 200 bytes so that a name near the system's limit
        // (255 bytes) still has room for its temporary file.
        let mut tmp_name = std::ffi::OsString::from(".");
        let lossy = name.to_string_lossy();
        if name.len() <= 200 && !matches!(lossy, std::borrow::Cow::Owned(_)) {
            tmp_name.push(name);
        } else {
            let mut cut = 200.min(lossy.len());
            while !lossy.is_char_boundary(cut) {
                cut -= 1;
            }
            tmp_name.push(&lossy[..cut]);
        }
        // Temporary files of this name left by a process that is gone (killed) are
        // removed now: they are recognisable by their name and dead process id.
        remove_stale(folder, &tmp_name.to_string_lossy());
        tmp_name.push(format!(
            ".{}.{}.tmp",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::SeqCst)
        ));
        let tmp = folder.join(tmp_name);
        let file = create_new(&tmp)?;
        if let Ok(mut p) = PENDING.lock() {
            p.push(tmp.clone());
        }
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp: Some(tmp),
            file: Some(BufWriter::with_capacity(1 << 16, file)),
            sync: false,
        })
    }

    /// Makes [`AtomicFile::commit`] flush the file to disk before the rename, so that it
    /// survives a power cut whole (for checkpoints and the editor's files; other outputs
    /// are only renamed, which no crash of the process can leave half written).
    pub(crate) fn durable(mut self) -> AtomicFile {
        self.sync = true;
        self
    }

    /// Gives the new file these permissions (e.g. those of the file it replaces).
    pub(crate) fn set_permissions(&self, perm: std::fs::Permissions) -> std::io::Result<()> {
        let f = self.file.as_ref().expect("not committed");
        f.get_ref().set_permissions(perm)
    }

    /// The target's path.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// Writes what was written so far to disk and renames it over the target.
    pub(crate) fn commit(mut self) -> std::io::Result<()> {
        let w = self.file.take().expect("committed once");
        let flushed = w.into_inner().map_err(|e| e.into_error());
        let Some(tmp) = self.tmp.clone() else {
            return flushed.map(drop);
        };
        // A write that fails here (the last buffer on a full disk) removes the temporary
        // file as a failed rename does.
        let renamed = flushed
            .and_then(|file| if self.sync { file.sync_all() } else { Ok(()) })
            .and_then(|()| std::fs::rename(&tmp, &self.path));
        if renamed.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        self.forget();
        renamed
    }

    fn forget(&self) {
        if let (Ok(mut p), Some(tmp)) = (PENDING.lock(), &self.tmp) {
            p.retain(|t| t != tmp);
        }
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.as_mut().expect("not committed").write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.file.as_mut().expect("not committed").write_all(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.as_mut().expect("not committed").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let (Some(_), Some(tmp)) = (self.file.take(), &self.tmp) {
            let _ = std::fs::remove_file(tmp);
            self.forget();
        }
    }
}

/// An output file of a command, opened before the command's work (so a bad path fails at
/// once) and written at its end: the message and exit status 2 when it cannot be.
pub(crate) fn open_output(path: &Path) -> Result<AtomicFile, ExitCode> {
    AtomicFile::create(path).map_err(|e| {
        say!("error: cannot write `{}`: {e}", path.display());
        ExitCode::from(2)
    })
}

/// Writes `bytes` into an output file opened with [`open_output`] and commits it.
pub(crate) fn write_output(mut f: AtomicFile, bytes: &[u8]) -> Result<(), ExitCode> {
    let path = f.path().to_path_buf();
    f.write_all(bytes).and_then(|_| f.commit()).map_err(|e| {
        say!("error: cannot write `{}`: {e}", path.display());
        ExitCode::from(2)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A process that ended but was not reaped (a zombie) does not run; this one does.
    #[test]
    #[cfg(target_os = "linux")]
    fn a_zombie_does_not_run() {
        assert!(process_runs(std::process::id()));
        let mut child = std::process::Command::new("true")
            .spawn()
            .expect("`true` runs");
        let stat = format!("/proc/{}/stat", child.id());
        // Not waited for: once it has exited, it stays a zombie until `wait`.
        let zombie = (0..500).any(|_| {
            std::thread::sleep(std::time::Duration::from_millis(10));
            std::fs::read_to_string(&stat).is_ok_and(|s| s.contains(") Z"))
        });
        assert!(zombie, "the child became a zombie");
        assert!(!process_runs(child.id()));
        child.wait().expect("reaped");
        assert!(!process_runs(child.id()));
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("latticesim-out-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn the_target_changes_only_at_commit_and_no_temporary_file_stays() {
        let d = scratch("commit");
        let p = d.join("final.txt");
        std::fs::write(&p, "old\n").unwrap();
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"new\n").unwrap();
        f.flush().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old\n");
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new\n");
        let dropped = AtomicFile::create(&p).unwrap();
        drop(dropped);
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("final.txt")]);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn bad_paths_fail_at_creation() {
        let d = scratch("bad");
        assert!(AtomicFile::create(&d.join("no/such/folder.txt")).is_err());
        assert!(AtomicFile::create(&d).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_replaced_not_followed() {
        let d = scratch("link");
        std::fs::write(d.join("target.txt"), "kept\n").unwrap();
        std::os::unix::fs::symlink(d.join("target.txt"), d.join("link.txt")).unwrap();
        write_output(open_output(&d.join("link.txt")).unwrap(), b"new\n").unwrap();
        assert_eq!(
            std::fs::read_to_string(d.join("target.txt")).unwrap(),
            "kept\n"
        );
        assert!(!std::fs::symlink_metadata(d.join("link.txt"))
            .unwrap()
            .file_type()
            .is_symlink());
        assert!(open_no_follow(&d.join("target.txt")).is_ok());
        std::os::unix::fs::symlink(d.join("target.txt"), d.join("link2.txt")).unwrap();
        assert!(open_no_follow(&d.join("link2.txt")).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }
}
