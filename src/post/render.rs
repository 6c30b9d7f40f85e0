//! Rendering a neutral toolpath with a definition: templates per op, modal
//! coordinate words, block numbers, comment sanitizing, the line-length
//! limit, and the safety rules of the engine.

use minijinja::{Value, context};
use nalgebra::{Matrix3, Vector3};

use super::definition::PostDefinition;
use super::{Coolant, Op, Target, euler_spatial, euler_zxz};
use crate::source::SourceError;

/// What the program is, for its header.
#[derive(Clone, Debug, PartialEq)]
pub struct ProgramInfo {
    /// Program name (the file stem; HEIDENHAIN `BEGIN PGM` name).
    pub name: String,
    /// Program number (FANUC `O` number).
    pub number: u32,
    /// One-line title.
    pub title: String,
    /// Header lines saying what the program is (test, machine, dialect,
    /// tool, zero point, ...), written as comments.
    pub lines: Vec<String>,
    /// Stock box in the work frame, mm (HEIDENHAIN `BLK FORM`).
    pub stock_min: Vector3<f64>,
    /// Stock box maximum corner.
    pub stock_max: Vector3<f64>,
    /// Letter of the tilt axis (`A` or `B`).
    pub tilt_letter: char,
}

/// A file that belongs with a program (the HEIDENHAIN FN 16 format file).
#[derive(Clone, Debug, PartialEq)]
pub struct AuxFile {
    /// File name (no directory).
    pub name: String,
    /// Its text.
    pub text: String,
}

/// A rendered program.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderedProgram {
    /// The program text, one block per line, ending with a newline.
    pub text: String,
    /// Files to write next to it.
    pub aux: Vec<AuxFile>,
}

/// Why a toolpath could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum PostError {
    /// A template failed (points into the definition file).
    #[error(transparent)]
    Template(#[from] SourceError),
    /// The toolpath breaks a rule of the engine.
    #[error("postprocessor {post}: op {index} ({op}): {message}")]
    Rule {
        /// Definition name.
        post: String,
        /// Index of the op in the toolpath.
        index: usize,
        /// Short op name.
        op: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A block is longer than the definition allows.
    #[error(
        "postprocessor {post}: block `{block}` has {len} characters, over the limit of {limit}"
    )]
    LineTooLong {
        /// Definition name.
        post: String,
        /// The block.
        block: String,
        /// Its length.
        len: usize,
        /// The limit.
        limit: usize,
    },
}

fn op_name(op: &Op) -> &'static str {
    match op {
        Op::Comment(_) => "comment",
        Op::Section(_) => "section",
        Op::ToolCall { .. } => "tool_call",
        Op::SpindleOn { .. } => "spindle_on",
        Op::SpindleOff => "spindle_off",
        Op::Coolant(_) => "coolant",
        Op::Rapid(_) => "rapid",
        Op::Feed { .. } => "feed",
        Op::Retract { .. } => "retract",
        Op::Rotary { .. } => "rotary",
        Op::TiltedPlane { .. } => "tilted_plane",
        Op::TiltedPlaneOff => "tilted_plane_off",
        Op::TcpOn => "tcp_on",
        Op::TcpOff => "tcp_off",
        Op::ProbeMove { .. } => "probe_move",
        Op::ProbeRead { .. } => "probe_read",
        Op::LogOpen { .. } => "log_open",
        Op::LogPoint { .. } => "log_point",
        Op::LogClose => "log_close",
        Op::Dwell(_) => "dwell",
        Op::Stop(_) => "stop",
    }
}

/// Output lines with block numbers and the length limit.
struct Blocks<'a> {
    def: &'a PostDefinition,
    text: String,
    next: u64,
}

impl<'a> Blocks<'a> {
    fn new(def: &'a PostDefinition) -> Self {
        Blocks {
            def,
            text: String::new(),
            next: def.block_numbers.as_ref().map_or(0, |b| b.start),
        }
    }

