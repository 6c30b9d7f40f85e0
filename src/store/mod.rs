//! The results store: every result `analyze`, `discover` and `compensate
//! --export` produce, kept per machine, so a machine's history can be
//! listed, plotted, trended and compared (`fivecal history`, `fivecal
//! verify`).
//!
//! Two back ends with one schema (see `docs/history.md`) and one set of queries: an
//! embedded SQLite file (the default, in the user's data directory) and a
//! PostgreSQL server for a shop that keeps many machines in one place
//! (`postgres://...`). Every write is one transaction, so a crash
//! mid-write loses nothing recorded before it; SQLite runs in WAL mode with
//! a busy timeout and PostgreSQL serialises through its own transactions,
//! so two runs writing at once both land. The layout is described in
//! `docs/history.md`.

pub mod runs;
mod schema;
mod sql;

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Duration;

use jiff::Timestamp;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

pub use schema::CURRENT_VERSION;
use sql::{Conn, SqlValue};

/// The version of fivecal that writes a record.
pub(crate) const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Environment variable naming the store when `--db` is not given.
pub(crate) const ENV_DB: &str = "FIVECAL_DB";

/// How long the store may take by default (`--db-timeout` changes it):
/// to connect and log in to a PostgreSQL server, to wait for another run
/// holding SQLite's write lock or a PostgreSQL lock, and for an
/// unacknowledged write to a server. A server that accepts and never
/// answers, or answers what is not PostgreSQL, ends the run after this
/// long with a message naming it.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(30);

/// What a run does with the store.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Records into it: created when new, its schema brought up to date.
    ReadWrite,
    /// Only reads it (history, verify): never created, migrated or
    /// otherwise changed; SQLite opens the file read-only.
    ReadOnly,
}

/// Why the store could not do what was asked.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The database refused or failed.
    #[error("results store {location}: {message}")]
    Database {
        /// The store (a path, or a URL without its password).
        location: String,
        /// What the database said.
        message: String,
    },
    /// A database error before its location is attached.
    #[error("{0}")]
    Sql(String),
    /// The store was written by a newer fivecal.
    #[error(
        "the store has schema version {found}, this fivecal ({}) knows versions up to {known}: use a newer fivecal",
        TOOL_VERSION
    )]
    NewerSchema {
        /// The store's version.
        found: i64,
        /// The newest this build knows.
        known: i64,
    },
    /// A value in the store that this fivecal did not write.
    #[error("unexpected content: {0}")]
    Corrupt(String),
    /// No data directory for the default store.
    #[error(
        "no data directory for the default results store (neither XDG_DATA_HOME nor HOME is set): give --db PATH, set {ENV_DB}, or --no-record"
    )]
    NoDataDir,
    /// A file to hash could not be read.
    #[error("cannot read {path} to hash it: {cause}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// A record that cannot be stored as given.
    #[error("{0}")]
    Invalid(String),
}

impl From<rusqlite::Error> for StoreError {
    fn from(e: rusqlite::Error) -> Self {
        StoreError::Sql(e.to_string())
    }
}

impl From<postgres::Error> for StoreError {
    fn from(e: postgres::Error) -> Self {
        let msg = match e.as_db_error() {
            Some(db) => db.to_string(),
            None => {
                let mut m = e.to_string();
                let mut src = std::error::Error::source(&e);
                while let Some(s) = src {
                    m.push_str(": ");
                    m.push_str(&s.to_string());
                    src = s.source();
                }
                m
            }
        };
        StoreError::Sql(msg)
    }
}

/// What produced a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RecordKind {
    /// An `analyze` result.
    Analyze,
    /// A `discover` result (the final model).
    Discover,
    /// `compensate --export`: the values put into the control.
    Export,
}

impl RecordKind {
    /// The name stored and printed.
    pub fn name(self) -> &'static str {
        match self {
            RecordKind::Analyze => "analyze",
            RecordKind::Discover => "discover",
            RecordKind::Export => "export",
        }
    }
}

impl fmt::Display for RecordKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for RecordKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "analyze" => Ok(RecordKind::Analyze),
            "discover" => Ok(RecordKind::Discover),
            "export" => Ok(RecordKind::Export),
            _ => Err(format!(
                "unknown record kind `{s}`: expected analyze, discover or export"
            )),
        }
    }
}

pub use crate::errorfile::FitVerdict;

