//! The OpenAPI document and the job spec's JSON Schema (`document`), with
//! the spec's per-field rules written into its schema (`spec_schema`), so a
//! schema-driven client builds specs the server accepts.

mod document;
mod spec_schema;

pub use document::{Profile, document, job_schema, json, serve_document, serve_job_schema, yaml};
