//! Giving back the disk space of a temporary file's bytes already consumed, while the rest
//! is still read: the file keeps its size and offsets, the range reads as zeros and holds no
//! blocks (`fallocate` with `FALLOC_FL_PUNCH_HOLE`, Linux; ext4, xfs, btrfs and tmpfs allow
//! it). Passes that read a spool once, front to back, keep the temporary disk near what is
//! still unread instead of the whole file.

use std::fs::File;

/// Frees the whole blocks inside `start..end` of `file` (a block only partly inside stays).
/// Returns the bytes freed: 0 where the system or the file system cannot punch holes (the
/// caller's later truncation frees them then).
pub fn punch(file: &File, start: u64, end: u64) -> u64 {
    const BLOCK: u64 = 4096;
    let from = start.div_ceil(BLOCK) * BLOCK;
    let to = end / BLOCK * BLOCK;
    if to <= from {
        return 0;
    }
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::io::AsRawFd;
        // SAFETY: fallocate only changes the file's allocation; the range is in the file.
        let r = unsafe {
            libc::fallocate(
                file.as_raw_fd(),
                libc::FALLOC_FL_PUNCH_HOLE | libc::FALLOC_FL_KEEP_SIZE,
                from as libc::off_t,
                (to - from) as libc::off_t,
            )
        };
        if r == 0 {
            return to - from;
        }
        0
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = file;
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Seek, SeekFrom, Write};
    use std::os::unix::fs::MetadataExt;

    #[test]
    fn a_punched_range_reads_as_zeros_and_holds_no_blocks() {
        let dir = tempfile::tempdir().unwrap();
        let mut file = tempfile::tempfile_in(dir.path()).unwrap();
        file.write_all(&vec![7u8; 1 << 20]).unwrap();
        file.sync_all().unwrap();
        let before = file.metadata().unwrap().blocks();
        let freed = punch(&file, 100, (1 << 20) - 100);
        if freed == 0 {
            return; // this file system cannot punch holes: nothing to check
        }
        assert_eq!(freed, (1 << 20) - 2 * 4096);
        assert_eq!(file.metadata().unwrap().len(), 1 << 20);
        assert!(file.metadata().unwrap().blocks() < before);
        let mut back = Vec::new();
        file.seek(SeekFrom::Start(0)).unwrap();
        file.read_to_end(&mut back).unwrap();
        assert!(back[..4096].iter().all(|&b| b == 7));
        assert!(back[4096..(1 << 20) - 4096].iter().all(|&b| b == 0));
        assert!(back[(1 << 20) - 4096..].iter().all(|&b| b == 7));
    }
}
