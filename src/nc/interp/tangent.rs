//! HEIDENHAIN `CT`: the circular path that starts tangent to the contour
//! element before it and ends at the programmed point. The arc is fixed by
//! three things: where it starts, the direction the element before it
//! ends in, and its end point; its centre lies on the normal of that
//! direction at the start, as far from the start as from the end.
//!
//! Source (read): HEIDENHAIN iTNC 530 conversational programming user's
//! manual, 6.4 "Circular path CT with tangential connection" (p. 225 of
//! the 2006 edition, p. 237 of 60642x-03), and TNC 640 user's manual
//! 10/2017 p. 306: "the tool moves on an arc that starts tangentially to
//! the previously programmed contour element", which "must be programmed
//! immediately before the CT block"; "a tangential arc is a
//! two-dimensional operation: the coordinates in the CT block and in the
//! contour element preceding it must be in the same plane of the arc".
//! The TNC7 manual (81762x-16) adds that at most two axes define the end
//! point. The closed form below is derived from these.

/// The unit direction from `a` to `b` in the plane, if they differ.
pub fn direction(a: [f64; 2], b: [f64; 2]) -> Option<[f64; 2]> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let n = dx.hypot(dy);
    (n > 0.0 && n.is_finite()).then(|| [dx / n, dy / n])
}

/// The direction of travel at the end `e` of an arc around `center`
/// (clockwise or not), if `e` is not the centre.
pub fn arc_end_direction(center: [f64; 2], e: [f64; 2], cw: bool) -> Option<[f64; 2]> {
    let r = direction(center, e)?;
    Some(if cw { [r[1], -r[0]] } else { [-r[1], r[0]] })
}

/// The `CT` arc from `s`, leaving it in the unit direction `t`, to `e`:
/// its centre and whether it turns clockwise. Refused where the control
/// draws no circle: an end point on the start, or on the line through
/// the start along `t` (ahead of it a straight line, behind it no
/// circle at all). `mm`: millimetres per program unit; an end within
/// 0.1 nm of that line counts as on it.
pub fn tangent_arc(
    s: [f64; 2],
    t: [f64; 2],
    e: [f64; 2],
    mm: f64,
) -> Result<([f64; 2], bool), &'static str> {
    let d = [e[0] - s[0], e[1] - s[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    if len2 == 0.0 || len2.is_nan() {
        return Err("its end point is where it starts");
    }
    // The normal to the left of the direction of travel.
    let n = [-t[1], t[0]];
    let h = d[0] * n[0] + d[1] * n[1];
    if h.abs() * mm < 1e-7 {
        return Err("its end point lies on the tangent of the element before it (no circle)");
    }
    // |s + r n - e| = |r|: r = |d|^2 / (2 d.n), to the left when positive.
    let r = len2 / (2.0 * h);
    Ok(([s[0] + r * n[0], s[1] + r * n[1]], h < 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manual_s_example_leaves_the_line_tangentially_and_reaches_its_end() {
        // iTNC 530 example: L X+0 Y+25, L X+25 Y+30, CT X+45 Y+20.
        let (s, e) = ([25.0, 30.0], [45.0, 20.0]);
        let t = direction([0.0, 25.0], s).unwrap();
        let (c, cw) = tangent_arc(s, t, e, 1.0).unwrap();
        // Equidistant from start and end.
        let (rs, re) = (
            (s[0] - c[0]).hypot(s[1] - c[1]),
            (e[0] - c[0]).hypot(e[1] - c[1]),
        );
        assert!((rs - re).abs() < 1e-12, "{rs} {re}");
        // The radius is square to the line at the start.
        assert!(((s[0] - c[0]) * t[0] + (s[1] - c[1]) * t[1]).abs() < 1e-12);
        // The end lies to the right of the line: it turns clockwise, and
        // the arc's own direction at its start is the line's.
        assert!(cw);
        let start_dir = arc_end_direction(c, s, cw).unwrap();
        assert!((start_dir[0] - t[0]).abs() < 1e-12 && (start_dir[1] - t[1]).abs() < 1e-12);
        // Independently: the circle through s and e tangent to the line
        // y = 25 + x / 5 at s; its radius by the chord-tangent angle:
        // chord = 2 r sin(angle between tangent and chord).
        let chord = (e[0] - s[0]).hypot(e[1] - s[1]);
        let dc = direction(s, e).unwrap();
        let sin = (t[0] * dc[1] - t[1] * dc[0]).abs();
        assert!((rs - chord / (2.0 * sin)).abs() < 1e-12, "{rs}");
    }

    #[test]
    fn an_end_behind_the_start_turns_more_than_half_a_circle() {
        // Leaving (0, 0) along +X, ending at (-1, 2): the centre is (0, 1.25)
        // to the left, the arc turns counter-clockwise through more than
        // 180 degrees.
        let (c, cw) = tangent_arc([0.0, 0.0], [1.0, 0.0], [-1.0, 2.0], 1.0).unwrap();
        assert!(!cw);
        assert!((c[0]).abs() < 1e-15 && (c[1] - 1.25).abs() < 1e-15, "{c:?}");
        let geo = crate::nc::interp::interpolation::ArcGeo::new(
            (0, 1, 2),
            c,
            &[0.0; 6],
            &[-1.0, 2.0, 0.0, 0.0, 0.0, 0.0],
            cw,
            0,
        );
        assert!(geo.sweep > std::f64::consts::PI, "{}", geo.sweep);
    }

    #[test]
    fn an_end_on_the_tangent_is_refused() {
        assert!(tangent_arc([0.0, 0.0], [1.0, 0.0], [5.0, 0.0], 1.0).is_err());
        assert!(tangent_arc([0.0, 0.0], [1.0, 0.0], [-5.0, 0.0], 1.0).is_err());
        assert!(tangent_arc([0.0, 0.0], [1.0, 0.0], [0.0, 0.0], 1.0).is_err());
    }
}
