//! The error symbols of docs/model.md (ISO 230-1 style, e.g. `EX0B`,
//! `EA(0B)C`, `EXC(B,C)`) and how each maps onto the model's error terms.
//!
//! A location symbol is a fixed linear combination of constant terms: most
//! are one term, two are sums (`EB0B = b_BY + b_CB`, `EY0C = dy_BY + dy_CB`)
//! because only the sum is observable. When a value is written into the
//! model it goes to one *canonical* term of the combination (Ibaraki & Ota 2014, table
//! 1: `b_CB`, `dy_CB`), so `simulate` and `analyze` agree on the meaning.
//! Map symbols name single terms as functions of the index angles.
//!
//! Head-table and head-head machines are this project's extension of the
//! model of docs/model.md: their location symbols describe each head axis line relative to the
//! spindle, since a constant offset of the whole head is a work-offset error
//! that no test can see.

use std::fmt;

use super::{Kinematics, LINKS};
use crate::geom::{MM_PER_UM, RAD_PER_URAD};
use crate::machine::Structure;

/// Unit of a symbol's value in error files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Micrometres (lengths).
    Um,
    /// Microradians (angles).
    Urad,
}

impl Unit {
    /// Model units (mm or rad) per file unit.
    pub fn scale(self) -> f64 {
        match self {
            Unit::Um => MM_PER_UM,
            Unit::Urad => RAD_PER_URAD,
        }
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unit::Um => "um",
            Unit::Urad => "urad",
        })
    }
}

/// A location-error symbol.
#[derive(Clone, Debug, PartialEq)]
pub struct LocationSymbol {
    /// `EX0B`, ...
    pub name: String,
    /// Its value = sum of coef * term / unit scale.
    pub terms: Vec<(usize, f64)>,
    /// The term a value is written into, with its coefficient.
    pub canonical: (usize, f64),
    /// um or urad.
    pub unit: Unit,
    /// What it is.
    pub description: String,
}

/// How a zero-point symbol's description starts.
const ZERO_POINT: &str = "zero (angular positioning) error";

impl LocationSymbol {
    /// Whether it is the zero (angular positioning) error of an axis:
    /// where the axis reads zero, not where its line lies.
    pub(crate) fn is_zero_point(&self) -> bool {
        self.description.starts_with(ZERO_POINT)
    }
}

/// A position-dependent symbol: one term as a function of index angles.
#[derive(Clone, Debug, PartialEq)]
pub struct MapSymbol {
    /// `EXB(B)`, `ECC(B,C)`, ...
    pub name: String,
    /// The term slot.
    pub slot: usize,
    /// The angles it runs over (0 = tilt, 1 = C), in grid order.
    pub deps: Vec<usize>,
    /// um or urad.
    pub unit: Unit,
}

/// Why a symbol name is not accepted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SymbolError {
    /// Not a symbol of this machine at all.
    #[error("unknown symbol `{name}`: expected one of {expected}")]
    Unknown {
        /// The name.
        name: String,
        /// The accepted names.
        expected: String,
    },
    /// A known quantity that tests of this kind cannot identify.
    #[error("`{name}` is not identifiable on this machine: {reason}")]
    NotIdentifiable {
        /// The name.
        name: String,
        /// Why.
        reason: String,
    },
}

/// All symbols of one machine.
#[derive(Clone, Debug, PartialEq)]
pub struct SymbolTable {
    /// Location symbols, in the order of docs/model.md.
    pub location: Vec<LocationSymbol>,
    /// Map symbols.
    pub maps: Vec<MapSymbol>,
    /// Names that are recognized but rejected, with the reason.
    pub not_identifiable: Vec<(String, String)>,
    /// The machine's tilt-axis letter.
    pub tilt: char,
    /// Per linear axis (X, Y, Z), which linear axes' positions make the
    /// lever arm of its angular error motions ([`linear_levers`]).
    pub levers: [[bool; 3]; 3],
}

