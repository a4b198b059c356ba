//! Fallible record streams fed to consumers that take plain values (the external sort): the
//! first error stops the stream and is kept for the caller to check.

use std::io;

/// The values of a stream of results, stopping at the first error (kept in `error`).
pub(super) fn ok_values<'a, T>(
    results: impl Iterator<Item = io::Result<T>> + 'a,
    error: &'a mut Option<io::Error>,
) -> impl Iterator<Item = T> + 'a {
    results.map_while(move |r| match r {
        Ok(v) => Some(v),
        Err(e) => {
            *error = Some(e);
            None
        }
    })
}

pub(super) fn check(error: Option<io::Error>) -> io::Result<()> {
    error.map_or(Ok(()), Err)
}
