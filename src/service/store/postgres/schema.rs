//! The tables in PostgreSQL and their versions. Every node migrates at
//! start; an advisory lock held for the migration's transaction makes
//! nodes starting together take turns, and the versions applied are
//! rows of `drapery_schema`.

use tokio_postgres::Client;

/// Version 1: jobs with their leases, frames, checkpoints.
const V1: &str = "
CREATE TABLE jobs (
    seq              BIGSERIAL PRIMARY KEY,
    id               TEXT NOT NULL UNIQUE,
    owner            TEXT NOT NULL,
    name             TEXT NOT NULL,
    status           TEXT NOT NULL,
    spec             TEXT NOT NULL,
    hello            TEXT NOT NULL,
    frames_total     BIGINT NOT NULL,
    frames_done      BIGINT NOT NULL DEFAULT 0,
    created_at       DOUBLE PRECISION NOT NULL,
    started_at       DOUBLE PRECISION,
    finished_at      DOUBLE PRECISION,
    run_seconds      DOUBLE PRECISION NOT NULL DEFAULT 0,
    attempts         INTEGER NOT NULL DEFAULT 0,
    error            TEXT,
    stats            TEXT,
    node             TEXT,
    lease_until      DOUBLE PRECISION,
    cancel_requested BOOLEAN NOT NULL DEFAULT FALSE
);
CREATE INDEX jobs_by_owner ON jobs (owner, seq);
CREATE INDEX jobs_by_status ON jobs (status, seq);
CREATE TABLE frames (
    job       BIGINT NOT NULL REFERENCES jobs (seq),
    n         BIGINT NOT NULL,
    time      DOUBLE PRECISION NOT NULL,
    positions BYTEA NOT NULL,
    stats     TEXT NOT NULL,
    PRIMARY KEY (job, n)
);
-- Positions are float bits: compression costs time and saves nothing.
ALTER TABLE frames ALTER COLUMN positions SET STORAGE EXTERNAL;
CREATE TABLE checkpoints (
    job   BIGINT PRIMARY KEY REFERENCES jobs (seq),
    frame BIGINT NOT NULL,
    data  BYTEA NOT NULL
);
ALTER TABLE checkpoints ALTER COLUMN data SET STORAGE EXTERNAL;
";

/// The migrations in order; version `k + 1` is `MIGRATIONS[k]`.
const MIGRATIONS: [&str; 1] = [V1];

/// Any constant: the advisory lock nodes take turns on while migrating.
const MIGRATION_LOCK: i64 = 0x0064_7261_7065_7279;

/// Why the schema could not be brought up to date.
#[derive(Debug)]
pub enum MigrateError {
    Postgres(tokio_postgres::Error),
    Newer { found: i64 },
}

impl From<tokio_postgres::Error> for MigrateError {
    fn from(e: tokio_postgres::Error) -> Self {
        Self::Postgres(e)
    }
}

impl From<MigrateError> for crate::service::store::StoreError {
    fn from(e: MigrateError) -> Self {
        match e {
            MigrateError::Postgres(e) => e.into(),
            MigrateError::Newer { found } => Self::Newer {
                found,
                known: MIGRATIONS.len() as i64,
            },
        }
    }
}

/// Applies the migrations this database lacks, in one transaction.
pub async fn migrate(c: &mut Client) -> Result<Result<(), MigrateError>, tokio_postgres::Error> {
    let tx = c.transaction().await?;
    tx.execute("SELECT pg_advisory_xact_lock($1)", &[&MIGRATION_LOCK])
        .await?;
    tx.batch_execute(
        "CREATE TABLE IF NOT EXISTS drapery_schema (
             version    INTEGER PRIMARY KEY,
             applied_at TIMESTAMPTZ NOT NULL DEFAULT now())",
    )
    .await?;
    let found: i64 = tx
        .query_one(
            "SELECT COALESCE(MAX(version), 0)::BIGINT FROM drapery_schema",
            &[],
        )
        .await?
        .get(0);
    if found > MIGRATIONS.len() as i64 {
        return Ok(Err(MigrateError::Newer { found }));
    }
    for (k, sql) in MIGRATIONS.iter().enumerate().skip(found.max(0) as usize) {
        tx.batch_execute(sql).await?;
        tx.execute(
            "INSERT INTO drapery_schema (version) VALUES ($1)",
            &[&(k as i32 + 1)],
        )
        .await?;
    }
    tx.commit().await?;
    Ok(Ok(()))
}
