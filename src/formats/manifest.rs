//! The plan manifest, `<test>.plan.yaml`: what `plan` wrote and everything
//! `simulate`, `analyze` and `discover` need to rebuild the plan exactly
//! (the machine and template files are copied next to it, so a plan
//! directory is self-contained and can be archived with its measurements).
//!
//! ```yaml
//! fivecal_plan: 1
//! test: stepped-square
//! kind: machining
//! machine: bc-trunnion
//! machine_file: stepped-square.machine.yaml
//! template_file: stepped-square.template.yaml
//! dialect: fanuc
//! kinematics: post
//! tool: {name: D8 carbide end mill, kind: flat, diameter: 8.0, length: 60.0, number: 1}
//! files: {program: stepped-square.nc, points: stepped-square.points.csv, dmis: stepped-square.dmi,
//!         glb: stepped-square.glb, obj: stepped-square.obj, setup: stepped-square.md}
//! poses:
//!   - {pose: B0C0, seq: 0, tilt: 0.0, c: 0.0, start_min: 0.0, end_min: 2.5}
//! ```

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::machine::{Dialect, Probe, Tool};
use crate::source::SourceError;

/// Current manifest format version.
pub const MANIFEST_VERSION: u32 = 1;

/// Machining test (the CMM measures the finished piece) or on-machine
/// probing (the probe measures in W at rotary zero).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TestKind {
    /// A machined piece measured on a CMM.
    Machining,
    /// Touch-probing on the machine.
    Probing,
}

/// How 3+2 positions are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum KinematicsMode {
    /// The post computes X, Y, Z and the rotary axes by inverse kinematics.
    Post,
    /// The controller's own tilted-plane or TCP functions do it.
    Controller,
}

/// A calibration test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Test {
    /// Squares stepped into the top and the sides of a block, each cut at
    /// its own pose, measured on a CMM (Ibaraki & Ota 2014).
    SteppedSquare,
    /// Nine sections of a face cut at nine poses, their heights measured
    /// (Cubas Brizuela & Yeh 2023).
    NineSection,
    /// Square columns probed on the machine at many poses (Ibaraki,
    /// Iritani & Matsushita 2013).
    ProbeColumns,
    /// A calibration sphere probed on the machine at many poses.
    ProbeSphere,
}

impl Test {
    /// Every test, in the order they are offered.
    pub const ALL: [Test; 4] = [
        Test::SteppedSquare,
        Test::NineSection,
        Test::ProbeColumns,
        Test::ProbeSphere,
    ];

    /// The tests that probe on the machine.
    pub const PROBING: [Test; 2] = [Test::ProbeColumns, Test::ProbeSphere];

    /// The name on the command line, in manifests and templates.
    pub const fn as_str(self) -> &'static str {
        match self {
            Test::SteppedSquare => "stepped-square",
            Test::NineSection => "nine-section",
            Test::ProbeColumns => "probe-columns",
            Test::ProbeSphere => "probe-sphere",
        }
    }

    /// A machined piece measured on a CMM, or probing on the machine.
    pub const fn kind(self) -> TestKind {
        match self {
            Test::SteppedSquare | Test::NineSection => TestKind::Machining,
            Test::ProbeColumns | Test::ProbeSphere => TestKind::Probing,
        }
    }

    /// The names of every test, for messages: `a, b, c or d`.
    pub fn names() -> String {
        let n: Vec<&str> = Test::ALL.iter().map(|t| t.as_str()).collect();
        format!("{} or {}", n[..n.len() - 1].join(", "), n[n.len() - 1])
    }
}

