//! What a test can and cannot identify, reported before any number: the
//! rank and condition number of the column-scaled design, which parameters
//! are identifiable, the parameter combinations that change no measurement
//! (named in symbols of docs/model.md and model terms), the identifiable combinations
//! of the parameters that are not identifiable alone, the enumeration of
//! identifiable parameter sets of the LAMDAMAP 2015 paper, section 4.
//!
//! (Earlier releases printed a "pose quality" per rotary axis on the scale
//! of HEIDENHAIN's valuation number, from the noise alone. Nothing followed
//! from it, and it read 0.02-0.76 on every machining test against ">= 2
//! needed": what decides whether a value can be acted on is now its full
//! `u` against the usefulness threshold, `crate::analyze::usefulness`.)

use std::fmt::Write;

use nalgebra::{DMatrix, DVector};

use super::lsq::Design;

/// Whether each parameter is identifiable, with its name.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ParamStatus {
    /// Parameter name (symbol, `symbol@angles` for map nodes, or a nuisance name).
    pub name: String,
    /// Whether the test determines it.
    pub identifiable: bool,
    /// What the method's estimate of it moves with besides itself (the
    /// judge's finding, [`Identifiability::judge_estimator`]): each other
    /// parameter with the change of this estimate per unit of it. Empty
    /// where the design alone decides.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub aliased_with: Vec<(String, f64)>,
}

/// The identifiability report of one design.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Identifiability {
    /// Number of measurements (residual rows).
    pub observations: usize,
    /// Number of parameters, nuisance included.
    pub parameters: usize,
    /// Parameters left free by the constraints.
    pub free: usize,
    /// Rank of the column-scaled design.
    pub rank: usize,
    /// Condition number of the column-scaled design (kept singular values).
    pub condition: f64,
    /// The constraints that define the parameters (papers' averaging).
    pub constraints: Vec<String>,
    /// Each parameter.
    pub params: Vec<ParamStatus>,
    /// Parameter combinations that change no measurement.
    pub null_combinations: Vec<String>,
    /// Combinations of non-identifiable parameters that are identifiable.
    pub identifiable_combinations: Vec<String>,
}

impl Identifiability {
    /// Whether parameter `i` is identifiable.
    pub(crate) fn is_identifiable(&self, i: usize) -> bool {
        self.params[i].identifiable
    }

    /// The judge of a method's estimator, beside the design's rank: `s`
    /// (`n_model` rows, one column per parameter of the design, nuisance
    /// included) is how each estimate moves with each parameter of the
    /// complete measurement model, `d theta_hat / d theta_true`, linearized
    /// at the data. A least-squares fit of the complete model has `s` =
    /// the projection on the seen directions, and the rank alone decides;
    /// a method that reduces the measurements first (the sphere method's
    /// axis lines) may lose sight of a term and let it leak into an
    /// estimate. A parameter stays reported only if its estimate follows
    /// it one to one and no other parameter moves it by more than
    /// [`ALIAS_TOLERANCE`] per unit; otherwise it becomes not identifiable,
    /// naming what it is aliased with.
    pub fn judge_estimator(&mut self, s: &DMatrix<f64>) {
        for i in 0..s.nrows().min(self.params.len()) {
            if !self.params[i].identifiable {
                continue;
            }
            let mut aliases = Vec::new();
            for j in 0..s.ncols().min(self.params.len()) {
                let want = if i == j { 1.0 } else { 0.0 };
                if (s[(i, j)] - want).abs() > ALIAS_TOLERANCE {
                    aliases.push((self.params[j].name.clone(), s[(i, j)]));
                }
            }
            if !aliases.is_empty() {
                self.params[i].identifiable = false;
                self.params[i].aliased_with = aliases;
            }
        }
    }

    /// Why parameter `i` is not reported, in words: the method's aliases
    /// (the judge) or the design's unseen combination that moves it.
    pub fn reason(&self, i: usize) -> String {
        let p = &self.params[i];
        if !p.aliased_with.is_empty() {
            // Its own coefficient: how far the estimate follows the error
            // (1 for a reported error).
            let own = p
                .aliased_with
                .iter()
                .find(|(n, _)| *n == p.name)
                .map(|x| x.1);
            let others: Vec<String> = p
                .aliased_with
                .iter()
                .filter(|(n, _)| *n != p.name)
                .map(|(n, c)| format!("{n} ({c:+.3} per unit)"))
                .collect();
            let mut why = Vec::new();
            match own {
                Some(c) if c.abs() < ALIAS_TOLERANCE => why.push(
                    "a change of it does not reach the method's estimate (what the method fits, \
                     such as the sphere method's per-pose centres and axis lines, does not see it)"
                        .to_string(),
                ),
                Some(c) => why.push(format!(
                    "the method's estimate follows it by {c:.3} per unit instead of one to one"
                )),
                None => {}
            }
            if !others.is_empty() {
                why.push(format!("its estimate moves with {}", others.join(", ")));
            }
            return format!("the method cannot separate it: {}", why.join("; "));
        }
        match self
            .null_combinations
            .iter()
            .find(|c| combination_mentions(c, &p.name))
        {
            Some(c) => format!("the test does not see it: {c}"),
            None => "the test does not see it".to_string(),
        }
    }

