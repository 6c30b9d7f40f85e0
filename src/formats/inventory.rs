//! What a measurement file holds, before any plan is involved: the format
//! and version recognized, the units, the measurement runs, each feature or
//! point with its label, nominal and actual coordinates and normal where the
//! file gives them, and what was skipped and why. `fivecal measured` prints
//! it; the readers of the richer formats (QIF, CALYPSO, tables with a
//! header) build it first and take the points `analyze` joins from it, so
//! what `measured` shows is what `analyze` reads.
//!
//! It also holds what every reader shares ([`LengthUnit`],
//! [`MeasuredOptions`], [`PointSet`], [`Nominal`]), so that the readers
//! and `detect.rs`, which recognizes a file and hands it to one of them,
//! stand on it rather than on each other.

use nalgebra::Vector3;

use super::measured::MeasuredPoint;

/// A length unit a file may be in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LengthUnit {
    /// Millimetre.
    Mm,
    /// Inch (25.4 mm).
    Inch,
}

impl LengthUnit {
    /// Millimetres per unit.
    pub fn mm(self) -> f64 {
        match self {
            LengthUnit::Mm => 1.0,
            LengthUnit::Inch => 25.4,
        }
    }

    /// Its name as files and messages write it.
    pub fn name(self) -> &'static str {
        match self {
            LengthUnit::Mm => "mm",
            LengthUnit::Inch => "inch",
        }
    }

    /// The unit by name (`mm`, `inch`, `in`).
    pub fn parse(s: &str) -> Option<LengthUnit> {
        match s.trim().to_ascii_lowercase().as_str() {
            "mm" | "millimeter" | "millimetre" => Some(LengthUnit::Mm),
            "in" | "inch" => Some(LengthUnit::Inch),
            _ => None,
        }
    }
}

/// What the user says about measurement files where the file cannot:
/// which run of a file with several, the unit of a file that states none,
/// the encoding of a file not in UTF-8.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeasuredOptions {
    /// The measurement run to read (1-based) of a file with several.
    pub run: Option<usize>,
    /// The length unit of a file that does not state it.
    pub units: Option<LengthUnit>,
    /// The encoding of a file not in UTF-8.
    pub encoding: Option<&'static encoding_rs::Encoding>,
}

impl MeasuredOptions {
    /// Millimetres per length unit of a file that states none: the unit
    /// the user named, else mm (the plain formats' contract); the
    /// inventory says which.
    pub(crate) fn unstated_unit_mm(&self, inv: &mut Inventory) -> f64 {
        match self.units {
            Some(u) => {
                inv.units = format!("{} (given with --units; the file states none)", u.name());
                u.mm()
            }
            None => 1.0,
        }
    }
}

/// Points read from one file.
#[derive(Clone, Debug, PartialEq)]
pub struct PointSet {
    /// The format's name (`dmis`, `csv`, `plain`, ...).
    pub format: &'static str,
    /// The points; labels are empty when the format has none.
    pub points: Vec<MeasuredPoint>,
    /// Whether the points carry labels.
    pub labeled: bool,
    /// Nominal positions the file itself states, by label (DMIS `F(..)`):
    /// used to check that the file belongs to the plan.
    pub nominals: Vec<Nominal>,
    /// Quirks met while reading.
    pub warnings: Vec<String>,
}

/// A nominal point as a measurement file states it.
#[derive(Clone, Debug, PartialEq)]
pub struct Nominal {
    /// Label.
    pub label: String,
    /// Position in the file's frame, mm.
    pub p: Vector3<f64>,
    /// Unit direction (the surface normal the CMM probed along), if given.
    pub n: Option<Vector3<f64>>,
    /// 1-based line.
    pub line: usize,
}

