//! Hostile input, round 2: no output lands on a file the run reads (named
//! on the command line or read through another file), a store that is only
//! read is never changed, every input is bounded, a server that never
//! answers ends the run, and legal output names are written. The cases
//! reported are pinned in `regression`, each named after its case.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::cli::fivecal;
use crate::util::tempdir;

fn example(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(rel)
}

fn hash(p: &Path) -> Vec<u8> {
    Sha256::digest(std::fs::read(p).unwrap()).to_vec()
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Runs `fivecal ARGS` (with `env` set) and expects a refusal (exit 2, no
/// panic) naming every one of `expect`; returns the message.
fn refused_with(
    env: &[(&str, &std::ffi::OsStr)],
    args: &[std::ffi::OsString],
    expect: &[&str],
) -> String {
    let mut c = fivecal();
    for (k, v) in env {
        c.env(k, v);
    }
    let out = c.args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: expected `{e}` in: {err}");
    }
    err
}

fn os(v: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<std::ffi::OsString> {
    v.iter().map(|a| a.as_ref().to_os_string()).collect()
}

/// The stepped-square example copied into `dir` (plan, points, machine and
/// template copies, measurement), so a run can be pointed at its files.
fn plan_copy(dir: &Path) -> PathBuf {
    let d = example("analyze/stepped-square");
    for e in std::fs::read_dir(&d).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    dir.join("stepped-square.plan.yaml")
}

fn analyze_onto(dir: &Path, out: &Path, db: &Path) -> Vec<std::ffi::OsString> {
    os(&[
        &"analyze",
        &"--plan",
        &dir.join("stepped-square.plan.yaml"),
        &"--measured",
        &dir.join("piece1.dmo"),
        &"--out",
        &out,
        &"--db",
        &db,
    ])
}

/// A results store with fivecal's schema and no record, made by the
/// library (the way a first recording run leaves it before its insert).
fn empty_store(p: &Path) {
    fivecal::store::Store::open(&fivecal::store::Location::Sqlite(p.to_path_buf())).unwrap();
}

mod regression {
    use super::*;

    /// `analyze --out` onto the plan's own points file, machine copy and
    /// template copy (read through the plan file, not named on the command
    /// line): refused with both names, the file untouched.
    #[test]
    fn analyze_out_onto_a_file_the_plan_reads_is_refused_with_both_names() {
        let dir = tempdir();
        plan_copy(dir.path());
        let db = dir.path().join("h.db");
        for (name, what) in [
            ("stepped-square.points.csv", "points"),
            ("stepped-square.machine.yaml", "machine"),
            ("stepped-square.template.yaml", "template"),
        ] {
            let target = dir.path().join(name);
            let before = hash(&target);
            let err = refused_with(
                &[],
                &analyze_onto(dir.path(), &target, &db),
                &[name, what, "which this run reads"],
            );
            assert_eq!(err.matches(name).count(), 2, "both names: {err}");
            assert_eq!(hash(&target), before, "{name} changed");
        }
    }

    /// `analyze --out` naming the store it records into: through `--db`,
    /// through `$FIVECAL_DB`, through a symbolic link, a hard link and a
    /// `..` path.
    #[test]
    fn analyze_out_onto_the_history_store_is_refused() {
        let dir = tempdir();
        plan_copy(dir.path());
        let db = dir.path().join("h.db");
        empty_store(&db);
        let before = hash(&db);
        refused_with(
            &[],
            &analyze_onto(dir.path(), &db, &db),
            &["h.db", "results store"],
        );
        let link = dir.path().join("link.yaml");
        std::os::unix::fs::symlink(&db, &link).unwrap();
        refused_with(
            &[],
            &analyze_onto(dir.path(), &link, &db),
            &["link.yaml", "h.db", "results store"],
        );
        let hard = dir.path().join("hard.yaml");
        std::fs::hard_link(&db, &hard).unwrap();
        refused_with(
            &[],
            &analyze_onto(dir.path(), &hard, &db),
            &["hard.yaml", "results store"],
        );
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let dotdot = dir.path().join("sub/../h.db");
        refused_with(
            &[],
            &analyze_onto(dir.path(), &dotdot, &db),
            &["results store"],
        );
        // Through the environment: no --db.
        let mut a = analyze_onto(dir.path(), &db, &db);
        a.truncate(a.len() - 2);
        refused_with(
            &[("FIVECAL_DB", db.as_os_str())],
            &a,
            &["h.db", "results store"],
        );
        assert_eq!(hash(&db), before);
        // A store that does not exist yet is refused the same way.
        let new = dir.path().join("new.db");
        refused_with(
            &[],
            &analyze_onto(dir.path(), &new, &new),
            &["new.db", "results store"],
        );
        assert!(!new.exists());
    }

    #[test]
    fn discover_out_onto_the_history_store_is_refused() {
        let dir = tempdir();
        let db = dir.path().join("h.db");
        empty_store(&db);
        let before = hash(&db);
        let d = example("discover");
        refused_with(
            &[],
            &os(&[
                &"discover",
                &"--plan",
                &d.join("stepped-square.plan.yaml"),
                &"--measured",
                &d.join("piece.dmo"),
                &"--out",
                &db,
                &"--db",
                &db,
            ]),
            &["h.db", "results store"],
        );
        assert_eq!(hash(&db), before);
    }

    #[test]
    fn verify_out_onto_the_history_store_is_refused() {
        let dir = tempdir();
        let db = dir.path().join("h.db");
        empty_store(&db);
        let before = hash(&db);
        refused_with(
            &[],
            &os(&[
                &"verify",
                &"--machine",
                &"bc-trunnion",
                &"--db",
                &db,
                &"--out",
                &db,
            ]),
            &["h.db", "results store"],
        );
        assert_eq!(hash(&db), before);
    }

    #[test]
    fn history_export_out_onto_the_history_store_is_refused() {
        let dir = tempdir();
        let db = dir.path().join("h.db");
        empty_store(&db);
        let before = hash(&db);
        refused_with(
            &[],
            &os(&[&"history", &"--db", &db, &"export", &"--out", &db]),
            &["h.db", "results store"],
        );
        assert_eq!(hash(&db), before);
    }

    /// `compensate --export` records into the store: neither the rewritten
    /// program (`-o`) nor the parameter file may be it.
    #[test]
    fn compensate_export_output_onto_the_history_store_is_refused() {
        let dir = tempdir();
        let db = dir.path().join("h.db");
        empty_store(&db);
        let before = hash(&db);
        let d = example("analyze/stepped-square");
        let base = os(&[
            &"compensate",
            &"--machine",
            &"bc-trunnion",
            &"--errors",
            &d.join("truth.yaml"),
            &"--export",
            &"fanuc",
            &"--db",
            &db,
        ]);
        let mut a = base.clone();
        a.extend(os(&[&d.join("stepped-square.nc"), &"-o", &db]));
        refused_with(&[], &a, &["h.db", "results store"]);
        let mut a = base;
        a.extend(os(&[&"--export-to", &db]));
        refused_with(&[], &a, &["h.db", "results store"]);
        assert_eq!(hash(&db), before);
    }

    /// `verify --machine NAME --db EMPTY.db` only reads the store: an empty
    /// file and a store without records stay byte for byte as they were,
    /// and nothing appears beside them.
    #[test]
    fn verify_on_an_empty_store_leaves_it_unchanged() {
        let dir = tempdir();
        let zero = dir.path().join("EMPTY.db");
        std::fs::write(&zero, b"").unwrap();
        let fresh = dir.path().join("fresh.db");
        empty_store(&fresh);
        let names = listing(dir.path());
        for db in [&zero, &fresh] {
            let before = hash(db);
            let err = refused_with(
                &[],
                &os(&[&"verify", &"--machine", &"bc-trunnion", &"--db", db]),
                &["bc-trunnion"],
            );
            assert!(!err.contains("readonly"), "{err}");
            assert_eq!(hash(db), before, "{} changed", db.display());
            assert_eq!(listing(dir.path()), names);
        }
        // history list reads it as empty.
        let out = fivecal()
            .args(["history", "--db"])
            .arg(&zero)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(String::from_utf8_lossy(&out.stdout).contains("no records"));
        assert_eq!(std::fs::read(&zero).unwrap(), b"");
    }
}

/// Runs `cmd` and waits at most `limit`; a run still going then is killed
/// and the test fails (a hang is the bug).
fn within(mut cmd: std::process::Command, limit: std::time::Duration) -> std::process::Output {
    use std::process::Stdio;
    let start = std::time::Instant::now();
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "still running after {limit:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

fn bin() -> std::process::Command {
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_fivecal"));
    c.env("FIVECAL_DB", crate::cli::test_store());
    c
}

fn mkfifo(p: &Path) {
    let ok = std::process::Command::new("mkfifo")
        .arg(p)
        .status()
        .unwrap()
        .success();
    assert!(ok, "mkfifo {}", p.display());
}

/// A TCP listener on 127.0.0.1 that accepts every connection and then
/// either says nothing or sends `garbage`, holding the connection open.
fn silent_server(garbage: Option<&'static [u8]>) -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = l.local_addr().unwrap().port();
    std::thread::spawn(move || {
        let mut held = Vec::new();
        for s in l.incoming() {
            let Ok(mut s) = s else { continue };
            if let Some(g) = garbage {
                use std::io::Write as _;
                let _ = s.write_all(g);
            }
            held.push(s);
        }
    });
    port
}

/// A server that never answers, and one that answers bytes that are not
/// PostgreSQL's: every command that reads or records ends within the
/// timeout with a message naming the server.
#[test]
fn a_store_server_that_never_answers_or_answers_garbage_ends_the_run_in_bounded_time() {
    let dir = tempdir();
    plan_copy(dir.path());
    let quiet = silent_server(None);
    // A length field of 0x7fffffff: a client that believes it waits for
    // two gigabytes.
    let noisy = silent_server(Some(b"R\x7f\xff\xff\xffgarbage that is not PostgreSQL"));
    for port in [quiet, noisy] {
        let url = format!("postgres://u@127.0.0.1:{port}/x");
        let mut c = bin();
        c.args(["history", "list", "--db", &url, "--db-timeout", "1"]);
        let out = within(c, std::time::Duration::from_secs(30));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(&format!("127.0.0.1:{port}")), "{err}");
        // analyze through the environment: refused before any work.
        let out_file = dir.path().join("r.yaml");
        let mut c = bin();
        c.env("FIVECAL_DB", &url)
            .args(analyze_onto(dir.path(), &out_file, Path::new("x"))[..7].iter())
            .args(["--db-timeout", "1"]);
        let out = within(c, std::time::Duration::from_secs(60));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("127.0.0.1"), "{err}");
        assert!(!out_file.exists());
    }
}

/// FIFOs and devices as inputs: refused at once by their file type, never
/// opened (a FIFO without a writer would block the open for ever).
#[test]
fn fifos_and_devices_as_inputs_are_refused_without_waiting() {
    let dir = tempdir();
    let plan = plan_copy(dir.path());
    let fifo = dir.path().join("fifo.yaml");
    mkfifo(&fifo);
    let limit = std::time::Duration::from_secs(30);
    let check = |args: Vec<std::ffi::OsString>, expect: &str| {
        let mut c = bin();
        c.args(&args);
        let out = within(c, limit);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(expect),
            "{args:?}: expected `{expect}` in {err}"
        );
    };
    // The machine file.
    check(os(&[&"machine", &"show", &fifo]), "FIFO");
    // The plan's machine copy, read through the plan.
    let machine_copy = dir.path().join("stepped-square.machine.yaml");
    std::fs::remove_file(&machine_copy).unwrap();
    mkfifo(&machine_copy);
    let out_file = dir.path().join("r.yaml");
    check(
        os(&[
            &"analyze",
            &"--plan",
            &plan,
            &"--measured",
            &dir.path().join("piece1.dmo"),
            &"--out",
            &out_file,
            &"--no-record",
        ]),
        "FIFO",
    );
    // A glTF buffer.
    let buffer = dir.path().join("buffer.bin");
    mkfifo(&buffer);
    let gltf = dir.path().join("part.gltf");
    std::fs::write(
        &gltf,
        r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"buffer.bin","byteLength":36}],"scenes":[{"nodes":[]}],"scene":0}"#,
    )
    .unwrap();
    check(
        os(&[
            &"analyze",
            &"contour",
            &"--model",
            &gltf,
            &"--measured",
            &fifo,
        ]),
        "FIFO",
    );
    // Limits from a device that never ends.
    for dev in ["/dev/zero", "/dev/urandom"] {
        check(
            os(&[
                &"analyze",
                &"--plan",
                &example("analyze/stepped-square/stepped-square.plan.yaml"),
                &"--measured",
                &example("analyze/stepped-square/piece1.dmo"),
                &"--out",
                &out_file,
                &"--no-record",
                &"--limits",
                &dev,
            ]),
            "device",
        );
    }
    assert!(!out_file.exists());
}