    /// Human-readable report.
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "identifiability: {} measurements, {} parameters ({} free after {} constraints), rank {}, condition number {:.3e}",
            self.observations,
            self.parameters,
            self.free,
            self.constraints.len(),
            self.rank,
            self.condition
        );
        let not: Vec<&str> = self
            .params
            .iter()
            .filter(|p| !p.identifiable)
            .map(|p| p.name.as_str())
            .collect();
        if not.is_empty() {
            let _ = writeln!(s, "  every parameter is identifiable");
        } else {
            let _ = writeln!(s, "  not identifiable: {}", not.join(", "));
        }
        for c in &self.null_combinations {
            let _ = writeln!(s, "  unseen combination: {c}");
        }
        for c in &self.identifiable_combinations {
            let _ = writeln!(s, "  identifiable combination: {c}");
        }
        for (i, p) in self.params.iter().enumerate() {
            if !p.aliased_with.is_empty() {
                let _ = writeln!(s, "  {}: {}", p.name, self.reason(i));
            }
        }
        s
    }
}

/// Largest change of an estimate per unit of another parameter (um per
/// um, um per urad, ...) the judge lets pass: 100 um of a term the method
/// cannot see would move the estimate by 0.1 um. A method that models
/// every term it reports has zero there up to rounding (1e-6).
pub const ALIAS_TOLERANCE: f64 = 1e-3;

/// Whether a printed combination names `name` as a term (not as a part of
/// a longer name: `EX0B` is not in `EX(0B)C`).
fn combination_mentions(c: &str, name: &str) -> bool {
    c.split(|ch: char| ch.is_whitespace()).any(|t| t == name)
}

/// A linear combination of named parameters, written out only when shown:
/// a discovery meets hundreds of unseen map combinations per candidate and
/// shows a handful.
#[derive(Clone, Debug, PartialEq)]
pub struct Combination {
    coef: Vec<f64>,
    names: std::sync::Arc<[String]>,
}

impl Combination {
    /// The combination `coef . names` (one coefficient per name).
    pub fn new(coef: Vec<f64>, names: std::sync::Arc<[String]>) -> Combination {
        Combination { coef, names }
    }
}

impl std::fmt::Display for Combination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&combination(&self.coef, &self.names))
    }
}

