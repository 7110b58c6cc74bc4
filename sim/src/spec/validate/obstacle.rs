//! `obstacles[k]`: one shape each, inline meshes, rigid motions.

use super::check::{Check, MAX_COORD};
use crate::spec::limits::Limits;
use crate::spec::obstacle::{MeshSource, Motion, Obstacle};

/// Checks obstacle `o` at `path`; `triangles` counts the mesh triangles of
/// the obstacles checked so far, which `limits.max_triangles` bounds in
/// all.
pub(super) fn validate_obstacle(
    path: &str,
    o: &Obstacle,
    limits: &Limits,
    triangles: &mut usize,
    c: &mut Check,
) {
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
            validate_inline_mesh(path, m, limits, *triangles, c);
        }
        if n == 1 && c.errors.len() == before {
            let field = if m.obj.is_some() {
                "obj"
            } else if m.stl.is_some() {
                "stl"
            } else {
                "triangles"
            };
            // An OBJ's faces are counted before it is parsed: one face of
            // many corners is cut into as many triangles.
            let listed = m.obj.as_deref().map_or(0, crate::mesh::obj_triangles);
            if *triangles + listed > limits.max_triangles {
                c.fail(
                    format!("{path}.mesh.{field}"),
                    too_many(listed, *triangles, limits),
                );
            } else {
                match crate::mesh::from_source(m) {
                    Err(e) => c.fail(format!("{path}.mesh.{field}"), e.0),
                    Ok(mesh) if *triangles + mesh.triangles().len() > limits.max_triangles => c
                        .fail(
                            format!("{path}.mesh.{field}"),
                            too_many(mesh.triangles().len(), *triangles, limits),
                        ),
                    Ok(mesh) => *triangles += mesh.triangles().len(),
                }
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

/// The error of a mesh of `count` triangles after `earlier` triangles of
/// other obstacles, over the limit they share.
fn too_many(count: usize, earlier: usize, limits: &Limits) -> String {
    let max = limits.max_triangles;
    if earlier == 0 {
        format!("{count} triangles exceeds the limit of {max}")
    } else {
        format!(
            "{count} triangles make {} with the obstacles before it, over the limit of {max} summed over obstacles",
            count + earlier
        )
    }
}

fn validate_inline_mesh(
    path: &str,
    m: &MeshSource,
    limits: &Limits,
    earlier: usize,
    c: &mut Check,
) {
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
    if earlier + ts.len() > limits.max_triangles {
        c.fail(
            format!("{path}.mesh.triangles"),
            too_many(ts.len(), earlier, limits),
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

pub(super) fn validate_motion(path: &str, m: &Motion, c: &mut Check) {
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
