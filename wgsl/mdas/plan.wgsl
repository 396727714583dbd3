// The iteration loop on the GPU. `plan` runs as one invocation after an
// iteration's count → scan → apply and advances the state in counters:
//   * added = min(selected, budget − n) new samples (the trimmed last
//     iteration places exactly the rest of the budget, adapt.wgsl); they
//     are the next evaluate dispatch's range; n += added;
//   * the leaves grow by the splits, unless the iteration was trimmed
//     (a trimmed iteration does not split);
//   * the render is done when nothing was added, the budget is reached or
//     the iteration cap (params.max_iterations) was this iteration;
//     otherwise the iteration number advances;
//   * E_max is reset for the next error pass.
// It writes the indirect arguments of the next evaluate dispatch and of
// the next iteration's leaf dispatches (error, count, apply): zero
// workgroups once done, so iterations recorded past the end do nothing
// (scan.wgsl and `plan` itself check C_DONE). `prime` writes both from
// the state the host set before the first iteration.

@group(1) @binding(0) var<storage, read_write> args: array<u32>;

const ARGS_LEAVES: u32 = 0u;
const ARGS_EVALUATE: u32 = 3u;

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

// Workgroups of the evaluate dispatch for `count` samples.
fn evaluate_groups(count: u32) -> u32 {
    let threads = (count + EVAL_PER_INVOCATION - 1u) / EVAL_PER_INVOCATION;
    return (threads + EVAL_WG - 1u) / EVAL_WG;
}

@compute @workgroup_size(1)
fn prime() {
    let done = atomicLoad(&counters[C_DONE]) != 0u;
    write_args(ARGS_LEAVES, select(leaf_groups(), 0u, done));
    write_args(ARGS_EVALUATE, evaluate_groups(atomicLoad(&counters[C_EVAL_COUNT])));
}

@compute @workgroup_size(1)
fn plan() {
    if (atomicLoad(&counters[C_DONE]) != 0u) {
        write_args(ARGS_EVALUATE, 0u);
        return;
    }
    var n = atomicLoad(&counters[C_SAMPLES]);
    let selected = atomicLoad(&counters[C_SELECTED]);
    let left = params.budget - n;
    let added = min(selected, left);
    if (added == 0u) {
        atomicStore(&counters[C_DONE], 1u);
        atomicStore(&counters[C_EVAL_COUNT], 0u);
        write_args(ARGS_LEAVES, 0u);
        write_args(ARGS_EVALUATE, 0u);
        return;
    }
    atomicStore(&counters[C_EVAL_FIRST], n);
    atomicStore(&counters[C_EVAL_COUNT], added);
    write_args(ARGS_EVALUATE, evaluate_groups(added));
    n += added;
    atomicStore(&counters[C_SAMPLES], n);
    if (selected <= left) {
        atomicAdd(&counters[C_LEAVES], atomicLoad(&counters[C_SPLITS]));
    }
    let it = iteration();
    if (n == params.budget || it >= params.max_iterations) {
        atomicStore(&counters[C_DONE], 1u);
        write_args(ARGS_LEAVES, 0u);
    } else {
        atomicStore(&counters[C_ITERATION], it + 1u);
        write_args(ARGS_LEAVES, leaf_groups());
    }
    atomicStore(&counters[C_EMAX], 0u);
}
