//! HEIDENHAIN Klartext semantics: path blocks (`L`, `C` around the pole
//! `CC`, `CR`, polar `LP`/`CP`, the corners `RND`/`CHF` cut between two
//! lines, the tangential circle `CT`, the approach and departure
//! `APPR LT|LN|CT|PLT|PLN|PCT`/`DEP LT|LN|CT`), M functions in any block (M128/M129 TCPM, M91/M92 machine
//! coordinates), `BEGIN PGM ... MM|INCH`, the cycles that shift, rotate,
//! mirror, scale or tilt the coordinate system (7, 8, 10, 11/26, 19, 247),
//! the drilling cycles a `CYCL CALL POS` runs as holes, PLANE and FUNCTION
//! TCPM, touch probe cycles and program control.

use super::ReasonKind;
use super::approach::Leg;
use super::{
    AXES, Arc, ArcPlane, Event, Interpreter, Move, MoveKind, Skip, Tcp, Units, arc_runs,
    center_from_radius,
};
use crate::nc::{Addr, Block, HhKind, Segment, Stmt, TokenKind, Value, Word};

impl Interpreter {
    /// One Klartext block.
    pub(super) fn heidenhain(&mut self, block: &Block, seg: &Segment) -> Event {
        let Stmt::Hh(kind) = seg.stmt else {
            return Event::None;
        };
        // M functions may appear in any block.
        let mut m91 = false;
        let mut cycle_call = false;
        for (ti, w) in block.words(seg) {
            if w.addr == Addr::letter(b'M')
                && let Value::Num(v) = w.value
            {
                let m = v.round() as u32;
                match m {
                    128 => self.set_tcp(Tcp::Axes),
                    129 => self.set_tcp(Tcp::Off),
                    91 | 92 => m91 = true,
                    114 => self.transformed = Some("M114 (tool length along the tilted axes)"),
                    115 => self.cancel("M114 (tool length along the tilted axes)"),
                    144 => {
                        self.transformed = Some("M144 (kinematics at the actual/nominal positions)")
                    }
                    145 => self.cancel("M144 (kinematics at the actual/nominal positions)"),
                    // Retract along the tool axis: wherever that ends.
                    140 => self.forget(),
                    // The cycle called here ends at its clearance height.
                    // M89 calls it after every positioning block from here
                    // (modal) until M99 or a CYCL CALL (TNC 306/TNC 406
                    // technical manual, "M-function M89"; there a machine
                    // parameter, MP7440 bit 1, makes M89 the modal call).
                    89 => {
                        cycle_call = true;
                        self.hh_modal_call = true;
                    }
                    99 => {
                        cycle_call = true;
                        self.hh_modal_call = false;
                    }
                    _ => {}
                }
                self.m_function(m, block.tokens[ti].span.start as usize, block.line);
            }
        }
        if matches!(kind, HhKind::Comment | HhKind::Structure) {
            return Event::None;
        }
        let cycle_call = cycle_call || (self.hh_modal_call && kind == HhKind::L);
        let line_before = self.hh_line_before.take();
        let pending = self.hh_corner.take();
        let tangent = self.hh_tangent.take();
        let approach = self.hh_approach.take();
        let ev = if kind == HhKind::Ct {
            self.hh_tangential(block, seg, m91, tangent)
        } else if matches!(kind, HhKind::Appr | HhKind::Dep) {
            self.hh_appr_dep(block, seg, kind, m91, tangent)
        } else {
            self.hh_statement(block, seg, kind, m91, cycle_call, line_before)
        };
        let ev = match pending {
            Some(c) => self.after_corner(c, kind, ev),
            None => ev,
        };
        let ev = match approach {
            Some(a) => self.after_approach(a, kind, ev),
            None => ev,
        };
        // The direction a CT after this statement starts in: a statement
        // that moves nothing and sets no other element (a pole, M
        // functions) keeps it.
        self.hh_tangent = match &ev {
            Event::None if matches!(kind, HhKind::Cc | HhKind::M) => tangent,
            Event::Move(mv)
                if matches!(
                    kind,
                    HhKind::L | HhKind::Lp | HhKind::C | HhKind::Cr | HhKind::Cp | HhKind::Ct
                ) =>
            {
                end_direction(mv)
            }
            _ => None,
        };
        if let Event::Move(mv) = &ev
            && kind == HhKind::L
            && mv.kind == MoveKind::Linear
        {
            self.hh_line_before = self.plane_point(&mv.start).zip(self.plane_point(&mv.end));
        }
        ev
    }

    /// The axes a move is followed in, as an array (an axis the machine
    /// does not have as 0), if all of them are known.
    fn plane_point(&self, p: &[Option<f64>; 6]) -> Option<[f64; 6]> {
        let mut out = [0.0; 6];
        for i in [0, 1, 2, self.cfg.tilt, 5] {
            out[i] = p[i]?;
        }
        Some(out)
    }

