//! How the arrays that grow with the budget are split across storage
//! bindings ([`Pages`]) and the WGSL that reaches them. A render's pages
//! are chosen, and checked against the adapter's limits, by
//! [`super::config::Config::for_limits`].

/// The arrays that grow with the budget, in the order of their extra
/// pages' bindings: name in WGSL and the binding of page 0.
pub const PAGED_ARRAYS: [(&str, u32); 4] =
    [("leaves", 1), ("samples", 2), ("values", 3), ("boxes", 7)];
/// Binding of the first extra page (bindings 0–8 are the base layout).
pub const FIRST_EXTRA_BINDING: u32 = 9;
/// Storage buffers of the base layout (bindings 1–8).
pub const BASE_STORAGE_BINDINGS: u32 = 8;

/// Pages of the arrays in [`PAGED_ARRAYS`]: each array's words are split
/// into pages of 2^shift words, one storage binding each, so that the
/// capacity is the device's memory rather than its largest storage
/// binding (lavapipe: 128 MiB, which held `cornell_pt` at 1024² to 8 spp).
/// Kernels reach them through `leaves_get(i)` / `leaves_set(i, v)` and the
/// like ([`Pages::wgsl`]); an array on one page compiles to plain indexing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Pages {
    /// log2 of the words per page.
    pub shift: u32,
    /// Pages of leaves, samples, values and boxes.
    pub count: [u32; 4],
}

impl Pages {
    /// Pages beyond the first of each array (bindings from
    /// [`FIRST_EXTRA_BINDING`] on).
    pub fn extra(&self) -> u32 {
        self.count.iter().map(|c| c - 1).sum()
    }

    /// Words per page.
    pub fn words(&self) -> u64 {
        1u64 << self.shift
    }

    /// The declarations of the paged arrays and their accessors
    /// (`wgsl/mdas/common.wgsl` explains the layout). An array on one page
    /// is indexed directly; on several, `i >> shift` picks the binding and
    /// `i & (2^shift − 1)` the word in it. Words are addressed one by one,
    /// so a record may straddle two pages.
    pub fn wgsl(&self) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        let mut binding = FIRST_EXTRA_BINDING;
        for (&(name, first), &count) in PAGED_ARRAYS.iter().zip(&self.count) {
            let decl = |out: &mut String, b: u32, n: &str| {
                writeln!(
                    out,
                    "@group(0) @binding({b}) var<storage, read_write> {n}: array<u32>;"
                )
                .unwrap();
            };
            decl(&mut out, first, name);
            if count == 1 {
                writeln!(out, "fn {name}_get(i: u32) -> u32 {{ return {name}[i]; }}").unwrap();
                writeln!(out, "fn {name}_set(i: u32, v: u32) {{ {name}[i] = v; }}").unwrap();
                continue;
            }
            for page in 1..count {
                decl(&mut out, binding, &format!("{name}_{page}"));
                binding += 1;
            }
            let mask = (1u64 << self.shift) - 1;
            let shift = self.shift;
            // The page an index is on picks the binding: `name` for page 0,
            // `name_p` for page p.
            let page_name = |page: u32| match page {
                0 => name.to_string(),
                p => format!("{name}_{p}"),
            };
            let cases = |out: &mut String, body: &dyn Fn(&str) -> String| {
                for page in 1..count {
                    writeln!(
                        out,
                        "        case {page}u: {{ {} }}",
                        body(&page_name(page))
                    )
                    .unwrap();
                }
                writeln!(
                    out,
                    "        default: {{ {} }}\n    }}\n}}",
                    body(&page_name(0))
                )
                .unwrap();
            };
            let head = |sig: &str| {
                format!("{sig} {{\n    let o = i & {mask}u;\n    switch (i >> {shift}u) {{")
            };
            writeln!(out, "{}", head(&format!("fn {name}_get(i: u32) -> u32"))).unwrap();
            cases(&mut out, &|a| format!("return {a}[o];"));
            writeln!(out, "{}", head(&format!("fn {name}_set(i: u32, v: u32)"))).unwrap();
            cases(&mut out, &|a| format!("{a}[o] = v;"));
        }
        out
    }
}
