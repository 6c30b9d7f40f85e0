//! The word-address G-code that FANUC and LinuxCNC share: the modal groups
//! (motion, plane, units, distance, feed mode, work offset, tool length and
//! TCP, cutter compensation), the non-modal codes whose axis words are not
//! positions (dwell, reference return, machine coordinates, probing, data
//! setting, G52, G92) and the move a block of axis words makes.

use super::ReasonKind;
use super::offsets::MACHINE_ZERO;
use super::{
    AXES, Arc, ArcPlane, Event, FeedMode, Interpreter, Motion, Move, MoveKind, Skip, Tcp, Tilt,
    Units, arc_runs, center_from_radius,
};
use crate::machine::Dialect;
pub(crate) use crate::nc::g_codes::g_code;
use crate::nc::{Block, Segment, Stmt, Value};

/// Haas's dynamic work offset (G254) given while a tilted plane is
/// active: Haas's manual does not say what the two make together.
const HAAS_DWO_IN_PLANE: &str = "a Haas dynamic work offset (G254) in a tilted working plane";

/// What the words of one block say, gathered before anything moves.
#[derive(Default)]
struct WordScan {
    g_nonmodal: Option<u32>,
    motion_word: Option<usize>,
    motion_here: Option<Motion>,
    drill_here: Option<u32>,
    m_codes: [Option<u32>; 4],
    nm: usize,
    p_word: Option<f64>,
    has_axis: bool,
    expr_g: bool,
}

impl Interpreter {
    /// One FANUC or LinuxCNC statement.
    pub(super) fn gcode(&mut self, block: &Block, seg: &Segment) -> Event {
        match seg.stmt {
            Stmt::Words => self.words(block, seg),
            Stmt::Flow(_) => {
                self.forget();
                Event::None
            }
            _ => Event::None,
        }
    }

    fn words(&mut self, block: &Block, seg: &Segment) -> Event {
        let old_frame = self.frame_key();
        let old_offset = self.offset_shift();
        let mut s = WordScan::default();
        for (ti, w) in block.words(seg) {
            let Some(letter) = w.addr.as_letter() else {
                continue;
            };
            match letter {
                b'G' => {
                    let Value::Num(v) = w.value else {
                        s.expr_g = true;
                        continue;
                    };
                    if let Some(g) = g_code(v) {
                        self.g_word(block, ti, g, &mut s);
                    }
                }
                b'M' => {
                    if let Value::Num(v) = w.value {
                        let m = v.round() as u32;
                        if s.nm < 4 {
                            s.m_codes[s.nm] = Some(m);
                            s.nm += 1;
                        }
                        self.m_function(m, block.tokens[ti].span.start as usize, block.line);
                    }
                }
                b'P' => {
                    if let Value::Num(v) = w.value {
                        s.p_word = Some(v);
                    }
                }
                b'F' => {
                    if let Value::Num(v) = w.value {
                        self.feed = Some(v);
                    }
                }
                // U, V and W move axes this machine does not have;
                // LinuxCNC's `@` and `^` put X and Y in polar coordinates.
                b'U' | b'V' | b'W' | b'@' | b'^' => s.has_axis = true,
                _ => {
                    if self.axis_index(w.addr).is_some() {
                        s.has_axis = true;
                    }
                }
            }
        }
        // G54.1 P n selects an additional work offset.
        if self.work_offset == 5410
            && let Some(p) = s.p_word
        {
            self.work_offset = 5410 + p.round() as u32;
        }
        let frame_now = self.frame_key();
        let rest = |k: (u32, bool, Tcp, bool, Units)| (k.1, k.2, k.3, k.4);
        let only_offset = frame_now.0 != old_frame.0 && rest(frame_now) == rest(old_frame);
        if only_offset && self.offsets.set && old_offset.is_some() {
            // Another offset whose values the program set: the same place
            // has other numbers, by the difference of the two.
            self.reoffset(old_offset);
        } else if frame_now != old_frame {
            // The same numbers mean another place now; rotary positions
            // are machine positions whatever the frame (no work offset has
            // a rotary part unless the program sets one, below: each lies
            // on the W origin at rotary zero; TCP
            // turns the linear axes, not the rotary ones) and keep their
            // meaning, and in a tilted plane tool length compensation
            // moves the controlled point along the plane's Z only.
            let kept = self.pos;
            self.forget();
            // FANUC's G43/G44/G49 offset only the tool-axis coordinate
            // (tool length compensation along Z, FANUC Series 30i/31i-B
            // operator's manual B-64484EN, "Tool length compensation"):
            // X and Y mean the same place before and after. LinuxCNC's
            // tool table may give a tool X and Y offsets as well, which
            // G43 applies: there they are not known without the table.
            let length_only = self.cfg.settings.dialect == Dialect::Fanuc
                && frame_now.1 != old_frame.1
                && (frame_now.0, frame_now.2, frame_now.3, frame_now.4)
                    == (old_frame.0, old_frame.2, old_frame.3, old_frame.4)
                && frame_now.2 == Tcp::Off
                && !self.tilted;
            let same = |i: usize| {
                i >= 3
                    || (length_only && i < 2)
                    || (frame_now.0 == old_frame.0
                        && frame_now.2 == old_frame.2
                        && self.tilted
                        && frame_now.3 == old_frame.3
                        && frame_now.4 == old_frame.4
                        && i < 2)
            };
            for (i, k) in kept.iter().enumerate() {
                if same(i) {
                    self.pos[i] = *k;
                }
            }
            // A rotary zero shift the program set moves the rotary
            // positions' meaning with the offset.
            let new_offset = self.offset_shift();
            if self.offsets.set && new_offset != old_offset {
                for i in [self.cfg.tilt, 5] {
                    self.pos[i] = match (old_offset, new_offset, self.pos[i]) {
                        (Some(b), Some(a), Some(p)) => Some(p + b[i] - a[i]),
                        _ => None,
                    };
                }
            }
        }
        self.words_event(block, seg, &s)
    }

