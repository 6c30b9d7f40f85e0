//! The uncertainty budget: how much of each parameter's variance each
//! contributor brings, in closed form.
//!
//! The linearized Monte Carlo ([`super::linear`]) moves the estimate by
//! `G (S c + e)` for a draw `c` of the contributors and `e` of the noise.
//! That is linear in what is drawn, so the variance it samples is known
//! without drawing: `diag(G S_g Σ_g S_gᵀ Gᵀ)` for each group `g` of
//! contributor columns (their covariance `Σ_g` follows from how
//! [`Contributors`] draws them) and `σ² diag(G Gᵀ)` for the noise. The sum
//! is the full `u` of every parameter that `analyze` prints by default;
//! each group's share of it is what the result file and the report list as
//! the largest contributors. `plan` computes the same budget at the
//! nominal machine, so its prediction and the analysis use one model, and
//! the tests set every group beside a Monte Carlo of that group alone.
//!
//! Two groups are not a plain diagonal: a straightness is drawn on nodes
//! 20 to 50 mm apart, the spacing itself uniform, and interpolated onto
//! the study's 1 mm grid, so neighbouring grid values are correlated; its
//! variance is the expectation over the spacing (a midpoint rule over the
//! spacing, fine enough that the rule's error is far below the Monte
//! Carlo's). A piece's setup is drawn as a rigid displacement and enters
//! the forward model through its nuisance parameters; the map between them
//! is taken by central differences (it is smooth, and linear at the
//! setups drawn).

use nalgebra::{DMatrix, DVector, Isometry3, Vector3};

use super::Contributors;
use super::contributors::Spread;
use super::linear::{LinearStudy, NotLinearized};
use crate::kinematics::maps::dim_weights;

/// Points of the midpoint rule over the straightness nodes' spacing.
const SPACING_STEPS: usize = 240;
/// Step of the central differences of a piece's setup: 1 um and 1 urad.
const SETUP_STEP: f64 = 1.0;

/// One group of contributors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// The instrument's noise per measured point.
    Noise,
    /// Linear positioning error (scale) of X, Y, Z.
    Scale,
    /// Squareness of the linear axes.
    Squareness,
    /// Non-periodic straightness of the linear axes.
    Straightness,
    /// Directional pre-travel variation of the probe.
    Pretravel,
    /// Where each test piece (or the sphere) sits on the table.
    Setup,
}

impl Group {
    /// Every group, in the budget's column order.
    pub const ALL: [Group; 6] = [
        Group::Noise,
        Group::Scale,
        Group::Squareness,
        Group::Straightness,
        Group::Pretravel,
        Group::Setup,
    ];

    /// Its column in [`Budget::variance`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// Whether its draw changes from one run of the test to the next: the
    /// noise, where a piece or sphere is set up, the probe's pre-travel
    /// (qualified anew with the probe). The linear axes' errors are the
    /// machine's own and bias every run of the same design alike.
    pub fn varies_per_run(self) -> bool {
        matches!(self, Group::Noise | Group::Pretravel | Group::Setup)
    }

    /// The name a report prints.
    pub fn name(self) -> &'static str {
        match self {
            Group::Noise => "measurement noise",
            Group::Scale => "linear-axis positioning (scale)",
            Group::Squareness => "squareness of the linear axes",
            Group::Straightness => "straightness of the linear axes",
            Group::Pretravel => "probe pre-travel variation",
            Group::Setup => "test-piece setup",
        }
    }
}

/// The variance each contributor group brings to each parameter.
#[derive(Clone, Debug)]
pub struct Budget {
    /// Parameters x groups ([`Group::ALL`] order): variance, in the
    /// parameter's unit squared.
    pub variance: DMatrix<f64>,
}

impl Budget {
    /// The full standard uncertainty of parameter `i`.
    pub fn u(&self, i: usize) -> f64 {
        self.variance.row(i).sum().max(0.0).sqrt()
    }

    /// The standard uncertainty parameter `i` has from `group` alone.
    pub fn u_of(&self, i: usize, group: Group) -> f64 {
        self.variance[(i, group.index())].max(0.0).sqrt()
    }

    /// The part of parameter `i`'s `u` that varies from run to run
    /// ([`Group::varies_per_run`]).
    pub fn u_random(&self, i: usize) -> f64 {
        Group::ALL
            .iter()
            .filter(|g| g.varies_per_run())
            .map(|g| self.variance[(i, g.index())].max(0.0))
            .sum::<f64>()
            .sqrt()
    }

    /// The `n` largest contributors to parameter `i`, largest first, with
    /// their share of its variance (0..1); groups that bring less than
    /// half a per cent are left out.
    pub fn largest(&self, i: usize, n: usize) -> Vec<(Group, f64)> {
        let total: f64 = self.variance.row(i).sum();
        if total <= 0.0 || !total.is_finite() {
            return Vec::new();
        }
        let mut v: Vec<(Group, f64)> = Group::ALL
            .iter()
            .map(|&group| (group, self.variance[(i, group.index())] / total))
            .filter(|(_, s)| *s >= 0.005)
            .collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1));
        v.truncate(n);
        v
    }
}

