//! `drapery run` executes itself again with glibc's huge-page tunable
//! (`drapery::huge_pages`), and leaves a user's own setting alone. What
//! shows it from outside: glibc then advises its heap `MADV_HUGEPAGE`,
//! which the kernel lists as the flag `hg` of the `[heap]` mapping. (The
//! environment is no witness: glibc rewrites `GLIBC_TUNABLES` in place.)

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Whether this machine is one where the command asks for huge pages and
/// glibc knows the tunable (2.35 and later; `getconf` says `glibc 2.36`).
fn applies() -> bool {
    let glibc = Command::new("getconf")
        .arg("GNU_LIBC_VERSION")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|v| {
            let (major, minor) = v.trim().strip_prefix("glibc ")?.split_once('.')?;
            Some((major.parse::<u32>().ok()?, minor.parse::<u32>().ok()?))
        });
    cfg!(all(target_os = "linux", target_env = "gnu"))
        && glibc.is_some_and(|v| v >= (2, 35))
        && drapery::huge_pages::kernel_gives_on_request()
}

/// Runs `drapery run` on a free fall of about a second with
/// `GLIBC_TUNABLES` set to `tunables` (or unset), and returns whether its
/// heap was seen advised for huge pages, and how often it was looked at.
fn heap_advised(tag: &str, tunables: Option<&str>) -> (bool, usize) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("huge-pages-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let spec = dir.join("fall.json");
    std::fs::write(
        &spec,
        r#"{"name": "fall", "cloth": {"grid": [40, 40], "size": [1, 1], "origin": [0, 0, 5]},
            "material": "cotton", "obstacles": [], "gravity": [0, 0, -9.81],
            "duration": 1.0, "fps": 30, "solver": {"dt": 0.001, "tolerance": 1e-8}}"#,
    )
    .expect("spec");
    let mut command = Command::new(env!("CARGO_BIN_EXE_drapery"));
    command
        .args(["run", "--format", "pc2", "--threads", "1", "--out"])
        .arg(dir.join("out"))
        .arg(&spec)
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    match tunables {
        Some(t) => command.env("GLIBC_TUNABLES", t),
        None => command.env_remove("GLIBC_TUNABLES"),
    };
    let mut child = command.spawn().expect("spawns");
    let smaps = format!("/proc/{}/smaps", child.id());
    let (mut advised, mut looks) = (false, 0);
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("waits") {
            break status;
        }
        if let Ok(text) = std::fs::read_to_string(&smaps) {
            let heap = text
                .lines()
                .skip_while(|l| !l.ends_with("[heap]"))
                .find_map(|l| l.strip_prefix("VmFlags:"));
            if let Some(flags) = heap {
                looks += 1;
                advised |= flags.split_whitespace().any(|f| f == "hg");
            }
        }
        assert!(start.elapsed() < Duration::from_secs(120), "the run hangs");
        std::thread::sleep(Duration::from_millis(5));
    };
    assert!(status.success(), "{status}");
    assert!(dir.join("out/stats.json").exists());
    (advised, looks)
}

#[test]
fn a_run_asks_for_huge_pages_unless_told_otherwise() {
    if !applies() {
        return;
    }
    assert!(heap_advised("unset", None).0);
    assert!(heap_advised("other", Some("glibc.malloc.arena_max=2")).0);
    // The user's word stands: the heap is never advised.
    let (advised, looks) = heap_advised("off", Some("glibc.malloc.hugetlb=0"));
    assert!(!advised && looks > 10, "{advised} after {looks} looks");
}