/// What a hashed file was to the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FileRole {
    /// A measurement file (CMM output, probe log).
    Measured,
    /// The plan manifest.
    Plan,
    /// The error file an export was made from.
    Errors,
}

impl FileRole {
    fn name(self) -> &'static str {
        match self {
            FileRole::Measured => "measured",
            FileRole::Plan => "plan",
            FileRole::Errors => "errors",
        }
    }
}

impl FromStr for FileRole {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "measured" => Ok(FileRole::Measured),
            "plan" => Ok(FileRole::Plan),
            "errors" => Ok(FileRole::Errors),
            _ => Err(format!("unknown file role `{s}`")),
        }
    }
}

/// A file a run read, with its SHA-256.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileHash {
    /// What it was.
    pub role: FileRole,
    /// The path as named on the command line.
    pub path: String,
    /// SHA-256 of its bytes, lower-case hex.
    pub sha256: String,
}

impl FileHash {
    /// Hashes the file at `path`.
    pub fn of(role: FileRole, path: &Path) -> Result<FileHash, StoreError> {
        let bytes = std::fs::read(path).map_err(|cause| StoreError::Read {
            path: path.to_path_buf(),
            cause,
        })?;
        Ok(FileHash {
            role,
            path: path.display().to_string(),
            sha256: sha256_hex(&bytes),
        })
    }
}

/// SHA-256 of `bytes`, lower-case hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use std::fmt::Write;
    Sha256::digest(bytes)
        .iter()
        .fold(String::with_capacity(64), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}

/// A date-time as stored: RFC 3339 in UTC with microseconds, so the text
/// sorts as the time does.
pub(crate) fn format_time(t: Timestamp) -> String {
    t.strftime("%Y-%m-%dT%H:%M:%S%.6fZ").to_string()
}

/// A date-time that does not read as RFC 3339.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{text}`: expected an RFC 3339 date-time such as 2026-03-01T08:30:00Z ({why})")]
pub struct TimeError {
    /// The text given.
    pub text: String,
    /// The parser's reason.
    pub why: String,
}

/// Reads an RFC 3339 date-time (any offset).
pub fn parse_time(s: &str) -> Result<Timestamp, TimeError> {
    s.parse::<Timestamp>().map_err(|e| TimeError {
        text: s.to_string(),
        why: e.to_string(),
    })
}

/// One result as kept.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Record {
    /// The machine's name (the result file's `machine`).
    pub machine: String,
    /// What produced it.
    pub kind: RecordKind,
    /// The test (`stepped-square`, ...); none for an export.
    pub test: Option<String>,
    /// When the machine was measured (the time trends use).
    #[serde(serialize_with = "ser_time")]
    pub measured_at: Timestamp,
    /// When the record was written.
    #[serde(serialize_with = "ser_time")]
    pub recorded_at: Timestamp,
    /// The fivecal version that wrote it.
    pub tool_version: String,
    /// The result file as named on the command line.
    pub result_name: String,
    /// The result file's content (an export: the error file exported).
    pub content: String,
    /// The fit verdict, when the result states one.
    pub fit: Option<FitVerdict>,
    /// The files the run read, with their hashes.
    pub files: Vec<FileHash>,
    /// A free note (`--note`).
    pub note: Option<String>,
    /// The machine's temperature, deg C (`--temperature`).
    pub temperature: Option<f64>,
    /// An export: the controller (`fanuc`, ...).
    pub controller: Option<String>,
    /// An export: the parameter text written.
    pub exported: Option<String>,
}

fn ser_time<S: serde::Serializer>(t: &Timestamp, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format_time(*t))
}

impl Record {
    /// A record of `kind` for `machine` measured and recorded now, by this
    /// fivecal, with nothing optional set.
    pub fn new(kind: RecordKind, machine: &str, result_name: &str, content: String) -> Record {
        // The store keeps microseconds.
        let now = Timestamp::from_microsecond(Timestamp::now().as_microsecond())
            .expect("the present is a valid time");
        Record {
            machine: machine.to_string(),
            kind,
            test: None,
            measured_at: now,
            recorded_at: now,
            tool_version: TOOL_VERSION.to_string(),
            result_name: result_name.to_string(),
            fit: FitVerdict::of_result(&content),
            content,
            files: Vec::new(),
            note: None,
            temperature: None,
            controller: None,
            exported: None,
        }
    }
}

