//! Position-dependent error terms: values at measured index angles,
//! interpolated linearly between them, periodic in C and held constant
//! beyond the last measured tilt angle.
//!
//! Interpolation is linear in the node values, so a map is a linear
//! function of its parameters: [`MapGrid::weights`] gives the coefficients
//! that identification needs for its Jacobian.

use serde::{Deserialize, Serialize};

/// One dimension of a map grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapDim {
    /// 0 = tilt axis, 1 = C axis.
    pub angle: usize,
    /// Node angles, deg, strictly increasing (C nodes within [0, 360)).
    pub nodes: Vec<f64>,
    /// Whether the dimension wraps at 360 deg.
    pub periodic: bool,
}

/// Why a list of node angles is no map dimension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NodeError {
    /// No node at all.
    #[error("a map needs at least one node")]
    Empty,
    /// A NaN or infinite angle.
    #[error("map nodes must be finite")]
    NotFinite,
    /// Two nodes at one angle (`periodic`: modulo 360 deg).
    #[error("map nodes repeat {}", if *.periodic { "an angle (mod 360)" } else { "a position" })]
    Repeated {
        /// Whether the angles were compared modulo 360 deg.
        periodic: bool,
    },
    /// Nodes given out of order where order is required.
    #[error("map nodes must be strictly increasing")]
    NotIncreasing,
}

impl MapDim {
    /// Builds a dimension from nodes in increasing order (periodic nodes
    /// are taken mod 360 and must then be increasing too). Fails on
    /// repeats or non-finite nodes.
    pub fn new(angle: usize, nodes: &[f64], periodic: bool) -> Result<MapDim, NodeError> {
        let (d, order) = MapDim::sorted(angle, nodes, periodic)?;
        if order.iter().enumerate().any(|(i, &o)| i != o) {
            return Err(NodeError::NotIncreasing);
        }
        Ok(d)
    }

    /// Builds a dimension, sorting the nodes (periodic ones into [0, 360));
    /// returns it with `order[k]` = the input index of sorted node `k`.
    pub(crate) fn sorted(
        angle: usize,
        nodes: &[f64],
        periodic: bool,
    ) -> Result<(MapDim, Vec<usize>), NodeError> {
        if nodes.is_empty() {
            return Err(NodeError::Empty);
        }
        if nodes.iter().any(|v| !v.is_finite()) {
            return Err(NodeError::NotFinite);
        }
        let n: Vec<f64> = if periodic {
            nodes.iter().map(|v| v.rem_euclid(360.0)).collect()
        } else {
            nodes.to_vec()
        };
        let mut order: Vec<usize> = (0..n.len()).collect();
        order.sort_by(|&a, &b| n[a].total_cmp(&n[b]));
        let sorted: Vec<f64> = order.iter().map(|&i| n[i]).collect();
        if sorted.windows(2).any(|w| w[1] - w[0] < 1e-9) {
            return Err(NodeError::Repeated { periodic });
        }
        Ok((
            MapDim {
                angle,
                nodes: sorted,
                periodic,
            },
            order,
        ))
    }

    /// Interpolation weights at angle `x`: up to two (node, weight) pairs.
    pub fn weights(&self, x: f64) -> [(usize, f64); 2] {
        dim_weights(&self.nodes, self.periodic, x)
    }
}

/// [`MapDim::weights`] on sorted `nodes`, for a caller that holds the
/// nodes but no `MapDim` (a straightness effect, at every evaluation).
pub(crate) fn dim_weights(n: &[f64], periodic: bool, x: f64) -> [(usize, f64); 2] {
    let last = n.len() - 1;
    if n.len() == 1 {
        return [(0, 1.0), (0, 0.0)];
    }
    if periodic {
        let x = x.rem_euclid(360.0);
        if x >= n[last] || x < n[0] {
            let gap = n[0] + 360.0 - n[last];
            let d = if x >= n[last] {
                x - n[last]
            } else {
                x + 360.0 - n[last]
            };
            let w = d / gap;
            return [(last, 1.0 - w), (0, w)];
        }
        let i = n.partition_point(|&v| v <= x) - 1;
        let w = (x - n[i]) / (n[i + 1] - n[i]);
        return [(i, 1.0 - w), (i + 1, w)];
    }
    if x <= n[0] {
        return [(0, 1.0), (0, 0.0)];
    }
    if x >= n[last] {
        return [(last, 1.0), (last, 0.0)];
    }
    let i = n.partition_point(|&v| v <= x) - 1;
    let w = (x - n[i]) / (n[i + 1] - n[i]);
    [(i, 1.0 - w), (i + 1, w)]
}

/// A grid over one or two angles; node values are stored row-major (first
/// dimension slowest).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapGrid {
    /// The dimensions (one or two).
    pub dims: Vec<MapDim>,
}

