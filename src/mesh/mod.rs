//! Nominal test pieces as solids and meshes: a small CSG tree of oriented
//! boxes ([`Solid`]) that answers exact point-membership queries (used to
//! check that every plan point sits on the surface with its normal pointing
//! out of the material), its boundary as a polygon mesh ([`Mesh`], by BSP
//! CSG), and writers for Wavefront `.obj` and binary glTF `.glb`.
//!
//! Every face carries a tag naming the primitive it came from: the stock,
//! or the cut of one pose, so a viewer shows which pose made which surface.

mod csg;

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt::Write as _;

use nalgebra::{Matrix3, Vector3};

pub use csg::{Csg, HalfSpace, Polygon};

/// A box with its own orientation: `center + axes * u` for `|u_i| <= half_i`.
#[derive(Clone, Debug, PartialEq)]
pub struct Cuboid {
    /// Centre, mm.
    pub center: Vector3<f64>,
    /// Unit axes as columns (a right-handed rotation).
    pub axes: Matrix3<f64>,
    /// Half extents along the axes, mm.
    pub half: Vector3<f64>,
    /// Tag given to its faces.
    pub tag: u32,
}

impl Cuboid {
    /// An axis-aligned box from two corners.
    pub fn aligned(min: Vector3<f64>, max: Vector3<f64>, tag: u32) -> Cuboid {
        Cuboid {
            center: (min + max) / 2.0,
            axes: Matrix3::identity(),
            half: (max - min) / 2.0,
            tag,
        }
    }

    /// Local coordinates of a point.
    pub fn local(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.axes.transpose() * (p - self.center)
    }

    /// Whether `p` is inside or on the boundary.
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        let u = self.local(p);
        (0..3).all(|i| u[i].abs() <= self.half[i])
    }

    fn polygons(&self) -> Vec<Polygon> {
        let mut out = Vec::with_capacity(6);
        for i in 0..3 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let (ai, aj, ak) = (
                self.axes.column(i).into_owned(),
                self.axes.column(j).into_owned(),
                self.axes.column(k).into_owned(),
            );
            for s in [1.0, -1.0] {
                let c = self.center + ai * (s * self.half[i]);
                let mut v: Vec<Vector3<f64>> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                    .iter()
                    .map(|&(sj, sk)| c + aj * (sj * self.half[j]) + ak * (sk * self.half[k]))
                    .collect();
                if s < 0.0 {
                    v.reverse();
                }
                let n = ai * s;
                out.push(Polygon {
                    plane: HalfSpace { n, w: n.dot(&c) },
                    vertices: v,
                    tag: self.tag,
                });
            }
        }
        out
    }
}

/// A CSG tree of boxes.
#[derive(Clone, Debug, PartialEq)]
pub enum Solid {
    /// One box.
    Cuboid(Cuboid),
    /// The first solid minus all the others.
    Difference(Box<Solid>, Vec<Solid>),
    /// The union of the solids.
    Union(Vec<Solid>),
}

impl Solid {
    /// Whether `p` is in the solid (boundaries count as inside for boxes
    /// and as outside where a subtracted solid's boundary is; query points
    /// off the boundary).
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        match self {
            Solid::Cuboid(b) => b.contains(p),
            Solid::Difference(a, cuts) => a.contains(p) && !cuts.iter().any(|c| c.contains(p)),
            Solid::Union(parts) => parts.iter().any(|s| s.contains(p)),
        }
    }

    /// The boundary as polygons.
    pub(crate) fn to_csg(&self) -> Csg {
        match self {
            Solid::Cuboid(b) => Csg {
                polygons: b.polygons(),
            },
            Solid::Difference(a, cuts) => cuts
                .iter()
                .fold(a.to_csg(), |acc, c| acc.subtract(&c.to_csg())),
            Solid::Union(parts) => {
                let mut it = parts.iter();
                let first = it.next().map(|s| s.to_csg()).unwrap_or_default();
                it.fold(first, |acc, s| acc.union(&s.to_csg()))
            }
        }
    }
}

/// A triangle with its tag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertices, counter-clockwise seen from outside.
    pub v: [Vector3<f64>; 3],
    /// Outward unit normal.
    pub n: Vector3<f64>,
    /// Tag of the face it belongs to.
    pub tag: u32,
}

