//! The nine-section test of Cubas Brizuela & Yeh 2023 (section 6, fig. 11, table 4): the top
//! face of a square block is cut in 3 x 3 sections, each at its own rotary
//! pose, with a ball or bull-nose end mill; section 1, the reference, is the
//! centre one at tilt = C = 0. All sections are cut to the same nominal
//! height, so the height of each section relative to section 1 shows the
//! machine's error at that pose.
//!
//! Each section (2..9) is put in the free cell its tool leans towards, so
//! the shank leans away from the rest of the piece. A section is cut by a
//! zigzag raster of contact-point passes spaced `stepover` apart, exactly on
//! the cell's borders, entered from outside the block where the cell
//! touches an edge (section 1 in the middle is entered by a plunge). The
//! points lie on raster passes, where the surface is exactly at the nominal
//! height (between passes the scallops stand higher), and away from the
//! borders by at least the tool radius, so no neighbouring section's tool
//! touches them.

use nalgebra::{Matrix3, Vector3};

use super::template::NineSectionTemplate;
use crate::kinematics::Kinematics;
use crate::limits::MAX_PLAN_MOVES;
use crate::machine::{Tool, ToolKind};
use crate::mesh::{Csg, Cuboid, HalfSpace, Polygon, Solid};
use crate::procedure::bounds::{echo, total};
use crate::procedure::machining::Pass;
use crate::procedure::machining::cutter::ToolPart;
use crate::procedure::machining::design::{
    MachiningDesign, PointDesign, PoseDesign, Stroke, check_work_area, dir_name, groups,
    pose_frame, tool_of, within_limits,
};
use crate::procedure::{PlanConfig, PlanError, short};

/// The tool tip that puts the lowest point of a ball or bull-nose tool with
/// axis `u` at the contact point `c` on a horizontal face.
pub(crate) fn tip_for_contact(
    c: &Vector3<f64>,
    u: &Vector3<f64>,
    radius: f64,
    corner: f64,
) -> Vector3<f64> {
    let z = Vector3::z();
    let w = u * z.dot(u) - z;
    let w = if w.norm() < 1e-12 {
        Vector3::zeros()
    } else {
        w.normalize()
    };
    c + z * corner - u * corner - w * (radius - corner)
}

const CELLS: [(i32, i32); 8] = [
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
    (0, -1),
    (1, -1),
    (1, 0),
    (1, 1),
];

/// The grid of sections on the block's top face and how each is cut, in W (mm).
struct Grid {
    /// Half the block's side.
    l: f64,
    /// A section's side.
    w: f64,
    /// The height every section is cut to.
    h: f64,
    /// Offset of the outer points from a section's centre.
    d: f64,
    /// Raster passes per section, less one, and their spacing.
    so_n: usize,
    so: f64,
    /// The tool's radius and corner radius.
    radius: f64,
    corner: f64,
    /// Clearance outside the block where a raster pass starts.
    air: f64,
}

