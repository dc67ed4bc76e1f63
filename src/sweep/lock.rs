//! One writer per output: every command that writes a sweep output, a shard or a merge holds an
//! exclusive OS lock (`flock`) on `OUT.lock` beside it for as long as it writes. The kernel
//! releases the lock when the process ends, however it ends, so `kill -9` leaves no stale lock;
//! a second writer is refused at once with the holder's process id.
//!
//! The lock file holds the holder's process id (for the message only: the lock, not the file,
//! decides). The holder removes it on a clean exit, while still holding the lock; a process that
//! opened the old file before its removal finds, once it has the lock, that the path no longer
//! names the file it locked (another device or inode), and tries again on the new one.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// An exclusive lock on an output, held until dropped.
#[derive(Debug)]
pub struct OutputLock {
    file: File,
    path: PathBuf,
}

/// The lock file of output `out`: `OUT.lock`.
pub fn path_for(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".lock");
    PathBuf::from(s)
}

#[cfg(unix)]
fn same_file(f: &File, p: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (f.metadata(), std::fs::metadata(p)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_: &File, p: &Path) -> bool {
    p.exists()
}

/// Takes the lock of output `out` (see the module docs), or says who holds it.
pub fn acquire(out: &Path) -> Result<OutputLock, String> {
    let path = path_for(out);
    // A few tries: only a holder removing its file between our open and our lock needs one.
    for _ in 0..8 {
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut who = String::new();
                let _ = file.read_to_string(&mut who);
                let who = who.trim();
                return Err(format!(
                    "{} is being written by {}, which holds {}; wait for it to finish, or stop \
                     it, then run again",
                    out.display(),
                    if who.is_empty() {
                        "another process".to_string()
                    } else {
                        format!("process {who}")
                    },
                    path.display()
                ));
            }
            Err(TryLockError::Error(e)) => {
                return Err(format!("{}: cannot lock: {e}", path.display()));
            }
        }
        if !same_file(&file, &path) {
            continue;
        }
        let _ = file.set_len(0);
        let _ = file.rewind();
        let _ = writeln!(file, "{}", std::process::id());
        let _ = file.flush();
        return Ok(OutputLock { file, path });
    }
    Err(format!(
        "{}: the lock file kept changing under this process; try again",
        path.display()
    ))
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still held (module docs); the lock goes with the file handle.
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_writer_is_refused_with_the_holders_id_until_the_first_is_done() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("s.h5");
        let first = acquire(&out).unwrap();
        let e = acquire(&out).unwrap_err();
        assert!(
            e.contains(&std::process::id().to_string()) && e.contains("s.h5.lock"),
            "{e}"
        );
        drop(first);
        assert!(!path_for(&out).exists(), "removed on a clean exit");
        let again = acquire(&out).unwrap();
        drop(again);
    }
}
