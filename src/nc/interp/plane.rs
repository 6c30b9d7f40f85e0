//! Tilted working planes (3+2 machining): the frame a plane definition
//! puts program coordinates in, and the rotary positions a controller picks
//! to put the tool along the plane's Z axis.
//!
//! A plane is a rotation and an origin in the workpiece coordinates of the
//! work offset in force: a point written in the plane lies at
//! `origin + rot * p` there. Each dialect's definitions build one:
//! FANUC and LinuxCNC `G68.2 X Y Z I J K` (rotating Z-X'-Z'' Euler angles;
//! LinuxCNC's tilted-work-plane remap also takes other orders by its Q
//! word and a turn R about the origin), HEIDENHAIN `PLANE SPATIAL` and
//! `CYCL DEF 19` (rotations about the fixed X, then Y, then Z axes),
//! `PLANE EULER` (Z-X'-Z''), `PLANE VECTOR` (the plane's X and Z axes),
//! `PLANE POINTS` (three points), `PLANE PROJECTED` (the plane's traces in
//! the ZX and YZ planes), `PLANE RELATIV` (one more rotation about an axis
//! of the plane in force) and `PLANE AXIAL` (the rotary positions
//! themselves: the frame the machine's axes take there), SINUMERIK
//! `CYCLE800` (axis-by-axis rotations about the turned axes in the order
//! its mode names, between a reference point and a zero point after the
//! swivel; new, or composed onto the plane in force).
//!
//! The rotary positions come from the nominal machine's inverse
//! kinematics, as the controller computes them: of the two tilt solutions
//! (a tilt and its opposite, C half a turn apart) the one the program's
//! choice names (HEIDENHAIN SEQ+/SEQ-, SINUMERIK's preferred direction),
//! else the one nearest the rotary positions before the plane (FANUC and
//! LinuxCNC G53.1, HEIDENHAIN without SEQ); when neither says, both lie
//! within the strokes and the positions before the plane are not known,
//! the choice is not known statically and the moves are left as written.

use nalgebra::{Matrix3, Vector3};

use crate::kinematics::fast::FastChain;
use crate::kinematics::{Axes, ToolPose};

/// A tilted working plane in the workpiece coordinates of the work offset
/// in force (program units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkPlane {
    /// The plane's X, Y and Z axes (columns) in workpiece coordinates.
    pub rot: Matrix3<f64>,
    /// The plane's origin in workpiece coordinates, program units.
    pub origin: Vector3<f64>,
}

impl WorkPlane {
    /// A plane through the workpiece origin.
    pub fn new(rot: Matrix3<f64>) -> WorkPlane {
        WorkPlane {
            rot,
            origin: Vector3::zeros(),
        }
    }

    /// Workpiece coordinates of a point written in the plane.
    pub(crate) fn to_workpiece(self, p: &Vector3<f64>) -> Vector3<f64> {
        self.origin + self.rot * p
    }

    /// Plane coordinates of a workpiece point.
    pub(crate) fn to_plane(self, q: &Vector3<f64>) -> Vector3<f64> {
        self.rot.transpose() * (q - self.origin)
    }

    /// The plane's Z axis (the tool axis in 3+2) in workpiece coordinates.
    pub fn normal(&self) -> Vector3<f64> {
        self.rot.column(2).into_owned()
    }
}

/// The tilted plane in force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tilt {
    /// A plane fivecal models.
    Plane(WorkPlane),
    /// A plane it does not model, defined at this line, and why.
    Unmodelled {
        /// 1-based line of the definition.
        line: usize,
        /// What is not modelled.
        why: &'static str,
    },
    /// Haas's dynamic work offset (`G254`, cancelled by `G255`): X, Y, Z
    /// are the workpiece's own coordinates (the work offset at rotary
    /// zero), which the control turns with the table to the rotary
    /// positions in force, for 3+1 and 3+2 positioning. Haas's mill
    /// operator's manual ("G254 - Dynamic Work Offset (DWO)") calls it
    /// TCPC for positioning only: the rotary axes stay where they were
    /// when it was invoked, the tool may point anywhere, and every rotary
    /// move needs `G255` first.
    Workpiece,
}

/// Why a move in a tilted plane is left as written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneSkip {
    /// The plane's definition (at this line) is not modelled, and why.
    Unmodelled(usize, &'static str),
    /// The rotary positions for the plane are not known here.
    RotaryUnknown,
    /// The rotary positions do not put the tool along the plane's Z axis.
    NotAlong,
    /// The block positions the rotary axes.
    RotaryMove,
    /// Tool length compensation is off (the point is not the tool tip).
    NoToolLength,
    /// Tool centre point control inside the plane.
    Tcp,
}

impl PlaneSkip {
    /// Which kind of reason this is (see [`super::ReasonKind`]).
    pub fn kind(&self) -> super::ReasonKind {
        use super::ReasonKind::{NotImplemented, OtherMachine, Unsaid};
        match self {
            PlaneSkip::Unmodelled(_, why) => super::kind_of(why),
            // STAY, a parameter, or two solutions the program does not
            // choose between.
            PlaneSkip::RotaryUnknown => Unsaid,
            // The program's rotary positions are not the plane's on this
            // machine's kinematics.
            PlaneSkip::NotAlong => OtherMachine,
            PlaneSkip::RotaryMove | PlaneSkip::Tcp => NotImplemented,
            // The tool length is the control's table value.
            PlaneSkip::NoToolLength => Unsaid,
        }
    }
}

impl std::fmt::Display for PlaneSkip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlaneSkip::Unmodelled(line, why) => write!(
                f,
                "a tilted working plane fivecal does not model is active (line {line}: {why})"
            ),
            PlaneSkip::RotaryUnknown => write!(
                f,
                "a tilted working plane is active and the rotary positions the controller chose for it are not known here (STAY or no G53.1 without a rotary move after it, a parameter, or two solutions and no way to tell which)"
            ),
            PlaneSkip::NotAlong => write!(
                f,
                "a tilted working plane is active and the rotary positions do not put the tool along its Z axis"
            ),
            PlaneSkip::RotaryMove => write!(
                f,
                "positions the rotary axes in a tilted working plane (kept as written: 3+2 corrects the coordinates in the plane, not the plane's rotary positions)"
            ),
            PlaneSkip::NoToolLength => write!(
                f,
                "a tilted working plane is active without tool length compensation (the point is not the tool tip)"
            ),
            PlaneSkip::Tcp => write!(
                f,
                "tool centre point control inside a tilted working plane is not modelled"
            ),
        }
    }
}

