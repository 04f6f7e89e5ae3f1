//! Output files written whole or not at all.
//!
//! [`AtomicFile`] writes into a hidden temporary file in the target's own
//! folder (`.NAME.navfuse-tmp.PID`, same file system, so the final step is a
//! `rename`), and only [`AtomicFile::commit`] makes it visible under its name:
//! flush, `fsync` of the data, `rename` over the target, `fsync` of the
//! folder. An error or a drop before `commit` removes the temporary file, so
//! a failed command leaves the previous version of every output (or none),
//! never a truncated one. A process killed mid-write (SIGKILL, power loss)
//! may leave a `.…navfuse-tmp.…` file behind but never a partial output
//! under the real name (POSIX `rename` replaces the target atomically).
//!
//! Overwrite policy: an existing output is replaced (atomically) — a rerun
//! into the same folder is the normal use, and since the old file stays
//! intact until the new one is complete, nothing is lost to a failed rerun.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Buffer of the writer in front of the temporary file (64 KiB: a few
/// `write` calls per MB, small against any output).
const BUF_BYTES: usize = 1 << 16;

/// The marker in every temporary name (tests and tools recognise leftovers by it).
pub const TMP_MARKER: &str = ".navfuse-tmp.";

/// An output file under construction; see the module doc.
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    w: Option<BufWriter<File>>,
}

/// The temporary name of `path`: `.NAME.navfuse-tmp.PID` in the same folder.
pub fn tmp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = format!(".{name}{TMP_MARKER}{}", std::process::id());
    match path.parent() {
        Some(d) => d.join(tmp),
        None => PathBuf::from(tmp),
    }
}

impl AtomicFile {
    /// Start writing `path` (its folder must exist). Nothing appears under
    /// `path` until [`commit`](Self::commit).
    pub fn create(path: &Path) -> io::Result<Self> {
        let tmp = tmp_path(path);
        let f = File::create(&tmp)?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            w: Some(BufWriter::with_capacity(BUF_BYTES, f)),
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flush, `fsync`, rename over the final path and `fsync` the folder.
    /// On error the temporary file is removed and the target is untouched.
    /// A second call is an error.
    pub fn commit(&mut self) -> io::Result<()> {
        let Some(w) = self.w.take() else {
            return Err(io::Error::other("output already committed"));
        };
        let done = (|| {
            let f = w.into_inner().map_err(|e| e.into_error())?;
            f.sync_all()?;
            drop(f);
            std::fs::rename(&self.tmp, &self.path)?;
            // The rename itself is durable once the folder is synced; a
            // failure here (some file systems refuse fsync on a folder)
            // does not undo a complete, visible file.
            if let Some(d) = self.path.parent() {
                let d = if d.as_os_str().is_empty() {
                    Path::new(".")
                } else {
                    d
                };
                if let Ok(df) = File::open(d) {
                    let _ = df.sync_all();
                }
            }
            Ok(())
        })();
        if done.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        done
    }

    fn writer(&mut self) -> io::Result<&mut BufWriter<File>> {
        self.w
            .as_mut()
            .ok_or_else(|| io::Error::other("write after commit"))
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

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(w) = self.w.take() {
            // Not committed: discard the buffer unwritten and remove the file.
            let (f, _) = w.into_parts();
            drop(f);
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Write `bytes` to `path` whole or not at all (an [`AtomicFile`] in one call).
pub fn write_atomic(path: &Path, bytes: impl AsRef<[u8]>) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes.as_ref())?;
    f.commit()
}

/// [`write_atomic`] with the path in the error text (`PATH: cause`), for
/// callers whose errors are strings.
pub fn write_atomic_named(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), String> {
    write_atomic(path, bytes).map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("navfuse_atomic_{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn listing(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn invisible_until_commit_then_replaces() {
        let d = dir("commit");
        let p = d.join("a.txt");
        std::fs::write(&p, "old\n").unwrap();
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"new\n").unwrap();
        f.flush().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old\n");
        assert_eq!(
            listing(&d).len(),
            2,
            "the temporary file exists while writing"
        );
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new\n");
        assert_eq!(listing(&d), ["a.txt"]);
        assert!(f.commit().is_err());
        assert!(f.write_all(b"x").is_err());
    }

    #[test]
    fn drop_without_commit_leaves_the_old_file_and_no_temporary() {
        let d = dir("drop");
        let p = d.join("b.nav");
        std::fs::write(&p, "complete\n").unwrap();
        {
            let mut f = AtomicFile::create(&p).unwrap();
            f.write_all(&[b'x'; 200_000]).unwrap();
        }
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "complete\n");
        assert_eq!(listing(&d), ["b.nav"]);
        // Never created: stays absent.
        drop(AtomicFile::create(&d.join("c.nav")).unwrap());
        assert_eq!(listing(&d), ["b.nav"]);
    }

    #[test]
    fn missing_folder_is_an_error_naming_nothing_written() {
        let d = dir("missing");
        let e = write_atomic_named(&d.join("no/such/x.csv"), "1").unwrap_err();
        assert!(e.contains("no/such/x.csv"), "{e}");
        assert_eq!(listing(&d).len(), 0);
    }
}
