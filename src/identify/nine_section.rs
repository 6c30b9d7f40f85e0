//! Statistics of the nine-section test (Cubas Brizuela & Yeh 2023, section 6, table 4): the
//! depth of each section relative to section 1, summarised as AVG (mean of
//! the signed heights), MAX (largest absolute height) and RMS (root mean
//! square), all over every section including section 1 itself, as the
//! seed's table computes them.
//!
//! The heights come either as measured (`section,height_um`) or from the
//! CMM's DMIS output of the planner's nine-section points: each point's
//! deviation along its nominal direction, in the CMM program's alignment
//! (the piece's datum, as the micrometer's), averaged per section and taken
//! relative to section 1. A best fit of the sections themselves would
//! remove their common tilt, which is part of what the test shows, so
//! points without nominals are refused.

use crate::formats::detect::PointSet;
use crate::formats::heights::SectionHeight;
use crate::formats::points::PlanPoints;

/// The statistics of one nine-section piece.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NineSection {
    /// Heights by section, um, in section order.
    pub sections: Vec<(u32, f64)>,
    /// Mean of the signed heights, um.
    pub avg_um: f64,
    /// Largest absolute height, um.
    pub max_um: f64,
    /// Root mean square of the heights, um.
    pub rms_um: f64,
}

/// Why measured points cannot be read as section heights.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DeviationError {
    /// A measured label the plan does not have.
    #[error("line {line}: `{label}` is not a point of the plan")]
    NotInPlan {
        /// Line of the measurement file.
        line: usize,
        /// The label.
        label: String,
    },
    /// A point without the nominal the deviation is measured along.
    #[error(
        "line {line}: `{label}` has no nominal point and direction: nine-section heights need the CMM's DMIS output (F and FA) or section,height_um"
    )]
    NoNominal {
        /// Line of the measurement file.
        line: usize,
        /// The label.
        label: String,
    },
    /// The reference section has no point.
    #[error("section 1 (pose {pose}) was not measured")]
    FirstSectionMissing {
        /// The section's pose.
        pose: String,
    },
    /// Planned points without a measurement: a section's height from part
    /// of its points (every other one, the file's first lines) is not the
    /// height the test defines, so nothing is computed.
    #[error(
        "{measured} of the plan's {planned} points are measured; missing {}: {by_section}{}; a nine-section result needs every planned point",
        planned - measured,
        if first.is_empty() { String::new() } else { format!(" (first: {})", first.join(", ")) }
    )]
    Missing {
        /// Points measured.
        measured: usize,
        /// Points planned.
        planned: usize,
        /// Missing points by section (`section 7: 24 of 24, ...`).
        by_section: String,
        /// The first missing labels.
        first: Vec<String>,
    },
    /// A deviation no machine's errors cut.
    #[error(
        "line {line}: `{label}` lies {} um from its nominal along its direction, beyond the largest error fivecal takes ({max} um): a wrong line or unit",
        crate::numbers::echo(*deviation_um)
    )]
    Implausible {
        /// Line of the measurement file.
        line: usize,
        /// The label.
        label: String,
        /// The deviation, um.
        deviation_um: f64,
        /// The bound, um.
        max: f64,
    },
}

