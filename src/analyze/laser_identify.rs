//! The linear axes' errors from the laser's lines (Jiang et al. 2013's
//! ten-line method on fivecal's one model): for each linear axis, its
//! positioning map and the two angular maps that have a lever arm across
//! its lines (pitch and yaw), each over the axis's position at the lines'
//! targets, by generalized least squares on the exact model's lines.
//!
//! A line's reading is the displacement of its measured point along the
//! line relative to target 0; on the model it is linear in the maps
//! (`positioning + (eps x lever) . direction`, the lever from the machine's
//! chain and the line's offset), so one solve is the answer, nothing to
//! iterate. Each map is relative to its first node (the reading's zero):
//! the value there is 0 with u 0. What the lines do not determine is found
//! on the design itself (a parameter is determined when its unit vector
//! lies in the row space) and named with what would measure it, never
//! given a number: the rolls (no line has a lever about its own
//! direction), the six straightnesses (they move the point across the
//! beam), the three squarenesses apart (one diagonal sees one combination,
//! mixed with the straightnesses' and rolls' share along it), and the maps
//! an absent offset line would have separated.
//!
//! u: each reading carries the plan's `reading_u_um` (a mean of the 2 n
//! readings at a target carries it over sqrt(2 n)), the line's zero (the
//! first reading, set to 0) carries it into every reading of the line, and
//! the laser's length term (`length_u_ppm` of the distance from target 0)
//! is common to a line; the covariance of each line's means holds all
//! three, and the least squares propagates it.

use nalgebra::{DMatrix, DVector, Vector3};

use crate::errorfile::{ErrorFile, MapEntry, NotIdentified, Values};
use crate::formats::laser::{LaserManifest, LineEntry};
use crate::geom::Axis3;
use crate::kinematics::Kinematics;
use crate::machine::Machine;
use crate::model::{Effect, Model};
use crate::simulate::laser::line_context;

const AXES: [Axis3; 3] = [Axis3::X, Axis3::Y, Axis3::Z];

/// One measured line: its plan entry, the mean bidirectional deviation at
/// each target (um) and the runs each way they rest on.
#[derive(Clone, Debug)]
pub struct MeasuredLine<'a> {
    /// The plan's line.
    pub line: &'a LineEntry,
    /// Mean deviation per target, um.
    pub means_um: Vec<f64>,
    /// Runs in each direction.
    pub runs: usize,
}

/// One identified map.
#[derive(Clone, Debug, PartialEq)]
pub struct IdentifiedMap {
    /// ISO 230-1 symbol (`EXX`, `EBX`, ...).
    pub symbol: String,
    /// The axis it runs over.
    pub axis: Axis3,
    /// Node positions, program coordinates, mm.
    pub nodes: Vec<f64>,
    /// Values, um or urad, the first 0.
    pub values: Vec<f64>,
    /// Standard uncertainties.
    pub u: Vec<f64>,
    /// `um` or `urad`.
    pub unit: &'static str,
}

/// What the lines give.
#[derive(Clone, Debug)]
pub struct Identification {
    /// The errors the lines determine, in their order.
    pub maps: Vec<IdentifiedMap>,
    /// What they do not, each with what would measure it.
    pub unseen: Vec<NotIdentified>,
    /// The lines used.
    pub lines_used: Vec<String>,
}

/// Why the identification cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// A line whose targets do not match its axis's other lines.
    #[error("{0}")]
    Lines(String),
}

fn symbol(about: Axis3, moving: Axis3) -> String {
    if about == moving {
        format!("E{0}{0}", moving.letter())
    } else {
        format!("E{}{}", rot_letter(about), moving.letter())
    }
}

fn rot_letter(a: Axis3) -> char {
    match a {
        Axis3::X => 'A',
        Axis3::Y => 'B',
        Axis3::Z => 'C',
    }
}

