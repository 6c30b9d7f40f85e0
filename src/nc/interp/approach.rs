//! HEIDENHAIN `APPR`/`DEP` `LT`, `LN` and `CT`: the straight lines and
//! tangential arcs that the control builds to and from the contour.
//!
//! Source (read): TNC 640 user's manual, DIN/ISO programming 1/2015,
//! p. 213, "Important positions for approach and departure", and the
//! conversational edition 5/2013 p. 199: the control moves from the
//! position before the `APPR` block (PS) to an auxiliary point PH it
//! computes from the block and the first contour element, then to the
//! first contour point PA the block names; a `DEP` block's end point PN
//! "results from your input in the DEP block". TNC7 basic user's manual
//! 81762x-18, "Approach function APPR LT": a straight line from PS to PH,
//! then a straight line from PH to PA "tangential to the first contour
//! element", `LEN` the distance of PH from the contour; "Departure
//! function DEP LT" likewise leaves the last contour point PE on a
//! straight line tangential to the last contour element, `LEN` long. So
//! PH lies `LEN` back from PA against the direction the first element
//! starts in, and PN `LEN` on from PE along the direction the last one
//! ends in: neither needs the side of the contour, which only radius
//! compensation (RL/RR) gives.
//!
//! `APPR LN`/`DEP LN` (TNC7 basic user's manual 81762x-18, "Approach
//! function APPR LN", "Departure function DEP LN"; TNC 640 user's manual
//! 5/2013): the line between PH (PN) and the contour is perpendicular to
//! the first (last) contour element, PH (PN) "LEN plus the tool radius"
//! from the contour point. The tool's centre on the contour lies the tool
//! radius from it on the side RL/RR puts the tool (left, right of the
//! direction of travel), so a line of length `LEN` square to the element
//! from there reaches that distance only on the same side: the programmed
//! contour's PH (PN) lies `LEN` from PA (PE) on the side RL/RR picks. With
//! R0 there is no side, and the manuals read do not say what the control
//! does; such a block is left as written.
//!
//! `APPR CT`/`DEP CT` (TNC7 user's manual 81762x-16, "Approach functions
//! APPR CT and APPR PCT"; TNC7 basic user's manual 81762x-18, "Approach
//! function APPR CT", "Departure function DEP CT"): the leg between PH and
//! PA (PE and PN) is a circular arc of radius |R| through the centre angle
//! CCA (positive, at most 360 deg), tangent to the contour element where
//! it meets it. Both manuals give the turning direction by the same
//! table: RL with R positive counter-clockwise, negative clockwise; RR
//! with R positive clockwise, negative counter-clockwise. With R0 the
//! TNC7 stops an `APPR CT` with an error, and for a `DEP CT` after a
//! contour without RL/RR the table gives no direction: both are left as
//! written. `APPR LCT`/`DEP LCT` ("Approach function APPR LCT",
//! "Departure function DEP LCT", same manuals) have an arc tangent to the
//! contour and to the straight leg, "uniquely defined by the radius R",
//! but no manual read says which way it turns, and an arc on either side
//! of the element fits: fivecal leaves them as written.
//!
//! Under RL/RR these are the points of the programmed contour (tool
//! radius zero), which is what fivecal corrects, as it does for every
//! `L`/`C`/`CR` under RL/RR: the control offsets the corrected contour by
//! the tool radius, a tangential line by the radius square to its own
//! direction, which is exact where the correction is locally a rigid
//! motion and off by about the radius times the local scale or
//! squareness error otherwise (docs/formats.md).

use super::tangent::{arc_end_direction, direction};
use super::{ArcPlane, Move, MoveKind};

/// Which side of the programmed contour radius compensation puts the
/// tool on, looking along the direction of travel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// `RL`.
    Left,
    /// `RR`.
    Right,
}

/// How the leg between the contour and an approach's auxiliary point
/// (a departure's end) meets the contour element.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Leg {
    /// `LT`: along the element's direction.
    Tangent,
    /// `LN`: square to it, on the side radius compensation puts the tool.
    Normal(Side),
    /// `CT`: a circular arc tangent to the element, of radius `radius`
    /// (|R|, program units) through `cca` degrees, turning clockwise or
    /// not as [`clockwise`] says.
    Arc {
        /// |R|.
        radius: f64,
        /// CCA, degrees.
        cca: f64,
        /// Whether the arc turns clockwise.
        cw: bool,
    },
}