    /// `APPR ...` / `DEP ...` (read: TNC 640 user's manual, DIN/ISO
    /// programming 1/2015 p. 213, "Important positions for approach and
    /// departure"; TNC7 basic user's manual 81762x-18, "Approach function
    /// APPR LT" ... "Departure function DEP LCT"; TNC7 user's manual
    /// 81762x-16, "Approach functions APPR CT and APPR PCT"; TNC 426
    /// pilot p. 13: "DEP blocks set the radius compensation to 0"): the
    /// control moves from where the tool is through an auxiliary point it
    /// computes from the block and from the first (last) contour element.
    /// `APPR LT|LN|CT` and `DEP LT|LN|CT` are followed
    /// ([`super::approach`]): the `APPR` is a move to its first contour
    /// point PA whose path the element after it completes, the `DEP` one
    /// `LEN` on along the element before (LT), square to it on the tool's
    /// side (LN), or round the arc tangent to it (CT; its move is that
    /// arc). LN and CT need RL/RR, which gives the side and the turning
    /// direction: with R0 there is none. Under RL/RR this is the
    /// programmed contour's path, as for every other element: the control
    /// offsets the corrected contour by the tool radius, which fivecal
    /// does not model. The others are kept, with the reason.
    fn hh_appr_dep(
        &mut self,
        block: &Block,
        seg: &Segment,
        kind: HhKind,
        m91: bool,
        tangent: Option<[f64; 2]>,
    ) -> Event {
        let dep = kind == HhKind::Dep;
        let path = block
            .seg_tokens(seg)
            .iter()
            .find(|t| t.kind == TokenKind::Keyword)
            .map(|t| {
                let b = block.bytes(t.span);
                let b = &b[if dep { 3 } else { 4 }.min(b.len())..];
                String::from_utf8_lossy(b).trim().to_ascii_uppercase()
            })
            .unwrap_or_default();
        let side_before = self.radius_comp;
        let (mut mv, mut skip) = self.hh_move(block, seg, MoveKind::Linear);
        // APPR PLT, PLN, PCT: the first contour point in polar coordinates
        // around the pole CC, read as an LP's end point (TNC7 user's
        // manual 81762x-16, "Approach functions APPR LT and APPR PLT",
        // "... APPR LN and APPR PLN", "... APPR CT and APPR PCT": the same
        // path with a pole defined first), so that it is corrected in its
        // own polar words as an LP is.
        let polar = !dep && matches!(path.as_str(), "PLT" | "PLN" | "PCT");
        let mut polar_why = Ok(());
        if polar {
            let (radius, angle, _) = read_polar(block, seg, &mut skip);
            let (_, end) = polar_end(self.pole, &mv.start, radius, angle, false);
            polar_why = if mv.words[0].is_some() || mv.words[1].is_some() {
                Err(
                    "X or Y in a polar approach (its first contour point is given by PR and PA around the pole CC)",
                )
            } else if self.pole.is_none() {
                Err("a polar approach without a known pole (CC)")
            } else {
                Ok(())
            };
            mv.end[0] = end[0];
            mv.end[1] = end[1];
            mv.polar = Some(super::Polar {
                radius: radius.map(|x| (x.0, x.2)),
                angle: angle.map(|x| (x.0, x.2)),
            });
        }
        // The side an LN's point lies on: the contour's before a DEP, the
        // one the APPR sets for the contour after it.
        let side = if dep { side_before } else { self.radius_comp };
        if dep {
            self.radius_comp = None;
        }
        let (mut len, mut radius, mut cca) = (None, None, None);
        let mm = self.units.mm();
        for (_, w) in block.words(seg) {
            let slot = if w.addr == Addr::new("LEN") {
                &mut len
            } else if w.addr == Addr::letter(b'R') {
                &mut radius
            } else if w.addr == Addr::new("CCA") {
                &mut cca
            } else {
                continue;
            };
            // An incremental centre angle (ICCA): the manuals read give
            // the entry but not what it counts from.
            let inc_cca = w.incremental && w.addr == Addr::new("CCA");
            *slot = Some(match w.value {
                Value::Num(v)
                    if !inc_cca && v.is_finite() && v.abs() * mm <= crate::limits::MAX_NC_VALUE =>
                {
                    Ok(v)
                }
                _ => Err(()),
            });
        }
        let plane_word = |i: usize| mv.words[i].is_some();
        let path = if polar { &path[1..] } else { path.as_str() };
        let why = match path {
            "LT" => Ok(Leg::Tangent),
            "LN" => side.map(Leg::Normal).ok_or(
                "a perpendicular approach or departure (LN) without radius compensation: the control puts its auxiliary or end point on the side of the contour RL/RR picks (TNC 640 user's manual, TNC7 basic user's manual 81762x-18), and with R0 none is picked; the manuals read do not say what the control does then",
            ),
            "CT" => match (side, radius, cca) {
                (None, ..) if dep => Err(
                    "a circular departure (DEP CT) after a contour without radius compensation: the arc turns the way RL/RR and the sign of R say (TNC7 basic user's manual 81762x-18, \"Departure function DEP CT\"), and with R0 there is no RL/RR; the manuals read do not say what the control does then",
                ),
                (None, ..) => Err(
                    "a circular approach (APPR CT) with R0: the TNC7 stops with an error message (TNC7 user's manual 81762x-16, \"Approach functions APPR CT and APPR PCT\")",
                ),
                (Some(side), Some(Ok(r)), Some(Ok(a)))
                    if r != 0.0 && a > 0.0 && a <= 360.0 && r.abs() * mm * a.to_radians() >= 1e-3 =>
                {
                    Ok(Leg::Arc {
                        radius: r.abs(),
                        cca: a,
                        cw: super::approach::clockwise(side, r),
                    })
                }
                _ => Err(
                    "its R or CCA is not a number, or is an incremental ICCA (the manuals read do not say what it counts from), or gives no arc (R not zero, CCA above 0 and at most 360 deg, TNC7 user's manual 81762x-16)",
                ),
            },
            "LCT" | "PLCT" => Err(
                "an approach or departure on a line and a tangential arc (LCT): the TNC7 manuals (user's manual 81762x-16, basic user's manual 81762x-18, \"APPR LCT\", \"DEP LCT\") fix the arc by its radius R and its tangency to the contour and to the line, but not which way it turns, and an arc on either side of the contour element fits; fivecal does not guess",
            ),
            _ => Err("no path type fivecal knows (LT, LN, CT, LCT, PLT, PLN, PCT, PLCT)"),
        };
        let why = why.and_then(|leg| {
            let len_ok = matches!(len, Some(Ok(v)) if v > 0.0);
            if let Err(why) = polar_why {
                Err(why)
            } else if self.plane != ArcPlane::Xy {
                Err("a working plane other than XY")
            } else if !matches!(leg, Leg::Arc { .. }) && !len_ok {
                Err("its LEN is not a positive number")
            } else if dep && (plane_word(0) || plane_word(1)) {
                Err(
                    "X or Y in a DEP LT, LN or CT (its end point follows from the last contour point and the last contour element)",
                )
            } else if !super::approach::flat(&mv.start, &mv.end, self.units.mm()) {
                Err(
                    "it moves the tool axis or a rotary axis: the TNC 640 manual has the control reach the auxiliary point in the working plane and then the tool-axis position, the TNC7 manual all three axes at once (APPR LCT, DEP LCT); which this control does is not known",
                )
            } else {
                Ok(leg)
            }
        });
        let len = match (why, len) {
            (Ok(Leg::Arc { .. }), _) => 0.0,
            (_, Some(Ok(v))) => v,
            _ => 0.0,
        };
        // Where the tool ends: a DEP LT, LN or CT where its leg from the
        // last contour point ends, the others as their words say (a DEP
        // LT, LN or CT names no end point in the plane).
        let pe = [mv.start[0], mv.start[1]];
        if dep {
            let end = match (why, pe, tangent) {
                (Ok(leg), [Some(x), Some(y)], Some(t)) => {
                    let p = super::approach::departure_end([x, y], t, len, leg);
                    // A DEP CT's move is its arc, which the simulator
                    // runs and the compensator checks as such.
                    if let (Some(center), Leg::Arc { cw, .. }) =
                        (super::approach::arc_center([x, y], t, leg), leg)
                    {
                        mv.kind = MoveKind::Arc(xy_arc(center, cw, 0));
                    }
                    [Some(p[0]), Some(p[1])]
                }
                _ => [None, None],
            };
            for (i, e) in end.into_iter().enumerate() {
                if !plane_word(i) {
                    mv.end[i] = e;
                }
            }
        } else if why.is_err() {
            for i in 0..2 {
                if !plane_word(i) {
                    mv.end[i] = None;
                }
            }
        }
        self.pos = mv.end;
        if m91 {
            return Event::Quiet;
        }
        let leg = match why {
            Ok(leg) => leg,
            Err(why) => {
                return Event::Skip(match skip {
                    Some(s @ (Skip::Expression | Skip::UnknownWord)) => s,
                    _ => Skip::ApproachDeparture(why),
                });
            }
        };
        if let Some(s) = skip {
            return Event::Skip(s);
        }
        if dep && tangent.is_none() {
            return Event::Skip(Skip::ApproachDeparture(
                "the element before it is not a line or circle in the XY plane that fivecal follows (the departure continues in the direction that element ends in)",
            ));
        }
        let (from, at) = match plane_ends(&mv) {
            Ok(_) => (
                super::coordinates::known(&mv.start),
                super::coordinates::known(&mv.end),
            ),
            Err(s) => return Event::Skip(s),
        };
        if let Some(s) = self.frame_skip() {
            return Event::Skip(s);
        }
        if dep {
            mv.appr_dep = Some(super::approach::Tangential::Departure { len, leg });
        } else {
            mv.appr_dep = Some(super::approach::Tangential::Approach { len, leg });
            self.hh_approach = Some(PendingApproach {
                line: block.line,
                from,
                at,
                len,
                leg,
            });
        }
        Event::Move(mv)
    }

    /// The statement after an `APPR LT`/`LN`/`CT`: the first contour element, whose
    /// direction at its start places the auxiliary point; a statement
    /// that moves nothing and sets no element (a pole, M functions) keeps
    /// it waiting. Anything else leaves the approach's path unknown, which
    /// whoever follows the moves reports.
    fn after_approach(&mut self, a: PendingApproach, kind: HhKind, ev: Event) -> Event {
        let mut mv = match ev {
            // A contour element: not another APPR, a DEP or a cycle call.
            Event::Move(mv)
                if matches!(
                    kind,
                    HhKind::L | HhKind::Lp | HhKind::C | HhKind::Cr | HhKind::Cp
                ) =>
            {
                mv
            }
            Event::None if matches!(kind, HhKind::Cc | HhKind::M) => {
                self.hh_approach = Some(a);
                return ev;
            }
            ev => return ev,
        };
        let starts_at_pa = matches!((mv.start[0], mv.start[1]), (Some(x), Some(y)) if x == a.at[0] && y == a.at[1]);
        let path = if !starts_at_pa {
            Err("the first contour element does not start at its end point")
        } else {
            super::approach::start_direction(&mv, self.units.mm())
        };
        let arc = path
            .ok()
            .and_then(|d| super::approach::arc_center([a.at[0], a.at[1]], d, a.leg));
        let path = path.map(|d| {
            let ph = super::approach::approach_aux(&a.at, d, a.len, a.leg);
            [a.from, ph, a.at]
        });
        mv.approach = Some(Box::new(super::approach::Approach {
            line: a.line,
            len: a.len,
            leg: a.leg,
            path,
            arc,
        }));
        Event::Move(mv)
    }