/// The covariance (um^2) of a line's mean deviations at `targets` (mm):
/// the means of 2 `runs` readings of u `ur`, all less the first reading,
/// and the length term `ppm` of the distance from target 0, common to
/// the line.
pub fn line_covariance(targets: &[f64], runs: usize, ur: f64, ppm: f64) -> DMatrix<f64> {
    let n = targets.len();
    let m = (2 * runs) as f64;
    let s2 = ur * ur;
    DMatrix::from_fn(n, n, |i, j| {
        // Cov(mean_i - z, mean_j - z) with z the first reading, which is
        // one of the readings at target 0.
        let mut c = s2;
        if i == j {
            c += s2 / m;
        }
        if i == 0 {
            c -= s2 / m;
        }
        if j == 0 {
            c -= s2 / m;
        }
        let li = ppm * 1e-3 * (targets[i] - targets[0]);
        let lj = ppm * 1e-3 * (targets[j] - targets[0]);
        c + li * lj
    })
}

/// Identifies what `lines` determine on `machine` (the plan's instrument
/// uncertainty in `plan`).
pub fn identify(
    plan: &LaserManifest,
    machine: &Machine,
    lines: &[MeasuredLine],
) -> Result<Identification, IdentifyError> {
    let kin = Kinematics::with_gauge_length(machine, 0.0);
    let mut maps = Vec::new();
    let mut unseen = Vec::new();
    for (a, &axis) in AXES.iter().enumerate() {
        let own: Vec<&MeasuredLine> = lines
            .iter()
            .filter(|l| l.line.axes == axis.letter().to_string())
            .collect();
        let across: Vec<Axis3> = AXES.iter().copied().filter(|&b| b != axis).collect();
        let candidates: Vec<(Axis3, String)> = std::iter::once((axis, symbol(axis, axis)))
            .chain(across.iter().map(|&b| (b, symbol(b, axis))))
            .collect();
        if own.is_empty() {
            for (_, s) in &candidates {
                unseen.push(NotIdentified {
                    symbol: s.clone(),
                    reason: format!(
                        "no line along {} was measured (the plan's lines along {} give it)",
                        axis.letter(),
                        axis.letter()
                    ),
                });
            }
            continue;
        }
        // Nodes: the axis's position at the first line's targets.
        let first = own[0].line;
        let nodes: Vec<f64> = (0..first.targets.len())
            .map(|i| line_context(machine, first, i).axes.xyz[a])
            .collect();
        for l in &own[1..] {
            let same = l.line.targets.len() == nodes.len()
                && (0..nodes.len()).all(|i| {
                    (line_context(machine, l.line, i).axes.xyz[a] - nodes[i]).abs() < 1e-3
                });
            if !same {
                return Err(IdentifyError::Lines(format!(
                    "line {} does not run through the positions of {} along {} (its targets differ): the maps need the lines of an axis at the same positions",
                    l.line.name,
                    first.name,
                    axis.letter()
                )));
            }
        }
        let effects: Vec<Effect> = std::iter::once(Effect::Positioning {
            axis,
            nodes: nodes.clone(),
        })
        .chain(across.iter().map(|&b| Effect::Angular {
            about: b,
            moving: axis,
            nodes: nodes.clone(),
        }))
        .collect();
        let model = Model::new(kin.clone(), effects);
        let np = model.n_params();
        let nn = nodes.len();
        let zero = vec![0.0; np];
        // Design (readings x parameters) and data, whitened line by line.
        let mut rows: Vec<DVector<f64>> = Vec::new();
        let mut data: Vec<f64> = Vec::new();
        for l in &own {
            let u = Vector3::from(l.line.direction);
            let grad = |i: usize| -> DVector<f64> {
                let (_, jt, _) = model.pose_jacobian(&zero, &line_context(machine, l.line, i));
                // mm per parameter unit, read in um.
                DVector::from_fn(np, |c, _| {
                    1000.0 * (jt[(0, c)] * u.x + jt[(1, c)] * u.y + jt[(2, c)] * u.z)
                })
            };
            let g0 = grad(0);
            let mut a_line = DMatrix::zeros(nn, np);
            for i in 0..nn {
                let gi = grad(i) - &g0;
                a_line.set_row(i, &gi.transpose());
            }
            let cov = line_covariance(
                &l.line.targets,
                l.runs,
                plan.reading_u_um,
                plan.length_u_ppm,
            );
            let chol = cov
                .cholesky()
                .expect("a line's covariance is positive definite");
            let aw = chol.l().solve_lower_triangular(&a_line).expect("lower");
            let dw = chol
                .l()
                .solve_lower_triangular(&DVector::from_column_slice(&l.means_um))
                .expect("lower");
            for i in 0..nn {
                rows.push(aw.row(i).transpose());
                data.push(dw[i]);
            }
        }
        // Node 0 of every map is the zero: dropped from the unknowns.
        let keep: Vec<usize> = (0..np).filter(|c| c % nn != 0).collect();
        let a_mat = DMatrix::from_fn(rows.len(), keep.len(), |r, k| rows[r][keep[k]]);
        let d = DVector::from_vec(data);
        let n_mat = a_mat.transpose() * &a_mat;
        let b = a_mat.transpose() * &d;
        let eig = n_mat.clone().symmetric_eigen();
        let top = eig.eigenvalues.iter().fold(0.0f64, |m, &v| m.max(v));
        let mut pinv = DMatrix::zeros(keep.len(), keep.len());
        for (k, &lam) in eig.eigenvalues.iter().enumerate() {
            if lam > 1e-10 * top {
                let v = eig.eigenvectors.column(k);
                pinv += (v * v.transpose()) / lam;
            }
        }
        let theta = &pinv * b;
        let proj = &pinv * &n_mat;
        let names: Vec<&str> = own.iter().map(|l| l.line.name.as_str()).collect();
        for (m, (about, sym)) in candidates.iter().enumerate() {
            let cols: Vec<usize> = (0..keep.len()).filter(|&k| keep[k] / nn == m).collect();
            let determined = cols.iter().all(|&k| {
                let mut e = DVector::zeros(keep.len());
                e[k] = 1.0;
                (&proj * &e - e).norm() < 1e-6
            });
            if !determined {
                let what = if *about == axis {
                    "the positioning".to_string()
                } else {
                    format!("the turn about {}", about.letter())
                };
                unseen.push(NotIdentified {
                    symbol: sym.clone(),
                    reason: format!(
                        "the lines measured along {} ({}) see {what} only together with another error of {}: the plan's other lines along {} (offset across it) separate it",
                        axis.letter(),
                        names.join(", "),
                        axis.letter(),
                        axis.letter()
                    ),
                });
                continue;
            }
            let mut values = vec![0.0];
            let mut u = vec![0.0];
            for &k in &cols {
                values.push(theta[k]);
                u.push(pinv[(k, k)].max(0.0).sqrt());
            }
            maps.push(IdentifiedMap {
                symbol: sym.clone(),
                axis,
                nodes: nodes.clone(),
                values,
                u,
                unit: if *about == axis { "um" } else { "urad" },
            });
        }
    }
    for (about, moving, how) in [
        (
            Axis3::X,
            Axis3::X,
            "an electronic level on the carriage as X moves",
        ),
        (
            Axis3::Y,
            Axis3::Y,
            "an electronic level on the carriage as Y moves",
        ),
        (
            Axis3::Z,
            Axis3::Z,
            "two indicators on a square or straightedge at two heights as Z moves",
        ),
    ] {
        unseen.push(NotIdentified {
            symbol: format!("E{}{}", rot_letter(about), moving.letter()),
            reason: format!(
                "roll: a turn about the line's own direction has no lever arm along it, no line sees it ({how} measures it)"
            ),
        });
    }
    for (dir, moving) in [
        (Axis3::Y, Axis3::X),
        (Axis3::Z, Axis3::X),
        (Axis3::X, Axis3::Y),
        (Axis3::Z, Axis3::Y),
        (Axis3::X, Axis3::Z),
        (Axis3::Y, Axis3::Z),
    ] {
        unseen.push(NotIdentified {
            symbol: format!("E{}{}", dir.letter(), moving.letter()),
            reason: "straightness: it moves the point across the beam, which a positioning reading does not see (the interferometer's straightness optics or a straightedge with an indicator measure it)".into(),
        });
    }
    let diagonal = lines.iter().any(|l| l.line.axes == "XYZ");
    for s in ["EC(0X)Y", "EB(0X)Z", "EA(0Y)Z"] {
        unseen.push(NotIdentified {
            symbol: s.into(),
            reason: if diagonal {
                "squareness: the diagonal L10 sees one combination of the three, mixed with the straightnesses' and rolls' share along it; fivecal gives no number for it (the four body diagonals of ISO 230-6 with the straightnesses known, or a ball bar in the three planes, separate them)".into()
            } else {
                "squareness: only the diagonal L10 sees it (one combination of the three); the four body diagonals of ISO 230-6 with the straightnesses known, or a ball bar in the three planes, separate them".into()
            },
        });
    }
    Ok(Identification {
        maps,
        unseen,
        lines_used: lines
            .iter()
            .filter(|l| l.line.axes != "XYZ")
            .map(|l| l.line.name.clone())
            .collect(),
    })
}

