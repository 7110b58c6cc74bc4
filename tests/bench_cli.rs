//! `drapery bench` end to end, at toy sizes (the studies themselves are
//! run by hand and reported in docs; speed is never asserted in tests).

use std::process::Command;

#[test]
fn bench_scale_writes_csv_and_svg() {
    let out = std::env::temp_dir().join(format!("drapery-bench-{}", uuid::Uuid::now_v7()));
    let status = Command::new(env!("CARGO_BIN_EXE_drapery"))
        .args([
            "bench",
            "scale",
            "--sizes",
            "6,10",
            "--duration",
            "0.05",
            "--out",
        ])
        .arg(&out)
        .status()
        .expect("runs");
    assert!(status.success());
    let csv = std::fs::read_to_string(out.join("scale.csv")).expect("scale.csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(lines[0].starts_with("n,particles,steps,"));
    assert!(lines[1].starts_with("6,36,12,"), "{csv}");
    assert!(lines[2].starts_with("10,100,12,"), "{csv}");
    let svg = std::fs::read_to_string(out.join("scale.svg")).expect("scale.svg");
    assert!(
        svg.starts_with("<svg") && svg.contains("fit:"),
        "{}",
        &svg[..200.min(svg.len())]
    );

    let bad = Command::new(env!("CARGO_BIN_EXE_drapery"))
        .args(["bench", "scale", "--sizes", "10,6", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--sizes"));
}