/// Rotation by `deg` degrees about the axis `axis` (b'X', b'Y' or b'Z').
pub fn about(axis: u8, deg: f64) -> Matrix3<f64> {
    let (s, c) = deg.to_radians().sin_cos();
    match axis {
        b'X' => Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        b'Y' => Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        _ => Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    }
}

/// Three rotations about the turned axes in `order` (intrinsic, e.g.
/// `b"ZXZ"`): `R = R1(a) R2(b) R3(c)`.
pub(crate) fn intrinsic(order: &[u8; 3], angles: [f64; 3]) -> Matrix3<f64> {
    about(order[0], angles[0]) * about(order[1], angles[1]) * about(order[2], angles[2])
}

/// HEIDENHAIN spatial angles: about the fixed X, then Y, then Z axes,
/// `R = Rz(c) Ry(b) Rx(a)`.
pub fn spatial(spa: f64, spb: f64, spc: f64) -> Matrix3<f64> {
    about(b'Z', spc) * about(b'Y', spb) * about(b'X', spa)
}

/// The plane whose X axis points along `x` and whose Z axis along `z`
/// (PLANE VECTOR, LinuxCNC G68.2 P3): both are normalized; they must be
/// perpendicular within 1e-4 (the controllers refuse them otherwise).
pub(crate) fn from_axes(x: &Vector3<f64>, z: &Vector3<f64>) -> Result<Matrix3<f64>, &'static str> {
    let (nx, nz) = (x.norm(), z.norm());
    if !(nx > 1e-9 && nz > 1e-9 && nx.is_finite() && nz.is_finite()) {
        return Err("a zero or unreadable vector");
    }
    let (x, z) = (x / nx, z / nz);
    if x.dot(&z).abs() > 1e-4 {
        return Err("the base and normal vectors are not perpendicular");
    }
    // The small remaining non-orthogonality goes into X (the normal is the
    // tool axis and is kept exactly).
    let x = (x - z * x.dot(&z)).normalize();
    let y = z.cross(&x);
    Ok(Matrix3::from_columns(&[x, y, z]))
}

/// The plane through three points: X from the first towards the second,
/// the third on the positive Y side (PLANE POINTS, LinuxCNC G68.2 P2).
pub fn from_points(p: [Vector3<f64>; 3]) -> Result<Matrix3<f64>, &'static str> {
    let x = p[1] - p[0];
    let v = p[2] - p[0];
    let z = x.cross(&v);
    if z.norm() < 1e-9 * (x.norm() * v.norm()).max(1e-12) || z.norm() == 0.0 {
        return Err("the three points lie on a line");
    }
    from_axes(&x, &z.normalize())
}

/// HEIDENHAIN `PLANE PROJECTED PROPR PROMIN ROT`: the plane whose trace in
/// the ZX plane makes `propr` with X and whose trace in the YZ plane makes
/// `promin` with Y (the edges of a slanted face of a block seen from the
/// front and from the left), its X axis along the ZX trace, then turned
/// `rot` about its own Z. Read in HEIDENHAIN's TNC7 user's manual: the
/// angles are those of the workpiece edges seen through the ZX and YZ
/// planes, all three are required, ROT turns the plane's X. Derived, not
/// read (the manual gives them in a figure): the sign of each angle, taken
/// in the mathematically positive sense of the plane as named (Z towards
/// X in ZX, Y towards Z in YZ), which makes a single projection angle the
/// spatial angle about the same axis (`PROPR` as `SPB`, `PROMIN` as
/// `SPA`), and the plane's X at ROT 0 along the ZX trace, as SINUMERIK's
/// projection angles put it. The traces fix the normal as (tan PROPR,
/// -tan PROMIN, 1), which is why both angles must stay within +-90 deg.
/// In closed form `R = Ry(PROPR) Rx(atan(tan PROMIN cos PROPR)) Rz(ROT)`.
pub(crate) fn projected(propr: f64, promin: f64, rot: f64) -> Result<Matrix3<f64>, &'static str> {
    if !(propr.abs() < 90.0 && promin.abs() < 90.0) {
        return Err("a PLANE PROJECTED angle outside +-90 deg");
    }
    let a = propr.to_radians();
    let nutation = (promin.to_radians().tan() * a.cos()).atan().to_degrees();
    Ok(about(b'Y', propr) * about(b'X', nutation) * about(b'Z', rot))
}

/// SINUMERIK `ROTS`/`AROTS` with three solid angles (the control refuses
/// them: two fix the plane).
pub(crate) const SOLID_THREE: &str =
    "a programmable frame rotation by three solid angles (ROTS/AROTS take at most two)";
/// Two solid angles, one of them not within +-90 deg.
pub(crate) const SOLID_STEEP: &str =
    "a programmable frame rotation by two solid angles, one of them not within +-90 deg";

