//! Writes the sample data of `examples/analyze/`: two plan directories made
//! by the planners, each with a measured file made from the foundation model
//! with known errors (until the simulator exists), so `analyze` can be
//! tried on files shaped exactly as real ones:
//!
//! - `stepped-square/`: `fivecal plan stepped-square` on `bc-trunnion`
//!   (FANUC), the piece machined with the eight location errors and a
//!   B-axis map set, measured on a CMM as DMIS output (0.35 um noise, the
//!   piece 800 mm away and turned);
//! - `probe-sphere/`: the calibration-sphere test of the probing planner on
//!   `ac-trunnion` (seed 004: 36 C and 13 A positions), probed with the
//!   eight location errors set, as the FANUC program logs it (ball centres,
//!   DPRNT).
//!
//! Run `cargo run --release --example synthetic_measurements [DIR]`; the
//! truth is in `truth.yaml` beside each plan.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use fivecal::errorfile::{ErrorFile, Noise};
use fivecal::formats::dmis::{self, DmisPoint, WriteOptions};
use fivecal::formats::manifest::{KinematicsMode, Manifest, PoseEntry, TestKind};
use fivecal::formats::probe_log::fanuc;
use fivecal::identify::synthetic;
use fivecal::kinematics::maps::{MapDim, MapGrid};
use fivecal::model::{Effect, Model};
use fivecal::plan::{PlanConfig, Template};
use fivecal::post::PostDefinition;
use fivecal::probing::template::{BUILTIN_SPHERE, SphereTemplate};
use fivecal::{Dialect, Kinematics, Machine};
use nalgebra::{Isometry3, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/analyze"));
    let mut rng = StdRng::seed_from_u64(2014);

    // Stepped square on bc-trunnion, as `fivecal plan` writes it.
    let m = Machine::builtin("bc-trunnion").unwrap();
    let cfg = PlanConfig {
        machine: m.clone(),
        template: Template::builtin("stepped-square").unwrap(),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    };
    let planned = fivecal::plan::plan(&cfg)?;
    let dir = out.join("stepped-square");
    std::fs::create_dir_all(&dir)?;
    planned.write(&dir, "stepped-square", &[])?;
    let plan = planned.plan_points();
    let k = Kinematics::new(&m);
    let sym = Model::new(k.clone(), vec![]).symbols;
    let model = Model::new(
        k.clone(),
        vec![
            Effect::Location {
                symbols: (0..8).collect(),
            },
            Effect::Map {
                symbol: sym.map_index("EBB(B)")?,
                grid: MapGrid {
                    dims: vec![MapDim::new(0, &[-90.0, 0.0, 90.0], false)?],
                },
            },
        ],
    );
    let theta = [
        12.0, -40.0, 80.0, -60.0, 150.0, 25.0, -18.0, 45.0, 32.0, -10.0, -22.0,
    ];
    let placement = Isometry3::new(
        Vector3::new(650.0, 420.0, -180.0),
        Vector3::new(0.2, -0.1, 2.4),
    );
    let pts = synthetic::machined(
        &model,
        &theta,
        &plan,
        &HashMap::new(),
        0.35,
        &placement,
        &mut rng,
    );
    // The CMM reports in its own alignment of the piece.
    let dp: Vec<DmisPoint> = pts
        .iter()
        .zip(&plan.points)
        .map(|(q, p)| DmisPoint {
            label: q.label.clone(),
            nominal: (
                (placement * nalgebra::Point3::from(p.p)).coords,
                placement.rotation * p.n,
            ),
            actual: q.p,
        })
        .collect();
    let opts = WriteOptions {
        name: "stepped-square piece 1".into(),
        ..Default::default()
    };
    std::fs::write(dir.join("piece1.dmo"), dmis::write_output(&dp, &opts))?;
    let u = vec![None; theta.len()];
    let truth = ErrorFile::from_model(
        &model,
        &theta,
        &u,
        &Noise {
            cmm: Some(0.35),
            probe: None,
        },
    );
    std::fs::write(dir.join("truth.yaml"), truth.to_yaml())?;

    // Calibration sphere on ac-trunnion, as the probing planner plans it.
    let m = Machine::builtin("ac-trunnion").unwrap();
    let t = SphereTemplate::builtin();
    let pplan = fivecal::probing::sphere::plan(&m, &t)?;
    let plan = pplan.points();
    let k = &pplan.kin;
    let centre = fivecal::probing::sphere::sphere_centre(&m, &t);
    let model = Model::new(
        k.clone(),
        vec![Effect::Location {
            symbols: (0..8).collect(),
        }],
    );
    let theta = [15.0, -30.0, 60.0, -90.0, 120.0, 20.0, -25.0, 40.0];
    let dir = out.join("probe-sphere");
    std::fs::create_dir_all(&dir)?;
    std::fs::write(
        dir.join("probe-sphere.machine.yaml"),
        std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/machines/ac-trunnion.yaml"),
        )?,
    )?;
    std::fs::write(dir.join("probe-sphere.template.yaml"), BUILTIN_SPHERE)?;
    std::fs::write(
        dir.join("probe-sphere.points.csv"),
        plan.to_csv(&[
            "probe-sphere on ac-trunnion (fivecal::probing::sphere::plan): contact points in W, mm",
        ]),
    )?;
    let mut poses: Vec<PoseEntry> = Vec::new();
    for p in &plan.points {
        if !poses.iter().any(|q| q.pose == p.pose) {
            poses.push(PoseEntry {
                pose: p.pose.clone(),
                seq: p.seq,
                tilt: p.tilt,
                c: p.c,
                start_min: 0.5 * p.seq as f64,
                end_min: 0.5 * p.seq as f64 + 0.4,
            });
        }
    }
    let manifest = Manifest {
        fivecal_plan: 1,
        test: "probe-sphere".into(),
        kind: TestKind::Probing,
        machine: m.name.clone(),
        machine_file: "probe-sphere.machine.yaml".into(),
        template_file: "probe-sphere.template.yaml".into(),
        dialect: Dialect::Fanuc,
        kinematics: KinematicsMode::Post,
        tool: None,
        probe: Some(m.probe.clone()),
        files: [(
            "points".to_string(),
            PathBuf::from("probe-sphere.points.csv"),
        )]
        .into_iter()
        .collect(),
        poses,
    };
    std::fs::write(dir.join("probe-sphere.plan.yaml"), manifest.to_yaml())?;
    let contacts = synthetic::probed_sphere(
        &model,
        &theta,
        &plan,
        &centre,
        t.diameter / 2.0,
        0.35,
        &mut rng,
    );
    // The controller logs the ball centre: the contact point plus the ball
    // radius along the touch's normal in program coordinates.
    let ball = m.probe.ball_diameter / 2.0;
    let mut log = String::from("%\nFIVECAL PROBE-SPHERE\n");
    for (i, (c, p)) in contacts.iter().zip(&plan.points).enumerate() {
        let n = k.nominal_table_transform(p.tilt, p.c).rotation * p.n;
        log += &(fanuc::touch_line(i + 1, &(c.p + n * ball), fanuc::Prt::Spaces) + "\n");
    }
    log += "%\n";
    std::fs::write(dir.join("PROBE.TXT"), log)?;
    let truth = ErrorFile::from_model(
        &model,
        &theta,
        &[None; 8],
        &Noise {
            cmm: None,
            probe: Some(0.35),
        },
    );
    std::fs::write(dir.join("truth.yaml"), truth.to_yaml())?;
    println!("wrote {}", out.display());
    Ok(())
}
