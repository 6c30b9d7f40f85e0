//! Contour errors (Jiang et al. 2013): the distance of each measured point to the
//! design surface of a part model, as `fivecal analyze contour` reports it.
//!
//! The model is a triangle mesh read from OBJ (tobj) or glTF/GLB (gltf, with
//! node transforms applied); the CMM's frame is the model's (Jiang et al. 2013
//! measured with "the measure base defined as design model base"). Each
//! point's distance is exact to the mesh: the closest point on the closest
//! triangle, found through a bounding-volume hierarchy. Its sign comes from
//! the angle-weighted pseudo-normal of the closest feature (face, edge or
//! vertex; Baerentzen and Aanaes 2005), positive outside the material (too
//! much material left), negative inside (cut too deep); that is correct on
//! edges and corners too, where a face normal would not be.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::{Matrix4, Point3, Vector3};

/// Why a model cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// Reading failed.
    #[error("cannot read {path}: {message}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A format problem.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A mesh built in code that [`PartMesh::check`] refuses.
    #[error("unusable mesh: {0}")]
    Invalid(String),
}

/// A triangle mesh, mm.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PartMesh {
    /// Vertex positions.
    pub vertices: Vec<Vector3<f64>>,
    /// Triangles (vertex indices, counter-clockwise seen from outside).
    pub triangles: Vec<[u32; 3]>,
}

