//! DMIS measurement programs (`.dmi`, ANSI/DMIS 105): one feature per plan
//! point, each probed once along its nominal normal. Between points the
//! probe goes up to a clearance height and comes down above a free point
//! from which the start of the probing move is in straight reach (the plan
//! gives the way the cutting tool came in), so it never crosses the piece.
//! The CMM's output (`F(label)`/`FA(label)` lines, read by
//! `formats::dmis`) pairs with the plan points by label.
//!
//! ```text
//! DMISMN/'stepped-square',05.0
//! UNITS/MM,ANGDEC
//! ...
//! F(B0C0-XP1)=FEAT/POINT,CART,20.000000,-10.000000,97.500000,1.000000,0.000000,0.000000
//! GOTO/CART,25.000000,-10.000000,125.000000
//! GOTO/CART,25.000000,-10.000000,110.000000
//! GOTO/CART,25.000000,-10.000000,97.500000
//! MEAS/POINT,F(B0C0-XP1),1
//! PTMEAS/CART,20.000000,-10.000000,97.500000,1.000000,0.000000,0.000000
//! ENDMES
//! GOTO/CART,25.000000,-10.000000,110.000000
//! GOTO/CART,25.000000,-10.000000,125.000000
//! OUTPUT/FA(B0C0-XP1)
//! ENDFIL
//! ```

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::points::{PlanPoint, fmt_num};

/// How the probe moves between points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DmisMoves {
    /// Distance from the surface where each probing move starts, mm.
    pub approach: f64,
    /// Z (in the part frame, = W) above the whole piece for moves between points, mm.
    pub clear_z: f64,
}

/// One point to probe with the free point the probe reaches it from.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeTarget {
    /// The plan point.
    pub point: PlanPoint,
    /// A point in free space with a straight way to the start of the
    /// probing move (`point + approach * n`) and straight below the
    /// clearance height.
    pub free: Vector3<f64>,
}

/// Writes a DMIS program measuring every point along its normal.
pub fn program(name: &str, comments: &[String], items: &[ProbeTarget], moves: DmisMoves) -> String {
    let mut s = String::new();
    let n = |v: f64| fmt_num(v, 6);
    let _ = writeln!(s, "DMISMN/'{name}',05.0");
    for c in comments {
        let _ = writeln!(s, "$$ {}", c.replace('\n', " "));
    }
    let _ = writeln!(s, "UNITS/MM,ANGDEC");
    let _ = writeln!(s, "MODE/AUTO,PROG,MAN");
    let _ = writeln!(s, "SNSET/APPRCH,{}", n(moves.approach));
    let _ = writeln!(s, "SNSET/RETRCT,{}", n(moves.approach));
    let _ = writeln!(s, "SNSET/SEARCH,{}", n(moves.approach));
    let goto = |s: &mut String, v: &Vector3<f64>| {
        let _ = writeln!(s, "GOTO/CART,{},{},{}", n(v.x), n(v.y), n(v.z));
    };
    for it in items {
        let p = &it.point;
        let a = p.p + p.n * moves.approach;
        let up = Vector3::new(it.free.x, it.free.y, moves.clear_z);
        let _ = writeln!(
            s,
            "F({})=FEAT/POINT,CART,{},{},{},{},{},{}",
            p.label,
            n(p.p.x),
            n(p.p.y),
            n(p.p.z),
            n(p.n.x),
            n(p.n.y),
            n(p.n.z)
        );
        goto(&mut s, &up);
        goto(&mut s, &it.free);
        goto(&mut s, &a);
        let _ = writeln!(s, "MEAS/POINT,F({}),1", p.label);
        let _ = writeln!(
            s,
            "PTMEAS/CART,{},{},{},{},{},{}",
            n(p.p.x),
            n(p.p.y),
            n(p.p.z),
            n(p.n.x),
            n(p.n.y),
            n(p.n.z)
        );
        let _ = writeln!(s, "ENDMES");
        goto(&mut s, &it.free);
        goto(&mut s, &up);
    }
    for it in items {
        let _ = writeln!(s, "OUTPUT/FA({})", it.point.label);
    }
    let _ = writeln!(s, "ENDFIL");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_point_is_a_feature_probed_along_its_normal() {
        let pts = vec![ProbeTarget {
            point: PlanPoint {
                label: "B0C0-XP1".into(),
                pose: "B0C0".into(),
                seq: 0,
                tilt: 0.0,
                c: 0.0,
                p: Vector3::new(20.0, -10.0, 97.5),
                n: Vector3::x(),
            },
            free: Vector3::new(25.0, -10.0, 110.0),
        }];
        let text = program(
            "t",
            &["hello".into()],
            &pts,
            DmisMoves {
                approach: 5.0,
                clear_z: 125.0,
            },
        );
        assert!(text.starts_with("DMISMN/'t',05.0\n$$ hello\n"));
        assert!(text.contains("F(B0C0-XP1)=FEAT/POINT,CART,20.000000,-10.000000,97.500000,1.000000,0.000000,0.000000\n"));
        assert!(text.contains("GOTO/CART,25.000000,-10.000000,125.000000\nGOTO/CART,25.000000,-10.000000,110.000000\nGOTO/CART,25.000000,-10.000000,97.500000\nMEAS/POINT,F(B0C0-XP1),1\nPTMEAS/CART,20.000000,"));
        assert!(text.trim_end().ends_with("OUTPUT/FA(B0C0-XP1)\nENDFIL"));
    }
}
