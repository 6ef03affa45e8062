//! glibc allocator tuning for a long-running server whose scene loads peak far above
//! what a resident scene keeps.

/// Hands the heap's free pages back to the OS. Parsing a GLB peaks well above what the
/// resident scene keeps (JSON, per-primitive buffers, the glTF extras), and glibc keeps
/// those pages mapped; without this a resident scene costs several times its size.
pub fn release_free_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free pages of glibc's own heap to the kernel.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Keeps large allocations (≥ 256 KiB) out of the heap: glibc otherwise raises its mmap
/// threshold to the size of each large block freed, after which blocks of that size
/// come from the heap, and a scene load's short-lived buffers (the GLB parse, the
/// walk-start sampler) leave resident fragments behind (seen: +7–9 MiB per scene).
pub fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes glibc's allocation policy for later allocations.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 * 1024);
    }
}