impl PartMesh {
    /// Loads `.obj`, `.gltf` or `.glb` by extension.
    pub fn load(path: &Path) -> Result<PartMesh, MeshError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let mesh = match ext.as_deref() {
            Some("obj") => PartMesh::from_obj(path)?,
            Some("glb") | Some("gltf") => PartMesh::from_gltf(path)?,
            _ => {
                return Err(MeshError::Format {
                    path: path.to_path_buf(),
                    message: "unknown model format: expected a .obj, .gltf or .glb file".into(),
                });
            }
        };
        mesh.check().map_err(|message| MeshError::Format {
            path: path.to_path_buf(),
            message,
        })?;
        Ok(mesh)
    }

    /// What makes a mesh unusable as a design surface: a vertex that is
    /// not a finite position within the machine-file range of lengths, a
    /// triangle naming a vertex that does not exist, or no triangle with an
    /// area at all (three equal vertices have no surface to measure to).
    pub fn check(&self) -> Result<(), String> {
        let max = crate::limits::MAX_MACHINE_MM;
        for (i, v) in self.vertices.iter().enumerate() {
            if !v.iter().all(|x| x.is_finite() && x.abs() <= max) {
                return Err(format!(
                    "vertex {} is ({}, {}, {}): expected finite coordinates within {max} mm",
                    i + 1,
                    v.x,
                    v.y,
                    v.z
                ));
            }
        }
        let n = self.vertices.len();
        if let Some(k) = self
            .triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(format!(
                "triangle {} names a vertex beyond the {n} vertices",
                k + 1
            ));
        }
        if self.triangles.is_empty() {
            return Err("the model has no triangles".into());
        }
        let has_area = self.triangles.iter().any(|t| {
            let p = t.map(|i| self.vertices[i as usize]);
            (p[1] - p[0]).cross(&(p[2] - p[0])).norm() > 0.0
        });
        if !has_area {
            return Err(format!(
                "none of the {} triangles has an area (their vertices coincide or lie on a line): no surface to measure to",
                self.triangles.len()
            ));
        }
        Ok(())
    }

    /// Reads an OBJ file (polygons are triangulated).
    pub(crate) fn from_obj(path: &Path) -> Result<PartMesh, MeshError> {
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let bytes = read_model(path)?;
        // Materials are not needed for a surface: `mtllib` lines are skipped.
        let (models, _) = tobj::load_obj_buf(&mut bytes.as_slice(), &opts, |_| {
            Ok((Vec::new(), Default::default()))
        })
        .map_err(|e| MeshError::Format {
            path: path.to_path_buf(),
            message: match obj_fault(&bytes) {
                Some((line, what)) => {
                    format!("line {line}: {what} (not a readable OBJ model: {e})")
                }
                None => format!("not a readable OBJ model: {e}"),
            },
        })?;
        let mut mesh = PartMesh::default();
        for m in models {
            let base = mesh.vertices.len() as u32;
            let p = &m.mesh.positions;
            for v in p.chunks_exact(3) {
                mesh.vertices
                    .push(Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64));
            }
            for t in m.mesh.indices.chunks_exact(3) {
                mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
            }
        }
        Ok(mesh)
    }

    /// Reads a glTF (`.gltf` with external or embedded buffers) or binary
    /// `.glb` file; every triangle primitive of the default scene, with its
    /// node transforms.
    pub(crate) fn from_gltf(path: &Path) -> Result<PartMesh, MeshError> {
        let bytes = read_model(path)?;
        let fmt = |message: String| MeshError::Format {
            path: path.to_path_buf(),
            message,
        };
        let doc = gltf::Gltf::from_slice(&bytes)
            .map_err(|e| fmt(format!("not a readable glTF model: {e}")))?;
        let mut buffers: Vec<Vec<u8>> = Vec::new();
        for b in doc.buffers() {
            let data = match b.source() {
                gltf::buffer::Source::Bin => doc
                    .blob
                    .clone()
                    .ok_or_else(|| fmt("the GLB has no binary chunk".into()))?,
                gltf::buffer::Source::Uri(uri) => {
                    if let Some(rest) = uri.strip_prefix("data:") {
                        let b64 = rest.split_once(";base64,").map(|x| x.1).ok_or_else(|| {
                            fmt(format!(
                                "buffer {}: only base64 data URIs are supported",
                                b.index()
                            ))
                        })?;
                        base64_decode(b64)
                            .ok_or_else(|| fmt(format!("buffer {}: bad base64 data", b.index())))?
                    } else {
                        let p = path.parent().unwrap_or(Path::new(".")).join(uri);
                        read_model(&p)?
                    }
                }
            };
            buffers.push(data);
        }
        let mut mesh = PartMesh::default();
        let scene = doc
            .default_scene()
            .or_else(|| doc.scenes().next())
            .ok_or_else(|| fmt("the model has no scene".into()))?;
        check_node_graph(&doc).map_err(&fmt)?;
        let mut stack: Vec<(gltf::Node, Matrix4<f64>)> =
            scene.nodes().map(|n| (n, Matrix4::identity())).collect();
        // A node shared by several parents is placed once per path to it:
        // a tree of shared nodes 40 levels deep has 2^40 of them.
        let mut placed = 0usize;
        while let Some((node, parent)) = stack.pop() {
            placed += 1;
            if placed > crate::limits::MAX_MODEL_NODES {
                return Err(fmt(format!(
                    "the scene places more than {} nodes (node {} and the nodes above it are shared by many parents): not a part model fivecal reads",
                    crate::limits::MAX_MODEL_NODES,
                    node.index()
                )));
            }
            if mesh.vertices.len() > crate::limits::MAX_MODEL_VERTICES {
                return Err(fmt(format!(
                    "the scene has more than {} vertices once its nodes are placed: not a part model fivecal reads",
                    crate::limits::MAX_MODEL_VERTICES
                )));
            }
            let m = node.transform().matrix();
            let local = Matrix4::from_fn(|r, c| m[c][r] as f64);
            let world = parent * local;
            if let Some(me) = node.mesh() {
                for prim in me.primitives() {
                    if prim.mode() != gltf::mesh::Mode::Triangles {
                        continue;
                    }
                    let pos = prim.get(&gltf::Semantic::Positions).ok_or_else(|| {
                        fmt(format!(
                            "mesh {}: a primitive without positions",
                            me.index()
                        ))
                    })?;
                    let base = mesh.vertices.len() as u32;
                    for p in read_vec3(&pos, &buffers).map_err(&fmt)? {
                        // glTF's unit is the metre (and fivecal writes its
                        // own `.glb` so); the contour works in mm.
                        let q = world.transform_point(&Point3::from(p));
                        mesh.vertices.push(q.coords * 1000.0);
                    }
                    let n = mesh.vertices.len() as u32 - base;
                    let idx: Vec<u32> = match prim.indices() {
                        Some(a) => read_indices(&a, &buffers).map_err(&fmt)?,
                        None => (0..n).collect(),
                    };
                    for t in idx.chunks_exact(3) {
                        if t.iter().any(|&i| i >= n) {
                            return Err(fmt(format!(
                                "mesh {}: a triangle index beyond its vertices",
                                me.index()
                            )));
                        }
                        mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
                    }
                }
            }
            for child in node.children() {
                stack.push((child, world));
            }
        }
        Ok(mesh)
    }
}