impl Leg {
    /// The path type as the block writes it.
    pub fn name(self) -> &'static str {
        match self {
            Leg::Tangent => "LT",
            Leg::Normal(_) => "LN",
            Leg::Arc { .. } => "CT",
        }
    }
}

/// Whether an `APPR CT`/`DEP CT` arc turns clockwise, from the side
/// radius compensation puts the tool on and the sign of `R` (the table of
/// the TNC7 user's manuals, module docs): RL turns counter-clockwise with
/// R positive, RR clockwise, and a negative R turns the other way.
pub fn clockwise(side: Side, r: f64) -> bool {
    (side == Side::Right) == (r > 0.0)
}

/// The centre of a `CT` leg's arc, which meets the contour at `at` (XY)
/// travelling along the unit direction `dir` there: the radius from it
/// square to `dir`, on the left of the direction of travel for a
/// counter-clockwise arc, on the right for a clockwise one. `None` for a
/// straight leg.
pub fn arc_center(at: [f64; 2], dir: [f64; 2], leg: Leg) -> Option<[f64; 2]> {
    let Leg::Arc { radius, cw, .. } = leg else {
        return None;
    };
    let n = normal(dir, if cw { Side::Right } else { Side::Left });
    Some([at[0] + radius * n[0], at[1] + radius * n[1]])
}

/// `p` turned about `c` by `angle` radians (counter-clockwise positive).
fn turned(p: [f64; 2], c: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, co) = angle.sin_cos();
    let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
    [c[0] + co * dx - s * dy, c[1] + s * dx + co * dy]
}

/// The signed angle (radians, counter-clockwise positive) a `CT` leg
/// turns through along its direction of travel; 0 for a straight leg.
fn swept(leg: Leg) -> f64 {
    match leg {
        Leg::Arc { cca, cw, .. } => cca.to_radians() * if cw { -1.0 } else { 1.0 },
        _ => 0.0,
    }
}

/// An `APPR LT`/`LN`/`CT` whose auxiliary point follows from the element
/// after it, carried by that element's move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Approach {
    /// 1-based line of the `APPR` block.
    pub line: usize,
    /// Its `LEN`, program units.
    pub len: f64,
    /// `LT` or `LN`.
    pub leg: Leg,
    /// Its path as the control runs it (start PS, auxiliary point PH,
    /// first contour point PA; program coordinates, absolute), or why
    /// fivecal cannot say.
    pub path: Result<[[f64; 6]; 3], &'static str>,
    /// For `CT`, the centre (XY) of the arc from PH to PA, which the
    /// points alone do not fix.
    pub arc: Option<[f64; 2]>,
}

/// What an `APPR`/`DEP` block is, on its own move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tangential {
    /// `APPR LT|LN ... LEN..` or `APPR CT ... CCA.. R..`: its end point
    /// PA is written; the leg to it starts at PH, placed from PA as `leg`
    /// says (`len` 0 for `CT`).
    Approach {
        /// `LEN`, program units.
        len: f64,
        /// `LT` or `LN`.
        leg: Leg,
    },
    /// `DEP LT|LN LEN..` or `DEP CT CCA.. R..`: its end PN is placed from
    /// where the tool is, as `leg` says, from the direction the element
    /// before ends in (`len` 0 for `CT`, whose move is the arc itself).
    Departure {
        /// `LEN`, program units.
        len: f64,
        /// `LT` or `LN`.
        leg: Leg,
    },
}

/// Largest change of Z (mm) or of a rotary axis (deg) along a move for
/// which it is still taken to lie in the XY plane: the micrometres a
/// correction tilts a flat contour by, never a contour that climbs (as
/// for a rounding, [`super::corner`]).
const FLAT_MM: f64 = 0.01;
const FLAT_DEG: f64 = 0.001;

/// Whether a move from `s` to `e` stays in the XY plane: Z within
/// `FLAT_MM` (program units times `mm`), the rotary axes within
/// `FLAT_DEG`; an axis known at one end only does not.
pub fn flat(s: &[Option<f64>; 6], e: &[Option<f64>; 6], mm: f64) -> bool {
    (2..6).all(|i| match (s[i], e[i]) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            (b - a).abs() * if i == 2 { mm } else { 1.0 } <= if i == 2 { FLAT_MM } else { FLAT_DEG }
        }
        _ => false,
    })
}

