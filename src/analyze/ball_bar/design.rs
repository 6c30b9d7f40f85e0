//! The parameters a ball-bar analysis identifies and the measurement
//! model that carries them to the readings.
//!
//! Parameters: every location error of the machine, and the six error
//! motions of each swept axis as maps over the angles of its sweep (the
//! tool's map symbols, `EXC(C)` ... `ECC(C)`; a map that also runs over the
//! other rotary axis has one node there, the angle that axis held). A map
//! can carry any location error of its axis (a constant map is a location
//! error), and on a head a map can carry an offset that turns with the
//! head (a spindle squareness, the head line's position relative to the
//! spindle). Each such pair is a gauge freedom of the parametrization,
//! not of the machine, and is fixed by a convention: the maps hold no part
//! along the pattern by which they would mimic a location error, so that
//! the location error is the part of the motion along its pattern (for a
//! constant pattern, the mean over the sweep: the average line) and the
//! map is the rest. What then still cannot be told apart is unseen
//! (`super::fit`).
//!
//! The reading: for setup `s` at angle `i`, the control's TCP commands the
//! axes that hold the nominal ball on M ([`commanded`]); the machine with
//! the parameters (and the linear axes' known errors) puts the ball at the
//! exact chain's tip; the spindle ball sits off the spindle axis by its
//! run-out; the bar reads the distance to N less its calibrated length.

use nalgebra::{DMatrix, DVector, Vector3};

use crate::formats::ball_bar::{BallBarManifest, SetupEntry};
use crate::kinematics::maps::{MapDim, MapGrid};
use crate::kinematics::{Kinematics, Perturbation};
use crate::machine::Machine;
use crate::model::{Context, Effect, Model};
use crate::procedure::ball_bar::predict::link_of;
use crate::simulate::ball_bar::{commanded, runout_w};

/// Relative size below which a singular value counts as zero.
pub(crate) const RANK_TOL: f64 = 1e-7;

/// The linear axes' errors known from an error file: a model holding only
/// its scale, squareness and straightness effects, with their values.
#[derive(Clone, Debug)]
pub struct KnownLinear {
    /// One model per gauge length, in the order of [`Design::gauges`].
    pub models: Vec<Model>,
    /// Their values.
    pub theta: Vec<f64>,
}

/// The spindle ball's run-out as measured (the setup sheet's dial
/// indicator check): removed from every reading.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Runout {
    /// Distance of the ball centre from the spindle axis, um.
    pub um: f64,
    /// Direction in the oriented spindle, from its X towards its Y, deg.
    pub phase_deg: f64,
}

/// One reading of one run.
#[derive(Clone, Debug)]
pub struct Reading {
    /// Index of the setup in the plan.
    pub setup: usize,
    /// Index of the angle in the setup's sweep.
    pub step: usize,
    /// Index of the gauge length (arbor) in [`Design::gauges`].
    pub gauge: usize,
    /// The bar's length minus its calibrated length, um, as read.
    pub um: f64,
}

/// The parameters and the measurement model.
#[derive(Clone, Debug)]
pub struct Design {
    /// The plan.
    pub plan: BallBarManifest,
    /// The gauge lengths of the arbors, mm, in order of first use.
    pub gauges: Vec<f64>,
    /// One model per gauge length (the same effects and parameters).
    pub models: Vec<Model>,
    /// Index of the location effect's first parameter and their number.
    pub location: std::ops::Range<usize>,
    /// The swept axes' letters, in plan order.
    pub axes: Vec<char>,
    /// The machine's tilt-axis letter.
    pub tilt: char,
    /// The convention's constraints, one row per location error a map can
    /// carry: `a^T theta = 0` over the map parameters.
    pub constraints: DMatrix<f64>,
    /// Per constraint row, the parameter it belongs to (a location error,
    /// or a pinned map node).
    pub constrained: Vec<usize>,
    /// The null directions of the design without the convention, in
    /// parameter units (what [`Design::conventional`] moves along).
    pub null: Vec<DVector<f64>>,
    /// The map nodes the convention pins to zero (the other axis' error
    /// motion at the angle it held): zero by definition, not measured.
    pub pinned: Vec<usize>,
}