    /// The work offset, tool length, TCP, tilt and units: what the numbers
    /// of an axis word mean.
    pub(super) fn frame_key(&self) -> (u32, bool, Tcp, bool, Units) {
        (
            self.work_offset,
            self.tool_length,
            self.tcp,
            self.tilted,
            self.units,
        )
    }

    /// One G code of a block: modal state set at once, the motion, cycle
    /// and non-modal codes noted in `s` for [`Self::words_event`].
    fn g_word(&mut self, block: &Block, ti: usize, g: u32, s: &mut WordScan) {
        match g {
            0 | 10 | 20 | 30 => {
                s.motion_here = Motion::of_g(g);
                s.motion_word = Some(ti);
            }
            50 | 51 | 52 | 53 | 330 | 331 | 760 | 730 | 740 | 810..=890 => {
                s.motion_here = Some(Motion::Other);
                s.motion_word = Some(ti);
                s.drill_here = Some(g);
            }
            800 => {
                self.motion = None;
                self.end_cycle();
            }
            980 => self.retract_initial = true,
            990 => self.retract_initial = false,
            40
            | 100
            | 280
            | 281
            | 300
            | 301
            | 310..=314
            | 382..=385
            | 520
            | 530
            | 650
            | 660
            | 531
            | 682
            | 920 => s.g_nonmodal = Some(g),
            670 => {}
            170 => self.plane = ArcPlane::Xy,
            180 => self.plane = ArcPlane::Zx,
            190 => self.plane = ArcPlane::Yz,
            200 => self.units = Units::Inch,
            210 => self.units = Units::Mm,
            900 => {
                self.absolute = true;
                self.state_unknown = None;
            }
            910 => {
                self.absolute = false;
                self.state_unknown = None;
            }
            901 => self.arc_absolute = true,
            911 => self.arc_absolute = false,
            921 | 922 => {
                self.shift = [0.0; 3];
            }
            930 => self.feed_mode = FeedMode::InverseTime,
            940 => self.feed_mode = FeedMode::PerMinute,
            950 => self.feed_mode = FeedMode::PerRev,
            400 => self.radius_comp = None,
            410..=412 => self.radius_comp = Some(super::approach::Side::Left),
            420..=422 => self.radius_comp = Some(super::approach::Side::Right),
            430 | 431 | 432 | 440 => {
                self.tool_length = true;
                self.tcp = Tcp::Off;
            }
            434 => {
                self.tool_length = true;
                self.tcp = Tcp::Axes;
            }
            435 => {
                self.tool_length = true;
                self.tcp = Tcp::Vector;
            }
            490 => {
                self.tool_length = false;
                self.tcp = Tcp::Off;
            }
            // Haas G234, tool centre point control: in the
            // tool length group as G43.4, X, Y, Z the tip in
            // the work offset turning with the table.
            2340 => {
                self.tool_length = true;
                self.tcp = Tcp::Axes;
            }
            // Haas's dynamic work offset: "after G254 is invoked, you
            // must specify an X-, Y-, and Z-Axis position" (the Haas
            // manual), so the linear positions start unknown.
            2540 => match self.working_plane {
                None | Some(Tilt::Workpiece) => self.set_plane(Some(Tilt::Workpiece)),
                Some(_) => {
                    let at = block.tokens[ti].span.start as usize;
                    self.plane_unmodelled(block.line, at, HAAS_DWO_IN_PLANE);
                }
            },
            2550 if self.working_plane == Some(Tilt::Workpiece)
                || matches!(self.working_plane, Some(Tilt::Unmodelled { why, .. }) if why == HAAS_DWO_IN_PLANE) =>
            {
                self.set_plane(None)
            }
            // G255 with no dynamic work offset active cancels nothing.
            2550 => {}
            541 => self.work_offset = 5410,
            540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => self.work_offset = g,
            // G68.3: the plane normal to the tool axis; its X direction
            // is the machine builder's (FANUC parameters, LinuxCNC's
            // per-kinematics `kins_calc_virtual_rot_for_g683`).
            683 => {
                let at = block.tokens[ti].span.start as usize;
                self.plane_unmodelled(
                    block.line,
                    at,
                    "G68.3, the plane from the tool axis, not implemented yet: the direction of its X axis is set by the machine's configuration",
                );
            }
            684 => s.g_nonmodal = Some(g),
            // G53.6: the axes turn to the plane keeping the tool centre
            // point where it is.
            536 => {
                let at = block.tokens[ti].span.start as usize;
                self.plane_unmodelled(
                    block.line,
                    at,
                    "G53.6, turning to the plane with the tool centre point kept, not implemented yet",
                );
            }
            680 => self.transformed = Some("coordinate rotation (G68)"),
            690 => {
                self.plane_pending = None;
                if self.tilted {
                    self.set_plane(None);
                }
                self.cancel("coordinate rotation (G68)");
            }
            // The axis words of a G51 block are the scaling centre, of a
            // G51.1 block the mirror axes: no move.
            510 => {
                self.transformed = Some("scaling (G51)");
                s.g_nonmodal = Some(g);
            }
            500 => self.cancel("scaling (G51)"),
            511 => {
                self.transformed = Some("programmable mirror image (G51.1)");
                s.g_nonmodal = Some(g);
            }
            501 => self.cancel("programmable mirror image (G51.1)"),
            160 => self.transformed = Some("polar coordinate command (G16)"),
            150 => self.cancel("polar coordinate command (G16)"),
            121 => self.transformed = Some("polar coordinate interpolation (G12.1)"),
            131 => self.cancel("polar coordinate interpolation (G12.1)"),
            71 => {
                self.transformed = if self.transformed.is_none() {
                    Some("cylindrical interpolation (G7.1)")
                } else {
                    None
                }
            }
            _ => {}
        }
    }

