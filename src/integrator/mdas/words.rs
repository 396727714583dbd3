//! The words of the counters and state buffers, one list each: their
//! indices here are generated into every kernel as `C_*` / `S_*`
//! constants ([`super::config::Config::constants`]).

/// Declares `pub const NAME: usize = index;` for each listed word and
/// `ALL`: the WGSL constant names (`prefix` + NAME) with their indices, which
/// [`config::Config::constants`] generates into every kernel. One list, so
/// a word's index exists once.
macro_rules! word_indices {
    ($prefix:literal; $($(#[$doc:meta])* $name:ident = $index:literal,)+) => {
        $($(#[$doc])* pub const $name: usize = $index;)+
        /// WGSL names and indices.
        pub const ALL: &[(&str, usize)] = &[$((concat!($prefix, stringify!($name)), $name)),+];
    };
}

/// Indices into the counters buffer: the words kernels update with atomics
/// (reductions over many invocations), `C_<NAME>` in the WGSL.
pub(crate) mod counter {
    word_indices! { "C_";
        /// E_max of the current error pass (f32 bits).
        EMAX = 0,
        /// Non-finite samples (stats.wgsl).
        NONFINITE = 1,
        /// Three words: largest finite |f| per channel (f32 bits, stats.wgsl).
        MAXABS = 2,
        /// Leaves marked collapsed.
        COLLAPSED = 5,
    }
    pub const LEN: usize = 8;
}

/// Indices into the state buffer, `S_<NAME>` in the WGSL: the iteration
/// state, written by one invocation at a time (scan.wgsl, plan.wgsl,
/// stats.wgsl) and read by every invocation with plain loads (an atomic
/// load of one word by millions of invocations serialises on a GPU).
pub(crate) mod state {
    word_indices! { "S_";
        /// Leaves selected in the current iteration (scan.wgsl).
        SELECTED = 0,
        /// Of those, the ones that split.
        SPLITS = 1,
        /// Leaves in use.
        LEAVES = 2,
        /// Samples placed (evaluated by the end of the iteration).
        SAMPLES = 3,
        /// The current iteration, from 1; the iterations run once done.
        ITERATION = 4,
        /// First sample of the pending evaluate dispatch.
        EVAL_FIRST = 5,
        /// Samples of the pending evaluate dispatch.
        EVAL_COUNT = 6,
        /// 1 once no further iteration runs (plan.wgsl).
        DONE = 7,
        /// The reconstruction's fixed-point exponent (i32 bits, stats.wgsl).
        FIXED_EXP = 8,
        /// 1/c of the paced selection (f32 bits; 1 without pacing): a
        /// leaf is selected with probability min(1, c·(E/E_max)^α)
        /// (adapt.wgsl `selected_now`, plan.wgsl).
        INV_PACE = 9,
        /// Samples each invocation of the pending evaluate dispatch takes
        /// (plan.wgsl `evaluate_groups`): at most EVAL_PER_INVOCATION,
        /// fewer when the dispatch would otherwise have fewer than
        /// `eval_min_groups` workgroups.
        EVAL_PER = 10,
    }
    pub const LEN: usize = 16;
}

/// The leaf record's header word, `slot 0 | count << COUNT_SHIFT |
/// collapsed << 31` (slot 0: the index of the leaf's first sample), and the error word's DIRTY mark: one definition,
/// generated into every kernel ([`super::config::Config::constants`]) and
/// used by the CPU oracle and the snapshot reader.
pub mod leaf {
    /// Bits of a sample index (slot 0 of the header).
    pub const INDEX_MASK: u32 = (1 << 27) - 1;
    /// The leaf's sample count sits above the slot-0 index.
    pub const COUNT_SHIFT: u32 = 27;
    /// Four bits of count: up to m + 1 = 15 after the trimmed last iteration.
    pub const COUNT_MASK: u32 = 15;
    pub const COLLAPSED_BIT: u32 = 1 << 31;
    /// The error word of a leaf whose error must be recomputed.
    pub const DIRTY: u32 = u32::MAX;

    /// The header of a leaf whose first sample is `first`, with `count`
    /// samples.
    pub const fn header(first: u32, count: u32) -> u32 {
        first | (count << COUNT_SHIFT)
    }

    /// The sample count of a header.
    pub const fn count(header: u32) -> u32 {
        (header >> COUNT_SHIFT) & COUNT_MASK
    }

    /// WGSL names and values.
    pub const ALL: &[(&str, u32)] = &[
        ("INDEX_MASK", INDEX_MASK),
        ("COUNT_SHIFT", COUNT_SHIFT),
        ("COLLAPSED_BIT", COLLAPSED_BIT),
        ("DIRTY", DIRTY),
    ];
}