/// SINUMERIK `ROTS`/`AROTS` (`X Y Z` angles, `None` where not written): the
/// rotation of the workpiece coordinate system by solid angles.
///
/// Read in Siemens' function manual K2 (Axes, coordinate systems, frames,
/// section 2.4 Frames, "solid angles": 08/2005 edition p. 2-101, 840D sl
/// edition p. 775): one solid angle turns as `ROT`/`AROT` about that axis
/// (also in the SINUMERIK ONE programming manual 12/2019, 2.12,
/// p. 324); two name a plane, their axes first and second as G17 (X, Y),
/// G18 (Z, X) and G19 (Y, Z) order them (ONE manual p. 324); the angle
/// written with each axis letter is the turn about that axis which brings
/// the plane's other axis onto the line where the turned plane cuts the
/// plane of that other axis and the third one (with X and Y: Y's angle
/// turns X about Y onto the plane's trace in ZX, X's angle turns Y about X
/// onto its trace in YZ); the turned first axis lies in the plane of the
/// first and third axes (the new X in the old ZX plane). Derived: the sense
/// of each turn is the right-hand rule of every frame rotation (K2 2.4.2.3,
/// read), which one angle alone being `ROT` also fixes; with two, the
/// traces must stay off the third axis, so both within +-90 deg. The ONE
/// manual's summary on p. 324 states the second turn as one about the
/// turned first axis; K2's prose (the traces) is what is modelled, and
/// with one angle zero both give the same rotation. With X and Y this is
/// the plane HEIDENHAIN's `PLANE PROJECTED` builds from its traces
/// (`projected(Y, X, 0)`); the G18 and G19 pairs are the same construction
/// with the axes named cyclically.
pub(crate) fn solid_angles(vals: [Option<f64>; 3]) -> Result<Matrix3<f64>, &'static str> {
    let given: Vec<usize> = (0..3).filter(|&i| vals[i].is_some()).collect();
    let v = |i: usize| vals[i].unwrap_or(0.0);
    match given.as_slice() {
        [] => Ok(Matrix3::identity()),
        [i] => Ok(about(b"XYZ"[*i], v(*i))),
        [a, b] => {
            // (first, second, third) of the plane the two axes name.
            let (f, s, t) = match (a, b) {
                (0, 1) => (0, 1, 2),
                (0, 2) => (2, 0, 1),
                _ => (1, 2, 0),
            };
            let r = projected(v(s), v(f), 0.0).map_err(|_| SOLID_STEEP)?;
            // The cyclic renaming X Y Z -> first, second, third keeps the
            // right hand.
            let p = Matrix3::from_columns(&[
                Vector3::ith(f, 1.0),
                Vector3::ith(s, 1.0),
                Vector3::ith(t, 1.0),
            ]);
            Ok(p * r * p.transpose())
        }
        _ => Err(SOLID_THREE),
    }
}

/// The frame the machine's rotary axes at `abc` (A, B, C, `None` where
/// not given) put the program in: the plane of HEIDENHAIN `PLANE AXIAL`
/// and of SINUMERIK's direct `CYCLE800`, the same frame `fivecal plan`
/// writes its tilted planes in. Both of the machine's rotary axes must be
/// given, and no other.
pub(crate) fn axial(
    kin: &crate::kinematics::Kinematics,
    tilt: usize,
    abc: [Option<f64>; 3],
) -> Result<Matrix3<f64>, &'static str> {
    if abc
        .iter()
        .enumerate()
        .any(|(i, v)| v.is_some_and(|v| v != 0.0) && i + 3 != tilt && i != 2)
    {
        return Err("rotary positions of an axis this machine does not have");
    }
    match (abc[tilt - 3], abc[2]) {
        (Some(t), Some(c)) => Ok(crate::kinematics::pose_frame::pose_frame(kin, t, c)),
        _ => Err("rotary positions without both of the machine's rotary axes"),
    }
}

/// LinuxCNC's `G68.2 P2` (three points) and `G68.2 P3` (two vectors),
/// given over several blocks as its tilted-work-plane remap reads them
/// (the remap of LinuxCNC's five-axis simulation configurations,
/// `configs/sim/axis/vismach/5axis/table-rotary_spindle-rotary-nutating/python/remap.py`):
/// P2 takes `Q0 X Y Z R` (the origin and a turn about Z) and the points
/// `Q1`, `Q2`, `Q3` (`X Y Z` each); P3 takes `Q0 X Y Z I J K R` (the
/// origin, a point `I J K` whose direction from the origin is the plane's
/// X, and the turn) and `Q1 I J K` (the normal). A missing Q is Q0 and a
/// missing word 0; the plane is defined once every part is given, in any
/// order, and a part given again replaces the earlier one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pending {
    /// 2 or 3.
    pub p: u8,
    /// The X Y Z I J K R of each Q block so far.
    pub parts: [Option<[f64; 7]>; 4],
    /// A part held a parameter or an expression.
    pub unknown: bool,
}

impl Pending {
    /// Nothing given yet for `P p`.
    pub fn new(p: u8) -> Pending {
        Pending {
            p,
            parts: [None; 4],
            unknown: false,
        }
    }

    /// How many Q blocks the form takes.
    pub fn needed(&self) -> usize {
        if self.p == 2 { 4 } else { 2 }
    }

    /// The plane, once every part is given.
    pub fn plane(&self) -> Option<Result<WorkPlane, &'static str>> {
        let n = self.needed();
        if self.parts[..n].iter().any(Option::is_none) {
            return None;
        }
        if self.unknown {
            return Some(Err("a parameter or an expression in G68.2"));
        }
        let part = |q: usize| self.parts[q].unwrap_or([0.0; 7]);
        let v = |q: usize, k: usize| Vector3::new(part(q)[k], part(q)[k + 1], part(q)[k + 2]);
        let (origin, r) = (v(0, 0), part(0)[6]);
        let rot = if self.p == 2 {
            let (x, y) = (v(2, 0) - v(1, 0), v(3, 0) - v(1, 0));
            // The remap normalizes both directions and takes their cross
            // product as the normal without normalizing it again: a frame
            // only when the points make a right angle at the first.
            let cos = x.dot(&y) / (x.norm() * y.norm());
            if cos.abs() > 1e-9 {
                return Some(Err(
                    "G68.2 P2 with points not at a right angle at the first (LinuxCNC's remap then builds no rotation)",
                ));
            }
            from_points([v(1, 0), v(2, 0), v(3, 0)])
        } else {
            let (x, z) = (v(0, 3) - origin, v(1, 3));
            // The remap refuses vectors whose normalized dot product is
            // not exactly 0.
            if (x.normalize().dot(&z.normalize())).abs() > 1e-12 {
                return Some(Err("G68.2 P3 with vectors that are not orthogonal"));
            }
            from_axes(&x, &z)
        };
        Some(rot.map(|rot| WorkPlane {
            rot: about(b'Z', r) * rot,
            origin,
        }))
    }
}

/// How a controller picks between the two rotary solutions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Choice {
    /// The one nearest the rotary positions before the plane.
    Nearest,
    /// The one whose tilt has this sign (+1 or -1); `strict`: the other
    /// one is an error (HEIDENHAIN SEQ), otherwise taken when this one is
    /// out of the stroke (SINUMERIK's preferred direction).
    Sign {
        /// +1 or -1.
        sign: f64,
        /// Whether the other solution is refused.
        strict: bool,
    },
}