/// One feature, point or characteristic of a measurement file; lengths in
/// mm whatever the file's unit.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// The file's name for it (empty when the format has none).
    pub label: String,
    /// What it is (`point`, `circle`, `height`, a characteristic's type).
    pub kind: String,
    /// Index of its measurement run in [`Inventory::runs`] (0 when the file
    /// has one).
    pub run: usize,
    /// Nominal position, mm.
    pub nominal: Option<Vector3<f64>>,
    /// Actual (measured) position, mm.
    pub actual: Option<Vector3<f64>>,
    /// Unit direction: the measured normal where the file gives one,
    /// otherwise the nominal's.
    pub normal: Option<Vector3<f64>>,
    /// A value without coordinates (a diameter, a characteristic's measured
    /// value, a height in um), reported as the file states it.
    pub value: Option<f64>,
    /// Raw measured points behind it (a QIF point set), surface points in mm.
    pub points: Vec<Vector3<f64>>,
    /// 1-based line of the file it came from (0 if unknown).
    pub line: usize,
}

impl Entry {
    /// An entry with a label and kind and nothing else yet.
    pub fn new(label: impl Into<String>, kind: impl Into<String>, line: usize) -> Entry {
        Entry {
            label: label.into(),
            kind: kind.into(),
            run: 0,
            nominal: None,
            actual: None,
            normal: None,
            value: None,
            points: Vec::new(),
            line,
        }
    }

    /// Whether it is one measured point `analyze` can join to a plan point.
    pub fn is_point(&self) -> bool {
        self.kind == "point" && self.actual.is_some()
    }
}

/// Something in the file that was not read, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Unread {
    /// 1-based line (0 if unknown).
    pub line: usize,
    /// What it is.
    pub what: String,
    /// Why it was not read.
    pub why: String,
}

/// What a measurement file holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Inventory {
    /// The format's name (`dmis`, `qif`, `calypso`, `csv`, ...).
    pub format: &'static str,
    /// The format's version, where the file states it.
    pub version: Option<String>,
    /// The file's length unit as it states it (`mm`, `inch`); every
    /// length here is converted to mm.
    pub units: String,
    /// The measurement runs (pieces) in the file, by name; one unnamed run
    /// when the format has no runs.
    pub runs: Vec<String>,
    /// Its features, points and characteristics in file order.
    pub entries: Vec<Entry>,
    /// What was not read.
    pub skipped: Vec<Unread>,
    /// Quirks met while reading.
    pub warnings: Vec<String>,
}

impl Inventory {
    /// An empty inventory of a format in mm with one run.
    pub fn new(format: &'static str) -> Inventory {
        Inventory {
            format,
            version: None,
            units: "mm".into(),
            runs: vec![String::new()],
            entries: Vec::new(),
            skipped: Vec::new(),
            warnings: Vec::new(),
        }
    }

    /// What a point reader read, as an inventory: each point with the
    /// nominal the file states for its label.
    pub(crate) fn of_points(set: &PointSet) -> Inventory {
        let mut inv = Inventory::new(set.format);
        let nominal = |label: &str| -> Option<&Nominal> {
            if label.is_empty() {
                return None;
            }
            set.nominals.iter().find(|n| n.label == label)
        };
        for p in &set.points {
            let mut e = Entry::new(p.label.clone(), "point", p.line);
            e.actual = Some(p.p);
            if let Some(n) = nominal(&p.label) {
                e.nominal = Some(n.p);
                e.normal = n.n;
            }
            inv.entries.push(e);
        }
        inv.warnings.clone_from(&set.warnings);
        inv
    }

    /// The measured points of run `run`, for `analyze`: labelled when every
    /// point of that run has a label, with the nominals the file states.
    pub(crate) fn point_set(&self, run: usize) -> PointSet {
        let entries: Vec<&Entry> = self
            .entries
            .iter()
            .filter(|e| e.run == run && e.is_point())
            .collect();
        let labeled = !entries.is_empty() && entries.iter().all(|e| !e.label.is_empty());
        PointSet {
            format: self.format,
            points: entries
                .iter()
                .map(|e| MeasuredPoint {
                    label: if labeled {
                        e.label.clone()
                    } else {
                        String::new()
                    },
                    p: e.actual.expect("is_point"),
                    line: e.line,
                    normal: e.normal,
                })
                .collect(),
            labeled,
            nominals: entries
                .iter()
                .filter_map(|e| {
                    Some(Nominal {
                        label: e.label.clone(),
                        p: e.nominal?,
                        n: e.normal,
                        line: e.line,
                    })
                })
                .filter(|_| labeled)
                .collect(),
            warnings: self.warnings.clone(),
        }
    }
}