    /// What a block does once its words are read: a move, a cycle's hole,
    /// a non-modal code's effect, or why its axis words are not followed.
    fn words_event(&mut self, block: &Block, seg: &Segment, s: &WordScan) -> Event {
        let calls = s.m_codes.iter().flatten().any(|&m| m == 98 || m == 99);
        if let Some(m) = s.motion_here {
            self.motion = Some(m);
            // Another motion code ends the cycle and forgets its data.
            match s.drill_here.filter(|&g| self.drill_cycle(g)) {
                Some(g) => self.cycle = Some(g),
                None => self.end_cycle(),
            }
        }
        if s.expr_g {
            // A G code from a variable: nothing below can be trusted.
            self.forget();
            self.motion = None;
            return if s.has_axis {
                Event::Skip(Skip::Expression)
            } else {
                Event::None
            };
        }
        if let Some(g) = s.g_nonmodal {
            let ev = self.nonmodal(block, seg, g, s.has_axis);
            if calls {
                self.forget();
            }
            return ev;
        }
        if calls {
            self.forget();
            return if s.has_axis {
                Event::Skip(Skip::MacroCall)
            } else {
                Event::None
            };
        }
        if !s.has_axis {
            if let Some(u) = seg.unknown {
                let word = String::from_utf8_lossy(block.bytes(u)).into_owned();
                self.note(
                    u.start as usize,
                    format!("`{word}`: a word fivecal does not know (taken to move no axis)"),
                );
            }
            return Event::None;
        }
        let motion = self.motion;
        match motion {
            Some(Motion::Rapid) | Some(Motion::Linear) | Some(Motion::ArcCw)
            | Some(Motion::ArcCcw) => self.iso_move(block, seg, motion.unwrap(), s.motion_word),
            Some(Motion::Other) if self.cycle.is_some() => self.drill(block, seg),
            Some(Motion::Other) => {
                self.track_words(block, seg);
                Event::Skip(Skip::CannedCycle)
            }
            None => {
                self.track_words(block, seg);
                Event::Skip(Skip::Element(
                    ReasonKind::Unsaid,
                    "motion without a motion mode",
                ))
            }
        }
    }

    /// A block whose axis words belong to a non-modal G code.
    fn nonmodal(&mut self, block: &Block, seg: &Segment, g: u32, has_axis: bool) -> Event {
        match g {
            // Dwell, scaling centre, mirror axes: the axis words are not
            // positions.
            40 | 510 | 511 => Event::None,
            // Data setting (work offsets, tool offsets): the offsets in use
            // may have changed.
            100 => {
                self.data_setting(block, seg);
                Event::None
            }
            // Reference return.
            280 | 281 | 300 | 301 => {
                self.forget_named(block, seg);
                if has_axis { Event::Quiet } else { Event::None }
            }
            // Machine coordinates.
            530 => {
                let absolute = self.absolute;
                self.machine_move(block, seg, |_, w| absolute && !w.incremental);
                if has_axis { Event::Quiet } else { Event::None }
            }
            // Probing: the machine stops somewhere along the move.
            310..=314 | 382..=385 => {
                self.forget_named(block, seg);
                Event::Quiet
            }
            // G53.1 turns the rotary axes to the tilted plane, the
            // solution nearest where they are (the shortest path of the
            // tilt, as LinuxCNC's remap does by default).
            531 => {
                let at = g_offset(block, seg, 531);
                self.position_for_plane(block.line, at, super::plane::Choice::Nearest);
                self.pos[0] = None;
                self.pos[1] = None;
                self.pos[2] = None;
                Event::None
            }
            682 => {
                self.g68_2(block, seg);
                Event::None
            }
            684 => {
                self.g68_4(block, seg);
                Event::None
            }
            650 | 660 => {
                self.forget();
                if has_axis {
                    Event::Skip(Skip::MacroCall)
                } else {
                    Event::None
                }
            }
            520 | 920 if self.tilted && has_axis => {
                // A shift along the plane's axes or the workpiece's: which
                // one the control takes is not modelled.
                let at = g_offset(block, seg, g);
                self.plane_unmodelled(block.line, at, "G52/G92 inside the tilted plane");
                Event::None
            }
            520 => {
                // G52: local coordinate system (absolute values; X0 cancels).
                for (_, w) in block.words(seg) {
                    if let Some(i) = self.axis_index(w.addr).filter(|&i| i < 3) {
                        match self.axis_value(&w) {
                            Ok(v) => {
                                if let Some(p) = self.pos[i] {
                                    self.pos[i] = Some(p + self.local_shift[i] - v);
                                }
                                self.local_shift[i] = v;
                            }
                            Err(_) => {
                                self.shift_known = false;
                            }
                        }
                    }
                }
                Event::None
            }
            920 => {
                // G92: the current position becomes the value given.
                for (_, w) in block.words(seg) {
                    if let Some(i) = self.axis_index(w.addr) {
                        match (self.axis_value(&w), self.pos[i]) {
                            (Ok(v), Some(p)) if i < 3 => {
                                self.shift[i] += p - v;
                                self.pos[i] = Some(v);
                            }
                            (Ok(v), _) if i >= 3 => {
                                // A rotary G92 shifts the rotary zero: unknown.
                                let _ = v;
                                self.pos[i] = None;
                                self.transformed = Some("a rotary-axis G92 shift");
                            }
                            _ => {
                                self.shift_known = false;
                                self.pos[i] = None;
                            }
                        }
                    }
                }
                Event::None
            }
            _ => Event::None,
        }
    }