    /// The line with its block number, without committing it.
    fn numbered(&self, line: &str) -> (String, bool) {
        let Some(b) = &self.def.block_numbers else {
            return (line.to_string(), false);
        };
        let continuation = line.starts_with(' ') || line.starts_with('\t');
        if continuation
            || b.skip
                .iter()
                .any(|s| !s.is_empty() && line.starts_with(s.as_str()))
        {
            return (line.to_string(), false);
        }
        (format!("{}{} {}", b.prefix, self.next, line), true)
    }

    fn fits(&self, line: &str) -> bool {
        self.numbered(line).0.chars().count() <= self.def.line_limit
    }

    fn push(&mut self, line: &str) -> Result<(), PostError> {
        let (full, used) = self.numbered(line);
        let len = full.chars().count();
        if len > self.def.line_limit {
            return Err(PostError::LineTooLong {
                post: self.def.name.clone(),
                block: full,
                len,
                limit: self.def.line_limit,
            });
        }
        if used {
            let b = self.def.block_numbers.as_ref().expect("numbered");
            self.next += b.step;
            if self.next > b.max {
                self.next = b.start;
            }
        }
        self.text.push_str(&full);
        self.text.push('\n');
        Ok(())
    }

    /// Pushes every non-blank line of a rendered template.
    fn push_all(&mut self, rendered: &str) -> Result<(), PostError> {
        for line in rendered.lines() {
            let line = line.trim_end();
            if !line.trim().is_empty() {
                self.push(line)?;
            }
        }
        Ok(())
    }
}

impl PostDefinition {
    /// Comment text as this control accepts it.
    pub(crate) fn sanitize_comment(&self, text: &str) -> String {
        let rules = &self.comment;
        let ok = |c: char| {
            let allowed = if rules.allowed.is_empty() {
                (' '..='~').contains(&c)
            } else {
                rules.allowed.contains(c)
            };
            allowed && !rules.forbidden.contains(c)
        };
        let mut s: String = text
            .chars()
            .map(|c| {
                let c = if rules.upper {
                    c.to_ascii_uppercase()
                } else {
                    c
                };
                if ok(c) {
                    return c;
                }
                // A separator keeps its meaning where the dialect lets
                // it: `(A 2013; B 2023)` reads `(A 2013, B 2023)`, not
                // `(A 2013 B 2023)`.
                let stand_in = match c {
                    ';' => ',',
                    '"' => '\'',
                    _ => ' ',
                };
                if ok(stand_in) { stand_in } else { ' ' }
            })
            .collect();
        while s.contains("  ") {
            s = s.replace("  ", " ");
        }
        // A stand-in comma after a dropped bracket or at a wrapped line's
        // end reads as a stray mark: `KINEMATICS , NO TCP`, `110 MM,`.
        while s.contains(" ,") {
            s = s.replace(" ,", ",");
        }
        let t = s.trim();
        t.strip_suffix(',').unwrap_or(t).trim_end().to_string()
    }

    fn words(&self, t: &Target, last: &mut [Option<String>; 3]) -> (String, [String; 3]) {
        let mut parts = Vec::new();
        let mut each: [String; 3] = Default::default();
        for (i, (letter, v)) in [('X', t.x), ('Y', t.y), ('Z', t.z)].into_iter().enumerate() {
            let Some(v) = v else { continue };
            let w = format!("{letter}{}", self.numbers.length.format(v));
            if last[i].as_deref() != Some(w.as_str()) {
                parts.push(w.clone());
                each[i] = w.clone();
                last[i] = Some(w);
            }
        }
        (parts.join(" "), each)
    }

    /// Renders a toolpath to program text.
    pub fn render(&self, info: &ProgramInfo, ops: &[Op]) -> Result<RenderedProgram, PostError> {
        let mut out = Blocks::new(self);
        let head = header_context(self, info);
        out.push_all(&self.render_template("header", head.clone())?)?;
        for line in &info.lines {
            self.push_comment(&mut out, "comment", line)?;
        }
        out.push_all(&self.render_template("preamble", head.clone())?)?;

        let mut w = Writer::new(self, info, out);
        for (index, op) in ops.iter().enumerate() {
            w.op(index, op)?;
        }
        let (mut out, log_used) = w.finish(ops.len())?;
        out.push_all(&self.render_template("footer", head)?)?;
        let aux = self.log_formats(log_used)?;
        Ok(RenderedProgram {
            text: out.text,
            aux,
        })
    }

