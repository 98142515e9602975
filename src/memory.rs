//! How much memory a large allocation may take, asked before making it: an allocation that
//! fails aborts the process (`memory allocation of N bytes failed`), so a render whose film
//! cannot fit is refused up front with the figure and what to do instead.

/// The bytes this process can still allocate, as far as the system says: the least of the
/// kernel's estimate of available memory (`MemAvailable`), the room left under a cgroup v2
/// memory limit, and the room left under the address-space limit (`ulimit -v`). `None` when
/// none of them is known.
pub fn available_bytes() -> Option<u64> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let kib_field = |text: &str, key: &str| -> Option<u64> {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|r| r.split_whitespace().next())
            .and_then(|v| v.parse::<u64>().ok())
            .map(|k| k * 1024)
    };
    let mut least: Option<u64> = None;
    let mut take = |v: u64| least = Some(least.map_or(v, |l| l.min(v)));
    if let Some(v) = read("/proc/meminfo").and_then(|t| kib_field(&t, "MemAvailable:")) {
        take(v);
    }
    if let (Some(max), Some(cur)) = (
        read("/sys/fs/cgroup/memory.max").and_then(|t| t.trim().parse::<u64>().ok()),
        read("/sys/fs/cgroup/memory.current").and_then(|t| t.trim().parse::<u64>().ok()),
    ) {
        take(max.saturating_sub(cur));
    }
    #[cfg(unix)]
    {
        let mut lim = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes the struct it is given.
        let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut lim) } == 0;
        if ok && lim.rlim_cur != libc::RLIM_INFINITY {
            let used = read("/proc/self/status")
                .and_then(|t| kib_field(&t, "VmSize:"))
                .unwrap_or(0);
            // rlim_t is u64 here, narrower or signed elsewhere.
            #[allow(clippy::unnecessary_cast)]
            let limit = lim.rlim_cur as u64;
            take(limit.saturating_sub(used));
        }
    }
    least
}

/// Fails when `bytes` are more than [`available_bytes`]: `what` says what needs them (it
/// starts the message), `advice` what to do instead.
pub fn check(bytes: u64, what: &str, advice: &str) -> anyhow::Result<()> {
    if let Some(free) = available_bytes() {
        if bytes > free {
            anyhow::bail!(
                "{what} needs about {} MiB, and {} MiB are available; {advice}",
                bytes >> 20,
                free >> 20
            );
        }
    }
    Ok(())
}

/// Hands the heap's free memory back to the system (glibc's `malloc_trim`; nothing elsewhere).
/// glibc keeps what a program frees for reuse (in per-thread arenas), and after a large free it
/// raises the size from which it maps big blocks apart, so temporaries of tens of MB can stay
/// in the heap once freed: after the 1M-triangle scene's load and BVH build, 35 MB of
/// lavapipe's peak (BENCHMARKS.md, the scene's memory). Call it once the set-up's temporaries
/// are gone, before the renderer's own memory is made.
pub fn release_free_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free memory to the system; it may be called at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Asks Linux to back the memory of `data`, a large array that the renderers read at random
/// (the BVH's nodes, the leaves' triangles), with 2 MiB transparent huge pages: a ray's walk
/// through a tree of tens of MB then misses the TLB far less often. The pages already there are
/// collapsed at once (`MADV_COLLAPSE`, Linux 6.1 and later); on older kernels `MADV_HUGEPAGE`
/// lets the kernel's background thread do it later. Only the 2 MiB blocks that lie wholly inside
/// `data` are advised, so no other allocation is touched. A hint: where the system refuses it
/// (huge pages off, another OS) nothing changes, and the contents never do.
pub fn advise_huge_pages<T>(data: &[T]) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const HUGE: usize = 2 << 20;
        let start = data.as_ptr() as usize;
        let end = start + std::mem::size_of_val(data);
        let first = start.next_multiple_of(HUGE);
        let last = end / HUGE * HUGE;
        if last > first {
            let (p, len) = (first as *mut libc::c_void, last - first);
            // SAFETY: the range lies inside `data`'s allocation and is aligned to the page
            // size; both advices change how its pages are backed, never their contents.
            unsafe {
                libc::madvise(p, len, libc::MADV_HUGEPAGE);
                libc::madvise(p, len, libc::MADV_COLLAPSE);
            }
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    let _ = data;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The advice keeps every value (an advice that discarded pages, as `MADV_DONTNEED` does,
    /// would read back zeros), on an array spanning several 2 MiB blocks, at an unaligned start,
    /// and on arrays too small to hold one block.
    #[test]
    fn huge_page_advice_keeps_the_contents() {
        let data: Vec<u32> = (0..3_000_000u32)
            .map(|i| i.wrapping_mul(2_654_435_761))
            .collect();
        advise_huge_pages(&data);
        advise_huge_pages(&data[1..]);
        advise_huge_pages(&data[..10]);
        advise_huge_pages::<u32>(&[]);
        assert!(data
            .iter()
            .enumerate()
            .all(|(i, &v)| v == (i as u32).wrapping_mul(2_654_435_761)));
    }
}