impl MapGrid {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.dims.iter().map(|d| d.nodes.len()).product()
    }

    /// Whether the grid has no node (never, for a valid grid).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Node angles of flat index `i`, as (angle variable: 0 tilt, 1 C;
    /// degrees) per dimension.
    pub fn node_angles(&self, i: usize) -> Vec<(usize, f64)> {
        let mut rest = i;
        let mut out = vec![(0, 0.0); self.dims.len()];
        for (k, d) in self.dims.iter().enumerate().rev() {
            let n = d.nodes.len();
            out[k] = (d.angle, d.nodes[rest % n]);
            rest /= n;
        }
        out
    }

    /// Interpolation weights at (tilt, c) deg: (flat node index, weight)
    /// pairs whose weights sum to one.
    pub fn weights(&self, tilt: f64, c: f64) -> Weights {
        let mut out = Weights {
            items: [(0, 1.0); 4],
            len: 1,
        };
        // Two dimensions at most (`MapGrid::dims`), two nodes each: four
        // pairs, kept on the stack (the fits ask at every point).
        debug_assert!(self.dims.len() <= 2, "a grid over tilt and C");
        for d in &self.dims {
            let x = if d.angle == 0 { tilt } else { c };
            let w = d.weights(x);
            let n = d.nodes.len();
            let mut next = Weights {
                items: [(0, 0.0); 4],
                len: 0,
            };
            for &(i, wi) in out.iter() {
                for &(j, wj) in &w {
                    if wj != 0.0 {
                        next.items[next.len] = (i * n + j, wi * wj);
                        next.len += 1;
                    }
                }
            }
            out = next;
        }
        out
    }
}

/// The (flat node index, weight) pairs of [`MapGrid::weights`]: one to
/// four, in the order of the grid's nodes.
#[derive(Clone, Copy, Debug)]
pub struct Weights {
    items: [(usize, f64); 4],
    len: usize,
}

impl Weights {
    /// The pairs.
    pub fn iter(&self) -> std::slice::Iter<'_, (usize, f64)> {
        self.items[..self.len].iter()
    }

    /// How many pairs.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there is none (never, for a grid with nodes).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl std::ops::Index<usize> for Weights {
    type Output = (usize, f64);
    fn index(&self, k: usize) -> &(usize, f64) {
        &self.items[..self.len][k]
    }
}

impl IntoIterator for Weights {
    type Item = (usize, f64);
    type IntoIter = std::iter::Take<std::array::IntoIter<(usize, f64), 4>>;
    fn into_iter(self) -> Self::IntoIter {
        self.items.into_iter().take(self.len)
    }
}

/// A map: a grid and one value per node.
#[derive(Clone, Debug, PartialEq)]
pub struct AngleMap {
    /// The grid.
    pub grid: MapGrid,
    /// Node values (row-major), in the unit of the term (um or urad).
    pub values: Vec<f64>,
}

impl AngleMap {
    /// The interpolated value at (tilt, c).
    pub fn eval(&self, tilt: f64, c: f64) -> f64 {
        self.grid
            .weights(tilt, c)
            .iter()
            .map(|&(i, w)| w * self.values[i])
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilt_map_interpolates_and_holds_at_the_ends() {
        let g = MapGrid {
            dims: vec![MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap()],
        };
        let m = AngleMap {
            grid: g,
            values: vec![10.0, 0.0, -20.0],
        };
        assert_eq!(m.eval(-45.0, 0.0), 5.0);
        assert_eq!(m.eval(45.0, 0.0), -10.0);
        assert_eq!(m.eval(-120.0, 0.0), 10.0);
        assert_eq!(m.eval(100.0, 0.0), -20.0);
        assert_eq!(m.eval(90.0, 0.0), -20.0);
    }

    #[test]
    fn c_map_is_periodic() {
        let g = MapGrid {
            dims: vec![MapDim::new(1, &[0.0, 90.0, 180.0, 270.0], true).unwrap()],
        };
        let m = AngleMap {
            grid: g,
            values: vec![0.0, 4.0, 8.0, 4.0],
        };
        assert_eq!(m.eval(0.0, 315.0), 2.0);
        assert_eq!(m.eval(0.0, -45.0), 2.0);
        assert_eq!(m.eval(0.0, 405.0), 2.0);
        assert_eq!(m.eval(0.0, 135.0), 6.0);
    }

    #[test]
    fn two_dimensional_weights_sum_to_one_and_reproduce_nodes() {
        let g = MapGrid {
            dims: vec![
                MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap(),
                MapDim::new(1, &[0.0, 120.0, 240.0], true).unwrap(),
            ],
        };
        for i in 0..g.len() {
            let a = g.node_angles(i);
            let w = g.weights(a[0].1, a[1].1);
            assert_eq!(w.len(), 1);
            assert_eq!(w[0], (i, 1.0));
        }
        let w = g.weights(-30.0, 300.0);
        let s: f64 = w.iter().map(|x| x.1).sum();
        assert!((s - 1.0).abs() < 1e-15);
        assert_eq!(w.len(), 4);
    }

    #[test]
    fn rejects_repeated_nodes_and_sorts_periodic_ones() {
        assert!(MapDim::new(1, &[0.0, 360.0], true).is_err());
        assert!(MapDim::new(0, &[10.0, 0.0], false).is_err());
        let (d, order) = MapDim::sorted(1, &[-90.0, 0.0, 90.0, 180.0], true).unwrap();
        assert_eq!(d.nodes, vec![0.0, 90.0, 180.0, 270.0]);
        assert_eq!(order, vec![1, 2, 3, 0]);
    }
}