    /// `RND R..` / `CHF ..`: the corner of the line before, to be cut
    /// when the line after it comes.
    fn read_corner(
        &self,
        block: &Block,
        seg: &Segment,
        kind: HhKind,
        line_before: Option<([f64; 6], [f64; 6])>,
    ) -> PendingCorner {
        let mut size = None;
        for t in block.seg_tokens(seg) {
            match t.kind {
                TokenKind::Word(w) if kind == HhKind::Rnd && w.addr == Addr::letter(b'R') => {
                    size = Some(w.value);
                }
                TokenKind::Text if kind == HhKind::Chf && size.is_none() => {
                    let b = block.bytes(t.span);
                    let n = crate::nc::lexeme::lex_len(b);
                    size = Some(if n > 0 && n == b.len() {
                        Value::Num(crate::nc::lexeme::read(b).value)
                    } else {
                        Value::Expr
                    });
                }
                _ => {}
            }
        }
        let geo = match (size, line_before) {
            _ if self.plane != ArcPlane::Xy => Err("a working plane other than XY"),
            (Some(Value::Num(v)), Some((from, at)))
                if v.is_finite() && v != 0.0 && v.abs() <= crate::limits::MAX_NC_VALUE =>
            {
                let k = if kind == HhKind::Rnd {
                    super::corner::CornerKind::Round(v)
                } else {
                    super::corner::CornerKind::Chamfer(v)
                };
                Ok((k, from, at))
            }
            (_, None) => {
                Err("the element before it is not a straight line (L) whose ends are known")
            }
            _ => Err("its radius or length is not a number"),
        };
        PendingCorner {
            line: block.line,
            geo,
        }
    }

    /// The statement after a `RND`/`CHF`: a straight line carries the
    /// corner; another move is left as written (the controller cuts the
    /// corner in a way fivecal does not follow); a statement that does not
    /// move keeps it waiting.
    fn after_corner(&mut self, c: PendingCorner, kind: HhKind, ev: Event) -> Event {
        let mut mv = match ev {
            Event::Move(mv) => mv,
            Event::None if !matches!(kind, HhKind::Rnd | HhKind::Chf) => {
                self.hh_corner = Some(c);
                return ev;
            }
            ev => return ev,
        };
        let why = match c.geo {
            Err(why) => why,
            Ok(_) if kind != HhKind::L || mv.kind != MoveKind::Linear => {
                "the element after it is not a straight line (L)"
            }
            Ok((k, from, at)) => match (self.plane_point(&mv.start), self.plane_point(&mv.end)) {
                (Some(s), Some(e)) if s == at => {
                    match super::corner::corner_path(&from, &at, &e, k, self.units.mm()) {
                        Ok(_) => {
                            mv.corner = Some(Box::new(super::corner::Corner {
                                line: c.line,
                                kind: k,
                                from,
                                at,
                            }));
                            return Event::Move(mv);
                        }
                        Err(why) => why,
                    }
                }
                _ => "the position after it is not known",
            },
        };
        Event::Skip(Skip::AfterCorner(c.line, why))
    }

    /// One statement of a block, with the M functions it has read.
    fn hh_statement(
        &mut self,
        block: &Block,
        seg: &Segment,
        kind: HhKind,
        m91: bool,
        cycle_call: bool,
        line_before: Option<([f64; 6], [f64; 6])>,
    ) -> Event {
        let text_has = |needle: &str| {
            block.seg_tokens(seg).iter().any(|t| {
                matches!(t.kind, TokenKind::Text | TokenKind::Keyword)
                    && block.bytes(t.span).eq_ignore_ascii_case(needle.as_bytes())
            })
        };
        match kind {
            HhKind::BeginPgm => {
                self.state_unknown = None;
                if text_has("INCH") {
                    self.units = Units::Inch;
                } else {
                    self.units = Units::Mm;
                }
                Event::None
            }
            HhKind::L => {
                let before = self.pos[2];
                let ev = self.hh_line(block, seg, m91);
                if cycle_call {
                    self.after_cycle(before);
                    if matches!(ev, Event::Move(_)) && self.hh_cycle.is_some_and(|c| c.is_hole()) {
                        let at = block.tokens[seg.body as usize].span.start as usize;
                        self.note(
                            at,
                            "M99/M89: the cycle called here drills to the depth its CYCL DEF gives (Q203 + Q201), which no word of this block moves: the hole is left as the machine drills it (a hole called by CYCL CALL POS X.. Y.. Z.. is corrected)",
                        );
                    }
                }
                ev
            }
            HhKind::C | HhKind::Cr => self.hh_arc(block, seg, kind, m91),
            HhKind::Cc => {
                let mut p = [self.pos[0], self.pos[1]];
                let mut expr = false;
                let mut any = false;
                for (_, w) in block.words(seg) {
                    let Some(i) = self.axis_index(w.addr).filter(|&i| i < 2) else {
                        continue;
                    };
                    any = true;
                    match self.axis_value(&w) {
                        Ok(v) => {
                            p[i] = if w.incremental {
                                self.pos[i].map(|q| q + v)
                            } else {
                                Some(v)
                            };
                        }
                        Err(_) => expr = true,
                    }
                }
                let _ = any;
                self.pole = match (p[0], p[1], expr) {
                    (Some(x), Some(y), false) => Some([x, y]),
                    _ => None,
                };
                Event::None
            }
            HhKind::Lp | HhKind::Cp => self.hh_polar(block, seg, kind, m91),
            HhKind::Appr | HhKind::Dep => unreachable!("APPR/DEP are read by hh_appr_dep"),
            HhKind::Ln => {
                // A vector line: not rewritten. Follow the Cartesian words.
                self.track_words(block, seg);
                Event::Skip(Skip::Element(
                    ReasonKind::NotImplemented,
                    "vector line (LN)",
                ))
            }
            // The controller cuts the corner between the line before and
            // the line after: the line after carries it.
            HhKind::Rnd | HhKind::Chf => {
                self.hh_corner = Some(self.read_corner(block, seg, kind, line_before));
                Event::None
            }
            HhKind::M => Event::None,
            HhKind::CyclDef { number, sub } => {
                self.hh_cycle(block, seg, number, sub);
                Event::None
            }
            HhKind::Plane | HhKind::PlaneReset => {
                self.hh_plane(block, seg);
                Event::None
            }
            HhKind::FunctionTcpm => {
                let spatial = text_has("SPAT");
                self.set_tcp(if spatial { Tcp::Spatial } else { Tcp::Axes });
                Event::None
            }
            HhKind::FunctionResetTcpm => {
                self.set_tcp(Tcp::Off);
                Event::None
            }
            HhKind::TchProbe => {
                // Touch probe cycles 0 (reference plane) and 1 (polar
                // datum plane) move the linear axes only; the others may
                // turn a rotary axis (403, 405) or move anywhere.
                if matches!(tch_probe_number(&block.text), Some(0 | 1)) {
                    self.pos[0] = None;
                    self.pos[1] = None;
                    self.pos[2] = None;
                } else {
                    self.forget();
                }
                Event::Quiet
            }
            HhKind::ToolCall => {
                // TOOL CALL with a tool: the machine builder's tool change
                // sequence runs, unless that tool is already in the
                // spindle; without one (`TOOL CALL S2000`, `TOOL CALL Z
                // S..`) only the spindle data change.
                let code = super::code_of(self.cfg.settings.dialect, &block.text);
                match tool_call_tool(&code) {
                    CalledTool::None => {}
                    CalledTool::Named(t) if self.hh_tool.as_deref() == Some(t.as_str()) => {}
                    CalledTool::Named(t) => {
                        self.tool_change(block.line);
                        self.hh_tool = Some(t);
                    }
                    CalledTool::Parameter => {
                        self.tool_change(block.line);
                        self.hh_tool = None;
                    }
                }
                Event::None
            }
            HhKind::CyclCall => {
                // A CYCL CALL ends a modal M89 call as M99 does (TNC 306/
                // TNC 406 technical manual, "M-function M89").
                self.hh_modal_call = false;
                let pos = block
                    .words(seg)
                    .any(|(_, w)| self.axis_index(w.addr).is_some());
                if pos {
                    self.hh_cycle_call(block, seg)
                } else {
                    // CYCL CALL: the cycle runs where the tool is and
                    // leaves it at a clearance of its own.
                    self.after_cycle(self.pos[2]);
                    Event::None
                }
            }
            HhKind::Lbl | HhKind::CallLbl | HhKind::CallPgm | HhKind::Stop => {
                self.forget();
                Event::None
            }
            HhKind::Fn(9) | HhKind::Fn(10) | HhKind::Fn(11) | HhKind::Fn(12) => {
                self.forget();
                Event::None
            }
            HhKind::Fn(17) => {
                // A SYSWRITE may set a datum, a preset or tool data: where
                // the next numbers put the tool is not known from here.
                self.forget();
                self.note(
                    block.tokens[seg.body as usize].span.start as usize,
                    "FN 17 SYSWRITE: the program writes controller data fivecal does not model",
                );
                Event::None
            }
            _ => Event::None,
        }
    }

