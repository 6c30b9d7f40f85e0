//! The results store on both back ends: an SQLite file and a real
//! PostgreSQL server (the one `.ci/postgres` starts; `FIVECAL_TEST_PG`
//! names it). Every test runs the same steps on each: record, list, show,
//! concurrent writers, a writer killed mid-transaction, a migration from
//! an older schema.
//!
//! Without `FIVECAL_TEST_PG` the PostgreSQL half fails on CI (`CI` set) and
//! is skipped with a note on a developer's machine.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};

use fivecal::store::{
    self, FileHash, FileRole, FitVerdict, Location, Record, RecordKind, Store, StoreError,
};

/// A result as `analyze` writes it.
const RESULT: &str = "machine: bc-trunnion
location_errors:
  EX0B: {value: 12.1, u: 0.4}
  EZ0B: {value: -24.6, u: 0.5}
";

/// A record measured at `at` (RFC 3339) with every field set.
pub fn record(machine: &str, at: &str, note: &str) -> Record {
    let t = store::parse_time(at).unwrap();
    let mut r = Record::new(
        RecordKind::Analyze,
        machine,
        "result.yaml",
        RESULT.to_string(),
    );
    r.test = Some("stepped-square".into());
    r.measured_at = t;
    r.recorded_at = t;
    r.note = Some(note.into());
    r.temperature = Some(20.5);
    r.files = vec![
        FileHash {
            role: FileRole::Measured,
            path: "piece.dmo".into(),
            sha256: store::sha256_hex(note.as_bytes()),
        },
        FileHash {
            role: FileRole::Plan,
            path: "ss/stepped-square.plan.yaml".into(),
            sha256: store::sha256_hex(b"plan"),
        },
    ];
    r
}

/// A fresh, empty store on one back end, removed when dropped.
pub struct TestStore {
    pub location: Location,
    _dir: Option<tempfile::TempDir>,
    pg_schema: Option<(String, String)>,
}

impl Drop for TestStore {
    fn drop(&mut self) {
        if let Some((url, schema)) = &self.pg_schema
            && let Ok(mut c) = postgres::Client::connect(url, postgres::NoTls)
        {
            let _ = c.batch_execute(&format!("DROP SCHEMA {schema} CASCADE"));
        }
    }
}

/// The PostgreSQL server of the tests, or `None` (with a note) on a
/// developer's machine without one; on CI its absence fails the test.
pub fn pg_url() -> Option<String> {
    match std::env::var("FIVECAL_TEST_PG") {
        Ok(u) if !u.is_empty() => Some(u),
        _ if std::env::var_os("CI").is_some() => panic!(
            "FIVECAL_TEST_PG is not set: on CI the PostgreSQL store tests must run (.ci/run starts a server with .ci/postgres)"
        ),
        _ => {
            eprintln!(
                "note: PostgreSQL store tests skipped: FIVECAL_TEST_PG is not set (eval \"$(.ci/postgres)\" starts a server)"
            );
            None
        }
    }
}

pub fn sqlite_store() -> TestStore {
    let dir = tempfile::tempdir().unwrap();
    TestStore {
        location: Location::Sqlite(dir.path().join("history.db")),
        _dir: Some(dir),
        pg_schema: None,
    }
}

/// A store in a schema of its own on the test server.
pub fn pg_store(url: &str) -> TestStore {
    static N: AtomicUsize = AtomicUsize::new(0);
    let schema = format!(
        "fivecal_t{}_{}_{}",
        std::process::id(),
        N.fetch_add(1, Ordering::SeqCst),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .subsec_nanos()
    );
    let mut c = postgres::Client::connect(url, postgres::NoTls).unwrap();
    c.batch_execute(&format!("CREATE SCHEMA {schema}")).unwrap();
    let sep = if url.contains('?') { '&' } else { '?' };
    TestStore {
        location: Location::Postgres(format!("{url}{sep}options=-csearch_path%3D{schema}")),
        _dir: None,
        pg_schema: Some((url.to_string(), schema)),
    }
}

/// Runs `check` on a fresh SQLite store and on a fresh PostgreSQL one.
fn on_both(check: impl Fn(&TestStore)) {
    check(&sqlite_store());
    if let Some(url) = pg_url() {
        check(&pg_store(&url));
    }
}