    /// G68.2: the feature coordinate system X Y Z (origin) I J K (Euler
    /// angles). FANUC: rotating Z-X'-Z''; its other forms (a P word:
    /// roll-pitch-yaw, three points, two vectors, projection angles) are
    /// left as written, their definitions not having been checked against
    /// FANUC's manual. LinuxCNC's tilted-work-plane remap: P0 (or none)
    /// proper Euler angles in the order of its Q word (313, i.e. Z-X'-Z'',
    /// by default), P1 Tait-Bryan angles (Q 123 by default), and R a turn
    /// about the plane's origin in the XY plane before them; P2 (three
    /// points) and P3 (two vectors) over several blocks
    /// ([`super::plane::Pending`]).
    fn g68_2(&mut self, block: &Block, seg: &Segment) {
        let line = block.line;
        let at = g_offset(block, seg, 682);
        if self.tilted {
            return self.plane_unmodelled(line, at, "G68.2 while a plane is active");
        }
        if !self.absolute {
            self.plane_pending = None;
            return self.plane_unmodelled(line, at, "G68.2 under G91");
        }
        let linuxcnc = self.cfg.settings.dialect == Dialect::Linuxcnc;
        // X Y Z I J K R P Q, `None` where not given; `Err` for a word
        // whose value is not known here.
        let mut vals = [Ok(None::<f64>); 9];
        for (_, w) in block.words(seg) {
            let l = w.addr.as_letter().unwrap_or(0);
            if l == b'G' {
                continue;
            }
            let Some(k) = b"XYZIJKRPQ".iter().position(|&c| c == l) else {
                return self.plane_unmodelled(
                    line,
                    at,
                    "G68.2 with a word other than X Y Z I J K (another way to give the plane)",
                );
            };
            if k >= 6 && !linuxcnc {
                return self.plane_unmodelled(
                    line,
                    at,
                    "FANUC G68.2 with R, P or Q (roll-pitch-yaw, three points, two vectors or projection angles: not checked against FANUC's manual)",
                );
            }
            vals[k] = self.axis_value(&w).map(Some);
        }
        let known = |k: usize| vals[k].ok().flatten();
        let p = match vals[7] {
            Ok(p) => p.unwrap_or(0.0),
            Err(_) => {
                self.plane_pending = None;
                return self.plane_unmodelled(line, at, "a parameter or an expression in G68.2");
            }
        };
        if p == 2.0 || p == 3.0 {
            return self.g68_2_part(line, at, p as u8, &vals);
        }
        // A one-block form starts the definition afresh.
        self.plane_pending = None;
        if vals.iter().any(Result::is_err) {
            return self.plane_unmodelled(
                line,
                at,
                "a parameter, an expression or a value without a decimal point in G68.2",
            );
        }
        let val = |k: usize| known(k).unwrap_or(0.0);
        let order = match (p, known(8).map(|q| q.round() as i64)) {
            (0.0, None) => *b"ZXZ",
            (1.0, None) => *b"XYZ",
            (p, Some(q)) if p == 0.0 || p == 1.0 => {
                let proper = [121, 131, 212, 232, 313, 323];
                let tait = [123, 132, 213, 231, 312, 321];
                let list = if p == 0.0 { proper } else { tait };
                if !list.contains(&q) {
                    return self.plane_unmodelled(line, at, "G68.2 with an unknown Q order");
                }
                let d = |n: i64| b"XYZ"[(n - 1) as usize];
                [d(q / 100), d(q / 10 % 10), d(q % 10)]
            }
            _ => return self.plane_unmodelled(line, at, "G68.2 with an unknown P form"),
        };
        let rot = super::plane::about(b'Z', val(6))
            * super::plane::intrinsic(&order, [val(3), val(4), val(5)]);
        let plane = super::plane::WorkPlane {
            rot,
            origin: nalgebra::Vector3::new(val(0), val(1), val(2)),
        };
        self.set_plane(Some(super::Tilt::Plane(plane)));
    }

    /// G68.4: a plane given on the plane in force, in its coordinates
    /// (FANUC's incremental multi-command; LinuxCNC's remap multiplies the
    /// plane in force by the one the block gives, read as G68.2 reads it).
    fn g68_4(&mut self, block: &Block, seg: &Segment) {
        let line = block.line;
        let at = g_offset(block, seg, 684);
        let current = match self.working_plane {
            Some(Tilt::Plane(w)) if self.tilted => w,
            // A plane not modelled stays so.
            Some(Tilt::Unmodelled { .. }) => return,
            _ => {
                return self.plane_unmodelled(
                    line,
                    at,
                    "G68.4 with no plane in force: FANUC then reads it as G68.2, LinuxCNC's remap stops with an error, so the file does not say which",
                );
            }
        };
        let p_form = block.words(seg).any(|(_, w)| {
            w.addr.as_letter() == Some(b'P')
                && !matches!(w.value, Value::Num(p) if p == 0.0 || p == 1.0)
        });
        if p_form {
            return self.plane_unmodelled(
                line,
                at,
                "G68.4 over several blocks (P2, P3) or with a P given by a parameter, not implemented yet",
            );
        }
        // The increment is read as G68.2 reads a plane, then put on the
        // plane in force.
        self.set_plane(None);
        self.g68_2(block, seg);
        if let Some(Tilt::Plane(inc)) = self.working_plane {
            let plane = super::plane::WorkPlane {
                rot: current.rot * inc.rot,
                origin: current.origin + current.rot * inc.origin,
            };
            self.set_plane(Some(Tilt::Plane(plane)));
        }
    }

