//! The loader thread: reads units through the memory map, off the render thread.
//!
//! A unit's patches are copied out of the map into one buffer (what the GPU upload takes) —
//! decoded on the way when the repository is packed (`Repository::read_patch`), so the render
//! thread never decodes — each patch's checksum checked the first time it is read: a
//! damaged patch fails the whole unit, naming the simplex, and the residency marks the unit
//! broken so its diamond never refines. The process holds no other copy of the repository:
//! the map is the only one, and the page cache decides what stays in memory.

use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::sync::Arc;
use std::thread::JoinHandle;

use tessera_core::repository::{Repository, RepositoryError};

/// A unit read by the loader.
#[derive(Debug)]
pub struct LoadedUnit {
    /// The unit (its diamond's index).
    pub unit: u32,
    /// The unit's patches back to back, in the order of `simplices`, each 8-aligned in the
    /// buffer; or why the unit could not be read.
    pub result: Result<UnitBytes, RepositoryError>,
}

/// The bytes of a unit's patches.
#[derive(Debug, Default)]
pub struct UnitBytes {
    /// Simplex, byte offset in `bytes`, byte length.
    pub patches: Vec<(u32, usize, usize)>,
    pub bytes: Vec<u8>,
    /// Time spent reading the patches out of the map (decoding them when packed), seconds.
    pub read_seconds: f64,
}

/// Reads unit `simplices` from `repo` (the work the thread does; callable directly).
pub fn read_unit(repo: &Repository, simplices: &[u32]) -> Result<UnitBytes, RepositoryError> {
    let start = std::time::Instant::now();
    let mut out = UnitBytes::default();
    for &t in simplices {
        let size = repo.decoded_patch_bytes(t as usize)?;
        let at = out.bytes.len().next_multiple_of(8);
        out.bytes.resize(at + size, 0);
        repo.read_patch(t as usize, &mut out.bytes[at..])?;
        out.patches.push((t, at, size));
    }
    out.read_seconds = start.elapsed().as_secs_f64();
    Ok(out)
}

/// A background thread that reads the units it is given, in order.
pub struct Loader {
    requests: Option<Sender<(u32, Vec<u32>)>>,
    results: Receiver<LoadedUnit>,
    thread: Option<JoinHandle<()>>,
}

impl Loader {
    /// Starts the thread over a shared repository.
    pub fn new(repo: Arc<Repository>) -> Loader {
        let (requests, inbox) = channel::<(u32, Vec<u32>)>();
        let (outbox, results) = channel();
        let thread = std::thread::Builder::new()
            .name("tessera-loader".into())
            .spawn(move || {
                for (unit, simplices) in inbox {
                    let result = read_unit(&repo, &simplices);
                    if outbox.send(LoadedUnit { unit, result }).is_err() {
                        break; // the caller is gone
                    }
                }
            })
            .expect("spawning the loader thread");
        Loader {
            requests: Some(requests),
            results,
            thread: Some(thread),
        }
    }

    /// Queues unit `unit` whose patches are `simplices`.
    pub fn submit(&self, unit: u32, simplices: Vec<u32>) {
        if let Some(tx) = &self.requests {
            // A send fails only when the thread died, which `finished` then reports.
            let _ = tx.send((unit, simplices));
        }
    }

    /// Every unit read since the last call, without waiting.
    pub fn finished(&self) -> Vec<LoadedUnit> {
        let mut out = Vec::new();
        loop {
            match self.results.try_recv() {
                Ok(unit) => out.push(unit),
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return out,
            }
        }
    }

    /// Waits for the next unit read (`None` when the thread is gone).
    pub fn wait(&self) -> Option<LoadedUnit> {
        self.results.recv().ok()
    }
}

impl Drop for Loader {
    fn drop(&mut self) {
        self.requests = None; // closes the channel: the thread's loop ends
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
