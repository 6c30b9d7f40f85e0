//! `plan`: the stepped-square and nine-section tests on every example
//! machine, their points on the written piece, provenance, the manifest
//! round trip and the errors a user sees.

use std::path::{Path, PathBuf};

use fivecal::formats::manifest::{KinematicsMode, Manifest};
use fivecal::formats::points::PlanPoints;
use fivecal::post::PostDefinition;
use fivecal::procedure::machining::{Pass, ToolPart, plan};
use fivecal::procedure::{MachiningPlan, Plan, PlanConfig, PlanError, Template, Test, load};
use fivecal::{Dialect, Kinematics, Machine};
use nalgebra::{DMatrix, Vector3};

use crate::cli::fivecal;
use crate::util::{MACHINES, machine, tempdir};

pub const TESTS: [&str; 2] = ["stepped-square", "nine-section"];

pub fn config(
    machine_name: &str,
    test: &str,
    dialect: Dialect,
    mode: KinematicsMode,
) -> PlanConfig {
    PlanConfig {
        machine: machine(machine_name),
        template: Template::builtin(test.parse().unwrap()),
        post: PostDefinition::builtin(dialect),
        kinematics: mode,
        tool: None,
    }
}

pub fn planned(machine_name: &str, test: &str, dialect: Dialect) -> MachiningPlan {
    plan(&config(machine_name, test, dialect, KinematicsMode::Post))
        .unwrap_or_else(|e| panic!("{test} on {machine_name} ({dialect}): {e}"))
}

// ---------------------------------------------------------------- meshes

/// Triangles of an OBJ file (read with tobj).
fn obj_triangles(path: &Path) -> Vec<[Vector3<f64>; 3]> {
    let (models, _) = tobj::load_obj(
        path,
        &tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        },
    )
    .unwrap();
    let mut tris = Vec::new();
    for m in models {
        let p = &m.mesh.positions;
        let v = |i: u32| {
            let i = i as usize * 3;
            Vector3::new(p[i] as f64, p[i + 1] as f64, p[i + 2] as f64)
        };
        for f in m.mesh.indices.chunks(3) {
            tris.push([v(f[0]), v(f[1]), v(f[2])]);
        }
    }
    tris
}

/// Triangles of a GLB file (positions read from the binary chunk).
fn glb_triangles(path: &Path) -> Vec<[Vector3<f64>; 3]> {
    let bytes = std::fs::read(path).unwrap();
    let glb = gltf::binary::Glb::from_slice(&bytes).unwrap();
    let bin = glb.bin.unwrap();
    let doc = gltf::Gltf::from_slice(&bytes).unwrap();
    let mut tris = Vec::new();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let acc = prim.get(&gltf::Semantic::Positions).unwrap();
            let view = acc.view().unwrap();
            let start = view.offset() + acc.offset();
            let f = |i: usize| {
                let o = start + 4 * i;
                // The .glb is in metres (glTF's unit), the plan in mm.
                f32::from_le_bytes(bin[o..o + 4].try_into().unwrap()) as f64 * 1000.0
            };
            let verts: Vec<Vector3<f64>> = (0..acc.count())
                .map(|i| Vector3::new(f(3 * i), f(3 * i + 1), f(3 * i + 2)))
                .collect();
            for t in verts.chunks(3) {
                tris.push([t[0], t[1], t[2]]);
            }
        }
    }
    tris
}

