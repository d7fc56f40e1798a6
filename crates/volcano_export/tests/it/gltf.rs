//! Binary glTF read back by the `gltf` crate (the reader under Bevy's glTF loader), which
//! also validates the document against the specification's rules; bad input refused.

use gltf::mesh::{Mode, Semantic};
use proptest::prelude::*;
use volcano_export::gltf::{GltfError, LineData, MeshData, TEMPERATURE_ATTRIBUTE, write_glb, write_glb_file};

fn write(meshes: &[MeshData], lines: &[LineData]) -> Vec<u8> {
    let mut out = Vec::new();
    write_glb(&mut out, meshes, lines).unwrap();
    out
}

/// A tetrahedron with every optional attribute.
fn tetrahedron() -> MeshData {
    let s = 1.0 / 3f32.sqrt();
    MeshData {
        name: "lava crust".into(),
        positions: vec![[1.5, -2.0, 0.25], [-1.0, 3.0, 7.5], [0.0, 0.125, -4.0], [2.0, 1.0, 1.0]],
        normals: Some(vec![[0.0, 1.0, 0.0], [s, s, s], [-1.0, 0.0, 0.0], [0.0, 0.6, -0.8]]),
        indices: vec![0, 1, 2, 0, 3, 1, 1, 3, 2, 2, 3, 0],
        colors: Some(vec![
            [1.0, 0.2, 0.0, 1.0],
            [0.5, 0.5, 0.5, 0.25],
            [0.0, 0.0, 0.0, 0.0],
            [0.1, 0.7, 0.3, 1.0],
        ]),
        temperature: Some(vec![1400.0, 1173.15, 300.5, 0.0]),
        emissive: Some([0.9, 0.3, 0.05]),
        base_color: [0.2, 0.15, 0.1, 1.0],
    }
}

fn rope() -> LineData {
    LineData {
        name: "fold rope 3".into(),
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [2.0, 0.25, 1.0]],
        indices: vec![0, 1, 1, 2, 2, 0],
        color: [1.0, 0.5, 0.0, 0.5],
    }
}

/// What a primitive holds, read through `gltf`'s reader.
struct Read {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    colors: Option<Vec<[f32; 4]>>,
    temperature: Option<Vec<f32>>,
    indices: Vec<u32>,
    mode: Mode,
    bounds: ([f32; 3], [f32; 3]),
}

fn read_primitive(doc: &gltf::Gltf, mesh: &gltf::Mesh) -> Read {
    assert_eq!(mesh.primitives().len(), 1);
    let p = mesh.primitives().next().unwrap();
    let blob = doc.blob.as_deref();
    let buffers = |b: gltf::Buffer| (b.index() == 0).then_some(blob).flatten();
    let r = p.reader(buffers);
    let temperature = p.get(&Semantic::Extras(TEMPERATURE_ATTRIBUTE[1..].into())).map(|a| {
        assert_eq!(a.data_type(), gltf::accessor::DataType::F32);
        assert_eq!(a.dimensions(), gltf::accessor::Dimensions::Scalar);
        gltf::accessor::Iter::<f32>::new(a, buffers).unwrap().collect()
    });
    let b = p.bounding_box();
    Read {
        positions: r.read_positions().unwrap().collect(),
        normals: r.read_normals().map(|n| n.collect()),
        colors: r.read_colors(0).map(|c| c.into_rgba_f32().collect()),
        temperature,
        indices: r.read_indices().unwrap().into_u32().collect(),
        mode: p.mode(),
        bounds: (b.min, b.max),
    }
}

