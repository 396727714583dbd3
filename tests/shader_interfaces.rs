//! The GPU interfaces, checked without a GPU.
//!
//! Rust and WGSL agree on three things that nothing else checks before a
//! device compiles a pipeline (and some not even then): that the WGSL is
//! valid, that the bind-group layouts built in Rust have the
//! `@group/@binding` numbers and resource kinds the kernels declare, and
//! that every `#[repr(C)]` host struct has the byte layout of the WGSL
//! struct it mirrors (a mismatch there reads garbage without any error).
//!
//! This test assembles every shader module the crate builds through the
//! same device-free functions the runtime calls (`source`, `base_wgsl`,
//! `layout_entries`, ...), over every integrand variant, and
//!
//! 1. parses and validates each with naga, the front end and validator
//!    wgpu itself runs, with no optional capability: the kernels must work
//!    on a device without the optional features `Gpu` asks for;
//! 2. compares, for every entry point, the bindings it uses with the Rust
//!    layouts of its pipeline's groups, and every Rust layout entry with
//!    the module's declaration at that slot;
//! 3. compares the members (offset, size, scalar kind, shared names) of
//!    every struct behind a uniform or storage binding with its Rust
//!    mirror ([`mirrors`]); a struct without one fails the test;
//! 4. checks that every file under `wgsl/` is part of some module.
//!
//! No wgpu instance, adapter or device is created.

mod common;
#[macro_use]
mod interface_checks;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::OnceLock;

use interface_checks::{layout_kind, struct_errors, structs_in, wgsl_kind, wgsl_layout, Layout};
use mdas::accel::{
    GpuEmitter, GpuInstance, GpuKeyframe, GpuLight, GpuMaterial, GpuScene, HitRecord, Ray,
    SceneUniforms, TraceKernel,
};
use mdas::film::Film;
use mdas::gpu::radix_sort;
use mdas::gpu::shader::Wgsl;
use mdas::integrand::{
    ambient_occlusion, area_light, depth_of_field, many_light, motion_blur, path,
};
use mdas::integrator::mdas::MdasParams;
use mdas::integrator::mdas::{
    adapt, config::Config, error, evaluate, gpu_params, initial, plan, reconstruct, scan, stats,
};
use mdas::integrator::{adaptive, halton};
use mdas::lights::gpu_sampler::{BatchSampler, GpuSamplerData, SampleAnswer, SampleQuery};
use mdas::lights::lgh::gpu::{GpuLgh, LghBuildParams};
use mdas::lights::lgh::GridLight;
use mdas::lights::registry::SamplerKind;
use mdas::lights::substitute::gpu_build::{GpuRadixTree, RadixParams};
use mdas::lights::tree::gpu_build::{BuildParams, GpuLightTree};
use mdas::lights::two_level::gpu::{GpuTwoLevel, Tree2Params};
use mdas::lights::vpl::{VplGenerator, VplParams};
use mdas::lights::{gpu_sampler::LightParams, AliasEntry, LightPrim, TreeNode};
use mdas::wgsl_file;
use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};
use naga::{AddressSpace, Handle, Module, SourceLocation, Type};

type Entries = Vec<wgpu::BindGroupLayoutEntry>;

/// One shader module as the runtime assembles it, with the layouts of the
/// bind groups its pipelines are built with (index = group).
struct Kernel {
    name: String,
    source: String,
    groups: Vec<Entries>,
}

fn kernel(name: impl Into<String>, wgsl: &Wgsl, groups: &[Entries]) -> Kernel {
    Kernel {
        name: name.into(),
        source: wgsl.source(),
        groups: groups.to_vec(),
    }
}

/// An integrand variant: name, dimension count, WGSL and group-1 layout.
struct Integrand {
    name: String,
    dims: u32,
    wgsl: Wgsl,
    group1: Entries,
}