/// The unit vector square to the unit direction `dir` on `side` of it.
pub fn normal(dir: [f64; 2], side: Side) -> [f64; 2] {
    match side {
        Side::Left => [-dir[1], dir[0]],
        Side::Right => [dir[1], -dir[0]],
    }
}

/// The auxiliary point of an `APPR LT`/`LN`/`CT`, from the first contour
/// point `at` and the unit direction `dir` the first element starts in
/// (XY): `len` back against `dir` for `LT`, `len` square to it on the
/// tool's side for `LN`, and for `CT` where the arc that ends at `at`
/// along `dir` starts, CCA back round its centre ([`arc_center`]); the
/// other axes as at `at`.
pub fn approach_aux(at: &[f64; 6], dir: [f64; 2], len: f64, leg: Leg) -> [f64; 6] {
    let xy = match leg {
        Leg::Tangent => [at[0] - len * dir[0], at[1] - len * dir[1]],
        Leg::Normal(side) => {
            let v = normal(dir, side);
            [at[0] + len * v[0], at[1] + len * v[1]]
        }
        Leg::Arc { .. } => match arc_center([at[0], at[1]], dir, leg) {
            Some(c) => turned([at[0], at[1]], c, -swept(leg)),
            None => [at[0], at[1]],
        },
    };
    let mut p = *at;
    p[0] = xy[0];
    p[1] = xy[1];
    p
}

/// The end point of a `DEP LT`/`LN`/`CT`, from the last contour point `at`
/// and the unit direction `dir` the last element ends in (XY): `len` on
/// along `dir` for `LT`, `len` square to it on the tool's side for `LN`,
/// and for `CT` CCA on round the centre of the arc that leaves `at` along
/// `dir` ([`arc_center`]).
pub fn departure_end(at: [f64; 2], dir: [f64; 2], len: f64, leg: Leg) -> [f64; 2] {
    match leg {
        Leg::Tangent => [at[0] + len * dir[0], at[1] + len * dir[1]],
        Leg::Normal(side) => {
            let v = normal(dir, side);
            [at[0] + len * v[0], at[1] + len * v[1]]
        }
        Leg::Arc { .. } => match arc_center(at, dir, leg) {
            Some(c) => turned(at, c, swept(leg)),
            None => at,
        },
    }
}