/// Every attribute, index and bound comes back exactly; names, materials and the scene too.
#[test]
fn meshes_and_lines_read_back_exactly() {
    let mut plain = tetrahedron();
    plain.name = "plain".into();
    plain.normals = None;
    plain.colors = None;
    plain.temperature = None;
    plain.emissive = None;
    let (mesh, lines) = (tetrahedron(), rope());
    let bytes = write(&[mesh.clone(), plain.clone()], std::slice::from_ref(&lines));
    let doc = gltf::Gltf::from_slice(&bytes).expect("a valid glTF");
    assert_eq!(doc.document.as_json().asset.generator.as_deref(), Some("volcano_export"));
    assert_eq!(doc.document.as_json().asset.version, "2.0");
    assert_eq!(doc.buffers().len(), 1);
    for v in doc.views() {
        assert_eq!(v.offset() % 4, 0, "buffer view {} is not 4-byte aligned", v.index());
    }
    let scene = doc.default_scene().expect("a default scene");
    let nodes: Vec<_> = scene.nodes().collect();
    let names: Vec<_> = nodes.iter().map(|n| n.name().unwrap()).collect();
    assert_eq!(names, ["lava crust", "plain", "fold rope 3"]);

    let m = nodes[0].mesh().unwrap();
    assert_eq!(m.name(), Some("lava crust"));
    let r = read_primitive(&doc, &m);
    assert_eq!(r.mode, Mode::Triangles);
    assert_eq!(r.positions, mesh.positions);
    assert_eq!(r.normals, mesh.normals);
    assert_eq!(r.colors, mesh.colors);
    assert_eq!(r.temperature, mesh.temperature);
    assert_eq!(r.indices, mesh.indices);
    assert_eq!(r.bounds, ([-1.0, -2.0, -4.0], [2.0, 3.0, 7.5]));
    let mat = m.primitives().next().unwrap().material();
    assert_eq!(mat.name(), Some("lava crust"));
    let pbr = mat.pbr_metallic_roughness();
    assert_eq!(pbr.base_color_factor(), mesh.base_color);
    assert_eq!((pbr.metallic_factor(), pbr.roughness_factor()), (0.0, 1.0));
    assert_eq!(mat.emissive_factor(), [0.9, 0.3, 0.05]);
    assert_eq!(mat.emissive_strength(), None);
    assert_eq!(mat.alpha_mode(), gltf::material::AlphaMode::Opaque);

    let m = nodes[1].mesh().unwrap();
    let r = read_primitive(&doc, &m);
    assert_eq!(r.positions, plain.positions);
    assert_eq!((r.normals, r.colors, r.temperature), (None, None, None));
    assert_eq!(m.primitives().next().unwrap().material().emissive_factor(), [0.0; 3]);

    let m = nodes[2].mesh().unwrap();
    assert_eq!(m.name(), Some("fold rope 3"));
    let r = read_primitive(&doc, &m);
    assert_eq!(r.mode, Mode::Lines);
    assert_eq!(r.positions, lines.positions);
    assert_eq!(r.indices, lines.indices);
    assert_eq!(r.bounds, ([0.0, 0.0, 0.0], [2.0, 0.5, 1.0]));
    let mat = m.primitives().next().unwrap().material();
    assert_eq!(mat.pbr_metallic_roughness().base_color_factor(), lines.color);
    assert_eq!(mat.alpha_mode(), gltf::material::AlphaMode::Blend, "alpha 0.5");
}

/// Emission above 1 is a factor of at most 1 times `KHR_materials_emissive_strength`.
#[test]
fn bright_emission_uses_the_emissive_strength_extension() {
    let mut m = tetrahedron();
    m.emissive = Some([8.0, 2.0, 0.0]);
    let doc = gltf::Gltf::from_slice(&write(&[m], &[])).unwrap();
    let mat = doc.materials().next().unwrap();
    assert_eq!(mat.emissive_factor(), [1.0, 0.25, 0.0]);
    assert_eq!(mat.emissive_strength(), Some(8.0));
    assert_eq!(doc.extensions_used().collect::<Vec<_>>(), ["KHR_materials_emissive_strength"]);
    assert_eq!(doc.extensions_required().count(), 0, "readers without it still open the file");
}

/// No meshes and no lines: a valid glTF with no buffer and no scene.
#[test]
fn an_empty_export_is_a_valid_file() {
    let bytes = write(&[], &[]);
    let doc = gltf::Gltf::from_slice(&bytes).unwrap();
    assert_eq!((doc.meshes().len(), doc.buffers().len(), doc.scenes().len()), (0, 0, 0));
    assert!(doc.blob.is_none());
}

