//! What a plan will identify, known before anything is cut or probed: the
//! plan is run on the simulator without errors or noise, and the method
//! `analyze` will use identifies its nominal measurements. What that
//! identification can report, it will report from real measurements; its
//! covariance per unit noise, scaled by the instrument's noise, is the
//! standard uncertainty each value will have (for the global method the
//! design's Cramér-Rao bound). `plan` prints the table and writes it into
//! the setup sheet, and `--require all` refuses a design that leaves a
//! location error unseen; where it does, [`crate::discover::suggest`] names the
//! known changes of the template that would identify more.

use std::fmt::Write as _;

use super::goodness::ExpectedNoise;
use super::usefulness::Usefulness;
use super::{AnalyzeError, method};
use crate::errorfile::ErrorFile;
use crate::formats::manifest::{Identifies, PredictedSymbol};
use crate::identify::sphere::{CircleMethod, SphereOptions};
use crate::identify::{Method, Setup};
use crate::procedure::{Plan, Test};
use crate::simulate::{self, SimOptions};

/// One location error of the machine: the uncertainty the test will give
/// it, or why it will not.
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewRow {
    /// The symbol.
    pub symbol: String,
    /// um or urad.
    pub unit: String,
    /// Standard uncertainty at the expected noise; `None`: not identified.
    pub u: Option<f64>,
    /// Why not, where not.
    pub reason: Option<String>,
}

/// What a plan will identify with a method at a noise.
#[derive(Clone, Debug)]
pub struct Preview {
    /// The method `analyze` will use.
    pub method: Method,
    /// The noise the uncertainties are predicted at.
    pub noise: ExpectedNoise,
    /// What the predicted `u` holds, in words.
    pub basis: String,
    /// Rank of the design and its number of free parameters (nuisance
    /// included).
    pub rank: (usize, usize),
    /// Every location error, in the machine's order.
    pub rows: Vec<PreviewRow>,
    /// Combinations of symbols no measurement of this design sees.
    pub unseen: Vec<String>,
    /// What the test says of every symbol at once (the nine-section
    /// test: how its heights respond and why it identifies none), printed
    /// under the heading.
    pub summary: Option<String>,
}

impl Preview {
    /// The symbols the test will not identify.
    pub fn missing(&self) -> Vec<&str> {
        self.rows
            .iter()
            .filter(|r| r.u.is_none())
            .map(|r| r.symbol.as_str())
            .collect()
    }

    /// The table, as `plan` prints it and the setup sheet shows it.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let seen = self.rows.iter().filter(|r| r.u.is_some()).count();
        let _ = writeln!(
            s,
            "identifies {seen} of {} location errors with the {} method (design rank {} of {}); u at {:.3} um noise ({}), holding {}:",
            self.rows.len(),
            self.method,
            self.rank.0,
            self.rank.1,
            self.noise.um,
            self.noise.from,
            self.basis
        );
        if let Some(summary) = &self.summary {
            let _ = writeln!(s, "  {summary}");
        }
        // One reason for every symbol (the nine-section test) is said once.
        let first = self.rows.first().and_then(|r| r.reason.as_ref());
        if let Some(why) = first
            && seen == 0
            && self.rows.iter().all(|r| r.reason.as_ref() == first)
        {
            let _ = writeln!(s, "  none: {why}");
            return s;
        }
        for r in &self.rows {
            match (r.u, &r.reason) {
                (Some(u), _) => {
                    let _ = writeln!(s, "  {:<10} u = {:>8.3} {}", r.symbol, u, r.unit);
                }
                (None, why) => {
                    let _ = writeln!(
                        s,
                        "  {:<10} not identified: {}",
                        r.symbol,
                        why.as_deref().unwrap_or("the design does not see it")
                    );
                }
            }
        }
        for c in &self.unseen {
            let _ = writeln!(s, "  not separable: {c}");
        }
        s
    }

    /// The manifest's `identifies:` entry. An uncertainty that is not a
    /// finite number is left out with the reason, never written.
    pub fn manifest_entry(&self) -> Identifies {
        Identifies {
            method: self.method.to_string(),
            noise_um: self.noise.um,
            rank: self.rank.0,
            parameters: self.rank.1,
            symbols: self
                .rows
                .iter()
                .map(|r| {
                    let u = r.u.filter(|u| u.is_finite());
                    let reason = match (u, r.u) {
                        (Some(_), _) => None,
                        (None, Some(_)) => Some("its uncertainty is not finite".to_string()),
                        (None, None) => r.reason.clone(),
                    };
                    (
                        r.symbol.clone(),
                        PredictedSymbol {
                            unit: r.unit.clone(),
                            u,
                            reason,
                        },
                    )
                })
                .collect(),
            not_separable: self.unseen.clone(),
        }
    }

    /// The setup sheet's section (Markdown).
    pub fn markdown(&self) -> String {
        format!(
            "\n## What this test identifies\n\nPredicted by `fivecal plan` from the plan alone (the plan run on the simulator \
             without errors or noise and identified as `fivecal analyze` will):\n\n```\n{}```\n",
            self.render()
        )
    }
}