/// Distance from a point to a triangle: to its plane when the foot lies
/// inside (barycentric), else to the nearest edge.
fn tri_distance(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> f64 {
    let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
    let area2 = n.norm();
    if area2 < 1e-12 {
        return f64::INFINITY;
    }
    let n = n / area2;
    let foot = p - n * n.dot(&(p - t[0]));
    let inside = (0..3).all(|i| {
        let (a, b) = (t[i], t[(i + 1) % 3]);
        (b - a).cross(&(foot - a)).dot(&n) >= -1e-12
    });
    if inside {
        return (p - foot).norm();
    }
    (0..3)
        .map(|i| {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let s = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
            (p - (a + (b - a) * s)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Whether a point is inside a closed triangle set (ray parity).
fn inside(p: &Vector3<f64>, tris: &[[Vector3<f64>; 3]]) -> bool {
    let d = Vector3::new(0.3127, 0.5531, 0.7723).normalize();
    let mut hits = 0;
    for t in tris {
        let e1 = t[1] - t[0];
        let e2 = t[2] - t[0];
        let h = d.cross(&e2);
        let a = e1.dot(&h);
        if a.abs() < 1e-14 {
            continue;
        }
        let s = p - t[0];
        let u = s.dot(&h) / a;
        let q = s.cross(&e1);
        let v = d.dot(&q) / a;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(&q) / a > 1e-9 {
            hits += 1;
        }
    }
    hits % 2 == 1
}

fn written(t: &MachiningPlan) -> (tempfile::TempDir, PathBuf) {
    let dir = tempdir();
    Plan::from(t.clone())
        .write(dir.path(), t.test.as_str(), &[])
        .unwrap();
    let p = dir.path().to_path_buf();
    (dir, p)
}

// ---------------------------------------------------------------- Show items

#[test]
fn stepped_square_on_bc_trunnion_has_seed_001s_twelve_poses() {
    let t = planned("bc-trunnion", "stepped-square", Dialect::Fanuc);
    let got: Vec<(String, u32, f64, f64)> = t
        .poses
        .iter()
        .map(|p| (p.id.clone(), p.seq, p.tilt, p.c))
        .collect();
    let mut expected = Vec::new();
    for b in [0.0, 90.0, -90.0] {
        for c in [0.0, 90.0, 180.0, 270.0] {
            expected.push((
                format!("B{}C{}", b as i32, c as i32),
                expected.len() as u32,
                b,
                c,
            ));
        }
    }
    assert_eq!(got, expected);
    // The reference step is the first pose and sits on top.
    assert_eq!(t.poses[0].tool_axis, Vector3::z());
    assert!(
        t.poses[0].feature.contains("reference"),
        "{}",
        t.poses[0].feature
    );
    // The B = +-90 poses cut the side faces.
    for p in &t.poses[4..] {
        assert!(
            p.tool_axis.z.abs() < 1e-12 && p.feature.contains("side step"),
            "{}",
            p.feature
        );
    }
    // Finishing with a zero radial cut: every pose repeats its finishing ring.
    for p in &t.poses {
        let fin = p.moves.iter().filter(|m| m.pass == Pass::Finish).count();
        let zero = p.moves.iter().filter(|m| m.pass == Pass::ZeroCut).count();
        assert!(
            fin >= 4 && zero == 4,
            "{}: {fin} finishing, {zero} zero-cut moves",
            p.id
        );
    }
}

#[test]
fn nine_section_on_ac_trunnion_has_nine_sections_with_section_1_at_zero() {
    let t = planned("ac-trunnion", "nine-section", Dialect::Fanuc);
    assert_eq!(t.poses.len(), 9);
    let ids: Vec<&str> = t.poses.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(ids, ["S1", "S2", "S3", "S4", "S5", "S6", "S7", "S8", "S9"]);
    assert_eq!((t.poses[0].tilt, t.poses[0].c), (0.0, 0.0));
    assert!(
        t.poses[0].feature.contains("cell centre"),
        "{}",
        t.poses[0].feature
    );
    // Section 8 at A = -30, C = 270 as in Cubas Brizuela & Yeh 2023.
    assert_eq!((t.poses[7].tilt, t.poses[7].c), (-30.0, 270.0));
    // All nine sections are cut to one nominal height, and each tool
    // leans away from the piece's centre.
    let z = t.points[0].point.p.z;
    for p in &t.points {
        assert!((p.point.p.z - z).abs() < 1e-12 && p.point.n == Vector3::z());
    }
    assert!(t.notes.is_empty(), "{:?}", t.notes);
    for p in &t.poses[1..] {
        let lean = Vector3::new(p.tool_axis.x, p.tool_axis.y, 0.0);
        let pts: Vec<_> = t.points.iter().filter(|q| q.point.pose == p.id).collect();
        let centre = pts[0].point.p;
        assert!(lean.dot(&centre) > 0.0, "{} leans towards the centre", p.id);
    }
}

/// A top-only stepped square with squares turned by 30 degrees.
fn turned_squares() -> MachiningPlan {
    let src = Template::builtin(Test::SteppedSquare).source().text.clone();
    let text = src
        .replace("tilt: auto ", "tilt: [0] ")
        .replace("c: [0, 90, 180, 270]", "c: [0, 30, 60]")
        .replace("first_size: 40 ", "first_size: 20 ")
        .replace("size_increment: 12 ", "size_increment: 15 ");
    let mut cfg = config(
        "bc-trunnion",
        "stepped-square",
        Dialect::Linuxcnc,
        KinematicsMode::Post,
    );
    cfg.template = Template::parse(Path::new("turned.yaml"), &text).unwrap();
    plan(&cfg).unwrap()
}

#[test]
fn every_point_lies_on_the_written_piece_with_its_normal_out_of_the_material() {
    let mut plans: Vec<MachiningPlan> = Vec::new();
    for m in MACHINES {
        for test in TESTS {
            plans.push(planned(m, test, Dialect::Linuxcnc));
        }
    }
    plans.push(turned_squares());
    for t in plans {
        let (m, test) = (t.machine.name.clone(), t.test);
        {
            let (_keep, dir) = written(&t);
            let pts = PlanPoints::read(&dir.join(format!("{test}.points.csv"))).unwrap();
            assert_eq!(pts.points.len(), t.points.len());
            for (name, tris) in [
                ("obj", obj_triangles(&dir.join(format!("{test}.obj")))),
                ("glb", glb_triangles(&dir.join(format!("{test}.glb")))),
            ] {
                for p in &pts.points {
                    let d = tris
                        .iter()
                        .map(|tr| tri_distance(&p.p, tr))
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        d < 1e-3,
                        "{m} {test} {name}: {} is {d} mm off the piece",
                        p.label
                    );
                    assert!(
                        inside(&(p.p - p.n * 0.01), &tris),
                        "{m} {test} {name}: no material under {}",
                        p.label
                    );
                    assert!(
                        !inside(&(p.p + p.n * 0.01), &tris),
                        "{m} {test} {name}: material above {}",
                        p.label
                    );
                }
            }
        }
    }
}

#[test]
fn each_stepped_square_pose_sees_three_normal_directions_and_all_six_components() {
    for m in MACHINES {
        let t = planned(m, "stepped-square", Dialect::Fanuc);
        for pose in &t.poses {
            let pts: Vec<_> = t
                .points
                .iter()
                .filter(|p| p.point.pose == pose.id)
                .collect();
            let normals = DMatrix::from_fn(pts.len(), 3, |i, j| pts[i].point.n[j]);
            let rank_n = normals.svd(false, false).rank(1e-9);
            assert_eq!(
                rank_n, 3,
                "{m} {}: normals span {rank_n} directions",
                pose.id
            );
            // Small rigid motion (d, w) moves a point along its normal by
            // n . (d + w x p): six columns n and p x n.
            // About the points' centroid, so that the conditioning does not
            // depend on where W's origin lies.
            let centroid = pts.iter().map(|p| p.point.p).sum::<Vector3<f64>>() / pts.len() as f64;
            let j = DMatrix::from_fn(pts.len(), 6, |i, k| {
                let (p, n) = (pts[i].point.p - centroid, pts[i].point.n);
                if k < 3 { n[k] } else { p.cross(&n)[k - 3] }
            });
            let sv = j.svd(false, false).singular_values;
            assert!(
                sv.min() > 1e-3 * sv.max(),
                "{m} {}: singular values {sv:?}",
                pose.id
            );
        }
    }
}

// ---------------------------------------------------------------- provenance

#[test]
fn every_point_knows_the_pose_moves_and_tool_part_that_made_it() {
    for m in MACHINES {
        for test in TESTS {
            let t = planned(m, test, Dialect::Fanuc);
            let labels: std::collections::HashSet<_> =
                t.points.iter().map(|p| &p.point.label).collect();
            assert_eq!(
                labels.len(),
                t.points.len(),
                "{m} {test}: labels not unique"
            );
            for p in &t.points {
                let pr = &p.provenance;
                let pose = &t.poses[pr.pose];
                assert_eq!(pose.id, p.point.pose);
                assert!(!pr.generators.is_empty());
                let expected = if test == "stepped-square" {
                    if p.surface == "floor" {
                        ToolPart::FlatEnd
                    } else {
                        ToolPart::Flank
                    }
                } else if t.tool.kind == fivecal::machine::ToolKind::Ball {
                    ToolPart::Ball
                } else if pose.tool_axis == Vector3::z() {
                    ToolPart::FlatEnd
                } else {
                    ToolPart::Torus
                };
                assert_eq!(pr.part, expected, "{m} {test} {}", p.point.label);
                let k = Kinematics::with_gauge_length(&t.machine, t.tool.length);
                for g in &pr.generators {
                    // The generator is on its move, the tool touches the point there,
                    // and the axis values give that tool pose through the kinematics.
                    let mv = &pose.moves[g.move_index];
                    assert!(!mv.rapid);
                    assert!((0.0..=1.0).contains(&g.t));
                    let d = t.cutter.signed_distance(&g.tip, &g.axis, &p.point.p);
                    assert!(
                        d.abs() < 1e-6,
                        "{m} {test} {}: tool {d} mm from the point",
                        p.point.label
                    );
                    let f = k.forward_nominal(&g.axes);
                    assert!((f.tip - g.tip).norm() < 1e-9 && (f.axis - g.axis).norm() < 1e-12);
                }
                // The last touch is a finishing pass (or the zero cut).
                let last = pr.generators.last().unwrap();
                assert!(
                    matches!(last.pass, Pass::Finish | Pass::ZeroCut),
                    "{:?}",
                    last.pass
                );
            }
        }
    }
}

/// What the simulator does with the provenance: an erroneous machine moves
/// the generating segments, and the surface along the nominal normal is
/// where the actual sweep first meets it. A pure X offset of the B axis
/// (dx_BY) at B = 0 shifts the walls facing X by exactly -dx and leaves the
/// floors alone (rTw = Dx(dx) ..., so wq = rTw^-1 rTw* wq*).
#[test]
fn provenance_gives_the_simulator_the_exact_surface_of_an_erroneous_machine() {
    let t = planned("bc-trunnion", "stepped-square", Dialect::Fanuc);
    let k = Kinematics::with_gauge_length(&t.machine, t.tool.length);
    let mut p_err = fivecal::Perturbation::zero();
    let dx = 0.012;
    p_err.0[0] = dx;
    let mut checked = 0;
    for p in t.points.iter().filter(|p| p.point.pose == "B0C0") {
        let pose = &t.poses[p.provenance.pose];
        let mut s_min = f64::INFINITY;
        for g in &p.provenance.generators {
            let (a, b) = pose.segment(g.move_index);
            let (fa, fb) = (k.forward(&a, &p_err), k.forward(&b, &p_err));
            let s = t
                .cutter
                .entry_along(
                    &fa.tip,
                    &fb.tip,
                    &fa.axis,
                    &(p.point.p - p.point.n),
                    &p.point.n,
                    0.0,
                    2.0,
                )
                .unwrap();
            s_min = s_min.min(s - 1.0);
        }
        let expected = -dx * p.point.n.x;
        assert!(
            (s_min - expected).abs() < 1e-9,
            "{}: surface moved {s_min}, expected {expected}",
            p.point.label
        );
        checked += 1;
    }
    assert_eq!(checked, 12);
}

// ---------------------------------------------------------------- manifest

#[test]
fn load_rebuilds_the_plan_exactly_from_its_manifest() {
    for (m, test, dialect, mode) in [
        (
            "bc-trunnion",
            "stepped-square",
            Dialect::Fanuc,
            KinematicsMode::Post,
        ),
        (
            "head-table",
            "nine-section",
            Dialect::Heidenhain,
            KinematicsMode::Controller,
        ),
    ] {
        let t = plan(&config(m, test, dialect, mode)).unwrap();
        let (_keep, dir) = written(&t);
        let man_path = dir.join(format!("{test}.plan.yaml"));
        let man = Manifest::read(&man_path).unwrap();
        assert_eq!(man.test, test);
        assert_eq!(
            man.machine_file,
            PathBuf::from(format!("{test}.machine.yaml"))
        );
        for role in [
            "program",
            "points",
            "dmis",
            "qif",
            "glb",
            "obj",
            "setup",
            "postprocessor",
        ] {
            assert!(man.file(&man_path, role).unwrap().exists(), "{role}");
        }
        let back = load(&man_path).unwrap();
        let back = back.machining().unwrap();
        assert_eq!(back.poses, t.poses);
        assert_eq!(back.points, t.points);
        assert_eq!(back.toolpath, t.toolpath);
        assert_eq!(back.program, t.program);
        assert_eq!(back.piece, t.piece);
        assert_eq!(back.tool, t.tool);
        assert_eq!(back.kinematics, mode);
    }
}

#[test]
fn templates_postprocessors_and_tools_given_by_path_round_trip() {
    let dir = tempdir();
    let tpl = dir.path().join("my-square.yaml");
    let src = Template::builtin(Test::SteppedSquare).source().text.clone();
    std::fs::write(&tpl, src.replace("first_size: 40 ", "first_size: 36 ")).unwrap();
    let post = dir.path().join("my-fanuc.yaml");
    let psrc = PostDefinition::builtin(Dialect::Fanuc).source;
    std::fs::write(
        &post,
        psrc.replace("start: 10, step: 10", "start: 5, step: 5"),
    )
    .unwrap();
    let out = dir.path().join("plan");
    fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--template",
        ])
        .arg(&tpl)
        .arg("--postprocessor")
        .arg(&post)
        .args([
            "--tool",
            "{name: D8 long end mill, kind: flat, diameter: 8, length: 70, number: 4}",
            "--out",
        ])
        .arg(&out)
        .assert()
        .success();
    let program = std::fs::read_to_string(out.join("stepped-square.nc")).unwrap();
    assert!(
        program.contains("\nN5 G90") && program.contains("T4 M6"),
        "{}",
        &program[..600]
    );
    let back = load(&out.join("stepped-square.plan.yaml")).unwrap();
    let back = back.machining().unwrap();
    assert_eq!(back.program.text, program);
    assert_eq!((back.tool.length, back.tool.number), (70.0, 4));
    assert!(
        back.poses[0].feature.contains("36 x 36"),
        "{}",
        back.poses[0].feature
    );
}

#[test]
fn load_refuses_a_plan_whose_copies_were_edited() {
    let t = planned("bc-trunnion", "stepped-square", Dialect::Fanuc);
    let (_keep, dir) = written(&t);
    let tpl = dir.join("stepped-square.template.yaml");
    let src = std::fs::read_to_string(&tpl).unwrap();
    std::fs::write(
        &tpl,
        src.replace("c: [0, 90, 180, 270]", "c: [0, 180, 90, 270]"),
    )
    .unwrap();
    let e = load(&dir.join("stepped-square.plan.yaml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("differs from the manifest") && e.contains("pose B0C180"),
        "{e}"
    );
}

#[test]
fn outputs_are_deterministic() {
    let a = planned("ac-trunnion", "stepped-square", Dialect::Heidenhain);
    let b = planned("ac-trunnion", "stepped-square", Dialect::Heidenhain);
    let (a, b) = (Plan::from(a), Plan::from(b));
    assert_eq!(a.outputs("x"), b.outputs("x"));
    for (name, bytes) in a.outputs("x") {
        let text = String::from_utf8_lossy(&bytes);
        assert!(
            !text.contains("2026") && !text.contains("2025"),
            "{} holds a date",
            name.display()
        );
    }
}

#[test]
fn poses_carry_their_moves_and_time_estimate() {
    let t = planned("bc-trunnion", "stepped-square", Dialect::Fanuc);
    let k = Kinematics::with_gauge_length(&t.machine, t.tool.length);
    let mut last_end = 0.0;
    for p in &t.poses {
        assert!(
            p.start_min >= last_end - 1e-12 && p.end_min > p.start_min,
            "{}",
            p.id
        );
        last_end = p.end_min;
        // Every move's tip is where the nominal machine puts the tool.
        for mv in &p.moves {
            let f = k.forward_nominal(&mv.axes);
            assert!((f.tip - mv.tip).norm() < 1e-9 && (f.axis - p.tool_axis).norm() < 1e-12);
            assert_eq!((mv.axes.tilt, mv.axes.c), (p.tilt, p.c));
        }
        // It ends at the safe height.
        assert_eq!(p.moves.last().unwrap().axes.xyz.z, t.safe_z);
    }
    assert!((last_end - t.run_minutes).abs() < 1e-9);
    assert!(
        t.run_minutes > 10.0 && t.run_minutes < 120.0,
        "{}",
        t.run_minutes
    );
}

#[test]
fn controller_mode_writes_plane_coordinates_that_map_back_to_w() {
    let t = plan(&config(
        "bc-trunnion",
        "stepped-square",
        Dialect::Fanuc,
        KinematicsMode::Controller,
    ))
    .unwrap();
    for p in &t.poses {
        let n = p.moves.len();
        for mv in &p.moves[..n - 1] {
            assert!((p.frame * mv.program - mv.tip).norm() < 1e-9);
        }
    }
    assert!(
        t.program.text.contains("G68.2")
            && t.program.text.contains("G53.1")
            && t.program.text.contains("G69")
    );
}

// ---------------------------------------------------------------- errors

fn plan_err(cfg: &PlanConfig) -> String {
    match plan(cfg) {
        Ok(_) => panic!("planned"),
        Err(e) => e.to_string(),
    }
}

fn with_template(test: &str, from: &str, to: &str) -> PlanConfig {
    let src = Template::builtin(test.parse().unwrap())
        .source()
        .text
        .clone();
    assert!(src.contains(from), "{from}");
    let text = src.replace(from, to);
    let mut cfg = config("bc-trunnion", test, Dialect::Fanuc, KinematicsMode::Post);
    cfg.template = Template::parse(Path::new("t.yaml"), &text).unwrap();
    cfg
}

#[test]
fn an_angle_outside_the_limits_names_the_value_and_the_limit() {
    let e = plan_err(&with_template(
        "stepped-square",
        "tilt: auto",
        "tilt: [0, 120]",
    ));
    assert!(
        e.starts_with("t.yaml:")
            && e.contains("B = 120 is outside the limits [-90, 90] of machine bc-trunnion"),
        "{e}"
    );
    let e = plan_err(&with_template(
        "nine-section",
        "{tilt: -30, c: 270}",
        "{tilt: -100, c: 270}",
    ));
    assert!(
        e.contains("section 8: B = -100 is outside the limits [-90, 90]"),
        "{e}"
    );
}

#[test]
fn a_tool_longer_than_the_clearance_names_its_length_and_the_clearance() {
    let mut cfg = config(
        "bc-trunnion",
        "stepped-square",
        Dialect::Fanuc,
        KinematicsMode::Post,
    );
    let mut tool = Template::builtin(Test::SteppedSquare);
    let _ = &mut tool;
    cfg.tool = Some(fivecal::machine::Tool {
        name: "long".into(),
        kind: fivecal::machine::ToolKind::Flat,
        diameter: 8.0,
        length: 300.0,
        corner_radius: None,
        flutes: None,
        number: 1,
        id: None,
    });
    let e = plan_err(&cfg);
    assert!(
        e.contains(
            "tool length 300 mm is longer than the clearance of 275 mm between the safe height Z145"
        ),
        "{e}"
    );
}

#[test]
fn bad_templates_fail_at_the_offending_key() {
    for (test, from, to, expect) in [
        (
            "stepped-square",
            "size_increment: 12 ",
            "size_increment: 20 ",
            "top.size_increment 20 mm leaves a floor band of 10 mm next to each wall, wider than the finishing pass of the D8 tool covers (7.5 mm): at most 15 mm",
        ),
        (
            "stepped-square",
            "height: 70",
            "height: 40",
            "stock.height 40 mm is too low",
        ),
        (
            "stepped-square",
            "stepover: 0.5 ",
            "stepover: 0.9 ",
            "and at most 0.8",
        ),
        (
            "stepped-square",
            "kind: flat",
            "kind: ball",
            "needs a straight (flat) end mill",
        ),
        (
            "nine-section",
            "kind: ball",
            "kind: flat",
            "needs a ball or bull-nose end mill",
        ),
        (
            "stepped-square",
            "c: [0, 90, 180, 270]",
            "c: [0, 45]",
            "normal to no face of the block",
        ),
    ] {
        let src = Template::builtin(test.parse().unwrap())
            .source()
            .text
            .clone();
        assert!(src.contains(from), "{from}");
        let text = src.replace(from, to);
        let line = text.lines().position(|l| l.contains(to.trim())).unwrap() + 1;
        let e = match Template::parse(Path::new("t.yaml"), &text) {
            Err(e) => e.to_string(),
            Ok(tpl) => {
                let mut cfg = config("bc-trunnion", test, Dialect::Fanuc, KinematicsMode::Post);
                cfg.template = tpl;
                plan_err(&cfg)
            }
        };
        assert!(e.contains(expect), "{e}");
        if !expect.contains("normal to no face") && !expect.contains("too low") {
            assert!(
                e.starts_with(&format!("t.yaml:{line}:")),
                "{e} (expected line {line})"
            );
        }
    }
    let e = Template::parse(
        Path::new("t.yaml"),
        "test: stepped-square\nstock: {size: 1, hieght: 2}\n",
    )
    .unwrap_err();
    assert!(
        e.to_string().starts_with("t.yaml:2:") && e.to_string().contains("hieght"),
        "{e}"
    );
}

#[test]
fn linuxcnc_has_no_controller_kinematics() {
    let e = plan_err(&config(
        "bc-trunnion",
        "stepped-square",
        Dialect::Linuxcnc,
        KinematicsMode::Controller,
    ));
    assert!(e.contains("use --kinematics post"), "{e}");
}

#[test]
fn machines_that_cannot_tilt_to_90_get_one_step_per_side_face() {
    for m in ["ac-trunnion", "head-table"] {
        let t = planned(m, "stepped-square", Dialect::Fanuc);
        assert_eq!(t.poses.len(), 8, "{m}");
        assert!(
            t.notes.iter().any(|n| n.contains("90 is left out")),
            "{m}: {:?}",
            t.notes
        );
    }
}

#[test]
fn plan_errors_are_typed() {
    let mut cfg = config(
        "bc-trunnion",
        "stepped-square",
        Dialect::Fanuc,
        KinematicsMode::Post,
    );
    cfg.machine = Machine::from_yaml(
        Path::new("m.yaml"),
        &machine("bc-trunnion")
            .source
            .replace("X: [-365, 365]", "X: [-60, 60]"),
    )
    .unwrap();
    match plan(&cfg) {
        Err(PlanError::Stroke { axis, lo, hi, .. }) => {
            assert_eq!((axis, lo, hi), ('X', -60.0, 60.0))
        }
        other => panic!("{other:?}"),
    }
}

// ---------------------------------------------------------------- CLI

/// No silent default machine: a plan is for the machine the user names.
/// Without `--machine` nothing is written and the message lists the
/// built-in machines and how to start one's own file.
#[test]
fn plan_without_a_machine_is_refused_and_writes_nothing() {
    let dir = tempdir();
    let err = fivecal()
        .current_dir(dir.path())
        .args(["plan", "stepped-square"])
        .assert()
        .failure()
        .get_output()
        .stderr
        .clone();
    let err = String::from_utf8_lossy(&err);
    assert!(err.contains("--machine"), "{err}");
    assert!(
        err.contains("head-table") && err.contains("machine new"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Without `--out`, the plan's files land in a directory named after the
/// test, never loose in the current directory.
#[test]
fn plan_without_out_writes_into_a_directory_named_after_the_test() {
    let dir = tempdir();
    fivecal()
        .current_dir(dir.path())
        .args(["plan", "probe-columns", "--machine", "ac-trunnion"])
        .assert()
        .success();
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["probe-columns"]);
    assert!(
        dir.path()
            .join("probe-columns/probe-columns.plan.yaml")
            .exists()
    );
}

#[test]
fn cli_writes_every_output_and_reports_bad_input_with_a_position() {
    let dir = tempdir();
    let out = fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
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
        text.contains("stepped-square on bc-trunnion: 12 poses, 144 points"),
        "{text}"
    );
    for f in [
        "stepped-square.nc",
        "stepped-square.points.csv",
        "stepped-square.plan.yaml",
        "stepped-square.dmi",
        "stepped-square.qif",
        "stepped-square.glb",
        "stepped-square.obj",
        "stepped-square.md",
        "stepped-square.machine.yaml",
        "stepped-square.template.yaml",
    ] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    let sheet = std::fs::read_to_string(dir.path().join("stepped-square.md")).unwrap();
    for s in [
        "Stock and fixturing",
        "T1: D8",
        "Zero point",
        "Estimated run time",
        "| 11 | B-90C270 |",
    ] {
        assert!(sheet.contains(s), "{s} missing in\n{sheet}");
    }
    let dmi = std::fs::read_to_string(dir.path().join("stepped-square.dmi")).unwrap();
    assert_eq!(dmi.matches("MEAS/POINT").count(), 144);

    let bad = dir.path().join("bad.yaml");
    let src = Template::builtin(Test::SteppedSquare).source().text.clone();
    std::fs::write(&bad, src.replace("tilt: auto", "tilt: [0, 95]")).unwrap();
    let err = fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--template",
        ])
        .arg(&bad)
        .arg("--out")
        .arg(dir.path())
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    let err = String::from_utf8(err).unwrap();
    assert!(
        err.contains("bad.yaml:") && err.contains("B = 95 is outside the limits [-90, 90]"),
        "{err}"
    );

    // An output never overwrites an input.
    let mpath = dir.path().join("stepped-square.machine.yaml");
    let err = fivecal()
        .args(["plan", "stepped-square", "--machine"])
        .arg(&mpath)
        .arg("--out")
        .arg(dir.path())
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    assert!(
        String::from_utf8(err)
            .unwrap()
            .contains("refusing to overwrite input file")
    );
}

#[test]
fn the_cmm_program_reaches_every_point_through_free_space() {
    for m in ["bc-trunnion", "head-head"] {
        for test in TESTS {
            let t = planned(m, test, Dialect::Fanuc);
            let dmi = t.dmis_program(test);
            // Per point: up, free, start of the probing move.
            let gotos: Vec<Vector3<f64>> = dmi
                .lines()
                .filter_map(|l| l.strip_prefix("GOTO/CART,"))
                .map(|v| {
                    let f: Vec<f64> = v.split(',').map(|x| x.parse().unwrap()).collect();
                    Vector3::new(f[0], f[1], f[2])
                })
                .collect();
            assert_eq!(gotos.len(), 5 * t.points.len());
            for (i, p) in t.points.iter().enumerate() {
                let g = &gotos[5 * i..5 * i + 3];
                assert!((g[2] - (p.point.p + p.point.n * 5.0)).norm() < 1e-6);
                for w in g.windows(2) {
                    let n = ((w[1] - w[0]).norm() / 0.25).ceil() as usize;
                    for k in 0..=n {
                        let q = w[0] + (w[1] - w[0]) * (k as f64 / n.max(1) as f64);
                        assert!(
                            !t.piece.solid.contains(&q),
                            "{m} {test} {}: the probe passes through the piece at {q:?}",
                            p.point.label
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn tcp_definitions_write_work_frame_coordinates() {
    for (d, on, off) in [
        (Dialect::Fanuc, "G43.4 H1", "G43 H1"),
        (
            Dialect::Heidenhain,
            "FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS",
            "FUNCTION RESET TCPM",
        ),
    ] {
        let mut cfg = config(
            "bc-trunnion",
            "stepped-square",
            d,
            KinematicsMode::Controller,
        );
        let src = cfg
            .post
            .source
            .replace("controller: tilted_plane", "controller: tcp");
        cfg.post = PostDefinition::parse(Path::new("tcp.yaml"), &src).unwrap();
        let t = plan(&cfg).unwrap();
        assert_eq!(t.program.text.matches(on).count(), 12, "{d}");
        assert!(t.program.text.contains(off));
        for p in &t.poses {
            let n = p.moves.len();
            for mv in &p.moves[..n - 1] {
                assert_eq!(mv.program, mv.tip);
            }
        }
    }
}

#[test]
fn a_bull_nose_cuts_the_nine_sections_with_its_flat_end_and_its_torus() {
    let mut cfg = config(
        "head-table",
        "nine-section",
        Dialect::Heidenhain,
        KinematicsMode::Post,
    );
    cfg.tool = Some(machine("head-table").tool);
    let t = plan(&cfg).unwrap();
    assert_eq!(t.tool.kind, fivecal::machine::ToolKind::Bull);
    for p in &t.points {
        let pose = &t.poses[p.provenance.pose];
        let expected = if pose.tool_axis == Vector3::z() {
            ToolPart::FlatEnd
        } else {
            ToolPart::Torus
        };
        assert_eq!(p.provenance.part, expected, "{}", p.point.label);
    }
}

/// The stepped-square poses a table-table machine gets, relative to the
/// reference pose, identify its eight location errors (docs/model.md),
/// also where tilt +90 is out of reach (ac-trunnion: A = 0, -90 only).
#[test]
fn the_stepped_square_poses_identify_eight_location_terms_on_both_trunnions() {
    for m in ["bc-trunnion", "ac-trunnion"] {
        let t = planned(m, "stepped-square", Dialect::Fanuc);
        let k = Kinematics::with_gauge_length(&t.machine, t.tool.length);
        let jac = |tilt: f64, c: f64, q: &Vector3<f64>| {
            let commanded = k.nominal_table_transform(tilt, c) * nalgebra::Point3::from(*q);
            let a = fivecal::Axes {
                xyz: commanded.coords,
                tilt,
                c,
            };
            k.jacobian(&a, &fivecal::Perturbation::zero())
                .tip
                .columns(5, 12)
                .into_owned()
        };
        let mut rows = Vec::new();
        for pose in &t.poses {
            for p in t.points.iter().filter(|p| p.point.pose == pose.id) {
                let d = jac(pose.tilt, pose.c, &p.point.p) - jac(0.0, 0.0, &p.point.p);
                rows.push((p.point.n.transpose() * d).into_owned());
            }
        }
        let j = DMatrix::from_rows(&rows);
        let sv = j.svd(false, false).singular_values;
        let rank = sv.iter().filter(|&&s| s > 1e-9 * sv.max()).count();
        assert_eq!(
            rank,
            8,
            "{m}: {} poses see {rank} of the twelve constant terms",
            t.poses.len()
        );
    }
}
