//! What the runs will identify, before anything is measured: per rotary
//! axis and per angle of its sweep, the bar length of every setup that
//! reaches the angle, differentiated with respect to the axis' six error
//! terms at that angle (the exact Jacobian of the kinematic chain, tip in
//! W projected on the bar), and the least-squares uncertainty of each term
//! from the bar's noise and calibration: `u_k = sigma sqrt((J^T J)^-1_kk)`.
//! Terms along a null direction of J (no setup sees them at that angle)
//! are named as unseen instead of given a number.
//!
//! The readings are taken as the bar length minus its calibrated length,
//! so the table ball's placement on its post is taken as known (the bar
//! is set between the balls after the spindle ball has been brought onto
//! M, as the paper does); its error adds to every reading of a run alike.

use nalgebra::{DMatrix, Vector3};

use super::{BallBarRequest, Setup, setup_kinematics};
use crate::kinematics::symbols::SymbolTable;
use crate::kinematics::{Perturbation, SLOT_LIN};

/// The prediction for one axis.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisPrediction {
    /// The axis letter.
    pub axis: char,
    /// The six symbols of its error motions (`EXC(C)`, ... as the error
    /// files name the map terms), in slot order dx, dy, dz, a, b, c.
    pub symbols: Vec<String>,
    /// um or urad, per symbol.
    pub units: Vec<&'static str>,
    /// The largest predicted u over the sweep, per symbol; `None`: unseen
    /// at some angle.
    pub u_max: Vec<Option<f64>>,
    /// Angles at which a symbol is unseen, per symbol.
    pub unseen_at: Vec<Vec<f64>>,
    /// Rank of the per-angle design, smallest over the sweep.
    pub rank: usize,
    /// Setups of the axis.
    pub setups: usize,
    /// The angles of the sweep (union of the setups'), deg.
    pub angles: Vec<f64>,
}

/// The prediction for every planned axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// Standard deviation of one reading used, um (noise and calibration
    /// combined).
    pub sigma_um: f64,
    /// Per axis, in plan order.
    pub axes: Vec<AxisPrediction>,
}

/// The derivative of setup `s`'s bar length (um) at angle `i` with
/// respect to the six terms of the link of its axis (um and urad), from
/// the chain's exact Jacobian.
pub fn length_row(req: &BallBarRequest, s: &Setup, i: usize) -> [f64; 6] {
    let kin = setup_kinematics(&req.machine, s.gauge);
    let link = link_of(&kin, s.axis);
    let j = kin.jacobian(&s.axes[i], &Perturbation::zero());
    let u: Vector3<f64> = (s.m - s.n).normalize();
    let mut row = [0.0; 6];
    for (k, r) in row.iter_mut().enumerate() {
        let col = j.tip.column(5 + 6 * link + k);
        let d = u.dot(&col.into_owned());
        // mm per mm is um per um; mm per rad is 1e-3 um per urad.
        *r = if k < 3 { d } else { d * 1e-3 };
    }
    row
}

/// The index of the link carrying the error terms of axis `letter`.
pub fn link_of(kin: &crate::kinematics::Kinematics, letter: char) -> usize {
    kin.links()
        .iter()
        .position(|l| l.child == letter)
        .expect("every rotary axis has a link")
}

