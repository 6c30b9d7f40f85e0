//! Planning the on-machine probing tests (`probe-columns`, `probe-sphere`)
//! as NC programs: the dialect-free [`TouchPlan`] of [`super`]
//! rendered through the post engine, with its nominal points, setup model,
//! setup sheet and manifest.
//!
//! # The program
//! The program runs with the work offset on the W origin at rotary zero,
//! without TCP or a tilted plane (commanded X, Y, Z are computed by fivecal
//! from the machine file, and the logs record positions in the same
//! program coordinates). It calls the probe ([`crate::machine::Probe`]'s
//! tool number, length compensation on), stops the spindle, opens the log
//! and writes its header, retracts to the safe height, and then per pose:
//! a section comment, a retract to the safe height right before the
//! rotary move (the engine refuses a rotary move without it), the rotary
//! move alone, and the plan's moves: rapids at the safe or clearance height
//! or straight down, positioning moves at the positioning feed, every
//! probing move along its touch's normal at the probing feed
//! ([`Op::ProbeMove`] to the overtravel end), followed by the log
//! statements of that touch ([`Op::LogPoint`]: index or label), and the
//! retract from the contact to the start point. The log is closed at the
//! end. Per dialect (the built-in postprocessors):
//! - FANUC: `G31 X.. Y.. Z.. F..`, `#199=<index>`,
//!   `DPRNT[T#199[50]*X#5061[44]*Y#5062[44]*Z#5063[44]]` inside
//!   `POPEN`/`PCLOS`; every coordinate fits DPRNT's `[44]` field (checked
//!   here, the plan is refused otherwise);
//! - HEIDENHAIN: `TCH PROBE 0` along one axis, `FN 18: SYSREAD ... ID360`
//!   and `FN 16: F-PRINT` through the format files `<test>-head.a` and
//!   `<test>-touch.a` written next to the program. Cycle 0 probes along X,
//!   Y or Z only ([`PostDefinition::probe_axis_aligned`]), so touches whose
//!   approach is oblique at their pose are left out of the plan and listed
//!   (the sphere's touches are always along axes; the columns' side faces
//!   are oblique wherever C is not a multiple of 90 deg). A definition with
//!   an oblique probing cycle and `probe_axis_aligned: false` keeps them;
//! - LinuxCNC: `G38.2 X.. Y.. Z.. F..` and `(LOG,T <label> X#5061 Y#5062
//!   Z#5063)` between `(LOGOPEN,<test>.log)` and `(LOGCLOSE)`.
//!
//! # For the simulator: what a [`ProbingPlan`] holds
//! Frames and units follow docs/model.md (W, mm, deg). [`load`](crate::procedure::load)
//! rebuilds it exactly from a manifest.
//! - `machine`, `probe` (ball diameter, gauge length, tool number) and
//!   `plan.kin`, the machine's kinematics with the probe's gauge length
//!   (`Kinematics::with_gauge_length(&machine, probe.length)`).
//! - `setup` ([`ProbedGeometry`]): the nominal geometry probed, column boxes or the
//!   sphere with its stem, in W, with [`ProbedGeometry::signed_distance`] from a
//!   point to the probed surfaces; `plan.obstacles` has the same solids plus
//!   the table for collision checks, `mesh` the triangles written to
//!   `.obj`/`.glb`.
//! - `plan` ([`TouchPlan`]): `poses` (id, seq, angles, the touches' index
//!   range), `touches` in execution order ([`super::Touch`]: the
//!   1-based `index` = row of points.csv and the index FANUC and HEIDENHAIN
//!   logs carry, the `label` LinuxCNC logs carry, the nominal contact point
//!   and outward normal in W and in program coordinates, and the waypoints
//!   `start` (ball at the clearance distance), `contact` (ball on the
//!   nominal surface) and `end` (the programmed overtravel end), each with
//!   the commanded axes and the ball centre in W and program coordinates,
//!   and the probing `feed`), the whole path `moves` in execution order,
//!   `settings` (clearance, overtravel, feeds), and what was `skipped`.
//! - `run_time`: minutes from the start of each pose and of each touch's
//!   contact (`poses`, `touch_min`), for effects that drift with time.
//! - `log_format()`: the [`LogFormat`] that writes the log the program
//!   makes the control write, and `read_options()` the reader's options.
//!
//! To simulate a touch on an erroneous machine: move the commanded axes
//! from `touch.start.axes` towards `touch.end.axes` (a straight line in
//! axis space; the rotary axes stand still), map the actual ball centre
//! (`Kinematics::forward` with the errors) into W, stop where its distance
//! from the nominal surface (`setup.signed_distance`) equals the ball
//! radius (plus the probe's pre-travel), and log the commanded X, Y, Z
//! there with `log_format().touch_line(touch, &xyz, ball_radius)`. The
//! plan's moves between touches keep `settings.safe_margin` from the
//! setup, so errors below that cannot cause a collision.