    /// One block of LinuxCNC's G68.2 P2 / P3: its part is kept, and the
    /// plane is set once every part is given.
    fn g68_2_part(&mut self, line: usize, at: usize, p: u8, vals: &[Result<Option<f64>, Skip>; 9]) {
        let mut pending = match self.plane_pending {
            Some(pd) if pd.p == p => pd,
            // The remap keeps one definition state: parts of another form
            // mix into it.
            Some(_) => {
                self.plane_pending = None;
                return self.plane_unmodelled(line, at, "G68.2 P2 and P3 parts mixed");
            }
            None => super::plane::Pending::new(p),
        };
        let q = match vals[8] {
            Ok(q) => q.unwrap_or(0.0),
            Err(_) => {
                self.plane_pending = None;
                return self.plane_unmodelled(line, at, "a parameter or an expression in G68.2");
            }
        };
        if q.fract() != 0.0 || q < 0.0 || q as usize >= pending.needed() {
            self.plane_pending = None;
            return self.plane_unmodelled(line, at, "G68.2 P2/P3 with an unknown Q");
        }
        let mut part = [0.0; 7];
        for (k, v) in part.iter_mut().enumerate() {
            match vals[k] {
                Ok(x) => *v = x.unwrap_or(0.0),
                Err(_) => pending.unknown = true,
            }
        }
        pending.parts[q as usize] = Some(part);
        match pending.plane() {
            None => self.plane_pending = Some(pending),
            Some(plane) => {
                self.plane_pending = None;
                match plane {
                    Ok(w) => self.set_plane(Some(super::Tilt::Plane(w))),
                    Err(why) => self.plane_unmodelled(line, at, why),
                }
            }
        }
    }

    /// G10 L2 / L20: work offset data ([`super::offsets`]). The offset
    /// named gets the values written: L2 as values in machine coordinates
    /// (FANUC adds them in G91; LinuxCNC's G10 ignores G90/G91), LinuxCNC
    /// L20 the values that make the current position read as written, in
    /// that offset (`V = position + V in force - value`); FANUC L20 sets
    /// the additional offsets G54.1 P n as L2 does. Positions in the offset
    /// in force follow its new values. What is not modelled is noted (and
    /// `--strict` refuses it): the FANUC external offset (P0), an offset
    /// not identified, LinuxCNC's rotation (R), a value not known here;
    /// other G10 data (tools, parameters) is noted as such.
    fn data_setting(&mut self, block: &Block, seg: &Segment) {
        let mut l = None;
        let mut p = None;
        let mut at = 0;
        let mut rotation = false;
        let mut values: [Option<Option<f64>>; 6] = [None; 6];
        let mut tokens = [None; 6];
        for (ti, w) in block.words(seg) {
            match (w.addr.as_letter(), w.value) {
                (Some(b'G'), _) => at = block.tokens[ti].span.start as usize,
                (Some(b'L'), Value::Num(v)) => l = Some(v.round() as i64),
                (Some(b'P'), Value::Num(v)) => p = Some(v.round() as i64),
                (Some(b'R'), _) => rotation = true,
                _ => {
                    if let Some(i) = self.axis_index(w.addr) {
                        values[i] = Some(self.axis_value(&w).ok());
                        tokens[i] = Some(ti);
                    }
                }
            }
        }
        let linuxcnc = self.cfg.settings.dialect == Dialect::Linuxcnc;
        let offset = match (l, p) {
            // P0: the offset in use (LinuxCNC), the external offset that
            // shifts them all (FANUC).
            (Some(2 | 20), Some(0)) if linuxcnc => Some(self.work_offset),
            (Some(2 | 20), Some(n @ 1..=6)) if linuxcnc || l == Some(2) => {
                Some(530 + 10 * n as u32)
            }
            (Some(2 | 20), Some(n @ 7..=9)) if linuxcnc => Some(584 + n as u32),
            // FANUC G10 L20 P n: the additional offset G54.1 P n.
            (Some(20), Some(n @ 1..=300)) if !linuxcnc => Some(5410 + n as u32),
            (Some(2 | 20), _) => Some(MACHINE_ZERO),
            _ => None,
        };
        let Some(id) = offset else {
            // A tool's data may be the one in use: the linear positions
            // may mean another place now; the rotary ones do not.
            self.pos[..3].fill(None);
            self.pole = None;
            self.note(
                at,
                "G10: the program changes tool or parameter data (the machine file's tool is used)",
            );
            return;
        };
        let before = self.offset_shift();
        if id == MACHINE_ZERO {
            self.offsets.set = true;
            self.offsets.lost = Some(if p == Some(0) {
                "the external work offset (G10 L2 P0), which shifts every offset, was changed by the program by an amount fivecal does not relate to --origin"
            } else {
                "G10 L2/L20 changed a work offset fivecal cannot identify (P missing or from a variable): no offset is known relative to --origin after it"
            });
            self.note(
                at,
                "G10: the program changes work offset data fivecal does not model (moves after it are left as written)",
            );
            self.reoffset(before);
            return;
        }
        let in_force = self.offsets.value(self.work_offset);
        let mut v = self.offsets.value(id);
        let incremental = !linuxcnc && !self.absolute;
        let current = l == Some(20) && linuxcnc;
        let mut unknown = rotation || (current && (self.tilted || self.tcp != super::Tcp::Off));
        for (i, w) in values.iter().enumerate() {
            let Some(w) = w else { continue };
            let k = if i < 3 { self.units.mm() } else { 1.0 };
            v[i] = match (*w, current) {
                (Some(x), false) if incremental => v[i].map(|(b, d)| (b, d + x * k)),
                (Some(x), false) => Some((MACHINE_ZERO, x * k)),
                (Some(x), true) => match (self.pos[i], in_force[i]) {
                    (Some(q), Some((b, d))) => Some((b, d + (q - x) * k)),
                    _ => None,
                },
                (None, _) => None,
            };
            unknown |= v[i].is_none();
        }
        if rotation {
            v = [None; 6];
        }
        if current {
            self.setting_words = Some(tokens);
        }
        self.offsets.store(id, v);
        if unknown {
            self.note(
                at,
                if rotation {
                    "G10: a work offset with a rotation (R), which fivecal does not model (moves in that offset are left as written)"
                } else {
                    "G10: work offset data whose value is not known here (an expression, or the position it counts from is unknown): moves in that offset are left as written"
                },
            );
        }
        self.reoffset(before);
    }

