//! The contract tables (Rust's side of each) and the checks over them.

use std::mem::size_of;

use ash::vk;

use super::spirv::{Module, StorageClass, Type};
use crate::geom::bvh_layout::{BvhNode, BvhTriangle};
use crate::gpu::raster::{self, TextureInfo};
use crate::gpu::rays::{self, GatherPoint, GatherSource, Hit, Ray, Segment};
use crate::gpu::shooting::{self, ElementGeometry, ShotParams};
use crate::gpu::{item, shaders, visibility};

/// A Rust struct the GPU reads or writes, and the GLSL struct it mirrors.
#[derive(Debug, Clone)]
struct Mirror {
    rust: &'static str,
    glsl: &'static str,
    size: usize,
    fields: Vec<MirroredField>,
}

/// A field of a [`Mirror`] and the GLSL member it mirrors.
#[derive(Debug, Clone)]
struct MirroredField {
    rust: &'static str,
    glsl: &'static str,
    offset: usize,
    size: usize,
}

/// `mirror!(RustType as "GlslStruct" { field, field => "glsl_member" })`:
/// a field mirrors the member of its own name unless one is given.
macro_rules! mirror {
    ($ty:ty as $glsl:literal { $($field:ident $(=> $member:literal)?),* $(,)? }) => {
        Mirror {
            rust: stringify!($ty),
            glsl: $glsl,
            size: size_of::<$ty>(),
            fields: vec![$(MirroredField {
                rust: stringify!($field),
                glsl: mirror!(@member $field $($member)?),
                offset: std::mem::offset_of!($ty, $field),
                size: size_of_field(|v: &$ty| &v.$field),
            }),*],
        }
    };
    (@member $field:ident) => { stringify!($field) };
    (@member $field:ident $member:literal) => { $member };
}

fn size_of_field<T, F>(_: impl Fn(&T) -> &F) -> usize {
    size_of::<F>()
}

/// Every struct shared with the shaders. GLSL members named `pad*` or
/// `_pad*` are padding and need no Rust field.
fn mirrors() -> Vec<Mirror> {
    vec![
        mirror!(ShotParams as "ShotParams" {
            face_view_proj, shooter_area, slot, hemicube_res, weight_offset,
            element_count, mode, hemicube_pixels, _pad0, shooter_ranks, outline,
            centre_radius, normal_area, outline_count, child_count, child_corners,
            child_outline, child_weight,
        }),
        mirror!(ElementGeometry as "Geometry" { corners => "corner", normal_count }),
        mirror!(BvhNode as "BvhNode" { min => "lo", index, max => "hi", count }),
        mirror!(BvhTriangle as "BvhTriangle" { v0, patch => "patch_id", e1, pad0, e2, pad1 }),
        mirror!(Segment as "Segment" { a, skip0, b, skip1 }),
        mirror!(Ray as "Ray" { a, skip, d, tmin }),
        mirror!(Hit as "Hit" { t, patch => "patch_id" }),
        mirror!(GatherPoint as "GatherPoint" { p, patch => "patch_id", n, stream }),
        mirror!(GatherSource as "GatherSource" {
            corners, normal, patch => "patch_id", radiosity, rays, corner_count, early_out,
        }),
        mirror!(TextureInfo as "TextureInfo" { first, width, height, clamped, scale, shift }),
    ]
}