/// The angle variable (0 tilt, 1 C) of axis `letter` on `m`.
fn angle_var(m: &Machine, letter: char) -> usize {
    if letter == m.tilt.letter { 0 } else { 1 }
}

impl Design {
    /// The design of `plan` on `machine`.
    pub fn new(plan: &BallBarManifest, machine: &Machine) -> Result<Design, String> {
        let mut gauges: Vec<f64> = Vec::new();
        for s in &plan.setups {
            if !gauges.iter().any(|g| (g - s.gauge_mm).abs() < 1e-12) {
                gauges.push(s.gauge_mm);
            }
        }
        let kin0 = Kinematics::with_gauge_length(machine, gauges[0]);
        let base = Model::new(kin0.clone(), Vec::new());
        let sym = base.symbols.clone();
        let mut effects = vec![Effect::Location {
            symbols: (0..sym.location.len()).collect(),
        }];
        let mut axes: Vec<char> = Vec::new();
        for s in &plan.setups {
            if !axes.contains(&s.axis) {
                axes.push(s.axis);
            }
        }
        for &letter in &axes {
            let mine: Vec<&SetupEntry> = plan.setups.iter().filter(|s| s.axis == letter).collect();
            let swept = angle_var(machine, letter);
            let held = mine[0].held_deg;
            if mine.iter().any(|s| (s.held_deg - held).abs() > 1e-9) {
                return Err(format!(
                    "the setups of {letter} hold the other axis at different angles: one map per axis needs one"
                ));
            }
            let mut nodes: Vec<f64> = mine
                .iter()
                .flat_map(|s| s.angles.iter().copied())
                .map(|a| if swept == 1 { a.rem_euclid(360.0) } else { a })
                .collect();
            nodes.sort_by(f64::total_cmp);
            nodes.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
            let link = link_of(&kin0, letter);
            for comp in 0..6 {
                let slot = 6 * link + comp;
                let Some(mi) = sym.maps.iter().position(|m| m.slot == slot) else {
                    return Err(format!(
                        "the machine has no map symbol for the {letter} axis"
                    ));
                };
                let dims = sym.maps[mi]
                    .deps
                    .iter()
                    .map(|&d| {
                        let n = if d == swept {
                            nodes.clone()
                        } else {
                            vec![held]
                        };
                        MapDim::new(d, &n, d == 1).map_err(|e| format!("{letter}: {e}"))
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                effects.push(Effect::Map {
                    symbol: mi,
                    grid: MapGrid { dims },
                });
            }
        }
        let models: Vec<Model> = gauges
            .iter()
            .map(|&g| Model::new(Kinematics::with_gauge_length(machine, g), effects.clone()))
            .collect();
        let location = models[0].param_range(0);
        let mut d = Design {
            plan: plan.clone(),
            gauges,
            models,
            location,
            axes,
            tilt: machine.tilt.letter,
            constraints: DMatrix::zeros(0, 0),
            constrained: Vec::new(),
            null: Vec::new(),
            pinned: Vec::new(),
        };
        d.convention();
        Ok(d)
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.models[0].n_params()
    }

    /// The model of the first arbor (names, symbols, effects).
    pub fn model(&self) -> &Model {
        &self.models[0]
    }

    /// Index of the gauge length of setup `s`.
    pub fn gauge_of(&self, s: &SetupEntry) -> usize {
        self.gauges
            .iter()
            .position(|g| (g - s.gauge_mm).abs() < 1e-12)
            .expect("every setup's gauge is listed")
    }

    /// Every reading's place, with zero as its value (the design's rows).
    pub fn rows(&self) -> Vec<Reading> {
        let mut v = Vec::new();
        for (k, s) in self.plan.setups.iter().enumerate() {
            let gauge = self.gauge_of(s);
            for step in 0..s.angles.len() {
                v.push(Reading {
                    setup: k,
                    step,
                    gauge,
                    um: 0.0,
                });
            }
        }
        v
    }

    /// The predicted reading (um) and its derivative with respect to every
    /// parameter (um per parameter unit), exact.
    pub fn predict(
        &self,
        r: &Reading,
        theta: &[f64],
        known: Option<&KnownLinear>,
        runout: &Runout,
    ) -> (f64, DVector<f64>) {
        let s = &self.plan.setups[r.setup];
        let model = &self.models[r.gauge];
        let kin = &model.kin;
        let axes = commanded(kin, s, r.step);
        let ctx = Context::at(axes);
        let mut p = model.perturbation(theta, &ctx);
        if let Some(k) = known {
            let q = k.models[r.gauge].perturbation(&k.theta, &ctx);
            add(&mut p, &q);
        }
        let (j, jt, _) = model.pose_jacobian_with(&p, &ctx);
        let off = runout_w(kin, axes.tilt, axes.c, runout.um, runout.phase_deg);
        let v = j.pose.tip + off - Vector3::from(s.table_ball);
        let len = v.norm();
        let u = v / len;
        let row = (u.transpose() * jt).transpose() * 1000.0;
        ((len - s.bar_mm) * 1000.0, row)
    }

    /// The derivative of the reading `r` with respect to the run-out's two
    /// components in the oriented spindle (X, Y), um per um.
    pub fn runout_row(&self, r: &Reading) -> [f64; 2] {
        let s = &self.plan.setups[r.setup];
        let kin = &self.models[r.gauge].kin;
        let axes = commanded(kin, s, r.step);
        let u = (Vector3::from(s.spindle_ball) - Vector3::from(s.table_ball)).normalize();
        [0.0, 90.0].map(|ph| u.dot(&runout_w(kin, axes.tilt, axes.c, 1.0, ph)) * 1000.0)
    }

    /// The Jacobian of every reading at `theta`.
    pub fn jacobian(
        &self,
        rows: &[Reading],
        theta: &[f64],
        known: Option<&KnownLinear>,
        runout: &Runout,
    ) -> (DVector<f64>, DMatrix<f64>) {
        let n = self.n_params();
        let mut f = DVector::zeros(rows.len());
        let mut j = DMatrix::zeros(rows.len(), n);
        for (i, r) in rows.iter().enumerate() {
            let (y, g) = self.predict(r, theta, known, runout);
            f[i] = y;
            j.set_row(i, &g.transpose());
        }
        (f, j)
    }

    /// The convention's constraints (see the module's text): for each
    /// location error whose effect on the readings a combination `a` of
    /// the maps reproduces, the row `a` over the map parameters; then the
    /// pins of the gauge between the two axes ([`Design::pins`]).
    fn convention(&mut self) {
        let rows = self.rows();
        let n = self.n_params();
        let zero = vec![0.0; n];
        let (_, j) = self.jacobian(&rows, &zero, None, &Runout::default());
        let mut rows_c: Vec<DVector<f64>> = Vec::new();
        let mut constrained = Vec::new();
        let names = self.model().symbols.location.clone();
        for l in self.location.clone() {
            let jl = j.column(l).into_owned();
            let norm = jl.norm();
            // The maps of the location error's own axis: its letter, or
            // the head's for the spindle's squareness to it (`EA(0B)S`).
            let name = &names[l - self.location.start].name;
            let mut letter = name.chars().last().unwrap_or('S');
            if letter == 'S' {
                letter = self.tilt;
            }
            let Some(ax) = self.axes.iter().position(|&a| a == letter) else {
                continue;
            };
            let maps: Vec<usize> = (self.location.end..n)
                .filter(|&c| self.axis_of_param(c) == Some(ax))
                .collect();
            if norm == 0.0 || maps.is_empty() {
                continue;
            }
            let jm = DMatrix::from_fn(j.nrows(), maps.len(), |r, c| j[(r, maps[c])]);
            let svd = jm.clone().svd(true, true);
            let smax = svd.singular_values.max();
            let a = svd
                .solve(&jl, smax * RANK_TOL)
                .expect("the SVD has both factors");
            let resid = (&jm * &a - &jl).norm() / norm;
            if resid > 1e-6 {
                continue;
            }
            let mut row = DVector::zeros(n);
            for (c, &p) in maps.iter().enumerate() {
                row[p] = a[c];
            }
            rows_c.push(row);
            constrained.push(l);
        }
        for k in self.pins(&j, &rows, &rows_c) {
            let mut row = DVector::zeros(n);
            row[k] = 1.0;
            rows_c.push(row);
            constrained.push(k);
        }
        self.pinned = constrained
            .iter()
            .copied()
            .filter(|k| !self.location.contains(k))
            .collect();
        self.constraints = DMatrix::from_fn(rows_c.len(), n, |r, c| rows_c[r][c]);
        self.constrained = constrained;
        self.null = null_space(&j, &DMatrix::identity(n, n));
    }

    /// The gauge between the two axes: each axis' sweep sees the other
    /// axis' maps only at the angle it holds, so a displacement common to
    /// the table and the head (a rigid motion of the whole machine, which
    /// no bar sees) can move from one axis' maps to the other's. It is
    /// fixed by pinning the other axis' error motion at the held angle to
    /// zero, a term at a time and only where the pin removes such a
    /// freedom; a term its own sweep cannot see stays unpinned (and
    /// unseen): no convention makes it seen.
    fn pins(&self, j: &DMatrix<f64>, rows: &[Reading], fixed: &[DVector<f64>]) -> Vec<usize> {
        let n = self.n_params();
        let model = self.model();
        let m = self.tilt;
        let mut candidates: Vec<usize> = Vec::new();
        for (ai, &a) in self.axes.iter().enumerate() {
            let setup = self
                .plan
                .setups
                .iter()
                .find(|s| s.axis == a)
                .expect("an axis has setups");
            for (bi, &b) in self.axes.iter().enumerate() {
                if bi == ai {
                    continue;
                }
                let bvar = if b == m { 0 } else { 1 };
                for (e, eff) in model.effects.iter().enumerate() {
                    let Effect::Map { grid, .. } = eff else {
                        continue;
                    };
                    if self.axis_of_effect(e) != Some(bi) {
                        continue;
                    }
                    let r = model.param_range(e);
                    for (i, k) in r.enumerate() {
                        let at = grid.node_angles(i);
                        let on = at.iter().any(|&(v, x)| {
                            v == bvar && {
                                let d = (x - setup.held_deg).rem_euclid(360.0);
                                d.min(360.0 - d) < 1e-9
                            }
                        });
                        if on {
                            candidates.push(k);
                        }
                    }
                }
            }
        }
        // What each axis' own sweep sees of its own maps: once per axis.
        let mut own_seen = vec![true; n];
        for ax in 0..self.axes.len() {
            let rs: Vec<usize> = (0..rows.len())
                .filter(|&i| self.plan.setups[rows[i].setup].axis == self.axes[ax])
                .collect();
            let cols: Vec<usize> = (0..n)
                .filter(|&c| self.axis_of_param(c) == Some(ax))
                .collect();
            let sub = DMatrix::from_fn(rs.len(), cols.len(), |r, c| j[(rs[r], cols[c])]);
            let null = null_space(&sub, &DMatrix::identity(cols.len(), cols.len()));
            for (at, &k) in cols.iter().enumerate() {
                own_seen[k] = null.iter().all(|v| v[at].abs() < 1e-6);
            }
        }
        let mut pins: Vec<usize> = Vec::new();
        // The null directions with the constraints so far: computed again
        // only when a pin is added.
        let current = |pins: &[usize]| {
            let mut c: Vec<DVector<f64>> = fixed.to_vec();
            for &p in pins {
                let mut row = DVector::zeros(n);
                row[p] = 1.0;
                c.push(row);
            }
            let cm = DMatrix::from_fn(c.len(), n, |r, q| c[r][q]);
            null_space(j, &null_basis(&cm, n))
        };
        let mut null = current(&pins);
        for k in candidates {
            if own_seen[k] && null.iter().any(|v| v[k].abs() > 1e-6) {
                pins.push(k);
                null = current(&pins);
            }
        }
        pins
    }

    /// Which swept axis (index into `axes`) map effect `e` belongs to.
    fn axis_of_effect(&self, e: usize) -> Option<usize> {
        (e > 0).then(|| (e - 1) / 6)
    }

    /// Which swept axis a parameter's map belongs to (`None`: a location
    /// error).
    fn axis_of_param(&self, k: usize) -> Option<usize> {
        let model = self.model();
        (1..model.effects.len())
            .find(|&e| model.param_range(e).contains(&k))
            .and_then(|e| self.axis_of_effect(e))
    }

    /// The basis of the parameters the convention allows (columns), the
    /// null space of the constraints.
    pub fn allowed(&self) -> DMatrix<f64> {
        null_basis(&self.constraints, self.n_params())
    }

    /// The parameters `theta` of any machine written in the convention:
    /// the same readings to first order (moved along the design's null
    /// directions only), the constraints holding. A truth given as
    /// location errors and maps of any shape has one value in the
    /// convention for every seen parameter; this is what the analysis
    /// should find.
    pub fn conventional(&self, theta: &[f64]) -> Vec<f64> {
        let k = self.constraints.nrows();
        let t = DVector::from_column_slice(theta);
        if k == 0 || self.null.is_empty() {
            return theta.to_vec();
        }
        let z = DMatrix::from_fn(self.n_params(), self.null.len(), |r, c| self.null[c][r]);
        let cz = &self.constraints * &z;
        let rhs = -(&self.constraints * &t);
        let c = cz
            .svd(true, true)
            .solve(&rhs, 1e-10)
            .expect("the SVD has both factors");
        (t + z * c).iter().copied().collect()
    }
}

/// Column scales: each column's norm, and infinity for a column no
/// reading sees (numerically: below 1e-12 of the largest), whose
/// direction is then dropped rather than blown up to a unit column of
/// rounding noise.
pub(crate) fn scaled(norms: &[f64]) -> Vec<f64> {
    let big = norms.iter().cloned().fold(0.0, f64::max);
    norms
        .iter()
        .map(|&v| if v > big * 1e-12 { v } else { f64::INFINITY })
        .collect()
}

/// The divisor of a column's entries in the parameters: its scale, or 1
/// for a column no reading sees (its direction kept as it is).
pub(crate) fn unit(scale: f64) -> f64 {
    if scale.is_finite() { scale } else { 1.0 }
}

/// The null space of `c` (rows: constraints over `n` parameters), as
/// columns.
fn null_basis(c: &DMatrix<f64>, n: usize) -> DMatrix<f64> {
    if c.nrows() == 0 {
        return DMatrix::identity(n, n);
    }
    let ctc = c.transpose() * c;
    let eig = ctc.symmetric_eigen();
    let lmax = eig.eigenvalues.max().max(f64::MIN_POSITIVE);
    let keep: Vec<usize> = (0..n)
        .filter(|&i| eig.eigenvalues[i] <= lmax * 1e-12)
        .collect();
    DMatrix::from_fn(n, keep.len(), |r, q| eig.eigenvectors[(r, keep[q])])
}

/// The null directions of `j` within the columns of `basis` (parameters
/// `basis * w`), in parameter units: columns scaled to unit norm first,
/// so that a lever of 500 mm is no rank of its own against a unit
/// translation.
pub(crate) fn null_space(j: &DMatrix<f64>, basis: &DMatrix<f64>) -> Vec<DVector<f64>> {
    let a = j * basis;
    let scale: Vec<f64> = (0..a.ncols()).map(|c| a.column(c).norm()).collect();
    let scale = scaled(&scale);
    let a = DMatrix::from_fn(a.nrows(), a.ncols(), |r, c| {
        if scale[c].is_finite() {
            a[(r, c)] / scale[c]
        } else {
            0.0
        }
    });
    let eig = (a.transpose() * &a).symmetric_eigen();
    let lmax = eig.eigenvalues.max().max(f64::MIN_POSITIVE);
    (0..a.ncols())
        .filter(|&i| eig.eigenvalues[i] <= lmax * RANK_TOL * RANK_TOL)
        .map(|i| {
            let w = DVector::from_fn(a.ncols(), |r, _| eig.eigenvectors[(r, i)] / unit(scale[r]));
            let t = basis * w;
            let big = t.amax();
            if big > 0.0 { t / big } else { t }
        })
        .collect()
}

fn add(p: &mut Perturbation, q: &Perturbation) {
    for (a, b) in p.0.iter_mut().zip(q.0.iter()) {
        *a += b;
    }
}
