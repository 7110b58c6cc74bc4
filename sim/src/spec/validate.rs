//! [`Spec::validate`]: every rule, every error with its field path.

use super::error::{SpecError, SpecErrors};
use super::limits::Limits;
use super::material::{MaterialParams, MaterialSpec, PRESETS, preset};
use super::obstacle::{Motion, Obstacle};
use super::scene::{ClothScene, Scene, SolverScene, TimeStepping};
use super::types::{PinEntry, Spec, TimeStep};
use crate::math::Vec3;

/// Largest coordinate magnitude accepted anywhere, in metres.
const MAX_COORD: f64 = 1.0e6;
/// Largest cloth side in metres.
const MAX_CLOTH_SIDE: f64 = 1.0e3;
/// Adaptive stepping subdivides a frame at most `2^ADAPTIVE_MAX_LEVEL` times.
const ADAPTIVE_MAX_LEVEL: u32 = 12;

/// Collects errors; each check reports and returns whether the value passed.
#[derive(Default)]
struct Check {
    errors: Vec<SpecError>,
}

impl Check {
    fn fail(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.errors.push(SpecError {
            path: path.into(),
            message: message.into(),
        });
    }

    fn finite(&mut self, path: &str, x: f64) -> bool {
        if x.is_finite() {
            true
        } else {
            self.fail(path, "must be a finite number");
            false
        }
    }

    /// `lo < x <= hi` (or `lo <= x` when `allow_zero` and `lo == 0`).
    fn range(&mut self, path: &str, x: f64, positive: bool, hi: f64) -> bool {
        if !self.finite(path, x) {
            return false;
        }
        if positive && x <= 0.0 {
            self.fail(path, "must be > 0");
            false
        } else if !positive && x < 0.0 {
            self.fail(path, "must be >= 0");
            false
        } else if x > hi {
            self.fail(path, format!("must be <= {hi}"));
            false
        } else {
            true
        }
    }

    fn point(&mut self, path: &str, p: [f64; 3]) -> Option<Vec3> {
        let mut ok = true;
        for (k, c) in p.iter().enumerate() {
            let at = format!("{path}[{k}]");
            if self.finite(&at, *c) && c.abs() > MAX_COORD {
                self.fail(at, format!("must be within ±{MAX_COORD} m"));
                ok = false;
            } else if !c.is_finite() {
                ok = false;
            }
        }
        ok.then(|| Vec3::new(p[0], p[1], p[2]))
    }

    fn direction(&mut self, path: &str, d: [f64; 3]) -> Option<Vec3> {
        let v = self.point(path, d)?;
        let n = v.norm();
        if n < 1e-12 {
            self.fail(path, "must be a non-zero vector");
            None
        } else {
            Some(v / n)
        }
    }
}

impl Spec {
    /// Checks every field against the rules and `limits`, returning the
    /// ready scene or every error found (never just the first).
    pub fn validate(&self, limits: &Limits) -> Result<Scene, SpecErrors> {
        let mut c = Check::default();
        if let Some(name) = &self.name
            && name.chars().count() > 200
        {
            c.fail("name", "must be at most 200 characters");
        }
        let cloth = validate_cloth(self, limits, &mut c);
        let material = validate_material(&self.material, &mut c);
        let gravity = c.point("gravity", self.gravity);
        if let Some(g) = gravity
            && g.norm() > 1000.0
        {
            c.fail("gravity", "must have magnitude <= 1000 m/s²");
        }
        for (k, o) in self.obstacles.iter().enumerate() {
            validate_obstacle(&format!("obstacles[{k}]"), o, limits, &mut c);
        }
        let frames = validate_timing(self, limits, &mut c);
        let solver = validate_solver(self, limits, frames, &mut c);

        match (cloth, material, gravity, frames, solver) {
            (Some(cloth), Some(material), Some(gravity), Some(frames), Some(solver))
                if c.errors.is_empty() =>
            {
                Ok(Scene {
                    name: self.name.clone().unwrap_or_else(|| "untitled".into()),
                    cloth,
                    material,
                    obstacles: self.obstacles.clone(),
                    gravity,
                    duration: self.duration,
                    fps: self.fps,
                    frames,
                    solver,
                })
            }
            _ => Err(SpecErrors(c.errors)),
        }
    }
}

