//! The process's memory: how much a large allocation may take, asked before making it (an
//! allocation that fails aborts the process, `memory allocation of N bytes failed`, so a render
//! whose film cannot fit is refused up front with the figure and what to do instead); handing
//! freed heap back to the system; and vectors on huge pages for the arrays the CPU reference
//! reads at random.

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
/// lavapipe's peak (docs/bench-log.md, the scene's memory). Call it once the set-up's temporaries
/// are gone, before the renderer's own memory is made.
pub fn release_free_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free memory to the system; it may be called at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// An empty vector with room for `capacity` values, whose memory Linux is asked to back with
/// 2 MiB transparent huge pages when it is first written (`MADV_HUGEPAGE` on the 2 MiB blocks
/// inside it), for the large arrays the CPU reference reads at random (the BVH's nodes, the
/// leaves' triangles): a ray's walk through tens of MB then misses the TLB far less often.
/// Debian's default THP mode is "madvise", under which nothing is on huge pages unasked. Fill
/// it without growing it (`extend_from_slice`, rayon's `par_extend`), so that its pages are
/// first touched where the advice holds. Advised before the first write, a page is made huge
/// when it is faulted in; advising a filled array instead needs `MADV_COLLAPSE`, which copies
/// every page (about 3 ms per MB here, 0.4 s for the 1M-triangle scene; docs/bench-log.md). A hint
/// only: where the system refuses it (huge pages off, another OS) nothing changes, and the
/// contents never depend on it.
pub fn huge_page_vec<T>(capacity: usize) -> Vec<T> {
    let v = Vec::with_capacity(capacity);
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let start = v.as_ptr() as usize;
        let end = start + capacity * std::mem::size_of::<T>();
        let first = start.next_multiple_of(HUGE);
        let last = end / HUGE * HUGE;
        if last > first {
            // SAFETY: the range lies inside the vector's allocation and is aligned to the page
            // size; the advice changes how its pages are backed, never what they hold.
            unsafe {
                libc::madvise(
                    first as *mut libc::c_void,
                    last - first,
                    libc::MADV_HUGEPAGE,
                );
            }
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector holds its room and takes its values as any other, large (several 2 MiB
    /// blocks) or small (none), and the advice leaves the memory it covers readable and
    /// writable.
    #[test]
    fn huge_page_vectors_hold_what_is_put_in_them() {
        for n in [0usize, 10, 3_000_000] {
            let mut v: Vec<u32> = huge_page_vec(n);
            let room = v.capacity();
            assert!(v.is_empty() && room >= n);
            v.extend((0..n as u32).map(|i| i.wrapping_mul(2_654_435_761)));
            assert_eq!((v.len(), v.capacity()), (n, room), "filled without growing");
            assert!(v
                .iter()
                .enumerate()
                .all(|(i, &x)| x == (i as u32).wrapping_mul(2_654_435_761)));
        }
    }
}
