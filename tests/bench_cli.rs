//! `drapery bench` end to end, at toy sizes (the studies themselves are
//! run by hand and reported in docs; speed is never asserted in tests).

mod support;

use std::process::Command;

use support::data_dir;

#[test]
fn bench_scale_writes_csv_and_svg() {
    let out = data_dir("bench");
    let status = Command::new(env!("CARGO_BIN_EXE_drapery"))
        .args([
            "bench",
            "scale",
            "--sizes",
            "6,10",
            "--duration",
            "0.05",
            "--preconditioners",
            "lines,multigrid",
            "--threads",
            "1,2",
            "--out",
        ])
        .arg(&out)
        .status()
        .expect("runs");
    assert!(status.success());
    let csv = std::fs::read_to_string(out.join("scale.csv")).expect("scale.csv");
    let lines: Vec<&str> = csv.lines().collect();
    // Every size with every preconditioner and thread count.
    assert_eq!(lines.len(), 1 + 2 * 2 * 2, "{csv}");
    assert!(lines[0].starts_with("n,preconditioner,threads,particles,steps,"));
    assert!(lines[1].starts_with("6,lines,1,36,12,"), "{csv}");
    assert!(lines[4].starts_with("6,multigrid,2,36,12,"), "{csv}");
    assert!(lines[8].starts_with("10,multigrid,2,100,12,"), "{csv}");
    assert!(lines[0].contains("solve_share"), "{csv}");
    let svg = std::fs::read_to_string(out.join("scale.svg")).expect("scale.svg");
    assert!(
        svg.starts_with("<svg") && svg.contains("lines, 1 thread: ") && svg.contains(" · N^"),
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

fn drapery(args: &[&str], dirs: &[&std::path::Path]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_drapery"))
        .args(args)
        .args(dirs)
        .output()
        .expect("runs")
}

/// A small cloth held by two corners, swinging for 0.2 s: smooth (no
/// contact), so implicit Euler's first order and BDF2's second show at
/// once.
const HANGING: &str = r#"{"cloth": {"grid": [6, 6], "size": [0.5, 0.5], "origin": [0, 0, 1],
    "pinned": [[0, 0], [5, 0]]}, "material": "cotton", "duration": 0.2, "fps": 30}"#;

/// Column `name` of a CSV as strings.
fn column<'a>(csv: &'a str, name: &str) -> Vec<&'a str> {
    let mut lines = csv.lines();
    let k = lines
        .next()
        .expect("header")
        .split(',')
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name}"));
    lines.map(|l| l.split(',').nth(k).expect("field")).collect()
}