    /// Updates tracked positions from the axis words (for moves left as
    /// written): literal values are followed, expressions forget.
    fn iso_move(
        &mut self,
        block: &Block,
        seg: &Segment,
        motion: Motion,
        motion_word: Option<usize>,
    ) -> Event {
        let start = self.pos;
        let mut mv = Move::new(MoveKind::Rapid, start, !self.absolute);
        mv.motion_word = motion_word;
        let mut skip: Option<Skip> = seg.unknown.map(|_| Skip::UnknownWord);
        let mut ijk: [Option<(usize, f64)>; 3] = [None; 3];
        let mut r_word: Option<(usize, f64)> = None;
        let mut p_turns: Option<f64> = None;
        let mut polar = PolarWords::default();
        for (ti, w) in block.words(seg) {
            let letter = w.addr.as_letter().unwrap_or(0);
            if let Some(i) = self.axis_index(w.addr) {
                mv.words[i] = Some(ti);
                if !self.machine_axis(i) {
                    skip.get_or_insert(Skip::UnknownAxis(AXES[i]));
                }
                match self.axis_value(&w) {
                    Ok(v) => {
                        mv.end[i] = if self.absolute {
                            Some(v)
                        } else {
                            start[i].map(|p| p + v)
                        };
                    }
                    Err(s) => {
                        mv.end[i] = None;
                        skip.get_or_insert(s);
                    }
                }
                continue;
            }
            match letter {
                b'I' | b'J' | b'K' => {
                    let k = (letter - b'I') as usize;
                    match self.axis_value(&w) {
                        Ok(v) => ijk[k] = Some((ti, v)),
                        Err(s) => {
                            skip.get_or_insert(s);
                        }
                    }
                }
                b'R' => match self.axis_value(&w) {
                    Ok(v) => r_word = Some((ti, v)),
                    Err(s) => {
                        skip.get_or_insert(s);
                    }
                },
                b'P' => {
                    if let Value::Num(v) = w.value {
                        p_turns = Some(v);
                    }
                }
                b'F' => {
                    if let Value::Num(v) = w.value {
                        mv.feed = Some((ti, v));
                    } else if self.feed_mode == FeedMode::InverseTime {
                        // Pieces of a subdivided move need their share of
                        // the block's time.
                        skip.get_or_insert(Skip::Expression);
                    }
                    // Otherwise the feed word stays as written and the
                    // axis words are corrected all the same (`F#650`).
                }
                b'@' | b'^' => polar.read(self, ti, &w, &mut skip),
                b'U' | b'V' | b'W' => {
                    skip.get_or_insert(Skip::UnknownAxis(letter));
                }
                _ => {}
            }
        }
        if polar.any() {
            let end = self.polar_end(&mv, &polar, !self.absolute, true);
            match end {
                Ok(p) => {
                    mv.end[0] = Some(p[0]);
                    mv.end[1] = Some(p[1]);
                }
                Err(s) => {
                    mv.end[0] = None;
                    mv.end[1] = None;
                    skip.get_or_insert(s);
                }
            }
            mv.polar = Some(polar.words(!self.absolute));
        }
        self.pos = mv.end;
        mv.kind = match motion {
            Motion::Rapid => MoveKind::Rapid,
            Motion::Linear => MoveKind::Linear,
            Motion::ArcCw | Motion::ArcCcw => {
                let cw = motion == Motion::ArcCw;
                let (a, b, _) = self.plane.axes();
                let (s0, s1, e0, e1) = (start[a], start[b], mv.end[a], mv.end[b]);
                let (Some(s0), Some(s1), Some(e0), Some(e1)) = (s0, s1, e0, e1) else {
                    return Event::Skip(skip.unwrap_or(Skip::PositionUnknown(
                        AXES[if start[a].is_none() || mv.end[a].is_none() {
                            a
                        } else {
                            b
                        }],
                    )));
                };
                let center = if let Some((_, r)) = r_word {
                    match center_from_radius([s0, s1], [e0, e1], r, cw) {
                        Some(c) => c,
                        None => {
                            return Event::Skip(skip.unwrap_or(Skip::Element(
                                ReasonKind::Unsaid,
                                "an arc whose radius does not reach its end point",
                            )));
                        }
                    }
                } else {
                    let off = |axis: usize| ijk[axis].map(|(_, v)| v).unwrap_or(0.0);
                    let c = if self.arc_absolute {
                        [
                            ijk[a].map(|(_, v)| v).unwrap_or(s0),
                            ijk[b].map(|(_, v)| v).unwrap_or(s1),
                        ]
                    } else {
                        [s0 + off(a), s1 + off(b)]
                    };
                    if !arc_runs([s0, s1], [e0, e1], c, self.units.mm()) {
                        return Event::Skip(skip.unwrap_or(Skip::Element(
                            ReasonKind::Unsaid,
                            "off-circle arc (its centre I, J, K not as far from the end as from the start)",
                       ) ));
                    }
                    c
                };
                MoveKind::Arc(Arc {
                    plane: self.plane,
                    cw,
                    center,
                    turns: p_turns.map_or(0, |p| (p.round() as u32).saturating_sub(1)),
                    center_words: [
                        ijk[0].map(|x| x.0),
                        ijk[1].map(|x| x.0),
                        ijk[2].map(|x| x.0),
                    ],
                    radius_word: r_word.map(|x| x.0),
                })
            }
            Motion::Other => unreachable!(),
        };
        if self.tcp == Tcp::Vector && !matches!(mv.kind, MoveKind::Arc(_)) {
            // G43.5: I J K are the tool direction; omitted ones are zero.
            if ijk.iter().any(|x| x.is_some()) {
                let v = [
                    ijk[0].map_or(0.0, |x| x.1),
                    ijk[1].map_or(0.0, |x| x.1),
                    ijk[2].map_or(0.0, |x| x.1),
                ];
                mv.tool_vector = Some((
                    v,
                    [
                        ijk[0].map(|x| x.0),
                        ijk[1].map(|x| x.0),
                        ijk[2].map(|x| x.0),
                    ],
                ));
            }
        }
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }
    /// Whether a motion code (x 10) is a drilling cycle whose holes are
    /// positions: G73, G74, G81-G89, and FANUC's fine boring G76
    /// (LinuxCNC's G76 is a threading cycle).
    fn drill_cycle(&self, g: u32) -> bool {
        matches!(g, 730 | 740 | 810..=890)
            || (g == 760 && self.cfg.settings.dialect == Dialect::Fanuc)
    }

