//! QIF 3 (ISO 23952) documents written for a plan: the measurement plan a
//! CMM that imports QIF plans runs (`plan` writes `<test>.qif`), and the
//! results a CMM writes for it (`simulate --format qif`).
//!
//! Both carry the same `Features` section: one `PointFeatureDefinition`,
//! and per plan point a `PointFeatureNominal` (its `Location` in W, mm, and
//! its outward unit `Normal`, along which it is probed) and a
//! `PointFeatureItem` named by the plan point's label. The ids are fixed by
//! the point's position in the plan (nominal `2k+2`, item `2k+3`), so a
//! results file made for the plan refers to the plan's items by the same
//! ids and names; the QIF reader (`formats::qif`) joins its measurements through them. The
//! plan orders the measurements by pose (one `MeasureSpecifiedFeatures`
//! step per cut or station, in execution order); the results hold one
//! `MeasurementResults` with a `PointFeatureMeasurement` per measured
//! point, its status `NOT_CALCULATED` (no tolerance is evaluated).
//! Lengths are in mm (`FileUnits`). The documents validate against the
//! QIF 3.0 schema (`QIFDocument.xsd`).

use std::fmt::Write as _;

use nalgebra::Vector3;
use sha2::{Digest, Sha256};

use super::points::{PlanPoint, fmt_num};

/// One point of a QIF document: its label, nominal surface point in W (mm)
/// and outward unit normal.
#[derive(Clone, Copy, Debug)]
pub struct QifPoint<'a> {
    /// The plan point's label (the feature's name).
    pub label: &'a str,
    /// Nominal surface point in W, mm.
    pub nominal: Vector3<f64>,
    /// Outward unit normal in W.
    pub normal: Vector3<f64>,
}

impl<'a> From<&'a PlanPoint> for QifPoint<'a> {
    fn from(p: &'a PlanPoint) -> QifPoint<'a> {
        QifPoint {
            label: &p.label,
            nominal: p.p,
            normal: p.n,
        }
    }
}

/// Id of the feature nominal of point `k`.
fn nominal_id(k: usize) -> usize {
    2 * k + 2
}

/// Id of the feature item of point `k`.
pub(crate) fn item_id(k: usize) -> usize {
    2 * k + 3
}