/// A pipeline layout as Rust declares it, and the shaders that use it.
struct Pass {
    name: &'static str,
    /// The embedded modules (`shaders::*`) its pipelines are built from.
    shaders: Vec<&'static [u8]>,
    /// What Rust hands `Bindings::new`: (binding, descriptor type).
    layout: Vec<(u32, vk::DescriptorType)>,
    /// Which GLSL resource (block or variable name) Rust binds where.
    resources: Vec<(&'static str, u32)>,
    push_bytes: u32,
}

fn passes() -> Vec<Pass> {
    use rays::gather::{B_GATHERED, B_POINTS, B_SOURCES};
    use rays::{B_BVH_NODES, B_BVH_TRIANGLES, B_CHUNK_INPUT, B_CHUNK_OUTPUT};
    use shaders::*;
    use shooting::*;
    let chunked = || rays::ray_pass_layout([B_CHUNK_INPUT, B_CHUNK_OUTPUT]);
    let bvh = [("BvhNodes", B_BVH_NODES), ("BvhTriangles", B_BVH_TRIANGLES)];
    vec![
        Pass {
            name: "shooting",
            shaders: vec![
                HEMICUBE_VERT,
                HEMICUBE_FRAG,
                FF_REDUCE_COMP,
                FF_NODE_COMP,
                SHOT_LIGHT_COMP,
                SHOOT_COMP,
            ],
            layout: LAYOUT.to_vec(),
            resources: vec![
                ("ShotParams", B_PARAMS),
                ("item_buffer", B_ITEM),
                ("Weights", B_WEIGHTS),
                ("FormFactors", B_FF),
                ("Elements", B_ELEMENTS),
                ("Radiosity", B_RADIOSITY),
                ("Unshot", B_UNSHOT),
                ("ElementGeometry", B_GEOMETRY),
                ("Ranks", B_RANKS),
                ("ShotLight", B_SHOT_LIGHT),
                ("Order", B_ORDER),
            ],
            push_bytes: PUSH_BYTES,
        },
        Pass {
            name: "first-hit rays",
            shaders: vec![FIRST_HIT_COMP],
            layout: chunked(),
            resources: [
                &bvh[..],
                &[("Rays", B_CHUNK_INPUT), ("Hits", B_CHUNK_OUTPUT)],
            ]
            .concat(),
            push_bytes: rays::first_hit::PUSH_BYTES,
        },
        Pass {
            name: "ray occlusion",
            shaders: vec![OCCLUSION_COMP],
            layout: chunked(),
            resources: [
                &bvh[..],
                &[("Segments", B_CHUNK_INPUT), ("Visible", B_CHUNK_OUTPUT)],
            ]
            .concat(),
            push_bytes: rays::occlusion::PUSH_BYTES,
        },
        Pass {
            name: "source gather",
            shaders: vec![GATHER_SOURCES_COMP],
            layout: rays::ray_pass_layout([B_POINTS, B_SOURCES, B_GATHERED]),
            resources: [
                &bvh[..],
                &[
                    ("Points", B_POINTS),
                    ("Sources", B_SOURCES),
                    ("Gathered", B_GATHERED),
                ],
            ]
            .concat(),
            push_bytes: rays::gather::PUSH_BYTES,
        },
        Pass {
            name: "visibility draws",
            shaders: vec![DM_ITEM_VERT, DM_ITEM_FRAG],
            layout: vec![],
            resources: vec![],
            push_bytes: visibility::DRAW_PUSH_BYTES,
        },
        Pass {
            name: "visibility flags",
            shaders: vec![DM_FLAGS_COMP],
            layout: visibility::FLAG_LAYOUT.to_vec(),
            resources: vec![
                ("item_buffer", visibility::B_ITEM_BUFFER),
                ("Flags", visibility::B_FLAGS),
            ],
            push_bytes: visibility::FLAG_PUSH_BYTES,
        },
        Pass {
            name: "final render",
            shaders: vec![
                RENDER_VERT,
                RENDER_FRAG,
                RENDER_PLAIN_VERT,
                RENDER_PLAIN_FRAG,
            ],
            layout: raster::LAYOUT.to_vec(),
            resources: vec![
                ("Infos", raster::B_TEXTURE_INFOS),
                ("Texels", raster::B_TEXELS),
            ],
            push_bytes: raster::PUSH_BYTES,
        },
    ]
}

/// A constant that Rust and GLSL share: the GLSL file that defines it
/// (`#define` or `const`), its GLSL name, and Rust's value.
fn shared_constants() -> Vec<(&'static str, &'static str, f64)> {
    use crate::gpu::item::NO_ITEM;
    vec![
        (
            "gather_sources.comp",
            "MAX_CORNERS",
            rays::MAX_SOURCE_CORNERS as f64,
        ),
        ("gather_sources.comp", "FIRST_RAYS", rays::FIRST_RAYS as f64),
        ("gather_sources.comp", "CORNER_INSET", rays::CORNER_INSET),
        ("bvh.glsl", "BVH_STACK", rays::bvh::BVH_STACK as f64),
        ("shot_params.glsl", "NO_ELEMENT", f64::from(NO_ITEM)),
        ("shot_params.glsl", "FF_SCALE", 1.0 / shooting::FF_FIXED_ONE),
        ("dm_flags.comp", "NO_POLYGON", f64::from(NO_ITEM)),
        ("render.frag", "NO_TEXTURE", f64::from(raster::NO_TEXTURE)),
        ("ff_reduce.comp", "RUN", f64::from(shooting::REDUCE_RUN)),
        // ff_node's polygons hold an outline clipped by one plane.
        (
            "ff_node.comp",
            "MAX_CORNERS",
            (shooting::MAX_OUTLINE + 1) as f64,
        ),
    ]
}

/// The file name of an embedded module (`shaders::ALL`).
fn file_name(bytes: &[u8]) -> &'static str {
    shaders::ALL
        .iter()
        .find(|(_, b)| *b == bytes)
        .map_or("?", |(name, _)| name)
}