/// Every integrand source the crate can build (the sources differ only in
/// the generated constants listed here; the many-light sampler kind is a
/// uniform), and the test integrands the integrator tests use.
fn integrands() -> Vec<Integrand> {
    let scene = GpuScene::layout_entries;
    let one = |name: &str, dims, wgsl, group1| Integrand {
        name: name.to_string(),
        dims,
        wgsl,
        group1,
    };
    let mut all = vec![
        one("area_light", 4, area_light::source(), scene()),
        one("depth_of_field", 4, depth_of_field::source(), scene()),
        one("motion_blur", 3, motion_blur::source(), scene()),
        one(
            "ambient_occlusion",
            4,
            ambient_occlusion::source(0.5),
            scene(),
        ),
    ];
    for nee in [false, true] {
        for bounces in 1..=path::max_bounces_limit(nee) {
            let name = format!("path[bounces={bounces}, area_nee={nee}]");
            let dims = path::path_dims(bounces, nee);
            all.push(one(&name, dims, path::source(bounces, nee), scene()));
        }
    }
    for triangles in [false, true] {
        let name = format!("many_light[triangles={triangles}]");
        let dims = if triangles { 5 } else { 3 };
        let wgsl = many_light::source(triangles, SamplerKind::Tree);
        all.push(one(&name, dims, wgsl, many_light::layout_entries()));
    }
    // sst: dimensions 3–5 hold a substitute's Gaussian position.
    let wgsl = many_light::source(true, SamplerKind::Sst);
    all.push(one(
        "many_light[sst]",
        6,
        wgsl,
        many_light::layout_entries(),
    ));
    // lgh: dimension 2 stratifies the shadow picks, 3–5 jitter them, 6–8
    // sample an emissive triangle.
    for (triangles, dims) in [(false, 6), (true, 9)] {
        let wgsl = many_light::source(triangles, SamplerKind::Lgh);
        let name = format!("many_light[lgh, triangles={triangles}]");
        all.push(one(&name, dims, wgsl, many_light::layout_entries()));
    }
    for case in 0..=7 {
        let wgsl = common::test_integrand_source(case);
        let group1 = common::test_integrand_layout_entries();
        all.push(one(&format!("test[case={case}]"), 3, wgsl, group1));
    }
    all
}

/// A valid MDAS configuration for `dims` dimensions: the default
/// parameters, with `bits_per_dim` 0 where the default's Morton code would
/// not fit, and a budget that covers the initial grid.
fn mdas_config(dims: u32) -> Config {
    let mut params = MdasParams {
        bits_per_dim: if dims <= 10 { 1 } else { 0 },
        ..MdasParams::default()
    };
    let film = Film {
        width: 64,
        height: 64,
    };
    let cells = 1u64 << (dims * params.bits_per_dim + 2 * params.extra_image_bits);
    params.spp = (cells as f32 / 4096.0).max(params.spp);
    Config::new(params, dims, film, 0).expect("a valid MDAS configuration")
}