use std::ops::Range;

use nalgebra::{Isometry3, Matrix3, Vector3};

use super::collision::ConvexSolid;
use super::{ControlLimits, ProbingMoveKind, RunTime, TouchPlan, columns, setup_mesh, sphere};
use crate::formats::points::PlanPoints;
use crate::formats::probe_log::write::LogFormat;
use crate::formats::probe_log::{ReadOptions, fanuc};
use crate::machine::{Dialect, Machine, Probe, Structure};
use crate::mesh::Mesh;
use crate::post::{Op, PostDefinition, ProgramInfo, RenderedProgram, Target};
use crate::procedure::{PlanConfig, PlanError, Template, Test, short};

/// One column of the setup.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbedColumn {
    /// Its name (`C1`), part of the labels of its touches.
    pub name: String,
    /// Centre of the box in W, mm (half its height above the table).
    pub centre: Vector3<f64>,
    /// The box axes in W as columns: the column's x and y (turned by its
    /// yaw about Z) and Z.
    pub axes: Matrix3<f64>,
    /// Half sizes along them, mm.
    pub half: Vector3<f64>,
}

impl ProbedColumn {
    /// Signed distance from `p` (W) to the box surface: negative inside.
    pub fn signed_distance(&self, p: &Vector3<f64>) -> f64 {
        let u = self.axes.transpose() * (p - self.centre);
        let q = u.abs() - self.half;
        let outside = q.sup(&Vector3::zeros()).norm();
        outside + q.max().min(0.0)
    }
}

/// The calibration sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbedSphere {
    /// Centre in W, mm.
    pub centre: Vector3<f64>,
    /// Diameter, mm.
    pub diameter: f64,
    /// Diameter of the stem holding it from the table, mm.
    pub stem_diameter: f64,
    /// The stem's foot on the table, in W.
    pub stem_foot: Vector3<f64>,
}

/// The nominal geometry a probing test touches, in W.
#[derive(Clone, Debug, PartialEq)]
pub enum ProbedGeometry {
    /// Square columns standing on the table.
    Columns(Vec<ProbedColumn>),
    /// A sphere on a stem.
    Sphere(ProbedSphere),
}

impl ProbedGeometry {
    /// Signed distance from a point of W to the probed surfaces (the
    /// columns, or the sphere; not the stem or the table): negative inside.
    pub fn signed_distance(&self, p: &Vector3<f64>) -> f64 {
        match self {
            ProbedGeometry::Columns(cs) => cs
                .iter()
                .map(|c| c.signed_distance(p))
                .fold(f64::INFINITY, f64::min),
            ProbedGeometry::Sphere(s) => (p - s.centre).norm() - s.diameter / 2.0,
        }
    }

    /// The setup in words, for program headers and the setup sheet.
    pub fn describe(&self) -> Vec<String> {
        match self {
            ProbedGeometry::Columns(cs) => cs
                .iter()
                .map(|c| {
                    let yaw = c.axes[(1, 0)].atan2(c.axes[(0, 0)]).to_degrees();
                    format!(
                        "column {}: {} x {} x {} mm, footprint centre X{} Y{} in W{}",
                        c.name,
                        short(2.0 * c.half.x),
                        short(2.0 * c.half.y),
                        short(2.0 * c.half.z),
                        short(c.centre.x),
                        short(c.centre.y),
                        if yaw.abs() > 1e-9 {
                            format!(", turned {} deg about Z", short(yaw))
                        } else {
                            String::new()
                        }
                    )
                })
                .collect(),
            ProbedGeometry::Sphere(s) => vec![format!(
                "sphere D{} on a D{} stem, centre X{} Y{} Z{} in W ({} mm above the table)",
                short(s.diameter),
                short(s.stem_diameter),
                short(s.centre.x),
                short(s.centre.y),
                short(s.centre.z),
                short(s.centre.z - s.stem_foot.z)
            )],
        }
    }
}

