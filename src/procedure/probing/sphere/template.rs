//! The probe-sphere template (`templates/probe-sphere.yaml`): the sphere
//! on its stem, the approach directions, the pose pattern, the plausibility
//! check of each pose's fit, how touches are made and the probe's stylus.

use nalgebra::Vector2;
use serde::Deserialize;

use crate::limits::{MAX_PLAN_POSES, MAX_PLAN_TURNS};
use crate::procedure::bounds::{angle, count, echo, length, position, within};
use crate::procedure::probing::ProbingSettings;
use crate::procedure::probing::template::{ProbeFile, ProbingFile, StylusSpec, settings, stylus};
use crate::procedure::{TemplateSource, Test};
use crate::source::SourceError;

/// The built-in template.
pub const BUILTIN_TEMPLATE: &str = include_str!("../../../../templates/probe-sphere.yaml");

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereGeomFile {
    diameter: f64,
    position: [f64; 2],
    height: f64,
    stem_diameter: f64,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct RangeFile {
    from: f64,
    to: f64,
    step: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CSweepFile {
    tilt: f64,
    c: RangeFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TiltSweepFile {
    c: f64,
    tilt: RangeFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Seed004File {
    c_sweep: CSweepFile,
    tilt_sweep: TiltSweepFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpanFile {
    from: f64,
    to: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Seed003File {
    poses: usize,
    tilt: SpanFile,
    turns: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GridFile {
    tilt: Vec<f64>,
    c: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckFile {
    radius_tolerance: f64,
    form_tolerance: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereFile {
    test: String,
    sphere: SphereGeomFile,
    touches: Vec<String>,
    pattern: String,
    #[serde(rename = "seed-004")]
    seed004: Seed004File,
    #[serde(rename = "seed-003")]
    seed003: Seed003File,
    #[serde(default)]
    grid: Option<GridFile>,
    check: CheckFile,
    probing: ProbingFile,
    probe: ProbeFile,
}

/// The probe-sphere pose pattern.
#[derive(Clone, Debug, PartialEq)]
pub enum SpherePattern {
    /// `pattern: seed-004`: a C sweep at one tilt, then a tilt sweep at
    /// one C (as Cubas Brizuela & Yeh 2023 probe).
    Seed004 {
        /// Tilt of the C sweep, deg.
        c_sweep_tilt: f64,
        /// C angles of the C sweep, deg.
        c_sweep: Vec<f64>,
        /// C of the tilt sweep, deg.
        tilt_sweep_c: f64,
        /// Tilt angles of the tilt sweep, deg.
        tilt_sweep: Vec<f64>,
    },
    /// `pattern: grid`: every tilt angle with every C angle, tilt by tilt
    /// (the supplementary test `discover` asks for after an ambiguity:
    /// each new tilt at several C angles, so that its map values are seen
    /// from every side).
    Grid {
        /// Tilt angles, deg.
        tilt: Vec<f64>,
        /// C angles, deg.
        c: Vec<f64>,
    },
    /// `pattern: seed-003`: a spiral of `poses` poses, the tilt evenly
    /// spread from `tilt.0` to `tilt.1` while C advances `turns` full turns.
    Seed003 {
        /// Number of poses.
        poses: usize,
        /// First and last tilt, deg.
        tilt: (f64, f64),
        /// Turns of C over the poses.
        turns: f64,
    },
}

/// The probe-sphere template, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereTemplate {
    /// Where it came from.
    pub source: TemplateSource,
    /// Sphere diameter, mm.
    pub diameter: f64,
    /// Centre (x, y) in W, mm.
    pub position: Vector2<f64>,
    /// Centre above the table surface, mm.
    pub height: f64,
    /// Stem diameter, mm.
    pub stem_diameter: f64,
    /// Approach directions in program coordinates (unit vectors along
    /// axes) with their feature names (`xp` for +x, ...).
    pub touches: Vec<(nalgebra::Vector3<f64>, &'static str)>,
    /// The pose pattern.
    pub pattern: SpherePattern,
    /// Largest accepted radius error of a pose's fit, mm.
    pub radius_tolerance: f64,
    /// Largest accepted form error of a pose's fit, mm.
    pub form_tolerance: f64,
    /// Probing settings.
    pub probing: ProbingSettings,
    /// Probe geometry.
    pub probe: StylusSpec,
}

fn range(src: &TemplateSource, keys: &[&str], r: RangeFile) -> Result<Vec<f64>, SourceError> {
    let key = |k: &'static str| [keys, &[k]].concat();
    angle(src, &key("from"), r.from)?;
    angle(src, &key("to"), r.to)?;
    if !(r.from <= r.to && r.step > 0.0 && r.step.is_finite()) {
        return Err(src.error(
            keys,
            format!(
                "{}: expected from <= to and a positive step, got from {} to {} step {}",
                keys.join("."),
                r.from,
                r.to,
                echo(r.step)
            ),
        ));
    }
    // Counted before any pose is made.
    let n = ((r.to - r.from) / r.step + 1e-9).floor() + 1.0;
    if n > MAX_PLAN_POSES as f64 {
        return Err(src.error(
            &key("step"),
            format!(
                "{}: a step of {} deg from {} to {} makes {n} poses, more than the {MAX_PLAN_POSES} a plan may have",
                keys.join("."),
                echo(r.step),
                r.from,
                r.to
            ),
        ));
    }
    Ok((0..n as usize)
        .map(|i| r.from + r.step * i as f64)
        .collect())
}

impl SphereTemplate {
    /// The built-in template.
    pub fn builtin() -> SphereTemplate {
        SphereTemplate::parse(TemplateSource::builtin(Test::ProbeSphere))
            .expect("the built-in template is valid")
    }

    /// Parses and validates a template.
    pub fn parse(source: TemplateSource) -> Result<SphereTemplate, SourceError> {
        let f: SphereFile = crate::input::parse_yaml(&source.path, &source.text)?;
        let src = &source;
        src.check_test(&f.test, Test::ProbeSphere)?;
        let s = &f.sphere;
        length(src, &["sphere", "diameter"], s.diameter)?;
        length(src, &["sphere", "stem_diameter"], s.stem_diameter)?;
        if s.stem_diameter >= s.diameter {
            return Err(src.error(
                &["sphere", "stem_diameter"],
                format!(
                    "sphere.stem_diameter ({}) must be smaller than the sphere's diameter ({})",
                    s.stem_diameter, s.diameter
                ),
            ));
        }
        length(src, &["sphere", "height"], s.height)?;
        if s.height <= s.diameter / 2.0 {
            return Err(src.error(
                &["sphere", "height"],
                format!(
                    "sphere.height (centre above the table) must exceed the radius {} mm, got {}",
                    s.diameter / 2.0,
                    s.height
                ),
            ));
        }
        for v in s.position {
            position(src, &["sphere", "position"], v)?;
        }
        let mut touches: Vec<(nalgebra::Vector3<f64>, &'static str)> = Vec::new();
        for t in &f.touches {
            let d = match t.as_str() {
                "+x" => (nalgebra::Vector3::x(), "xp"),
                "-x" => (-nalgebra::Vector3::x(), "xm"),
                "+y" => (nalgebra::Vector3::y(), "yp"),
                "-y" => (-nalgebra::Vector3::y(), "ym"),
                "-z" => (-nalgebra::Vector3::z(), "zm"),
                _ => {
                    return Err(src.error(
                        &["touches"],
                        format!(
                            "touches: unknown approach `{t}`: expected +x, -x, +y, -y or -z (the stem is below the sphere)"
                        ),
                    ));
                }
            };
            if touches.iter().any(|o| o.1 == d.1) {
                return Err(src.error(&["touches"], format!("touches: `{t}` is listed twice")));
            }
            touches.push(d);
        }
        if touches.len() < 4 || !touches.iter().any(|t| t.1 == "zm") {
            return Err(src.error(
                &["touches"],
                "touches: a sphere needs at least four touches, one of them -z (the equator alone lies in one plane)",
            ));
        }
        let pattern = match f.pattern.as_str() {
            "seed-004" => SpherePattern::Seed004 {
                c_sweep_tilt: angle(
                    src,
                    &["seed-004", "c_sweep", "tilt"],
                    f.seed004.c_sweep.tilt,
                )?,
                c_sweep: range(src, &["seed-004", "c_sweep", "c"], f.seed004.c_sweep.c)?,
                tilt_sweep_c: angle(
                    src,
                    &["seed-004", "tilt_sweep", "c"],
                    f.seed004.tilt_sweep.c,
                )?,
                tilt_sweep: range(
                    src,
                    &["seed-004", "tilt_sweep", "tilt"],
                    f.seed004.tilt_sweep.tilt,
                )?,
            },
            "seed-003" => {
                let p = &f.seed003;
                count(src, &["seed-003", "poses"], p.poses, (2, MAX_PLAN_POSES))?;
                within(
                    src,
                    &["seed-003", "turns"],
                    p.turns,
                    (0.0, MAX_PLAN_TURNS),
                    "turns",
                    "",
                )?;
                angle(src, &["seed-003", "tilt", "from"], p.tilt.from)?;
                angle(src, &["seed-003", "tilt", "to"], p.tilt.to)?;
                SpherePattern::Seed003 {
                    poses: p.poses,
                    tilt: (p.tilt.from, p.tilt.to),
                    turns: p.turns,
                }
            }
            "grid" => {
                let Some(g) = &f.grid else {
                    return Err(src.error(
                        &["pattern"],
                        "pattern: grid needs a `grid:` section with its `tilt` and `c` angles (deg)",
                    ));
                };
                for (key, v) in [("tilt", &g.tilt), ("c", &g.c)] {
                    if v.is_empty() || v.len() > 1000 || v.iter().any(|a| !a.is_finite()) {
                        return Err(src.error(
                            &["grid", key],
                            format!("grid.{key}: expected 1 to 1000 angles in degrees"),
                        ));
                    }
                }
                SpherePattern::Grid {
                    tilt: g.tilt.clone(),
                    c: g.c.clone(),
                }
            }
            other => {
                return Err(src.error(
                    &["pattern"],
                    format!("pattern: unknown `{other}`: expected seed-004, seed-003 or grid"),
                ));
            }
        };
        length(
            src,
            &["check", "radius_tolerance"],
            f.check.radius_tolerance,
        )?;
        length(src, &["check", "form_tolerance"], f.check.form_tolerance)?;
        Ok(SphereTemplate {
            diameter: s.diameter,
            position: Vector2::new(s.position[0], s.position[1]),
            height: s.height,
            stem_diameter: s.stem_diameter,
            touches,
            pattern,
            radius_tolerance: f.check.radius_tolerance,
            form_tolerance: f.check.form_tolerance,
            probing: settings(src, &f.probing)?,
            probe: stylus(src, &f.probe)?,
            source,
        })
    }

    /// The per-pose sphere check for touches logged as ball centres of a
    /// ball of radius `ball_radius`.
    pub fn sphere_check(&self, ball_radius: f64) -> crate::shape_fit::SphereCheck {
        crate::shape_fit::SphereCheck {
            expected_radius: self.diameter / 2.0 + ball_radius,
            radius_tolerance: self.radius_tolerance,
            form_tolerance: self.form_tolerance,
        }
    }
}