pub(crate) fn design(
    cfg: &PlanConfig,
    t: &NineSectionTemplate,
    raise: f64,
) -> Result<MachiningDesign, PlanError> {
    let riser = t.stock.fixture_height + raise;
    let m = &cfg.machine;
    let src = &t.source;
    let tool = tool_of(cfg, &t.tool);
    if tool.kind == ToolKind::Flat {
        return Err(PlanError::Impossible(format!(
            "the nine-section test needs a ball or bull-nose end mill (Cubas Brizuela & Yeh 2023: round-tip tool); tool T{} `{}` is flat",
            tool.number, tool.name
        )));
    }
    check_work_area(cfg, src, t.stock.size, &tool)?;
    let k = Kinematics::with_gauge_length(m, tool.length);
    let radius = tool.diameter / 2.0;
    let corner = match tool.kind {
        ToolKind::Ball => radius,
        _ => tool.corner_radius.unwrap_or(0.0),
    };
    let size = t.stock.size;
    let l = size / 2.0;
    let w = size / 3.0;
    let zb = m.table.surface + riser;
    let zt = zb + t.stock.height;
    let h = zt - t.depth;
    let d = point_offset(t, radius)?;

    let mut sections = vec![(0.0, 0.0)];
    sections.extend(t.sections.iter().map(|s| (s.tilt, s.c)));
    let mut notes = Vec::new();
    let (frames, leans) = section_frames(&k, t, &sections)?;
    let cells = assign_cells(m.tilt_letter(), &sections, &leans, &mut notes);

    // Counted before any pass is made: each of the nine sections is
    // rastered in passes `stepover` apart, two moves a pass.
    let passes = (w / t.cutting.stepover).ceil().max(1.0) + 1.0;
    total(
        src,
        &["cutting", "stepover"],
        sections.len() as f64 * 2.0 * passes,
        MAX_PLAN_MOVES,
        "moves",
        &format!(
            "sections of {} mm rastered in passes {} mm apart (cutting.stepover): raise it",
            short(w),
            echo(t.cutting.stepover)
        ),
    )?;
    let so_n = (w / t.cutting.stepover).ceil().max(1.0) as usize;
    let grid = Grid {
        l,
        w,
        h,
        d,
        so_n,
        so: w / so_n as f64,
        radius,
        corner,
        air: t.clearance.rapid.max(1.0),
    };
    let mut poses = Vec::new();
    let mut points = Vec::new();
    for (i, (&(tilt, c), &cell)) in sections.iter().zip(&cells).enumerate() {
        let pose = grid.cut(i, tilt, c, cell, &frames[i]);
        points.extend(grid.points(t, &tool, i, &pose, cell));
        poses.push(pose);
    }

    let stock = Cuboid::aligned(Vector3::new(-l, -l, zb), Vector3::new(l, l, zt), 0);
    let (solid, csg) = grid.piece(zb, &cells);
    let ids: Vec<String> = poses.iter().map(|p| p.id.clone()).collect();
    let groups = groups(&ids);
    let fixture = (riser > 0.0).then(|| {
        Cuboid::aligned(
            Vector3::new(-l, -l, m.table.surface),
            Vector3::new(l, l, zb),
            u32::MAX,
        )
    });
    Ok(MachiningDesign {
        title: "nine-section machining test (Cubas Brizuela & Yeh 2023)".into(),
        description: format!(
            "9 sections of {} x {} mm cut to Z{} in W; {} CMM points; result: each section's height relative to section 1",
            short(w),
            short(w),
            short(h),
            points.len()
        ),
        program_number: 1002,
        tool,
        cutting: t.cutting.clone(),
        clearance: t.clearance.clone(),
        stock,
        fixture,
        solid,
        csg,
        groups,
        poses,
        points,
        notes,
        stock_text: format!(
            "block {} x {} x {} mm, centred on the W origin in X and Y, on a {} mm riser (bottom at Z{} in W); cut {} mm deep",
            short(size),
            short(size),
            short(t.stock.height),
            short(riser),
            short(zb),
            short(t.depth)
        ),
    })
}

/// The offset of a section's outer points from its centre, refused when the
/// cut is deeper than the block, the sections leave no room for points away
/// from their borders, or more points are asked for than there are places.
fn point_offset(t: &NineSectionTemplate, radius: f64) -> Result<f64, PlanError> {
    let src = &t.source;
    let size = t.stock.size;
    let w = size / 3.0;
    if t.depth >= t.stock.height {
        return Err(src
            .error(
                &["depth"],
                format!(
                    "depth {} mm must be less than the stock height {} mm",
                    t.depth, t.stock.height
                ),
            )
            .into());
    }
    let margin = t.point_margin.max(radius + 0.5);
    let d = w / 2.0 - margin;
    if d < 0.5 {
        return Err(src
            .error(
                &["stock", "size"],
                format!(
                    "sections of {} mm (stock.size {size} / 3) leave no room for points {margin} mm (at least the tool radius + 0.5) from their borders: stock.size must be at least {}",
                    short(w),
                    short(6.0 * (margin + 0.5))
                ),
            )
            .into());
    }
    if t.points_per_section > 9 {
        return Err(src
            .error(
                &["points", "per_section"],
                format!("at most 9 points per section, got {}", t.points_per_section),
            )
            .into());
    }
    Ok(d)
}

/// Each section's frame and the horizontal direction its tool leans,
/// refused beyond the axis limits or tilted more than 75 deg from the top
/// face's normal.
#[allow(clippy::type_complexity)]
fn section_frames(
    k: &Kinematics,
    t: &NineSectionTemplate,
    sections: &[(f64, f64)],
) -> Result<(Vec<Matrix3<f64>>, Vec<Vector3<f64>>), PlanError> {
    let m = k.machine();
    let src = &t.source;
    let letter = m.tilt_letter();
    let mut leans = Vec::new();
    let mut frames = Vec::new();
    for (i, &(tilt, c)) in sections.iter().enumerate() {
        within_limits(m, letter, tilt)
            .and_then(|_| within_limits(m, 'C', c))
            .map_err(|e| src.error(&["sections"], format!("section {}: {e}", i + 1)))?;
        let f = pose_frame(k, tilt, c);
        let u: Vector3<f64> = f.column(2).into_owned();
        if u.z < 75f64.to_radians().cos() {
            return Err(src
                .error(
                    &["sections"],
                    format!(
                        "section {} ({letter} = {tilt}, C = {c}) tilts the tool {:.1} deg from the top face's normal: at most 75 deg",
                        i + 1,
                        u.z.clamp(-1.0, 1.0).acos().to_degrees()
                    ),
                )
                .into());
        }
        let lean = Vector3::new(u.x, u.y, 0.0);
        leans.push(if lean.norm() < 1e-9 {
            Vector3::zeros()
        } else {
            lean.normalize()
        });
        frames.push(f);
    }
    Ok((frames, leans))
}