fn validate_cloth(spec: &Spec, limits: &Limits, c: &mut Check) -> Option<ClothScene> {
    let cl = &spec.cloth;
    let mut ok = true;
    for k in 0..2 {
        if cl.grid[k] < 2 {
            c.fail(format!("cloth.grid[{k}]"), "must be >= 2");
            ok = false;
        }
        if !c.range(
            &format!("cloth.size[{k}]"),
            cl.size[k],
            true,
            MAX_CLOTH_SIDE,
        ) {
            ok = false;
        }
    }
    let particles = u64::from(cl.grid[0]) * u64::from(cl.grid[1]);
    if particles > limits.max_particles as u64 {
        c.fail(
            "cloth.grid",
            format!(
                "{particles} particles exceeds the limit of {}",
                limits.max_particles
            ),
        );
        ok = false;
    }
    let origin = c.point("cloth.origin", cl.origin);
    let u = c.direction("cloth.u", cl.u.unwrap_or([1.0, 0.0, 0.0]));
    let v = c.direction("cloth.v", cl.v.unwrap_or([0.0, 1.0, 0.0]));
    if let (Some(u), Some(v)) = (u, v)
        && u.dot(&v).abs() > 1e-6
    {
        c.fail("cloth.v", "must be perpendicular to cloth.u");
        ok = false;
    }
    let (nu, nv) = (cl.grid[0] as usize, cl.grid[1] as usize);
    // (particle, motion group, entry index), then sorted by particle.
    let mut pins: Vec<(usize, Option<usize>, usize)> = Vec::with_capacity(cl.pinned.len());
    let mut pin_motions = Vec::new();
    let mut pin = |at: String, p: &[u32; 2], group: Option<usize>, k: usize, c: &mut Check| {
        let mut inside = true;
        for (axis, n) in [(0, nu), (1, nv)] {
            if p[axis] as usize >= n {
                c.fail(
                    format!("{at}[{axis}]"),
                    format!("must be < {n} (cloth.grid[{axis}])"),
                );
                inside = false;
            }
        }
        if inside {
            pins.push((p[0] as usize + p[1] as usize * nu, group, k));
        }
        inside
    };
    for (k, entry) in cl.pinned.iter().enumerate() {
        match entry {
            PinEntry::Particle(p) => ok &= pin(format!("cloth.pinned[{k}]"), p, None, k, c),
            PinEntry::Group(g) => {
                if g.particles.is_empty() {
                    c.fail(format!("cloth.pinned[{k}].particles"), "must not be empty");
                    ok = false;
                }
                let group = g.motion.as_ref().map(|m| {
                    validate_motion(&format!("cloth.pinned[{k}].motion"), m, c);
                    pin_motions.push(m.clone());
                    pin_motions.len() - 1
                });
                for (m, p) in g.particles.iter().enumerate() {
                    ok &= pin(format!("cloth.pinned[{k}].particles[{m}]"), p, group, k, c);
                }
            }
        }
    }
    pins.sort_unstable();
    pins.dedup_by_key(|p| (p.0, p.1));
    for w in pins.windows(2) {
        if w[0].0 == w[1].0 {
            c.fail(
                format!("cloth.pinned[{}]", w[1].2),
                format!(
                    "particle [{}, {}] is also pinned by cloth.pinned[{}] with another motion",
                    w[1].0 % nu,
                    w[1].0 / nu,
                    w[0].2
                ),
            );
            ok = false;
        }
    }
    let pinned = pins.iter().map(|p| p.0).collect();
    let pin_group = pins.iter().map(|p| p.1).collect();
    let (origin, u, v) = (origin?, u?, v?);
    ok.then_some(ClothScene {
        nu,
        nv,
        size: cl.size,
        origin,
        u,
        v,
        pinned,
        pin_group,
        pin_motions,
    })
}

fn validate_material(m: &MaterialSpec, c: &mut Check) -> Option<MaterialParams> {
    let p = match m {
        MaterialSpec::Preset(name) => match preset(name) {
            Some(p) => return Some(p),
            None => {
                let names: Vec<&str> = PRESETS.iter().map(|(n, _)| *n).collect();
                c.fail(
                    "material",
                    format!(
                        "unknown preset {name:?}; expected one of {}",
                        names.join(", ")
                    ),
                );
                return None;
            }
        },
        MaterialSpec::Params(p) => p,
    };
    let checks = [
        ("material.density", p.density, true, 100.0),
        ("material.stretch", p.stretch, true, 1.0e9),
        ("material.shear", p.shear, false, 1.0e9),
        ("material.bend", p.bend, false, 1.0e3),
        ("material.bend_threshold", p.bend_threshold, false, 1.0e3),
        ("material.shear_threshold", p.shear_threshold, false, 1.0e9),
        ("material.damping", p.damping, false, 10.0),
        ("material.air_drag", p.air_drag, false, 1.0e4),
    ];
    let mut ok = true;
    for (path, x, positive, hi) in checks {
        ok &= c.range(path, x, positive, hi);
    }
    ok.then_some(*p)
}