/// A planned probing test.
#[derive(Clone, Debug)]
pub struct ProbingPlan {
    /// The test.
    pub test: Test,
    /// The machine.
    pub machine: Machine,
    /// The template.
    pub template: Template,
    /// The postprocessor.
    pub post: PostDefinition,
    /// The dialect.
    pub dialect: Dialect,
    /// What the control can do (from the postprocessor).
    pub limits: ControlLimits,
    /// The probe of the machine file.
    pub probe: Probe,
    /// Touches, path and setup obstacles.
    pub plan: TouchPlan,
    /// The nominal geometry probed.
    pub setup: ProbedGeometry,
    /// Expected run time, per pose and per touch.
    pub run_time: RunTime,
    /// The neutral toolpath of the whole program.
    pub toolpath: Vec<Op>,
    /// What the program header says.
    pub info: ProgramInfo,
    /// The rendered program (and HEIDENHAIN's format files).
    pub program: RenderedProgram,
    /// The setup as a mesh (`.obj`, `.glb`).
    pub mesh: Mesh,
    /// Notes for the setup sheet: left-out touches, weak poses.
    pub notes: Vec<String>,
    /// Why the safe height is safe, in words.
    pub safe_reason: String,
}

/// One pose with its timing, as the manifest lists it.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbingPose {
    /// Pose id.
    pub id: String,
    /// Execution order from 0.
    pub seq: u32,
    /// Tilt, deg.
    pub tilt: f64,
    /// C, deg.
    pub c: f64,
    /// Minutes from the program start when the pose begins.
    pub start_min: f64,
    /// ... and ends.
    pub end_min: f64,
    /// Its touches in `plan.touches`.
    pub touches: Range<usize>,
}

impl ProbingPlan {
    /// The nominal points (points.csv): row `i` is touch `i`.
    pub fn plan_points(&self) -> PlanPoints {
        self.plan.points()
    }

    /// The poses with their estimated times.
    pub fn poses(&self) -> Vec<ProbingPose> {
        self.plan
            .poses
            .iter()
            .zip(&self.run_time.poses)
            .map(|(p, &(start_min, end_min))| ProbingPose {
                id: p.id.clone(),
                seq: p.seq,
                tilt: p.tilt,
                c: p.c,
                start_min,
                end_min,
                touches: p.touches.clone(),
            })
            .collect()
    }

    /// How the program's log reads: the writer a simulator uses.
    pub fn log_format(&self) -> LogFormat {
        LogFormat::for_program(self.dialect, &self.program)
    }

    /// The reader's options for this plan's logs.
    pub fn read_options(&self) -> ReadOptions {
        let mut o = ReadOptions::for_plan(&self.plan.settings, self.plan.probe.ball_radius);
        o.test = Some(self.test);
        o
    }

    /// The estimated run time, min.
    pub fn run_minutes(&self) -> f64 {
        self.run_time.total_min
    }
}

/// The nominal setup of a probing template, and the test in words for the
/// program header; a machining template is refused.
fn setup_of(m: &Machine, t: &Template) -> Result<(ProbedGeometry, String), PlanError> {
    Ok(match t {
        Template::Columns(t) => (
            ProbedGeometry::Columns(
                t.columns
                    .iter()
                    .map(|c| {
                        let o = columns::column_obstacle(m, c);
                        let ConvexSolid::Cuboid { centre, axes, half } = o.solid else {
                            unreachable!("columns are boxes")
                        };
                        ProbedColumn {
                            name: c.name.clone(),
                            centre,
                            axes,
                            half,
                        }
                    })
                    .collect(),
            ),
            format!(
                "on-machine probing of {} square columns (Ibaraki, Iritani & Matsushita 2013)",
                t.columns.len()
            ),
        ),
        Template::Sphere(t) => {
            let centre = sphere::sphere_centre(m, t);
            (
                ProbedGeometry::Sphere(ProbedSphere {
                    centre,
                    diameter: t.diameter,
                    stem_diameter: t.stem_diameter,
                    stem_foot: Vector3::new(centre.x, centre.y, m.table.surface),
                }),
                format!(
                    "calibration sphere D{} probed {} times per pose ({})",
                    short(t.diameter),
                    t.touches.len(),
                    match t.pattern {
                        sphere::SpherePattern::Seed004 { .. } => "Cubas Brizuela & Yeh 2023",
                        sphere::SpherePattern::Seed003 { .. } =>
                            "the LAMDAMAP 2015 paper's spiral of poses",
                        sphere::SpherePattern::Grid { .. } => "every tilt with every C",
                    }
                ),
            )
        }
        Template::SteppedSquare(_) | Template::NineSection(_) => {
            return Err(PlanError::Impossible(format!(
                "{} is a machining test, not a probing test",
                t.test()
            )));
        }
    })
}

