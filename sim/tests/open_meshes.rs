//! Open meshes are shells with two sides (`collision::meshsurface`): a
//! cloth may rest on or hang under a sheet of one face, and fall into a
//! box without a lid or a bowl, without being thrown through a face or
//! torn.
//!
//! The sheet and the box are made of axis-aligned rectangles and the
//! bowl's wall lies on a sphere, so a crossing is read from the frames
//! exactly enough: a particle that is over the same rectangle at two
//! frames in a row, on opposite sides of its plane (or below the bowl's
//! rim on opposite sides of its sphere), went through it (at 30 frames a
//! second a particle moves a few centimetres a frame, far less than the
//! obstacles' size; the bowl's facets lie within 3 mm of its sphere).

mod common;

use common::scene_from_json;
use drapery_sim::math::{Real, Vec3};
use drapery_sim::sim::{Control, FrameStats, Simulation};

/// A rectangle of a face: `axis` is constant at `at`; the other two
/// coordinates lie within `lo..hi`.
struct Rect {
    axis: usize,
    at: Real,
    lo: [Real; 3],
    hi: [Real; 3],
}

impl Rect {
    fn over(&self, p: &Vec3) -> bool {
        (0..3).all(|k| k == self.axis || (self.lo[k] < p[k] && p[k] < self.hi[k]))
    }

    fn side(&self, p: &Vec3) -> bool {
        p[self.axis] > self.at
    }
}

/// Particles that went through one of `rects` between consecutive frames.
fn crossings(frames: &[Vec<Vec3>], rects: &[Rect]) -> usize {
    frames
        .windows(2)
        .map(|w| {
            w[0].iter()
                .zip(&w[1])
                .filter(|(a, b)| {
                    rects
                        .iter()
                        .any(|r| r.over(a) && r.over(b) && r.side(a) != r.side(b))
                })
                .count()
        })
        .sum()
}

fn scene(mesh: &str, top: Real, grid: u32) -> String {
    format!(
        r#"{{"cloth": {{"grid": [{grid}, {grid}], "size": [1, 1], "origin": [-0.5, -0.5, {top}]}},
            "material": "cotton", "obstacles": [{{"mesh": {mesh}, "friction": 0.4}}],
            "duration": 1.2, "fps": 30, "solver": {{"dt": 0.004166666666666667}}}}"#
    )
}

/// Runs `json`, checking that every frame is finite, reports no particle
/// inside the shell (its distances are unsigned) and stretches no edge
/// past 5 %.
fn run(json: &str) -> Vec<Vec<Vec3>> {
    let mut sim = Simulation::new(&scene_from_json(json)).expect("builds");
    let mut frames = vec![sim.state().x.clone()];
    while !sim.is_done() {
        let s: FrameStats = sim.advance_frame(&Control::default()).expect("steps");
        let x = sim.state().x.clone();
        assert!(x.iter().all(|p| p.iter().all(|c| c.is_finite())));
        assert!(s.min_signed_distance.is_some_and(|d| d >= 0.0), "{s:?}");
        assert!(
            s.max_stretch <= 1.05,
            "frame {}: stretch {}",
            s.frame,
            s.max_stretch
        );
        frames.push(x);
    }
    frames
}

/// A 0.5 m square sheet of 32 triangles at z = 0, under a 1 m cloth: the
/// cloth drapes over its rim, the skirt hangs well below the sheet, no
/// particle goes through it (nor, in [`run`], is reported inside it).
#[test]
fn a_cloth_drapes_over_a_sheet_of_one_face() {
    let n = 5;
    let vertices: Vec<String> = (0..n * n)
        .map(|k| {
            let (i, j) = ((k % n) as Real, (k / n) as Real);
            format!("[{}, {}, 0]", -0.25 + 0.125 * i, -0.25 + 0.125 * j)
        })
        .collect();
    let mut triangles = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = i + n * j;
            triangles.push(format!(
                "[{a}, {}, {}], [{a}, {}, {}]",
                a + 1,
                a + 1 + n,
                a + 1 + n,
                a + n
            ));
        }
    }
    let mesh = format!(
        r#"{{"vertices": [{}], "triangles": [{}]}}"#,
        vertices.join(", "),
        triangles.join(", ")
    );
    let frames = run(&scene(&mesh, 0.1, 24));
    let sheet = Rect {
        axis: 2,
        at: 0.0,
        lo: [-0.25; 3],
        hi: [0.25; 3],
    };
    assert_eq!(crossings(&frames, &[sheet]), 0);
    let last = frames.last().expect("frames");
    let lowest = last.iter().map(|p| p.z).fold(Real::INFINITY, Real::min);
    assert!(lowest < -0.2, "the skirt hangs: lowest {lowest}");
}