/// Refuses a glTF node graph that is not a forest: a node that is its
/// own child, or a loop of children (glTF 2.0 requires "node hierarchy
/// must be a set of disjoint strict trees"). Walked without recursion, in
/// time linear in nodes and children.
fn check_node_graph(doc: &gltf::Gltf) -> Result<(), String> {
    let children: Vec<Vec<usize>> = doc
        .nodes()
        .map(|n| n.children().map(|c| c.index()).collect())
        .collect();
    // 0: not seen, 1: on the current path, 2: done.
    let mut state = vec![0u8; children.len()];
    for root in 0..children.len() {
        if state[root] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
        state[root] = 1;
        while let Some(top) = stack.last_mut() {
            let (n, k) = *top;
            if let Some(&c) = children[n].get(k) {
                top.1 += 1;
                match state.get(c) {
                    Some(1) => {
                        return Err(if c == n {
                            format!("node {n} is its own child: a node tree must not loop")
                        } else {
                            format!(
                                "node {c} is a child of node {n}, which is below node {c}: a node tree must not loop"
                            )
                        });
                    }
                    Some(0) => {
                        state[c] = 1;
                        stack.push((c, 0));
                    }
                    _ => {}
                }
            } else {
                state[n] = 2;
                stack.pop();
            }
        }
    }
    Ok(())
}

/// A model file or a glTF buffer, read within [`crate::limits::MAX_MODEL_BYTES`].
fn read_model(path: &Path) -> Result<Vec<u8>, MeshError> {
    crate::input::read_bytes(path, "3-D model", crate::limits::MAX_MODEL_BYTES).map_err(|e| {
        MeshError::Read {
            path: path.to_path_buf(),
            message: e.message,
        }
    })
}

fn accessor_bytes<'a>(
    a: &gltf::Accessor,
    buffers: &'a [Vec<u8>],
    elem: usize,
) -> Result<(&'a [u8], usize), String> {
    let v = a.view().ok_or_else(|| {
        format!(
            "accessor {}: sparse accessors without a buffer view are not supported",
            a.index()
        )
    })?;
    let buf = buffers
        .get(v.buffer().index())
        .ok_or_else(|| format!("accessor {}: missing buffer", a.index()))?;
    let stride = v.stride().unwrap_or(elem);
    let start = v.offset() + a.offset();
    let need = if a.count() == 0 {
        0
    } else {
        start + stride * (a.count() - 1) + elem
    };
    if need > buf.len() || need > v.offset() + v.length() {
        return Err(format!("accessor {}: data runs past its buffer", a.index()));
    }
    Ok((&buf[start..], stride))
}

fn read_vec3(a: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<Vector3<f64>>, String> {
    if a.data_type() != gltf::accessor::DataType::F32
        || a.dimensions() != gltf::accessor::Dimensions::Vec3
    {
        return Err(format!(
            "accessor {}: positions must be float VEC3",
            a.index()
        ));
    }
    let (bytes, stride) = accessor_bytes(a, buffers, 12)?;
    let f = |b: &[u8], k: usize| {
        f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]]) as f64
    };
    Ok((0..a.count())
        .map(|i| {
            let e = &bytes[i * stride..i * stride + 12];
            Vector3::new(f(e, 0), f(e, 1), f(e, 2))
        })
        .collect())
}

fn read_indices(a: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    use gltf::accessor::DataType;
    let size = match a.data_type() {
        DataType::U8 => 1,
        DataType::U16 => 2,
        DataType::U32 => 4,
        _ => {
            return Err(format!(
                "accessor {}: indices must be unsigned integers",
                a.index()
            ));
        }
    };
    let (bytes, stride) = accessor_bytes(a, buffers, size)?;
    Ok((0..a.count())
        .map(|i| {
            let e = &bytes[i * stride..];
            match size {
                1 => e[0] as u32,
                2 => u16::from_le_bytes([e[0], e[1]]) as u32,
                _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
            }
        })
        .collect())
}

fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => (c - b'A') as u32,
            b'a'..=b'z' => (c - b'a' + 26) as u32,
            b'0'..=b'9' => (c - b'0' + 52) as u32,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        })
    };
    let clean: Vec<u8> = s
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let mut acc = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * k);
        }
        let n = match chunk.len() {
            4 => 3,
            3 => 2,
            2 => 1,
            _ => return None,
        };
        for k in 0..n {
            out.push((acc >> (16 - 8 * k)) as u8);
        }
    }
    Some(out)
}

/// Which feature of a triangle is closest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Feature {
    Face,
    Edge(u8),
    Vertex(u8),
}

/// Closest point on triangle (a, b, c) to p (Ericson, Real-Time Collision
/// Detection, 5.1.5), with the feature it lies on.
fn closest_on_triangle(
    p: &Vector3<f64>,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
) -> (Vector3<f64>, Feature) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (*a, Feature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (*b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, Feature::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (*c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, Feature::Face)
}

#[derive(Clone, Debug)]
struct Node {
    lo: Vector3<f64>,
    hi: Vector3<f64>,
    /// Children (internal) or triangle range (leaf: start, count).
    kind: NodeKind,
}

#[derive(Clone, Debug)]
enum NodeKind {
    Inner(usize, usize),
    Leaf(usize, usize),
}

/// A mesh ready for distance queries.
#[derive(Clone, Debug)]
pub struct Surface {
    vertices: Vec<Vector3<f64>>,
    triangles: Vec<[u32; 3]>,
    face_normals: Vec<Vector3<f64>>,
    vertex_normals: Vec<Vector3<f64>>,
    edge_normals: HashMap<(u32, u32), Vector3<f64>>,
    nodes: Vec<Node>,
    order: Vec<usize>,
}

/// The result of a query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// Closest point on the surface.
    pub point: Vector3<f64>,
    /// Signed distance, mm: positive outside the material.
    pub distance: f64,
    /// Outward normal used for the sign.
    pub normal: Vector3<f64>,
}

