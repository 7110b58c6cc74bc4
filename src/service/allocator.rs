//! The allocator's give-back rule for a long-running server.
//!
//! glibc's `malloc` raises its mmap threshold to the size of each large
//! block freed (up to 32 MiB), so after the first download of a result
//! the next ones are carved from the heap of whichever thread builds
//! them, and a heap keeps what it frees. Measured: twelve glb downloads of
//! 17.7 MB, one at a time, took the server's resident memory from 79 to
//! 345 MB and left it there (one per blocking thread's arena); with the
//! threshold fixed at [`MMAP_THRESHOLD`], 182 MB at most, and back after.

/// Blocks at least this large are mapped on their own and returned to the
/// system when freed: a frame of 10,000 particles is 120 kB, a download
/// megabytes, a solver's vectors below.
const MMAP_THRESHOLD: i32 = 1 << 20;

/// Fixes the threshold (glibc only; other allocators already return
/// large blocks).
pub fn return_large_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets a parameter of the allocator; called at
    // start, before any thread of the server allocates.
    #[allow(unsafe_code)]
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
    }
}