    /// The format files of the probe log `(name, test)` the program wrote,
    /// for the controls whose log needs them (HEIDENHAIN FN 16).
    fn log_formats(&self, log_used: Option<(String, String)>) -> Result<Vec<AuxFile>, PostError> {
        let mut aux = Vec::new();
        if let Some((name, test)) = log_used {
            for (template, suffix) in [("log_header_format", "head"), ("log_touch_format", "touch")]
            {
                if self.has(template) {
                    let ctx = context! { name => name.as_str(), test => test.as_str() };
                    let text = self.render_template(template, ctx)?;
                    aux.push(AuxFile {
                        name: format!("{name}-{suffix}.a"),
                        text: format!("{}\n", text.trim_end()),
                    });
                }
            }
        }
        Ok(aux)
    }

    /// A comment, wrapped at spaces into as many blocks as it takes to
    /// keep every block within the line limit.
    fn push_comment(
        &self,
        out: &mut Blocks<'_>,
        template: &str,
        text: &str,
    ) -> Result<(), PostError> {
        let fits = |out: &Blocks<'_>, t: &str| -> Result<bool, PostError> {
            let rendered = self.render_template(template, context! { text => t })?;
            Ok(rendered
                .lines()
                .filter(|l| !l.trim().is_empty())
                .all(|l| out.fits(l.trim_end())))
        };
        let mut rest = self.sanitize_comment(text);
        while !rest.is_empty() {
            // The longest prefix that fits, cut at a space when there is one.
            let chars: Vec<char> = rest.chars().collect();
            let (mut lo, mut hi) = (0usize, chars.len());
            while lo < hi {
                let mid = (lo + hi).div_ceil(2);
                let t: String = chars[..mid].iter().collect();
                if fits(out, &t)? {
                    lo = mid;
                } else {
                    hi = mid - 1;
                }
            }
            if lo == 0 {
                return Err(PostError::LineTooLong {
                    post: self.name.clone(),
                    block: self.render_template(template, context! { text => "" })?,
                    len: self.line_limit + 1,
                    limit: self.line_limit,
                });
            }
            let mut cut = lo;
            if cut < chars.len()
                && let Some(sp) = chars[..cut].iter().rposition(|&c| c == ' ')
                && sp > 0
            {
                cut = sp;
            }
            let line: String = chars[..cut].iter().collect();
            let rendered = self.render_template(template, context! { text => line.trim() })?;
            out.push_all(&rendered)?;
            rest = chars[cut..].iter().collect::<String>().trim().to_string();
        }
        Ok(())
    }
}

/// A program being written: its blocks and the modal state the control
/// holds after the ops so far, which decides what the next op writes and
/// whether it may.
struct Writer<'a> {
    post: &'a PostDefinition,
    info: &'a ProgramInfo,
    out: Blocks<'a>,
    /// The X, Y, Z words in force (an unchanged word is not written again).
    last: [Option<String>; 3],
    /// The feed word in force.
    last_feed: Option<String>,
    /// At the safe height, with no move since: a rotary index may follow.
    retracted: bool,
    /// A tilted working plane is active.
    plane: bool,
    /// TCP is active.
    tcp: bool,
    spindle: bool,
    /// The probe log open now.
    log: Option<String>,
    /// The last probe log opened, with its test.
    log_used: Option<(String, String)>,
    tool_number: u32,
}

impl<'a> Writer<'a> {
    fn new(post: &'a PostDefinition, info: &'a ProgramInfo, out: Blocks<'a>) -> Self {
        Writer {
            post,
            info,
            out,
            last: Default::default(),
            last_feed: None,
            retracted: true,
            plane: false,
            tcp: false,
            spindle: false,
            log: None,
            log_used: None,
            tool_number: 0,
        }
    }