    /// Where the machining cycle defined last leaves the tool once a
    /// `CYCL CALL` or `M99`/`M89` ran it (`z_before`: the tool-axis
    /// position it started from). The machining cycles move the linear
    /// axes of the working plane only, never a rotary axis. A drilling
    /// cycle ends on the hole's axis (X and Y as before) at the height
    /// [`CycleDef::end_height`] gives; any other leaves X, Y and Z where
    /// its own parameters put them.
    fn after_cycle(&mut self, z_before: Option<f64>) {
        let Some(cycle) = self.hh_cycle else {
            // No cycle defined: the control's error, nothing moves.
            return;
        };
        self.pole = None;
        match cycle.end_height(z_before) {
            Some(z) if self.plane == ArcPlane::Xy => self.pos[2] = Some(z),
            _ if cycle.ends_on_axis() && self.plane == ArcPlane::Xy => self.pos[2] = None,
            _ => self.pos[..3].fill(None),
        }
    }

    /// `CYCL CALL POS X.. Y.. Z..`: the cycle defined last runs at X Y,
    /// its tool-axis word a datum its own surface `Q203` counts from. A
    /// drilling cycle is one hole: the move ends at its bottom
    /// (`Z + Q203 + Q201`), reached along the tool axis from the set-up
    /// clearance (`Z + Q203 + Q200`); the cycle moves the linear axes
    /// only and leaves the tool at a clearance of its own.
    fn hh_cycle_call(&mut self, block: &Block, seg: &Segment) -> Event {
        let (mut mv, mut skip) = self.hh_move(block, seg, MoveKind::Rapid);
        self.pos = mv.end;
        self.pos[2] = None;
        if mv.words[3..].iter().any(Option::is_some) {
            skip.get_or_insert(Skip::CycleCall(
                ReasonKind::NotImplemented,
                "a rotary axis word in the cycle call",
            ));
        }
        if let Some(s) = skip {
            return Event::Skip(s);
        }
        let Some(cycle) = self.hh_cycle else {
            return Event::Skip(Skip::CycleCall(
                ReasonKind::Unsaid,
                "no cycle is defined before it",
            ));
        };
        if !cycle.is_hole() {
            return Event::Skip(Skip::CycleCall(
                ReasonKind::NotImplemented,
                "a cycle other than the drilling cycles 200-203, 205-207, 209 and 241 (its moves are not one hole)",
            ));
        }
        let (Some(q200), Some(q201), Some(q203)) = (cycle.clearance, cycle.depth, cycle.surface)
        else {
            return Event::Skip(Skip::CycleCall(
                ReasonKind::Unsaid,
                "the cycle's Q200, Q201 or Q203 is not written as a number in its CYCL DEF",
            ));
        };
        if q201 == 0.0 {
            return Event::Skip(Skip::CycleCall(
                ReasonKind::NotImplemented,
                "the cycle's depth Q201 is 0 (no hole)",
            ));
        }
        if self.plane != ArcPlane::Xy {
            return Event::Skip(Skip::CycleCall(
                ReasonKind::NotImplemented,
                "a tool axis other than Z",
            ));
        }
        if mv.words[..3].iter().any(Option::is_none) {
            // The control asks for all three; fivecal does not guess.
            return Event::Skip(Skip::CycleCall(
                ReasonKind::Unsaid,
                "the call does not name X, Y and Z",
            ));
        }
        let Some(z) = mv.end[2] else {
            return Event::Skip(Skip::PositionUnknown(b'Z'));
        };
        mv.end[2] = Some(z + q203 + q201);
        mv.drill = Some(super::Drill {
            axis: 2,
            r_level: z + q203 + q200,
            to_initial: false,
            call_offset: Some(q203 + q201),
        });
        if let Some(s) = self.frame_skip() {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }

    fn hh_cycle(&mut self, block: &Block, seg: &Segment, number: u32, sub: Option<u32>) {
        if !DEF_ACTIVE.contains(&number) {
            // A machining cycle: what CYCL CALL and M99 run from here.
            self.hh_cycle = Some(CycleDef::read(block, seg, number));
            return;
        }
        let sub = sub.unwrap_or(0);
        let words: Vec<Word> = block.words(seg).map(|(_, w)| w).collect();
        let hash = block
            .seg_tokens(seg)
            .iter()
            .any(|t| t.kind == TokenKind::Text && block.bytes(t.span).starts_with(b"#"));
        match (number, sub) {
            (7, s) if s >= 1 && self.tilted => {
                // A shift along the tilted axes.
                let at = block.tokens[seg.body as usize].span.start as usize;
                self.plane_unmodelled(block.line, at, "a datum shift inside the tilted plane");
            }
            (7, s) if s >= 1 => {
                let known_before = self.shift_known;
                if hash {
                    self.shift_known = false;
                }
                let before = self.shift;
                let mut expr = false;
                let mut absolute = [false; 3];
                for w in &words {
                    if let Some(i) = self.axis_index(w.addr).filter(|&i| i < 3) {
                        match w.value {
                            // An incremental value counts from the shift
                            // last in force, an absolute one from the
                            // preset (TNC 640 user's manual, cycle 7
                            // DATUM SHIFT).
                            Value::Num(v) if w.incremental => self.shift[i] += v,
                            Value::Num(v) => {
                                self.shift[i] = v;
                                absolute[i] = true;
                            }
                            _ => {
                                expr = true;
                                self.shift_known = false;
                            }
                        }
                    }
                }
                // An incremental value the words do not carry (`IX+5`
                // read otherwise) would be taken as absolute: unknown.
                let code = super::code_of(self.cfg.settings.dialect, &block.text);
                if code
                    .windows(2)
                    .any(|w| w[0] == b'I' && matches!(w[1], b'X' | b'Y' | b'Z'))
                    && !words.iter().any(|w| w.incremental)
                {
                    expr = true;
                    self.shift_known = false;
                }
                // Values written with a space between letter and sign
                // (`X + 0`) come as text: read them from the raw block.
                if words.is_empty() && !hash {
                    let txt = String::from_utf8_lossy(&block.text).to_string();
                    let body = txt.split("7.").nth(1).unwrap_or("");
                    let compact: String = body.chars().filter(|c| !c.is_whitespace()).collect();
                    for (i, l) in ['X', 'Y', 'Z'].iter().enumerate() {
                        if let Some(p) = compact.find(*l) {
                            let rest = &compact[p + 1..];
                            let n = crate::nc::lexeme::lex_len(rest.as_bytes());
                            if n > 0 {
                                self.shift[i] =
                                    crate::nc::lexeme::read(&rest.as_bytes()[..n]).value;
                            }
                        }
                    }
                }
                // The tool stays where it is: its coordinates are the old
                // ones minus what the datum moved by. A shift from a table
                // or a parameter is not known, nor then where the tool is.
                if !hash && !expr && absolute == [true; 3] {
                    // All three from the preset: known again.
                    self.shift_known = true;
                }
                if hash || expr || !known_before {
                    self.pos[..3].fill(None);
                } else {
                    let moved: [f64; 3] = std::array::from_fn(|i| self.shift[i] - before[i]);
                    for (p, d) in self.pos.iter_mut().zip(moved) {
                        *p = p.map(|v| v - d);
                    }
                }
                self.pole = None;
                for w in &words {
                    if let Some(i) = self.axis_index(w.addr).filter(|&i| i >= 3) {
                        self.pos[i] = None;
                    }
                }
            }
            (19, s) if s >= 1 => {
                // Spatial angles A, then B, then C about the fixed axes
                // (the common setting of the machine parameter; a machine
                // set to axis angles needs PLANE AXIAL's model). The cycle
                // does not turn the rotary axes: a later block does.
                let at = block.tokens[seg.body as usize].span.start as usize;
                let mut abc = [0.0; 3];
                for w in &words {
                    match (w.addr.as_letter(), w.value) {
                        (Some(l @ (b'A' | b'B' | b'C')), Value::Num(v)) => {
                            abc[(l - b'A') as usize] = v
                        }
                        (Some(b'A' | b'B' | b'C'), _) => {
                            return self.plane_unmodelled(
                                block.line,
                                at,
                                "a parameter in CYCL DEF 19",
                            );
                        }
                        _ => {}
                    }
                }
                if abc == [0.0; 3] {
                    self.set_plane(None);
                } else {
                    let rot = super::plane::spatial(abc[0], abc[1], abc[2]);
                    self.set_plane(Some(super::Tilt::Plane(super::WorkPlane::new(rot))));
                }
            }
            (10, s) if s >= 1 => {
                let rot = words.iter().any(|w| {
                    matches!(w.value, Value::Num(v) if v != 0.0) || w.value == Value::Expr
                });
                self.transformed = rot.then_some("coordinate rotation (CYCL DEF 10)");
            }
            (8, s) if s >= 1 => {
                let any = block.seg_tokens(seg).iter().any(|t| {
                    t.kind == TokenKind::Text && matches!(block.bytes(t.span), b"X" | b"Y" | b"Z")
                });
                self.transformed = any.then_some("mirror image (CYCL DEF 8)");
            }
            (11, s) | (26, s) if s >= 1 => {
                let unity = words
                    .iter()
                    .all(|w| matches!(w.value, Value::Num(v) if (v - 1.0).abs() < 1e-12));
                self.transformed = (!unity).then_some("scaling (CYCL DEF 11/26)");
            }
            (247, _) => {
                // The rotary positions are machine positions: no preset has
                // a rotary part (each lies on the W origin at rotary zero).
                self.work_offset = 100_000 + 247;
                let rotary = [self.pos[3], self.pos[4], self.pos[5]];
                self.forget();
                self.pos[3..].copy_from_slice(&rotary);
            }
            _ => {}
        }
    }

    /// PLANE ...: the plane, and the rotary positions TURN / MOVE give
    /// (SEQ+ / SEQ- picks the sign of the tilt, else the shortest way
    /// from where the axes are); STAY leaves them where they are.
    fn hh_plane(&mut self, block: &Block, seg: &Segment) {
        let code = String::from_utf8_lossy(&super::code_of(self.cfg.settings.dialect, &block.text))
            .into_owned();
        let at = block.tokens[seg.body as usize].span.start as usize;
        let k = super::plane::klartext(&code);
        self.hh_plane_seq = k.seq;
        let line = block.line;
        match k.plane {
            None => {
                self.set_plane(None);
                if k.turn {
                    // PLANE RESET TURN: the axes go back to their home
                    // positions.
                    self.pos[3..].fill(None);
                }
            }
            Some(Err(why)) => self.plane_unmodelled(line, at, why),
            Some(Ok(def)) => {
                let rot = match (def, self.working_plane) {
                    (super::plane::Definition::Absolute(r), _) => r,
                    (super::plane::Definition::Relative(r), Some(super::Tilt::Plane(w))) => {
                        w.rot * r
                    }
                    // Haas's DWO (an ISO code) never reaches Klartext;
                    // as a plane it is the workpiece's own axes.
                    (
                        super::plane::Definition::Relative(r),
                        None | Some(super::Tilt::Workpiece),
                    ) => r,
                    (super::plane::Definition::Axial(abc), _) => {
                        // The rotary positions themselves: the frame the
                        // machine's axes take there, and TURN / MOVE goes
                        // to exactly them.
                        let t = self.cfg.tilt;
                        return match super::plane::axial(&self.cfg.kin, t, abc) {
                            Ok(rot) => {
                                self.set_plane(Some(super::Tilt::Plane(super::WorkPlane::new(
                                    rot,
                                ))));
                                if k.turn {
                                    self.pos[t] = abc[t - 3];
                                    self.pos[5] = abc[2];
                                }
                            }
                            Err(why) => self.plane_unmodelled(line, at, why),
                        };
                    }
                    (
                        super::plane::Definition::Relative(_),
                        Some(super::Tilt::Unmodelled { .. }),
                    ) => {
                        return self.plane_unmodelled(
                            line,
                            at,
                            "PLANE RELATIV on a plane fivecal does not model",
                        );
                    }
                };
                self.set_plane(Some(super::Tilt::Plane(super::WorkPlane::new(rot))));
                if k.sym {
                    self.note(
                        at,
                        "SYM+/SYM-: a choice of rotary solution fivecal does not model (the moves in the plane are left as written)",
                    );
                    self.pos[3..].fill(None);
                } else if k.turn {
                    let choice = match k.seq {
                        Some(sign) => super::plane::Choice::Sign { sign, strict: true },
                        None => super::plane::Choice::Nearest,
                    };
                    self.position_for_plane(line, at, choice);
                }
            }
        }
    }

    /// `A+Q120`, `B+Q121`, `C+Q122` in a tilted plane: the rotary
    /// positions the control computed for it and stored there (TNC 640
    /// user's manual, "PLANE: automatic positioning": with STAY the
    /// control only computes the angles, into Q120 to Q122, for a later
    /// block to move to), when they can be known: the solution whose tilt
    /// has the sign SEQ+/SEQ- asks for, else the one nearest the
    /// positions before.
    fn computed_rotary(&self, block: &Block, w: &Word, i: usize) -> Option<f64> {
        let text = block.bytes(w.value_span).to_ascii_uppercase();
        let text = text.strip_prefix(b"+").unwrap_or(&text);
        if w.incremental || text != format!("Q{}", 117 + i).as_bytes() {
            return None;
        }
        let Some(super::Tilt::Plane(plane)) = self.working_plane else {
            return None;
        };
        let t = self.cfg.tilt;
        let (tilt, c) = super::plane::rotary_for(
            &self.cfg.nominal,
            &plane.normal(),
            (self.pos[t], self.pos[5]),
            match self.hh_plane_seq {
                Some(sign) => super::plane::Choice::Sign { sign, strict: true },
                None => super::plane::Choice::Nearest,
            },
        )
        .ok()?;
        match i {
            5 => Some(c),
            _ if i == t => Some(tilt),
            _ => None,
        }
    }

    /// A move of `kind` from the current position to the block's axis
    /// words, with its feed and radius compensation read, and the first
    /// reason it cannot be followed (an unknown word, an axis the machine
    /// lacks, a value not known).
    fn hh_move(&mut self, block: &Block, seg: &Segment, kind: MoveKind) -> (Move, Option<Skip>) {
        let mut mv = Move::new(kind, self.pos, false);
        let mut skip = seg.unknown.map(|_| Skip::UnknownWord);
        for (ti, w) in block.words(seg) {
            if let Some(i) = self.axis_index(w.addr) {
                mv.words[i] = Some(ti);
                mv.incremental[i] = w.incremental;
                if !self.machine_axis(i) {
                    skip.get_or_insert(Skip::UnknownAxis(AXES[i]));
                }
                match self.axis_value(&w) {
                    Ok(v) => {
                        mv.end[i] = if w.incremental {
                            mv.start[i].map(|p| p + v)
                        } else {
                            Some(v)
                        };
                    }
                    Err(Skip::Expression) if self.computed_rotary(block, &w, i).is_some() => {
                        mv.end[i] = self.computed_rotary(block, &w, i);
                    }
                    Err(s) => {
                        mv.end[i] = None;
                        skip.get_or_insert(s);
                    }
                }
            } else if w.addr == Addr::letter(b'F') {
                match w.value {
                    Value::Num(v) => {
                        mv.feed = Some((ti, v));
                        self.feed = Some(v);
                    }
                    // An older TNC's feed field left without an entry
                    // (`L X+12,500 R F M`): the feed as it was.
                    Value::None => {}
                    // A feed from a Q parameter: not known here, and not
                    // needed (Klartext has no inverse-time feed a piece
                    // would need its share of): the block's axis words are
                    // corrected all the same.
                    _ => self.feed = None,
                }
            } else if w.addr == Addr::new("RL") || w.addr == Addr::new("RR") {
                self.radius_comp = Some(if w.addr == Addr::new("RL") {
                    super::approach::Side::Left
                } else {
                    super::approach::Side::Right
                });
            } else if w.addr == Addr::new("R0") {
                self.radius_comp = None;
            } else if matches!(w.addr.as_letter(), Some(b'U' | b'V' | b'W')) {
                skip.get_or_insert(Skip::UnknownAxis(w.addr.as_letter().unwrap()));
            }
        }
        (mv, skip)
    }

    fn hh_line(&mut self, block: &Block, seg: &Segment, m91: bool) -> Event {
        let rapid = block.words(seg).any(|(_, w)| w.addr == Addr::new("FMAX"));
        let kind = if rapid {
            MoveKind::Rapid
        } else {
            MoveKind::Linear
        };
        let (mv, skip) = self.hh_move(block, seg, kind);
        if m91 {
            for i in 0..6 {
                if mv.words[i].is_some() {
                    self.pos[i] = None;
                }
            }
            return if mv.words.iter().any(|w| w.is_some()) {
                Event::Quiet
            } else {
                Event::None
            };
        }
        self.pos = mv.end;
        if mv.words.iter().all(|w| w.is_none()) {
            return Event::None;
        }
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }

    /// `LP PR.. PA..` and `CP PA.. DR..`: a line or circle to a point given
    /// in polar coordinates around the pole `CC`. `IPR`/`IPA` count from
    /// the polar coordinates of the position before the block; a missing
    /// `PR` keeps its radius (for CP always: the circle's radius is the
    /// start's distance from the pole), a missing `PA` its angle. `CP IPA`
    /// turns by that angle, whole turns and all (a helix with `IZ`).
    fn hh_polar(&mut self, block: &Block, seg: &Segment, kind: HhKind, m91: bool) -> Event {
        let circle = kind == HhKind::Cp;
        let rapid = block.words(seg).any(|(_, w)| w.addr == Addr::new("FMAX"));
        let (mut mv, mut skip) = self.hh_move(
            block,
            seg,
            if rapid {
                MoveKind::Rapid
            } else {
                MoveKind::Linear
            },
        );
        let (radius, angle, cw) = read_polar(block, seg, &mut skip);
        let pole = self.pole;
        let (here, end) = polar_end(pole, &mv.start, radius, angle, circle);
        let cartesian = mv.words[0].is_some() || mv.words[1].is_some();
        mv.end[0] = end[0];
        mv.end[1] = end[1];
        self.pos = mv.end;
        if m91 {
            return Event::Quiet;
        }
        if cartesian {
            return Event::Skip(
                skip.unwrap_or(Skip::Element(ReasonKind::Unsaid, "X or Y in a polar block")),
            );
        }
        let Some(p) = pole else {
            return Event::Skip(skip.unwrap_or(Skip::Element(
                ReasonKind::Unsaid,
                "polar element without a known pole (CC)",
            )));
        };
        if self.plane != ArcPlane::Xy {
            return Event::Skip(Skip::Element(
                ReasonKind::NotImplemented,
                "polar element outside the XY plane",
            ));
        }
        mv.polar = Some(super::Polar {
            radius: radius.map(|x| (x.0, x.2)),
            angle: angle.map(|x| (x.0, x.2)),
        });
        if circle {
            let Some((rs, a0)) = here else {
                return Event::Skip(skip.unwrap_or(Skip::PositionUnknown(
                    if mv.start[0].is_none() { b'X' } else { b'Y' },
                )));
            };
            let Some((_, pa, inc)) = angle else {
                return Event::Skip(skip.unwrap_or(Skip::Element(
                    ReasonKind::Unsaid,
                    "polar circle (CP) without PA",
                )));
            };
            // IPA turns by its own sign unless DR says otherwise; the
            // whole turns of a helix are beyond the end angle.
            let sweep = if inc { pa } else { 0.0 };
            let cw = match cw {
                Some(cw) if inc && sweep != 0.0 && cw != (sweep < 0.0) => {
                    return Event::Skip(Skip::Element(
                        ReasonKind::Unsaid,
                        "polar circle whose IPA and DR turn opposite ways",
                    ));
                }
                Some(cw) => cw,
                None => sweep < 0.0,
            };
            if rs * self.units.mm() < 0.00127 || (inc && sweep == 0.0) {
                return Event::Skip(skip.unwrap_or(Skip::Element(
                    ReasonKind::Unsaid,
                    "polar circle of zero radius or zero angle",
                )));
            }
            let turns = if inc {
                ((sweep.abs() / 360.0 - 1e-9).ceil() as u32).saturating_sub(1)
            } else {
                0
            };
            let _ = a0;
            mv.kind = MoveKind::Arc(xy_arc(p, cw, turns));
        }
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }

    /// `CT X.. Y..`: the arc from where the tool is, leaving it in the
    /// direction `tangent` the element before ends in, to the end point
    /// ([`super::tangent`]).
    fn hh_tangential(
        &mut self,
        block: &Block,
        seg: &Segment,
        m91: bool,
        tangent: Option<[f64; 2]>,
    ) -> Event {
        let (mut mv, skip) = self.hh_move(block, seg, MoveKind::Linear);
        self.pos = mv.end;
        if m91 {
            return Event::Quiet;
        }
        let ([s0, s1], [e0, e1]) = match plane_ends(&mv) {
            Ok(x) => x,
            Err(s) => return Event::Skip(skip.unwrap_or(s)),
        };
        if let Some(s) = skip {
            return Event::Skip(s);
        }
        // A two-dimensional element in the plane of the one before it.
        let moves_off_plane = (2..6).any(|i| mv.words[i].is_some() && mv.start[i] != mv.end[i]);
        let why = if self.plane != ArcPlane::Xy {
            Err("a working plane other than XY")
        } else if moves_off_plane {
            Err(
                "a word that moves the tool axis or a rotary axis (the control takes the two axes of the plane only)",
            )
        } else if let Some(t) = tangent {
            super::tangent::tangent_arc([s0, s1], t, [e0, e1], self.units.mm()).map(|a| (t, a))
        } else {
            Err(
                "the element before it is not a line or circle in the XY plane that fivecal follows (the arc starts in that element's direction)",
            )
        };
        let (t, (center, cw)) = match why {
            Ok(x) => x,
            Err(why) => return Event::Skip(Skip::Tangential(why)),
        };
        mv.kind = MoveKind::Arc(xy_arc(center, cw, 0));
        mv.tangential = Some(t);
        if let Some(s) = self.frame_skip() {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }

    fn hh_arc(&mut self, block: &Block, seg: &Segment, kind: HhKind, m91: bool) -> Event {
        let (mut mv, mut skip) = self.hh_move(block, seg, MoveKind::Linear);
        let mut cw = None;
        let mut radius: Option<(usize, f64)> = None;
        for (ti, w) in block.words(seg) {
            if w.addr == Addr::new("DR") {
                cw = Some(
                    block.bytes(w.value_span).is_empty()
                        && block.text[w.value_span.start as usize - 1] == b'-',
                );
            } else if w.addr == Addr::letter(b'R') {
                match self.axis_value(&w) {
                    Ok(v) => radius = Some((ti, v)),
                    Err(s) => {
                        skip.get_or_insert(s);
                    }
                }
            }
        }
        self.pos = mv.end;
        if m91 {
            return Event::Quiet;
        }
        // HEIDENHAIN circles are in the working plane; only XY is modelled.
        let ([s0, s1], [e0, e1]) = match plane_ends(&mv) {
            Ok(x) => x,
            Err(s) => return Event::Skip(skip.unwrap_or(s)),
        };
        if mv.words[2].is_some() && self.plane != ArcPlane::Xy {
            return Event::Skip(Skip::Element(
                ReasonKind::NotImplemented,
                "circle outside the XY plane",
            ));
        }
        let cw = cw.unwrap_or(false);
        let center = match kind {
            HhKind::C => match self.pole {
                Some(p) if arc_runs([s0, s1], [e0, e1], p, self.units.mm()) => p,
                Some(_) => {
                    return Event::Skip(skip.unwrap_or(Skip::Element(
                        ReasonKind::Unsaid,
                        "off-circle circle (its end not as far from the pole CC as its start)",
                    )));
                }
                None => {
                    return Event::Skip(skip.unwrap_or(Skip::Element(
                        ReasonKind::Unsaid,
                        "circle without a known pole (CC)",
                    )));
                }
            },
            _ => match radius {
                Some((_, r)) => match center_from_radius([s0, s1], [e0, e1], r, cw) {
                    Some(c) => c,
                    None => {
                        return Event::Skip(skip.unwrap_or(Skip::Element(
                            ReasonKind::Unsaid,
                            "circle whose radius does not reach its end point",
                        )));
                    }
                },
                None => {
                    return Event::Skip(
                        skip.unwrap_or(Skip::Element(ReasonKind::Unsaid, "CR without a radius")),
                    );
                }
            },
        };
        mv.kind = MoveKind::Arc(Arc {
            plane: ArcPlane::Xy,
            cw,
            center,
            turns: 0,
            center_words: [None; 3],
            // A C block turns about the pole: an R word there is not its
            // radius (and is left as written).
            radius_word: radius.filter(|_| kind != HhKind::C).map(|r| r.0),
        });
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }
}

/// A `RND`/`CHF` waiting for the element after it: its line, and the
/// rounding or chamfer with the line before it (start, corner), or why
/// the corner cannot be followed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PendingCorner {
    line: usize,
    #[allow(clippy::type_complexity)]
    geo: Result<(super::corner::CornerKind, [f64; 6], [f64; 6]), &'static str>,
}

/// An `APPR LT`/`LN`/`CT` waiting for the first contour element: its line, where it
/// starts (PS) and its first contour point (PA; program coordinates,
/// absolute, NaN on an axis the machine does not have), its `LEN` and which of the two.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PendingApproach {
    line: usize,
    from: [f64; 6],
    at: [f64; 6],
    len: f64,
    leg: Leg,
}

