//! The store's schema and its versioned migrations, one list for both back
//! ends: the same tables and columns, in each database's own words where
//! they differ (an identity column, the number types).
//!
//! `fivecal_schema` keeps one row per migration applied; the highest
//! version is the schema's. Opening a store applies what is missing, in one
//! transaction under a lock (SQLite's write lock, a PostgreSQL advisory
//! lock), so two runs opening a new store at once migrate it once. A store
//! newer than this fivecal is refused rather than misread.

use super::StoreError;
use super::sql::{Backend, Conn, SqlValue};

/// One step of the schema.
pub(crate) struct Migration {
    /// Version reached by this step.
    pub version: i64,
    /// What it does (kept in `fivecal_schema`).
    pub description: &'static str,
    /// The statements for SQLite.
    pub sqlite: &'static str,
    /// The statements for PostgreSQL.
    pub postgres: &'static str,
}

/// Every migration, in order. Never edit a released one: add a step.
pub(crate) const MIGRATIONS: &[Migration] = &[
    Migration {
        version: 1,
        description: "records of analyze, discover and export runs, with the files they read",
        sqlite: "
            CREATE TABLE records (
                id           INTEGER PRIMARY KEY AUTOINCREMENT,
                machine      TEXT NOT NULL,
                kind         TEXT NOT NULL CHECK (kind IN ('analyze', 'discover', 'export')),
                test         TEXT,
                measured_at  TEXT NOT NULL,
                recorded_at  TEXT NOT NULL,
                tool_version TEXT NOT NULL,
                result_name  TEXT NOT NULL,
                content      TEXT NOT NULL,
                note         TEXT,
                temperature  REAL,
                controller   TEXT,
                exported     TEXT
            );
            CREATE TABLE record_files (
                record_id INTEGER NOT NULL REFERENCES records (id) ON DELETE CASCADE,
                position  INTEGER NOT NULL,
                role      TEXT NOT NULL CHECK (role IN ('measured', 'plan', 'errors')),
                path      TEXT NOT NULL,
                sha256    TEXT NOT NULL,
                PRIMARY KEY (record_id, position)
            );
            CREATE INDEX records_by_machine ON records (machine, measured_at, id);
        ",
        postgres: "
            CREATE TABLE records (
                id           BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
                machine      TEXT NOT NULL,
                kind         TEXT NOT NULL CHECK (kind IN ('analyze', 'discover', 'export')),
                test         TEXT,
                measured_at  TEXT NOT NULL,
                recorded_at  TEXT NOT NULL,
                tool_version TEXT NOT NULL,
                result_name  TEXT NOT NULL,
                content      TEXT NOT NULL,
                note         TEXT,
                temperature  DOUBLE PRECISION,
                controller   TEXT,
                exported     TEXT
            );
            CREATE TABLE record_files (
                record_id BIGINT NOT NULL REFERENCES records (id) ON DELETE CASCADE,
                position  BIGINT NOT NULL,
                role      TEXT NOT NULL CHECK (role IN ('measured', 'plan', 'errors')),
                path      TEXT NOT NULL,
                sha256    TEXT NOT NULL,
                PRIMARY KEY (record_id, position)
            );
            CREATE INDEX records_by_machine ON records (machine, measured_at, id);
        ",
    },
    Migration {
        version: 2,
        description: "the fit verdict of a result (fits, misfit; NULL when unknown)",
        sqlite: "ALTER TABLE records ADD COLUMN fit TEXT CHECK (fit IN ('fits', 'misfit'));",
        postgres: "ALTER TABLE records ADD COLUMN fit TEXT CHECK (fit IN ('fits', 'misfit'));",
    },
];

/// The schema version this fivecal writes.
pub const CURRENT_VERSION: i64 = MIGRATIONS[MIGRATIONS.len() - 1].version;

/// An arbitrary constant naming the migration lock among PostgreSQL's
/// advisory locks.
const PG_LOCK: i64 = 0x0066_6976_6563_616c;

/// The version of the store `c` is in (0: empty).
pub(crate) fn version(c: &mut dyn Conn) -> Result<i64, StoreError> {
    let exists = match c.backend() {
        Backend::Sqlite => c.query(
            "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'fivecal_schema'",
            &[],
        )?,
        Backend::Postgres => c.query(
            "SELECT 1 FROM information_schema.tables WHERE table_schema = current_schema() AND table_name = 'fivecal_schema'",
            &[],
        )?,
    };
    if exists.is_empty() {
        return Ok(0);
    }
    let rows = c.query("SELECT MAX(version) FROM fivecal_schema", &[])?;
    Ok(rows
        .first()
        .and_then(|r| r.first())
        .map(|v| v.int())
        .transpose()?
        .flatten()
        .unwrap_or(0))
}

/// Brings the store to `target` (at most [`CURRENT_VERSION`]); called
/// inside a write transaction.
pub(crate) fn migrate(c: &mut dyn Conn, target: i64, now: &str) -> Result<i64, StoreError> {
    if c.backend() == Backend::Postgres {
        c.exec(
            "SELECT pg_advisory_xact_lock(?)",
            &[SqlValue::Int(Some(PG_LOCK))],
        )?;
    }
    let found = version(c)?;
    if found > CURRENT_VERSION {
        return Err(StoreError::NewerSchema {
            found,
            known: CURRENT_VERSION,
        });
    }
    if found == 0 {
        c.batch(
            "CREATE TABLE fivecal_schema (
                version      BIGINT NOT NULL PRIMARY KEY,
                description  TEXT NOT NULL,
                applied_at   TEXT NOT NULL,
                tool_version TEXT NOT NULL
            );",
        )?;
    }
    for m in MIGRATIONS
        .iter()
        .filter(|m| m.version > found && m.version <= target)
    {
        c.batch(match c.backend() {
            Backend::Sqlite => m.sqlite,
            Backend::Postgres => m.postgres,
        })?;
        c.exec(
            "INSERT INTO fivecal_schema (version, description, applied_at, tool_version) VALUES (?, ?, ?, ?)",
            &[
                SqlValue::Int(Some(m.version)),
                SqlValue::text(m.description),
                SqlValue::text(now),
                SqlValue::text(super::TOOL_VERSION),
            ],
        )?;
    }
    version(c)
}
