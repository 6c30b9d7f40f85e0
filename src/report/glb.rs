//! A binary glTF (`.glb`) of the measured piece: each nominal point (grey),
//! the measured point with its deviation along the normal magnified and
//! coloured (blue = measured inside the nominal surface, red = outside
//! it), and a segment joining the two in its pose's colour, so the error
//! pattern of every pose can be turned around in any glTF viewer. Every
//! pose is its own node, named after it, and its segments have a material
//! `pose ID` in the colour the report's residual plot gives the pose (the
//! points a material `deviation` that shows their vertex colours).
//! Coordinates are in metres, as glTF expects.

use std::borrow::Cow;
use std::collections::BTreeMap;

use gltf_json as json;
use json::validation::Checked::Valid;
use json::validation::USize64;
use nalgebra::Vector3;

/// One point to show.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShownPoint {
    /// Nominal position, mm.
    pub nominal: Vector3<f64>,
    /// Unit normal (direction of a positive deviation).
    pub normal: Vector3<f64>,
    /// Deviation along the normal, um.
    pub deviation_um: f64,
}

/// Blue - white - red for -1 .. 1.
pub(crate) fn diverging(t: f64) -> [f32; 3] {
    let t = t.clamp(-1.0, 1.0) as f32;
    if t < 0.0 {
        [1.0 + t, 1.0 + t, 1.0]
    } else {
        [1.0, 1.0 - t, 1.0 - t]
    }
}