/// A record with its id in the store.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Stored {
    /// The id (increasing in the order records were written).
    pub id: i64,
    /// The record.
    #[serde(flatten)]
    pub record: Record,
}

/// Where the store is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// An SQLite file.
    Sqlite(PathBuf),
    /// A PostgreSQL connection URL.
    Postgres(String),
}

impl Location {
    /// `postgres://...` or `postgresql://...` is a server, anything else a
    /// file path.
    pub fn parse(spec: &str) -> Location {
        if spec.starts_with("postgres://") || spec.starts_with("postgresql://") {
            Location::Postgres(spec.to_string())
        } else {
            Location::Sqlite(PathBuf::from(spec))
        }
    }

    /// The default SQLite file: `fivecal/history.db` in the user's data
    /// directory (`$XDG_DATA_HOME`, else `~/.local/share` on Linux).
    pub(crate) fn default_path() -> Result<PathBuf, StoreError> {
        dirs::data_dir()
            .map(|d| d.join("fivecal").join("history.db"))
            .ok_or(StoreError::NoDataDir)
    }

    /// `db` if given, else the `FIVECAL_DB` environment variable, else
    /// the default file.
    ///
    /// An SQLite file is noted as an input of the run
    /// ([`crate::io::note_input`]): no output of the run may land on the
    /// store it records into or reads.
    pub fn resolve(db: Option<&str>) -> Result<Location, StoreError> {
        let l = match db {
            Some(d) => Location::parse(d),
            None => match std::env::var(ENV_DB) {
                Ok(v) if !v.is_empty() => Location::parse(&v),
                _ => Location::Sqlite(Location::default_path()?),
            },
        };
        if let Location::Sqlite(p) = &l {
            crate::io::note_input(p, "the results store");
        }
        Ok(l)
    }
}

impl fmt::Display for Location {
    /// A path as is; a URL without its password.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Sqlite(p) => write!(f, "{}", p.display()),
            Location::Postgres(url) => {
                let shown = match (url.find("://"), url.rfind('@')) {
                    (Some(s), Some(at)) if at > s => {
                        let cred = &url[s + 3..at];
                        match cred.find(':') {
                            Some(c) => format!("{}{}:***{}", &url[..s + 3], &cred[..c], &url[at..]),
                            None => url.clone(),
                        }
                    }
                    _ => url.clone(),
                };
                f.write_str(&shown)
            }
        }
    }
}

enum Connection {
    Sqlite(rusqlite::Connection),
    Postgres(Box<postgres::Client>),
}

/// An open store.
pub struct Store {
    conn: Connection,
    location: Location,
    /// Its schema version when opened (a read-only store may be older
    /// than this fivecal: the columns it lacks read as NULL).
    version: i64,
}

/// Several records written in one transaction: all land on
/// [`Batch::commit`], none if it is dropped or the process dies first.
pub struct Batch<'a> {
    tx: BatchTx<'a>,
    location: &'a Location,
}

enum BatchTx<'a> {
    Sqlite(rusqlite::Transaction<'a>),
    Postgres(postgres::Transaction<'a>),
}

impl Batch<'_> {
    fn conn(&mut self) -> &mut dyn Conn {
        match &mut self.tx {
            BatchTx::Sqlite(t) => t,
            BatchTx::Postgres(t) => t,
        }
    }

    /// Adds a record; returns its id (visible to others after the commit).
    pub fn insert(&mut self, r: &Record) -> Result<i64, StoreError> {
        let loc = self.location.to_string();
        insert(self.conn(), r).map_err(|e| at(e, &loc))
    }

    /// Makes every inserted record durable at once.
    pub fn commit(self) -> Result<(), StoreError> {
        let loc = self.location.to_string();
        match self.tx {
            BatchTx::Sqlite(t) => t.commit().map_err(StoreError::from),
            BatchTx::Postgres(t) => t.commit().map_err(StoreError::from),
        }
        .map_err(|e| at(e, &loc))
    }
}

/// Attaches the store's location to a database error.
fn at(e: StoreError, location: &str) -> StoreError {
    match e {
        StoreError::Sql(message) => StoreError::Database {
            location: location.to_string(),
            message,
        },
        StoreError::NewerSchema { .. } | StoreError::Corrupt(_) => StoreError::Database {
            location: location.to_string(),
            message: e.to_string(),
        },
        other => other,
    }
}

