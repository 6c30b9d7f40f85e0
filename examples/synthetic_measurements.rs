//! Writes the synthetic sample data of `examples/analyze/`: two plan
//! directories shaped as `fivecal plan` writes them, each with a measured
//! file made from the foundation model with known errors, so `analyze` can
//! be tried before the planner and the simulator exist.
//!
//! - `stepped-square/`: a stepped-square-like piece (12 cuts, B = -90, 0, 90
//!   x C = 0, 90, 180, 270) machined on `bc-trunnion` with the eight
//!   location errors and a B-axis map set, measured on a CMM (DMIS output,
//!   0.35 um noise, the piece 800 mm away and turned);
//! - `probe-sphere/`: a 30 mm calibration sphere probed on `ac-trunnion` at
//!   36 C and 13 A positions (seed 004), contact points as CSV.
//!
//! Run `cargo run --release --example synthetic_measurements [DIR]`; the
//! truth is in `truth.yaml` beside each plan.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use fivecal::errorfile::{ErrorFile, Noise};
use fivecal::formats::dmis::{self, DmisPoint, WriteOptions};
use fivecal::formats::manifest::{KinematicsMode, Manifest, PoseEntry, TestKind};
use fivecal::formats::measured;
use fivecal::formats::points::PlanPoints;
use fivecal::identify::synthetic;
use fivecal::kinematics::maps::{MapDim, MapGrid};
use fivecal::model::{Effect, Model};
use fivecal::{Dialect, Kinematics, Machine};
use nalgebra::{Isometry3, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;

fn write_plan(
    dir: &Path,
    test: &str,
    kind: TestKind,
    m: &Machine,
    plan: &PlanPoints,
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let src = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("examples/machines/{}.yaml", m.name)),
    )?;
    std::fs::write(dir.join(format!("{test}.machine.yaml")), src)?;
    std::fs::write(
        dir.join(format!("{test}.template.yaml")),
        "# synthetic sample: the point set comes from fivecal::identify::synthetic\n",
    )?;
    std::fs::write(
        dir.join(format!("{test}.points.csv")),
        plan.to_csv(&[&format!("{test} on {} (synthetic sample)", m.name)]),
    )?;
    let mut poses: Vec<PoseEntry> = Vec::new();
    for p in &plan.points {
        if !poses.iter().any(|q| q.pose == p.pose) {
            poses.push(PoseEntry {
                pose: p.pose.clone(),
                seq: p.seq,
                tilt: p.tilt,
                c: p.c,
                start_min: 3.0 * p.seq as f64,
                end_min: 3.0 * p.seq as f64 + 2.5,
            });
        }
    }
    let manifest = Manifest {
        fivecal_plan: 1,
        test: test.into(),
        kind,
        machine: m.name.clone(),
        machine_file: format!("{test}.machine.yaml").into(),
        template_file: format!("{test}.template.yaml").into(),
        dialect: Dialect::Fanuc,
        kinematics: KinematicsMode::Post,
        tool: (kind == TestKind::Machining).then(|| m.tool.clone()),
        probe: (kind == TestKind::Probing).then(|| m.probe.clone()),
        files: [(
            "points".to_string(),
            PathBuf::from(format!("{test}.points.csv")),
        )]
        .into_iter()
        .collect(),
        poses,
    };
    std::fs::write(dir.join(format!("{test}.plan.yaml")), manifest.to_yaml())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/analyze"));
    let mut rng = StdRng::seed_from_u64(2014);

    // Stepped square on bc-trunnion.
    let m = Machine::builtin("bc-trunnion").unwrap();
    let k = Kinematics::new(&m);
    let plan = synthetic::stepped_square(&k, &[-90.0, 0.0, 90.0], &[0.0, 90.0, 180.0, 270.0], 15.0);
    let sym = Model::new(k.clone(), vec![]).symbols;
    let ebb = sym.map_index("EBB(B)")?;
    let model = Model::new(
        k.clone(),
        vec![
            Effect::Location {
                symbols: (0..8).collect(),
            },
            Effect::Map {
                symbol: ebb,
                grid: MapGrid {
                    dims: vec![MapDim::new(0, &[-90.0, 0.0, 90.0], false)?],
                },
            },
        ],
    );
    let theta = [
        12.0, -40.0, 80.0, -60.0, 150.0, 25.0, -18.0, 45.0, 32.0, -10.0, -22.0,
    ];
    let dir = out.join("stepped-square");
    write_plan(&dir, "stepped-square", TestKind::Machining, &m, &plan)?;
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

    // Calibration sphere on ac-trunnion.
    let m = Machine::builtin("ac-trunnion").unwrap();
    let k = Kinematics::with_gauge_length(&m, m.probe.length);
    let mut poses: Vec<(f64, f64)> = (0..36).map(|i| (0.0, 10.0 * i as f64)).collect();
    poses.extend(
        (0..13)
            .map(|i| (-90.0 + 10.0 * i as f64, 0.0))
            .filter(|p| p.0 != 0.0),
    );
    let centre = Vector3::new(120.0, -40.0, 60.0);
    let plan = synthetic::sphere_plan(&k, &centre, 15.0, &poses);
    let model = Model::new(
        k.clone(),
        vec![Effect::Location {
            symbols: (0..8).collect(),
        }],
    );
    let theta = [15.0, -30.0, 60.0, -90.0, 120.0, 20.0, -25.0, 40.0];
    let dir = out.join("probe-sphere");
    write_plan(&dir, "probe-sphere", TestKind::Probing, &m, &plan)?;
    let pts = synthetic::probed_sphere(&model, &theta, &plan, &centre, 15.0, 0.35, &mut rng);
    std::fs::write(
        dir.join("sphere.csv"),
        measured::to_csv(
            &pts,
            &["contact points in W at rotary zero (synthetic sample)"],
        ),
    )?;
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