/// Builds the `.glb` bytes. `magnification` multiplies the deviations;
/// `poses` names each pose with the indices of its points.
pub(crate) fn glb(
    points: &[ShownPoint],
    magnification: f64,
    poses: &[(String, Vec<usize>)],
) -> Vec<u8> {
    let max_dev = points
        .iter()
        .fold(0.0f64, |a, p| a.max(p.deviation_um.abs()))
        .max(1e-9);
    // Vertices: for each point its nominal and its magnified measured
    // position; positions then colours, f32; then each pose's vertex
    // indices, u32 (the same pairs draw its points and its segments).
    let mut pos: Vec<[f32; 3]> = Vec::new();
    let mut col: Vec<[f32; 3]> = Vec::new();
    for p in points {
        let shown = p.nominal + p.normal * (p.deviation_um * 1e-3 * magnification);
        for (v, c) in [
            (p.nominal, [0.6f32, 0.6, 0.6]),
            (shown, diverging(p.deviation_um / max_dev)),
        ] {
            pos.push([
                (v.x * 1e-3) as f32,
                (v.y * 1e-3) as f32,
                (v.z * 1e-3) as f32,
            ]);
            col.push(c);
        }
    }
    let n = pos.len();
    let mut min = [f32::MAX; 3];
    let mut max = [f32::MIN; 3];
    for p in &pos {
        for i in 0..3 {
            min[i] = min[i].min(p[i]);
            max[i] = max[i].max(p[i]);
        }
    }
    let mut bin: Vec<u8> = Vec::with_capacity(24 * n);
    for v in pos.iter().chain(&col) {
        for x in v {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    let vertex_bytes = bin.len();
    let mut index_ranges = Vec::new();
    for (_, obs) in poses {
        let start = bin.len() - vertex_bytes;
        let mut count = 0usize;
        for &k in obs.iter().filter(|&&k| k < points.len()) {
            for v in [2 * k, 2 * k + 1] {
                bin.extend_from_slice(&(v as u32).to_le_bytes());
                count += 1;
            }
        }
        index_ranges.push((start, count));
    }
    let mut root = json::Root::default();
    let buffer = root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        extensions: Default::default(),
        extras: Default::default(),
        name: Some("points".into()),
        uri: None,
    });
    let view = root.push(json::buffer::View {
        buffer,
        byte_length: USize64::from(vertex_bytes),
        byte_offset: None,
        byte_stride: None,
        extensions: Default::default(),
        extras: Default::default(),
        name: None,
        target: Some(Valid(json::buffer::Target::ArrayBuffer)),
    });
    let index_view = (bin.len() > vertex_bytes).then(|| {
        root.push(json::buffer::View {
            buffer,
            byte_length: USize64::from(bin.len() - vertex_bytes),
            byte_offset: Some(USize64::from(vertex_bytes)),
            byte_stride: None,
            extensions: Default::default(),
            extras: Default::default(),
            name: Some("pose indices".into()),
            target: Some(Valid(json::buffer::Target::ElementArrayBuffer)),
        })
    });
    let positions = crate::mesh::vec3_accessor(&mut root, view, 0, n, Some((min, max)));
    let colours = crate::mesh::vec3_accessor(&mut root, view, 12 * n, n, None);
    let material = |root: &mut json::Root, name: String, rgb: [f32; 3]| {
        root.push(json::Material {
            name: Some(name),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor([
                    rgb[0], rgb[1], rgb[2], 1.0,
                ]),
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(1.0),
                ..Default::default()
            },
            ..Default::default()
        })
    };
    let deviation = material(&mut root, "deviation".into(), [1.0, 1.0, 1.0]);
    let primitive = |mode, indices, material, with_colours: bool| {
        let mut attributes = BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
        if with_colours {
            attributes.insert(Valid(json::mesh::Semantic::Colors(0)), colours);
        }
        json::mesh::Primitive {
            attributes,
            extensions: Default::default(),
            extras: Default::default(),
            indices,
            material: Some(material),
            mode: Valid(mode),
            targets: None,
        }
    };
    let mut nodes = Vec::new();
    for (k, ((id, _), (start, count))) in poses.iter().zip(&index_ranges).enumerate() {
        let (Some(iv), true) = (index_view, *count > 0) else {
            continue;
        };
        let indices = root.push(json::Accessor {
            buffer_view: Some(iv),
            byte_offset: Some(USize64::from(*start)),
            count: USize64::from(*count),
            component_type: Valid(json::accessor::GenericComponentType(
                json::accessor::ComponentType::U32,
            )),
            extensions: Default::default(),
            extras: Default::default(),
            type_: Valid(json::accessor::Type::Scalar),
            min: None,
            max: None,
            name: None,
            normalized: false,
            sparse: None,
        });
        let (r, g, b) = super::pose_colour(k);
        let rgb = [r, g, b].map(|c| f32::from(c) / 255.0);
        let pose_material = material(&mut root, format!("pose {id}"), rgb);
        let mesh = root.push(json::Mesh {
            extensions: Default::default(),
            extras: Default::default(),
            name: Some(format!("pose {id}: deviations x{magnification}")),
            primitives: vec![
                primitive(json::mesh::Mode::Points, Some(indices), deviation, true),
                primitive(json::mesh::Mode::Lines, Some(indices), pose_material, false),
            ],
            weights: None,
        });
        nodes.push(root.push(json::Node {
            mesh: Some(mesh),
            name: Some(id.clone()),
            ..Default::default()
        }));
    }
    let scene = root.push(json::Scene {
        extensions: Default::default(),
        extras: Default::default(),
        name: Some("measured piece".into()),
        nodes,
    });
    root.scene = Some(scene);
    let json_string = json::serialize::to_string(&root).expect("glTF JSON serializes");
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        bin: Some(Cow::Owned(bin)),
        json: Cow::Owned(json_string.into_bytes()),
    };
    glb.to_vec().expect("a GLB of this size serializes")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_a_glb_that_gltf_reads_back() {
        let pts = [
            ShownPoint {
                nominal: Vector3::new(10.0, 0.0, 5.0),
                normal: Vector3::x(),
                deviation_um: 4.0,
            },
            ShownPoint {
                nominal: Vector3::new(0.0, 10.0, 5.0),
                normal: Vector3::y(),
                deviation_um: -2.0,
            },
        ];
        let poses = [
            ("A0C0".to_string(), vec![0]),
            ("A90C0".to_string(), vec![1]),
        ];
        let bytes = glb(&pts, 1000.0, &poses);
        let g = gltf::Gltf::from_slice(&bytes).unwrap();
        // One node and mesh per pose, named after it, each with its
        // points (deviation colours) and its segment (the pose's colour).
        let names: Vec<&str> = g.nodes().filter_map(|n| n.name()).collect();
        assert_eq!(names, ["A0C0", "A90C0"]);
        for (k, mesh) in g.meshes().enumerate() {
            let prims: Vec<_> = mesh.primitives().collect();
            assert_eq!(prims.len(), 2);
            assert_eq!(prims[0].material().name(), Some("deviation"));
            let line = prims[1].material();
            assert_eq!(line.name(), Some(["pose A0C0", "pose A90C0"][k]));
            let (r, gr, b) = crate::report::pose_colour(k);
            let want = [r, gr, b].map(|c| f32::from(c) / 255.0);
            assert_eq!(line.pbr_metallic_roughness().base_color_factor()[..3], want);
            assert_eq!(prims[1].indices().unwrap().count(), 2);
        }
        let acc = g.accessors().next().unwrap();
        assert_eq!(acc.count(), 4);
        // The magnified deviation of the first point: 4 um x 1000 = 4 mm.
        let b = g.blob.as_ref().unwrap();
        let x = f32::from_le_bytes([b[12], b[13], b[14], b[15]]);
        assert!((x - 0.014).abs() < 1e-6, "{x}");
        // The second pose's indices: its nominal and measured vertex.
        let at = 2 * 4 * 12;
        let second: Vec<u32> = (0..2)
            .map(|i| {
                let o = at + 8 + 4 * i;
                u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
            })
            .collect();
        assert_eq!(second, [2, 3]);
    }
}