/// An embedded module, parsed.
fn module(bytes: &[u8]) -> Module {
    let name = file_name(bytes);
    let module = Module::parse(bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(
        !module.names.is_empty(),
        "{name} carries no OpName: compiled with -g0 or stripped? Regenerate spirv/ as \
         tests/it/shaders.rs says"
    );
    module
}

fn all_modules() -> Vec<(&'static str, Module)> {
    shaders::ALL
        .iter()
        .map(|&(name, bytes)| (name, module(bytes)))
        .collect()
}

/// An optional value as a message shows it.
fn shown<T: std::fmt::Debug>(value: Option<T>) -> String {
    value.map_or("none".to_string(), |v| format!("{v:?}"))
}

fn is_padding(member: &str) -> bool {
    member.starts_with("pad") || member.starts_with("_pad")
}

/// How `shader`'s laid-out copies of `mirror.glsl` differ from `mirror`,
/// one line per difference, each naming the member.
fn struct_mismatches(shader: &str, module: &Module, mirror: &Mirror) -> Vec<String> {
    let mut out = Vec::new();
    for id in module.laid_out_structs(mirror.glsl) {
        let members = module.members(id);
        for (index, (name, _)) in (0u32..).zip(&members) {
            let what = format!("{shader}: {}.{name}", mirror.glsl);
            let Some(field) = mirror.fields.iter().find(|f| f.glsl == name) else {
                if !is_padding(name) {
                    out.push(format!("{what} has no field in Rust's {}", mirror.rust));
                }
                continue;
            };
            let rust = format!("{}::{}", mirror.rust, field.rust);
            let offset = module.member_offset(id, index).map(|o| o as usize);
            if offset != Some(field.offset) {
                out.push(format!(
                    "{what}: offset {} in SPIR-V, {} in {rust}",
                    shown(offset),
                    field.offset
                ));
            }
            let size = module.member_size(id, index).map(|s| s as usize);
            if size != Some(field.size) {
                out.push(format!(
                    "{what}: {} bytes in SPIR-V, {} in {rust}",
                    shown(size),
                    field.size
                ));
            }
        }
        for field in &mirror.fields {
            if !members.iter().any(|(name, _)| name == field.glsl) {
                out.push(format!(
                    "{shader}: {}::{} mirrors {}.{}, which the shader lacks",
                    mirror.rust, field.rust, mirror.glsl, field.glsl
                ));
            }
        }
        let strides = module.strides_of_arrays_of(id);
        for &stride in &strides {
            if stride != Some(mirror.size as u32) {
                out.push(format!(
                    "{shader}: arrays of {} step {} bytes, size_of::<{}>() is {}",
                    mirror.glsl,
                    shown(stride),
                    mirror.rust,
                    mirror.size
                ));
            }
        }
        // A block, in no array: its members must fill the Rust struct.
        let extent = module.size(id, None).map(|s| s as usize);
        if strides.is_empty() && extent != Some(mirror.size) {
            out.push(format!(
                "{shader}: {} spans {} bytes, size_of::<{}>() is {}",
                mirror.glsl,
                shown(extent),
                mirror.rust,
                mirror.size
            ));
        }
    }
    out
}

/// What Vulkan descriptor types a resource of this kind may be bound as.
fn descriptor_types(
    module: &Module,
    storage: StorageClass,
    ty: u32,
) -> &'static [vk::DescriptorType] {
    match (storage, module.types.get(&ty)) {
        (StorageClass::StorageBuffer, _) => &[vk::DescriptorType::STORAGE_BUFFER],
        (StorageClass::Uniform, _) => &[
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC,
        ],
        (StorageClass::UniformConstant, Some(Type::Image { sampled: 2 })) => {
            &[vk::DescriptorType::STORAGE_IMAGE]
        }
        (StorageClass::UniformConstant, Some(Type::Image { .. })) => {
            &[vk::DescriptorType::SAMPLED_IMAGE]
        }
        _ => &[],
    }
}

