//! How the process asks the system allocator for memory.
//!
//! A large request's operator is a few megabytes (1001 × 1001 positions: about 3 MB; 2001 ×
//! 2001: 13 MB) and lives as long as the operator cache keeps it. glibc's malloc serves blocks
//! that large by mapping fresh pages (above its mmap threshold, 128 KiB until a freed mapping
//! raises it) and gives freed memory at the heap's top back to the system (above its trim
//! threshold); either way the next request touches new pages, and every 4 KiB page costs a
//! fault on first touch (13 % of a cold 1001 × 1001 prediction where every block is fresh).
//! So the service raises both thresholds once, before any thread starts: blocks up to 32 MiB
//! come from the heap, and up to 64 MiB of freed memory is kept for reuse. Measured in the
//! server (docs/PERFORMANCE.md): 58–138 page faults a cold 1001 × 1001 request before, 1–29
//! after, and the request about 3 % faster. What the process holds stays bounded by what it
//! used at its peak (the operator cache bounds most of that).

/// Largest block served from the heap rather than mapped on its own, bytes.
const HEAP_BLOCKS_UP_TO: usize = 32 << 20;
/// Freed memory at the heap's top kept for reuse, bytes.
const KEEP_FREED: usize = 64 << 20;

/// Sets the allocator's thresholds (see the module docs). Call once, before threads start;
/// where the allocator is not glibc's this does nothing.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets malloc's parameters; it is called before any other thread
    // exists, so no allocation runs alongside it. A refusal (0) leaves glibc's defaults.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, HEAP_BLOCKS_UP_TO as libc::c_int);
        libc::mallopt(libc::M_TRIM_THRESHOLD, KEEP_FREED as libc::c_int);
    }
}