impl Identification {
    /// The error file of what the lines determine (positioning and angular
    /// maps with u), the unseen listed under `not_identifiable`.
    pub fn error_file(&self, machine: &str) -> ErrorFile {
        let mut f = ErrorFile {
            machine: machine.to_string(),
            test: Some("laser-lines".into()),
            location_errors: Default::default(),
            position_dependent: Default::default(),
            effects: Default::default(),
            not_identifiable: self.unseen.clone(),
            fit: None,
            uncertainty: None,
            seen_not_usefully: Vec::new(),
            ambiguity: None,
            circularity: Vec::new(),
        };
        for m in &self.maps {
            let mut nodes = indexmap::IndexMap::new();
            nodes.insert(m.axis.letter().to_string(), m.nodes.clone());
            let entry = MapEntry {
                nodes,
                values: Values::Flat(m.values.clone()),
                u: Some(Values::Flat(m.u.clone())),
            };
            if m.unit == "um" {
                f.effects.positioning.insert(m.symbol.clone(), entry);
            } else {
                f.effects.angular.insert(m.symbol.clone(), entry);
            }
        }
        f
    }

    /// The terminal's account: what is not seen first, then the maps.
    pub fn render(&self) -> String {
        let mut s = String::new();
        s.push_str(&format!(
            "linear-axis errors from the lines {} (each map relative to its first node, where the reading was set to zero; u standard, k = 1):\n",
            self.lines_used.join(", ")
        ));
        s.push_str("not determined by these lines (no number is given for them):\n");
        for n in &self.unseen {
            s.push_str(&format!("  {}: {}\n", n.symbol, n.reason));
        }
        for m in &self.maps {
            let peak = m
                .values
                .iter()
                .zip(&m.u)
                .max_by(|x, y| x.0.abs().total_cmp(&y.0.abs()))
                .map(|(v, u)| (*v, *u))
                .unwrap_or((0.0, 0.0));
            let umax = m.u.iter().fold(0.0f64, |a, &b| a.max(b));
            s.push_str(&format!(
                "  {} over {} = {:.1} .. {:.1} mm ({} nodes): largest {:.3} {} (u {:.3}), u up to {:.3} {}\n",
                m.symbol,
                m.axis.letter(),
                m.nodes[0],
                m.nodes[m.nodes.len() - 1],
                m.nodes.len(),
                peak.0,
                m.unit,
                peak.1,
                umax,
                m.unit
            ));
        }
        s
    }
}