impl Store {
    /// Opens the store at `location`, creating it (and an SQLite file's
    /// directory) when needed and bringing its schema up to date.
    pub fn open(location: &Location) -> Result<Store, StoreError> {
        Store::open_with(location, Access::ReadWrite, DEFAULT_TIMEOUT)
    }

    /// Opens the store at `location` for `access`, waiting at most
    /// `timeout` to connect and for a lock. Read-only: an SQLite file must
    /// exist and is opened read-only (a file without fivecal's tables reads
    /// as an empty store); a store newer than this fivecal is refused.
    pub fn open_with(
        location: &Location,
        access: Access,
        timeout: Duration,
    ) -> Result<Store, StoreError> {
        if access == Access::ReadWrite {
            return Store::open_migrated(location, CURRENT_VERSION, timeout);
        }
        let loc = location.to_string();
        let conn = connect(location, access, timeout).map_err(|e| at(e, &loc))?;
        let mut store = Store {
            conn,
            location: location.clone(),
            version: 0,
        };
        let found = store.read(schema::version)?;
        if found > CURRENT_VERSION {
            return Err(at(
                StoreError::NewerSchema {
                    found,
                    known: CURRENT_VERSION,
                },
                &loc,
            ));
        }
        store.version = found;
        Ok(store)
    }

    /// Opens the store migrated only up to schema `version`: the store an
    /// older fivecal left (for tests of the migrations). A store already
    /// beyond `version` stays as it is.
    pub fn open_at_version(location: &Location, version: i64) -> Result<Store, StoreError> {
        Store::open_migrated(location, version, DEFAULT_TIMEOUT)
    }

    fn open_migrated(
        location: &Location,
        version: i64,
        timeout: Duration,
    ) -> Result<Store, StoreError> {
        let loc = location.to_string();
        let conn = connect(location, Access::ReadWrite, timeout).map_err(|e| at(e, &loc))?;
        let mut store = Store {
            conn,
            location: location.clone(),
            version: 0,
        };
        let now = format_time(Timestamp::now());
        store.version = store.write(|c| schema::migrate(c, version.min(CURRENT_VERSION), &now))?;
        Ok(store)
    }

    /// Where the store is.
    pub fn location(&self) -> &Location {
        &self.location
    }

    /// The schema version of the store.
    pub fn schema_version(&mut self) -> Result<i64, StoreError> {
        self.read(schema::version)
    }

    /// Writes one record in its own transaction; returns its id.
    pub fn record(&mut self, r: &Record) -> Result<i64, StoreError> {
        let mut b = self.batch()?;
        let id = b.insert(r)?;
        b.commit()?;
        Ok(id)
    }

    /// Starts a transaction for several records.
    pub fn batch(&mut self) -> Result<Batch<'_>, StoreError> {
        let loc = self.location.to_string();
        let tx = match &mut self.conn {
            Connection::Sqlite(c) => BatchTx::Sqlite(
                c.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)
                    .map_err(|e| at(e.into(), &loc))?,
            ),
            Connection::Postgres(c) => {
                BatchTx::Postgres(c.transaction().map_err(|e| at(e.into(), &loc))?)
            }
        };
        Ok(Batch {
            tx,
            location: &self.location,
        })
    }

    /// Every record, or a machine's, oldest measurement first.
    pub fn list(&mut self, machine: Option<&str>) -> Result<Vec<Stored>, StoreError> {
        let m = machine.map(str::to_string);
        let v = self.version;
        self.read(move |c| select(c, v, m.as_deref(), None))
    }

    /// One record.
    pub fn get(&mut self, id: i64) -> Result<Option<Stored>, StoreError> {
        let v = self.version;
        self.read(move |c| Ok(select(c, v, None, Some(id))?.into_iter().next()))
    }

    /// The machines with records, and how many each has.
    pub fn machines(&mut self) -> Result<Vec<(String, i64)>, StoreError> {
        if self.version == 0 {
            return Ok(Vec::new());
        }
        self.read(|c| {
            c.query(
                "SELECT machine, COUNT(*) FROM records GROUP BY machine ORDER BY machine",
                &[],
            )?
            .iter()
            .map(|r| Ok((r[0].text_req("machine")?, r[1].int()?.unwrap_or(0))))
            .collect()
        })
    }

    fn write<T>(
        &mut self,
        f: impl FnOnce(&mut dyn Conn) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        let loc = self.location.to_string();
        let r = match &mut self.conn {
            Connection::Sqlite(c) => (|| -> Result<T, StoreError> {
                let mut t =
                    c.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
                let v = f(&mut t)?;
                t.commit()?;
                Ok(v)
            })(),
            Connection::Postgres(c) => (|| -> Result<T, StoreError> {
                let mut t = c.transaction()?;
                let v = f(&mut t)?;
                t.commit()?;
                Ok(v)
            })(),
        };
        r.map_err(|e| at(e, &loc))
    }

    fn read<T>(
        &mut self,
        f: impl FnOnce(&mut dyn Conn) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        let loc = self.location.to_string();
        let r = match &mut self.conn {
            Connection::Sqlite(c) => (|| -> Result<T, StoreError> {
                let mut t = c.transaction()?;
                f(&mut t)
            })(),
            Connection::Postgres(c) => (|| -> Result<T, StoreError> {
                let mut t = c.build_transaction().read_only(true).start()?;
                f(&mut t)
            })(),
        };
        r.map_err(|e| at(e, &loc))
    }
}

