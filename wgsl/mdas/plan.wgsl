// The iteration loop on the GPU. `plan` runs as one invocation after an
// iteration's count → scan → apply and advances the state (`state`):
//   * added = min(selected, budget − n) new samples (the trimmed last
//     iteration places exactly the rest of the budget, adapt.wgsl); they
//     are the next evaluate dispatch's range; n += added;
//   * the leaves grow by the splits, unless the iteration was trimmed
//     (a trimmed iteration does not split);
//   * the render is done when nothing was added, the budget is reached or
//     the iteration cap (params.max_iterations) was this iteration;
//     otherwise the iteration number advances;
//   * E_max is reset for the next error pass;
//   * with the paced selection (params.pace > 0), the selection's factor
//     c (state[S_INV_PACE] = 1/c, adapt.wgsl) is fed back from this
//     iteration's count: the next iteration aims to place
//     T = max(⌈pace · left⌉, pace_floor) samples, left those still to
//     place, and c ← c · T/S (S this iteration's selected leaves, at
//     least 1; the step kept in [1/64, 64], c in [1, 2^24]). The
//     probabilities min(1, c·(E/E_max)^α) keep the paper's order; c only
//     decides how many leaves an iteration takes, so that a large α runs
//     in a few large iterations rather than many small ones.
// It writes the indirect arguments of the next evaluate dispatch and of
// the next iteration's leaf dispatches (error, count, apply): zero
// workgroups once done, so iterations recorded past the end do nothing
// (scan.wgsl and `plan` itself check S_DONE). `prime` writes both from
// the state the host set before the first iteration.

// args[ARGS_LEAVES ..] and args[ARGS_EVALUATE ..]: three words each
// (generated from src/integrator/mdas/plan.rs).
@group(1) @binding(0) var<storage, read_write> args: array<u32>;

// Arguments of a 2D dispatch of `groups` workgroups: the fewest rows of at
// most max_groups each, evenly filled (as Gpu::dispatch_dims).
fn write_args(at: u32, groups: u32) {
    var x = 0u;
    var y = 1u;
    if (groups > 0u) {
        y = (groups + params.max_groups - 1u) / params.max_groups;
        x = (groups + y - 1u) / y;
    }
    args[at] = x;
    args[at + 1u] = y;
    args[at + 2u] = 1u;
}

// Workgroups of the evaluate dispatch for `count` samples, and the
// samples per invocation (state[S_EVAL_PER]): EVAL_PER_INVOCATION, or
// fewer where that would give fewer than params.eval_min_groups
// workgroups (never below one sample per invocation). Which invocation
// evaluates a sample changes no result.
fn evaluate_groups(count: u32) -> u32 {
    let per_group_max = max((count + params.eval_min_groups - 1u) / max(params.eval_min_groups, 1u), 1u);
    let per = clamp((per_group_max + WG - 1u) / WG, 1u, EVAL_PER_INVOCATION);
    state[S_EVAL_PER] = per;
    let invocations = (count + per - 1u) / per;
    return (invocations + WG - 1u) / WG;
}

@compute @workgroup_size(1)
fn prime() {
    let done = state[S_DONE] != 0u;
    write_args(ARGS_LEAVES, select(leaf_groups(), 0u, done));
    write_args(ARGS_EVALUATE, evaluate_groups(state[S_EVAL_COUNT]));
}

// The paced selection's factor for the next iteration (see above).
fn pace_next(selected: u32, left: u32) {
    let aim = max(ceil(params.pace * f32(left)), f32(params.pace_floor));
    let step = clamp(aim / f32(max(selected, 1u)), 1.0 / 64.0, 64.0);
    let c = clamp(step / bitcast<f32>(state[S_INV_PACE]), 1.0, 16777216.0);
    state[S_INV_PACE] = bitcast<u32>(1.0 / c);
}

@compute @workgroup_size(1)
fn plan() {
    if (state[S_DONE] != 0u) {
        write_args(ARGS_EVALUATE, 0u);
        return;
    }
    var n = state[S_SAMPLES];
    let selected = state[S_SELECTED];
    let left = params.budget - n;
    let added = min(selected, left);
    if (added == 0u) {
        state[S_DONE] = 1u;
        state[S_EVAL_COUNT] = 0u;
        write_args(ARGS_LEAVES, 0u);
        write_args(ARGS_EVALUATE, 0u);
        return;
    }
    state[S_EVAL_FIRST] = n;
    state[S_EVAL_COUNT] = added;
    write_args(ARGS_EVALUATE, evaluate_groups(added));
    n += added;
    state[S_SAMPLES] = n;
    if (selected <= left) {
        state[S_LEAVES] += state[S_SPLITS];
    }
    let it = iteration();
    if (n == params.budget || it >= params.max_iterations) {
        state[S_DONE] = 1u;
        write_args(ARGS_LEAVES, 0u);
    } else {
        state[S_ITERATION] = it + 1u;
        write_args(ARGS_LEAVES, leaf_groups());
        if (params.pace > 0.0) {
            pace_next(selected, params.budget - n);
        }
    }
    atomicStore(&counters[C_EMAX], 0u);
}