/// A polar word: its token, value, and whether it is incremental.
type PolarWord = Option<(usize, f64, bool)>;

/// The polar words of a block (`PR`/`IPR`, `PA`/`IPA`) and the turning
/// direction `DR` (clockwise for `DR-`), recording in `skip` why a value
/// is not known.
fn read_polar(
    block: &Block,
    seg: &Segment,
    skip: &mut Option<Skip>,
) -> (PolarWord, PolarWord, Option<bool>) {
    let mut radius: PolarWord = None;
    let mut angle: PolarWord = None;
    let mut cw = None;
    for (ti, w) in block.words(seg) {
        let slot = if w.addr == Addr::new("PR") {
            &mut radius
        } else if w.addr == Addr::new("PA") {
            &mut angle
        } else {
            if w.addr == Addr::new("DR") {
                cw = Some(
                    block.bytes(w.value_span).is_empty()
                        && block.text[w.value_span.start as usize - 1] == b'-',
                );
            }
            continue;
        };
        match w.value {
            Value::Num(v) if v.is_finite() && v.abs() <= crate::limits::MAX_NC_VALUE => {
                *slot = Some((ti, v, w.incremental));
            }
            Value::Num(_) => {
                skip.get_or_insert(Skip::OutOfRange(b'P'));
            }
            _ => {
                skip.get_or_insert(Skip::Expression);
            }
        }
    }
    (radius, angle, cw)
}

