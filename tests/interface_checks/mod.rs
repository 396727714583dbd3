//! Support for `tests/shader_interfaces.rs`: resource kinds of bindings
//! on both sides, and struct layouts from Rust (`host!`) and from naga,
//! with their comparison.

use naga::{AddressSpace, Handle, Module, ScalarKind, StorageAccess, Type, TypeInner};
use std::mem::size_of;

/// A binding's resource kind, as WGSL declares it or a layout entry says.
/// Compared for equality, as wgpu does when it creates a pipeline (it
/// compares address spaces, storage access included).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Uniform,
    StorageRead,
    StorageReadWrite,
    Texture,
    StorageTexture,
    Sampler,
    Other,
}

/// The kind of a WGSL global with a binding.
pub fn wgsl_kind(module: &Module, var: &naga::GlobalVariable) -> Kind {
    match var.space {
        AddressSpace::Uniform => Kind::Uniform,
        AddressSpace::Storage { access } if access.contains(StorageAccess::STORE) => {
            Kind::StorageReadWrite
        }
        AddressSpace::Storage { .. } => Kind::StorageRead,
        AddressSpace::Handle => match module.types[var.ty].inner {
            TypeInner::Image {
                class: naga::ImageClass::Storage { .. },
                ..
            } => Kind::StorageTexture,
            TypeInner::Image { .. } => Kind::Texture,
            TypeInner::Sampler { .. } => Kind::Sampler,
            _ => Kind::Other,
        },
        _ => Kind::Other,
    }
}

/// The kind of a Rust layout entry.
pub fn layout_kind(entry: &wgpu::BindGroupLayoutEntry) -> Kind {
    match entry.ty {
        wgpu::BindingType::Buffer { ty, .. } => match ty {
            wgpu::BufferBindingType::Uniform => Kind::Uniform,
            wgpu::BufferBindingType::Storage { read_only: true } => Kind::StorageRead,
            wgpu::BufferBindingType::Storage { read_only: false } => Kind::StorageReadWrite,
        },
        wgpu::BindingType::Texture { .. } => Kind::Texture,
        wgpu::BindingType::StorageTexture { .. } => Kind::StorageTexture,
        wgpu::BindingType::Sampler(_) => Kind::Sampler,
        _ => Kind::Other,
    }
}

/// A scalar's kind and width in bytes.
pub type Scalar = (ScalarKind, u8);

/// The scalar a host field is made of.
pub trait HostScalar {
    const SCALAR: Scalar;
}
impl HostScalar for u32 {
    const SCALAR: Scalar = (ScalarKind::Uint, 4);
}
impl HostScalar for i32 {
    const SCALAR: Scalar = (ScalarKind::Sint, 4);
}
impl HostScalar for f32 {
    const SCALAR: Scalar = (ScalarKind::Float, 4);
}
impl HostScalar for u8 {
    const SCALAR: Scalar = (ScalarKind::Uint, 1);
}
impl HostScalar for glam::Vec3 {
    const SCALAR: Scalar = (ScalarKind::Float, 4);
}
impl<T: HostScalar, const N: usize> HostScalar for [T; N] {
    const SCALAR: Scalar = T::SCALAR;
}

/// A member of either side: name, byte range start, size, scalar.
#[derive(Clone, Debug)]
pub struct Field {
    pub name: String,
    pub offset: usize,
    pub size: usize,
    pub scalar: Option<Scalar>,
}

impl Field {
    fn end(&self) -> usize {
        self.offset + self.size
    }
    fn is_pad(&self) -> bool {
        self.name.starts_with('_')
    }
}

/// A struct's members and size, from Rust or from naga.
pub struct Layout {
    pub name: String,
    pub size: usize,
    pub fields: Vec<Field>,
}

/// The field `f` of `S` (its type found through the accessor).
pub fn host_field<S, F: HostScalar>(name: &str, offset: usize, _: fn(&S) -> &F) -> Field {
    Field {
        name: name.to_string(),
        offset,
        size: size_of::<F>(),
        scalar: Some(F::SCALAR),
    }
}

/// The [`Layout`] of a Rust struct; list every field, in order.
macro_rules! host {
    ($t:ty { $($f:ident),+ $(,)? }) => {
        $crate::interface_checks::Layout {
            name: stringify!($t).to_string(),
            size: std::mem::size_of::<$t>(),
            fields: vec![$($crate::interface_checks::host_field(
                stringify!($f),
                std::mem::offset_of!($t, $f),
                |s: &$t| &s.$f,
            )),+],
        }
    };
}

/// The scalar a WGSL type is made of (None for structs).
pub fn wgsl_scalar(module: &Module, ty: Handle<Type>) -> Option<Scalar> {
    match module.types[ty].inner {
        TypeInner::Scalar(s)
        | TypeInner::Vector { scalar: s, .. }
        | TypeInner::Matrix { scalar: s, .. }
        | TypeInner::Atomic(s) => Some((s.kind, s.width)),
        TypeInner::Array { base, .. } => wgsl_scalar(module, base),
        _ => None,
    }
}

/// Adds to `out` every struct type inside `ty` (itself, array elements,
/// members).
pub fn structs_in(module: &Module, ty: Handle<Type>, out: &mut Vec<Handle<Type>>) {
    match &module.types[ty].inner {
        TypeInner::Struct { members, .. } if !out.contains(&ty) => {
            out.push(ty);
            for m in members {
                structs_in(module, m.ty, out);
            }
        }
        TypeInner::Array { base, .. } | TypeInner::BindingArray { base, .. } => {
            structs_in(module, *base, out)
        }
        _ => {}
    }
}