/// The measurements `plan` gives on a machine without errors, measured
/// without noise: its design, known before anything is cut or probed.
pub fn nominal_data(plan: &Plan) -> Result<crate::identify::Dataset, AnalyzeError> {
    let kin = simulate::plan_kinematics(plan);
    let name = kin.machine().name.clone();
    let src = format!("machine: {name}\n");
    let path = std::path::Path::new("(no errors)");
    let zero = ErrorFile::parse(path, &src)?.to_model(&kin, path, &src)?;
    let sim = simulate::run(plan, &zero, &SimOptions::exact())
        .map_err(|e| AnalyzeError::Plan(format!("cannot simulate the plan: {e}")))?;
    Ok(super::uncertainty::simulated::plan_dataset(
        plan, "nominal", sim.points,
    )?)
}

/// Predicts what `plan` will identify with `method` (the test's default
/// when `None`) at the instrument's noise (`noise` um, else its default),
/// with the default usefulness thresholds.
pub fn predict(
    plan: &Plan,
    method: Option<Method>,
    noise: Option<f64>,
) -> Result<Preview, AnalyzeError> {
    predict_useful(plan, method, noise, &Usefulness::default())
}

/// [`predict`] with the thresholds `useful`: a location error whose
/// predicted `u` is above its threshold is seen, but not usefully, and is
/// not counted as identified ([`super::usefulness`]).
pub fn predict_useful(
    plan: &Plan,
    method: Option<Method>,
    noise: Option<f64>,
    useful: &Usefulness,
) -> Result<Preview, AnalyzeError> {
    predict_with(
        plan,
        method,
        noise,
        useful,
        &super::ContributorChoice::TestDefault,
    )
}