/// Where the tool is in polar coordinates around the pole (radius, angle
/// in degrees), when it is known.
type PolarHere = Option<(f64, f64)>;

/// Where the tool is in polar coordinates around `pole`, from `start`,
/// and the end point (XY) the polar words `radius` and `angle` name from
/// there: an incremental word counts from where the tool is, a missing
/// one keeps its value (a `CP`, `circle`, always keeps the radius).
fn polar_end(
    pole: Option<[f64; 2]>,
    start: &[Option<f64>; 6],
    radius: PolarWord,
    angle: PolarWord,
    circle: bool,
) -> (PolarHere, [Option<f64>; 2]) {
    let here = match (pole, start[0], start[1]) {
        (Some(p), Some(x), Some(y)) => Some((
            (x - p[0]).hypot(y - p[1]),
            (y - p[1]).atan2(x - p[0]).to_degrees(),
        )),
        _ => None,
    };
    let r = match radius {
        _ if circle => here.map(|h| h.0),
        Some((_, v, false)) => Some(v),
        Some((_, v, true)) => here.map(|h| h.0 + v),
        None => here.map(|h| h.0),
    };
    let a = match angle {
        Some((_, v, false)) => Some(v),
        Some((_, v, true)) => here.map(|h| h.1 + v),
        None => here.map(|h| h.1),
    };
    let end = match (pole, r, a) {
        (Some(p), Some(r), Some(a)) => {
            let (s, c) = a.to_radians().sin_cos();
            [Some(p[0] + r * c), Some(p[1] + r * s)]
        }
        _ => [None, None],
    };
    (here, end)
}

