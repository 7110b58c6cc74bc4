//! Reading job specs from JSON with errors that name the field.
//!
//! Two passes. The first reads the text as JSON and nothing more
//! (`IgnoredAny`, no allocation per value) up to its very end: a syntax
//! error, or anything after the document (`{...}xx`), is
//! [`SpecLoadError::Malformed`]. The second reads the now well-formed JSON
//! into a [`Spec`] through [`WholeNumbers`] (whole floats fill integer
//! fields; an array longer than its fixed length is a length error), with
//! the path tracked by `serde_path_to_error`: every error there — wrong
//! type, unknown field, wrong length, number out of range — is the
//! document's shape, [`SpecLoadError::Invalid`] at the field's path. Rule
//! violations come from [`Spec::validate`], and what only the built scene
//! shows (a cloth starting inside an obstacle) from `World::check`. All
//! end as [`SpecErrors`].

mod whole_numbers;

use drapery_sim::sim::{SimError, Simulation, World};
use drapery_sim::spec::{Limits, Scene, Spec, SpecError, SpecErrors};
use serde::Deserialize;

use whole_numbers::WholeNumbers;

/// Why a spec was refused.
#[derive(Debug, thiserror::Error)]
pub enum SpecLoadError {
    /// Not JSON at all (syntax error, truncated input).
    #[error("malformed JSON: {0}")]
    Malformed(String),
    /// JSON, but not a valid spec.
    #[error("{0}")]
    Invalid(SpecErrors),
}

impl SpecLoadError {
    /// The errors, each with its path; a malformed document has one at the
    /// root.
    pub fn errors(&self) -> Vec<SpecError> {
        match self {
            SpecLoadError::Malformed(m) => vec![SpecError {
                path: String::new(),
                message: format!("malformed JSON: {m}"),
            }],
            SpecLoadError::Invalid(e) => e.0.clone(),
        }
    }
}

/// Parses `text` into a [`Spec`] (no rule checks yet).
pub fn parse(text: &str) -> Result<Spec, SpecLoadError> {
    check_syntax(text)?;
    // A well-formed document that is not an object (an array would be
    // read as the spec's fields in order, with a baffling message).
    if !text.trim_start().starts_with('{') {
        return Err(SpecLoadError::Invalid(SpecErrors(vec![SpecError {
            path: String::new(),
            message: "the spec must be a JSON object".into(),
        }])));
    }
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize::<_, Spec>(WholeNumbers(de)).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        let message = e.into_inner().to_string();
        SpecLoadError::Invalid(SpecErrors(vec![SpecError {
            path: field_path(path, &message),
            message,
        }]))
    })
}

/// The path of an error about a field that is missing or given twice:
/// serde names the field in its message and the path stops at the object
/// holding it (`cloth` for a missing `cloth.grid`).
fn field_path(path: String, message: &str) -> String {
    let named = ["missing field `", "duplicate field `"]
        .iter()
        .find_map(|lead| message.strip_prefix(lead))
        .and_then(|rest| rest.split('`').next());
    match named {
        Some(field) if path.is_empty() => field.to_owned(),
        Some(field) => format!("{path}.{field}"),
        None => path,
    }
}

/// `text` is one JSON document and nothing after it but white space.
fn check_syntax(text: &str) -> Result<(), SpecLoadError> {
    let mut de = serde_json::Deserializer::from_str(text);
    serde::de::IgnoredAny::deserialize(&mut de)
        .and_then(|_| de.end())
        .map_err(|e| SpecLoadError::Malformed(e.to_string()))
}

/// Parses and validates `text` under `limits`, and checks that the
/// scene can be built (`World::check`: an obstacle the cloth starts
/// inside is refused by name, like any other bad field).
pub fn load(text: &str, limits: &Limits) -> Result<Scene, SpecLoadError> {
    load_spec(text, limits, |_| Ok::<_, SpecLoadError>(())).map(|(scene, _)| scene)
}