fn validate_obstacle(path: &str, o: &Obstacle, limits: &Limits, c: &mut Check) {
    let shapes = [
        o.sphere.is_some(),
        o.box_.is_some(),
        o.plane.is_some(),
        o.cylinder.is_some(),
        o.mesh.is_some(),
    ];
    let count = shapes.iter().filter(|s| **s).count();
    if count != 1 {
        c.fail(
            path,
            format!(
                "must have exactly one shape (sphere, box, plane, cylinder or mesh), found {count}"
            ),
        );
    }
    if let Some(s) = &o.sphere {
        c.point(&format!("{path}.sphere.center"), s.center);
        c.range(&format!("{path}.sphere.radius"), s.radius, true, MAX_COORD);
    }
    if let Some(b) = &o.box_ {
        c.point(&format!("{path}.box.center"), b.center);
        for k in 0..3 {
            c.range(&format!("{path}.box.size[{k}]"), b.size[k], true, MAX_COORD);
        }
    }
    if let Some(p) = &o.plane {
        c.point(&format!("{path}.plane.point"), p.point);
        c.direction(&format!("{path}.plane.normal"), p.normal);
    }
    if let Some(cy) = &o.cylinder {
        c.point(&format!("{path}.cylinder.center"), cy.center);
        c.direction(&format!("{path}.cylinder.axis"), cy.axis);
        c.range(
            &format!("{path}.cylinder.radius"),
            cy.radius,
            true,
            MAX_COORD,
        );
        c.range(
            &format!("{path}.cylinder.height"),
            cy.height,
            true,
            MAX_COORD,
        );
    }
    if let Some(m) = &o.mesh {
        let inline = m.vertices.is_some() || m.triangles.is_some();
        let sources = [m.obj.is_some(), m.stl.is_some(), inline];
        let n = sources.iter().filter(|s| **s).count();
        if n != 1 {
            c.fail(
                format!("{path}.mesh"),
                format!("must have exactly one of obj, stl, or vertices + triangles, found {n}"),
            );
        }
        let before = c.errors.len();
        if inline {
            validate_inline_mesh(path, m, limits, c);
        }
        if n == 1 && c.errors.len() == before {
            let field = if m.obj.is_some() {
                "obj"
            } else if m.stl.is_some() {
                "stl"
            } else {
                "triangles"
            };
            match crate::mesh::from_source(m) {
                Err(e) => c.fail(format!("{path}.mesh.{field}"), e.0),
                Ok(mesh) if mesh.triangles().len() > limits.max_triangles => c.fail(
                    format!("{path}.mesh.{field}"),
                    format!(
                        "{} triangles exceeds the limit of {}",
                        mesh.triangles().len(),
                        limits.max_triangles
                    ),
                ),
                Ok(_) => {}
            }
        }
    }
    c.range(&format!("{path}.friction"), o.friction, false, 10.0);
    if let Some(off) = o.offset {
        c.range(&format!("{path}.offset"), off, false, 1.0);
    }
    if let Some(m) = &o.motion {
        validate_motion(&format!("{path}.motion"), m, c);
    }
}

fn validate_inline_mesh(path: &str, m: &super::MeshSource, limits: &Limits, c: &mut Check) {
    let (Some(vs), Some(ts)) = (&m.vertices, &m.triangles) else {
        c.fail(
            format!("{path}.mesh"),
            "vertices and triangles must be given together",
        );
        return;
    };
    if ts.is_empty() {
        c.fail(format!("{path}.mesh.triangles"), "must not be empty");
    }
    if ts.len() > limits.max_triangles {
        c.fail(
            format!("{path}.mesh.triangles"),
            format!(
                "{} triangles exceeds the limit of {}",
                ts.len(),
                limits.max_triangles
            ),
        );
        return;
    }
    for (k, v) in vs.iter().enumerate() {
        if c.point(&format!("{path}.mesh.vertices[{k}]"), *v).is_none() {
            return; // one bad vertex is enough to report; avoid a flood
        }
    }
    for (k, t) in ts.iter().enumerate() {
        for (q, &i) in t.iter().enumerate() {
            if i as usize >= vs.len() {
                c.fail(
                    format!("{path}.mesh.triangles[{k}][{q}]"),
                    format!("index {i} out of range ({} vertices)", vs.len()),
                );
                return;
            }
        }
    }
}