/// Where a move starts and ends in the XY plane, or which axis is not
/// known there.
fn plane_ends(mv: &Move) -> Result<([f64; 2], [f64; 2]), Skip> {
    match (mv.start[0], mv.start[1], mv.end[0], mv.end[1]) {
        (Some(s0), Some(s1), Some(e0), Some(e1)) => Ok(([s0, s1], [e0, e1])),
        _ if mv.start[0].is_none() || mv.end[0].is_none() => Err(Skip::PositionUnknown(b'X')),
        _ => Err(Skip::PositionUnknown(b'Y')),
    }
}

/// The direction (XY, unit) a move ends in, where it moves in XY.
fn end_direction(mv: &Move) -> Option<[f64; 2]> {
    let e = [mv.end[0]?, mv.end[1]?];
    match mv.kind {
        MoveKind::Arc(a) if a.plane == ArcPlane::Xy => {
            super::tangent::arc_end_direction(a.center, e, a.cw)
        }
        MoveKind::Arc(_) => None,
        _ => super::tangent::direction([mv.start[0]?, mv.start[1]?], e),
    }
}

/// Cycles that act where they are defined (coordinate transformations,
/// dwell, tolerance, the contour of SL cycles): a `CYCL DEF` of one of
/// them leaves the cycle that `CYCL CALL` runs as it was.
const DEF_ACTIVE: [u32; 12] = [7, 8, 9, 10, 11, 12, 13, 14, 19, 26, 32, 247];