/// [`predict_useful`] with the contributors `choice` (the test's own by
/// default; [`super::ContributorChoice::NoiseOnly`] predicts the noise's
/// part alone, at the instrument's noise).
pub fn predict_with(
    plan: &Plan,
    method: Option<Method>,
    noise: Option<f64>,
    useful: &Usefulness,
    choice: &super::ContributorChoice,
) -> Result<Preview, AnalyzeError> {
    let test = plan.test();
    let kin = simulate::plan_kinematics(plan);
    let expected = ExpectedNoise::new(noise, plan.kind(), test);
    let method = method.unwrap_or(method::default_for(test, kin.machine().structure));
    method::check(method, test, plan.kind(), &[])?;
    let symbols = crate::kinematics::symbols::SymbolTable::for_kinematics(&kin);
    let nothing = |reason: &str| Preview {
        method,
        noise: expected.clone(),
        basis: "nothing: the test identifies no location error".into(),
        rank: (0, symbols.location.len()),
        rows: symbols
            .location
            .iter()
            .map(|l| PreviewRow {
                symbol: l.name.clone(),
                unit: l.unit.to_string(),
                u: None,
                reason: Some(reason.to_string()),
            })
            .collect(),
        unseen: Vec::new(),
        summary: None,
    };
    if test == Test::NineSection {
        return nine_section(plan, &symbols, method, expected);
    }
    let data = nominal_data(plan)?;
    let setup = Setup::new(&kin, &data.poses, &[])?;
    let sphere = SphereOptions {
        circle: CircleMethod::Robust,
        check: None,
    };
    // A design the method cannot take at all (a spiral of sphere touches
    // without a circle about C, for the sphere method) identifies nothing
    // with it: that is the prediction, not a failure of the plan.
    let est = match method::identify_with_plan(method, &setup, &data, &sphere, Some(plan)) {
        Ok(est) => est,
        Err(e) => {
            return Ok(nothing(&format!(
                "the {method} method cannot analyse this design: {e}"
            )));
        }
    };
    // The same budget `analyze` reports: the test's contributors at the
    // instrument's noise, through the fit's response at the nominal
    // machine; the noise alone where the method's response is not linear.
    let budget = super::uncertainty::budget_of(
        &super::uncertainty::Estimate {
            est: &est,
            setup: &setup,
            data: &data,
            sphere,
        },
        Ok(plan),
        choice.resolve(plan.kind(), expected.um, expected.um),
    );
    let u: Vec<Option<f64>> = (0..est.theta.len())
        .map(|i| {
            est.identifiable(i).then(|| match &budget {
                Ok(b) => b.u(i),
                Err(_) => est.cov_unit[(i, i)].max(0.0).sqrt() * expected.um,
            })
        })
        .collect();
    let basis = match &budget {
        Ok(_) => choice.describe(plan.kind()),
        Err(why) => format!("the measurement noise only ({why})"),
    };
    let file = est.error_file(Some(&u));
    let limits = &kin.machine().limits;
    let rows = symbols
        .location
        .iter()
        .map(|l| {
            let q = file.location_errors.get(&l.name);
            let t = useful.threshold(&l.name, l.unit, limits);
            if let Some(u) = q.and_then(|q| q.u).filter(|u| *u > t.u) {
                return PreviewRow {
                    symbol: l.name.clone(),
                    unit: l.unit.to_string(),
                    u: None,
                    reason: Some(format!(
                        "seen, but not usefully: u = {u:.3} {} above {} {} ({})",
                        l.unit, t.u, l.unit, t.from
                    )),
                };
            }
            PreviewRow {
                symbol: l.name.clone(),
                unit: l.unit.to_string(),
                u: q.and_then(|q| q.u),
                reason: match q.and_then(|q| q.u) {
                    Some(_) => None,
                    None => Some(
                        file.not_identifiable
                            .iter()
                            .find(|n| n.symbol == l.name)
                            .map(|n| n.reason.clone())
                            .unwrap_or_else(|| "the design does not see it".into()),
                    ),
                },
            }
        })
        .collect();
    let unseen = file
        .not_identifiable
        .iter()
        .filter(|n| !symbols.location.iter().any(|l| l.name == n.symbol))
        .map(|n| format!("{}: {}", n.symbol, n.reason))
        .collect();
    Ok(Preview {
        method,
        noise: expected,
        basis,
        rank: (est.identifiability.rank, est.identifiability.free),
        rows,
        unseen,
        summary: None,
    })
}

