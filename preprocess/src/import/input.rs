//! Buffered input shared by all readers: a plain or gzip-compressed file behind one large
//! buffer, a hand-written tokenizer that tracks line numbers (text formats), and fixed-size
//! reads (binary formats). Nothing here allocates in proportion to counts found in a file.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

use flate2::read::MultiGzDecoder;

use super::error::{ImportErrorKind as K, Location};

const BUF_SIZE: usize = 1 << 20;

/// Most elements to pre-allocate for a count read from a file whose size does not bound it.
pub(crate) const MAX_PREALLOC: u64 = 1 << 20;

/// Byte classes for the tokenizer.
const TOKEN: u8 = 0;
const SPACE: u8 = 1;
const NEWLINE: u8 = 2;
const HASH: u8 = 3;

static CLASS: [u8; 256] = {
    let mut t = [TOKEN; 256];
    t[b' ' as usize] = SPACE;
    t[b'\t' as usize] = SPACE;
    t[b'\r' as usize] = SPACE;
    t[0x0b] = SPACE;
    t[0x0c] = SPACE;
    t[b'\n' as usize] = NEWLINE;
    t[b'#' as usize] = HASH;
    t
};

pub(crate) struct Input {
    src: Box<dyn Read>,
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    eof: bool,
    gz: bool,
    /// Stream bytes before `buf[0]`.
    base: u64,
    /// Total stream size where known (uncompressed files).
    size: Option<u64>,
    /// 1-based line number of the byte at `pos` (maintained by the text functions only).
    pub line: u64,
}

impl Input {
    /// Opens `path`, decompressing on the fly when `gz`.
    pub fn open(path: &Path, gz: bool) -> Result<Self, K> {
        let file = File::open(path).map_err(K::Io)?;
        let meta = file.metadata().map_err(K::Io)?;
        if meta.is_dir() {
            return Err(K::Io(io::Error::other("is a directory")));
        }
        Ok(if gz {
            Self::new(Box::new(MultiGzDecoder::new(file)), true, None)
        } else {
            Self::new(Box::new(file), false, Some(meta.len()))
        })
    }

    /// Reads bytes held in memory, decompressing on the fly when `gz`: the same reader a file
    /// gets, for [`load_mesh_bytes`](super::load_mesh_bytes). The buffer starts no larger than
    /// the bytes need (it grows as a file's does).
    pub fn from_bytes(bytes: Vec<u8>, gz: bool) -> Self {
        if gz {
            let src = Box::new(MultiGzDecoder::new(io::Cursor::new(bytes)));
            Self::with_buffer(src, true, None, BUF_SIZE)
        } else {
            let size = bytes.len();
            let capacity = (size + 1).clamp(64, BUF_SIZE);
            Self::with_buffer(
                Box::new(io::Cursor::new(bytes)),
                false,
                Some(size as u64),
                capacity,
            )
        }
    }

    /// Wraps any reader; `size` is its total length if known.
    pub fn new(src: Box<dyn Read>, gz: bool, size: Option<u64>) -> Self {
        Self::with_buffer(src, gz, size, BUF_SIZE)
    }

    fn with_buffer(src: Box<dyn Read>, gz: bool, size: Option<u64>, capacity: usize) -> Self {
        Input {
            src,
            buf: vec![0; capacity],
            pos: 0,
            end: 0,
            eof: false,
            gz,
            base: 0,
            size,
            line: 1,
        }
    }

    /// Bytes left to read, where the size is known.
    pub fn remaining(&self) -> Option<u64> {
        self.size
            .map(|s| s.saturating_sub(self.base + self.pos as u64))
    }

    /// How much to pre-allocate for `count` items: everything when the file size has already
    /// bounded the count, at most [`MAX_PREALLOC`] otherwise.
    pub fn prealloc(&self, count: u64, bounded: bool) -> usize {
        if bounded {
            count as usize
        } else {
            count.min(MAX_PREALLOC) as usize
        }
    }

    fn io_err(&self, e: io::Error) -> K {
        if self.gz {
            K::Gzip(e)
        } else {
            K::Io(e)
        }
    }