    /// The error of op `index` breaking a rule of the engine.
    fn rule(&self, index: usize, op: &Op, message: String) -> PostError {
        PostError::Rule {
            post: self.post.name.clone(),
            index,
            op: op_name(op),
            message,
        }
    }

    /// Refuses an op the definition has no template `name` for.
    fn need(&self, index: usize, op: &Op, name: &str) -> Result<(), PostError> {
        if self.post.has(name) {
            Ok(())
        } else {
            Err(self.rule(
                index,
                op,
                format!(
                    "the {} postprocessor has no `{name}` template, so it cannot write this op",
                    self.post.name
                ),
            ))
        }
    }

    /// Renders template `name` and writes its blocks.
    fn write(&mut self, name: &str, ctx: Value) -> Result<(), PostError> {
        let text = self.post.render_template(name, ctx)?;
        self.out.push_all(&text)
    }

    /// Writes op `index`.
    fn op(&mut self, index: usize, op: &Op) -> Result<(), PostError> {
        let post = self.post;
        match op {
            Op::Comment(t) => post.push_comment(&mut self.out, "comment", t)?,
            Op::Section(t) => {
                let name = if post.has("section") {
                    "section"
                } else {
                    "comment"
                };
                post.push_comment(&mut self.out, name, t)?;
            }
            Op::ToolCall {
                number,
                name,
                id,
                rpm,
            } => {
                self.tool_number = *number;
                let ctx = context! {
                    number => *number,
                    name => post.sanitize_comment(name),
                    id => id.clone(),
                    rpm => *rpm,
                };
                self.write("tool_call", ctx)?;
                self.last = Default::default();
                self.last_feed = None;
            }
            Op::SpindleOn { rpm } => {
                self.write("spindle_on", context! { rpm => *rpm })?;
                self.spindle = true;
            }
            Op::SpindleOff => {
                self.write("spindle_off", context! {})?;
                self.spindle = false;
            }
            Op::Coolant(Coolant::Off) => self.write("coolant_off", context! {})?,
            Op::Coolant(k) => {
                let code = match k {
                    Coolant::Flood => &post.coolant.flood,
                    Coolant::Mist => &post.coolant.mist,
                    _ => &post.coolant.air,
                };
                let ctx = context! { code => code.as_str(), kind => k.name() };
                self.write("coolant_on", ctx)?;
            }
            Op::Rapid(t) => {
                let (words, [x, y, z]) = post.words(t, &mut self.last);
                if !words.is_empty() {
                    let ctx = context! { words, x, y, z };
                    self.write("rapid", ctx)?;
                    self.retracted = false;
                }
            }
            Op::Feed { to, feed } => self.feed(index, op, to, *feed)?,
            Op::Retract { z } => self.retract(index, op, *z)?,
            Op::Rotary { tilt, c } => self.rotary(index, op, *tilt, *c)?,
            Op::TiltedPlane {
                rotation,
                origin,
                tilt,
                c,
            } => self.tilted_plane(index, op, rotation, origin, *tilt, *c)?,
            Op::TiltedPlaneOff => {
                self.need(index, op, "tilted_plane_off")?;
                self.write("tilted_plane_off", context! {})?;
                self.plane = false;
                self.last = Default::default();
            }
            Op::TcpOn => {
                self.need(index, op, "tcp_on")?;
                if self.plane || self.tcp {
                    return Err(self.rule(
                        index,
                        op,
                        "a tilted plane or TCP is already active".into(),
                    ));
                }
                self.write("tcp_on", context! { number => self.tool_number })?;
                self.tcp = true;
                self.last = Default::default();
            }
            Op::TcpOff => {
                self.need(index, op, "tcp_off")?;
                self.write("tcp_off", context! { number => self.tool_number })?;
                self.tcp = false;
                self.last = Default::default();
            }
            Op::ProbeMove {
                from,
                to,
                feed,
                direction,
            } => self.probe_move(index, op, from, to, *feed, direction)?,
            Op::ProbeRead { vars } => {
                self.need(index, op, "probe_read")?;
                let ctx = context! { x => vars[0], y => vars[1], z => vars[2] };
                self.write("probe_read", ctx)?;
            }
            Op::LogOpen { name, test } => {
                if self.log.is_some() {
                    return Err(self.rule(index, op, "a log is already open".into()));
                }
                if post.has("log_open") {
                    let ctx = context! { name => name.as_str(), test => test.as_str() };
                    self.write("log_open", ctx)?;
                }
                self.log = Some(name.clone());
                self.log_used = Some((name.clone(), test.clone()));
            }
            Op::LogPoint {
                index: touch,
                label,
            } => self.log_point(index, op, *touch, label)?,
            Op::LogClose => {
                let Some(name) = self.log.take() else {
                    return Err(self.rule(index, op, "no log is open".into()));
                };
                if post.has("log_close") {
                    self.write("log_close", context! { name })?;
                }
            }
            Op::Dwell(s) => {
                self.need(index, op, "dwell")?;
                self.write("dwell", context! { seconds => *s })?;
            }
            Op::Stop(t) => {
                self.need(index, op, "stop")?;
                let ctx = context! { text => post.sanitize_comment(t) };
                self.write("stop", ctx)?;
            }
        }
        Ok(())
    }

