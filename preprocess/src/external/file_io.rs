//! Two things Linux does for the staged files that `std` does not: giving an unnamed
//! (`O_TMPFILE`) file a name, and reading one file from several places at once.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

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
        use std::os::unix::fs::FileExt;
        let n = self.file.read_at(buf, self.at)?;
        self.at += n as u64;
        Ok(n)
    }
}