/// A glTF whose node is its own child, two nodes that are each other's
/// child, and a tree of shared nodes 40 levels deep (2^40 placements):
/// each refused at once, in bounded memory.
#[test]
fn gltf_node_loops_and_exponential_sharing_are_refused() {
    let dir = tempdir();
    let csv = dir.path().join("p.csv");
    std::fs::write(&csv, "label,x,y,z\np1,0,0,0\n").unwrap();
    let run = |nodes: &str, expect: &str| {
        let gltf = dir.path().join("part.gltf");
        std::fs::write(
            &gltf,
            format!(
                r#"{{"asset":{{"version":"2.0"}},"nodes":{nodes},"scenes":[{{"nodes":[0]}}],"scene":0}}"#
            ),
        )
        .unwrap();
        let mut c = bin();
        c.args(["analyze", "contour", "--model"])
            .arg(&gltf)
            .arg("--measured")
            .arg(&csv);
        let out = within(c, std::time::Duration::from_secs(30));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(expect), "expected `{expect}` in {err}");
    };
    run(r#"[{"children":[0]}]"#, "its own child");
    run(r#"[{"children":[1]},{"children":[0]}]"#, "must not loop");
    // Two nodes per level, each with both nodes of the next level as
    // children.
    let mut nodes = Vec::new();
    for level in 0..40 {
        let kids = if level < 39 {
            format!("[{},{}]", 2 * level + 2, 2 * level + 3)
        } else {
            "[]".into()
        };
        nodes.push(format!(r#"{{"children":{kids}}}"#));
        nodes.push(format!(r#"{{"children":{kids}}}"#));
    }
    run(&format!("[{}]", nodes.join(",")), "more than 100000 nodes");
}

/// Output names of 230 to 255 characters are legal: their temporary names
/// fit too.
#[test]
fn output_names_up_to_255_characters_are_written() {
    let dir = tempdir();
    let d = example("analyze/stepped-square");
    for len in [230, 255] {
        let name = format!("{}.nc", "p".repeat(len - 3));
        let out_path = dir.path().join(&name);
        let mut c = bin();
        c.args(["compensate", "--machine", "bc-trunnion", "--errors"])
            .arg(d.join("truth.yaml"))
            .arg(d.join("stepped-square.nc"))
            .arg("-o")
            .arg(&out_path);
        let out = within(c, std::time::Duration::from_secs(120));
        assert!(
            out.status.success(),
            "{len}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(out_path.is_file());
        let name = format!("{}.yaml", "r".repeat(len - 5));
        let out_path = dir.path().join(&name);
        let mut args = analyze_onto(&d, &out_path, Path::new("x"));
        args.truncate(7);
        let mut c = bin();
        c.args(&args).arg("--no-record");
        let out = within(c, std::time::Duration::from_secs(120));
        assert!(
            out.status.success(),
            "{len}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(out_path.is_file());
    }
    assert!(
        listing(dir.path())
            .iter()
            .all(|n| !n.contains("fivecal-tmp")),
        "{:?}",
        listing(dir.path())
    );
}

/// A temporary file that a killed run left beside its output is removed
/// by the next run writing there, which names it; one of a run still
/// going is left alone.
#[test]
fn stale_temporaries_of_a_killed_run_are_removed_and_named_by_the_next_run() {
    let dir = tempdir();
    let d = example("analyze/stepped-square");
    // A pid that no longer runs: a process that has ended.
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    let dead = gone.id();
    gone.wait().unwrap();
    let stale = dir.path().join(format!(".out.nc.{dead:x}-1f.fivecal-tmp"));
    std::fs::write(&stale, "half a program").unwrap();
    let live = dir
        .path()
        .join(format!(".out.nc.{:x}-1f.fivecal-tmp", std::process::id()));
    std::fs::write(&live, "being written").unwrap();
    let mut c = bin();
    c.args(["compensate", "--machine", "bc-trunnion", "--errors"])
        .arg(d.join("truth.yaml"))
        .arg(d.join("stepped-square.nc"))
        .arg("-o")
        .arg(dir.path().join("out.nc"));
    let out = within(c, std::time::Duration::from_secs(120));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!stale.exists());
    assert!(
        err.contains(&stale.file_name().unwrap().to_string_lossy().to_string()),
        "{err}"
    );
    assert!(live.exists(), "a running process's temporary file stays");
}
