//! The glTF document (`gltf-json`'s model) and its binary buffer, built from checked data.

use gltf_json as json;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::buffer::Target;
use json::material::{AlphaMode, EmissiveFactor, PbrBaseColorFactor, PbrMetallicRoughness, StrengthFactor};
use json::mesh::{Mode, Primitive, Semantic};
use json::validation::{Checked::Valid, USize64};
use json::{Index, Root};

use super::{GENERATOR, LineData, MeshData, TEMPERATURE_ATTRIBUTE};

/// The extension that lets emission exceed 1.
const EMISSIVE_STRENGTH: &str = "KHR_materials_emissive_strength";

/// The document and its binary buffer (the GLB's BIN chunk, a multiple of 4 bytes long).
/// The data must have passed `validate`: counts fit `u32` and the buffer fits a GLB.
pub(super) fn build(meshes: &[MeshData], lines: &[LineData]) -> (Root, Vec<u8>) {
    let mut b = Builder { root: Root::default(), bin: Vec::new() };
    b.root.asset.generator = Some(GENERATOR.into());
    let mut nodes = Vec::with_capacity(meshes.len() + lines.len());
    for m in meshes {
        let mut attributes = vec![(Semantic::Positions, b.positions(&m.positions))];
        if let Some(n) = &m.normals {
            attributes.push((Semantic::Normals, b.floats(n, Type::Vec3, Target::ArrayBuffer)));
        }
        if let Some(c) = &m.colors {
            attributes.push((Semantic::Colors(0), b.floats(c, Type::Vec4, Target::ArrayBuffer)));
        }
        if let Some(t) = &m.temperature {
            // `gltf-json` writes an `Extras` semantic with the leading underscore.
            let semantic = Semantic::Extras(TEMPERATURE_ATTRIBUTE[1..].into());
            let (t, _) = t.as_chunks::<1>();
            attributes.push((semantic, b.floats(t, Type::Scalar, Target::ArrayBuffer)));
        }
        let material = b.material(&m.name, m.base_color, m.emissive);
        nodes.push(b.mesh(&m.name, attributes, &m.indices, Mode::Triangles, material));
    }
    for l in lines {
        let attributes = vec![(Semantic::Positions, b.positions(&l.positions))];
        let material = b.material(&l.name, l.color, None);
        nodes.push(b.mesh(&l.name, attributes, &l.indices, Mode::Lines, material));
    }
    if !b.bin.is_empty() {
        let byte_length = USize64(b.bin.len() as u64);
        b.root.push(json::Buffer {
            byte_length,
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
    }
    if !nodes.is_empty() {
        let scene =
            b.root.push(json::Scene { extensions: None, extras: Default::default(), name: None, nodes });
        b.root.scene = Some(scene);
    }
    (b.root, b.bin)
}

struct Builder {
    root: Root,
    bin: Vec<u8>,
}

impl Builder {
    /// Appends `bytes` to the buffer as a buffer view of its own. Every element written is
    /// 4 bytes, so each view starts 4-byte aligned, as accessors of `f32` and `u32` require.
    fn view(&mut self, bytes: impl Iterator<Item = [u8; 4]>, target: Target) -> Index<json::buffer::View> {
        debug_assert!(self.bin.len().is_multiple_of(4));
        let offset = self.bin.len();
        self.bin.extend(bytes.flatten());
        self.root.push(json::buffer::View {
            buffer: Index::new(0),
            byte_length: USize64((self.bin.len() - offset) as u64),
            byte_offset: Some(USize64(offset as u64)),
            byte_stride: None,
            name: None,
            target: Some(Valid(target)),
            extensions: None,
            extras: Default::default(),
        })
    }

    fn accessor(
        &mut self,
        view: Index<json::buffer::View>,
        count: usize,
        component: ComponentType,
        type_: Type,
        bounds: Option<(json::Value, json::Value)>,
    ) -> Index<json::Accessor> {
        let (min, max) = bounds.unzip();
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64(count as u64),
            component_type: Valid(GenericComponentType(component)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// A float attribute of `N` components.
    fn floats<const N: usize>(
        &mut self,
        data: &[[f32; N]],
        type_: Type,
        target: Target,
    ) -> Index<json::Accessor> {
        let view = self.view(data.iter().flatten().map(|v| v.to_le_bytes()), target);
        self.accessor(view, data.len(), ComponentType::F32, type_, None)
    }

    /// `POSITION`, with the bounds the specification requires of it.
    fn positions(&mut self, p: &[[f32; 3]]) -> Index<json::Accessor> {
        let view = self.view(p.iter().flatten().map(|v| v.to_le_bytes()), Target::ArrayBuffer);
        let mut min = [f32::INFINITY; 3];
        let mut max = [f32::NEG_INFINITY; 3];
        for v in p {
            for k in 0..3 {
                min[k] = min[k].min(v[k]);
                max[k] = max[k].max(v[k]);
            }
        }
        let bounds = Some((json::Value::from(min.to_vec()), json::Value::from(max.to_vec())));
        self.accessor(view, p.len(), ComponentType::F32, Type::Vec3, bounds)
    }

    /// An opaque (or, with an alpha below 1, blended) dielectric, fully rough material.
    fn material(&mut self, name: &str, base: [f32; 4], emissive: Option<[f32; 3]>) -> Index<json::Material> {
        let mut material = json::Material {
            name: Some(name.into()),
            alpha_mode: Valid(if base[3] < 1.0 { AlphaMode::Blend } else { AlphaMode::Opaque }),
            pbr_metallic_roughness: PbrMetallicRoughness {
                base_color_factor: PbrBaseColorFactor(base),
                metallic_factor: StrengthFactor(0.0),
                roughness_factor: StrengthFactor(1.0),
                ..Default::default()
            },
            ..Default::default()
        };
        if let Some(e) = emissive {
            // `emissiveFactor` is limited to [0, 1]; brighter emission is the factor scaled
            // to 1 times the extension's strength, which readers without it ignore.
            let peak = e.iter().copied().fold(0.0f32, f32::max);
            if peak > 1.0 {
                material.emissive_factor = EmissiveFactor(e.map(|c| c / peak));
                // Set on a default value: a build that enables more of `gltf-json`'s
                // extensions (Bevy's glTF loader does) gives this struct more fields.
                let mut extensions = json::extensions::material::Material::default();
                extensions.emissive_strength = Some(json::extensions::material::EmissiveStrength {
                    emissive_strength: json::extensions::material::EmissiveStrengthFactor(peak),
                });
                material.extensions = Some(extensions);
                if !self.root.extensions_used.iter().any(|x| x == EMISSIVE_STRENGTH) {
                    self.root.extensions_used.push(EMISSIVE_STRENGTH.into());
                }
            } else {
                material.emissive_factor = EmissiveFactor(e);
            }
        }
        self.root.push(material)
    }

    /// A mesh of one indexed primitive and the node that places it.
    fn mesh(
        &mut self,
        name: &str,
        attributes: Vec<(Semantic, Index<json::Accessor>)>,
        indices: &[u32],
        mode: Mode,
        material: Index<json::Material>,
    ) -> Index<json::Node> {
        let view = self.view(indices.iter().map(|i| i.to_le_bytes()), Target::ElementArrayBuffer);
        let indices = self.accessor(view, indices.len(), ComponentType::U32, Type::Scalar, None);
        let primitive = Primitive {
            attributes: attributes.into_iter().map(|(s, a)| (Valid(s), a)).collect(),
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(material),
            mode: Valid(mode),
            targets: None,
        };
        let mesh = self.root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some(name.into()),
            primitives: vec![primitive],
            weights: None,
        });
        self.root.push(json::Node { mesh: Some(mesh), name: Some(name.into()), ..Default::default() })
    }
}