fn connect(
    location: &Location,
    access: Access,
    timeout: Duration,
) -> Result<Connection, StoreError> {
    match location {
        Location::Sqlite(path) if access == Access::ReadOnly => {
            use rusqlite::OpenFlags;
            if !path.is_file() {
                return Err(StoreError::Sql(
                    "no store there (reading never creates one)".into(),
                ));
            }
            // With no write-ahead log beside it, every committed record is
            // in the file itself: it is read as immutable, so that not even
            // the lock and log files SQLite keeps beside a WAL store are
            // created. With a log (a writer is connected, or one was
            // killed), the log is read under SQLite's locks, read-only.
            let mut wal = path.as_os_str().to_owned();
            wal.push("-wal");
            let immutable = !Path::new(&wal).exists();
            let c = if immutable {
                let uri = format!("file:{}?immutable=1", uri_path(path));
                rusqlite::Connection::open_with_flags(
                    uri,
                    OpenFlags::SQLITE_OPEN_READ_ONLY
                        | OpenFlags::SQLITE_OPEN_NO_MUTEX
                        | OpenFlags::SQLITE_OPEN_URI,
                )?
            } else {
                rusqlite::Connection::open_with_flags(
                    path,
                    OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
                )?
            };
            c.busy_timeout(timeout)?;
            Ok(Connection::Sqlite(c))
        }
        Location::Sqlite(path) => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| {
                    StoreError::Sql(format!(
                        "cannot create the directory {}: {e}",
                        dir.display()
                    ))
                })?;
            }
            let c = rusqlite::Connection::open(path)?;
            c.busy_timeout(timeout)?;
            // WAL: readers do not block the writer, and a writer killed
            // mid-transaction leaves the committed state intact.
            let mode: String = retry_busy(timeout, || {
                c.query_row("PRAGMA journal_mode = WAL", [], |r| r.get(0))
            })?;
            if !mode.eq_ignore_ascii_case("wal") {
                return Err(StoreError::Sql(format!(
                    "the file cannot be put in WAL mode (journal mode {mode})"
                )));
            }
            // FULL: a commit survives a power cut too, not only a crash.
            c.pragma_update(None, "synchronous", "FULL")?;
            c.pragma_update(None, "foreign_keys", "ON")?;
            Ok(Connection::Sqlite(c))
        }
        Location::Postgres(url) => {
            let mut cfg = postgres::Config::from_str(url)?;
            if cfg.get_connect_timeout().is_none() {
                cfg.connect_timeout(timeout);
            }
            // A write the server does not acknowledge, and a lock held by
            // another session, end the statement after `timeout` too.
            cfg.tcp_user_timeout(timeout);
            let ms = timeout.as_millis().max(1);
            let options = match cfg.get_options() {
                Some(o) => format!("{o} -c lock_timeout={ms}"),
                None => format!("-c lock_timeout={ms}"),
            };
            cfg.options(&options);
            Ok(Connection::Postgres(Box::new(connect_within(
                cfg, timeout,
            )?)))
        }
    }
}

/// `path` as the path of an SQLite `file:` URI: absolute, with `%`, `?`
/// and `#` (and anything not printable ASCII) percent-encoded.
fn uri_path(path: &Path) -> String {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = String::new();
    for b in abs.as_os_str().as_encoded_bytes() {
        match b {
            b'%' | b'?' | b'#' => out.push_str(&format!("%{b:02X}")),
            0x21..=0x7e => out.push(*b as char),
            _ => out.push_str(&format!("%{b:02X}")),
        }
    }
    out
}