/// How the shaders of `pass` differ from what Rust declares for it: each
/// resource's (set, binding) and descriptor type, and the push constants.
fn binding_mismatches(pass: &Pass) -> Vec<String> {
    let mut out = Vec::new();
    for &bytes in &pass.shaders {
        let module = module(bytes);
        let what = format!("{} pass, {}", pass.name, file_name(bytes));
        for v in &module.variables {
            if v.storage == StorageClass::PushConstant {
                let size = module.size(v.ty, None);
                if size.is_none_or(|size| size > pass.push_bytes) {
                    out.push(format!(
                        "{what}: push constants of {} bytes, Rust declares {}",
                        shown(size),
                        pass.push_bytes
                    ));
                }
                continue;
            }
            let allowed = descriptor_types(&module, v.storage, v.ty);
            if allowed.is_empty() {
                continue; // not a descriptor
            }
            // A block by its type's name; an image by the variable's.
            let name = match module.types.get(&v.ty) {
                Some(Type::Struct { .. }) => module.name(v.ty),
                _ => module.name(v.id),
            }
            .unwrap_or("?");
            let binding = module.binding(v.id);
            let set = module.descriptor_set(v.id);
            let Some(&(_, rust_binding)) = pass.resources.iter().find(|(n, _)| *n == name) else {
                out.push(format!(
                    "{what}: {name} (binding {}) is not one Rust binds",
                    shown(binding)
                ));
                continue;
            };
            if set != Some(0) || binding != Some(rust_binding) {
                out.push(format!(
                    "{what}: {name} at (set {}, binding {}), Rust binds it at \
                     (set 0, binding {rust_binding})",
                    shown(set),
                    shown(binding)
                ));
            }
            match pass.layout.iter().find(|(b, _)| *b == rust_binding) {
                Some((_, ty)) if allowed.contains(ty) => {}
                declared => out.push(format!(
                    "{what}: {name} needs one of {allowed:?}, Rust's layout declares \
                     binding {rust_binding} as {}",
                    shown(declared.map(|d| d.1))
                )),
            }
        }
    }
    out
}