/// Drilling cycles that drill one hole along the tool axis from the
/// surface `Q203` to the depth `Q201` (counted from the surface, its sign
/// the direction), starting at the set-up clearance `Q200` above the
/// surface: drilling, reaming, boring, universal drilling, universal
/// pecking, tapping (floating and rigid, with chip breaking) and
/// single-lip deep-hole drilling.
const HOLES: [u32; 9] = [200, 201, 202, 203, 205, 206, 207, 209, 241];

/// The cycles that end at the set-up clearance or the second set-up
/// clearance above the surface Q203 (see [`CycleDef::end_height`]).
const ENDS_ABOVE_SURFACE: [u32; 12] = [200, 201, 202, 203, 204, 205, 206, 207, 208, 209, 240, 241];

/// A machining cycle defined by `CYCL DEF`, with the parameters a hole
/// needs where they are written as numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CycleDef {
    /// The cycle number.
    pub number: u32,
    /// `Q200`: the set-up clearance above the surface.
    pub clearance: Option<f64>,
    /// `Q201`: the depth, from the surface.
    pub depth: Option<f64>,
    /// `Q203`: the surface coordinate.
    pub surface: Option<f64>,
    /// `Q204`: the second set-up clearance above the surface.
    pub second_clearance: Option<f64>,
}

impl CycleDef {
    /// The cycle of a `CYCL DEF` block: its `Qn=value` assignments
    /// (`Q201=-8 ;DEPTH ~` on continuation lines); a value that is not a
    /// number (`Q201=+Q5`) stays unknown.
    fn read(block: &Block, seg: &Segment, number: u32) -> CycleDef {
        let mut code = Vec::new();
        for t in block.seg_tokens(seg) {
            match t.kind {
                TokenKind::Comment => {}
                TokenKind::Space | TokenKind::LineEnd | TokenKind::Continuation => code.push(b' '),
                _ => code.extend_from_slice(block.bytes(t.span)),
            }
        }
        let q = |n: u32| -> Option<f64> {
            let name = format!("Q{n}");
            let at = code
                .windows(name.len())
                .enumerate()
                .find(|(i, w)| {
                    w.eq_ignore_ascii_case(name.as_bytes())
                        && (*i == 0 || !code[i - 1].is_ascii_alphanumeric())
                        && !code.get(i + name.len()).is_some_and(u8::is_ascii_digit)
                })?
                .0;
            let rest = &code[at + name.len()..];
            let rest = rest
                .trim_ascii_start()
                .strip_prefix(b"=")?
                .trim_ascii_start();
            let n = crate::nc::lexeme::lex_len(rest);
            let after = rest.get(n).copied();
            (n > 0 && after.is_none_or(|c| c == b' '))
                .then(|| crate::nc::lexeme::read(&rest[..n]).value)
                .filter(|v| v.is_finite() && v.abs() <= crate::limits::MAX_NC_VALUE)
        };
        CycleDef {
            number,
            clearance: q(200),
            depth: q(201),
            surface: q(203),
            second_clearance: q(204),
        }
    }

    /// Whether the cycle ends on the axis of the hole it made (the
    /// drilling, reaming, boring, tapping and centring cycles 1, 200-209,
    /// 240 and 241).
    pub fn ends_on_axis(&self) -> bool {
        self.number == 1 || ENDS_ABOVE_SURFACE.contains(&self.number)
    }

    /// The tool-axis coordinate the cycle leaves the tool at, when its
    /// CYCL DEF gives it as numbers: cycles 200-209, 240 and 241 retract
    /// to the set-up clearance above the surface, or to the second set-up
    /// clearance when that is the greater ("Q204 only comes into effect if
    /// its value is greater than the set-up clearance Q200", each cycle's
    /// run in HEIDENHAIN's cycle programming manuals, TNC 640 / TNC7);
    /// the old pecking cycle 1 returns to the position it started from
    /// (`z_before`).
    pub fn end_height(&self, z_before: Option<f64>) -> Option<f64> {
        if self.number == 1 {
            return z_before;
        }
        if !ENDS_ABOVE_SURFACE.contains(&self.number) {
            return None;
        }
        let (q200, q203, q204) = (self.clearance?, self.surface?, self.second_clearance?);
        Some(q203 + q200.max(q204))
    }

    /// Whether the cycle drills one hole along the tool axis.
    pub fn is_hole(&self) -> bool {
        HOLES.contains(&self.number)
    }
}

/// The tool a `TOOL CALL` block names.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum CalledTool {
    /// None: only the spindle axis, speed, feed or deltas are given.
    None,
    /// A number or a quoted name, as written (upper case, a number
    /// without leading zeros or a fraction of `.0`).
    Named(String),
    /// A Q parameter: which tool is not known here.
    Parameter,
}

/// The tool of a `TOOL CALL` block (`code`: its text outside comments,
/// upper case): `TOOL CALL 5 Z S4456`, `TOOL CALL "MILL_D10" Z`,
/// `TOOL CALL 12.1 Z` (indexed), `TOOL CALL Q5 Z`, `TOOL CALL S2000`.
pub(crate) fn tool_call_tool(code: &[u8]) -> CalledTool {
    let text = String::from_utf8_lossy(code);
    let Some(at) = text.find("TOOL CALL") else {
        return CalledTool::Parameter;
    };
    let rest = text[at + "TOOL CALL".len()..].trim_start();
    if let Some(name) = rest.strip_prefix('"') {
        return match name.find('"') {
            Some(e) => CalledTool::Named(format!("\"{}\"", &name[..e])),
            None => CalledTool::Parameter,
        };
    }
    let word: String = rest
        .chars()
        .take_while(|c| !c.is_whitespace() && *c != '~')
        .collect();
    if word.starts_with('Q') {
        return CalledTool::Parameter;
    }
    if word.starts_with(|c: char| c.is_ascii_digit()) {
        return match word.parse::<f64>() {
            Ok(v) if v.is_finite() => CalledTool::Named(format!("{v}")),
            _ => CalledTool::Parameter,
        };
    }
    CalledTool::None
}

/// The cycle number of a `TCH PROBE n.m` block.
pub(super) fn tch_probe_number(text: &[u8]) -> Option<u32> {
    let up = text.to_ascii_uppercase();
    let at = up.windows(9).position(|w| w == b"TCH PROBE")? + 9;
    let rest = &up[at..];
    let start = rest.iter().position(|b| !b.is_ascii_whitespace())?;
    let digits: Vec<u8> = rest[start..]
        .iter()
        .take_while(|b| b.is_ascii_digit())
        .copied()
        .collect();
    std::str::from_utf8(&digits).ok()?.parse().ok()
}

/// An arc in the XY plane whose centre the control computes (a pole, a
/// tangent, an approach's arc), so no centre or radius word of the block
/// names it.
fn xy_arc(center: [f64; 2], cw: bool, turns: u32) -> Arc {
    Arc {
        plane: ArcPlane::Xy,
        cw,
        center,
        turns,
        center_words: [None; 3],
        radius_word: None,
    }
}
