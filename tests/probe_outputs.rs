//! `plan probe-columns|probe-sphere`: the files a probing plan writes, the
//! manifest from which `procedure::load` rebuilds it exactly, the setup
//! model and sheet, a simulator following the documented recipe, and the
//! errors a user sees.

use std::path::{Path, PathBuf};

use fivecal::formats::manifest::{Manifest, TestKind};
use fivecal::formats::probe_log;
use fivecal::kinematics::Perturbation;
use fivecal::post::PostDefinition;
use fivecal::procedure::probing::ProbedGeometry;
use fivecal::procedure::{Plan, PlanConfig, ProbingPlan, Template, TemplateSource, Test, load};
use fivecal::{Axes, Dialect};
use nalgebra::Vector3;

use crate::cli::fivecal;
use crate::probe_programs::probing;
use crate::util::{machine, rng, tempdir};

fn written(p: &ProbingPlan) -> (tempfile::TempDir, PathBuf) {
    let dir = tempdir();
    let path = dir.path().to_path_buf();
    Plan::from(p.clone())
        .write(&path, p.test.as_str(), &[])
        .unwrap();
    (dir, path)
}

fn same_plan(a: &ProbingPlan, b: &ProbingPlan) {
    assert_eq!(a.test, b.test);
    assert_eq!(a.dialect, b.dialect);
    assert_eq!(a.probe, b.probe);
    assert_eq!(a.plan.touches, b.plan.touches);
    assert_eq!(a.plan.moves, b.plan.moves);
    assert_eq!(a.plan.poses, b.plan.poses);
    assert_eq!(a.plan.obstacles, b.plan.obstacles);
    assert_eq!(a.plan.settings, b.plan.settings);
    assert_eq!(a.plan.skipped, b.plan.skipped);
    assert_eq!(a.plan.safe_z, b.plan.safe_z);
    assert_eq!(a.setup, b.setup);
    assert_eq!(a.run_time, b.run_time);
    assert_eq!(a.toolpath, b.toolpath);
    assert_eq!(a.program, b.program);
    assert_eq!(a.mesh, b.mesh);
    assert_eq!(a.poses(), b.poses());
}

#[test]
fn load_any_rebuilds_probing_plans_exactly_and_tells_the_kinds_apart() {
    for (m, test, d) in [
        ("ac-trunnion", "probe-columns", Dialect::Fanuc),
        ("head-table", "probe-sphere", Dialect::Heidenhain),
        ("head-head", "probe-columns", Dialect::Linuxcnc),
    ] {
        let p = probing(m, test, d);
        let (_keep, dir) = written(&p);
        let man_path = dir.join(format!("{test}.plan.yaml"));
        let man = Manifest::read(&man_path).unwrap();
        assert_eq!(
            (man.kind, man.test.as_str(), man.dialect),
            (TestKind::Probing, test, d)
        );
        assert_eq!(man.probe.as_ref(), Some(&machine(m).probe));
        assert!(man.tool.is_none());
        for role in ["program", "points", "glb", "obj", "setup", "postprocessor"] {
            assert!(man.file(&man_path, role).unwrap().exists(), "{role}");
        }
        assert_eq!(man.poses.len(), p.plan.poses.len());
        for (e, q) in man.poses.iter().zip(p.poses()) {
            assert_eq!((e.pose.as_str(), e.seq), (q.id.as_str(), q.seq));
            assert!((e.start_min - q.start_min).abs() <= 5e-4);
            assert!((e.end_min - q.end_min).abs() <= 5e-4);
        }
        let back = match load(&man_path).unwrap() {
            Plan::Probing(b) => b,
            Plan::Machining(_) => panic!("{test} loaded as machining"),
        };
        same_plan(&p, &back);
    }
    // A machining manifest through the same call.
    let t = crate::plan::planned("bc-trunnion", "stepped-square", Dialect::Fanuc);
    let dir = tempdir();
    Plan::from(t.clone())
        .write(dir.path(), t.test.as_str(), &[])
        .unwrap();
    let man_path = dir.path().join("stepped-square.plan.yaml");
    let any = load(&man_path).unwrap();
    assert_eq!(any.kind(), TestKind::Machining);
    assert_eq!(any.plan_points(), t.plan_points());
    assert_eq!(any.machining().unwrap().program, t.program);
    assert!(any.probing().is_none());
}