/// The rotary positions (tilt, C) that put the tool along `normal` (in W),
/// chosen as `choice` says from the positions before the plane `before`
/// (`None`: not known).
pub(crate) fn rotary_for(
    nominal: &FastChain,
    normal: &Vector3<f64>,
    before: (Option<f64>, Option<f64>),
    choice: Choice,
) -> Result<(f64, f64), &'static str> {
    let pose = ToolPose {
        tip: Vector3::zeros(),
        axis: *normal,
    };
    let c_ref = before.1.unwrap_or(0.0);
    // Each root of the orientation, if the machine reaches it within its
    // strokes (C on its turn nearest the reference).
    let roots = nominal
        .orientation_roots(normal, c_ref)
        .ok_or("no rotary positions of the machine put the tool along it")?;
    let reach = |(t, c): (f64, f64)| {
        let c = c_ref + crate::geom::wrap180(c - c_ref);
        nominal
            .inverse(&pose, &Axes::new(0.0, 0.0, 0.0, t, c))
            .ok()
            .filter(|a| (a.tilt - t).abs() < 1e-9)
            .map(|a| (a.tilt, a.c))
    };
    let (a, b) = (reach(roots[0]), reach(roots[1]));
    let (hi, lo) = match (a, b) {
        (Some(x), Some(y)) if y.0 > x.0 => (Some(y), Some(x)),
        (Some(x), Some(y)) => (Some(x), Some(y)),
        (x, y) => (x.or(y), x.or(y)),
    };
    let unique = match (hi, lo) {
        (None, None) => return Err("no rotary positions of the machine put the tool along it"),
        (Some(a), None) | (None, Some(a)) => Some(a),
        (Some(a), Some(b)) if (a.0 - b.0).abs() < 1e-9 => Some(a),
        _ => None,
    };
    match choice {
        Choice::Nearest => match (unique, hi, lo, before.0) {
            (Some(a), ..) => Ok(a),
            (None, Some(h), Some(l), Some(t)) => {
                // The way of each: the tilt's, and C's where C is known.
                let way =
                    |a: (f64, f64)| (a.0 - t).abs() + before.1.map_or(0.0, |c| (a.1 - c).abs());
                let (dh, dl) = (way(h), way(l));
                if (dh - dl).abs() < 1e-9 {
                    Err("two rotary solutions are equally near the positions before the plane")
                } else if dh < dl {
                    Ok(h)
                } else {
                    Ok(l)
                }
            }
            _ => Err(
                "two rotary solutions lie within the strokes and the positions before the plane are not known",
            ),
        },
        Choice::Sign { sign, strict } => {
            let want = if sign > 0.0 { hi } else { lo };
            match want {
                Some(a) if a.0 * sign >= -1e-9 => Ok(a),
                _ if strict => Err("no solution with the tilt of the requested sign (SEQ)"),
                _ => unique.or(hi).or(lo).ok_or("no rotary positions"),
            }
        }
    }
}

/// A HEIDENHAIN `PLANE` block read: the plane (or why not), and how the
/// rotary axes are positioned.
#[derive(Clone, Debug, PartialEq)]
pub struct Klartext {
    /// `None` for `PLANE RESET`.
    pub plane: Option<Result<Definition, &'static str>>,
    /// TURN or MOVE: the control turns the rotary axes.
    pub turn: bool,
    /// SEQ+ / SEQ-.
    pub seq: Option<f64>,
    /// SYM+ / SYM- (a choice fivecal does not model).
    pub sym: bool,
}

/// A plane definition: absolute, or one more rotation of the plane in
/// force (PLANE RELATIV).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Definition {
    /// The plane's rotation in workpiece coordinates.
    Absolute(Matrix3<f64>),
    /// A rotation about the plane's own axes, applied after the plane in
    /// force.
    Relative(Matrix3<f64>),
    /// PLANE AXIAL: the rotary positions A, B, C (`None` where not given);
    /// the frame is the machine's (`axial`).
    Axial([Option<f64>; 3]),
}