/// A closed triangle mesh with named face groups.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Triangles.
    pub triangles: Vec<Triangle>,
    /// Group name of each tag.
    pub groups: BTreeMap<u32, String>,
}

impl Mesh {
    /// Triangulates a polygon set (fans; the polygons are convex).
    pub(crate) fn from_csg(csg: &Csg, groups: BTreeMap<u32, String>) -> Mesh {
        let mut triangles = Vec::new();
        for p in &csg.polygons {
            if p.area() < 1e-10 {
                continue;
            }
            let v = &p.vertices;
            for i in 1..v.len() - 1 {
                let t = [v[0], v[i], v[i + 1]];
                if (t[1] - t[0]).cross(&(t[2] - t[0])).norm() < 1e-12 {
                    continue;
                }
                triangles.push(Triangle {
                    v: t,
                    n: p.plane.n,
                    tag: p.tag,
                });
            }
        }
        Mesh { triangles, groups }
    }

    /// Enclosed volume, mm^3.
    pub fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| t.v[0].dot(&t.v[1].cross(&t.v[2])))
            .sum::<f64>()
            / 6.0
    }

    /// Distance from `p` to the surface, mm, with the triangle reached.
    pub fn distance(&self, p: &Vector3<f64>) -> (f64, Option<&Triangle>) {
        let mut best = (f64::INFINITY, None);
        for t in &self.triangles {
            let d = (closest_on_triangle(p, &t.v) - p).norm();
            if d < best.0 {
                best = (d, Some(t));
            }
        }
        best
    }

    /// Whether `p` is inside (ray parity along a fixed skew direction).
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        let dir = Vector3::new(0.5773, 0.5774, 0.5773_5).normalize();
        let dir = (dir + Vector3::new(1.3e-3, -2.7e-3, 0.9e-3)).normalize();
        let mut hits = 0;
        for t in &self.triangles {
            if ray_hits(p, &dir, &t.v) {
                hits += 1;
            }
        }
        hits % 2 == 1
    }

    fn group_name(&self, tag: u32) -> String {
        self.groups
            .get(&tag)
            .cloned()
            .unwrap_or_else(|| format!("face{tag}"))
    }

    /// Wavefront OBJ text: shared vertices (6 decimals), one `g` group per
    /// tag, triangles counter-clockwise from outside.
    pub fn to_obj(&self, title: &str) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# {title}");
        let _ = writeln!(s, "# units: mm, frame: W (fivecal)");
        let mut index: BTreeMap<[i64; 3], usize> = BTreeMap::new();
        let mut verts: Vec<Vector3<f64>> = Vec::new();
        let key = |v: &Vector3<f64>| {
            [
                (v.x * 1e6).round() as i64,
                (v.y * 1e6).round() as i64,
                (v.z * 1e6).round() as i64,
            ]
        };
        let mut faces: BTreeMap<u32, Vec<[usize; 3]>> = BTreeMap::new();
        for t in &self.triangles {
            let mut f = [0usize; 3];
            for (k, v) in t.v.iter().enumerate() {
                let n = verts.len();
                let i = *index.entry(key(v)).or_insert(n);
                if i == n {
                    verts.push(*v);
                }
                f[k] = i + 1;
            }
            faces.entry(t.tag).or_default().push(f);
        }
        for v in &verts {
            let _ = writeln!(
                s,
                "v {} {} {}",
                crate::numbers::fmt_num(v.x, 6),
                crate::numbers::fmt_num(v.y, 6),
                crate::numbers::fmt_num(v.z, 6)
            );
        }
        for (tag, fs) in &faces {
            let _ = writeln!(s, "g {}", self.group_name(*tag));
            for f in fs {
                let _ = writeln!(s, "f {} {} {}", f[0], f[1], f[2]);
            }
        }
        s
    }

    /// Binary glTF: one named node and mesh per tag, flat-shaded triangles
    /// (positions and normals as f32; positions in metres, glTF's unit, so
    /// a viewer shows a 100 mm block as 0.1 m like the report's `.glb`).
    pub fn to_glb(&self, title: &str) -> Vec<u8> {
        use gltf_json as json;
        use json::validation::Checked::Valid;
        use json::validation::USize64;

        let mut root = json::Root {
            asset: json::Asset {
                generator: Some(format!("fivecal {}", env!("CARGO_PKG_VERSION"))),
                copyright: None,
                extensions: None,
                extras: Default::default(),
                min_version: None,
                version: "2.0".into(),
            },
            ..Default::default()
        };
        let mut bin: Vec<u8> = Vec::new();
        let mut groups: BTreeMap<u32, Vec<&Triangle>> = BTreeMap::new();
        for t in &self.triangles {
            groups.entry(t.tag).or_default().push(t);
        }
        // Buffer views are pushed after the buffer exists; collect first.
        struct Pending {
            name: String,
            pos: (usize, usize, [f32; 3], [f32; 3]),
            nor: (usize, usize),
            count: usize,
        }
        let mut pending = Vec::new();
        for (tag, tris) in &groups {
            let start = bin.len();
            let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
            for t in tris {
                for v in &t.v {
                    for i in 0..3 {
                        let x = (v[i] * 1e-3) as f32;
                        lo[i] = lo[i].min(x);
                        hi[i] = hi[i].max(x);
                        bin.extend_from_slice(&x.to_le_bytes());
                    }
                }
            }
            let pos_len = bin.len() - start;
            let nstart = bin.len();
            for t in tris {
                for _ in 0..3 {
                    for i in 0..3 {
                        bin.extend_from_slice(&(t.n[i] as f32).to_le_bytes());
                    }
                }
            }
            pending.push(Pending {
                name: self.group_name(*tag),
                pos: (start, pos_len, lo, hi),
                nor: (nstart, bin.len() - nstart),
                count: tris.len() * 3,
            });
        }
        let buffer = root.push(json::Buffer {
            byte_length: USize64::from(bin.len()),
            extensions: Default::default(),
            extras: Default::default(),
            name: Some(title.to_string()),
            uri: None,
        });
        let mut nodes = Vec::new();
        for p in pending {
            let view = |root: &mut json::Root, off: usize, len: usize| {
                root.push(json::buffer::View {
                    buffer,
                    byte_length: USize64::from(len),
                    byte_offset: Some(USize64::from(off)),
                    byte_stride: None,
                    extensions: Default::default(),
                    extras: Default::default(),
                    name: None,
                    target: Some(Valid(json::buffer::Target::ArrayBuffer)),
                })
            };
            let pv = view(&mut root, p.pos.0, p.pos.1);
            let pa = vec3_accessor(&mut root, pv, 0, p.count, Some((p.pos.2, p.pos.3)));
            let nv = view(&mut root, p.nor.0, p.nor.1);
            let na = vec3_accessor(&mut root, nv, 0, p.count, None);
            let primitive = json::mesh::Primitive {
                attributes: {
                    let mut map = BTreeMap::new();
                    map.insert(Valid(json::mesh::Semantic::Positions), pa);
                    map.insert(Valid(json::mesh::Semantic::Normals), na);
                    map
                },
                extensions: Default::default(),
                extras: Default::default(),
                indices: None,
                material: None,
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            };
            let mesh = root.push(json::Mesh {
                extensions: Default::default(),
                extras: Default::default(),
                name: Some(p.name.clone()),
                primitives: vec![primitive],
                weights: None,
            });
            nodes.push(root.push(json::Node {
                mesh: Some(mesh),
                name: Some(p.name),
                ..Default::default()
            }));
        }
        let scene = root.push(json::Scene {
            extensions: Default::default(),
            extras: Default::default(),
            name: Some(title.to_string()),
            nodes,
        });
        root.scene = Some(scene);
        let json_text = json::serialize::to_string(&root).expect("glTF JSON serializes");
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                // to_vec recomputes the length.
                length: 0,
            },
            json: Cow::Owned(json_text.into_bytes()),
            bin: Some(Cow::Owned(bin)),
        };
        glb.to_vec().expect("GLB serializes")
    }
}

