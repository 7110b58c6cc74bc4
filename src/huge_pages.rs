//! Huge pages for the solver's arrays: the compute commands (`run`,
//! `bench`) run with glibc's allocator asking the kernel for transparent
//! huge pages.
//!
//! Why: at 100² a CG iteration streams the matrix (9.2 MB), the line
//! factors (~6.5 MB), their single-precision copy and a dozen vectors of
//! 240 kB, some 5,000 pages of 4 KiB, past the processor's TLB: every few
//! cache lines a page walk. Most hosts ship transparent huge pages in
//! `madvise` mode (given to a region only when asked for), and glibc asks
//! only when its tunable `glibc.malloc.hugetlb=1` is set; in `always` mode
//! the heap has them already, and glibc then asks nothing. Measured on
//! sphere-drape-100's first 0.5 s, one thread, three alternated runs each
//! (docs/benchmarks.md 1aj): solve stage 7.65–7.93 s → 6.17–6.43 s, wall
//! 14.2–15.0 s → 12.4–12.9 s. Advising only the blocks of 2 MiB and more,
//! from a global allocator, moved 10 MB onto huge pages instead of 51 MB
//! and left the solve at 7.1–7.8 s: the vectors and the line packs matter
//! as much as the matrix.
//!
//! How: glibc reads its tunables once, when the program starts, so a
//! compute command whose environment lacks the tunable executes itself
//! again with it added (the same process, arguments and `argv[0]`). Where
//! that cannot help or cannot be done (not glibc, transparent huge pages
//! off or always on, the tunable already set either way, no path to the
//! executable) it carries on as it is. Placement changes no result: the
//! solver's arithmetic does not depend on addresses.

/// glibc's tunable for transparent huge pages in `malloc` (glibc ≥ 2.35;
/// older versions ignore it).
pub const TUNABLE: &str = "glibc.malloc.hugetlb";

/// Where the kernel says whether it offers transparent huge pages.
const THP_MODE: &str = "/sys/kernel/mm/transparent_hugepage/enabled";

/// `GLIBC_TUNABLES` with huge pages asked for, given its current value;
/// `None` if it already says something about them (the user's word
/// stands, and a process executed again does not do so twice).
pub fn tunables_with_huge_pages(current: Option<&str>) -> Option<String> {
    match current {
        Some(c) if c.contains(TUNABLE) => None,
        Some(c) if !c.is_empty() => Some(format!("{c}:{TUNABLE}=1")),
        _ => Some(format!("{TUNABLE}=1")),
    }
}

/// Whether the kernel's mode (`THP_MODE`'s text, the current choice in
/// brackets) gives transparent huge pages where a process asks for them,
/// and only there: the one mode where glibc's tunable changes anything.
pub fn thp_on_request(mode: &str) -> bool {
    mode.contains("[madvise]")
}

/// [`thp_on_request`] of this machine's kernel (false where it does not
/// say).
pub fn kernel_gives_on_request() -> bool {
    std::fs::read_to_string(THP_MODE).is_ok_and(|m| thp_on_request(&m))
}

/// Executes this program again with huge pages asked for, if it runs on
/// glibc without them and the kernel gives them on request; returns only
/// when it did not (module doc). Call first thing in `main`, before any thread starts.
pub fn ensure() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        use std::os::unix::process::CommandExt;
        // A value that is not UTF-8 is the user's: left as it is.
        let current = match std::env::var_os("GLIBC_TUNABLES").map(|c| c.into_string()) {
            None => None,
            Some(Ok(c)) => Some(c),
            Some(Err(_)) => return,
        };
        let Some(value) = tunables_with_huge_pages(current.as_deref()) else {
            return;
        };
        if !kernel_gives_on_request() {
            return;
        }
        let Ok(exe) = std::env::current_exe() else {
            return;
        };
        let mut args = std::env::args_os();
        let mut command = std::process::Command::new(exe);
        if let Some(arg0) = args.next() {
            command.arg0(arg0);
        }
        // `exec` returns only on failure; the run goes on without.
        let _ = command.args(args).env("GLIBC_TUNABLES", value).exec();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tunable_is_added_once_and_never_over_the_users() {
        let added = "glibc.malloc.hugetlb=1";
        assert_eq!(tunables_with_huge_pages(None).as_deref(), Some(added));
        assert_eq!(tunables_with_huge_pages(Some("")).as_deref(), Some(added));
        assert_eq!(
            tunables_with_huge_pages(Some("glibc.malloc.arena_max=2")).as_deref(),
            Some("glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1")
        );
        // Set once (this module's own re-execution), or turned off.
        assert_eq!(tunables_with_huge_pages(Some(added)), None);
        assert_eq!(
            tunables_with_huge_pages(Some("glibc.malloc.hugetlb=0")),
            None
        );
    }

    #[test]
    fn huge_pages_are_asked_for_only_where_asking_changes_anything() {
        assert!(thp_on_request("always [madvise] never\n"));
        assert!(!thp_on_request("[always] madvise never\n"));
        assert!(!thp_on_request("always madvise [never]\n"));
        assert!(!thp_on_request(""));
    }
}