    /// Reads more data, keeping `buf[pos..end]` (moved to the front). Returns false when the
    /// input is exhausted.
    fn fill(&mut self) -> Result<bool, K> {
        if self.eof {
            return Ok(false);
        }
        if self.pos > 0 {
            self.buf.copy_within(self.pos..self.end, 0);
            self.base += self.pos as u64;
            self.end -= self.pos;
            self.pos = 0;
        }
        if self.end == self.buf.len() {
            let n = self.buf.len();
            self.buf.resize(2 * n, 0);
        }
        loop {
            match self.src.read(&mut self.buf[self.end..]) {
                Ok(0) => {
                    self.eof = true;
                    return Ok(false);
                }
                Ok(n) => {
                    self.end += n;
                    return Ok(true);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(self.io_err(e)),
            }
        }
    }

    // ---------------------------------------------------------------- text

    /// Skips whitespace, newlines and (with `comments`) `#` comments up to the next token.
    /// Returns false at the end of the input.
    pub fn skip_blank(&mut self, comments: bool) -> Result<bool, K> {
        loop {
            while self.pos < self.end {
                match CLASS[self.buf[self.pos] as usize] {
                    SPACE => self.pos += 1,
                    NEWLINE => {
                        self.pos += 1;
                        self.line += 1;
                    }
                    HASH if comments => self.skip_line()?,
                    _ => return Ok(true),
                }
            }
            if !self.fill()? {
                return Ok(false);
            }
        }
    }

    /// Consumes everything up to and including the next newline.
    pub fn skip_line(&mut self) -> Result<(), K> {
        loop {
            if let Some(i) = self.buf[self.pos..self.end]
                .iter()
                .position(|&c| c == b'\n')
            {
                self.pos += i + 1;
                self.line += 1;
                return Ok(());
            }
            self.pos = self.end;
            if !self.fill()? {
                return Ok(());
            }
        }
    }

    /// Skips spaces and tabs within the line. Returns the byte class there, or None at the end
    /// of the input.
    fn skip_spaces(&mut self) -> Result<Option<u8>, K> {
        loop {
            while self.pos < self.end {
                let c = CLASS[self.buf[self.pos] as usize];
                if c != SPACE {
                    return Ok(Some(c));
                }
                self.pos += 1;
            }
            if !self.fill()? {
                return Ok(None);
            }
        }
    }

    /// The next whitespace-delimited token on the current line, or None at the end of the line
    /// (the newline is not consumed), at a comment (with `comments`) or at the end of the input.
    pub fn token(&mut self, comments: bool) -> Result<Option<&[u8]>, K> {
        match self.skip_spaces()? {
            None | Some(NEWLINE) => return Ok(None),
            Some(HASH) if comments => return Ok(None),
            _ => {}
        }
        let mut len = 1;
        loop {
            while self.pos + len < self.end {
                match CLASS[self.buf[self.pos + len] as usize] {
                    TOKEN => len += 1,
                    HASH if !comments => len += 1,
                    _ => {
                        let start = self.pos;
                        self.pos += len;
                        return Ok(Some(&self.buf[start..start + len]));
                    }
                }
            }
            if !self.fill()? {
                let start = self.pos;
                self.pos += len;
                return Ok(Some(&self.buf[start..start + len]));
            }
        }
    }

    /// At the end of a record: skips trailing spaces (and a comment, with `comments`) and the
    /// newline. Returns false, consuming nothing more, if another token follows on the line.
    pub fn end_line(&mut self, comments: bool) -> Result<bool, K> {
        match self.skip_spaces()? {
            None => Ok(true),
            Some(NEWLINE) => {
                self.pos += 1;
                self.line += 1;
                Ok(true)
            }
            Some(HASH) if comments => {
                self.skip_line()?;
                Ok(true)
            }
            _ => Ok(false),
        }
    }

    /// One raw line without its newline (and a trailing `\r`); None at the end of the input.
    /// Lines longer than `max` bytes are a header error.
    pub fn read_line(&mut self, max: usize) -> Result<Option<&[u8]>, K> {
        let mut scanned = 0;
        loop {
            if let Some(i) = self.buf[self.pos + scanned..self.end]
                .iter()
                .position(|&c| c == b'\n')
            {
                let start = self.pos;
                let mut stop = start + scanned + i;
                self.pos = stop + 1;
                self.line += 1;
                if stop > start && self.buf[stop - 1] == b'\r' {
                    stop -= 1;
                }
                return Ok(Some(&self.buf[start..stop]));
            }
            scanned = self.end - self.pos;
            if scanned > max {
                return Err(K::Header {
                    at: Location::Line(self.line),
                    msg: format!("line longer than {max} bytes"),
                });
            }
            if !self.fill()? {
                if self.pos == self.end {
                    return Ok(None);
                }
                let start = self.pos;
                self.pos = self.end;
                self.line += 1;
                return Ok(Some(&self.buf[start..self.end]));
            }
        }
    }

    // ---------------------------------------------------------------- binary

    /// The next `n` bytes, or None if the input ends first.
    #[inline]
    pub fn bytes(&mut self, n: usize) -> Result<Option<&[u8]>, K> {
        while self.end - self.pos < n {
            if !self.fill()? {
                return Ok(None);
            }
        }
        let start = self.pos;
        self.pos += n;
        Ok(Some(&self.buf[start..start + n]))
    }

    /// Up to `n` bytes from the current position without consuming them (fewer at the end).
    pub fn peek(&mut self, n: usize) -> Result<&[u8], K> {
        while self.end - self.pos < n {
            if !self.fill()? {
                break;
            }
        }
        let stop = self.end.min(self.pos + n);
        Ok(&self.buf[self.pos..stop])
    }

    /// Skips `n` bytes. Returns false if the input ends first.
    pub fn skip_bytes(&mut self, mut n: u64) -> Result<bool, K> {
        loop {
            let here = ((self.end - self.pos) as u64).min(n);
            self.pos += here as usize;
            n -= here;
            if n == 0 {
                return Ok(true);
            }
            if !self.fill()? {
                return Ok(false);
            }
        }
    }

    /// Whether the input is exhausted.
    pub fn at_end(&mut self) -> Result<bool, K> {
        Ok(self.peek(1)?.is_empty())
    }

    /// Everything that is left.
    pub fn read_to_end(&mut self) -> Result<Vec<u8>, K> {
        let mut out = self.buf[self.pos..self.end].to_vec();
        self.pos = self.end;
        if !self.eof {
            self.src.read_to_end(&mut out).map_err(|e| self.io_err(e))?;
            self.eof = true;
        }
        Ok(out)
    }
}

/// Parses a decimal integer (optional sign).
#[inline]
pub(crate) fn parse_int(tok: &[u8]) -> Option<i64> {
    let (neg, digits) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.len() > 18 {
        return parse_int_slow(tok);
    }
    if digits.is_empty() {
        return None;
    }
    let mut v: i64 = 0;
    for &c in digits {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + d as i64;
    }
    Some(if neg { -v } else { v })
}

#[cold]
fn parse_int_slow(tok: &[u8]) -> Option<i64> {
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Parses a floating-point number (anything `f64::from_str` accepts).
#[inline]
pub(crate) fn parse_float(tok: &[u8]) -> Option<f64> {
    // Tokens are ASCII in every valid file; from_utf8 on a short slice is cheap.
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Checks a position; returns the non-finite error for vertex `vertex` otherwise.
#[inline]
pub(crate) fn check_finite(
    p: [f64; 3],
    vertex: u64,
    at: impl FnOnce() -> Location,
) -> Result<(), K> {
    if p[0].is_finite() && p[1].is_finite() && p[2].is_finite() {
        Ok(())
    } else {
        Err(K::NonFinite {
            at: at(),
            vertex,
            x: p[0],
            y: p[1],
            z: p[2],
        })
    }
}

/// Fan-triangulates polygon `poly` onto `out` (nothing for fewer than three corners).
#[inline]
pub(crate) fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}