/// How the nine-section heights respond to each location error: the
/// heights of sections 2.. (relative to section 1) the simulator gives
/// with one unit (1 um or 1 urad) of that error alone, exact and without
/// noise. Columns in the symbol table's order.
pub fn nine_section_sensitivity(
    plan: &Plan,
) -> Result<(Vec<String>, nalgebra::DMatrix<f64>), AnalyzeError> {
    let kin = simulate::plan_kinematics(plan);
    let symbols = crate::kinematics::symbols::SymbolTable::for_kinematics(&kin);
    let name = kin.machine().name.clone();
    let path = std::path::Path::new("(one unit of one error)");
    let heights = |body: &str| -> Result<Vec<f64>, AnalyzeError> {
        let src = format!("machine: {name}\n{body}");
        let errors = ErrorFile::parse(path, &src)?.to_model(&kin, path, &src)?;
        let sim = simulate::run(plan, &errors, &SimOptions::exact())
            .map_err(|e| AnalyzeError::Plan(format!("cannot simulate the plan: {e}")))?;
        Ok(sim
            .heights
            .unwrap_or_default()
            .iter()
            .filter(|h| h.section > 1)
            .map(|h| h.height_um)
            .collect())
    };
    let zero = heights("")?;
    let mut cols = Vec::new();
    for l in &symbols.location {
        let h = heights(&format!("location_errors:\n  {}: 1.0\n", l.name))?;
        cols.push(h.iter().zip(&zero).map(|(a, b)| a - b).collect::<Vec<_>>());
    }
    let rows = zero.len();
    let j = nalgebra::DMatrix::from_fn(rows, cols.len(), |r, c| {
        cols[c].get(r).copied().unwrap_or(0.0)
    });
    Ok((symbols.location.iter().map(|l| l.name.clone()).collect(), j))
}

/// The nine-section test's preview: its rank is that of the heights'
/// real sensitivity to the location errors, and each row says how much
/// the heights respond to the error; no error is identified, because the
/// test evaluates a machine (its heights are compared before and after a
/// compensation), and `analyze` reports AVG, MAX and RMS only.
fn nine_section(
    plan: &Plan,
    symbols: &crate::kinematics::symbols::SymbolTable,
    method: Method,
    expected: ExpectedNoise,
) -> Result<Preview, AnalyzeError> {
    let (_, j) = nine_section_sensitivity(plan)?;
    let rank = if j.nrows() == 0 || j.ncols() == 0 {
        0
    } else {
        let sv = j.clone().svd(false, false).singular_values;
        let top = sv.iter().fold(0.0f64, |a, &b| a.max(b));
        sv.iter().filter(|&&x| x > top * 1e-6 && x > 1e-9).count()
    };
    // An error the heights would determine on their own: its unit vector
    // lies in the row space of the sensitivity.
    let alone = |c: usize| -> bool {
        if rank == 0 {
            return false;
        }
        let svd = j.clone().svd(false, true);
        let Some(vt) = svd.v_t else { return false };
        let top = svd.singular_values.iter().fold(0.0f64, |a, &b| a.max(b));
        let mut inside = 0.0;
        for (k, sv) in svd.singular_values.iter().enumerate() {
            if *sv > top * 1e-6 && *sv > 1e-9 {
                inside += vt[(k, c)] * vt[(k, c)];
            }
        }
        inside > 1.0 - 1e-6
    };
    let rows: Vec<PreviewRow> = symbols
        .location
        .iter()
        .enumerate()
        .map(|(c, l)| {
            let col = j.column(c);
            let (lo, hi) = col.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
                (lo.min(x.abs()), hi.max(x.abs()))
            });
            let reason = if hi < 1e-9 {
                "the section heights do not respond to it".to_string()
            } else {
                let v = |x: f64| {
                    if x == 0.0 || x >= 0.005 {
                        format!("{x:.2}")
                    } else {
                        format!("{x:.1e}")
                    }
                };
                format!(
                    "the section heights respond to it ({}-{} um per {}){}",
                    v(lo),
                    v(hi),
                    l.unit,
                    if alone(c) {
                        ", and would determine it alone"
                    } else {
                        ", together with others"
                    }
                )
            };
            PreviewRow {
                symbol: l.name.clone(),
                unit: l.unit.to_string(),
                u: None,
                reason: Some(reason),
            }
        })
        .collect();
    let responding = rows
        .iter()
        .filter(|r| !r.reason.as_deref().unwrap_or("").contains("do not respond"))
        .count();
    let summary = format!(
        "the heights of sections 2-9 respond to {responding} of the {} location errors, in {rank} independent combinations (rank {rank}); {}",
        rows.len(),
        super::NINE_SECTION_REASON
    );
    Ok(Preview {
        method,
        noise: expected,
        basis: "nothing: the nine-section test evaluates, it does not identify".into(),
        rank: (rank, symbols.location.len()),
        rows,
        unseen: Vec::new(),
        summary: Some(summary),
    })
}