/// A WGSL struct's layout, as naga computed it for the module.
pub fn wgsl_layout(module: &Module, ty: Handle<Type>) -> Layout {
    let TypeInner::Struct { members, span } = &module.types[ty].inner else {
        unreachable!("structs_in returns structs")
    };
    let fields = members
        .iter()
        .map(|m| Field {
            name: m.name.clone().unwrap_or_default(),
            offset: m.offset as usize,
            size: module.types[m.ty].inner.size(module.to_ctx()) as usize,
            scalar: wgsl_scalar(module, m.ty),
        })
        .collect();
    Layout {
        name: module.types[ty].name.clone().unwrap_or_default(),
        size: *span as usize,
        fields,
    }
}

/// The differences between a WGSL struct and its Rust mirror: size; a Rust
/// field and a WGSL member that overlap without one containing the other;
/// bytes that carry data on one side and padding (a `_` name, or no
/// member) on the other; the scalar kind of members that coincide; and
/// names both sides have at different places.
pub fn struct_errors(wgsl: &Layout, rust: &Layout) -> Vec<String> {
    let mut errors = Vec::new();
    if wgsl.size != rust.size {
        errors.push(format!("size {} in WGSL, {} in Rust", wgsl.size, rust.size));
    }
    for r in &rust.fields {
        for w in &wgsl.fields {
            let overlap = r.offset < w.end() && w.offset < r.end();
            let nested = (r.offset <= w.offset && w.end() <= r.end())
                || (w.offset <= r.offset && r.end() <= w.end());
            if overlap && !nested {
                errors.push(format!(
                    "Rust `{}` {} straddles WGSL `{}` {}",
                    r.name,
                    range(r),
                    w.name,
                    range(w)
                ));
            }
            if r.offset == w.offset
                && r.size == w.size
                && r.scalar.map(|s| s.0) != w.scalar.map(|s| s.0)
            {
                errors.push(format!(
                    "Rust `{}` is {:?}, WGSL `{}` is {:?}",
                    r.name, r.scalar, w.name, w.scalar
                ));
            }
            if r.name == w.name && (r.offset, r.size) != (w.offset, w.size) {
                errors.push(format!(
                    "`{}` is {} in Rust, {} in WGSL",
                    r.name,
                    range(r),
                    range(w)
                ));
            }
        }
    }
    for byte in 0..wgsl.size.max(rust.size) {
        match (data_at(&rust.fields, byte), data_at(&wgsl.fields, byte)) {
            (Some(r), None) => errors.push(format!(
                "Rust `{}` {} lies in WGSL padding",
                r.name,
                range(r)
            )),
            (None, Some(w)) => errors.push(format!(
                "WGSL `{}` {} lies in Rust padding",
                w.name,
                range(w)
            )),
            _ => continue,
        }
        break;
    }
    errors
}

/// The field that holds byte `byte` unless it is padding.
fn data_at(fields: &[Field], byte: usize) -> Option<&Field> {
    fields
        .iter()
        .find(|f| f.offset <= byte && byte < f.end() && !f.is_pad())
}

fn range(f: &Field) -> String {
    format!("[{}, {})", f.offset, f.end())
}

/// [`struct_errors`] itself: a WGSL `vec3<f32>` + `f32` against Rust
/// mirrors that are right, misordered, misplaced, straddling or short.
#[test]
fn struct_comparison_catches_mismatches() {
    let f = |name: &str, offset, size, kind| Field {
        name: name.to_string(),
        offset,
        size,
        scalar: Some((kind, 4)),
    };
    let layout = |fields: Vec<Field>, size| Layout {
        name: "S".into(),
        size,
        fields,
    };
    let float = ScalarKind::Float;
    let wgsl = layout(vec![f("p", 0, 12, float), f("r", 12, 4, float)], 16);
    let check = |fields, size| struct_errors(&wgsl, &layout(fields, size));
    assert!(check(vec![f("p", 0, 12, float), f("r", 12, 4, float)], 16).is_empty());
    // The same bytes, other names: fine; other kinds: not.
    assert!(check(vec![f("q", 0, 12, float), f("s", 12, 4, float)], 16).is_empty());
    let kinds = check(
        vec![f("p", 0, 12, float), f("r", 12, 4, ScalarKind::Uint)],
        16,
    );
    assert_eq!(kinds.len(), 1, "{kinds:?}");
    // `r` first: a shared name elsewhere, and straddling members.
    let swapped = check(vec![f("r", 0, 4, float), f("p", 4, 12, float)], 16);
    assert!(
        swapped.iter().any(|e| e.contains("straddles")),
        "{swapped:?}"
    );
    assert!(swapped.iter().any(|e| e.contains("`r` is")), "{swapped:?}");
    // Data where the other side has padding, and a size mismatch.
    let padded = check(vec![f("p", 0, 12, float), f("_pad", 12, 4, float)], 16);
    assert!(padded[0].contains("lies in Rust padding"), "{padded:?}");
    let short = check(vec![f("p", 0, 12, float)], 12);
    assert!(
        short.iter().any(|e| e.contains("size 16 in WGSL, 12")),
        "{short:?}"
    );
    assert!(
        short.iter().any(|e| e.contains("lies in Rust padding")),
        "{short:?}"
    );
}