/// Every module the crate builds, assembled as the runtime does.
fn kernels() -> Vec<Kernel> {
    let mut all = Vec::new();
    // Each dimension count unpaged and with its arrays split into pages
    // (values into four or five: the paged accessors and bindings).
    let configs = (3..=mdas::integrand::MAX_DIMS).flat_map(|dims| {
        let cfg = mdas_config(dims);
        let page = cfg.values_bytes() / 4;
        [cfg.clone(), cfg.paged(page)]
    });
    for cfg in configs {
        let (dims, extra) = (cfg.dims, cfg.pages.extra());
        let own = || vec![gpu_params::layout_entries(extra)];
        let base = cfg.base_wgsl();
        let name = |k: &str| format!("mdas.{k}[dims={dims}, extra pages={extra}]");
        all.push(kernel(name("initial"), &initial::source(&base), &own()));
        all.push(kernel(name("error"), &error::source(&base), &own()));
        all.push(kernel(name("adapt"), &adapt::source(&base), &own()));
        all.push(kernel(name("scan"), &scan::source(&base), &own()));
        all.push(kernel(name("stats"), &stats::source(&base), &own()));
        let rec = reconstruct::source(&base);
        all.push(kernel(name("reconstruct"), &rec, &own()));
        let args = gpu_params::args_layout_entries();
        let groups = [gpu_params::layout_entries(extra), args];
        all.push(kernel(name("plan"), &plan::source(&base), &groups));
    }
    for i in integrands() {
        let base = mdas_config(i.dims).base_wgsl();
        let groups = [gpu_params::layout_entries(0), i.group1.clone()];
        let eval = evaluate::source(&base, i.wgsl.clone());
        all.push(kernel(format!("mdas.evaluate[{}]", i.name), &eval, &groups));
        let groups = [halton::layout_entries(), i.group1.clone()];
        let source = halton::source(i.wgsl.clone());
        all.push(kernel(format!("halton[{}]", i.name), &source, &groups));
        let groups = [adaptive::evaluate_layout_entries(), i.group1.clone()];
        let source = adaptive::evaluate_source(i.wgsl.clone());
        all.push(kernel(format!("adaptive[{}]", i.name), &source, &groups));
        if i.name.starts_with("many_light") {
            let groups = [many_light::cuts_layout_entries(), i.group1];
            let cuts = many_light::cuts_source(i.wgsl, 100);
            all.push(kernel(format!("{}.cuts", i.name), &cuts, &groups));
        }
    }
    let control = [adaptive::control_layout_entries()];
    all.push(kernel(
        "adaptive.control",
        &adaptive::control_source(),
        &control,
    ));
    let trace = [TraceKernel::layout_entries(), GpuScene::layout_entries()];
    all.push(kernel("trace", &TraceKernel::source(), &trace));
    let sort = [radix_sort::RadixSort::layout_entries()];
    all.push(kernel(
        "radix_sort",
        &radix_sort::RadixSort::source(),
        &sort,
    ));
    let tree = [GpuLightTree::layout_entries()];
    for file in [
        wgsl_file!("lights/bounds.wgsl"),
        wgsl_file!("lights/morton.wgsl"),
        wgsl_file!("lights/tree_build.wgsl"),
    ] {
        let name = format!("light_tree[{}]", file.0);
        all.push(kernel(name, &GpuLightTree::source(file), &tree));
    }
    let radix = [
        GpuRadixTree::layout_entries(),
        GpuRadixTree::args_layout_entries(),
    ];
    for file in [
        wgsl_file!("lights/bounds.wgsl"),
        wgsl_file!("lights/morton.wgsl"),
        wgsl_file!("lights/radix_build.wgsl"),
    ] {
        let name = format!("sst_tree[{}]", file.0);
        all.push(kernel(name, &GpuRadixTree::source(file), &radix));
    }
    let tree2 = [GpuTwoLevel::layout_entries()];
    all.push(kernel("tree2_build", &GpuTwoLevel::source(), &tree2));
    let vpl = [VplGenerator::layout_entries(), GpuScene::layout_entries()];
    all.push(kernel("vpl", &VplGenerator::source(), &vpl));
    let lgh = [GpuLgh::layout_entries()];
    all.push(kernel("lgh_build", &GpuLgh::source(), &lgh));
    let voxel = [mdas::accel::gpu_voxel::layout_entries()];
    all.push(kernel(
        "voxel_build",
        &mdas::accel::gpu_voxel::source(),
        &voxel,
    ));
    let batch = [
        BatchSampler::layout_entries(),
        GpuSamplerData::layout_entries(),
    ];
    all.push(kernel("light_batch", &BatchSampler::source(), &batch));
    all
}

/// A kernel with its parsed and validated module, or naga's error.
struct Checked {
    kernel: Kernel,
    result: Result<(Module, ModuleInfo), String>,
}

/// The kernels, parsed and validated once for all tests of this file.
fn checked() -> &'static [Checked] {
    static CHECKED: OnceLock<Vec<Checked>> = OnceLock::new();
    CHECKED.get_or_init(|| {
        kernels()
            .into_iter()
            .map(|kernel| Checked {
                result: parse_and_validate(&kernel),
                kernel,
            })
            .collect()
    })
}

