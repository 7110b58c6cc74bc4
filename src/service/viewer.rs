//! The browser viewer at `GET /`: a page, its script and stylesheet, and
//! the vendored three.js and uPlot (with their licences), all embedded in
//! the binary so the server needs no CDN and no files at run time; plus
//! the bundled example scenes the page offers for submission.

use axum::extract::Path;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

use super::error::ApiError;

/// An embedded file: name under `/assets/`, media type, content.
struct Asset(&'static str, &'static str, &'static [u8]);

macro_rules! viewer_file {
    ($name:literal, $type:literal) => {
        Asset(
            $name,
            $type,
            include_bytes!(concat!("../../viewer/", $name)),
        )
    };
}

const JS: &str = "text/javascript; charset=utf-8";

const ASSETS: &[Asset] = &[
    viewer_file!("app.js", "text/javascript; charset=utf-8"),
    viewer_file!("style.css", "text/css; charset=utf-8"),
    Asset(
        "three.module.min.js",
        JS,
        include_bytes!("../../viewer/vendor/three.module.min.js"),
    ),
    Asset(
        "three.core.min.js",
        JS,
        include_bytes!("../../viewer/vendor/three.core.min.js"),
    ),
    Asset(
        "OrbitControls.js",
        JS,
        include_bytes!("../../viewer/vendor/OrbitControls.js"),
    ),
    Asset(
        "uPlot.iife.min.js",
        JS,
        include_bytes!("../../viewer/vendor/uPlot.iife.min.js"),
    ),
    Asset(
        "uPlot.min.css",
        "text/css; charset=utf-8",
        include_bytes!("../../viewer/vendor/uPlot.min.css"),
    ),
    Asset(
        "LICENSE-three.txt",
        "text/plain; charset=utf-8",
        include_bytes!("../../viewer/vendor/LICENSE-three.txt"),
    ),
    Asset(
        "LICENSE-uplot.txt",
        "text/plain; charset=utf-8",
        include_bytes!("../../viewer/vendor/LICENSE-uplot.txt"),
    ),
];

const INDEX: &str = include_str!("../../viewer/index.html");

/// The example scenes, by name.
const EXAMPLES: &[(&str, &str)] = &[
    (
        "cantilever",
        include_str!("../../examples/scenes/cantilever.json"),
    ),
    (
        "free-fall",
        include_str!("../../examples/scenes/free-fall.json"),
    ),
    (
        "hanging-corners",
        include_str!("../../examples/scenes/hanging-corners.json"),
    ),
    (
        "pedestal-mesh",
        include_str!("../../examples/scenes/pedestal-mesh.json"),
    ),
    (
        "rising-sphere",
        include_str!("../../examples/scenes/rising-sphere.json"),
    ),
    (
        "rotating-sphere",
        include_str!("../../examples/scenes/rotating-sphere.json"),
    ),
    (
        "sphere-drape-30",
        include_str!("../../examples/scenes/sphere-drape-30.json"),
    ),
    (
        "sphere-drape-100",
        include_str!("../../examples/scenes/sphere-drape-100.json"),
    ),
    (
        "sphere-drape-30-self-collision",
        include_str!("../../examples/scenes/sphere-drape-30-self-collision.json"),
    ),
    (
        "table-drape",
        include_str!("../../examples/scenes/table-drape.json"),
    ),
];

/// `GET /`: the page.
pub async fn index() -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        INDEX,
    )
        .into_response()
}

/// `GET /assets/{file}`.
pub async fn asset(Path(file): Path<String>) -> Response {
    match ASSETS.iter().find(|a| a.0 == file) {
        Some(Asset(_, content_type, bytes)) => (
            [
                (header::CONTENT_TYPE, *content_type),
                (header::CACHE_CONTROL, "no-cache"),
            ],
            *bytes,
        )
            .into_response(),
        None => ApiError::not_found("such asset").into_response(),
    }
}

/// `GET /examples`: the example names.
pub async fn examples() -> Response {
    let names: Vec<&str> = EXAMPLES.iter().map(|e| e.0).collect();
    axum::Json(names).into_response()
}

/// `GET /examples/{name}`: one example spec.
pub async fn example(Path(name): Path<String>) -> Response {
    match EXAMPLES.iter().find(|e| e.0 == name) {
        Some((_, text)) => (
            StatusCode::OK,
            [(header::CONTENT_TYPE, "application/json")],
            *text,
        )
            .into_response(),
        None => ApiError::not_found("such example").into_response(),
    }
}

/// Bytes the page loads on first visit (page, script, styles, libraries).
pub fn load_size() -> usize {
    INDEX.len()
        + ASSETS
            .iter()
            .filter(|a| !a.0.starts_with("LICENSE"))
            .map(|a| a.2.len())
            .sum::<usize>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use drapery_sim::spec::Limits;

    #[test]
    fn every_example_is_a_valid_spec() {
        for (name, text) in EXAMPLES {
            crate::specfile::load(text, &Limits::default())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }

    #[test]
    fn page_references_only_embedded_assets() {
        for line in INDEX
            .lines()
            .chain(std::str::from_utf8(ASSETS[0].2).unwrap_or("").lines())
        {
            if let Some(i) = line.find("/assets/") {
                let rest = &line[i + 8..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || matches!(c, '.' | '-' | '_'))
                    .collect();
                assert!(ASSETS.iter().any(|a| a.0 == name), "{name} is not embedded");
            }
        }
        assert!(load_size() > 100_000);
    }
}
