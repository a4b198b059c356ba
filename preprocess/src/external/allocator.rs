//! The C allocator's habits that a memory budget must reckon with (glibc): freed small blocks
//! stay in the process's heap, and each thread that allocates gets its own arena, so memory
//! freed by one worker is not reused by another. Under `build --memory` the build asks for one
//! arena and gives freed memory back between its phases; the resident size then follows what
//! the build holds (2 M generated at `--memory 64M`: 68 → 55 MiB peak, about 10 % slower).
//! Elsewhere these do nothing.

/// Makes every thread allocate from one arena. Call before the worker threads start.
pub fn single_arena() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const M_ARENA_MAX: i32 = -8;
        extern "C" {
            fn mallopt(param: i32, value: i32) -> i32;
        }
        // SAFETY: mallopt only changes the allocator's tuning.
        unsafe {
            mallopt(M_ARENA_MAX, 1);
        }
    }
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
