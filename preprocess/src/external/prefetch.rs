//! Running a serial producer one item ahead of its consumer, on its own thread.
//!
//! The out-of-core build's leaf groups are joined from the staged files by one thread (a
//! serial walk over sorted record files), then encoded in parallel and stored by another: in
//! turn, one core idled through each join. Here the next group is joined while the current one
//! is encoded. The channel holds no item (a rendezvous), so at most two items are alive: the
//! one being consumed and the one made (or being made) next.
//!
//! The producer's thread is not one of the build's rayon workers: it must not call rayon's
//! parallel iterators (they would run on rayon's global pool, beside the pool `--threads`
//! sized). With a single worker (`--threads 1`) the producer runs inline, on the caller's
//! thread, so the build keeps to one thread.

use std::io;
use std::sync::mpsc::sync_channel;

/// A fallible source of items, `Ok(None)` at the end.
pub type Next<'a, T> = dyn FnMut() -> io::Result<Option<T>> + 'a;

/// Calls `consume` with a source giving `produce`'s items in order, `produce` running on its
/// own thread one item ahead. `produce` is not called again after it returns an error or the
/// end; when `consume` returns early, `produce` stops after the item it is making.
pub fn one_ahead<T: Send, R>(
    mut produce: impl FnMut() -> io::Result<Option<T>> + Send,
    consume: impl FnOnce(&mut Next<'_, T>) -> R,
) -> R {
    if rayon::current_num_threads() <= 1 {
        return consume(&mut ending_once(produce));
    }
    std::thread::scope(|scope| {
        let (sender, receiver) = sync_channel::<io::Result<Option<T>>>(0);
        scope.spawn(move || loop {
            let item = produce();
            let last = !matches!(item, Ok(Some(_)));
            // A closed channel: the consumer stopped early.
            if sender.send(item).is_err() || last {
                break;
            }
        });
        // `next` (and with it the receiver) is dropped when `consume` returns, so a producer
        // waiting to hand over an item is released before the scope joins it.
        let mut next = ending_once(move || {
            receiver
                .recv()
                .map_err(|_| io::Error::other("the producing thread stopped"))?
        });
        consume(&mut next)
    })
}

/// `source`, not called again once it has given an error or the end (then the end, again).
fn ending_once<T>(
    mut source: impl FnMut() -> io::Result<Option<T>>,
) -> impl FnMut() -> io::Result<Option<T>> {
    let mut ended = false;
    move || {
        if ended {
            return Ok(None);
        }
        let item = source();
        ended = !matches!(item, Ok(Some(_)));
        item
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs `f` inline (one worker) and with the producer on its own thread (two).
    fn in_both_modes(f: impl Fn() + Sync) {
        for workers in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(workers)
                .build()
                .unwrap();
            pool.install(&f);
        }
    }

    #[test]
    fn gives_every_item_in_order_then_the_end() {
        in_both_modes(|| {
            let mut n = 0;
            let got = one_ahead(
                || {
                    n += 1;
                    Ok((n <= 100).then_some(n))
                },
                |next| {
                    let mut got = Vec::new();
                    while let Some(x) = next().unwrap() {
                        got.push(x);
                    }
                    assert!(next().unwrap().is_none(), "the end repeats");
                    got
                },
            );
            assert_eq!(got, (1..=100).collect::<Vec<_>>());
            assert_eq!(n, 101, "nothing is made after the end");
        });
    }

    #[test]
    fn an_error_reaches_the_consumer_and_stops_the_producer() {
        in_both_modes(|| {
            let mut calls = 0;
            let result = one_ahead(
                || {
                    calls += 1;
                    match calls {
                        1 => Ok(Some(1)),
                        _ => Err(io::Error::other("disk full")),
                    }
                },
                |next| {
                    assert_eq!(next().unwrap(), Some(1));
                    let error = next().map(|_| ());
                    assert!(next().unwrap().is_none(), "the end after an error");
                    error
                },
            );
            assert_eq!(result.unwrap_err().to_string(), "disk full");
            assert_eq!(calls, 2, "nothing is made after an error");
        });
    }

    #[test]
    fn with_one_worker_the_producer_runs_inline() {
        for (workers, inline) in [(1, true), (2, false)] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(workers)
                .build()
                .unwrap();
            let (consumer, producers) = pool.install(|| {
                let mut producers = Vec::new();
                let consumer = std::thread::current().id();
                one_ahead(
                    || {
                        producers.push(std::thread::current().id());
                        Ok((producers.len() <= 3).then_some(()))
                    },
                    |next| while next().unwrap().is_some() {},
                );
                (consumer, producers)
            });
            assert_eq!(producers.len(), 4);
            assert!(
                producers.iter().all(|&p| (p == consumer) == inline),
                "{workers} worker(s)"
            );
        }
    }

    #[test]
    fn a_consumer_that_stops_early_releases_the_producer() {
        let result: Option<u64> = one_ahead(
            || Ok(Some(vec![0u8; 1024])),
            |next| next().unwrap().map(|v| v.len() as u64),
        );
        // Returning at all shows the endless producer was released.
        assert_eq!(result, Some(1024));
    }
}