#[test]
fn bench_precision_shows_euler_first_order_bdf2_second_and_reuses_its_reference() {
    let dir = data_dir("precision");
    let spec = dir.join("hanging.json");
    std::fs::write(&spec, HANGING).expect("spec");
    let first = dir.join("first");
    let args = [
        "--dt-max",
        "1/60",
        "--halvings",
        "3",
        "--repeat",
        "2",
        "--tolerances",
        "1e-3,1e-6",
        "--errors",
        "1e-3,1e-4",
        "--out",
    ];
    let run = |out: &std::path::Path, extra: &[&str]| {
        let mut a = vec!["bench", "precision"];
        a.extend(extra);
        a.extend(args);
        drapery(&a, &[out, &spec])
    };
    // `SPEC` after `--out DIR`: clap takes the positional anywhere.
    let o = run(&first, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let csv = std::fs::read_to_string(first.join("precision.csv")).expect("csv");
    let sweeps = column(&csv, "sweep");
    let mut expected = vec!["dt"; 8];
    expected.extend(["tolerance"; 3]);
    expected.extend(["adaptive"; 4]);
    assert_eq!(sweeps, expected);
    let integrators = column(&csv, "integrator");
    assert_eq!(
        integrators[..8],
        [
            "euler", "euler", "euler", "euler", "bdf2", "bdf2", "bdf2", "bdf2"
        ]
    );
    assert_eq!(integrators[11..], ["euler", "euler", "bdf2", "bdf2"]);
    let stopping = column(&csv, "stopping");
    assert!(stopping[..10].iter().all(|s| *s == "residual"), "{csv}");
    assert_eq!(stopping[10], "error", "{csv}");
    let num = |name: &str| -> Vec<f64> {
        column(&csv, name)
            .iter()
            .map(|v| v.parse().unwrap_or(f64::NAN))
            .collect()
    };
    let (dt, err) = (num("dt"), num("error_rms"));
    // Implicit Euler is first order: each halving of the step divides
    // the error by about 2, i.e. a local order log2(ratio) near 1. The
    // bounds 0.6..1.7 per halving and 0.8..1.5 on average allow for the
    // reference's own error (at 1/8 of the smallest step it inflates the
    // last ratio towards (2 - 1/8) / (1 - 1/8) = 2.14) and for the
    // higher-order terms at the large steps; a zeroth- or second-order
    // error would fall outside them.
    let orders = |first: usize| -> Vec<f64> {
        (first..first + 3)
            .map(|k| {
                assert!((dt[k] / dt[k + 1] - 2.0).abs() < 1e-9);
                (err[k] / err[k + 1]).log2()
            })
            .collect()
    };
    let euler = orders(0);
    assert!(
        euler.iter().all(|p| (0.6..1.7).contains(p)),
        "{euler:?}: {csv}"
    );
    let mean = euler.iter().sum::<f64>() / 3.0;
    assert!((0.8..1.5).contains(&mean), "{euler:?}: {csv}");
    // BDF2 at second order on this smooth swing, and more accurate than
    // Euler at every step.
    let bdf2 = orders(4);
    let mean = bdf2.iter().sum::<f64>() / 3.0;
    assert!(mean > 1.6, "{bdf2:?}: {csv}");
    assert!((0..4).all(|k| err[k + 4] < err[k]), "{csv}");
    // The solver's error shrinks with its tolerance; the error rule
    // leaves a small part of the run's error (a tenth of each step's).
    let solver = num("solver_error_rms");
    assert!(solver[8] > solver[9] && solver[9] < 1e-4, "{csv}");
    assert!(solver[10] < 0.1 * err[10], "{csv}");
    // The adaptive runs: a tighter request, a smaller error; each run's
    // own estimate within its request.
    let (target, estimate) = (num("error_target"), num("error_estimate"));
    for k in [11, 13] {
        assert!(target[k] == 1e-3 && target[k + 1] == 1e-4, "{csv}");
        assert!(err[k + 1] < err[k], "{csv}");
        assert!(
            estimate[k] <= target[k] && estimate[k + 1] <= target[k + 1],
            "{csv}"
        );
    }
    assert!(column(&csv, "pareto").contains(&"true"));
    assert!(stderr.contains("observed order in dt"), "{stderr}");
    assert!(first.join("reference.bin").is_file());
    let svg = std::fs::read_to_string(first.join("precision.svg")).expect("svg");
    assert!(svg.starts_with("<svg") && svg.contains("Pareto front"));
    // Every run's error frame by frame: 6 frames after frame 0, 15 runs.
    let frames = std::fs::read_to_string(first.join("precision-frames.csv")).expect("frames");
    assert_eq!(frames.lines().count(), 1 + 15 * 6, "{frames}");
    assert!(first.join("precision-frames.svg").is_file());

    // The saved reference gives the same errors without being recomputed.
    let second = dir.join("second");
    let o = drapery(
        &[
            "bench",
            "precision",
            "--dt-max",
            "1/60",
            "--repeat",
            "1",
            "--halvings",
            "3",
            "--tolerances",
            "1e-3,1e-6",
            "--errors",
            "1e-3,1e-4",
            "--reference",
        ],
        &[&first, std::path::Path::new("--out"), &second, &spec],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!second.join("reference.bin").exists());
    let again = std::fs::read_to_string(second.join("precision.csv")).expect("csv");
    assert_eq!(column(&again, "error_rms"), column(&csv, "error_rms"));

    // A reference of another scene is refused, naming the flag.
    std::fs::write(
        &spec,
        HANGING
            .replace("[6, 6]", "[7, 7]")
            .replace("[5, 0]", "[6, 0]"),
    )
    .expect("spec");
    let o = drapery(
        &[
            "bench",
            "precision",
            "--dt-max",
            "1/60",
            "--halvings",
            "3",
            "--reference",
        ],
        &[&first, std::path::Path::new("--out"), &second, &spec],
    );
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--reference"));
}

#[test]
fn bench_stress_writes_csv_and_replayable_specs() {
    let out = data_dir("stress");
    let o = drapery(
        &[
            "bench",
            "stress",
            "--size",
            "6",
            "--only",
            "tablecloth-pull 8,impact",
            "--out",
        ],
        &[&out],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("stress.csv")).expect("csv");
    assert!(csv.starts_with(
        "case,dt,finite,max_stretch,min_signed_distance,self_crossings,obstacle_crossings,cg_iterations_max,unconverged_solves,wall_seconds,pass"
    ));
    assert_eq!(
        column(&csv, "case"),
        ["impact 10 m/s", "tablecloth-pull 8 m/s"]
    );
    assert_eq!(column(&csv, "pass"), ["true", "true"]);
    // Each case's scene replays with `drapery run`.
    let spec = out.join("specs").join("impact-10-m-s.json");
    let o = drapery(&["validate"], &[&spec]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let o = drapery(&["bench", "stress", "--only", "nothing", "--out"], &[&out]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--only"));
}

/// `bench precision` and `bench scale` run on every bundled scene (the
/// canonical scenes), at sizes that take a fraction of a second: moving
/// obstacles, meshes, pins and planes all go through both studies. (0.05 s
/// and 0.1 s: at least one frame at every scene's rate, the slowest being
/// 20 fps.)
#[test]
fn precision_and_scale_run_on_every_bundled_scene() {
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes");
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&scenes).expect("examples/scenes") {
        let spec = entry.expect("entry").path();
        let out = data_dir("every-scene");
        let o = drapery(
            &[
                "bench",
                "precision",
                "--duration",
                "0.05",
                "--tight-tolerance",
                "1e-6",
                "--reference-dt",
                "1/240",
                "--dt-max",
                "1/60",
                "--halvings",
                "1",
                "--repeat",
                "1",
                "--tolerances",
                "1e-3",
                "--out",
            ],
            &[&out, &spec],
        );
        assert!(
            o.status.success(),
            "{}: {}",
            spec.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let o = drapery(
            &[
                "bench",
                "scale",
                "--sizes",
                "4,6",
                "--duration",
                "0.1",
                "--spec",
            ],
            &[&spec, std::path::Path::new("--out"), &out],
        );
        assert!(
            o.status.success(),
            "{}: {}",
            spec.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(out.join("precision.csv").is_file() && out.join("scale.csv").is_file());
        names.push(spec);
    }
    assert!(names.len() >= 9, "{names:?}");
}