impl fmt::Display for Test {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A test equals its name (`test == "nine-section"` in a worked example).
impl PartialEq<&str> for Test {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

impl FromStr for Test {
    type Err = String;
    fn from_str(s: &str) -> Result<Test, String> {
        Test::ALL
            .into_iter()
            .find(|t| t.as_str() == s)
            .ok_or_else(|| format!("unknown test `{s}`: expected {}", Test::names()))
    }
}

/// One pose (cut or station) in execution order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseEntry {
    /// Pose id, as in points.csv.
    pub pose: String,
    /// Execution order from 0.
    pub seq: u32,
    /// Tilt angle, deg.
    pub tilt: f64,
    /// C angle, deg.
    pub c: f64,
    /// Estimated minutes from program start when the pose begins.
    pub start_min: f64,
    /// ... and ends.
    pub end_min: f64,
}

/// A plan manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Format version ([`MANIFEST_VERSION`]).
    pub fivecal_plan: u32,
    /// The test (`stepped-square`, `nine-section`, `probe-columns`, `probe-sphere`).
    pub test: Test,
    /// Machining or probing.
    pub kind: TestKind,
    /// Machine name.
    pub machine: String,
    /// Copy of the machine file, relative to the manifest.
    pub machine_file: PathBuf,
    /// Copy of the template, relative to the manifest.
    pub template_file: PathBuf,
    /// Dialect of the program.
    pub dialect: Dialect,
    /// How 3+2 positions were written.
    pub kinematics: KinematicsMode,
    /// The cutting tool (machining tests).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool: Option<Tool>,
    /// The probe (probing tests).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe: Option<Probe>,
    /// Output files by role (`program`, `points`, `dmis`, `glb`, `obj`, `setup`, ...),
    /// relative to the manifest.
    pub files: IndexMap<String, PathBuf>,
    /// Poses in execution order.
    pub poses: Vec<PoseEntry>,
    /// What the test will identify on this machine, as `plan` predicted
    /// it from the design.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub identifies: Option<Identifies>,
    /// Known changes of the test's template that would identify what this
    /// design leaves unidentified, each re-planned and predicted by `plan`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub suggestions: Vec<SuggestedChange>,
}

/// What a plan will identify: the method, the noise the uncertainties are
/// predicted at, the design's rank, each location error's predicted `u`
/// or why it will not be identified.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Identifies {
    /// The method `analyze` will use by default.
    pub method: String,
    /// Noise per measured point the uncertainties are predicted at, um.
    pub noise_um: f64,
    /// Rank of the design.
    pub rank: usize,
    /// Free parameters of the design (nuisance included).
    pub parameters: usize,
    /// Every location error of the machine.
    pub symbols: IndexMap<String, PredictedSymbol>,
    /// Combinations no measurement of this design sees.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_separable: Vec<String>,
}

/// One location error in [`Identifies`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PredictedSymbol {
    /// um or urad.
    pub unit: String,
    /// Predicted standard uncertainty; absent: not identified.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
    /// Why not, where not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// One entry of the manifest's `suggestions:`: a change of the template
/// and what the test identifies with it beyond the plan as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuggestedChange {
    /// What the change is, in words (`more tilt angles`).
    pub change: String,
    /// The template keys to set, as a fragment of the template (nested
    /// keys with their new values).
    pub set: serde_yaml::Value,
    /// The location errors it makes identifiable, with their predicted
    /// standard uncertainty at the same noise.
    pub identifies: IndexMap<String, PredictedSymbol>,
    /// Location errors identified with the change, of all the machine's.
    pub identified: usize,
    /// Poses of the changed plan.
    pub poses: usize,
    /// Its estimated run time, min.
    pub run_min: f64,
    /// The `fivecal plan` command that plans it, once the template is
    /// changed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<String>,
    /// Where the change is a second run of the test with another probe,
    /// analysed together with this one (then `set` is empty, `poses` and
    /// `run_min` are the second run's, `identified` the two runs'
    /// together, and `command` plans the second run).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub second_run: Option<SecondRunEntry>,
}

/// The second run of a suggestion: the machine file it is planned with and
/// how both runs are analysed together.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SecondRunEntry {
    /// The copy of the machine file to make (it keeps the machine's name).
    pub machine_file: String,
    /// What it is a copy of: the machine file written beside this plan.
    pub copy_of: String,
    /// The machine file keys to set in the copy, as a fragment of it.
    pub machine_set: serde_yaml::Value,
    /// The `fivecal discover` command fitting both runs' measurements
    /// together (`FIRST-RUN-MEASURED`, `SECOND-RUN-MEASURED`: the
    /// measurement files of each run).
    pub together: String,
}