#[test]
fn records_are_listed_by_machine_in_measurement_order_and_shown_as_written() {
    on_both(|s| {
        let mut st = Store::open(&s.location).unwrap();
        assert_eq!(st.schema_version().unwrap(), store::CURRENT_VERSION);
        let late = record("bc-trunnion", "2026-03-10T08:00:00Z", "after the crash");
        let early = record("bc-trunnion", "2026-03-01T08:00:00.123456Z", "weekly");
        let mut other = record("ac-trunnion", "2026-03-05T08:00:00Z", "other machine");
        other.kind = RecordKind::Export;
        other.test = None;
        other.controller = Some("fanuc".into());
        other.exported = Some("N19700 P1 ...\n".into());
        other.fit = Some(FitVerdict::Fits);
        other.temperature = None;
        let id_late = st.record(&late).unwrap();
        let id_early = st.record(&early).unwrap();
        let id_other = st.record(&other).unwrap();
        assert!(id_late < id_early && id_early < id_other);

        let list = st.list(Some("bc-trunnion")).unwrap();
        let ids: Vec<i64> = list.iter().map(|r| r.id).collect();
        assert_eq!(ids, [id_early, id_late], "{}", s.location);
        assert_eq!(list[0].record, early);
        assert_eq!(list[1].record, late);
        assert_eq!(st.list(None).unwrap().len(), 3);
        assert_eq!(st.get(id_other).unwrap().unwrap().record, other);
        assert!(st.get(id_other + 100).unwrap().is_none());
        assert_eq!(
            st.machines().unwrap(),
            [
                ("ac-trunnion".to_string(), 1),
                ("bc-trunnion".to_string(), 2)
            ]
        );
        // A second connection sees the same.
        let mut again = Store::open(&s.location).unwrap();
        assert_eq!(again.list(None).unwrap(), st.list(None).unwrap());
    });
}

/// Four writers, each with its own connection, record ten results each at
/// the same time: all forty land, each once.
#[test]
fn concurrent_writers_all_land() {
    on_both(|s| {
        Store::open(&s.location).unwrap();
        std::thread::scope(|scope| {
            for w in 0..4 {
                let loc = s.location.clone();
                scope.spawn(move || {
                    let mut st = Store::open(&loc).unwrap();
                    for k in 0..10 {
                        st.record(&record(
                            "bc-trunnion",
                            "2026-03-01T08:00:00Z",
                            &format!("writer {w} result {k}"),
                        ))
                        .unwrap();
                    }
                });
            }
        });
        let all = Store::open(&s.location).unwrap().list(None).unwrap();
        assert_eq!(all.len(), 40, "{}", s.location);
        let mut notes: Vec<String> = all.iter().map(|r| r.record.note.clone().unwrap()).collect();
        notes.sort();
        notes.dedup();
        assert_eq!(notes.len(), 40);
        assert!(all.iter().all(|r| r.record.files.len() == 2));
    });
}

/// Two processes opening a new store and recording at once: the schema is
/// created once and both processes' records land.
#[test]
fn two_processes_writing_at_once_both_land() {
    on_both(|s| {
        let children: Vec<_> = (0..2)
            .map(|k| child(&s.location, &format!("write:15:p{k}")))
            .collect();
        for mut c in children {
            let status = c.wait().unwrap();
            assert!(status.success(), "child failed on {}", s.location);
        }
        let all = Store::open(&s.location).unwrap().list(None).unwrap();
        assert_eq!(all.len(), 30, "{}", s.location);
        for p in ["p0", "p1"] {
            assert_eq!(
                all.iter()
                    .filter(|r| r.record.note.as_deref().unwrap().starts_with(p))
                    .count(),
                15
            );
        }
    });
}

/// A writer records one result, starts a second, and is killed before it
/// commits: the first is intact, the second absent, and the store takes
/// the next record as usual.
#[test]
fn a_writer_killed_mid_transaction_loses_nothing_recorded_before() {
    on_both(|s| {
        let mut c = child(&s.location, "hang");
        let mut out = BufReader::new(c.stdout.take().unwrap());
        let mut line = String::new();
        loop {
            line.clear();
            assert!(
                out.read_line(&mut line).unwrap() > 0,
                "the child ended before it was mid-transaction"
            );
            if line.trim_end().ends_with("mid-transaction") {
                break;
            }
        }
        c.kill().unwrap();
        c.wait().unwrap();
        let mut st = Store::open(&s.location).unwrap();
        let all = st.list(None).unwrap();
        assert_eq!(all.len(), 1, "{}", s.location);
        assert_eq!(
            all[0].record,
            record("bc-trunnion", "2026-03-01T08:00:00Z", "committed")
        );
        st.record(&record("bc-trunnion", "2026-03-02T08:00:00Z", "next"))
            .unwrap();
        let notes: Vec<_> = st
            .list(None)
            .unwrap()
            .into_iter()
            .map(|r| r.record.note.unwrap())
            .collect();
        assert_eq!(notes, ["committed", "next"]);
    });
}

fn child(location: &Location, mode: &str) -> std::process::Child {
    let loc = match location {
        Location::Sqlite(p) => p.display().to_string(),
        Location::Postgres(u) => u.clone(),
    };
    Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "store::store_child_process",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("FIVECAL_STORE_CHILD", mode)
        .env("FIVECAL_STORE_CHILD_DB", loc)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap()
}