/// Closest point of a triangle to `p` (Ericson, Real-Time Collision Detection 5.1.5).
pub fn closest_on_triangle(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> Vector3<f64> {
    let (a, b, c) = (t[0], t[1], t[2]);
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Möller-Trumbore: whether the ray `o + s d`, s > 0, crosses the triangle.
fn ray_hits(o: &Vector3<f64>, d: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> bool {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let h = d.cross(&e2);
    let a = e1.dot(&h);
    if a.abs() < 1e-14 {
        return false;
    }
    let f = 1.0 / a;
    let s = o - t[0];
    let u = f * s.dot(&h);
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(&e1);
    let v = f * d.dot(&q);
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    f * e2.dot(&q) > 1e-12
}

/// A `VEC3` float accessor of `count` items at `offset` bytes into `view`.
pub(crate) fn vec3_accessor(
    root: &mut gltf_json::Root,
    view: gltf_json::Index<gltf_json::buffer::View>,
    offset: usize,
    count: usize,
    minmax: Option<([f32; 3], [f32; 3])>,
) -> gltf_json::Index<gltf_json::Accessor> {
    use gltf_json as json;
    use json::validation::Checked::Valid;
    use json::validation::USize64;
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64::from(offset)),
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(
            json::accessor::ComponentType::F32,
        )),
        extensions: Default::default(),
        extras: Default::default(),
        type_: Valid(json::accessor::Type::Vec3),
        min: minmax.map(|m| json::Value::from(Vec::from(m.0))),
        max: minmax.map(|m| json::Value::from(Vec::from(m.1))),
        name: None,
        normalized: false,
        sparse: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stepped() -> Solid {
        let stock = Solid::Cuboid(Cuboid::aligned(
            Vector3::new(-50.0, -50.0, 0.0),
            Vector3::new(50.0, 50.0, 60.0),
            0,
        ));
        // Cut everything above z = 55 outside a 40 x 40 boss.
        let cut = Solid::Difference(
            Box::new(Solid::Cuboid(Cuboid::aligned(
                Vector3::new(-60.0, -60.0, 55.0),
                Vector3::new(60.0, 60.0, 70.0),
                1,
            ))),
            vec![Solid::Cuboid(Cuboid::aligned(
                Vector3::new(-20.0, -20.0, 50.0),
                Vector3::new(20.0, 20.0, 80.0),
                1,
            ))],
        );
        Solid::Difference(Box::new(stock), vec![cut])
    }

    #[test]
    fn a_stepped_block_has_the_volume_of_its_closed_form() {
        let s = stepped();
        let mesh = Mesh::from_csg(&s.to_csg(), BTreeMap::new());
        let expected = 100.0 * 100.0 * 55.0 + 40.0 * 40.0 * 5.0;
        assert!((mesh.volume() - expected).abs() < 1e-6, "{}", mesh.volume());
        for p in [
            Vector3::new(0.0, 0.0, 57.0),
            Vector3::new(30.0, 0.0, 50.0),
            Vector3::new(-49.0, 49.0, 1.0),
        ] {
            assert!(s.contains(&p) && mesh.contains(&p), "{p:?}");
        }
        for p in [
            Vector3::new(30.0, 0.0, 57.0),
            Vector3::new(0.0, 0.0, 61.0),
            Vector3::new(51.0, 0.0, 10.0),
        ] {
            assert!(!s.contains(&p) && !mesh.contains(&p), "{p:?}");
        }
        // The floor of the step is on the mesh.
        assert!(mesh.distance(&Vector3::new(30.0, 10.0, 55.0)).0 < 1e-9);
        assert!(mesh.distance(&Vector3::new(20.0, 10.0, 57.0)).0 < 1e-9);
    }

    #[test]
    fn glb_and_obj_are_readable() {
        let mut groups = BTreeMap::new();
        groups.insert(0, "stock".to_string());
        groups.insert(1, "cut".to_string());
        let mesh = Mesh::from_csg(&stepped().to_csg(), groups);
        let glb = mesh.to_glb("t");
        let g = gltf::Gltf::from_slice(&glb).unwrap();
        let names: Vec<String> = g
            .meshes()
            .filter_map(|m| m.name().map(String::from))
            .collect();
        assert_eq!(names, ["stock", "cut"]);
        let obj = mesh.to_obj("t");
        assert!(obj.contains("g stock") && obj.contains("g cut"));
    }
}