/// The Vulkan format that feeds a vertex input of type `ty`.
fn vertex_format(module: &Module, ty: u32) -> Option<vk::Format> {
    let scalar = |id: u32| match module.types.get(&id) {
        Some(Type::Float { width: 32 }) => Some(0),
        Some(Type::Int {
            width: 32,
            signed: false,
        }) => Some(1),
        Some(Type::Int {
            width: 32,
            signed: true,
        }) => Some(2),
        _ => None,
    };
    let (kind, count) = match module.types.get(&ty)? {
        Type::Vector { component, count } => (scalar(*component)?, *count),
        _ => (scalar(ty)?, 1),
    };
    use vk::Format as F;
    let formats = [
        [
            F::R32_SFLOAT,
            F::R32G32_SFLOAT,
            F::R32G32B32_SFLOAT,
            F::R32G32B32A32_SFLOAT,
        ],
        [
            F::R32_UINT,
            F::R32G32_UINT,
            F::R32G32B32_UINT,
            F::R32G32B32A32_UINT,
        ],
        [
            F::R32_SINT,
            F::R32G32_SINT,
            F::R32G32B32_SINT,
            F::R32G32B32A32_SINT,
        ],
    ];
    formats[kind].get(count as usize - 1).copied()
}

/// The GLSL value of `name` in `glsl/{file}`: a `#define` or a `const`,
/// a number or a quotient of two.
fn glsl_constant(file: &str, name: &str) -> Result<f64, String> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("glsl")
        .join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let value = text.lines().find_map(|line| {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("#define ") {
            let (n, value) = rest.split_once(char::is_whitespace)?;
            return (n == name).then(|| value.trim());
        }
        let rest = line.strip_prefix("const ")?;
        let (_type, rest) = rest.split_once(char::is_whitespace)?;
        let (n, value) = rest.split_once('=')?;
        (n.trim() == name).then(|| value.trim().trim_end_matches(';').trim())
    });
    let value = value.ok_or(format!("glsl/{file} defines no {name}"))?;
    let number = |s: &str| {
        let s = s.trim().trim_end_matches(['u', 'U']);
        match s.strip_prefix("0x").or(s.strip_prefix("0X")) {
            Some(hex) => u64::from_str_radix(hex, 16).map(|v| v as f64).ok(),
            None => s.trim_end_matches(['f', 'F']).parse::<f64>().ok(),
        }
    };
    let parsed = match value.split_once('/') {
        Some((a, b)) => number(a).zip(number(b)).map(|(a, b)| a / b),
        None => number(value),
    };
    parsed.ok_or(format!("glsl/{file}: {name} = {value} is not a number"))
}

/// `Some(description)` when GLSL's `name` in `file` is not `rust`.
fn constant_mismatch(file: &str, name: &str, rust: f64) -> Option<String> {
    match glsl_constant(file, name) {
        Ok(glsl) if glsl == rust => None,
        Ok(glsl) => Some(format!("glsl/{file}: {name} is {glsl}, Rust's is {rust}")),
        Err(e) => Some(e),
    }
}

fn assert_none(heading: &str, mismatches: Vec<String>) {
    assert!(
        mismatches.is_empty(),
        "{heading}:\n  {}",
        mismatches.join("\n  ")
    );
}

#[test]
fn shared_structs_match_their_rust_mirrors() {
    let modules = all_modules();
    let mut mismatches = Vec::new();
    for mirror in mirrors() {
        let mut found = false;
        for (shader, module) in &modules {
            found |= !module.laid_out_structs(mirror.glsl).is_empty();
            mismatches.extend(struct_mismatches(shader, module, &mirror));
        }
        if !found {
            mismatches.push(format!(
                "no shader lays out {} (mirrored by {}): renamed?",
                mirror.glsl, mirror.rust
            ));
        }
    }
    assert_none("struct layouts differ between Rust and GLSL", mismatches);
}

