//! A binary glTF (`.glb`) of the measured piece: each nominal point (grey),
//! the measured point with its deviation along the normal magnified and
//! coloured (blue = into the material, red = proud of it), and a segment
//! joining the two, so the error pattern of every pose can be turned around
//! in any glTF viewer. Coordinates are in metres, as glTF expects.

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

/// Builds the `.glb` bytes. `magnification` multiplies the deviations.
pub(crate) fn glb(points: &[ShownPoint], magnification: f64) -> Vec<u8> {
    let max_dev = points
        .iter()
        .fold(0.0f64, |a, p| a.max(p.deviation_um.abs()))
        .max(1e-9);
    // Vertices: for each point its nominal and its magnified measured
    // position; positions then colours, f32.
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
        byte_length: USize64::from(bin.len()),
        byte_offset: None,
        byte_stride: None,
        extensions: Default::default(),
        extras: Default::default(),
        name: None,
        target: Some(Valid(json::buffer::Target::ArrayBuffer)),
    });
    let positions = crate::mesh::vec3_accessor(&mut root, view, 0, n, Some((min, max)));
    let colours = crate::mesh::vec3_accessor(&mut root, view, 12 * n, n, None);
    let attributes = || {
        let mut map = BTreeMap::new();
        map.insert(Valid(json::mesh::Semantic::Positions), positions);
        map.insert(Valid(json::mesh::Semantic::Colors(0)), colours);
        map
    };
    let primitive = |mode| json::mesh::Primitive {
        attributes: attributes(),
        extensions: Default::default(),
        extras: Default::default(),
        indices: None,
        material: None,
        mode: Valid(mode),
        targets: None,
    };
    let mesh = root.push(json::Mesh {
        extensions: Default::default(),
        extras: Default::default(),
        name: Some(format!("deviations x{magnification}")),
        primitives: vec![
            primitive(json::mesh::Mode::Points),
            primitive(json::mesh::Mode::Lines),
        ],
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(mesh),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: Default::default(),
        extras: Default::default(),
        name: Some("measured piece".into()),
        nodes: vec![node],
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
        let bytes = glb(&pts, 1000.0);
        let g = gltf::Gltf::from_slice(&bytes).unwrap();
        let mesh = g.meshes().next().unwrap();
        assert_eq!(mesh.primitives().count(), 2);
        let acc = g.accessors().next().unwrap();
        assert_eq!(acc.count(), 4);
        // The magnified deviation of the first point: 4 um x 1000 = 4 mm.
        let b = g.blob.as_ref().unwrap();
        let x = f32::from_le_bytes([b[12], b[13], b[14], b[15]]);
        assert!((x - 0.014).abs() < 1e-6, "{x}");
    }
}