/// The child half of the process tests (does nothing unless a test
/// started this binary with `FIVECAL_STORE_CHILD`): `write:N:TAG` records
/// N results noted `TAG k`; `hang` records one, starts a second in a
/// transaction, says so and waits to be killed.
#[test]
fn store_child_process() {
    let Ok(mode) = std::env::var("FIVECAL_STORE_CHILD") else {
        return;
    };
    let loc = Location::parse(&std::env::var("FIVECAL_STORE_CHILD_DB").unwrap());
    let mut st = Store::open(&loc).unwrap();
    if let Some(rest) = mode.strip_prefix("write:") {
        let (n, tag) = rest.split_once(':').unwrap();
        for k in 0..n.parse::<usize>().unwrap() {
            st.record(&record(
                "bc-trunnion",
                "2026-03-01T08:00:00Z",
                &format!("{tag} {k}"),
            ))
            .unwrap();
        }
        return;
    }
    assert_eq!(mode, "hang");
    st.record(&record("bc-trunnion", "2026-03-01T08:00:00Z", "committed"))
        .unwrap();
    let mut b = st.batch().unwrap();
    b.insert(&record(
        "bc-trunnion",
        "2026-03-02T08:00:00Z",
        "never committed",
    ))
    .unwrap();
    println!("mid-transaction");
    std::thread::sleep(std::time::Duration::from_secs(120));
    panic!("the parent should have killed this process");
}

/// A store an older fivecal wrote (schema 1: no fit verdict yet) opens
/// with its records intact, is migrated to the current schema, and takes
/// records with a verdict; a store from a newer fivecal is refused.
#[test]
fn an_older_store_is_migrated_and_a_newer_one_refused() {
    on_both(|s| {
        let mut old = Store::open_at_version(&s.location, 1).unwrap();
        assert_eq!(old.schema_version().unwrap(), 1);
        drop(old);
        // What fivecal wrote at schema 1, by hand.
        let insert = "INSERT INTO records (machine, kind, test, measured_at, recorded_at, tool_version, result_name, content, note, temperature, controller, exported) VALUES ('bc-trunnion', 'analyze', 'stepped-square', '2025-11-03T07:00:00.000000Z', '2025-11-03T07:05:00.000000Z', '0.0.9', 'r.yaml', 'machine: bc-trunnion', 'cold', 19.0, NULL, NULL)";
        let file = "INSERT INTO record_files (record_id, position, role, path, sha256) VALUES (1, 0, 'measured', 'p.dmo', 'ab')";
        match &s.location {
            Location::Sqlite(p) => {
                let c = rusqlite::Connection::open(p).unwrap();
                c.execute_batch(&format!("{insert}; {file};")).unwrap();
            }
            Location::Postgres(u) => {
                let mut c = postgres::Client::connect(u, postgres::NoTls).unwrap();
                c.batch_execute(&format!("{insert}; {file};")).unwrap();
            }
        }
        let mut st = Store::open(&s.location).unwrap();
        assert_eq!(st.schema_version().unwrap(), store::CURRENT_VERSION);
        let old = &st.list(None).unwrap()[0];
        assert_eq!(old.record.note.as_deref(), Some("cold"));
        assert_eq!(old.record.tool_version, "0.0.9");
        assert_eq!(old.record.fit, None);
        assert_eq!(old.record.files[0].path, "p.dmo");
        let mut r = record("bc-trunnion", "2026-01-01T00:00:00Z", "with a verdict");
        r.fit = Some(FitVerdict::Misfit);
        let id = st.record(&r).unwrap();
        assert_eq!(
            st.get(id).unwrap().unwrap().record.fit,
            Some(FitVerdict::Misfit)
        );
        drop(st);

        let newer = "INSERT INTO fivecal_schema (version, description, applied_at, tool_version) VALUES (99, 'future', '2030-01-01T00:00:00.000000Z', '9.0.0')";
        match &s.location {
            Location::Sqlite(p) => rusqlite::Connection::open(p)
                .unwrap()
                .execute_batch(newer)
                .unwrap(),
            Location::Postgres(u) => postgres::Client::connect(u, postgres::NoTls)
                .unwrap()
                .batch_execute(newer)
                .unwrap(),
        }
        let e = Store::open(&s.location)
            .err()
            .expect("a newer store is refused");
        assert!(matches!(e, StoreError::Database { .. }), "{e:?}");
        let msg = e.to_string();
        assert!(
            msg.contains("schema version 99") && msg.contains("newer fivecal"),
            "{msg}"
        );
    });
}

#[test]
fn a_file_that_is_not_a_store_is_refused_with_its_path() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("notes.db");
    std::fs::write(&p, "these are my notes, not a database\n".repeat(200)).unwrap();
    let e = Store::open(&Location::Sqlite(p.clone()))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains(&p.display().to_string()) && e.contains("not a database"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(&p).unwrap(),
        "these are my notes, not a database\n".repeat(200)
    );
}

#[test]
fn an_unreachable_server_is_named_in_the_error() {
    // Nothing listens on port 1 of the loopback interface.
    let loc = Location::parse("postgres://fivecal:pw@127.0.0.1:1/none?connect_timeout=5");
    let e = Store::open(&loc).err().unwrap().to_string();
    assert!(
        e.contains("postgres://fivecal:***@127.0.0.1:1/none") && !e.contains(":pw@"),
        "{e}"
    );
}