#[test]
fn every_struct_the_shaders_lay_out_has_a_rust_mirror() {
    let mirrored: Vec<&str> = mirrors().iter().map(|m| m.glsl).collect();
    let mut unmirrored = Vec::new();
    for (shader, module) in all_modules() {
        for (&id, ty) in &module.types {
            let Type::Struct { members } = ty else {
                continue;
            };
            let name = module.name(id).unwrap_or("?");
            let block = module.variables.iter().find(|v| v.ty == id);
            // Blocks that only wrap one runtime array, and push blocks
            // (which Rust fills from arrays), need no mirror.
            let wraps_one_array = members.len() == 1
                && matches!(
                    module.types.get(&members[0]),
                    Some(Type::RuntimeArray { .. })
                );
            let exempt =
                block.is_some_and(|v| v.storage == StorageClass::PushConstant || wraps_one_array);
            let laid_out = module.member_offset(id, 0).is_some();
            if laid_out && !exempt && !mirrored.contains(&name) {
                unmirrored.push(format!("{shader}: {name}"));
            }
        }
    }
    unmirrored.sort();
    unmirrored.dedup();
    assert_none("structs with no Rust mirror in mirrors()", unmirrored);
}

#[test]
fn descriptor_bindings_and_push_constants_match_each_pass() {
    let mismatches = passes().iter().flat_map(binding_mismatches).collect();
    assert_none("bindings differ from what Rust declares", mismatches);
}

#[test]
fn every_shader_belongs_to_a_checked_pass() {
    let checked: Vec<&[u8]> = passes().iter().flat_map(|p| p.shaders.clone()).collect();
    let unchecked: Vec<String> = shaders::ALL
        .iter()
        .filter(|(_, bytes)| !checked.contains(bytes))
        .map(|(name, _)| name.to_string())
        .collect();
    assert_none("shaders in no pass of passes()", unchecked);
}

#[test]
fn vertex_inputs_match_the_attributes_rust_declares() {
    type Attribute = (u32, vk::Format, u32);
    let vertex_shaders: [(&[u8], &[Attribute]); 4] = [
        (shaders::RENDER_VERT, &raster::LIT_ATTRIBUTES),
        (shaders::RENDER_PLAIN_VERT, &raster::PLAIN_ATTRIBUTES),
        (shaders::HEMICUBE_VERT, &item::ITEM_ATTRIBUTES),
        (shaders::DM_ITEM_VERT, &item::ITEM_ATTRIBUTES),
    ];
    let mut mismatches = Vec::new();
    for (bytes, attributes) in vertex_shaders {
        let (shader, module) = (file_name(bytes), module(bytes));
        let inputs: Vec<(u32, Option<vk::Format>, &str)> = module
            .variables
            .iter()
            .filter(|v| v.storage == StorageClass::Input)
            .filter_map(|v| {
                let location = module.location(v.id)?;
                Some((location, vertex_format(&module, v.ty), module.name(v.id)?))
            })
            .collect();
        for &(location, format, name) in &inputs {
            let fed = attributes.iter().find(|a| a.0 == location).map(|a| a.1);
            if fed.is_none() || fed != format {
                mismatches.push(format!(
                    "{shader}: {name} (location {location}) takes {}, Rust feeds {}",
                    shown(format),
                    shown(fed)
                ));
            }
        }
        for a in attributes {
            if !inputs.iter().any(|i| i.0 == a.0) {
                mismatches.push(format!("{shader}: no input at Rust's location {}", a.0));
            }
        }
    }
    assert_none("vertex inputs differ from Rust's attributes", mismatches);
}