impl serde::Serialize for Combination {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Formats a linear combination `sum c_k name_k` with the largest
/// coefficient 1, dropping negligible terms.
pub fn combination(coef: &[f64], names: &[String]) -> String {
    let max = coef.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    if max == 0.0 {
        return "0".into();
    }
    let mut s = String::new();
    for (c, n) in coef.iter().zip(names) {
        let v = c / max;
        if v.abs() < 1e-6 {
            continue;
        }
        let mag = v.abs();
        let sign = if v < 0.0 { "-" } else { "+" };
        if s.is_empty() {
            if v < 0.0 {
                s.push('-');
            }
        } else {
            let _ = write!(s, " {sign} ");
        }
        if (mag - 1.0).abs() < 1e-9 {
            s.push_str(n);
        } else {
            let _ = write!(s, "{mag:.4} {n}");
        }
    }
    s
}

/// Rows of the reduced row echelon form of `m` (rows: vectors), each with
/// its pivot scaled to 1; near-zero rows dropped.
fn rref(mut m: DMatrix<f64>) -> Vec<DVector<f64>> {
    let (rows, cols) = m.shape();
    // Pivots and entries below this are round-off of the directions given:
    // a direction the design sees a million times more weakly than the
    // rest comes with a part of the seen ones of about that size (1e-6),
    // which as a pivot would mix every unseen combination with every
    // other.
    let tol = 1e-5 * m.amax();
    let mut r = 0;
    for c in 0..cols {
        if r == rows {
            break;
        }
        let (piv, val) = (r..rows)
            .map(|i| (i, m[(i, c)].abs()))
            .fold((r, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        if val < tol.max(1e-9) {
            continue;
        }
        m.swap_rows(r, piv);
        let p = m[(r, c)];
        for j in 0..cols {
            m[(r, j)] /= p;
        }
        for i in 0..rows {
            if i != r {
                let f = m[(i, c)];
                if f != 0.0 {
                    for j in 0..cols {
                        let v = m[(r, j)];
                        m[(i, j)] -= f * v;
                    }
                }
            }
        }
        r += 1;
    }
    (0..r)
        .map(|i| {
            m.row(i)
                .transpose()
                .map(|v| if v.abs() < tol { 0.0 } else { v })
        })
        .collect()
}

/// Builds the report from the design's analysis.
///
/// `names`: every parameter (the `n_model` model parameters first, then
/// nuisance; identifiable combinations are sought among model parameters);
pub fn report(
    d: &Design,
    observations: usize,
    n_model: usize,
    names: &[String],
    constraints: &[String],
) -> Identifiability {
    let n = names.len();
    // A parameter is identifiable when no unseen direction moves it.
    let ident: Vec<bool> = (0..n)
        .map(|k| (0..d.null.ncols()).all(|c| d.null[(k, c)].abs() < 1e-7))
        .collect();
    let null_combinations: Vec<String> = if d.null.ncols() == 0 {
        Vec::new()
    } else {
        rref(d.null.transpose())
            .iter()
            .map(|v| {
                format!(
                    "{} (changing these together changes no measurement)",
                    combination(v.as_slice(), names)
                )
            })
            .collect()
    };
    // Identifiable combinations among the non-identifiable parameters:
    // coefficient vectors c on them with c . v = 0 for every unseen v.
    let group: Vec<usize> = (0..n_model.min(n)).filter(|&k| !ident[k]).collect();
    let mut identifiable_combinations = Vec::new();
    if !group.is_empty() {
        let vg = DMatrix::from_fn(group.len(), d.null.ncols(), |i, c| d.null[(group[i], c)]);
        // Null space of vg^T, within the group.
        let g = &vg * vg.transpose();
        let e = g.symmetric_eigen();
        let max = e.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let vecs: Vec<DVector<f64>> = (0..group.len())
            .filter(|&k| e.eigenvalues[k].abs() < 1e-10 * max.max(1e-300))
            .map(|k| e.eigenvectors.column(k).into_owned())
            .collect();
        if !vecs.is_empty() {
            let m = DMatrix::from_columns(&vecs).transpose();
            let gnames: Vec<String> = group.iter().map(|&k| names[k].clone()).collect();
            for v in rref(m) {
                identifiable_combinations.push(combination(v.as_slice(), &gnames));
            }
        }
    }
    Identifiability {
        observations,
        parameters: n,
        free: d.free,
        rank: d.rank,
        condition: d.condition,
        constraints: constraints.to_vec(),
        params: names
            .iter()
            .zip(&ident)
            .map(|(n, &i)| ParamStatus {
                name: n.clone(),
                identifiable: i,
                aliased_with: Vec::new(),
            })
            .collect(),
        null_combinations,
        identifiable_combinations,
    }
}

/// The LAMDAMAP 2015 paper, section 4: among the columns `candidates` of a design `j`
/// (rows: measurements), every set of `size` columns that, together with
/// the always-included columns `fixed` (nuisance), has full column rank.
/// Returns the sets (as indices into `candidates`) and the number tried.
pub fn identifiable_sets(
    j: &DMatrix<f64>,
    candidates: &[usize],
    fixed: &[usize],
    size: usize,
) -> (Vec<Vec<usize>>, usize) {
    let mut out = Vec::new();
    let mut tried = 0;
    let n = candidates.len();
    if size > n {
        return (out, 0);
    }
    let mut idx: Vec<usize> = (0..size).collect();
    loop {
        tried += 1;
        let cols: Vec<usize> = fixed
            .iter()
            .copied()
            .chain(idx.iter().map(|&i| candidates[i]))
            .collect();
        let mut m = DMatrix::from_fn(j.nrows(), cols.len(), |r, c| j[(r, cols[c])]);
        for mut col in m.column_iter_mut() {
            let nrm = col.norm();
            if nrm > 0.0 {
                col /= nrm;
            }
        }
        let sv = m.svd(false, false).singular_values;
        let max = sv.max();
        if sv.iter().all(|&s| s > 1e-9 * max) {
            out.push(idx.clone());
        }
        // Next combination.
        let mut i = size;
        loop {
            if i == 0 {
                return (out, tried);
            }
            i -= 1;
            if idx[i] != i + n - size {
                break;
            }
            if i == 0 && idx[0] == n - size {
                return (out, tried);
            }
        }
        idx[i] += 1;
        for k in i + 1..size {
            idx[k] = idx[k - 1] + 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combinations_read_like_the_symbols() {
        let names: Vec<String> = ["dy_BY", "dy_CB", "EX0B"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        assert_eq!(combination(&[0.7, -0.7, 0.0], &names), "dy_BY - dy_CB");
        assert_eq!(
            combination(&[0.5, 1.0, 1e-9], &names),
            "0.5000 dy_BY + dy_CB"
        );
    }

    #[test]
    fn enumerates_the_sets_of_full_rank() {
        // Columns 0 and 1 are the same: sets {0,2} and {1,2} work, {0,1} not.
        let j = DMatrix::from_row_slice(3, 3, &[1., 1., 0., 2., 2., 1., 0., 0., 1.]);
        let (sets, tried) = identifiable_sets(&j, &[0, 1, 2], &[], 2);
        assert_eq!(tried, 3);
        assert_eq!(sets, vec![vec![0, 2], vec![1, 2]]);
    }
}