impl Surface {
    /// Prepares `mesh` (vertices are welded by position so that normals
    /// are shared across the facets of one surface). A mesh [`PartMesh::check`]
    /// refuses (a vertex out of range, a triangle naming a vertex that does
    /// not exist, no triangle with an area) is refused here too, so that a
    /// mesh built in code rather than loaded cannot make a query panic.
    pub fn new(mesh: &PartMesh) -> Result<Surface, MeshError> {
        mesh.check().map_err(MeshError::Invalid)?;
        let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut remap = Vec::with_capacity(mesh.vertices.len());
        for v in &mesh.vertices {
            let key = [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            let id = *ids.entry(key).or_insert_with(|| {
                vertices.push(*v);
                (vertices.len() - 1) as u32
            });
            remap.push(id);
        }
        let triangles: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .map(|t| {
                [
                    remap[t[0] as usize],
                    remap[t[1] as usize],
                    remap[t[2] as usize],
                ]
            })
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect();
        let mut face_normals = Vec::with_capacity(triangles.len());
        let mut vertex_normals = vec![Vector3::zeros(); vertices.len()];
        let mut edge_normals: HashMap<(u32, u32), Vector3<f64>> = HashMap::new();
        for t in &triangles {
            let p = [
                vertices[t[0] as usize],
                vertices[t[1] as usize],
                vertices[t[2] as usize],
            ];
            let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let n = if n.norm() > 0.0 {
                n.normalize()
            } else {
                Vector3::zeros()
            };
            face_normals.push(n);
            for k in 0..3 {
                let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
                let (u, v) = ((b - a), (c - a));
                let angle = if u.norm() > 0.0 && v.norm() > 0.0 {
                    u.angle(&v)
                } else {
                    0.0
                };
                vertex_normals[t[k] as usize] += n * angle;
                let (i, j) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                *edge_normals.entry((i, j)).or_insert_with(Vector3::zeros) += n;
            }
        }
        let mut s = Surface {
            vertices,
            triangles,
            face_normals,
            vertex_normals,
            edge_normals,
            nodes: Vec::new(),
            order: Vec::new(),
        };
        s.build();
        Ok(s)
    }

    fn tri_bounds(&self, i: usize) -> (Vector3<f64>, Vector3<f64>) {
        let t = self.triangles[i];
        let p = t.map(|k| self.vertices[k as usize]);
        (p[0].inf(&p[1]).inf(&p[2]), p[0].sup(&p[1]).sup(&p[2]))
    }

    fn build(&mut self) {
        self.order = (0..self.triangles.len()).collect();
        let centers: Vec<Vector3<f64>> = (0..self.triangles.len())
            .map(|i| {
                let (lo, hi) = self.tri_bounds(i);
                (lo + hi) / 2.0
            })
            .collect();
        let mut nodes = Vec::new();
        let n = self.order.len();
        self.split(&mut nodes, &centers, 0, n);
        self.nodes = nodes;
    }

    fn split(
        &mut self,
        nodes: &mut Vec<Node>,
        centers: &[Vector3<f64>],
        start: usize,
        count: usize,
    ) -> usize {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for &i in &self.order[start..start + count] {
            let (a, b) = self.tri_bounds(i);
            lo = lo.inf(&a);
            hi = hi.sup(&b);
        }
        let id = nodes.len();
        nodes.push(Node {
            lo,
            hi,
            kind: NodeKind::Leaf(start, count),
        });
        if count <= 4 {
            return id;
        }
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let slice = &mut self.order[start..start + count];
        slice.sort_unstable_by(|&a, &b| centers[a][axis].total_cmp(&centers[b][axis]));
        let half = count / 2;
        let l = self.split(nodes, centers, start, half);
        let r = self.split(nodes, centers, start + half, count - half);
        nodes[id].kind = NodeKind::Inner(l, r);
        id
    }

    /// The closest point of the surface to `p` and the signed distance.
    pub fn closest(&self, p: &Vector3<f64>) -> Closest {
        let mut best = (f64::INFINITY, Vector3::zeros(), 0usize, Feature::Face);
        let mut stack = vec![0usize];
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id];
            let d = p.sup(&node.lo).inf(&node.hi) - p;
            if d.norm_squared() >= best.0 {
                continue;
            }
            match node.kind {
                NodeKind::Leaf(s, c) => {
                    for &i in &self.order[s..s + c] {
                        let t = self.triangles[i];
                        let (q, f) = closest_on_triangle(
                            p,
                            &self.vertices[t[0] as usize],
                            &self.vertices[t[1] as usize],
                            &self.vertices[t[2] as usize],
                        );
                        let d2 = (q - p).norm_squared();
                        if d2 < best.0 {
                            best = (d2, q, i, f);
                        }
                    }
                }
                NodeKind::Inner(l, r) => {
                    // Nearer child last, so it is searched first.
                    let dist = |n: usize| {
                        let nd = &self.nodes[n];
                        (p.sup(&nd.lo).inf(&nd.hi) - p).norm_squared()
                    };
                    if dist(l) < dist(r) {
                        stack.push(r);
                        stack.push(l);
                    } else {
                        stack.push(l);
                        stack.push(r);
                    }
                }
            }
        }
        let (d2, q, i, f) = best;
        let t = self.triangles[i];
        let normal = match f {
            Feature::Face => self.face_normals[i],
            Feature::Vertex(k) => self.vertex_normals[t[k as usize] as usize],
            Feature::Edge(k) => {
                let (a, b) = (t[k as usize], t[(k as usize + 1) % 3]);
                self.edge_normals[&(a.min(b), a.max(b))]
            }
        };
        let sign = if (p - q).dot(&normal) < 0.0 {
            -1.0
        } else {
            1.0
        };
        Closest {
            point: q,
            distance: sign * d2.sqrt(),
            normal: if normal.norm() > 0.0 {
                normal.normalize()
            } else {
                normal
            },
        }
    }
}

/// One evaluated point.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourPoint {
    /// Label.
    pub label: String,
    /// Measured point, mm.
    pub measured: Vector3<f64>,
    /// Nearest design-surface point, mm.
    pub nearest: Vector3<f64>,
    /// Signed distance (contour error), mm: positive = material left.
    pub error: f64,
}