/// wgpu derives naga's capabilities from the device's features; `Gpu`
/// (src/gpu/mod.rs) asks only for optional ones that every kernel must do
/// without, so the kernels are validated with none. (The capabilities wgpu
/// grants from downlevel flags concern textures and multisampling, which
/// no kernel uses.) The flags are wgpu's: all validation.
fn parse_and_validate(k: &Kernel) -> Result<(Module, ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(&k.source).map_err(|e| {
        let at = first_location(e.labels().map(|(span, _)| span), &k.source);
        diagnostic(
            k,
            "parse",
            at,
            e.emit_to_string_with_path(&k.source, &k.name),
        )
    })?;
    let mut validator = Validator::new(ValidationFlags::all(), Capabilities::empty());
    let info = validator.validate(&module).map_err(|e| {
        let at = first_location(e.spans().map(|(span, _)| *span), &k.source);
        diagnostic(
            k,
            "validation",
            at,
            e.emit_to_string_with_path(&k.source, &k.name),
        )
    })?;
    Ok((module, info))
}

/// Where the first of an error's spans that points somewhere is.
fn first_location(
    mut spans: impl Iterator<Item = naga::Span>,
    source: &str,
) -> Option<SourceLocation> {
    spans.find(|s| s.is_defined()).map(|s| s.location(source))
}

fn diagnostic(k: &Kernel, what: &str, at: Option<SourceLocation>, report: String) -> String {
    let (file, line) = at.map_or(("?", 0), |l| part_at(&k.source, l.line_number as usize));
    format!(
        "{}: WGSL {what} error at {file} line {line}:\n{report}",
        k.name
    )
}

/// The part (file) of an assembled source that holds line `line`
/// (1-based), and the line within it, from the `// ---- file ----`
/// markers `Wgsl::source` puts before every part.
fn part_at(source: &str, line: usize) -> (&str, usize) {
    let mut part = ("?", 0);
    for (n, text) in source.lines().take(line).enumerate() {
        if let Some(name) = marker(text) {
            part = (name, n + 1);
        }
    }
    (part.0, line - part.1)
}

fn marker(line: &str) -> Option<&str> {
    line.strip_prefix("// ---- ")?.strip_suffix(" ----")
}

/// Panics with every message, one per line, if there are any.
fn assert_none(what: &str, errors: BTreeSet<String>) {
    let list: Vec<_> = errors.into_iter().collect();
    assert!(list.is_empty(), "{what}:\n{}", list.join("\n"));
}

#[test]
fn every_module_parses_and_validates() {
    let errors = checked().iter().filter_map(|c| c.result.as_ref().err());
    assert_none("WGSL that naga rejects", errors.cloned().collect());
}

/// The global declared at (`group`, `binding`), if any.
fn declared(module: &Module, group: u32, binding: u32) -> Option<&naga::GlobalVariable> {
    let at = |v: &&naga::GlobalVariable| {
        v.binding
            .as_ref()
            .is_some_and(|b| b.group == group && b.binding == binding)
    };
    module.global_variables.iter().map(|(_, v)| v).find(at)
}

