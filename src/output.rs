//! Writing output files safely: every file is written to a temporary file in
//! the same folder and renamed into place, so a reader never sees half a file
//! and a write that fails leaves nothing behind. [`write_atomic`] writes bytes
//! held in memory; [`write_atomic_with`] streams a file through a buffered
//! writer, so that large files need not be built in memory first.
//! [`Written`] lists the files a run wrote and times the writing.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::error::{Error, Result};

/// Capacity of the buffer [`write_atomic_with`] streams through.
const BUFFER: usize = 1 << 20;

/// Writes `bytes` to `path` atomically (temporary file, sync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes `path` atomically from `fill`, which streams the contents into a
/// buffered writer on a temporary file in the same folder; the file is
/// synced and renamed into place once `fill` returns, and removed when
/// anything fails.
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<()> {
    let io = |e: std::io::Error| Error::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    };
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut w = BufWriter::with_capacity(BUFFER, File::create(&tmp)?);
        fill(&mut w)?;
        let f = w.into_inner().map_err(|e| e.into_error())?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

/// The files written into one folder, by name in the order written, with
/// their sizes and the seconds spent writing them.
#[derive(Clone, Debug)]
pub struct Written {
    dir: PathBuf,
    /// File names, relative to the folder.
    pub files: Vec<String>,
    /// Bytes written, all files together.
    pub bytes: u64,
    /// Seconds spent in [`Written::write`], all files together.
    pub seconds: f64,
}

impl Written {
    /// Nothing written yet into `dir`.
    pub fn new(dir: &Path) -> Written {
        Written {
            dir: dir.to_path_buf(),
            files: Vec::new(),
            bytes: 0,
            seconds: 0.0,
        }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Writes the file `name` of the folder with `write` (given its path),
    /// timed, and lists it once written.
    pub fn write(&mut self, name: &str, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
        let path = self.dir.join(name);
        let t = Instant::now();
        write(&path)?;
        let seconds = t.elapsed().as_secs_f64();
        let bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
        tracing::info!(file = name, bytes, seconds, "wrote");
        self.files.push(name.to_string());
        self.bytes += bytes;
        self.seconds += seconds;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_replaces_without_leaving_temporaries() {
        let dir = std::env::temp_dir().join(format!("cgfem-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.json");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        let missing = dir.join("no/such/dir/b.json");
        assert!(matches!(
            write_atomic(&missing, b"x"),
            Err(Error::Io { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failed_stream_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("cgfem-out-stream-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.vtu");
        write_atomic(&p, b"old").unwrap();
        let failed = write_atomic_with(&p, |w| {
            w.write_all(b"half a file")?;
            Err(std::io::Error::other("the encoder stopped"))
        });
        match failed {
            Err(Error::Io { reason, .. }) => assert!(reason.contains("encoder stopped")),
            other => panic!("expected Error::Io, got {other:?}"),
        }
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        let mut written = Written::new(&dir);
        written
            .write("b.txt", |path| write_atomic(path, b"12345"))
            .unwrap();
        assert_eq!(
            (written.files.as_slice(), written.bytes),
            (&["b.txt".to_string()][..], 5)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
