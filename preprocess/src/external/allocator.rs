//! The C allocator's habits that a memory budget must reckon with (glibc): freed small blocks
//! stay in the process's heap, and each thread that allocates gets its own arena, so memory
//! freed by one worker is not reused by another. Under `build --memory` the build asks for one
//! arena per [`BUDGET_PER_ARENA`] of its budget (at least one) and gives freed memory back
//! between its phases; the resident size then follows what the build holds. One arena is
//! what a tight budget needs (2 M generated at `--memory 64M`: 68 → 55 MiB peak), but the
//! workers then queue on its lock (10 M generated at `--memory 1G`, two runs each: the
//! simplification 14.9 / 14.3 s with two arenas against 19.0 / 18.2 s with one, its peak
//! 366 / 344 against 333 / 333 MiB).
//! Elsewhere these do nothing.

/// The budget that pays for one more allocator arena.
pub const BUDGET_PER_ARENA: u64 = 512 << 20;

/// Limits the allocator to one arena per [`BUDGET_PER_ARENA`] of `budget` bytes, at least
/// one, and keeps freed heap tops returned to the system. Call before the worker threads
/// start.
pub fn arenas_for_budget(budget: u64) {
    let arenas = (budget / BUDGET_PER_ARENA).clamp(1, 64) as i32;
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const M_ARENA_MAX: i32 = -8;
        // Setting the trim threshold also stops glibc from raising it (and the mmap
        // threshold) as blocks are freed, which let a 2 M build at `--memory 64M` peak at
        // 69.5 MiB once in CI; with it the same build peaks at 48 MiB here.
        const M_TRIM_THRESHOLD: i32 = -1;
        extern "C" {
            fn mallopt(param: i32, value: i32) -> i32;
        }
        // SAFETY: mallopt only changes the allocator's tuning.
        unsafe {
            mallopt(M_ARENA_MAX, arenas);
            mallopt(M_TRIM_THRESHOLD, 128 << 10);
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    let _ = arenas;
}

/// Gives the heap's free memory back to the system.
pub fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn malloc_trim(pad: usize) -> i32;
        }
        // SAFETY: glibc's malloc_trim only returns free heap pages to the system.
        unsafe {
            malloc_trim(0);
        }
    }
}