/// The first id after the features of `n` points.
fn after_features(n: usize) -> usize {
    2 * n + 2
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn triple(v: &Vector3<f64>, decimals: usize) -> String {
    format!(
        "{} {} {}",
        fmt_num(v.x, decimals),
        fmt_num(v.y, decimals),
        fmt_num(v.z, decimals)
    )
}

/// A QIF persistent id (a UUID in form) derived from the document's
/// content, so the same plan writes the same bytes.
fn qpid(body: &str) -> String {
    let h = Sha256::digest(body.as_bytes());
    let x: String = h.iter().take(16).map(|b| format!("{b:02x}")).collect();
    format!(
        "{}-{}-4{}-8{}-{}",
        &x[0..8],
        &x[8..12],
        &x[13..16],
        &x[17..20],
        &x[20..32]
    )
}

/// The document around `body` (the sections after `FileUnits`), with
/// `comments` as an XML comment first.
fn document(comments: &[String], id_max: usize, body: &str) -> String {
    let mut s = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!--\n");
    for c in comments {
        // `--` may not appear inside an XML comment.
        let _ = writeln!(s, "  {}", c.replace("--", "- -"));
    }
    s.push_str("-->\n");
    let _ = writeln!(
        s,
        "<QIFDocument xmlns=\"http://qifstandards.org/xsd/qif3\" versionQIF=\"3.0.0\" idMax=\"{id_max}\">"
    );
    let _ = writeln!(s, "  <QPId>{}</QPId>", qpid(body));
    s.push_str(
        "  <Header>\n    <Application>\n      <Name>fivecal</Name>\n      <Organization>fivecal</Organization>\n    </Application>\n  </Header>\n",
    );
    s.push_str(
        "  <FileUnits>\n    <PrimaryUnits>\n      <LinearUnit>\n        <SIUnitName>meter</SIUnitName>\n        <UnitName>mm</UnitName>\n        <UnitConversion>\n          <Factor>0.001</Factor>\n        </UnitConversion>\n      </LinearUnit>\n    </PrimaryUnits>\n  </FileUnits>\n",
    );
    s.push_str(body);
    s.push_str("</QIFDocument>\n");
    s
}

/// The `Features` section of `points`.
fn features(points: &[QifPoint<'_>]) -> String {
    let n = points.len();
    let mut s = String::from("  <Features>\n");
    s.push_str("    <FeatureDefinitions n=\"1\">\n      <PointFeatureDefinition id=\"1\"/>\n    </FeatureDefinitions>\n");
    let _ = writeln!(s, "    <FeatureNominals n=\"{n}\">");
    for (k, p) in points.iter().enumerate() {
        let _ = writeln!(
            s,
            "      <PointFeatureNominal id=\"{}\">\n        <FeatureDefinitionId>1</FeatureDefinitionId>\n        <Location>{}</Location>\n        <Normal>{}</Normal>\n      </PointFeatureNominal>",
            nominal_id(k),
            triple(&p.nominal, 6),
            triple(&p.normal, 9)
        );
    }
    s.push_str("    </FeatureNominals>\n");
    let _ = writeln!(s, "    <FeatureItems n=\"{n}\">");
    for (k, p) in points.iter().enumerate() {
        let _ = writeln!(
            s,
            "      <PointFeatureItem id=\"{}\">\n        <FeatureNominalId>{}</FeatureNominalId>\n        <FeatureName>{}</FeatureName>\n        <DeterminationMode>\n          <Checked>\n            <CheckDetails>\n              <Measured/>\n            </CheckDetails>\n          </Checked>\n        </DeterminationMode>\n      </PointFeatureItem>",
            item_id(k),
            nominal_id(k),
            escape(p.label)
        );
    }
    s.push_str("    </FeatureItems>\n  </Features>\n");
    s
}

/// The measurement plan of `points`, measured pose by pose in execution
/// order (`seq`), each pose's points in plan order.
pub fn plan(comments: &[String], points: &[PlanPoint]) -> String {
    let q: Vec<QifPoint<'_>> = points.iter().map(QifPoint::from).collect();
    let mut seqs: Vec<u32> = points.iter().map(|p| p.seq).collect();
    seqs.sort_unstable();
    seqs.dedup();
    let mut body = features(&q);
    let _ = writeln!(
        body,
        "  <Plan>\n    <OrderedPlanRoot>\n      <Steps n=\"{}\">",
        seqs.len()
    );
    for (i, seq) in seqs.iter().enumerate() {
        let ids: Vec<usize> = points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.seq == *seq)
            .map(|(k, _)| item_id(k))
            .collect();
        let _ = writeln!(
            body,
            "        <NumberedPlanElement>\n          <SequenceNumber>{}</SequenceNumber>\n          <MeasureSpecifiedFeatures>\n            <FeatureItemIds n=\"{}\">",
            i + 1,
            ids.len()
        );
        for id in ids {
            let _ = writeln!(body, "              <Id>{id}</Id>");
        }
        body.push_str("            </FeatureItemIds>\n          </MeasureSpecifiedFeatures>\n        </NumberedPlanElement>\n");
    }
    body.push_str("      </Steps>\n    </OrderedPlanRoot>\n  </Plan>\n");
    document(comments, after_features(points.len()) - 1, &body)
}

/// The results of a measurement: each point with where it was measured
/// (mm, in the CMM's frame), in plan order.
pub fn results(comments: &[String], measured: &[(QifPoint<'_>, Vector3<f64>)]) -> String {
    let points: Vec<QifPoint<'_>> = measured.iter().map(|m| m.0).collect();
    let first = after_features(points.len());
    let run_id = first + points.len();
    let mut body = features(&points);
    let _ = writeln!(
        body,
        "  <Results>\n    <MeasurementResultsSet n=\"1\">\n      <MeasurementResults id=\"{run_id}\">\n        <MeasuredFeatures n=\"{}\">",
        measured.len()
    );
    for (k, (_, a)) in measured.iter().enumerate() {
        let _ = writeln!(
            body,
            "          <PointFeatureMeasurement id=\"{}\">\n            <FeatureItemId>{}</FeatureItemId>\n            <Location>{}</Location>\n          </PointFeatureMeasurement>",
            first + k,
            item_id(k),
            triple(a, 6)
        );
    }
    body.push_str("        </MeasuredFeatures>\n        <InspectionStatus>\n          <InspectionStatusEnum>NOT_CALCULATED</InspectionStatusEnum>\n        </InspectionStatus>\n      </MeasurementResults>\n    </MeasurementResultsSet>\n  </Results>\n");
    document(comments, run_id, &body)
}
