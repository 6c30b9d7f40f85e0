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

/// An empty results store `h.db` in `dir` and its hash: each case ends by
/// checking that the store is byte for byte as it was.
fn store_in(dir: &Path) -> (PathBuf, Vec<u8>) {
    let db = dir.join("h.db");
    empty_store(&db);
    let before = hash(&db);
    (db, before)
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
                &[name, what, "this run reads"],
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
        let (db, before) = store_in(dir.path());
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
        let (db, before) = store_in(dir.path());
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
        let (db, before) = store_in(dir.path());
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
        let (db, before) = store_in(dir.path());
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
        let (db, before) = store_in(dir.path());
        let d = example("analyze/stepped-square");
        let base = os(&[
            &"compensate",
            &"--machine",
            &"bc-trunnion",
            &"--errors",
            &d.join("truth.yaml"),
            &"--export",
            &"fanuc",
            // Only an export entered at the control is recorded, so only
            // then does the store come into play.
            &"--entered",
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

/// The address space every hostile run is held to. A normal run of any
/// command needs well under a tenth of it; the inputs of issue 47 (a glTF
/// node tree that loops or shares nodes exponentially, limits read from
/// `/dev/zero`) asked for 6 GB or more. Past the bound an allocation fails,
/// the run aborts, and the test fails on its exit status.
const MEMORY_BOUND_BYTES: u64 = 2 << 30;

/// Runs `cmd` in bounded memory (`MEMORY_BOUND_BYTES` of address space, set
/// in the child before it runs) and waits at most `limit`; a run still
/// going then is killed and the test fails (a hang is the bug).
fn within(mut cmd: std::process::Command, limit: std::time::Duration) -> std::process::Output {
    use std::os::unix::process::CommandExt;
    use std::process::Stdio;
    // glibc reserves 64 MB of address space per malloc arena, up to eight
    // per core: on a many-core runner that alone would fill the bound.
    cmd.env("MALLOC_ARENA_MAX", "2");
    // SAFETY: the closure runs in the forked child before exec and only
    // calls setrlimit, which is async-signal-safe.
    unsafe {
        cmd.pre_exec(|| {
            let bound = libc::rlimit {
                rlim_cur: MEMORY_BOUND_BYTES as libc::rlim_t,
                rlim_max: MEMORY_BOUND_BYTES as libc::rlim_t,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &bound) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
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

/// The bound is in force in every run `within` starts: the shell's own
/// `ulimit -v` (KiB) reads it back.
#[test]
fn hostile_runs_are_held_to_the_memory_bound() {
    let mut sh = std::process::Command::new("sh");
    sh.args(["-c", "ulimit -v"]);
    let out = within(sh, std::time::Duration::from_secs(10));
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        (MEMORY_BOUND_BYTES / 1024).to_string()
    );
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

/// The tool-tip samples `simulate nc` writes: (nominal tip, actual tip),
/// mm, in W.
fn tip_samples(csv: &Path) -> Vec<([f64; 3], [f64; 3])> {
    std::fs::read_to_string(csv)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("line"))
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            let n = [f[2], f[3], f[4]];
            (
                n,
                [n[0] + f[8] * 1e-3, n[1] + f[9] * 1e-3, n[2] + f[10] * 1e-3],
            )
        })
        .collect()
}

fn segment_distance(x: &[f64; 3], a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let l = ab.iter().map(|v| v * v).sum::<f64>();
    let t = if l == 0.0 {
        0.0
    } else {
        ((0..3).map(|k| (x[k] - a[k]) * ab[k]).sum::<f64>() / l).clamp(0.0, 1.0)
    };
    (0..3)
        .map(|k| (a[k] + t * ab[k] - x[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Largest distance, um, of the actual tip path of `compensated` (run on
/// the machine with the errors) from the intended path of `original` (run
/// on the nominal machine), both sampled by `simulate nc`, the simulator's
/// exact model, which the compensator's own path check does not use.
fn path_deviation_um(dir: &Path, original: &Path, compensated: &Path) -> f64 {
    let errors = example("analyze/stepped-square/truth.yaml");
    let sample = |program: &Path, name: &str| {
        let csv = dir.join(name);
        let out = bin()
            .args(["simulate", "nc", "--machine", "bc-trunnion", "--errors"])
            .arg(&errors)
            .arg("--program")
            .arg(program)
            .args(["--step", "0.02", "-o"])
            .arg(&csv)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        tip_samples(&csv)
    };
    let intended: Vec<[f64; 3]> = sample(original, "intended.csv")
        .into_iter()
        .map(|s| s.0)
        .collect();
    let actual = sample(compensated, "actual.csv");
    actual
        .iter()
        .map(|(_, x)| {
            intended
                .windows(2)
                .map(|w| segment_distance(x, &w[0], &w[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        * 1e3
}

mod tolerance_regression {
    use super::*;

    /// B45 to B-45 while C turns 0 to 90 deg, and B30 to B40 while C turns
    /// 0 to 90 deg (no crossing of B0).
    const MOVES: &str = "O1000\nG90 G54 G94\nG0 X10. Y20. Z30. B45. C0.\nG1 X10. Y20. Z30. B-45. C90. F1000.\nG0 B30. C0.\nG1 B40. C90. F1000.\nM30\n";

    /// B30 to B40 while C turns 0 to 90 deg alone (the move through B0
    /// takes a minute to compensate at these tolerances in a debug build).
    const NO_CROSSING: &str =
        "O1000\nG90 G54 G94\nG0 X10. Y20. Z30. B30. C0.\nG1 B40. C90. F1000.\nM30\n";

    fn compensate(dir: &Path, program: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
        let _ = dir;
        bin()
            .args(["compensate", "--machine", "bc-trunnion", "--errors"])
            .arg(example("analyze/stepped-square/truth.yaml"))
            .arg(program)
            .arg("-o")
            .arg(out)
            .args(extra)
            .output()
            .unwrap()
    }

    /// `--tolerance 0.01` (and 0.05) with the default 4 decimals in mm:
    /// the rounding of the words alone moves the tip by more (0.113 um), so
    /// the run is refused with the smallest tolerance that holds (twice
    /// that: as much for the path between the written points), and nothing
    /// is written.
    #[test]
    fn a_tolerance_finer_than_the_written_decimals_is_refused_with_the_smallest_that_holds() {
        let dir = tempdir();
        let program = dir.path().join("cross.nc");
        std::fs::write(&program, MOVES).unwrap();
        let out = dir.path().join("out.nc");
        for t in ["0.01", "0.05"] {
            let o = compensate(dir.path(), &program, &out, &["--tolerance", t]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{err}");
            assert!(
                err.contains("smallest tolerance that holds is 0.230 um"),
                "{err}"
            );
            assert!(!out.exists());
        }
        // The smallest printed is accepted.
        std::fs::write(&program, NO_CROSSING).unwrap();
        let o = compensate(dir.path(), &program, &out, &["--tolerance", "0.23"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }

    /// The check itself at 0.01 um: with 6 decimals in mm and 8 in degrees
    /// (rounding 0.001 um), the move is written corrected and the actual
    /// tip path, simulated independently, stays within 0.01 um of the
    /// intended one (the 0.0005 um chord error of the 0.02 mm sampling
    /// included).
    #[test]
    fn a_move_reported_within_0_01_um_is_within_0_01_um() {
        let dir = tempdir();
        let program = dir.path().join("b30.nc");
        std::fs::write(&program, NO_CROSSING).unwrap();
        let out = dir.path().join("out.nc");
        let o = compensate(
            dir.path(),
            &program,
            &out,
            &["--tolerance", "0.01", "--decimals", "6,8"],
        );
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(text.contains("no move left as written"), "{text}");
        let d = path_deviation_um(dir.path(), &program, &out);
        assert!(d <= 0.01, "the tip leaves the intended path by {d} um");
        // The same program not compensated misses by tens of um: the
        // measure sees a wrong path.
        let d0 = path_deviation_um(dir.path(), &program, &program);
        assert!(d0 > 10.0, "{d0}");
    }
}

mod non_finite_regression {
    use super::*;

    fn fails(args: &[std::ffi::OsString], expect: &[&str]) -> String {
        let out = bin().args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        for e in expect {
            assert!(err.contains(e), "expected `{e}` in {err}");
        }
        err
    }

    /// `--expand` of a SINUMERIK program whose R parameter computes to
    /// infinity: refused at the line that writes it, nothing written (no
    /// `G1 X=inf`).
    #[test]
    fn expand_with_r1_exp_1000_writes_no_inf() {
        let dir = tempdir();
        let p = dir.path().join("inf.mpf");
        std::fs::write(
            &p,
            "%_N_INF_MPF\nG90 G54\nR1=EXP(1000)\nG0 X0 Y0 Z50 B0 C0\nG1 X=R1 F1000\nM30\n",
        )
        .unwrap();
        let out = dir.path().join("out.mpf");
        let err = fails(
            &os(&[
                &"compensate",
                &"--machine",
                &"bc-trunnion",
                &"--errors",
                &example("analyze/stepped-square/truth.yaml"),
                &"--expand",
                &p,
                &"-o",
                &out,
            ]),
            &["inf.mpf:"],
        );
        assert!(!err.contains("X=inf"), "{err}");
        assert!(!out.exists());
    }

    /// `analyze contour` with a measured point at 1e308 mm: refused at its
    /// line instead of statistics of infinity.
    #[test]
    fn contour_with_a_1e308_point_is_refused_at_its_line() {
        let dir = tempdir();
        let csv = dir.path().join("m.csv");
        std::fs::write(&csv, "label,x,y,z\np1,0,0,0\np2,1e308,0,0\n").unwrap();
        let err = fails(
            &os(&[
                &"analyze",
                &"contour",
                &"--model",
                &example("analyze/stepped-square/stepped-square.obj"),
                &"--measured",
                &csv,
            ]),
            &["m.csv:3", "p2", "beyond any machine"],
        );
        assert!(!err.contains("inf"), "{err}");
    }

    /// `verify` of a result whose u is 1e300 um: refused naming the file
    /// and key, not a change printed with an infinite u.
    #[test]
    fn verify_with_u_1e300_is_refused_naming_the_key() {
        let dir = tempdir();
        let a = dir.path().join("a.yaml");
        std::fs::write(
            &a,
            "machine: bc-trunnion\nlocation_errors:\n  EX0B: {value: 12.0, u: 1e300}\n",
        )
        .unwrap();
        let b = dir.path().join("b.yaml");
        std::fs::write(
            &b,
            "machine: bc-trunnion\nlocation_errors:\n  EX0B: {value: 2.0, u: 0.5}\n",
        )
        .unwrap();
        let err = fails(
            &os(&[&"verify", &"--before", &a, &"--after", &b]),
            &["a.yaml:3", "EX0B", "u 1e300"],
        );
        assert!(!err.contains("inf"), "{err}");
    }

    /// A machine name of 10 KB in a message: the message stays short.
    #[test]
    fn a_10_kb_machine_name_is_not_printed_whole() {
        let name = "m".repeat(10_000);
        let out = bin().args(["machine", "show", &name]).output().unwrap();
        assert_eq!(out.status.code(), Some(2));
        assert!(out.stderr.len() < 1024, "{} bytes", out.stderr.len());
    }
}

/// Runs `fivecal ARGS` in `dir` and expects success; returns stdout.
fn ok_in(dir: &Path, args: &[&str]) -> String {
    let o = bin().current_dir(dir).args(args).output().unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs `fivecal ARGS` in `dir` and expects a refusal (exit 2, no panic)
/// naming every one of `expect`; returns the message.
fn refused_in(dir: &Path, args: &[&str], expect: &[&str]) -> String {
    let o = bin().current_dir(dir).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: expected `{e}` in: {err}");
    }
    err
}

/// Issue 47, item 2: a nine-section measurement that does not match its
/// plan (9 sections of 5 points on `bc-trunnion`) is refused, naming what
/// is missing or extra, never averaged.
mod nine_section_regression {
    use super::*;

    /// A nine-section plan in `dir/p`, its heights (`h.csv`) and the CMM's
    /// DMIS output of its points (`m.dmo`), simulated with errors.
    fn nine_section(dir: &Path) -> (String, String) {
        ok_in(
            dir,
            &[
                "plan",
                "nine-section",
                "--machine",
                "bc-trunnion",
                "--out",
                "p",
            ],
        );
        std::fs::write(
            dir.join("t.yaml"),
            "machine: bc-trunnion\nlocation_errors: {EX0B: 10.0, EA0B: 40.0}\n",
        )
        .unwrap();
        for out in ["h.csv", "m.dmo"] {
            ok_in(
                dir,
                &[
                    "simulate",
                    "--plan",
                    "p/nine-section.plan.yaml",
                    "--errors",
                    "t.yaml",
                    "-o",
                    out,
                ],
            );
        }
        (
            std::fs::read_to_string(dir.join("h.csv")).unwrap(),
            std::fs::read_to_string(dir.join("m.dmo")).unwrap(),
        )
    }

    fn analyze(measured: &str) -> Vec<&str> {
        vec![
            "analyze",
            "--plan",
            "p/nine-section.plan.yaml",
            "--measured",
            measured,
            "--out",
            "r.yaml",
            "--no-record",
        ]
    }

    /// The DMIS blocks (`OUTPUT/...` and its lines) of `m.dmo` kept where
    /// `keep(index, label)` says so.
    fn dmis_keeping(dmo: &str, keep: impl Fn(usize, &str) -> bool) -> String {
        let mut parts = dmo.split("OUTPUT/");
        let mut out = parts.next().unwrap().to_string();
        for (i, b) in parts.enumerate() {
            let label = b[2..].split(')').next().unwrap();
            if keep(i, label) {
                out += "OUTPUT/";
                out += b;
            }
        }
        out
    }

    #[test]
    fn nine_section_heights_that_lost_their_last_lines_are_refused_naming_the_missing_sections() {
        let dir = tempdir();
        let d = dir.path();
        let (h, _) = nine_section(d);
        let lines: Vec<&str> = h.lines().collect();
        std::fs::write(d.join("h6.csv"), lines[..lines.len() - 3].join("\n")).unwrap();
        refused_in(
            d,
            &analyze("h6.csv"),
            &[
                "h6.csv: 6 of the plan's 9 sections are listed",
                "missing sections 7, 8, 9",
            ],
        );
        assert!(!d.join("r.yaml").exists());
        // The whole file is analysed.
        ok_in(d, &analyze("h.csv"));
    }

    #[test]
    fn nine_section_heights_of_sections_the_plan_lacks_are_refused_10_11_12_or_1000() {
        let dir = tempdir();
        let d = dir.path();
        let (h, _) = nine_section(d);
        let mut extra = h.clone();
        for k in 10..=12 {
            extra += &format!("{k},-4.0\n");
        }
        std::fs::write(d.join("h12.csv"), &extra).unwrap();
        refused_in(
            d,
            &analyze("h12.csv"),
            &[
                "h12.csv: sections 10 (line 13), 11 (line 14), 12 (line 15) are not in the plan, which has 9 sections",
            ],
        );
        let mut many = h.clone();
        for k in 10..=1000 {
            many += &format!("{k},-4.0\n");
        }
        std::fs::write(d.join("h1000.csv"), &many).unwrap();
        let err = refused_in(
            d,
            &analyze("h1000.csv"),
            &["and 981 more are not in the plan"],
        );
        assert!(err.len() < 1024, "{err}");
    }

    #[test]
    fn nine_section_heights_of_1e308_or_99999_um_are_refused_at_their_line() {
        let dir = tempdir();
        let d = dir.path();
        let (h, _) = nine_section(d);
        for v in ["99999", "1e308"] {
            let bad: String = h
                .lines()
                .map(|l| {
                    if l.starts_with("5,") {
                        format!("5,{v}\n")
                    } else {
                        format!("{l}\n")
                    }
                })
                .collect();
            std::fs::write(d.join("big.csv"), bad).unwrap();
            refused_in(
                d,
                &analyze("big.csv"),
                &[
                    "big.csv:8:3: height",
                    "of section 5 is beyond the largest error fivecal takes (10000 um)",
                ],
            );
        }
    }

    #[test]
    fn a_stepped_square_plan_given_nine_section_heights_is_refused() {
        let dir = tempdir();
        let d = dir.path();
        nine_section(d);
        plan_copy(d);
        refused_in(
            d,
            &[
                "analyze",
                "--plan",
                "stepped-square.plan.yaml",
                "--measured",
                "h.csv",
                "--out",
                "r.yaml",
                "--no-record",
            ],
            &[
                "h.csv: section heights belong to a nine-section plan, this plan is `stepped-square`",
            ],
        );
    }

    #[test]
    fn a_nine_section_dmis_of_every_other_point_3_points_or_missing_sections_is_refused() {
        let dir = tempdir();
        let d = dir.path();
        let (_, m) = nine_section(d);
        std::fs::write(d.join("half.dmo"), dmis_keeping(&m, |i, _| i % 2 == 0)).unwrap();
        refused_in(
            d,
            &analyze("half.dmo"),
            &[
                "half.dmo: 23 of the plan's 45 points are measured; missing 22",
                "section 1: 2 of 5",
                "a nine-section result needs every planned point",
            ],
        );
        std::fs::write(d.join("three.dmo"), dmis_keeping(&m, |i, _| i < 3)).unwrap();
        refused_in(
            d,
            &analyze("three.dmo"),
            &["three.dmo: 3 of the plan's 45 points are measured; missing 42"],
        );
        // The file lost its last sections.
        std::fs::write(
            d.join("six.dmo"),
            dmis_keeping(&m, |_, l| {
                !["S7", "S8", "S9"].iter().any(|s| l.starts_with(s))
            }),
        )
        .unwrap();
        refused_in(
            d,
            &analyze("six.dmo"),
            &["missing 15: section 7: 5 of 5, section 8: 5 of 5, section 9: 5 of 5"],
        );
        let out = ok_in(d, &analyze("m.dmo"));
        assert!(out.contains("AVG"), "{out}");
    }

    /// A point 99999 mm off its nominal: refused at its line, not averaged
    /// into its section.
    #[test]
    fn a_nine_section_dmis_point_far_off_its_nominal_is_refused_at_its_line() {
        let dir = tempdir();
        let d = dir.path();
        let (_, m) = nine_section(d);
        let line = m.lines().position(|l| l.starts_with("FA(S4-2)=")).unwrap() + 1;
        let bad: String = m
            .lines()
            .map(|l| {
                if l.starts_with("FA(S4-2)=") {
                    let f: Vec<&str> = l.split(',').collect();
                    format!("{},{},{},99999,{}\n", f[0], f[1], f[2], f[4..].join(","))
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        std::fs::write(d.join("far.dmo"), bad).unwrap();
        refused_in(
            d,
            &analyze("far.dmo"),
            &[&format!("far.dmo:{line}"), "S4-2"],
        );
    }
}

/// Issue 49, item 4: each error blames the file that is wrong, with its
/// line (and key), and says what fivecal was doing.
mod wrong_file_regression {
    use super::*;

    #[test]
    fn a_nan_probe_ball_diameter_in_the_plan_file_is_blamed_on_the_plan_file() {
        let dir = tempdir();
        let d = dir.path();
        ok_in(
            d,
            &[
                "plan",
                "probe-sphere",
                "--machine",
                "ac-trunnion",
                "--out",
                "p",
            ],
        );
        std::fs::write(
            d.join("t.yaml"),
            "machine: ac-trunnion\nlocation_errors: {EX0C: 10.0}\n",
        )
        .unwrap();
        ok_in(
            d,
            &[
                "simulate",
                "--plan",
                "p/probe-sphere.plan.yaml",
                "--errors",
                "t.yaml",
                "-o",
                "log.txt",
            ],
        );
        let manifest = d.join("p/probe-sphere.plan.yaml");
        let text = std::fs::read_to_string(&manifest).unwrap();
        let line = text
            .lines()
            .position(|l| l.trim_start().starts_with("ball_diameter:"))
            .unwrap()
            + 1;
        let bad = text.replacen("ball_diameter: 6.0", "ball_diameter: .nan", 1);
        assert_ne!(bad, text);
        std::fs::write(&manifest, bad).unwrap();
        let err = refused_in(
            d,
            &[
                "analyze",
                "--plan",
                "p/probe-sphere.plan.yaml",
                "--measured",
                "log.txt",
                "--out",
                "r.yaml",
                "--no-record",
            ],
            &[
                &format!("p/probe-sphere.plan.yaml:{line}:"),
                "probe ball_diameter",
                "NaN",
            ],
        );
        assert!(!err.contains("log.txt"), "{err}");
    }

    #[test]
    fn a_plan_points_file_with_rows_missing_is_blamed_on_the_points_file() {
        let dir = tempdir();
        let d = dir.path();
        plan_copy(d);
        let points = d.join("stepped-square.points.csv");
        let text = std::fs::read_to_string(&points).unwrap();
        let kept: Vec<&str> = text
            .lines()
            .enumerate()
            .filter(|(i, _)| !(4..7).contains(i))
            .map(|(_, l)| l)
            .collect();
        std::fs::write(&points, kept.join("\n") + "\n").unwrap();
        let err = refused_in(
            d,
            &[
                "analyze",
                "--plan",
                "stepped-square.plan.yaml",
                "--measured",
                "piece1.dmo",
                "--out",
                "r.yaml",
                "--no-record",
            ],
            &[
                "stepped-square.points.csv: the plan's points file lacks 3 points the plan has",
                "rows were lost",
            ],
        );
        assert!(!err.contains("belongs to a different plan"), "{err}");
    }

    #[test]
    fn obj_errors_name_their_line() {
        let dir = tempdir();
        let d = dir.path();
        std::fs::write(d.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
        std::fs::write(d.join("c.csv"), "label,x,y,z\np1,0,0,0\n").unwrap();
        let args = [
            "analyze",
            "contour",
            "--model",
            "bad.obj",
            "--measured",
            "c.csv",
        ];
        refused_in(
            d,
            &args,
            &["bad.obj: line 4: `f 1 2 9`: vertex index 9 names none of the 3 given before it"],
        );
        std::fs::write(d.join("bad.obj"), "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        refused_in(
            d,
            &args,
            &["bad.obj: line 2: `v 1 zero 0`: expected a vertex `v x y z`"],
        );
    }

    #[test]
    fn yaml_alias_bombs_name_the_line_of_the_first_alias_and_what_was_expected() {
        let dir = tempdir();
        let d = dir.path();
        let mut bomb =
            String::from("a: &a [\"x\",\"x\",\"x\",\"x\",\"x\",\"x\",\"x\",\"x\",\"x\"]\n");
        for (k, prev) in ["b", "c", "d", "e", "f", "g", "h"]
            .iter()
            .zip(["a", "b", "c", "d", "e", "f", "g"])
        {
            bomb += &format!("{k}: &{k} [{}]\n", vec![format!("*{prev}"); 9].join(","));
        }
        std::fs::write(d.join("bomb.yaml"), bomb).unwrap();
        refused_in(
            d,
            &["machine", "show", "bomb.yaml"],
            &[
                "bomb.yaml:2:8:",
                "aliases",
                "expected plain keys and values",
            ],
        );
    }

    #[test]
    fn multi_document_yaml_names_the_line_of_the_second_document() {
        let dir = tempdir();
        let d = dir.path();
        std::fs::write(
            d.join("a.yaml"),
            "machine: bc-trunnion\nlocation_errors: {EX0B: 1}\n---\nmachine: x\n",
        )
        .unwrap();
        std::fs::write(
            d.join("b.yaml"),
            "machine: bc-trunnion\nlocation_errors: {EX0B: 2}\n",
        )
        .unwrap();
        refused_in(
            d,
            &["verify", "--before", "a.yaml", "--after", "b.yaml"],
            &[
                "a.yaml:3:1: a second YAML document starts here (`---`): expected one document per file",
            ],
        );
    }

    #[test]
    fn a_bull_nose_tool_without_or_with_a_wrong_corner_radius_names_the_file_line_and_key() {
        let dir = tempdir();
        let d = dir.path();
        let m = std::fs::read_to_string(example("machines/bc-trunnion.yaml")).unwrap();
        let tool = m.lines().position(|l| l.starts_with("tool:")).unwrap() + 1;
        let bull = m.replacen("  kind: flat", "  kind: bull", 1);
        assert_ne!(bull, m);
        std::fs::write(d.join("m.yaml"), &bull).unwrap();
        refused_in(
            d,
            &["machine", "show", "m.yaml"],
            &[&format!(
                "m.yaml:{tool}:1: a bull-nose tool needs corner_radius (mm)"
            )],
        );
        std::fs::write(
            d.join("m.yaml"),
            bull.replacen("  kind: bull", "  kind: bull\n  corner_radius: 9", 1),
        )
        .unwrap();
        refused_in(
            d,
            &["machine", "show", "m.yaml"],
            &[&format!(
                "m.yaml:{}:3: corner_radius must be between 0 and half the diameter",
                tool + 3
            )],
        );
    }

    #[test]
    fn the_measurements_cover_1_pose_names_the_file() {
        let dir = tempdir();
        let d = dir.path();
        plan_copy(d);
        let m = std::fs::read_to_string(d.join("piece1.dmo")).unwrap();
        let mut parts = m.split("OUTPUT/");
        let mut one = parts.next().unwrap().to_string();
        for b in parts.filter(|b| b.starts_with("F(B0C0-")) {
            one += "OUTPUT/";
            one += b;
        }
        std::fs::write(d.join("one.dmo"), one).unwrap();
        refused_in(
            d,
            &[
                "analyze",
                "--plan",
                "stepped-square.plan.yaml",
                "--measured",
                "one.dmo",
                "--out",
                "r.yaml",
                "--no-record",
            ],
            &["one.dmo: the measurements cover 1 of the plan's 12 poses (only B0C0)"],
        );
    }

    #[test]
    fn output_to_dev_full_says_what_fivecal_was_writing_and_the_path() {
        let dir = tempdir();
        let d = dir.path();
        std::fs::write(
            d.join("a.nc"),
            "O1\nG90 G54\nG0 X0 Y0 Z50 B0 C0\nG1 X10 F100\nM30\n",
        )
        .unwrap();
        let truth = example("analyze/stepped-square/truth.yaml");
        let truth = truth.to_str().unwrap();
        refused_in(
            d,
            &[
                "compensate",
                "--machine",
                "bc-trunnion",
                "--errors",
                truth,
                "a.nc",
                "-o",
                "/dev/full",
            ],
            &["cannot write the output /dev/full: No space left on device"],
        );
        refused_in(
            d,
            &[
                "simulate",
                "--plan",
                plan_copy(d).to_str().unwrap(),
                "--errors",
                truth,
                "-o",
                "/dev/full",
            ],
            &["cannot write /dev/full"],
        );
    }

    #[test]
    fn step_minus_1_is_read_as_a_number_and_refused_with_what_is_expected() {
        let dir = tempdir();
        let d = dir.path();
        std::fs::write(d.join("a.nc"), "O1\nG0 X0 Y0 Z50 B0 C0\nG1 X10 F100\nM30\n").unwrap();
        let truth = example("analyze/stepped-square/truth.yaml");
        let err = refused_in(
            d,
            &[
                "simulate",
                "nc",
                "--machine",
                "bc-trunnion",
                "--errors",
                truth.to_str().unwrap(),
                "a.nc",
                "--step",
                "-1",
                "-o",
                "s.csv",
            ],
            &["--step -1: expected 0 (end points only) or a distance of at least 0.001 mm"],
        );
        assert!(!err.contains("unexpected argument"), "{err}");
    }

    /// Runs the same command `n` times at once in `dir`; each must succeed.
    fn at_once(dir: &Path, n: usize, args: impl Fn(usize) -> Vec<String>) {
        let children: Vec<_> = (0..n)
            .map(|i| {
                bin()
                    .current_dir(dir)
                    .args(args(i))
                    .stdout(std::process::Stdio::null())
                    .stderr(std::process::Stdio::piped())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for c in children {
            let o = c.wait_with_output().unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        }
    }

    #[test]
    fn two_plan_runs_into_one_directory_at_once_both_write_it() {
        let dir = tempdir();
        let d = dir.path();
        at_once(d, 3, |_| {
            [
                "plan",
                "stepped-square",
                "--machine",
                "bc-trunnion",
                "--out",
                "p",
            ]
            .map(String::from)
            .to_vec()
        });
        let names = listing(&d.join("p"));
        assert!(
            names.contains(&"stepped-square.plan.yaml".to_string()),
            "{names:?}"
        );
        assert!(
            !names.iter().any(|n| n.contains("fivecal-tmp")),
            "{names:?}"
        );
        assert!(
            !listing(d).iter().any(|n| n.contains("fivecal-tmp")),
            "{:?}",
            listing(d)
        );
    }

    #[test]
    fn two_report_runs_into_one_report_directory_at_once_both_write_it() {
        let dir = tempdir();
        let d = dir.path();
        plan_copy(d);
        at_once(d, 2, |i| {
            [
                "analyze",
                "--plan",
                "stepped-square.plan.yaml",
                "--measured",
                "piece1.dmo",
                "--no-record",
                "--out",
                &format!("r{i}.yaml"),
                "--report",
                "rep",
            ]
            .map(String::from)
            .to_vec()
        });
        assert!(!listing(&d.join("rep")).is_empty());
        assert!(
            !listing(d).iter().any(|n| n.contains("fivecal-tmp")),
            "{:?}",
            listing(d)
        );
    }

    /// Issue 49: a postprocessor template that renders a block of 50 MB is
    /// refused with a message under 1 KB.
    #[test]
    fn a_50_mb_template_render_is_refused_in_a_message_under_1_kb() {
        let dir = tempdir();
        let d = dir.path();
        let post = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("postprocessors/fanuc.yaml"),
        )
        .unwrap();
        let big = post.replacen(
            "  rapid: \"G0 {{ words }}\"",
            "  rapid: \"G0 {{ words }}{{ 'X' * 50000000 }}\"",
            1,
        );
        assert_ne!(big, post);
        std::fs::write(d.join("big.yaml"), big).unwrap();
        let err = refused_in(
            d,
            &[
                "plan",
                "stepped-square",
                "--machine",
                "bc-trunnion",
                "--postprocessor",
                "big.yaml",
                "--out",
                "p",
            ],
            &["characters cut"],
        );
        assert!(err.len() < 1024, "{} bytes", err.len());
        assert!(!d.join("p").exists());
    }
}

/// Issue 47, item 4: a long Monte-Carlo study is bounded by
/// `--max-seconds` and refused when it outlasts it, naming how far it
/// came, never a u from fewer runs than asked.
#[test]
fn mc_exact_beyond_max_seconds_is_refused_naming_the_runs_done() {
    let dir = tempdir();
    let d = dir.path();
    plan_copy(d);
    let start = std::time::Instant::now();
    let err = refused_in(
        d,
        &[
            "analyze",
            "--plan",
            "stepped-square.plan.yaml",
            "--measured",
            "piece1.dmo",
            "--out",
            "r.yaml",
            "--no-record",
            "--mc",
            "100000",
            "--mc-exact",
            "--max-seconds",
            "1",
        ],
        &[
            "the Monte-Carlo study of 100000 runs stopped at --max-seconds 1 with",
            "a u from fewer runs than asked is not reported",
        ],
    );
    assert!(start.elapsed().as_secs() < 60, "{err}");
    assert!(!d.join("r.yaml").exists());
    refused_in(
        d,
        &[
            "analyze",
            "--plan",
            "stepped-square.plan.yaml",
            "--measured",
            "piece1.dmo",
            "--out",
            "r.yaml",
            "--mc",
            "10",
            "--max-seconds",
            "-1",
        ],
        &["--max-seconds -1: expected a time > 0 s"],
    );
}

/// Issue 47, "Show": commands fed generated hostile inputs (heights with
/// absurd, missing, repeated and extra sections; error files with hostile
/// numbers; NC programs of hostile words) either succeed with finite
/// outputs or refuse naming the file; the input is never changed, no
/// temporary file is left, and each run ends within a bound. Few cases per
/// property, so the suite stays fast.
mod properties {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngSeed, TestRunner};

    fn config(cases: u32, salt: u64) -> Config {
        Config {
            cases,
            rng_seed: RngSeed::Fixed(47 ^ salt),
            failure_persistence: None,
            ..Config::default()
        }
    }

    /// Numbers as an attacker writes them.
    const NUMBERS: &[&str] = &[
        "0", "-5", "3.25", "1e308", "-1e308", "99999", "NaN", "inf", "-inf", "", "abc", "1e-300",
        "0x10", "1,5", "+7", "-0", "5e3", "10001",
    ];

    fn number() -> impl Strategy<Value = String> {
        prop_oneof![
            proptest::sample::select(NUMBERS).prop_map(String::from),
            (-2e4f64..2e4).prop_map(|v| format!("{v}")),
        ]
    }

    /// Runs one case in `dir`: `args` with `input` written to `name`. The
    /// run must end within 60 s, exit 0 or 2 (never a panic), leave the
    /// input as it was and no temporary file; a refusal names `name`, a
    /// success writes no non-finite number to stdout or `out` that the
    /// input did not have.
    fn check(
        dir: &Path,
        name: &str,
        input: &str,
        args: &[&str],
        out: Option<&str>,
    ) -> Result<(), TestCaseError> {
        let path = dir.join(name);
        std::fs::write(&path, input).unwrap();
        if let Some(o) = out {
            let _ = std::fs::remove_file(dir.join(o));
        }
        let before = hash(&path);
        let mut cmd = bin();
        cmd.current_dir(dir).args(args);
        let o = within(cmd, std::time::Duration::from_secs(60));
        let err = String::from_utf8_lossy(&o.stderr);
        let stdout = String::from_utf8_lossy(&o.stdout);
        prop_assert!(!err.contains("panicked"), "{err}");
        match o.status.code() {
            Some(0) => {
                // A non-finite word is no result of fivecal's unless the
                // input had it (a block left as written copies it).
                let words = |t: &str, bad: &str| {
                    t.to_ascii_lowercase()
                        .split(|c: char| !c.is_ascii_alphanumeric())
                        .filter(|w| *w == bad)
                        .count()
                };
                let written = out
                    .map(|o| std::fs::read_to_string(dir.join(o)).unwrap_or_default())
                    .unwrap_or_default();
                for bad in ["nan", "inf"] {
                    for text in [stdout.as_ref(), written.as_str()] {
                        prop_assert!(
                            words(text, bad) <= words(input, bad),
                            "{bad} in the output of {args:?}: {text}"
                        );
                    }
                }
            }
            Some(2) => prop_assert!(err.contains(name), "a refusal without {name}: {err}"),
            c => prop_assert!(false, "exit {c:?}: {err}"),
        }
        prop_assert_eq!(hash(&path), before, "{} changed", name);
        let left: Vec<String> = listing(dir)
            .into_iter()
            .filter(|n| n.contains("fivecal-tmp"))
            .collect();
        prop_assert!(left.is_empty(), "left behind: {left:?}");
        Ok(())
    }

    #[test]
    fn hostile_nine_section_heights_are_computed_finite_or_refused_naming_the_file() {
        let dir = tempdir();
        let d = dir.path();
        ok_in(
            d,
            &[
                "plan",
                "nine-section",
                "--machine",
                "bc-trunnion",
                "--out",
                "p",
            ],
        );
        let rows = proptest::collection::vec((0u32..14, number()), 0..14);
        TestRunner::new(config(10, 1))
            .run(&rows, |rows| {
                let mut text = String::from("section,height_um\n1,0\n");
                for (s, v) in &rows {
                    text += &format!("{s},{v}\n");
                }
                check(
                    d,
                    "h.csv",
                    &text,
                    &[
                        "analyze",
                        "--plan",
                        "p/nine-section.plan.yaml",
                        "--measured",
                        "h.csv",
                        "--out",
                        "r.yaml",
                        "--no-record",
                    ],
                    Some("r.yaml"),
                )
            })
            .unwrap();
    }

    #[test]
    fn hostile_error_files_are_verified_finite_or_refused_naming_the_file() {
        let dir = tempdir();
        let d = dir.path();
        std::fs::write(
            d.join("b.yaml"),
            "machine: bc-trunnion\nlocation_errors:\n  EX0B: {value: 2.0, u: 0.5}\n",
        )
        .unwrap();
        let values = (number(), number(), proptest::bool::ANY);
        TestRunner::new(config(10, 2))
            .run(&values, |(v, u, alias)| {
                let text = if alias {
                    format!(
                        "machine: bc-trunnion\nx: &x [{v},{v},{v}]\ny: [*x,*x,*x]\nlocation_errors:\n  EX0B: {{value: {v}, u: {u}}}\n"
                    )
                } else {
                    format!("machine: bc-trunnion\nlocation_errors:\n  EX0B: {{value: {v}, u: {u}}}\n")
                };
                check(
                    d,
                    "a.yaml",
                    &text,
                    &["verify", "--before", "a.yaml", "--after", "b.yaml"],
                    None,
                )
            })
            .unwrap();
    }

    #[test]
    fn hostile_nc_programs_are_compensated_finite_or_refused_naming_the_file() {
        let dir = tempdir();
        let d = dir.path();
        let truth = example("analyze/stepped-square/truth.yaml");
        let truth = truth.to_str().unwrap().to_string();
        let word = prop_oneof![
            proptest::sample::select(&["X", "Y", "Z", "B", "C", "F", "R1="][..])
                .prop_flat_map(|w| number().prop_map(move |n| format!("{w}{n}"))),
            proptest::sample::select(
                &[
                    "G1",
                    "G0",
                    "G2",
                    "G91",
                    "M30",
                    "#1=EXP[1000]",
                    "(",
                    "%",
                    "N"
                ][..]
            )
            .prop_map(String::from),
        ];
        let lines = proptest::collection::vec(proptest::collection::vec(word, 1..4), 0..6);
        TestRunner::new(config(8, 3))
            .run(&lines, |lines| {
                let mut text = String::from("O1000\nG90 G54 G94\nG0 X10. Y20. Z30. B0. C0.\n");
                for l in &lines {
                    text += &l.join(" ");
                    text.push('\n');
                }
                text += "G1 X20. F500.\nM30\n";
                check(
                    d,
                    "p.nc",
                    &text,
                    &[
                        "compensate",
                        "--machine",
                        "bc-trunnion",
                        "--errors",
                        &truth,
                        "p.nc",
                        "-o",
                        "out.nc",
                    ],
                    Some("out.nc"),
                )
            })
            .unwrap();
    }
}