/// The cell of each section: section 1 in the centre, sections 2..9 in the
/// eight outer cells so that the tools lean outwards as well as possible
/// (the best of all 8! assignments; the first in lexicographic order wins
/// ties), with a note for a section left leaning inwards.
fn assign_cells(
    letter: char,
    sections: &[(f64, f64)],
    leans: &[Vector3<f64>],
    notes: &mut Vec<String>,
) -> Vec<(i32, i32)> {
    let score = |cell: (i32, i32), lean: &Vector3<f64>| {
        Vector3::new(cell.0 as f64, cell.1 as f64, 0.0)
            .normalize()
            .dot(lean)
    };
    let mut best: (f64, Vec<usize>) = (f64::NEG_INFINITY, Vec::new());
    let mut perm: Vec<usize> = Vec::new();
    let mut used = [false; 8];
    fn search(
        perm: &mut Vec<usize>,
        used: &mut [bool; 8],
        acc: f64,
        eval: &dyn Fn(usize, usize) -> f64,
        best: &mut (f64, Vec<usize>),
    ) {
        if perm.len() == 8 {
            if acc > best.0 + 1e-9 {
                *best = (acc, perm.clone());
            }
            return;
        }
        for c in 0..8 {
            if !used[c] {
                used[c] = true;
                let s = eval(perm.len(), c);
                perm.push(c);
                search(perm, used, acc + s, eval, best);
                perm.pop();
                used[c] = false;
            }
        }
    }
    let eval = |section: usize, cell: usize| score(CELLS[cell], &leans[section + 1]);
    search(&mut perm, &mut used, 0.0, &eval, &mut best);
    let mut cells = vec![(0, 0)];
    for (k, &c) in best.1.iter().enumerate() {
        if score(CELLS[c], &leans[k + 1]) < -1e-9 {
            notes.push(format!(
                "section {} ({letter} = {}, C = {}) leans its tool towards the piece centre: no free cell lies the way it leans",
                k + 2,
                sections[k + 1].0,
                sections[k + 1].1
            ));
        }
        cells.push(CELLS[c]);
    }
    cells
}

impl Grid {
    /// The raster of a cell: along x or not, where each pass starts and
    /// ends, and the across coordinate of the first pass. Along x when the
    /// cell touches a side at x = +-L (entered there), else along y when it
    /// touches y = +-L, else (the centre) along x with a plunge.
    fn raster(&self, (ci, cj): (i32, i32)) -> (bool, f64, f64, f64) {
        let Grid {
            l, w, radius, air, ..
        } = *self;
        let (cx, cy) = (ci as f64 * w, cj as f64 * w);
        let along_x = ci != 0 || cj == 0;
        let (outer, inner, across_lo) = if along_x {
            let outer = if ci != 0 {
                ci as f64 * (l + radius + air)
            } else {
                cx - w / 2.0
            };
            let inner = if ci != 0 {
                ci as f64 * (w / 2.0)
            } else {
                cx + w / 2.0
            };
            (outer, inner, cy - w / 2.0)
        } else {
            (
                cj as f64 * (l + radius + air),
                cj as f64 * (w / 2.0),
                cx - w / 2.0,
            )
        };
        (along_x, outer, inner, across_lo)
    }