/// A 0.4 m box without its lid (ten triangles): the cloth falls onto its
/// rims, sags into it and hangs over the walls, through no face (read as a solid, the open box tore
/// it: stretch 10.3).
#[test]
fn a_cloth_falls_into_a_box_without_a_lid() {
    let h = 0.2;
    let mesh = format!(
        r#"{{"vertices": [[-{h},-{h},-{h}],[{h},-{h},-{h}],[-{h},{h},-{h}],[{h},{h},-{h}],
                          [-{h},-{h},{h}],[{h},-{h},{h}],[-{h},{h},{h}],[{h},{h},{h}]],
             "triangles": [[0,2,3],[0,3,1],[0,1,5],[0,5,4],[2,6,7],[2,7,3],
                           [0,4,6],[0,6,2],[1,3,7],[1,7,5]]}}"#
    );
    let frames = run(&scene(&mesh, 0.3, 20));
    let wall = |axis, at| Rect {
        axis,
        at,
        lo: [-h; 3],
        hi: [h; 3],
    };
    let walls = [
        wall(2, -h),
        wall(0, -h),
        wall(0, h),
        wall(1, -h),
        wall(1, h),
    ];
    assert_eq!(crossings(&frames, &walls), 0);
    // It spans the opening, held by the rims, and sags into it.
    let last = frames.last().expect("frames");
    let over = last.iter().filter(|p| p.x.abs() < h && p.y.abs() < h);
    let lowest = over.map(|p| p.z).fold(Real::INFINITY, Real::min);
    assert!(
        -h < lowest && lowest < h - 0.01,
        "lowest over the opening {lowest}"
    );
}

/// An open hemispherical bowl (radius 0.3 m, 360 triangles, rim up): a
/// 0.8 m cloth dropped over it falls in and lies on its bottom, and no
/// particle below the rim goes through its wall (read as a solid, the
/// bowl's inside was its inside: the cloth was thrown up over the rim
/// and stretched 59 %).
#[test]
fn a_cloth_falls_into_an_open_bowl() {
    let (r, rings, around) = (0.3, 8, 24);
    let mut vertices = vec![String::from("[0, 0, 0]")];
    for i in 1..=rings {
        let theta = std::f64::consts::FRAC_PI_2 * i as Real / rings as Real;
        for j in 0..around {
            let phi = std::f64::consts::TAU * j as Real / around as Real;
            let (s, c) = (r * theta.sin(), r - r * theta.cos());
            vertices.push(format!("[{}, {}, {c}]", s * phi.cos(), s * phi.sin()));
        }
    }
    let at = |i: usize, j: usize| 1 + (i - 1) * around + j % around;
    let mut triangles: Vec<String> = (0..around)
        .map(|j| format!("[0, {}, {}]", at(1, j), at(1, j + 1)))
        .collect();
    for i in 1..rings {
        for j in 0..around {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            triangles.push(format!("[{a}, {d}, {c}], [{a}, {c}, {b}]"));
        }
    }
    let mesh = format!(
        r#"{{"vertices": [{}], "triangles": [{}]}}"#,
        vertices.join(", "),
        triangles.join(", ")
    );
    let json = scene(&mesh, 0.45, 20).replace(
        r#""size": [1, 1], "origin": [-0.5, -0.5, 0.45]"#,
        r#""size": [0.8, 0.8], "origin": [-0.4, -0.4, 0.45]"#,
    );
    let frames = run(&json);
    let centre = Vec3::new(0.0, 0.0, r);
    let inside = |p: &Vec3| (p - centre).norm() < r;
    let through: usize = frames
        .windows(2)
        .map(|w| {
            w[0].iter()
                .zip(&w[1])
                .filter(|(a, b)| a.z < r && b.z < r && inside(a) != inside(b))
                .count()
        })
        .sum();
    assert_eq!(through, 0);
    let last = frames.last().expect("frames");
    let lowest = last.iter().map(|p| p.z).fold(Real::INFINITY, Real::min);
    assert!(lowest < 0.05, "the cloth reaches the bottom: {lowest}");
    assert!(last.iter().all(|p| p.z < r + 0.05), "and stays in the bowl");
}