/// [`load`], with the spec as read: what the service stores
/// (re-serialised, so the stored text is as long as what it says, not as
/// the body that said it: white space or a number of twenty million
/// digits cost nothing to store or to read back). `admit` sees the valid
/// scene before its obstacles are built to check it, which for meshes of
/// millions of triangles takes time and memory the service first weighs.
pub fn load_spec<E: From<SpecLoadError>>(
    text: &str,
    limits: &Limits,
    admit: impl FnOnce(&Scene) -> Result<(), E>,
) -> Result<(Scene, Spec), E> {
    let spec = parse(text)?;
    let scene = spec.validate(limits).map_err(SpecLoadError::Invalid)?;
    admit(&scene)?;
    World::check(&scene).map_err(unbuildable)?;
    Ok((scene, spec))
}

/// Parses and validates `text` under `limits`, without building the
/// scene: for a run, which checks what it needs before [`build`] builds
/// the obstacles once (`World::check` in [`load`] would build them only
/// to throw them away: a 159,200-triangle mesh, 0.4 s).
pub fn load_scene(text: &str, limits: &Limits) -> Result<Scene, SpecLoadError> {
    parse(text)?
        .validate(limits)
        .map_err(SpecLoadError::Invalid)
}

/// The simulation of a validated scene, refused as [`load`] refuses it.
pub fn build(scene: &Scene) -> Result<Simulation, SpecLoadError> {
    Simulation::new(scene).map_err(unbuildable)
}

/// A scene that cannot be built, as the spec error it is: an obstacle
/// (or a cloth starting inside one) at the obstacle's path.
fn unbuildable(e: SimError) -> SpecLoadError {
    let (path, message) = match e {
        SimError::Obstacle { index, message } => (format!("obstacles[{index}]"), message),
        other => (String::new(), other.to_string()),
    };
    SpecLoadError::Invalid(SpecErrors(vec![SpecError { path, message }]))
}