    /// A feed move, its feed word written only when it changes.
    fn feed(&mut self, index: usize, op: &Op, to: &Target, feed: f64) -> Result<(), PostError> {
        if !(feed.is_finite() && feed > 0.0) {
            return Err(self.rule(index, op, format!("feed must be > 0 mm/min, got {feed}")));
        }
        let (words, [x, y, z]) = self.post.words(to, &mut self.last);
        if !words.is_empty() {
            let fw = self.post.numbers.feed.format(feed);
            let new_feed = self.last_feed.as_deref() != Some(fw.as_str());
            self.last_feed = Some(fw);
            let ctx = context! { words, x, y, z, f => feed, new_feed };
            self.write("feed", ctx)?;
            self.retracted = false;
        }
        Ok(())
    }

    /// A retract to the safe height, refused when the template writes
    /// anything but a Z move there.
    fn retract(&mut self, index: usize, op: &Op, z: f64) -> Result<(), PostError> {
        let t = Target {
            z: Some(z),
            ..Target::default()
        };
        // A retract is always written, even when Z is unchanged:
        // it is the marker the safety rule and readers rely on.
        self.last[2] = None;
        let (words, _) = self.post.words(&t, &mut self.last);
        let ctx = context! { words => words.as_str(), z => z };
        let block = self.post.render_template("retract", ctx)?;
        // Whatever the template says, a retract reaches the
        // safe height before a rotary index may follow.
        if !block.contains(&words) || moves_axes(&block, &['X', 'Y']) {
            return Err(self.rule(
                index,
                op,
                format!(
                    "the retract template wrote `{}`, which does not move Z alone to `{words}`",
                    block.trim()
                ),
            ));
        }
        self.out.push_all(&block)?;
        self.retracted = true;
        Ok(())
    }

    /// A rotary index, refused unless right after a retract and with no
    /// tilted plane active.
    fn rotary(&mut self, index: usize, op: &Op, tilt: f64, c: f64) -> Result<(), PostError> {
        if !self.retracted {
            return Err(self.rule(
                index,
                op,
                "a rotary index must follow a retract to the safe height, with no move in between"
                    .into(),
            ));
        }
        if self.plane {
            return Err(self.rule(
                index,
                op,
                "cancel the tilted working plane before indexing the rotary axes".into(),
            ));
        }
        let a = &self.post.numbers.angle;
        let tilt_letter = self.info.tilt_letter;
        let words = format!("{}{} C{}", tilt_letter, a.format(tilt), a.format(c));
        let ctx = context! {
            words,
            tilt => tilt,
            c => c,
            tilt_letter => tilt_letter.to_string(),
        };
        self.write("rotary", ctx)?;
        self.last = Default::default();
        Ok(())
    }