/// The log's file stem: short, so that HEIDENHAIN's `FN 16` block naming
/// the format file and the log twice stays within 80 characters.
pub fn log_name(test: Test) -> &'static str {
    match test {
        Test::ProbeColumns => "columns",
        _ => "sphere",
    }
}

/// The program number (FANUC `O`) of each test.
fn program_number(test: Test) -> u32 {
    match test {
        Test::ProbeColumns => 2001,
        _ => 2002,
    }
}

/// The neutral toolpath of a plan.
fn toolpath(plan: &TouchPlan, probe: &Probe, log: &str) -> Vec<Op> {
    let letter = plan.kin.machine().tilt_letter();
    let safe = plan.safe_z;
    let feed = plan.settings.positioning_feed;
    let mut ops = vec![
        Op::ToolCall {
            number: probe.number,
            name: probe.name.clone(),
            id: probe.id.clone(),
            rpm: None,
        },
        Op::SpindleOff,
        Op::LogOpen {
            name: log.to_string(),
            test: plan.test.to_string(),
        },
        Op::Retract { z: safe },
    ];
    let section = |k: usize| {
        let p = &plan.poses[k];
        Op::Section(format!(
            "pose {} (seq {}): {letter} = {}, C = {}: {} touches",
            p.id,
            p.seq,
            short(p.tilt),
            short(p.c),
            p.touches.len()
        ))
    };
    let first = &plan.poses[0];
    ops.push(section(0));
    ops.push(Op::Rotary {
        tilt: first.tilt,
        c: first.c,
    });
    ops.push(Op::Rapid(Target::xyz(plan.start.axes.xyz)));
    for mv in &plan.moves {
        let to = mv.to.axes.xyz;
        match mv.kind {
            ProbingMoveKind::Rapid => {
                let up = (to.x - mv.from.axes.xyz.x).abs() < 1e-9
                    && (to.y - mv.from.axes.xyz.y).abs() < 1e-9
                    && (to.z - safe).abs() < 1e-9;
                ops.push(if up {
                    Op::Retract { z: safe }
                } else {
                    Op::Rapid(Target::xyz(to))
                });
            }
            ProbingMoveKind::Rotary => {
                if !matches!(ops.last(), Some(Op::Retract { .. })) {
                    ops.push(Op::Retract { z: safe });
                }
                ops.push(section(mv.pose));
                ops.push(Op::Rotary {
                    tilt: mv.to.axes.tilt,
                    c: mv.to.axes.c,
                });
            }
            ProbingMoveKind::Position | ProbingMoveKind::Retract(_) => ops.push(Op::Feed {
                to: Target::xyz(to),
                feed,
            }),
            ProbingMoveKind::Probe(i) => {
                let t = &plan.touches[i];
                ops.push(Op::ProbeMove {
                    from: t.start.axes.xyz,
                    to,
                    feed: t.feed,
                    direction: -t.normal_prog,
                });
                ops.push(Op::LogPoint {
                    index: t.index,
                    label: t.label.clone(),
                });
            }
        }
    }
    if !matches!(ops.last(), Some(Op::Retract { .. })) {
        ops.push(Op::Retract { z: safe });
    }
    ops.push(Op::LogClose);
    ops
}

/// The box around the probed pieces (HEIDENHAIN's `BLK FORM`).
fn stock_box(plan: &TouchPlan) -> (Vector3<f64>, Vector3<f64>) {
    let id = Isometry3::identity();
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for o in plan.obstacles.iter().filter(|o| o.name != "table") {
        for i in 0..3 {
            let mut d = Vector3::zeros();
            d[i] = 1.0;
            hi[i] = hi[i].max(o.solid.extent_along(&id, &d));
            lo[i] = lo[i].min(-o.solid.extent_along(&id, &-d));
        }
    }
    let r = |v: Vector3<f64>| v.map(|x| (x * 1000.0).round() / 1000.0);
    (r(lo), r(hi))
}