/// Predicts every axis of the setups.
pub fn predict(req: &BallBarRequest, setups: &[Setup]) -> Prediction {
    let sigma = (req.noise_um.powi(2) + req.calibration_um.powi(2)).sqrt();
    let mut axes = Vec::new();
    let mut letters: Vec<char> = setups.iter().map(|s| s.axis).collect();
    letters.dedup();
    for letter in letters {
        let mine: Vec<&Setup> = setups.iter().filter(|s| s.axis == letter).collect();
        let kin = setup_kinematics(&req.machine, mine[0].gauge);
        let link = link_of(&kin, letter);
        let table = SymbolTable::for_kinematics(&kin);
        let symbols: Vec<String> = (0..6)
            .map(|k| {
                let slot = 6 * link + k;
                table
                    .maps
                    .iter()
                    .find(|m| m.slot == slot)
                    .map(|m| m.name.clone())
                    .unwrap_or_else(|| kin.slot_name(slot).unwrap_or_default())
            })
            .collect();
        debug_assert!(6 * link + 5 < SLOT_LIN);
        let mut angles: Vec<f64> = mine.iter().flat_map(|s| s.angles.clone()).collect();
        angles.sort_by(f64::total_cmp);
        angles.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        let mut u_max: Vec<Option<f64>> = vec![Some(0.0); 6];
        let mut unseen_at: Vec<Vec<f64>> = vec![Vec::new(); 6];
        let mut rank_min = 6;
        for &a in &angles {
            let rows: Vec<[f64; 6]> = mine
                .iter()
                .filter_map(|s| {
                    let i = s.angles.iter().position(|x| (x - a).abs() < 1e-9)?;
                    Some(length_row(req, s, i))
                })
                .collect();
            let (u, rank) = per_angle_u(&rows, sigma);
            rank_min = rank_min.min(rank);
            for k in 0..6 {
                match u[k] {
                    Some(v) => {
                        if let Some(m) = &mut u_max[k] {
                            *m = m.max(v);
                        }
                    }
                    None => {
                        u_max[k] = None;
                        unseen_at[k].push(a);
                    }
                }
            }
        }
        axes.push(AxisPrediction {
            axis: letter,
            symbols,
            units: vec!["um", "um", "um", "urad", "urad", "urad"],
            u_max,
            unseen_at,
            rank: rank_min,
            setups: mine.len(),
            angles,
        });
    }
    Prediction {
        sigma_um: sigma,
        axes,
    }
}

/// Least-squares u of each of six parameters from `rows` (each one
/// reading of standard deviation `sigma`), `None` for a parameter with a
/// share in a null direction; and the rank.
pub fn per_angle_u(rows: &[[f64; 6]], sigma: f64) -> ([Option<f64>; 6], usize) {
    let mut out = [None; 6];
    if rows.is_empty() {
        return (out, 0);
    }
    let j = DMatrix::from_fn(rows.len(), 6, |r, c| rows[r][c]);
    // Columns scaled to unit norm, so that a lever of 500 mm does not
    // look like a rank of its own against a unit translation.
    let scale: Vec<f64> = (0..6)
        .map(|c| {
            let n = j.column(c).norm();
            if n > 0.0 { n } else { 1.0 }
        })
        .collect();
    let js = DMatrix::from_fn(rows.len(), 6, |r, c| j[(r, c)] / scale[c]);
    // The normal matrix's eigenvectors: those of a (relatively) zero
    // eigenvalue span what no reading sees.
    let eig = (js.transpose() * &js).symmetric_eigen();
    let lmax = eig.eigenvalues.max();
    let tol = lmax.max(f64::MIN_POSITIVE) * 1e-12;
    let mut rank = 0;
    let mut null: Vec<nalgebra::DVector<f64>> = Vec::new();
    let mut cov = DMatrix::<f64>::zeros(6, 6);
    for i in 0..6 {
        let l = eig.eigenvalues[i];
        let v = eig.eigenvectors.column(i).into_owned();
        if l > tol {
            rank += 1;
            cov += &v * v.transpose() / l;
        } else {
            null.push(v);
        }
    }
    for k in 0..6 {
        let seen = null.iter().all(|n| n[k].abs() < 1e-6);
        if seen {
            out[k] = Some(sigma * cov[(k, k)].sqrt() / scale[k]);
        }
    }
    (out, rank)
}

impl Prediction {
    /// Plain text, as `plan` prints it.
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "identifies (per angle, from the bar's noise and calibration, sigma {:.2} um per reading):",
            self.sigma_um
        );
        for a in &self.axes {
            let _ = writeln!(
                s,
                "  {} axis: {} setups, {} angles, rank {} of 6",
                a.axis,
                a.setups,
                a.angles.len(),
                a.rank
            );
            for k in 0..6 {
                match a.u_max[k] {
                    Some(u) => {
                        let _ =
                            writeln!(s, "    {:<10} u <= {:.3} {}", a.symbols[k], u, a.units[k]);
                    }
                    None => {
                        let _ = writeln!(
                            s,
                            "    {:<10} not identified at {} of the angles (no setup sees it there)",
                            a.symbols[k],
                            a.unseen_at[k].len()
                        );
                    }
                }
            }
        }
        s
    }
}