/// Connects and logs in within `timeout`. The client's own connect
/// timeout covers only the TCP connection: a server that accepts and then
/// never answers (or answers with bytes that promise a long message) would
/// hold the login for ever, so the login runs on its own thread and is
/// given up after `timeout` (the thread ends with the process).
fn connect_within(
    cfg: postgres::Config,
    timeout: Duration,
) -> Result<postgres::Client, StoreError> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::Builder::new()
        .name("fivecal-store-connect".into())
        .spawn(move || {
            let _ = tx.send(cfg.connect(postgres::NoTls));
        })
        .map_err(|e| StoreError::Sql(format!("cannot start the connection: {e}")))?;
    match rx.recv_timeout(timeout) {
        Ok(r) => Ok(r?),
        Err(_) => Err(StoreError::Sql(format!(
            "no answer from the server within {} s (it accepted the connection but did not log in as PostgreSQL does; --db-timeout SECONDS waits longer)",
            fmt_secs(timeout)
        ))),
    }
}

fn fmt_secs(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s.fract() == 0.0 {
        format!("{s:.0}")
    } else {
        format!("{s}")
    }
}

/// Runs `f` again while SQLite answers busy, until `timeout`.
///
/// Turning a new file to WAL needs its exclusive lock. When two
/// connections holding its shared lock both ask for it, SQLite answers
/// busy at once instead of calling the busy handler (waiting would
/// deadlock), so two runs creating the store at the same moment need the
/// loser to let go and try again.
fn retry_busy<T>(
    timeout: Duration,
    mut f: impl FnMut() -> rusqlite::Result<T>,
) -> rusqlite::Result<T> {
    let deadline = std::time::Instant::now() + timeout;
    let mut pause = Duration::from_millis(2);
    loop {
        match f() {
            Err(rusqlite::Error::SqliteFailure(e, _))
                if e.code == rusqlite::ErrorCode::DatabaseBusy
                    && std::time::Instant::now() < deadline =>
            {
                std::thread::sleep(pause);
                pause = (pause * 2).min(Duration::from_millis(100));
            }
            r => return r,
        }
    }
}

fn insert(c: &mut dyn Conn, r: &Record) -> Result<i64, StoreError> {
    if r.temperature.is_some_and(|t| !t.is_finite()) {
        return Err(StoreError::Invalid(
            "the temperature must be a finite number (deg C)".into(),
        ));
    }
    let rows = c.query(
        "INSERT INTO records (machine, kind, test, measured_at, recorded_at, tool_version, result_name, content, note, temperature, controller, exported, fit)
         VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
        &[
            SqlValue::text(&r.machine),
            SqlValue::text(r.kind.name()),
            SqlValue::opt_text(r.test.as_deref()),
            SqlValue::text(&format_time(r.measured_at)),
            SqlValue::text(&format_time(r.recorded_at)),
            SqlValue::text(&r.tool_version),
            SqlValue::text(&r.result_name),
            SqlValue::text(&r.content),
            SqlValue::opt_text(r.note.as_deref()),
            SqlValue::Real(r.temperature),
            SqlValue::opt_text(r.controller.as_deref()),
            SqlValue::opt_text(r.exported.as_deref()),
            // The column's check (schema version 2) knows fits and misfit;
            // a fit that did not converge is kept as unknown there and
            // read back from the content, which states it.
            SqlValue::opt_text(r.fit.filter(|f| *f != FitVerdict::NotConverged).map(FitVerdict::name)),
        ],
    )?;
    let id = rows
        .first()
        .and_then(|row| row.first())
        .map(|v| v.int())
        .transpose()?
        .flatten()
        .ok_or_else(|| StoreError::Corrupt("the insert returned no id".into()))?;
    for (k, f) in r.files.iter().enumerate() {
        c.exec(
            "INSERT INTO record_files (record_id, position, role, path, sha256) VALUES (?, ?, ?, ?, ?)",
            &[
                SqlValue::Int(Some(id)),
                SqlValue::Int(Some(k as i64)),
                SqlValue::text(f.role.name()),
                SqlValue::text(&f.path),
                SqlValue::text(&f.sha256),
            ],
        )?;
    }
    Ok(id)
}