/// The direction (XY, unit) a move starts in, if it is a line or a circle
/// in the XY plane that moves neither the tool axis nor a rotary axis
/// (the approach is a two-dimensional element; `mm`: millimetres per
/// program unit, see [`flat`]), or why not.
pub fn start_direction(mv: &Move, mm: f64) -> Result<[f64; 2], &'static str> {
    let (Some(s0), Some(s1), Some(e0), Some(e1)) = (mv.start[0], mv.start[1], mv.end[0], mv.end[1])
    else {
        return Err("the first contour element's ends are not known");
    };
    if !flat(&mv.start, &mv.end, mm) {
        return Err(
            "the first contour element moves the tool axis or a rotary axis (the control builds the approach in the working plane)",
        );
    }
    if mv.tangential.is_some() {
        return Err(
            "the first contour element is a CT, which starts in the direction of the approach itself",
        );
    }
    if mv.drill.is_some() || mv.corner.is_some() {
        return Err("the first contour element is not a line or a circle");
    }
    match mv.kind {
        MoveKind::Arc(a) if a.plane == ArcPlane::Xy && a.turns == 0 => {
            arc_end_direction(a.center, [s0, s1], a.cw)
                .ok_or("the first contour element is a circle of no radius")
        }
        MoveKind::Arc(_) | MoveKind::Through(_) => {
            Err("the first contour element is a circle outside the XY plane or a helix")
        }
        MoveKind::Linear | MoveKind::Rapid => direction([s0, s1], [e0, e1])
            .ok_or("the first contour element has no length in the XY plane"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_auxiliary_point_lies_len_back_along_the_first_element() {
        // A contour starting at (20, 20) along +X: PH 10 mm before it on
        // the line's extension, (10, 20); Z and the rotary axes as at PA.
        let at = [20.0, 20.0, -1.0, 0.0, 5.0, 30.0];
        let ph = approach_aux(&at, [1.0, 0.0], 10.0, Leg::Tangent);
        assert_eq!(ph, [10.0, 20.0, -1.0, 0.0, 5.0, 30.0]);
        // Along the diagonal (3, 4) / 5, LEN 15: back by (9, 12).
        let ph = approach_aux(&at, [0.6, 0.8], 15.0, Leg::Tangent);
        assert!((ph[0] - 11.0).abs() < 1e-12 && (ph[1] - 8.0).abs() < 1e-12);
    }

    #[test]
    fn the_departure_end_lies_len_on_along_the_last_element() {
        assert_eq!(
            departure_end([5.0, -3.0], [0.0, -1.0], 12.5, Leg::Tangent),
            [5.0, -15.5]
        );
    }

    /// `LN`: checked against an independent construction, the direction
    /// turned by +90 deg (RL) or -90 deg (RR) through its angle, over
    /// directions all round: `LEN` from the contour point, square to the
    /// element, on the side the cross product gives.
    #[test]
    fn a_perpendicular_point_lies_len_square_to_the_element_on_the_tools_side() {
        let at = [3.0, -7.0, -2.0, 0.0, 10.0, 45.0];
        let len = 12.5;
        for k in 0..24 {
            let a = 0.3 + k as f64 * std::f64::consts::TAU / 24.0;
            let dir = [a.cos(), a.sin()];
            for (side, turn) in [(Side::Left, 1.0), (Side::Right, -1.0)] {
                let b = a + turn * std::f64::consts::FRAC_PI_2;
                let want = [at[0] + len * b.cos(), at[1] + len * b.sin()];
                let ph = approach_aux(&at, dir, len, Leg::Normal(side));
                let pn = departure_end([at[0], at[1]], dir, len, Leg::Normal(side));
                for p in [[ph[0], ph[1]], pn] {
                    assert!((p[0] - want[0]).abs() < 1e-12 && (p[1] - want[1]).abs() < 1e-12);
                    let v = [p[0] - at[0], p[1] - at[1]];
                    assert!((v[0].hypot(v[1]) - len).abs() < 1e-12);
                    assert!((v[0] * dir[0] + v[1] * dir[1]).abs() < 1e-12);
                    // Left of the direction of travel: its cross product
                    // with the offset is positive.
                    let cross = dir[0] * v[1] - dir[1] * v[0];
                    assert!(cross * turn > 0.0, "{side:?} {cross}");
                }
                assert_eq!(ph[2..], at[2..]);
            }
        }
    }

    /// The turning direction of `APPR CT`/`DEP CT`, row by row from the
    /// manuals' table.
    #[test]
    fn a_circular_leg_turns_as_the_manuals_table_says() {
        assert!(!clockwise(Side::Left, 5.0));
        assert!(clockwise(Side::Left, -5.0));
        assert!(clockwise(Side::Right, 5.0));
        assert!(!clockwise(Side::Right, -5.0));
    }

    /// `CT`: checked against an independent construction over directions
    /// all round, both turning directions and centre angles up to a full
    /// circle. The centre lies |R| square to the element at the contour
    /// point, on the side the arc turns to (by the angle of the direction
    /// turned +-90 deg); the other end of the arc is that radius turned
    /// about the centre by CCA, back for an approach, on for a
    /// departure. Then, finitely: both ends are |R| from the centre, the
    /// arc meets the element tangentially (the radius there is square to
    /// it and the arc's own direction of travel is the element's), and
    /// the arc from one end to the other sweeps CCA.
    #[test]
    fn a_circular_leg_is_tangent_to_the_element_and_sweeps_its_centre_angle() {
        use crate::nc::interp::interpolation::ArcGeo;
        use crate::nc::interp::tangent::arc_end_direction;
        let at = [3.0, -7.0, -2.0, 0.0, 10.0, 45.0];
        let r = 7.5;
        for k in 0..24 {
            let a = 0.2 + k as f64 * std::f64::consts::TAU / 24.0;
            let dir = [a.cos(), a.sin()];
            for cw in [false, true] {
                for cca in [10.0, 90.0, 180.0, 270.0, 359.0] {
                    let leg = Leg::Arc { radius: r, cca, cw };
                    let turn = if cw { -1.0 } else { 1.0 };
                    // By hand: the centre, and the angle of the contour
                    // point about it.
                    let b = a + turn * std::f64::consts::FRAC_PI_2;
                    let c = [at[0] + r * b.cos(), at[1] + r * b.sin()];
                    let t0 = b + std::f64::consts::PI;
                    let back = t0 - turn * cca.to_radians();
                    let on = t0 + turn * cca.to_radians();
                    let ph_want = [c[0] + r * back.cos(), c[1] + r * back.sin()];
                    let pn_want = [c[0] + r * on.cos(), c[1] + r * on.sin()];
                    let got = arc_center([at[0], at[1]], dir, leg).unwrap();
                    assert!((got[0] - c[0]).abs() < 1e-12 && (got[1] - c[1]).abs() < 1e-12);
                    let ph = approach_aux(&at, dir, 0.0, leg);
                    let pn = departure_end([at[0], at[1]], dir, 0.0, leg);
                    assert_eq!(ph[2..], at[2..]);
                    for (p, q) in [([ph[0], ph[1]], ph_want), (pn, pn_want)] {
                        assert!(
                            (p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12,
                            "{cw} {cca}: {p:?} {q:?}"
                        );
                        assert!(((p[0] - c[0]).hypot(p[1] - c[1]) - r).abs() < 1e-12);
                    }
                    assert!(((at[0] - c[0]).hypot(at[1] - c[1]) - r).abs() < 1e-12);
                    // Tangent at the contour point, travelling along it.
                    assert!(((at[0] - c[0]) * dir[0] + (at[1] - c[1]) * dir[1]).abs() < 1e-12);
                    let d = arc_end_direction(c, [at[0], at[1]], cw).unwrap();
                    assert!((d[0] - dir[0]).abs() < 1e-12 && (d[1] - dir[1]).abs() < 1e-12);
                    // The approach's arc from PH to PA, the departure's
                    // from PE to PN, sweep CCA.
                    let mut pn6 = at;
                    pn6[0] = pn[0];
                    pn6[1] = pn[1];
                    for (p0, p1) in [(&ph, &at), (&at, &pn6)] {
                        let geo = ArcGeo::new((0, 1, 2), c, p0, p1, cw, 0);
                        assert!(
                            (geo.sweep.abs() - cca.to_radians()).abs() < 1e-9,
                            "{cw} {cca}: {}",
                            geo.sweep.to_degrees()
                        );
                        assert_eq!(geo.sweep < 0.0, cw);
                    }
                }
            }
        }
    }

    fn line(s: [f64; 3], e: [f64; 3]) -> Move {
        let mut mv = Move::new(
            MoveKind::Linear,
            [
                Some(s[0]),
                Some(s[1]),
                Some(s[2]),
                Some(0.0),
                None,
                Some(0.0),
            ],
            false,
        );
        mv.end = [
            Some(e[0]),
            Some(e[1]),
            Some(e[2]),
            Some(0.0),
            None,
            Some(0.0),
        ];
        mv
    }

    #[test]
    fn a_first_element_starts_in_its_own_direction() {
        // A line: its direction; a counter-clockwise circle about (20, 30)
        // from (20, 20): +X at its start (square to the radius, turning
        // left), a clockwise one -X.
        let d = start_direction(&line([20.0, 20.0, -1.0], [20.0, 35.0, -1.0]), 1.0).unwrap();
        assert_eq!(d, [0.0, 1.0]);
        let mut mv = line([20.0, 20.0, -1.0], [30.0, 30.0, -1.0]);
        let arc = super::super::Arc {
            plane: ArcPlane::Xy,
            cw: false,
            center: [20.0, 30.0],
            turns: 0,
            center_words: [None; 3],
            radius_word: None,
        };
        mv.kind = MoveKind::Arc(arc);
        let d = start_direction(&mv, 1.0).unwrap();
        assert!((d[0] - 1.0).abs() < 1e-15 && d[1].abs() < 1e-15, "{d:?}");
        mv.kind = MoveKind::Arc(super::super::Arc { cw: true, ..arc });
        let d = start_direction(&mv, 1.0).unwrap();
        assert!((d[0] + 1.0).abs() < 1e-15 && d[1].abs() < 1e-15, "{d:?}");
    }

    #[test]
    fn a_first_element_that_leaves_the_plane_gives_no_direction() {
        assert!(start_direction(&line([0.0, 0.0, 0.0], [10.0, 0.0, -1.0]), 1.0).is_err());
        assert!(start_direction(&line([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]), 1.0).is_err());
        // The micrometres a correction tilts a flat contour by keep it flat.
        assert!(start_direction(&line([0.0, 0.0, 0.0], [10.0, 0.0, 0.003]), 1.0).is_ok());
    }
}