    /// A tilted working plane (both Euler conventions offered to the
    /// template), refused when one or TCP is already active.
    fn tilted_plane(
        &mut self,
        index: usize,
        op: &Op,
        rotation: &Matrix3<f64>,
        origin: &Vector3<f64>,
        tilt: f64,
        c: f64,
    ) -> Result<(), PostError> {
        self.need(index, op, "tilted_plane")?;
        if self.plane || self.tcp {
            return Err(self.rule(index, op, "a tilted plane or TCP is already active".into()));
        }
        let [i, j, k] = euler_zxz(rotation);
        let [spa, spb, spc] = euler_spatial(rotation);
        let ctx = context! {
            i, j, k, spa, spb, spc,
            x => origin.x, y => origin.y, z => origin.z,
            tilt => tilt, c => c,
            tilt_letter => self.info.tilt_letter.to_string(),
        };
        self.write("tilted_plane", ctx)?;
        self.plane = true;
        self.last = Default::default();
        Ok(())
    }

    /// A probing move, refused with the spindle on, at no feed, or off the
    /// axes on a control that probes along one axis only.
    fn probe_move(
        &mut self,
        index: usize,
        op: &Op,
        from: &Vector3<f64>,
        to: &Vector3<f64>,
        feed: f64,
        direction: &Vector3<f64>,
    ) -> Result<(), PostError> {
        self.need(index, op, "probe_move")?;
        if self.spindle {
            return Err(self.rule(index, op, "probe moves need the spindle stopped".into()));
        }
        if !(feed.is_finite() && feed > 0.0) {
            return Err(self.rule(
                index,
                op,
                format!("probing feed must be > 0 mm/min, got {feed}"),
            ));
        }
        let d = direction.normalize();
        let axis = (0..3).find(|&i| (d[i].abs() - 1.0).abs() < 1e-9);
        if self.post.probe_axis_aligned && axis.is_none() {
            return Err(self.rule(
                index,
                op,
                format!(
                    "the {} control probes along one axis only; direction ({:.4}, {:.4}, {:.4}) is not along X, Y or Z",
                    self.post.name, d.x, d.y, d.z
                ),
            ));
        }
        let (axis_letter, sign) = match axis {
            Some(i) => (
                ["X", "Y", "Z"][i].to_string(),
                if d[i] > 0.0 { "+" } else { "-" }.to_string(),
            ),
            None => (String::new(), String::new()),
        };
        // Probe moves always state every axis: the target is
        // what the controller compares the contact against.
        self.last = Default::default();
        let (words, _) = self.post.words(&Target::xyz(*to), &mut self.last);
        let ctx = context! {
            words,
            x => to.x, y => to.y, z => to.z,
            sx => from.x, sy => from.y, sz => from.z,
            f => feed,
            axis => axis_letter,
            sign,
            aligned => axis.is_some(),
        };
        self.write("probe_move", ctx)?;
        self.retracted = false;
        // The machine stops wherever contact happens, and the
        // probing feed is modal now: the next feed move names its own.
        self.last = Default::default();
        self.last_feed = None;
        Ok(())
    }

    /// One touch's record in the open probe log.
    fn log_point(
        &mut self,
        index: usize,
        op: &Op,
        touch: usize,
        label: &str,
    ) -> Result<(), PostError> {
        self.need(index, op, "log_point")?;
        let Some(name) = &self.log else {
            return Err(self.rule(index, op, "no log is open (LogOpen first)".into()));
        };
        if !crate::formats::valid_label(label) {
            return Err(self.rule(
                index,
                op,
                format!("label `{label}` must be letters, digits, `_`, `.` and `-`"),
            ));
        }
        let ctx = context! {
            index => touch,
            label => label,
            name => name.as_str(),
        };
        self.write("log_point", ctx)
    }