impl Manifest {
    /// Parses a manifest.
    pub fn parse(path: &Path, src: &str) -> Result<Manifest, SourceError> {
        let m: Manifest = crate::input::parse_yaml(path, src)?;
        if m.fivecal_plan != MANIFEST_VERSION {
            return Err(SourceError::at_key(
                path,
                src,
                &["fivecal_plan"],
                format!(
                    "plan manifest version {} is not supported (expected {MANIFEST_VERSION})",
                    m.fivecal_plan
                ),
            ));
        }
        // The tool and probe are read by what analyses the plan's
        // measurements: a NaN ball would surface as a measurement that
        // matches nothing, blaming the measurement file.
        if let Some(t) = &m.tool {
            crate::machine::check_tool(t)
                .map_err(|(k, msg)| SourceError::at_key(path, src, &["tool", k], msg))?;
        }
        if let Some(p) = &m.probe {
            let max = crate::limits::MAX_MACHINE_MM;
            for (k, v) in [("ball_diameter", p.ball_diameter), ("length", p.length)] {
                if !(v.is_finite() && v > 0.0 && v <= max) {
                    return Err(SourceError::at_key(
                        path,
                        src,
                        &["probe", k],
                        format!(
                            "probe {k} must be > 0 and at most {max} mm, got {}",
                            crate::numbers::echo(v)
                        ),
                    ));
                }
            }
        }
        Ok(m)
    }

    /// Reads a manifest file.
    pub fn read(path: &Path) -> Result<Manifest, SourceError> {
        let src = crate::input::read_text(path, "plan manifest", crate::limits::MAX_YAML_BYTES)?;
        let m = Manifest::parse(path, &src)?;
        // The files of the plan are its inputs too, read now or later in
        // the run: no output of the run may land on one.
        crate::io::note_input(&m.resolve(path, &m.machine_file), "the plan's machine copy");
        crate::io::note_input(
            &m.resolve(path, &m.template_file),
            "the plan's template copy",
        );
        for (role, rel) in &m.files {
            crate::io::note_input(&m.resolve(path, rel), &format!("the plan's {role} file"));
        }
        Ok(m)
    }

    /// YAML text.
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).expect("manifests serialize")
    }

    /// The path of a listed file, resolved against the manifest's directory.
    pub fn resolve(&self, manifest_path: &Path, rel: &Path) -> PathBuf {
        manifest_path.parent().unwrap_or(Path::new(".")).join(rel)
    }

    /// The path of the file with role `role`, if listed.
    pub fn file(&self, manifest_path: &Path, role: &str) -> Option<PathBuf> {
        self.files.get(role).map(|r| self.resolve(manifest_path, r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_checks_the_version() {
        let m = Manifest {
            fivecal_plan: 1,
            test: Test::SteppedSquare,
            kind: TestKind::Machining,
            machine: "bc-trunnion".into(),
            machine_file: "s.machine.yaml".into(),
            template_file: "s.template.yaml".into(),
            dialect: Dialect::Fanuc,
            kinematics: KinematicsMode::Post,
            tool: None,
            probe: None,
            files: [("points".to_string(), PathBuf::from("s.points.csv"))]
                .into_iter()
                .collect(),
            poses: vec![PoseEntry {
                pose: "B0C0".into(),
                seq: 0,
                tilt: 0.0,
                c: 0.0,
                start_min: 0.0,
                end_min: 1.5,
            }],
            identifies: None,
            suggestions: Vec::new(),
        };
        let text = m.to_yaml();
        assert_eq!(Manifest::parse(Path::new("p.yaml"), &text).unwrap(), m);
        let bad = text.replace("fivecal_plan: 1", "fivecal_plan: 7");
        let e = Manifest::parse(Path::new("p.yaml"), &bad)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "p.yaml:1:1: plan manifest version 7 is not supported (expected 1)"
        );
        assert_eq!(
            m.file(Path::new("dir/p.yaml"), "points").unwrap(),
            PathBuf::from("dir/s.points.csv")
        );
    }

    #[test]
    fn names_parse_back_and_serialize_as_written() {
        for t in Test::ALL {
            assert_eq!(t.as_str().parse::<Test>(), Ok(t));
            assert_eq!(serde_yaml::to_string(&t).unwrap().trim(), t.as_str());
        }
        assert_eq!(
            "probe".parse::<Test>().unwrap_err(),
            "unknown test `probe`: expected stepped-square, nine-section, probe-columns or probe-sphere"
        );
    }
}