/// For each linear axis L of `chain` (workpiece to tool, `F` the frame),
/// the linear axes whose program positions are in the lever arm of L's
/// angular error motions: the tool tip relative to a point of L's carriage.
/// A tool-side axis (after F) carries the axes after it, so its lever holds
/// their positions and not its own (the point rides along with L). A
/// table-side axis carries the workpiece and the table-side axes before it;
/// relative to its carriage the tip moves with L itself, the table-side
/// axes between L and F and every tool-side axis: all from L on.
pub fn linear_levers(chain: &str) -> [[bool; 3]; 3] {
    let at = |c: char| chain.chars().position(|x| x == c);
    let f = at('F').unwrap_or(0);
    let mut out = [[false; 3]; 3];
    for (l, &lc) in LIN.iter().enumerate() {
        let Some(i) = at(lc) else { continue };
        for (m, &mc) in LIN.iter().enumerate() {
            let Some(j) = at(mc) else { continue };
            out[l][m] = j > i || (j == i && i < f);
        }
    }
    out
}

const LIN: [char; 3] = ['X', 'Y', 'Z'];
const ROT: [char; 3] = ['A', 'B', 'C'];

fn s(link: usize, k: usize) -> usize {
    link * 6 + k
}

impl SymbolTable {
    /// The symbols of a machine.
    pub fn for_kinematics(k: &Kinematics) -> SymbolTable {
        let m = k.machine();
        let mut list = Listing::default();
        match m.structure {
            Structure::TableTable => list.table_table(k),
            Structure::HeadTable | Structure::HeadHead => {
                if m.structure == Structure::HeadTable {
                    list.c_table(k);
                } else {
                    list.c_head(k);
                }
                list.tilt_head(k);
            }
        }
        SymbolTable {
            location: list.loc,
            maps: map_symbols(k),
            not_identifiable: list.rej,
            tilt: m.tilt.letter,
            levers: linear_levers(&m.chain),
        }
    }

    fn reject(&self, name: &str, expected: String) -> SymbolError {
        if let Some((_, reason)) = self.not_identifiable.iter().find(|(n, _)| n == name) {
            return SymbolError::NotIdentifiable {
                name: name.to_string(),
                reason: reason.clone(),
            };
        }
        SymbolError::Unknown {
            name: name.to_string(),
            expected,
        }
    }

    /// Index of a location symbol.
    pub fn location_index(&self, name: &str) -> Result<usize, SymbolError> {
        self.location.iter().position(|s| s.name == name).ok_or_else(|| {
            if self.maps.iter().any(|m| m.name == name) {
                return SymbolError::Unknown {
                    name: name.to_string(),
                    expected: format!("a location symbol ({}); `{name}` is a position-dependent symbol and belongs under position_dependent", self.location_names()),
                };
            }
            self.reject(name, self.location_names())
        })
    }

    /// Index of a map symbol.
    pub fn map_index(&self, name: &str) -> Result<usize, SymbolError> {
        self.maps
            .iter()
            .position(|s| s.name == name)
            .ok_or_else(|| {
                let names: Vec<&str> = self.maps.iter().map(|m| m.name.as_str()).collect();
                self.reject(name, names.join(", "))
            })
    }