/// Statistics of the contour errors, mm.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourSummary {
    /// Number of points.
    pub n: usize,
    /// Mean of the absolute errors (Jiang et al.'s (2013) "average contour error").
    pub mean_abs: f64,
    /// Largest absolute error and its label.
    pub max_abs: (f64, String),
    /// RMS error.
    pub rms: f64,
    /// Mean signed error.
    pub mean: f64,
    /// Smallest and largest signed error.
    pub range: (f64, f64),
}

/// Contour errors of labelled measured points against a surface.
pub fn evaluate(
    surface: &Surface,
    points: &[(String, Vector3<f64>)],
) -> (Vec<ContourPoint>, ContourSummary) {
    let out: Vec<ContourPoint> = points
        .iter()
        .map(|(label, p)| {
            let c = surface.closest(p);
            ContourPoint {
                label: label.clone(),
                measured: *p,
                nearest: c.point,
                error: c.distance,
            }
        })
        .collect();
    let n = out.len().max(1) as f64;
    let mut max_abs = (0.0, String::new());
    let mut range = (f64::INFINITY, f64::NEG_INFINITY);
    for p in &out {
        if p.error.abs() > max_abs.0 {
            max_abs = (p.error.abs(), p.label.clone());
        }
        range = (range.0.min(p.error), range.1.max(p.error));
    }
    let summary = ContourSummary {
        n: out.len(),
        mean_abs: out.iter().map(|p| p.error.abs()).sum::<f64>() / n,
        max_abs,
        rms: (out.iter().map(|p| p.error * p.error).sum::<f64>() / n).sqrt(),
        mean: out.iter().map(|p| p.error).sum::<f64>() / n,
        range,
    };
    (out, summary)
}