fn validate_motion(path: &str, m: &Motion, c: &mut Check) {
    let constant = m.velocity.is_some() || m.angular_velocity.is_some() || m.pivot.is_some();
    if let Some(v) = m.velocity {
        c.point(&format!("{path}.velocity"), v);
    }
    if let Some(w) = m.angular_velocity {
        c.point(&format!("{path}.angular_velocity"), w);
    }
    if let Some(p) = m.pivot {
        c.point(&format!("{path}.pivot"), p);
    }
    match (&m.keyframes, constant) {
        (Some(_), true) => c.fail(
            path,
            "must be either velocity/angular_velocity/pivot or keyframes, not both",
        ),
        (None, false) => c.fail(path, "must give velocity, angular_velocity or keyframes"),
        (Some(keys), false) => {
            if keys.is_empty() {
                c.fail(format!("{path}.keyframes"), "must not be empty");
            }
            let mut last = f64::NEG_INFINITY;
            for (k, key) in keys.iter().enumerate() {
                let at = format!("{path}.keyframes[{k}]");
                if c.finite(&format!("{at}.time"), key.time) {
                    if key.time <= last {
                        c.fail(
                            format!("{at}.time"),
                            "must be greater than the previous key's",
                        );
                    }
                    last = key.time;
                }
                c.point(&format!("{at}.translation"), key.translation);
                let q = key.rotation;
                let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                if !norm.is_finite() || (norm - 1.0).abs() > 1e-3 {
                    c.fail(
                        format!("{at}.rotation"),
                        "must be a unit quaternion [x, y, z, w]",
                    );
                }
            }
        }
        (None, true) => {}
    }
}

/// Returns the number of frames after frame 0.
fn validate_timing(spec: &Spec, limits: &Limits, c: &mut Check) -> Option<usize> {
    let d = c.range("duration", spec.duration, true, limits.max_duration);
    let f = c.range("fps", spec.fps, true, 10_000.0);
    if !(d && f) {
        return None;
    }
    // NOTE: a small slack so 2.0 s at 60 fps gives 120 frames despite round-off.
    let frames = (spec.duration * spec.fps + 1e-9).floor() as usize;
    if frames == 0 {
        c.fail(
            "duration",
            "must cover at least one frame (duration * fps >= 1)",
        );
        return None;
    }
    if frames > limits.max_frames {
        c.fail(
            "fps",
            format!("{frames} frames exceeds the limit of {}", limits.max_frames),
        );
        return None;
    }
    Some(frames)
}

fn validate_solver(
    spec: &Spec,
    limits: &Limits,
    frames: Option<usize>,
    c: &mut Check,
) -> Option<SolverScene> {
    let s = &spec.solver;
    let mut ok = c.range("solver.tolerance", s.tolerance, true, 0.5);
    if s.max_iterations == 0 || s.max_iterations > 1_000_000 {
        c.fail("solver.max_iterations", "must be between 1 and 1000000");
        ok = false;
    }
    let stepping = match s.dt {
        TimeStep::Adaptive => Some(TimeStepping::Adaptive {
            max_level: ADAPTIVE_MAX_LEVEL,
        }),
        TimeStep::Fixed(dt) => {
            if !c.range("solver.dt", dt, true, 1.0) {
                None
            } else if dt < 1e-7 {
                c.fail("solver.dt", "must be >= 1e-7 s");
                None
            } else if spec.fps.is_finite() && spec.fps > 0.0 {
                let frame_dt = 1.0 / spec.fps;
                // The largest step that divides the frame and is not above dt.
                let substeps = ((frame_dt / dt) - 1e-6).ceil().max(1.0) as usize;
                let total = frames.map_or(0, |f| f.saturating_mul(substeps));
                if total > limits.max_steps {
                    c.fail(
                        "solver.dt",
                        format!("{total} steps exceeds the limit of {}", limits.max_steps),
                    );
                    None
                } else {
                    Some(TimeStepping::Fixed { substeps })
                }
            } else {
                None
            }
        }
    };
    let stepping = stepping?;
    ok.then_some(SolverScene {
        stepping,
        tolerance: s.tolerance,
        max_iterations: s.max_iterations as usize,
        preconditioner: s.preconditioner,
        warm_start: s.warm_start,
        collision: s.collision,
    })
}