/// Reads a Klartext `PLANE ...` block (its text without the comment):
/// SPATIAL (SPA SPB SPC), PROJECTED (PROPR PROMIN ROT, or PROROT as older
/// manuals write it), EULER (EULPR EULNU EULROT), VECTOR (BX BY BZ NX NY
/// NZ), POINTS (P1X ... P3Z), RELATIV (one of SPA SPB SPC), AXIAL (A B C),
/// RESET; the positioning TURN / MOVE / STAY and SEQ+ / SEQ-.
pub fn klartext(code: &str) -> Klartext {
    let up = code.to_ascii_uppercase().replace(',', ".");
    let words: Vec<&str> = up.split_whitespace().collect();
    let at = words.iter().position(|w| *w == "PLANE").unwrap_or(0);
    let form = words.get(at + 1).copied().unwrap_or("");
    let rest = &words[(at + 2).min(words.len())..];
    let mut values: Vec<(&str, Option<f64>)> = Vec::new();
    let mut out = Klartext {
        plane: None,
        turn: false,
        seq: None,
        sym: false,
    };
    const NAMES: [&str; 25] = [
        "EULPR", "EULNU", "EULROT", "PROPR", "PROMIN", "PROROT", "SPA", "SPB", "SPC", "ROT", "BX",
        "BY", "BZ", "NX", "NY", "NZ", "P1X", "P1Y", "P1Z", "P2X", "P2Y", "P2Z", "P3X", "P3Y",
        "P3Z",
    ];
    let mut k = 0;
    while k < rest.len() {
        let w = rest[k];
        k += 1;
        match w {
            "TURN" | "MOVE" => out.turn = true,
            "SEQ+" => out.seq = Some(1.0),
            "SEQ-" => out.seq = Some(-1.0),
            _ if w.starts_with("SYM") => out.sym = true,
            _ => {
                // An axis word of PLANE AXIAL: `B+30`, `B +30`, `B+Q1`.
                let axial = form == "AXIAL"
                    && matches!(w.as_bytes()[0], b'A' | b'B' | b'C')
                    && w.as_bytes()
                        .get(1)
                        .is_none_or(|c| c.is_ascii_digit() || b"+-.Q".contains(c));
                let name = NAMES
                    .iter()
                    .find(|n| w.starts_with(**n))
                    .copied()
                    .or(axial.then(|| &w[..1]));
                let Some(name) = name else { continue };
                let mut text = w[name.len()..].to_string();
                // `SPB +30` and `SPB + 30`.
                while (text.is_empty() || text == "+" || text == "-")
                    && k < rest.len()
                    && rest[k]
                        .bytes()
                        .next()
                        .is_some_and(|c| c.is_ascii_digit() || b"+-.Q".contains(&c))
                {
                    text.push_str(rest[k]);
                    k += 1;
                }
                if name == "ROT" && text.is_empty() {
                    continue;
                }
                values.push((name, text.parse::<f64>().ok().filter(|v| v.is_finite())));
            }
        }
    }
    if form == "RESET" {
        return out;
    }
    let get = |n: &str| values.iter().find(|(k, _)| *k == n).map(|(_, v)| *v);
    if values.iter().any(|(_, v)| v.is_none()) {
        out.plane = Some(Err("a parameter or an unreadable value in the plane"));
        return out;
    }
    let num = |n: &str| get(n).flatten().unwrap_or(0.0);
    let v3 = |a: &str, b: &str, c: &str| Vector3::new(num(a), num(b), num(c));
    out.plane = Some(match form {
        "SPATIAL" => Ok(Definition::Absolute(spatial(
            num("SPA"),
            num("SPB"),
            num("SPC"),
        ))),
        "EULER" => Ok(Definition::Absolute(intrinsic(
            b"ZXZ",
            [num("EULPR"), num("EULNU"), num("EULROT")],
        ))),
        "VECTOR" => {
            from_axes(&v3("BX", "BY", "BZ"), &v3("NX", "NY", "NZ")).map(Definition::Absolute)
        }
        "POINTS" => from_points([
            v3("P1X", "P1Y", "P1Z"),
            v3("P2X", "P2Y", "P2Z"),
            v3("P3X", "P3Y", "P3Z"),
        ])
        .map(Definition::Absolute),
        "RELATIV" => {
            let given: Vec<(u8, f64)> = [("SPA", b'X'), ("SPB", b'Y'), ("SPC", b'Z')]
                .iter()
                .filter_map(|(n, a)| get(n).flatten().map(|v| (*a, v)))
                .collect();
            match given.as_slice() {
                [(axis, v)] => Ok(Definition::Relative(about(*axis, *v))),
                _ => Err("PLANE RELATIV with other than one spatial angle"),
            }
        }
        "PROJECTED" => projected(
            num("PROPR"),
            num("PROMIN"),
            get("ROT").or(get("PROROT")).flatten().unwrap_or(0.0),
        )
        .map(Definition::Absolute),
        "AXIAL" => Ok(Definition::Axial([
            get("A").flatten(),
            get("B").flatten(),
            get("C").flatten(),
        ])),
        _ => Err("an unknown PLANE form"),
    });
    out
}

/// What a SINUMERIK `CYCLE800(...)` call does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Swivel {
    /// `CYCLE800()`: no swivel.
    Reset,
    /// A plane by rotations (axis by axis), or by the rotary positions
    /// (direct mode, `_A _B _C` named by the axis letter): `rot` is `None`
    /// in direct mode.
    Plane {
        /// Rotation (axis-by-axis mode).
        rot: Option<Matrix3<f64>>,
        /// Direct mode: `_A`, `_B`, `_C`.
        abc: [f64; 3],
        /// Reference point of the rotation `_X0 _Y0 _Z0`.
        before: Vector3<f64>,
        /// Zero point after it `_X1 _Y1 _Z1` (in the swivelled axes).
        after: Vector3<f64>,
        /// Preferred direction `_DIR` (0: the rotary axes do not move).
        dir: f64,
        /// Additive (units digit of `_ST` 1): composed onto the plane in
        /// force, its reference point, rotation and zero point in that
        /// plane's axes. Siemens' operating manual says the additive
        /// plane builds on the last one; chaining it as a further frame
        /// is fivecal's reading of that.
        additive: bool,
    },
}