#[test]
fn load_refuses_a_probing_plan_whose_copies_were_edited() {
    let p = probing("ac-trunnion", "probe-columns", Dialect::Linuxcnc);
    // A column moved by 1 mm: same poses and labels, other points.
    let (_keep, dir) = written(&p);
    let tpl = dir.join("probe-columns.template.yaml");
    let src = std::fs::read_to_string(&tpl).unwrap();
    std::fs::write(
        &tpl,
        src.replace("centre: [-60, -45]", "centre: [-59, -45]"),
    )
    .unwrap();
    let e = load(&dir.join("probe-columns.plan.yaml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("differs from the manifest"), "{e}");
    // points.csv edited: its rows no longer are the plan's touches.
    let (_keep, dir) = written(&p);
    let pts = dir.join("probe-columns.points.csv");
    let src = std::fs::read_to_string(&pts).unwrap();
    std::fs::write(
        &pts,
        src.replacen(
            "-60.000000,-45.000000,100.000000",
            "-60.000000,-45.000000,100.100000",
            1,
        ),
    )
    .unwrap();
    let e = load(&dir.join("probe-columns.plan.yaml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("row 1 of") && e.contains("A0C0_C1_t1"), "{e}");
    // The probe of the manifest is not the machine file's.
    let (_keep, dir) = written(&p);
    let man = dir.join("probe-columns.plan.yaml");
    let src = std::fs::read_to_string(&man).unwrap();
    std::fs::write(
        &man,
        src.replace("ball_diameter: 6.0", "ball_diameter: 4.0"),
    )
    .unwrap();
    let e = load(&man).unwrap_err().to_string();
    assert!(e.contains("the manifest's probe"), "{e}");
}

#[test]
fn probing_outputs_are_deterministic() {
    for d in [Dialect::Fanuc, Dialect::Heidenhain] {
        let a = Plan::from(probing("bc-trunnion", "probe-sphere", d));
        let b = Plan::from(probing("bc-trunnion", "probe-sphere", d));
        assert_eq!(a.outputs("x"), b.outputs("x"));
        for (name, bytes) in a.outputs("x") {
            let text = String::from_utf8_lossy(&bytes);
            // Coordinates may hold any digits; a date has its dashes.
            assert!(
                !["2025-", "2026-", "2027-"].iter().any(|y| text.contains(y)),
                "{} holds a date",
                name.display()
            );
        }
    }
}

/// Triangles of an OBJ file with their group names (read with tobj).
fn obj_groups(path: &Path) -> Vec<(String, Vec<[Vector3<f64>; 3]>)> {
    let (models, _) = tobj::load_obj(
        path,
        &tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        },
    )
    .unwrap();
    models
        .into_iter()
        .map(|m| {
            let p = &m.mesh.positions;
            let v = |i: u32| {
                let i = i as usize * 3;
                Vector3::new(p[i] as f64, p[i + 1] as f64, p[i + 2] as f64)
            };
            let tris = m
                .mesh
                .indices
                .chunks(3)
                .map(|f| [v(f[0]), v(f[1]), v(f[2])])
                .collect();
            (m.name, tris)
        })
        .collect()
}

/// The written model holds the setup: one group per piece, closed around
/// its volume, and every touch's contact point lies on the model (to the
/// facets' chord on the round sphere).
#[test]
fn the_setup_model_holds_every_touch() {
    for (test, names, tol) in [
        ("probe-columns", vec!["C1", "C2", "C3", "table"], 1e-5),
        // r (1 - cos(pi / 64)) for the 15 mm sphere, and OBJ's 6 decimals.
        ("probe-sphere", vec!["sphere", "stem", "table"], 0.0181),
    ] {
        let p = probing("ac-trunnion", test, Dialect::Fanuc);
        let (_keep, dir) = written(&p);
        let groups = obj_groups(&dir.join(format!("{test}.obj")));
        let got: Vec<&str> = groups.iter().map(|g| g.0.as_str()).collect();
        assert_eq!(got, names);
        let all: Vec<[Vector3<f64>; 3]> = groups.iter().flat_map(|g| g.1.clone()).collect();
        assert_eq!(all.len(), p.mesh.triangles.len());
        for (name, tris) in &groups {
            // Closed and facing out: the divergence theorem gives a positive volume.
            let vol: f64 = tris
                .iter()
                .map(|t| t[0].dot(&t[1].cross(&t[2])))
                .sum::<f64>()
                / 6.0;
            assert!(vol > 0.0, "{test} {name}: volume {vol}");
        }
        for t in &p.plan.touches {
            let d = all
                .iter()
                .map(|tri| {
                    (fivecal::mesh::closest_on_triangle(&t.contact_w, tri) - t.contact_w).norm()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(d < tol, "{test} {}: {d} mm off the model", t.label);
        }
        // The GLB holds the same groups and triangles.
        let bytes = std::fs::read(dir.join(format!("{test}.glb"))).unwrap();
        let doc = gltf::Gltf::from_slice(&bytes).unwrap();
        let meshes: Vec<(String, usize)> = doc
            .meshes()
            .map(|m| {
                let n = m
                    .primitives()
                    .map(|pr| pr.get(&gltf::Semantic::Positions).unwrap().count())
                    .sum::<usize>();
                (m.name().unwrap().to_string(), n / 3)
            })
            .collect();
        let want: Vec<(String, usize)> = groups.iter().map(|g| (g.0.clone(), g.1.len())).collect();
        assert_eq!(meshes, want);
    }
}

/// The setup sheet states the expected run time, compared with Ibaraki, Iritani & Matsushita's (2013)
/// 219 points in about 28 min; pose and touch times run on from 0 to it.
#[test]
fn the_setup_sheet_gives_the_run_time_against_seed_000() {
    let p = probing("ac-trunnion", "probe-columns", Dialect::Fanuc);
    let rt = &p.run_time;
    assert_eq!(rt.touches, 221);
    assert!(
        (20.0..35.0).contains(&rt.total_min),
        "{} min for 221 touches (Ibaraki, Iritani & Matsushita 2013: 219 in about 28)",
        rt.total_min
    );
    let sheet = p.setup_sheet("probe-columns");
    let want = format!(
        "Estimated run time {} min for 221 touches",
        (rt.total_min * 10.0).round() / 10.0
    );
    assert!(sheet.contains(&want), "{want}\n{sheet}");
    assert!(
        sheet.contains("Ibaraki, Iritani & Matsushita 2013 reports 219 points in about 28 min")
    );
    assert!(sheet.contains("| 0 | A0C0 | 0 | 0 | 15 | 0 |"), "{sheet}");
    // Times run on: poses in order, each touch within its pose.
    let poses = p.poses();
    let mut prev = 0.0;
    for q in &poses {
        assert!(
            q.start_min >= prev - 1e-12 && q.end_min > q.start_min,
            "{q:?}"
        );
        for i in q.touches.clone() {
            let t = rt.touch_min[i];
            assert!(
                t > q.start_min && t < q.end_min,
                "{}: {t}",
                p.plan.touches[i].label
            );
            if i > 0 {
                assert!(t > rt.touch_min[i - 1]);
            }
        }
        prev = q.end_min;
    }
    assert!((poses.last().unwrap().end_min - rt.total_min).abs() < 1e-9);
    // The manifest carries the same times (3 decimals).
    let man = Plan::from(p.clone()).manifest("probe-columns");
    assert_eq!(
        man.poses.last().unwrap().end_min,
        (rt.total_min * 1000.0).round() / 1000.0
    );
}

/// A simulator following `plan::probing`'s recipe: move the commanded axes
/// from each touch's start towards its end until the actual ball meets the
/// nominal surface, log the commanded X, Y, Z with the plan's log format,
/// and read the log back. Without errors that gives the nominal contact
/// points; with location errors every touch still triggers inside its
/// window and the measured points move by no more than the errors can
/// move a point of the setup.
#[test]
fn a_simulator_following_the_documented_recipe_writes_logs_the_reader_accepts() {
    let lin_um = 20.0;
    let ang_urad = 50.0;
    for (m, test, d) in [
        ("ac-trunnion", "probe-columns", Dialect::Fanuc),
        ("head-table", "probe-sphere", Dialect::Linuxcnc),
    ] {
        let p = probing(m, test, d);
        let kin = &p.plan.kin;
        let r = p.probe.ball_diameter / 2.0;
        let mut errors = crate::util::random_perturbation(kin, &mut rng(41), lin_um, ang_urad);
        errors.0[fivecal::kinematics::SLOT_TOOL_LENGTH] = 0.0;
        for (label, e) in [("nominal", Perturbation::zero()), ("erroneous", errors)] {
            let recorded: Vec<_> = p
                .plan
                .touches
                .iter()
                .map(|t| {
                    let (a, b) = (t.start.axes, t.end.axes);
                    let at = |s: f64| Axes {
                        xyz: a.xyz + (b.xyz - a.xyz) * s,
                        ..a
                    };
                    let gap = |s: f64| p.setup.signed_distance(&kin.forward(&at(s), &e).tip) - r;
                    let (mut lo, mut hi) = (0.0, 1.0);
                    assert!(gap(lo) > 0.0 && gap(hi) < 0.0, "{}", t.label);
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        if gap(mid) > 0.0 {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    (t, at(lo).xyz)
                })
                .collect();
            let text = p.log_format().write(&p.plan, recorded);
            let log = probe_log::read(
                d,
                Path::new("sim.log"),
                &text,
                &p.plan_points(),
                kin,
                &p.read_options(),
            )
            .unwrap_or_else(|e| panic!("{test} on {m}, {label}: {e}"));
            assert_eq!(log.points.len(), p.plan.touches.len());
            // Reach: every contact lies within 300 mm of the rotary axes.
            let bound = if label == "nominal" {
                2e-4
            } else {
                6.0 * lin_um * 1e-3 + 6.0 * ang_urad * 1e-6 * 300.0
            };
            let mut moved = 0.0_f64;
            for (got, t) in log.points.iter().zip(&p.plan.touches) {
                let dev = (got.p - t.contact_prog).norm();
                assert!(dev < bound, "{test} on {m}, {label}, {}: {dev} mm", t.label);
                moved = moved.max(dev);
            }
            if label == "erroneous" {
                assert!(moved > 1e-3, "{test} on {m}: the errors moved nothing");
            }
        }
    }
}

/// The probed surfaces of the setup as the simulator sees them: every
/// contact point on them, every touch's start at the clearance distance.
#[test]
fn the_setup_geometry_puts_each_touch_on_its_surface() {
    for test in ["probe-columns", "probe-sphere"] {
        let p = probing("bc-trunnion", test, Dialect::Linuxcnc);
        let r = p.probe.ball_diameter / 2.0;
        let c = p.plan.settings.clearance;
        for t in &p.plan.touches {
            let s = &p.setup;
            assert!(s.signed_distance(&t.contact_w).abs() < 1e-9, "{}", t.label);
            assert!((s.signed_distance(&t.contact.ball_w) - r).abs() < 1e-9);
            assert!((s.signed_distance(&t.start.ball_w) - r - c).abs() < 1e-9);
            assert!(s.signed_distance(&(t.contact_w - t.normal_w * 0.5)) < 0.0);
        }
        match &p.setup {
            ProbedGeometry::Columns(cs) => assert_eq!(cs.len(), 3),
            ProbedGeometry::Sphere(s) => assert_eq!(
                (s.diameter, s.centre.z),
                (30.0, 100.0 + machine("bc-trunnion").table.surface)
            ),
        }
    }
}

#[test]
fn cli_writes_every_probing_output() {
    let dir = tempdir();
    let out = fivecal()
        .args([
            "plan",
            "probe-sphere",
            "--machine",
            "ac-trunnion",
            "--dialect",
            "heidenhain",
            "--out",
        ])
        .arg(dir.path())
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.starts_with(
            "probe-sphere on ac-trunnion: 49 poses, 242 touches, about 26 min (heidenhain dialect)"
        ),
        "{text}"
    );
    for f in [
        "probe-sphere.h",
        "sphere-head.a",
        "sphere-touch.a",
        "probe-sphere.points.csv",
        "probe-sphere.plan.yaml",
        "probe-sphere.machine.yaml",
        "probe-sphere.template.yaml",
        "probe-sphere.post.yaml",
        "probe-sphere.glb",
        "probe-sphere.obj",
        "probe-sphere.md",
    ] {
        assert!(dir.path().join(f).exists(), "{f} missing:\n{text}");
        assert!(text.contains(&format!("wrote {}", dir.path().join(f).display())));
    }
    let p = match load(&dir.path().join("probe-sphere.plan.yaml")).unwrap() {
        Plan::Probing(p) => p,
        _ => panic!(),
    };
    assert_eq!(
        std::fs::read_to_string(dir.path().join("probe-sphere.h")).unwrap(),
        p.program.text
    );

    // The default machine, a template given by path (the LAMDAMAP 2015 paper's spiral).
    let tpl = dir.path().join("spiral.yaml");
    std::fs::write(
        &tpl,
        fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE
            .replace("pattern: seed-004", "pattern: seed-003"),
    )
    .unwrap();
    let sub = dir.path().join("spiral");
    fivecal()
        .args([
            "plan",
            "probe-sphere",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "linuxcnc",
            "--template",
        ])
        .arg(&tpl)
        .arg("--out")
        .arg(&sub)
        .assert()
        .success();
    let back = load(&sub.join("probe-sphere.plan.yaml")).unwrap();
    let back = back.probing().unwrap();
    assert_eq!(back.machine.name, "bc-trunnion");
    assert_eq!(back.plan.poses.len(), 50);
    assert_eq!(back.plan.poses[7].id, "S07");
}

#[test]
fn cli_refuses_what_a_probing_plan_cannot_do() {
    let dir = tempdir();
    let run = |args: &[&str]| {
        let out = fivecal()
            .args(args)
            .arg("--out")
            .arg(dir.path())
            .assert()
            .code(2)
            .get_output()
            .stderr
            .clone();
        String::from_utf8(out).unwrap()
    };
    let e = run(&[
        "plan",
        "probe-columns",
        "--machine",
        "bc-trunnion",
        "--kinematics",
        "controller",
    ]);
    assert!(e.contains("--kinematics controller"), "{e}");
    let e = run(&[
        "plan",
        "probe-sphere",
        "--machine",
        "bc-trunnion",
        "--tool",
        "machine",
    ]);
    assert!(e.contains("machine file's probe"), "{e}");
    let col = dir.path().join("col.yaml");
    std::fs::write(&col, fivecal::procedure::probing::columns::BUILTIN_TEMPLATE).unwrap();
    let e = run(&[
        "plan",
        "probe-sphere",
        "--machine",
        "bc-trunnion",
        "--template",
        col.to_str().unwrap(),
    ]);
    assert!(
        e.contains("the template is for test `probe-columns`"),
        "{e}"
    );
    let bad = dir.path().join("bad.yaml");
    std::fs::write(
        &bad,
        fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE
            .replace("diameter: 30 ", "diameter: -30 "),
    )
    .unwrap();
    let e = run(&[
        "plan",
        "probe-sphere",
        "--machine",
        "bc-trunnion",
        "--template",
        bad.to_str().unwrap(),
    ]);
    assert!(
        e.contains("bad.yaml:9:")
            && e.contains("sphere.diameter must be between 0.001 and 2000 mm")
            && e.contains("got -30"),
        "{e}"
    );
    // A sphere beyond the tilt limits of the machine.
    let e = run(&[
        "plan",
        "probe-sphere",
        "--machine",
        "ac-trunnion",
        "--template",
        {
            let t = dir.path().join("far.yaml");
            std::fs::write(
                &t,
                fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE.replace(
                    "tilt: {from: -90, to: 30, step: 10}",
                    "tilt: {from: -130, to: 30, step: 10}",
                ),
            )
            .unwrap();
            Box::leak(t.to_str().unwrap().to_string().into_boxed_str())
        },
    ]);
    assert!(e.contains("A = -130 deg is outside the limits"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    // An output never overwrites an input: the template's own copy.
    let own = dir.path().join("probe-sphere.template.yaml");
    std::fs::write(&own, fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE).unwrap();
    let e = run(&[
        "plan",
        "probe-sphere",
        "--machine",
        "bc-trunnion",
        "--template",
        own.to_str().unwrap(),
    ]);
    assert!(e.contains("refusing to overwrite input file"), "{e}");
    assert!(!dir.path().join("probe-sphere.plan.yaml").exists());
}

/// A postprocessor whose control probes in any direction keeps the column
/// faces HEIDENHAIN's cycle 0 cannot reach, and the plan says why it left
/// them out otherwise.
#[test]
fn single_axis_probing_leaves_out_oblique_touches_and_says_so() {
    let h = probing("ac-trunnion", "probe-columns", Dialect::Heidenhain);
    let f = probing("ac-trunnion", "probe-columns", Dialect::Fanuc);
    assert!(h.limits.axis_aligned_probing && !f.limits.axis_aligned_probing);
    assert!(h.plan.touches.len() < f.plan.touches.len());
    assert!(
        h.plan
            .skipped
            .iter()
            .any(|s| s.label == "A0C60_C1_xp" && s.reason.contains("probes along X, Y or Z only"))
    );
    assert!(
        h.notes.iter().any(|n| n.contains("multiples of 90 deg")),
        "{:?}",
        h.notes
    );
    // The same control with an oblique cycle keeps every touch.
    let src = PostDefinition::builtin(Dialect::Heidenhain)
        .source
        .replace("probe_axis_aligned: true", "probe_axis_aligned: false");
    let post = PostDefinition::parse(Path::new("h.yaml"), &src).unwrap();
    let any = fivecal::procedure::probing::plan(&PlanConfig {
        kinematics: fivecal::formats::manifest::KinematicsMode::Post,
        tool: None,
        machine: machine("ac-trunnion"),
        template: Template::from_source(TemplateSource::builtin(Test::ProbeColumns)).unwrap(),
        post,
    })
    .unwrap();
    assert_eq!(any.plan.touches, f.plan.touches);
}

/// The setup sheet sends the operator to a command, not to the library:
/// on every dialect it names `fivecal analyze` with the plan file that the
/// plan really wrote beside it.
#[test]
fn the_setup_sheet_names_the_command_that_reads_the_log_back() {
    for d in Dialect::ALL {
        let p = probing("ac-trunnion", "probe-columns", d);
        let (_keep, dir) = written(&p);
        let sheet = std::fs::read_to_string(dir.join("probe-columns.md")).unwrap();
        assert!(!sheet.contains("fivecal::"), "{d:?}: {sheet}");
        let cmd = "`fivecal analyze --plan probe-columns.plan.yaml --measured LOG";
        assert!(sheet.contains(cmd), "{d:?}: {sheet}");
        assert!(dir.join("probe-columns.plan.yaml").exists());
    }
}