    /// The blocks written and the probe log used, refused when a log is
    /// left open or a tilted plane or TCP still active after the last of
    /// `n_ops` ops.
    fn finish(self, n_ops: usize) -> Result<(Blocks<'a>, Option<(String, String)>), PostError> {
        if let Some(name) = self.log {
            return Err(PostError::Rule {
                post: self.post.name.clone(),
                index: n_ops,
                op: "log_close",
                message: format!("log `{name}` is never closed"),
            });
        }
        if self.plane || self.tcp {
            return Err(PostError::Rule {
                post: self.post.name.clone(),
                index: n_ops,
                op: "footer",
                message: "the program ends with a tilted plane or TCP still active".into(),
            });
        }
        Ok((self.out, self.log_used))
    }
}

/// Whether a rendered block moves one of `axes`: a letter not preceded by
/// a letter (so `FMAX` is not an X word) and followed by a number, sign,
/// point or variable, outside comments (`(...)`, `;...`).
fn moves_axes(text: &str, axes: &[char]) -> bool {
    text.lines().any(|line| {
        let code = line.split(';').next().unwrap_or("");
        let mut depth = 0usize;
        let mut prev = ' ';
        let cs: Vec<char> = code.chars().collect();
        for (i, &c) in cs.iter().enumerate() {
            match c {
                '(' => depth += 1,
                ')' => depth = depth.saturating_sub(1),
                _ if depth == 0
                    && axes.contains(&c)
                    && !prev.is_ascii_alphabetic()
                    && cs.get(i + 1).is_some_and(|n| {
                        n.is_ascii_digit() || matches!(n, '+' | '-' | '.' | '#' | '[' | 'Q')
                    }) =>
                {
                    return true;
                }
                _ => {}
            }
            prev = c;
        }
        false
    })
}

/// Checks that the templates the safety rules rest on do what their names
/// say, rendered with sample positions in the definition's own number
/// format: `retract` writes the Z word it is given and no X or Y word,
/// `rapid` writes every word it is given, `rotary` writes both rotary
/// words and no linear axis. Returns the template and what is wrong.
pub(super) fn check_motion_templates(def: &PostDefinition) -> Result<(), (&'static str, String)> {
    let len = |v: f64| def.numbers.length.format(v);
    for z in [100.0, 137.5] {
        let words = format!("Z{}", len(z));
        let got = def
            .render_template("retract", context! { words => words.as_str(), z })
            .map_err(|e| ("retract", e.message))?;
        if !got.contains(&words) {
            return Err((
                "retract",
                format!(
                    "given `{words}` it writes `{}`, which does not retract to the safe height: it must write the Z word (`{{{{ words }}}}`)",
                    got.trim()
                ),
            ));
        }
        if moves_axes(&got, &['X', 'Y']) {
            return Err((
                "retract",
                format!(
                    "given `{words}` it writes `{}`, which also moves X or Y: a retract moves Z alone",
                    got.trim()
                ),
            ));
        }
    }
    let (x, y, z) = (
        format!("X{}", len(12.5)),
        format!("Y{}", len(-7.0)),
        format!("Z{}", len(30.0)),
    );
    let words = format!("{x} {y} {z}");
    let got = def
        .render_template(
            "rapid",
            context! { words => words.as_str(), x => x.as_str(), y => y.as_str(), z => z.as_str() },
        )
        .map_err(|e| ("rapid", e.message))?;
    if ![&x, &y, &z].iter().all(|w| got.contains(w.as_str())) {
        return Err((
            "rapid",
            format!(
                "given `{words}` it writes `{}`: a rapid must write every word it is given (`{{{{ words }}}}`)",
                got.trim()
            ),
        ));
    }
    let a = &def.numbers.angle;
    let (tw, cw) = (
        format!("B{}", a.format(30.0)),
        format!("C{}", a.format(45.0)),
    );
    let words = format!("{tw} {cw}");
    let got = def
        .render_template(
            "rotary",
            context! { words => words.as_str(), tilt => 30.0, c => 45.0, tilt_letter => "B" },
        )
        .map_err(|e| ("rotary", e.message))?;
    if !(got.contains(&tw) && got.contains(&cw)) || moves_axes(&got, &['X', 'Y', 'Z']) {
        return Err((
            "rotary",
            format!(
                "given `{words}` it writes `{}`: a rotary index writes both rotary words and no X, Y or Z word",
                got.trim()
            ),
        ));
    }
    Ok(())
}