/// Reads the argument list of `CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0,
/// _Z0, _A, _B, _C, _X1, _Y1, _Z1, _DIR [, _FR_I, _DMODE])`: a new plane
/// (units digit of `_ST` 0) or one added to the plane in force (1), axis
/// by axis (`_MODE` bits 6-7 zero, the axis of each angle in bits 0-1,
/// 2-3, 4-5: 1 X, 2 Y, 3 Z; each rotation about the axes the previous
/// ones turned) or direct (192, new planes only). Solid and projection
/// angles (bits 6-7 01 and 10) stay refused: which value is which, and
/// the sign of each angle, are shown only in the manual's figures.
pub fn cycle800(args: &str) -> Result<Swivel, &'static str> {
    let inner = args.trim().trim_start_matches('(').trim_end_matches(')');
    if inner.trim().is_empty() {
        return Ok(Swivel::Reset);
    }
    let mut fields: Vec<String> = vec![String::new()];
    let mut quoted = false;
    for ch in inner.chars() {
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => fields.push(String::new()),
            _ if !quoted => fields.last_mut().unwrap().push(ch),
            _ => {}
        }
    }
    let num = |k: usize| -> Result<f64, &'static str> {
        match fields.get(k).map(|f| f.trim()) {
            None | Some("") => Ok(0.0),
            Some(f) => f
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or("a parameter or an expression in CYCLE800"),
        }
    };
    if fields.len() < 14 {
        return Err("CYCLE800 with fewer than 14 parameters");
    }
    let st = num(2)?;
    let units = st.rem_euclid(10.0);
    if units != 0.0 && units != 1.0 {
        return Err("a CYCLE800 _ST whose units digit is neither 0 (new) nor 1 (additive)");
    }
    let additive = units == 1.0;
    let mode = num(3)? as i64;
    let v3 = |k: usize| -> Result<Vector3<f64>, &'static str> {
        Ok(Vector3::new(num(k)?, num(k + 1)?, num(k + 2)?))
    };
    let abc = [num(7)?, num(8)?, num(9)?];
    let rot = match mode >> 6 {
        0 => {
            let axis = |k: i64| match (mode >> (2 * k)) & 3 {
                1 => Ok(b'X'),
                2 => Ok(b'Y'),
                3 => Ok(b'Z'),
                _ => Err("a CYCLE800 _MODE without the axis of an angle"),
            };
            Some(intrinsic(&[axis(0)?, axis(1)?, axis(2)?], abc))
        }
        3 if additive => return Err("an additive CYCLE800 in direct mode (_MODE 192)"),
        3 => None,
        _ => return Err("CYCLE800 with solid or projection angles (_MODE bits 6-7 01 or 10)"),
    };
    Ok(Swivel::Plane {
        rot,
        abc,
        before: v3(4)?,
        after: v3(10)?,
        dir: num(13)?,
        additive,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Matrix3<f64>, b: &Matrix3<f64>) -> bool {
        (a - b).abs().max() < 1e-12
    }

    #[test]
    fn euler_zxz_by_hand() {
        // I90 J45 K0: turn 90 deg about Z (X to Y), then 45 deg about the
        // new X (which is the old Y): the plane's X is the workpiece Y, its
        // Z is tilted from Z towards -X.
        let r = intrinsic(b"ZXZ", [90.0, 45.0, 0.0]);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let by_hand = Matrix3::new(0.0, -h, h, 1.0, 0.0, 0.0, 0.0, h, h);
        assert!(close(&r, &by_hand), "{r}");
        // Round trip through the post's angles of a rotation.
        let back = crate::post::euler_zxz(&intrinsic(b"ZXZ", [30.0, 40.0, -20.0]));
        assert!((back[0] - 30.0).abs() < 1e-9 && (back[1] - 40.0).abs() < 1e-9);
        assert!((back[2] + 20.0).abs() < 1e-9);
    }

    #[test]
    fn spatial_euler_vector_and_points_agree() {
        // The same plane four ways: SPA 0 SPB 30 SPC 90 turns the tool
        // axis 30 deg about Y, then the whole plane 90 deg about Z.
        let s = spatial(0.0, 30.0, 90.0);
        let back = crate::post::euler_spatial(&s);
        assert!((back[1] - 30.0).abs() < 1e-9 && (back[2] - 90.0).abs() < 1e-9);
        let [pr, nu, rot] = crate::post::euler_zxz(&s);
        assert!(close(&intrinsic(b"ZXZ", [pr, nu, rot]), &s));
        let v = from_axes(&s.column(0).into_owned(), &s.column(2).into_owned()).unwrap();
        assert!(close(&v, &s));
        let o = Vector3::new(5.0, -3.0, 2.0);
        let pts = [
            o,
            o + 10.0 * s.column(0),
            o + 4.0 * s.column(1) - s.column(0),
        ];
        assert!((from_points(pts).unwrap() - s).abs().max() < 1e-12);
        // The tool axis by hand: Z turned 30 deg about Y gives (sin 30, 0,
        // cos 30); then 90 deg about Z moves it to (0, sin 30, cos 30).
        let n = s.column(2);
        assert!((n - Vector3::new(0.0, 0.5, 0.75f64.sqrt())).norm() < 1e-12);
        assert!(from_axes(&Vector3::x(), &Vector3::new(1.0, 0.0, 1.0)).is_err());
        assert!(from_points([o, o, o]).is_err());
    }

    #[test]
    fn rotary_choice_follows_the_rule() {
        let m = crate::machine::Machine::builtin("ac-trunnion").unwrap();
        let k = crate::kinematics::Kinematics::new(&m);
        let nominal = FastChain::nominal(&k);
        let n = spatial(30.0, 0.0, 0.0).column(2).into_owned();
        let check = |(t, c): (f64, f64)| {
            let a = nominal.forward(&Axes::new(0.0, 0.0, 0.0, t, c)).axis;
            assert!((a - n).norm() < 1e-9, "{t} {c}");
            t
        };
        let plus = rotary_for(
            &nominal,
            &n,
            (None, None),
            Choice::Sign {
                sign: 1.0,
                strict: true,
            },
        );
        let minus = rotary_for(
            &nominal,
            &n,
            (None, None),
            Choice::Sign {
                sign: -1.0,
                strict: true,
            },
        );
        match (plus, minus) {
            (Ok(p), Ok(q)) => {
                assert!(check(p) > 0.0 && check(q) < 0.0);
                // Without a sign: the one nearest the positions before, and
                // no choice when they are not known.
                let near = rotary_for(&nominal, &n, (Some(-5.0), Some(170.0)), Choice::Nearest);
                assert!(check(near.unwrap()) < 0.0);
                // Equally near (A0 C90 between A+30 C0 and A-30 C180): no
                // way to tell.
                assert!(
                    rotary_for(&nominal, &n, (Some(0.0), Some(90.0)), Choice::Nearest).is_err()
                );
                assert!(rotary_for(&nominal, &n, (None, None), Choice::Nearest).is_err());
            }
            (Ok(p), Err(_)) | (Err(_), Ok(p)) => {
                let t = check(p);
                let any = rotary_for(&nominal, &n, (None, None), Choice::Nearest).unwrap();
                assert_eq!(check(any), t);
            }
            _ => panic!("no solution"),
        }
    }

    #[test]
    fn klartext_planes_read_as_written() {
        let k = klartext("5 PLANE SPATIAL SPA+0 SPB+30 SPC+90 TURN MB MAX FMAX SEQ-");
        assert_eq!(
            k.plane,
            Some(Ok(Definition::Absolute(spatial(0.0, 30.0, 90.0))))
        );
        assert!(k.turn && k.seq == Some(-1.0) && !k.sym);
        let [pr, nu, rot] = crate::post::euler_zxz(&spatial(0.0, 30.0, 90.0));
        let e = klartext(&format!(
            "7 PLANE EULER EULPR{pr:+.9} EULNU {nu:+.9} EULROT{rot:+.9} STAY"
        ));
        let Some(Ok(Definition::Absolute(r))) = e.plane else {
            panic!("{e:?}")
        };
        assert!((r - spatial(0.0, 30.0, 90.0)).abs().max() < 1e-9 && !e.turn);
        let rel = klartext("9 PLANE RELATIV SPB-15 TURN FMAX");
        assert_eq!(
            rel.plane,
            Some(Ok(Definition::Relative(about(b'Y', -15.0))))
        );
        assert_eq!(klartext("3 PLANE RESET STAY").plane, None);
        assert!(matches!(
            klartext("3 PLANE SPATIAL SPA+0 SPB+Q1 SPC+0 STAY").plane,
            Some(Err(_))
        ));
        assert_eq!(
            klartext("3 PLANE AXIAL B+30 TURN FMAX").plane,
            Some(Ok(Definition::Axial([None, Some(30.0), None])))
        );
        assert!(klartext("3 PLANE SPATIAL SPA+0 SPB+30 SPC+0 TURN SYM+ FMAX").sym);
        // CYCLE800 mode 57: X, then the turned Y, then the turned Z.
        let Ok(Swivel::Plane {
            rot: Some(r),
            after,
            dir,
            ..
        }) = cycle800("(1,\"TC1\",200000,57,0,0,0,10,30,90,0,5,0,-1,100,1)")
        else {
            panic!()
        };
        assert!(close(
            &r,
            &(about(b'X', 10.0) * about(b'Y', 30.0) * about(b'Z', 90.0))
        ));
        assert!(after == Vector3::new(0.0, 5.0, 0.0) && dir == -1.0);
        // 27: Z, Y, X.
        let Ok(Swivel::Plane { rot: Some(r), .. }) =
            cycle800("(1,\"T\",0,27,0,0,0,10,30,90,0,0,0,1)")
        else {
            panic!()
        };
        assert!(close(&r, &intrinsic(b"ZYX", [10.0, 30.0, 90.0])));
        assert_eq!(cycle800("()"), Ok(Swivel::Reset));
        assert!(cycle800("(1,\"T\",0,57,0,0,0,0,R1,0,0,0,0,1)").is_err());
        let Ok(Swivel::Plane { additive, .. }) = cycle800("(1,\"T\",1,57,0,0,0,0,10,0,0,0,0,1)")
        else {
            panic!()
        };
        assert!(additive);
        assert!(cycle800("(1,\"T\",1,192,0,0,0,0,10,0,0,0,0,1)").is_err());
        assert!(cycle800("(1,\"T\",2,57,0,0,0,0,10,0,0,0,0,1)").is_err());
        assert!(cycle800("(1,\"T\",0,121,0,0,0,0,30,0,0,0,0,1)").is_err());
        let t = klartext("3 PLANE SPATIAL SPA+0 SPB+30 SPC+0 STAY SEQ- COORD ROT");
        assert_eq!(
            t.plane,
            Some(Ok(Definition::Absolute(spatial(0.0, 30.0, 0.0))))
        );
    }

    #[test]
    fn projected_angles_are_the_traces_of_the_plane() {
        for (pr, min, rot) in [(24.0, 24.0, 30.0), (-35.0, 12.0, 0.0), (10.0, -60.0, -75.0)] {
            let r = projected(pr, min, rot).unwrap();
            let (a, b) = (f64::to_radians(pr), f64::to_radians(min));
            // Independently: the plane through the two traces, the ZX one
            // (PROPR from X, down towards -Z for a positive angle, as SPB
            // turns X) and the YZ one (PROMIN from Y, up towards +Z, as
            // SPA turns Y); X along the ZX trace, then ROT about Z.
            let l1 = Vector3::new(a.cos(), 0.0, -a.sin());
            let l2 = Vector3::new(0.0, b.cos(), b.sin());
            let n = l1.cross(&l2).normalize();
            let (s, c) = rot.to_radians().sin_cos();
            let x = c * l1 + s * n.cross(&l1);
            assert!((r.column(2) - n).norm() < 1e-12, "{pr} {min}: {r}");
            assert!((r.column(0) - x).norm() < 1e-12, "{pr} {min} {rot}: {r}");
            assert!((r.determinant() - 1.0).abs() < 1e-12);
            // The plane's traces measured back: its X at ROT 0 seen in the
            // ZX plane, and the line where it cuts the YZ plane.
            let r0 = projected(pr, min, 0.0).unwrap();
            let x0 = r0.column(0);
            assert!(x0[1].abs() < 1e-12);
            assert!((f64::atan2(-x0[2], x0[0]).to_degrees() - pr).abs() < 1e-9);
            let nn = r0.column(2);
            let trace = Vector3::new(0.0, nn[2], -nn[1]);
            assert!((f64::atan2(trace[2], trace[1]).to_degrees() - min).abs() < 1e-9);
        }
        // One projection angle alone is the spatial angle about that axis.
        assert!(close(
            &projected(30.0, 0.0, 0.0).unwrap(),
            &spatial(0.0, 30.0, 0.0)
        ));
        assert!(close(
            &projected(0.0, -20.0, 0.0).unwrap(),
            &spatial(-20.0, 0.0, 0.0)
        ));
        assert!(projected(90.0, 0.0, 0.0).is_err() && projected(0.0, -95.0, 0.0).is_err());
        let k = klartext("5 PLANE PROJECTED PROPR+24 PROMIN+24 ROT+30 TURN MB MAX FMAX SEQ-");
        assert_eq!(
            k.plane,
            Some(Ok(Definition::Absolute(
                projected(24.0, 24.0, 30.0).unwrap()
            )))
        );
        assert!(k.turn && k.seq == Some(-1.0));
        let older = klartext("5 PLANE PROJECTED PROPR+24 PROMIN+24 PROROT+30 STAY");
        assert_eq!(older.plane, k.plane);
    }

    #[test]
    fn solid_angles_are_the_traces_of_the_turned_plane() {
        let e = |i: usize| Vector3::ith(i, 1.0);
        // (written axes, their angles): the pairs of G17, G18 and G19.
        for (first, second, third) in [(0, 1, 2), (2, 0, 1), (1, 2, 0)] {
            for (af, as_) in [(20.0, 35.0), (-40.0, 10.0), (15.0, -70.0)] {
                let mut vals = [None; 3];
                vals[first] = Some(af);
                vals[second] = Some(as_);
                let r = solid_angles(vals).unwrap();
                assert!((r.determinant() - 1.0).abs() < 1e-12);
                assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
                // Measured back, independently of the construction: the
                // turned first axis lies in the plane of the first and
                // third axes, turned about the second by the second's
                // angle (right hand: from the first towards -third).
                let f = r.column(first);
                assert!(f.dot(&e(second)).abs() < 1e-12, "{r}");
                let got = f64::atan2(-f.dot(&e(third)), f.dot(&e(first)));
                assert!((got.to_degrees() - as_).abs() < 1e-9, "{first}: {r}");
                // The turned plane cuts the plane of the second and third
                // axes along the second turned about the first by the
                // first's angle (from the second towards +third).
                let n = r.column(third);
                let trace = n.cross(&e(first));
                let got = f64::atan2(trace.dot(&e(third)), trace.dot(&e(second)));
                assert!((got.to_degrees() - af).abs() < 1e-9, "{first}: {r}");
            }
        }
        // One solid angle is ROT about that axis, none turns nothing.
        for i in 0..3 {
            let mut vals = [None; 3];
            vals[i] = Some(-25.0);
            assert!(close(
                &solid_angles(vals).unwrap(),
                &about(b"XYZ"[i], -25.0)
            ));
        }
        assert_eq!(solid_angles([None; 3]), Ok(Matrix3::identity()));
        // With X and Y it is the plane PLANE PROJECTED builds.
        assert!(close(
            &solid_angles([Some(12.0), Some(-30.0), None]).unwrap(),
            &projected(-30.0, 12.0, 0.0).unwrap()
        ));
        assert_eq!(
            solid_angles([Some(1.0), Some(2.0), Some(3.0)]),
            Err(SOLID_THREE)
        );
        assert_eq!(
            solid_angles([None, Some(95.0), Some(3.0)]),
            Err(SOLID_STEEP)
        );
    }

    #[test]
    fn axial_is_the_frame_the_machine_axes_take() {
        let m = crate::machine::Machine::builtin("bc-trunnion").unwrap();
        let kin = crate::kinematics::Kinematics::new(&m);
        let nominal = FastChain::nominal(&kin);
        let r = axial(&kin, 4, [None, Some(30.0), Some(-70.0)]).unwrap();
        // Independently, through the nominal forward kinematics: the
        // table turns the workpiece, so the machine's X and Y and the
        // tool axis, seen from the workpiece, are where a unit move of X
        // and of Y takes the tip, and the tool axis there.
        let at = |x: f64, y: f64| nominal.forward(&Axes::new(x, y, 0.0, 30.0, -70.0));
        let o = at(0.0, 0.0);
        assert!(
            (r.column(0) - (at(1.0, 0.0).tip - o.tip)).norm() < 1e-9,
            "{r}"
        );
        assert!(
            (r.column(1) - (at(0.0, 1.0).tip - o.tip)).norm() < 1e-9,
            "{r}"
        );
        assert!((r.column(2) - o.axis).norm() < 1e-9, "{r}");
        // Both of the machine's rotary axes, and no other.
        assert!(axial(&kin, 4, [None, Some(30.0), None]).is_err());
        assert!(axial(&kin, 4, [Some(5.0), Some(30.0), Some(0.0)]).is_err());
        assert!(axial(&kin, 4, [Some(0.0), Some(30.0), Some(0.0)]).is_ok());
        let k = klartext("7 PLANE AXIAL B+30 C-70 TURN MB MAX FMAX");
        assert_eq!(
            k.plane,
            Some(Ok(Definition::Axial([None, Some(30.0), Some(-70.0)])))
        );
        assert!(k.turn);
        let spaced = klartext("7 PLANE AXIAL B +30 C -70 STAY");
        assert_eq!(spaced.plane, k.plane);
        assert!(!spaced.turn);
        assert!(matches!(
            klartext("7 PLANE AXIAL B+Q5 C+0 TURN FMAX").plane,
            Some(Err(_))
        ));
    }

    #[test]
    fn linuxcnc_points_and_vectors_build_the_remaps_frame() {
        // P2: origin (10, 0, 5) from Q0 (not the first point), turned
        // R 90 about Z; the points make X along (1, 1, 0)/sqrt 2 and put
        // the third on the +Y side, which here is +Z.
        let mut p2 = Pending::new(2);
        p2.parts[1] = Some([1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        p2.parts[3] = Some([1.0, 1.0, 4.0, 0.0, 0.0, 0.0, 0.0]);
        p2.parts[2] = Some([3.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!(p2.plane().is_none());
        p2.parts[0] = Some([10.0, 0.0, 5.0, 0.0, 0.0, 0.0, 90.0]);
        let w = p2.plane().unwrap().unwrap();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let (x, y) = (Vector3::new(h, h, 0.0), Vector3::z());
        let by_hand = about(b'Z', 90.0) * Matrix3::from_columns(&[x, y, x.cross(&y)]);
        assert!(close(&w.rot, &by_hand), "{}", w.rot);
        assert_eq!(w.origin, Vector3::new(10.0, 0.0, 5.0));
        // Not at a right angle: the remap's frame is no rotation.
        p2.parts[3] = Some([2.0, 1.0, 4.0, 0.0, 0.0, 0.0, 0.0]);
        assert!(p2.plane().unwrap().is_err());
        // P3: X towards the point I J K from the origin, Z the normal.
        let mut p3 = Pending::new(3);
        p3.parts[1] = Some([0.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0]);
        p3.parts[0] = Some([5.0, 5.0, 0.0, 7.0, 5.0, 0.0, 0.0]);
        let w = p3.plane().unwrap().unwrap();
        let z = Vector3::new(0.0, -h, h);
        let by_hand = Matrix3::from_columns(&[Vector3::x(), z.cross(&Vector3::x()), z]);
        assert!(close(&w.rot, &by_hand), "{}", w.rot);
        assert_eq!(w.origin, Vector3::new(5.0, 5.0, 0.0));
        p3.parts[1] = Some([0.0, 0.0, 0.0, 0.01, -1.0, 1.0, 0.0]);
        assert!(p3.plane().unwrap().is_err());
        p3.unknown = true;
        assert!(p3.plane().unwrap().is_err());
    }
}