#[test]
fn workgroup_sizes_match_the_dispatches() {
    let rays = rays::GROUP_SIZE as u32;
    let shooting = shooting::GROUP_SIZE;
    let flags = visibility::FLAG_GROUP;
    let expected: [(&[u8], [u32; 3]); 7] = [
        (shaders::FIRST_HIT_COMP, [rays, 1, 1]),
        (shaders::OCCLUSION_COMP, [rays, 1, 1]),
        (shaders::GATHER_SOURCES_COMP, [rays, 1, 1]),
        (shaders::FF_REDUCE_COMP, [shooting, 1, 1]),
        (shaders::FF_NODE_COMP, [shooting, 1, 1]),
        (shaders::SHOOT_COMP, [shooting, 1, 1]),
        (shaders::DM_FLAGS_COMP, [flags, flags, 1]),
    ];
    let mismatches = expected
        .iter()
        .filter_map(|&(bytes, rust)| {
            let glsl = module(bytes).local_size;
            (glsl != Some(rust)).then(|| {
                let shader = file_name(bytes);
                format!(
                    "{shader}: local size {}, Rust dispatches {rust:?}",
                    shown(glsl)
                )
            })
        })
        .collect();
    assert_none("workgroup sizes differ from Rust's", mismatches);
}

#[test]
fn shared_constants_match_rust() {
    let mismatches = shared_constants()
        .into_iter()
        .filter_map(|(file, name, rust)| constant_mismatch(file, name, rust))
        .collect();
    assert_none("constants differ between Rust and GLSL", mismatches);
}

#[test]
fn array_lengths_match_rust_constants() {
    let expected = [
        ("ShotParams", "outline", shooting::MAX_OUTLINE),
        ("ShotParams", "child_corners", shooting::MAX_CHILDREN),
        ("ShotParams", "child_weight", shooting::MAX_CHILDREN),
        ("ShotParams", "child_outline", 4 * shooting::MAX_CHILDREN),
        ("GatherSource", "corners", rays::MAX_SOURCE_CORNERS),
    ];
    let mut mismatches = Vec::new();
    for (shader, module) in all_modules() {
        for (strukt, member, rust) in expected {
            for id in module.laid_out_structs(strukt) {
                let glsl = module
                    .members(id)
                    .into_iter()
                    .find(|(name, _)| name == member)
                    .and_then(|(_, ty)| module.array_length(ty));
                if glsl != Some(rust as u32) {
                    mismatches.push(format!(
                        "{shader}: {strukt}.{member} holds {}, Rust {rust}",
                        shown(glsl)
                    ));
                }
            }
        }
    }
    assert_none("array lengths differ from Rust's constants", mismatches);
}

/// The checks must be able to fail: each runs on a table with one planted
/// error, and must name it.
#[test]
fn the_checks_report_a_planted_mismatch_by_name() {
    let gather = module(shaders::GATHER_SOURCES_COMP);
    let mut point = mirrors()
        .into_iter()
        .find(|m| m.rust == "GatherPoint")
        .expect("GatherPoint is mirrored");
    assert_eq!(struct_mismatches("gather", &gather, &point), [""; 0]);
    let stream = point.fields.iter_mut().find(|f| f.rust == "stream");
    stream.expect("GatherPoint has a stream").offset -= 4;
    let found = struct_mismatches("gather", &gather, &point);
    assert!(
        found
            .iter()
            .any(|m| m.contains("GatherPoint.stream: offset 28")),
        "a wrong offset went unreported: {found:?}"
    );

    let mut pass = passes()
        .into_iter()
        .find(|p| p.name == "source gather")
        .expect("the source gather is a pass");
    assert_eq!(binding_mismatches(&pass), [""; 0]);
    let sources = pass.resources.iter_mut().find(|r| r.0 == "Sources");
    sources.expect("the gather binds Sources").1 += 1;
    let found = binding_mismatches(&pass);
    assert!(
        found
            .iter()
            .any(|m| m.contains("Sources at (set 0, binding 3)")),
        "a wrong binding went unreported: {found:?}"
    );

    let first_rays = rays::FIRST_RAYS as f64;
    let file = "gather_sources.comp";
    assert_eq!(constant_mismatch(file, "FIRST_RAYS", first_rays), None);
    let found = constant_mismatch(file, "FIRST_RAYS", first_rays + 1.0);
    assert!(
        found
            .as_deref()
            .is_some_and(|m| m.contains("FIRST_RAYS is 16")),
        "a wrong constant went unreported: {found:?}"
    );
}
