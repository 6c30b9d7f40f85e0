//! Work offsets the program sets itself (G10 L2 / L20) and how they relate
//! to the offset in force at the program's first move, whose program zero
//! the user states (`--origin`).
//!
//! A control stores each work offset as a position in machine coordinates
//! (linear axes) and a rotary zero shift (machine rotary = programmed +
//! offset). Where the offsets lie in machine coordinates is not known to a
//! rewrite, only where the program zero of the offset in force at the
//! first move lies in W. What the program writes into the offsets is
//! known, so each axis of each offset is tracked as a value counted from a
//! base: machine zero for a value the program set, or the unknown value an
//! offset held when the program began. Two offsets are related on a linear
//! axis exactly when their values there count from the same base; the
//! rotary part is known outright when set, and the offsets the program
//! never sets carry none (as everywhere in fivecal: each lies on the W
//! origin at rotary zero).

/// One axis of a stored work offset, as far as the program tells: the base
/// it counts from ([`MACHINE_ZERO`] or the number of the offset whose value
/// at the program's start it is), and the amount added to that base (mm
/// for linear axes, deg for rotary ones); `None` when not known.
pub type OffsetAxis = Option<(u32, f64)>;

/// The base of a value the program set: machine zero.
pub const MACHINE_ZERO: u32 = u32::MAX;

/// The work offset data along a program.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WorkOffsets {
    /// The program has set work offset data (G10 L2 / L20). Until it does,
    /// every offset is taken with its program zero at `--origin`.
    pub set: bool,
    /// Why the offsets are not known any more (a G10 to an offset that is
    /// not identified, the FANUC external offset), if so.
    pub lost: Option<&'static str>,
    /// The offsets the program changed, with their values.
    values: Vec<(u32, [OffsetAxis; 6])>,
    /// The offset in force at the first move in work coordinates, and its
    /// values then.
    reference: Option<(u32, [OffsetAxis; 6])>,
}

/// Why the moves in a work offset are left as written.
pub const UNRELATED: &str = "a work offset whose relation to the one in force at the first move is not known (the program sets work offset data with G10 L2/L20, but not this offset's on every axis, or not from a known value)";

/// Why moves in a tilted plane or under G43.5 are left as written in an
/// offset with a rotary part.
pub const ROTARY_IN_PLANE: &str = "a work offset with a rotary part (set by G10) under a tilted working plane or G43.5, which fivecal does not model";

impl WorkOffsets {
    /// The values of offset `id` now.
    pub fn value(&self, id: u32) -> [OffsetAxis; 6] {
        self.values
            .iter()
            .find(|(o, _)| *o == id)
            .map(|(_, v)| *v)
            .unwrap_or([Some((id, 0.0)); 6])
    }

    /// Stores the values of offset `id`.
    pub fn store(&mut self, id: u32, v: [OffsetAxis; 6]) {
        self.set = true;
        match self.values.iter_mut().find(|(o, _)| *o == id) {
            Some(e) => e.1 = v,
            None => self.values.push((id, v)),
        }
    }

    /// Notes the offset in force at the first move in work coordinates
    /// (once).
    pub fn first_move(&mut self, id: u32) {
        if self.reference.is_none() {
            self.reference = Some((id, self.value(id)));
        }
    }

    /// What offset `id` adds now to the offset in force at the first move:
    /// X, Y, Z in mm (its program zero minus that one's, in machine axes)
    /// and the rotary zero shift of the machine's rotary axes `rotary` in
    /// deg (0 for the others); `None` where the relation is not known.
    pub fn shift(&self, id: u32, rotary: [usize; 2]) -> Option<[f64; 6]> {
        if !self.set {
            return Some([0.0; 6]);
        }
        if self.lost.is_some() {
            return None;
        }
        let now = self.value(id);
        let reference = self.reference.map_or(now, |(_, v)| v);
        let mut out = [0.0; 6];
        for i in 0..3 {
            match (now[i], reference[i]) {
                (Some((b, d)), Some((rb, rd))) if b == rb => out[i] = d - rd,
                _ => return None,
            }
        }
        for i in rotary {
            out[i] = now[i]?.1;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_set_from_machine_zero_relate_and_others_do_not() {
        let mut w = WorkOffsets::default();
        assert_eq!(w.shift(550, [3, 5]), Some([0.0; 6]), "nothing set yet");
        let set = |x: f64, c: f64| {
            [
                Some((MACHINE_ZERO, x)),
                Some((MACHINE_ZERO, 2.0 * x)),
                Some((MACHINE_ZERO, -x)),
                Some((MACHINE_ZERO, 0.0)),
                None,
                Some((MACHINE_ZERO, c)),
            ]
        };
        w.store(540, set(-100.0, 0.0));
        w.store(550, set(-160.0, 30.0));
        w.first_move(540);
        // The reference is taken once.
        w.first_move(550);
        assert_eq!(
            w.shift(550, [3, 5]),
            Some([-60.0, -120.0, 60.0, 0.0, 0.0, 30.0])
        );
        assert_eq!(w.shift(540, [3, 5]), Some([0.0; 6]));
        // B is unknown, and not an axis of an A/C machine.
        assert_eq!(w.shift(550, [4, 5]), None);
        // G56 was never set: its start value counts from its own base.
        assert_eq!(w.shift(560, [3, 5]), None);
        w.lost = Some("external offset");
        assert_eq!(w.shift(540, [3, 5]), None);
    }

    #[test]
    fn an_offset_changed_from_its_start_value_relates_to_itself() {
        let mut w = WorkOffsets::default();
        w.first_move(540);
        let mut v = w.value(540);
        v[0] = v[0].map(|(b, d)| (b, d + 1.5));
        w.store(540, v);
        assert_eq!(w.shift(540, [3, 5]), Some([1.5, 0.0, 0.0, 0.0, 0.0, 0.0]));
    }
}