fn header_context(def: &PostDefinition, info: &ProgramInfo) -> Value {
    let v = |p: &Vector3<f64>| context! { x => p.x, y => p.y, z => p.z };
    context! {
        program => info.name.as_str(),
        number => info.number,
        title => def.sanitize_comment(&info.title),
        stock_min => v(&info.stock_min),
        stock_max => v(&info.stock_max),
        tilt_letter => info.tilt_letter.to_string(),
        extension => def.extension.as_str(),
    }
}

/// One sample context per template, with every variable the engine passes,
/// for validating definitions at load time.
pub(super) fn sample_contexts(def: &PostDefinition) -> Vec<(&'static str, Value)> {
    let info = ProgramInfo {
        name: "sample".into(),
        number: 1,
        title: "sample".into(),
        lines: vec![],
        stock_min: Vector3::new(-50.0, -50.0, 0.0),
        stock_max: Vector3::new(50.0, 50.0, 70.0),
        tilt_letter: 'B',
    };
    let head = header_context(def, &info);
    let words = || "X1. Y2. Z3.".to_string();
    vec![
        ("header", head.clone()),
        ("preamble", head.clone()),
        ("footer", head),
        ("comment", context! { text => "sample" }),
        ("section", context! { text => "sample" }),
        (
            "tool_call",
            context! { number => 1u32, name => "sample", id => Some("SAMPLE_D8"), rpm => Some(1000.0) },
        ),
        (
            "tool_call",
            context! { number => 1u32, name => "sample", id => None::<String>, rpm => None::<f64> },
        ),
        ("spindle_on", context! { rpm => 1000.0 }),
        ("spindle_off", context! {}),
        ("coolant_on", context! { code => "M8", kind => "flood" }),
        ("coolant_off", context! {}),
        (
            "rapid",
            context! { words => words(), x => "X1.", y => "", z => "" },
        ),
        (
            "feed",
            context! { words => words(), x => "X1.", y => "", z => "", f => 100.0, new_feed => true },
        ),
        ("retract", context! { words => "Z100.", z => 100.0 }),
        (
            "rotary",
            context! { words => "B0. C0.", tilt => 0.0, c => 0.0, tilt_letter => "B" },
        ),
        (
            "tilted_plane",
            context! {
                i => 0.0, j => 90.0, k => 0.0, spa => 0.0, spb => 90.0, spc => 0.0,
                x => 0.0, y => 0.0, z => 0.0, tilt => 90.0, c => 0.0, tilt_letter => "B",
            },
        ),
        ("tilted_plane_off", context! {}),
        ("tcp_on", context! { number => 1u32 }),
        ("tcp_off", context! { number => 1u32 }),
        (
            "probe_move",
            context! {
                words => words(), x => 1.0, y => 2.0, z => 3.0,
                sx => 1.0, sy => 2.0, sz => 8.0, f => 100.0,
                axis => "Z", sign => "-", aligned => true,
            },
        ),
        (
            "probe_read",
            context! { x => 101u32, y => 102u32, z => 103u32 },
        ),
        ("log_open", context! { name => "sample", test => "sample" }),
        (
            "log_point",
            context! { index => 1usize, label => "P1", name => "sample" },
        ),
        ("log_close", context! { name => "sample" }),
        (
            "log_header_format",
            context! { name => "sample", test => "sample" },
        ),
        (
            "log_touch_format",
            context! { name => "sample", test => "sample" },
        ),
        ("dwell", context! { seconds => 1.0 }),
        ("stop", context! { text => "sample" }),
    ]
}
