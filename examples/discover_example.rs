//! Writes the worked example of `examples/discover/`: the stepped-square
//! test of Ibaraki & Ota 2014 planned for `bc-trunnion` (FANUC), run on the virtual
//! machine (`simulate::run`) with the eight location errors and three
//! effects a location calibration does not know: EZ0B drifting 1.2 um per
//! cut as the machine warms up, an end mill cutting 3 um larger than its
//! nominal radius, and a B-axis angular positioning error EBB(B) of up to
//! 60 urad; measured on a CMM as DMIS output (0.35 um of noise, the piece
//! anywhere on the CMM); and the story `fivecal discover` tells about it.
//!
//! Run `cargo run --release --example discover_example [DIR]`; the truth
//! is in `truth.yaml`.

use std::path::{Path, PathBuf};

use fivecal::discover::{DiscoverOptions, Inputs};
use fivecal::errorfile::{ErrorFile, LoadedErrors, Noise};
use fivecal::formats::manifest::KinematicsMode;
use fivecal::kinematics::maps::{MapDim, MapGrid};
use fivecal::model::{DriftBasis, Effect, Model};
use fivecal::post::PostDefinition;
use fivecal::procedure::{PlanConfig, Template, Test};
use fivecal::simulate::{self, Format, SimOptions};
use fivecal::{Dialect, Machine};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/discover"));
    std::fs::create_dir_all(&dir)?;

    // The plan, as `fivecal plan stepped-square --machine bc-trunnion` writes it.
    let m = Machine::builtin("bc-trunnion").unwrap();
    let plan = fivecal::procedure::plan(&PlanConfig {
        machine: m,
        template: Template::builtin(Test::SteppedSquare),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })?;
    plan.write(&dir, "stepped-square", &[])?;
    let kin = simulate::plan_kinematics(&plan);

    // The machine: location errors, a warming Z position of the B axis, a
    // tool a little larger than it says, and a B axis that does not turn
    // exactly as far as commanded.
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
            Effect::ToolRadius,
            Effect::Map {
                symbol: sym.map_index("EBB(B)")?,
                grid: MapGrid {
                    dims: vec![MapDim::new(0, &[-90.0, 0.0, 90.0], false)?],
                },
            },
        ],
    );
    let theta = vec![
        12.0, -40.0, 80.0, -60.0, 150.0, 25.0, -18.0, 45.0, // location
        1.2,  // drift.EZ0B, um per cut
        3.0,  // tool radius, um
        60.0, -15.0, -45.0, // EBB(B) at B = -90, 0, 90, urad
    ];
    let noise = Noise {
        cmm: Some(0.35),
        probe: None,
    };
    let truth = ErrorFile::from_model(&model, &theta, &vec![None; theta.len()], &noise);
    std::fs::write(dir.join("truth.yaml"), truth.to_yaml())?;
    let errors = LoadedErrors {
        u: vec![None; theta.len()],
        model,
        theta,
        noise,
        not_identifiable: Vec::new(),
        fit: None,
    };
    let out = simulate::run(
        &plan,
        &errors,
        &SimOptions {
            seed: 2026,
            ..SimOptions::default()
        },
    )?;
    out.write(Format::Dmis, &dir.join("piece.dmo"))?;

    // The story, as `fivecal discover` prints it (paths relative to the
    // repository, as the README runs it).
    let inputs = Inputs::load(
        &dir.join("stepped-square.plan.yaml"),
        &[dir.join("piece.dmo")],
        &Default::default(),
    )?;
    let d = inputs.discover(&DiscoverOptions::default())?;
    std::fs::write(dir.join("story.txt"), d.story.render())?;
    println!("{}", d.story.render());
    println!("wrote the example into {}", dir.display());
    Ok(())
}
