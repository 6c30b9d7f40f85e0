//! What a user reads after a rewrite: the summary of what was corrected,
//! held, kept and left as written, with the lines of each, and the note on
//! rotary positions a run was told to assume. Shared by `compensate` and
//! `simulate nc`, so that both say the same thing in the same words.

use std::fmt::Write as _;
use std::path::Path;

use super::{Lines, Reason, ReasonKind, Settings, Summary};
use crate::machine::{Machine, MachineOrigin};
use crate::nc::dialect::Detection;
use crate::numbers::count;

/// What `--rotary-start` makes a run assume, for its report (`None` when
/// nothing is assumed).
pub fn rotary_start_note(start: &[(char, f64)]) -> Option<String> {
    if start.is_empty() {
        return None;
    }
    let axes: Vec<String> = start
        .iter()
        .map(|(a, v)| format!("{a} taken at {v} deg"))
        .collect();
    Some(format!(
        "{} before the first block, as --rotary-start states (until the program sets or forgets it)",
        axes.join(", ")
    ))
}

/// Moves left out, by kind of reason, then by reason, in one line:
/// `the file does not say: why: lines 3, 7; why: lines 9 | not
/// implemented yet: why: lines 12`.
pub fn reasons(skipped: &[(Reason, Lines)]) -> String {
    by_kind(skipped)
        .map(|(kind, of)| {
            let each: Vec<String> = of
                .map(|(why, lines)| format!("{why}: lines {}", lines.list()))
                .collect();
            format!("{kind}: {}", each.join("; "))
        })
        .collect::<Vec<_>>()
        .join(" | ")
}

/// The reasons of each kind present, kinds in [`ReasonKind::ALL`]'s
/// order, reasons in the order first met.
pub fn by_kind(
    skipped: &[(Reason, Lines)],
) -> impl Iterator<Item = (ReasonKind, impl Iterator<Item = &(Reason, Lines)>)> {
    ReasonKind::ALL.into_iter().filter_map(move |kind| {
        let mut of = skipped
            .iter()
            .filter(move |(r, _)| r.kind == kind)
            .peekable();
        of.peek()?;
        Some((kind, of))
    })
}

/// One rewrite as its summary names it: which program became which, on
/// which machine, with which errors, read in which dialect and how.
pub struct Rewrite<'a> {
    /// The program read.
    pub input: &'a Path,
    /// The program written.
    pub output: &'a Path,
    /// The machine.
    pub machine: &'a Machine,
    /// Where the machine came from (built in or a file).
    pub machine_origin: &'a MachineOrigin,
    /// The error file.
    pub errors: &'a Path,
    /// The dialect the program was read in, and why.
    pub detection: &'a Detection,
    /// The settings of the rewrite (tolerance, assumed rotary positions).
    pub settings: &'a Settings,
}