    /// Section `i`'s pose: a zigzag raster of contact-point passes over its
    /// cell, each pass's tip placed so the tool touches the cut height.
    fn cut(
        &self,
        i: usize,
        tilt: f64,
        c: f64,
        (ci, cj): (i32, i32),
        f: &Matrix3<f64>,
    ) -> PoseDesign {
        let Grid {
            w,
            h,
            so_n,
            so,
            radius,
            corner,
            ..
        } = *self;
        let u: Vector3<f64> = f.column(2).into_owned();
        let (along_x, outer, inner, across_lo) = self.raster((ci, cj));
        let contact = |along: f64, across: f64| {
            if along_x {
                Vector3::new(along, across, h)
            } else {
                Vector3::new(across, along, h)
            }
        };
        let tip = |p: Vector3<f64>| tip_for_contact(&p, &u, radius, corner);
        let start = tip(contact(outer, across_lo));
        let mut segs = Vec::new();
        for kk in 0..=so_n {
            let across = across_lo + kk as f64 * so;
            let (from, to) = if kk % 2 == 0 {
                (outer, inner)
            } else {
                (inner, outer)
            };
            if kk > 0 {
                segs.push((tip(contact(from, across)), Pass::Finish));
            }
            segs.push((tip(contact(to, across)), Pass::Finish));
        }
        let lean = Vector3::new(u.x, u.y, 0.0);
        PoseDesign {
            id: format!("S{}", i + 1),
            tilt,
            c,
            axis: u,
            frame: *f,
            feature: format!(
                "section {}{}: cell {}, {} x {} mm at Z{} in W{}",
                i + 1,
                if i == 0 { " (reference)" } else { "" },
                cell_name(ci, cj),
                short(w),
                short(w),
                short(h),
                if lean.norm() > 1e-9 {
                    format!(", tool leaning {}", dir_name(&lean.normalize()))
                } else {
                    String::new()
                }
            ),
            strokes: vec![Stroke { start, segs }],
        }
    }

    /// Section `i`'s CMM points: centre, corners, then edge middles, each
    /// snapped onto the nearest raster pass (where the surface is exactly at
    /// the cut height).
    fn points(
        &self,
        t: &NineSectionTemplate,
        tool: &Tool,
        i: usize,
        pose: &PoseDesign,
        (ci, cj): (i32, i32),
    ) -> Vec<PointDesign> {
        let Grid { w, h, d, so, .. } = *self;
        let u = pose.axis;
        let part = match tool.kind {
            ToolKind::Ball => ToolPart::Ball,
            _ if (u - Vector3::z()).norm() < 1e-12 => ToolPart::FlatEnd,
            _ => ToolPart::Torus,
        };
        let (cx, cy) = (ci as f64 * w, cj as f64 * w);
        let (along_x, _, _, across_lo) = self.raster((ci, cj));
        let offsets = [
            (0.0, 0.0),
            (d, d),
            (-d, d),
            (-d, -d),
            (d, -d),
            (d, 0.0),
            (0.0, d),
            (-d, 0.0),
            (0.0, -d),
        ];
        let mut points = Vec::new();
        for (n, &(ox, oy)) in offsets.iter().take(t.points_per_section).enumerate() {
            let (mut x, mut y) = (cx + ox, cy + oy);
            if along_x {
                y = across_lo + ((y - across_lo) / so).round() * so;
            } else {
                x = across_lo + ((x - across_lo) / so).round() * so;
            }
            points.push(PointDesign {
                label: format!("{}-{}", pose.id, n + 1),
                pose: i,
                p: Vector3::new(x, y, h),
                n: Vector3::z(),
                surface: format!("section {}", i + 1),
                part,
            });
        }
        points
    }

    /// The piece: the block (bottom at `zb`) cut down to the cut height, its
    /// top split by section.
    fn piece(&self, zb: f64, cells: &[(i32, i32)]) -> (Solid, Csg) {
        let Grid { l, w, h, .. } = *self;
        let piece = Cuboid::aligned(Vector3::new(-l, -l, zb), Vector3::new(l, l, h), 0);
        let solid = Solid::Cuboid(piece.clone());
        let mut polys: Vec<Polygon> = Solid::Cuboid(piece)
            .to_csg()
            .polygons
            .into_iter()
            .filter(|p| p.plane.n.z < 0.5)
            .collect();
        for (i, &(ci, cj)) in cells.iter().enumerate() {
            let (cx, cy) = (ci as f64 * w, cj as f64 * w);
            let (x0, x1, y0, y1) = (cx - w / 2.0, cx + w / 2.0, cy - w / 2.0, cy + w / 2.0);
            polys.push(Polygon {
                vertices: vec![
                    Vector3::new(x0, y0, h),
                    Vector3::new(x1, y0, h),
                    Vector3::new(x1, y1, h),
                    Vector3::new(x0, y1, h),
                ],
                plane: HalfSpace {
                    n: Vector3::z(),
                    w: h,
                },
                tag: i as u32 + 1,
            });
        }
        (solid, Csg { polygons: polys })
    }
}

fn cell_name(i: i32, j: i32) -> &'static str {
    match (i, j) {
        (0, 0) => "centre",
        (0, 1) => "+Y edge",
        (0, -1) => "-Y edge",
        (1, 0) => "+X edge",
        (-1, 0) => "-X edge",
        (1, 1) => "+X+Y corner",
        (-1, 1) => "-X+Y corner",
        (-1, -1) => "-X-Y corner",
        _ => "+X-Y corner",
    }
}