impl NineSection {
    /// Computes the statistics.
    pub fn new(heights: &[SectionHeight]) -> NineSection {
        let n = heights.len().max(1) as f64;
        let v: Vec<f64> = heights.iter().map(|h| h.height_um).collect();
        NineSection {
            sections: heights.iter().map(|h| (h.section, h.height_um)).collect(),
            avg_um: v.iter().sum::<f64>() / n,
            max_um: v.iter().fold(0.0f64, |a, b| a.max(b.abs())),
            rms_um: (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
        }
    }

    /// The statistics from the DMIS output of a nine-section piece: the
    /// sections are the plan's poses in execution order (section 1
    /// first), each point's deviation is along the file's own nominal
    /// direction. Fails, saying why, when a point lacks its nominal.
    pub(crate) fn from_deviations(
        plan: &PlanPoints,
        set: &PointSet,
    ) -> Result<NineSection, DeviationError> {
        NineSection::check_coverage(plan, set)?;
        let mut poses: Vec<(u32, String)> = Vec::new();
        for p in &plan.points {
            if !poses.iter().any(|q| q.1 == p.pose) {
                poses.push((p.seq, p.pose.clone()));
            }
        }
        poses.sort();
        let mut sums = vec![(0.0, 0usize); poses.len()];
        for m in &set.points {
            let Some(pp) = plan.points.iter().find(|p| p.label == m.label) else {
                return Err(DeviationError::NotInPlan {
                    line: m.line,
                    label: m.label.clone(),
                });
            };
            let Some((p, n)) = set
                .nominals
                .iter()
                .find(|n| n.label == m.label)
                .and_then(|n| Some((n.p, n.n?)))
            else {
                return Err(DeviationError::NoNominal {
                    line: m.line,
                    label: m.label.clone(),
                });
            };
            let k = poses.iter().position(|q| q.1 == pp.pose).unwrap_or(0);
            let d = n.dot(&(m.p - p)) * 1e3;
            let max = crate::limits::MAX_ERROR_UM;
            if !d.is_finite() || d.abs() > max {
                return Err(DeviationError::Implausible {
                    line: m.line,
                    label: m.label.clone(),
                    deviation_um: d,
                    max,
                });
            }
            sums[k].0 += d;
            sums[k].1 += 1;
        }
        if sums[0].1 == 0 {
            return Err(DeviationError::FirstSectionMissing {
                pose: poses[0].1.clone(),
            });
        }
        let reference = sums[0].0 / sums[0].1 as f64;
        let heights: Vec<SectionHeight> = sums
            .iter()
            .enumerate()
            .filter(|(_, s)| s.1 > 0)
            .map(|(i, s)| SectionHeight {
                section: i as u32 + 1,
                height_um: s.0 / s.1 as f64 - reference,
                line: 0,
            })
            .collect();
        Ok(NineSection::new(&heights))
    }

    /// Refuses a measurement that lacks planned points: a section's height
    /// from part of its points (every other one, the file's first lines)
    /// is not the height the test defines. Checked before the points are
    /// joined, so a file of three points is named for what it lacks.
    pub(crate) fn check_coverage(plan: &PlanPoints, set: &PointSet) -> Result<(), DeviationError> {
        // Points joined by position, not label, are checked by the join.
        if !set.labeled {
            return Ok(());
        }
        let mut poses: Vec<(u32, String)> = Vec::new();
        for p in &plan.points {
            if !poses.iter().any(|q| q.1 == p.pose) {
                poses.push((p.seq, p.pose.clone()));
            }
        }
        poses.sort();
        // Every planned point must be there (the join refuses labels the
        // plan does not have and labels measured twice).
        let measured: std::collections::HashSet<&str> =
            set.points.iter().map(|m| m.label.as_str()).collect();
        let missing: Vec<&crate::formats::points::PlanPoint> = plan
            .points
            .iter()
            .filter(|p| !measured.contains(p.label.as_str()))
            .collect();
        if !missing.is_empty() {
            let mut by_section = Vec::new();
            for (k, (_, pose)) in poses.iter().enumerate() {
                let planned = plan.points.iter().filter(|p| &p.pose == pose).count();
                let gone = missing.iter().filter(|p| &p.pose == pose).count();
                if gone > 0 {
                    by_section.push(format!("section {}: {gone} of {planned}", k + 1));
                }
            }
            const LISTED: usize = 8;
            if by_section.len() > LISTED {
                let more = by_section.len() - LISTED;
                by_section.truncate(LISTED);
                by_section.push(format!(
                    "{more} more section{}",
                    if more > 1 { "s" } else { "" }
                ));
            }
            return Err(DeviationError::Missing {
                measured: plan.points.len() - missing.len(),
                planned: plan.points.len(),
                by_section: by_section.join(", "),
                first: missing
                    .iter()
                    .take(5)
                    .map(|p| crate::source::cut(&p.label))
                    .collect(),
            });
        }
        Ok(())
    }

    /// The rate of improvement of each statistic from `before` to `self`,
    /// percent (Cubas Brizuela & Yeh 2023, table 4: `(|before| - |after|) / |before|`).
    /// A statistic that was zero before has no rate (`None`): the quotient
    /// would be infinite or not a number.
    pub fn improvement_over(&self, before: &NineSection) -> [Option<f64>; 3] {
        let rate = |b: f64, a: f64| (b != 0.0).then(|| (b.abs() - a.abs()) / b.abs() * 100.0);
        [
            rate(before.avg_um, self.avg_um),
            rate(before.max_um, self.max_um),
            rate(before.rms_um, self.rms_um),
        ]
    }

    /// Text table.
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::from("section  height_um\n");
        for (k, h) in &self.sections {
            let _ = writeln!(s, "{k:>7}  {h:>9.3}");
        }
        let _ = writeln!(
            s,
            "AVG {:.4} um, MAX {:.4} um, RMS {:.4} um",
            self.avg_um, self.max_um, self.rms_um
        );
        s
    }
}