/// A spec stored by the service, which [`load`] accepted when it was
/// submitted: parsed and validated again, not built.
pub fn load_stored(text: &str) -> Result<Scene, SpecLoadError> {
    load_scene(text, &Limits::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(text: &str) -> Vec<SpecError> {
        load(text, &Limits::default())
            .expect_err("must be refused")
            .errors()
    }

    const OK: &str = r#"{"cloth": {"grid": [3, 3], "size": [1, 1]}, "material": "cotton", "duration": 1, "fps": 10}"#;

    #[test]
    fn accepts_a_minimal_spec() {
        let scene = load(OK, &Limits::default()).expect("valid");
        assert_eq!(scene.frames, 10);
    }

    /// A cloth that starts inside an obstacle is refused, naming the
    /// obstacle and the particle, by `load` and `load_simulation` alike;
    /// one laid exactly on a surface is not.
    #[test]
    fn a_cloth_starting_inside_an_obstacle_is_refused_by_name() {
        let spec = |obstacles: &str| {
            format!(
                r#"{{"cloth": {{"grid": [11, 11], "size": [1, 1], "origin": [-0.5, -0.5, 0.3]}},
                    "material": "cotton", "duration": 1, "fps": 10, "obstacles": [{obstacles}]}}"#
            )
        };
        let plane = r#"{"plane": {"point": [0, 0, 0.3], "normal": [0, 0, 1]}}"#;
        let sphere = r#"{"sphere": {"center": [0, 0, 0.3], "radius": 0.1}}"#;
        let floor = r#"{"plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}}"#;
        load(&spec(plane), &Limits::default()).expect("lying on a plane");
        let e = errors(&spec(&format!("{floor}, {sphere}")));
        assert_eq!(e.len(), 1, "{e:?}");
        assert_eq!(e[0].path, "obstacles[1]", "{e:?}");
        assert!(
            e[0].message.contains("starts inside") && e[0].message.contains("particle [5, 5]"),
            "{e:?}"
        );
        assert!(e[0].message.contains("1.000e-1 m"), "{e:?}");
        // A run builds the simulation once and refuses it alike.
        let run = |text: &str| load_scene(text, &Limits::default()).and_then(|s| build(&s));
        let refused = run(&spec(&format!("{floor}, {sphere}")));
        assert_eq!(refused.expect_err("refused").errors(), e);
        assert!(run(&spec(plane)).is_ok());
        // The service weighs a valid scene before its obstacles are built:
        // a refusal there comes first.
        #[derive(Debug, PartialEq)]
        enum Weighed {
            Over,
            Load,
        }
        impl From<SpecLoadError> for Weighed {
            fn from(_: SpecLoadError) -> Self {
                Self::Load
            }
        }
        let inside = spec(&format!("{floor}, {sphere}"));
        let over = load_spec(&inside, &Limits::default(), |_| Err(Weighed::Over));
        assert_eq!(over.map(drop), Err(Weighed::Over));
        let built = load_spec(&inside, &Limits::default(), |_| Ok(()));
        assert_eq!(built.map(drop), Err(Weighed::Load));
    }

    /// An object given as the sequence of its fields is refused: serde
    /// would read it in field order.
    #[test]
    fn objects_given_as_sequences_are_refused_at_their_path() {
        let e = errors(&OK.replace(r#"{"grid": [3, 3], "size": [1, 1]}"#, "[[3, 3], [1, 1]]"));
        assert_eq!(e[0].path, "cloth", "{e:?}");
        assert!(e[0].message.contains("invalid type: sequence"), "{e:?}");
    }

    /// Every example scene, re-serialised as the service stores it, reads
    /// back as the same spec and scene.
    #[test]
    fn specs_survive_their_re_serialisation() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes");
        let mut read = 0;
        for entry in std::fs::read_dir(dir).expect("examples") {
            let text = std::fs::read_to_string(entry.expect("entry").path()).expect("scene");
            let (scene, spec) =
                load_spec(&text, &Limits::default(), |_| Ok::<_, SpecLoadError>(()))
                    .expect("loads");
            let stored = serde_json::to_string(&spec).expect("serialises");
            assert_eq!(parse(&stored).expect("parses"), spec);
            assert_eq!(load_stored(&stored).expect("loads"), scene);
            read += 1;
        }
        assert!(read >= 9, "{read} example scenes");
    }

    /// The frame limit counts the frames written, frame 0 included.
    #[test]
    fn the_frame_limit_counts_frame_zero() {
        let limits = |max_frames| Limits {
            max_frames,
            ..Limits::default()
        };
        load(OK, &limits(11)).expect("11 frames at the limit");
        let e = load(OK, &limits(10)).expect_err("11 frames over").errors();
        assert_eq!(e[0].path, "fps", "{e:?}");
        assert!(e[0].message.starts_with("11 frames"), "{e:?}");
    }

    /// A missing or repeated field's error names the field itself.
    #[test]
    fn missing_and_repeated_fields_are_named_in_the_path() {
        assert_eq!(errors("{}")[0].path, "cloth");
        let e = errors(&OK.replace(r#""grid": [3, 3], "#, ""));
        assert_eq!(e[0].path, "cloth.grid", "{e:?}");
        let e = errors(&OK.replace(r#""fps": 10"#, r#""fps": 10, "duration": 2"#));
        assert_eq!(e[0].path, "duration", "{e:?}");
    }

    #[test]
    fn a_document_that_is_not_an_object_is_refused_as_such() {
        for text in ["[1, 2]", "\"cloth\"", " 3"] {
            let e = errors(text);
            assert_eq!(
                e[0].message, "the spec must be a JSON object",
                "{text}: {e:?}"
            );
        }
    }

    #[test]
    fn malformed_json_is_reported_as_such() {
        let e = errors(r#"{"cloth": "#);
        assert!(e[0].message.starts_with("malformed JSON"), "{e:?}");
    }

    #[test]
    fn unknown_fields_and_wrong_types_name_the_field() {
        let e = errors(&OK.replace(r#""size""#, r#""colour": 1, "size""#));
        assert!(
            e[0].path == "cloth.colour" && e[0].message.contains("unknown field"),
            "{e:?}"
        );
        let e = errors(&OK.replace("[3, 3]", "[3, -1]"));
        assert_eq!(e[0].path, "cloth.grid[1]", "{e:?}");
        let e = errors(&OK.replace(r#""cotton""#, r#"{"density": 0.1, "stretch": "x"}"#));
        assert_eq!(e[0].path, "material.stretch", "{e:?}");
    }

    /// Gravity is an acceleration: however large a component, the error
    /// is its magnitude's, in m/s², never a coordinate's bound in metres.
    #[test]
    fn gravity_too_strong_is_named_as_an_acceleration() {
        for g in ["[0, 0, -5000]", "[0, 0, -1e30]"] {
            let e = errors(&OK.replace(r#""duration""#, &format!(r#""gravity": {g}, "duration""#)));
            assert_eq!(e.len(), 1, "{g}: {e:?}");
            assert_eq!(e[0].path, "gravity", "{g}: {e:?}");
            assert!(e[0].message.contains("m/s²"), "{g}: {e:?}");
        }
    }

    #[test]
    fn every_rule_violation_is_reported_with_its_path() {
        let bad = r#"{"cloth": {"grid": [1, 3], "size": [0, 1], "pinned": [[5, 0]]},
            "material": {"density": -1, "stretch": 100, "shear": 1, "bend": 1e-5},
            "obstacles": [{"sphere": {"center": [0,0,0], "radius": 1}, "plane": {"point": [0,0,0], "normal": [0,0,0]}}],
            "duration": 1e9, "fps": 30, "solver": {"dt": 0, "tolerance": 2}}"#;
        let e = errors(bad);
        let paths: Vec<&str> = e.iter().map(|e| e.path.as_str()).collect();
        for want in [
            "cloth.grid[0]",
            "cloth.size[0]",
            "cloth.pinned[0][0]",
            "material.density",
            "obstacles[0]",
            "obstacles[0].plane.normal",
            "duration",
            "solver.tolerance",
        ] {
            assert!(paths.contains(&want), "missing {want} in {paths:?}");
        }
        let grid = e
            .iter()
            .find(|e| e.path == "cloth.grid[0]")
            .expect("grid error");
        assert_eq!(grid.to_string(), "cloth.grid[0]: must be >= 2");
    }

    #[test]
    fn absurd_sizes_are_refused_against_the_limits() {
        let e = errors(&OK.replace("[3, 3]", "[100000, 100000]"));
        assert!(
            e[0].path == "cloth.grid" && e[0].message.contains("limit"),
            "{e:?}"
        );
        let e = errors(&OK.replace("\"fps\": 10", "\"fps\": 10, \"solver\": {\"dt\": 1e-8}"));
        assert!(e.iter().any(|e| e.path == "solver.dt"), "{e:?}");
    }

    #[test]
    fn trailing_data_after_the_json_is_refused() {
        let e = load(&format!("{OK}xx"), &Limits::default()).expect_err("trailing data");
        assert!(matches!(e, SpecLoadError::Malformed(_)), "{e:?}");
        assert!(e.to_string().contains("trailing characters"), "{e}");
        load(&format!("{OK} \n"), &Limits::default()).expect("white space may follow");
    }

    #[test]
    fn a_grid_of_three_is_a_shape_error_at_cloth_grid() {
        let e = load(&OK.replace("[3, 3]", "[20, 20, 20]"), &Limits::default())
            .expect_err("three numbers");
        assert!(matches!(e, SpecLoadError::Invalid(_)), "{e:?}");
        let e = e.errors();
        assert_eq!(e[0].path, "cloth.grid", "{e:?}");
        assert!(e[0].message.contains("invalid length 3"), "{e:?}");
        let e = errors(&OK.replace("[3, 3]", "[3, \"3\"]"));
        assert_eq!(e[0].path, "cloth.grid[1]", "{e:?}");
    }

    #[test]
    fn integral_floats_are_accepted_where_an_integer_is_meant() {
        let scene =
            load(&OK.replace("[3, 3]", "[976.0, 3.0]"), &Limits::default()).expect("976.0 is 976");
        assert_eq!((scene.cloth.nu, scene.cloth.nv), (976, 3));
        let e = errors(&OK.replace("[3, 3]", "[976.5, 3]"));
        assert_eq!(e[0].path, "cloth.grid[0]", "{e:?}");
    }

    #[test]
    fn numbers_out_of_range_are_errors_not_infinities() {
        let e = errors(&OK.replace("\"duration\": 1", "\"duration\": 1e999"));
        assert!(!e.is_empty());
    }

    #[test]
    fn bad_meshes_are_refused_with_the_obstacle_path() {
        let with = |mesh: &str| {
            OK.replace(
                "\"fps\": 10",
                &format!("\"fps\": 10, \"obstacles\": [{{\"mesh\": {mesh}}}]"),
            )
        };
        let cases = [
            (
                r#"{"obj": "v 0 0 0\nf 1 2 3\n"}"#,
                "obstacles[0].mesh.obj",
                "OBJ",
            ),
            (
                r#"{"obj": "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"}"#,
                "obstacles[0].mesh.obj",
                "no triangle of non-zero area",
            ),
            (r#"{"stl": "%%%"}"#, "obstacles[0].mesh.stl", "base64"),
            (
                r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,5]]}"#,
                "obstacles[0].mesh.triangles[0][2]",
                "out of range",
            ),
            (
                r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,1]]}"#,
                "obstacles[0].mesh.triangles",
                "no triangle of non-zero area",
            ),
            (
                r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": []}"#,
                "obstacles[0].mesh.triangles",
                "empty",
            ),
        ];
        for (mesh, path, words) in cases {
            let e = errors(&with(mesh));
            assert!(
                e.iter()
                    .any(|e| e.path == path && e.message.contains(words)),
                "{mesh}: {e:?}"
            );
        }
        let tetra = r#"{"obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"}"#;
        load(&with(tetra), &Limits::default()).expect("a tetrahedron is fine");
        let few = Limits {
            max_triangles: 3,
            ..Limits::default()
        };
        let e = load(&with(tetra), &few)
            .expect_err("over the limit")
            .errors();
        assert!(e[0].message.contains("limit of 3"), "{e:?}");
    }

    /// The triangle limit holds summed over obstacles, an OBJ's faces are
    /// counted before it is parsed, and the obstacles are bounded in
    /// number before any is looked into.
    #[test]
    fn obstacles_are_bounded_in_all() {
        let with = |obstacles: &[String]| {
            OK.replace(
                "\"fps\": 10",
                &format!("\"fps\": 10, \"obstacles\": [{}]", obstacles.join(",")),
            )
        };
        let tetra = r#"{"mesh": {"obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"}}"#;
        let limits = Limits {
            max_triangles: 6,
            max_obstacles: 3,
            ..Limits::default()
        };
        load(&with(&[tetra.to_owned()]), &limits).expect("4 of 6 triangles");
        let e = load(&with(&[tetra.to_owned(), tetra.to_owned()]), &limits)
            .expect_err("8 of 6 triangles")
            .errors();
        assert_eq!(e.len(), 1, "{e:?}");
        assert_eq!(e[0].path, "obstacles[1].mesh.obj", "{e:?}");
        assert!(e[0].message.contains("make 8"), "{e:?}");
        // One face of 1,000 corners is 998 triangles, refused unparsed.
        let corners: Vec<String> = (1..=1000).map(|k| k.to_string()).collect();
        let fan = format!(
            r#"{{"mesh": {{"obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf {}\n"}}}}"#,
            corners.join(" ")
        );
        let e = load(&with(&[fan]), &limits)
            .expect_err("998 triangles")
            .errors();
        assert_eq!(e[0].path, "obstacles[0].mesh.obj", "{e:?}");
        assert!(e[0].message.starts_with("998 triangles"), "{e:?}");
        let plane = r#"{"plane": {"point": [0, 0, -1], "normal": [0, 0, 1]}}"#.to_owned();
        load(&with(&vec![plane.clone(); 3]), &limits).expect("3 obstacles");
        let e = load(&with(&vec![plane; 4]), &limits)
            .expect_err("4 obstacles")
            .errors();
        assert_eq!(e[0].path, "obstacles", "{e:?}");
        assert!(e[0].message.contains("limit of 3"), "{e:?}");
    }
}
