//! Two things Linux does for the staged files that `std` does not: giving an unnamed
//! (`O_TMPFILE`) file a name, and reading one file from several places at once.

use std::fs::File;
use std::io::{self, Read, Write};
use std::os::unix::fs::FileExt;
use std::path::Path;

/// Gives the first `len` bytes of an unnamed temporary file the name `path` (a checkpoint's):
/// linked where the file system allows it (`link_unnamed`), so they are on disk once, else
/// copied there (and synced). Returns their CRC-32 and, where they were copied, the copy
/// opened for reading (the caller reads that from then on).
pub(crate) fn keep_unnamed_at(
    file: &File,
    len: u64,
    path: &Path,
) -> io::Result<(u32, Option<File>)> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(e),
        _ => {}
    }
    let mut copy = match link_unnamed(file, path) {
        Ok(()) => None,
        Err(_) => Some(io::BufWriter::with_capacity(1 << 20, File::create(path)?)),
    };
    let mut hasher = crc32fast::Hasher::new();
    let mut buffer = vec![0u8; 1 << 20];
    let mut at = 0;
    while at < len {
        let n = (len - at).min(buffer.len() as u64) as usize;
        file.read_exact_at(&mut buffer[..n], at)?;
        hasher.update(&buffer[..n]);
        if let Some(copy) = &mut copy {
            copy.write_all(&buffer[..n])?;
        }
        at += n as u64;
    }
    let reopened = match copy {
        Some(copy) => {
            copy.into_inner().map_err(|e| e.into_error())?.sync_all()?;
            Some(File::open(path)?)
        }
        None => None,
    };
    Ok((hasher.finalize(), reopened))
}

/// Gives an `O_TMPFILE` file the name `path` (`linkat` through `/proc/self/fd`); fails for a
/// file that was created with a name and unlinked, and off Linux.
pub(crate) fn link_unnamed(file: &File, path: &Path) -> io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use std::ffi::CString;
        use std::os::unix::ffi::OsStrExt;
        use std::os::unix::io::AsRawFd;
        let from = CString::new(format!("/proc/self/fd/{}", file.as_raw_fd()))?;
        let to = CString::new(path.as_os_str().as_bytes())?;
        // SAFETY: both are NUL-terminated paths that outlive the call.
        let r = unsafe {
            libc::linkat(
                libc::AT_FDCWD,
                from.as_ptr(),
                libc::AT_FDCWD,
                to.as_ptr(),
                libc::AT_SYMLINK_FOLLOW,
            )
        };
        if r == 0 {
            Ok(())
        } else {
            Err(io::Error::last_os_error())
        }
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = (file, path);
        Err(io::Error::from(io::ErrorKind::Unsupported))
    }
}

/// Reads a file from an offset of its own (`pread`): handles of one file share their offset,
/// and a staged file is read by several passes at once (the use counts beside the
/// barycentres' join).
pub struct ReadAt {
    pub(super) file: File,
    pub(super) at: u64,
}

impl Read for ReadAt {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.file.read_at(buf, self.at)?;
        self.at += n as u64;
        Ok(n)
    }
}