impl Summary {
    /// The summary a user reads after the rewrite `run`: one line per kind
    /// of event, each with its lines.
    pub fn describe(&self, run: &Rewrite<'_>) -> String {
        let s = self;
        let mut t = String::new();
        let m = run.machine;
        let _ = writeln!(
            t,
            "compensated {} -> {} (machine {} ({}), errors {})",
            run.input.display(),
            run.output.display(),
            m.name,
            run.machine_origin,
            run.errors.display()
        );
        let _ = writeln!(t, "  read as {}", run.detection);
        if let Some(n) = rotary_start_note(&run.settings.rotary_start) {
            let _ = writeln!(t, "  {n}");
        }
        let _ = writeln!(
            t,
            "  {}, {}: {}, {} ({}, {}) to stay within {} um",
            count(s.blocks, "block", "blocks"),
            count(s.moves, "move", "moves"),
            count(s.changed, "block changed", "blocks changed"),
            count(s.inserted, "block added", "blocks added"),
            count(s.subdivided.len(), "move subdivided", "moves subdivided"),
            count(s.linearized.len(), "arc linearized", "arcs linearized"),
            run.settings.tolerance * 1e3
        );
        let _ = writeln!(
            t,
            "  {} of {} motion blocks (blocks that move an axis) corrected",
            s.corrected_blocks, s.motion_blocks
        );
        match (s.largest_linear, s.largest_rotary) {
            (Some(l), Some(r)) => {
                let _ = writeln!(
                    t,
                    "  largest correction: {:.2} um in X, Y, Z (line {}); {:.2} urad of tool orientation (line {})",
                    l.value, l.line, r.value, r.line
                );
            }
            _ => {
                let _ = writeln!(t, "  no move was corrected");
            }
        }
        if !s.held_c.is_empty() {
            let _ = writeln!(
                t,
                "  C held next to the tilt singularity (tool along C) in {} moves (lines {}): tip exact, tool axis within {:.1} urad",
                s.held_c.len(),
                s.held_c.list(),
                s.held_c_axis_error
            );
        }
        if !s.held_tilt.is_empty() {
            let _ = writeln!(
                t,
                "  {} held at its limit (the correction needs it a little beyond) in {} moves (lines {}): tip exact, tool axis within {:.1} urad",
                m.tilt.letter,
                s.held_tilt.len(),
                s.held_tilt.list(),
                s.held_tilt_axis_error
            );
        }
        if !s.tilted_plane.is_empty() {
            let _ = writeln!(
                t,
                "  3+2 in a tilted working plane: {} moves corrected in the plane (lines {}): tip exact; the tool axis keeps up to {:.1} urad of the machine's orientation error (not correctable by coordinates; the plane and its rotary positions are as written)",
                s.tilted_plane.len(),
                s.tilted_plane.list(),
                s.tilted_plane_axis_error
            );
        }
        if !s.drilled.is_empty() {
            let _ = writeln!(
                t,
                "  canned cycles: {} holes corrected at their bottom (lines {}): tip exact there; the cycle drills along the actual tool axis, which keeps up to {:.1} urad of the machine's orientation error (rotary positions as written), up to {:.2} um off the intended hole axis at the R level",
                s.drilled.len(),
                s.drilled.list(),
                s.drilled_axis_error,
                s.drilled_residual
            );
        }
        match s.coordinates.as_slice() {
            [] => {}
            [one] => {
                let _ = writeln!(t, "  coordinates: {} ({})", one.meaning, one.why);
            }
            many => {
                let _ = writeln!(t, "  coordinates, section by section:");
                for c in many {
                    let _ = writeln!(
                        t,
                        "    lines {}-{}: {} ({})",
                        c.lines.0, c.lines.1, c.meaning, c.why
                    );
                }
            }
        }
        if !s.unmodelled.is_empty() {
            let _ = writeln!(
                t,
                "  kept as written, effect not modelled (--strict refuses them):"
            );
            for (what, lines) in &s.unmodelled {
                let _ = writeln!(t, "    {what}: lines {}", lines.list());
            }
        }
        if let Some(m) = &s.macro_logic {
            let _ = writeln!(t, "  {m}");
        }
        if s.skipped.is_empty() {
            let _ = writeln!(t, "  no move left as written");
        } else {
            let moves = s.skipped_count() - s.unreadable.len();
            if s.unreadable.is_empty() {
                let _ = writeln!(t, "  {moves} moves left as written:");
            } else {
                let _ = writeln!(
                    t,
                    "  {moves} moves and {} unreadable blocks left as written (no correction across an unreadable block; --strict refuses them):",
                    s.unreadable.len()
                );
            }
            for (kind, of) in by_kind(&s.skipped) {
                let _ = writeln!(t, "    {kind} ({}):", kind.advice());
                for (reason, lines) in of {
                    let _ = writeln!(t, "      {reason}: lines {}", lines.list());
                }
            }
        }
        for n in &s.not_compensated {
            let _ = writeln!(t, "  not compensated: {n}");
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(of: &[usize]) -> Lines {
        let mut l = Lines::default();
        for &n in of {
            l.push(n);
        }
        l
    }

    #[test]
    fn reasons_name_each_reason_with_its_lines_under_its_kind() {
        let skipped = vec![
            (
                Reason::new(ReasonKind::NotImplemented, "unknown word"),
                lines(&[9]),
            ),
            (
                Reason::new(ReasonKind::Unsaid, "expression"),
                lines(&[3, 7]),
            ),
            (Reason::new(ReasonKind::Unsaid, "table value"), lines(&[11])),
        ];
        assert_eq!(
            reasons(&skipped),
            "the file does not say: expression: lines 3, 7; table value: lines 11 | not implemented yet: unknown word: lines 9"
        );
    }

    #[test]
    fn rotary_start_note_is_said_only_when_something_is_assumed() {
        assert_eq!(rotary_start_note(&[]), None);
        assert_eq!(
            rotary_start_note(&[('A', 0.0), ('C', 90.0)]).as_deref(),
            Some(
                "A taken at 0 deg, C taken at 90 deg before the first block, as --rotary-start states (until the program sets or forgets it)"
            )
        );
    }
}