    /// G80 or another motion code: the cycle and its data are gone.
    pub(super) fn end_cycle(&mut self) {
        self.cycle = None;
        self.cycle_depth = None;
        self.cycle_r = None;
    }

    /// A block in a drilling cycle: one hole at X Y (the plane's axes), to
    /// the bottom Z (the normal axis; modal), from the R level (modal).
    /// The move is the hole's bottom, reached along the drill axis; the
    /// tool then waits at the R level (G99) or the level it came from
    /// (G98, never below R). The repeat count (FANUC K, LinuxCNC L) drills
    /// the same hole again in G90; incremental cycles are left as written.
    fn drill(&mut self, block: &Block, seg: &Segment) -> Event {
        let (_, _, n) = self.plane.axes();
        let linuxcnc = self.cfg.settings.dialect == Dialect::Linuxcnc;
        let mut mv = Move::new(MoveKind::Rapid, self.pos, false);
        let mut skip = seg.unknown.map(|_| Skip::UnknownWord);
        let mut repeats = None;
        let mut polar = PolarWords::default();
        for (ti, w) in block.words(seg) {
            let Some(letter) = w.addr.as_letter() else {
                continue;
            };
            if let Some(i) = self.axis_index(w.addr) {
                mv.words[i] = Some(ti);
                if i >= 3 {
                    skip.get_or_insert(Skip::Element(
                        ReasonKind::NotImplemented,
                        "a rotary axis word in a canned cycle",
                    ));
                }
                match self.axis_value(&w) {
                    Ok(v) => mv.end[i] = Some(v),
                    Err(s) => {
                        mv.end[i] = None;
                        skip.get_or_insert(s);
                    }
                }
                continue;
            }
            match letter {
                b'R' => match self.axis_value(&w) {
                    Ok(v) => self.cycle_r = Some(v),
                    Err(s) => {
                        self.cycle_r = None;
                        skip.get_or_insert(s);
                    }
                },
                b'K' if !linuxcnc => repeats = Some(w.value),
                b'L' => repeats = Some(w.value),
                b'@' | b'^' => polar.read(self, ti, &w, &mut skip),
                b'F' => {
                    if let Value::Num(v) = w.value {
                        mv.feed = Some((ti, v));
                    }
                }
                b'U' | b'V' | b'W' => {
                    skip.get_or_insert(Skip::UnknownAxis(letter));
                }
                _ => {}
            }
        }
        if !self.absolute {
            // Z and R count from the initial level and the R level: the
            // holes of a G91 cycle with repeats are several places.
            self.track_words(block, seg);
            self.pos[n] = None;
            return Event::Skip(Skip::Element(
                ReasonKind::NotImplemented,
                "a canned cycle in incremental distance (G91)",
            ));
        }
        if polar.any() {
            // A hole in polar coordinates: the word left out is where the
            // tool stands (LinuxCNC's cycles do not refuse the origin).
            match self.polar_end(&mv, &polar, false, false) {
                Ok(p) => {
                    mv.end[0] = Some(p[0]);
                    mv.end[1] = Some(p[1]);
                }
                Err(s) => {
                    mv.end[0] = None;
                    mv.end[1] = None;
                    skip.get_or_insert(s);
                }
            }
            mv.polar = Some(polar.words(false));
        }
        if mv.words[n].is_some() {
            self.cycle_depth = mv.end[n];
        }
        mv.end[n] = self.cycle_depth;
        let initial = mv.start[n];
        let r = self.cycle_r;
        for i in 0..6 {
            if i != n {
                self.pos[i] = mv.end[i];
            }
        }
        self.pos[n] = match (r, initial) {
            (Some(r), Some(z)) if self.retract_initial => Some(z.max(r)),
            (Some(r), _) if !self.retract_initial => Some(r),
            _ => None,
        };
        match repeats {
            Some(Value::Num(k)) if k.round() == 0.0 => {
                // FANUC K0: the data is stored, no hole is drilled.
                return Event::Skip(Skip::Element(
                    ReasonKind::NotImplemented,
                    "a canned cycle block with K0/L0 (no hole)",
                ));
            }
            Some(Value::Num(_)) | None => {}
            Some(_) => {
                skip.get_or_insert(Skip::Expression);
            }
        }
        let Some(r_level) = r else {
            return Event::Skip(skip.unwrap_or(Skip::Element(
                ReasonKind::Unsaid,
                "a canned cycle without its R level",
            )));
        };
        mv.drill = Some(super::Drill {
            axis: n,
            r_level,
            to_initial: self.retract_initial,
            call_offset: None,
        });
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }
}