/// The size of the SINUMERIK probe log the program writes, bytes, at
/// most: its header line and one line per touch, `T<i> X.. Y.. Z..` with
/// the ball centre at the nominal touch in program coordinates, each
/// value with all four decimals and a sign, and WRITE's line feed.
fn sinumerik_log_bytes(plan: &TouchPlan, ball_radius: f64) -> usize {
    let header = format!("FIVECAL {}\n", plan.test).len();
    let touches: usize = plan
        .touches
        .iter()
        .map(|t| {
            let c = t.contact_prog + t.normal_prog * ball_radius;
            format!(
                "T{} X{:.4} Y{:.4} Z{:.4}\n",
                t.index,
                -c.x.abs(),
                -c.y.abs(),
                -c.z.abs()
            )
            .len()
        })
        .sum();
    header + touches
}

/// Counts the left-out touches by kind of reason, for notes.
fn skipped_notes(plan: &TouchPlan) -> Vec<String> {
    let mut kinds: Vec<(&str, usize, String)> = Vec::new();
    for s in &plan.skipped {
        let kind = if s.label == s.pose {
            "whole poses without a reachable touch"
        } else if s.reason.contains("probes along X, Y or Z only") {
            "touches whose approach is not along X, Y or Z (the control probes along one axis)"
        } else if s.reason.contains("stroke") {
            "touches outside the strokes"
        } else {
            "touches the probe cannot make without collision (a face turned away or hidden, the stem, the table)"
        };
        match kinds.iter_mut().find(|k| k.0 == kind) {
            Some(k) => k.1 += 1,
            None => kinds.push((kind, 1, s.label.clone())),
        }
    }
    kinds
        .into_iter()
        .map(|(k, n, first)| {
            let mut note = format!("left out: {n} {k}, e.g. {first}");
            if k.starts_with("touches whose approach") {
                note.push_str(
                    "; with this control, give the template C angles that are multiples of 90 deg and columns without yaw, or use a postprocessor with an oblique probing cycle (`probe_axis_aligned: false`)",
                );
            }
            note
        })
        .collect()
}