#[test]
fn write_glb_file_writes_what_write_glb_does() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame_0001.glb");
    write_glb_file(&path, &[tetrahedron()], &[rope()]).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), write(&[tetrahedron()], &[rope()]));
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary left");
}

/// Every kind of bad input is refused, before a byte is written, and `write_glb_file` leaves
/// no file.
#[test]
fn bad_input_is_refused_and_nothing_is_written() {
    type Case = (&'static str, fn(&mut MeshData, &mut LineData), fn(&GltfError) -> bool);
    let cases: &[Case] = &[
        (
            "empty mesh name",
            |m, _| m.name.clear(),
            |e| matches!(e, GltfError::EmptyName { kind: "mesh", .. }),
        ),
        (
            "empty line name",
            |_, l| l.name.clear(),
            |e| matches!(e, GltfError::EmptyName { kind: "line set", .. }),
        ),
        (
            "no vertices",
            |m, _| m.positions.clear(),
            |e| matches!(e, GltfError::Empty { what: "vertices", .. }),
        ),
        ("no indices", |_, l| l.indices.clear(), |e| matches!(e, GltfError::Empty { what: "indices", .. })),
        (
            "short normals",
            |m, _| _ = m.normals.as_mut().unwrap().pop(),
            |e| matches!(e, GltfError::Length { attribute: "normals", len: 3, vertices: 4, .. }),
        ),
        (
            "long colors",
            |m, _| m.colors.as_mut().unwrap().push([0.0; 4]),
            |e| matches!(e, GltfError::Length { attribute: "colors", .. }),
        ),
        (
            "short temperature",
            |m, _| _ = m.temperature.as_mut().unwrap().pop(),
            |e| matches!(e, GltfError::Length { attribute: "temperatures", .. }),
        ),
        ("partial triangle", |m, _| m.indices.push(0), |e| matches!(e, GltfError::IndexCount { per: 3, .. })),
        ("partial segment", |_, l| l.indices.push(0), |e| matches!(e, GltfError::IndexCount { per: 2, .. })),
        (
            "mesh index out of range",
            |m, _| m.indices[5] = 4,
            |e| matches!(e, GltfError::IndexOutOfRange { at: 5, index: 4, vertices: 4, .. }),
        ),
        (
            "line index out of range",
            |_, l| l.indices[0] = u32::MAX,
            |e| matches!(e, GltfError::IndexOutOfRange { at: 0, .. }),
        ),
        (
            "NaN position",
            |m, _| m.positions[2][1] = f32::NAN,
            |e| matches!(e, GltfError::NonFinite { attribute: "position", at: 2, .. }),
        ),
        (
            "infinite line position",
            |_, l| l.positions[1][0] = f32::INFINITY,
            |e| matches!(e, GltfError::NonFinite { attribute: "position", at: 1, .. }),
        ),
        (
            "NaN normal",
            |m, _| m.normals.as_mut().unwrap()[3][2] = f32::NAN,
            |e| matches!(e, GltfError::NonFinite { attribute: "normal", at: 3, .. }),
        ),
        (
            "non-unit normal",
            |m, _| m.normals.as_mut().unwrap()[1] = [0.0, 2.0, 0.0],
            |e| matches!(e, GltfError::NotUnit { at: 1, .. }),
        ),
        (
            "infinite color",
            |m, _| m.colors.as_mut().unwrap()[0][3] = f32::NEG_INFINITY,
            |e| matches!(e, GltfError::NonFinite { attribute: "color", at: 0, .. }),
        ),
        (
            "color above 1",
            |m, _| m.colors.as_mut().unwrap()[2][0] = 1.25,
            |e| matches!(e, GltfError::OutOfRange { attribute: "color", at: 2, .. }),
        ),
        (
            "NaN temperature",
            |m, _| m.temperature.as_mut().unwrap()[1] = f32::NAN,
            |e| matches!(e, GltfError::NonFinite { attribute: "temperature", at: 1, .. }),
        ),
        (
            "NaN emission",
            |m, _| m.emissive = Some([0.0, f32::NAN, 0.0]),
            |e| matches!(e, GltfError::NonFinite { attribute: "emissive", .. }),
        ),
        (
            "negative emission",
            |m, _| m.emissive = Some([-0.5, 0.0, 0.0]),
            |e| matches!(e, GltfError::OutOfRange { attribute: "emissive", .. }),
        ),
        (
            "base color above 1",
            |m, _| m.base_color[0] = 1.5,
            |e| matches!(e, GltfError::OutOfRange { attribute: "base color", .. }),
        ),
        (
            "NaN base color",
            |m, _| m.base_color[3] = f32::NAN,
            |e| matches!(e, GltfError::NonFinite { attribute: "base color", .. }),
        ),
        (
            "negative line color",
            |_, l| l.color[2] = -0.1,
            |e| matches!(e, GltfError::OutOfRange { attribute: "line color", .. }),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (what, spoil, expected) in cases {
        let (mut m, mut l) = (tetrahedron(), rope());
        spoil(&mut m, &mut l);
        let mut out = Vec::new();
        let e = write_glb(&mut out, &[tetrahedron(), m.clone()], &[l.clone()]).expect_err(what);
        assert!(expected(&e), "{what}: wrong error {e:?}");
        assert!(out.is_empty(), "{what}: {} bytes written", out.len());
        let path = dir.path().join("bad.glb");
        let e = write_glb_file(&path, &[m], &[l]).expect_err(what);
        assert!(expected(&e), "{what}: wrong error {e:?} from write_glb_file");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "{what}: a file was left");
    }
}

#[test]
fn an_unwritable_folder_is_an_error_naming_the_file() {
    let path = std::path::Path::new("/nonexistent-volcano-dir/x.glb");
    let e = write_glb_file(path, &[tetrahedron()], &[]).unwrap_err();
    assert!(matches!(e, GltfError::File(_)), "{e:?}");
    assert!(e.to_string().contains("/nonexistent-volcano-dir/x.glb"), "{e}");
}

fn arb_mesh() -> impl Strategy<Value = MeshData> {
    (1usize..40, 1usize..30, any::<[bool; 3]>()).prop_flat_map(|(n, tris, [has_n, has_c, has_t])| {
        let v3 = prop::array::uniform3(-1e6f32..1e6);
        (
            prop::collection::vec(v3.clone(), n),
            prop::collection::vec(
                v3.prop_filter("normalisable", |v| v.iter().map(|c| c * c).sum::<f32>() > 1.0),
                n,
            ),
            prop::collection::vec(0..n as u32, 3 * tris),
            prop::collection::vec(prop::array::uniform4(0f32..=1.0), n),
            prop::collection::vec(0f32..3000.0, n),
        )
            .prop_map(move |(positions, normals, indices, colors, t)| MeshData {
                name: "m".into(),
                positions,
                normals: has_n.then(|| {
                    normals
                        .iter()
                        .map(|v| {
                            let l = v.iter().map(|c| c * c).sum::<f32>().sqrt();
                            v.map(|c| c / l)
                        })
                        .collect()
                }),
                indices,
                colors: has_c.then_some(colors),
                temperature: has_t.then_some(t),
                emissive: None,
                base_color: [1.0; 4],
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random meshes come back bit for bit, with their bounds.
    #[test]
    fn random_meshes_read_back_exactly(meshes in prop::collection::vec(arb_mesh(), 1..4)) {
        let doc = gltf::Gltf::from_slice(&write(&meshes, &[])).unwrap();
        let read: Vec<_> = doc.meshes().map(|m| read_primitive(&doc, &m)).collect();
        prop_assert_eq!(read.len(), meshes.len());
        for (r, m) in read.iter().zip(&meshes) {
            prop_assert_eq!(&r.positions, &m.positions);
            prop_assert_eq!(&r.normals, &m.normals);
            prop_assert_eq!(&r.colors, &m.colors);
            prop_assert_eq!(&r.temperature, &m.temperature);
            prop_assert_eq!(&r.indices, &m.indices);
            for k in 0..3 {
                prop_assert_eq!(r.bounds.0[k], m.positions.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min));
                prop_assert_eq!(r.bounds.1[k], m.positions.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max));
            }
        }
    }
}