/// Bindings each entry point uses against the Rust layouts of its groups.
fn entry_point_errors(k: &Kernel, module: &Module, info: &ModuleInfo) -> BTreeSet<String> {
    let mut errors = BTreeSet::new();
    for (i, ep) in module.entry_points.iter().enumerate() {
        let uses = info.get_entry_point(i);
        for (h, var) in module.global_variables.iter() {
            let Some(slot) = &var.binding else { continue };
            if uses[h].is_empty() {
                continue;
            }
            let (g, b) = (slot.group, slot.binding);
            let name = var.name.as_deref().unwrap_or("?");
            let wgsl = wgsl_kind(module, var);
            let entry = k
                .groups
                .get(g as usize)
                .and_then(|es| es.iter().find(|e| e.binding == b));
            let at = format!(
                "{}: entry `{}` uses `{name}` (@group({g}) @binding({b}), {wgsl:?})",
                k.name, ep.name
            );
            match entry {
                None => errors.insert(format!("{at}, which the Rust layouts lack")),
                Some(e) if layout_kind(e) != wgsl => {
                    errors.insert(format!("{at}; the Rust layout says {:?}", layout_kind(e)))
                }
                Some(e) if !e.visibility.contains(wgpu::ShaderStages::COMPUTE) => {
                    errors.insert(format!("{at}; the Rust entry is not visible to compute"))
                }
                Some(_) => false,
            };
        }
    }
    errors
}

/// Every Rust layout entry against the module's declaration at its slot.
fn layout_errors(k: &Kernel, module: &Module) -> BTreeSet<String> {
    let mut errors = BTreeSet::new();
    for (g, entries) in k.groups.iter().enumerate() {
        let mut seen = BTreeSet::new();
        for e in entries {
            let (rust, b) = (layout_kind(e), e.binding);
            let at = format!(
                "{}: Rust layout @group({g}) @binding({b}) ({rust:?})",
                k.name
            );
            if !seen.insert(b) {
                errors.insert(format!("{at} appears twice"));
            }
            match declared(module, g as u32, b) {
                None => errors.insert(format!("{at}: the WGSL declares nothing there")),
                Some(v) if wgsl_kind(module, v) != rust => errors.insert(format!(
                    "{at}: the WGSL declares `{}` as {:?}",
                    v.name.as_deref().unwrap_or("?"),
                    wgsl_kind(module, v)
                )),
                Some(_) => false,
            };
        }
    }
    errors
}

#[test]
fn bind_group_layouts_match_the_wgsl() {
    let mut errors = BTreeSet::new();
    for c in checked() {
        if let Ok((module, info)) = &c.result {
            errors.extend(entry_point_errors(&c.kernel, module, info));
            errors.extend(layout_errors(&c.kernel, module));
        }
    }
    assert_none("bind-group layouts that disagree with the WGSL", errors);
}

