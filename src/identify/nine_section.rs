//! Statistics of the nine-section test (seed 004 section 6, table 4): the
//! depth of each section relative to section 1, summarised as AVG (mean of
//! the signed heights), MAX (largest absolute height) and RMS (root mean
//! square), all over every section including section 1 itself, as the
//! seed's table computes them.

use crate::formats::heights::SectionHeight;

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

    /// The rate of improvement of each statistic from `before` to `self`,
    /// percent (seed 004 table 4: `(|before| - |after|) / |before|`).
    pub fn improvement_over(&self, before: &NineSection) -> [f64; 3] {
        let rate = |b: f64, a: f64| (b.abs() - a.abs()) / b.abs() * 100.0;
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
