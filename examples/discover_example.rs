//! Writes the worked example of `examples/discover/`: the stepped-square
//! test of seed 001 planned for `bc-trunnion` (FANUC), a piece machined on
//! a machine with the eight location errors and two effects a location
//! calibration does not know (EZ0B drifting 1.2 um per cut as the machine
//! warms up, and a B-axis angular positioning error EBB(B) of up to 60
//! urad), measured on a CMM as DMIS output (0.35 um of noise, the piece 800
//! mm away and turned), and the story `fivecal discover` tells about it.
//!
//! The piece is machined with the foundation's exact model
//! (`identify::synthetic`) until the simulator's `simulate::run` is on
//! main. Run `cargo run --release --example discover_example [DIR]`; the
//! truth is in `truth.yaml`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use fivecal::discover::{self, DiscoverOptions, Inputs};
use fivecal::errorfile::{ErrorFile, Noise};
use fivecal::formats::dmis::{self, DmisPoint, WriteOptions};
use fivecal::formats::manifest::KinematicsMode;
use fivecal::identify::synthetic;
use fivecal::kinematics::maps::{MapDim, MapGrid};
use fivecal::model::{DriftBasis, Effect, Model};
use fivecal::plan::{PlanConfig, Template};
use fivecal::post::PostDefinition;
use fivecal::{Dialect, Kinematics, Machine};
use nalgebra::{Isometry3, Point3, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/discover"));
    std::fs::create_dir_all(&dir)?;
    let mut rng = StdRng::seed_from_u64(2026);

    // The plan, as `fivecal plan stepped-square --machine bc-trunnion` writes it.
    let m = Machine::builtin("bc-trunnion").unwrap();
    let planned = fivecal::plan::plan(&PlanConfig {
        machine: m.clone(),
        template: Template::builtin("stepped-square").unwrap(),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })?;
    planned.write(&dir, "stepped-square", &[])?;
    let plan = planned.plan_points();
    let kin = Kinematics::with_gauge_length(&m, planned.tool.length);

    // The machine: location errors, a warming Z position of the B axis,
    // and a B axis that does not turn exactly as far as commanded.
    let sym = Model::new(kin.clone(), vec![]).symbols;
    let model = Model::new(
        kin.clone(),
        vec![
            Effect::Location {
                symbols: (0..8).collect(),
            },
            Effect::Drift {
                symbol: sym.location_index("EZ0B")?,
                basis: DriftBasis::Seq,
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
        12.0, -40.0, 80.0, -60.0, 150.0, 25.0, -18.0, 45.0, // location
        1.2,  // drift.EZ0B, um per cut
        60.0, -15.0, -45.0, // EBB(B) at B = -90, 0, 90, urad
    ];
    let minutes: HashMap<String, f64> = planned
        .manifest("stepped-square")
        .poses
        .iter()
        .map(|p| (p.pose.clone(), 0.5 * (p.start_min + p.end_min)))
        .collect();
    let placement = Isometry3::new(
        Vector3::new(800.0, 350.0, -120.0),
        Vector3::new(0.1, 0.2, -1.9),
    );
    let pts = synthetic::machined(&model, &theta, &plan, &minutes, 0.35, &placement, &mut rng);
    // The CMM reports in its own alignment of the piece.
    let dp: Vec<DmisPoint> = pts
        .iter()
        .zip(&plan.points)
        .map(|(q, p)| DmisPoint {
            label: q.label.clone(),
            nominal: (
                (placement * Point3::from(p.p)).coords,
                placement.rotation * p.n,
            ),
            actual: q.p,
        })
        .collect();
    let opts = WriteOptions {
        name: "stepped-square piece".into(),
        ..Default::default()
    };
    std::fs::write(dir.join("piece.dmo"), dmis::write_output(&dp, &opts))?;
    let truth = ErrorFile::from_model(
        &model,
        &theta,
        &vec![None; theta.len()],
        &Noise {
            cmm: Some(0.35),
            probe: None,
        },
    );
    std::fs::write(dir.join("truth.yaml"), truth.to_yaml())?;

    // The story, as `fivecal discover` prints it (paths relative to the
    // repository, as the README runs it).
    let inputs = Inputs::load(
        &dir.join("stepped-square.plan.yaml"),
        &[dir.join("piece.dmo")],
    )?;
    let d = discover::run(
        &inputs.kin,
        &inputs.data,
        &DiscoverOptions {
            test: inputs.plan.test().to_string(),
            ..DiscoverOptions::default()
        },
    )?;
    std::fs::write(dir.join("story.txt"), d.story.render())?;
    println!("{}", d.story.render());
    println!("wrote the example into {}", dir.display());
    Ok(())
}