/// Plans a probing test and renders its program (the configuration's
/// kinematics mode and tool do not apply: the program positions every axis
/// itself, with the machine file's probe).
pub fn plan(cfg: &PlanConfig) -> Result<ProbingPlan, PlanError> {
    let m = &cfg.machine;
    let post = &cfg.post;
    let limits = ControlLimits {
        axis_aligned_probing: post.probe_axis_aligned,
    };
    let (setup, what) = setup_of(m, &cfg.template)?;
    let plan = super::touch_plan(m, &cfg.template, &limits)?;
    let test = plan.test;
    let stem = test.to_string();

    // FANUC prints every recorded position through DPRNT's [44] field.
    if post.dialect == Dialect::Fanuc {
        for (i, mv) in plan.moves.iter().enumerate() {
            for w in [&mv.from, &mv.to] {
                if let Some(v) = w.axes.xyz.iter().find(|v| !fanuc::fits_field(**v)) {
                    return Err(PlanError::Impossible(format!(
                        "move {i} of the path reaches {v:.4} mm in program coordinates, more than DPRNT's [44] field prints"
                    )));
                }
            }
        }
    }

    let run_time = plan.run_time();
    let mut mesh_obstacles = plan.obstacles.clone();
    // The model shows the table's top slab, not its whole thickness.
    for o in &mut mesh_obstacles {
        if let (true, ConvexSolid::Cylinder { a, b, .. }) = (o.name == "table", &mut o.solid) {
            a.z = b.z - 10.0;
        }
    }
    let mesh = setup_mesh::setup_mesh(&mesh_obstacles);

    let mut notes = skipped_notes(&plan);
    notes.extend(plan.warnings.iter().cloned());
    // SINUMERIK's WRITE stops with error 10 (this program's alarm 65001)
    // once the log passes machine datum MD11420 LEN_PROTOCOL_FILE, in kB:
    // checked when the postprocessor states it, said when it does not.
    if post.dialect == Dialect::Sinumerik {
        let bytes = sinumerik_log_bytes(&plan, m.probe.ball_diameter / 2.0);
        let kb = (bytes as f64 / 1024.0).ceil();
        match post.log_limit_kb {
            Some(limit) if bytes as f64 > limit * 1024.0 => {
                return Err(PlanError::Impossible(format!(
                    "the probe log FIVECAL_{} will hold about {kb} kB ({} touches), more than the {limit} kB the postprocessor's log_limit_kb gives for the control's protocol files (MD11420 LEN_PROTOCOL_FILE): WRITE would stop the run with error 10; raise MD11420 to at least {kb} kB and log_limit_kb with it",
                    log_name(test).to_ascii_uppercase(),
                    plan.touches.len()
                )));
            }
            Some(_) => {}
            None => notes.push(format!(
                "the probe log FIVECAL_{} will hold about {kb} kB ({} touches): WRITE stops the run with error 10 (alarm 65001) when the control's protocol-file size MD11420 LEN_PROTOCOL_FILE is smaller; check it, or give it as log_limit_kb in a copy of the postprocessor to have the plan check it",
                log_name(test).to_ascii_uppercase(),
                plan.touches.len()
            )),
        }
    }
    let letter = m.tilt_letter();
    let safe_reason = match m.structure {
        Structure::TableTable => format!(
            "the probe clears the ball about the W origin that holds the setup, whatever {letter} and C do"
        ),
        _ => "the probe's reach about the head pivot clears the top of the setup, whatever the rotary axes do".to_string(),
    };
    let probe = m.probe.clone();
    let s = &plan.settings;
    let log = log_name(test);
    let log_where = match post.dialect {
        Dialect::Fanuc => "POPEN output (DPRNT)".to_string(),
        Dialect::Heidenhain => format!("TNC:\\fivecal\\{log}.txt (FN 16)"),
        Dialect::Linuxcnc => format!("{log}.log (LOGOPEN)"),
        Dialect::Sinumerik => format!("FIVECAL_{} (WRITE)", log.to_ascii_uppercase()),
    };
    let mut lines = vec![
        format!("fivecal plan: {test}: {what}"),
        format!(
            "{} poses, {} touches{}",
            plan.poses.len(),
            plan.touches.len(),
            if plan.skipped.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} left out where the probe cannot reach them, see the setup sheet)",
                    plan.skipped.len()
                )
            }
        ),
        format!("machine {}: {}", m.name, m.description),
        format!("dialect {}, postprocessor {}", post.dialect, post.name),
        format!(
            "probe {}: {}, ball D{}, gauge length {} mm; probing feed {} mm/min, positioning {} mm/min",
            probe.label(),
            probe.name,
            short(probe.ball_diameter),
            short(probe.length),
            short(s.feed),
            short(s.positioning_feed)
        ),
        format!(
            "no TCP, no tilted plane: X Y Z {letter} C computed by fivecal from the machine file"
        ),
        format!(
            "zero point: {} on the W origin at {letter} = C = 0, pivot of the machine file X{} Y{} Z{} (gauge point)",
            post.dialect.work_offset(),
            short(m.pivot.x),
            short(m.pivot.y),
            short(m.pivot.z)
        ),
    ];
    lines.extend(setup.describe());
    lines.push(format!(
        "safe height Z{}: {safe_reason}",
        short((plan.safe_z * 1000.0).round() / 1000.0)
    ));
    lines.push(format!(
        "log: {log_where}, one line per touch with its {} and the recorded position",
        if post.dialect == Dialect::Linuxcnc {
            "label"
        } else {
            "index (row of points.csv)"
        }
    ));
    lines.push(format!(
        "estimated run time {} min",
        short(run_time.total_min.round())
    ));
    let (stock_min, stock_max) = stock_box(&plan);
    let info = ProgramInfo {
        name: stem.clone(),
        number: program_number(test),
        title: format!("{test} {}", m.name),
        lines,
        stock_min,
        stock_max,
        tilt_letter: letter,
    };
    let toolpath = toolpath(&plan, &probe, log);
    let program = post.render(&info, &toolpath)?;
    Ok(ProbingPlan {
        test,
        machine: m.clone(),
        template: cfg.template.clone(),
        post: post.clone(),
        dialect: post.dialect,
        limits,
        probe,
        plan,
        setup,
        run_time,
        toolpath,
        info,
        program,
        mesh,
        notes,
        safe_reason,
    })
}