/// The Rust mirror of each WGSL struct behind a binding, keyed by the file
/// that declares it and its name (two files declare a `Params`).
#[rustfmt::skip]
fn mirrors() -> BTreeMap<(&'static str, &'static str), Layout> {
    use mdas::accel::trace::TraceParams;
    use mdas::accel::gpu_voxel::VoxelBuildParams;
    use mdas::accel::voxel::{VoxelFrame, VoxelObject};
    use mdas::lights::substitute::Substitute;
    use mdas::lights::LightCone;
    use mdas::integrator::adaptive::AdaptiveGpuParams;
    use mdas::integrator::halton::HaltonParams;
    use mdas::integrator::mdas::gpu_params::GpuParams;
    use obvhs::cwbvh::node::CwBvhNode;
    let scene = "shared/scene.wgsl";
    let trace = "trace.wgsl";
    let prims = "lights/light_prim.wgsl";
    let lights = "lights/bindings.wgsl";
    BTreeMap::from([
        (("mdas/common.wgsl", "Params"), host!(GpuParams {
            seed, budget, max_iterations, max_groups, pass_offset, width, height, select_all,
            scale_factor, inv_alpha, epsilon, pixel_prior, pace, pace_floor, eval_min_groups, _pad,
        })),
        (("halton.wgsl", "HaltonParams"), host!(HaltonParams {
            width, height, dims, seed, spp, first_index, samples_per_invocation, slots,
            row_invocations, _pad,
        })),
        (("adaptive.wgsl", "AdaptiveParams"), host!(AdaptiveGpuParams {
            width, height, dims, seed, round_samples, remaining, spp_max, entries, first_slot,
            slots, samples_per_invocation, threshold, pixel_groups, _pad,
        })),
        ((scene, "SceneUniforms"), host!(SceneUniforms {
            cam_position, cam_lens_radius, cam_forward, cam_focus_distance, cam_right,
            cam_tan_half_fov_y, cam_up, cam_aspect, film_size, shutter, background,
            emitter_count, light_count, instance_count, tlas_root, triangle_count,
            visibility, voxel_directions, voxel_skip, voxel_objects,
        })),
        ((scene, "Material"), host!(GpuMaterial {
            albedo, checker_scale, emission, one_sided, albedo2, checker_uv, to_uv0, to_uv1,
        })),
        ((scene, "Emitter"), host!(GpuEmitter { prim, cdf, pmf, area })),
        ((scene, "Light"), host!(GpuLight {
            kind, _pad0, _pad1, _pad2, position, _pad3, intensity, _pad4,
        })),
        ((scene, "Instance"), host!(GpuInstance { node_root, prim_offset, key_offset, key_count })),
        ((scene, "Keyframe"), host!(GpuKeyframe { translation, time, rotation })),
        ((scene, "BvhNode"), host!(CwBvhNode {
            p, e, imask, child_base_idx, primitive_base_idx, child_meta, child_min_x, child_max_x,
            child_min_y, child_max_y, child_min_z, child_max_z,
        })),
        (("shared/voxel.wgsl", "VoxelObject"), host!(VoxelObject {
            centre, res, words, base, frames, _pad, world_min, _pad1, world_max, _pad2,
        })),
        (("shared/voxel.wgsl", "VoxelFrame"), host!(VoxelFrame { a, b, u })),
        (("voxel_build.wgsl", "VoxelObject"), host!(VoxelObject {
            centre, res, words, base, frames, _pad, world_min, _pad1, world_max, _pad2,
        })),
        (("voxel_build.wgsl", "VoxelFrame"), host!(VoxelFrame { a, b, u })),
        (("voxel_build.wgsl", "VoxelBuildParams"), host!(VoxelBuildParams {
            item_count, row_stride, direction_offset, per_instance,
        })),
        ((trace, "Ray"), host!(Ray { origin, t_max, dir, time })),
        ((trace, "HitRecord"), host!(HitRecord {
            t, prim, bary, any_hit, steps_closest, steps_any, _pad,
        })),
        ((trace, "TraceParams"), host!(TraceParams { ray_count, row_stride, normals, _pad })),
        ((prims, "LightPrim"), host!(LightPrim {
            p0, kind, p1, _pad0, p2, _pad1, emission, _pad2,
        })),
        ((prims, "TreeNode"), host!(TreeNode { min, intensity, max, id })),
        (("lights/cone.wgsl", "LightCone"), host!(LightCone {
            axis, cos_o, sin_o, cos_e, two_sided, points,
        })),
        ((lights, "AliasEntry"), host!(AliasEntry { q, alias })),
        ((lights, "LightParams"), host!(LightParams {
            count, kind, levels, leaf_count, node_count, cut_size, block_size, blocks_per_row,
            alias_count, interleave, frame, time, vpl_clamp2, sst_nu_min, sst_sigma_max2,
            cut_mixture, lgh_lo, lgh_levels, lgh_h1, lgh_inv_h1, lgh_alpha, lgh_level0, lgh_shadows,
            lgh_cells_offset, lgh_sorted_offset, lgh_triangles, lgh_soft2, light_samples,
            _pad2, _pad3,
        })),
        (("lights/sample_batch.wgsl", "SampleQuery"), host!(SampleQuery { p, u, n, block })),
        (("lights/sample_batch.wgsl", "SampleAnswer"), host!(SampleAnswer {
            light, pmf_m, pmf_e, _pad,
        })),
        (("lights/substitute.wgsl", "Substitute"), host!(Substitute {
            mean, nu, normal, cov_xy, cov_diag, cov_xz, emission, cov_yz,
        })),
        (("lights/tree_bindings.wgsl", "BuildParams"), host!(BuildParams {
            n, leaf_count, zero, src_level, levels_up, cones, _pad,
        })),
        (("lights/radix_bindings.wgsl", "RadixParams"), host!(RadixParams {
            n, zero, level, cap, max_groups_x, _pad,
        })),
        (("lights/tree2_build.wgsl", "Tree2Params"), host!(Tree2Params {
            count, first, zero, _pad,
        })),
        (("lights/lgh_light.wgsl", "GridLight"), host!(GridLight {
            e, w, p, iso, q, vertex, n, level,
        })),
        (("lights/lgh_build.wgsl", "LghBuildParams"), host!(LghBuildParams {
            lo, levels, h1, inv_h1, n, level, cells_offset, sorted_offset, groups_x, clear_len,
        })),
        (("lights/vpl.wgsl", "VplParams"), host!(VplParams {
            paths, bounces, seed, source_count, center, radius, time, _pad,
        })),
        (("gpu/radix_sort.wgsl", "Params"), host!(radix_sort::Params {
            n, shift, mask, tiles, groups_x, _pad,
        })),
    ])
}