/// The first line of an OBJ file the reader refuses, and why: the OBJ
/// reader says what is wrong but not where. Vertices, texture coordinates
/// and normals are counted as they come; a face's index (1-based, or
/// negative counting back) must name one already given.
fn obj_fault(bytes: &[u8]) -> Option<(usize, String)> {
    let text = String::from_utf8_lossy(bytes);
    let (mut v, mut vt, mut vn) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(head) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        let numbers =
            |n: usize| rest.len() >= n && rest[..n].iter().all(|w| w.parse::<f32>().is_ok());
        let quoted = crate::source::cut(line.trim());
        match head {
            "v" if !numbers(3) => {
                return Some((i + 1, format!("`{quoted}`: expected a vertex `v x y z`")));
            }
            "vn" if !numbers(3) => {
                return Some((i + 1, format!("`{quoted}`: expected a normal `vn x y z`")));
            }
            "vt" if !numbers(1) => {
                return Some((
                    i + 1,
                    format!("`{quoted}`: expected texture coordinates `vt u v`"),
                ));
            }
            "v" => v += 1,
            "vn" => vn += 1,
            "vt" => vt += 1,
            "f" | "l" => {
                if head == "f" && rest.len() < 3 {
                    return Some((
                        i + 1,
                        format!("`{quoted}`: a face needs three vertices or more"),
                    ));
                }
                for r in &rest {
                    for (k, (part, count, what)) in r
                        .split('/')
                        .zip([(v, "vertex"), (vt, "texture coordinate"), (vn, "normal")])
                        .map(|(p, (c, w))| (p, c, w))
                        .enumerate()
                    {
                        if k > 0 && part.is_empty() {
                            continue;
                        }
                        let Ok(n) = part.parse::<i64>() else {
                            return Some((
                                i + 1,
                                format!(
                                    "`{quoted}`: `{}` is not a {what} index",
                                    crate::source::cut(r)
                                ),
                            ));
                        };
                        if n == 0 || n > count || n < -count {
                            return Some((
                                i + 1,
                                format!(
                                    "`{quoted}`: {what} index {n} names none of the {count} given before it"
                                ),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit-free cube [0, 10]^3 with outward triangles.
    pub(crate) fn cube() -> PartMesh {
        let v = |x: f64, y: f64, z: f64| Vector3::new(x, y, z);
        let vertices = vec![
            v(0., 0., 0.),
            v(10., 0., 0.),
            v(10., 10., 0.),
            v(0., 10., 0.),
            v(0., 0., 10.),
            v(10., 0., 10.),
            v(10., 10., 10.),
            v(0., 10., 10.),
        ];
        let q = |a: u32, b: u32, c: u32, d: u32| [[a, b, c], [a, c, d]];
        let mut triangles = Vec::new();
        for f in [
            q(0, 3, 2, 1),
            q(4, 5, 6, 7),
            q(0, 1, 5, 4),
            q(2, 3, 7, 6),
            q(1, 2, 6, 5),
            q(0, 4, 7, 3),
        ] {
            triangles.extend(f);
        }
        PartMesh {
            vertices,
            triangles,
        }
    }

    #[test]
    fn distances_and_signs_on_faces_edges_and_corners() {
        let s = Surface::new(&cube()).unwrap();
        let cases = [
            (Vector3::new(5., 5., 10.2), 0.2),
            (Vector3::new(5., 5., 9.7), -0.3),
            (Vector3::new(-0.1, 5., 5.), 0.1),
            (Vector3::new(10.3, 10.4, 5.), 0.5),
            (Vector3::new(11., 11., 11.), 3f64.sqrt()),
            (Vector3::new(9.9, 9.9, 5.), -0.1),
        ];
        for (p, want) in cases {
            let c = s.closest(&p);
            assert!(
                (c.distance - want).abs() < 1e-12,
                "{p:?}: {} want {want}",
                c.distance
            );
        }
    }

    /// The models `fivecal plan` writes (through [`crate::mesh::PartMesh`]) read
    /// back here, OBJ and GLB alike.
    #[test]
    fn models_written_by_the_mesh_module_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let c = cube();
        let triangles = c
            .triangles
            .iter()
            .map(|t| {
                let v = t.map(|i| c.vertices[i as usize]);
                crate::mesh::Triangle {
                    v,
                    n: (v[1] - v[0]).cross(&(v[2] - v[0])).normalize(),
                    tag: 0,
                }
            })
            .collect();
        let m = crate::mesh::Mesh {
            triangles,
            groups: Default::default(),
        };
        let obj = dir.path().join("c.obj");
        std::fs::write(&obj, m.to_obj("cube")).unwrap();
        let glb = dir.path().join("c.glb");
        std::fs::write(&glb, m.to_glb("cube")).unwrap();
        for p in [obj, glb] {
            let back = PartMesh::load(&p).unwrap();
            assert_eq!(back.triangles.len(), 12, "{p:?}");
            let s = Surface::new(&back).unwrap();
            assert!((s.closest(&Vector3::new(5., 5., 12.)).distance - 2.0).abs() < 1e-6);
            assert!((s.closest(&Vector3::new(5., 5., 9.)).distance + 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn a_bad_mesh_built_in_code_is_refused_not_panicked_on() {
        // Each of these panicked in `Surface::new` or in a query when a
        // caller skipped `PartMesh::check`.
        let point = Vector3::new(1.0, 2.0, 3.0);
        let bad = [
            // One triangle with three equal vertices (no area).
            PartMesh {
                vertices: vec![point; 3],
                triangles: vec![[0, 1, 2]],
            },
            // A triangle naming a vertex that does not exist.
            PartMesh {
                vertices: cube().vertices,
                triangles: vec![[0, 1, 99]],
            },
            // No triangles.
            PartMesh {
                vertices: cube().vertices,
                triangles: Vec::new(),
            },
            // A vertex at infinity.
            PartMesh {
                vertices: vec![point, point * 2.0, Vector3::new(f64::INFINITY, 0.0, 0.0)],
                triangles: vec![[0, 1, 2]],
            },
        ];
        for m in bad {
            let e = Surface::new(&m).unwrap_err().to_string();
            assert!(e.starts_with("unusable mesh: "), "{e}");
        }
        // A cube with one degenerate triangle more still measures.
        let mut m = cube();
        m.vertices.push(point);
        let k = m.vertices.len() as u32 - 1;
        m.triangles.push([k, k, k]);
        let s = Surface::new(&m).unwrap();
        assert!((s.closest(&Vector3::new(5., 5., 12.)).distance - 2.0).abs() < 1e-12);
    }

    #[test]
    fn base64_decodes() {
        assert_eq!(base64_decode("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(base64_decode("AAEC").unwrap(), vec![0, 1, 2]);
    }
}