/// LinuxCNC's polar words of a block: `@` (the distance from the origin
/// of the XY plane) and `^` (the angle from +X, deg, counter-clockwise),
/// token index and value.
#[derive(Default)]
struct PolarWords {
    radius: Option<(usize, Option<f64>)>,
    angle: Option<(usize, Option<f64>)>,
}

impl PolarWords {
    fn read(
        &mut self,
        interp: &Interpreter,
        ti: usize,
        w: &crate::nc::Word,
        skip: &mut Option<Skip>,
    ) {
        let radius = w.addr.as_letter() == Some(b'@');
        let v = match w.value {
            Value::Num(v) => {
                let unit = if radius { interp.units.mm() } else { 1.0 };
                if v.is_finite() && (v * unit).abs() <= crate::limits::MAX_NC_VALUE {
                    Some(v)
                } else {
                    skip.get_or_insert(Skip::OutOfRange(if radius { b'@' } else { b'^' }));
                    None
                }
            }
            _ => {
                skip.get_or_insert(Skip::Expression);
                None
            }
        };
        if radius {
            self.radius = Some((ti, v));
        } else {
            self.angle = Some((ti, v));
        }
    }

    fn any(&self) -> bool {
        self.radius.is_some() || self.angle.is_some()
    }

    fn words(&self, incremental: bool) -> super::Polar {
        super::Polar {
            radius: self.radius.map(|(ti, _)| (ti, incremental)),
            angle: self.angle.map(|(ti, _)| (ti, incremental)),
        }
    }
}

/// Where LinuxCNC's polar words put X and Y, from `start` (program frame),
/// as its interpreter computes them (`find_ends`, and the XY cycles):
/// absolute, `@` and `^` are the point's distance and angle from the
/// origin, the one left out the start's; incremental (G91), `@` adds to
/// the start's distance along its direction, then `^` turns the point
/// about the origin. From the origin a direction is missing: LinuxCNC
/// refuses the block, except a cycle's in G90 (`origin_ok`), which takes
/// the angle of zero.
pub(crate) fn linuxcnc_polar(
    start: [Option<f64>; 2],
    radius: Option<Option<f64>>,
    angle: Option<Option<f64>>,
    incremental: bool,
    origin_ok: bool,
) -> Result<[f64; 2], Skip> {
    let value = |w: Option<Option<f64>>| match w {
        Some(Some(v)) => Ok(Some(v)),
        Some(None) => Err(Skip::Expression),
        None => Ok(None),
    };
    let (r, a) = (value(radius)?, value(angle)?);
    if let (false, Some(r), Some(a)) = (incremental, r, a) {
        let (s, c) = a.to_radians().sin_cos();
        return Ok([r * c, r * s]);
    }
    let (Some(mut x), Some(mut y)) = (start[0], start[1]) else {
        return Err(Skip::PositionUnknown(if start[0].is_none() {
            b'X'
        } else {
            b'Y'
        }));
    };
    const AT_ORIGIN: &str = "a polar word (@, ^) without the other at the origin, where LinuxCNC has no direction and refuses the block";
    let at_origin = |x: f64, y: f64| x == 0.0 && y == 0.0 && !origin_ok;
    if let Some(r) = r {
        if at_origin(x, y) {
            return Err(Skip::Element(ReasonKind::Unsaid, AT_ORIGIN));
        }
        let t = y.atan2(x);
        let r = if incremental { x.hypot(y) + r } else { r };
        (x, y) = (r * t.cos(), r * t.sin());
    }
    if let Some(a) = a {
        if at_origin(x, y) {
            return Err(Skip::Element(ReasonKind::Unsaid, AT_ORIGIN));
        }
        let t = if incremental {
            y.atan2(x) + a.to_radians()
        } else {
            a.to_radians()
        };
        let r = x.hypot(y);
        (x, y) = (r * t.cos(), r * t.sin());
    }
    Ok([x, y])
}

impl Interpreter {
    /// The end point in X and Y of a block with LinuxCNC polar words; why
    /// it has none (LinuxCNC refuses them with X or Y, outside G17).
    fn polar_end(
        &self,
        mv: &Move,
        polar: &PolarWords,
        incremental: bool,
        move_block: bool,
    ) -> Result<[f64; 2], Skip> {
        if mv.words[0].is_some() || mv.words[1].is_some() {
            return Err(Skip::Element(
                ReasonKind::Unsaid,
                "X or Y with a polar word (@, ^), which LinuxCNC refuses",
            ));
        }
        if self.plane != ArcPlane::Xy {
            return Err(Skip::Element(
                ReasonKind::Unsaid,
                "a polar word (@, ^) outside the XY plane (G17), which LinuxCNC refuses",
            ));
        }
        linuxcnc_polar(
            [mv.start[0], mv.start[1]],
            polar.radius.map(|x| x.1),
            polar.angle.map(|x| x.1),
            incremental,
            !move_block,
        )
    }
}

/// Byte offset of the block's G word with this code (x 10), or of the
/// statement.
fn g_offset(block: &Block, seg: &Segment, g: u32) -> usize {
    block
        .words(seg)
        .find(|(_, w)| {
            w.addr.as_letter() == Some(b'G')
                && matches!(w.value, Value::Num(v) if g_code(v) == Some(g))
        })
        .map_or(
            block.tokens[seg.body as usize].span.start as usize,
            |(ti, _)| block.tokens[ti].span.start as usize,
        )
}