/// The file that declares type `ty` of kernel `k`'s module.
fn declaring_file<'a>(k: &'a Kernel, module: &Module, ty: Handle<Type>) -> &'a str {
    let line = module.types.get_span(ty).location(&k.source).line_number;
    part_at(&k.source, line as usize).0
}

#[test]
fn host_structs_match_the_wgsl() {
    let mirrors = mirrors();
    let mut found = BTreeSet::new();
    let mut errors = BTreeSet::new();
    for c in checked() {
        let Ok((module, _)) = &c.result else { continue };
        for (_, var) in module.global_variables.iter() {
            let (Some(slot), AddressSpace::Uniform | AddressSpace::Storage { .. }) =
                (&var.binding, var.space)
            else {
                continue;
            };
            let mut structs = Vec::new();
            structs_in(module, var.ty, &mut structs);
            for ty in structs {
                let wgsl = wgsl_layout(module, ty);
                let file = declaring_file(&c.kernel, module, ty);
                let Some(rust) = mirrors.get(&(file, wgsl.name.as_str())) else {
                    errors.insert(format!(
                        "{}: `{}` (@group({}) @binding({})) holds struct `{}` of {file}, which has no Rust mirror in `mirrors()`",
                        c.kernel.name, var.name.as_deref().unwrap_or("?"), slot.group, slot.binding, wgsl.name
                    ));
                    continue;
                };
                found.insert((file.to_string(), wgsl.name.clone()));
                for e in struct_errors(&wgsl, rust) {
                    errors.insert(format!(
                        "WGSL `{}` ({file}) vs Rust `{}`: {e}",
                        wgsl.name, rust.name
                    ));
                }
            }
        }
    }
    for (file, name) in mirrors.keys() {
        if !found.contains(&(file.to_string(), name.to_string())) {
            errors.insert(format!(
                "mirror of `{name}` ({file}): no binding of a module that validates holds it"
            ));
        }
    }
    assert_none("host structs that disagree with the WGSL", errors);
}

/// Files under `dir` (recursively), relative to `root`, `/`-separated.
fn wgsl_files(root: &std::path::Path, dir: &std::path::Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).expect("readable wgsl/") {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            wgsl_files(root, &path, out);
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            let rel = path.strip_prefix(root).expect("under wgsl/");
            out.push(rel.to_string_lossy().replace('\\', "/"));
        }
    }
}

#[test]
fn every_wgsl_file_is_part_of_a_checked_module() {
    let parts: BTreeSet<&str> = checked()
        .iter()
        .flat_map(|c| c.kernel.source.lines().filter_map(marker))
        .collect();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("wgsl");
    let mut files = Vec::new();
    wgsl_files(&root, &root, &mut files);
    let missing = files.into_iter().filter(|f| !parts.contains(f.as_str()));
    let errors = missing.map(|f| format!("wgsl/{f} is in no module of `kernels()`"));
    assert_none("WGSL files this test does not check", errors.collect());
}