/// The variance of one value drawn with spread `v` the way
/// [`Contributors`] draws its systematic contributors.
fn draw_variance(c: &Contributors, v: f64) -> f64 {
    match c.distribution {
        Spread::Uniform => v * v / 3.0,
        Spread::Normal => v * v,
    }
}

impl LinearStudy {
    /// The study's budget: the variance every contributor group brings to
    /// every parameter, as the linearized Monte Carlo draws them (see the
    /// module documentation).
    pub fn budget(&self) -> Result<Budget, NotLinearized> {
        let c = self.contributors();
        let l = self.layout();
        let r = self.response();
        let g = self.gain();
        let n = r.nrows();
        let mut var = DMatrix::zeros(n, Group::ALL.len());
        let col = Group::index;
        // Independent columns with one variance each.
        let mut diagonal = |first: usize, len: usize, v: f64, group: Group| {
            for j in first..first + len {
                for i in 0..n {
                    var[(i, col(group))] += v * r[(i, j)] * r[(i, j)];
                }
            }
        };
        if let Some(first) = l.scale {
            diagonal(
                first,
                3,
                draw_variance(c, c.linear_scale_um_per_m),
                Group::Scale,
            );
        }
        if let Some(first) = l.squareness {
            diagonal(
                first,
                3,
                draw_variance(c, c.squareness_urad),
                Group::Squareness,
            );
        }
        if let Some(first) = l.pretravel {
            let k = crate::model::Effect::ProbePretravel.n_params();
            diagonal(first, k, draw_variance(c, c.pretravel_um), Group::Pretravel);
        }
        let noise = c.noise_um * c.noise_um;
        for i in 0..n {
            var[(i, col(Group::Noise))] = noise * g.row(i).iter().map(|x| x * x).sum::<f64>();
        }
        // Straightness: the grid values are the nodes' interpolation, the
        // nodes' spacing uniform in [20, 50] mm, their values independent.
        if !l.straightness.is_empty() {
            let v = draw_variance(c, c.straightness_um);
            let m = self.kinematics().machine();
            for (moving, _, grid, first) in &l.straightness {
                let a = moving.index();
                let (lo, hi) = (m.strokes[a].0 - m.pivot[a], m.strokes[a].1 - m.pivot[a]);
                let mut sum = DVector::<f64>::zeros(n);
                for s in 0..SPACING_STEPS {
                    let step = 20.0 + 30.0 * (s as f64 + 0.5) / SPACING_STEPS as f64;
                    let mut nodes = Vec::new();
                    let mut x = lo;
                    while x < hi + step {
                        nodes.push(x);
                        x += step;
                    }
                    // How parameter i moves per unit of node k.
                    let mut per_node = DMatrix::<f64>::zeros(n, nodes.len());
                    for (j, x) in grid.iter().enumerate() {
                        for (k, w) in dim_weights(&nodes, false, *x) {
                            if w != 0.0 {
                                for i in 0..n {
                                    per_node[(i, k)] += w * r[(i, first + j)];
                                }
                            }
                        }
                    }
                    for i in 0..n {
                        sum[i] += per_node.row(i).iter().map(|x| x * x).sum::<f64>();
                    }
                }
                for i in 0..n {
                    var[(i, col(Group::Straightness))] += v * sum[i] / SPACING_STEPS as f64;
                }
            }
        }
        // Setup: each piece drawn independently, normal, through its
        // nuisance parameters.
        if let (Some(first), Some(fw)) = (l.setup, self.probing()) {
            let pieces = self.pieces();
            let sigma = [
                c.setup_position_um[0],
                c.setup_position_um[1],
                c.setup_position_um[2],
                c.setup_orientation_urad[0],
                c.setup_orientation_urad[1],
                c.setup_orientation_urad[2],
            ];
            let width = r.ncols() - first;
            for piece in 0..pieces {
                for (d, s) in sigma.iter().enumerate() {
                    if *s <= 0.0 {
                        continue;
                    }
                    let at = |h: f64| {
                        let mut v = [0.0; 6];
                        v[d] = h;
                        let iso = Isometry3::new(
                            Vector3::new(v[0], v[1], v[2]) * 1e-3,
                            Vector3::new(v[3], v[4], v[5]) * 1e-6,
                        );
                        let mut setups = vec![Isometry3::identity(); pieces];
                        setups[piece] = iso;
                        fw.nuisance_of(&setups)
                    };
                    let (plus, minus) = (at(SETUP_STEP), at(-SETUP_STEP));
                    if plus.len() != width {
                        return Err(NotLinearized::NoColumn(format!(
                            "the setup of piece {} ({} nuisance values, {} columns)",
                            piece + 1,
                            plus.len(),
                            width
                        )));
                    }
                    for i in 0..n {
                        let moved: f64 = (0..width)
                            .map(|k| r[(i, first + k)] * (plus[k] - minus[k]) / (2.0 * SETUP_STEP))
                            .sum();
                        var[(i, col(Group::Setup))] += s * s * moved * moved;
                    }
                }
            }
        }
        Ok(Budget { variance: var })
    }
}

#[cfg(test)]
mod tests {
    use super::Group;

    #[test]
    fn each_group_sits_at_its_own_column() {
        for (k, g) in Group::ALL.iter().enumerate() {
            assert_eq!(g.index(), k, "{g:?}");
        }
    }
}