    /// The location symbol names, comma-separated.
    pub(crate) fn location_names(&self) -> String {
        self.location
            .iter()
            .map(|s| s.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The location symbols of a machine as they are listed, and the location
/// errors rejected as not identifiable, each with its reason.
#[derive(Default)]
struct Listing {
    loc: Vec<LocationSymbol>,
    rej: Vec<(String, String)>,
}

impl Listing {
    /// Lists one symbol: its name, its terms (slot, coefficient), the slot it
    /// is canonically written to, its unit and what it is.
    fn add(
        &mut self,
        name: String,
        terms: Vec<(usize, f64)>,
        canonical: (usize, f64),
        unit: Unit,
        description: String,
    ) {
        self.loc.push(LocationSymbol {
            name,
            terms,
            canonical,
            unit,
            description,
        })
    }

    /// A table-table machine: the tilt axis's and the C table's lines.
    fn table_table(&mut self, k: &Kinematics) {
        let m = k.machine();
        let t = m.tilt.letter;
        let it = m.tilt.about.index();
        let io = 1 - it;
        let name = |slot: usize| k.slot_name(slot).unwrap_or_default();
        let one = |slot| (vec![(slot, 1.0)], (slot, 1.0));
        let (a, b) = one(s(0, io));
        self.add(
            format!("E{}0{t}", LIN[io]),
            a,
            b,
            Unit::Um,
            format!("position of the {t}-axis average line in {}", LIN[io]),
        );
        let (a, b) = one(s(0, 2));
        self.add(
            format!("EZ0{t}"),
            a,
            b,
            Unit::Um,
            format!("position of the {t}-axis average line in Z"),
        );
        let (a, b) = one(s(0, 3 + io));
        self.add(
            format!("E{}0{t}", ROT[io]),
            a,
            b,
            Unit::Urad,
            format!(
                "orientation of the {t}-axis average line around {}",
                LIN[io]
            ),
        );
        let (a, b) = one(s(0, 5));
        self.add(
            format!("EC0{t}"),
            a,
            b,
            Unit::Urad,
            format!("orientation of the {t}-axis average line around Z"),
        );
        self.add(
            format!("E{}0{t}", ROT[it]),
            vec![(s(0, 3 + it), 1.0), (s(1, 3 + it), 1.0)],
            (s(1, 3 + it), 1.0),
            Unit::Urad,
            format!("{ZERO_POINT} of {t}"),
        );
        let (a, b) = one(s(1, io));
        self.add(
            format!("E{}(0{t})C", LIN[io]),
            a,
            b,
            Unit::Um,
            format!(
                "position of the C-axis average line from {t} in {}",
                LIN[io]
            ),
        );
        self.add(
            format!("E{}0C", LIN[it]),
            vec![(s(0, it), 1.0), (s(1, it), 1.0)],
            (s(1, it), 1.0),
            Unit::Um,
            format!("position of the C-axis average line in {}", LIN[it]),
        );
        let (a, b) = one(s(1, 3 + io));
        self.add(
            format!("E{}(0{t})C", ROT[io]),
            a,
            b,
            Unit::Urad,
            format!("squareness of C to {t} (around {})", LIN[io]),
        );
        self.rej.push((
            format!("E{}0{t}", LIN[it]),
            format!("{} moves the C axis along the {t} axis; only its sum with {} is seen, reported as E{}0C", name(s(0, it)), name(s(1, it)), LIN[it]),
        ));
        for n in ["EZ0C".to_string(), format!("EZ(0{t})C")] {
            self.rej.push((n, format!("{} moves the C axis along its own direction, which changes nothing a test can see", name(s(1, 2)))));
        }
        for n in ["EC0C".to_string(), format!("EC(0{t})C")] {
            self.rej.push((n, format!("{} (the zero of C) is indistinguishable from the workpiece's own rotation on the table", name(s(1, 5)))));
        }
        self.rej.push((
            format!("E{}(0{t})C", ROT[it]),
            format!(
                "{} is seen only in its sum with {}, reported as E{}0{t}",
                name(s(1, 3 + it)),
                name(s(0, 3 + it)),
                ROT[it]
            ),
        ));
        self.rej.push((
            format!("E{}(0{t})C", LIN[it]),
            format!(
                "{} is seen only in its sum with {}, reported as E{}0C",
                name(s(1, it)),
                name(s(0, it)),
                LIN[it]
            ),
        ));
    }

    /// A head-table machine's C table: its line's position and orientation.
    fn c_table(&mut self, k: &Kinematics) {
        let name = |slot: usize| k.slot_name(slot).unwrap_or_default();
        let one = |slot, coef| (vec![(slot, coef)], (slot, coef));
        for (i, what) in [(0usize, "position"), (1, "position")] {
            let (a, b) = one(s(0, i), 1.0);
            self.add(
                format!("E{}0C", LIN[i]),
                a,
                b,
                Unit::Um,
                format!("{what} of the C-table axis average line in {}", LIN[i]),
            );
        }
        for i in [0usize, 1] {
            let (a, b) = one(s(0, 3 + i), 1.0);
            self.add(
                format!("E{}0C", ROT[i]),
                a,
                b,
                Unit::Urad,
                format!(
                    "orientation of the C-table axis average line around {}",
                    LIN[i]
                ),
            );
        }
        self.rej.push(("EZ0C".into(), format!("{} moves the C table along its own axis, which a test cannot tell from a work-offset error", name(s(0, 2)))));
        self.rej.push(("EC0C".into(), format!("{} (the zero of a single C table) is indistinguishable from the workpiece's own rotation", name(s(0, 5)))));
    }

    /// A head-head machine's C head: its line relative to the tool, its
    /// orientation and zero.
    fn c_head(&mut self, k: &Kinematics) {
        let m = k.machine();
        let t = m.tilt.letter;
        let name = |slot: usize| k.slot_name(slot).unwrap_or_default();
        let one = |slot, coef| (vec![(slot, coef)], (slot, coef));
        for i in [0usize, 1] {
            let (a, b) = one(s(1, i), -1.0);
            self.add(
                format!("E{}0C", LIN[i]),
                a,
                b,
                Unit::Um,
                format!(
                    "position of the C-head axis line relative to the tool in {}",
                    LIN[i]
                ),
            );
        }
        for i in [0usize, 1, 2] {
            let (a, b) = one(s(0, 3 + i), 1.0);
            let what = if i == 2 {
                format!("{ZERO_POINT} of the C head")
            } else {
                format!("orientation of the C-head axis line around {}", LIN[i])
            };
            self.add(format!("E{}0C", ROT[i]), a, b, Unit::Urad, what);
        }
        self.rej.push(("EZ0C".into(), format!("{} moves the C head along its own axis, which a test cannot tell from a work-offset error", name(s(0, 2)))));
        self.rej.push((
            format!("EC0{t}"),
            format!(
                "{} turns the {t} axis about Z exactly as the zero of C does; reported as EC0C",
                name(s(1, 5))
            ),
        ));
    }

    /// A tilting head (head-table or head-head): its line relative to the
    /// spindle, its orientation and zero, the spindle's squareness to it.
    fn tilt_head(&mut self, k: &Kinematics) {
        let m = k.machine();
        let t = m.tilt.letter;
        let it = m.tilt.about.index();
        let io = 1 - it;
        let name = |slot: usize| k.slot_name(slot).unwrap_or_default();
        let one = |slot, coef| (vec![(slot, coef)], (slot, coef));
        let (a, b) = one(s(2, io), -1.0);
        self.add(
            format!("E{}0{t}", LIN[io]),
            a,
            b,
            Unit::Um,
            format!(
                "position of the {t}-head axis line relative to the spindle axis in {}",
                LIN[io]
            ),
        );
        let (a, b) = one(s(2, 2), -1.0);
        self.add(
            format!("EZ0{t}"),
            a,
            b,
            Unit::Um,
            format!(
                "height of the {t}-head axis line above the tool tip (pivot-length error; indistinguishable from a tool-length error)"
            ),
        );
        let (a, b) = one(s(1, 3 + io), 1.0);
        self.add(
            format!("E{}0{t}", ROT[io]),
            a,
            b,
            Unit::Urad,
            format!("orientation of the {t}-head axis line around {}", LIN[io]),
        );
        if m.structure == Structure::HeadTable {
            let (a, b) = one(s(1, 5), 1.0);
            self.add(
                format!("EC0{t}"),
                a,
                b,
                Unit::Urad,
                format!("orientation of the {t}-head axis line around Z"),
            );
        }
        let (a, b) = one(s(1, 3 + it), 1.0);
        self.add(
            format!("E{}0{t}", ROT[it]),
            a,
            b,
            Unit::Urad,
            format!("{ZERO_POINT} of the {t} head"),
        );
        let (a, b) = one(s(2, 3 + io), 1.0);
        self.add(
            format!("E{}(0{t})S", ROT[io]),
            a,
            b,
            Unit::Urad,
            format!("squareness of the spindle axis to {t} (around {})", LIN[io]),
        );
        self.rej.push((
            format!("E{}0{t}", LIN[it]),
            if m.structure == Structure::HeadTable {
                format!("{} shifts the tool along the {t} axis by the same amount at every angle, which a test cannot tell from a work-offset error", name(s(2, it)))
            } else {
                format!("{} moves the tool along the {t} axis exactly as {} does; part of E{}0C", name(s(2, it)), name(s(1, it)), LIN[it])
            },
        ));
    }
}

/// The error-map symbols: six components of every link whose error
/// depends on a rotary axis angle.
fn map_symbols(k: &Kinematics) -> Vec<MapSymbol> {
    let t = k.machine().tilt.letter;
    let mut maps = Vec::new();
    for (l, info) in k.links().iter().enumerate().take(LINKS) {
        if info.map_deps.is_empty() {
            continue;
        }
        let deps: Vec<String> = info
            .map_deps
            .iter()
            .map(|&d| {
                if d == 0 {
                    t.to_string()
                } else {
                    "C".to_string()
                }
            })
            .collect();
        for comp in 0..6 {
            let letter = if comp < 3 { LIN[comp] } else { ROT[comp - 3] };
            maps.push(MapSymbol {
                name: format!("E{letter}{}({})", info.child, deps.join(",")),
                slot: s(l, comp),
                deps: info.map_deps.clone(),
                unit: if comp < 3 { Unit::Um } else { Unit::Urad },
            });
        }
    }
    maps
}