const COLUMNS: &str = "id, machine, kind, test, measured_at, recorded_at, tool_version, result_name, content, note, temperature, controller, exported, fit";

fn select(
    c: &mut dyn Conn,
    version: i64,
    machine: Option<&str>,
    id: Option<i64>,
) -> Result<Vec<Stored>, StoreError> {
    // An empty file read without creating the schema holds no records; a
    // store of schema 1 has no fit column yet.
    if version == 0 {
        return Ok(Vec::new());
    }
    let columns = if version < 2 {
        COLUMNS.replace(", fit", ", NULL AS fit")
    } else {
        COLUMNS.to_string()
    };
    let (filter, params) = match (machine, id) {
        (_, Some(id)) => ("WHERE id = ?", vec![SqlValue::Int(Some(id))]),
        (Some(m), None) => ("WHERE machine = ?", vec![SqlValue::text(m)]),
        (None, None) => ("", vec![]),
    };
    let rows = c.query(
        &format!("SELECT {columns} FROM records {filter} ORDER BY measured_at, id"),
        &params,
    )?;
    let file_rows = c.query(
        &format!(
            "SELECT record_id, role, path, sha256 FROM record_files WHERE record_id IN (SELECT id FROM records {filter}) ORDER BY record_id, position"
        ),
        &params,
    )?;
    let mut files: std::collections::HashMap<i64, Vec<FileHash>> = Default::default();
    for f in &file_rows {
        let id = f[0].int()?.unwrap_or(-1);
        files.entry(id).or_default().push(FileHash {
            role: f[1]
                .text_req("role")?
                .parse()
                .map_err(StoreError::Corrupt)?,
            path: f[2].text_req("path")?,
            sha256: f[3].text_req("sha256")?,
        });
    }
    rows.iter()
        .map(|r| {
            let id = r[0]
                .int()?
                .ok_or_else(|| StoreError::Corrupt("a record without id".into()))?;
            let time = |v: &SqlValue, col: &str| -> Result<Timestamp, StoreError> {
                parse_time(&v.text_req(col)?).map_err(|e| StoreError::Corrupt(e.to_string()))
            };
            Ok(Stored {
                id,
                record: Record {
                    machine: r[1].text_req("machine")?,
                    kind: r[2]
                        .text_req("kind")?
                        .parse()
                        .map_err(StoreError::Corrupt)?,
                    test: r[3].text_opt()?,
                    measured_at: time(&r[4], "measured_at")?,
                    recorded_at: time(&r[5], "recorded_at")?,
                    tool_version: r[6].text_req("tool_version")?,
                    result_name: r[7].text_req("result_name")?,
                    content: r[8].text_req("content")?,
                    note: r[9].text_opt()?,
                    temperature: r[10].real()?,
                    controller: r[11].text_opt()?,
                    exported: r[12].text_opt()?,
                    fit: match r[13].text_opt()? {
                        Some(s) => Some(s.parse().map_err(StoreError::Corrupt)?),
                        None => FitVerdict::of_result(&r[8].text_req("content")?),
                    },
                    files: files.remove(&id).unwrap_or_default(),
                },
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_a_known_string() {
        // FIPS 180-2 appendix B.1.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn times_are_utc_with_microseconds_and_read_back() {
        let t = parse_time("2026-03-01T09:30:00.25+01:00").unwrap();
        assert_eq!(format_time(t), "2026-03-01T08:30:00.250000Z");
        assert_eq!(parse_time(&format_time(t)).unwrap(), t);
        assert!(
            parse_time("yesterday")
                .unwrap_err()
                .to_string()
                .contains("RFC 3339")
        );
    }

    #[test]
    fn a_url_is_shown_without_its_password() {
        let l = Location::parse("postgres://shop:s3cret@db.local:5432/fivecal");
        assert_eq!(l.to_string(), "postgres://shop:***@db.local:5432/fivecal");
        assert_eq!(
            Location::parse("history.db"),
            Location::Sqlite("history.db".into())
        );
    }

    #[test]
    fn the_fit_verdict_is_read_from_the_result() {
        assert_eq!(
            FitVerdict::of_result("machine: m\nfit: {sigma_um: 2.5, verdict: misfit}\n"),
            Some(FitVerdict::Misfit)
        );
        assert_eq!(FitVerdict::of_result("machine: m\n"), None);
    }
}
